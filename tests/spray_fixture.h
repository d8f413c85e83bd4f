/* Test fixture: build a spray solver from INI text (and optional particle rows) through the public case
 * reader, as a user's case file would. */
#ifndef SPRAYCOAT_TESTS_SPRAY_FIXTURE_H
#define SPRAYCOAT_TESTS_SPRAY_FIXTURE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "case_fixture.h"
#include "core/config.h"
#include "core/error.h"
#include "app/app.h"
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
    if (case_fixture_write(f->dir, ini, "particles.csv", "x,y,z,vx,vy,vz,wx,wy,wz,d", rows,
                           "\n[spray]\ninjection = file\nparticles = particles.csv\n") != 0)
        return -1;
    int status = case_fixture_load(f->dir, spraycoat_registry, &f->c);
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
    dem_destroy(f->solver);
    dem_config_free(&f->cfg);
    case_free(f->c);
    case_fixture_remove(f->dir);
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
