/* The spray stage's case keys and their resolution into struct dem_config. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/csv.h"
#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/run_keys.h"
#include "dem/dem.h"
#include "dem/dem_impl.h"

const struct cfg_key dem_case_keys[] = {
    /* [spray] */
    {"spray", "dt", CFG_REAL, "s", "2e-6", 0, 1e-2, 1, NULL, "time step"},
    {"spray", "t_end", CFG_REAL, "s", "0.01", 0, 1e4, 1, NULL, "simulated time"},
    {"spray", "injection", CFG_CHOICE, "", "stream", 0, 0, 0, "stream|file",
     "stream: random injection at the nozzle (Eq. 35); file: particles read from `particles`"},
    {"spray", "particles", CFG_PATH, "", NULL, 0, 0, 0, NULL,
     "CSV with header x,y,z,vx,vy,vz,wx,wy,wz,d (SI), with injection = file"},
    {"spray", "feed_count", CFG_INT, "-", "50", 1, 1e7, 0, NULL, "N_in: particles per injection (Eq. 35)"},
    {"spray", "feed_every", CFG_INT, "-", "100", 1, 2e9, 0, NULL,
     "T_in: time steps between injections, a count (Eq. 35)"},
    {"spray", "max_injected", CFG_INT, "-", "50050", 1, 1e9, 0, NULL, "injection stops after this many particles"},
    {"spray", "nozzle_radius", CFG_REAL, "m", "0.01", 0, 10, 1, NULL,
     "radius of the injection disc at z = 0 (with [nozzle] and not given: the nozzle's exit radius)"},
    {"spray", "release_speed_min", CFG_REAL, "m/s", "0", 0, 1e4, 0, NULL, "lowest release speed"},
    {"spray", "release_speed_max", CFG_REAL, "m/s", "50", 0, 1e4, 0, NULL, "highest release speed"},
    {"spray", "release_cone", CFG_REAL, "degree", "0", 0, 89.9, 0, NULL,
     "half-angle of the cone of release directions around +z (uniform in solid angle)"},
    {"spray", "phi", CFG_REAL, "-", "0.5", 0, 1, 0, NULL, "phi of the one-step scheme, Eqs. 42-43 (0.5: trapezoidal)"},
    /* at most 0.1: dem/integrate.c's first_iterate_stops needs tol < 1 */
    {"spray", "fixed_point_tol", CFG_REAL, "-", "1e-8", 0, 0.1, 1, NULL,
     "relative tolerance of the fixed-point iterations, Eq. 53 (per particle)"},
    {"spray", "fixed_point_max_iter", CFG_INT, "-", "50", 1, 100000, 0, NULL, "iteration limit per step"},
    {"spray", "domain_radius", CFG_REAL, "m", "0.1", 0, 100, 1, NULL,
     "escape boundary: particles farther than this from the axis are removed"},
    {"spray", "handoff_height", CFG_REAL, "m", "0.01", 0, 100, 0, NULL,
     "height above the target of the hand-off plane whose crossings are recorded"},
    {"spray", "metrics_every", CFG_INT, "steps", "100", 1, 2e9, 0, NULL, "steps between metric samples"},
    {"spray", "snapshot_every", CFG_REAL, "s", "auto", 0, 100, 0, "auto",
     "simulated time between snapshots of the particles in spray.h5 /snapshots (and the end); auto: t_end / 32; "
     "0: none"},
    /* [powder] */
    {"powder", "distribution", CFG_CHOICE, "", "weibull", 0, 0, 0, "weibull|mono", "size distribution, Eq. 36"},
    {"powder", "median_diameter", CFG_REAL, "m", "160e-6", 0, 1, 1, NULL,
     "D_median, Eq. 37: the median by number of the untruncated law (half the particles are smaller); a powder "
     "sheet's d50 is usually by volume, which is larger (1.26 D_median at shape 3.5)"},
    {"powder", "shape", CFG_REAL, "-", "5", 0, 100, 1, NULL, "Weibull shape n, Eq. 36"},
    {"powder", "d_min", CFG_REAL, "m", "0", 0, 1, 0, NULL, "smallest diameter (truncation; 0 = none)"},
    {"powder", "d_max", CFG_REAL, "m", "0", 0, 1, 0, NULL, "largest diameter (truncation; 0 = none)"},
    {"powder", "density", CFG_REAL, "kg/m3", "5680", 0, 1e5, 1, NULL, "particle density (Table 1)"},
    {"powder", "shear_modulus", CFG_REAL, "Pa", "77e9", 0, 1e13, 1, NULL, "particle G (Table 1)"},
    {"powder", "bulk_modulus", CFG_REAL, "Pa", "167e9", 0, 1e13, 1, NULL, "particle K (Table 1)"},
    {"powder", "yield_stress", CFG_REAL, "Pa", "690e6", 0, 1e12, 1, NULL, "particle yield stress Y, Eqs. 17-19"},
    {"powder", "surface_energy", CFG_REAL, "J/m2", "46e-3", 0, 100, 0, NULL, "particle surface energy (Table 1)"},
    {"powder", "friction", CFG_REAL, "-", "0.5", 0, 10, 0, NULL, "particle Coulomb friction coefficient"},
    /* [target] */
    {"target", "standoff", CFG_REAL, "m", "0.3", 0, 100, 1, NULL, "distance nozzle exit to target plane"},
    {"target", "shear_modulus", CFG_REAL, "Pa", "80e9", 0, 1e13, 1, NULL, "target G (Table 1)"},
    {"target", "bulk_modulus", CFG_REAL, "Pa", "160e9", 0, 1e13, 1, NULL, "target K (Table 1)"},
    {"target", "yield_stress", CFG_REAL, "Pa", "690e6", 0, 1e12, 1, NULL, "target yield stress (Table 1)"},
    {"target", "surface_energy", CFG_REAL, "J/m2", "1.1", 0, 100, 0, NULL, "target surface energy (Table 1)"},
    {"target", "friction", CFG_REAL, "-", "0.5", 0, 10, 0, NULL, "target Coulomb friction coefficient"},
    {"target", "deposit_radius", CFG_REAL, "m", "0.005", 0, 100, 1, NULL,
     "radius of the deposit region around the axis used for the volume fraction"},
    /* [contact] */
    {"contact", "restitution", CFG_REAL, "-", "johnson", 0, 1, 0, "johnson",
     "johnson: velocity-dependent e of Eqs. 16-19; or a constant e in [0, 1]"},
    {"contact", "friction_regularization", CFG_REAL, "m/s", "1e-4", 0, 1e3, 1, NULL,
     "slip speed epsilon of the regularised Coulomb law, Eq. 11"},
    {"contact", "rest_speed", CFG_REAL, "m/s", "1", 0, 1e3, 0, NULL,
     "a particle that meets the target or a fixed particle slower than this (its whole speed) and does not stick "
     "comes to rest there (resting: no longer moved or re-collided; 0: never; jet model none: never)"},
    /* [jet] */
    {"jet", "model", CFG_CHOICE, "", "bickley", 0, 0, 0, "bickley|uniform|none",
     "gas field: self-similar jet of Eqs. 26-27, uniform stream along +z, or no gas (no drag)"},
    {"jet", "drag", CFG_CHOICE, "", "auto", 0, 0, 0, "auto|haider_levenspiel|stokes|henderson",
     "drag coefficient: Eq. 25 (Haider-Levenspiel), Stokes 24/Re, or Henderson (1976) with the slip's Mach number; "
     "auto: henderson with [nozzle], else haider_levenspiel"},
    {"jet", "C1", CFG_REAL, "m^(4/3)/s", "30", 0, 1e6, 0, NULL, "axial velocity scale, Eq. 26"},
    {"jet", "C2", CFG_REAL, "m^(5/3)/s", NULL, -1e6, 1e6, 0, NULL,
     "entrainment scale, Eq. 27 (default C1/(3 C3): divergence-free)"},
    {"jet", "C3", CFG_REAL, "m^(-1/3)", "20", 0, 1e6, 1, NULL, "spreading constant, Eqs. 26-27"},
    {"jet", "virtual_origin", CFG_REAL, "m", "0.1", 0, 100, 0, NULL,
     "distance of the jet's virtual origin behind the nozzle exit (x = z + virtual_origin)"},
    {"jet", "core_length", CFG_REAL, "m", "0.02", 0, 100, 0, NULL,
     "potential core: no decay and no entrainment for z below this"},
    {"jet", "gas_density", CFG_REAL, "kg/m3", "1.1", 0, 1e4, 1, NULL, "carrier gas density (Table 1)"},
    {"jet", "gas_viscosity", CFG_REAL, "m2/s", "25e-6", 0, 1, 1, NULL, "kinematic viscosity (Table 1)"},
    {"jet", "uniform_velocity", CFG_REAL, "m/s", "0", -1e4, 1e4, 0, NULL, "gas velocity along +z, model = uniform"},
    {"jet", "stagnation_height", CFG_REAL, "-", "1.5", 0, 10, 0, NULL,
     "model = bickley: height of the wall region in front of the target, in half-widths of the free jet at the "
     "target (1.5: the impingement region of 0.14 of the nozzle-to-plate distance, Beltaos & Rajaratnam 1974, "
     "over a round jet's half-width of 0.094 of it); 0: the free jet up to the target"},
    {"jet", "gas_temperature", CFG_REAL, "K", "293.15", 0, 1e4, CFG_MIN_EXCLUSIVE, NULL,
     "static temperature of the jet gas, the same throughout the free jet (isobaric at gas_density); sets the sound "
     "speed of bow_shock"},
    {"jet", "gas_gamma", CFG_REAL, "-", "1.4", 1, 2, CFG_MIN_EXCLUSIVE, NULL,
     "ratio of specific heats of the jet gas (1.4: air, N2; 5/3: He)"},
    {"jet", "gas_constant", CFG_REAL, "J/(kg K)", "287.05", 0, 1e5, CFG_MIN_EXCLUSIVE, NULL,
     "specific gas constant of the jet gas (287.05: air; 296.8: N2; 2077.3: He)"},
    {"jet", "gas_sutherland", CFG_REAL, "K", "111", 0, 1e4, 0, NULL,
     "Sutherland's constant S of the jet gas (111: air; 107: N2, White, Viscous Fluid Flow, Table 1-2; 79.4: He, "
     "dem/nozzle.c): the viscosity behind a bow shock, mu2/mu1 = (T2/T1)^1.5 (T1 + S)/(T2 + S)"},
    {"jet", "bow_shock", CFG_CHOICE, "", "auto", 0, 0, 0, "auto|none",
     "auto: where the free jet arrives supersonic on the axis, a normal shock stands in front of the target "
     "(standoff 0.82 b rho1/rho2, Lobb 1964) over a compressed layer; none: the subsonic wall region always"},
    /* [deposition] */
    {"deposition", "rule", CFG_CHOICE, "", "adhesion", 0, 0, 0, "adhesion|critical_velocity|table|none",
     "adhesion: stick below the Eq. 34 speed; critical_velocity/table: stick at or above v_crit (cold "
     "spray); none: always rebound"},
    {"deposition", "alpha_adh", CFG_REAL, "-", "5000", 0, 1e12, 1, NULL, "alpha_ADH factor of Eq. 34"},
    {"deposition", "critical_velocity", CFG_REAL, "m/s", NULL, 0, 1e5, 1, NULL,
     "normal impact speed at and above which a particle sticks, rule = critical_velocity"},
    {"deposition", "table", CFG_PATH, "", NULL, 0, 0, 0, NULL,
     "v_crit(d) or v_crit(d, T) table (CSV with columns diameter,v_crit and optionally temperature, or HDF5 with "
     "datasets diameter, v_crit and optionally temperature: the output of `spraycoat vcrit`), rule = table"},
    /* [powder]: the particles' temperature (docs/physics.md "Nozzle") */
    {"powder", "temperature", CFG_REAL, "K", "293.15", 0, 5000, 1, NULL,
     "particles' temperature at release without [nozzle] (with it: at the nozzle inlet)"},
    {"powder", "specific_heat", CFG_REAL, "J/(kg K)", "900", 0, 1e5, 1, NULL,
     "particle specific heat, for the heating in [nozzle] (Al about 900, Cu 385, steel 500)"},
    /* [nozzle]: the de Laval nozzle (dem/nozzle.c); optional: without stagnation_pressure none */
    {"nozzle", "gas", CFG_CHOICE, "", "n2", 0, 0, 0, "n2|he|air",
     "process gas (properties in docs/physics.md \"Nozzle\")"},
    {"nozzle", "stagnation_pressure", CFG_REAL, "Pa", NULL, 0, 1e9, 1, NULL,
     "gas pressure in the pre-chamber (gives the nozzle: release speeds, temperatures and the jet from it)"},
    {"nozzle", "stagnation_temperature", CFG_REAL, "K", NULL, 0, 5000, 1, NULL, "gas temperature in the pre-chamber"},
    {"nozzle", "throat_diameter", CFG_REAL, "m", NULL, 0, 1, 1, NULL, "throat diameter"},
    {"nozzle", "exit_diameter", CFG_REAL, "m", NULL, 0, 1, 1, NULL, "exit diameter (at least the throat's)"},
    {"nozzle", "inlet_diameter", CFG_REAL, "m", "auto", 0, 1, 1, "auto",
     "diameter at the convergent part's inlet; auto: 3 throat diameters"},
    {"nozzle", "convergent_length", CFG_REAL, "m", NULL, 0, 10, 1, NULL, "length of the conical convergent part"},
    {"nozzle", "divergent_length", CFG_REAL, "m", NULL, 0, 10, 1, NULL, "length of the conical divergent part"},
    {"nozzle", "ambient_pressure", CFG_REAL, "Pa", "101325", 0, 1e9, 0, NULL,
     "pressure of the room the nozzle sprays into (checks the exit for a shock inside the nozzle)"},
    {"deposition", "size_classes", CFG_INT, "-", "8", 1, 1000, 0, NULL,
     "classes of equal width over the run's diameters ([powder] d_min to d_max, else the smallest to the largest "
     "sprayed) of the deposition efficiency's split by size (spray.h5 /deposition_efficiency/by_size)"},
    {"deposition", "angle_class_width", CFG_REAL, "degree", "10", 0, 90, 1, NULL,
     "width of the classes of the first impact's angle to the target normal of the deposition efficiency's "
     "split by angle (spray.h5 /deposition_efficiency/by_angle)"},
    /* [path] */
    {"path", "pattern", CFG_CHOICE, "", "none", 0, 0, 0, "none|line|raster|file",
     "the nozzle's motion: none (fixed at the origin), line (passes back and forth along +x), raster (passes along x "
     "step_over apart in +y), file (waypoints)"},
    {"path", "traverse_speed", CFG_REAL, "m/s", "0.2", 0, 100, 1, NULL,
     "nozzle speed along the path, pattern = line or raster (far below the gas speed: the jet is quasi-steady)"},
    {"path", "start_x", CFG_REAL, "m", "0", -100, 100, 0, NULL, "x where the first pass starts"},
    {"path", "start_y", CFG_REAL, "m", "0", -100, 100, 0, NULL, "y where the first pass starts"},
    {"path", "pass_length", CFG_REAL, "m", "0.02", 0, 100, 1, NULL, "length of a pass along x"},
    {"path", "step_over", CFG_REAL, "m", "0.002", 0, 100, 0, NULL,
     "pattern = raster: distance in +y between passes (> 0 with passes > 1)"},
    {"path", "passes", CFG_INT, "-", "1", 1, 1e6, 0, NULL,
     "number of passes (line: over the same line, back and forth; raster: rows)"},
    {"path", "waypoints", CFG_PATH, "", NULL, 0, 0, 0, NULL,
     "pattern = file: CSV with header t,x,y (SI), t ascending from 0; the nozzle moves linearly between them"},
    {"path", "map_cell", CFG_REAL, "m", "auto", 0, 1, 1, "auto",
     "side of the cells of the deposit's height map (spray.h5 /deposit); auto: the larger of nozzle_radius / 8 "
     "and the median diameter"},
    {"path", "packing", CFG_REAL, "-", "1", 0, 1, 1, NULL,
     "volume fraction of the deposit: height = particle volume / (cell area packing); 1: the volume-equivalent "
     "thickness of a dense coating"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

static void load_material(const struct case_file *c, const char *section, struct dem_material *m)
{
    m->density = strcmp(section, "powder") == 0 ? case_real(c, section, "density") : 0.0;
    m->shear_modulus = case_real(c, section, "shear_modulus");
    m->bulk_modulus = case_real(c, section, "bulk_modulus");
    m->yield_stress = case_real(c, section, "yield_stress");
    m->surface_energy = case_real(c, section, "surface_energy");
    m->friction = case_real(c, section, "friction");
}

static int load_spray(const struct case_file *c, struct dem_config *cfg)
{
    cfg->dt = case_real(c, "spray", "dt");
    cfg->t_end = case_real(c, "spray", "t_end");
    cfg->injection = case_is(c, "spray", "injection", "file") ? DEM_INJECT_FILE : DEM_INJECT_STREAM;
    cfg->feed_count = case_int(c, "spray", "feed_count");
    cfg->feed_every = case_int(c, "spray", "feed_every");
    cfg->max_injected = case_int(c, "spray", "max_injected");
    cfg->nozzle_radius = case_real(c, "spray", "nozzle_radius");
    cfg->release_speed_min = case_real(c, "spray", "release_speed_min");
    cfg->release_speed_max = case_real(c, "spray", "release_speed_max");
    cfg->release_cone = case_real(c, "spray", "release_cone") * M_PI / 180.0;
    cfg->phi = case_real(c, "spray", "phi");
    cfg->fixed_point_tol = case_real(c, "spray", "fixed_point_tol");
    cfg->fixed_point_max_iter = case_int(c, "spray", "fixed_point_max_iter");
    cfg->domain_radius = case_real(c, "spray", "domain_radius");
    cfg->handoff_height = case_real(c, "spray", "handoff_height");
    cfg->metrics_every = case_int(c, "spray", "metrics_every");
    cfg->snapshot_every =
        case_is(c, "spray", "snapshot_every", "auto") ? cfg->t_end / 32 : case_real(c, "spray", "snapshot_every");
    if (cfg->release_speed_min > cfg->release_speed_max)
        return case_invalid(c, "spray", "release_speed_min", "greater than release_speed_max = %g m/s",
                            cfg->release_speed_max);
    if (cfg->dt > cfg->t_end)
        return case_invalid(c, "spray", "dt", "longer than t_end = %g s", cfg->t_end);
    if (cfg->t_end / cfg->dt > 1e12)
        return case_invalid(c, "spray", "dt", "t_end / dt = %g steps; allowed: at most 1e12", cfg->t_end / cfg->dt);
    return SC_OK;
}

static int load_powder(const struct case_file *c, struct dem_config *cfg)
{
    struct dem_size_distribution *sizes = &cfg->sizes;
    sizes->monodisperse = case_is(c, "powder", "distribution", "mono");
    sizes->median_diameter = case_real(c, "powder", "median_diameter");
    sizes->shape = case_real(c, "powder", "shape");
    sizes->d_min = case_real(c, "powder", "d_min");
    double d_max = case_real(c, "powder", "d_max");
    sizes->d_max = d_max > 0 ? d_max : INFINITY;
    if (sizes->d_min >= sizes->d_max)
        return case_invalid(c, "powder", "d_min", "not below d_max = %g m", d_max);
    if (!sizes->monodisperse && sizes->d_max < INFINITY) {
        double scale = dem_weibull_scale(sizes->median_diameter, sizes->shape);
        double mass =
            dem_weibull_cdf(sizes->d_max, scale, sizes->shape) - dem_weibull_cdf(sizes->d_min, scale, sizes->shape);
        if (!(mass > 1e-12))
            return case_invalid(c, "powder", "d_max",
                                "the range [d_min, d_max] holds no part of the Weibull distribution "
                                "(median %g m, shape %g)",
                                sizes->median_diameter, sizes->shape);
    }
    load_material(c, "powder", &cfg->powder);
    return SC_OK;
}

static int load_target(const struct case_file *c, struct dem_config *cfg)
{
    load_material(c, "target", &cfg->target);
    cfg->standoff = case_real(c, "target", "standoff");
    cfg->deposit_radius = case_real(c, "target", "deposit_radius");
    if (cfg->handoff_height >= cfg->standoff)
        return case_invalid(c, "spray", "handoff_height", "not below the standoff %g m", cfg->standoff);
    /* a centre never comes closer to the target than its radius: a lower plane would record nothing */
    const struct dem_size_distribution *sizes = &cfg->sizes;
    double d_largest = sizes->monodisperse ? sizes->median_diameter : sizes->d_max;
    if (cfg->injection == DEM_INJECT_STREAM && d_largest < INFINITY && cfg->handoff_height <= 0.5 * d_largest)
        return case_invalid(c, "spray", "handoff_height",
                            "not above the largest particle radius %g m, so "
                            "particle centres would never cross it",
                            0.5 * d_largest);
    return SC_OK;
}

static void load_contact_and_jet(const struct case_file *c, struct dem_config *cfg)
{
    struct dem_contact_law *law = &cfg->contact;
    law->friction_regularization = case_real(c, "contact", "friction_regularization");
    cfg->rest_speed = case_real(c, "contact", "rest_speed");
    if (case_is(c, "contact", "restitution", "johnson")) {
        law->model = DEM_RESTITUTION_JOHNSON;
        law->restitution = 1.0;
    } else {
        law->model = DEM_RESTITUTION_CONSTANT;
        law->restitution = case_real(c, "contact", "restitution");
    }
    struct dem_gas_field *gas = &cfg->gas;
    gas->model = case_is(c, "jet", "model", "bickley")   ? DEM_JET_BICKLEY
                 : case_is(c, "jet", "model", "uniform") ? DEM_JET_UNIFORM
                                                         : DEM_JET_NONE;
    gas->drag = case_is(c, "jet", "drag", "stokes")      ? DEM_DRAG_STOKES
                : case_is(c, "jet", "drag", "henderson") ? DEM_DRAG_HENDERSON
                                                         : DEM_DRAG_HAIDER_LEVENSPIEL; /* auto: see map_jet */
    gas->c1 = case_real(c, "jet", "C1");
    gas->c3 = case_real(c, "jet", "C3");
    /* Erratum of Eq. 27 (docs/physics.md): C2 = C1/(3 C3) makes the planar jet divergence-free. */
    gas->c2 = case_has(c, "jet", "C2") ? case_real(c, "jet", "C2") : gas->c1 / (3.0 * gas->c3);
    gas->virtual_origin = case_real(c, "jet", "virtual_origin");
    gas->core_length = case_real(c, "jet", "core_length");
    gas->uniform_velocity = case_real(c, "jet", "uniform_velocity");
    gas->density = case_real(c, "jet", "gas_density");
    gas->kinematic_viscosity = case_real(c, "jet", "gas_viscosity");
    gas->stagnation_factor = case_real(c, "jet", "stagnation_height");
    gas->gas_temperature = case_real(c, "jet", "gas_temperature");
    gas->gas_gamma = case_real(c, "jet", "gas_gamma");
    gas->gas_constant = case_real(c, "jet", "gas_constant");
    gas->gas_sutherland = case_real(c, "jet", "gas_sutherland");
    gas->bow_shock = case_is(c, "jet", "bow_shock", "none") ? DEM_BOW_SHOCK_NONE : DEM_BOW_SHOCK_AUTO;
    dem_gas_set_wall(gas, cfg->standoff);
}

/* The self-similar jet is singular at its virtual origin: the core must end downstream of it. */
static int check_jet(const struct case_file *c, const struct dem_gas_field *gas)
{
    if (gas->model == DEM_JET_BICKLEY && !(gas->virtual_origin + gas->core_length > 0.0))
        return case_invalid(c, "jet", "virtual_origin",
                            "virtual_origin + core_length must be > 0 m (the jet of "
                            "Eqs. 26-27 is singular at its virtual origin)");
    return SC_OK;
}

/* Read a CSV table of numbers (core/csv.h); an error names the case key that gave the path. */
static int read_csv_columns(const struct case_file *c, const char *section, const char *key, const char *path,
                            const struct csv_column *columns, int column_count, int flags, double **rows_out,
                            size_t *count_out)
{
    char message[1024];
    struct csv_table table;
    if (csv_read(path, columns, column_count, flags, &table, message, sizeof message) != SC_OK)
        return case_invalid(c, section, key, "%s", message);
    *rows_out = table.numbers;
    *count_out = table.rows;
    table.numbers = NULL;
    csv_free(&table);
    return SC_OK;
}

struct row_at_x {
    double x;
    size_t row;
};

static int compare_row_x(const void *a, const void *b)
{
    double xa = ((const struct row_at_x *)a)->x, xb = ((const struct row_at_x *)b)->x;
    return (xa > xb) - (xa < xb);
}

/* Particles of the file that overlap at t = 0: a contact starts when two surfaces meet, so an overlapping pair
 * never collides (they pass through each other).  Warned, with the first pair's rows: a set-up error, but the
 * tests' random clouds start so and drop those pairs.  Sorted by x, each row meets only the rows within the
 * largest diameter along x. */
static void warn_overlapping_particles(const struct dem_config *cfg)
{
    size_t n = cfg->file_particle_count, pairs = 0, first[2] = {0, 0};
    struct row_at_x *order = malloc((n ? n : 1) * sizeof *order);
    if (!order)
        return; /* a warning only */
    const double *rows = cfg->file_particles;
    double d_max = 0.0;
    for (size_t i = 0; i < n; i++)
        order[i] = (struct row_at_x){rows[10 * i], i}, d_max = fmax(d_max, rows[10 * i + 9]);
    qsort(order, n, sizeof *order, compare_row_x);
    for (size_t a = 0; a < n; a++)
        for (size_t b = a + 1; b < n && order[b].x - order[a].x < d_max; b++) {
            const double *p = rows + 10 * order[a].row, *q = rows + 10 * order[b].row;
            double dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2], contact = 0.5 * (p[9] + q[9]);
            if (!(dx * dx + dy * dy + dz * dz < contact * contact))
                continue;
            size_t low = order[a].row < order[b].row ? order[a].row : order[b].row,
                   high = order[a].row ^ order[b].row ^ low;
            if (pairs++ == 0 || low < first[0] || (low == first[0] && high < first[1]))
                first[0] = low, first[1] = high; /* the first in the file's order */
        }
    free(order);
    if (pairs > 0)
        log_warn("spray: %zu pair%s of the particles in %s overlap at t = 0 (first: data rows %zu and %zu): a pair "
                 "that starts overlapping never collides, its particles pass through each other",
                 pairs, pairs > 1 ? "s" : "", cfg->particles_path, first[0] + 1, first[1] + 1);
}

