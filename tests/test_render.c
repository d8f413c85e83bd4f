/* render/: the viridis table, and synthetic scenes with known field gradients drawn by OSMesa: the colour at each
 * sphere's projected centre is the colour map's colour for its value, the background is the background, the
 * colour bar is where render_colorbar_box says and runs from viridis(0) at the bottom to viridis(1) at the top,
 * the section view shows the cut face, and the same input gives the same pixels. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "core/error.h"
#include "render/render.h"

#define WIDTH  640
#define HEIGHT 360

static void channels(uint32_t pixel, int rgb[3])
{
    rgb[0] = (int)((pixel >> 16) & 255), rgb[1] = (int)((pixel >> 8) & 255), rgb[2] = (int)(pixel & 255);
}

/* The largest channel difference between a pixel and a colour in [0, 1]. */
static int colour_error(uint32_t pixel, const double rgb[3])
{
    int c[3], worst = 0;
    channels(pixel, c);
    for (int k = 0; k < 3; k++) {
        int d = abs(c[k] - (int)lround(255 * rgb[k]));
        worst = d > worst ? d : worst;
    }
    return worst;
}

/* matplotlib's published entries 0, 128 and 255 */
static void test_viridis_table(void)
{
    static const double expected[3][3] = {
        {0.267004, 0.004874, 0.329415}, {0.127568, 0.566949, 0.550556}, {0.993248, 0.906157, 0.143936}};
    static const int index[3] = {0, 128, 255};
    for (int i = 0; i < 3; i++) {
        double rgb[3];
        render_viridis_entry(index[i], rgb);
        for (int k = 0; k < 3; k++)
            CHECK_CLOSE(rgb[k], expected[i][k], 0, 1e-9, "viridis table entry");
    }
    double lo[3], hi[3], a[3], b[3], mid[3];
    render_viridis(0, lo), render_viridis(1, hi), render_viridis(127.5 / 255, mid);
    render_viridis_entry(127, a), render_viridis_entry(128, b);
    for (int k = 0; k < 3; k++) {
        CHECK_CLOSE(lo[k], expected[0][k], 0, 1e-12, "viridis(0) is entry 0");
        CHECK_CLOSE(hi[k], expected[2][k], 0, 1e-12, "viridis(1) is entry 255");
        CHECK_CLOSE(mid[k], 0.5 * (a[k] + b[k]), 0, 1e-12, "viridis between entries interpolates");
    }
}

/* A flat 16 x 8 sheet of spheres in z = 0, value = x: a gradient across the picture. */
struct sheet {
    double x[3 * 128], value[128];
    size_t count;
};

static void make_sheet(struct sheet *s)
{
    s->count = 0;
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 16; i++) {
            double *x = s->x + 3 * s->count;
            x[0] = i * 1e-6, x[1] = j * 1e-6, x[2] = 0;
            s->value[s->count++] = 3.0 + 0.5 * i; /* 3 to 10.5 */
        }
}

static struct render_scene top_scene(void)
{
    return (struct render_scene){RENDER_VIEW_TOP,
                                 WIDTH,
                                 HEIGHT,
                                 3.0,
                                 10.5,
                                 "effective plastic strain",
                                 "-",
                                 "t = 1.00 ns",
                                 0,
                                 0.5,
                                 0,
                                 0,
                                 0,
                                 NULL,
                                 NULL};
}

