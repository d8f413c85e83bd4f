/* dem: the spray solver of Mukherjee & Zohdi (2015), J. Comput. Phys. 290:298-317.
 *
 * Particles are injected at the nozzle disc (z = 0), carried by a one-way coupled gas jet towards the
 * target plane z = standoff, collide with each other, the target and deposited particles through
 * impulses (Section 2), stick or rebound by a deposition rule (Section 3), and are integrated with the
 * phi-scheme and fixed-point iterations (Section 4.4).  All quantities SI.
 *
 * Each step: inject (every feed_every steps); bin; find every contact whose swept spheres touch inside
 * the step (time of impact, so nothing tunnels); resolve the contacts as impulses in order of time of
 * impact (collide-and-stream); integrate the smooth forces (drag) of free particles; apply boundaries
 * (escape, hand-off plane); sample metrics. */
#ifndef SPRAYCOAT_DEM_H
#define SPRAYCOAT_DEM_H

#include <hdf5.h>
#include <stddef.h>
#include <stdint.h>

#include "core/config.h"

/* 3: impacts carry contact_index; resting particles (state 2) and their count; 4: particles, impacts and hand-offs
 * carry the temperature, /nozzle; /escapes and /deposition_efficiency, the escaped particles in the checkpoints;
 * hand-offs carry the jet's axis (records and checkpoints), /deposit */
#define DEM_FORMAT         "spraycoat-spray"
#define DEM_FORMAT_VERSION 4

enum dem_injection { DEM_INJECT_STREAM, DEM_INJECT_FILE };
enum dem_deposition_rule { DEM_DEPOSIT_ADHESION, DEM_DEPOSIT_CRITICAL_VELOCITY, DEM_DEPOSIT_TABLE, DEM_DEPOSIT_NONE };
/* DEM_RESTING: a rebounder that lies on the target at negligible normal speed ([contact] rest_speed): it no longer
 * moves nor is re-collided; flying particles meet it as an obstacle, like a deposit, but it has not stuck. */
enum dem_particle_state { DEM_FLYING = 0, DEM_DEPOSITED = 1, DEM_RESTING = 2 };
enum dem_outcome { DEM_REBOUND = 0, DEM_STUCK = 1, DEM_RESTED = 2 };

/* ---- The parts of the configuration that coupling/ and app/ read and fill: the carrier gas (Mukherjee & Zohdi
 * Section 2.3, Eqs. 24-27, dem/gas.c), the materials (Table 1, dem/material.c), the size law (Section 4.2,
 * dem/sizes.c) and the contact law (Sections 2.1-2.2, dem/contact.c).  The rest of those files' API is
 * module-private (dem/gas.h, dem/material.h, dem/sizes.h, dem/contact.h). ---- */

/* The carrier gas.  Coordinates: nozzle exit centre at the origin, spray axis +z; the jet's streamwise coordinate
 * is x = z + virtual_origin and its cross-stream coordinate r = sqrt(x^2 + y^2) of the spray frame. */
enum dem_jet_model { DEM_JET_BICKLEY, DEM_JET_UNIFORM, DEM_JET_NONE };
enum dem_drag_law { DEM_DRAG_HAIDER_LEVENSPIEL, DEM_DRAG_STOKES, DEM_DRAG_HENDERSON };

