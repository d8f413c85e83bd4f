/* The critical-velocity figures (RUN_DIR/vcrit.h5): v_crit vs diameter, every run of the search, and the thesis's
 * predictions for comparison; the coefficient of restitution against impact speed per diameter (every run). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "render/render_impl.h"

/* Tang (2021), Table 5.4: predicted critical velocities of Al on Al (grid 1.5/0.5). */
static const double tang_diameter_um[] = {14, 18, 22, 26, 30};
static const double tang_vcrit[] = {824, 809, 791, 776, 761};
/* Hassani-Gangaraj et al. (2018), LIPIT of Al on Al, +-2 % (docs/references.md): measured critical velocities. */
static const double measured_diameter_um[] = {14, 30};
static const double measured_vcrit[] = {810, 770};

struct search_runs {
    size_t count, capacity;
    double *d, *v, *cor;    /* um, m/s, - (NaN when the file has no cor) */
    int *verdict;           /* 1 bonded, 0 rebounded, 2 unsettled (enum vcrit_verdict's values in vcrit.h5), 3 held */
    double vrest_threshold; /* [impact] vrest_threshold: a rebounded run slower than it is held */
    /* error bars of logistic fits: per search, (d, v_crit - se), (d, v_crit + se), (NaN, NaN): a line with gaps */
    size_t bar_count, bar_capacity;
    double *bar_x, *bar_y;
};

#define RUN_REBOUNDED 0
#define RUN_BONDED    1
#define RUN_UNSETTLED 2
#define RUN_HELD      3 /* rebounded by the verdict but at rest: too few bonded points (mpm_verdict_held) */

/* *array resized to capacity doubles; 0 (the array as it was) when memory ran out. */
static int grow(double **array, size_t capacity)
{
    double *resized = realloc(*array, capacity * sizeof *resized);
    if (resized)
        *array = resized;
    return resized != NULL;
}

static int add_run(struct search_runs *r, double d, double v, int verdict, double cor)
{
    if (r->count == r->capacity) {
        size_t capacity = r->capacity ? 2 * r->capacity : 64;
        int grown = grow(&r->d, capacity) & grow(&r->v, capacity) & grow(&r->cor, capacity);
        int *b2 = realloc(r->verdict, capacity * sizeof *b2);
        if (b2)
            r->verdict = b2;
        if (!grown || !b2)
            SC_FAIL_OOM(capacity * (3 * sizeof(double) + sizeof *b2), "the critical-velocity runs");
        r->capacity = capacity;
    }
    r->d[r->count] = d, r->v[r->count] = v, r->cor[r->count] = cor, r->verdict[r->count++] = verdict;
    return SC_OK;
}

/* The +-1 standard error bar of a search's logistic v_crit (attributes v_crit, v_crit_se; none for a bisection or
 * a separable fit, whose se is not finite and positive). */
static int add_error_bar(struct search_runs *r, hid_t group, double d_um)
{
    double v, se;
    if (H5Aexists(group, "v_crit_se") <= 0 || h5_attr_read_double(group, "v_crit_se", &se) != SC_OK ||
        h5_attr_read_double(group, "v_crit", &v) != SC_OK || !(se > 0 && isfinite(se) && isfinite(v)))
        return SC_OK;
    if (r->bar_count + 3 > r->bar_capacity) {
        size_t capacity = r->bar_capacity ? 2 * r->bar_capacity : 48;
        if (!(grow(&r->bar_x, capacity) & grow(&r->bar_y, capacity)))
            SC_FAIL_OOM(2 * capacity * sizeof(double), "the error bars of the critical-velocity figure");
        r->bar_capacity = capacity;
    }
    const double x[3] = {d_um, d_um, NAN}, y[3] = {v - se, v + se, NAN};
    memcpy(r->bar_x + r->bar_count, x, sizeof x);
    memcpy(r->bar_y + r->bar_count, y, sizeof y);
    r->bar_count += 3;
    return SC_OK;
}

