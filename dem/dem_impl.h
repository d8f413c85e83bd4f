/* Module-private (dem/): the solver's state, shared by the files of dem/. */
#ifndef SPRAYCOAT_DEM_IMPL_H
#define SPRAYCOAT_DEM_IMPL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/balance.h"
#include "dem/contact.h"
#include "dem/dem.h"
#include "dem/gas.h"
#include "dem/material.h"
#include "dem/sizes.h"

/* The drag at a particle's state as the integrator left it (dem/integrate.c): the force (N), the slip (m/s) and
 * Re^0.6459 there, valid while `kept` is 1 (whatever changes x or v outside the integrator clears it); and the
 * forces at the ends of the two steps before, of which the newest `history_count` (0-2) are known: they
 * extrapolate the force at the end of the next step, the first fixed-point iterate's guess.  The three forces
 * are a ring: at step n the force at the particle's state is in slot n mod 3 and the older ones in the slots
 * before (dem_drag_slot), so that a step writes only the new one, in the slot of the oldest.  Structure of
 * arrays, one per slot and component (a block of consecutive particles reads and writes each as vectors; one
 * record per particle was a strided gather of 96 bytes); checkpointed as one struct dem_drag_record each, in
 * the order newest first. */
struct dem_drag {
    double *forces[3][3]; /* forces[slot][c][i] */
    double *slip, *reynolds_power;
    uint8_t *kept, *history_count;
};

/* The ring slot at step `step` of the force `age` steps older than the one at the particle's state (age 0). */
static inline int dem_drag_slot(int64_t step, int age)
{
    return (int)((step + 3 - age) % 3);
}

/* A particle's drag (struct dem_drag) as the checkpoint's dataset "drag" holds it, one record per particle. */
struct dem_drag_record {
    double force[3], previous[2][3], slip, reynolds_power;
    uint8_t kept, history_count;
};

/* Particles in flight and deposited, structure of arrays, in order of injection (= order of id). */
struct dem_particles {
    size_t count, capacity;
    double *x, *v, *w; /* 3 per particle: position (m), velocity (m/s), spin (rad/s) */
    double *x_start;   /* position at the start of the step, of the particles that collided in it
                        * (dem/collide.c keep_start_velocity) or flew to a boundary (dem/integrate.c):
                        * read only for those, for the hand-off crossings */
    double *v_start;   /* velocity and spin at the start of the step, kept only for the particles that */
    double *w_start;   /* collided in it (dem/collide.c): the hand-off rows of particles that stuck */
    double *d, *m;     /* diameter (m), mass (kg) */
    int64_t *id;
    uint8_t *state; /* enum dem_particle_state */
    struct dem_drag drag;
    /* The drag skin of each particle flying in the step (m): a bound on how far the drag bends its path off
     * the straight line within the step (dem/integrate.c, dem_drag_skins); every contact test widens the
     * particle's radius by it (dem_contact_radius).  Scratch of the step, owned by the solver (skin_capacity),
     * not moved by dem_particles_compact; read only for flying particles; NULL: no skins (a broad phase
     * run on its own). */
    double *skin;
    double *temperature; /* K: set at injection (the nozzle's exit table, or [powder] temperature), constant after */
};

/* The radius with which particle i enters every contact test: its own, widened by its drag skin while it
 * flies (a deposit does not move). */
static inline double dem_contact_radius(const struct dem_particles *p, size_t i)
{
    return 0.5 * p->d[i] + (p->skin && p->state[i] == DEM_FLYING ? p->skin[i] : 0.0);
}

/* One entry per (particle, cell its swept box overlaps). */
struct dem_bin_entry {
    int32_t cell[3];
    uint32_t index; /* particle index */
};

/* Swept-box hash grid: cubic cells of side `cell`; each particle is entered in every cell that its reach box
 * overlaps; cell (i, j, k) lives in bucket hash(i, j, k).  The reach box holds the particle's swept sphere
 * over the next `horizon` steps at its velocity of the build, widened by a skin: the pairs whose reach
 * boxes overlap are listed once, and the grid and the list serve the following steps for as long as every
 * particle's swept box of the step stays inside its reach box (broadphase.c, like a Verlet list's skin). */
