/* mpm: the impact solver of Tang (2021), "Predictive model of impact-induced bonding in cold spray using the
 * Material Point Method" (MASc thesis, Waterloo): explicit MUSL MPM in 3-D with PTW strength, Mie-Grueneisen
 * pressure, SCG melt, adiabatic heating, multi-body contact on a multi-mesh (Ma et al.), viscous absorbing
 * boundaries and the energy- (or strain-) based bonding model of Chapter 4.  All quantities SI.
 *
 * Coordinates (docs/physics.md): the substrate's top surface is z = 0 and the substrate fills z < 0; bodies start
 * above it.  The grid is uniform with cell size DCell = [impact] grid, aligned so that z = 0 is a node plane.
 *
 * One step (thesis Section 3.4, steps 1-12): dt = cfl DCell / (c + max|v|); particle-to-grid mass, momentum,
 * internal and external force per body (fixed order: the same bits for any thread count); nodal update;
 * contact and bonding forces at nodes where several bodies have mass; grid-to-particle velocity and position;
 * MUSL re-projection of momentum; strain and spin increments; density; stress update; bond parameter;
 * removal of points that left the grid box. */
#ifndef SPRAYCOAT_MPM_H
#define SPRAYCOAT_MPM_H

#include <hdf5.h>
#include <stddef.h>
#include <stdint.h>

#include "core/config.h"

#define MPM_FORMAT         "spraycoat-impact"
#define MPM_FORMAT_VERSION 2

/* [impact] series_every and snapshot_every are at least t_end / MPM_MAX_CLOCK_TICKS: each interval stays far above
 * the rounding of a time near t_end (1e-16 of it), where adding the interval to the time it was last due no longer
 * moves it (an interval of 1e-30 s stalled the run at its first step); mpm_config_scale_lengths scales all three
 * alike, so a scaled run keeps the bound.  Not a bound on the output: a run records at most one row and one snapshot
 * a step whatever the interval (mpm_clock_next), and a millimetre-scale set-up runs for milliseconds with the
 * default 0.5 ns between rows (t_end / 1e6 refused the tests' elastic set-ups). */
#define MPM_MAX_CLOCK_TICKS 1e12

enum mpm_shape { MPM_SPHERE, MPM_CYLINDER, MPM_BOX };
enum mpm_substrate { MPM_SUBSTRATE_CYLINDER, MPM_SUBSTRATE_BOX, MPM_SUBSTRATE_RIGID };
enum mpm_shape_function { MPM_LINEAR, MPM_UGIMP };
enum mpm_contact_law { MPM_CONTACT_STICK, MPM_CONTACT_FRICTIONLESS, MPM_CONTACT_FRICTION };
/* once: one decision per node and step (approach, surfaces met, bonds only while separating), projected on the
 * updated and re-projected momenta; thesis: contact decided and projected on the updated momenta, and again on
 * the MUSL re-projected ones; consistent: one decision (approach) per node and step, projected on the start,
 * updated and re-projected momenta */
enum mpm_contact_scheme { MPM_CONTACT_THESIS, MPM_CONTACT_CONSISTENT, MPM_CONTACT_ONCE };
/* contact_scheme = once: where a pair counts as approaching (mpm/contact.c approaching) */
enum mpm_contact_approach { MPM_APPROACH_BOTH, MPM_APPROACH_COMMON };
/* contact_scheme = once: where a pair's surface points count as in contact for the bonding model (mpm/contact.c
 * bonds_grow): at its nodes only while the two bodies' centres of mass approach along the node's normal, or at all */
enum mpm_bond_growth { MPM_GROWTH_APPROACH, MPM_GROWTH_CONTACT };
enum mpm_bonding { MPM_BONDING_ENERGY, MPM_BONDING_STRAIN, MPM_BONDING_NONE };
/* [impact] bonding_preheat: how a body's start temperature scales the critical value of the bonding model */
enum mpm_bonding_preheat { MPM_PREHEAT_NONE, MPM_PREHEAT_MELT_HEAT };
/* flip: the points take the grid's velocity change (Eq. 3.32, blended with PIC by `flip`); apic: the affine
 * particle-in-cell transfer of Jiang et al. (2015), the grid velocity at the point and an affine matrix per point */
