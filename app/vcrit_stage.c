/* `spraycoat vcrit`: the critical impact velocity v_crit(d), or v_crit(d, T) over the particle temperatures of
 * [vcrit] temperatures, from single-particle MPM impacts (Tang Section 5.2.2), for the spray stage's
 * `[deposition] rule = table`.
 *
 * Per diameter (per pair of diameter and temperature): one run at v_low (must rebound) and one at v_high (must bond),
 * then bisection of the bracket until it is at most `tolerance` wide; v_crit is the upper end, the lowest speed known
 * to bond.  With `method = logistic` the bisection only finds the transition: sweep_count runs on each side of its
 * v_crit, sweep_step apart, follow, and v_crit is the speed of 50 % success of a first-order logistic fit (Tang
 * Eq. 4.12 in one variable, core/logistic.h) to every settled run of the search, an estimate that does not assume
 * the outcome monotone in the speed, which near v_crit it is not (docs/validation.md).  Each run goes to [impact] t_end
 * (or until its verdict settled) and is judged by mpm_verdicts (PBCP and restitution velocity thresholds of [impact]);
 * an unsettled run counts as not bonded (note_unsettled); a run that fails as a simulation (NaN or blow-up) is
 * recorded as failed and ends its own search without a v_crit, the other searches going on (note_failed). Every
 * finished run is recorded in RUN_DIR/vcrit_runs.csv
 * (rewritten atomically, kept with the outputs); a restarted search reuses the recorded runs of the same impact set-up
 * (runs_hash) instead of running them again, so an interruption loses at most the run that was going on, and a search
 * extended to more diameters or a finer tolerance runs only what is new.  The outputs are RUN_DIR/vcrit.csv,
 * vcrit_cor.csv and vcrit.h5.
 *
 * Under MPI the searches are shared out (a rank takes the next one not yet taken, core/parallel.h) and rank
 * k > 0 records its runs in RUN_DIR/vcrit_runs_rankK.csv.  When all are done, rank 0 reads every record and
 * replays each bisection from them (no run is repeated): the outputs are those of one process, whatever the
 * number of ranks, also after a resume with another number of ranks. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/atomic.h"
#include "core/error.h"
#include "core/units.h"
#include "core/interrupt.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/logistic.h"
#include "core/parallel.h"
#include "core/run_keys.h"
#include "core/version.h"
#include "app/app.h"
#include "mpm/mpm.h"

#define STAGE                "vcrit"
#define VCRIT_FORMAT         "spraycoat-vcrit"
#define VCRIT_FORMAT_VERSION 1
#define MAX_DIAMETERS        256
#define MAX_COR_OFFSETS      32
#define MAX_TEMPERATURES     64

const struct cfg_key vcrit_case_keys[] = {
    {"vcrit", "diameters", CFG_STRING, "m", "14e-6,30e-6", 0, 0, 0, NULL,
     "comma-separated particle diameters at which v_crit is searched (each > 0 and <= 1 m, all different; a unit may "
     "follow each: 10 um)"},
    {"vcrit", "v_low", CFG_REAL, "m/s", "500", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL,
     "lower end of the search: a particle at this speed must rebound"},
    {"vcrit", "v_high", CFG_REAL, "m/s", "1200", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL,
     "upper end of the search: a particle at this speed must bond"},
    {"vcrit", "tolerance", CFG_REAL, "m/s", "10", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL,
     "bisection stops when the bracket [rebounds, bonds] is at most this wide"},
    {"vcrit", "max_runs", CFG_INT, "-", "20", 2, 1000, 0, NULL, "most MPM runs per diameter (the two ends included)"},
    {"vcrit", "outcome", CFG_CHOICE, "", "bonded", 0, 0, 0, "bonded|adhered",
     "v_crit is the lowest speed of this outcome; " VCRIT_OUTCOME_DOC},
    {"vcrit", "substrate_scale", CFG_REAL, "-", "0", 0, 1000, 0, NULL,
     "0: the substrate of [impact]; > 0: substrate diameter = this times the particle diameter (Tang Table 5.3: "
     "about 2)"},
    {"vcrit", "reference_diameter", CFG_REAL, "m", "0", 0, 1, 0, NULL,
     "0: every run on the grid of [impact]; > 0: [impact] describes a particle of this diameter, and a run of diameter "
     "d has its grid, spacing, substrate, box_margin and times scaled by d / reference_diameter (the same cells per "
     "diameter for every size, docs/physics.md \"Resolution in cells per diameter\")"},
    {"vcrit", "cor_below", CFG_STRING, "m/s", NULL, 0, 0, 0, NULL,
     "comma-separated speed differences (each > 0): after the bisection, one more run per diameter at v_crit minus "
     "each, for the coefficient of restitution against impact speed (RUN_DIR/vcrit_cor.csv); not given: none"},
    {"vcrit", "method", CFG_CHOICE, "", "bisection", 0, 0, 0, "bisection|logistic",
     "bisection: v_crit is the lowest speed seen to succeed at the end of the bisection; logistic: after the "
     "bisection, sweep_count more runs on each side of its v_crit, sweep_step apart, and v_crit is the speed of 50 % "
     "success of a first-order logistic fit (Tang Eq. 4.12 in the speed) to every settled run of the search: robust "
     "where the outcome is not monotone in the speed (docs/physics.md \"v_crit by logistic regression\")"},
    {"vcrit", "sweep_step", CFG_REAL, "m/s", "10", 0, 1e4, CFG_MIN_EXCLUSIVE, NULL,
     "method = logistic: the spacing of the sweep's speeds around the bisection's v_crit"},
    {"vcrit", "sweep_count", CFG_INT, "-", "4", 1, 100, 0, NULL,
     "method = logistic: sweep runs on each side of the bisection's v_crit (at most 2 x this many runs more per "
     "diameter)"},
    {"vcrit", "temperatures", CFG_STRING, "K", NULL, 0, 0, 0, NULL,
     "comma-separated particle temperatures at impact (each > 0 and <= 1e5 K, all different; 25 degC too): one search "
     "per "
     "(diameter, temperature), the table v_crit(d, T); not given: the [impact] material's T_initial only, the "
     "table v_crit(d)"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

struct vcrit_result {
    double diameter, temperature, v_crit, pbcp, v_rest; /* temperature 0: the material's T_initial */
    double v_bisection;                                 /* the bisection's v_crit (= v_crit with method = bisection) */
    struct logistic_threshold fit;                      /* method = logistic: the fit (fit.x50 = v_crit) */
    int runs;
    struct vcrit_run_record *records; /* the runs of this diameter in the order of the search, then the CoR runs */
    char note[256];                   /* "" when bracketed and converged */
};

struct vcrit_search {
    const struct case_file *c;
    const char *run_dir;
    uint64_t case_hash;
    double diameters[MAX_DIAMETERS];
    int count;
    double v_low, v_high, tolerance, scale, angle;
    double reference;           /* [vcrit] reference_diameter: 0, or the diameter [impact]'s lengths are for */
    double vrest_threshold;     /* [impact] vrest_threshold: below it a rebounded particle is "held" */
    enum vcrit_outcome outcome; /* [vcrit] outcome: what v_crit is the threshold of */
    int max_runs;
    int logistic;                        /* [vcrit] method = logistic */
    double sweep_step;                   /* m/s */
    int sweep_count;                     /* sweep runs on each side of the bisection's v_crit */
    double cor_offsets[MAX_COR_OFFSETS]; /* extra runs at v_crit minus these, for CoR(v) */
    int cor_count;
    struct vcrit_runs runs; /* every finished run (also those of an earlier, interrupted process) */
    /* [vcrit] temperatures, ascending; without the key one entry 0: the particle at its material's T_initial */
    double temperatures[MAX_TEMPERATURES];
    int temperature_count;
    int over_temperature; /* 1 with [vcrit] temperatures: the outputs have a temperature column */
};

/* The searches are the pairs (diameter i, temperature j), pair i * temperature_count + j. */
static int pair_count(const struct vcrit_search *v)
{
    return v->count * v->temperature_count;
}

