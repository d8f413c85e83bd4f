/* The background grid: shape functions (trilinear, Eq. 3.20, or uGIMP) and the particle-to-grid transfers of
 * thesis Section 3.4 steps 1-2 and 8 (mass and momentum Eqs. 3.23-3.24, forces Eqs. 3.25-3.27, the MUSL
 * re-projection Eq. 3.33), done block by block in 8 colours so that no two threads ever add to the
 * same node and every node receives its contributions in the same order for any number of threads. */
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "mpm/contact_node.h" /* PAIR_STATE_LAYERS */
#include "mpm/mpm_impl.h"

size_t mpm_grid_node(const struct mpm_grid *g, int i, int j, int k)
{
    return ((size_t)k * (size_t)g->n[1] + (size_t)j) * (size_t)g->n[0] + (size_t)i;
}

static void linear_weights(double xi, int *base, double w[3], double dw[3], double h)
{
    double cell = floor(xi);
    double f = xi - cell;
    *base = (int)cell;
    w[0] = 1.0 - f;
    w[1] = f;
    dw[0] = -1.0 / h;
    dw[1] = 1.0 / h;
}

/* uGIMP weight and derivative of a node at signed distance r = x_p - x_I (Bardenhagen & Kober 2004, with the
 * particle's half-width l constant: "uniform" GIMP). */
static void ugimp_weight(double r, double h, double l, double *w, double *dw)
{
    double a = fabs(r), sign = r < 0 ? -1.0 : 1.0;
    if (a >= h + l) {
        *w = *dw = 0.0;
    } else if (a > h - l) {
        *w = (h + l - a) * (h + l - a) / (4.0 * h * l);
        *dw = -sign * (h + l - a) / (2.0 * h * l);
    } else if (a >= l) {
        *w = 1.0 - a / h;
        *dw = -sign / h;
    } else {
        *w = 1.0 - (r * r + l * l) / (2.0 * h * l);
        *dw = -r / (h * l);
    }
}

int mpm_grid_stencil(const struct mpm_grid *g, enum mpm_shape_function kind, double lp, const double x[3],
                     struct stencil *st)
{
    st->width = kind == MPM_UGIMP ? 3 : 2;
    for (int d = 0; d < 3; d++) {
        double xi = (x[d] - g->origin[d]) / g->h;
        if (!(xi > 1.0 && xi < (double)g->n[d] - 2.0))
            return -1;
        if (kind == MPM_LINEAR) {
            linear_weights(xi, &st->base[d], st->w[d], st->g[d], g->h);
            continue;
        }
        st->base[d] = (int)floor(xi + 0.5) - 1;
        for (int a = 0; a < 3; a++) {
            double node = g->origin[d] + (double)(st->base[d] + a) * g->h;
            ugimp_weight(x[d] - node, g->h, lp, &st->w[d][a], &st->g[d][a]);
        }
    }
    st->node = mpm_grid_node(g, st->base[0], st->base[1], st->base[2]);
    return 0;
}

/* What alloc_layers allocates for one node of one body's layer. */
#define GRID_BYTES_PER_NODE_LAYER                                                                                      \
    (sizeof *((struct mpm_grid *)0)->mass + 18 * sizeof *((struct mpm_grid *)0)->momentum +                            \
     sizeof *((struct mpm_grid *)0)->bond_sum + sizeof *((struct mpm_grid *)0)->bond_weight +                          \
     2 * sizeof *((struct mpm_grid *)0)->contact + sizeof *((struct mpm_grid *)0)->wall_held)

static int alloc_layers(struct mpm_grid *g)
{
    size_t n = g->nodes * (size_t)g->layers;
    g->mass = mpm_calloc_lines(n, sizeof *g->mass);
    /* one double to spare after the vector fields read with node_vector (mpm_impl.h) */
    g->momentum = mpm_calloc_lines(3 * n + 1, sizeof *g->momentum);
    g->momentum_new = mpm_calloc_lines(3 * n + 1, sizeof *g->momentum_new);
    g->force = mpm_calloc_lines(3 * n, sizeof *g->force);
    g->gradient = mpm_calloc_lines(3 * n, sizeof *g->gradient);
    g->moment = mpm_calloc_lines(3 * n, sizeof *g->moment);
    g->velocity = mpm_calloc_lines(3 * n + 1, sizeof *g->velocity);
    g->bond_sum = mpm_calloc_lines(n, sizeof *g->bond_sum);
    g->bond_weight = mpm_calloc_lines(n, sizeof *g->bond_weight);
    g->contact = mpm_calloc_lines(n, sizeof *g->contact);
    g->bond_contact = mpm_calloc_lines(n, sizeof *g->bond_contact);
    g->wall_held = mpm_calloc_lines(n, sizeof *g->wall_held);
    g->body_velocity = mpm_calloc_lines(3 * (size_t)g->layers, sizeof *g->body_velocity);
    int pairs = g->layers >= 3 && g->layers <= PAIR_STATE_LAYERS; /* a node may hold more than one pair */
    g->pair_state = pairs ? mpm_calloc_lines(n, sizeof *g->pair_state) : NULL;
    if (!g->body_velocity || !g->bond_contact || !g->mass || !g->momentum || !g->momentum_new || !g->force ||
        !g->gradient || !g->moment || !g->velocity || !g->bond_sum || !g->bond_weight || !g->contact || !g->wall_held ||
        (pairs && !g->pair_state))
        SC_FAIL_OOM(n * (GRID_BYTES_PER_NODE_LAYER + (size_t)pairs * sizeof *g->pair_state) + 3 * sizeof *g->momentum,
                    "the grid (nodes x bodies)");
    return SC_OK;
}

/* Blocks are 4 cells a side, or 2 where a block of 4 filled with points would hold more than this share of a
 * colour's points: a colour's blocks are shared among the threads whole, and in the 68,000-point impact of
 * `make bench` (3 points a cell a side) a block of 4 held a fifth of its colour's points, too coarse a share
 * (2-thread transfer wall -10 to -13 % with blocks of 2 there; on the 1e6-point grid, 2 % a block, blocks of 2
 * cost 15 % more work). */
