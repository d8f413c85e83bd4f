/* The MUSL step of thesis Section 3.4 (steps 1-12, Eqs. 3.23-3.37: mass and momentum to the grid, nodal forces
 * and momentum update, points' velocity and position, MUSL re-projection, strain increments, density Eq. 3.36,
 * the time step of Eq. 3.37 with the points' speeds added) with contact (Section 3.5.4), bonding (Chapter 4)
 * and absorbing boundaries (Section 3.5.5). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/error.h"
#include "core/log.h"
#include "mpm/mpm_impl.h"

static int copy_config(const struct mpm_config *from, struct mpm_config *to)
{
    *to = *from;
    to->materials = malloc((size_t)from->material_count * sizeof *to->materials);
    to->bodies = malloc((size_t)from->body_count * sizeof *to->bodies);
    if (!to->materials || !to->bodies)
        SC_FAIL_OOM((size_t)from->material_count * sizeof *to->materials +
                        (size_t)from->body_count * sizeof *to->bodies,
                    "the impact materials and bodies");
    memcpy(to->materials, from->materials, (size_t)from->material_count * sizeof *to->materials);
    memcpy(to->bodies, from->bodies, (size_t)from->body_count * sizeof *to->bodies);
    return SC_OK;
}

/* Spring coefficients k A of a boundary point of the substrate (the viscous-spring boundary of Deeks & Randolph
 * 1994, in the 3-D form of Liu et al. 2006): k = alpha G / R per unit area, alpha_N normal and alpha_T tangential
 * to the face, R the distance from the impact point (the substrate's top centre) to the face: the substrate's
 * height for the bottom, its radius (half its side) for the sides.  docs/physics.md "Substrate bottom". */
static void body_springs(struct mpm_solver *s, int b, double G, double area)
{
    const struct mpm_config *cfg = &s->cfg;
    const struct mpm_body *body = &cfg->bodies[b];
    double *k = s->body_spring + 4 * b;
    k[0] = k[1] = k[2] = k[3] = 0.0;
    if (!body->substrate)
        return;
    double per_R = G * area; /* k A R */
    if (cfg->spring_bottom) {
        k[0] = cfg->spring_alpha_normal * per_R / body->h;
        k[1] = cfg->spring_alpha_tangential * per_R / body->h;
    }
    if (cfg->spring_sides) {
        k[2] = cfg->spring_alpha_normal * per_R / (0.5 * body->d);
        k[3] = cfg->spring_alpha_tangential * per_R / (0.5 * body->d);
    }
}

/* Dashpot coefficients of a boundary point (Eqs. 3.45-3.46 with a = b = 1): rho0 V A with the face area
 * A = dp^2 of a lattice point. */
static void body_constants(struct mpm_solver *s)
{
    const struct mpm_config *cfg = &s->cfg;
    double area = cfg->spacing * cfg->spacing;
    s->wave_speed_max = 0.0;
    for (int b = 0; b < cfg->body_count; b++) {
        const struct mpm_material *m = &cfg->materials[cfg->bodies[b].material];
        double G = mpm_mts_shear_modulus(m, m->T_initial);
        double vp = sqrt((m->bulk_modulus + 4.0 * G / 3.0) / m->density), vs = sqrt(G / m->density);
        s->body_dashpot[2 * b] = cfg->absorbing ? m->density * vp * area : 0.0;
        s->body_dashpot[2 * b + 1] = cfg->absorbing ? m->density * vs * area : 0.0;
        s->wave_speed_max = fmax(s->wave_speed_max, mpm_material_wave_speed(m));
        /* a body that starts colder than T_initial (a particle from the spray) is stiffer, G(T) of Eq. 2.6 falling
         * with T: its wave speed bounds the step too */
        double T0 = cfg->bodies[b].temperature;
        if (T0 > 0.0 && T0 < m->T_initial) {
            double G0 = mpm_mts_shear_modulus(m, T0);
            s->wave_speed_max = fmax(s->wave_speed_max, sqrt((m->bulk_modulus + 4.0 * G0 / 3.0) / m->density));
        }
        const double *v = cfg->bodies[b].velocity;
        s->body_speed[b] = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        s->body_bond_scale[b] = mpm_bonding_preheat_scale(cfg, b);
        if (s->body_bond_scale[b] != 1.0 && cfg->bonding != MPM_BONDING_NONE)
            log_info("impact: body %d starts at %g K: its %s is %.4g of the calibrated (bonding_preheat = "
                     "melt_heat)",
                     b, T0 > 0.0 ? T0 : m->T_initial, cfg->bonding == MPM_BONDING_STRAIN ? "eps_c" : "G_c",
                     s->body_bond_scale[b]);
        if (s->body_spring)
            body_springs(s, b, G, area);
    }
}

static double kinetic_energy_total(const struct mpm_points *p)
{
    double sum = 0.0;
    for (size_t i = 0; i < p->count; i++) {
        size_t q = p->slot[i]; /* summed by id (point_order.c) */
        if (p->flags[q] & POINT_ACTIVE) {
            const double *v = p->v + 3 * q;
            sum += 0.5 * p->mass[q] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        }
    }
    return sum;
}

/* The absorbing-boundary points (their flags are set once, at set-up): the energy they absorb is booked every
 * step without scanning all points.  The list holds ids, ascending; with springs on, each point's rank in it and
 * its anchor (present position). */
