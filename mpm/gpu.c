/* The host's side of the GPU step (mpm/gpu.h, docs/gpu.md): the device state made from the solver, the step's
 * clocks and accounting, and the host's copy of the points brought up to date when the host reads it.  The
 * device's side is mpm/cuda/step.cu (make CUDA=1), or mpm/gpu_stub.c.  A fault of the device or its runtime (a copy,
 * a launch, a sum that fails) is SC_EIO, exit status 3 as for a full disk or no memory: the machine failed, not the
 * simulation, and a rerun may pass (`vcrit` and `calibrate` record a run that fails as a simulation, SC_ESIM, as
 * failed and never run it again); a non-finite state the step found stays SC_ESIM. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/log.h"
#include "mpm/gpu.h"
#include "mpm/mpm_impl.h"

_Static_assert((int)GPU_POINT_ACTIVE == (int)POINT_ACTIVE && (int)GPU_POINT_SURFACE == (int)POINT_SURFACE &&
                   (int)GPU_POINT_BOTTOM == (int)POINT_BOTTOM && (int)GPU_POINT_SIDE == (int)POINT_SIDE &&
                   (int)GPU_POINT_CONTACT == (int)POINT_CONTACT,
               "the point flags of mpm/gpu.h are those of mpm_impl.h");

static struct mpm_gpu_points host_points(const struct mpm_solver *s)
{
    const struct mpm_points *p = &s->points;
    return (struct mpm_gpu_points){.x = p->x,
                                   .v = p->v,
                                   .mass = p->mass,
                                   .volume0 = p->volume0,
                                   .volume = p->volume,
                                   .d_bond = p->d_bond,
                                   .plastic_work = p->plastic_work,
                                   .normal = p->normal,
                                   .state = p->state,
                                   .body = p->body,
                                   .flags = p->flags};
}

/* The host's arrays must be in id order: a solver on the GPU is never reordered (mpm_step), and both the set-up
 * and a checkpoint leave the points in that order. */
static int check_id_order(const struct mpm_solver *s)
{
    for (size_t q = 0; q < s->points.count; q++)
        if (s->points.id[q] != q)
            SC_FAIL(SC_ESIM, "impact: the GPU step needs the points in set-up order (point %zu holds id %u)", q,
                    (unsigned)s->points.id[q]);
    return SC_OK;
}

int mpm_gpu_attach(struct mpm_solver *s)
{
    const struct mpm_config *cfg = &s->cfg;
    const struct mpm_grid *g = &s->grid;
    int *body_material = malloc((size_t)cfg->body_count * sizeof *body_material);
    if (!body_material)
        SC_FAIL_OOM((size_t)cfg->body_count * sizeof *body_material, "the GPU step's bodies");
    for (int b = 0; b < cfg->body_count; b++)
        body_material[b] = cfg->bodies[b].material;
    struct mpm_gpu_setup setup = {
        .points = s->points.count,
        .bodies = cfg->body_count,
        .materials = cfg->material_count,
        .h = g->h,
        .inv_h = g->inv_h,
        .mass_cutoff = g->mass_cutoff,
        .moments = g->moments,
        .flip = cfg->flip,
        .friction = cfg->friction,
        .contact_gap = cfg->contact_gap,
        .bond_gap = cfg->bond_gap,
        .substrate_top = cfg->substrate_top,
        .substrate_bottom = cfg->substrate_bottom,
        .contact = (int)cfg->contact,
        .contact_scheme = (int)cfg->contact_scheme,
        .contact_approach = (int)cfg->contact_approach,
        .bond_growth = (int)cfg->bond_growth,
        .rigid_wall = cfg->substrate == MPM_SUBSTRATE_RIGID,
        .fixed_bottom = cfg->fixed_bottom,
        .bonding = (int)cfg->bonding,
        .Gc = cfg->Gc,
        .Gc_rate = cfg->Gc_rate,
        .eps_c = cfg->eps_c,
        .eps_rate_c = cfg->eps_rate_c,
        .bonding_floor = cfg->bonding_floor,
        .viscosity = cfg->viscosity,
        .material = cfg->materials,
        .constants = s->material_constants,
        .body_material = body_material,
        .body_dashpot = s->body_dashpot,
        .body_bond_scale = s->body_bond_scale,
    };
    for (int d = 0; d < 3; d++) {
        setup.origin[d] = g->origin[d];
        setup.inside_from[d] = g->inside_from[d];
        setup.inside_to[d] = g->inside_to[d];
        setup.n[d] = g->n[d];
    }
    for (int d = 0; d < 2; d++) {
        setup.mirror[d] = cfg->mirror[d];
        setup.mirror_plane[d] = g->mirror_plane[d];
    }
    mpm_conduction_kernel(s, &setup.conduction_eps2, &setup.conduction_laplacian);
    int status = check_id_order(s);
    if (status == SC_OK && mpm_gpu_open(&setup, &s->gpu) != 0)
        status = sc_error_set(SC_EINPUT, __FILE__, __LINE__, "[run] device = gpu: %s", mpm_gpu_message());
    free(body_material);
    SC_TRY(status);
    log_info("impact: the step runs on %s", mpm_gpu_name(s->gpu));
    return mpm_gpu_reload(s);
}

