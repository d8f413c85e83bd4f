/* Counter-based random numbers (Philox4x32-10, Random123).
 *
 * Every draw is a pure function of (seed, stream, id, step, block): nothing to checkpoint, the same for
 * any thread count and after a restart.  Key = {seed, stream}; counter = {id low, id high, step, block}. */
#ifndef SPRAYCOAT_CORE_RNG_H
#define SPRAYCOAT_CORE_RNG_H

#include <stdint.h>

enum rng_stream {
    RNG_STREAM_INJECT_POSITION = 1,
    RNG_STREAM_INJECT_VELOCITY = 2,
    RNG_STREAM_SIZE = 3,
    RNG_STREAM_COUPLE_SAMPLE = 4,
    RNG_STREAM_COUPLE_RUNS = 5,
    RNG_STREAM_TEST = 99,
};

/* The raw Philox4x32-10 block function (exposed for the known-answer test). */
void rng_philox4x32_10(const uint32_t counter[4], const uint32_t key[2], uint32_t out[4]);

/* The 64-bit integer -> (0, 1) map of rng_uniform2: ((bits >> 11) + 0.5) * 2^-53, except that the top value,
 * which rounds to 1.0 in double arithmetic, gives the largest double below 1 (exposed for the edge test). */
double rng_bits_to_open_unit(uint64_t bits);

/* Two independent uniforms in the open interval (0, 1), 53-bit resolution.  Words 0,1 and 2,3 of the block
 * (low word first) make the two 64-bit integers. */
void rng_uniform2(uint32_t seed, uint32_t stream, uint64_t id, uint32_t step, uint32_t block, double out[2]);

#endif