/* [jet] bow_shock: none, or a normal shock in front of the target where the free jet arrives supersonic. */
enum dem_bow_shock { DEM_BOW_SHOCK_NONE, DEM_BOW_SHOCK_AUTO };
struct dem_gas_field {
    enum dem_jet_model model;
    enum dem_drag_law drag;
    double c1, c2, c3;          /* jet constants of Eqs. (26)-(27), SI (C1: m^(4/3)/s, C2: m^(5/3)/s, C3: m^(-1/3)) */
    double virtual_origin;      /* m, distance of the jet's virtual origin behind the nozzle exit */
    double core_length;         /* m, potential core: for z < core_length the profile of z = core_length
                                   is used without entrainment (no radial velocity) */
    double uniform_velocity;    /* m/s along +z, DEM_JET_UNIFORM */
    double density;             /* rho_f, kg/m3 */
    double kinematic_viscosity; /* nu_f, m2/s */
    /* The wall region of the jet impinging on the target (dem/gas_eval.h, docs/physics.md "The jet at the
     * wall"): set by dem_gas_set_wall; stagnation_height 0 (a zeroed struct) is the free jet everywhere. */
    double stagnation_factor;         /* [jet] stagnation_height: H in half-widths of the free jet at the wall */
    double wall_z;                    /* m, the wall plane (the target, z = standoff) */
    double stagnation_height;         /* m, H: the wall region is wall_z - H < z */
    double wall_axis_speed;           /* m/s, U_H: the free jet's axial speed on the axis at z = wall_z - H */
    double wall_inverse_width;        /* 1/m, a_H = C3 / x_H^(2/3): the free jet's profile sech^2(a_H r) there */
    double inverse_stagnation_height; /* 1/m, 1/H (0 without a wall region) */
    double wall_outflow_scale;        /* m/s, U_H / (a_H^2 H): the wall jet's u_r = g' scale F(a_H r) / r */
    double gas_temperature;           /* K */
    double gas_gamma;
    double gas_constant;   /* J/(kg K) */
    double gas_sutherland; /* K: Sutherland's constant S of the gas, for the viscosity behind a bow shock */
    /* The bow shock in front of the target (docs/physics.md "The bow shock at the target"): placed by
     * dem_gas_set_wall; shock_standoff 0 (a zeroed struct, bow_shock none, a subsonic jet) is no shock. */
    enum dem_bow_shock bow_shock;   /* [jet] bow_shock */
    double shock_mach;              /* M1: the free jet's axial Mach number on the axis at the shock */
    double shock_standoff;          /* m, Delta: the shock stands at wall_z - Delta, the top of the wall region */
    double shock_velocity_ratio;    /* u2/u1 = rho1/rho2 of the normal shock at M1 */
    double shock_density_ratio;     /* rho2/rho1: the gas density in the layer below the shock, over `density` */
    double shock_temperature_ratio; /* T2/T1 */
    double shock_viscosity_ratio;   /* mu2/mu1: Sutherland's law at T2 and T1 */
    double axis_x, axis_y;          /* m: the jet's axis (the nozzle's position), set every step by the path */
};

/* Place the wall of the impinging jet at z = wall_z: the stagnation height H = stagnation_factor b(wall_z), b the
 * free jet's half-width (sech^2 = 1/2) at the wall, at most wall_z, and the free jet's profile at the top of the
 * wall region.  Only the Bickley jet has a width and so a wall region; for the other models (or a factor 0) H = 0,
 * the free field up to the wall.  With bow_shock auto, where the free jet reaches the wall region supersonic
 * (gas_temperature, gas_gamma, gas_constant), a normal shock stands at the standoff Delta = 0.82 b rho1/rho2 and
 * the wall region is the compressed layer below it, H = Delta. */
void dem_gas_set_wall(struct dem_gas_field *gas, double wall_z);

/* Gas velocity u[3] at position x[3] (DEM_JET_NONE: still gas, zero).  Public with dem_gas_drag_force: the couple stage
 * and coupling/flight.c use the spray's gas. */
void dem_gas_velocity(const struct dem_gas_field *gas, const double x[3], double u[3]);

/* Drag force f[3] (N) on a sphere of diameter d moving at v[3] in gas moving at u[3], Eq. (24).
 * DEM_JET_NONE means no gas at all: zero force. */
void dem_gas_drag_force(const struct dem_gas_field *gas, double diameter, const double v[3], const double u[3],
                        double f[3]);

/* The same at position x[3], in the gas there: below a bow shock the layer's density (docs/physics.md "The bow
 * shock at the target"), elsewhere `density`.  The spray's integrator and the couple stage's flight use this. */
void dem_gas_drag_force_at(const struct dem_gas_field *gas, double diameter, const double x[3], const double v[3],
                           const double u[3], double f[3]);

/* Elastic-plastic constants of a powder or target material.  E and nu follow from the shear and bulk moduli. */
struct dem_material {
    double density;        /* kg/m3 (particles; unused for the target) */
    double shear_modulus;  /* G, Pa */
    double bulk_modulus;   /* K, Pa */
    double yield_stress;   /* Y, Pa */
    double surface_energy; /* gamma, J/m2 */
    double friction;       /* Coulomb coefficient mu, - */
};

