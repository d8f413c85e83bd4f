/* Test fixtures share this: a temporary folder holding a case file written from INI text and, optionally, the
 * CSV it names, loaded through the public case reader as a user's file would be. */
#ifndef SPRAYCOAT_TESTS_CASE_FIXTURE_H
#define SPRAYCOAT_TESTS_CASE_FIXTURE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/config.h"

/* dir[64] becomes a new folder; rows (NULL: none) go to dir/csv_name under `header`, and `reference` (the INI
 * lines that name that file) is appended to the case.  0 or -1 (folder or file not made). */
static int case_fixture_write(char dir[64], const char *ini, const char *csv_name, const char *header, const char *rows,
                              const char *reference) __attribute__((unused));
static int case_fixture_write(char dir[64], const char *ini, const char *csv_name, const char *header, const char *rows,
                              const char *reference)
{
    strcpy(dir, "/tmp/spraycoat-test-XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    char path[256];
    if (rows) {
        snprintf(path, sizeof path, "%s/%s", dir, csv_name);
        FILE *csv = fopen(path, "w");
        if (!csv)
            return -1;
        fprintf(csv, "%s\n%s", header, rows);
        fclose(csv);
    }
    snprintf(path, sizeof path, "%s/case.ini", dir);
    FILE *file = fopen(path, "w");
    if (!file)
        return -1;
    fputs(ini, file);
    if (rows)
        fputs(reference, file);
    fclose(file);
    return 0;
}

/* Load dir/case.ini against `registry`. */
static int case_fixture_load(const char *dir, const struct cfg_key *const *registry, struct case_file **c)
    __attribute__((unused));
static int case_fixture_load(const char *dir, const struct cfg_key *const *registry, struct case_file **c)
{
    char path[256];
    snprintf(path, sizeof path, "%s/case.ini", dir);
    return case_load(path, registry, c);
}

static void case_fixture_remove(const char *dir) __attribute__((unused));
static void case_fixture_remove(const char *dir)
{
    char command[128];
    snprintf(command, sizeof command, "rm -rf %s", dir);
    if (system(command) != 0)
        printf("  fixture: could not remove %s\n", dir);
}

#endif
