/* Shared by the libFuzzer harnesses of tests/fuzz/ (see tests/fuzz/run.sh): a private folder for the files the
 * readers open, and writing one fuzz input to a file there.  Each harness defines LLVMFuzzerTestOneInput. */
#ifndef SPRAYCOAT_TESTS_FUZZ_COMMON_H
#define SPRAYCOAT_TESTS_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/config.h"
#include "core/error.h"
#include "core/log.h"
#include "core/run_keys.h"
#include "dem/dem.h"
#include "mpm/mpm.h"

/* The keys of the stages the harnesses reach (the application's registry also holds couple, vcrit and render). */
static const struct cfg_key *const fuzz_registry[] = {run_case_keys, dem_case_keys, mpm_case_keys, NULL};

static char fuzz_folder[64];

/* FOLDER/name, the folder made on first use. */
static const char *fuzz_path(const char *name)
{
    static char path[128];
    if (!fuzz_folder[0]) {
        snprintf(fuzz_folder, sizeof fuzz_folder, "/tmp/spraycoat_fuzz_XXXXXX");
        if (!mkdtemp(fuzz_folder)) {
            perror("mkdtemp");
            abort();
        }
        log_set_level(LOG_QUIET);
    }
    snprintf(path, sizeof path, "%s/%s", fuzz_folder, name);
    return path;
}

static void fuzz_write(const char *name, const void *data, size_t size)
{
    const char *path = fuzz_path(name);
    FILE *file = fopen(path, "wb");
    if (!file || fwrite(data, 1, size, file) != size || fclose(file) != 0) {
        perror(path);
        abort();
    }
}

/* The case `text` (written as case.ini) loaded, or abort: the harness's own case must be valid. */
static struct case_file *fuzz_fixed_case(const char *text)
{
    fuzz_write("case.ini", text, strlen(text));
    struct case_file *c = NULL;
    if (case_load(fuzz_path("case.ini"), fuzz_registry, &c) != SC_OK) {
        fprintf(stderr, "fuzz harness: its case does not load: %s\n", sc_error_message());
        abort();
    }
    return c;
}

#endif