/* Particle sizes: a (truncated) Weibull law, Eqs. (36)-(37). */
struct dem_size_distribution {
    int monodisperse;       /* 1: every particle has the median diameter */
    double median_diameter; /* m */
    double shape;           /* Weibull n */
    double d_min, d_max;    /* truncation, m (0 and INFINITY: none) */
};

/* The impulse contact law of rigid spheres. */
enum dem_restitution_model { DEM_RESTITUTION_JOHNSON, DEM_RESTITUTION_CONSTANT };
struct dem_contact_law {
    enum dem_restitution_model model;
    double restitution;             /* e for DEM_RESTITUTION_CONSTANT, in [0, 1] */
    double friction_regularization; /* epsilon of Eq. (11), m/s */
};

/* [path]: the nozzle's motion in its exit plane (dem/path.c, docs/physics.md "A traversing nozzle"); the jet's
 * axis and the injection disc follow it. */
enum dem_path_pattern { DEM_PATH_NONE, DEM_PATH_LINE, DEM_PATH_RASTER, DEM_PATH_FILE };
struct dem_path {
    enum dem_path_pattern pattern;
    double traverse_speed;   /* m/s */
    double start_x, start_y; /* m: where the first pass starts */
    double pass_length;      /* m: each pass runs along x */
    double step_over;        /* m: raster: +y between passes */
    long passes;             /* line: over the same line, back and forth; raster: rows */
    size_t waypoint_count;   /* pattern = file: rows (t, x, y), t ascending from 0 */
    double *waypoints;       /* owned by the configuration */
    double map_cell;         /* m: the height map's cell side */
    double packing;          /* volume fraction of the deposit: height = particle volume / (cell area packing) */
};

/* The nozzle's (x, y) at time t (m); none: the origin. */
void dem_path_position(const struct dem_path *path, double t, double xy[2]);
/* The time the path takes (s); none: 0. */
double dem_path_duration(const struct dem_path *path);

struct dem_config {
    uint32_t seed;
    int threads; /* 0: all cores */
    /* [spray] */
    double dt, t_end;
    enum dem_injection injection;
    char particles_path[4096];  /* with injection = file */
    size_t file_particle_count; /* rows of the particles file: x y z vx vy vz wx wy wz d */
    double *file_particles;
    long feed_count, feed_every, max_injected;
    double nozzle_radius, release_speed_min, release_speed_max, release_cone; /* release_cone in rad */
    double phi, fixed_point_tol;
    long fixed_point_max_iter;
    double domain_radius, handoff_height;
    long metrics_every;
    double snapshot_every; /* s; 0: no snapshots */
    /* [powder], [target] */
    struct dem_size_distribution sizes;
    struct dem_material powder, target;
    double standoff, deposit_radius;
    /* [contact], [jet] */
    struct dem_contact_law contact;
    double rest_speed; /* m/s: a target contact slower than this along the normal leaves the particle resting */
    struct dem_gas_field gas;
    /* [deposition] */
    enum dem_deposition_rule rule;
    double alpha_adh, critical_velocity;
    size_t table_count; /* v_crit(d) table, diameters ascending */
    double *table_diameter, *table_velocity;
    /* [powder] temperature and specific_heat; [nozzle] (nozzle.enabled 0 without the section) */
    double powder_temperature;   /* K: the particles' temperature at release without [nozzle] */
    double powder_specific_heat; /* J/(kg K) */
    struct dem_nozzle *nozzle;   /* NULL without [nozzle]; owned by the config (dem_config_free) */
    /* the deposition efficiency's classes (dem/efficiency.c): size classes over the run's size range, and
     * first-impact angle classes of this width (rad) from the target normal */
    long de_size_classes;
    double de_angle_class_width;
    /* v_crit(d, T) (a table with temperatures, docs/files.md "v_crit tables"): table_temperature_count > 0
     * temperatures (K) ascending; table_velocity then holds table_count x table_temperature_count values, the
     * temperatures of one diameter side by side.  0: the 1-D table v_crit(d). */
    size_t table_temperature_count;
    double *table_temperature;
    struct dem_path path; /* [path] */
};

/* The keys of [spray] [powder] [target] [contact] [jet] [deposition] (NULL-key terminated). */
extern const struct cfg_key dem_case_keys[];

/* Resolve and cross-check the spray configuration; reads the v_crit table and checks the particles file
 * exists.  SC_EINPUT with a FILE:LINE: [section] key message on anything wrong. */
