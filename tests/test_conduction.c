/* Heat conduction inside the bodies ([impact] conduction = on, mpm/conduction.c) against the heat equation.
 *
 * A Gaussian hot spot, dT = A exp(-r^2 / (2 s0^2)), in the middle of an Al block (k 167 W/(m K), rho 2700 kg/m3,
 * c_p 900 J/(kg K): kappa = 6.87e-5 m2/s) spreads in free space as
 *     dT(centre, t) = A (s0^2 / (s0^2 + 2 kappa t))^(3/2),   variance per axis s^2(t) = s0^2 + 2 kappa t
 * (the fundamental solution convolved with the Gaussian).  The variance's growth is what the scheme must get right
 * in the interior to rounding (its kernel is normalised to the lattice's second moment: the discrete Laplacian of
 * x^2 is exactly 2); only the block's faces, 8 um from the centre, where the excess is 1e-4 of A, can move it, so
 * the bound is 0.5 %.  The centre value carries the kernel's O((eps / s)^2) error (eps = 0.8 um, s 1.5-2.1 um):
 * measured within 1 % of the formula, the bound 3 %.  The heat is conserved body by body (pair exchanges are
 * antisymmetric) to rounding, none crosses into a touching body of another temperature, and no temperature leaves
 * the range of the start (the step keeps each new temperature a weighted mean of the old ones); the same with two
 * materials, points moved off their lattice and unequal volumes.  Through the solver
 * (mpm_step, the block at rest) the exchanges happen on schedule: the variance grows by 2 kappa t over the time
 * stepped. */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "impact_fixture.h"
/* A white-box test: includes the module-private header mpm/mpm_impl.h (only tests may; tests/test_symbols.sh). */
#include "mpm/mpm_impl.h"

static const double kappa = 167.0 / (2700.0 * 900.0), s0 = 1.5e-6, amplitude = 100.0, T_block = 298.0;
static const double T_particle = 600.0;

/* The block, 16 um a side on 1.2/0.4 um, and a 2 um particle at rest touching its top, both at T_block. */
static int open_block(struct impact_fixture *f, double t_end, const char *symmetry)
{
    char ini[640];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_diameter = 16e-6\nsubstrate_height = 16e-6\ngrid = 1.2e-6\n"
             "spacing = 0.4e-6\nbonding = none\nconduction = on\nabsorbing = no\nstop_when_settled = no\n"
             "t_end = %g\nbox_margin = 2.4e-6\nsymmetry = %s\n[material.aluminium]\n",
             t_end, symmetry);
    return impact_fixture_open(f, ini, "sphere,0,0,1.0e-6,0,0,0,2e-6,0,aluminium\n");
}

/* Sets the hot spot on the block (body 0) around its point nearest the block's centre, and the particle (body 1)
 * to T_particle; returns that point's slot. */
static size_t heat_block(struct mpm_points *p, double centre[3])
{
    size_t nearest = 0;
    double best = INFINITY;
    for (size_t q = 0; q < p->count; q++) {
        const double *x = p->x + 3 * q;
        double r2 = x[0] * x[0] + x[1] * x[1] + (x[2] + 8e-6) * (x[2] + 8e-6);
        if (p->body[q] == 0 && r2 < best)
            best = r2, nearest = q;
    }
    for (int d = 0; d < 3; d++)
        centre[d] = p->x[3 * nearest + d];
    for (size_t q = 0; q < p->count; q++) {
        const double *x = p->x + 3 * q;
        double r2 = 0.0;
        for (int d = 0; d < 3; d++)
            r2 += (x[d] - centre[d]) * (x[d] - centre[d]);
        p->state[q].T = p->body[q] == 0 ? T_block + amplitude * exp(-r2 / (2.0 * s0 * s0)) : T_particle;
    }
    return nearest;
}

struct heat_moments {
    double heat[2];   /* sum m c T of each body, J */
    double variance;  /* mean over the axes of the block's excess-weighted variance about the centre, m^2 */
    double low, high; /* the block's temperature range, K */
};

static struct heat_moments moments(const struct mpm_points *p, const double centre[3])
{
    struct heat_moments m = {{0.0, 0.0}, 0.0, INFINITY, -INFINITY};
    double excess = 0.0, second = 0.0;
    for (size_t q = 0; q < p->count; q++) {
        double T = p->state[q].T;
        m.heat[p->body[q]] += p->mass[q] * 900.0 * T;
        if (p->body[q] != 0)
            continue;
        double r2 = 0.0;
        for (int d = 0; d < 3; d++)
            r2 += (p->x[3 * q + d] - centre[d]) * (p->x[3 * q + d] - centre[d]);
        excess += p->mass[q] * (T - T_block);
        second += p->mass[q] * (T - T_block) * r2;
        m.low = fmin(m.low, T), m.high = fmax(m.high, T);
    }
    m.variance = second / excess / 3.0;
    return m;
}

