/* The couple stage's sampling and placement (coupling/couple.h) on synthetic impacts: random draws every
 * candidate once, stratified covers every diameter quantile with speed sub-strata inside it, window keeps the
 * arrivals inside the window in arrival order, and the placement keeps lateral offsets and arrival order, bounds
 * the heights and never overlaps bodies. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "coupling/coupling.h"
#include "tests/check.h"

#define CANDIDATES 997

static struct couple_candidate candidates[CANDIDATES];

/* Diameters 5-40 um, speeds 400-900 m/s, positions over a 20 mm square, arrival times in [0, 1 ms), all from
 * the test stream of the generator (fixed). */
static void make_candidates(void)
{
    for (int i = 0; i < CANDIDATES; i++) {
        double u[2], w[2];
        rng_uniform2(5, RNG_STREAM_TEST, (uint64_t)i, 0, 0, u);
        rng_uniform2(5, RNG_STREAM_TEST, (uint64_t)i, 1, 0, w);
        struct couple_candidate *c = &candidates[i];
        c->impact_row = 3 * i + 1;
        c->particle_id = i;
        c->d = 5e-6 + 35e-6 * u[0];
        c->v[2] = 400.0 + 500.0 * u[1];
        c->x[0] = 0.02 * (w[0] - 0.5);
        c->x[1] = 0.02 * (w[1] - 0.5);
        rng_uniform2(5, RNG_STREAM_TEST, (uint64_t)i, 2, 0, u);
        c->t = 1e-3 * u[0];
        c->m = 2700.0 * M_PI * c->d * c->d * c->d / 6.0;
    }
}

static struct couple_config config(enum couple_sample sample, long runs, long bodies)
{
    struct couple_config cfg = {.sample = sample,
                                .runs = runs,
                                .bodies_per_run = bodies,
                                .rtol = 1e-8,
                                .atol = 1e-10,
                                .patch_size = 40e-6,
                                .max_gap = 10e-6,
                                .seed = 3};
    return cfg;
}

static int compare_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void test_random_is_a_permutation(void)
{
    struct couple_config cfg = config(COUPLE_RANDOM, 10, 3);
    struct couple_strata s;
    CHECK(couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &s) == SC_OK, "%s", sc_error_message());
    CHECK(s.count == 1 && s.offset[1] == CANDIDATES, "one stratum of all %d candidates", CANDIDATES);
    int *seen = calloc(CANDIDATES, sizeof *seen), in_order = 0;
    for (size_t i = 0; i < s.offset[1]; i++) {
        seen[s.members[i]]++;
        in_order += s.members[i] == i;
    }
    int once = 1;
    for (int i = 0; i < CANDIDATES; i++)
        once &= seen[i] == 1;
    CHECK(once, "every candidate exactly once");
    CHECK(in_order < 20, "shuffled (%d of %d in place)", in_order, CANDIDATES);
    free(seen);
    couple_strata_free(&s);
}

static void test_random_is_reproducible(void)
{
    struct couple_config cfg = config(COUPLE_RANDOM, 4, 1);
    struct couple_strata a, b, c;
    couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &a);
    couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &b);
    cfg.seed = 99;
    couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &c);
    CHECK(memcmp(a.members, b.members, CANDIDATES * sizeof *a.members) == 0, "same seed, same order");
    CHECK(memcmp(a.members, c.members, CANDIDATES * sizeof *a.members) != 0, "another seed, another order");
    couple_strata_free(&a);
    couple_strata_free(&b);
    couple_strata_free(&c);
}

/* Stratified over as few candidates as seeds, or a few more, for N = 2..20 seeds (runs of one body): every seed's
 * stratum holds candidates, and their sizes differ by at most one share (n / N rounded, +1).  With the diameter
 * quantiles of equal count, N = n = 3 gave the first quantile (2 seeds) 1 candidate, and the stage stopped with
 * "no further spray impact of its stratum" though the spray had enough. */
static void test_stratified_never_empty(void)
{
    int empty = 0, uneven = 0;
    for (long seeds = 2; seeds <= 20; seeds++)
        for (size_t n = (size_t)seeds; n < (size_t)seeds + 8; n++) {
            struct couple_config cfg = config(COUPLE_STRATIFIED, seeds, 1);
            struct couple_strata s;
            if (couple_strata_build(NULL, &cfg, candidates, n, &s) != SC_OK) {
                CHECK(0, "N %ld, n %zu: %s", seeds, n, sc_error_message());
                sc_error_clear();
                continue;
            }
            for (size_t k = 0; k < s.count; k++) {
                size_t size = s.offset[k + 1] - s.offset[k];
                if (size == 0 && !empty++)
                    printf("  N %ld, n %zu: stratum %zu is empty\n", seeds, n, k);
                uneven += size > n / (size_t)seeds + 1;
            }
            CHECK(s.offset[s.count] == n, "N %ld, n %zu: the strata hold %zu candidates", seeds, n, s.offset[s.count]);
            couple_strata_free(&s);
        }
    CHECK(empty == 0, "%d empty strata", empty);
    CHECK(uneven == 0, "%d strata hold more than one share and one", uneven);
}

