/* Time integration of the smooth forces (the gas drag) of the free particles: Mukherjee & Zohdi 2015,
 * Section 4.4, Eqs. (42)-(53).
 *
 * - Eqs. 42-43: the one-step phi-scheme for v and x (case key phi; 0.5, the trapezoidal rule the paper uses;
 *   0 explicit Euler).  Eq. 44's net force is here the drag alone (dem/gas_eval.h): contacts were applied as
 *   impulses at the start of the step (dem/collide.c).
 * - Eqs. 45-50: the fixed-point form; phi_problem_set holds the explicit parts R_v, R_x (Eqs. 48, 50).
 * - Eqs. 51-52: one fixed-point iterate (phi_iterate).
 * - Eq. 53: the convergence test, per particle: the drag depends only on the particle's own x and v, so the
 *   iteration decouples into one per particle (eq53_exact; eq53_shortcut decides most cases from the squares).
 *
 * Beyond the paper (docs/physics.md, "Integration"):
 * - A particle whose drag response time tau is below two steps is sub-cycled: k equal sub-steps, dt/k <= tau/2.
 * - The step ends at iterate k when Eq. 53 holds between k and k + 1 (k is within the tolerance by the same
 *   test), and the force at k, known, is kept as the next step's start force (struct dem_drag) while nothing
 *   else changes the particle (contacts, deposition and the target plane clear it; test: dem_reuse_drag).
 * - The first iterate starts from the end force extrapolated from the last step-end forces: 3 F_n - 3 F_n-1 +
 *   F_n-2, 2 F_n - F_n-1, or F_n itself (the paper's start).  Any start converges to the same fixed point
 *   within Eq. 53; the forces are checkpointed, so a resumed run gives the same bits.
 *
 * The equations are coded twice.  integrate_particle_reference, one particle in the order of the equations, is
 * the readable reference.  The block engine (struct block, integrate_block), which the program runs, computes
 * the same for 32 particles at once as vector lanes and must give identical bits: tests/test_spray_solver.c
 * (test_block_engine_matches_reference) compares the two.  Why the engine looks as it does is in the commit
 * messages. */

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/balance.h"
#include "core/error.h"
#include "dem/dem_impl.h"
#include "dem/gas_eval.h"

#define MAX_SUBSTEPS 100000
/* Particles integrated together: their start forces and first fixed-point iterations run as loops over the
 * block's lanes, which the compiler vectorises at -O3 (dem/gas_eval.h has no branches and no libm calls; no
 * `omp simd` here: it turns the lanes' small local arrays into memory and the loops stay scalar). */
#define BLOCK 32
/* Vectorised passes continue while more than this many lanes of a block iterate; the few that need more
 * iterations than the rest finish one by one (same arithmetic, same bits). */
#define BLOCK_MIN_ACTIVE 4

struct iteration_count {
    int64_t iterations, solves, unconverged, max_iterations, subcycled;
};

FM_INLINE double squared_difference(const double a[3], const double b[3])
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* The squared norms of Eq. 53: the change of v and x from the last iterate, and their progress from the start. */
struct eq53_squares {
    double change_v, change_x, progress_v, progress_x;
};

/* Eq. 53 per particle as written: |dv| + |dx| <= tol (|v - v0| + |x - x0|), or an exactly repeated iterate. */
FM_INLINE int eq53_exact(const struct eq53_squares *q, double tol)
{
    double change = sqrt(q->change_v) + sqrt(q->change_x);
    double progress = sqrt(q->progress_v) + sqrt(q->progress_x);
    return (change <= tol * progress) | (change == 0.0); /* bitwise: no branch, so loops vectorise */
}

/* Eq. 53 from the squares alone, without the four square roots: since |a| + |b| lies between
 * sqrt(a^2 + b^2) and sqrt(2 (a^2 + b^2)), the answer is certain unless the sums of squares are within a
 * factor 2 of each other (with 1e-12 to spare for rounding, and only where no square under- or overflows).
 * Returns 1 (holds), 0 (does not) or -1 (undecided: ask eq53_exact).  Where it answers, eq53_exact gives the
 * same answer, so the iteration is unchanged. */
FM_INLINE int eq53_shortcut(const struct eq53_squares *q, double tol)
{
    double change = q->change_v + q->change_x, progress = q->progress_v + q->progress_x;
    double bound = tol * tol * progress;
    int safe = (bound > 1e-250) & (progress < 1e300) & (change < 1e300);
    int holds = safe & (2.0 * change <= bound * (1.0 - 1e-12));
    int fails = safe & (change > 2.0 * bound * (1.0 + 1e-12));
    return holds - ((holds | fails) == 0); /* 1, 0 or -1 without a branch, so loops vectorise */
}

FM_INLINE int eq53_holds(const struct eq53_squares *q, double tol)
{
    int decided = eq53_shortcut(q, tol);
    return decided >= 0 ? decided : eq53_exact(q, tol);
}

/* The constants of one phi-scheme step of length h (Eqs. 47-52) and its start state. */
struct phi_problem {
    double d;                            /* diameter */
    double h_over_m_phi, h_phi;          /* h/m phi and h phi: the implicit parts */
    double x0[3], v0[3];                 /* start of the step */
    double residual_x[3], residual_v[3]; /* the explicit parts, Eqs. 48 and 50 */
};

FM_INLINE void phi_problem_set(struct phi_problem *problem, double phi, double d, double m, double h, const double x[3],
                               const double v[3], const double force_start[3])
{
    problem->d = d;
    problem->h_over_m_phi = h / m * phi;
    problem->h_phi = h * phi;
    double h_over_m_explicit = h / m * (1.0 - phi), h_explicit = h * (1.0 - phi);
    for (int c = 0; c < 3; c++) {
        problem->x0[c] = x[c];
        problem->v0[c] = v[c];
        problem->residual_v[c] = v[c] + h_over_m_explicit * force_start[c]; /* Eq. 48 */
        problem->residual_x[c] = x[c] + h_explicit * v[c];                  /* Eq. 50 */
    }
}

/* One fixed-point iterate (Eqs. 51-52) from (x_k, v_k) with the force there; returns the squares of Eq. 53. */
FM_INLINE struct eq53_squares phi_iterate(const struct phi_problem *problem, const double force[3], double x_k[3],
                                          double v_k[3])
{
    double v_next[3], x_next[3];
    for (int c = 0; c < 3; c++) {
        v_next[c] = problem->residual_v[c] + problem->h_over_m_phi * force[c]; /* Eqs. 47, 51 */
        x_next[c] = problem->residual_x[c] + problem->h_phi * v_next[c];       /* Eqs. 49, 52 */
    }
    struct eq53_squares q = {squared_difference(v_next, v_k), squared_difference(x_next, x_k),
                             squared_difference(v_next, problem->v0), squared_difference(x_next, problem->x0)};
    for (int c = 0; c < 3; c++) {
        v_k[c] = v_next[c];
        x_k[c] = x_next[c];
    }
    return q;
}

/* The drag force f at (x, v), with the slip and Re^0.6459 there, from which the response time follows
 * (gas_eval_response_time). */
FM_INLINE void drag_and_slip(const struct dem_gas_field *gas, double d, const double x[3], const double v[3],
                             double f[3], double *slip, double *reynolds_power)
{
    double u[3], relative[3];
    gas_eval_velocity(gas, x, u);
    struct gas_local local = gas_eval_local(gas, x); /* the bow shock's layer compresses the gas */
    *slip = gas_eval_slip(v, u, relative);
    *reynolds_power = gas_eval_reynolds_power(gas_eval_reynolds_in(local, d, *slip));
    gas_eval_drag_from_slip_in(gas, local, d, relative, *slip, *reynolds_power, f);
}

/* Where a step ended: whether the force there is known, and if so the force, slip and Re^0.6459. */
struct step_end {
    double force[3], slip, reynolds_power;
    int force_known;
};

/* Iterate from (x_k, v_k), the newest iterate (its force not yet known), whose count of iterates so far is
 * *iteration, until Eq. 53 holds or the limit.  Converged: (x_k, v_k) is left at the iterate that ends the
 * step, whose force, slip and Re^0.6459 go to *end.  Not converged: at the newest iterate, force unknown. */
static int phi_iterate_to_convergence(const struct dem_config *cfg, const struct phi_problem *problem, double x_k[3],
                                      double v_k[3], int64_t *iteration, struct step_end *end)
{
    end->force_known = 0;
    while (*iteration < cfg->fixed_point_max_iter) {
        double force[3], slip, power, x_next[3], v_next[3];
        drag_and_slip(&cfg->gas, problem->d, x_k, v_k, force, &slip, &power);
        memcpy(x_next, x_k, sizeof x_next);
        memcpy(v_next, v_k, sizeof v_next);
        struct eq53_squares q = phi_iterate(problem, force, x_next, v_next);
        ++*iteration;
        if (eq53_holds(&q, cfg->fixed_point_tol)) {
            memcpy(end->force, force, sizeof force);
            end->slip = slip;
            end->reynolds_power = power;
            end->force_known = 1;
            return 1;
        }
        memcpy(x_k, x_next, sizeof x_next);
        memcpy(v_k, v_next, sizeof v_next);
    }
    return 0;
}

static void count_solve(struct iteration_count *count, int64_t iterations, int converged)
{
    count->iterations += iterations;
    count->solves++;
    count->unconverged += !converged;
    if (iterations > count->max_iterations)
        count->max_iterations = iterations;
}

/* One phi-scheme step of length h from (x, v), whose force is force_start; the result replaces (x, v), and
 * *end says whether the force there is known.  The first iterate comes from the start force; if Eq. 53
 * holds for it already (it moved nothing, or phi = 0: explicit Euler), the step ends there. */
