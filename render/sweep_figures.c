/* The figure of a sweep (RUN_DIR/sweep.h5, app/sweep_stage.c): the map of the deposition efficiency over the two
 * swept keys as coloured cells (viridis over the map's range), each cell with its DE and mean impact speed
 * printed, and a colour bar. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "render/render_impl.h"

struct sweep_grid {
    size_t nx, ny;
    struct render_array de, speed;
    /* per cell 1 where the DE is a lower bound: more of the run's particles than sweep.h5's de_lower_bound_share
     * still in flight at its end (none marked in a sweep.h5 without in_flight_share) */
    unsigned char *lower_bound;
    size_t lower_bounds;
    char x_key[160], y_key[160], x_labels[4096], y_labels[4096];
};

/* The k-th comma-separated label of list into out. */
void render_nth_label(const char *list, size_t k, char *out, size_t size)
{
    const char *p = list;
    for (size_t i = 0; i < k && p; i++) {
        p = strchr(p, ',');
        p = p ? p + 1 : NULL;
    }
    if (!p) {
        snprintf(out, size, "%zu", k + 1);
        return;
    }
    snprintf(out, size, "%.*s", (int)strcspn(p, ","), p);
}

int render_sweep_lower_bounds(hid_t file, const char *path, size_t count, unsigned char **marks, size_t *marked)
{
    *marked = 0;
    SC_TRY(sc_calloc(marks, count, 1, "the sweep's lower bounds"));
    if (!h5_exists(file, "in_flight_share")) /* a sweep.h5 of before the map said so */
        return SC_OK;
    struct render_array share = {0};
    double bound = NAN;
    int status;
    SC_CHECK(status, render_read_array(file, path, "in_flight_share", &share), done);
    SC_CHECK(status, h5_attr_read_double(file, "de_lower_bound_share", &bound), done);
    if (share.count != count)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: /in_flight_share is not the shape of /de", path);
    for (size_t k = 0; k < count; k++) {
        (*marks)[k] = share.values[k] > bound;
        *marked += (*marks)[k];
    }
done:
    render_array_free(&share);
    return status;
}

/* Dark text on light cells, light text on dark ones (relative luminance, ITU-R BT.709). */
static void text_colour_on(cairo_t *cr, const double rgb[3])
{
    double luminance = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    double shade = luminance > 0.5 ? 0.0 : 1.0;
    cairo_set_source_rgb(cr, shade, shade, shade);
}

static void draw_cells(cairo_t *cr, const struct sweep_grid *g, double left, double top, double width, double height,
                       double lo, double hi)
{
    double cw = width / (double)g->nx, ch = height / (double)g->ny;
    double font = fmin(0.2 * ch, 0.14 * cw);
    for (size_t j = 0; j < g->ny; j++)
        for (size_t i = 0; i < g->nx; i++) {
            size_t k = j * g->nx + i;
            double de = g->de.values[k], rgb[3];
            render_viridis(hi > lo ? (de - lo) / (hi - lo) : 0.5, rgb);
            double x = left + (double)i * cw, y = top + (double)(g->ny - 1 - j) * ch; /* y value 0 at the bottom */
            cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
            cairo_rectangle(cr, x, y, cw, ch);
            cairo_fill(cr);
            char text[64];
            text_colour_on(cr, rgb);
            snprintf(text, sizeof text, "DE %s%.3f", g->lower_bound[k] ? "\u2265 " : "", de);
            render_text(cr, x + 0.5 * cw, y + 0.5 * ch - 0.1 * font, font, 0.5, 1, text);
            if (isfinite(g->speed.values[k]))
                snprintf(text, sizeof text, "%.0f m/s", g->speed.values[k]);
            else
                snprintf(text, sizeof text, "no impact");
            render_text(cr, x + 0.5 * cw, y + 0.5 * ch + 0.1 * font, 0.85 * font, 0.5, 0, text);
        }
}

static void draw_axes(cairo_t *cr, const struct sweep_grid *g, double left, double top, double width, double height)
{
    double cw = width / (double)g->nx, ch = height / (double)g->ny, font = 14;
    char label[128];
    cairo_set_source_rgb(cr, 0, 0, 0);
    for (size_t i = 0; i < g->nx; i++) {
        render_nth_label(g->x_labels, i, label, sizeof label);
        render_text(cr, left + ((double)i + 0.5) * cw, top + height + 6, font, 0.5, 0, label);
    }
    for (size_t j = 0; j < g->ny; j++) {
        render_nth_label(g->y_labels, j, label, sizeof label);
        render_text(cr, left - 8, top + ((double)(g->ny - 1 - j) + 0.5) * ch, font, 1, 0.5, label);
    }
    render_text(cr, left + 0.5 * width, top + height + 12 + 1.4 * font, font, 0.5, 0, g->x_key);
    cairo_save(cr);
    cairo_translate(cr, 16, top + 0.5 * height);
    cairo_rotate(cr, -M_PI / 2);
    render_text(cr, 0, 0, font, 0.5, 0, g->y_key[0] ? g->y_key : "(one row)");
    cairo_restore(cr);
    render_text(cr, left + 0.5 * width, 12, 1.2 * font, 0.5, 0,
                g->lower_bounds ? "Deposition efficiency (mass; \u2265: a lower bound, particles still in flight) and "
                                  "mean impact speed"
                                : "Deposition efficiency (mass) and mean impact speed over the sweep");
}

