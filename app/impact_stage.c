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
#include "core/interrupt.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/run_keys.h"
#include "coupling/coupling.h"
#include "app/app.h"
#include "mpm/mpm.h"

#define STAGE        "impact"
#define SNAPSHOT_DIR "impact_snapshots"
#define RUNS_DIR     "impact_runs"

struct impact_run {
    const struct stage_context *ctx;
    const char *run_dir;
    /* where this run's files go: one run (impact.h5 itself) or run r of several (impact_runs/run_NNNN.h5, copied
     * into impact.h5 /run_NNNN when all are done) */
    char label[32]; /* checkpoint and log name: "impact" or "impact_rNNNN" */
    char snapshot_dir[H5IO_PATH_MAX - 64];
    char output[H5IO_PATH_MAX];
    char xdmf[H5IO_PATH_MAX];
    char snapshot_group[64]; /* the snapshots' group in the final impact.h5 */
    struct run_settings settings;
    struct mpm_config cfg;
    struct mpm_solver *solver;
    size_t seed_first, seed_count; /* a run of the seeds: its rows of couple.h5 /seeds (count 0: [impact]) */
    uint64_t case_hash;
    double start_time;     /* log_elapsed() when this process started stepping */
    int64_t start_updates; /* point updates done before (by the run this one resumed) */
    int64_t start_step;
    struct stage_timing timing; /* this process's time loop (after_step: the snapshots) */
};

static void snapshot_path(const struct impact_run *run, int64_t index, char *out, size_t size)
{
    snprintf(out, size, "%s/%06lld.h5", run->snapshot_dir, (long long)index);
}

/* Remove the snapshot folder's files (and the folder itself when remove_folder). */
static int clear_snapshots(const struct impact_run *run, int remove_folder)
{
    char path[H5IO_PATH_MAX + 300];
    const char *folder = run->snapshot_dir;
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
    if (status != SC_OK)
        return status;
    if (remove_folder && rmdir(folder) != 0 && errno != ENOENT)
        SC_FAIL(SC_EIO, "cannot remove folder %s: %s", folder, strerror(errno));
    return status;
}

static int make_snapshot_folder(const struct impact_run *run)
{
    if (mkdir(run->snapshot_dir, 0777) != 0 && errno != EEXIST)
        SC_FAIL(SC_EIO, "cannot create folder %s: %s", run->snapshot_dir, strerror(errno));
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
    hid_t group = H5I_INVALID_HID;
    int status;
    SC_CHECK(status, h5_write_root_attributes(out.file, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, run->case_hash), done);
    SC_CHECK(status, h5_create_group(out.file, "snapshot", &group), done);
    SC_CHECK(status, mpm_write_snapshot(run->solver, group), done);
done:
    if (group >= 0)
        H5Gclose(group);
    if (status != SC_OK) {
        h5_abort(&out);
        return status;
    }
    SC_TRY(h5_commit(&out));
    mpm_snapshot_taken(run->solver);
    struct mpm_counts counts = mpm_get_counts(run->solver);
    log_debug("%s: snapshot %06lld at step %lld (t = %.6g s)", run->label, (long long)index, (long long)counts.step,
              counts.t);
    return SC_OK;
}

static int snapshot_if_due(struct impact_run *run)
{
    if (mpm_snapshot_due(run->solver))
        SC_TRY(write_snapshot(run));
    return SC_OK;
}

/* ---- the solver as the stage loop sees it (struct stage_ops) ---- */

/* What `spraycoat info` shows of a checkpoint (the solver's own datasets are its business), then the solver. */
static int checkpoint_write(void *owner, hid_t file)
{
    struct impact_run *run = owner;
    struct mpm_counts counts = mpm_get_counts(run->solver);
    SC_TRY(h5_attr_write_int64(file, "step", counts.step));
    SC_TRY(h5_attr_write_double(file, "t", counts.t));
    SC_TRY(h5_attr_write_double(file, "t_end", run->cfg.t_end));
    SC_TRY(h5_attr_write_int64(file, "snapshots", mpm_snapshot_index(run->solver)));
    SC_TRY(h5_attr_write_int64(file, "active_points", counts.active_points));
    return mpm_checkpoint_write(run->solver, file);
}

static int checkpoint_read(void *owner, hid_t file)
{
    return mpm_checkpoint_read(((struct impact_run *)owner)->solver, file);
}

static int step(void *owner)
{
    return mpm_step(((struct impact_run *)owner)->solver);
}

static int finished(void *owner)
{
    return mpm_finished(((struct impact_run *)owner)->solver);
}

static int after_step(void *owner)
{
    return snapshot_if_due(owner);
}

/* Progress is counted in simulated picoseconds: the number of steps is not known in advance (dt follows the
 * wave speed and the fastest point), simulated time is. */
static int64_t picoseconds(double t)
{
    return (int64_t)llround(t * 1e12);
}

static void position(void *owner, int64_t *step_index, double *t, int64_t *progress)
{
    struct mpm_counts counts = mpm_get_counts(((struct impact_run *)owner)->solver);
    *step_index = counts.step;
    *t = counts.t;
    *progress = picoseconds(counts.t);
}

static void describe(void *owner, char *text, size_t size)
{
    struct mpm_counts counts = mpm_get_counts(((struct impact_run *)owner)->solver);
    snprintf(text, size, "step %lld, dt %.3g s, %lld of %lld points active", (long long)counts.step, counts.dt,
             (long long)counts.active_points, (long long)counts.points);
}

static struct stage_ops stage_ops_of(struct impact_run *run, char *note, size_t size)
{
    snprintf(note, size, "checkpoint written, continue with `spraycoat resume %s`", stage_resume_dir(run->ctx));
    return (struct stage_ops){.label = run->label,
                              .stage = STAGE,
                              .format = MPM_FORMAT,
                              .format_version = MPM_FORMAT_VERSION,
                              .case_hash = run->case_hash,
                              .run_dir = run->run_dir,
                              .settings = &run->settings,
                              .progress_unit = "ps",
                              .progress_total = picoseconds(run->cfg.t_end),
                              .owner = run,
                              .step = step,
                              .finished = finished,
                              .position = position,
                              .describe = describe,
                              .after_step = after_step,
                              .checkpoint_write = checkpoint_write,
                              .checkpoint_read = checkpoint_read,
                              .interrupted_note = note};
}

