/* Reading the run's HDF5 files: whole datasets, with messages that name the file and the dataset. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "render/render_impl.h"

int render_open(const char *path, hid_t *file)
{
    if (h5_open_read(path, file) != SC_OK)
        SC_FAIL(SC_EIO, "render: %s is not a readable HDF5 file (damaged or truncated?)", path);
    return SC_OK;
}

/* Integer datasets (outcome, state, bonded) are read as int64 into `integers` (count + 1 of them) and converted. */
static int read_values(hid_t loc, const char *name, int64_t *integers, double *values, size_t count)
{
    if (!integers) {
        SC_TRY(h5_read_doubles(loc, name, values, count));
        return SC_OK;
    }
    SC_TRY(h5_read_int64s(loc, name, integers, count));
    for (size_t i = 0; i < count; i++)
        values[i] = (double)integers[i];
    return SC_OK;
}

int render_read_array(hid_t loc, const char *file, const char *name, struct render_array *out)
{
    memset(out, 0, sizeof *out);
    if (!h5_exists(loc, name))
        SC_FAIL(SC_EIO, "render: %s has no dataset %s (not a complete spraycoat output?)", file, name);
    hid_t set = H5Dopen2(loc, name, H5P_DEFAULT);
    hid_t space = set >= 0 ? H5Dget_space(set) : H5I_INVALID_HID;
    int rank = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
    hsize_t dims[3] = {0, 0, 0};
    hid_t type = set >= 0 ? H5Dget_type(set) : H5I_INVALID_HID;
    int integer = type >= 0 && H5Tget_class(type) == H5T_INTEGER;
    if (type >= 0)
        H5Tclose(type);
    if (rank >= 1 && rank <= 3)
        H5Sget_simple_extent_dims(space, dims, NULL);
    if (space >= 0)
        H5Sclose(space);
    if (set >= 0)
        H5Dclose(set);
    if (rank < 1 || rank > 3)
        SC_FAIL(SC_EIO, "render: %s: dataset %s is unreadable or of rank %d (1 to 3 expected)", file, name, rank);
    size_t count = 1;
    for (int k = 0; k < rank; k++)
        count *= (size_t)dims[k];
    int status = SC_OK;
    int64_t *integers = NULL;
    out->values = malloc((count + 1) * sizeof *out->values);
    if (!out->values)
        SC_FAIL_OOM_AT(status, done, (count + 1) * sizeof *out->values, name);
    if (integer && !(integers = malloc((count + 1) * sizeof *integers)))
        SC_FAIL_OOM_AT(status, done, (count + 1) * sizeof *integers, name);
    out->count = count;
    out->rows = (size_t)dims[0];
    out->width = out->rows ? count / out->rows : 0;
    if (read_values(loc, name, integers, out->values, count) != SC_OK) {
        char reason[1024]; /* h5io's message names the file and says why ("... Fletcher32 checksum") */
        snprintf(reason, sizeof reason, "%s", sc_error_message());
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: cannot read dataset %s: %s", file, name, reason);
    }
done:
    free(integers);
    if (status != SC_OK)
        render_array_free(out);
    return status;
}

void render_array_free(struct render_array *a)
{
    free(a->values);
    memset(a, 0, sizeof *a);
}
