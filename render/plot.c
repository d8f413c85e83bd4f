/* 2-D plots with Cairo: one or two panels, axes with nice ticks, labels with units, legend; PNG and SVG from the
 * same drawing code. */
#include <cairo-svg.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/atomic.h"
#include "core/error.h"
#include "render/render_impl.h"

struct range {
    double lo, hi;
};

struct frame { /* the data-to-device mapping of one panel */
    double left, top, width, height;
    struct range x, y;
    double font;
};

static void extend(struct range *r, double v)
{
    if (isfinite(v)) {
        r->lo = fmin(r->lo, v);
        r->hi = fmax(r->hi, v);
    }
}

/* The data range of the panel's series, padded 4 %, overridden by the panel's fixed limits. */
static void data_ranges(const struct render_panel *p, struct range *x, struct range *y)
{
    *x = (struct range){INFINITY, -INFINITY};
    *y = (struct range){INFINITY, -INFINITY};
    for (int s = 0; s < p->series_count; s++) {
        const struct render_series *series = &p->series[s];
        for (size_t i = 0; i < series->count; i++) {
            if (!isfinite(series->x[i]) || !isfinite(series->y[i]))
                continue;
            extend(x, series->x[i]);
            extend(y, series->y[i]);
            if (series->kind == RENDER_BARS) {
                extend(x, series->x[i] + series->bar_width);
                extend(y, 0);
            }
        }
    }
    if (p->y_from_zero)
        extend(y, 0);
    struct range *both[2] = {x, y};
    for (int k = 0; k < 2; k++) {
        struct range *r = both[k];
        if (!(r->lo <= r->hi))
            r->lo = 0, r->hi = 1;
        double pad = r->hi > r->lo ? 0.04 * (r->hi - r->lo) : fmax(0.05 * fabs(r->lo), 0.5);
        int from_zero = k == 1 && p->y_from_zero && r->lo == 0;
        r->lo = from_zero ? 0 : r->lo - pad;
        r->hi += pad;
    }
    if (isfinite(p->xmin))
        x->lo = p->xmin;
    if (isfinite(p->xmax))
        x->hi = p->xmax;
    if (isfinite(p->ymin))
        y->lo = p->ymin;
    if (isfinite(p->ymax))
        y->hi = p->ymax;
}

static double to_x(const struct frame *f, double v)
{
    return f->left + (v - f->x.lo) / (f->x.hi - f->x.lo) * f->width;
}
static double to_y(const struct frame *f, double v)
{
    return f->top + (1 - (v - f->y.lo) / (f->y.hi - f->y.lo)) * f->height;
}

static void draw_axes(cairo_t *cr, const struct frame *f, const struct render_panel *p)
{
    double ticks[32], step;
    char label[48];
    cairo_set_line_width(cr, 1);
    int n = render_nice_ticks(f->x.lo, f->x.hi, (int)fmax(3, f->width / (6 * f->font)), ticks, &step);
    for (int i = 0; i < n; i++) {
        double x = to_x(f, ticks[i]);
        cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
        cairo_move_to(cr, x, f->top), cairo_line_to(cr, x, f->top + f->height), cairo_stroke(cr);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_move_to(cr, x, f->top + f->height), cairo_line_to(cr, x, f->top + f->height + 5), cairo_stroke(cr);
        render_format_tick(ticks[i], step, label, sizeof label);
        render_text(cr, x, f->top + f->height + 7, f->font, 0.5, 0, label);
    }
    n = render_nice_ticks(f->y.lo, f->y.hi, (int)fmax(3, f->height / (3 * f->font)), ticks, &step);
    for (int i = 0; i < n; i++) {
        double y = to_y(f, ticks[i]);
        cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
        cairo_move_to(cr, f->left, y), cairo_line_to(cr, f->left + f->width, y), cairo_stroke(cr);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_move_to(cr, f->left - 5, y), cairo_line_to(cr, f->left, y), cairo_stroke(cr);
        render_format_tick(ticks[i], step, label, sizeof label);
        render_text(cr, f->left - 7, y, f->font, 1, 0.5, label);
    }
    cairo_rectangle(cr, f->left, f->top, f->width, f->height);
    cairo_stroke(cr);
    if (p->title)
        render_text(cr, f->left + 0.5 * f->width, f->top - 0.5 * f->font, 1.1 * f->font, 0.5, 1, p->title);
    if (p->xlabel)
        render_text(cr, f->left + 0.5 * f->width, f->top + f->height + 2.2 * f->font, f->font, 0.5, 0, p->xlabel);
    if (p->ylabel) {
        cairo_save(cr);
        cairo_translate(cr, f->left - 4.6 * f->font, f->top + 0.5 * f->height);
        cairo_rotate(cr, -M_PI / 2);
        render_text(cr, 0, 0, f->font, 0.5, 0.5, p->ylabel);
        cairo_restore(cr);
    }
}

static void draw_marker(cairo_t *cr, double x, double y, double size, int open)
{
    cairo_new_sub_path(cr);
    cairo_arc(cr, x, y, size, 0, 2 * M_PI);
    if (open)
        cairo_stroke(cr);
    else
        cairo_fill(cr);
}

