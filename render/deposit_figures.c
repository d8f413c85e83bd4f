/* The deposit of a traversing run (spray.h5 /deposit, dem/deposit.c): the height map as a picture, viridis from 0 to
 * the highest cell, and the track's thickness profile across the track with its Gaussian fit. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "render/render_impl.h"

struct deposit_data {
    struct render_array height, x, y, profile_y, profile_height;
    int has_fit;
    double amplitude, centre, width, mean_thickness;
};

static void deposit_data_free(struct deposit_data *d)
{
    render_array_free(&d->height);
    render_array_free(&d->x);
    render_array_free(&d->y);
    render_array_free(&d->profile_y);
    render_array_free(&d->profile_height);
}

static int deposit_data_read(hid_t file, const char *path, struct deposit_data *d)
{
    SC_TRY(render_read_array(file, path, "deposit/height", &d->height));
    SC_TRY(render_read_array(file, path, "deposit/x", &d->x));
    SC_TRY(render_read_array(file, path, "deposit/y", &d->y));
    if (d->height.count != d->x.count * d->y.count || d->x.count < 2 || d->y.count < 2)
        SC_FAIL(SC_EIO, "render: %s: /deposit/height is not |y| x |x| (%zu, %zu x %zu)", path, d->height.count,
                d->y.count, d->x.count);
    if (!h5_exists(file, "deposit/profile_y"))
        return SC_OK;
    SC_TRY(render_read_array(file, path, "deposit/profile_y", &d->profile_y));
    SC_TRY(render_read_array(file, path, "deposit/profile_height", &d->profile_height));
    hid_t g = H5Gopen2(file, "deposit", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s: cannot open /deposit", path);
    int status = h5_attr_read_double(g, "mean_thickness", &d->mean_thickness);
    d->has_fit = status == SC_OK && H5Aexists(g, "fit_amplitude") > 0;
    if (d->has_fit)
        status = h5_attr_read_double(g, "fit_amplitude", &d->amplitude) == SC_OK &&
                         h5_attr_read_double(g, "fit_centre", &d->centre) == SC_OK &&
                         h5_attr_read_double(g, "fit_width", &d->width) == SC_OK
                     ? SC_OK
                     : SC_EIO;
    H5Gclose(g);
    if (status != SC_OK)
        SC_FAIL(SC_EIO, "render: %s: unreadable attributes of /deposit", path);
    return SC_OK;
}

/* The map's cells as squares, x right and y up, viridis of height / the highest cell; a colour bar at the right. */
static void draw_map(cairo_t *cr, const struct deposit_data *d, double left, double top, double scale, double peak)
{
    size_t nx = d->x.count, ny = d->y.count;
    double cell = d->x.values[1] - d->x.values[0];
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            double rgb[3];
            render_viridis(peak > 0 ? d->height.values[j * nx + i] / peak : 0.0, rgb);
            cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
            /* row j at the bottom for j = 0: y up */
            cairo_rectangle(cr, left + (double)i * cell * scale, top + (double)(ny - 1 - j) * cell * scale,
                            cell * scale + 0.5, cell * scale + 0.5);
            cairo_fill(cr);
        }
}

static void draw_colour_bar(cairo_t *cr, double x, double top, double height, double peak, double font)
{
    for (int k = 0; k < 64; k++) {
        double rgb[3];
        render_viridis((k + 0.5) / 64.0, rgb);
        cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
        cairo_rectangle(cr, x, top + height * (1.0 - (k + 1) / 64.0), 16, height / 64.0 + 0.5);
        cairo_fill(cr);
    }
    char label[64];
    cairo_set_source_rgb(cr, 0, 0, 0);
    snprintf(label, sizeof label, "%.3g µm", peak * 1e6);
    render_text(cr, x + 20, top, font, 0, 0.5, label);
    render_text(cr, x + 20, top + height, font, 0, 0.5, "0");
    render_text(cr, x + 8, top + height + 1.6 * font, font, 0.5, 0.5, "height");
}

