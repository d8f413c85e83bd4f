/* The carrier gas (dem/gas.c): Haider-Levenspiel drag against the reference table and an independent
 * library value, the jet profile against its table, the continuity of the planar jet, the centreline
 * decay and the potential core, drag forces, response times, and terminal velocities. */
/* A white-box test: includes the module-private header dem/gas.h (only tests may; tests/test_symbols.sh). */
#include "dem/gas.h"
#include "tests/check.h"
#include "tests/verification_csv.h"

#include <string.h>

#define PI 3.14159265358979323846

#define TABLE_RTOL 1e-8

/* ---- drag coefficient ---- */

static void check_drag_row(const struct csv_row *row)
{
    CHECK_CLOSE(dem_drag_coefficient_haider_levenspiel(csv_number(row, 0)), csv_number(row, 1), TABLE_RTOL, 0.0,
                "Haider-Levenspiel C_D (Eq. 25)");
}

static void test_drag_coefficient(void)
{
    int rows = csv_for_each("drag_haider_levenspiel.csv", check_drag_row);
    CHECK(rows >= 10, "drag_haider_levenspiel.csv rows: %d", rows);
    /* CalebBell/fluids, Haider_Levenspiel(200.) (docs/references.md). */
    CHECK_CLOSE(dem_drag_coefficient_haider_levenspiel(200.0), 0.7959551680251666, 1e-13, 0.0, "C_D(200)");
}

/* ---- jet profile ---- */

static struct dem_gas_field table_jet(void)
{
    struct dem_gas_field gas = {0};
    gas.model = DEM_JET_BICKLEY;
    gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    gas.c1 = 30.0;
    gas.c3 = 20.0;
    gas.c2 = gas.c1 / (3.0 * gas.c3);
    gas.virtual_origin = 0.0;
    gas.core_length = 0.0;
    gas.density = 1.2;
    gas.kinematic_viscosity = 1.5e-5;
    return gas;
}

static void check_jet_row(const struct csv_row *row)
{
    struct dem_gas_field gas = table_jet();
    double x = csv_number(row, 0), r = csv_number(row, 1), axial = csv_number(row, 2), radial = csv_number(row, 3);
    double atol = radial == 0.0 ? 1e-12 : 0.0;
    double on_x_axis[3] = {r, 0.0, x}, u[3];
    dem_gas_velocity(&gas, on_x_axis, u);
    CHECK_CLOSE(u[2], axial, TABLE_RTOL, 0.0, "axial velocity (Eq. 26)");
    CHECK_CLOSE(u[0], radial, TABLE_RTOL, atol, "radial velocity (Eq. 27, erratum)");
    CHECK(u[1] == 0.0, "no azimuthal velocity");
    /* Same radius at azimuth 120 degrees: the radial part points along (x, y)/r. */
    double c = cos(2.0 * PI / 3.0), s = sin(2.0 * PI / 3.0);
    double rotated[3] = {r * c, r * s, x};
    dem_gas_velocity(&gas, rotated, u);
    CHECK_CLOSE(u[2], axial, TABLE_RTOL, 0.0, "axial velocity, rotated");
    CHECK_CLOSE(u[0], radial * c, TABLE_RTOL, atol, "radial velocity x, rotated");
    CHECK_CLOSE(u[1], radial * s, TABLE_RTOL, atol, "radial velocity y, rotated");
}

static void test_jet_table(void)
{
    int rows = csv_for_each("jet_profile.csv", check_jet_row);
    CHECK(rows >= 25, "jet_profile.csv rows: %d", rows);
}

/* du/dx + dv/dy of the planar jet (u streamwise at z = x, v cross-stream at position x = y), by central
 * differences; du/dx is returned for scale. */
static double planar_divergence(const struct dem_gas_field *gas, double x, double y, double *du_dx)
{
    double hx = 1e-5 * x, hy = 1e-5 * cbrt(x) * cbrt(x) / gas->c3;
    double ahead[3] = {y, 0.0, x + hx}, behind[3] = {y, 0.0, x - hx};
    double outer[3] = {y + hy, 0.0, x}, inner[3] = {y - hy, 0.0, x};
    double ua[3], ub[3], uo[3], ui[3];
    dem_gas_velocity(gas, ahead, ua);
    dem_gas_velocity(gas, behind, ub);
    dem_gas_velocity(gas, outer, uo);
    dem_gas_velocity(gas, inner, ui);
    *du_dx = (ua[2] - ub[2]) / (2.0 * hx);
    return *du_dx + (uo[0] - ui[0]) / (2.0 * hy);
}

static const double divergence_x[] = {0.02, 0.1, 0.25};
static const double divergence_y[] = {0.003, 0.008, 0.015};

