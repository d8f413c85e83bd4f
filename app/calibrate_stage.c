/* `spraycoat calibrate`: the bonding calibration of Tang (2021), Sections 4.1.2 and 5.1.
 *
 * Over a grid of the bonding model's two parameters (energy: Gc, Gc_rate; strain: eps_c, eps_rate_c; the record's
 * fields Gc and Gc_rate hold them), single-particle impacts of each size of
 * [calibrate] at its experimental critical velocity (Tang: 14 um at 810 m/s, 30 um at 770 m/s, measured by
 * Hassani-Gangaraj et al. 2018, the thesis's [9]; substrates 30 and 50 um across).  Each run is classified by the
 * impact stage's verdict (mpm_verdicts): bonded (1) or rebounded (0), or with [calibrate] outcome = adhered bonded or
 * held (1) or left (0); a verdict that has not settled is neither, left out of the fit and counted, and so is a run
 * that failed as a simulation (NaN or blow-up: recorded as failed, never repeated, it stops no other run).  Per size, a
 * second-order logistic regression of the outcomes on the scaled parameters (Eqs. 4.10-4.14, core/logistic.h) gives the
 * bonding boundary h = 0.5 (Z = 0); the intersection of the first two sizes' boundaries is the calibrated pair: the
 * parameters at which both sizes just bond at their critical velocity. With reference_diameter each size's run is
 * [impact] scaled to its diameter (mpm_config_scale_lengths): the same cells per diameter for both sizes.
 *
 * Runs are recorded and shared among MPI ranks exactly as vcrit's (struct vcrit_runs, RUN_DIR/calibrate_runs.csv):
 * an interrupted calibration continues with `spraycoat resume RUN_DIR` without repeating a finished run, a refined
 * grid run into the same RUN_DIR reuses the runs it shares (runs_hash: the record is kept), and rank 0
 * fits and writes RUN_DIR/calibrate.csv, calibrate_outcomes.csv and calibrate.h5 (docs/files.md). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/logistic.h"
#include "core/parallel.h"
#include "core/run_keys.h"
#include "app/app.h"
#include "mpm/mpm.h"

#define STAGE                    "calibrate"
#define CALIBRATE_FORMAT         "spraycoat-calibrate"
#define CALIBRATE_FORMAT_VERSION 1
#define MAX_SIZES                4
#define BOUNDARY_SAMPLES         401 /* x1 values at which the boundary Z = 0 is solved for x2 */
#define MAX_CROSSINGS            8
#define BRANCHES                 4 /* two roots, solved for x2 and for x1 */

