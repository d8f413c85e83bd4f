/* libFuzzer harness of the case-file reader (core/config.c): any bytes as case.ini.  A case that loads is also
 * printed, hashed, written back (and read again) and resolved by the spray and impact stages' configuration
 * (dem/params.c, mpm/params.c), which read the CSV files it may name.  A crash, a sanitizer report or an abort (the
 * reader's "internal error") is a bug; an SC_EINPUT or SC_EIO status is the expected answer to bad input. */
#include "tests/fuzz/fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_write("case.ini", data, size);
    struct case_file *c = NULL;
    if (case_load(fuzz_path("case.ini"), fuzz_registry, &c) == SC_OK) {
        FILE *sink = fopen("/dev/null", "w");
        if (sink) {
            case_print(c, sink);
            fclose(sink);
        }
        /* the resolved text (what outputs store) must read back as the same case (case_write_resolved writes the
         * same lines, but fsyncs: too slow here) */
        char *resolved = case_resolved_text(c);
        fuzz_write("resolved.ini", resolved, strlen(resolved));
        free(resolved);
        struct case_file *again = NULL;
        if (case_load(fuzz_path("resolved.ini"), fuzz_registry, &again) == SC_OK && case_hash(again) != case_hash(c))
            abort();
        case_free(again);
        struct dem_config dem;
        if (dem_config_load(c, &dem) == SC_OK)
            dem_config_free(&dem);
        struct mpm_config mpm;
        if (mpm_config_load(c, &mpm) == SC_OK) {
            int i, j;
            (void)mpm_find_sphere_overlap(&mpm, &i, &j);
            mpm_config_free(&mpm);
        }
    }
    case_free(c);
    sc_error_clear();
    return 0;
}
