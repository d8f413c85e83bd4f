/* The last flight of a sprayed particle, from the hand-off plane to the wall: m dv/dt = F_drag(v, u) with
 * Mukherjee & Zohdi's drag, Eqs. 24-25, in the spray's own gas field, the jet impinging on the target (dem/,
 * dem_gas_velocity: the free jet above the wall region, the stagnation flow and the radial wall jet in it, below a
 * bow shock the compressed layer, whose density the drag takes: dem_gas_drag_force_at),
 * integrated with CVODE (BDF, Newton, dense linear solver); the flight ends at the stop height of the spray's first
 * contact, the wall or a deposit above it (root finding), or at a time limit. */
#include "coupling/coupling.h"

#include <cvode/cvode.h>
#include <math.h>
#include <nvector/nvector_serial.h>
#include <stdlib.h>
#include <string.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "core/error.h"

enum { STATE = 6, MAX_STEPS = 200000 };

struct couple_flight_solver {
    SUNContext context;
    N_Vector state, abstol;
    SUNMatrix jacobian;
    SUNLinearSolver linear;
    void *cvode;
    int initialised;
};

/* What the right-hand side and the root functions need. */
struct flight_particle {
    const struct couple_flight_layer *layer;
    double diameter, mass;
    double stop_z; /* the centre's height where the flight ends */
};

/* The time limit of a flight starting at z0 with axial speed vz0: 100 times the time to the stop height at that
 * speed (at least 1 m/s). */
static double flight_time_limit(double stop_z, double z0, double vz0)
{
    return 100.0 * fabs(stop_z - z0) / fmax(vz0, 1.0);
}

/* y = (x, y, z, vx, vy, vz): dx/dt = v, m dv/dt = F_drag(v, u(x)). */
static int flight_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void *data)
{
    (void)t;
    const struct flight_particle *p = data;
    const double *state = N_VGetArrayPointer(y);
    double *rate = N_VGetArrayPointer(ydot);
    double u[3], force[3];
    dem_gas_velocity(&p->layer->gas, state, u);
    dem_gas_drag_force_at(&p->layer->gas, p->diameter, state, state + 3, u, force);
    for (int k = 0; k < 3; k++) {
        rate[k] = state[3 + k];
        rate[3 + k] = force[k] / p->mass;
    }
    return 0;
}

/* Contact: the centre reaches the stop height (the wall's: the sphere's leading point at the wall, z + d/2 =
 * wall_z; a deposit's: the centre's height at the spray's contact with it). */
static int flight_contact(sunrealtype t, N_Vector y, sunrealtype *g, void *data)
{
    (void)t;
    const struct flight_particle *p = data;
    g[0] = p->stop_z - N_VGetArrayPointer(y)[2];
    return 0;
}

double couple_flight_wall_contact_z(const struct couple_flight_layer *layer, double diameter)
{
    return layer->gas.wall_z - 0.5 * diameter;
}

/* The spray's x of a first contact with a deposit is the centre there (dem/collide.c record_impact): where the
 * particle rests touching its obstacle (rest_position), or for a rebounder where the contact was found, on its
 * path; the spray took v_in there (velocity_at_contact).  Flying on to the target plane, up to ~100 um below the
 * top of a growing deposit, gave the MPM body a velocity the spray never judged (a review: 0.1-0.2 us later, 2-8 um
 * aside, v_z ~1 m/s off). */
double couple_candidate_stop_z(const struct couple_flight_layer *layer, const struct couple_candidate *candidate)
{
    return candidate->partner < 0 ? couple_flight_wall_contact_z(layer, candidate->d) : candidate->x[2];
}

void couple_flight_solver_destroy(struct couple_flight_solver *solver)
{
    if (!solver)
        return;
    CVodeFree(&solver->cvode);
    SUNLinSolFree(solver->linear);
    SUNMatDestroy(solver->jacobian);
    N_VDestroy(solver->abstol);
    N_VDestroy(solver->state);
    SUNContext_Free(&solver->context);
    free(solver);
}

int couple_flight_solver_create(struct couple_flight_solver **out)
{
    struct couple_flight_solver *solver = calloc(1, sizeof *solver);
    if (!solver)
        SC_FAIL_OOM(sizeof *solver, "the flight solver");
    int ok = SUNContext_Create(NULL, &solver->context) == 0;
    if (ok) {
        solver->state = N_VNew_Serial(STATE, solver->context);
        solver->abstol = N_VNew_Serial(STATE, solver->context);
        solver->jacobian = SUNDenseMatrix(STATE, STATE, solver->context);
        solver->cvode = CVodeCreate(CV_BDF, solver->context);
        ok = solver->state && solver->abstol && solver->jacobian && solver->cvode;
    }
    if (ok) {
        solver->linear = SUNLinSol_Dense(solver->state, solver->jacobian, solver->context);
        ok = solver->linear != NULL;
    }
    if (!ok) {
        couple_flight_solver_destroy(solver);
        SC_FAIL(SC_EIO, "flight: cannot create the CVODE solver (out of memory?)");
    }
    *out = solver;
    return SC_OK;
}

