/* Diagnostics of the impact runs (thesis Chapter 5): energies, plastic strain and its energy density
 * (Eq. 4.15), PBCP (Eq. 5.1), the restitution velocity with the 60 m/s filter (Section 5.2.1) and the
 * bonded/rebounded verdict.  v_com and v_rest take the grid velocity at the points (smooth_velocity), not the
 * points' own velocities, whose FLIP noise the 60 m/s filter turned into a bias.  Sums run over points in id order, so
 * they do not depend on threads or on the storage order. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/log.h"
#include "mpm/diagnostics_point.h"
#include "mpm/mpm_impl.h"

/* The velocity of the grid at point q: the last step's re-projected, contact-corrected nodal velocities of its
 * body (g->velocity, those the strain rate is taken from) interpolated to its position, normalised by the
 * weights of its heavy nodes; its own velocity where it has none (before the first step, after a restart).
 * Point velocities carry FLIP noise the grid does not see (89 m/s RMS against the grid velocity in a 750 m/s
 * impact): selected by a speed filter, the noise biased v_rest (8.9 m/s reported against a centre of mass moving
 * at 16.9 m/s; issue 22).  The interpolated grid velocity is the motion the grid gives the material, smooth
 * over a cell; its mass-weighted mean is the body's momentum over its mass where all its nodes are heavy. */
static void smooth_velocity(const struct mpm_solver *s, size_t q, double v[3])
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    struct stencil st;
    double sum[3] = {0, 0, 0}, weight = 0.0;
    if (mpm_grid_stencil(g, s->cfg.shape_function, s->lp, p->x + 3 * q, &st) == 0) {
        size_t layer = (size_t)p->body[q] * g->nodes;
        for (int c = 0; c < st.width; c++)
            for (int b = 0; b < st.width; b++)
                for (int a = 0; a < st.width; a++) {
                    double N = st.w[0][a] * st.w[1][b] * st.w[2][c];
                    size_t I = layer + stencil_node(g, &st, a, b, c);
                    if (N == 0.0 || !(g->mass[I] > g->mass_cutoff))
                        continue;
                    weight += N;
                    for (int d = 0; d < 3; d++)
                        sum[d] += N * g->velocity[3 * I + d];
                }
    }
    for (int d = 0; d < 3; d++)
        v[d] = weight > 0.0 ? sum[d] / weight : p->v[3 * q + d];
}

/* The whole body's from its modelled part's sums ([impact] symmetry, `copies` of it): the extensive sums times the
 * copies (no point lies on a mirror plane), means as they are, no centre-of-mass motion across a mirror plane;
 * interface and bonded: its interface nodes and those bonded, already the whole set-up's (a node on a mirror plane
 * has no image: mirror_node_copies), -1: not counted. */
static void finish_body(const struct mpm_config *cfg, const struct point_sums *b, int64_t interface, int64_t bonded,
                        struct mpm_body_diagnostics *out)
{
    double copies = mpm_mirror_copies(cfg);
    out->mass = copies * b->mass;
    out->kinetic_energy = copies * b->kinetic;
    out->internal_energy = copies * b->internal;
    out->plastic_work = copies * b->plastic_work;
    out->mean_eps_p = b->mass > 0 ? b->eps_p_mass / b->mass : 0.0;
    out->plastic_energy_density = b->volume0 > 0 ? b->plastic_work / b->volume0 : 0.0;
    /* a body whose every point left the grid box (removed) has no centre of mass: NaN, which the verdict reads as the
     * body gone (mpm/verdict.c); 0 made it a body at rest, judged "held" (a review) */
    for (int d = 0; d < 3; d++)
        out->v_com[d] = !(b->mass > 0) ? NAN : !(d < 2 && cfg->mirror[d]) ? b->momentum[d] / b->mass : 0.0;
    out->pbcp = b->contacted > 0 ? (double)b->bonded / (double)b->contacted : 0.0;
    out->v_rest = b->slow > 0 ? b->slow_vz / (double)b->slow : NAN;
    out->mean_d_bond = b->surface > 0 ? b->d_bond_surface / (double)b->surface : 0.0;
    out->contacted_points = (int64_t)copies * b->contacted;
    out->bonded_points = (int64_t)copies * b->bonded;
    out->interface_nodes = interface < 0 ? -1 : interface;
    out->bonded_nodes = bonded < 0 ? -1 : bonded;
    out->bonded_interface = interface < 0 ? NAN : interface > 0 ? (double)bonded / (double)interface : 0.0;
}

