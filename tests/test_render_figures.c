/* The render stage on a small run: a real spray stage (300 particles), an impact.h5 with two runs in /run_NNNN
 * groups and a vcrit.h5 written here.  Every figure exists with the requested size and is not blank, the plotted
 * histograms hold the run's data (counts sum to the particles and to the particles with a contact, one first
 * impact each, in spray.h5), the frame
 * sequence follows `every`, the report names every figure, and missing or damaged inputs are I/O errors. */
#include <cairo.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "case_fixture.h"
#include "check.h"
#include "core/error.h"
#include "core/h5io.h"
#include "app/app.h"
#include "render/render.h"
/* A white-box test: includes the module-private header render/render_impl.h (render_injection_radius, the nozzle
 * disc the spray figures draw; only tests may: tests/test_symbols.sh). */
#include "render/render_impl.h"

static const char ini[] =
    "[run]\nseed = 3\n"
    "[spray]\ndt = 1e-6\nt_end = 3e-3\nfeed_count = 20\nfeed_every = 10\nmax_injected = 300\n"
    "nozzle_radius = 0.005\nrelease_speed_min = 20\nrelease_speed_max = 60\nrelease_cone = 2\n"
    "domain_radius = 0.03\nhandoff_height = 0.005\nmetrics_every = 100\nsnapshot_every = 5e-4\n"
    "[powder]\ndistribution = weibull\nmedian_diameter = 40e-6\nshape = 3.5\nd_min = 10e-6\nd_max = 100e-6\n"
    "[target]\nstandoff = 0.03\ndeposit_radius = 0.005\n"
    "[jet]\nmodel = bickley\nC1 = 30\nC3 = 20\nvirtual_origin = 0.05\ncore_length = 0.005\n"
    "[deposition]\nrule = adhesion\nalpha_adh = 10000\n"
    "[render]\nwidth = 320\nheight = 200\nplot_width = 400\nplot_height = 250\nevery = 2\nbins = 12\n"
    "point_radius = 0.5e-6\n";

#define SNAPSHOTS 4
#define POINTS    60
#define STEPS     5
#define BODIES    2

/* Snapshot k of a run: a 5 x 4 x 3 block sinking by k um, eps_p growing with depth and time. */
static int write_snapshot(hid_t snapshots, int k)
{
    char name[16];
    snprintf(name, sizeof name, "%06d", k);
    hid_t g;
    SC_TRY(h5_create_group(snapshots, name, &g));
    double x[3 * POINTS], v[3 * POINTS], eps[POINTS], T[POINTS], D[POINTS];
    int64_t body[POINTS];
    for (int q = 0; q < POINTS; q++) {
        x[3 * q] = (q % 5) * 1e-6, x[3 * q + 1] = (q / 5 % 4) * 1e-6, x[3 * q + 2] = (q / 20) * 1e-6 - k * 1e-6;
        v[3 * q] = 0, v[3 * q + 1] = 0, v[3 * q + 2] = -100.0 * (SNAPSHOTS - k);
        eps[q] = 0.1 * k * (1 + q / 20), T[q] = 300 + 10 * k, D[q] = 0.1 * k, body[q] = q / 20 == 0 ? 0 : 1;
    }
    hsize_t n[1] = {POINTS}, n3[2] = {POINTS, 3};
    int status = h5_write_doubles(g, "x", 2, n3, x, "m", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "v", 2, n3, v, "m/s", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "eps_p", 1, n, eps, "-", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "T", 1, n, T, "K", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "D_bond", 1, n, D, "-", 0);
    if (status == SC_OK)
        status = h5_write_int64s(g, "body", 1, n, body, "-", 0);
    if (status == SC_OK)
        status = h5_attr_write_double(g, "t", k * 1e-9);
    H5Gclose(g);
    return status;
}

static int write_series(hid_t run)
{
    hid_t g;
    SC_TRY(h5_create_group(run, "series", &g));
    double t[STEPS], per_body[STEPS * BODIES], total[STEPS];
    for (int i = 0; i < STEPS; i++) {
        t[i] = i * 1e-9, total[i] = 1e-6;
        for (int b = 0; b < BODIES; b++)
            per_body[i * BODIES + b] = 0.01 * i * (b + 1);
    }
    hsize_t nt[1] = {STEPS}, ntb[2] = {STEPS, BODIES};
    int status = h5_write_doubles(g, "t", 1, nt, t, "s", 0);
    const char *names[] = {"pbcp", "v_rest", "ke", "plastic_work", "internal_energy"};
    for (int f = 0; status == SC_OK && f < 5; f++)
        status = h5_write_doubles(g, names[f], 2, ntb, per_body, "-", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "energy_total", 1, nt, total, "J", 0);
    H5Gclose(g);
    return status;
}