static void phi_step(const struct dem_config *cfg, double d, double m, double h, const double force_start[3],
                     double x[3], double v[3], struct iteration_count *count, struct step_end *end)
{
    struct phi_problem problem;
    phi_problem_set(&problem, cfg->phi, d, m, h, x, v, force_start);
    struct eq53_squares q = phi_iterate(&problem, force_start, x, v);
    int converged = eq53_holds(&q, cfg->fixed_point_tol) | (cfg->phi == 0.0);
    int64_t iteration = 1;
    end->force_known = 0;
    if (!converged)
        converged = phi_iterate_to_convergence(cfg, &problem, x, v, &iteration, end);
    count_solve(count, iteration, converged);
}

/* k phi-steps of h/k from (x, v), the first from force_start, each next one from the force where the last
 * ended (kept where its iteration converged, else computed); *end as the last one left it. */
static void phi_substeps(const struct dem_config *cfg, double d, double m, double h, int64_t k,
                         const double force_start[3], double x[3], double v[3], struct iteration_count *count,
                         struct step_end *end)
{
    double force[3], slip, power;
    memcpy(force, force_start, sizeof force);
    for (int64_t j = 0; j < k; j++) {
        if (j > 0 && end->force_known)
            memcpy(force, end->force, sizeof force);
        else if (j > 0)
            drag_and_slip(&cfg->gas, d, x, v, force, &slip, &power);
        phi_step(cfg, d, m, h / (double)k, force, x, v, count, end);
    }
}

/* The most sub-steps that a step whose fixed point did not converge is redone in (phi_redo_in_substeps). */
#define REDO_MOST_SUBSTEPS 16

/* A step of dt whose fixed-point iteration did not converge is redone from its start, problem's (x0, v0) with
 * force_start, in 2, 4, 8 and at most REDO_MOST_SUBSTEPS phi-steps, until every one converges.  The drag is
 * discontinuous across the bow shock's plane (the layer's density below it: docs/physics.md "The bow shock at
 * the target"): when the step's end lies within about phi h^2 |dF| / m of the plane, an iterate that ends above it
 * takes the drag of the free jet and sends the next below, which takes the layer's and sends the next above, and
 * the iteration cycles between the two, with no fixed point to find.  The band shrinks as h^2 and the chance that
 * a sub-step ends in it as h.  Returns whether the last try converged in every sub-step ((x, v) and *end are that
 * try's); its sub-steps' iterations are counted, not their solves: the step is one solve. */
static int phi_redo_in_substeps(const struct dem_config *cfg, double m, const struct phi_problem *problem,
                                const double force_start[3], double x[3], double v[3], struct iteration_count *count,
                                struct step_end *end)
{
    int converged = 0;
    for (int64_t k = 2; k <= REDO_MOST_SUBSTEPS && !converged; k *= 2) {
        struct iteration_count part = {0};
        memcpy(x, problem->x0, sizeof problem->x0);
        memcpy(v, problem->v0, sizeof problem->v0);
        phi_substeps(cfg, problem->d, m, cfg->dt, k, force_start, x, v, &part, end);
        count->iterations += part.iterations;
        converged = part.unconverged == 0;
    }
    return converged;
}

/* Where a step of dt from z0 to z1 crosses the bow shock's plane (the top of the wall region below a shock,
 * dem/gas_eval.h gas_eval_local), as the fraction of the step at which the straight line between them does; 0
 * when it does not cross. */
static double shock_crossing_fraction(const struct dem_gas_field *gas, double z0, double z1)
{
    if (!(gas->shock_standoff > 0.0))
        return 0.0;
    double plane = gas->wall_z - gas->stagnation_height;
    if ((z0 > plane) == (z1 > plane))
        return 0.0;
    return (plane - z0) / (z1 - z0);
}

/* Sub-steps for the rest of a step, of length h, for a particle of response time tau: h/k <= tau/2. */
static int64_t substeps_over(double h, double tau)
{
    if (!(tau < 2.0 * h))
        return 1;
    double k = ceil(2.0 * h / tau);
    return k > MAX_SUBSTEPS ? MAX_SUBSTEPS : (int64_t)k;
}

/* The time from (z0, vz) to the bow shock's plane under a constant acceleration az (the drag at the start, on
 * the start's side): the smallest positive root of z0 + vz t + az t^2 / 2 = plane, both roots in the stable form
 * (a particle moving away from the plane that the gas turns back has a negative root too); infinite if none. */
static double time_to_shock_plane(const struct dem_gas_field *gas, double z0, double vz, double az)
{
    double gap = gas->wall_z - gas->stagnation_height - z0;
    double discriminant = vz * vz + 2.0 * az * gap;
    if (!(discriminant >= 0.0))
        return INFINITY;
    double q = vz + copysign(sqrt(discriminant), vz), roots[2] = {INFINITY, INFINITY};
    if (q != 0.0)
        roots[0] = 2.0 * gap / q;
    if (az != 0.0)
        roots[1] = -q / az;
    double first = INFINITY;
    for (int k = 0; k < 2; k++)
        if (roots[k] > 0.0 && roots[k] < first)
            first = roots[k];
    return first;
}

/* A step of dt that crossed the bow shock's plane, redone from its start as two phi-steps that meet just short of
 * the plane.  The drag jumps there (the layer is shock_density_ratio times denser), and a phi-step across the jump
 * weighs the drags of its two ends by the scheme's phi, not by the time spent on either side: an error of first
 * order in dt (a 3 um Al particle at 400 m/s reached the target 4 % faster than CVODE's flight at dt = 1 us; 0.4 %
 * without the shock; tests/test_wall_jet.c).  The first part lasts until the plane under the start's drag
 * (time_to_shock_plane) less 1e-3 of it, and shorter again while its end is past the plane (whose drag it would
 * then take for the whole part) or its iteration cycles about it (four tries, else the step is left to
 * phi_redo_in_substeps); the second part from the far side's drag, in sub-steps of at most half the response time
 * tau_beyond on the plane's far side (the layer's is several times shorter than the free jet's, from which the
 * step's was taken).  Returns whether both parts converged. */
static int phi_redo_at_shock(const struct dem_config *cfg, double m, const struct phi_problem *problem,
                             const double force_start[3], double tau_beyond, double x[3], double v[3],
                             struct iteration_count *count, struct step_end *end)
{
    const struct dem_gas_field *gas = &cfg->gas;
    struct iteration_count part = {0};
    double force[3], slip, power;
    double h = (1.0 - 1e-3) * time_to_shock_plane(gas, problem->x0[2], problem->v0[2], force_start[2] / m);
    h = fmin(h, cfg->dt);
    int short_of_plane = 0;
    for (int attempt = 0; attempt < 4 && !short_of_plane; attempt++) {
        struct iteration_count first = {0};
        memcpy(x, problem->x0, sizeof problem->x0);
        memcpy(v, problem->v0, sizeof problem->v0);
        phi_step(cfg, problem->d, m, h, force_start, x, v, &first, end);
        count->iterations += first.iterations;
        double fraction = shock_crossing_fraction(gas, problem->x0[2], x[2]);
        int crossed = fraction > 0.0 && fraction < 1.0;
        short_of_plane = !crossed && !first.unconverged;
        if (!short_of_plane) /* past the plane, or cycling about it: end the first part further short of it */
            h *= crossed ? (1.0 - 1e-3) * fraction : 0.99;
    }
    if (!short_of_plane) /* not found in four tries: the step is redone in sub-steps (phi_step_checked) */
        return 0;
    /* the second part starts with the drag of the far side (the first part's end is just short of the plane:
     * its own drag, the near side's, would be blended into the second part's first sub-step) */
    double plane = gas->wall_z - gas->stagnation_height;
    double far_side[3] = {x[0], x[1], problem->x0[2] > plane ? plane : nextafter(plane, INFINITY)};
    drag_and_slip(gas, problem->d, far_side, v, force, &slip, &power);
    phi_substeps(cfg, problem->d, m, cfg->dt - h, substeps_over(cfg->dt - h, tau_beyond), force, x, v, &part, end);
    count->iterations += part.iterations;
    return part.unconverged == 0;
}

/* The end of a step of dt whose iteration ended at (x, v) (converged or not): a step that crossed the bow
 * shock's plane is redone in two parts that meet there (phi_redo_at_shock), and one whose iteration did not
 * converge in sub-steps (phi_redo_in_substeps).  Returns whether the step's result converged. */
static int phi_step_checked(const struct dem_config *cfg, double m, const struct phi_problem *problem,
                            const double force_start[3], int converged, double x[3], double v[3],
                            struct iteration_count *count, struct step_end *end)
{
    double fraction = shock_crossing_fraction(&cfg->gas, problem->x0[2], x[2]);
    if (fraction > 0.0 && fraction < 1.0) {
        double force[3], slip, power; /* at the end found: beyond the plane */
        drag_and_slip(&cfg->gas, problem->d, x, v, force, &slip, &power);
        double tau_beyond = gas_eval_response_time_in(&cfg->gas, gas_eval_local(&cfg->gas, x), cfg->powder.density,
                                                      problem->d, slip, power);
        converged = phi_redo_at_shock(cfg, m, problem, force_start, tau_beyond, x, v, count, end);
    }
    if (!converged)
        converged = phi_redo_in_substeps(cfg, m, problem, force_start, x, v, count, end);
    return converged;
}

/* Sub-steps for a particle of response time tau: dt/k <= tau/2. */
static int64_t substeps_for(const struct dem_config *cfg, double tau)
{
    if (!(tau < 2.0 * cfg->dt))
        return 1;
    double k = ceil(2.0 * cfg->dt / tau);
    return k > MAX_SUBSTEPS ? MAX_SUBSTEPS : (int64_t)k;
}

/* A particle whose response time is below two steps, in k sub-steps; force_start and tau at its start.  Each
 * sub-step starts from the force where the last one ended, when known. */
