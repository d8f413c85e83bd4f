/* The de Laval nozzle (dem/nozzle.h): the area-Mach relation and the isentropic exit state against their closed
 * forms (Anderson, Modern Compressible Flow, Eqs. 3.28-3.31 and 5.20) to 1e-6, Henderson's drag coefficient in
 * its Stokes and free-molecular limits and at six points against an independent evaluation (as the particle's
 * rates at the throat), the CVODE particle exit state against a fine classical RK4 integration of
 * the same equations, and the normal shock inside the divergent part refused with its numbers. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "dem/dem.h"
#include "tests/check.h"
#include "tests/spray_fixture.h"

/* Area ratios of M = 4 and M = 0.5 at gamma = 1.4, and M = 2 at gamma = 5/3, in closed form:
 * A/A* = (1/M) [(2/(g+1)) (1 + (g-1)/2 M^2)]^((g+1)/(2(g-1))): (1/4) 3.5^3, 2 (0.875)^3, (1/2) 1.75^2. */
static void test_area_mach(void)
{
    CHECK_CLOSE(dem_nozzle_area_ratio(4.0, 1.4), 10.71875, 1e-14, 0, "A/A*(M = 4)");
    CHECK_CLOSE(dem_nozzle_mach(10.71875, 1.4, 1), 4.0, 1e-12, 0, "M(A/A* = 10.71875), supersonic");
    CHECK_CLOSE(dem_nozzle_mach(1.33984375, 1.4, 0), 0.5, 1e-12, 0, "M(A/A* = 1.33984375), subsonic");
    CHECK_CLOSE(dem_nozzle_mach(1.53125, 5.0 / 3.0, 1), 2.0, 1e-12, 0, "M(A/A* = 1.53125), helium");
    CHECK_CLOSE(dem_nozzle_mach(1.0, 1.4, 1), 1.0, 0, 0, "the throat");
    /* round trip over both branches */
    for (double ratio = 1.001; ratio < 200; ratio *= 1.7) {
        CHECK_CLOSE(dem_nozzle_area_ratio(dem_nozzle_mach(ratio, 1.4, 1), 1.4), ratio, 1e-12, 0, "round trip sup");
        CHECK_CLOSE(dem_nozzle_area_ratio(dem_nozzle_mach(ratio, 1.4, 0), 1.4), ratio, 1e-12, 0, "round trip sub");
    }
}

/* The item 6 nozzle (N2, 6.55 MPa, 698.15 K, 2 mm throat, 30 + 140 mm) with the exit diameter of A/A* = 10.71875. */
static struct dem_nozzle test_nozzle(double exit_diameter)
{
    struct dem_nozzle n = {.enabled = 1, .gas = DEM_NOZZLE_N2};
    n.properties = *dem_nozzle_gas_properties(DEM_NOZZLE_N2);
    n.stagnation_pressure = 6.55e6, n.stagnation_temperature = 698.15;
    n.throat_diameter = 2e-3, n.exit_diameter = exit_diameter, n.inlet_diameter = 6e-3;
    n.convergent_length = 0.03, n.divergent_length = 0.14;
    n.ambient_pressure = 101325.0;
    n.particle_density = 2700.0, n.particle_specific_heat = 896.0, n.particle_temperature = 293.15;
    return n;
}

static void test_exit_state(void)
{
    struct dem_nozzle n = test_nozzle(2e-3 * sqrt(10.71875));
    CHECK(dem_nozzle_solve(&n, 10e-6, 50e-6) == SC_OK, "solve: %s", sc_error_message());
    double r = 296.80, t_exit = 698.15 / 4.2; /* T0/T = 1 + 0.2 M^2 = 4.2 */
    CHECK_CLOSE(n.exit.mach, 4.0, 1e-6, 0, "exit Mach");
    CHECK_CLOSE(n.exit.temperature, t_exit, 1e-6, 0, "exit temperature (K)");
    CHECK_CLOSE(n.exit.velocity, 4.0 * sqrt(1.4 * r * t_exit), 1e-6, 0, "exit velocity (m/s)");
    CHECK_CLOSE(n.exit.pressure, 6.55e6 * pow(4.2, -3.5), 1e-6, 0, "exit pressure (Pa)");
    CHECK_CLOSE(n.exit.density, n.exit.pressure / (r * t_exit), 1e-6, 0, "exit density (kg/m3)");
    /* the throat: M = 1, T* = 2 T0 / (g + 1) */
    struct dem_nozzle_station throat;
    dem_nozzle_station_at(&n, 0.03, &throat);
    CHECK_CLOSE(throat.mach, 1.0, 1e-12, 0, "throat Mach");
    CHECK_CLOSE(throat.temperature, 698.15 / 1.2, 1e-12, 0, "throat temperature");
    /* the table: bigger particles are slower at the exit, and every one slower than the gas */
    for (int k = 1; k < DEM_NOZZLE_TABLE_ROWS; k++)
        CHECK(n.table_velocity[k] < n.table_velocity[k - 1], "exit speed falls with the diameter (row %d)", k);
    CHECK(n.table_velocity[0] < n.exit.velocity && n.table_velocity[0] > 300, "10 um exit speed %g m/s",
          n.table_velocity[0]);
}

