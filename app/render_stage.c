/* The render stage: figures and report.html from whatever RUN_DIR holds (render/ draws them). */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/version.h"
#include "app/app.h"
#include "render/render.h"

int render_stage_validate(const struct stage_context *ctx)
{
    /* the outputs to draw are looked for when the stage runs: an earlier stage may make them */
    struct render_config cfg;
    return render_config_load(ctx->c, &cfg);
}

static int render_stage_draw(const struct case_file *c, const char *run_dir, const char *const *ignored,
                             int ignored_count);

/* The report's case summary: every key the case file or the command line gives (not the defaults). */
static int case_rows(const struct case_file *c, struct render_case_row **rows, int *count)
{
    int capacity = 0;
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++)
            capacity++;
    *rows = calloc((size_t)capacity + 1, sizeof **rows);
    if (!*rows)
        SC_FAIL_OOM(((size_t)capacity + 1) * sizeof **rows, "the report's case summary");
    *count = 0;
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++) {
            if (strchr(k->section, '*') || !case_is_given(c, k->section, k->key))
                continue; /* [material.NAME] keys are per material; the resolved case.ini holds them */
            (*rows)[(*count)++] =
                (struct render_case_row){k->section, k->key, case_text(c, k->section, k->key), k->unit};
        }
    return SC_OK;
}

/* What the figures depend on, as one line: the program (git describe), the [render] values and the identity (case
 * hash and creation time) of every input file present.  A pipeline run skips the stage when
 * RUN_DIR/figures/render.stamp holds it and report.html exists; `spraycoat render` always draws. */
static void render_fingerprint(const struct case_file *c, const char *run_dir, char *out, size_t size)
{
    static const char *const inputs[] = {"spray.h5", "impact.h5", "vcrit.h5", "calibrate.h5", "sweep.h5"};
    /* the program too: render/ is not in sources_id, and a new drawing code draws the figures again */
    size_t used = (size_t)snprintf(out, size, "program=%s;", spraycoat_version());
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++)
            if (strcmp(k->section, "render") == 0 && case_has(c, "render", k->key) && used < size)
                used += (size_t)snprintf(out + used, size - used, "%s=%s;", k->key, case_text(c, "render", k->key));
    for (size_t i = 0; i < sizeof inputs / sizeof inputs[0] && used < size; i++) {
        char path[4200], hash[64] = "-", created[64] = "-";
        snprintf(path, sizeof path, "%s/%s", run_dir, inputs[i]);
        hid_t file;
        if (access(path, R_OK) == 0 && h5_open_read(path, &file) == SC_OK) {
            h5_attr_read_string(file, "case_hash", hash, sizeof hash);
            h5_attr_read_string(file, "created", created, sizeof created);
            H5Fclose(file);
        }
        used += (size_t)snprintf(out + used, size - used, "%s:%s@%s;", inputs[i], hash, created);
    }
    sc_error_clear();
}

static void stamp_path(const char *run_dir, char *out, size_t size)
{
    snprintf(out, size, "%s/figures/render.stamp", run_dir);
}

static int figures_current(const char *run_dir, const char *fingerprint)
{
    char path[4200], line[4096] = "";
    snprintf(path, sizeof path, "%s/report.html", run_dir);
    if (access(path, R_OK) != 0)
        return 0;
    stamp_path(run_dir, path, sizeof path);
    FILE *file = fopen(path, "r");
    if (!file)
        return 0;
    int same = fgets(line, sizeof line, file) && strcmp(line, fingerprint) == 0;
    fclose(file);
    return same;
}

static int write_stamp(const char *run_dir, const char *fingerprint)
{
    char path[4200];
    stamp_path(run_dir, path, sizeof path);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    fputs(fingerprint, out.stream);
    return atomic_publish(&out);
}

const char *const render_stage_inputs[] = {"spray", "impact", "vcrit", "calibrate", "sweep", NULL};

