/* The substrate as a semi-infinite body (thesis Section 3.5.5; issue 22, item 5): a plane P-wave pulse running
 * down a substrate column leaves it through the absorbing (dashpot, Eqs. 3.45-3.46) bottom, and the fixed bottom
 * (substrate_bottom = fixed: no vertical nodal velocity at the bottom face) sends it back up.  The viscous-spring
 * bottom (substrate_bottom = spring) absorbs the pulse as the dashpot does, sends back and holds what the
 * continuum's spring-dashpot boundary would, closes the energy balance with its springs' energy, carries a static
 * load at the static solution where the free bottom creeps, and restarts from a checkpoint to the same bits.
 *
 * The column: 4 mm x 4 mm x 40 mm of an elastic material with Poisson ratio 0 (no lateral expansion: the column
 * carries the uniaxial-strain wave at c_L = sqrt((K + 4G/3)/rho) = 1414 m/s, as a half-space under a plane wave
 * does), 1 mm cells, 2 points per cell edge, no bulk viscosity.  Its sides stand for planes of symmetry of that
 * half-space, not for its edges: their dashpots (whose tangential part would damp the wave's v_z along the sides)
 * are switched off here.  The pulse: the top 4 (or 8) mm start moving down at 1 m/s; half of it runs down at once, half
 * after reflecting off the free top, an 8 (16) mm pulse in all.  When it has had time to pass the bottom (t = (h + 2
 * slabs) / c_L + 3 us) and before a reflection could reach the top again, the energy left in the column over the energy
 * put in is the energy reflection coefficient.
 *
 * Bounds: the dashpot of a lattice point (rho c_L dp^2) matches the impedance of the continuum exactly at normal
 * incidence, so what comes back is discretisation error (the dashpot acts on the points of the last half cell,
 * spread over two node planes; the pulse disperses on the grid) and must fall as the pulse gets more cells:
 * measured 10.1 % of the energy for a pulse 8 cells long and 4.5 % for 16 cells (amplitude reflection 32 % and
 * 21 %), so the bounds are 12 % and 6 %.  An impact's stress pulse is about a particle diameter long, 7-20
 * cells on the grids of docs/physics.md.  The fixed bottom must keep more than 80 % (it reflects all but the
 * numerical dissipation; measured 101.7 %, the excess being the energy measure's own error). */
#include <math.h>

#include "check.h"
#include "impact_fixture.h"
/* A white-box test: includes the module-private header mpm/mpm_impl.h (only tests may; tests/test_symbols.sh). */
#include "mpm/mpm_impl.h"

#define NU0_MATERIAL                                                                                                   \
    "[material.nu0]\nstrength = elastic\ndensity = 1000\neos_c0 = 816.496580927726\neos_s = 0\n"                       \
    "eos_gamma0 = 0\nG0 = 1e9\nD = 0\nmelt_T0 = 1e5\n"

static const double height = 0.04, c_L = 1414.213562373095;

/* The energy left in the column over the energy put in, and the absorbed energy booked over the same, for a
 * start slab `pulse` thick (a pulse twice as long); `extra`: more [impact] keys; `stored` and `total`: the energy
 * the boundary springs hold at the end and the solver's energy total, over the energy put in (NULL: not asked). */
