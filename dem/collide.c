/* Contacts of one step, Mukherjee & Zohdi: swept-sphere detection in place of the overlap test of Eq. 40
 * (broad phase in dem/broadphase.c), impulse resolution (Sections 2.1-2.2, Eqs. 1-23 in dem/contact.c;
 * collide-and-stream of Section 4.4), deposition rules (Section 3, Eqs. 33-34 with alpha_ADH; docs/physics.md).
 *
 * The paper tests for overlap at the end of a step (Eq. 40); at its step sizes a particle moves more
 * than its diameter per step, so contacts would be missed and particles would tunnel.  Here every pair
 * whose spheres (widened by their drag skins, dem/integrate.c), moving with their start-of-step velocities,
 * touch at some time s in [0, dt] is a contact.  Contacts are resolved as impulses in order of time,
 * (s, kind, a, b): a total order, so results do not depend on the thread count; after every change of a
 * path the new path's contacts join them ("contacts of changed paths" below; docs/physics.md, "Contacts
 * in order of time"). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/fastmath.h"
#include "dem/dem_impl.h"

/* ---------------------------------------------------------------- contacts of the step */

/* The target plane is reached within the step by a particle moving towards it: the time of impact and
 * whether there is one, for n moving particles from moving[0], by a loop without branches, which vectorises
 * (the division is done for every particle and its value used only where v_z is not <= 0, as the scalar test
 * used it).  Inlined with a constant `consecutive` (the particles are moving[0] + k: the usual case, all of
 * them flying), it reads the arrays with a known stride, not by gathers, which are slow. */
FM_INLINE void target_hits(const struct dem_solver *s, const uint32_t *moving, size_t n, int consecutive,
                           double *restrict t_hit, uint8_t *restrict hits)
{
    const double *restrict x = s->p.x, *restrict v = s->p.v, *restrict d = s->p.d, *restrict skin = s->p.skin;
    const double standoff = s->cfg.standoff, dt = s->cfg.dt;
    const size_t i0 = moving[0];
    for (size_t k = 0; k < n; k++) {
        size_t i = consecutive ? i0 + k : moving[k];
        double gap = standoff - (0.5 * d[i] + skin[i]) - x[3 * i + 2], vz = v[3 * i + 2]; /* dem_contact_radius */
        t_hit[k] = fm_select(gap <= 0.0, 0.0, gap / vz);
        hits[k] = (uint8_t)(!(vz <= 0.0) & (t_hit[k] <= dt));
    }
}

/* The target contacts of the step's moving particles, appended to `out` in any order (they are sorted); a
 * thread's share of them inside a parallel region, as dem_broadphase_pairs.  TARGET_CHUNK particles at a time (a
 * free particle is far from the target: the push is rare). */
#define TARGET_CHUNK 256
static void find_target_contacts(const struct dem_solver *s, struct dem_candidates *out)
{
    const size_t chunks = (s->moving_count + TARGET_CHUNK - 1) / TARGET_CHUNK;
#pragma omp for schedule(static) nowait
    for (size_t chunk = 0; chunk < chunks; chunk++) {
        size_t first = chunk * TARGET_CHUNK,
               n = s->moving_count - first < TARGET_CHUNK ? s->moving_count - first : TARGET_CHUNK;
        const uint32_t *moving = s->moving + first;
        double t_hit[TARGET_CHUNK];
        uint8_t hits[TARGET_CHUNK];
        if (moving[n - 1] - moving[0] == n - 1) /* moving is increasing */
            target_hits(s, moving, n, 1, t_hit, hits);
        else
            target_hits(s, moving, n, 0, t_hit, hits);
        for (const uint8_t *hit = memchr(hits, 1, n); hit; hit = memchr(hit + 1, 1, n - (size_t)(hit + 1 - hits))) {
            size_t k = (size_t)(hit - hits);
            dem_candidates_push(out, t_hit[k], moving[k], 0, CONTACT_TARGET);
        }
    }
}

/* The pair and target contacts of the step into s->candidates, in any order (they are sorted): one parallel
 * region for both, each thread's finds merged at its end. */
static void find_contacts(struct dem_solver *s)
{
#pragma omp parallel if (s->bins.pair_count + s->moving_count >= DEM_PARALLEL_MIN)
    {
        struct dem_candidates local = {0};
        dem_broadphase_pairs(&s->bins, &s->p, s->cfg.dt, &local);
        find_target_contacts(s, &local);
#pragma omp critical(dem_contacts_merge)
        for (size_t k = 0; k < local.count; k++)
            dem_candidates_push(&s->candidates, local.items[k].s, local.items[k].a, local.items[k].b,
                                local.items[k].kind);
        free(local.items);
    }
}

/* Resolution order: time of impact, then target contacts before pair contacts, then indices: a total order,
 * so the order in which the contacts were found does not matter. */
static int candidate_order(const void *pa, const void *pb)
{
    const struct dem_candidate *a = pa, *b = pb;
    if (a->s != b->s)
        return a->s < b->s ? -1 : 1;
    if (a->kind != b->kind)
        return a->kind < b->kind ? -1 : 1;
    if (a->a != b->a)
        return a->a < b->a ? -1 : 1;
    return a->b < b->b ? -1 : (a->b > b->b);
}

/* Every contact of this step, sorted into the order of resolution. */
void dem_detect_contacts(struct dem_solver *s)
{
    struct dem_particles *p = &s->p;
    s->candidates.count = 0;
    double start = omp_get_wtime();
    dem_broadphase_build(&s->bins, p, s->cfg.dt);
    s->timing.broad_phase += omp_get_wtime() - start;
    find_contacts(s);
    if (s->candidates.count > 1)
        qsort(s->candidates.items, s->candidates.count, sizeof *s->candidates.items, candidate_order);
}

/* ---------------------------------------------------------------- deposition rules */

/* Where x falls among n ascending values: the interval [*lo, *lo + 1] and the fraction f in it, clamped to the
 * ends (f 0 at or below the first value, the last interval with f 1 at or above the last; one value: f 0). */