const struct cfg_key calibrate_case_keys[] = {
    {"calibrate", "diameters", CFG_STRING, "m", "14e-6,30e-6", 0, 0, 0, NULL,
     "comma-separated particle diameters of the calibration (Tang Section 4.1.2: 14 and 30 um); the first two "
     "sizes' boundaries intersect in the calibrated parameters"},
    {"calibrate", "velocities", CFG_STRING, "m/s", "810,770", 0, 0, 0, NULL,
     "impact speed of each diameter: its experimental critical velocity (Tang Section 4.1.2 after Hassani-Gangaraj et "
     "al. 2018: "
     "810 and 770 m/s)"},
    {"calibrate", "substrate_diameters", CFG_STRING, "m", "30e-6,50e-6", 0, 0, 0, NULL,
     "substrate diameter of each particle diameter (Tang Section 4.1.2: 30 and 50 um; height from [impact])"},
    {"calibrate", "Gc_min", CFG_REAL, "J/m2", "500", 0, 1e9, CFG_MIN_EXCLUSIVE, NULL, "lowest Gc of the grid"},
    {"calibrate", "Gc_max", CFG_REAL, "J/m2", "3000", 0, 1e9, CFG_MIN_EXCLUSIVE, NULL,
     "highest Gc of the grid (>= Gc_min)"},
    {"calibrate", "Gc_count", CFG_INT, "-", "6", 1, 100, 0, NULL, "Gc values, evenly spaced from Gc_min to Gc_max"},
    {"calibrate", "Gc_rate_min", CFG_REAL, "J/m2/s", "5e10", 0, 1e30, CFG_MIN_EXCLUSIVE, NULL,
     "lowest Gc_rate of the grid"},
    {"calibrate", "Gc_rate_max", CFG_REAL, "J/m2/s", "5e11", 0, 1e30, CFG_MIN_EXCLUSIVE, NULL,
     "highest Gc_rate of the grid (>= Gc_rate_min)"},
    {"calibrate", "Gc_rate_count", CFG_INT, "-", "6", 1, 100, 0, NULL,
     "Gc_rate values, evenly spaced from Gc_rate_min to Gc_rate_max"},
    {"calibrate", "eps_c_min", CFG_REAL, "-", "0.1", 0, 1e3, CFG_MIN_EXCLUSIVE, NULL,
     "lowest eps_c of the grid ([impact] bonding = strain)"},
    {"calibrate", "eps_c_max", CFG_REAL, "-", "0.6", 0, 1e3, CFG_MIN_EXCLUSIVE, NULL,
     "highest eps_c of the grid (>= eps_c_min)"},
    {"calibrate", "eps_c_count", CFG_INT, "-", "6", 1, 100, 0, NULL,
     "eps_c values, evenly spaced from eps_c_min to eps_c_max"},
    {"calibrate", "eps_rate_c_min", CFG_REAL, "1/s", "2e8", 0, 1e20, CFG_MIN_EXCLUSIVE, NULL,
     "lowest eps_rate_c of the grid ([impact] bonding = strain)"},
    {"calibrate", "eps_rate_c_max", CFG_REAL, "1/s", "5e9", 0, 1e20, CFG_MIN_EXCLUSIVE, NULL,
     "highest eps_rate_c of the grid (>= eps_rate_c_min)"},
    {"calibrate", "eps_rate_c_count", CFG_INT, "-", "6", 1, 100, 0, NULL,
     "eps_rate_c values, evenly spaced from eps_rate_c_min to eps_rate_c_max"},
    {"calibrate", "rate_axis", CFG_CHOICE, "", "linear", 0, 0, 0, "linear|log",
     "spacing of the second parameter's values (Gc_rate, eps_rate_c) and the scale the fit sees it on: linear, or "
     "log (even in its logarithm: the rate enters the bonding laws as ln(rate / critical rate), Eqs. 4.4, 4.16b)"},
    {"calibrate", "reference_diameter", CFG_REAL, "m", "0", 0, 1, 0, NULL,
     "0: every run on the grid and substrate_diameters of [impact]; > 0: [impact] describes a particle of this "
     "diameter and each size's run is it scaled by d / reference_diameter (grid, spacing, substrate, times: the same "
     "cells per diameter, docs/physics.md \"Resolution in cells per diameter\"); substrate_diameters is then not "
     "used"},
    {"calibrate", "ridge", CFG_REAL, "-", "1e-3", 0, 1e6, 0, NULL,
     "ridge term lambda of the logistic fit in the scaled parameters (0: plain maximum likelihood, which has no "
     "finite solution when the outcomes are separable, as a deterministic grid's often are; then lambda places the "
     "boundary in the gap between grid points, and the outputs say so)"},
    {"calibrate", "outcome", CFG_CHOICE, "", "bonded", 0, 0, 0, "bonded|adhered",
     "each run is classified by this outcome (y = 1) or not; " VCRIT_OUTCOME_DOC},
    {"calibrate", "method", CFG_CHOICE, "", "boundaries", 0, 0, 0, "boundaries|vcrit",
     "boundaries: Tang's calibration, the intersection of the sizes' bonding boundaries over the grid of both "
     "parameters; vcrit: the first parameter (Gc or eps_c, between its _min and _max) at which the critical "
     "velocities of `spraycoat vcrit` searches of the diameters meet velocities on average, the second kept at its "
     "[impact] value ([vcrit] keys for the searches; docs/physics.md \"Calibrated on v_crit\")"},
    {"calibrate", "fit_tolerance", CFG_REAL, "m/s", "5", 0, 1e4, CFG_MIN_EXCLUSIVE, NULL,
     "method = vcrit: the mean of v_crit - velocity over the sizes accepted as zero"},
    {"calibrate", "fit_bracket", CFG_REAL, "-", "0.005", 0, 1, CFG_MIN_EXCLUSIVE, NULL,
     "method = vcrit: a bracket of the parameter narrower than this fraction of its middle ends the search there "
     "(the mean residual jumps across zero: single verdicts near v_crit are discrete); its middle is the value"},
    {"calibrate", "fit_evaluations", CFG_INT, "-", "8", 3, 50, 0, NULL,
     "method = vcrit: at most this many v_crit searches (the two ends of the range first, then false position)"},
    {"calibrate", "rate", CFG_CHOICE, "", "kept", 0, 0, 0, "kept|fitted",
     "method = vcrit: kept: the second parameter (Gc_rate, eps_rate_c) stays at its [impact] value; fitted: it is "
     "fitted too, between its _min and _max (false position in its logarithm), so that v_crit of the first diameter "
     "minus that of the last meets the difference of their velocities within fit_spread_tolerance, the first "
     "parameter fitted anew at each of its values (docs/physics.md \"Calibrated on v_crit\")"},
    {"calibrate", "fit_spread_tolerance", CFG_REAL, "m/s", "10", 0, 1e4, CFG_MIN_EXCLUSIVE, NULL,
     "method = vcrit, rate = fitted: the spread residual, (v_crit of the first diameter - of the last) - (their "
     "velocities' difference), accepted as zero"},
    {"calibrate", "fit_rate_evaluations", CFG_INT, "-", "6", 2, 12, 0, NULL,
     "method = vcrit, rate = fitted: at most this many fits of the first parameter (the ends of the second's range "
     "first, then false position); with fit_evaluations searches each at most 100 searches in all"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

/* The two parameters a bonding model is calibrated in: the critical value and the critical rate (Eqs. 4.4, 4.16b). */
struct bonding_axes {
    const char *model, *name[2], *unit[2];
};
static const struct bonding_axes energy_axes = {"energy", {"Gc", "Gc_rate"}, {"J/m2", "J/m2/s"}};
static const struct bonding_axes strain_axes = {"strain", {"eps_c", "eps_rate_c"}, {"-", "1/s"}};

struct calibrate_size {
    double diameter, velocity, substrate;
    int counts[4];           /* as the fit counted the runs (enum vcrit_verdict): not, the outcome, unsettled, failed */
    struct logistic_fit fit; /* valid when fitted */
    int fitted;
    double *boundary; /* first then second parameter: BRANCHES x (BOUNDARY_SAMPLES + 1), a NaN gap after each */
    size_t boundary_count;
    char note[200]; /* "" when fitted to outcomes that overlap; else why not (also when separable and fitted) */
};

struct calibrate {
    const struct case_file *c;
    const char *run_dir;
    uint64_t case_hash;
    int size_count, gc_count, rate_count;
    const struct bonding_axes *axes; /* gc_*: its first parameter, rate_*: its second */
    double gc_min, gc_max, rate_min, rate_max, ridge, angle;
    double reference;           /* [calibrate] reference_diameter: 0, or the diameter [impact]'s lengths are for */
    int rate_log;               /* [calibrate] rate_axis = log: the second parameter's axis in its logarithm */
    enum vcrit_outcome outcome; /* [calibrate] outcome: what counts as y = 1 */
    double vrest_threshold;     /* [impact] vrest_threshold: at rest on the substrate (held) within it */
    struct calibrate_size sizes[MAX_SIZES];
    struct vcrit_runs runs;
    struct vcrit_run_record *outcomes;   /* one per task, in task order */
    double crossings[2 * MAX_CROSSINGS]; /* parameter pairs, the chosen first */
    int crossing_count;
};

/* ---- the settings ------------------------------------------------------------------------------------------- */

static int parse_sizes(const struct case_file *c, struct calibrate *k)
{
    double d[MAX_SIZES], v[MAX_SIZES], s[MAX_SIZES];
    int nd, nv, ns;
    SC_TRY(vcrit_runs_parse_list(c, STAGE, "diameters", 1.0, "m", d, MAX_SIZES, &nd));
    SC_TRY(vcrit_runs_parse_list(c, STAGE, "velocities", 1e5, "m/s", v, MAX_SIZES, &nv));
    SC_TRY(vcrit_runs_parse_list(c, STAGE, "substrate_diameters", 1.0, "m", s, MAX_SIZES, &ns));
    if (nd == 0)
        return case_invalid(c, STAGE, "diameters", "no diameter given");
    if (nv != nd)
        return case_invalid(c, STAGE, "velocities", "%d speeds for %d diameters; allowed: one per diameter", nv, nd);
    if (ns != nd && !(case_real(c, STAGE, "reference_diameter") > 0))
        return case_invalid(c, STAGE, "substrate_diameters", "%d values for %d diameters; allowed: one per diameter",
                            ns, nd);
    k->size_count = nd;
    for (int i = 0; i < nd; i++)
        k->sizes[i] = (struct calibrate_size){.diameter = d[i], .velocity = v[i], .substrate = i < ns ? s[i] : NAN};
    return SC_OK;
}

/* [calibrate] NAME_suffix of the axis's parameter NAME. */
static const char *axis_key(const struct bonding_axes *axes, int axis, const char *suffix, char *key, size_t size)
{
    snprintf(key, size, "%s_%s", axes->name[axis], suffix);
    return key;
}

static int load_axis(const struct case_file *c, const struct bonding_axes *axes, int axis, double *min, double *max,
                     int *count)
{
    char key_min[32], key_max[32], key_count[32];
    const char *name = axes->name[axis], *unit = axes->unit[axis];
    *min = case_real(c, STAGE, axis_key(axes, axis, "min", key_min, sizeof key_min));
    *max = case_real(c, STAGE, axis_key(axes, axis, "max", key_max, sizeof key_max));
    *count = (int)case_int(c, STAGE, axis_key(axes, axis, "count", key_count, sizeof key_count));
    if (*max < *min)
        return case_invalid(c, STAGE, key_max, "below %s = %g %s", key_min, *min, unit);
    if ((*count > 1) != (*max > *min))
        return case_invalid(c, STAGE, key_count,
                            "%d values between %g and %g %s; allowed: 1 when %s_min = %s_max, else at least 2", *count,
                            *min, *max, unit, name, name);
    return SC_OK;
}

static int load_grid(const struct case_file *c, struct calibrate *k)
{
    if (case_is(c, "impact", "bonding", "none"))
        return case_invalid(c, "impact", "bonding",
                            "is none: calibrate varies a bonding model's parameters; allowed: energy, strain");
    k->axes = case_is(c, "impact", "bonding", "strain") ? &strain_axes : &energy_axes;
    SC_TRY(load_axis(c, k->axes, 0, &k->gc_min, &k->gc_max, &k->gc_count));
    SC_TRY(load_axis(c, k->axes, 1, &k->rate_min, &k->rate_max, &k->rate_count));
    k->ridge = case_real(c, STAGE, "ridge");
    k->outcome = vcrit_runs_outcome_of(c, STAGE);
    k->vrest_threshold = case_real(c, "impact", "vrest_threshold");
    k->reference = case_real(c, STAGE, "reference_diameter");
    k->rate_log = case_is(c, STAGE, "rate_axis", "log");
    if (k->reference > 0 && case_is_given(c, STAGE, "substrate_diameters"))
        return case_invalid(c, STAGE, "substrate_diameters",
                            "is not used with reference_diameter (each substrate is [impact]'s, scaled); remove one "
                            "of the two");
    return SC_OK;
}

static int task_count(const struct calibrate *k)
{
    return k->size_count * k->gc_count * k->rate_count;
}

static double grid_value(double min, double max, int count, int i)
{
    return count > 1 ? min + (max - min) * i / (count - 1.0) : min;
}

/* The second parameter's axis: linear, or in its logarithm (rate_axis = log). */
static double axis_in(const struct calibrate *k, double value)
{
    return k->rate_log ? log(value) : value;
}

static double axis_out(const struct calibrate *k, double value)
{
    return k->rate_log ? exp(value) : value;
}

static double rate_value(const struct calibrate *k, int i)
{
    if (!k->rate_log || i == 0)
        return grid_value(k->rate_min, k->rate_max, k->rate_count, i); /* the ends exactly as given */
    if (i == k->rate_count - 1)
        return k->rate_max;
    return axis_out(k, grid_value(axis_in(k, k->rate_min), axis_in(k, k->rate_max), k->rate_count, i));
}

/* Task t: size t / (count of the first parameter x count of the second), then the first, then the second. */
static struct vcrit_run_record task_run(const struct calibrate *k, int t)
{
    int per_size = k->gc_count * k->rate_count, i = t / per_size, g = (t % per_size) / k->rate_count,
        r = t % k->rate_count;
    return (struct vcrit_run_record){.diameter = k->sizes[i].diameter,
                                     .velocity = k->sizes[i].velocity,
                                     .Gc = grid_value(k->gc_min, k->gc_max, k->gc_count, g),
                                     .Gc_rate = rate_value(k, r)};
}

/* The impact set-up of task t: [impact] (scaled to the size with reference_diameter, else with the size's substrate
 * diameter) with one sphere of the size at its speed and the task's two bonding parameters. */
static int make_config(const struct calibrate *k, int t, struct mpm_config *cfg)
{
    struct vcrit_run_record run = task_run(k, t);
    const struct calibrate_size *size = &k->sizes[t / (k->gc_count * k->rate_count)];
    SC_TRY(mpm_config_load(k->c, cfg));
    if (k->reference > 0)
        mpm_config_scale_lengths(cfg, size->diameter / k->reference);
    else
        for (int b = 0; b < cfg->body_count; b++)
            if (cfg->bodies[b].substrate)
                cfg->bodies[b].d = size->substrate;
    if (k->axes == &strain_axes) {
        cfg->eps_c = run.Gc;
        cfg->eps_rate_c = run.Gc_rate;
    } else {
        cfg->Gc = run.Gc;
        cfg->Gc_rate = run.Gc_rate;
    }
    int status = mpm_config_single_particle(cfg, run.diameter, run.velocity, k->angle);
    if (status != SC_OK)
        mpm_config_free(cfg);
    return status;
}

static int load_settings(const struct case_file *c, struct calibrate *k)
{
    SC_TRY(parse_sizes(c, k));
    SC_TRY(load_grid(c, k));
    if (case_is(c, STAGE, "rate", "fitted")) /* method = boundaries spans the second parameter in its grid */
        return case_invalid(c, STAGE, "rate",
                            "only method = vcrit fits the rate; allowed with method = boundaries: kept");
    k->angle = case_real(c, "impact", "angle") * M_PI / 180.0;
    if (case_has(c, "impact", "bodies"))
        return case_invalid(c, "impact", "bodies",
                            "calibrate runs single particles ([impact] material, the sizes of "
                            "[calibrate]); remove bodies from the case");
    for (int i = 0; i < k->size_count; i++) {
        struct mpm_config cfg;
        SC_TRY(make_config(k, i * k->gc_count * k->rate_count, &cfg));
        double spacing = cfg.spacing;
        for (int b = 0; b < cfg.body_count; b++)
            if (cfg.bodies[b].substrate)
                k->sizes[i].substrate = cfg.bodies[b].d; /* scaled with reference_diameter */
        mpm_config_free(&cfg);
        if (k->sizes[i].diameter < 2.0 * spacing)
            return case_invalid(c, STAGE, "diameters", "%g m is less than two point spacings ([impact] spacing = %g m)",
                                k->sizes[i].diameter, spacing);
        /* the substrate too (without reference_diameter, the case's own): it passed check and the run failed with
         * "body 0 holds no material point", naming no key (a review) */
        if (k->sizes[i].substrate < 2.0 * spacing)
            return case_invalid(c, STAGE, k->reference > 0 ? "reference_diameter" : "substrate_diameters",
                                "the substrate of the %g m particle is %g m across, less than two point spacings "
                                "([impact] spacing = %g m); allowed: at least %g m",
                                k->sizes[i].diameter, k->sizes[i].substrate, spacing, 2.0 * spacing);
    }
    return SC_OK;
}

/* ---- the runs ----------------------------------------------------------------------------------------------- */

static int task_outcome(struct calibrate *k, int t)
{
    struct vcrit_run_record run = task_run(k, t);
    struct mpm_config cfg;
    SC_TRY(make_config(k, t, &cfg));
    int status = vcrit_runs_outcome(&k->runs, &cfg, &run);
    mpm_config_free(&cfg);
    SC_TRY(status);
    k->outcomes[t] = run;
    return SC_OK;
}

/* Every rank takes the next run not yet taken. */
static int runs_shared(struct calibrate *k)
{
    int status = vcrit_runs_load(&k->runs);
    if (status != SC_OK)
        sc_error_trace(__FILE__, __LINE__);
    else if (k->runs.count > 0)
        log_info("calibrate: %zu runs recorded in %s are reused", k->runs.count, k->run_dir);
    /* every rank takes part in the task counter even after a failure here (no early return) */
    parallel_tasks_begin();
    for (int64_t t; status == SC_OK && (t = parallel_task_next()) < task_count(k);)
        if ((status = task_outcome(k, (int)t)) != SC_OK)
            sc_error_trace(__FILE__, __LINE__);
    parallel_tasks_end();
    return status;
}

/* ---- the fit ------------------------------------------------------------------------------------------------ */

/* The parameters scaled to [0, 1] over the grid (a conditioned Hessian; the ridge term acts on these). */
static double scaled(double value, double min, double max)
{
    return max > min ? (value - min) / (max - min) : 0.0;
}

static double unscaled(double x, double min, double max)
{
    return max > min ? min + x * (max - min) : min;
}

/* The second parameter scaled to [0, 1] over the grid on its axis, and back. */
static double rate_scaled(const struct calibrate *k, double value)
{
    return scaled(axis_in(k, value), axis_in(k, k->rate_min), axis_in(k, k->rate_max));
}

static double rate_unscaled(const struct calibrate *k, double x)
{
    return axis_out(k, unscaled(x, axis_in(k, k->rate_min), axis_in(k, k->rate_max)));
}

/* A point of the boundary Z(x1, x2) = 0 in [0, 1]^2: branch b = 2 axis + sign.  axis 0: x1 = t and x2 the root
 * (sign 0: -, 1: +) of the quadratic in x2; axis 1: x2 = t and x1 the root.  Both, so that a boundary steep in
 * either direction is found.  0 when there is no root in [0, 1]. */
static int boundary_point(const double *theta, int b, double t, double *x1, double *x2)
{
    int axis = b / 2, sign = b % 2;
    double a = axis ? theta[3] : theta[5], lin = axis ? theta[1] + theta[4] * t : theta[2] + theta[4] * t,
           c = axis ? theta[0] + theta[2] * t + theta[5] * t * t : theta[0] + theta[1] * t + theta[3] * t * t, root;
    if (fabs(a) <= 1e-12 * (fabs(lin) + fabs(c))) {
        if (sign == 1 || lin == 0)
            return 0;
        root = -c / lin;
    } else {
        double disc = lin * lin - 4 * a * c;
        if (disc < 0)
            return 0;
        root = (-lin + (sign ? 1 : -1) * sqrt(disc)) / (2 * a);
    }
    if (!(root >= -1e-9 && root <= 1 + 1e-9))
        return 0;
    *x1 = axis ? root : t;
    *x2 = axis ? t : root;
    return 1;
}

/* The boundary h = 0.5 of a fitted size in the two parameters: the four branches over the grid, a NaN gap after
 * each. */
static int sample_boundary(const struct calibrate *k, struct calibrate_size *size)
{
    size_t n = BRANCHES * (BOUNDARY_SAMPLES + 1);
    SC_TRY(sc_calloc(&size->boundary, 2 * n, sizeof *size->boundary, "the bonding boundary"));
    double *gc = size->boundary, *rate = size->boundary + n;
    for (int b = 0; b < BRANCHES; b++) {
        for (int i = 0; i < BOUNDARY_SAMPLES; i++) {
            size_t at = (size_t)b * (BOUNDARY_SAMPLES + 1) + (size_t)i;
            double x1, x2;
            int on = boundary_point(size->fit.theta, b, i / (BOUNDARY_SAMPLES - 1.0), &x1, &x2);
            gc[at] = on ? unscaled(x1, k->gc_min, k->gc_max) : NAN;
            rate[at] = on ? rate_unscaled(k, x2) : NAN;
        }
        gc[(size_t)b * (BOUNDARY_SAMPLES + 1) + BOUNDARY_SAMPLES] = NAN;
        rate[(size_t)b * (BOUNDARY_SAMPLES + 1) + BOUNDARY_SAMPLES] = NAN;
    }
    size->boundary_count = n;
    return SC_OK;
}

/* How the fit counts run r (enum vcrit_verdict): the outcome (VCRIT_BONDED), not (VCRIT_REBOUNDED), unsettled, or
 * failed as a simulation; the last two are left out of the fit and counted apart. */
static int counted_as(const struct calibrate *k, const struct vcrit_run_record *r)
{
    if (r->verdict == VCRIT_FAILED)
        return VCRIT_FAILED;
    int success = vcrit_runs_succeeds(r, k->outcome, k->vrest_threshold);
    return success < 0 ? VCRIT_UNSETTLED : success ? VCRIT_BONDED : VCRIT_REBOUNDED;
}

/* The outcomes of one size as rows of Eq. 4.12 (unsettled and failed ones left out) and the fit. */
static int fit_outcomes(const struct calibrate *k, int index, struct calibrate_size *size, double *X, int *y)
{
    int per_size = k->gc_count * k->rate_count, m = 0;
    for (int t = index * per_size; t < (index + 1) * per_size; t++) {
        const struct vcrit_run_record *r = &k->outcomes[t];
        int verdict = counted_as(k, r);
        size->counts[verdict]++;
        if (verdict == VCRIT_UNSETTLED || verdict == VCRIT_FAILED)
            continue;
        logistic_quadratic_terms(scaled(r->Gc, k->gc_min, k->gc_max), rate_scaled(k, r->Gc_rate), X + 6 * m);
        y[m++] = verdict == VCRIT_BONDED;
    }
    if (size->counts[VCRIT_BONDED] == 0 || size->counts[VCRIT_REBOUNDED] == 0) {
        int adhered = k->outcome == VCRIT_OUTCOME_ADHERED;
        snprintf(size->note, sizeof size->note, "no boundary in the grid: %d %s, %d %s, %d unsettled, %d failed",
                 size->counts[VCRIT_BONDED], adhered ? "adhered" : "bonded", size->counts[VCRIT_REBOUNDED],
                 adhered ? "left" : "rebounded", size->counts[VCRIT_UNSETTLED], size->counts[VCRIT_FAILED]);
        return SC_OK;
    }
    if (logistic_fit(X, y, (size_t)m, 6, k->ridge, &size->fit) != SC_OK) {
        snprintf(size->note, sizeof size->note, "no fit: %s", sc_error_message());
        sc_error_clear();
        return SC_OK;
    }
    size->fitted = 1;
    /* separable outcomes (every one on its side of Z = 0): the boundary is not fitted but placed in the gap the
     * outcomes leave, by the ridge term, or where a fit without one stopped */
    if (size->fit.separable && k->ridge > 0)
        snprintf(size->note, sizeof size->note,
                 "outcomes separable: the boundary lies anywhere in the gap between grid points; placed by ridge = %g",
                 k->ridge);
    else if (size->fit.separable)
        snprintf(size->note, sizeof size->note,
                 "outcomes separable: the boundary lies anywhere in the gap between grid points; placed where the "
                 "fit without a ridge term stopped running away (set ridge > 0)");
    return sample_boundary(k, size);
}

static int fit_size(const struct calibrate *k, int index, struct calibrate_size *size)
{
    size_t per_size = (size_t)(k->gc_count * k->rate_count);
    double *X;
    int *y;
    SC_TRY(sc_calloc(&X, 6 * per_size, sizeof *X, "the logistic regression"));
    int status = sc_calloc(&y, per_size, sizeof *y, "the logistic regression");
    if (status == SC_OK)
        status = fit_outcomes(k, index, size, X, y);
    free(X);
    free(y);
    return status;
}

/* Z of size b along branch `branch` of size a's boundary at t (NaN off the boundary). */
static double z_along(const struct calibrate_size *a, const struct calibrate_size *b, int branch, double t)
{
    double x1, x2;
    return boundary_point(a->fit.theta, branch, t, &x1, &x2) ? logistic_quadratic_z(b->fit.theta, x1, x2) : NAN;
}

/* Record the crossing at (x1, x2) unless an earlier one lies within 1e-3 (scaled): the branches of the two axes
 * find the same points. */
static void add_crossing(struct calibrate *k, double x1, double x2)
{
    double gc = unscaled(x1, k->gc_min, k->gc_max), rate = rate_unscaled(k, x2);
    for (int i = 0; i < k->crossing_count; i++)
        if (fabs(scaled(k->crossings[2 * i], k->gc_min, k->gc_max) - x1) < 1e-3 &&
            fabs(rate_scaled(k, k->crossings[2 * i + 1]) - x2) < 1e-3)
            return;
    if (k->crossing_count == MAX_CROSSINGS)
        return;
    k->crossings[2 * k->crossing_count] = gc;
    k->crossings[2 * k->crossing_count + 1] = rate;
    k->crossing_count++;
}

/* Where size b's Z changes sign along size a's boundary: bisection on each bracketing pair of samples. */
static void find_crossings(struct calibrate *k, const struct calibrate_size *a, const struct calibrate_size *b)
{
    for (int branch = 0; branch < BRANCHES; branch++)
        for (int i = 0; i + 1 < BOUNDARY_SAMPLES; i++) {
            double lo = i / (BOUNDARY_SAMPLES - 1.0), hi = (i + 1) / (BOUNDARY_SAMPLES - 1.0);
            double zlo = z_along(a, b, branch, lo), zhi = z_along(a, b, branch, hi);
            if (!isfinite(zlo) || !isfinite(zhi) || (zlo > 0) == (zhi > 0))
                continue;
            for (int it = 0; it < 60; it++) {
                double mid = 0.5 * (lo + hi), zmid = z_along(a, b, branch, mid);
                if (!isfinite(zmid))
                    break;
                if ((zmid > 0) == (zlo > 0))
                    lo = mid, zlo = zmid;
                else
                    hi = mid;
            }
            double x1, x2;
            if (boundary_point(a->fit.theta, branch, lo, &x1, &x2))
                add_crossing(k, x1, x2);
        }
}

/* The calibrated pair: of the intersections, the one nearest the grid's centre (scaled), put first. */
static void choose_crossing(struct calibrate *k)
{
    int best = 0;
    double best_distance = INFINITY;
    for (int i = 0; i < k->crossing_count; i++) {
        double dx = scaled(k->crossings[2 * i], k->gc_min, k->gc_max) - 0.5,
               dy = rate_scaled(k, k->crossings[2 * i + 1]) - 0.5;
        if (dx * dx + dy * dy < best_distance)
            best = i, best_distance = dx * dx + dy * dy;
    }
    for (int j = 0; j < 2 && best > 0; j++) {
        double swap = k->crossings[j];
        k->crossings[j] = k->crossings[2 * best + j];
        k->crossings[2 * best + j] = swap;
    }
}

static int fit_all(struct calibrate *k)
{
    for (int i = 0; i < k->size_count; i++)
        SC_TRY(fit_size(k, i, &k->sizes[i]));
    if (k->size_count >= 2 && k->sizes[0].fitted && k->sizes[1].fitted)
        find_crossings(k, &k->sizes[0], &k->sizes[1]);
    choose_crossing(k);
    return SC_OK;
}

/* ---- outputs ------------------------------------------------------------------------------------------------ */

/* calibrate_outcomes.csv: every run; calibrate.csv: the intersections, the calibrated pair first. */
static int write_csvs(const struct calibrate *k)
{
    char path[4096];
    struct atomic_file out;
    snprintf(path, sizeof path, "%s/calibrate_outcomes.csv", k->run_dir);
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "diameter,velocity,%s,%s,verdict,pbcp,v_rest,cor\n", k->axes->name[0], k->axes->name[1]);
    for (int t = 0; t < task_count(k); t++) {
        const struct vcrit_run_record *r = &k->outcomes[t];
        fprintf(out.stream, "%.17g,%.17g,%.17g,%.17g,%s,%.17g,%.17g,%.17g\n", r->diameter, r->velocity, r->Gc,
                r->Gc_rate, vcrit_verdict_name(r->verdict), r->pbcp, r->v_rest, r->cor);
    }
    SC_TRY(atomic_publish(&out));
    snprintf(path, sizeof path, "%s/calibrate.csv", k->run_dir);
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "%s,%s,calibrated\n", k->axes->name[0], k->axes->name[1]);
    for (int i = 0; i < k->crossing_count; i++)
        fprintf(out.stream, "%.17g,%.17g,%d\n", k->crossings[2 * i], k->crossings[2 * i + 1], i == 0);
    if (k->crossing_count == 0)
        fprintf(out.stream, "# no intersection of the first two sizes' bonding boundaries in the grid\n");
    for (int i = 0; i < k->size_count; i++) {
        if (k->sizes[i].note[0])
            fprintf(out.stream, "# d = %g m: %s\n", k->sizes[i].diameter, k->sizes[i].note);
        if (k->sizes[i].counts[VCRIT_FAILED])
            fprintf(out.stream,
                    "# d = %g m: %d runs failed as simulations (NaN or blow-up), left out of the fit "
                    "(calibrate_outcomes.csv)\n",
                    k->sizes[i].diameter, k->sizes[i].counts[VCRIT_FAILED]);
    }
    return atomic_publish(&out);
}

