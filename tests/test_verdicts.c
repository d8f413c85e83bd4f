/* Settled verdicts (mpm/verdict.c; issue 22, item 3): each row is judged on the means of v_rest and v_com over the
 * window that ends there, and a verdict counts only once PBCP and those means have held it over the settling window; a
 * transient rebound is `unsettled`, never `rebounded`; a rebound faster than vrest_filter is judged on its speed; a
 * body with unknown values is never judged; the run ends once
 * every particle is settled.  The judging is tested on series rows written into a small solver (the shapes of the
 * issue's 14 um run at 750 m/s), the end of a run on an elastic sphere bouncing off a rigid wall; a run resumed from a
 * checkpoint at its end writes the summary of the run that was never stopped. */
#include <math.h>

#include "check.h"
#include "core/h5io.h"
#include "impact_fixture.h"
/* A white-box test: includes the module-private header mpm/mpm_impl.h (only tests may; tests/test_symbols.sh). */
#include "mpm/mpm_impl.h"

#define ROW_DT 0.5e-9 /* series_every */

/* What one body's series looks like over time. */
typedef void (*history)(double t, double *v_com_z, double *pbcp, double *v_rest);

/* A solver with `bodies` small spheres over a rigid wall (defaults: settle_window 10 ns, settle_vcom 0.5 m/s,
 * settle_pbcp 0.005, pbcp_threshold 0.05; vrest_threshold set to 5 m/s, the scale the shapes below were drawn for,
 * not the default 0.6 m/s); its series replaced by rows every ROW_DT up to t_last, body k following shapes[k]. */
static int judged(struct impact_fixture *f, int bodies, const history *shapes, double t_last)
{
    const char *ini = "[impact]\nsubstrate = rigid\ngrid = 2e-6\nspacing = 1e-6\nvrest_threshold = 5\n"
                      "[material.aluminium]\n";
    char rows[256] = "";
    for (int k = 0; k < bodies; k++)
        snprintf(rows + strlen(rows), sizeof rows - strlen(rows), "sphere,%g,0,3e-6,0,0,-100,4e-6,0,aluminium\n",
                 10e-6 * k);
    if (impact_fixture_open(f, ini, rows) != SC_OK)
        return -1;
    struct mpm_solver *s = f->solver;
    size_t width = SERIES_FIXED + (size_t)bodies * SERIES_PER_BODY, n = (size_t)llround(t_last / ROW_DT) + 1;
    double *series = calloc(n * width, sizeof *series);
    if (!series)
        return -1;
    for (size_t r = 0; r < n; r++) {
        double *row = series + r * width, t = (double)r * ROW_DT;
        row[0] = t;
        for (int k = 0; k < bodies; k++) {
            double *c = row + SERIES_FIXED + (size_t)k * SERIES_PER_BODY;
            shapes[k](t, &c[2], &c[8], &c[9]); /* v_com z, pbcp, v_rest (mpm_series_record) */
        }
    }
    free(s->series);
    s->series = series, s->series_rows = s->series_capacity = n;
    mpm_verdict_replay(s);
    return 0;
}

static int verdict_of(struct impact_fixture *f, int body)
{
    int v[4];
    mpm_verdicts(f->solver, v);
    return v[body];
}

/* The 14 um particle at 750 m/s: it leaves at 30 m/s at 40 ns, and the bonds pull it back; v_com decays
 * as 30 exp(-(t - 40 ns)/6 ns) m/s, PBCP 0.3.  Before 40 ns it is stopped from -750 m/s. */
static void held_back(double t, double *v, double *pbcp, double *v_rest)
{
    *v = t < 40e-9 ? -750.0 + 780.0 * t / 40e-9 : 30.0 * exp(-(t - 40e-9) / 6e-9);
    *pbcp = 0.3;
    *v_rest = t < 5e-9 ? NAN : *v; /* no point slower than 60 m/s at first */
}