enum mpm_transfer { MPM_TRANSFER_FLIP, MPM_TRANSFER_APIC };

/* A body: its points fill the shape on a lattice of spacing dp.  center is the centre of the sphere, of the
 * cylinder (axis along z) or of the box (d x d x h). */
struct mpm_body {
    enum mpm_shape shape;
    double center[3], velocity[3];
    double d, h;        /* diameter (or box side) and height (cylinder, box) */
    int material;       /* index into mpm_config.materials */
    int substrate;      /* 1 for the substrate body */
    double temperature; /* K, the body's points at the start; 0: the material's T_initial (issue 26: a sprayed
                           particle arrives at its temperature from the spray) */
};

/* A material's constants (PTW strength, MTS shear modulus, Mie-Grueneisen EOS, SCG melt, heating): defined with
 * the material models and the stress update in the module-private mpm/material.h. */
struct mpm_material;

/* Artificial bulk viscosity of the stress update. */
struct mpm_bulk_viscosity {
    double quadratic, linear; /* c_q, c_l of q = rho l^2 c_q epsv_dot^2 - c_l rho l c epsv_dot in compression
                                 (epsv_dot < 0; Zhang et al. Eq. 2.82), q = 0 in expansion; 0, 0 = off */
    double length;            /* l, the cell size DCell (m) */
};

struct mpm_config {
    int material_count;
    struct mpm_material *materials;
    int body_count;
    struct mpm_body *bodies; /* the substrate first when it is a deformable body */
    enum mpm_substrate substrate;
    double substrate_top; /* z of the rigid wall or the substrate's top (0) */
    double grid, spacing, cfl, t_end, box_margin;
    enum mpm_shape_function shape_function;
    enum mpm_contact_law contact;
    enum mpm_contact_scheme contact_scheme;
    double contact_gap; /* contact_scheme = once: largest separation of touching bodies' nodal centres, cells */
    enum mpm_contact_approach contact_approach; /* contact_scheme = once: along which normals a pair approaches */
    enum mpm_bond_growth bond_growth;           /* contact_scheme = once: where a pair's nodes count for D_bond */
    double bond_gap; /* contact_scheme = once: largest separation of a bonded pair's nodal centres, cells; 0: any */
    double flip;     /* FLIP share of the points' new velocity, the rest PIC (Eq. 3.32 is flip = 1) */
    double friction;
    enum mpm_bonding bonding;
    double Gc, Gc_rate, eps_c, eps_rate_c;
    double bonding_floor;                     /* smallest G_bond / G_c and eps_bond / eps_c (bonding.c) */
    enum mpm_bonding_preheat bonding_preheat; /* melt_heat: eps_c, G_c of a body times its melt-heat factor */
    double bonding_T_reference;               /* K, the temperature eps_c and G_c were calibrated at */
    double bonding_preheat_exponent;          /* n of the melt-heat share's power */
    double pbcp_threshold, vrest_threshold, vrest_filter;
    double settle_window, settle_vcom, settle_pbcp; /* settled verdicts (verdict.c) */
    int stop_when_settled;                          /* end the run once every verdict settled */
    double snapshot_every, series_every;            /* each at least t_end / MPM_MAX_CLOCK_TICKS */
    struct mpm_bulk_viscosity viscosity;
    int absorbing;           /* viscous absorbing boundaries on the substrate's bottom and sides */
    int fixed_bottom;        /* nodes at and below the substrate's bottom face cannot move vertically */
    double substrate_bottom; /* z of that face */
    int device;              /* [run] device: MPM_DEVICE_CPU, or MPM_DEVICE_GPU (mpm/cuda/, docs/gpu.md) */
    /* viscous-spring boundary (substrate_bottom = spring, substrate_sides = spring; docs/physics.md "Substrate
     * bottom"): besides its dashpot, a spring alpha G / R per unit area on each such boundary face of a point,
     * pulling the point back to its set-up position; R the distance from the substrate's top centre to the face */
    int spring_bottom, spring_sides;
    double spring_alpha_normal, spring_alpha_tangential;
    /* [impact] transfer: grid-to-point transfer (solver.c) */
    enum mpm_transfer transfer;
    int conduction; /* [impact] conduction = on: heat conduction inside each body (conduction.c) */
    /* [impact] symmetry: the node planes x = 0 (mirror[0]) and y = 0 (mirror[1]) are mirror planes; only the
     * points on their positive side are modelled (bodies.c, contact.c, diagnostics.c; docs/physics.md "Mirror
     * symmetry") */
    int mirror[2];
};
enum mpm_device { MPM_DEVICE_CPU, MPM_DEVICE_GPU };
/* What this build's GPU step is, for --version: the CUDA step (make CUDA=1), its emulation on the CPU (the test
 * binary BUILD/cuda-emu/spraycoat, docs/gpu.md "The emulation"), or none. */
