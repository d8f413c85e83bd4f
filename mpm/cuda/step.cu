/* The impact step on an NVIDIA GPU in FP64 (make CUDA=1; docs/gpu.md): thesis Section 3.4 steps 1-12 as
 * mpm/solver.c does them, trilinear shape functions, with the points on the device for the whole run.
 *
 *   bin        each active point's stencil base node and fractions (Eq. 3.20), its key body * nodes + base node
 *   sort       the point indices by key, a stable radix sort (CUB) of the keys in id order: within a cell the
 *              points are in id order
 *   reorder    every REORDER_EVERY steps the points' arrays themselves in that order (cell, then id), so that a
 *              cell's points lie together in memory; no result depends on the storage order (below)
 *   ranges     each cell's run of sorted points
 *   gather     particle-to-grid as a segmented reduction: a thread per node of a body's layer sums, in a fixed
 *              order (the 8 cells whose stencils hold the node, then their points by id), mass, momentum, forces
 *              (Eqs. 3.23-3.27), the volume gradient, the first mass moment and the bond sums (Eq. 4.6); no atomics,
 *              so the same bits run to run
 *   bodies     each body's centre-of-mass velocity (bond_growth = approach), two passes without atomics
 *   nodal      Eq. 3.28, the rigid wall or the fixed bottom, multi-body contact and bonds (contact_node.h
 *              node_update, which contact.c calls at each node of the CPU's grid: a thread per node, its layers in
 *              order)
 *   book       the dashpots' work (mpm_book_absorbed_energy)
 *   g2p        grid-to-points (Eq. 3.32, FLIP/PIC), the escapes and the largest speed
 *   musl       the re-projected momenta (Eq. 3.33, the gather again), corrected as contact.c does (step 8)
 *   update     velocity gradient (Eq. 3.35), volume (Eq. 3.36), the stress update of mpm/stress_point.h (PTW return,
 *              EOS energy update, heating, melt, viscosity) and the bonding increment of mpm/bonding_law.h: the
 *              CPU's own functions, compiled for the device
 *   remove     points that left the grid box
 * Sums over points (removed energy, absorbed work) and the maxima are CUB reductions: a fixed tree for a given
 * size, the same bits run to run.  They differ from the CPU's sums in order (docs/gpu.md, "Bits").  The diagnostics
 * (diagnostics_point.h) are each body's sums over its points, in two passes without atomics, when a series row asks
 * for them: the points come back to the host only for snapshots and checkpoints.
 *
 * The storage order changes no bit: every sum over points runs in id order (the sort's input, the reductions'
 * inputs written at the point's id, the diagnostics read by id), so a run gives the same bits whether its points
 * are reordered every step or never (SPRAYCOAT_GPU_REORDER_EVERY, tests/test_gpu_emulated.sh). */
#define STRESS_LANES 1

#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>

#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mpm/bonding_law.h"
#include "mpm/boundary_point.h"
#include "mpm/contact_node.h"
#include "mpm/gpu.h"
#include "mpm/stress_point.h"

/* ---- errors ---- */

static char gpu_message[512];

static int fail(const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    vsnprintf(gpu_message, sizeof gpu_message, fmt, args);
    va_end(args);
    return -1;
}

#define CU(call)                                                                                                       \
    do {                                                                                                               \
        cudaError_t cu_status = (call);                                                                                \
        if (cu_status != cudaSuccess)                                                                                  \
            return fail("%s: %s (%s:%d)", #call, cudaGetErrorString(cu_status), __FILE__, __LINE__);                   \
    } while (0)

/* ---- the device state ---- */

struct mpm_gpu {
    struct mpm_gpu_setup s; /* its material, constants and body tables (copy_tables) on the device */
    char name[320];
    size_t n, nodes, cells; /* points, nodes of a layer, layer entries (bodies x nodes) */
    size_t row, plane;
    int key_bits;
    int64_t removed_total;
    int host_stale;
    int grid_stepped; /* the grid holds a step's state (contact flags, masses): a step ran since the last upload */
    /* points, in storage order: id order after an upload, by cell after a reordering (reorder_points) */
    double *x, *x_next, *v, *mass, *volume0, *volume, *d_bond, *plastic_work, *normal;
    struct mpm_point_state *state;
    int32_t *body;
    uint8_t *flags;
    uint32_t *id;      /* the id of the point stored at each index */
    uint32_t *slot;    /* the index at which each id is stored */
    void *scratch;     /* a point array's size of the largest (state), for the reordering and the download */
    int reorder_every; /* steps between reorderings, 0 never (SPRAYCOAT_GPU_REORDER_EVERY; REORDER_EVERY) */
    long steps;        /* steps since the open */
    /* binning */
    unsigned long long *key, *key_sorted;
    uint32_t *order, *order_sorted, *cell_start, *cell_end;
    uint32_t *base;   /* stencil base node of each active point */
    double *fraction; /* 3 per point: x/h - base */
    /* the grid, per layer entry (vectors 3 per entry) */
    double *gmass, *momentum, *momentum_new, *force, *gradient, *moment, *bond_sum, *bond_weight, *velocity;
    uint8_t *contact, *bond_contact, *wall_held;
    uint64_t *pair_state; /* each pair's state, with 3 to PAIR_STATE_LAYERS bodies (contact_node.h); NULL otherwise */
    double *body_partial;  /* BODY_BLOCKS x 4 per body: partial sums of mass and momentum (body_partial_kernel) */
    double *body_velocity; /* 3 per body: its centre-of-mass velocity this step (contact.c body_velocities) */
    struct point_sums *sums_partial;   /* BODY_BLOCKS per body: the diagnostics' partial sums (diagnostics_kernel) */
    struct point_sums *sums;           /* per body: the diagnostics' sums (diagnostics_body_kernel) */
    struct contact_nodes contact_grid; /* the grid's arrays above as contact_node.h reads them (set_contact_nodes) */
    /* reductions: per point or per node inputs, and the results.  The inputs of sums are written at the points' ids
     * (point_a in book_kernel, point_b, point_c, point_count: summed in id order); those of maxima and minima, and
     * point_a as the heat of heat_kernel for heat_apply_kernel, at the points' places */
    double *point_a, *point_b, *point_c;
    long long *point_id, *point_id2;
    int *point_count, *node_contacts, *node_bonds;
    double *result;       /* 5: vmax2, absorbed, removed mass, removed energy, spare */
    long long *result_id; /* 2: nonfinite, failed */
    int *result_int;      /* 3: removed, contacts, bonds */
    void *temp;
    size_t temp_bytes;
};

/* ---- device helpers ---- */

#define THREADS 256
/* Steps between two reorderings of the points' storage by cell (the CPU's REORDER_EVERY of solver.c): a cell's
 * points drift into the next cells slowly, and a reordering costs about one pass over the points' arrays. */
#define REORDER_EVERY 16
static unsigned blocks_for(size_t count)
{
    return (unsigned)((count + THREADS - 1) / THREADS);
}

/* grid_contains of mpm_impl.h (boundary_point.h grid_interior). */
__device__ static int contains(const struct mpm_gpu_setup *s, const double x[3])
{
    return grid_interior(s->origin, s->inside_from, s->inside_to, x);
}

/* boundary_dashpot_force of mpm_impl.h (Eqs. 3.45-3.46, a = b = 1; boundary_point.h boundary_face_force). */
__device__ static void dashpot_force(const struct mpm_gpu *g, size_t q, double f[3])
{
    const double *coef = g->s.body_dashpot + 2 * g->body[q];
    f[0] = f[1] = f[2] = 0.0;
    boundary_face_force(g->flags[q] & GPU_POINT_BOTTOM, g->flags[q] & GPU_POINT_SIDE, g->normal + 3 * q, g->v + 3 * q,
                        coef, coef, f);
}

/* The trilinear weights and derivatives of point q: w[d][0] = 1 - f, w[d][1] = f, g = -+1/h (grid_point_stencil). */
__device__ static void point_weights(const struct mpm_gpu *g, size_t q, double w[3][2], double dw[3][2])
{
    for (int d = 0; d < 3; d++) {
        double f = g->fraction[3 * q + d];
        w[d][0] = 1.0 - f, w[d][1] = f;
        dw[d][0] = -g->s.inv_h, dw[d][1] = g->s.inv_h;
    }
}

/* ---- bin, sort, ranges ---- */

/* linear_cell of grid.c: base = floor((x - origin) / h), fraction the rest; inactive points sort last.  The keys and
 * the point indices go to the sort at the points' ids. */
__global__ static void bin_kernel(struct mpm_gpu g)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    size_t i = g.id[q]; /* the sort's input in id order: its stable sort keeps a cell's points by id */
    g.order[i] = (uint32_t)q;
    g.key[i] = g.cells;
    if (!(g.flags[q] & GPU_POINT_ACTIVE))
        return;
    int base[3];
    for (int d = 0; d < 3; d++) {
        double xi = (g.x[3 * q + d] - g.s.origin[d]) / g.s.h;
        double cell = floor(xi);
        g.fraction[3 * q + d] = xi - cell;
        base[d] = (int)cell;
    }
    size_t node = (size_t)base[0] + g.row * (size_t)base[1] + g.plane * (size_t)base[2];
    g.base[q] = (uint32_t)node;
    g.key[i] = (unsigned long long)g.body[q] * g.nodes + node;
}