/* The points are summed by id, scattered over the storage after a reordering (point_order.c): the fields of the
 * point DIAGNOSTICS_AHEAD ids ahead are fetched while a point is added (a miss on each was most of the time). */
#define DIAGNOSTICS_AHEAD 16

static void prefetch_diagnostics_point(const struct mpm_points *p, size_t q)
{
    __builtin_prefetch(p->flags + q);
    __builtin_prefetch(p->body + q);
    __builtin_prefetch(p->v + 3 * q);
    __builtin_prefetch(p->mass + q);
    __builtin_prefetch(p->volume0 + q);
    __builtin_prefetch(p->plastic_work + q);
    __builtin_prefetch(p->d_bond + q);
    __builtin_prefetch(&p->state[q].energy);
    __builtin_prefetch(&p->state[q].eps_p);
}

/* Each body's sums over its active points, by id (the GPU's: mpm_gpu_body_sums, summed on the device). */
static int body_sums(const struct mpm_solver *s, struct point_sums *sums)
{
    if (s->gpu)
        return mpm_gpu_body_sums(s, sums);
    const struct mpm_points *p = &s->points;
    const struct point_fields fields = {.v = p->v,
                                        .mass = p->mass,
                                        .volume0 = p->volume0,
                                        .plastic_work = p->plastic_work,
                                        .d_bond = p->d_bond,
                                        .state = p->state,
                                        .flags = p->flags,
                                        .surface_flag = POINT_SURFACE,
                                        .vrest_filter = s->cfg.vrest_filter};
    for (size_t i = 0; i < p->count; i++) {
        if (i + DIAGNOSTICS_AHEAD < p->count)
            prefetch_diagnostics_point(p, p->slot[i + DIAGNOSTICS_AHEAD]);
        size_t q = p->slot[i]; /* by id (point_order.c) */
        if (!(p->flags[q] & POINT_ACTIVE))
            continue;
        double v[3];
        smooth_velocity(s, q, v);
        point_sums_add(&sums[p->body[q]], &fields, q, v);
    }
    return SC_OK;
}

/* A body whose sums are not known (the device failed): every value NaN, every count -1 (not counted). */
static void unknown_body(struct mpm_body_diagnostics *out)
{
    double unknown = NAN;
    *out = (struct mpm_body_diagnostics){.mass = unknown,
                                         .kinetic_energy = unknown,
                                         .internal_energy = unknown,
                                         .plastic_work = unknown,
                                         .mean_eps_p = unknown,
                                         .plastic_energy_density = unknown,
                                         .v_com = {unknown, unknown, unknown},
                                         .pbcp = unknown,
                                         .v_rest = unknown,
                                         .mean_d_bond = unknown,
                                         .contacted_points = -1,
                                         .bonded_points = -1,
                                         .interface_nodes = -1,
                                         .bonded_nodes = -1,
                                         .bonded_interface = unknown};
}

/* The diagnostics of the bodies now into s->diagnostics.  A fault of the device leaves every body's values unknown
 * (unknown_body) and the total energy NaN. */
static int compute_diagnostics(struct mpm_solver *s)
{
    int nb = s->cfg.body_count;
    struct point_sums *sums = calloc((size_t)nb, sizeof *sums);
    int64_t *nodes = calloc(2 * (size_t)nb, sizeof *nodes);
    if (!sums || !nodes) /* mpm_compute_diagnostics returns the diagnostics, not a status */
        SC_DIE_OOM((size_t)nb * (sizeof *sums + 2 * sizeof *nodes), "the diagnostics of the bodies");
    /* with [run] device = gpu the grid's contact state lives on the device (the host's grid is not filled) */
    if (s->gpu)
        mpm_gpu_count_interface(s, nodes, nodes + nb);
    else
        mpm_contact_interface_nodes(s, nodes, nodes + nb);
    int status = body_sums(s, sums);
    struct mpm_diagnostics *d = &s->diagnostics;
    d->t = s->t;
    d->body_count = nb;
    d->body = s->body_diagnostics;
    double copies = mpm_mirror_copies(&s->cfg);
    d->energy_absorbed = copies * s->energy_absorbed;
    d->energy_removed = copies * s->energy_removed;
    d->energy_initial = copies * s->energy_initial;
    d->energy_stored = copies * mpm_boundary_spring_energy(s);
    d->energy_total = d->energy_absorbed + d->energy_removed + d->energy_stored;
    for (int b = 0; b < nb; b++) {
        if (status == SC_OK)
            finish_body(&s->cfg, &sums[b], nodes[b], nodes[nb + b], &d->body[b]);
        else
            unknown_body(&d->body[b]);
        d->energy_total += d->body[b].kinetic_energy + d->body[b].internal_energy;
    }
    free(nodes);
    free(sums);
    return status;
}