static void set_pair(const struct vcrit_search *v, int pair, struct vcrit_result *result)
{
    result->diameter = v->diameters[pair / v->temperature_count];
    result->temperature = v->temperatures[pair % v->temperature_count];
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int vcrit_runs_parse_list(const struct case_file *c, const char *section, const char *key, double max, const char *unit,
                          double *out, int capacity, int *count)
{
    char text[4096];
    if (snprintf(text, sizeof text, "%s", case_text(c, section, key)) >= (int)sizeof text)
        return case_invalid(c, section, key, "too long");
    *count = 0;
    /* every item between commas (strtok skipped empty ones: "14e-6,,22e-6" read as two diameters, a typo unseen) */
    for (char *token = text, *next; token; token = next) {
        next = strchr(token, ',');
        if (next)
            *next++ = '\0';
        while (*token == ' ' || *token == '\t')
            token++;
        if (*token == '\0' && (next || *count > 0 || token != text))
            return case_invalid(c, section, key,
                                "an empty item (two commas, or one at an end); allowed: comma-separated numbers");
        if (*token == '\0')
            break; /* an empty list: the caller says what is missing */
        char *end, why[256] = "";
        errno = 0;
        double x = strtod(token, &end);
        int read = end != token && errno != ERANGE && isfinite(x);
        while (*end == ' ' || *end == '\t')
            end++;
        for (char *last = end + strlen(end); last > end && (last[-1] == ' ' || last[-1] == '\t');)
            *--last = '\0';
        if (read && *end && units_to_si(x, end, unit, &x, why, sizeof why) != UNITS_OK)
            read = 0;
        if (!read || !(x > 0) || x > max)
            return case_invalid(c, section, key,
                                "'%s' is not allowed%s%s; allowed: comma-separated numbers, each > 0 and <= %g %s (a "
                                "unit may follow: 10 um)",
                                token, why[0] ? ": " : "", why, max, unit);
        if (*count == capacity)
            return case_invalid(c, section, key, "more than %d values", capacity);
        out[(*count)++] = x;
    }
    return SC_OK;
}

static int parse_diameters(const struct case_file *c, struct vcrit_search *v)
{
    SC_TRY(vcrit_runs_parse_list(c, "vcrit", "diameters", 1.0, "m", v->diameters, MAX_DIAMETERS, &v->count));
    if (v->count == 0)
        return case_invalid(c, "vcrit", "diameters", "no diameter given");
    qsort(v->diameters, (size_t)v->count, sizeof v->diameters[0], compare_doubles);
    for (int i = 1; i < v->count; i++)
        if (v->diameters[i] == v->diameters[i - 1])
            return case_invalid(c, "vcrit", "diameters", "%g m is given twice", v->diameters[i]);
    return SC_OK;
}

static int parse_temperatures(const struct case_file *c, struct vcrit_search *v)
{
    v->over_temperature = case_has(c, "vcrit", "temperatures");
    v->temperature_count = 1;
    v->temperatures[0] = 0.0;
    if (!v->over_temperature)
        return SC_OK;
    SC_TRY(vcrit_runs_parse_list(c, "vcrit", "temperatures", 1e5, "K", v->temperatures, MAX_TEMPERATURES,
                                 &v->temperature_count));
    if (v->temperature_count == 0)
        return case_invalid(c, "vcrit", "temperatures", "no temperature given");
    qsort(v->temperatures, (size_t)v->temperature_count, sizeof v->temperatures[0], compare_doubles);
    for (int i = 1; i < v->temperature_count; i++)
        if (v->temperatures[i] == v->temperatures[i - 1])
            return case_invalid(c, "vcrit", "temperatures", "%g K is given twice", v->temperatures[i]);
    return SC_OK;
}

/* The impact configuration of one run: [impact] with one sphere of diameter d at `speed`, at temperature T (K; 0:
 * its material's T_initial). */
static int make_config(const struct vcrit_search *v, double d, double T, double speed, struct mpm_config *cfg)
{
    SC_TRY(mpm_config_load(v->c, cfg));
    if (v->reference > 0)
        mpm_config_scale_lengths(cfg, d / v->reference);
    if (v->scale > 0)
        for (int b = 0; b < cfg->body_count; b++)
            if (cfg->bodies[b].substrate)
                cfg->bodies[b].d = v->scale * d;
    int status = mpm_config_single_particle(cfg, d, speed, v->angle);
    if (status == SC_OK && T > 0.0)
        status = mpm_config_set_particle_temperatures(cfg, 1, &T);
    if (status != SC_OK)
        mpm_config_free(cfg);
    return status;
}

static int load_settings(const struct case_file *c, struct vcrit_search *v)
{
    SC_TRY(parse_diameters(c, v));
    SC_TRY(parse_temperatures(c, v));
    v->cor_count = 0;
    if (case_has(c, "vcrit", "cor_below"))
        SC_TRY(
            vcrit_runs_parse_list(c, "vcrit", "cor_below", 1e5, "m/s", v->cor_offsets, MAX_COR_OFFSETS, &v->cor_count));
    v->v_low = case_real(c, "vcrit", "v_low");
    v->v_high = case_real(c, "vcrit", "v_high");
    v->tolerance = case_real(c, "vcrit", "tolerance");
    v->max_runs = (int)case_int(c, "vcrit", "max_runs");
    v->logistic = case_is(c, "vcrit", "method", "logistic");
    v->sweep_step = case_real(c, "vcrit", "sweep_step");
    v->sweep_count = (int)case_int(c, "vcrit", "sweep_count");
    v->outcome = vcrit_runs_outcome_of(c, "vcrit");
    v->scale = case_real(c, "vcrit", "substrate_scale");
    v->reference = case_real(c, "vcrit", "reference_diameter");
    v->angle = case_real(c, "impact", "angle") * M_PI / 180.0;
    if (!(v->v_low < v->v_high))
        return case_invalid(c, "vcrit", "v_low", "not below v_high = %g m/s", v->v_high);
    if (case_has(c, "impact", "bodies"))
        return case_invalid(c, "impact", "bodies",
                            "vcrit runs single particles ([impact] material, the diameters "
                            "of [vcrit]); remove bodies from the case");
    if (v->scale > 0 && case_is(c, "impact", "substrate", "rigid"))
        return case_invalid(c, "vcrit", "substrate_scale",
                            "scales a deformable substrate, but [impact] substrate = "
                            "rigid; allowed: 0 with a rigid substrate");
    /* every run's set-up must be possible before the first one starts */
    for (int i = 0; i < v->count; i++) {
        struct mpm_config cfg;
        SC_TRY(make_config(v, v->diameters[i], 0.0, v->v_high, &cfg));
        double spacing = cfg.spacing, substrate_d = INFINITY;
        v->vrest_threshold = cfg.vrest_threshold;
        for (int b = 0; b < cfg.body_count; b++)
            if (cfg.bodies[b].substrate)
                substrate_d = cfg.bodies[b].d;
        mpm_config_free(&cfg);
        if (v->diameters[i] < 2.0 * spacing)
            return case_invalid(c, "vcrit", "diameters",
                                "%g m is less than two point spacings ([impact] spacing = "
                                "%g m)",
                                v->diameters[i], spacing);
        /* a rigid substrate is no body (substrate_d stays infinite): there is no size to check */
        if (isfinite(substrate_d) && (substrate_d < 2.0 * spacing || substrate_d > 1.0))
            return case_invalid(c, "vcrit", "substrate_scale",
                                "gives a substrate of %g m for d = %g m; allowed: "
                                "two point spacings (%g m) to 1 m",
                                substrate_d, v->diameters[i], 2.0 * spacing);
    }
    /* the set-up is possible at diameter 0 (checked above): a failure now is the temperature's */
    for (int j = 0; j < v->temperature_count; j++) {
        struct mpm_config cfg;
        if (make_config(v, v->diameters[0], v->temperatures[j], v->v_high, &cfg) != SC_OK)
            return case_invalid(c, "vcrit", "temperatures", "%s", sc_error_message());
        mpm_config_free(&cfg);
    }
    return SC_OK;
}

/* The shortest of %.15g, %.16g, %.17g that reads back as the same double (8e-06 rather than
 * 7.9999999999999996e-06): exact, and readable. */
static const char *exact(double value, char *out, size_t size)
{
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(out, size, "%.*g", digits, value);
        if (strtod(out, NULL) == value || value != value)
            break;
    }
    return out;
}

/* ---- the record of finished runs: RUN_DIR/NAME_runs.csv (vcrit_runs.csv, calibrate_runs.csv) ------------------ */

const char *vcrit_verdict_name(int verdict)
{
    static const char *const names[] = {"rebounded", "bonded", "unsettled", "failed"};
    return verdict >= VCRIT_REBOUNDED && verdict <= VCRIT_FAILED ? names[verdict] : "unsettled";
}

/* The verdict of a finished run in words: "held" for a rebounded particle at rest on the substrate (v_rest below
 * the threshold) that too few bonds hold to count as bonded (mpm.h mpm_verdict_held). */
static const char *run_verdict_word(const struct vcrit_run_record *run, double vrest_threshold)
{
    if (run->verdict == VCRIT_REBOUNDED && mpm_verdict_held(MPM_VERDICT_REBOUNDED, run->v_rest, vrest_threshold))
        return "held";
    return vcrit_verdict_name(run->verdict);
}

enum vcrit_outcome vcrit_runs_outcome_of(const struct case_file *c, const char *section)
{
    return case_is(c, section, "outcome", "adhered") ? VCRIT_OUTCOME_ADHERED : VCRIT_OUTCOME_BONDED;
}

int vcrit_runs_succeeds(const struct vcrit_run_record *run, enum vcrit_outcome outcome, double vrest_threshold)
{
    if (run->verdict != VCRIT_BONDED && run->verdict != VCRIT_REBOUNDED)
        return -1;
    if (run->verdict == VCRIT_BONDED)
        return 1;
    return outcome == VCRIT_OUTCOME_ADHERED && mpm_verdict_held(MPM_VERDICT_REBOUNDED, run->v_rest, vrest_threshold);
}

/* This rank's record file. */
static void records_path(const struct vcrit_runs *r, char *out, size_t size)
{
    if (parallel_rank() == 0)
        snprintf(out, size, "%s/%s_runs.csv", r->run_dir, r->name);
    else
        snprintf(out, size, "%s/%s_runs_rank%d.csv", r->run_dir, r->name, parallel_rank());
}