__global__ static void range_kernel(struct mpm_gpu g)
{
    size_t i = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (i >= g.n)
        return;
    unsigned long long k = g.key_sorted[i];
    if (k >= g.cells)
        return;
    if (i == 0 || g.key_sorted[i - 1] != k)
        g.cell_start[k] = (uint32_t)i;
    if (i + 1 == g.n || g.key_sorted[i + 1] != k)
        g.cell_end[k] = (uint32_t)(i + 1);
}

/* ---- particle-to-grid as a gather ---- */

/* Node I = layer entry (layer, node): the cells whose stencils hold it are node - a - b row - c plane, a, b, c in
 * {0, 1}; their points add with the weights of stencil node (a, b, c), as scatter_all_width does. */
__global__ static void gather_kernel(struct mpm_gpu g, int momentum_only)
{
    size_t I = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (I >= g.cells)
        return;
    size_t layer = I / g.nodes, node = I % g.nodes;
    int idx[3] = {(int)(node % g.row), (int)((node / g.row) % (size_t)g.s.n[1]), (int)(node / g.plane)};
    double mass = 0.0, mom[3] = {0, 0, 0}, force[3] = {0, 0, 0}, grad[3] = {0, 0, 0}, moment[3] = {0, 0, 0};
    double bond_sum = 0.0, bond_weight = 0.0;
    for (int c = 0; c < 2; c++)
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++) {
                if (idx[0] < a || idx[1] < b || idx[2] < c)
                    continue;
                size_t cell = layer * g.nodes + node - (size_t)a - (size_t)b * g.row - (size_t)c * g.plane;
                uint32_t end = g.cell_end[cell];
                for (uint32_t k = g.cell_start[cell]; k < end; k++) {
                    size_t q = g.order_sorted[k];
                    double w[3][2], dw[3][2];
                    point_weights(&g, q, w, dw);
                    double m = g.mass[q];
                    const double *v = g.v + 3 * q;
                    double wyz = w[1][b] * w[2][c], N = w[0][a] * wyz;
                    if (momentum_only) { /* step 8: (m v_i) N */
                        for (int d = 0; d < 3; d++)
                            mom[d] += (m * v[d]) * N;
                        continue;
                    }
                    double V = g.volume[q], sig[6], fext[3];
                    const struct mpm_point_state *ps = &g.state[q];
                    for (int e = 0; e < 6; e++)
                        sig[e] = e < 3 ? ps->stress[e] - ps->viscosity : ps->stress[e];
                    fext[0] = fext[1] = fext[2] = 0.0;
                    if (g.flags[q] & (GPU_POINT_BOTTOM | GPU_POINT_SIDE))
                        dashpot_force(&g, q, fext);
                    double dN[3] = {dw[0][a] * wyz, w[0][a] * dw[1][b] * w[2][c], w[0][a] * w[1][b] * dw[2][c]};
                    double col0[3] = {sig[0], sig[5], sig[4]}, col1[3] = {sig[5], sig[1], sig[3]};
                    double col2[3] = {sig[4], sig[3], sig[2]};
                    mass += m * N;
                    for (int d = 0; d < 3; d++) {
                        mom[d] += (m * v[d]) * N;
                        force[d] += -V * ((col0[d] * dN[0] + col1[d] * dN[1]) + col2[d] * dN[2]) + N * fext[d];
                        grad[d] += V * dN[d];
                        moment[d] += (m * g.x[3 * q + d]) * N;
                    }
                    if (g.flags[q] & GPU_POINT_SURFACE) {
                        bond_sum += g.d_bond[q] * N;
                        bond_weight += N;
                    }
                }
            }
    if (momentum_only) {
        for (int d = 0; d < 3; d++)
            g.momentum_new[3 * I + d] = mom[d];
        return;
    }
    g.gmass[I] = mass;
    for (int d = 0; d < 3; d++) {
        g.momentum[3 * I + d] = mom[d];
        g.force[3 * I + d] = force[d];
        g.gradient[3 * I + d] = grad[d];
        g.moment[3 * I + d] = g.s.moments ? moment[d] : 0.0;
    }
    g.bond_sum[I] = bond_sum;
    g.bond_weight[I] = bond_weight;
    g.contact[I] = 0;
    g.bond_contact[I] = 0;
    if (g.pair_state)
        g.pair_state[I] = 0;
}

/* ---- the nodal update and contact: contact_node.h, the CPU's functions, a thread per node ---- */

/* Each body's centre of mass velocity (contact.c body_velocities), in two passes without atomics, so the same bits
 * run to run: BODY_BLOCKS blocks per body each sum a fixed stride of the layer's nodes and reduce them in a fixed
 * tree; then a thread per body adds the blocks' sums in order. */
#define BODY_BLOCKS 64
__global__ static void body_partial_kernel(struct mpm_gpu g)
{
    __shared__ double sum[4][THREADS];
    size_t layer = (size_t)blockIdx.y * g.nodes;
    double local[4] = {0.0, 0.0, 0.0, 0.0};
    for (size_t node = blockIdx.x * (size_t)THREADS + threadIdx.x; node < g.nodes;
         node += (size_t)BODY_BLOCKS * THREADS) {
        size_t I = layer + node;
        local[0] += g.gmass[I];
        for (int d = 0; d < 3; d++)
            local[1 + d] += g.momentum[3 * I + d];
    }
    for (int c = 0; c < 4; c++)
        sum[c][threadIdx.x] = local[c];
    __syncthreads();
    for (int half = THREADS / 2; half > 0; half /= 2) {
        if ((int)threadIdx.x < half)
            for (int c = 0; c < 4; c++)
                sum[c][threadIdx.x] += sum[c][threadIdx.x + half];
        __syncthreads();
    }
    if (threadIdx.x == 0)
        for (int c = 0; c < 4; c++)
            g.body_partial[4 * ((size_t)blockIdx.y * BODY_BLOCKS + blockIdx.x) + c] = sum[c][0];
}

