/* The mpm material models (mpm/ptw.c, mpm/melt.c, mpm/eos.c): the PTW flow stress, MTS shear modulus and
 * xi_dot against ptw_aluminium.csv, the SCG melt law against scg_melt_aluminium.csv, and the linear-in-energy
 * Mie-Grueneisen EOS against hand values and its continuity at mu = 0. */
#include <string.h>

/* A white-box test: includes the module-private header mpm/material.h (only tests may; tests/test_symbols.sh). */
#include "mpm/material.h"
#include "tests/check.h"
#include "tests/verification_csv.h"

#define PTW_RTOL  1e-6
#define MELT_RTOL 1e-9
#define TABLE_TM  933.0 /* the PTW table holds the melt temperature at 933 K */
#define TABLE_RHO 2700.0

/* Al with the constants of the ptw_aluminium.csv header (Tang Table 2.1, atomic mass in kg) and the EOS/melt
 * constants of docs/references.md (Mie-Grüneisen, SCG) and scg_melt_aluminium.csv. */
static struct mpm_material aluminium(void)
{
    struct mpm_material m = {0};
    m.strength = MPM_STRENGTH_PTW;
    m.density = 2700.0;
    m.ptw_theta = 0.01156, m.ptw_p = 3.0, m.ptw_s0 = 0.01489, m.ptw_sinf = 0.002819, m.ptw_kappa = 1.3;
    m.ptw_gamma = 2.04e-5, m.ptw_y0 = 0.0115, m.ptw_yinf = 0.002003, m.ptw_y1 = 0.0168, m.ptw_y2 = 0.2339;
    m.ptw_beta = 0.2034;
    m.atomic_mass = 4.48039e-26;
    m.rate_floor = 1e-3;
    m.G0 = 28.8e9, m.D = 3.44e9, m.T0 = 215.0;
    m.eos_c0 = 5240.0, m.eos_s = 1.4, m.eos_gamma0 = 1.97;
    m.melt_T0 = 933.0, m.melt_a = 1.5;
    m.specific_heat = 900.0, m.taylor_quinney = 0.9, m.T_initial = 298.0;
    m.bulk_modulus = m.density * m.eos_c0 * m.eos_c0;
    return m;
}

/* ---- (a) PTW table ---- */

static int ptw_rows_checked;

static void check_ptw_row(const struct csv_row *row)
{
    struct mpm_material m = aluminium();
    double T = csv_number(row, 0), rate = csv_number(row, 1), eps = csv_number(row, 2);
    double G = mpm_mts_shear_modulus(&m, T);
    CHECK_CLOSE(G, csv_number(row, 4), PTW_RTOL, 0.0, "MTS shear modulus (Eq. 2.6)");
    CHECK_CLOSE(mpm_ptw_xi_dot(&m, TABLE_RHO, G), csv_number(row, 5), PTW_RTOL, 0.0, "xi_dot (Eq. 2.8)");
    CHECK_CLOSE(mpm_ptw_flow_stress(&m, eps, rate, T, TABLE_TM, TABLE_RHO, G), csv_number(row, 3), PTW_RTOL, 0.0,
                "PTW flow stress (Eqs. 2.4-2.7)");
    ptw_rows_checked++;
}

static void test_ptw_table(void)
{
    int rows = csv_for_each("ptw_aluminium.csv", check_ptw_row);
    CHECK(rows >= 100 && rows == ptw_rows_checked, "ptw_aluminium.csv rows: %d", rows);
}