int mpm_list_boundary_points(struct mpm_solver *s)
{
    const struct mpm_points *p = &s->points;
    free(s->boundary_points), free(s->boundary_work), free(s->boundary_rank), free(s->boundary_anchor);
    s->boundary_rank = NULL, s->boundary_anchor = NULL;
    s->boundary_count = 0;
    for (size_t q = 0; q < p->count; q++)
        s->boundary_count += (p->flags[q] & (POINT_BOTTOM | POINT_SIDE)) != 0;
    size_t n = s->boundary_count ? s->boundary_count : 1;
    s->boundary_points = malloc(n * sizeof *s->boundary_points);
    s->boundary_work = malloc(n * sizeof *s->boundary_work);
    if (!s->boundary_points || !s->boundary_work)
        SC_FAIL_OOM(n * (sizeof *s->boundary_points + sizeof *s->boundary_work), "the absorbing-boundary points");
    int springs = s->cfg.spring_bottom || s->cfg.spring_sides;
    if (springs) {
        s->boundary_rank = calloc(p->count ? p->count : 1, sizeof *s->boundary_rank);
        s->boundary_anchor = malloc(3 * n * sizeof *s->boundary_anchor);
        if (!s->boundary_rank || !s->boundary_anchor)
            SC_FAIL_OOM(p->count * sizeof *s->boundary_rank + 3 * n * sizeof *s->boundary_anchor,
                        "the boundary springs' anchors");
    }
    size_t k = 0;
    for (size_t i = 0; i < p->count; i++) {
        size_t q = p->slot[i]; /* by id */
        if (!(p->flags[q] & (POINT_BOTTOM | POINT_SIDE)))
            continue;
        if (springs) {
            s->boundary_rank[i] = (uint32_t)k;
            memcpy(s->boundary_anchor + 3 * k, p->x + 3 * q, 3 * sizeof *s->boundary_anchor);
        }
        s->boundary_points[k++] = i;
    }
    return SC_OK;
}

/* Sum over the boundary points of 1/2 u . K u = -1/2 u . f_spring(u), by id. */
double mpm_boundary_spring_energy(const struct mpm_solver *s)
{
    if (!s->boundary_rank)
        return 0.0;
    const struct mpm_points *p = &s->points;
    double sum = 0.0;
    for (size_t k = 0; k < s->boundary_count; k++) {
        size_t q = p->slot[s->boundary_points[k]];
        if (!(p->flags[q] & POINT_ACTIVE))
            continue;
        double u[3], f[3] = {0.0, 0.0, 0.0};
        boundary_displacement(s, q, u);
        boundary_spring_vector(s, q, u, f);
        sum -= 0.5 * (u[0] * f[0] + u[1] * f[1] + u[2] * f[2]);
    }
    return sum;
}

/* Each particle whose resolution is not the one the shipped bonding parameters belong to: its verdict is not
 * calibrated (mpm_bonding_calibrated_resolution; the report and `spraycoat info` say it too). */
static void warn_uncalibrated_resolution(const struct mpm_config *cfg)
{
    int strain = cfg->bonding == MPM_BONDING_STRAIN;
    for (int b = 0; b < cfg->body_count; b++)
        if (mpm_bonding_calibrated_resolution(cfg, b) == 0)
            log_warn("impact: body %d (d = %.4g um) has %.3g grid cells across (DCell %.4g um, %.3g points per cell "
                     "edge), but the %s model's shipped parameters belong to %s: its verdict is not calibrated here "
                     "(docs/physics.md \"Bonding calibration\")",
                     b, 1e6 * cfg->bodies[b].d, cfg->bodies[b].d / cfg->grid, 1e6 * cfg->grid, cfg->grid / cfg->spacing,
                     strain ? "strain" : "energy",
                     strain ? "10 cells across with 3 points per cell edge" : "2.0 um cells with 3 points per edge");
}

int mpm_create(const struct mpm_config *cfg, struct mpm_solver **out)
{
    struct mpm_solver *s = calloc(1, sizeof *s);
    *out = s;
    if (!s)
        SC_FAIL_OOM(sizeof *s, "the impact solver");
    SC_TRY(copy_config(cfg, &s->cfg));
    if (cfg->transfer == MPM_TRANSFER_APIC)
        s->cfg.flip = 0.0; /* APIC's point velocity is the grid velocity at the point: PIC (solver.c, "apic") */
    s->lp = 0.5 * cfg->spacing;
    s->body_speed = calloc((size_t)cfg->body_count, sizeof *s->body_speed);
    s->body_dashpot = calloc(2 * (size_t)cfg->body_count, sizeof *s->body_dashpot);
    s->body_bond_scale = calloc((size_t)cfg->body_count, sizeof *s->body_bond_scale);
    s->body_diagnostics = calloc((size_t)cfg->body_count, sizeof *s->body_diagnostics);
    if (cfg->spring_bottom || cfg->spring_sides) {
        s->body_spring = calloc(4 * (size_t)cfg->body_count, sizeof *s->body_spring);
        if (!s->body_spring)
            SC_FAIL_OOM(4 * (size_t)cfg->body_count * sizeof *s->body_spring, "the boundary springs");
    }
    s->material_constants = calloc((size_t)cfg->material_count, sizeof *s->material_constants);
    if (!s->body_speed || !s->body_dashpot || !s->body_bond_scale || !s->body_diagnostics || !s->material_constants)
        SC_FAIL_OOM((size_t)cfg->body_count * (4 * sizeof *s->body_speed + sizeof *s->body_diagnostics) +
                        (size_t)cfg->material_count * sizeof *s->material_constants,
                    "the impact bodies' constants");
    for (int m = 0; m < cfg->material_count; m++)
        mpm_material_prepare(&s->cfg.materials[m], &s->material_constants[m]);
    body_constants(s);
    if (cfg->bonding == MPM_BONDING_STRAIN) /* eps_c = auto resolves by conduction: say which value runs */
        log_info("impact: strain bonding model, eps_c %.6g, eps_rate_c %.6g 1/s", cfg->eps_c, cfg->eps_rate_c);
    warn_uncalibrated_resolution(cfg);
    SC_TRY(mpm_points_create(&s->cfg, &s->points));
    SC_TRY(mpm_grid_create(&s->cfg, &s->points, &s->grid));
    SC_TRY(mpm_list_boundary_points(s));
    SC_TRY(mpm_conduction_create(s));
    s->energy_initial = kinetic_energy_total(&s->points);
    s->next_series = cfg->series_every;
    s->next_snapshot = cfg->snapshot_every;
    s->snapshot_pending = 1;
    SC_TRY(mpm_series_record(s));
    SC_TRY(mpm_verdict_create(s));
    if (cfg->device == MPM_DEVICE_GPU && cfg->transfer == MPM_TRANSFER_APIC)
        SC_FAIL(SC_EINPUT, "impact: transfer = apic is not in the GPU step; use device = cpu or transfer = flip");
    if (cfg->device == MPM_DEVICE_GPU)
        SC_TRY(mpm_gpu_attach(s));
    return SC_OK;
}

