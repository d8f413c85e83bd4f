/* The calibration figures (RUN_DIR/calibrate.h5, app/calibrate_stage.c): per size the outcomes over the grid of the
 * bonding model's two parameters (energy: Gc, Gc_rate; strain: eps_c, eps_rate_c) with the bonding boundary h = 0.5
 * (Tang 2021 Fig. 4.4 a, b), and both boundaries with their intersection, the calibrated pair (Fig. 4.4 c, Fig. 5.1).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "render/render_impl.h"

#define MAX_SIZES 2 /* the figures show the first two sizes: the two of the calibration */

/* A model's two parameters: their names in calibrate.h5, axis labels, and the unit the second is drawn in. */
struct calibrate_axes {
    const char *model, *name[2], *label[2], *log_label; /* log_label: the second's, rate_axis = log */
    double rate_unit;
};
static const struct calibrate_axes model_axes[] = {
    {"energy",
     {"Gc", "Gc_rate"},
     {"critical adhesion energy Gc (J/m²)", "critical adhesion energy rate Gc_rate (10^11 J/m²/s)"},
     "log10 of the critical adhesion energy rate Gc_rate in J/m²/s",
     1e11},
    {"strain",
     {"eps_c", "eps_rate_c"},
     {"critical bonding strain eps_c", "critical bonding strain rate eps_rate_c (10^9 1/s)"},
     "log10 of the critical bonding strain rate eps_rate_c in 1/s",
     1e9},
};

struct calibrate_data {
    struct render_array d, gc, rate,
        verdict; /* /runs; as the fit counted it (1 success, 0 not, 2 unsettled, 3 failed) */
    int adhered; /* [calibrate] outcome = adhered: held runs counted as successes */
    struct render_array boundary_gc[MAX_SIZES], boundary_rate[MAX_SIZES];
    struct render_array cross_gc, cross_rate;
    double diameter[MAX_SIZES], velocity[MAX_SIZES];
    int sizes;
    const struct calibrate_axes *axes;
    int rate_log;           /* rate_axis = log: the second parameter drawn as its log10 */
    const char *rate_label; /* the second parameter's axis label */
};

/* A value of the second parameter as drawn. */
static double rate_drawn(const struct calibrate_data *c, double value)
{
    return c->rate_log ? log10(value) : value / c->axes->rate_unit;
}

static void data_free(struct calibrate_data *c)
{
    render_array_free(&c->d), render_array_free(&c->gc), render_array_free(&c->rate);
    render_array_free(&c->verdict), render_array_free(&c->cross_gc), render_array_free(&c->cross_rate);
    for (int i = 0; i < MAX_SIZES; i++)
        render_array_free(&c->boundary_gc[i]), render_array_free(&c->boundary_rate[i]);
}

static int read_size(hid_t file, const char *path, int i, struct calibrate_data *c)
{
    hid_t g;
    if (!h5_numbered_group(file, "size", (size_t)i, &g))
        return SC_OK;
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s: cannot open /size/%03d", path, i);
    int status;
    SC_CHECK(status, h5_attr_read_double(g, "diameter", &c->diameter[i]), done);
    SC_CHECK(status, h5_attr_read_double(g, "velocity", &c->velocity[i]), done);
    char first[48], second[48];
    snprintf(first, sizeof first, "boundary_%s", c->axes->name[0]);
    snprintf(second, sizeof second, "boundary_%s", c->axes->name[1]);
    if (h5_exists(g, first)) {
        SC_CHECK(status, render_read_array(g, path, first, &c->boundary_gc[i]), done);
        SC_CHECK(status, render_read_array(g, path, second, &c->boundary_rate[i]), done);
        for (size_t k = 0; k < c->boundary_rate[i].count; k++)
            c->boundary_rate[i].values[k] = rate_drawn(c, c->boundary_rate[i].values[k]);
    }
    c->sizes = i + 1;
done:
    H5Gclose(g);
    return status;
}

