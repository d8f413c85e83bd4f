/* The spraycoat command line (README "The commands"; docs/architecture.md).  Only this file prints errors and exits. */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/memory.h"
#include "core/parallel.h"
#include "core/units.h"
#include "core/version.h"
#include "app/app.h"
#include "dem/dem.h"
#include "mpm/mpm.h"

static const char usage[] =
    "usage:\n"
    "  spraycoat check CASE.ini                 validate the case; print every resolved parameter\n"
    "                                           with its unit and where it came from\n"
    "  spraycoat spray CASE.ini [-o RUN_DIR]    run the spray stage (resumes from a checkpoint of the\n"
    "                                           same case in RUN_DIR if there is one)\n"
    "  spraycoat impact CASE.ini [-o RUN_DIR]   run the impact stage (MPM impacts of [impact]; resumes\n"
    "                                           like spray)\n"
    "  spraycoat vcrit CASE.ini [-o RUN_DIR]    critical velocity vs diameter from MPM impacts ([vcrit])\n"
    "  spraycoat calibrate CASE.ini [-o RUN_DIR]\n"
    "                                           bonding calibration: logistic boundaries of the bonding\n"
    "                                           model's two parameters from MPM impacts of two sizes\n"
    "                                           ([calibrate]), or (method = vcrit) the first, and with\n"
    "                                           rate = fitted the second too, fitted to measured\n"
    "                                           critical velocities, then figures\n"
    "  spraycoat render CASE.ini [-o RUN_DIR]   figures (RUN_DIR/figures/) and RUN_DIR/report.html from the\n"
    "                                           outputs RUN_DIR holds ([render])\n"
    "  spraycoat couple CASE.ini [-o RUN_DIR]   sample the spray's impacts, fly them through the gas layer\n"
    "                                           in front of the target (CVODE) and seed the impact runs\n"
    "  spraycoat run CASE.ini [-o RUN_DIR] [--stages LIST]\n"
    "                                           the pipeline spray,couple,impact,render (couple and impact\n"
    "                                           when the case has [couple] or [impact]); LIST picks stages\n"
    "  spraycoat sweep CASE.ini [-o RUN_DIR]    the spray over a grid of two case keys ([sweep]): maps of\n"
    "                                           the deposition efficiency and the impact speed\n"
    "  spraycoat resume RUN_DIR                 continue an interrupted run (the stages of the command\n"
    "                                           that made RUN_DIR) from its newest checkpoint\n"
    "  spraycoat info RUN_DIR|FILE.h5           what a run or file holds: stage, step, time, metrics\n"
    "  spraycoat keys                           the case-file keys as Markdown tables\n"
    "  spraycoat help [COMMAND]                 this help, or a command's (also spraycoat COMMAND --help)\n"
    "  spraycoat --help | --version\n"
    "options:\n"
    "  -o RUN_DIR      run directory (default runs/CASE_NAME)\n"
    "  --threads N     OpenMP threads (overrides [run] threads; 0 = all cores)\n"
    "  --device D      where the impact step runs: cpu or gpu (overrides [run] device; gpu: make CUDA=1)\n"
    "  --stages LIST   run: comma-separated stages to run (spray,couple,impact,render)\n"
    "  -v, --verbose   debug messages;  -q, --quiet   warnings and errors only\n"
    "exit status: 0 done, 1 simulation failed, 2 bad command line or case file, 3 I/O error,\n"
    "             130/143 interrupted by SIGINT/SIGTERM after writing a checkpoint\n";