static int load_particles_file(const struct case_file *c, struct dem_config *cfg)
{
    /* the ranges of the keys the columns stand for: positions as standoff and domain_radius (at most 100 m),
     * velocities as release_speed_max (at most 1e4 m/s), d as d_min, d_max and median_diameter (at most 1 m; at least 1
     * nm, as no powder is finer: 1e-300 m passed the keys' range and stalled the run); spins at most 1e9 rad/s (no key)
     */
    static const struct csv_column columns[] = {
        {"x", CSV_NUMBER, -100, 100, 0, "m", NULL},      {"y", CSV_NUMBER, -100, 100, 0, "m", NULL},
        {"z", CSV_NUMBER, -100, 100, 0, "m", NULL},      {"vx", CSV_NUMBER, -1e4, 1e4, 0, "m/s", NULL},
        {"vy", CSV_NUMBER, -1e4, 1e4, 0, "m/s", NULL},   {"vz", CSV_NUMBER, -1e4, 1e4, 0, "m/s", NULL},
        {"wx", CSV_NUMBER, -1e9, 1e9, 0, "rad/s", NULL}, {"wy", CSV_NUMBER, -1e9, 1e9, 0, "rad/s", NULL},
        {"wz", CSV_NUMBER, -1e9, 1e9, 0, "rad/s", NULL}, {"d", CSV_NUMBER, 1e-9, 1, 0, "m", NULL},
    };
    if (!case_has(c, "spray", "particles"))
        return case_require(c, "spray", "particles", "injection = file");
    SC_TRY(case_path(c, "spray", "particles", cfg->particles_path, sizeof cfg->particles_path));
    SC_TRY(read_csv_columns(c, "spray", "particles", cfg->particles_path, columns, 10, 0, &cfg->file_particles,
                            &cfg->file_particle_count));
    for (size_t i = 0; i < cfg->file_particle_count; i++) {
        const double *row = cfg->file_particles + 10 * i;
        if (!(row[9] > 0))
            return case_invalid(c, "spray", "particles", "%s: data row %zu: diameter d = %g m must be > 0",
                                cfg->particles_path, i + 1, row[9]);
        if (row[2] + row[9] / 2 > cfg->standoff)
            return case_invalid(c, "spray", "particles",
                                "%s: data row %zu: the particle lies beyond the target "
                                "plane z = %g m",
                                cfg->particles_path, i + 1, cfg->standoff);
    }
    warn_overlapping_particles(cfg);
    return SC_OK;
}

