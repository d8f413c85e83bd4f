/* Material points filling the bodies on a cubic lattice of spacing dp (thesis Section 3.4: DCell/dp), with
 * the surface points of the bonding model and the boundary points of the absorbing boundaries marked at set-up. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "mpm/mpm_impl.h"

/* Lattice position (i, j, k) of a body: spheres are centred on the lattice, cylinders and boxes hang from
 * their top face so that the substrate's top layer of points lies dp/2 below z = 0. */
static void lattice_position(const struct mpm_body *b, double dp, long i, long j, long k, double x[3])
{
    x[0] = b->center[0] + ((double)i + 0.5) * dp;
    x[1] = b->center[1] + ((double)j + 0.5) * dp;
    if (b->shape == MPM_SPHERE)
        x[2] = b->center[2] + ((double)k + 0.5) * dp;
    else
        x[2] = b->center[2] + 0.5 * b->h - ((double)k + 0.5) * dp;
}

static int inside(const struct mpm_body *b, const double x[3], double tol)
{
    double dx = x[0] - b->center[0], dy = x[1] - b->center[1], dz = x[2] - b->center[2];
    double r = 0.5 * b->d + tol;
    switch (b->shape) {
    case MPM_SPHERE:
        return dx * dx + dy * dy + dz * dz <= r * r;
    case MPM_CYLINDER:
        return dx * dx + dy * dy <= r * r && fabs(dz) <= 0.5 * b->h + tol;
    case MPM_BOX:
        return fabs(dx) <= r && fabs(dy) <= r && fabs(dz) <= 0.5 * b->h + tol;
    }
    return 0;
}

/* Index range of the lattice that covers the body. */
static void lattice_range(const struct mpm_body *b, double dp, long lo[3], long hi[3])
{
    long half = (long)ceil(0.5 * b->d / dp) + 1;
    lo[0] = lo[1] = -half;
    hi[0] = hi[1] = half;
    if (b->shape == MPM_SPHERE) {
        lo[2] = -half;
        hi[2] = half;
    } else {
        lo[2] = 0;
        hi[2] = (long)ceil(b->h / dp) + 1;
    }
}

struct point_seed {
    double x[3];
    uint8_t flags;
    double normal[3];
};

/* Surface and boundary marks from the six lattice neighbours (Section 4.1.1: surface points; Section 3.5.5:
 * absorbing boundary on the substrate's bottom and sides, not its top). */
