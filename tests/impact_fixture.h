/* Test fixture: build an impact (MPM) solver from INI text and optional bodies rows through the public case
 * reader, as a user's case file would. */
#ifndef SPRAYCOAT_TESTS_IMPACT_FIXTURE_H
#define SPRAYCOAT_TESTS_IMPACT_FIXTURE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "case_fixture.h"
#include "core/config.h"
#include "core/error.h"
#include "core/run_keys.h"
#include "mpm/mpm.h"

struct impact_fixture {
    char dir[64];
    struct case_file *c;
    struct mpm_config cfg;
    struct mpm_solver *solver;
};

/* rows: bodies as "shape,x,y,z,vx,vy,vz,d,h,material\n" lines (NULL: the single particle of [impact]);
 * particle_temperature (K): the last body (the particle) starts at it, as a seed from the spray (0: its material's
 * T_initial). */
static int impact_fixture_open_at(struct impact_fixture *f, const char *ini, const char *rows,
                                  double particle_temperature) __attribute__((unused));
static int impact_fixture_open_at(struct impact_fixture *f, const char *ini, const char *rows,
                                  double particle_temperature)
{
    static const struct cfg_key *const registry[] = {run_case_keys, mpm_case_keys, NULL};
    memset(f, 0, sizeof *f);
    if (case_fixture_write(f->dir, ini, "bodies.csv", "shape,x,y,z,vx,vy,vz,d,h,material", rows,
                           "\n[impact]\nbodies = bodies.csv\n") != 0)
        return -1;
    int status = case_fixture_load(f->dir, registry, &f->c);
    if (status == SC_OK)
        status = mpm_config_load(f->c, &f->cfg);
    if (status == SC_OK && particle_temperature > 0.0)
        status = mpm_config_set_particle_temperatures(&f->cfg, 1, &particle_temperature);
    if (status == SC_OK)
        status = mpm_create(&f->cfg, &f->solver);
    if (status != SC_OK)
        printf("  fixture: %s\n", sc_error_message());
    return status;
}

static int impact_fixture_open(struct impact_fixture *f, const char *ini, const char *rows) __attribute__((unused));
static int impact_fixture_open(struct impact_fixture *f, const char *ini, const char *rows)
{
    return impact_fixture_open_at(f, ini, rows, 0.0);
}

static void impact_fixture_close(struct impact_fixture *f) __attribute__((unused));
static void impact_fixture_close(struct impact_fixture *f)
{
    mpm_destroy(f->solver);
    mpm_config_free(&f->cfg);
    case_free(f->c);
    case_fixture_remove(f->dir);
    memset(f, 0, sizeof *f);
}

/* Run to t_end; SC_OK or the solver's error (printed). */
static int impact_fixture_run(struct impact_fixture *f) __attribute__((unused));
static int impact_fixture_run(struct impact_fixture *f)
{
    while (!mpm_finished(f->solver)) {
        int status = mpm_step(f->solver);
        if (status != SC_OK) {
            printf("  run: %s\n", sc_error_message());
            return status;
        }
    }
    return SC_OK;
}

#endif
