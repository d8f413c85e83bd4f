/* The CVODE flight through the gas in front of the target (coupling/coupling.h): Stokes relaxation against
 * ../shared/verification/stokes_relaxation.csv, a non-stiff Haider-Levenspiel flight through the jet's wall region
 * against a fine explicit reference, and a stiff sub-micron particle that follows the stagnation flow to the wall
 * in few steps and never passes it.  The field itself: tests/test_wall_jet.c. */
#include <math.h>
#include <string.h>

#include "core/error.h"
#include "coupling/coupling.h"
#include "tests/check.h"
#include "tests/verification_csv.h"

static struct couple_flight_solver *solver;

static struct couple_flight_layer stokes_layer(double wall_z)
{
    /* the table's set-up: mu = 1.8e-5 Pa s (rho_g nu), a uniform stream of 100 m/s (delta = 0) */
    struct couple_flight_layer layer = {.rtol = 1e-10, .atol = 1e-12};
    layer.gas.model = DEM_JET_UNIFORM;
    layer.gas.uniform_velocity = 100.0;
    layer.gas.drag = DEM_DRAG_STOKES;
    layer.gas.density = 1.2;
    layer.gas.kinematic_viscosity = 1.8e-5 / 1.2;
    dem_gas_set_wall(&layer.gas, wall_z); /* a uniform stream has no wall region */
    return layer;
}

/* The time to cover x_k from rest is t_k, and the speed there is v_k: the wall is put at x_k + d/2 so that the
 * flight's contact root lands on the table row. */
static int stokes_rows_checked;
static void visit_stokes_row(const struct csv_row *row)
{
    double t = csv_number(row, 0), v = csv_number(row, 1), x = csv_number(row, 2);
    if (t <= 0.0)
        return;
    const double d = 1e-5, rho = 2700.0;
    struct couple_flight_layer layer = stokes_layer(x + 0.5 * d);
    struct couple_flight_result r;
    const double x0[3] = {0, 0, 0}, v0[3] = {0, 0, 0};
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, couple_flight_wall_contact_z(&layer, d), &r) ==
              SC_OK,
          "flight: %s", sc_error_message());
    CHECK(r.reached, "the particle reaches x = %g m", x);
    CHECK_CLOSE(r.t, t, 1e-6, 0.0, "time to cover x");
    CHECK_CLOSE(r.v[2], v, 1e-6, 0.0, "speed at x");
    couple_flight_result_free(&r);
    stokes_rows_checked++;
}

static void test_stokes_relaxation_table(void)
{
    int rows = csv_for_each("stokes_relaxation.csv", visit_stokes_row);
    CHECK(rows >= 4, "stokes_relaxation.csv has rows (got %d)", rows);
    CHECK(stokes_rows_checked == rows - 1, "every row with t > 0 checked (%d of %d)", stokes_rows_checked, rows);
}

/* ---- a non-stiff flight against classical RK4 at a step far below the drag response time -------------------- */

/* The field is the spray's (dem_gas_velocity, checked on its own in tests/test_wall_jet.c); the reference is an
 * independent integrator of the same equation of motion. */
static void reference_rate(const struct couple_flight_layer *layer, double d, double mass, const double y[6],
                           double dy[6])
{
    double u[3], force[3];
    dem_gas_velocity(&layer->gas, y, u);
    dem_gas_drag_force(&layer->gas, d, y + 3, u, force);
    for (int k = 0; k < 3; k++) {
        dy[k] = y[3 + k];
        dy[3 + k] = force[k] / mass;
    }
}