/* Per-command help (`spraycoat CMD --help`, `spraycoat help CMD`): synopsis, what it does, its options. */
struct command_help {
    const char *name, *synopsis, *text;
};
static const struct command_help command_helps[] = {
    {"check", "spraycoat check CASE.ini",
     "Validate the case file without running anything: every key, its range and the cross-key rules, the input\n"
     "files it names, and (with [impact] or [vcrit]) the whole impact set-up.  Prints every resolved parameter\n"
     "with its unit and where it came from (the file or the default; a value written with a unit as given and in\n"
     "SI: 30 mm = 0.03 m) and the case hash, or every error of the file (bad values, units, keys, sections).\n"},
    {"run", "spraycoat run CASE.ini [-o RUN_DIR] [--threads N] [--stages LIST]",
     "The pipeline: spray, couple, impact, render (couple and impact when the case has [couple] or [impact]).\n"
     "Each stage skips what is up to date and resumes from its newest checkpoint.  Ends with a summary of the\n"
     "results.  --stages picks stages (comma-separated: spray,couple,impact,render).\n"},
    {"resume", "spraycoat resume RUN_DIR [--threads N]",
     "Continue the stages recorded in RUN_DIR/stages with the case recorded in RUN_DIR/case.ini, from the newest\n"
     "checkpoint of each; the results are identical, bit for bit, to an uninterrupted run.  Ends with the same\n"
     "summary as run.\n"},
    {"spray", "spraycoat spray CASE.ini [-o RUN_DIR] [--threads N]",
     "The spray stage (DEM): writes RUN_DIR/spray.h5 and spray.xdmf.\n"},
    {"couple", "spraycoat couple CASE.ini [-o RUN_DIR]",
     "The couple stage: samples spray.h5's impacts, flies them through the gas layer in front of the target\n"
     "(CVODE) and writes the impact runs' seeds to RUN_DIR/couple.h5.\n"},
    {"impact", "spraycoat impact CASE.ini [-o RUN_DIR] [--threads N]",
     "The impact stage (MPM): the bodies of [impact] (or the couple stage's seeds when RUN_DIR holds couple.h5 of\n"
     "the case; a case with [couple] over another case's couple.h5 is refused); writes RUN_DIR/impact.h5 and\n"
     "impact.xdmf.\n"},
    {"vcrit", "spraycoat vcrit CASE.ini [-o RUN_DIR] [--threads N]",
     "Critical velocity against diameter by bisection of single-particle MPM impacts ([vcrit]); writes\n"
     "RUN_DIR/vcrit.csv and vcrit.h5.  Runs are shared among MPI ranks in the MPI build.\n"},
    {"calibrate", "spraycoat calibrate CASE.ini [-o RUN_DIR] [--threads N]",
     "The bonding calibration of Tang (2021) Sections 4.1.2 and 5.1 ([calibrate]): single-particle MPM impacts of\n"
     "each size at its experimental critical velocity over a grid of the bonding model's two parameters (energy:\n"
     "Gc, Gc_rate; strain: eps_c, eps_rate_c; with reference_diameter each size's set-up scaled to its diameter),\n"
     "each classified bonded or\n"
     "rebounded by the impact verdict (unsettled runs are counted and left out), a second-order logistic\n"
     "regression per size (Eqs. 4.10-4.14), the bonding boundaries h = 0.5 and their intersection, the calibrated\n"
     "pair.  Writes RUN_DIR/calibrate.csv, calibrate_outcomes.csv, calibrate.h5, then the figures and report of\n"
     "the render stage.  Runs are shared among MPI ranks; `spraycoat resume RUN_DIR` reuses finished runs.\n"
     "With [calibrate] method = vcrit instead: the model's first parameter such that the critical velocities of\n"
     "`spraycoat vcrit` searches of the diameters ([vcrit] keys, one run directory RUN_DIR/vcrit_NN per search)\n"
     "meet [calibrate] velocities on average within fit_tolerance (false position from the parameter's _min and\n"
     "_max); writes RUN_DIR/calibrate.csv, calibrate_vcrit.csv and calibrate.h5.\n"},
    {"render", "spraycoat render CASE.ini [-o RUN_DIR] [--every N]",
     "Figures (RUN_DIR/figures/) and RUN_DIR/report.html from the outputs RUN_DIR holds ([render]).\n"
     "--every N (overrides [render] every): films as PNG frames of every Nth snapshot and the last, the plume\n"
     "from spray.h5 in figures/film_plume/ and each impact run in figures/film_impact*/; 0: none.\n"},
    {"sweep", "spraycoat sweep CASE.ini [-o RUN_DIR] [--threads N]",
     "The spray stage for every combination of the values of two case keys ([sweep] x_key, x_values, y_key,\n"
     "y_values; keys of the spray's sections, each value checked like the case file's), each run in\n"
     "RUN_DIR/runs/xI_yJ (a finished run is not run again, an interrupted one resumes from its checkpoint; shared\n"
     "among MPI ranks), then RUN_DIR/sweep.h5 with the deposition efficiency (by mass) and the mean impact speed\n"
     "over the grid, and the render stage's figure of it (figures/sweep_de.png).\n"},
    {"info", "spraycoat info RUN_DIR|FILE.h5",
     "What a run directory or an HDF5 file of spraycoat holds: stages, steps, times, metrics, and whether a\n"
     "process is running in the directory now.\n"},
    {"keys", "spraycoat keys", "Every case-file key as Markdown tables: section, key, unit, default, range.\n"},
    {"help", "spraycoat help [COMMAND]", "This help, or a command's.\n"},
};

static const char command_options[] = "options:\n"
                                      "  -o RUN_DIR      run directory (default runs/CASE_NAME)\n"
                                      "  --threads N     OpenMP threads (overrides [run] threads; 0 = all cores)\n"
                                      "  --device D      where the impact step runs: cpu or gpu (overrides [run] "
                                      "device)\n"
                                      "  -v, --verbose   debug messages;  -q, --quiet   warnings and errors only\n";

/* The help of `name` on stdout; SC_EINPUT for an unknown command. */
static int print_command_help(const char *name)
{
    for (size_t i = 0; i < sizeof command_helps / sizeof command_helps[0]; i++)
        if (strcmp(command_helps[i].name, name) == 0) {
            printf("usage: %s\n\n%s\n%s", command_helps[i].synopsis, command_helps[i].text, command_options);
            return SC_OK;
        }
    SC_FAIL(SC_EINPUT, "unknown command '%s' (see spraycoat --help)", name);
}

/* The stages of `spraycoat run`, in order. */
#define PIPELINE "spray,couple,impact,render"
/* RUN_DIR/stages of a `run`: "run:" and the stages, so that `resume` continues a pipeline as a pipeline */
#define RUN_PREFIX "run:"
/* Longest -o RUN_DIR: room for the names of the files inside within H5IO_PATH_MAX. */
#define RUN_DIR_MAX (H5IO_PATH_MAX - 256)

struct options {
    const char *command;
    const char *target; /* CASE.ini or RUN_DIR or FILE.h5 */
    const char *run_dir;
    const char *threads;
    const char *stages;
    const char *every;  /* render: --every N */
    const char *device; /* --device cpu|gpu */
};

