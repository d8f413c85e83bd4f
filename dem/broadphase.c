/* Broad phase of the contact search (Mukherjee & Zohdi Section 4.3, extended to swept spheres).
 *
 * The paper bins particles in cells scaled by the largest diameter and tests neighbouring cells.  With
 * swept-sphere detection a particle reaches as far as its sweep |v| dt, which at the paper's steps is
 * several diameters; cells sized by the largest sweep would hold hundreds of particles in a dense stream.
 * Instead each particle is entered in every cell (side: the largest diameter) that the bounding box of its
 * swept sphere overlaps, and only particles sharing a cell are tested.  A pair is tested in exactly one
 * cell, the one holding the lower corner of the intersection of the two boxes.  Cells are hashed into
 * buckets (O(N) memory whatever the domain), filled by a counting sort.
 *
 * The grid is not rebuilt every step.  Each particle enters it with a reach box: its swept sphere over the
 * next `horizon` steps at its current velocity, widened by a skin of SKIN_RADII radii.  The pairs whose reach
 * boxes overlap are listed.  While every particle's swept box of the current step lies inside its reach box,
 * every pair whose swept boxes overlap is in the list, so testing the listed pairs finds exactly the contacts
 * a fresh grid would (the same box test and time of impact on the same numbers): in free flight the grid is
 * rebuilt every few steps instead of every step.  The horizon adapts (next_horizon).
 *
 * Between builds the grid and the list are repaired rather than rebuilt when only a few particles change:
 * a particle whose swept box left its reach box (a rebound, a deposit) or that was injected gets a new reach
 * box and joins the repaired set; its old pairs are dropped, and its new ones are found from the grid cells
 * of its new box (partners still as built, by the same lower-corner rule, so each pair once) and by testing
 * the other repaired particles directly (their grid entries are stale and skipped).  Removed particles are
 * compacted out of the grid and the list (dem_broadphase_compact).  Past REPAIR_MIN + count / REPAIR_SHARE
 * repaired particles the grid is rebuilt.  The list then still holds every pair whose swept boxes overlap,
 * once: the contacts found are those of a fresh build. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/fastmath.h"
#include "dem/dem_impl.h"

/* Cells per particle per axis stay bounded: a particle far faster than the rest widens the cells instead
 * of filling thousands of them.  4 (a reach box along the fastest sweep spans about 3 cells) rather than 8:
 * half the entries, in free flight 20 instructions fewer per particle-step, Table 1 on 1 thread no slower
 * (BENCHMARKS.md's history in git). */
#define MAX_CELLS_PER_SWEEP 4.0
/* Cell side in largest diameters: 2 balances entries per particle (about 3) against pairs per cell. */
#define CELL_DIAMETERS 2.0
/* Reach boxes: 2 to 16 steps ahead (or plain swept boxes), and a skin of this many radii for the bending of
 * paths; after PLAIN_BUILDS plain builds a horizon is tried again. */
#define MIN_HORIZON  2.0
#define MAX_HORIZON  16.0
#define SKIN_RADII   0.5
#define PLAIN_BUILDS 16
/* Repairs: a rebuild once more than REPAIR_MIN + count / REPAIR_SHARE particles are repaired, or when a new
 * reach box spans more than REPAIR_MAX_CELLS cells (cells sized for slower particles). */
#define REPAIR_MIN       64
#define REPAIR_SHARE     32
#define REPAIR_MAX_CELLS 512
/* The index of a grid entry whose particle was removed since the build. */
#define REMOVED_ENTRY UINT32_MAX
/* Values of bins->repaired: in the grid as built, repaired in an earlier step, repaired in this one. */
enum { AS_BUILT = 0, REPAIRED = 1, RENEWED = 2 };

/* The bucket of a cell: cells along z, and then along x, go to neighbouring buckets (a reach box spans cells
 * along its velocity, and particles are stored by injection or file order, near their neighbours), each
 * y-row somewhere at random.  The counting sort's increments and writes then stay within a few cache lines
 * where a hash of all three scattered them (free flight: the broad phase's L1 misses fall by 30 %, its share
 * of the time loop from 17 % to 15 %; the dense cloud: -14 % misses for +1.5 % instructions).  Which buckets
 * the cells share changes no result (bucket_count_for). */