static void integrate_subcycled(const struct dem_config *cfg, double d, double m, double tau,
                                const double force_start[3], double x[3], double v[3], struct iteration_count *count)
{
    struct step_end end;
    phi_substeps(cfg, d, m, cfg->dt, substeps_for(cfg, tau), force_start, x, v, count, &end);
    count->subcycled++;
}

/* A particle whose velocity changed in this step's contacts (dem/collide.c) goes on from where its path
 * restarted, path_x at path_time, over the rest of the step, h = dt - path_time: the path along which the
 * contacts of the rest of the step were searched (docs/physics.md, "Contact detection").  The phi-scheme of
 * the reference from the drag there, computed afresh (a contact clears the kept drag), in sub-steps where
 * tau < 2 h; the force at the end, where known, is kept for the next step, with no history before it. */
/* (x, v) advanced by h under the drag of the gas at `side` (x itself, or a point just across the bow shock's
 * plane from it), in sub-steps where tau < 2 h. */
static void fly_part(const struct dem_config *cfg, double d, double m, double h, const double side[3], double x[3],
                     double v[3], struct iteration_count *count, struct step_end *end)
{
    double force[3], slip, power;
    drag_and_slip(&cfg->gas, d, side, v, force, &slip, &power);
    int64_t substeps = substeps_over(
        h, gas_eval_response_time_in(&cfg->gas, gas_eval_local(&cfg->gas, side), cfg->powder.density, d, slip, power));
    phi_substeps(cfg, d, m, h, substeps, force, x, v, count, end);
    count->subcycled += substeps > 1;
}

/* (x, v) advanced by h under the drag alone: the phi-scheme from the drag there, computed afresh, in sub-steps
 * where tau < 2 h (straight without gas); *end as the last sub-step left it.  A flight that reaches the bow
 * shock's plane within h is flown in two parts that meet just short of it, as phi_redo_at_shock redoes a step:
 * the second from the far side's drag, in sub-steps of its response time.  In one part, the sub-steps took the
 * near side's response time and each blended the drags of its two ends across the jump (0.37 % off for a 6 um
 * particle flown 1 us across it, tests/test_wall_jet.c test_flight_across_shock_plane); velocity_at_contact flies
 * a step's start to its contact through here. */
static void fly_under_drag(const struct dem_config *cfg, double d, double m, double h, double x[3], double v[3],
                           struct iteration_count *count, struct step_end *end)
{
    end->force_known = 0;
    if (cfg->gas.model == DEM_JET_NONE) {
        for (int c = 0; c < 3; c++)
            x[c] += h * v[c];
        return;
    }
    if (!(h > 0.0))
        return;
    double near = h, z0 = x[2];
    if (cfg->gas.shock_standoff > 0.0) {
        double force[3], slip, power;
        drag_and_slip(&cfg->gas, d, x, v, force, &slip, &power);
        near = fmin(h, (1.0 - 1e-3) * time_to_shock_plane(&cfg->gas, x[2], v[2], force[2] / m));
    }
    fly_part(cfg, d, m, near, x, x, v, count, end);
    if (near < h) {
        /* the far side is the side the flight did not start on (as phi_redo_at_shock takes it from the step's
         * start): the first part's end may lie a little past the plane (its time came from the start's drag, which
         * weakens as a fast particle slows), and the plane itself is the free jet's side (a review: a 2 um particle
         * at 1200 m/s ended 3 um past it and flew on through the layer with the jet's drag, 3.4 % off) */
        double plane = cfg->gas.wall_z - cfg->gas.stagnation_height;
        double far_side[3] = {x[0], x[1], z0 > plane ? plane : nextafter(plane, INFINITY)};
        fly_part(cfg, d, m, h - near, far_side, x, v, count, end);
    }
}

void dem_fly_under_drag(const struct dem_config *cfg, double d, double m, double h, double x[3], double v[3])
{
    struct iteration_count uncounted = {0};
    struct step_end end;
    fly_under_drag(cfg, d, m, h, x, v, &uncounted, &end);
}

static void integrate_rest_of_step(const struct dem_solver *s, struct dem_particles *p, uint32_t i,
                                   struct iteration_count *count)
{
    const struct dem_config *cfg = &s->cfg;
    double x[3], v[3];
    memcpy(x, s->path_x + 3 * i, sizeof x);
    memcpy(v, p->v + 3 * i, sizeof v);
    struct step_end end;
    fly_under_drag(cfg, p->d[i], p->m[i], cfg->dt - s->path_time[i], x, v, count, &end);
    /* a hand-off crossing in this step takes the end velocity (dem/solver.c record_handoff): the one before the
     * contact, kept in v_start until now, is not one to interpolate from */
    memcpy(p->v_start + 3 * i, v, sizeof v);
    struct dem_drag *drag = &p->drag;
    for (int c = 0; c < 3; c++) {
        p->x[3 * i + c] = x[c];
        p->v[3 * i + c] = v[c];
        drag->forces[dem_drag_slot(s->step + 1, 0)][c][i] = end.force_known ? end.force[c] : 0.0;
    }
    drag->slip[i] = end.force_known ? end.slip : 0.0;
    drag->reynolds_power[i] = end.force_known ? end.reynolds_power : 0.0;
    drag->history_count[i] = 0;
    drag->kept[i] = (uint8_t)end.force_known;
}

/* ---------------------------------------------------------------------------------------------------------
 * The drag skins (dem_impl.h, dem_skin_from_force): from the force at each moving particle's start state,
 * the kept one where there is one (the same bits as computed afresh), else computed. */
static void ensure_skin_capacity(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    if (p->capacity <= s->skin_capacity && p->skin)
        return;
    size_t old = p->skin ? s->skin_capacity : 0, capacity = p->capacity ? p->capacity : 1;
    p->skin = dem_realloc_or_die(p->skin, capacity * sizeof *p->skin);
    memset(p->skin + old, 0, (capacity - old) * sizeof *p->skin);
    s->skin_capacity = capacity;
}

void dem_drag_skins(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    const struct dem_config *cfg = &s->cfg;
    ensure_skin_capacity(s);
    const int no_gas = cfg->gas.model == DEM_JET_NONE, reuse = s->reuse_drag;
    const int slot = dem_drag_slot(s->step, 0);
    const size_t count = s->moving_count;
#pragma omp parallel for schedule(static) if (count >= DEM_PARALLEL_MIN)
    for (size_t k = 0; k < count; k++) {
        uint32_t i = s->moving[k];
        double f[3] = {0.0, 0.0, 0.0}, slip = 0.0, power;
        if (no_gas) {
            p->skin[i] = 0.0;
            continue;
        }
        if (reuse && p->drag.kept[i]) {
            for (int c = 0; c < 3; c++)
                f[c] = p->drag.forces[slot][c][i];
            slip = p->drag.slip[i];
        } else {
            drag_and_slip(&cfg->gas, p->d[i], p->x + 3 * i, p->v + 3 * i, f, &slip, &power);
        }
        p->skin[i] = dem_skin_from_force(cfg, f, slip, p->m[i]);
    }
}

void dem_drag_skin_after_contact(struct dem_solver *s, uint32_t i, const double x[3])
{
    struct dem_particles *p = &s->p;
    double f[3] = {0.0, 0.0, 0.0}, slip = 0.0, power;
    if (s->cfg.gas.model != DEM_JET_NONE)
        drag_and_slip(&s->cfg.gas, p->d[i], x, p->v + 3 * i, f, &slip, &power);
    p->skin[i] = dem_skin_from_force(&s->cfg, f, slip, p->m[i]);
}

/* ---------------------------------------------------------------------------------------------------------
 * The reference: one free particle over one step, the equations in order.  This is the readable statement of
 * what the block engine below computes for 32 particles at once; the engine must give its bits (x, v, the kept
 * drag and the iteration counts), which tests/test_spray_solver.c checks (test_block_engine_matches_reference).
 *
 * 1. The start force F_n: the kept one (reuse_drag and the particle's drag kept), else the drag at (x, v).
 * 2. The response time tau there; below two steps (or not finite) the particle is sub-cycled
 *    (integrate_subcycled: phi-steps of dt/k from the start force; nothing is kept for the next step).
 * 3. Eqs. 48 and 50: the explicit parts; the first iterate (Eqs. 51-52) from the guess of the end force,
 *    extrapolated from the kept step-end forces: 3 F_n - 3 F_n-1 + F_n-2, 2 F_n - F_n-1, or F_n.
 * 4. Eq. 53 for the first iterate (it holds only if the iterate moved nothing; or phi = 0: explicit Euler),
 *    then the fixed-point iteration (phi_iterate_to_convergence): the step ends at iterate k when Eq. 53 holds
 *    between k and k + 1, with the force at k known.
 * 5. The drag kept for the next step: the force, slip and Re^0.6459 at the end where known (else zero, not
 *    kept), in the ring slot of the oldest force (dem_drag_slot); a start force computed afresh to its slot. */

/* The guess of the force at the end of the step from the last `chain` step-end forces (newest first: the start
 * force, then the ends of the two steps before).  The block engine's end_force_guess, as written there. */
static void end_force_guess_one(int chain, const double force_start[3], const double previous[2][3], double guess[3])
{
    for (int c = 0; c < 3; c++) {
        double newest = force_start[c], older = previous[0][c], oldest = previous[1][c];
        if (chain >= 3)
            guess[c] = oldest + 3.0 * (newest - older); /* quadratic: 3 F_n - 3 F_n-1 + F_n-2 */
        else if (chain == 2)
            guess[c] = newest + (newest - older); /* linear: 2 F_n - F_n-1 */
        else
            guess[c] = newest;
    }
}

