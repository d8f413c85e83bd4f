/* Illinois false position (core/root.c; Dowell & Jarratt 1971): a linear function's root in one step, the cube root
 * of 2 to 1e-12 in at most 12 values (9 here) where plain false position needs 35 (its hi end never moves), the points
 * always inside the bracket that holds the root, and refused brackets. */
#include "core/root.h"
#include "core/error.h"
#include "tests/check.h"

#include <math.h>

static double cubic(double x)
{
    return x * x * x - 2.0;
}

static void test_linear_in_one_step(void)
{
    struct root_bracket b;
    CHECK(root_bracket_start(&b, 0.0, 3.0 * (0.0 - 1.7), 5.0, 3.0 * (5.0 - 1.7)) == SC_OK, "bracket");
    CHECK_CLOSE(root_bracket_next(&b), 1.7, 1e-14, 0, "the chord's zero");
}

/* Values until |f| < 1e-12, each point checked to lie in the bracket, which keeps the root. */
static int values_to_root(double (*f)(double), double lo, double hi, double root)
{
    struct root_bracket b;
    CHECK(root_bracket_start(&b, lo, f(lo), hi, f(hi)) == SC_OK, "bracket");
    for (int n = 1; n <= 200; n++) {
        double x = root_bracket_next(&b), fx = f(x);
        CHECK(x >= b.lo && x <= b.hi, "point %d: %.17g inside [%.17g, %.17g]", n, x, b.lo, b.hi);
        if (fabs(fx) < 1e-12)
            return n;
        root_bracket_update(&b, x, fx);
        CHECK(b.lo <= root && root <= b.hi, "the bracket [%.17g, %.17g] keeps the root", b.lo, b.hi);
        CHECK(b.f_lo < 0 && b.f_hi > 0, "the ends' values keep their signs");
    }
    return 201;
}

static void test_cube_root_of_two(void)
{
    int n = values_to_root(cubic, 0.0, 2.0, cbrt(2.0));
    printf("  x^3 - 2 on [0, 2]: %d values\n", n);
    CHECK(n <= 12, "%d values to 1e-12 (plain false position: 35)", n);
}

static void test_refused_brackets(void)
{
    struct root_bracket b;
    CHECK(root_bracket_start(&b, 0.0, 1.0, 1.0, 2.0) == SC_EINPUT, "values of one sign");
    CHECK(root_bracket_start(&b, 1.0, -1.0, 1.0, 1.0) == SC_EINPUT, "an empty interval");
    CHECK(root_bracket_start(&b, 2.0, -1.0, 1.0, 1.0) == SC_EINPUT, "ends out of order");
    CHECK(root_bracket_start(&b, 0.0, 0.0, 1.0, 1.0) == SC_OK, "a zero at an end is a root");
}

int main(void)
{
    RUN(test_linear_in_one_step);
    RUN(test_cube_root_of_two);
    RUN(test_refused_brackets);
    return check_finish();
}
