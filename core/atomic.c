/* The one atomic file writer (core/atomic.h). */
#include "core/atomic.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"

int atomic_prepare(const char *path, struct atomic_file *out)
{
    out->stream = NULL;
    out->path[0] = out->tmp_path[0] = '\0';
    size_t length = strlen(path);
    if (length == 0 || length >= sizeof out->path)
        SC_FAIL(SC_EIO, "cannot write a file named by %zu characters (at most %zu): %.200s...", length,
                sizeof out->path - 1, path);
    memcpy(out->path, path, length + 1);
    snprintf(out->tmp_path, sizeof out->tmp_path, "%s.tmp", path);
    struct stat info;
    if (unlink(out->tmp_path) != 0 && errno != ENOENT) {
        int saved = errno;
        /* a read-only file system refuses the unlink of a file that is not there (EROFS): no stale file, and
         * creating the new one says what is wrong */
        if (lstat(out->tmp_path, &info) != 0 && errno == ENOENT)
            return SC_OK;
        out->tmp_path[0] = '\0';
        SC_FAIL(SC_EIO, "cannot remove the stale temporary file %s.tmp: %s", path, sc_strerror(saved));
    }
    return SC_OK;
}

int atomic_open(const char *path, struct atomic_file *out)
{
    SC_TRY(atomic_prepare(path, out));
    int fd = open(out->tmp_path, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0) {
        int saved = errno;
        out->tmp_path[0] = '\0'; /* not ours: never unlink what another process created */
        SC_FAIL(SC_EIO, "cannot create %s.tmp: %s", path, sc_strerror(saved));
    }
    out->stream = fdopen(fd, "w");
    if (!out->stream) {
        int saved = errno;
        close(fd);
        atomic_abort(out);
        SC_FAIL(SC_EIO, "cannot write %s.tmp: %s", path, sc_strerror(saved));
    }
    return SC_OK;
}

/* fsync what `path` names, opened with `flags`; 0 or an errno.  Some file systems cannot sync a folder
 * (EINVAL): the data itself is synced already. */
static int sync_path(const char *path, int flags)
{
    int fd = open(path, flags | O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return errno;
    int failed = fsync(fd) != 0 && errno != EINVAL ? errno : 0;
    close(fd);
    return failed;
}

int atomic_sync_folder(const char *path)
{
    char folder[ATOMIC_PATH_MAX];
    const char *slash = strrchr(path, '/');
    size_t length = slash ? (slash == path ? 1 : (size_t)(slash - path)) : 0;
    if (length >= sizeof folder)
        length = sizeof folder - 1;
    if (length == 0)
        snprintf(folder, sizeof folder, ".");
    else
        snprintf(folder, sizeof folder, "%.*s", (int)length, path);
    int failed = sync_path(folder, O_DIRECTORY);
    if (failed)
        SC_FAIL(SC_EIO, "cannot sync folder %s: %s", folder, sc_strerror(failed));
    return SC_OK;
}

/* Flush and close the stream; 0 or an errno. */
static int close_stream(struct atomic_file *out)
{
    if (!out->stream)
        return 0;
    /* a write that failed earlier (full disk, file-size limit) left its errno: the best reason there is */
    int earlier = ferror(out->stream) ? errno : 0;
    errno = 0;
    int failed = ferror(out->stream) || fflush(out->stream) != 0 || fsync(fileno(out->stream)) != 0;
    int saved = failed ? (errno ? errno : earlier ? earlier : EIO) : 0;
    if (fclose(out->stream) != 0 && !saved)
        saved = errno ? errno : EIO;
    out->stream = NULL;
    return saved;
}

int atomic_publish(struct atomic_file *out)
{
    if (out->tmp_path[0] == '\0')
        SC_FAIL(SC_EIO, "cannot publish %s: no temporary file is open", out->path);
    int failed = close_stream(out);
    if (!failed)
        failed = sync_path(out->tmp_path, O_NOFOLLOW);
    if (!failed && rename(out->tmp_path, out->path) != 0)
        failed = errno;
    if (failed) {
        atomic_abort(out);
        SC_FAIL(SC_EIO, "cannot write %s: %s", out->path, sc_strerror(failed));
    }
    out->tmp_path[0] = '\0';
    return atomic_sync_folder(out->path);
}

void atomic_abort(struct atomic_file *out)
{
    if (out->stream)
        fclose(out->stream);
    out->stream = NULL;
    if (out->tmp_path[0] != '\0')
        unlink(out->tmp_path);
    out->tmp_path[0] = '\0';
}

int atomic_write(const char *path, const void *data, size_t length)
{
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    if (length > 0 && fwrite(data, 1, length, out.stream) != length) {
        int saved = errno ? errno : EIO;
        atomic_abort(&out);
        SC_FAIL(SC_EIO, "cannot write %s: %s", path, sc_strerror(saved));
    }
    return atomic_publish(&out);
}