static void test_transient_rebound_is_unsettled(void)
{
    struct impact_fixture f;
    history shapes[1] = {held_back};
    CHECK(judged(&f, 1, shapes, 40e-9) == 0, "set-up");
    CHECK(verdict_of(&f, 0) == MPM_VERDICT_UNSETTLED, "at 40 ns, leaving at 30 m/s: %s, not rebounded",
          mpm_verdict_name(verdict_of(&f, 0)));
    CHECK(!mpm_all_settled(f.solver), "not settled at 40 ns");
    impact_fixture_close(&f);
    CHECK(judged(&f, 1, shapes, 80e-9) == 0, "set-up");
    CHECK(verdict_of(&f, 0) == MPM_VERDICT_BONDED, "at 80 ns: %s", mpm_verdict_name(verdict_of(&f, 0)));
    /* Judged on the mean of the 21 rows of the 10 ns window: once the window lies past 40 ns, m(t) = 30 S
     * exp(-(t - 40 ns)/6 ns) with S = (1/21) sum_i exp(i 0.5/6), i = 0 .. 20.  Settled once the means of the 10 ns
     * before moved by at most 0.5 m/s: m(t - 10 ns) - m(t) = m(t) (exp(10/6) - 1) <= 0.5, on the next row (79.05 ns,
     * so both windows lie past 40 ns) */
    double S = (exp(21.0 * 0.5 / 6.0) - 1.0) / (exp(0.5 / 6.0) - 1.0) / 21.0;
    double t = 40e-9 + 6e-9 * log(30.0 * S * (exp(10.0 / 6.0) - 1.0) / 0.5);
    CHECK_CLOSE(mpm_verdict_settled_at(f.solver, 0), ceil(t / ROW_DT) * ROW_DT, 0.0, 1e-13, "settled at (s)");
    CHECK(mpm_all_settled(f.solver), "every particle settled at 80 ns");
    impact_fixture_close(&f);
}

/* Leaving at a steady 20 m/s from 20 ns: rebounded.  Its window mean is 20 m/s from 30 ns and within 0.5 m/s of it
 * from 29.5 ns (20 - 8/21 m/s: one row of the window at 12 m/s), so it is settled one window later, at 39.5 ns. */
static void flies_off(double t, double *v, double *pbcp, double *v_rest)
{
    *v = t < 20e-9 ? -300.0 + 320.0 * t / 20e-9 : 20.0;
    *pbcp = 0.01;
    *v_rest = t < 5e-9 ? NAN : *v;
}

/* Leaving at a steady 64 m/s from 20 ns, faster than vrest_filter (60 m/s): no point is slow enough for a v_rest
 * (NaN) while it lands or leaves, and a leaving row's rest velocity is its centre of mass's speed.  Its window mean
 * is 64 m/s from 30 ns and within 0.5 m/s of it from 29.5 ns (one row of the window at 54.9 m/s), so it settles one
 * window later, at 39.5 ns. */
static void leaves_fast(double t, double *v, double *pbcp, double *v_rest)
{
    *v = t < 20e-9 ? -300.0 + 364.0 * t / 20e-9 : 64.0;
    *pbcp = 0.01;
    *v_rest = fabs(*v) < 60.0 ? *v : NAN;
}

/* Sliding off along the substrate at a steady 100 m/s (v_com_z -0.1 m/s, within settle_vcom; v_com_x 100 m/s, set
 * by test_sliding_off), no point slower than vrest_filter: not held, whatever its PBCP. */
static void slides_off(double t, double *v, double *pbcp, double *v_rest)
{
    (void)t;
    *v = -0.1;
    *pbcp = 0.3;
    *v_rest = NAN;
}

/* A body whose values are unknown (the device failed: every column NaN). */
static void unknown(double t, double *v, double *pbcp, double *v_rest)
{
    (void)t;
    *v = *pbcp = *v_rest = NAN;
}

/* Still approaching at a steady 50 m/s (slower than vrest_filter, so v_rest has a value): in flight. */
static void approaching(double t, double *v, double *pbcp, double *v_rest)
{
    (void)t;
    *v = *v_rest = -50.0;
    *pbcp = 0.0;
}