static void test_gradient_colours(void)
{
    struct sheet s;
    make_sheet(&s);
    struct render_spheres spheres = {s.count, s.x, NULL, 0.5e-6, s.value};
    struct render_scene scene = top_scene();
    struct render_renderer *r;
    if (render_renderer_create(WIDTH, HEIGHT, &r) != SC_OK) {
        CHECK(0, "renderer: %s", sc_error_message());
        return;
    }
    struct render_camera cam;
    const struct render_image *image;
    CHECK(render_spheres_draw(r, &spheres, &scene, &cam, &image) == SC_OK, "draw: %s", sc_error_message());
    CHECK(image->width == WIDTH && image->height == HEIGHT, "image %d x %d", image->width, image->height);
    CHECK(cam.pixels_per_metre * 0.5e-6 > 5, "spheres of %.2f px radius are not points", cam.pixels_per_metre * 0.5e-6);
    int worst = 0;
    for (size_t i = 0; i < s.count; i++) {
        double px, py, rgb[3];
        render_camera_project(&cam, s.x + 3 * i, &px, &py);
        render_viridis((s.value[i] - 3.0) / 7.5, rgb);
        int e = colour_error(render_pixel(image, (int)px, (int)py), rgb);
        worst = e > worst ? e : worst;
    }
    CHECK(worst <= 3, "sphere centres differ from viridis by up to %d levels of 255", worst);
    /* x grows to the right in the top view: the left column is darker than the right one */
    double left[3], right[3];
    render_camera_project(&cam, s.x, &left[0], &left[1]);
    render_camera_project(&cam, s.x + 3 * 15, &right[0], &right[1]);
    CHECK(right[0] > left[0], "top view: +x to the right (%.1f, %.1f)", left[0], right[0]);
    /* background: the corners of the scene box and a point between sheet and colour bar */
    struct render_box box = render_scene_box(&scene);
    CHECK(render_pixel(image, (int)box.x + 2, (int)(box.y + box.height) - 2) == RENDER_BACKGROUND,
          "bottom-left of the scene is background");
    double beyond[3] = {20e-6, 3.5e-6, 0}, bx, by;
    render_camera_project(&cam, beyond, &bx, &by);
    CHECK(render_pixel(image, (int)bx, (int)by) == RENDER_BACKGROUND, "right of the sheet is background");
    /* the colour bar: viridis(f) at height f, background just left of it */
    struct render_box bar = render_colorbar_box(&scene);
    for (int k = 1; k < 10; k++) {
        double f = k / 10.0, rgb[3];
        render_viridis(f, rgb);
        int x = (int)(bar.x + 0.5 * bar.width), y = (int)(bar.y + (1 - f) * bar.height);
        CHECK(colour_error(render_pixel(image, x, y), rgb) <= 4, "colour bar at %.1f: pixel %06x", f,
              render_pixel(image, x, y) & 0xffffff);
    }
    CHECK(render_pixel(image, (int)bar.x - 3, (int)(bar.y + 0.5 * bar.height)) == RENDER_BACKGROUND,
          "left of the colour bar is background");
    render_renderer_destroy(r);
}

/* A 12 x 6 x 12 block with value = y; the section keeps y >= 0 and looks along +y, so the cut face (y = 0) is what
 * shows: every visible centre has the colour of the y = 0 layer, not of the hidden y < 0 half. */
static void test_section_shows_cut_face(void)
{
    enum { NX = 12, NY = 6, NZ = 12, N = NX * NY * NZ };
    double *x = malloc(3 * N * sizeof *x), *value = malloc(N * sizeof *value);
    size_t n = 0;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++, n++) {
                x[3 * n] = (i - NX / 2) * 1e-6, x[3 * n + 1] = (j - NY / 2) * 1e-6, x[3 * n + 2] = -k * 1e-6;
                value[n] = x[3 * n + 1] * 1e6; /* -3 .. 2 */
            }
    struct render_spheres spheres = {N, x, NULL, 0.5e-6, value};
    struct render_scene scene = {
        RENDER_VIEW_SECTION, WIDTH, HEIGHT, -3, 2, "y", "um", NULL, 0, 0.5, 0, 0, 0, NULL, NULL};
    struct render_renderer *r;
    if (render_renderer_create(WIDTH, HEIGHT, &r) != SC_OK) {
        CHECK(0, "renderer: %s", sc_error_message());
        free(x), free(value);
        return;
    }
    struct render_camera cam;
    const struct render_image *image;
    CHECK(render_spheres_draw(r, &spheres, &scene, &cam, &image) == SC_OK, "draw: %s", sc_error_message());
    double face[3];
    render_viridis(3.0 / 5.0, face); /* y = 0 */
    int worst = 0, checked = 0;
    for (size_t q = 0; q < N; q++) {
        if (x[3 * q + 1] != 0)
            continue;
        double px, py;
        render_camera_project(&cam, x + 3 * q, &px, &py);
        int e = colour_error(render_pixel(image, (int)px, (int)py), face);
        worst = e > worst ? e : worst;
        checked++;
    }
    CHECK(checked == NX * NZ, "%d cut-face spheres", checked);
    CHECK(worst <= 3, "cut face differs from viridis(y = 0) by up to %d levels", worst);
    /* the camera frames only the kept half: its centre has y >= 0 */
    CHECK(cam.center[1] >= 0, "section frames y >= 0 (centre y %.3g)", cam.center[1]);
    render_renderer_destroy(r);
    free(x), free(value);
}

