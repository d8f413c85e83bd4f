/* Contacts that never pass through (issue 21, item 5; docs/physics.md, "Contact detection"): at the end of
 * every step no two particles overlap and no particle lies inside the target, beyond round-off, and no
 * end-of-step correction (clamp) was needed to make it so.  Each case is one that the contact search missed
 * before: a head-on pair bent together by drag, a chain of touching spheres, a particle deflected past a
 * resting one, a dense stream onto its deposit. */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "spray_fixture.h"

/* An overlap beyond round-off: closer than the contact distance by more than this fraction of it. */
#define OVERLAP_TOLERANCE 1e-9

struct overlap_count {
    int64_t pairs, target; /* particle-steps found overlapping */
    double worst;          /* deepest overlap, m */
    int64_t worst_step;
    int64_t worst_a, worst_b; /* ids (b = -1: the target) */
};

struct by_x {
    double lo;
    size_t index;
};

static int by_x_order(const void *pa, const void *pb)
{
    const struct by_x *a = pa, *b = pb;
    return a->lo < b->lo ? -1 : a->lo > b->lo;
}

static void note_overlap(struct overlap_count *count, double depth, int64_t step, int64_t a, int64_t b)
{
    if (depth > count->worst) {
        count->worst = depth;
        count->worst_step = step;
        count->worst_a = a;
        count->worst_b = b;
    }
}

/* Every pair closer than its contact distance and every particle beyond the target plane, by brute force
 * along x (sorted by the lower x of each sphere: a pair can overlap only if their x-extents do). */
static void count_overlaps(const struct dem_solver *s, double standoff, int64_t step, struct overlap_count *count)
{
    size_t n = dem_particle_count(s);
    struct dem_particle_view *views = malloc((n ? n : 1) * sizeof *views);
    struct by_x *order = malloc((n ? n : 1) * sizeof *order);
    for (size_t i = 0; i < n; i++) {
        views[i] = dem_particle(s, i);
        order[i] = (struct by_x){views[i].x[0] - 0.5 * views[i].d, i};
        double depth = views[i].x[2] + 0.5 * views[i].d - standoff;
        if (depth > OVERLAP_TOLERANCE * views[i].d) {
            count->target++;
            note_overlap(count, depth, step, views[i].id, -1);
        }
    }
    qsort(order, n, sizeof *order, by_x_order);
    for (size_t k = 0; k < n; k++) {
        const struct dem_particle_view *a = &views[order[k].index];
        for (size_t m = k + 1; m < n && order[m].lo <= a->x[0] + 0.5 * a->d; m++) {
            const struct dem_particle_view *b = &views[order[m].index];
            double reach = 0.5 * (a->d + b->d), dx = b->x[0] - a->x[0], dy = b->x[1] - a->x[1], dz = b->x[2] - a->x[2];
            double depth = reach - sqrt(dx * dx + dy * dy + dz * dz);
            if (depth > OVERLAP_TOLERANCE * reach) {
                count->pairs++;
                note_overlap(count, depth, step, a->id, b->id);
            }
        }
    }
    free(order);
    free(views);
}

/* Run `steps` steps, checking every step end; reports and returns the overlaps. */
static struct overlap_count run_checked(struct fixture *f, int64_t steps, const char *what)
{
    struct overlap_count count = {0};
    for (int64_t step = 1; step <= steps; step++) {
        if (fixture_steps(f, 1) != SC_OK) {
            CHECK(0, "%s: step %lld failed", what, (long long)step);
            break;
        }
        count_overlaps(f->solver, f->cfg.standoff, step, &count);
    }
    struct dem_counts counts = dem_get_counts(f->solver);
    CHECK(count.pairs == 0 && count.target == 0,
          "%s: %lld pair and %lld target overlaps at step ends; deepest %.3g m at step %lld (ids %lld, %lld)", what,
          (long long)count.pairs, (long long)count.target, count.worst, (long long)count.worst_step,
          (long long)count.worst_a, (long long)count.worst_b);
    CHECK(counts.clamps == 0, "%s: %lld end-of-step corrections (clamps)", what, (long long)counts.clamps);
    return count;
}