/* At rest, but v_rest on either side of the 5 m/s threshold, row by row. */
static void flickers(double t, double *v, double *pbcp, double *v_rest)
{
    *v = 0.0;
    *pbcp = 0.3;
    *v_rest = (long)llround(t / ROW_DT) % 2 ? 4.0 : 6.0;
}

/* At rest and bonded by v_rest, PBCP still growing by 0.01 per ns. */
static void still_bonding(double t, double *v, double *pbcp, double *v_rest)
{
    *v = 0.0;
    *v_rest = 0.0;
    *pbcp = 0.05 + 1e7 * t;
}

static void test_steady_rebound(void)
{
    const history shapes[2] = {flies_off, leaves_fast};
    const double speed[2] = {20.0, 64.0};
    for (int k = 0; k < 2; k++) {
        struct impact_fixture f;
        CHECK(judged(&f, 1, &shapes[k], 50e-9) == 0, "set-up");
        CHECK(verdict_of(&f, 0) == MPM_VERDICT_REBOUNDED, "steady %g m/s: %s", speed[k],
              mpm_verdict_name(verdict_of(&f, 0)));
        CHECK_CLOSE(mpm_verdict_settled_at(f.solver, 0), 39.5e-9, 0.0, 1e-13, "settled at (s)");
        CHECK_CLOSE(mpm_verdict_vrest(f.solver, 0), speed[k], 0.0, 1e-12, "v_rest (m/s)");
        impact_fixture_close(&f);
    }
}

/* Judged on its speed, 100 m/s: rebounded, settled once the first window of judgements is full (20 ns). */
static void test_sliding_off(void)
{
    struct impact_fixture f;
    history shapes[1] = {slides_off};
    CHECK(judged(&f, 1, shapes, 40e-9) == 0, "set-up");
    struct mpm_solver *s = f.solver;
    for (size_t r = 0; r < s->series_rows; r++)
        s->series[r * (SERIES_FIXED + SERIES_PER_BODY) + SERIES_FIXED] = 100.0; /* v_com x */
    mpm_verdict_replay(s);
    CHECK(verdict_of(&f, 0) == MPM_VERDICT_REBOUNDED, "sliding off at 100 m/s: %s",
          mpm_verdict_name(verdict_of(&f, 0)));
    CHECK_CLOSE(mpm_verdict_settled_at(s, 0), 20e-9, 0.0, 1e-13, "settled at (s)");
    CHECK_CLOSE(mpm_verdict_vrest(s, 0), sqrt(100.0 * 100.0 + 0.1 * 0.1), 1e-14, 0.0, "v_rest (m/s)");
    impact_fixture_close(&f);
}

/* Held, and ringing on the substrate as a 30 um particle does (period 13 ns, here 8 m/s decaying over 20 ns, around
 * 0 after landing at 40 ns; the 5 m/s threshold stands for Tang's 0.6 m/s): one row's v_rest is above the threshold
 * until 9.4 ns after landing (8 exp(-x/20 ns) = 5), and the row values over the last window swing by about
 * 16 exp(-(x - 10 ns)/20 ns) m/s, above 0.5 m/s until x = 79 ns: a verdict on row values would not settle by 100 ns.
 * The 10 ns window mean keeps only sin(pi 10/13)/(pi 10/13) = 0.27 of the swing, so the means over the last window
 * swing by 0.27 times that, 0.5 m/s at x = 53 ns: bonded, settled at about 93 ns. */
static void rings_held(double t, double *v, double *pbcp, double *v_rest)
{
    const double pi = 3.14159265358979323846;
    double x = t - 40e-9;
    *v = t < 40e-9 ? -750.0 + 750.0 * t / 40e-9 : 8.0 * exp(-x / 20e-9) * sin(2.0 * pi * x / 13e-9);
    *pbcp = 0.3;
    *v_rest = t < 5e-9 ? NAN : *v;
}

