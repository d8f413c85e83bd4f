/* coupling: the last flight of a sprayed particle, from the hand-off plane to the wall, through the gas layer in
 * front of the target that the spray paper leaves out (Mukherjee & Zohdi, Section 6), integrated with SUNDIALS
 * CVODE (BDF, Newton iteration with a dense direct linear solver).
 *
 * The gas (spray frame: +z towards the target, the wall is the plane z = wall_z, the spray axis is x = y = 0):
 * an axisymmetric stagnation-point flow of thickness delta in front of the wall, approached by a uniform stream
 * of speed U along +z (notes/coldspray.md Section 3: the Hiemenz-type layer behind the wall shock),
 *     s = wall_z - z (distance to the wall)
 *     s >= delta:      u = (0, 0, U)
 *     0 <= s < delta:  u_z = U s / delta,  u_x = U x / (2 delta),  u_y = U y / (2 delta)
 * which is divergence-free in both regions (radial outflow from continuity: (1/r) d(r u_r)/dr = U / delta) and
 * continuous in u_z at s = delta; delta = 0 is a uniform stream up to the wall.  The gas is not disturbed by the
 * particles (one-way coupling, as in the spray stage).  The particle: a rigid sphere of diameter d and density
 * rho_p, m dv/dt = F_drag(v, u) with the drag law of [jet] (Haider-Levenspiel Eq. 25 or Stokes); no gravity.
 * The flight ends when the sphere touches the wall (centre at wall_z - d/2, found by CVODE's root finding) or
 * at a time limit: a fine particle carried by the outflow may approach the wall only asymptotically. */
#ifndef SPRAYCOAT_COUPLING_FLIGHT_H
#define SPRAYCOAT_COUPLING_FLIGHT_H

#include <stddef.h>

#include "dem/dem.h"

struct flight_layer {
    struct gas_field gas;       /* density, kinematic viscosity and drag law; model none: no gas, no drag */
    double wall_z;              /* m, the wall plane (spray frame) */
    double thickness;           /* m, delta */
    double approach_velocity;   /* m/s, U */
    double rtol;                /* CVODE relative tolerance */
    double atol;                /* absolute tolerance, relative to the scales: positions atol * (distance to the
                                   wall at the start), velocities atol * (speed at the start, at least 1 m/s) */
};

struct flight_result {
    int reached;                /* 1: the sphere touched the wall; 0: stopped at the time limit */
    double t, x[3], v[3];       /* at the wall (or at the time limit) */
    long steps, rhs_evals, jac_evals, error_test_failures, nonlinear_iterations, nonlinear_failures;
    size_t samples;             /* the trajectory at every internal CVODE step, the start included */
    double *sample_t, *sample_x, *sample_v;   /* samples, 3 * samples, 3 * samples */
};

/* Gas velocity u[3] at x[3] (the formula above). */
void flight_gas_velocity(const struct flight_layer *layer, const double x[3], double u[3]);

/* The time limit of a flight starting at z0 with axial speed vz0: 100 times the time to the wall at that speed
 * (at least 1 m/s). */
double flight_time_limit(const struct flight_layer *layer, double z0, double vz0);

struct flight_solver;

int flight_solver_create(struct flight_solver **out);
void flight_solver_destroy(struct flight_solver *solver);

/* Integrate one particle (diameter d, density rho_p) from (t0, x0, v0) to the wall.  The result's sample arrays
 * are owned by *result (flight_result_free).  SC_ESIM when CVODE fails (the message names its flag). */
int flight_integrate(struct flight_solver *solver, const struct flight_layer *layer, double diameter, double density,
                     double t0, const double x0[3], const double v0[3], struct flight_result *result);
void flight_result_free(struct flight_result *result);

#endif