double mpm_machine_memory(void)
{
    double memory = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    return memory > 0.0 ? memory : 0.0;
}

int mpm_check_set_up(const struct mpm_config *cfg)
{
    /* the grid's memory first, from the bodies' box (no point seeded yet: a run too large fails at once) */
    struct mpm_grid_need need;
    mpm_grid_need(cfg, mpm_machine_memory(), &need);
    if (need.nodes > (double)MPM_GRID_MAX_NODES)
        SC_FAIL(SC_EINPUT, "impact: the grid would have %.3g nodes, over %zu; use a grid of at least %.3g m",
                need.nodes, MPM_GRID_MAX_NODES, need.finest);
    if (!need.fits)
        SC_FAIL(SC_EINPUT,
                "impact: the run would need %.3g GB for its grid (a layer of %.3g GB for each of the %d "
                "bodies) on a machine of %.3g GB; use fewer bodies per run, a coarser grid or a smaller box_margin",
                need.bytes / 1e9, need.bytes / cfg->body_count / 1e9, cfg->body_count, need.memory / 1e9);
    /* then every body seeded with its points: overlapping bodies of any shape, a body that holds no point */
    struct mpm_points points;
    SC_TRY(mpm_points_create(cfg, &points));
    mpm_points_free(&points);
    return SC_OK;
}

void mpm_destroy(struct mpm_solver *s)
{
    if (!s)
        return;
    mpm_gpu_detach(s);
    mpm_conduction_free(s);
    mpm_points_free(&s->points);
    mpm_grid_free(&s->grid);
    mpm_config_free(&s->cfg);
    free(s->body_speed);
    free(s->body_dashpot);
    free(s->body_bond_scale);
    free(s->body_diagnostics);
    free(s->material_constants);
    free(s->boundary_points);
    free(s->boundary_work);
    free(s->body_spring);
    free(s->boundary_rank);
    free(s->boundary_anchor);
    balance_free(&s->update_balance);
    free(s->series);
    mpm_verdict_free(s);
    free(s);
}

int mpm_finished(const struct mpm_solver *s)
{
    return s->t >= s->cfg.t_end * (1.0 - 1e-12) || (s->cfg.stop_when_settled && s->all_settled);
}
int mpm_body_count(const struct mpm_solver *s)
{
    return s->cfg.body_count;
}

struct mpm_counts mpm_get_counts(const struct mpm_solver *s)
{
    struct mpm_counts c = {.step = s->step,
                           .t = s->t,
                           .dt = s->dt,
                           .points = (int64_t)s->points.count,
                           .removed_points = s->removed_points,
                           .removed_mass = s->removed_mass,
                           .point_updates = s->point_updates,
                           .contact_node_steps = s->contact_node_steps,
                           .bonded_node_steps = s->bonded_node_steps};
    c.active_points = c.points - c.removed_points;
    return c;
}

/* dt = cfl DCell / (c + max|v|) (docs/physics.md), the last step cut to end exactly at t_end. */
static inline double speed_squared(const double v[3])
{
    return v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
}

/* The time step of Section 3.4, dt = cfl DCell / (c + max |v|), from the active points' speeds as the last
 * step's grid_to_points found them (a maximum: the same bits whoever finds it), or from a pass of its own. */
static void choose_time_step(struct mpm_solver *s)
{
    const struct mpm_points *p = &s->points;
    long n = (long)p->count;
    double vmax2 = s->vmax2;
    if (!s->vmax2_known) {
        vmax2 = 0.0;
#pragma omp parallel for schedule(static) reduction(max : vmax2)
        for (long q = 0; q < n; q++) {
            if (p->flags[q] & POINT_ACTIVE) {
                double v2 = speed_squared(p->v + 3 * q);
                vmax2 = v2 > vmax2 ? v2 : vmax2; /* fmax without a libm call: a NaN is skipped alike */
            }
        }
    }
    s->vmax2_known = 0;
    s->dt = s->cfg.cfl * s->cfg.grid / (s->wave_speed_max + sqrt(vmax2));
    if (s->t + s->dt > s->cfg.t_end)
        s->dt = s->cfg.t_end - s->t;
}

/* Step 7 for one point from its grid sums: the position moves with the new grid velocity vnew; the velocity takes
 * the grid's velocity change dv (FLIP, Eq. 3.32), or with flip < 1 that share of it and the rest of vnew (PIC),
 * which damps the points' velocity noise the grid does not see (docs/physics.md, "Transfers"). */
static inline void point_velocity_position(const struct mpm_solver *s, double *v, const double *x, double *xn,
                                           const vec3pad *dv, const vec3pad *vnew)
{
    double flip = s->cfg.flip;
    for (int d = 0; d < 3; d++) {
        v[d] = flip == 1.0 ? v[d] + (*dv)[d] : flip * (v[d] + (*dv)[d]) + (1.0 - flip) * (*vnew)[d];
        xn[d] = x[d] + s->dt * (*vnew)[d];
    }
}

