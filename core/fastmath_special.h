/* e^x - 1 and erf(x) in plain double arithmetic (no libm calls, no branches), on top of core/fastmath.h, for the
 * PTW flow stress of mpm/ (Tang Eqs. 2.4-2.7) evaluated across material points in vector lanes.  As there, a
 * vector lane gives the same bits as the scalar code (C17: no contraction into FMA).  A header of its own so
 * that core/fastmath.h stays as dem/ uses it.
 *
 * Accuracy against glibc (tests/test_fastmath.c measures it on the ranges PTW uses and beyond):
 *   fm_expm1  within 2 ulp on [-700, 700] (1 ulp for |x| <= 1e-6);
 *   fm_erf_from_gauss  within 3 ulp on [-8, 8], the largest errors just above the switch at |x| = 0.75 where
 *   erfc is still 0.29 of erf; exactly +-1 beyond |x| = 5.8 (erf rounds to +-1 beyond 5.93). */
#ifndef SPRAYCOAT_CORE_FASTMATH_SPECIAL_H
#define SPRAYCOAT_CORE_FASTMATH_SPECIAL_H

#include "core/fastmath.h"

/* e^x - 1 without the cancellation of fm_exp(x) - 1 near 0: x = n ln2 + r as in fm_exp, e^x - 1 =
 * 2^n (e^r - 1) + (2^n - 1), with e^r - 1 = r (1 + r/2 + ... + r^12/13!) (relative remainder below 1.3e-17
 * for |r| <= 0.347).  n = 0 for |x| <= ln2/2, where r = x exactly; for larger |x| the two terms cancel by at most
 * a factor 2.  Below -708 the result is -1, above 709 it is e^709 - 1; NaN stays NaN. */
FM_INLINE double fm_expm1(double x)
{
    double shifted, r = fm_exp_reduce(x, &shifted);
    double two_n = fm_exp_power_of_two(shifted);
    double result = two_n * fm_exp_series_minus_one(r) + (two_n - 1.0);
    return fm_select(x < -708.0, -1.0, result);
}

/* The loops over coefficients unrolled: a loop left inside the caller's loop over lanes keeps that from being
 * vectorised (gcc unrolls only short loops by itself). */
#if defined(__CUDA_ARCH__)
#define FM_UNROLL _Pragma("unroll")
#elif defined(__CUDACC__) /* nvcc's host pass: its front end knows no GCC pragma, and the CPU never runs it */
#define FM_UNROLL
#elif defined(__GNUC__) && !defined(__clang__)
#define FM_UNROLL _Pragma("GCC unroll 32")
#else
#define FM_UNROLL
#endif

/* Coefficients of fm_erf_from_gauss, from scripts/erf_coefficients.py (which says how they were made). */
#define FM_ERF_SERIES_TERMS    17
#define FM_ERF_CHEBYSHEV_TERMS 18
#define FM_ERF_SPLIT           0.75
#define FM_ERF_TAIL_END        6.0
#define FM_ERF_MAP_K           2.0
#define FM_ERF_MAP_MID         0.022727272727272735 /* middle of y(0.75) = -5/11 and y(6) = 1/2 */
#define FM_ERF_MAP_SCALE       2.0952380952380953   /* 2 / (y(6) - y(0.75)) */

/* 2/sqrt(pi) (-1)^n / (n! (2n + 1)), n = 0..16: the Maclaurin series of erf in x^2 (remainder below 1e-18 of
 * erf(x) at |x| < 0.75). */
#define FM_ERF_SERIES_VALUES                                                                                           \
    1.1283791670955126, -0.37612638903183754, 0.11283791670955126, -0.026866170645131252, 0.0052239776254421879,       \
        -0.00085483270234508522, 0.00012055332981789664, -1.492565035840625e-05, 1.6462114365889246e-06,               \
        -1.6365844691234924e-07, 1.4807192815879218e-08, -1.2290555301717926e-09, 9.4227590646504113e-11,              \
        -6.7113668551641105e-12, 4.4632242632864775e-13, -2.7835162072109212e-14, 1.6342614095367152e-15