static void test_same_input_same_pixels(void)
{
    struct sheet s;
    make_sheet(&s);
    struct render_spheres spheres = {s.count, s.x, NULL, 0.5e-6, s.value};
    struct render_scene scene = top_scene();
    scene.view = RENDER_VIEW_ISO;
    struct render_renderer *r;
    if (render_renderer_create(WIDTH, HEIGHT, &r) != SC_OK) {
        CHECK(0, "renderer: %s", sc_error_message());
        return;
    }
    const struct render_image *image;
    size_t bytes = (size_t)HEIGHT * WIDTH * 4;
    uint32_t *first = malloc(bytes);
    CHECK(render_spheres_draw(r, &spheres, &scene, NULL, &image) == SC_OK, "draw: %s", sc_error_message());
    memcpy(first, image->pixels, bytes);
    scene.view = RENDER_VIEW_TOP; /* something else in between */
    CHECK(render_spheres_draw(r, &spheres, &scene, NULL, &image) == SC_OK, "draw: %s", sc_error_message());
    scene.view = RENDER_VIEW_ISO;
    CHECK(render_spheres_draw(r, &spheres, &scene, NULL, &image) == SC_OK, "draw: %s", sc_error_message());
    CHECK(memcmp(first, image->pixels, bytes) == 0, "the same scene drawn twice differs");
    free(first);
    render_renderer_destroy(r);
}

/* Luminance (0-255) of a pixel. */
static double luminance(uint32_t pixel)
{
    int c[3];
    channels(pixel, c);
    return 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2];
}

/* Mean luminance of the pixels (x0..x1, y0..y1) inclusive. */
static double mean_luminance(const struct render_image *im, int x0, int x1, int y0, int y1)
{
    double sum = 0;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++)
            sum += luminance(render_pixel(im, x, y));
    return sum / ((x1 - x0 + 1) * (y1 - y0 + 1));
}

/* The cracks of the impact pictures (issue 23): a 16 x 16 x 8 lattice of spacing h centred on the axis, as the
 * impact stage seeds it (points at (i + 1/2) h), spread sideways like a flattened particle: the top layer by 10 %,
 * each lower layer 3 % more.  Seen from the top with the radius the impact pictures use, the block is solid (no
 * background inside the top layer's footprint) and the pixel column at x = 0 and the row at y = 0 are within the
 * spread of the other columns and rows: no point crosses the mirror planes, so with spheres of h/2 these were
 * see-through lines of background. */
