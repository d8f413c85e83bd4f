/* Broad phase of the contact search (Mukherjee & Zohdi Section 4.3, extended to swept spheres).
 *
 * The paper bins particles in cells scaled by the largest diameter and tests neighbouring cells.  With
 * swept-sphere detection a particle reaches as far as its sweep |v| dt, which at the paper's steps is
 * several diameters; cells sized by the largest sweep would hold hundreds of particles in a dense stream.
 * Instead each particle is entered in every cell (side: the largest diameter) that the bounding box of its
 * swept sphere overlaps, and only particles sharing a cell are tested.  A pair is tested in exactly one
 * cell, the one holding the lower corner of the intersection of the two boxes.  Cells are hashed into
 * buckets (O(N) memory whatever the domain), rebuilt every step by a counting sort. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dem/dem_impl.h"

/* Cells per particle per axis stay bounded: a particle far faster than the rest widens the cells instead
 * of filling thousands of them. */
#define MAX_CELLS_PER_SWEEP 8.0
/* Cell side in largest diameters: 2 balances entries per particle (about 3) against pairs per cell. */
#define CELL_DIAMETERS 2.0
/* Boxes are widened by this fraction of the radius so that rounding cannot drop a grazing contact. */
#define BOX_MARGIN 1e-9

static inline uint32_t cell_hash(const int32_t cell[3], size_t bucket_count)
{
    uint64_t h = (uint64_t)(int64_t)cell[0] * 0x9E3779B97F4A7C15ull ^
                 (uint64_t)(int64_t)cell[1] * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)(int64_t)cell[2] * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    return (uint32_t)(h & (bucket_count - 1));
}

/* Clamped so that a particle absurdly far away (about to escape) or a non-finite state (about to be
 * reported) cannot overflow the integer conversion. */
static inline int32_t cell_index(double coordinate, double cell)
{
    double index = floor(coordinate / cell);
    if (!(index > -1073741824.0))
        return index != index ? 0 : -1073741824;
    return index < 1073741824.0 ? (int32_t)index : 1073741824;
}

/* Bounding box of particle i's sphere over the step: [lo, hi]. */
static void swept_box(const struct dem_particles *p, size_t i, double dt, double lo[3], double hi[3])
{
    double radius = 0.5 * p->d[i] * (1.0 + BOX_MARGIN);
    for (int c = 0; c < 3; c++) {
        double start = p->x[3 * i + c], end = start + (p->state[i] == DEM_FLYING ? p->v[3 * i + c] * dt : 0.0);
        lo[c] = fmin(start, end) - radius;
        hi[c] = fmax(start, end) + radius;
    }
}

static double grid_cell_size(const struct dem_particles *p, double dt)
{
    double d_largest = 0.0, sweep_largest = 0.0;
    for (size_t i = 0; i < p->count; i++) {
        d_largest = fmax(d_largest, p->d[i]);
        if (p->state[i] == DEM_FLYING)
            for (int c = 0; c < 3; c++)
                sweep_largest = fmax(sweep_largest, fabs(p->v[3 * i + c]) * dt);
    }
    return CELL_DIAMETERS * fmax(d_largest, sweep_largest / MAX_CELLS_PER_SWEEP) * (1.0 + 1e-12) + 1e-300;
}

static void cell_range(const struct dem_particles *p, size_t i, double dt, double cell, int32_t lo[3], int32_t hi[3])
{
    double box_lo[3], box_hi[3];
    swept_box(p, i, dt, box_lo, box_hi);
    for (int c = 0; c < 3; c++) {
        lo[c] = cell_index(box_lo[c], cell);
        hi[c] = cell_index(box_hi[c], cell);
    }
}

static void ensure_capacity(struct dem_bins *bins, size_t entries)
{
    if (entries <= bins->entry_capacity)
        return;
    bins->entry_capacity = entries + entries / 2 + 1024;
    bins->entries = dem_realloc_or_die(bins->entries, bins->entry_capacity * sizeof *bins->entries);
    bins->scratch = dem_realloc_or_die(bins->scratch, bins->entry_capacity * sizeof *bins->scratch);
    bins->entry_bucket = dem_realloc_or_die(bins->entry_bucket, bins->entry_capacity * sizeof *bins->entry_bucket);
}

static size_t cells_in_range(const int32_t lo[3], const int32_t hi[3])
{
    return (size_t)(hi[0] - lo[0] + 1) * (size_t)(hi[1] - lo[1] + 1) * (size_t)(hi[2] - lo[2] + 1);
}

/* Write the entries of every particle (in particle order) into bins->scratch and their buckets into
 * bins->entry_bucket; returns their number.  Two parallel passes: count each particle's cells, then
 * (after a prefix sum) write them at their offsets, so the order is the same for any thread count. */