/* 1 for the name of any rank's record file. */
static int is_records_file(const struct vcrit_runs *r, const char *name)
{
    size_t n = strlen(r->name);
    if (strncmp(name, r->name, n) != 0)
        return 0;
    name += n;
    if (strcmp(name, "_runs.csv") == 0)
        return 1;
    int rank, end = 0;
    return sscanf(name, "_runs_rank%d.csv%n", &rank, &end) == 1 && name[end] == '\0';
}

static void records_title(const struct vcrit_runs *r, char *out, size_t size)
{
    snprintf(out, size, "# spraycoat %s runs of case %016llx, sources %s\n", r->name, (unsigned long long)r->case_hash,
             spraycoat_sources_id());
}

/* The header of the records; files written before the runs carried a temperature have the oldest one (their runs
 * at the material's T_initial, temperature 0), those before failed runs were recorded one without `error`.  The
 * error, a failed run's message, is the last field, quoted as RFC 4180 has it ("...", a quote doubled) so that a
 * CSV reader sees one field however many commas it holds; files written before have it unquoted, the rest of the
 * line. */
#define RECORDS_HEADER        "diameter,velocity,Gc,Gc_rate,verdict,pbcp,v_rest,cor,steps,temperature,error\n"
#define RECORDS_HEADER_NO_ERR "diameter,velocity,Gc,Gc_rate,verdict,pbcp,v_rest,cor,steps,temperature\n"
#define RECORDS_HEADER_OLD    "diameter,velocity,Gc,Gc_rate,verdict,pbcp,v_rest,cor,steps\n"

/* `text` as one quoted CSV field (RFC 4180), "" for an empty text; `out` holds at least 2 * VCRIT_ERROR_MAX + 3. */
static const char *quoted_field(const char *text, char *out)
{
    char *o = out;
    if (*text) {
        *o++ = '"';
        for (const char *c = text; *c; c++) {
            if (*c == '"')
                *o++ = '"';
            *o++ = *c;
        }
        *o++ = '"';
    }
    *o = '\0';
    return out;
}

/* The error field at `rest` (after its comma) into x->error: quoted (RFC 4180) or, as written before, the rest of
 * the line; returns where the field ends, NULL when it does not fit or a quote is not closed. */
static const char *unquoted_field(const char *rest, struct vcrit_run_record *x)
{
    size_t n = 0;
    if (*rest != '"') {
        n = strcspn(rest, "\r\n");
        if (n >= sizeof x->error)
            return NULL;
        memcpy(x->error, rest, n);
        x->error[n] = '\0';
        return rest + n;
    }
    for (rest++; *rest && n + 1 < sizeof x->error; rest++) {
        if (*rest == '"' && rest[1] != '"')
            break;
        rest += *rest == '"'; /* a doubled quote is one */
        x->error[n++] = *rest;
    }
    x->error[n] = '\0';
    return *rest == '"' ? rest + 1 : NULL;
}

static int save_records(const struct vcrit_runs *r)
{
    char path[4096], title[128];
    records_path(r, path, sizeof path);
    records_title(r, title, sizeof title);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "%s%s", title, RECORDS_HEADER);
    for (size_t i = 0; i < r->count; i++) {
        const struct vcrit_run_record *x = &r->done[i];
        char a[32], b[32], c[32], d[32], e[32], f[32], g[32], h[32], error[2 * VCRIT_ERROR_MAX + 3];
        fprintf(out.stream, "%s,%s,%s,%s,%d,%s,%s,%s,%lld,%s,%s\n", exact(x->diameter, a, sizeof a),
                exact(x->velocity, b, sizeof b), exact(x->Gc, c, sizeof c), exact(x->Gc_rate, d, sizeof d), x->verdict,
                exact(x->pbcp, e, sizeof e), exact(x->v_rest, f, sizeof f), exact(x->cor, g, sizeof g),
                (long long)x->steps, exact(x->temperature, h, sizeof h), quoted_field(x->error, error));
    }
    return atomic_publish(&out);
}

static int add_record(struct vcrit_runs *r, const struct vcrit_run_record *x)
{
    if (r->count == r->capacity) {
        size_t grown = r->capacity ? 2 * r->capacity : 64;
        struct vcrit_run_record *more = realloc(r->done, grown * sizeof *more);
        if (!more)
            SC_FAIL_OOM(grown * sizeof *more, "the records of the impact runs");
        r->done = more;
        r->capacity = grown;
    }
    r->done[r->count++] = *x;
    return SC_OK;
}

/* After fgets gave NULL: SC_EIO when that was a read error, not the end of the file.  Taken for the end, an
 * unreadable record lost its runs: the next save_records replaced it with the new runs only. */
static int read_error(const struct vcrit_runs *r, const char *path, FILE *file)
{
    if (!ferror(file))
        return SC_OK;
    int saved = errno ? errno : EIO;
    SC_FAIL(SC_EIO, "%s: cannot read %s: %s", r->name, path, strerror(saved));
}

/* The number of fields of the records in `file` (11, or 10 or 9 in the older headers) after its title and header;
 * 0 for a file of another case or format (or damaged). */
static int records_header(const struct vcrit_runs *r, const char *path, FILE *file, int *fields)
{
    char line[512] = "", title[128];
    records_title(r, title, sizeof title);
    int ok = fgets(line, sizeof line, file) && strcmp(line, title) == 0 && fgets(line, sizeof line, file);
    SC_TRY(read_error(r, path, file));
    *fields = !ok                                        ? 0
              : strcmp(line, RECORDS_HEADER) == 0        ? 11
              : strcmp(line, RECORDS_HEADER_NO_ERR) == 0 ? 10
              : strcmp(line, RECORDS_HEADER_OLD) == 0    ? 9
                                                         : 0;
    return SC_OK;
}

/* One record of a file with `fields` fields; 0 when the line is not one.  The error field (11) is quoted, or the
 * rest of the line (unquoted_field); a line without it (written by hand, as the tests' crafted records are) has
 * none. */
static int parse_record(const char *line, int fields, struct vcrit_run_record *x)
{
    long long steps;
    int end = -1,
        read = fields == 9
                   ? sscanf(line, "%lf,%lf,%lf,%lf,%d,%lf,%lf,%lf,%lld%n", &x->diameter, &x->velocity, &x->Gc,
                            &x->Gc_rate, &x->verdict, &x->pbcp, &x->v_rest, &x->cor, &steps, &end)
                   : sscanf(line, "%lf,%lf,%lf,%lf,%d,%lf,%lf,%lf,%lld,%lf%n", &x->diameter, &x->velocity, &x->Gc,
                            &x->Gc_rate, &x->verdict, &x->pbcp, &x->v_rest, &x->cor, &steps, &x->temperature, &end);
    if (read != (fields == 9 ? 9 : 10) || end < 0)
        return 0;
    x->steps = steps;
    const char *rest = line + end;
    if (fields == 11 && *rest == ',' && !(rest = unquoted_field(rest + 1, x)))
        return 0;
    return rest[strspn(rest, " \t\r\n")] == '\0';
}

/* A record of another case, build or format (or a damaged one) is not used; this rank's own record file, which
 * its next save_records would replace, is first renamed to PATH.kept-N (the first N free): its runs may have taken
 * hours.  Another rank's file is that rank's to keep. */
static int keep_aside(const struct vcrit_runs *r, const char *path)
{
    char own[4096], kept[4500];
    records_path(r, own, sizeof own);
    if (strcmp(own, path) != 0) {
        log_info("%s: %s belongs to another case, build or version; its runs are not used", r->name, path);
        return SC_OK;
    }
    for (int n = 1; n < 1000; n++) {
        snprintf(kept, sizeof kept, "%s.kept-%d", path, n);
        if (access(kept, F_OK) == 0)
            continue;
        if (rename(path, kept) != 0)
            SC_FAIL(SC_EIO, "%s: cannot keep %s (another case's runs) as %s: %s", r->name, path, kept, strerror(errno));
        log_info("%s: %s belongs to another case, build or version; its runs are not used, and it is kept as %s",
                 r->name, path, kept);
        return atomic_sync_folder(path);
    }
    SC_FAIL(SC_EIO, "%s: cannot keep %s (another case's runs): %s.kept-1 to -999 exist; remove some", r->name, path,
            path);
}

/* Runs recorded in `path` for this case; a file of another case or format (or damaged) is not used (keep_aside), one
 * that cannot be read is an I/O error (only a missing one holds no runs). */
static int load_records_file(struct vcrit_runs *r, const char *path)
{
    char line[1024]; /* a record: ten numbers and a failed run's message (VCRIT_ERROR_MAX, its quotes doubled) */
    FILE *file = fopen(path, "r");
    if (!file) {
        if (errno == ENOENT) /* removed since the folder was listed */
            return SC_OK;
        SC_FAIL(SC_EIO, "%s: cannot read %s: %s", r->name, path, strerror(errno));
    }
    int fields, status;
    SC_CHECK(status, records_header(r, path, file, &fields), done);
    if (fields == 0) {
        fclose(file);
        return keep_aside(r, path);
    }
    while (fgets(line, sizeof line, file)) {
        struct vcrit_run_record x = {0};
        if (!parse_record(line, fields, &x)) {
            log_warn("%s: %s: unreadable line '%.60s'; the runs from there on will be done again", r->name, path, line);
            break;
        }
        SC_CHECK(status, add_record(r, &x), done);
    }
    SC_CHECK(status, read_error(r, path, file), done);
done:
    fclose(file);
    return status;
}

