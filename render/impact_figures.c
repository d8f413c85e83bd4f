/* Figures of the impact stage (RUN_DIR/impact.h5): per run (the root, or each /run_NNNN/ group) PBCP and v_rest
 * vs time per body, the energy balance vs time, the last snapshot in the three views, and the frame sequence
 * (Tang Figs. 4.5, 5.10, 5.12, 5.15-5.17). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "render/render_impl.h"

#define MAX_SNAPSHOTS 100000

struct impact_run {
    const struct render_request *req;
    const char *path; /* RUN_DIR/impact.h5 */
    hid_t group;      /* the run: the root or /run_NNNN */
    char prefix[48];  /* figure names: "impact" or "impact_run_0001" */
    char label[48];   /* "" or " (run_0001)" */
    double radius;    /* of a material point (m) */
    int snapshot_count;
    char (*snapshots)[32]; /* names in /snapshots, ascending */
};

static const char *const field_names[] = {"eps_p", "T", "D_bond", "speed"};
static const char *const field_labels[] = {"effective plastic strain", "temperature", "bond parameter D", "speed |v|"};
static const char *const field_units[] = {"-", "K", "-", "m/s"};

/* ---- reading ---- */

static herr_t collect_name(hid_t group, const char *name, const H5L_info_t *info, void *data)
{
    (void)group, (void)info;
    struct impact_run *run = data;
    if (run->snapshot_count < MAX_SNAPSHOTS)
        snprintf(run->snapshots[run->snapshot_count++], 32, "%s", name);
    return 0;
}

static int list_snapshots(struct impact_run *run)
{
    run->snapshot_count = 0;
    if (!h5_exists(run->group, "snapshots"))
        return SC_OK;
    hid_t g = H5Gopen2(run->group, "snapshots", H5P_DEFAULT);
    H5G_info_t info;
    if (g < 0 || H5Gget_info(g, &info) < 0) {
        if (g >= 0)
            H5Gclose(g);
        SC_FAIL(SC_EIO, "render: %s: cannot read the snapshot list", run->path);
    }
    int status = SC_OK;
    run->snapshots = calloc(info.nlinks + 1, sizeof *run->snapshots);
    if (!run->snapshots)
        SC_FAIL_OOM_AT(status, done, (info.nlinks + 1) * sizeof *run->snapshots, "the snapshot list");
    if (H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, NULL, collect_name, run) < 0)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: cannot read the snapshot list", run->path);
done:
    H5Gclose(g);
    return status;
}

/* The field of snapshot i as one value per point; *x gets the positions when with_x.  On failure neither array is
 * left allocated. */
static int read_snapshot(const struct impact_run *run, int i, int with_x, struct render_array *x,
                         struct render_array *value, double *t)
{
    char name[96];
    snprintf(name, sizeof name, "snapshots/%s", run->snapshots[i]);
    hid_t g = H5Gopen2(run->group, name, H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "render: %s: cannot open snapshot %s", run->path, name);
    enum render_field field = run->req->cfg->field;
    int status;
    memset(value, 0, sizeof *value);
    if (with_x)
        memset(x, 0, sizeof *x);
    SC_CHECK(status, render_read_array(g, run->path, field == RENDER_SPEED ? "v" : field_names[field], value), done);
    if (with_x)
        SC_CHECK(status, render_read_array(g, run->path, "x", x), done);
    if (h5_attr_read_double(g, "t", t) != SC_OK)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: snapshot %s has no time", run->path, name);
    if (field == RENDER_SPEED) { /* |v| in place: the first third of the buffer */
        for (size_t k = 0; k < value->rows; k++) {
            const double *v = value->values + 3 * k;
            value->values[k] = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        }
        value->count = value->rows, value->width = 1;
    }
    if (with_x && x->count != 3 * value->count)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s: snapshot %s: x and %s of different lengths", run->path, name,
                   field_names[field]);
done:
    H5Gclose(g);
    if (status != SC_OK) {
        render_array_free(value);
        if (with_x)
            render_array_free(x);
    }
    return status;
}