/* Open snapshot `index` and check that it was written by this case. */
static int open_snapshot(const struct impact_run *run, int64_t index, hid_t *file)
{
    char path[H5IO_PATH_MAX], stored[64] = "", wanted[64];
    snapshot_path(run, index, path, sizeof path);
    if (access(path, R_OK) != 0)
        SC_FAIL(SC_EIO,
                "%s: snapshot %s is missing (removed while the run was interrupted?); remove %s/checkpoints/"
                "%s_*.h5 to run it from the start",
                run->label, path, run->run_dir, run->label);
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
    hid_t group = H5I_INVALID_HID;
    int status;
    SC_CHECK(status, h5_dataset_size(file, "snapshot/eps_p", &info->points), done);
    group = H5Gopen2(file, "snapshot", H5P_DEFAULT);
    if (group < 0)
        SC_FAIL_AT(status, done, SC_EIO, "impact: snapshot %06lld has no /snapshot group", (long long)index);
    SC_CHECK(status, h5_attr_read_double(group, "t", &info->t), done);
done:
    if (group >= 0)
        H5Gclose(group);
    H5Fclose(file);
    if (status != SC_OK)
        SC_FAIL(SC_EIO, "impact: cannot read the time and size of snapshot %06lld", (long long)index);
    return SC_OK;
}

/* Snapshot 0 is written before any step, with every point active, so its `id` is 0 .. n0-1, and points are
 * only ever removed, so a later snapshot has n <= n0 points: the first n ids of snapshot 0 are then the
 * connectivity of a snapshot (one vertex cell a point).  *n0 is 0 when snapshot 0 is not so (*n0 stays 0 and
 * the connectivity is written inline). */
static int first_snapshot_indices(const struct impact_run *run, size_t *n0)
{
    *n0 = 0;
    hid_t file;
    SC_TRY(open_snapshot(run, 0, &file));
    size_t n = 0;
    int64_t *id = NULL;
    int status = h5_dataset_size(file, "snapshot/id", &n);
    if (status == SC_OK && !(id = malloc((n ? n : 1) * sizeof *id)))
        status = sc_out_of_memory(__FILE__, __LINE__, (n ? n : 1) * sizeof *id, "the ids of snapshot 0");
    if (status == SC_OK)
        status = h5_read_int64s(file, "snapshot/id", id, n);
    H5Fclose(file);
    size_t i = 0;
    while (status == SC_OK && i < n && id[i] == (int64_t)i)
        i++;
    if (status == SC_OK && i == n)
        *n0 = n;
    free(id);
    return status;
}

/* RUN_DIR/impact.xdmf: a temporal collection of point clouds, one per snapshot of impact.h5.  The Polyvertex
 * topology has its connectivity (the first n ids of snapshot 0, or inline): without it the Xdmf3 readers of
 * ParaView make no cells, and the Surface and Points representations draw nothing. */
static int write_xdmf(const struct impact_run *run)
{
    static const char *const scalars[] = {"eps_p", "T", "D_bond", "pressure", "von_mises", "rho"};
    static const char *const integers[] = {"body", "id", "surface"};
    int64_t count = mpm_snapshot_index(run->solver);
    struct atomic_file out;
    SC_TRY(atomic_open(run->xdmf, &out));
    FILE *f = out.stream;
    size_t n0 = 0;
    int checked = count > 0 ? first_snapshot_indices(run, &n0) : SC_OK;
    if (checked != SC_OK) {
        atomic_abort(&out);
        return checked;
    }
    fprintf(f, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
               "  <Grid Name=\"impact\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (int64_t i = 0; i < count; i++) {
        struct snapshot_info info;
        int status = read_snapshot_info(run, i, &info);
        if (status != SC_OK) {
            atomic_abort(&out);
            return status;
        }
        size_t n = info.points;
        char where[128];
        snprintf(where, sizeof where, "impact.h5:/%s/%06lld", run->snapshot_group, (long long)i);
        fprintf(f,
                "   <Grid Name=\"%06lld\" GridType=\"Uniform\">\n    <Time Value=\"%.17g\"/>\n"
                "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%zu\" NodesPerElement=\"1\">\n",
                (long long)i, info.t, n);
        if (n > 0 && n <= n0)
            fprintf(f,
                    "     <DataItem ItemType=\"HyperSlab\" Dimensions=\"%zu\">\n"
                    "      <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 %zu</DataItem>\n"
                    "      <DataItem Dimensions=\"%zu\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
                    "impact.h5:/%s/000000/id</DataItem>\n     </DataItem>\n",
                    n, n, n0, run->snapshot_group);
        else if (n > 0)
            xdmf_inline_indices(f, "     ", n);
        fprintf(f, "    </Topology>\n");
        xdmf_geometry(f, "    ", n, where);
        xdmf_attribute(f, "    ", "v", XDMF_VECTOR, n, where);
        for (size_t k = 0; k < sizeof scalars / sizeof scalars[0]; k++)
            xdmf_attribute(f, "    ", scalars[k], XDMF_SCALAR, n, where);
        for (size_t k = 0; k < sizeof integers / sizeof integers[0]; k++)
            xdmf_attribute(f, "    ", integers[k], XDMF_INTEGER, n, where);
        fprintf(f, "   </Grid>\n");
    }
    fprintf(f, "  </Grid>\n </Domain>\n</Xdmf>\n");
    return atomic_publish(&out);
}

/* Copy the snapshot files' /snapshot groups into /snapshots/NNNNNN of the open output file. */
static int copy_snapshots(const struct impact_run *run, hid_t file)
{
    hid_t snapshots;
    SC_TRY(h5_create_group(file, "snapshots", &snapshots));
    int64_t count = mpm_snapshot_index(run->solver);
    hid_t source = H5I_INVALID_HID;
    int status = SC_OK;
    for (int64_t i = 0; i < count; i++) {
        hid_t opened;
        SC_CHECK(status, open_snapshot(run, i, &opened), done);
        source = opened;
        char name[32];
        snprintf(name, sizeof name, "%06lld", (long long)i);
        /* not H5Ocopy: it crashes on a full disk */
        SC_CHECK(status, h5_copy(source, "snapshot", snapshots, name), done);
        H5Fclose(source);
        source = H5I_INVALID_HID;
    }
done:
    if (source >= 0)
        H5Fclose(source);
    H5Gclose(snapshots);
    return status;
}

static int output_contents(void *owner, hid_t file)
{
    struct impact_run *run = owner;
    SC_TRY(copy_snapshots(run, file));
    return mpm_write_results(run->solver, file);
}

static int side_xdmf(void *owner)
{
    return write_xdmf(owner);
}

/* impact.h5 (or a run's) with its XDMF index as side file (app.h stage_write_outputs). */
static int write_output(struct impact_run *run)
{
    SC_TRY(stage_write_outputs(run->output, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, run->case_hash, run->ctx->c,
                               output_contents, side_xdmf, run));
    log_info("%s: wrote %s", run->label, run->output);
    return SC_OK;
}

/* Body b's v_rest as its verdict is judged (the window mean), or `now` while it has no judgement. */
static double judged_or(const struct mpm_solver *s, int b, double now)
{
    double v_rest = mpm_verdict_vrest(s, b);
    return isnan(v_rest) ? now : v_rest;
}

/* The verdict as the report words it (render/report.c): a settled "rebounded" body whose v_rest is within
 * vrest_threshold is at rest on the substrate, held by bonds too few to count (PBCP below pbcp_threshold, Tang
 * Sec. 5.1's "not bonded sufficiently"), so it is named that way, not "rebounded". */
