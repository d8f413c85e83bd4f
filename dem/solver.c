/* The spray solver's step (Algorithm 1 of Mukherjee & Zohdi, with swept contact detection) and the
 * boundaries: target plane, hand-off plane, escape. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "dem/dem_impl.h"

int dem_create(const struct dem_config *cfg, struct dem_solver **out)
{
    struct dem_solver *s = calloc(1, sizeof *s);
    if (!s)
        SC_FAIL_OOM(sizeof *s, "the spray solver");
    s->cfg = *cfg;
    s->reuse_drag = 1;
    s->weibull_lambda = dem_weibull_scale(cfg->sizes.median_diameter, cfg->sizes.shape);
    dem_particles_reserve(&s->p, 1024);
    if (cfg->injection == DEM_INJECT_FILE)
        dem_inject_file(s);
    *out = s;
    return SC_OK;
}

void dem_reuse_drag(struct dem_solver *s, int reuse)
{
    s->reuse_drag = reuse != 0;
}

void dem_destroy(struct dem_solver *s)
{
    if (!s)
        return;
    free(s->p.skin); /* the solver's, not the particle arrays' */
    dem_particles_free(&s->p);
    dem_bins_free(&s->bins);
    balance_free(&s->integrate_balance);
    free(s->candidates.items);
    free(s->moving);
    free(s->at_boundary);
    free(s->path_time);
    free(s->path_x);
    free(s->path_changed);
    free(s->start_kept);
    free(s->seen);
    free(s->contacts_in_step);
    free(s->impacts);
    free(s->handoffs);
    free(s->metrics);
    free(s->contacts_of);
    free(s->escapes);
    free(s);
}

int64_t dem_total_steps(const struct dem_solver *s)
{
    /* the relative slack keeps t_end = k dt from rounding up to k + 1 steps */
    return (int64_t)ceil(s->cfg.t_end / s->cfg.dt * (1.0 - 1e-12));
}

/* The crossing of the hand-off plane by particle i during this step, on the straight line from its start
 * position to its end position: for a free particle over the whole step, its velocity interpolated as well between
 * the start's and the end's (the end's alone, as before, differed from the velocity at the crossing by the drag's
 * deceleration over the rest of the step: the couple stage's flight starts from it); for a particle that stuck in
 * this step up to the time it stuck (then it carries its velocity and spin from the start of the step).  Without
 * gas the velocity is constant.  A particle whose velocity a contact changed in this step takes the end's
 * (integrate_rest_of_step leaves its v_start at its end velocity: the velocity before the contact is not one to
 * interpolate from). */
static void record_handoff(struct dem_solver *s, size_t i, double plane)
{
    struct dem_particles *p = &s->p;
    const double *x0 = p->x_start + 3 * i, *x1 = p->x + 3 * i;
    int flying = p->state[i] == DEM_FLYING;
    int interpolated = flying && s->cfg.gas.model != DEM_JET_NONE;
    double fraction = (plane - x0[2]) / (x1[2] - x0[2]);
    double duration = flying ? s->cfg.dt : s->path_time[i];
    struct dem_handoff *row = dem_grow((void **)&s->handoffs, &s->handoff_count, &s->handoff_capacity, sizeof *row);
    row->t = (double)s->step * s->cfg.dt + fraction * duration;
    row->particle_id = p->id[i];
    for (int c = 0; c < 3; c++) {
        const double *v0 = p->v_start + 3 * i, *v1 = p->v + 3 * i;
        row->x[c] = x0[c] + fraction * (x1[c] - x0[c]);
        row->v[c] = interpolated ? v0[c] + fraction * (v1[c] - v0[c]) : flying ? v1[c] : v0[c];
        row->w[c] = flying ? p->w[3 * i + c] : p->w_start[3 * i + c];
    }
    row->d = p->d[i];
    row->temperature = p->temperature[i];
    dem_path_position(&s->cfg.path, row->t, row->axis);
}

/* Particle i leaves the domain: its mass stays in the sprayed mass of the deposition efficiency
 * (dem/efficiency.c), which it no longer finds among the particles. */
static void record_escape(struct dem_solver *s, size_t i)
{
    struct dem_escape *row = dem_grow((void **)&s->escapes, &s->escape_count, &s->escape_capacity, sizeof *row);
    row->t = (double)(s->step + 1) * s->cfg.dt;
    row->particle_id = s->p.id[i];
    row->d = s->p.d[i];
    row->m = s->p.m[i];
}

/* Hand-off crossings, the target plane as a hard limit, escape: of the moving particles that dem_integrate
 * found at a boundary (s->at_boundary, in index order; every other particle is inside and stays).  The
 * escaped ones are listed in index order and removed together. */