static void test_no_lines_on_mirror_planes(void)
{
    enum { NX = 16, NZ = 8, N = NX * NX * NZ };
    const double h = 1e-6;
    double *x = malloc(3 * N * sizeof *x), *value = malloc(N * sizeof *value);
    size_t n = 0;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NX; j++)
            for (int i = 0; i < NX; i++, n++) {
                double stretch = 1.10 + 0.03 * k;
                x[3 * n] = (i - NX / 2 + 0.5) * h * stretch, x[3 * n + 1] = (j - NX / 2 + 0.5) * h * stretch;
                x[3 * n + 2] = -(k + 0.5) * h;
                value[n] = 0.5;
            }
    struct render_spheres spheres = {N, x, NULL, render_point_radius(h), value};
    struct render_scene scene = {RENDER_VIEW_TOP, WIDTH, HEIGHT, 0, 1, "value", "-", NULL, 0, 0.5, 0, 0, 0, NULL, NULL};
    struct render_renderer *r;
    if (render_renderer_create(WIDTH, HEIGHT, &r) != SC_OK) {
        CHECK(0, "renderer: %s", sc_error_message());
        free(x), free(value);
        return;
    }
    struct render_camera cam;
    const struct render_image *image;
    CHECK(render_spheres_draw(r, &spheres, &scene, &cam, &image) == SC_OK, "draw: %s", sc_error_message());
    /* the top layer's footprint: its outermost centres */
    double corner_lo[3] = {x[0], x[1], 0}, corner_hi[3] = {x[3 * (NX * NX - 1)], x[3 * (NX * NX - 1) + 1], 0};
    double ax, ay, bx, by, ox, oy, origin[3] = {0, 0, 0};
    render_camera_project(&cam, corner_lo, &ax, &ay);
    render_camera_project(&cam, corner_hi, &bx, &by);
    render_camera_project(&cam, origin, &ox, &oy);
    int x0 = (int)ceil(fmin(ax, bx)), x1 = (int)floor(fmax(ax, bx)), y0 = (int)ceil(fmin(ay, by)),
        y1 = (int)floor(fmax(ay, by));
    int holes = 0;
    for (int py = y0; py <= y1; py++)
        for (int px = x0; px <= x1; px++)
            holes += render_pixel(image, px, py) == RENDER_BACKGROUND;
    CHECK(holes == 0, "%d background pixels inside the block's top face (%d x %d px)", holes, x1 - x0 + 1, y1 - y0 + 1);
    /* the column through x = 0 against every other column at least 2 px away from it; the same for rows */
    int cx = (int)floor(ox), cy = (int)floor(oy);
    double lo = INFINITY, hi = -INFINITY;
    for (int px = x0; px <= x1; px++)
        if (abs(px - cx) > 2) {
            double m = mean_luminance(image, px, px, y0, y1);
            lo = fmin(lo, m), hi = fmax(hi, m);
        }
    double at_zero = mean_luminance(image, cx, cx, y0, y1);
    CHECK(at_zero >= lo && at_zero <= hi, "column x = 0: mean luminance %.1f outside the other columns' %.1f to %.1f",
          at_zero, lo, hi);
    lo = INFINITY, hi = -INFINITY;
    for (int py = y0; py <= y1; py++)
        if (abs(py - cy) > 2) {
            double m = mean_luminance(image, x0, x1, py, py);
            lo = fmin(lo, m), hi = fmax(hi, m);
        }
    at_zero = mean_luminance(image, x0, x1, cy, cy);
    CHECK(at_zero >= lo && at_zero <= hi, "row y = 0: mean luminance %.1f outside the other rows' %.1f to %.1f",
          at_zero, lo, hi);
    render_renderer_destroy(r);
    free(x), free(value);
}

/* Decorations: on a side view framed on a box (the plume picture), the guide (a nozzle-exit line) is drawn where
 * the camera puts it, and the scale bar is as long as its label says: its longest black horizontal run in the
 * scene's bottom band is render_scale_length(a fifth of the scene's width) x pixels per metre, to 2 px. */
