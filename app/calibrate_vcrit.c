/* `spraycoat calibrate` with [calibrate] method = vcrit: the bonding model's first parameter (energy: Gc, strain:
 * eps_c) such that the critical velocities `spraycoat vcrit` predicts meet measured ones (docs/physics.md,
 * "Calibrated on v_crit").
 *
 * Tang's calibration (the other method, app/calibrate_stage.c) asks that two sizes just bond at their measured
 * critical velocities at one pair of parameters; with the current contact rules no such pair exists, while v_crit of
 * both sizes moves with the first parameter at one rate and keeps the measured difference.  So here the second
 * parameter stays at its [impact] value and the first p is chosen so that the mean of v_crit(d_i; p) - target_i over
 * the sizes is zero: the least-squares p when every size's v_crit moves with p at the same rate.  Each value of p is
 * a whole `spraycoat vcrit` search of the [calibrate] diameters (the [vcrit] keys for everything else; a search by
 * logistic regression is the one whose v_crit is not decided by a single noisy run) in RUN_DIR/vcrit_NN, and p
 * follows the Illinois false position (core/root.h) from the two ends [calibrate] <p>_min and <p>_max until the
 * mean residual is within fit_tolerance, or the bracket is narrower than fit_bracket of its middle (the residual
 * jumps across zero there: its middle is the value), or fit_evaluations searches are spent.  Every search is
 * restartable and shared among MPI ranks as `spraycoat vcrit` is; after an interruption the iteration replays from
 * their outputs. A search with a size without v_crit (not bracketed, or a run of it failed as a simulation)
 * stops the calibration with SC_ESIM, its message telling the two apart (read_search). Writes
 * RUN_DIR/calibrate_vcrit.csv (each search's v_crit), calibrate.csv and calibrate.h5
 * (docs/files.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/atomic.h"
#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/root.h"
#include "core/run_keys.h"
#include "app/app.h"

#define STAGE            "calibrate"
#define FORMAT           "spraycoat-calibrate"
#define FORMAT_VERSION   1
#define MAX_SIZES        8
#define MAX_EVALUATIONS  100
#define MAX_RATE_FITS    12
#define VCRIT_DIR_FORMAT "%s/vcrit_%02d"

struct vcrit_fit {
    const struct stage_context *ctx;
    uint64_t case_hash;
    const char *name[2], *unit[2]; /* the model's two parameters: the fitted one, the one kept */
    double kept;                   /* the second parameter: its [impact] value, or the value being tried */
    double lo, hi, tolerance;      /* the first parameter's range, the mean residual accepted (m/s) */
    double bracket_tolerance;      /* a bracket this narrow relative to its middle ends the iteration */
    int size_count, max_evaluations;
    double diameter[MAX_SIZES], target[MAX_SIZES];
    int count; /* searches done */
    double p[MAX_EVALUATIONS], rate[MAX_EVALUATIONS], v[MAX_EVALUATIONS][MAX_SIZES], residual[MAX_EVALUATIONS];
    double calibrated; /* NaN unless a search met the tolerance or the bracket closed */
    char note[240];    /* how the value was found ("" when a search met the tolerance), or why there is none */
    /* [calibrate] rate = fitted: the second parameter too, between rate_lo and rate_hi (false position in its
     * logarithm) so that the spread v_crit(first size) - v_crit(last size) meets that of the targets */
    int fit_rate, max_rate_fits;
    double rate_lo, rate_hi, spread_tolerance;
    int rate_fits;                        /* first-parameter fits done, one per value of the second */
    double fitted[MAX_RATE_FITS];         /* each fit's value of the first parameter (NaN: none found) */
    double fit_rate_value[MAX_RATE_FITS]; /* the second parameter of each fit */
    double slope; /* mean residual per unit of the first parameter, from the first fit's ends (m/s per unit) */
    double spread_residual[MAX_RATE_FITS];
};

/* [calibrate] <name>_min and <name>_max, the range `who` searches. */
static int load_range(const struct case_file *c, const char *name, const char *who, double *lo, double *hi)
{
    char key_min[32], key_max[32];
    snprintf(key_min, sizeof key_min, "%s_min", name);
    snprintf(key_max, sizeof key_max, "%s_max", name);
    *lo = case_real(c, STAGE, key_min), *hi = case_real(c, STAGE, key_max);
    if (!(*hi > *lo))
        return case_invalid(c, STAGE, key_max, "%g is not above %s = %g: %s searches between the two", *hi, key_min,
                            *lo, who);
    return SC_OK;
}