/* The same ringing around a steady rebound at 20 m/s: rebounded. */
static void rings_leaving(double t, double *v, double *pbcp, double *v_rest)
{
    rings_held(t, v, pbcp, v_rest);
    if (t >= 40e-9)
        *v += 20.0, *v_rest += 20.0, *pbcp = 0.01;
}

static void test_ringing_settles(void)
{
    const history shapes[2] = {rings_held, rings_leaving};
    const int expected[2] = {MPM_VERDICT_BONDED, MPM_VERDICT_REBOUNDED};
    for (int k = 0; k < 2; k++) {
        struct impact_fixture f;
        CHECK(judged(&f, 1, &shapes[k], 100e-9) == 0, "set-up");
        double t_settled = mpm_verdict_settled_at(f.solver, 0);
        printf("  ringing %s: %s, settled at %.4g ns\n", k ? "while leaving" : "while held",
               mpm_verdict_name(verdict_of(&f, 0)), t_settled * 1e9);
        CHECK(verdict_of(&f, 0) == expected[k], "ringing %d: %s", k, mpm_verdict_name(verdict_of(&f, 0)));
        CHECK(t_settled > 88e-9 && t_settled < 97e-9, "ringing %d: settled at %g s, when its mean steadied", k,
              t_settled);
        impact_fixture_close(&f);
    }
}

static void test_unsettled_cases(void)
{
    const history shapes[4] = {unknown, flickers, still_bonding, approaching};
    const char *what[4] = {"values unknown", "v_rest either side of the threshold", "PBCP growing",
                           "approaching at a steady speed"};
    for (int k = 0; k < 4; k++) {
        struct impact_fixture f;
        CHECK(judged(&f, 1, &shapes[k], 60e-9) == 0, "set-up");
        CHECK(verdict_of(&f, 0) == MPM_VERDICT_UNSETTLED, "%s: %s", what[k], mpm_verdict_name(verdict_of(&f, 0)));
        CHECK(isnan(mpm_verdict_settled_at(f.solver, 0)), "%s: no settling time", what[k]);
        impact_fixture_close(&f);
    }
}

/* Two particles: the run may end only when both are settled. */
static void test_every_body_settles(void)
{
    struct impact_fixture f;
    history shapes[2] = {flies_off, held_back};
    CHECK(judged(&f, 2, shapes, 60e-9) == 0, "set-up");
    CHECK(verdict_of(&f, 0) == MPM_VERDICT_REBOUNDED && verdict_of(&f, 1) == MPM_VERDICT_UNSETTLED,
          "at 60 ns: %s and %s", mpm_verdict_name(verdict_of(&f, 0)), mpm_verdict_name(verdict_of(&f, 1)));
    CHECK(!mpm_all_settled(f.solver) && !mpm_finished(f.solver), "the run goes on while one is unsettled");
    impact_fixture_close(&f);
}

/* An elastic sphere (4 cells across, Poisson ratio 0.33) at 20 m/s onto the rigid wall: it rebounds, flies off at a
 * steady speed, and the run ends one window after that, before t_end, with the verdict `rebounded`. */
static void test_run_ends_when_settled(void)
{
    struct impact_fixture f;
    const char *ini = "[impact]\nsubstrate = rigid\nmaterial = elastic\ngrid = 2e-6\nspacing = 1e-6\n"
                      "t_end = 400e-9\ncfl = 0.2\nbonding = none\nbox_margin = 40e-6\n"
                      "[material.elastic]\nstrength = elastic\ndensity = 1000\neos_c0 = 1000\neos_s = 0\n"
                      "eos_gamma0 = 0\nG0 = 1e9\nD = 0\nmelt_T0 = 1e5\n";
    if (impact_fixture_open(&f, ini, "sphere,0,0,4.5e-6,0,0,-20,8e-6,0,elastic\n") != SC_OK) {
        CHECK(0, "set-up");
        return;
    }
    CHECK(impact_fixture_run(&f) == SC_OK, "run");
    struct mpm_counts c = mpm_get_counts(f.solver);
    const struct mpm_diagnostics *d = mpm_compute_diagnostics(f.solver);
    printf("  ended at %.4g ns (settled at %.4g ns), v_com_z %.4g m/s, %s\n", c.t * 1e9,
           mpm_verdict_settled_at(f.solver, 0) * 1e9, d->body[0].v_com[2], mpm_verdict_name(verdict_of(&f, 0)));
    CHECK(c.t < 0.9 * f.cfg.t_end, "the run ended at %g s, before t_end", c.t);
    CHECK(verdict_of(&f, 0) == MPM_VERDICT_REBOUNDED && d->body[0].v_com[2] > 0, "rebounded, moving up");
    CHECK_CLOSE(mpm_verdict_settled_at(f.solver, 0), c.t, 0.0, 1e-15, "ended on the row it settled (s)");
    impact_fixture_close(&f);
}

