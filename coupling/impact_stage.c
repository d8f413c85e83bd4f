/* The impact stage driver: MPM runs of mpm/ with checkpoints, resume, signals, progress, snapshots and
 * RUN_DIR/impact.h5 + RUN_DIR/impact.xdmf.
 *
 * Snapshots are written while the stage runs, one file each, RUN_DIR/impact_snapshots/NNNNNN.h5 (group
 * /snapshot), atomically; a resumed run starts from a checkpoint taken after some snapshot and writes the later
 * ones again, identical because the solver is deterministic.  When the run ends, impact.xdmf is written, then
 * impact.h5 with the snapshots copied into /snapshots/NNNNNN, and the snapshot folder and the checkpoints are
 * removed. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/run_keys.h"
#include "coupling/stages.h"
#include "mpm/mpm.h"

#define STAGE "impact"
#define SNAPSHOT_DIR "impact_snapshots"

struct impact_run {
    const struct case_file *c;
    const char *run_dir;
    struct run_settings settings;
    struct mpm_config cfg;
    struct mpm_solver *solver;
    uint64_t case_hash;
    double last_checkpoint_time;
    int64_t last_checkpoint_step;
    double start_time;      /* log_elapsed() when this process started stepping */
    int64_t start_updates;  /* point updates done before (by the run this one resumed) */
    int64_t start_step;
};

static void snapshot_path(const struct impact_run *run, int64_t index, char *out, size_t size)
{
    snprintf(out, size, "%s/" SNAPSHOT_DIR "/%06lld.h5", run->run_dir, (long long)index);
}

/* Remove the snapshot folder's files (and the folder itself when remove_folder). */
static int clear_snapshots(const struct impact_run *run, int remove_folder)
{
    char folder[H5IO_PATH_MAX], path[H5IO_PATH_MAX + 300];
    snprintf(folder, sizeof folder, "%s/" SNAPSHOT_DIR, run->run_dir);
    DIR *dir = opendir(folder);
    if (!dir) {
        if (errno == ENOENT)
            return SC_OK;
        SC_FAIL(SC_EIO, "cannot read folder %s: %s", folder, strerror(errno));
    }
    struct dirent *entry;
    int status = SC_OK;
    while ((entry = readdir(dir))) {
        if (strcmp(entry->d_name, ".") == 0 || strcmp(entry->d_name, "..") == 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", folder, entry->d_name);
        if (unlink(path) != 0 && errno != ENOENT && status == SC_OK)
            status = sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot remove %s: %s", path, strerror(errno));
    }
    closedir(dir);
    if (status == SC_OK && remove_folder && rmdir(folder) != 0 && errno != ENOENT)
        SC_FAIL(SC_EIO, "cannot remove folder %s: %s", folder, strerror(errno));
    return status;
}

static int make_snapshot_folder(const struct impact_run *run)
{
    char folder[H5IO_PATH_MAX];
    snprintf(folder, sizeof folder, "%s/" SNAPSHOT_DIR, run->run_dir);
    if (mkdir(folder, 0777) != 0 && errno != EEXIST)
        SC_FAIL(SC_EIO, "cannot create folder %s: %s", folder, strerror(errno));
    return SC_OK;
}

/* RUN_DIR/impact_snapshots/NNNNNN.h5: root attributes and the material points in group /snapshot. */
static int write_snapshot(struct impact_run *run)
{
    char path[H5IO_PATH_MAX];
    int64_t index = mpm_snapshot_index(run->solver);
    snapshot_path(run, index, path, sizeof path);
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    int status = h5_write_root_attributes(out.file, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, run->case_hash);
    hid_t group = H5I_INVALID_HID;
    if (status == SC_OK)
        status = h5_create_group(out.file, "snapshot", &group);
    if (status == SC_OK) {
        status = mpm_write_snapshot(run->solver, group);
        H5Gclose(group);
    }
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_commit(&out));
    mpm_snapshot_taken(run->solver);
    struct mpm_counts counts = mpm_get_counts(run->solver);
    log_debug("impact: snapshot %06lld at step %lld (t = %.6g s)", (long long)index, (long long)counts.step,
              counts.t);
    return SC_OK;
}