/* The rows (diameter, [temperature,] v_crit) of a v_crit table, `width` 2 or 3 numbers each. */
struct vcrit_rows {
    size_t count;
    int width;
    double *numbers;
};

/* A 2-D table of `spraycoat vcrit` holds a pair it could not bracket as a comment line "# d,T,nan,..." (vcrit.csv) or
 * a NaN cell of /grid/v_crit (vcrit.h5), and leaves it out of the rows.  When every pair of a temperature (or a
 * diameter) is left out the rows still fill a smaller grid, and the table would be read as if that temperature had
 * never been asked for: its particles would get the v_crit of the nearest temperature searched.  So such a pair is
 * refused, wherever it lies. */
static int unbracketed_pair(const struct case_file *c, const char *path, long line, double d, double T)
{
    return case_invalid(c, "deposition", "table",
                        "%s%s%.0ld: d = %g m, T = %g K has no v_crit (`spraycoat vcrit` did not bracket it: its "
                        "vcrit.csv says why); a table v_crit(d, T) needs every pair: search it again with a wider "
                        "v_low .. v_high, or leave that temperature or diameter out of the search",
                        path, line > 0 ? ":" : "", line > 0 ? line : 0L, d, T);
}

/* The first "# d,T,nan" comment line of a 2-D CSV table (an unbracketed pair of `spraycoat vcrit`), refused. */
static int csv_unbracketed_pairs(const struct case_file *c, const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) /* csv_read read it a moment ago: a reader failing now says so itself */
        return SC_OK;
    char text[512];
    long line = 0;
    int status = SC_OK;
    while (status == SC_OK && fgets(text, sizeof text, f)) {
        line++;
        char *p = text, *end;
        if (p[0] != '#')
            continue;
        double d = strtod(p + 1, &end), T = NAN;
        if (end != p + 1 && *end == ',')
            T = strtod(p = end + 1, &end);
        if (end != p && *end == ',' && strncmp(end + 1, "nan", 3) == 0 && d > 0 && T > 0)
            status = unbracketed_pair(c, path, line, d, T);
    }
    fclose(f);
    return status;
}

