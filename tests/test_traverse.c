/* A traversing nozzle ([path], dem/path.c) and the deposit as a height map (dem/deposit.c): the path's positions,
 * the jet's axis moving with the nozzle, the Gaussian fit against a known Gaussian, and small spray runs (mono 50 um,
 * no gas, every particle sticking: critical_velocity 1 m/s below the release speeds) along a line 10 mm long:
 * the map's mass against the deposited particles', the track's profile centred on the path, and two passes giving
 * twice the thickness of one within the run's counting error; a nozzle on waypoints (an L) injecting about its
 * position at every release.  docs/physics.md "A traversing nozzle". */
#include <math.h>

#include "check.h"
#include "spray_fixture.h"

#define START_Y 0.5e-3 /* m: the track lies off the axis, so an injection that stayed at the origin misses it */

static void test_line_and_raster_positions(void)
{
    struct dem_path line = {.pattern = DEM_PATH_LINE,
                            .traverse_speed = 0.2,
                            .start_x = 0.01,
                            .start_y = -0.002,
                            .pass_length = 0.02,
                            .passes = 2};
    double xy[2];
    dem_path_position(&line, 0.05, xy); /* 10 mm into the first pass */
    CHECK_CLOSE(xy[0], 0.02, 1e-12, 0, "line x after 0.05 s");
    CHECK_CLOSE(xy[1], -0.002, 1e-12, 0, "line y");
    dem_path_position(&line, 0.15, xy); /* 10 mm back on the second */
    CHECK_CLOSE(xy[0], 0.02, 1e-12, 0, "line x after 0.15 s (back)");
    dem_path_position(&line, 0.175, xy);
    CHECK_CLOSE(xy[0], 0.015, 1e-12, 0, "line x after 0.175 s (back)");
    dem_path_position(&line, 1.0, xy); /* after the end: stays at the end of the last pass (the start) */
    CHECK_CLOSE(xy[0], 0.01, 1e-12, 0, "line x after its end");
    CHECK_CLOSE(dem_path_duration(&line), 0.2, 1e-12, 0, "line duration");
    struct dem_path raster = {
        .pattern = DEM_PATH_RASTER, .traverse_speed = 0.1, .pass_length = 0.01, .step_over = 0.002, .passes = 3};
    CHECK_CLOSE(dem_path_duration(&raster), (0.03 + 0.004) / 0.1, 1e-12, 0, "raster duration");
    dem_path_position(&raster, 0.11, xy); /* on the step-over after pass 1: 1 mm up */
    CHECK_CLOSE(xy[0], 0.01, 1e-12, 0, "raster x on the step-over");
    CHECK_CLOSE(xy[1], 0.001, 1e-12, 0, "raster y on the step-over");
    dem_path_position(&raster, 0.17, xy); /* pass 2 (backwards), 5 mm into it */
    CHECK_CLOSE(xy[0], 0.005, 1e-12, 0, "raster x on pass 2");
    CHECK_CLOSE(xy[1], 0.002, 1e-12, 0, "raster y on pass 2");
    dem_path_position(&raster, 0.32, xy); /* pass 3, 8 mm into it */
    CHECK_CLOSE(xy[0], 0.008, 1e-12, 0, "raster x on pass 3");
    CHECK_CLOSE(xy[1], 0.004, 1e-12, 0, "raster y on pass 3");
}

static void test_waypoints(void)
{
    double rows[] = {0.0, 0.0, 0.0, 1.0, 0.01, 0.0, 3.0, 0.01, 0.004};
    struct dem_path path = {.pattern = DEM_PATH_FILE, .waypoint_count = 3, .waypoints = rows};
    double xy[2];
    dem_path_position(&path, 0.25, xy);
    CHECK_CLOSE(xy[0], 0.0025, 1e-12, 0, "waypoint x at 0.25 s");
    dem_path_position(&path, 2.5, xy);
    CHECK_CLOSE(xy[0], 0.01, 1e-12, 0, "waypoint x at 2.5 s");
    CHECK_CLOSE(xy[1], 0.003, 1e-12, 0, "waypoint y at 2.5 s");
    dem_path_position(&path, 9.0, xy);
    CHECK_CLOSE(xy[1], 0.004, 1e-12, 0, "waypoint y after the last");
    CHECK_CLOSE(dem_path_duration(&path), 3.0, 0, 0, "waypoint duration");
}