static const char *verdict_words(const struct impact_run *run, int verdict, double v_rest, char *out, size_t size)
{
    if (!mpm_verdict_held(verdict, v_rest, run->cfg.vrest_threshold))
        return mpm_verdict_name(verdict);
    snprintf(out, size, "not bonded: at rest, PBCP < %.3g %%", 100.0 * run->cfg.pbcp_threshold);
    return out;
}

static void log_summary(struct impact_run *run)
{
    int nb = mpm_body_count(run->solver);
    int *bonded = calloc((size_t)nb, sizeof *bonded);
    if (!bonded)
        return;
    mpm_verdicts(run->solver, bonded);
    const struct mpm_diagnostics *d = mpm_final_diagnostics(run->solver);
    for (int b = 0; b < nb; b++) {
        const struct mpm_body *body = &run->cfg.bodies[b];
        if (body->substrate)
            continue;
        const double *v = body->velocity;
        char settled[64] = "not settled by the end of the run";
        if (bonded[b] != MPM_VERDICT_UNSETTLED)
            snprintf(settled, sizeof settled, "settled at %.4g ns", 1e9 * mpm_verdict_settled_at(run->solver, b));
        double v_rest = judged_or(run->solver, b, d->body[b].v_rest);
        char words[64];
        const struct mpm_body_diagnostics *x = &d->body[b];
        char interface[96] = "bonded interface not counted (the GPU failed to count it)";
        if (x->interface_nodes >= 0)
            snprintf(interface, sizeof interface,
                     "bonded at %lld of the %lld nodes where it meets a body now (%.1f %%)", (long long)x->bonded_nodes,
                     (long long)x->interface_nodes, 100.0 * x->bonded_interface);
        const char *averaged = isnan(x->v_com[2]) && bonded[b] == MPM_VERDICT_REBOUNDED
                                   ? "as it left the grid box" /* mpm/verdict.c judge_gone */
                               : isnan(mpm_verdict_vrest(run->solver, b)) ? "the last row's: no window judged"
                                                                          : "window mean";
        log_info("%s: body %d (d = %.4g um, %.4g m/s): %s (%s), PBCP %.2f %%, %s, v_rest %.3g m/s (%s), "
                 "v_com_z %.3g m/s",
                 run->label, b, body->d * 1e6, sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]),
                 verdict_words(run, bonded[b], v_rest, words, sizeof words), settled, 100.0 * x->pbcp, interface,
                 v_rest, averaged, x->v_com[2]);
    }
    free(bonded);
    struct mpm_counts counts = mpm_get_counts(run->solver);
    int64_t updates = counts.point_updates - run->start_updates;
    log_info("%s: t = %.6g s after %lld steps (%lld in this process, %.1f s wall); %lld of %lld points removed (left "
             "the grid box)",
             run->label, counts.t, (long long)counts.step, (long long)(counts.step - run->start_step),
             log_elapsed() - run->start_time, (long long)counts.removed_points, (long long)counts.points);
    /* point updates per second of the steps alone, as MPM codes state their speed; the snapshots and checkpoints
     * written in the loop (serial file output, as many as the case asks for) are given beside them */
    const struct stage_timing *w = &run->timing;
    double other = w->loop - w->stepping - w->after_step - w->checkpoints;
    log_info("%s: time loop %.3f s wall on %d threads: stepping %.3f s, %.3g point updates/s; snapshots %.3f s, "
             "checkpoints %.3f s, other %.3f s",
             run->label, w->loop, omp_get_max_threads(), w->stepping,
             w->stepping > 0 ? (double)updates / w->stepping : 0.0, w->after_step, w->checkpoints,
             other > 0.0 ? other : 0.0);
    log_info("%s: energy: initial %.6g J, now %.6g J (absorbed by the boundaries %.3g J, carried away %.3g J)",
             run->label, d->energy_initial, d->energy_total, d->energy_absorbed, d->energy_removed);
}

/* x rounded up to 3 significant digits (a bound shown with %.3g that still holds). */
static double round_up_3(double x)
{
    if (!(x > 0.0) || !isfinite(x))
        return x;
    double unit = pow(10.0, floor(log10(x)) - 2.0);
    return ceil(x / unit * (1.0 - 1e-12)) * unit;
}

/* A grid beyond the machine's memory (or beyond MPM_GRID_MAX_NODES nodes) is the fault of [impact] grid, whatever the
 * bodies: it names grid with the finest cell that fits.  `whose` leads the message (the seeds of a run) or is "". */
static int check_grid_fits(const struct case_file *c, const struct mpm_config *cfg, const char *whose)
{
    struct mpm_grid_need need;
    mpm_grid_need(cfg, mpm_machine_memory(), &need);
    if (need.fits)
        return SC_OK;
    if (need.nodes > (double)MPM_GRID_MAX_NODES)
        return case_invalid(c, "impact", "grid",
                            "%sthe grid would have %.3g nodes, over the %zu a grid may have; allowed: at least %.3g m "
                            "on this machine (the bodies, box_margin and substrate as they are)",
                            whose, need.nodes, MPM_GRID_MAX_NODES, round_up_3(need.finest));
    double layer = need.bytes / cfg->body_count;
    if (!*whose && case_has(c, "impact", "bodies") && layer <= need.memory) /* the file's bodies are too many */
        return case_invalid(c, "impact", "bodies",
                            "the run would need %.3g GB for the grid of its %d bodies (a layer of %.3g GB each) on "
                            "a machine of %.3g GB; allowed: at most %.0f bodies in a run with grid = %g m, or a grid "
                            "of at least %.3g m",
                            need.bytes / 1e9, cfg->body_count, layer / 1e9, need.memory / 1e9,
                            floor(need.memory / layer), cfg->grid, round_up_3(need.finest));
    return case_invalid(c, "impact", "grid",
                        "%sthe run would need %.3g GB for its grid (%d bodies, a layer of %.3g GB each) on a machine "
                        "of %.3g GB; allowed: at least %.3g m on this machine (or fewer bodies per run, a smaller "
                        "box_margin)",
                        whose, need.bytes / 1e9, cfg->body_count, need.bytes / cfg->body_count / 1e9, need.memory / 1e9,
                        round_up_3(need.finest));
}

/* mpm_create refuses set-ups it cannot make (overlapping bodies, a body holding no point): name the case key, or
 * for a run of the seeds the rows of couple.h5 the bodies came from (no key of the case gave them). */