static void integrate_particle_reference(const struct dem_config *cfg, struct dem_particles *p, int reuse_drag,
                                         int64_t step, size_t i, struct iteration_count *count)
{
    struct dem_drag *drag = &p->drag;
    const double d = p->d[i], m = p->m[i];
    double x[3], v[3], force_start[3], previous[2][3], slip, power;
    for (int c = 0; c < 3; c++) {
        x[c] = p->x[3 * i + c];
        v[c] = p->v[3 * i + c];
        previous[0][c] = drag->forces[dem_drag_slot(step, 1)][c][i];
        previous[1][c] = drag->forces[dem_drag_slot(step, 2)][c][i];
    }
    const int kept = drag->kept[i], chain = kept ? 1 + drag->history_count[i] : 0;
    /* 1. the start force */
    if (reuse_drag && kept) {
        for (int c = 0; c < 3; c++)
            force_start[c] = drag->forces[dem_drag_slot(step, 0)][c][i];
        slip = drag->slip[i];
        power = drag->reynolds_power[i];
    } else {
        drag_and_slip(&cfg->gas, d, x, v, force_start, &slip, &power);
        for (int c = 0; c < 3; c++)
            drag->forces[dem_drag_slot(step, 0)][c][i] = force_start[c];
    }
    /* 2. sub-cycled, or 3-4. one phi-step of dt */
    double tau =
        gas_eval_response_time_in(&cfg->gas, gas_eval_local(&cfg->gas, x), cfg->powder.density, d, slip, power);
    struct step_end end = {.force_known = 0};
    if (!(tau >= 2.0 * cfg->dt)) {
        integrate_subcycled(cfg, d, m, tau, force_start, x, v, count);
    } else {
        struct phi_problem problem;
        double guess[3];
        phi_problem_set(&problem, cfg->phi, d, m, cfg->dt, x, v, force_start);
        end_force_guess_one(chain, force_start, previous, guess);
        struct eq53_squares q = phi_iterate(&problem, guess, x, v);
        int converged = eq53_holds(&q, cfg->fixed_point_tol) | (cfg->phi == 0.0);
        int64_t iteration = 1;
        if (!converged)
            converged = phi_iterate_to_convergence(cfg, &problem, x, v, &iteration, &end);
        converged = phi_step_checked(cfg, m, &problem, force_start, converged, x, v, count, &end);
        count_solve(count, iteration, converged);
    }
    /* 5. the end state and the drag kept for the next step */
    for (int c = 0; c < 3; c++) {
        p->x[3 * i + c] = x[c];
        p->v[3 * i + c] = v[c];
        drag->forces[dem_drag_slot(step + 1, 0)][c][i] = end.force_known ? end.force[c] : 0.0;
    }
    drag->slip[i] = end.force_known ? end.slip : 0.0;
    drag->reynolds_power[i] = end.force_known ? end.reynolds_power : 0.0;
    drag->history_count[i] = (uint8_t)(end.force_known && chain > 0 ? (chain < 2 ? chain : 2) : 0);
    drag->kept[i] = (uint8_t)end.force_known;
}

/* ---------------------------------------------------------------------------------------------------------
 * The block engine: the reference above for BLOCK particles at once, as loops over lanes that vectorise.
 * Same operations in the same order for each lane, so the same bits; where the lanes part ways (sub-cycling,
 * the few that iterate longest) the lanes finish one by one with the scalar functions above. */

/* The particles of one block as structure of arrays: lane l is particle index[l]. */
struct block {
    size_t count;
    uint32_t index[BLOCK];
    /* whole cache lines: a 64-byte vector access to a block's array never spans two (allocated aligned) */
    _Alignas(64) double x[3][BLOCK];
    double v[3][BLOCK], d[BLOCK], m[BLOCK];
    double force_start[3][BLOCK], tau[BLOCK];
    /* struct phi_problem of each lane, as arrays */
    double x0[3][BLOCK], v0[3][BLOCK], residual_x[3][BLOCK], residual_v[3][BLOCK];
    double h_over_m_phi[BLOCK], h_phi[BLOCK];
    /* the force, slip and Re^0.6459 at (x, v) in the last pass */
    double force[3][BLOCK], slip[BLOCK], reynolds_power[BLOCK];
    /* the force, slip and Re^0.6459 at the iterate where the lane stopped (force_known) */
    double end_force[3][BLOCK], end_slip[BLOCK], end_reynolds_power[BLOCK];
    int64_t iterations[BLOCK];
    /* Byte flags on purpose: the narrowest type stored in a lane loop sets gcc's vectorisation factor, here
     * all 32 lanes at once, 8 independent 4-lane chains interleaved.  Each lane's body is one long chain of
     * dependent operations (square roots, the series of exp and log, divisions); with 64-bit flags gcc
     * vectorises 4 lanes at a time, the chains hardly overlap, and free flight took 1.7x the time.  The spills
     * of the 32-lane loop cost less (16 lanes as fast; the force evaluation split into one loop
     * per long chain, 4 lanes each, 8 % fewer instructions but no faster). */
    uint8_t active[BLOCK], converged[BLOCK], force_known[BLOCK], stops[BLOCK];
    /* the squares of Eq. 53 of the last iterate, and whether they left it undecided */
    double squares[4][BLOCK];
    uint8_t undecided[BLOCK];
    int start_kept; /* every lane's start force, slip and Re^0.6459 were kept (dem_particles: drag) */
    int64_t step;   /* the step: which ring slots of the kept forces are which (dem_drag_slot) */
    /* the forces at the ends of the two steps before (newest first) and how many step-end forces in a row are
     * known, the start force included (0-3): what the first iterate's guess is extrapolated from */
    double previous_force[2][3][BLOCK];
    uint8_t chain[BLOCK];
};

static inline void lane_get(const double soa[3][BLOCK], int l, double out[3])
{
    out[0] = soa[0][l];
    out[1] = soa[1][l];
    out[2] = soa[2][l];
}

static inline void lane_put(double soa[3][BLOCK], int l, const double in[3])
{
    soa[0][l] = in[0];
    soa[1][l] = in[1];
    soa[2][l] = in[2];
}

static inline struct phi_problem lane_problem(const struct block *b, int l)
{
    struct phi_problem problem = {.d = b->d[l], .h_over_m_phi = b->h_over_m_phi[l], .h_phi = b->h_phi[l]};
    lane_get(b->x0, l, problem.x0);
    lane_get(b->v0, l, problem.v0);
    lane_get(b->residual_x, l, problem.residual_x);
    lane_get(b->residual_v, l, problem.residual_v);
    return problem;
}

static inline void lane_put_problem(struct block *b, int l, const struct phi_problem *problem)
{
    b->h_over_m_phi[l] = problem->h_over_m_phi;
    b->h_phi[l] = problem->h_phi;
    lane_put(b->x0, l, problem->x0);
    lane_put(b->v0, l, problem->v0);
    lane_put(b->residual_x, l, problem->residual_x);
    lane_put(b->residual_v, l, problem->residual_v);
}

static inline void lane_put_squares(struct block *b, int l, const struct eq53_squares *q)
{
    b->squares[0][l] = q->change_v;
    b->squares[1][l] = q->change_x;
    b->squares[2][l] = q->progress_v;
    b->squares[3][l] = q->progress_x;
}

/* Is any of a block's byte flags set?  One vector test where a loop over the lanes would branch on each. */
static inline int any_lane(const uint8_t flags[BLOCK])
{
    uint8_t any = 0;
    for (int l = 0; l < BLOCK; l++)
        any |= flags[l];
    return any != 0;
}

/* Gas, drag and response time at the start of the step for every lane; the force, slip and Re^0.6459 may
 * have been kept from the end of the last step. */
FM_INLINE void start_forces_with(const struct dem_config *cfg, struct block *restrict b, const struct dem_gas_field gas)
{
    const double density = cfg->powder.density;
    if (!b->start_kept) {
        for (int l = 0; l < BLOCK; l++) {
            double x[3], v[3], force[3];
            lane_get(b->x, l, x);
            lane_get(b->v, l, v);
            drag_and_slip(&gas, b->d[l], x, v, force, &b->slip[l], &b->reynolds_power[l]);
            lane_put(b->force_start, l, force);
        }
    }
    for (int l = 0; l < BLOCK; l++) {
        double x[3];
        lane_get(b->x, l, x);
        b->tau[l] = gas_eval_response_time_in(&gas, gas_eval_local(&gas, x), density, b->d[l], b->slip[l],
                                              b->reynolds_power[l]);
    }
}

/* The usual gas, the jet with Haider-Levenspiel drag, is given to the loops below as constants: the selects on
 * the model and the law (dem/gas_eval.h) then fold away, where for any gas they are done in every lane. */
static int gas_is_usual(const struct dem_gas_field *gas)
{
    return gas->model == DEM_JET_BICKLEY && gas->drag == DEM_DRAG_HAIDER_LEVENSPIEL;
}

static struct dem_gas_field gas_usual(struct dem_gas_field gas)
{
    gas.model = DEM_JET_BICKLEY;
    gas.drag = DEM_DRAG_HAIDER_LEVENSPIEL;
    return gas;
}

static void block_start_forces(const struct dem_config *cfg, struct block *restrict b)
{
    if (gas_is_usual(&cfg->gas))
        start_forces_with(cfg, b, gas_usual(cfg->gas));
    else
        start_forces_with(cfg, b, cfg->gas);
}

/* The force at the end of lane l's step extrapolated from its start force and the forces at the ends of the
 * steps before (a polynomial in time through the last `chain` step-end forces, at most quadratic). */
FM_INLINE void end_force_guess(const struct block *b, int l, int all_quadratic, const double force_start[3],
                               double guess[3])
{
    int chain = all_quadratic ? 3 : b->chain[l];
    for (int c = 0; c < 3; c++) {
        double newest = force_start[c], older = b->previous_force[0][c][l], oldest = b->previous_force[1][c][l];
        double linear = newest + (newest - older);
        double quadratic = oldest + 3.0 * (newest - older);
        guess[c] = fm_select(chain >= 3, quadratic, fm_select(chain == 2, linear, newest));
    }
}