__global__ static void body_velocity_kernel(struct mpm_gpu g)
{
    int body = blockIdx.x * blockDim.x + threadIdx.x;
    if (body >= g.s.bodies)
        return;
    double total[4] = {0.0, 0.0, 0.0, 0.0};
    for (int block = 0; block < BODY_BLOCKS; block++)
        for (int c = 0; c < 4; c++)
            total[c] += g.body_partial[4 * ((size_t)body * BODY_BLOCKS + block) + c];
    for (int d = 0; d < 3; d++) /* the whole body's: none across a mirror plane */
        g.body_velocity[3 * body + d] = total[0] > 0.0 && !(d < 2 && g.s.mirror[d]) ? total[1 + d] / total[0] : 0.0;
}

/* Steps 3-6 at each node (contact_node.h node_update, as contact.c's mpm_contact_nodal_update). */
__global__ static void nodal_kernel(struct mpm_gpu g, double dt)
{
    size_t node = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (node >= g.nodes)
        return;
    int bonded;
    int touched = node_update(&g.contact_grid, node, (int)(node / g.plane), dt, &bonded);
    g.node_contacts[node] = touched;
    g.node_bonds[node] = touched && bonded;
}

/* Step 8's correction of the re-projected momenta (contact_node.h node_correct). */
__global__ static void correct_kernel(struct mpm_gpu g)
{
    size_t node = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (node < g.nodes)
        node_correct(&g.contact_grid, node, (int)(node / g.plane), g.momentum_new);
}

/* The re-projected nodal velocities (Eq. 3.34) and the contact flags of heavy nodes (nodal_velocities). */
__global__ static void velocity_kernel(struct mpm_gpu g)
{
    size_t I = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (I >= g.cells)
        return;
    int h = heavy_entry(&g.contact_grid, I);
    for (int d = 0; d < 3; d++)
        g.velocity[3 * I + d] = h ? g.momentum_new[3 * I + d] / g.gmass[I] : 0.0;
    g.contact[I] = h ? g.contact[I] : 0;
    if (g.pair_state)
        g.pair_state[I] = h ? g.pair_state[I] : 0;
}

/* diagnostics.c smooth_velocity: the last step's re-projected nodal velocities of the point's body (velocity_kernel)
 * interpolated to its position now over its heavy nodes, normalised by their weights (mpm_grid_stencil's trilinear
 * weights, the same operations); its own velocity where it has none: before the first step (after an upload), with
 * its stencil outside the grid's interior, or without a heavy node. */
__device__ static void grid_velocity_at_point(const struct mpm_gpu *g, size_t q, double v[3])
{
    const double *x = g->x + 3 * q;
    double sum[3] = {0.0, 0.0, 0.0}, weight = 0.0, w[3][2];
    int base[3], inside = g->grid_stepped;
    for (int d = 0; d < 3 && inside; d++) {
        double xi = (x[d] - g->s.origin[d]) / g->s.h;
        inside = xi > 1.0 && xi < (double)g->s.n[d] - 2.0;
        double cell = floor(xi), f = xi - cell;
        base[d] = inside ? (int)cell : 0;
        w[d][0] = 1.0 - f, w[d][1] = f;
    }
    if (inside) {
        size_t first =
            (size_t)g->body[q] * g->nodes + (size_t)base[0] + g->row * (size_t)base[1] + g->plane * (size_t)base[2];
        for (int c = 0; c < 2; c++)
            for (int b = 0; b < 2; b++)
                for (int a = 0; a < 2; a++) {
                    double N = w[0][a] * w[1][b] * w[2][c];
                    size_t I = first + (size_t)a + (size_t)b * g->row + (size_t)c * g->plane;
                    if (N == 0.0 || !heavy_entry(&g->contact_grid, I))
                        continue;
                    weight += N;
                    for (int d = 0; d < 3; d++)
                        sum[d] += N * g->velocity[3 * I + d];
                }
    }
    for (int d = 0; d < 3; d++)
        v[d] = weight > 0.0 ? sum[d] / weight : g->v[3 * q + d];
}

/* Each body's diagnostics (diagnostics.c body_sums), as body_partial_kernel sums the bodies' momenta: BODY_BLOCKS
 * blocks per body each add a fixed stride of the points' ids (those of the body that are active), then reduce their
 * threads' sums in a fixed tree; a thread per body adds the blocks' sums in order. */
__global__ static void diagnostics_kernel(struct mpm_gpu g, struct point_fields fields)
{
    __shared__ struct point_sums sum[THREADS];
    struct point_sums local;
    memset(&local, 0, sizeof local);
    int body = (int)blockIdx.y;
    for (size_t i = blockIdx.x * (size_t)THREADS + threadIdx.x; i < g.n; i += (size_t)BODY_BLOCKS * THREADS) {
        size_t q = g.slot[i]; /* by id */
        if (g.body[q] != body || !(g.flags[q] & GPU_POINT_ACTIVE))
            continue;
        double v[3];
        grid_velocity_at_point(&g, q, v);
        point_sums_add(&local, &fields, q, v);
    }
    sum[threadIdx.x] = local;
    __syncthreads();
    for (int half = THREADS / 2; half > 0; half /= 2) {
        if ((int)threadIdx.x < half)
            point_sums_merge(&sum[threadIdx.x], &sum[threadIdx.x + half]);
        __syncthreads();
    }
    if (threadIdx.x == 0)
        g.sums_partial[(size_t)body * BODY_BLOCKS + blockIdx.x] = sum[0];
}

__global__ static void diagnostics_body_kernel(struct mpm_gpu g)
{
    int body = blockIdx.x * blockDim.x + threadIdx.x;
    if (body >= g.s.bodies)
        return;
    struct point_sums total;
    memset(&total, 0, sizeof total);
    for (int block = 0; block < BODY_BLOCKS; block++)
        point_sums_merge(&total, &g.sums_partial[(size_t)body * BODY_BLOCKS + block]);
    g.sums[body] = total;
}

/* Body `body`'s interface nodes now (count_interface_pairs of contact.c, after a step): at each node, the other
 * bodies it meets (both heavy, a normal, the pair in contact, bonded or touching: pair_state_recorded), and of those
 * the pairs bonded by Eq. 4.7.  Summed over the nodes by a CUB reduction of integers: the CPU's counts exactly, given
 * the same grid state. */
__global__ static void interface_kernel(struct mpm_gpu g, int body)
{
    size_t node = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (node >= g.nodes)
        return;
    int meets = 0, bonded = 0;
    const struct contact_nodes *c = &g.contact_grid;
    size_t Ia = (size_t)body * g.nodes + node;
    if (heavy_entry(c, Ia) && g.contact[Ia])
        for (int other = 0; other < g.s.bodies; other++) {
            size_t Ib = (size_t)other * g.nodes + node;
            double n[3];
            if (other == body || !heavy_entry(c, Ib) || pair_state_recorded(c, Ia, Ib) == PAIR_FREE ||
                contact_normal(c, Ia, Ib, n) != 0)
                continue;
            meets++;
            bonded += pair_bonded(c, Ia, Ib);
        }
    int copies = mirror_node_copies(c, node); /* the whole set-up's, as count_interface_pairs */
    g.node_contacts[node] = copies * meets;
    g.node_bonds[node] = copies * bonded;
}

/* ---- points ---- */

__device__ static size_t stencil_entry(const struct mpm_gpu *g, size_t q, int a, int b, int c)
{
    return (size_t)g->body[q] * g->nodes + g->base[q] + (size_t)a + (size_t)b * g->row + (size_t)c * g->plane;
}

