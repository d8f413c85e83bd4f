/* One material point driven through mpm_stress_update (mpm/stress_update.c, Tang Appendix A): consistency of
 * the rate-dependent radial return with the PTW flow stress, elastic loading and unloading slopes, plastic
 * work and the EOS energy balance, adiabatic heating, objectivity under pure spin, melting, the isentrope of
 * the elastic EOS path against an independent integration, and the artificial bulk viscosity. */
#include <string.h>

/* A white-box test: includes the module-private header mpm/material.h (only tests may; tests/test_symbols.sh). */
#include "mpm/material.h"
#include "tests/check.h"

#define V0         1e-18 /* m3: a 1 um cube */
#define STEP       1e-5  /* strain increment per step along the loading axis */
#define RATE_FLOOR 1e-3

static struct mpm_material aluminium(double taylor_quinney)
{
    struct mpm_material m = {0};
    m.strength = MPM_STRENGTH_PTW;
    m.density = 2700.0;
    m.ptw_theta = 0.01156, m.ptw_p = 3.0, m.ptw_s0 = 0.01489, m.ptw_sinf = 0.002819, m.ptw_kappa = 1.3;
    m.ptw_gamma = 2.04e-5, m.ptw_y0 = 0.0115, m.ptw_yinf = 0.002003, m.ptw_y1 = 0.0168, m.ptw_y2 = 0.2339;
    m.ptw_beta = 0.2034;
    m.atomic_mass = 4.48039e-26;
    m.rate_floor = RATE_FLOOR;
    m.G0 = 28.8e9, m.D = 3.44e9, m.T0 = 215.0;
    m.eos_c0 = 5240.0, m.eos_s = 1.4, m.eos_gamma0 = 1.97;
    m.melt_T0 = 933.0, m.melt_a = 1.5;
    m.specific_heat = 900.0, m.taylor_quinney = taylor_quinney, m.T_initial = 298.0;
    m.bulk_modulus = m.density * m.eos_c0 * m.eos_c0;
    return m;
}

static const double no_spin[3] = {0.0, 0.0, 0.0};

/* ---- helpers ---- */

static double contract(const double a[6], const double b[6])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

static void deviator(const double t[6], double s[6])
{
    double mean = (t[0] + t[1] + t[2]) / 3.0;
    for (int k = 0; k < 6; k++)
        s[k] = t[k] - (k < 3 ? mean : 0.0);
}

static double von_mises_of_stress(const double stress[6])
{
    double s[6];
    deviator(stress, s);
    return sqrt(1.5 * contract(s, s));
}

/* Isochoric uniaxial increment diag(1, -1/2, -1/2) * size, plus an xy shear part. */
static void isochoric(double size, double shear, double de[6])
{
    double v[6] = {size, -0.5 * size, -0.5 * size, 0.0, 0.0, shear};
    for (int k = 0; k < 6; k++)
        de[k] = v[k];
}

/* A step at constant volume V0. */
static struct mpm_update_result step(const struct mpm_material *m, const double de[6], const double spin[3], double dt,
                                     struct mpm_point_state *state)
{
    struct mpm_update_result r;
    int rc = mpm_stress_update(m, NULL, de, spin, dt, V0, V0, V0, state, &r);
    CHECK(rc == 0, "mpm_stress_update returned %d", rc);
    return r;
}

/* ---- (1) the rate-dependent return is consistent with PTW at the plastic rate d/dt ---- */

static void run_consistency(double rate, double sigma_end, int *plastic_steps)
{
    struct mpm_material m = aluminium(0.0);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    double dt = STEP / rate, de[6], G = mpm_mts_shear_modulus(&m, 298.0), Tm = mpm_scg_melt_temperature(&m, 2700.0);
    isochoric(STEP, 0.0, de);
    struct mpm_update_result r = {0};
    for (int n = 0; n < 5000; n++) {
        double s_old[6], trial[6];
        deviator(state.stress, s_old);
        for (int k = 0; k < 6; k++)
            trial[k] = s_old[k] + 2.0 * G * de[k];
        double sigma_trial = sqrt(1.5 * contract(trial, trial));
        r = step(&m, de, no_spin, dt, &state);
        double vm = von_mises_of_stress(state.stress);
        if (r.eps_p_increment == 0.0)
            continue;
        (*plastic_steps)++;
        double ptw =
            mpm_ptw_flow_stress(&m, state.eps_p, fmax(r.eps_p_increment / dt, RATE_FLOOR), 298.0, Tm, state.rho, G);
        CHECK_CLOSE(vm, ptw, 1e-8, 0.0, "von Mises = PTW(eps_p, d/dt) after the return");
        CHECK_CLOSE(state.yield_stress, ptw, 1e-12, 0.0, "stored yield stress");
        CHECK_CLOSE(vm + 3.0 * G * r.eps_p_increment, sigma_trial, 1e-9, 0.0, "consistency sigma* - 3G d");
        CHECK_CLOSE(r.von_mises, vm, 1e-12, 0.0, "result von Mises");
    }
    CHECK(state.T == 298.0, "taylor_quinney 0 keeps T: %g", state.T);
    CHECK_CLOSE(r.eps_p_increment / dt, rate, 0.05, 0.0, "steady plastic rate approaches the loading rate");
    CHECK_CLOSE(von_mises_of_stress(state.stress), sigma_end, 0.01, 0.0, "flow stress at the end");
}

