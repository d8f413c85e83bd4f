/* Test fixture: build a spray solver from INI text (and optional particle rows) through the public case
 * reader, as a user's case file would. */
#ifndef SPRAYCOAT_TESTS_SPRAY_FIXTURE_H
#define SPRAYCOAT_TESTS_SPRAY_FIXTURE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/config.h"
#include "core/error.h"
#include "coupling/stages.h"
#include "dem/dem.h"

struct fixture {
    char dir[64];
    struct case_file *c;
    struct dem_config cfg;
    struct dem_solver *solver;
};

/* rows: particles as "x,y,z,vx,vy,vz,wx,wy,wz,d\n" lines (NULL for stream injection). */
static int fixture_open(struct fixture *f, const char *ini, const char *rows) __attribute__((unused));
static int fixture_open(struct fixture *f, const char *ini, const char *rows)
{
    memset(f, 0, sizeof *f);
    strcpy(f->dir, "/tmp/spraycoat-test-XXXXXX");
    if (!mkdtemp(f->dir))
        return -1;
    char path[256];
    if (rows) {
        snprintf(path, sizeof path, "%s/particles.csv", f->dir);
        FILE *csv = fopen(path, "w");
        fprintf(csv, "x,y,z,vx,vy,vz,wx,wy,wz,d\n%s", rows);
        fclose(csv);
    }
    snprintf(path, sizeof path, "%s/case.ini", f->dir);
    FILE *file = fopen(path, "w");
    fputs(ini, file);
    if (rows)
        fputs("\n[spray]\ninjection = file\nparticles = particles.csv\n", file);
    fclose(file);
    int status = case_load(path, spraycoat_registry, &f->c);
    if (status == SC_OK)
        status = dem_config_load(f->c, &f->cfg);
    if (status == SC_OK)
        status = dem_create(&f->cfg, &f->solver);
    if (status != SC_OK)
        printf("  fixture: %s\n", sc_error_message());
    return status;
}

static void fixture_close(struct fixture *f) __attribute__((unused));
static void fixture_close(struct fixture *f)
{
    char command[128];
    dem_destroy(f->solver);
    dem_config_free(&f->cfg);
    case_free(f->c);
    snprintf(command, sizeof command, "rm -rf %s", f->dir);
    if (system(command) != 0)
        printf("  could not remove %s\n", f->dir);
}

static int fixture_steps(struct fixture *f, int64_t steps) __attribute__((unused));
static int fixture_steps(struct fixture *f, int64_t steps)
{
    for (int64_t k = 0; k < steps; k++) {
        int status = dem_step(f->solver);
        if (status != SC_OK) {
            printf("  step failed: %s\n", sc_error_message());
            return status;
        }
    }
    return SC_OK;
}

#endif
