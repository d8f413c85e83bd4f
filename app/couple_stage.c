/* The couple stage: spray.h5 -> sampled impacts -> CVODE flights through the jet's wall region -> MPM seeds in
 * RUN_DIR/couple.h5 (/seeds, /flight).  The stage has no checkpoints: it flies a few hundred particles at most,
 * in well under a second each, and writes couple.h5 atomically at the end, so an interrupted stage is simply
 * run again (with the same result: the flights and the sampling are deterministic). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/h5io.h"
#include "core/log.h"
#include "coupling/coupling.h"
#include "app/app.h"
#include "dem/dem.h"

#define STAGE         "couple"
#define COUPLE_FORMAT "spraycoat-couple"
/* 2: the flights end at the height of the spray's first contact (/flight/stop_z), a deposit's above the target
 * plane; version 1 flew every one on to the plane.  The impact stage reads /seeds of either alike. */
#define COUPLE_FORMAT_VERSION 2

/* malloc(0) may return NULL: every array gets at least one element. */
static size_t at_least_one(size_t n)
{
    return n ? n : 1;
}

/* The rows of spray.h5 the stage uses. */
struct spray_rows {
    size_t impact_count, handoff_count;
    struct dem_impact *impacts;
    struct dem_handoff *handoffs;
};

/* How closely the spray's own impact velocities (spray.h5 /impacts v_in) agree with the CVODE flights to the same
 * contacts: |v_end - v_in| / |v_in| over the flights that reached their contact. */
struct flight_agreement {
    size_t flights;
    double mean, median, max;
    size_t worst;    /* the flight of the max */
    size_t outliers; /* flights more than COUPLE_SPRAY_VELOCITY_OUTLIER off */
};

/* A spray whose impact velocities differ from the flights' by more than this at the median is warned of: its step
 * resolves the gas at the wall too coarsely; at the spray's own resolution they agree within 0.1-0.2 %
 * (docs/physics.md "The spray's resolution").  The median, not the max: one particle that met another after its
 * hand-off, which the one-way flight does not see, is off by tens of per cent whatever the step (a review: 102 % in
 * the tests' small pipeline with 40 runs), and a smaller dt would not help it. */
#define COUPLE_SPRAY_VELOCITY_WARN 0.01
/* Flights further off than this are counted and warned of apart: such a particle most likely met another one. */
#define COUPLE_SPRAY_VELOCITY_OUTLIER 0.1

struct couple_work {
    const struct stage_context *ctx;
    const struct case_file *c;
    const char *run_dir;
    uint64_t hash;
    struct couple_config cfg;
    struct couple_flight_layer layer;
    struct spray_rows spray;
    struct couple_candidate *candidates;
    size_t candidate_count;
    size_t *handoff_of;                   /* per candidate: its hand-off row, or SIZE_MAX */
    struct couple_flight_result *flights; /* in the order flown */
    size_t *flight_candidate;
    size_t flight_count;
    struct couple_seed *seeds;
    size_t seed_count;
    double spray_dt;                   /* [spray] dt, named when the spray's impact velocities disagree */
    struct flight_agreement agreement; /* the flights' end velocities against the spray's own */
};

/* ---- spray.h5 ---------------------------------------------------------------------------------------------- */

/* Read `name` (rows x width doubles) into the field at `offset` of `rows` records of `stride` bytes. */
static int read_into_records(hid_t group, const char *name, size_t rows, size_t width, void *records, size_t stride,
                             size_t offset)
{
    double *column = malloc(at_least_one(rows * width) * sizeof *column);
    if (!column)
        SC_FAIL_OOM(at_least_one(rows * width) * sizeof *column, name);
    int status;
    SC_CHECK(status, h5_read_doubles(group, name, column, rows * width), done);
    for (size_t i = 0; i < rows; i++)
        memcpy((char *)records + i * stride + offset, column + i * width, width * sizeof *column);
done:
    free(column);
    return status;
}

static int read_ids_into_records(hid_t group, const char *name, size_t rows, void *records, size_t stride,
                                 size_t offset)
{
    int64_t *column = malloc(at_least_one(rows) * sizeof *column);
    if (!column)
        SC_FAIL_OOM(at_least_one(rows) * sizeof *column, name);
    int status;
    SC_CHECK(status, h5_read_int64s(group, name, column, rows), done);
    for (size_t i = 0; i < rows; i++)
        memcpy((char *)records + i * stride + offset, column + i, sizeof *column);
done:
    free(column);
    return status;
}

#define READ_FIELD(group, rows, array, type, field, width)                                                             \
    read_into_records(group, #field, rows, width, array, sizeof(type), offsetof(type, field))
#define READ_ID(group, rows, array, type, field)                                                                       \
    read_ids_into_records(group, #field, rows, array, sizeof(type), offsetof(type, field))

/* `path`: the file, for the messages. */
static int read_impacts(hid_t file, const char *path, struct spray_rows *rows)
{
    hid_t g = H5Gopen2(file, "impacts", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "couple: spray.h5 has no /impacts group");
    size_t n = 0;
    int status;
    SC_CHECK(status, h5_dataset_size(g, "t", &n), done);
    rows->impact_count = n;
    SC_CHECK(status, sc_calloc(&rows->impacts, n ? n : 1, sizeof *rows->impacts, "the spray impacts"), done);
    struct dem_impact *r = rows->impacts;
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, t, 1), done);
    SC_CHECK(status, READ_ID(g, n, r, struct dem_impact, particle_id), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, x, 3), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, v_in, 3), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, d, 1), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, m, 1), done);
    SC_CHECK(status, READ_ID(g, n, r, struct dem_impact, partner), done);
    /* the seeds' temperature is the impacts' (no fallback to a material's T_initial): a spray.h5 without it is of
     * a spraycoat before spray format 4, and its spray stage must run again */
    if (!h5_exists(g, "temperature"))
        SC_FAIL_AT(status, done, SC_EIO,
                   "couple: %s has no /impacts/temperature: it was written by an older version of spraycoat (spray "
                   "format before version 4); run the spray stage again (`spraycoat spray` or `spraycoat run`) to "
                   "have the particles' temperatures at impact",
                   path);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_impact, temperature, 1), done);