static void bracket(const double *values, size_t n, double x, size_t *lo, double *f)
{
    *lo = 0;
    *f = 0.0;
    if (n < 2 || !(x > values[0]))
        return;
    if (x >= values[n - 1]) {
        *lo = n - 2;
        *f = 1.0;
        return;
    }
    size_t hi = 1;
    while (values[hi] < x)
        hi++;
    *lo = hi - 1;
    *f = (x - values[hi - 1]) / (values[hi] - values[hi - 1]);
}

/* Linear in d along the table's diameters, and in T along its temperatures when it has them (bilinear); clamped at
 * the table's ends: v_crit outside the searched range is not extrapolated (docs/physics.md "v_crit(d, T)"). */
double dem_vcrit_lookup(const struct dem_config *cfg, double d, double T)
{
    size_t i, j, nt = cfg->table_temperature_count;
    double fd, ft;
    bracket(cfg->table_diameter, cfg->table_count, d, &i, &fd);
    const double *v = cfg->table_velocity;
    size_t i1 = cfg->table_count > 1 ? i + 1 : i;
    if (nt == 0)
        return (1.0 - fd) * v[i] + fd * v[i1];
    bracket(cfg->table_temperature, nt, T, &j, &ft);
    size_t j1 = nt > 1 ? j + 1 : j;
    double at_lo = (1.0 - ft) * v[i * nt + j] + ft * v[i * nt + j1];
    double at_hi = (1.0 - ft) * v[i1 * nt + j] + ft * v[i1 * nt + j1];
    return (1.0 - fd) * at_lo + fd * at_hi;
}

/* Does a particle arriving at normal speed vn stick?  r_eff, gamma_partner, yield describe the contact; temperature
 * (K) is the particle's (the table rule's v_crit(d, T)). */
static int sticks(const struct dem_config *cfg, double vn, double mass, double d, double temperature, double r_eff,
                  double gamma_partner, double yield)
{
    switch (cfg->rule) {
    case DEM_DEPOSIT_ADHESION: /* Eq. 34 with alpha_ADH: an upper bound on the impact speed */
        return vn < dem_contact_adhesion_capture_speed(cfg->alpha_adh, cfg->powder.surface_energy, gamma_partner, mass,
                                                       r_eff, yield);
    case DEM_DEPOSIT_CRITICAL_VELOCITY: /* cold spray: bonding at and above v_crit */
        return vn >= cfg->critical_velocity;
    case DEM_DEPOSIT_TABLE:
        return vn >= dem_vcrit_lookup(cfg, d, temperature);
    case DEM_DEPOSIT_NONE:
        break;
    }
    return 0;
}

/* ---------------------------------------------------------------- resolution */

static struct sphere_state sphere_of(const struct dem_particles *p, uint32_t i, const struct dem_material *mat)
{
    struct sphere_state sphere = {.mass = p->m[i], .radius = 0.5 * p->d[i], .material = mat};
    memcpy(sphere.v, p->v + 3 * i, sizeof sphere.v);
    memcpy(sphere.w, p->w + 3 * i, sizeof sphere.w);
    return sphere;
}

/* Before the first change of particle i's velocity or spin in this step: keep them and its position as they
 * were at its start (the hand-off row of a particle that sticks in this step carries them).  Only the
 * particles that collide are copied, not every particle every step (dem_integrate keeps the start positions
 * of the others). */
static void keep_start_velocity(struct dem_solver *s, uint32_t i)
{
    struct dem_particles *p = &s->p;
    if (s->start_kept[i])
        return;
    memcpy(p->x_start + 3 * i, p->x + 3 * i, 3 * sizeof(double));
    memcpy(p->v_start + 3 * i, p->v + 3 * i, 3 * sizeof(double));
    memcpy(p->w_start + 3 * i, p->w + 3 * i, 3 * sizeof(double));
    s->start_kept[i] = 1;
    s->contact_flags_set = 1;
}

static void store_sphere(struct dem_solver *s, uint32_t i, const struct sphere_state *sphere)
{
    struct dem_particles *p = &s->p;
    keep_start_velocity(s, i);
    p->drag.kept[i] = 0;
    memcpy(p->v + 3 * i, sphere->v, sizeof sphere->v);
    memcpy(p->w + 3 * i, sphere->w, sizeof sphere->w);
}

/* Where particle i's current path starts, and when.  Until its velocity changes in this step (start_kept),
 * a particle is on the path it started the step on: from x at time 0 (contacts move no particle but the one
 * that sticks, and that one starts a new path), so only the particles that collide need path_x and path_time,
 * and a deposit of an earlier step is at x. */
static const double *path_origin(const struct dem_solver *s, uint32_t i)
{
    return s->start_kept[i] ? s->path_x + 3 * i : s->p.x + 3 * i;
}

static double path_start_time(const struct dem_solver *s, uint32_t i)
{
    return s->start_kept[i] ? s->path_time[i] : 0.0;
}

/* Centre of particle i at time `at` of the step, on its current path. */
static void path_position(const struct dem_solver *s, uint32_t i, double at, double out[3])
{
    const double *origin = path_origin(s, i);
    double since = at - path_start_time(s, i);
    for (int k = 0; k < 3; k++)
        out[k] = origin[k] + s->p.v[3 * i + k] * since;
}

#define PATH_SEARCH_DUE 1 /* path_changed: restarted, its contacts not yet searched */
#define PATH_LISTED     2 /* path_changed: in the step's list of changed particles (contacts of changed paths) */

/* After a velocity change at time `at` (keep_start_velocity came first) with the particle at x: its path
 * restarts there. */
static void path_restart(struct dem_solver *s, uint32_t i, double at, const double x[3])
{
    s->path_time[i] = at;
    memcpy(s->path_x + 3 * i, x, 3 * sizeof(double));
    s->path_changed[i] |= PATH_SEARCH_DUE;
    s->contact_flags_set = 1;
    if (s->p.state[i] == DEM_FLYING) /* the drag skin of the new velocity */
        dem_drag_skin_after_contact(s, i, x);
}

/* When particle i, on its current path, touches the target (partner < 0) or particle `partner` (on its
 * current path) while approaching, within the step; -1 if it does not.  For particles whose velocities
 * have not changed in this step this is exactly the time found by the broad phase; after an earlier
 * contact it is found again from the new paths, so a particle that bounced cannot meet its old partners
 * where its old path would have taken it. */
