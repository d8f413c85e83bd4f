/* HDF5 helpers: crash-safe files, typed datasets with units, attributes, checkpoints.
 *
 * Every file is written through core/atomic.h: NAME.tmp, flushed, closed, fsynced, renamed to NAME and the
 * directory fsynced, so a reader never sees a half-written file.  Datasets carry a "units" attribute.  Every
 * non-empty dataset is chunked and written with the Fletcher32 filter, which HDF5 verifies on every read (the
 * `checksum` argument of the writers is kept for their callers and no longer changes anything: outputs are checked like
 * checkpoints). */
#ifndef SPRAYCOAT_CORE_H5IO_H
#define SPRAYCOAT_CORE_H5IO_H

#include <hdf5.h>
#include <stddef.h>
#include <stdint.h>

#include "core/atomic.h"

#define H5IO_PATH_MAX ATOMIC_PATH_MAX

struct h5_out {
    hid_t file;
    struct atomic_file name; /* the final name and the temporary one (core/atomic.h) */
};

/* Silence HDF5's own error printing (errors are reported through core/error.h). Call once at start-up. */
void h5_quiet(void);

/* Create path.tmp exclusively (core/atomic.h: a stale file or a planted link of that name is removed first, and
 * H5F_ACC_EXCL never follows a link), in the HDF5 1.8 file format, whose metadata carries checksums
 * (docs/files.md "File format"; checkpoints are in the 1.10 format).  SC_EIO with a strerror-style message on
 * failure. */
int h5_create_atomic(const char *path, struct h5_out *out);
/* Flush and close, fsync, rename to the final name, fsync the folder.  SC_EIO on failure (tmp removed). */
int h5_commit(struct h5_out *out);
/* Close and remove the temporary file (after an error). */
void h5_abort(struct h5_out *out);
/* Open for reading; SC_EIO naming the file when it is missing or not HDF5. */
int h5_open_read(const char *path, hid_t *file);

int h5_create_group(hid_t parent, const char *name, hid_t *group);

/* Datasets.  dims has `rank` entries (rank 1 to 3); zero-length datasets are allowed. */
int h5_write_doubles(hid_t loc, const char *name, int rank, const hsize_t *dims, const double *data, const char *units,
                     int checksum);
int h5_write_int64s(hid_t loc, const char *name, int rank, const hsize_t *dims, const int64_t *data, const char *units,
                    int checksum);
int h5_write_bytes(hid_t loc, const char *name, size_t size, const void *data, int checksum);
/* Read a whole dataset of `count` elements (error if its size differs). */
int h5_read_doubles(hid_t loc, const char *name, double *data, size_t count);
int h5_read_int64s(hid_t loc, const char *name, int64_t *data, size_t count);
int h5_read_bytes(hid_t loc, const char *name, void *data, size_t size);
/* Number of elements (product of dims) of a dataset; SC_EIO if absent. */
int h5_dataset_size(hid_t loc, const char *name, size_t *count);
int h5_exists(hid_t loc, const char *path);
/* Group PREFIX/NNN (NNN = index, three digits at least: /search/000, /size/001) of loc: 0 when there is none (the
 * groups are numbered from 0 without gaps, so a loop ends there), else 1 with the group opened into *group
 * (negative when it cannot be opened; close it with H5Gclose otherwise). */
int h5_numbered_group(hid_t loc, const char *prefix, size_t index, hid_t *group);
/* Copy the group or dataset from_loc/from_name (attributes, members, values, chunks and filters) to
 * to_loc/to_name, making missing groups on the way; what H5Ocopy does, but a failed write (full disk, file-size
 * limit) is SC_EIO with the reason, where H5Ocopy of HDF5 1.10 crashes.  H5Oopen of "/" copies a whole file. */
int h5_copy(hid_t from_loc, const char *from_name, hid_t to_loc, const char *to_name);

/* Attributes on a file, group or dataset. */
int h5_attr_write_string(hid_t loc, const char *name, const char *value);
int h5_attr_write_double(hid_t loc, const char *name, double value);
int h5_attr_write_int64(hid_t loc, const char *name, int64_t value);
int h5_attr_read_string(hid_t loc, const char *name, char *value, size_t size);
int h5_attr_read_double(hid_t loc, const char *name, double *value);
int h5_attr_read_int64(hid_t loc, const char *name, int64_t *value);

/* Root attributes every spraycoat file carries: format, format_version, program_version, sources_id (the
 * digest of the sources that compute results, core/version.h), case_hash (hex text), stage, units = "SI", created
 * (UTC ISO 8601; a timing attribute); and the group /code with the build record as text attributes
 * (core/version.h: compiler, flags, target, library versions). */
int h5_write_root_attributes(hid_t file, const char *format, int64_t format_version, const char *stage,
                             uint64_t case_hash);
/* 1 when the open file's root attribute sources_id is this build's, else 0 (a file of other sources, or one
 * written before the attribute: its value then "none"); the stored value into stored[size]. */
int h5_same_sources(hid_t file, char *stored, size_t size);

/* Read every attribute and every dataset in the file completely (Fletcher32 and the metadata checksums are
 * verified on read).  SC_EIO if any fails, naming the dataset or attribute. */
int h5_verify_file(const char *path);

/* Checkpoints: RUN_DIR/checkpoints/STAGE_NNNNNNNN.h5 (NNNNNNNN = step), in the HDF5 1.10 file format (its chunk
 * indexes carry checksums as well). */
int h5_checkpoint_begin(const char *run_dir, const char *stage, int64_t step, struct h5_out *out);
/* Commit and delete all but the newest `keep` checkpoints of this stage (keep <= 0: keep all).  Checkpoints of
 * later steps than this one are deleted as well: they belong to a history abandoned by resuming from an older
 * (because the later ones were damaged), and must not be resumed into. */
int h5_checkpoint_commit(struct h5_out *out, const char *run_dir, const char *stage, int keep);
/* Newest valid checkpoint of `stage` into path[size] ("" if there is none).  A checkpoint that fails
 * h5_verify_file is skipped with a warning (the previous one is used).  One with another case hash, format
 * version or sources_id (another build's) is refused: SC_EINPUT with a message naming it. */
int h5_checkpoint_find_newest(const char *run_dir, const char *stage, const char *format, int64_t format_version,
                              uint64_t case_hash, char *path, size_t size);
/* h5_checkpoint_find_newest without the warnings, for a stage's validation before it runs: it refuses another case's
 * or build's checkpoint early, and the stage's resume, which reads the checkpoint, warns of the damaged ones (once). */
int h5_checkpoint_check_newest(const char *run_dir, const char *stage, const char *format, int64_t format_version,
                               uint64_t case_hash);
/* Remove every checkpoint of `stage` (after the stage finished). */
int h5_checkpoint_remove_all(const char *run_dir, const char *stage);

#endif
