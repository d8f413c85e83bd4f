/* Contiguous shares balanced by measured speeds (core/balance.h). */
#include "core/balance.h"

#include <stdio.h>
#include <stdlib.h>

/* Weight of a run's measured speed in the smoothed one: a thread slowed for one run (another process took its
 * core) loses a quarter of the difference, and the shares follow a lasting change within a few runs. */
#define SMOOTHING 0.25

static void *or_die(void *allocated)
{
    if (!allocated) {
        fprintf(stderr, "spraycoat: out of memory\n");
        abort();
    }
    return allocated;
}

void balance_prepare(struct balance *b, int threads)
{
    if (threads == b->threads)
        return;
    balance_free(b);
    b->threads = threads;
    b->speed = or_die(calloc((size_t)threads, sizeof *b->speed));
    b->items = or_die(calloc((size_t)threads, sizeof *b->items));
    b->seconds = or_die(calloc((size_t)threads, sizeof *b->seconds));
}

/* Where thread t's share starts: count times the speeds of the threads before it over all speeds. */
static size_t share_start(const struct balance *b, int thread, int threads, size_t count, int measured)
{
    if (thread <= 0)
        return 0;
    if (thread >= threads)
        return count;
    if (!measured)
        return (size_t)((double)count * thread / threads);
    double before = 0.0, all = 0.0;
    for (int t = 0; t < threads; t++) {
        before += t < thread ? b->speed[t] : 0.0;
        all += b->speed[t];
    }
    size_t start = (size_t)((double)count * (before / all));
    return start < count ? start : count;
}

void balance_range(const struct balance *b, int thread, int threads, size_t count, size_t *first, size_t *end)
{
    int measured = threads == b->threads;
    for (int t = 0; measured && t < threads; t++)
        measured = b->speed[t] > 0.0;
    *first = share_start(b, thread, threads, count, measured);
    *end = share_start(b, thread + 1, threads, count, measured);
}

void balance_record(struct balance *b, int thread, int threads, size_t items, double seconds)
{
    if (threads != b->threads || thread < 0 || thread >= threads)
        return;
    b->items[thread] = (double)items;
    b->seconds[thread] = seconds;
}

void balance_update(struct balance *b)
{
    for (int t = 0; t < b->threads; t++) {
        if (b->items[t] > 0.0 && b->seconds[t] > 0.0) {
            double speed = b->items[t] / b->seconds[t];
            b->speed[t] = b->speed[t] > 0.0 ? (1.0 - SMOOTHING) * b->speed[t] + SMOOTHING * speed : speed;
        }
        b->items[t] = 0.0;
        b->seconds[t] = 0.0;
    }
}

void balance_free(struct balance *b)
{
    free(b->speed);
    free(b->items);
    free(b->seconds);
    b->threads = 0;
    b->speed = b->items = b->seconds = NULL;
}