static int parse_arguments(int argc, char **argv, struct options *opt)
{
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (strcmp(arg, "-o") == 0 || strcmp(arg, "--threads") == 0 || strcmp(arg, "--stages") == 0 ||
            strcmp(arg, "--every") == 0 || strcmp(arg, "--device") == 0) {
            if (i + 1 >= argc)
                SC_FAIL(SC_EINPUT, "option %s needs a value", arg);
            if (arg[1] == 'o')
                opt->run_dir = argv[++i];
            else if (strcmp(arg, "--threads") == 0)
                opt->threads = argv[++i];
            else if (strcmp(arg, "--every") == 0)
                opt->every = argv[++i];
            else if (strcmp(arg, "--device") == 0)
                opt->device = argv[++i];
            else
                opt->stages = argv[++i];
        } else if (strcmp(arg, "-v") == 0 || strcmp(arg, "--verbose") == 0) {
            log_set_level(LOG_DEBUG);
        } else if (strcmp(arg, "-q") == 0 || strcmp(arg, "--quiet") == 0) {
            log_set_level(LOG_WARN);
        } else if (arg[0] == '-' && arg[1] != '\0') {
            SC_FAIL(SC_EINPUT, "unknown option '%s' (see spraycoat --help)", arg);
        } else if (!opt->command) {
            opt->command = arg;
        } else if (!opt->target) {
            opt->target = arg;
        } else {
            SC_FAIL(SC_EINPUT, "unexpected argument '%s' (see spraycoat --help)", arg);
        }
    }
    if (!opt->command)
        SC_FAIL(SC_EINPUT, "no command given (see spraycoat --help)");
    /* the files inside (checkpoints/STAGE_NNNNNNNN.h5.tmp, snapshots/...) must fit in a path too */
    if (opt->run_dir && strlen(opt->run_dir) > RUN_DIR_MAX)
        SC_FAIL(SC_EINPUT, "-o RUN_DIR: the path has %zu characters; allowed: at most %d", strlen(opt->run_dir),
                RUN_DIR_MAX);
    /* a run directory that cannot be made is an I/O error (exit 3, as one under a regular file), said as such: a
     * file there was found only when the stage listed RUN_DIR/checkpoints ("Not a directory") */
    struct stat info;
    if (opt->run_dir && stat(opt->run_dir, &info) == 0 && !S_ISDIR(info.st_mode))
        SC_FAIL(SC_EIO, "-o %s: the run directory exists but is not a directory (nothing was written to it)",
                opt->run_dir);
    return SC_OK;
}

/* Several errors of a case file: each on its own line (the recorded message may be cut short), then the
 * recorded message's first line, "FILE: N errors in the case file", which main prints as the error. */
static int report_every_error(const char *every_error)
{
    for (const char *line = every_error; *line;) {
        size_t length = strcspn(line, "\n");
        if (parallel_rank() == 0)
            fprintf(stderr, "spraycoat: %.*s\n", (int)length, line);
        line += length + (line[length] == '\n');
    }
    const char *message = sc_error_message();
    int head = (int)strcspn(message, "\n");
    if (head > 0 && message[head - 1] == ':')
        head--;
    char summary[512];
    snprintf(summary, sizeof summary, "%.*s (above)", head, message);
    SC_FAIL(SC_EINPUT, "%s", summary);
}

static int load_case(const char *path, const struct options *opt, struct case_file **c)
{
    if (!path)
        SC_FAIL(SC_EINPUT, "%s needs a case file (see spraycoat --help)", opt->command);
    char *every_error = NULL;
    int loaded = case_load_reporting(path, spraycoat_registry, c, &every_error);
    if (loaded != SC_OK && every_error && strchr(every_error, '\n'))
        loaded = report_every_error(every_error);
    free(every_error);
    SC_TRY(loaded);
    if (opt->threads || opt->every || opt->device) {
        int status = opt->threads ? case_set(*c, "run", "threads", opt->threads, "command line --threads") : SC_OK;
        if (status == SC_OK && opt->device)
            status = case_set(*c, "run", "device", opt->device, "command line --device");
        if (status == SC_OK && opt->every)
            status = case_set(*c, "render", "every", opt->every, "command line --every");
        if (status != SC_OK) {
            case_free(*c);
            *c = NULL;
            return status;
        }
    }
    return SC_OK;
}

/* With [nozzle] the jet's keys not given come from the nozzle's exit state (dem/params.c map_jet): case_print lists
 * their defaults, which the run does not use; the values it uses follow. */
static void print_nozzle_jet(const struct case_file *c, const struct dem_config *cfg)
{
    if (!cfg->nozzle)
        return;
    const struct dem_gas_field *g = &cfg->gas;
    const struct {
        const char *section, *key;
        double value;
        const char *unit;
    } derived[] = {
        {"jet", "C1", g->c1, "m^(4/3)/s"},
        {"jet", "C3", g->c3, "m^(-1/3)"},
        {"jet", "virtual_origin", g->virtual_origin, "m"},
        {"jet", "core_length", g->core_length, "m"},
        {"jet", "gas_density", g->density, "kg/m3"},
        {"jet", "gas_viscosity", g->kinematic_viscosity, "m2/s"},
        {"jet", "gas_temperature", g->gas_temperature, "K"},
        {"jet", "gas_gamma", g->gas_gamma, "-"},
        {"jet", "gas_constant", g->gas_constant, "J/(kg K)"},
        {"jet", "gas_sutherland", g->gas_sutherland, "K"},
        {"spray", "nozzle_radius", cfg->nozzle_radius, "m"},
    };
    printf("with [nozzle], from its exit state (the defaults listed above are not used):\n");
    for (size_t k = 0; k < sizeof derived / sizeof derived[0]; k++)
        if (!case_is_given(c, derived[k].section, derived[k].key))
            printf("  [%s] %-20s = %.6g %s\n", derived[k].section, derived[k].key, derived[k].value, derived[k].unit);
    printf("  [spray] release speeds: each particle at the nozzle's exit speed of its diameter (spray.h5 /nozzle)\n");
}