static int snapshot_if_due(struct impact_run *run)
{
    if (mpm_snapshot_due(run->solver))
        SC_TRY(write_snapshot(run));
    return SC_OK;
}

static int write_checkpoint(struct impact_run *run)
{
    struct mpm_counts counts = mpm_get_counts(run->solver);
    struct h5_out out;
    SC_TRY(checkpoint_begin(run->run_dir, STAGE, counts.step, &out));
    int status = h5_write_root_attributes(out.file, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, run->case_hash);
    /* what `spraycoat info` shows of a checkpoint (the solver's own datasets are its business) */
    if (status == SC_OK)
        status = h5_attr_write_int64(out.file, "step", counts.step);
    if (status == SC_OK)
        status = h5_attr_write_double(out.file, "t", counts.t);
    if (status == SC_OK)
        status = h5_attr_write_double(out.file, "t_end", run->cfg.t_end);
    if (status == SC_OK)
        status = h5_attr_write_int64(out.file, "snapshots", mpm_snapshot_index(run->solver));
    if (status == SC_OK)
        status = h5_attr_write_int64(out.file, "active_points", counts.active_points);
    if (status == SC_OK)
        status = mpm_checkpoint_write(run->solver, out.file);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(checkpoint_commit(&out, run->run_dir, STAGE, run->settings.keep_checkpoints));
    run->last_checkpoint_time = log_elapsed();
    run->last_checkpoint_step = counts.step;
    log_info("impact: checkpoint at step %lld (t = %.6g s)", (long long)counts.step, counts.t);
    return SC_OK;
}

/* 1 when resumed from a checkpoint. */
static int resume_if_possible(struct impact_run *run, int *resumed)
{
    char path[H5IO_PATH_MAX];
    *resumed = 0;
    SC_TRY(checkpoint_find_newest(run->run_dir, STAGE, MPM_FORMAT, MPM_FORMAT_VERSION, run->case_hash, path,
                                  sizeof path));
    if (path[0] == '\0')
        return SC_OK;
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    int status = mpm_checkpoint_read(run->solver, file);
    H5Fclose(file);
    if (status != SC_OK)
        return status;
    struct mpm_counts counts = mpm_get_counts(run->solver);
    run->last_checkpoint_step = counts.step;
    *resumed = 1;
    log_info("impact: resuming from %s (step %lld, t = %.6g s, %lld snapshots taken)", path, (long long)counts.step,
             counts.t, (long long)mpm_snapshot_index(run->solver));
    return SC_OK;
}

static int checkpoint_due(const struct impact_run *run, int64_t step)
{
    return stage_checkpoint_due(&run->settings, step, run->last_checkpoint_step, run->last_checkpoint_time);
}

/* Progress is counted in simulated picoseconds: the number of steps is not known in advance (dt follows the
 * wave speed and the fastest point), simulated time is. */
static int64_t picoseconds(double t) { return (int64_t)llround(t * 1e12); }

static int time_loop(struct impact_run *run)
{
    struct progress bar;
    struct mpm_counts counts = mpm_get_counts(run->solver);
    progress_begin(&bar, STAGE, "ps", picoseconds(counts.t), picoseconds(run->cfg.t_end));
    run->last_checkpoint_time = log_elapsed();
    while (!mpm_finished(run->solver)) {
        SC_TRY(mpm_step(run->solver));
        SC_TRY(snapshot_if_due(run));
        counts = mpm_get_counts(run->solver);
        int interrupted = stages_interrupt_status();
        if (interrupted || (checkpoint_due(run, counts.step) && !mpm_finished(run->solver)))
            SC_TRY(write_checkpoint(run));
        if (interrupted) {
            progress_end(&bar, picoseconds(counts.t));
            SC_FAIL(interrupted, "impact: interrupted at step %lld (t = %.6g s); checkpoint written, continue with "
                    "`spraycoat resume %s`", (long long)counts.step, counts.t, run->run_dir);
        }
        char extra[160];
        snprintf(extra, sizeof extra, "step %lld, dt %.3g s, %lld of %lld points active", (long long)counts.step,
                 counts.dt, (long long)counts.active_points, (long long)counts.points);
        progress_update(&bar, picoseconds(counts.t), extra);
    }
    progress_end(&bar, picoseconds(mpm_get_counts(run->solver).t));
    return SC_OK;
}