static int height_map_figure(const struct render_request *req, const struct deposit_data *d, struct render_output *out)
{
    int width = req->cfg->plot_width, height = req->cfg->plot_height;
    double font = 0.03 * height, margin = 3.0 * font, bar_room = 6.0 * font;
    size_t nx = d->x.count, ny = d->y.count;
    double cell = d->x.values[1] - d->x.values[0], span_x = (double)nx * cell, span_y = (double)ny * cell;
    double scale = fmin((width - 2 * margin - bar_room) / span_x, (height - 3 * margin) / span_y);
    double left = margin, top = 1.5 * margin, peak = 0.0;
    for (size_t k = 0; k < d->height.count; k++)
        peak = fmax(peak, d->height.values[k]);
    cairo_surface_t *surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height);
    cairo_t *cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    draw_map(cr, d, left, top, scale, peak);
    cairo_set_source_rgb(cr, 0, 0, 0);
    char label[160];
    snprintf(label, sizeof label, "Deposit height map (top view, x right, y up): %zu x %zu cells of %.3g mm", nx, ny,
             cell * 1e3);
    render_text(cr, 0.5 * width, 0.6 * margin, 1.1 * font, 0.5, 0.5, label);
    snprintf(label, sizeof label, "x %.3g to %.3g mm", (d->x.values[0] - 0.5 * cell) * 1e3,
             (d->x.values[nx - 1] + 0.5 * cell) * 1e3);
    render_text(cr, left, top + span_y * scale + 0.5 * font, font, 0, 0, label);
    snprintf(label, sizeof label, "y %.3g to %.3g mm", (d->y.values[0] - 0.5 * cell) * 1e3,
             (d->y.values[ny - 1] + 0.5 * cell) * 1e3);
    render_text(cr, left, top + span_y * scale + 1.8 * font, font, 0, 0, label);
    draw_colour_bar(cr, left + span_x * scale + font, top, fmax(span_y * scale, 4 * font), peak, font);
    cairo_destroy(cr);
    char dir[4200], path[4300];
    render_figures_dir(req->run_dir, dir, sizeof dir);
    snprintf(path, sizeof path, "%s/deposit_height.png", dir);
    int status = render_surface_write_png(surface, path);
    cairo_surface_destroy(surface);
    SC_TRY(status);
    return render_output_push(out, "deposit_height", "spray", 0,
                              "Deposit height map: deposited particle volume per cell / (cell area x packing)", NULL);
}

static int profile_figure(const struct render_request *req, const struct deposit_data *d, struct render_output *out)
{
    size_t n = d->profile_y.count;
    enum { FIT_POINTS = 200 };
    double *buffer = malloc((2 * n + 2 * FIT_POINTS) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((2 * n + 2 * FIT_POINTS) * sizeof *buffer, "the track profile");
    double *left = buffer, *h = buffer + n, *fy = buffer + 2 * n, *fh = fy + FIT_POINTS;
    double cell = d->profile_y.values[1] - d->profile_y.values[0];
    for (size_t j = 0; j < n; j++)
        left[j] = (d->profile_y.values[j] - 0.5 * cell) * 1e3, h[j] = d->profile_height.values[j] * 1e6;
    double lo = d->profile_y.values[0], hi = d->profile_y.values[n - 1];
    for (int k = 0; k < FIT_POINTS; k++) {
        double y = lo + (hi - lo) * k / (FIT_POINTS - 1.0), u = (y - d->centre) / d->width;
        fy[k] = y * 1e3, fh[k] = d->amplitude * exp(-0.5 * u * u) * 1e6;
    }
    char fit_label[160];
    snprintf(fit_label, sizeof fit_label, "Gaussian fit: %.3g µm, sigma %.3g mm, centre %.3g mm", d->amplitude * 1e6,
             d->width * 1e3, d->centre * 1e3);
    struct render_series series[2] = {{"profile (middle half of the pass)", RENDER_BARS, n, left, h, cell * 1e3, 2},
                                      {fit_label, RENDER_LINE, FIT_POINTS, fy, fh, 0, 1}};
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){d->has_fit ? "Track thickness profile across the track"
                                                      : "Coating thickness profile across the passes",
                                           "y across the track (mm)",
                                           "thickness (µm)",
                                           NAN,
                                           NAN,
                                           0,
                                           NAN,
                                           1,
                                           d->has_fit ? 2 : 1,
                                           series};
    int status = render_plot_publish(req->run_dir, out, "deposit_profile", "spray",
                                     d->has_fit ? "Track thickness profile across the track (mean over the middle "
                                                  "half of the pass) and its Gaussian fit"
                                                : "Coating thickness profile across the passes (mean over the middle "
                                                  "half of the passes' length)",
                                     &plot);
    free(buffer);
    return status;
}

int render_nozzle_moves(hid_t file)
{
    char pattern[16] = "none";
    if (h5_exists(file, "deposit")) {
        hid_t g = H5Gopen2(file, "deposit", H5P_DEFAULT);
        if (g >= 0 && h5_attr_read_string(g, "pattern", pattern, sizeof pattern) != SC_OK)
            sc_error_clear();
        if (g >= 0)
            H5Gclose(g);
    }
    return strcmp(pattern, "none") != 0;
}

int render_deposit_figures(const struct render_request *req, hid_t file, const char *path, struct render_output *out)
{
    if (!render_nozzle_moves(file))
        return SC_OK; /* a fixed nozzle (spray_thickness has its radial profile), or a spray.h5 without /deposit */
    struct deposit_data d;
    memset(&d, 0, sizeof d);
    int status;
    SC_CHECK(status, deposit_data_read(file, path, &d), done);
    SC_CHECK(status, height_map_figure(req, &d, out), done);
    if (d.profile_y.count >= 2)
        SC_CHECK(status, profile_figure(req, &d, out), done);
done:
    deposit_data_free(&d);
    return status;
}