static void classify(const struct mpm_body *b, double dp, double tol, struct point_seed *seed)
{
    static const int dirs[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    seed->flags = POINT_ACTIVE;
    for (int n = 0; n < 6; n++) {
        double y[3];
        for (int k = 0; k < 3; k++)
            y[k] = seed->x[k] + dirs[n][k] * dp;
        if (inside(b, y, tol))
            continue;
        seed->flags |= POINT_SURFACE;
        if (!b->substrate || n == 4)
            continue;
        if (n == 5) {
            seed->flags |= POINT_BOTTOM;
        } else {
            seed->flags |= POINT_SIDE;
            for (int k = 0; k < 3; k++)
                seed->normal[k] += dirs[n][k];
        }
    }
    if ((seed->flags & POINT_SIDE) && b->shape == MPM_CYLINDER) {
        seed->normal[0] = seed->x[0] - b->center[0];
        seed->normal[1] = seed->x[1] - b->center[1];
        seed->normal[2] = 0.0;
    }
    double norm =
        sqrt(seed->normal[0] * seed->normal[0] + seed->normal[1] * seed->normal[1] + seed->normal[2] * seed->normal[2]);
    for (int k = 0; k < 3 && norm > 0; k++)
        seed->normal[k] /= norm;
}

/* Whether a lattice position lies on the modelled side of the mirror planes ([impact] symmetry): the lattice of a
 * body centred on a plane has no point on it (offsets (i + 1/2) dp), and its points on the other side are the
 * mirror images of those kept. */
static int modelled(const int mirror[2], const double x[3])
{
    return (!mirror[0] || x[0] > 0.0) && (!mirror[1] || x[1] > 0.0);
}

int mpm_mirror_check(const struct mpm_config *cfg, char *why, size_t size)
{
    static const char axis[2] = {'x', 'y'};
    for (int b = 0; b < cfg->body_count; b++)
        for (int d = 0; d < 2; d++) {
            const struct mpm_body *body = &cfg->bodies[b];
            if (!cfg->mirror[d] || (body->center[d] == 0.0 && body->velocity[d] == 0.0))
                continue;
            snprintf(why, size,
                     "body %d is centred at %c = %g m moving at v_%c = %g m/s, not on the mirror plane %c = 0", b,
                     axis[d], body->center[d], axis[d], body->velocity[d], axis[d]);
            return -1;
        }
    return 0;
}

static int seed_body(const struct mpm_config *cfg, int body, struct point_seed **seeds, size_t *count, size_t *capacity)
{
    const struct mpm_body *b = &cfg->bodies[body];
    double dp = cfg->spacing;
    long lo[3], hi[3];
    lattice_range(b, dp, lo, hi);
    double tol = 1e-9 * dp;
    for (long k = lo[2]; k <= hi[2]; k++)
        for (long j = lo[1]; j <= hi[1]; j++)
            for (long i = lo[0]; i <= hi[0]; i++) {
                struct point_seed seed = {0};
                lattice_position(b, dp, i, j, k, seed.x);
                if (!inside(b, seed.x, tol) || !modelled(cfg->mirror, seed.x))
                    continue;
                classify(b, dp, tol, &seed);
                if (*count == *capacity) {
                    size_t grown = *capacity ? 2 * *capacity : 4096;
                    struct point_seed *more = realloc(*seeds, grown * sizeof *more);
                    if (!more)
                        SC_FAIL_OOM(grown * sizeof *more, "seeding material points");
                    *seeds = more;
                    *capacity = grown;
                }
                (*seeds)[(*count)++] = seed;
            }
    return SC_OK;
}

static int allocate(struct mpm_points *p, size_t n)
{
    memset(p, 0, sizeof *p);
    p->count = n;
    p->x = mpm_calloc_lines(3 * n, sizeof *p->x);
    p->v = mpm_calloc_lines(3 * n, sizeof *p->v);
    p->x_next = mpm_calloc_lines(3 * n, sizeof *p->x_next);
    p->mass = mpm_calloc_lines(n, sizeof *p->mass);
    p->volume0 = mpm_calloc_lines(n, sizeof *p->volume0);
    p->volume = mpm_calloc_lines(n, sizeof *p->volume);
    p->d_bond = mpm_calloc_lines(n, sizeof *p->d_bond);
    p->plastic_work = mpm_calloc_lines(n, sizeof *p->plastic_work);
    p->normal = mpm_calloc_lines(3 * n, sizeof *p->normal);
    p->state = mpm_calloc_lines(n, sizeof *p->state);
    p->body = mpm_calloc_lines(n, sizeof *p->body);
    p->flags = mpm_calloc_lines(n, sizeof *p->flags);
    p->id = mpm_calloc_lines(n, sizeof *p->id);
    p->slot = mpm_calloc_lines(n, sizeof *p->slot);
    if (n >= UINT32_MAX)
        SC_FAIL(SC_EINPUT, "impact: %zu material points; at most %u are supported", n, UINT32_MAX - 1);
    if (!p->x || !p->id || !p->slot || !p->x_next || !p->v || !p->mass || !p->volume0 || !p->volume || !p->d_bond ||
        !p->plastic_work || !p->normal || !p->state || !p->body || !p->flags)
        SC_FAIL_OOM(n * (9 * sizeof *p->x + 4 * sizeof *p->mass + sizeof *p->state + sizeof *p->body +
                         sizeof *p->flags + sizeof *p->id + sizeof *p->slot),
                    "the material points");
    return SC_OK;
}

/* Bodies may touch but not overlap: a point of one inside another is a set-up error. */
static int points_inside(const struct mpm_config *cfg, int other, const struct point_seed *seeds, size_t count)
{
    for (size_t i = 0; i < count; i++)
        if (inside(&cfg->bodies[other], seeds[i].x, -0.25 * cfg->spacing))
            return 1;
    return 0;
}

/* The box around a body's points, widened by a spacing (the points lie within the shape, to a tolerance). */
struct body_box {
    double lo[3], hi[3];
};

static struct body_box box_of(const struct mpm_body *b, double slack)
{
    double half[3] = {0.5 * b->d, 0.5 * b->d, b->shape == MPM_SPHERE ? 0.5 * b->d : 0.5 * b->h};
    struct body_box box;
    for (int k = 0; k < 3; k++) {
        box.lo[k] = b->center[k] - half[k] - slack;
        box.hi[k] = b->center[k] + half[k] + slack;
    }
    return box;
}

void mpm_bodies_bounds(const struct mpm_config *cfg, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (int b = 0; b < cfg->body_count; b++) {
        struct body_box box = box_of(&cfg->bodies[b], cfg->spacing);
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], box.lo[k]);
            hi[k] = fmax(hi[k], box.hi[k]);
        }
    }
    for (int k = 0; k < 2; k++) /* the modelled side of a mirror plane ([impact] symmetry) */
        if (cfg->mirror[k])
            lo[k] = fmax(lo[k], 0.0);
}

