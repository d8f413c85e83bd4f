/* The spray stage driver: checkpoints, resume, signals, progress and RUN_DIR/spray.h5. */
#include <errno.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/run_keys.h"
#include "app/app.h"
#include "dem/dem.h"

#define STAGE "spray"

struct spray_run {
    const struct case_file *c;
    const char *run_dir;
    struct run_settings settings;
    struct dem_config cfg;
    struct dem_solver *solver;
    uint64_t case_hash;
    double last_checkpoint_time;
    int64_t last_checkpoint_step;
    double loop_seconds, checkpoint_seconds; /* wall: the time loop, and its checkpoints */
    int64_t loop_particle_steps, loop_steps; /* advanced by the time loop of this process */
};

static int write_checkpoint(struct spray_run *run)
{
    double start = omp_get_wtime();
    struct dem_counts counts = dem_get_counts(run->solver);
    struct h5_out out;
    SC_TRY(h5_checkpoint_begin(run->run_dir, STAGE, counts.step, &out));
    int status = h5_write_root_attributes(out.file, DEM_FORMAT, DEM_FORMAT_VERSION, STAGE, run->case_hash);
    if (status == SC_OK)
        status = dem_checkpoint_write(run->solver, out.file);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_checkpoint_commit(&out, run->run_dir, STAGE, run->settings.keep_checkpoints));
    run->last_checkpoint_time = log_elapsed();
    run->last_checkpoint_step = counts.step;
    log_info("spray: checkpoint at step %lld (t = %.6g s)", (long long)counts.step, counts.t);
    run->checkpoint_seconds += omp_get_wtime() - start;
    return SC_OK;
}

static int resume_if_possible(struct spray_run *run)
{
    char path[H5IO_PATH_MAX];
    SC_TRY(h5_checkpoint_find_newest(run->run_dir, STAGE, DEM_FORMAT, DEM_FORMAT_VERSION, run->case_hash, path,
                                  sizeof path));
    if (path[0] == '\0')
        return SC_OK;
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    int status = dem_checkpoint_read(run->solver, file);
    H5Fclose(file);
    if (status != SC_OK)
        return status;
    struct dem_counts counts = dem_get_counts(run->solver);
    run->last_checkpoint_step = counts.step;
    log_info("spray: resuming from %s (step %lld, t = %.6g s)", path, (long long)counts.step, counts.t);
    return SC_OK;
}

static int checkpoint_due(const struct spray_run *run, int64_t step)
{
    return stage_checkpoint_due(&run->settings, step, run->last_checkpoint_step, run->last_checkpoint_time);
}

static int time_loop(struct spray_run *run)
{
    int64_t total = dem_total_steps(run->solver);
    double start = omp_get_wtime();
    int64_t particle_steps_before = dem_get_counts(run->solver).particle_steps;
    int64_t steps_before = dem_get_counts(run->solver).step;
    struct progress bar;
    log_progress_begin(&bar, STAGE, "steps", dem_get_counts(run->solver).step, total);
    run->last_checkpoint_time = log_elapsed();
    for (int64_t step = dem_get_counts(run->solver).step; step < total; step++) {
        SC_TRY(dem_step(run->solver));
        struct dem_counts counts = dem_get_counts(run->solver);
        int interrupted = stages_interrupt_status();
        if (interrupted || (checkpoint_due(run, counts.step) && counts.step < total))
            SC_TRY(write_checkpoint(run));
        if (interrupted) {
            log_progress_end(&bar, counts.step);
            SC_FAIL(interrupted, "spray: interrupted at step %lld; checkpoint written, continue with "
                    "`spraycoat resume %s`", (long long)counts.step, run->run_dir);
        }
        char extra[160];
        snprintf(extra, sizeof extra, "in flight %lld, deposited %lld, escaped %lld", (long long)counts.in_flight,
                 (long long)counts.deposited, (long long)counts.escaped);
        log_progress_update(&bar, counts.step, extra);
    }
    log_progress_end(&bar, total);
    run->loop_seconds = omp_get_wtime() - start;
    run->loop_particle_steps = dem_get_counts(run->solver).particle_steps - particle_steps_before;
    run->loop_steps = dem_get_counts(run->solver).step - steps_before;
    return SC_OK;
}