/* The sections that give a case the stage: a case without any of them has no such stage (`spraycoat run` does not
 * run it, and its own command refuses the case or computes nothing of it). */
static const char *stage_sections(const char *stage)
{
    static const char *const table[][2] = {{"spray", "spray"}, {"couple", "couple"},       {"impact", "impact,couple"},
                                           {"vcrit", "vcrit"}, {"calibrate", "calibrate"}, {"sweep", "sweep"}};
    for (size_t k = 0; k < sizeof table / sizeof table[0]; k++)
        if (strcmp(table[k][0], stage) == 0)
            return table[k][1];
    return NULL;
}

static int case_has_stage(const struct case_file *c, const char *stage)
{
    const char *sections = stage_sections(stage);
    if (!sections)
        return 1;
    char section[32];
    for (const char *p = sections; *p;) {
        size_t length = strcspn(p, ",");
        snprintf(section, sizeof section, "%.*s", (int)length, p);
        if (app_case_section_given(c, section))
            return 1;
        p += length + (p[length] == ',');
    }
    return 0;
}

int render_stage_ignores(const struct stage_context *ctx, const char *stage)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s.h5", ctx->run_dir, stage);
    if (access(path, F_OK) != 0 || case_has_stage(ctx->c, stage))
        return 0;
    return run_dir_made_by_case(ctx, stage, path) != 1; /* another case's, or not readable as this case's */
}

int render_stage_run(const struct stage_context *ctx)
{
    const struct case_file *c = ctx->c;
    const char *run_dir = ctx->run_dir;
    /* an output of a stage this case does not have, made by another case (a run of that case into the same
     * directory left it), is not this case's result: left out of the figures and the report, with a line that
     * says so; the advice to run that stage again could not be followed (the case has none) */
    static const char *const readable[] = {"spray", "couple", "impact", "vcrit", "calibrate", "sweep"};
    static char ignored_names[sizeof readable / sizeof readable[0]][32];
    const char *ignored[sizeof readable / sizeof readable[0]];
    int ignored_count = 0;
    for (size_t i = 0; i < sizeof readable / sizeof readable[0]; i++)
        if (render_stage_ignores(ctx, readable[i])) {
            snprintf(ignored_names[ignored_count], sizeof ignored_names[0], "%s.h5", readable[i]);
            ignored[ignored_count] = ignored_names[ignored_count];
            ignored_count++;
            log_info("render: %s/%s.h5 is not this case's (another case made it, and this case has no %s stage: "
                     "no [%s]): left out of the figures and report.html",
                     run_dir, readable[i], readable[i],
                     strcmp(readable[i], "impact") == 0 ? "impact] or [couple" : readable[i]);
        }
    /* refuse, not warn: the report names this case's keys and hash above the figures, so figures of another
     * case's file would be wrong results under a right-looking label (exit 3, the same as couple and impact) */
    for (size_t i = 0; render_stage_inputs[i]; i++)
        if (!render_stage_ignores(ctx, render_stage_inputs[i]))
            SC_TRY(run_dir_check_input(ctx, render_stage_inputs[i], "render", 0));
    char fingerprint[4096];
    render_fingerprint(c, run_dir, fingerprint, sizeof fingerprint);
    /* and what is left out: a report of another case that drew the file is not this one's, up to date */
    for (int k = 0; k < ignored_count; k++) {
        size_t used = strlen(fingerprint);
        snprintf(fingerprint + used, sizeof fingerprint - used, "left out:%s;", ignored[k]);
    }
    if (ctx->pipeline && figures_current(run_dir, fingerprint)) {
        log_info("render: the figures and %s/report.html are up to date; nothing to do", run_dir);
        return SC_OK;
    }
    SC_TRY(render_stage_draw(c, run_dir, ignored, ignored_count));
    return write_stamp(run_dir, fingerprint);
}

/* The report's notices on the run's state: each stage RUN_DIR/stages asks for whose output is missing (interrupted
 * when it left checkpoints), and each drawn input made by another build (docs/architecture.md "Another build"). */