/* The NaN cells of a 2-D vcrit.h5's /grid (its diameters x temperatures), refused; none without /grid. */
static int h5_unbracketed_pairs(const struct case_file *c, const char *path, hid_t file)
{
    size_t nd = 0, nt = 0, n = 0;
    if (!h5_exists(file, "grid") || h5_dataset_size(file, "grid/diameter", &nd) != SC_OK ||
        h5_dataset_size(file, "grid/temperature", &nt) != SC_OK || h5_dataset_size(file, "grid/v_crit", &n) != SC_OK ||
        n != nd * nt || n == 0)
        return SC_OK; /* no grid, or not one: the rows are checked as they are */
    double *values = malloc((n + nd + nt) * sizeof *values);
    if (!values)
        SC_FAIL_OOM((n + nd + nt) * sizeof *values, "the deposition table's grid");
    int status = SC_OK;
    if (h5_read_doubles(file, "grid/v_crit", values, n) == SC_OK &&
        h5_read_doubles(file, "grid/diameter", values + n, nd) == SC_OK &&
        h5_read_doubles(file, "grid/temperature", values + n + nd, nt) == SC_OK)
        for (size_t k = 0; k < n && status == SC_OK; k++)
            if (isnan(values[k]))
                status = unbracketed_pair(c, path, 0, values[n + k / nt], values[n + nd + k % nt]);
    free(values);
    return status;
}