/* Step 7, Eq. 3.32, for one point with its stencil. */
STENCIL_INLINE void point_from_grid_width(struct mpm_solver *s, size_t q, const struct stencil *stencil, int width)
{
    struct mpm_points *p = &s->points;
    const struct mpm_grid *g = &s->grid;
    const struct stencil *st = stencil; /* the caller's local, read in place (mpm_impl.h) */
    double *x = p->x + 3 * q, *xn = p->x_next + 3 * q, *v = p->v + 3 * q;
    size_t layer = (size_t)p->body[q] * g->nodes;
    vec3pad dv = {0, 0, 0, 0}, vnew = {0, 0, 0, 0}; /* x, y, z in lanes (mpm_impl.h): the same bits */
    for (int c = 0; c < width; c++)
        for (int b = 0; b < width; b++)
            for (int a = 0; a < width; a++) {
                double N = st->w[0][a] * st->w[1][b] * st->w[2][c];
                size_t I = layer + stencil_node(g, st, a, b, c);
                /* a light node has no velocity.  A heavy node with N = 0 adds 0 times its finite momenta, +-0,
                 * which leaves the sums' bits (they start at +0, so are never -0): trilinear stencils (width 2)
                 * have such nodes only for a point on a node plane, and are not tested for them */
                if ((width != 2 && N == 0.0) || !(g->mass[I] > g->mass_cutoff))
                    continue;
                double w = N / g->mass[I];
                vec3pad momentum_new, momentum;
                node_vector(&momentum_new, g->momentum_new, I);
                node_vector(&momentum, g->momentum, I);
                dv += w * (momentum_new - momentum);
                vnew += w * momentum_new;
            }
    point_velocity_position(s, v, x, xn, &dv, &vnew);
}

/* The 8 nodes of a run of trilinear stencils (mpm_impl.h) as grid-to-points reads them: the masses in lanes,
 * and per heavy node (bit n of `heavy`) its momenta p_new - p and p_new, x, y, z in lanes as
 * point_from_grid_width has them. */
struct run_nodes {
    lanes8 mass;
    vec3pad change[8], momentum_new[8];
    unsigned heavy;
};

static inline void run_nodes_load(const struct mpm_grid *g, size_t key, struct run_nodes *r)
{
    size_t pair[4] = {key, key + g->row, key + g->plane, key + g->row + g->plane};
    lanes_load(&r->mass, g->mass, pair);
    r->heavy = 0;
    for (int n = 0; n < 8; n++) {
        size_t I = pair[n >> 1] + (size_t)(n & 1);
        vec3pad momentum;
        node_vector(&r->momentum_new[n], g->momentum_new, I);
        node_vector(&momentum, g->momentum, I);
        r->change[n] = r->momentum_new[n] - momentum;
        r->heavy |= (unsigned)(g->mass[I] > g->mass_cutoff) << n;
    }
}

/* Step 7 for point q of a run: point_from_grid_width (width 2) with the same operations in the same order per
 * node, the weights N = w_0 w_1 w_2 and N / m_I of the 8 nodes taken in lanes. */
static inline void run_point_from_grid(struct mpm_solver *s, size_t q, const struct run_nodes *r)
{
    struct mpm_points *p = &s->points;
    const double *x = p->x + 3 * q;
    double *xn = p->x_next + 3 * q, *v = p->v + 3 * q;
    lanes8 weights[3];
    run_weights(&s->grid, q, weights);
    lanes8 w = weights[0] * weights[1] * weights[2] / r->mass; /* light nodes' lanes (perhaps 0 / 0) are not used */
    vec3pad dv = {0, 0, 0, 0}, vnew = {0, 0, 0, 0};
    for (int n = 0; n < 8; n++)
        if (r->heavy >> n & 1) {
            dv += w[n] * r->change[n];
            vnew += w[n] * r->momentum_new[n];
        }
    point_velocity_position(s, v, x, xn, &dv, &vnew);
}

/* Step 7 for the points q .. end - 1; trilinear stencils in runs of consecutive active points with the same key
 * (AVX-512 builds), others point by point. */
static void grid_to_points_range(struct mpm_solver *s, size_t q, size_t end)
{
    struct mpm_points *p = &s->points;
    int runs = TRILINEAR_RUNS && s->cfg.shape_function == MPM_LINEAR;
    while (q < end) {
        if (!(p->flags[q] & POINT_ACTIVE)) {
            memcpy(p->x_next + 3 * q, p->x + 3 * q, 3 * sizeof *p->x);
            q++;
            continue;
        }
        if (runs) {
            size_t key = run_key(s, q), run_end = q + 1;
            while (run_end < end && (p->flags[run_end] & POINT_ACTIVE) && run_key(s, run_end) == key)
                run_end++;
            struct run_nodes r;
            run_nodes_load(&s->grid, key, &r);
            for (; q < run_end; q++)
                run_point_from_grid(s, q, &r);
            continue;
        }
        struct stencil st;
        grid_point_stencil(s, q, &st);
        if (st.width == 2)
            point_from_grid_width(s, q, &st, 2);
        else
            point_from_grid_width(s, q, &st, st.width);
        q++;
    }
}

/* The points q .. end - 1 after step 7, while their new positions and velocities are in the cache: how many
 * leave the grid box (*leaving), the smallest id of one whose position or velocity is not finite (*bad), and
 * the largest squared speed of those that stay (*vmax2: the next step's time step; neither the update nor
 * remove_escaped changes a velocity). */
static void scan_escapes(const struct mpm_solver *s, size_t q, size_t end, int64_t *leaving, long *bad, double *vmax2)
{
    const struct mpm_points *p = &s->points;
    for (; q < end; q++) {
        if (!(p->flags[q] & POINT_ACTIVE))
            continue;
        const double *x = p->x_next + 3 * q, *v = p->v + 3 * q;
        if (!isfinite(x[0] + x[1] + x[2] + v[0] + v[1] + v[2])) {
            *bad = (long)p->id[q] < *bad ? (long)p->id[q] : *bad;
        } else if (!grid_contains(&s->grid, x)) {
            (*leaving)++;
        } else {
            double v2 = speed_squared(v);
            *vmax2 = v2 > *vmax2 ? v2 : *vmax2;
        }
    }
}

