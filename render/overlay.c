/* Cairo over the OSMesa buffer: colour bar, caption, text and tick helpers, PNG output. */
#include <errno.h>
#include <cairo-svg.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/atomic.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "render/render_impl.h"

void render_text(cairo_t *cr, double x, double y, double size, double anchor_x, double anchor_y, const char *text)
{
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, size);
    cairo_text_extents_t e;
    cairo_text_extents(cr, text, &e);
    /* the box is placed by the font's size, not by the ink of these letters, so labels line up */
    cairo_move_to(cr, x - anchor_x * e.x_advance, y + (1 - anchor_y) * 0.75 * size - anchor_y * 0.25 * size);
    cairo_show_text(cr, text);
}

double render_text_width(cairo_t *cr, double size, const char *text)
{
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, size);
    cairo_text_extents_t e;
    cairo_text_extents(cr, text, &e);
    return e.x_advance;
}

int render_nice_ticks(double lo, double hi, int max_ticks, double *ticks, double *step)
{
    if (!(hi > lo) || !isfinite(lo) || !isfinite(hi)) {
        ticks[0] = lo;
        *step = 1;
        return 1;
    }
    double raw = (hi - lo) / (max_ticks > 2 ? max_ticks - 1 : 1);
    double magnitude = pow(10, floor(log10(raw)));
    static const double steps[] = {1, 2, 2.5, 5, 10};
    double s = 10 * magnitude;
    for (int i = 0; i < 5; i++)
        if (steps[i] * magnitude >= raw) {
            s = steps[i] * magnitude;
            break;
        }
    int n = 0;
    for (double t = ceil(lo / s - 1e-9) * s; t <= hi + 1e-9 * s && n < max_ticks + 1; t += s)
        ticks[n++] = fabs(t) < 1e-12 * s ? 0 : t;
    *step = s;
    return n;
}

void render_format_tick(double value, double step, char *out, size_t size)
{
    if (value == 0 || !(step > 0)) {
        snprintf(out, size, "0");
        return;
    }
    /* one more digit for steps like 2.5 */
    double mantissa = step / pow(10, floor(log10(step)));
    int extra = fabs(mantissa - round(mantissa)) > 1e-6;
    if (fabs(value) >= 1e-3 && fabs(value) < 1e6) {
        int decimals = (int)fmax(0, -floor(log10(step)) + extra);
        snprintf(out, size, "%.*f", decimals, value);
        return;
    }
    int digits = (int)(floor(log10(fabs(value))) - floor(log10(step))) + 1 + extra;
    snprintf(out, size, "%.*e", digits < 1 ? 0 : digits > 12 ? 11 : digits - 1, value);
}

void render_palette(int i, double rgb[3])
{
    static const unsigned colours[] = {0x0072B2, 0xD55E00, 0x009E73, 0xCC79A7, 0xE69F00, 0x56B4E9, 0x000000, 0xF0E442};
    unsigned c = colours[((i % 8) + 8) % 8];
    rgb[0] = ((c >> 16) & 255) / 255.0, rgb[1] = ((c >> 8) & 255) / 255.0, rgb[2] = (c & 255) / 255.0;
}

/* The bar itself: one horizontal line per pixel row, bottom = vmin. */
static void draw_bar(cairo_t *cr, struct render_box bar)
{
    int rows = (int)ceil(bar.height);
    for (int j = 0; j < rows; j++) {
        double rgb[3];
        render_viridis(1.0 - (j + 0.5) / rows, rgb);
        cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
        cairo_rectangle(cr, bar.x, bar.y + j * bar.height / rows, bar.width, bar.height / rows + 0.5);
        cairo_fill(cr);
    }
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, floor(bar.x) + 0.5, floor(bar.y) + 0.5, ceil(bar.width), ceil(bar.height));
    cairo_stroke(cr);
}

static void draw_bar_ticks(cairo_t *cr, struct render_box bar, const struct render_scene *s, double font)
{
    double ticks[16], step;
    int n = render_nice_ticks(s->vmin, s->vmax, 6, ticks, &step);
    double range = s->vmax - s->vmin;
    for (int i = 0; i < n && range > 0; i++) {
        double y = bar.y + bar.height * (1 - (ticks[i] - s->vmin) / range);
        char label[32];
        render_format_tick(ticks[i], step, label, sizeof label);
        cairo_move_to(cr, bar.x + bar.width, y);
        cairo_line_to(cr, bar.x + bar.width + 5, y);
        cairo_stroke(cr);
        render_text(cr, bar.x + bar.width + 8, y, font, 0, 0.5, label);
    }
    /* the exact range, below the bar: the colour scale of a film can be compared frame by frame */
    char range_text[96];
    snprintf(range_text, sizeof range_text, "range %.4g to %.4g", s->vmin, s->vmax);
    render_text(cr, bar.x + 0.5 * bar.width, bar.y + bar.height + 0.6 * font, 0.85 * font, 0.5, 0, range_text);
}

