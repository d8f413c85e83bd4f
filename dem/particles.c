/* Storage of the particle arrays. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "dem/dem_impl.h"

/* Out of memory mid-step: no state worth saving can be written without memory either.  The one out-of-memory
 * message and exit status 3 (core/error.h), not abort(). */
static void *or_die(void *allocated, size_t bytes)
{
    if (!allocated)
        SC_DIE_OOM(bytes, "the spray stage's arrays");
    return allocated;
}

void *dem_realloc_or_die(void *data, size_t bytes)
{
    return or_die(realloc(data, bytes ? bytes : 1), bytes);
}

void *dem_aligned_alloc_or_die(size_t alignment, size_t bytes)
{
    return or_die(aligned_alloc(alignment, bytes), bytes);
}

static void *resize(void *data, size_t count, size_t size)
{
    return dem_realloc_or_die(data, count * size);
}

/* Where each particle array starts within a page, in cache lines.  Large blocks come from mmap and start at
 * the same offset of a page, so element i of every array of doubles maps to the same set of the L1 cache:
 * a block of the integration (dem/integrate.c) reads 4 lines from each of 13 such arrays (d, m, the drag's
 * 11), more lines per set than the cache has ways, and the lines evicted each other before they were used.
 * Each array gets its own offset: the arrays of doubles 4 lines apart (one block's 32 elements), those of 3
 * doubles 12 apart, the bytes 1 apart. */
enum { PAGE_BYTES = 4096, LINE_BYTES = 64 };
enum particle_array {
    ARRAY_X,
    ARRAY_V,
    ARRAY_W,
    ARRAY_X_START,
    ARRAY_V_START,
    ARRAY_W_START,
    ARRAY_D,
    ARRAY_M,
    ARRAY_ID,
    ARRAY_DRAG, /* 11 of them */
    ARRAY_STATE = ARRAY_DRAG + 11,
    ARRAY_KEPT,
    ARRAY_HISTORY_COUNT,
    ARRAY_TEMPERATURE
};

static size_t stagger_lines(enum particle_array array)
{
    if (array < ARRAY_D)
        return 12 * (size_t)array;
    if (array == ARRAY_TEMPERATURE)
        return 56; /* after the drag's last array (52), not read by the integration */
    if (array < ARRAY_STATE)
        return 4 * (size_t)(array - ARRAY_D);
    return 60 + (size_t)(array - ARRAY_STATE);
}

/* A block of `bytes` whose start lies stagger_lines(array) lines into a page; the block malloc gave is kept
 * in the word before it (array_free). */
static void *array_alloc(size_t bytes, enum particle_array array)
{
    size_t offset = (stagger_lines(array) % (PAGE_BYTES / LINE_BYTES)) * LINE_BYTES;
    char *block = dem_realloc_or_die(NULL, bytes + PAGE_BYTES + sizeof(void *));
    uintptr_t first = (uintptr_t)(block + sizeof(void *));
    uintptr_t start = first + ((offset - first % PAGE_BYTES) + PAGE_BYTES) % PAGE_BYTES;
    memcpy((char *)start - sizeof(void *), &block, sizeof block);
    return (void *)start;
}

static void array_free(void *data)
{
    if (!data)
        return;
    void *block;
    memcpy(&block, (char *)data - sizeof block, sizeof block);
    free(block);
}

/* An array of count_before rows of `size` bytes grown to count rows (contents kept, the new rows undefined). */
static void *array_grow(void *data, size_t count_before, size_t count, size_t size, enum particle_array array)
{
    void *grown = array_alloc(count * size, array);
    if (data)
        memcpy(grown, data, count_before * size);
    array_free(data);
    return grown;
}

/* The drag's arrays of doubles, each with one value per particle (struct dem_drag). */
#define DRAG_DOUBLE_ARRAYS 11
static void drag_double_arrays(struct dem_drag *drag, double **arrays[DRAG_DOUBLE_ARRAYS])
{
    for (int slot = 0; slot < 3; slot++)
        for (int c = 0; c < 3; c++)
            arrays[3 * slot + c] = &drag->forces[slot][c];
    arrays[9] = &drag->slip;
    arrays[10] = &drag->reynolds_power;
}

/* The drag's arrays grown to `capacity` particles, the new slots cleared: nothing kept, zero forces. */
static void drag_reserve(struct dem_drag *drag, size_t old_capacity, size_t capacity)
{
    double **arrays[DRAG_DOUBLE_ARRAYS];
    drag_double_arrays(drag, arrays);
    for (int a = 0; a < DRAG_DOUBLE_ARRAYS; a++) {
        *arrays[a] = array_grow(*arrays[a], old_capacity, capacity, sizeof(double), ARRAY_DRAG + a);
        memset(*arrays[a] + old_capacity, 0, (capacity - old_capacity) * sizeof(double));
    }
    drag->kept = array_grow(drag->kept, old_capacity, capacity, 1, ARRAY_KEPT);
    drag->history_count = array_grow(drag->history_count, old_capacity, capacity, 1, ARRAY_HISTORY_COUNT);
    memset(drag->kept + old_capacity, 0, capacity - old_capacity);
    memset(drag->history_count + old_capacity, 0, capacity - old_capacity);
}