/* Open snapshot `index` and check that it was written by this case. */
static int open_snapshot(const struct impact_run *run, int64_t index, hid_t *file)
{
    char path[H5IO_PATH_MAX], stored[64] = "", wanted[64];
    snapshot_path(run, index, path, sizeof path);
    if (access(path, R_OK) != 0)
        SC_FAIL(SC_EIO, "impact: snapshot %s is missing (removed while the run was interrupted?); remove %s/checkpoints/"
                STAGE "_*.h5 to run the stage from the start", path, run->run_dir);
    SC_TRY(h5_open_read(path, file));
    snprintf(wanted, sizeof wanted, "%016llx", (unsigned long long)run->case_hash);
    if (h5_attr_read_string(*file, "case_hash", stored, sizeof stored) != SC_OK || strcmp(stored, wanted) != 0) {
        H5Fclose(*file);
        SC_FAIL(SC_EIO, "impact: snapshot %s belongs to another case (case hash %s, this case %s)", path, stored,
                wanted);
    }
    return SC_OK;
}

struct snapshot_info {
    double t;
    size_t points;
};

static int read_snapshot_info(const struct impact_run *run, int64_t index, struct snapshot_info *info)
{
    hid_t file;
    SC_TRY(open_snapshot(run, index, &file));
    int status = h5_dataset_size(file, "snapshot/eps_p", &info->points);
    if (status == SC_OK) {
        hid_t group = H5Gopen2(file, "snapshot", H5P_DEFAULT);
        status = group < 0 ? SC_EIO : h5_attr_read_double(group, "t", &info->t);
        if (group >= 0)
            H5Gclose(group);
    }
    H5Fclose(file);
    if (status != SC_OK)
        SC_FAIL(SC_EIO, "impact: cannot read the time and size of snapshot %06lld", (long long)index);
    return SC_OK;
}

/* RUN_DIR/impact.xdmf: a temporal collection of point clouds, one per snapshot of impact.h5. */
static int write_xdmf(const struct impact_run *run)
{
    static const char *const scalars[] = {"eps_p", "T", "D_bond", "pressure", "von_mises", "rho"};
    static const char *const integers[] = {"body", "id", "surface"};
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.xdmf", run->run_dir);
    int64_t count = mpm_snapshot_index(run->solver);
    struct text_out out;
    SC_TRY(text_create_atomic(path, &out));
    FILE *f = out.file;
    fprintf(f, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
               "  <Grid Name=\"impact\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (int64_t i = 0; i < count; i++) {
        struct snapshot_info info;
        int status = read_snapshot_info(run, i, &info);
        if (status != SC_OK) {
            text_abort(&out);
            return status;
        }
        size_t n = info.points;
        char where[64];
        snprintf(where, sizeof where, "impact.h5:/snapshots/%06lld", (long long)i);
        fprintf(f, "   <Grid Name=\"%06lld\" GridType=\"Uniform\">\n    <Time Value=\"%.17g\"/>\n"
                   "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%zu\"/>\n"
                   "    <Geometry GeometryType=\"XYZ\">\n"
                   "     <DataItem Dimensions=\"%zu 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s/x"
                   "</DataItem>\n    </Geometry>\n", (long long)i, info.t, n, n, where);
        fprintf(f, "    <Attribute Name=\"v\" AttributeType=\"Vector\" Center=\"Node\">\n"
                   "     <DataItem Dimensions=\"%zu 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s/v"
                   "</DataItem>\n    </Attribute>\n", n, where);
        for (size_t k = 0; k < sizeof scalars / sizeof scalars[0]; k++)
            fprintf(f, "    <Attribute Name=\"%s\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                       "     <DataItem Dimensions=\"%zu\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s/%s"
                       "</DataItem>\n    </Attribute>\n", scalars[k], n, where, scalars[k]);
        for (size_t k = 0; k < sizeof integers / sizeof integers[0]; k++)
            fprintf(f, "    <Attribute Name=\"%s\" AttributeType=\"Scalar\" Center=\"Node\">\n"
                       "     <DataItem Dimensions=\"%zu\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">%s/%s"
                       "</DataItem>\n    </Attribute>\n", integers[k], n, where, integers[k]);
        fprintf(f, "   </Grid>\n");
    }
    fprintf(f, "  </Grid>\n </Domain>\n</Xdmf>\n");
    return text_commit(&out);
}