/* With C2 = C1/(3 C3) the planar form is divergence-free (erratum of Eq. 27, docs/physics.md). */
static void test_jet_divergence_free(void)
{
    struct dem_gas_field gas = table_jet();
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double du_dx, div = planar_divergence(&gas, divergence_x[i], divergence_y[j], &du_dx);
            CHECK(fabs(div) < 1e-6 * fabs(du_dx), "x %g y %g: divergence %g against du/dx %g", divergence_x[i],
                  divergence_y[j], div, du_dx);
        }
}

/* ... and clearly not with another C2: the check above can fail. */
static void test_jet_divergence_detects_wrong_c2(void)
{
    struct dem_gas_field gas = table_jet();
    gas.c2 = 2.0 * gas.c1 / (3.0 * gas.c3);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double du_dx, div = planar_divergence(&gas, divergence_x[i], divergence_y[j], &du_dx);
            CHECK(fabs(div) > 0.05 * fabs(du_dx), "x %g y %g: wrong C2 should leave a divergence (%g vs %g)",
                  divergence_x[i], divergence_y[j], div, du_dx);
        }
}

/* Centreline u(0) = C1 x^(-1/3), x = z + virtual_origin. */
static void test_jet_centreline_decay(void)
{
    struct dem_gas_field gas = table_jet();
    gas.virtual_origin = 0.02;
    const double z[] = {0.0, 0.01, 0.05, 0.3, 2.0};
    for (int i = 0; i < 5; i++) {
        double pos[3] = {0.0, 0.0, z[i]}, u[3];
        dem_gas_velocity(&gas, pos, u);
        CHECK_CLOSE(u[2], 30.0 / cbrt(z[i] + 0.02), 1e-14, 0.0, "centreline C1 x^(-1/3)");
        CHECK(u[0] == 0.0 && u[1] == 0.0, "no radial velocity on the axis");
    }
}

/* Inside the potential core and behind the virtual origin: the profile of z = core_length, no radial part. */
static void test_jet_potential_core(void)
{
    struct dem_gas_field gas = table_jet();
    gas.virtual_origin = 0.02;
    gas.core_length = 0.03;
    double x_core = 0.05, r = 0.004;
    double expected = 30.0 / cbrt(x_core) / pow(cosh(20.0 * r / pow(x_core, 2.0 / 3.0)), 2.0);
    const double z[] = {0.01, -0.01, -0.5};
    for (int i = 0; i < 3; i++) {
        double pos[3] = {0.0, r, z[i]}, u[3];
        dem_gas_velocity(&gas, pos, u);
        CHECK_CLOSE(u[2], expected, 1e-12, 0.0, "core: axial profile of z = core_length");
        CHECK(u[0] == 0.0 && u[1] == 0.0, "core: no entrainment");
    }
    double downstream[3] = {0.0, r, 0.031}, u[3];
    dem_gas_velocity(&gas, downstream, u);
    CHECK(u[1] != 0.0, "past the core the jet entrains");
}

/* Far from the axis cosh(xi) overflows; sech^2 must go to 0 and tanh to 1, without NaN. */
static void test_jet_far_field(void)
{
    struct dem_gas_field gas = table_jet();
    double pos[3] = {30.0, 0.0, 0.01}, u[3];
    dem_gas_velocity(&gas, pos, u);
    CHECK(u[2] == 0.0, "far field axial velocity %g", u[2]);
    CHECK_CLOSE(u[0], -0.5 / pow(0.01, 2.0 / 3.0), 1e-14, 0.0, "far field entrainment -C2/x^(2/3)");
}

static void test_uniform_and_still_gas(void)
{
    struct dem_gas_field gas = table_jet();
    double pos[3] = {0.01, -0.02, 0.1}, u[3];
    gas.model = DEM_JET_UNIFORM;
    gas.uniform_velocity = 120.0;
    dem_gas_velocity(&gas, pos, u);
    CHECK(u[0] == 0.0 && u[1] == 0.0 && u[2] == 120.0, "uniform jet");
    gas.model = DEM_JET_NONE;
    dem_gas_velocity(&gas, pos, u);
    CHECK(u[0] == 0.0 && u[1] == 0.0 && u[2] == 0.0, "no gas: still");
    double v[3] = {3.0, 0.0, -5.0}, f[3] = {1.0, 1.0, 1.0};
    dem_gas_drag_force(&gas, 4e-5, v, u, f);
    CHECK(f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0, "no gas: no drag");
    CHECK(isinf(dem_gas_response_time(&gas, 8960.0, 4e-5, 1.0)), "no gas: infinite response time");
}

/* ---- drag force, Eq. (24) ---- */