/* [calibrate] rate = fitted: the second parameter's range (<name>_min, <name>_max) and the most fits of the first. */
static int load_rate(const struct case_file *c, struct vcrit_fit *f)
{
    f->fit_rate = case_is(c, STAGE, "rate", "fitted");
    if (!f->fit_rate)
        return SC_OK;
    if (f->size_count < 2)
        return case_invalid(c, STAGE, "rate",
                            "is fitted with one diameter: the spread of v_crit over the sizes needs two at least");
    SC_TRY(load_range(c, f->name[1], "rate = fitted", &f->rate_lo, &f->rate_hi));
    f->max_rate_fits = (int)case_int(c, STAGE, "fit_rate_evaluations");
    f->spread_tolerance = case_real(c, STAGE, "fit_spread_tolerance");
    if ((long)f->max_rate_fits * f->max_evaluations > MAX_EVALUATIONS)
        return case_invalid(c, STAGE, "fit_rate_evaluations",
                            "%d fits of at most fit_evaluations = %d searches each exceed the %d searches a "
                            "calibration can hold; lower either",
                            f->max_rate_fits, f->max_evaluations, MAX_EVALUATIONS);
    return SC_OK;
}

static int load(const struct stage_context *ctx, struct vcrit_fit *f)
{
    const struct case_file *c = ctx->c;
    int strain = case_is(c, "impact", "bonding", "strain");
    if (case_is(c, "impact", "bonding", "none"))
        return case_invalid(c, "impact", "bonding", "is none: calibrate fits a bonding model; allowed: energy, strain");
    f->name[0] = strain ? "eps_c" : "Gc", f->name[1] = strain ? "eps_rate_c" : "Gc_rate";
    f->unit[0] = strain ? "-" : "J/m2", f->unit[1] = strain ? "1/s" : "J/m2/s";
    f->kept = case_real(c, "impact", f->name[1]);
    SC_TRY(load_range(c, f->name[0], "method = vcrit", &f->lo, &f->hi));
    f->tolerance = case_real(c, STAGE, "fit_tolerance");
    f->max_evaluations = (int)case_int(c, STAGE, "fit_evaluations");
    f->bracket_tolerance = case_real(c, STAGE, "fit_bracket");
    int targets;
    SC_TRY(vcrit_runs_parse_list(c, STAGE, "diameters", 1.0, "m", f->diameter, MAX_SIZES, &f->size_count));
    SC_TRY(vcrit_runs_parse_list(c, STAGE, "velocities", 1e5, "m/s", f->target, MAX_SIZES, &targets));
    if (f->size_count == 0)
        return case_invalid(c, STAGE, "diameters", "no diameter given");
    if (targets != f->size_count)
        return case_invalid(c, STAGE, "velocities",
                            "%d speeds for %d diameters; allowed: one measured critical velocity per diameter", targets,
                            f->size_count);
    SC_TRY(load_rate(c, f));
    if (case_is_given(c, "vcrit", "temperatures"))
        return case_invalid(c, "vcrit", "temperatures",
                            "is given: method = vcrit fits v_crit(d) at the material's T_initial; remove it");
    if (case_is_given(c, "vcrit", "diameters"))
        return case_invalid(c, "vcrit", "diameters",
                            "is given: with [calibrate] method = vcrit the searches are of [calibrate] diameters; "
                            "remove it");
    return SC_OK;
}

/* The case of the search at p: the calibration's case with [impact] <name> = p and [vcrit] diameters =
 * [calibrate]'s.  A copy of the case in memory, never the file read again: that may have been edited since and lacks
 * the command line's overrides (--device gpu was dropped: every search ran on the CPU). */