/* Contact, and the top of the wall region z = wall_z - H, where the gas velocity's derivatives jump (the free
 * jet's decay above, the stagnation profile below): the integration stops there and starts afresh, so that no
 * step straddles the kink in the right-hand side (CVODE's error control assumes a smooth one). */
static int flight_roots(sunrealtype t, N_Vector y, sunrealtype *g, void *data)
{
    const struct flight_particle *p = data;
    flight_contact(t, y, g, data);
    g[1] = p->layer->gas.wall_z - p->layer->gas.stagnation_height - N_VGetArrayPointer(y)[2];
    return 0;
}

/* The root functions of a flight that is `edge_ahead` of the wall region or already inside it. */
static int set_roots(struct couple_flight_solver *solver, int edge_ahead)
{
    int flag =
        edge_ahead ? CVodeRootInit(solver->cvode, 2, flight_roots) : CVodeRootInit(solver->cvode, 1, flight_contact);
    if (flag == CV_SUCCESS) {
        int direction[2] = {-1, -1}; /* the gaps close */
        flag = CVodeSetRootDirection(solver->cvode, direction);
    }
    return flag;
}

/* CVodeInit the first time, CVodeReInit after: every flight starts with a fresh history and fresh counters,
 * so a flight's result does not depend on the flights before it (docs/architecture.md, "Determinism and restart"). */
static int start_flight(struct couple_flight_solver *solver, struct flight_particle *particle, double t0,
                        double t_limit, int edge_ahead)
{
    int flag;
    if (!solver->initialised) {
        flag = CVodeInit(solver->cvode, flight_rhs, t0, solver->state);
        if (flag == CV_SUCCESS)
            flag = CVodeSetLinearSolver(solver->cvode, solver->linear, solver->jacobian);
        if (flag == CV_SUCCESS)
            flag = CVodeSetMaxNumSteps(solver->cvode, MAX_STEPS);
        /* CVODE's own error printing goes to stderr; the status is reported through our error path */
        if (flag == CV_SUCCESS)
            flag = CVodeSetErrFile(solver->cvode, NULL);
        solver->initialised = flag == CV_SUCCESS;
    } else {
        flag = CVodeReInit(solver->cvode, t0, solver->state);
    }
    if (flag == CV_SUCCESS)
        flag = set_roots(solver, edge_ahead);
    if (flag == CV_SUCCESS)
        flag = CVodeSetUserData(solver->cvode, particle);
    if (flag == CV_SUCCESS)
        flag = CVodeSetStopTime(solver->cvode, t_limit);
    if (flag != CV_SUCCESS)
        SC_FAIL(SC_ESIM, "flight: CVODE set-up failed (flag %d: %s)", flag, CVodeGetReturnFlagName(flag));
    return SC_OK;
}

static int record_sample(struct couple_flight_result *r, size_t *capacity, double t, const double *state)
{
    if (r->samples == *capacity) {
        size_t grown = *capacity ? 2 * *capacity : 64;
        double *times = realloc(r->sample_t, grown * sizeof *times);
        if (times)
            r->sample_t = times;
        double *positions = realloc(r->sample_x, 3 * grown * sizeof *positions);
        if (positions)
            r->sample_x = positions;
        double *velocities = realloc(r->sample_v, 3 * grown * sizeof *velocities);
        if (velocities)
            r->sample_v = velocities;
        if (!times || !positions || !velocities)
            SC_FAIL_OOM(7 * grown * sizeof *times, "the trajectory");
        *capacity = grown;
    }
    r->sample_t[r->samples] = t;
    memcpy(r->sample_x + 3 * r->samples, state, 3 * sizeof *state);
    memcpy(r->sample_v + 3 * r->samples, state + 3, 3 * sizeof *state);
    r->samples++;
    return SC_OK;
}

/* Add the counters of the current CVODE integration (a flight has two when it crosses the layer's edge). */
static void add_counters(void *cvode, struct couple_flight_result *r)
{
    long steps = 0, rhs = 0, jac = 0, error_tests = 0, iterations = 0, failures = 0;
    CVodeGetNumSteps(cvode, &steps);
    CVodeGetNumRhsEvals(cvode, &rhs);
    CVodeGetNumJacEvals(cvode, &jac);
    CVodeGetNumErrTestFails(cvode, &error_tests);
    CVodeGetNumNonlinSolvIters(cvode, &iterations);
    CVodeGetNumNonlinSolvConvFails(cvode, &failures);
    r->steps += steps;
    r->rhs_evals += rhs;
    r->jac_evals += jac;
    r->error_test_failures += error_tests;
    r->nonlinear_iterations += iterations;
    r->nonlinear_failures += failures;
}

