/* The spray solver as a whole: drag integration against analytical solutions, swept contact detection
 * against brute force, convergence in dt (no tunnelling: tests/test_contact_paths.c), accounting, determinism across
 * threads, checkpoint round trip. */
#include <math.h>
#include <omp.h>

#include "check.h"
#include "tests/verification_csv.h"
#include "core/h5io.h"
/* A white-box test: includes the module-private header dem/dem_impl.h (only tests may; tests/test_symbols.sh). */
#include "dem/dem_impl.h"
#include "spray_fixture.h"

/* stokes_relaxation.csv: a sphere released at rest in a uniform stream with Stokes drag,
 * v = U (1 - exp(-t/tau)), tau = rho d^2 / (18 mu) = 8.333e-4 s.  The trapezoidal scheme at dt = tau/1000
 * is second order: relative error ~ (dt/tau)^2. */
static void test_stokes_relaxation(void)
{
    char path[512];
    snprintf(path, sizeof path, "%s/stokes_relaxation.csv", check_verification_dir());
    FILE *table = fopen(path, "r");
    CHECK(table != NULL, "cannot open %s", path);
    if (!table)
        return;
    const double tau = 2700.0 * 1e-10 / (18.0 * 1.8e-5), dt = tau / 1000.0;
    char ini[1024];
    snprintf(
        ini, sizeof ini,
        "[spray]\ndt = %.17g\nt_end = 0.01\ndomain_radius = 1\n[target]\nstandoff = 2\n[powder]\ndensity = 2700\n"
        "[jet]\nmodel = uniform\nuniform_velocity = 100\ndrag = stokes\ngas_density = 1.2\ngas_viscosity = 1.5e-5\n"
        "[deposition]\nrule = none\n",
        dt);
    struct fixture f;
    if (fixture_open(&f, ini, "0,0,0.001,0,0,0,0,0,0,1e-5\n") != SC_OK) {
        CHECK(0, "fixture");
        fclose(table);
        return;
    }
    char line[256];
    int rows = 0;
    while (fgets(line, sizeof line, table)) {
        if (line[0] == '#' || line[0] == 't')
            continue;
        struct csv_row row;
        csv_split(line, &row);
        double t = csv_number(&row, 0), v = csv_number(&row, 1), x = csv_number(&row, 2);
        int64_t target_step = llround(t / dt);
        fixture_steps(&f, target_step - dem_get_counts(f.solver).step);
        struct dem_particle_view p = dem_particle(f.solver, 0);
        CHECK_CLOSE(p.v[2], v, 1e-6, 1e-9, "Stokes velocity");
        /* the trapezoidal rule's truncation error in x is about (dt/t)^2/6 of x early on */
        double x_rtol = t > 0 ? fmax(1e-6, 0.2 * (dt / t) * (dt / t)) : 0;
        CHECK_CLOSE(p.x[2] - 0.001, x, x_rtol, 1e-15, "Stokes distance");
        rows++;
    }
    fclose(table);
    CHECK(rows == 5, "rows read: %d", rows);
    fixture_close(&f);
}

/* A 1 um particle has tau = 8.3 us; at dt = 100 us (12 tau) the plain fixed-point iteration diverges.
 * Sub-cycling keeps it stable and accurate: it reaches the gas velocity. */
