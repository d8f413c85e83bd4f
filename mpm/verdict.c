/* Settled verdicts (issue 22, item 3; Tang Section 5.2.1 judges bonded/rebounded once the impact reached steady
 * state, about 50-60 ns in Section 4.3.3): a body's verdict counts only once it has stopped changing.
 *
 * A held particle does not come to rest: it rings on the substrate with a period of 10-15 ns (a 30 um Al particle at
 * 770 m/s on the 2 um grid: v_com_z swings by +-1 m/s at 80 ns and +-0.4 m/s at 100 ns), above Tang's 0.6 m/s v_rest
 * threshold, so a judgement on one row's v_rest flips with the phase of the ringing and never settles.  Each row is
 * therefore judged on the means of v_rest and v_com over the window W that ends at it (W: settle_window, or two wave
 * transits across the body, body_window): bonded when PBCP >= pbcp_threshold and the mean v_rest <= vrest_threshold.
 * A row with no point slower than vrest_filter has no judgement while the body is landing; otherwise it counts its
 * centre of mass's speed as its v_rest (row_vrest).  A verdict
 * is settled at a row when over the window ending there every row has a judgement, the same one, the mean v_com_z
 * is >= -settle_vcom (a body still landing is not judged), each component of the mean v_com moved by at most
 * settle_vcom and PBCP by at most settle_pbcp.  A steady motion thus settles two windows after it set in.  The run
 * stops once every particle is settled (stop_when_settled) and otherwise at t_end; a body not settled then is
 * `unsettled`, never rebounded.  Everything here is derived from the recorded series, so a run read back from a
 * checkpoint replays it. */
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "mpm/mpm_impl.h"

/* The series columns of a body (SERIES_PER_BODY in mpm_impl.h, mpm_series_record in diagnostics.c) */
enum { COLUMN_VCOM = 0, COLUMN_KE = 3, COLUMN_PBCP = 8, COLUMN_VREST = 9 };

static const double *series_row(const struct mpm_solver *s, size_t row)
{
    return s->series + row * (SERIES_FIXED + (size_t)s->cfg.body_count * SERIES_PER_BODY);
}

static const double *body_columns(const struct mpm_solver *s, size_t row, int body)
{
    return series_row(s, row) + SERIES_FIXED + (size_t)body * SERIES_PER_BODY;
}

/* Body b's window: settle_window, or two longitudinal wave transits across the body (its largest size over its
 * material's c_L) if that is longer.  A body's velocity changes on that time scale (one period of its fundamental
 * vibration, about 2 D / c_L): a shorter window could find it "steady" while it decelerates slowly on a target,
 * which happens in the millimetre-scale tests (a 14 um Al particle: 4.4 ns, under the 10 ns default). */
static double body_window(const struct mpm_solver *s, int b)
{
    const struct mpm_body *body = &s->cfg.bodies[b];
    double size = body->shape == MPM_SPHERE ? body->d : fmax(body->d, body->h);
    return fmax(s->cfg.settle_window, 2.0 * size / mpm_material_wave_speed(&s->cfg.materials[body->material]));
}

/* The first row of the window of length `window` that ends at `row`: the last one at least that much earlier; -1
 * when the series does not reach that far back. */
static long window_start(const struct mpm_solver *s, size_t row, double window)
{
    double t = series_row(s, row)[0], start = t - window * (1.0 - 1e-9);
    for (long j = (long)row; j >= 0; j--)
        if (series_row(s, (size_t)j)[0] <= start)
            return j;
    return -1;
}

/* The judgement of one row: the means over the window that ends at it, and bonded or not. */
struct judgement {
    double vcom[3], vrest, pbcp;
    int bonded;
};

/* A row's rest velocity: its v_rest, the mean z-velocity of the body's points slower than vrest_filter (Section
 * 5.2.1's filter leaves out the material jetted away).  When no point is that slow and the body does not move towards
 * the substrate (v_com_z >= -settle_vcom, the bound the settling applies), the whole of it leaves faster than the
 * filter, none of it held: its rest velocity is then its centre of mass's speed (ours; without it a rebound at 64 m/s
 * was never judged and stayed `unsettled`).  The speed, not v_com_z: a body sliding off along the substrate is not
 * held.  NaN (no judgement) for a body with no slow point that is landing, or whose values are unknown (a failed
 * device). */