done:
    H5Gclose(g);
    return status;
}

static int read_handoffs(hid_t file, struct spray_rows *rows)
{
    hid_t g = H5Gopen2(file, "handoff", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "couple: spray.h5 has no /handoff group");
    size_t n = 0;
    int status;
    SC_CHECK(status, h5_dataset_size(g, "t", &n), done);
    rows->handoff_count = n;
    SC_CHECK(status, sc_calloc(&rows->handoffs, n ? n : 1, sizeof *rows->handoffs, "the spray hand-offs"), done);
    struct dem_handoff *r = rows->handoffs;
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_handoff, t, 1), done);
    SC_CHECK(status, READ_ID(g, n, r, struct dem_handoff, particle_id), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_handoff, x, 3), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_handoff, v, 3), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_handoff, d, 1), done);
    SC_CHECK(status, READ_FIELD(g, n, r, struct dem_handoff, axis, 2), done);
done:
    H5Gclose(g);
    return status;
}

/* spray.h5 must exist and come from this case's spray stage. */
static int read_spray(struct couple_work *w)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.h5", w->run_dir);
    SC_TRY(run_dir_check_input(w->ctx, "spray", STAGE, 1));
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    int status;
    SC_CHECK(status, read_impacts(file, path, &w->spray), done);
    SC_CHECK(status, read_handoffs(file, &w->spray), done);
done:
    H5Fclose(file);
    return status;
}

/* ---- candidates -------------------------------------------------------------------------------------------- */

/* Row indices of n records (stride bytes apart; a particle id and a time at the given offsets) ordered by particle,
 * then time, then row: a total order, so the result does not depend on qsort's algorithm.  NULL: out of memory. */
static const char *sort_records;
static size_t sort_stride, sort_id_offset, sort_t_offset;

static int compare_by_particle_and_time(const void *pa, const void *pb)
{
    size_t a = *(const size_t *)pa, b = *(const size_t *)pb;
    int64_t id_a, id_b;
    double t_a, t_b;
    memcpy(&id_a, sort_records + a * sort_stride + sort_id_offset, sizeof id_a);
    memcpy(&id_b, sort_records + b * sort_stride + sort_id_offset, sizeof id_b);
    memcpy(&t_a, sort_records + a * sort_stride + sort_t_offset, sizeof t_a);
    memcpy(&t_b, sort_records + b * sort_stride + sort_t_offset, sizeof t_b);
    if (id_a != id_b)
        return id_a < id_b ? -1 : 1;
    if (t_a != t_b)
        return t_a < t_b ? -1 : 1;
    return (a > b) - (a < b);
}

static size_t *rows_by_particle_and_time(const void *records, size_t n, size_t stride, size_t id_offset,
                                         size_t t_offset)
{
    size_t *order = malloc(at_least_one(n) * sizeof *order);
    if (!order)
        return NULL;
    for (size_t i = 0; i < n; i++)
        order[i] = i;
    sort_records = records;
    sort_stride = stride;
    sort_id_offset = id_offset;
    sort_t_offset = t_offset;
    qsort(order, n, sizeof *order, compare_by_particle_and_time);
    return order;
}

/* The first contact of every particle, in order of particle id. */
static int find_candidates(struct couple_work *w)
{
    size_t n = w->spray.impact_count;
    size_t *order = rows_by_particle_and_time(w->spray.impacts, n, sizeof *w->spray.impacts,
                                              offsetof(struct dem_impact, particle_id), offsetof(struct dem_impact, t));
    if (!order)
        SC_FAIL_OOM(at_least_one(n) * sizeof *order, "the order of the spray impacts");
    w->candidates = calloc(at_least_one(n), sizeof *w->candidates);
    if (!w->candidates) {
        free(order);
        SC_FAIL_OOM(at_least_one(n) * sizeof *w->candidates, "the couple candidates");
    }
    for (size_t i = 0; i < n; i++) {
        const struct dem_impact *row = &w->spray.impacts[order[i]];
        if (i > 0 && row->particle_id == w->spray.impacts[order[i - 1]].particle_id)
            continue;
        struct couple_candidate *c = &w->candidates[w->candidate_count++];
        c->impact_row = (int64_t)order[i];
        c->particle_id = row->particle_id;
        c->partner = row->partner;
        c->t = row->t;
        memcpy(c->x, row->x, sizeof c->x);
        memcpy(c->v, row->v_in, sizeof c->v);
        c->d = row->d;
        c->m = row->m;
        c->temperature = row->temperature;
    }
    free(order);
    return SC_OK;
}

/* Each candidate's last crossing of the hand-off plane before its impact (linear scan per candidate over the
 * hand-offs sorted by particle: both lists are in particle order). */
static int match_handoffs(struct couple_work *w)
{
    size_t n = w->spray.handoff_count;
    size_t *order =
        rows_by_particle_and_time(w->spray.handoffs, n, sizeof *w->spray.handoffs,
                                  offsetof(struct dem_handoff, particle_id), offsetof(struct dem_handoff, t));
    if (!order)
        SC_FAIL_OOM(at_least_one(n) * sizeof *order, "the order of the spray hand-offs");
    w->handoff_of = malloc(at_least_one(w->candidate_count) * sizeof *w->handoff_of);
    if (!w->handoff_of) {
        free(order);
        SC_FAIL_OOM(at_least_one(w->candidate_count) * sizeof *w->handoff_of, "the couple hand-off rows");
    }
    size_t h = 0;
    for (size_t k = 0; k < w->candidate_count; k++) {
        const struct couple_candidate *c = &w->candidates[k];
        w->handoff_of[k] = SIZE_MAX;
        while (h < n && w->spray.handoffs[order[h]].particle_id < c->particle_id)
            h++;
        for (size_t j = h; j < n && w->spray.handoffs[order[j]].particle_id == c->particle_id; j++)
            if (w->spray.handoffs[order[j]].t <= c->t)
                w->handoff_of[k] = order[j];
    }
    free(order);
    return SC_OK;
}