/* The dashpots' work over the step at the start momenta (mpm_book_absorbed_energy, grid_velocity_at). */
__global__ static void book_kernel(struct mpm_gpu g, double dt)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    size_t id = g.id[q]; /* summed in id order */
    g.point_a[id] = 0.0;
    if (!(g.flags[q] & GPU_POINT_ACTIVE) || !(g.flags[q] & (GPU_POINT_BOTTOM | GPU_POINT_SIDE)))
        return;
    double f[3], w[3][2], dw[3][2], v[3] = {0, 0, 0};
    dashpot_force(&g, q, f);
    point_weights(&g, q, w, dw);
    for (int c = 0; c < 2; c++)
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++) {
                double N = w[0][a] * w[1][b] * w[2][c];
                size_t I = stencil_entry(&g, q, a, b, c);
                if (N == 0.0 || !heavy_entry(&g.contact_grid, I))
                    continue;
                for (int d = 0; d < 3; d++)
                    v[d] += N * g.momentum[3 * I + d] / g.gmass[I];
            }
    g.point_a[id] = (f[0] * v[0] + f[1] * v[1] + f[2] * v[2]) * dt;
}

/* Step 7 (point_from_grid_width, point_velocity_position) and what scan_escapes finds: point_a the squared speed of
 * a point that stays, point_id its id if its position or velocity is not finite. */
__global__ static void g2p_kernel(struct mpm_gpu g, double dt)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    double *x = g.x + 3 * q, *xn = g.x_next + 3 * q, *v = g.v + 3 * q;
    g.point_a[q] = 0.0;
    g.point_id[q] = LLONG_MAX;
    if (!(g.flags[q] & GPU_POINT_ACTIVE)) {
        xn[0] = x[0], xn[1] = x[1], xn[2] = x[2];
        return;
    }
    double w[3][2], dw[3][2], dv[3] = {0, 0, 0}, vnew[3] = {0, 0, 0};
    point_weights(&g, q, w, dw);
    for (int c = 0; c < 2; c++)
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++) {
                double N = w[0][a] * w[1][b] * w[2][c];
                size_t I = stencil_entry(&g, q, a, b, c);
                if (!heavy_entry(&g.contact_grid, I))
                    continue;
                double wN = N / g.gmass[I];
                for (int d = 0; d < 3; d++) {
                    dv[d] += wN * (g.momentum_new[3 * I + d] - g.momentum[3 * I + d]);
                    vnew[d] += wN * g.momentum_new[3 * I + d];
                }
            }
    double flip = g.s.flip;
    for (int d = 0; d < 3; d++) {
        v[d] = flip == 1.0 ? v[d] + dv[d] : flip * (v[d] + dv[d]) + (1.0 - flip) * vnew[d];
        xn[d] = x[d] + dt * vnew[d];
    }
    if (!isfinite(xn[0] + xn[1] + xn[2] + v[0] + v[1] + v[2]))
        g.point_id[q] = (long long)g.id[q];
    else if (contains(&g.s, xn))
        g.point_a[q] = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
}

/* Steps 9-11 for one point (update_block, point_increments, finish_point, bonding_update of solver.c): point_id its
 * id where the update failed. */
__global__ static void update_kernel(struct mpm_gpu g, double dt, double log_dt)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    g.point_id2[q] = LLONG_MAX;
    if (!(g.flags[q] & GPU_POINT_ACTIVE))
        return;
    double w[3][2], dw[3][2], L[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    int contact = 0;
    point_weights(&g, q, w, dw);
    for (int c = 0; c < 2; c++)
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++) {
                size_t I = stencil_entry(&g, q, a, b, c);
                double dN[3] = {(dw[0][a] * w[1][b]) * w[2][c], (w[0][a] * dw[1][b]) * w[2][c],
                                (w[0][a] * w[1][b]) * dw[2][c]};
                for (int i = 0; i < 3; i++)
                    for (int j = 0; j < 3; j++)
                        L[i][j] += g.velocity[3 * I + i] * dN[j];
                contact |= (w[0][a] * w[1][b] * w[2][c] > 0.0) & (g.contact[I] != 0) & (g.bond_contact[I] != 0);
            }
    contact = contact && (g.flags[q] & GPU_POINT_SURFACE);
    double de[6], dspin[3];
    double exx = L[0][0] * dt, eyy = L[1][1] * dt, ezz = L[2][2] * dt;
    de[0] = exx, de[1] = eyy, de[2] = ezz;
    de[3] = 0.5 * (L[1][2] + L[2][1]) * dt, de[4] = 0.5 * (L[0][2] + L[2][0]) * dt;
    de[5] = 0.5 * (L[0][1] + L[1][0]) * dt;
    dspin[0] = 0.5 * (L[1][2] - L[2][1]) * dt, dspin[1] = 0.5 * (L[0][2] - L[2][0]) * dt;
    dspin[2] = 0.5 * (L[0][1] - L[1][0]) * dt;
    double volume_old = g.volume[q], volume_new = volume_old * (1.0 + exx + eyy + ezz);
    if (!(volume_new > 0.0)) {
        g.point_id2[q] = (long long)g.id[q];
        return;
    }
    int material = g.s.body_material[g.body[q]];
    const struct mpm_material *m = &g.s.material[material];
    const struct mpm_material_constants *mc = &g.s.constants[material];
    struct mpm_point_state *state = &g.state[q];
    double T = state->T;
    double G = fm_select(T == m->T_initial, mc->G_initial, mts_lane_shear_modulus(m, T));
    struct mpm_stress_work work;
    struct mpm_update_result result;
    if (stress_begin(m, mc, de, dspin, G, dt, log_dt, g.volume0[q], volume_new, state, &work))
        stress_return_one(m, &work.ret);
    if (stress_finish(m, mc, &g.s.viscosity, dt, g.volume0[q], volume_old, volume_new, &work, state, &result) != 0) {
        g.point_id2[q] = (long long)g.id[q];
        return;
    }
    g.volume[q] = volume_new;
    g.plastic_work[q] += result.plastic_work;
    if (contact)
        g.flags[q] |= GPU_POINT_CONTACT;
    else
        g.flags[q] &= (uint8_t)~GPU_POINT_CONTACT;
    if (g.s.bonding != MPM_BONDING_NONE && contact) {
        double scale = g.s.body_bond_scale[g.body[q]]; /* mpm_bonding_grow */
        g.d_bond[q] += g.s.bonding == MPM_BONDING_ENERGY
                           ? bonding_energy_increment(result.eps_p_increment, result.von_mises, dt, g.s.h,
                                                      g.s.Gc * scale, g.s.Gc_rate, g.s.bonding_floor)
                           : bonding_strain_increment(result.eps_p_increment, dt, g.s.eps_c * scale, g.s.eps_rate_c,
                                                      g.s.bonding_floor);
    }
}

/* remove_escaped of solver.c: the points whose stencil left the grid (x already the new positions). */
__global__ static void remove_kernel(struct mpm_gpu g)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    size_t id = g.id[q]; /* summed in id order */
    g.point_b[id] = g.point_c[id] = 0.0;
    g.point_count[id] = 0;
    if (!(g.flags[q] & GPU_POINT_ACTIVE) || contains(&g.s, g.x + 3 * q))
        return;
    const double *v = g.v + 3 * q;
    g.flags[q] &= (uint8_t)~GPU_POINT_ACTIVE;
    g.point_count[id] = 1;
    g.point_b[id] = g.mass[q];
    g.point_c[id] = 0.5 * g.mass[q] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + g.state[q].energy;
}

/* ---- heat conduction (conduction.c): after a step whose time crossed multiples of the exchange interval ---- */

/* eta(s) = (1 - s^2)^3 of conduction.c, of s^2 */
__device__ static double pse_kernel(double r2_over_eps2)
{
    double u = 1.0 - r2_over_eps2;
    return u > 0.0 ? u * u * u : 0.0;
}

/* The sum over the points o of q's body within eps of the position x of V0_o (T_o - T_q) eta, from the cells of
 * its layer that reach x (the cell edge is the grid's; eps = 2 spacings; x outside the grid searches from the
 * nearest cell, which holds every point within eps of it), in cell order, their points by id. */