static int write_output(struct spray_run *run)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.h5", run->run_dir);
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    char *case_text = case_resolved_text(run->c);
    int status = h5_write_root_attributes(out.file, DEM_FORMAT, DEM_FORMAT_VERSION, STAGE, run->case_hash);
    if (status == SC_OK)
        status = h5_attr_write_string(out.file, "case", case_text);
    free(case_text);
    if (status == SC_OK)
        status = dem_write_output(run->solver, out.file);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_commit(&out));
    log_info("spray: wrote %s", path);
    return SC_OK;
}

/* RUN_DIR/spray.xdmf: the final particles of spray.h5 as a point cloud for ParaView/VisIt. */
static int write_xdmf(const struct spray_run *run)
{
    char path[H5IO_PATH_MAX], tmp[H5IO_PATH_MAX + 8];
    snprintf(path, sizeof path, "%s/spray.xdmf", run->run_dir);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    size_t n = dem_particle_count(run->solver);
    FILE *file = fopen(tmp, "w");
    if (!file)
        SC_FAIL(SC_EIO, "cannot write %s: %s", tmp, strerror(errno));
    fprintf(file, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
                  "  <Grid Name=\"particles\" GridType=\"Uniform\">\n"
                  "   <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%zu\"/>\n"
                  "   <Geometry GeometryType=\"XYZ\">\n"
                  "    <DataItem Dimensions=\"%zu 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
                  "spray.h5:/particles/x</DataItem>\n   </Geometry>\n", n, n);
    static const char *const vectors[] = {"v", "w"}, *const scalars[] = {"d", "m"};
    for (int k = 0; k < 2; k++)
        fprintf(file, "   <Attribute Name=\"%s\" AttributeType=\"Vector\" Center=\"Node\">\n"
                      "    <DataItem Dimensions=\"%zu 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
                      "spray.h5:/particles/%s</DataItem>\n   </Attribute>\n", vectors[k], n, vectors[k]);
    for (int k = 0; k < 2; k++)
        fprintf(file, "   <Attribute Name=\"%s\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                      "    <DataItem Dimensions=\"%zu\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
                      "spray.h5:/particles/%s</DataItem>\n   </Attribute>\n", scalars[k], n, scalars[k]);
    fprintf(file, "   <Attribute Name=\"state\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                  "    <DataItem Dimensions=\"%zu\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
                  "spray.h5:/particles/state</DataItem>\n   </Attribute>\n  </Grid>\n </Domain>\n</Xdmf>\n", n);
    int failed = ferror(file) | fflush(file) | fsync(fileno(file));
    failed |= fclose(file);
    if (failed || rename(tmp, path) != 0) {
        int saved = errno;
        unlink(tmp);
        SC_FAIL(SC_EIO, "cannot write %s: %s", path, strerror(saved));
    }
    return SC_OK;
}

/* Where the time loop's wall time went, by phase of the step (dem_get_timing), and its rate. */
static void log_timing(const struct spray_run *run)
{
    struct dem_timing t = dem_get_timing(run->solver);
    double loop = run->loop_seconds > 0.0 ? run->loop_seconds : 1e-300;
    double other = loop - (t.injection + t.broad_phase + t.contacts + t.integration + t.boundaries + t.metrics +
                           run->checkpoint_seconds);
    int threads = omp_get_max_threads();
    log_info("spray: time loop %.3f s wall on %d thread%s, %.3g M particle-steps/s: integration %.1f %%, broad "
             "phase %.1f %%, contacts %.1f %%, injection %.1f %%, boundaries %.1f %%, metrics %.1f %%, "
             "checkpoints %.1f %%, other %.1f %%",
             run->loop_seconds, threads, threads == 1 ? "" : "s", (double)run->loop_particle_steps / loop / 1e6,
             100.0 * t.integration / loop, 100.0 * t.broad_phase / loop, 100.0 * t.contacts / loop,
             100.0 * t.injection / loop, 100.0 * t.boundaries / loop, 100.0 * t.metrics / loop,
             100.0 * run->checkpoint_seconds / loop, 100.0 * other / loop);
    log_info("spray: broad phase: %lld grid builds and %lld repairs in %lld steps", (long long)t.grid_builds,
             (long long)t.grid_repairs, (long long)run->loop_steps);
}