/* A particle that flies out of the grid box (an elastic sphere at 100 m/s off the rigid wall, 2 um of box margin,
 * the run going on to t_end): its every point removed, it has rebounded, settled, with the v_rest and v_com_z it
 * left with, not at rest.  Its empty rows read v_com = 0 and v_rest = 0: it settled as "held, at rest" with a CoR
 * of 0 (a review). */
static void test_body_that_left_the_box(void)
{
    struct impact_fixture f;
    const char *ini = "[impact]\nsubstrate = rigid\nmaterial = elastic\ngrid = 2e-6\nspacing = 1e-6\n"
                      "t_end = 400e-9\ncfl = 0.2\nbonding = none\nbox_margin = 2e-6\nstop_when_settled = no\n"
                      "[material.elastic]\nstrength = elastic\ndensity = 1000\neos_c0 = 1000\neos_s = 0\n"
                      "eos_gamma0 = 0\nG0 = 1e9\nD = 0\nmelt_T0 = 1e5\n";
    if (impact_fixture_open(&f, ini, "sphere,0,0,4.5e-6,0,0,-100,8e-6,0,elastic\n") != SC_OK) {
        CHECK(0, "set-up");
        return;
    }
    CHECK(impact_fixture_run(&f) == SC_OK, "run");
    struct mpm_counts c = mpm_get_counts(f.solver);
    double v_rest = mpm_verdict_vrest(f.solver, 0), v_com_z = mpm_verdict_vcom_z(f.solver, 0);
    int verdict = verdict_of(&f, 0); /* the rigid wall is no body: the particle is body 0 */
    printf("  %lld of %lld points removed by %.4g ns; %s, settled at %.4g ns, v_rest %.4g m/s, v_com_z %.4g m/s\n",
           (long long)c.removed_points, (long long)c.points, 1e9 * c.t, mpm_verdict_name(verdict),
           1e9 * mpm_verdict_settled_at(f.solver, 0), v_rest, v_com_z);
    CHECK(c.removed_points > 0 && isnan(mpm_compute_diagnostics(f.solver)->body[0].v_com[2]),
          "the particle did not leave the box: %lld points removed", (long long)c.removed_points);
    CHECK(verdict == MPM_VERDICT_REBOUNDED, "verdict %s, not rebounded", mpm_verdict_name(verdict));
    CHECK(!mpm_verdict_held(verdict, v_rest, f.cfg.vrest_threshold) && v_rest > 10.0 && v_com_z > 10.0,
          "left the box at v_rest %g, v_com_z %g m/s: judged at rest", v_rest, v_com_z);
    impact_fixture_close(&f);
}

/* The /summary of results written by `run` (its diagnostics written to `name` in `file`); the particle's (body 1)
 * values in out: pbcp, v_rest, cor, bonded_interface, verdict. */