/* A length with the unit that keeps the number from 1 to 999: nm, µm, mm or m. */
static void format_length(double metres, char *out, size_t size)
{
    static const struct {
        double scale;
        const char *unit;
    } units[] = {{1e-9, "nm"}, {1e-6, "µm"}, {1e-3, "mm"}, {1, "m"}};
    int u = 0;
    while (u < 3 && metres >= 1000 * units[u].scale * (1 - 1e-9))
        u++;
    snprintf(out, size, "%g %s", metres / units[u].scale, units[u].unit);
}

/* A bar of a round length (render_scale_length of a fifth of the scene's width) at the bottom right of the
 * scene, its length above it.  Orthographic views: true for every length in the picture's plane. */
static void draw_scale_bar(cairo_t *cr, const struct render_scene *scene, const struct render_camera *cam, double font)
{
    struct render_box box = render_scene_box(scene);
    double length = render_scale_length(0.2 * box.width / cam->pixels_per_metre);
    if (!(length > 0))
        return;
    double px = length * cam->pixels_per_metre, x1 = box.x + box.width - 0.02 * box.width, x0 = x1 - px;
    double y = box.y + box.height - 0.2 * font;
    char text[32];
    format_length(length, text, sizeof text);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 3);
    cairo_move_to(cr, x0, y);
    cairo_line_to(cr, x1, y);
    cairo_move_to(cr, x0, y - 5), cairo_line_to(cr, x0, y + 5);
    cairo_move_to(cr, x1, y - 5), cairo_line_to(cr, x1, y + 5);
    cairo_stroke(cr);
    render_text(cr, 0.5 * (x0 + x1), y - 6, font, 0.5, 1, text);
}

/* The world axis (0 x, 1 y, 2 z) a camera direction runs along and its sign; -1 when oblique (the iso view). */
static int world_axis(const double dir[3], double *sign)
{
    for (int k = 0; k < 3; k++)
        if (fabs(fabs(dir[k]) - 1) < 1e-9) {
            *sign = dir[k] > 0 ? 1 : -1;
            return k;
        }
    return -1;
}

/* One axis along the scene box's bottom (vertical = 0) or left side, ticks in mm of the world coordinate. */
static void draw_axis(cairo_t *cr, const struct render_camera *cam, struct render_box box, int vertical, double font)
{
    static const char *const names[] = {"x (mm)", "y (mm)", "z (mm)"};
    double sign;
    int k = world_axis(vertical ? cam->up : cam->right, &sign);
    if (k < 0)
        return;
    double ppm = cam->pixels_per_metre;
    /* world coordinate (mm) at the two ends of the side; screen y grows downward */
    double a = vertical ? cam->center[k] + sign * (cam->py0 - (box.y + box.height)) / ppm
                        : cam->center[k] + sign * (box.x - cam->px0) / ppm;
    double b = vertical ? cam->center[k] + sign * (cam->py0 - box.y) / ppm
                        : cam->center[k] + sign * (box.x + box.width - cam->px0) / ppm;
    double ticks[16], step;
    int n = render_nice_ticks(fmin(a, b) * 1e3, fmax(a, b) * 1e3, 8, ticks, &step);
    double base = vertical ? box.x : box.y + box.height;
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    if (vertical)
        cairo_move_to(cr, base - 0.5, box.y), cairo_line_to(cr, base - 0.5, box.y + box.height);
    else
        cairo_move_to(cr, box.x, base + 0.5), cairo_line_to(cr, box.x + box.width, base + 0.5);
    cairo_stroke(cr);
    for (int i = 0; i < n; i++) {
        double along = (ticks[i] * 1e-3 - cam->center[k]) * sign * ppm;
        char label[32];
        render_format_tick(ticks[i], step, label, sizeof label);
        if (vertical) {
            double y = cam->py0 - along;
            cairo_move_to(cr, base, y), cairo_line_to(cr, base - 5, y);
            cairo_stroke(cr);
            render_text(cr, base - 8, y, 0.9 * font, 1, 0.5, label);
        } else {
            double x = cam->px0 + along;
            cairo_move_to(cr, x, base), cairo_line_to(cr, x, base + 5);
            cairo_stroke(cr);
            render_text(cr, x, base + 8, 0.9 * font, 0.5, 0, label);
        }
    }
    if (vertical) /* beside the axis' top end: above it is the caption */
        render_text(cr, base + 8, box.y, font, 0, 0.5, names[k]);
    else
        render_text(cr, box.x + 0.5 * box.width, base + 10 + 1.1 * font, font, 0.5, 0, names[k]);
}

