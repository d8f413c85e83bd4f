/* The render stage: figures and report.html from whatever RUN_DIR holds (render/ draws them). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/log.h"
#include "coupling/stages.h"
#include "render/render.h"

int render_stage_validate(const struct case_file *c, const char *run_dir)
{
    (void)run_dir; /* the outputs to draw are looked for when the stage runs: an earlier stage may make them */
    struct render_config cfg;
    return render_config_load(c, &cfg);
}

/* The report's case summary: every key the case file or the command line gives (not the defaults). */
static int case_rows(const struct case_file *c, struct render_case_row **rows, int *count)
{
    int capacity = 0;
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++)
            capacity++;
    *rows = calloc((size_t)capacity + 1, sizeof **rows);
    if (!*rows)
        SC_FAIL(SC_ESIM, "out of memory");
    *count = 0;
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++) {
            if (strchr(k->section, '*') || !case_is_given(c, k->section, k->key))
                continue; /* [material.NAME] keys are per material; the resolved case.ini holds them */
            (*rows)[(*count)++] = (struct render_case_row){k->section, k->key, case_text(c, k->section, k->key),
                                                           k->unit};
        }
    return SC_OK;
}

int render_stage_run(const struct case_file *c, const char *run_dir)
{
    struct render_config cfg;
    SC_TRY(render_config_load(c, &cfg));
    struct render_request req = {.run_dir = run_dir, .cfg = &cfg, .c = c, .case_hash = case_hash(c)};
    struct render_case_row *rows;
    SC_TRY(case_rows(c, &rows, &req.row_count));
    req.rows = rows;
    double start = log_elapsed();
    struct render_output out;
    int status = render_run_dir(&req, &out);
    if (status == SC_OK)
        log_info("render: %d figures, %d frames in %.1f s", out.count, out.frames, log_elapsed() - start);
    render_output_free(&out);
    free(rows);
    return status;
}