int vcrit_runs_load(struct vcrit_runs *r)
{
    r->count = 0;
    DIR *dir = opendir(r->run_dir);
    if (!dir)
        SC_FAIL(SC_EIO, "cannot read folder %s: %s", r->run_dir, strerror(errno));
    int status = SC_OK;
    struct dirent *entry;
    while ((entry = readdir(dir))) {
        if (!is_records_file(r, entry->d_name))
            continue;
        char path[4400];
        snprintf(path, sizeof path, "%s/%s", r->run_dir, entry->d_name);
        SC_CHECK(status, load_records_file(r, path), done);
    }
done:
    closedir(dir);
    return status;
}

void vcrit_runs_free(struct vcrit_runs *r)
{
    free(r->done);
    r->done = NULL;
    r->count = r->capacity = 0;
}

/* Equal up to round-off: a grid value computed as min + (max - min) i / (n - 1) on a refined grid is the same
 * parameter as on the coarser one but may differ in its last bits. */
static int same_value(double a, double b)
{
    return a == b || fabs(a - b) <= 1e-12 * fmax(fabs(a), fabs(b));
}

static const struct vcrit_run_record *find_record(const struct vcrit_runs *r, const struct vcrit_run_record *key)
{
    for (size_t i = 0; i < r->count; i++) {
        const struct vcrit_run_record *x = &r->done[i];
        if (same_value(x->diameter, key->diameter) && same_value(x->velocity, key->velocity) &&
            same_value(x->Gc, key->Gc) && same_value(x->Gc_rate, key->Gc_rate) &&
            same_value(x->temperature, key->temperature))
            return x;
    }
    return NULL;
}

/* ---- one MPM run ---------------------------------------------------------------------------------------------- */

/* One MPM run as the stage loop sees it (struct stage_ops): no checkpoints (a run is short; the search records
 * every finished run in RUN_DIR/NAME_runs*.csv instead). */
struct vcrit_run {
    struct mpm_solver *solver;
};

static int64_t picoseconds(double t)
{
    return (int64_t)llround(t * 1e12);
}

static int run_step(void *owner)
{
    return mpm_step(((struct vcrit_run *)owner)->solver);
}

static int run_finished(void *owner)
{
    return mpm_finished(((struct vcrit_run *)owner)->solver);
}

static void run_position(void *owner, int64_t *step, double *t, int64_t *progress)
{
    struct mpm_counts counts = mpm_get_counts(((struct vcrit_run *)owner)->solver);
    *step = counts.step;
    *t = counts.t;
    *progress = picoseconds(counts.t);
}

/* The verdict of the run's last body (the particle; the substrate is body 0) through mpm_verdicts: 1 bonded, 0
 * rebounded, anything else (a verdict that has not settled) unsettled.  The coefficient of restitution is the
 * particle's centre-of-mass velocity along the substrate normal (+z, away) over the normal impact speed. */
static int record_outcome(struct mpm_solver *s, const struct mpm_config *cfg, struct vcrit_run_record *out)
{
    int nb = mpm_body_count(s), *verdicts = calloc((size_t)nb, sizeof *verdicts);
    if (!verdicts)
        SC_FAIL_OOM((size_t)nb * sizeof *verdicts, "the verdicts of the bodies");
    mpm_verdicts(s, verdicts);
    const struct mpm_diagnostics *diag = mpm_final_diagnostics(s);
    const struct mpm_body_diagnostics *particle = &diag->body[nb - 1];
    double normal_speed = -cfg->bodies[cfg->body_count - 1].velocity[2];
    int v = verdicts[nb - 1];
    out->verdict = v == 1 ? VCRIT_BONDED : v == 0 ? VCRIT_REBOUNDED : VCRIT_UNSETTLED;
    /* v_rest and the rebound speed: the means over the judging window (mpm_verdict_vrest), the last row's values
     * while the particle has no judgement */
    double v_rest = mpm_verdict_vrest(s, nb - 1), v_com_z = mpm_verdict_vcom_z(s, nb - 1);
    out->pbcp = particle->pbcp;
    out->v_rest = isnan(v_rest) ? particle->v_rest : v_rest;
    out->cor = normal_speed > 0 ? (isnan(v_com_z) ? particle->v_com[2] : v_com_z) / normal_speed : NAN;
    out->steps = mpm_get_counts(s).step;
    free(verdicts);
    return SC_OK;
}

/* "Gc 720 J/m2, Gc_rate 2e+11 J/m2/s", "eps_c 2, eps_rate_c 1e+07 1/s" or "no bonding": the run's bonding law. */
static const char *bonding_text(const struct mpm_config *cfg, char *text, size_t size)
{
    if (cfg->bonding == MPM_BONDING_ENERGY)
        snprintf(text, size, "Gc %.6g J/m2, Gc_rate %.6g J/m2/s", cfg->Gc, cfg->Gc_rate);
    else if (cfg->bonding == MPM_BONDING_STRAIN)
        snprintf(text, size, "eps_c %.6g, eps_rate_c %.6g 1/s", cfg->eps_c, cfg->eps_rate_c);
    else
        snprintf(text, size, "no bonding");
    return text;
}

/* The run failed as a simulation (SC_ESIM, the error's message names step and body): a finished run with verdict
 * failed, its message and the steps it made kept in the record.  The same set-up fails the same way again (the run
 * is deterministic), so a resume takes it from the record instead of failing once more.  The error is cleared: it
 * has been taken. */
static void record_failure(struct mpm_solver *s, struct vcrit_run_record *out)
{
    out->verdict = VCRIT_FAILED;
    out->pbcp = out->v_rest = out->cor = NAN;
    out->steps = mpm_get_counts(s).step;
    snprintf(out->error, sizeof out->error, "%s", sc_error_message());
    for (char *c = out->error; *c; c++) /* one line of NAME_runs.csv */
        if (*c == '\n' || *c == '\r')
            *c = ' ';
    sc_error_clear();
}

static int simulate(const struct vcrit_runs *r, const struct mpm_config *cfg, struct vcrit_run_record *out)
{
    struct vcrit_run run = {NULL};
    int status;
    char label[200], note[4400], model[80];
    char T[40] = "";
    if (out->temperature > 0.0)
        snprintf(T, sizeof T, ", T = %.6g K", out->temperature);
    snprintf(label, sizeof label, "%s d = %.4g um%s, %.6g m/s, %s", r->name, out->diameter * 1e6, T, out->velocity,
             bonding_text(cfg, model, sizeof model));
    snprintf(note, sizeof note,
             "the %zu finished runs are recorded in %s/%s_runs.csv: continue with `spraycoat "
             "resume %s`",
             r->count, r->run_dir, r->name, r->resume_dir ? r->resume_dir : r->run_dir);
    const struct stage_ops ops = {.label = label,
                                  .stage = r->name,
                                  .run_dir = r->run_dir,
                                  .progress_unit = "ps",
                                  .progress_total = picoseconds(cfg->t_end),
                                  .owner = &run,
                                  .step = run_step,
                                  .finished = run_finished,
                                  .position = run_position,
                                  .interrupted_note = note};
    struct stage_timing timing;
    SC_CHECK(status, mpm_create(cfg, &run.solver), done);
    status = stage_loop_run(&ops, &timing);
    if (status == SC_ESIM) { /* a NaN or blow-up: a finished run of its own kind, the caller's to judge */
        record_failure(run.solver, out);
        status = SC_OK;
        goto done;
    }
    SC_CHECK(status, status == SC_OK ? record_outcome(run.solver, cfg, out) : status, done);
done:
    mpm_destroy(run.solver);
    return status;
}

int vcrit_runs_outcome(struct vcrit_runs *r, const struct mpm_config *cfg, struct vcrit_run_record *run)
{
    const struct vcrit_run_record *known = find_record(r, run);
    if (known) {
        *run = *known;
        return SC_OK;
    }
    double start = log_elapsed();
    SC_TRY(simulate(r, cfg, run));
    SC_TRY(add_record(r, run));
    SC_TRY(save_records(r));
    r->new_runs++;
    char T[40] = "";
    if (run->temperature > 0.0)
        snprintf(T, sizeof T, ", T = %.6g K,", run->temperature);
    char model[80];
    if (run->verdict == VCRIT_FAILED)
        log_warn("%s: d = %.4g um%s at %.6g m/s (%s): failed after %lld steps: %s; recorded as failed (a resume "
                 "does not repeat it)",
                 r->name, run->diameter * 1e6, T, run->velocity, bonding_text(cfg, model, sizeof model),
                 (long long)run->steps, run->error);
    else
        log_info("%s: d = %.4g um%s at %.6g m/s (%s): %s (PBCP %.2f %%, v_rest %.3g m/s, CoR %.3g; %lld steps, "
                 "%.1f s)",
                 r->name, run->diameter * 1e6, T, run->velocity, bonding_text(cfg, model, sizeof model),
                 run_verdict_word(run, cfg->vrest_threshold), 100 * run->pbcp, run->v_rest, run->cor,
                 (long long)run->steps, log_elapsed() - start);
    return SC_OK;
}