int dem_config_load(const struct case_file *c, struct dem_config *cfg);
void dem_config_free(struct dem_config *cfg);

/* v_crit (m/s) of the table rule at diameter d (m) and particle temperature T (K): linear in d (1-D table) or
 * bilinear in d and T (2-D table), clamped to the table's first and last diameter and temperature. */
double dem_vcrit_lookup(const struct dem_config *cfg, double d, double T);

/* One row per contact of a particle with the target or a deposited particle (spray.h5:/impacts). */
struct dem_impact {
    double t;
    int64_t particle_id;
    double x[3], v_in[3], v_out[3], w_in[3], w_out[3];
    double d, m;
    int64_t outcome;       /* enum dem_outcome */
    int64_t partner;       /* -1 the target, else the deposited (or resting) particle's id */
    int64_t contact_index; /* the particle's contacts with the target or fixed particles before this one */
    double temperature;    /* K: the particle's temperature (constant after the nozzle exit) */
};

/* One row per crossing of the hand-off plane z = standoff - handoff_height (spray.h5:/handoff). */
struct dem_handoff {
    double t;
    int64_t particle_id;
    double x[3], v[3], w[3];
    double d;
    double temperature; /* K: the particle's temperature (constant after the nozzle exit) */
    double axis[2]; /* m: the jet's axis (the nozzle's x, y) at t, where the couple stage's flight centres the jet */
};

/* One row per particle that left the domain (spray.h5:/escapes). */
struct dem_escape {
    double t; /* s, the end of the step in which it left */
    int64_t particle_id;
    double d, m;
};

/* Accounting and solver statistics. */
struct dem_counts {
    int64_t step;
    double t;
    int64_t injected, in_flight, deposited, escaped;
    int64_t resting;               /* particles lying on the target (or a deposit) without having stuck */
    int64_t first_impact_deposits; /* deposits made on the particle's first contact (contact_index 0) */
    int64_t contacts_pair, contacts_target, contacts_deposit;
    int64_t contacts_turned_away; /* contacts found on the straight paths of the step that the drag turned away
                                   * before the bodies met: no impulse, the path restarted from the drag's state */
    int64_t fixed_point_iterations, fixed_point_solves, fixed_point_unconverged, max_iterations;
    int64_t subcycled_particle_steps;
    int64_t particle_steps; /* flying particles advanced, summed over steps */
    int64_t clamps;         /* corrections of a particle found inside the target or another particle: at a
                             * step's end (put back on the target plane) or where it stuck (put touching) */
    int64_t trapped;        /* flying particles stopped, caught between bodies (DEM_TRAP_CONTACTS contacts in
                             * one step) */
};

struct dem_solver;

int dem_create(const struct dem_config *cfg, struct dem_solver **out);
void dem_destroy(struct dem_solver *s);
/* For tests: reuse 0 computes the drag at the start of every step again instead of taking the one the last
 * step ended with (dem/integrate.c); the results must be the same bit for bit. */
void dem_reuse_drag(struct dem_solver *s, int reuse);

/* Advance one step.  SC_ESIM with step, particle id and quantity if a particle's state is not finite. */
int dem_step(struct dem_solver *s);
/* Total number of steps to t_end. */
int64_t dem_total_steps(const struct dem_solver *s);
struct dem_counts dem_get_counts(const struct dem_solver *s);
/* Wall seconds spent in each phase of dem_step since the solver was created (a resumed run counts from its
 * resume), for the stage's closing log line: where the time goes, as LAMMPS's breakdown shows it; and how often
 * the broad phase built its grid and pair list afresh or repaired them (as LAMMPS counts its neighbor list
 * builds), in the same span. */
struct dem_timing {
    double injection, broad_phase, contacts, integration, boundaries, metrics;
    int64_t grid_builds, grid_repairs;
};
struct dem_timing dem_get_timing(const struct dem_solver *s);
/* SC_ESIM if injected != in flight + deposited + escaped. */
int dem_check_accounting(const struct dem_solver *s);

const struct dem_impact *dem_impacts(const struct dem_solver *s, size_t *count);
const struct dem_handoff *dem_handoffs(const struct dem_solver *s, size_t *count);

