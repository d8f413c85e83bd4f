/* Reading the reference tables of ../shared/verification: '#' lines are comments, the first other line
 * is the header, fields are split at commas. */
#ifndef SPRAYCOAT_TESTS_VERIFICATION_CSV_H
#define SPRAYCOAT_TESTS_VERIFICATION_CSV_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tests/check.h"

#define CSV_MAX_FIELDS 16
#define CSV_LINE_MAX   1024

struct csv_row {
    int count;
    char *field[CSV_MAX_FIELDS];
};

static inline void csv_split(char *line, struct csv_row *row)
{
    row->count = 0;
    line[strcspn(line, "\r\n")] = '\0';
    char *cursor = line;
    while (row->count < CSV_MAX_FIELDS) {
        row->field[row->count++] = cursor;
        char *comma = strchr(cursor, ',');
        if (!comma)
            break;
        *comma = '\0';
        cursor = comma + 1;
    }
}

/* Calls visit() for every data row of the table `name` in the verification folder; returns the number of
 * rows, or -1 if the file cannot be opened. */
static inline int csv_for_each(const char *name, void (*visit)(const struct csv_row *row))
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", check_verification_dir(), name);
    FILE *file = fopen(path, "r");
    if (!file)
        return -1;
    char line[CSV_LINE_MAX];
    int header_seen = 0, rows = 0;
    while (fgets(line, sizeof line, file)) {
        if (line[0] == '#' || line[0] == '\n')
            continue;
        if (!header_seen) {
            header_seen = 1;
            continue;
        }
        struct csv_row row;
        csv_split(line, &row);
        visit(&row);
        rows++;
    }
    fclose(file);
    return rows;
}

static inline double csv_number(const struct csv_row *row, int column)
{
    return column < row->count ? strtod(row->field[column], NULL) : NAN;
}

#endif