/* A head-on pair at 500 m/s each at the paper's dt (2 us, Table 1), in a uniform stream of 1500 m/s along
 * +z: the small leading particle (20 um, slip 1000 m/s) is pushed towards the large one (500 um, slip
 * 2000 m/s) harder than that one is pushed away, about 3e6 m/s^2 more: over a step the pair closes ~6 um
 * more than the straight sweep says.  Started so that the straight sweep first touches 0.5-8 um after the
 * end of step 1. */
static void test_head_on_pair_bent_by_drag(void)
{
    const double dt = 2e-6, d_small = 20e-6, d_large = 500e-6, speed = 500.0, z_small = 0.1;
    const double margins[] = {0.5e-6, 1e-6, 2e-6, 3e-6, 4e-6, 6e-6, 8e-6};
    int64_t contacts = 0;
    for (size_t k = 0; k < sizeof margins / sizeof *margins; k++) {
        double gap = 2.0 * speed * dt + margins[k], z_large = z_small + 0.5 * (d_small + d_large) + gap;
        char rows[256], what[64];
        snprintf(rows, sizeof rows, "0,0,%.17g,0,0,%.17g,0,0,0,%.17g\n0,0,%.17g,0,0,%.17g,0,0,0,%.17g\n", z_small,
                 speed, d_small, z_large, -speed, d_large);
        snprintf(what, sizeof what, "sweep misses by %.1f um", margins[k] * 1e6);
        struct fixture f;
        if (fixture_open(&f,
                         "[spray]\ndt = 2e-6\nt_end = 1e-3\n[jet]\nmodel = uniform\nuniform_velocity = 1500\n"
                         "[deposition]\nrule = none\n[contact]\nrestitution = 0.5\n",
                         rows) != SC_OK) {
            CHECK(0, "fixture");
            return;
        }
        run_checked(&f, 4, what);
        contacts += dem_get_counts(f.solver).contacts_pair;
        fixture_close(&f);
    }
    CHECK(contacts == (int64_t)(sizeof margins / sizeof *margins), "one pair contact per run (%lld in all)",
          (long long)contacts);
}