const struct mpm_diagnostics *mpm_compute_diagnostics(struct mpm_solver *s)
{
    if (compute_diagnostics(s) != SC_OK)
        log_warn("%s (the bodies' diagnostics are unknown: NaN, counts -1)", sc_error_message());
    return &s->diagnostics;
}

const struct mpm_diagnostics *mpm_final_diagnostics(struct mpm_solver *s)
{
    mpm_compute_diagnostics(s); /* the masses and energies, which the series does not hold */
    if (s->series_rows == 0)
        return &s->diagnostics;
    int nb = s->cfg.body_count;
    const double *row = s->series + (s->series_rows - 1) * (SERIES_FIXED + (size_t)nb * SERIES_PER_BODY);
    for (int b = 0; b < nb; b++) {
        /* the columns in mpm_series_record's order */
        const double *r = row + SERIES_FIXED + (size_t)b * SERIES_PER_BODY;
        struct mpm_body_diagnostics *x = &s->diagnostics.body[b];
        x->v_com[0] = r[0], x->v_com[1] = r[1], x->v_com[2] = r[2];
        x->kinetic_energy = r[3], x->internal_energy = r[4], x->plastic_work = r[5];
        x->mean_eps_p = r[6], x->plastic_energy_density = r[7], x->pbcp = r[8], x->v_rest = r[9];
        x->mean_d_bond = r[10];
        x->contacted_points = (int64_t)r[11], x->bonded_points = (int64_t)r[12];
        x->interface_nodes = (int64_t)r[13], x->bonded_nodes = (int64_t)r[14];
        x->bonded_interface = x->interface_nodes < 0   ? NAN
                              : x->interface_nodes > 0 ? (double)x->bonded_nodes / (double)x->interface_nodes
                                                       : 0.0;
    }
    return &s->diagnostics;
}

/* The grid's start-of-step velocity of body `layer`'s field at point q, sum_I N_Ip p_I / m_I. */
static void grid_velocity_at(const struct mpm_solver *s, size_t q, double v[3])
{
    const struct mpm_grid *g = &s->grid;
    struct stencil st;
    grid_point_stencil(s, q, &st); /* this step's binning: the weights of mpm_grid_stencil without its divisions */
    size_t layer = (size_t)s->points.body[q] * g->nodes;
    /* x, y, z in lanes (mpm_impl.h): one division per node instead of three, each lane the scalar (N p_d) / m_I */
    vec3pad sum = {0, 0, 0, 0};
    for (int c = 0; c < st.width; c++)
        for (int b = 0; b < st.width; b++)
            for (int a = 0; a < st.width; a++) {
                double N = st.w[0][a] * st.w[1][b] * st.w[2][c];
                size_t I = layer + stencil_node(g, &st, a, b, c);
                if (N == 0.0 || !(g->mass[I] > g->mass_cutoff))
                    continue;
                vec3pad momentum, mass = {g->mass[I], g->mass[I], g->mass[I], g->mass[I]};
                node_vector(&momentum, g->momentum, I);
                sum += N * momentum / mass;
            }
    v[0] = sum[0], v[1] = sum[1], v[2] = sum[2];
}

/* Work of the absorbing boundaries (Eqs. 3.45-3.46) over the step, booked so that the energy balance closes.
 * The dashpot force of a point reaches the points' velocities through its nodes: to first order in dt it
 * changes their kinetic energy by sum_I f_I . v_I dt with the nodal start velocities v_I (FLIP), i.e. by
 * f_p . v_grid(x_p) dt, not by f_p . v_p dt.  Booking with the point's own velocity also counted the part of
 * v_p that the grid does not see (up to 4 % of the initial energy in an 8 ns impact; docs/physics.md, "Contact and
 * energy").  Called after the nodal update, on the start momenta the points' velocity change refers to. */
/* The boundary points are visited by id, scattered over the storage (point_order.c): the fields a point's booking
 * reads are fetched BOOK_AHEAD points ahead, and its 8 nodes' BOOK_AHEAD / 2 ahead (trilinear stencils, whose
 * base nodes are cached) once its cached stencil has arrived.  Loads that missed the cache were most of the
 * booking's samples. */