/* The three gases' constants against their sources, derived here rather than retyped: R = R_u / M (R_u =
 * 8.314462618 J/(mol K), CODATA 2018; M of N2 28.0134, He 4.002602 (IUPAC) and dry air 28.9647 g/mol (ISO 2533)),
 * gamma 7/5 for the diatomic gases and 5/3 for the monatomic one, and the viscosity at 300 K within 1 % of the
 * reference correlations' (NIST Chemistry WebBook, Lemmon & Jacobsen 2004 for N2 17.89 and air 18.54 uPa s, Arp,
 * McCarty & Friend 1998 for He 19.94 uPa s).  A gas's constants swapped with another's, or a wrong molar mass, fail. */
static void test_gas_constants(void)
{
    static const struct {
        enum dem_nozzle_gas gas;
        const char *name;
        double molar_mass, gamma, mu_300;
    } gases[] = {{DEM_NOZZLE_N2, "n2", 28.0134e-3, 1.4, 17.89e-6},
                 {DEM_NOZZLE_HE, "he", 4.002602e-3, 5.0 / 3.0, 19.94e-6},
                 {DEM_NOZZLE_AIR, "air", 28.9647e-3, 1.4, 18.54e-6}};
    for (size_t k = 0; k < sizeof gases / sizeof gases[0]; k++) {
        const struct dem_nozzle_gas_properties *g = dem_nozzle_gas_properties(gases[k].gas);
        char what[64];
        CHECK(strcmp(g->name, gases[k].name) == 0, "gas %zu is %s (%s)", k, gases[k].name, g->name);
        snprintf(what, sizeof what, "%s: R = R_u / M", gases[k].name);
        CHECK_CLOSE(g->gas_constant, 8.314462618 / gases[k].molar_mass, 2e-5, 0, what);
        snprintf(what, sizeof what, "%s: gamma", gases[k].name);
        CHECK_CLOSE(g->gamma, gases[k].gamma, 1e-15, 0, what);
        snprintf(what, sizeof what, "%s: viscosity at 300 K", gases[k].name);
        CHECK_CLOSE(dem_nozzle_viscosity(g, 300.0), gases[k].mu_300, 0.01, 0, what);
    }
}

/* Helium's exit state in closed form: at gamma = 5/3 and M = 3, A/A* = (1/3) [0.75 (1 + 9/3)]^2 = 3 and T0/T = 4, so
 * a nozzle of exit diameter sqrt(3) times its throat's leaves at u = 3 sqrt(gamma R T0 / 4) and p = p0 4^-2.5. */
static void test_exit_state_helium(void)
{
    struct dem_nozzle n = test_nozzle(2e-3 * sqrt(3.0));
    n.gas = DEM_NOZZLE_HE;
    n.properties = *dem_nozzle_gas_properties(DEM_NOZZLE_HE);
    CHECK(dem_nozzle_solve(&n, 10e-6, 50e-6) == SC_OK, "solve: %s", sc_error_message());
    double r = 8.314462618 / 4.002602e-3, t_exit = 698.15 / 4.0;
    CHECK_CLOSE(n.exit.mach, 3.0, 1e-6, 0, "exit Mach");
    CHECK_CLOSE(n.exit.temperature, t_exit, 1e-6, 0, "exit temperature (K)");
    CHECK_CLOSE(n.exit.velocity, 3.0 * sqrt(5.0 / 3.0 * r * t_exit), 2e-5, 0, "exit velocity (m/s)");
    CHECK_CLOSE(n.exit.pressure, 6.55e6 * pow(4.0, -2.5), 1e-6, 0, "exit pressure (Pa)");
}

