/* From spray impacts to MPM seeds: the [couple] keys, the sampling strata and the placement (coupling/coupling.h).
 * No equations of the papers: the sampling and the frames are docs/physics.md's ("The couple stage"). */
#include "coupling/coupling.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "core/run_keys.h"

const struct cfg_key couple_case_keys[] = {
    {"couple", "sample", CFG_CHOICE, "", "random", 0, 0, 0, "random|stratified|window",
     "which spray impacts become MPM bodies: uniform at random, stratified by diameter then speed quantiles, or "
     "the arrivals inside a square window of the target in arrival order"},
    {"couple", "bodies_per_run", CFG_INT, "", "1", 1, 1000, 0, NULL, "bodies (seeds) in each impact run"},
    {"couple", "runs", CFG_INT, "", "1", 1, 100000, 0, NULL, "independent impact runs"},
    {"couple", "rtol", CFG_REAL, "-", "1e-8", 1e-14, 1e-2, 0, NULL, "CVODE relative tolerance of the flight"},
    {"couple", "atol", CFG_REAL, "-", "1e-10", 1e-16, 1e-2, 0, NULL,
     "CVODE absolute tolerance, relative to the hand-off distance (positions) and speed (velocities)"},
    {"couple", "patch_size", CFG_REAL, "m", "40e-6", 0, 0.1, CFG_MIN_EXCLUSIVE, NULL,
     "side of the square patch of the target that one impact run stands for (lateral offsets lie inside it); the "
     "substrate must hold it where a run's bodies spread over it (bodies_per_run >= 2, or sample = window): "
     "substrate_diameter >= sqrt(2) patch_size + the largest diameter (a box: patch_size + it)"},
    {"couple", "window_x", CFG_REAL, "m", "0", -1, 1, 0, NULL, "sample = window: x of the window's centre"},
    {"couple", "window_y", CFG_REAL, "m", "0", -1, 1, 0, NULL, "sample = window: y of the window's centre"},
    {"couple", "max_gap", CFG_REAL, "m", "10e-6", 0, 1e-3, 0, NULL,
     "highest start of a later body above the substrate before any lift to clear an earlier one: the run's "
     "arrival-time differences are compressed by one factor to it, keeping their order and ratios"},
    {"couple", "reference_diameter", CFG_REAL, "m", "0", 0, 1, 0, NULL,
     "0: every impact run on the grid and substrate of [impact]; > 0 (bodies_per_run = 1): [impact] describes a "
     "particle of this diameter, and the run of a particle of diameter d has its grid, spacing, substrate, box_margin "
     "and times scaled by d / reference_diameter (the same cells per diameter for every size, as [vcrit] "
     "reference_diameter; docs/physics.md \"Resolution in cells per diameter\")"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

int couple_config_load(const struct case_file *c, struct couple_config *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->sample = case_is(c, "couple", "sample", "stratified") ? COUPLE_STRATIFIED
                  : case_is(c, "couple", "sample", "window")   ? COUPLE_WINDOW
                                                               : COUPLE_RANDOM;
    cfg->bodies_per_run = case_int(c, "couple", "bodies_per_run");
    cfg->runs = case_int(c, "couple", "runs");
    cfg->rtol = case_real(c, "couple", "rtol");
    cfg->atol = case_real(c, "couple", "atol");
    cfg->patch_size = case_real(c, "couple", "patch_size");
    cfg->window_x = case_real(c, "couple", "window_x");
    cfg->window_y = case_real(c, "couple", "window_y");
    cfg->max_gap = case_real(c, "couple", "max_gap");
    cfg->reference_diameter = case_real(c, "couple", "reference_diameter");
    if (cfg->reference_diameter > 0 && cfg->bodies_per_run != 1)
        return case_invalid(c, "couple", "reference_diameter",
                            "%g m with bodies_per_run = %ld: a run's set-up is scaled to its one particle; allowed: 0, "
                            "or bodies_per_run = 1",
                            cfg->reference_diameter, cfg->bodies_per_run);
    struct run_settings run;
    run_settings_load(c, &run);
    cfg->seed = run.seed;
    if ((double)cfg->runs * (double)cfg->bodies_per_run > 1e6)
        return case_invalid(c, "couple", "runs", "runs * bodies_per_run = %.0f seeds; allowed: at most 1e6",
                            (double)cfg->runs * (double)cfg->bodies_per_run);
    return SC_OK;
}

/* ---- strata ------------------------------------------------------------------------------------------------ */

static const struct couple_candidate *sort_candidates;
static int sort_key; /* 0 diameter, 1 speed, 2 arrival time */

static double candidate_key(const struct couple_candidate *a)
{
    if (sort_key == 0)
        return a->d;
    if (sort_key == 1)
        return sqrt(a->v[0] * a->v[0] + a->v[1] * a->v[1] + a->v[2] * a->v[2]);
    return a->t;
}

/* Ties broken by the impact row: a total order, so the strata do not depend on qsort's algorithm. */
static int compare_members(const void *pa, const void *pb)
{
    const struct couple_candidate *a = &sort_candidates[*(const size_t *)pa],
                                  *b = &sort_candidates[*(const size_t *)pb];
    double ka = candidate_key(a), kb = candidate_key(b);
    if (ka != kb)
        return ka < kb ? -1 : 1;
    return (a->impact_row > b->impact_row) - (a->impact_row < b->impact_row);
}

static void sort_members(const struct couple_candidate *candidates, size_t *members, size_t count, int key)
{
    sort_candidates = candidates;
    sort_key = key;
    qsort(members, count, sizeof *members, compare_members);
}

/* Fisher-Yates with the counter-based generator keyed by (seed, stream, stratum, position). */
static void shuffle(uint32_t seed, uint64_t stratum, size_t *members, size_t count)
{
    for (size_t i = count; i > 1; i--) {
        double u[2];
        rng_uniform2(seed, RNG_STREAM_COUPLE_SAMPLE, stratum, (uint32_t)(i - 1), 0, u);
        size_t j = (size_t)(u[0] * (double)i);
        if (j >= i)
            j = i - 1;
        size_t swap = members[i - 1];
        members[i - 1] = members[j];
        members[j] = swap;
    }
}

static int strata_alloc(struct couple_strata *s, size_t strata, size_t members, size_t slots)
{
    s->count = strata;
    s->offset = calloc(strata + 1, sizeof *s->offset);
    s->members = calloc(members ? members : 1, sizeof *s->members);
    s->slot_stratum = calloc(slots ? slots : 1, sizeof *s->slot_stratum);
    if (!s->offset || !s->members || !s->slot_stratum) {
        couple_strata_free(s);
        SC_FAIL_OOM((strata + 1) * sizeof *s->offset + (members ? members : 1) * sizeof *s->members +
                        (slots ? slots : 1) * sizeof *s->slot_stratum,
                    "the strata of the candidates");
    }
    return SC_OK;
}

/* random: one stratum, every candidate, shuffled. */
static int build_random(const struct couple_config *cfg, size_t n, size_t seeds, struct couple_strata *s)
{
    SC_TRY(strata_alloc(s, 1, n, seeds));
    for (size_t i = 0; i < n; i++)
        s->members[i] = i;
    s->offset[1] = n;
    shuffle(cfg->seed, 0, s->members, n);
    return SC_OK;
}

/* window: one stratum, the candidates inside the window in order of arrival. */
static int build_window(const struct couple_config *cfg, const struct couple_candidate *cand, size_t n, size_t seeds,
                        struct couple_strata *s)
{
    SC_TRY(strata_alloc(s, 1, n, seeds));
    size_t inside = 0;
    double half = 0.5 * cfg->patch_size;
    for (size_t i = 0; i < n; i++)
        if (fabs(cand[i].x[0] - cfg->window_x) <= half && fabs(cand[i].x[1] - cfg->window_y) <= half)
            s->members[inside++] = i;
    sort_members(cand, s->members, inside, 2);
    s->offset[1] = inside;
    return SC_OK;
}

/* stratified: n_d diameter strata; diameter stratum i holds the seeds k = i, i + n_d, ... and is split by speed
 * into one sub-stratum per seed.  Each diameter stratum's share of the candidates is its share of the seeds (the
 * first ones get one seed more when n_d does not divide N): every sub-stratum then holds at least n / N >= 1
 * candidates (equal quantiles left the first, which has the most seeds, with fewer candidates than seeds for some n
 * >= N, and a seed without candidates), and each seed stands for the same share of the impacts. */
static int build_stratified(const struct couple_config *cfg, const struct couple_candidate *cand, size_t n,
                            size_t seeds, struct couple_strata *s)
{
    size_t n_d = (size_t)ceil(sqrt((double)seeds));
    size_t *by_diameter = malloc((n ? n : 1) * sizeof *by_diameter);
    if (!by_diameter)
        SC_FAIL_OOM((n ? n : 1) * sizeof *by_diameter, "the candidates by diameter");
    for (size_t i = 0; i < n; i++)
        by_diameter[i] = i;
    sort_members(cand, by_diameter, n, 0);
    int status;
    SC_CHECK(status, strata_alloc(s, seeds, n, seeds), done);
    size_t stratum = 0, seeds_before = 0;
    for (size_t i = 0; i < n_d; i++) {
        size_t slots = (seeds - i + n_d - 1) / n_d;                                         /* seeds i, i + n_d, ... */
        size_t first = seeds_before * n / seeds, last = (seeds_before + slots) * n / seeds; /* diameter quantile i */
        seeds_before += slots;
        sort_members(cand, by_diameter + first, last - first, 1);
        for (size_t j = 0; j < slots; j++, stratum++) {
            size_t lo = first + j * (last - first) / slots, hi = first + (j + 1) * (last - first) / slots;
            memcpy(s->members + s->offset[stratum], by_diameter + lo, (hi - lo) * sizeof *by_diameter);
            s->offset[stratum + 1] = s->offset[stratum] + (hi - lo);
            shuffle(cfg->seed, stratum + 1, s->members + s->offset[stratum], hi - lo);
            s->slot_stratum[i + j * n_d] = stratum;
        }
    }
done:
    free(by_diameter);
    return status;
}

/* An SC_EINPUT error about a [couple] key: in the case file's form when there is a case (the stage), plain when
 * the strata are built without one (the tests). */
static int couple_invalid(const struct case_file *c, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static int couple_invalid(const struct case_file *c, const char *key, const char *fmt, ...)
{
    char message[1024];
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    if (c)
        return case_invalid(c, "couple", key, "%s", message);
    return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "[couple] %s: %s", key, message);
}

int couple_strata_build(const struct case_file *c, const struct couple_config *cfg,
                        const struct couple_candidate *candidates, size_t n, struct couple_strata *strata)
{
    memset(strata, 0, sizeof *strata);
    size_t seeds = (size_t)(cfg->runs * cfg->bodies_per_run);
    if (n < seeds)
        return couple_invalid(c, "runs",
                              "%ld runs of %ld bodies need %zu spray impacts, and spray.h5 has %zu "
                              "particles that reached the target; allowed: runs * bodies_per_run <= %zu",
                              cfg->runs, cfg->bodies_per_run, seeds, n, n);
    if (cfg->sample == COUPLE_RANDOM)
        SC_TRY(build_random(cfg, n, seeds, strata));
    else if (cfg->sample == COUPLE_WINDOW)
        SC_TRY(build_window(cfg, candidates, n, seeds, strata));
    else
        SC_TRY(build_stratified(cfg, candidates, n, seeds, strata));
    size_t members = strata->offset[strata->count];
    if (cfg->sample == COUPLE_WINDOW && members < seeds) {
        couple_strata_free(strata);
        return couple_invalid(c, "patch_size",
                              "the window of %g m centred at (%g, %g) m holds %zu arrivals, "
                              "fewer than the %zu seeds of %ld runs of %ld bodies; allowed: a larger window, fewer "
                              "runs or bodies",
                              cfg->patch_size, cfg->window_x, cfg->window_y, members, seeds, cfg->runs,
                              cfg->bodies_per_run);
    }
    return SC_OK;
}

void couple_strata_free(struct couple_strata *strata)
{
    free(strata->offset);
    free(strata->members);
    free(strata->slot_stratum);
    memset(strata, 0, sizeof *strata);
}

/* ---- runs and placement ------------------------------------------------------------------------------------ */

void couple_assign_runs(const struct couple_config *cfg, struct couple_seed *seeds, size_t count)
{
    if (cfg->sample == COUPLE_STRATIFIED && cfg->bodies_per_run > 1)
        for (size_t i = count; i > 1; i--) { /* Fisher-Yates, as shuffle */
            double u[2];
            rng_uniform2(cfg->seed, RNG_STREAM_COUPLE_RUNS, 0, (uint32_t)(i - 1), 0, u);
            size_t j = (size_t)(u[0] * (double)i);
            if (j >= i)
                j = i - 1;
            struct couple_seed swap = seeds[i - 1];
            seeds[i - 1] = seeds[j];
            seeds[j] = swap;
        }
    for (size_t k = 0; k < count; k++)
        seeds[k].run = (int64_t)(k / (size_t)cfg->bodies_per_run);
}

static int compare_arrival(const void *pa, const void *pb)
{
    const struct couple_seed *a = pa, *b = pb;
    if (a->t_wall != b->t_wall)
        return a->t_wall < b->t_wall ? -1 : 1;
    return (a->candidate > b->candidate) - (a->candidate < b->candidate);
}

/* x folded periodically into [-size/2, size/2). */
static double fold(double x, double size)
{
    return x - size * floor(x / size + 0.5);
}

/* Lift body k until it clears every earlier body of the run (bodies may touch, not overlap).  A lift only raises
 * k, and puts it above j's centre, where raising it further moves it away from j: each earlier body lifts it at
 * most once, so k + 1 passes always end with no overlap (a fixed 64 could in principle stop short silently; in
 * order of arrival the earlier bodies lie below one another and one pass suffices). */
static void clear_earlier_bodies(struct couple_seed *seeds, size_t k)
{
    for (size_t pass = 0; pass <= k; pass++) {
        int moved = 0;
        for (size_t j = 0; j < k; j++) {
            double dx = seeds[k].center[0] - seeds[j].center[0], dy = seeds[k].center[1] - seeds[j].center[1];
            double reach = 0.5 * (seeds[k].d + seeds[j].d) * (1.0 + 1e-9), lateral2 = dx * dx + dy * dy;
            double dz = seeds[k].center[2] - seeds[j].center[2];
            if (lateral2 + dz * dz >= reach * reach)
                continue;
            seeds[k].center[2] = seeds[j].center[2] + sqrt(reach * reach - lateral2);
            moved = 1;
        }
        if (!moved)
            return;
    }
}

/* The one factor by which the run's arrival-time differences are compressed so that the highest start, |v_z| (t -
 * t_first) times it, is max_gap (1 when every start is below it).  One factor for all keeps the order of arrival
 * and the ratios of the intervals: a bound on each height alone (min(max_gap, |v_z| dt)) started every later body
 * at max_gap, where the faster one arrives first, reversing the order (a review: 2 us after a 550 m/s arrival a
 * 750 m/s one hit the substrate 5 ns before it). */
static double time_compression(const struct couple_config *cfg, const struct couple_seed *seeds, size_t count)
{
    double highest = 0.0;
    for (size_t k = 1; k < count; k++)
        highest = fmax(highest, fabs(seeds[k].v_wall[2]) * (seeds[k].t_wall - seeds[0].t_wall));
    return highest > cfg->max_gap ? cfg->max_gap / highest : 1.0;
}

void couple_place_run(const struct couple_config *cfg, struct couple_seed *seeds, size_t count)
{
    if (count == 0)
        return;
    qsort(seeds, count, sizeof *seeds, compare_arrival);
    const struct couple_seed *first = &seeds[0];
    double compression = time_compression(cfg, seeds, count);
    for (size_t k = 0; k < count; k++) {
        struct couple_seed *s = &seeds[k];
        s->body = (int64_t)k;
        if (cfg->sample == COUPLE_WINDOW) {
            s->center[0] = s->x_wall[0] - cfg->window_x;
            s->center[1] = s->x_wall[1] - cfg->window_y;
        } else {
            s->center[0] = fold(s->x_wall[0] - first->x_wall[0], cfg->patch_size);
            s->center[1] = fold(s->x_wall[1] - first->x_wall[1], cfg->patch_size);
        }
        double gap = fabs(s->v_wall[2]) * (s->t_wall - first->t_wall) * compression;
        s->center[2] = 0.5 * s->d + gap;
        /* the spray frame's +z points at the target; the impact frame's substrate is below, at z < 0 */
        s->velocity[0] = s->v_wall[0];
        s->velocity[1] = s->v_wall[1];
        s->velocity[2] = -s->v_wall[2];
        clear_earlier_bodies(seeds, k);
    }
}