static size_t fill_entries(struct dem_bins *bins, const struct dem_particles *p, double dt, size_t buckets)
{
    size_t *offset = dem_realloc_or_die(NULL, (p->count + 1) * sizeof *offset);
    offset[0] = 0;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < p->count; i++) {
        int32_t lo[3], hi[3];
        cell_range(p, i, dt, bins->cell, lo, hi);
        offset[i + 1] = cells_in_range(lo, hi);
    }
    for (size_t i = 0; i < p->count; i++)
        offset[i + 1] += offset[i];
    size_t count = offset[p->count];
    ensure_capacity(bins, count);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < p->count; i++) {
        int32_t lo[3], hi[3];
        cell_range(p, i, dt, bins->cell, lo, hi);
        size_t e = offset[i];
        for (int32_t a = lo[0]; a <= hi[0]; a++)
            for (int32_t b = lo[1]; b <= hi[1]; b++)
                for (int32_t k = lo[2]; k <= hi[2]; k++, e++) {
                    struct dem_bin_entry *entry = &bins->scratch[e];
                    entry->cell[0] = a, entry->cell[1] = b, entry->cell[2] = k;
                    entry->index = (uint32_t)i;
                    bins->entry_bucket[e] = cell_hash(entry->cell, buckets);
                }
    }
    free(offset);
    return count;
}

/* A power of two at least twice the expected number of entries (about 3 per particle). */
static size_t bucket_count_for(size_t particles)
{
    size_t buckets = 1024;
    while (buckets < 8 * particles)
        buckets *= 2;
    return buckets;
}

void broadphase_build(struct dem_bins *bins, const struct dem_particles *p, double dt)
{
    bins->cell = grid_cell_size(p, dt);
    size_t buckets = bucket_count_for(p->count);
    if (buckets != bins->bucket_count) {
        bins->bucket_start = dem_realloc_or_die(bins->bucket_start, (buckets + 1) * sizeof(uint32_t));
        bins->bucket_count = buckets;
    }
    size_t count = fill_entries(bins, p, dt, buckets);
    bins->entry_count = count;
    memset(bins->bucket_start, 0, (buckets + 1) * sizeof(uint32_t));
    for (size_t e = 0; e < count; e++)
        bins->bucket_start[bins->entry_bucket[e] + 1]++;
    for (size_t b = 0; b < buckets; b++)
        bins->bucket_start[b + 1] += bins->bucket_start[b];
    /* counting sort: entries of a bucket stay in particle order */
    uint32_t *fill = dem_realloc_or_die(NULL, buckets * sizeof(uint32_t));
    memcpy(fill, bins->bucket_start, buckets * sizeof(uint32_t));
    for (size_t e = 0; e < count; e++)
        bins->entries[fill[bins->entry_bucket[e]]++] = bins->scratch[e];
    free(fill);
}

void dem_bins_free(struct dem_bins *bins)
{
    free(bins->bucket_start);
    free(bins->entries);
    free(bins->scratch);
    free(bins->entry_bucket);
    memset(bins, 0, sizeof *bins);
}

double time_of_impact(const double dx[3], const double dv[3], double reach, double dt)
{
    double b = dx[0] * dv[0] + dx[1] * dv[1] + dx[2] * dv[2];
    if (b >= 0.0)
        return -1.0; /* separating or at rest relative to each other */
    double c = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] - reach * reach;
    if (c <= 0.0)
        return 0.0;
    double a = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
    double discriminant = b * b - a * c;
    if (discriminant < 0.0)
        return -1.0;
    double s = c / (-b + sqrt(discriminant)); /* the smaller root, in the form without cancellation */
    return s <= dt ? s : -1.0;
}

void candidates_push(struct dem_candidates *list, double s, uint32_t a, uint32_t b, int kind)
{
    if (list->count == list->capacity) {
        list->capacity = list->capacity ? 2 * list->capacity : 64;
        list->items = dem_realloc_or_die(list->items, list->capacity * sizeof *list->items);
    }
    list->items[list->count++] = (struct dem_candidate){s, a, b, kind};
}

static inline int same_cell(const struct dem_bin_entry *a, const struct dem_bin_entry *b)
{
    return a->cell[0] == b->cell[0] && a->cell[1] == b->cell[1] && a->cell[2] == b->cell[2];
}

/* A particle as the pair test sees it: deposited particles do not move. */
struct swept_sphere {
    double x[3], v[3], radius;
    uint32_t index;
    int flying;
};