/* Stokes: Re -> 0 at M -> 0 gives C_D Re / 24 -> 1 (the pressure term adds 4.5 Re / 24); the free-molecular
 * sphere with diffuse reflection (Schaaf & Chambre 1958) at S = M sqrt(g/2) = 4.18 and Tw = T: C_D = 2 + 2/S^2 -
 * 1/(2 S^4) + 2 sqrt(pi)/(3 S) = 2.395 (the exponential and erf corrections below 1e-7), which Henderson's fit meets
 * to 1.3 %. */
static void test_drag_limits(void)
{
    double re = 1e-3;
    CHECK_CLOSE(dem_nozzle_drag_coefficient(re, 1e-9, 1.0, 1.4) * re / 24.0, 1.0, 2e-4, 0, "Stokes limit");
    double s = 5.0 * sqrt(0.7), s2 = s * s;
    double free_molecular = 2.0 + 2.0 / s2 - 0.5 / (s2 * s2) + 2.0 * sqrt(M_PI) / (3.0 * s);
    CHECK_CLOSE(dem_nozzle_drag_coefficient(1e-9, 5.0, 1.0, 1.4), free_molecular, 0.02, 0, "free-molecular limit");
    /* continuum, supersonic: about 0.9 + 0.34/M^2 at high Re */
    CHECK_CLOSE(dem_nozzle_drag_coefficient(1e9, 2.0, 1.0, 1.4), 0.9 + 0.34 / 4.0, 1e-3, 0, "continuum M = 2");
    /* continuity of the interpolation at M = 1 and 1.75 */
    CHECK_CLOSE(dem_nozzle_drag_coefficient(500, 1.0 + 1e-12, 1.0, 1.4),
                dem_nozzle_drag_coefficient(500, 1.0, 1.0, 1.4), 1e-9, 0, "C_D continuous at M = 1");
    CHECK_CLOSE(dem_nozzle_drag_coefficient(500, 1.75 - 1e-12, 1.0, 1.4),
                dem_nozzle_drag_coefficient(500, 1.75, 1.0, 1.4), 1e-9, 0, "C_D continuous at M = 1.75");
}

/* Henderson's C_D inside its continuum and transitional range, subsonic, interpolated and supersonic, against the
 * values scripts/nozzle_reference.py computes apart from this code from the paper's equations (printed to 17
 * digits).  The limits above check a few of its constants; these check every one (0.03 for 0.003, or M^4 for M^8,
 * passed the limits). */
static void test_henderson_values(void)
{
    static const struct {
        double re, mach, tr, gamma, cd;
    } points[] = {
        {100, 0.5, 1, 1.4, 1.0893667598216161},    {1000, 0.5, 1, 1.4, 0.51518361011498326},
        {500, 1.3, 1, 1.4, 1.0192390611638233},    {100, 2.0, 2, 1.4, 1.5048021987068219},
        {1172, 1.08, 1, 1.4, 0.81144657326032932}, {10, 0.2, 1.5, 5.0 / 3.0, 4.0149589564652564},
    };
    for (size_t k = 0; k < sizeof points / sizeof points[0]; k++)
        CHECK_CLOSE(dem_nozzle_drag_coefficient(points[k].re, points[k].mach, points[k].tr, points[k].gamma),
                    points[k].cd, 1e-12, 0, "Henderson C_D");
}

/* The particle's rates at the throat of the item 6 nozzle (M = 1): a 20 um particle at 300 m/s and 400 K, against
 * scripts/nozzle_reference.py (its own Henderson, Ranz-Marshall, recovery temperature and Sutherland viscosity).
 * The RK4 comparison below integrates these same rates, so only this holds their terms (a drag twice as large
 * passed every other test). */
static void test_throat_rates(void)
{
    struct dem_nozzle n = test_nozzle(6.3e-3);
    double y[3] = {300.0, 400.0, 0.0}, dydx[3];
    dem_nozzle_particle_rates(&n, 20e-6, n.convergent_length, y, dydx);
    CHECK_CLOSE(dydx[0], 15039.963521465181, 1e-10, 0, "dv/dx at the throat (1/s)");
    CHECK_CLOSE(dydx[1], 5029.494862510719, 1e-10, 0, "dT_p/dx at the throat (K/m)");
    CHECK_CLOSE(dydx[2], 1.0 / 300.0, 1e-15, 0, "dt/dx at the throat (s/m)");
}

