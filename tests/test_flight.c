/* The CVODE flight through the gas layer in front of the target (coupling/flight.h): Stokes relaxation against
 * ../shared/verification/stokes_relaxation.csv, a non-stiff Haider-Levenspiel flight against a fine explicit
 * reference, and a stiff sub-micron particle that follows the stagnation flow to the wall in few steps and never
 * passes it. */
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
    struct couple_flight_layer layer = {
        .wall_z = wall_z, .thickness = 0.0, .approach_velocity = 100.0, .rtol = 1e-10, .atol = 1e-12};
    layer.gas.model = DEM_JET_UNIFORM;
    layer.gas.drag = DEM_DRAG_STOKES;
    layer.gas.density = 1.2;
    layer.gas.kinematic_viscosity = 1.8e-5 / 1.2;
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
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, &r) == SC_OK, "flight: %s", sc_error_message());
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

/* The reference knows which side of the layer's edge a step belongs to (a sub-stage of the step that ends on the
 * edge may land a rounding error beyond it): upstream the uniform stream, inside the layer the layer's field. */
static int reference_inside_layer;

static void reference_rate(const struct couple_flight_layer *layer, double d, double mass, const double y[6],
                           double dy[6])
{
    double u[3] = {0.0, 0.0, layer->approach_velocity}, force[3];
    if (reference_inside_layer) { /* the stagnation-point flow, written out independently of flight.c */
        double rate = layer->approach_velocity / layer->thickness;
        u[0] = 0.5 * rate * y[0];
        u[1] = 0.5 * rate * y[1];
        u[2] = rate * (layer->wall_z - y[2]);
    }
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

/* RK4 until the gap closes.  A step that would cross the layer's edge (where u_x, u_y jump) or the contact plane
 * is replaced by the step that ends on it, so that no step straddles the jump. */
static void rk4_to_wall(const struct couple_flight_layer *layer, double d, double mass, const double y0[6], double h,
                        double *t_wall, double v_wall[3])
{
    double y[6], t = 0.0;
    memcpy(y, y0, sizeof y);
    double contact_z = layer->wall_z - 0.5 * d, edge_z = layer->wall_z - layer->thickness;
    int edge_ahead = layer->thickness > 0.5 * d && y[2] < edge_z;
    reference_inside_layer = !edge_ahead;
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
        reference_inside_layer = 1;
    }
    *t_wall = t;
    memcpy(v_wall, y + 3, 3 * sizeof *v_wall);
}

static struct couple_flight_layer cold_spray_layer(void)
{
    struct couple_flight_layer layer = {
        .wall_z = 0.05, .thickness = 2e-3, .approach_velocity = 450.0, .rtol = 1e-10, .atol = 1e-12};
    layer.gas.model = DEM_JET_UNIFORM;
    layer.gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    layer.gas.density = 2.0;
    layer.gas.kinematic_viscosity = 1.5e-5;
    return layer;
}

static void test_nonstiff_against_rk4(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    const double d = 20e-6, rho = 2700.0, mass = rho * M_PI * d * d * d / 6.0;
    /* from the hand-off plane 5 mm before the wall, off axis and slightly oblique */
    const double x0[3] = {1e-3, -0.5e-3, 0.045}, v0[3] = {5.0, -2.0, 600.0};
    struct couple_flight_result r;
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, &r) == SC_OK, "flight: %s", sc_error_message());
    double y0[6] = {x0[0], x0[1], x0[2], v0[0], v0[1], v0[2]}, t_ref = 0.0, v_ref[3] = {0};
    rk4_to_wall(&layer, d, mass, y0, 2e-10, &t_ref, v_ref);
    CHECK(r.reached, "the 20 um particle reaches the wall");
    CHECK_CLOSE(r.t, t_ref, 1e-7, 0.0, "arrival time against RK4");
    for (int k = 0; k < 3; k++)
        CHECK_CLOSE(r.v[k], v_ref[k], 1e-6, 1e-6, "velocity at the wall against RK4");
    CHECK(r.v[2] < v0[2], "the layer slows the particle (%g < %g m/s)", r.v[2], v0[2]);
    CHECK(r.steps > 0 && r.rhs_evals >= r.steps && r.samples == (size_t)r.steps + 1,
          "counters: %ld steps, %ld rhs, %zu samples", r.steps, r.rhs_evals, r.samples);
    couple_flight_result_free(&r);
}

/* A 0.1 um particle with Stokes drag: drag response time tau = 50 ns against a flight of tens of microseconds
 * (stiff: an explicit method would need a step below 2 tau).  Inside the layer the motion is linear,
 *     tau s'' + s' + (U / delta) s = 0    (s = distance to the wall),
 * so s(t) = A exp(l1 t) + B exp(l2 t) with the roots of tau l^2 + l + U/delta = 0: the arrival (s = d/2) and its
 * speed follow exactly.  The particle slows with the gas and reaches the wall at a tiny speed, never passing it. */