static inline uint32_t cell_hash(const int32_t cell[3], size_t bucket_count)
{
    uint64_t row = (uint64_t)(int64_t)cell[1] * 0x9E3779B97F4A7C15ull;
    row ^= row >> 29;
    uint64_t h = (uint64_t)(int64_t)cell[2] + 64u * (uint64_t)(int64_t)cell[0] + row;
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

/* fmin and fmax without the libm calls (gcc keeps them calls: about 3 % of a free-flight step went to them).
 * The same value for every input, signed zeros and NaN included: x86-64's minsd/maxsd, which return the
 * second operand when the two are equal, and the other operand when one is a NaN. */
static inline double lesser(double a, double b)
{
    return (a < b) | (b != b) ? a : b;
}
static inline double greater(double a, double b)
{
    return (a > b) | (b != b) ? a : b;
}

/* The box that particle i's sphere can reach within `horizon` steps at its current velocity, widened by the
 * skin; a deposited particle reaches its sphere only. */
static void reach_box(const struct dem_particles *p, size_t i, double dt, double horizon, double lo[3], double hi[3])
{
    int flying = p->state[i] == DEM_FLYING;
    /* horizon 0: the swept box of this step alone, as a grid rebuilt every step would hold it */
    double skin = flying && horizon > 0.0 ? SKIN_RADII : 0.0;
    /* the contact radius (with the drag skin) as reach_flags tests it, then the skin of the horizon */
    double radius = dem_contact_radius(p, i) * (1.0 + DEM_BOX_MARGIN) + 0.5 * p->d[i] * skin;
    double span = horizon > 0.0 ? dt * horizon : dt;
    for (int c = 0; c < 3; c++) {
        double start = p->x[3 * i + c], end = start + (flying ? p->v[3 * i + c] * span : 0.0);
        lo[c] = lesser(start, end) - radius;
        hi[c] = greater(start, end) + radius;
    }
}

/* Cells of two largest diameters, or wider when the reach of the fastest particle spans more than
 * MAX_CELLS_PER_SWEEP / 2 of them: from the largest diameter and the largest speed along an axis of a flying
 * particle (rebuild finds them). */
static double grid_cell_size(double d_largest, double speed_largest, double dt, double horizon)
{
    double sweep_largest = speed_largest * dt * (horizon > 0.0 ? horizon : 1.0);
    double size = d_largest > sweep_largest / MAX_CELLS_PER_SWEEP ? d_largest : sweep_largest / MAX_CELLS_PER_SWEEP;
    return CELL_DIAMETERS * size * (1.0 + 1e-12) + 1e-300;
}

static void box_cells(const double box_lo[3], const double box_hi[3], double cell, int32_t lo[3], int32_t hi[3])
{
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

/* A power of two at least twice the number of entries: short chains, and the counting sort's passes over
 * the buckets cost no more than those over the entries.  (Sized from the particles, at 8 per particle, the
 * buckets outnumbered the entries 9 to 1 late in the Table 1 case, where half the particles are deposits
 * with one entry each, and clearing and summing them was most of a rebuild.)  Which buckets the cells share
 * changes no result: a pair is listed from one cell, whatever its bucket, and the contacts are sorted. */
static size_t bucket_count_for(size_t entries)
{
    size_t buckets = 1024;
    while (buckets < 2 * entries)
        buckets *= 2;
    return buckets;
}

static void set_bucket_count(struct dem_bins *bins, size_t buckets)
{
    if (buckets == bins->bucket_count)
        return;
    bins->bucket_start = dem_realloc_or_die(bins->bucket_start, (buckets + 1) * sizeof(uint32_t));
    bins->bucket_count = buckets;
}

/* Write the entries of every particle (in particle order) into bins->scratch and their buckets into
 * bins->entry_bucket, the bucket count chosen for them; returns their number.  Two parallel passes: find
 * each particle's cells (kept, so that the second pass does not divide and round again), then (after a
 * prefix sum) write them at their offsets, so the order is the same for any thread count. */
static size_t fill_entries(struct dem_bins *bins, const struct dem_particles *p)
{
    size_t *offset = dem_realloc_or_die(NULL, (p->count + 1) * sizeof *offset);
    int32_t *cells = dem_realloc_or_die(NULL, (p->count ? p->count : 1) * 6 * sizeof *cells);
    offset[0] = 0;
#pragma omp parallel for schedule(static) if (p->count >= DEM_PARALLEL_MIN)
    for (size_t i = 0; i < p->count; i++) {
        int32_t *lo = cells + 6 * i, *hi = lo + 3;
        box_cells(bins->reach_lo + 3 * i, bins->reach_hi + 3 * i, bins->cell, lo, hi);
        offset[i + 1] = cells_in_range(lo, hi);
    }
    for (size_t i = 0; i < p->count; i++)
        offset[i + 1] += offset[i];
    size_t count = offset[p->count];
    ensure_capacity(bins, count);
    set_bucket_count(bins, bucket_count_for(count));
    const size_t buckets = bins->bucket_count;
#pragma omp parallel for schedule(static) if (p->count >= DEM_PARALLEL_MIN)
    for (size_t i = 0; i < p->count; i++) {
        const int32_t *lo = cells + 6 * i, *hi = lo + 3;
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
    free(cells);
    free(offset);
    return count;
}

/* The counting sort of the entries by bucket (stable: a bucket's entries stay in particle order) in two stable
 * passes that run in parallel: by group of consecutive buckets (SORT_GROUPS groups; slices of the entries
 * counted and scattered side by side, each slice's entries of a group after those of the slices before),
 * then each group by bucket on its own.  Stable twice is the order of one stable sort, whatever the
 * threads: the same grid as a serial sort, and the groups' counts fit in the first-level cache where the
 * serial sort's random increments over all buckets missed. */
#define SORT_GROUPS 256
#define SORT_SLICES 16

static size_t slice_bound(size_t count, size_t k)
{
    return count * k / SORT_SLICES;
}

/* Entries [first, end) of bins->scratch: how many fall in each group. */
static void count_groups(const struct dem_bins *bins, size_t first, size_t end, int group_shift, uint32_t *counts)
{
    memset(counts, 0, SORT_GROUPS * sizeof *counts);
    for (size_t e = first; e < end; e++)
        counts[bins->entry_bucket[e] >> group_shift]++;
}

/* The counts of (slice, group) become where each slice's entries of a group start: group by group, slices in
 * order.  group_start[g]: where group g starts. */
static void group_offsets(uint32_t (*counts)[SORT_GROUPS], uint32_t *group_start)
{
    uint32_t sum = 0;
    for (size_t g = 0; g < SORT_GROUPS; g++) {
        group_start[g] = sum;
        for (size_t k = 0; k < SORT_SLICES; k++) {
            uint32_t n = counts[k][g];
            counts[k][g] = sum;
            sum += n;
        }
    }
    group_start[SORT_GROUPS] = sum;
}

static void scatter_groups(struct dem_bins *bins, size_t first, size_t end, int group_shift, uint32_t *cursor)
{
    for (size_t e = first; e < end; e++)
        bins->entries[cursor[bins->entry_bucket[e] >> group_shift]++] = bins->scratch[e];
}

/* Group g's entries, in bins->entries, to the same places of bins->scratch in bucket order; the starts of the
 * group's buckets.  The bucket comes from the cell again (cheaper than carrying it along). */
static void sort_group(struct dem_bins *bins, size_t g, size_t per_group, const uint32_t *group_start, uint32_t *fill)
{
    const size_t buckets = bins->bucket_count, b0 = g * per_group;
    uint32_t *start = bins->bucket_start + b0, *cursor = fill + b0;
    memset(cursor, 0, per_group * sizeof *cursor);
    for (uint32_t e = group_start[g]; e < group_start[g + 1]; e++)
        cursor[cell_hash(bins->entries[e].cell, buckets) - b0]++;
    uint32_t sum = group_start[g];
    for (size_t b = 0; b < per_group; b++) {
        start[b] = sum;
        sum += cursor[b];
        cursor[b] = start[b];
    }
    for (uint32_t e = group_start[g]; e < group_start[g + 1]; e++)
        bins->scratch[cursor[cell_hash(bins->entries[e].cell, buckets) - b0]++] = bins->entries[e];
}

/* The entries of bins->scratch (buckets in bins->entry_bucket) sorted into bins->entries (the two arrays
 * trade places), bins->bucket_start set. */
static void sort_entries(struct dem_bins *bins, size_t count)
{
    const size_t per_group = bins->bucket_count / SORT_GROUPS; /* at least 4: 1024 buckets or more */
    int group_shift = 0; /* per_group is a power of two: a shift, not a division, finds an entry's group */
    while (((size_t)1 << group_shift) < per_group)
        group_shift++;
    uint32_t(*counts)[SORT_GROUPS] = dem_realloc_or_die(NULL, SORT_SLICES * sizeof *counts);
    uint32_t *fill = dem_realloc_or_die(NULL, bins->bucket_count * sizeof *fill);
    uint32_t group_start[SORT_GROUPS + 1];
#pragma omp parallel
    {
#pragma omp for schedule(static)
        for (size_t k = 0; k < SORT_SLICES; k++)
            count_groups(bins, slice_bound(count, k), slice_bound(count, k + 1), group_shift, counts[k]);
#pragma omp single
        group_offsets(counts, group_start);
#pragma omp for schedule(static)
        for (size_t k = 0; k < SORT_SLICES; k++)
            scatter_groups(bins, slice_bound(count, k), slice_bound(count, k + 1), group_shift, counts[k]);
#pragma omp for schedule(dynamic, 16)
        for (size_t g = 0; g < SORT_GROUPS; g++)
            sort_group(bins, g, per_group, group_start, fill);
    }
    struct dem_bin_entry *sorted = bins->scratch;
    bins->scratch = bins->entries;
    bins->entries = sorted;
    bins->bucket_start[bins->bucket_count] = (uint32_t)count;
    free(fill);
    free(counts);
}

/* sort_entries on one thread: one stable counting sort over all buckets, fewer passes than the two of
 * sort_entries (about half the work, early in a spray), the same order. */
static void sort_entries_serial(struct dem_bins *bins, size_t count)
{
    const size_t buckets = bins->bucket_count;
    memset(bins->bucket_start, 0, (buckets + 1) * sizeof(uint32_t));
    for (size_t e = 0; e < count; e++)
        bins->bucket_start[bins->entry_bucket[e] + 1]++;
    for (size_t b = 0; b < buckets; b++)
        bins->bucket_start[b + 1] += bins->bucket_start[b];
    uint32_t *fill = dem_realloc_or_die(NULL, buckets * sizeof(uint32_t));
    memcpy(fill, bins->bucket_start, buckets * sizeof(uint32_t));
    for (size_t e = 0; e < count; e++)
        bins->entries[fill[bins->entry_bucket[e]]++] = bins->scratch[e];
    free(fill);
}

/* The two-pass parallel sort costs about twice the serial one's CPU time: on 2 threads it was slower than the
 * serial sort on one (interleaved, 2 threads, free flight: broad phase 0.109-0.137 s with it against
 * 0.101-0.110 s without, time loop -2 %; colliding cloud and Table 1 within the noise), so it serves larger
 * teams only. */
#define SORT_PARALLEL_MIN_THREADS 3

static void grid_fill(struct dem_bins *bins, const struct dem_particles *p)
{
    bins->entry_count = fill_entries(bins, p);
    if (bins->entry_count >= DEM_PARALLEL_MIN && omp_get_max_threads() >= SORT_PARALLEL_MIN_THREADS)
        sort_entries(bins, bins->entry_count);
    else
        sort_entries_serial(bins, bins->entry_count);
}

void dem_bins_free(struct dem_bins *bins)
{
    free(bins->bucket_start);
    free(bins->entries);
    free(bins->scratch);
    free(bins->entry_bucket);
    free(bins->reach_lo);
    free(bins->reach_hi);
    free(bins->built_id);
    free(bins->built_flying);
    free(bins->reach_verified);
    free(bins->repaired);
    free(bins->repaired_list);
    free(bins->failing);
    free(bins->pairs);
    memset(bins, 0, sizeof *bins);
}

double dem_time_of_impact(const double dx[3], const double dv[3], double reach, double dt)
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

void dem_candidates_push(struct dem_candidates *list, double s, uint32_t a, uint32_t b, int kind)
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
    struct swept_sphere sphere = {.radius = dem_contact_radius(p, i), .index = i, .flying = p->state[i] == DEM_FLYING};
    for (int c = 0; c < 3; c++) {
        sphere.x[c] = p->x[3 * i + c];
        sphere.v[c] = sphere.flying ? p->v[3 * i + c] : 0.0;
    }
    return sphere;
}

/* Do the boxes of the two spheres' sweeps over the step intersect?  (The boxes are those the grid used to
 * hold, widened by DEM_BOX_MARGIN.) */
static int swept_boxes_overlap(const struct swept_sphere *a, const struct swept_sphere *b, double dt)
{
    for (int c = 0; c < 3; c++) {
        double ra = a->radius * (1.0 + DEM_BOX_MARGIN), rb = b->radius * (1.0 + DEM_BOX_MARGIN);
        double a_end = a->x[c] + a->v[c] * dt, b_end = b->x[c] + b->v[c] * dt;
        double lo = greater(lesser(a->x[c], a_end) - ra, lesser(b->x[c], b_end) - rb);
        double hi = lesser(greater(a->x[c], a_end) + ra, greater(b->x[c], b_end) + rb);
        if (lo > hi)
            return 0;
    }
    return 1;
}

/* A listed pair, first < second: a contact if the swept boxes intersect and the spheres touch while
 * approaching within the step.  The flying particle goes first in the contact. */
static void test_pair(const struct dem_particles *p, uint32_t first, uint32_t second, double dt,
                      struct dem_candidates *out)
{
    if (p->state[first] != DEM_FLYING && p->state[second] != DEM_FLYING)
        return;
    struct swept_sphere a = swept_sphere_of(p, first), b = swept_sphere_of(p, second);
    if (!swept_boxes_overlap(&a, &b, dt))
        return;
    double dx[3] = {b.x[0] - a.x[0], b.x[1] - a.x[1], b.x[2] - a.x[2]};
    double dv[3] = {b.v[0] - a.v[0], b.v[1] - a.v[1], b.v[2] - a.v[2]};
    double t_hit = dem_time_of_impact(dx, dv, a.radius + b.radius, dt);
    if (t_hit < 0.0)
        return;
    if (a.flying)
        dem_candidates_push(out, t_hit, first, second, CONTACT_PAIR);
    else
        dem_candidates_push(out, t_hit, second, first, CONTACT_PAIR);
}

void dem_broadphase_pairs(const struct dem_bins *bins, const struct dem_particles *p, double dt,
                          struct dem_candidates *out)
{
#pragma omp for schedule(static) nowait
    for (size_t k = 0; k < bins->pair_count; k++)
        test_pair(p, bins->pairs[2 * k], bins->pairs[2 * k + 1], dt, out);
}

/* ---------------------------------------------------------------- the pair list */

/* Do the reach boxes of i and j intersect with the lower corner of the intersection in cell_here?  (A pair
 * is listed from that one cell only.) */
static int owns_reach_pair(const struct dem_bins *bins, uint32_t i, uint32_t j, const int32_t cell_here[3])
{
    const double *lo_i = bins->reach_lo + 3 * i, *hi_i = bins->reach_hi + 3 * i;
    const double *lo_j = bins->reach_lo + 3 * j, *hi_j = bins->reach_hi + 3 * j;
    const double cell = bins->cell;
    for (int c = 0; c < 3; c++) {
        double lo = lo_i[c] > lo_j[c] ? lo_i[c] : lo_j[c];
        double hi = hi_i[c] < hi_j[c] ? hi_i[c] : hi_j[c];
        if (lo > hi || cell_index(lo, cell) != cell_here[c])
            return 0;
    }
    return 1;
}

static void pair_push(struct dem_bins *list, uint32_t a, uint32_t b)
{
    if (list->pair_count == list->pair_capacity) {
        list->pair_capacity = list->pair_capacity ? 2 * list->pair_capacity : 256;
        list->pairs = dem_realloc_or_die(list->pairs, 2 * list->pair_capacity * sizeof *list->pairs);
    }
    list->pairs[2 * list->pair_count] = a;
    list->pairs[2 * list->pair_count + 1] = b;
    list->pair_count++;
}

/* The pairs, not both deposited, whose reach boxes intersect with the lower corner of the intersection in a
 * cell of this bucket: entries of a bucket are in particle order, so a < b. */
static void list_bucket_pairs(const struct dem_bins *bins, const struct dem_particles *p, size_t bucket,
                              struct dem_bins *out)
{
    uint32_t first = bins->bucket_start[bucket], end = bins->bucket_start[bucket + 1];
    for (uint32_t e = first; e + 1 < end; e++)
        for (uint32_t f = e + 1; f < end; f++) {
            const struct dem_bin_entry *a = &bins->entries[e], *b = &bins->entries[f];
            if (!same_cell(a, b) || a->index == b->index)
                continue;
            if (p->state[a->index] != DEM_FLYING && p->state[b->index] != DEM_FLYING)
                continue;
            if (owns_reach_pair(bins, a->index, b->index, a->cell))
                pair_push(out, a->index, b->index);
        }
}

/* Every pair, not both deposited, whose reach boxes intersect.  Only buckets of two entries or more can hold a
 * pair, and most buckets hold fewer (there are twice as many as entries): they are found PAIR_BUCKETS at a
 * time by a loop without branches, which vectorises, where a loop over every bucket cost ~10 instructions
 * per bucket. */
#define PAIR_BUCKETS 1024
static void list_pairs(struct dem_bins *bins, const struct dem_particles *p)
{
    bins->pair_count = 0;
    const size_t chunks = (bins->bucket_count + PAIR_BUCKETS - 1) / PAIR_BUCKETS;
#pragma omp parallel if (p->count >= DEM_PARALLEL_MIN)
    {
        struct dem_bins local = {0}; /* only its pair list is used */
#pragma omp for schedule(dynamic, 1) nowait
        for (size_t chunk = 0; chunk < chunks; chunk++) {
            const size_t first = chunk * PAIR_BUCKETS;
            const size_t n = bins->bucket_count - first < PAIR_BUCKETS ? bins->bucket_count - first : PAIR_BUCKETS;
            const uint32_t *start = bins->bucket_start + first;
            uint8_t crowded[PAIR_BUCKETS];
            for (size_t k = 0; k < n; k++)
                crowded[k] = (uint8_t)(start[k + 1] - start[k] >= 2);
            for (const uint8_t *at = memchr(crowded, 1, n); at; at = memchr(at + 1, 1, n - (size_t)(at + 1 - crowded)))
                list_bucket_pairs(bins, p, first + (size_t)(at - crowded), &local);
        }
#pragma omp critical(dem_broadphase_list_merge)
        for (size_t k = 0; k < local.pair_count; k++)
            pair_push(bins, local.pairs[2 * k], local.pairs[2 * k + 1]);
        free(local.pairs);
    }
}

/* ---------------------------------------------------------------- building and keeping */

static void ensure_particle_capacity(struct dem_bins *bins, size_t count)
{
    if (count <= bins->built_capacity)
        return;
    size_t old_capacity = bins->built_capacity;
    bins->built_capacity = count + count / 2 + 1024;
    bins->reach_lo = dem_realloc_or_die(bins->reach_lo, 3 * bins->built_capacity * sizeof *bins->reach_lo);
    bins->reach_hi = dem_realloc_or_die(bins->reach_hi, 3 * bins->built_capacity * sizeof *bins->reach_hi);
    bins->built_id = dem_realloc_or_die(bins->built_id, bins->built_capacity * sizeof *bins->built_id);
    bins->built_flying = dem_realloc_or_die(bins->built_flying, bins->built_capacity);
    bins->reach_verified = dem_realloc_or_die(bins->reach_verified, bins->built_capacity);
    memset(bins->reach_verified + old_capacity, 0, bins->built_capacity - old_capacity);
    bins->repaired = dem_realloc_or_die(bins->repaired, bins->built_capacity);
    bins->repaired_list = dem_realloc_or_die(bins->repaired_list, bins->built_capacity * sizeof *bins->repaired_list);
    bins->failing = dem_realloc_or_die(bins->failing, bins->built_capacity * sizeof *bins->failing);
}

/* inside[i] for the particles [first, end): is its swept box of the step inside its reach box, is it the
 * same particle as at the build, and not deposited then and flying now?  A particle deposited at the build
 * (or its repair) is still where its box was made for it (deposits never move), so it passes whatever the
 * test says.  No branches, so that gcc vectorises the loop (the sweep of a deposited particle, at rest, is
 * v * 0; no lesser or greater). */
FM_INLINE void reach_flags_with(const struct dem_bins *bins, const struct dem_particles *p, double dt, size_t first,
                                size_t end, uint8_t *restrict inside, int with_skin)
{
    /* local restrict copies: the stores to inside[] cannot change them */
    const double *restrict x = p->x, *restrict v = p->v, *restrict d = p->d, *restrict drag_skin = p->skin;
    const double no_skin = 0.0;
    const double *restrict reach_lo = bins->reach_lo, *restrict reach_hi = bins->reach_hi;
    const int64_t *restrict id = p->id, *restrict built_id = bins->built_id;
    const uint8_t *restrict state = p->state, *restrict built_flying = bins->built_flying;
    for (size_t i = first; i < end; i++) {
        int same = id[i] == built_id[i], flying = state[i] == DEM_FLYING;
        double skin = with_skin ? drag_skin[i] : no_skin; /* with_skin: a constant where inlined */
        double radius = (0.5 * d[i] + fm_select(flying, skin, 0.0)) * (1.0 + DEM_BOX_MARGIN), span = flying ? dt : 0.0;
        int holds = same & (built_flying[i] | !flying);
        for (int c = 0; c < 3; c++) /* a NaN fails here, a harmless extra repair */
            holds &=
                dem_sweep_inside(x[3 * i + c], v[3 * i + c], span, radius, reach_lo[3 * i + c], reach_hi[3 * i + c]);
        inside[i] = (uint8_t)(holds | (same & !built_flying[i]));
    }
}

/* The drag skins (dem_contact_radius) widen the flying particles' spheres; none where the particles have
 * none (a broad phase run on its own, as tests/test_broadphase.c does). */
static void reach_flags(const struct dem_bins *bins, const struct dem_particles *p, double dt, size_t first, size_t end,
                        uint8_t *restrict inside)
{
    if (p->skin)
        reach_flags_with(bins, p, dt, first, end, inside, 1);
    else
        reach_flags_with(bins, p, dt, first, end, inside, 0);
}

/* Are all n flags (0 or 1) set?  A loop that vectorises. */
static int all_set(const uint8_t *flags, size_t n)
{
    uint8_t all = 1;
    for (size_t k = 0; k < n; k++)
        all &= flags[k];
    return all;
}

/* Is every particle of [first, end) verified by the integration or a deposit of the build?  A loop that
 * vectorises. */
static int run_needs_no_box_test(const struct dem_bins *bins, size_t first, size_t end)
{
    uint8_t all = 1;
    for (size_t i = first; i < end; i++)
        all &= bins->reach_verified[i] | !bins->built_flying[i];
    return all;
}

/* reach_flags in runs of RUN_DEPOSITS particles, where it can be answered without the box test:
 * - a particle that the integration verified (bins->reach_verified: it flew at the build and flies on, and its
 *   swept box of this step lies in its reach box, tested on the same numbers) passes: `same` holds for every
 *   particle below built_count (removals move the built arrays with the particles, or make the next build a
 *   rebuild, which clears the verifications), so a run of them all is answered without reading the ids;
 * - a deposit of the build passes if it is the same particle (deposits never move): reach_flags answers `same`
 *   for it, which the ids alone give, without the 100-odd bytes per particle of the box test.  Late in a spray
 *   most particles are deposits, and the oldest runs are all deposits.
 * The verifications are used once: cleared here. */
#define RUN_DEPOSITS 64
static void reach_flags_of_runs(const struct dem_bins *bins, const struct dem_particles *p, double dt, size_t first,
                                size_t end, uint8_t *restrict verified, uint8_t *restrict inside)
{
    for (size_t run = first; run < end; run += RUN_DEPOSITS) {
        size_t run_end = run + RUN_DEPOSITS < end ? run + RUN_DEPOSITS : end;
        if (all_set(verified + run, run_end - run)) {
            memset(inside + run, 1, run_end - run);
        } else if (run_needs_no_box_test(bins, run, run_end)) {
            for (size_t i = run; i < run_end; i++)
                inside[i] = p->id[i] == bins->built_id[i];
        } else {
            reach_flags(bins, p, dt, run, run_end, inside);
        }
        memset(verified + run, 0, run_end - run);
    }
}

static size_t repair_limit(size_t count)
{
    return REPAIR_MIN + count / REPAIR_SHARE;
}

/* Particle i failed the test of reach_flags, or was injected since: list it in bins->failing.  Returns
 * 0 if the repaired set would then exceed its limit. */
static int note_failing(struct dem_bins *bins, size_t i, size_t *grown, size_t limit)
{
    *grown += bins->repaired[i] == AS_BUILT;
    if (bins->repaired_count + *grown > limit)
        return 0;
    bins->failing[bins->failing_count++] = (uint32_t)i;
    return 1;
}

/* The particles whose grid entries and pairs no longer hold this step's contacts, in bins->failing in index
 * order: those that fail reach_flags and those injected since the build.  Returns 0 when they are too many
 * to repair. */
static int collect_failing(struct dem_bins *bins, const struct dem_particles *p, double dt)
{
    uint8_t *inside = dem_realloc_or_die(NULL, bins->built_count ? bins->built_count : 1);
    const size_t chunk = 1024, chunks = (bins->built_count + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) if (bins->built_count >= DEM_PARALLEL_MIN)
    for (size_t k = 0; k < chunks; k++)
        reach_flags_of_runs(bins, p, dt, k * chunk,
                            (k + 1) * chunk < bins->built_count ? (k + 1) * chunk : bins->built_count,
                            bins->reach_verified, inside);
    ensure_particle_capacity(bins, p->count);
    /* the integration's marks of the particles injected since: none (their slots may hold removed ones') */
    memset(bins->reach_verified + bins->built_count, 0, p->count - bins->built_count);
    size_t limit = repair_limit(p->count), grown = 0;
    int fits = 1;
    bins->failing_count = 0;
    for (const uint8_t *next = inside, *end = inside + bins->built_count; fits && next < end; next++) {
        next = memchr(next, 0, (size_t)(end - next));
        if (!next)
            break;
        fits = note_failing(bins, (size_t)(next - inside), &grown, limit);
    }
    for (size_t i = bins->built_count; i < p->count && fits; i++) {
        bins->repaired[i] = AS_BUILT;
        fits = note_failing(bins, i, &grown, limit);
    }
    free(inside);
    return fits;
}

static void rebuild(struct dem_bins *bins, const struct dem_particles *p, double dt)
{
    ensure_particle_capacity(bins, p->count);
    /* The extremes for the cell size in the same pass: a maximum is exact, the same for any split of the
     * particles (a NaN never wins a comparison, here as in OpenMP's combination of the threads' maxima). */
    double d_largest = 0.0, speed_largest = 0.0;
#pragma omp parallel for schedule(static) reduction(max : d_largest, speed_largest) if (p->count >= DEM_PARALLEL_MIN)
    for (size_t i = 0; i < p->count; i++) {
        reach_box(p, i, dt, bins->horizon, bins->reach_lo + 3 * i, bins->reach_hi + 3 * i);
        bins->built_id[i] = p->id[i];
        bins->built_flying[i] = p->state[i] == DEM_FLYING;
        double reach_d = 2.0 * dem_contact_radius(p, i); /* with the drag skin */
        d_largest = reach_d > d_largest ? reach_d : d_largest;
        for (int c = 0; c < 3 && bins->built_flying[i]; c++) {
            double speed = fabs(p->v[3 * i + c]);
            speed_largest = speed > speed_largest ? speed : speed_largest;
        }
    }
    bins->cell = grid_cell_size(d_largest, speed_largest, dt, bins->horizon);
    bins->built_count = p->count;
    memset(bins->repaired, AS_BUILT, p->count);
    memset(bins->reach_verified, 0, p->count); /* made for the boxes replaced */
    bins->repaired_count = 0;
    grid_fill(bins, p);
    list_pairs(bins, p);
    bins->age = 0;
    bins->builds++;
}

/* The horizon of the next build.  One that served at least half its horizon may reach twice as far; one
 * that served only its own step (paths change every step: a dense, colliding cloud) falls back to plain
 * swept boxes, rebuilt every step as before, and tries a horizon again after PLAIN_BUILDS of them. */
static void next_horizon(struct dem_bins *bins)
{
    if (!bins->reach_lo) {
        bins->horizon = MIN_HORIZON;
    } else if (bins->horizon == 0.0) {
        if (++bins->plain_builds >= PLAIN_BUILDS)
            bins->horizon = MIN_HORIZON;
    } else if ((double)bins->age >= 0.5 * bins->horizon) {
        bins->horizon = bins->horizon * 2.0 < MAX_HORIZON ? bins->horizon * 2.0 : MAX_HORIZON;
    } else if (bins->age == 0) {
        bins->horizon = 0.0;
        bins->plain_builds = 0;
    } else {
        bins->horizon = bins->horizon * 0.5 > MIN_HORIZON ? bins->horizon * 0.5 : MIN_HORIZON;
    }
}

/* ---------------------------------------------------------------- repairs */

static int both_deposited(const struct dem_particles *p, uint32_t a, uint32_t b)
{
    return p->state[a] != DEM_FLYING && p->state[b] != DEM_FLYING;
}

static void pair_push_ordered(struct dem_bins *bins, uint32_t a, uint32_t b)
{
    if (a < b)
        pair_push(bins, a, b);
    else
        pair_push(bins, b, a);
}

/* The test of owns_reach_pair without the cell. */
static int reach_boxes_overlap(const double lo_i[3], const double hi_i[3], const double lo_j[3], const double hi_j[3])
{
    for (int c = 0; c < 3; c++) {
        double lo = lo_i[c] > lo_j[c] ? lo_i[c] : lo_j[c];
        double hi = hi_i[c] < hi_j[c] ? hi_i[c] : hi_j[c];
        if (lo > hi)
            return 0;
    }
    return 1;
}

static void drop_renewed_pairs(struct dem_bins *bins)
{
    size_t kept = 0;
    for (size_t k = 0; k < bins->pair_count; k++) {
        uint32_t a = bins->pairs[2 * k], b = bins->pairs[2 * k + 1];
        if (bins->repaired[a] == RENEWED || bins->repaired[b] == RENEWED)
            continue;
        bins->pairs[2 * kept] = a;
        bins->pairs[2 * kept + 1] = b;
        kept++;
    }
    bins->pair_count = kept;
}

/* Call visit(entry, here, context) for every entry, of a particle still as built, that lies in cell `here` of
 * the cells first..last (removed particles and the stale entries of repaired ones are skipped). */
static void visit_built_entries(const struct dem_bins *bins, const int32_t first[3], const int32_t last[3],
                                void (*visit)(const struct dem_bin_entry *entry, const int32_t here[3], void *context),
                                void *context)
{
    int32_t here[3];
    for (here[0] = first[0]; here[0] <= last[0]; here[0]++)
        for (here[1] = first[1]; here[1] <= last[1]; here[1]++)
            for (here[2] = first[2]; here[2] <= last[2]; here[2]++) {
                uint32_t bucket = cell_hash(here, bins->bucket_count);
                for (uint32_t e = bins->bucket_start[bucket]; e < bins->bucket_start[bucket + 1]; e++) {
                    const struct dem_bin_entry *entry = &bins->entries[e];
                    if (entry->index == REMOVED_ENTRY || bins->repaired[entry->index] != AS_BUILT)
                        continue;
                    if (entry->cell[0] == here[0] && entry->cell[1] == here[1] && entry->cell[2] == here[2])
                        visit(entry, here, context);
                }
            }
}

struct grid_pairs_query {
    struct dem_bins *bins;
    const struct dem_particles *p;
    uint32_t i;
};

static void add_grid_pair(const struct dem_bin_entry *entry, const int32_t here[3], void *context)
{
    struct grid_pairs_query *q = context;
    uint32_t j = entry->index;
    if (!both_deposited(q->p, q->i, j) && owns_reach_pair(q->bins, q->i, j, here))
        pair_push_ordered(q->bins, q->i, j);
}

/* The pairs of renewed particle i with the particles still in the grid as built: from the cells of i's new
 * reach box, each pair from the cell that holds the lower corner of the boxes' intersection (both boxes
 * overlap that cell, and the partner has one entry there), as list_pairs does. */
static void list_grid_pairs_of(struct dem_bins *bins, const struct dem_particles *p, uint32_t i)
{
    int32_t first[3], last[3];
    box_cells(bins->reach_lo + 3 * i, bins->reach_hi + 3 * i, bins->cell, first, last);
    struct grid_pairs_query query = {bins, p, i};
    visit_built_entries(bins, first, last, add_grid_pair, &query);
}

/* The pairs of renewed particle i with the other repaired particles, tested directly; a pair of two renewed
 * particles from the lower one. */
static void list_repaired_pairs_of(struct dem_bins *bins, const struct dem_particles *p, uint32_t i)
{
    const double *lo_i = bins->reach_lo + 3 * i, *hi_i = bins->reach_hi + 3 * i;
    for (size_t k = 0; k < bins->repaired_count; k++) {
        uint32_t j = bins->repaired_list[k];
        if (j == i || (bins->repaired[j] == RENEWED && j < i) || both_deposited(p, i, j))
            continue;
        if (reach_boxes_overlap(lo_i, hi_i, bins->reach_lo + 3 * j, bins->reach_hi + 3 * j))
            pair_push_ordered(bins, i, j);
    }
}

/* New reach boxes for the failing particles and their pairs anew.  Returns 0 (the grid must be rebuilt) if
 * a new box spans too many cells. */
static int repair(struct dem_bins *bins, const struct dem_particles *p, double dt)
{
    for (size_t k = 0; k < bins->failing_count; k++) {
        uint32_t i = bins->failing[k];
        double *lo = bins->reach_lo + 3 * i, *hi = bins->reach_hi + 3 * i;
        reach_box(p, i, dt, bins->horizon, lo, hi);
        int32_t first[3], last[3];
        box_cells(lo, hi, bins->cell, first, last);
        if (cells_in_range(first, last) > REPAIR_MAX_CELLS)
            return 0;
        bins->built_id[i] = p->id[i];
        bins->built_flying[i] = p->state[i] == DEM_FLYING;
        if (bins->repaired[i] == AS_BUILT)
            bins->repaired_list[bins->repaired_count++] = i;
        bins->repaired[i] = RENEWED;
    }
    bins->built_count = p->count;
    drop_renewed_pairs(bins);
    for (size_t k = 0; k < bins->failing_count; k++) {
        list_grid_pairs_of(bins, p, bins->failing[k]);
        list_repaired_pairs_of(bins, p, bins->failing[k]);
    }
    for (size_t k = 0; k < bins->failing_count; k++)
        bins->repaired[bins->failing[k]] = REPAIRED;
    bins->repairs++;
    return 1;
}

void dem_broadphase_build(struct dem_bins *bins, const struct dem_particles *p, double dt)
{
    /* built_count above the count: removals that dem_broadphase_compact could not follow */
    if (bins->reach_lo && p->count >= bins->built_count && collect_failing(bins, p, dt) &&
        (bins->failing_count == 0 || repair(bins, p, dt))) {
        bins->age++;
        return;
    }
    next_horizon(bins);
    rebuild(bins, p, dt);
}

/* moved_to[i]: where particle i of the old_count went after the removals (increasing indices), down by the
 * removals before it, or REMOVED_ENTRY.  Run by run, so that the loops vectorise. */
static void fill_moved_to(uint32_t *moved_to, size_t old_count, const uint32_t *removed, size_t removed_count)
{
    for (size_t i = 0; i < removed[0]; i++)
        moved_to[i] = (uint32_t)i;
    for (size_t k = 0; k < removed_count; k++) {
        size_t first = (size_t)removed[k] + 1, end = k + 1 < removed_count ? removed[k + 1] : old_count;
        moved_to[removed[k]] = REMOVED_ENTRY;
        for (size_t i = first; i < end; i++)
            moved_to[i] = (uint32_t)(i - k - 1);
    }
}

/* The pairs without the removed particles, renumbered; the order of indices is kept, so pairs stay lower
 * index first. */
static void compact_pairs(struct dem_bins *bins, const uint32_t *moved_to)
{
    size_t pairs = 0;
    for (size_t k = 0; k < bins->pair_count; k++) {
        uint32_t a = moved_to[bins->pairs[2 * k]], b = moved_to[bins->pairs[2 * k + 1]];
        bins->pairs[2 * pairs] = a;
        bins->pairs[2 * pairs + 1] = b;
        pairs += a != REMOVED_ENTRY && b != REMOVED_ENTRY;
    }
    bins->pair_count = pairs;
}

static void compact_repaired_list(struct dem_bins *bins, const uint32_t *moved_to)
{
    size_t repaired = 0;
    for (size_t k = 0; k < bins->repaired_count; k++) {
        uint32_t i = moved_to[bins->repaired_list[k]];
        bins->repaired_list[repaired] = i;
        repaired += i != REMOVED_ENTRY;
    }
    bins->repaired_count = repaired;
}

/* Grid entries [first, end) renumbered; those of removed particles are marked and skipped from then on. */
static void renumber_entries(struct dem_bins *bins, size_t first, size_t end, const uint32_t *moved_to)
{
    for (size_t e = first; e < end; e++)
        if (bins->entries[e].index != REMOVED_ENTRY)
            bins->entries[e].index = moved_to[bins->entries[e].index];
}

/* The independent parts of dem_broadphase_compact, largest first: the pair list, the per-particle arrays, the
 * repaired list, then the grid entries in slices of ENTRY_SLICES. */
#define COMPACT_JOBS 5
#define ENTRY_SLICES 8
static void compact_job(struct dem_bins *bins, int job, const uint32_t *moved_to, const uint32_t *removed,
                        size_t removed_count, size_t old_count)
{
    switch (job) {
    case 0:
        compact_pairs(bins, moved_to);
        return;
    case 1:
        dem_remove_rows(bins->reach_lo, 3 * sizeof *bins->reach_lo, old_count, removed, removed_count);
        return;
    case 2:
        dem_remove_rows(bins->reach_hi, 3 * sizeof *bins->reach_hi, old_count, removed, removed_count);
        return;
    case 3:
        dem_remove_rows(bins->built_id, sizeof *bins->built_id, old_count, removed, removed_count);
        return;
    case 4:
        dem_remove_rows(bins->built_flying, 1, old_count, removed, removed_count);
        dem_remove_rows(bins->reach_verified, 1, old_count, removed, removed_count);
        dem_remove_rows(bins->repaired, 1, old_count, removed, removed_count);
        compact_repaired_list(bins, moved_to);
        return;
    default: {
        size_t slice = (size_t)(job - COMPACT_JOBS), per = (bins->entry_count + ENTRY_SLICES - 1) / ENTRY_SLICES;
        size_t first = slice * per < bins->entry_count ? slice * per : bins->entry_count;
        size_t end = first + per < bins->entry_count ? first + per : bins->entry_count;
        renumber_entries(bins, first, end, moved_to);
    }
    }
}

void dem_broadphase_compact(struct dem_bins *bins, const uint32_t *removed, size_t removed_count, size_t old_count)
{
    if (!bins->reach_lo || removed_count == 0)
        return;
    if (bins->built_count != old_count) {
        bins->built_count = SIZE_MAX; /* not the particles it was built for: rebuild */
        return;
    }
    uint32_t *moved_to = dem_realloc_or_die(NULL, old_count * sizeof *moved_to);
    fill_moved_to(moved_to, old_count, removed, removed_count);
#pragma omp parallel for schedule(dynamic, 1) if (old_count >= DEM_PARALLEL_MIN)
    for (int job = 0; job < COMPACT_JOBS + ENTRY_SLICES; job++)
        compact_job(bins, job, moved_to, removed, removed_count, old_count);
    bins->built_count = old_count - removed_count;
    free(moved_to);
}

/* dem_broadphase_visit_box's visitor, called with the index of each entry */
struct index_visit {
    void (*visit)(uint32_t index, void *context);
    void *context;
};

static void visit_index(const struct dem_bin_entry *entry, const int32_t here[3], void *context)
{
    (void)here;
    const struct index_visit *forward = context;
    forward->visit(entry->index, forward->context);
}

int dem_broadphase_visit_box(const struct dem_bins *bins, const double lo[3], const double hi[3], size_t max_cells,
                             void (*visit)(uint32_t index, void *context), void *context)
{
    int32_t first[3], last[3];
    for (int c = 0; c < 3; c++) {
        first[c] = cell_index(lo[c], bins->cell);
        last[c] = cell_index(hi[c], bins->cell);
    }
    if (cells_in_range(first, last) > max_cells)
        return -1;
    struct index_visit forward = {visit, context};
    visit_built_entries(bins, first, last, visit_index, &forward);
    /* the repaired particles, whose grid entries are stale */
    for (size_t k = 0; k < bins->repaired_count; k++) {
        uint32_t i = bins->repaired_list[k];
        if (reach_boxes_overlap(bins->reach_lo + 3 * i, bins->reach_hi + 3 * i, lo, hi))
            visit(i, context);
    }
    return 0;
}