static int side_csvs(void *owner)
{
    return write_csvs(owner);
}

static int write_runs(const struct calibrate *k, hid_t file)
{
    size_t n = (size_t)task_count(k);
    double *values;
    int64_t *verdicts; /* the runs' verdicts, then as the fit counted them (outcome) */
    SC_TRY(sc_calloc(&values, 7 * n, sizeof *values, "the calibration runs"));
    int status = sc_calloc(&verdicts, 2 * n, sizeof *verdicts, "the calibration verdicts");
    hid_t group = H5I_INVALID_HID;
    if (status != SC_OK)
        goto done;
    for (size_t t = 0; t < n; t++) {
        const struct vcrit_run_record *r = &k->outcomes[t];
        double row[7] = {r->diameter, r->velocity, r->Gc, r->Gc_rate, r->pbcp, r->v_rest, r->cor};
        for (int j = 0; j < 7; j++)
            values[(size_t)j * n + t] = row[j];
        verdicts[t] = r->verdict;
        verdicts[n + t] = counted_as(k, r);
    }
    const char *const names[] = {"diameter", "velocity", k->axes->name[0], k->axes->name[1], "pbcp", "v_rest", "cor"};
    const char *const units[] = {"m", "m/s", k->axes->unit[0], k->axes->unit[1], "-", "m/s", "-"};
    hsize_t dims[1] = {n};
    SC_CHECK(status, h5_create_group(file, "runs", &group), done);
    for (int j = 0; j < 7; j++)
        SC_CHECK(status, h5_write_doubles(group, names[j], 1, dims, values + (size_t)j * n, units[j], 0), done);
    SC_CHECK(status, h5_write_int64s(group, "verdict", 1, dims, verdicts, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "counted", 1, dims, verdicts + n, "-", 0), done);
done:
    free(values);
    free(verdicts);
    if (group >= 0)
        H5Gclose(group);
    return status;
}