static int search_case(const struct vcrit_fit *f, double p, struct case_file **out)
{
    const struct case_file *c = f->ctx->c;
    struct case_file *run = case_clone(c);
    char value[64];
    snprintf(value, sizeof value, "%.17g", p);
    int status = case_set(run, "impact", f->name[0], value, "[calibrate] method = vcrit");
    snprintf(value, sizeof value, "%.17g", f->kept);
    if (status == SC_OK && f->fit_rate)
        status = case_set(run, "impact", f->name[1], value, "[calibrate] rate = fitted");
    if (status == SC_OK)
        status = case_set(run, "vcrit", "diameters", case_text(c, STAGE, "diameters"), "[calibrate] diameters");
    if (status != SC_OK) {
        case_free(run);
        SC_TRY(status);
    }
    *out = run;
    return SC_OK;
}

/* The result of vcrit.h5's search of diameter d (/search/NNN attribute result, vcrit_stage.c): "" where none is
 * found. */
static void search_note(hid_t file, double d, char *note, size_t size)
{
    note[0] = '\0';
    hid_t group;
    for (size_t i = 0; i < 1000 && h5_numbered_group(file, "search", i, &group); i++) {
        double at = NAN;
        if (group >= 0 && h5_attr_read_double(group, "diameter", &at) == SC_OK && fabs(at - d) <= 1e-12 * d)
            h5_attr_read_string(group, "result", note, size);
        if (group >= 0)
            H5Gclose(group);
    }
    sc_error_clear(); /* a search without its note is only a shorter message */
}

/* v_crit of every size from DIR/vcrit.h5, matched by diameter.  A size without one stops the calibration (SC_ESIM):
 * its search was not bracketed, or a run of it failed as a simulation (NaN or blow-up), which the message tells
 * apart, since the remedies differ. */
static int read_search(const struct vcrit_fit *f, const char *dir, double p, double *v)
{
    char path[4300];
    snprintf(path, sizeof path, "%s/vcrit.h5", dir);
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    size_t n = 0;
    double d[MAX_SIZES], vc[MAX_SIZES];
    int status;
    SC_CHECK(status, h5_dataset_size(file, "diameter", &n), done);
    /* vcrit.h5 holds the bracketed diameters only: one missing is a size whose v_crit the range does not hold */
    if (n > MAX_SIZES)
        SC_FAIL_AT(status, done, SC_EIO, "calibrate: %s has %zu diameters, more than the %d the calibration can hold",
                   path, n, MAX_SIZES);
    SC_CHECK(status, h5_read_doubles(file, "diameter", d, n), done);
    SC_CHECK(status, h5_read_doubles(file, "v_crit", vc, n), done);
    for (int i = 0; i < f->size_count; i++) {
        v[i] = NAN;
        for (size_t j = 0; j < n; j++)
            if (fabs(d[j] - f->diameter[i]) <= 1e-12 * f->diameter[i])
                v[i] = vc[j];
        char note[512];
        if (!isfinite(v[i]))
            search_note(file, f->diameter[i], note, sizeof note);
        if (!isfinite(v[i]) && strstr(note, "no v_crit"))
            SC_FAIL_AT(status, done, SC_ESIM,
                       "calibrate: at %s = %.6g the critical velocity of d = %g m was not found: %s (%s/vcrit.csv): "
                       "make [impact] hold at these speeds (a smaller cfl, a finer grid) or narrow [vcrit] v_low to "
                       "v_high",
                       f->name[0], p, f->diameter[i], note, dir);
        if (!isfinite(v[i]))
            SC_FAIL_AT(status, done, SC_ESIM,
                       "calibrate: at %s = %.6g the critical velocity of d = %g m was not found in [vcrit] v_low to "
                       "v_high (%s/vcrit.csv says why): widen that range",
                       f->name[0], p, f->diameter[i], dir);
    }
done:
    H5Fclose(file);
    return status;
}

