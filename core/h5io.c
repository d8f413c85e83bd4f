/* HDF5 helpers: crash-safe files, typed datasets with units, attributes, checkpoints.
 *
 * Failures become SC_EIO through core/error.h with a message naming the file (and dataset or attribute) and the
 * reason: strerror(errno) (sc_strerror) where the operating system failed, else the innermost entry of HDF5's error
 * stack
 * ("file signature not found", "data error detected by Fletcher32 checksum"). */
#include "core/h5io.h"
#include "core/version.h"

#include "core/error.h"
#include "core/log.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* A checksummed chunk holds at most this many bytes: large enough for fast I/O, small enough to fit HDF5's
 * default 1 MiB chunk cache, and one damaged byte costs a read of one chunk, not of the whole dataset. */
#define H5IO_CHUNK_BYTES ((hsize_t)1 << 20)

/* Room for "FILE:/group/dataset" and for HDF5's error descriptions in messages. */
#define H5IO_WHAT_MAX   (2 * H5IO_PATH_MAX)
#define H5IO_REASON_MAX 512

/* ---------------------------------------------------------------------------------------------------------
 * Small utilities */

void h5_quiet(void)
{
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}

/* Close any HDF5 identifier (ignores invalid ones), so cleanup code needs no per-type bookkeeping. */
static void h5io_close(hid_t id)
{
    if (id < 0)
        return;
    switch (H5Iget_type(id)) {
    case H5I_FILE:
        H5Fclose(id);
        break;
    case H5I_GROUP:
        H5Gclose(id);
        break;
    case H5I_DATASET:
        H5Dclose(id);
        break;
    case H5I_DATASPACE:
        H5Sclose(id);
        break;
    case H5I_DATATYPE:
        H5Tclose(id);
        break;
    case H5I_ATTR:
        H5Aclose(id);
        break;
    case H5I_GENPROP_LST:
        H5Pclose(id);
        break;
    default:
        break;
    }
}

static herr_t keep_innermost_error(unsigned n, const H5E_error2_t *error, void *reason)
{
    if (n == 0) {
        /* HDF5's low-level descriptions run over several lines (time, buffer address, ...): keep the
         * first, and the system's reason when there is one */
        const char *desc = error->desc;
        const char *system_reason = strstr(desc, "error message = '");
        const char *system_errno = strstr(desc, "errno = ");
        int first_line = (int)strcspn(desc, "\n,");
        const char *time_stamp = strstr(desc, ": time = "); /* "file write failed: time = ..." */
        if (time_stamp && time_stamp - desc < first_line)
            first_line = (int)(time_stamp - desc);
        int errnum = system_errno ? atoi(system_errno + strlen("errno = ")) : 0;
        if (errnum > 0) { /* a full disk or a file-size limit must say so (not "Input/output error") */
            snprintf(reason, H5IO_REASON_MAX, "%.*s: %s", first_line, desc, sc_strerror(errnum));
        } else if (system_reason) {
            system_reason += strlen("error message = '");
            snprintf(reason, H5IO_REASON_MAX, "%.*s: %.*s", first_line, desc, (int)strcspn(system_reason, "'"),
                     system_reason);
        } else {
            snprintf(reason, H5IO_REASON_MAX, "%.*s", (int)strcspn(desc, "\n"), desc);
        }
    }
    return 0;
}

/* Why the last HDF5 call failed: the innermost (most specific) entry of the error stack.  Call it before any
 * other HDF5 function, since every API call clears the stack. */
static const char *hdf5_reason(char reason[H5IO_REASON_MAX])
{
    snprintf(reason, H5IO_REASON_MAX, "unknown HDF5 error");
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, keep_innermost_error, reason);
    return reason;
}

/* The reason for a failed file open or create: the operating system's when it set errno (cleared before the
 * call), else HDF5's. */
static const char *file_reason(int saved_errno, char reason[H5IO_REASON_MAX])
{
    if (saved_errno != 0) {
        snprintf(reason, H5IO_REASON_MAX, "%s", sc_strerror(saved_errno));
        return reason;
    }
    return hdf5_reason(reason);
}

/* "FILE:/group/name" for messages ("FILE:/group" when name is ""). */
static void describe_object(hid_t loc, const char *name, char what[H5IO_WHAT_MAX])
{
    char file[H5IO_PATH_MAX], group[H5IO_PATH_MAX];
    if (H5Fget_name(loc, file, sizeof file) < 0)
        snprintf(file, sizeof file, "?");
    if (H5Iget_name(loc, group, sizeof group) <= 0)
        snprintf(group, sizeof group, "/");
    if (name[0] == '/') /* an absolute name does not depend on loc */
        group[0] = '\0';
    size_t group_length = strlen(group);
    const char *joint = name[0] == '\0' || group_length == 0 || group[group_length - 1] == '/' ? "" : "/";
    if (snprintf(what, H5IO_WHAT_MAX, "%s:%s%s%s", file, group, joint, name) < 0)
        snprintf(what, H5IO_WHAT_MAX, "%s", name);
}

static int attr_read_any_text(hid_t attr, char **text, char reason[H5IO_REASON_MAX]);

/* After a read of loc's file failed for `reason`: when a checksum failed, " (FILE is damaged: remove it and run the
 * STAGE stage again)", STAGE the file's root attribute `stage`, so that the message says what to do; else "". */
static void damage_advice(hid_t loc, const char *reason, char advice[H5IO_WHAT_MAX])
{
    advice[0] = '\0';
    if (strstr(reason, "checksum") == NULL)
        return;
    char file[H5IO_PATH_MAX], ignored[H5IO_REASON_MAX];
    if (H5Fget_name(loc, file, sizeof file) < 0)
        snprintf(file, sizeof file, "the file");
    hid_t root = H5Oopen(loc, "/", H5P_DEFAULT);
    hid_t attr = root >= 0 && H5Aexists(root, "stage") > 0 ? H5Aopen(root, "stage", H5P_DEFAULT) : H5I_INVALID_HID;
    char *stage = NULL;
    if (attr < 0 || attr_read_any_text(attr, &stage, ignored) != 0 || strlen(stage) > 32 ||
        strspn(stage, "abcdefghijklmnopqrstuvwxyz") != strlen(stage) || stage[0] == '\0')
        snprintf(advice, H5IO_WHAT_MAX, " (%s is damaged: remove it and make it again)", file);
    else
        snprintf(advice, H5IO_WHAT_MAX, " (%s is damaged: remove it and run the %s stage again)", file, stage);
    free(stage);
    h5io_close(attr);
    h5io_close(root);
}

/* snprintf that reports truncation: paths that do not fit are an error, never silently shortened (buf is
 * emptied, so a shortened name can never be used, e.g. unlinked by h5_abort). */
static int format_path(char *buf, size_t size, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int format_path(char *buf, size_t size, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    int length = vsnprintf(buf, size, fmt, args);
    va_end(args);
    if (length >= 0 && (size_t)length < size)
        return SC_OK;
    int status = sc_error_set(SC_EIO, __FILE__, __LINE__, "path too long (%d characters, at most %zu): %.200s...",
                              length, size - 1, buf);
    buf[0] = '\0';
    return status;
}

/* ---------------------------------------------------------------------------------------------------------
 * Files */

/* File access with the "strong" close degree: H5Fclose then closes every object still open in the file, so
 * the file really is complete and closed before h5_commit syncs and renames it; objects are written in the file
 * format of HDF5 `oldest` or later (docs/files.md "File format").  From 1.8 on the superblock, object headers
 * (which hold the attributes), link and attribute heaps and v2 B-trees carry checksums, so damaged metadata reads
 * as an error, as damaged data does through Fletcher32; the earliest format's have none (a flipped bit of a
 * checkpoint's snapshot count read back as another count).  From 1.10 on a chunked dataset's index is checksummed
 * too (1.8's is a v1 B-tree without one). */
static hid_t strong_close_access(H5F_libver_t oldest)
{
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    if (fapl >= 0 && (H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG) < 0 ||
                      H5Pset_libver_bounds(fapl, oldest, H5F_LIBVER_LATEST) < 0)) {
        H5Pclose(fapl);
        return H5I_INVALID_HID;
    }
    return fapl;
}