#define BOOK_AHEAD 8

static void prefetch_boundary_point(const struct mpm_solver *s, size_t q)
{
    const struct mpm_points *p = &s->points;
    __builtin_prefetch(p->flags + q);
    __builtin_prefetch(p->body + q);
    __builtin_prefetch(p->v + 3 * q);
    __builtin_prefetch(p->normal + 3 * q);
    __builtin_prefetch(s->grid.point_fraction + 3 * q);
    __builtin_prefetch(s->grid.point_node + q);
}

static void prefetch_boundary_nodes(const struct mpm_solver *s, size_t q)
{
    const struct mpm_grid *g = &s->grid;
    if (s->cfg.shape_function != MPM_LINEAR || !(s->points.flags[q] & POINT_ACTIVE))
        return;
    size_t key = (size_t)s->points.body[q] * g->nodes + g->point_node[q];
    size_t pair[4] = {key, key + g->row, key + g->plane, key + g->row + g->plane};
    for (int k = 0; k < 4; k++) {
        __builtin_prefetch(g->mass + pair[k]);
        __builtin_prefetch(g->momentum + 3 * pair[k]);
    }
}

/* The points' terms in parallel (each thread its range, prefetching within it), then their sum by id, in the
 * order of the serial loop this was. */
void mpm_book_absorbed_energy(struct mpm_solver *s)
{
    const struct mpm_points *p = &s->points;
    long n = (long)s->boundary_count;
    double *work = s->boundary_work;
#pragma omp parallel
    {
        int t = omp_get_thread_num(), threads = omp_get_num_threads();
        long lo = n * t / threads, hi = n * (t + 1) / threads;
        for (long k = lo; k < hi; k++) {
            if (k + BOOK_AHEAD < hi)
                prefetch_boundary_point(s, p->slot[s->boundary_points[k + BOOK_AHEAD]]);
            if (k + BOOK_AHEAD / 2 < hi)
                prefetch_boundary_nodes(s, p->slot[s->boundary_points[k + BOOK_AHEAD / 2]]);
            size_t q = p->slot[s->boundary_points[k]];
            double f[3], v[3];
            work[k] = 0.0;
            if (!(p->flags[q] & POINT_ACTIVE))
                continue;
            boundary_dashpot_force(s, q, f);
            grid_velocity_at(s, q, v);
            work[k] = (f[0] * v[0] + f[1] * v[1] + f[2] * v[2]) * s->dt;
        }
    }
    for (long k = 0; k < n; k++) /* an inactive point's 0 leaves the sum's bits as they are */
        s->energy_absorbed -= work[k];
}

int mpm_series_record(struct mpm_solver *s)
{
    int nb = s->cfg.body_count;
    size_t width = SERIES_FIXED + (size_t)nb * SERIES_PER_BODY;
    if (s->series_rows == s->series_capacity) {
        size_t grown = s->series_capacity ? 2 * s->series_capacity : 256;
        double *more = realloc(s->series, grown * width * sizeof *more);
        if (!more)
            SC_FAIL_OOM(grown * width * sizeof *more, "the impact series");
        s->series = more;
        s->series_capacity = grown;
    }
    SC_TRY(compute_diagnostics(s)); /* with device = gpu summed there: the points stay on the device */
    const struct mpm_diagnostics *d = &s->diagnostics;
    double *row = s->series + s->series_rows++ * width;
    row[0] = d->t;
    row[1] = d->energy_total;
    row[2] = d->energy_absorbed;
    row[3] = d->energy_removed;
    for (int b = 0; b < nb; b++) {
        const struct mpm_body_diagnostics *x = &d->body[b];
        double *r = row + SERIES_FIXED + (size_t)b * SERIES_PER_BODY;
        double values[SERIES_PER_BODY] = {x->v_com[0],
                                          x->v_com[1],
                                          x->v_com[2],
                                          x->kinetic_energy,
                                          x->internal_energy,
                                          x->plastic_work,
                                          x->mean_eps_p,
                                          x->plastic_energy_density,
                                          x->pbcp,
                                          x->v_rest,
                                          x->mean_d_bond,
                                          (double)x->contacted_points,
                                          (double)x->bonded_points,
                                          (double)x->interface_nodes,
                                          (double)x->bonded_nodes};
        memcpy(r, values, sizeof values);
    }
    return SC_OK;
}