#define MAX_BLOCK_SHARE 0.05

static void block_grid(struct mpm_grid *g, int shift)
{
    g->block_shift = shift;
    for (int d = 0; d < 3; d++)
        g->blocks[d] = (g->n[d] + (1 << shift) - 1) >> shift;
    g->block_count = (size_t)g->blocks[0] * (size_t)g->blocks[1] * (size_t)g->blocks[2];
}

static int alloc_blocks(struct mpm_grid *g, size_t points, double spacing)
{
    double cell_points = pow(g->h / spacing, 3.0), colour_points = (double)points / 8.0;
    block_grid(g, 64.0 * cell_points > MAX_BLOCK_SHARE * colour_points ? 1 : 2);
    g->block_start = calloc(g->block_count + 1, sizeof *g->block_start);
    g->block_points = mpm_calloc_lines(points ? points : 1, sizeof *g->block_points);
    g->sort_threads = omp_get_max_threads();
    g->block_cursor = calloc((size_t)g->sort_threads * (g->block_count ? g->block_count : 1), sizeof *g->block_cursor);
    g->point_block = mpm_calloc_lines(points ? points : 1, sizeof *g->point_block);
    g->point_node = mpm_calloc_lines(points ? points : 1, sizeof *g->point_node);
    g->point_fraction = mpm_calloc_lines(3 * (points ? points : 1), sizeof *g->point_fraction);
    for (int c = 0; c < 8; c++) {
        g->colour_blocks[c] = calloc(g->block_count, sizeof *g->colour_blocks[c]);
        g->colour_points[c] = calloc(g->block_count + 1, sizeof *g->colour_points[c]);
    }
    for (int c = 0; c < 8; c++)
        if (!g->colour_blocks[c] || !g->colour_points[c])
            SC_FAIL_OOM((2 * g->block_count + 1) * sizeof *g->colour_points[c], "the grid blocks of a colour");
    if (!g->block_start || !g->block_points || !g->block_cursor || !g->point_block || !g->point_node ||
        !g->point_fraction)
        SC_FAIL_OOM((points ? points : 1) * (sizeof *g->block_points + sizeof *g->point_block + sizeof *g->point_node +
                                             3 * sizeof *g->point_fraction),
                    "the grid blocks");
    for (int k = 0; k < g->blocks[2]; k++)
        for (int j = 0; j < g->blocks[1]; j++)
            for (int i = 0; i < g->blocks[0]; i++) {
                int colour = (i & 1) | (j & 1) << 1 | (k & 1) << 2;
                size_t block = ((size_t)k * (size_t)g->blocks[1] + (size_t)j) * (size_t)g->blocks[0] + (size_t)i;
                g->colour_blocks[colour][g->colour_count[colour]++] = block;
            }
    return SC_OK;
}

/* The least double offset d with d / h > bound as rounded: the rounded quotient grows with d, so d / h > bound
 * holds exactly for the offsets from it on (grid_contains). */
static double least_offset_above(double h, double bound)
{
    double d = bound * h;
    while (d / h > bound)
        d = nextafter(d, -INFINITY);
    while (!(d / h > bound))
        d = nextafter(d, INFINITY);
    return d;
}

/* The grid around the box lo..hi: cells of cfg->grid, box_margin and two guard cells beyond it on each side, node
 * planes on multiples of DCell so that z = 0 (the substrate's top) is a node plane.  A grid too fine to count in an
 * int per axis (a cell of 1e-12 m) gets nodes = SIZE_MAX, refused by the caller's size check (the count overflowed
 * and wrapped, a review: 1e-12 m reported 5.8e17 nodes).  Returns the number of nodes as a double, unbounded. */
static double grid_layout(const struct mpm_config *cfg, const double lo[3], const double hi[3], struct mpm_grid *g)
{
    memset(g, 0, sizeof *g);
    g->h = cfg->grid;
    g->inv_h = 1.0 / g->h;
    g->layers = cfg->body_count;
    double nodes = 1.0;
    for (int d = 0; d < 3; d++) {
        g->origin[d] = g->h * (floor((lo[d] - cfg->box_margin) / g->h) - 2.0);
        double count = ceil((hi[d] + cfg->box_margin - g->origin[d]) / g->h) + 3.0;
        g->n[d] = count < (double)INT_MAX ? (int)count : INT_MAX;
        nodes *= count;
    }
    g->nodes = nodes < 0x1p63 ? (size_t)nodes : SIZE_MAX;
    return nodes;
}

static int grid_box(const struct mpm_config *cfg, const double lo[3], const double hi[3], struct mpm_grid *g)
{
    grid_layout(cfg, lo, hi, g);
    for (int d = 0; d < 3; d++) {
        /* 1 < d / h < n - 2: d / h > 1, and not d / h > the double below n - 2 */
        g->inside_from[d] = least_offset_above(g->h, 1.0);
        g->inside_to[d] = least_offset_above(g->h, nextafter((double)g->n[d] - 2.0, -INFINITY));
    }
    g->row = (size_t)g->n[0];
    g->plane = g->row * (size_t)g->n[1];
    for (int d = 0; d < 2; d++) /* origin is a whole number of cells: the plane 0 is a node plane */
        g->mirror_plane[d] = lround(-g->origin[d] / g->h);
    if (g->nodes > MPM_GRID_MAX_NODES)
        SC_FAIL(SC_EINPUT,
                "impact: the grid would have %zu nodes (%d x %d x %d); use a coarser grid or a smaller "
                "box_margin",
                g->nodes, g->n[0], g->n[1], g->n[2]);
    return SC_OK;
}

/* The grid of cfg with cells of h around the bodies' box: it fits when within the node limit and memory (memory 0:
 * unknown, not checked); its bytes in *bytes. */
static int grid_fits(const struct mpm_config *cfg, double h, const double lo[3], const double hi[3], double memory,
                     double *bytes)
{
    struct mpm_config trial = *cfg;
    trial.grid = h;
    struct mpm_grid g;
    grid_layout(&trial, lo, hi, &g);
    *bytes = (double)g.nodes * (double)g.layers * (double)GRID_BYTES_PER_NODE_LAYER;
    return g.nodes <= MPM_GRID_MAX_NODES && (memory <= 0.0 || *bytes <= memory);
}

