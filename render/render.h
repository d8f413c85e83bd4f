/* render: pictures of a run without a display (docs/architecture.md).
 *
 * 3-D: material points and spray particles drawn as lit spheres of their own size by OSMesa (llvmpipe, no
 * GPU, no display): each sphere is one instanced screen-aligned quad whose fragment shader discards the corners,
 * shades the sphere with a headlight and writes the sphere's depth, so 1e6 spheres cost 1e6 quads.  The
 * projection is orthographic and framed automatically from the bounding box; colours come from viridis; Cairo
 * draws the colour bar and the labels over the OSMesa buffer (an OSMESA_BGRA buffer is a Cairo ARGB32 surface)
 * and writes the PNG.  The same input gives the same bytes on the same machine.
 *
 * 2-D: Cairo plots (PNG and SVG) with axes, ticks, units and legends.
 *
 * The run: render_run_dir() draws whatever RUN_DIR holds (spray.h5, impact.h5, vcrit.h5) into RUN_DIR/figures/
 * and writes RUN_DIR/report.html.  All inputs are SI; figures show convenient multiples (um, ns, ms). */
#ifndef SPRAYCOAT_RENDER_H
#define SPRAYCOAT_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "core/config.h"

/* ---- colour map -------------------------------------------------------------------------------------------- */

/* viridis (van der Walt & Smith, matplotlib's 256-entry table, CC0): rgb in [0, 1] for t in [0, 1] (clamped), by
 * linear interpolation between the table's entries. */
#define RENDER_VIRIDIS_SIZE 256
void render_viridis(double t, double rgb[3]);
/* Entry i of the table (0 <= i < RENDER_VIRIDIS_SIZE). */
void render_viridis_entry(int i, double rgb[3]);

/* ---- images ------------------------------------------------------------------------------------------------ */

/* Pixels 0xAARRGGBB (Cairo ARGB32, opaque), row 0 at the top, `stride` bytes per row. */
struct render_image {
    int width, height, stride;
    uint32_t *pixels;
};
static inline uint32_t render_pixel(const struct render_image *im, int x, int y)
{
    return im->pixels[(size_t)y * (size_t)(im->stride / 4) + (size_t)x];
}
/* The background of 3-D scenes and plots. */
#define RENDER_BACKGROUND 0xFFFFFFFFu

/* ---- 3-D scenes of spheres --------------------------------------------------------------------------------- */

enum render_view {
    RENDER_VIEW_ISO,     /* from (+x, -y, +z), z up */
    RENDER_VIEW_SECTION, /* the half y >= section_y seen from -y: the cut through the impact axis, z up */
    RENDER_VIEW_TOP,     /* from +z looking down, x right, y up */
    RENDER_VIEW_SIDE,    /* from -y, x right, z up (the spray plume) */
    RENDER_VIEW_FACING,  /* from -z looking along +z (the deposit seen from the nozzle), x right, y down */
};

struct render_spheres {
    size_t count;
    const double *x;      /* centres, 3 per sphere (m) */
    const double *radius; /* per sphere (m), or NULL for common_radius */
    double common_radius; /* m */
    const double *value;  /* the coloured field, one per sphere */
};

/* A labelled polyline in the scene (the nozzle exit, the target line), drawn over the spheres. */
struct render_guide {
    const double *points; /* 3 per point (m) */
    int count;
    int closed;        /* 1: back to the first point */
    const char *label; /* next to the first point (NULL: none) */
    int label_below;   /* 1: below the first point, 0: above */
};

struct render_scene {
    enum render_view view;
    int width, height;       /* px */
    double vmin, vmax;       /* colour range: vmin -> viridis(0), vmax -> viridis(1) */
    const char *field_label; /* colour bar title, e.g. "effective plastic strain" */
    const char *unit;        /* e.g. "K", "-" */
    const char *caption;     /* top-left label, e.g. "t = 12.0 ns" (NULL: none) */
    double section_y;        /* RENDER_VIEW_SECTION: the cut plane y = section_y (m) */
    double min_pixel_radius; /* spheres are drawn at least this big (px), so that far views show something */
    /* decorations, all off when zero */
    int scale_bar; /* 1: a bar of a round length (nm, um or mm) at the bottom right of the scene */
    int axes;      /* 1: axes with ticks in mm along the bottom and the left (SIDE, FACING, TOP views) */
    int guide_count;
    const struct render_guide *guides;
    const double *frame; /* NULL, or lo[3] then hi[3] (m): the camera frames this box, not the spheres, so that
                            the frames of a film share one view and the guides are in the picture */
};

/* The radius a material point of a lattice of `spacing` is drawn with: spacing sqrt(3)/2, the radius at which
 * spheres on a cubic lattice fill space (a cube's centre is that far from its corners).  Spheres of half the
 * spacing only touch: along a lattice axis the background shows between every four of them, and once the body
 * stretches (an impact spreads the particle sideways by ~10 %) the gaps widen.  Under most of the body the
 * columns lean outward and their lower points hide the gaps, but no point ever crosses a mirror plane of a
 * symmetric impact (x = 0, y = 0): there the gaps line up into see-through lines that look like cracks.  At
 * sqrt(3)/2 no line of sight passes an undeformed lattice and a sideways stretch of up to 22 % stays closed; the
 * price is a silhouette 0.37 spacing larger on each side ([render] point_radius sets another radius). */