/* The first iterate (x, v are the start of the step, and become the iterate): does Eq. 53 hold for it?  Its
 * change from the last iterate, the start, is its progress from the start, so for tol < 1 (the case key
 * allows at most 0.1) change <= tol progress holds only for a change of 0 (it moved nothing) or of Inf
 * (Inf <= tol Inf); eq53_holds gives the same answers from the same squares.  Two squares, not four, and no square
 * roots. */
FM_INLINE int first_iterate_stops(const struct phi_problem *problem, const double force[3], double x[3], double v[3])
{
    double v_start[3] = {v[0], v[1], v[2]}, x_start[3] = {x[0], x[1], x[2]};
    for (int c = 0; c < 3; c++) {
        v[c] = problem->residual_v[c] + problem->h_over_m_phi * force[c]; /* Eqs. 47, 51 */
        x[c] = problem->residual_x[c] + problem->h_phi * v[c];            /* Eqs. 49, 52 */
    }
    /* the change |dv| + |dx| is 0 when both squares are, and Inf when one is Inf and the other not NaN */
    double square_v = squared_difference(v, v_start), square_x = squared_difference(x, x_start);
    return (square_v + square_x == 0.0) | ((square_v == INFINITY) & (square_x == square_x)) |
           ((square_x == INFINITY) & (square_v == square_v));
}

/* The first iterate of every lane that needs no sub-steps, from the guess of its end force (all_quadratic: every
 * lane's guess is the quadratic one). */
FM_INLINE void start_with(const struct dem_config *cfg, struct block *restrict b, int all_quadratic)
{
    const double phi = cfg->phi, dt = cfg->dt;
    const int more_allowed = 1 < cfg->fixed_point_max_iter;
    for (int l = 0; l < BLOCK; l++) {
        double x[3], v[3], force[3], guess[3];
        lane_get(b->x, l, x);
        lane_get(b->v, l, v);
        lane_get(b->force_start, l, force);
        end_force_guess(b, l, all_quadratic, force, guess);
        struct phi_problem problem;
        phi_problem_set(&problem, phi, b->d[l], b->m[l], dt, x, v, force);
        lane_put_problem(b, l, &problem);
        int converged = first_iterate_stops(&problem, guess, x, v) | (phi == 0.0); /* phi = 0: explicit Euler */
        lane_put(b->x, l, x);
        lane_put(b->v, l, v);
        b->converged[l] = (uint8_t)converged;
        b->force_known[l] = 0;
        b->iterations[l] = 1;
        b->active[l] = (uint8_t)((b->tau[l] >= 2.0 * dt) & !converged & more_allowed);
    }
}

/* The start forces, then the first iterates.  In steady flight every lane has three step-end forces to
 * extrapolate from, and the guess's selects fold away. */
static void block_start(const struct dem_config *cfg, struct block *restrict b)
{
    block_start_forces(cfg, b);
    uint8_t all_quadratic = 1;
    for (int l = 0; l < BLOCK; l++)
        all_quadratic &= (uint8_t)(b->chain[l] >= 3);
    if (all_quadratic)
        start_with(cfg, b, 1);
    else
        start_with(cfg, b, 0);
}

/* One more iterate for every lane still iterating (the inactive lanes are computed and dropped); returns how
 * many still iterate.  A lane for which Eq. 53 holds stays at its iterate, whose force is now known; the
 * others move on to the next iterate.  A lane that the squares leave undecided moves, or not, in
 * block_settle_moves. */
FM_INLINE int next_iterates_with(const struct dem_config *cfg, struct block *restrict b, const struct dem_gas_field gas)
{
    const double tol = cfg->fixed_point_tol;
    const int64_t max_iter = cfg->fixed_point_max_iter;
    int active_count = 0;
    for (int l = 0; l < BLOCK; l++) {
        double x[3], v[3], force[3], slip, power;
        lane_get(b->x, l, x);
        lane_get(b->v, l, v);
        drag_and_slip(&gas, b->d[l], x, v, force, &slip, &power);
        struct phi_problem problem = lane_problem(b, l);
        struct eq53_squares q = phi_iterate(&problem, force, x, v);
        int decision = eq53_shortcut(&q, tol);
        int active = b->active[l];
        int stops = active & (decision == 1), moves = active & (decision == 0);
        lane_put_squares(b, l, &q);
        b->undecided[l] = (uint8_t)(active & (decision < 0));
        for (int c = 0; c < 3; c++) {
            b->force[c][l] = force[c];
            b->x[c][l] = fm_select(moves, x[c], b->x[c][l]);
            b->v[c][l] = fm_select(moves, v[c], b->v[c][l]);
        }
        b->slip[l] = slip;
        b->reynolds_power[l] = power;
        b->stops[l] = (uint8_t)stops;
        b->converged[l] = (uint8_t)(stops | ((active == 0) & b->converged[l]));
        b->iterations[l] += active;
        int still = active & !stops & (b->iterations[l] < max_iter);
        b->active[l] = (uint8_t)still;
        active_count += still;
    }
    return active_count;
}

static int block_next_iterates(const struct dem_config *cfg, struct block *restrict b)
{
    if (gas_is_usual(&cfg->gas))
        return next_iterates_with(cfg, b, gas_usual(cfg->gas));
    return next_iterates_with(cfg, b, cfg->gas);
}

/* Lane l stopped at its iterate: keep the force there for the end of the step. */
static inline void lane_keep_end(struct block *b, int l)
{
    b->force_known[l] = 1;
    for (int c = 0; c < 3; c++)
        b->end_force[c][l] = b->force[c][l];
    b->end_slip[l] = b->slip[l];
    b->end_reynolds_power[l] = b->reynolds_power[l];
}

/* The lanes that stopped in this pass keep the force at their iterate, all lanes at once. */
static void block_keep_stopped(struct block *restrict b)
{
    for (int l = 0; l < BLOCK; l++) {
        int stops = b->stops[l];
        b->force_known[l] |= (uint8_t)stops;
        for (int c = 0; c < 3; c++)
            b->end_force[c][l] = fm_select(stops, b->force[c][l], b->end_force[c][l]);
        b->end_slip[l] = fm_select(stops, b->slip[l], b->end_slip[l]);
        b->end_reynolds_power[l] = fm_select(stops, b->reynolds_power[l], b->end_reynolds_power[l]);
    }
}

/* After a pass: the lanes that stopped keep their force; the undecided ones get Eq. 53 with its square
 * roots, and stop (and keep theirs) where it holds, else move on to the next iterate.  Returns how many
 * undecided lanes stopped. */
static int block_settle_moves(struct block *b, double tol)
{
    block_keep_stopped(b);
    int stopped = 0;
    if (!any_lane(b->undecided))
        return 0;
    for (int l = 0; l < BLOCK; l++) {
        if (!b->undecided[l])
            continue;
        struct eq53_squares q = {b->squares[0][l], b->squares[1][l], b->squares[2][l], b->squares[3][l]};
        if (eq53_exact(&q, tol)) {
            b->converged[l] = 1;
            lane_keep_end(b, l);
            stopped += b->active[l];
            b->active[l] = 0;
            continue;
        }
        /* the next iterate again, from the force at this one: the same operations, the same bits */
        double x[3], v[3], force[3];
        lane_get(b->x, l, x);
        lane_get(b->v, l, v);
        lane_get(b->force, l, force);
        struct phi_problem problem = lane_problem(b, l);
        phi_iterate(&problem, force, x, v);
        lane_put(b->x, l, x);
        lane_put(b->v, l, v);
    }
    return stopped;
}

static int block_iterate(const struct dem_config *cfg, struct block *restrict b)
{
    int active = block_next_iterates(cfg, b);
    return active - block_settle_moves(b, cfg->fixed_point_tol);
}

/* Are the block's particles consecutive, i0 to i0 + BLOCK - 1?  (Lists of particles are increasing.) */
static inline int block_consecutive(const struct block *b)
{
    return b->count == BLOCK && b->index[BLOCK - 1] - b->index[0] == BLOCK - 1;
}

/* Lane l's particle: block index i0 + l when the block's particles are consecutive (the usual case: the
 * flying particles in index order), else index[l].  Inlined with a constant `consecutive`, the loops below
 * read and write the particle arrays with a known stride and vectorise; through index[] they gather. */
FM_INLINE size_t lane_particle(const struct block *b, size_t i0, int consecutive, size_t l)
{
    return consecutive ? i0 + l : b->index[l];
}

/* The block's particles from the arrays: position, velocity, diameter, mass and the kept drag (its forces from
 * the ring slots of this step, dem_drag_slot).  Separate loops for the doubles, for each component of the
 * forces and for the byte flags: gcc vectorises loops of doubles, not one that mixes them with bytes. */
