/* The [run] section every stage shares: seed, threads, checkpoint policy, the impact step's device. */
#ifndef SPRAYCOAT_CORE_RUN_KEYS_H
#define SPRAYCOAT_CORE_RUN_KEYS_H

#include "core/config.h"

extern const struct cfg_key run_case_keys[];

struct run_settings {
    uint32_t seed;
    int threads;            /* 0: all cores */
    double checkpoint_wall; /* s between checkpoints, 0 = off */
    long checkpoint_steps;  /* steps between checkpoints, 0 = off */
    int keep_checkpoints;
    int gpu; /* [run] device = gpu: the impact step on the GPU (mpm reads it with the impact's keys) */
};

void run_settings_load(const struct case_file *c, struct run_settings *run);

#endif
