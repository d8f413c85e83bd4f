/* The critical-velocity figures (RUN_DIR/vcrit.h5): v_crit vs diameter, every run of the search, and the thesis's
 * predictions for comparison; the coefficient of restitution against impact speed per diameter (every run).  A
 * table over diameter and temperature ([vcrit] temperatures) gets a v_crit curve per temperature, and its CoR
 * figure two panels, the coldest and the hottest temperature. */
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
    double *T;              /* K, the search's temperature (0: the material's T_initial, a table without them) */
    int *verdict;           /* RUN_*: vcrit.h5's verdicts, with held told apart from rebounded */
    double vrest_threshold; /* [impact] vrest_threshold: a rebounded run slower than it is held */
    /* error bars of logistic fits: per search, (d, v_crit - se), (d, v_crit + se), (NaN, NaN): a line with gaps */
    size_t bar_count, bar_capacity;
    double *bar_x, *bar_y;
};

#define RUN_REBOUNDED 0
#define RUN_BONDED    1
#define RUN_UNSETTLED 2
#define RUN_HELD      3 /* rebounded by the verdict but at rest: too few bonded points (mpm_verdict_held) */
#define RUN_FAILED    4 /* failed as a simulation (NaN or blow-up): enum vcrit_verdict's 3 in vcrit.h5 */
#define FILE_FAILED   3 /* VCRIT_FAILED (app/app.h), the value vcrit.h5 gives a failed run */

/* *array resized to capacity doubles; 0 (the array as it was) when memory ran out. */
static int grow(double **array, size_t capacity)
{
    double *resized = realloc(*array, capacity * sizeof *resized);
    if (resized)
        *array = resized;
    return resized != NULL;
}

static int add_run(struct search_runs *r, double d, double T, double v, int verdict, double cor)
{
    if (r->count == r->capacity) {
        size_t capacity = r->capacity ? 2 * r->capacity : 64;
        int grown = grow(&r->d, capacity) & grow(&r->T, capacity) & grow(&r->v, capacity) & grow(&r->cor, capacity);
        int *b2 = realloc(r->verdict, capacity * sizeof *b2);
        if (b2)
            r->verdict = b2;
        if (!grown || !b2)
            SC_FAIL_OOM(capacity * (4 * sizeof(double) + sizeof *b2), "the critical-velocity runs");
        r->capacity = capacity;
    }
    r->d[r->count] = d, r->T[r->count] = T, r->v[r->count] = v, r->cor[r->count] = cor;
    r->verdict[r->count++] = verdict;
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
    double d, T = 0.0;
    struct render_array v, verdict, cor, v_rest;
    memset(&v, 0, sizeof v), memset(&verdict, 0, sizeof verdict), memset(&cor, 0, sizeof cor);
    memset(&v_rest, 0, sizeof v_rest);
    if (g < 0)
        return -1;
    int status;
    SC_CHECK(status, h5_attr_read_double(g, "diameter", &d), done);
    if (H5Aexists(g, "temperature") > 0)
        SC_CHECK(status, h5_attr_read_double(g, "temperature", &T), done);
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
        if (run == FILE_FAILED)
            run = RUN_FAILED;
        else if (run == RUN_REBOUNDED && i < v_rest.count && v_rest.values[i] <= runs->vrest_threshold)
            run = RUN_HELD;
        SC_CHECK(status, add_run(runs, d * 1e6, T, v.values[i], run, i < cor.count ? cor.values[i] : NAN), done);
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

/* The top of the v_crit axis: the data's range above it, times 1.2 for a legend of up to 9 rows (about 40 % of the
 * frame's height) and in proportion for more, so that the legend in the top corner covers no point. */
static double legend_headroom(const struct render_array *v, const struct search_runs *runs, int legend_rows)
{
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < v->count; i++)
        lo = fmin(lo, v->values[i]), hi = fmax(hi, v->values[i]);
    for (size_t i = 0; i < runs->count; i++)
        lo = fmin(lo, runs->v[i]), hi = fmax(hi, runs->v[i]);
    for (size_t i = 0; i < sizeof tang_vcrit / sizeof tang_vcrit[0]; i++)
        lo = fmin(lo, tang_vcrit[i]), hi = fmax(hi, tang_vcrit[i]);
    double scale = 1.2 * fmax(1.0, legend_rows / 9.0);
    return hi > lo ? hi + scale * (hi - lo) : NAN;
}

