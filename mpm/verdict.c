/* Settled verdicts (issue 22, item 3; Tang Section 5.2.1 judges bonded/rebounded once the impact reached steady
 * state, about 50-60 ns in Section 4.3.3): a body's verdict counts only once it has stopped changing.  At every
 * series row (series_every) each particle is judged on that row's PBCP and v_rest (bonded: PBCP >= pbcp_threshold
 * and v_rest <= vrest_threshold); its verdict is settled at a row when over the window [t - W, t] (W:
 * settle_window, or two wave transits across the body, body_window) every row has a v_rest (some point slower
 * than vrest_filter), the body does not move towards the substrate (v_com_z >= -settle_vcom), the judgement is
 * the same, v_com moved by at most settle_vcom in every component and PBCP by at most settle_pbcp.  The run stops
 * once every particle is settled (stop_when_settled) and otherwise at t_end; a body not settled then is
 * `unsettled`, never rebounded.  Everything here is derived from the recorded series, so a run read back from a
 * checkpoint replays it. */
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "mpm/mpm_impl.h"

/* The series columns of a body (SERIES_PER_BODY in mpm_impl.h, mpm_series_record in diagnostics.c) */
enum { COLUMN_VCOM = 0, COLUMN_PBCP = 8, COLUMN_VREST = 9 };

static const double *series_row(const struct mpm_solver *s, size_t row)
{
    return s->series + row * (SERIES_FIXED + (size_t)s->cfg.body_count * SERIES_PER_BODY);
}

static const double *body_columns(const struct mpm_solver *s, size_t row, int body)
{
    return series_row(s, row) + SERIES_FIXED + (size_t)body * SERIES_PER_BODY;
}

/* Bonded at one row: Eq. 5.1's PBCP and the restitution velocity against the thresholds (Section 5.2.1). */
static int bonded_at(const struct mpm_config *cfg, const double *columns)
{
    return columns[COLUMN_PBCP] >= cfg->pbcp_threshold && columns[COLUMN_VREST] <= cfg->vrest_threshold;
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

/* Whether body b's verdict is settled over the window of rows first .. row. */
static int settled_over(const struct mpm_solver *s, long first, size_t row, int b)
{
    const struct mpm_config *cfg = &s->cfg;
    const double *last = body_columns(s, row, b);
    double lo[4], hi[4]; /* v_com x, y, z and PBCP */
    for (int k = 0; k < 4; k++)
        lo[k] = hi[k] = k < 3 ? last[COLUMN_VCOM + k] : last[COLUMN_PBCP];
    int verdict = bonded_at(cfg, last);
    for (long j = first; j <= (long)row; j++) {
        const double *c = body_columns(s, (size_t)j, b);
        /* a body still moving towards the substrate is in flight (or still landing), whatever it reads */
        if (isnan(c[COLUMN_VREST]) || bonded_at(cfg, c) != verdict || c[COLUMN_VCOM + 2] < -cfg->settle_vcom)
            return 0;
        for (int k = 0; k < 4; k++) {
            double value = k < 3 ? c[COLUMN_VCOM + k] : c[COLUMN_PBCP];
            lo[k] = fmin(lo[k], value), hi[k] = fmax(hi[k], value);
        }
    }
    double vcom_range = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    return vcom_range <= cfg->settle_vcom && hi[3] - lo[3] <= cfg->settle_pbcp;
}

/* The judgement after series row `row` was recorded. */
static void judge_row(struct mpm_solver *s, size_t row)
{
    double t = series_row(s, row)[0];
    int particles = 0, settled = 0;
    for (int b = 0; b < s->cfg.body_count; b++) {
        if (s->cfg.bodies[b].substrate)
            continue;
        particles++;
        long first = window_start(s, row, body_window(s, b));
        if (first >= 0 && settled_over(s, first, row, b)) {
            if (isnan(s->settled_at[b]))
                s->settled_at[b] = t;
            settled++;
        } else {
            s->settled_at[b] = NAN;
        }
        s->bonded_now[b] = bonded_at(&s->cfg, body_columns(s, row, b));
    }
    s->all_settled = particles > 0 && settled == particles;
}

int mpm_verdict_create(struct mpm_solver *s)
{
    size_t n = (size_t)s->cfg.body_count;
    s->settled_at = malloc(n * sizeof *s->settled_at);
    s->bonded_now = calloc(n, sizeof *s->bonded_now);
    if (!s->settled_at || !s->bonded_now)
        SC_FAIL_OOM(n * (sizeof *s->settled_at + sizeof *s->bonded_now), "the verdicts of the bodies");
    mpm_verdict_replay(s);
    return SC_OK;
}

void mpm_verdict_free(struct mpm_solver *s)
{
    free(s->settled_at);
    free(s->bonded_now);
}

void mpm_verdict_record(struct mpm_solver *s)
{
    if (s->series_rows > 0)
        judge_row(s, s->series_rows - 1);
}

void mpm_verdict_replay(struct mpm_solver *s)
{
    for (int b = 0; b < s->cfg.body_count; b++)
        s->settled_at[b] = NAN, s->bonded_now[b] = 0;
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

void mpm_verdicts(struct mpm_solver *s, int *verdict)
{
    for (int b = 0; b < s->cfg.body_count; b++)
        verdict[b] = s->cfg.bodies[b].substrate ? MPM_VERDICT_SUBSTRATE
                     : isnan(s->settled_at[b])  ? MPM_VERDICT_UNSETTLED
                     : s->bonded_now[b]         ? MPM_VERDICT_BONDED
                                                : MPM_VERDICT_REBOUNDED;
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
