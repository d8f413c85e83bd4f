/* The bow shock in front of the target (dem/gas.c, dem/gas_eval.h, docs/physics.md "The bow shock at the target"):
 * the normal-shock relations against NACA Report 1135's table; the shock's placement (Mach number at the shock,
 * Lobb's standoff) solved self-consistently; a subsonic jet with the same field as bow_shock = none, bit for bit;
 * the layer: the jump only at the shock (u2/u1 on the axis), continuous below it, still at the wall, bounded by the
 * free jet's speed, at the compressed density rho2; and a fine particle losing its speed in the layer where a
 * coarse one does not, against an independent integration of the layer's equations, in the couple stage's CVODE
 * flight too. */
#include <math.h>
#include <string.h>

/* A white-box test: includes the module-private header dem/gas.h (dem_normal_shock; tests/test_symbols.sh). */
#include "core/error.h"
#include "coupling/coupling.h"
#include "dem/gas.h"
#include "tests/check.h"

/* NACA Report 1135 (1953), Table II (normal shock, gamma = 1.4): M1, M2, p2/p1, rho2/rho1, T2/T1, printed to 4-5
 * significant digits. */
static const double naca_1135[][5] = {
    {1.5, 0.7011, 2.4583, 1.8621, 1.3202},
    {2.0, 0.5774, 4.5000, 2.6667, 1.6875},
    {3.0, 0.4752, 10.333, 3.8571, 2.6790},
};

static void test_normal_shock_table(void)
{
    for (size_t i = 0; i < sizeof naca_1135 / sizeof naca_1135[0]; i++) {
        const double *row = naca_1135[i];
        struct dem_normal_shock s = dem_normal_shock(1.4, row[0]);
        CHECK_CLOSE(s.mach_after, row[1], 1e-4, 0.0, "M2");
        CHECK_CLOSE(s.pressure_ratio, row[2], 1e-4, 0.0, "p2/p1");
        CHECK_CLOSE(s.density_ratio, row[3], 1e-4, 0.0, "rho2/rho1");
        CHECK_CLOSE(s.temperature_ratio, row[4], 1e-4, 0.0, "T2/T1");
        CHECK_CLOSE(s.velocity_ratio * s.density_ratio, 1.0, 1e-15, 0.0, "u2/u1 = rho1/rho2 (mass)");
    }
    /* M1 = 1: no jump */
    struct dem_normal_shock sonic = dem_normal_shock(1.4, 1.0);
    CHECK(fabs(sonic.density_ratio - 1.0) < 1e-15 && fabs(sonic.mach_after - 1.0) < 1e-15, "a Mach wave at M1 = 1");
}

/* The demo's cold-spray jet (cases/demo.ini: about 760 m/s on the axis near the target, air at 293.15 K, M ~ 2.2),
 * or the paper's Table 1 jet (cases/mz2015_table1.ini: 41 m/s at the target), with the [jet] defaults. */
static struct dem_gas_field jet(int table1, enum dem_bow_shock bow_shock)
{
    struct dem_gas_field gas = {.model = DEM_JET_BICKLEY, .drag = DEM_DRAG_HAIDER_LEVENSPIEL};
    gas.c1 = table1 ? 30.0 : 320.0;
    gas.c3 = table1 ? 20.0 : 40.0;
    gas.c2 = gas.c1 / (3.0 * gas.c3);
    gas.virtual_origin = table1 ? 0.1 : 0.05;
    gas.core_length = table1 ? 0.02 : 0.002;
    gas.density = 1.1;
    gas.kinematic_viscosity = 25e-6;
    gas.stagnation_factor = 1.5;
    gas.gas_temperature = 293.15;
    gas.gas_gamma = 1.4;
    gas.gas_constant = 287.05;
    gas.gas_sutherland = 111.0;
    gas.bow_shock = bow_shock;
    dem_gas_set_wall(&gas, table1 ? 0.30 : 0.03);
    return gas;
}

static double axis_speed(const struct dem_gas_field *gas, double z)
{
    double x = z + gas->virtual_origin;
    if (z < gas->core_length)
        x = gas->core_length + gas->virtual_origin;
    return gas->c1 / cbrt(x);
}

static double half_width_at_wall(const struct dem_gas_field *gas)
{
    return 0.88137358701954302523 * pow(gas->wall_z + gas->virtual_origin, 2.0 / 3.0) / gas->c3;
}

