#include "core/run_keys.h"

const struct cfg_key run_case_keys[] = {
    {"run", "seed", CFG_INT, "-", "1", 0, 2147483647, 0, NULL,
     "seed of the counter-based random generator (results depend only on it, not on threads)"},
    {"run", "threads", CFG_INT, "-", "0", 0, 4096, CFG_NOT_HASHED, NULL, "OpenMP threads, 0 = all cores"},
    {"run", "checkpoint_wall", CFG_REAL, "s", "600", 0, 1e9, CFG_NOT_HASHED, NULL,
     "wall-clock seconds between checkpoints, 0 = off"},
    {"run", "checkpoint_steps", CFG_INT, "-", "0", 0, 2147483647, CFG_NOT_HASHED, NULL,
     "steps between checkpoints, 0 = off"},
    {"run", "keep_checkpoints", CFG_INT, "-", "3", 1, 1000, CFG_NOT_HASHED, NULL, "newest checkpoints kept per stage"},
    {"run", "device", CFG_CHOICE, "", "cpu", 0, 0, CFG_NOT_HASHED, "cpu|gpu",
     "where the impact step runs: cpu, or gpu (an NVIDIA GPU in FP64; a build with make CUDA=1, docs/gpu.md)"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

void run_settings_load(const struct case_file *c, struct run_settings *run)
{
    run->seed = (uint32_t)case_int(c, "run", "seed");
    run->threads = (int)case_int(c, "run", "threads");
    run->checkpoint_wall = case_real(c, "run", "checkpoint_wall");
    run->checkpoint_steps = case_int(c, "run", "checkpoint_steps");
    run->keep_checkpoints = (int)case_int(c, "run", "keep_checkpoints");
    run->gpu = case_is(c, "run", "device", "gpu");
}