void mpm_grid_need(const struct mpm_config *cfg, double memory, struct mpm_grid_need *need)
{
    double lo[3], hi[3];
    mpm_bodies_bounds(cfg, lo, hi);
    struct mpm_grid g;
    need->nodes = grid_layout(cfg, lo, hi, &g);
    need->memory = memory;
    need->fits = grid_fits(cfg, cfg->grid, lo, hi, memory, &need->bytes);
    need->finest = cfg->grid;
    if (need->fits)
        return;
    /* the finest cell that fits: bisection on the cell size between one that does not and one that does */
    double coarse = cfg->grid, fine = cfg->grid, bytes;
    for (int k = 0; k < 200 && !grid_fits(cfg, coarse, lo, hi, memory, &bytes); k++)
        fine = coarse, coarse *= 2.0;
    for (int k = 0; k < 60; k++) {
        double middle = 0.5 * (fine + coarse);
        if (grid_fits(cfg, middle, lo, hi, memory, &bytes))
            coarse = middle;
        else
            fine = middle;
    }
    need->finest = coarse;
}

int mpm_grid_create(const struct mpm_config *cfg, const struct mpm_points *p, struct mpm_grid *g)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t q = 0; q < p->count; q++)
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], p->x[3 * q + d]);
            hi[d] = fmax(hi[d], p->x[3 * q + d]);
        }
    SC_TRY(grid_box(cfg, lo, hi, g));
    double lightest = INFINITY;
    for (int m = 0; m < cfg->material_count; m++)
        lightest = fmin(lightest, cfg->materials[m].density);
    /* Nodes lighter than 1e-14 of a full cell carry no velocity (a point exactly on a node plane).  MPM3D-F90
     * drops nodes below 1e-5 of a cell, but the force a dropped node holds is lost from the momentum balance
     * (its weight gradient is not small), and N_Ip / m_I <= 1 / m_p bounds what a light node gives a point. */
    g->mass_cutoff = 1e-14 * lightest * g->h * g->h * g->h;
    for (int d = 0; d < 3; d++) {
        g->box.lo[d] = g->held.lo[d] = 0;
        g->box.hi[d] = g->held.hi[d] = g->n[d] - 1;
    }
    g->moments = cfg->contact_scheme == MPM_CONTACT_ONCE && (g->layers > 1 || cfg->substrate == MPM_SUBSTRATE_RIGID);
    SC_TRY(alloc_layers(g));
    SC_TRY(alloc_blocks(g, p->count, cfg->spacing));
    return SC_OK;
}

void mpm_grid_free(struct mpm_grid *g)
{
    free(g->mass);
    free(g->momentum);
    free(g->momentum_new);
    free(g->force);
    free(g->gradient);
    free(g->moment);
    free(g->velocity);
    free(g->bond_sum);
    free(g->bond_weight);
    free(g->contact);
    free(g->pair_state);
    free(g->bond_contact);
    free(g->wall_held);
    free(g->body_velocity);
    for (int kind = 0; kind < 2; kind++)
        for (int colour = 0; colour < 8; colour++)
            balance_free(&g->colour_balance[kind][colour]);
    free(g->block_start);
    free(g->block_points);
    free(g->block_cursor);
    free(g->point_block);
    free(g->point_node);
    free(g->point_fraction);
    for (int c = 0; c < 8; c++) {
        free(g->colour_blocks[c]);
        free(g->colour_points[c]);
    }
    memset(g, 0, sizeof *g);
}

/* The base cell and the fractions of a trilinear stencil at x, as mpm_grid_stencil computes them (Eq. 3.20) without
 * the weights: 0, or -1 when the stencil leaves the grid.  Inlined into the binning loop, which calls it for
 * every point and step. */
static inline int linear_cell(const struct mpm_grid *g, const double x[3], struct stencil *st, double f[3])
{
    for (int d = 0; d < 3; d++) {
        double xi = (x[d] - g->origin[d]) / g->h;
        if (!(xi > 1.0 && xi < (double)g->n[d] - 2.0))
            return -1;
        double cell = floor(xi);
        f[d] = xi - cell;
        st->base[d] = (int)cell;
    }
    st->node = mpm_grid_node(g, st->base[0], st->base[1], st->base[2]);
    return 0;
}

/* The block starts and each thread's write cursors from the counts in block_cursor (thread t's row counts the
 * points of its ids per block): block b's points are thread 0's, then thread 1's, ... */
static void block_offsets(struct mpm_grid *g, int threads)
{
    size_t at = 0;
    for (size_t b = 0; b < g->block_count; b++) {
        g->block_start[b] = at;
        for (int t = 0; t < threads; t++) {
            size_t *cursor = g->block_cursor + (size_t)t * g->block_count + b, count = *cursor;
            *cursor = at;
            at += count;
        }
    }
    g->block_start[g->block_count] = at;
}

/* The active points into block_points by block, by id within a block, whatever the storage order: a node sums
 * its points' contributions in the same order always.  A counting sort in which each thread takes a range of
 * ids: its points follow those of the lower ranges in every block, so the order is the serial sort's for any
 * thread count (a serial pass had been a tenth of the 2-thread step's time spent by one thread alone). */
static void sort_by_block(struct mpm_grid *g, const struct mpm_points *p)
{
    size_t n = p->count, blocks = g->block_count;
    int threads = omp_get_max_threads() < g->sort_threads ? omp_get_max_threads() : g->sort_threads;
#pragma omp parallel num_threads(threads)
    {
        int t = omp_get_thread_num(), threads = omp_get_num_threads();
        size_t lo = n * (size_t)t / (size_t)threads, hi = n * (size_t)(t + 1) / (size_t)threads;
        size_t *cursor = g->block_cursor + (size_t)t * blocks;
        memset(cursor, 0, blocks * sizeof *cursor);
        for (size_t i = lo; i < hi; i++) {
            int b = g->point_block[p->slot[i]];
            if (b >= 0)
                cursor[b]++;
        }
#pragma omp barrier
#pragma omp single
        block_offsets(g, threads);
        for (size_t i = lo; i < hi; i++) {
            size_t q = p->slot[i];
            if (g->point_block[q] >= 0)
                g->block_points[cursor[g->point_block[q]]++] = q;
        }
    }
}