/* The outcome at (d, speed): from the record, or a new run that is then recorded. */
static int outcome(struct vcrit_search *v, struct vcrit_result *result, double speed)
{
    struct vcrit_run_record r = {.diameter = result->diameter,
                                 .velocity = speed,
                                 .Gc = case_real(v->c, "impact", "Gc"),
                                 .Gc_rate = case_real(v->c, "impact", "Gc_rate"),
                                 .temperature = result->temperature};
    struct mpm_config cfg;
    SC_TRY(make_config(v, r.diameter, r.temperature, speed, &cfg));
    int status = vcrit_runs_outcome(&v->runs, &cfg, &r);
    mpm_config_free(&cfg);
    SC_TRY(status);
    result->records[result->runs++] = r;
    return SC_OK;
}

/* "d = 8e-06 m" or, with a temperature, "d = 8e-06 m, T = 600 K": which search a log line is about. */
static const char *pair_name(const struct vcrit_result *r, char *out, size_t size)
{
    if (r->temperature > 0.0)
        snprintf(out, size, "d = %g m, T = %g K", r->diameter, r->temperature);
    else
        snprintf(out, size, "d = %g m", r->diameter);
    return out;
}

/* An unsettled run (its verdict still changing at t_end, mpm/verdict.c) counts as not bonded: v_crit is the
 * lowest speed known to bond with a settled verdict.  The note and the log say how many there were, since each
 * may have bonded in a longer run (then v_crit is lower than reported). */
static void note_unsettled(struct vcrit_result *result)
{
    int unsettled = 0;
    for (int k = 0; k < result->runs; k++)
        unsettled += result->records[k].verdict == VCRIT_UNSETTLED;
    /* a search replayed from its records (after the runs, or under MPI) notes its unsettled runs once; a search that
     * ended with a failed run has no v_crit to doubt, and its note is the failure's alone (note_failed) */
    if (unsettled == 0 || strstr(result->note, "counted as not bonded") || strstr(result->note, "no v_crit"))
        return;
    size_t used = strlen(result->note);
    snprintf(result->note + used, sizeof result->note - used, "%s%d unsettled run%s counted as not bonded",
             used ? "; " : "", unsettled, unsettled > 1 ? "s" : "");
    char name[96];
    log_warn("vcrit: %s: %d of %d runs unsettled at t_end, counted as not bonded (a longer t_end may lower v_crit)",
             pair_name(result, name, sizeof name), unsettled, result->runs);
}

/* 1 when the search's last run failed as a simulation: it ends the search (note_failed). */
static int last_failed(const struct vcrit_result *result)
{
    return result->runs > 0 && result->records[result->runs - 1].verdict == VCRIT_FAILED;
}

/* A run that failed as a simulation (NaN or blow-up, recorded with verdict failed) ends its pair's search without a
 * v_crit: the set-up does not hold at that speed, so neither the bracket nor a fit around it can be trusted.  The
 * other pairs go on, and the row is a '#' line of vcrit.csv as an unbracketed one is.  The note is the failure's
 * alone, the same however often the search is replayed (also where an earlier pass noted unsettled runs); the
 * warning is given once. */
static void note_failed(struct vcrit_result *result)
{
    const struct vcrit_run_record *r = &result->records[result->runs - 1];
    result->v_crit = result->v_bisection = result->pbcp = result->v_rest = NAN;
    result->fit = (struct logistic_threshold){.x50 = NAN, .se = NAN, .width = NAN};
    int noted = strstr(result->note, "no v_crit") != NULL;
    snprintf(result->note, sizeof result->note, "run at %.6g m/s failed (%.180s): no v_crit", r->velocity, r->error);
    char name[96];
    if (!noted)
        log_warn("vcrit: %s: %s; the other searches go on", pair_name(result, name, sizeof name), result->note);
}

/* The bisection treats a verdict that has not settled as not bonded: v_crit is the lowest speed seen to bond (or,
 * with outcome = adhered, to stay on the substrate). */
static int counts_as_success(const struct vcrit_search *v, const struct vcrit_run_record *r)
{
    return vcrit_runs_succeeds(r, v->outcome, v->vrest_threshold) == 1;
}

/* Over pair `key`'s settled runs among n records: the lowest speed of a success and the highest of a failure
 * (INFINITY / -INFINITY when none). */
static void outcome_extremes(const struct vcrit_search *v, const struct vcrit_run_record *key,
                             const struct vcrit_run_record *records, size_t n, double *lowest_success,
                             double *highest_failure)
{
    for (size_t k = 0; k < n; k++) {
        const struct vcrit_run_record *r = &records[k];
        if (!same_value(r->diameter, key->diameter) || !same_value(r->temperature, key->temperature) ||
            !same_value(r->Gc, key->Gc) || !same_value(r->Gc_rate, key->Gc_rate))
            continue;
        int success = vcrit_runs_succeeds(r, v->outcome, v->vrest_threshold);
        if (success == 1)
            *lowest_success = fmin(*lowest_success, r->velocity);
        if (success == 0)
            *highest_failure = fmax(*highest_failure, r->velocity);
    }
}

/* The bisection assumes that the outcome is monotone in the speed: every failure slower than every success.  Its
 * own runs cannot show otherwise (each lies inside the bracket of the ones before), but runs at other speeds can:
 * the CoR runs below v_crit, and the runs of the same pair that earlier searches recorded in the run directory
 * (another bracket or tolerance).  A settled success slower than a settled failure means the threshold is not
 * sharp at this resolution (PBCP near pbcp_threshold is not monotone in the speed, docs/validation.md), and the
 * note and the log say so with the two speeds.  (A success between the bracket's failure and v_crit is no
 * contradiction: with a coarse tolerance v_crit is the bracket's end, and the tiny search of tests/test_vcrit.sh
 * bonded at 850 m/s against v_crit 950 from the bracket 700-950.) */
static void note_not_monotone(const struct vcrit_search *v, struct vcrit_result *result)
{
    double success = INFINITY, failure = -INFINITY;
    if (result->runs > 0 && isfinite(result->v_crit)) {
        outcome_extremes(v, &result->records[0], result->records, (size_t)result->runs, &success, &failure);
        outcome_extremes(v, &result->records[0], v->runs.done, v->runs.count, &success, &failure);
    }
    if (!isfinite(result->v_crit) || !(success < failure) || strstr(result->note, "not monotone"))
        return;
    int adhered = v->outcome == VCRIT_OUTCOME_ADHERED;
    size_t used = strlen(result->note);
    char what[120];
    snprintf(what, sizeof what, "%s at %g m/s, %s at %g m/s", adhered ? "adheres" : "bonds", success,
             adhered ? "leaves" : "not bonded", failure);
    snprintf(result->note + used, sizeof result->note - used, "%snot monotone in speed: %s (v_crit %g m/s)",
             used ? "; " : "", what, result->v_crit);
    char name[96];
    log_warn("vcrit: %s: the outcome is not monotone in the speed: %s against v_crit = %g m/s from the bisection",
             pair_name(result, name, sizeof name), what, result->v_crit);
}

static int speed_known(const struct vcrit_result *result, double speed)
{
    for (int i = 0; i < result->runs; i++)
        if (result->records[i].velocity == speed)
            return 1;
    return 0;
}

/* Runs below v_crit for the coefficient of restitution against impact speed ([vcrit] cor_below). */
static int cor_runs(struct vcrit_search *v, struct vcrit_result *result)
{
    for (int k = 0; k < v->cor_count && !last_failed(result); k++) {
        double speed = result->v_crit - v->cor_offsets[k];
        if (speed > 0 && !speed_known(result, speed))
            SC_TRY(outcome(v, result, speed));
    }
    return SC_OK;
}

/* method = logistic: sweep_count runs on each side of the bisection's v_crit, sweep_step apart (a speed the
 * bisection already ran is not repeated). */
static int sweep_runs(struct vcrit_search *v, struct vcrit_result *result)
{
    for (int k = -v->sweep_count; k <= v->sweep_count && !last_failed(result); k++) {
        double speed = result->v_bisection + k * v->sweep_step;
        if (k != 0 && speed > 0 && !speed_known(result, speed))
            SC_TRY(outcome(v, result, speed));
    }
    return SC_OK;
}

/* A run's impact speed as its normal component, as the outputs give it (normal_components). */
static double normal_speed(const struct vcrit_search *v, double speed)
{
    return v->angle == 0.0 ? speed : speed * cos(v->angle);
}

/* method = logistic: v_crit is the speed of 50 % success of the first-order logistic fit to every settled run of the
 * search (core/logistic.h; unsettled runs are left out, note_unsettled counts them; a failed run ended the search
 * before the fit, note_failed); PBCP and v_rest are those of
 * the slowest success at or above it. */