/* ---- flights and seeds ------------------------------------------------------------------------------------- */

static int setup_layer(struct couple_work *w, const struct dem_config *spray)
{
    struct couple_flight_layer *layer = &w->layer;
    layer->gas = spray->gas; /* its wall at the target (dem_config_load): the field the spray flew through */
    layer->rtol = w->cfg.rtol;
    layer->atol = w->cfg.atol;
    log_info("couple: the spray's gas, wall region %.4g m deep (axial speed %.4g m/s at its top); hand-off plane "
             "%.4g m before the target",
             layer->gas.stagnation_height, layer->gas.wall_axis_speed, spray->handoff_height);
    if (layer->gas.shock_standoff > 0.0)
        log_info("couple: the wall region is the layer behind a bow shock at Mach %.3g (rho2/rho1 = %.3g)",
                 layer->gas.shock_mach, layer->gas.shock_density_ratio);
    return SC_OK;
}

/* Fly candidate k from its hand-off crossing to its first contact's height; returns its flight row in *row. */
static int fly(struct couple_work *w, struct couple_flight_solver *solver, size_t k, size_t *row)
{
    const struct dem_handoff *h = &w->spray.handoffs[w->handoff_of[k]];
    const struct couple_candidate *c = &w->candidates[k];
    double density = c->m / (M_PI * c->d * c->d * c->d / 6.0);
    size_t i = w->flight_count;
    /* the jet's axis where the nozzle was at the hand-off: quasi-steady over the flight's few us (3.9-4.6 us in the
     * demo), in which the nozzle moves under 1 um at 0.2 m/s */
    w->layer.gas.axis_x = h->axis[0];
    w->layer.gas.axis_y = h->axis[1];
    if (couple_flight_integrate(solver, &w->layer, c->d, density, h->t, h->x, h->v,
                                couple_candidate_stop_z(&w->layer, c), &w->flights[i]) != SC_OK) {
        char reason[1024];
        snprintf(reason, sizeof reason, "%s", sc_error_message());
        SC_FAIL(SC_ESIM,
                "couple: the flight of particle %lld (d = %.4g um; spray.h5 /impacts row %lld, /handoff row %zu): %s",
                (long long)c->particle_id, c->d * 1e6, (long long)c->impact_row, w->handoff_of[k], reason);
    }
    w->flight_candidate[i] = k;
    w->flight_count++;
    *row = i;
    return SC_OK;
}

/* Whether a flight with sample = window ends inside the window: the window takes its candidates by where the spray
 * met the obstacle, the bodies are placed where the flights end.  A flight that flew on past a deposit to the target
 * plane drifted sideways a few um, and a body was placed outside the patch, past what the substrate was checked to
 * hold (a review: -77.5 um in a 150 um window).  Flights now end at the contact's height (couple_candidate_stop_z),
 * but the spray's x is where the particle rests, moved in along the contact's normal from where its contact was
 * found within the drag skin (dem/collide.c rest_position): 1-8 um aside at dt = 1 us in that case, enough at the
 * window's edge. */
static int inside_window(const struct couple_config *cfg, const double x_wall[3])
{
    double half = 0.5 * cfg->patch_size;
    return cfg->sample != COUPLE_WINDOW ||
           (fabs(x_wall[0] - cfg->window_x) <= half && fabs(x_wall[1] - cfg->window_y) <= half);
}

/* Slot `slot` takes the next candidate of its stratum that has a hand-off, is not taken and reaches the wall (with
 * sample = window, inside the window). */
static int fill_slot(struct couple_work *w, struct couple_flight_solver *solver, const struct couple_strata *strata,
                     size_t *cursor, char *taken, size_t slot)
{
    size_t s = strata->slot_stratum[slot];
    while (cursor[s] < strata->offset[s + 1] - strata->offset[s]) {
        size_t k = strata->members[strata->offset[s] + cursor[s]++];
        if (taken[k] || w->handoff_of[k] == SIZE_MAX)
            continue;
        taken[k] = 1;
        size_t row = 0;
        SC_TRY(fly(w, solver, k, &row));
        const struct couple_flight_result *f = &w->flights[row];
        if (!f->reached || !inside_window(&w->cfg, f->x))
            continue;
        struct couple_seed *seed = &w->seeds[slot];
        seed->candidate = k;
        seed->flight = row;
        seed->t_wall = f->t;
        memcpy(seed->x_wall, f->x, sizeof seed->x_wall);
        memcpy(seed->v_wall, f->v, sizeof seed->v_wall);
        seed->d = w->candidates[k].d;
        seed->m = w->candidates[k].m;
        seed->temperature = w->candidates[k].temperature;
        return SC_OK;
    }
    if (w->cfg.sample == COUPLE_WINDOW) /* inside_window passes over flights ending outside: the window may be why */
        return case_invalid(
            w->c, "couple", "runs",
            "seed %zu: no further spray impact in the window reaches the wall inside it with a hand-off "
            "crossing (%zu flown so far); allowed: fewer runs or bodies_per_run, a larger patch_size, "
            "a window (window_x, window_y) where more particles arrive, or a spray with more impacts",
            slot + 1, w->flight_count);
    return case_invalid(w->c, "couple", "runs",
                        "seed %zu: no further spray impact of its %s reaches the wall with a "
                        "hand-off crossing (%zu flown so far); allowed: fewer runs or bodies_per_run, or a spray with "
                        "more impacts",
                        slot + 1, w->cfg.sample == COUPLE_STRATIFIED ? "stratum" : "sample", w->flight_count);
}