enum { NOTICES_MAX = 16, NOTICE_LENGTH = 600 };

static void add_notice(char (*notices)[NOTICE_LENGTH], int *count, const char *format, ...)
    __attribute__((format(printf, 3, 4)));
static void add_notice(char (*notices)[NOTICE_LENGTH], int *count, const char *format, ...)
{
    if (*count >= NOTICES_MAX)
        return;
    va_list args;
    va_start(args, format);
    vsnprintf(notices[(*count)++], NOTICE_LENGTH, format, args);
    va_end(args);
}

static int is_ignored(const char *name, const char *const *ignored, int ignored_count)
{
    for (int k = 0; k < ignored_count; k++)
        if (strcmp(ignored[k], name) == 0)
            return 1;
    return 0;
}

static void run_state_notices(const char *run_dir, const char *const *ignored, int ignored_count,
                              char (*notices)[NOTICE_LENGTH], int *count)
{
    static const char *const stages[] = {"spray", "couple", "impact", "vcrit", "calibrate", "sweep"};
    char asked[256], path[4200], newest[4400], sources[64];
    if (run_dir_read_stages(run_dir, asked, sizeof asked) != SC_OK)
        sc_error_clear(), asked[0] = '\0';
    for (size_t k = 0; k < sizeof stages / sizeof stages[0]; k++) {
        snprintf(path, sizeof path, "%s/%s.h5", run_dir, stages[k]);
        int done = access(path, R_OK) == 0;
        size_t checkpoints = run_dir_stage_checkpoints(run_dir, stages[k], newest, sizeof newest);
        if (!done && strstr(asked, stages[k]))
            add_notice(notices, count,
                       "The %s stage asked for (RUN_DIR/stages: %s) has no result: %s. What this report shows "
                       "does not include it.",
                       stages[k], asked,
                       checkpoints ? "it was interrupted (its checkpoints are kept: the same command resumes it)"
                                   : "it has not run");
        char name[64];
        snprintf(name, sizeof name, "%s.h5", stages[k]);
        if (done && is_ignored(name, ignored, ignored_count)) {
            add_notice(notices, count,
                       "%s in the run directory is another case's result (this case has no %s stage): it is left "
                       "out of this report. Give each case a run directory of its own.",
                       name, stages[k]);
            continue;
        }
        hid_t file;
        if (done && h5_open_read(path, &file) == SC_OK) {
            if (!h5_same_sources(file, sources, sizeof sources))
                add_notice(notices, count,
                           "%s.h5 was made by another build of spraycoat (sources %s, this build's %s): running its "
                           "stage again computes it with this one.",
                           stages[k], sources, spraycoat_sources_id());
            H5Fclose(file);
        }
        sc_error_clear();
    }
}

static int render_stage_draw(const struct case_file *c, const char *run_dir, const char *const *ignored,
                             int ignored_count)
{
    struct render_config cfg;
    SC_TRY(render_config_load(c, &cfg));
    struct render_request req = {.run_dir = run_dir,
                                 .cfg = &cfg,
                                 .c = c,
                                 .case_hash = case_hash(c),
                                 .ignored = ignored,
                                 .ignored_count = ignored_count};
    struct render_case_row *rows;
    SC_TRY(case_rows(c, &rows, &req.row_count));
    req.rows = rows;
    char notices[NOTICES_MAX][NOTICE_LENGTH];
    const char *notice_lines[NOTICES_MAX];
    run_state_notices(run_dir, ignored, ignored_count, notices, &req.notice_count);
    for (int k = 0; k < req.notice_count; k++)
        notice_lines[k] = notices[k];
    req.notices = notice_lines;
    double start = log_elapsed();
    struct render_output out;
    int status;
    SC_CHECK(status, render_run_dir(&req, &out), done);
    log_info("render: %d figures, %d frames in %.1f s", out.count, out.frames, log_elapsed() - start);
done:
    render_output_free(&out);
    free(rows);
    return status;
}