/* Classical RK4 in x with a fixed step of h, the throat on a step boundary. */
static void rk4_leg(const struct dem_nozzle *n, double d, double x0, double x1, int steps, double y[3])
{
    double h = (x1 - x0) / steps;
    for (int k = 0; k < steps; k++) {
        double x = x0 + k * h, k1[3], k2[3], k3[3], k4[3], t[3];
        dem_nozzle_particle_rates(n, d, x, y, k1);
        for (int c = 0; c < 3; c++)
            t[c] = y[c] + 0.5 * h * k1[c];
        dem_nozzle_particle_rates(n, d, x + 0.5 * h, t, k2);
        for (int c = 0; c < 3; c++)
            t[c] = y[c] + 0.5 * h * k2[c];
        dem_nozzle_particle_rates(n, d, x + 0.5 * h, t, k3);
        for (int c = 0; c < 3; c++)
            t[c] = y[c] + h * k3[c];
        dem_nozzle_particle_rates(n, d, x + h, t, k4);
        for (int c = 0; c < 3; c++)
            y[c] += h / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
    }
}

/* RK4 with 6000 + 28000 steps and with half of them agree to ~1e-9 (fourth order: the error of the finer one is
 * 1/15 of their difference), so the reference is good to far better than the 1e-6 asked of CVODE. */
static void test_particle_against_rk4(void)
{
    struct dem_nozzle n = test_nozzle(6.3e-3);
    const double diameters[] = {5e-6, 25e-6, 60e-6};
    for (size_t i = 0; i < sizeof diameters / sizeof *diameters; i++) {
        double d = diameters[i], fine[3], coarse[3], out[3];
        struct dem_nozzle_station inlet;
        dem_nozzle_station_at(&n, 0.0, &inlet);
        for (int pass = 0; pass < 2; pass++) {
            double *y = pass ? coarse : fine;
            y[0] = inlet.velocity, y[1] = n.particle_temperature, y[2] = 0.0;
            int scale = pass ? 1 : 2;
            rk4_leg(&n, d, 0.0, 0.03, 3000 * scale, y);
            rk4_leg(&n, d, 0.03, 0.17, 14000 * scale, y);
        }
        CHECK(fabs(fine[0] - coarse[0]) < 1e-7 * fine[0], "RK4 converged: %.12g vs %.12g", fine[0], coarse[0]);
        CHECK(dem_nozzle_particle_exit(&n, d, out) == SC_OK, "CVODE: %s", sc_error_message());
        CHECK_CLOSE(out[0], fine[0], 1e-6, 0, "exit velocity against RK4 (m/s)");
        CHECK_CLOSE(out[1], fine[1], 1e-6, 0, "exit temperature against RK4 (K)");
        CHECK_CLOSE(out[2], fine[2], 1e-6, 0, "residence time against RK4 (s)");
        printf("  d = %g um: exit %.9g m/s, %.9g K after %.6g s (RK4 %.9g m/s, %.9g K)\n", d * 1e6, out[0], out[1],
               out[2], fine[0], fine[1]);
    }
}

static void test_shock_inside(void)
{
    struct dem_nozzle n = test_nozzle(6.3e-3);
    n.stagnation_pressure = 2e5;
    CHECK(dem_nozzle_solve(&n, 10e-6, 50e-6) == SC_EINPUT, "a shock inside the nozzle is refused");
    const char *message = sc_error_message();
    CHECK(strstr(message, "normal shock") && strstr(message, "101325"), "message with the numbers: %s", message);
    n.stagnation_pressure = 2e6; /* over-expanded, the shock outside: accepted */
    CHECK(dem_nozzle_solve(&n, 10e-6, 50e-6) == SC_OK, "over-expanded is fine: %s", sc_error_message());
    /* p_e = 2 MPa / 4.2^3.5 = 13.2 kPa, 0.13 of the ambient: may separate (warned); the item 6 nozzle's 0.48 not */
    CHECK(dem_nozzle_may_separate(&n), "p_e/p_a = %g: may separate", n.exit.pressure / n.ambient_pressure);
    struct dem_nozzle item6 = test_nozzle(6.3e-3);
    CHECK(dem_nozzle_solve(&item6, 10e-6, 50e-6) == SC_OK, "item 6 nozzle: %s", sc_error_message());
    CHECK(!dem_nozzle_may_separate(&item6), "item 6: p_e/p_a = %g, attached", item6.exit.pressure / 101325.0);
}

/* The spray stage with [nozzle]: every hand-off row carries the speed and temperature of the nozzle's table at its
 * diameter (no gas drag after the exit: jet model none), and the jet's constants follow the exit state unless given
 * in [jet]. */