static int write_summary(hid_t run)
{
    hid_t g;
    SC_TRY(h5_create_group(run, "summary", &g));
    double d[BODIES] = {30e-6, 10e-6}, v[BODIES] = {0, 800}, pbcp[BODIES] = {0, 0.2}, vr[BODIES] = {0, 1};
    double cor[BODIES] = {NAN, 0.001};
    int64_t bonded[BODIES] = {-1, 1}, substrate[BODIES] = {1, 0};
    hsize_t nb[1] = {BODIES};
    int status = h5_write_doubles(g, "diameter", 1, nb, d, "m", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "v_impact", 1, nb, v, "m/s", 0);
    if (status == SC_OK)
        status = h5_write_int64s(g, "bonded", 1, nb, bonded, "-", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "pbcp", 1, nb, pbcp, "-", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "v_rest", 1, nb, vr, "m/s", 0);
    if (status == SC_OK)
        status = h5_write_doubles(g, "cor", 1, nb, cor, "-", 0);
    if (status == SC_OK)
        status = h5_write_int64s(g, "substrate", 1, nb, substrate, "-", 0);
    H5Gclose(g);
    return status;
}

static int write_run(hid_t file, const char *name)
{
    hid_t run, snapshots;
    SC_TRY(h5_create_group(file, name, &run));
    int status = write_series(run);
    if (status == SC_OK)
        status = write_summary(run);
    if (status == SC_OK)
        status = h5_create_group(run, "snapshots", &snapshots);
    for (int k = 0; status == SC_OK && k < SNAPSHOTS; k++)
        status = write_snapshot(snapshots, k);
    if (status == SC_OK)
        H5Gclose(snapshots);
    H5Gclose(run);
    return status;
}

static int write_impact(const char *dir)
{
    char path[256];
    snprintf(path, sizeof path, "%s/impact.h5", dir);
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    int status = h5_write_root_attributes(out.file, "spraycoat-impact", 1, "impact", 0);
    if (status == SC_OK)
        status = write_run(out.file, "run_0001");
    if (status == SC_OK)
        status = write_run(out.file, "run_0002");
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    return h5_commit(&out);
}

static int write_vcrit(const char *dir)
{
    char path[256];
    snprintf(path, sizeof path, "%s/vcrit.h5", dir);
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    double d[2] = {14e-6, 30e-6}, v[2] = {830, 770}, p[2] = {0.05, 0.06}, vr[2] = {0.5, 0.4};
    double velocity[3] = {700, 900, 830};
    int64_t bonded[3] = {0, 1, 1};
    hsize_t n[1] = {2}, m[1] = {3};
    hid_t search, run;
    int status = h5_write_root_attributes(out.file, "spraycoat-vcrit", 1, "vcrit", 0);
    if (status == SC_OK)
        status = h5_write_doubles(out.file, "diameter", 1, n, d, "m", 0);
    if (status == SC_OK)
        status = h5_write_doubles(out.file, "v_crit", 1, n, v, "m/s", 0);
    if (status == SC_OK)
        status = h5_write_doubles(out.file, "pbcp", 1, n, p, "-", 0);
    if (status == SC_OK)
        status = h5_write_doubles(out.file, "v_rest", 1, n, vr, "m/s", 0);
    if (status == SC_OK && (status = h5_create_group(out.file, "search", &search)) == SC_OK) {
        if ((status = h5_create_group(search, "000", &run)) == SC_OK) {
            status = h5_write_doubles(run, "velocity", 1, m, velocity, "m/s", 0);
            if (status == SC_OK)
                status = h5_write_int64s(run, "bonded", 1, m, bonded, "-", 0);
            if (status == SC_OK)
                status = h5_attr_write_double(run, "diameter", 14e-6);
            H5Gclose(run);
        }
        H5Gclose(search);
    }
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    return h5_commit(&out);
}

