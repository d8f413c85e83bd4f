#include "core/isa.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* SPRAYCOAT_ISA_VARIANTS comes from the Makefile when it compiles the kernels per level (x86-64 with gcc >= 12, whose
 * __builtin_cpu_supports knows the levels by the names -march gives them). */

static int level;
static char name[160];
static pthread_once_t once = PTHREAD_ONCE_INIT;

#if defined(SPRAYCOAT_ISA_VARIANTS)
/* The highest level this CPU (and its operating system, which must save the AVX and AVX-512 registers) runs. */
static int cpu_level(void)
{
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4"))
        return 4;
    if (__builtin_cpu_supports("x86-64-v3"))
        return 3;
    return 2;
}

/* SPRAYCOAT_ISA as a level: "v2".."v4" or "x86-64-v2".."x86-64-v4"; 0 for anything else. */
static int parse_level(const char *text)
{
    if (strncmp(text, "x86-64-", 7) == 0)
        text += 7;
    if (text[0] == 'v' && text[1] >= '2' && text[1] <= '4' && text[2] == '\0')
        return text[1] - '0';
    return 0;
}

static void choose(void)
{
    int best = cpu_level();
    const char *forced = getenv("SPRAYCOAT_ISA");
    if (forced == NULL || forced[0] == '\0') {
        level = best;
        snprintf(name, sizeof name, "x86-64-v%d (the best of v2 v3 v4 this CPU runs)", level);
        return;
    }
    int wanted = parse_level(forced);
    if (wanted == 0 || wanted > best) {
        fprintf(stderr,
                "spraycoat: environment variable SPRAYCOAT_ISA=\"%.40s\": %s; allowed on this CPU: v2 .. v%d "
                "(or unset: v%d, the best it runs)\n",
                forced, wanted == 0 ? "not an instruction-set level" : "this CPU cannot run that level", best, best);
        exit(2);
    }
    level = wanted;
    snprintf(name, sizeof name, "x86-64-v%d (SPRAYCOAT_ISA=%.40s; this CPU runs up to v%d)", level, forced, best);
}
#else
static void choose(void)
{
    const char *forced = getenv("SPRAYCOAT_ISA");
    if (forced != NULL && forced[0] != '\0') {
        fprintf(stderr,
                "spraycoat: environment variable SPRAYCOAT_ISA=\"%.40s\": this build has one instruction set (no "
                "x86-64 levels to choose from); unset it\n",
                forced);
        exit(2);
    }
    level = 0;
    snprintf(name, sizeof name, "one build (the target below; no per-level kernels)");
}
#endif

int isa_level(void)
{
    pthread_once(&once, choose);
    return level;
}

const char *isa_name(void)
{
    pthread_once(&once, choose);
    return name;
}