static void log_summary(const struct spray_run *run)
{
    struct dem_metrics m = dem_compute_metrics(run->solver);
    struct dem_counts c = dem_get_counts(run->solver);
    log_info("spray: t = %.6g s: injected %lld, deposited %lld (fraction %.4f), escaped %lld, in flight %lld",
             m.t, (long long)m.injected, (long long)m.deposited, m.deposit_fraction, (long long)m.escaped,
             (long long)m.in_flight);
    log_info("spray: contacts: particle-particle %lld, target %lld, deposit %lld; fixed-point iterations "
             "%.2f per solve (max %lld, unconverged %lld), sub-cycled particle-steps %lld",
             (long long)c.contacts_pair, (long long)c.contacts_target, (long long)c.contacts_deposit,
             c.fixed_point_solves ? (double)c.fixed_point_iterations / (double)c.fixed_point_solves : 0.0,
             (long long)c.max_iterations, (long long)c.fixed_point_unconverged,
             (long long)c.subcycled_particle_steps);
    log_info("spray: volume fraction %.4g, mean spread %.4g m, scatter %.4g m, max thickness %.4g m",
             m.volume_fraction, m.mean_spread, m.scatter, m.max_thickness);
    log_timing(run);
}

static int run_stage(struct spray_run *run)
{
    SC_TRY(dem_create(&run->cfg, &run->solver));
    log_info("spray: %lld steps of %.3g s to t_end = %.6g s on %d threads", (long long)dem_total_steps(run->solver),
             run->cfg.dt, run->cfg.t_end, omp_get_max_threads());
    SC_TRY(resume_if_possible(run));
    SC_TRY(time_loop(run));
    SC_TRY(dem_check_accounting(run->solver));
    /* the index first: spray.h5 marks the stage done, so everything else must exist before it */
    SC_TRY(write_xdmf(run));
    SC_TRY(write_output(run));
    /* the stage is complete: its checkpoints would only stop a changed case from running here */
    SC_TRY(h5_checkpoint_remove_all(run->run_dir, STAGE));
    log_summary(run);
    return SC_OK;
}

/* The configuration that spray_stage_validate loaded, kept for spray_stage_run of the same case: loading it
 * again read the particle file a second time (strtod on every value: ~2 % of the bench's 20,000-particle
 * free flight). */
static struct {
    const struct case_file *c;
    struct dem_config cfg;
} validated;

static void validated_drop(void)
{
    if (validated.c)
        dem_config_free(&validated.cfg);
    validated.c = NULL;
}

/* The configuration of case c: the validated one if it is c's, else loaded. */
static int config_for_run(const struct case_file *c, struct dem_config *cfg)
{
    if (validated.c == c) {
        *cfg = validated.cfg;
        validated.c = NULL;
        return SC_OK;
    }
    validated_drop();
    return dem_config_load(c, cfg);
}

int spray_stage_validate(const struct case_file *c, const char *run_dir)
{
    validated_drop();
    SC_TRY(dem_config_load(c, &validated.cfg));
    validated.c = c;
    if (!run_dir)
        return SC_OK;
    /* refuse checkpoints of another case before anything in the run directory is written */
    char path[H5IO_PATH_MAX];
    return h5_checkpoint_find_newest(run_dir, STAGE, DEM_FORMAT, DEM_FORMAT_VERSION, stage_hash(c, STAGE), path, sizeof path);
}

int spray_stage_run(const struct case_file *c, const char *run_dir)
{
    struct spray_run run = {.c = c, .run_dir = run_dir, .case_hash = stage_hash(c, STAGE)};
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.h5", run_dir);
    if (stage_begin(STAGE, path, run.case_hash, c, &run.settings)) {
        validated_drop();
        return SC_OK;
    }
    SC_TRY(config_for_run(c, &run.cfg));
    int status = run_stage(&run);
    dem_destroy(run.solver);
    dem_config_free(&run.cfg);
    return status;
}
