/* The storage order of the material points.  The particle-to-grid transfer visits the points block by block
 * (grid.c); with the points stored in set-up order it gathered each point's 120-byte state from a different
 * place, a cache miss per point.  The solver now and then stores the points block by block, in the order in
 * which the transfer finds them within a colour.  Every result is independent of this order: the transfer
 * visits the points of a block by id (mpm_grid_bin_points), each point's update is its own, and sums over points,
 * outputs and checkpoints run in id order.  So a run gives the same bits however often it reorders, for any
 * thread count and after a resume. */
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "mpm/mpm_impl.h"

void mpm_points_order_reset(struct mpm_points *p)
{
    for (size_t q = 0; q < p->count; q++)
        p->id[q] = p->slot[q] = (uint32_t)q;
}

/* The permutation is applied array by array: slot k of an array gathers the element now in slot from[k] into a
 * scratch array, which is then copied back.  The reads go through the old order in runs (a block's points are
 * neighbours in the set-up lattice), the writes in order, and no read waits for another.  Following the cycles
 * of the permutation instead moved whole points, one cache miss per array and point, each waiting for the one
 * before: twice the time on the 1e6-point impact, whose first reordering moves every point (6 % of its samples
 * over 31 steps, 3 % now); the same on the small one. */
#define NO_GATHERS __attribute__((optimize("no-tree-vectorize"))) /* gcc would gather with vgatherqpd: slow on Zen */

/* Bytes [offset, offset + part) of each of the n elements of `size` bytes at base: element k's become those of
 * element from[k] (scratch: part bytes per element).  Always inlined with literal sizes: the copies are moves.
 * Called by every thread of a parallel region, which share the elements (the loops' ends are barriers). */
static inline __attribute__((always_inline)) NO_GATHERS void
permute_bytes(void *base, size_t size, size_t offset, size_t part, const uint32_t *from, size_t n, char *scratch)
{
    char *b = base;
#pragma omp for schedule(static)
    for (size_t k = 0; k < n; k++)
        memcpy(scratch + k * part, b + (size_t)from[k] * size + offset, part);
#pragma omp for schedule(static)
    for (size_t k = 0; k < n; k++)
        memcpy(b + k * size + offset, scratch + k * part, part);
}

/* The parts of a point state moved at a time: three doubles, the scratch's size per point. */
#define STATE_PART (3 * sizeof(double))
_Static_assert(sizeof(struct mpm_point_state) % STATE_PART == 0, "a point state is a whole number of parts");

/* Slot k takes the point now in slot from[k], for every k: everything stored for a point (x_next is scratch
 * within a step and is not kept: it is the scratch here, 3 doubles per point). */
static NO_GATHERS void permute(struct mpm_points *p, const uint32_t *from)
{
    size_t n = p->count;
    char *scratch = (char *)p->x_next;
    if (n == 0)
        return;
#pragma omp parallel
    {
        permute_bytes(p->x, 3 * sizeof *p->x, 0, 3 * sizeof *p->x, from, n, scratch);
        permute_bytes(p->v, 3 * sizeof *p->v, 0, 3 * sizeof *p->v, from, n, scratch);
        permute_bytes(p->normal, 3 * sizeof *p->normal, 0, 3 * sizeof *p->normal, from, n, scratch);
        permute_bytes(p->mass, sizeof *p->mass, 0, sizeof *p->mass, from, n, scratch);
        permute_bytes(p->volume0, sizeof *p->volume0, 0, sizeof *p->volume0, from, n, scratch);
        permute_bytes(p->volume, sizeof *p->volume, 0, sizeof *p->volume, from, n, scratch);
        permute_bytes(p->d_bond, sizeof *p->d_bond, 0, sizeof *p->d_bond, from, n, scratch);
        permute_bytes(p->plastic_work, sizeof *p->plastic_work, 0, sizeof *p->plastic_work, from, n, scratch);
        for (size_t offset = 0; offset < sizeof *p->state; offset += STATE_PART)
            permute_bytes(p->state, sizeof *p->state, offset, STATE_PART, from, n, scratch);
        permute_bytes(p->body, sizeof *p->body, 0, sizeof *p->body, from, n, scratch);
        permute_bytes(p->flags, sizeof *p->flags, 0, sizeof *p->flags, from, n, scratch);
        permute_bytes(p->id, sizeof *p->id, 0, sizeof *p->id, from, n, scratch);
        for (size_t offset = 0; p->affine && offset < 9 * sizeof *p->affine; offset += STATE_PART)
            permute_bytes(p->affine, 9 * sizeof *p->affine, offset, STATE_PART, from, n, scratch);
    }
}

/* The blocks in index order (z, then y, then x), the points of a block as binned; then the points in no block
 * (removed, or outside the grid until remove_escaped), by id.  The transfer visits a colour's blocks in this
 * order, each block's points together; and the halves of the storage are the halves of the grid in z, as are
 * the threads' shares of each colour in the transfer, so that the loops over the storage (grid-to-points, the
 * update) find a point's nodes and state in the cache of the core that scattered them.  The colours in turn had
 * been the order before: 2 threads, 1e6 points +8 %, 68,000 points +1 to +6 % (grid-to-points -2 to -16 %);
 * 1 thread the same. */
static void transfer_order(const struct mpm_solver *s, uint32_t *from)
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    size_t k = 0;
    for (size_t j = 0; j < g->block_start[g->block_count]; j++)
        from[k++] = (uint32_t)g->block_points[j];
    for (size_t i = 0; i < p->count; i++)
        if (g->point_block[p->slot[i]] < 0)
            from[k++] = p->slot[i];
}

int mpm_points_reorder(struct mpm_solver *s)
{
    struct mpm_points *p = &s->points;
    uint32_t *from = malloc((p->count ? p->count : 1) * sizeof *from);
    if (!from)
        SC_FAIL_OOM((p->count ? p->count : 1) * sizeof *from, "the reordering of the material points");
    transfer_order(s, from);
    permute(p, from);
#pragma omp parallel for schedule(static)
    for (size_t q = 0; q < p->count; q++)
        p->slot[p->id[q]] = (uint32_t)q;
    free(from);
    return SC_OK;
}