static double contact_time(const struct dem_solver *s, uint32_t i, int64_t partner)
{
    const struct dem_particles *p = &s->p;
    const double dt = s->cfg.dt;
    if (partner < 0) {
        double vz = p->v[3 * i + 2], start = path_start_time(s, i);
        double gap = s->cfg.standoff - dem_contact_radius(p, i) - path_origin(s, i)[2];
        if (vz <= 0.0)
            return -1.0;
        double at = gap <= 0.0 ? start : start + gap / vz;
        return at <= dt ? at : -1.0;
    }
    uint32_t j = (uint32_t)partner;
    double start = fmax(path_start_time(s, i), path_start_time(s, j)), xi[3], xj[3], dx[3], dv[3];
    path_position(s, i, start, xi);
    path_position(s, j, start, xj);
    for (int k = 0; k < 3; k++) {
        dx[k] = xj[k] - xi[k];
        dv[k] = p->v[3 * j + k] - p->v[3 * i + k];
    }
    double delay = dem_time_of_impact(dx, dv, dem_contact_radius(p, i) + dem_contact_radius(p, j), dt - start);
    return delay < 0.0 ? -1.0 : start + delay;
}

static void record_impact(struct dem_solver *s, uint32_t i, double at, const double x[3],
                          const struct sphere_state *before, int outcome, int64_t partner)
{
    struct dem_impact *row = dem_grow((void **)&s->impacts, &s->impact_count, &s->impact_capacity, sizeof *row);
    const struct dem_particles *p = &s->p;
    row->t = (double)s->step * s->cfg.dt + at;
    row->particle_id = p->id[i];
    memcpy(row->x, x, sizeof row->x);
    memcpy(row->v_in, before->v, sizeof row->v_in);
    memcpy(row->w_in, before->w, sizeof row->w_in);
    memcpy(row->v_out, p->v + 3 * i, sizeof row->v_out);
    memcpy(row->w_out, p->w + 3 * i, sizeof row->w_out);
    row->d = p->d[i];
    row->m = p->m[i];
    row->outcome = outcome;
    row->partner = partner;
    uint32_t *contacts = dem_contacts_of(s, p->id[i]);
    row->contact_index = *contacts;
    row->temperature = p->temperature[i];
    ++*contacts;
    if (outcome == DEM_STUCK && row->contact_index == 0)
        s->first_impact_deposits++;
}

/* Particle i stops at x: deposited (it stuck) or resting (it lies there without having stuck). */
static void freeze(struct dem_solver *s, uint32_t i, const double x[3], int state)
{
    struct dem_particles *p = &s->p;
    keep_start_velocity(s, i);
    p->drag.kept[i] = 0;
    memcpy(p->x + 3 * i, x, 3 * sizeof(double));
    memset(p->v + 3 * i, 0, 3 * sizeof(double));
    memset(p->w + 3 * i, 0, 3 * sizeof(double));
    p->state[i] = (uint8_t)state;
    if (state == DEM_DEPOSITED)
        s->deposited++;
    else
        s->resting++;
}

/* Unit normal from the centre x of particle i to the obstacle: the target plane or deposited `partner`. */
static void obstacle_normal(const struct dem_particles *p, int64_t partner, const double x[3], double n[3])
{
    if (partner < 0) {
        n[0] = 0.0, n[1] = 0.0, n[2] = 1.0;
        return;
    }
    const double *xj = p->x + 3 * partner;
    double dist =
        sqrt((xj[0] - x[0]) * (xj[0] - x[0]) + (xj[1] - x[1]) * (xj[1] - x[1]) + (xj[2] - x[2]) * (xj[2] - x[2]));
    for (int k = 0; k < 3; k++)
        n[k] = (xj[k] - x[k]) / dist;
}

