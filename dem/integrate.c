/* Time integration of the smooth forces, Mukherjee & Zohdi Section 4.4, Eqs. (42)-(53).
 *
 * Collisions were applied as impulses at the start of the step (dem/collide.c), so within the step each
 * free particle feels only the gas drag, which depends on its own position and velocity: the fixed-point
 * iteration of Eqs. (51)-(52) decouples into one small iteration per particle, converged to the relative
 * error of Eq. (53) for that particle.  The iteration contracts by about phi dt / tau (tau the drag
 * response time); a particle whose response time is shorter than twice the step is sub-cycled with k equal
 * sub-steps so that dt/k <= tau/2 (DESIGN.md: stiff particles must not go unstable). */
#include <math.h>
#include <string.h>

#include "core/error.h"
#include "dem/dem_impl.h"

#define MAX_SUBSTEPS 100000

struct iteration_count {
    int64_t iterations, solves, unconverged, max_iterations, subcycled;
};

static void net_force(const struct gas_field *gas, double d, const double x[3], const double v[3], double f[3])
{
    double u[3];
    gas_velocity(gas, x, u);
    gas_drag_force(gas, d, v, u, f);
}

static double norm3_difference(const double a[3], const double b[3])
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* One phi-scheme step of length h from (x, v); the result replaces (x, v).  gas_start, if not NULL, is the
 * gas velocity at x, already known to the caller. */
static void phi_step(const struct dem_config *cfg, double d, double m, double h, const double *gas_start, double x[3],
                     double v[3], struct iteration_count *count)
{
    const double phi = cfg->phi;
    double force_start[3], residual_v[3], residual_x[3];
    double x0[3], v0[3], x_k[3], v_k[3];
    if (gas_start)
        gas_drag_force(&cfg->gas, d, v, gas_start, force_start);
    else
        net_force(&cfg->gas, d, x, v, force_start);
    for (int c = 0; c < 3; c++) {
        residual_v[c] = v[c] + h / m * (1.0 - phi) * force_start[c]; /* Eq. 48 */
        residual_x[c] = x[c] + h * (1.0 - phi) * v[c];                 /* Eq. 50 */
        x0[c] = x_k[c] = x[c];
        v0[c] = v_k[c] = v[c];
    }
    int64_t iteration = 0;
    int converged = 0;
    while (!converged && iteration < cfg->fixed_point_max_iter) {
        double force[3], v_next[3], x_next[3];
        /* the first iterate is the start state, whose force is already known */
        if (iteration == 0)
            memcpy(force, force_start, sizeof force);
        else
            net_force(&cfg->gas, d, x_k, v_k, force);
        for (int c = 0; c < 3; c++) {
            v_next[c] = residual_v[c] + h / m * phi * force[c]; /* Eqs. 47, 51 */
            x_next[c] = residual_x[c] + h * phi * v_next[c];    /* Eqs. 49, 52 */
        }
        iteration++;
        double change = norm3_difference(v_next, v_k) + norm3_difference(x_next, x_k);
        double progress = norm3_difference(v_next, v0) + norm3_difference(x_next, x0);
        /* Eq. 53 per particle; an exactly repeated iterate has converged whatever the denominator */
        converged = change <= cfg->fixed_point_tol * progress || change == 0.0;
        memcpy(v_k, v_next, sizeof v_k);
        memcpy(x_k, x_next, sizeof x_k);
        if (phi == 0.0)
            converged = 1; /* explicit Euler: nothing to iterate */
    }
    memcpy(x, x_k, 3 * sizeof(double));
    memcpy(v, v_k, 3 * sizeof(double));
    count->iterations += iteration;
    count->solves++;
    count->unconverged += !converged;
    if (iteration > count->max_iterations)
        count->max_iterations = iteration;
}

/* Sub-steps needed for a particle of diameter d at velocity v in gas moving at u. */
static int64_t substeps_for(const struct dem_config *cfg, double d, const double u[3], const double v[3])
{
    double slip = norm3_difference(u, v);
    double tau = gas_response_time(&cfg->gas, cfg->powder.density, d, slip);
    if (!(tau < 2.0 * cfg->dt))
        return 1;
    double k = ceil(2.0 * cfg->dt / tau);
    return k > MAX_SUBSTEPS ? MAX_SUBSTEPS : (int64_t)k;
}

static void integrate_particle(const struct dem_config *cfg, double d, double m, double x[3], double v[3],
                               struct iteration_count *count)
{
    if (cfg->gas.model == JET_NONE) { /* no smooth forces: exact free flight */
        for (int c = 0; c < 3; c++)
            x[c] += cfg->dt * v[c];
        return;
    }
    double u[3];
    gas_velocity(&cfg->gas, x, u); /* evaluated once: for the sub-step count and the first start force */
    int64_t substeps = substeps_for(cfg, d, u, v);
    double h = cfg->dt / (double)substeps;
    for (int64_t k = 0; k < substeps; k++)
        phi_step(cfg, d, m, h, k == 0 ? u : NULL, x, v, count);
    if (substeps > 1)
        count->subcycled++;
}

static int first_non_finite(const struct dem_particles *p, size_t *index, const char **quantity)
{
    for (size_t i = 0; i < p->count; i++) {
        for (int c = 0; c < 3; c++) {
            if (!isfinite(p->x[3 * i + c]) || !isfinite(p->v[3 * i + c]) || !isfinite(p->w[3 * i + c])) {
                *index = i;
                *quantity = !isfinite(p->x[3 * i + c]) ? "position" : !isfinite(p->v[3 * i + c]) ? "velocity" : "spin";
                return 1;
            }
        }
    }
    return 0;
}

int dem_integrate(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    const struct dem_config *cfg = &s->cfg;
    int64_t iterations = 0, solves = 0, unconverged = 0, max_iterations = s->stats.max_iterations, subcycled = 0;
    int64_t advanced = 0;
    /* Dynamic schedule: deposited particles (skipped) gather at low indices.  Each particle's update is
     * independent and the reductions are integer sums, so the result does not depend on the schedule. */
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : iterations, solves, unconverged, subcycled, advanced) \
    reduction(max : max_iterations)
    for (size_t i = 0; i < p->count; i++) {
        if (p->state[i] != DEM_FLYING)
            continue;
        struct iteration_count count = {0};
        advanced++;
        integrate_particle(cfg, p->d[i], p->m[i], p->x + 3 * i, p->v + 3 * i, &count);
        iterations += count.iterations;
        solves += count.solves;
        unconverged += count.unconverged;
        subcycled += count.subcycled;
        if (count.max_iterations > max_iterations)
            max_iterations = count.max_iterations;
    }
    s->stats.fixed_point_iterations += iterations;
    s->stats.fixed_point_solves += solves;
    s->stats.fixed_point_unconverged += unconverged;
    s->stats.subcycled_particle_steps += subcycled;
    s->stats.particle_steps += advanced;
    s->stats.max_iterations = max_iterations;
    size_t bad;
    const char *quantity;
    if (first_non_finite(p, &bad, &quantity))
        SC_FAIL(SC_ESIM, "spray: step %lld (t = %.9g s): particle %lld: %s is not finite (NaN or Inf)",
                (long long)s->step, (double)s->step * cfg->dt, (long long)p->id[bad], quantity);
    return SC_OK;
}