static int reflected_with(const char *bottom, const char *extra, double pulse, double *left, double *absorbed,
                          double *stored, double *total)
{
    struct impact_fixture f;
    char ini[1024];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_material = nu0\nmaterial = nu0\nsubstrate_diameter = 0.004\n"
             "substrate_height = %g\nsubstrate_bottom = %s\nabsorbing = yes\ngrid = 1e-3\nspacing = 0.5e-3\n"
             "t_end = %g\ncfl = 0.2\nbonding = none\nbulk_viscosity_linear = 0\nbulk_viscosity_quadratic = 0\n"
             "box_margin = 2e-3\nstop_when_settled = no\n%s\n" NU0_MATERIAL,
             height, bottom, (height + 2 * pulse) / c_L + 3e-6, extra);
    /* a small body at rest well above the column (a case holds a particle; this one takes no part) */
    if (impact_fixture_open(&f, ini, "sphere,0,0,0.006,0,0,0,0.002,0,nu0\n") != SC_OK)
        return -1;
    struct mpm_points *p = &f.solver->points;
    double e0 = 0.0;
    for (size_t q = 0; q < p->count; q++) {
        if (p->body[q] != 0)
            continue;
        p->flags[q] &= (uint8_t)~POINT_SIDE;
        if (p->x[3 * q + 2] > -pulse) {
            p->v[3 * q + 2] = -1.0;
            e0 += 0.5 * p->mass[q];
        }
    }
    f.solver->energy_initial = e0;
    int status = impact_fixture_run(&f);
    const struct mpm_diagnostics *d = mpm_compute_diagnostics(f.solver);
    *left = (d->body[0].kinetic_energy + d->body[0].internal_energy) / e0;
    *absorbed = d->energy_absorbed / e0;
    if (stored)
        *stored = d->energy_stored / e0, *total = d->energy_total / e0;
    printf("  %s bottom %s, %g mm pulse: %.4f of the pulse's energy left in the column, %.4f absorbed, %.4f stored "
           "(t = %.4g s)\n",
           bottom, extra, 2e3 * pulse, *left, *absorbed, d->energy_stored / e0, mpm_get_counts(f.solver).t);
    impact_fixture_close(&f);
    return status;
}

static int reflected(const char *bottom, double pulse, double *left, double *absorbed)
{
    return reflected_with(bottom, "", pulse, left, absorbed, NULL, NULL);
}

static void test_absorbing_bottom(void)
{
    /* pulses 8 and 16 cells long: what reflects is discretisation error, and falls as the pulse is resolved */
    const double pulse[2] = {0.004, 0.008}, bound[2] = {0.12, 0.06};
    for (int k = 0; k < 2; k++) {
        double left = NAN, absorbed = NAN;
        CHECK(reflected("free", pulse[k], &left, &absorbed) == SC_OK, "run");
        CHECK(left < bound[k], "%g cells a pulse: reflected energy %.4f of the incident (bound %g)", 2e3 * pulse[k],
              left, bound[k]);
        CHECK(absorbed > 0.85, "the dashpots booked %.4f of the incident energy as absorbed", absorbed);
    }
}

static void test_fixed_bottom_reflects(void)
{
    double left = NAN, absorbed = NAN;
    CHECK(reflected("fixed", 0.004, &left, &absorbed) == SC_OK, "run");
    CHECK(left > 0.8, "the fixed bottom sends back %.4f of the incident energy (at least 0.8)", left);
}

/* The viscous-spring bottom (substrate_bottom = spring) in the continuum: the boundary's traction on the column is
 * -C v - K u per unit area (C = rho c_L, K = alpha_N G / R).  With the incident wave's velocity v_i at the bottom
 * and the reflected one v_r, the traction is -C v_i + C v_r and v = v_i + v_r, so 2 C v_r = -K u and
 * du/dt = v_i - u / tau with tau = 2 C / K (for harmonic waves the amplitude reflection K / sqrt(K^2 + (2 C w)^2)
 * of docs/physics.md).  For the rectangular pulse here (v_i = a over T = 2 pulse / c_L) u rises as
 * a tau (1 - exp(-t / tau)) and then decays as exp(-t / tau); the energy sent back up until t_w after the pulse
 * (int v_r^2 over int v_i^2) and the energy the spring holds then, both over the pulse's C a^2 T: */