/* render_point_radius of the [impact] spacing the run used, from the resolved case stored in impact.h5 (or the
 * case given). */
static double point_radius(const struct render_request *req, hid_t file)
{
    if (!isnan(req->cfg->point_radius))
        return req->cfg->point_radius;
    char *text = malloc(1 << 20);
    double spacing = case_real(req->c, "impact", "spacing");
    if (text && h5_attr_read_string(file, "case", text, 1 << 20) == SC_OK) {
        char *section = strstr(text, "[impact]");
        char *line = section ? strstr(section, "\nspacing = ") : NULL;
        char *next_section = section ? strstr(section + 1, "\n[") : NULL;
        if (line && (!next_section || line < next_section))
            spacing = strtod(line + strlen("\nspacing = "), NULL);
    }
    sc_error_clear();
    free(text);
    return render_point_radius(spacing);
}

/* ---- 3-D pictures ---- */

/* Snapshot i is a frame: every Nth, and the last. */
static int is_frame(const struct impact_run *run, int i)
{
    long every = run->req->cfg->every;
    return every > 0 && (i % every == 0 || i == run->snapshot_count - 1);
}

/* The colour range: [render] range_min/max, or the field's extremes over the snapshots drawn. */
static int colour_range(const struct impact_run *run, double *lo, double *hi)
{
    const struct render_config *cfg = run->req->cfg;
    *lo = cfg->range_min, *hi = cfg->range_max;
    if (!isnan(*lo) && !isnan(*hi))
        return SC_OK;
    double min = INFINITY, max = -INFINITY;
    for (int i = 0; i < run->snapshot_count; i++) {
        if (!is_frame(run, i) && i != run->snapshot_count - 1)
            continue;
        struct render_array value;
        double t;
        SC_TRY(read_snapshot(run, i, 0, NULL, &value, &t));
        for (size_t k = 0; k < value.count; k++)
            if (isfinite(value.values[k]))
                min = fmin(min, value.values[k]), max = fmax(max, value.values[k]);
        render_array_free(&value);
    }
    if (!(min <= max))
        min = 0, max = 1;
    if (min == max)
        max = min + (min != 0 ? 1e-6 * fabs(min) : 1);
    if (isnan(*lo))
        *lo = isnan(*hi) ? min : fmin(min, *hi - fabs(*hi) * 1e-6 - 1e-300);
    if (isnan(*hi))
        *hi = fmax(max, *lo + fabs(*lo) * 1e-6 + 1e-300);
    return SC_OK;
}

static int draw_snapshot(struct impact_run *run, struct render_renderer **renderer, int i, enum render_view view,
                         double lo, double hi, const char *path)
{
    const struct render_config *cfg = run->req->cfg;
    struct render_array x, value;
    double t;
    SC_TRY(read_snapshot(run, i, 1, &x, &value, &t));
    char caption[128];
    snprintf(caption, sizeof caption, "t = %.2f ns%s", t * 1e9, run->label);
    struct render_spheres spheres = {value.count, x.values, NULL, run->radius, value.values};
    struct render_scene scene = {view,
                                 cfg->width,
                                 cfg->height,
                                 lo,
                                 hi,
                                 field_labels[cfg->field],
                                 field_units[cfg->field],
                                 caption,
                                 cfg->section_y,
                                 0.5,
                                 1,
                                 0,
                                 0,
                                 NULL,
                                 NULL};
    const struct render_image *image;
    int status;
    SC_CHECK(status, render_renderer_get(cfg, renderer), done);
    SC_CHECK(status, render_spheres_draw(*renderer, &spheres, &scene, NULL, &image), done);
    SC_CHECK(status, render_image_write_png(image, path), done);
done:
    render_array_free(&x);
    render_array_free(&value);
    return status;
}