#ifdef __cplusplus
extern "C" { /* mpm/cuda/step.cu defines it */
#endif
const char *mpm_gpu_build(void);
#ifdef __cplusplus
}
#endif

/* The keys of [impact] and [material.NAME] (NULL-key terminated). */
extern const struct cfg_key mpm_case_keys[];

/* Resolve [impact] and the materials it names.  SC_EINPUT with FILE:LINE: [section] key messages. */
int mpm_config_load(const struct case_file *c, struct mpm_config *cfg);
/* Warn of each [material.NAME] section of the case that no body of cfg uses (a misspelt name left the body on
 * another material, silently); the number of such sections. */
int mpm_config_warn_unused_materials(const struct case_file *c, const struct mpm_config *cfg);
void mpm_config_free(struct mpm_config *cfg);
/* Replace the bodies by one sphere of `diameter` moving at `speed` (m/s) at `angle` (rad from the normal)
 * towards the substrate, touching it (the single-particle set-up of [impact] and of vcrit). */
int mpm_config_single_particle(struct mpm_config *cfg, double diameter, double speed, double angle);

/* How many copies of the modelled part the mirror planes make of the whole set-up: 1, 2 (symmetry = half) or 4
 * (quarter).  Diagnostics, series and summaries are of the whole bodies; snapshots, checkpoints and stats/ of the
 * modelled part. */
int mpm_mirror_copies(const struct mpm_config *cfg);
/* Whether body b runs at the resolution the shipped parameters of the case's bonding model were calibrated at
 * (docs/physics.md "Bonding calibration"): the strain model's at 10 cells across the body's diameter, the energy
 * model's on 2.0 um cells, both with 3 points per cell edge.  1 yes, 0 no (its verdict is not calibrated), -1 not
 * judged: the substrate, no bonding model, or parameters of the case's own. */
int mpm_bonding_calibrated_resolution(const struct mpm_config *cfg, int b);

/* Multiply every length and time of the set-up (grid, spacing, box_margin, bodies, t_end, settle_window,
 * series_every, snapshot_every) by `factor` > 0: the same impact at another scale, with the same cells per body. */
void mpm_config_scale_lengths(struct mpm_config *cfg, double factor);

/* Start the last `count` bodies (the particles of mpm_config_set_spheres or mpm_config_single_particle) at the
 * temperatures temperature[k] (K) instead of their material's T_initial.  SC_EINPUT for a temperature <= 0, above
 * 1e5 K or where the material's shear modulus is not positive. */
int mpm_config_set_particle_temperatures(struct mpm_config *cfg, int count, const double *temperature);

/* Replace the particles by `count` spheres of the particle material: diameters d[k], centres center[3k..3k+2]
 * (z above the substrate's top) and velocities velocity[3k..3k+2] (the seeds of the couple stage). */
