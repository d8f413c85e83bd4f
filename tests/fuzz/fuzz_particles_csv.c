/* libFuzzer harness of the particles CSV reader (dem/params.c through core/csv.c): any bytes as the file of
 * `[spray] particles` of a fixed case, read by dem_config_load. */
#include "tests/fuzz/fuzz_common.h"

static const char fixed_case_text[] =
    "[spray]\ninjection = file\nparticles = particles.csv\n\n[target]\nstandoff = 0.05\n";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static struct case_file *c;
    if (!c)
        c = fuzz_fixed_case(fixed_case_text);
    fuzz_write("particles.csv", data, size);
    struct dem_config cfg;
    if (dem_config_load(c, &cfg) == SC_OK)
        dem_config_free(&cfg);
    sc_error_clear();
    return 0;
}
