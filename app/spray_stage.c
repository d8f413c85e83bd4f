/* The spray stage driver: checkpoints, resume, signals, progress and RUN_DIR/spray.h5. */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/run_keys.h"
#include "app/app.h"
#include "dem/dem.h"

#define STAGE "spray"

struct spray_run {
    const struct stage_context *ctx;
    struct run_settings settings;
    struct dem_config cfg;
    struct dem_solver *solver;
    uint64_t case_hash;
    struct stage_timing timing;
    int64_t loop_particle_steps, loop_steps; /* advanced by the time loop of this process */
    struct dem_snapshots snapshots;          /* spray.h5 /snapshots, kept in the checkpoints */
    int64_t snapshot_steps;                  /* 0: none */
};

/* ---- the solver as the stage loop sees it (struct stage_ops) ---- */

/* A snapshot every snapshot_steps and at the last step: taken inside the step, so that the checkpoint written
 * after a step holds exactly the snapshots up to it and a resumed run neither repeats nor misses one. */
static int step(void *owner)
{
    struct spray_run *run = owner;
    SC_TRY(dem_step(run->solver));
    int64_t now = dem_get_counts(run->solver).step;
    if (run->snapshot_steps > 0 && (now % run->snapshot_steps == 0 || now == dem_total_steps(run->solver)))
        SC_TRY(dem_snapshot_take(run->solver, &run->snapshots));
    return SC_OK;
}

static int finished(void *owner)
{
    struct spray_run *run = owner;
    return dem_get_counts(run->solver).step >= dem_total_steps(run->solver);
}

static void position(void *owner, int64_t *step_index, double *t, int64_t *progress)
{
    struct dem_counts counts = dem_get_counts(((struct spray_run *)owner)->solver);
    *step_index = *progress = counts.step;
    *t = counts.t;
}

static void describe(void *owner, char *text, size_t size)
{
    struct dem_counts counts = dem_get_counts(((struct spray_run *)owner)->solver);
    snprintf(text, size, "in flight %lld, deposited %lld, resting %lld, escaped %lld", (long long)counts.in_flight,
             (long long)counts.deposited, (long long)counts.resting, (long long)counts.escaped);
}

static int checkpoint_write(void *owner, hid_t file)
{
    struct spray_run *run = owner;
    SC_TRY(dem_checkpoint_write(run->solver, file));
    return dem_snapshots_write(&run->snapshots, file, 1);
}

static int checkpoint_read(void *owner, hid_t file)
{
    struct spray_run *run = owner;
    SC_TRY(dem_checkpoint_read(run->solver, file));
    return dem_snapshots_read(file, &run->snapshots);
}

static int time_loop(struct spray_run *run)
{
    char note[H5IO_PATH_MAX + 100];
    snprintf(note, sizeof note, "checkpoint written, continue with `spraycoat resume %s`", stage_resume_dir(run->ctx));
    const struct stage_ops ops = {.label = STAGE,
                                  .stage = STAGE,
                                  .format = DEM_FORMAT,
                                  .format_version = DEM_FORMAT_VERSION,
                                  .case_hash = run->case_hash,
                                  .run_dir = run->ctx->run_dir,
                                  .settings = &run->settings,
                                  .progress_unit = "steps",
                                  .progress_total = dem_total_steps(run->solver),
                                  .owner = run,
                                  .step = step,
                                  .finished = finished,
                                  .position = position,
                                  .describe = describe,
                                  .checkpoint_write = checkpoint_write,
                                  .checkpoint_read = checkpoint_read,
                                  .interrupted_note = note};
    int resumed;
    SC_TRY(stage_loop_resume(&ops, &resumed));
    struct dem_counts before = dem_get_counts(run->solver);
    SC_TRY(stage_loop_run(&ops, &run->timing));
    struct dem_counts after = dem_get_counts(run->solver);
    run->loop_particle_steps = after.particle_steps - before.particle_steps;
    run->loop_steps = after.step - before.step;
    return SC_OK;
}