static int fit_threshold(const struct vcrit_search *v, struct vcrit_result *result)
{
    double *speeds = NULL;
    int *successes = NULL, status;
    size_t m = 0, n = (size_t)result->runs + 1;
    SC_CHECK(status, sc_calloc(&speeds, n, sizeof *speeds, "the speeds of a vcrit fit"), done);
    SC_CHECK(status, sc_calloc(&successes, n, sizeof *successes, "the outcomes of a vcrit fit"), done);
    for (int k = 0; k < result->runs; k++) {
        int success = vcrit_runs_succeeds(&result->records[k], v->outcome, v->vrest_threshold);
        if (success >= 0) {
            speeds[m] = result->records[k].velocity;
            successes[m++] = success;
        }
    }
    SC_CHECK(status, logistic_threshold_fit(speeds, successes, m, result->v_bisection, v->sweep_step, &result->fit),
             done);
    result->v_crit = result->fit.x50;
    double slowest_run = INFINITY, fastest_run = -INFINITY, fastest_failure = -INFINITY, slowest_success = INFINITY;
    size_t settled_successes = 0;
    for (size_t k = 0; k < m; k++) {
        slowest_run = fmin(slowest_run, speeds[k]), fastest_run = fmax(fastest_run, speeds[k]);
        settled_successes += (size_t)successes[k];
        if (successes[k])
            slowest_success = fmin(slowest_success, speeds[k]);
        else
            fastest_failure = fmax(fastest_failure, speeds[k]);
    }
    /* every failure (or success) unsettled, so left out: no fit; the bisection counted them as failures */
    int one_sided = settled_successes == 0 || settled_successes == m;
    if (one_sided)
        result->v_crit = result->v_bisection;
    /* a nearly flat fit (outcomes mixed over the whole range) puts its 50 % point beyond every speed run: an
     * extrapolation, which a table must not take; the bisection's threshold stands, and the note says why */
    int beyond_runs = isfinite(result->fit.x50) && (result->fit.x50 < slowest_run || result->fit.x50 > fastest_run);
    if (beyond_runs) /* the fit's standard error is its 50 % point's, not the bisection's */
        result->v_crit = result->v_bisection, result->fit.se = NAN;
    result->pbcp = result->v_rest = NAN;
    double slowest = INFINITY;
    for (int k = 0; k < result->runs; k++) {
        const struct vcrit_run_record *r = &result->records[k];
        if (counts_as_success(v, r) && r->velocity >= result->v_crit && r->velocity < slowest) {
            slowest = r->velocity;
            result->pbcp = r->pbcp;
            result->v_rest = r->v_rest;
        }
    }
    size_t used = strlen(result->note);
    /* a replayed search noted it the first time */
    int noted = strstr(result->note, "logistic") != NULL || strstr(result->note, "outcomes separable") != NULL;
    if (!noted && one_sided)
        snprintf(result->note + used, sizeof result->note - used,
                 "%sno logistic fit: no settled run %s (the unsettled are left out): v_crit is the bisection's",
                 used ? "; " : "", settled_successes == 0 ? "succeeded" : "failed");
    else if (!noted && !result->fit.rising)
        snprintf(result->note + used, sizeof result->note - used,
                 "%sno logistic threshold: the outcome does not rise with the speed", used ? "; " : "");
    else if (!noted && beyond_runs)
        snprintf(result->note + used, sizeof result->note - used,
                 "%slogistic 50 %% point %.4g m/s beyond the speeds run (%g-%g m/s): v_crit is the bisection's",
                 used ? "; " : "", result->fit.x50, slowest_run, fastest_run);
    else if (!noted && result->fit.separable) /* no fit (core/logistic.h); the gap's speeds as the outputs give them */
        snprintf(result->note + used, sizeof result->note - used,
                 "%soutcomes separable: v_crit is the middle of the gap %.6g-%.6g m/s (no fit, no standard error)",
                 used ? "; " : "", normal_speed(v, fastest_failure), normal_speed(v, slowest_success));
    else if (!noted)
        snprintf(result->note + used, sizeof result->note - used,
                 "%snot monotone in speed: logistic 10-90 %% width %.3g m/s", used ? "; " : "", result->fit.width);
done:
    free(speeds);
    free(successes);
    return status;
}

/* The bracket [v_low, v_high] and its bisection for one pair: v_crit the upper end, or NaN when the bracket does not
 * hold (the note says why) or a run failed (the last record; search_pair notes it). */
static int bisect(struct vcrit_search *v, struct vcrit_result *result)
{
    SC_TRY(outcome(v, result, v->v_low));
    if (last_failed(result))
        return SC_OK;
    if (counts_as_success(v, &result->records[0])) {
        snprintf(result->note, sizeof result->note, "not bracketed: bonds already at v_low = %g m/s", v->v_low);
        return SC_OK;
    }
    SC_TRY(outcome(v, result, v->v_high));
    if (last_failed(result))
        return SC_OK;
    if (!counts_as_success(v, &result->records[1])) {
        snprintf(result->note, sizeof result->note, "not bracketed: %s still at v_high = %g m/s",
                 result->records[1].verdict == VCRIT_UNSETTLED ? "unsettled" : "rebounds", v->v_high);
        return SC_OK;
    }
    double low = v->v_low, high = v->v_high;
    struct vcrit_run_record best = result->records[1];
    while (high - low > v->tolerance && result->runs < v->max_runs) {
        SC_TRY(outcome(v, result, 0.5 * (low + high)));
        const struct vcrit_run_record *r = &result->records[result->runs - 1];
        if (last_failed(result))
            return SC_OK;
        if (counts_as_success(v, r)) {
            high = r->velocity;
            best = *r;
        } else {
            low = r->velocity;
        }
    }
    result->v_crit = result->v_bisection = high;
    result->pbcp = best.pbcp;
    result->v_rest = best.v_rest;
    if (high - low > v->tolerance) {
        snprintf(result->note, sizeof result->note, "max_runs reached: bonds at %g m/s, rebounds at %g m/s", high, low);
        char name[96];
        log_warn("vcrit: %s: %s (the bracket is wider than tolerance = %g m/s)", pair_name(result, name, sizeof name),
                 result->note, v->tolerance);
    }
    return SC_OK;
}

/* The search of one (diameter, temperature) pair: the bisection, with method = logistic its sweep and fit, then
 * the CoR runs; a run that fails as a simulation ends it (note_failed). */
static int search_pair(struct vcrit_search *v, struct vcrit_result *result)
{
    result->v_crit = result->v_bisection = result->pbcp = result->v_rest = NAN;
    result->fit = (struct logistic_threshold){.x50 = NAN, .se = NAN, .width = NAN};
    size_t capacity = (size_t)(v->max_runs + v->cor_count + (v->logistic ? 2 * v->sweep_count : 0));
    result->records = calloc(capacity, sizeof *result->records);
    if (!result->records)
        SC_FAIL_OOM(capacity * sizeof *result->records, "the runs of a vcrit search");
    SC_TRY(bisect(v, result));
    if (v->logistic && isfinite(result->v_crit)) {
        SC_TRY(sweep_runs(v, result));
        if (!last_failed(result))
            SC_TRY(fit_threshold(v, result));
    }
    if (!last_failed(result))
        note_unsettled(result);
    if (isfinite(result->v_crit) && !last_failed(result))
        SC_TRY(cor_runs(v, result));
    if (last_failed(result))
        note_failed(result);
    else if (!v->logistic)
        note_not_monotone(v, result);
    return SC_OK;
}

/* ---- outputs --------------------------------------------------------------------------------------------------- */

static int bracketed(const struct vcrit_result *r)
{
    return isfinite(r->v_crit);
}

/* vcrit.csv: the table of the spray stage's rule = table, v_crit(d) or, with [vcrit] temperatures, v_crit(d, T) with
 * a temperature column after the diameter.  Searches without a bracket are '#' comment lines (with NaN and the
 * reason): the table reader skips them, so a 1-D table stays usable as it is (a 2-D one then misses a pair of its
 * grid, which the reader refuses, saying so). */
static int write_csv(const struct vcrit_search *v, const struct vcrit_result *results)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/vcrit.csv", v->run_dir);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "%s%s\n",
            v->over_temperature ? "diameter,temperature,v_crit,pbcp,v_rest,runs" : "diameter,v_crit,pbcp,v_rest,runs",
            v->logistic ? ",v_crit_se,width,v_bisection" : "");
    for (int i = 0; i < pair_count(v); i++) {
        const struct vcrit_result *r = &results[i];
        char a[32], b[32], c[32], d[32], t[32];
        fprintf(out.stream, "%s%s,%s%s%s,%s,%s,%d", bracketed(r) ? "" : "# ", exact(r->diameter, a, sizeof a),
                v->over_temperature ? exact(r->temperature, t, sizeof t) : "", v->over_temperature ? "," : "",
                exact(r->v_crit, b, sizeof b), exact(r->pbcp, c, sizeof c), exact(r->v_rest, d, sizeof d), r->runs);
        if (v->logistic)
            fprintf(out.stream, ",%s,%s,%s", exact(r->fit.se, a, sizeof a), exact(r->fit.width, b, sizeof b),
                    exact(r->v_bisection, c, sizeof c));
        if (bracketed(r))
            fputc('\n', out.stream);
        else
            fprintf(out.stream, "  %s\n", r->note);
        /* a v_crit that is no fit's 50 % point but the middle of the gap says so beneath its row (a comment line:
         * the table readers skip it; an unbracketed row's line starts with its diameter instead) */
        if (v->logistic && bracketed(r) && r->fit.separable)
            fprintf(out.stream, "# d = %s m%s%s%s: %s\n", exact(r->diameter, a, sizeof a),
                    v->over_temperature ? ", T = " : "", v->over_temperature ? exact(r->temperature, t, sizeof t) : "",
                    v->over_temperature ? " K" : "", r->note);
    }
    return atomic_publish(&out);
}

