/* app: the application above the physics: the command line, the run directory, `spraycoat info` and the stage
 * drivers (docs/architecture.md; the run directory: docs/files.md). */
#ifndef SPRAYCOAT_APP_APP_H
#define SPRAYCOAT_APP_APP_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "core/atomic.h"
#include "core/config.h"
#include "core/h5io.h"
#include "core/run_keys.h"
#include "coupling/coupling.h"

/* The registry of every case key the program accepts (NULL-terminated list of tables). */
extern const struct cfg_key *const spraycoat_registry[];
/* The keys of [vcrit] (app/vcrit_stage.c). */
extern const struct cfg_key vcrit_case_keys[];

/* Create the run directory (and parents), lock it for this process (SC_EIO if another process holds it)
 * and write RUN_DIR/case.ini, the resolved case.  SC_EIO on failure. */
int run_dir_prepare(const char *run_dir, const struct case_file *c);
/* Lock RUN_DIR for this process when it exists already (SC_EIO "in use" if another process holds it), before
 * anything in it is read. */
int run_dir_lock_existing(const char *run_dir);
/* 1 when another process holds RUN_DIR's lock (a stage is running there now). */
int run_dir_in_use(const char *run_dir);

/* RUN_DIR/stages: the comma-separated stages the last command asked for ("spray", "impact", "vcrit"), so that
 * `spraycoat resume RUN_DIR` continues the same work.  Written atomically. */
int run_dir_write_stages(const char *run_dir, const char *stages);
/* The stages recorded in RUN_DIR/stages into out[size]; "spray" when the file is absent (run directories of
 * versions before the file existed held only spray runs).  SC_EIO when it exists but cannot be read. */
int run_dir_read_stages(const char *run_dir, char *out, size_t size);
/* The checkpoints of `stage` in RUN_DIR/checkpoints: their number and the newest one's path into newest[size]
 * (newest[0] = '\0' when there is none). */
size_t run_dir_stage_checkpoints(const char *run_dir, const char *stage, char *newest, size_t size);

/* 1 when the case file or the command line gives any key of [section] (a registered section, not "material.*"). */
int app_case_section_given(const struct case_file *c, const char *section);

/* What a stage works on, passed to every stage (no global state decides where a stage takes its input). */
struct stage_context {
    const struct case_file *c;
    const char *run_dir;    /* NULL for `spraycoat check`: validate the case only */
    int pipeline;           /* 1 under `spraycoat run`: the render stage skips figures that are up to date */
    int impact_from_seeds;  /* 1: the impact stage takes its bodies from RUN_DIR/couple.h5 (the stages of
                             * `spraycoat run`, or `spraycoat impact` in a run directory holding couple.h5 of the
                             * case); 0: from [impact] (one particle or a bodies file) */
    const char *resume_dir; /* the directory an interrupted stage tells the user to resume: the sweep's or the
                             * calibration's own for one of its runs, which resumes them all; NULL: run_dir */
};

/* ctx->resume_dir, or ctx->run_dir where it is not set. */
const char *stage_resume_dir(const struct stage_context *ctx);

/* The hash that identifies a stage's results (root attribute case_hash of its output and checkpoints): the
 * case keys of the stage and of the stages before it, so that changing [impact] does not rerun the spray. */
uint64_t stage_hash(const struct stage_context *ctx, const char *stage);
/* 1 when the results of `stage` ("spray") depend on the keys of `section` (the sections its hash covers). */
int stage_has_section(const char *stage, const char *section);
/* 1 when RUN_DIR/couple.h5 exists and was made by this case's couple stage. */
int run_dir_has_seeds(const struct case_file *c, const char *run_dir);

/* What a stage's output `path` holds: nothing, results that are up to date (this case's `case_hash` and this
 * build's sources_id, and the whole file reads back: h5_verify_file, one read of it), or results to compute
 * again: another case's (or a file that cannot be read as one), this case's computed by another build of spraycoat
 * (other sources: docs/architecture.md "Another build"), or this case's and this build's but damaged (a dataset or
 * attribute fails its checksum; run_dir_log_rerun says which). */