/* Width, height and the number of distinct pixel values of a PNG (0 when it cannot be read). */
static int png_facts(const char *path, int *width, int *height)
{
    cairo_surface_t *s = cairo_image_surface_create_from_png(path);
    int distinct = 0;
    *width = *height = 0;
    if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
        *width = cairo_image_surface_get_width(s), *height = cairo_image_surface_get_height(s);
        const uint32_t *p = (const uint32_t *)cairo_image_surface_get_data(s);
        int stride = cairo_image_surface_get_stride(s) / 4;
        uint32_t first = p[0];
        distinct = 1;
        for (int y = 0; y < *height && distinct == 1; y++)
            for (int x = 0; x < *width; x++)
                if (p[y * stride + x] != first) {
                    distinct = 2;
                    break;
                }
    }
    cairo_surface_destroy(s);
    return distinct;
}

static long file_size(const char *path)
{
    struct stat info;
    return stat(path, &info) == 0 ? (long)info.st_size : -1;
}

struct fixture {
    char dir[64];
    struct case_file *c;
    struct render_config cfg;
};

static int fixture_open(struct fixture *f)
{
    if (case_fixture_write(f->dir, ini, NULL, NULL, NULL, NULL) != 0)
        return -1;
    int status = case_fixture_load(f->dir, spraycoat_registry, &f->c);
    if (status == SC_OK)
        status = render_config_load(f->c, &f->cfg);
    if (status == SC_OK)
        status = run_dir_prepare(f->dir, f->c);
    if (status != SC_OK)
        printf("  fixture: %s\n", sc_error_message());
    return status;
}

/* Particles with at least one contact in /impacts: the first impacts the histograms count. */
static int64_t count_first_impacts(const char *dir)
{
    char path[256];
    snprintf(path, sizeof path, "%s/spray.h5", dir);
    hid_t file;
    size_t n = 0, m = 0;
    int64_t count = -1;
    if (h5_open_read(path, &file) != SC_OK)
        return -1;
    if (h5_dataset_size(file, "impacts/particle_id", &n) == SC_OK &&
        h5_dataset_size(file, "particles/id", &m) == SC_OK) {
        int64_t *id = malloc((n + 1) * sizeof *id);
        char *seen = calloc(n + m + 1, 1);
        if (id && seen && h5_read_int64s(file, "impacts/particle_id", id, n) == SC_OK) {
            count = 0;
            for (size_t i = 0; i < n; i++) {
                if (id[i] < 0 || (size_t)id[i] > n + m)
                    continue;
                count += !seen[id[i]];
                seen[id[i]] = 1;
            }
        }
        free(id);
        free(seen);
    }
    H5Fclose(file);
    return count;
}

static size_t count_particles(const char *dir)
{
    char path[256];
    snprintf(path, sizeof path, "%s/spray.h5", dir);
    hid_t file;
    size_t n = 0;
    if (h5_open_read(path, &file) == SC_OK) {
        h5_dataset_size(file, "particles/d", &n);
        H5Fclose(file);
    }
    return n;
}

/* The count attribute of spray.h5 /snapshots (-1 when absent). */
static int64_t count_spray_snapshots(const char *dir)
{
    char path[256];
    snprintf(path, sizeof path, "%s/spray.h5", dir);
    hid_t file, group;
    int64_t n = -1;
    if (h5_open_read(path, &file) == SC_OK) {
        if ((group = H5Gopen2(file, "snapshots", H5P_DEFAULT)) >= 0) {
            h5_attr_read_int64(group, "count", &n);
            H5Gclose(group);
        }
        H5Fclose(file);
    }
    sc_error_clear();
    return n;
}

static void check_figures(const struct fixture *f, const struct render_output *out)
{
    for (int i = 0; i < out->count; i++) {
        const struct render_figure *fig = &out->figures[i];
        char path[256];
        snprintf(path, sizeof path, "%s/figures/%s.png", f->dir, fig->name);
        int w, h, distinct = png_facts(path, &w, &h);
        int want_w = fig->is_plot ? f->cfg.plot_width : f->cfg.width;
        int want_h = fig->is_plot ? f->cfg.plot_height : f->cfg.height;
        if (strcmp(fig->name, "spray_metrics") == 0)
            want_w *= 2; /* two panels side by side */
        CHECK(w == want_w && h == want_h, "%s: %d x %d px, expected %d x %d", fig->name, w, h, want_w, want_h);
        CHECK(distinct == 2, "%s is blank (one colour) or unreadable", fig->name);
        if (fig->is_plot) {
            snprintf(path, sizeof path, "%s/figures/%s.svg", f->dir, fig->name);
            CHECK(file_size(path) > 1000, "%s.svg: %ld bytes", fig->name, file_size(path));
        }
    }
}

