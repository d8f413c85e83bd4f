/* CUDA on the CPU, for checking the GPU step where no GPU is (BUILD/cuda-emu/spraycoat; docs/gpu.md, "The emulation").
 *
 * The part of the CUDA runtime that mpm/cuda/step.cu uses, in C++17 on the host: device memory is host memory,
 * a kernel launch runs the grid's blocks one after the other and each block's threads one after the other, so a
 * kernel computes what it computes on a device wherever its threads do not race (the step has no atomics: each
 * thread writes its own entries).  A kernel that calls __syncthreads runs its block's threads as coroutines that
 * stop at each barrier until every thread of the block has reached it (found at the kernel's first launch).
 * cudaMalloc fills what it returns with 0xff bytes (every double NaN, every integer -1), so that reading device
 * memory the step never wrote shows.  The <<<grid, block>>> syntax is rewritten to EMU_LAUNCH(kernel, grid, block)
 * by the build (the Makefile's cuda-emu rules), the only change to the source.
 *
 * SPRAYCOAT_CUDA_EMU_ORDER=reverse runs blocks, threads and the coroutines between barriers last to first: a race
 * between threads (one reading what another writes in the same launch) then gives other results, which comparing
 * the two orders shows.  SPRAYCOAT_CUDA_EMU_FAIL_COPY=BYTES makes every copy of exactly BYTES from the device to the
 * host fail with cudaErrorLaunchFailure, as a kernel's fault surfaces on a device at the next copy: the step's
 * handling of a device fault, checked.  What it cannot check: a race that both orders happen to hide, the device's
 * memory model, a host pointer used on the device (or a device pointer on the host: here both are host memory), timing.
 * compute-sanitizer on a device does. */
#ifndef SPRAYCOAT_CUDA_EMU_RUNTIME_H
#define SPRAYCOAT_CUDA_EMU_RUNTIME_H

#include <stddef.h>

#include <tuple>

#define __global__
#define __device__
#define __host__
#define __shared__      static /* one block at a time: the block's threads share it */
#define __forceinline__ inline

typedef enum cudaError {
    cudaSuccess = 0,
    cudaErrorInvalidValue = 1,
    cudaErrorMemoryAllocation = 2,
    cudaErrorInvalidConfiguration = 9,
    cudaErrorNoDevice = 100,
    cudaErrorLaunchFailure = 719,
} cudaError_t;

enum cudaMemcpyKind {
    cudaMemcpyHostToHost = 0,
    cudaMemcpyHostToDevice = 1,
    cudaMemcpyDeviceToHost = 2,
    cudaMemcpyDeviceToDevice = 3,
    cudaMemcpyDefault = 4,
};

typedef struct emu_stream *cudaStream_t;

struct cudaDeviceProp {
    char name[256];
    size_t totalGlobalMem;
    int major, minor;
    int multiProcessorCount;
};

struct dim3 {
    unsigned x, y, z;
    constexpr dim3(unsigned x_ = 1, unsigned y_ = 1, unsigned z_ = 1) : x(x_), y(y_), z(z_) {}
};
struct uint3 {
    unsigned x, y, z;
};

/* the running thread's indices, set by the launch before each thread runs or resumes */
inline uint3 threadIdx, blockIdx;
inline dim3 blockDim, gridDim;

cudaError_t cudaMalloc(void **pointer, size_t bytes);
cudaError_t cudaFree(void *pointer);
cudaError_t cudaMemcpy(void *to, const void *from, size_t bytes, enum cudaMemcpyKind kind);
cudaError_t cudaMemset(void *pointer, int value, size_t bytes);
cudaError_t cudaGetDeviceCount(int *count);
cudaError_t cudaSetDevice(int device);
cudaError_t cudaGetDeviceProperties(struct cudaDeviceProp *prop, int device);
cudaError_t cudaDeviceSynchronize(void);
cudaError_t cudaGetLastError(void);
const char *cudaGetErrorString(cudaError_t error);
void __syncthreads(void);

namespace emu
{
/* one launch: the grid's threads, each calling thread_body() with the indices set */
struct thread_body {
    virtual void run() = 0;
    virtual ~thread_body() = default;
};
void run_grid(const void *kernel, dim3 grid, dim3 block, thread_body &body);

template <typename... P> struct launcher {
    void (*kernel)(P...);
    dim3 grid, block;
    template <typename... A> void operator()(const A &...args) const
    {
        struct call : thread_body {
            void (*kernel)(P...);
            std::tuple<const A &...> args;
            call(void (*k)(P...), const A &...a) : kernel(k), args(a...) {}
            void run() override { std::apply(kernel, args); } /* by value, as a launch copies them */
        } body(kernel, args...);
        run_grid((const void *)kernel, grid, block, body);
    }
};

template <typename... P> launcher<P...> launch(void (*kernel)(P...), dim3 grid, dim3 block)
{
    return launcher<P...>{kernel, grid, block};
}
} // namespace emu

#define EMU_LAUNCH(kernel, grid, block) emu::launch(kernel, dim3(grid), dim3(block))

#endif