/* PTW edge cases: 0 at and above melt and for G = 0, finite near melt and at rate 0 (floor), p -> 0 form. */
static void test_ptw_limits(void)
{
    struct mpm_material m = aluminium();
    double G = mpm_mts_shear_modulus(&m, 298.0);
    CHECK(mpm_ptw_flow_stress(&m, 0.1, 1e6, 933.0, 933.0, 2700.0, G) == 0.0, "zero at T = Tm");
    CHECK(mpm_ptw_flow_stress(&m, 0.1, 1e6, 1500.0, 933.0, 2700.0, G) == 0.0, "zero above Tm");
    CHECK(mpm_ptw_flow_stress(&m, 0.1, 1e6, 298.0, 933.0, 2700.0, 0.0) == 0.0, "zero at G = 0");
    double near = mpm_ptw_flow_stress(&m, 0.1, 1e6, 932.999, 933.0, 2700.0, G);
    CHECK(isfinite(near) && near > 0.0, "finite just below melt: %g", near);
    CHECK_CLOSE(mpm_ptw_flow_stress(&m, 0.2, 0.0, 298.0, 933.0, 2700.0, G),
                mpm_ptw_flow_stress(&m, 0.2, m.rate_floor, 298.0, 933.0, 2700.0, G), 1e-15, 0.0, "rate 0 -> floor");
    /* p -> 0: tau = tau_s - (tau_s - tau_y) exp(-theta eps / (tau_s - tau_y)); quasi-static taus from the table */
    m.ptw_p = 0.0;
    double ts = 0.002819, ty = 0.002003, eps = 0.05;
    double expected = 2.0 * G * (ts - (ts - ty) * exp(-m.ptw_theta * eps / (ts - ty)));
    CHECK_CLOSE(mpm_ptw_flow_stress(&m, eps, 1.0, 298.0, 933.0, 2700.0, G), expected, 1e-9, 0.0, "p -> 0 limit");
    /* the p -> 0 form is the limit of the p > 0 form */
    struct mpm_material small = aluminium();
    small.ptw_p = 1e-7;
    CHECK_CLOSE(mpm_ptw_flow_stress(&small, eps, 1.0, 298.0, 933.0, 2700.0, G), expected, 1e-6, 0.0, "p = 1e-7");
}

/* ---- (b) SCG melt ---- */

static void check_melt_row(const struct csv_row *row)
{
    struct mpm_material m = aluminium();
    double eta = csv_number(row, 0);
    CHECK_CLOSE(mpm_scg_melt_temperature(&m, eta * m.density), csv_number(row, 1), MELT_RTOL, 0.0,
                "SCG melt temperature (Eq. 2.9, erratum)");
}

static void test_melt_table(void)
{
    int rows = csv_for_each("scg_melt_aluminium.csv", check_melt_row);
    CHECK(rows >= 6, "scg_melt_aluminium.csv rows: %d", rows);
}

/* ---- (c) EOS ---- */

static double eos_at_mu(const struct mpm_material *m, double mu, double E)
{
    return mpm_eos_pressure(m, (1.0 + mu) * m->density, E);
}

static void test_eos_reference_state(void)
{
    struct mpm_material m = aluminium();
    CHECK(mpm_eos_pressure(&m, m.density, 0.0) == 0.0, "p(rho0, 0) = 0: got %g", mpm_eos_pressure(&m, m.density, 0.0));
    double A, B;
    eos_coefficients(&m, 0.9 * m.density, &A, &B);
    CHECK_CLOSE(B, 1.97, 1e-15, 0.0, "B = Gamma0 in tension (continuity decision)");
    eos_coefficients(&m, 1.1 * m.density, &A, &B);
    CHECK_CLOSE(B, 1.97, 1e-15, 0.0, "B = Gamma0 in compression");
}

/* dp/dmu at mu = 0 from both sides equals rho0 c0^2 (= 2700 * 5240^2 = 74.13552 GPa), and p and dp/dmu are
 * continuous across mu = 0 with E = 0 and with E = 5e8 J/m3. */
static void test_eos_continuity(void)
{
    struct mpm_material m = aluminium();
    double c1 = 74.13552e9, h = 1e-7;
    double energies[2] = {0.0, 5e8};
    for (int i = 0; i < 2; i++) {
        double E = energies[i];
        double p0 = eos_at_mu(&m, 0.0, E);
        double right = (eos_at_mu(&m, h, E) - p0) / h, left = (p0 - eos_at_mu(&m, -h, E)) / h;
        CHECK_CLOSE(right, c1, 1e-5, 0.0, "dp/dmu, compression side");
        CHECK_CLOSE(left, c1, 1e-5, 0.0, "dp/dmu, tension side");
        CHECK_CLOSE(eos_at_mu(&m, 1e-12, E), eos_at_mu(&m, -1e-12, E), 0.0, 3e-12 * c1 + 1e-9 * fabs(p0),
                    "p continuous at mu = 0");
        CHECK_CLOSE(p0, 1.97 * E, 1e-14, 0.0, "p(mu = 0, E) = Gamma0 E");
    }
}

/* p at mu = 0.1, E = 0 by hand: C1 = 74.13552e9, C2 = 1.8 C1, C3 = 0.4 * 3.2 C1 = 1.28 C1,
 * A = C1 (0.1 + 0.018 + 0.00128) (1 - 1.97 * 0.1 / 2.2) = 74.13552e9 * 0.11928 * 0.91045454... */