struct dem_bins {
    double cell;
    size_t bucket_count;    /* power of two */
    uint32_t *bucket_start; /* bucket_count + 1 */
    struct dem_bin_entry *entries;
    size_t entry_count, entry_capacity;
    uint32_t *entry_bucket; /* scratch for the counting sort */
    struct dem_bin_entry *scratch;
    /* the particles as built: reach boxes (corners lo and hi, x, y, z each), ids and flying flags.  Two arrays
     * of corners rather than one of boxes: gcc 12 vectorises reach_flags over stride-3 groups, not stride 6. */
    size_t built_count, built_capacity;
    double *reach_lo, *reach_hi;
    int64_t *built_id;
    uint8_t *built_flying;
    /* Set by the integration (dem/integrate.c, block_verify_reach) for a particle whose swept box of the next
     * step, from where the step left it, lies in its reach box; read and cleared by the next step's test, which
     * then skips the box test for it (broadphase.c, collect_failing).  0 for every other particle. */
    uint8_t *reach_verified;
    /* Repairs between builds (broadphase.c): a particle whose reach box was renewed after the build (it left
     * the old one, or was injected) is in repaired_list; its grid entries are stale and skipped.  `failing`
     * is scratch: the particles renewed in this step. */
    uint8_t *repaired; /* per particle: 0 in the grid as built, else repaired */
    uint32_t *repaired_list, *failing;
    size_t repaired_count, failing_count;
    uint32_t *pairs; /* 2 per listed pair: lower index, higher index */
    size_t pair_count, pair_capacity;
    double horizon;          /* steps covered by a reach box; 0: the step's swept box, no skin */
    int64_t age;             /* steps served since the build, not counting its own */
    int64_t plain_builds;    /* builds with horizon 0 in a row */
    int64_t builds, repairs; /* for the statistics */
};

/* Boxes are widened by this fraction of the radius so that rounding cannot drop a grazing contact. */
#define DEM_BOX_MARGIN 1e-9

/* Does the sweep of one coordinate, from start over span at velocity v, of a sphere of this radius (widened by
 * DEM_BOX_MARGIN) stay within [lo, hi]?  The lower end minus the radius is >= lo exactly when both ends minus
 * the radius are (rounding is monotonic), the same for the upper; a NaN fails (stop is NaN when start is, and
 * `a < b ? a : b` gives b when b is NaN).  No branch, so that loops over particles vectorise (min and max). */
static inline int dem_sweep_inside(double start, double v, double span, double radius, double lo, double hi)
{
    double stop = start + v * span;
    double lower = start < stop ? start : stop, upper = start > stop ? start : stop;
    return (lower - radius >= lo) & (upper + radius <= hi);
}

enum dem_contact_kind { CONTACT_TARGET = 0, CONTACT_PAIR = 1 };

/* A contact found by the swept-sphere test: particles a (< b when both fly) touch at time s in the step. */
struct dem_candidate {
    double s;
    uint32_t a, b; /* b unused for CONTACT_TARGET */
    int kind;
};

struct dem_candidates {
    struct dem_candidate *items;
    size_t count, capacity;
};