/* N = 12 seeds: n_d = 4 diameter quantiles of the candidates, three seeds each; each seed's stratum lies inside
 * its diameter quantile and inside one third of that quantile's speed range; the strata of one quantile do not
 * overlap and together hold the whole quantile. */
static void test_stratified_covers_every_quantile(void)
{
    struct couple_config cfg = config(COUPLE_STRATIFIED, 6, 2);
    size_t seeds = 12, n_d = 4;
    struct couple_strata s;
    CHECK(couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &s) == SC_OK, "%s", sc_error_message());
    CHECK(s.count == seeds, "one stratum per seed (%zu)", s.count);
    double sorted[CANDIDATES];
    for (int i = 0; i < CANDIDATES; i++)
        sorted[i] = candidates[i].d;
    qsort(sorted, CANDIDATES, sizeof *sorted, compare_double);
    size_t per_quantile[4] = {0}, members_per_quantile[4] = {0};
    for (size_t k = 0; k < seeds; k++) {
        size_t q = k % n_d, st = s.slot_stratum[k];
        double lo = sorted[q * CANDIDATES / n_d], hi = sorted[(q + 1) * CANDIDATES / n_d - 1];
        int inside = s.offset[st + 1] > s.offset[st];
        for (size_t m = s.offset[st]; m < s.offset[st + 1]; m++)
            inside &= candidates[s.members[m]].d >= lo && candidates[s.members[m]].d <= hi;
        CHECK(inside, "seed %zu: its stratum lies in diameter quantile %zu [%g, %g]", k, q, lo, hi);
        per_quantile[q]++;
        members_per_quantile[q] += s.offset[st + 1] - s.offset[st];
    }
    for (size_t q = 0; q < n_d; q++) {
        CHECK(per_quantile[q] == 3, "quantile %zu has 3 seeds (%zu)", q, per_quantile[q]);
        size_t size = (q + 1) * CANDIDATES / n_d - q * CANDIDATES / n_d;
        CHECK(members_per_quantile[q] == size, "the speed strata of quantile %zu hold all %zu of it (%zu)", q, size,
              members_per_quantile[q]);
    }
    /* speed order of the sub-strata of quantile 0 (seeds 0, 4, 8): each one's speeds below the next one's */
    for (size_t j = 0; j + 1 < 3; j++) {
        size_t a = s.slot_stratum[j * n_d], b = s.slot_stratum[(j + 1) * n_d];
        double max_a = 0.0, min_b = INFINITY;
        for (size_t m = s.offset[a]; m < s.offset[a + 1]; m++)
            max_a = fmax(max_a, candidates[s.members[m]].v[2]);
        for (size_t m = s.offset[b]; m < s.offset[b + 1]; m++)
            min_b = fmin(min_b, candidates[s.members[m]].v[2]);
        CHECK(max_a <= min_b, "speed sub-stratum %zu below %zu (%g <= %g)", j, j + 1, max_a, min_b);
    }
    couple_strata_free(&s);
}

static void test_window_in_arrival_order(void)
{
    struct couple_config cfg = config(COUPLE_WINDOW, 2, 2);
    cfg.patch_size = 4e-3;
    cfg.window_x = 1e-3;
    cfg.window_y = -2e-3;
    struct couple_strata s;
    CHECK(couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &s) == SC_OK, "%s", sc_error_message());
    size_t expected = 0;
    for (int i = 0; i < CANDIDATES; i++)
        expected += fabs(candidates[i].x[0] - 1e-3) <= 2e-3 && fabs(candidates[i].x[1] + 2e-3) <= 2e-3;
    CHECK(s.offset[1] == expected && expected >= 4, "the window holds %zu arrivals (%zu)", expected, s.offset[1]);
    int ordered = 1, inside = 1;
    for (size_t m = 0; m < s.offset[1]; m++) {
        const struct couple_candidate *c = &candidates[s.members[m]];
        inside &= fabs(c->x[0] - 1e-3) <= 2e-3 && fabs(c->x[1] + 2e-3) <= 2e-3;
        if (m > 0)
            ordered &= candidates[s.members[m - 1]].t <= c->t;
    }
    CHECK(inside && ordered, "inside the window (%d), in arrival order (%d)", inside, ordered);
    couple_strata_free(&s);
    /* a window with fewer arrivals than seeds is refused */
    cfg.patch_size = 1e-6;
    CHECK(couple_strata_build(NULL, &cfg, candidates, CANDIDATES, &s) == SC_EINPUT, "an empty window is an error");
}