static double row_vrest(const double *c, double settle_vcom)
{
    const double *v = c + COLUMN_VCOM;
    if (!isnan(c[COLUMN_VREST]) || !(v[2] >= -settle_vcom))
        return c[COLUMN_VREST];
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* Body b's judgement at `row` (Section 5.2.1's PBCP and v_rest thresholds on the window means); 0 when the row
 * has none (the series is shorter than the window, or a row of the window has no rest velocity, row_vrest). */
static int judge(const struct mpm_solver *s, size_t row, int b, double window, struct judgement *out)
{
    long first = window_start(s, row, window);
    if (first < 0)
        return 0;
    double sum[4] = {0.0, 0.0, 0.0, 0.0};
    for (long j = first; j <= (long)row; j++) {
        const double *c = body_columns(s, (size_t)j, b);
        double vrest = row_vrest(c, s->cfg.settle_vcom);
        if (isnan(vrest))
            return 0;
        for (int k = 0; k < 3; k++)
            sum[k] += c[COLUMN_VCOM + k];
        sum[3] += vrest;
    }
    double rows = (double)((long)row - first + 1);
    for (int k = 0; k < 3; k++)
        out->vcom[k] = sum[k] / rows;
    out->vrest = sum[3] / rows;
    out->pbcp = body_columns(s, row, b)[COLUMN_PBCP];
    out->bonded = out->pbcp >= s->cfg.pbcp_threshold && out->vrest <= s->cfg.vrest_threshold;
    return 1;
}

/* Whether body b's verdict `last` (its judgement at `row`) is settled over the window of rows first .. row. */
static int settled_over(const struct mpm_solver *s, long first, size_t row, int b, double window,
                        const struct judgement *last)
{
    const struct mpm_config *cfg = &s->cfg;
    double lo[4], hi[4]; /* mean v_com x, y, z and PBCP */
    for (int k = 0; k < 4; k++)
        lo[k] = hi[k] = k < 3 ? last->vcom[k] : last->pbcp;
    for (long j = first; j <= (long)row; j++) {
        struct judgement at;
        /* a body still moving towards the substrate is in flight (or still landing), whatever it reads */
        if (!judge(s, (size_t)j, b, window, &at) || at.bonded != last->bonded || at.vcom[2] < -cfg->settle_vcom)
            return 0;
        for (int k = 0; k < 4; k++) {
            double value = k < 3 ? at.vcom[k] : at.pbcp;
            lo[k] = fmin(lo[k], value), hi[k] = fmax(hi[k], value);
        }
    }
    double vcom_range = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    return vcom_range <= cfg->settle_vcom && hi[3] - lo[3] <= cfg->settle_pbcp;
}

/* A row of a body whose every point has left the grid box: no centre of mass (NaN, mpm/diagnostics.c), no kinetic
 * energy and no PBCP (0, counted over no point); a row of unknown values (a failed device) has NaN in them and is
 * never judged. */
static int gone(const double *c)
{
    return isnan(c[COLUMN_VCOM + 2]) && c[COLUMN_KE] == 0.0 && c[COLUMN_PBCP] == 0.0;
}

/* Body b has left the grid box by series row `row`: it rebounded, settled (nothing of it is left to change), at the
 * time it left unless it had settled before.  Its v_rest and v_com_z stay those of its last judged row, or, never
 * judged, those of the last row it was seen in (its speed as its v_rest, row_vrest's rule for a body leaving faster
 * than the filter): a body that leaves is not at rest.  Before, its empty rows read v_com = 0 and v_rest = 0: it
 * settled as "held, at rest" (a review: an elastic particle at 300 m/s that flew out of the box). */
static int judge_gone(struct mpm_solver *s, size_t row, int b)
{
    s->bonded_now[b] = 0;
    if (isnan(s->settled_at[b]))
        s->settled_at[b] = series_row(s, row)[0];
    for (long j = (long)row - 1; isnan(s->judged_vrest[b]) && j >= 0; j--) {
        const double *c = body_columns(s, (size_t)j, b);
        if (gone(c))
            continue;
        const double *v = c + COLUMN_VCOM;
        s->judged_vrest[b] = isnan(c[COLUMN_VREST]) ? sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) : c[COLUMN_VREST];
        s->judged_vcom_z[b] = v[2];
    }
    return 1;
}