/* `spraycoat run` checks [impact] as the pipeline's impact stage, over the couple stage's seeds (a substrate that
 * holds the powder's particles, no mirror planes), which a case made for `spraycoat impact`, `vcrit` or `calibrate`
 * need not meet: check said OK and run refused it (a review).  A case with [couple] was checked as a pipeline
 * already.  The stage's warnings were printed by the check before; this one prints its refusal only. */
static void note_pipeline_refusal(const struct case_file *c)
{
    if (!app_case_section_given(c, "impact") || app_case_section_given(c, "couple"))
        return;
    const struct stage_context pipeline = {.c = c, .pipeline = 1, .impact_from_seeds = 1};
    enum log_level level = log_get_level();
    log_set_level(LOG_QUIET);
    int status = impact_stage_validate(&pipeline);
    log_set_level(level);
    if (status == SC_OK)
        return;
    printf("note: `spraycoat run` (the pipeline, whose impact runs take the spray's particles) refuses this case: %s\n"
           "note: `spraycoat impact`, `vcrit` and `calibrate` run [impact] as it is\n",
           sc_error_message());
    sc_error_clear();
}

static int command_check(const struct options *opt)
{
    struct case_file *c;
    SC_TRY(load_case(opt->target, opt, &c));
    struct dem_config cfg;
    int status, loaded = 0;
    SC_CHECK(status, dem_config_load(c, &cfg), done);
    loaded = 1;
    /* the impact configuration is checked when the case sets any [impact], [vcrit], [calibrate] or [couple] key (a
     * spray case need not name the materials of an impact it never runs; the couple stage's seeds are the impact
     * stage's bodies, and whether [impact]'s substrate holds them is checked there) */
    const struct stage_context ctx = {.c = c};
    if (app_case_section_given(c, "impact") || app_case_section_given(c, "vcrit") ||
        app_case_section_given(c, "calibrate") || app_case_section_given(c, "couple"))
        SC_CHECK(status, impact_stage_validate(&ctx), done);
    if (app_case_section_given(c, "vcrit"))
        SC_CHECK(status, vcrit_stage_validate(&ctx), done);
    if (app_case_section_given(c, "calibrate"))
        SC_CHECK(status, calibrate_stage_validate(&ctx), done);
    if (app_case_section_given(c, "sweep"))
        SC_CHECK(status, sweep_stage_validate(&ctx), done);
    if (app_case_section_given(c, "couple"))
        SC_CHECK(status, couple_stage_validate(&ctx), done);
    case_print(c, stdout);
    print_nozzle_jet(c, &cfg);
    printf("case hash %016llx: OK\n", (unsigned long long)case_hash(c));
    note_pipeline_refusal(c);
done:
    if (loaded)
        dem_config_free(&cfg);
    case_free(c);
    return status;
}

/* Default run directory: runs/<case file name without .ini>. */
static void default_run_dir(const char *case_path, char *out, size_t size)
{
    const char *base = strrchr(case_path, '/');
    base = base ? base + 1 : case_path;
    size_t len = strlen(base);
    if (len > 4 && strcmp(base + len - 4, ".ini") == 0)
        len -= 4;
    snprintf(out, size, "runs/%.*s", (int)len, base);
}

/* The stages a command runs, as recorded in RUN_DIR/stages for `resume`. */
struct stage {
    const char *name;
    int (*validate)(const struct stage_context *ctx);
    int (*run)(const struct stage_context *ctx);
    const char *output;
    int distributed; /* under MPI every rank runs it */
    /* NULL, or what the stage refuses from the contents of its inputs, checked before the run directory is written
     * unless a chosen stage before it writes them anew (check_inputs below) */
    int (*check_inputs)(const struct stage_context *ctx);
};
static const struct stage stages[] = {
    {"spray", spray_stage_validate, spray_stage_run, "spray.h5", 0, NULL},
    {"couple", couple_stage_validate, couple_stage_run, "couple.h5", 0, couple_stage_check_inputs},
    {"impact", impact_stage_validate, impact_stage_run, "impact.h5, impact.xdmf", 1, NULL},
    {"vcrit", vcrit_stage_validate, vcrit_stage_run, "vcrit.csv, vcrit_cor.csv, vcrit.h5", 1, NULL},
    {"calibrate", calibrate_stage_validate, calibrate_stage_run, "calibrate.csv, calibrate.h5", 1, NULL},
    {"sweep", sweep_stage_validate, sweep_stage_run, "runs/, sweep.h5", 1, NULL},
    {"render", render_stage_validate, render_stage_run, "figures/, report.html", 0, NULL},
};

/* The stages a record names (RUN_DIR/stages: "run:" for a pipeline, then comma-separated names) as flags by
 * index of stages[]; unknown names are left out.  1 when the record is a pipeline's. */
static int record_stages(const char *record, int *chosen)
{
    int pipeline = strncmp(record, RUN_PREFIX, strlen(RUN_PREFIX)) == 0;
    for (const char *p = record + (pipeline ? strlen(RUN_PREFIX) : 0); *p;) {
        size_t length = strcspn(p, ",\n");
        for (size_t i = 0; i < sizeof stages / sizeof stages[0]; i++)
            if (strlen(stages[i].name) == length && strncmp(stages[i].name, p, length) == 0)
                chosen[i] = 1;
        p += length + (p[length] != '\0');
    }
    return pipeline;
}