/* The v_crit curves: one, or one per temperature of a table over (d, T) (its rows by diameter, then temperature),
 * each with its diameters in um and its values, in ascending temperature. */
#define MAX_CURVES 8
struct vcrit_curves {
    int count;
    double temperature[MAX_CURVES];
    size_t length[MAX_CURVES];
    char label[MAX_CURVES][40];
    double *d_um[MAX_CURVES], *v[MAX_CURVES];
};

/* Split the table's rows into curves (`t` with no values: one curve); `buffer` holds 2 d->count doubles.  The
 * temperatures beyond MAX_CURVES are left out of the figure (warned), not of the table. */
static void split_curves(const struct render_array *d, const struct render_array *v, const struct render_array *t,
                         double *buffer, struct vcrit_curves *c)
{
    size_t n = d->count, used = 0;
    memset(c, 0, sizeof *c);
    for (size_t i = 0; i < n; i++) {
        double T = t->count == n ? t->values[i] : 0.0;
        int k = 0;
        while (k < c->count && c->temperature[k] != T)
            k++;
        if (k == c->count) {
            if (c->count == MAX_CURVES) {
                log_warn("render: vcrit figure: more than %d temperatures, the row at %g K left out", MAX_CURVES, T);
                continue;
            }
            c->temperature[c->count++] = T;
        }
    }
    for (int a = 1; a < c->count; a++) /* ascending temperature */
        for (int b = a; b > 0 && c->temperature[b] < c->temperature[b - 1]; b--) {
            double swap = c->temperature[b];
            c->temperature[b] = c->temperature[b - 1], c->temperature[b - 1] = swap;
        }
    for (int k = 0; k < c->count; k++) {
        c->d_um[k] = buffer + used, c->v[k] = buffer + n + used;
        for (size_t i = 0; i < n; i++)
            if ((t->count == n ? t->values[i] : 0.0) == c->temperature[k]) {
                c->d_um[k][c->length[k]] = d->values[i] * 1e6, c->v[k][c->length[k]++] = v->values[i];
            }
        used += c->length[k];
        if (t->count == n)
            snprintf(c->label[k], sizeof c->label[k], "v_crit at %.0f K (this run)", c->temperature[k]);
        else
            snprintf(c->label[k], sizeof c->label[k], "v_crit (this run)");
    }
}

/* Colours of the curves (palette indices), odd ones dashed: blue for the two coldest, vermilion for the next two;
 * the runs' markers are green, black, pink and orange. */
static const int curve_colour[MAX_CURVES] = {0, 0, 1, 1, 7, 7, 3, 3};

/* The runs as RUN_SERIES marker series by verdict (an unsettled or failed run is neither bonded nor rebounded: a
 * series of its own); `xy` holds 2 runs->count doubles per series.  A verdict no run has is left out of the legend. */
#define RUN_SERIES 5
static void run_series(const struct search_runs *runs, int many, double *xy, struct render_series series[RUN_SERIES])
{
    static const int verdict[RUN_SERIES] = {RUN_BONDED, -1, RUN_UNSETTLED, RUN_HELD, RUN_FAILED};
    static const char *const label[RUN_SERIES] = {"runs: bonded", "runs: rebounded", "runs: unsettled",
                                                  "runs: held (at rest, too little bonded)",
                                                  "runs: failed (NaN or blow-up)"};
    static const int colour[RUN_SERIES] = {2, 6, 3, 4, 5};
    size_t m = runs->count;
    for (int k = 0; k < RUN_SERIES; k++) {
        double *x = xy + 2 * (size_t)k * m, *y = x + m;
        size_t n = 0;
        for (size_t i = 0; i < m; i++) {
            int v = runs->verdict[i];
            int rebounded = v != RUN_BONDED && v != RUN_UNSETTLED && v != RUN_HELD && v != RUN_FAILED;
            if (k == 1 ? rebounded : v == verdict[k])
                x[n] = runs->d[i], y[n++] = runs->v[i];
        }
        const char *text = k == 0 && many ? "runs (every temperature): bonded" : label[k];
        series[k] =
            (struct render_series){n ? text : NULL, k ? RENDER_OPEN_MARKERS : RENDER_MARKERS, n, x, y, 0, colour[k]};
    }
}

