/* e^x, ln x, x^y and x^(-1/3) in plain double arithmetic (no libm calls, no branches).  (Square roots are
 * sqrt: with -fno-math-errno, as dem/integrate.c is built, the correctly rounded instruction vectorises.)
 *
 * Why: the drag integration (dem/integrate.c) evaluates a power (Haider-Levenspiel, Eq. 25), an inverse cube
 * root and an exponential (the jet, Eqs. 26-27) for every particle and step, and libm's scalar calls cost
 * most of its time.  Written as selects and IEEE operations these functions vectorise across particles, and
 * a vector lane gives the same bits as the scalar code (C17 mode: no contraction into FMA), so results do
 * not depend on how particles are split between threads or vector lanes.
 *
 * Accuracy (measured against libm over the ranges used, tests/test_gas.c checks the jet and drag to 1e-14 and
 * 1e-13; tests/test_fastmath.c measures): exp and log within 1-2 ulp, x^(-1/3) within 1 ulp, pow within a few
 * ulp (the error of ln x scaled by y). */
#ifndef SPRAYCOAT_DEM_FASTMATH_H
#define SPRAYCOAT_DEM_FASTMATH_H

#include <float.h>
#include <stdint.h>
#include <string.h>

/* Inlined whatever the compiler's size limits: the loops over particles that call these vectorise only when
 * nothing in them is a call.  Under nvcc (make CUDA=1, mpm/cuda/) for the host and the device alike: the GPU's
 * stress update calls the very functions of the CPU's (SC_HD marks the others it shares, docs/gpu.md). */
#ifdef __CUDACC__
#define SC_HD     __host__ __device__
#define FM_INLINE static __host__ __device__ __forceinline__
#else
#define SC_HD
#define FM_INLINE static inline __attribute__((always_inline))
#endif

/* ln 2 split so that n * FM_LN2_HI is exact for |n| < 2^11 (fdlibm's split). */
#define FM_LN2_HI 6.93147180369123816490e-01
#define FM_LN2_LO 1.90821492927058770002e-10
#define FM_LOG2_E 1.44269504088896338700e+00
#define FM_SQRT2  1.41421356237309504880
/* Adding 1.5 * 2^52 rounds a double of magnitude below 2^51 to an integer held in the low mantissa bits. */
#define FM_ROUNDING_SHIFTER 6755399441055744.0

