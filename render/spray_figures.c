/* Figures of the spray stage (RUN_DIR/spray.h5): powder sizes with the Weibull law (paper Fig. 4), speed and
 * angle of each particle's first impact, speed vs diameter of first impacts, deposit metrics vs time (Figs. 7, 9),
 * the radial coating thickness profile, the deposit seen from the nozzle (Fig. 10) and the plume from the side
 * (Figs. 5, 8). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "render/render_impl.h"

struct spray_data {
    char path[4200];
    struct render_array d, x, v, state;                                                   /* /particles */
    struct render_array hit_t, hit_d, hit_v, hit_outcome, hit_partner, hit_id;            /* /impacts */
    struct render_array t, deposit_fraction, volume_fraction, spread, scatter, thickness; /* /metrics */
    struct render_array id;
    struct render_array escaped_d; /* /escapes/d: the particles that left the domain (empty if none) */
    double injection_radius;       /* render_injection_radius */
};

static void spray_data_free(struct spray_data *s)
{
    struct render_array *all[] = {&s->d,
                                  &s->x,
                                  &s->v,
                                  &s->state,
                                  &s->hit_t,
                                  &s->hit_d,
                                  &s->hit_v,
                                  &s->hit_outcome,
                                  &s->hit_partner,
                                  &s->hit_id,
                                  &s->t,
                                  &s->deposit_fraction,
                                  &s->volume_fraction,
                                  &s->spread,
                                  &s->scatter,
                                  &s->thickness,
                                  &s->id,
                                  &s->escaped_d};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        render_array_free(all[i]);
}

