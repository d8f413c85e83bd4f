/* Render benchmark (scripts/bench_render.sh): about 1e6 material points (a flattened sphere on a substrate slab,
 * spacing 0.25 um) drawn at 1920 x 1080 in the three views, each timed from the points in memory to the PNG on
 * disk.  With a path argument it also writes them as impact.h5 (one snapshot) for an end-to-end `spraycoat render`.
 * Prints one table row per view. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "app/app.h"
#include "core/config.h"
#include "core/error.h"
#include "core/h5io.h"
#include "render/render.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* Substrate 160 x 160 x 30 points and a sphere of radius 38 spacings squashed to half its height above it. */
static size_t make_points(double *x, double *eps, int64_t *body)
{
    const double h = 0.25e-6;
    size_t n = 0;
    for (int k = 0; k < 30; k++)
        for (int j = 0; j < 160; j++)
            for (int i = 0; i < 160; i++, n++) {
                x[3 * n] = (i - 80) * h, x[3 * n + 1] = (j - 80) * h, x[3 * n + 2] = -(k + 0.5) * h;
                double r = hypot(x[3 * n], x[3 * n + 1]) / (40 * h);
                eps[n] = 1.5 * exp(-r * r) * exp(-k / 8.0), body[n] = 0;
            }
    for (int k = -38; k <= 38; k++)
        for (int j = -38; j <= 38; j++)
            for (int i = -38; i <= 38; i++) {
                if (i * i + j * j + k * k > 38 * 38)
                    continue;
                double spread = 1.4 - 0.4 * (k + 38) / 76.0; /* wider at the bottom, as after impact */
                x[3 * n] = i * h * spread, x[3 * n + 1] = j * h * spread, x[3 * n + 2] = (k + 38.5) * h * 0.55;
                eps[n] = 0.2 + 2.5 * exp(-(k + 38) / 10.0) * (i * i + j * j) / (38.0 * 38.0), body[n] = 1;
                n++;
            }
    return n;
}

static int write_h5(const char *path, const double *x, const double *eps, const int64_t *body, size_t n,
                    uint64_t case_hash)
{
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    hid_t snapshots, g, series, summary;
    hsize_t dn[1] = {n}, d3[2] = {n, 3}, one[1] = {1}, two[2] = {1, 1};
    double zero = 0, *v = calloc(3 * n, sizeof *v);
    int64_t bonded = 1;
    int status = v ? h5_write_root_attributes(out.file, "spraycoat-impact", 1, "impact", case_hash) : SC_EIO;
    if (status == SC_OK && (status = h5_create_group(out.file, "snapshots", &snapshots)) == SC_OK) {
        if ((status = h5_create_group(snapshots, "000000", &g)) == SC_OK) {
            status = h5_write_doubles(g, "x", 2, d3, x, "m", 0);
            if (status == SC_OK)
                status = h5_write_doubles(g, "v", 2, d3, v, "m/s", 0);
            if (status == SC_OK)
                status = h5_write_doubles(g, "eps_p", 1, dn, eps, "-", 0);
            if (status == SC_OK)
                status = h5_write_int64s(g, "body", 1, dn, body, "-", 0);
            if (status == SC_OK)
                status = h5_attr_write_double(g, "t", 40e-9);
            H5Gclose(g);
        }
        H5Gclose(snapshots);
    }
    const char *per_body[] = {"pbcp", "v_rest", "ke", "plastic_work"};
    if (status == SC_OK && (status = h5_create_group(out.file, "series", &series)) == SC_OK) {
        status = h5_write_doubles(series, "t", 1, one, &zero, "s", 0);
        for (int f = 0; status == SC_OK && f < 4; f++)
            status = h5_write_doubles(series, per_body[f], 2, two, &zero, "-", 0);
        if (status == SC_OK)
            status = h5_write_doubles(series, "energy_total", 1, one, &zero, "J", 0);
        H5Gclose(series);
    }
    const char *summary_fields[] = {"diameter", "v_impact", "pbcp", "v_rest", "cor"};
    if (status == SC_OK && (status = h5_create_group(out.file, "summary", &summary)) == SC_OK) {
        for (int f = 0; status == SC_OK && f < 5; f++)
            status = h5_write_doubles(summary, summary_fields[f], 1, one, &zero, "-", 0);
        if (status == SC_OK)
            status = h5_write_int64s(summary, "bonded", 1, one, &bonded, "-", 0);
        H5Gclose(summary);
    }
    free(v);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    return h5_commit(&out);
}

int main(int argc, char **argv)
{
    h5_quiet();
    size_t capacity = 160 * 160 * 30 + 77 * 77 * 77;
    double *x = malloc(3 * capacity * sizeof *x), *eps = malloc(capacity * sizeof *eps);
    int64_t *body = malloc(capacity * sizeof *body);
    size_t n = make_points(x, eps, body);
    const char *dir = argc > 1 ? argv[1] : "/tmp";
    /* the case `spraycoat render` is then run with: impact.h5 carries its impact stage's hash, or render refuses
     * it as another case's */
    uint64_t case_hash = 0;
    if (argc > 2) {
        struct case_file *c;
        if (case_load(argv[2], spraycoat_registry, &c) != SC_OK) {
            fprintf(stderr, "render_bench: %s\n", sc_error_message());
            return 2;
        }
        struct stage_context ctx = {.c = c};
        case_hash = stage_hash(&ctx, "impact");
        case_free(c);
    }
    char path[4200];
    struct render_renderer *r;
    double t0 = now();
    if (render_renderer_create(1920, 1080, &r) != SC_OK) {
        fprintf(stderr, "render_bench: %s\n", sc_error_message());
        return 3;
    }
    printf("| %-24s | %9zu | %9s | %8.3f |\n", "OSMesa context + shaders", n, "-", now() - t0);
    static const enum render_view views[] = {RENDER_VIEW_ISO, RENDER_VIEW_SECTION, RENDER_VIEW_TOP};
    static const char *const names[] = {"iso", "section", "top"};
    struct render_spheres spheres = {n, x, NULL, 0.125e-6, eps};
    for (int v = 0; v < 3; v++) {
        struct render_scene scene = {
            views[v], 1920, 1080, 0, 2.7, "effective plastic strain", "-", "t = 40.00 ns", 0, 0.5, 1, 0, 0, NULL, NULL};
        const struct render_image *image;
        double start = now();
        int status = render_spheres_draw(r, &spheres, &scene, NULL, &image);
        double drawn = now();
        snprintf(path, sizeof path, "%s/render_bench_%s.png", dir, names[v]);
        if (status == SC_OK)
            status = render_image_write_png(image, path);
        if (status != SC_OK) {
            fprintf(stderr, "render_bench: %s\n", sc_error_message());
            return 3;
        }
        printf("| %-24s | %9zu | %9.3f | %8.3f |\n", names[v], n, drawn - start, now() - start);
    }
    render_renderer_destroy(r);
    snprintf(path, sizeof path, "%s/impact.h5", dir);
    int status = argc > 1 ? write_h5(path, x, eps, body, n, case_hash) : SC_OK;
    free(x), free(eps), free(body);
    if (status != SC_OK)
        fprintf(stderr, "render_bench: %s\n", sc_error_message());
    return status;
}