static int output_contents(void *owner, hid_t file)
{
    struct spray_run *run = owner;
    SC_TRY(dem_write_output(run->solver, file));
    return dem_snapshots_write(&run->snapshots, file, 0);
}

/* The fields of a particle grid in spray.h5 at `where`: v, d, id, state (and w, m, temperature for /particles). */
static void xdmf_particle_fields(FILE *file, const char *indent, size_t n, const char *where, int final)
{
    xdmf_geometry(file, indent, n, where);
    xdmf_attribute(file, indent, "v", XDMF_VECTOR, n, where);
    if (final)
        xdmf_attribute(file, indent, "w", XDMF_VECTOR, n, where);
    xdmf_attribute(file, indent, "d", XDMF_SCALAR, n, where);
    if (final) {
        xdmf_attribute(file, indent, "m", XDMF_SCALAR, n, where);
        xdmf_attribute(file, indent, "temperature", XDMF_SCALAR, n, where);
    }
    xdmf_attribute(file, indent, "id", XDMF_INTEGER, n, where);
    xdmf_attribute(file, indent, "state", XDMF_INTEGER, n, where);
}

/* The snapshots as a temporal collection: one grid a snapshot, its vertex cells a hyperslab of
 * /snapshots/index. */
static void xdmf_snapshots(FILE *file, const struct dem_snapshots *list)
{
    size_t most = 0;
    for (size_t i = 0; i < list->count; i++)
        most = list->items[i].count > most ? list->items[i].count : most;
    fprintf(file, "  <Grid Name=\"spray\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for (size_t i = 0; i < list->count; i++) {
        size_t n = list->items[i].count;
        char where[64];
        snprintf(where, sizeof where, "spray.h5:/snapshots/%06zu", i);
        fprintf(file,
                "   <Grid Name=\"%06zu\" GridType=\"Uniform\">\n    <Time Value=\"%.17g\"/>\n"
                "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%zu\" NodesPerElement=\"1\">\n",
                i, list->items[i].t, n);
        if (n > 0)
            xdmf_slab_indices(file, "     ", n, most, "spray.h5:/snapshots/index");
        fprintf(file, "    </Topology>\n");
        xdmf_particle_fields(file, "    ", n, where, 0);
        fprintf(file, "   </Grid>\n");
    }
    fprintf(file, "  </Grid>\n");
}

/* RUN_DIR/spray.xdmf for ParaView/VisIt: the snapshots of spray.h5 as a time series, or, without snapshots
 * (snapshot_every = 0), the final particles.  The Polyvertex topology has its connectivity: without it the
 * Xdmf3 readers of ParaView make no cells, and the Surface and Points representations draw nothing. */
static int write_xdmf(const struct spray_run *run)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.xdmf", run->ctx->run_dir);
    size_t n = dem_particle_count(run->solver);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    FILE *file = out.stream;
    fprintf(file, "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n");
    if (run->snapshots.count > 0) {
        xdmf_snapshots(file, &run->snapshots);
    } else {
        fprintf(file,
                "  <Grid Name=\"particles\" GridType=\"Uniform\">\n"
                "   <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%zu\" NodesPerElement=\"1\">\n",
                n);
        /* /particles/id is not 0 .. n-1 once particles have escaped: the connectivity is inline */
        if (n > 0)
            xdmf_inline_indices(file, "    ", n);
        fprintf(file, "   </Topology>\n");
        xdmf_particle_fields(file, "   ", n, "spray.h5:/particles", 1);
        fprintf(file, "  </Grid>\n");
    }
    fprintf(file, " </Domain>\n</Xdmf>\n");
    return atomic_publish(&out);
}

/* RUN_DIR/deposit.xdmf: the height map spray.h5:/deposit/height on a co-rectilinear mesh one node thick in the target
 * plane z = standoff, whose nodes are the cells' centres (ParaView: the Surface representation coloured by height, or
 * Warp By Scalar for the relief).  A 2DCoRectMesh would do, but ParaView's readers lay it in the y-z plane. */