int render_injection_radius(hid_t file, const char *path, const struct case_file *c, double *radius)
{
    *radius = case_real(c, "spray", "nozzle_radius");
    if (!h5_exists(file, "nozzle"))
        return SC_OK;
    hid_t g = H5Gopen2(file, "nozzle", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s: cannot open /nozzle", path);
    int status = H5Aexists(g, "injection_radius") > 0 ? h5_attr_read_double(g, "injection_radius", radius) : SC_OK;
    H5Gclose(g);
    SC_TRY(status);
    return SC_OK;
}

static int spray_data_read(hid_t f, struct spray_data *s)
{
    const char *p = s->path;
    SC_TRY(render_read_array(f, p, "particles/d", &s->d));
    SC_TRY(render_read_array(f, p, "particles/x", &s->x));
    SC_TRY(render_read_array(f, p, "particles/v", &s->v));
    SC_TRY(render_read_array(f, p, "particles/state", &s->state));
    SC_TRY(render_read_array(f, p, "particles/id", &s->id));
    if (h5_exists(f, "escapes/d"))
        SC_TRY(render_read_array(f, p, "escapes/d", &s->escaped_d));
    SC_TRY(render_read_array(f, p, "impacts/t", &s->hit_t));
    SC_TRY(render_read_array(f, p, "impacts/d", &s->hit_d));
    SC_TRY(render_read_array(f, p, "impacts/v_in", &s->hit_v));
    SC_TRY(render_read_array(f, p, "impacts/outcome", &s->hit_outcome));
    SC_TRY(render_read_array(f, p, "impacts/partner", &s->hit_partner));
    SC_TRY(render_read_array(f, p, "impacts/particle_id", &s->hit_id));
    SC_TRY(render_read_array(f, p, "metrics/t", &s->t));
    SC_TRY(render_read_array(f, p, "metrics/deposit_fraction", &s->deposit_fraction));
    SC_TRY(render_read_array(f, p, "metrics/volume_fraction", &s->volume_fraction));
    SC_TRY(render_read_array(f, p, "metrics/mean_spread", &s->spread));
    SC_TRY(render_read_array(f, p, "metrics/scatter", &s->scatter));
    SC_TRY(render_read_array(f, p, "metrics/max_thickness", &s->thickness));
    size_t n = s->d.count;
    if (s->x.count != 3 * n || s->v.count != 3 * n || s->state.count != n || s->id.count != n)
        SC_FAIL(SC_EIO, "render: %s: /particles datasets of different lengths", p);
    size_t m = s->hit_d.count;
    if (s->hit_t.count != m || s->hit_v.count != 3 * m || s->hit_outcome.count != m || s->hit_partner.count != m ||
        s->hit_id.count != m)
        SC_FAIL(SC_EIO, "render: %s: /impacts datasets of different lengths", p);
    return SC_OK;
}

static double norm3(const double *v)
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* Truncated Weibull density (Eqs. 36-37: lambda = D_median / ln(2)^(1/n)) per metre, 0 outside [d_min, d_max]. */
static double weibull_density(double d, double median, double shape, double d_min, double d_max)
{
    double lambda = median / pow(log(2.0), 1.0 / shape);
    double lo = d_min > 0 ? 1 - exp(-pow(d_min / lambda, shape)) : 0;
    double hi = d_max > 0 ? 1 - exp(-pow(d_max / lambda, shape)) : 1;
    if (d < d_min || (d_max > 0 && d > d_max) || !(hi > lo))
        return 0;
    double u = d / lambda;
    return shape / lambda * pow(u, shape - 1) * exp(-pow(u, shape)) / (hi - lo);
}

/* Bars of a histogram whose values were scaled by `scale` (m -> um). */
static struct render_series histogram_bars(const struct render_histogram *h, double *edges, double *heights,
                                           const char *label)
{
    double width = (h->hi - h->lo) / h->bins;
    for (int i = 0; i < h->bins; i++) {
        edges[i] = h->lo + i * width;
        heights[i] = (double)h->counts[i];
    }
    return (struct render_series){label, RENDER_BARS, (size_t)h->bins, edges, heights, width, 0};
}

static int write_histogram(const struct render_request *req, struct render_output *out, const char *name,
                           const char *title, const char *xlabel, const double *values, size_t n,
                           const struct render_series *extra)
{
    struct render_figure *fig;
    SC_TRY(render_output_push(out, name, "spray", 1, title, &fig));
    SC_TRY(render_histogram_fill(values, n, req->cfg->bins, 0, 0, &fig->histogram));
    double *buffer = malloc(2 * (size_t)req->cfg->bins * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM(2 * (size_t)req->cfg->bins * sizeof *buffer, "a histogram's bars");
    struct render_series series[2];
    char label[64];
    snprintf(label, sizeof label, "%lld particles", (long long)fig->histogram.total);
    series[0] = histogram_bars(&fig->histogram, buffer, buffer + req->cfg->bins, label);
    if (extra)
        series[1] = *extra;
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){title, xlabel, "count", NAN, NAN, NAN, NAN, 1, extra ? 2 : 1, series};
    char dir[4200];
    render_figures_dir(req->run_dir, dir, sizeof dir);
    int status = render_plot_write(&plot, dir, name);
    free(buffer);
    SC_TRY(status);
    return SC_OK;
}

/* Diameters of every injected particle (um): those in the domain at the end and those that left it (the law is the
 * injected powder's; the ones left alone are biased to the sizes that stay), with the expected counts of the case's
 * Weibull law. */
static int diameter_figure(const struct render_request *req, const struct spray_data *s, struct render_output *out)
{
    size_t kept = s->d.count, n = kept + s->escaped_d.count;
    double *um = malloc((n + 1) * sizeof *um);
    enum { CURVE = 200 };
    double cx[CURVE], cy[CURVE];
    if (!um)
        SC_FAIL_OOM((n + 1) * sizeof *um, "the particle diameters");
    for (size_t i = 0; i < n; i++)
        um[i] = (i < kept ? s->d.values[i] : s->escaped_d.values[i - kept]) * 1e6;
    struct render_series curve = {NULL, RENDER_LINE, 0, cx, cy, 0, 1};
    int weibull = case_is(req->c, "powder", "distribution", "weibull");
    struct render_histogram h = {0};
    int status;
    SC_CHECK(status, render_histogram_fill(um, n, req->cfg->bins, 0, 0, &h), done);
    if (weibull) {
        double median = case_real(req->c, "powder", "median_diameter"), shape = case_real(req->c, "powder", "shape");
        double d_min = case_real(req->c, "powder", "d_min"), d_max = case_real(req->c, "powder", "d_max");
        double width_m = (h.hi - h.lo) / h.bins * 1e-6;
        for (int i = 0; i < CURVE; i++) {
            double d = (h.lo + (h.hi - h.lo) * i / (CURVE - 1)) * 1e-6;
            cx[i] = d * 1e6;
            cy[i] = (double)h.total * width_m * weibull_density(d, median, shape, d_min, d_max);
        }
        curve.count = CURVE;
        curve.label = "Weibull law of [powder] x count x bin width";
    }
    SC_CHECK(status,
             write_histogram(req, out, "spray_diameter", "Diameters of every injected particle (escaped included)",
                             "diameter d (µm)", um, n, weibull ? &curve : NULL),
             done);
done:
    render_histogram_free(&h);
    free(um);
    return status;
}

size_t render_first_contacts(const double *t, const double *particle_id, size_t m, size_t *rows)
{
    double max_id = -1;
    for (size_t i = 0; i < m; i++)
        if (particle_id[i] >= 0)
            max_id = fmax(max_id, particle_id[i]);
    if (max_id < 0)
        return 0;
    size_t ids = (size_t)max_id + 1, k = 0;
    size_t *first = malloc(ids * sizeof *first);
    if (!first)
        return (size_t)-1;
    for (size_t i = 0; i < ids; i++)
        first[i] = (size_t)-1;
    for (size_t i = 0; i < m; i++) {
        if (!(particle_id[i] >= 0))
            continue;
        size_t id = (size_t)particle_id[i];
        if (first[id] == (size_t)-1 || t[i] < t[first[id]])
            first[id] = i;
    }
    for (size_t i = 0; i < ids; i++)
        if (first[i] != (size_t)-1)
            rows[k++] = first[i];
    free(first);
    return k;
}

/* First impacts: each particle's first contact (its smallest t in /impacts, with the target or a deposit), one
 * per particle; the later contacts (rebounds, particles sliding or resting on the target) are left out, so the
 * histograms show the spray's arrival, not how long particles stay on the target.  Speed (m/s) and angle from
 * the target normal +z (deg). */
static int impact_figures(const struct render_request *req, const struct spray_data *s, struct render_output *out)
{
    size_t m = s->hit_d.count, *rows = malloc((m + 1) * sizeof *rows);
    double *buffer = malloc((4 * m + 1) * sizeof *buffer), *s_dep = NULL;
    if (!buffer || !rows) {
        free(buffer), free(rows);
        SC_FAIL_OOM((4 * m + 1) * sizeof *buffer, "the first impacts");
    }
    size_t k = render_first_contacts(s->hit_t.values, s->hit_id.values, m, rows);
    int status = SC_OK;
    if (k == (size_t)-1)
        SC_FAIL_OOM_AT(status, done, m * sizeof *rows, "the first impacts");
    double *speed = buffer, *angle = buffer + m, *d_dep = buffer + 2 * m, *d_reb = buffer + 3 * m;
    for (size_t j = 0; j < k; j++) {
        const double *v = s->hit_v.values + 3 * rows[j];
        speed[j] = norm3(v);
        angle[j] = speed[j] > 0 ? acos(fmin(1, fabs(v[2]) / speed[j])) * 180 / M_PI : 0;
    }
    SC_CHECK(status,
             write_histogram(req, out, "spray_impact_speed", "Speed of first impacts (one per particle)",
                             "impact speed |v_in| (m/s)", speed, k, NULL),
             done);
    SC_CHECK(status,
             write_histogram(req, out, "spray_impact_angle", "Angle of first impacts (one per particle)",
                             "angle from the target normal +z (deg)", angle, k, NULL),
             done);
    /* speed vs diameter, deposited and rebounded apart: [deposition] decides by these two numbers */
    size_t nd = 0, nr = 0;
    s_dep = malloc((2 * m + 1) * sizeof *s_dep);
    if (!s_dep)
        SC_FAIL_OOM_AT(status, done, (2 * m + 1) * sizeof *s_dep, "the first impacts");
    double *s_reb = s_dep + m;
    for (size_t j = 0; j < k; j++) {
        size_t i = rows[j];
        int deposited = s->hit_outcome.values[i] == 1;
        (deposited ? d_dep : d_reb)[deposited ? nd : nr] = s->hit_d.values[i] * 1e6;
        (deposited ? s_dep : s_reb)[deposited ? nd++ : nr++] = speed[j];
    }
    struct render_series series[2] = {{"deposited", RENDER_MARKERS, nd, d_dep, s_dep, 0, 2},
                                      {"rebounded", RENDER_OPEN_MARKERS, nr, d_reb, s_reb, 0, 1}};
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){"First impacts: speed vs diameter",
                                           "diameter d (µm)",
                                           "impact speed |v_in| (m/s)",
                                           NAN,
                                           NAN,
                                           NAN,
                                           NAN,
                                           1,
                                           2,
                                           series};
    SC_CHECK(status,
             render_plot_publish(req->run_dir, out, "spray_speed_diameter", "spray", plot.panels[0].title, &plot),
             done);
done:
    free(s_dep);
    free(buffer);
    free(rows);
    return status;
}