/* The jet in its own frame: the field with the axis at (a, b) at (x, y, z) is the field with the axis at the origin
 * at (x - a, y - b, z), in the free jet and in the wall region. */
static void test_gas_follows_the_axis(void)
{
    struct dem_gas_field gas = {.model = DEM_JET_BICKLEY,
                                .c1 = 30,
                                .c3 = 20,
                                .virtual_origin = 0.1,
                                .core_length = 0.02,
                                .density = 1.1,
                                .kinematic_viscosity = 25e-6,
                                .stagnation_factor = 1.5};
    gas.c2 = gas.c1 / (3 * gas.c3);
    dem_gas_set_wall(&gas, 0.3);
    const double points[3][3] = {{0.004, -0.002, 0.1}, {0.013, 0.004, 0.295}, {0.0071, -0.003, 0.299}};
    for (int k = 0; k < 3; k++) {
        double moved[3], still[3], shifted[3] = {points[k][0] - 0.007, points[k][1] + 0.003, points[k][2]};
        gas.axis_x = 0.007, gas.axis_y = -0.003;
        dem_gas_velocity(&gas, points[k], moved);
        gas.axis_x = gas.axis_y = 0.0;
        dem_gas_velocity(&gas, shifted, still);
        for (int c = 0; c < 3; c++)
            CHECK(moved[c] == still[c] && (k != 0 || c != 2 || moved[c] > 1.0),
                  "point %d component %d: %.17g with the axis moved, %.17g shifted", k, c, moved[c], still[c]);
    }
}

