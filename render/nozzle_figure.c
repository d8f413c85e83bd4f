/* The nozzle's figure (spray.h5 /nozzle, docs/physics.md "Nozzle"): each diameter's velocity and temperature at the
 * nozzle exit, beside the gas's exit state. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "render/render_impl.h"

enum { NOZZLE_ARRAYS = 3 };

static int nozzle_plot(const struct render_request *req, struct render_output *out, const struct render_array *a,
                       double gas_velocity, double gas_temperature)
{
    size_t n = a[0].count;
    double *buffer = malloc((3 * n + 4) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((3 * n + 4) * sizeof *buffer, "the nozzle figure");
    double *um = buffer, *celsius = buffer + n, *gas_x = buffer + 2 * n, *gas_v = gas_x + 2, *gas_t = gas_v + 2;
    for (size_t i = 0; i < n; i++) {
        um[i] = a[0].values[i] * 1e6;
        celsius[i] = a[2].values[i] - 273.15;
    }
    gas_x[0] = um[0], gas_x[1] = um[n - 1];
    gas_v[0] = gas_v[1] = gas_velocity;
    gas_t[0] = gas_t[1] = gas_temperature - 273.15;
    struct render_series speeds[2] = {{"particle", RENDER_LINE, n, um, a[1].values, 0, 0},
                                      {"gas", RENDER_DASHED, 2, gas_x, gas_v, 0, 1}};
    struct render_series temperatures[2] = {{"particle", RENDER_LINE, n, um, celsius, 0, 2},
                                            {"gas (static)", RENDER_DASHED, 2, gas_x, gas_t, 0, 1}};
    struct render_plot plot = render_plot_start(req->cfg, 2);
    plot.width *= 2;
    plot.panels[0] = (struct render_panel){
        "Velocity at the nozzle exit", "particle diameter (um)", "velocity (m/s)", NAN, NAN, NAN, NAN, 1, 2, speeds};
    plot.panels[1] = (struct render_panel){"Temperature at the nozzle exit",
                                           "particle diameter (um)",
                                           "temperature (C)",
                                           NAN,
                                           NAN,
                                           NAN,
                                           NAN,
                                           0,
                                           2,
                                           temperatures};
    int status;
    SC_CHECK(status,
             render_plot_publish(req->run_dir, out, "spray_nozzle", "spray",
                                 "Particles at the nozzle exit vs diameter: quasi-1-D isentropic gas, Henderson drag, "
                                 "Ranz-Marshall heating (CVODE)",
                                 &plot),
             done);
done:
    free(buffer);
    return status;
}

int render_nozzle_figure(const struct render_request *req, struct render_output *out)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/spray.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(path, &file));
    static const char *const names[NOZZLE_ARRAYS] = {"nozzle/particles/diameter", "nozzle/particles/velocity",
                                                     "nozzle/particles/temperature"};
    struct render_array a[NOZZLE_ARRAYS];
    memset(a, 0, sizeof a);
    double gas_velocity = 0, gas_temperature = 0;
    int status = SC_OK;
    if (!h5_exists(file, "nozzle"))
        goto done; /* a case without [nozzle] */
    hid_t g = H5Gopen2(file, "nozzle", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL_AT(status, done, SC_EIO, "%s: cannot open /nozzle", path);
    status = h5_attr_read_double(g, "exit_velocity", &gas_velocity);
    if (status == SC_OK)
        status = h5_attr_read_double(g, "exit_temperature", &gas_temperature);
    H5Gclose(g);
    SC_CHECK(status, status, done);
    for (int k = 0; k < NOZZLE_ARRAYS; k++)
        SC_CHECK(status, render_read_array(file, path, names[k], &a[k]), done);
    if (a[0].count == 0 || a[1].count != a[0].count || a[2].count != a[0].count)
        SC_FAIL_AT(status, done, SC_EIO, "%s: /nozzle/particles: datasets of different lengths", path);
    SC_CHECK(status, nozzle_plot(req, out, a, gas_velocity, gas_temperature), done);
done:
    for (int k = 0; k < NOZZLE_ARRAYS; k++)
        render_array_free(&a[k]);
    H5Fclose(file);
    return status;
}