enum output_state { OUTPUT_NONE, OUTPUT_CURRENT, OUTPUT_OTHER_CASE, OUTPUT_OTHER_BUILD, OUTPUT_DAMAGED };
enum output_state run_dir_output_state(const char *path, uint64_t case_hash);
/* 1 when run_dir_output_state is OUTPUT_CURRENT, else 0. */
int run_dir_output_current(const char *path, uint64_t case_hash);
/* Log why `stage` computes its output `path` again (state OUTPUT_OTHER_CASE or OUTPUT_OTHER_BUILD; OUTPUT_DAMAGED
 * as a warning naming what failed to read; nothing else). */
void run_dir_log_rerun(const char *stage, const char *path, enum output_state state);
/* Remove a stage's output `path` (the file whose case hash says "up to date"), durably (the folder fsynced), before
 * the stage publishes any other file of its new results (stage_write_outputs): a failure between two files then
 * leaves no output that declares another case's files (vcrit.csv beside vcrit.h5) up to date, and the next run
 * writes them all again.  Missing is fine; SC_EIO when it cannot be removed. */
int run_dir_retire_output(const char *path);
/* The input RUN_DIR/STAGE.h5 a later stage (`reader`: couple, impact, render) reads must have been made by this
 * case's `stage`: SC_EIO naming the file and the stage to rerun when it was made by another case, is not readable,
 * or (with required) is missing.  Exit status 3, not 2: the case file and command line are fine, what is wrong
 * is a file in the run directory. */
int run_dir_check_input(const struct stage_context *ctx, const char *stage, const char *reader, int required);
/* Whether the output `path` of `stage` was made by ctx's case (its case_hash, either impact hash): 1, 0, or -1 when
 * it cannot be read. */
int run_dir_made_by_case(const struct stage_context *ctx, const char *stage, const char *path);

/* The start every stage shares: 1 (and a log line) when `output` is current for the case, so the stage has
 * nothing to do; otherwise say whether it is rerun over another case's output, load [run] into *settings and
 * apply its thread count, and return 0. */
int stage_begin(const char *stage, const char *output, uint64_t case_hash, const struct case_file *c,
                struct run_settings *settings);

/* ---- the one stage loop (app/stage_loop.c) -------------------------------------------------------------------
 * A stage with a time loop (the spray, each impact run, each run of the critical-velocity search) describes its
 * solver by a struct stage_ops; the loop owns what every such stage does the same way: resume from the newest
 * valid checkpoint of the case, step with checkpoints by the [run] policy, stop at a signal after a checkpoint,
 * progress, timing, and the final output written atomically with the root attributes. */
struct stage_ops {
    const char *label;  /* log, progress and checkpoint name: "spray", "impact", "impact_r0003" */
    const char *stage;  /* the root attribute stage of its files */
    const char *format; /* file format name and version of its checkpoints */
    int64_t format_version;
    uint64_t case_hash;
    const char *run_dir;
    const struct run_settings *settings; /* checkpoint policy; NULL: no checkpoints */
    const char *progress_unit;           /* "steps", "ps" */
    int64_t progress_total;
    void *owner; /* passed to every callback */
    int (*step)(void *owner);
    int (*finished)(void *owner);
    void (*position)(void *owner, int64_t *step, double *t, int64_t *progress);
    void (*describe)(void *owner, char *text, size_t size); /* the progress line's text; NULL: none */
    int (*after_step)(void *owner);                         /* e.g. snapshots; NULL: none */
    int (*checkpoint_write)(void *owner, hid_t file);       /* the solver's state; NULL: no checkpoints */
    int (*checkpoint_read)(void *owner, hid_t file);
    const char *interrupted_note; /* said when interrupted: what is kept and how to continue */
};

/* Wall seconds of this process's time loop: all of it, and its steps, after-step work and checkpoints. */
struct stage_timing {
    double loop, stepping, after_step, checkpoints;
};

/* Resume from the newest valid checkpoint of the case (*resumed = 1), or leave the solver at its start. */
int stage_loop_resume(const struct stage_ops *ops, int *resumed);
/* Step until finished.  SC_EINT / SC_ETERM after writing a checkpoint when a signal arrived. */
int stage_loop_run(const struct stage_ops *ops, struct stage_timing *timing);
/* The stage's output file `path`, atomically: root attributes (format, version, stage, case hash), the resolved
 * case text (when c is not NULL), then what `contents` writes. */
int stage_write_output(const char *path, const char *format, int64_t format_version, const char *stage,
                       uint64_t case_hash, const struct case_file *c, int (*contents)(void *owner, hid_t file),
                       void *owner);
