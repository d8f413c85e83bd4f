/* The storage order of the material points.  The particle-to-grid transfer visits the points block by block
 * (grid.c); with the points stored in set-up order it gathered each point's 120-byte state from a different
 * place, a cache miss per point.  The solver now and then stores the points in the order that transfer
 * visits them.  Every result is independent of this order: the transfer visits the points of a block by id
 * (grid_bin_points), each point's update is its own, and sums over points, outputs and checkpoints run in id
 * order.  So a run gives the same bits however often it reorders, for any thread count and after a resume. */
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "mpm/mpm_impl.h"

void points_order_reset(struct mpm_points *p)
{
    for (size_t q = 0; q < p->count; q++)
        p->id[q] = p->slot[q] = (uint32_t)q;
}

/* Everything stored for one point (x_next is scratch within a step and is not kept). */
struct point_record {
    double x[3], v[3], normal[3];
    double mass, volume0, volume, d_bond, plastic_work;
    struct mpm_point_state state;
    int32_t body;
    uint8_t flags;
    uint32_t id;
};

static void record_load(const struct mpm_points *p, size_t q, struct point_record *r)
{
    memcpy(r->x, p->x + 3 * q, sizeof r->x);
    memcpy(r->v, p->v + 3 * q, sizeof r->v);
    memcpy(r->normal, p->normal + 3 * q, sizeof r->normal);
    r->mass = p->mass[q], r->volume0 = p->volume0[q], r->volume = p->volume[q];
    r->d_bond = p->d_bond[q], r->plastic_work = p->plastic_work[q];
    r->state = p->state[q];
    r->body = p->body[q], r->flags = p->flags[q], r->id = p->id[q];
}

static void record_store(struct mpm_points *p, size_t q, const struct point_record *r)
{
    memcpy(p->x + 3 * q, r->x, sizeof r->x);
    memcpy(p->v + 3 * q, r->v, sizeof r->v);
    memcpy(p->normal + 3 * q, r->normal, sizeof r->normal);
    p->mass[q] = r->mass, p->volume0[q] = r->volume0, p->volume[q] = r->volume;
    p->d_bond[q] = r->d_bond, p->plastic_work[q] = r->plastic_work;
    p->state[q] = r->state;
    p->body[q] = r->body, p->flags[q] = r->flags, p->id[q] = r->id;
}

/* Slot k takes the point now in slot from[k], for every k: done in place, one cycle of the permutation at a
 * time, so that no second copy of the point arrays is needed (moved marks the slots already filled). */
static void permute(struct mpm_points *p, const uint32_t *from, uint8_t *moved)
{
    memset(moved, 0, p->count);
    for (size_t start = 0; start < p->count; start++) {
        if (moved[start] || from[start] == start)
            continue;
        struct point_record first, next;
        record_load(p, start, &first);
        size_t k = start;
        while (from[k] != start) {
            record_load(p, from[k], &next);
            record_store(p, k, &next);
            moved[k] = 1;
            k = from[k];
        }
        record_store(p, k, &first);
        moved[k] = 1;
    }
}

/* The transfer's order: the colours in turn, their blocks in turn, the points of a block as binned; then the
 * points in no block (removed, or outside the grid until remove_escaped), by id. */
static void transfer_order(const struct mpm_solver *s, uint32_t *from)
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_points *p = &s->points;
    size_t k = 0;
    for (int colour = 0; colour < 8; colour++)
        for (size_t i = 0; i < g->colour_count[colour]; i++) {
            size_t block = g->colour_blocks[colour][i];
            for (size_t j = g->block_start[block]; j < g->block_start[block + 1]; j++)
                from[k++] = (uint32_t)g->block_points[j];
        }
    for (size_t i = 0; i < p->count; i++)
        if (g->point_block[p->slot[i]] < 0)
            from[k++] = p->slot[i];
}

int points_reorder(struct mpm_solver *s)
{
    struct mpm_points *p = &s->points;
    uint32_t *from = malloc((p->count ? p->count : 1) * sizeof *from);
    uint8_t *moved = malloc(p->count ? p->count : 1);
    if (!from || !moved) {
        free(from);
        free(moved);
        SC_FAIL(SC_ESIM, "out of memory reordering %zu material points", p->count);
    }
    transfer_order(s, from);
    permute(p, from, moved);
    for (size_t q = 0; q < p->count; q++)
        p->slot[p->id[q]] = (uint32_t)q;
    free(from);
    free(moved);
    return SC_OK;
}