static int make_seeds(struct couple_work *w)
{
    struct couple_strata strata;
    SC_TRY(couple_strata_build(w->c, &w->cfg, w->candidates, w->candidate_count, &strata));
    size_t seeds = (size_t)(w->cfg.runs * w->cfg.bodies_per_run), n = w->candidate_count;
    w->seed_count = seeds;
    size_t *cursor = NULL;
    char *taken = NULL;
    struct couple_flight_solver *solver = NULL;
    struct progress bar;
    log_progress_begin(&bar, STAGE, "seeds", 0, (int64_t)seeds);
    size_t filled = 0;
    int status;
    SC_CHECK(status, sc_calloc(&w->seeds, seeds, sizeof *w->seeds, "the couple seeds"), done);
    SC_CHECK(status, sc_calloc(&w->flights, n ? n : 1, sizeof *w->flights, "the couple flights"), done);
    SC_CHECK(status, sc_calloc(&w->flight_candidate, n ? n : 1, sizeof *w->flight_candidate, "the couple flights"),
             done);
    SC_CHECK(status, sc_calloc(&cursor, strata.count, sizeof *cursor, "the couple strata"), done);
    SC_CHECK(status, sc_calloc(&taken, n ? n : 1, 1, "the couple candidates"), done);
    SC_CHECK(status, couple_flight_solver_create(&solver), done);
    for (size_t slot = 0; slot < seeds; slot++) {
        SC_CHECK(status, fill_slot(w, solver, &strata, cursor, taken, slot), done);
        filled++;
        log_progress_update(&bar, (int64_t)slot + 1, "");
        /* couple.h5 is written whole at the end: an interrupted stage keeps nothing and runs again on resume */
        int interrupted = interrupt_status();
        if (interrupted)
            SC_FAIL_AT(status, done, interrupted,
                       "couple: interrupted after %zu of %zu seeds; the stage runs again "
                       "from its start on `spraycoat resume %s`",
                       slot + 1, seeds, w->run_dir);
    }
    couple_assign_runs(&w->cfg, w->seeds, seeds);
    for (size_t r = 0; r < (size_t)w->cfg.runs; r++)
        couple_place_run(&w->cfg, w->seeds + r * (size_t)w->cfg.bodies_per_run, (size_t)w->cfg.bodies_per_run);
done:
    if (status == SC_OK)
        log_progress_end(&bar, (int64_t)seeds);
    else
        log_progress_stop(&bar, (int64_t)filled);
    couple_flight_solver_destroy(solver);
    free(cursor);
    free(taken);
    couple_strata_free(&strata);
    return status;
}

/* ---- couple.h5 --------------------------------------------------------------------------------------------- */

/* One column of n rows into group g, each row's value from `expr` (or 3 values from `array`) with row index i;
 * the caller holds `status` and a cleanup label `done`, scratch `ints` (n) and `reals` (3 n), and `dims1` /
 * `dims3`. */
#define COLUMN_INT(name, expr)                                                                                         \
    for (size_t i = 0; i < n; i++)                                                                                     \
        ints[i] = (int64_t)(expr);                                                                                     \
    SC_CHECK(status, h5_write_int64s(g, name, 1, dims1, ints, "", 0), done);
#define COLUMN_REAL(name, expr, unit)                                                                                  \
    for (size_t i = 0; i < n; i++)                                                                                     \
        reals[i] = (expr);                                                                                             \
    SC_CHECK(status, h5_write_doubles(g, name, 1, dims1, reals, unit, 0), done);
#define COLUMN_VEC(name, array, unit)                                                                                  \
    for (size_t i = 0; i < n; i++)                                                                                     \
        memcpy(reals + 3 * i, (array), 3 * sizeof *reals);                                                             \
    SC_CHECK(status, h5_write_doubles(g, name, 2, dims3, reals, unit, 0), done);

static int write_seed_columns(hid_t g, const struct couple_work *w)
{
    size_t n = w->seed_count;
    int64_t *ints = malloc(at_least_one(n) * sizeof *ints);
    double *reals = malloc(at_least_one(3 * n) * sizeof *reals);
    int status = SC_OK;
    if (!ints || !reals)
        SC_FAIL_OOM_AT(status, done, at_least_one(n) * (sizeof *ints + 3 * sizeof *reals), "the couple.h5 columns");
    hsize_t dims1[1] = {n}, dims3[2] = {n, 3};
    const struct couple_seed *s = w->seeds;
    COLUMN_INT("run", s[i].run)
    COLUMN_INT("body", s[i].body)
    COLUMN_INT("impact_row", w->candidates[s[i].candidate].impact_row)
    COLUMN_INT("particle_id", w->candidates[s[i].candidate].particle_id)
    COLUMN_INT("flight", (int64_t)s[i].flight)
    COLUMN_REAL("d", s[i].d, "m")
    COLUMN_REAL("m", s[i].m, "kg")
    COLUMN_REAL("t_wall", s[i].t_wall, "s")
    COLUMN_VEC("x", s[i].center, "m")
    COLUMN_VEC("v", s[i].velocity, "m/s")
    COLUMN_VEC("x_wall", s[i].x_wall, "m")
    COLUMN_VEC("v_wall", s[i].v_wall, "m/s")
    COLUMN_VEC("v_spray", w->candidates[s[i].candidate].v, "m/s")
    COLUMN_REAL("temperature", s[i].temperature, "K")
done:
    free(ints);
    free(reals);
    return status;
}

