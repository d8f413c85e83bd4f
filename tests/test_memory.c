/* core/memory.c: after memory_heap_init, blocks of the heap lie in memory advised as transparent huge pages. */
#include "core/memory.h"
#include "tests/check.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#define FOREIGN_MALLOC 1 /* the sanitizer's allocator, not glibc's heap: memory_heap_init leaves it alone */
#else
#define FOREIGN_MALLOC 0
#endif

/* The VmFlags line of the mapping of /proc/self/smaps that holds address `at` (empty if none). */
static void mapping_flags(uintptr_t at, char *flags, size_t size)
{
    flags[0] = '\0';
    FILE *smaps = fopen("/proc/self/smaps", "r");
    if (!smaps)
        return;
    char line[512];
    int inside = 0;
    while (fgets(line, sizeof line, smaps)) {
        unsigned long first, end;
        if (sscanf(line, "%lx-%lx ", &first, &end) == 2) { /* a mapping's first line; the others start with a name */
            inside = at >= first && at < end;
            continue;
        }
        if (inside && strncmp(line, "VmFlags:", 8) == 0) {
            snprintf(flags, size, "%s", line + 8);
            break;
        }
    }
    fclose(smaps);
}

static int kernel_has_huge_pages(void)
{
    return access("/sys/kernel/mm/transparent_hugepage/enabled", R_OK) == 0;
}

/* Arrays of a few MB, as the spray's particles and grid: in the advised part of the heap, usable, and freed. */
static void test_heap_blocks_advised(void)
{
    memory_heap_init();
    size_t bytes = (size_t)8 << 20;
    char *block = malloc(bytes);
    CHECK(block != NULL, "malloc of 8 MB after memory_heap_init failed");
    if (!block)
        return;
    memset(block, 0x5a, bytes);
    CHECK(block[0] == 0x5a && block[bytes - 1] == 0x5a, "the block does not hold what was written");
    char flags[512];
    mapping_flags((uintptr_t)block + bytes / 2, flags, sizeof flags);
    if (FOREIGN_MALLOC || !kernel_has_huge_pages()) {
        printf("  (sanitizer's malloc or no transparent huge pages in this kernel: the advice is not checked)\n");
    } else {
        CHECK(strstr(flags, " hg") != NULL, "the block's mapping is not advised as huge pages (VmFlags:%s)", flags);
        CHECK((char *)sbrk(0) > block, "an 8 MB block was mapped on its own, not taken from the heap");
    }
    free(block);
}

int main(void)
{
    RUN(test_heap_blocks_advised);
    return check_finish();
}
