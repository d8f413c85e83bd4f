/* The broad phase's repairs (dem/broadphase.c): a grid and pair list kept across steps in which particles
 * change velocity, deposit, are removed and are injected must give exactly the contacts of a grid built
 * afresh in every step, with no pair listed twice, and the grid queries of the secondary contact passes
 * must see every particle whose swept box meets the query box. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
/* A white-box test: includes the module-private header dem/dem_impl.h (only tests may; tests/test_symbols.sh). */
#include "dem/dem_impl.h"

#define CUBE    1.5e-3 /* m: particles bounce inside [0, CUBE]^3 */
#define DT      4e-6   /* s: a sweep of about half a diameter at 5 m/s */
#define DENSITY 4000.0

/* splitmix64: a small deterministic generator for the configurations */
static uint64_t rng_state = 0x243F6A8885A308D3ull;

static double uniform(void)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

static int64_t next_id;
static double deposit_share = 0.3; /* of the particles added */

static void add_random_particle(struct dem_particles *p)
{
    double x[3], v[3], w[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < 3; c++) {
        x[c] = CUBE * uniform();
        v[c] = 10.0 * (uniform() - 0.5);
    }
    size_t i = dem_particles_append(p, next_id++, x, v, w, 2e-5 + 4e-5 * uniform(), DENSITY);
    if (uniform() < deposit_share) {
        p->state[i] = DEM_DEPOSITED;
        memset(p->v + 3 * i, 0, 3 * sizeof(double));
    }
}

static int candidate_order(const void *pa, const void *pb)
{
    const struct dem_candidate *a = pa, *b = pb;
    if (a->s != b->s)
        return a->s < b->s ? -1 : 1;
    if (a->a != b->a)
        return a->a < b->a ? -1 : 1;
    return a->b < b->b ? -1 : (a->b > b->b);
}

static int pair_order(const void *pa, const void *pb)
{
    const uint32_t *a = pa, *b = pb;
    if (a[0] != b[0])
        return a[0] < b[0] ? -1 : 1;
    return a[1] < b[1] ? -1 : (a[1] > b[1]);
}

/* The contacts of the kept grid and of a fresh one, sorted, must be the same, bit for bit. */
static int same_contacts_as_fresh(const struct dem_bins *kept, const struct dem_particles *p, int64_t step)
{
    struct dem_candidates from_kept = {0}, from_fresh = {0};
    struct dem_bins fresh = {0};
    dem_broadphase_build(&fresh, p, DT);
    dem_broadphase_pairs(kept, p, DT, &from_kept);
    dem_broadphase_pairs(&fresh, p, DT, &from_fresh);
    qsort(from_kept.items, from_kept.count, sizeof *from_kept.items, candidate_order);
    qsort(from_fresh.items, from_fresh.count, sizeof *from_fresh.items, candidate_order);
    int same = from_kept.count == from_fresh.count;
    for (size_t k = 0; same && k < from_kept.count; k++) {
        const struct dem_candidate *a = &from_kept.items[k], *b = &from_fresh.items[k];
        same = memcmp(&a->s, &b->s, sizeof a->s) == 0 && a->a == b->a && a->b == b->b && a->kind == b->kind;
    }
    CHECK(same, "step %lld: %zu contacts from the repaired grid, %zu from a fresh one", (long long)step,
          from_kept.count, from_fresh.count);
    int found = (int)from_fresh.count;
    free(from_kept.items);
    free(from_fresh.items);
    dem_bins_free(&fresh);
    return found;
}

/* Every listed pair once, lower index first, indices in range. */
static void check_pair_list(const struct dem_bins *kept, const struct dem_particles *p, int64_t step)
{
    uint32_t *pairs = malloc((kept->pair_count ? kept->pair_count : 1) * 2 * sizeof *pairs);
    memcpy(pairs, kept->pairs, kept->pair_count * 2 * sizeof *pairs);
    qsort(pairs, kept->pair_count, 2 * sizeof *pairs, pair_order);
    size_t bad = 0, duplicates = 0;
    for (size_t k = 0; k < kept->pair_count; k++) {
        bad += pairs[2 * k] >= pairs[2 * k + 1] || pairs[2 * k + 1] >= p->count;
        duplicates += k > 0 && pair_order(pairs + 2 * k, pairs + 2 * k - 2) == 0;
    }
    CHECK(bad == 0 && duplicates == 0, "step %lld: %zu pairs out of order or range, %zu listed twice", (long long)step,
          bad, duplicates);
    free(pairs);
}

static void swept(const struct dem_particles *p, size_t i, double lo[3], double hi[3])
{
    double r = 0.5 * p->d[i];
    for (int c = 0; c < 3; c++) {
        double a = p->x[3 * i + c], b = a + (p->state[i] == DEM_FLYING ? p->v[3 * i + c] * DT : 0.0);
        lo[c] = (a < b ? a : b) - r;
        hi[c] = (a < b ? b : a) + r;
    }
}

static void mark_visited(uint32_t index, void *context)
{
    ((uint8_t *)context)[index] = 1;
}