static int write_size(const struct calibrate *k, hid_t parent, int index)
{
    const struct calibrate_size *s = &k->sizes[index];
    char name[32];
    snprintf(name, sizeof name, "%03d", index);
    hid_t group;
    SC_TRY(h5_create_group(parent, name, &group));
    int status;
    hsize_t six[1] = {6}, n[1] = {s->boundary_count};
    SC_CHECK(status, h5_attr_write_double(group, "diameter", s->diameter), done);
    SC_CHECK(status, h5_attr_write_double(group, "velocity", s->velocity), done);
    SC_CHECK(status, h5_attr_write_double(group, "substrate_diameter", s->substrate), done);
    SC_CHECK(status, h5_attr_write_int64(group, "bonded", s->counts[VCRIT_BONDED]), done);
    SC_CHECK(status, h5_attr_write_int64(group, "rebounded", s->counts[VCRIT_REBOUNDED]), done);
    SC_CHECK(status, h5_attr_write_int64(group, "unsettled", s->counts[VCRIT_UNSETTLED]), done);
    SC_CHECK(status, h5_attr_write_int64(group, "failed", s->counts[VCRIT_FAILED]), done);
    SC_CHECK(status, h5_attr_write_string(group, "result", s->note[0] ? s->note : "fitted"), done);
    if (s->fitted) {
        /* separable outcomes have no standard errors: the penalised Hessian's measure the ridge term, not the data */
        const double none[6] = {NAN, NAN, NAN, NAN, NAN, NAN};
        SC_CHECK(status, h5_write_doubles(group, "theta", 1, six, s->fit.theta, "-", 0), done);
        SC_CHECK(status, h5_write_doubles(group, "theta_se", 1, six, s->fit.separable ? none : s->fit.se, "-", 0),
                 done);
        SC_CHECK(status, h5_attr_write_double(group, "cost", s->fit.cost), done);
        char name0[40], name1[40];
        snprintf(name0, sizeof name0, "boundary_%s", k->axes->name[0]);
        snprintf(name1, sizeof name1, "boundary_%s", k->axes->name[1]);
        SC_CHECK(status, h5_write_doubles(group, name0, 1, n, s->boundary, k->axes->unit[0], 0), done);
        SC_CHECK(status, h5_write_doubles(group, name1, 1, n, s->boundary + s->boundary_count, k->axes->unit[1], 0),
                 done);
    }
done:
    H5Gclose(group);
    return status;
}