static void velocity_at(const struct dem_gas_field *gas, double r, double z, double u[3])
{
    const double x[3] = {r, 0.0, z};
    dem_gas_velocity(gas, x, u);
}

/* The demo's jet: M1 = U(wall - Delta)/a > 1 at the shock it places, Delta = 0.82 b rho1/rho2(M1), the wall region
 * is the layer below it; the state behind it is the normal shock's at M1. */
static void test_shock_placement(void)
{
    struct dem_gas_field gas = jet(0, DEM_BOW_SHOCK_AUTO);
    double a = sqrt(1.4 * 287.05 * 293.15), b = half_width_at_wall(&gas);
    double mach = axis_speed(&gas, gas.wall_z - gas.shock_standoff) / a;
    struct dem_normal_shock s = dem_normal_shock(1.4, mach);
    printf("  demo jet: M1 = %.4f, standoff %.4g m (%.3f b), rho2/rho1 = %.4f, T2/T1 = %.4f\n", gas.shock_mach,
           gas.shock_standoff, gas.shock_standoff / b, gas.shock_density_ratio, gas.shock_temperature_ratio);
    CHECK(gas.shock_standoff > 0.0 && mach > 2.0 && mach < 2.4, "a shock at M1 = %g", mach);
    CHECK_CLOSE(gas.shock_mach, mach, 1e-12, 0.0, "M1 at the shock's station");
    CHECK_CLOSE(gas.shock_standoff, 0.82 * b * s.velocity_ratio, 1e-10, 0.0, "Delta = 0.82 b rho1/rho2 (Lobb)");
    CHECK_CLOSE(gas.shock_density_ratio, s.density_ratio, 1e-12, 0.0, "rho2/rho1");
    CHECK_CLOSE(gas.shock_temperature_ratio, s.temperature_ratio, 1e-12, 0.0, "T2/T1");
    CHECK(gas.stagnation_height == gas.shock_standoff, "the wall region is the layer below the shock");
}

/* No shock where the jet arrives subsonic (Table 1's 41 m/s; the demo's jet in gas whose sound speed exceeds its
 * speed, a hot gas of 2000 K: a = 896 m/s): the field is bow_shock = none's, bit for bit, as is the drag. */
static void test_subsonic_unchanged(void)
{
    for (int k = 0; k < 2; k++) {
        struct dem_gas_field gas = k ? jet(0, DEM_BOW_SHOCK_AUTO) : jet(1, DEM_BOW_SHOCK_AUTO);
        if (k) {
            gas.gas_temperature = 2000.0;
            dem_gas_set_wall(&gas, gas.wall_z);
        }
        struct dem_gas_field none = gas;
        none.bow_shock = DEM_BOW_SHOCK_NONE;
        dem_gas_set_wall(&none, gas.wall_z);
        CHECK(gas.shock_standoff == 0.0 && gas.stagnation_height == none.stagnation_height, "case %d: no shock", k);
        int same = 1;
        double b = half_width_at_wall(&gas);
        for (int i = 0; i <= 30; i++)
            for (int j = 0; j <= 60; j++) {
                double r = 4.0 * b * i / 30.0, z = gas.wall_z * (1.0 - 0.1 * j / 60.0), u[3], w[3], f[3], g[3];
                const double x[3] = {r, 0.0, z}, v[3] = {1.0, -2.0, 300.0};
                velocity_at(&gas, r, z, u);
                velocity_at(&none, r, z, w);
                dem_gas_drag_force_at(&gas, 2e-5, x, v, u, f);
                dem_gas_drag_force(&none, 2e-5, v, w, g);
                same &= memcmp(u, w, sizeof u) == 0 && memcmp(f, g, sizeof f) == 0;
            }
        CHECK(same, "case %d: the subsonic field and drag are bow_shock = none's", k);
    }
}

/* Above the shock: the free jet (the supersonic jet does not feel the wall).  Across it: u_z drops by exactly
 * u2/u1 and the density rises by rho2/rho1.  Below it: the subsonic wall region's field of height Delta times u2/u1,
 * continuous (largest step between grid neighbours against the same for the field without shock), u_z = 0 at the
 * wall, and no gas speed above the free jet's at the shock. */