static void test_return_consistency(void)
{
    int quasi = 0, shock = 0;
    /* 1e3 /s: quasi-static branch, eps_p 0.048 at the end: 122.65 MPa (table: 123.1 MPa at 0.05); 1e8 /s:
     * shock branch, 661.9 MPa at any strain (ptw_aluminium.csv). */
    run_consistency(1e3, 122.65e6, &quasi);
    run_consistency(1e8, 661.9e6, &shock);
    CHECK(quasi > 4000 && shock > 4000, "plastic steps: %d, %d", quasi, shock);
}

/* One step far beyond yield (sigma* about 2 GPa): f(d) = sigma* - 3 G d - sigma_y(d/dt) = 0. */
static void test_single_large_step(void)
{
    struct mpm_material m = aluminium(0.0);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    double G = mpm_mts_shear_modulus(&m, 298.0), size = 2e9 / (3.0 * G), dt = 1e-9, de[6];
    isochoric(size, 0.0, de);
    struct mpm_update_result r = step(&m, de, no_spin, dt, &state);
    double vm = von_mises_of_stress(state.stress);
    CHECK_CLOSE(vm + 3.0 * G * r.eps_p_increment, 2e9, 1e-9, 0.0, "consistency of one large step");
    CHECK_CLOSE(vm, mpm_ptw_flow_stress(&m, r.eps_p_increment, r.eps_p_increment / dt, 298.0, 933.0, 2700.0, G), 1e-10,
                0.0, "sigma_y at the solved rate");
    CHECK(r.eps_p_increment > 0.5 * size && r.eps_p_increment < size, "d = %g of %g", r.eps_p_increment, size);
    /* d/dt about 2e7 /s: between the table's 1e6 /s (259.4 MPa) and 1e8 /s (661.9 MPa) values */
    CHECK(r.eps_p_increment / dt > 1e7 && r.eps_p_increment / dt < 3e7, "rate %g", r.eps_p_increment / dt);
    CHECK(vm > 259.4e6 && vm < 661.9e6, "flow stress at about 2e7 /s: %g", vm);
}

/* ---- (2) elastic loading 3 G eps and unloading slope 2 G ---- */

static void test_elastic_slopes(void)
{
    struct mpm_material m = aluminium(0.0);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    double G = mpm_mts_shear_modulus(&m, 298.0), dt = STEP / 1e3, de[6], back[6];
    isochoric(STEP, 0.0, de);
    isochoric(-STEP, 0.0, back);
    int elastic = 0;
    for (int n = 1; n <= 2000; n++) {
        struct mpm_update_result r = step(&m, de, no_spin, dt, &state);
        if (r.eps_p_increment > 0.0)
            continue;
        elastic++;
        CHECK(state.eps_p == 0.0, "no plastic strain before yield");
        CHECK_CLOSE(von_mises_of_stress(state.stress), 3.0 * G * n * STEP, 1e-9, 0.0, "sigma_vm = 3 G eps");
    }
    /* yield at 102.34 MPa (table, floor rate): 102.34e6 / (3 G STEP) = 133.5 steps */
    CHECK(elastic == 133, "elastic steps: %d", elastic);
    double eps_p = state.eps_p;
    for (int n = 0; n < 10; n++) {
        double before = state.stress[0] + state.pressure;
        struct mpm_update_result r = step(&m, back, no_spin, dt, &state);
        double after = state.stress[0] + state.pressure;
        CHECK(r.eps_p_increment == 0.0, "elastic unloading");
        CHECK_CLOSE(after - before, -2.0 * G * STEP, 1e-9, 0.0, "unloading slope 2 G in s_xx");
        CHECK_CLOSE(state.stress[1] - state.stress[2], 0.0, 0.0, 1e-6, "s_yy = s_zz");
    }
    CHECK(state.eps_p == eps_p, "eps_p unchanged while unloading");
}