/* Points per chunk of grid_to_points' parallel loop: a run ends at a chunk's end. */
#define GRID_TO_POINTS_CHUNK 256

/* Step 7, Eq. 3.32: the point velocity takes the nodal velocity change (FLIP) and the position the new
 * nodal velocity.  The points leaving the grid are counted here for remove_escaped, and the largest speed of
 * those staying found for the next step's choose_time_step (passes of their own over the positions and
 * velocities had cost 2.6 % of the step). */
static void grid_to_points(struct mpm_solver *s)
{
    size_t n = s->points.count;
    long chunks = (long)((n + GRID_TO_POINTS_CHUNK - 1) / GRID_TO_POINTS_CHUNK), bad = (long)n;
    int64_t leaving = 0;
    double vmax2 = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : leaving) reduction(min : bad) reduction(max : vmax2)
    for (long c = 0; c < chunks; c++) {
        size_t q = (size_t)c * GRID_TO_POINTS_CHUNK, end = n - q < GRID_TO_POINTS_CHUNK ? n : q + GRID_TO_POINTS_CHUNK;
        grid_to_points_range(s, q, end);
        scan_escapes(s, q, end, &leaving, &bad, &vmax2);
    }
    s->leaving_points = leaving;
    s->nonfinite_id = bad;
    s->vmax2 = vmax2;
    s->vmax2_known = 1;
}

/* The re-projected nodal velocities v_I = p_I / m_I (Eq. 3.34), once per node rather than once per point and
 * node in the velocity gradient.  Nodes too light to carry a velocity get 0 (velocity_gradient_width adds their
 * 0 * dN instead of testing the mass), and lose their contact flag: from here to the step's end the flag marks
 * the contact nodes the velocity gradient counts, without a second test of the mass there. */
static void nodal_velocities(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    /* over the nodes of this step's stencils (g->box), each row in every layer: the fields are 0 elsewhere */
    long rows = (long)box_rows(&g->box), layer_rows = rows * g->layers;
    size_t length = box_row_length(&g->box);
#pragma omp parallel for schedule(static)
    for (long r = 0; r < layer_rows; r++) {
        int k;
        size_t first = (size_t)(r / rows) * g->nodes + box_row_start(g, &g->box, (size_t)(r % rows), &k);
        for (size_t I = first; I < first + length; I++) {
            int heavy = g->mass[I] > g->mass_cutoff;
            for (int d = 0; d < 3; d++)
                g->velocity[3 * I + d] = heavy ? g->momentum_new[3 * I + d] / g->mass[I] : 0.0;
            g->contact[I] = heavy ? g->contact[I] : 0; /* the pair state of contact.c, kept where heavy */
            if (g->pair_state)
                g->pair_state[I] = heavy ? g->pair_state[I] : 0;
        }
    }
}

/* Velocity gradient L_ij = sum_I v_iI dN_I/dx_j from the re-projected nodal velocities (Eq. 3.35). */
STENCIL_INLINE void velocity_gradient_width(const struct mpm_solver *s, size_t q, const struct stencil *stencil,
                                            int width, double L[3][3])
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    const struct stencil *st = stencil; /* the caller's local, read in place (mpm_impl.h) */
    size_t layer = (size_t)p->body[q] * g->nodes;
    /* the rows of L summed in registers, j = 0, 1, 2 in the lanes (mpm_impl.h), in the same order as before */
    vec3pad row[3] = {{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}};
    for (int c = 0; c < width; c++)
        for (int b = 0; b < width; b++)
            for (int a = 0; a < width; a++) {
                size_t I = layer + stencil_node(g, st, a, b, c);
                /* a light node adds 0 * dN (its velocity is 0, nodal_velocities): a sum that starts at +0 is
                 * unchanged by adding +-0, so no branch is needed for the same bits.
                 * dN_j = (g0 w1 w2, w0 g1 w2, w0 w1 g2), each product taken left to right as before; the pad
                 * lanes copy lane 2 (a 0 there made gcc emit a vmovq valgrind cannot run, mpm_impl.h) */
                vec3pad x = {st->g[0][a], st->w[0][a], st->w[0][a], st->w[0][a]};
                vec3pad y = {st->w[1][b], st->g[1][b], st->w[1][b], st->w[1][b]};
                vec3pad z = {st->w[2][c], st->w[2][c], st->g[2][c], st->g[2][c]};
                vec3pad dN = x * y * z, vI;
                node_vector(&vI, g->velocity, I);
                for (int i = 0; i < 3; i++)
                    row[i] += vI[i] * dN;
            }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            L[i][j] = row[i][j];
}

/* Whether the point's own body is in contact at one of its nodes for the bonding model: a heavy contact node
 * (nodal_velocities) with N > 0 whose pair counts for D_bond (bond_contact, contact.c bonds_grow). */
static int stencil_in_contact(const struct mpm_solver *s, size_t q, const struct stencil *st)
{
    const struct mpm_grid *g = &s->grid;
    size_t layer = (size_t)s->points.body[q] * g->nodes;
    int contact = 0;
    for (int c = 0; c < st->width; c++)
        for (int b = 0; b < st->width; b++)
            for (int a = 0; a < st->width; a++)
                contact |= (st->w[0][a] * st->w[1][b] * st->w[2][c] > 0.0) &
                           (g->contact[layer + stencil_node(g, st, a, b, c)] != 0) &
                           (g->bond_contact[layer + stencil_node(g, st, a, b, c)] != 0);
    return contact;
}

/* L of point q, and whether it is a surface point in contact (finish_point flags only surface points, so the
 * stencil's contact flags are read only for those). */