static const double fm_erf_series[FM_ERF_SERIES_TERMS] = {FM_ERF_SERIES_VALUES};
#ifdef __CUDACC__ /* the device pass reads its own copy (a __device__ array is not the host's) */
static __device__ const double fm_erf_series_device[FM_ERF_SERIES_TERMS] = {FM_ERF_SERIES_VALUES};
#endif

/* Chebyshev coefficients (the first halved) of g(y) = e^(t^2) erfc(t) (1 + 2 t), y = (t - 2)/(t + 2), over
 * t in [0.75, 6] (Weideman's map: g is smooth and slowly varying in y). */
#define FM_ERF_CHEBYSHEV_VALUES                                                                                        \
    1.2560913329761065, -0.034887012263731865, -0.019036297344327845, 0.0042725941695178713, -0.00033829425069461594,  \
        -1.0024443962655238e-05, 3.0415530737095114e-06, 7.1944874445971363e-08, -2.9640945364839411e-08,              \
        -1.6037027964280193e-09, 2.781292245124245e-10, 3.4641419940917295e-11, -1.384612910437788e-12,                \
        -5.7435024618246455e-13, -2.8174077654208318e-14, 6.0764110756950096e-15, 4.2500725161431774e-16,              \
        -6.5052130349130266e-19
static const double fm_erf_chebyshev[FM_ERF_CHEBYSHEV_TERMS] = {FM_ERF_CHEBYSHEV_VALUES};
#ifdef __CUDACC__ /* the device pass reads its own copy (a __device__ array is not the host's) */
static __device__ const double fm_erf_chebyshev_device[FM_ERF_CHEBYSHEV_TERMS] = {FM_ERF_CHEBYSHEV_VALUES};
#endif

/* erf(x), given gauss = fm_exp(-x * x) (the caller usually needs it too: d erf/dx = 2/sqrt(pi) e^(-x^2)).
 * |x| < 0.75: x times the Maclaurin series in x^2.  |x| >= 0.75: 1 - erfc(|x|) with the sign of x, erfc(t) =
 * e^(-t^2) g(y) / (1 + 2 t); t is held at 6 in g, where erfc < 2e-17 no longer changes the result.  Both are
 * evaluated and one is selected. */
#ifdef __CUDA_ARCH__
#define FM_ERF_SERIES    fm_erf_series_device
#define FM_ERF_CHEBYSHEV fm_erf_chebyshev_device
#else
#define FM_ERF_SERIES    fm_erf_series
#define FM_ERF_CHEBYSHEV fm_erf_chebyshev
#endif
FM_INLINE double fm_erf_from_gauss(double x, double gauss)
{
    double x2 = x * x;
    double series = FM_ERF_SERIES[FM_ERF_SERIES_TERMS - 1];
    FM_UNROLL
    for (int k = FM_ERF_SERIES_TERMS - 2; k >= 0; k--)
        series = series * x2 + FM_ERF_SERIES[k];
    double near_zero = x * series;

    uint64_t sign = fm_to_bits(x) & 0x8000000000000000ull;
    double t = fm_from_bits(fm_to_bits(x) & 0x7fffffffffffffffull);
    double t_held = fm_select(t > FM_ERF_TAIL_END, FM_ERF_TAIL_END, t);
    t_held = fm_select(t_held < FM_ERF_SPLIT, FM_ERF_SPLIT, t_held);
    double y = (t_held - FM_ERF_MAP_K) / (t_held + FM_ERF_MAP_K);
    double z = (y - FM_ERF_MAP_MID) * FM_ERF_MAP_SCALE, two_z = 2.0 * z;
    /* Clenshaw's recurrence b_k = c_k + 2 z b_(k+1) - b_(k+2); g = c_0 + z b_1 - b_2 */
    double b1 = 0.0, b2 = 0.0;
    FM_UNROLL
    for (int k = FM_ERF_CHEBYSHEV_TERMS - 1; k >= 1; k--) {
        double b0 = FM_ERF_CHEBYSHEV[k] + two_z * b1 - b2;
        b2 = b1;
        b1 = b0;
    }
    double g = FM_ERF_CHEBYSHEV[0] + z * b1 - b2;
    double erfc = gauss * g / (1.0 + 2.0 * t_held);
    double tail = fm_from_bits(fm_to_bits(1.0 - erfc) | sign);
    return fm_select(t < FM_ERF_SPLIT, near_zero, tail);
}

#endif