static void check_report_names_figures(const struct fixture *f, const struct render_output *out)
{
    char path[256];
    snprintf(path, sizeof path, "%s/report.html", f->dir);
    FILE *file = fopen(path, "r");
    CHECK(file != NULL, "no %s", path);
    if (!file)
        return;
    static char text[1 << 20];
    size_t n = fread(text, 1, sizeof text - 1, file);
    text[n] = '\0';
    fclose(file);
    for (int i = 0; i < out->count; i++) {
        char ref[128];
        snprintf(ref, sizeof ref, "src=\"figures/%s.png\"", out->figures[i].name);
        CHECK(strstr(text, ref) != NULL, "report.html does not show %s", out->figures[i].name);
    }
    CHECK(strstr(text, "run_0002") != NULL && strstr(text, "Critical velocity") != NULL,
          "report.html lacks the second impact run or the v_crit table");
}

static void test_every_figure_of_a_run(void)
{
    struct fixture f;
    if (fixture_open(&f) != SC_OK)
        return;
    const struct stage_context ctx = {.c = f.c, .run_dir = f.dir};
    CHECK(spray_stage_run(&ctx) == SC_OK, "spray: %s", sc_error_message());
    CHECK(write_impact(f.dir) == SC_OK && write_vcrit(f.dir) == SC_OK, "inputs: %s", sc_error_message());
    struct render_request req = {.run_dir = f.dir, .cfg = &f.cfg, .c = f.c};
    struct render_output out;
    CHECK(render_run_dir(&req, &out) == SC_OK, "render: %s", sc_error_message());
    /* spray 9 (with the DE by size and angle), per impact run 3 plots + 3 views, vcrit 2 (v_crit(d) and CoR(v)) */
    CHECK(out.count == 9 + 2 * 6 + 2, "%d figures", out.count);
    /* the spray's snapshots: one every 500 of 3000 steps, the last at the end; the plume film every 2nd and the
     * last: 0 2 4 5 */
    int64_t spray_snapshots = count_spray_snapshots(f.dir);
    CHECK(spray_snapshots == 6, "%lld spray snapshots, expected 6 (every 5e-4 s of 3e-3 s)",
          (long long)spray_snapshots);
    CHECK(out.frames == 2 * 3 + 4, "%d frames (impact: every 2nd of 4 snapshots and the last, two runs; plume: 4)",
          out.frames);
    check_figures(&f, &out);
    const struct render_figure *d = render_output_find(&out, "spray_diameter");
    size_t particles = count_particles(f.dir);
    CHECK(d && particles > 100 && d->histogram.total == (int64_t)particles && d->histogram.outside == 0,
          "diameter histogram holds %lld of %zu particles", d ? (long long)d->histogram.total : -1LL, particles);
    int64_t sum = 0;
    for (int b = 0; d && b < d->histogram.bins; b++)
        sum += d->histogram.counts[b];
    CHECK(d && sum == d->histogram.total && d->histogram.bins == f.cfg.bins, "bins sum to %lld", (long long)sum);
    const struct render_figure *s = render_output_find(&out, "spray_impact_speed");
    int64_t contacts = count_first_impacts(f.dir);
    CHECK(s && contacts > 0 && s->histogram.total == contacts, "speed histogram holds %lld of %lld first impacts",
          s ? (long long)s->histogram.total : -1LL, (long long)contacts);
    char path[256];
    snprintf(path, sizeof path, "%s/figures/film_impact_run_0002/eps_p_section_000003.png", f.dir);
    int w, h;
    CHECK(png_facts(path, &w, &h) == 2 && w == f.cfg.width, "last frame of run 2: %s", path);
    snprintf(path, sizeof path, "%s/figures/film_plume/plume_000005.png", f.dir);
    CHECK(png_facts(path, &w, &h) == 2 && w == f.cfg.width, "last frame of the plume: %s", path);
    snprintf(path, sizeof path, "%s/figures/film_plume/plume_000003.png", f.dir);
    CHECK(png_facts(path, &w, &h) != 2, "plume frame 3 drawn, though every = 2: %s", path);
    check_report_names_figures(&f, &out);
    render_output_free(&out);
    /* damaged input: the message names the file, the status is an I/O error */
    snprintf(path, sizeof path, "%s/vcrit.h5", f.dir);
    FILE *garbage = fopen(path, "w");
    fputs("not HDF5\n", garbage);
    fclose(garbage);
    CHECK(render_run_dir(&req, &out) == SC_EIO && strstr(sc_error_message(), "vcrit.h5"), "damaged vcrit.h5: %s",
          sc_error_message());
    render_output_free(&out);
    case_free(f.c);
    case_fixture_remove(f.dir);
}

