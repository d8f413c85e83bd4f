/* Module-private (render/): Cairo helpers shared by the overlay of 3-D pictures and the plots, the readers of
 * the run's files, and the figure builders. */
#ifndef SPRAYCOAT_RENDER_IMPL_H
#define SPRAYCOAT_RENDER_IMPL_H

#include <cairo.h>
#include <hdf5.h>

#include "core/atomic.h"
#include "render/render.h"

/* ---- the camera (render/camera.c) ---- */

/* Frame the camera on the bounding box of the spheres the view shows (for SECTION those with y >= section_y). */
int render_camera_frame(const struct render_spheres *s, const struct render_scene *scene, struct render_camera *cam);
/* 1 when the view shows sphere i (SECTION hides the half y < section_y). */
int render_view_shows(const struct render_scene *scene, const double x[3]);

/* ---- 2-D plots (render/plot.c): lines, markers and bars in one or two panels ---- */

enum render_series_kind { RENDER_LINE, RENDER_DASHED, RENDER_MARKERS, RENDER_OPEN_MARKERS, RENDER_BARS };
struct render_series {
    const char *label; /* legend text (NULL: not in the legend) */
    enum render_series_kind kind;
    size_t count;
    const double *x, *y; /* RENDER_BARS: x = left edges, y = heights, each bar bar_width wide */
    double bar_width;
    int colour; /* index into the palette (colour-blind safe, Okabe & Ito) */
};
struct render_panel {
    const char *title, *xlabel, *ylabel;
    double xmin, xmax, ymin, ymax; /* NAN: from the data */
    int y_from_zero;               /* the automatic y range includes 0 */
    int series_count;
    const struct render_series *series;
};
struct render_plot {
    int width, height; /* px (PNG) and pt (SVG) */
    int panel_count;   /* 1 or 2 (side by side) */
    struct render_panel panels[2];
};
/* Write DIR/NAME.png and DIR/NAME.svg.  SC_EIO on failure. */
int render_plot_write(const struct render_plot *plot, const char *dir, const char *name);

/* The colour bar (with field name, unit and range) and the caption, drawn by Cairo over the image. */
int render_overlay_scene(struct render_image *image, const struct render_scene *scene, const struct render_camera *cam);

/* Text: the font every picture uses (sans-serif) at `size` px; anchor_x and anchor_y in [0, 1] place the text's
 * box relative to (x, y): 0 left/top, 0.5 centre, 1 right/bottom. */
void render_text(cairo_t *cr, double x, double y, double size, double anchor_x, double anchor_y, const char *text);
double render_text_width(cairo_t *cr, double size, const char *text);
/* Tick values at "nice" steps (1, 2, 5 x 10^k) inside [lo, hi]: at most max_ticks, into ticks[]; returns the
 * count and the step in *step. */
int render_nice_ticks(double lo, double hi, int max_ticks, double *ticks, double *step);
/* A tick label: %g with as many digits as the step needs. */
void render_format_tick(double value, double step, char *out, size_t size);
/* Palette colour i (Okabe & Ito). */
void render_palette(int i, double rgb[3]);

/* ---- reading the run's files ---- */

/* 1 when RUN_DIR/name ("spray.h5") is there and not one of the request's ignored files, else 0. */
int render_input_present(const struct render_request *req, const char *name);

/* A 1-D or 2-D double dataset read whole: values (count) and its first dimension (rows) and width (count/rows).
 * SC_EIO naming file and dataset when absent or unreadable. */
struct render_array {
    double *values;
    size_t count, rows, width;
};
int render_read_array(hid_t loc, const char *file, const char *name, struct render_array *out);
void render_array_free(struct render_array *a);
/* Open an HDF5 file of the run; SC_EIO "RUN_DIR/NAME is not a readable HDF5 file" when malformed. */
int render_open(const char *path, hid_t *file);

/* ---- building the output ---- */

/* Append a figure entry (name, title, group); returns it, or NULL when out of memory. */
struct render_figure *render_output_add(struct render_output *out, const char *name, const char *group, int is_plot,
                                        const char *title);
/* render_output_add with a status: SC_OK and *figure (when figure is not NULL) the entry, or out of memory. */
int render_output_push(struct render_output *out, const char *name, const char *group, int is_plot, const char *title,
                       struct render_figure **figure);
/* The plot sizes of the request. */
struct render_plot render_plot_start(const struct render_config *cfg, int panels);
/* A film's folder (RUN_DIR/figures/film_*), made if missing and emptied of the PNGs of an earlier render, so
 * that its frames are those of this one (a different `every` leaves no stale frame in a video made of them). */