/* HDF5 (`spraycoat vcrit`'s vcrit.h5): datasets /diameter and /v_crit of equal length, and /temperature of that
 * length too when it is there (a table over diameter and temperature). */
static int read_table_h5(const struct case_file *c, const char *path, struct vcrit_rows *rows)
{
    hid_t file;
    if (h5_open_read(path, &file) != SC_OK)
        return case_invalid(c, "deposition", "table", "%s", sc_error_message());
    size_t n = 0, n2 = 0, n3 = 0;
    double *column = NULL;
    int status, out_of_memory = 0;
    rows->width = h5_exists(file, "temperature") ? 3 : 2;
    SC_CHECK(status, h5_dataset_size(file, "diameter", &n), done);
    SC_CHECK(status, h5_dataset_size(file, "v_crit", &n2), done);
    if (rows->width == 3)
        SC_CHECK(status, h5_dataset_size(file, "temperature", &n3), done);
    if (n == 0 || n != n2 || (rows->width == 3 && n3 != n)) {
        status = SC_EINPUT;
        goto done;
    }
    rows->numbers = malloc(n * (size_t)rows->width * sizeof(double));
    column = malloc(n * sizeof(double));
    if (!rows->numbers || !column) {
        out_of_memory = 1;
        SC_FAIL_OOM_AT(status, done, 4 * n * sizeof(double), "the deposition table");
    }
    rows->count = n;
    static const char *const names2[] = {"diameter", "v_crit"}, *const names3[] = {"diameter", "temperature", "v_crit"};
    for (int k = 0; k < rows->width; k++) {
        SC_CHECK(status, h5_read_doubles(file, rows->width == 3 ? names3[k] : names2[k], column, n), done);
        for (size_t i = 0; i < n; i++)
            rows->numbers[(size_t)rows->width * i + (size_t)k] = column[i];
    }
    if (rows->width == 3)
        SC_CHECK(status, h5_unbracketed_pairs(c, path, file), refused);
done:
    free(column);
    H5Fclose(file);
    if (status != SC_OK && !out_of_memory)
        return case_invalid(c, "deposition", "table",
                            "%s: needs datasets /diameter and /v_crit (and /temperature, when given) of equal, "
                            "non-zero length",
                            path);
    SC_TRY(status);
    return SC_OK;
refused: /* the message is the refusal's */
    free(column);
    H5Fclose(file);
    return status;
}

static int read_table_csv(const struct case_file *c, const char *path, struct vcrit_rows *rows)
{
    /* diameter as [powder] d_max (1 nm to 1 m, as the particles CSV's d), v_crit as [deposition] critical_velocity (at
     * most 1e5 m/s), temperature as [material.NAME] T_initial (above 0 K, at most 1e5 K) */
    static const struct csv_column two[] = {{"diameter", CSV_NUMBER, 1e-9, 1, 0, "m", NULL},
                                            {"v_crit", CSV_NUMBER, 0, 1e5, 1, "m/s", NULL}};
    static const struct csv_column three[] = {{"diameter", CSV_NUMBER, 1e-9, 1, 0, "m", NULL},
                                              {"temperature", CSV_NUMBER, 0, 1e5, 1, "K", NULL},
                                              {"v_crit", CSV_NUMBER, 0, 1e5, 1, "m/s", NULL}};
    rows->width = csv_header_has(path, "temperature") ? 3 : 2;
    SC_TRY(read_csv_columns(c, "deposition", "table", path, rows->width == 3 ? three : two, rows->width,
                            CSV_OTHER_COLUMNS, &rows->numbers, &rows->count));
    return rows->width == 3 ? csv_unbracketed_pairs(c, path) : SC_OK;
}

static int compare_doubles(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

/* The distinct values of column `k` of the rows, ascending, into out (rows->count long); their number. */
static size_t distinct_values(const struct vcrit_rows *rows, int k, double *out)
{
    for (size_t i = 0; i < rows->count; i++)
        out[i] = rows->numbers[(size_t)rows->width * i + (size_t)k];
    qsort(out, rows->count, sizeof *out, compare_doubles);
    size_t n = 0;
    for (size_t i = 0; i < rows->count; i++)
        if (n == 0 || out[i] != out[n - 1])
            out[n++] = out[i];
    return n;
}

static size_t index_of(const double *values, size_t n, double x)
{
    size_t i = 0;
    while (i < n && values[i] != x)
        i++;
    return i;
}

/* Below this a v_crit table's temperature is more likely degrees Celsius than a powder's kelvin. */
#define TABLE_TEMPERATURE_DEGC_SUSPECT 200.0

/* 2-D: the rows must fill the grid of their distinct diameters x distinct temperatures, every cell exactly once. */
static int table_grid(const struct case_file *c, const char *path, const struct vcrit_rows *rows,
                      struct dem_config *cfg)
{
    size_t n = rows->count;
    cfg->table_diameter = malloc(n * sizeof(double));
    cfg->table_temperature = malloc(n * sizeof(double));
    if (!cfg->table_diameter || !cfg->table_temperature)
        SC_FAIL_OOM(2 * n * sizeof(double), "the deposition table");
    size_t nd = distinct_values(rows, 0, cfg->table_diameter), nt = distinct_values(rows, 1, cfg->table_temperature);
    cfg->table_count = nd;
    cfg->table_temperature_count = nt;
    /* the column is in kelvin; a table written in degC (25, 300, ...) would otherwise be read as cryogenic powder */
    if (cfg->table_temperature[0] < TABLE_TEMPERATURE_DEGC_SUSPECT)
        log_warn("[deposition] table = %s: its lowest temperature is %g K (the column is in kelvin; degrees "
                 "Celsius?)",
                 path, cfg->table_temperature[0]);
    if (nd * nt != n)
        return case_invalid(c, "deposition", "table",
                            "%s: %zu rows do not fill the grid of its %zu diameters x %zu temperatures (a table "
                            "v_crit(d, T) needs every pair once; `spraycoat vcrit` leaves out a pair it could "
                            "not bracket)",
                            path, n, nd, nt);
    cfg->table_velocity = malloc(n * sizeof(double));
    if (!cfg->table_velocity)
        SC_FAIL_OOM(n * sizeof(double), "the deposition table");
    for (size_t i = 0; i < n; i++)
        cfg->table_velocity[i] = NAN;
    for (size_t i = 0; i < n; i++) {
        const double *row = rows->numbers + 3 * i;
        size_t cell = index_of(cfg->table_diameter, nd, row[0]) * nt + index_of(cfg->table_temperature, nt, row[1]);
        if (!isnan(cfg->table_velocity[cell]))
            return case_invalid(c, "deposition", "table", "%s: row %zu: d = %g m, T = %g K is given twice", path, i + 1,
                                row[0], row[1]);
        cfg->table_velocity[cell] = row[2];
    }
    return SC_OK;
}

static int table_line(const struct case_file *c, const char *path, const struct vcrit_rows *rows,
                      struct dem_config *cfg)
{
    size_t n = rows->count;
    cfg->table_diameter = malloc(n * sizeof(double));
    cfg->table_velocity = malloc(n * sizeof(double));
    if (!cfg->table_diameter || !cfg->table_velocity)
        SC_FAIL_OOM(2 * n * sizeof(double), "the deposition table");
    cfg->table_count = n;
    for (size_t i = 0; i < n; i++) {
        cfg->table_diameter[i] = rows->numbers[2 * i];
        cfg->table_velocity[i] = rows->numbers[2 * i + 1];
    }
    for (size_t i = 1; i < n; i++)
        if (!(cfg->table_diameter[i] > cfg->table_diameter[i - 1]))
            return case_invalid(c, "deposition", "table", "%s: row %zu: diameters must be strictly increasing", path,
                                i + 1);
    return SC_OK;
}

/* The diameters of a table v_crit(d) without a v_crit: `spraycoat vcrit` writes a diameter it could not bracket
 * as a comment line "# d,nan,..." of vcrit.csv, and in vcrit.h5 only under /search/NNN (v_crit NaN), not in the
 * table.  The count, the first such diameter and its reason (vcrit.csv's text after the fields, vcrit.h5's
 * `result`). */
struct table_gaps {
    size_t count;
    double first;
    char reason[160];
};

static void csv_table_gaps(const char *path, struct table_gaps *gaps)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    char text[512];
    while (fgets(text, sizeof text, f)) {
        char *end;
        double d = text[0] == '#' ? strtod(text + 1, &end) : NAN;
        if (!(d > 0) || strncmp(end, ",nan", 4) != 0)
            continue;
        if (gaps->count++ == 0) {
            const char *why = strstr(end, "  ");
            gaps->first = d;
            snprintf(gaps->reason, sizeof gaps->reason, "%s", why ? why + 2 : "not bracketed");
            gaps->reason[strcspn(gaps->reason, "\r\n")] = '\0';
        }
    }
    fclose(f);
}