/* Exchanges alone (no mechanics) until 2 kappa t = s0^2: the centre at 2^(-3/2) of its excess. */
static void test_hot_spot(void)
{
    struct impact_fixture f;
    if (open_block(&f, 1e-9, "none") != SC_OK) {
        CHECK(0, "block set up");
        return;
    }
    struct mpm_points *p = &f.solver->points;
    double centre[3];
    size_t middle = heat_block(p, centre);
    struct heat_moments start = moments(p, centre);
    double interval = mpm_conduction_interval(f.solver), t_total = s0 * s0 / (2.0 * kappa);
    int exchanges = (int)ceil(t_total / interval);
    double dt = t_total / exchanges;
    CHECK(dt <= interval && exchanges >= 20, "%d exchanges of %g s (interval %g s)", exchanges, dt, interval);
    for (int k = 0; k < exchanges; k++)
        mpm_conduction_exchange(f.solver, dt);
    struct heat_moments end = moments(p, centre);
    printf("  variance %.6g -> %.6g m2 (2 kappa t = %.6g); centre excess %.6g K (formula %.6g)\n", start.variance,
           end.variance, 2.0 * kappa * t_total, p->state[middle].T - T_block, amplitude * pow(2.0, -1.5));
    CHECK_CLOSE(end.variance - start.variance, 2.0 * kappa * t_total, 5e-3, 0.0, "variance growth 2 kappa t");
    CHECK_CLOSE(p->state[middle].T - T_block, amplitude * pow(2.0, -1.5), 0.03, 0.0, "centre excess");
    CHECK_CLOSE(end.heat[0], start.heat[0], 1e-13, 0.0, "block's heat conserved");
    CHECK_CLOSE(end.heat[1], start.heat[1], 1e-13, 0.0, "particle's heat: none crossed the contact");
    CHECK(end.low >= T_block - 1e-9 && end.high <= start.high, "block's range [%.9g, %.9g] within [%g, %.9g]", end.low,
          end.high, T_block, start.high);
    impact_fixture_close(&f);
}

/* Through mpm_step: the variance grows by 2 kappa t over the time stepped. */
static void test_through_the_solver(void)
{
    struct impact_fixture f;
    double t_end = 3e-9;
    if (open_block(&f, t_end, "none") != SC_OK) {
        CHECK(0, "block set up");
        return;
    }
    struct mpm_points *p = &f.solver->points;
    double centre[3];
    heat_block(p, centre);
    struct heat_moments start = moments(p, centre);
    CHECK(impact_fixture_run(&f) == SC_OK, "run");
    double interval = mpm_conduction_interval(f.solver), t = mpm_get_counts(f.solver).t;
    double exchanged = floor(t / interval) * interval;
    struct heat_moments end = moments(p, centre);
    printf("  t = %.4g s, %g exchanges of %.4g s: variance %.6g -> %.6g m2 (2 kappa t = %.6g)\n", t,
           floor(t / interval), interval, start.variance, end.variance, 2.0 * kappa * exchanged);
    CHECK(exchanged > 0.8 * t_end, "exchanged %g s of %g s", exchanged, t);
    CHECK_CLOSE(end.variance - start.variance, 2.0 * kappa * exchanged, 0.01, 0.0, "variance growth 2 kappa t");
    impact_fixture_close(&f);
}

/* Two materials, points off their lattice and of unequal volumes: a copper particle (k 398 W/(m K), rho 8960, c_p
 * 385) with a temperature gradient touching an Al block whose points are moved by up to 0.15 spacing and whose
 * volumes and masses vary by up to 20 % (density kept), with the hot spot.  Each body's heat sum m c_p T stays to
 * rounding (a pair's heat is antisymmetric only if each side uses its own volume, mass, conductivity and heat
 * capacity), no temperature leaves its body's start range, each point's internal energy grows by m c_p dT of its
 * own material, and both bodies did exchange heat. */