static int write_deposit_xdmf(const struct spray_run *run, const struct dem_deposit *d)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/deposit.xdmf", run->ctx->run_dir);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    fprintf(
        out.stream,
        "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
        "  <Grid Name=\"deposit\" GridType=\"Uniform\">\n"
        "   <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"1 %zu %zu\"/>\n"
        "   <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
        "    <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">%.17g %.17g "
        "%.17g</DataItem>\n"
        "    <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">1 %.17g %.17g</DataItem>\n"
        "   </Geometry>\n"
        "   <Attribute Name=\"height\" AttributeType=\"Scalar\" Center=\"Node\">\n"
        "    <DataItem Dimensions=\"1 %zu %zu\" NumberType=\"Float\" Precision=\"8\" "
        "Format=\"HDF\">spray.h5:/deposit/height</DataItem>\n"
        "   </Attribute>\n  </Grid>\n </Domain>\n</Xdmf>\n",
        d->ny, d->nx, run->cfg.standoff, d->y0, d->x0, d->cell, d->cell, d->ny, d->nx);
    return atomic_publish(&out);
}

/* The deposit's index file and its figures in the log: the track's mean thickness and Gaussian fit. */
static int deposit_summary(const struct spray_run *run)
{
    struct dem_deposit d;
    SC_TRY(dem_deposit_build(run->solver, &d));
    /* a fixed nozzle's deposit is spray_thickness's radial profile: no index file for it */
    int status = run->cfg.path.pattern == DEM_PATH_NONE ? SC_OK : write_deposit_xdmf(run, &d);
    if (d.profile_count)
        log_info("spray: deposit: mean thickness %.4g m over the band y in [%.4g, %.4g] m (height map of %zu x %zu "
                 "cells of %.3g m, packing %.3g)",
                 d.mean_thickness, d.band_lo, d.band_hi, d.nx, d.ny, d.cell, d.packing);
    if (d.has_fit)
        log_info("spray: track profile: Gaussian fit amplitude %.4g +- %.2g m, width (sigma) %.4g +- %.2g m, centre "
                 "y = %.5g +- %.2g m",
                 d.fit.amplitude, d.fit.amplitude_error, d.fit.width, d.fit.width_error, d.fit.centre,
                 d.fit.centre_error);
    dem_deposit_free(&d);
    return status;
}

/* spray.h5's side files: the XDMF indexes of its particles and deposit (and the deposit's figures in the log). */
static int side_files(void *owner)
{
    const struct spray_run *run = owner;
    SC_TRY(write_xdmf(run));
    return deposit_summary(run);
}

static int write_output(struct spray_run *run)
{
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.h5", run->ctx->run_dir);
    SC_TRY(stage_write_outputs(path, DEM_FORMAT, DEM_FORMAT_VERSION, STAGE, run->case_hash, run->ctx->c,
                               output_contents, side_files, run));
    log_info("spray: wrote %s", path);
    return SC_OK;
}

/* Where the time loop's wall time went, by phase of the step (dem_get_timing), and its rate. */
static void log_timing(const struct spray_run *run)
{
    struct dem_timing t = dem_get_timing(run->solver);
    double loop = run->timing.loop > 0.0 ? run->timing.loop : 1e-300;
    double other = loop - (t.injection + t.broad_phase + t.contacts + t.integration + t.boundaries + t.metrics +
                           run->timing.checkpoints);
    int threads = omp_get_max_threads();
    log_info("spray: time loop %.3f s wall on %d thread%s, %.3g M particle-steps/s: integration %.1f %%, broad "
             "phase %.1f %%, contacts %.1f %%, injection %.1f %%, boundaries %.1f %%, metrics %.1f %%, "
             "checkpoints %.1f %%, other %.1f %%",
             run->timing.loop, threads, threads == 1 ? "" : "s", (double)run->loop_particle_steps / loop / 1e6,
             100.0 * t.integration / loop, 100.0 * t.broad_phase / loop, 100.0 * t.contacts / loop,
             100.0 * t.injection / loop, 100.0 * t.boundaries / loop, 100.0 * t.metrics / loop,
             100.0 * run->timing.checkpoints / loop, 100.0 * other / loop);
    log_info("spray: broad phase: %lld grid builds and %lld repairs in %lld steps", (long long)t.grid_builds,
             (long long)t.grid_repairs, (long long)run->loop_steps);
}