static int snapshot_pictures(struct impact_run *run, struct render_renderer **renderer, struct render_output *out)
{
    static const enum render_view views[] = {RENDER_VIEW_ISO, RENDER_VIEW_SECTION, RENDER_VIEW_TOP};
    static const char *const view_names[] = {"iso", "section", "top"};
    const struct render_config *cfg = run->req->cfg;
    if (run->snapshot_count == 0)
        return SC_OK;
    double lo, hi;
    SC_TRY(colour_range(run, &lo, &hi));
    char dir[4200], path[4400], name[64], title[160];
    render_figures_dir(run->req->run_dir, dir, sizeof dir);
    for (int v = 0; v < 3; v++) {
        snprintf(name, sizeof name, "%s_%s_%s", run->prefix, field_names[cfg->field], view_names[v]);
        snprintf(path, sizeof path, "%s/%s.png", dir, name);
        SC_TRY(draw_snapshot(run, renderer, run->snapshot_count - 1, views[v], lo, hi, path));
        snprintf(title, sizeof title, "%s, last snapshot, %s view%s", field_labels[cfg->field], view_names[v],
                 run->label);
        SC_TRY(render_output_push(out, name, "impact", 0, title, NULL));
    }
    const char *view_name = view_names[cfg->view == RENDER_VIEW_ISO ? 0 : cfg->view == RENDER_VIEW_SECTION ? 1 : 2];
    if (cfg->every > 0) { /* the film of this run: figures/film_impact/ or film_impact_run_NNNN/ */
        snprintf(path, sizeof path, "%s/film_%s", dir, run->prefix);
        SC_TRY(render_film_folder(path));
    }
    for (int i = 0; i < run->snapshot_count; i++) {
        if (!is_frame(run, i))
            continue;
        snprintf(path, sizeof path, "%s/film_%s/%s_%s_%s.png", dir, run->prefix, field_names[cfg->field], view_name,
                 run->snapshots[i]); /* film_impact_run_0001/eps_p_section_000003.png */
        SC_TRY(draw_snapshot(run, renderer, i, cfg->view, lo, hi, path));
        out->frames++;
    }
    return SC_OK;
}

/* ---- time series ---- */

struct series_data {
    struct render_array t, pbcp, v_rest, ke, internal, plastic, total, absorbed, removed, substrate;
};

static void series_free(struct series_data *s)
{
    struct render_array *all[] = {&s->t,       &s->pbcp,  &s->v_rest,   &s->ke,      &s->internal,
                                  &s->plastic, &s->total, &s->absorbed, &s->removed, &s->substrate};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        render_array_free(all[i]);
}

static int series_read(const struct impact_run *run, struct series_data *s)
{
    hid_t g = run->group;
    const char *p = run->path;
    SC_TRY(render_read_array(g, p, "series/t", &s->t));
    SC_TRY(render_read_array(g, p, "series/pbcp", &s->pbcp));
    SC_TRY(render_read_array(g, p, "series/v_rest", &s->v_rest));
    SC_TRY(render_read_array(g, p, "series/ke", &s->ke));
    SC_TRY(render_read_array(g, p, "series/plastic_work", &s->plastic));
    SC_TRY(render_read_array(g, p, "series/energy_total", &s->total));
    /* beyond the design's first list of figures: optional */
    if (h5_exists(g, "series/internal_energy"))
        SC_TRY(render_read_array(g, p, "series/internal_energy", &s->internal));
    if (h5_exists(g, "series/energy_absorbed"))
        SC_TRY(render_read_array(g, p, "series/energy_absorbed", &s->absorbed));
    if (h5_exists(g, "series/energy_removed"))
        SC_TRY(render_read_array(g, p, "series/energy_removed", &s->removed));
    if (h5_exists(g, "summary/substrate"))
        SC_TRY(render_read_array(g, p, "summary/substrate", &s->substrate));
    size_t nt = s->t.count;
    if (s->pbcp.rows != nt || s->v_rest.count != s->pbcp.count || s->ke.count != s->pbcp.count || s->total.count != nt)
        SC_FAIL(SC_EIO, "render: %s: /series datasets of inconsistent sizes", p);
    return SC_OK;
}