/* Search k at p (or its output, when an earlier process finished it): the sizes' v_crit and the mean residual. */
static int evaluate(struct vcrit_fit *f, double p)
{
    int k = f->count;
    if (k >= MAX_EVALUATIONS)
        SC_FAIL(SC_ESIM, "calibrate: more than %d searches", MAX_EVALUATIONS);
    char dir[4200];
    snprintf(dir, sizeof dir, VCRIT_DIR_FORMAT, f->ctx->run_dir, k + 1);
    struct case_file *run;
    SC_TRY(search_case(f, p, &run));
    /* interrupted, the search names the calibration's directory: resuming that finishes the calibration */
    const struct stage_context ctx = {.c = run, .run_dir = dir, .resume_dir = stage_resume_dir(f->ctx)};
    if (parallel_rank() == 0)
        log_info("calibrate: search %d, %s = %.6g %s (%s = %.6g %s), in %s", k + 1, f->name[0], p, f->unit[0],
                 f->name[1], f->kept, f->unit[1], dir);
    int status = parallel_rank() == 0 ? run_dir_prepare(dir, run) : SC_OK;
    if (status == SC_OK && parallel_rank() == 0)
        status = run_dir_write_stages(dir, "vcrit");
    status = parallel_share_status(status);
    if (status == SC_OK)
        status = vcrit_stage_validate(&ctx);
    if (status == SC_OK)
        status = vcrit_stage_run(&ctx);
    case_free(run);
    SC_TRY(parallel_share_status(status));
    parallel_barrier(); /* rank 0 wrote vcrit.h5 */
    SC_TRY(read_search(f, dir, p, f->v[k]));
    double sum = 0;
    for (int i = 0; i < f->size_count; i++)
        sum += f->v[k][i] - f->target[i];
    f->p[k] = p, f->rate[k] = f->kept, f->residual[k] = sum / f->size_count, f->count++;
    if (parallel_rank() == 0)
        log_info("calibrate: %s = %.6g: mean v_crit - target %+.3g m/s (tolerance %g)", f->name[0], p, f->residual[k],
                 f->tolerance);
    return SC_OK;
}

static int within(const struct vcrit_fit *f, int k)
{
    return fabs(f->residual[k]) <= f->tolerance;
}

/* The search of the fit that began with search `first` whose mean residual is smallest. */
static int nearest_search(const struct vcrit_fit *f, int first)
{
    int best = first;
    for (int k = first + 1; k < f->count; k++)
        if (fabs(f->residual[k]) < fabs(f->residual[best]))
            best = k;
    return best;
}

/* The fit of the first parameter that began with search `first`, from two of its searches at x0 < x1 with residuals
 * r0, r1: false position until a mean residual is within the tolerance.  f->calibrated is NaN where none is found
 * (f->note says why). */
static int refine(struct vcrit_fit *f, int first, double x0, double r0, double x1, double r1)
{
    if (r0 * r1 > 0) {
        snprintf(f->note, sizeof f->note,
                 "the mean residual has one sign over %s %g to %g (%+.3g and %+.3g m/s): widen the range", f->name[0],
                 x0, x1, r0, r1);
        return SC_OK;
    }
    struct root_bracket b;
    SC_TRY(root_bracket_start(&b, x0, r0, x1, r1));
    while (f->count - first < f->max_evaluations) {
        SC_TRY(evaluate(f, root_bracket_next(&b)));
        int k = f->count - 1;
        if (within(f, k)) {
            f->calibrated = f->p[k];
            return SC_OK;
        }
        root_bracket_update(&b, f->p[k], f->residual[k]);
        if (b.hi - b.lo <= f->bracket_tolerance * 0.5 * fabs(b.lo + b.hi)) {
            /* the mean residual jumps across zero (single verdicts near v_crit are discrete): its place is found */
            f->calibrated = 0.5 * (b.lo + b.hi);
            snprintf(f->note, sizeof f->note,
                     "the middle of the bracket %s %.6g to %.6g, narrower than fit_bracket, across which the mean "
                     "residual changes sign",
                     f->name[0], b.lo, b.hi);
            return SC_OK;
        }
    }
    snprintf(f->note, sizeof f->note,
             "no search of %d met the tolerance %g m/s; the root lies in %s %.6g to %.6g (raise fit_evaluations or "
             "fit_tolerance)",
             f->count - first, f->tolerance, f->name[0], b.lo, b.hi);
    return SC_OK;
}

/* Search k, and whether it met the tolerance (then it is the value). */
static int evaluate_and_accept(struct vcrit_fit *f, double p, int *accepted)
{
    SC_TRY(evaluate(f, p));
    *accepted = within(f, f->count - 1);
    if (*accepted)
        f->calibrated = p;
    return SC_OK;
}

/* The first parameter at the second's current value (f->kept) from the range's two ends.  Their secant slope, the
 * change of the mean residual per unit of the parameter, is kept for the fits that start near a value (below). */
