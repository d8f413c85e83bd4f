/* Storage of the particle arrays. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dem/dem_impl.h"

void *dem_realloc_or_die(void *data, size_t bytes)
{
    void *grown = realloc(data, bytes ? bytes : 1);
    if (!grown) {
        /* out of memory mid-step: no state worth saving can be written without memory either */
        fprintf(stderr, "spraycoat: out of memory (%zu bytes requested)\n", bytes);
        abort();
    }
    return grown;
}

static void *resize(void *data, size_t count, size_t size) { return dem_realloc_or_die(data, count * size); }

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
        *arrays[a] = resize(*arrays[a], capacity, sizeof(double));
        memset(*arrays[a] + old_capacity, 0, (capacity - old_capacity) * sizeof(double));
    }
    drag->kept = resize(drag->kept, capacity, sizeof(uint8_t));
    drag->history_count = resize(drag->history_count, capacity, sizeof(uint8_t));
    memset(drag->kept + old_capacity, 0, capacity - old_capacity);
    memset(drag->history_count + old_capacity, 0, capacity - old_capacity);
}

void particles_reserve(struct dem_particles *p, size_t capacity)
{
    if (capacity <= p->capacity)
        return;
    p->x = resize(p->x, 3 * capacity, sizeof(double));
    p->v = resize(p->v, 3 * capacity, sizeof(double));
    p->w = resize(p->w, 3 * capacity, sizeof(double));
    p->x_start = resize(p->x_start, 3 * capacity, sizeof(double));
    p->v_start = resize(p->v_start, 3 * capacity, sizeof(double));
    p->w_start = resize(p->w_start, 3 * capacity, sizeof(double));
    p->d = resize(p->d, capacity, sizeof(double));
    p->m = resize(p->m, capacity, sizeof(double));
    p->id = resize(p->id, capacity, sizeof(int64_t));
    p->state = resize(p->state, capacity, sizeof(uint8_t));
    drag_reserve(&p->drag, p->capacity, capacity);
    p->capacity = capacity;
}

size_t particles_append(struct dem_particles *p, int64_t id, const double x[3], const double v[3],
                        const double w[3], double d, double density)
{
    if (p->count == p->capacity)
        particles_reserve(p, p->capacity ? 2 * p->capacity : 1024);
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
void particles_compact(struct dem_particles *p, const uint32_t *removed, size_t removed_count)
{
    enum { ARRAYS = 3 + DRAG_DOUBLE_ARRAYS + 6 };
    struct row_array arrays[ARRAYS] = {{p->x, 3 * sizeof(double)}, {p->v, 3 * sizeof(double)},
                                       {p->w, 3 * sizeof(double)}};
    double **drag_arrays[DRAG_DOUBLE_ARRAYS];
    drag_double_arrays(&p->drag, drag_arrays);
    for (int a = 0; a < DRAG_DOUBLE_ARRAYS; a++)
        arrays[3 + a] = (struct row_array){*drag_arrays[a], sizeof(double)};
    const struct row_array rest[6] = {{p->d, sizeof(double)}, {p->m, sizeof(double)}, {p->id, sizeof(int64_t)},
                                      {p->state, 1},          {p->drag.kept, 1},      {p->drag.history_count, 1}};
    memcpy(arrays + 3 + DRAG_DOUBLE_ARRAYS, rest, sizeof rest);
#pragma omp parallel for schedule(dynamic, 1) if (p->count >= DEM_PARALLEL_MIN)
    for (int a = 0; a < ARRAYS; a++)
        dem_remove_rows(arrays[a].rows, arrays[a].size, p->count, removed, removed_count);
    p->count -= removed_count;
}

void particles_free(struct dem_particles *p)
{
    free(p->x);
    free(p->v);
    free(p->w);
    free(p->x_start);
    free(p->v_start);
    free(p->w_start);
    free(p->d);
    free(p->m);
    free(p->id);
    free(p->state);
    double **drag_arrays[DRAG_DOUBLE_ARRAYS];
    drag_double_arrays(&p->drag, drag_arrays);
    for (int a = 0; a < DRAG_DOUBLE_ARRAYS; a++)
        free(*drag_arrays[a]);
    free(p->drag.kept);
    free(p->drag.history_count);
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