/* calibrate.h5 (docs/files.md): the grid, /runs, /size/NNN with the fit and boundary, /intersection. */
static int output_contents(void *owner, hid_t file)
{
    const struct calibrate *k = owner;
    double none = NAN;
    const double *best = k->crossing_count ? k->crossings : NULL;
    const struct bonding_axes *a = k->axes;
    SC_TRY(h5_attr_write_string(file, "bonding", a->model));
    SC_TRY(h5_attr_write_double(file, a->name[0], best ? best[0] : none));
    SC_TRY(h5_attr_write_double(file, a->name[1], best ? best[1] : none));
    char grid[4][32];
    axis_key(a, 0, "min", grid[0], sizeof grid[0]);
    axis_key(a, 0, "max", grid[1], sizeof grid[1]);
    axis_key(a, 1, "min", grid[2], sizeof grid[2]);
    axis_key(a, 1, "max", grid[3], sizeof grid[3]);
    double values[] = {k->gc_min, k->gc_max, k->rate_min, k->rate_max};
    for (int i = 0; i < 4; i++)
        SC_TRY(h5_attr_write_double(file, grid[i], values[i]));
    SC_TRY(h5_attr_write_double(file, "ridge", k->ridge));
    SC_TRY(h5_attr_write_double(file, "reference_diameter", k->reference));
    SC_TRY(h5_attr_write_string(file, "rate_axis", k->rate_log ? "log" : "linear"));
    SC_TRY(h5_attr_write_string(file, "outcome", k->outcome == VCRIT_OUTCOME_ADHERED ? "adhered" : "bonded"));
    SC_TRY(write_runs(k, file));
    hid_t group;
    SC_TRY(h5_create_group(file, "size", &group));
    int status = SC_OK;
    for (int i = 0; i < k->size_count && status == SC_OK; i++)
        status = write_size(k, group, i);
    H5Gclose(group);
    SC_TRY(status);
    double gc[MAX_CROSSINGS], rate[MAX_CROSSINGS];
    for (int i = 0; i < k->crossing_count; i++)
        gc[i] = k->crossings[2 * i], rate[i] = k->crossings[2 * i + 1];
    hsize_t dims[1] = {(hsize_t)k->crossing_count};
    char name0[40], name1[40];
    snprintf(name0, sizeof name0, "intersection_%s", a->name[0]);
    snprintf(name1, sizeof name1, "intersection_%s", a->name[1]);
    SC_TRY(h5_write_doubles(file, name0, 1, dims, gc, a->unit[0], 0));
    return h5_write_doubles(file, name1, 1, dims, rate, a->unit[1], 0);
}