static void draw_series(cairo_t *cr, const struct frame *f, const struct render_series *s)
{
    double rgb[3];
    render_palette(s->colour, rgb);
    cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
    cairo_set_line_width(cr, s->kind == RENDER_OPEN_MARKERS ? 1.2 : 1.8);
    double dash[] = {6, 4};
    cairo_set_dash(cr, dash, s->kind == RENDER_DASHED ? 2 : 0, 0);
    int pen_down = 0;
    for (size_t i = 0; i < s->count; i++) {
        if (!isfinite(s->x[i]) || !isfinite(s->y[i])) {
            pen_down = 0; /* a gap in a line */
            continue;
        }
        double x = to_x(f, s->x[i]), y = to_y(f, s->y[i]);
        if (s->kind == RENDER_LINE || s->kind == RENDER_DASHED) {
            if (pen_down)
                cairo_line_to(cr, x, y);
            else
                cairo_move_to(cr, x, y);
            pen_down = 1;
        } else if (s->kind == RENDER_BARS) {
            double x1 = to_x(f, s->x[i] + s->bar_width), y0 = to_y(f, fmax(f->y.lo, 0));
            cairo_rectangle(cr, x, y, x1 - x, y0 - y);
            cairo_fill_preserve(cr);
            cairo_save(cr);
            cairo_set_source_rgb(cr, 1, 1, 1);
            cairo_set_line_width(cr, 0.5);
            cairo_stroke(cr);
            cairo_restore(cr);
        } else {
            draw_marker(cr, x, y, 0.25 * f->font, s->kind == RENDER_OPEN_MARKERS);
        }
    }
    if (s->kind == RENDER_LINE || s->kind == RENDER_DASHED)
        cairo_stroke(cr);
    cairo_set_dash(cr, NULL, 0, 0);
}

static void draw_legend(cairo_t *cr, const struct frame *f, const struct render_panel *p)
{
    double width = 0;
    int rows = 0;
    for (int s = 0; s < p->series_count; s++)
        if (p->series[s].label) {
            width = fmax(width, render_text_width(cr, 0.9 * f->font, p->series[s].label));
            rows++;
        }
    if (rows == 0)
        return;
    double line = 1.3 * f->font, box_w = width + 3.2 * f->font, box_h = rows * line + 0.5 * f->font;
    double x0 = f->left + f->width - box_w - 6, y0 = f->top + 6;
    cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
    cairo_rectangle(cr, x0, y0, box_w, box_h);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
    cairo_set_line_width(cr, 0.8);
    cairo_stroke(cr);
    int row = 0;
    for (int s = 0; s < p->series_count; s++) {
        const struct render_series *series = &p->series[s];
        if (!series->label)
            continue;
        double y = y0 + 0.25 * f->font + (row++ + 0.5) * line, x = x0 + 0.4 * f->font;
        /* a two-point sample of the series drawn through the same code as the data */
        double sx[2] = {x, x + 2 * f->font}, sy[2] = {y, y};
        struct frame identity = {0, 0, 1, 1, {0, 1}, {1, 0}, f->font};
        struct render_series sample = *series;
        sample.count = series->kind == RENDER_LINE || series->kind == RENDER_DASHED ? 2 : 1;
        if (series->kind != RENDER_LINE && series->kind != RENDER_DASHED)
            sx[0] += f->font;
        sample.x = sx, sample.y = sy;
        if (series->kind == RENDER_BARS) {
            double rgb[3];
            render_palette(series->colour, rgb);
            cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
            cairo_rectangle(cr, x + 0.3 * f->font, y - 0.4 * f->font, 1.4 * f->font, 0.8 * f->font);
            cairo_fill(cr);
        } else {
            draw_series(cr, &identity, &sample);
        }
        cairo_set_source_rgb(cr, 0, 0, 0);
        render_text(cr, x + 2.6 * f->font, y, 0.9 * f->font, 0, 0.5, series->label);
    }
}

static void draw_panel(cairo_t *cr, const struct render_panel *p, double left, double width, double height)
{
    struct frame f;
    f.font = fmax(10, fmin(width / 45, height / 30));
    f.left = left + 6 * f.font;
    f.top = 2.5 * f.font;
    f.width = fmax(10, width - 7 * f.font);
    f.height = fmax(10, height - 6.2 * f.font);
    data_ranges(p, &f.x, &f.y);
    draw_axes(cr, &f, p);
    cairo_save(cr);
    cairo_rectangle(cr, f.left, f.top, f.width, f.height);
    cairo_clip(cr);
    for (int s = 0; s < p->series_count; s++)
        draw_series(cr, &f, &p->series[s]);
    cairo_restore(cr);
    draw_legend(cr, &f, p);
}

static void draw_plot(cairo_t *cr, const struct render_plot *plot)
{
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    double panel_width = (double)plot->width / plot->panel_count;
    for (int i = 0; i < plot->panel_count; i++)
        draw_panel(cr, &plot->panels[i], i * panel_width, panel_width, plot->height);
}

static int finish(cairo_t *cr, cairo_surface_t *surface, const char *path)
{
    int status = cairo_status(cr);
    cairo_destroy(cr);
    cairo_surface_finish(surface);
    if (status == CAIRO_STATUS_SUCCESS)
        status = cairo_surface_status(surface);
    cairo_surface_destroy(surface);
    if (status != CAIRO_STATUS_SUCCESS)
        SC_FAIL(SC_EIO, "render: cannot write %s: %s", path, render_cairo_error(status));
    return SC_OK;
}

int render_plot_write(const struct render_plot *plot, const char *dir, const char *name)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s.png", dir, name);
    cairo_surface_t *surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, plot->width, plot->height);
    cairo_t *cr = cairo_create(surface);
    draw_plot(cr, plot);
    int written = render_surface_write_png(surface, path);
    int finished = finish(cr, surface, path);
    SC_TRY(written);
    SC_TRY(finished);
    snprintf(path, sizeof path, "%s/%s.svg", dir, name);
    struct atomic_file out;
    SC_TRY(render_svg_begin(path, plot->width, plot->height, &out, &surface));
    cr = cairo_create(surface);
    draw_plot(cr, plot);
    int status = finish(cr, surface, path);
    if (status != SC_OK)
        atomic_abort(&out);
    SC_TRY(status);
    SC_TRY(atomic_publish(&out));
    return SC_OK;
}
