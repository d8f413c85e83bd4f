/* Contiguous shares of a parallel loop's items, balanced by the threads' measured speeds.
 *
 * A static schedule gives each thread the same items every time the loop runs, so that their data stay in its
 * core's caches (a dynamic schedule moved them between the cores: BENCHMARKS.md, in git), but equal shares wait for
 * the slowest thread: on a shared or virtual machine the cores are not equally fast at every moment, and the
 * items are not equally costly.  Here thread t of n gets a contiguous share of the items in proportion to the
 * speed (items per second) it showed in the loop's last runs, smoothed: the shares move a little from run to
 * run and a thread keeps nearly the same items.  Which thread does which item changes no result where the
 * items are independent and the reductions exact (integer sums), as in the loops that use it.
 *
 * Use: before the parallel region balance_prepare with the team's size; in it, balance_range, the loop over
 * [first, end) and balance_record with the thread's time; after it balance_update.  A new struct balance
 * (zeros) starts with equal shares, as does a team of another size.  Where the items may run in any order,
 * balance_shares and balance_next add stealing at the end of the shares (below). */
#ifndef SPRAYCOAT_CORE_BALANCE_H
#define SPRAYCOAT_CORE_BALANCE_H

#include <stddef.h>

struct balance_rest;

struct balance {
    int threads;   /* the team the speeds are for (0: none yet) */
    double *speed; /* per thread: items per second, smoothed (0: not measured yet) */
    double *items; /* per thread: this run's items and seconds (balance_record) */
    double *seconds;
    struct balance_rest *rest; /* per thread: what is left of its share (balance_shares, balance_next) */
};

/* Before the region (one thread): the team will have `threads` threads. */
void balance_prepare(struct balance *b, int threads);

/* Thread `thread` of a team of `threads`: its share [*first, *end) of `count` items.  Every thread computes the
 * same split, and the shares cover [0, count) in order; equal shares until every thread's speed is known. */
void balance_range(const struct balance *b, int thread, int threads, size_t count, size_t *first, size_t *end);

/* In the region, by each thread: it did `items` items in `seconds`. */
void balance_record(struct balance *b, int thread, int threads, size_t items, double seconds);

/* Shares with stealing, for a loop whose items may run on any thread, in any order (no result depends on the
 * order): the speeds still place the shares, but a thread that has finished its own takes the last items of the
 * share with the most left, so that no thread waits for another (a core slowed for part of one run, items
 * costlier than measured).  Before the region (one thread, after balance_prepare): balance_shares with the count.
 * In the region each thread takes chunks of up to `chunk` items by balance_next until it returns 0: from the front
 * of its own share, in order, then from the backs of the others; it then calls balance_record with the items it
 * took.  Items below 2^32. */
void balance_shares(struct balance *b, size_t count);
int balance_next(struct balance *b, int thread, size_t chunk, size_t *first, size_t *end);

/* After the region (one thread): this run's speeds join the smoothed ones. */
void balance_update(struct balance *b);

void balance_free(struct balance *b);

#endif
