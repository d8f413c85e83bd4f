/* The heap in transparent huge pages (core/memory.h). */
#include "core/memory.h"

#include <malloc.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

#define HUGE_PAGE ((uintptr_t)2 << 20)
/* What malloc adds to the heap whenever it grows it: the part advised as huge pages. */
#define HEAP_RESERVE (64 << 20)
/* Blocks up to this size come from the heap; larger ones are mapped on their own (the impact stage places
 * and advises its large arrays itself: mpm_calloc_lines). */
#define HEAP_BLOCK_LIMIT (32 << 20)
/* Freed memory is returned to the system only beyond this much at the heap's top. */
#define HEAP_KEEP (256 << 20)

void memory_heap_init(void)
{
    /* a fixed threshold also turns off glibc's dynamic one, which would send a block freed once to the heap
     * and its equal, allocated before, to a mapping of its own */
    mallopt(M_MMAP_THRESHOLD, HEAP_BLOCK_LIMIT);
    mallopt(M_TRIM_THRESHOLD, HEAP_KEEP);
    mallopt(M_TOP_PAD, HEAP_RESERVE);
    /* a block the heap's top cannot hold makes malloc grow the heap by it and the reserve */
    char *probe = malloc((size_t)1 << 20);
    char *heap_end = sbrk(0);
    /* only glibc's heap (a sanitizer's or valgrind's malloc hands out blocks elsewhere) */
    if (probe && probe < heap_end && heap_end - probe < 2 * (ptrdiff_t)HEAP_RESERVE) {
        uintptr_t first = ((uintptr_t)probe + HUGE_PAGE - 1) & ~(HUGE_PAGE - 1);
        uintptr_t last = (uintptr_t)heap_end & ~(HUGE_PAGE - 1);
        if (last > first)
            madvise((void *)first, last - first, MADV_HUGEPAGE); /* a hint: where refused, pages stay small */
    }
    free(probe);
}
