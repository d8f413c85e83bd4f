/* CUDA on the CPU: the runtime's functions and the launch (tests/cuda_emu/cuda_runtime.h says what it is for and
 * what it cannot check). */
#include <cuda_runtime.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <ucontext.h>

#include <map>
#include <memory>
#include <vector>

static cudaError_t last_error = cudaSuccess;

static cudaError_t record(cudaError_t error)
{
    if (error != cudaSuccess)
        last_error = error;
    return error;
}

cudaError_t cudaMalloc(void **pointer, size_t bytes)
{
    if (!pointer)
        return record(cudaErrorInvalidValue);
    *pointer = malloc(bytes ? bytes : 1);
    if (!*pointer)
        return record(cudaErrorMemoryAllocation);
    memset(*pointer, 0xff, bytes); /* device memory starts undefined: here NaN and -1, so that reading it shows */
    return cudaSuccess;
}

cudaError_t cudaFree(void *pointer)
{
    free(pointer);
    return cudaSuccess;
}

/* SPRAYCOAT_CUDA_EMU_FAIL_COPY: the size of the device-to-host copies that fail (cuda_runtime.h), 0 none */
static size_t failing_copy_bytes(void)
{
    const char *given = getenv("SPRAYCOAT_CUDA_EMU_FAIL_COPY");
    return given ? (size_t)strtoull(given, NULL, 10) : 0;
}

cudaError_t cudaMemcpy(void *to, const void *from, size_t bytes, enum cudaMemcpyKind kind)
{
    if (bytes && (!to || !from || (int)kind < 0 || (int)kind > 4))
        return record(cudaErrorInvalidValue);
    static const size_t failing = failing_copy_bytes();
    if (failing && bytes == failing && kind == cudaMemcpyDeviceToHost)
        return record(cudaErrorLaunchFailure);
    if (bytes)
        memmove(to, from, bytes);
    return cudaSuccess;
}

cudaError_t cudaMemset(void *pointer, int value, size_t bytes)
{
    if (bytes && !pointer)
        return record(cudaErrorInvalidValue);
    if (bytes)
        memset(pointer, value, bytes);
    return cudaSuccess;
}

/* One device, unless SPRAYCOAT_CUDA_EMU_DEVICES says how many (0: the machine without a device). */
cudaError_t cudaGetDeviceCount(int *count)
{
    const char *given = getenv("SPRAYCOAT_CUDA_EMU_DEVICES");
    *count = given ? atoi(given) : 1;
    return *count > 0 ? cudaSuccess : cudaErrorNoDevice;
}

cudaError_t cudaSetDevice(int device)
{
    int count = 0;
    cudaGetDeviceCount(&count);
    return device >= 0 && device < count ? cudaSuccess : record(cudaErrorInvalidValue);
}

cudaError_t cudaGetDeviceProperties(struct cudaDeviceProp *prop, int device)
{
    memset(prop, 0, sizeof *prop);
    snprintf(prop->name, sizeof prop->name, "CUDA emulated on the CPU (tests/cuda_emu), device %d", device);
    prop->totalGlobalMem = (size_t)16 << 30;
    prop->major = 9, prop->minor = 0;
    prop->multiProcessorCount = 1;
    return cudaSuccess;
}

cudaError_t cudaDeviceSynchronize(void)
{
    return cudaSuccess;
}

cudaError_t cudaGetLastError(void)
{
    cudaError_t error = last_error;
    last_error = cudaSuccess;
    return error;
}

const char *cudaGetErrorString(cudaError_t error)
{
    switch (error) {
    case cudaSuccess:
        return "no error";
    case cudaErrorInvalidValue:
        return "invalid argument";
    case cudaErrorMemoryAllocation:
        return "out of memory";
    case cudaErrorInvalidConfiguration:
        return "invalid configuration argument";
    case cudaErrorNoDevice:
        return "no CUDA-capable device is detected";
    case cudaErrorLaunchFailure:
        return "unspecified launch failure";
    }
    return "unknown error";
}

