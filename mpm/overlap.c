/* Overlapping spheres among the bodies (mpm/mpm.h, mpm_find_sphere_overlap): a cell list instead of the test of
 * every pair, which took half a minute for 1e5 bodies. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "mpm/mpm.h"

struct cell_entry {
    int64_t cell[3];
    int body;
};

static int compare_cells(const int64_t *a, const int64_t *b)
{
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k])
            return a[k] < b[k] ? -1 : 1;
    return 0;
}

static int compare_entries(const void *pa, const void *pb)
{
    const struct cell_entry *a = pa, *b = pb;
    int by_cell = compare_cells(a->cell, b->cell);
    return by_cell ? by_cell : (a->body > b->body) - (a->body < b->body);
}

/* First entry of `cell` in the sorted entries (or where it would be). */
static size_t lower_bound(const struct cell_entry *entries, size_t count, const int64_t cell[3])
{
    size_t low = 0, high = count;
    while (low < high) {
        size_t middle = low + (high - low) / 2;
        if (compare_cells(entries[middle].cell, cell) < 0)
            low = middle + 1;
        else
            high = middle;
    }
    return low;
}

/* The same test as before the cell list: touching spheres (to a relative 1e-9) do not overlap. */
static int spheres_overlap(const struct mpm_body *a, const struct mpm_body *b)
{
    double dx = a->center[0] - b->center[0], dy = a->center[1] - b->center[1], dz = a->center[2] - b->center[2];
    double distance = sqrt(dx * dx + dy * dy + dz * dz), reach = 0.5 * (a->d + b->d);
    return distance < reach * (1.0 - 1e-9);
}

/* Cell index of a coordinate, clamped: clamping is monotone, so two centres less than a cell apart still land in
 * the same or neighbouring cells. */
static int64_t cell_of(double x, double width)
{
    double cell = floor(x / width);
    const double limit = 4e15;
    if (!(cell > -limit))
        cell = -limit;
    if (cell > limit)
        cell = limit;
    return (int64_t)cell;
}

int mpm_find_sphere_overlap(const struct mpm_config *cfg, int *first, int *second)
{
    *first = *second = -1;
    size_t count = 0;
    double width = 0.0;
    for (int i = 0; i < cfg->body_count; i++) {
        const struct mpm_body *b = &cfg->bodies[i];
        if (!b->substrate && b->shape == MPM_SPHERE) {
            count++;
            if (b->d > width)
                width = b->d;
        }
    }
    if (count < 2)
        return 0;
    if (!(width > 0.0) || !isfinite(width))
        width = 1.0;
    struct cell_entry *entries = malloc(count * sizeof *entries);
    if (!entries)
        return -1;
    size_t n = 0;
    for (int i = 0; i < cfg->body_count; i++) {
        const struct mpm_body *b = &cfg->bodies[i];
        if (b->substrate || b->shape != MPM_SPHERE)
            continue;
        for (int k = 0; k < 3; k++)
            entries[n].cell[k] = cell_of(b->center[k], width);
        entries[n++].body = i;
    }
    qsort(entries, count, sizeof *entries, compare_entries);
    /* two overlapping spheres are less than the largest diameter apart: in the same or neighbouring cells */
    int best_i = -1, best_j = -1;
    for (size_t e = 0; e < count; e++) {
        int i = entries[e].body;
        if (best_i >= 0 && i > best_i)
            continue; /* cannot improve on the pair found */
        for (int dx = -1; dx <= 1; dx++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dz = -1; dz <= 1; dz++) {
                    int64_t cell[3] = {entries[e].cell[0] + dx, entries[e].cell[1] + dy, entries[e].cell[2] + dz};
                    for (size_t f = lower_bound(entries, count, cell);
                         f < count && compare_cells(entries[f].cell, cell) == 0; f++) {
                        int j = entries[f].body;
                        if (j <= i || !spheres_overlap(&cfg->bodies[i], &cfg->bodies[j]))
                            continue;
                        if (best_i < 0 || i < best_i || (i == best_i && j < best_j)) {
                            best_i = i;
                            best_j = j;
                        }
                    }
                }
    }
    free(entries);
    if (best_i < 0)
        return 0;
    *first = best_i;
    *second = best_j;
    return 1;
}
