/* The run-time choice of the kernels' instruction set (core/isa.h; docs/performance.md, "One build for every
 * x86-64").  The Makefile compiles each kernel file once per level N in 2, 3, 4 with -march=x86-64-vN, renames the
 * external functions of the level-N objects from NAME to NAME_vN (objcopy --redefine-syms, calls between the
 * kernel files included, so a level's kernels call each other directly), and lists the renamed functions in the
 * generated isa_kernels.h.  Here each NAME is defined as a jump through a slot of a table, which holds the level-2
 * functions until, before main, the constructor below fills it with the level core/isa.c chose.  A jump rather
 * than a C wrapper: it passes every argument and return value through untouched, so this file needs no
 * prototypes and follows the kernels' API as the other files change it.  Nothing here without the variants. */
#include "core/isa.h"

#if defined(SPRAYCOAT_ISA_KERNELS)
#include "isa_kernels.h" /* ISA_KERNELS(X): X(index, name) for each kernel function; ISA_KERNEL_COUNT */

/* NAME: jump to the address in slot INDEX (8 bytes a slot); the arguments are still in their registers. */
#define TRAMPOLINE(index, fn)                                                                                          \
    __asm__(".text\n\t.globl " #fn "\n\t.type " #fn ", @function\n\t.p2align 4\n" #fn ":\n\tjmp *isa_dispatch_slots+"  \
            "8*" #index "(%rip)\n\t.size " #fn ", .-" #fn "\n");
ISA_KERNELS(TRAMPOLINE)

/* The three compilations of each function (declared as arrays: only their addresses are taken). */
#define DECLARE(index, fn) extern char fn##_v2[], fn##_v3[], fn##_v4[];
ISA_KERNELS(DECLARE)
#define VARIANTS(index, fn) [index] = {fn##_v2, fn##_v3, fn##_v4},
static void *const variants[ISA_KERNEL_COUNT][3] = {ISA_KERNELS(VARIANTS)};

/* The slot of each kernel function: its address at the chosen level, level 2 until the constructor runs (hidden:
 * the jumps address it directly). */
#define LEVEL_2(index, fn) [index] = fn##_v2,
__attribute__((visibility("hidden"))) void *isa_dispatch_slots[ISA_KERNEL_COUNT] = {ISA_KERNELS(LEVEL_2)};

/* Before main (and before any other constructor of ours): a SPRAYCOAT_ISA the CPU cannot run ends the process
 * here, with exit status 2. */
__attribute__((constructor(101))) static void choose_level(void)
{
    int level = isa_level();
    for (int i = 0; i < ISA_KERNEL_COUNT; i++)
        isa_dispatch_slots[i] = variants[i][level - 2];
}
#endif
