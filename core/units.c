/* Units in case files, converted with UDUNITS-2 (see core/units.h).
 *
 * UDUNITS-2 knows the SI prefixes and derived units, non-SI units in use (degC, degF, bar, psi, inch, min, h, %)
 * and parses products, quotients and integer powers ("kg/m3", "J/(kg K)", "m2/s", "µm" in UTF-8), so that no
 * table of units lives here; a number in the unit that is no power ("m/s 2"), which it would take as a factor, is
 * refused.  Its parser has no fractional powers: a key whose unit is "m^(4/3)/s" takes bare SI
 * numbers only (UNITS_KEY_NO_UNIT). */
#include "core/units.h"

#include <ctype.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <udunits2.h>

static ut_system *unit_system;
static char database_path[1024];
static pthread_once_t load_once = PTHREAD_ONCE_INIT;

/* Read the database once; it stays for the life of the process (reachable, so not a leak to LSan). */
static void load_database(void)
{
    ut_set_error_message_handler(ut_ignore); /* UDUNITS-2 prints to stderr by default; we report ourselves */
    ut_status status;
    const char *path = ut_get_path_xml(NULL, &status);
    snprintf(database_path, sizeof database_path, "%s", path ? path : "(none)");
    unit_system = ut_read_xml(NULL);
}

static ut_system *units_system(void)
{
    pthread_once(&load_once, load_database);
    return unit_system;
}

const char *units_database_path(void)
{
    units_system();
    return database_path;
}

/* The registry writes dimensionless as "-" or leaves the unit empty; UDUNITS-2 spells it "1". */
static const char *key_unit_text(const char *key_unit)
{
    return !key_unit || !*key_unit || strcmp(key_unit, "-") == 0 ? "1" : key_unit;
}

static ut_unit *parse_unit(ut_system *system, const char *text)
{
    return ut_parse(system, text, UT_UTF8);
}

int units_key_unit_known(const char *key_unit)
{
    ut_system *system = units_system();
    if (!system)
        return 0;
    ut_unit *unit = parse_unit(system, key_unit_text(key_unit));
    ut_free(unit);
    return unit != NULL;
}

/* value * factor where factor = 1/n for a whole n (mm, um, ns, %, mm/s): divide by n, which rounds correctly
 * (30 mm is the double nearest 0.03, as "0.03" is; the factor is taken as whole when within 1e-12 of it), where
 * multiplying by 0.001, itself rounded, may miss it by an ulp and so change the case hash between "30 mm" and "0.03".
 * Affine conversions (degC) go through UDUNITS-2. */
static double convert(const cv_converter *forward, const cv_converter *back, double value)
{
    double offset = cv_convert_double(forward, 0.0);
    double inverse = cv_convert_double(back, 1.0); /* 1 s in ns: 999999999.99999994, UDUNITS-2 inverts 1e-9 */
    double whole = nearbyint(inverse);
    if (offset == 0.0 && whole > 1.0 && whole < 9007199254740992.0 && fabs(inverse - whole) <= 1e-12 * whole)
        return value / whole;
    return cv_convert_double(forward, value);
}

/* The power of the radian in a unit: 1 for rad, degree, arc_minute, mrad and rad/s, 2 for sr, 0 for 1, % and m/s.
 * UDUNITS-2 counts the radian as dimensionless (ut_are_convertible("degree", "%") is true), but keeps it in a unit
 * as a basic unit of its own, which a visitor finds. */
struct radian_power {
    const ut_unit *radian;
    int power;
};

static ut_status visit_basic(const ut_unit *unit, void *arg)
{
    struct radian_power *r = arg;
    r->power = ut_compare(unit, r->radian) == 0;
    return UT_SUCCESS;
}