/* The DE by mass (spray.h5 /deposition_efficiency) and its classes, as the closing lines of the stage. */
static void log_de_classes(const char *what, const struct dem_de_class *classes, size_t count, double scale)
{
    char text[2048];
    size_t used = 0;
    for (size_t k = 0; k < count && used < sizeof text - 64; k++)
        if (classes[k].sprayed_count > 0)
            used += (size_t)snprintf(text + used, sizeof text - used, " %.3g-%.3g: %.3f (%lld);", scale * classes[k].lo,
                                     scale * classes[k].hi, classes[k].de, (long long)classes[k].sprayed_count);
    log_info("spray: DE by %s (particles sprayed):%s", what, used ? text : " none");
}

static void log_deposition_efficiency(const struct spray_run *run)
{
    struct dem_deposition_efficiency de;
    if (dem_deposition_efficiency(run->solver, &de) != SC_OK) {
        sc_error_clear();
        return;
    }
    char impacts[128] = "no impact";
    if (!isnan(de.mean_impact_speed))
        snprintf(impacts, sizeof impacts, "first impacts at %.4g m/s (normal %.4g m/s) on average",
                 de.mean_impact_speed, de.mean_impact_normal_speed);
    log_info("spray: deposition efficiency (mass) %.4f: %.4g of %.4g kg sprayed deposited (%lld of %lld particles); "
             "%s",
             de.de, de.deposited_mass, de.sprayed_mass, (long long)de.deposited_count, (long long)de.sprayed_count,
             impacts);
    log_de_classes("size (um)", de.by_size, de.size_count, 1e6);
    log_de_classes("first-impact angle (degree)", de.by_angle, de.angle_count, 180.0 / M_PI);
    if (de.table_impacts_outside > 0) /* dem_vcrit_lookup clamps: the edge's v_crit, never an extrapolation */
        log_warn("spray: %lld of the %lld impacts judged by the v_crit table (%.1f %%) had a diameter or temperature "
                 "beyond its grid and took the v_crit of its nearest edge: widen the search that made the table "
                 "([vcrit] diameters, temperatures) to cover the powder",
                 (long long)de.table_impacts_outside, (long long)de.table_impacts,
                 100.0 * (double)de.table_impacts_outside / (double)de.table_impacts);
    /* the DE counts a particle still flying at the end as sprayed and not deposited (docs/physics.md "Deposition
     * efficiency"): a lower bound that the headline alone does not show once many are in the air */
    struct dem_metrics m = dem_compute_metrics(run->solver);
    if (de.sprayed_count > 0 && (double)m.in_flight > DEM_DE_LOWER_BOUND_IN_FLIGHT * (double)de.sprayed_count)
        log_warn(
            "spray: %lld of the %lld particles sprayed (%.1f %%) were still in flight at t_end: the DE counts them "
            "as not deposited, so it is a lower bound; a longer [spray] t_end (or an injection that stops "
            "earlier) lets them land",
            (long long)m.in_flight, (long long)de.sprayed_count,
            100.0 * (double)m.in_flight / (double)de.sprayed_count);
    dem_deposition_efficiency_free(&de);
}

