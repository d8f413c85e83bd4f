/* Units in case files (core/units.c through core/config.c): a value written with a unit is converted to the key's
 * SI unit by UDUNITS-2 (mm, um, µm, degC -> K, MPa, ns, m/s, mm/s, km/h, %), a bare number stays as it is, a unit of
 * another dimension, an unknown unit and a unit on an integer count are refused with the file, line, key, the unit
 * given and the unit expected; `check`'s listing shows both values; and every real key of the program's registry has
 * a unit UDUNITS-2 parses (but the few with fractional powers, which take bare SI numbers). */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/app.h"
#include "core/config.h"
#include "core/error.h"
#include "core/units.h"
#include "tests/check.h"

static const struct cfg_key unit_keys[] = {
    {"u", "length", CFG_REAL, "m", "1", 0, 100, CFG_MIN_EXCLUSIVE, NULL, "a length"},
    {"u", "diameter", CFG_REAL, "m", "1e-5", 0, 1, CFG_MIN_EXCLUSIVE, NULL, "a diameter"},
    {"u", "speed", CFG_REAL, "m/s", "0", 0, 1e4, 0, NULL, "a speed"},
    {"u", "feed", CFG_REAL, "m/s", "0", 0, 1e4, 0, NULL, "a slow speed"},
    {"u", "pressure", CFG_REAL, "Pa", "0", 0, 1e12, 0, NULL, "a pressure"},
    {"u", "temperature", CFG_REAL, "K", "300", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL, "an absolute temperature"},
    {"u", "time", CFG_REAL, "s", "1", 0, 1e9, 0, NULL, "a time"},
    {"u", "fraction", CFG_REAL, "-", "0.5", 0, 1, 0, NULL, "a fraction"},
    {"u", "density", CFG_REAL, "kg/m3", "1000", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL, "a density"},
    {"u", "scale", CFG_REAL, "m^(4/3)/s", "30", 0, 1e6, 0, NULL, "beyond UDUNITS-2"},
    {"u", "count", CFG_INT, "steps", "1", 0, 1000, 0, NULL, "a count"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};
static const struct cfg_key *const registry[] = {unit_keys, NULL};

static char folder[256];

static struct case_file *load_line(const char *line, int *status)
{
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/units.ini", folder);
    FILE *file = fopen(path, "w");
    if (!file) {
        printf("  cannot write %s: %s\n", path, strerror(errno));
        exit(1);
    }
    fprintf(file, "[u]\n%s\n", line);
    fclose(file);
    struct case_file *c = NULL;
    sc_error_clear();
    *status = case_load(path, registry, &c);
    return c;
}

/* `line` loads and its key reads `expected` within rtol (0: exactly). */
static void expect_value(const char *line, const char *key, double expected, double rtol)
{
    int status;
    struct case_file *c = load_line(line, &status);
    CHECK(status == SC_OK, "\"%s\": status %d: %s", line, status, sc_error_message());
    if (!c)
        return;
    double got = case_real(c, "u", key);
    if (rtol == 0)
        CHECK(got == expected, "\"%s\": got %.17g, expected exactly %.17g", line, got, expected);
    else
        CHECK_CLOSE(got, expected, rtol, 0, line);
    case_free(c);
}

/* `line` is refused (SC_EINPUT) with a message holding every fragment. */
static void expect_refused(const char *line, const char *const *fragments)
{
    int status;
    struct case_file *c = load_line(line, &status);
    CHECK(status == SC_EINPUT && !c, "\"%s\": status %d, expected SC_EINPUT", line, status);
    case_free(c);
    for (; *fragments; fragments++)
        CHECK(strstr(sc_error_message(), *fragments), "\"%s\": message lacks \"%s\": %s", line, *fragments,
              sc_error_message());
}

static void test_conversions(void)
{
    /* decimal prefixes divide by a whole number: the same double as the decimal SI spelling */
    expect_value("length = 30 mm", "length", 0.03, 0);
    expect_value("length = 30mm", "length", 0.03, 0);
    expect_value("diameter = 20 um", "diameter", 20e-6, 0);
    expect_value("diameter = 20 µm", "diameter", 20e-6, 0);
    expect_value("diameter = 0.5 inch", "diameter", 0.0127, 1e-15);
    expect_value("temperature = 425 degC", "temperature", 698.15, 1e-15);
    expect_value("temperature = 32 degF", "temperature", 273.15, 1e-15);
    expect_value("pressure = 1.5 MPa", "pressure", 1.5e6, 0);
    expect_value("pressure = 30 bar", "pressure", 3e6, 0);
    expect_value("time = 50 ns", "time", 50e-9, 0);
    expect_value("time = 2 min", "time", 120, 0);
    expect_value("speed = 800 m/s", "speed", 800, 0);
    expect_value("feed = 15 mm/s", "feed", 0.015, 0);
    expect_value("speed = 72 km/h", "speed", 20, 1e-15);
    expect_value("fraction = 25 %", "fraction", 0.25, 0);
    expect_value("density = 2.7 g/cm3", "density", 2700, 1e-15);
}

static void test_bare_number_unchanged(void)
{
    expect_value("length = 0.03", "length", 0.03, 0);
    expect_value("diameter = 2e-5", "diameter", 2e-5, 0);
    expect_value("temperature = 698.15", "temperature", 698.15, 0);
    expect_value("scale = 30", "scale", 30, 0);
    /* the same case whichever spelling: the hash is over the SI values */
    int status;
    struct case_file *a = load_line("length = 30 mm", &status);
    uint64_t with_unit = a ? case_hash(a) : 0;
    case_free(a);
    struct case_file *b = load_line("length = 0.03", &status);
    uint64_t bare = b ? case_hash(b) : 1;
    case_free(b);
    CHECK(with_unit == bare, "hash of \"30 mm\" %016llx differs from that of \"0.03\" %016llx",
          (unsigned long long)with_unit, (unsigned long long)bare);
}

static void test_refused(void)
{
    expect_refused("length = 30 s", (const char *const[]){"units.ini:2:", "[u] length = 30 s", "\"s\"", "\"m\"",
                                                          "not convertible", NULL});
    expect_refused("temperature = 300 Pa", (const char *const[]){"units.ini:2:", "\"Pa\"", "\"K\"", NULL});
    expect_refused("speed = 3 m", (const char *const[]){"\"m\"", "\"m/s\"", NULL});
    expect_refused("length = 30 furlongz",
                   (const char *const[]){"units.ini:2:", "[u] length", "unknown unit", "\"furlongz\"", "\"m\"", NULL});
    /* converted, then checked against the range in SI */
    expect_refused("length = 0.3 km", (const char *const[]){"out of range (300 m)", "allowed: > 0 and <= 100 m", NULL});
    expect_refused("temperature = -300 degC", (const char *const[]){"out of range", NULL});
    expect_refused("count = 5 steps", (const char *const[]){"not an integer", "without a unit", NULL});
    expect_refused("scale = 30 m/s", (const char *const[]){"bare number", "m^(4/3)/s", NULL});
    /* a comment after a number is not a unit */
    expect_refused("length = 3 # metres",
                   (const char *const[]){"not a number", "inline comments start with ';'", NULL});
}

/* A number in the unit is refused, not taken as a factor: UDUNITS-2 reads "800 m/s 2" as 1600 m/s, "30 mm (2)",
 * "30 mm.2" and "30 mm·2" as 0.06 m, "30 mm 1e3" as 30 m.  Powers attached to a unit, and the 1 of 1/s, stay. */
static void test_numeric_factor_refused(void)
{
    expect_refused("speed = 800 m/s 2", (const char *const[]){"units.ini:2:", "[u] speed = 800 m/s 2", "\"m/s 2\"",
                                                              "numeric factor", "allowed: ", "0 .. 10000 m/s", NULL});
    const char *const factor[] = {"units.ini:2:", "[u] length", "numeric factor", "allowed: ", NULL};
    expect_refused("length = 30 mm 2", factor);
    expect_refused("length = 30 mm (2)", factor);
    expect_refused("length = 30 mm.2", factor);
    expect_refused("length = 30 mm·2", factor);
    expect_refused("length = 30 mm 1e3", factor);
    expect_refused("length = 30 mm .5", factor);
    expect_refused("length = 30 2 mm", (const char *const[]){"not a number", NULL});
    expect_refused("speed = 800 m 2/s", (const char *const[]){"[u] speed", "numeric factor", NULL});
    /* the forms of docs/keys.md: powers on their unit, signed, after ^ or **, and 1/s */
    expect_value("density = 2.7 g/cm3", "density", 2700, 1e-15);
    expect_value("density = 2700 kg/m3", "density", 2700, 0);
    expect_value("density = 2700 kg m-3", "density", 2700, 0);
    expect_value("density = 2700 kg/m^3", "density", 2700, 0);
    expect_value("density = 2700 kg/m**3", "density", 2700, 0);
    expect_value("density = 2700 kg.m^-3", "density", 2700, 0);
    expect_value("speed = 800 m.s-1", "speed", 800, 0);
    expect_value("speed = 800 m s^-1", "speed", 800, 0);
    expect_value("speed = 800 m·s-1", "speed", 800, 0);
    expect_value("speed = 800 m*s**-1", "speed", 800, 0);
    expect_value("speed = 0.8 mm/us", "speed", 800, 1e-15);
    expect_value("diameter = 20 µm", "diameter", 20e-6, 0);
    expect_value("speed = 800 m (1/s)", "speed", 800, 0);
    expect_value("temperature = 25 degC", "temperature", 298.15, 1e-15);
}

/* `check` lists a value given with a unit as given and in SI. */
static void test_print_both_values(void)
{
    int status;
    struct case_file *c = load_line("length = 30 mm", &status);
    CHECK(c != NULL, "load: %s", sc_error_message());
    if (!c)
        return;
    char text[8192] = "";
    FILE *out = fmemopen(text, sizeof text - 1, "w");
    case_print(c, out);
    fclose(out);
    CHECK(strstr(text, "30 mm = 0.03 m"), "the listing lacks \"30 mm = 0.03 m\":\n%s", text);
    CHECK(strstr(text, "= 1e-5 m "), "a default without a unit is shown as before:\n%s", text);
    case_free(c);
}

/* Every real key of the program has a unit UDUNITS-2 parses; the exceptions take bare SI numbers. */
static void test_registry_units_parse(void)
{
    static const char *const beyond_udunits[] = {"m^(4/3)/s", "m^(5/3)/s", "m^(-1/3)", "unit of field", NULL};
    CHECK(units_key_unit_known("m"), "UDUNITS-2 database not read (%s)", units_database_path());
    int checked = 0;
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *spec = spraycoat_registry[t]; spec->key; spec++) {
            if (spec->type != CFG_REAL)
                continue;
            int excepted = 0;
            for (int i = 0; beyond_udunits[i]; i++)
                excepted |= strcmp(spec->unit, beyond_udunits[i]) == 0;
            CHECK(excepted || units_key_unit_known(spec->unit), "[%s] %s: UDUNITS-2 does not parse its unit \"%s\"",
                  spec->section, spec->key, spec->unit);
            checked++;
        }
    CHECK(checked > 50, "only %d real keys found", checked);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(folder, sizeof folder, "%s/test_units.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(folder)) {
        printf("FAIL test_units: mkdtemp: %s\n", strerror(errno));
        return 1;
    }
    RUN(test_conversions);
    RUN(test_bare_number_unchanged);
    RUN(test_refused);
    RUN(test_numeric_factor_refused);
    RUN(test_print_both_values);
    RUN(test_registry_units_parse);
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/units.ini", folder);
    unlink(path);
    rmdir(folder);
    return check_finish();
}