static int create_solver(struct impact_run *run)
{
    char whose[H5IO_PATH_MAX + 200] = "";
    if (run->seed_count >= 1)
        snprintf(whose, sizeof whose, "%s: the bodies of %s/couple.h5 /seeds rows %zu to %zu: ", run->label,
                 run->run_dir, run->seed_first, run->seed_first + run->seed_count - 1);
    SC_TRY(check_grid_fits(run->ctx->c, &run->cfg, whose));
    int status = mpm_create(&run->cfg, &run->solver);
    if (status != SC_EINPUT)
        return status;
    char message[1024];
    snprintf(message, sizeof message, "%s", sc_error_message());
    if (run->seed_count == 1)
        SC_FAIL(SC_EINPUT, "%s: the body of %s/couple.h5 /seeds row %zu: %s", run->label, run->run_dir, run->seed_first,
                message);
    if (run->seed_count > 1)
        SC_FAIL(SC_EINPUT, "%s: the bodies of %s/couple.h5 /seeds rows %zu to %zu: %s", run->label, run->run_dir,
                run->seed_first, run->seed_first + run->seed_count - 1, message);
    const char *key = case_has(run->ctx->c, "impact", "bodies") ? "bodies" : "diameter";
    return case_invalid(run->ctx->c, "impact", key, "%s", message);
}

static int run_stage(struct impact_run *run)
{
    SC_TRY(create_solver(run));
    struct mpm_counts counts = mpm_get_counts(run->solver);
    log_info("%s: %lld material points in %d bodies, grid %.3g m, spacing %.3g m, to t_end = %.6g s on %d "
             "threads",
             run->label, (long long)counts.points, mpm_body_count(run->solver), run->cfg.grid, run->cfg.spacing,
             run->cfg.t_end, omp_get_max_threads());
    char note[H5IO_PATH_MAX + 100];
    const struct stage_ops ops = stage_ops_of(run, note, sizeof note);
    int resumed;
    SC_TRY(stage_loop_resume(&ops, &resumed));
    if (resumed)
        log_info("%s: %lld snapshots taken before", run->label, (long long)mpm_snapshot_index(run->solver));
    /* a fresh start owns the snapshot folder: files of an earlier, abandoned run must not end up in impact.h5 */
    if (!resumed)
        SC_TRY(clear_snapshots(run, 0));
    SC_TRY(make_snapshot_folder(run));
    counts = mpm_get_counts(run->solver);
    run->start_time = log_elapsed();
    run->start_updates = counts.point_updates;
    run->start_step = counts.step;
    SC_TRY(snapshot_if_due(run));
    SC_TRY(stage_loop_run(&ops, &run->timing));
    /* impact.h5 marks the stage done: its index is written before it is published (write_output) */
    SC_TRY(write_output(run));
    /* the stage is complete: its checkpoints and snapshot files are no longer needed */
    SC_TRY(h5_checkpoint_remove_all(run->run_dir, run->label));
    SC_TRY(clear_snapshots(run, 1));
    log_summary(run);
    return SC_OK;
}

/* Spheres of a bodies file must not overlap (mpm_create finds any overlap, but only when the run starts, after
 * the run directory was prepared): the exact test for sphere pairs here, before anything is written. */
static int check_sphere_overlap(const struct case_file *c, const struct mpm_config *cfg)
{
    int first = cfg->body_count > 0 && cfg->bodies[0].substrate; /* data row r of the file is body r - 1 + first */
    int i, j, found = mpm_find_sphere_overlap(cfg, &i, &j);
    if (found < 0) /* the cell list: 32 bytes per body */
        SC_FAIL_OOM((size_t)cfg->body_count * 4 * sizeof(int64_t), "the cell list of the overlap check");
    if (found == 0)
        return SC_OK;
    const struct mpm_body *a = &cfg->bodies[i], *b = &cfg->bodies[j];
    double dx = a->center[0] - b->center[0], dy = a->center[1] - b->center[1], dz = a->center[2] - b->center[2];
    double distance = sqrt(dx * dx + dy * dy + dz * dz), reach = 0.5 * (a->d + b->d);
    char path[4096] = "";
    case_path(c, "impact", "bodies", path, sizeof path);
    return case_invalid(c, "impact", "bodies",
                        "%s: data rows %d and %d: the spheres overlap (centres %.4g m apart, "
                        "radii add up to %.4g m); bodies may touch, not overlap",
                        path, i + 1 - first, j + 1 - first, distance, reach);
}

static void name_run(struct impact_run *run, long index);

static int check_set_up(const struct stage_context *ctx, struct mpm_config *cfg)
{
    SC_TRY(check_grid_fits(ctx->c, cfg, ""));
    int status = mpm_check_set_up(cfg);
    if (status != SC_EINPUT)
        return status;
    char message[1024];
    snprintf(message, sizeof message, "%s", sc_error_message());
    const char *key = case_has(ctx->c, "impact", "bodies") ? "bodies" : "diameter";
    return case_invalid(ctx->c, "impact", key, "%s", message);
}

/* A pipeline's runs that spread their bodies: the couple stage places a run's bodies over a square of [couple]
 * patch_size on the substrate's axis (several bodies of random or stratified sampling, folded into the patch; any
 * number with sample = window, each at its wall position less the window's centre: a lone body lands anywhere in the
 * window, not on the axis), and seeds_over_substrate refuses a body beyond the substrate's edge, but only after the
 * spray and the couple stage have run.  The same rule from the case alone, with the powder's largest diameter
 * ([powder] d_max; without one, the bodies' centres only).  Scaled runs ([couple] reference_diameter) are checked
 * when they are seeded. */
/* A lone body on the substrate's axis: the substrate at least as wide as the particles the runs may seed. */
static int centred_fits(const struct case_file *c, double substrate_width, double particle, const char *which)
{
    if (particle <= substrate_width)
        return SC_OK;
    return case_invalid(
        c, "impact", "substrate_diameter",
        "%.4g um is narrower than %s, %.4g um, which the pipeline's impact runs may seed; allowed: "
        "at least %.4g um, or [couple] reference_diameter to scale each run to its particle (`spraycoat "
        "impact` runs [impact]'s own particle, without the spray)",
        substrate_width * 1e6, which, particle * 1e6, particle * 1e6);
}