static void spring_reflection(double K, double pulse, double t_w, double *reflected_fraction, double *stored_fraction)
{
    double C = 1000.0 * c_L, tau = 2.0 * C / K, T = 2.0 * pulse / c_L, x = T / tau, rise = 1.0 - exp(-x);
    double during = (T - 2.0 * tau * rise + 0.5 * tau * (1.0 - exp(-2.0 * x))) / T;
    double after = tau * rise * rise * (1.0 - exp(-2.0 * t_w / tau)) / (2.0 * T);
    *reflected_fraction = during + after;
    *stored_fraction = tau * rise * rise * exp(-2.0 * t_w / tau) / T;
}

/* The spring bottom with the default alpha_N = 2 (R = the column's 40 mm, K = 5e10 Pa/m, tau = 57 us, 10 and 20
 * times the pulses): the dashpot absorbs the pulse as the free bottom does; the spring sends back a little of
 * its low frequencies and holds some of its energy (the pulse displaces the bottom; the spring relaxes it over tau).
 * The energy balance closes with the springs' stored energy. */
static void test_spring_bottom(void)
{
    const double pulse[2] = {0.004, 0.008}, bound[2] = {0.125, 0.09};
    const double K = 2.0 * 1e9 / height;
    for (int k = 0; k < 2; k++) {
        double left = NAN, absorbed = NAN, stored = NAN, total = NAN, analytic = NAN, analytic_stored = NAN;
        CHECK(reflected_with("spring", "", pulse[k], &left, &absorbed, &stored, &total) == SC_OK, "run");
        spring_reflection(K, pulse[k], pulse[k] / c_L + 3e-6, &analytic, &analytic_stored);
        printf("  continuum: the spring alone sends back %.4f and holds %.4f\n", analytic, analytic_stored);
        CHECK(left < bound[k], "%g cells a pulse: reflected energy %.4f of the incident (bound %g)", 2e3 * pulse[k],
              left, bound[k]);
        CHECK_CLOSE(stored, analytic_stored, 0.1, 0.0, "energy held by the springs over the pulse's");
        CHECK_CLOSE(total, 1.0, 0.0, 0.02, "energy total (left + absorbed + stored) over the pulse's energy");
    }
}

/* A stiff spring (alpha_N = 20: tau = 5.7 us, the 8 mm pulse's length) sends back a large share of the pulse as
 * the continuum's boundary would. */
static void test_stiff_spring_bottom(void)
{
    const double pulse = 0.008, K = 20.0 * 1e9 / height;
    double left = NAN, absorbed = NAN, stored = NAN, total = NAN, analytic = NAN, analytic_stored = NAN;
    CHECK(reflected_with("spring", "spring_alpha_normal = 20", pulse, &left, &absorbed, &stored, &total) == SC_OK,
          "run");
    spring_reflection(K, pulse, pulse / c_L + 3e-6, &analytic, &analytic_stored);
    printf("  continuum: the spring alone sends back %.4f and holds %.4f\n", analytic, analytic_stored);
    CHECK_CLOSE(left, analytic, 0.15, 0.0, "reflected energy over the incident");
    CHECK_CLOSE(total, 1.0, 0.0, 0.02, "energy total (left + absorbed + stored) over the pulse's energy");
}

/* A static load on the bottom.  The column, 10 mm high, is pressed down by a platen: its top layer of points gets a
 * soft spring (the side boundary's spring, normal +z, the points flagged and listed again) anchored `preload` below
 * them, so that it pushes with about P = k_top preload whatever the column does.  The spring bottom (k_b = 2 G / R,
 * R = 10 mm) must come to rest carrying P, displaced by the static solution u = sigma R / (alpha G), and stop;
 * the free (dashpot) bottom holds no static load: the column creeps down at P / (2 rho c_L) (the platen's layer
 * has its dashpot too, as the top of a boundary would).  The sides are planes of symmetry (no dashpots).  Returns
 * the bottom's mean displacement, the mean sigma_zz of the column's points (less those of its top and bottom cells,
 * which take the boundary forces) and its v_z (centre of mass) at the end. */