static void test_layer(void)
{
    struct dem_gas_field gas = jet(0, DEM_BOW_SHOCK_AUTO), free_jet = gas;
    free_jet.stagnation_factor = 0.0;
    dem_gas_set_wall(&free_jet, gas.wall_z);
    double delta = gas.shock_standoff, top = gas.wall_z - delta, b = half_width_at_wall(&gas);
    double u_shock = axis_speed(&gas, top), above[3], below[3], free_u[3];
    int same = 1;
    for (int i = 0; i <= 40; i++)
        for (int j = 0; j <= 40; j++) {
            double r = 5.0 * b * i / 40.0, z = top * j / 40.0;
            velocity_at(&gas, r, z, above);
            velocity_at(&free_jet, r, z, free_u);
            same &= memcmp(above, free_u, sizeof above) == 0;
        }
    CHECK(same, "above the shock the free jet's field, bit for bit");
    velocity_at(&gas, 0.0, top * (1.0 - 1e-13), above);
    velocity_at(&gas, 0.0, top * (1.0 + 1e-13), below);
    CHECK_CLOSE(below[2] / above[2], gas.shock_velocity_ratio, 1e-9, 0.0, "u2/u1 across the shock on the axis");
    const double x_above[3] = {0.0, 0.0, top * (1.0 - 1e-13)}, x_below[3] = {0.0, 0.0, top * (1.0 + 1e-13)};
    const double v[3] = {0.0, 0.0, 500.0};
    double f_above[3], f_below[3], f_free[3];
    dem_gas_drag_force_at(&gas, 5e-6, x_above, v, above, f_above);
    dem_gas_drag_force(&gas, 5e-6, v, above, f_free);
    CHECK(memcmp(f_above, f_free, sizeof f_above) == 0, "above the shock the drag is the free jet's");
    dem_gas_drag_force_at(&gas, 5e-6, x_below, v, below, f_below);
    CHECK(f_below[2] < 0.0 && f_above[2] > 0.0, "the layer brakes a particle the free jet pushed (%g, %g N)",
          f_below[2], f_above[2]);

    /* continuity below the shock and the bound, on a grid of the layer out to 20 half-widths */
    const int nr = 2000, nz = 100;
    double largest = 0.0, worst_step = 0.0, wall_uz = 0.0, previous_row[2001][3];
    for (int j = 0; j <= nz; j++) {
        double z = gas.wall_z - delta * (1.0 - 1e-12) * j / nz;
        double previous[3] = {0, 0, 0};
        for (int i = 0; i <= nr; i++) {
            double r = 20.0 * b * i / nr, u[3];
            velocity_at(&gas, r, z, u);
            largest = fmax(largest, sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]));
            if (j == 0)
                wall_uz = fmax(wall_uz, fabs(u[2]));
            for (int k = 0; k < 3; k++) {
                if (i > 0)
                    worst_step = fmax(worst_step, fabs(u[k] - previous[k]));
                if (j > 0)
                    worst_step = fmax(worst_step, fabs(u[k] - previous_row[i][k]));
                previous[k] = u[k];
                previous_row[i][k] = u[k];
            }
        }
    }
    CHECK(wall_uz == 0.0, "u_z at the wall %g m/s", wall_uz);
    /* a grid of 20 b / 2000 = 0.01 b by Delta / 100: the largest gradient, du_r/dr = (u2/u1) U1/Delta = 1.2 U1/b
     * at the wall near the axis, gives steps of 0.012 U1; a jump below the shock would be one of order u2 = 0.34 U1 */
    CHECK(worst_step < 0.02 * u_shock, "largest step between grid neighbours in the layer %g m/s (%g U1)", worst_step,
          worst_step / u_shock);
    CHECK(largest <= 0.95 * u_shock,
          "largest gas speed in the layer %g m/s <= 0.95 U1 = %g m/s (bound 0.941 U1: docs/physics.md)", largest,
          0.95 * u_shock);
    double density_above = 0, density_below = 0;
    {
        /* the drag's density: the Stokes-free part of the drag at large Re is proportional to it */
        const double fast[3] = {0.0, 0.0, -2000.0}, still[3] = {0.0, 0.0, 0.0};
        double fa[3], fb[3];
        dem_gas_drag_force_at(&gas, 1e-3, x_above, fast, still, fa);
        dem_gas_drag_force_at(&gas, 1e-3, x_below, fast, still, fb);
        density_above = fa[2];
        density_below = fb[2];
    }
    CHECK(density_below / density_above > 0.95 * gas.shock_density_ratio &&
              density_below / density_above < 1.05 * gas.shock_density_ratio,
          "the drag at Re ~ 1e5 rises by rho2/rho1 = %g across the shock (%g)", gas.shock_density_ratio,
          density_below / density_above);
}