static int check_patch_fits(const struct case_file *c, const struct mpm_config *cfg)
{
    int window = case_is(c, "couple", "sample", "window");
    long per_run = case_int(c, "couple", "bodies_per_run");
    if (case_real(c, "couple", "reference_diameter") > 0)
        return SC_OK;

    const struct mpm_body *substrate = NULL;
    for (int b = 0; b < cfg->body_count; b++)
        if (cfg->bodies[b].substrate)
            substrate = &cfg->bodies[b];
    if (!substrate) /* a rigid wall has no edge */
        return SC_OK;
    int box = substrate->shape == MPM_BOX;
    double patch = case_real(c, "couple", "patch_size");
    double d_max = case_is(c, "powder", "distribution", "mono") ? case_real(c, "powder", "median_diameter")
                                                                : case_real(c, "powder", "d_max");
    double corner = 0.5 * patch * (box ? 1.0 : sqrt(2.0)), largest = d_max > 0 ? d_max : 0.0;
    /* wherever it lands, a body wider than the substrate does not fit: the first body of a run of random or stratified
     * sampling lands on the axis (untruncated, half the powder is above its median: that much is sure to be seeded) */
    SC_TRY(centred_fits(c, substrate->d, largest > 0 ? largest : case_real(c, "powder", "median_diameter"),
                        largest > 0 ? "the powder's largest particle ([powder] d_max)"
                                    : "the powder's median diameter ([powder] median_diameter; no d_max)"));
    if ((per_run < 2 && !window) || corner + 0.5 * largest <= 0.5 * substrate->d)
        return SC_OK; /* a lone body of random or stratified sampling lands on the axis */
    char spread[160];
    if (window) /* bodies_per_run = 1 does not help: a lone body lands anywhere in the window */
        snprintf(spread, sizeof spread, "is the window where a run's %s (sample = window), wider than the substrate",
                 per_run > 1 ? "bodies land" : "body lands");
    else
        snprintf(spread, sizeof spread, "spreads a run's %ld bodies wider than the substrate", per_run);
    char sizes[96];
    if (largest > 0) /* without d_max the particles' size is unbounded: the patch's corner alone is checked */
        snprintf(sizes, sizeof sizes, "particles up to %.4g um ([powder] d_max)", largest * 1e6);
    else
        snprintf(sizes, sizeof sizes, "the particles' size unbounded ([powder] d_max = 0)");
    return case_invalid(c, "couple", "patch_size",
                        "%s (%s %.4g um across, [impact] substrate_diameter), %s; allowed: at most %.4g um (the "
                        "substrate's width less the largest particle%s), or a wider substrate%s",
                        spread, box ? "a box" : "a cylinder", substrate->d * 1e6, sizes,
                        (substrate->d - largest) / (box ? 1.0 : sqrt(2.0)) * 1e6, box ? "" : ", over sqrt(2)",
                        window ? "" : ", or bodies_per_run = 1");
}

int impact_stage_validate(const struct stage_context *ctx)
{
    const struct case_file *c = ctx->c;
    const char *run_dir = ctx->run_dir;
    struct mpm_config cfg;
    SC_TRY(mpm_config_load(c, &cfg));
    mpm_config_warn_unused_materials(c, &cfg);
    int status = SC_OK;
    if (ctx->impact_from_seeds && !case_is(c, "impact", "symmetry", "none")) {
        status = case_invalid(c, "impact", "symmetry",
                              "the couple stage's particles arrive off the axis, not on mirror planes; allowed: none "
                              "in a pipeline, half|quarter for `spraycoat impact`, `vcrit` and `calibrate`");
        goto done;
    }
    /* the pipeline's impact stage; `spraycoat check` (no run directory) checks a case with [couple] as one */
    if (ctx->impact_from_seeds || (!run_dir && app_case_section_given(c, "couple")))
        SC_CHECK(status, check_patch_fits(c, &cfg), done);
    if (!ctx->impact_from_seeds) {
        SC_CHECK(status, check_sphere_overlap(c, &cfg), done);
        /* the whole set-up (every body seeded with its points, overlaps of any shapes, bodies that hold no point),
         * so that a case that cannot run fails here, before the run directory is touched */
        SC_CHECK(status, check_set_up(ctx, &cfg), done);
    }
done:
    mpm_config_free(&cfg);
    if (status != SC_OK || !run_dir)
        return status;
    /* refuse checkpoints of another case before anything in the run directory is written: the single run's, or
     * those of the runs of the seeds (as many as [couple] asks for) */
    uint64_t hash = stage_hash(ctx, STAGE);
    if (!ctx->impact_from_seeds)
        return h5_checkpoint_check_newest(run_dir, STAGE, MPM_FORMAT, MPM_FORMAT_VERSION, hash);
    long runs = case_int(c, "couple", "runs");
    for (long r = 0; r < runs; r++) {
        struct impact_run names = {.run_dir = run_dir};
        name_run(&names, r);
        SC_TRY(h5_checkpoint_check_newest(run_dir, names.label, MPM_FORMAT, MPM_FORMAT_VERSION, hash));
    }
    return SC_OK;
}

/* The file names of one run: the run of [impact] (index < 0) writes impact.h5 itself; run `index` of the couple
 * stage's seeds writes impact_runs/run_NNNN.h5, and impact.h5 gathers them at the end. */
static void name_run(struct impact_run *run, long index)
{
    const char *dir = run->run_dir;
    if (index < 0) {
        snprintf(run->label, sizeof run->label, STAGE);
        snprintf(run->snapshot_dir, sizeof run->snapshot_dir, "%s/" SNAPSHOT_DIR, dir);
        snprintf(run->output, sizeof run->output, "%s/impact.h5", dir);
        snprintf(run->xdmf, sizeof run->xdmf, "%s/impact.xdmf", dir);
        snprintf(run->snapshot_group, sizeof run->snapshot_group, "snapshots");
        return;
    }
    snprintf(run->label, sizeof run->label, STAGE "_r%04ld", index);
    snprintf(run->snapshot_dir, sizeof run->snapshot_dir, "%s/" RUNS_DIR "/snapshots_%04ld", dir, index);
    snprintf(run->output, sizeof run->output, "%s/" RUNS_DIR "/run_%04ld.h5", dir, index);
    /* staged beside the run's file, and moved to RUN_DIR/impact_run_NNNN.xdmf with impact.h5 (gathered_xdmf): one
     * published at once pointed into an impact.h5 that a failed gathering never wrote */
    snprintf(run->xdmf, sizeof run->xdmf, "%s/" RUNS_DIR "/run_%04ld.xdmf", dir, index);
    snprintf(run->snapshot_group, sizeof run->snapshot_group, "run_%04ld/snapshots", index);
}

static int run_single(const struct stage_context *ctx, uint64_t hash, const struct run_settings *settings)
{
    struct impact_run run = {.ctx = ctx, .run_dir = ctx->run_dir, .case_hash = hash, .settings = *settings};
    name_run(&run, -1);
    SC_TRY(mpm_config_load(ctx->c, &run.cfg));
    int status = run_stage(&run);
    mpm_destroy(run.solver);
    mpm_config_free(&run.cfg);
    return status;
}

/* [couple] reference_diameter: [impact] describes a particle of that diameter, and the run of seed `first` is its
 * set-up scaled by d / reference_diameter (mpm_config_scale_lengths, as vcrit does it): the same cells across every
 * particle, the resolution its bonding parameters belong to. */
static int scale_to_particle(const struct case_file *c, struct mpm_config *cfg, const struct couple_bodies *bodies,
                             size_t first, size_t count)
{
    double reference = case_real(c, "couple", "reference_diameter");
    if (!(reference > 0))
        return SC_OK;
    if (count != 1) /* couple_config_load refuses it; a case changed after the couple stage ran is refused here */
        SC_FAIL(SC_EINPUT,
                "[couple] reference_diameter = %g m scales a run to its one particle, but this run has %zu "
                "bodies; allowed: 0, or bodies_per_run = 1",
                reference, count);
    mpm_config_scale_lengths(cfg, bodies->d[first] / reference);
    return SC_OK;
}

