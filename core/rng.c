/* Counter-based random numbers: Philox4x32-10 from Random123.
 *
 * Random123's philox.h compiles cleanly with gcc 12 -std=c17 -Wall -Wextra -Werror (checked, also with
 * -pedantic), so it is included without pragmas. */
#include "core/rng.h"

#include <Random123/philox.h>

/* 2^-53: one unit in the last place of a double in [0.5, 1). */
#define RNG_TWO_POW_MINUS_53 (1.0 / 9007199254740992.0)

void rng_philox4x32_10(const uint32_t counter[4], const uint32_t key[2], uint32_t out[4])
{
    philox4x32_ctr_t ctr = {{counter[0], counter[1], counter[2], counter[3]}};
    philox4x32_key_t k = {{key[0], key[1]}};
    philox4x32_ctr_t result = philox4x32_R(10, ctr, k);
    for (int i = 0; i < 4; i++)
        out[i] = result.v[i];
}

/* Keep the top 53 bits and centre them in their interval so that 0 never occurs (log(u) and 1/u stay finite).
 * For bits >> 11 >= 2^52 the sum needs 54 significant bits and rounds to even; at the very top it rounds up to
 * 2^53, i.e. u = 1.0, so that single value is pulled back to the largest double below 1. */
double rng_bits_to_open_unit(uint64_t bits)
{
    double u = ((double)(bits >> 11) + 0.5) * RNG_TWO_POW_MINUS_53;
    return u < 1.0 ? u : 1.0 - RNG_TWO_POW_MINUS_53;
}

void rng_uniform2(uint32_t seed, uint32_t stream, uint64_t id, uint32_t step, uint32_t block, double out[2])
{
    const uint32_t counter[4] = {(uint32_t)id, (uint32_t)(id >> 32), step, block};
    const uint32_t key[2] = {seed, stream};
    uint32_t words[4];
    rng_philox4x32_10(counter, key, words);
    out[0] = rng_bits_to_open_unit(((uint64_t)words[1] << 32) | words[0]);
    out[1] = rng_bits_to_open_unit(((uint64_t)words[3] << 32) | words[2]);
}