static void rk4_step(const struct couple_flight_layer *layer, double d, double mass, double h, double y[6])
{
    double k1[6], k2[6], k3[6], k4[6], tmp[6];
    reference_rate(layer, d, mass, y, k1);
    for (int i = 0; i < 6; i++)
        tmp[i] = y[i] + 0.5 * h * k1[i];
    reference_rate(layer, d, mass, tmp, k2);
    for (int i = 0; i < 6; i++)
        tmp[i] = y[i] + 0.5 * h * k2[i];
    reference_rate(layer, d, mass, tmp, k3);
    for (int i = 0; i < 6; i++)
        tmp[i] = y[i] + h * k3[i];
    reference_rate(layer, d, mass, tmp, k4);
    for (int i = 0; i < 6; i++)
        y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

/* One RK4 step from `start` that ends on the plane z = plane: its length found by the secant method. */
static double rk4_step_to_plane(const struct couple_flight_layer *layer, double d, double mass, const double start[6],
                                double h, double plane, double y[6])
{
    double lo = 0.0, z_lo = start[2], hi = h, z_hi;
    memcpy(y, start, 6 * sizeof *y);
    rk4_step(layer, d, mass, hi, y);
    z_hi = y[2];
    for (int i = 0; i < 60 && fabs(y[2] - plane) > 1e-15 * fabs(plane); i++) {
        double length = lo + (plane - z_lo) * (hi - lo) / (z_hi - z_lo);
        memcpy(y, start, 6 * sizeof *y);
        rk4_step(layer, d, mass, length, y);
        lo = hi;
        z_lo = z_hi;
        hi = length;
        z_hi = y[2];
    }
    return hi;
}

/* RK4 until the centre reaches the height stop_z.  A step that would cross the top of the wall region (where the
 * field's derivatives jump) or the stop plane is replaced by the step that ends on it, so that no step straddles the
 * kink. */
static void rk4_to_height(const struct couple_flight_layer *layer, double d, double mass, const double y0[6], double h,
                          double stop_z, double *t_wall, double v_wall[3])
{
    double y[6], t = 0.0;
    memcpy(y, y0, sizeof y);
    double contact_z = stop_z, edge_z = layer->gas.wall_z - layer->gas.stagnation_height;
    int edge_ahead = layer->gas.stagnation_height > 0.5 * d && y[2] < edge_z && edge_z < stop_z;
    for (;;) {
        double previous[6];
        memcpy(previous, y, sizeof y);
        rk4_step(layer, d, mass, h, y);
        double plane = edge_ahead ? edge_z : contact_z;
        if (y[2] < plane) {
            t += h;
            continue;
        }
        t += rk4_step_to_plane(layer, d, mass, previous, h, plane, y);
        if (!edge_ahead)
            break;
        edge_ahead = 0;
    }
    *t_wall = t;
    memcpy(v_wall, y + 3, 3 * sizeof *v_wall);
}

/* The demo's cold-spray jet (cases/demo.ini) impinging on a target 30 mm from the nozzle: a wall region 6.1 mm
 * deep, 760 m/s on the axis at its top. */
static struct couple_flight_layer cold_spray_layer(void)
{
    struct couple_flight_layer layer = {.rtol = 1e-10, .atol = 1e-12};
    layer.gas.model = DEM_JET_BICKLEY;
    layer.gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    layer.gas.c1 = 320.0;
    layer.gas.c3 = 40.0;
    layer.gas.c2 = layer.gas.c1 / (3.0 * layer.gas.c3);
    layer.gas.virtual_origin = 0.05;
    layer.gas.core_length = 0.002;
    layer.gas.density = 2.0;
    layer.gas.kinematic_viscosity = 1.5e-5;
    layer.gas.stagnation_factor = 1.5;
    dem_gas_set_wall(&layer.gas, 0.03);
    return layer;
}

static void test_nonstiff_against_rk4(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    const double d = 20e-6, rho = 2700.0, mass = rho * M_PI * d * d * d / 6.0;
    /* from a hand-off plane 8 mm before the wall, above the wall region, off axis and slightly oblique */
    const double x0[3] = {1e-3, -0.5e-3, 0.022}, v0[3] = {5.0, -2.0, 600.0};
    struct couple_flight_result r;
    CHECK(layer.gas.stagnation_height > 5e-3 && layer.gas.stagnation_height < 8e-3, "wall region %g m",
          layer.gas.stagnation_height);
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, couple_flight_wall_contact_z(&layer, d), &r) ==
              SC_OK,
          "flight: %s", sc_error_message());
    double y0[6] = {x0[0], x0[1], x0[2], v0[0], v0[1], v0[2]}, t_ref = 0.0, v_ref[3] = {0};
    rk4_to_height(&layer, d, mass, y0, 2e-10, couple_flight_wall_contact_z(&layer, d), &t_ref, v_ref);
    CHECK(r.reached, "the 20 um particle reaches the wall");
    CHECK_CLOSE(r.t, t_ref, 1e-7, 0.0, "arrival time against RK4");
    for (int k = 0; k < 3; k++)
        CHECK_CLOSE(r.v[k], v_ref[k], 1e-6, 1e-6, "velocity at the wall against RK4");
    struct couple_flight_layer free_jet = layer;
    free_jet.gas.stagnation_factor = 0.0;
    dem_gas_set_wall(&free_jet.gas, layer.gas.wall_z);
    struct couple_flight_result unslowed;
    CHECK(couple_flight_integrate(solver, &free_jet, d, rho, 0.0, x0, v0, couple_flight_wall_contact_z(&free_jet, d),
                                  &unslowed) == SC_OK,
          "flight: %s", sc_error_message());
    CHECK(r.v[2] < unslowed.v[2] - 5.0, "the stagnation flow slows the particle (%g m/s, %g m/s in the free jet)",
          r.v[2], unslowed.v[2]);
    couple_flight_result_free(&unslowed);
    CHECK(r.v[0] > v0[0], "the wall jet pushes it outwards (v_x %g > %g m/s)", r.v[0], v0[0]);
    CHECK(r.steps > 0 && r.rhs_evals >= r.steps && r.samples == (size_t)r.steps + 1,
          "counters: %ld steps, %ld rhs, %zu samples", r.steps, r.rhs_evals, r.samples);
    couple_flight_result_free(&r);
}