static int read_data(const char *path, struct calibrate_data *c)
{
    hid_t file;
    SC_TRY(render_open(path, &file));
    int status = SC_OK;
    char model[32] = "energy", name[4][48]; /* files written before strain calibrations have no "bonding" */
    if (H5Aexists(file, "bonding") > 0)
        SC_CHECK(status, h5_attr_read_string(file, "bonding", model, sizeof model), done);
    c->axes = NULL;
    for (size_t i = 0; i < sizeof model_axes / sizeof model_axes[0]; i++)
        if (strcmp(model, model_axes[i].model) == 0)
            c->axes = &model_axes[i];
    if (!c->axes)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: unknown bonding model \"%s\"", path, model);
    char axis[16] = "linear";
    if (H5Aexists(file, "rate_axis") > 0)
        SC_CHECK(status, h5_attr_read_string(file, "rate_axis", axis, sizeof axis), done);
    c->rate_log = strcmp(axis, "log") == 0;
    c->rate_label = c->rate_log ? c->axes->log_label : c->axes->label[1];
    snprintf(name[0], sizeof name[0], "runs/%s", c->axes->name[0]);
    snprintf(name[1], sizeof name[1], "runs/%s", c->axes->name[1]);
    snprintf(name[2], sizeof name[2], "intersection_%s", c->axes->name[0]);
    snprintf(name[3], sizeof name[3], "intersection_%s", c->axes->name[1]);
    SC_CHECK(status, render_read_array(file, path, "runs/diameter", &c->d), done);
    SC_CHECK(status, render_read_array(file, path, name[0], &c->gc), done);
    SC_CHECK(status, render_read_array(file, path, name[1], &c->rate), done);
    /* as the fit counted them ([calibrate] outcome); files written before it have the verdicts only */
    SC_CHECK(
        status,
        render_read_array(file, path, h5_exists(file, "runs/counted") ? "runs/counted" : "runs/verdict", &c->verdict),
        done);
    char outcome[16] = "bonded";
    if (H5Aexists(file, "outcome") > 0)
        SC_CHECK(status, h5_attr_read_string(file, "outcome", outcome, sizeof outcome), done);
    c->adhered = strcmp(outcome, "adhered") == 0;
    SC_CHECK(status, render_read_array(file, path, name[2], &c->cross_gc), done);
    SC_CHECK(status, render_read_array(file, path, name[3], &c->cross_rate), done);
    for (int i = 0; i < MAX_SIZES; i++)
        SC_CHECK(status, read_size(file, path, i, c), done);
    if (c->gc.count != c->d.count || c->rate.count != c->d.count || c->verdict.count != c->d.count)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: the datasets of /runs have different lengths", path);
    for (size_t k = 0; k < c->rate.count; k++)
        c->rate.values[k] = rate_drawn(c, c->rate.values[k]);
    for (size_t k = 0; k < c->cross_rate.count; k++)
        c->cross_rate.values[k] = rate_drawn(c, c->cross_rate.values[k]);
done:
    H5Fclose(file);
    return status;
}

/* The runs of size i with verdict v into x, y; returns their number. */
static size_t select_runs(const struct calibrate_data *c, int i, int v, double *x, double *y)
{
    size_t n = 0;
    for (size_t k = 0; k < c->d.count; k++)
        if (c->d.values[k] == c->diameter[i] && (int)c->verdict.values[k] == v)
            x[n] = c->gc.values[k], y[n++] = c->rate.values[k];
    return n;
}

/* Fig. 4.4 a, b: per size the bonded, rebounded, unsettled and failed runs (as /runs/counted counts them: 0, 1, 2,
 * 3; enum vcrit_verdict) and the fitted boundary. */