static void h5_table_gaps(const char *path, struct table_gaps *gaps)
{
    hid_t file;
    if (h5_open_read(path, &file) != SC_OK)
        return;
    hid_t group;
    for (size_t i = 0; h5_numbered_group(file, "search", i, &group); i++) {
        double d = NAN, v = NAN;
        char result[160] = "not bracketed";
        if (group >= 0 && h5_attr_read_double(group, "diameter", &d) == SC_OK &&
            h5_attr_read_double(group, "v_crit", &v) == SC_OK && isnan(v) && d > 0 && gaps->count++ == 0) {
            h5_attr_read_string(group, "result", result, sizeof result);
            gaps->first = d;
            snprintf(gaps->reason, sizeof gaps->reason, "%s", result);
        }
        if (group >= 0)
            H5Gclose(group);
    }
    H5Fclose(file);
    sc_error_clear();
}

/* A table v_crit(d) with diameters that have no v_crit is usable, but a particle of such a size takes a v_crit
 * interpolated between the table's neighbouring diameters (or its nearest one beyond its ends), which the search
 * found to be wrong there (bonded already at v_low, or never up to v_high): said once, not refused (a table
 * v_crit(d, T) with a gap is refused, table_grid). */
static void warn_table_gaps(const char *path, int h5)
{
    struct table_gaps gaps = {0};
    if (h5)
        h5_table_gaps(path, &gaps);
    else
        csv_table_gaps(path, &gaps);
    if (gaps.count > 0)
        log_warn("[deposition] table = %s: %zu diameter%s without a v_crit (first d = %g m: %s): particles of such "
                 "sizes take a v_crit interpolated between the table's neighbouring diameters, or its nearest one "
                 "beyond its ends; search them again with a wider [vcrit] v_low .. v_high",
                 path, gaps.count, gaps.count == 1 ? "" : "s", gaps.first, gaps.reason);
}

static int load_vcrit_table(const struct case_file *c, struct dem_config *cfg)
{
    char path[4096];
    if (!case_has(c, "deposition", "table"))
        return case_require(c, "deposition", "table", "rule = table");
    SC_TRY(case_path(c, "deposition", "table", path, sizeof path));
    size_t len = strlen(path);
    struct vcrit_rows rows = {0};
    int h5 = len > 3 && strcmp(path + len - 3, ".h5") == 0;
    int status = h5 ? read_table_h5(c, path, &rows) : read_table_csv(c, path, &rows);
    /* the HDF5 datasets are not range-checked by a CSV reader */
    for (size_t i = 0; i < rows.count && status == SC_OK; i++) {
        const double *row = rows.numbers + (size_t)rows.width * i;
        if (!(row[0] > 0) || !(row[rows.width - 1] > 0) || (rows.width == 3 && !(row[1] > 0)))
            status = case_invalid(c, "deposition", "table", "%s: row %zu: diameter, temperature and v_crit must be > 0",
                                  path, i + 1);
    }
    if (status == SC_OK)
        status = rows.width == 3 ? table_grid(c, path, &rows, cfg) : table_line(c, path, &rows, cfg);
    if (status == SC_OK && rows.width == 2)
        warn_table_gaps(path, h5);
    free(rows.numbers);
    return status;
}

static int load_deposition(const struct case_file *c, struct dem_config *cfg)
{
    cfg->alpha_adh = case_real(c, "deposition", "alpha_adh");
    cfg->de_size_classes = case_int(c, "deposition", "size_classes");
    cfg->de_angle_class_width = case_real(c, "deposition", "angle_class_width") * M_PI / 180.0;
    cfg->rule = case_is(c, "deposition", "rule", "adhesion")            ? DEM_DEPOSIT_ADHESION
                : case_is(c, "deposition", "rule", "critical_velocity") ? DEM_DEPOSIT_CRITICAL_VELOCITY
                : case_is(c, "deposition", "rule", "table")             ? DEM_DEPOSIT_TABLE
                                                                        : DEM_DEPOSIT_NONE;
    if (cfg->rule == DEM_DEPOSIT_CRITICAL_VELOCITY) {
        if (!case_has(c, "deposition", "critical_velocity"))
            return case_require(c, "deposition", "critical_velocity", "rule = critical_velocity");
        cfg->critical_velocity = case_real(c, "deposition", "critical_velocity");
    }
    if (cfg->rule == DEM_DEPOSIT_TABLE)
        SC_TRY(load_vcrit_table(c, cfg));
    return SC_OK;
}

/* The size range of the nozzle's table: the 0.1 % and 99.9 % quantiles of the size law (a single size: half to
 * twice it), or the particles file's smallest and largest. */
static void nozzle_size_range(const struct dem_config *cfg, double *d_small, double *d_large)
{
    const struct dem_size_distribution *sizes = &cfg->sizes;
    if (cfg->injection == DEM_INJECT_FILE && cfg->file_particle_count > 0) {
        *d_small = INFINITY, *d_large = 0.0;
        for (size_t i = 0; i < cfg->file_particle_count; i++) {
            *d_small = fmin(*d_small, cfg->file_particles[10 * i + 9]);
            *d_large = fmax(*d_large, cfg->file_particles[10 * i + 9]);
        }
    } else if (sizes->monodisperse) {
        *d_small = 0.5 * sizes->median_diameter, *d_large = 2.0 * sizes->median_diameter;
    } else {
        *d_small = dem_sizes_sample(sizes, 0.001), *d_large = dem_sizes_sample(sizes, 0.999);
    }
}

/* The free jet from the nozzle's exit state (docs/physics.md "Nozzle"), key by key unless given in [jet]: potential
 * core L = D_e (4.2 + 1.1 M_e^2) (Lau, Morris & Fisher 1979); C3 makes the Bickley profile's half-width
 * 0.88137 x^(2/3) / C3 at the core's end x_c = L + x0 the exit radius R_e, the width the model's jet then has over
 * the whole core (it holds the core's end profile there): a jet keeps about the nozzle's width until the lip's
 * mixing layer, centred near r = R_e, reaches the axis, which ends the core (a round jet's half-width S z, S =
 * 0.094 (Pope 2000, Table 5.2), is 0.8 R_e at the 4.2 D_e core of a subsonic jet); C1 makes its axis speed there
 * the exit velocity.  x0 = D_e / (2 S), where a round jet of half-width S (z + x0) has R_e at the exit, sets only
 * how the jet widens and slows beyond the core.  Gas density and kinematic viscosity of the exit's static state;
 * drag = auto is Henderson's, the nozzle's. */