/* Every body of the seeds over the substrate: the couple stage spreads a run's bodies over [couple] patch_size,
 * and a body placed beyond the substrate's edge meets nothing, flies on, and its run counts it as a body that did
 * not bond.  (A rigid wall has no edge.) */
static int seeds_over_substrate(const struct impact_run *run)
{
    const struct mpm_config *cfg = &run->cfg;
    const struct mpm_body *substrate = NULL;
    for (int b = 0; b < cfg->body_count; b++)
        if (cfg->bodies[b].substrate)
            substrate = &cfg->bodies[b];
    if (!substrate)
        return SC_OK;
    int box = substrate->shape == MPM_BOX;
    /* with sample = window a lone body lands anywhere in the window too: bodies_per_run = 1 is no remedy */
    int window = case_is(run->ctx->c, "couple", "sample", "window");
    for (size_t k = 0; k < run->seed_count; k++) {
        const struct mpm_body *body = &cfg->bodies[cfg->body_count - (int)run->seed_count + (int)k];
        double dx = body->center[0] - substrate->center[0], dy = body->center[1] - substrate->center[1];
        double from_axis = box ? fmax(fabs(dx), fabs(dy)) : hypot(dx, dy);
        double beyond = from_axis + 0.5 * body->d - 0.5 * substrate->d;
        if (body->d > substrate->d) /* wherever it lands: the particle is wider */
            SC_FAIL(SC_EINPUT,
                    "%s: the body of %s/couple.h5 /seeds row %zu (d = %.4g um) is wider than the substrate (%s %.4g "
                    "um across in this run: [impact] substrate_diameter); allowed: substrate_diameter at least the "
                    "largest particle's diameter, or [couple] reference_diameter to scale each run to its particle",
                    run->label, run->run_dir, run->seed_first + k, body->d * 1e6, box ? "a box" : "a cylinder",
                    substrate->d * 1e6);
        if (beyond > 0.0)
            SC_FAIL(SC_EINPUT,
                    "%s: the body of %s/couple.h5 /seeds row %zu (d = %.4g um, its centre %.4g um from the "
                    "substrate's axis) reaches %.3g um beyond the substrate (%s %.4g um across in this run: "
                    "[impact] substrate_diameter, scaled with the run when [couple] reference_diameter is given): "
                    "[couple] patch_size = %g m %s wider than the substrate; allowed: substrate_diameter at least "
                    "%s patch_size plus the largest particle's diameter (as scaled), or a smaller patch_size%s",
                    run->label, run->run_dir, run->seed_first + k, body->d * 1e6, from_axis * 1e6, beyond * 1e6,
                    box ? "a box" : "a cylinder", substrate->d * 1e6, case_real(run->ctx->c, "couple", "patch_size"),
                    window ? "is the window where a run's bodies land (sample = window)," : "spreads a run's bodies",
                    box ? "" : "sqrt(2) times", window ? "" : ", or bodies_per_run = 1");
    }
    return SC_OK;
}

/* Run `index` of the seeds, unless its file is already there (an earlier, interrupted process finished it). */
static int run_seeded(const struct stage_context *ctx, uint64_t hash, const struct run_settings *settings,
                      const struct couple_bodies *bodies, long index)
{
    struct impact_run run = {.ctx = ctx, .run_dir = ctx->run_dir, .case_hash = hash, .settings = *settings};
    name_run(&run, index);
    enum output_state state = run_dir_output_state(run.output, hash);
    if (state == OUTPUT_CURRENT) {
        log_info("%s: done already (%s)", run.label, run.output);
        return SC_OK;
    }
    run_dir_log_rerun(run.label, run.output, state);
    SC_TRY(mpm_config_load(ctx->c, &run.cfg));
    size_t first = bodies->first[index], count = bodies->first[index + 1] - first;
    run.seed_first = first, run.seed_count = count;
    int status;
    SC_CHECK(status, scale_to_particle(ctx->c, &run.cfg, bodies, first, count), done);
    SC_CHECK(status,
             mpm_config_set_spheres(&run.cfg, (int)count, bodies->d + first, bodies->center + 3 * first,
                                    bodies->velocity + 3 * first),
             done);
    if (bodies->temperature)
        SC_CHECK(status, mpm_config_set_particle_temperatures(&run.cfg, (int)count, bodies->temperature + first), done);
    SC_CHECK(status, seeds_over_substrate(&run), done);
    SC_CHECK(status, run_stage(&run), done);
done:
    mpm_destroy(run.solver);
    mpm_config_free(&run.cfg);
    return status;
}

/* ---- gathering the runs into impact.h5 --------------------------------------------------------------------- */

struct run_totals {
    int64_t bodies, bonded, unsettled;
    int64_t uncalibrated;          /* bodies off their bonding calibration's resolution; -1: none judged */
    double pbcp, bonded_interface; /* over every particle */
    double v_rest, cor;            /* over the settled ones */
};

/* The per-run columns of a pipeline's /summary: the share of the run's particles whose verdict settled as bonded
 * (an unsettled one counts as not bonded: run_unsettled says how many), the means of their PBCP (every particle's,
 * an unsettled one's at the end), of v_rest and CoR (the settled particles': an unsettled one's is still changing,
 * not yet a restitution; NaN when none settled), and the number of them still unsettled at the end. */
enum { RUN_COLUMNS = 5 };
static const char *const run_columns[RUN_COLUMNS] = {"run_bonded_fraction", "run_pbcp", "run_v_rest", "run_cor",
                                                     "run_unsettled"};

/* A sum over the `settled` particles as their mean; NaN when none settled. */
static double settled_mean(double sum, int64_t settled)
{
    return settled > 0 ? sum / (double)settled : NAN;
}

/* One run's /summary rows of particles (the substrate left out) added to *total; the run's own values in
 * out[RUN_COLUMNS] (run_columns). */