/* At the layer's edge: a fresh integration from the current state with the contact root alone. */
static int restart_at_edge(struct couple_flight_solver *solver, double t, struct couple_flight_result *r)
{
    add_counters(solver->cvode, r);
    int flag = CVodeReInit(solver->cvode, t, solver->state);
    if (flag == CV_SUCCESS)
        flag = set_roots(solver, 0);
    if (flag != CV_SUCCESS)
        SC_FAIL(SC_ESIM, "flight: CVODE restart at the layer's edge failed (flag %d: %s)", flag,
                CVodeGetReturnFlagName(flag));
    return SC_OK;
}

/* Step by step (CV_ONE_STEP, every internal step is a trajectory sample) to the stop root or the time limit. */
static int integrate_steps(struct couple_flight_solver *solver, double t_limit, int edge_ahead,
                           struct couple_flight_result *r)
{
    size_t capacity = 0;
    double *state = N_VGetArrayPointer(solver->state);
    double t = r->t;
    SC_TRY(record_sample(r, &capacity, t, state));
    /* CVodeSetMaxNumSteps bounds the steps of one CVode call, and each call here takes one: the flight's own count */
    for (long steps = 1;; steps++) {
        int flag = CVode(solver->cvode, t_limit, solver->state, &t, CV_ONE_STEP);
        if (flag < 0)
            SC_FAIL(SC_ESIM, "flight: CVODE failed at step %ld, t = %.17g s, z = %.6g m (flag %d: %s)", steps, t,
                    state[2], flag, CVodeGetReturnFlagName(flag));
        if (steps > MAX_STEPS)
            SC_FAIL(SC_ESIM,
                    "flight: %d CVODE steps without reaching the stop height or the time limit (t = %.17g s, z = "
                    "%.6g m)",
                    MAX_STEPS, t, state[2]);
        SC_TRY(record_sample(r, &capacity, t, state));
        int found[2] = {0, 0};
        if (flag == CV_ROOT_RETURN)
            CVodeGetRootInfo(solver->cvode, found);
        if (flag == CV_ROOT_RETURN && edge_ahead && found[1] && !found[0]) {
            SC_TRY(restart_at_edge(solver, t, r));
            edge_ahead = 0;
            continue;
        }
        if (flag == CV_ROOT_RETURN || flag == CV_TSTOP_RETURN || t >= t_limit) {
            r->reached = flag == CV_ROOT_RETURN;
            break;
        }
    }
    add_counters(solver->cvode, r);
    r->t = t;
    memcpy(r->x, state, sizeof r->x);
    memcpy(r->v, state + 3, sizeof r->v);
    return SC_OK;
}

int couple_flight_integrate(struct couple_flight_solver *solver, const struct couple_flight_layer *layer,
                            double diameter, double density, double t0, const double x0[3], const double v0[3],
                            double stop_z, struct couple_flight_result *result)
{
    memset(result, 0, sizeof *result);
    struct flight_particle particle = {layer, diameter, density * M_PI * diameter * diameter * diameter / 6.0, stop_z};
    double *state = N_VGetArrayPointer(solver->state), *abstol = N_VGetArrayPointer(solver->abstol);
    double length = fmax(fabs(layer->gas.wall_z - x0[2]), diameter);
    double speed = fmax(sqrt(v0[0] * v0[0] + v0[1] * v0[1] + v0[2] * v0[2]), 1.0);
    for (int k = 0; k < 3; k++) {
        state[k] = x0[k];
        state[3 + k] = v0[k];
        abstol[k] = layer->atol * length;
        abstol[3 + k] = layer->atol * speed;
    }
    double t_limit = t0 + flight_time_limit(stop_z, x0[2], v0[2]);
    double height = layer->gas.stagnation_height;
    int edge_ahead = height > 0.0 && layer->gas.wall_z - x0[2] > height;
    SC_TRY(start_flight(solver, &particle, t0, t_limit, edge_ahead));
    int flag = CVodeSVtolerances(solver->cvode, layer->rtol, solver->abstol);
    if (flag != CV_SUCCESS)
        SC_FAIL(SC_ESIM, "flight: CVODE tolerances refused (flag %d)", flag);
    result->t = t0;
    int status = integrate_steps(solver, t_limit, edge_ahead, result);
    if (status != SC_OK)
        couple_flight_result_free(result);
    SC_TRY(status);
    return SC_OK;
}

void couple_flight_result_free(struct couple_flight_result *result)
{
    free(result->sample_t);
    free(result->sample_x);
    free(result->sample_v);
    result->sample_t = result->sample_x = result->sample_v = NULL;
    result->samples = 0;
}