static void apply_boundaries(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    uint32_t *removed = NULL;
    size_t removed_count = 0;
    for (size_t k = 0; k < s->at_boundary_count; k++) {
        uint32_t i = s->at_boundary[k];
        if (dem_crossed_handoff(s, i))
            record_handoff(s, i, dem_handoff_plane(&s->cfg));
        if (p->state[i] != DEM_FLYING)
            continue;
        /* A particle that would end the step inside the target stops at it; its contact is resolved at
         * the start of the next step (time of impact 0), so nothing passes through the target. */
        if (dem_beyond_target(s, i)) {
            p->x[3 * i + 2] = s->cfg.standoff - 0.5 * p->d[i];
            p->drag.kept[i] = 0;
            s->stats.clamps++; /* the contact search missed it: counted (docs/physics.md, "Contact detection") */
        }
        if (dem_escapes(s, i)) {
            if (!removed)
                removed = dem_realloc_or_die(NULL, (s->at_boundary_count - k) * sizeof *removed);
            removed[removed_count++] = i;
            record_escape(s, i);
        }
    }
    if (removed_count) {
        size_t old_count = p->count;
        dem_particles_compact(p, removed, removed_count);
        dem_broadphase_compact(&s->bins, removed, removed_count, old_count);
        s->escaped += (int64_t)removed_count;
    }
    free(removed);
}

int dem_check_accounting(const struct dem_solver *s)
{
    int64_t flying = 0, deposited = 0, resting = 0;
    for (size_t i = 0; i < s->p.count; i++) {
        flying += s->p.state[i] == DEM_FLYING;
        deposited += s->p.state[i] == DEM_DEPOSITED;
        resting += s->p.state[i] == DEM_RESTING;
    }
    if (deposited != s->deposited || resting != s->resting || s->injected != flying + deposited + resting + s->escaped)
        SC_FAIL(SC_ESIM,
                "spray: step %lld: particle accounting broken: injected %lld != in flight %lld + deposited %lld "
                "(counter %lld) + resting %lld (counter %lld) + escaped %lld",
                (long long)s->step, (long long)s->injected, (long long)flying, (long long)deposited,
                (long long)s->deposited, (long long)resting, (long long)s->resting, (long long)s->escaped);
    return SC_OK;
}

/* Adds the wall time since *mark to *phase and moves the mark on. */
static void time_phase(double *phase, double *mark)
{
    double now = omp_get_wtime();
    *phase += now - *mark;
    *mark = now;
}

int dem_step(struct dem_solver *s)
{
    struct dem_timing *timing = &s->timing;
    double mark = omp_get_wtime();
    /* the nozzle, and with it the jet's axis, where the path has it at the step's start: the jet is quasi-steady
     * (docs/physics.md "A traversing nozzle") */
    double nozzle[2];
    dem_path_position(&s->cfg.path, (double)s->step * s->cfg.dt, nozzle);
    s->cfg.gas.axis_x = nozzle[0];
    s->cfg.gas.axis_y = nozzle[1];
    dem_inject(s);
    time_phase(&timing->injection, &mark);
    SC_TRY(dem_collide(s));
    time_phase(&timing->contacts, &mark);
    SC_TRY(dem_integrate(s));
    time_phase(&timing->integration, &mark);
    apply_boundaries(s);
    s->step++;
#ifndef NDEBUG
    SC_TRY(dem_check_accounting(s));
#endif
    time_phase(&timing->boundaries, &mark);
    if (s->step % s->cfg.metrics_every == 0 || s->step == dem_total_steps(s))
        dem_sample_metrics(s);
    time_phase(&timing->metrics, &mark);
    return SC_OK;
}

struct dem_timing dem_get_timing(const struct dem_solver *s)
{
    struct dem_timing timing = s->timing;
    timing.contacts -= timing.broad_phase; /* the rest of dem_collide: swept tests, sorting, resolution */
    timing.grid_builds = s->bins.builds;
    timing.grid_repairs = s->bins.repairs;
    return timing;
}

struct dem_counts dem_get_counts(const struct dem_solver *s)
{
    struct dem_counts counts = s->stats;
    counts.step = s->step;
    counts.t = (double)s->step * s->cfg.dt;
    counts.injected = s->injected;
    counts.deposited = s->deposited;
    counts.escaped = s->escaped;
    counts.resting = s->resting;
    counts.first_impact_deposits = s->first_impact_deposits;
    counts.in_flight = s->injected - s->deposited - s->escaped - s->resting;
    return counts;
}

const struct dem_impact *dem_impacts(const struct dem_solver *s, size_t *count)
{
    *count = s->impact_count;
    return s->impacts;
}

const struct dem_handoff *dem_handoffs(const struct dem_solver *s, size_t *count)
{
    *count = s->handoff_count;
    return s->handoffs;
}

size_t dem_particle_count(const struct dem_solver *s)
{
    return s->p.count;
}

struct dem_particle_view dem_particle(const struct dem_solver *s, size_t index)
{
    const struct dem_particles *p = &s->p;
    struct dem_particle_view view = {.id = p->id[index], .state = p->state[index], .d = p->d[index], .m = p->m[index]};
    memcpy(view.x, p->x + 3 * index, sizeof view.x);
    memcpy(view.v, p->v + 3 * index, sizeof view.v);
    memcpy(view.w, p->w + 3 * index, sizeof view.w);
    return view;
}