/* Copy the snapshot files' /snapshot groups into /snapshots/NNNNNN of the open output file. */
static int copy_snapshots(const struct impact_run *run, hid_t file)
{
    hid_t snapshots;
    SC_TRY(h5_create_group(file, "snapshots", &snapshots));
    int64_t count = mpm_snapshot_index(run->solver);
    int status = SC_OK;
    for (int64_t i = 0; status == SC_OK && i < count; i++) {
        hid_t source;
        status = open_snapshot(run, i, &source);
        if (status != SC_OK)
            break;
        char name[32];
        snprintf(name, sizeof name, "%06lld", (long long)i);
        if (H5Ocopy(source, "snapshot", snapshots, name, H5P_DEFAULT, H5P_DEFAULT) < 0)
            status = sc_error_set(SC_EIO, __FILE__, __LINE__, "impact: cannot copy snapshot %s into impact.h5 "
                                  "(disk full?)", name);
        H5Fclose(source);
    }
    H5Gclose(snapshots);
    return status;
}

static int write_output(struct impact_run *run)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.h5", run->run_dir);
    struct h5_out out;
    SC_TRY(h5_create_atomic(path, &out));
    char *case_text = case_resolved_text(run->c);
    int status = h5_write_root_attributes(out.file, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, run->case_hash);
    if (status == SC_OK)
        status = h5_attr_write_string(out.file, "case", case_text);
    free(case_text);
    if (status == SC_OK)
        status = copy_snapshots(run, out.file);
    if (status == SC_OK)
        status = mpm_write_results(run->solver, out.file);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_commit(&out));
    log_info("impact: wrote %s", path);
    return SC_OK;
}

static void log_summary(struct impact_run *run)
{
    int nb = mpm_body_count(run->solver);
    int *bonded = calloc((size_t)nb, sizeof *bonded);
    if (!bonded)
        return;
    mpm_verdicts(run->solver, bonded);
    const struct mpm_diagnostics *d = mpm_compute_diagnostics(run->solver);
    for (int b = 0; b < nb; b++) {
        const struct mpm_body *body = &run->cfg.bodies[b];
        if (body->substrate)
            continue;
        const double *v = body->velocity;
        log_info("impact: body %d (d = %.4g um, %.4g m/s): %s, PBCP %.2f %%, v_rest %.3g m/s", b + 1, body->d * 1e6,
                 sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), bonded[b] ? "bonded" : "rebounded",
                 100.0 * d->body[b].pbcp, d->body[b].v_rest);
    }
    free(bonded);
    struct mpm_counts counts = mpm_get_counts(run->solver);
    double wall = log_elapsed() - run->start_time;
    int64_t updates = counts.point_updates - run->start_updates;
    log_info("impact: t = %.6g s after %lld steps (%lld in this process, %.1f s wall, %.3g point updates/s on %d "
             "threads); %lld of %lld points removed (left the grid box)", counts.t, (long long)counts.step,
             (long long)(counts.step - run->start_step), wall, wall > 0 ? (double)updates / wall : 0.0,
             omp_get_max_threads(), (long long)counts.removed_points, (long long)counts.points);
    log_info("impact: energy: initial %.6g J, now %.6g J (absorbed by the boundaries %.3g J, carried away %.3g J)",
             d->energy_initial, d->energy_total, d->energy_absorbed, d->energy_removed);
}

/* mpm_create refuses set-ups it cannot make (overlapping bodies, a body holding no point): name the case key. */
static int create_solver(struct impact_run *run)
{
    int status = mpm_create(&run->cfg, &run->solver);
    if (status != SC_EINPUT)
        return status;
    char message[1024];
    snprintf(message, sizeof message, "%s", sc_error_message());
    const char *key = case_has(run->c, "impact", "bodies") ? "bodies" : "diameter";
    return case_invalid(run->c, "impact", key, "%s", message);
}