/* Per body b (not the substrate): column b of a (nt x nb) dataset, t in ns. */
static int per_body_figure(const struct impact_run *run, const struct series_data *s, const struct render_array *a,
                           double scale, const char *what, const char *ylabel, struct render_output *out)
{
    size_t nt = s->t.count, nb = a->width;
    double *buffer = malloc(((nb + 1) * nt + 1) * sizeof *buffer);
    struct render_series *series = calloc(nb + 1, sizeof *series);
    char(*labels)[32] = calloc(nb + 1, sizeof *labels);
    int status = SC_OK, count = 0;
    if (!buffer || !series || !labels)
        SC_FAIL_OOM_AT(status, done,
                       ((nb + 1) * nt + 1) * sizeof *buffer + (nb + 1) * (sizeof *series + sizeof *labels),
                       "a per-body figure");
    for (size_t i = 0; i < nt; i++)
        buffer[i] = s->t.values[i] * 1e9;
    for (size_t b = 0; b < nb; b++) {
        if (s->substrate.count == nb && s->substrate.values[b] == 1)
            continue;
        double *y = buffer + (b + 1) * nt;
        for (size_t i = 0; i < nt; i++)
            y[i] = a->values[i * nb + b] * scale;
        snprintf(labels[count], 32, "body %zu", b);
        series[count] = (struct render_series){labels[count], RENDER_LINE, nt, buffer, y, 0, count};
        count++;
    }
    char name[96], title[160];
    snprintf(name, sizeof name, "%s_%s", run->prefix, what);
    snprintf(title, sizeof title, "%s vs time per body%s", strcmp(what, "pbcp") == 0 ? "PBCP" : "v_rest", run->label);
    struct render_plot plot = render_plot_start(run->req->cfg, 1);
    plot.panels[0] = (struct render_panel){title, "time t (ns)", ylabel, NAN, NAN, NAN, NAN, 1, count, series};
    SC_CHECK(status, render_plot_publish(run->req->run_dir, out, name, "impact", title, &plot), done);
done:
    free(buffer), free(series), free(labels);
    return status;
}

/* Sum over bodies of a (nt x nb) dataset, in uJ; NAN when the dataset is absent. */
static void body_sum(const struct render_array *a, size_t nt, double *out)
{
    for (size_t i = 0; i < nt; i++) {
        out[i] = a->count ? 0 : NAN;
        for (size_t b = 0; a->count && b < a->width; b++)
            out[i] += a->values[i * a->width + b] * 1e6;
    }
}