int render_film_folder(const char *path);
/* RUN_DIR/figures */
void render_figures_dir(const char *run_dir, char *out, size_t size);
/* A plot's figure entry (name, group, title) and its files RUN_DIR/figures/NAME.png and .svg. */
int render_plot_publish(const char *run_dir, struct render_output *out, const char *name, const char *group,
                        const char *title, const struct render_plot *plot);

int render_spray_figures(const struct render_request *req, struct render_renderer **renderer,
                         struct render_output *out);
int render_impact_figures(const struct render_request *req, struct render_renderer **renderer,
                          struct render_output *out);
int render_vcrit_figures(const struct render_request *req, struct render_output *out);
/* RUN_DIR/calibrate.h5: the outcomes and boundaries per size, both boundaries and their intersection. */
int render_calibrate_figures(const struct render_request *req, struct render_output *out);
/* RUN_DIR/spray.h5 /nozzle: the particles' exit velocity and temperature vs diameter (nothing without /nozzle). */
int render_nozzle_figure(const struct render_request *req, struct render_output *out);
/* RUN_DIR/sweep.h5: the map of the deposition efficiency over the swept keys (figures/sweep_de.png). */
int render_sweep_figures(const struct render_request *req, struct render_output *out);
/* The first contact of each particle in spray.h5 /impacts (t and particle_id of m rows): its row with the smallest
 * t, into rows[] (m entries of room) in order of particle id; returns the count, (size_t)-1 when out of memory. */
size_t render_first_contacts(const double *t, const double *particle_id, size_t m, size_t *rows);
/* The radial profile of the coating from spray.h5 /particles (x n*3, d, state; state 1 deposited): `bins` annuli
 * of equal width around the spray axis out to the farthest deposited particle's edge, r_left[b] their inner
 * radii (m), *width their width (m), thickness[b] the deposited particle volume whose centre lies in the
 * annulus over the annulus area (m): the thickness of a fully dense layer (a porous coating of packing fraction
 * phi is 1/phi thicker).  Returns bins, or 0 when nothing is deposited. */
int render_thickness_profile(const double *x, const double *d, const double *state, size_t n, int bins, double *r_left,
                             double *thickness, double *width);
/* spray.h5 /deposit (open as `file`, named `path` in messages): the height map picture and, for a line or raster
 * path, the track's profile with its fit (render/deposit_figures.c); nothing for a fixed nozzle (pattern none). */
int render_deposit_figures(const struct render_request *req, hid_t file, const char *path, struct render_output *out);
/* The radius of the disc the spray of the open spray.h5 (`path` in messages) injected over, the figures' nozzle
 * exit: /nozzle's attribute injection_radius (with [nozzle] the exit's unless [spray] nozzle_radius was given: the
 * case text then holds the key's default, not the disc), else the case's nozzle_radius (a run without [nozzle], or
 * a spray.h5 written before the attribute). */
int render_injection_radius(hid_t file, const char *path, const struct case_file *c, double *radius);
/* 1 when the open spray.h5 is of a nozzle that moved ([path] pattern other than none: /deposit's attribute). */
int render_nozzle_moves(hid_t file);
/* The k-th (from 0) of a comma-separated list of labels (sweep.h5 x_labels), or k + 1 beyond its end. */
void render_nth_label(const char *list, size_t k, char *out, size_t size);
/* Of an open sweep.h5's `count` cells, those whose DE is a lower bound (in_flight_share above the file's
 * de_lower_bound_share) as *marks (count bytes, 1 or 0; free() it) and their number; none in a file without them. */
int render_sweep_lower_bounds(hid_t file, const char *path, size_t count, unsigned char **marks, size_t *marked);
/* Lazily create the renderer of the request's size. */
int render_renderer_get(const struct render_config *cfg, struct render_renderer **renderer);

/* The results table rows and the page. */
int render_write_report(const struct render_request *req, const struct render_output *out);

/* Figures go through core/atomic.h like every file: a PNG of the surface written atomically, and an SVG surface
 * whose bytes go to out's temporary file (atomic_publish it once the surface is finished, atomic_abort on
 * failure). */
int render_surface_write_png(cairo_surface_t *surface, const char *path);
/* Cairo's status as text, with the reason of a failed write (ENOSPC, EFBIG) when the stream writer saw one. */
const char *render_cairo_error(int status);
int render_svg_begin(const char *path, double width, double height, struct atomic_file *out, cairo_surface_t **surface);

#endif