/* A known Gaussian, exact and with deterministic noise of 2% of its amplitude. */
static void test_gaussian_fit(void)
{
    enum { N = 61 };
    double y[N], h[N], noisy[N];
    const double amplitude = 3e-4, centre = 1.3e-3, width = 0.8e-3;
    for (int i = 0; i < N; i++) {
        y[i] = -4e-3 + 1e-4 * (double)i;
        double u = (y[i] - centre) / width;
        h[i] = amplitude * exp(-0.5 * u * u);
        noisy[i] = h[i] + 0.02 * amplitude * sin(12.9898 * (double)i + 78.233); /* not correlated with the peak */
    }
    struct dem_gaussian fit;
    CHECK(dem_gaussian_fit(y, h, N, &fit) == SC_OK, "exact Gaussian: fit failed");
    CHECK_CLOSE(fit.amplitude, amplitude, 1e-8, 0, "exact amplitude");
    CHECK_CLOSE(fit.centre, centre, 0, 1e-12, "exact centre");
    CHECK_CLOSE(fit.width, width, 1e-8, 0, "exact width");
    CHECK(dem_gaussian_fit(y, noisy, N, &fit) == SC_OK, "noisy Gaussian: fit failed");
    CHECK(fabs(fit.amplitude - amplitude) < 3 * fit.amplitude_error && fit.amplitude_error < 0.02 * amplitude,
          "noisy amplitude %g +- %g, true %g", fit.amplitude, fit.amplitude_error, amplitude);
    CHECK(fabs(fit.centre - centre) < 3 * fit.centre_error && fit.centre_error < 0.05 * width,
          "noisy centre %g +- %g, true %g", fit.centre, fit.centre_error, centre);
    CHECK(fabs(fit.width - width) < 3 * fit.width_error && fit.width_error < 0.05 * width,
          "noisy width %g +- %g, true %g", fit.width, fit.width_error, width);
    double flat[N] = {0};
    CHECK(dem_gaussian_fit(y, flat, N, &fit) != SC_OK, "no peak: the fit must fail");
    sc_error_clear();
    /* a track centred on y = 0 (the default start_y) with noise symmetric about it: the centre converges to 0, where a
     * step measured against the centre itself never counted as small (the fit failed, and the run wrote none) */
    double ys[N], symmetric[N];
    for (int i = 0; i < N; i++) {
        ys[i] = 1e-4 * (double)(i - N / 2);
        double u = ys[i] / width;
        symmetric[i] = amplitude * exp(-0.5 * u * u) + 0.02 * amplitude * cos(12.9898 * fabs(ys[i]) / 1e-4);
    }
    CHECK(dem_gaussian_fit(ys, symmetric, N, &fit) == SC_OK, "centred on 0: the fit failed (%s)", sc_error_message());
    sc_error_clear();
    CHECK(fabs(fit.centre) < 1e-3 * width && fabs(fit.width - width) < 3 * fit.width_error,
          "centred on 0: centre %g, width %g +- %g (true %g)", fit.centre, fit.width, fit.width_error, width);
    /* a track over 12 widths of map (noise where particles land, within 4 widths; no particle, no height beyond) and
     * the same with 60 empty rows more on each side (a map widened by its band or a stray deposit): the same fit and
     * standard errors; over every row the errors shrank as 1 / sqrt(n - 3) (by 1.8 here) */
    enum { ROWS = 97, PAD = 60, WIDE = ROWS + 2 * PAD };
    double y_wide[WIDE], h_wide[WIDE];
    for (int i = 0; i < WIDE; i++) {
        y_wide[i] = 1e-4 * (double)(i - WIDE / 2);
        double u = y_wide[i] / width;
        h_wide[i] = fabs(u) > 4.0 ? 0.0 : amplitude * exp(-0.5 * u * u) * (1.0 + 0.05 * sin(12.9898 * (double)i));
    }
    struct dem_gaussian narrow, wide;
    CHECK(dem_gaussian_fit(y_wide + PAD, h_wide + PAD, ROWS, &narrow) == SC_OK &&
              dem_gaussian_fit(y_wide, h_wide, WIDE, &wide) == SC_OK,
          "padded: the fits failed");
    printf("  errors of the centre: %.4g m over %d rows, %.4g m over %d\n", narrow.centre_error, ROWS,
           wide.centre_error, WIDE);
    CHECK_CLOSE(wide.centre, narrow.centre, 0, 1e-9 * width, "padded: the centre");
    CHECK_CLOSE(wide.width, narrow.width, 1e-9, 0, "padded: the width");
    CHECK_CLOSE(wide.amplitude_error, narrow.amplitude_error, 1e-6, 0, "padded: the amplitude's error");
    CHECK_CLOSE(wide.centre_error, narrow.centre_error, 1e-6, 0, "padded: the centre's error");
    CHECK_CLOSE(wide.width_error, narrow.width_error, 1e-6, 0, "padded: the width's error");
}

/* The particles fed during a 1 ms pass: 4 a step of 2 us (run_path) */
#define ONE_PASS_FED (4 * 500)

struct track {
    int ok;
    struct dem_deposit deposit;
    double particle_mass; /* of the deposited particles, from the solver's particle views */
    int64_t deposited, injected;
    size_t in_band;       /* deposited particles whose centres lie in the middle half of the pass and in the band */
    size_t in_band_first; /* those of them fed during the first 1 ms pass (the first ONE_PASS_FED ids) */
    double off_path;      /* the farthest deposited centre from the waypoints' nozzle at its release (run_path) */
    size_t handoffs, handoff_axis_wrong; /* hand-off rows, and those whose axis is not the path's at their time */
    double handoff_axis_x_max;
};

/* Waypoints t, x, y (rows of 3), and the nozzle's position at t from them, linear between them and held after the
 * last: written here apart from dem/path.c, to check the spray's injection against. */