static int energy_figure(const struct impact_run *run, const struct series_data *s, struct render_output *out)
{
    size_t nt = s->t.count;
    double *buffer = malloc((7 * nt + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((7 * nt + 1) * sizeof *buffer, "the energy figure");
    double *ns = buffer, *ke = buffer + nt, *internal = buffer + 2 * nt, *plastic = buffer + 3 * nt;
    double *total = buffer + 4 * nt, *absorbed = buffer + 5 * nt, *removed = buffer + 6 * nt;
    body_sum(&s->ke, nt, ke);
    body_sum(&s->internal, nt, internal);
    body_sum(&s->plastic, nt, plastic);
    for (size_t i = 0; i < nt; i++) {
        ns[i] = s->t.values[i] * 1e9;
        total[i] = s->total.values[i] * 1e6;
        absorbed[i] = s->absorbed.count ? s->absorbed.values[i] * 1e6 : NAN;
        removed[i] = s->removed.count ? s->removed.values[i] * 1e6 : NAN;
    }
    struct render_series series[] = {
        {"kinetic", RENDER_LINE, nt, ns, ke, 0, 0},
        {"internal", RENDER_LINE, nt, ns, internal, 0, 1},
        {"plastic work", RENDER_DASHED, nt, ns, plastic, 0, 1},
        {"absorbed by boundaries", RENDER_LINE, nt, ns, absorbed, 0, 2},
        {"carried off by removed points", RENDER_LINE, nt, ns, removed, 0, 3},
        {"total", RENDER_LINE, nt, ns, total, 0, 6},
    };
    char name[96], title[160];
    snprintf(name, sizeof name, "%s_energy", run->prefix);
    snprintf(title, sizeof title, "Energy balance%s", run->label);
    struct render_plot plot = render_plot_start(run->req->cfg, 1);
    plot.panels[0] = (struct render_panel){title, "time t (ns)", "energy (µJ)", NAN, NAN, NAN, NAN, 1, 6, series};
    int status;
    SC_CHECK(status, render_plot_publish(run->req->run_dir, out, name, "impact", title, &plot), done);
done:
    free(buffer);
    return status;
}

static int series_figures(const struct impact_run *run, struct render_output *out)
{
    struct series_data s;
    memset(&s, 0, sizeof s);
    int status;
    SC_CHECK(status, series_read(run, &s), done);
    SC_CHECK(status, per_body_figure(run, &s, &s.pbcp, 100, "pbcp", "PBCP (%)", out), done);
    SC_CHECK(status, per_body_figure(run, &s, &s.v_rest, 1, "v_rest", "restitution velocity v_rest (m/s)", out), done);
    SC_CHECK(status, energy_figure(run, &s, out), done);
done:
    series_free(&s);
    return status;
}

/* ---- runs ---- */

static int draw_run(struct impact_run *run, struct render_renderer **renderer, struct render_output *out)
{
    int status;
    SC_CHECK(status, series_figures(run, out), done);
    SC_CHECK(status, list_snapshots(run), done);
    SC_CHECK(status, snapshot_pictures(run, renderer, out), done);
done:
    free(run->snapshots);
    run->snapshots = NULL;
    return status;
}

struct run_names {
    int count;
    char names[1000][32];
};

static herr_t collect_run(hid_t group, const char *name, const H5L_info_t *info, void *data)
{
    (void)group, (void)info;
    struct run_names *runs = data;
    if (strncmp(name, "run_", 4) == 0 && runs->count < 1000)
        snprintf(runs->names[runs->count++], 32, "%s", name);
    return 0;
}

/* One run at the root (/series), or several in /run_NNNN groups. */
static int draw_runs(const struct render_request *req, hid_t file, const char *path, struct render_renderer **renderer,
                     struct render_output *out)
{
    struct impact_run run = {.req = req, .path = path, .group = file, .radius = point_radius(req, file)};
    if (h5_exists(file, "series")) {
        snprintf(run.prefix, sizeof run.prefix, "impact");
        SC_TRY(draw_run(&run, renderer, out));
        return SC_OK;
    }
    struct run_names *runs = calloc(1, sizeof *runs);
    if (!runs)
        SC_FAIL_OOM(sizeof *runs, "the list of impact runs");
    int status = SC_OK;
    if (H5Literate(file, H5_INDEX_NAME, H5_ITER_INC, NULL, collect_run, runs) < 0 || runs->count == 0)
        SC_FAIL_AT(status, done, SC_EIO, "render: %s has neither /series nor /run_NNNN groups (not an impact.h5?)",
                   path);
    for (int i = 0; i < runs->count; i++) {
        run.group = H5Gopen2(file, runs->names[i], H5P_DEFAULT);
        if (run.group < 0)
            SC_FAIL_AT(status, done, SC_EIO, "render: %s: cannot open /%s", path, runs->names[i]);
        snprintf(run.prefix, sizeof run.prefix, "impact_%s", runs->names[i]);
        snprintf(run.label, sizeof run.label, " (%s)", runs->names[i]);
        status = draw_run(&run, renderer, out);
        H5Gclose(run.group);
        SC_CHECK(status, status, done); /* the run's status, its group closed */
    }
done:
    free(runs);
    return status;
}

int render_impact_figures(const struct render_request *req, struct render_renderer **renderer,
                          struct render_output *out)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/impact.h5", req->run_dir);
    hid_t file;
    SC_TRY(render_open(path, &file));
    int status = draw_runs(req, file, path, renderer, out);
    H5Fclose(file);
    SC_TRY(status);
    log_info("render: impact figures from %s", path);
    return SC_OK;
}