static int create_atomic(const char *path, H5F_libver_t oldest, struct h5_out *out)
{
    out->file = H5I_INVALID_HID;
    SC_TRY(atomic_prepare(path, &out->name));
    hid_t fapl = strong_close_access(oldest);
    errno = 0;
    /* H5F_ACC_EXCL is O_EXCL: the name atomic_prepare freed is created anew, never opened through a link */
    out->file = fapl < 0 ? H5I_INVALID_HID : H5Fcreate(out->name.tmp_path, H5F_ACC_EXCL, H5P_DEFAULT, fapl);
    int saved_errno = errno;
    char reason[H5IO_REASON_MAX];
    if (out->file < 0)
        file_reason(saved_errno, reason);
    h5io_close(fapl);
    if (out->file < 0) {
        char tmp_path[sizeof out->name.tmp_path];
        snprintf(tmp_path, sizeof tmp_path, "%s", out->name.tmp_path);
        out->name.tmp_path[0] = '\0'; /* not ours when the exclusive create failed: leave it */
        SC_FAIL(SC_EIO, "cannot create %s: %s", tmp_path, reason);
    }
    return SC_OK;
}

/* Results in the 1.8 format: viewers and scripts built on HDF5 1.8 still open them. */
int h5_create_atomic(const char *path, struct h5_out *out)
{
    return create_atomic(path, H5F_LIBVER_V18, out);
}

/* Close the finished temporary file (its bytes are made durable by atomic_publish). */
static int close_tmp(struct h5_out *out)
{
    char reason[H5IO_REASON_MAX];
    if (H5Fflush(out->file, H5F_SCOPE_GLOBAL) < 0)
        SC_FAIL(SC_EIO, "cannot flush %s: %s", out->name.tmp_path, hdf5_reason(reason));
    herr_t closed = H5Fclose(out->file);
    out->file = H5I_INVALID_HID;
    if (closed < 0)
        SC_FAIL(SC_EIO, "cannot close %s: %s", out->name.tmp_path, hdf5_reason(reason));
    return SC_OK;
}

int h5_commit(struct h5_out *out)
{
    if (out->file < 0)
        SC_FAIL(SC_EIO, "cannot commit %s: the file is not open", out->name.path);
    int status = close_tmp(out);
    if (status != SC_OK) {
        h5_abort(out);
        return status;
    }
    return atomic_publish(&out->name);
}

void h5_abort(struct h5_out *out)
{
    if (out->file >= 0)
        H5Fclose(out->file);
    out->file = H5I_INVALID_HID;
    atomic_abort(&out->name);
}

int h5_open_read(const char *path, hid_t *file)
{
    *file = H5I_INVALID_HID;
    struct stat info;
    if (stat(path, &info) != 0)
        SC_FAIL(SC_EIO, "cannot open %s: %s", path, sc_strerror(errno));
    if (S_ISDIR(info.st_mode))
        SC_FAIL(SC_EIO, "cannot open %s: it is a folder, not an HDF5 file", path);
    /* a FIFO would block H5Fopen forever, a device never end */
    if (!S_ISREG(info.st_mode))
        SC_FAIL(SC_EIO,
                "cannot open %s: not a regular file (a FIFO, device or socket); an HDF5 input must be a "
                "regular file",
                path);
    errno = 0;
    *file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    if (*file < 0) {
        int saved_errno = errno;
        char reason[H5IO_REASON_MAX];
        SC_FAIL(SC_EIO, "cannot open %s: not a readable HDF5 file (%s)", path, file_reason(saved_errno, reason));
    }
    return SC_OK;
}

/* Link creation that makes missing intermediate groups, so "snapshots/000001" needs no separate step. */
static hid_t intermediate_groups_plist(void)
{
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    if (lcpl >= 0 && H5Pset_create_intermediate_group(lcpl, 1) < 0) {
        H5Pclose(lcpl);
        return H5I_INVALID_HID;
    }
    return lcpl;
}