struct waypoint_table {
    const double *rows;
    size_t count;
};

static void nozzle_at(const struct waypoint_table *w, double t, double xy[2])
{
    size_t k = 1;
    while (k < w->count - 1 && w->rows[3 * k] < t)
        k++;
    const double *a = w->rows + 3 * (k - 1), *b = w->rows + 3 * k;
    double f = fmin(1.0, fmax(0.0, (t - a[0]) / (b[0] - a[0])));
    xy[0] = a[1] + f * (b[1] - a[1]);
    xy[1] = a[2] + f * (b[2] - a[2]);
}

/* One spray run (mono 50 um, no gas, all sticking, 4 particles a step of 2 us from a 1 mm nozzle) along `path` (the
 * [path] section's lines), injecting for `duration` and then letting the last ones land for 0.4 ms.  in_band counts
 * the deposited centres with x in [x_lo, x_hi] and y in the deposit's band; with `waypoints`, off_path is the
 * farthest a deposited centre lies from the nozzle at its release (particle id / 4 steps: each falls straight down
 * from the disc about it). */
static struct track run_path(const char *path, double duration, int seed, double packing, double x_lo, double x_hi,
                             const struct waypoint_table *waypoints)
{
    long steps = (long)(duration / 2e-6 + 0.5);
    char ini[2048];
    snprintf(ini, sizeof ini,
             "[run]\nseed = %d\nthreads = 1\n"
             "[spray]\ndt = 2e-6\nt_end = %.17g\ninjection = stream\nfeed_count = 4\nfeed_every = 1\n"
             "max_injected = %ld\nnozzle_radius = 1e-3\nrelease_speed_min = 50\nrelease_speed_max = 60\n"
             "domain_radius = 0.004\nhandoff_height = 1e-3\nmetrics_every = 1000\nsnapshot_every = 0\n"
             "[powder]\ndistribution = mono\nmedian_diameter = 50e-6\ndensity = 8900\n"
             "[target]\nstandoff = 0.005\n"
             "[jet]\nmodel = none\n"
             "[deposition]\nrule = critical_velocity\ncritical_velocity = 1\n"
             "[path]\n%smap_cell = 1e-4\npacking = %g\n",
             seed, duration + 4e-4, 4 * steps, path, packing);
    struct fixture f;
    struct track t = {0};
    if (fixture_open(&f, ini, NULL) == SC_OK && fixture_steps(&f, dem_total_steps(f.solver)) == SC_OK &&
        dem_deposit_build(f.solver, &t.deposit) == SC_OK) {
        t.ok = 1;
        struct dem_counts c = dem_get_counts(f.solver);
        t.deposited = c.deposited, t.injected = c.injected;
        const struct dem_handoff *h = dem_handoffs(f.solver, &t.handoffs);
        for (size_t k = 0; k < t.handoffs; k++) {
            double xy[2];
            dem_path_position(&f.cfg.path, h[k].t, xy);
            t.handoff_axis_wrong += !(h[k].axis[0] == xy[0] && h[k].axis[1] == xy[1]);
            t.handoff_axis_x_max = fmax(t.handoff_axis_x_max, h[k].axis[0]);
        }
        for (size_t i = 0; i < dem_particle_count(f.solver); i++) {
            struct dem_particle_view p = dem_particle(f.solver, i);
            if (p.state != DEM_DEPOSITED)
                continue;
            t.particle_mass += p.m;
            int in_band =
                p.x[0] >= x_lo && p.x[0] <= x_hi && p.x[1] >= t.deposit.band_lo && p.x[1] <= t.deposit.band_hi;
            t.in_band += (size_t)in_band;
            t.in_band_first += (size_t)(in_band && p.id < ONE_PASS_FED);
            if (waypoints) {
                double xy[2];
                nozzle_at(waypoints, (double)(p.id / 4) * 2e-6, xy);
                t.off_path = fmax(t.off_path, hypot(p.x[0] - xy[0], p.x[1] - xy[1]));
            }
        }
    } else {
        printf("  spray run failed: %s\n", sc_error_message());
    }
    fixture_close(&f);
    return t;
}

