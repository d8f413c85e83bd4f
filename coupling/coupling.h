/* coupling: the physics between the spray and the impact stages (docs/physics.md "The couple stage"), one header: the
 * sampling of the spray's impacts into MPM seeds (couple.c) and the CVODE flight through the jet's wall region in front
 * of the target (flight.c). */
#ifndef SPRAYCOAT_COUPLING_COUPLING_H
#define SPRAYCOAT_COUPLING_COUPLING_H

#include <stddef.h>
#include <stdint.h>

#include "core/config.h"
#include "dem/dem.h"

/* coupling: from spray impacts to MPM seeds (the couple stage's sampling and placement, docs/physics.md).
 *
 * Candidates are the first contacts of particles with the target or the deposit (one per particle: the impact a
 * particle makes when it arrives; its later bounces are not new arrivals).  N = runs * bodies_per_run seeds are
 * drawn by one of three rules:
 *   random      uniform over the candidates, without replacement;
 *   stratified  by diameter quantiles, then by speed quantiles inside each diameter stratum: seed k belongs to
 *               diameter stratum k mod n_d (n_d = ceil(sqrt(N)) strata, each holding its share of the seeds as
 *               its share of the candidates: the first ones, with one seed more when n_d does not divide N, hold
 *               more), and inside it to one of the speed sub-strata of equal count, one per seed of that stratum;
 *               the seed is drawn uniformly from its sub-stratum;
 *   window      the candidates whose impact point lies in the square patch of side patch_size centred at
 *               (window_x, window_y) on the target, in order of arrival.
 * A drawn candidate whose flight does not reach its first contact (couple_candidate_stop_z) is replaced by the
 * next one of its stratum.  Seed k belongs to run k / bodies_per_run.
 *
 * Placement in the impact frame (substrate top z = 0, bodies above it moving towards -z): within a run, bodies in
 * order of arrival at their contacts (the wall, or a deposit above it: the flat substrate stands for either);
 * lateral offsets are the contact positions relative to the patch centre (window) or to
 * the run's first arrival folded periodically into the patch (random, stratified: the draws come from anywhere on
 * the target, so only their spacing within the patch is kept); the first arrival touches the substrate and a later
 * one starts |v_z| (t - t_first) c higher, c <= 1 the one factor for the run that puts the highest start at max_gap
 * (1 where all are lower: the arrival order and the ratios of the intervals kept), lifted further where it would
 * overlap an earlier body. */

enum couple_sample { COUPLE_RANDOM, COUPLE_STRATIFIED, COUPLE_WINDOW };

struct couple_config {
    enum couple_sample sample;
    long bodies_per_run, runs;
    double rtol, atol;
    double patch_size, window_x, window_y, max_gap; /* m */
    double reference_diameter; /* m: > 0, [impact] is a particle of this size, each run scaled to its own */
    uint32_t seed;             /* [run] seed */
};

extern const struct cfg_key couple_case_keys[];

int couple_config_load(const struct case_file *c, struct couple_config *cfg);

/* A candidate: the spray's impact (spray frame) and, once flown, its arrival at that contact. */
struct couple_candidate {
    int64_t impact_row, particle_id;
    int64_t partner;            /* the first contact's obstacle: -1 the target, else the deposited (or resting)
                                   particle's id (spray.h5 /impacts/partner) */
    double t, x[3], v[3], d, m; /* the spray's first contact: x its centre there (spray.h5 /impacts/x) */
    double temperature;         /* K, the particle's at that contact (spray.h5 /impacts/temperature) */
};

/* The strata of the sampling rule: every seed slot k (0 <= k < N) draws from stratum slot_stratum[k], whose
 * candidates (indices into the candidate array) are members[offset[s]] ... members[offset[s + 1] - 1] in the
 * order they are tried. */
struct couple_strata {
    size_t count;   /* strata */
    size_t *offset; /* count + 1 */
    size_t *members;
    size_t *slot_stratum; /* N */
};

/* Build the strata for `n` candidates and N = runs * bodies_per_run seeds.  SC_EINPUT (naming [couple] keys)
 * when the rule cannot give N seeds: fewer candidates than seeds, or fewer in the window. */
int couple_strata_build(const struct case_file *c, const struct couple_config *cfg,
                        const struct couple_candidate *candidates, size_t n, struct couple_strata *strata);
void couple_strata_free(struct couple_strata *strata);

/* One seed's arrival at its first contact (spray frame; "wall" in the names: the target plane, or a deposit above
 * it) and, after placement, its body in the impact frame. */
struct couple_seed {
    size_t candidate; /* index into the candidate array */
    size_t flight;    /* row of its flight in couple.h5 /flight */
    double t_wall, x_wall[3], v_wall[3], d, m;
    int64_t run, body;
    double center[3], velocity[3]; /* impact frame */
    double temperature;            /* K, the particle's (its candidate's): the body starts at it */
};