FM_INLINE double fm_from_bits(uint64_t bits)
{
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

FM_INLINE uint64_t fm_to_bits(double value)
{
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    return bits;
}

/* condition ? a : b without a branch: a bit mask.  Written so because the compiler turns ?: on doubles back into
 * branches (jump threading), and a loop with branches does not vectorise. */
FM_INLINE double fm_select(int condition, double a, double b)
{
    uint64_t mask = (uint64_t)0 - (uint64_t)(condition != 0);
    return fm_from_bits((fm_to_bits(a) & mask) | (fm_to_bits(b) & ~mask));
}

/* The argument reduction shared by fm_exp and fm_expm1 (core/fastmath_special.h): x clamped to [-708, 709]
 * (NaN stays NaN), x = n ln2 + r with |r| <= ln2 / 2; `shifted` holds n in its low bits. */
FM_INLINE double fm_exp_reduce(double x, double *shifted)
{
    x = fm_select(x < -708.0, -708.0, x);
    x = fm_select(x > 709.0, 709.0, x);
    *shifted = x * FM_LOG2_E + FM_ROUNDING_SHIFTER;
    double n = *shifted - FM_ROUNDING_SHIFTER;
    return (x - n * FM_LN2_HI) - n * FM_LN2_LO;
}

/* e^r - 1 for the reduced r: r (1 + r/2 + ... + r^12/13!), the Taylor series of e^r to r^13 (the remainder
 * r^14/14! < 5e-18 for |r| <= 0.347). */
FM_INLINE double fm_exp_series_minus_one(double r)
{
    double p = 1.0 / 6227020800.0;
    p = p * r + 1.0 / 479001600.0;
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    return p * r;
}

/* 2^n from the shifter of fm_exp_reduce: biased exponent n + 1023 in [1, 2046]. */
FM_INLINE double fm_exp_power_of_two(double shifted)
{
    uint64_t biased = fm_to_bits(shifted) - fm_to_bits(FM_ROUNDING_SHIFTER) + 1023u;
    return fm_from_bits(biased << 52);
}

/* e^x.  Below -708 the result is 0 (no subnormals: the jet's e^(-2|xi|) far from the axis must give sech^2 = 0
 * exactly); above 709 it is e^709.  NaN stays NaN. */
FM_INLINE double fm_exp(double x)
{
    double shifted, r = fm_exp_reduce(x, &shifted);
    double result = (fm_exp_series_minus_one(r) + 1.0) * fm_exp_power_of_two(shifted);
    return fm_select(x < -708.0, 0.0, result);
}

/* x = 2^exponent m for normal positive x: returns m in [1, 2) and the exponent as a double, both from the bits
 * (exact, and vectorises); shared by fm_log and fm_inverse_cbrt. */
FM_INLINE double fm_split(double x, double *exponent)
{
    uint64_t bits = fm_to_bits(x);
    *exponent = fm_from_bits((bits >> 52) | 0x4330000000000000ull) - (4503599627370496.0 + 1023.0);
    return fm_from_bits((bits & 0x000fffffffffffffull) | 0x3ff0000000000000ull);
}

/* ln x for normal positive x (subnormals are read as if normal; callers keep x >= 1e-300).  +Inf and NaN are
 * returned as they are. */
FM_INLINE double fm_log(double x)
{
    /* x = 2^e m, m in [sqrt(1/2), sqrt(2)) */
    double exponent, mantissa = fm_split(x, &exponent);
    int above = mantissa > FM_SQRT2;
    double half_mantissa = 0.5 * mantissa, next_exponent = exponent + 1.0;
    mantissa = fm_select(above, half_mantissa, mantissa);
    exponent = fm_select(above, next_exponent, exponent);
    /* ln m = 2 atanh(s), s = (m - 1)/(m + 1), |s| <= 0.1716: 2 s (1 + z/3 + z^2/5 + ...), z = s^2, to z^11 */
    double f = mantissa - 1.0; /* exact (Sterbenz) */
    double s = f / (2.0 + f), z = s * s;
    double series = 1.0 / 23.0;
    series = series * z + 1.0 / 21.0;
    series = series * z + 1.0 / 19.0;
    series = series * z + 1.0 / 17.0;
    series = series * z + 1.0 / 15.0;
    series = series * z + 1.0 / 13.0;
    series = series * z + 1.0 / 11.0;
    series = series * z + 1.0 / 9.0;
    series = series * z + 1.0 / 7.0;
    series = series * z + 1.0 / 5.0;
    series = series * z + 1.0 / 3.0;
    double log_mantissa = 2.0 * s + 2.0 * s * (z * series);
    double result = exponent * FM_LN2_HI + (log_mantissa + exponent * FM_LN2_LO);
    return fm_select(x <= DBL_MAX, result, x);
}

/* x^y for x > 0 (x below 1e-300 is taken as 1e-300). */
FM_INLINE double fm_pow(double x, double y)
{
    return fm_exp(y * fm_log(fm_select(x > 1e-300, x, 1e-300)));
}

/* x^(-1/3) for x > 0 (x below 1e-300 is taken as 1e-300; finite x only) within 2 ulp, without exp, log or a
 * division: x = 2^(3q + k) m, m in [1, 2), k in {0, 1, 2}, so x^(-1/3) = 2^-q y^(-1/3) with y = 2^k m in
 * [1, 8).  A quadratic in m times 2^(-k/3) guesses y^(-1/3) within 2.1e-3 (Chebyshev interpolation of
 * m^(-1/3) on [1, 2]), and three Newton steps for r^-3 = y, r <- r + r (1 - y r^3)/3, whose relative error
 * goes e -> 2 e^2, reach rounding (2.1e-3 -> 8.8e-6 -> 1.5e-10 -> 5e-20).  The jet (dem/gas_eval.h) needs
 * x^(-1/3) and x^(-2/3); fm_cbrt's exp(log(x)/3) cost twice as much and a division for each. */
FM_INLINE double fm_inverse_cbrt(double x)
{
    double exponent, mantissa = fm_split(fm_select(x > 1e-300, x, 1e-300), &exponent);
    /* q = floor(exponent / 3) as the integer nearest exponent / 3 - 0.4 (the shifter rounds; floor() would keep
     * gcc from vectorising the loops that call this) */
    double q = (exponent * (1.0 / 3.0) - 0.4 + FM_ROUNDING_SHIFTER) - FM_ROUNDING_SHIFTER, k = exponent - 3.0 * q;
    double y = mantissa * fm_select(k == 0.0, 1.0, fm_select(k == 1.0, 2.0, 4.0));
    double guess = 1.3835059191296828 + mantissa * (-0.47684205620727066 + mantissa * 0.09126116885223201);
    double r = guess * fm_select(k == 0.0, 1.0, fm_select(k == 1.0, 0.79370052598409973738, 0.62996052494743658238));
    for (int step = 0; step < 3; step++) {
        double residual = 1.0 - y * r * r * r;
        r = r + r * residual * (1.0 / 3.0);
    }
    return r * fm_exp_power_of_two(FM_ROUNDING_SHIFTER - q);
}

#endif
