/* core/balance.c: contiguous shares that cover the items in order, equal until measured, then in proportion to
 * the threads' smoothed speeds. */
#include "core/balance.h"
#include "tests/check.h"

#include <omp.h>
#include <stdlib.h>

/* The shares of a team cover [0, count) in order, without gaps or overlaps. */
static void check_cover(const struct balance *b, int threads, size_t count)
{
    size_t expected_first = 0;
    for (int t = 0; t < threads; t++) {
        size_t first, end;
        balance_range(b, t, threads, count, &first, &end);
        CHECK(first == expected_first && end >= first,
              "%d threads, %zu items: thread %d has [%zu, %zu), expected to "
              "start at %zu",
              threads, count, t, first, end, expected_first);
        expected_first = end;
    }
    CHECK(expected_first == count, "%d threads, %zu items: the shares end at %zu", threads, count, expected_first);
}

static void test_equal_shares_cover_the_items(void)
{
    struct balance b = {0};
    const size_t counts[] = {0, 1, 3, 7, 1000, 1001};
    for (int threads = 1; threads <= 5; threads++) {
        balance_prepare(&b, threads);
        for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++)
            check_cover(&b, threads, counts[c]);
    }
    size_t first, end;
    balance_prepare(&b, 4);
    balance_range(&b, 2, 4, 1000, &first, &end);
    CHECK(first == 500 && end == 750, "4 equal shares of 1000: thread 2 has [%zu, %zu), expected [500, 750)", first,
          end);
    balance_free(&b);
}

/* Thread 1 twice as fast as thread 0: after one run it gets 2/3 of the items; a second run's speeds are
 * smoothed with weight 1/4. */
static void test_shares_follow_the_speeds(void)
{
    struct balance b = {0};
    balance_prepare(&b, 2);
    balance_record(&b, 0, 2, 300, 1.0); /* 300 items/s */
    balance_record(&b, 1, 2, 300, 0.5); /* 600 items/s */
    balance_update(&b);
    size_t first, end;
    balance_range(&b, 1, 2, 900, &first, &end);
    CHECK(first == 300 && end == 900, "speeds 300 and 600: thread 1 has [%zu, %zu) of 900, expected [300, 900)", first,
          end);
    check_cover(&b, 2, 900);
    /* now thread 0 runs at 1200 items/s: smoothed 0.75 * 300 + 0.25 * 1200 = 525, thread 1 stays at 600 */
    balance_record(&b, 0, 2, 1200, 1.0);
    balance_record(&b, 1, 2, 600, 1.0);
    balance_update(&b);
    CHECK_CLOSE(b.speed[0], 525.0, 1e-15, 0.0, "thread 0's smoothed speed");
    CHECK_CLOSE(b.speed[1], 600.0, 1e-15, 0.0, "thread 1's smoothed speed");
    balance_range(&b, 0, 2, 1125, &first, &end);
    CHECK(first == 0 && end == 525, "speeds 525 and 600: thread 0 has [%zu, %zu) of 1125, expected [0, 525)", first,
          end);
    /* a thread without items this run keeps its speed */
    balance_record(&b, 0, 2, 0, 0.0);
    balance_record(&b, 1, 2, 600, 1.0);
    balance_update(&b);
    CHECK_CLOSE(b.speed[0], 525.0, 1e-15, 0.0, "thread 0's speed after a run without items");
    balance_free(&b);
}

/* Another team size starts again from equal shares, and records for a team of another size are ignored. */
static void test_team_change_resets(void)
{
    struct balance b = {0};
    balance_prepare(&b, 2);
    balance_record(&b, 0, 2, 100, 1.0);
    balance_record(&b, 1, 2, 300, 1.0);
    balance_update(&b);
    balance_prepare(&b, 3);
    size_t first, end;
    balance_range(&b, 1, 3, 300, &first, &end);
    CHECK(first == 100 && end == 200, "a new team of 3: thread 1 has [%zu, %zu) of 300, expected [100, 200)", first,
          end);
    balance_record(&b, 0, 2, 100, 1.0); /* a team of 2 no longer: ignored */
    balance_update(&b);
    CHECK(b.speed[0] == 0.0, "a record of a team of 2 changed the speeds of a team of 3 (%g)", b.speed[0]);
    balance_range(&b, 2, 3, 300, &first, &end);
    CHECK(first == 200 && end == 300, "thread 2 has [%zu, %zu) of 300, expected [200, 300)", first, end);
    balance_free(&b);
}

/* balance_next, one thread: its own share in order from the front, chunk by chunk, then the backs of the others'
 * shares, always the one with the most left (the first of equals); every item exactly once, and 0 once none is
 * left. */
static void test_stealing_takes_every_item_once(void)
{
    struct balance b = {0};
    balance_prepare(&b, 3);
    balance_shares(&b, 30); /* equal shares [0, 10) [10, 20) [20, 30) */
    size_t first, end,
        expected[][2] = {{10, 14}, {14, 18}, {18, 20}, {6, 10}, {26, 30}, {2, 6}, {22, 26}, {0, 2}, {20, 22}};
    int taken = 0;
    for (; balance_next(&b, 1, 4, &first, &end); taken++) {
        if (taken < 9)
            CHECK(first == expected[taken][0] && end == expected[taken][1],
                  "chunk %d of thread 1: [%zu, %zu), expected [%zu, %zu)", taken, first, end, expected[taken][0],
                  expected[taken][1]);
    }
    CHECK(taken == 9, "thread 1 alone took %d chunks, expected 9", taken);
    CHECK(!balance_next(&b, 0, 4, &first, &end), "thread 0 found items after all were taken");
    balance_free(&b);
}

/* Threads taking chunks at once from shares placed by unequal speeds: the chunks cover every item exactly once,
 * however the threads race (and with a team smaller than the shares: the missing thread's share is taken). */
static void test_stealing_races_cover_the_items(void)
{
    enum { ITEMS = 100003, ROUNDS = 20 };
    unsigned char *seen = calloc(ITEMS, 1);
    for (int round = 0; round < ROUNDS; round++) {
        struct balance b = {0};
        balance_prepare(&b, 4);
        for (int t = 0; t < 4; t++)
            balance_record(&b, t, 4, (size_t)(t + 1) * 100, 1.0); /* shares 1 : 2 : 3 : 4 */
        balance_update(&b);
        balance_shares(&b, ITEMS);
        int team = round % 2 ? 3 : 4; /* odd rounds: thread 3's share has no owner */
#pragma omp parallel num_threads(team)
        {
            size_t first, end;
            while (balance_next(&b, omp_get_thread_num(), 1 + (size_t)round % 7, &first, &end))
                for (size_t i = first; i < end; i++) {
#pragma omp atomic
                    seen[i]++;
                }
        }
        size_t wrong = 0;
        for (size_t i = 0; i < ITEMS; i++) {
            wrong += seen[i] != 1;
            seen[i] = 0;
        }
        CHECK(wrong == 0, "round %d, %d threads: %zu of %d items not taken exactly once", round, team, wrong, ITEMS);
        balance_free(&b);
    }
    free(seen);
}

int main(void)
{
    RUN(test_equal_shares_cover_the_items);
    RUN(test_shares_follow_the_speeds);
    RUN(test_team_change_resets);
    RUN(test_stealing_takes_every_item_once);
    RUN(test_stealing_races_cover_the_items);
    return check_finish();
}