__device__ static double heat_sum_at(const struct mpm_gpu *g, size_t q, const double x[3])
{
    double eps2 = g->s.conduction_eps2, T = g->state[q].T, sum = 0.0;
    int reach = (int)ceil(sqrt(eps2) * g->s.inv_h), i[3];
    for (int d = 0; d < 3; d++) {
        double cell = floor((x[d] - g->s.origin[d]) / g->s.h);
        i[d] = cell > 0.0 ? (cell < g->s.n[d] - 1 ? (int)cell : g->s.n[d] - 1) : 0;
    }
    size_t layer = (size_t)g->body[q] * g->nodes;
    for (int dz = -reach; dz <= reach; dz++)
        for (int dy = -reach; dy <= reach; dy++)
            for (int dx = -reach; dx <= reach; dx++) {
                int j[3] = {i[0] + dx, i[1] + dy, i[2] + dz};
                if (j[0] < 0 || j[1] < 0 || j[2] < 0 || j[0] >= g->s.n[0] || j[1] >= g->s.n[1] || j[2] >= g->s.n[2])
                    continue;
                size_t cell = layer + (size_t)j[0] + g->row * (size_t)j[1] + g->plane * (size_t)j[2];
                uint32_t end = g->cell_end[cell];
                for (uint32_t k = g->cell_start[cell]; k < end; k++) {
                    size_t o = g->order_sorted[k];
                    const double *y = g->x + 3 * o;
                    double r2 =
                        (y[0] - x[0]) * (y[0] - x[0]) + (y[1] - x[1]) * (y[1] - x[1]) + (y[2] - x[2]) * (y[2] - x[2]);
                    if (r2 < eps2) /* the point itself (r2 = 0 unmirrored, T_o = T_q mirrored) adds nothing */
                        sum += g->volume0[o] * (g->state[o].T - T) * pse_kernel(r2 / eps2);
                }
            }
    return sum;
}

/* Each active point's heat over dt into point_a (exchange of conduction.c): dt k (6 / M2) V0_q times its sum, and
 * with [impact] symmetry its mirror images' (exchange_sum of conduction.c: the sums at q's images within eps of the
 * planes x = 0, y = 0). */
__global__ static void heat_kernel(struct mpm_gpu g, double dt)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n)
        return;
    g.point_a[q] = 0.0;
    if (!(g.flags[q] & GPU_POINT_ACTIVE))
        return;
    const double *x = g.x + 3 * q;
    double eps = sqrt(g.s.conduction_eps2), sum = 0.0;
    for (int image = 0; image < 4; image++) { /* bit d: mirrored across the plane of axis d */
        double at[3] = {x[0], x[1], x[2]};
        int reaches = 1;
        for (int d = 0; d < 2; d++)
            if (image & (1 << d)) {
                reaches = reaches && g.s.mirror[d] && fabs(x[d]) < eps;
                at[d] = -x[d];
            }
        if (reaches)
            sum += heat_sum_at(&g, q, at);
    }
    const struct mpm_material *m = &g.s.material[g.s.body_material[g.body[q]]];
    g.point_a[q] = dt * m->conductivity * g.s.conduction_laplacian * g.volume0[q] * sum;
}

/* The heat into each active point's temperature and internal energy (after every point's sum: a sum must not see a
 * neighbour already updated). */
__global__ static void heat_apply_kernel(struct mpm_gpu g)
{
    size_t q = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (q >= g.n || !(g.flags[q] & GPU_POINT_ACTIVE))
        return;
    const struct mpm_material *m = &g.s.material[g.s.body_material[g.body[q]]];
    g.state[q].T += g.point_a[q] / (g.mass[q] * m->specific_heat);
    g.state[q].energy += g.point_a[q];
}

/* ---- the storage order ---- */

/* to[k] = from[index[k]] for k < n, width values a point: a point array in the sorted order (index = order_sorted)
 * or in id order (index = slot).  One kernel per element type (a launch's kernel is named, not a template). */
__global__ static void permute_doubles_kernel(double *to, const double *from, const uint32_t *index, size_t n,
                                              int width)
{
    size_t k = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (k >= n)
        return;
    size_t q = index[k];
    for (int j = 0; j < width; j++)
        to[(size_t)width * k + j] = from[(size_t)width * q + j];
}

__global__ static void permute_words_kernel(uint32_t *to, const uint32_t *from, const uint32_t *index, size_t n)
{
    size_t k = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (k < n)
        to[k] = from[index[k]];
}

__global__ static void permute_bytes_kernel(uint8_t *to, const uint8_t *from, const uint32_t *index, size_t n)
{
    size_t k = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (k < n)
        to[k] = from[index[k]];
}

/* slot = the inverse of id (identity: both the identity, the storage in id order as the host's). */
__global__ static void slot_kernel(struct mpm_gpu g, int identity)
{
    size_t k = blockIdx.x * (size_t)blockDim.x + threadIdx.x;
    if (k >= g.n)
        return;
    if (identity)
        g.id[k] = (uint32_t)k;
    g.slot[g.id[k]] = (uint32_t)k;
}

/* ---- host side ---- */

extern "C" int mpm_gpu_built(void)
{
    return 1;
}

#define GPU_TEXT(x)  #x
#define GPU_VALUE(x) GPU_TEXT(x)
extern "C" const char *mpm_gpu_build(void)
{
#ifdef __CUDACC__
    return "CUDA step (nvcc " GPU_VALUE(__CUDACC_VER_MAJOR__) "." GPU_VALUE(__CUDACC_VER_MINOR__) ", FP64)";
#else
    return "CUDA step emulated on the CPU (tests/cuda_emu: a check of the device code, not for production runs)";
#endif
}

extern "C" const char *mpm_gpu_message(void)
{
    return gpu_message;
}

extern "C" const char *mpm_gpu_name(const struct mpm_gpu *g)
{
    return g ? g->name : "no GPU";
}

extern "C" int mpm_gpu_host_stale(const struct mpm_gpu *g)
{
    return g && g->host_stale;
}

template <typename T> static int device_array(T **p, size_t count)
{
    CU(cudaMalloc((void **)p, (count ? count : 1) * sizeof(T)));
    return 0;
}

template <typename T> static int copy_in(T *device, const T *host, size_t count)
{
    CU(cudaMemcpy(device, host, count * sizeof(T), cudaMemcpyHostToDevice));
    return 0;
}

template <typename T> static int copy_out(T *host, const T *device, size_t count)
{
    CU(cudaMemcpy(host, device, count * sizeof(T), cudaMemcpyDeviceToHost));
    return 0;
}

#define TRY(call)                                                                                                      \
    do {                                                                                                               \
        if ((call) != 0)                                                                                               \
            return -1;                                                                                                 \
    } while (0)

/* The largest temporary storage any of the step's CUB calls asks for. */
static int reserve_temp(struct mpm_gpu *g)
{
    size_t bytes = 0, need = 0;
    int n = (int)g->n, nodes = (int)g->nodes;
    CU(cub::DeviceRadixSort::SortPairs(NULL, need, g->key, g->key_sorted, g->order, g->order_sorted, n, 0,
                                       g->key_bits));
    bytes = need > bytes ? need : bytes;
    CU(cub::DeviceReduce::Max(NULL, need, g->point_a, g->result, n));
    bytes = need > bytes ? need : bytes;
    CU(cub::DeviceReduce::Sum(NULL, need, g->point_a, g->result, n));
    bytes = need > bytes ? need : bytes;
    CU(cub::DeviceReduce::Min(NULL, need, g->point_id, g->result_id, n));
    bytes = need > bytes ? need : bytes;
    CU(cub::DeviceReduce::Sum(NULL, need, g->point_count, g->result_int, n));
    bytes = need > bytes ? need : bytes;
    CU(cub::DeviceReduce::Sum(NULL, need, g->node_contacts, g->result_int, nodes));
    bytes = need > bytes ? need : bytes;
    g->temp_bytes = bytes;
    return device_array((char **)&g->temp, bytes);
}

