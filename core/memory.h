/* The process's heap in transparent huge pages.
 *
 * Every first touch of a 4 kB page costs a page fault, and on the virtual machines we measured a fault costs
 * 10-11 us (a 2 MB huge page faulted at once, under 1 us per 4 kB of it): the start of a 20,000-particle spray
 * (reading the particles, the first grid) took 5,500 faults, half of its 0.11 s.  memory_heap_init gives malloc
 * a heap reserve of 64 MB, asks the kernel to back it with 2 MB pages (madvise(MADV_HUGEPAGE): a hint, honoured
 * where transparent huge pages are `madvise` or `always`, as on Debian's kernels) and keeps arrays below 32 MB
 * and freed memory in that heap.  No result depends on it.  Measured (BENCHMARKS.md's history in git): the
 * spray's start 0.11 -> 0.06 s, the 1e6-point impact's faults 34,000 -> 12,800, peak memory
 * +2 to +22 % (a whole huge page is backed where a few bytes of it are touched). */
#ifndef SPRAYCOAT_CORE_MEMORY_H
#define SPRAYCOAT_CORE_MEMORY_H

/* Once, first thing in main, before anything large is allocated.  Does nothing where malloc is not glibc's
 * heap (sanitizers, valgrind). */
void memory_heap_init(void);

#endif