/* ---- the launch ---- */

/* A block whose kernel calls __syncthreads: a coroutine per thread, each run until it reaches the barrier or
 * returns, in thread order, round after round.  On x86-64 a thread is switched by saving the callee-saved registers
 * and the stack pointer (emu_switch below: a few ns, where glibc's swapcontext makes a system call for the signal
 * mask, 0.7 us a round trip, which made the step's one block reduction cost 0.3 s); elsewhere, and under
 * AddressSanitizer (which follows swapcontext, not a bare stack switch), with ucontext. */
#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
#define EMU_FAST_SWITCH 1
/* emu_switch(&save, load): the callee-saved registers pushed, the stack pointer stored in save, the one in load
 * taken and its registers popped, returning into the other context (System V AMD64 ABI: rbx, rbp, r12-r15 and
 * rsp are the callee's to keep; MXCSR and the x87 control word are left alone, as nothing here changes them). */
extern "C" void emu_switch(void **save, void *load);
asm(".text\n"
    ".globl emu_switch\n"
    ".type emu_switch, @function\n"
    "emu_switch:\n"
    "    pushq %rbp\n"
    "    pushq %rbx\n"
    "    pushq %r12\n"
    "    pushq %r13\n"
    "    pushq %r14\n"
    "    pushq %r15\n"
    "    movq %rsp, (%rdi)\n"
    "    movq %rsi, %rsp\n"
    "    popq %r15\n"
    "    popq %r14\n"
    "    popq %r13\n"
    "    popq %r12\n"
    "    popq %rbx\n"
    "    popq %rbp\n"
    "    ret\n"
    ".size emu_switch, .-emu_switch\n");
#else
#define EMU_FAST_SWITCH 0
#endif