FM_INLINE void block_gather(const struct dem_particles *p, struct block *restrict b, int consecutive)
{
    const double *restrict x = p->x, *restrict v = p->v, *restrict d = p->d, *restrict m = p->m;
    const struct dem_drag *drag = &p->drag;
    const double *restrict slip = p->drag.slip, *restrict reynolds_power = p->drag.reynolds_power;
    const uint8_t *restrict kept_drag = p->drag.kept, *restrict history_count = p->drag.history_count;
    const size_t i0 = b->index[0];
    for (size_t l = 0; l < BLOCK; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        for (int c = 0; c < 3; c++) {
            b->x[c][l] = x[3 * i + c];
            b->v[c][l] = v[3 * i + c];
        }
        b->d[l] = d[i];
        b->m[l] = m[i];
    }
    for (size_t l = 0; l < BLOCK; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        b->slip[l] = slip[i];
        b->reynolds_power[l] = reynolds_power[i];
    }
    for (int c = 0; c < 3; c++) { /* one component at a time: no aliasing between the arrays to fear */
        const double *restrict force = drag->forces[dem_drag_slot(b->step, 0)][c];
        const double *restrict newer = drag->forces[dem_drag_slot(b->step, 1)][c];
        const double *restrict older = drag->forces[dem_drag_slot(b->step, 2)][c];
        for (size_t l = 0; l < BLOCK; l++) {
            size_t i = lane_particle(b, i0, consecutive, l);
            b->previous_force[0][c][l] = newer[i]; /* zero or a force of the past: finite */
            b->previous_force[1][c][l] = older[i];
            b->force_start[c][l] = force[i]; /* used only if every lane kept its force */
        }
    }
    int start_kept = b->start_kept;
    for (size_t l = 0; l < BLOCK; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        uint8_t kept = kept_drag[i]; /* 0 or 1 */
        start_kept &= kept;
        b->chain[l] = (uint8_t)((1 + history_count[i]) & -kept); /* kept ? 1 + history : 0, in bytes */
    }
    b->start_kept = start_kept;
}

static void block_load(const struct dem_particles *p, int reuse_drag, int64_t step, struct block *b,
                       const uint32_t *flying, size_t count)
{
    b->count = count;
    b->step = step;
    b->start_kept = reuse_drag;
    if (count == BLOCK)
        memcpy(b->index, flying, sizeof b->index);
    else
        for (size_t l = 0; l < BLOCK; l++)
            b->index[l] = flying[l < count ? l : count - 1]; /* spare lanes repeat the last particle: never stored */
    if (block_consecutive(b))
        block_gather(p, b, 1);
    else
        block_gather(p, b, 0);
}

/* Lane l's end of step from a scalar function: (x, v) and what *end says of the force there. */
static void lane_put_end(struct block *b, int l, const double x[3], const double v[3], const struct step_end *end)
{
    lane_put(b->x, l, x);
    lane_put(b->v, l, v);
    b->force_known[l] = (uint8_t)end->force_known;
    lane_put(b->end_force, l, end->force);
    b->end_slip[l] = end->slip;
    b->end_reynolds_power[l] = end->reynolds_power;
}

/* The lanes that the vectorised passes left unfinished, one by one, from the block's state: those still
 * iterating, and those that need sub-steps (from the start of the step again).  Their results go back to
 * the block, so that every lane is stored alike. */
static void block_finish_lanes(const struct dem_config *cfg, struct block *b, struct iteration_count *count)
{
    uint8_t unfinished[BLOCK];
    for (int l = 0; l < BLOCK; l++)
        unfinished[l] = (uint8_t)(((b->tau[l] >= 2.0 * cfg->dt) == 0) | b->active[l]);
    if (!any_lane(unfinished))
        return;
    for (int l = 0; l < (int)b->count; l++) {
        int subcycled = !(b->tau[l] >= 2.0 * cfg->dt);
        if (!subcycled && !b->active[l])
            continue;
        struct step_end end = {.force_known = 0};
        double x[3], v[3];
        if (subcycled) {
            double force[3];
            lane_get(b->x0, l, x);
            lane_get(b->v0, l, v);
            lane_get(b->force_start, l, force);
            integrate_subcycled(cfg, b->d[l], b->m[l], b->tau[l], force, x, v, count);
        } else {
            struct phi_problem problem = lane_problem(b, l);
            lane_get(b->x, l, x);
            lane_get(b->v, l, v);
            b->converged[l] = (uint8_t)phi_iterate_to_convergence(cfg, &problem, x, v, &b->iterations[l], &end);
        }
        lane_put_end(b, l, x, v, &end);
    }
}

/* The lanes of a step of dt that crossed the bow shock's plane or whose iteration did not converge, redone as the
 * reference does (phi_step_checked) from the block's start state. */
static void block_redo_unconverged(const struct dem_config *cfg, struct block *b, struct iteration_count *count)
{
    for (int l = 0; l < (int)b->count; l++) {
        if (!(b->tau[l] >= 2.0 * cfg->dt))
            continue;
        double fraction = shock_crossing_fraction(&cfg->gas, b->x0[2][l], b->x[2][l]);
        if (b->converged[l] && !(fraction > 0.0 && fraction < 1.0))
            continue;
        struct phi_problem problem = lane_problem(b, l);
        struct step_end end = {.force_known = 0};
        double x[3], v[3], force_start[3];
        lane_get(b->force_start, l, force_start);
        lane_get(b->x, l, x);
        lane_get(b->v, l, v);
        b->converged[l] =
            (uint8_t)phi_step_checked(cfg, b->m[l], &problem, force_start, b->converged[l], x, v, count, &end);
        lane_put_end(b, l, x, v, &end);
    }
}

/* The iteration counts of the block's lanes that did not need sub-steps (those count their own solves), as
 * sums over the lanes. */
static void block_count(const struct dem_config *cfg, const struct block *restrict b, struct iteration_count *count)
{
    int64_t iterations = 0, solves = 0, unconverged = 0, most = count->max_iterations;
    for (size_t l = 0; l < b->count; l++) {
        int64_t counted = b->tau[l] >= 2.0 * cfg->dt;
        iterations += counted * b->iterations[l];
        solves += counted;
        unconverged += counted & (b->converged[l] == 0);
        int64_t here = counted * b->iterations[l];
        most = here > most ? here : most;
    }
    count->iterations += iterations;
    count->solves += solves;
    count->unconverged += unconverged;
    count->max_iterations = most;
}

/* The block's particles back to the arrays: end position and velocity, and the drag (struct dem_drag): the
 * force at the end of the step where known (zero where not, as a checkpoint stores it) goes to the ring slot
 * of the oldest force, so that the start force and the one before become the history; a start force computed
 * afresh goes to its slot (a kept one is there).  Returns whether a position or velocity of the block is not
 * finite (x - x is 0 for a finite x and NaN otherwise). */
FM_INLINE int block_scatter(struct dem_particles *p, const struct block *restrict b, int consecutive)
{
    double *restrict x = p->x, *restrict v = p->v;
    const struct dem_drag *drag = &p->drag;
    double *restrict slip = p->drag.slip, *restrict reynolds_power = p->drag.reynolds_power;
    uint8_t *restrict kept = p->drag.kept, *restrict history_count = p->drag.history_count;
    const size_t i0 = b->index[0], count = consecutive ? BLOCK : b->count;
    int bad = 0;
    for (size_t l = 0; l < count; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        for (int c = 0; c < 3; c++) {
            x[3 * i + c] = b->x[c][l];
            v[3 * i + c] = b->v[c][l];
            bad |= !(b->x[c][l] - b->x[c][l] == 0.0) | !(b->v[c][l] - b->v[c][l] == 0.0);
        }
    }
    for (size_t l = 0; l < count; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        int known = b->force_known[l];
        slip[i] = fm_select(known, b->end_slip[l], 0.0);
        reynolds_power[i] = fm_select(known, b->end_reynolds_power[l], 0.0);
    }
    for (int c = 0; c < 3; c++) {
        double *restrict end = drag->forces[dem_drag_slot(b->step + 1, 0)][c]; /* the oldest's slot */
        for (size_t l = 0; l < count; l++)
            end[lane_particle(b, i0, consecutive, l)] = fm_select(b->force_known[l], b->end_force[c][l], 0.0);
    }
    for (int c = 0; c < 3 && !b->start_kept; c++) { /* start forces computed afresh */
        double *restrict start = drag->forces[dem_drag_slot(b->step, 0)][c];
        for (size_t l = 0; l < count; l++)
            start[lane_particle(b, i0, consecutive, l)] = b->force_start[c][l];
    }
    for (size_t l = 0; l < count; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        int known = b->force_known[l], chain = b->chain[l];
        history_count[i] = (uint8_t)(known && chain > 0 ? (chain < 2 ? chain : 2) : 0);
        kept[i] = (uint8_t)known;
    }
    return bad;
}

static int block_store(struct dem_particles *p, const struct block *b)
{
    if (block_consecutive(b))
        return block_scatter(p, b, 1);
    return block_scatter(p, b, 0);
}

/* Is a spin of the block not finite?  Only contacts change the spin, so only the particles that had one in
 * this step (start_kept) are tested (x - x is 0 for a finite x and NaN otherwise). */
static int block_spin_non_finite(const struct dem_solver *s, const struct block *b)
{
    int bad = 0;
    for (size_t l = 0; l < b->count; l++) {
        uint32_t i = b->index[l];
        if (!s->start_kept[i])
            continue;
        const double *w = s->p.w + 3 * i;
        bad |= !(w[0] - w[0] == 0.0) | !(w[1] - w[1] == 0.0) | !(w[2] - w[2] == 0.0);
    }
    return bad;
}

/* The contacts of the step are over for the block's particles (dem_contacts_end_step); *bad is set if the spin
 * of one that had a contact is not finite. */
static void block_end_contacts(struct dem_solver *s, const struct block *b, int consecutive, int *bad)
{
    if (!consecutive || any_lane(s->start_kept + b->index[0]))
        *bad |= block_spin_non_finite(s, b);
    if (consecutive) {
        memset(s->start_kept + b->index[0], 0, BLOCK);
        memset(s->path_changed + b->index[0], 0, BLOCK);
    } else {
        for (size_t l = 0; l < b->count; l++)
            dem_contacts_end_step(s, b->index[l]);
    }
}

/* The integration's share of the next step's broad phase (struct dem_bins: reach_verified): whether each
 * particle's swept box of the next step, from where this step leaves it, lies in its reach box, as
 * broadphase.c's reach_flags would find at the next step on the same numbers (a particle at a boundary may
 * still be moved or removed: not verified). */