static double stokes_gap(const double a[2], const double l[2], double t)
{
    return a[0] * exp(l[0] * t) + a[1] * exp(l[1] * t);
}

static void test_stiff_particle(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    layer.gas.drag = DEM_DRAG_STOKES;
    layer.rtol = 1e-8;
    layer.atol = 1e-12;
    const double d = 0.1e-6, rho = 2700.0, s0 = 1e-3, speed0 = 300.0;
    const double x0[3] = {0.0, 0.0, layer.wall_z - s0}, v0[3] = {0.0, 0.0, speed0};
    struct couple_flight_result r;
    CHECK(couple_flight_integrate(solver, &layer, d, rho, 0.0, x0, v0, &r) == SC_OK, "flight: %s", sc_error_message());
    CHECK(r.reached, "the fine particle reaches the wall");
    CHECK(r.steps < 1000, "BDF steps stay few for a stiff particle: %ld", r.steps);
    double contact_z = layer.wall_z - 0.5 * d;
    int passed = 0;
    for (size_t i = 0; i < r.samples; i++)
        passed |= r.sample_x[3 * i + 2] > contact_z * (1.0 + 1e-12);
    CHECK(!passed, "no trajectory sample beyond the wall");
    /* the exact solution */
    double mu = layer.gas.density * layer.gas.kinematic_viscosity, tau = rho * d * d / (18.0 * mu);
    double k = layer.approach_velocity / layer.thickness, root = sqrt(1.0 - 4.0 * tau * k);
    double l[2] = {(-1.0 + root) / (2.0 * tau), (-1.0 - root) / (2.0 * tau)};
    double a[2]; /* s(0) = s0, s'(0) = -speed0 */
    a[0] = (-speed0 - l[1] * s0) / (l[0] - l[1]);
    a[1] = s0 - a[0];
    double lo = 0.0, hi = 1.0;
    while (stokes_gap(a, l, hi) > 0.5 * d)
        hi *= 2.0;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (stokes_gap(a, l, mid) > 0.5 * d)
            lo = mid;
        else
            hi = mid;
    }
    double t_exact = 0.5 * (lo + hi);
    double v_exact = -(a[0] * l[0] * exp(l[0] * t_exact) + a[1] * l[1] * exp(l[1] * t_exact));
    CHECK(tau * k < 0.05 && t_exact / tau > 100.0, "a stiff case: tau U/delta = %g, flight / tau = %g", tau * k,
          t_exact / tau);
    CHECK_CLOSE(r.t, t_exact, 1e-5, 0.0, "arrival time against the exact solution");
    CHECK_CLOSE(r.v[2], v_exact, 1e-4, 0.0, "arrival speed against the exact solution");
    CHECK(r.v[2] < 1e-3 * speed0, "the wall layer stops the fine particle (%g m/s)", r.v[2]);
    couple_flight_result_free(&r);
}

/* The gas layer itself: divergence-free and continuous where it meets the uniform stream. */
static void test_layer_gas_field(void)
{
    struct couple_flight_layer layer = cold_spray_layer();
    const double h = 1e-7, x[3] = {3e-4, -2e-4, layer.wall_z - 0.7e-3};
    double divergence = 0.0;
    for (int k = 0; k < 3; k++) {
        double plus[3] = {x[0], x[1], x[2]}, minus[3] = {x[0], x[1], x[2]}, up[3], um[3];
        plus[k] += h;
        minus[k] -= h;
        couple_flight_gas_velocity(&layer, plus, up);
        couple_flight_gas_velocity(&layer, minus, um);
        divergence += (up[k] - um[k]) / (2.0 * h);
    }
    CHECK(fabs(divergence) < 1e-6 * layer.approach_velocity / layer.thickness, "div u = %g /s", divergence);
    double below[3] = {0, 0, layer.wall_z - layer.thickness * (1 + 1e-12)}, u[3];
    couple_flight_gas_velocity(&layer, below, u);
    CHECK_CLOSE(u[2], layer.approach_velocity, 1e-9, 0.0, "u_z continuous at the layer's edge");
    double wall[3] = {1e-3, 0, layer.wall_z};
    couple_flight_gas_velocity(&layer, wall, u);
    CHECK(u[2] == 0.0 && u[0] > 0.0, "at the wall the gas flows outwards only (u_z %g, u_x %g)", u[2], u[0]);
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
    RUN(test_layer_gas_field);
    couple_flight_solver_destroy(solver);
    return check_finish();
}