int mpm_config_set_spheres(struct mpm_config *cfg, int count, const double *diameter, const double *center,
                           const double *velocity);

/* The first pair of overlapping spheres among the bodies that are not the substrate (first by the lower index,
 * then by the higher): centres closer than their radii add up to, less a relative 1e-9 (touching is allowed).
 * Returns 1 and the indices into cfg->bodies, 0 when none overlap, -1 when out of memory.  Near-linear in the
 * number of spheres (a cell list whose cells are as wide as the largest sphere). */
int mpm_find_sphere_overlap(const struct mpm_config *cfg, int *first, int *second);

struct mpm_solver;

int mpm_create(const struct mpm_config *cfg, struct mpm_solver **out);
/* What mpm_create would refuse, found without making the solver: every body seeded with its points (overlapping
 * bodies of any shape, a body that holds no point) and the grid's memory against the machine's.  SC_EINPUT
 * naming the bodies or the grid. */
int mpm_check_set_up(const struct mpm_config *cfg);

/* The most nodes a grid may have (the node index of a stencil is an int in places). */
#define MPM_GRID_MAX_NODES ((size_t)1 << 31)
/* What the grid of a set-up needs, from the bodies' box (no point seeded), against `memory` bytes (0: unknown, not
 * checked): its nodes and bytes (nodes x bodies' layers), and when it does not fit (more than MPM_GRID_MAX_NODES
 * nodes, or more bytes than the memory) the finest cell size, in m, that would, the other keys as they are. */
struct mpm_grid_need {
    double nodes; /* the grid's node count (a double: a grid too fine overflows any integer) */
    double bytes, memory, finest;
    int fits;
};
void mpm_grid_need(const struct mpm_config *cfg, double memory, struct mpm_grid_need *need);
/* The machine's memory in bytes (0 when unknown), which a grid must fit in. */
double mpm_machine_memory(void);
void mpm_destroy(struct mpm_solver *s);

/* Advance one step.  SC_ESIM naming step, point, body and quantity when the state is not finite. */
int mpm_step(struct mpm_solver *s);
/* 1 once t >= t_end, or once every verdict settled (stop_when_settled). */
int mpm_finished(const struct mpm_solver *s);

struct mpm_counts {
    int64_t step;
    double t, dt;
    int64_t points, active_points, removed_points;
    double removed_mass;
    int64_t point_updates; /* active points advanced, summed over steps */
    int64_t contact_node_steps, bonded_node_steps;
};
struct mpm_counts mpm_get_counts(const struct mpm_solver *s);

/* Per-body diagnostics at the current state (Tang Chapter 5).  Arrays have body_count entries. */
struct mpm_body_diagnostics {
    double mass, kinetic_energy, internal_energy, plastic_work;
    double mean_eps_p, plastic_energy_density; /* Eq. 4.15, J/m3, mass-weighted mean */
    double v_com[3];
    double pbcp;        /* Eq. 5.1: points with D >= 1 over points with D > 0 (0 when none) */
    double v_rest;      /* mean v_z of points slower than vrest_filter (m/s, + away from the substrate) */
    double mean_d_bond; /* over surface points */
    int64_t contacted_points, bonded_points;
    /* the nodes where it meets another body now (one count per pair at a node) and, of those, the nodes where the
     * pair is bonded by Eq. 4.7 (the mean of both bodies' nodal D_bond at least 1): its bonded interface; PBCP counts
     * its own points whose D_bond ever reached 1, so a particle that has left keeps its PBCP and bonds at no node */
    int64_t interface_nodes, bonded_nodes; /* -1: not counted (the GPU failed to count them) */
    double bonded_interface;               /* bonded_nodes / interface_nodes (0 when it meets nothing, NaN: -1) */
};
struct mpm_diagnostics {
    double t;
    int body_count;
    struct mpm_body_diagnostics *body; /* owned by the solver; valid until the next call */
    double energy_total; /* kinetic + internal + absorbed by boundaries + carried away by removed points + stored
                            in the boundary springs */
    double energy_absorbed, energy_removed, energy_initial;
    double energy_stored; /* elastic energy held by the boundary springs (spring_bottom, spring_sides); in the total */
};
const struct mpm_diagnostics *mpm_compute_diagnostics(struct mpm_solver *s);
/* The diagnostics the run's verdicts were judged on: each body's as its last series row holds them (at the run's end
 * once it finished), the masses and energies computed now.  The same as mpm_compute_diagnostics at the end of a run,
 * and also right after a resume from a checkpoint written at its end, where no step has rebuilt the grid that the
 * interface counts need (mpm_compute_diagnostics would count no interface, and its other values are those of the
 * points alone). */