/* Particle state (flying and deposited), in order of injection. */
size_t dem_particle_count(const struct dem_solver *s);
struct dem_particle_view {
    int64_t id;
    int state; /* enum dem_particle_state */
    double x[3], v[3], w[3], d, m;
};
struct dem_particle_view dem_particle(const struct dem_solver *s, size_t index);

/* Deposit metrics of Section 5.2 at the current state. */
struct dem_metrics {
    double t;
    int64_t injected, in_flight, deposited, escaped;
    double deposit_fraction, volume_fraction, mean_spread, scatter, max_thickness, deposition_rate;
    int64_t resting, first_impact_deposits;
    double first_impact_share; /* first_impact_deposits / deposited (0 without deposits) */
};
struct dem_metrics dem_compute_metrics(const struct dem_solver *s);

/* The deposition efficiency by mass (dem/efficiency.c, docs/physics.md "Deposition efficiency"): of all the
 * particles sprayed (injected), the mass deposited over the mass sprayed, and its split into classes of
 * diameter and of the angle of a particle's first impact (its first contact with the target or a fixed
 * particle) to the target normal.  A class holds its bounds, the mass and number sprayed into it and deposited
 * from it, and de = deposited / sprayed mass (0 where nothing was sprayed).  The size classes add up to the
 * whole; the angle classes add up to the particles that had an impact, the rest is `unimpacted` (still in
 * flight, or escaped without touching), none of which is deposited. */
struct dem_de_class {
    double lo, hi; /* m (size) or rad (angle) */
    double sprayed_mass, deposited_mass, de;
    int64_t sprayed_count, deposited_count;
};
struct dem_deposition_efficiency {
    double sprayed_mass, deposited_mass, de; /* kg, kg, - */
    int64_t sprayed_count, deposited_count;
    double unimpacted_mass; /* kg sprayed without an impact */
    int64_t unimpacted_count;
    double mean_impact_speed, mean_impact_normal_speed; /* m/s: mean |v| and v_z of the first impacts; NaN: none */
    /* rule = table: the impacts (/impacts) judged by the v_crit table, and those of them whose diameter or
     * temperature lay beyond its grid, judged at its nearest edge (no extrapolation); 0 with another rule */
    int64_t table_impacts, table_impacts_outside;
    size_t size_count, angle_count;
    struct dem_de_class *by_size, *by_angle;
};
/* The DE counts a particle still in flight at the end as sprayed and not deposited: a lower bound, which the spray
 * stage warns of and the sweep's map marks once more than this share of the particles sprayed (by number) is still
 * in flight (docs/physics.md "Deposition efficiency"). */
#define DEM_DE_LOWER_BOUND_IN_FLIGHT 0.05
/* SC_EIO (out of memory) or SC_OK; free with dem_deposition_efficiency_free. */
int dem_deposition_efficiency(const struct dem_solver *s, struct dem_deposition_efficiency *de);
void dem_deposition_efficiency_free(struct dem_deposition_efficiency *de);
/* The group /deposition_efficiency of spray.h5 (written by dem_write_output) into an open file or group. */
int dem_deposition_efficiency_write(const struct dem_deposition_efficiency *de, hid_t loc);

/* Checkpoint: everything the next step needs, into an open group (X_checkpoint_write, as every module names it). */
int dem_checkpoint_write(const struct dem_solver *s, hid_t group);
/* Restore into a solver created from the same configuration. */
int dem_checkpoint_read(struct dem_solver *s, hid_t group);
/* The spray.h5 contents (/particles, /impacts, /handoff, /metrics, /stats, /escapes, /deposition_efficiency)
 * into an open file. */
int dem_write_output(const struct dem_solver *s, hid_t file);

/* The deposit as a height map on the target (dem/deposit.c, spray.h5 /deposit, docs/physics.md "The deposit as a
 * height map"): each deposited particle's volume goes to the square cell under its centre; height = volume /
 * (cell area * packing). */
struct dem_gaussian {
    double amplitude, centre, width; /* h(y) = amplitude exp(-(y - centre)^2 / (2 width^2)): width is sigma (m) */
    double amplitude_error, centre_error, width_error; /* standard errors from the residuals (least squares) */
    double rms;                                        /* root mean square residual (m) */
    int iterations;
};
/* Least-squares fit of the Gaussian to n >= 4 points (y_i, h_i, y ascending) by Levenberg-Marquardt from the
 * moments of h, then again over the points within 5 widths of that centre: the parameters and their standard errors
 * do not depend on how many empty points lie beyond.  SC_OK, or SC_ESIM when the points hold no peak (all h <= 0) or
 * the fit does not converge. */