/* A first contact with a deposit 60 um above the target plane (the couple stage's candidates, couple_candidate_stop_z):
 * the flight stops where the centre reaches that contact's height, with the velocity RK4 gives at that height, not
 * flown on to the target plane (it flew on: 0.1-0.2 us later, v_z ~1 m/s lower, a review). */
static void test_stop_at_deposit_height(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    const double d = 20e-6, rho = 2700.0, mass = rho * M_PI * d * d * d / 6.0;
    const double x0[3] = {1e-3, -0.5e-3, 0.022}, v0[3] = {5.0, -2.0, 600.0};
    struct couple_candidate deposit = {.partner = 7, .d = d, .x = {1.2e-3, -0.6e-3, 0.0}};
    deposit.x[2] = couple_flight_wall_contact_z(&layer, d) - 60e-6;
    struct couple_candidate target = deposit;
    target.partner = -1;
    double stop_z = couple_candidate_stop_z(&layer, &deposit);
    CHECK(stop_z == deposit.x[2], "a deposit's contact: the flight stops at its centre height (%.17g m)", stop_z);
    CHECK(couple_candidate_stop_z(&layer, &target) == layer.gas.wall_z - 0.5 * d,
          "the target's contact: the flight stops at the wall, wall_z - d/2");
    struct couple_flight_result r;
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, stop_z, &r) == SC_OK, "flight: %s",
          sc_error_message());
    double y0[6] = {x0[0], x0[1], x0[2], v0[0], v0[1], v0[2]}, t_ref = 0.0, v_ref[3] = {0}, t_wall = 0.0, v_wall[3];
    rk4_to_height(&layer, d, mass, y0, 2e-10, stop_z, &t_ref, v_ref);
    rk4_to_height(&layer, d, mass, y0, 2e-10, couple_flight_wall_contact_z(&layer, d), &t_wall, v_wall);
    CHECK(r.reached, "the particle reaches the deposit's height");
    CHECK_CLOSE(r.x[2], stop_z, 0.0, 1e-12, "the flight ends at the deposit's height (m)");
    CHECK_CLOSE(r.t, t_ref, 1e-7, 0.0, "arrival time at that height against RK4");
    for (int k = 0; k < 3; k++)
        CHECK_CLOSE(r.v[k], v_ref[k], 1e-6, 1e-6, "velocity at that height against RK4");
    printf("  60 um above the wall: v_z %.6g m/s (RK4 %.6g); at the wall %.6g m/s, %.3g us later\n", r.v[2], v_ref[2],
           v_wall[2], 1e6 * (t_wall - t_ref));
    /* the test can tell the two: the 60 um to the target plane take ~0.1 us and change v_z by more than its bound */
    CHECK(t_wall - t_ref > 5e-8 && fabs(v_wall[2] - v_ref[2]) > 1e-4 * fabs(v_ref[2]),
          "the target plane is distinguishable: %g s later, v_z %.6g against %.6g m/s", t_wall - t_ref, v_wall[2],
          v_ref[2]);
    couple_flight_result_free(&r);
}