static int fit_first(struct vcrit_fit *f)
{
    int first = f->count, accepted;
    f->calibrated = NAN, f->note[0] = '\0';
    SC_TRY(evaluate_and_accept(f, f->lo, &accepted));
    if (accepted)
        return SC_OK;
    SC_TRY(evaluate_and_accept(f, f->hi, &accepted));
    f->slope = (f->residual[first + 1] - f->residual[first]) / (f->hi - f->lo);
    if (accepted)
        return SC_OK;
    return refine(f, first, f->lo, f->residual[first], f->hi, f->residual[first + 1]);
}

/* Among the searches of the fit that began with search `first`, two neighbours in the parameter whose mean
 * residuals differ in sign (or one is zero): 1 and their values, lowest such pair first; 0 where there is none. */
static int sign_change(const struct vcrit_fit *f, int first, double *x0, double *r0, double *x1, double *r1)
{
    int found = 0;
    for (int i = first; i < f->count; i++) {
        int next = -1; /* the search with the next larger parameter */
        for (int k = first; k < f->count; k++)
            if (f->p[k] > f->p[i] && (next < 0 || f->p[k] < f->p[next]))
                next = k;
        if (next >= 0 && f->residual[i] * f->residual[next] <= 0 && (!found || f->p[i] < *x0)) {
            *x0 = f->p[i], *r0 = f->residual[i], *x1 = f->p[next], *r1 = f->residual[next];
            found = 1;
        }
    }
    return found;
}

/* The mean residual of the search at p of the fit that began with search `first`; NaN where there is none. */
static double residual_at(const struct vcrit_fit *f, int first, double p)
{
    for (int k = first; k < f->count; k++)
        if (f->p[k] == p)
            return f->residual[k];
    return NAN;
}

/* The search at p unless the fit that began with search `first` has made it already. */
static int evaluate_new(struct vcrit_fit *f, int first, double p, int *accepted)
{
    *accepted = 0;
    return isnan(residual_at(f, first, p)) ? evaluate_and_accept(f, p, accepted) : SC_OK;
}

/* The end of the fit that began with search `first`, once its searches are made: false position from two that
 * bracket the root; where none do, refine's note on the two ends of one sign, or, when fit_evaluations ran out before
 * both ends were searched, a note of its own. */
static int refine_searched(struct vcrit_fit *f, int first)
{
    double x0, r0, x1, r1;
    if (sign_change(f, first, &x0, &r0, &x1, &r1))
        return refine(f, first, x0, r0, x1, r1);
    double r_lo = residual_at(f, first, f->lo), r_hi = residual_at(f, first, f->hi);
    if (!isnan(r_lo) && !isnan(r_hi))
        return refine(f, first, f->lo, r_lo, f->hi, r_hi);
    snprintf(f->note, sizeof f->note,
             "no search of %d (fit_evaluations) met the tolerance %g m/s or bracketed the root in %s %g to %g (raise "
             "fit_evaluations or fit_tolerance)",
             f->count - first, f->tolerance, f->name[0], f->lo, f->hi);
    return SC_OK;
}

/* The first parameter at the second's current value, starting from `guess` (the value fitted at a nearby value of
 * the second): then one secant step with f->slope toward the root, then, until two searches bracket it, the
 * range's end beyond the step and the other end, never more than fit_evaluations searches in all (the ends made it
 * four with fit_evaluations = 3).  Two searches where the guess is near, against three or more from the ends. */
static int fit_first_near(struct vcrit_fit *f, double guess)
{
    int first = f->count, accepted;
    f->calibrated = NAN, f->note[0] = '\0';
    SC_TRY(evaluate_and_accept(f, guess, &accepted));
    if (accepted)
        return SC_OK;
    double r = f->residual[first];
    double toward = r * f->slope > 0 ? f->lo : f->hi; /* the end the root lies toward on the slope */
    double step = fmin(fmax(guess - r / f->slope, f->lo), f->hi);
    if (step == guess) /* a step too small to move, or the guess at the end the root lies beyond */
        step = toward != guess ? toward : (toward == f->lo ? f->hi : f->lo);
    SC_TRY(evaluate_and_accept(f, step, &accepted));
    if (accepted)
        return SC_OK;
    double beyond = step < guess ? f->lo : f->hi, ends[2] = {beyond, beyond == f->lo ? f->hi : f->lo};
    double x0, r0, x1, r1;
    for (int e = 0; e < 2 && !sign_change(f, first, &x0, &r0, &x1, &r1); e++) {
        if (isnan(residual_at(f, first, ends[e])) && f->count - first >= f->max_evaluations)
            break;
        SC_TRY(evaluate_new(f, first, ends[e], &accepted));
        if (accepted)
            return SC_OK;
    }
    return refine_searched(f, first);
}