#define COUNTED_KINDS 4
static int sizes_plot(const struct render_request *req, const struct calibrate_data *c, struct render_output *out)
{
    static const char *const bonded_labels[] = {"rebounded", "bonded", "unsettled", "failed (NaN or blow-up)"};
    static const char *const adhered_labels[] = {"left", "adhered (bonded or held)", "unsettled",
                                                 "failed (NaN or blow-up)"};
    const char *const *labels = c->adhered ? adhered_labels : bonded_labels;
    static const enum render_series_kind kinds[] = {RENDER_OPEN_MARKERS, RENDER_MARKERS, RENDER_OPEN_MARKERS,
                                                    RENDER_OPEN_MARKERS};
    static const int colours[] = {6, 2, 4, 5};
    size_t m = c->d.count, bytes = (2 * COUNTED_KINDS * m * (size_t)c->sizes + 1) * sizeof(double);
    double *blocks = malloc(bytes); /* per panel and verdict: x (m values), then y COUNTED_KINDS blocks later */
    if (!blocks)
        SC_FAIL_OOM(bytes, "the calibration figure");
    struct render_series series[MAX_SIZES][COUNTED_KINDS + 1];
    char titles[MAX_SIZES][96];
    struct render_plot plot = render_plot_start(req->cfg, c->sizes);
    for (int i = 0; i < c->sizes; i++) {
        for (int v = 0; v < COUNTED_KINDS; v++) {
            double *x = blocks + ((size_t)i * 2 * COUNTED_KINDS + (size_t)v) * m, *y = x + COUNTED_KINDS * m;
            size_t n = select_runs(c, i, v, x, y);
            /* a kind no run has stays out of the legend (files before failed runs were counted have none) */
            series[i][v] = (struct render_series){n || v < 3 ? labels[v] : NULL, kinds[v], n, x, y, 0, colours[v]};
        }
        series[i][COUNTED_KINDS] = (struct render_series){"boundary h = 0.5",
                                                          RENDER_LINE,
                                                          c->boundary_gc[i].count,
                                                          c->boundary_gc[i].values,
                                                          c->boundary_rate[i].values,
                                                          0,
                                                          0};
        snprintf(titles[i], sizeof titles[i], "%.3g µm at %.4g m/s", c->diameter[i] * 1e6, c->velocity[i]);
        plot.panels[i] = (struct render_panel){titles[i], c->axes->label[0], c->rate_label, NAN, NAN, NAN, NAN,
                                               0,         COUNTED_KINDS + 1, series[i]};
    }
    int status = render_plot_publish(req->run_dir, out, "calibrate_sizes", "calibrate",
                                     "Calibration outcomes and bonding boundaries", &plot);
    free(blocks);
    return status;
}

/* Fig. 4.4 c, Fig. 5.1: both boundaries and their intersection. */
static int boundaries_plot(const struct render_request *req, const struct calibrate_data *c, struct render_output *out)
{
    char labels[MAX_SIZES][64];
    struct render_series series[MAX_SIZES + 1];
    int n = 0;
    for (int i = 0; i < c->sizes; i++) {
        snprintf(labels[i], sizeof labels[i], "boundary %.3g µm", c->diameter[i] * 1e6);
        series[n++] = (struct render_series){
            labels[i], RENDER_LINE,   c->boundary_gc[i].count, c->boundary_gc[i].values, c->boundary_rate[i].values,
            0,         i == 0 ? 0 : 1};
    }
    series[n++] = (struct render_series){"intersection (first: calibrated)",
                                         RENDER_MARKERS,
                                         c->cross_gc.count,
                                         c->cross_gc.values,
                                         c->cross_rate.values,
                                         0,
                                         5};
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){"Bonding boundaries and the calibrated parameters",
                                           c->axes->label[0],
                                           c->rate_label,
                                           NAN,
                                           NAN,
                                           NAN,
                                           NAN,
                                           0,
                                           n,
                                           series};
    return render_plot_publish(req->run_dir, out, "calibrate", "calibrate", plot.panels[0].title, &plot);
}

/* [calibrate] method = vcrit, rate = fitted: each fit of the first parameter's spread residual, (v_crit of the first
 * size - of the last) - (their targets' difference), against the second parameter on a log scale, with the
 * tolerance band and the calibrated rate. */
#define FIT_SEARCHES 100 /* app/calibrate_vcrit.c MAX_EVALUATIONS */
struct spread_panel {
    struct render_array rate, residual;
    double x[FIT_SEARCHES], y[FIT_SEARCHES], band_x[2], band_lo[2], band_hi[2], cal_x[2], cal_y[2];
    struct render_series series[4];
    char xlabel[96];
};

