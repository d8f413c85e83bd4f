/* The one stage loop (app/app.h "the one stage loop"): resume, checkpoints by the [run] policy, signals, progress,
 * timing and the stage's atomic output, for every stage that steps a solver. */
#include <stdio.h>
#include <stdlib.h>

#include "app/app.h"
#include "core/error.h"
#include "core/h5io.h"
#include "core/interrupt.h"
#include "core/log.h"

/* What the loop keeps between checkpoints. */
struct loop_state {
    int64_t last_checkpoint_step;
    double last_checkpoint_time; /* log_elapsed() */
};

static int checkpoint_due(const struct stage_ops *ops, const struct loop_state *state, int64_t step)
{
    const struct run_settings *settings = ops->settings;
    if (!settings || !ops->checkpoint_write)
        return 0;
    if (settings->checkpoint_steps > 0 && step - state->last_checkpoint_step >= settings->checkpoint_steps)
        return 1;
    return settings->checkpoint_wall > 0 && log_elapsed() - state->last_checkpoint_time >= settings->checkpoint_wall;
}

static int write_checkpoint(const struct stage_ops *ops, struct loop_state *state)
{
    int64_t step, progress;
    double t;
    ops->position(ops->owner, &step, &t, &progress);
    struct h5_out out;
    SC_TRY(h5_checkpoint_begin(ops->run_dir, ops->label, step, &out));
    int status;
    SC_CHECK(status, h5_write_root_attributes(out.file, ops->format, ops->format_version, ops->stage, ops->case_hash),
             done);
    SC_CHECK(status, ops->checkpoint_write(ops->owner, out.file), done);
done:
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_checkpoint_commit(&out, ops->run_dir, ops->label, ops->settings->keep_checkpoints));
    state->last_checkpoint_time = log_elapsed();
    state->last_checkpoint_step = step;
    log_info("%s: checkpoint at step %lld (t = %.6g s)", ops->label, (long long)step, t);
    return SC_OK;
}

int stage_loop_resume(const struct stage_ops *ops, int *resumed)
{
    *resumed = 0;
    if (!ops->checkpoint_read)
        return SC_OK;
    char path[H5IO_PATH_MAX];
    SC_TRY(h5_checkpoint_find_newest(ops->run_dir, ops->label, ops->format, ops->format_version, ops->case_hash, path,
                                     sizeof path));
    if (path[0] == '\0')
        return SC_OK;
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    int status = ops->checkpoint_read(ops->owner, file);
    H5Fclose(file);
    SC_TRY(status);
    int64_t step, progress;
    double t;
    ops->position(ops->owner, &step, &t, &progress);
    *resumed = 1;
    log_info("%s: resuming from %s (step %lld, t = %.6g s)", ops->label, path, (long long)step, t);
    return SC_OK;
}

/* A call's wall time added to *seconds. */
#define TIMED(seconds, call)                                                                                           \
    do {                                                                                                               \
        double timed_start_ = log_elapsed();                                                                           \
        int timed_status_ = (call);                                                                                    \
        *(seconds) += log_elapsed() - timed_start_;                                                                    \
        SC_TRY(timed_status_);                                                                                         \
    } while (0)

/* One step and what follows it: after-step work, a checkpoint when due or interrupted, the progress line. */
static int loop_step(const struct stage_ops *ops, struct loop_state *state, struct progress *bar,
                     struct stage_timing *timing)
{
    TIMED(&timing->stepping, ops->step(ops->owner));
    if (ops->after_step)
        TIMED(&timing->after_step, ops->after_step(ops->owner));
    int64_t step, progress;
    double t;
    ops->position(ops->owner, &step, &t, &progress);
    int interrupted = interrupt_status();
    int can_checkpoint = ops->settings && ops->checkpoint_write;
    if ((interrupted && can_checkpoint) || (checkpoint_due(ops, state, step) && !ops->finished(ops->owner)))
        TIMED(&timing->checkpoints, write_checkpoint(ops, state));
    if (interrupted) {
        log_progress_stop(bar, progress);
        SC_FAIL(interrupted, "%s: interrupted at step %lld (t = %.6g s); %s", ops->label, (long long)step, t,
                ops->interrupted_note);
    }
    char text[200] = "";
    if (ops->describe)
        ops->describe(ops->owner, text, sizeof text);
    log_progress_update(bar, progress, ops->describe ? text : NULL);
    return SC_OK;
}

int stage_loop_run(const struct stage_ops *ops, struct stage_timing *timing)
{
    *timing = (struct stage_timing){0};
    int64_t step, progress;
    double t;
    ops->position(ops->owner, &step, &t, &progress);
    struct loop_state state = {.last_checkpoint_step = step, .last_checkpoint_time = log_elapsed()};
    struct progress bar;
    log_progress_begin(&bar, ops->label, ops->progress_unit, progress, ops->progress_total);
    double start = log_elapsed();
    while (!ops->finished(ops->owner)) {
        int status = loop_step(ops, &state, &bar, timing);
        if (status != SC_OK) {
            timing->loop = log_elapsed() - start;
            ops->position(ops->owner, &step, &t, &progress); /* how far it got, not where it started */
            if (!interrupt_status())                         /* an interruption said "stopped" already */
                log_progress_stop(&bar, progress);
            return status;
        }
    }
    timing->loop = log_elapsed() - start;
    ops->position(ops->owner, &step, &t, &progress);
    log_progress_end(&bar, progress);
    return SC_OK;
}

int stage_write_output(const char *path, const char *format, int64_t format_version, const char *stage,
                       uint64_t case_hash, const struct case_file *c, int (*contents)(void *owner, hid_t file),
                       void *owner)
{
    return stage_write_outputs(path, format, format_version, stage, case_hash, c, contents, NULL, owner);
}

int stage_write_outputs(const char *path, const char *format, int64_t format_version, const char *stage,
                        uint64_t case_hash, const struct case_file *c, int (*contents)(void *owner, hid_t file),
                        int (*side_files)(void *owner), void *owner)
{
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    char *case_text = NULL;
    int status;
    SC_CHECK(status, h5_write_root_attributes(out.file, format, format_version, stage, case_hash), done);
    if (c) {
        case_text = case_resolved_text(c);
        SC_CHECK(status, h5_attr_write_string(out.file, "case", case_text), done);
    }
    SC_CHECK(status, contents(owner, out.file), done);
    if (side_files) {
        SC_CHECK(status, run_dir_retire_output(path), done);
        SC_CHECK(status, side_files(owner), done);
    }
done:
    free(case_text);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_commit(&out));
    return SC_OK;
}