static int boxes_meet(const struct body_box *a, const struct body_box *b)
{
    for (int k = 0; k < 3; k++)
        if (a->hi[k] < b->lo[k] || b->hi[k] < a->lo[k])
            return 0;
    return 1;
}

struct box_entry {
    int64_t cell[3];
    int body;
};

static int compare_cell(const int64_t *a, const int64_t *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k] ? -1 : 1;
    return 0;
}

static int compare_box_entries(const void *pa, const void *pb)
{
    const struct box_entry *a = pa, *b = pb;
    int by_cell = compare_cell(a->cell, b->cell);
    return by_cell ? by_cell : (a->body > b->body) - (a->body < b->body);
}

static int compare_ints(const void *pa, const void *pb)
{
    int a = *(const int *)pa, b = *(const int *)pb;
    return (a > b) - (a < b);
}

/* Cell of a coordinate, clamped (monotone: boxes less than a cell apart stay in neighbouring cells). */
static int64_t box_cell(double x, double width)
{
    double cell = floor(x / width);
    if (!(cell > -4e15))
        cell = -4e15;
    if (cell > 4e15)
        cell = 4e15;
    return (int64_t)cell;
}

/* The first body (in order) with a point inside an earlier body, and the first such earlier body: the pairs come
 * from a cell list of the bodies' boxes (cells as wide as the widest box but the substrate's), not from every
 * pair, which made the set-up of 1e5 bodies take hours. */
static int check_overlaps(const struct mpm_config *cfg, struct point_seed *const *seeds, const size_t *counts)
{
    int n = cfg->body_count, status = SC_OK;
    double slack = cfg->spacing, width = 0.0;
    struct body_box *boxes = malloc((size_t)n * sizeof *boxes);
    struct box_entry *entries = malloc((size_t)n * sizeof *entries);
    int *candidates = malloc((size_t)n * sizeof *candidates), *substrates = malloc((size_t)n * sizeof *substrates);
    if (!boxes || !entries || !candidates || !substrates)
        SC_FAIL_OOM_AT(status, done, (size_t)n * (sizeof *boxes + sizeof *entries + 2 * sizeof(int)),
                       "the bodies' overlap check");
    for (int b = 0; b < n; b++) {
        boxes[b] = box_of(&cfg->bodies[b], slack);
        for (int k = 0; !cfg->bodies[b].substrate && k < 3; k++)
            if (boxes[b].hi[k] - boxes[b].lo[k] > width)
                width = boxes[b].hi[k] - boxes[b].lo[k];
    }
    if (!(width > 0.0) || !isfinite(width))
        width = 1.0;
    size_t small = 0;
    int substrate_count = 0;
    for (int b = 0; b < n; b++) {
        if (cfg->bodies[b].substrate)
            substrates[substrate_count++] = b;
        if (cfg->bodies[b].substrate)
            continue;
        for (int k = 0; k < 3; k++)
            entries[small].cell[k] = box_cell(boxes[b].lo[k], width);
        entries[small++].body = b;
    }
    qsort(entries, small, sizeof *entries, compare_box_entries);
    for (int b = 0; b < n; b++) {
        int found = 0;
        /* for a substrate every earlier body; for another body the earlier substrates (a list: a scan of every
         * earlier body for each body made 3e5 bodies take minutes) */
        if (cfg->bodies[b].substrate) {
            for (int o = 0; o < b; o++)
                if (boxes_meet(&boxes[o], &boxes[b]))
                    candidates[found++] = o;
        } else {
            for (int i = 0; i < substrate_count && substrates[i] < b; i++)
                if (boxes_meet(&boxes[substrates[i]], &boxes[b]))
                    candidates[found++] = substrates[i];
        }
        if (!cfg->bodies[b].substrate) {
            /* a box no wider than a cell that meets b's starts in the cells from lo - width to hi */
            int64_t from[3], to[3];
            for (int k = 0; k < 3; k++) {
                from[k] = box_cell(boxes[b].lo[k] - width, width);
                to[k] = box_cell(boxes[b].hi[k], width);
            }
            for (int64_t x = from[0]; x <= to[0]; x++)
                for (int64_t y = from[1]; y <= to[1]; y++)
                    for (int64_t z = from[2]; z <= to[2]; z++) {
                        int64_t cell[3] = {x, y, z};
                        size_t low = 0, high = small;
                        while (low < high) {
                            size_t middle = low + (high - low) / 2;
                            if (compare_cell(entries[middle].cell, cell) < 0)
                                low = middle + 1;
                            else
                                high = middle;
                        }
                        for (size_t e = low; e < small && compare_cell(entries[e].cell, cell) == 0; e++) {
                            int o = entries[e].body;
                            if (o < b && boxes_meet(&boxes[o], &boxes[b]))
                                candidates[found++] = o;
                        }
                    }
        }
        qsort(candidates, (size_t)found, sizeof *candidates, compare_ints);
        for (int i = 0; i < found; i++)
            if (points_inside(cfg, candidates[i], seeds[b], counts[b]))
                SC_FAIL_AT(status, done, SC_EINPUT, "impact: body %d overlaps body %d (bodies may touch, not overlap)",
                           b, candidates[i]);
    }
done:
    free(boxes);
    free(entries);
    free(candidates);
    free(substrates);
    return status;
}

