/* core/fastmath.h and core/fastmath_special.h against glibc: the largest error in ulp over the ranges the PTW
 * flow stress (mpm/ptw_lane.h) and the drag (dem/gas_eval.h) use, and the same bits from a vectorised loop as
 * from scalar calls. */

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core/fastmath_special.h"
#include "tests/check.h"

#define SAMPLES 200001

/* Distance in units in the last place of the reference (0 for equal values, huge for different signs). */
static double ulp_error(double value, double reference)
{
    if (value == reference)
        return 0.0;
    if (!isfinite(value) || !isfinite(reference))
        return INFINITY;
    double spacing = nextafter(fabs(reference), INFINITY) - fabs(reference);
    return fabs(value - reference) / spacing;
}

/* Largest ulp error of fm over [lo, hi] (evenly spaced samples plus the ends). */
static double worst_ulp(double (*fm)(double), double (*ref)(double), double lo, double hi, double *where)
{
    double worst = 0.0;
    for (int k = 0; k < SAMPLES; k++) {
        double x = lo + (hi - lo) * k / (SAMPLES - 1);
        double e = ulp_error(fm(x), ref(x));
        if (e > worst)
            worst = e, *where = x;
    }
    return worst;
}

static double fm_expm1_call(double x)
{
    return fm_expm1(x);
}
static double fm_erf_call(double x)
{
    return fm_erf_from_gauss(x, fm_exp(-x * x));
}
static double fm_exp_call(double x)
{
    return fm_exp(x);
}
static double fm_log_call(double x)
{
    return fm_log(x);
}

static void check_range(const char *name, double (*fm)(double), double (*ref)(double), double lo, double hi,
                        double max_ulp)
{
    double where = lo, worst = worst_ulp(fm, ref, lo, hi, &where);
    printf("  %s on [%g, %g]: %.2f ulp at %.17g\n", name, lo, hi, worst, where);
    CHECK(worst <= max_ulp, "%s: %.2f ulp at %.17g on [%g, %g] (allowed %g)", name, worst, where, lo, hi, max_ulp);
}

/* expm1 on PTW's ranges: a = (tau_s - tau_y)/A (order 1, any sign), -q <= 0, and the small arguments where
 * e^x - 1 would cancel. */
static void test_expm1(void)
{
    check_range("fm_expm1", fm_expm1_call, expm1, -1e-6, 1e-6, 1.0);
    check_range("fm_expm1", fm_expm1_call, expm1, -0.35, 0.35, 2.0);
    check_range("fm_expm1", fm_expm1_call, expm1, -40.0, 40.0, 2.0);
    check_range("fm_expm1", fm_expm1_call, expm1, -700.0, 700.0, 2.0);
    CHECK(fm_expm1(0.0) == 0.0 && fm_expm1(-800.0) == -1.0, "expm1(0) = 0, expm1(-800) = -1");
    CHECK(fm_expm1(1e-300) == 1e-300, "expm1 keeps a tiny argument: %g", fm_expm1(1e-300));
    CHECK(isnan(fm_expm1(NAN)), "expm1(NaN) is NaN");
}

/* erf on PTW's x = kappa T^ ln(gamma xi_dot / rate): about [-3, 10] for the rates of an impact. */
static void test_erf(void)
{
    check_range("fm_erf", fm_erf_call, erf, -1e-3, 1e-3, 2.0);
    check_range("fm_erf", fm_erf_call, erf, -1.0, 1.0, 3.0);
    check_range("fm_erf", fm_erf_call, erf, 0.7, 0.8, 3.0);
    check_range("fm_erf", fm_erf_call, erf, -8.0, 8.0, 3.0);
    check_range("fm_erf", fm_erf_call, erf, 5.8, 40.0, 0.0);
    CHECK(fm_erf_call(0.0) == 0.0 && fm_erf_call(1e300) == 1.0 && fm_erf_call(-1e300) == -1.0, "erf(0, +-big)");
    CHECK(isnan(fm_erf_call(NAN)), "erf(NaN) is NaN");
}