/* Mass: in the layer rho2 u equals rho1 times the subsonic wall region's velocity with H = Delta (the field
 * whose volume flux tests/test_wall_jet.c balances), everywhere in the layer. */
static void test_layer_mass_flux(void)
{
    struct dem_gas_field gas = jet(0, DEM_BOW_SHOCK_AUTO), subsonic = gas;
    double b = half_width_at_wall(&gas);
    subsonic.bow_shock = DEM_BOW_SHOCK_NONE;
    subsonic.stagnation_factor = gas.shock_standoff / b;
    dem_gas_set_wall(&subsonic, gas.wall_z);
    CHECK_CLOSE(subsonic.stagnation_height, gas.shock_standoff, 1e-14, 0.0, "the subsonic region of height Delta");
    double worst = 0.0, scale = gas.density * subsonic.wall_axis_speed;
    for (int i = 0; i <= 200; i++)
        for (int j = 0; j < 50; j++) {
            double r = 10.0 * b * i / 200.0, z = gas.wall_z - gas.shock_standoff * j / 50.0, u[3], w[3];
            velocity_at(&gas, r, z, u);
            velocity_at(&subsonic, r, z, w);
            for (int k = 0; k < 3; k++)
                worst = fmax(worst, fabs(gas.shock_density_ratio * gas.density * u[k] - gas.density * w[k]));
        }
    CHECK(worst < 1e-12 * scale, "rho2 u - rho1 u_subsonic: largest %g kg/(m2 s) of %g", worst, scale);
}

/* ---- a fine and a coarse Al particle on the axis through the layer ------------------------------------------ */

struct axis_gas {
    double wall_z, top, u1, ratio, rho, nu, compression;
    double sound, sound_ratio; /* the free jet's speed of sound and the layer's a2/a1 = sqrt(T2/T1) (Henderson) */
    double viscosity_ratio;    /* mu2/mu1 of Sutherland's law */
};

/* The layer's equations on the axis written out here, independently of dem/gas_eval.h: u_z = (u2/u1) U1 eta (2 -
 * eta) below the shock, eta = s/Delta; the free jet's U(z) above; density rho2 and nu2 = nu1 (mu2/mu1) rho1/rho2 below
 * (Sutherland); Haider-Levenspiel drag (Eqs. 24-25), or with drag = henderson Henderson's C_D
 * (dem_nozzle_drag_coefficient, the sphere at the gas's temperature) at the slip's Mach number against a1 = sqrt(gamma
 * R T1), sqrt(T2/T1) a1 below. */
static double axis_acceleration(const struct axis_gas *g, const struct dem_gas_field *gas, double d, double mass,
                                double z, double v)
{
    double u, rho = g->rho, nu = g->nu, sound = g->sound;
    if (z > g->top) {
        double eta = (g->wall_z - z) / (g->wall_z - g->top);
        u = g->ratio * g->u1 * eta * (2.0 - eta);
        rho *= g->compression;
        nu *= g->viscosity_ratio / g->compression;
        sound *= g->sound_ratio;
    } else {
        u = axis_speed(gas, z);
    }
    double slip = fabs(u - v);
    if (slip == 0.0)
        return 0.0;
    double cd = gas->drag == DEM_DRAG_HENDERSON
                    ? dem_nozzle_drag_coefficient(d * slip / nu, slip / sound, 1.0, gas->gas_gamma)
                    : dem_drag_coefficient_haider_levenspiel(d * slip / nu);
    return 0.5 * rho * M_PI * d * d / 4.0 * cd * slip * (u - v) / mass;
}

/* RK4 on the axis (dt 0.2 ns) from z0 at v0 until the sphere touches the wall; the speed there.  use_dem: the
 * acceleration from dem_gas_velocity and dem_gas_drag_force_at instead. */