/* Body b's judgement and whether it is settled after series row `row` was recorded. */
static int judge_body(struct mpm_solver *s, size_t row, int b)
{
    if (gone(body_columns(s, row, b)))
        return judge_gone(s, row, b);
    double window = body_window(s, b);
    struct judgement now;
    int judged = judge(s, row, b, window, &now);
    long first = judged ? window_start(s, row, window) : -1;
    int settled = first >= 0 && settled_over(s, first, row, b, window, &now);
    s->bonded_now[b] = judged && now.bonded;
    s->judged_vrest[b] = judged ? now.vrest : NAN;
    s->judged_vcom_z[b] = judged ? now.vcom[2] : NAN;
    if (!settled)
        s->settled_at[b] = NAN;
    else if (isnan(s->settled_at[b]))
        s->settled_at[b] = series_row(s, row)[0];
    return settled;
}

/* The judgement after series row `row` was recorded. */
static void judge_row(struct mpm_solver *s, size_t row)
{
    int particles = 0, settled = 0;
    for (int b = 0; b < s->cfg.body_count; b++) {
        if (s->cfg.bodies[b].substrate)
            continue;
        particles++;
        settled += judge_body(s, row, b);
    }
    s->all_settled = particles > 0 && settled == particles;
}

int mpm_verdict_create(struct mpm_solver *s)
{
    size_t n = (size_t)s->cfg.body_count;
    s->settled_at = malloc(n * sizeof *s->settled_at);
    s->bonded_now = calloc(n, sizeof *s->bonded_now);
    s->judged_vrest = malloc(n * sizeof *s->judged_vrest);
    s->judged_vcom_z = malloc(n * sizeof *s->judged_vcom_z);
    if (!s->settled_at || !s->bonded_now || !s->judged_vrest || !s->judged_vcom_z)
        SC_FAIL_OOM(n * (3 * sizeof(double) + sizeof *s->bonded_now), "the verdicts of the bodies");
    mpm_verdict_replay(s);
    return SC_OK;
}

void mpm_verdict_free(struct mpm_solver *s)
{
    free(s->settled_at);
    free(s->bonded_now);
    free(s->judged_vrest);
    free(s->judged_vcom_z);
}

void mpm_verdict_record(struct mpm_solver *s)
{
    if (s->series_rows > 0)
        judge_row(s, s->series_rows - 1);
}

void mpm_verdict_replay(struct mpm_solver *s)
{
    for (int b = 0; b < s->cfg.body_count; b++)
        s->settled_at[b] = s->judged_vrest[b] = s->judged_vcom_z[b] = NAN, s->bonded_now[b] = 0;
    s->all_settled = 0;
    for (size_t row = 0; row < s->series_rows; row++)
        judge_row(s, row);
}

int mpm_all_settled(const struct mpm_solver *s)
{
    return s->all_settled;
}

double mpm_verdict_settled_at(const struct mpm_solver *s, int body)
{
    return s->cfg.bodies[body].substrate ? NAN : s->settled_at[body];
}

double mpm_verdict_vrest(const struct mpm_solver *s, int body)
{
    return s->cfg.bodies[body].substrate ? NAN : s->judged_vrest[body];
}

double mpm_verdict_vcom_z(const struct mpm_solver *s, int body)
{
    return s->cfg.bodies[body].substrate ? NAN : s->judged_vcom_z[body];
}

void mpm_verdicts(struct mpm_solver *s, int *verdict)
{
    for (int b = 0; b < s->cfg.body_count; b++)
        verdict[b] = s->cfg.bodies[b].substrate ? MPM_VERDICT_SUBSTRATE
                     : isnan(s->settled_at[b])  ? MPM_VERDICT_UNSETTLED
                     : s->bonded_now[b]         ? MPM_VERDICT_BONDED
                                                : MPM_VERDICT_REBOUNDED;
}

int mpm_verdict_held(int verdict, double v_rest, double vrest_threshold)
{
    return verdict == MPM_VERDICT_REBOUNDED && v_rest <= vrest_threshold;
}

const char *mpm_verdict_name(int verdict)
{
    switch (verdict) {
    case MPM_VERDICT_BONDED:
        return "bonded";
    case MPM_VERDICT_REBOUNDED:
        return "rebounded";
    case MPM_VERDICT_UNSETTLED:
        return "unsettled";
    default:
        return "-";
    }
}
