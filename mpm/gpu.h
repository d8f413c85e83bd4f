/* Module-private (mpm/): the impact step on an NVIDIA GPU (make CUDA=1; mpm/cuda/step.cu; docs/gpu.md).
 *
 * The points live on the device for the whole run, structure of arrays, reordered there by cell (step.cu
 * reorder_points); the host's arrays (in id order: a solver on the GPU never reorders them, point_order.c) are
 * brought up to date, in id order, only when something on the host reads them: a snapshot, a checkpoint
 * (mpm_gpu_sync); the diagnostics are summed on the device (mpm_gpu_point_sums).  This header is plain C for both
 * compilers: step.cu does not include mpm_impl.h (whose GNU vector types nvcc's front end need not accept); mpm/gpu.c
 * fills the plain view below from the solver.  Without CUDA=1, mpm/gpu_stub.c defines the functions, and
 * mpm_gpu_built() is 0. */
#ifndef SPRAYCOAT_MPM_GPU_H
#define SPRAYCOAT_MPM_GPU_H

#include <stddef.h>
#include <stdint.h>

#include "mpm/diagnostics_point.h"
#include "mpm/material.h"

#ifdef __cplusplus
extern "C" {
#endif

struct mpm_gpu; /* the device state (step.cu) */

/* The bits of enum point_flags (mpm_impl.h; gpu.c checks that they agree). */
enum mpm_gpu_point_flags {
    GPU_POINT_ACTIVE = 1,
    GPU_POINT_SURFACE = 2,
    GPU_POINT_BOTTOM = 4,
    GPU_POINT_SIDE = 8,
    GPU_POINT_CONTACT = 16
};

/* What the device step needs of the solver: sizes, the grid, the case's numerics, the materials. */
struct mpm_gpu_setup {
    size_t points;
    int bodies, materials;
    /* the grid (mpm_grid): origin, cell, nodes per direction, the offsets grid_contains accepts */
    double origin[3], h, inv_h, inside_from[3], inside_to[3];
    int n[3];
    double mass_cutoff;
    int moments; /* the first mass moments are summed (contact_scheme = once with several layers, or the wall) */
    /* numerics (mpm_config) */
    double flip, friction, contact_gap, bond_gap, substrate_top, substrate_bottom;
    int contact, contact_scheme, contact_approach, bond_growth, rigid_wall, fixed_bottom, bonding;
    int mirror[2];        /* [impact] symmetry: the node planes x = 0 (mirror[0]) and y = 0 are mirror planes */
    long mirror_plane[2]; /* their node indices (mpm_grid mirror_plane) */
    /* [impact] conduction = on (conduction.c): the kernel's squared radius (m^2) and 6 / M2 (1/m^5); 0 when off */
    double conduction_eps2, conduction_laplacian;
    double Gc, Gc_rate, eps_c, eps_rate_c, bonding_floor;
    struct mpm_bulk_viscosity viscosity;
    const struct mpm_material *material;            /* materials */
    const struct mpm_material_constants *constants; /* materials */
    const int *body_material;                       /* bodies */
    const double *body_dashpot;                     /* 2 per body (Eq. 3.46) */
    const double *body_bond_scale;                  /* bodies: the critical value's factor (bonding_preheat) */
};

/* The host's point arrays, in id order (struct mpm_points). */
struct mpm_gpu_points {
    double *x, *v, *mass, *volume0, *volume, *d_bond, *plastic_work, *normal;
    struct mpm_point_state *state;
    int32_t *body;
    uint8_t *flags;
};

/* What one device step found (reduced on the device, in fixed orders: the same bits run to run). */
struct mpm_gpu_step_out {
    double vmax2;          /* largest squared speed of the points that stay active (the next time step) */
    long nonfinite_id;     /* smallest id of a point whose position or velocity is not finite, else -1 */
    long failed_id;        /* smallest id of a point whose stress update failed, else -1 */
    int64_t removed;       /* points that left the grid box this step (deactivated) */
    double removed_mass;   /* their mass */
    double removed_energy; /* their kinetic and internal energy */
    double absorbed_work;  /* the dashpots' work this step (mpm_book_absorbed_energy: subtracted) */
    int64_t contact_nodes; /* nodes where a pair interacted (contact_node_steps) */
    int64_t bonded_nodes;  /* of those, bonded (bonded_node_steps) */
    int64_t active;        /* active points advanced */
};

/* 1 in a build with the GPU step. */
int mpm_gpu_built(void);
/* 0 when a device this build runs on is there, else -1 with the reason in mpm_gpu_message(). */
int mpm_gpu_probe(void);
/* Make the device state for `setup` on the first device; 0, or -1 with the reason in mpm_gpu_message() (no
 * device, no memory). */
int mpm_gpu_open(const struct mpm_gpu_setup *setup, struct mpm_gpu **out);
void mpm_gpu_close(struct mpm_gpu *g);
/* The host's points onto the device (after set-up and after reading a checkpoint), and back. */
int mpm_gpu_upload(struct mpm_gpu *g, const struct mpm_gpu_points *p);
int mpm_gpu_download(struct mpm_gpu *g, const struct mpm_gpu_points *p);
/* 1 when the host's copy is older than the device's points. */
int mpm_gpu_host_stale(const struct mpm_gpu *g);
/* One step of length dt on the device (thesis Section 3.4, steps 1-12, as mpm_step). */
int mpm_gpu_step_points(struct mpm_gpu *g, double dt, struct mpm_gpu_step_out *out);
/* `exchanges` heat exchanges of `interval` each among the points at their current positions (mpm_conduction_advance
 * of conduction.c), after a step whose time crossed that many multiples of the interval. */
int mpm_gpu_conduct(struct mpm_gpu *g, double interval, int exchanges);
/* Each body's interface nodes after the last step and those bonded by Eq. 4.7 (mpm_contact_interface_nodes of
 * contact.c, on the device's grid); 0 each before the first step.  interface and bonded have `bodies` entries. */
int mpm_gpu_interface_nodes(struct mpm_gpu *g, int64_t *interface, int64_t *bonded);
/* Each body's sums over its active points (diagnostics_point.h point_sums_add), with the last step's grid velocity
 * at each point (diagnostics.c smooth_velocity) and v_rest's filter vrest_filter (m/s), summed on the device in a
 * fixed order (the same bits run to run); sums has `bodies` entries. */
int mpm_gpu_point_sums(struct mpm_gpu *g, double vrest_filter, struct point_sums *sums);
/* The device's name and memory, for the log. */
const char *mpm_gpu_name(const struct mpm_gpu *g);
/* The reason of the last failure. */
const char *mpm_gpu_message(void);

#ifdef __cplusplus
}
#endif

#endif