/* The same for a stage whose results are several files, the .h5 and `side_files` (its CSVs, its XDMF index; NULL:
 * none), whose case hash only the .h5 carries: once the .h5 is complete under its temporary name, the earlier .h5
 * at `path` is removed (run_dir_retire_output), then side_files(owner) writes the other files, then the .h5 is
 * published.  An I/O fault writing the .h5 leaves the earlier results whole; no failure or crash leaves an .h5 that
 * declares another case's side files up to date (docs/architecture.md "Atomic writes"). */
int stage_write_outputs(const char *path, const char *format, int64_t format_version, const char *stage,
                        uint64_t case_hash, const struct case_file *c, int (*contents)(void *owner, hid_t file),
                        int (*side_files)(void *owner), void *owner);

/* Check the spray stage's configuration (cross-key checks, input files) and, when run_dir is not NULL,
 * that its checkpoints there (if any) belong to this case, without writing anything. */
int spray_stage_validate(const struct stage_context *ctx);

/* The spray stage: resume from the newest valid checkpoint of this case if there is one, run to t_end
 * with checkpoints, write RUN_DIR/spray.h5.  Skips the work when spray.h5 exists for the same case.
 * Returns SC_EINT/SC_ETERM after writing a checkpoint when interrupted by SIGINT/SIGTERM. */
int spray_stage_run(const struct stage_context *ctx);

/* The impact stage's configuration ([impact], the materials it names, the bodies file) and, with run_dir, that
 * its checkpoints there (if any) belong to this case.  Writes nothing. */
int impact_stage_validate(const struct stage_context *ctx);

/* The impact stage (MPM, mpm/): resume from the newest valid checkpoint of this case if there is one, run to
 * t_end with checkpoints and snapshots (RUN_DIR/impact_snapshots/), write RUN_DIR/impact.xdmf and then
 * RUN_DIR/impact.h5.  Skips the work when impact.h5 exists for the same case.  SC_EINT/SC_ETERM after writing
 * a checkpoint when interrupted. */
int impact_stage_run(const struct stage_context *ctx);

/* The critical-velocity search ([vcrit]): its keys and the impact configuration of every diameter. */
int vcrit_stage_validate(const struct stage_context *ctx);

/* Bisection of the impact speed per diameter with single-particle MPM runs; finished runs are recorded in
 * RUN_DIR/vcrit_runs.csv and not repeated after an interruption.  Writes RUN_DIR/vcrit.csv and RUN_DIR/vcrit.h5;
 * skips the work when vcrit.h5 exists for the same case.  SC_EINT/SC_ETERM when interrupted. */
int vcrit_stage_run(const struct stage_context *ctx);

/* ---- single-particle impact runs recorded for restart (app/vcrit_stage.c), shared by vcrit and calibrate -------
 * Every finished run goes into RUN_DIR/NAME_runs.csv (rank 0; NAME_runs_rankK.csv on rank K), rewritten atomically;
 * a run already recorded for the case (same diameter, speed, Gc, Gc_rate and temperature) is taken from there, not
 * repeated. */
/* VCRIT_FAILED: the run failed as a simulation (SC_ESIM: NaN or blow-up); it is recorded like a finished run,
 * since the same set-up fails the same way again, so that one such run ends only its own search, never the stage. */
enum vcrit_verdict { VCRIT_REBOUNDED = 0, VCRIT_BONDED = 1, VCRIT_UNSETTLED = 2, VCRIT_FAILED = 3 };
#define VCRIT_ERROR_MAX 200 /* room for a failed run's message in its record (one line of NAME_runs.csv) */
struct vcrit_run_record {
    double diameter, velocity, Gc, Gc_rate; /* m, m/s, J/m2, J/m2/s: what identifies the run */
    int verdict;                            /* enum vcrit_verdict, from mpm_verdicts */
    double pbcp, v_rest, cor; /* cor: rebound over impact speed, both along the substrate normal; NaN when failed */
    int64_t steps;            /* the steps done (when failed: before the step that failed) */
    double temperature;       /* K, the particle's at the start (identifies the run too); 0: its material's T_initial */
    char error[VCRIT_ERROR_MAX]; /* VCRIT_FAILED: the error's message (it names the step and body); else "" */
};
struct vcrit_runs {
    const char *run_dir, *name; /* name: "vcrit", "calibrate" */
    const char *resume_dir;     /* named when a run is interrupted (stage_resume_dir) */
    uint64_t case_hash;
    struct vcrit_run_record *done; /* every recorded run */
    size_t count, capacity;
    int64_t new_runs; /* runs this process made */
};
struct mpm_config;
/* "bonded", "rebounded", "unsettled", "failed". */
const char *vcrit_verdict_name(int verdict);
/* What a search counts as the particle's success ([vcrit] outcome, [calibrate] outcome): bonded (the verdict, PBCP
 * and v_rest: Tang Section 5.2.1), or adhered (bonded, or held: at rest on the substrate once settled, so the
 * particle does not leave, which is what a single-particle impact experiment observes). */
