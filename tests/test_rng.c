/* Philox4x32-10 known answers and the statistics of rng_uniform2. */
#include "core/rng.h"
#include "tests/check.h"

#include <stdint.h>
#include <string.h>

#define SEED 20240611u

/* Random123's kat_vectors, the three "philox4x32 10" lines: counter (4 words), key (2 words), expected. */
static void test_known_answers(void)
{
    static const struct {
        uint32_t counter[4];
        uint32_t key[2];
        uint32_t expected[4];
    } kat[] = {
        {{0, 0, 0, 0}, {0, 0}, {0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}},
        {{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
         {0xffffffffu, 0xffffffffu},
         {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}},
        {{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u},
         {0xa4093822u, 0x299f31d0u},
         {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}},
    };
    for (size_t v = 0; v < sizeof kat / sizeof kat[0]; v++) {
        uint32_t out[4];
        rng_philox4x32_10(kat[v].counter, kat[v].key, out);
        for (int i = 0; i < 4; i++)
            CHECK(out[i] == kat[v].expected[i], "vector %zu word %d: got %08x, expected %08x", v, i, out[i],
                  kat[v].expected[i]);
    }
}

/* rng_uniform2 is the documented mapping of the block function's output. */
static void test_uniform_mapping(void)
{
    const uint64_t id = 0x0000000500000007ull;
    const uint32_t counter[4] = {7, 5, 11, 3};
    const uint32_t key[2] = {SEED, RNG_STREAM_TEST};
    uint32_t words[4];
    rng_philox4x32_10(counter, key, words);
    double u[2];
    rng_uniform2(SEED, RNG_STREAM_TEST, id, 11, 3, u);
    for (int k = 0; k < 2; k++) {
        uint64_t bits = ((uint64_t)words[2 * k + 1] << 32) | words[2 * k];
        double expected = ((double)(bits >> 11) + 0.5) / 9007199254740992.0;
        CHECK(u[k] == expected, "uniform %d: got %.17g, expected %.17g", k, u[k], expected);
    }
}

/* The extreme integers: 0 gives 2^-54, and all ones (whose centred value rounds to 1.0 in double arithmetic)
 * gives the largest double below 1; the map never decreases. */
static void test_open_unit_extremes(void)
{
    const double two_pow_53 = 9007199254740992.0;
    double lowest = rng_bits_to_open_unit(0);
    double highest = rng_bits_to_open_unit(UINT64_MAX);
    CHECK(lowest == 0.5 / two_pow_53, "bits 0 give %.17g, expected 2^-54", lowest);
    CHECK(highest < 1.0 && highest == 1.0 - 1.0 / two_pow_53, "all-ones bits give %.17g, expected 1 - 2^-53", highest);
    const uint64_t probes[] = {0, 1u << 11, (1ull << 63) - 1, 1ull << 63, UINT64_MAX - (1u << 11), UINT64_MAX};
    for (size_t i = 0; i < sizeof probes / sizeof probes[0]; i++) {
        double u = rng_bits_to_open_unit(probes[i]);
        CHECK(u > 0.0 && u < 1.0, "bits %016llx give %.17g", (unsigned long long)probes[i], u);
        if (i > 0)
            CHECK(u >= rng_bits_to_open_unit(probes[i - 1]), "map decreases at bits %016llx",
                  (unsigned long long)probes[i]);
    }
}

static void test_open_interval(void)
{
    int outside = 0;
    for (uint64_t id = 0; id < 500000; id++) {
        double u[2];
        rng_uniform2(SEED, RNG_STREAM_TEST, id, 0, 0, u);
        outside += !(u[0] > 0.0 && u[0] < 1.0) + !(u[1] > 0.0 && u[1] < 1.0);
    }
    CHECK(outside == 0, "%d of 1e6 draws outside (0, 1)", outside);
}

/* Mean and variance of 1e6 draws within 5 standard errors of 1/2 and 1/12.  The standard error of the
 * sample variance of U(0,1) is sqrt((mu4 - sigma^4) / n) with mu4 = 1/80 and sigma^4 = 1/144. */
static void test_mean_and_variance(void)
{
    const int pairs = 500000;
    const double n = 2.0 * pairs;
    double sum = 0.0, sum_sq = 0.0;
    for (int i = 0; i < pairs; i++) {
        double u[2];
        rng_uniform2(SEED, RNG_STREAM_TEST, (uint64_t)i, 17, 0, u);
        sum += u[0] + u[1];
        sum_sq += u[0] * u[0] + u[1] * u[1];
    }
    double mean = sum / n;
    double variance = sum_sq / n - mean * mean;
    double mean_error = sqrt(1.0 / 12.0 / n);
    double variance_error = sqrt((1.0 / 80.0 - 1.0 / 144.0) / n);
    CHECK_CLOSE(mean, 0.5, 0.0, 5.0 * mean_error, "mean of 1e6 uniforms");
    CHECK_CLOSE(variance, 1.0 / 12.0, 0.0, 5.0 * variance_error, "variance of 1e6 uniforms");
}

static int same_pair(const double a[2], const double b[2])
{
    return a[0] == b[0] && a[1] == b[1];
}

static void test_inputs_select_different_numbers(void)
{
    double base[2], other[2];
    rng_uniform2(SEED, RNG_STREAM_INJECT_POSITION, 42, 7, 0, base);
    CHECK(base[0] != base[1], "the two uniforms of one draw are equal");

    rng_uniform2(SEED, RNG_STREAM_INJECT_POSITION, 43, 7, 0, other);
    CHECK(!same_pair(base, other), "id 42 and 43 give the same numbers");
    rng_uniform2(SEED, RNG_STREAM_INJECT_POSITION, 42 + (1ull << 32), 7, 0, other);
    CHECK(!same_pair(base, other), "the high word of the id is ignored");
    rng_uniform2(SEED, RNG_STREAM_INJECT_POSITION, 42, 8, 0, other);
    CHECK(!same_pair(base, other), "step 7 and 8 give the same numbers");
    rng_uniform2(SEED, RNG_STREAM_INJECT_VELOCITY, 42, 7, 0, other);
    CHECK(!same_pair(base, other), "streams 1 and 2 give the same numbers");
    rng_uniform2(SEED, RNG_STREAM_INJECT_POSITION, 42, 7, 1, other);
    CHECK(!same_pair(base, other), "block 0 and 1 give the same numbers");
    rng_uniform2(SEED + 1, RNG_STREAM_INJECT_POSITION, 42, 7, 0, other);
    CHECK(!same_pair(base, other), "seeds %u and %u give the same numbers", SEED, SEED + 1);
}

/* A pure function: the same inputs give bit-identical numbers, whatever was drawn in between. */
static void test_pure_function(void)
{
    double first[2], again[2], unrelated[2];
    rng_uniform2(SEED, RNG_STREAM_SIZE, 123456789012ull, 99, 2, first);
    for (uint64_t id = 0; id < 1000; id++)
        rng_uniform2(SEED, RNG_STREAM_SIZE, id, 99, 2, unrelated);
    rng_uniform2(SEED, RNG_STREAM_SIZE, 123456789012ull, 99, 2, again);
    CHECK(memcmp(first, again, sizeof first) == 0, "repeated draw differs: %.17g %.17g vs %.17g %.17g", first[0],
          first[1], again[0], again[1]);
}

/* Pearson chi-square of 1e6 draws in 100 equal bins, 99 degrees of freedom; the 99.9 % quantile of
 * chi-square(99) is 148.23 (computed from the regularised incomplete gamma function). */
static void test_chi_square(void)
{
    enum { BINS = 100, PAIRS = 500000 };
    long counts[BINS] = {0};
    for (int i = 0; i < PAIRS; i++) {
        double u[2];
        rng_uniform2(SEED, RNG_STREAM_TEST, (uint64_t)i, 3, 1, u);
        counts[(int)(u[0] * BINS)]++;
        counts[(int)(u[1] * BINS)]++;
    }
    const double expected = 2.0 * PAIRS / BINS;
    double chi2 = 0.0;
    for (int b = 0; b < BINS; b++)
        chi2 += (counts[b] - expected) * (counts[b] - expected) / expected;
    printf("  chi-square of 1e6 draws in %d bins: %.2f (99.9 %% quantile 148.23)\n", BINS, chi2);
    CHECK(chi2 < 148.23, "chi-square %.2f above the 99.9 %% quantile 148.23", chi2);
}

int main(void)
{
    RUN(test_known_answers);
    RUN(test_uniform_mapping);
    RUN(test_open_unit_extremes);
    RUN(test_open_interval);
    RUN(test_mean_and_variance);
    RUN(test_inputs_select_different_numbers);
    RUN(test_pure_function);
    RUN(test_chi_square);
    return check_finish();
}