static void log_summary(const struct spray_run *run)
{
    struct dem_metrics m = dem_compute_metrics(run->solver);
    struct dem_counts c = dem_get_counts(run->solver);
    log_info("spray: t = %.6g s: injected %lld, deposited %lld (deposit fraction by count %.4f), resting %lld, escaped "
             "%lld, in flight %lld",
             m.t, (long long)m.injected, (long long)m.deposited, m.deposit_fraction, (long long)m.resting,
             (long long)m.escaped, (long long)m.in_flight);
    log_info("spray: deposits made on a first impact %lld (share %.4f); target contacts per injected particle %.3g",
             (long long)m.first_impact_deposits, m.first_impact_share,
             m.injected ? (double)c.contacts_target / (double)m.injected : 0.0);
    log_info("spray: contacts: particle-particle %lld, target %lld, deposit %lld, turned away by the drag before "
             "they met %lld; fixed-point iterations %.2f per solve (max %lld, unconverged %lld), sub-cycled "
             "particle-steps %lld",
             (long long)c.contacts_pair, (long long)c.contacts_target, (long long)c.contacts_deposit,
             (long long)c.contacts_turned_away,
             c.fixed_point_solves ? (double)c.fixed_point_iterations / (double)c.fixed_point_solves : 0.0,
             (long long)c.max_iterations, (long long)c.fixed_point_unconverged, (long long)c.subcycled_particle_steps);
    if (c.clamps) /* the contact search missed a contact (docs/physics.md, "Contact detection") */
        log_warn("spray: %lld end-of-step corrections (clamps): particles put back out of the target or another "
                 "particle; %lld stopped caught between bodies",
                 (long long)c.clamps, (long long)c.trapped);
    else
        log_info("spray: no end-of-step corrections (clamps): no particle ended a step inside another or the target; "
                 "%lld stopped caught between bodies",
                 (long long)c.trapped);
    log_info("spray: volume fraction %.4g, mean spread %.4g m, scatter %.4g m, max thickness %.4g m%s",
             m.volume_fraction, m.mean_spread, m.scatter, m.max_thickness,
             run->cfg.path.pattern == DEM_PATH_NONE ? ""
                                                    : " (the first three measured from the origin, where the nozzle's "
                                                      "path starts, not from its moving axis)");
    log_deposition_efficiency(run);
    log_timing(run);
}

static int run_stage(struct spray_run *run)
{
    SC_TRY(dem_create(&run->cfg, &run->solver));
    run->snapshot_steps = dem_snapshot_steps(&run->cfg);
    log_info("spray: %lld steps of %.3g s to t_end = %.6g s on %d threads", (long long)dem_total_steps(run->solver),
             run->cfg.dt, run->cfg.t_end, omp_get_max_threads());
    const struct dem_gas_field *gas = &run->cfg.gas;
    if (gas->shock_standoff > 0.0) /* docs/physics.md "The bow shock at the target" */
        log_info("spray: the jet arrives at Mach %.3g: a bow shock %.3g m before the target, behind it rho2/rho1 = "
                 "%.3g, u2/u1 = %.3g, T2/T1 = %.3g",
                 gas->shock_mach, gas->shock_standoff, gas->shock_density_ratio, gas->shock_velocity_ratio,
                 gas->shock_temperature_ratio);
    SC_TRY(time_loop(run));
    SC_TRY(dem_check_accounting(run->solver));
    /* spray.h5 marks the stage done: its side files (the XDMF indexes) are written before it is published, and never
     * beside another case's spray.h5 (app.h stage_write_outputs) */
    SC_TRY(write_output(run));
    /* the stage is complete: its checkpoints would only stop a changed case from running here */
    SC_TRY(h5_checkpoint_remove_all(run->ctx->run_dir, STAGE));
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

int spray_stage_validate(const struct stage_context *ctx)
{
    validated_drop();
    SC_TRY(dem_config_load(ctx->c, &validated.cfg));
    validated.c = ctx->c;
    if (!ctx->run_dir)
        return SC_OK;
    /* refuse checkpoints of another case before anything in the run directory is written */
    return h5_checkpoint_check_newest(ctx->run_dir, STAGE, DEM_FORMAT, DEM_FORMAT_VERSION, stage_hash(ctx, STAGE));
}

int spray_stage_run(const struct stage_context *ctx)
{
    struct spray_run run = {.ctx = ctx, .case_hash = stage_hash(ctx, STAGE)};
    char path[H5IO_PATH_MAX];
    snprintf(path, sizeof path, "%s/spray.h5", ctx->run_dir);
    if (stage_begin(STAGE, path, run.case_hash, ctx->c, &run.settings)) {
        validated_drop();
        return SC_OK;
    }
    SC_TRY(config_for_run(ctx->c, &run.cfg));
    int status = run_stage(&run);
    dem_snapshots_free(&run.snapshots);
    dem_destroy(run.solver);
    dem_config_free(&run.cfg);
    return status;
}