int dem_gaussian_fit(const double *y, const double *h, size_t n, struct dem_gaussian *fit);

struct dem_deposit {
    size_t nx, ny;
    double x0, y0, cell; /* the centre of cell (0, 0) and the cells' side (m) */
    double packing;
    const char *pattern; /* [path] pattern: "none", "line", "raster", "file" */
    double *height;      /* ny rows of nx (row j at y0 + j cell), m */
    double volume, mass; /* of the deposited particles (m3, kg) */
    /* patterns line and raster: the height across the track (y), averaged over the cells whose centres lie in the
     * middle half of the pass length (x); the mean of it over the band the nozzle disc swept; its Gaussian fit */
    size_t profile_count;
    double *profile_y, *profile_height;
    double band_lo, band_hi, mean_thickness;
    int has_fit; /* pattern line and the fit converged */
    struct dem_gaussian fit;
};
int dem_deposit_build(const struct dem_solver *s, struct dem_deposit *deposit);
void dem_deposit_free(struct dem_deposit *deposit);
/* The group /deposit of spray.h5 (docs/files.md). */
int dem_deposit_write(const struct dem_deposit *deposit, hid_t file);

/* The particles at one time: spray.h5 /snapshots/NNNNNN (docs/files.md).  The spray stage takes one every
 * snapshot_every of simulated time and at the end, keeps them in memory and in its checkpoints (a resumed run
 * goes on from the snapshots of its checkpoint: none twice, none missing) and writes them with the output. */
struct dem_snapshot {
    double t;
    int64_t step;
    size_t count;
    int64_t *id, *state;
    double *x, *v, *d; /* x and v: 3 per particle */
};
struct dem_snapshots {
    size_t count, capacity;
    struct dem_snapshot *items;
};
/* Steps between snapshots (0: none) of a configuration. */
int64_t dem_snapshot_steps(const struct dem_config *cfg);
/* Append the solver's particles now; SC_EIO (SC_FAIL_OOM) when out of memory. */
int dem_snapshot_take(const struct dem_solver *s, struct dem_snapshots *list);
/* The group `snapshots` of loc with one group per snapshot (6-digit index; attributes t, step); checksum as
 * h5_write_doubles. */
int dem_snapshots_write(const struct dem_snapshots *list, hid_t loc, int checksum);
/* Replace list by the group `snapshots` of loc (none: an empty list). */
int dem_snapshots_read(hid_t loc, struct dem_snapshots *list);
void dem_snapshots_free(struct dem_snapshots *list);

/* ---- The de Laval nozzle in front of the spray (dem/nozzle.c) (docs/physics.md "Nozzle").
 *
 * Quasi-one-dimensional isentropic flow of a calorically perfect gas through a conical convergent-divergent
 * nozzle (Anderson, Modern Compressible Flow, 3rd ed., Ch. 5: the area-Mach relation Eq. 5.20 and the isentropic
 * relations Eqs. 3.28-3.31; the normal shock Eq. 3.57), and each particle's acceleration and heating along its axis:
 * drag with Henderson's (1976) coefficient for continuum and rarefied, subsonic and supersonic flow, convective
 * heating with the Ranz-Marshall (1952) Nusselt number towards the recovery temperature, integrated with CVODE.
 * Coordinates: x along the axis from the convergent inlet (x = 0), the throat at x = convergent_length, the exit
 * at x = convergent_length + divergent_length.  All quantities SI. ---- */
enum dem_nozzle_gas { DEM_NOZZLE_N2, DEM_NOZZLE_HE, DEM_NOZZLE_AIR };

/* A process gas: calorically perfect, Sutherland's viscosity law mu = mu_ref (T/T_ref)^1.5 (T_ref + S)/(T + S),
 * constant Prandtl number (docs/physics.md "Nozzle" cites the values). */
struct dem_nozzle_gas_properties {
    const char *name;
    double gamma;        /* ratio of specific heats */
    double gas_constant; /* J/(kg K) */
    double mu_ref;       /* Pa s at t_ref */
    double t_ref;        /* K */
    double sutherland;   /* S, K */
    double prandtl;      /* - */
};
const struct dem_nozzle_gas_properties *dem_nozzle_gas_properties(enum dem_nozzle_gas gas);
/* Dynamic viscosity (Pa s) of the gas at temperature T (K). */
double dem_nozzle_viscosity(const struct dem_nozzle_gas_properties *gas, double temperature);