static int legend_rows(const struct render_series *series, int count)
{
    int rows = 0;
    for (int k = 0; k < count; k++)
        rows += series[k].label != NULL;
    return rows;
}

static int vcrit_plot(const struct render_request *req, const struct render_array *d, const struct render_array *v,
                      const struct render_array *t, const struct search_runs *runs, struct render_output *out)
{
    size_t n = d->count, m = runs->count;
    double *buffer = malloc((2 * n + 2 * RUN_SERIES * m + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((2 * n + 2 * RUN_SERIES * m + 1) * sizeof *buffer, "the critical-velocity figure");
    struct vcrit_curves curves;
    split_curves(d, v, t, buffer, &curves);
    int many = curves.count > 1;
    /* the runs first, so that the curves, their error bars and the published points are drawn over them */
    struct render_series series[RUN_SERIES + 3 + 2 * MAX_CURVES];
    run_series(runs, many, buffer + 2 * n, series);
    int count = RUN_SERIES;
    for (int k = 0; k < curves.count; k++) {
        int colour = many ? curve_colour[k] : 0;
        series[count++] = (struct render_series){
            curves.label[k], k % 2 ? RENDER_DASHED : RENDER_LINE, curves.length[k], curves.d_um[k], curves.v[k], 0,
            colour};
        series[count++] =
            (struct render_series){NULL, RENDER_MARKERS, curves.length[k], curves.d_um[k], curves.v[k], 0, colour};
    }
    series[count++] = (struct render_series){runs->bar_count ? "v_crit ± standard error (logistic fit)" : NULL,
                                             RENDER_LINE,
                                             runs->bar_count,
                                             runs->bar_x,
                                             runs->bar_y,
                                             0,
                                             6};
    series[count++] = (struct render_series){many ? "Tang (2021) Table 5.4, room temperature" : "Tang (2021) Table 5.4",
                                             RENDER_OPEN_MARKERS,
                                             5,
                                             tang_diameter_um,
                                             tang_vcrit,
                                             0,
                                             1};
    series[count++] = (struct render_series){
        "measured, Al on Al (Hassani-Gangaraj 2018)", RENDER_MARKERS, 2, measured_diameter_um, measured_vcrit, 0, 5};
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){many ? "Critical velocity vs particle diameter and temperature"
                                                : "Critical velocity vs particle diameter",
                                           "diameter d (µm)",
                                           "critical velocity v_crit (m/s)",
                                           NAN,
                                           NAN,
                                           NAN,
                                           NAN,
                                           0,
                                           count,
                                           series};
    plot.panels[0].ymax = legend_headroom(v, runs, legend_rows(series, count));
    int status;
    SC_CHECK(status, render_plot_publish(req->run_dir, out, "vcrit", "vcrit", plot.panels[0].title, &plot), done);
done:
    free(buffer);
    return status;
}

/* CoR against impact speed: one marker series per diameter, of the runs at temperature T (runs of a search are
 * consecutive, the searches by diameter).  x and y hold runs->count values; returns the number of series. */
#define COR_DIAMETERS 16
static int cor_series(const struct search_runs *runs, double T, double *x, double *y,
                      struct render_series series[COR_DIAMETERS], char labels[COR_DIAMETERS][32])
{
    int n = 0;
    size_t used = 0;
    for (size_t i = 0; i < runs->count && n < COR_DIAMETERS;) {
        size_t j = i, first = used;
        for (; j < runs->count && runs->d[j] == runs->d[i]; j++)
            if (runs->T[j] == T)
                x[used] = runs->v[j], y[used++] = runs->cor[j];
        if (used > first) {
            snprintf(labels[n], sizeof labels[n], "%.3g µm", runs->d[i]);
            series[n] = (struct render_series){labels[n], RENDER_MARKERS, used - first, x + first, y + first, 0, n % 8};
            n++;
        }
        i = j;
    }
    return n;
}

/* The CoR figure: one panel, or with temperatures two, the coldest and the hottest (vcrit_cor.csv has them all). */
static int cor_plot(const struct render_request *req, const struct search_runs *runs, struct render_output *out)
{
    double cold = INFINITY, hot = -INFINITY;
    for (size_t i = 0; i < runs->count; i++)
        cold = fmin(cold, runs->T[i]), hot = fmax(hot, runs->T[i]);
    int panels = runs->count && hot > cold ? 2 : 1;
    double *buffer = malloc((4 * runs->count + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((4 * runs->count + 1) * sizeof *buffer, "the CoR figure");
    struct render_series series[2][COR_DIAMETERS];
    char labels[2][COR_DIAMETERS][32], titles[2][80];
    struct render_plot plot = render_plot_start(req->cfg, panels);
    const char *title = "Coefficient of restitution vs impact speed";
    for (int p = 0; p < panels; p++) {
        double T = p ? hot : cold;
        double *x = buffer + 2 * (size_t)p * runs->count, *y = x + runs->count;
        int n = runs->count ? cor_series(runs, T, x, y, series[p], labels[p]) : 0;
        if (panels == 2)
            snprintf(titles[p], sizeof titles[p], "CoR vs impact speed, particles at %.0f K", T);
        plot.panels[p] = (struct render_panel){panels == 2 ? titles[p] : title,
                                               "impact speed (m/s)",
                                               "coefficient of restitution (normal)",
                                               NAN,
                                               NAN,
                                               NAN,
                                               NAN,
                                               1,
                                               n,
                                               series[p]};
    }
    int status = render_plot_publish(req->run_dir, out, "vcrit_cor", "vcrit", title, &plot);
    free(buffer);
    return status;
}

int render_vcrit_figures(const struct render_request *req, struct render_output *out)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/vcrit.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(path, &file));
    struct render_array d, v, t;
    struct search_runs runs = {0};
    runs.vrest_threshold = case_real(req->c, "impact", "vrest_threshold");
    memset(&d, 0, sizeof d), memset(&v, 0, sizeof v), memset(&t, 0, sizeof t);
    int status;
    SC_CHECK(status, render_read_array(file, path, "diameter", &d), done);
    SC_CHECK(status, render_read_array(file, path, "v_crit", &v), done);
    if (v.count != d.count)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: /diameter and /v_crit of different lengths", path);
    if (h5_exists(file, "temperature")) { /* a table over (d, T) */
        SC_CHECK(status, render_read_array(file, path, "temperature", &t), done);
        if (t.count != d.count)
            SC_FAIL_AT(status, done, SC_EIO, "render: %s: /diameter and /temperature of different lengths", path);
    }
    SC_CHECK(status, read_search(file, path, &runs), done);
    H5Fclose(file);
    file = H5I_INVALID_HID;
    SC_CHECK(status, vcrit_plot(req, &d, &v, &t, &runs, out), done);
    SC_CHECK(status, cor_plot(req, &runs, out), done);
    log_info("render: vcrit figures from %s", path);
done:
    if (file >= 0)
        H5Fclose(file);
    render_array_free(&d), render_array_free(&v), render_array_free(&t);
    free(runs.d), free(runs.T), free(runs.v), free(runs.verdict), free(runs.cor), free(runs.bar_x), free(runs.bar_y);
    return status;
}