static void log_results(const struct calibrate *k)
{
    for (int i = 0; i < k->size_count; i++) {
        const struct calibrate_size *s = &k->sizes[i];
        int adhered = k->outcome == VCRIT_OUTCOME_ADHERED;
        log_info("calibrate: d = %.4g um at %g m/s: %d %s, %d %s, %d unsettled, %d failed%s%s", s->diameter * 1e6,
                 s->velocity, s->counts[VCRIT_BONDED], adhered ? "adhered" : "bonded", s->counts[VCRIT_REBOUNDED],
                 adhered ? "left" : "rebounded", s->counts[VCRIT_UNSETTLED], s->counts[VCRIT_FAILED],
                 s->note[0] ? "; " : "", s->note);
        if (s->counts[VCRIT_FAILED]) /* also on a resume, which takes them from the records without a word */
            log_warn("calibrate: d = %.4g um: %d runs failed as simulations (NaN or blow-up), left out of the fit "
                     "(calibrate_outcomes.csv: verdict failed)",
                     s->diameter * 1e6, s->counts[VCRIT_FAILED]);
    }
    if (k->crossing_count)
        log_info("calibrate: calibrated %s = %.6g %s, %s = %.6g %s (%d intersection%s)", k->axes->name[0],
                 k->crossings[0], k->axes->unit[0], k->axes->name[1], k->crossings[1], k->axes->unit[1],
                 k->crossing_count, k->crossing_count > 1 ? "s" : "");
    else
        log_warn("calibrate: the bonding boundaries do not intersect in the grid: no calibrated pair");
}