/* The gas at one station. */
struct dem_nozzle_station {
    double x;           /* m from the inlet */
    double diameter;    /* m */
    double mach;        /* - */
    double pressure;    /* Pa, static */
    double temperature; /* K, static */
    double density;     /* kg/m3 */
    double velocity;    /* m/s */
};

enum { DEM_NOZZLE_PROFILE_POINTS = 201, DEM_NOZZLE_TABLE_ROWS = 24 };

struct dem_nozzle {
    int enabled; /* 0: no [nozzle] section, none of the rest is set */
    enum dem_nozzle_gas gas;
    struct dem_nozzle_gas_properties properties;
    double stagnation_pressure, stagnation_temperature; /* Pa, K */
    double inlet_diameter, throat_diameter, exit_diameter;
    double convergent_length, divergent_length; /* m */
    double ambient_pressure;                    /* Pa */
    /* the powder as the nozzle sees it */
    double particle_density;       /* kg/m3 */
    double particle_specific_heat; /* J/(kg K) */
    double particle_temperature;   /* K, at the inlet */
    /* results (dem_nozzle_solve) */
    struct dem_nozzle_station exit;
    struct dem_nozzle_station profile[DEM_NOZZLE_PROFILE_POINTS]; /* equally spaced inlet to exit */
    double table_diameter[DEM_NOZZLE_TABLE_ROWS];                 /* m, ascending (logarithmically spaced) */
    double table_velocity[DEM_NOZZLE_TABLE_ROWS];                 /* m/s at the exit */
    double table_temperature[DEM_NOZZLE_TABLE_ROWS];              /* K at the exit */
    double table_time[DEM_NOZZLE_TABLE_ROWS];                     /* s, residence time inlet to exit */
};

/* A/A* of the isentropic flow at Mach number M (Anderson Eq. 5.20). */
double dem_nozzle_area_ratio(double mach, double gamma);
/* The Mach number of area ratio A/A* >= 1 on the subsonic (supersonic = 0) or supersonic branch, to round-off. */
double dem_nozzle_mach(double area_ratio, double gamma, int supersonic);
/* The gas at x (subsonic before the throat, supersonic after it). */
void dem_nozzle_station_at(const struct dem_nozzle *n, double x, struct dem_nozzle_station *out);

/* Henderson (1976), AIAA J. 14:707-708: the drag coefficient of a sphere at Reynolds number Re and Mach number M
 * of the slip, the sphere's temperature over the gas's temperature_ratio = T_p/T_g, the gas's gamma. */
double dem_nozzle_drag_coefficient(double reynolds, double mach, double temperature_ratio, double gamma);

/* The particle's rates along the axis at x: y = (v, T_p, t) (m/s, K, s), dy/dx (v > 0). */
void dem_nozzle_particle_rates(const struct dem_nozzle *n, double diameter, double x, const double y[3],
                               double dydx[3]);

/* Integrate one particle of diameter d from the inlet (at the gas speed there, at particle_temperature) to the
 * exit with CVODE; out = (v, T_p, t) at the exit.  SC_ESIM if the integration fails. */
int dem_nozzle_particle_exit(const struct dem_nozzle *n, double diameter, double out[3]);

/* The exit state, the profile and the particle table over [d_small, d_large]; SC_EINPUT when a normal shock would
 * stand inside the divergent part (the ambient pressure above the pressure behind a normal shock at the exit),
 * with the numbers in the message. */
int dem_nozzle_solve(struct dem_nozzle *n, double d_small, double d_large);

/* 1 when the solved nozzle's exit pressure is below 0.4 of the ambient: its flow may separate from the divergent wall
 * before the exit (Summerfield et al. 1954), which the quasi-1-D attached flow does not capture; dem_nozzle_solve
 * warns. */
int dem_nozzle_may_separate(const struct dem_nozzle *n);

/* The exit velocity and temperature of diameter d, interpolated in ln d in the table (held at its ends). */
void dem_nozzle_lookup(const struct dem_nozzle *n, double diameter, double *velocity, double *temperature);

#endif
