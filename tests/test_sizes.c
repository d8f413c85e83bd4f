/* Particle sizes (dem/sizes.c): the Weibull scale of Eq. (37) against the reference table, the
 * distribution functions, and inverse-transform sampling with the counter-based RNG (moments and a
 * one-sample Kolmogorov-Smirnov test, also for the truncated law). */
#include "core/rng.h"
/* A white-box test: includes the module-private header dem/sizes.h (only tests may; tests/test_symbols.sh). */
#include "dem/sizes.h"
#include "tests/check.h"
#include "tests/verification_csv.h"

#include <string.h>

/* ---- sampling helpers ---- */

#define SAMPLE_COUNT 200000
#define SAMPLE_SEED  20150302u
/* 1 % critical value of sqrt(N) D for the one-sample Kolmogorov-Smirnov test, large N. */
#define KS_CRITICAL_1PERCENT 1.63

static double samples[SAMPLE_COUNT];

/* Fill `samples` from dem_sizes_sample with u = the first of rng_uniform2(seed, RNG_STREAM_SIZE, id, 0, 0). */
static void draw_samples(const struct dem_size_distribution *dist, uint64_t first_id)
{
    for (int i = 0; i < SAMPLE_COUNT; i++) {
        double u[2];
        rng_uniform2(SAMPLE_SEED, RNG_STREAM_SIZE, first_id + (uint64_t)i, 0, 0, u);
        samples[i] = dem_sizes_sample(dist, u[0]);
    }
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* CDF of the Weibull law truncated to [d_min, d_max] (d_min = 0, d_max = INFINITY: untruncated). */
struct truncated_weibull {
    double scale, shape, d_min, d_max;
};

static double truncated_cdf(const struct truncated_weibull *law, double d)
{
    double low = dem_weibull_cdf(law->d_min, law->scale, law->shape);
    double high = isinf(law->d_max) ? 1.0 : dem_weibull_cdf(law->d_max, law->scale, law->shape);
    double f = (dem_weibull_cdf(d, law->scale, law->shape) - low) / (high - low);
    return fmin(fmax(f, 0.0), 1.0);
}

/* sqrt(N) times the Kolmogorov-Smirnov distance between the sorted samples and the law. */
static double ks_statistic(const struct truncated_weibull *law)
{
    double worst = 0.0;
    for (int i = 0; i < SAMPLE_COUNT; i++) {
        double f = truncated_cdf(law, samples[i]);
        double above = (double)(i + 1) / SAMPLE_COUNT - f, below = f - (double)i / SAMPLE_COUNT;
        worst = fmax(worst, fmax(above, below));
    }
    return worst * sqrt((double)SAMPLE_COUNT);
}

static void sample_moments(double *mean, double *std)
{
    double sum = 0.0;
    for (int i = 0; i < SAMPLE_COUNT; i++)
        sum += samples[i];
    *mean = sum / SAMPLE_COUNT;
    double squares = 0.0;
    for (int i = 0; i < SAMPLE_COUNT; i++)
        squares += (samples[i] - *mean) * (samples[i] - *mean);
    *std = sqrt(squares / (SAMPLE_COUNT - 1));
}

/* Standard error of the sample standard deviation: sqrt((mu4 - sigma^4)/N) / (2 sigma), with the
 * Weibull raw moments lambda^k Gamma(1 + k/n). */
static double std_standard_error(double scale, double shape)
{
    double g1 = tgamma(1.0 + 1.0 / shape), g2 = tgamma(1.0 + 2.0 / shape);
    double g3 = tgamma(1.0 + 3.0 / shape), g4 = tgamma(1.0 + 4.0 / shape);
    double variance = g2 - g1 * g1;
    double mu4 = g4 - 4.0 * g3 * g1 + 6.0 * g2 * g1 * g1 - 3.0 * g1 * g1 * g1 * g1;
    return scale * sqrt((mu4 - variance * variance) / SAMPLE_COUNT) / (2.0 * sqrt(variance));
}

/* ---- the table rows ---- */

static void check_weibull_row(const struct csv_row *row)
{
    double shape = csv_number(row, 0), median = csv_number(row, 1), mean = csv_number(row, 3), std = csv_number(row, 4);
    double scale = dem_weibull_scale(median, shape);
    CHECK_CLOSE(scale, csv_number(row, 2), 1e-9, 0.0, "Weibull scale (Eq. 37)");
    CHECK_CLOSE(dem_weibull_cdf(median, scale, shape), 0.5, 1e-14, 0.0, "F(median) = 1/2");

    /* Every row maps the same uniforms (ids 0..N-1): the KS distance of exact inverse-transform samples
     * against their own CDF is that of the uniforms, so the rows share one draw of the 1 % test instead of
     * running eight (a family-wise false alarm rate of 8 %); what each row adds is the check that
     * dem_sizes_sample, dem_weibull_cdf and the scale agree, and the rejection of the wrong shape. */
    struct dem_size_distribution dist = {0, median, shape, 0.0, INFINITY};
    draw_samples(&dist, 0);
    double sample_mean, sample_std;
    sample_moments(&sample_mean, &sample_std);
    CHECK_CLOSE(sample_mean, mean, 0.0, 4.0 * std / sqrt((double)SAMPLE_COUNT), "sample mean within 4 s.e.");
    CHECK_CLOSE(sample_std, std, 0.0, 4.0 * std_standard_error(scale, shape), "sample std within 4 s.e.");

    qsort(samples, SAMPLE_COUNT, sizeof samples[0], compare_doubles);
    struct truncated_weibull law = {scale, shape, 0.0, INFINITY};
    double ks = ks_statistic(&law);
    CHECK(ks < KS_CRITICAL_1PERCENT, "n %g: KS sqrt(N) D = %g against the sampled law", shape, ks);
    /* The same test against a law with the same median and a 10 % larger shape must reject. */
    struct truncated_weibull wrong = {dem_weibull_scale(median, 1.1 * shape), 1.1 * shape, 0.0, INFINITY};
    double ks_wrong = ks_statistic(&wrong);
    CHECK(ks_wrong > KS_CRITICAL_1PERCENT, "n %g: KS sqrt(N) D = %g should reject the wrong shape", shape, ks_wrong);
}

static void test_weibull_table(void)
{
    int rows = csv_for_each("weibull_sizes.csv", check_weibull_row);
    CHECK(rows >= 8, "weibull_sizes.csv rows: %d", rows);
}

/* ---- distribution functions ---- */

static void test_distribution_functions(void)
{
    double scale = 4.4e-5, shape = 3.5;
    const double d[] = {1e-6, 2e-5, 4.4e-5, 7e-5, 9e-5};
    for (int i = 0; i < 5; i++) {
        double f = dem_weibull_cdf(d[i], scale, shape);
        /* rtol 1e-9: the naive 1 - exp(-x) loses digits at small d, which -expm1 keeps */
        CHECK_CLOSE(f, 1.0 - exp(-pow(d[i] / scale, shape)), 1e-9, 0.0, "F(d) = 1 - exp(-(d/lambda)^n)");
        CHECK_CLOSE(dem_weibull_quantile(f, scale, shape), d[i], 1e-10, 0.0, "quantile inverts the CDF");
        double h = 1e-6 * d[i];
        double slope = (dem_weibull_cdf(d[i] + h, scale, shape) - dem_weibull_cdf(d[i] - h, scale, shape)) / (2.0 * h);
        CHECK_CLOSE(dem_weibull_pdf(d[i], scale, shape), slope, 1e-6, 0.0, "pdf = dF/dd (Eq. 36)");
    }
    CHECK(dem_weibull_cdf(0.0, scale, shape) == 0.0 && dem_weibull_cdf(-1.0, scale, shape) == 0.0, "F = 0 for d <= 0");
    CHECK(dem_weibull_pdf(-1.0, scale, shape) == 0.0, "f = 0 for d < 0");
    CHECK_CLOSE(dem_weibull_pdf(0.0, scale, 1.0), 1.0 / scale, 1e-15, 0.0, "exponential pdf at 0");
}

/* ---- truncation ---- */

static void test_truncated_sampling(void)
{
    double median = 4e-5, shape = 2.0;
    struct dem_size_distribution dist = {0, median, shape, 0.6 * median, 1.5 * median};
    draw_samples(&dist, 0); /* the same fixed draw as the table rows (see check_weibull_row) */
    int outside = 0;
    for (int i = 0; i < SAMPLE_COUNT; i++)
        outside += samples[i] < dist.d_min || samples[i] > dist.d_max;
    CHECK(outside == 0, "%d samples outside [d_min, d_max]", outside);
    qsort(samples, SAMPLE_COUNT, sizeof samples[0], compare_doubles);
    struct truncated_weibull law = {dem_weibull_scale(median, shape), shape, dist.d_min, dist.d_max};
    double ks = ks_statistic(&law);
    CHECK(ks < KS_CRITICAL_1PERCENT, "truncated: KS sqrt(N) D = %g", ks);
    struct truncated_weibull untruncated = {law.scale, shape, 0.0, INFINITY};
    double ks_untruncated = ks_statistic(&untruncated);
    CHECK(ks_untruncated > KS_CRITICAL_1PERCENT, "truncated samples must fail against the full law (%g)",
          ks_untruncated);
    /* The ends of u map onto the ends of the interval. */
    CHECK_CLOSE(dem_sizes_sample(&dist, 1e-16), dist.d_min, 1e-9, 0.0, "u -> 0 gives d_min");
    CHECK_CLOSE(dem_sizes_sample(&dist, 1.0 - 1e-16), dist.d_max, 1e-9, 0.0, "u -> 1 gives d_max");
}

static void test_monodisperse(void)
{
    struct dem_size_distribution dist = {1, 3e-5, 2.0, 0.0, INFINITY};
    CHECK(dem_sizes_sample(&dist, 0.01) == 3e-5 && dem_sizes_sample(&dist, 0.99) == 3e-5, "monodisperse: the median");
    dist.monodisperse = 0;
    CHECK_CLOSE(dem_sizes_sample(&dist, 0.5), 3e-5, 1e-14, 0.0, "u = 1/2 gives the median");
}

int main(void)
{
    RUN(test_weibull_table);
    RUN(test_distribution_functions);
    RUN(test_truncated_sampling);
    RUN(test_monodisperse);
    return check_finish();
}
