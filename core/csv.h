/* Input files: opening only regular files, and CSV tables with a header line (the particles CSV of the spray,
 * the bodies CSV of the impact, the v_crit table).
 *
 * A FIFO would block the reader and /dev/zero would never end, so every input is opened without blocking and
 * refused unless it is a regular file.  A CSV table has one header line naming its columns (in any order, each
 * exactly once, no others unless CSV_OTHER_COLUMNS), then one row per line with exactly as many comma-separated fields;
 * blanks around a field, blank lines and lines starting with '#' are ignored, a UTF-8 byte order mark (Excel's "CSV
 * UTF-8") is skipped, lines may end in CRLF and have any length.  Every number is checked against its column's range.
 * Errors read "PATH:LINE:COLUMN: name = value: what is wrong; allowed: ..." (LINE and COLUMN from 1). */
#ifndef SPRAYCOAT_CORE_CSV_H
#define SPRAYCOAT_CORE_CSV_H

#include <stddef.h>
#include <stdio.h>

/* Open `path` for reading if it is a regular file.  Returns 0 and *out, else 0 is not returned: -1 when the file
 * exists but is not a regular file (folder, FIFO, device, socket), else the errno of open().  `why` gets the
 * reason ("tests/x.csv is a FIFO; an input file must be a regular file", "cannot open x.csv: No such file..."). */
int csv_input_fopen(const char *path, FILE **out, char *why, size_t size);

enum csv_kind {
    CSV_NUMBER, /* a finite number in [min, max] */
    CSV_WORD,   /* one of the '|'-separated words: its index is stored as the number */
    CSV_NAME,   /* a name as in [material.NAME] (letters, digits, '_' or '-'): stored as text */
};

struct csv_column {
    const char *name;
    enum csv_kind kind;
    double min, max;   /* CSV_NUMBER: allowed range */
    int min_exclusive; /* CSV_NUMBER: > min rather than >= min */
    const char *unit;  /* CSV_NUMBER: shown with the range */
    const char *words; /* CSV_WORD: "sphere|cylinder|box" */
};

struct csv_table {
    size_t rows;
    int columns;     /* as in the column list given to csv_read, in its order */
    double *numbers; /* rows x columns: CSV_NUMBER values, CSV_WORD indices; NAN for CSV_NAME */
    char **names;    /* rows x columns: CSV_NAME texts (NULL elsewhere); NULL when there is no CSV_NAME column */
    long *lines;     /* the file line of each row, for messages */
};

/* csv_read's flags: CSV_OTHER_COLUMNS lets the header name columns besides the listed ones, ignored (the v_crit
 * table that `spraycoat vcrit` writes has more); without it they are an error (a typo must not pass). */
enum { CSV_OTHER_COLUMNS = 1 };

/* Read the table at `path` (at least one data row).  Returns SC_OK, SC_EINPUT (bad content, not a regular file)
 * or SC_EIO (cannot open or read); on failure `message` holds the reason and *out is empty. */
int csv_read(const char *path, const struct csv_column *columns, int column_count, int flags, struct csv_table *out,
             char *message, size_t size);
void csv_free(struct csv_table *t);

/* 1 when the header line of the CSV at `path` (its first line neither blank nor a '#' comment, as csv_read reads it)
 * names the column `name`, else 0 (also when the file cannot be read: csv_read then says why).  For a column that
 * a table may have or leave out: the temperature of a v_crit table or of an impact bodies file. */
int csv_header_has(const char *path, const char *name);

#endif