/* The query of a flying particle's swept box visits every particle whose swept box meets it. */
static void check_visits(const struct dem_bins *kept, const struct dem_particles *p, int64_t step)
{
    uint8_t *visited = malloc(p->count);
    size_t missed = 0;
    for (int q = 0; q < 20; q++) {
        size_t i = (size_t)(uniform() * (double)p->count);
        double lo[3], hi[3];
        swept(p, i, lo, hi);
        memset(visited, 0, p->count);
        if (dem_broadphase_visit_box(kept, lo, hi, 4096, mark_visited, visited) != 0)
            continue;
        for (size_t j = 0; j < p->count; j++) {
            double jlo[3], jhi[3];
            swept(p, j, jlo, jhi);
            int meets = 1;
            for (int c = 0; c < 3; c++)
                meets &= jlo[c] <= hi[c] && lo[c] <= jhi[c];
            missed += meets && !visited[j];
        }
    }
    CHECK(missed == 0, "step %lld: %zu particles missed by grid queries", (long long)step, missed);
    free(visited);
}

/* What the integration does at the end of a step (dem/integrate.c, block_verify_reach): mark the particles,
 * flying at the build and now, whose swept box of the next step lies in their reach box.  The broad phase
 * uses the marks only for runs of particles marked alike, all of them; returns how many particles were
 * marked in such runs (of 64, as broadphase.c's RUN_DEPOSITS). */
static size_t verify_reach_like_the_integration(const struct dem_particles *p, struct dem_bins *kept)
{
    if (!kept->reach_verified || kept->built_count > p->count)
        return 0;
    size_t in_full_runs = 0, run_marked = 0;
    for (size_t i = 0; i < kept->built_count; i++) {
        double radius = 0.5 * p->d[i] * (1.0 + DEM_BOX_MARGIN);
        int holds = kept->built_flying[i] & (p->state[i] == DEM_FLYING);
        for (int c = 0; c < 3; c++)
            holds &= dem_sweep_inside(p->x[3 * i + c], p->v[3 * i + c], DT, radius, kept->reach_lo[3 * i + c],
                                      kept->reach_hi[3 * i + c]);
        kept->reach_verified[i] = (uint8_t)holds;
        run_marked = i % 64 == 0 ? (size_t)holds : run_marked + (size_t)holds;
        in_full_runs += i % 64 == 63 && run_marked == 64 ? 64 : 0;
    }
    return in_full_runs;
}

/* One step of straight flight with bounces off the cube's walls, then random rebounds, deposits, removals
 * and injections. */
static void advance(struct dem_particles *p, struct dem_bins *kept)
{
    for (size_t i = 0; i < p->count; i++) {
        if (p->state[i] != DEM_FLYING)
            continue;
        for (int c = 0; c < 3; c++) {
            double *x = p->x + 3 * i + c, *v = p->v + 3 * i + c;
            *x += *v * DT;
            if ((*x < 0.0 && *v < 0.0) || (*x > CUBE && *v > 0.0))
                *v = -0.8 * *v;
        }
        double u = uniform();
        if (u < 0.003)
            p->v[3 * i + (size_t)(3 * uniform())] *= -0.5;
        else if (u < 0.004)
            p->state[i] = DEM_DEPOSITED, memset(p->v + 3 * i, 0, 3 * sizeof(double));
    }
    uint32_t *removed = malloc((p->count ? p->count : 1) * sizeof *removed);
    size_t removed_count = 0;
    for (size_t i = 0; i < p->count; i++)
        if (uniform() < 0.002)
            removed[removed_count++] = (uint32_t)i;
    if (removed_count) {
        size_t old_count = p->count;
        dem_particles_compact(p, removed, removed_count);
        dem_broadphase_compact(kept, removed, removed_count, old_count);
    }
    free(removed);
    if (uniform() < 0.2)
        for (int k = 0; k < 5; k++)
            add_random_particle(p);
}

/* 300 steps of a kept grid against fresh ones; `verify`: the integration's marks are set between steps (all
 * particles flying, so that whole runs of them are marked). */
static void run_kept_grid(int verify)
{
    struct dem_particles p = {0};
    struct dem_bins kept = {0};
    deposit_share = verify ? 0.0 : 0.3;
    for (int k = 0; k < 2000; k++)
        add_random_particle(&p);
    int64_t contacts = 0;
    size_t marked = 0;
    for (int64_t step = 0; step < 300 && check_test_failures == 0; step++) {
        dem_broadphase_build(&kept, &p, DT);
        contacts += same_contacts_as_fresh(&kept, &p, step);
        check_pair_list(&kept, &p, step);
        check_visits(&kept, &p, step);
        advance(&p, &kept);
        if (verify)
            marked += verify_reach_like_the_integration(&p, &kept);
    }
    printf("  %lld contacts, %lld builds, %lld repairs in 300 steps, %zu particle-steps marked in full runs\n",
           (long long)contacts, (long long)kept.builds, (long long)kept.repairs, marked);
    CHECK(contacts > 1000, "too few contacts to test anything: %lld", (long long)contacts);
    CHECK(kept.repairs > 50 && kept.builds > 1, "repairs %lld and builds %lld: both should occur",
          (long long)kept.repairs, (long long)kept.builds);
    CHECK(!verify || marked > 10000, "only %zu particle-steps marked in full runs: the marks are hardly used", marked);
    dem_bins_free(&kept);
    dem_particles_free(&p);
}

static void test_repairs_match_fresh_builds(void)
{
    run_kept_grid(0);
}

/* The integration's marks (struct dem_bins: reach_verified) stand in for the box test: the same contacts. */
static void test_verified_reach_matches_fresh_builds(void)
{
    run_kept_grid(1);
}

int main(void)
{
    RUN(test_repairs_match_fresh_builds);
    RUN(test_verified_reach_matches_fresh_builds);
    return check_finish();
}
