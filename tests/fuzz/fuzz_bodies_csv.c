/* libFuzzer harness of the bodies CSV reader (mpm/params.c through core/csv.c): any bytes as the file of
 * `[impact] bodies` of a fixed case with two materials, read by mpm_config_load, then checked for overlaps. */
#include "tests/fuzz/fuzz_common.h"

static const char fixed_case_text[] = "[impact]\ngrid = 2e-6\nspacing = 1e-6\nsubstrate_diameter = 20e-6\n"
                                      "substrate_height = 6e-6\nbodies = bodies.csv\n\n[material.aluminium]\n\n"
                                      "[material.copper]\ndensity = 8960\n";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static struct case_file *c;
    if (!c)
        c = fuzz_fixed_case(fixed_case_text);
    fuzz_write("bodies.csv", data, size);
    struct mpm_config cfg;
    if (mpm_config_load(c, &cfg) == SC_OK) {
        int i, j;
        (void)mpm_find_sphere_overlap(&cfg, &i, &j);
        mpm_config_free(&cfg);
    }
    sc_error_clear();
    return 0;
}