struct dem_solver {
    struct dem_config cfg; /* copy; table and file arrays are owned by the caller's config */
    double weibull_lambda;
    int64_t step;
    int64_t injected, escaped, deposited;
    int64_t resting, first_impact_deposits;
    /* contacts with the target or fixed particles so far, by particle id (ids are 0, 1, ... in order of
     * injection): the next impact row's contact_index; rebuilt from /impacts on a restart */
    uint32_t *contacts_of;
    size_t contacts_of_capacity;
    int64_t injection_deferred; /* particles that found no free place in the nozzle disc */
    struct dem_particles p;
    struct dem_bins bins;
    struct dem_candidates candidates;
    int reuse_drag;                   /* start a step from the kept drag (struct dem_drag); 1 but in tests */
    struct dem_timing timing;         /* contacts: all of dem_collide, the broad phase included (dem_get_timing) */
    struct balance integrate_balance; /* the threads' shares of the drag integration (dem/integrate.c) */
    /* The particles flying at the start of the step, in index order (dem_collide lists them; the
     * integration and the boundaries of the step use them): the per-step passes need not visit deposits. */
    uint32_t *moving;
    size_t moving_count, moving_capacity;
    /* the particle count, the stopped particles (deposited or resting) and the escapes counted when moving was
     * listed: the same stopped count at the integration, none stopped in the step's contacts; all the same at
     * the next step, the same list.  A particle that comes to rest counts like one that sticks: left in the
     * list, it would be integrated (drag gives it a velocity and moves it) while it is meant to lie still. */
    size_t listed_count;
    int64_t stopped_at_listing, escaped_at_listing;
    /* The moving particles that the step's boundaries concern (dem_at_boundary), in index order: found by
     * dem_integrate as each particle finishes the step, handled by the step's end (dem/solver.c). */
    uint32_t *at_boundary;
    size_t at_boundary_count, at_boundary_capacity;
    /* Paths within the step, for contacts resolved after an earlier velocity change: particle i is at
     * path_x[3i..3i+2] at time path_time[i] of the step and moves on with its current velocity; valid only
     * where start_kept[i] is set (a particle whose velocity has not changed is on its start path: x at 0). */
    double *path_time, *path_x;
    uint8_t *path_changed; /* dem/collide.c: the path restarted (its contacts not yet searched), and the
                            * particle is in the step's list of changed ones */
    uint8_t *start_kept;   /* set when x_start, v_start and w_start of the particle hold this step's
                            * start (it collided) and its path restarted */
    int contact_flags_set; /* a start_kept or path_changed was set in this step (else all are 0: the
                            * step's end need not visit them) */
    uint32_t *seen;        /* per particle: stamp of the last grid query that visited it (only equality
                            * with the current stamp counts; stamps grow from step to step) */
    uint32_t seen_stamp;
    uint32_t *contacts_in_step; /* per particle: its contacts in this step so far (0 between steps) */
    size_t path_capacity;
    size_t skin_capacity;    /* of p.skin */
    struct dem_counts stats; /* cumulative contact and iteration counts */
    struct dem_impact *impacts;
    size_t impact_count, impact_capacity;
    struct dem_handoff *handoffs;
    size_t handoff_count, handoff_capacity;
    struct dem_metrics *metrics;
    size_t metric_count, metric_capacity;
    /* the particles that left the domain, in order of escape (spray.h5 /escapes; the sprayed mass of
     * dem/efficiency.c) */
    struct dem_escape *escapes;
    size_t escape_count, escape_capacity;
};

/* The particles that no longer move: deposited or resting. */
static inline int64_t dem_stopped_count(const struct dem_solver *s)
{
    return s->deposited + s->resting;
}

/* Loops over fewer particles (or pairs) than this run on one thread: opening a parallel region costs more
 * than they do, and far more on a loaded machine, where the threads wait for each other at its end.  The
 * drag integration, about a microsecond per particle, goes parallel from DEM_PARALLEL_MIN_INTEGRATE. */
#define DEM_PARALLEL_MIN           2048
#define DEM_PARALLEL_MIN_INTEGRATE 512

/* dem/particles.c */
/* realloc that reports and aborts when memory runs out (bytes 0 allocates 1) */
void *dem_realloc_or_die(void *data, size_t bytes);
/* bytes a multiple of alignment (C17 aligned_alloc); aborts when out of memory, as dem_realloc_or_die. */
void *dem_aligned_alloc_or_die(size_t alignment, size_t bytes);
void dem_particles_reserve(struct dem_particles *p, size_t capacity);
size_t dem_particles_append(struct dem_particles *p, int64_t id, const double x[3], const double v[3],
                            const double w[3], double d, double density);
void dem_particles_free(struct dem_particles *p);
/* Remove the particles removed[0, removed_count) (increasing indices), preserving the order of the others
 * (x_start, v_start, w_start excepted: they are scratch of the step and invalid after it). */
void dem_particles_compact(struct dem_particles *p, const uint32_t *removed, size_t removed_count);
/* The same for any array of `count` rows of `size` bytes. */
void dem_remove_rows(void *rows, size_t size, size_t count, const uint32_t *removed, size_t removed_count);