static herr_t read_search_group(hid_t parent, const char *name, const H5L_info_t *info, void *data)
{
    (void)info;
    struct search_runs *runs = data;
    hid_t g = H5Gopen2(parent, name, H5P_DEFAULT);
    double d;
    struct render_array v, verdict, cor, v_rest;
    memset(&v, 0, sizeof v), memset(&verdict, 0, sizeof verdict), memset(&cor, 0, sizeof cor);
    memset(&v_rest, 0, sizeof v_rest);
    if (g < 0)
        return -1;
    int status;
    SC_CHECK(status, h5_attr_read_double(g, "diameter", &d), done);
    SC_CHECK(status, add_error_bar(runs, g, d * 1e6), done);
    SC_CHECK(status, render_read_array(g, "vcrit.h5", "velocity", &v), done);
    /* the verdicts with the unsettled runs told apart; files before settled verdicts have only bonded (0/1) */
    SC_CHECK(status, render_read_array(g, "vcrit.h5", h5_exists(g, "verdict") ? "verdict" : "bonded", &verdict), done);
    if (h5_exists(g, "cor")) /* files of versions before CoR have none */
        SC_CHECK(status, render_read_array(g, "vcrit.h5", "cor", &cor), done);
    if (h5_exists(g, "v_rest"))
        SC_CHECK(status, render_read_array(g, "vcrit.h5", "v_rest", &v_rest), done);
    for (size_t i = 0; i < v.count && i < verdict.count; i++) {
        int run = (int)verdict.values[i];
        if (run == RUN_REBOUNDED && i < v_rest.count && v_rest.values[i] <= runs->vrest_threshold)
            run = RUN_HELD;
        SC_CHECK(status, add_run(runs, d * 1e6, v.values[i], run, i < cor.count ? cor.values[i] : NAN), done);
    }
done:
    render_array_free(&v), render_array_free(&verdict), render_array_free(&cor), render_array_free(&v_rest);
    H5Gclose(g);
    return status == SC_OK ? 0 : -1;
}

static int read_search(hid_t file, const char *path, struct search_runs *runs)
{
    if (!h5_exists(file, "search"))
        return SC_OK;
    hid_t g = H5Gopen2(file, "search", H5P_DEFAULT);
    herr_t ok = g < 0 ? -1 : H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, NULL, read_search_group, runs);
    if (g >= 0)
        H5Gclose(g);
    if (ok < 0)
        SC_FAIL(SC_EIO, "render: %s: cannot read the runs in /search", path);
    return SC_OK;
}

/* The top of the v_crit axis: 1.2 times the data's range above it, so that the legend in the top corner (up to 9
 * rows, about 40 % of the frame's height) covers no point. */
static double legend_headroom(const struct render_array *v, const struct search_runs *runs)
{
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < v->count; i++)
        lo = fmin(lo, v->values[i]), hi = fmax(hi, v->values[i]);
    for (size_t i = 0; i < runs->count; i++)
        lo = fmin(lo, runs->v[i]), hi = fmax(hi, runs->v[i]);
    for (size_t i = 0; i < sizeof tang_vcrit / sizeof tang_vcrit[0]; i++)
        lo = fmin(lo, tang_vcrit[i]), hi = fmax(hi, tang_vcrit[i]);
    return hi > lo ? hi + 1.2 * (hi - lo) : NAN;
}