static int spread_panel_read(hid_t file, hid_t g, const char *path, const struct calibrate_axes *axes,
                             struct spread_panel *s, struct render_panel *panel)
{
    SC_TRY(render_read_array(g, path, "fit_second_parameter", &s->rate));
    SC_TRY(render_read_array(g, path, "spread_residual", &s->residual));
    if (s->rate.count != s->residual.count)
        SC_FAIL(SC_EIO, "render: %s: /vcrit_fit fit sizes do not agree", path);
    double tolerance = NAN, calibrated = NAN, lo = INFINITY, hi = -INFINITY;
    h5_attr_read_double(file, "fit_spread_tolerance", &tolerance);
    h5_attr_read_double(file, axes->name[1], &calibrated);
    size_t n = s->rate.count < FIT_SEARCHES ? s->rate.count : FIT_SEARCHES;
    for (size_t k = 0; k < n; k++) {
        s->x[k] = s->rate.values[k] > 0 ? log10(s->rate.values[k]) : NAN, s->y[k] = s->residual.values[k];
        if (isfinite(s->x[k]))
            lo = fmin(lo, s->x[k]), hi = fmax(hi, s->x[k]);
    }
    s->band_x[0] = lo - 0.1, s->band_x[1] = hi + 0.1;
    s->band_lo[0] = s->band_lo[1] = -tolerance, s->band_hi[0] = s->band_hi[1] = tolerance;
    int have_cal = isfinite(calibrated) && calibrated > 0;
    s->cal_x[0] = s->cal_x[1] = have_cal ? log10(calibrated) : NAN;
    s->cal_y[0] = -3 * tolerance, s->cal_y[1] = 3 * tolerance;
    s->series[0] = (struct render_series){"each fit of the first parameter", RENDER_MARKERS, n, s->x, s->y, 0, 0};
    s->series[1] = (struct render_series){"fit_spread_tolerance", RENDER_DASHED, 2, s->band_x, s->band_lo, 0, 7};
    s->series[2] = (struct render_series){NULL, RENDER_DASHED, 2, s->band_x, s->band_hi, 0, 7};
    s->series[3] = (struct render_series){
        have_cal ? "calibrated" : NULL, RENDER_LINE, have_cal ? 2u : 0u, s->cal_x, s->cal_y, 0, 6};
    snprintf(s->xlabel, sizeof s->xlabel, "%s", axes->log_label);
    *panel = (struct render_panel){"Spread residual of each fit vs the second parameter",
                                   s->xlabel,
                                   "spread residual (m/s)",
                                   NAN,
                                   NAN,
                                   NAN,
                                   NAN,
                                   1,
                                   4,
                                   s->series};
    return SC_OK;
}

static const struct calibrate_axes *axes_of_file(hid_t file)
{
    char bonding[32] = "strain";
    h5_attr_read_string(file, "bonding", bonding, sizeof bonding);
    return strcmp(bonding, "energy") == 0 ? &model_axes[0] : &model_axes[1];
}

/* [calibrate] method = vcrit (app/calibrate_vcrit.c): each size's v_crit against the fitted parameter, one marker
 * per search (open: a search at another second parameter than the calibrated one, rate = fitted), with its measured
 * target as a line across, and the calibrated value as a line up; with rate = fitted a second panel of the fits'
 * spread residuals. */