/* A 0.1 um particle with Stokes drag on the axis: drag response time tau = 50 ns against a flight of tens of
 * microseconds (stiff: an explicit method needs a step below 2 tau, here RK4 at tau/25).  It slows with the gas,
 * whose axial speed falls to zero at the wall, and arrives at a tiny speed, never passing the wall. */
static void test_stiff_particle(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    layer.gas.drag = DEM_DRAG_STOKES;
    layer.rtol = 1e-8;
    layer.atol = 1e-12;
    const double d = 0.1e-6, rho = 2700.0, s0 = 1e-3, speed0 = 300.0, mass = rho * M_PI * d * d * d / 6.0;
    const double x0[3] = {0.0, 0.0, layer.gas.wall_z - s0}, v0[3] = {0.0, 0.0, speed0};
    struct couple_flight_result r;
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, couple_flight_wall_contact_z(&layer, d), &r) ==
              SC_OK,
          "flight: %s", sc_error_message());
    CHECK(r.reached, "the fine particle reaches the wall");
    CHECK(r.steps < 1000, "BDF steps stay few for a stiff particle: %ld", r.steps);
    double contact_z = layer.gas.wall_z - 0.5 * d;
    int passed = 0;
    for (size_t i = 0; i < r.samples; i++)
        passed |= r.sample_x[3 * i + 2] > contact_z * (1.0 + 1e-12);
    CHECK(!passed, "no trajectory sample beyond the wall");
    double mu = layer.gas.density * layer.gas.kinematic_viscosity, tau = rho * d * d / (18.0 * mu);
    double y0[6] = {x0[0], x0[1], x0[2], v0[0], v0[1], v0[2]}, t_ref = 0.0, v_ref[3] = {0};
    rk4_to_height(&layer, d, mass, y0, tau / 25.0, couple_flight_wall_contact_z(&layer, d), &t_ref, v_ref);
    CHECK(t_ref / tau > 100.0, "a stiff case: flight / tau = %g", t_ref / tau);
    CHECK_CLOSE(r.t, t_ref, 1e-5, 0.0, "arrival time against RK4");
    CHECK_CLOSE(r.v[2], v_ref[2], 1e-4, 0.0, "arrival speed against RK4");
    CHECK(r.v[2] < 1e-3 * speed0, "the stagnation flow stops the fine particle (%g m/s)", r.v[2]);
    couple_flight_result_free(&r);
}

int main(void)
{
    if (couple_flight_solver_create(&solver) != SC_OK) {
        printf("FAIL couple_flight_solver_create: %s\n", sc_error_message());
        return 1;
    }
    RUN(test_stokes_relaxation_table);
    RUN(test_nonstiff_against_rk4);
    RUN(test_stiff_particle);
    RUN(test_stop_at_deposit_height);
    couple_flight_solver_destroy(solver);
    return check_finish();
}