static int compare_runs(const void *a, const void *b)
{
    const struct vcrit_run_record *x = a, *y = b;
    if (x->diameter != y->diameter)
        return (x->diameter > y->diameter) - (x->diameter < y->diameter);
    if (x->temperature != y->temperature)
        return (x->temperature > y->temperature) - (x->temperature < y->temperature);
    return (x->velocity > y->velocity) - (x->velocity < y->velocity);
}

/* vcrit_cor.csv: every run of every search (bisection and cor_below), by diameter (temperature) and speed: the
 * coefficient of restitution against impact speed. */
static int write_cor_csv(const struct vcrit_search *v, const struct vcrit_result *results)
{
    size_t n = 0;
    for (int i = 0; i < pair_count(v); i++)
        n += (size_t)results[i].runs;
    struct vcrit_run_record *all;
    SC_TRY(sc_calloc(&all, n, sizeof *all, "the runs of the vcrit search"));
    for (int i = 0, k = 0; i < pair_count(v); i++)
        for (int j = 0; j < results[i].runs; j++)
            all[k++] = results[i].records[j];
    qsort(all, n, sizeof *all, compare_runs);
    char path[4096];
    snprintf(path, sizeof path, "%s/vcrit_cor.csv", v->run_dir);
    struct atomic_file out;
    int status;
    SC_CHECK(status, atomic_open(path, &out), done);
    fprintf(out.stream, "%s\n",
            v->over_temperature ? "diameter,temperature,velocity,verdict,cor,pbcp,v_rest"
                                : "diameter,velocity,verdict,cor,pbcp,v_rest");
    for (size_t k = 0; k < n; k++) {
        char a[32], b[32], c[32], d[32], e[32], t[32];
        fprintf(out.stream, "%s,%s%s%s,%s,%s,%s,%s\n", exact(all[k].diameter, a, sizeof a),
                v->over_temperature ? exact(all[k].temperature, t, sizeof t) : "", v->over_temperature ? "," : "",
                exact(normal_speed(v, all[k].velocity), b, sizeof b), run_verdict_word(&all[k], v->vrest_threshold),
                exact(all[k].cor, c, sizeof c), exact(all[k].pbcp, d, sizeof d), exact(all[k].v_rest, e, sizeof e));
    }
    SC_CHECK(status, atomic_publish(&out), done);
done:
    free(all);
    return status;
}

static int write_runs_group(const struct vcrit_search *v, hid_t parent, int index, const struct vcrit_result *r)
{
    char name[32];
    snprintf(name, sizeof name, "%03d", index);
    hid_t group;
    SC_TRY(h5_create_group(parent, name, &group));
    size_t n = (size_t)r->runs;
    double *values = calloc(4 * n + 1, sizeof *values);
    int64_t *integers = calloc(3 * n + 1, sizeof *integers);
    int status = SC_OK;
    if (!values || !integers)
        SC_FAIL_OOM_AT(status, done, (4 * n + 1) * sizeof *values + (3 * n + 1) * sizeof *integers,
                       "the runs of a vcrit search");
    for (size_t k = 0; k < n; k++) {
        values[k] = normal_speed(v, r->records[k].velocity);
        values[n + k] = r->records[k].pbcp;
        values[2 * n + k] = r->records[k].v_rest;
        values[3 * n + k] = r->records[k].cor;
        integers[k] = counts_as_success(v, &r->records[k]);
        integers[n + k] = r->records[k].steps;
        integers[2 * n + k] = r->records[k].verdict;
    }
    hsize_t dims[1] = {n};
    SC_CHECK(status, h5_write_doubles(group, "velocity", 1, dims, values, "m/s", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "bonded", 1, dims, integers, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "pbcp", 1, dims, values + n, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "v_rest", 1, dims, values + 2 * n, "m/s", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "steps", 1, dims, integers + n, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "cor", 1, dims, values + 3 * n, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "verdict", 1, dims, integers + 2 * n, "-", 0), done);
    SC_CHECK(status, h5_attr_write_double(group, "diameter", r->diameter), done);
    if (r->temperature > 0.0)
        SC_CHECK(status, h5_attr_write_double(group, "temperature", r->temperature), done);
    SC_CHECK(status, h5_attr_write_double(group, "v_crit", r->v_crit), done);
    SC_CHECK(status, h5_attr_write_string(group, "method", v->logistic ? "logistic" : "bisection"), done);
    if (v->logistic) {
        SC_CHECK(status, h5_attr_write_double(group, "v_bisection", r->v_bisection), done);
        SC_CHECK(status, h5_attr_write_double(group, "v_crit_se", r->fit.se), done);
        SC_CHECK(status, h5_attr_write_double(group, "width", r->fit.width), done);
    }
    SC_CHECK(status, h5_attr_write_string(group, "result", r->note[0] ? r->note : "bracketed"), done);
    /* what `bonded` and v_crit count: bonded, or adhered (bonded or held) */
    SC_CHECK(status, h5_attr_write_string(group, "outcome", v->outcome == VCRIT_OUTCOME_ADHERED ? "adhered" : "bonded"),
             done);
done:
    free(values);
    free(integers);
    H5Gclose(group);
    return status;
}

/* /grid: the table v_crit(d, T) as a grid, /grid/diameter (nd), /grid/temperature (nt), /grid/v_crit (nd x nt, NaN
 * where the search found no bracket). */
static int write_grid(const struct vcrit_search *v, const struct vcrit_result *results, hid_t file)
{
    size_t nd = (size_t)v->count, nt = (size_t)v->temperature_count;
    double *grid = malloc(nd * nt * sizeof *grid);
    if (!grid)
        SC_FAIL_OOM(nd * nt * sizeof *grid, "the vcrit grid");
    for (size_t p = 0; p < nd * nt; p++)
        grid[p] = results[p].v_crit;
    hid_t group;
    int status;
    SC_CHECK(status, h5_create_group(file, "grid", &group), out);
    hsize_t dims_d[1] = {nd}, dims_t[1] = {nt}, dims[2] = {nd, nt};
    SC_CHECK(status, h5_write_doubles(group, "diameter", 1, dims_d, v->diameters, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "temperature", 1, dims_t, v->temperatures, "K", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "v_crit", 2, dims, grid, "m/s", 0), done);
done:
    H5Gclose(group);
out:
    free(grid);
    return status;
}

/* vcrit.h5: /diameter, /v_crit, /pbcp, /v_rest, /runs for the searches with a v_crit (by diameter, then temperature:
 * the table of rule = table), with [vcrit] temperatures also /temperature and /grid; and /search/NNN per search with
 * every run. */