static int write_seeds(hid_t file, const struct couple_work *w)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "seeds", &g));
    static const char *const rules[] = {"random", "stratified", "window"};
    int status;
    SC_CHECK(status, write_seed_columns(g, w), done);
    SC_CHECK(status, h5_attr_write_string(g, "sample", rules[w->cfg.sample]), done);
    SC_CHECK(status, h5_attr_write_int64(g, "runs", w->cfg.runs), done);
    SC_CHECK(status, h5_attr_write_int64(g, "bodies_per_run", w->cfg.bodies_per_run), done);
    SC_CHECK(status, h5_attr_write_double(g, "patch_size", w->cfg.patch_size), done);
    SC_CHECK(status, h5_attr_write_int64(g, "candidates", (int64_t)w->candidate_count), done);
done:
    H5Gclose(g);
    return status;
}

/* The trajectories, concatenated: flight i has samples offset[i] ... offset[i + 1] - 1. */
static int write_trajectories(hid_t g, const struct couple_work *w)
{
    size_t nf = w->flight_count, total = 0;
    for (size_t i = 0; i < nf; i++)
        total += w->flights[i].samples;
    int64_t *offset = malloc((nf + 1) * sizeof *offset);
    double *t = malloc(at_least_one(total) * sizeof *t), *x = malloc(at_least_one(3 * total) * sizeof *x),
           *v = malloc(at_least_one(3 * total) * sizeof *v);
    int status = SC_OK;
    if (!offset || !t || !x || !v)
        SC_FAIL_OOM_AT(status, done, (nf + 1) * sizeof *offset + at_least_one(7 * total) * sizeof *t,
                       "the flight trajectories");
    size_t at = 0;
    for (size_t i = 0; i < nf; i++) {
        const struct couple_flight_result *f = &w->flights[i];
        offset[i] = (int64_t)at;
        memcpy(t + at, f->sample_t, f->samples * sizeof *t);
        memcpy(x + 3 * at, f->sample_x, 3 * f->samples * sizeof *x);
        memcpy(v + 3 * at, f->sample_v, 3 * f->samples * sizeof *v);
        at += f->samples;
    }
    offset[nf] = (int64_t)at;
    hsize_t off_dims[1] = {nf + 1}, t_dims[1] = {total}, x_dims[2] = {total, 3};
    SC_CHECK(status, h5_write_int64s(g, "sample_offset", 1, off_dims, offset, "", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "sample_t", 1, t_dims, t, "s", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "sample_x", 2, x_dims, x, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "sample_v", 2, x_dims, v, "m/s", 0), done);
done:
    free(offset);
    free(t);
    free(x);
    free(v);
    return status;
}

static int write_flight_columns(hid_t g, const struct couple_work *w)
{
    size_t n = w->flight_count;
    int64_t *ints = malloc(at_least_one(n) * sizeof *ints);
    double *reals = malloc(at_least_one(3 * n) * sizeof *reals);
    int status = SC_OK;
    if (!ints || !reals)
        SC_FAIL_OOM_AT(status, done, at_least_one(n) * (sizeof *ints + 3 * sizeof *reals), "the couple.h5 columns");
    hsize_t dims1[1] = {n}, dims3[2] = {n, 3};
    const struct couple_flight_result *f = w->flights;
    const struct couple_candidate *c = w->candidates;
    const size_t *k = w->flight_candidate;
    COLUMN_INT("impact_row", c[k[i]].impact_row)
    COLUMN_INT("particle_id", c[k[i]].particle_id)
    COLUMN_INT("handoff_row", w->handoff_of[k[i]])
    COLUMN_REAL("d", c[k[i]].d, "m")
    COLUMN_REAL("t0", f[i].samples ? f[i].sample_t[0] : NAN, "s")
    COLUMN_VEC("x0", f[i].sample_x, "m")
    COLUMN_VEC("v0", f[i].sample_v, "m/s")
    COLUMN_REAL("t_end", f[i].t, "s")
    COLUMN_REAL("stop_z", couple_candidate_stop_z(&w->layer, &c[k[i]]), "m")
    COLUMN_VEC("x_end", f[i].x, "m")
    COLUMN_VEC("v_end", f[i].v, "m/s")
    COLUMN_INT("reached", f[i].reached)
    COLUMN_INT("steps", f[i].steps)
    COLUMN_INT("rhs_evals", f[i].rhs_evals)
    COLUMN_INT("jac_evals", f[i].jac_evals)
    COLUMN_INT("error_test_failures", f[i].error_test_failures)
    COLUMN_INT("nonlinear_iterations", f[i].nonlinear_iterations)
    COLUMN_INT("nonlinear_failures", f[i].nonlinear_failures)
done:
    free(ints);
    free(reals);
    return status;
}

static int write_flights(hid_t file, const struct couple_work *w)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "flight", &g));
    int status;
    SC_CHECK(status, write_flight_columns(g, w), done);
    SC_CHECK(status, write_trajectories(g, w), done);
    SC_CHECK(status, h5_attr_write_double(g, "wall_z", w->layer.gas.wall_z), done);
    SC_CHECK(status, h5_attr_write_double(g, "stagnation_height", w->layer.gas.stagnation_height), done);
    SC_CHECK(status, h5_attr_write_double(g, "rtol", w->layer.rtol), done);
    SC_CHECK(status, h5_attr_write_double(g, "atol", w->layer.atol), done);
    SC_CHECK(status, h5_attr_write_double(g, "spray_velocity_difference_mean", w->agreement.mean), done);
    SC_CHECK(status, h5_attr_write_double(g, "spray_velocity_difference_median", w->agreement.median), done);
    SC_CHECK(status, h5_attr_write_double(g, "spray_velocity_difference_max", w->agreement.max), done);
    SC_CHECK(status, h5_attr_write_int64(g, "spray_velocity_outliers", (int64_t)w->agreement.outliers), done);