static int vcrit_plot(const struct render_request *req, const struct render_array *d, const struct render_array *v,
                      const struct search_runs *runs, struct render_output *out)
{
    size_t n = d->count, m = runs->count, nb = 0, nr = 0, nu = 0, nh = 0;
    double *buffer = malloc((n + 8 * m + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((n + 8 * m + 1) * sizeof *buffer, "the critical-velocity figure");
    double *d_um = buffer, *bd = buffer + n, *bv = bd + m, *rd = bv + m, *rv = rd + m, *ud = rv + m, *uv = ud + m,
           *hd = uv + m, *hv = hd + m;
    for (size_t i = 0; i < n; i++)
        d_um[i] = d->values[i] * 1e6;
    for (size_t i = 0; i < m; i++) { /* an unsettled run is neither bonded nor rebounded: a series of its own */
        if (runs->verdict[i] == RUN_BONDED)
            bd[nb] = runs->d[i], bv[nb++] = runs->v[i];
        else if (runs->verdict[i] == RUN_UNSETTLED)
            ud[nu] = runs->d[i], uv[nu++] = runs->v[i];
        else if (runs->verdict[i] == RUN_HELD)
            hd[nh] = runs->d[i], hv[nh++] = runs->v[i];
        else
            rd[nr] = runs->d[i], rv[nr++] = runs->v[i];
    }
    /* the runs first, so that the curve, its error bars and the published points are drawn over them */
    struct render_series series[] = {
        {"runs: bonded", RENDER_MARKERS, nb, bd, bv, 0, 2},
        {"runs: rebounded", RENDER_OPEN_MARKERS, nr, rd, rv, 0, 6},
        {"runs: unsettled", RENDER_OPEN_MARKERS, nu, ud, uv, 0, 3},
        {"runs: held (at rest, too little bonded)", RENDER_OPEN_MARKERS, nh, hd, hv, 0, 4},
        {"v_crit (this run)", RENDER_LINE, n, d_um, v->values, 0, 0},
        {NULL, RENDER_MARKERS, n, d_um, v->values, 0, 0},
        {runs->bar_count ? "v_crit ± standard error (logistic fit)" : NULL, RENDER_LINE, runs->bar_count, runs->bar_x,
         runs->bar_y, 0, 6},
        {"Tang (2021) Table 5.4", RENDER_OPEN_MARKERS, 5, tang_diameter_um, tang_vcrit, 0, 1},
        {"measured, Al on Al (Hassani-Gangaraj 2018)", RENDER_MARKERS, 2, measured_diameter_um, measured_vcrit, 0, 5},
    };
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){"Critical velocity vs particle diameter",
                                           "diameter d (µm)",
                                           "critical velocity v_crit (m/s)",
                                           NAN,
                                           NAN,
                                           NAN,
                                           NAN,
                                           0,
                                           9,
                                           series};
    plot.panels[0].ymax = legend_headroom(v, runs);
    int status;
    SC_CHECK(status, render_plot_publish(req->run_dir, out, "vcrit", "vcrit", plot.panels[0].title, &plot), done);
done:
    free(buffer);
    return status;
}

/* CoR against impact speed: one marker series per diameter (the runs of a diameter are consecutive). */
#define COR_DIAMETERS 16
static int cor_plot(const struct render_request *req, const struct search_runs *runs, struct render_output *out)
{
    struct render_series series[COR_DIAMETERS];
    char labels[COR_DIAMETERS][32];
    int n = 0;
    for (size_t i = 0; i < runs->count && n < COR_DIAMETERS;) {
        size_t j = i;
        while (j < runs->count && runs->d[j] == runs->d[i])
            j++;
        snprintf(labels[n], sizeof labels[n], "%.3g µm", runs->d[i]);
        series[n] = (struct render_series){labels[n], RENDER_MARKERS, j - i, runs->v + i, runs->cor + i, 0, n % 8};
        n++;
        i = j;
    }
    struct render_plot plot = render_plot_start(req->cfg, 1);
    const char *title = "Coefficient of restitution vs impact speed";
    plot.panels[0] = (struct render_panel){
        title, "impact speed (m/s)", "coefficient of restitution (normal)", NAN, NAN, NAN, NAN, 1, n, series};
    return render_plot_publish(req->run_dir, out, "vcrit_cor", "vcrit", plot.panels[0].title, &plot);
}

int render_vcrit_figures(const struct render_request *req, struct render_output *out)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/vcrit.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(path, &file));
    struct render_array d, v;
    struct search_runs runs = {0};
    runs.vrest_threshold = case_real(req->c, "impact", "vrest_threshold");
    memset(&d, 0, sizeof d), memset(&v, 0, sizeof v);
    int status;
    SC_CHECK(status, render_read_array(file, path, "diameter", &d), done);
    SC_CHECK(status, render_read_array(file, path, "v_crit", &v), done);
    if (v.count != d.count)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: /diameter and /v_crit of different lengths", path);
    SC_CHECK(status, read_search(file, path, &runs), done);
    H5Fclose(file);
    file = H5I_INVALID_HID;
    SC_CHECK(status, vcrit_plot(req, &d, &v, &runs, out), done);
    SC_CHECK(status, cor_plot(req, &runs, out), done);
    log_info("render: vcrit figures from %s", path);
done:
    if (file >= 0)
        H5Fclose(file);
    render_array_free(&d), render_array_free(&v);
    free(runs.d), free(runs.v), free(runs.verdict), free(runs.cor), free(runs.bar_x), free(runs.bar_y);
    return status;
}