void dem_particles_reserve(struct dem_particles *p, size_t capacity)
{
    if (capacity <= p->capacity)
        return;
    size_t before = p->capacity;
    p->x = array_grow(p->x, 3 * before, 3 * capacity, sizeof(double), ARRAY_X);
    p->v = array_grow(p->v, 3 * before, 3 * capacity, sizeof(double), ARRAY_V);
    p->w = array_grow(p->w, 3 * before, 3 * capacity, sizeof(double), ARRAY_W);
    p->x_start = array_grow(p->x_start, 3 * before, 3 * capacity, sizeof(double), ARRAY_X_START);
    p->v_start = array_grow(p->v_start, 3 * before, 3 * capacity, sizeof(double), ARRAY_V_START);
    p->w_start = array_grow(p->w_start, 3 * before, 3 * capacity, sizeof(double), ARRAY_W_START);
    p->d = array_grow(p->d, before, capacity, sizeof(double), ARRAY_D);
    p->m = array_grow(p->m, before, capacity, sizeof(double), ARRAY_M);
    p->id = array_grow(p->id, before, capacity, sizeof(int64_t), ARRAY_ID);
    p->state = array_grow(p->state, before, capacity, sizeof(uint8_t), ARRAY_STATE);
    p->temperature = array_grow(p->temperature, before, capacity, sizeof(double), ARRAY_TEMPERATURE);
    drag_reserve(&p->drag, before, capacity);
    p->capacity = capacity;
}

size_t dem_particles_append(struct dem_particles *p, int64_t id, const double x[3], const double v[3],
                            const double w[3], double d, double density)
{
    if (p->count == p->capacity)
        dem_particles_reserve(p, p->capacity ? 2 * p->capacity : 1024);
    size_t i = p->count++;
    memcpy(p->x + 3 * i, x, 3 * sizeof(double));
    memcpy(p->v + 3 * i, v, 3 * sizeof(double));
    memcpy(p->w + 3 * i, w, 3 * sizeof(double));
    memcpy(p->x_start + 3 * i, x, 3 * sizeof(double));
    memcpy(p->v_start + 3 * i, v, 3 * sizeof(double));
    memcpy(p->w_start + 3 * i, w, 3 * sizeof(double));
    p->d[i] = d;
    p->m[i] = density * M_PI * d * d * d / 6.0;
    p->id[i] = id;
    p->state[i] = DEM_FLYING;
    p->temperature[i] = 293.15; /* the injector sets the particle's own (dem/inject.c) */
    p->drag.kept[i] = 0;
    p->drag.history_count[i] = 0;
    return i;
}

/* Remove rows removed[0, removed_count) (increasing) of an array of `count` rows of `size` bytes, keeping the
 * order of the others: the run between two removals moves down by the number of removals before it, one
 * memmove per run (escapes are few per step, the runs long), in increasing order, since each run lands on
 * the tail of the one before. */
void dem_remove_rows(void *rows, size_t size, size_t count, const uint32_t *removed, size_t removed_count)
{
    char *base = rows;
    for (size_t k = 0; k < removed_count; k++) {
        size_t first = (size_t)removed[k] + 1, end = k + 1 < removed_count ? removed[k + 1] : count;
        memmove(base + (first - k - 1) * size, base + first * size, (end - first) * size);
    }
}

struct row_array {
    void *rows;
    size_t size; /* bytes per particle */
};

/* x_start, v_start and w_start are not moved: they hold the start of the current step only, are read before
 * the removals at the step's end (hand-off rows) and written again in the next step before they are read
 * (dem/collide.c), so moving them was a third of the copying.  The arrays are independent: one thread each,
 * largest first, so that two threads share the bytes about evenly (24 each for x, v, w, 8 for each of the
 * drag's 11 arrays of doubles, d, m and id...). */
void dem_particles_compact(struct dem_particles *p, const uint32_t *removed, size_t removed_count)
{
    enum { ARRAYS = 3 + DRAG_DOUBLE_ARRAYS + 7 };
    struct row_array arrays[ARRAYS] = {
        {p->x, 3 * sizeof(double)}, {p->v, 3 * sizeof(double)}, {p->w, 3 * sizeof(double)}};
    double **drag_arrays[DRAG_DOUBLE_ARRAYS];
    drag_double_arrays(&p->drag, drag_arrays);
    for (int a = 0; a < DRAG_DOUBLE_ARRAYS; a++)
        arrays[3 + a] = (struct row_array){*drag_arrays[a], sizeof(double)};
    const struct row_array rest[7] = {
        {p->d, sizeof(double)}, {p->m, sizeof(double)},     {p->id, sizeof(int64_t)},        {p->state, 1},
        {p->drag.kept, 1},      {p->drag.history_count, 1}, {p->temperature, sizeof(double)}};
    memcpy(arrays + 3 + DRAG_DOUBLE_ARRAYS, rest, sizeof rest);
#pragma omp parallel for schedule(dynamic, 1) if (p->count >= DEM_PARALLEL_MIN)
    for (int a = 0; a < ARRAYS; a++)
        dem_remove_rows(arrays[a].rows, arrays[a].size, p->count, removed, removed_count);
    p->count -= removed_count;
}

void dem_particles_free(struct dem_particles *p)
{
    void *arrays[] = {p->x,          p->v, p->w,  p->x_start, p->v_start,   p->w_start,
                      p->d,          p->m, p->id, p->state,   p->drag.kept, p->drag.history_count,
                      p->temperature};
    for (size_t a = 0; a < sizeof arrays / sizeof *arrays; a++)
        array_free(arrays[a]);
    double **drag_arrays[DRAG_DOUBLE_ARRAYS];
    drag_double_arrays(&p->drag, drag_arrays);
    for (int a = 0; a < DRAG_DOUBLE_ARRAYS; a++)
        array_free(*drag_arrays[a]);
    memset(p, 0, sizeof *p);
}

void *dem_grow(void **items, size_t *count, size_t *capacity, size_t item_size)
{
    if (*count == *capacity) {
        *capacity = *capacity ? 2 * *capacity : 256;
        *items = resize(*items, *capacity, item_size);
    }
    char *slot = (char *)*items + (*count)++ * item_size;
    memset(slot, 0, item_size);
    return slot;
}