int h5_create_group(hid_t parent, const char *name, hid_t *group)
{
    hid_t lcpl = intermediate_groups_plist();
    *group = lcpl < 0 ? H5I_INVALID_HID : H5Gcreate2(parent, name, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    char reason[H5IO_REASON_MAX];
    if (*group < 0)
        hdf5_reason(reason);
    h5io_close(lcpl);
    if (*group < 0) {
        char what[H5IO_WHAT_MAX];
        describe_object(parent, name, what);
        SC_FAIL(SC_EIO, "cannot create group %s: %s", what, reason);
    }
    return SC_OK;
}

/* ---------------------------------------------------------------------------------------------------------
 * Writing datasets */

struct dataset_spec {
    const char *name;
    int rank;
    const hsize_t *dims;
    hid_t memory_type;
    hid_t file_type;
    size_t element_size;
    const void *data;
    const char *units; /* NULL: no units attribute */
    int checksum;
};

static hsize_t element_count(int rank, const hsize_t *dims)
{
    hsize_t count = 1;
    for (int i = 0; i < rank; i++)
        count *= dims[i];
    return count;
}

/* Chunks of whole rows along dim 0, at most H5IO_CHUNK_BYTES (a row longer than that is split as well). */
static void choose_chunk(const struct dataset_spec *spec, hsize_t chunk[3])
{
    hsize_t budget = H5IO_CHUNK_BYTES / spec->element_size;
    for (int d = spec->rank - 1; d >= 1; d--) {
        chunk[d] = spec->dims[d] < budget ? spec->dims[d] : budget;
        if (chunk[d] == 0)
            chunk[d] = 1;
        budget = budget / chunk[d] ? budget / chunk[d] : 1;
    }
    chunk[0] = spec->dims[0] < budget ? spec->dims[0] : budget;
    if (chunk[0] == 0)
        chunk[0] = 1;
}

/* Chunked with Fletcher32, every dataset of every file (not only where spec->checksum asks): a flipped bit in an
 * output must stop the stage that reads it, not flow into the next file (issue 24).  An empty dataset stays
 * contiguous: HDF5 refuses chunks larger than a fixed zero-size dimension, and there are no bytes to protect. */
static hid_t dataset_creation_plist(const struct dataset_spec *spec)
{
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    if (dcpl < 0 || element_count(spec->rank, spec->dims) == 0)
        return dcpl;
    hsize_t chunk[3];
    choose_chunk(spec, chunk);
    if (H5Pset_chunk(dcpl, spec->rank, chunk) < 0 || H5Pset_fletcher32(dcpl) < 0) {
        H5Pclose(dcpl);
        return H5I_INVALID_HID;
    }
    return dcpl;
}

static int fill_dataset(hid_t dataset, const struct dataset_spec *spec, const char *what)
{
    char reason[H5IO_REASON_MAX];
    if (element_count(spec->rank, spec->dims) > 0 &&
        H5Dwrite(dataset, spec->memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, spec->data) < 0)
        SC_FAIL(SC_EIO, "cannot write dataset %s: %s", what, hdf5_reason(reason));
    if (spec->units != NULL)
        SC_TRY(h5_attr_write_string(dataset, "units", spec->units));
    return SC_OK;
}

static int create_dataset(hid_t loc, const struct dataset_spec *spec, hid_t space, hid_t dcpl, hid_t lcpl,
                          const char *what)
{
    char reason[H5IO_REASON_MAX];
    if (space < 0 || dcpl < 0 || lcpl < 0)
        SC_FAIL(SC_EIO, "cannot prepare dataset %s: %s", what, hdf5_reason(reason));
    hid_t dataset = H5Dcreate2(loc, spec->name, spec->file_type, space, lcpl, dcpl, H5P_DEFAULT);
    if (dataset < 0)
        SC_FAIL(SC_EIO, "cannot create dataset %s: %s", what, hdf5_reason(reason));
    int status = fill_dataset(dataset, spec, what);
    if (H5Dclose(dataset) < 0 && status == SC_OK)
        SC_FAIL(SC_EIO, "cannot close dataset %s: %s", what, hdf5_reason(reason));
    return status;
}

static int write_dataset(hid_t loc, const struct dataset_spec *spec)
{
    char what[H5IO_WHAT_MAX];
    describe_object(loc, spec->name, what);
    if (spec->rank < 1 || spec->rank > 3)
        SC_FAIL(SC_EIO, "cannot write dataset %s: rank %d (only 1 to 3 are supported)", what, spec->rank);
    if (spec->data == NULL && element_count(spec->rank, spec->dims) > 0)
        SC_FAIL(SC_EIO, "cannot write dataset %s: no data given", what);
    hid_t space = H5Screate_simple(spec->rank, spec->dims, NULL);
    hid_t dcpl = dataset_creation_plist(spec);
    hid_t lcpl = intermediate_groups_plist();
    int status = create_dataset(loc, spec, space, dcpl, lcpl, what);
    h5io_close(lcpl);
    h5io_close(dcpl);
    h5io_close(space);
    return status;
}

int h5_write_doubles(hid_t loc, const char *name, int rank, const hsize_t *dims, const double *data, const char *units,
                     int checksum)
{
    const struct dataset_spec spec = {name,           rank, dims,  H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE,
                                      sizeof(double), data, units, checksum};
    return write_dataset(loc, &spec);
}

int h5_write_int64s(hid_t loc, const char *name, int rank, const hsize_t *dims, const int64_t *data, const char *units,
                    int checksum)
{
    const struct dataset_spec spec = {name, rank,  dims,    H5T_NATIVE_INT64, H5T_STD_I64LE, sizeof(int64_t),
                                      data, units, checksum};
    return write_dataset(loc, &spec);
}

int h5_write_bytes(hid_t loc, const char *name, size_t size, const void *data, int checksum)
{
    const hsize_t dims[1] = {size};
    const struct dataset_spec spec = {name, 1, dims, H5T_NATIVE_UINT8, H5T_STD_U8LE, 1, data, NULL, checksum};
    return write_dataset(loc, &spec);
}

/* ---------------------------------------------------------------------------------------------------------
 * Reading datasets */

struct read_spec {
    const char *name;
    hid_t memory_type;
    H5T_class_t type_class; /* what the stored type must be */
    size_t type_size;       /* required stored size in bytes, 0 = any */
    void *data;
    size_t count;
};

static int open_dataset(hid_t loc, const char *name, hid_t *dataset, const char *what)
{
    char reason[H5IO_REASON_MAX];
    int exists = h5_exists(loc, name);
    *dataset = exists ? H5Dopen2(loc, name, H5P_DEFAULT) : H5I_INVALID_HID;
    if (*dataset < 0)
        SC_FAIL(SC_EIO, "cannot open dataset %s: %s", what, exists ? hdf5_reason(reason) : "no such dataset");
    return SC_OK;
}

static int dataset_element_count(hid_t dataset, size_t *count, const char *what)
{
    char reason[H5IO_REASON_MAX];
    hid_t space = H5Dget_space(dataset);
    hssize_t points = space < 0 ? -1 : H5Sget_simple_extent_npoints(space);
    if (points < 0)
        hdf5_reason(reason);
    h5io_close(space);
    if (points < 0)
        SC_FAIL(SC_EIO, "cannot read the shape of dataset %s: %s", what, reason);
    *count = (size_t)points;
    return SC_OK;
}

static const char *type_class_name(H5T_class_t type_class)
{
    switch (type_class) {
    case H5T_INTEGER:
        return "integer";
    case H5T_FLOAT:
        return "floating-point";
    case H5T_STRING:
        return "string";
    default:
        return "other";
    }
}

/* The stored type must convert sensibly to what the caller reads: floats to doubles, integers to integers,
 * and blobs are single bytes (HDF5 would otherwise convert silently, clipping or rounding). */
static int check_stored_type(hid_t dataset, const struct read_spec *spec, const char *what)
{
    hid_t type = H5Dget_type(dataset);
    H5T_class_t type_class = type < 0 ? H5T_NO_CLASS : H5Tget_class(type);
    size_t type_size = type < 0 ? 0 : H5Tget_size(type);
    h5io_close(type);
    if (type_class != spec->type_class || (spec->type_size != 0 && type_size != spec->type_size))
        SC_FAIL(SC_EIO, "dataset %s holds %zu-byte %s numbers, expected %s%s", what, type_size,
                type_class_name(type_class), type_class_name(spec->type_class),
                spec->type_size == 1 ? " bytes" : " numbers");
    return SC_OK;
}

static int read_open_dataset(hid_t dataset, const struct read_spec *spec, const char *what)
{
    size_t stored_count = 0;
    SC_TRY(dataset_element_count(dataset, &stored_count, what));
    if (stored_count != spec->count)
        SC_FAIL(SC_EIO, "dataset %s has %zu elements, expected %zu", what, stored_count, spec->count);
    SC_TRY(check_stored_type(dataset, spec, what));
    char reason[H5IO_REASON_MAX], advice[H5IO_WHAT_MAX];
    if (spec->count > 0 && H5Dread(dataset, spec->memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, spec->data) < 0) {
        hdf5_reason(reason);
        damage_advice(dataset, reason, advice);
        SC_FAIL(SC_EIO, "cannot read dataset %s: %s%s", what, reason, advice);
    }
    return SC_OK;
}

static int read_dataset(hid_t loc, const struct read_spec *spec)
{
    char what[H5IO_WHAT_MAX];
    describe_object(loc, spec->name, what);
    hid_t dataset = H5I_INVALID_HID;
    SC_TRY(open_dataset(loc, spec->name, &dataset, what));
    int status = read_open_dataset(dataset, spec, what);
    H5Dclose(dataset);
    return status;
}

int h5_read_doubles(hid_t loc, const char *name, double *data, size_t count)
{
    const struct read_spec spec = {name, H5T_NATIVE_DOUBLE, H5T_FLOAT, 0, data, count};
    return read_dataset(loc, &spec);
}

int h5_read_int64s(hid_t loc, const char *name, int64_t *data, size_t count)
{
    const struct read_spec spec = {name, H5T_NATIVE_INT64, H5T_INTEGER, 0, data, count};
    return read_dataset(loc, &spec);
}

int h5_read_bytes(hid_t loc, const char *name, void *data, size_t size)
{
    const struct read_spec spec = {name, H5T_NATIVE_UINT8, H5T_INTEGER, 1, data, size};
    return read_dataset(loc, &spec);
}

int h5_dataset_size(hid_t loc, const char *name, size_t *count)
{
    char what[H5IO_WHAT_MAX];
    describe_object(loc, name, what);
    hid_t dataset = H5I_INVALID_HID;
    SC_TRY(open_dataset(loc, name, &dataset, what));
    int status = dataset_element_count(dataset, count, what);
    H5Dclose(dataset);
    return status;
}

/* H5Lexists fails (rather than saying no) when an intermediate group is missing, so test each prefix of the
 * path in turn; the last test also follows the link, so a dangling soft link does not count. */
int h5_numbered_group(hid_t loc, const char *prefix, size_t index, hid_t *group)
{
    char name[H5IO_PATH_MAX];
    snprintf(name, sizeof name, "%s/%03zu", prefix, index);
    if (!h5_exists(loc, name))
        return 0;
    *group = H5Gopen2(loc, name, H5P_DEFAULT);
    return 1;
}

int h5_exists(hid_t loc, const char *path)
{
    char prefix[H5IO_PATH_MAX];
    if (strcmp(path, "/") == 0 || strcmp(path, ".") == 0)
        return 1;
    if (path[0] == '\0' || format_path(prefix, sizeof prefix, "%s", path) != SC_OK) {
        sc_error_clear();
        return 0;
    }
    for (char *slash = strchr(prefix + 1, '/'); slash != NULL; slash = strchr(slash + 1, '/')) {
        *slash = '\0';
        htri_t found = H5Lexists(loc, prefix, H5P_DEFAULT);
        *slash = '/';
        if (found <= 0)
            return 0;
    }
    return H5Lexists(loc, prefix, H5P_DEFAULT) > 0 && H5Oexists_by_name(loc, prefix, H5P_DEFAULT) > 0;
}

/* ---------------------------------------------------------------------------------------------------------
 * Attributes */

/* Write a scalar attribute, replacing one of the same name. */
static int attr_replace(hid_t loc, const char *name, hid_t file_type, hid_t memory_type, const void *value)
{
    char what[H5IO_WHAT_MAX], reason[H5IO_REASON_MAX];
    htri_t exists = H5Aexists(loc, name);
    if (exists < 0 || (exists > 0 && H5Adelete(loc, name) < 0)) {
        hdf5_reason(reason);
        describe_object(loc, "", what);
        SC_FAIL(SC_EIO, "cannot replace attribute %s on %s: %s", name, what, reason);
    }
    hid_t space = H5Screate(H5S_SCALAR);
    hid_t attr = space < 0 ? H5I_INVALID_HID : H5Acreate2(loc, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT);
    herr_t written = attr < 0 ? -1 : H5Awrite(attr, memory_type, value);
    if (written < 0)
        hdf5_reason(reason);
    h5io_close(attr);
    h5io_close(space);
    if (written < 0) {
        describe_object(loc, "", what);
        SC_FAIL(SC_EIO, "cannot write attribute %s on %s: %s", name, what, reason);
    }
    return SC_OK;
}

/* Fixed-length UTF-8 of `length` bytes, its terminating zero included: the text is stored in the attribute itself,
 * inside the checksummed object header or attribute heap.  A variable-length string's text lives in the file's
 * global heap, which no HDF5 format checksums (a flipped digit of the case hash went unnoticed). */
static hid_t text_type(size_t length)
{
    hid_t type = H5Tcopy(H5T_C_S1);
    if (type >= 0 && (H5Tset_size(type, length) < 0 || H5Tset_strpad(type, H5T_STR_NULLTERM) < 0 ||
                      H5Tset_cset(type, H5T_CSET_UTF8) < 0)) {
        H5Tclose(type);
        return H5I_INVALID_HID;
    }
    return type;
}

int h5_attr_write_string(hid_t loc, const char *name, const char *value)
{
    hid_t type = text_type(strlen(value) + 1);
    if (type < 0) {
        char reason[H5IO_REASON_MAX];
        SC_FAIL(SC_EIO, "cannot make a string type for attribute %s: %s", name, hdf5_reason(reason));
    }
    int status = attr_replace(loc, name, type, type, value);
    H5Tclose(type);
    return status;
}

int h5_attr_write_double(hid_t loc, const char *name, double value)
{
    return attr_replace(loc, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

int h5_attr_write_int64(hid_t loc, const char *name, int64_t value)
{
    return attr_replace(loc, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}

static int attr_open(hid_t loc, const char *name, hid_t *attr, char what[H5IO_WHAT_MAX])
{
    describe_object(loc, "", what);
    htri_t exists = H5Aexists(loc, name);
    *attr = exists > 0 ? H5Aopen(loc, name, H5P_DEFAULT) : H5I_INVALID_HID;
    if (*attr < 0)
        SC_FAIL(SC_EIO, "no readable attribute %s on %s", name, what);
    return SC_OK;
}

/* A scalar number attribute; its stored class must match (no silent float -> int conversion). */
static int attr_read_number(hid_t loc, const char *name, hid_t memory_type, H5T_class_t type_class, void *value)
{
    char what[H5IO_WHAT_MAX], reason[H5IO_REASON_MAX];
    hid_t attr = H5I_INVALID_HID;
    SC_TRY(attr_open(loc, name, &attr, what));
    hid_t type = H5Aget_type(attr);
    hid_t space = H5Aget_space(attr);
    int right_kind =
        type >= 0 && H5Tget_class(type) == type_class && space >= 0 && H5Sget_simple_extent_npoints(space) == 1;
    herr_t read = right_kind ? H5Aread(attr, memory_type, value) : -1;
    if (right_kind && read < 0)
        hdf5_reason(reason);
    h5io_close(space);
    h5io_close(type);
    H5Aclose(attr);
    if (!right_kind)
        SC_FAIL(SC_EIO, "attribute %s on %s is not a single %s", name, what,
                type_class == H5T_FLOAT ? "floating-point number" : "integer");
    if (read < 0)
        SC_FAIL(SC_EIO, "cannot read attribute %s on %s: %s", name, what, reason);
    return SC_OK;
}

int h5_attr_read_double(hid_t loc, const char *name, double *value)
{
    return attr_read_number(loc, name, H5T_NATIVE_DOUBLE, H5T_FLOAT, value);
}

int h5_attr_read_int64(hid_t loc, const char *name, int64_t *value)
{
    return attr_read_number(loc, name, H5T_NATIVE_INT64, H5T_INTEGER, value);
}

/* Read a string attribute (variable or fixed length) into a new malloc'd C string. */
static int attr_read_text(hid_t attr, hid_t type, char **text)
{
    *text = NULL;
    if (H5Tis_variable_str(type) > 0) {
        char *stored = NULL;
        if (H5Aread(attr, type, &stored) < 0)
            return -1;
        *text = strdup(stored ? stored : "");
        hid_t space = H5Screate(H5S_SCALAR);
        H5Dvlen_reclaim(type, space, H5P_DEFAULT, &stored);
        h5io_close(space);
        return *text ? 0 : -1;
    }
    size_t length = H5Tget_size(type);
    *text = calloc(length + 1, 1);
    if (*text == NULL || H5Aread(attr, type, *text) < 0) {
        free(*text);
        *text = NULL;
        return -1;
    }
    return 0;
}

/* Read a string attribute in the memory type HDF5 derives from the stored one: a copy with the same character
 * set (HDF5 refuses to convert between ASCII and UTF-8), so text written by any tool can be read. */
static int attr_read_any_text(hid_t attr, char **text, char reason[H5IO_REASON_MAX])
{
    hid_t file_type = H5Aget_type(attr);
    if (file_type < 0 || H5Tget_class(file_type) != H5T_STRING) {
        snprintf(reason, H5IO_REASON_MAX, "not a string");
        h5io_close(file_type);
        return -1;
    }
    hid_t type = H5Tget_native_type(file_type, H5T_DIR_DEFAULT);
    int failed = type < 0 || attr_read_text(attr, type, text) != 0;
    if (failed)
        hdf5_reason(reason);
    h5io_close(type);
    H5Tclose(file_type);
    return failed ? -1 : 0;
}

int h5_attr_read_string(hid_t loc, const char *name, char *value, size_t size)
{
    char what[H5IO_WHAT_MAX], reason[H5IO_REASON_MAX];
    hid_t attr = H5I_INVALID_HID;
    SC_TRY(attr_open(loc, name, &attr, what));
    char *text = NULL;
    int failed = attr_read_any_text(attr, &text, reason);
    H5Aclose(attr);
    if (failed)
        SC_FAIL(SC_EIO, "cannot read attribute %s on %s as text: %s", name, what, reason);
    size_t length = strlen(text);
    if (length >= size) {
        free(text);
        SC_FAIL(SC_EIO, "attribute %s on %s is too long (%zu characters, room for %zu)", name, what, length,
                size ? size - 1 : 0);
    }
    memcpy(value, text, length + 1);
    free(text);
    return SC_OK;
}

/* Current UTC time as ISO 8601, e.g. 2024-06-11T08:30:00Z. */
static void utc_now_iso8601(char text[32])
{
    time_t now = time(NULL);
    struct tm utc;
    if (gmtime_r(&now, &utc) == NULL || strftime(text, 32, "%Y-%m-%dT%H:%M:%SZ", &utc) == 0)
        snprintf(text, 32, "unknown");
}

/* The /code group: the build record (core/version.h), one text attribute per entry. */
static int write_code_group(hid_t file)
{
    hid_t group = H5I_INVALID_HID;
    if (h5_exists(file, "code")) {
        group = H5Gopen2(file, "code", H5P_DEFAULT);
        if (group < 0) {
            char reason[H5IO_REASON_MAX];
            SC_FAIL(SC_EIO, "cannot open group /code: %s", hdf5_reason(reason));
        }
    } else {
        SC_TRY(h5_create_group(file, "code", &group));
    }
    int status = SC_OK;
    for (const struct spraycoat_build_item *item = spraycoat_build_info(); item->name; item++)
        SC_CHECK(status, h5_attr_write_string(group, item->name, item->value), done);
done:
    H5Gclose(group);
    return status;
}

int h5_write_root_attributes(hid_t file, const char *format, int64_t format_version, const char *stage,
                             uint64_t case_hash)
{
    char hash_text[17], created[32];
    snprintf(hash_text, sizeof hash_text, "%016" PRIx64, case_hash);
    utc_now_iso8601(created);
    SC_TRY(h5_attr_write_string(file, "format", format));
    SC_TRY(h5_attr_write_int64(file, "format_version", format_version));
    SC_TRY(h5_attr_write_string(file, "program_version", spraycoat_version()));
    SC_TRY(h5_attr_write_string(file, "sources_id", spraycoat_sources_id()));
    SC_TRY(h5_attr_write_string(file, "case_hash", hash_text));
    SC_TRY(h5_attr_write_string(file, "stage", stage));
    SC_TRY(h5_attr_write_string(file, "units", "SI"));
    SC_TRY(h5_attr_write_string(file, "created", created));
    SC_TRY(write_code_group(file));
    return SC_OK;
}

int h5_same_sources(hid_t file, char *stored, size_t size)
{
    if (h5_attr_read_string(file, "sources_id", stored, size) != SC_OK) {
        sc_error_clear();
        snprintf(stored, size, "none");
        return 0;
    }
    return strcmp(stored, spraycoat_sources_id()) == 0;
}

/* ---------------------------------------------------------------------------------------------------------
 * Copying objects between files
 *
 * H5Ocopy would do this, but HDF5 1.10 crashes (SIGSEGV in H5T_close_real, from H5O_copy_header_map) when a write
 * fails in the middle of a copy: a full disk or a file-size limit (issue 24).  This copy reads every dataset and
 * attribute into memory and writes it with the ordinary calls, each failure reported like any other write. */

struct copy_walk {
    hid_t to;
    int status;
};

static int vlen_parts(hid_t type)
{
    return H5Tdetect_class(type, H5T_VLEN) > 0 || H5Tis_variable_str(type) > 0;
}

/* Room for `points` elements of `type`; NULL with *bytes = 0 when the size overflows or memory is short. */
static void *element_buffer(hid_t type, hssize_t points, size_t *bytes)
{
    size_t size = H5Tget_size(type);
    *bytes = 0;
    if (points < 0 || size == 0 || (size_t)points > SIZE_MAX / size)
        return NULL;
    *bytes = (size_t)points * size;
    return calloc(*bytes ? *bytes : 1, 1);
}

/* Attribute `name` of object `from` onto object `to`, with the same type and shape. */
static int copy_attribute(hid_t from, const char *name, hid_t to)
{
    char reason[H5IO_REASON_MAX] = "", what[H5IO_WHAT_MAX];
    hid_t attr = H5Aopen(from, name, H5P_DEFAULT);
    hid_t type = attr < 0 ? H5I_INVALID_HID : H5Aget_type(attr);
    hid_t space = attr < 0 ? H5I_INVALID_HID : H5Aget_space(attr);
    size_t bytes = 0;
    void *buffer = type < 0 || space < 0 ? NULL : element_buffer(type, H5Sget_simple_extent_npoints(space), &bytes);
    int read = buffer != NULL && H5Aread(attr, type, buffer) >= 0;
    if (!read && buffer != NULL)
        hdf5_reason(reason);
    else if (!read)
        snprintf(reason, sizeof reason, "impossible size");
    hid_t copy = read ? H5Acreate2(to, name, type, space, H5P_DEFAULT, H5P_DEFAULT) : H5I_INVALID_HID;
    int written = copy >= 0 && H5Awrite(copy, type, buffer) >= 0;
    if (read && !written)
        hdf5_reason(reason);
    if (copy >= 0 && H5Aclose(copy) < 0 && written) {
        written = 0;
        hdf5_reason(reason);
    }
    if (read && vlen_parts(type))
        H5Dvlen_reclaim(type, space, H5P_DEFAULT, buffer);
    free(buffer);
    h5io_close(space);
    h5io_close(type);
    h5io_close(attr);
    if (buffer == NULL && bytes > 0) /* a size element_buffer could compute, but not allocate */
        SC_FAIL_OOM(bytes, "a copied attribute");
    if (!written) {
        describe_object(to, "", what);
        SC_FAIL(SC_EIO, "cannot copy attribute %s to %s: %s", name, what, reason);
    }
    return SC_OK;
}

static herr_t copy_attribute_cb(hid_t from, const char *name, const H5A_info_t *info, void *data)
{
    (void)info;
    struct copy_walk *walk = data;
    walk->status = copy_attribute(from, name, walk->to);
    return walk->status == SC_OK ? 0 : -1;
}

static int copy_attributes(hid_t from, hid_t to)
{
    struct copy_walk walk = {to, SC_OK};
    herr_t done = H5Aiterate2(from, H5_INDEX_NAME, H5_ITER_INC, NULL, copy_attribute_cb, &walk);
    if (walk.status != SC_OK)
        return walk.status;
    if (done < 0) {
        char reason[H5IO_REASON_MAX], what[H5IO_WHAT_MAX];
        hdf5_reason(reason);
        describe_object(from, "", what);
        SC_FAIL(SC_EIO, "cannot list the attributes of %s: %s", what, reason);
    }
    return SC_OK;
}

/* Dataset `from` (open) as `name` in `to_loc`: its type, shape, creation properties (chunks, Fletcher32),
 * values and attributes. */
static int copy_dataset(hid_t from, hid_t to_loc, const char *name)
{
    char reason[H5IO_REASON_MAX] = "", what[H5IO_WHAT_MAX];
    hid_t type = H5Dget_type(from), space = H5Dget_space(from), dcpl = H5Dget_create_plist(from);
    hssize_t points = space < 0 ? -1 : H5Sget_simple_extent_npoints(space);
    size_t bytes = 0;
    void *buffer = type < 0 || dcpl < 0 ? NULL : element_buffer(type, points, &bytes);
    int read = buffer != NULL && (points == 0 || H5Dread(from, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer) >= 0);
    if (!read && buffer != NULL)
        hdf5_reason(reason);
    else if (!read)
        snprintf(reason, sizeof reason, "impossible size");
    hid_t lcpl = read ? intermediate_groups_plist() : H5I_INVALID_HID;
    hid_t copy = lcpl < 0 ? H5I_INVALID_HID : H5Dcreate2(to_loc, name, type, space, lcpl, dcpl, H5P_DEFAULT);
    int written = copy >= 0 && (points == 0 || H5Dwrite(copy, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer) >= 0);
    if (read && !written)
        hdf5_reason(reason);
    int status = SC_OK;
    if (written)
        status = copy_attributes(from, copy);
    if (copy >= 0 && H5Dclose(copy) < 0 && written && status == SC_OK) {
        written = 0;
        hdf5_reason(reason);
    }
    if (read && vlen_parts(type))
        H5Dvlen_reclaim(type, space, H5P_DEFAULT, buffer);
    free(buffer);
    h5io_close(lcpl);
    h5io_close(dcpl);
    h5io_close(space);
    h5io_close(type);
    if (status != SC_OK)
        return status;
    if (buffer == NULL && bytes > 0) /* a size element_buffer could compute, but not allocate */
        SC_FAIL_OOM(bytes, "a copied dataset");
    if (!read) { /* the source's fault: name it, not the destination (a temporary file deleted on the way out) */
        char advice[H5IO_WHAT_MAX];
        describe_object(from, "", what);
        damage_advice(from, reason, advice);
        SC_FAIL(SC_EIO, "cannot read dataset %s to copy it: %s%s", what, reason, advice);
    }
    if (!written) {
        describe_object(to_loc, name, what);
        SC_FAIL(SC_EIO, "cannot copy dataset %s: %s", what, reason);
    }
    return SC_OK;
}

static int copy_object(hid_t from, hid_t to_loc, const char *name);

static herr_t copy_member_cb(hid_t group, const char *name, const H5L_info_t *info, void *data)
{
    (void)info;
    struct copy_walk *walk = data;
    hid_t member = H5Oopen(group, name, H5P_DEFAULT);
    if (member < 0) {
        char reason[H5IO_REASON_MAX], what[H5IO_WHAT_MAX];
        hdf5_reason(reason);
        describe_object(group, name, what);
        walk->status = sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot open %s to copy it: %s", what, reason);
        return -1;
    }
    walk->status = copy_object(member, walk->to, name);
    H5Oclose(member);
    return walk->status == SC_OK ? 0 : -1;
}

/* Group `from` (open) as `name` in `to_loc`: its attributes and, in name order, its members. */
static int copy_group(hid_t from, hid_t to_loc, const char *name)
{
    hid_t group;
    SC_TRY(h5_create_group(to_loc, name, &group));
    struct copy_walk walk = {group, SC_OK};
    int status;
    SC_CHECK(status, copy_attributes(from, group), done);
    herr_t listed = H5Literate(from, H5_INDEX_NAME, H5_ITER_INC, NULL, copy_member_cb, &walk);
    SC_CHECK(status, walk.status, done);
    if (listed < 0) {
        char reason[H5IO_REASON_MAX], what[H5IO_WHAT_MAX];
        hdf5_reason(reason);
        describe_object(from, "", what);
        SC_FAIL_AT(status, done, SC_EIO, "cannot list the members of %s: %s", what, reason);
    }
done:
    /* a failure to close is reported when nothing failed before it */
    if (H5Gclose(group) < 0 && status == SC_OK) {
        char reason[H5IO_REASON_MAX], what[H5IO_WHAT_MAX];
        hdf5_reason(reason);
        describe_object(to_loc, name, what);
        status = sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot close group %s: %s", what, reason);
    }
    return status;
}

static int copy_object(hid_t from, hid_t to_loc, const char *name)
{
    H5I_type_t kind = H5Iget_type(from);
    if (kind == H5I_GROUP || kind == H5I_FILE)
        return copy_group(from, to_loc, name);
    if (kind == H5I_DATASET)
        return copy_dataset(from, to_loc, name);
    char what[H5IO_WHAT_MAX];
    describe_object(to_loc, name, what);
    SC_FAIL(SC_EIO, "cannot copy to %s: the source is neither a group nor a dataset", what);
}

int h5_copy(hid_t from_loc, const char *from_name, hid_t to_loc, const char *to_name)
{
    hid_t from = H5Oopen(from_loc, from_name, H5P_DEFAULT);
    if (from < 0) {
        char reason[H5IO_REASON_MAX], what[H5IO_WHAT_MAX];
        hdf5_reason(reason);
        describe_object(from_loc, from_name, what);
        SC_FAIL(SC_EIO, "cannot open %s to copy it: %s", what, reason);
    }
    int status = copy_object(from, to_loc, to_name);
    H5Oclose(from);
    return status;
}

/* ---------------------------------------------------------------------------------------------------------
 * Verification */

struct verify_walk {
    int failed;
    char object[H5IO_PATH_MAX + 300]; /* "dataset /a/b" or "attribute NAME of /a/b" */
    char reason[H5IO_REASON_MAX];
};

/* Read `bytes` of the dataset or attribute into a scratch buffer and drop them (variable-length parts freed too). */
static int read_into_scratch(hid_t object, int is_attribute, hid_t type, hid_t space, size_t bytes,
                             char reason[H5IO_REASON_MAX])
{
    if (bytes == 0)
        return 0;
    void *buffer = malloc(bytes);
    if (buffer == NULL) /* not "damaged": that would fall back to an older checkpoint and delete this one */
        SC_DIE_OOM(bytes, "checking a dataset's checksums");
    herr_t read =
        is_attribute ? H5Aread(object, type, buffer) : H5Dread(object, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
    int failed = read < 0;
    if (failed)
        hdf5_reason(reason);
    else /* a no-op for fixed-size types */
        H5Dvlen_reclaim(type, space, H5P_DEFAULT, buffer);
    free(buffer);
    return failed ? -1 : 0;
}

/* Size the dataset or attribute in its native memory type and read it all: HDF5 then checks a dataset's every
 * chunk's Fletcher32 and the checksums of the metadata it passes.  Each failure records HDF5's reason at once,
 * before the next call clears the error stack. */
static int read_fully(hid_t object, int is_attribute, hid_t file_type, char reason[H5IO_REASON_MAX])
{
    hid_t type = H5Tget_native_type(file_type, H5T_DIR_ASCEND);
    if (type < 0) {
        hdf5_reason(reason);
        return -1;
    }
    hid_t space = is_attribute ? H5Aget_space(object) : H5Dget_space(object);
    hssize_t points = space < 0 ? -1 : H5Sget_simple_extent_npoints(space);
    size_t type_size = H5Tget_size(type);
    int status = -1;
    if (points < 0)
        hdf5_reason(reason);
    else if (type_size == 0 || (size_t)points > SIZE_MAX / type_size)
        snprintf(reason, H5IO_REASON_MAX, "impossible size (%lld elements of %zu bytes)", (long long)points, type_size);
    else
        status = read_into_scratch(object, is_attribute, type, space, (size_t)points * type_size, reason);
    h5io_close(space);
    H5Tclose(type);
    return status;
}

static int read_whole_dataset(hid_t file, const char *name, char reason[H5IO_REASON_MAX])
{
    hid_t dataset = H5Dopen2(file, name, H5P_DEFAULT);
    hid_t file_type = dataset < 0 ? H5I_INVALID_HID : H5Dget_type(dataset);
    int status = -1;
    if (file_type < 0)
        hdf5_reason(reason);
    else
        status = read_fully(dataset, 0, file_type, reason);
    h5io_close(file_type);
    h5io_close(dataset);
    return status;
}

static herr_t verify_attribute(hid_t object, const char *name, const H5A_info_t *info, void *data)
{
    (void)info;
    struct verify_walk *walk = data;
    hid_t attr = H5Aopen(object, name, H5P_DEFAULT);
    hid_t file_type = attr < 0 ? H5I_INVALID_HID : H5Aget_type(attr);
    int status = -1;
    if (file_type < 0)
        hdf5_reason(walk->reason);
    else
        status = read_fully(attr, 1, file_type, walk->reason);
    h5io_close(file_type);
    h5io_close(attr);
    if (status == 0)
        return 0;
    walk->failed = 1;
    snprintf(walk->object, sizeof walk->object, "attribute %.255s", name); /* the object's name follows */
    return -1;
}

/* Every object's attributes (stored in its header or an attribute heap), and a dataset's data. */
static herr_t verify_object(hid_t file, const char *name, const H5O_info_t *info, void *data)
{
    struct verify_walk *walk = data;
    const char *shown = strcmp(name, ".") == 0 ? "" : name; /* the root group */
    hid_t object = H5Oopen(file, name, H5P_DEFAULT);
    if (object < 0) {
        hdf5_reason(walk->reason);
        walk->failed = 1;
        snprintf(walk->object, sizeof walk->object, "object /%s", shown);
        return -1;
    }
    hsize_t next = 0;
    herr_t attributes = H5Aiterate2(object, H5_INDEX_NAME, H5_ITER_NATIVE, &next, verify_attribute, walk);
    H5Oclose(object);
    if (attributes < 0) {
        if (!walk->failed) {
            hdf5_reason(walk->reason);
            walk->failed = 1;
            snprintf(walk->object, sizeof walk->object, "the attributes");
        }
        size_t used = strlen(walk->object);
        snprintf(walk->object + used, sizeof walk->object - used, " of /%s", shown);
        return -1;
    }
    if (info->type != H5O_TYPE_DATASET)
        return 0;
    if (read_whole_dataset(file, name, walk->reason) == 0)
        return 0;
    walk->failed = 1;
    snprintf(walk->object, sizeof walk->object, "dataset /%s", name);
    return -1;
}

int h5_verify_file(const char *path)
{
    hid_t file = H5I_INVALID_HID;
    SC_TRY(h5_open_read(path, &file));
    struct verify_walk walk = {0, "", ""};
    herr_t visited = H5Ovisit(file, H5_INDEX_NAME, H5_ITER_NATIVE, verify_object, &walk);
    char reason[H5IO_REASON_MAX];
    if (visited < 0 && !walk.failed)
        hdf5_reason(reason);
    H5Fclose(file);
    if (walk.failed)
        SC_FAIL(SC_EIO, "%s in %s cannot be read: %s", walk.object, path, walk.reason);
    if (visited < 0)
        SC_FAIL(SC_EIO, "cannot walk the objects of %s: %s", path, reason);
    return SC_OK;
}

/* ---------------------------------------------------------------------------------------------------------
 * Checkpoints: RUN_DIR/checkpoints/STAGE_NNNNNNNN.h5 */

#define CHECKPOINT_SUFFIX     ".h5"
#define CHECKPOINT_TMP_SUFFIX ".h5.tmp"

struct checkpoint_entry {
    int64_t step;
    char name[256];
};

struct checkpoint_list {
    struct checkpoint_entry *items;
    size_t count;
    size_t capacity;
};

static int checkpoint_dir(const char *run_dir, char dir[H5IO_PATH_MAX])
{
    return format_path(dir, H5IO_PATH_MAX, "%s/checkpoints", run_dir);
}

static int check_stage_name(const char *stage)
{
    if (stage == NULL || stage[0] == '\0' || strchr(stage, '/') != NULL)
        SC_FAIL(SC_EINPUT, "invalid checkpoint stage name \"%s\"", stage ? stage : "(null)");
    return SC_OK;
}

/* Step of a file named STAGE_<digits><suffix>, or -1 when the name is not one (another stage, a stray file). */
static int64_t checkpoint_step_of(const char *file_name, const char *stage, const char *suffix)
{
    size_t stage_length = strlen(stage);
    if (strncmp(file_name, stage, stage_length) != 0 || file_name[stage_length] != '_')
        return -1;
    const char *digits = file_name + stage_length + 1;
    size_t digit_count = strspn(digits, "0123456789");
    if (digit_count == 0 || digit_count > 18 || strcmp(digits + digit_count, suffix) != 0)
        return -1;
    return (int64_t)strtoll(digits, NULL, 10);
}

static int checkpoint_list_add(struct checkpoint_list *list, int64_t step, const char *name)
{
    if (list->count == list->capacity) {
        size_t capacity = list->capacity ? 2 * list->capacity : 16;
        struct checkpoint_entry *items = realloc(list->items, capacity * sizeof *items);
        if (items == NULL)
            SC_FAIL_OOM(capacity * sizeof *items, "the list of checkpoints");
        list->items = items;
        list->capacity = capacity;
    }
    list->items[list->count].step = step;
    snprintf(list->items[list->count].name, sizeof list->items[list->count].name, "%s", name);
    list->count++;
    return SC_OK;
}

static int newest_first(const void *a, const void *b)
{
    int64_t step_a = ((const struct checkpoint_entry *)a)->step;
    int64_t step_b = ((const struct checkpoint_entry *)b)->step;
    return (step_a < step_b) - (step_a > step_b);
}

static int read_checkpoint_dir(DIR *folder, const char *dir, const char *stage, const char *suffix,
                               struct checkpoint_list *list)
{
    for (;;) {
        errno = 0;
        struct dirent *entry = readdir(folder);
        if (entry == NULL) {
            if (errno != 0)
                SC_FAIL(SC_EIO, "cannot list %s: %s", dir, sc_strerror(errno));
            return SC_OK;
        }
        int64_t step = checkpoint_step_of(entry->d_name, stage, suffix);
        if (step >= 0)
            SC_TRY(checkpoint_list_add(list, step, entry->d_name));
    }
}

/* This stage's files with `suffix` in RUN_DIR/checkpoints, newest first; empty when the folder is missing. */
static int list_checkpoints(const char *run_dir, const char *stage, const char *suffix, struct checkpoint_list *list)
{
    *list = (struct checkpoint_list){NULL, 0, 0};
    char dir[H5IO_PATH_MAX];
    SC_TRY(checkpoint_dir(run_dir, dir));
    DIR *folder = opendir(dir);
    if (folder == NULL) {
        if (errno == ENOENT)
            return SC_OK;
        SC_FAIL(SC_EIO, "cannot list %s: %s", dir, sc_strerror(errno));
    }
    int status = read_checkpoint_dir(folder, dir, stage, suffix, list);
    closedir(folder);
    if (status != SC_OK) {
        free(list->items);
        *list = (struct checkpoint_list){NULL, 0, 0};
        return status;
    }
    if (list->count > 1)
        qsort(list->items, list->count, sizeof *list->items, newest_first);
    return SC_OK;
}

static int checkpoint_entry_path(const char *run_dir, const struct checkpoint_entry *entry, char path[H5IO_PATH_MAX])
{
    return format_path(path, H5IO_PATH_MAX, "%s/checkpoints/%s", run_dir, entry->name);
}

static int remove_listed(const char *run_dir, const struct checkpoint_list *list)
{
    for (size_t i = 0; i < list->count; i++) {
        char path[H5IO_PATH_MAX];
        SC_TRY(checkpoint_entry_path(run_dir, &list->items[i], path));
        if (unlink(path) != 0 && errno != ENOENT)
            SC_FAIL(SC_EIO, "cannot remove %s: %s", path, sc_strerror(errno));
    }
    return SC_OK;
}

/* Delete every file of this stage with `suffix`. */
static int remove_stage_files(const char *run_dir, const char *stage, const char *suffix)
{
    struct checkpoint_list list;
    SC_TRY(list_checkpoints(run_dir, stage, suffix, &list));
    int status = remove_listed(run_dir, &list);
    free(list.items);
    return status;
}

int h5_checkpoint_begin(const char *run_dir, const char *stage, int64_t step, struct h5_out *out)
{
    out->file = H5I_INVALID_HID;
    out->name.path[0] = out->name.tmp_path[0] = '\0';
    SC_TRY(check_stage_name(stage));
    if (step < 0)
        SC_FAIL(SC_EINPUT, "invalid checkpoint step %" PRId64 " for stage %s", step, stage);
    char dir[H5IO_PATH_MAX], path[H5IO_PATH_MAX];
    SC_TRY(checkpoint_dir(run_dir, dir));
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        SC_FAIL(SC_EIO, "cannot create folder %s: %s", dir, sc_strerror(errno));
    /* A crash during an earlier write leaves STAGE_*.h5.tmp behind; nothing can use it. */
    SC_TRY(remove_stage_files(run_dir, stage, CHECKPOINT_TMP_SUFFIX));
    SC_TRY(format_path(path, sizeof path, "%s/%s_%08lld" CHECKPOINT_SUFFIX, dir, stage, (long long)step));
    /* only spraycoat reads a checkpoint: the 1.10 format, checksummed throughout */
    SC_TRY(create_atomic(path, H5F_LIBVER_V110, out));
    return SC_OK;
}

/* Keep the newest `keep` checkpoints up to the committed step.  Those of later steps are deleted too: they
 * belong to a history this run abandoned when it resumed from an older checkpoint (the later ones were damaged),
 * and keeping them would make the next resume jump back into that history.  A failed delete only warns: the new
 * checkpoint is safe, and stopping a long run for an old file would do more harm. */
static void prune_checkpoints(const char *run_dir, const struct checkpoint_list *list, int64_t committed_step, int keep)
{
    int kept = 0;
    for (size_t i = 0; i < list->count; i++) {
        const struct checkpoint_entry *entry = &list->items[i];
        if (entry->step <= committed_step && (keep <= 0 || kept < keep)) {
            kept++;
            continue;
        }
        char path[H5IO_PATH_MAX];
        if (checkpoint_entry_path(run_dir, entry, path) != SC_OK) {
            log_warn("cannot remove old checkpoint %s: %s", entry->name, sc_error_message());
            sc_error_clear();
        } else if (unlink(path) != 0 && errno != ENOENT) {
            log_warn("cannot remove old checkpoint %s: %s", path, sc_strerror(errno));
        }
    }
}

int h5_checkpoint_commit(struct h5_out *out, const char *run_dir, const char *stage, int keep)
{
    SC_TRY(check_stage_name(stage));
    const char *slash = strrchr(out->name.path, '/');
    int64_t committed_step = checkpoint_step_of(slash ? slash + 1 : out->name.path, stage, CHECKPOINT_SUFFIX);
    if (committed_step < 0) {
        h5_abort(out);
        SC_FAIL(SC_EINPUT, "%s is not a checkpoint of stage %s", out->name.path, stage);
    }
    SC_TRY(h5_commit(out));
    struct checkpoint_list list;
    SC_TRY(list_checkpoints(run_dir, stage, CHECKPOINT_SUFFIX, &list));
    prune_checkpoints(run_dir, &list, committed_step, keep);
    free(list.items);
    return SC_OK;
}

struct checkpoint_identity {
    const char *format;
    int64_t format_version;
    uint64_t case_hash;
};

static int read_checkpoint_identity(hid_t file, char format[256], int64_t *format_version, char hash[64])
{
    SC_TRY(h5_attr_read_string(file, "format", format, 256));
    SC_TRY(h5_attr_read_int64(file, "format_version", format_version));
    SC_TRY(h5_attr_read_string(file, "case_hash", hash, 64));
    return SC_OK;
}

/* The last checkpoint file this process verified whole.  A resume looks for the newest checkpoint twice (the
 * stage's validation, before anything in the run directory is written, then the resume itself), and the second
 * look read every dataset of a file it had just verified again: the same file (device, inode, size and
 * modification time unchanged) is not verified twice.  Its identity is still read each time. */
static struct {
    int known;
    dev_t device;
    ino_t inode;
    off_t size;
    struct timespec modified;
} verified_file;

static int is_verified_file(const struct stat *st)
{
    return verified_file.known && st->st_dev == verified_file.device && st->st_ino == verified_file.inode &&
           st->st_size == verified_file.size && st->st_mtim.tv_sec == verified_file.modified.tv_sec &&
           st->st_mtim.tv_nsec == verified_file.modified.tv_nsec;
}

static int verify_checkpoint_file(const char *path)
{
    struct stat st;
    int have_stat = stat(path, &st) == 0;
    if (have_stat && is_verified_file(&st))
        return SC_OK;
    verified_file.known = 0;
    SC_TRY(h5_verify_file(path));
    if (have_stat) {
        verified_file.device = st.st_dev, verified_file.inode = st.st_ino, verified_file.size = st.st_size;
        verified_file.modified = st.st_mtim;
        verified_file.known = 1;
    }
    return SC_OK;
}

/* SC_OK if the checkpoint is readable and ours; SC_EIO if damaged (or lacking root attributes), SC_EINPUT if
 * it belongs to another case or format. */
static int inspect_checkpoint(const char *path, const char *run_dir, const struct checkpoint_identity *want)
{
    SC_TRY(verify_checkpoint_file(path));
    hid_t file = H5I_INVALID_HID;
    SC_TRY(h5_open_read(path, &file));
    char format[256], hash[64], want_hash[17];
    int64_t format_version;
    int status = read_checkpoint_identity(file, format, &format_version, hash);
    char sources[64], program[256] = "unknown";
    int same_sources = h5_same_sources(file, sources, sizeof sources);
    if (h5_attr_read_string(file, "program_version", program, sizeof program) != SC_OK)
        sc_error_clear();
    H5Fclose(file);
    SC_TRY(status);
    snprintf(want_hash, sizeof want_hash, "%016" PRIx64, want->case_hash);
    if (strcmp(format, want->format) != 0 || format_version != want->format_version)
        SC_FAIL(SC_EINPUT,
                "checkpoint %s has format %s version %" PRId64 ", this program writes %s version %" PRId64
                ", refusing to resume; remove %s/checkpoints or use another run directory",
                path, format, format_version, want->format, want->format_version, run_dir);
    if (strcmp(hash, want_hash) != 0)
        SC_FAIL(SC_EINPUT,
                "checkpoint %s belongs to another case (hash %s, this case %s), refusing to resume; remove "
                "%s/checkpoints or use another run directory",
                path, hash, want_hash, run_dir);
    /* a run continued by other code would mix two programs' results in one output that names only the last */
    if (!same_sources)
        SC_FAIL(SC_EINPUT,
                "checkpoint %s was written by another build of spraycoat (sources %s, git %s; this build: sources "
                "%s, git %s), refusing to resume: the run would mix the results of two programs; resume it with the "
                "build that wrote it, or remove %s/checkpoints to run the stage again",
                path, sources, program, spraycoat_sources_id(), spraycoat_version(), run_dir);
    return SC_OK;
}

/* Walk the list newest first; the first good checkpoint wins, damaged ones are skipped (with a warning when `warn`). */
static int choose_checkpoint(const char *run_dir, const struct checkpoint_list *list,
                             const struct checkpoint_identity *want, int warn, char *path, size_t size)
{
    for (size_t i = 0; i < list->count; i++) {
        char candidate[H5IO_PATH_MAX];
        SC_TRY(checkpoint_entry_path(run_dir, &list->items[i], candidate));
        /* a checkpoint the system will not let us read is not damaged: falling back would later delete it */
        if (access(candidate, R_OK) != 0)
            SC_FAIL(SC_EIO, "cannot read checkpoint %s: %s (not falling back to an older one)", candidate,
                    sc_strerror(errno));
        int status = inspect_checkpoint(candidate, run_dir, want);
        if (status == SC_OK)
            return format_path(path, size, "%s", candidate);
        if (status != SC_EIO)
            return status;
        if (warn)
            log_warn("checkpoint %s is damaged (%s); %s", candidate, sc_error_message(),
                     i + 1 < list->count ? "falling back to the previous one" : "no older checkpoint is left");
        sc_error_clear();
    }
    return SC_OK;
}

static int find_newest(const char *run_dir, const char *stage, const char *format, int64_t format_version,
                       uint64_t case_hash, int warn, char *path, size_t size)
{
    if (size > 0)
        path[0] = '\0';
    SC_TRY(check_stage_name(stage));
    struct checkpoint_list list;
    SC_TRY(list_checkpoints(run_dir, stage, CHECKPOINT_SUFFIX, &list));
    const struct checkpoint_identity want = {format, format_version, case_hash};
    int status = choose_checkpoint(run_dir, &list, &want, warn, path, size);
    free(list.items);
    return status;
}

int h5_checkpoint_find_newest(const char *run_dir, const char *stage, const char *format, int64_t format_version,
                              uint64_t case_hash, char *path, size_t size)
{
    return find_newest(run_dir, stage, format, format_version, case_hash, 1, path, size);
}

int h5_checkpoint_check_newest(const char *run_dir, const char *stage, const char *format, int64_t format_version,
                               uint64_t case_hash)
{
    char path[H5IO_PATH_MAX];
    return find_newest(run_dir, stage, format, format_version, case_hash, 0, path, sizeof path);
}

int h5_checkpoint_remove_all(const char *run_dir, const char *stage)
{
    SC_TRY(check_stage_name(stage));
    SC_TRY(remove_stage_files(run_dir, stage, CHECKPOINT_SUFFIX));
    SC_TRY(remove_stage_files(run_dir, stage, CHECKPOINT_TMP_SUFFIX));
    return SC_OK;
}
