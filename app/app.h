/* app: the application above the physics: the command line, the run directory, `spraycoat info` and the stage
 * drivers (DESIGN.md "Layout", "Run directory"). */
#ifndef SPRAYCOAT_APP_APP_H
#define SPRAYCOAT_APP_APP_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "core/config.h"
#include "core/run_keys.h"

/* The registry of every case key the program accepts (NULL-terminated list of tables). */
extern const struct cfg_key *const spraycoat_registry[];
/* The keys of [vcrit] (app/vcrit_stage.c). */
extern const struct cfg_key vcrit_case_keys[];

/* Create the run directory (and parents), lock it for this process (SC_EIO if another process holds it)
 * and write RUN_DIR/case.ini, the resolved case.  SC_EIO on failure. */
int run_dir_prepare(const char *run_dir, const struct case_file *c);

/* RUN_DIR/stages: the comma-separated stages the last command asked for ("spray", "impact", "vcrit"), so that
 * `spraycoat resume RUN_DIR` continues the same work.  Written atomically. */
int run_dir_write_stages(const char *run_dir, const char *stages);
/* The stages recorded in RUN_DIR/stages into out[size]; "spray" when the file is absent (run directories of
 * versions before the file existed held only spray runs).  SC_EIO when it exists but cannot be read. */
int run_dir_read_stages(const char *run_dir, char *out, size_t size);

/* 1 when the case file or the command line gives any key of [section] (a registered section, not "material.*"). */
int app_case_section_given(const struct case_file *c, const char *section);

/* The hash that identifies a stage's results (root attribute case_hash of its output and checkpoints): the
 * case keys of the stage and of the stages before it, so that changing [impact] does not rerun the spray. */
uint64_t stage_hash(const struct case_file *c, const char *stage);
/* 1 when the impact stage takes its bodies from RUN_DIR/couple.h5 (set by stages_set_pipeline: the stages of
 * `spraycoat run`, or `spraycoat impact` in a run directory holding couple.h5 of the case), 0 when from [impact]
 * (one particle or a bodies file). */
int stages_impact_takes_seeds(const struct case_file *c);
void stages_set_pipeline(int on);
/* 1 in a pipeline (`spraycoat run`): its render stage skips figures that are up to date. */
int stages_in_pipeline(void);
/* 1 when RUN_DIR/couple.h5 exists and was made by this case's couple stage. */
int run_dir_has_seeds(const struct case_file *c, const char *run_dir);

/* 1 when `path` is a readable spraycoat HDF5 file whose root attribute case_hash is `case_hash`, else 0. */
int run_dir_output_current(const char *path, uint64_t case_hash);

/* The start every stage shares: 1 (and a log line) when `output` is current for the case, so the stage has
 * nothing to do; otherwise say whether it is rerun over another case's output, load [run] into *settings and
 * apply its thread count, and return 0. */
int stage_begin(const char *stage, const char *output, uint64_t case_hash, const struct case_file *c,
                struct run_settings *settings);
/* 1 when a checkpoint is due by the [run] policy: checkpoint_steps steps or checkpoint_wall seconds (log_elapsed)
 * since the last one. */
int stage_checkpoint_due(const struct run_settings *settings, int64_t step, int64_t last_step, double last_time);

/* A text file written atomically: NAME.tmp, flushed, fsynced, renamed to NAME, folder fsynced. */
struct text_out {
    FILE *file;
    char path[4096];
    char tmp_path[4104];
};
int text_create_atomic(const char *path, struct text_out *out);
/* Close, sync and rename; SC_EIO with strerror on failure (the temporary file is removed). */
int text_commit(struct text_out *out);
void text_abort(struct text_out *out);

/* Check the spray stage's configuration (cross-key checks, input files) and, when run_dir is not NULL,
 * that its checkpoints there (if any) belong to this case, without writing anything. */
int spray_stage_validate(const struct case_file *c, const char *run_dir);

/* The spray stage: resume from the newest valid checkpoint of this case if there is one, run to t_end
 * with checkpoints, write RUN_DIR/spray.h5.  Skips the work when spray.h5 exists for the same case.
 * Returns SC_EINT/SC_ETERM after writing a checkpoint when interrupted by SIGINT/SIGTERM. */
int spray_stage_run(const struct case_file *c, const char *run_dir);

/* The impact stage's configuration ([impact], the materials it names, the bodies file) and, with run_dir, that
 * its checkpoints there (if any) belong to this case.  Writes nothing. */
int impact_stage_validate(const struct case_file *c, const char *run_dir);

/* The impact stage (MPM, mpm/): resume from the newest valid checkpoint of this case if there is one, run to
 * t_end with checkpoints and snapshots (RUN_DIR/impact_snapshots/), write RUN_DIR/impact.xdmf and then
 * RUN_DIR/impact.h5.  Skips the work when impact.h5 exists for the same case.  SC_EINT/SC_ETERM after writing
 * a checkpoint when interrupted. */
int impact_stage_run(const struct case_file *c, const char *run_dir);


/* The critical-velocity search ([vcrit]): its keys and the impact configuration of every diameter. */
int vcrit_stage_validate(const struct case_file *c, const char *run_dir);

/* Bisection of the impact speed per diameter with single-particle MPM runs; finished runs are recorded in
 * RUN_DIR/vcrit_runs.csv and not repeated after an interruption.  Writes RUN_DIR/vcrit.csv and RUN_DIR/vcrit.h5;
 * skips the work when vcrit.h5 exists for the same case.  SC_EINT/SC_ETERM when interrupted. */
int vcrit_stage_run(const struct case_file *c, const char *run_dir);

/* The couple stage ([couple]): sample spray.h5's impacts, fly them through the gas layer in front of the target
 * (CVODE) and write the MPM seeds to RUN_DIR/couple.h5.  Skips the work when couple.h5 is current.  SC_EIO when
 * spray.h5 is missing or from another case. */
int couple_stage_validate(const struct case_file *c, const char *run_dir);
int couple_stage_run(const struct case_file *c, const char *run_dir);
extern const struct cfg_key couple_case_keys[];

/* SIGINT/SIGTERM: set a flag the stages poll between steps. */
void stages_install_signal_handlers(void);
/* 0, or SC_EINT / SC_ETERM once a signal arrived. */
int stages_interrupt_status(void);

/* The render stage ([render], render/): figures of whatever RUN_DIR holds (spray.h5, impact.h5, vcrit.h5) into
 * RUN_DIR/figures/ and RUN_DIR/report.html.  SC_EIO when RUN_DIR holds none of them or one is malformed. */
int render_stage_validate(const struct case_file *c, const char *run_dir);
int render_stage_run(const struct case_file *c, const char *run_dir);

/* `spraycoat info`: what a run directory or an HDF5 file of spraycoat holds. */
/* target: a run directory or a .h5 file.  SC_EIO when it cannot be read. */
int info_print(const char *target, FILE *out);

/* A few lines on what a finished run says: deposit fraction, bonded fraction and PBCP, where the report is. */
void info_headline(const char *run_dir, FILE *out);

#endif