static void test_stiff_particle_is_stable(void)
{
    const double tau = 2700.0 * 1e-12 / (18.0 * 1.8e-5);
    char ini[1024];
    snprintf(ini, sizeof ini,
             "[spray]\ndt = 1e-4\nt_end = 0.01\ndomain_radius = 1\n[target]\nstandoff = 2\n[powder]\ndensity = 2700\n"
             "[jet]\nmodel = uniform\nuniform_velocity = 100\ndrag = stokes\ngas_density = 1.2\n"
             "gas_viscosity = 1.5e-5\n[deposition]\nrule = none\n");
    struct fixture f;
    if (fixture_open(&f, ini, "0,0,0.001,0,0,0,0,0,0,1e-6\n") != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    fixture_steps(&f, 1);
    struct dem_particle_view p = dem_particle(f.solver, 0);
    CHECK_CLOSE(p.v[2], 100.0 * (1.0 - exp(-1e-4 / tau)), 1e-3, 0, "velocity after one step");
    fixture_steps(&f, 9);
    p = dem_particle(f.solver, 0);
    CHECK_CLOSE(p.v[2], 100.0, 1e-9, 0, "relaxed to the gas velocity");
    /* distance: U (t - tau (1 - exp(-t/tau))) */
    double t = 1e-3;
    CHECK_CLOSE(p.x[2] - 0.001, 100.0 * (t - tau * (1.0 - exp(-t / tau))), 1e-3, 0, "distance");
    struct dem_counts c = dem_get_counts(f.solver);
    CHECK(c.subcycled_particle_steps == 10, "every step sub-cycled (%lld)", (long long)c.subcycled_particle_steps);
    CHECK(c.fixed_point_unconverged == 0, "all fixed-point solves converged (%lld not)",
          (long long)c.fixed_point_unconverged);
    fixture_close(&f);
}

/* Random particles in a 2 mm box, random velocities up to 60 m/s, written as a particles file. */
static char *random_cloud(int count, double box, double speed, unsigned seed)
{
    char *rows = malloc((size_t)count * 200);
    size_t used = 0;
    srand(seed);
    for (int i = 0; i < count; i++) {
        double r[7];
        for (int k = 0; k < 7; k++)
            r[k] = (double)rand() / RAND_MAX;
        double d = 50e-6 + 100e-6 * r[6];
        used += (size_t)sprintf(rows + used, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,0,0,0,%.9g\n", box * (r[0] - 0.5),
                                box * (r[1] - 0.5), 0.1 + box * r[2], speed * (2 * r[3] - 1), speed * (2 * r[4] - 1),
                                speed * (2 * r[5] - 1), d);
    }
    return rows;
}

static int candidate_listed(const struct dem_candidates *list, uint32_t a, uint32_t b)
{
    for (size_t k = 0; k < list->count; k++)
        if (list->items[k].kind == CONTACT_PAIR && list->items[k].a == a && list->items[k].b == b)
            return 1;
    return 0;
}

/* Every pair that brute-force O(N^2) sub-stepping (2000 sub-steps) sees touching while approaching
 * within the step is found by the binned swept-sphere test, and every pair it reports really touches. */
static void test_swept_detection_matches_brute_force(void)
{
    const double dt = 2e-6;
    for (unsigned seed = 1; seed <= 3; seed++) {
        char *rows = random_cloud(400, 0.002, 60.0, seed);
        struct fixture f;
        if (fixture_open(&f, "[spray]\ndt = 2e-6\nt_end = 1e-4\n[jet]\nmodel = none\n[deposition]\nrule = none\n",
                         rows) != SC_OK) {
            CHECK(0, "fixture");
            free(rows);
            return;
        }
        free(rows);
        struct dem_solver *s = f.solver;
        dem_inject(s);
        /* drop pairs that overlap in the initial random placement: a solver never starts from them */
        dem_detect_contacts(s);
        const struct dem_particles *p = &s->p;
        int missed = 0, brute_pairs = 0, spurious = 0;
        for (uint32_t i = 0; i < p->count; i++)
            for (uint32_t j = i + 1; j < p->count; j++) {
                double reach = 0.5 * (p->d[i] + p->d[j]), dx[3], dv[3];
                for (int c = 0; c < 3; c++) {
                    dx[c] = p->x[3 * j + c] - p->x[3 * i + c];
                    dv[c] = p->v[3 * j + c] - p->v[3 * i + c];
                }
                int touching = 0;
                for (int k = 0; k <= 2000 && !touching; k++) {
                    double t = dt * k / 2000.0, r2 = 0.0, approach = 0.0;
                    for (int c = 0; c < 3; c++) {
                        double sep = dx[c] + dv[c] * t;
                        r2 += sep * sep;
                        approach += sep * dv[c];
                    }
                    touching = r2 <= reach * reach && approach < 0.0;
                }
                brute_pairs += touching;
                int listed = candidate_listed(&s->candidates, i, j);
                if (touching && !listed)
                    missed++;
                if (listed) {
                    /* closest approach within [0, dt] must reach contact distance */
                    double a = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
                    double b = dx[0] * dv[0] + dx[1] * dv[1] + dx[2] * dv[2];
                    double t = fmin(dt, fmax(0.0, -b / a)), r2 = 0.0;
                    for (int c = 0; c < 3; c++)
                        r2 += (dx[c] + dv[c] * t) * (dx[c] + dv[c] * t);
                    spurious += r2 > reach * reach * (1 + 1e-12);
                }
            }
        CHECK(brute_pairs > 20, "seed %u: enough contacts to test (%d)", seed, brute_pairs);
        CHECK(missed == 0, "seed %u: %d of %d brute-force contacts missed", seed, missed, brute_pairs);
        CHECK(spurious == 0, "seed %u: %d reported contacts that never touch", seed, spurious);
        fixture_close(&f);
    }
}

/* Stream injection into a crowded disc: a batch of 3000 particles of 20-60 um in a 1.5 mm disc (a third of the disc
 * covered), placed by random sequential addition against a grid of cells (dem/inject.c): no two of them may overlap,
 * whatever cells they fall in, and nearly all find a place.  A grid that missed a neighbouring cell placed
 * overlapping particles here. */
static void test_injection_places_without_overlap(void)
{
    struct fixture f;
    if (fixture_open(&f,
                     "[spray]\ndt = 1e-9\nt_end = 1e-6\ninjection = stream\nfeed_count = 3000\nfeed_every = 1000\n"
                     "max_injected = 3000\nnozzle_radius = 0.0015\n[powder]\ndistribution = weibull\n"
                     "median_diameter = 30e-6\nshape = 3.5\nd_min = 20e-6\nd_max = 60e-6\n[jet]\nmodel = none\n"
                     "[deposition]\nrule = none\n",
                     NULL) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    struct dem_solver *s = f.solver;
    dem_inject(s);
    const struct dem_particles *p = &s->p;
    int overlapping = 0;
    for (size_t i = 0; i < p->count; i++)
        for (size_t j = i + 1; j < p->count; j++) {
            double dx = p->x[3 * j] - p->x[3 * i], dy = p->x[3 * j + 1] - p->x[3 * i + 1];
            double contact = 0.5 * (p->d[i] + p->d[j]);
            overlapping += dx * dx + dy * dy < contact * contact;
        }
    printf("  %zu of 3000 placed\n", p->count);
    CHECK(p->count > 2900, "%zu of 3000 placed", p->count);
    CHECK(overlapping == 0, "%d overlapping pairs", overlapping);
    fixture_close(&f);
}

/* Number of particle-particle collisions in a dense cloud over 200 us, as a function of dt. */
static int64_t collisions_in_cloud(double dt)
{
    char *rows = random_cloud(1500, 0.003, 30.0, 42);
    char ini[512];
    snprintf(ini, sizeof ini,
             "[spray]\ndt = %.17g\nt_end = 2e-4\n[jet]\nmodel = none\n[deposition]\nrule = none\n"
             "[contact]\nrestitution = 0.9\n",
             dt);
    struct fixture f;
    int64_t count = -1;
    if (fixture_open(&f, ini, rows) == SC_OK) {
        fixture_steps(&f, dem_total_steps(f.solver));
        count = dem_get_counts(f.solver).contacts_pair;
        fixture_close(&f);
    }
    free(rows);
    return count;
}

/* Swept detection converges as dt shrinks from 5 us to 0.1 us: the collision count at the paper's
 * step sizes is within a few per cent of the fine-step count (end-of-step overlap tests lose most of them). */
static void test_collision_count_converges(void)
{
    const double steps[] = {5e-6, 2e-6, 1e-6, 5e-7, 2e-7, 1e-7};
    int64_t counts[6];
    for (int k = 0; k < 6; k++)
        counts[k] = collisions_in_cloud(steps[k]);
    double reference = (double)counts[5];
    printf("  collisions vs dt:");
    for (int k = 0; k < 6; k++)
        printf(" %g s: %lld;", steps[k], (long long)counts[k]);
    printf("\n");
    CHECK(reference > 200, "enough collisions (%g)", reference);
    for (int k = 0; k < 5; k++) {
        double error = fabs((double)counts[k] - reference) / reference;
        CHECK(error < 0.05, "dt = %g: %lld collisions, %.1f %% from the dt = 0.1 us count", steps[k],
              (long long)counts[k], 100 * error);
    }
    double coarse_error = fabs((double)counts[0] - reference), fine_error = fabs((double)counts[4] - reference);
    CHECK(fine_error <= coarse_error, "error does not shrink: %g at 5 us, %g at 0.2 us", coarse_error, fine_error);
}

static int run_demo_like(int threads, struct fixture *f, int64_t steps)
{
    omp_set_num_threads(threads);
    const char *ini = "[run]\nseed = 11\n[spray]\ndt = 1e-6\nt_end = 2e-3\nfeed_count = 40\nfeed_every = 5\n"
                      "max_injected = 3000\nnozzle_radius = 0.003\nrelease_speed_min = 5\nrelease_speed_max = 60\n"
                      "release_cone = 5\ndomain_radius = 0.02\nhandoff_height = 0.005\nmetrics_every = 50\n"
                      "[powder]\nmedian_diameter = 40e-6\nshape = 3.5\nd_min = 10e-6\nd_max = 100e-6\n"
                      "[target]\nstandoff = 0.03\n[jet]\nvirtual_origin = 0.05\ncore_length = 0.005\n"
                      "[deposition]\nalpha_adh = 10000\n";
    if (fixture_open(f, ini, NULL) != SC_OK)
        return -1;
    return fixture_steps(f, steps);
}

static int same_state(struct dem_solver *a, struct dem_solver *b)
{
    if (dem_particle_count(a) != dem_particle_count(b))
        return 0;
    for (size_t i = 0; i < dem_particle_count(a); i++) {
        struct dem_particle_view pa = dem_particle(a, i), pb = dem_particle(b, i);
        if (memcmp(&pa, &pb, sizeof pa) != 0)
            return 0;
    }
    size_t na, nb;
    const struct dem_impact *ia = dem_impacts(a, &na), *ib = dem_impacts(b, &nb);
    return na == nb && (na == 0 || memcmp(ia, ib, na * sizeof *ia) == 0);
}

/* 1, 2 and 4 threads give the same state bit for bit (4: the broad phase's parallel sort, which only larger
 * teams use); the particle accounting holds throughout. */
static void test_threads_bit_identical(void)
{
    struct fixture one, two, four;
    int status1 = run_demo_like(1, &one, 2000), status2 = run_demo_like(2, &two, 2000);
    int status4 = run_demo_like(4, &four, 2000);
    CHECK(status1 == SC_OK && status4 == SC_OK && same_state(one.solver, four.solver), "1 and 4 threads differ");
    fixture_close(&four);
    CHECK(status1 == SC_OK && status2 == SC_OK, "runs");
    if (status1 == SC_OK && status2 == SC_OK) {
        struct dem_counts c = dem_get_counts(one.solver);
        CHECK(c.injected == 3000, "all injected (%lld)", (long long)c.injected);
        CHECK(c.contacts_pair > 0 && c.contacts_target > 0, "collisions happened (%lld pair, %lld target)",
              (long long)c.contacts_pair, (long long)c.contacts_target);
        CHECK(c.deposited > 0 && c.deposited < c.injected, "some deposit (%lld)", (long long)c.deposited);
        CHECK(c.injected == c.in_flight + c.deposited + c.escaped, "accounting");
        CHECK(dem_check_accounting(one.solver) == SC_OK, "accounting against the arrays");
        CHECK(same_state(one.solver, two.solver), "1 and 2 threads differ");
        /* deposits never interpenetrate: every contact's position comes from the paths current when it
         * is resolved (a particle that bounced cannot stick where its old path would have gone) */
        int overlapping = 0;
        size_t n = dem_particle_count(one.solver);
        for (size_t i = 0; i < n; i++) {
            struct dem_particle_view a = dem_particle(one.solver, i);
            for (size_t j = i + 1; a.state == DEM_DEPOSITED && j < n; j++) {
                struct dem_particle_view b = dem_particle(one.solver, j);
                if (b.state != DEM_DEPOSITED)
                    continue;
                double dx = a.x[0] - b.x[0], dy = a.x[1] - b.x[1], dz = a.x[2] - b.x[2];
                double reach = 0.5 * (a.d + b.d) * (1.0 - 1e-9);
                if (dx * dx + dy * dy + dz * dz < reach * reach) {
                    overlapping++;
                    printf("  overlap: particles %lld and %lld, %.3g of the contact distance\n", (long long)a.id,
                           (long long)b.id, 1.0 - sqrt(dx * dx + dy * dy + dz * dz) / (0.5 * (a.d + b.d)));
                }
            }
        }
        CHECK(overlapping == 0, "%d pairs of deposited particles overlap", overlapping);
    }
    fixture_close(&one);
    fixture_close(&two);
    omp_set_num_threads(2);
}

/* Checkpoint at step 700, restore into a new solver, continue: identical to the uninterrupted run. */
/* The drag a step ends with starts the next one (dem/integrate.c) unless a contact, deposition or the target
 * plane changed the particle: computing every start force again must give the same state bit for bit, in a
 * run with injection, pair and target contacts, deposits and escapes. */
static void test_kept_drag_changes_nothing(void)
{
    struct fixture kept, computed;
    int status1 = run_demo_like(2, &kept, 1500);
    omp_set_num_threads(2);
    int status2 = run_demo_like(2, &computed, 0);
    if (status2 == SC_OK) {
        dem_reuse_drag(computed.solver, 0);
        status2 = fixture_steps(&computed, 1500);
    }
    CHECK(status1 == SC_OK && status2 == SC_OK, "runs");
    if (status1 == SC_OK && status2 == SC_OK) {
        struct dem_counts c = dem_get_counts(kept.solver);
        CHECK(c.contacts_pair > 0 && c.contacts_target > 0 && c.deposited > 0 && c.escaped > 0,
              "contacts, deposits and escapes happened (%lld pair, %lld target, %lld deposited, %lld escaped)",
              (long long)c.contacts_pair, (long long)c.contacts_target, (long long)c.deposited, (long long)c.escaped);
        CHECK(same_state(kept.solver, computed.solver), "kept and recomputed start forces differ");
    }
    fixture_close(&kept);
    fixture_close(&computed);
}

/* Particles flying through the Bickley jet (free flight, the bench's set-up in small): with the first iterate
 * guessed from the last step-end forces (dem/integrate.c), Eq. 53 holds at its first test in smooth flight, so
 * a step costs two iterates (one drag evaluation), where the explicit guess needs three or four; and the state
 * stays within what Eq. 53 allows of the same scheme converged to 1e-14: each step's iterate lies within about
 * tol times that step's progress of its fixed point, so after n steps within tol times the summed progress,
 * which in this monotone flight is at most n times the largest step (bounded here by the change over the run
 * plus the first step's, times 2). */
static int run_jet_flight(double tol, struct fixture *f)
{
    char ini[512];
    snprintf(ini, sizeof ini,
             "[spray]\ndt = 1e-6\nt_end = 1\nfixed_point_tol = %.17g\ndomain_radius = 0.2\n[target]\n"
             "standoff = 0.3\n[deposition]\nrule = none\n",
             tol);
    const char *rows = "0.003,0.002,0.01,0,0,50,0,0,0,4e-5\n-0.004,0.001,0.03,0,0,20,0,0,0,1e-5\n"
                       "0.001,-0.002,0.05,0.5,0,80,0,0,0,1.6e-4\n0,0,0.02,0,0,60,0,0,0,4e-5\n";
    if (fixture_open(f, ini, rows) != SC_OK)
        return -1;
    return fixture_steps(f, 2000);
}

static void test_guessed_first_iterate(void)
{
    struct fixture guessed, tight;
    int status1 = run_jet_flight(1e-8, &guessed), status2 = run_jet_flight(1e-14, &tight);
    CHECK(status1 == SC_OK && status2 == SC_OK, "runs");
    if (status1 == SC_OK && status2 == SC_OK) {
        struct dem_counts c = dem_get_counts(guessed.solver);
        double per_step = (double)c.fixed_point_iterations / (double)c.fixed_point_solves;
        /* two: the guess and its test, but in the first steps (fewer forces to extrapolate from) and where
         * the jet leaves its core (a kink); the explicit guess needs 3.7 here */
        CHECK(c.fixed_point_unconverged == 0 && per_step < 2.2,
              "iterates per particle-step %.3f (two: the guess and its test), %lld unconverged", per_step,
              (long long)c.fixed_point_unconverged);
        for (size_t i = 0; i < dem_particle_count(guessed.solver); i++) {
            struct dem_particle_view a = dem_particle(guessed.solver, i), b = dem_particle(tight.solver, i);
            double dv = 0.0, dx = 0.0, change_v = 0.0;
            for (int k = 0; k < 3; k++) {
                dv += (a.v[k] - b.v[k]) * (a.v[k] - b.v[k]);
                dx += (a.x[k] - b.x[k]) * (a.x[k] - b.x[k]);
            }
            const double start_v[4][3] = {{0, 0, 50}, {0, 0, 20}, {0.5, 0, 80}, {0, 0, 60}};
            for (int k = 0; k < 3; k++)
                change_v += (b.v[k] - start_v[a.id][k]) * (b.v[k] - start_v[a.id][k]);
            double allowed = 1e-8 * 2.0 * (sqrt(change_v) + 2000 * 1e-6 * 100.0);
            CHECK(sqrt(dv) + sqrt(dx) <= allowed,
                  "particle %lld: |dv| %.3g + |dx| %.3g from the converged scheme, allowed %.3g", (long long)a.id,
                  sqrt(dv), sqrt(dx), allowed);
            printf("  particle %lld: |dv| %.3g m/s, |dx| %.3g m from tol 1e-14 (allowed %.3g)\n", (long long)a.id,
                   sqrt(dv), sqrt(dx), allowed);
        }
    }
    fixture_close(&guessed);
    fixture_close(&tight);
}

static void test_checkpoint_round_trip(void)
{
    struct fixture whole, first, resumed;
    CHECK(run_demo_like(2, &whole, 1500) == SC_OK, "uninterrupted run");
    CHECK(run_demo_like(2, &first, 700) == SC_OK, "first part");
    char path[256];
    snprintf(path, sizeof path, "%s/checkpoint.h5", first.dir);
    struct h5_out out;
    CHECK(h5_create_atomic(path, &out) == SC_OK, "create");
    CHECK(dem_checkpoint_write(first.solver, out.file) == SC_OK, "write");
    CHECK(h5_commit(&out) == SC_OK, "commit");
    CHECK(run_demo_like(2, &resumed, 0) == SC_OK, "fresh solver");
    hid_t file;
    CHECK(h5_open_read(path, &file) == SC_OK, "open");
    CHECK(dem_checkpoint_read(resumed.solver, file) == SC_OK, "read: %s", sc_error_message());
    H5Fclose(file);
    CHECK(dem_get_counts(resumed.solver).step == 700, "resumed at step 700");
    fixture_steps(&resumed, 800);
    CHECK(same_state(whole.solver, resumed.solver), "resumed run differs from the uninterrupted one");
    size_t nh1, nh2;
    const struct dem_handoff *h1 = dem_handoffs(whole.solver, &nh1), *h2 = dem_handoffs(resumed.solver, &nh2);
    CHECK(nh1 == nh2 && nh1 > 0 && memcmp(h1, h2, nh1 * sizeof *h1) == 0, "hand-off records differ");
    fixture_close(&whole);
    fixture_close(&first);
    fixture_close(&resumed);
}

/* Two particles in a uniform jet after 3 healthy steps: the set-up of the blow-up tests. */
static int open_healthy_pair(struct fixture *f)
{
    if (fixture_open(f, "[spray]\ndt = 1e-6\nt_end = 1e-4\n[jet]\nmodel = uniform\nuniform_velocity = 100\n",
                     "0,0,0.01,0,0,10,0,0,0,4e-5\n0,0.001,0.01,0,0,10,0,0,0,4e-5\n") != SC_OK) {
        CHECK(0, "fixture");
        return 0;
    }
    CHECK(fixture_steps(f, 3) == SC_OK, "healthy steps");
    return 1;
}

/* The next step stops with SC_ESIM and a message naming step 3, particle 1 and `what`. */
static void check_blow_up_reported(struct fixture *f, const char *what)
{
    int status = dem_step(f->solver);
    CHECK(status == SC_ESIM, "status %d, expected SC_ESIM", status);
    const char *message = sc_error_message();
    CHECK(strstr(message, "step 3") && strstr(message, "particle 1") && strstr(message, what),
          "message names step, particle and quantity: %s", message);
}

/* A state that is no longer finite stops the run with SC_ESIM and a message naming step, particle and
 * quantity (the stage driver then leaves the last checkpoint in place and writes no output). */
static void test_blow_up_is_reported(void)
{
    struct fixture f;
    if (!open_healthy_pair(&f))
        return;
    f.solver->p.v[3 * 1 + 2] = NAN; /* particle id 1 */
    check_blow_up_reported(&f, "not finite");
    fixture_close(&f);
}

/* Only contacts change a spin, so the step tests the spins of the particles that had a contact in it
 * (start_kept, which a contact sets, dem/collide.c): a spin made NaN there is reported like a position. */
static void test_spin_blow_up_is_reported(void)
{
    struct fixture f;
    if (!open_healthy_pair(&f))
        return;
    f.solver->p.w[3 * 1 + 0] = NAN; /* particle id 1, as a contact of this step would leave it */
    memcpy(f.solver->p.x_start + 3, f.solver->p.x + 3, 3 * sizeof(double));
    memcpy(f.solver->p.v_start + 3, f.solver->p.v + 3, 3 * sizeof(double));
    memcpy(f.solver->p.w_start + 3, f.solver->p.w + 3, 3 * sizeof(double));
    f.solver->start_kept[1] = 1;
    f.solver->contact_flags_set = 1;
    check_blow_up_reported(&f, "spin is not finite");
    fixture_close(&f);
}

/* The block engine of dem/integrate.c (32 particles as vector lanes) against its scalar reference, one particle
 * at a time (integrate_particle_reference): the same bits for x, v, the kept drag and the iteration counts.
 * Random particles in the jet, diameters from 0.2 um (sub-cycled: response time below two steps) to 100 um,
 * after some steps (kept forces and their history); a third lose their kept drag (the paper's explicit first
 * guess, more iterations, so several lanes iterate in the vectorised passes) and some their history (linear or
 * no extrapolation); with and without the kept start forces; all particles (consecutive blocks) and every other
 * one (gathered blocks, the last one partial). */
struct drag_state {
    size_t n;
    double *x, *v, *forces[3][3], *slip, *reynolds_power;
    uint8_t *kept, *history_count;
};

/* save: a new copy of p's integration state into *st; else p's state back from *st. */
static void drag_state_copy(struct drag_state *st, struct dem_particles *p, int save)
{
    size_t n = p->count, vec = 3 * n * sizeof(double), one = n * sizeof(double);
    if (save) {
        st->n = n;
        st->x = malloc(vec), st->v = malloc(vec), st->slip = malloc(one), st->reynolds_power = malloc(one);
        st->kept = malloc(n), st->history_count = malloc(n);
        for (int s = 0; s < 3; s++)
            for (int c = 0; c < 3; c++)
                st->forces[s][c] = malloc(one);
    }
#define COPY(mine, theirs, size) (save ? memcpy(mine, theirs, size) : memcpy(theirs, mine, size))
    COPY(st->x, p->x, vec);
    COPY(st->v, p->v, vec);
    COPY(st->slip, p->drag.slip, one);
    COPY(st->reynolds_power, p->drag.reynolds_power, one);
    COPY(st->kept, p->drag.kept, n);
    COPY(st->history_count, p->drag.history_count, n);
    for (int s = 0; s < 3; s++)
        for (int c = 0; c < 3; c++)
            COPY(st->forces[s][c], p->drag.forces[s][c], one);
#undef COPY
}

static void drag_state_free(struct drag_state *st)
{
    free(st->x), free(st->v), free(st->slip), free(st->reynolds_power), free(st->kept), free(st->history_count);
    for (int s = 0; s < 3; s++)
        for (int c = 0; c < 3; c++)
            free(st->forces[s][c]);
}

/* The first particle (of the list) where a and b differ in any bit, with what differs; -1 if none. */
static long drag_state_differ(const struct drag_state *a, const struct drag_state *b, const uint32_t *list,
                              size_t count, const char **what)
{
    size_t one = sizeof(double);
    for (size_t k = 0; k < count; k++) {
        size_t i = list[k];
        *what = "x";
        if (memcmp(a->x + 3 * i, b->x + 3 * i, 3 * one) != 0)
            return (long)i;
        *what = "v";
        if (memcmp(a->v + 3 * i, b->v + 3 * i, 3 * one) != 0)
            return (long)i;
        *what = "slip or Re^0.6459";
        if (memcmp(a->slip + i, b->slip + i, one) != 0 ||
            memcmp(a->reynolds_power + i, b->reynolds_power + i, one) != 0)
            return (long)i;
        *what = "kept or history_count";
        if (a->kept[i] != b->kept[i] || a->history_count[i] != b->history_count[i])
            return (long)i;
        *what = "a kept force";
        for (int s = 0; s < 3; s++)
            for (int c = 0; c < 3; c++)
                if (memcmp(a->forces[s][c] + i, b->forces[s][c] + i, one) != 0)
                    return (long)i;
    }
    return -1;
}

/* What one comparison covered: integrations with sub-steps, runs with more than two iterations, particles that
 * crossed the bow shock's plane (a step split there, dem/integrate.c phi_redo_at_shock), unconverged solves. */
struct engine_coverage {
    int64_t subcycled, iterated, crossed, unconverged;
};

/* The block engine against the reference from the state after `steps` steps of the case (ini, rows): every
 * particle's x, v and kept drag the same bits, the same iteration counts, over all particles and every other one,
 * with the start drag reused and not. */
static void engine_matches_reference(const char *name, const char *ini, const char *rows, int steps,
                                     struct engine_coverage *cover)
{
    struct fixture f;
    int status = fixture_open(&f, ini, rows);
    if (status == SC_OK)
        status = fixture_steps(&f, steps);
    CHECK(status == SC_OK, "%s: fixture and %d steps", name, steps);
    if (status != SC_OK) {
        fixture_close(&f);
        return;
    }
    struct dem_particles *p = &f.solver->p;
    const struct dem_gas_field *gas = &f.solver->cfg.gas;
    const double plane = gas->shock_standoff > 0.0 ? gas->wall_z - gas->stagnation_height : NAN;
    const size_t n = p->count;
    for (size_t i = 0; i < n; i++) {
        if (i % 3 == 0)
            p->drag.kept[i] = 0;
        else if (i % 5 == 0)
            p->drag.history_count[i] = (uint8_t)(i % 2);
    }
    uint32_t *all = malloc(n * sizeof *all), *every_other = malloc(n * sizeof *every_other);
    size_t halves = 0;
    for (size_t i = 0; i < n; i++) {
        all[i] = (uint32_t)i;
        if (i % 2)
            every_other[halves++] = (uint32_t)i;
    }
    struct drag_state start, engine, reference;
    drag_state_copy(&start, p, 1);
    for (int reuse = 0; reuse < 2; reuse++) {
        for (int which = 0; which < 2; which++) {
            const uint32_t *list = which ? every_other : all;
            size_t count = which ? halves : n;
            int64_t counts_engine[5] = {0}, counts_reference[5] = {0};
            drag_state_copy(&start, p, 0);
            int bad_engine =
                dem_integrate_particles(&f.solver->cfg, p, reuse, f.solver->step, list, count, 0, counts_engine);
            drag_state_copy(&engine, p, 1);
            drag_state_copy(&start, p, 0);
            int bad_reference =
                dem_integrate_particles(&f.solver->cfg, p, reuse, f.solver->step, list, count, 1, counts_reference);
            drag_state_copy(&reference, p, 1);
            const char *what = "";
            long first = drag_state_differ(&engine, &reference, list, count, &what);
            CHECK(first < 0,
                  "%s: reuse_drag %d, %s: particle %ld: %s differs between the block engine and the reference", name,
                  reuse, which ? "every other particle" : "all particles", first, what);
            CHECK(memcmp(counts_engine, counts_reference, sizeof counts_engine) == 0 && bad_engine == bad_reference,
                  "%s: reuse_drag %d, %s: iteration counts differ: engine %lld %lld %lld %lld %lld, reference %lld "
                  "%lld %lld %lld %lld",
                  name, reuse, which ? "every other particle" : "all particles", (long long)counts_engine[0],
                  (long long)counts_engine[1], (long long)counts_engine[2], (long long)counts_engine[3],
                  (long long)counts_engine[4], (long long)counts_reference[0], (long long)counts_reference[1],
                  (long long)counts_reference[2], (long long)counts_reference[3], (long long)counts_reference[4]);
            cover->subcycled += counts_reference[4];
            cover->iterated += counts_reference[3] > 2;
            cover->unconverged += counts_reference[2];
            for (size_t k = 0; k < count; k++)
                cover->crossed += (start.x[3 * list[k] + 2] > plane) != (reference.x[3 * list[k] + 2] > plane);
            drag_state_free(&engine);
            drag_state_free(&reference);
        }
    }
    drag_state_free(&start);
    free(all);
    free(every_other);
    fixture_close(&f);
}

/* Random particles (state: an LCG) as rows: x, y within +-half_width of the axis, z in [z0, z0 + depth), vz in
 * [vz0, vz0 + vz_span), diameters log-uniform in [d_lo, d_hi]. */
static void random_rows(char *rows, size_t size, int count, double half_width, double z0, double depth, double vz0,
                        double vz_span, double d_lo, double d_hi)
{
    size_t used = 0;
    uint64_t state = 0x9e3779b97f4a7c15u;
#define UNIFORM() ((double)((state = state * 6364136223846793005u + 1442695040888963407u) >> 11) * 0x1p-53)
    for (int k = 0; k < count; k++) {
        double x = 2.0 * half_width * (UNIFORM() - 0.5), y = 2.0 * half_width * (UNIFORM() - 0.5);
        double z = z0 + depth * UNIFORM();
        double vx = 10.0 * (UNIFORM() - 0.5), vy = 10.0 * (UNIFORM() - 0.5), vz = vz0 + vz_span * UNIFORM();
        double d = d_lo * pow(d_hi / d_lo, UNIFORM());
        used += (size_t)snprintf(rows + used, size - used, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,0,0,0,%.17g\n", x, y, z,
                                 vx, vy, vz, d);
    }
#undef UNIFORM
}

/* Three set-ups: a slow cloud in the paper's jet (every regime of the drag, sub-cycled fine particles); the demo's
 * jet with its bow shock, particles within 0.7 mm of the shock's plane moving both ways (steps split at the plane);
 * the same with fixed_point_max_iter = 3 (unconverged steps redone in sub-steps, dem/integrate.c
 * phi_redo_in_substeps).  A review found the shock's paths unexercised by the first alone. */
static void test_block_engine_matches_reference(void)
{
    static char rows[150 * 160];
    struct engine_coverage cloud = {0}, shock = {0}, few = {0};
    random_rows(rows, sizeof rows, 150, 0.005, 0.005, 0.1, 0.0, 150.0, 2e-7, 1e-4);
    engine_matches_reference("cloud",
                             "[spray]\ndt = 1e-6\nt_end = 1\ndomain_radius = 0.2\n[target]\nstandoff = 0.3\n"
                             "[deposition]\nrule = none\n",
                             rows, 20, &cloud);
    CHECK(cloud.subcycled > 0 && cloud.iterated > 0, "cloud: covers sub-steps (%lld) and long iterations (%lld)",
          (long long)cloud.subcycled, (long long)cloud.iterated);
    const char *shock_case =
        "[spray]\ndt = 1e-6\nt_end = 1e-4\ndomain_radius = 0.02\n[powder]\ndensity = 2700\n"
        "[target]\nstandoff = 0.03\n[jet]\nmodel = bickley\nC1 = 320\nC3 = 40\n"
        "virtual_origin = 0.05\ncore_length = 0.002\nbow_shock = auto\n[deposition]\nrule = none\n";
    char few_case[1024];
    snprintf(few_case, sizeof few_case, "%s[spray]\nfixed_point_max_iter = 3\n", shock_case);
    /* the plane stands 1.15 mm before the target at z = 0.03 (docs/physics.md "The bow shock at the target") */
    random_rows(rows, sizeof rows, 150, 0.0005, 0.0281, 0.0014, -300.0, 1000.0, 3e-6, 3e-5);
    engine_matches_reference("shock", shock_case, rows, 0, &shock);
    CHECK(shock.crossed > 20, "shock: particles crossed the plane (%lld)", (long long)shock.crossed);
    engine_matches_reference("shock, max_iter 3", few_case, rows, 0, &few);
    printf("  crossings of the shock's plane compared: %lld, and %lld with max_iter 3 (%lld unconverged)\n",
           (long long)shock.crossed, (long long)few.crossed, (long long)few.unconverged);
    CHECK(few.crossed > 20, "shock, max_iter 3: particles crossed the plane (%lld)", (long long)few.crossed);
}

int main(void)
{
    h5_quiet();
    RUN(test_stokes_relaxation);
    RUN(test_stiff_particle_is_stable);
    RUN(test_swept_detection_matches_brute_force);
    RUN(test_injection_places_without_overlap);
    RUN(test_collision_count_converges);
    RUN(test_threads_bit_identical);
    RUN(test_kept_drag_changes_nothing);
    RUN(test_guessed_first_iterate);
    RUN(test_block_engine_matches_reference);
    RUN(test_checkpoint_round_trip);
    RUN(test_blow_up_is_reported);
    RUN(test_spin_blow_up_is_reported);
    return check_finish();
}