/* The earlier fit with a value whose second parameter is nearest `rate` in its logarithm; -1 where none. */
static int nearest_fit(const struct vcrit_fit *f, double rate)
{
    int near = -1;
    for (int j = 0; j < f->rate_fits; j++)
        if (isfinite(f->fitted[j]) &&
            (near < 0 || fabs(log(f->fit_rate_value[j] / rate)) < fabs(log(f->fit_rate_value[near] / rate))))
            near = j;
    return near;
}

/* rate = fitted: the first parameter fitted at the second = rate, and the spread residual of its nearest search,
 * (v_crit of the first size - v_crit of the last) - (their targets' difference).  NaN where the fit found none. */
static int fit_at_rate(struct vcrit_fit *f, double rate, double *spread_residual)
{
    int j = f->rate_fits, first = f->count, last = f->size_count - 1;
    f->kept = rate;
    if (parallel_rank() == 0)
        log_info("calibrate: fit %d of at most %d of %s at %s = %.6g %s", j + 1, f->max_rate_fits, f->name[0],
                 f->name[1], rate, f->unit[1]);
    int near = nearest_fit(f, rate);
    if (near >= 0 && isfinite(f->slope) && f->slope != 0)
        SC_TRY(fit_first_near(f, f->fitted[near]));
    else
        SC_TRY(fit_first(f));
    int k = nearest_search(f, first);
    f->fitted[j] = f->calibrated, f->fit_rate_value[j] = rate, f->rate_fits++;
    *spread_residual = isfinite(f->calibrated) ? (f->v[k][0] - f->v[k][last]) - (f->target[0] - f->target[last]) : NAN;
    f->spread_residual[j] = *spread_residual;
    if (parallel_rank() == 0 && isfinite(f->calibrated))
        log_info("calibrate: %s = %.6g %s: %s = %.6g, spread residual %+.3g m/s (tolerance %g)", f->name[1], rate,
                 f->unit[1], f->name[0], f->calibrated, *spread_residual, f->spread_tolerance);
    return SC_OK;
}

/* A fit of the first parameter failed: the note says at which value of the second. */
static void note_failed_fit(struct vcrit_fit *f)
{
    char why[sizeof f->note];
    snprintf(why, sizeof why, "%s", f->note);
    snprintf(f->note, sizeof f->note, "at %s = %.6g: %.200s", f->name[1], f->kept, why);
}

/* The fit whose spread residual is smallest in magnitude (one was found: every fit so far had a value). */
static int nearest_spread(const struct vcrit_fit *f)
{
    int best = 0;
    for (int j = 1; j < f->rate_fits; j++)
        if (fabs(f->spread_residual[j]) < fabs(f->spread_residual[best]))
            best = j;
    return best;
}