FM_INLINE void block_verify_reach(const struct dem_solver *s, const struct block *restrict b,
                                  const uint8_t at_boundary[BLOCK], int consecutive)
{
    const double *restrict lo = s->bins.reach_lo, *restrict hi = s->bins.reach_hi;
    const uint8_t *restrict built_flying = s->bins.built_flying;
    uint8_t *restrict verified = s->bins.reach_verified;
    const double dt = s->cfg.dt;
    const size_t i0 = b->index[0], count = consecutive ? BLOCK : b->count;
    for (size_t l = 0; l < count; l++) {
        size_t i = lane_particle(b, i0, consecutive, l);
        /* the next step's drag skin, from the force kept for it (unknown: not verified) */
        double force[3];
        lane_get(b->end_force, (int)l, force);
        double skin = dem_skin_from_force(&s->cfg, force, b->end_slip[l], b->m[l]);
        double radius = (0.5 * b->d[l] + skin) * (1.0 + DEM_BOX_MARGIN);
        int64_t holds = b->force_known[l];
        for (int c = 0; c < 3; c++)
            holds &= (int64_t)dem_sweep_inside(b->x[c][l], b->v[c][l], dt, radius, lo[3 * i + c], hi[3 * i + c]);
        verified[i] = (uint8_t)(holds & built_flying[i] & !at_boundary[l]);
    }
}

/* The end of the step for the block's particles, which fly: their contacts are over, and those at a boundary
 * go to hits[0, return value), in order, with their start positions and velocities (x_start, v_start: the step's
 * end reads them only there, for hand-off crossings).  dem_at_boundary's tests on the block's copies of the same values
 * (x0 is the start position), as bit operations on all lanes at once; *bad is set if a spin is not finite. */
static size_t block_finish(struct dem_solver *s, const struct block *restrict b, uint32_t *hits, int *bad)
{
    const struct dem_config *cfg = &s->cfg;
    const double plane = dem_handoff_plane(cfg), standoff = cfg->standoff;
    const double escape_radius2 = cfg->domain_radius * cfg->domain_radius;
    uint8_t at_boundary[BLOCK];
    for (int l = 0; l < BLOCK; l++) {
        double x = b->x[0][l] - cfg->gas.axis_x, y = b->x[1][l] - cfg->gas.axis_y, z = b->x[2][l];
        int crossed_handoff = (b->x0[2][l] < plane) & (z >= plane);
        int beyond_target = z > standoff - 0.5 * b->d[l];
        int escapes = (x * x + y * y > escape_radius2) | ((z < 0.0) & (b->v[2][l] < 0.0));
        at_boundary[l] = (uint8_t)(crossed_handoff | beyond_target | escapes);
    }
    int consecutive = block_consecutive(b);
    if (s->bins.reach_verified && consecutive)
        block_verify_reach(s, b, at_boundary, 1);
    else if (s->bins.reach_verified)
        block_verify_reach(s, b, at_boundary, 0);
    if (s->contact_flags_set) /* else every flag is 0 (as between steps): nothing to test or clear */
        block_end_contacts(s, b, consecutive, bad);
    size_t n = 0;
    if (!any_lane(at_boundary))
        return 0;
    for (int l = 0; l < (int)b->count; l++) {
        if (at_boundary[l]) {
            lane_get(b->x0, l, s->p.x_start + 3 * b->index[l]);
            lane_get(b->v0, l, s->p.v_start + 3 * b->index[l]);
            hits[n++] = b->index[l];
        }
    }
    return n;
}

/* Advance the block's particles over the step: vectorised start forces and iterations, then one by one the
 * lanes still iterating and the particles that need sub-steps; returns whether a value is not finite. */
static int integrate_block(const struct dem_config *cfg, struct dem_particles *p, struct block *b,
                           struct iteration_count *count)
{
    block_start(cfg, b);
    int active = 0;
    for (int l = 0; l < (int)b->count; l++)
        active += b->active[l];
    while (active > BLOCK_MIN_ACTIVE)
        active = block_iterate(cfg, b);
    block_finish_lanes(cfg, b, count);
    block_redo_unconverged(cfg, b, count);
    block_count(cfg, b, count);
    return block_store(p, b);
}

int dem_integrate_particles(const struct dem_config *cfg, struct dem_particles *p, int reuse_drag, int64_t step,
                            const uint32_t *list, size_t count, int reference, int64_t counts[5])
{
    struct iteration_count total = {0};
    int bad = 0;
    if (reference) {
        for (size_t k = 0; k < count; k++) {
            integrate_particle_reference(cfg, p, reuse_drag, step, list[k], &total);
            for (int c = 0; c < 3; c++)
                bad |= !isfinite(p->x[3 * list[k] + c]) | !isfinite(p->v[3 * list[k] + c]);
        }
    } else {
        struct block *b = dem_aligned_alloc_or_die(_Alignof(struct block), sizeof *b);
        for (size_t first = 0; first < count; first += BLOCK) {
            block_load(p, reuse_drag, step, b, list + first, count - first < BLOCK ? count - first : BLOCK);
            bad |= integrate_block(cfg, p, b, &total);
        }
        free(b);
    }
    counts[0] += total.iterations;
    counts[1] += total.solves;
    counts[2] += total.unconverged;
    counts[3] = total.max_iterations > counts[3] ? total.max_iterations : counts[3];
    counts[4] += total.subcycled;
    return bad;
}

/* The moving particles of the step split, in order: those still flying (flying[0, *count)) and those that
 * deposited in it (landed[0, *landed_count)).  When none deposited (every deposit is counted in
 * s->deposited), the flying are the moving: no copy, *owned is 0. */
static const uint32_t *flying_particles(const struct dem_solver *s, size_t *count, uint32_t **landed,
                                        size_t *landed_count, int *owned)
{
    *owned = dem_stopped_count(s) != s->stopped_at_listing;
    if (!*owned) {
        *count = s->moving_count;
        *landed = NULL;
        *landed_count = 0;
        return s->moving;
    }
    size_t slots = s->moving_count ? s->moving_count : 1;
    uint32_t *flying = dem_realloc_or_die(NULL, slots * sizeof *flying);
    *landed = dem_realloc_or_die(NULL, slots * sizeof **landed);
    size_t n = 0, m = 0;
    for (size_t k = 0; k < s->moving_count; k++) {
        uint32_t i = s->moving[k];
        int flies = s->p.state[i] == DEM_FLYING;
        flying[n] = i;
        (*landed)[m] = i;
        n += flies;
        m += !flies;
    }
    *count = n;
    *landed_count = m;
    return flying;
}

/* The hand-off crossings need the start positions of the particles that fly through the step; those that
 * collided in it kept theirs already (dem/collide.c), the same position, since a contact moves only the
 * particle that sticks. */
static void keep_start_positions(struct dem_particles *p, const uint32_t *flying, size_t count)
{
    for (size_t k = 0; k < count; k++)
        memcpy(p->x_start + 3 * flying[k], p->x + 3 * flying[k], 3 * sizeof(double));
}

static int value_non_finite(const struct dem_particles *p, uint32_t i, const char **quantity)
{
    for (int c = 0; c < 3; c++) {
        if (!isfinite(p->x[3 * i + c]) || !isfinite(p->v[3 * i + c]) || !isfinite(p->w[3 * i + c])) {
            *quantity = !isfinite(p->x[3 * i + c]) ? "position" : !isfinite(p->v[3 * i + c]) ? "velocity" : "spin";
            return 1;
        }
    }
    return 0;
}

/* The first of the step's moving particles (the only ones whose state changed in it: every deposit was
 * checked in the step it deposited) with a coordinate of x, v or w not finite. */
static int first_non_finite(const struct dem_solver *s, size_t *index, const char **quantity)
{
    for (size_t k = 0; k < s->moving_count; k++) {
        if (value_non_finite(&s->p, s->moving[k], quantity)) {
            *index = s->moving[k];
            return 1;
        }
    }
    return 0;
}

/* Is any coordinate of x, v or w of the listed particles not finite?  x - x is 0 for a finite x and NaN
 * otherwise: no branches, where first_non_finite tests each value.  Run on each block as it is integrated,
 * while its particles are in cache. */
static int any_non_finite(const struct dem_particles *p, const uint32_t *list, size_t count)
{
    const double *x = p->x, *v = p->v, *w = p->w;
    int bad = 0;
    for (size_t k = 0; k < count; k++)
        for (int c = 0; c < 3; c++) {
            size_t at = 3 * (size_t)list[k] + (size_t)c;
            bad |= !(x[at] - x[at] == 0.0) | !(v[at] - v[at] == 0.0) | !(w[at] - w[at] == 0.0);
        }
    return bad;
}

/* The end of the step for the listed particles, which have finished it: their contacts are over, and those
 * at a boundary go to hits[0, return value), in order. */
static size_t finish_particles(struct dem_solver *s, const uint32_t *list, size_t count, uint32_t *hits)
{
    size_t n = 0;
    for (size_t k = 0; k < count; k++) {
        dem_contacts_end_step(s, list[k]);
        hits[n] = list[k];
        n += dem_at_boundary(s, list[k]) != 0;
    }
    return n;
}

/* No smooth forces: exact free flight, block by block as the drag's loop below, each block's particles finished
 * (their contacts over, those at a boundary in hits, their values tested) while they are in cache.  Returns
 * whether a value is not finite. */