/* ---- (3), (4) plastic work, EOS energy balance, heating ---- */

struct work_totals {
    double plastic, plastic_rectangle, deviatoric, increments, elastic_end, T_end, energy_end;
};

/* 3000 isochoric steps with an xy shear part at 1e6 /s; totals from the test's own bookkeeping. */
static struct work_totals run_work(double taylor_quinney)
{
    struct mpm_material m = aluminium(taylor_quinney);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    double dt = STEP / 1e6, de[6];
    isochoric(STEP, 0.3 * STEP, de);
    struct work_totals w = {0};
    for (int n = 0; n < 3000; n++) {
        double s_old[6], s_new[6], s_half[6];
        deviator(state.stress, s_old);
        struct mpm_update_result r = step(&m, de, no_spin, dt, &state);
        deviator(state.stress, s_new);
        for (int k = 0; k < 6; k++)
            s_half[k] = 0.5 * (s_old[k] + s_new[k]);
        w.deviatoric += V0 * contract(s_half, de);
        w.plastic += r.plastic_work;
        w.plastic_rectangle += V0 * state.yield_stress * r.eps_p_increment;
        w.increments += r.energy_increment;
    }
    double s[6];
    deviator(state.stress, s);
    w.elastic_end = V0 * contract(s, s) / (4.0 * mpm_mts_shear_modulus(&m, state.T));
    w.T_end = state.T;
    w.energy_end = state.energy;
    CHECK(state.eps_p > 0.02, "plastic strain reached: %g", state.eps_p);
    return w;
}

static void test_work_and_energy(void)
{
    struct work_totals w = run_work(0.0);
    CHECK_CLOSE(w.plastic, w.plastic_rectangle, 1e-12, 0.0, "plastic work = sum V sigma_y d eps_p");
    CHECK_CLOSE(w.energy_end, w.deviatoric, 1e-12, 0.0, "EOS energy = deviatoric work (no volume change)");
    CHECK_CLOSE(w.increments, w.deviatoric, 1e-12, 0.0, "sum of energy increments");
    /* deviatoric work = stored elastic energy + plastic dissipation, up to the midpoint rule */
    CHECK_CLOSE(w.deviatoric, w.plastic + w.elastic_end, 1e-3, 0.0, "work split elastic + plastic");
    CHECK(w.T_end == 298.0, "T fixed at taylor_quinney 0");
}

static void test_heating(void)
{
    struct work_totals w = run_work(0.9);
    double rise = 0.9 * w.plastic / (V0 * 2700.0 * 900.0);
    CHECK_CLOSE(w.T_end - 298.0, rise, 1e-9, 0.0, "Eq. 3.44: dT = chi W_p / (m c_p)");
    CHECK(rise > 1.0 && rise < 10.0, "a few kelvin: %g", rise);
    CHECK_CLOSE(w.energy_end, w.deviatoric, 1e-12, 0.0, "EOS energy = deviatoric work with heating");
}

/* ---- (5) pure spin ---- */

/* A point with s = (50, -20, -30, 0, 0, 10) MPa and p = 40 MPa, energy consistent with the EOS at rho0. */
static void stressed_point(const struct mpm_material *m, struct mpm_point_state *state)
{
    mpm_point_state_init(m, state);
    double s[6] = {50e6, -20e6, -30e6, 0.0, 0.0, 10e6}, p = 40e6;
    for (int k = 0; k < 6; k++)
        state->stress[k] = s[k] - (k < 3 ? p : 0.0);
    state->pressure = p;
    state->energy = p / m->eos_gamma0 * V0;
}