/* A 10 mm line from (0, START_Y) at 10 m/s, `passes` times. */
static struct track run_track(int passes, int seed, double packing)
{
    char path[256];
    snprintf(path, sizeof path,
             "pattern = line\ntraverse_speed = 10\nstart_x = 0\nstart_y = %g\npass_length = 0.01\n"
             "passes = %d\n",
             START_Y, passes);
    return run_path(path, passes * 1e-3, seed, packing, 2.5e-3, 7.5e-3, NULL);
}

/* The map's mass, sum of height * cell area * packing * density, is the deposited particles' mass. */
static void test_deposit_mass(void)
{
    struct track t = run_track(1, 1, 0.9);
    CHECK(t.ok && t.deposited > 1000, "run: %lld of %lld deposited", (long long)t.deposited, (long long)t.injected);
    const struct dem_deposit *d = &t.deposit;
    double volume = 0.0;
    for (size_t k = 0; k < d->nx * d->ny; k++)
        volume += d->height[k] * d->cell * d->cell * d->packing;
    double expected = (double)t.deposited * 8900 * M_PI * pow(50e-6, 3) / 6;
    printf("  %lld deposited, map mass %.6g kg, particles %.6g kg (%zu x %zu cells of %g m)\n", (long long)t.deposited,
           volume * 8900, t.particle_mass, d->nx, d->ny, d->cell);
    CHECK_CLOSE(volume * 8900, t.particle_mass, 1e-12, 0, "map mass against the deposited particles' mass");
    CHECK_CLOSE(t.particle_mass, expected, 1e-12, 0, "the deposited particles' mass against their count");
    /* the couple stage centres each flight's jet on the hand-off row's axis: the nozzle's position at its time */
    CHECK(t.handoffs >= (size_t)t.deposited && t.handoff_axis_wrong == 0 && t.handoff_axis_x_max > 9e-3,
          "%zu hand-offs, %zu with an axis off the path, the farthest at x = %g m", t.handoffs, t.handoff_axis_wrong,
          t.handoff_axis_x_max);
    dem_deposit_free(&t.deposit);
}

/* The single track's profile is centred on the path: the Gaussian fit's centre within three of its standard errors
 * of START_Y, and the profile's first moment within three of its counting errors (the spread of the deposited
 * centres across the track over the square root of their number). */
static void test_profile_symmetric(void)
{
    struct track t = run_track(1, 2, 1.0);
    const struct dem_deposit *d = &t.deposit;
    CHECK(t.ok && d->has_fit, "run %d, fit %d", t.ok, d->has_fit);
    double weight = 0.0, first = 0.0, second = 0.0;
    for (size_t j = 0; j < d->profile_count; j++)
        weight += d->profile_height[j], first += d->profile_height[j] * d->profile_y[j];
    double mean = first / weight;
    for (size_t j = 0; j < d->profile_count; j++)
        second += d->profile_height[j] * (d->profile_y[j] - mean) * (d->profile_y[j] - mean);
    double spread = sqrt(second / weight), error = spread / sqrt((double)t.in_band);
    printf("  fit: amplitude %.4g +- %.2g m, width %.4g +- %.2g m, centre %.5g +- %.2g m (path at %g m); "
           "first moment %.5g +- %.2g m (%zu particles)\n",
           d->fit.amplitude, d->fit.amplitude_error, d->fit.width, d->fit.width_error, d->fit.centre,
           d->fit.centre_error, START_Y, mean, error, t.in_band);
    CHECK(fabs(d->fit.centre - START_Y) < 3 * d->fit.centre_error, "fitted centre %g +- %g, path at %g", d->fit.centre,
          d->fit.centre_error, START_Y);
    CHECK(fabs(mean - START_Y) < 3 * error, "profile's first moment %g +- %g, path at %g", mean, error, START_Y);
    /* the disc of radius 1 mm spreads the track: sigma of a uniform disc's chord profile is R/2 */
    CHECK(d->fit.width > 0.3e-3 && d->fit.width < 0.7e-3, "fitted width %g m, expected about 0.5 mm", d->fit.width);
    dem_deposit_free(&t.deposit);
}