#define ROUND_JET_SPREADING 0.094
static void map_jet(const struct case_file *c, const struct dem_nozzle *n, struct dem_gas_field *gas)
{
    const struct dem_nozzle_station *e = &n->exit;
    double exit_d = n->exit_diameter;
    if (!case_is_given(c, "jet", "core_length"))
        gas->core_length = exit_d * (4.2 + 1.1 * e->mach * e->mach);
    if (!case_is_given(c, "jet", "virtual_origin"))
        gas->virtual_origin = exit_d / (2.0 * ROUND_JET_SPREADING);
    double x_core = gas->core_length + gas->virtual_origin;
    if (!case_is_given(c, "jet", "C3"))
        gas->c3 = 0.88137358701954302523 * pow(x_core, 2.0 / 3.0) / (0.5 * exit_d);
    if (!case_is_given(c, "jet", "C1"))
        gas->c1 = e->velocity * cbrt(x_core);
    if (!case_is_given(c, "jet", "C2"))
        gas->c2 = gas->c1 / (3.0 * gas->c3);
    if (!case_is_given(c, "jet", "gas_density"))
        gas->density = e->density;
    if (!case_is_given(c, "jet", "gas_viscosity"))
        gas->kinematic_viscosity = dem_nozzle_viscosity(&n->properties, e->temperature) / e->density;
    /* the static exit state, for the bow shock (docs/physics.md "The bow shock at the target") */
    if (case_is(c, "jet", "drag", "auto")) /* the nozzle's own law: the slip is near Mach 1 after the exit */
        gas->drag = DEM_DRAG_HENDERSON;
    if (!case_is_given(c, "jet", "gas_temperature"))
        gas->gas_temperature = e->temperature;
    if (!case_is_given(c, "jet", "gas_gamma"))
        gas->gas_gamma = n->properties.gamma;
    if (!case_is_given(c, "jet", "gas_constant"))
        gas->gas_constant = n->properties.gas_constant;
    if (!case_is_given(c, "jet", "gas_sutherland"))
        gas->gas_sutherland = n->properties.sutherland;
}

/* The injection disc of radius nozzle_radius, the one the spray uses: [spray] nozzle_radius, or with [nozzle] and
 * nozzle_radius not given the exit's (from_exit; the messages name the key that gave it).  It holds the particles,
 * reaches no farther than the domain, and can hold a batch of feed_count particles side by side.  Placed at random,
 * discs cover at most 0.547 of a plane (the random sequential adsorption limit: Feder 1980, J. Theor. Biol. 87:237;
 * Hinrichsen, Feder & Jossang 1986, J. Stat. Phys. 44:793), so a batch of more particles of the median diameter
 * than that mostly cannot be placed: each then takes 1000 failed attempts (it took minutes in step 0, where no
 * signal is looked at). */
static int check_disc(const struct case_file *c, const struct dem_config *cfg, int from_exit)
{
    const char *section = from_exit ? "nozzle" : "spray", *key = from_exit ? "exit_diameter" : "nozzle_radius";
    const char *source = from_exit ? "[nozzle] exit_diameter / 2" : "[spray] nozzle_radius";
    double d_smallest = cfg->sizes.monodisperse ? cfg->sizes.median_diameter : cfg->sizes.d_min;
    if (d_smallest >= 2 * cfg->nozzle_radius)
        return case_invalid(c, section, key, "the nozzle disc (radius %g m) is smaller than the particles",
                            cfg->nozzle_radius);
    if (cfg->domain_radius <= cfg->nozzle_radius)
        return case_invalid(c, "spray", "domain_radius",
                            "not larger than the nozzle disc's radius %g m (%s); allowed: above %g m",
                            cfg->nozzle_radius, source, cfg->nozzle_radius);
    double typical = cfg->sizes.median_diameter, usable = cfg->nozzle_radius - 0.5 * d_smallest;
    double capacity = floor(0.547 * usable * usable / (0.25 * typical * typical));
    if ((double)cfg->feed_count > capacity)
        return case_invalid(c, "spray", "feed_count",
                            "%lld particles of the median diameter %g m do not fit side by side in the nozzle disc of "
                            "radius %g m (%s); allowed: at most %.0f (random packing covers 0.547 of the disc), or a "
                            "larger disc",
                            (long long)cfg->feed_count, typical, cfg->nozzle_radius, source, capacity);
    return SC_OK;
}

/* With [nozzle] the release speeds come from its table (release_speed_min/max are not used) and the injection disc
 * is the nozzle's exit unless [spray] nozzle_radius is given. */
static void nozzle_release(const struct case_file *c, struct dem_config *cfg)
{
    if (case_is_given(c, "spray", "release_speed_min") || case_is_given(c, "spray", "release_speed_max"))
        log_warn("[spray] release_speed_min/max are not used with [nozzle]: each particle leaves at the nozzle's "
                 "exit speed of its diameter");
    if (!case_is_given(c, "spray", "nozzle_radius") && cfg->injection == DEM_INJECT_STREAM)
        cfg->nozzle_radius = 0.5 * cfg->nozzle->exit_diameter;
}

static int load_nozzle(const struct case_file *c, struct dem_config *cfg)
{
    cfg->powder_temperature = case_real(c, "powder", "temperature");
    cfg->powder_specific_heat = case_real(c, "powder", "specific_heat");
    static const char *const required[] = {"stagnation_pressure", "stagnation_temperature", "throat_diameter",
                                           "exit_diameter",       "convergent_length",      "divergent_length"};
    int given = 0;
    for (size_t k = 0; k < sizeof required / sizeof *required; k++)
        given |= case_has(c, "nozzle", required[k]);
    if (!given)
        return SC_OK;
    for (size_t k = 0; k < sizeof required / sizeof *required; k++)
        if (!case_has(c, "nozzle", required[k]))
            return case_require(c, "nozzle", required[k], "a [nozzle] section");
    struct dem_nozzle *n = calloc(1, sizeof *n);
    if (!n)
        SC_FAIL_OOM(sizeof *n, "the nozzle");
    cfg->nozzle = n;
    n->enabled = 1;
    n->gas = case_is(c, "nozzle", "gas", "he")    ? DEM_NOZZLE_HE
             : case_is(c, "nozzle", "gas", "air") ? DEM_NOZZLE_AIR
                                                  : DEM_NOZZLE_N2;
    n->properties = *dem_nozzle_gas_properties(n->gas);
    n->stagnation_pressure = case_real(c, "nozzle", "stagnation_pressure");
    n->stagnation_temperature = case_real(c, "nozzle", "stagnation_temperature");
    n->throat_diameter = case_real(c, "nozzle", "throat_diameter");
    n->exit_diameter = case_real(c, "nozzle", "exit_diameter");
    n->inlet_diameter = case_is(c, "nozzle", "inlet_diameter", "auto") ? 3.0 * n->throat_diameter
                                                                       : case_real(c, "nozzle", "inlet_diameter");
    n->convergent_length = case_real(c, "nozzle", "convergent_length");
    n->divergent_length = case_real(c, "nozzle", "divergent_length");
    n->ambient_pressure = case_real(c, "nozzle", "ambient_pressure");
    n->particle_density = cfg->powder.density;
    n->particle_specific_heat = cfg->powder_specific_heat;
    n->particle_temperature = cfg->powder_temperature;
    if (n->exit_diameter < n->throat_diameter)
        return case_invalid(c, "nozzle", "exit_diameter", "below throat_diameter = %g m", n->throat_diameter);
    if (n->inlet_diameter <= n->throat_diameter)
        return case_invalid(c, "nozzle", "inlet_diameter", "not above throat_diameter = %g m", n->throat_diameter);
    double d_small, d_large;
    nozzle_size_range(cfg, &d_small, &d_large);
    int status = dem_nozzle_solve(n, d_small, d_large);
    if (status == SC_EINPUT) {
        char message[1024];
        snprintf(message, sizeof message, "%s", sc_error_message());
        return case_invalid(c, "nozzle", "ambient_pressure", "%s", message);
    }
    SC_TRY(status);
    int last = DEM_NOZZLE_TABLE_ROWS - 1;
    log_info("nozzle: %s, exit Mach %.3f, %.1f m/s, %.1f K, %.4g Pa; particles %.3g-%.3g um leave at %.1f-%.1f m/s "
             "and %.1f-%.1f K",
             n->properties.name, n->exit.mach, n->exit.velocity, n->exit.temperature, n->exit.pressure,
             n->table_diameter[0] * 1e6, n->table_diameter[last] * 1e6, n->table_velocity[0], n->table_velocity[last],
             n->table_temperature[0], n->table_temperature[last]);
    map_jet(c, n, &cfg->gas);
    dem_gas_set_wall(&cfg->gas, cfg->standoff);
    SC_TRY(check_jet(c, &cfg->gas));
    nozzle_release(c, cfg);
    return SC_OK;
}