static void test_pure_rotation(void)
{
    struct mpm_material m = aluminium(0.9);
    struct mpm_point_state state;
    stressed_point(&m, &state);
    double vm0 = von_mises_of_stress(state.stress), zero[6] = {0.0};
    /* rigid rotation about z at omega: W_xy = -omega; 100 steps of 1e-5 rad */
    double spin[3] = {0.0, 0.0, -1e-5}, theta = 1e-3;
    for (int n = 0; n < 100; n++)
        step(&m, zero, spin, 1e-9, &state);
    CHECK_CLOSE(von_mises_of_stress(state.stress), vm0, 1e-6, 0.0, "von Mises kept under spin");
    CHECK_CLOSE(state.pressure, 40e6, 1e-6, 0.0, "pressure kept under spin");
    /* R sigma R^T: sigma_xy = c cos(2 theta) + (a - b)/2 sin(2 theta), a - b = 70 MPa */
    double expected_xy = 10e6 * cos(2.0 * theta) + 35e6 * sin(2.0 * theta);
    CHECK_CLOSE(state.stress[5], expected_xy, 0.0, 1e-6 * vm0, "sigma_xy rotated");
    CHECK(state.eps_p == 0.0, "no plastic flow under spin");
    /* any axis */
    double spin3[3] = {2e-5, -1e-5, 3e-5};
    for (int n = 0; n < 100; n++)
        step(&m, zero, spin3, 1e-9, &state);
    CHECK_CLOSE(von_mises_of_stress(state.stress), vm0, 1e-6, 0.0, "von Mises kept, general spin");
    CHECK_CLOSE(-(state.stress[0] + state.stress[1] + state.stress[2]) / 3.0, 40e6, 1e-6, 0.0, "mean stress");
}

/* ---- (6) melting ---- */

static void test_melting(void)
{
    struct mpm_material m = aluminium(0.9);
    struct mpm_point_state state;
    stressed_point(&m, &state);
    state.T = 1000.0; /* above Tm(rho0) = 933 K */
    state.eps_p = 0.3;
    double de[6], s[6];
    isochoric(1e-3, 1e-3, de);
    struct mpm_update_result r = step(&m, de, no_spin, 1e-9, &state);
    deviator(state.stress, s);
    for (int k = 0; k < 6; k++)
        CHECK(fabs(s[k]) <= 1e-8 * fabs(state.pressure) && isfinite(state.stress[k]), "s[%d] = %g", k, s[k]);
    CHECK(state.melted == 1.0 && state.yield_stress == 0.0, "melted, no yield");
    CHECK(state.eps_p == 0.3 && r.eps_p_increment == 0.0 && r.plastic_work == 0.0, "eps_p unchanged");
    CHECK(state.T == 1000.0 && isfinite(state.pressure) && isfinite(state.energy), "finite, T kept");
    /* compressed to eta = 1.1, Tm = 1257.9 K > 1000 K: solid again, shear stress 2 G de_xy */
    double V1 = V0 / 1.1, squeeze[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 1e-4};
    int rc = mpm_stress_update(&m, NULL, squeeze, no_spin, 1e-9, V0, V0, V1, &state, &r);
    CHECK(rc == 0 && state.melted == 0.0, "solid under compression: rc %d melted %g", rc, state.melted);
    CHECK_CLOSE(state.stress[5], 2.0 * mpm_mts_shear_modulus(&m, 1000.0) * 1e-4, 1e-12, 0.0, "shear reappears");
    CHECK_CLOSE(state.rho, 2970.0, 1e-12, 0.0, "rho_new = rho0 V0 / V");
}

/* ---- (7) the EOS path of a hydrostatic compression ---- */

/* dE/dv = -(A(v) + Gamma0 E), v = V/V0: the isentrope of the linear EOS, by RK4 with 20000 steps. */
static double isentrope_energy(const struct mpm_material *m, double v_end)
{
    int steps = 20000;
    double h = (v_end - 1.0) / steps, E = 0.0, v = 1.0;
    for (int n = 0; n < steps; n++) {
        double k1 = -mpm_eos_pressure(m, m->density / v, E);
        double k2 = -mpm_eos_pressure(m, m->density / (v + 0.5 * h), E + 0.5 * h * k1);
        double k3 = -mpm_eos_pressure(m, m->density / (v + 0.5 * h), E + 0.5 * h * k2);
        double k4 = -mpm_eos_pressure(m, m->density / (v + h), E + h * k3);
        E += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0;
        v += h;
    }
    return E;
}