static void test_eos_hand_value(void)
{
    struct mpm_material m = aluminium();
    double expected = 74.13552e9 * 0.11928 * (1.0 - 0.197 / 2.2);
    CHECK_CLOSE(eos_at_mu(&m, 0.1, 0.0), expected, 1e-12, 0.0, "p(mu = 0.1, E = 0)");
    CHECK_CLOSE(eos_at_mu(&m, 0.1, 0.0), 8.05104468e9, 1e-8, 0.0, "p(mu = 0.1) = 8.0510 GPa");
    CHECK_CLOSE(eos_at_mu(&m, 0.1, 1e8), expected + 1.97e8, 1e-12, 0.0, "p(mu = 0.1, E = 1e8)");
    CHECK_CLOSE(eos_at_mu(&m, -0.05, 2e8), -0.05 * 74.13552e9 + 1.97 * 2e8, 1e-12, 0.0, "p(mu = -0.05, E)");
}

/* ---- (d) MTS at room temperature ---- */

static double G298_table = NAN;

static void find_G298(const struct csv_row *row)
{
    if (csv_number(row, 0) == 298.0)
        G298_table = csv_number(row, 4);
}

static void test_mts_shear_modulus(void)
{
    struct mpm_material m = aluminium();
    csv_for_each("ptw_aluminium.csv", find_G298);
    CHECK_CLOSE(mpm_mts_shear_modulus(&m, 298.0), G298_table, PTW_RTOL, 0.0, "G(298 K) vs table");
    CHECK_CLOSE(mpm_mts_shear_modulus(&m, 298.0), 25.54694907e9, 1e-9, 0.0, "G(298 K) = 25.547 GPa");
    CHECK(mpm_mts_shear_modulus(&m, 0.0) == 28.8e9, "G(0 K) = G0");
    CHECK(mpm_mts_shear_modulus(&m, 1e7) == 0.0, "G clamped at 0 when hot");
    CHECK(mpm_mts_shear_modulus(&m, 500.0) < mpm_mts_shear_modulus(&m, 298.0), "G falls with T");
    /* the temperature the case check names for a too hot T_initial: 215 K / ln(1 + 3.44/28.8) = 1905.479 K */
    double T_max = mpm_mts_positive_below(&m);
    CHECK_CLOSE(T_max, 1905.4788459842, 1e-12, 0.0, "G > 0 below T0 / ln(1 + D/G0) (K)");
    CHECK(mpm_mts_shear_modulus(&m, T_max * (1.0 - 1e-9)) > 0.0 &&
              mpm_mts_shear_modulus(&m, T_max * (1.0 + 1e-9)) == 0.0,
          "G changes sign at that temperature");
    m.D = 0.0;
    CHECK(isinf(mpm_mts_positive_below(&m)), "with D = 0, G = G0 at every temperature");
}

/* A point's state at rest: every field set (a body's points all copy one such state, so a field left unset
 * would be the stack's garbage in all of them; the plastic increment is the next return's first guess). */
static void test_point_state_at_rest(void)
{
    struct mpm_material m = aluminium();
    struct mpm_point_state state;
    memset(&state, 0xff, sizeof state); /* NaN in every double */
    mpm_point_state_init(&m, &state);
    for (int k = 0; k < 6; k++)
        CHECK(state.stress[k] == 0.0, "stress[%d] = 0", k);
    CHECK(state.pressure == 0.0 && state.viscosity == 0.0 && state.eps_p == 0.0 && state.energy == 0.0,
          "pressure, viscosity, plastic strain and energy 0");
    CHECK(state.T == m.T_initial && state.rho == m.density && state.melted == 0.0, "T, rho at rest, not melted");
    CHECK(state.yield_stress > 0.0, "a PTW flow stress");
    CHECK(state.plastic_increment == 0.0, "no plastic increment yet: %g", state.plastic_increment);
}

int main(void)
{
    RUN(test_ptw_table);
    RUN(test_ptw_limits);
    RUN(test_melt_table);
    RUN(test_eos_reference_state);
    RUN(test_eos_continuity);
    RUN(test_eos_hand_value);
    RUN(test_mts_shear_modulus);
    RUN(test_point_state_at_rest);
    return check_finish();
}