/* The running sums of the points in each colour's blocks, by which the transfer shares a colour's blocks. */
static void count_colour_points(struct mpm_grid *g)
{
    for (int colour = 0; colour < 8; colour++) {
        const size_t *blocks = g->colour_blocks[colour];
        size_t *sum = g->colour_points[colour];
        sum[0] = 0;
        for (size_t i = 0; i < g->colour_count[colour]; i++)
            sum[i + 1] = sum[i] + (g->block_start[blocks[i] + 1] - g->block_start[blocks[i]]);
    }
}

void mpm_grid_bin_points(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    long n = (long)p->count;
    int linear = s->cfg.shape_function == MPM_LINEAR;
    /* the box of the stencils' nodes: the extremes of their base nodes (scalars: an array reduction was kept in
     * memory), widened by the stencil's width (2 nodes trilinear, 3 uGIMP) */
    int lo0 = INT_MAX, lo1 = INT_MAX, lo2 = INT_MAX, hi0 = INT_MIN, hi1 = INT_MIN, hi2 = INT_MIN;
    int last = linear ? 1 : 2;
#pragma omp parallel for schedule(static) reduction(min : lo0, lo1, lo2) reduction(max : hi0, hi1, hi2)
    for (long q = 0; q < n; q++) {
        struct stencil st;
        double f[3] = {0.0, 0.0, 0.0}; /* trilinear: the fractions; unused for uGIMP */
        g->point_block[q] = -1;
        if (!(p->flags[q] & POINT_ACTIVE))
            continue;
        if ((linear ? linear_cell(g, p->x + 3 * q, &st, f)
                    : mpm_grid_stencil(g, s->cfg.shape_function, s->lp, p->x + 3 * q, &st)) != 0)
            continue;
        int b[3];
        for (int d = 0; d < 3; d++) {
            b[d] = st.base[d] >> g->block_shift; /* base >= 0 (xi > 1) */
            g->point_fraction[3 * q + d] = f[d];
        }
        lo0 = st.base[0] < lo0 ? st.base[0] : lo0, hi0 = st.base[0] > hi0 ? st.base[0] : hi0;
        lo1 = st.base[1] < lo1 ? st.base[1] : lo1, hi1 = st.base[1] > hi1 ? st.base[1] : hi1;
        lo2 = st.base[2] < lo2 ? st.base[2] : lo2, hi2 = st.base[2] > hi2 ? st.base[2] : hi2;
        g->point_node[q] = (uint32_t)st.node;
        g->point_block[q] =
            (int)(((size_t)b[2] * (size_t)g->blocks[1] + (size_t)b[1]) * (size_t)g->blocks[0] + (size_t)b[0]);
    }
    g->box = lo0 <= hi0 ? (struct node_box){.lo = {lo0, lo1, lo2}, .hi = {hi0 + last, hi1 + last, hi2 + last}}
                        : (struct node_box){.lo = {0, 0, 0}, .hi = {-1, -1, -1}}; /* no active point: empty */
    sort_by_block(g, p);
    count_colour_points(g);
}

/* Point q's stress less its bulk viscosity (xx, yy, zz, yz, xz, xy) and its external force (the absorbing
 * boundary's dashpot, Eqs. 3.45-3.46, and spring where on): what particle-to-grid spreads over its nodes with
 * Eqs. 3.25-3.26. */
static inline void point_force_terms(const struct mpm_solver *s, size_t q, double sig[6], double fext[3])
{
    const struct mpm_point_state *ps = &s->points.state[q];
    double qv = ps->viscosity;
    for (int k = 0; k < 6; k++)
        sig[k] = k < 3 ? ps->stress[k] - qv : ps->stress[k];
    fext[0] = fext[1] = fext[2] = 0.0;
    if (s->points.flags[q] & (POINT_BOTTOM | POINT_SIDE))
        boundary_force(s, q, fext);
}

/* transfer = apic (Jiang et al. 2015, Section 5): a point adds m_p N_I (v_p + C_p (x_I - x_p)) to node I's momentum,
 * which reproduces an affine velocity field at the nodes exactly.  The columns of m_p C_p in lanes, so that the
 * affine term is col0 dx_0 + col1 dx_1 + col2 dx_2 as a vector. */
static inline void affine_columns(const struct mpm_points *p, size_t q, double m, vec3pad col[3])
{
    const double *C = p->affine + 9 * q;
    for (int j = 0; j < 3; j++)
        col[j] = (vec3pad){m * C[j], m * C[3 + j], m * C[6 + j], m * C[6 + j]};
}

/* The offsets x_I - x_p of a stencil's nodes per direction: -f h and (1 - f) h for trilinear weights (width 2,
 * f = w[d][1]), from the base node for uGIMP. */
STENCIL_INLINE void stencil_offsets(const struct mpm_grid *g, const double x[3], const struct stencil *st, int width,
                                    double dx[3][3])
{
    for (int d = 0; d < 3; d++)
        for (int a = 0; a < width; a++)
            dx[d][a] = width == 2 ? (a == 0 ? -st->w[d][1] * g->h : st->w[d][0] * g->h)
                                  : g->origin[d] + (double)(st->base[d] + a) * g->h - x[d];
}

/* Steps 1-2: mass (Eq. 3.23), momentum (3.24), internal (3.25) and external (3.26) force, the volume gradient
 * for the contact normals (Section 3.5.4) and the bond sums of Eq. 4.6, for one point; apic (a literal 0 or 1 of
 * the caller, so that FLIP's copy has no trace of it) adds the affine momentum. */
