/* core/atomic: the one way spraycoat writes a file (docs/architecture.md "Atomic writes", after redis rdbSave()).
 *
 * A file is written under a temporary name beside its final one, flushed, fsynced, closed, renamed over the
 * final name, and the folder is fsynced: a reader sees the old file or the whole new one, never a half-written
 * file, and a crash leaves at most a NAME.tmp that the next writer replaces.
 *
 * The temporary is created with O_CREAT | O_EXCL | O_NOFOLLOW after a stale entry of that name is unlinked
 * (unlink removes a planted symbolic link itself, never its target), so a link placed at NAME.tmp can never
 * make spraycoat write through it.  Libraries that create their files themselves (HDF5, Cairo's PNG writer
 * through a stream) use atomic_prepare for the name and create it exclusively (HDF5: H5F_ACC_EXCL, which is
 * O_EXCL), then atomic_publish. */
#ifndef SPRAYCOAT_CORE_ATOMIC_H
#define SPRAYCOAT_CORE_ATOMIC_H

#include <stdio.h>

#define ATOMIC_PATH_MAX 4096

struct atomic_file {
    char path[ATOMIC_PATH_MAX];         /* the final name */
    char tmp_path[ATOMIC_PATH_MAX + 8]; /* the name while writing; "" once published or aborted */
    FILE *stream;                       /* atomic_open's stream, NULL otherwise */
};

/* Name path.tmp and remove a stale entry of that name (a crashed writer's file or a planted link).  SC_EIO
 * when the path is too long or the stale entry cannot be removed. */
int atomic_prepare(const char *path, struct atomic_file *out);
/* atomic_prepare, then create path.tmp exclusively (O_EXCL | O_NOFOLLOW, mode 0644) and open it as out->stream
 * for writing. */
int atomic_open(const char *path, struct atomic_file *out);
/* Flush and close out->stream (when open), fsync the temporary, rename it to the final name and fsync the
 * folder.  SC_EIO naming the file and the reason (no space left, file too large, ...) on failure, with the
 * temporary removed. */
int atomic_publish(struct atomic_file *out);
/* Close out->stream (when open) and remove the temporary.  Safe to call twice and after atomic_publish. */
void atomic_abort(struct atomic_file *out);

/* The whole of `length` bytes of `data` as the file `path`, atomically. */
int atomic_write(const char *path, const void *data, size_t length);

/* fsync the folder that holds `path` (makes a rename or an unlink durable). */
int atomic_sync_folder(const char *path);

#endif