static int summary_of(struct mpm_solver *run, hid_t file, const char *name, double out[5])
{
    hid_t group = H5Gcreate2(file, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (group < 0 || mpm_write_results(run, group) != SC_OK)
        return -1;
    static const char *const fields[] = {"summary/pbcp", "summary/v_rest", "summary/cor", "summary/bonded_interface"};
    double two[2];
    int64_t verdict[2];
    for (int k = 0; k < 4; k++) {
        if (h5_read_doubles(group, fields[k], two, 2) != SC_OK)
            return -1;
        out[k] = two[1];
    }
    if (h5_read_int64s(group, "summary/verdict", verdict, 2) != SC_OK)
        return -1;
    out[4] = (double)verdict[1];
    H5Gclose(group);
    return 0;
}

/* A run resumed from a checkpoint written at its last step (a signal during that step) takes no step and writes its
 * results: its /summary must be the uninterrupted run's.  It held the values of t = 0 (PBCP 0, v_rest the impact
 * speed) where they came from diagnostics that a checkpoint does not restore and no step had computed again.  An 8
 * um particle at 1000 m/s that bonds within 10 ns (tests/test_vcrit.sh's set-up). */
static void test_summary_after_resume_at_end(void)
{
    const char *ini = "[impact]\ngrid = 2e-6\nspacing = 1e-6\ndiameter = 8e-6\nvelocity = 1000\n"
                      "substrate_diameter = 20e-6\nsubstrate_height = 6e-6\nt_end = 10e-9\nbonding = energy\n"
                      "settle_window = 2e-9\nsettle_vcom = 1e4\nsettle_pbcp = 1\nvrest_filter = 1e4\n"
                      "[material.aluminium]\n";
    struct impact_fixture a, b;
    char path[] = "/tmp/spraycoat_resume_end_XXXXXX";
    int fd = mkstemp(path);
    if (fd < 0 || impact_fixture_open(&a, ini, NULL) != SC_OK || impact_fixture_open(&b, ini, NULL) != SC_OK) {
        CHECK(0, "set-up");
        return;
    }
    close(fd);
    CHECK(impact_fixture_run(&a) == SC_OK && mpm_finished(a.solver), "the run to its end");
    hid_t file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    hid_t checkpoint = H5Gcreate2(file, "checkpoint", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(mpm_checkpoint_write(a.solver, checkpoint) == SC_OK, "checkpoint at the end written");
    CHECK(mpm_checkpoint_read(b.solver, checkpoint) == SC_OK && mpm_finished(b.solver), "read: finished, no step");
    H5Gclose(checkpoint);
    double ran[5] = {0}, resumed[5] = {0};
    CHECK(summary_of(a.solver, file, "ran", ran) == 0 && summary_of(b.solver, file, "resumed", resumed) == 0,
          "both summaries written and read");
    printf("  the particle: PBCP %.4g / %.4g, v_rest %.4g / %.4g m/s, CoR %.4g / %.4g, bonded interface %.4g / %.4g, "
           "verdict %g / %g (ran / resumed)\n",
           ran[0], resumed[0], ran[1], resumed[1], ran[2], resumed[2], ran[3], resumed[3], ran[4], resumed[4]);
    CHECK(ran[0] > 0.05 && ran[3] > 0.0 && ran[4] == MPM_VERDICT_BONDED, "the run bonds (the test needs a bond)");
    static const char *const names[] = {"PBCP", "v_rest", "CoR", "bonded interface", "verdict"};
    for (int k = 0; k < 5; k++)
        CHECK(memcmp(&ran[k], &resumed[k], sizeof ran[k]) == 0, "%s: %.17g resumed, %.17g uninterrupted", names[k],
              resumed[k], ran[k]);
    H5Fclose(file);
    unlink(path);
    impact_fixture_close(&a);
    impact_fixture_close(&b);
}

int main(void)
{
    RUN(test_transient_rebound_is_unsettled);
    RUN(test_steady_rebound);
    RUN(test_sliding_off);
    RUN(test_ringing_settles);
    RUN(test_unsettled_cases);
    RUN(test_every_body_settles);
    RUN(test_run_ends_when_settled);
    RUN(test_body_that_left_the_box);
    RUN(test_summary_after_resume_at_end);
    return check_finish();
}