STENCIL_INLINE void scatter_all_width(struct mpm_solver *s, size_t q, const struct stencil *stencil, int width,
                                      int apic)
{
    struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    const struct stencil *st = stencil; /* the caller's local, read in place (mpm_impl.h) */
    double V = p->volume[q], m = p->mass[q], sig[6], fext[3];
    const double *v = p->v + 3 * q;
    point_force_terms(s, q, sig, fext);
    double sxx = sig[0], syy = sig[1], szz = sig[2], syz = sig[3], sxz = sig[4], sxy = sig[5];
    int surface = (p->flags[q] & POINT_SURFACE) != 0, moments = g->moments;
    double dbond = p->d_bond[q];
    const double *x = p->x + 3 * q;
    vec3pad mx = {m * x[0], m * x[1], m * x[2], 0.0};
    /* m v_i N is evaluated (m v_i) N: the products hoisted give the same bits, and the stores below may alias v.
     * Vectors x, y, z in lanes (mpm_impl.h) with each lane's operations those of the scalar code: the force's
     * row i is -V (col0_i dN_0 + col1_i dN_1 + col2_i dN_2) + N fext_i, summed left to right. */
    vec3pad mv = {m * v[0], m * v[1], m * v[2], 0.0}, fextv = {fext[0], fext[1], fext[2], fext[2]};
    vec3pad col0 = {sxx, sxy, sxz, sxz}, col1 = {sxy, syy, syz, syz}, col2 = {sxz, syz, szz, szz};
    size_t layer = (size_t)p->body[q] * g->nodes;
    vec3pad mC[3];
    double dx[3][3];
    if (apic) {
        affine_columns(p, q, m, mC);
        stencil_offsets(g, x, st, width, dx);
    }
    for (int c = 0; c < width; c++)
        for (int b = 0; b < width; b++)
            for (int a = 0; a < width; a++) {
                double wyz = st->w[1][b] * st->w[2][c];
                double N = st->w[0][a] * wyz;
                /* a node with N = 0 and dN_0 = 0 adds nothing (uGIMP); a trilinear stencil (width 2, the
                 * literal of the inlined copy) has g = +-1/h, never 0, so the test is left out there */
                if (width != 2 && N == 0.0 && st->g[0][a] == 0.0)
                    continue;
                double dN0 = st->g[0][a] * wyz, dN1 = st->w[0][a] * st->g[1][b] * st->w[2][c];
                double dN2 = st->w[0][a] * st->w[1][b] * st->g[2][c];
                vec3pad dN = {dN0, dN1, dN2, dN2};
                size_t I = layer + stencil_node(g, st, a, b, c);
                g->mass[I] += m * N;
                vec3pad momentum = mv * N, gradient = V * dN;
                if (apic)
                    momentum = (mv + ((mC[0] * dx[0][a] + mC[1] * dx[1][b]) + mC[2] * dx[2][c])) * N;
                vec3pad force = -V * ((col0 * dN0 + col1 * dN1) + col2 * dN2) + N * fextv;
                node_add(g->momentum, I, &momentum);
                node_add(g->force, I, &force);
                node_add(g->gradient, I, &gradient);
                if (moments) {
                    vec3pad moment = mx * N;
                    node_add(g->moment, I, &moment);
                }
                if (surface) {
                    g->bond_sum[I] += dbond * N;
                    g->bond_weight[I] += N;
                }
            }
}

static void scatter_all(struct mpm_solver *s, size_t q)
{
    struct stencil st;
    grid_point_stencil(s, q, &st);
    if (st.width == 2)
        scatter_all_width(s, q, &st, 2, 0);
    else
        scatter_all_width(s, q, &st, st.width, 0);
}

/* scatter_all with the affine momentum (transfer = apic): a function of its own, so that FLIP's transfers are
 * compiled (and inlined) as before. */
static void scatter_all_apic(struct mpm_solver *s, size_t q)
{
    struct stencil st;
    grid_point_stencil(s, q, &st);
    if (st.width == 2)
        scatter_all_width(s, q, &st, 2, 1);
    else
        scatter_all_width(s, q, &st, st.width, 1);
}

/* Step 8 (MUSL): the momentum of the updated point velocities, Eq. 3.33, with N^k: the stencil at the step's
 * start positions. */
STENCIL_INLINE void scatter_momentum_width(struct mpm_solver *s, size_t q, const struct stencil *stencil, int width,
                                           int apic)
{
    struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    const struct stencil *st = stencil; /* the caller's local, read in place (mpm_impl.h) */
    double m = p->mass[q];
    const double *v = p->v + 3 * q;
    vec3pad mv = {m * v[0], m * v[1], m * v[2], 0.0}; /* (m v_i) N as before, in lanes (mpm_impl.h) */
    size_t layer = (size_t)p->body[q] * g->nodes;
    vec3pad mC[3];
    double dx[3][3];
    if (apic) { /* the new C_p about the step's start position, the stencil's */
        affine_columns(p, q, m, mC);
        stencil_offsets(g, p->x + 3 * q, st, width, dx);
    }
    for (int c = 0; c < width; c++)
        for (int b = 0; b < width; b++)
            for (int a = 0; a < width; a++) {
                double N = st->w[0][a] * st->w[1][b] * st->w[2][c];
                /* uGIMP skips its many N = 0 nodes; a trilinear stencil (width 2) has them only for a point on a
                 * node plane, where adding (m v) 0 = +-0 leaves the sum's bits as they are (a sum that starts at
                 * +0 is never -0) for a finite m v: no test, a straight loop */
                if (width != 2 && N == 0.0)
                    continue;
                vec3pad momentum = mv * N;
                if (apic)
                    momentum = (mv + ((mC[0] * dx[0][a] + mC[1] * dx[1][b]) + mC[2] * dx[2][c])) * N;
                node_add(g->momentum_new, stencil_node(g, st, a, b, c) + layer, &momentum);
            }
}

static void scatter_momentum(struct mpm_solver *s, size_t q)
{
    struct stencil st;
    grid_point_stencil(s, q, &st);
    if (st.width == 2)
        scatter_momentum_width(s, q, &st, 2, 0);
    else
        scatter_momentum_width(s, q, &st, st.width, 0);
}

