/* The instruction set the hot kernels run with.  On x86-64 the Makefile compiles the kernel files (ISA_KERNEL_SRC:
 * the impact's transfers and stress update, the spray's integration and contacts) once per level x86-64-v2, -v3
 * (AVX2) and -v4 (AVX-512), and app/isa_dispatch.c sends every call of a kernel function to the level chosen here,
 * before main: the best level the CPU runs, or the one the environment variable SPRAYCOAT_ISA (v2, v3 or v4)
 * forces.  Every level gives the same bits (-ffp-contract=off; docs/performance.md). */
#ifndef SPRAYCOAT_CORE_ISA_H
#define SPRAYCOAT_CORE_ISA_H

/* The level the kernels run with: 2, 3 or 4 (x86-64-vN), or 0 in a build with one instruction set (not x86-64,
 * or built without the variants).  A SPRAYCOAT_ISA the build or the CPU cannot honour ends the process with a
 * message and exit status 2 (bad input) on the first call.  Thread-safe; the same for the life of the process. */
int isa_level(void);

/* The level in words, for --version and /code: "x86-64-v3 (the best of v2 v3 v4 this CPU runs)",
 * "x86-64-v2 (SPRAYCOAT_ISA=v2; this CPU runs up to v3)" or "one build (...)". */
const char *isa_name(void);

#endif