static double fly_axis(const struct dem_gas_field *gas, int use_dem, double d, double z0, double v0, double *v_shock)
{
    struct axis_gas g = {gas->wall_z,
                         gas->wall_z - gas->shock_standoff,
                         0,
                         gas->shock_velocity_ratio,
                         gas->density,
                         gas->kinematic_viscosity,
                         gas->shock_density_ratio,
                         sqrt(gas->gas_gamma * gas->gas_constant * gas->gas_temperature),
                         sqrt(gas->shock_temperature_ratio),
                         0};
    double t1 = gas->gas_temperature, t2 = gas->shock_temperature_ratio * t1, S = gas->gas_sutherland;
    g.viscosity_ratio = pow(t2 / t1, 1.5) * (t1 + S) / (t2 + S);
    g.u1 = axis_speed(gas, g.top);
    double mass = 2700.0 * M_PI * d * d * d / 6.0, h = 2e-10, z = z0, v = v0;
    *v_shock = 0.0;
    while (z + 0.5 * d < gas->wall_z) {
        double kz[4], kv[4], zz = z, vv = v;
        for (int s = 0; s < 4; s++) {
            if (s > 0) {
                double c = s == 3 ? 1.0 : 0.5;
                zz = z + c * h * kz[s - 1];
                vv = v + c * h * kv[s - 1];
            }
            kz[s] = vv;
            if (use_dem) {
                const double x[3] = {0, 0, zz}, vel[3] = {0, 0, vv};
                double u[3], f[3];
                dem_gas_velocity(gas, x, u);
                dem_gas_drag_force_at(gas, d, x, vel, u, f);
                kv[s] = f[2] / mass;
            } else {
                kv[s] = axis_acceleration(&g, gas, d, mass, zz, vv);
            }
        }
        double z_next = z + h / 6.0 * (kz[0] + 2 * kz[1] + 2 * kz[2] + kz[3]);
        double v_next = v + h / 6.0 * (kv[0] + 2 * kv[1] + 2 * kv[2] + kv[3]);
        if (z <= g.top && z_next > g.top)
            *v_shock = v + (v_next - v) * (g.top - z) / (z_next - z);
        if (z_next + 0.5 * d >= gas->wall_z) /* linear to the contact */
            return v + (v_next - v) * (gas->wall_z - 0.5 * d - z) / (z_next - z);
        z = z_next;
        v = v_next;
    }
    return v;
}

/* A 5 um Al particle arriving at the shock at ~640 m/s loses a tenth of its speed in the 1.1 mm layer of rho2 =
 * 3 rho1, a 25 um one ~1 %: the dem field and drag against the layer's equations integrated independently, and
 * the loss against the same layer uncompressed (a drag that ignored the layer's density would lose a third less). */
static void test_fine_particle_slows(void)
{
    struct dem_gas_field gas = jet(0, DEM_BOW_SHOCK_AUTO), uncompressed = gas;
    uncompressed.shock_density_ratio = 1.0;
    const double d[2] = {5e-6, 25e-6}, start[2] = {650.0, 550.0}, z0 = gas.wall_z - 3e-3;
    double loss[2], loss_uncompressed = 0.0;
    for (int k = 0; k < 2; k++) {
        double at_shock, at_shock_ref, at_shock_u;
        double v_wall = fly_axis(&gas, 1, d[k], z0, start[k], &at_shock);
        double v_ref = fly_axis(&gas, 0, d[k], z0, start[k], &at_shock_ref);
        CHECK_CLOSE(v_wall, v_ref, 1e-6, 0.0, "speed at the wall: dem's layer against its equations");
        CHECK_CLOSE(at_shock, at_shock_ref, 1e-6, 0.0, "speed at the shock");
        loss[k] = 1.0 - v_wall / at_shock;
        printf("  d = %g um: %.1f m/s at the shock, %.1f m/s at the wall (loss %.2f %%)\n", d[k] * 1e6, at_shock,
               v_wall, 100.0 * loss[k]);
        if (k == 0) {
            double v_u = fly_axis(&uncompressed, 0, d[k], z0, start[k], &at_shock_u);
            loss_uncompressed = 1.0 - v_u / at_shock_u;
            printf("  (uncompressed layer: loss %.2f %%)\n", 100.0 * loss_uncompressed);
        }
    }
    CHECK(loss[0] > 0.05, "the 5 um particle loses %g of its speed in the layer", loss[0]);
    CHECK(loss[1] < 0.02 && loss[1] > 0.0, "the 25 um particle loses %g", loss[1]);
    CHECK(loss[0] > 5.0 * loss[1], "fine loses > 5 x coarse's share");
    CHECK(loss[0] > 1.3 * loss_uncompressed, "the layer's density: loss %g against %g uncompressed", loss[0],
          loss_uncompressed);
}