static void test_guides_and_scale_bar(void)
{
    double x[3 * 3] = {0, 0, 0.002, 0.001, 0, 0.010, -0.001, 0, 0.020}, value[3] = {0, 0.5, 1};
    double radius[3] = {1e-4, 1e-4, 1e-4}, line[6] = {-0.003, 0, 0, 0.003, 0, 0};
    double frame[6] = {-0.008, 0, -0.001, 0.008, 0, 0.031};
    struct render_guide nozzle = {line, 2, 0, "nozzle exit", 1};
    struct render_spheres spheres = {3, x, radius, 0, value};
    struct render_scene scene = {RENDER_VIEW_SIDE, WIDTH, HEIGHT, 0, 1, "speed", "m/s", NULL, 0, 2.0, 1, 1, 1,
                                 &nozzle,          frame};
    struct render_renderer *r;
    if (render_renderer_create(WIDTH, HEIGHT, &r) != SC_OK) {
        CHECK(0, "renderer: %s", sc_error_message());
        return;
    }
    struct render_camera cam;
    const struct render_image *image;
    CHECK(render_spheres_draw(r, &spheres, &scene, &cam, &image) == SC_OK, "draw: %s", sc_error_message());
    /* the frame box, not the spheres, sets the scale: 16 mm wide or 32 mm high into the scene box */
    struct render_box box = render_scene_box(&scene);
    double expected = 0.92 * fmin(box.width / 0.016, box.height / 0.032);
    CHECK_CLOSE(cam.pixels_per_metre, expected, 1e-9, 0, "pixels per metre of the frame box");
    double mid[3] = {0.0015, 0, 0}, px, py;
    render_camera_project(&cam, mid, &px, &py);
    uint32_t pixel = render_pixel(image, (int)px, (int)py);
    int c[3];
    channels(pixel, c);
    CHECK(c[0] > 150 && c[1] < 90 && c[2] < 90, "guide at (%.0f, %.0f) is %06x, not the guides' red", px, py,
          pixel & 0xffffff);
    double bar_m = render_scale_length(0.2 * box.width / cam.pixels_per_metre);
    int longest = 0;
    for (int y = (int)(box.y + 0.8 * box.height); y < (int)(box.y + box.height); y++) {
        int run = 0;
        for (int xpix = (int)(box.x + 0.5 * box.width); xpix < (int)(box.x + box.width); xpix++) {
            run = (render_pixel(image, xpix, y) & 0xffffff) == 0 ? run + 1 : 0;
            longest = run > longest ? run : longest;
        }
    }
    CHECK(fabs(longest - bar_m * cam.pixels_per_metre) <= 2, "scale bar %d px, %g m is %.1f px", longest, bar_m,
          bar_m * cam.pixels_per_metre);
    CHECK_CLOSE(render_scale_length(0.0042), 0.002, 1e-12, 0, "round length below 4.2 mm");
    CHECK_CLOSE(render_scale_length(7e-6), 5e-6, 1e-12, 0, "round length below 7 um");
    CHECK_CLOSE(render_scale_length(1e-3), 1e-3, 1e-12, 0, "round length below 1 mm");
    render_renderer_destroy(r);
}

static void test_histogram(void)
{
    double values[] = {0, 0.5, 1, 1.5, 2, 2.5, 3, 3.5, 4, NAN};
    struct render_histogram h;
    CHECK(render_histogram_fill(values, 10, 4, 0, 4, &h) == SC_OK, "fill");
    CHECK(h.total == 9 && h.outside == 1, "total %lld, outside %lld", (long long)h.total, (long long)h.outside);
    CHECK(h.counts[0] == 2 && h.counts[1] == 2 && h.counts[2] == 2 && h.counts[3] == 3, "counts %lld %lld %lld %lld",
          (long long)h.counts[0], (long long)h.counts[1], (long long)h.counts[2], (long long)h.counts[3]);
    render_histogram_free(&h);
    CHECK(render_histogram_fill(values, 9, 3, 0, 0, &h) == SC_OK, "fill, automatic range");
    CHECK(h.lo == 0 && h.hi == 4 && h.total == 9, "automatic range [%g, %g], total %lld", h.lo, h.hi,
          (long long)h.total);
    render_histogram_free(&h);
}

int main(void)
{
    RUN(test_viridis_table);
    RUN(test_gradient_colours);
    RUN(test_section_shows_cut_face);
    RUN(test_same_input_same_pixels);
    RUN(test_no_lines_on_mirror_planes);
    RUN(test_guides_and_scale_bar);
    RUN(test_histogram);
    return check_finish();
}