/* Two passes over the line give twice the mean thickness of one.  The two runs share their seed and their feed, so
 * the first pass of the two is the one pass (checked: the same particles in the band), and the ratio is 1 + N2/N1,
 * N1 and N2 the particles the first and the second pass put in the band (the mean thickness there is proportional
 * to them).  The passes are independent draws of the same expected count: as Poisson counts (an upper bound: the
 * injection feeds a fixed number a step) N2/N1 has the error (N2/N1) sqrt(1/N1 + 1/N2); allowed 3 of it (0.13 for
 * N1 ~ N2 ~ 1000; treating the two runs as independent allowed 0.23, where reruns with four seeds spread by 0.02:
 * a review). */
static void test_two_passes(void)
{
    struct track one = run_track(1, 3, 1.0), two = run_track(2, 3, 1.0);
    CHECK(one.ok && two.ok && one.in_band > 0 && two.in_band > 0, "runs %d %d", one.ok, two.ok);
    CHECK(two.in_band_first == one.in_band, "the first of two passes put %zu particles in the band, the one pass %zu",
          two.in_band_first, one.in_band);
    double ratio = two.deposit.mean_thickness / one.deposit.mean_thickness;
    double first = (double)one.in_band, second = (double)(two.in_band - two.in_band_first);
    double error = second / first * sqrt(1.0 / first + 1.0 / second);
    printf("  mean thickness: one pass %.4g m (%zu particles), two passes %.4g m (%zu): ratio %.4f +- %.4f\n",
           one.deposit.mean_thickness, one.in_band, two.deposit.mean_thickness, two.in_band, ratio, error);
    CHECK(fabs(ratio - 2.0) < 3 * error, "ratio %g, expected 2 +- %g", ratio, 3 * error);
    dem_deposit_free(&one.deposit);
    dem_deposit_free(&two.deposit);
}

/* A raster's coating: where every pass within the nozzle's reach of a point exists (y from R above the first pass
 * to R below the last), the thickness is the volume fed per time over the traverse speed and the step over,
 * h = (dN/dt) (pi d^3 / 6) / (v s), independently of the track's shape (the passes' profiles summed at spacing s).
 * 13 passes of 3 mm, 0.25 mm apart, at 10 m/s: h = 2e6/s x 6.545e-14 m3 / (10 m/s x 2.5e-4 m) = 52.4 um.  The
 * profile's mean over the middle half of the pass and y in [1, 2] mm must match within 3 counting errors (as
 * test_two_passes: 1/sqrt(N) of the particles in that region). */
static void test_raster_thickness(void)
{
    const double speed = 10, step_over = 2.5e-4, pass = 3e-3, radius = 1e-3;
    const int passes = 13;
    char path[256];
    snprintf(path, sizeof path,
             "pattern = raster\ntraverse_speed = %g\nstart_x = 0\nstart_y = 0\npass_length = %g\nstep_over = %g\n"
             "passes = %d\n",
             speed, pass, step_over, passes);
    double duration = (passes * pass + (passes - 1) * step_over) / speed;
    struct track t = run_path(path, duration, 4, 1.0, 0.25 * pass, 0.75 * pass, NULL);
    const struct dem_deposit *d = &t.deposit;
    double y_lo = radius, y_hi = (passes - 1) * step_over - radius, sum = 0.0;
    size_t rows = 0;
    for (size_t j = 0; j < d->profile_count; j++)
        if (d->profile_y[j] >= y_lo && d->profile_y[j] <= y_hi)
            sum += d->profile_height[j], rows++;
    double mean = rows ? sum / (double)rows : NAN, volume = M_PI * pow(50e-6, 3) / 6;
    double expected = (4 / 2e-6) * volume / (speed * step_over);
    double count = expected * (0.5 * pass) * (y_hi - y_lo) / volume; /* particles in the region */
    double error = expected / sqrt(count);
    printf("  raster: mean thickness %.4g m over y in [%g, %g] m (%zu rows), expected (dN/dt) V / (v s) = %.4g m "
           "+- %.2g (%.0f particles); over the whole band %.4g m\n",
           mean, y_lo, y_hi, rows, expected, error, count, d->mean_thickness);
    CHECK(t.ok && rows >= 5 && fabs(mean - expected) < 3 * error, "raster thickness %g, expected %g +- %g", mean,
          expected, 3 * error);
    dem_deposit_free(&t.deposit);
}