enum vcrit_outcome { VCRIT_OUTCOME_BONDED = 0, VCRIT_OUTCOME_ADHERED = 1 };
/* The key's doc and the choice from it ([section] outcome). */
#define VCRIT_OUTCOME_DOC                                                                                              \
    "what counts as success: bonded (PBCP >= pbcp_threshold and v_rest <= vrest_threshold, Tang Section 5.2.1) or "    \
    "adhered (bonded, or held: at rest on the substrate, v_rest <= vrest_threshold, with fewer bonds; what a "         \
    "single-particle impact experiment sees, docs/physics.md \"Held but not bonded\")"
enum vcrit_outcome vcrit_runs_outcome_of(const struct case_file *c, const char *section);
/* 1 when the run is a success under `outcome`, 0 when not, -1 when it has no settled verdict (unsettled or
 * failed: neither counts either way). */
int vcrit_runs_succeeds(const struct vcrit_run_record *run, enum vcrit_outcome outcome, double vrest_threshold);
/* The records of every rank's file for this case (others ignored). */
int vcrit_runs_load(struct vcrit_runs *r);
/* The outcome of *run (diameter, velocity, Gc, Gc_rate set; cfg the impact set-up of exactly that run): from the
 * records, or an MPM run to cfg->t_end through the stage loop, then recorded.  A run that fails as a simulation
 * (SC_ESIM) is recorded with verdict VCRIT_FAILED and its message, with a warning, and SC_OK is returned: the
 * caller decides what the failure means; any other error (I/O, input, an interruption) is returned. */
int vcrit_runs_outcome(struct vcrit_runs *r, const struct mpm_config *cfg, struct vcrit_run_record *run);
void vcrit_runs_free(struct vcrit_runs *r);
/* A comma-separated list of numbers in `unit` (SI), each > 0 and <= max, from [section] key into out[capacity];
 * *count may be 0.  A number may carry a unit ("10 um", "25 degC"), converted as a case key's value is. */
int vcrit_runs_parse_list(const struct case_file *c, const char *section, const char *key, double max, const char *unit,
                          double *out, int capacity, int *count);

/* `spraycoat calibrate` ([calibrate], app/calibrate_stage.c): the bonding calibration of Tang (2021) Sections
 * 4.1.2 and 5.1 over a (Gc, Gc_rate) grid.  Writes RUN_DIR/calibrate.csv, calibrate_runs... (while it runs),
 * calibrate_outcomes.csv and calibrate.h5; restartable and shared among MPI ranks like vcrit. */
extern const struct cfg_key calibrate_case_keys[];
int calibrate_stage_validate(const struct stage_context *ctx);
int calibrate_stage_run(const struct stage_context *ctx);
/* [calibrate] method = vcrit (app/calibrate_vcrit.c): the bonding model's first parameter fitted so that the
 * critical velocities of `spraycoat vcrit` searches meet the measured ones; called by the calibrate stage after
 * its up-to-date check, with its case hash. */
int calibrate_vcrit_validate(const struct stage_context *ctx);
int calibrate_vcrit_run(const struct stage_context *ctx, uint64_t case_hash);

/* `spraycoat sweep` ([sweep], app/sweep_stage.c): the spray stage over a grid of two case keys, each run in
 * RUN_DIR/runs/xI_yJ (restartable like `spraycoat spray`; shared among MPI ranks), and RUN_DIR/sweep.h5 with the
 * maps of the deposition efficiency and the mean impact speed. */
extern const struct cfg_key sweep_case_keys[];
int sweep_stage_validate(const struct stage_context *ctx);
/* The sweep's case hash from `base` (the case's spray keys and [sweep]): with a file key on an axis, every run's spray
 * hash folded in, so that the contents of the swept files are part of it (stage_hash calls it). */