/* With [nozzle] and no nozzle_radius the spray injects over the exit (6.3 mm across): spray.h5 /nozzle records that
 * disc (injection_radius) and the exit's diameter, and the figures take the disc from there, not from the case's
 * nozzle_radius (its default, 10 mm, is all the case text holds). */
static void test_nozzle_exit_drawn(void)
{
    static const char nozzle_ini[] =
        "[run]\nseed = 3\n"
        "[spray]\ndt = 2e-7\nt_end = 1e-4\nfeed_count = 8\nfeed_every = 50\nmax_injected = 16\nrelease_cone = 1\n"
        "domain_radius = 0.02\nhandoff_height = 0.003\nmetrics_every = 50\n"
        "[powder]\ndistribution = weibull\nmedian_diameter = 30e-6\nshape = 4\nd_min = 15e-6\nd_max = 45e-6\n"
        "density = 2700\nspecific_heat = 896\n"
        "[target]\nstandoff = 0.04\n"
        "[nozzle]\nstagnation_pressure = 6.55e6\nstagnation_temperature = 698.15\nthroat_diameter = 2e-3\n"
        "exit_diameter = 6.3e-3\ninlet_diameter = 6e-3\nconvergent_length = 0.03\ndivergent_length = 0.14\n"
        "[jet]\nmodel = bickley\n"
        "[deposition]\nrule = adhesion\n"
        "[render]\nwidth = 320\nheight = 200\nplot_width = 400\nplot_height = 250\n";
    struct fixture f;
    memset(&f, 0, sizeof f);
    if (case_fixture_write(f.dir, nozzle_ini, NULL, NULL, NULL, NULL) != 0 ||
        case_fixture_load(f.dir, spraycoat_registry, &f.c) != SC_OK || render_config_load(f.c, &f.cfg) != SC_OK ||
        run_dir_prepare(f.dir, f.c) != SC_OK) {
        CHECK(0, "fixture: %s", sc_error_message());
        case_free(f.c);
        case_fixture_remove(f.dir);
        return;
    }
    const struct stage_context ctx = {.c = f.c, .run_dir = f.dir};
    CHECK(spray_stage_run(&ctx) == SC_OK, "spray: %s", sc_error_message());
    char path[256];
    snprintf(path, sizeof path, "%s/spray.h5", f.dir);
    hid_t file, group;
    double exit_diameter = NAN, radius = NAN;
    if (h5_open_read(path, &file) == SC_OK) {
        if ((group = H5Gopen2(file, "nozzle", H5P_DEFAULT)) >= 0) {
            h5_attr_read_double(group, "exit_diameter", &exit_diameter);
            H5Gclose(group);
        }
        CHECK(render_injection_radius(file, path, f.c, &radius) == SC_OK, "read: %s", sc_error_message());
        H5Fclose(file);
    }
    sc_error_clear();
    CHECK(exit_diameter == 6.3e-3, "/nozzle exit_diameter %g m, expected 6.3e-3", exit_diameter);
    CHECK(radius == 0.5 * 6.3e-3,
          "the figures' nozzle exit: radius %g m, expected the exit's 0.00315 m (the case's "
          "nozzle_radius, its default, is %g m)",
          radius, case_real(f.c, "spray", "nozzle_radius"));
    struct render_request req = {.run_dir = f.dir, .cfg = &f.cfg, .c = f.c};
    struct render_output out;
    CHECK(render_run_dir(&req, &out) == SC_OK && render_output_find(&out, "spray_deposit") &&
              render_output_find(&out, "spray_plume"),
          "render: %s", sc_error_message());
    render_output_free(&out);
    case_free(f.c);
    case_fixture_remove(f.dir);
}

static void test_nothing_to_draw(void)
{
    struct fixture f;
    if (fixture_open(&f) != SC_OK)
        return;
    struct render_request req = {.run_dir = f.dir, .cfg = &f.cfg, .c = f.c};
    struct render_output out;
    CHECK(render_run_dir(&req, &out) == SC_EIO && strstr(sc_error_message(), "no output"), "empty run directory: %s",
          sc_error_message());
    render_output_free(&out);
    case_free(f.c);
    case_fixture_remove(f.dir);
}

int main(void)
{
    h5_quiet();
    RUN(test_every_figure_of_a_run);
    RUN(test_nothing_to_draw);
    RUN(test_nozzle_exit_drawn);
    return check_finish();
}