static int allocate(struct mpm_gpu *g)
{
    size_t n = g->n, cells = g->cells;
    TRY(device_array(&g->x, 3 * n) || device_array(&g->x_next, 3 * n) || device_array(&g->v, 3 * n));
    TRY(device_array(&g->mass, n) || device_array(&g->volume0, n) || device_array(&g->volume, n));
    TRY(device_array(&g->d_bond, n) || device_array(&g->plastic_work, n) || device_array(&g->normal, 3 * n));
    TRY(device_array(&g->state, n) || device_array(&g->body, n) || device_array(&g->flags, n));
    TRY(device_array(&g->id, n) || device_array(&g->slot, n) ||
        device_array((struct mpm_point_state **)&g->scratch, n));
    TRY(device_array(&g->key, n) || device_array(&g->key_sorted, n) || device_array(&g->order, n));
    TRY(device_array(&g->order_sorted, n) || device_array(&g->base, n) || device_array(&g->fraction, 3 * n));
    TRY(device_array(&g->cell_start, cells) || device_array(&g->cell_end, cells));
    TRY(device_array(&g->gmass, cells) || device_array(&g->momentum, 3 * cells));
    TRY(device_array(&g->momentum_new, 3 * cells) || device_array(&g->force, 3 * cells));
    TRY(device_array(&g->gradient, 3 * cells) || device_array(&g->moment, 3 * cells));
    TRY(device_array(&g->bond_sum, cells) || device_array(&g->bond_weight, cells));
    TRY(device_array(&g->velocity, 3 * cells) || device_array(&g->contact, cells));
    TRY(device_array(&g->bond_contact, cells));
    g->pair_state = NULL;
    if (g->s.bodies >= 3 && g->s.bodies <= PAIR_STATE_LAYERS) /* as grid.c alloc_layers */
        TRY(device_array(&g->pair_state, cells));
    TRY(device_array(&g->wall_held, cells) || device_array(&g->body_velocity, 3 * (size_t)g->s.bodies));
    TRY(device_array(&g->body_partial, 4 * BODY_BLOCKS * (size_t)g->s.bodies));
    CU(cudaMemset(g->wall_held, 0, cells));
    TRY(device_array(&g->point_a, n) || device_array(&g->point_b, n) || device_array(&g->point_c, n));
    TRY(device_array(&g->sums_partial, BODY_BLOCKS * (size_t)g->s.bodies));
    TRY(device_array(&g->sums, (size_t)g->s.bodies));
    TRY(device_array(&g->point_id, n) || device_array(&g->point_id2, n) || device_array(&g->point_count, n));
    TRY(device_array(&g->node_contacts, g->nodes) || device_array(&g->node_bonds, g->nodes));
    TRY(device_array(&g->result, 5) || device_array(&g->result_id, 2) || device_array(&g->result_int, 3));
    return reserve_temp(g);
}

/* The setup's tables onto the device (the struct keeps their device copies, each as soon as it is allocated, so
 * that mpm_gpu_close frees what a failure left). */
static int copy_tables(struct mpm_gpu *g, const struct mpm_gpu_setup *setup)
{
    struct mpm_material *material;
    struct mpm_material_constants *constants;
    int *body_material;
    double *body_dashpot, *body_bond_scale;
    TRY(device_array(&material, (size_t)setup->materials));
    g->s.material = material;
    TRY(device_array(&constants, (size_t)setup->materials));
    g->s.constants = constants;
    TRY(device_array(&body_material, (size_t)setup->bodies));
    g->s.body_material = body_material;
    TRY(device_array(&body_dashpot, 2 * (size_t)setup->bodies));
    g->s.body_dashpot = body_dashpot;
    TRY(device_array(&body_bond_scale, (size_t)setup->bodies));
    g->s.body_bond_scale = body_bond_scale;
    TRY(copy_in(material, setup->material, (size_t)setup->materials));
    TRY(copy_in(constants, setup->constants, (size_t)setup->materials));
    TRY(copy_in(body_material, setup->body_material, (size_t)setup->bodies));
    TRY(copy_in(body_dashpot, setup->body_dashpot, 2 * (size_t)setup->bodies));
    TRY(copy_in(body_bond_scale, setup->body_bond_scale, (size_t)setup->bodies));
    return 0;
}

/* The device of this process, if there is one this build runs on; its description into name.  Under mpirun (or
 * srun) the processes of a node take the node's devices in turn, by their local rank: one rank per GPU
 * (CUDA_VISIBLE_DEVICES narrows the choice as usual). */
static int choose_device(char *name, size_t size)
{
    int count = 0;
    cudaError_t status = cudaGetDeviceCount(&count);
    if (status != cudaSuccess || count == 0)
        return fail("no CUDA device found (%s); allowed: cpu on this machine",
                    status != cudaSuccess ? cudaGetErrorString(status) : "none present");
    const char *local = getenv("OMPI_COMM_WORLD_LOCAL_RANK");
    if (!local)
        local = getenv("SLURM_LOCALID");
    int device = local ? atoi(local) % count : 0;
    device = device < 0 ? 0 : device;
    cudaDeviceProp prop;
    CU(cudaSetDevice(device));
    CU(cudaGetDeviceProperties(&prop, device));
    if (prop.major < 9)
        return fail("device %d, %s, has compute capability %d.%d; this build's step is for sm_90 or later (make "
                    "CUDA=1 CUDA_ARCH=sm_%d%d); allowed: cpu on this machine",
                    device, prop.name, prop.major, prop.minor, prop.major, prop.minor);
    snprintf(name, size, "GPU %d of %d: %s, %.0f GiB, compute capability %d.%d", device, count, prop.name,
             (double)prop.totalGlobalMem / (1 << 30), prop.major, prop.minor);
    return 0;
}

/* The contact's view of the device's grid (contact.c nodes_of): device pointers, read by the kernels from their
 * copy of the struct. */
static void set_contact_nodes(struct mpm_gpu *g)
{
    struct contact_nodes *c = &g->contact_grid;
    c->mass = g->gmass, c->gradient = g->gradient, c->moment = g->moment;
    c->bond_sum = g->bond_sum, c->bond_weight = g->bond_weight, c->body_velocity = g->body_velocity;
    c->contact = g->contact, c->bond_contact = g->bond_contact, c->pair_state = g->pair_state;
    c->nodes = g->nodes, c->layers = g->s.bodies;
    c->mass_cutoff = g->s.mass_cutoff, c->h = g->s.h;
    c->bonding = g->s.bonding, c->law = g->s.contact, c->scheme = g->s.contact_scheme;
    c->approach = g->s.contact_approach, c->growth = g->s.bond_growth;
    c->friction = g->s.friction, c->contact_gap = g->s.contact_gap, c->bond_gap = g->s.bond_gap;
    c->momentum = g->momentum, c->force = g->force, c->momentum_new = g->momentum_new, c->wall_held = g->wall_held;
    c->moments = g->s.moments, c->row = g->row, c->plane = g->plane, c->origin_z = g->s.origin[2];
    c->rigid_wall = g->s.rigid_wall, c->fixed_bottom = g->s.fixed_bottom;
    c->substrate_top = g->s.substrate_top, c->substrate_bottom = g->s.substrate_bottom;
    for (int d = 0; d < 2; d++)
        c->mirror[d] = g->s.mirror[d], c->mirror_plane[d] = g->s.mirror_plane[d];
}

extern "C" int mpm_gpu_probe(void)
{
    char name[320];
    return choose_device(name, sizeof name);
}