/* Rank 0, once every run is done: the outcomes from all ranks' records, the fits, the outputs. */
static int fit_and_write(struct calibrate *k, double start)
{
    int64_t runs = k->runs.new_runs;
    SC_TRY(vcrit_runs_load(&k->runs));
    for (int t = 0; t < task_count(k); t++)
        SC_TRY(task_outcome(k, t));
    if (k->runs.new_runs != runs)
        SC_FAIL(SC_EIO, "calibrate: a run is missing from the records after all ranks finished (a records file "
                        "removed or damaged while the stage ran?)");
    SC_TRY(fit_all(k));
    char path[4096];
    snprintf(path, sizeof path, "%s/calibrate.h5", k->run_dir);
    /* the CSVs as calibrate.h5's side files: never beside another case's calibrate.h5 (app.h) */
    SC_TRY(stage_write_outputs(path, CALIBRATE_FORMAT, CALIBRATE_FORMAT_VERSION, STAGE, k->case_hash, k->c,
                               output_contents, side_csvs, k));
    log_info("calibrate: wrote %s/calibrate.csv, calibrate_outcomes.csv and calibrate.h5 (%lld runs in this "
             "process, %.1f s)",
             k->run_dir, (long long)k->runs.new_runs, log_elapsed() - start);
    log_results(k);
    return SC_OK;
}