static void test_drag_force(void)
{
    struct dem_gas_field gas = table_jet();
    double d = 4e-5, v[3] = {1.0, -2.0, 30.0}, u[3] = {0.0, 1.0, 50.0}, f[3];
    dem_gas_drag_force(&gas, d, v, u, f);
    double rel[3] = {u[0] - v[0], u[1] - v[1], u[2] - v[2]};
    double slip = sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]);
    double cd = dem_drag_coefficient_haider_levenspiel(d * slip / gas.kinematic_viscosity);
    for (int k = 0; k < 3; k++)
        CHECK_CLOSE(f[k], 0.5 * 1.2 * PI * d * d / 4.0 * cd * slip * rel[k], 1e-13, 0.0, "Eq. 24 component");
    gas.drag = DEM_DRAG_STOKES;
    dem_gas_drag_force(&gas, d, v, u, f);
    double mu = gas.density * gas.kinematic_viscosity;
    for (int k = 0; k < 3; k++)
        CHECK_CLOSE(f[k], 3.0 * PI * mu * d * rel[k], 1e-13, 0.0, "Stokes drag 3 pi mu d (u - v)");
    gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    dem_gas_drag_force(&gas, d, u, u, f);
    CHECK(f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0, "zero slip: zero force, no NaN");
}

/* ---- response time ---- */

/* |F| along a slip s, for the numerical derivative. */
static double drag_magnitude(const struct dem_gas_field *gas, double d, double s)
{
    double v[3] = {0.0, 0.0, 0.0}, u[3] = {0.0, 0.0, s}, f[3];
    dem_gas_drag_force(gas, d, v, u, f);
    return f[2];
}

static void test_response_time(void)
{
    struct dem_gas_field gas = table_jet();
    double d = 2e-5, rho = 2700.0, mu = gas.density * gas.kinematic_viscosity;
    double tau_stokes = rho * d * d / (18.0 * mu);
    gas.drag = DEM_DRAG_STOKES;
    CHECK_CLOSE(dem_gas_response_time(&gas, rho, d, 0.0), tau_stokes, 1e-14, 0.0, "Stokes tau at zero slip");
    CHECK_CLOSE(dem_gas_response_time(&gas, rho, d, 40.0), tau_stokes, 1e-14, 0.0, "Stokes tau at any slip");
    gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    CHECK_CLOSE(dem_gas_response_time(&gas, rho, d, 0.0), tau_stokes, 1e-14, 0.0, "HL tau: Stokes limit at zero slip");
    double mass = rho * PI * d * d * d / 6.0;
    const double slips[] = {0.01, 1.0, 30.0, 300.0, 3000.0};
    for (int i = 0; i < 5; i++) {
        double h = 1e-5 * slips[i];
        double slope = (drag_magnitude(&gas, d, slips[i] + h) - drag_magnitude(&gas, d, slips[i] - h)) / (2.0 * h);
        CHECK_CLOSE(dem_gas_response_time(&gas, rho, d, slips[i]), mass / slope, 1e-7, 0.0, "HL tau = m / (dF/ds)");
    }
    CHECK(dem_gas_response_time(&gas, rho, d, 300.0) < tau_stokes, "HL drag stiffens with slip");
}

/* ---- terminal velocity of a 40 um Cu sphere in air (docs/references.md) ---- */

static double terminal_velocity(const struct dem_gas_field *gas, double d, double rho_p)
{
    double weight = (rho_p - gas->density) * PI * d * d * d / 6.0 * 9.81; /* m g (rho_p - rho_f)/rho_p */
    double lo = 0.0, hi = 10.0;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (drag_magnitude(gas, d, mid) > weight)
            hi = mid;
        else
            lo = mid;
    }
    return 0.5 * (lo + hi);
}

static void test_terminal_velocity(void)
{
    struct dem_gas_field gas = {0};
    gas.model = DEM_JET_UNIFORM;
    gas.density = 1.2;
    gas.kinematic_viscosity = 1.5e-5;
    double d = 4e-5, rho_p = 8960.0;
    gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    CHECK_CLOSE(terminal_velocity(&gas, d, rho_p), 0.368, 0.0, 5e-4, "HL terminal velocity");
    gas.drag = DEM_DRAG_STOKES;
    double stokes = terminal_velocity(&gas, d, rho_p);
    CHECK_CLOSE(stokes, 0.434, 0.0, 5e-4, "Stokes terminal velocity");
    CHECK_CLOSE(stokes, (rho_p - 1.2) * 9.81 * d * d / (18.0 * 1.8e-5), 1e-12, 0.0, "Stokes law");
}

int main(void)
{
    RUN(test_drag_coefficient);
    RUN(test_jet_table);
    RUN(test_jet_divergence_free);
    RUN(test_jet_divergence_detects_wrong_c2);
    RUN(test_jet_centreline_decay);
    RUN(test_jet_potential_core);
    RUN(test_jet_far_field);
    RUN(test_uniform_and_still_gas);
    RUN(test_drag_force);
    RUN(test_response_time);
    RUN(test_terminal_velocity);
    return check_finish();
}