static void draw_colour_bar(cairo_t *cr, double x, double top, double height, double lo, double hi)
{
    const int steps = 128;
    for (int s = 0; s < steps; s++) {
        double rgb[3];
        render_viridis((double)s / (steps - 1), rgb);
        cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
        cairo_rectangle(cr, x, top + height * (1.0 - (double)(s + 1) / steps), 18, height / steps + 0.5);
        cairo_fill(cr);
    }
    char text[32];
    cairo_set_source_rgb(cr, 0, 0, 0);
    snprintf(text, sizeof text, "%.3f", hi);
    render_text(cr, x + 24, top, 13, 0, 0.5, text);
    snprintf(text, sizeof text, "%.3f", lo);
    render_text(cr, x + 24, top + height, 13, 0, 0.5, text);
    render_text(cr, x + 24, top + 0.5 * height, 13, 0, 0.5, "DE");
}

static int draw_map(const struct render_request *req, const struct sweep_grid *g, const char *path)
{
    int width = req->cfg->plot_width, height = req->cfg->plot_height;
    double left = 110, right = 90, top = 44, bottom = 64;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t k = 0; k < g->de.count; k++)
        lo = fmin(lo, g->de.values[k]), hi = fmax(hi, g->de.values[k]);
    cairo_surface_t *surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height);
    cairo_t *cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    double w = width - left - right, h = height - top - bottom;
    draw_cells(cr, g, left, top, w, h, lo, hi);
    draw_axes(cr, g, left, top, w, h);
    draw_colour_bar(cr, left + w + 16, top, h, lo, hi);
    int status = cairo_status(cr);
    cairo_destroy(cr);
    if (status != CAIRO_STATUS_SUCCESS) {
        cairo_surface_destroy(surface);
        SC_FAIL(SC_EIO, "render: cannot draw %s: %s", path, cairo_status_to_string((cairo_status_t)status));
    }
    status = render_surface_write_png(surface, path);
    cairo_surface_destroy(surface);
    SC_TRY(status);
    return SC_OK;
}

static int read_grid(hid_t file, const char *path, struct sweep_grid *g)
{
    SC_TRY(render_read_array(file, path, "de", &g->de));
    SC_TRY(render_read_array(file, path, "mean_impact_speed", &g->speed));
    g->ny = g->de.rows;
    g->nx = g->de.width;
    if (g->speed.count != g->de.count || g->nx == 0 || g->ny == 0)
        SC_FAIL(SC_EIO, "render: %s: /de and /mean_impact_speed are not maps of the same shape", path);
    SC_TRY(h5_attr_read_string(file, "x_key", g->x_key, sizeof g->x_key));
    SC_TRY(h5_attr_read_string(file, "y_key", g->y_key, sizeof g->y_key));
    SC_TRY(h5_attr_read_string(file, "x_labels", g->x_labels, sizeof g->x_labels));
    SC_TRY(h5_attr_read_string(file, "y_labels", g->y_labels, sizeof g->y_labels));
    return render_sweep_lower_bounds(file, path, g->de.count, &g->lower_bound, &g->lower_bounds);
}

int render_sweep_figures(const struct render_request *req, struct render_output *out)
{
    char path[4200], png[4300], dir[4200];
    snprintf(path, sizeof path, "%s/sweep.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(path, &file));
    struct sweep_grid g;
    memset(&g, 0, sizeof g);
    int status = read_grid(file, path, &g);
    H5Fclose(file);
    render_figures_dir(req->run_dir, dir, sizeof dir);
    snprintf(png, sizeof png, "%s/sweep_de.png", dir);
    if (status == SC_OK)
        status = render_output_push(out, "sweep_de", "sweep", 0, "Deposition efficiency over the sweep", NULL);
    if (status == SC_OK)
        status = draw_map(req, &g, png);
    if (status == SC_OK)
        log_info("render: sweep figure from %s", path);
    render_array_free(&g.de), render_array_free(&g.speed);
    free(g.lower_bound);
    SC_TRY(status);
    return SC_OK;
}
