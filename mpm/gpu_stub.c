/* The GPU step's functions in a build without it (no make CUDA=1): mpm_gpu_built() is 0, and [run] device = gpu is
 * refused when the case is read (params.c), so none of the others is ever called on a solver. */
#include "mpm/gpu.h"

#ifndef SPRAYCOAT_CUDA
int mpm_gpu_built(void)
{
    return 0;
}
int mpm_gpu_probe(void)
{
    return -1;
}
int mpm_gpu_open(const struct mpm_gpu_setup *setup, struct mpm_gpu **out)
{
    (void)setup;
    *out = NULL;
    return -1;
}
void mpm_gpu_close(struct mpm_gpu *g)
{
    (void)g;
}
int mpm_gpu_upload(struct mpm_gpu *g, const struct mpm_gpu_points *p)
{
    (void)g, (void)p;
    return -1;
}
int mpm_gpu_download(struct mpm_gpu *g, const struct mpm_gpu_points *p)
{
    (void)g, (void)p;
    return -1;
}
int mpm_gpu_host_stale(const struct mpm_gpu *g)
{
    (void)g;
    return 0;
}
int mpm_gpu_step_points(struct mpm_gpu *g, double dt, struct mpm_gpu_step_out *out)
{
    (void)g, (void)dt, (void)out;
    return -1;
}
int mpm_gpu_conduct(struct mpm_gpu *g, double interval, int exchanges)
{
    (void)g, (void)interval, (void)exchanges;
    return -1;
}
int mpm_gpu_interface_nodes(struct mpm_gpu *g, int64_t *interface, int64_t *bonded)
{
    (void)g, (void)interface, (void)bonded;
    return -1;
}
int mpm_gpu_point_sums(struct mpm_gpu *g, double vrest_filter, struct point_sums *sums)
{
    (void)g, (void)vrest_filter, (void)sums;
    return -1;
}
const char *mpm_gpu_name(const struct mpm_gpu *g)
{
    (void)g;
    return "none";
}
const char *mpm_gpu_build(void)
{
    return "none (built without make CUDA=1)";
}
const char *mpm_gpu_message(void)
{
    return "this spraycoat was built without the GPU step (make CUDA=1)";
}
#else
typedef int mpm_gpu_stub_unused; /* the CUDA build defines them in mpm/cuda/step.cu */
#endif