/* Compress hydrostatically to V = 0.9 V0 in `steps` steps (elastic strength); returns the final energy. */
static double compress(const struct mpm_material *m, int steps, double *pressure_end)
{
    struct mpm_point_state state;
    mpm_point_state_init(m, &state);
    double work = 0.0, dt = 1e-10;
    for (int n = 0; n < steps; n++) {
        double v_old = V0 * (1.0 - 0.1 * n / steps), v_new = V0 * (1.0 - 0.1 * (n + 1) / steps);
        double x = log(v_new / v_old) / 3.0, de[6] = {x, x, x, 0.0, 0.0, 0.0}, p_old = state.pressure;
        struct mpm_update_result r;
        int rc = mpm_stress_update(m, NULL, de, no_spin, dt, V0, v_old, v_new, &state, &r);
        CHECK(rc == 0, "rc %d", rc);
        work -= 0.5 * (p_old + state.pressure) * (v_new - v_old);
        CHECK_CLOSE(state.pressure, mpm_eos_pressure(m, state.rho, state.energy / V0), 1e-12, 0.0, "p = A + B E");
    }
    CHECK_CLOSE(state.energy, work, 1e-10, 0.0, "energy = trapezoid work -sum p^{n+1/2} dV");
    CHECK(von_mises_of_stress(state.stress) <= 1e-9 * state.pressure, "no shear in hydrostatic compression");
    *pressure_end = state.pressure;
    return state.energy;
}

static void test_compression_energy(void)
{
    struct mpm_material m = aluminium(0.9);
    m.strength = MPM_STRENGTH_ELASTIC;
    double p1, p2;
    double e1 = compress(&m, 1000, &p1), e2 = compress(&m, 2000, &p2);
    double reference = isentrope_energy(&m, 0.9) * V0;
    CHECK_CLOSE(e2, e1, 1e-6, 0.0, "energy converged in the step size");
    CHECK_CLOSE(e1, reference, 1e-6, 0.0, "energy on the isentrope (RK4)");
    CHECK_CLOSE(p1, mpm_eos_pressure(&m, 3000.0, reference / V0), 1e-6, 0.0, "pressure on the isentrope");
    /* A(mu = 1/9) = 9.028 GPa plus the thermal part Gamma0 E, E = 0.450 GJ/m3 on the isentrope: p = 9.915 GPa */
    CHECK(p1 > 9.5e9 && p1 < 10.0e9, "p(V = 0.9 V0) = %g", p1);
}

/* ---- (8) bulk viscosity ---- */

static void test_bulk_viscosity(void)
{
    struct mpm_material m = aluminium(0.9);
    struct mpm_bulk_viscosity off = {0.0, 0.0, 1e-6}, on = {1.5, 0.06, 1e-6};
    double c = mpm_material_wave_speed(&m);
    CHECK_CLOSE(c, sqrt((74.13552e9 + 4.0 / 3.0 * 25.54694907e9) / 2700.0), 1e-9, 0.0, "wave speed");
    CHECK_CLOSE(c, 6330.4, 1e-4, 0.0, "wave speed about 6330 m/s");
    double x = -1e-4, dt = 1e-10, de[6] = {x, x, x, 0.0, 0.0, 0.0}, v1 = V0 * exp(3.0 * x);
    struct mpm_point_state a, b, n;
    struct mpm_update_result ra, rb, rn;
    mpm_point_state_init(&m, &a);
    b = a, n = a;
    CHECK(mpm_stress_update(&m, &off, de, no_spin, dt, V0, V0, v1, &a, &ra) == 0, "off");
    CHECK(mpm_stress_update(&m, &on, de, no_spin, dt, V0, V0, v1, &b, &rb) == 0, "on");
    CHECK(mpm_stress_update(&m, NULL, de, no_spin, dt, V0, V0, v1, &n, &rn) == 0, "NULL");
    CHECK(a.viscosity == 0.0 && n.viscosity == 0.0, "viscosity off: %g %g", a.viscosity, n.viscosity);
    double rate = 3.0 * x / dt, rho = 2700.0 * V0 / v1;
    double q = rho * 1e-12 * 1.5 * rate * rate - 0.06 * rho * 1e-6 * c * rate;
    CHECK(b.viscosity > 0.0, "q > 0 in compression");
    CHECK_CLOSE(b.viscosity, q, 1e-12, 0.0, "q = rho l^2 c_q epsv_dot^2 - c_l rho l c epsv_dot");
    CHECK_CLOSE(rb.energy_increment - ra.energy_increment, -q * (v1 - V0), 1e-9, 0.0, "work of q: -q dV");
    CHECK(b.stress[0] == a.stress[0] && b.pressure == a.pressure, "q not in the stress");
    double grow[6] = {-x, -x, -x, 0.0, 0.0, 0.0};
    CHECK(mpm_stress_update(&m, &on, grow, no_spin, dt, V0, v1, V0, &b, &rb) == 0, "expansion");
    CHECK(b.viscosity == 0.0, "q = 0 in expansion: %g", b.viscosity);
}