static int calibrate_all(struct calibrate *k)
{
    double start = log_elapsed();
    if (parallel_rank() == 0)
        log_info("calibrate: %d sizes x %d %s x %d %s = %d runs, on %d threads x %d process%s", k->size_count,
                 k->gc_count, k->axes->name[0], k->rate_count, k->axes->name[1], task_count(k), omp_get_max_threads(),
                 parallel_size(), parallel_size() > 1 ? "es" : "");
    int status = parallel_max_status(runs_shared(k));
    if (status == SC_OK && parallel_rank() == 0)
        status = fit_and_write(k, start);
    return parallel_share_status(status);
}

int calibrate_stage_validate(const struct stage_context *ctx)
{
    if (case_is(ctx->c, STAGE, "method", "vcrit"))
        return calibrate_vcrit_validate(ctx);
    struct calibrate k = {.c = ctx->c};
    return load_settings(ctx->c, &k);
}

/* What one run's outcome depends on besides its diameter, speed and the two parameters: [run], [impact], the
 * materials, and the reference diameter, or without one each size's substrate.  The grid's own keys (the parameters'
 * ranges and counts, ridge, rate_axis, velocities) are left out, so that a grid refined, widened or moved reuses the
 * runs it shares with the one before (the record is kept with the outputs), as vcrit's does. */
static uint64_t runs_hash(const struct calibrate *k)
{
    static const char *const run_sections[] = {"run", "impact", "material.*", NULL};
    uint64_t hash = case_hash_sections(k->c, run_sections);
    double keys[1 + 2 * MAX_SIZES] = {k->reference};
    size_t count = 1;
    for (int i = 0; k->reference <= 0 && i < k->size_count; i++)
        keys[count++] = k->sizes[i].diameter, keys[count++] = k->sizes[i].substrate;
    return case_hash_continue(hash, keys, count * sizeof keys[0]);
}

int calibrate_stage_run(const struct stage_context *ctx)
{
    struct calibrate k = {.c = ctx->c, .run_dir = ctx->run_dir, .case_hash = stage_hash(ctx, STAGE)};
    char path[4096];
    snprintf(path, sizeof path, "%s/calibrate.h5", ctx->run_dir);
    struct run_settings settings;
    if (stage_begin(STAGE, path, k.case_hash, ctx->c, &settings))
        return SC_OK;
    if (case_is(ctx->c, STAGE, "method", "vcrit"))
        return calibrate_vcrit_run(ctx, k.case_hash);
    SC_TRY(load_settings(ctx->c, &k));
    k.runs = (struct vcrit_runs){
        .run_dir = ctx->run_dir, .name = STAGE, .resume_dir = stage_resume_dir(ctx), .case_hash = runs_hash(&k)};
    int status;
    SC_CHECK(status, sc_calloc(&k.outcomes, (size_t)task_count(&k), sizeof *k.outcomes, "the calibration runs"), done);
    SC_CHECK(status, calibrate_all(&k), done);
done:
    for (int i = 0; i < k.size_count; i++)
        free(k.sizes[i].boundary);
    free(k.outcomes);
    vcrit_runs_free(&k.runs);
    return status;
}