static double squared_distance(const double a[3], const double b[3])
{
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

/* The particles whose path changed in this step, in order of their first change, with the boxes of their
 * paths (path_box) when they were last searched: boxes that do not meet hold no contact. */
struct changed_list {
    uint32_t *items;
    double *lo, *hi; /* 3 per item */
    size_t count, capacity, box_capacity;
};

/* Most grid cells one search visits (a wider box: every particle). */
#define SECONDARY_MAX_CELLS 4096

/* Does a particle of radius r at x overlap a particle at rest (deposited or resting) other than i and `partner`?
 * A flying one is left to the contact search that follows i's change of path. */
struct rest_overlap_query {
    const struct dem_solver *s;
    uint32_t self;
    int64_t partner;
    const double *x;
    double r;
    int overlaps;
};

static void rest_overlap_visit(uint32_t j, void *context)
{
    struct rest_overlap_query *q = context;
    const struct dem_particles *p = &q->s->p;
    if (j == q->self || (int64_t)j == q->partner || j >= p->count || p->state[j] == DEM_FLYING)
        return;
    double reach = q->r + 0.5 * p->d[j];
    q->overlaps |= squared_distance(q->x, p->x + 3 * j) < reach * reach * (1.0 - 1e-12);
}

static int overlaps_at_rest(const struct dem_solver *s, const struct changed_list *changed, uint32_t i, int64_t partner,
                            const double x[3], double r)
{
    struct rest_overlap_query query = {s, i, partner, x, r, 0};
    double lo[3], hi[3];
    for (int k = 0; k < 3; k++)
        lo[k] = x[k] - r, hi[k] = x[k] + r;
    /* a particle at rest since an earlier step is in the grid with its sphere: if it overlaps the sphere, it shares
     * a cell with the sphere's box (too wide a box: every particle); one that came to rest in this step, perhaps
     * off the path the grid holds, is in the step's list of changed particles */
    if (dem_broadphase_visit_box(&s->bins, lo, hi, SECONDARY_MAX_CELLS, rest_overlap_visit, &query) != 0)
        for (size_t j = 0; j < s->p.count && !query.overlaps; j++)
            rest_overlap_visit((uint32_t)j, &query);
    for (size_t k = 0; k < changed->count && !query.overlaps; k++)
        rest_overlap_visit(changed->items[k], &query);
    return query.overlaps;
}

/* Where particle i of radius r that stuck (or came to rest) at x_hit stays: touching its obstacle, moved there
 * along the normal.  It met the obstacle within the drag skins (dem_contact_radius), up to a third of a diameter
 * away in the stagnation layer, or overlapping it; from within the skins it is moved in unless a particle at rest
 * is in the way there (then it stays where it met the obstacle: a safety net, since one that close would have been
 * met first, within the skins, save for the drag's bending of the path); out of an overlap always, a correction
 * that is counted (docs/physics.md, "Contact detection"). */
static void rest_position(struct dem_solver *s, const struct changed_list *changed, uint32_t i, int64_t partner,
                          const double x_hit[3], const double n[3], double r, double obstacle_radius, double rest[3])
{
    double reach = partner < 0 ? r : r + obstacle_radius;
    double depth =
        partner < 0 ? x_hit[2] - (s->cfg.standoff - r) : reach - sqrt(squared_distance(x_hit, s->p.x + 3 * partner));
    double touching[3];
    for (int k = 0; k < 3; k++)
        touching[k] = partner < 0 ? x_hit[k] : s->p.x[3 * partner + k] - n[k] * reach;
    if (partner < 0)
        touching[2] = s->cfg.standoff - r;
    s->stats.clamps += depth > 1e-9 * reach;
    int moved_in = depth <= 0.0 && !overlaps_at_rest(s, changed, i, partner, touching, r);
    memcpy(rest, depth > 0.0 || moved_in ? touching : x_hit, 3 * sizeof(double));
}

/* Eq. 33 under the adhesion rule: the adhesion force acts through the whole contact, so a particle that does
 * not stick leaves with the normal speed e (v0 - v*), not e v0 (v* the capture speed of Eq. 34, v0 = vn_in
 * the arrival normal speed; e whatever the contact law gave, read off the rebound: e v0 = the normal speed
 * out).  n points from the particle to the obstacle; the tangential velocity and the spin are left as the
 * contact law made them. */
static void adhesion_slowed_rebound(struct sphere_state *sphere, const double n[3], double vn_in, double capture)
{
    if (!(vn_in > 0.0))
        return;
    double normal = sphere->v[0] * n[0] + sphere->v[1] * n[1] + sphere->v[2] * n[2]; /* < 0: leaving */
    double slowed = normal * (vn_in - capture) / vn_in;
    for (int k = 0; k < 3; k++)
        sphere->v[k] += (slowed - normal) * n[k];
}

/* Particle i's state at time `at` of the step: flown under the drag (dem_fly_under_drag) from its path's start,
 * where it had the path's velocity, to `at`.  Its path, straight at that velocity, is where the contacts were
 * found; the drag has slowed (or turned) it since, so at `at` it is short of the path's place and slower. */
static void fly_path_to(const struct dem_solver *s, uint32_t i, double at, double x[3], double v[3])
{
    const struct dem_particles *p = &s->p;
    double h = at - path_start_time(s, i);
    memcpy(x, path_origin(s, i), 3 * sizeof *x);
    memcpy(v, p->v + 3 * i, 3 * sizeof *v);
    if (h > 0.0)
        dem_fly_under_drag(&s->cfg, p->d[i], p->m[i], h, x, v);
}

/* A particle's state on the drag's path: at time t of the step (t may lie beyond the step's end), at x with
 * velocity v. */
struct drag_state {
    double t, x[3], v[3];
};

/* Particle i's velocity where it meets an immovable body.  Its path touches the body at `at`, at x_hit, with
 * normal n (towards the body); flown under the drag to `at` (fly_path_to), it is still short of x_hit there, and
 * flies on by the distance left along n over its approach speed, twice more: `meet`, the drag's path where it
 * meets the body, whose velocity the impact takes.  With the path's velocity instead (the velocity at the start of
 * the step), the impact missed the drag of the part of the step before it: 16 % too fast for a 3 um particle
 * crossing the demo's bow shock layer at dt = 1 us, and the demo's deposition efficiency 0.0400 against 0.0298 at
 * dt -> 0 (a review).  The contact keeps its time and place (`at`, x_hit): only the velocity changes.  `within`:
 * the last of these states within the step, where a particle that the drag turned away before it met the body
 * goes on (turned_away). */
static void velocity_at_contact(const struct dem_solver *s, uint32_t i, double at, const double x_hit[3],
                                const double n[3], struct drag_state *meet, struct drag_state *within)
{
    const struct dem_particles *p = &s->p;
    meet->t = at;
    fly_path_to(s, i, at, meet->x, meet->v);
    *within = *meet;
    for (int pass = 1; pass < 3 && at > path_start_time(s, i); pass++) {
        double left = 0.0, approach = 0.0;
        for (int k = 0; k < 3; k++) {
            left += (x_hit[k] - meet->x[k]) * n[k];
            approach += meet->v[k] * n[k];
        }
        double h = approach > 0.0 && left > 0.0 ? fmin(left / approach, s->cfg.dt) : 0.0;
        if (!(h > 0.0))
            break;
        dem_fly_under_drag(&s->cfg, p->d[i], p->m[i], h, meet->x, meet->v);
        meet->t += h;
        if (meet->t <= s->cfg.dt)
            *within = *meet;
    }
}

/* Particle i moves on from x at time `at` of the step with velocity v and spin w: its path restarts there. */
static void restart_at(struct dem_solver *s, uint32_t i, double at, const double x[3], const double v[3],
                       const double w[3])
{
    struct sphere_state sphere = sphere_of(&s->p, i, &s->cfg.powder);
    memcpy(sphere.v, v, sizeof sphere.v);
    memcpy(sphere.w, w, sizeof sphere.w);
    store_sphere(s, i, &sphere);
    path_restart(s, i, at, x);
}

/* A contact found on the straight paths that the drag turned away before the bodies met: no impulse, no impact
 * row.  Particle i goes on from the drag's state `from` (spin kept), the path along which the integration of the
 * rest of the step (dem/integrate.c integrate_rest_of_step) flies it and the rest of its contacts are searched;
 * left on its straight path, it would be searched along a path that runs on into the body.  The caller counts
 * the contact (contacts_turned_away; docs/physics.md "The spray's resolution"). */
static void turned_away(struct dem_solver *s, uint32_t i, const struct drag_state *from)
{
    restart_at(s, i, from->t, from->x, from->v, s->p.w + 3 * i);
}

/* Flying particle i meets an immovable body: the target (partner < 0) or deposited particle `partner`. */
static void resolve_fixed(struct dem_solver *s, const struct changed_list *changed, uint32_t i, int64_t partner)
{
    struct dem_particles *p = &s->p;
    const struct dem_config *cfg = &s->cfg;
    double at = contact_time(s, i, partner);
    if (at < 0.0)
        return;
    double x_hit[3], n[3];
    path_position(s, i, at, x_hit);
    obstacle_normal(p, partner, x_hit, n);
    double obstacle_radius = partner < 0 ? INFINITY : 0.5 * p->d[partner];
    const struct dem_material *obstacle = partner < 0 ? &cfg->target : &cfg->powder;
    struct sphere_state sphere = sphere_of(p, i, &cfg->powder);
    struct drag_state meet, within;
    velocity_at_contact(s, i, at, x_hit, n, &meet, &within);
    memcpy(sphere.v, meet.v, sizeof sphere.v);
    struct sphere_state before = sphere;
    struct contact_outcome outcome;
    if (!dem_contact_fixed(&cfg->contact, &sphere, obstacle, obstacle_radius, n, &outcome)) {
        /* separating: turned away by the drag (its centre no longer approaches), or by its spin alone, which
         * a contact found on a path approaching the body leaves as it was */
        if (meet.v[0] * n[0] + meet.v[1] * n[1] + meet.v[2] * n[2] <= 0.0) {
            turned_away(s, i, &within);
            s->stats.contacts_turned_away++;
        }
        return;
    }
    double r = 0.5 * p->d[i];
    double r_eff = partner < 0 ? r : r * obstacle_radius / (r + obstacle_radius);
    double yield = fmin(cfg->powder.yield_stress, obstacle->yield_stress);
    int stuck = sticks(cfg, outcome.vn, p->m[i], p->d[i], p->temperature[i], r_eff, obstacle->surface_energy, yield);
    if (!stuck && cfg->rule == DEM_DEPOSIT_ADHESION)
        adhesion_slowed_rebound(&sphere, n, outcome.vn,
                                dem_contact_adhesion_capture_speed(cfg->alpha_adh, cfg->powder.surface_energy,
                                                                   obstacle->surface_energy, p->m[i], r_eff, yield));
    /* A rebounder that arrives slower than rest_speed comes to rest instead: in the wall region the gas pushes it
     * back at once, and it would bounce in place, re-collided every step, for the rest of the run (docs/physics.md
     * "Resting particles").  Its whole speed, not the normal component alone: one sliding along the wall jet is not
     * bouncing in place (a review: the demo's one resting particle arrived at 0.93 m/s along the normal and 274 m/s
     * along the target, and lay there as an obstacle for the rest of the run).  Without gas nothing brings it
     * back: it rebounds. */
    double speed_in = sqrt(before.v[0] * before.v[0] + before.v[1] * before.v[1] + before.v[2] * before.v[2]);
    int rests = !stuck && cfg->gas.model != DEM_JET_NONE && speed_in < cfg->rest_speed;
    store_sphere(s, i, &sphere);
    if (stuck || rests) {
        double rest[3];
        rest_position(s, changed, i, partner, x_hit, n, r, obstacle_radius, rest);
        memcpy(x_hit, rest, sizeof rest);
        freeze(s, i, x_hit, stuck ? DEM_DEPOSITED : DEM_RESTING);
    }
    path_restart(s, i, at, x_hit);
    record_impact(s, i, at, x_hit, &before,
                  stuck   ? DEM_STUCK
                  : rests ? DEM_RESTED
                          : DEM_REBOUND,
                  partner < 0 ? -1 : p->id[partner]);
    if (partner < 0)
        s->stats.contacts_target++;
    else
        s->stats.contacts_deposit++;
}

static void resolve_pair(struct dem_solver *s, const struct changed_list *changed, uint32_t a, uint32_t b)
{
    struct dem_particles *p = &s->p;
    int a_flying = p->state[a] == DEM_FLYING, b_flying = p->state[b] == DEM_FLYING;
    if (!a_flying && !b_flying)
        return;
    if (!b_flying) {
        resolve_fixed(s, changed, a, b);
        return;
    }
    if (!a_flying) { /* a was deposited earlier in this step */
        resolve_fixed(s, changed, b, a);
        return;
    }
    double at = contact_time(s, a, b);
    if (at < 0.0)
        return;
    double xa[3], xb[3], n[3];
    path_position(s, a, at, xa);
    path_position(s, b, at, xb);
    double dist =
        sqrt((xb[0] - xa[0]) * (xb[0] - xa[0]) + (xb[1] - xa[1]) * (xb[1] - xa[1]) + (xb[2] - xa[2]) * (xb[2] - xa[2]));
    for (int k = 0; k < 3; k++)
        n[k] = (xb[k] - xa[k]) / dist;
    /* Each at its velocity on the drag's path at `at` (fly_path_to), as an impact on an immovable body takes
     * the drag's (velocity_at_contact), not the start of the step's: the time only, without the passes beyond
     * `at` to where the drag's paths meet.  Both lag their straight paths, and what is left between them closes
     * at their relative speed, which can be near zero (one overtaking the other): the passes would divide a
     * difference of lags by a difference of speeds.  The part they leave out, the drag from `at` to the meeting,
     * is of second order in the step (of (h/tau)^2 / 2 against h/tau for the part before `at`), and no
     * deposition rule reads a pair's speeds. */
    struct sphere_state sa = sphere_of(p, a, &s->cfg.powder), sb = sphere_of(p, b, &s->cfg.powder);
    struct drag_state fa = {.t = at}, fb = {.t = at};
    fly_path_to(s, a, at, fa.x, fa.v);
    fly_path_to(s, b, at, fb.x, fb.v);
    memcpy(sa.v, fa.v, sizeof sa.v);
    memcpy(sb.v, fb.v, sizeof sb.v);
    struct contact_outcome outcome;
    if (!dem_contact_pair(&s->cfg.contact, &sa, &sb, n, &outcome)) {
        double closing = 0.0; /* turned away by the drag, as in resolve_fixed, or separating by spin alone */
        for (int k = 0; k < 3; k++)
            closing += (fa.v[k] - fb.v[k]) * n[k];
        if (closing <= 0.0) {
            turned_away(s, a, &fa);
            turned_away(s, b, &fb);
            s->stats.contacts_turned_away++;
        }
        return;
    }
    store_sphere(s, a, &sa);
    store_sphere(s, b, &sb);
    path_restart(s, a, at, xa);
    path_restart(s, b, at, xb);
    s->stats.contacts_pair++;
}

/* ---------------------------------------------------------------- contacts of changed paths */

/* A particle whose velocity changed in the step (or that stuck in it) can meet particles its old path never
 * came near, and its old contacts no longer hold.  The contacts are therefore resolved as events in order
 * of time: those found at the start of the step (sorted) and, after every change of a particle's path, the
 * contacts of its new path (from where it restarted to the end of the step: the path the integration then
 * follows, dem/integrate.c) with the target, the unchanged particles (through the grid) and the particles
 * changed before it (directly: their grid entries hold their old paths), pushed into a heap.  A contact
 * found before a change of one of its particles no longer matches their paths (its time, found again, is
 * not the same) and is dropped: the search after the change found the one that holds.  The step goes on
 * until no contact is left, so none is dropped; past DEM_MAX_CONTACT_EVENTS per moving particle (a particle
 * caught between bodies that never lets go) it stops with an error naming the particles and the step. */

struct secondary_query {
    struct dem_solver *s;
    uint32_t moving;
    struct dem_candidates *out;
};

/* A pair contact of i (whose path changed) with j, if they touch while approaching in the rest of the step;
 * the flying particle first, the lower index first when both fly (the order of dem_broadphase_pairs). */
static void push_pair_contact(struct dem_solver *s, uint32_t i, uint32_t j, struct dem_candidates *out)
{
    double at = contact_time(s, i, j);
    if (at < 0.0)
        return;
    int i_flying = s->p.state[i] == DEM_FLYING, j_flying = s->p.state[j] == DEM_FLYING;
    if (!i_flying && !j_flying)
        return;
    uint32_t a = !i_flying || (j_flying && j < i) ? j : i, b = a == i ? j : i;
    dem_candidates_push(out, at, a, b, CONTACT_PAIR);
}

static void consider_partner(uint32_t j, void *context)
{
    struct secondary_query *query = context;
    struct dem_solver *s = query->s;
    uint32_t i = query->moving;
    if (j == i || s->seen[j] == s->seen_stamp)
        return;
    s->seen[j] = s->seen_stamp;
    if (s->path_changed[j] & PATH_LISTED)
        return; /* changed too: tested directly */
    push_pair_contact(s, i, j, query->out);
}

/* The box of i's sphere along its current path from its path time to the end of the step. */
static void path_box(const struct dem_solver *s, uint32_t i, double lo[3], double hi[3])
{
    double end[3], radius = dem_contact_radius(&s->p, i) * (1.0 + 1e-9);
    const double *origin = path_origin(s, i);
    path_position(s, i, s->cfg.dt, end);
    for (int c = 0; c < 3; c++) {
        lo[c] = fmin(origin[c], end[c]) - radius;
        hi[c] = fmax(origin[c], end[c]) + radius;
    }
}

static int boxes_meet(const double *lo_a, const double *hi_a, const double *lo_b, const double *hi_b)
{
    return lo_a[0] <= hi_b[0] && lo_b[0] <= hi_a[0] && lo_a[1] <= hi_b[1] && lo_b[1] <= hi_a[1] && lo_a[2] <= hi_b[2] &&
           lo_b[2] <= hi_a[2];
}

/* The contacts of particle i's new path, into `out`: the target, the unchanged particles whose grid boxes
 * its path's box meets, and every particle changed before it. */
static void find_contacts_of_new_path(struct dem_solver *s, uint32_t i, const struct changed_list *changed,
                                      struct dem_candidates *out)
{
    if (s->p.state[i] == DEM_FLYING) {
        double at = contact_time(s, i, -1);
        if (at >= 0.0)
            dem_candidates_push(out, at, i, 0, CONTACT_TARGET);
    }
    if (++s->seen_stamp == 0) { /* wrapped: start the stamps afresh, also in the free slots (stamps are
                                 * kept from step to step; a new particle there keeps its slot's) */
        memset(s->seen, 0, s->path_capacity * sizeof *s->seen);
        s->seen_stamp = 1;
    }
    double lo[3], hi[3];
    path_box(s, i, lo, hi);
    struct secondary_query query = {s, i, out};
    /* a path whose box spans more cells than the search visits (not seen: a changed path moves at most a few times
     * the fastest particle's step, and a cell is at least that): every particle, rather than none */
    if (dem_broadphase_visit_box(&s->bins, lo, hi, SECONDARY_MAX_CELLS, consider_partner, &query) != 0)
        for (size_t j = 0; j < s->p.count; j++)
            consider_partner((uint32_t)j, &query);
    for (size_t k = 0; k < changed->count; k++)
        if (changed->items[k] != i && boxes_meet(lo, hi, changed->lo + 3 * k, changed->hi + 3 * k))
            push_pair_contact(s, i, changed->items[k], out);
}

/* The heap of contacts found after changes, in candidate_order (a binary min-heap). */
static void heap_push(struct dem_candidates *heap, const struct dem_candidate *c)
{
    dem_candidates_push(heap, c->s, c->a, c->b, c->kind);
    struct dem_candidate *h = heap->items;
    for (size_t k = heap->count - 1; k > 0;) {
        size_t parent = (k - 1) / 2;
        if (candidate_order(&h[k], &h[parent]) >= 0)
            break;
        struct dem_candidate t = h[k];
        h[k] = h[parent];
        h[parent] = t;
        k = parent;
    }
}

static struct dem_candidate heap_pop(struct dem_candidates *heap)
{
    struct dem_candidate *h = heap->items, top = h[0];
    h[0] = h[--heap->count];
    for (size_t k = 0;;) {
        size_t least = k, left = 2 * k + 1, right = left + 1;
        if (left < heap->count && candidate_order(&h[left], &h[least]) < 0)
            least = left;
        if (right < heap->count && candidate_order(&h[right], &h[least]) < 0)
            least = right;
        if (least == k)
            break;
        struct dem_candidate t = h[k];
        h[k] = h[least];
        h[least] = t;
        k = least;
    }
    return top;
}

/* Does contact c still hold on the particles' current paths (its time found again is the same)? */
static int still_holds(const struct dem_solver *s, const struct dem_candidate *c)
{
    double at = c->kind == CONTACT_TARGET ? contact_time(s, c->a, -1) : contact_time(s, c->a, c->b);
    return at >= 0.0 && fabs(at - c->s) <= 1e-9 * s->cfg.dt;
}

static void resolve_candidate(struct dem_solver *s, const struct changed_list *changed, const struct dem_candidate *c)
{
    if (c->kind == CONTACT_TARGET) {
        if (s->p.state[c->a] == DEM_FLYING)
            resolve_fixed(s, changed, c->a, -1);
    } else {
        resolve_pair(s, changed, c->a, c->b);
    }
}

/* Particle i moves on from where it is at time `at` with velocity v and no spin. */
static void restart_with_velocity(struct dem_solver *s, uint32_t i, double at, const double v[3])
{
    double x[3], w[3] = {0.0, 0.0, 0.0};
    path_position(s, i, at, x);
    restart_at(s, i, at, x, v, w);
}

/* Do flying particles i and j touch at time `at` (within their contact radii)? */
static int touching_at(const struct dem_solver *s, uint32_t i, uint32_t j, double at)
{
    double xi[3], xj[3], reach = (dem_contact_radius(&s->p, i) + dem_contact_radius(&s->p, j)) * (1.0 + 1e-9);
    path_position(s, i, at, xi);
    path_position(s, j, at, xj);
    return squared_distance(xi, xj) <= reach * reach;
}

/* A flying particle caught between bodies: DEM_TRAP_CONTACTS contacts in one step, as within the drag skins of
 * two bodies facing each other (it bounces from one to the other without moving on) or in a cluster that
 * collapses inelastically (a chain of touching spheres at e = 0.5: the contacts pile up without end).  At
 * the time of its contact c, and again at every further contact in the step, it and the changed particles
 * touching it (transitively) move on as one body without spin: at rest if c is with the target or a
 * deposit, else at their centre-of-mass velocity (momentum kept).  Counted; the members go to members[],
 * their number returned. */
static size_t stop_trapped(struct dem_solver *s, const struct dem_candidate *c, uint32_t i,
                           const struct changed_list *changed, uint32_t *members)
{
    const struct dem_particles *p = &s->p;
    size_t n = 0;
    members[n++] = i;
    int fixed = c->kind == CONTACT_TARGET || p->state[c->a] != DEM_FLYING || p->state[c->b] != DEM_FLYING;
    for (size_t m = 0; m < n; m++)
        for (size_t k = 0; k < changed->count; k++) {
            uint32_t j = changed->items[k];
            int member = 0;
            for (size_t q = 0; q < n; q++)
                member |= members[q] == j;
            if (!member && p->state[j] == DEM_FLYING && touching_at(s, members[m], j, c->s))
                members[n++] = j;
        }
    double momentum[3] = {0.0, 0.0, 0.0}, mass = 0.0, v[3] = {0.0, 0.0, 0.0};
    for (size_t m = 0; m < n && !fixed; m++) {
        mass += p->m[members[m]];
        for (int k = 0; k < 3; k++)
            momentum[k] += p->m[members[m]] * p->v[3 * members[m] + k];
    }
    for (int k = 0; k < 3 && !fixed; k++)
        v[k] = momentum[k] / mass;
    for (size_t m = 0; m < n; m++)
        restart_with_velocity(s, members[m], c->s, v);
    s->stats.trapped += (int64_t)n;
    return n;
}

/* The contacts of particle i's new path into the heap; i joins the list of changed particles. */
static void search_new_path(struct dem_solver *s, uint32_t i, struct changed_list *changed, struct dem_candidates *heap,
                            struct dem_candidates *found)
{
    s->path_changed[i] &= (uint8_t)~PATH_SEARCH_DUE;
    found->count = 0;
    find_contacts_of_new_path(s, i, changed, found);
    for (size_t k = 0; k < found->count; k++)
        heap_push(heap, &found->items[k]);
    size_t k = 0;
    if (!(s->path_changed[i] & PATH_LISTED)) {
        s->path_changed[i] |= PATH_LISTED;
        uint32_t *slot = dem_grow((void **)&changed->items, &changed->count, &changed->capacity, sizeof *slot);
        *slot = i;
        k = changed->count - 1;
        if (changed->capacity > changed->box_capacity) {
            changed->box_capacity = changed->capacity;
            changed->lo = dem_realloc_or_die(changed->lo, 3 * changed->box_capacity * sizeof(double));
            changed->hi = dem_realloc_or_die(changed->hi, 3 * changed->box_capacity * sizeof(double));
        }
    } else {
        while (changed->items[k] != i)
            k++;
    }
    path_box(s, i, changed->lo + 3 * k, changed->hi + 3 * k);
}

/* After contact c: the new contacts of particle i (one of c's), if its path changed, and of those that a
 * stop changed with it. */
static void search_changed(struct dem_solver *s, const struct dem_candidate *c, uint32_t i,
                           struct changed_list *changed, struct dem_candidates *heap, struct dem_candidates *found)
{
    if (!(s->path_changed[i] & PATH_SEARCH_DUE))
        return;
    if (++s->contacts_in_step[i] >= DEM_TRAP_CONTACTS && s->p.state[i] == DEM_FLYING) {
        uint32_t *members = dem_realloc_or_die(NULL, (changed->count + 1) * sizeof *members);
        size_t n = stop_trapped(s, c, i, changed, members);
        for (size_t m = 1; m < n; m++)
            search_new_path(s, members[m], changed, heap, found);
        free(members);
    }
    search_new_path(s, i, changed, heap, found);
}

/* The contacts did not end: SC_ESIM naming the step and the particles of the last contact. */
static int contacts_did_not_end(const struct dem_solver *s, const struct dem_candidate *c, int64_t events)
{
    const struct dem_particles *p = &s->p;
    if (c->kind == CONTACT_TARGET)
        SC_FAIL(SC_ESIM,
                "spray: step %lld (t = %.9g s): %lld contacts in the step and still more: particle %lld keeps meeting "
                "the target; a smaller [spray] dt resolves it",
                (long long)s->step, (double)s->step * s->cfg.dt, (long long)events, (long long)p->id[c->a]);
    SC_FAIL(SC_ESIM,
            "spray: step %lld (t = %.9g s): %lld contacts in the step and still more: particles %lld and %lld keep "
            "meeting; a smaller [spray] dt resolves it",
            (long long)s->step, (double)s->step * s->cfg.dt, (long long)events, (long long)p->id[c->a],
            (long long)p->id[c->b]);
}

/* Every contact of the step, in order of time (see above). */
static int resolve_contacts_in_order(struct dem_solver *s)
{
    const struct dem_candidates *initial = &s->candidates;
    struct dem_candidates heap = {0}, found = {0};
    struct changed_list changed = {0};
    const int64_t most = DEM_MAX_CONTACT_EVENTS * (int64_t)(s->moving_count + 1);
    int64_t events = 0;
    int status = SC_OK;
    for (size_t next = 0;;) {
        struct dem_candidate c;
        int from_heap =
            heap.count && (next == initial->count || candidate_order(&heap.items[0], &initial->items[next]) < 0);
        if (from_heap)
            c = heap_pop(&heap);
        else if (next < initial->count)
            c = initial->items[next++];
        else
            break;
        if (!still_holds(s, &c))
            continue;
        if (++events > most) {
            status = contacts_did_not_end(s, &c, events);
            break;
        }
        resolve_candidate(s, &changed, &c);
        search_changed(s, &c, c.a, &changed, &heap, &found);
        if (c.kind == CONTACT_PAIR)
            search_changed(s, &c, c.b, &changed, &heap, &found);
    }
    for (size_t k = 0; k < changed.count; k++)
        s->contacts_in_step[changed.items[k]] = 0;
    free(heap.items);
    free(found.items);
    free(changed.items);
    free(changed.lo);
    free(changed.hi);
    return status;
}

/* Slices of the particles for list_moving: each slice's flyers are counted, then written after those of the
 * slices before, so the list is the same for any thread count. */
#define MOVING_SLICES 16

static size_t count_flying(const uint8_t *state, size_t first, size_t end)
{
    size_t n = 0;
    for (size_t i = first; i < end; i++)
        n += state[i] == DEM_FLYING;
    return n;
}

/* The flyers of [first, end) to out[].  Up to the last flyer only: the loop without a branch (deposits and
 * flyers interleave) writes each index at the next free slot, a deposit's to be overwritten, and past the
 * last flyer that slot would be the next slice's. */
static void list_flying(const uint8_t *state, size_t first, size_t end, uint32_t *out)
{
    while (end > first && state[end - 1] != DEM_FLYING)
        end--;
    size_t n = 0;
    for (size_t i = first; i < end; i++) {
        out[n] = (uint32_t)i;
        n += state[i] == DEM_FLYING;
    }
}

/* s->moving: the flying particles, in index order.  The list of the last step still holds when no particle
 * was injected, deposited, brought to rest or removed since (the particles and their states are as then). */
static void list_moving(struct dem_solver *s)
{
    const struct dem_particles *p = &s->p;
    if (s->moving && p->count == s->listed_count && dem_stopped_count(s) == s->stopped_at_listing &&
        s->escaped == s->escaped_at_listing)
        return;
    if (p->count > s->moving_capacity) {
        s->moving_capacity = p->capacity;
        s->moving = dem_realloc_or_die(s->moving, s->moving_capacity * sizeof *s->moving);
    }
    size_t flyers[MOVING_SLICES], count = p->count;
    /* one barrier: after it each slice sums the counts before it itself (16 numbers), no serial step between */
#pragma omp parallel if (count >= DEM_PARALLEL_MIN)
    {
#pragma omp for schedule(static)
        for (size_t k = 0; k < MOVING_SLICES; k++)
            flyers[k] = count_flying(p->state, count * k / MOVING_SLICES, count * (k + 1) / MOVING_SLICES);
#pragma omp for schedule(static) nowait
        for (size_t k = 0; k < MOVING_SLICES; k++) {
            size_t at = 0;
            for (size_t j = 0; j < k; j++)
                at += flyers[j];
            list_flying(p->state, count * k / MOVING_SLICES, count * (k + 1) / MOVING_SLICES, s->moving + at);
        }
    }
    size_t total = 0;
    for (size_t k = 0; k < MOVING_SLICES; k++)
        total += flyers[k];
    s->moving_count = total;
    s->listed_count = count;
    s->stopped_at_listing = dem_stopped_count(s);
    s->escaped_at_listing = s->escaped;
}

/* The per-particle scratch of the contacts, grown with the particles.  Its flags are 0 between steps
 * (dem_contacts_end_step clears those of the step's moving particles), new slots too. */
static void ensure_path_capacity(struct dem_solver *s)
{
    const struct dem_particles *p = &s->p;
    if (p->count <= s->path_capacity)
        return;
    size_t old = s->path_capacity, capacity = p->capacity;
    s->path_time = dem_realloc_or_die(s->path_time, capacity * sizeof(double));
    s->path_x = dem_realloc_or_die(s->path_x, 3 * capacity * sizeof(double));
    s->path_changed = dem_realloc_or_die(s->path_changed, capacity);
    s->seen = dem_realloc_or_die(s->seen, capacity * sizeof *s->seen);
    s->start_kept = dem_realloc_or_die(s->start_kept, capacity);
    s->contacts_in_step = dem_realloc_or_die(s->contacts_in_step, capacity * sizeof *s->contacts_in_step);
    memset(s->contacts_in_step + old, 0, (capacity - old) * sizeof *s->contacts_in_step);
    memset(s->path_changed + old, 0, capacity - old);
    memset(s->seen + old, 0, (capacity - old) * sizeof *s->seen);
    memset(s->start_kept + old, 0, capacity - old);
    s->path_capacity = capacity;
}

int dem_collide(struct dem_solver *s)
{
    list_moving(s);
    ensure_path_capacity(s);
    dem_drag_skins(s);
    dem_detect_contacts(s);
    return resolve_contacts_in_order(s);
}
