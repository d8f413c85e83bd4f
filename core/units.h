/* Units in case files: a value written with a unit ("30 mm", "425 degC") is converted to the key's SI unit with
 * UDUNITS-2 (Unidata's units library and its XML database of units), which also refuses a unit of another
 * dimension ("30 s" for a length).  The database is read once, on the first value that carries a unit, from
 * $UDUNITS2_XML_PATH or the library's default (Debian: /usr/share/xml/udunits/udunits2.xml). */
#ifndef SPRAYCOAT_CORE_UNITS_H
#define SPRAYCOAT_CORE_UNITS_H

#include <stddef.h>

enum units_status {
    UNITS_OK,
    UNITS_UNKNOWN,     /* UDUNITS-2 does not know the given unit */
    UNITS_MISMATCH,    /* the given unit is not convertible to the key's (another dimension) */
    UNITS_KEY_NO_UNIT, /* the key's own unit is beyond UDUNITS-2 (fractional powers, "unit of field") */
    UNITS_NO_DATABASE, /* the XML database cannot be read */
    UNITS_FACTOR,      /* the given unit holds a numeric factor ("m/s 2", "mm (2)"): refused, not multiplied */
};

/* `value` in the unit `given` expressed in the key's unit `key_unit` (a registry unit string; "" and "-" are
 * dimensionless, i.e. "1") into *si.  On failure *si is untouched and `why` says what is wrong, naming both
 * units. */
enum units_status units_to_si(double value, const char *given, const char *key_unit, double *si, char *why,
                              size_t size);

/* 1 when UDUNITS-2 parses the registry unit string (so that values of the key may carry a unit), else 0.
 * Reads the database on the first call; 0 when it cannot be read. */
int units_key_unit_known(const char *key_unit);

/* The XML database UDUNITS-2 reads (for messages and `spraycoat --version`). */
const char *units_database_path(void);

#endif