/* The guides: labelled polylines in the scene (nozzle exit, target). */
static void draw_guides(cairo_t *cr, const struct render_scene *scene, const struct render_camera *cam, double font)
{
    for (int g = 0; g < scene->guide_count; g++) {
        const struct render_guide *guide = &scene->guides[g];
        if (guide->count < 1)
            continue;
        cairo_set_source_rgb(cr, 0.80, 0.15, 0.10);
        cairo_set_line_width(cr, 2.5);
        double px, py, first_x, first_y;
        for (int i = 0; i < guide->count; i++) {
            render_camera_project(cam, guide->points + 3 * i, &px, &py);
            if (i == 0)
                cairo_move_to(cr, px, py), first_x = px, first_y = py;
            else
                cairo_line_to(cr, px, py);
        }
        if (guide->closed)
            cairo_close_path(cr);
        cairo_stroke(cr);
        render_camera_project(cam, guide->points, &first_x, &first_y);
        if (guide->label)
            render_text(cr, first_x, first_y + (guide->label_below ? 0.4 * font : -0.4 * font), font, 0,
                        guide->label_below ? 0 : 1, guide->label);
    }
}

int render_overlay_scene(struct render_image *image, const struct render_scene *scene, const struct render_camera *cam)
{
    cairo_surface_t *surface = cairo_image_surface_create_for_data((unsigned char *)image->pixels, CAIRO_FORMAT_ARGB32,
                                                                   image->width, image->height, image->stride);
    cairo_t *cr = cairo_create(surface);
    double font = fmax(11, image->height / 45.0);
    struct render_box bar = render_colorbar_box(scene);
    draw_bar(cr, bar);
    draw_bar_ticks(cr, bar, scene, font);
    char title[160];
    snprintf(title, sizeof title, "%s (%s)", scene->field_label ? scene->field_label : "",
             scene->unit && scene->unit[0] ? scene->unit : "-");
    render_text(cr, bar.x + bar.width, bar.y - 0.8 * font, font, 0.5, 1, title);
    if (scene->caption)
        render_text(cr, 0.02 * image->width, 0.5 * fmax(20, 0.08 * image->height), 1.2 * font, 0, 0.5, scene->caption);
    draw_guides(cr, scene, cam, font);
    if (scene->axes) {
        draw_axis(cr, cam, render_scene_box(scene), 0, font);
        draw_axis(cr, cam, render_scene_box(scene), 1, font);
    }
    if (scene->scale_bar)
        draw_scale_bar(cr, scene, cam, font);
    cairo_surface_flush(surface);
    int status = cairo_status(cr);
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    if (status != CAIRO_STATUS_SUCCESS)
        SC_FAIL(SC_EIO, "render: Cairo: %s", cairo_status_to_string((cairo_status_t)status));
    return SC_OK;
}

/* The errno of the stream writer's last failed write (Cairo says only "error while writing to output stream"). */
static _Thread_local int write_errno;

/* Cairo's stream writer: the bytes go to the atomic file's stream. */
static cairo_status_t write_to_stream(void *closure, const unsigned char *data, unsigned int length)
{
    FILE *stream = closure;
    if (fwrite(data, 1, length, stream) == length)
        return CAIRO_STATUS_SUCCESS;
    write_errno = errno;
    return CAIRO_STATUS_WRITE_ERROR;
}

const char *render_cairo_error(int status)
{
    static _Thread_local char text[256];
    if (status == CAIRO_STATUS_WRITE_ERROR && write_errno) /* a full disk, a file-size limit: say which */
        snprintf(text, sizeof text, "%s (%s)", cairo_status_to_string((cairo_status_t)status),
                 sc_strerror(write_errno));
    else
        snprintf(text, sizeof text, "%s", cairo_status_to_string((cairo_status_t)status));
    return text;
}

int render_surface_write_png(cairo_surface_t *surface, const char *path)
{
    /* every figure and frame passes here: the place where a long render stops at SIGINT/SIGTERM */
    int interrupted = interrupt_status();
    if (interrupted)
        SC_FAIL(interrupted,
                "render: interrupted before %s; the figures drawn so far are kept, and the render stage "
                "draws them all again when it runs next",
                path);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    write_errno = 0;
    cairo_status_t status = cairo_surface_write_to_png_stream(surface, write_to_stream, out.stream);
    if (status != CAIRO_STATUS_SUCCESS) {
        atomic_abort(&out);
        SC_FAIL(SC_EIO, "render: cannot write %s: %s", path, render_cairo_error(status));
    }
    SC_TRY(atomic_publish(&out));
    return SC_OK;
}

int render_svg_begin(const char *path, double width, double height, struct atomic_file *out, cairo_surface_t **surface)
{
    SC_TRY(atomic_open(path, out));
    write_errno = 0;
    *surface = cairo_svg_surface_create_for_stream(write_to_stream, out->stream, width, height);
    return SC_OK;
}

int render_image_write_png(const struct render_image *image, const char *path)
{
    cairo_surface_t *surface = cairo_image_surface_create_for_data((unsigned char *)image->pixels, CAIRO_FORMAT_ARGB32,
                                                                   image->width, image->height, image->stride);
    int status = render_surface_write_png(surface, path);
    cairo_surface_destroy(surface);
    SC_TRY(status);
    return SC_OK;
}
