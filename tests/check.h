/* A minimal test harness: each test program runs several test functions with RUN(); each prints
 * "PASS name" or "FAIL name" and tests/run_tests.sh adds them up.  Checks print what they compared. */
#ifndef SPRAYCOAT_TESTS_CHECK_H
#define SPRAYCOAT_TESTS_CHECK_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_test_failures;
static int check_total_failed;
static int check_total_passed;

static void check_report(int ok, const char *file, int line, const char *fmt, ...)
    __attribute__((format(printf, 4, 5), unused));
static void check_report(int ok, const char *file, int line, const char *fmt, ...)
{
    if (ok)
        return;
    check_test_failures++;
    fprintf(stdout, "  check failed at %s:%d: ", file, line);
    va_list args;
    va_start(args, fmt);
    vfprintf(stdout, fmt, args);
    va_end(args);
    fputc('\n', stdout);
}

#define CHECK(cond, ...) check_report(!!(cond), __FILE__, __LINE__, __VA_ARGS__)

/* |actual - expected| <= rtol |expected| + atol */
#define CHECK_CLOSE(actual, expected, rtol, atol, what)                                                                \
    do {                                                                                                               \
        double check_a_ = (actual), check_e_ = (expected);                                                             \
        check_report(fabs(check_a_ - check_e_) <= (rtol)*fabs(check_e_) + (atol), __FILE__, __LINE__,                  \
                     "%s: got %.12g, expected %.12g (rtol %g, atol %g)", (what), check_a_, check_e_, (double)(rtol),   \
                     (double)(atol));                                                                                  \
    } while (0)

static void check_run(const char *name, void (*test)(void)) __attribute__((unused));
static void check_run(const char *name, void (*test)(void))
{
    const char *only = getenv("CHECK_ONLY"); /* run only the tests whose name contains it (when debugging one) */
    if (only && *only && !strstr(name, only))
        return;
    check_test_failures = 0;
    test();
    if (check_test_failures == 0) {
        check_total_passed++;
        printf("PASS %s\n", name);
    } else {
        check_total_failed++;
        printf("FAIL %s\n", name);
    }
    fflush(stdout);
}

#define RUN(test) check_run(#test, test)

/* Exit status of the test program. */
static int check_finish(void) __attribute__((unused));
static int check_finish(void)
{
    return check_total_failed ? 1 : 0;
}

/* Folder of the independently computed reference tables. */
static const char *check_verification_dir(void) __attribute__((unused));
static const char *check_verification_dir(void)
{
    const char *dir = getenv("SPRAYCOAT_VERIFICATION");
    return dir ? dir : "../shared/verification";
}

#endif