static void scatter_momentum_apic(struct mpm_solver *s, size_t q)
{
    struct stencil st;
    grid_point_stencil(s, q, &st);
    if (st.width == 2)
        scatter_momentum_width(s, q, &st, 2, 1);
    else
        scatter_momentum_width(s, q, &st, st.width, 1);
}

/* Points are visited in block order, and stored in that order only as of the last mpm_points_reorder: fetch the
 * state, velocity and stencil of the point PREFETCH_AHEAD places ahead (a cache miss on the 120-byte state was
 * the largest stall of the transfer; about 5 % of the step, measured on the 1.5/0.5 impact). */
#define PREFETCH_AHEAD 8

static void prefetch_point(const struct mpm_solver *s, size_t q)
{
    const char *state = (const char *)&s->points.state[q];
    __builtin_prefetch(state);
    __builtin_prefetch(state + 64);
    __builtin_prefetch(s->points.v + 3 * q);
    __builtin_prefetch(s->grid.point_fraction + 3 * q);
}

/* ---- Steps 1-2 for trilinear stencils, in runs of points ----
 * Consecutive points of a block that lie in the same cell (a lattice row of the body crossing it: about
 * DCell / dp points, 3 on the benchmark) add to the same 8 nodes.  A run of them adds into the 8 nodes' sums
 * held in vector lanes, node a + 2b + 4c of the stencil in lane a + 2b + 4c: the sums are read once before the
 * run and written once after it, instead of once per point, and the 8 nodes of a point take one vector
 * operation where they took eight.  Each lane does scatter_all_width's operations for its node in the same
 * order, on the sum it would have read from memory (C17 mode: no contraction into FMA): the same bits.
 * Only with AVX-512: the 12 sums of 8 lanes then stay in its 32 vector registers, and the lane shuffles are
 * single instructions.  With AVX2 (x86-64-v3) they spilled and the shuffles went through memory: the 4 ns
 * impact took 8 s instead of 4; those builds transfer point by point (scatter_all).  TRILINEAR_RUNS, lanes8,
 * lanes_load and run_key: mpm_impl.h. */

/* The sums of the fields particle-to-grid adds to, lane n for node n of the stencil. */
struct stencil_sums {
    lanes8 mass, momentum[3], force[3], gradient[3], moment[3], bond_sum, bond_weight;
};

/* Lane shuffles of two 8-lane vectors, indices 8-15 picking from the second (gcc's and clang's builtins). */
#if defined(__clang__)
#define LANES_SHUFFLE(a, b, ...) __builtin_shufflevector(a, b, __VA_ARGS__)
#else
typedef long long lanes8_index __attribute__((vector_size(8 * sizeof(long long))));
#define LANES_SHUFFLE(a, b, ...) __builtin_shuffle(a, b, (lanes8_index){__VA_ARGS__})
#endif

/* The 8 nodes are 4 pairs of x neighbours, pair p = b + 2c at node pair[p] (lanes 2p and 2p + 1): a pair's
 * doubles are contiguous in every field.  Vectors go by pointer (a vector passed by value has another ABI with
 * AVX than without, mpm_impl.h). */

static inline void lanes_store(double *f, const size_t pair[4], const lanes8 *v)
{
    for (int p = 0; p < 4; p++)
        f[pair[p]] = (*v)[2 * p], f[pair[p] + 1] = (*v)[2 * p + 1];
}

/* A field with 3 doubles per node into its x, y and z lanes: each pair read as 8 doubles (its 6 and the x and y
 * of the next node, which exists: a stencil ends at least one node before the grid's last) and transposed. */
static inline void lanes_load3(lanes8 xyz[3], const double *f, const size_t pair[4])
{
    lanes8 q[4];
    for (int p = 0; p < 4; p++)
        memcpy(&q[p], f + 3 * pair[p], sizeof q[p]);
    lanes8 xy01 = LANES_SHUFFLE(q[0], q[1], 0, 3, 8, 11, 1, 4, 9, 12);
    lanes8 xy23 = LANES_SHUFFLE(q[2], q[3], 0, 3, 8, 11, 1, 4, 9, 12);
    lanes8 z01 = LANES_SHUFFLE(q[0], q[1], 2, 5, 10, 13, 2, 5, 10, 13);
    lanes8 z23 = LANES_SHUFFLE(q[2], q[3], 2, 5, 10, 13, 2, 5, 10, 13);
    xyz[0] = LANES_SHUFFLE(xy01, xy23, 0, 1, 2, 3, 8, 9, 10, 11);
    xyz[1] = LANES_SHUFFLE(xy01, xy23, 4, 5, 6, 7, 12, 13, 14, 15);
    xyz[2] = LANES_SHUFFLE(z01, z23, 0, 1, 2, 3, 8, 9, 10, 11);
}

/* The x, y and z lanes back into the field, 6 doubles a pair. */
static inline void lanes_store3(double *f, const size_t pair[4], const lanes8 xyz[3])
{
    lanes8 xy01 = LANES_SHUFFLE(xyz[0], xyz[1], 0, 8, 1, 9, 2, 10, 3, 11);
    lanes8 xy23 = LANES_SHUFFLE(xyz[0], xyz[1], 4, 12, 5, 13, 6, 14, 7, 15);
    lanes8 q[4] = {LANES_SHUFFLE(xy01, xyz[2], 0, 1, 8, 2, 3, 9, 9, 9),
                   LANES_SHUFFLE(xy01, xyz[2], 4, 5, 10, 6, 7, 11, 11, 11),
                   LANES_SHUFFLE(xy23, xyz[2], 0, 1, 12, 2, 3, 13, 13, 13),
                   LANES_SHUFFLE(xy23, xyz[2], 4, 5, 14, 6, 7, 15, 15, 15)}; /* lanes 6 and 7 not stored */
    for (int p = 0; p < 4; p++)
        memcpy(f + 3 * pair[p], &q[p], 6 * sizeof(double));
}