/* dem/inject.c */
void dem_inject(struct dem_solver *s);
/* The particles of `injection = file`, all at t = 0. */
void dem_inject_file(struct dem_solver *s);

/* dem/broadphase.c: the swept-box grid and the pairs of particles whose swept spheres touch in the step. */
void dem_bins_free(struct dem_bins *bins);
/* Bring the grid and the pair list up to date for this step: the particles that left their reach box, were
 * injected, or flew off a deposit since the build are repaired in place; rebuilt when they are too many. */
void dem_broadphase_build(struct dem_bins *bins, const struct dem_particles *p, double dt);
/* After dem_particles_compact(p, removed, removed_count) removed those of the old_count particles: the grid and
 * the pair list follow, so that the next build need not start afresh. */
void dem_broadphase_compact(struct dem_bins *bins, const uint32_t *removed, size_t removed_count, size_t old_count);
/* Append to `out` every pair (a, b), at least one flying, whose spheres moving with their current velocities
 * touch while approaching at some s in [0, dt]: a < b when both fly, else a is the flying one.  Inside a
 * parallel region every thread calls it, each with its own `out`, and each tests a share of the pairs (an
 * orphaned `omp for` without a barrier at its end); outside one, it tests them all. */
void dem_broadphase_pairs(const struct dem_bins *bins, const struct dem_particles *p, double dt,
                          struct dem_candidates *out);
/* First time s in [0, dt] at which |dx + dv s| = reach while approaching; -1 if none. */
double dem_time_of_impact(const double dx[3], const double dv[3], double reach, double dt);
/* Call visit(index, context) for every entry of the cells that the box [lo, hi] overlaps, and every
 * repaired particle whose reach box overlaps it (a particle may be visited more than once).  Returns 0, or
 * -1 without visiting if the box spans more than max_cells cells. */
int dem_broadphase_visit_box(const struct dem_bins *bins, const double lo[3], const double hi[3], size_t max_cells,
                             void (*visit)(uint32_t index, void *context), void *context);
/* Append one contact to a list. */
void dem_candidates_push(struct dem_candidates *list, double s, uint32_t a, uint32_t b, int kind);

/* dem/collide.c: bin the particles and list the contacts of this step (swept spheres), sorted. */
void dem_detect_contacts(struct dem_solver *s);
/* dem/collide.c: find the contacts of this step and resolve them as impulses in order of time, searching
 * anew after every change of a path until none is left; lists the step's moving particles (s->moving)
 * first.  SC_ESIM naming the particles and the step past DEM_MAX_CONTACT_EVENTS contacts per moving
 * particle in one step. */
int dem_collide(struct dem_solver *s);
#define DEM_MAX_CONTACT_EVENTS 1000
/* A particle with this many contacts in one step is caught between bodies and stops (dem/collide.c); a
 * chain of 10 touching spheres hit at one end takes a few dozen. */
#define DEM_TRAP_CONTACTS 256
/* The contacts of the step are over for moving particle i: its contact flags (dem/collide.c) are cleared, so
 * that they are 0 for every particle between steps.  Inline: the integration asks it of every particle. */
static inline void dem_contacts_end_step(struct dem_solver *s, uint32_t i)
{
    s->start_kept[i] = 0;
    s->path_changed[i] = 0;
}

/* The drag skin of a particle of mass m under the drag force f at slip `slip` over a step: how far the drag
 * can bend its path off the straight line of its start velocity, a dt^2 / 2 for a constant acceleration
 * a = |f| / m, and phi a dt^2 for the phi-scheme's step (Eqs. 42-43: x = x0 + dt v0 + phi dt^2 (...)/m;
 * sub-steps give no more), with a factor 2 for the drag's growth within the step: 2 max(phi, 1/2) |f| dt^2 / m;
 * and at most 2 slip dt, since the drag only brings the velocity towards the gas's (a particle whose response
 * time is far below dt).  One formula for the skin of the step (dem_drag_skins) and the one foreseen for the
 * next (block_verify_reach), so that both give the same bits. */
static inline double dem_skin_from_force(const struct dem_config *cfg, const double f[3], double slip, double m)
{
    double phi = cfg->phi > 0.5 ? cfg->phi : 0.5;
    double bent = 2.0 * phi * cfg->dt * cfg->dt * sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) / m;
    double relaxed = 2.0 * slip * cfg->dt;
    return bent < relaxed ? bent : relaxed;
}