extern "C" int mpm_gpu_open(const struct mpm_gpu_setup *setup, struct mpm_gpu **out)
{
    *out = NULL;
    struct mpm_gpu *g = (struct mpm_gpu *)calloc(1, sizeof *g);
    if (!g)
        return fail("out of memory for the GPU state");
    g->s = *setup;
    /* the tables' device copies replace these (copy_tables); until then none, so that a failed open frees nothing
     * of the host's */
    g->s.material = NULL, g->s.constants = NULL, g->s.body_material = NULL, g->s.body_dashpot = NULL;
    g->s.body_bond_scale = NULL;
    g->n = setup->points;
    g->row = (size_t)setup->n[0];
    g->plane = g->row * (size_t)setup->n[1];
    g->nodes = g->plane * (size_t)setup->n[2];
    g->cells = g->nodes * (size_t)setup->bodies;
    const char *every = getenv("SPRAYCOAT_GPU_REORDER_EVERY"); /* a check's setting: the bits are the same */
    g->reorder_every = every ? atoi(every) : REORDER_EVERY;
    g->key_bits = 1;
    while (g->key_bits < 64 && (g->cells >> g->key_bits) != 0) /* keys up to cells (inactive) */
        g->key_bits++;
    if (g->n >= UINT32_MAX || g->nodes >= UINT32_MAX) {
        size_t nodes = g->nodes;
        free(g);
        return fail("%zu points and %zu nodes: the GPU step indexes both with 32 bits", setup->points, nodes);
    }
    if (choose_device(g->name, sizeof g->name) != 0 || copy_tables(g, setup) != 0 || allocate(g) != 0) {
        mpm_gpu_close(g);
        return -1;
    }
    set_contact_nodes(g);
    *out = g;
    return 0;
}

extern "C" void mpm_gpu_close(struct mpm_gpu *g)
{
    if (!g)
        return;
    void *arrays[] = {g->x,
                      g->x_next,
                      g->v,
                      g->mass,
                      g->volume0,
                      g->volume,
                      g->d_bond,
                      g->plastic_work,
                      g->normal,
                      g->state,
                      g->body,
                      g->flags,
                      g->id,
                      g->slot,
                      g->scratch,
                      g->key,
                      g->key_sorted,
                      g->order,
                      g->order_sorted,
                      g->base,
                      g->fraction,
                      g->cell_start,
                      g->cell_end,
                      g->gmass,
                      g->momentum,
                      g->momentum_new,
                      g->force,
                      g->gradient,
                      g->moment,
                      g->bond_sum,
                      g->bond_weight,
                      g->velocity,
                      g->contact,
                      g->bond_contact,
                      g->wall_held,
                      g->body_partial,
                      g->body_velocity,
                      g->sums_partial,
                      g->sums,
                      g->point_a,
                      g->point_b,
                      g->point_c,
                      g->point_id,
                      g->point_id2,
                      g->point_count,
                      g->node_contacts,
                      g->node_bonds,
                      g->pair_state,
                      g->result,
                      g->result_id,
                      g->result_int,
                      g->temp,
                      (void *)g->s.material,
                      (void *)g->s.constants,
                      (void *)g->s.body_material,
                      (void *)g->s.body_dashpot,
                      (void *)g->s.body_bond_scale};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; i++)
        if (arrays[i])
            cudaFree(arrays[i]);
    free(g);
}

extern "C" int mpm_gpu_upload(struct mpm_gpu *g, const struct mpm_gpu_points *p)
{
    size_t n = g->n;
    TRY(copy_in(g->x, p->x, 3 * n) || copy_in(g->v, p->v, 3 * n) || copy_in(g->mass, p->mass, n));
    TRY(copy_in(g->volume0, p->volume0, n) || copy_in(g->volume, p->volume, n) || copy_in(g->d_bond, p->d_bond, n));
    TRY(copy_in(g->plastic_work, p->plastic_work, n) || copy_in(g->normal, p->normal, 3 * n));
    TRY(copy_in(g->state, p->state, n) || copy_in(g->body, p->body, n) || copy_in(g->flags, p->flags, n));
    int64_t active = 0;
    for (size_t q = 0; q < n; q++)
        active += (p->flags[q] & GPU_POINT_ACTIVE) != 0;
    g->removed_total = (int64_t)n - active;
    slot_kernel<<<blocks_for(n), THREADS>>>(*g, 1); /* the storage in id order, as the host's */
    CU(cudaGetLastError());
    g->host_stale = 0;
    g->grid_stepped = 0;
    return 0;
}

/* The point state is its doubles (the permutation copies it as such). */
#define STATE_DOUBLES ((int)(sizeof(struct mpm_point_state) / sizeof(double)))
static_assert(sizeof(struct mpm_point_state) == STATE_DOUBLES * sizeof(double), "struct mpm_point_state: doubles");

/* A point array of `width` doubles a point in id order (through the scratch array) onto the host's. */
static int copy_out_by_id(struct mpm_gpu *g, double *host, const double *device, int width)
{
    permute_doubles_kernel<<<blocks_for(g->n), THREADS>>>((double *)g->scratch, device, g->slot, g->n, width);
    CU(cudaGetLastError());
    return copy_out(host, (const double *)g->scratch, (size_t)width * g->n);
}

extern "C" int mpm_gpu_download(struct mpm_gpu *g, const struct mpm_gpu_points *p)
{
    /* mass, volume0, normal and body never change: the host's copies in id order hold */
    TRY(copy_out_by_id(g, p->x, g->x, 3) || copy_out_by_id(g, p->v, g->v, 3));
    TRY(copy_out_by_id(g, p->volume, g->volume, 1) || copy_out_by_id(g, p->d_bond, g->d_bond, 1));
    TRY(copy_out_by_id(g, p->plastic_work, g->plastic_work, 1));
    TRY(copy_out_by_id(g, (double *)p->state, (const double *)g->state, STATE_DOUBLES));
    permute_bytes_kernel<<<blocks_for(g->n), THREADS>>>((uint8_t *)g->scratch, g->flags, g->slot, g->n);
    CU(cudaGetLastError());
    TRY(copy_out(p->flags, (const uint8_t *)g->scratch, g->n));
    g->host_stale = 0;
    return 0;
}

/* Sort the active points by cell and find each cell's run (bin, sort, ranges). */
static int bin_and_sort(struct mpm_gpu *g)
{
    unsigned pb = blocks_for(g->n);
    bin_kernel<<<pb, THREADS>>>(*g);
    CU(cudaGetLastError());
    size_t bytes = g->temp_bytes;
    CU(cub::DeviceRadixSort::SortPairs(g->temp, bytes, g->key, g->key_sorted, g->order, g->order_sorted, (int)g->n, 0,
                                       g->key_bits));
    CU(cudaMemset(g->cell_start, 0, g->cells * sizeof *g->cell_start));
    CU(cudaMemset(g->cell_end, 0, g->cells * sizeof *g->cell_end));
    range_kernel<<<pb, THREADS>>>(*g);
    CU(cudaGetLastError());
    return 0;
}

/* A point array of `width` doubles a point in the sorted order (through the scratch array). */
static int reorder_doubles(struct mpm_gpu *g, double *array, int width)
{
    permute_doubles_kernel<<<blocks_for(g->n), THREADS>>>((double *)g->scratch, array, g->order_sorted, g->n, width);
    CU(cudaGetLastError());
    CU(cudaMemcpy(array, g->scratch, (size_t)width * g->n * sizeof *array, cudaMemcpyDeviceToDevice));
    return 0;
}

static int reorder_words(struct mpm_gpu *g, uint32_t *array)
{
    permute_words_kernel<<<blocks_for(g->n), THREADS>>>((uint32_t *)g->scratch, array, g->order_sorted, g->n);
    CU(cudaGetLastError());
    CU(cudaMemcpy(array, g->scratch, g->n * sizeof *array, cudaMemcpyDeviceToDevice));
    return 0;
}