double render_point_radius(double spacing);

/* Orthographic camera: pixel (px, py) from the top-left corner of the image of a point x. */
struct render_camera {
    double right[3], up[3], toward[3]; /* unit vectors; toward points from the scene to the viewer */
    double center[3];                  /* the point at (px0, py0) */
    double pixels_per_metre, px0, py0;
    double depth_half; /* half the depth range (m) */
};

/* A scale bar's length: 1, 2 or 5 x 10^k metres, the largest not above `target` (m). */
double render_scale_length(double target);

/* The pixel box of the colour bar (x, y from the top-left) and of the region the scene is framed into. */
struct render_box {
    double x, y, width, height;
};
struct render_box render_colorbar_box(const struct render_scene *scene);
struct render_box render_scene_box(const struct render_scene *scene);

void render_camera_project(const struct render_camera *cam, const double x[3], double *px, double *py);

/* An OSMesa context with its buffer, reused from frame to frame. */
struct render_renderer;
int render_renderer_create(int width, int height, struct render_renderer **out);
void render_renderer_destroy(struct render_renderer *r);
/* Draw the spheres, the colour bar and the caption.  *image points into the renderer's buffer and stays valid
 * until the next draw.  cam (may be NULL) receives the camera used. */
int render_spheres_draw(struct render_renderer *r, const struct render_spheres *s, const struct render_scene *scene,
                        struct render_camera *cam, const struct render_image **image);
int render_image_write_png(const struct render_image *image, const char *path);

/* ---- 2-D plots: histograms (the plot writer itself is module-private, render/render_impl.h) ---------------- */

struct render_histogram {
    int bins;
    double lo, hi;   /* edges: lo + i (hi - lo) / bins */
    int64_t *counts; /* bins entries, values in [lo, hi) (hi itself in the last bin) */
    int64_t total;   /* values counted (sum of counts) */
    int64_t outside; /* values outside [lo, hi] or not finite */
};
/* Bin n values into `bins` bins over [lo, hi]; lo >= hi: the range of the finite values.  SC_ESIM when out of
 * memory. */
int render_histogram_fill(const double *values, size_t n, int bins, double lo, double hi, struct render_histogram *h);
void render_histogram_free(struct render_histogram *h);

/* ---- the render stage -------------------------------------------------------------------------------------- */

/* The keys of [render] (NULL-key terminated). */
extern const struct cfg_key render_case_keys[];

enum render_field { RENDER_EPS_P, RENDER_T, RENDER_D_BOND, RENDER_SPEED };

struct render_config {
    enum render_field field;
    enum render_view view; /* of the frame sequence */
    int width, height, plot_width, plot_height;
    long every;                  /* frames: every Nth snapshot (and the last); 0: none */
    double range_min, range_max; /* NAN: automatic (over the snapshots drawn) */
    double point_radius;         /* NAN: half the [impact] spacing of the run */
    int deposit_by_speed;        /* deposit colours: 0 diameter, 1 impact speed */
    int bins;
    double section_y;
};
/* Resolve [render]; SC_EINPUT with the standard message. */
int render_config_load(const struct case_file *c, struct render_config *cfg);

/* One row of the report's case summary. */
struct render_case_row {
    const char *section, *key, *value, *unit;
};

/* What render_run_dir drew: one entry per figure, with the data of the histograms, for checks. */
struct render_figure {
    char name[64]; /* file name without extension, in RUN_DIR/figures/ */
    char title[160];
    char group[32];                    /* "spray", "impact", "vcrit", "frames" */
    int is_plot;                       /* 1: .png and .svg; 0: .png only (3-D render) */
    struct render_histogram histogram; /* bins == 0 when not a histogram */
};
struct render_output {
    int count, capacity;
    struct render_figure *figures;
    int frames; /* frame-sequence PNGs written (not listed in figures) */
};
void render_output_free(struct render_output *out);
/* The figure named `name`, or NULL. */
const struct render_figure *render_output_find(const struct render_output *out, const char *name);

struct render_request {
    const char *run_dir;
    const struct render_config *cfg;
    const struct case_file *c;          /* for [powder] (the Weibull law) and the summary */
    const struct render_case_row *rows; /* case summary for the report */
    int row_count;
    uint64_t case_hash;
    /* the run's state for the report's warnings, from the caller: stages asked for and not done, inputs of another
     * build (each an HTML-free sentence) */
    const char *const *notices;
    int notice_count;
    /* files of run_dir ("impact.h5") neither drawn nor read for the report: another case's outputs of stages this
     * case does not have (app/render_stage.c), left in the directory by a run of that case */
    const char *const *ignored;
    int ignored_count;
};
/* Draw every figure the outputs in run_dir allow, then RUN_DIR/report.html.  SC_EIO when run_dir holds none of
 * spray.h5, impact.h5, vcrit.h5, or when one is malformed (the message names it); SC_EINPUT for a bad request. */
int render_run_dir(const struct render_request *req, struct render_output *out);

#endif