static const char *nozzle_case = "[run]\nseed = 3\n"
                                 "[spray]\ndt = 1e-6\nt_end = 4e-5\nfeed_count = 5\nfeed_every = 5\n"
                                 "max_injected = 20\nnozzle_radius = 0.00315\ndomain_radius = 0.02\n"
                                 "handoff_height = 0.003\n"
                                 "[powder]\ndistribution = weibull\nmedian_diameter = 30e-6\nshape = 4\n"
                                 "d_min = 15e-6\nd_max = 45e-6\ndensity = 2700\nspecific_heat = 896\n"
                                 "[target]\nstandoff = 0.01\n"
                                 "[nozzle]\nstagnation_pressure = 6.55e6\nstagnation_temperature = 698.15\n"
                                 "throat_diameter = 2e-3\nexit_diameter = 6.3e-3\nconvergent_length = 0.03\n"
                                 "divergent_length = 0.14\n"
                                 "[jet]\nmodel = none\nC1 = 123\n"
                                 "[deposition]\nrule = none\n";

static void test_spray_release(void)
{
    struct fixture f;
    if (fixture_open(&f, nozzle_case, NULL) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    const struct dem_nozzle *n = f.cfg.nozzle;
    CHECK(n && n->enabled, "[nozzle] read");
    if (!n) {
        fixture_close(&f);
        return;
    }
    CHECK_CLOSE(f.cfg.gas.core_length, 6.3e-3 * (4.2 + 1.1 * n->exit.mach * n->exit.mach), 1e-12, 0, "core length");
    CHECK_CLOSE(f.cfg.gas.c1, 123.0, 0, 0, "C1 given in [jet] wins");
    CHECK_CLOSE(f.cfg.gas.density, n->exit.density, 0, 0, "gas density of the exit");
    CHECK_CLOSE(f.cfg.gas.gas_temperature, n->exit.temperature, 0, 0, "gas temperature of the exit");
    fixture_steps(&f, 40);
    size_t count;
    const struct dem_handoff *h = dem_handoffs(f.solver, &count);
    CHECK(count >= 15, "%zu hand-off rows", count);
    for (size_t k = 0; k < count; k++) {
        double speed, temperature;
        dem_nozzle_lookup(n, h[k].d, &speed, &temperature);
        CHECK_CLOSE(sqrt(h[k].v[0] * h[k].v[0] + h[k].v[1] * h[k].v[1] + h[k].v[2] * h[k].v[2]), speed, 1e-12, 0,
                    "release speed of the table");
        CHECK_CLOSE(h[k].temperature, temperature, 0, 0, "temperature of the table");
        CHECK(temperature > 400 && temperature < 520, "heated in the nozzle: %g K", temperature);
    }
    fixture_close(&f);
}

/* nozzle_case with one line replaced (a line "key = value\n" of it; "" removes it). */
static void nozzle_case_with(char *out, size_t size, const char *line, const char *replacement)
{
    const char *at = strstr(nozzle_case, line);
    snprintf(out, size, "%.*s%s%s", (int)(at - nozzle_case), nozzle_case, replacement, at + strlen(line));
}

/* With [nozzle] and no nozzle_radius the spray injects over the exit (radius 3.15 mm), and the checks of the disc
 * are those of that disc: a domain of 8 mm holds it (it was refused against the default 10 mm disc), one of 3 mm
 * does not, and the message names the key, its value and the range allowed. */
static void test_exit_disc(void)
{
    char ini[2048], inner[2048];
    nozzle_case_with(ini, sizeof ini, "nozzle_radius = 0.00315\ndomain_radius = 0.02\n", "domain_radius = 0.008\n");
    struct fixture f;
    if (fixture_open(&f, ini, NULL) != SC_OK) {
        CHECK(0, "the case with an 8 mm domain loads: %s", sc_error_message());
    } else {
        CHECK_CLOSE(f.cfg.nozzle_radius, 0.00315, 1e-15, 0, "the injection disc is the exit's");
        fixture_close(&f);
    }
    nozzle_case_with(inner, sizeof inner, "nozzle_radius = 0.00315\ndomain_radius = 0.02\n", "domain_radius = 0.003\n");
    char dir[64];
    struct case_file *c = NULL;
    struct dem_config cfg;
    CHECK(case_fixture_write(dir, inner, NULL, NULL, NULL, NULL) == 0, "fixture written");
    int status = case_fixture_load(dir, spraycoat_registry, &c);
    CHECK(status == SC_OK, "case read: %s", sc_error_message());
    if (status == SC_OK) {
        status = dem_config_load(c, &cfg);
        const char *message = sc_error_message();
        CHECK(status == SC_EINPUT, "a 3 mm domain inside the 3.15 mm exit is refused (status %d)", status);
        CHECK(strstr(message, "[spray] domain_radius = 0.003:") && strstr(message, "0.00315 m") &&
                  strstr(message, "[nozzle] exit_diameter") && strstr(message, "allowed: above 0.00315 m"),
              "the message names the key, the value, the exit and the range: %s", message);
        if (status == SC_OK)
            dem_config_free(&cfg);
    }
    case_free(c);
    case_fixture_remove(dir);
}

/* The jet mapped from the exit state (dem/params.c map_jet): over its potential core it has the nozzle's width (the
 * free jet's axial speed half the axis's at the exit radius, the axis's the exit velocity), and the bow shock before
 * a target inside the core stands Lobb's 0.82 R_e rho1/rho2 ahead of it, R_e the exit radius. */
static void test_jet_from_exit(void)
{
    static const char *jet_line = "[jet]\nmodel = none\nC1 = 123\n";
    char ini[2048];
    const char *at = strstr(nozzle_case, jet_line);
    snprintf(ini, sizeof ini, "%.*s%s", (int)(at - nozzle_case), nozzle_case, at + strlen(jet_line));
    struct fixture f;
    if (fixture_open(&f, ini, NULL) != SC_OK) {
        CHECK(0, "fixture: %s", sc_error_message());
        return;
    }
    const struct dem_nozzle *n = f.cfg.nozzle;
    struct dem_gas_field gas = f.cfg.gas; /* no wall: the free jet everywhere */
    gas.stagnation_height = gas.shock_standoff = 0.0;
    double exit_radius = 0.5 * 6.3e-3, u_e = n->exit.velocity, u[3];
    CHECK(gas.core_length > 0.1, "core %g m", gas.core_length);
    for (double z = 0.0; z < gas.core_length; z += 0.02) {
        dem_gas_velocity(&gas, (double[3]){0.0, 0.0, z}, u);
        CHECK_CLOSE(u[2], u_e, 1e-12, 0, "the axis speed in the core is the exit velocity");
        dem_gas_velocity(&gas, (double[3]){exit_radius, 0.0, z}, u);
        CHECK_CLOSE(u[2], 0.5 * u_e, 1e-12, 0, "half of it at the exit radius: the jet keeps the nozzle's width");
    }
    dem_gas_set_wall(&gas, 0.04);
    double a = sqrt(n->properties.gamma * n->properties.gas_constant * n->exit.temperature);
    double g = n->properties.gamma, m2 = u_e * u_e / (a * a), velocity_ratio = ((g - 1) * m2 + 2) / ((g + 1) * m2);
    CHECK_CLOSE(gas.shock_mach, u_e / a, 1e-12, 0, "the shock at the exit Mach number");
    CHECK_CLOSE(gas.shock_standoff, 0.82 * exit_radius * velocity_ratio, 1e-12, 0,
                "Lobb's standoff with the exit radius, u2/u1 of a normal shock");
    CHECK(gas.drag == DEM_DRAG_HENDERSON, "drag = auto is Henderson's with [nozzle]");
    CHECK(gas.gas_sutherland == n->properties.sutherland && gas.gas_sutherland == 107.0, "N2's Sutherland constant");
    double t2 = gas.shock_temperature_ratio * n->exit.temperature;
    CHECK_CLOSE(gas.shock_viscosity_ratio,
                dem_nozzle_viscosity(&n->properties, t2) / dem_nozzle_viscosity(&n->properties, n->exit.temperature),
                1e-12, 0, "the layer's viscosity: the nozzle's law at T2");
    printf("  jet from the exit: u_e %.1f m/s, M %.3f, bow shock %.3f mm before a target at 40 mm\n", u_e, u_e / a,
           1e3 * gas.shock_standoff);
    fixture_close(&f);
}

int main(void)
{
    RUN(test_area_mach);
    RUN(test_exit_state);
    RUN(test_gas_constants);
    RUN(test_exit_state_helium);
    RUN(test_drag_limits);
    RUN(test_henderson_values);
    RUN(test_throat_rates);
    RUN(test_particle_against_rk4);
    RUN(test_shock_inside);
    RUN(test_spray_release);
    RUN(test_jet_from_exit);
    RUN(test_exit_disc);
    return check_finish();
}