static ut_status visit_product(const ut_unit *unit, int count, const ut_unit *const *basic, const int *powers,
                               void *arg)
{
    (void)unit;
    struct radian_power *r = arg;
    r->power = 0;
    for (int k = 0; k < count; k++)
        if (ut_compare(basic[k], r->radian) == 0)
            r->power += powers[k];
    return UT_SUCCESS;
}

static ut_status visit_galilean(const ut_unit *unit, double scale, const ut_unit *underlying, double offset, void *arg);

static ut_status visit_timestamp(const ut_unit *unit, const ut_unit *time_unit, double origin, void *arg)
{
    (void)unit, (void)time_unit, (void)origin;
    ((struct radian_power *)arg)->power = 0;
    return UT_SUCCESS;
}

static ut_status visit_logarithmic(const ut_unit *unit, double base, const ut_unit *reference, void *arg)
{
    (void)unit, (void)base, (void)reference;
    ((struct radian_power *)arg)->power = 0;
    return UT_SUCCESS;
}

static ut_visitor radian_visitor = {visit_basic, visit_product, visit_galilean, visit_timestamp, visit_logarithmic};

static ut_status visit_galilean(const ut_unit *unit, double scale, const ut_unit *underlying, double offset, void *arg)
{
    (void)unit, (void)scale, (void)offset;
    return ut_accept_visitor(underlying, &radian_visitor, arg);
}

static int radian_power(const ut_unit *unit)
{
    struct radian_power r = {ut_get_unit_by_symbol(ut_get_system(unit), "rad"), 0};
    if (r.radian)
        ut_accept_visitor(unit, &radian_visitor, &r);
    ut_free((ut_unit *)r.radian);
    return r.power;
}

static enum units_status convert_units(ut_unit *from, ut_unit *to, double value, double *si, const char *given,
                                       const char *expected, char *why, size_t size)
{
    if (!ut_are_convertible(from, to)) {
        snprintf(why, size, "the unit \"%s\" is not convertible to the key's unit \"%s\" (another dimension)", given,
                 expected);
        return UNITS_MISMATCH;
    }
    /* an angle is not a number: "10 %" for an angle, "2 degree" for a fraction, "0.5 sr" for a plane angle */
    int given_power = radian_power(from), key_power = radian_power(to);
    if (given_power != key_power) {
        if (key_power == 1 && given_power == 0)
            snprintf(why, size,
                     "the unit \"%s\" is not an angle; the key's unit \"%s\" is (rad, degree, arc_minute, "
                     "arc_second; not sr, %%)",
                     given, expected);
        else if (key_power == 0 && strcmp(expected, "1") == 0)
            snprintf(why, size,
                     "the unit \"%s\" is an angle; the key is dimensionless (a bare number, %%, ppm; not rad, "
                     "degree, sr)",
                     given);
        else
            snprintf(why, size,
                     "the unit \"%s\" is not convertible to the key's unit \"%s\" (an angle is a dimension of its "
                     "own here: rad, degree; sr is rad^2)",
                     given, expected);
        return UNITS_MISMATCH;
    }
    cv_converter *forward = ut_get_converter(from, to), *back = ut_get_converter(to, from);
    enum units_status status = UNITS_OK;
    if (!forward || !back) {
        snprintf(why, size, "cannot convert \"%s\" to \"%s\"", given, expected);
        status = UNITS_MISMATCH;
    } else {
        *si = convert(forward, back, value);
    }
    cv_free(forward);
    cv_free(back);
    return status;
}

/* A byte of a unit's symbol or name: an ASCII letter, '_' (inch_H2O_39F), or a byte of a UTF-8 character (µm, °C),
 * but for the multiplication dot U+00B7 (0xc2 0xb7), which UDUNITS-2 reads as '.', a product. */
static int symbol_byte(const char *text, size_t i)
{
    unsigned char c = (unsigned char)text[i];
    if (c == 0xc2 && (unsigned char)text[i + 1] == 0xb7)
        return 0;
    if (c == 0xb7 && i > 0 && (unsigned char)text[i - 1] == 0xc2)
        return 0;
    return isalpha(c) || c == '_' || c >= 0x80;
}