static int write_h5_contents(const struct vcrit_search *v, const struct vcrit_result *results, hid_t file)
{
    size_t m = (size_t)pair_count(v);
    double *columns = calloc(5 * m + 1, sizeof *columns);
    int64_t *runs = calloc(m + 1, sizeof *runs);
    hid_t group = H5I_INVALID_HID;
    int status = SC_OK;
    if (!columns || !runs)
        SC_FAIL_OOM_AT(status, done, (5 * m + 1) * sizeof *columns + (m + 1) * sizeof *runs, "the vcrit table");
    size_t n = 0;
    for (size_t i = 0; i < m; i++) {
        if (!bracketed(&results[i]))
            continue;
        columns[n] = results[i].diameter;
        columns[m + n] = results[i].v_crit;
        columns[2 * m + n] = results[i].pbcp;
        columns[3 * m + n] = results[i].v_rest;
        columns[4 * m + n] = results[i].temperature;
        runs[n] = results[i].runs;
        n++;
    }
    hsize_t dims[1] = {n};
    SC_CHECK(status, h5_write_doubles(file, "diameter", 1, dims, columns, "m", 0), done);
    if (v->over_temperature)
        SC_CHECK(status, h5_write_doubles(file, "temperature", 1, dims, columns + 4 * m, "K", 0), done);
    SC_CHECK(status, h5_write_doubles(file, "v_crit", 1, dims, columns + m, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(file, "pbcp", 1, dims, columns + 2 * m, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(file, "v_rest", 1, dims, columns + 3 * m, "m/s", 0), done);
    SC_CHECK(status, h5_write_int64s(file, "runs", 1, dims, runs, "-", 0), done);
    /* the runs' angle from the substrate normal: the speeds here are normal components (normal_components) */
    SC_CHECK(status, h5_attr_write_double(file, "impact_angle", v->angle * 180.0 / M_PI), done);
    if (v->over_temperature)
        SC_CHECK(status, write_grid(v, results, file), done);
    SC_CHECK(status, h5_create_group(file, "search", &group), done);
    for (size_t i = 0; i < m; i++)
        SC_CHECK(status, write_runs_group(v, group, (int)i, &results[i]), done);
done:
    free(columns);
    free(runs);
    /* closed on every path: a group left open kept vcrit.h5 open after a failed write */
    if (group >= 0)
        H5Gclose(group);
    return status;
}

struct vcrit_output {
    const struct vcrit_search *v;
    const struct vcrit_result *results;
};

static int output_contents(void *owner, hid_t file)
{
    const struct vcrit_output *o = owner;
    return write_h5_contents(o->v, o->results, file);
}

static int output_tables(void *owner)
{
    const struct vcrit_output *o = owner;
    SC_TRY(write_csv(o->v, o->results));
    return write_cor_csv(o->v, o->results);
}

/* vcrit.h5 with the CSVs as its side files (stage_write_outputs: another case's vcrit.h5 never stays beside this
 * case's CSVs, and a fault writing vcrit.h5 leaves the earlier results whole). */
static int write_outputs(const struct vcrit_search *v, const struct vcrit_result *results)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/vcrit.h5", v->run_dir);
    struct vcrit_output o = {v, results};
    return stage_write_outputs(path, VCRIT_FORMAT, VCRIT_FORMAT_VERSION, STAGE, v->case_hash, v->c, output_contents,
                               output_tables, &o);
}

static void log_table(const struct vcrit_search *v, const struct vcrit_result *results)
{
    log_info("vcrit: %-12s %-8s %-10s %-8s %-10s %-5s", "diameter/um", "T/K", "v_crit", "PBCP/%", "v_rest", "runs");
    for (int i = 0; i < pair_count(v); i++) {
        const struct vcrit_result *r = &results[i];
        char T[32] = "T_initial";
        if (r->temperature > 0.0)
            snprintf(T, sizeof T, "%g", r->temperature);
        log_info("vcrit: %-12.4g %-8s %-10.6g %-8.3g %-10.3g %-5d %s", r->diameter * 1e6, T, r->v_crit, 100 * r->pbcp,
                 r->v_rest, r->runs, r->note);
        if (v->logistic && isfinite(r->v_crit))
            log_info("vcrit: %-12s logistic fit: v_crit %.5g +- %.2g m/s (1 s.e.), 10-90 %% width %.3g m/s, "
                     "bisection %.6g m/s%s",
                     "", r->v_crit, r->fit.se, r->fit.width, r->v_bisection,
                     r->fit.separable ? " (outcomes separable: the middle of the gap)" : "");
    }
}

/* ---- the stage --------------------------------------------------------------------------------------------------- */

static void free_records(struct vcrit_result *results, int count)
{
    for (int i = 0; i < count; i++) {
        free(results[i].records);
        results[i].records = NULL;
        results[i].runs = 0;
    }
}

/* Every rank takes the next (diameter, temperature) pair not yet taken and bisects it. */
static int search_shared(struct vcrit_search *v, struct vcrit_result *results)
{
    int status = vcrit_runs_load(&v->runs);
    if (status != SC_OK)
        sc_error_trace(__FILE__, __LINE__);
    else if (v->runs.count > 0)
        log_info("vcrit: %zu runs recorded in %s are reused where the search meets them", v->runs.count, v->run_dir);
    /* every rank takes part in the task counter even after a failure here (no early return) */
    parallel_tasks_begin();
    for (int64_t i; status == SC_OK && (i = parallel_task_next()) < pair_count(v);) {
        set_pair(v, (int)i, &results[i]);
        if ((status = search_pair(v, &results[i])) != SC_OK)
            sc_error_trace(__FILE__, __LINE__);
    }
    parallel_tasks_end();
    free_records(results, pair_count(v));
    return status;
}

/* The outputs' speeds as normal components: the runs fly at [impact] angle from the substrate normal, and the spray's
 * table rule compares the normal component of a particle's velocity with v_crit (docs/physics.md "v_crit over
 * temperature"), so a threshold found in speed is written as speed times cos(angle), and so are the runs' speeds
 * in vcrit_cor.csv and /search (normal_speed); at normal incidence they are the same.  The records of the runs
 * (vcrit_runs.csv) keep their speeds, which the search replays. */
static void normal_components(const struct vcrit_search *v, struct vcrit_result *results)
{
    if (v->angle == 0.0)
        return;
    double c = cos(v->angle);
    log_info("vcrit: the runs fly at %g degrees from the substrate normal: the table's v_crit is the normal component "
             "of the threshold speed (x cos %g degrees = %.4g), what the spray's table rule compares; so are the runs' "
             "speeds in vcrit_cor.csv and vcrit.h5",
             v->angle * 180.0 / M_PI, v->angle * 180.0 / M_PI, c);
    for (int i = 0; i < pair_count(v); i++) {
        struct vcrit_result *r = &results[i];
        r->v_crit *= c, r->v_bisection *= c;
        r->fit.x50 *= c, r->fit.se *= c, r->fit.width *= c;
    }
}

/* Rank 0, once every pair is done: the bisections again from all ranks' records, then the outputs. */
static int replay_and_write(struct vcrit_search *v, struct vcrit_result *results, double start)
{
    int64_t runs = v->runs.new_runs;
    SC_TRY(vcrit_runs_load(&v->runs));
    for (int i = 0; i < pair_count(v); i++) {
        set_pair(v, i, &results[i]);
        SC_TRY(search_pair(v, &results[i]));
    }
    if (v->runs.new_runs != runs)
        SC_FAIL(SC_EIO, "vcrit: a run of the search is missing from the records after all ranks finished (a records "
                        "file removed or damaged while the stage ran?)");
    normal_components(v, results);
    SC_TRY(write_outputs(v, results));
    log_info("vcrit: wrote %s/vcrit.csv, vcrit_cor.csv and vcrit.h5 (%lld runs in this process, %.1f s)", v->run_dir,
             (long long)v->runs.new_runs, log_elapsed() - start);
    log_table(v, results);
    return SC_OK;
}

static int run_search(struct vcrit_search *v, struct vcrit_result *results)
{
    double start = log_elapsed();
    if (parallel_rank() == 0)
        log_info("vcrit: %d diameters x %d temperatures, %g to %g m/s, tolerance %g m/s, at most %d runs each, on %d "
                 "threads x %d process%s",
                 v->count, v->temperature_count, v->v_low, v->v_high, v->tolerance, v->max_runs, omp_get_max_threads(),
                 parallel_size(), parallel_size() > 1 ? "es" : "");
    if (parallel_rank() == 0 && v->outcome == VCRIT_OUTCOME_ADHERED)
        log_info("vcrit: outcome = adhered: v_crit is the lowest speed at which the particle stays on the substrate "
                 "(bonded, or held at rest with PBCP under the threshold)");
    int status = parallel_max_status(search_shared(v, results));
    if (status == SC_OK && parallel_rank() == 0)
        status = replay_and_write(v, results, start);
    return parallel_share_status(status);
}

int vcrit_stage_validate(const struct stage_context *ctx)
{
    /* recorded runs of another case are ignored, never refused */
    struct vcrit_search v = {.c = ctx->c};
    SC_TRY(load_settings(ctx->c, &v));
    struct mpm_config cfg; /* the single particle on its substrate: the materials in use */
    SC_TRY(mpm_config_load(ctx->c, &cfg));
    mpm_config_warn_unused_materials(ctx->c, &cfg);
    mpm_config_free(&cfg);
    return SC_OK;
}

/* What one run's outcome depends on besides its diameter, speed and temperature: [run], [impact], the materials and
 * the substrate's scale, the impact angle and the reference diameter (when set) of [vcrit].  The search's own keys
 * (diameters, temperatures, v_low, v_high, tolerance, max_runs, cor_below) are left out, so that a search widened,
 * refined or extended to more sizes reuses the runs it shares with the one before (the record is kept with the
 * outputs). */
static uint64_t runs_hash(const struct vcrit_search *v)
{
    static const char *const run_sections[] = {"run", "impact", "material.*", NULL};
    uint64_t hash = case_hash_sections(v->c, run_sections);
    const double run_keys[3] = {v->scale, v->angle, v->reference};
    /* the reference only when set: records made before the key existed keep their hash */
    return case_hash_continue(hash, run_keys, (v->reference > 0 ? 3 : 2) * sizeof run_keys[0]);
}

int vcrit_stage_run(const struct stage_context *ctx)
{
    const struct case_file *c = ctx->c;
    const char *run_dir = ctx->run_dir;
    struct vcrit_search v = {.c = c, .run_dir = run_dir, .case_hash = stage_hash(ctx, STAGE)};
    char path[4096];
    snprintf(path, sizeof path, "%s/vcrit.h5", run_dir);
    enum output_state state = run_dir_output_state(path, v.case_hash);
    if (state == OUTPUT_CURRENT) {
        log_info("vcrit: %s is up to date with the case; nothing to do", path);
        return SC_OK;
    }
    run_dir_log_rerun(STAGE, path, state);
    SC_TRY(load_settings(c, &v));
    v.runs = (struct vcrit_runs){
        .run_dir = run_dir, .name = STAGE, .resume_dir = stage_resume_dir(ctx), .case_hash = runs_hash(&v)};
    struct run_settings settings;
    run_settings_load(c, &settings);
    if (settings.threads > 0)
        omp_set_num_threads(settings.threads);
    struct vcrit_result *results = NULL;
    int status;
    SC_CHECK(status, sc_calloc(&results, (size_t)pair_count(&v), sizeof *results, "the vcrit results"), done);
    SC_CHECK(status, run_search(&v, results), done);
done:
    if (results)
        free_records(results, pair_count(&v));
    free(results);
    vcrit_runs_free(&v.runs);
    return status;
}