/* [path] waypoints: t ascending (strictly) from 0. */
static int load_waypoints(const struct case_file *c, struct dem_path *path)
{
    static const struct csv_column columns[] = {
        {"t", CSV_NUMBER, 0, 1e4, 0, "s", NULL},
        {"x", CSV_NUMBER, -100, 100, 0, "m", NULL},
        {"y", CSV_NUMBER, -100, 100, 0, "m", NULL},
    };
    if (!case_has(c, "path", "waypoints"))
        return case_require(c, "path", "waypoints", "pattern = file");
    char file[4096];
    SC_TRY(case_path(c, "path", "waypoints", file, sizeof file));
    SC_TRY(read_csv_columns(c, "path", "waypoints", file, columns, 3, 0, &path->waypoints, &path->waypoint_count));
    if (path->waypoints[0] != 0.0)
        return case_invalid(c, "path", "waypoints", "%s: data row 1: t = %g s; allowed: the first waypoint at t = 0",
                            file, path->waypoints[0]);
    for (size_t i = 1; i < path->waypoint_count; i++)
        if (!(path->waypoints[3 * i] > path->waypoints[3 * (i - 1)]))
            return case_invalid(
                c, "path", "waypoints",
                "%s: data row %zu: t = %g s not after the row before (%g s); allowed: t strictly ascending", file,
                i + 1, path->waypoints[3 * i], path->waypoints[3 * (i - 1)]);
    /* the jet is taken as quasi-steady about the moving nozzle: at most traverse_speed's limit between waypoints */
    for (size_t i = 1; i < path->waypoint_count; i++) {
        const double *a = path->waypoints + 3 * (i - 1), *b = path->waypoints + 3 * i;
        double speed = hypot(b[1] - a[1], b[2] - a[2]) / (b[0] - a[0]);
        if (speed > 100.0)
            return case_invalid(c, "path", "waypoints",
                                "%s: data rows %zu-%zu: the nozzle moves at %g m/s; allowed: at most 100 m/s, as "
                                "traverse_speed (far below the gas speed: the jet is quasi-steady)",
                                file, i, i + 1, speed);
    }
    return SC_OK;
}

/* A stream fed on its own schedule (a batch of feed_count every feed_every steps from step 0 up to max_injected) and
 * a nozzle on its path are two clocks: a feed that outlasts the path releases its last particles from the nozzle
 * parked at the path's end, into the track's profile (a review: the Al6061 case fed 20 % of its powder there), and a
 * feed that stops first leaves the end of the path bare.  Either is warned of, with the times. */
static void warn_feed_against_path(const struct dem_config *cfg)
{
    const struct dem_path *path = &cfg->path;
    double duration = dem_path_duration(path);
    if (path->pattern == DEM_PATH_NONE || cfg->injection != DEM_INJECT_STREAM || duration > cfg->t_end)
        return; /* no path, or the run ends before it does (warned of above) */
    double interval = (double)cfg->feed_every * cfg->dt;
    /* the batches: at the starts of steps 0, feed_every, ... of the run's steps (dem_total_steps), up to
     * max_injected; those fed by the path's end */
    long batches = (cfg->max_injected + cfg->feed_count - 1) / cfg->feed_count;
    double steps = ceil(cfg->t_end / cfg->dt * (1.0 - 1e-12));
    long in_run = (long)fmin((double)batches, floor((steps - 1.0) / (double)cfg->feed_every) + 1.0);
    long on_path = (long)fmin((double)in_run, floor(duration / interval * (1.0 + 1e-12)) + 1.0);
    double last = (double)(in_run - 1) * interval;
    if (in_run > on_path) {
        long fed = (long)fmin((double)cfg->max_injected, (double)in_run * (double)cfg->feed_count);
        log_warn("[spray]: the powder is fed until t = %.4g s (%ld every %ld steps, max_injected = %ld, t_end = "
                 "%.4g s), after the nozzle's path ends at %.4g s: %ld particles leave the nozzle parked at the path's "
                 "end, and the deposit and the track's profile take them in; a smaller max_injected ends the feed with "
                 "the path",
                 last, cfg->feed_count, cfg->feed_every, cfg->max_injected, cfg->t_end, duration,
                 fed - on_path * cfg->feed_count);
    } else if (in_run == batches && last + interval < duration * (1.0 - 1e-9)) {
        log_warn("[spray]: the powder runs out at t = %.4g s (max_injected = %ld), before the nozzle's path ends at "
                 "%.4g s: the rest of the path sprays nothing, and the track's profile and thickness are those of the "
                 "part sprayed",
                 last, cfg->max_injected, duration);
    }
}

static int load_path(const struct case_file *c, struct dem_config *cfg)
{
    struct dem_path *path = &cfg->path;
    path->pattern = case_is(c, "path", "pattern", "line")     ? DEM_PATH_LINE
                    : case_is(c, "path", "pattern", "raster") ? DEM_PATH_RASTER
                    : case_is(c, "path", "pattern", "file")   ? DEM_PATH_FILE
                                                              : DEM_PATH_NONE;
    path->traverse_speed = case_real(c, "path", "traverse_speed");
    path->start_x = case_real(c, "path", "start_x");
    path->start_y = case_real(c, "path", "start_y");
    path->pass_length = case_real(c, "path", "pass_length");
    path->step_over = case_real(c, "path", "step_over");
    path->passes = case_int(c, "path", "passes");
    path->packing = case_real(c, "path", "packing");
    path->map_cell = case_is(c, "path", "map_cell", "auto") ? fmax(cfg->nozzle_radius / 8.0, cfg->sizes.median_diameter)
                                                            : case_real(c, "path", "map_cell");
    if (path->pattern == DEM_PATH_FILE)
        SC_TRY(load_waypoints(c, path));
    if (path->pattern == DEM_PATH_RASTER && path->passes > 1 && !(path->step_over > 0.0))
        return case_invalid(c, "path", "step_over",
                            "0 m with %ld passes: the passes would lie on each other (use "
                            "pattern = line for that)",
                            path->passes);
    /* the profile averages the middle half of the pass and the thickness is the coating's after every pass: a run
     * that ends first reports those of a part of the path, which the numbers alone do not show */
    if (path->pattern != DEM_PATH_NONE && dem_path_duration(path) > cfg->t_end)
        log_warn(
            "[path]: the nozzle takes %.4g s over its path, longer than [spray] t_end = %.4g s: the run ends before "
            "the path does, and the deposit's thickness and track profile are those of the part sprayed",
            dem_path_duration(path), cfg->t_end);
    warn_feed_against_path(cfg);
    return SC_OK;
}

static int load_all(const struct case_file *c, struct dem_config *cfg)
{
    struct run_settings run;
    run_settings_load(c, &run);
    cfg->seed = run.seed;
    cfg->threads = run.threads;
    SC_TRY(load_spray(c, cfg));
    SC_TRY(load_powder(c, cfg));
    SC_TRY(load_target(c, cfg));
    load_contact_and_jet(c, cfg);
    SC_TRY(check_jet(c, &cfg->gas));
    if (cfg->injection == DEM_INJECT_FILE)
        SC_TRY(load_particles_file(c, cfg));
    SC_TRY(load_deposition(c, cfg));
    SC_TRY(load_nozzle(c, cfg));
    /* the disc the spray injects over: with [nozzle] and no nozzle_radius the exit's (load_nozzle set it) */
    if (cfg->injection == DEM_INJECT_STREAM)
        SC_TRY(check_disc(c, cfg, cfg->nozzle && !case_is_given(c, "spray", "nozzle_radius")));
    SC_TRY(load_path(c, cfg));
    return SC_OK;
}

int dem_config_load(const struct case_file *c, struct dem_config *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    int status = load_all(c, cfg);
    if (status != SC_OK)
        dem_config_free(cfg);
    SC_TRY(status);
    return SC_OK;
}

void dem_config_free(struct dem_config *cfg)
{
    free(cfg->file_particles);
    free(cfg->table_diameter);
    free(cfg->table_velocity);
    free(cfg->nozzle);
    cfg->nozzle = NULL;
    free(cfg->table_temperature);
    cfg->file_particles = cfg->table_diameter = cfg->table_velocity = cfg->table_temperature = NULL;
    cfg->file_particle_count = cfg->table_count = cfg->table_temperature_count = 0;
    free(cfg->path.waypoints);
    cfg->path.waypoints = NULL;
    cfg->path.waypoint_count = 0;
}