/* The first number in `unit` that is not a power of the symbol before it, NULL if none.  UDUNITS-2 reads a number
 * anywhere else as a factor of the product: "m/s 2" is 2 m/s, "mm (2)", "mm.2" and "mm·2" 2 mm, "mm 1e3" 1 m, so
 * that "800 m/s 2" was taken as 1600 m/s.  A power is attached to its symbol or to a closing parenthesis, signed or
 * not, after '^' or '**' or directly: m2, s-1, m^2, m**2; and the 1 of "1/s" (a numerator of 1 at the start
 * or after '(') is no factor. */
static const char *numeric_factor(const char *unit, size_t *length)
{
    for (size_t i = 0; unit[i]; i++) {
        if (!isdigit((unsigned char)unit[i]))
            continue;
        size_t end = i;
        while (isdigit((unsigned char)unit[end]))
            end++;
        size_t before = i;
        if (before > 0 && (unit[before - 1] == '-' || unit[before - 1] == '+'))
            before--;
        if (before > 0 && unit[before - 1] == '^')
            before--;
        else if (before > 1 && unit[before - 1] == '*' && unit[before - 2] == '*')
            before -= 2;
        int power = before > 0 && (symbol_byte(unit, before - 1) || unit[before - 1] == ')');
        size_t after = end;
        while (unit[after] == ' ' || unit[after] == '\t')
            after++;
        size_t lead = i;
        while (lead > 0 && (unit[lead - 1] == ' ' || unit[lead - 1] == '\t'))
            lead--;
        int numerator_one =
            end == i + 1 && unit[i] == '1' && unit[after] == '/' && (lead == 0 || unit[lead - 1] == '(');
        if (!power && !numerator_one) {
            /* the whole number as written: digits, a decimal point, an exponent (1e3, 2.5, .5) */
            size_t start = i > 0 && unit[i - 1] == '.' && (i < 2 || !symbol_byte(unit, i - 2)) ? i - 1 : i;
            char *stop;
            strtod(unit + start, &stop);
            *length = stop > unit + end ? (size_t)(stop - unit - start) : end - start;
            return unit + start;
        }
        i = end - 1;
    }
    return NULL;
}

enum units_status units_to_si(double value, const char *given, const char *key_unit, double *si, char *why, size_t size)
{
    ut_system *system = units_system();
    if (!system) {
        snprintf(why, size,
                 "cannot read the UDUNITS-2 database of units (%s; set UDUNITS2_XML_PATH, or install "
                 "libudunits2-data); write the value in SI without a unit",
                 database_path);
        return UNITS_NO_DATABASE;
    }
    const char *expected = key_unit_text(key_unit);
    ut_unit *to = parse_unit(system, expected);
    if (!to) {
        snprintf(why, size, "this key takes a bare number in %s (no unit: UDUNITS-2 cannot express its unit)",
                 key_unit);
        return UNITS_KEY_NO_UNIT;
    }
    size_t length = 0;
    const char *factor = numeric_factor(given, &length);
    if (factor) {
        snprintf(why, size,
                 "the unit \"%s\" holds a number, %.*s, that UDUNITS-2 would multiply the value by (a unit with a "
                 "numeric factor)",
                 given, (int)length, factor);
        ut_free(to);
        return UNITS_FACTOR;
    }
    ut_unit *from = parse_unit(system, given);
    enum units_status status;
    if (!from) {
        snprintf(why, size,
                 "unknown unit \"%s\" (UDUNITS-2 units, e.g. mm, um, degC, MPa, ns, m/s); the key's unit is \"%s\"",
                 given, expected);
        status = UNITS_UNKNOWN;
    } else {
        status = convert_units(from, to, value, si, given, expected, why, size);
    }
    ut_free(from);
    ut_free(to);
    return status;
}