const struct mpm_diagnostics *mpm_final_diagnostics(struct mpm_solver *s);

/* Verdict per body (Tang Section 5.2.1; mpm/verdict.c, docs/physics.md "Settled verdicts"): judged at every
 * series row on the means of v_rest and v_com over the window that ends there: bonded when PBCP >= pbcp_threshold and
 * the mean v_rest <= vrest_threshold; settled once that judgement, the mean v_com (within settle_vcom) and PBCP
 * (within settle_pbcp) have held over the last settle_window.  out has body_count
 * entries: the settled judgement, MPM_VERDICT_UNSETTLED while it is not settled (also when v_rest has no value),
 * MPM_VERDICT_SUBSTRATE for the substrate. */
enum mpm_verdict {
    MPM_VERDICT_SUBSTRATE = -1,
    MPM_VERDICT_REBOUNDED = 0,
    MPM_VERDICT_BONDED = 1,
    MPM_VERDICT_UNSETTLED = 2
};
void mpm_verdicts(struct mpm_solver *s, int *verdict);
/* "bonded", "rebounded", "unsettled" or "-" (the substrate). */
const char *mpm_verdict_name(int verdict);
/* 1 when a settled "rebounded" body with restitution velocity v_rest is at rest on the substrate, held by too few
 * bonded points to count (docs/physics.md, "Held but not bonded"): not bonded, but not leaving either. */
int mpm_verdict_held(int verdict, double v_rest, double vrest_threshold);
/* The time at which body b's verdict settled (the end of the first window over which it held, and has held
 * since); NaN while unsettled and for the substrate. */
double mpm_verdict_settled_at(const struct mpm_solver *s, int body);
/* The means over the judging window that body b's last judgement was made on (docs/physics.md, "Settled
 * verdicts"): the restitution velocity v_rest and the centre-of-mass velocity along z (m/s); NaN while the body has
 * no judgement and for the substrate. */
double mpm_verdict_vrest(const struct mpm_solver *s, int body);
double mpm_verdict_vcom_z(const struct mpm_solver *s, int body);
/* 1 when every body but the substrate is settled (the run ends then with stop_when_settled = yes). */
int mpm_all_settled(const struct mpm_solver *s);

int mpm_body_count(const struct mpm_solver *s);

/* Output.  A snapshot (material points: x, v, eps_p, T, D_bond, body, ... with units) into an open group. */
int mpm_write_snapshot(const struct mpm_solver *s, hid_t group);
/* The time series recorded every series_every (and at the end) and the per-body summary into an open group:
 * series/ and summary/ and stats/ as in docs/files.md. */
int mpm_write_results(struct mpm_solver *s, hid_t group);
/* 1 when a snapshot is due at the current step (every snapshot_every, the first and the last step). */
int mpm_snapshot_due(const struct mpm_solver *s);
int64_t mpm_snapshot_index(const struct mpm_solver *s); /* number of snapshots taken so far */
void mpm_snapshot_taken(struct mpm_solver *s);

/* Checkpoint: everything the next step needs, into an open group; read back into a solver made from the same
 * configuration.  Shape-function caches and bins are rebuilt, never stored. */
int mpm_checkpoint_write(const struct mpm_solver *s, hid_t group);
int mpm_checkpoint_read(struct mpm_solver *s, hid_t group);

#endif