static int pressed(const char *bottom, double *u_bottom, double *sigma, double *v)
{
    const double column = 0.01, k_top = 1e9, preload = 1e-3; /* P = 1 MPa, strain 5e-4 */
    struct impact_fixture f;
    char ini[1024];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_material = nu0\nmaterial = nu0\nsubstrate_diameter = 0.004\n"
             "substrate_height = %g\nsubstrate_bottom = %s\nsubstrate_sides = spring\nabsorbing = yes\n"
             "grid = 1e-3\nspacing = 0.5e-3\nt_end = 100e-6\ncfl = 0.2\nbonding = none\n"
             "bulk_viscosity_linear = 0\nbulk_viscosity_quadratic = 0\nbox_margin = 2e-3\nstop_when_settled = no\n"
             "series_every = 1e-6\nsettle_window = 4e-6\n" NU0_MATERIAL,
             column, bottom);
    if (impact_fixture_open(&f, ini, "sphere,0,0,0.006,0,0,0,0.002,0,nu0\n") != SC_OK)
        return -1;
    struct mpm_solver *s = f.solver;
    struct mpm_points *p = &s->points;
    for (size_t q = 0; q < p->count; q++) {
        if (p->body[q] != 0)
            continue;
        p->flags[q] &= (uint8_t)~POINT_SIDE;
        if (p->x[3 * q + 2] > -0.5e-3) { /* the top layer: the platen's spring, normal +z */
            p->flags[q] |= POINT_SIDE;
            p->normal[3 * q] = p->normal[3 * q + 1] = 0.0, p->normal[3 * q + 2] = 1.0;
        }
    }
    int status = mpm_list_boundary_points(s);
    s->body_spring[2] = k_top * 0.5e-3 * 0.5e-3;
    s->body_spring[3] = 0.0;
    for (size_t q = 0; q < p->count; q++)
        if (p->body[q] == 0 && (p->flags[q] & POINT_SIDE))
            s->boundary_anchor[3 * s->boundary_rank[p->id[q]] + 2] -= preload;
    if (status == SC_OK)
        status = impact_fixture_run(&f);
    double sum_u = 0.0, sum_s = 0.0, sum_mv = 0.0, mass = 0.0;
    size_t n_bottom = 0, n = 0;
    for (size_t q = 0; q < p->count; q++) {
        if (p->body[q] != 0)
            continue;
        if (p->flags[q] & POINT_BOTTOM) {
            double u[3];
            boundary_displacement(s, q, u);
            sum_u += u[2], n_bottom++;
        }
        if (p->x[3 * q + 2] < -1e-3 && p->x[3 * q + 2] > 1e-3 - column) {
            sum_s += p->state[q].stress[2];
            n++;
        }
        sum_mv += p->mass[q] * p->v[3 * q + 2], mass += p->mass[q];
    }
    *u_bottom = sum_u / (double)n_bottom, *sigma = sum_s / (double)n, *v = sum_mv / mass;
    printf("  %s bottom under %g MPa: bottom displaced %.4g m, sigma_zz %.4g Pa, v_z %.3g m/s at %.3g s\n", bottom,
           k_top * preload / 1e6, *u_bottom, *sigma, *v, mpm_get_counts(s).t);
    impact_fixture_close(&f);
    return status;
}

static void test_spring_bottom_holds_static_load(void)
{
    const double P = 1e6, k_bottom = 2.0 * 1e9 / 0.01, creep = P / (2.0 * 1000.0 * c_L);
    double u = NAN, sigma = NAN, v = NAN;
    CHECK(pressed("spring", &u, &sigma, &v) == SC_OK, "run");
    CHECK_CLOSE(u, sigma / k_bottom, 0.02, 0.0, "bottom displacement against sigma R / (alpha G)");
    CHECK_CLOSE(sigma, -P, 0.02, 0.0, "the column carries the platen's load");
    CHECK(fabs(v) < 0.01 * creep, "at rest: v_z %.3g m/s (the free bottom's creep %.3g m/s)", v, creep);
    CHECK(pressed("free", &u, &sigma, &v) == SC_OK, "run");
    CHECK(v < -0.8 * creep, "the free bottom creeps: v_z %.3g m/s (P / (2 rho c_L) = %.3g m/s)", v, creep);
}