/* What RUN_DIR/stages must say after this command: its own stages, and those of the earlier record when that
 * was made for the same case, so that a later single-stage command never drops the unfinished stages of an
 * interrupted pipeline (resume continues all of them; each skips what is done). */
static void merged_record(const struct case_file *c, const char *run_dir, const char *list, int pipeline, char *record,
                          size_t size)
{
    int chosen[sizeof stages / sizeof stages[0]] = {0};
    char old[256], path[4200];
    struct case_file *old_case = NULL;
    snprintf(path, sizeof path, "%s/stages", run_dir);
    int recorded = access(path, F_OK) == 0; /* without a record (older versions), run_dir_read_stages says "spray" */
    snprintf(path, sizeof path, "%s/case.ini", run_dir);
    if (recorded && access(path, R_OK) == 0 && run_dir_read_stages(run_dir, old, sizeof old) == SC_OK &&
        case_load(path, spraycoat_registry, &old_case) == SC_OK && case_hash(old_case) == case_hash(c))
        pipeline |= record_stages(old, chosen);
    case_free(old_case);
    sc_error_clear();
    record_stages(list, chosen);
    size_t used = (size_t)snprintf(record, size, "%s", pipeline ? RUN_PREFIX : "");
    for (size_t i = 0; i < sizeof stages / sizeof stages[0] && used < size; i++)
        if (chosen[i])
            used += (size_t)snprintf(record + used, size - used, "%s%s",
                                     used > (pipeline ? strlen(RUN_PREFIX) : 0) ? "," : "", stages[i].name);
}

/* Rank 0 makes and locks the run directory and records the stages (RUN_DIR/stages) for `resume`. */
static int prepare_run_dir(const struct case_file *c, const char *run_dir, const char *list, int pipeline)
{
    char record[300];
    merged_record(c, run_dir, list, pipeline, record, sizeof record);
    SC_TRY(run_dir_prepare(run_dir, c));
    return run_dir_write_stages(run_dir, record);
}

/* Under MPI the impact and vcrit stages run on every rank (they share out their runs); the others on rank 0
 * while the rest wait.  Every rank ends with the same status. */
static int failed_on_this_rank; /* a failure of a rank's own task, which only that rank can report */

static int run_stage_on_ranks(const struct stage *stage, const struct stage_context *ctx)
{
    if (stage->distributed) {
        int status = stage->run(ctx);
        failed_on_this_rank = status != SC_OK && status != SC_EINT && status != SC_ETERM;
        return parallel_max_status(status);
    }
    int status = parallel_rank() == 0 ? stage->run(ctx) : SC_OK;
    return parallel_share_status(status);
}

/* The outputs of earlier stages that a stage reads: render draws whichever are there; couple needs the spray's,
 * impact the couple's seeds in a pipeline (ctx->impact_from_seeds), and a case with [couple] may not meet another
 * case's seeds. */
static int stage_inputs(const struct stage_context *ctx, const char *stage, const char **inputs, int *required)
{
    int n = 0;
    if (strcmp(stage, "couple") == 0)
        inputs[n] = "spray", required[n++] = 1;
    else if (strcmp(stage, "impact") == 0 && ctx->impact_from_seeds)
        inputs[n] = "couple", required[n++] = 1;
    else if (strcmp(stage, "impact") == 0 && app_case_section_given(ctx->c, "couple"))
        /* a case of the pipeline over another case's seeds: refused, not run on [impact]'s own bodies in their
         * place (it wrote a single particle's impact.h5 over the seeded runs') */
        inputs[n] = "couple", required[n++] = 0;
    else if (strcmp(stage, "render") == 0)
        for (size_t k = 0; render_stage_inputs[k]; k++)
            inputs[n] = render_stage_inputs[k], required[n++] = 0;
    return n;
}

/* Whether chosen stage `input`, before stage i, will write its output anew: chosen, and its output not already this
 * case's (the stage skips it then: `spraycoat run` over a finished spray reads the spray.h5 that is there). */
static int made_anew(const struct stage_context *ctx, const struct stage *const *chosen, int i, const char *input)
{
    for (int j = 0; j < i; j++)
        if (strcmp(chosen[j]->name, input) == 0) {
            char path[4200];
            snprintf(path, sizeof path, "%s/%s.h5", ctx->run_dir, input);
            return !run_dir_output_current(path, stage_hash(ctx, input));
        }
    return 0;
}

/* The inputs of the chosen stages that no chosen stage before them makes are checked (this case's, present when
 * needed) before the run directory is touched: the stage refused them only after case.ini and the record of the
 * stages were written over those of the run whose outputs they are (a `render` of another case left the directory
 * naming a case none of its results are of).  So are their contents, where a stage refuses some (check_inputs of
 * stages[]), unless a chosen stage before it writes them anew: `spraycoat couple` with more runs than spray.h5 has
 * particles at the target replaced case.ini and stages, then refused the case, and `resume` of the run failed on it
 * ever after.  Inputs written anew by this command come with this case's case.ini: a refusal of their contents then
 * leaves a directory of one case. */
static int check_inputs(const struct stage_context *ctx, const struct stage *const *chosen, int count)
{
    for (int i = 0; i < count; i++) {
        const char *inputs[8];
        int required[8], n = stage_inputs(ctx, chosen[i]->name, inputs, required), anew = 0;
        for (int k = 0; k < n; k++) {
            int made_here = 0;
            for (int j = 0; j < i; j++)
                made_here |= strcmp(chosen[j]->name, inputs[k]) == 0;
            if (chosen[i]->check_inputs)
                anew |= made_anew(ctx, chosen, i, inputs[k]);
            /* another case's output of a stage this case does not have: the render stage leaves it out */
            if (strcmp(chosen[i]->name, "render") == 0 && render_stage_ignores(ctx, inputs[k]))
                continue;
            if (!made_here)
                SC_TRY(run_dir_check_input(ctx, inputs[k], chosen[i]->name, required[k]));
        }
        if (chosen[i]->check_inputs && !anew)
            SC_TRY(chosen[i]->check_inputs(ctx));
    }
    return SC_OK;
}