void mpm_gpu_detach(struct mpm_solver *s)
{
    mpm_gpu_close(s->gpu);
    s->gpu = NULL;
}

int mpm_gpu_reload(struct mpm_solver *s)
{
    if (!s->gpu)
        return SC_OK;
    SC_TRY(check_id_order(s));
    struct mpm_gpu_points p = host_points(s);
    if (mpm_gpu_upload(s->gpu, &p) != 0)
        SC_FAIL(SC_EIO, "impact: copying the points to the GPU: %s", mpm_gpu_message());
    return SC_OK;
}

int mpm_gpu_sync(const struct mpm_solver *s)
{
    if (!s->gpu || !mpm_gpu_host_stale(s->gpu))
        return SC_OK;
    struct mpm_gpu_points p = host_points(s); /* the arrays, not the solver, are written */
    if (mpm_gpu_download(s->gpu, &p) != 0)
        SC_FAIL(SC_EIO, "impact: copying the points from the GPU: %s", mpm_gpu_message());
    return SC_OK;
}

/* The bodies' interface counts (mpm_contact_interface_nodes) from the device's grid: the host's is not filled on
 * the GPU.  A device that fails here gives -1 each (not counted) with a warning; the next step reports the fault. */
void mpm_gpu_count_interface(const struct mpm_solver *s, int64_t *interface, int64_t *bonded)
{
    if (mpm_gpu_interface_nodes(s->gpu, interface, bonded) == 0)
        return;
    log_warn("impact: counting the interface nodes on the GPU: %s", mpm_gpu_message());
    for (int b = 0; b < s->cfg.body_count; b++)
        interface[b] = bonded[b] = -1;
}

int mpm_gpu_body_sums(const struct mpm_solver *s, struct point_sums *sums)
{
    if (mpm_gpu_point_sums(s->gpu, s->cfg.vrest_filter, sums) != 0)
        SC_FAIL(SC_EIO, "impact: step %lld (t = %.6g s): summing the diagnostics on the GPU: %s", (long long)s->step,
                s->t, mpm_gpu_message());
    return SC_OK;
}

/* The time step of Section 3.4 (choose_time_step of solver.c), from the speeds the last device step found, or from
 * the host's points after set-up or a checkpoint (then up to date). */
static void gpu_time_step(struct mpm_solver *s)
{
    const struct mpm_points *p = &s->points;
    double vmax2 = s->vmax2;
    if (!s->vmax2_known) {
        vmax2 = 0.0;
        for (size_t q = 0; q < p->count; q++)
            if (p->flags[q] & POINT_ACTIVE) {
                const double *v = p->v + 3 * q;
                double v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                vmax2 = v2 > vmax2 ? v2 : vmax2;
            }
    }
    s->vmax2_known = 0;
    s->dt = s->cfg.cfl * s->cfg.grid / (s->wave_speed_max + sqrt(vmax2));
    if (s->t + s->dt > s->cfg.t_end)
        s->dt = s->cfg.t_end - s->t;
}

int mpm_gpu_step(struct mpm_solver *s)
{
    struct mpm_gpu_step_out out;
    gpu_time_step(s);
    if (mpm_gpu_step_points(s->gpu, s->dt, &out) != 0)
        SC_FAIL(SC_EIO, "impact: step %lld (t = %.6g s): the GPU step failed: %s", (long long)s->step + 1, s->t,
                mpm_gpu_message());
    if (out.failed_id >= 0)
        SC_FAIL(SC_ESIM,
                "impact: step %lld (t = %.6g s): material point %ld of body %d: the stress update gave a "
                "non-finite state or a non-positive volume (time step %.3g s)",
                (long long)s->step + 1, s->t, out.failed_id, s->points.body[out.failed_id], s->dt);
    s->energy_absorbed -= out.absorbed_work;
    s->contact_node_steps += out.contact_nodes;
    s->bonded_node_steps += out.bonded_nodes;
    double t_before = s->t;
    s->t += s->dt;
    s->step++;
    s->point_updates += out.active;
    if (out.nonfinite_id >= 0)
        SC_FAIL(SC_ESIM,
                "impact: step %lld (t = %.6g s): material point %ld of body %d: position or velocity is not finite",
                (long long)s->step, s->t, out.nonfinite_id, s->points.body[out.nonfinite_id]);
    s->removed_points += out.removed;
    s->removed_mass += out.removed_mass;
    s->energy_removed += out.removed_energy;
    s->vmax2 = out.vmax2;
    s->vmax2_known = 1;
    int exchanges = mpm_conduction_exchanges(s, t_before, s->t); /* as mpm_step: after the removal */
    if (exchanges > 0 && mpm_gpu_conduct(s->gpu, mpm_conduction_interval(s), exchanges) != 0)
        SC_FAIL(SC_EIO, "impact: step %lld (t = %.6g s): the GPU's heat conduction failed: %s", (long long)s->step,
                s->t, mpm_gpu_message());
    return SC_OK; /* the host's points are brought up to date by those who read them (mpm_gpu_sync) */
}