static void fill_points(const struct mpm_config *cfg, int body, const struct point_seed *seeds, size_t count,
                        size_t offset, struct mpm_points *p)
{
    const struct mpm_body *b = &cfg->bodies[body];
    const struct mpm_material *m = &cfg->materials[b->material];
    double volume = cfg->spacing * cfg->spacing * cfg->spacing;
    /* the same initial state for every point of the body: set up once (its PTW flow stress, evaluated per point,
     * cost more than half a time step of the small impact case) */
    struct mpm_point_state initial;
    if (b->temperature > 0.0)
        mpm_point_state_init_at(m, b->temperature, &initial);
    else
        mpm_point_state_init(m, &initial);
    for (size_t i = 0; i < count; i++) {
        size_t q = offset + i;
        memcpy(p->x + 3 * q, seeds[i].x, sizeof seeds[i].x);
        memcpy(p->v + 3 * q, b->velocity, sizeof b->velocity);
        memcpy(p->normal + 3 * q, seeds[i].normal, sizeof seeds[i].normal);
        p->mass[q] = m->density * volume;
        p->volume0[q] = p->volume[q] = volume;
        p->body[q] = body;
        p->flags[q] = seeds[i].flags;
        p->state[q] = initial;
    }
}

int mpm_points_create(const struct mpm_config *cfg, struct mpm_points *points)
{
    memset(points, 0, sizeof *points);
    struct point_seed **seeds = NULL;
    size_t *counts = NULL, total = 0;
    int status;
    SC_CHECK(status, sc_calloc(&seeds, (size_t)cfg->body_count, sizeof *seeds, "the bodies' seeds"), done);
    SC_CHECK(status, sc_calloc(&counts, (size_t)cfg->body_count, sizeof *counts, "the bodies' seeds"), done);
    char why[256];
    if (mpm_mirror_check(cfg, why, sizeof why) != 0)
        SC_FAIL_AT(status, done, SC_EINPUT, "impact: symmetry: %s", why);
    for (int b = 0; b < cfg->body_count; b++) {
        size_t capacity = 0;
        SC_CHECK(status, seed_body(cfg, b, &seeds[b], &counts[b], &capacity), done);
        if (counts[b] == 0)
            SC_FAIL_AT(
                status, done, SC_EINPUT,
                "impact: body %d (d = %g m%s) holds no material point at [impact] spacing = %g m; allowed: "
                "bodies at least two spacings across (a particle's diameter, a box's side and height, in [impact] "
                "or a row of [impact] bodies; with [couple] reference_diameter the spacing scales with it)",
                b, cfg->bodies[b].d, cfg->bodies[b].shape == MPM_SPHERE ? "" : ", a cylinder or box", cfg->spacing);
        total += counts[b];
    }
    SC_CHECK(status, check_overlaps(cfg, seeds, counts), done);
    SC_CHECK(status, allocate(points, total), done);
    if (cfg->transfer == MPM_TRANSFER_APIC) { /* C_p = 0: every body starts in uniform motion */
        points->affine = mpm_calloc_lines(9 * (total ? total : 1), sizeof *points->affine);
        if (!points->affine)
            SC_FAIL_OOM_AT(status, done, 9 * total * sizeof *points->affine, "the points' affine matrices");
    }
    mpm_points_order_reset(points);
    size_t offset = 0;
    for (int b = 0; b < cfg->body_count; offset += counts[b], b++)
        fill_points(cfg, b, seeds[b], counts[b], offset, points);
done:
    for (int b = 0; seeds && b < cfg->body_count; b++)
        free(seeds[b]);
    free(seeds);
    free(counts);
    if (status != SC_OK) /* what allocate got before it failed */
        mpm_points_free(points);
    return status;
}

void mpm_points_free(struct mpm_points *p)
{
    free(p->x);
    free(p->v);
    free(p->x_next);
    free(p->mass);
    free(p->volume0);
    free(p->volume);
    free(p->d_bond);
    free(p->plastic_work);
    free(p->normal);
    free(p->state);
    free(p->body);
    free(p->flags);
    free(p->id);
    free(p->slot);
    free(p->affine);
    memset(p, 0, sizeof *p);
}