static const struct stage *find_stage(const char *name, size_t length)
{
    for (size_t i = 0; i < sizeof stages / sizeof stages[0]; i++)
        if (strlen(stages[i].name) == length && strncmp(stages[i].name, name, length) == 0)
            return &stages[i];
    return NULL;
}

/* list: comma-separated stage names; pipeline: 1 for `run` (its impact stage takes the couple stage's seeds).
 * Every stage is validated before the run directory is touched. */
static int run_stages(struct case_file *c, const char *run_dir, const char *list, int pipeline)
{
    const struct stage *chosen[8];
    int count = 0;
    if (list[strspn(list, ", ")] == '\0')
        SC_FAIL(SC_EINPUT, "no stage to run ('%s'; allowed: spray, couple, impact, vcrit, calibrate, sweep, render)",
                list);
    for (const char *p = list; *p;) {
        size_t length = strcspn(p, ",");
        const struct stage *stage = find_stage(p, length);
        if (!stage || count == 8)
            SC_FAIL(SC_EINPUT,
                    "unknown stage '%.*s' in '%s' (allowed: spray, couple, impact, vcrit, calibrate, sweep, render)",
                    (int)length, p, list);
        int repeated = 0;
        for (int i = 0; i < count; i++)
            repeated |= chosen[i] == stage;
        if (!repeated)
            chosen[count++] = stage;
        p += length + (p[length] == ',');
    }
    /* stages run in pipeline order whatever the order of the list */
    for (int i = 1; i < count; i++)
        for (int j = i; j > 0 && chosen[j] < chosen[j - 1]; j--) {
            const struct stage *swap = chosen[j];
            chosen[j] = chosen[j - 1];
            chosen[j - 1] = swap;
        }
    /* the impact stage takes the couple stage's seeds in a pipeline, and on its own when couple.h5 of this case is
     * there (`spraycoat impact` as one stage of a run made by `spraycoat run`) */
    const struct stage_context ctx = {.c = c,
                                      .run_dir = run_dir,
                                      .pipeline = pipeline,
                                      .impact_from_seeds =
                                          pipeline || (strstr(list, "impact") && run_dir_has_seeds(c, run_dir))};
    /* one process per run directory, and before anything there is read (its checkpoints by the validation) */
    SC_TRY(parallel_share_status(parallel_rank() == 0 ? run_dir_lock_existing(run_dir) : SC_OK));
    /* a case that fails validation must not touch the run directory (no case.ini over a good run's) */
    for (int i = 0; i < count; i++)
        SC_TRY(chosen[i]->validate(&ctx));
    SC_TRY(parallel_share_status(parallel_rank() == 0 ? check_inputs(&ctx, chosen, count) : SC_OK));
    SC_TRY(parallel_share_status(parallel_rank() == 0 ? prepare_run_dir(c, run_dir, list, pipeline) : SC_OK));
    interrupt_install();
    for (int i = 0; i < count; i++) {
        SC_TRY(run_stage_on_ranks(chosen[i], &ctx));
        if (parallel_rank() == 0)
            log_info("results in %s (%s); `spraycoat info %s` summarises them", run_dir, chosen[i]->output, run_dir);
    }
    /* every stage done (every rank past the last stage's collective end): the checkpoints folder, emptied by the
     * stages as they finished, goes too; one that still holds a file (another stage's, interrupted) stays */
    if (parallel_rank() == 0) {
        char folder[4200];
        snprintf(folder, sizeof folder, "%s/checkpoints", run_dir);
        rmdir(folder);
    }
    return SC_OK;
}

static int command_run(const struct options *opt, const char *list, int pipeline)
{
    struct case_file *c;
    SC_TRY(load_case(opt->target, opt, &c));
    char run_dir[4096];
    if (opt->run_dir)
        snprintf(run_dir, sizeof run_dir, "%s", opt->run_dir);
    else
        default_run_dir(opt->target, run_dir, sizeof run_dir);
    int status = run_stages(c, run_dir, list, pipeline);
    case_free(c);
    return status;
}

/* The summary `run` and `resume` end with: what the finished run says. */
static void print_results(const char *run_dir)
{
    printf("results in %s:\n", run_dir);
    info_headline(run_dir, stdout);
}

/* `run`: the pipeline.  Without --stages: spray, then couple and impact when the case describes them ([couple] or
 * [impact] given; a spray-only case goes from the spray to the render), then render. */
static int command_pipeline(const struct options *opt)
{
    if (opt->stages)
        return command_run(opt, opt->stages, 1);
    struct case_file *c;
    SC_TRY(load_case(opt->target, opt, &c));
    int whole = app_case_section_given(c, "couple") || app_case_section_given(c, "impact");
    case_free(c);
    if (!whole)
        log_info("run: the case has no [couple] or [impact] section: no impact runs");
    SC_TRY(command_run(opt, whole ? PIPELINE : "spray,render", 1));
    if (parallel_rank() == 0) {
        char run_dir[4096];
        if (opt->run_dir)
            snprintf(run_dir, sizeof run_dir, "%s", opt->run_dir);
        else
            default_run_dir(opt->target, run_dir, sizeof run_dir);
        print_results(run_dir);
    }
    return SC_OK;
}