static int add_run_summary(hid_t summary, struct run_totals *total, double out[RUN_COLUMNS])
{
    size_t n;
    SC_TRY(h5_dataset_size(summary, "bonded", &n));
    int64_t *bonded = malloc((n ? n : 1) * sizeof *bonded), *substrate = malloc((n ? n : 1) * sizeof *substrate);
    int64_t *verdict = malloc((n ? n : 1) * sizeof *verdict);
    double *columns = malloc((n ? 4 * n : 4) * sizeof *columns);
    int status = SC_OK;
    if (!bonded || !substrate || !verdict || !columns)
        SC_FAIL_OOM_AT(status, done, (n ? n : 1) * (3 * sizeof *bonded + 4 * sizeof *columns), "a run's summary");
    SC_CHECK(status, h5_read_int64s(summary, "bonded", bonded, n), done);
    SC_CHECK(status, h5_read_int64s(summary, "substrate", substrate, n), done);
    SC_CHECK(status, h5_read_doubles(summary, "pbcp", columns, n), done);
    SC_CHECK(status, h5_read_int64s(summary, "verdict", verdict, n), done);
    SC_CHECK(status, h5_read_doubles(summary, "v_rest", columns + n, n), done);
    SC_CHECK(status, h5_read_doubles(summary, "cor", columns + 2 * n, n), done);
    SC_CHECK(status, h5_read_doubles(summary, "bonded_interface", columns + 3 * n, n), done);
    struct run_totals run = {0};
    for (size_t i = 0; i < n; i++) {
        if (substrate[i])
            continue;
        run.bodies++;
        run.bonded += bonded[i] == 1;
        run.pbcp += columns[i];
        run.bonded_interface += columns[3 * n + i];
        if (verdict[i] == MPM_VERDICT_UNSETTLED) {
            run.unsettled++;
            continue;
        }
        run.v_rest += columns[n + i];
        run.cor += columns[2 * n + i];
    }
    double bodies = run.bodies ? (double)run.bodies : 1.0;
    out[0] = (double)run.bonded / bodies;
    out[1] = run.pbcp / bodies;
    out[2] = settled_mean(run.v_rest, run.bodies - run.unsettled);
    out[3] = settled_mean(run.cor, run.bodies - run.unsettled);
    out[4] = (double)run.unsettled;
    total->bodies += run.bodies;
    total->bonded += run.bonded;
    total->unsettled += run.unsettled;
    total->pbcp += run.pbcp;
    total->v_rest += run.v_rest;
    total->cor += run.cor;
    total->bonded_interface += run.bonded_interface;
    int64_t uncalibrated = -1; /* mpm/output.c: bodies judged off their calibration's resolution */
    if (H5Aexists(summary, "uncalibrated_bodies") > 0)
        SC_CHECK(status, h5_attr_read_int64(summary, "uncalibrated_bodies", &uncalibrated), done);
    if (uncalibrated >= 0)
        total->uncalibrated = (total->uncalibrated > 0 ? total->uncalibrated : 0) + uncalibrated;
done:
    free(bonded);
    free(substrate);
    free(verdict);
    free(columns);
    return status;
}

/* Copy run file `index` (its snapshots, series, summary, stats) into /run_NNNN of the output. */
static int gather_run(hid_t out, const char *run_dir, long index, struct run_totals *total, double means[RUN_COLUMNS])
{
    struct impact_run names = {.run_dir = run_dir};
    name_run(&names, index);
    hid_t source;
    SC_TRY(h5_open_read(names.output, &source));
    char group[32];
    snprintf(group, sizeof group, "run_%04ld", index);
    hid_t summary = H5I_INVALID_HID;
    int status;
    SC_CHECK(status, h5_copy(source, "/", out, group), done); /* not H5Ocopy: it crashes on a full disk */
    summary = H5Gopen2(source, "summary", H5P_DEFAULT);
    if (summary < 0)
        SC_FAIL_AT(status, done, SC_EIO, "impact: %s has no /summary", names.output);
    SC_CHECK(status, add_run_summary(summary, total, means), done);
done:
    if (summary >= 0)
        H5Gclose(summary);
    H5Fclose(source);
    return status;
}

/* /summary of the whole stage: per run (run_columns) and over all bodies. */
static int write_overall_summary(hid_t out, long runs, const double *means, const struct run_totals *total)
{
    hid_t g;
    SC_TRY(h5_create_group(out, "summary", &g));
    double *column = malloc((size_t)runs * sizeof *column);
    int status = SC_OK;
    if (!column)
        SC_FAIL_OOM_AT(status, done, (size_t)runs * sizeof *column, "the summary of the runs");
    static const char *const units[RUN_COLUMNS] = {"-", "-", "m/s", "-", "-"};
    hsize_t dims[1] = {(hsize_t)runs};
    for (int k = 0; k < RUN_COLUMNS; k++) {
        for (long r = 0; r < runs; r++)
            column[r] = means[RUN_COLUMNS * r + k];
        SC_CHECK(status, h5_write_doubles(g, run_columns[k], 1, dims, column, units[k], 0), done);
    }
    double bodies = total->bodies ? (double)total->bodies : 1.0;
    SC_CHECK(status, h5_attr_write_int64(g, "runs", runs), done);
    SC_CHECK(status, h5_attr_write_int64(g, "bodies", total->bodies), done);
    SC_CHECK(status, h5_attr_write_int64(g, "bonded", total->bonded), done);
    SC_CHECK(status, h5_attr_write_double(g, "bonded_fraction", (double)total->bonded / bodies), done);
    SC_CHECK(status, h5_attr_write_int64(g, "unsettled", total->unsettled), done);
    SC_CHECK(status, h5_attr_write_double(g, "mean_pbcp", total->pbcp / bodies), done);
    int64_t settled = total->bodies - total->unsettled;
    SC_CHECK(status, h5_attr_write_double(g, "mean_v_rest", settled_mean(total->v_rest, settled)), done);
    SC_CHECK(status, h5_attr_write_double(g, "mean_cor", settled_mean(total->cor, settled)), done);
    SC_CHECK(status, h5_attr_write_double(g, "mean_bonded_interface", total->bonded_interface / bodies), done);
    SC_CHECK(status, h5_attr_write_int64(g, "uncalibrated_bodies", total->uncalibrated), done);
    log_info("impact: %lld of %lld bodies bonded (%.1f %%), %lld unsettled, over %ld runs; mean PBCP %.2f %%, mean "
             "bonded interface %.2f %%, mean v_rest %.3g m/s (of the %lld settled)",
             (long long)total->bonded, (long long)total->bodies, 100.0 * (double)total->bonded / bodies,
             (long long)total->unsettled, runs, 100.0 * total->pbcp / bodies, 100.0 * total->bonded_interface / bodies,
             settled_mean(total->v_rest, settled), (long long)settled);
done:
    free(column);
    H5Gclose(g);
    return status;
}

struct gathering {
    const char *run_dir;
    long runs;
};

static int gathered_contents(void *owner, hid_t file)
{
    const struct gathering *g = owner;
    SC_TRY(h5_attr_write_int64(file, "runs", g->runs));
    double *means = malloc((size_t)g->runs * RUN_COLUMNS * sizeof *means);
    if (!means)
        SC_FAIL_OOM((size_t)g->runs * RUN_COLUMNS * sizeof *means, "the means of the runs");
    struct run_totals total = {.uncalibrated = -1};
    int status;
    for (long r = 0; r < g->runs; r++)
        SC_CHECK(status, gather_run(file, g->run_dir, r, &total, means + RUN_COLUMNS * r), done);
    SC_CHECK(status, write_overall_summary(file, g->runs, means, &total), done);
done:
    free(means);
    return status;
}