/* The same pair in vacuum: the straight sweep is exact; they meet once, in step 1, and part. */
static void test_head_on_pair_in_vacuum(void)
{
    struct fixture f;
    if (fixture_open(&f,
                     "[spray]\ndt = 2e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\nrule = none\n"
                     "[contact]\nrestitution = 0.5\n",
                     "0,0,0.1,0,0,500,0,0,0,20e-6\n0,0,0.101,0,0,-500,0,0,0,500e-6\n") != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    run_checked(&f, 4, "vacuum");
    CHECK(dem_get_counts(f.solver).contacts_pair == 1, "one contact (%lld)",
          (long long)dem_get_counts(f.solver).contacts_pair);
    fixture_close(&f);
}

/* A striker hits a chain of 9 touching 100 um spheres at 100 m/s, dt = 2 us (the striker's path in a step:
 * 2 diameters).  The momentum runs down the chain within the first step, one contact after another; every
 * contact of the step must be resolved (before, at most 1 + 4 rounds were: sphere 5 passed through sphere 6
 * and stayed overlapped with sphere 7).  Momentum is conserved whatever the restitution. */
static void run_chain(const char *restitution)
{
    const double d = 100e-6, z0 = 0.1, v = 100.0;
    char rows[2048], ini[256], what[64];
    size_t used = (size_t)snprintf(rows, sizeof rows, "0,0,%.17g,0,0,%.17g,0,0,0,%.17g\n", z0 - d - 10e-6, v, d);
    for (int k = 0; k < 9; k++)
        used += (size_t)snprintf(rows + used, sizeof rows - used, "0,0,%.17g,0,0,0,0,0,0,%.17g\n", z0 + k * d, d);
    snprintf(ini, sizeof ini,
             "[spray]\ndt = 2e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\nrule = none\n"
             "[contact]\nrestitution = %s\n",
             restitution);
    snprintf(what, sizeof what, "chain, restitution %s", restitution);
    struct fixture f;
    if (fixture_open(&f, ini, rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    run_checked(&f, 20, what);
    double momentum = 0.0, mass = 0.0;
    for (size_t i = 0; i < dem_particle_count(f.solver); i++) {
        struct dem_particle_view p = dem_particle(f.solver, i);
        momentum += p.m * p.v[2];
        mass = p.m;
    }
    CHECK_CLOSE(momentum, mass * v, 1e-12, 0, "momentum along the chain");
    CHECK(dem_get_counts(f.solver).contacts_pair >= 9, "%s: %lld pair contacts", what,
          (long long)dem_get_counts(f.solver).contacts_pair);
    fixture_close(&f);
}

static void test_chain_of_nine(void)
{
    run_chain("johnson");
    run_chain("1");
    run_chain("0.5");
}

/* A 50 um particle hits the target half-way through a step (dt = 2 us) at (50, 0, 100) m/s and rebounds
 * (e = 1, no friction) at (50, 0, -100) m/s; a particle at rest lies at (50, 0, -300) um from the hit point.
 * On its path from the hit point the rebounder passes it at 89 um (contact distance 50 um): no contact.
 * Restarted from its start-of-step position with the new velocity (as before), the rebounder ended the step
 * on the resting particle's centre, and no contact had been found. */
static void test_deflected_past_resting(void)
{
    const double d = 50e-6, standoff = 0.3, z_hit = standoff - 0.5 * d, half = 1e-6;
    char rows[256];
    snprintf(rows, sizeof rows, "%.17g,0,%.17g,50,0,100,0,0,0,%.17g\n%.17g,0,%.17g,0,0,0,0,0,0,%.17g\n", -50.0 * half,
             z_hit - 100.0 * half, d, 50e-6, z_hit - 300e-6, d);
    struct fixture f;
    if (fixture_open(&f,
                     "[spray]\ndt = 2e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\nrule = none\n"
                     "[contact]\nrestitution = 1\n[powder]\nfriction = 0\n[target]\nfriction = 0\n",
                     rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    run_checked(&f, 5, "deflection");
    struct dem_counts counts = dem_get_counts(f.solver);
    CHECK(counts.contacts_target == 1 && counts.contacts_pair == 0, "one target contact (%lld), no pair contact (%lld)",
          (long long)counts.contacts_target, (long long)counts.contacts_pair);
    struct dem_particle_view rebounder = dem_particle(f.solver, 0);
    /* after the hit: 1 us then 4 steps at (50, 0, -100) m/s */
    CHECK_CLOSE(rebounder.x[0], 50.0 * (half + 8.0 * half), 1e-9, 0, "rebounder's x on the path from the hit");
    CHECK_CLOSE(rebounder.x[2], z_hit - 100.0 * 9.0 * half, 1e-12, 0, "rebounder's z on the path from the hit");
    fixture_close(&f);
}

/* Where the particles of a deposit rest: each touches the target, or another particle at rest, or stays where it met
 * its obstacle because touching it there would overlap a particle at rest (docs/physics.md "Contact detection").
 * They met their obstacles within their drag skins, up to a third of a diameter away here, and were left there
 * hovering (the demo's particles on the target 6.7 um above it on average). */
static void check_deposit_rests(const struct dem_solver *s, double standoff, const char *what)
{
    size_t n = dem_particle_count(s), on_target = 0, on_particle = 0, blocked = 0, hovering = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        struct dem_particle_view a = dem_particle(s, i);
        if (a.state != DEM_DEPOSITED)
            continue;
        double gap = standoff - a.x[2] - 0.5 * a.d, plane[3] = {a.x[0], a.x[1], standoff - 0.5 * a.d};
        int touches = 0, blocks = 0;
        for (size_t j = 0; j < n && !touches; j++) {
            struct dem_particle_view b = dem_particle(s, j);
            if (j == i || b.state == DEM_FLYING)
                continue;
            double reach = 0.5 * (a.d + b.d), dx = a.x[0] - b.x[0], dy = a.x[1] - b.x[1], dz = a.x[2] - b.x[2];
            double px = plane[0] - b.x[0], py = plane[1] - b.x[1], pz = plane[2] - b.x[2];
            touches = fabs(sqrt(dx * dx + dy * dy + dz * dz) - reach) <= 1e-9 * reach;
            blocks |= sqrt(px * px + py * py + pz * pz) < reach * (1.0 - 1e-12);
        }
        if (gap <= 1e-9 * a.d)
            on_target++;
        else if (touches)
            on_particle++;
        else if (blocks)
            blocked++;
        else
            hovering++, worst = fmax(worst, gap);
    }
    printf("  %s: deposited on the target %zu, on a particle %zu, held off by a particle in the way %zu, hovering %zu "
           "(highest %.3g um above the target)\n",
           what, on_target, on_particle, blocked, hovering, worst * 1e6);
    CHECK(hovering == 0, "%s: %zu deposited particles touch nothing (up to %.3g um above the target)", what, hovering,
          worst * 1e6);
    CHECK(on_target > 50, "%s: %zu particles rest on the target", what, on_target);
}

/* A dense stream of 10-30 um particles at 600-800 m/s through the demo's jet (drag up to ~1e7 m/s^2)
 * onto the target, where each sticks at its first contact and builds a deposit that the later ones hit
 * (rebounders would stay pushed onto the target by this jet, which blows at full speed up to the wall:
 * issue 21's near-wall gas); in flight they collide and rebound.  20 particles per step from a 0.6 mm disc,
 * 200 steps. */
static void test_dense_stream_onto_deposit(void)
{
    const char *ini = "[run]\nseed = 5\n[spray]\ndt = 1e-6\nt_end = 1e-3\nfeed_count = 20\nfeed_every = 1\n"
                      "max_injected = 4000\nnozzle_radius = 0.0003\nrelease_speed_min = 600\n"
                      "release_speed_max = 800\nrelease_cone = 1\ndomain_radius = 0.02\nhandoff_height = 0.003\n"
                      "[powder]\nmedian_diameter = 20e-6\nshape = 3.5\nd_min = 10e-6\nd_max = 30e-6\n"
                      "density = 2700\nshear_modulus = 26e9\nbulk_modulus = 76e9\nyield_stress = 102e6\n"
                      "[target]\nstandoff = 0.03\nshear_modulus = 26e9\nbulk_modulus = 76e9\nyield_stress = 102e6\n"
                      "[jet]\nC1 = 320\nC3 = 40\nvirtual_origin = 0.05\ncore_length = 0.002\n"
                      "[deposition]\nrule = critical_velocity\ncritical_velocity = 1e-6\n";
    struct fixture f;
    if (fixture_open(&f, ini, NULL) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    run_checked(&f, 200, "dense stream");
    struct dem_counts counts = dem_get_counts(f.solver);
    printf("  dense stream: %lld injected, %lld deposited, contacts: %lld target, %lld deposit, %lld pair\n",
           (long long)counts.injected, (long long)counts.deposited, (long long)counts.contacts_target,
           (long long)counts.contacts_deposit, (long long)counts.contacts_pair);
    CHECK(counts.deposited > 100 && counts.contacts_deposit > 100, "a deposit that the stream hits");
    check_deposit_rests(f.solver, 0.03, "dense stream");
    fixture_close(&f);
}

/* Fast particles (500 m/s and slower, up to 2.5 mm per step, 50 times their diameter) in 12 columns of 5 along
 * the axis, faster behind slower: they overtake each other, and the rebounders from the target (e = 0.5) meet
 * those still coming.  None passes the target or another, at no step end is one inside the target or
 * another, and none had to be put back (an end-of-step overlap test in place of the swept target test
 * fails here: every particle would end a step inside the target and be clamped). */
static void test_nothing_tunnels(void)
{
    char rows[64 * 200] = "";
    size_t used = 0;
    for (int i = 0; i < 60; i++)
        used += (size_t)snprintf(rows + used, sizeof rows - used, "%.6g,%.6g,%.6g,0,0,%g,0,0,0,5e-5\n", 1e-4 * (i % 4),
                                 1e-4 * (i / 4 % 3), 0.2 + 1e-3 * (i / 12), 500.0 - 60.0 * (i / 12));
    struct fixture f;
    if (fixture_open(&f,
                     "[spray]\ndt = 5e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\nrule = none\n"
                     "[contact]\nrestitution = 0.5\n",
                     rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    run_checked(&f, 150, "columns");
    struct dem_counts counts = dem_get_counts(f.solver);
    CHECK(counts.contacts_target >= 60, "every particle hit the target (%lld target contacts)",
          (long long)counts.contacts_target);
    CHECK(counts.contacts_pair >= 12, "the columns' particles met (%lld pair contacts)",
          (long long)counts.contacts_pair);
    fixture_close(&f);
}

int main(void)
{
    RUN(test_nothing_tunnels);
    RUN(test_head_on_pair_bent_by_drag);
    RUN(test_head_on_pair_in_vacuum);
    RUN(test_chain_of_nine);
    RUN(test_deflected_past_resting);
    RUN(test_dense_stream_onto_deposit);
    return check_finish();
}