/* rate = fitted: false position in ln(rate) on the spread residual, each value a fit of the first parameter. */
static int fit_both(struct vcrit_fit *f)
{
    double end[2] = {f->rate_lo, f->rate_hi}, s[2];
    for (int j = 0; j < 2; j++) {
        SC_TRY(fit_at_rate(f, end[j], &s[j]));
        if (!isfinite(s[j])) {
            note_failed_fit(f);
            return SC_OK;
        }
        if (fabs(s[j]) <= f->spread_tolerance)
            return SC_OK;
    }
    f->calibrated = NAN;
    if (s[0] * s[1] > 0) {
        snprintf(f->note, sizeof f->note,
                 "the spread residual has one sign over %s %g to %g (%+.3g and %+.3g m/s): widen the range", f->name[1],
                 f->rate_lo, f->rate_hi, s[0], s[1]);
        return SC_OK;
    }
    struct root_bracket b;
    SC_TRY(root_bracket_start(&b, log(end[0]), s[0], log(end[1]), s[1]));
    while (f->rate_fits < f->max_rate_fits) {
        double next = root_bracket_next(&b), spread;
        SC_TRY(fit_at_rate(f, exp(next), &spread));
        if (!isfinite(spread)) {
            note_failed_fit(f);
            return SC_OK;
        }
        if (fabs(spread) <= f->spread_tolerance)
            return SC_OK;
        root_bracket_update(&b, next, spread);
        if (exp(b.hi) - exp(b.lo) <= f->bracket_tolerance * 0.5 * (exp(b.lo) + exp(b.hi))) {
            /* the spread jumps across zero: of the fits made, the one whose spread is nearest is the pair */
            int j = nearest_spread(f);
            f->kept = f->fit_rate_value[j], f->calibrated = f->fitted[j];
            snprintf(f->note, sizeof f->note,
                     "the fit of smallest spread residual (%+.3g m/s); the bracket %s %.6g to %.6g, across which it "
                     "changes sign, is narrower than fit_bracket",
                     f->spread_residual[j], f->name[1], exp(b.lo), exp(b.hi));
            return SC_OK;
        }
    }
    f->calibrated = NAN;
    snprintf(f->note, sizeof f->note,
             "no fit of %d met the spread tolerance %g m/s; the root lies in %s %.6g to %.6g (raise "
             "fit_rate_evaluations or fit_spread_tolerance)",
             f->rate_fits, f->spread_tolerance, f->name[1], exp(b.lo), exp(b.hi));
    return SC_OK;
}

static int fit(struct vcrit_fit *f)
{
    return f->fit_rate ? fit_both(f) : fit_first(f);
}

/* calibrate_vcrit.csv: every search's v_crit per size; calibrate.csv: the calibrated pair (the format of the
 * other method's). */
static int write_csvs(const struct vcrit_fit *f)
{
    char path[4200];
    struct atomic_file out;
    snprintf(path, sizeof path, "%s/calibrate_vcrit.csv", f->ctx->run_dir);
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "search,%s,%s,diameter,v_crit,target,mean_residual\n", f->name[0], f->name[1]);
    for (int k = 0; k < f->count; k++)
        for (int i = 0; i < f->size_count; i++)
            fprintf(out.stream, "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", k + 1, f->p[k], f->rate[k], f->diameter[i],
                    f->v[k][i], f->target[i], f->residual[k]);
    SC_TRY(atomic_publish(&out));
    snprintf(path, sizeof path, "%s/calibrate.csv", f->ctx->run_dir);
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "%s,%s,calibrated\n", f->name[0], f->name[1]);
    if (isfinite(f->calibrated))
        fprintf(out.stream, "%.17g,%.17g,1\n", f->calibrated, f->kept);
    if (isfinite(f->calibrated) && f->note[0])
        fprintf(out.stream, "# %s\n", f->note);
    else if (!isfinite(f->calibrated))
        fprintf(out.stream, "# no calibrated value: %s\n", f->note);
    return atomic_publish(&out);
}

static int side_csvs(void *owner)
{
    return write_csvs(owner);
}