/* impact.xdmf of several runs: the first run's (every run has its impact_run_NNNN.xdmf). */
static int write_first_run_xdmf(const char *run_dir)
{
    char from[H5IO_PATH_MAX], to[H5IO_PATH_MAX];
    snprintf(from, sizeof from, "%s/impact_run_0000.xdmf", run_dir);
    snprintf(to, sizeof to, "%s/impact.xdmf", run_dir);
    FILE *in = fopen(from, "r");
    if (!in)
        SC_FAIL(SC_EIO, "cannot read %s: %s", from, strerror(errno));
    struct atomic_file out;
    int opened = 0, status;
    SC_CHECK(status, atomic_open(to, &out), done);
    opened = 1;
    char buffer[8192];
    size_t got;
    while ((got = fread(buffer, 1, sizeof buffer, in)) > 0)
        if (fwrite(buffer, 1, got, out.stream) != got)
            SC_FAIL_AT(status, done, SC_EIO, "cannot write %s: %s", to, strerror(errno));
    SC_CHECK(status, atomic_publish(&out), done);
done:
    fclose(in);
    /* a failed atomic_open leaves nothing to abort (nor a struct atomic_abort may read) */
    if (status != SC_OK && opened)
        atomic_abort(&out);
    return status;
}

/* Each run's staged XDMF index to RUN_DIR/impact_run_NNNN.xdmf (rename: atomic), once the gathered impact.h5 it
 * points into is complete; a run whose index was moved before (an interrupted gathering) keeps it. */
static int publish_run_xdmf(const char *run_dir, long index)
{
    struct impact_run names = {.run_dir = run_dir};
    name_run(&names, index);
    char to[H5IO_PATH_MAX];
    snprintf(to, sizeof to, "%s/impact_run_%04ld.xdmf", run_dir, index);
    if (rename(names.xdmf, to) != 0 && !(errno == ENOENT && access(to, F_OK) == 0))
        SC_FAIL(SC_EIO, "cannot move %s to %s: %s", names.xdmf, to, strerror(errno));
    return SC_OK;
}

static int gathered_xdmf(void *owner)
{
    const struct gathering *g = owner;
    for (long r = 0; r < g->runs; r++)
        SC_TRY(publish_run_xdmf(g->run_dir, r));
    return write_first_run_xdmf(g->run_dir);
}

/* impact.h5 of several runs with impact.xdmf as its side file (app.h stage_write_outputs). */
static int write_gathered(const struct stage_context *ctx, uint64_t hash, long runs)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.h5", ctx->run_dir);
    struct gathering g = {.run_dir = ctx->run_dir, .runs = runs};
    SC_TRY(stage_write_outputs(path, MPM_FORMAT, MPM_FORMAT_VERSION, STAGE, hash, ctx->c, gathered_contents,
                               gathered_xdmf, &g));
    log_info("impact: wrote %s (%ld runs)", path, runs);
    return SC_OK;
}

/* The run files are copied into impact.h5: remove them and their folder, and what an interruption between a
 * run's file and its clean-up may have left (its snapshots, its checkpoints). */
static int remove_run_files(const char *run_dir, long runs)
{
    for (long r = 0; r < runs; r++) {
        struct impact_run names = {.run_dir = run_dir};
        name_run(&names, r);
        if (unlink(names.output) != 0 && errno != ENOENT)
            SC_FAIL(SC_EIO, "cannot remove %s: %s", names.output, strerror(errno));
        if (unlink(names.xdmf) != 0 && errno != ENOENT) /* moved by gathered_xdmf; left by an older layout */
            SC_FAIL(SC_EIO, "cannot remove %s: %s", names.xdmf, strerror(errno));
        SC_TRY(clear_snapshots(&names, 1));
        SC_TRY(h5_checkpoint_remove_all(run_dir, names.label));
    }
    char folder[H5IO_PATH_MAX];
    snprintf(folder, sizeof folder, "%s/" RUNS_DIR, run_dir);
    if (rmdir(folder) != 0 && errno != ENOENT && errno != ENOTEMPTY)
        SC_FAIL(SC_EIO, "cannot remove folder %s: %s", folder, strerror(errno));
    return SC_OK;
}

static int gather(const struct stage_context *ctx, uint64_t hash, long runs);

static int run_all_seeded(const struct stage_context *ctx, uint64_t hash, const struct run_settings *settings)
{
    const char *run_dir = ctx->run_dir;
    struct couple_bodies bodies;
    SC_TRY(couple_stage_read_bodies(ctx, &bodies));
    char folder[H5IO_PATH_MAX];
    snprintf(folder, sizeof folder, "%s/" RUNS_DIR, run_dir);
    int status = SC_OK;
    if (parallel_rank() == 0 && mkdir(folder, 0777) != 0 && errno != EEXIST)
        status = sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot create folder %s: %s", folder, strerror(errno));
    status = parallel_share_status(status);
    long runs = (long)bodies.runs;
    if (parallel_rank() == 0)
        log_info("impact: %ld runs of the couple stage's seeds (%zu bodies) on %d process%s", runs, bodies.count,
                 parallel_size(), parallel_size() > 1 ? "es" : "");
    /* every rank takes the next run not yet taken (dynamic balance: runs differ in size) */
    parallel_tasks_begin();
    for (int64_t r; status == SC_OK && (r = parallel_task_next()) < runs;)
        if ((status = run_seeded(ctx, hash, settings, &bodies, (long)r)) != SC_OK)
            sc_error_trace(__FILE__, __LINE__);
    parallel_tasks_end();
    couple_stage_bodies_free(&bodies);
    /* rank 0 gathers once every rank is done; the others report its status */
    status = parallel_max_status(status);
    if (status == SC_OK && parallel_rank() == 0)
        status = gather(ctx, hash, runs);
    return parallel_share_status(status);
}

static int gather(const struct stage_context *ctx, uint64_t hash, long runs)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.h5", ctx->run_dir);
    SC_TRY(write_gathered(ctx, hash, runs));
    return remove_run_files(ctx->run_dir, runs);
}

/* impact.h5 is there, but a process killed while it cleaned up may have left run files, snapshots and
 * checkpoints of the runs behind. */
static int remove_leftovers(const struct stage_context *ctx)
{
    const char *run_dir = ctx->run_dir;
    if (ctx->impact_from_seeds)
        return remove_run_files(run_dir, case_int(ctx->c, "couple", "runs"));
    struct impact_run names = {.run_dir = run_dir};
    name_run(&names, -1);
    return clear_snapshots(&names, 1);
}

int impact_stage_run(const struct stage_context *ctx)
{
    uint64_t hash = stage_hash(ctx, STAGE);
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/impact.h5", ctx->run_dir);
    struct run_settings settings;
    if (stage_begin(STAGE, path, hash, ctx->c, &settings))
        return parallel_rank() == 0 ? remove_leftovers(ctx) : SC_OK;
    if (ctx->impact_from_seeds)
        return run_all_seeded(ctx, hash, &settings);
    /* one run: rank 0's (the others have nothing to share) */
    return parallel_rank() == 0 ? run_single(ctx, hash, &settings) : SC_OK;
}