/* ---- initial state ---- */

/* ---- (11) a block of returns in vector lanes gives each point the bits of its update alone ---- */

#define LANE_POINTS 40

/* Point k of the block: a spread of strains, rates, temperatures and histories (elastic, plastic from rest,
 * plastic with last step's increment as the first guess, hot). */
static void lane_point(const struct mpm_material *m, int k, double de[6], double *dt, struct mpm_point_state *state)
{
    mpm_point_state_init(m, state);
    state->eps_p = 0.02 * (k % 7);
    state->T = m->T_initial + 40.0 * (k % 5);
    state->plastic_increment = k % 3 == 0 ? 0.0 : 1e-4 * (1 + k % 4);
    state->yield_stress = k % 3 == 0 ? state->yield_stress : 2.0e8 + 1.0e7 * (k % 6);
    *dt = 1e-11 * (1 + k % 3);
    isochoric(k % 8 == 0 ? 1e-5 : 2e-3 * (1 + k % 5), 1e-4 * (k % 4), de);
}

/* The three phases over the block, in the given order of the points, against each point alone. */
static void check_block_order(const struct mpm_material *m, const struct mpm_material_constants *c, int reversed)
{
    struct mpm_point_state alone[LANE_POINTS], block[LANE_POINTS];
    struct mpm_stress_work work[LANE_POINTS];
    struct mpm_return *returns[LANE_POINTS];
    double de[LANE_POINTS][6], dt[LANE_POINTS];
    int n = 0, plastic = 0;
    for (int k = 0; k < LANE_POINTS; k++) {
        struct mpm_update_result r;
        lane_point(m, k, de[k], &dt[k], &alone[k]);
        block[k] = alone[k];
        mpm_stress_update_prepared(m, c, NULL, de[k], no_spin, dt[k], log(dt[k]), V0, V0, V0, &alone[k], &r);
    }
    for (int j = 0; j < LANE_POINTS; j++) {
        int k = reversed ? LANE_POINTS - 1 - j : j;
        double G;
        mpm_shear_moduli(m, c, 1, &block[k].T, &G);
        if (mpm_stress_begin(m, c, de[k], no_spin, G, dt[k], log(dt[k]), V0, V0, &block[k], &work[k]))
            returns[n++] = &work[k].ret;
    }
    mpm_stress_returns(m, returns, n);
    int differ = 0;
    for (int k = 0; k < LANE_POINTS; k++) {
        struct mpm_update_result r;
        mpm_stress_finish(m, c, NULL, dt[k], V0, V0, V0, &work[k], &block[k], &r);
        differ += memcmp(&alone[k], &block[k], sizeof alone[k]) != 0;
        plastic += r.eps_p_increment > 0.0;
    }
    printf("  %d returns, %d plastic of %d points\n", n, plastic, LANE_POINTS);
    CHECK(n >= LANE_POINTS / 2 && plastic >= LANE_POINTS / 3, "%d returns, %d plastic of %d", n, plastic, LANE_POINTS);
    CHECK(differ == 0, "%d of %d points differ from their update alone (order %s)", differ, LANE_POINTS,
          reversed ? "reversed" : "forward");
}

static void test_block_of_returns(void)
{
    struct mpm_material m = aluminium(0.9);
    struct mpm_material_constants c;
    mpm_material_prepare(&m, &c);
    check_block_order(&m, &c, 0);
    check_block_order(&m, &c, 1);
}

static void test_initial_state(void)
{
    struct mpm_material m = aluminium(0.9);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    CHECK(state.T == 298.0 && state.rho == 2700.0 && state.eps_p == 0.0 && state.energy == 0.0, "init");
    CHECK(state.melted == 0.0 && state.pressure == 0.0 && state.stress[0] == 0.0, "init stress");
    /* ptw_aluminium.csv: 298 K, 1e-3 /s, eps_p 0 */
    CHECK_CLOSE(state.yield_stress, 102341078.0, 1e-6, 0.0, "initial yield stress at the rate floor");
}

int main(void)
{
    RUN(test_initial_state);
    RUN(test_return_consistency);
    RUN(test_single_large_step);
    RUN(test_elastic_slopes);
    RUN(test_work_and_energy);
    RUN(test_heating);
    RUN(test_pure_rotation);
    RUN(test_melting);
    RUN(test_compression_energy);
    RUN(test_bulk_viscosity);
    RUN(test_block_of_returns);
    return check_finish();
}
