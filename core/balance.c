/* Contiguous shares balanced by measured speeds (core/balance.h). */
#include "core/balance.h"
#include "core/error.h"

#include <stdalign.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

/* Weight of a run's measured speed in the smoothed one: a thread slowed for one run (another process took its
 * core) loses a quarter of the difference, and the shares follow a lasting change within a few runs. */
#define SMOOTHING 0.25

/* balance_prepare returns no status: an allocation failure ends the process, as every out of memory where no
 * status can be returned (core/error.h, SC_DIE_OOM: exit status 3) */
static void *or_die(void *allocated, size_t bytes)
{
    if (!allocated)
        SC_DIE_OOM(bytes, "the load balance of a thread team");
    return allocated;
}

/* What is left of a thread's share: [front, back) packed in one word (front in the low half), so that its owner
 * taking from the front and a thief taking from the back cannot both take the last items.  One cache line each:
 * an owner's updates do not disturb the other threads' lines. */
struct balance_rest {
    alignas(64) _Atomic uint64_t word;
};

static uint64_t rest_word(size_t front, size_t back)
{
    return (uint64_t)front | (uint64_t)back << 32;
}
static size_t rest_front(uint64_t word)
{
    return (size_t)(word & UINT32_MAX);
}
static size_t rest_back(uint64_t word)
{
    return (size_t)(word >> 32);
}

void balance_prepare(struct balance *b, int threads)
{
    if (threads == b->threads)
        return;
    balance_free(b);
    b->threads = threads;
    b->speed = or_die(calloc((size_t)threads, sizeof *b->speed), (size_t)threads * sizeof *b->speed);
    b->items = or_die(calloc((size_t)threads, sizeof *b->items), (size_t)threads * sizeof *b->items);
    b->seconds = or_die(calloc((size_t)threads, sizeof *b->seconds), (size_t)threads * sizeof *b->seconds);
    b->rest = or_die(aligned_alloc(alignof(struct balance_rest), (size_t)threads * sizeof *b->rest),
                     (size_t)threads * sizeof *b->rest);
    for (int t = 0; t < threads; t++)
        atomic_init(&b->rest[t].word, 0);
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

void balance_shares(struct balance *b, size_t count)
{
    if (count > UINT32_MAX) {
        fprintf(stderr, "spraycoat: balance_shares: %zu items, more than 2^32 - 1\n", count);
        abort();
    }
    for (int t = 0; t < b->threads; t++) {
        size_t first, end;
        balance_range(b, t, b->threads, count, &first, &end);
        atomic_store_explicit(&b->rest[t].word, rest_word(first, end), memory_order_relaxed);
    }
}

/* Up to `chunk` items from the front (or the back) of rest's items into [*first, *end); 0 when none are left. */
static int take(struct balance_rest *rest, size_t chunk, int from_back, size_t *first, size_t *end)
{
    uint64_t word = atomic_load_explicit(&rest->word, memory_order_relaxed);
    for (;;) {
        size_t front = rest_front(word), back = rest_back(word);
        if (front >= back)
            return 0;
        size_t n = back - front < chunk ? back - front : chunk;
        uint64_t left = from_back ? rest_word(front, back - n) : rest_word(front + n, back);
        if (atomic_compare_exchange_weak_explicit(&rest->word, &word, left, memory_order_relaxed,
                                                  memory_order_relaxed)) {
            *first = from_back ? back - n : front;
            *end = from_back ? back : front + n;
            return 1;
        }
    }
}

/* The other thread with the most items left, or -1. */
static int fullest_other(const struct balance *b, int thread)
{
    int fullest = -1;
    size_t most = 0;
    for (int t = 0; t < b->threads; t++) {
        uint64_t word = atomic_load_explicit(&b->rest[t].word, memory_order_relaxed);
        size_t left = rest_back(word) > rest_front(word) ? rest_back(word) - rest_front(word) : 0;
        if (t != thread && left > most) {
            most = left;
            fullest = t;
        }
    }
    return fullest;
}

int balance_next(struct balance *b, int thread, size_t chunk, size_t *first, size_t *end)
{
    chunk = chunk ? chunk : 1;
    if (take(&b->rest[thread], chunk, 0, first, end))
        return 1;
    for (int victim = fullest_other(b, thread); victim >= 0; victim = fullest_other(b, thread))
        if (take(&b->rest[victim], chunk, 1, first, end))
            return 1;
    return 0;
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
    free(b->rest);
    b->threads = 0;
    b->speed = b->items = b->seconds = NULL;
    b->rest = NULL;
}