/* The nodal sums of the run's stencil; the bond sums only where a point of the run is a surface point. */
static inline void sums_load(const struct mpm_grid *g, const size_t pair[4], int bonds, struct stencil_sums *sum)
{
    lanes_load(&sum->mass, g->mass, pair);
    lanes_load3(sum->momentum, g->momentum, pair);
    lanes_load3(sum->force, g->force, pair);
    lanes_load3(sum->gradient, g->gradient, pair);
    lanes8 zero = {0};
    sum->moment[0] = sum->moment[1] = sum->moment[2] = zero;
    if (g->moments)
        lanes_load3(sum->moment, g->moment, pair);
    sum->bond_sum = sum->bond_weight = zero;
    if (bonds) {
        lanes_load(&sum->bond_sum, g->bond_sum, pair);
        lanes_load(&sum->bond_weight, g->bond_weight, pair);
    }
}

static inline void sums_store(struct mpm_grid *g, const size_t pair[4], int bonds, const struct stencil_sums *sum)
{
    lanes_store(g->mass, pair, &sum->mass);
    lanes_store3(g->momentum, pair, sum->momentum);
    lanes_store3(g->force, pair, sum->force);
    lanes_store3(g->gradient, pair, sum->gradient);
    if (g->moments)
        lanes_store3(g->moment, pair, sum->moment);
    if (bonds) {
        lanes_store(g->bond_sum, pair, &sum->bond_sum);
        lanes_store(g->bond_weight, pair, &sum->bond_weight);
    }
}

/* Point q's terms of Eqs. 3.23-3.26, the volume gradient and the bond sums, added to the 8 lanes: per lane the
 * operations of scatter_all_width (width 2), with the weights of grid_point_stencil (1 - f and f, -1/h and 1/h). */
static inline void run_point_add(const struct mpm_solver *s, size_t q, struct stencil_sums *sum)
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    double V = p->volume[q], m = p->mass[q], sig[6], fext[3];
    const double *v = p->v + 3 * q;
    point_force_terms(s, q, sig, fext);
    double sxx = sig[0], syy = sig[1], szz = sig[2], syz = sig[3], sxz = sig[4], sxy = sig[5];
    double h = g->inv_h;
    lanes8 w[3];
    run_weights(g, q, w);
    lanes8 w0 = w[0], w1 = w[1], w2 = w[2];
    lanes8 g0 = {-h, h, -h, h, -h, h, -h, h}, g1 = {-h, -h, h, h, -h, -h, h, h};
    lanes8 g2 = {-h, -h, -h, -h, h, h, h, h};
    lanes8 wyz = w1 * w2, N = w0 * wyz, dN0 = g0 * wyz, dN1 = w0 * g1 * w2, dN2 = w0 * w1 * g2;
    sum->mass += m * N;
    for (int i = 0; i < 3; i++)
        sum->momentum[i] += m * v[i] * N;
    sum->gradient[0] += V * dN0;
    sum->gradient[1] += V * dN1;
    sum->gradient[2] += V * dN2;
    if (g->moments)
        for (int i = 0; i < 3; i++)
            sum->moment[i] += m * p->x[3 * q + i] * N;
    /* row i: -V (col0_i dN_0 + col1_i dN_1 + col2_i dN_2) + N fext_i, the columns of scatter_all_width */
    sum->force[0] += -V * ((sxx * dN0 + sxy * dN1) + sxz * dN2) + N * fext[0];
    sum->force[1] += -V * ((sxy * dN0 + syy * dN1) + syz * dN2) + N * fext[1];
    sum->force[2] += -V * ((sxz * dN0 + syz * dN1) + szz * dN2) + N * fext[2];
    if (p->flags[q] & POINT_SURFACE) {
        sum->bond_sum += p->d_bond[q] * N;
        sum->bond_weight += N;
    }
}

/* Particle-to-grid of the points block_points[k .. end) of one block, trilinear, run by run. */
static void scatter_all_runs(struct mpm_solver *s, size_t k, size_t end)
{
    struct mpm_grid *g = &s->grid;
    const size_t *points = g->block_points;
    while (k < end) {
        size_t key = run_key(s, points[k]), run_end = k + 1;
        int bonds = (s->points.flags[points[k]] & POINT_SURFACE) != 0;
        for (; run_end < end && run_key(s, points[run_end]) == key; run_end++)
            bonds |= (s->points.flags[points[run_end]] & POINT_SURFACE) != 0;
        size_t pair[4] = {key, key + g->row, key + g->plane, key + g->row + g->plane};
        struct stencil_sums sum;
        sums_load(g, pair, bonds, &sum);
        for (; k < run_end; k++) {
            if (k + PREFETCH_AHEAD < end)
                prefetch_point(s, points[k + PREFETCH_AHEAD]);
            run_point_add(s, points[k], &sum);
        }
        sums_store(g, pair, bonds, &sum);
    }
}

/* Step 8 for point q in a run: scatter_momentum_width's (m v_i) N per lane, N = w_0 w_1 w_2 in its order. */
static inline void run_point_momentum(const struct mpm_solver *s, size_t q, lanes8 sum[3])
{
    const struct mpm_points *p = &s->points;
    const double *v = p->v + 3 * q;
    double m = p->mass[q];
    lanes8 w[3];
    run_weights(&s->grid, q, w);
    lanes8 N = w[0] * w[1] * w[2];
    for (int i = 0; i < 3; i++)
        sum[i] += m * v[i] * N;
}

/* The MUSL re-projection of the points block_points[k .. end) of one block, trilinear, run by run (the runs of
 * scatter_all_runs: the stencils have not moved). */
static void scatter_momentum_runs(struct mpm_solver *s, size_t k, size_t end)
{
    struct mpm_grid *g = &s->grid;
    const size_t *points = g->block_points;
    while (k < end) {
        size_t key = run_key(s, points[k]), run_end = k + 1;
        while (run_end < end && run_key(s, points[run_end]) == key)
            run_end++;
        size_t pair[4] = {key, key + g->row, key + g->plane, key + g->row + g->plane};
        lanes8 sum[3];
        lanes_load3(sum, g->momentum_new, pair);
        for (; k < run_end; k++) {
            if (k + PREFETCH_AHEAD < end)
                prefetch_point(s, points[k + PREFETCH_AHEAD]);
            run_point_momentum(s, points[k], sum);
        }
        lanes_store3(g->momentum_new, pair, sum);
    }
}