static int velocity_gradient(const struct mpm_solver *s, size_t q, double L[3][3])
{
    struct stencil st;
    grid_point_stencil(s, q, &st);
    if (st.width == 2)
        velocity_gradient_width(s, q, &st, 2, L);
    else
        velocity_gradient_width(s, q, &st, st.width, L);
    return (s->points.flags[q] & POINT_SURFACE) && stencil_in_contact(s, q, &st);
}

/* Points updated together (steps 10-11): their plastic returns run in vector lanes (mpm_stress_returns). */
#define POINT_BLOCK MPM_RETURN_LANES

/* A block of points between the phases of its update. */
struct point_block {
    struct mpm_stress_work work[POINT_BLOCK];
    struct mpm_update_result result[POINT_BLOCK];
    double strain[POINT_BLOCK][6], spin[POINT_BLOCK][3];
    double volume_new[POINT_BLOCK], T[POINT_BLOCK], G[POINT_BLOCK];
    int material[POINT_BLOCK], contact[POINT_BLOCK], updating[POINT_BLOCK], failed[POINT_BLOCK];
};

/* Steps 10-11 up to the stress update for point q (slot k of the block): strain and spin increments (Eq. 3.35)
 * and the new volume (Eq. 3.36).  Returns -1 for a non-positive volume. */
static int point_increments(const struct mpm_solver *s, size_t q, struct point_block *b, int k)
{
    double L[3][3], dt = s->dt, *de = b->strain[k], *dw = b->spin[k];
    b->contact[k] = velocity_gradient(s, q, L);
    /* the trace from locals: gcc stores de[0..3] as one vector, and reading them back one by one stalled on
     * store forwarding (a seventh of update_block's samples) */
    double exx = L[0][0] * dt, eyy = L[1][1] * dt, ezz = L[2][2] * dt;
    de[0] = exx, de[1] = eyy, de[2] = ezz;
    de[3] = 0.5 * (L[1][2] + L[2][1]) * dt, de[4] = 0.5 * (L[0][2] + L[2][0]) * dt;
    de[5] = 0.5 * (L[0][1] + L[1][0]) * dt;
    dw[0] = 0.5 * (L[1][2] - L[2][1]) * dt, dw[1] = 0.5 * (L[0][2] - L[2][0]) * dt;
    dw[2] = 0.5 * (L[0][1] - L[1][0]) * dt;
    double volume_new = s->points.volume[q] * (1.0 + exx + eyy + ezz);
    b->volume_new[k] = volume_new;
    return volume_new > 0.0 ? 0 : -1;
}

/* transfer = apic: C_p is the velocity gradient L at the point of the MUSL re-projected, contact-corrected nodal
 * velocities (those of the strain rate), not Jiang et al.'s B_p D_p^-1 of the updated ones: with trilinear weights
 * D_p is singular where a point barely reaches a node, whose updated velocity takes dt f_I / m_I, and that C_p made
 * a free elastic sphere blow up within 100 steps (docs/physics.md, "Transfers").  L back from the block's strain
 * and spin increments (point_increments), once per block: FLIP's update has no test per point. */
static void store_affine(struct mpm_solver *s, long q0, const struct point_block *b, int count)
{
    if (!(s->dt > 0.0))
        return;
    double inv_dt = 1.0 / s->dt;
    for (int k = 0; k < count; k++) {
        if (!b->updating[k])
            continue;
        const double *de = b->strain[k], *dw = b->spin[k];
        double *C = s->points.affine + 9 * (q0 + k);
        C[0] = de[0] * inv_dt, C[4] = de[1] * inv_dt, C[8] = de[2] * inv_dt;
        C[5] = (de[3] + dw[0]) * inv_dt, C[7] = (de[3] - dw[0]) * inv_dt; /* L_yz, L_zy */
        C[2] = (de[4] + dw[1]) * inv_dt, C[6] = (de[4] - dw[1]) * inv_dt; /* L_xz, L_zx */
        C[1] = (de[5] + dw[2]) * inv_dt, C[3] = (de[5] - dw[2]) * inv_dt; /* L_xy, L_yx */
    }
}

/* The stress update's view of the block of points q0 .. q0 + count - 1 (mpm_stress_begin_block). */
static struct mpm_stress_block stress_block(const struct mpm_solver *s, long q0, int count, double log_dt,
                                            struct point_block *b)
{
    const struct mpm_points *p = &s->points;
    return (struct mpm_stress_block){.n = count,
                                     .material = b->material,
                                     .updating = b->updating,
                                     .materials = s->cfg.materials,
                                     .constants = s->material_constants,
                                     .viscosity = &s->cfg.viscosity,
                                     .dt = s->dt,
                                     .log_dt = log_dt,
                                     .strain = b->strain,
                                     .spin = b->spin,
                                     .G = b->G,
                                     .volume0 = p->volume0 + q0,
                                     .volume_old = p->volume + q0,
                                     .volume_new = b->volume_new,
                                     .state = p->state + q0,
                                     .work = b->work,
                                     .result = b->result,
                                     .failed = b->failed};
}

/* The materials and shear moduli G(T) of the block's points: in lanes for the first point's material, again one
 * by one for points of another (the same function: the same bits). */
static void block_shear_moduli(const struct mpm_solver *s, long q0, struct point_block *b, int count)
{
    const struct mpm_points *p = &s->points;
    if (count <= 0)
        return;
    int first = s->cfg.bodies[p->body[q0]].material;
    for (int k = 0; k < count; k++) {
        b->material[k] = s->cfg.bodies[p->body[q0 + k]].material;
        b->T[k] = p->state[q0 + k].T;
    }
    mpm_shear_moduli(&s->cfg.materials[first], &s->material_constants[first], count, b->T, b->G);
    for (int k = 1; k < count; k++)
        if (b->material[k] != first)
            mpm_shear_moduli(&s->cfg.materials[b->material[k]], &s->material_constants[b->material[k]], 1, &b->T[k],
                             &b->G[k]);
}