static void test_two_materials_off_lattice(void)
{
    struct impact_fixture f;
    char ini[640];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_diameter = 8e-6\nsubstrate_height = 8e-6\ngrid = 1.2e-6\n"
             "spacing = 0.4e-6\nbonding = none\nconduction = on\nabsorbing = no\nt_end = 1e-9\nbox_margin = 2.4e-6\n"
             "[material.aluminium]\n[material.copper]\ndensity = 8960\nspecific_heat = 385\nconductivity = 398\n");
    if (impact_fixture_open(&f, ini, "sphere,0,0,1.4e-6,0,0,0,2.8e-6,0,copper\n") != SC_OK) {
        CHECK(0, "set up");
        return;
    }
    struct mpm_points *p = &f.solver->points;
    const double c_p[2] = {900.0, 385.0};
    unsigned state = 12345u;
    double heat0[2] = {0.0, 0.0}, low[2] = {INFINITY, INFINITY}, high[2] = {-INFINITY, -INFINITY};
    for (size_t q = 0; q < p->count; q++) {
        int b = p->body[q];
        double *x = p->x + 3 * q;
        if (b == 0) {
            for (int d = 0; d < 3; d++) {
                state = state * 1664525u + 1013904223u;
                x[d] += 0.15 * 0.4e-6 * (2.0 * (state >> 8) / 16777216.0 - 1.0);
            }
            state = state * 1664525u + 1013904223u;
            double scale = 0.8 + 0.4 * (state >> 8) / 16777216.0;
            p->volume0[q] *= scale, p->mass[q] *= scale;
            p->state[q].T = T_block + amplitude * exp(-(x[0] * x[0] + x[1] * x[1] + (x[2] + 4e-6) * (x[2] + 4e-6)) /
                                                      (2.0 * s0 * s0));
        } else {
            p->state[q].T = T_particle + 1e8 * x[0]; /* 100 K per um across the particle */
        }
        heat0[b] += p->mass[q] * c_p[b] * p->state[q].T;
        low[b] = fmin(low[b], p->state[q].T), high[b] = fmax(high[b], p->state[q].T);
    }
    double *T0 = malloc(p->count * sizeof *T0), *E0 = malloc(p->count * sizeof *E0);
    for (size_t q = 0; q < p->count; q++)
        T0[q] = p->state[q].T, E0[q] = p->state[q].energy;
    double start[2] = {p->state[0].T, 0.0}, moved[2] = {0.0, 0.0}, heat[2] = {0.0, 0.0};
    size_t first_particle = p->count;
    for (size_t q = 0; q < p->count && first_particle == p->count; q++)
        if (p->body[q] == 1)
            first_particle = q, start[1] = p->state[q].T;
    for (int k = 0; k < 30; k++)
        mpm_conduction_exchange(f.solver, mpm_conduction_interval(f.solver));
    int in_range = 1;
    double worst = 0.0; /* internal energy gained against m c_p dT, largest relative mismatch */
    for (size_t q = 0; q < p->count; q++) {
        int b = p->body[q];
        heat[b] += p->mass[q] * c_p[b] * p->state[q].T;
        in_range &= p->state[q].T >= low[b] - 1e-9 && p->state[q].T <= high[b] + 1e-9;
        double dE = p->state[q].energy - E0[q], mcdT = p->mass[q] * c_p[b] * (p->state[q].T - T0[q]);
        worst = fmax(worst, fabs(dE - mcdT) / (fabs(mcdT) + 1e-30));
    }
    free(T0), free(E0);
    moved[0] = fabs(p->state[0].T - start[0]), moved[1] = fabs(p->state[first_particle].T - start[1]);
    printf("  heat change: block %.3g, particle %.3g (relative); a block point moved %.3g K, a particle point %.3g K\n",
           heat[0] / heat0[0] - 1.0, heat[1] / heat0[1] - 1.0, moved[0], moved[1]);
    CHECK_CLOSE(heat[0], heat0[0], 1e-13, 0.0, "block's heat conserved");
    CHECK_CLOSE(heat[1], heat0[1], 1e-13, 0.0, "copper particle's heat conserved");
    CHECK(in_range, "every temperature within its body's start range");
    CHECK(worst < 1e-6, "each point's internal energy gained = m c_p dT of its material (worst mismatch %.3g)", worst);
    CHECK(moved[1] > 1e-3, "the particle's points exchanged heat");
    impact_fixture_close(&f);
}

/* A lattice point's position in half spacings (the lattice's points lie at odd multiples of them from the planes). */
struct lattice_key {
    long i[3];
    size_t slot;
};

static int compare_keys(const void *a, const void *b)
{
    const long *u = ((const struct lattice_key *)a)->i, *v = ((const struct lattice_key *)b)->i;
    for (int d = 0; d < 3; d++)
        if (u[d] != v[d])
            return u[d] < v[d] ? -1 : 1;
    return 0;
}

/* The block's points (body 0) in the quadrant x > 0, y > 0, sorted by position; returns how many. */
static size_t quadrant_keys(const struct mpm_points *p, struct lattice_key *keys)
{
    size_t n = 0;
    for (size_t q = 0; q < p->count; q++) {
        const double *x = p->x + 3 * q;
        if (p->body[q] != 0 || x[0] < 0.0 || x[1] < 0.0)
            continue;
        for (int d = 0; d < 3; d++)
            keys[n].i[d] = lround(x[d] / 0.2e-6);
        keys[n++].slot = q;
    }
    qsort(keys, n, sizeof *keys, compare_keys);
    return n;
}

