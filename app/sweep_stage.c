/* `spraycoat sweep` ([sweep]): the spray stage over a grid of two case keys, e.g. the jet's C1 against the release
 * speed, and the map of the deposition efficiency (DE by mass, dem/efficiency.c) and the mean impact speed over it
 * (RUN_DIR/sweep.h5; the figure is the render stage's).  Each combination is a spray run of its own in
 * RUN_DIR/runs/xI_yJ, made and resumed as `spraycoat spray` makes them: a finished run is not run again, an
 * interrupted one resumes from its checkpoint.  Under MPI the runs are shared among the ranks like the impact runs
 * of a pipeline (core/parallel.h); rank 0 gathers the map. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/memory.h"
#include "core/parallel.h"
#include "app/app.h"
#include "dem/dem.h"

#define STAGE                "sweep"
#define SWEEP_FORMAT         "spraycoat-sweep"
#define SWEEP_FORMAT_VERSION 1
#define SWEEP_MAX_VALUES     32
/* each run holds its directory's lock (an open descriptor) until the process ends: a bound under the usual 1024 */
#define SWEEP_MAX_RUNS 256

const struct cfg_key sweep_case_keys[] = {
    {"sweep", "x_key", CFG_STRING, "", NULL, 0, 0, 0, NULL,
     "the first case key to vary, as SECTION.KEY (e.g. jet.C1): a key of the spray stage's sections that changes "
     "results"},
    {"sweep", "x_values", CFG_STRING, "", NULL, 0, 0, 0, NULL,
     "its values, comma-separated, each written as in the case file (a unit may follow: 300 m/s) and checked "
     "like it; absolute file names for a file key"},
    {"sweep", "y_key", CFG_STRING, "", NULL, 0, 0, 0, NULL, "the second case key to vary (none: a single row)"},
    {"sweep", "y_values", CFG_STRING, "", NULL, 0, 0, 0, NULL, "its values, comma-separated, as x_values"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

struct sweep_axis {
    char section[64], key[64]; /* section "" : no key (one value) */
    int count;
    char values[SWEEP_MAX_VALUES][512]; /* long enough for absolute file names */
    double numbers[SWEEP_MAX_VALUES];   /* the values in SI (NAN for a word) */
    const char *unit;
    int file; /* the key names a file (CFG_PATH): its values are absolute paths, their contents hashed */
};

struct sweep {
    const struct case_file *c;
    const struct stage_context *ctx;
    const char *run_dir;
    struct sweep_axis x, y;
    uint64_t hash; /* the map's: the case and the contents of the files it names, when the sweep began */
};

/* ---- the keys of [sweep] ---- */

static const struct cfg_key *registered_key(const char *section, const char *key)
{
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++)
            if (strcmp(k->section, section) == 0 && strcmp(k->key, key) == 0)
                return k;
    return NULL;
}

/* SECTION.KEY of [sweep] name: a registered key of the spray stage that changes its results. */
static int parse_key(const struct case_file *c, const char *name, struct sweep_axis *axis)
{
    const char *text = case_text(c, "sweep", name);
    const char *dot = strchr(text, '.');
    if (!dot || dot == text || !dot[1] || (size_t)(dot - text) >= sizeof axis->section ||
        strlen(dot + 1) >= sizeof axis->key)
        return case_invalid(c, "sweep", name, "not SECTION.KEY; allowed: a case key such as jet.C1");
    snprintf(axis->section, sizeof axis->section, "%.*s", (int)(dot - text), text);
    snprintf(axis->key, sizeof axis->key, "%s", dot + 1);
    const struct cfg_key *k = registered_key(axis->section, axis->key);
    if (!k)
        return case_invalid(c, "sweep", name, "[%s] %s is not a case key (spraycoat keys lists them)", axis->section,
                            axis->key);
    if (!stage_has_section("spray", axis->section) || (k->flags & CFG_NOT_HASHED))
        return case_invalid(c, "sweep", name,
                            "[%s] %s does not change the spray's results; allowed: a key of the spray stage's "
                            "sections (docs/architecture.md) that does",
                            axis->section, axis->key);
    /* with [nozzle] each particle leaves at the nozzle's exit speed of its diameter: the release speeds do nothing */
    if (app_case_section_given(c, "nozzle") && strcmp(axis->section, "spray") == 0 &&
        (strcmp(axis->key, "release_speed_min") == 0 || strcmp(axis->key, "release_speed_max") == 0))
        return case_invalid(c, "sweep", name,
                            "[spray] %s does not change the spray's results with [nozzle] (each particle leaves at "
                            "the nozzle's exit speed of its diameter); allowed: a key that does, e.g. "
                            "nozzle.stagnation_pressure",
                            axis->key);
    axis->unit = k->unit;
    axis->file = k->type == CFG_PATH;
    return SC_OK;
}

/* The comma-separated values of [sweep] name, as text (each checked when set on a run's case). */
static int parse_values(const struct case_file *c, const char *name, struct sweep_axis *axis)
{
    const char *text = case_text(c, "sweep", name);
    axis->count = 0;
    for (const char *p = text; *p;) {
        size_t length = strcspn(p, ",");
        const char *start = p, *end = p + length;
        while (start < end && (*start == ' ' || *start == '\t'))
            start++;
        while (end > start && (end[-1] == ' ' || end[-1] == '\t'))
            end--;
        if (end == start)
            return case_invalid(c, "sweep", name, "an empty value; allowed: comma-separated values");
        if (axis->count == SWEEP_MAX_VALUES || (size_t)(end - start) >= sizeof axis->values[0])
            return case_invalid(c, "sweep", name, "more than %d values, or one longer than %zu characters",
                                SWEEP_MAX_VALUES, sizeof axis->values[0] - 1);
        snprintf(axis->values[axis->count++], sizeof axis->values[0], "%.*s", (int)(end - start), start);
        p += length + (p[length] == ',');
    }
    if (axis->count == 0)
        return case_invalid(c, "sweep", name, "no value given");
    /* RUN_DIR/case.ini keeps [sweep] as written, and a resumed sweep reads it from there: a relative file name
     * would then be looked for in RUN_DIR */
    for (int k = 0; axis->file && k < axis->count; k++)
        if (axis->values[k][0] != '/')
            return case_invalid(c, "sweep", name,
                                "'%s' is a relative file name of [%s] %s; allowed: absolute paths (a resumed sweep "
                                "reads its values from RUN_DIR/case.ini, in another folder)",
                                axis->values[k], axis->section, axis->key);
    return SC_OK;
}

static int load_axis(const struct case_file *c, const char *key_name, const char *values_name, struct sweep_axis *axis)
{
    memset(axis, 0, sizeof *axis);
    if (!case_has(c, "sweep", key_name)) {
        if (case_has(c, "sweep", values_name))
            return case_require(c, "sweep", key_name, "[sweep] values are given");
        axis->count = 1; /* no key: one run along this axis */
        axis->numbers[0] = NAN;
        return SC_OK;
    }
    SC_TRY(parse_key(c, key_name, axis));
    if (!case_has(c, "sweep", values_name))
        return case_require(c, "sweep", values_name, "[sweep] a key to vary is given");
    return parse_values(c, values_name, axis);
}

static int load_sweep(const struct stage_context *ctx, struct sweep *sw)
{
    memset(sw, 0, sizeof *sw);
    sw->c = ctx->c;
    sw->run_dir = ctx->run_dir;
    if (!case_has(ctx->c, "sweep", "x_key"))
        return case_require(ctx->c, "sweep", "x_key", "spraycoat sweep");
    SC_TRY(load_axis(ctx->c, "x_key", "x_values", &sw->x));
    SC_TRY(load_axis(ctx->c, "y_key", "y_values", &sw->y));
    if (sw->y.section[0] && strcmp(sw->x.section, sw->y.section) == 0 && strcmp(sw->x.key, sw->y.key) == 0)
        return case_invalid(ctx->c, "sweep", "y_key", "the same key as x_key");
    if (sw->x.count * sw->y.count > SWEEP_MAX_RUNS)
        return case_invalid(ctx->c, "sweep", "x_values", "%d x %d runs; allowed: at most %d", sw->x.count, sw->y.count,
                            SWEEP_MAX_RUNS);
    return SC_OK;
}

/* ---- one run of the grid ---- */

static void run_name(int i, int j, char *out, size_t size)
{
    snprintf(out, size, "runs/x%d_y%d", i, j);
}

/* "[jet] C1 = 300, [spray] release_speed_max = 700" */
static void describe_run(const struct sweep *sw, int i, int j, char *out, size_t size)
{
    int used = snprintf(out, size, "[%s] %s = %s", sw->x.section, sw->x.key, sw->x.values[i]);
    if (sw->y.section[0] && used > 0 && (size_t)used < size)
        snprintf(out + used, size - (size_t)used, ", [%s] %s = %s", sw->y.section, sw->y.key, sw->y.values[j]);
}

/* One value on a run's case, validated exactly like a value of the file; the origin names the [sweep] key. */
static int set_value(struct case_file *run, const struct sweep_axis *axis, int index, const char *values_name)
{
    if (!axis->section[0])
        return SC_OK;
    char origin[4200]; /* FILE:LINE, so that a bad value's message names where it was written */
    snprintf(origin, sizeof origin, "%s:%d: [sweep] %s value %d", case_file_path(run),
             case_line(run, "sweep", values_name), values_name, index + 1);
    return case_set(run, axis->section, axis->key, axis->values[index], origin);
}

/* The case of run (i, j): the sweep's case with the two values set.  A copy of the case in memory, never the file
 * read again: that may have been edited since the sweep began (runs of two cases under one hash) and lacks the
 * command line's overrides (--threads, --device). */
static int run_case(const struct sweep *sw, int i, int j, struct case_file **out)
{
    struct case_file *run = case_clone(sw->c);
    int status = set_value(run, &sw->x, i, "x_values");
    if (status == SC_OK)
        status = set_value(run, &sw->y, j, "y_values");
    if (status != SC_OK) {
        case_free(run);
        SC_TRY(status);
    }
    *out = run;
    return SC_OK;
}

/* ---- the sweep's hash ---- */

/* With a file key on an axis ([deposition] table, [path] waypoints) the [sweep] text names the files but the case
 * hash holds only the base case's files: the map stayed up to date after a swept file changed.  The hash then takes
 * in every run's spray hash, which holds the contents of the files its values name.  `base` is the hash of the case
 * and [sweep]; it stands alone when no axis is a file or the axes cannot be read (the stage refuses them). */
uint64_t sweep_stage_hash(const struct case_file *c, uint64_t base)
{
    struct stage_context ctx = {.c = c};
    struct sweep sw;
    if (load_sweep(&ctx, &sw) != SC_OK) {
        sc_error_clear();
        return base;
    }
    if (!sw.x.file && !sw.y.file)
        return base;
    uint64_t hash = base;
    for (int j = 0; j < sw.y.count; j++)
        for (int i = 0; i < sw.x.count; i++) {
            struct case_file *run;
            if (run_case(&sw, i, j, &run) != SC_OK) {
                sc_error_clear();
                continue;
            }
            const struct stage_context run_ctx = {.c = run};
            hash = hash * 1099511628211ULL ^ stage_hash(&run_ctx, "spray");
            case_free(run);
        }
    return hash;
}

/* The values in SI where the key is a number (the run's case converts them: "300 mm" is 0.3); NaN for a word,
 * whichever words the key has (restitution's is johnson, not auto: asking case_is for "auto" aborted). */
static void axis_numbers(struct sweep_axis *axis, const struct case_file *run, int index)
{
    const struct cfg_key *k = axis->section[0] ? registered_key(axis->section, axis->key) : NULL;
    if (!k || !(k->type == CFG_REAL || k->type == CFG_INT) || case_is_word(run, axis->section, axis->key))
        axis->numbers[index] = NAN;
    else
        axis->numbers[index] = k->type == CFG_INT ? (double)case_int(run, axis->section, axis->key)
                                                  : case_real(run, axis->section, axis->key);
}

static int validate_run(const struct sweep *sw, int i, int j)
{
    struct case_file *run;
    SC_TRY(run_case(sw, i, j, &run));
    char dir[4200], name[64];
    run_name(i, j, name, sizeof name);
    snprintf(dir, sizeof dir, "%s/%s", sw->run_dir ? sw->run_dir : ".", name);
    /* with the run directory: its checkpoints (if any) must be this run's case */
    const struct stage_context ctx = {.c = run, .run_dir = sw->run_dir ? dir : NULL};
    int status = spray_stage_validate(&ctx);
    case_free(run);
    if (status == SC_OK)
        return SC_OK;
    /* a check across keys names the key it found wrong, where the file has it: say which run's values made it so
     * (a reviewer's target.standoff = 0.001 was reported as [spray] handoff_height alone) */
    char message[2048], values[1100];
    snprintf(message, sizeof message, "%s", sc_error_message());
    sc_error_clear();
    values[0] = '\0';
    const struct sweep_axis *axes[2] = {&sw->x, &sw->y};
    const int at[2] = {i, j};
    for (int a = 0; a < 2; a++)
        if (axes[a]->section[0])
            snprintf(values + strlen(values), sizeof values - strlen(values), "%s[%s] %s = %s", values[0] ? ", " : "",
                     axes[a]->section, axes[a]->key, axes[a]->values[at[a]]);
    SC_FAIL(status, "%s (sweep run %s: %s)", message, name, values);
}

/* The axes' values in SI, from the cases of the runs of the first row and column. */
static int fill_numbers(struct sweep *sw)
{
    for (int i = 0; i < sw->x.count; i++) {
        struct case_file *run;
        SC_TRY(run_case(sw, i, 0, &run));
        axis_numbers(&sw->x, run, i);
        case_free(run);
    }
    for (int j = 0; j < sw->y.count; j++) {
        struct case_file *run;
        SC_TRY(run_case(sw, 0, j, &run));
        axis_numbers(&sw->y, run, j);
        case_free(run);
    }
    return SC_OK;
}

/* SC_EINPUT when a file the case names (its contents are part of the hash: a table, waypoints) changed since the
 * sweep began.  The runs copy the case in memory, not the files: each run's hash would then hold the contents it
 * read, and the map, under the first contents' hash, runs of two cases (found up to date once the file is back). */
static int files_unchanged(const struct sweep *sw)
{
    if (stage_hash(sw->ctx, STAGE) == sw->hash)
        return SC_OK;
    SC_FAIL(SC_EINPUT,
            "sweep: a file the case names (a [deposition] table, the [path] waypoints, ...) changed while the sweep "
            "ran: its runs before and after would be of two cases in one map; the runs done are kept, each with its "
            "own case; run the sweep again to finish it with the files as they are now");
}

/* Run (or resume, or skip when done) the spray of run t = j nx + i in RUN_DIR/runs/xI_yJ. */
static int spray_run(const struct sweep *sw, int64_t t)
{
    SC_TRY(files_unchanged(sw));
    int i = (int)(t % sw->x.count), j = (int)(t / sw->x.count);
    char dir[4200], name[64];
    run_name(i, j, name, sizeof name);
    snprintf(dir, sizeof dir, "%s/%s", sw->run_dir, name);
    struct case_file *run;
    SC_TRY(run_case(sw, i, j, &run));
    char where[256];
    describe_run(sw, i, j, where, sizeof where);
    log_info("sweep: run %lld of %d, %s: %s", (long long)t + 1, sw->x.count * sw->y.count, name, where);
    /* interrupted, the run names the sweep's directory: resuming that finishes every run and the map */
    const struct stage_context ctx = {.c = run, .run_dir = dir, .resume_dir = sw->run_dir};
    int status;
    SC_CHECK(status, run_dir_prepare(dir, run), done);
    SC_CHECK(status, run_dir_write_stages(dir, "spray"), done);
    SC_CHECK(status, spray_stage_validate(&ctx), done);
    SC_CHECK(status, spray_stage_run(&ctx), done);
done:
    case_free(run);
    return status;
}

/* ---- the map ---- */

struct sweep_map {
    const struct sweep *sw;
    double *de, *speed, *normal_speed, *deposit_fraction; /* ny x nx, row j = y value j */
    double *in_flight; /* the share of the particles sprayed still in flight at the run's end (by number) */
};

/* The last value of the time series `name` of spray.h5 (NaN when it is empty). */
static int last_of_series(hid_t file, const char *name, double *value)
{
    size_t n = 0;
    *value = NAN;
    SC_TRY(h5_dataset_size(file, name, &n));
    if (n == 0)
        return SC_OK;
    double *column;
    SC_TRY(sc_calloc(&column, n, sizeof *column, "a time series of spray.h5"));
    int status = h5_read_doubles(file, name, column, n);
    *value = column[n - 1];
    free(column);
    return status;
}

/* The run's particles still in flight at its end (the last of /metrics/in_flight, a count) over those sprayed: its
 * DE counts them as not deposited, a lower bound once they are many (DEM_DE_LOWER_BOUND_IN_FLIGHT; a review: the
 * map did not say so). */
static int in_flight_share(hid_t file, double *share)
{
    size_t n = 0;
    int64_t sprayed = 0, *in_flight;
    SC_TRY(h5_dataset_size(file, "metrics/in_flight", &n));
    if (n == 0)
        SC_FAIL(SC_EIO, "spray.h5's /metrics/in_flight is empty");
    SC_TRY(sc_calloc(&in_flight, n, sizeof *in_flight, "the counts in flight of spray.h5"));
    int status = h5_read_int64s(file, "metrics/in_flight", in_flight, n);
    double last = (double)in_flight[n - 1];
    free(in_flight);
    SC_TRY(status);
    hid_t group = H5Gopen2(file, "deposition_efficiency", H5P_DEFAULT);
    if (group < 0)
        SC_FAIL(SC_EIO, "spray.h5 has no /deposition_efficiency");
    status = h5_attr_read_int64(group, "sprayed_count", &sprayed);
    H5Gclose(group);
    SC_TRY(status);
    *share = sprayed > 0 ? last / (double)sprayed : 0.0;
    return SC_OK;
}

static int read_run(const struct sweep *sw, int i, int j, struct sweep_map *map)
{
    char path[4300], name[64];
    run_name(i, j, name, sizeof name);
    snprintf(path, sizeof path, "%s/%s/spray.h5", sw->run_dir, name);
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    size_t k = (size_t)j * (size_t)sw->x.count + (size_t)i;
    int status;
    SC_CHECK(status, h5_read_doubles(file, "deposition_efficiency/de", &map->de[k], 1), done);
    SC_CHECK(status, h5_read_doubles(file, "deposition_efficiency/mean_impact_speed", &map->speed[k], 1), done);
    SC_CHECK(status, h5_read_doubles(file, "deposition_efficiency/mean_impact_normal_speed", &map->normal_speed[k], 1),
             done);
    SC_CHECK(status, last_of_series(file, "metrics/deposit_fraction", &map->deposit_fraction[k]), done);
    SC_CHECK(status, in_flight_share(file, &map->in_flight[k]), done);
done:
    H5Fclose(file);
    return status;
}

static int write_axis(hid_t file, const char *prefix, const struct sweep_axis *axis)
{
    /* every value whole: each up to sizeof values[0] - 1 characters and a comma (a smaller buffer let the running
     * offset pass its end: a review) */
    char name[32], key[160], labels[SWEEP_MAX_VALUES * sizeof axis->values[0]] = "";
    hsize_t dims[1] = {(hsize_t)axis->count};
    snprintf(name, sizeof name, "%s_values", prefix);
    SC_TRY(h5_write_doubles(file, name, 1, dims, axis->numbers, axis->unit ? axis->unit : "", 0));
    size_t used = 0;
    for (int k = 0; k < axis->count; k++)
        used += (size_t)snprintf(labels + used, sizeof labels - used, "%s%s", k ? "," : "", axis->values[k]);
    snprintf(name, sizeof name, "%s_labels", prefix);
    SC_TRY(h5_attr_write_string(file, name, labels));
    snprintf(key, sizeof key, "%s%s%s", axis->section, axis->section[0] ? "." : "", axis->key);
    snprintf(name, sizeof name, "%s_key", prefix);
    SC_TRY(h5_attr_write_string(file, name, key));
    return SC_OK;
}

static int map_contents(void *owner, hid_t file)
{
    const struct sweep_map *map = owner;
    const struct sweep *sw = map->sw;
    hsize_t dims[2] = {(hsize_t)sw->y.count, (hsize_t)sw->x.count};
    SC_TRY(write_axis(file, "x", &sw->x));
    SC_TRY(write_axis(file, "y", &sw->y));
    SC_TRY(h5_write_doubles(file, "de", 2, dims, map->de, "-", 0));
    SC_TRY(h5_write_doubles(file, "mean_impact_speed", 2, dims, map->speed, "m/s", 0));
    SC_TRY(h5_write_doubles(file, "mean_impact_normal_speed", 2, dims, map->normal_speed, "m/s", 0));
    SC_TRY(h5_write_doubles(file, "deposit_fraction", 2, dims, map->deposit_fraction, "-", 0));
    SC_TRY(h5_write_doubles(file, "in_flight_share", 2, dims, map->in_flight, "-", 0));
    SC_TRY(h5_attr_write_double(file, "de_lower_bound_share", DEM_DE_LOWER_BOUND_IN_FLIGHT));
    return SC_OK;
}

static void log_map(const struct sweep *sw, const struct sweep_map *map)
{
    int lower_bounds = 0;
    for (int j = 0; j < sw->y.count; j++)
        for (int i = 0; i < sw->x.count; i++) {
            char where[256], bound[160] = "";
            describe_run(sw, i, j, where, sizeof where);
            size_t k = (size_t)j * (size_t)sw->x.count + (size_t)i;
            if (map->in_flight[k] > DEM_DE_LOWER_BOUND_IN_FLIGHT) {
                snprintf(bound, sizeof bound, " (a lower bound: %.1f %% of the particles still in flight at t_end)",
                         100.0 * map->in_flight[k]);
                lower_bounds++;
            }
            log_info("sweep: %s: DE %.4f%s, mean impact speed %.4g m/s", where, map->de[k], bound, map->speed[k]);
        }
    if (lower_bounds > 0)
        log_warn("sweep: the DE of %d of the %d runs is a lower bound: over %g %% of their particles were still in "
                 "flight at t_end (counted as not deposited); a longer [spray] t_end lets them land",
                 lower_bounds, sw->x.count * sw->y.count, 100.0 * DEM_DE_LOWER_BOUND_IN_FLIGHT);
}

static int write_map(struct sweep *sw, uint64_t hash)
{
    SC_TRY(files_unchanged(sw));
    SC_TRY(fill_numbers(sw));
    size_t n = (size_t)sw->x.count * (size_t)sw->y.count;
    struct sweep_map map = {.sw = sw};
    map.de = calloc(5 * n, sizeof *map.de);
    if (!map.de)
        SC_FAIL_OOM(5 * n * sizeof *map.de, "the sweep's map");
    map.speed = map.de + n, map.normal_speed = map.de + 2 * n, map.deposit_fraction = map.de + 3 * n;
    map.in_flight = map.de + 4 * n;
    int status = SC_OK;
    for (int j = 0; j < sw->y.count; j++)
        for (int i = 0; i < sw->x.count; i++)
            SC_CHECK(status, read_run(sw, i, j, &map), done);
    char path[4200];
    snprintf(path, sizeof path, "%s/sweep.h5", sw->run_dir);
    SC_CHECK(status,
             stage_write_output(path, SWEEP_FORMAT, SWEEP_FORMAT_VERSION, STAGE, hash, sw->c, map_contents, &map),
             done);
    log_info("sweep: wrote %s (%d x %d runs)", path, sw->x.count, sw->y.count);
    log_map(sw, &map);
done:
    free(map.de);
    return status;
}

int sweep_stage_validate(const struct stage_context *ctx)
{
    struct sweep sw;
    SC_TRY(load_sweep(ctx, &sw));
    for (int j = 0; j < sw.y.count; j++)
        for (int i = 0; i < sw.x.count; i++)
            SC_TRY(validate_run(&sw, i, j));
    return SC_OK;
}

int sweep_stage_run(const struct stage_context *ctx)
{
    struct sweep sw;
    SC_TRY(load_sweep(ctx, &sw));
    uint64_t hash = stage_hash(ctx, STAGE);
    sw.ctx = ctx, sw.hash = hash;
    char path[4200];
    snprintf(path, sizeof path, "%s/sweep.h5", ctx->run_dir);
    struct run_settings settings;
    int up_to_date = parallel_rank() == 0 ? stage_begin(STAGE, path, hash, ctx->c, &settings) : 0;
    /* every rank learns rank 0's finding (as a status: the one value parallel.h shares) */
    if (parallel_share_status(up_to_date ? SC_EIO : SC_OK) != SC_OK)
        return SC_OK;
    int64_t runs = (int64_t)sw.x.count * sw.y.count;
    if (parallel_rank() == 0)
        log_info("sweep: %lld spray runs in %s/runs over %d process%s", (long long)runs, ctx->run_dir, parallel_size(),
                 parallel_size() > 1 ? "es" : "");
    int status = SC_OK;
    /* every rank takes part in the task counter even after a failure (no early return) */
    parallel_tasks_begin();
    for (int64_t t; status == SC_OK && (t = parallel_task_next()) < runs;)
        if ((status = spray_run(&sw, t)) != SC_OK)
            sc_error_trace(__FILE__, __LINE__);
    parallel_tasks_end();
    status = parallel_max_status(status);
    if (status == SC_OK && parallel_rank() == 0)
        status = write_map(&sw, hash);
    return status;
}