/* The plastic returns of the block, one material at a time (each lane's result is its own: the grouping does not
 * change it). */
static void block_returns(const struct mpm_solver *s, struct point_block *b, int count)
{
    int solved[POINT_BLOCK] = {0};
    for (int first = 0; first < count; first++) {
        if (solved[first] || !b->updating[first] || !b->work[first].returning)
            continue;
        struct mpm_return *lanes[POINT_BLOCK];
        int n = 0, material = b->material[first];
        for (int k = first; k < count; k++)
            if (!solved[k] && b->updating[k] && b->work[k].returning && b->material[k] == material)
                lanes[n++] = &b->work[k].ret, solved[k] = 1;
        mpm_stress_returns(&s->cfg.materials[material], lanes, n);
    }
}

/* Step 11 after the stress update of point q (mpm_stress_finish_block): volume, plastic work, contact flag,
 * bonding. */
static void finish_point(struct mpm_solver *s, size_t q, const struct point_block *b, int k)
{
    struct mpm_points *p = &s->points;
    const struct mpm_update_result *r = &b->result[k];
    p->volume[q] = b->volume_new[k];
    p->plastic_work[q] += r->plastic_work;
    if (b->contact[k]) /* a surface point touching another body (velocity_gradient) */
        p->flags[q] |= POINT_CONTACT;
    else
        p->flags[q] &= (uint8_t)~POINT_CONTACT;
    bonding_update(s, q, r->eps_p_increment, r->von_mises);
}

/* The smaller of a failed point's id and *bad (the one reported: the same for any storage order). */
static void note_failure(const struct mpm_points *p, size_t q, long *bad)
{
    long id = (long)p->id[q];
    *bad = *bad < 0 || id < *bad ? id : *bad;
}

/* Both cache lines a 120-byte point state can span, for writing: with 2 threads the other thread's transfers
 * may hold a shared copy, which stress_finish's stores would wait to invalidate (interleaved, 4 ns, 2 threads,
 * within a thread's range: 6.61 6.60 7.78 7.22 7.80e6 PUPS against 6.47 6.44 7.23 7.20 7.40e6 with a plain
 * prefetch of the next block whoever holds it). */
static inline void prefetch_state(const struct mpm_point_state *state)
{
    __builtin_prefetch(state, 1);
    __builtin_prefetch((const char *)state + 64, 1);
}

/* Steps 10-11 for the points q0 .. q0 + count - 1 in three phases, prefetching the states of the next
 * next_count points; returns the smallest id of a point that failed, or -1. */
static long update_block(struct mpm_solver *s, long q0, int count, long next_count, double log_dt)
{
    struct point_block b __attribute__((aligned(64)));
    struct mpm_stress_block stress = stress_block(s, q0, count, log_dt, &b);
    long bad = -1;
    block_shear_moduli(s, q0, &b, count);
    /* the next block's states, fetched while this block's velocity gradients are summed: block_shear_moduli is
     * the first to read them in the step, and stalled on every state (a sixth of update_block's samples) */
    const struct mpm_point_state *next = s->points.state + q0 + count;
    for (int k = 0; k < count; k++) {
        size_t q = (size_t)(q0 + k);
        if (k < next_count)
            prefetch_state(next + k);
        b.updating[k] = (s->points.flags[q] & POINT_ACTIVE) != 0;
        if (b.updating[k] && point_increments(s, q, &b, k) != 0) {
            b.updating[k] = 0;
            note_failure(&s->points, q, &bad);
        }
    }
    if (s->points.affine)
        store_affine(s, q0, &b, count);
    mpm_stress_begin_block(&stress);
    block_returns(s, &b, count);
    mpm_stress_finish_block(&stress);
    for (int k = 0; k < count; k++) {
        if (!b.updating[k])
            continue;
        if (b.failed[k]) /* the state became non-finite */
            note_failure(&s->points, (size_t)(q0 + k), &bad);
        else
            finish_point(s, (size_t)(q0 + k), &b, k);
    }
    return bad;
}

/* Steps 10-11 for the points [q0, end), block by block; a block prefetches the next block's states, within the
 * range only: the points after it are another thread's, being updated at that moment, and a prefetch for
 * writing would take their lines away from it. */
static long update_range(struct mpm_solver *s, long q0, long end, double log_dt)
{
    long bad = -1;
    for (long q = q0; q < end; q += POINT_BLOCK) {
        int count = (int)(end - q < POINT_BLOCK ? end - q : POINT_BLOCK);
        long failed = update_block(s, q, count, end - (q + count), log_dt);
        if (failed >= 0)
            bad = bad < 0 || failed < bad ? failed : bad;
    }
    return bad;
}

/* Blocks (POINT_BLOCK points each) a thread takes at a time (core/balance.h): 2,048 points, about 0.2 ms of work
 * in the 68,000-point benchmark (33 chunks a step); the atomic taking them is a few tens of ns. */
#define UPDATE_CHUNK 8