/* Continue the stages of the command that made RUN_DIR (RUN_DIR/stages; "spray" when absent) with the case it
 * recorded (RUN_DIR/case.ini).  Each stage skips what is done and resumes from its newest checkpoint. */
static int command_resume(const struct options *opt)
{
    if (!opt->target)
        SC_FAIL(SC_EINPUT, "resume needs a run directory (see spraycoat --help)");
    if (opt->run_dir) /* it was ignored: the results went on into RUN_DIR, not where -o said */
        SC_FAIL(SC_EINPUT,
                "resume continues %s where it is; -o goes with run and the stage commands (to run its case into "
                "another directory: spraycoat run %s/case.ini -o %s)",
                opt->target, opt->target, opt->run_dir);
    char case_path[4096], list[256];
    snprintf(case_path, sizeof case_path, "%s/case.ini", opt->target);
    if (access(case_path, R_OK) != 0)
        SC_FAIL(SC_EIO, "%s is not a run directory: cannot read %s", opt->target, case_path);
    SC_TRY(run_dir_read_stages(opt->target, list, sizeof list));
    struct case_file *c;
    SC_TRY(load_case(case_path, opt, &c));
    log_info("resuming %s: stages %s", opt->target, list);
    int pipeline = strncmp(list, RUN_PREFIX, strlen(RUN_PREFIX)) == 0;
    int status = run_stages(c, opt->target, list + (pipeline ? strlen(RUN_PREFIX) : 0), pipeline);
    case_free(c);
    SC_TRY(status);
    if (parallel_rank() == 0)
        print_results(opt->target);
    return SC_OK;
}

/* ---- OpenMP's wait policy ---------------------------------------------------------------------------------
 * libgomp reads OMP_WAIT_POLICY (and GOMP_SPINCOUNT) once, when it is loaded, before main.  Unset, a thread that
 * waits at a barrier spins 300,000 times before it sleeps: on a machine whose cores are busy with other work, the
 * spinning threads take the time the working ones need (2 threads on a loaded 2-core machine ran 4x slower than
 * with a passive wait; docs/performance.md).  On an idle machine the passive wait costs instead: a thread that
 * sleeps at every barrier is woken late, and the spray's short loops ran 2.6x slower.  So a command that computes
 * runs itself again, once, with OMP_WAIT_POLICY=passive when the user has not set the variable and the machine is
 * busy when it starts; a value the user set is kept as it is. */
#define REEXEC_MARK "SPRAYCOAT_PASSIVE_WAIT" /* set in the environment of the run again: not twice */

/* The command of argv (its first word that is not an option or an option's value), NULL if none. */
static const char *command_word(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-o") == 0 || strcmp(argv[i], "--threads") == 0 || strcmp(argv[i], "--stages") == 0 ||
            strcmp(argv[i], "--device") == 0)
            i++;
        else if (argv[i][0] != '-')
            return argv[i];
    }
    return NULL;
}

/* The commands that run OpenMP loops; the others (check, info, keys, help) are not worth a second start. */
static int computes(const char *command)
{
    static const char *const computing[] = {"run",   "resume",    "spray",  "couple", "impact",
                                            "vcrit", "calibrate", "render", "sweep"};
    for (size_t i = 0; command && i < sizeof computing / sizeof computing[0]; i++)
        if (strcmp(command, computing[i]) == 0)
            return 1;
    return 0;
}

/* Under valgrind, /proc/self/exe is valgrind's tool, not spraycoat, and a second start would run outside valgrind
 * (unless it traces children): its preloaded core library in LD_PRELOAD tells. */
static int under_valgrind(void)
{
    const char *preload = getenv("LD_PRELOAD");
    return preload && strstr(preload, "vgpreload") != NULL;
}

/* Busy: other work already keeps the cores running, the 1-minute load average at least the online cores less one
 * half (a 2-core machine with nothing else to do shows about 1 here).  Unknown counts as busy, the safe choice. */
static int machine_busy(double *load, long *cores)
{
    *load = NAN;
    *cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (getloadavg(load, 1) != 1 || *cores < 1)
        return 1;
    return *load >= (double)*cores - 0.5;
}

static void prefer_passive_wait(int argc, char **argv)
{
    const char *policy = getenv("OMP_WAIT_POLICY");
    double load;
    long cores;
    if ((policy && *policy) || getenv(REEXEC_MARK) || !computes(command_word(argc, argv)) || under_valgrind() ||
        !machine_busy(&load, &cores))
        return;
    if (setenv("OMP_WAIT_POLICY", "passive", 1) == 0 && setenv(REEXEC_MARK, "1", 1) == 0)
        execv("/proc/self/exe", argv);
    /* no /proc (or no memory): run on with libgomp's default, and do not claim a passive wait */
    unsetenv("OMP_WAIT_POLICY");
    unsetenv(REEXEC_MARK);
}

/* The wait policy of this process (or, for --version, that of the commands that compute). */
static void describe_wait_policy(char *out, size_t size, int computing)
{
    const char *policy = getenv("OMP_WAIT_POLICY");
    if (policy && !*policy)
        policy = NULL; /* libgomp takes an empty value as unset */
    double load;
    long cores;
    int busy = machine_busy(&load, &cores);
    if (policy && getenv(REEXEC_MARK))
        snprintf(out, size, "%s (set by spraycoat: OMP_WAIT_POLICY was unset and the machine busy)", policy);
    else if (policy)
        snprintf(out, size, "%.64s (OMP_WAIT_POLICY of the environment)", policy);
    else if (computing)
        snprintf(out, size, "libgomp's default, spin then sleep (the machine was idle: load %.2f on %ld cores)", load,
                 cores);
    else
        snprintf(out, size,
                 "passive for the commands that compute when the machine is busy (load average >= cores - 0.5; "
                 "now %.2f on %ld cores: %s), else libgomp's default; OMP_WAIT_POLICY overrides",
                 load, cores, busy ? "busy" : "idle");
}