static int integrate_free_flight(struct dem_solver *s, const uint32_t *flying, size_t count, uint32_t *hits,
                                 uint8_t *hit_count)
{
    struct dem_particles *p = &s->p;
    const double dt = s->cfg.dt;
    const size_t blocks = (count + BLOCK - 1) / BLOCK;
    int bad = 0;
#pragma omp parallel for schedule(static) reduction(| : bad) if (count >= DEM_PARALLEL_MIN)
    for (size_t k = 0; k < blocks; k++) {
        size_t first = k * BLOCK, n = count - first < BLOCK ? count - first : BLOCK;
        keep_start_positions(p, flying + first, n);
        for (size_t j = first; j < first + n; j++)
            for (int c = 0; c < 3; c++)
                p->x[3 * flying[j] + c] += dt * p->v[3 * flying[j] + c];
        bad |= any_non_finite(p, flying + first, n);
        hit_count[k] = (uint8_t)finish_particles(s, flying + first, n, hits + first);
    }
    return bad;
}

/* s->at_boundary: the merge, in index order, of the landed particles at a boundary and the flying ones,
 * found block by block (block k's in hits[k * BLOCK, k * BLOCK + hit_count[k])). */
static void list_at_boundary(struct dem_solver *s, const uint32_t *landed, size_t landed_count, const uint32_t *hits,
                             const uint8_t *hit_count, size_t blocks)
{
    size_t most = landed_count + blocks * BLOCK;
    if (most > s->at_boundary_capacity) {
        s->at_boundary_capacity = most + most / 2 + 64;
        s->at_boundary = dem_realloc_or_die(s->at_boundary, s->at_boundary_capacity * sizeof *s->at_boundary);
    }
    size_t n = 0, next_landed = 0;
    for (size_t k = 0; k < blocks; k++)
        for (size_t h = 0; h < hit_count[k]; h++) {
            uint32_t i = hits[k * BLOCK + h];
            while (next_landed < landed_count && landed[next_landed] < i)
                s->at_boundary[n++] = landed[next_landed++];
            s->at_boundary[n++] = i;
        }
    while (next_landed < landed_count)
        s->at_boundary[n++] = landed[next_landed++];
    s->at_boundary_count = n;
}

/* The particles in the gas, block by block; their iteration counts are added to *total.  Each particle's update
 * is independent and the reductions are integer sums, so the result does not depend on which thread does which
 * block; the vector lanes give the bits of the scalar code.  Each thread takes a contiguous share of the
 * blocks, balanced by the threads' speeds in the last steps (core/balance.h): it keeps nearly the same
 * particles from step to step, and their lines stay in its core's caches (dynamic chunks moved them between
 * the cores every step: Table 1 on 2 threads took 22 % more CPU time; BENCHMARKS.md's history in git), while
 * equal shares waited for the slower core.  A thread done with its share takes the last
 * chunks of another's (INTEGRATE_CHUNK blocks at a time), so that what the speeds got wrong in one step is not
 * waited for.  Returns whether a value is not finite. */
#define INTEGRATE_CHUNK 4
static int integrate_with_drag(struct dem_solver *s, const uint32_t *flying, size_t count, uint32_t *hits,
                               uint8_t *hit_count, struct iteration_count *total)
{
    const struct dem_config *cfg = &s->cfg;
    struct dem_particles *p = &s->p;
    const int reuse_drag = s->reuse_drag;
    const size_t blocks = (count + BLOCK - 1) / BLOCK;
    const int team = count >= DEM_PARALLEL_MIN_INTEGRATE ? omp_get_max_threads() : 1;
    int bad = 0;
    balance_prepare(&s->integrate_balance, team);
    balance_shares(&s->integrate_balance, blocks);
#pragma omp parallel num_threads(team)
    {
        struct iteration_count mine = {0};
        int bad_here = 0;
        size_t first_block, end_block, taken = 0;
        const int thread = omp_get_thread_num();
        double start = omp_get_wtime();
        struct block *b = dem_aligned_alloc_or_die(_Alignof(struct block), sizeof *b);
        while (balance_next(&s->integrate_balance, thread, INTEGRATE_CHUNK, &first_block, &end_block)) {
            for (size_t k = first_block; k < end_block; k++) {
                size_t first = k * BLOCK, n = count - first < BLOCK ? count - first : BLOCK;
                block_load(p, reuse_drag, s->step, b, flying + first, n);
                bad_here |= integrate_block(cfg, p, b, &mine);
                hit_count[k] = (uint8_t)block_finish(s, b, hits + first, &bad_here);
            }
            taken += end_block - first_block;
        }
        free(b);
        balance_record(&s->integrate_balance, thread, omp_get_num_threads(), taken, omp_get_wtime() - start);
#pragma omp critical(dem_integrate_counts)
        {
            bad |= bad_here;
            total->iterations += mine.iterations;
            total->solves += mine.solves;
            total->unconverged += mine.unconverged;
            total->subcycled += mine.subcycled;
            if (mine.max_iterations > total->max_iterations)
                total->max_iterations = mine.max_iterations;
        }
    }
    balance_update(&s->integrate_balance);
    return bad;
}

/* The flying particles whose path restarted in this step's contacts (start_kept) leave flying[0, *count)
 * (kept in order) for restarted[0, return value), in order; flying is copied to a list of its own, *owned,
 * where it was not. */
static size_t split_restarted(const struct dem_solver *s, const uint32_t **flying, size_t *count, int *owned,
                              uint32_t **restarted)
{
    *restarted = NULL;
    if (!s->contact_flags_set)
        return 0;
    const uint32_t *list = *flying;
    size_t n = 0, r = 0;
    for (size_t k = 0; k < *count; k++)
        r += s->start_kept[list[k]] != 0;
    if (r == 0)
        return 0;
    uint32_t *kept = *owned ? (uint32_t *)list : dem_realloc_or_die(NULL, *count * sizeof *kept);
    *restarted = dem_realloc_or_die(NULL, r * sizeof **restarted);
    r = 0;
    for (size_t k = 0; k < *count; k++) {
        uint32_t i = list[k];
        if (s->start_kept[i])
            (*restarted)[r++] = i;
        else
            kept[n++] = i;
    }
    *flying = kept;
    *count = n;
    *owned = 1;
    return r;
}

/* The merge of two increasing index lists into a new one. */
static uint32_t *merge_indices(const uint32_t *a, size_t a_count, const uint32_t *b, size_t b_count)
{
    uint32_t *out = dem_realloc_or_die(NULL, (a_count + b_count ? a_count + b_count : 1) * sizeof *out);
    size_t i = 0, j = 0, n = 0;
    while (i < a_count || j < b_count)
        out[n++] = j == b_count || (i < a_count && a[i] < b[j]) ? a[i++] : b[j++];
    return out;
}

/* The particles whose path restarted in the step: each over the rest of it, from where its path restarted
 * (integrate_rest_of_step), then finished as finish_particles does; those at a boundary are merged into
 * the landed ones at a boundary (*landed, *landed_hits; a new list, *landed_owned).  Returns whether a value
 * is not finite. */
static int integrate_restarted(struct dem_solver *s, uint32_t *restarted, size_t count, uint32_t **landed,
                               size_t *landed_hits, int *landed_owned, struct iteration_count *total)
{
    for (size_t k = 0; k < count; k++)
        integrate_rest_of_step(s, &s->p, restarted[k], total);
    int bad = any_non_finite(&s->p, restarted, count);
    size_t hits = finish_particles(s, restarted, count, restarted);
    if (hits) {
        uint32_t *merged = merge_indices(*landed, *landed_hits, restarted, hits);
        if (*landed_owned)
            free(*landed);
        *landed = merged;
        *landed_hits += hits;
        *landed_owned = 1;
    }
    return bad;
}

int dem_integrate(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    const struct dem_config *cfg = &s->cfg;
    size_t flying_count, landed_count;
    uint32_t *landed, *restarted;
    int owned;
    const uint32_t *flying = flying_particles(s, &flying_count, &landed, &landed_count, &owned);
    int landed_owned = 0;             /* landed is a merged list of its own */
    uint32_t *moving_landed = landed; /* flying_particles's list (or NULL) */
    size_t restarted_count = split_restarted(s, &flying, &flying_count, &owned, &restarted);
    struct iteration_count total = {.max_iterations = s->stats.max_iterations};
    int bad = any_non_finite(p, landed, landed_count);
    size_t landed_hits = finish_particles(s, landed, landed_count, landed);
    bad |= integrate_restarted(s, restarted, restarted_count, &landed, &landed_hits, &landed_owned, &total);
    size_t blocks = (flying_count + BLOCK - 1) / BLOCK;
    uint32_t *hits = dem_realloc_or_die(NULL, (blocks ? blocks : 1) * BLOCK * sizeof *hits);
    uint8_t *hit_count = dem_realloc_or_die(NULL, blocks ? blocks : 1);
    if (cfg->gas.model == DEM_JET_NONE) {
        bad |= integrate_free_flight(s, flying, flying_count, hits, hit_count);
    } else {
        bad |= integrate_with_drag(s, flying, flying_count, hits, hit_count, &total);
    }
    s->contact_flags_set = 0; /* every moving particle's were cleared */
    list_at_boundary(s, landed, landed_hits, hits, hit_count, blocks);
    free(hits);
    free(hit_count);
    if (landed_owned)
        free(landed);
    free(moving_landed);
    free(restarted);
    if (owned)
        free((void *)flying);
    s->stats.fixed_point_iterations += total.iterations;
    s->stats.fixed_point_solves += total.solves;
    s->stats.fixed_point_unconverged += total.unconverged;
    s->stats.subcycled_particle_steps += total.subcycled;
    s->stats.particle_steps += (int64_t)(flying_count + restarted_count);
    s->stats.max_iterations = total.max_iterations;
    size_t first_bad;
    const char *quantity;
    if (bad && first_non_finite(s, &first_bad, &quantity))
        SC_FAIL(SC_ESIM, "spray: step %lld (t = %.9g s): particle %lld: %s is not finite (NaN or Inf)",
                (long long)s->step, (double)s->step * cfg->dt, (long long)p->id[first_bad], quantity);
    return SC_OK;
}