static int update_points(struct mpm_solver *s)
{
    struct mpm_points *p = &s->points;
    long n = (long)p->count, bad = n, blocks = (n + POINT_BLOCK - 1) / POINT_BLOCK;
    double log_dt = s->dt > 0.0 ? log(s->dt) : 0.0; /* once per step, not per plastic point (the same bits) */
    int team = omp_get_max_threads();
    balance_prepare(&s->update_balance, team);
    balance_shares(&s->update_balance, (size_t)blocks);
/* Contiguous shares of the blocks, balanced by the threads' speeds in the last steps, with stealing at the end
 * (core/balance.h): the costly plastic points of a particle sit together in index order, a thread keeps nearly
 * the same points from step to step, and what one step's speeds got wrong (a per-step wait of about 5 % of the
 * update, 2 threads) goes to the thread that is free.  Each point's update is its own: the same results on any
 * thread. */
#pragma omp parallel num_threads(team) reduction(min : bad)
    {
        size_t first, end, taken = 0;
        int thread = omp_get_thread_num(), threads = omp_get_num_threads();
        double start = omp_get_wtime();
        while (balance_next(&s->update_balance, thread, UPDATE_CHUNK, &first, &end)) {
            long q_end = (long)end * POINT_BLOCK < n ? (long)end * POINT_BLOCK : n;
            long failed = update_range(s, (long)first * POINT_BLOCK, q_end, log_dt);
            if (failed >= 0)
                bad = failed < bad ? failed : bad;
            taken += end - first;
        }
        balance_record(&s->update_balance, thread, threads, taken, omp_get_wtime() - start);
    }
    balance_update(&s->update_balance);
    if (bad < n)
        SC_FAIL(SC_ESIM,
                "impact: step %lld (t = %.6g s): material point %ld of body %d: the stress update gave a "
                "non-finite state or a non-positive volume (time step %.3g s)",
                (long long)s->step + 1, s->t, bad, p->body[p->slot[bad]], s->dt);
    return SC_OK;
}

/* Points whose stencil leaves the grid are removed and counted (docs/physics.md); their energy is booked.  Which they
 * are, and whether any went non-finite, grid_to_points found (the stress update moves no point). */
static int remove_escaped(struct mpm_solver *s)
{
    struct mpm_points *p = &s->points;
    int64_t leaving = s->leaving_points;
    if (s->nonfinite_id < (long)p->count)
        SC_FAIL(SC_ESIM,
                "impact: step %lld (t = %.6g s): material point %ld of body %d: position or velocity is "
                "not finite",
                (long long)s->step, s->t, s->nonfinite_id, p->body[p->slot[s->nonfinite_id]]);
    for (size_t i = 0; leaving > 0 && i < p->count; i++) {
        size_t q = p->slot[i]; /* by id: energy_removed sums in the same order for any storage order */
        if (!(p->flags[q] & POINT_ACTIVE) || grid_contains(&s->grid, p->x + 3 * q))
            continue;
        const double *v = p->v + 3 * q;
        p->flags[q] &= (uint8_t)~POINT_ACTIVE;
        s->removed_points++;
        s->removed_mass += p->mass[q];
        s->energy_removed += 0.5 * p->mass[q] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + p->state[q].energy;
        leaving--;
    }
    return SC_OK;
}

/* The first multiple of `every` after t (with t's tolerance of 1e-12), computed directly: a loop adding `every` to
 * the last due time took t / every turns, and none ended once `every` fell below half an ulp of that time (the
 * sum no longer grew).  [impact] keeps every >= t_end / MPM_MAX_CLOCK_TICKS (params.c); this holds for any
 * every > 0: at worst the next step is due. */
double mpm_clock_next(double t, double every)
{
    double limit = t * (1.0 + 1e-12);
    double next = every * (floor(limit / every) + 1.0);
    if (!(next > limit)) /* the quotient or the product rounded down */
        next += every;
    /* every below limit's rounding (next no later than limit, or later by its rounding only), or limit / every
     * beyond the doubles (next infinite): the next step is due */
    if (!(next > limit && next - limit <= 2.0 * every))
        next = nextafter(limit, INFINITY);
    return next;
}

static int advance_clocks(struct mpm_solver *s)
{
    const struct mpm_config *cfg = &s->cfg;
    int last = mpm_finished(s);
    if (s->t >= s->next_series * (1.0 - 1e-12) || last) {
        SC_TRY(mpm_series_record(s));
        mpm_verdict_record(s);
        last = mpm_finished(s); /* the verdicts may have settled on this row */
        if (s->next_series <= s->t * (1.0 + 1e-12))
            s->next_series = mpm_clock_next(s->t, cfg->series_every);
    }
    if (s->t >= s->next_snapshot * (1.0 - 1e-12) || last) {
        s->snapshot_pending = 1;
        if (s->next_snapshot <= s->t * (1.0 + 1e-12))
            s->next_snapshot = mpm_clock_next(s->t, cfg->snapshot_every);
    }
    return SC_OK;
}

/* Steps between two reorderings of the point storage (point_order.c).  The points of a block drift into other
 * blocks slowly (a block is 2 or 4 cells), and a reordering costs about one transfer. */
#define REORDER_EVERY 16

int mpm_step(struct mpm_solver *s)
{
    if (s->gpu) { /* the same step on the device (mpm/gpu.c), the clocks here */
        SC_TRY(mpm_gpu_step(s));
        return advance_clocks(s);
    }
    choose_time_step(s);
    mpm_grid_bin_points(s);
    if (s->step % REORDER_EVERY == 0) {
        SC_TRY(mpm_points_reorder(s));
        mpm_grid_bin_points(s);
    }
    mpm_grid_transfer_all(s);
    mpm_contact_nodal_update(s);
    mpm_book_absorbed_energy(s);
    grid_to_points(s);
    mpm_grid_transfer_momentum(s);
    mpm_contact_correct_momentum(s, s->grid.momentum_new, 0);
    nodal_velocities(s);
    SC_TRY(update_points(s));
    double *swap = s->points.x;
    s->points.x = s->points.x_next;
    s->points.x_next = swap;
    double t_before = s->t;
    s->t += s->dt;
    s->step++;
    s->point_updates += (int64_t)s->points.count - s->removed_points;
    SC_TRY(remove_escaped(s));
    mpm_conduction_advance(s, t_before, s->t); /* among the points that stay, positions finite */
    SC_TRY(advance_clocks(s));
    return SC_OK;
}

int mpm_snapshot_due(const struct mpm_solver *s)
{
    return s->snapshot_pending;
}
int64_t mpm_snapshot_index(const struct mpm_solver *s)
{
    return s->snapshot_count;
}
void mpm_snapshot_taken(struct mpm_solver *s)
{
    s->snapshot_pending = 0;
    s->snapshot_count++;
}
