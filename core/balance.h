/* Contiguous shares of a parallel loop's items, balanced by the threads' measured speeds.
 *
 * A static schedule gives each thread the same items every time the loop runs, so that their data stay in its
 * core's caches (a dynamic schedule moved them between the cores: BENCHMARKS.md), but equal shares wait for
 * the slowest thread: on a shared or virtual machine the cores are not equally fast at every moment, and the
 * items are not equally costly.  Here thread t of n gets a contiguous share of the items in proportion to the
 * speed (items per second) it showed in the loop's last runs, smoothed: the shares move a little from run to
 * run and a thread keeps nearly the same items.  Which thread does which item changes no result where the
 * items are independent and the reductions exact (integer sums), as in the loops that use it.
 *
 * Use: before the parallel region balance_prepare with the team's size; in it, balance_range, the loop over
 * [first, end) and balance_record with the thread's time; after it balance_update.  A new struct balance
 * (zeros) starts with equal shares, as does a team of another size. */
#ifndef SPRAYCOAT_CORE_BALANCE_H
#define SPRAYCOAT_CORE_BALANCE_H

#include <stddef.h>

struct balance {
    int threads;     /* the team the speeds are for (0: none yet) */
    double *speed;   /* per thread: items per second, smoothed (0: not measured yet) */
    double *items;   /* per thread: this run's items and seconds (balance_record) */
    double *seconds;
};

/* Before the region (one thread): the team will have `threads` threads. */
void balance_prepare(struct balance *b, int threads);

/* Thread `thread` of a team of `threads`: its share [*first, *end) of `count` items.  Every thread computes the
 * same split, and the shares cover [0, count) in order; equal shares until every thread's speed is known. */
void balance_range(const struct balance *b, int thread, int threads, size_t count, size_t *first, size_t *end);

/* In the region, by each thread: it did `items` items in `seconds`. */
void balance_record(struct balance *b, int thread, int threads, size_t items, double seconds);

/* After the region (one thread): this run's speeds join the smoothed ones. */
void balance_update(struct balance *b);

void balance_free(struct balance *b);

#endif