static int dispatch(const struct options *opt)
{
    const char *command = opt->command;
    if (strcmp(command, "check") == 0)
        return command_check(opt);
    if (strcmp(command, "run") == 0)
        return command_pipeline(opt);
    if (opt->stages)
        SC_FAIL(SC_EINPUT, "--stages goes with the run command (see spraycoat --help)");
    if (opt->every && strcmp(command, "render") != 0)
        SC_FAIL(SC_EINPUT, "--every goes with the render and run commands (see spraycoat help render)");
    if (strcmp(command, "spray") == 0 || strcmp(command, "couple") == 0 || strcmp(command, "impact") == 0 ||
        strcmp(command, "vcrit") == 0 || strcmp(command, "render") == 0)
        return command_run(opt, command, 0);
    if (strcmp(command, "calibrate") == 0)
        return command_run(opt, "calibrate,render", 0);
    if (strcmp(command, "sweep") == 0)
        return command_run(opt, "sweep,render", 0);
    if (strcmp(command, "resume") == 0)
        return command_resume(opt);
    if (strcmp(command, "info") == 0)
        return info_print(opt->target, stdout);
    if (strcmp(command, "help") == 0) {
        if (!opt->target) {
            fputs(usage, stdout);
            return SC_OK;
        }
        return print_command_help(opt->target);
    }
    if (strcmp(command, "keys") == 0) {
        if (opt->target)
            SC_FAIL(SC_EINPUT, "keys takes no argument (see spraycoat --help)");
        case_registry_markdown(spraycoat_registry, stdout);
        return SC_OK;
    }
    SC_FAIL(SC_EINPUT, "unknown command '%s' (see spraycoat --help)", command);
}

/* The semantic version first, then the build record that every output's /code group holds (program_version, the
 * git description, shown as "git"), the units database read for case files and the OpenMP wait policy the
 * commands that compute run with. */
static void print_version(void)
{
    const struct spraycoat_build_item *items = spraycoat_build_info();
    for (const struct spraycoat_build_item *item = items; item->name; item++)
        if (strcmp(item->name, "version") == 0)
            printf("spraycoat %s\n", item->value);
    for (const struct spraycoat_build_item *item = items; item->name; item++)
        if (strcmp(item->name, "version") != 0)
            printf("  %-12s %s\n", strcmp(item->name, "program_version") == 0 ? "git" : item->name, item->value);
    printf("  %-12s %s\n", "gpu", mpm_gpu_build());
    printf("  %-12s %s\n", "udunits2", units_database_path());
    char policy[256];
    describe_wait_policy(policy, sizeof policy, 0);
    printf("  %-12s %s\n", "omp_wait", policy);
}

int main(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            /* `spraycoat COMMAND --help`: the command's help; the general one otherwise */
            const char *command = i > 1 && argv[1][0] != '-' ? argv[1] : NULL;
            if (!command || strcmp(command, "help") == 0) {
                fputs(usage, stdout);
                return 0;
            }
            int status = print_command_help(command);
            if (status != SC_OK)
                fprintf(stderr, "spraycoat: %s\n", sc_error_message());
            return status;
        }
        if (strcmp(argv[i], "--version") == 0) {
            if (argc > 2) { /* `spraycoat run x.ini --version` ran nothing and said so only by its output */
                fprintf(stderr, "spraycoat: --version takes no other argument (see spraycoat --help)\n");
                return SC_EINPUT;
            }
            print_version();
            return 0;
        }
    }
    prefer_passive_wait(argc, argv);
    memory_heap_init(); /* before anything large is allocated */
    /* HDF5's exit-time cleanup can crash on a file whose close failed (full disk, file-size limit);
     * every file spraycoat writes is closed or abandoned explicitly, so the cleanup is not needed */
    H5dont_atexit();
    h5_quiet();
    /* a file-size limit must give EFBIG and exit status 3, not kill the process mid-write */
    signal(SIGXFSZ, SIG_IGN);
    parallel_init(&argc, &argv);
    char origin[32] = "";
    if (parallel_rank() > 0)
        snprintf(origin, sizeof origin, "[rank %d]", parallel_rank());
    log_set_origin(origin);
    struct options opt = {0};
    int status = parse_arguments(argc, argv, &opt);
    if (status == SC_OK && computes(opt.command)) {
        char policy[256];
        describe_wait_policy(policy, sizeof policy, 1);
        log_debug("OpenMP wait policy: %s", policy);
    }
    if (status != SC_OK)
        sc_error_trace(__FILE__, __LINE__);
    else if ((status = dispatch(&opt)) != SC_OK)
        sc_error_trace(__FILE__, __LINE__);
    /* the rank where it happened says what went wrong (rank 0 also for what every rank saw) */
    if (status != SC_OK && sc_error_message()[0] && (parallel_rank() == 0 || failed_on_this_rank)) {
        fprintf(stderr, "spraycoat%s: %s\n", origin, sc_error_message());
        if (log_get_level() >= LOG_DEBUG)
            fprintf(stderr, "%s\n", sc_error_traceback());
    }
    parallel_finalize();
    return status;
}