/* A restart: the springs' anchors are the boundary points' set-up positions, made again with the solver from the
 * case (a derived table: checkpoints do not hold it, and one of any substrate_bottom loads).  A run checkpointed
 * while the pulse displaces the bottom and resumed into a fresh solver ends with the same bits as the run that went
 * on. */
static int open_pulse(struct impact_fixture *f)
{
    char ini[1024];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_material = nu0\nmaterial = nu0\nsubstrate_diameter = 0.004\n"
             "substrate_height = 0.01\nsubstrate_bottom = spring\ngrid = 1e-3\n"
             "spacing = 0.5e-3\nt_end = 1e-3\ncfl = 0.2\nbonding = none\nbox_margin = 2e-3\n"
             "stop_when_settled = no\n" NU0_MATERIAL);
    if (impact_fixture_open(f, ini, "sphere,0,0,0.006,0,0,0,0.002,0,nu0\n") != SC_OK)
        return -1;
    struct mpm_points *p = &f->solver->points;
    for (size_t q = 0; q < p->count; q++)
        if (p->body[q] == 0 && p->x[3 * q + 2] > -0.004)
            p->v[3 * q + 2] = -1.0;
    return SC_OK;
}

static int steps(struct mpm_solver *s, int n)
{
    for (int k = 0; k < n; k++)
        if (mpm_step(s) != SC_OK)
            return -1;
    return SC_OK;
}

static void test_spring_restart(void)
{
    struct impact_fixture a, b;
    char path[] = "/tmp/spraycoat_spring_XXXXXX";
    int fd = mkstemp(path);
    if (fd < 0 || open_pulse(&a) != SC_OK || open_pulse(&b) != SC_OK) {
        CHECK(0, "set-up");
        return;
    }
    CHECK(steps(a.solver, 60) == SC_OK, "first steps");
    hid_t file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(mpm_checkpoint_write(a.solver, file) == SC_OK, "checkpoint written");
    H5Fclose(file);
    file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
    CHECK(mpm_checkpoint_read(b.solver, file) == SC_OK, "checkpoint read");
    H5Fclose(file);
    CHECK(steps(a.solver, 60) == SC_OK && steps(b.solver, 60) == SC_OK, "steps after the checkpoint");
    const struct mpm_points *pa = &a.solver->points, *pb = &b.solver->points;
    size_t differ = 0;
    double lowest = 0.0;
    for (size_t i = 0; i < pa->count; i++) {
        const double *xa = pa->x + 3 * pa->slot[i], *xb = pb->x + 3 * pb->slot[i];
        differ += memcmp(xa, xb, 3 * sizeof *xa) != 0;
        if (pa->flags[pa->slot[i]] & POINT_BOTTOM) {
            double u[3];
            boundary_displacement(a.solver, pa->slot[i], u);
            lowest = fmin(lowest, u[2]);
        }
    }
    printf("  after the restart: %zu of %zu points differ; the bottom displaced by down to %.3g m\n", differ, pa->count,
           lowest);
    CHECK(differ == 0, "%zu points differ from the run that went on", differ);
    CHECK(lowest < -1e-7, "the pulse has reached the springs (bottom displaced %.3g m)", lowest);
    impact_fixture_close(&a);
    impact_fixture_close(&b);
    if (fd >= 0)
        close(fd), unlink(path);
}

int main(void)
{
    RUN(test_absorbing_bottom);
    RUN(test_fixed_bottom_reflects);
    RUN(test_spring_bottom);
    RUN(test_stiff_spring_bottom);
    RUN(test_spring_bottom_holds_static_load);
    RUN(test_spring_restart);
    return check_finish();
}