static struct swept_sphere swept_sphere_of(const struct dem_particles *p, uint32_t i)
{
    struct swept_sphere sphere = {.radius = 0.5 * p->d[i], .index = i, .flying = p->state[i] == DEM_FLYING};
    for (int c = 0; c < 3; c++) {
        sphere.x[c] = p->x[3 * i + c];
        sphere.v[c] = sphere.flying ? p->v[3 * i + c] : 0.0;
    }
    return sphere;
}

/* The pair is tested only in the cell holding the lower corner of the intersection of the two swept
 * boxes; returns 0 if the boxes do not intersect or `cell_here` is not that cell. */
static int owns_pair(const struct swept_sphere *a, const struct swept_sphere *b, const int32_t cell_here[3], double dt,
                     double cell)
{
    for (int c = 0; c < 3; c++) {
        double ra = a->radius * (1.0 + BOX_MARGIN), rb = b->radius * (1.0 + BOX_MARGIN);
        double a_end = a->x[c] + a->v[c] * dt, b_end = b->x[c] + b->v[c] * dt;
        double lo = fmax(fmin(a->x[c], a_end) - ra, fmin(b->x[c], b_end) - rb);
        double hi = fmin(fmax(a->x[c], a_end) + ra, fmax(b->x[c], b_end) + rb);
        if (lo > hi || cell_index(lo, cell) != cell_here[c])
            return 0;
    }
    return 1;
}

/* Entries of a bucket are in particle order, so first < second; a deposited particle goes second. */
static void test_pair(const struct dem_particles *p, uint32_t first, uint32_t second, const int32_t cell_here[3],
                      double dt, double cell, struct dem_candidates *out)
{
    if (p->state[first] != DEM_FLYING && p->state[second] != DEM_FLYING)
        return;
    struct swept_sphere a = swept_sphere_of(p, first), b = swept_sphere_of(p, second);
    if (!owns_pair(&a, &b, cell_here, dt, cell))
        return;
    double dx[3] = {b.x[0] - a.x[0], b.x[1] - a.x[1], b.x[2] - a.x[2]};
    double dv[3] = {b.v[0] - a.v[0], b.v[1] - a.v[1], b.v[2] - a.v[2]};
    double t_hit = time_of_impact(dx, dv, a.radius + b.radius, dt);
    if (t_hit < 0.0)
        return;
    if (a.flying)
        candidates_push(out, t_hit, first, second, CONTACT_PAIR);
    else
        candidates_push(out, t_hit, second, first, CONTACT_PAIR);
}

void broadphase_pairs(const struct dem_bins *bins, const struct dem_particles *p, double dt, struct dem_candidates *out)
{
#pragma omp parallel
    {
        struct dem_candidates local = {0};
#pragma omp for schedule(dynamic, 256) nowait
        for (size_t bucket = 0; bucket < bins->bucket_count; bucket++) {
            uint32_t first = bins->bucket_start[bucket], end = bins->bucket_start[bucket + 1];
            for (uint32_t i = first; i + 1 < end; i++)
                for (uint32_t j = i + 1; j < end; j++) {
                    const struct dem_bin_entry *a = &bins->entries[i], *b = &bins->entries[j];
                    if (same_cell(a, b) && a->index != b->index)
                        test_pair(p, a->index, b->index, a->cell, dt, bins->cell, &local);
                }
        }
#pragma omp critical(dem_broadphase_merge)
        for (size_t k = 0; k < local.count; k++)
            candidates_push(out, local.items[k].s, local.items[k].a, local.items[k].b, local.items[k].kind);
        free(local.items);
    }
}

int broadphase_visit_box(const struct dem_bins *bins, const double lo[3], const double hi[3], size_t max_cells,
                         void (*visit)(uint32_t index, void *context), void *context)
{
    int32_t first[3], last[3];
    for (int c = 0; c < 3; c++) {
        first[c] = cell_index(lo[c], bins->cell);
        last[c] = cell_index(hi[c], bins->cell);
    }
    if (cells_in_range(first, last) > max_cells)
        return -1;
    int32_t here[3];
    for (here[0] = first[0]; here[0] <= last[0]; here[0]++)
        for (here[1] = first[1]; here[1] <= last[1]; here[1]++)
            for (here[2] = first[2]; here[2] <= last[2]; here[2]++) {
                uint32_t bucket = cell_hash(here, bins->bucket_count);
                for (uint32_t e = bins->bucket_start[bucket]; e < bins->bucket_start[bucket + 1]; e++) {
                    const struct dem_bin_entry *entry = &bins->entries[e];
                    if (entry->cell[0] == here[0] && entry->cell[1] == here[1] && entry->cell[2] == here[2])
                        visit(entry->index, context);
                }
            }
    return 0;
}