/* exp and log as the PTW lanes use them (the drag's tests cover theirs). */
static void test_exp_log(void)
{
    check_range("fm_exp", fm_exp_call, exp, -700.0, 700.0, 2.0);
    check_range("fm_exp", fm_exp_call, exp, -1.0, 1.0, 2.0);
    check_range("fm_log", fm_log_call, log, 1e-300, 1e300, 2.0);
    check_range("fm_log", fm_log_call, log, 0.5, 2.0, 2.0);
}

static double inverse_cbrt_reference(double x)
{
    return (double)powl((long double)x, -1.0L / 3.0L);
}
static double fm_inverse_cbrt_call(double x)
{
    return fm_inverse_cbrt(x);
}

/* x^(-1/3) as the jet uses it (x = z + virtual_origin: about 1e-3 to 10 m), over every exponent residue mod 3,
 * and far out. */
static void test_inverse_cbrt(void)
{
    check_range("fm_inverse_cbrt", fm_inverse_cbrt_call, inverse_cbrt_reference, 1e-3, 10.0, 2.0);
    check_range("fm_inverse_cbrt", fm_inverse_cbrt_call, inverse_cbrt_reference, 0.9, 8.1, 2.0);
    check_range("fm_inverse_cbrt", fm_inverse_cbrt_call, inverse_cbrt_reference, 1e-300, 1e300, 2.0);
    check_range("fm_inverse_cbrt", fm_inverse_cbrt_call, inverse_cbrt_reference, 1e-200, 1e-190, 2.0);
    CHECK(fm_inverse_cbrt(8.0) == 0.5 && fm_inverse_cbrt(0.125) == 2.0 && fm_inverse_cbrt(1.0) == 1.0,
          "exact cubes: %.17g %.17g %.17g", fm_inverse_cbrt(8.0), fm_inverse_cbrt(0.125), fm_inverse_cbrt(1.0));
}

static double __attribute__((noinline)) erf_scalar(double x)
{
    return fm_erf_call(x);
}
static double __attribute__((noinline)) expm1_scalar(double x)
{
    return fm_expm1(x);
}
static double __attribute__((noinline)) inverse_cbrt_scalar(double x)
{
    return fm_inverse_cbrt(x);
}

/* A loop the compiler vectorises (-O3 here) gives the bits of the scalar calls in every lane. */
static void test_lanes_match_scalar(void)
{
    enum { N = 1024 };
    static double x[N], erf_lanes[N], expm1_lanes[N], inverse_cbrt_lanes[N];
    for (int k = 0; k < N; k++)
        x[k] = -9.0 + 18.0 * k / (N - 1) + 1e-3 * sin(k);
    for (int k = 0; k < N; k++) {
        erf_lanes[k] = fm_erf_from_gauss(x[k], fm_exp(-x[k] * x[k]));
        expm1_lanes[k] = fm_expm1(4.0 * x[k]);
        inverse_cbrt_lanes[k] = fm_inverse_cbrt(exp(x[k]));
    }
    int differ = 0;
    for (int k = 0; k < N; k++)
        differ += memcmp(&erf_lanes[k], &(double){erf_scalar(x[k])}, sizeof(double)) != 0 ||
                  memcmp(&expm1_lanes[k], &(double){expm1_scalar(4.0 * x[k])}, sizeof(double)) != 0 ||
                  memcmp(&inverse_cbrt_lanes[k], &(double){inverse_cbrt_scalar(exp(x[k]))}, sizeof(double)) != 0;
    CHECK(differ == 0, "%d of %d lanes differ from the scalar bits", differ, N);
}

int main(void)
{
    RUN(test_expm1);
    RUN(test_erf);
    RUN(test_exp_log);
    RUN(test_inverse_cbrt);
    RUN(test_lanes_match_scalar);
    return check_finish();
}