/* [impact] symmetry with conduction: the hot spot centred on the planes x = 0 and y = 0 (its axis through the
 * block's centre) spreads in the quarter model as in the whole block, point by point: each quarter point's
 * temperature is its whole twin's to rounding (the sums' order differs), the quarter's heat is conserved, and the
 * points by the planes (which without the images see only their own side, an adiabatic wall with half a kernel)
 * are the ones that would tell. */
static void test_mirror_images(void)
{
    struct impact_fixture whole, quarter;
    if (open_block(&whole, 1e-9, "none") != SC_OK || open_block(&quarter, 1e-9, "quarter") != SC_OK) {
        CHECK(0, "blocks set up");
        impact_fixture_close(&whole);
        return;
    }
    struct mpm_points *pw = &whole.solver->points, *pq = &quarter.solver->points;
    double centre[3];
    heat_block(pw, centre);
    centre[0] = centre[1] = 0.0; /* on both planes: the field is mirror-symmetric */
    double heat0 = 0.0, heat = 0.0;
    for (int m = 0; m < 2; m++) {
        struct mpm_points *p = m ? pq : pw;
        for (size_t q = 0; q < p->count; q++) {
            const double *x = p->x + 3 * q;
            double r2 = x[0] * x[0] + x[1] * x[1] + (x[2] - centre[2]) * (x[2] - centre[2]);
            p->state[q].T = p->body[q] == 0 ? T_block + amplitude * exp(-r2 / (2.0 * s0 * s0)) : T_particle;
        }
    }
    for (size_t q = 0; q < pq->count; q++)
        heat0 += pq->mass[q] * 900.0 * pq->state[q].T;
    double dt = mpm_conduction_interval(whole.solver);
    for (int k = 0; k < 40; k++) {
        mpm_conduction_exchange(whole.solver, dt);
        mpm_conduction_exchange(quarter.solver, dt);
    }
    for (size_t q = 0; q < pq->count; q++)
        heat += pq->mass[q] * 900.0 * pq->state[q].T;
    struct lattice_key *kw = malloc(pw->count * sizeof *kw), *kq = malloc(pq->count * sizeof *kq);
    size_t nw = quadrant_keys(pw, kw), nq = quadrant_keys(pq, kq);
    double worst = INFINITY, worst_plane = 0.0, hottest = 0.0;
    if (nw == nq) {
        worst = 0.0;
        for (size_t k = 0; k < nq; k++) {
            if (compare_keys(&kw[k], &kq[k]) != 0) {
                worst = INFINITY;
                break;
            }
            double off = fabs(pq->state[kq[k].slot].T - pw->state[kw[k].slot].T) / amplitude;
            worst = fmax(worst, off);
            hottest = fmax(hottest, pq->state[kq[k].slot].T - T_block);
            if (kq[k].i[0] == 1 || kq[k].i[1] == 1)
                worst_plane = fmax(worst_plane, off);
        }
    }
    free(kw), free(kq);
    printf("  %zu quarter points against %zu of the whole's quadrant: largest difference %.3g of the amplitude "
           "(%.3g by the planes); quarter's heat change %.3g, hottest excess %.4g K\n",
           nq, nw, worst, worst_plane, heat / heat0 - 1.0, hottest);
    CHECK(nq == nw && nq > 0, "the quarter's block points are the whole's quadrant: %zu and %zu", nq, nw);
    CHECK(worst < 1e-12, "each quarter point's temperature is its whole twin's: largest difference %.3g of A", worst);
    CHECK_CLOSE(heat, heat0, 1e-13, 0.0, "quarter's heat conserved");
    CHECK(hottest < 0.8 * amplitude, "the spot spread: hottest excess %.4g K of %g", hottest, amplitude);
    impact_fixture_close(&whole);
    impact_fixture_close(&quarter);
}

/* A case that does not ask for conduction runs adiabatic, as the thesis's (Eq. 3.44). */
static void test_default_off(void)
{
    struct impact_fixture f;
    CHECK(impact_fixture_open(&f, "[impact]\ngrid = 2e-6\nspacing = 1e-6\n[material.aluminium]\n", NULL) == SC_OK,
          "default case");
    CHECK(f.solver && f.solver->conduction == NULL && !f.cfg.conduction, "conduction off by default (adiabatic)");
    impact_fixture_close(&f);
}

int main(void)
{
    RUN(test_hot_spot);
    RUN(test_through_the_solver);
    RUN(test_two_materials_off_lattice);
    RUN(test_mirror_images);
    RUN(test_default_off);
    return check_finish();
}