int render_thickness_profile(const double *x, const double *d, const double *state, size_t n, int bins, double *r_left,
                             double *thickness, double *width)
{
    double r_max = 0;
    int deposited = 0;
    for (size_t i = 0; i < n; i++)
        if (state[i] == 1) {
            r_max = fmax(r_max, hypot(x[3 * i], x[3 * i + 1]) + 0.5 * d[i]);
            deposited++;
        }
    if (!deposited || !(r_max > 0))
        return 0;
    *width = r_max / bins;
    double *volume = thickness;
    for (int b = 0; b < bins; b++)
        r_left[b] = b * *width, volume[b] = 0;
    for (size_t i = 0; i < n; i++) {
        if (state[i] != 1)
            continue;
        int b = (int)(hypot(x[3 * i], x[3 * i + 1]) / *width);
        volume[b < bins ? b : bins - 1] += M_PI * d[i] * d[i] * d[i] / 6;
    }
    for (int b = 0; b < bins; b++) {
        double r1 = r_left[b], r2 = r1 + *width;
        thickness[b] = volume[b] / (M_PI * (r2 * r2 - r1 * r1));
    }
    return bins;
}

/* The radial profile of the coating: render_thickness_profile's dense-equivalent thickness per annulus. */
static int thickness_figure(const struct render_request *req, const struct spray_data *s, struct render_output *out)
{
    enum { BINS = 20 };
    double r[BINS], h[BINS], width;
    if (render_thickness_profile(s->x.values, s->d.values, s->state.values, s->d.count, BINS, r, h, &width) == 0)
        return SC_OK; /* nothing deposited */
    for (int b = 0; b < BINS; b++)
        r[b] *= 1e3, h[b] *= 1e6;
    struct render_series bars = {NULL, RENDER_BARS, BINS, r, h, width * 1e3, 2};
    struct render_plot plot = render_plot_start(req->cfg, 1);
    plot.panels[0] = (struct render_panel){"Coating thickness vs radius (dense-equivalent)",
                                           "radius from the spray axis r (mm)",
                                           "thickness (µm)",
                                           0,
                                           NAN,
                                           0,
                                           NAN,
                                           1,
                                           1,
                                           &bars};
    return render_plot_publish(req->run_dir, out, "spray_thickness", "spray",
                               "Coating thickness vs radius: deposited particle volume per annulus / annulus area "
                               "(a fully dense layer)",
                               &plot);
}