uint64_t sweep_stage_hash(const struct case_file *c, uint64_t base);
int sweep_stage_run(const struct stage_context *ctx);

/* The couple stage ([couple]): sample spray.h5's impacts, fly them through the gas layer in front of the target
 * (CVODE) and write the MPM seeds to RUN_DIR/couple.h5.  Skips the work when couple.h5 is current.  SC_EIO when
 * spray.h5 is missing or from another case. */
int couple_stage_validate(const struct stage_context *ctx);
/* What the stage refuses from spray.h5's contents (runs * bodies_per_run more than the particles that reached the
 * target, or than those that reach the wall; a window holding too few), found as the stage finds it, seeding without
 * writing: called before the run directory is written when spray.h5 is already there, so that a case refused for
 * the spray's results leaves an earlier run's case.ini and stages as they were.  SC_OK when couple.h5 is current. */
int couple_stage_check_inputs(const struct stage_context *ctx);
int couple_stage_run(const struct stage_context *ctx);
extern const struct cfg_key couple_case_keys[];
/* The seeds of RUN_DIR/couple.h5 as bodies of the impact runs (the couple stage's output, read by the impact
 * stage): run r has rows first[r] ... first[r + 1] - 1, ordered by arrival.  SC_EIO when couple.h5 is missing or
 * was made from another case. */
struct couple_bodies {
    size_t runs, count;
    size_t *first;                 /* runs + 1 */
    double *d, *center, *velocity; /* count, 3 count, 3 count (impact frame) */
    double *temperature;           /* count, K; NULL: a couple.h5 without /seeds/temperature (T_initial) */
};
int couple_stage_read_bodies(const struct stage_context *ctx, struct couple_bodies *bodies);
void couple_stage_bodies_free(struct couple_bodies *bodies);

/* The render stage ([render], render/): figures of whatever RUN_DIR holds (spray.h5, impact.h5, vcrit.h5) into
 * RUN_DIR/figures/ and RUN_DIR/report.html.  SC_EIO when RUN_DIR holds none of them or one is malformed. */
int render_stage_validate(const struct stage_context *ctx);
/* The stages whose outputs the render stage draws (whichever are there), NULL-terminated: it checks each is this
 * case's, and so does a command before it touches the run directory (app/main.c). */
extern const char *const render_stage_inputs[];
/* 1 when RUN_DIR/STAGE.h5 is there but is not this case's, and this case has no such stage (none of the stage's
 * sections given: [couple] for couple; [impact] or [couple] for impact; [spray], [vcrit], [calibrate], [sweep]):
 * a run of another case into the directory left it.  The render stage then neither refuses nor draws it (the
 * advice to run the stage again could not be followed) and leaves it out of the report, saying so. */
int render_stage_ignores(const struct stage_context *ctx, const char *stage);
int render_stage_run(const struct stage_context *ctx);

/* `spraycoat info`: what a run directory or an HDF5 file of spraycoat holds. */
/* target: a run directory or a .h5 file.  SC_EIO when it cannot be read. */
int info_print(const char *target, FILE *out);

/* A few lines on what a finished run says: deposit fraction, bonded fraction and PBCP, where the report is. */
void info_headline(const char *run_dir, FILE *out);

/* ---- XDMF index files (app/xdmf.c): pieces of a Uniform grid of n points whose data lie in HDF5 at `where`
 * ("spray.h5:/particles"), each line starting with `indent`. */
enum xdmf_kind { XDMF_SCALAR, XDMF_INTEGER, XDMF_VECTOR };
/* The connectivity 0 1 .. n-1 inline: one vertex cell a point (without it ParaView's Xdmf3 readers make none). */
void xdmf_inline_indices(FILE *f, const char *indent, size_t n);
/* The same connectivity as the first n of the `total` integers 0 1 .. total-1 of an HDF5 dataset ("FILE:/PATH"). */
void xdmf_slab_indices(FILE *f, const char *indent, size_t n, size_t total, const char *dataset);
/* The points' positions, the dataset x. */
void xdmf_geometry(FILE *f, const char *indent, size_t n, const char *where);
/* A point field: the dataset `name` (n doubles, n integers, or n x 3 doubles). */
void xdmf_attribute(FILE *f, const char *indent, const char *name, enum xdmf_kind kind, size_t n, const char *where);

#endif