/* A nozzle on waypoints (pattern = file) in a spray run: an L, 5 mm along +x in 0.5 ms, then 5 mm along +y in 0.5
 * ms.  Each particle falls straight down (no gas, no release cone) from the 1 mm disc about the nozzle at its
 * release, so every deposited centre lies within the disc's radius of the waypoints' nozzle at that time, computed
 * here apart from dem/path.c (nozzle_at); and the deposit spans the L: its map reaches x = 5 mm and y = 5 mm. */
static void test_waypoints_spray(void)
{
    static const double rows[] = {0.0, 0.0, 0.0, 0.5e-3, 5e-3, 0.0, 1.0e-3, 5e-3, 5e-3};
    const struct waypoint_table table = {rows, 3};
    char dir[] = "/tmp/spraycoat-waypoints-XXXXXX", csv[96], path[256];
    CHECK(mkdtemp(dir) != NULL, "cannot make a folder for the waypoints");
    snprintf(csv, sizeof csv, "%s/path.csv", dir);
    FILE *file = fopen(csv, "w");
    CHECK(file != NULL, "cannot write %s", csv);
    fprintf(file, "t,x,y\n");
    for (size_t k = 0; k < table.count; k++)
        fprintf(file, "%.17g,%.17g,%.17g\n", rows[3 * k], rows[3 * k + 1], rows[3 * k + 2]);
    fclose(file);
    snprintf(path, sizeof path, "pattern = file\nwaypoints = %s\n", csv);
    struct track t = run_path(path, 1e-3, 5, 1.0, 0.0, 0.0, &table);
    const struct dem_deposit *d = &t.deposit;
    double x_far = d->x0 + (double)(d->nx - 1) * d->cell, y_far = d->y0 + (double)(d->ny - 1) * d->cell;
    printf("  %lld of %lld deposited, the farthest %.4g um from the nozzle at its release; map to x = %.4g, y = %.4g "
           "mm\n",
           (long long)t.deposited, (long long)t.injected, t.off_path * 1e6, x_far * 1e3, y_far * 1e3);
    CHECK(t.ok && t.deposited == t.injected && t.injected == 2000, "run: %lld of %lld deposited",
          (long long)t.deposited, (long long)t.injected);
    CHECK(t.off_path <= 1e-3 + 1e-9, "a deposit %g m from the nozzle at its release, beyond the 1 mm disc", t.off_path);
    CHECK(x_far > 5e-3 && y_far > 5e-3 && d->x0 < 0.0 && d->y0 < 0.0, "the map spans x %g to %g, y %g to %g m", d->x0,
          x_far, d->y0, y_far);
    dem_deposit_free(&t.deposit);
    remove(csv);
    rmdir(dir);
}

int main(void)
{
    RUN(test_line_and_raster_positions);
    RUN(test_waypoints);
    RUN(test_gas_follows_the_axis);
    RUN(test_gaussian_fit);
    RUN(test_deposit_mass);
    RUN(test_profile_symmetric);
    RUN(test_two_passes);
    RUN(test_raster_thickness);
    RUN(test_waypoints_spray);
    return check_finish();
}