#define FIT_SIZES 8
static int vcrit_fit_plot(const struct render_request *req, hid_t file, const char *path, struct render_output *out)
{
    struct render_array d, target, p, v, second;
    memset(&d, 0, sizeof d), memset(&target, 0, sizeof target), memset(&p, 0, sizeof p), memset(&v, 0, sizeof v);
    memset(&second, 0, sizeof second);
    struct spread_panel spread;
    memset(&spread, 0, sizeof spread);
    char name[32] = "parameter", label[96], rate[16] = "kept";
    double calibrated = NAN, calibrated_rate = NAN;
    int status;
    hid_t g = H5Gopen2(file, "vcrit_fit", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s has no group vcrit_fit (not a complete spraycoat output?)", path);
    const struct calibrate_axes *axes = axes_of_file(file);
    SC_CHECK(status, render_read_array(g, path, "diameter", &d), done);
    SC_CHECK(status, render_read_array(g, path, "target", &target), done);
    SC_CHECK(status, render_read_array(g, path, "parameter", &p), done);
    SC_CHECK(status, render_read_array(g, path, "v_crit", &v), done);
    h5_attr_read_string(g, "parameter_name", name, sizeof name);
    h5_attr_read_double(file, name, &calibrated);
    h5_attr_read_string(file, "rate", rate, sizeof rate);
    int fitted_rate = strcmp(rate, "fitted") == 0;
    if (fitted_rate) {
        SC_CHECK(status, render_read_array(g, path, "second_parameter", &second), done);
        h5_attr_read_double(file, axes->name[1], &calibrated_rate);
    }
    size_t n = d.count < FIT_SIZES ? d.count : FIT_SIZES, m = p.count;
    if (v.count != n * m || target.count != d.count || (fitted_rate && second.count != m))
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: /vcrit_fit sizes do not agree", path);
    double at[FIT_SIZES][FIT_SEARCHES], other[FIT_SIZES][FIT_SEARCHES], lx[FIT_SIZES][2], ly[FIT_SIZES][2];
    double px[2] = {calibrated, calibrated}, py[2];
    char labels[FIT_SIZES][48];
    struct render_series series[3 * FIT_SIZES + 1];
    double lo = INFINITY, hi = -INFINITY, pmin = INFINITY, pmax = -INFINITY;
    for (size_t k = 0; k < m; k++)
        pmin = fmin(pmin, p.values[k]), pmax = fmax(pmax, p.values[k]);
    size_t shown = m < FIT_SEARCHES ? m : FIT_SEARCHES;
    for (size_t i = 0; i < n; i++) {
        for (size_t k = 0; k < shown; k++) {
            double vk = v.values[k * d.count + i];
            int at_calibrated = !fitted_rate || !isfinite(calibrated_rate) || second.values[k] == calibrated_rate;
            at[i][k] = at_calibrated ? vk : NAN, other[i][k] = at_calibrated ? NAN : vk;
            lo = fmin(lo, vk), hi = fmax(hi, vk);
        }
        lx[i][0] = pmin, lx[i][1] = pmax, ly[i][0] = ly[i][1] = target.values[i];
        lo = fmin(lo, target.values[i]), hi = fmax(hi, target.values[i]);
        snprintf(labels[i], sizeof labels[i], "%.3g µm (dashed: measured)", d.values[i] * 1e6);
        series[3 * i] = (struct render_series){labels[i], RENDER_MARKERS, shown, p.values, at[i], 0, (int)i % 8};
        series[3 * i + 1] = (struct render_series){NULL, RENDER_OPEN_MARKERS, shown, p.values, other[i], 0, (int)i % 8};
        series[3 * i + 2] = (struct render_series){NULL, RENDER_DASHED, 2, lx[i], ly[i], 0, (int)i % 8};
    }
    py[0] = lo, py[1] = hi;
    series[3 * n] = (struct render_series){
        isfinite(calibrated) ? "calibrated" : NULL, RENDER_LINE, isfinite(calibrated) ? 2u : 0u, px, py, 0, 6};
    snprintf(label, sizeof label, "%s ([impact] bonding parameter)", name);
    struct render_plot plot = render_plot_start(req->cfg, fitted_rate ? 2 : 1);
    plot.panels[0] = (struct render_panel){fitted_rate ? "v_crit of each search (open: at another rate)"
                                                       : "Critical velocity of each search vs the fitted parameter",
                                           label,
                                           "critical velocity v_crit (m/s)",
                                           NAN,
                                           NAN,
                                           NAN,
                                           hi + (hi - lo),
                                           0,
                                           3 * (int)n + 1,
                                           series};
    if (fitted_rate)
        SC_CHECK(status, spread_panel_read(file, g, path, axes, &spread, &plot.panels[1]), done);
    SC_CHECK(status,
             render_plot_publish(req->run_dir, out, "calibrate_vcrit", "calibrate", plot.panels[0].title, &plot), done);
done:
    H5Gclose(g);
    render_array_free(&d), render_array_free(&target), render_array_free(&p), render_array_free(&v);
    render_array_free(&second), render_array_free(&spread.rate), render_array_free(&spread.residual);
    return status;
}

int render_calibrate_figures(const struct render_request *req, struct render_output *out)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/calibrate.h5", req->run_dir);
    char method[32] = "boundaries";
    hid_t file;
    SC_TRY(render_open(path, &file));
    if (H5Aexists(file, "method") > 0)
        h5_attr_read_string(file, "method", method, sizeof method);
    if (strcmp(method, "vcrit") == 0) {
        int fit_status = vcrit_fit_plot(req, file, path, out);
        H5Fclose(file);
        if (fit_status == SC_OK)
            log_info("render: calibration figure from %s", path);
        return fit_status;
    }
    H5Fclose(file);
    struct calibrate_data c;
    memset(&c, 0, sizeof c);
    int status;
    SC_CHECK(status, read_data(path, &c), done);
    if (c.sizes > 0)
        SC_CHECK(status, sizes_plot(req, &c, out), done);
    SC_CHECK(status, boundaries_plot(req, &c, out), done);
    log_info("render: calibration figures from %s", path);
done:
    data_free(&c);
    return status;
}