/* calibrate.h5 (docs/files.md): method "vcrit", the pair, the range and /vcrit_fit with every search. */
static int output_contents(void *owner, hid_t file)
{
    const struct vcrit_fit *f = owner;
    char key[40];
    SC_TRY(h5_attr_write_string(file, "method", "vcrit"));
    SC_TRY(h5_attr_write_string(file, "bonding", strcmp(f->name[0], "eps_c") == 0 ? "strain" : "energy"));
    SC_TRY(h5_attr_write_double(file, f->name[0], f->calibrated));
    /* with rate = fitted and no pair, the rate last tried is not a result */
    SC_TRY(h5_attr_write_double(file, f->name[1], f->fit_rate && !isfinite(f->calibrated) ? NAN : f->kept));
    snprintf(key, sizeof key, "%s_min", f->name[0]);
    SC_TRY(h5_attr_write_double(file, key, f->lo));
    snprintf(key, sizeof key, "%s_max", f->name[0]);
    SC_TRY(h5_attr_write_double(file, key, f->hi));
    SC_TRY(h5_attr_write_double(file, "fit_tolerance", f->tolerance));
    SC_TRY(h5_attr_write_string(file, "rate", f->fit_rate ? "fitted" : "kept"));
    if (f->fit_rate) {
        snprintf(key, sizeof key, "%s_min", f->name[1]);
        SC_TRY(h5_attr_write_double(file, key, f->rate_lo));
        snprintf(key, sizeof key, "%s_max", f->name[1]);
        SC_TRY(h5_attr_write_double(file, key, f->rate_hi));
        SC_TRY(h5_attr_write_double(file, "fit_spread_tolerance", f->spread_tolerance));
    }
    SC_TRY(h5_attr_write_string(file, "result", f->note[0] ? f->note : "calibrated"));
    hid_t group;
    SC_TRY(h5_create_group(file, "vcrit_fit", &group));
    double v[MAX_EVALUATIONS * MAX_SIZES];
    for (int k = 0; k < f->count; k++)
        for (int i = 0; i < f->size_count; i++)
            v[k * f->size_count + i] = f->v[k][i];
    hsize_t sizes[1] = {(hsize_t)f->size_count}, searches[1] = {(hsize_t)f->count},
            both[2] = {(hsize_t)f->count, (hsize_t)f->size_count};
    int status;
    SC_CHECK(status, h5_write_doubles(group, "diameter", 1, sizes, f->diameter, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "target", 1, sizes, f->target, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "parameter", 1, searches, f->p, f->unit[0], 0), done);
    SC_CHECK(status, h5_write_doubles(group, "second_parameter", 1, searches, f->rate, f->unit[1], 0), done);
    SC_CHECK(status, h5_write_doubles(group, "mean_residual", 1, searches, f->residual, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "v_crit", 2, both, v, "m/s", 0), done);
    SC_CHECK(status, h5_attr_write_string(group, "parameter_name", f->name[0]), done);
    if (f->fit_rate) { /* each fit of the first parameter: its second, its value (NaN: none) and spread residual */
        hsize_t fits[1] = {(hsize_t)f->rate_fits};
        SC_CHECK(status, h5_write_doubles(group, "fit_second_parameter", 1, fits, f->fit_rate_value, f->unit[1], 0),
                 done);
        SC_CHECK(status, h5_write_doubles(group, "fit_first_parameter", 1, fits, f->fitted, f->unit[0], 0), done);
        SC_CHECK(status, h5_write_doubles(group, "spread_residual", 1, fits, f->spread_residual, "m/s", 0), done);
    }
done:
    H5Gclose(group);
    return status;
}

int calibrate_vcrit_validate(const struct stage_context *ctx)
{
    struct vcrit_fit f = {.ctx = ctx};
    SC_TRY(load(ctx, &f));
    struct case_file *run;
    SC_TRY(search_case(&f, f.lo, &run)); /* the searches' [vcrit] and [impact] */
    const struct stage_context search = {.c = run};
    int status = vcrit_stage_validate(&search);
    case_free(run);
    return status;
}

int calibrate_vcrit_run(const struct stage_context *ctx, uint64_t case_hash)
{
    struct vcrit_fit f = {.ctx = ctx, .case_hash = case_hash};
    SC_TRY(load(ctx, &f));
    double start = log_elapsed();
    SC_TRY(fit(&f));
    if (parallel_rank() != 0)
        return SC_OK;
    char path[4200];
    snprintf(path, sizeof path, "%s/calibrate.h5", ctx->run_dir);
    /* the CSVs as calibrate.h5's side files: never beside another case's calibrate.h5 (app.h) */
    SC_TRY(stage_write_outputs(path, FORMAT, FORMAT_VERSION, STAGE, case_hash, ctx->c, output_contents, side_csvs, &f));
    if (isfinite(f.calibrated))
        log_info("calibrate: calibrated %s = %.6g %s (%s = %.6g %s %s) after %d searches, %.1f s%s%s", f.name[0],
                 f.calibrated, f.unit[0], f.name[1], f.kept, f.unit[1], f.fit_rate ? "fitted" : "kept", f.count,
                 log_elapsed() - start, f.note[0] ? ": " : "", f.note);
    else
        log_warn("calibrate: no calibrated %s: %s", f.name[0], f.note);
    return SC_OK;
}