/* The couple stage's CVODE flight takes the layer's density too: the 5 um particle's speed at the wall against the
 * RK4 reference. */
static void test_flight_through_layer(void)
{
    struct couple_flight_layer layer = {.rtol = 1e-9, .atol = 1e-11};
    layer.gas = jet(0, DEM_BOW_SHOCK_AUTO);
    struct couple_flight_solver *solver = NULL;
    CHECK(couple_flight_solver_create(&solver) == SC_OK, "solver");
    const double d = 5e-6, z0 = layer.gas.wall_z - 3e-3, x0[3] = {0, 0, z0}, v0[3] = {0, 0, 650.0};
    struct couple_flight_result r;
    CHECK(couple_flight_integrate(solver, &layer, d, 2700.0, 0.0, x0, v0, couple_flight_wall_contact_z(&layer, d),
                                  &r) == SC_OK,
          "flight: %s", sc_error_message());
    double at_shock, v_ref = fly_axis(&layer.gas, 0, d, z0, 650.0, &at_shock);
    CHECK(r.reached, "reached the wall");
    CHECK_CLOSE(r.v[2], v_ref, 1e-5, 0.0, "CVODE speed at the wall against the RK4 reference");
    couple_flight_result_free(&r);
    couple_flight_solver_destroy(solver);
}

/* drag = henderson (the law of a jet from [nozzle]): the same flights through the demo's layer against the layer's
 * equations with Henderson's C_D at the local Mach number (the layer's speed of sound sqrt(T2/T1) = 1.35 times the
 * free jet's); the slip there is near Mach 1, where Henderson's C_D exceeds Haider-Levenspiel's, so the fine
 * particle loses more.  The response time is m over a central difference of the drag. */
static void test_henderson_layer(void)
{
    struct dem_gas_field gas = jet(0, DEM_BOW_SHOCK_AUTO), usual = gas;
    gas.drag = DEM_DRAG_HENDERSON;
    const double d[2] = {5e-6, 25e-6}, start[2] = {650.0, 550.0}, z0 = gas.wall_z - 3e-3;
    for (int k = 0; k < 2; k++) {
        double at_shock, at_shock_ref, at_shock_usual;
        double v_wall = fly_axis(&gas, 1, d[k], z0, start[k], &at_shock);
        double v_ref = fly_axis(&gas, 0, d[k], z0, start[k], &at_shock_ref);
        double v_usual = fly_axis(&usual, 1, d[k], z0, start[k], &at_shock_usual);
        CHECK_CLOSE(v_wall, v_ref, 1e-6, 0.0, "Henderson: speed at the wall against the layer's equations");
        CHECK_CLOSE(at_shock, at_shock_ref, 1e-6, 0.0, "Henderson: speed at the shock");
        printf("  Henderson, d = %g um: %.1f m/s at the shock, %.1f m/s at the wall (Haider-Levenspiel %.1f, %.1f)\n",
               d[k] * 1e6, at_shock, v_wall, at_shock_usual, v_usual);
        if (k == 0)
            CHECK(at_shock - v_wall > at_shock_usual - v_usual, "the fine particle loses more with Henderson");
    }
    const double slips[3] = {0.0, 30.0, 400.0};
    for (int k = 0; k < 3; k++) {
        double s = slips[k], step = 1e-3 * fmax(s, 1.0), mass = 2700.0 * M_PI * 125e-18 / 6.0, f[2][3];
        for (int side = 0; side < 2; side++) {
            const double x[3] = {0, 0, 0.01}, v[3] = {0, 0, 0};
            double u[3] = {0, 0, (side ? 1.0 : -1.0) * step + s};
            dem_gas_drag_force_at(&gas, 5e-6, x, v, u, f[side]);
        }
        double slope = (f[1][2] - f[0][2]) / (2.0 * step), tau = dem_gas_response_time(&gas, 2700.0, 5e-6, s);
        CHECK_CLOSE(tau, mass / slope, 1e-4, 0.0, "Henderson: response time m / (dF/ds)");
    }
}

int main(void)
{
    RUN(test_normal_shock_table);
    RUN(test_shock_placement);
    RUN(test_subsonic_unchanged);
    RUN(test_layer);
    RUN(test_layer_mass_flux);
    RUN(test_fine_particle_slows);
    RUN(test_flight_through_layer);
    RUN(test_henderson_layer);
    return check_finish();
}