/* The points' arrays in the order of the last sort (by body and cell, a cell's points by id, inactive points last),
 * so that a cell's points lie together for the gathers and their neighbours' threads read neighbouring nodes; then
 * binned and sorted again at their new places. */
static int reorder_points(struct mpm_gpu *g)
{
    TRY(reorder_doubles(g, g->x, 3) || reorder_doubles(g, g->v, 3) || reorder_doubles(g, g->mass, 1));
    TRY(reorder_doubles(g, g->volume0, 1) || reorder_doubles(g, g->volume, 1) || reorder_doubles(g, g->d_bond, 1));
    TRY(reorder_doubles(g, g->plastic_work, 1) || reorder_doubles(g, g->normal, 3));
    TRY(reorder_doubles(g, (double *)g->state, STATE_DOUBLES));
    TRY(reorder_words(g, (uint32_t *)g->body) || reorder_words(g, g->id));
    permute_bytes_kernel<<<blocks_for(g->n), THREADS>>>((uint8_t *)g->scratch, g->flags, g->order_sorted, g->n);
    CU(cudaGetLastError());
    CU(cudaMemcpy(g->flags, g->scratch, g->n, cudaMemcpyDeviceToDevice));
    slot_kernel<<<blocks_for(g->n), THREADS>>>(*g, 0);
    CU(cudaGetLastError());
    return bin_and_sort(g);
}

/* The step's reductions into out (copied back once). */
static int reduce(struct mpm_gpu *g, struct mpm_gpu_step_out *out)
{
    size_t bytes = g->temp_bytes;
    int n = (int)g->n, nodes = (int)g->nodes;
    double result[5];
    long long result_id[2];
    int result_int[3];
    /* point_a: the dashpots' work was summed before g2p reused it (step_points) */
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->point_b, g->result + 2, n));
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->point_c, g->result + 3, n));
    CU(cub::DeviceReduce::Min(g->temp, bytes, g->point_id2, g->result_id + 1, n));
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->point_count, g->result_int, n));
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->node_contacts, g->result_int + 1, nodes));
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->node_bonds, g->result_int + 2, nodes));
    CU(cudaMemcpy(result, g->result, sizeof result, cudaMemcpyDeviceToHost));
    CU(cudaMemcpy(result_id, g->result_id, sizeof result_id, cudaMemcpyDeviceToHost));
    CU(cudaMemcpy(result_int, g->result_int, sizeof result_int, cudaMemcpyDeviceToHost));
    out->vmax2 = result[0];
    out->absorbed_work = result[1];
    out->removed_mass = result[2];
    out->removed_energy = result[3];
    out->nonfinite_id = result_id[0] == LLONG_MAX ? -1 : (long)result_id[0];
    out->failed_id = result_id[1] == LLONG_MAX ? -1 : (long)result_id[1];
    out->removed = result_int[0];
    out->contact_nodes = result_int[1];
    out->bonded_nodes = result_int[2];
    return 0;
}

extern "C" int mpm_gpu_step_points(struct mpm_gpu *g, double dt, struct mpm_gpu_step_out *out)
{
    memset(out, 0, sizeof *out);
    unsigned pb = blocks_for(g->n), nb = blocks_for(g->nodes), cb = blocks_for(g->cells);
    size_t bytes = g->temp_bytes;
    int n = (int)g->n;
    double log_dt = dt > 0.0 ? log(dt) : 0.0;
    out->active = (int64_t)g->n - g->removed_total;
    g->host_stale = 1;
    TRY(bin_and_sort(g));
    if (g->reorder_every > 0 && g->steps % g->reorder_every == 0)
        TRY(reorder_points(g));
    g->steps++;
    gather_kernel<<<cb, THREADS>>>(*g, 0); /* steps 1-2 */
    if (g->s.bond_growth == MPM_GROWTH_APPROACH && g->s.contact_scheme == MPM_CONTACT_ONCE && g->s.bodies > 1) {
        body_partial_kernel<<<dim3(BODY_BLOCKS, (unsigned)g->s.bodies), THREADS>>>(*g);
        body_velocity_kernel<<<blocks_for((size_t)g->s.bodies), THREADS>>>(*g);
    }
    nodal_kernel<<<nb, THREADS>>>(*g, dt); /* steps 3-6 */
    book_kernel<<<pb, THREADS>>>(*g, dt);
    CU(cudaGetLastError());
    CU(cub::DeviceReduce::Sum(g->temp, bytes, g->point_a, g->result + 1, n));
    g2p_kernel<<<pb, THREADS>>>(*g, dt); /* step 7 */
    CU(cudaGetLastError());
    CU(cub::DeviceReduce::Max(g->temp, bytes, g->point_a, g->result, n));
    CU(cub::DeviceReduce::Min(g->temp, bytes, g->point_id, g->result_id, n));
    gather_kernel<<<cb, THREADS>>>(*g, 1); /* step 8, MUSL */
    correct_kernel<<<nb, THREADS>>>(*g);
    velocity_kernel<<<cb, THREADS>>>(*g);
    update_kernel<<<pb, THREADS>>>(*g, dt, log_dt); /* steps 9-11 */
    CU(cudaGetLastError());
    double *swap = g->x;
    g->x = g->x_next, g->x_next = swap;
    remove_kernel<<<pb, THREADS>>>(*g); /* step 12 */
    CU(cudaGetLastError());
    TRY(reduce(g, out));
    g->removed_total += out->removed;
    g->grid_stepped = 1;
    return 0;
}

extern "C" int mpm_gpu_conduct(struct mpm_gpu *g, double interval, int exchanges)
{
    TRY(bin_and_sort(g)); /* the cells of the points' positions after the step (the next step bins them again) */
    unsigned pb = blocks_for(g->n);
    for (int k = 0; k < exchanges; k++) {
        heat_kernel<<<pb, THREADS>>>(*g, interval);
        heat_apply_kernel<<<pb, THREADS>>>(*g);
        CU(cudaGetLastError());
    }
    g->host_stale = 1;
    return 0;
}

extern "C" int mpm_gpu_interface_nodes(struct mpm_gpu *g, int64_t *interface, int64_t *bonded)
{
    size_t bytes = g->temp_bytes;
    int nodes = (int)g->nodes, counts[2];
    for (int b = 0; b < g->s.bodies; b++) {
        interface[b] = bonded[b] = 0;
        if (!g->grid_stepped || g->s.bodies < 2) /* no step yet: the CPU's grid is empty then */
            continue;
        interface_kernel<<<blocks_for(g->nodes), THREADS>>>(*g, b);
        CU(cudaGetLastError());
        CU(cub::DeviceReduce::Sum(g->temp, bytes, g->node_contacts, g->result_int + 1, nodes));
        CU(cub::DeviceReduce::Sum(g->temp, bytes, g->node_bonds, g->result_int + 2, nodes));
        CU(cudaMemcpy(counts, g->result_int + 1, sizeof counts, cudaMemcpyDeviceToHost));
        interface[b] = counts[0], bonded[b] = counts[1];
    }
    return 0;
}

extern "C" int mpm_gpu_point_sums(struct mpm_gpu *g, double vrest_filter, struct point_sums *sums)
{
    struct point_fields fields = {g->v,     g->mass,  g->volume0,        g->plastic_work, g->d_bond,
                                  g->state, g->flags, GPU_POINT_SURFACE, vrest_filter};
    diagnostics_kernel<<<dim3(BODY_BLOCKS, (unsigned)g->s.bodies), THREADS>>>(*g, fields);
    diagnostics_body_kernel<<<blocks_for((size_t)g->s.bodies), THREADS>>>(*g);
    CU(cudaGetLastError());
    TRY(copy_out(sums, g->sums, (size_t)g->s.bodies));
    return 0;
}