/* The metrics of spray.h5 /metrics (the paper's Section 5.2) over time.  With a moving nozzle the volume fraction,
 * mean spread and scatter are measured from the origin, where the path starts (dem/output.c), and the title says so. */
static int metrics_figure(const struct render_request *req, const struct spray_data *s, int moves,
                          struct render_output *out)
{
    size_t n = s->t.count;
    double *buffer = malloc((4 * n + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((4 * n + 1) * sizeof *buffer, "the deposit metrics");
    double *ms = buffer, *spread = buffer + n, *scatter = buffer + 2 * n, *thickness = buffer + 3 * n;
    for (size_t i = 0; i < n; i++) {
        ms[i] = s->t.values[i] * 1e3;
        spread[i] = s->spread.values[i] * 1e3;
        scatter[i] = s->scatter.values[i] * 1e3;
        thickness[i] = s->thickness.values[i] * 1e3;
    }
    struct render_series fractions[2] = {{"deposit fraction", RENDER_LINE, n, ms, s->deposit_fraction.values, 0, 0},
                                         {"volume fraction", RENDER_DASHED, n, ms, s->volume_fraction.values, 0, 1}};
    struct render_series lengths[3] = {{"mean spread", RENDER_LINE, n, ms, spread, 0, 0},
                                       {"scatter", RENDER_DASHED, n, ms, scatter, 0, 1},
                                       {"max thickness", RENDER_LINE, n, ms, thickness, 0, 2}};
    struct render_plot plot = render_plot_start(req->cfg, 2);
    plot.width *= 2;
    plot.panels[0] =
        (struct render_panel){"Deposit fractions", "time t (ms)", "fraction (-)", NAN, NAN, 0, NAN, 1, 2, fractions};
    plot.panels[1] =
        (struct render_panel){"Deposit extent", "time t (ms)", "length (mm)", NAN, NAN, NAN, NAN, 1, 3, lengths};
    int status;
    const char *title = moves
                            ? "Deposit metrics vs time (volume fraction, spread and scatter measured from the origin, "
                              "where the nozzle's path starts, not from its moving axis)"
                            : "Deposit metrics vs time";
    SC_CHECK(status, render_plot_publish(req->run_dir, out, "spray_metrics", "spray", title, &plot), done);
done:
    free(buffer);
    return status;
}

/* Impact speed of each particle's deposition contact, by particle id (NAN when none). */
static double *deposition_speeds(const struct spray_data *s)
{
    double max_id = 0;
    for (size_t i = 0; i < s->id.count; i++)
        max_id = fmax(max_id, s->id.values[i]);
    for (size_t i = 0; i < s->hit_id.count; i++)
        max_id = fmax(max_id, s->hit_id.values[i]);
    size_t count = (size_t)max_id + 1;
    double *speed = malloc(count * sizeof *speed);
    if (!speed)
        return NULL;
    for (size_t i = 0; i < count; i++)
        speed[i] = NAN;
    for (size_t i = 0; i < s->hit_id.count; i++)
        if (s->hit_outcome.values[i] == 1 && s->hit_id.values[i] >= 0)
            speed[(size_t)s->hit_id.values[i]] = norm3(s->hit_v.values + 3 * i);
    return speed;
}

static void value_range(const double *v, size_t n, double *lo, double *hi)
{
    *lo = INFINITY, *hi = -INFINITY;
    for (size_t i = 0; i < n; i++)
        if (isfinite(v[i]))
            *lo = fmin(*lo, v[i]), *hi = fmax(*hi, v[i]);
    if (!(*lo <= *hi))
        *lo = 0, *hi = 1;
}

static int draw_scene(const struct render_request *req, struct render_renderer **renderer, struct render_output *out,
                      const struct render_spheres *spheres, struct render_scene *scene, const char *name,
                      const char *title)
{
    SC_TRY(render_renderer_get(req->cfg, renderer));
    value_range(spheres->value, spheres->count, &scene->vmin, &scene->vmax);
    const struct render_image *image;
    SC_TRY(render_spheres_draw(*renderer, spheres, scene, NULL, &image));
    char path[4300];
    render_figures_dir(req->run_dir, path, sizeof path);
    snprintf(path + strlen(path), sizeof path - strlen(path), "/%s.png", name);
    SC_TRY(render_image_write_png(image, path));
    SC_TRY(render_output_push(out, name, "spray", 0, title, NULL));
    return SC_OK;
}

/* The nozzle exit (radius R, at z = 0: the disc the spray injected over) and the target plane (z = standoff) of
 * the case, for the guides. */
struct spray_geometry {
    double nozzle_radius, standoff;
};

static struct spray_geometry spray_geometry(const struct render_request *req, const struct spray_data *s)
{
    return (struct spray_geometry){s->injection_radius, case_real(req->c, "target", "standoff")};
}

/* The deposit seen from the nozzle: deposited particles as spheres of their diameter on axes in mm, with the
 * nozzle exit's outline (the circle of radius R on the axis). */
static int deposit_picture(const struct render_request *req, struct render_renderer **renderer,
                           const struct spray_data *s, struct render_output *out)
{
    size_t n = s->d.count, k = 0;
    double *buffer = malloc((5 * n + 1) * sizeof *buffer), *speed_by_id = deposition_speeds(s);
    if (!buffer || !speed_by_id) {
        free(buffer), free(speed_by_id);
        SC_FAIL_OOM((5 * n + 1) * sizeof *buffer, "the deposit picture");
    }
    double *x = buffer, *radius = buffer + 3 * n, *value = buffer + 4 * n;
    for (size_t i = 0; i < n; i++) {
        if (s->state.values[i] != 1)
            continue;
        memcpy(x + 3 * k, s->x.values + 3 * i, 3 * sizeof *x);
        radius[k] = 0.5 * s->d.values[i];
        value[k++] = req->cfg->deposit_by_speed ? speed_by_id[(size_t)s->id.values[i]] : s->d.values[i] * 1e6;
    }
    struct spray_geometry geo = spray_geometry(req, s);
    enum { SEGMENTS = 96 };
    double circle[3 * SEGMENTS], extent = geo.nozzle_radius;
    for (int i = 0; i < SEGMENTS; i++) {
        double phi = 2 * M_PI * i / SEGMENTS;
        circle[3 * i] = geo.nozzle_radius * cos(phi), circle[3 * i + 1] = geo.nozzle_radius * sin(phi);
        circle[3 * i + 2] = geo.standoff;
    }
    for (size_t i = 0; i < k; i++)
        extent = fmax(extent, fmax(fabs(x[3 * i]), fabs(x[3 * i + 1])) + radius[i]);
    extent *= 1.05;
    double frame[6] = {-extent, -extent, geo.standoff, extent, extent, geo.standoff};
    char label[96], caption[128];
    snprintf(label, sizeof label, "nozzle exit (d = %.3g mm)", 2e3 * geo.nozzle_radius);
    struct render_guide nozzle = {circle, SEGMENTS, 1, label, 0};
    struct render_scene scene = {RENDER_VIEW_FACING,
                                 req->cfg->width,
                                 req->cfg->height,
                                 0,
                                 1,
                                 req->cfg->deposit_by_speed ? "impact speed" : "diameter",
                                 req->cfg->deposit_by_speed ? "m/s" : "µm",
                                 caption,
                                 0,
                                 2.0,
                                 0,
                                 1,
                                 1,
                                 &nozzle,
                                 frame};
    snprintf(caption, sizeof caption, "deposit on the target seen from the nozzle: %zu particles", k);
    struct render_spheres deposit = {k, x, radius, 0, value};
    int status = draw_scene(req, renderer, out, &deposit, &scene, "spray_deposit", "Deposit on the target");
    free(buffer);
    free(speed_by_id);
    return status;
}

/* Snapshot i of spray.h5 (/snapshots/NNNNNN): positions, speeds |v|, diameters and states. */
struct spray_snapshot {
    struct render_array x, v, d, state;
    double t;
};

static void snapshot_free(struct spray_snapshot *snap)
{
    render_array_free(&snap->x), render_array_free(&snap->v), render_array_free(&snap->d);
    render_array_free(&snap->state);
}

static int snapshot_read(hid_t file, const char *path, long i, struct spray_snapshot *snap)
{
    memset(snap, 0, sizeof *snap);
    char name[64];
    snprintf(name, sizeof name, "snapshots/%06ld", i);
    hid_t g = H5Gopen2(file, name, H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s: no snapshot %s", path, name);
    int status;
    SC_CHECK(status, render_read_array(g, path, "x", &snap->x), done);
    SC_CHECK(status, render_read_array(g, path, "v", &snap->v), done);
    SC_CHECK(status, render_read_array(g, path, "d", &snap->d), done);
    SC_CHECK(status, render_read_array(g, path, "state", &snap->state), done);
    if (h5_attr_read_double(g, "t", &snap->t) != SC_OK)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: snapshot %s has no time", path, name);
    size_t n = snap->d.count;
    if (snap->x.count != 3 * n || snap->v.count != 3 * n || snap->state.count != n)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: snapshot %s: datasets of different lengths", path, name);
    for (size_t k = 0; k < n; k++) /* |v| in place */
        snap->v.values[k] = norm3(snap->v.values + 3 * k);
done:
    H5Gclose(g);
    if (status != SC_OK)
        snapshot_free(snap);
    return status;
}

/* The plume from the side (x right, z up: the nozzle exit at the bottom, the target at the top), framed on
 * nozzle to target so that every frame of the film shows the same region, with axes in mm and both drawn. */
struct plume_view {
    struct spray_geometry geo;
    double frame[6], nozzle[6], target[6];
    char nozzle_label[96], target_label[96];
    struct render_guide guides[2];
    double vmax; /* colour range 0 .. vmax (m/s) */
};

static void plume_view_init(const struct render_request *req, const struct spray_data *s, struct plume_view *pv)
{
    pv->geo = spray_geometry(req, s);
    double width = pv->geo.nozzle_radius, length = pv->geo.standoff;
    for (size_t i = 0; i < s->d.count; i++)
        width = fmax(width, fabs(s->x.values[3 * i]) + 0.5 * s->d.values[i]);
    width *= 1.1;
    double frame[6] = {-width, 0, -0.04 * length, width, 0, 1.04 * length};
    double nozzle[6] = {-pv->geo.nozzle_radius, 0, 0, pv->geo.nozzle_radius, 0, 0};
    double target[6] = {-width, 0, length, width, 0, length};
    memcpy(pv->frame, frame, sizeof frame), memcpy(pv->nozzle, nozzle, sizeof nozzle);
    memcpy(pv->target, target, sizeof target);
    snprintf(pv->nozzle_label, sizeof pv->nozzle_label, "nozzle exit (d = %.3g mm)", 2e3 * pv->geo.nozzle_radius);
    snprintf(pv->target_label, sizeof pv->target_label, "target (standoff %.3g mm)", 1e3 * length);
    pv->guides[0] = (struct render_guide){pv->nozzle, 2, 0, pv->nozzle_label, 1};
    pv->guides[1] = (struct render_guide){pv->target, 2, 0, pv->target_label, 0};
    pv->vmax = 0;
    for (size_t i = 0; i < s->hit_d.count; i++)
        pv->vmax = fmax(pv->vmax, norm3(s->hit_v.values + 3 * i));
    for (size_t i = 0; i < s->d.count; i++)
        pv->vmax = fmax(pv->vmax, norm3(s->v.values + 3 * i));
    if (!(pv->vmax > 0))
        pv->vmax = 1;
}

/* Draw particles (x, |v|, d, state of n) from the side into path. */
static int plume_draw(const struct render_request *req, struct render_renderer **renderer, const struct plume_view *pv,
                      const struct spray_snapshot *snap, const char *caption, const char *path)
{
    size_t n = snap->d.count;
    double *radius = malloc((n + 1) * sizeof *radius);
    if (!radius)
        SC_FAIL_OOM((n + 1) * sizeof *radius, "the plume picture");
    for (size_t i = 0; i < n; i++)
        radius[i] = 0.5 * snap->d.values[i];
    struct render_spheres plume = {n, snap->x.values, radius, 0, snap->v.values};
    struct render_scene side = {
        RENDER_VIEW_SIDE, req->cfg->width, req->cfg->height, 0, pv->vmax, "speed", "m/s", caption, 0, 2.0, 0, 1, 2,
        pv->guides,       pv->frame};
    const struct render_image *image;
    int status;
    SC_CHECK(status, render_renderer_get(req->cfg, renderer), done);
    SC_CHECK(status, render_spheres_draw(*renderer, &plume, &side, NULL, &image), done);
    SC_CHECK(status, render_image_write_png(image, path), done);
done:
    free(radius);
    return status;
}

static void plume_caption(const struct spray_snapshot *snap, char *out, size_t size)
{
    size_t flying = 0, deposited = 0;
    for (size_t i = 0; i < snap->d.count; i++)
        flying += snap->state.values[i] == 0, deposited += snap->state.values[i] == 1;
    size_t resting = snap->d.count - flying - deposited;
    int n =
        snprintf(out, size, "t = %.3f ms: %zu particles in flight, %zu deposited", snap->t * 1e3, flying, deposited);
    if (resting > 0 && n > 0 && (size_t)n < size)
        snprintf(out + n, size - (size_t)n, ", %zu resting", resting);
}

/* The number of snapshots in spray.h5 (0 without /snapshots: a run with snapshot_every = 0). */
static int snapshot_count(hid_t file, const char *path, long *count)
{
    *count = 0;
    if (!h5_exists(file, "snapshots"))
        return SC_OK;
    hid_t g = H5Gopen2(file, "snapshots", H5P_DEFAULT);
    int64_t c = -1;
    if (g >= 0)
        h5_attr_read_int64(g, "count", &c), H5Gclose(g);
    if (c < 0)
        SC_FAIL(SC_EIO, "render: %s: /snapshots has no count", path);
    *count = (long)c;
    return SC_OK;
}

/* The plume picture: the snapshot halfway through the run (the plume in flight), or without snapshots the final
 * state; and the film: every `every`-th snapshot and the last into figures/film_plume/. */
static int plume_pictures(const struct render_request *req, struct render_renderer **renderer,
                          const struct spray_data *s, struct render_output *out)
{
    struct plume_view pv;
    plume_view_init(req, s, &pv);
    char dir[4200], path[4400], caption[160];
    render_figures_dir(req->run_dir, dir, sizeof dir);
    snprintf(path, sizeof path, "%s/spray_plume.png", dir);
    hid_t file;
    SC_TRY(render_open(s->path, &file));
    long count, every = req->cfg->every;
    int status;
    struct spray_snapshot snap;
    memset(&snap, 0, sizeof snap);
    SC_CHECK(status, snapshot_count(file, s->path, &count), done);
    if (count == 0) { /* the final state: /particles */
        struct spray_snapshot final = {s->x, s->v, s->d, s->state, NAN};
        double *speed = malloc((s->d.count + 1) * sizeof *speed);
        if (!speed)
            SC_FAIL_OOM_AT(status, done, (s->d.count + 1) * sizeof *speed, "the plume picture");
        for (size_t i = 0; i < s->d.count; i++)
            speed[i] = norm3(s->v.values + 3 * i);
        final.v.values = speed;
        snprintf(caption, sizeof caption, "final state from the side: %zu particles (no snapshots)", s->d.count);
        status = plume_draw(req, renderer, &pv, &final, caption, path);
        free(speed);
        SC_CHECK(status, status, done);
        SC_CHECK(status, render_output_push(out, "spray_plume", "spray", 0, "Particles of the final state", NULL),
                 done);
        goto done;
    }
    SC_CHECK(status, snapshot_read(file, s->path, count / 2, &snap), done);
    plume_caption(&snap, caption, sizeof caption);
    SC_CHECK(status, plume_draw(req, renderer, &pv, &snap, caption, path), done);
    snapshot_free(&snap);
    SC_CHECK(status,
             render_output_push(out, "spray_plume", "spray", 0, "The plume in flight, halfway through the run", NULL),
             done);
    if (every <= 0)
        goto done;
    snprintf(path, sizeof path, "%s/film_plume", dir);
    SC_CHECK(status, render_film_folder(path), done);
    for (long i = 0; i < count; i++) {
        if (i % every != 0 && i != count - 1)
            continue;
        SC_CHECK(status, snapshot_read(file, s->path, i, &snap), done);
        plume_caption(&snap, caption, sizeof caption);
        snprintf(path, sizeof path, "%s/film_plume/plume_%06ld.png", dir, i);
        SC_CHECK(status, plume_draw(req, renderer, &pv, &snap, caption, path), done);
        snapshot_free(&snap);
        out->frames++;
    }
done:
    snapshot_free(&snap);
    H5Fclose(file);
    return status;
}

/* The DE classes of one group of spray.h5 /deposition_efficiency: bars at [lo, hi) (scaled) of height DE. */
static int read_de_classes(hid_t file, const char *group, double scale, struct render_array *lo,
                           struct render_array *hi, struct render_array *de)
{
    char name[96];
    snprintf(name, sizeof name, "deposition_efficiency/%s/lo", group);
    SC_TRY(render_read_array(file, "spray.h5", name, lo));
    snprintf(name, sizeof name, "deposition_efficiency/%s/hi", group);
    SC_TRY(render_read_array(file, "spray.h5", name, hi));
    snprintf(name, sizeof name, "deposition_efficiency/%s/de", group);
    SC_TRY(render_read_array(file, "spray.h5", name, de));
    if (lo->count != de->count || hi->count != de->count || de->count == 0)
        SC_FAIL(SC_EIO, "render: spray.h5 /deposition_efficiency/%s: lo, hi and de of different lengths", group);
    for (size_t k = 0; k < lo->count; k++)
        lo->values[k] *= scale, hi->values[k] *= scale;
    return SC_OK;
}

/* A powder of one size has every class [d, d] (dem/efficiency.c), all of it in the first: one bar, 4 % of d wide
 * about d, rather than bars of no width. */
static void single_size_bar(struct render_series *bars, double *left)
{
    if (bars->bar_width > 0 || bars->count == 0)
        return;
    bars->count = 1;
    bars->bar_width = 0.04 * left[0];
    left[0] -= 0.5 * bars->bar_width;
}

/* The deposition efficiency by mass (dem/efficiency.c) by size class and by first-impact angle, side by side. */
static int de_figure(const struct render_request *req, const char *path, struct render_output *out)
{
    hid_t file;
    SC_TRY(render_open(path, &file));
    if (!h5_exists(file, "deposition_efficiency")) { /* a spray.h5 of an earlier version */
        H5Fclose(file);
        return SC_OK;
    }
    struct render_array lo[2], hi[2], de[2];
    memset(lo, 0, sizeof lo), memset(hi, 0, sizeof hi), memset(de, 0, sizeof de);
    int status;
    SC_CHECK(status, read_de_classes(file, "by_size", 1e6, &lo[0], &hi[0], &de[0]), done);
    SC_CHECK(status, read_de_classes(file, "by_angle", 1.0, &lo[1], &hi[1], &de[1]), done);
    struct render_series bars[2];
    for (int g = 0; g < 2; g++)
        bars[g] = (struct render_series){NULL,          RENDER_BARS,  de[g].count,
                                         lo[g].values,  de[g].values, hi[g].values[0] - lo[g].values[0],
                                         g == 0 ? 2 : 4};
    single_size_bar(&bars[0], lo[0].values);
    struct render_plot plot = render_plot_start(req->cfg, 2);
    plot.panels[0] = (struct render_panel){
        "DE by particle size", "diameter d (µm)", "deposition efficiency (mass)", NAN, NAN, 0, 1, 1, 1, &bars[0]};
    plot.panels[1] = (struct render_panel){"DE by first-impact angle",
                                           "angle to the target normal (degree)",
                                           "deposition efficiency (mass)",
                                           0,
                                           90,
                                           0,
                                           1,
                                           1,
                                           1,
                                           &bars[1]};
    SC_CHECK(status,
             render_plot_publish(req->run_dir, out, "spray_de", "spray",
                                 "Deposition efficiency (deposited / sprayed mass) by size class and by the angle of "
                                 "the first impact",
                                 &plot),
             done);
done:
    H5Fclose(file);
    for (int g = 0; g < 2; g++)
        render_array_free(&lo[g]), render_array_free(&hi[g]), render_array_free(&de[g]);
    return status;
}

int render_spray_figures(const struct render_request *req, struct render_renderer **renderer, struct render_output *out)
{
    struct spray_data s;
    memset(&s, 0, sizeof s);
    snprintf(s.path, sizeof s.path, "%s/spray.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(s.path, &file));
    int status = spray_data_read(file, &s);
    if (status == SC_OK)
        status = render_injection_radius(file, s.path, req->c, &s.injection_radius);
    if (status == SC_OK)
        status = render_deposit_figures(req, file, s.path, out);
    int moves = render_nozzle_moves(file);
    H5Fclose(file);
    SC_CHECK(status, status, done); /* the read's status, the file closed */
    SC_CHECK(status, diameter_figure(req, &s, out), done);
    SC_CHECK(status, impact_figures(req, &s, out), done);
    SC_CHECK(status, metrics_figure(req, &s, moves, out), done);
    if (!moves) /* measured from the spray axis, which moved: the deposit's height map and profile take its place */
        SC_CHECK(status, thickness_figure(req, &s, out), done);
    SC_CHECK(status, render_nozzle_figure(req, out), done);
    SC_CHECK(status, de_figure(req, s.path, out), done);
    SC_CHECK(status, deposit_picture(req, renderer, &s, out), done);
    SC_CHECK(status, plume_pictures(req, renderer, &s, out), done);
    log_info("render: spray figures from %s", s.path);
done:
    spray_data_free(&s);
    return status;
}