/* The `count` seeds (slot order) into their runs, bodies_per_run a run in array order (seed k in run k /
 * bodies_per_run).  stratified with several bodies a run: shuffled first (seeded by [run] seed), so that a run
 * holds draws of every speed quantile alike; in slot order run r held the r-th speed quantile of every diameter
 * quantile (a review: 3 x 3 put the slowest third of each size in run 0). */
void couple_assign_runs(const struct couple_config *cfg, struct couple_seed *seeds, size_t count);

/* Order the `count` seeds of one run by arrival and place them (the header's rules). */
void couple_place_run(const struct couple_config *cfg, struct couple_seed *seeds, size_t count);

/* coupling: the last flight of a sprayed particle, from the hand-off plane to its first contact, through the gas in
 * front of the target that the spray paper leaves out (Mukherjee & Zohdi, Section 6), integrated with SUNDIALS CVODE
 * (BDF, Newton iteration with a dense direct linear solver).
 *
 * The gas is the spray's (dem_gas_velocity, docs/physics.md "The jet at the wall"): in the spray frame (+z towards
 * the target, the wall is the plane z = gas.wall_z, the spray axis is x = y = 0) the free jet of Eqs. 26-27 above
 * the wall region z < wall_z - H, and in it the stagnation flow whose axial velocity falls to zero at the wall and
 * the radial wall jet it feeds: the spray stage decides stick or rebound with the velocity the particle has after
 * crossing the same field.  The gas is not disturbed by the particles (one-way coupling, as in the spray stage).
 * The particle: a rigid sphere of diameter d and density rho_p, m dv/dt = F_drag(v, u) with the spray's drag
 * (dem_gas_drag_force_at, on the gas dem_config_load made): [jet]'s density, viscosity and law (Haider-Levenspiel
 * Eq. 25, Stokes or Henderson), but with [nozzle] the density and viscosity [jet] does not give are the nozzle
 * exit's and drag = auto is Henderson's, and below a bow shock the layer's rho2 and nu2; no gravity.  The flight ends
 * when the sphere's centre reaches a stop height (found by CVODE's root finding) or at a time limit: a fine particle
 * carried by the wall jet may approach the wall only asymptotically.  The stop height is the spray's first contact's:
 * the wall's, wall_z - d/2, where that contact was with the target; the centre's height at the contact where it was
 * with a deposit, which lies above the target plane (couple_candidate_stop_z). */

struct couple_flight_layer {
    struct dem_gas_field gas; /* the spray's gas, its wall placed (dem_gas_set_wall); model none: no gas, no drag */
    double rtol;              /* CVODE relative tolerance */
    double atol;              /* absolute tolerance, relative to the scales: positions atol * (distance to the
                                 wall at the start), velocities atol * (speed at the start, at least 1 m/s) */
};

struct couple_flight_result {
    int reached;          /* 1: the centre reached the stop height; 0: stopped at the time limit */
    double t, x[3], v[3]; /* at the stop height (or at the time limit) */
    long steps, rhs_evals, jac_evals, error_test_failures, nonlinear_iterations, nonlinear_failures;
    size_t samples;                         /* the trajectory at every internal CVODE step, the start included */
    double *sample_t, *sample_x, *sample_v; /* samples, 3 * samples, 3 * samples */
};

struct couple_flight_solver;

int couple_flight_solver_create(struct couple_flight_solver **out);
void couple_flight_solver_destroy(struct couple_flight_solver *solver);

/* The centre's height when a sphere of this diameter touches the wall: wall_z - d/2. */
double couple_flight_wall_contact_z(const struct couple_flight_layer *layer, double diameter);

/* The height at which the candidate's flight stops: where the spray's first contact was.  With the target, the
 * wall's contact height; with a deposit, the centre's height at that contact, x[2] (the centre where the particle
 * stuck or came to rest, touching its obstacle; a rebounder's where the contact was found: spray.h5 /impacts). */
double couple_candidate_stop_z(const struct couple_flight_layer *layer, const struct couple_candidate *candidate);

/* Integrate one particle (diameter d, density rho_p) from (t0, x0, v0) until its centre reaches the height stop_z
 * (z grows towards the wall: stop_z > x0[2]; one that starts past it ends at the time limit, not reached, and one
 * that starts on it has no time to fly: SC_ESIM).  The result's sample arrays are owned by *result
 * (couple_flight_result_free).  SC_ESIM when CVODE fails (the message names its flag). */
int couple_flight_integrate(struct couple_flight_solver *solver, const struct couple_flight_layer *layer,
                            double diameter, double density, double t0, const double x0[3], const double v0[3],
                            double stop_z, struct couple_flight_result *result);
void couple_flight_result_free(struct couple_flight_result *result);

#endif