done:
    H5Gclose(g);
    return status;
}

static int output_contents(void *owner, hid_t file)
{
    const struct couple_work *w = owner;
    SC_TRY(write_seeds(file, w));
    return write_flights(file, w);
}

static int write_output(const struct couple_work *w)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/couple.h5", w->run_dir);
    SC_TRY(stage_write_output(path, COUPLE_FORMAT, COUPLE_FORMAT_VERSION, STAGE, w->hash, w->c, output_contents,
                              (void *)w));
    log_info("couple: wrote %s", path);
    return SC_OK;
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* |v_end - v_in| / |v_in| of flight i (the spray's impact velocity against the flight's). */
static double flight_difference(const struct couple_work *w, size_t i)
{
    const struct couple_flight_result *f = &w->flights[i];
    const double *v_spray = w->candidates[w->flight_candidate[i]].v;
    double difference = 0.0, speed = 0.0;
    for (int k = 0; k < 3; k++) {
        difference += (f->v[k] - v_spray[k]) * (f->v[k] - v_spray[k]);
        speed += v_spray[k] * v_spray[k];
    }
    return sqrt(difference / speed);
}

static int flight_agreement(const struct couple_work *w, struct flight_agreement *a)
{
    *a = (struct flight_agreement){.mean = NAN, .median = NAN, .max = NAN};
    double *relative = malloc(at_least_one(w->flight_count) * sizeof *relative);
    if (!relative)
        SC_FAIL_OOM(at_least_one(w->flight_count) * sizeof *relative, "the flights' differences from the spray");
    double sum = 0.0;
    for (size_t i = 0; i < w->flight_count; i++) {
        if (!w->flights[i].reached)
            continue;
        double r = flight_difference(w, i);
        sum += r;
        if (a->flights == 0 || r > a->max) {
            a->max = r;
            a->worst = i;
        }
        a->outliers += r > COUPLE_SPRAY_VELOCITY_OUTLIER;
        relative[a->flights++] = r;
    }
    if (a->flights) {
        qsort(relative, a->flights, sizeof *relative, compare_doubles);
        size_t half = a->flights / 2;
        a->median = a->flights % 2 ? relative[half] : 0.5 * (relative[half - 1] + relative[half]);
        a->mean = sum / (double)a->flights;
    }
    free(relative);
    return SC_OK;
}

/* The flights against the spray's impact velocities: told always; warned of when the median is beyond
 * COUPLE_SPRAY_VELOCITY_WARN (the spray's step) and when some are beyond COUPLE_SPRAY_VELOCITY_OUTLIER. */
static void log_agreement(const struct couple_work *w)
{
    const struct flight_agreement *a = &w->agreement;
    if (!a->flights)
        return;
    const struct couple_candidate *c = &w->candidates[w->flight_candidate[a->worst]];
    log_info("couple: the flights' velocities at the spray's contacts against the spray's own (/impacts v_in): "
             "|dv|/|v| %.3g %% on average, %.3g %% at the median, at most %.3g %% (particle %lld, d = %.3g um; %zu "
             "flights)",
             100.0 * a->mean, 100.0 * a->median, 100.0 * a->max, (long long)c->particle_id, 1e6 * c->d, a->flights);
    if (a->median > COUPLE_SPRAY_VELOCITY_WARN)
        log_warn(
            "couple: the spray's impact velocities differ from the flights' (CVODE) by %.3g %% at the median (over "
            "%g %%): the spray's dt = %g s resolves the gas at the wall coarsely, and the deposition it decided used "
            "those velocities; the impact runs take the flights'. A smaller [spray] dt brings them together "
            "(docs/physics.md \"The couple stage\")",
            100.0 * a->median, 100.0 * COUPLE_SPRAY_VELOCITY_WARN, w->spray_dt);
    if (a->outliers)
        log_warn("couple: %zu of the %zu flights differ from the spray's impact velocities by more than %g %% (at most "
                 "%.3g %%, particle %lld): most likely particles that met another one between the hand-off and the "
                 "target, which the flight (one-way coupled) does not see; their impact runs start from the "
                 "flight's velocity, the spray decided their deposition from its own (docs/physics.md \"The couple "
                 "stage\")",
                 a->outliers, a->flights, 100.0 * COUPLE_SPRAY_VELOCITY_OUTLIER, 100.0 * a->max,
                 (long long)c->particle_id);
}

static void log_summary(const struct couple_work *w)
{
    double speed_spray = 0.0, speed_wall = 0.0, diameter = 0.0;
    long steps = 0;
    for (size_t i = 0; i < w->seed_count; i++) {
        const struct couple_seed *s = &w->seeds[i];
        const double *vs = w->candidates[s->candidate].v;
        speed_spray += sqrt(vs[0] * vs[0] + vs[1] * vs[1] + vs[2] * vs[2]);
        speed_wall += sqrt(s->v_wall[0] * s->v_wall[0] + s->v_wall[1] * s->v_wall[1] + s->v_wall[2] * s->v_wall[2]);
        diameter += s->d;
    }
    for (size_t i = 0; i < w->flight_count; i++)
        steps += w->flights[i].steps;
    double n = (double)at_least_one(w->seed_count);
    log_info("couple: %zu seeds in %ld runs from %zu candidate impacts (%zu flights, %ld CVODE steps); mean diameter "
             "%.3g um, mean speed %.4g m/s in the spray, %.4g m/s at the wall (CVODE through the jet's wall region)",
             w->seed_count, w->cfg.runs, w->candidate_count, w->flight_count, steps, 1e6 * diameter / n,
             speed_spray / n, speed_wall / n);
}