/* dem/integrate.c: the drag skins (p.skin) of the step's moving particles, from the drag at their start
 * states; and of particle i anew after its velocity changed in the step, from the drag at x with its new
 * velocity. */
void dem_drag_skins(struct dem_solver *s);
void dem_drag_skin_after_contact(struct dem_solver *s, uint32_t i, const double x[3]);
/* (x, v) of a particle of diameter d and mass m advanced by h under the drag alone (the phi-scheme of the rest of
 * a step, dem/integrate.c; nothing counted or kept): where its contact within the step meets it (dem/collide.c,
 * velocity_at_contact). */
void dem_fly_under_drag(const struct dem_config *cfg, double d, double m, double h, double x[3], double v[3]);

/* dem/integrate.c: advance the free particles over one step with the phi-scheme; end the contacts of the
 * step's moving particles (dem_contacts_end_step) and list those at a boundary (s->at_boundary). */
int dem_integrate(struct dem_solver *s);
/* For tests: the drag integration of the particles list[0, count) (increasing) over step `step`, no contacts
 * or boundaries: by the block engine, as dem_integrate runs it (reference = 0), or one by one by the scalar
 * reference (reference = 1), which the engine must match bit for bit.  Adds to counts: [0] fixed-point
 * iterations, [1] solves, [2] unconverged, [4] sub-cycled particle-steps; [3] the most iterations of a solve.
 * Returns whether a position or velocity is not finite. */
int dem_integrate_particles(const struct dem_config *cfg, struct dem_particles *p, int reuse_drag, int64_t step,
                            const uint32_t *list, size_t count, int reference, int64_t counts[5]);

/* The boundaries of the step's end (dem/solver.c), as tests of one particle after its integration; inline,
 * since dem_integrate asks them of every particle, in parallel. */
static inline double dem_handoff_plane(const struct dem_config *cfg)
{
    return cfg->standoff - cfg->handoff_height;
}

/* Did particle i cross the hand-off plane in this step (also a particle that crossed and stuck in it)? */
static inline int dem_crossed_handoff(const struct dem_solver *s, uint32_t i)
{
    const double plane = dem_handoff_plane(&s->cfg);
    return s->p.x_start[3 * i + 2] < plane && s->p.x[3 * i + 2] >= plane;
}

/* Would flying particle i end the step inside the target? */
static inline int dem_beyond_target(const struct dem_solver *s, uint32_t i)
{
    return s->p.x[3 * i + 2] > s->cfg.standoff - 0.5 * s->p.d[i];
}

/* Has flying particle i left the domain (radially, or behind the nozzle going back)?  The same before and
 * after the target-plane clamp, which moves no particle behind the nozzle. */
static inline int dem_escapes(const struct dem_solver *s, uint32_t i)
{
    const double *x = s->p.x + 3 * i;
    const double escape_radius2 = s->cfg.domain_radius * s->cfg.domain_radius;
    double dx = x[0] - s->cfg.gas.axis_x, dy = x[1] - s->cfg.gas.axis_y; /* from the jet's axis, which moves */
    int outside = dx * dx + dy * dy > escape_radius2;
    int behind_nozzle = x[2] < 0.0 && s->p.v[3 * i + 2] < 0.0;
    return outside || behind_nozzle;
}

/* Does the end of this step concern moving particle i (a hand-off crossing, the target plane, an escape)? */
static inline int dem_at_boundary(const struct dem_solver *s, uint32_t i)
{
    if (dem_crossed_handoff(s, i))
        return 1;
    return s->p.state[i] == DEM_FLYING && (dem_beyond_target(s, i) || dem_escapes(s, i));
}

/* dem/output.c */
void dem_sample_metrics(struct dem_solver *s);
/* The contact count of particle `id` (struct dem_solver contacts_of), the array grown to hold it. */
uint32_t *dem_contacts_of(struct dem_solver *s, int64_t id);

/* Grow a record array by one and return the new slot. */
void *dem_grow(void **items, size_t *count, size_t *capacity, size_t item_size);

#endif