static void test_too_few_candidates(void)
{
    struct couple_config cfg = config(COUPLE_RANDOM, 5, 3);
    struct couple_strata s;
    CHECK(couple_strata_build(NULL, &cfg, candidates, 14, &s) == SC_EINPUT, "15 seeds from 14 impacts refused");
    CHECK(strstr(sc_error_message(), "runs") != NULL, "the message names the key: %s", sc_error_message());
}

static struct couple_seed seed_at(double t, double x, double y, double vz, double d)
{
    struct couple_seed s = {.t_wall = t, .d = d};
    s.x_wall[0] = x;
    s.x_wall[1] = y;
    s.v_wall[0] = 3.0;
    s.v_wall[2] = vz;
    return s;
}

/* Window placement: offsets from the window's centre, bodies in arrival order, the first touching, a later
 * one |v_z| (t - t_first) c higher (c the run's one compression that puts the highest start at max_gap),
 * velocities mirrored into the impact frame. */
static void test_place_window(void)
{
    struct couple_config cfg = config(COUPLE_WINDOW, 1, 3);
    cfg.window_x = 1e-3;
    cfg.window_y = 2e-3;
    struct couple_seed seeds[3] = {seed_at(2e-9, 1e-3 + 12e-6, 2e-3, 700.0, 10e-6),
                                   seed_at(0.0, 1e-3 - 15e-6, 2e-3 + 5e-6, 650.0, 14e-6),
                                   seed_at(1e-6, 1e-3, 2e-3 - 18e-6, 600.0, 8e-6)};
    seeds[0].candidate = 0, seeds[1].candidate = 1, seeds[2].candidate = 2;
    couple_place_run(&cfg, seeds, 3);
    CHECK(seeds[0].candidate == 1 && seeds[1].candidate == 0 && seeds[2].candidate == 2, "arrival order");
    CHECK_CLOSE(seeds[0].center[0], -15e-6, 1e-9, 1e-15, "offset x kept");
    CHECK_CLOSE(seeds[0].center[1], 5e-6, 1e-9, 1e-15, "offset y kept");
    CHECK_CLOSE(seeds[0].center[2], 7e-6, 1e-12, 0.0, "the first arrival touches the substrate");
    double c = cfg.max_gap / (600.0 * 1e-6); /* the last arrival's 600 um compressed to max_gap */
    CHECK_CLOSE(seeds[1].center[2], 5e-6 + 700.0 * 2e-9 * c, 1e-12, 0.0, "height from the compressed time difference");
    CHECK_CLOSE(seeds[2].center[2], 4e-6 + cfg.max_gap, 1e-12, 0.0, "the highest start at max_gap");
    CHECK(seeds[1].velocity[2] == -700.0 && seeds[1].velocity[0] == 3.0, "velocity towards the substrate");
    CHECK(seeds[0].body == 0 && seeds[2].body == 2, "bodies numbered in arrival order");
}

/* Stratified, 3 runs of 3 bodies: the 9 slots are 3 diameter quantiles x 3 speed quantiles (slot k: diameter k % 3,
 * speed k / 3).  In slot order run r held speed quantile r of every size, the slowest third all in run 0 (a
 * review); shuffled among the runs, each run holds on average one slot of the slowest speed quantile, over 200
 * seeds within 0.2 (4 standard errors: 3 of 9 drawn with 3 slow has variance 0.5).  Other rules keep slot order. */