namespace
{
struct block_run {
    emu::thread_body *body;
    std::vector<std::unique_ptr<char[]>> stacks; /* kept from launch to launch */
    std::vector<char> done;
#if EMU_FAST_SWITCH
    std::vector<void *> saved; /* each thread's stack pointer while it waits */
    void *scheduler;
#else
    std::vector<ucontext_t> contexts;
    ucontext_t scheduler;
#endif
    unsigned current;
    int barriers; /* __syncthreads calls seen in this launch */
};
block_run *cooperative = nullptr; /* the block now run as coroutines; none while threads run plainly */
constexpr size_t STACK_BYTES = 256 * 1024;

/* from the running thread back to the scheduler */
void yield_to_scheduler(block_run *r)
{
#if EMU_FAST_SWITCH
    emu_switch(&r->saved[r->current], r->scheduler);
#else
    swapcontext(&r->contexts[r->current], &r->scheduler);
#endif
}

/* from the scheduler into thread t */
void resume_thread(block_run *r, unsigned t)
{
#if EMU_FAST_SWITCH
    emu_switch(&r->scheduler, r->saved[t]);
#else
    swapcontext(&r->scheduler, &r->contexts[t]);
#endif
}

[[noreturn]] void thread_entry()
{
    block_run *r = cooperative;
    r->body->run();
    r->done[r->current] = 1;
    yield_to_scheduler(r);
    abort(); /* a finished thread is never resumed */
}

/* thread t's context, to start at thread_entry on its own stack */
void prepare_thread(block_run &r, unsigned t)
{
    if (!r.stacks[t])
        r.stacks[t].reset(new char[STACK_BYTES]);
#if EMU_FAST_SWITCH
    /* emu_switch pops six registers and returns into thread_entry, which then finds the stack as a call leaves it
     * (its pointer 8 past a multiple of 16) */
    uintptr_t top = ((uintptr_t)r.stacks[t].get() + STACK_BYTES) & ~(uintptr_t)15;
    void **sp = (void **)top;
    *--sp = nullptr;               /* thread_entry's return address: it never returns */
    *--sp = (void *)&thread_entry; /* emu_switch's */
    for (int k = 0; k < 6; k++)
        *--sp = nullptr; /* rbp rbx r12-r15 */
    r.saved[t] = sp;
#else
    getcontext(&r.contexts[t]);
    r.contexts[t].uc_stack.ss_sp = r.stacks[t].get();
    r.contexts[t].uc_stack.ss_size = STACK_BYTES;
    r.contexts[t].uc_link = &r.scheduler;
    makecontext(&r.contexts[t], (void (*)())thread_entry, 0);
#endif
}

/* SPRAYCOAT_CUDA_EMU_ORDER=reverse runs the blocks of a launch, the threads of a block and the coroutines between
 * barriers last to first.  A kernel whose threads race (one reads what another writes in the same launch, or
 * between the same barriers) then computes otherwise, which comparing the two orders shows (tests/
 * test_gpu_emulated.sh); a device runs them in no set order.  Any other value, or none: first to last. */
bool reversed()
{
    static int order = -1;
    if (order < 0) {
        const char *given = getenv("SPRAYCOAT_CUDA_EMU_ORDER");
        order = given && strcmp(given, "reverse") == 0;
    }
    return order == 1;
}

/* the i-th of count in the order of the run */
unsigned long long in_order(unsigned long long i, unsigned long long count)
{
    return reversed() ? count - 1 - i : i;
}

uint3 thread_index(unsigned t, dim3 block)
{
    return uint3{t % block.x, t / block.x % block.y, t / (block.x * block.y)};
}

/* the block's threads to their ends; whether any called __syncthreads */
int run_cooperative(block_run &r, dim3 block)
{
    unsigned count = block.x * block.y * block.z;
    r.stacks.resize(count);
    r.done.assign(count, 0);
#if EMU_FAST_SWITCH
    r.saved.resize(count);
#else
    r.contexts.resize(count);
#endif
    r.barriers = 0;
    for (unsigned t = 0; t < count; t++)
        prepare_thread(r, t);
    cooperative = &r;
    for (unsigned left = count; left > 0;) {
        left = 0;
        for (unsigned i = 0; i < count; i++) {
            unsigned t = (unsigned)in_order(i, count);
            if (r.done[t])
                continue;
            r.current = t;
            threadIdx = thread_index(t, block);
            resume_thread(&r, t);
            left += !r.done[t];
        }
    }
    cooperative = nullptr;
    return r.barriers > 0;
}

std::map<const void *, int> uses_barrier; /* per kernel, found at its first launch */
} // namespace

void __syncthreads(void)
{
    if (!cooperative) {
        fprintf(stderr, "cuda_emu: __syncthreads in a kernel that did not call it at its first launch; the "
                        "emulation runs such a kernel's threads one after the other\n");
        abort();
    }
    block_run *r = cooperative;
    r->barriers++;
    yield_to_scheduler(r);
}

void emu::run_grid(const void *kernel, dim3 grid, dim3 block, thread_body &body)
{
    unsigned long long threads = (unsigned long long)block.x * block.y * block.z;
    if (threads == 0 || threads > 1024 || block.z > 64 || grid.y > 65535 || grid.z > 65535) {
        record(cudaErrorInvalidConfiguration);
        return;
    }
    gridDim = grid, blockDim = block;
    auto known = uses_barrier.find(kernel);
    unsigned long long blocks = (unsigned long long)grid.x * grid.y * grid.z;
    for (unsigned long long i = 0; i < blocks; i++) {
        unsigned long long b = in_order(i, blocks);
        blockIdx = uint3{(unsigned)(b % grid.x), (unsigned)(b / grid.x % grid.y), (unsigned)(b / grid.x / grid.y)};
        if (known == uses_barrier.end() || known->second) {
            static block_run r;
            r.body = &body;
            int barrier = run_cooperative(r, block);
            if (known == uses_barrier.end())
                known = uses_barrier.emplace(kernel, barrier).first;
            continue;
        }
        for (unsigned t = 0; t < threads; t++) {
            threadIdx = thread_index((unsigned)in_order(t, threads), block);
            body.run();
        }
    }
}