static void couple_work_free(struct couple_work *w)
{
    for (size_t i = 0; i < w->flight_count; i++)
        couple_flight_result_free(&w->flights[i]);
    free(w->flights);
    free(w->flight_candidate);
    free(w->seeds);
    free(w->handoff_of);
    free(w->candidates);
    free(w->spray.impacts);
    free(w->spray.handoffs);
}

/* ---- reading the seeds back (the impact stage) ------------------------------------------------------------- */

void couple_stage_bodies_free(struct couple_bodies *b)
{
    free(b->first);
    free(b->d);
    free(b->center);
    free(b->velocity);
    free(b->temperature);
    memset(b, 0, sizeof *b);
}

static int read_body_columns(hid_t g, struct couple_bodies *b, int64_t *run)
{
    size_t n = b->count;
    b->d = malloc(at_least_one(n) * sizeof *b->d);
    b->center = malloc(at_least_one(3 * n) * sizeof *b->center);
    b->velocity = malloc(at_least_one(3 * n) * sizeof *b->velocity);
    if (!b->d || !b->center || !b->velocity)
        SC_FAIL_OOM(at_least_one(7 * n) * sizeof *b->d, "the seeds of couple.h5");
    SC_TRY(h5_read_int64s(g, "run", run, n));
    SC_TRY(h5_read_doubles(g, "d", b->d, n));
    SC_TRY(h5_read_doubles(g, "x", b->center, 3 * n));
    SC_TRY(h5_read_doubles(g, "v", b->velocity, 3 * n));
    if (!h5_exists(g, "temperature"))
        return SC_OK; /* a couple.h5 from before the seeds carried it: the material's T_initial */
    b->temperature = malloc(at_least_one(n) * sizeof *b->temperature);
    if (!b->temperature)
        SC_FAIL_OOM(at_least_one(n) * sizeof *b->temperature, "the seeds of couple.h5");
    SC_TRY(h5_read_doubles(g, "temperature", b->temperature, n));
    return SC_OK;
}

/* Every seed must be a body the impact stage can make: a finite diameter > 0, a finite centre and velocity.  A NaN
 * there is couple.h5's fault (damaged past its checksum, or written by a faulty couple stage), and the message must
 * say so, not blame the [impact] keys when the MPM set-up fails on it (issue 24). */
static int check_body_rows(const struct couple_bodies *b, const int64_t *run, const char *path)
{
    for (size_t i = 0; i < b->count; i++) {
        const double *x = b->center + 3 * i, *v = b->velocity + 3 * i;
        if (!(isfinite(b->d[i]) && b->d[i] > 0.0))
            SC_FAIL(SC_EIO,
                    "%s: /seeds/d row %zu (a body of run %04lld) is %g, not a diameter > 0; the file is "
                    "damaged or was written wrong: rerun the couple stage",
                    path, i, (long long)run[i], b->d[i]);
        for (int k = 0; k < 3; k++)
            if (!isfinite(x[k]) || !isfinite(v[k]))
                SC_FAIL(SC_EIO,
                        "%s: /seeds/%s row %zu (a body of run %04lld) is not finite; the file is damaged or "
                        "was written wrong: rerun the couple stage",
                        path, isfinite(x[k]) ? "v" : "x", i, (long long)run[i]);
        if (b->temperature && !(isfinite(b->temperature[i]) && b->temperature[i] > 0.0))
            SC_FAIL(SC_EIO,
                    "%s: /seeds/temperature row %zu (a body of run %04lld) is %g, not a temperature > 0 K; the file "
                    "is damaged or was written wrong: rerun the couple stage",
                    path, i, (long long)run[i], b->temperature[i]);
    }
    return SC_OK;
}

/* Rows are grouped by run, in run order (as written). */
static int index_runs(struct couple_bodies *b, const int64_t *run, const char *path)
{
    b->runs = b->count ? (size_t)run[b->count - 1] + 1 : 0;
    b->first = calloc(b->runs + 1, sizeof *b->first);
    if (!b->first)
        SC_FAIL_OOM((b->runs + 1) * sizeof *b->first, "the runs of couple.h5");
    for (size_t i = 0; i < b->count; i++) {
        if (run[i] < 0 || (size_t)run[i] >= b->runs || (i > 0 && run[i] < run[i - 1]))
            SC_FAIL(SC_EIO, "%s: /seeds/run is not grouped by run (row %zu)", path, i);
        b->first[run[i] + 1] = i + 1;
    }
    for (size_t r = 1; r <= b->runs; r++)
        if (b->first[r] < b->first[r - 1])
            b->first[r] = b->first[r - 1];
    return SC_OK;
}