static void test_runs_mix_speed_quantiles(void)
{
    double slowest[3] = {0.0, 0.0, 0.0};
    const int trials = 200;
    for (int t = 0; t < trials; t++) {
        struct couple_config cfg = config(COUPLE_STRATIFIED, 3, 3);
        cfg.seed = (uint32_t)(1000 + t);
        struct couple_seed seeds[9];
        for (size_t k = 0; k < 9; k++)
            seeds[k] = (struct couple_seed){.candidate = k};
        couple_assign_runs(&cfg, seeds, 9);
        for (size_t k = 0; k < 9; k++) {
            CHECK(seeds[k].run == (int64_t)(k / 3), "seed %zu in run %lld", k, (long long)seeds[k].run);
            slowest[k / 3] += seeds[k].candidate / 3 == 0 ? 1.0 / trials : 0.0;
        }
    }
    printf("  slots of the slowest speed quantile per run, mean over %d seeds: %.3f %.3f %.3f\n", trials, slowest[0],
           slowest[1], slowest[2]);
    for (int r = 0; r < 3; r++)
        CHECK(fabs(slowest[r] - 1.0) < 0.2, "run %d holds %.3f of the slowest slots on average, not 1", r, slowest[r]);
    struct couple_config random = config(COUPLE_RANDOM, 3, 3);
    struct couple_seed seeds[9];
    for (size_t k = 0; k < 9; k++)
        seeds[k] = (struct couple_seed){.candidate = k};
    couple_assign_runs(&random, seeds, 9);
    for (size_t k = 0; k < 9; k++)
        CHECK(seeds[k].candidate == k && seeds[k].run == (int64_t)(k / 3), "random: slot %zu moved", k);
}

/* The order of arrival survives the bound on the heights: arrivals at 0, 1 and 2 us at 700, 550 and 750 m/s start
 * 0, 550 and 1500 um up before the bound; bounded each at max_gap (10 um), the third (750 m/s) met the substrate at
 * 13.3 ns, before the second (550 m/s) at 18.2 ns.  With the run's one compression they arrive in the spray's order,
 * at times proportional to the spray's intervals (1 : 2), the last starting at max_gap. */
static void test_place_keeps_arrival_order(void)
{
    struct couple_config cfg = config(COUPLE_WINDOW, 1, 3);
    struct couple_seed seeds[3] = {seed_at(0.0, 0.0, 0.0, 700.0, 10e-6), seed_at(1e-6, 20e-6, 0.0, 550.0, 10e-6),
                                   seed_at(2e-6, -20e-6, 0.0, 750.0, 10e-6)};
    couple_place_run(&cfg, seeds, 3);
    double arrival[3];
    for (int k = 0; k < 3; k++)
        arrival[k] = (seeds[k].center[2] - 0.5 * seeds[k].d) / -seeds[k].velocity[2];
    printf("  arrivals in the run at %.4g, %.4g, %.4g ns\n", 1e9 * arrival[0], 1e9 * arrival[1], 1e9 * arrival[2]);
    CHECK(arrival[0] == 0.0 && arrival[0] < arrival[1] && arrival[1] < arrival[2], "arrivals %g, %g, %g s", arrival[0],
          arrival[1], arrival[2]);
    CHECK_CLOSE(arrival[2] / arrival[1], 2.0, 1e-12, 0.0, "the intervals' ratio kept");
    CHECK_CLOSE(seeds[2].center[2] - 0.5 * seeds[2].d, cfg.max_gap, 1e-12, 0.0, "the highest start at max_gap");
}

/* Random placement: offsets relative to the first arrival folded into the patch; overlapping bodies lifted. */
static void test_place_fold_and_clear(void)
{
    struct couple_config cfg = config(COUPLE_RANDOM, 1, 2);
    struct couple_seed seeds[2] = {seed_at(0.0, 5e-3, 5e-3, 700.0, 20e-6),
                                   seed_at(1e-12, 5e-3 + 2e-6 + 40e-6, 5e-3, 700.0, 20e-6)};
    couple_place_run(&cfg, seeds, 2);
    CHECK(seeds[0].center[0] == 0.0 && seeds[0].center[1] == 0.0, "the first arrival at the patch centre");
    CHECK_CLOSE(seeds[1].center[0], 2e-6, 1e-9, 1e-15, "offset folded into the 40 um patch");
    double dx = seeds[1].center[0] - seeds[0].center[0], dz = seeds[1].center[2] - seeds[0].center[2];
    CHECK(sqrt(dx * dx + dz * dz) >= 20e-6 * (1.0 - 1e-12), "no overlap after lifting (distance %g m)",
          sqrt(dx * dx + dz * dz));
    CHECK(dz > 0.0, "the later body is lifted above the earlier one");
}

int main(void)
{
    make_candidates();
    RUN(test_random_is_a_permutation);
    RUN(test_random_is_reproducible);
    RUN(test_stratified_covers_every_quantile);
    RUN(test_stratified_never_empty);
    RUN(test_window_in_arrival_order);
    RUN(test_too_few_candidates);
    RUN(test_runs_mix_speed_quantiles);
    RUN(test_place_window);
    RUN(test_place_keeps_arrival_order);
    RUN(test_place_fold_and_clear);
    return check_finish();
}