static int run_stage(struct impact_run *run)
{
    SC_TRY(create_solver(run));
    struct mpm_counts counts = mpm_get_counts(run->solver);
    log_info("impact: %lld material points in %d bodies, grid %.3g m, spacing %.3g m, to t_end = %.6g s on %d "
             "threads", (long long)counts.points, mpm_body_count(run->solver), run->cfg.grid, run->cfg.spacing,
             run->cfg.t_end, omp_get_max_threads());
    int resumed;
    SC_TRY(resume_if_possible(run, &resumed));
    /* a fresh start owns the snapshot folder: files of an earlier, abandoned run must not end up in impact.h5 */
    if (!resumed)
        SC_TRY(clear_snapshots(run, 0));
    SC_TRY(make_snapshot_folder(run));
    counts = mpm_get_counts(run->solver);
    run->start_time = log_elapsed();
    run->start_updates = counts.point_updates;
    run->start_step = counts.step;
    SC_TRY(snapshot_if_due(run));
    SC_TRY(time_loop(run));
    /* the index first: impact.h5 marks the stage done, so everything else must exist before it */
    SC_TRY(write_xdmf(run));
    SC_TRY(write_output(run));
    /* the stage is complete: its checkpoints and snapshot files are no longer needed */
    SC_TRY(checkpoint_remove_all(run->run_dir, STAGE));
    SC_TRY(clear_snapshots(run, 1));
    log_summary(run);
    return SC_OK;
}

/* Spheres of a bodies file must not overlap (mpm_create finds any overlap, but only when the run starts, after
 * the run directory was prepared): the exact test for sphere pairs here, before anything is written. */
static int check_sphere_overlap(const struct case_file *c, const struct mpm_config *cfg)
{
    int first = cfg->body_count > 0 && cfg->bodies[0].substrate; /* data row r of the file is body r - 1 + first */
    for (int i = 0; i < cfg->body_count; i++)
        for (int j = i + 1; j < cfg->body_count; j++) {
            const struct mpm_body *a = &cfg->bodies[i], *b = &cfg->bodies[j];
            if (a->substrate || b->substrate || a->shape != MPM_SPHERE || b->shape != MPM_SPHERE)
                continue;
            double dx = a->center[0] - b->center[0], dy = a->center[1] - b->center[1],
                   dz = a->center[2] - b->center[2];
            double distance = sqrt(dx * dx + dy * dy + dz * dz), reach = 0.5 * (a->d + b->d);
            if (distance < reach * (1.0 - 1e-9)) {
                char path[4096] = "";
                case_path(c, "impact", "bodies", path, sizeof path);
                return case_invalid(c, "impact", "bodies", "%s: data rows %d and %d: the spheres overlap (centres "
                                    "%.4g m apart, radii add up to %.4g m); bodies may touch, not overlap", path,
                                    i + 1 - first, j + 1 - first, distance, reach);
            }
        }
    return SC_OK;
}

int impact_stage_validate(const struct case_file *c, const char *run_dir)
{
    struct mpm_config cfg;
    SC_TRY(mpm_config_load(c, &cfg));
    int status = check_sphere_overlap(c, &cfg);
    mpm_config_free(&cfg);
    if (status != SC_OK || !run_dir)
        return status;
    /* refuse checkpoints of another case before anything in the run directory is written */
    char path[H5IO_PATH_MAX];
    return checkpoint_find_newest(run_dir, STAGE, MPM_FORMAT, MPM_FORMAT_VERSION, case_hash(c), path, sizeof path);
}

int impact_stage_run(const struct case_file *c, const char *run_dir)
{
    struct impact_run run = {.c = c, .run_dir = run_dir, .case_hash = case_hash(c)};
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.h5", run_dir);
    if (stage_begin(STAGE, path, run.case_hash, c, &run.settings))
        return SC_OK;
    SC_TRY(mpm_config_load(c, &run.cfg));
    int status = run_stage(&run);
    mpm_destroy(run.solver);
    mpm_config_free(&run.cfg);
    return status;
}