enum transfer { TRANSFER_ALL, TRANSFER_MOMENTUM };

/* The points of one block in order, transfer = apic (no runs: the affine term differs from point to point). */
static void scatter_block_apic(struct mpm_solver *s, size_t block, enum transfer transfer)
{
    const struct mpm_grid *g = &s->grid;
    size_t end = g->block_start[block + 1];
    for (size_t k = g->block_start[block]; k < end; k++) {
        if (k + PREFETCH_AHEAD < end)
            prefetch_point(s, g->block_points[k + PREFETCH_AHEAD]);
        if (transfer == TRANSFER_ALL)
            scatter_all_apic(s, g->block_points[k]);
        else
            scatter_momentum_apic(s, g->block_points[k]);
    }
}

/* The points of one block in order; the transfer is chosen by value, not through a function pointer, so that
 * both scatters are direct calls the compiler can inline. */
static void scatter_block(struct mpm_solver *s, size_t block, enum transfer transfer)
{
    const struct mpm_grid *g = &s->grid;
    size_t end = g->block_start[block + 1];
    if (s->points.affine) { /* transfer = apic: point by point */
        scatter_block_apic(s, block, transfer);
        return;
    }
    if (TRILINEAR_RUNS && s->cfg.shape_function == MPM_LINEAR) {
        if (transfer == TRANSFER_ALL)
            scatter_all_runs(s, g->block_start[block], end);
        else
            scatter_momentum_runs(s, g->block_start[block], end);
        return;
    }
    for (size_t k = g->block_start[block]; k < end; k++) {
        if (k + PREFETCH_AHEAD < end)
            prefetch_point(s, g->block_points[k + PREFETCH_AHEAD]);
        if (transfer == TRANSFER_ALL)
            scatter_all(s, g->block_points[k]);
        else
            scatter_momentum(s, g->block_points[k]);
    }
}

/* The first of the ascending `count` values at or above `value`. */
static size_t lower_bound(const size_t *values, size_t count, size_t value)
{
    size_t lo = 0, hi = count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (values[mid] < value)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* The blocks of one colour write disjoint nodes and run in parallel, each thread a contiguous share of them
 * holding a share of the colour's points balanced by the threads' speeds (points per second) in the last steps
 * (core/balance.h): a thread scatters nearly the same points to nearly the same nodes from step to step.  The
 * shares are counted in points, not blocks: the blocks of the grid's margins are empty and those of a particle
 * full, and shares of equal blocks had left one thread most of the points. */
static void for_each_point_by_colour(struct mpm_solver *s, enum transfer transfer)
{
    struct mpm_grid *g = &s->grid;
    int team = omp_get_max_threads();
    for (int colour = 0; colour < 8; colour++) {
        const size_t *blocks = g->colour_blocks[colour], *sum = g->colour_points[colour];
        size_t count = g->colour_count[colour];
        struct balance *balance = &g->colour_balance[transfer == TRANSFER_ALL][colour];
        balance_prepare(balance, team);
#pragma omp parallel num_threads(team)
        {
            size_t first_point, end_point;
            int thread = omp_get_thread_num(), threads = omp_get_num_threads();
            balance_range(balance, thread, threads, sum[count], &first_point, &end_point);
            size_t first = lower_bound(sum, count, first_point);
            size_t end = thread == threads - 1 ? count : lower_bound(sum, count, end_point);
            double start = omp_get_wtime();
            for (size_t i = first; i < end; i++)
                scatter_block(s, blocks[i], transfer);
            balance_record(balance, thread, threads, sum[end] - sum[first], omp_get_wtime() - start);
        }
        balance_update(balance);
    }
}

/* A nodal field (node_bytes per node and layer) set to 0 on the nodes of a box, in every layer, the rows shared
 * among the threads. */
static void clear_box(const struct mpm_grid *g, const struct node_box *box, void *field, size_t node_bytes)
{
    long rows = (long)box_rows(box), all_rows = (long)g->layers * rows;
    size_t length = box_row_length(box);
#pragma omp for schedule(static)
    for (long i = 0; i < all_rows; i++) {
        int k;
        size_t I = (size_t)(i / rows) * g->nodes + box_row_start(g, box, (size_t)(i % rows), &k);
        memset((char *)field + I * node_bytes, 0, length * node_bytes);
    }
}

void mpm_grid_transfer_all(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    /* the fields are 0 outside the last step's box: clearing that box clears the grid, and this step's nodal
     * loops write only inside its own box.  momentum_new and velocity are not cleared: mpm_contact_nodal_update and
     * nodal_velocities write them at every node of the box, in every layer, before anything reads them, and
     * nothing reads them outside it (a sixth of the clearing) */
    const struct node_box *held = &g->held;
#pragma omp parallel
    {
        clear_box(g, held, g->mass, sizeof *g->mass);
        clear_box(g, held, g->momentum, 3 * sizeof *g->momentum);
        clear_box(g, held, g->force, 3 * sizeof *g->force);
        clear_box(g, held, g->gradient, 3 * sizeof *g->gradient);
        if (g->moments)
            clear_box(g, held, g->moment, 3 * sizeof *g->moment);
        clear_box(g, held, g->bond_sum, sizeof *g->bond_sum);
        clear_box(g, held, g->bond_weight, sizeof *g->bond_weight);
        clear_box(g, held, g->contact, sizeof *g->contact);
        if (g->pair_state)
            clear_box(g, held, g->pair_state, sizeof *g->pair_state);
        clear_box(g, held, g->bond_contact, sizeof *g->bond_contact);
        clear_box(g, held, g->wall_held, sizeof *g->wall_held);
    }
    g->held = g->box;
    for_each_point_by_colour(s, TRANSFER_ALL);
}

void mpm_grid_transfer_momentum(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
#pragma omp parallel
    clear_box(g, &g->box, g->momentum_new, 3 * sizeof *g->momentum_new);
    for_each_point_by_colour(s, TRANSFER_MOMENTUM);
}