int couple_stage_read_bodies(const struct stage_context *ctx, struct couple_bodies *b)
{
    memset(b, 0, sizeof *b);
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/couple.h5", ctx->run_dir);
    SC_TRY(run_dir_check_input(ctx, STAGE, "impact", 1));
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    int64_t *run = NULL;
    int status;
    hid_t g = H5Gopen2(file, "seeds", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL_AT(status, done, SC_EIO, "%s has no /seeds group", path);
    SC_CHECK(status, h5_dataset_size(g, "d", &b->count), done);
    run = malloc(at_least_one(b->count) * sizeof *run);
    if (!run)
        SC_FAIL_OOM_AT(status, done, at_least_one(b->count) * sizeof *run, "the runs of couple.h5");
    SC_CHECK(status, read_body_columns(g, b, run), done);
    SC_CHECK(status, check_body_rows(b, run, path), done);
    SC_CHECK(status, index_runs(b, run, path), done);
done:
    free(run);
    if (g >= 0)
        H5Gclose(g);
    H5Fclose(file);
    if (status != SC_OK)
        couple_stage_bodies_free(b);
    return status;
}

/* [couple] reference_diameter: [impact] describes a particle of that diameter, and the run of a particle of
 * diameter d is [impact] scaled by d / reference_diameter, its point spacing too, so that every particle is
 * reference_diameter / spacing spacings across whatever its size, the smallest ([powder] d_min) included.  Below two
 * spacings it may hold no material point, the rule of [vcrit] diameters: the impact stage found that out only after
 * the spray and the couple stage had run (a review: reference_diameter = 1e-9 m, "body 1 holds no material point at
 * spacing 0.0104699 m"). */
static int check_reference_diameter(const struct case_file *c, const struct couple_config *cfg)
{
    double reference = cfg->reference_diameter, spacing = case_real(c, "impact", "spacing");
    if (!(reference > 0) || reference >= 2.0 * spacing)
        return SC_OK;
    int mono = case_is(c, "powder", "distribution", "mono");
    double smallest = case_real(c, "powder", mono ? "median_diameter" : "d_min");
    char example[256] = "";
    if (smallest > 0)
        snprintf(example, sizeof example, ": the smallest particle ([powder] %s = %g m) is seeded at spacing %g m",
                 mono ? "median_diameter" : "d_min", smallest, spacing * smallest / reference);
    return case_invalid(c, "couple", "reference_diameter",
                        "%g m is less than two point spacings ([impact] spacing = %g m): each run is [impact] scaled "
                        "by d / reference_diameter, and a particle of any diameter d is %.3g spacings across%s, too "
                        "few to hold material points; allowed: 0, or at least %g m (two [impact] spacings)",
                        reference, spacing, reference / spacing, example, 2.0 * spacing);
}

/* Every seed is a particle of the spray, one each: runs * bodies_per_run cannot exceed the particles the spray injects
 * at most ([spray] max_injected, or the rows of the particles file).  How many of them reach the target is known from
 * spray.h5 only (couple_stage_check_inputs); this much from the case, at check time (a review: runs = 100000 over a
 * spray of 2000 was refused only by the stage, after case.ini and the record of the stages had been replaced). */
static int check_seeds_injectable(const struct case_file *c, const struct couple_config *cfg,
                                  const struct dem_config *spray)
{
    int from_file = spray->injection == DEM_INJECT_FILE;
    double seeds = (double)cfg->runs * (double)cfg->bodies_per_run;
    double most = from_file ? (double)spray->file_particle_count : (double)spray->max_injected;
    if (seeds <= most)
        return SC_OK;
    char source[4608];
    if (from_file)
        snprintf(source, sizeof source, "the %.0f particles of %s ([spray] particles)", most, spray->particles_path);
    else
        snprintf(source, sizeof source, "at most %.0f particles ([spray] max_injected)", most);
    return case_invalid(c, "couple", case_is_given(c, "couple", "runs") ? "runs" : "bodies_per_run",
                        "%ld runs of %ld bodies need %.0f spray impacts, one particle each, and the spray injects %s; "
                        "allowed: runs * bodies_per_run <= %.0f",
                        cfg->runs, cfg->bodies_per_run, seeds, source, most);
}

int couple_stage_validate(const struct stage_context *ctx)
{
    const struct case_file *c = ctx->c;
    struct couple_config cfg;
    SC_TRY(couple_config_load(c, &cfg));
    SC_TRY(check_reference_diameter(c, &cfg));
    struct dem_config spray;
    SC_TRY(dem_config_load(c, &spray));
    int status = SC_OK;
    if (spray.handoff_height <= 0.0)
        status = case_invalid(c, "spray", "handoff_height",
                              "the couple stage starts its flights at the hand-off "
                              "plane; allowed: handoff_height > 0");
    if (status == SC_OK)
        status = check_seeds_injectable(c, &cfg, &spray);
    dem_config_free(&spray);
    return status;
}

/* spray.h5 to the seeds: every refusal that needs the spray's results (too few particles reached the target, in the
 * window, or reach the wall with a hand-off crossing) is made here. */
static int seed(struct couple_work *w)
{
    struct dem_config spray;
    SC_TRY(dem_config_load(w->c, &spray));
    int status = setup_layer(w, &spray);
    w->spray_dt = spray.dt;
    dem_config_free(&spray);
    SC_TRY(status);
    SC_TRY(read_spray(w));
    SC_TRY(find_candidates(w));
    SC_TRY(match_handoffs(w));
    return make_seeds(w);
}

int couple_stage_check_inputs(const struct stage_context *ctx)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/couple.h5", ctx->run_dir);
    if (run_dir_output_current(path, stage_hash(ctx, STAGE)))
        return SC_OK; /* the stage will not run */
    struct couple_work w = {.ctx = ctx, .c = ctx->c, .run_dir = ctx->run_dir};
    SC_TRY(couple_config_load(ctx->c, &w.cfg));
    /* the stage seeds again when it runs: its flights are flown twice (CVODE, 1500 in 0.3 s), which carrying the
     * seeds from main's check over to the stage would save at the price of state kept between the two */
    enum log_level level = log_get_level(); /* the stage tells what it does when it runs */
    log_set_level(LOG_QUIET);
    int status = seed(&w);
    log_set_level(level);
    couple_work_free(&w);
    return status;
}

static int couple(struct couple_work *w)
{
    SC_TRY(seed(w));
    SC_TRY(flight_agreement(w, &w->agreement));
    SC_TRY(write_output(w));
    log_summary(w);
    log_agreement(w);
    return SC_OK;
}

int couple_stage_run(const struct stage_context *ctx)
{
    struct couple_work w = {.ctx = ctx, .c = ctx->c, .run_dir = ctx->run_dir, .hash = stage_hash(ctx, STAGE)};
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/couple.h5", ctx->run_dir);
    struct run_settings settings;
    if (stage_begin(STAGE, path, w.hash, ctx->c, &settings))
        return SC_OK;
    SC_TRY(couple_config_load(ctx->c, &w.cfg));
    int status = couple(&w);
    couple_work_free(&w);
    return status;
}
