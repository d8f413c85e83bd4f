/* RUN_DIR/report.html: one page that opens with the result (the headline: deposit fraction of the spray, bonded
 * fraction of the MPM runs and its criterion, whether the two agree, coating thickness with its radial profile,
 * the couple stage's seeds, the impact resolution), then the tables (one row per particle body of every impact
 * run), every figure (images beside it in figures/, so the page is small and the PNGs stay usable on their own),
 * and provenance and the case collapsed at the end. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/logistic.h"
#include "core/version.h"
#include "render/render_impl.h"

static void escaped(FILE *f, const char *text)
{
    for (const char *p = text ? text : ""; *p; p++) {
        switch (*p) {
        case '<':
            fputs("&lt;", f);
            break;
        case '>':
            fputs("&gt;", f);
            break;
        case '&':
            fputs("&amp;", f);
            break;
        case '"':
            fputs("&quot;", f);
            break;
        default:
            fputc(*p, f);
        }
    }
}

static void cell(FILE *f, const char *tag, const char *text)
{
    fprintf(f, "<%s>", tag);
    escaped(f, text);
    fprintf(f, "</%s>", tag);
}

static const char style[] =
    "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left}"
    "th{background:#f2f2f2}tr.differs td{background:#fff3cd}tr.unsettled td{font-style:italic;color:#666}#headline "
    "li{margin:0.3em 0}"
    "#headline figure{width:60%}summary{cursor:pointer;font-weight:bold;margin:1em "
    "0}figure{display:inline-block;width:47%;margin:0.5em;vertical-align:top}"
    "figure img{width:100%;border:1px solid #ddd}figcaption{font-size:90%}";

/* One row per output file: its root attributes. */
static void provenance(FILE *f, const struct render_request *req)
{
    static const char *const files[] = {"spray.h5", "couple.h5", "impact.h5", "vcrit.h5", "calibrate.h5", "sweep.h5"};
    static const char *const attributes[] = {"format", "program_version", "case_hash", "created"};
    char now[64];
    time_t t = time(NULL);
    strftime(now, sizeof now, "%Y-%m-%dT%H:%M:%SZ", gmtime(&t));
    fprintf(f, "<h2>Provenance</h2>\n<table><tr><th>spraycoat</th>");
    cell(f, "td", spraycoat_version());
    fprintf(f, "</tr><tr><th>case hash</th><td>%016llx</td></tr><tr><th>rendered (UTC)</th>",
            (unsigned long long)req->case_hash);
    cell(f, "td", now);
    fprintf(f, "</tr></table>\n<table><tr><th>file</th><th>format</th><th>written by</th><th>case hash</th>"
               "<th>written (UTC)</th></tr>\n");
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        char path[4200], value[256];
        snprintf(path, sizeof path, "%s/%s", req->run_dir, files[i]);
        hid_t file;
        if (!render_input_present(req, files[i]) || access(path, R_OK) != 0 || h5_open_read(path, &file) != SC_OK) {
            sc_error_clear();
            continue;
        }
        fprintf(f, "<tr>");
        cell(f, "td", files[i]);
        for (int k = 0; k < 4; k++) {
            if (h5_attr_read_string(file, attributes[k], value, sizeof value) != SC_OK)
                snprintf(value, sizeof value, "?");
            cell(f, "td", value);
        }
        sc_error_clear();
        H5Fclose(file);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
}

static void case_summary(FILE *f, const struct render_request *req)
{
    fprintf(f, "<h2>Case</h2>\n<p>The keys the case file gives (every other key has its default; "
               "<code>spraycoat check</code> lists them all).</p>\n<table><tr><th>section</th><th>key</th>"
               "<th>value</th><th>unit</th></tr>\n");
    for (int i = 0; i < req->row_count; i++) {
        const struct render_case_row *r = &req->rows[i];
        fprintf(f, "<tr>");
        cell(f, "td", r->section), cell(f, "td", r->key), cell(f, "td", r->value), cell(f, "td", r->unit);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
}

/* ---- numbers for people ---------------------------------------------------------------------------------- */

/* `digits` significant digits, fixed notation between 1e-3 and 1e6, "n/a" for NaN and infinities. */
struct number {
    char s[48];
};
static struct number num(double v, int digits)
{
    struct number n;
    if (!isfinite(v)) {
        snprintf(n.s, sizeof n.s, "n/a");
        return n;
    }
    if (v == 0) {
        snprintf(n.s, sizeof n.s, "0");
        return n;
    }
    int magnitude = (int)floor(log10(fabs(v)));
    if (magnitude >= 6 || magnitude < -3)
        snprintf(n.s, sizeof n.s, "%.*e", digits - 1, v);
    else
        snprintf(n.s, sizeof n.s, "%.*f", digits - 1 - magnitude > 0 ? digits - 1 - magnitude : 0, v);
    return n;
}

/* A value of the case (a threshold, a spacing) or a count: as short as it is, up to 6 significant digits. */
static struct number given(double v)
{
    struct number n;
    snprintf(n.s, sizeof n.s, "%.6g", v);
    return n;
}

/* "lo to hi", or one number when they print the same. */
static struct number span(struct number lo, struct number hi)
{
    struct number n;
    if (strcmp(lo.s, hi.s) == 0)
        snprintf(n.s, sizeof n.s, "%s", lo.s);
    else
        snprintf(n.s, sizeof n.s, "%.20s to %.20s", lo.s, hi.s);
    return n;
}

static void number_cell_digits(FILE *f, double value, int digits)
{
    cell(f, "td", num(value, digits).s);
}

/* ---- what the run's files say ------------------------------------------------------------------------------ */

/* One particle body of an impact run (the substrate left out). */
struct body_row {
    int run;         /* -1: a single impact run (top-level /summary) */
    size_t body;     /* index in impact.h5 (0-based, the substrate included) */
    size_t particle; /* its index among the run's particle bodies (the couple's /seeds body) */
    double d, v, bonded, pbcp, v_rest, cor;
    double bonded_interface; /* share of its interface nodes bonded at the end (NAN: a file without it) */
    int seed;                /* its row of couple.h5 /seeds, -1 when none */
    double spacing;          /* m, its run's point spacing (stats; NAN: a file without it, the case's then) */
};

struct seed_row {
    long run, body, particle_id, impact_row;
    double d, v_spray, v_wall;
    int spray_outcome; /* outcome of the particle's first contact in spray.h5: 0 rebound, 1 deposited, -1 none */
};

struct report_data {
    /* spray.h5 */
    int spray;
    int64_t injected, deposited, escaped, in_flight, resting;
    double t_spray, deposit_fraction, volume_fraction, spread, scatter, max_thickness;
    double standoff, deposit_top; /* the target plane's z; the highest deposited particle's top above it (NAN: none) */
    double target_gap_max, target_gap_mean; /* how far above the target those stuck on it rest (NAN: none) */
    int profile_bins;
    double profile_r[20], profile_h[20], profile_width;
    /* a moving nozzle: /deposit's mean thickness over the swept band and a line's Gaussian fit (NAN: none) */
    int moves;
    double mean_thickness, band_lo, band_hi, fit_amplitude, fit_amplitude_error, fit_width, fit_centre;
    double packing; /* [path] packing of the height map (dem/deposit.c divides by it); NaN in files without it */
    /* couple.h5 */
    struct seed_row *seeds;
    size_t seed_count;
    /* impact.h5 */
    int impact, runs;
    struct body_row *rows;
    size_t row_count, row_capacity;
    double points_min, points_max, t_impact;
    int64_t uncalibrated; /* particles off their bonding calibration's resolution (/summary attribute), -1 unknown */
    /* spray.h5 /deposition_efficiency (NAN: none) */
    double de, de_sprayed_mass, de_deposited_mass;
    int64_t table_impacts, table_impacts_outside; /* /deposition_efficiency attributes (0: none, or no table) */
};

static double last(hid_t file, const char *name)
{
    struct render_array a;
    double value = NAN;
    if (render_read_array(file, "spray.h5", name, &a) == SC_OK && a.count > 0)
        value = a.values[a.count - 1];
    render_array_free(&a);
    return value;
}

static double deposit_attribute(hid_t deposit, const char *name)
{
    double value = NAN;
    if (H5Aexists(deposit, name) > 0 && h5_attr_read_double(deposit, name, &value) != SC_OK)
        sc_error_clear(), value = NAN;
    return value;
}

/* The deposit of a moving nozzle (dem/deposit.c): the radial profile about the origin means nothing there. */
static void read_deposit(hid_t file, struct report_data *r)
{
    hid_t g = H5Gopen2(file, "deposit", H5P_DEFAULT);
    if (g < 0) {
        sc_error_clear();
        r->mean_thickness = r->fit_amplitude = NAN;
        return;
    }
    r->mean_thickness = deposit_attribute(g, "mean_thickness");
    r->packing = deposit_attribute(g, "packing");
    r->band_lo = deposit_attribute(g, "band_lo");
    r->band_hi = deposit_attribute(g, "band_hi");
    r->fit_amplitude = deposit_attribute(g, "fit_amplitude");
    r->fit_amplitude_error = deposit_attribute(g, "fit_amplitude_error");
    r->fit_width = deposit_attribute(g, "fit_width");
    r->fit_centre = deposit_attribute(g, "fit_centre");
    H5Gclose(g);
}

/* A gap between the target and a particle stuck on it beyond round-off (m). */
#define TARGET_GAP_SHOWN 1e-9

/* The particles that stuck on the target rest touching it, unless one was held off by a particle in the way (or the
 * file is of a version that left them where they met it within their drag skin) (docs/physics.md "Contact
 * detection"): their gaps to it, from /impacts (outcome stuck, partner -1: the target). */
static void read_target_gaps(hid_t file, struct report_data *r)
{
    struct render_array x = {0}, d = {0}, outcome = {0}, partner = {0};
    r->target_gap_max = r->target_gap_mean = NAN;
    if (render_read_array(file, "spray.h5", "impacts/x", &x) == SC_OK &&
        render_read_array(file, "spray.h5", "impacts/d", &d) == SC_OK &&
        render_read_array(file, "spray.h5", "impacts/outcome", &outcome) == SC_OK &&
        render_read_array(file, "spray.h5", "impacts/partner", &partner) == SC_OK && x.count == 3 * d.count &&
        outcome.count == d.count && partner.count == d.count) {
        double sum = 0.0, largest = -INFINITY;
        size_t n = 0;
        for (size_t k = 0; k < d.count; k++)
            if (outcome.values[k] == 1 && partner.values[k] < 0) { /* DEM_STUCK on the target */
                double gap = r->standoff - x.values[3 * k + 2] - 0.5 * d.values[k];
                sum += gap, largest = fmax(largest, gap), n++;
            }
        if (n > 0)
            r->target_gap_max = largest, r->target_gap_mean = sum / (double)n;
    }
    sc_error_clear();
    render_array_free(&x), render_array_free(&d), render_array_free(&outcome), render_array_free(&partner);
}

static void read_spray(hid_t file, struct report_data *r)
{
    r->spray = 1;
    hid_t stats = h5_exists(file, "stats") ? H5Gopen2(file, "stats", H5P_DEFAULT) : H5I_INVALID_HID;
    if (stats >= 0) {
        h5_attr_read_int64(stats, "injected", &r->injected);
        h5_attr_read_int64(stats, "deposited", &r->deposited);
        h5_attr_read_int64(stats, "escaped", &r->escaped);
        h5_attr_read_int64(stats, "in_flight", &r->in_flight);
        h5_attr_read_int64(stats, "resting", &r->resting);
        h5_attr_read_double(stats, "t", &r->t_spray);
        H5Gclose(stats);
    }
    r->deposit_fraction = last(file, "metrics/deposit_fraction");
    r->volume_fraction = last(file, "metrics/volume_fraction");
    r->spread = last(file, "metrics/mean_spread");
    r->scatter = last(file, "metrics/scatter");
    r->max_thickness = last(file, "metrics/max_thickness");
    r->de = last(file, "deposition_efficiency/de");
    r->de_sprayed_mass = last(file, "deposition_efficiency/sprayed_mass");
    r->de_deposited_mass = last(file, "deposition_efficiency/deposited_mass");
    hid_t de = h5_exists(file, "deposition_efficiency") ? H5Gopen2(file, "deposition_efficiency", H5P_DEFAULT)
                                                        : H5I_INVALID_HID;
    if (de >= 0) {
        if (H5Aexists(de, "table_impacts_outside") > 0 && H5Aexists(de, "table_impacts") > 0) {
            h5_attr_read_int64(de, "table_impacts_outside", &r->table_impacts_outside);
            h5_attr_read_int64(de, "table_impacts", &r->table_impacts);
        }
        H5Gclose(de);
    }
    sc_error_clear();
    read_target_gaps(file, r);
    r->moves = render_nozzle_moves(file);
    if (r->moves)
        read_deposit(file, r);
    struct render_array x = {0}, d = {0}, state = {0};
    r->deposit_top = NAN;
    if (render_read_array(file, "spray.h5", "particles/x", &x) == SC_OK &&
        render_read_array(file, "spray.h5", "particles/d", &d) == SC_OK &&
        render_read_array(file, "spray.h5", "particles/state", &state) == SC_OK && x.count == 3 * d.count &&
        state.count == d.count) {
        for (size_t i = 0; i < d.count; i++)
            if (state.values[i] == 1) /* deposited: its top, the target below it at z = standoff */
                r->deposit_top = fmax(isnan(r->deposit_top) ? -INFINITY : r->deposit_top,
                                      r->standoff - x.values[3 * i + 2] + 0.5 * d.values[i]);
        if (!r->moves)
            r->profile_bins = render_thickness_profile(x.values, d.values, state.values, d.count, 20, r->profile_r,
                                                       r->profile_h, &r->profile_width);
    }
    render_array_free(&x), render_array_free(&d), render_array_free(&state);
    /* the spray's verdict on each seeded particle: the outcome of its first contact (smallest t) */
    struct render_array t = {0}, id = {0}, outcome = {0};
    if (r->seed_count > 0 && render_read_array(file, "spray.h5", "impacts/t", &t) == SC_OK &&
        render_read_array(file, "spray.h5", "impacts/particle_id", &id) == SC_OK &&
        render_read_array(file, "spray.h5", "impacts/outcome", &outcome) == SC_OK && id.count == t.count &&
        outcome.count == t.count) {
        for (size_t k = 0; k < r->seed_count; k++) {
            size_t first = (size_t)-1;
            for (size_t i = 0; i < t.count; i++)
                if (id.values[i] == (double)r->seeds[k].particle_id &&
                    (first == (size_t)-1 || t.values[i] < t.values[first]))
                    first = i;
            r->seeds[k].spray_outcome = first == (size_t)-1 ? -1 : (int)outcome.values[first];
        }
    }
    render_array_free(&t), render_array_free(&id), render_array_free(&outcome);
    sc_error_clear();
}

static void read_couple(hid_t file, struct report_data *r)
{
    static const char *const names[] = {"seeds/run", "seeds/body",    "seeds/particle_id", "seeds/impact_row",
                                        "seeds/d",   "seeds/v_spray", "seeds/v_wall"};
    struct render_array a[7];
    int ok = 1;
    for (int k = 0; k < 7; k++)
        ok = render_read_array(file, "couple.h5", names[k], &a[k]) == SC_OK && ok;
    size_t n = ok ? a[0].count : 0;
    for (int k = 0; ok && k < 7; k++)
        ok = a[k].count == (k >= 5 ? 3 * n : n);
    if (ok && n > 0 && (r->seeds = calloc(n, sizeof *r->seeds)) != NULL) {
        r->seed_count = n;
        for (size_t i = 0; i < n; i++) {
            const double *vs = a[5].values + 3 * i, *vw = a[6].values + 3 * i;
            r->seeds[i] = (struct seed_row){(long)a[0].values[i],
                                            (long)a[1].values[i],
                                            (long)a[2].values[i],
                                            (long)a[3].values[i],
                                            a[4].values[i],
                                            sqrt(vs[0] * vs[0] + vs[1] * vs[1] + vs[2] * vs[2]),
                                            sqrt(vw[0] * vw[0] + vw[1] * vw[1] + vw[2] * vw[2]),
                                            -1};
        }
    }
    for (int k = 0; k < 7; k++)
        render_array_free(&a[k]);
    sc_error_clear();
}

/* The particle bodies of one /summary group (loc: the file or a /run_NNNN group). */
static void read_summary(hid_t loc, int run, struct report_data *r)
{
    /* summary/verdict (-1 substrate, 0 rebounded, 1 bonded, 2 unsettled; mpm/verdict.c), or in files without it
     * summary/bonded (-1, 0, 1) */
    const char *names[] = {"summary/diameter", "summary/v_impact", "summary/verdict",
                           "summary/pbcp",     "summary/v_rest",   "summary/cor"};
    if (!h5_exists(loc, names[2]))
        names[2] = "summary/bonded";
    struct render_array a[6];
    int ok = 1;
    for (int k = 0; k < 6; k++)
        ok = render_read_array(loc, "impact.h5", names[k], &a[k]) == SC_OK && ok && a[k].count == a[0].count;
    /* summary/bonded_interface: in files of format version 2 on */
    struct render_array interface = {0};
    if (ok && h5_exists(loc, "summary/bonded_interface"))
        render_read_array(loc, "impact.h5", "summary/bonded_interface", &interface);
    double spacing = NAN; /* the run's own ([couple] reference_diameter scales it) */
    hid_t run_stats = h5_exists(loc, "stats") ? H5Gopen2(loc, "stats", H5P_DEFAULT) : H5I_INVALID_HID;
    if (run_stats >= 0) {
        if (H5Aexists(run_stats, "spacing") > 0)
            h5_attr_read_double(run_stats, "spacing", &spacing);
        H5Gclose(run_stats);
    }
    size_t particle = 0;
    for (size_t b = 0; ok && b < a[0].count; b++) {
        if (a[2].values[b] < 0)
            continue; /* the substrate */
        if (r->row_count == r->row_capacity) {
            size_t capacity = r->row_capacity ? 2 * r->row_capacity : 16;
            struct body_row *grown = realloc(r->rows, capacity * sizeof *grown);
            if (!grown)
                break;
            r->rows = grown, r->row_capacity = capacity;
        }
        struct body_row *row = &r->rows[r->row_count++];
        *row = (struct body_row){run,
                                 b,
                                 particle,
                                 a[0].values[b],
                                 a[1].values[b],
                                 a[2].values[b],
                                 a[3].values[b],
                                 a[4].values[b],
                                 a[5].values[b],
                                 interface.count == a[0].count ? interface.values[b] : NAN,
                                 -1,
                                 spacing};
        for (size_t s = 0; s < r->seed_count; s++) /* the same particle: same run, place and diameter */
            if (r->seeds[s].run == (run < 0 ? 0 : run) && r->seeds[s].body == (long)particle &&
                fabs(r->seeds[s].d - row->d) <= 0.01 * row->d)
                row->seed = (int)s;
        particle++;
    }
    for (int k = 0; k < 6; k++)
        render_array_free(&a[k]);
    render_array_free(&interface);
    int64_t points;
    double t_end;
    hid_t stats = h5_exists(loc, "stats") ? H5Gopen2(loc, "stats", H5P_DEFAULT) : H5I_INVALID_HID;
    if (stats >= 0) {
        if (h5_attr_read_int64(stats, "points", &points) == SC_OK) {
            r->points_min = fmin(r->points_min, (double)points);
            r->points_max = fmax(r->points_max, (double)points);
        }
        if (h5_attr_read_double(stats, "t_end", &t_end) == SC_OK)
            r->t_impact = fmax(r->t_impact, t_end); /* the longest run (runs end once settled) */
        H5Gclose(stats);
    }
    r->runs++;
    sc_error_clear();
}

static herr_t read_run_group(hid_t parent, const char *name, const H5L_info_t *info, void *data)
{
    (void)info;
    if (strncmp(name, "run_", 4) != 0)
        return 0;
    hid_t g = H5Gopen2(parent, name, H5P_DEFAULT);
    if (g < 0)
        return 0;
    read_summary(g, atoi(name + 4), data);
    H5Gclose(g);
    return 0;
}

/* A pipeline's impact.h5 has /run_NNNN/summary per body (and a top-level /summary of per-run means); a single
 * impact run has /summary per body. */
static void read_impact(hid_t file, struct report_data *r)
{
    r->impact = 1;
    r->points_min = INFINITY, r->points_max = -INFINITY, r->t_impact = NAN;
    r->uncalibrated = -1;
    hid_t summary = h5_exists(file, "summary") ? H5Gopen2(file, "summary", H5P_DEFAULT) : H5I_INVALID_HID;
    if (summary >= 0) {
        if (H5Aexists(summary, "uncalibrated_bodies") > 0)
            h5_attr_read_int64(summary, "uncalibrated_bodies", &r->uncalibrated);
        H5Gclose(summary);
    }
    if (h5_exists(file, "summary/diameter"))
        read_summary(file, -1, r);
    else
        H5Literate(file, H5_INDEX_NAME, H5_ITER_INC, NULL, read_run_group, r);
    sc_error_clear();
}

static int open_output(const struct render_request *req, const char *name, hid_t *file)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", req->run_dir, name);
    if (!render_input_present(req, name) || access(path, R_OK) != 0 || h5_open_read(path, file) != SC_OK) {
        sc_error_clear();
        return 0;
    }
    return 1;
}

static void report_read(const struct render_request *req, struct report_data *r)
{
    memset(r, 0, sizeof *r);
    r->standoff = case_real(req->c, "target", "standoff");
    hid_t file;
    if (open_output(req, "couple.h5", &file))
        read_couple(file, r), H5Fclose(file);
    if (open_output(req, "spray.h5", &file))
        read_spray(file, r), H5Fclose(file);
    if (open_output(req, "impact.h5", &file))
        read_impact(file, r), H5Fclose(file);
}

static void report_free(struct report_data *r)
{
    free(r->seeds);
    free(r->rows);
}

/* ---- the page ---------------------------------------------------------------------------------------------- */

/* The resolution the defaults of the case's bonding model were calibrated on (docs/physics.md, "Bonding
 * calibration"): change it with them.  NULL: no bonding model. */
static const char *calibration_resolution(const struct case_file *c)
{
    const char *model = case_text(c, "impact", "bonding");
    if (strcmp(model, "strain") == 0) /* eps_c, eps_rate_c: docs/physics.md, the calibration with them both fitted */
        return "10 grid cells across the particle's diameter with points a third of a cell apart (1.4/0.467 µm for "
               "14 µm; the fit at 15 cells across, eps_c = 3.036, is cases/vcrit_al_15cells.ini)";
    if (strcmp(model, "energy") == 0) /* Gc, Gc_rate: cases/bonding_calibration_al.csv */
        return "grid cells of 2.0 µm with points 0.667 µm apart";
    return NULL;
}

/* Whose bonding parameters the run used, and the resolution the shipped ones belong to: a case that sets its own
 * (e.g. cases/vcrit_al_15cells.ini, fitted at 15 cells across) is told so rather than that the defaults apply. */
static void calibration_sentence(FILE *f, const struct case_file *c)
{
    const char *calibrated = calibration_resolution(c);
    if (!calibrated)
        return;
    const char *model = case_text(c, "impact", "bonding");
    int strain = strcmp(model, "strain") == 0;
    const char *key = strain ? "eps_c" : "Gc", *rate_key = strain ? "eps_rate_c" : "Gc_rate";
    fprintf(f, ". The ");
    int own =
        (case_is_given(c, "impact", key) && !case_is(c, "impact", key, "auto")) || case_is_given(c, "impact", rate_key);
    if (own)
        fprintf(f,
                "case sets the bonding model's parameters (<code>[impact] bonding = %s</code>, %s = %s, %s = %s); "
                "the shipped ones",
                model, key, case_is(c, "impact", key, "auto") ? "auto" : given(case_real(c, "impact", key)).s, rate_key,
                given(case_real(c, "impact", rate_key)).s);
    else
        fprintf(f, "shipped parameters of the bonding model (<code>[impact] bonding = %s</code>)", model);
    fprintf(f,
            " belong to %s (docs/physics.md, \"Bonding calibration\"): at another resolution the verdicts are not "
            "calibrated",
            calibrated);
    /* eps_c = auto takes the strain model's calibration with conduction (mpm/params.c); every other was adiabatic */
    if (case_is(c, "impact", "conduction", "on") && strain && !own)
        fprintf(f, "; with heat conduction (<code>[impact] conduction = on</code>) the strain model's calibration "
                   "made with it, eps_c = 2.506 (cases/calibrate_vcrit_al_conduction.ini)");
    else if (case_is(c, "impact", "conduction", "on"))
        fprintf(f, "; the impacts ran with heat conduction (<code>[impact] conduction = on</code>), the calibration "
                   "without it (docs/physics.md, \"Heat conduction\")");
}

enum verdict { BONDED, REBOUNDED, STUCK, UNSETTLED };
static enum verdict verdict(const struct body_row *row, double vrest_threshold)
{
    if (row->bonded == 1)
        return BONDED;
    if (row->bonded == 2 || !isfinite(row->v_rest)) /* not settled by the run's end (mpm/verdict.c), or no v_rest */
        return UNSETTLED;
    return row->v_rest > vrest_threshold ? REBOUNDED : STUCK;
}

static const char *spray_said(const struct report_data *r, const struct body_row *row)
{
    if (row->seed < 0)
        return "-";
    int o = r->seeds[row->seed].spray_outcome;
    return o == 1 ? "deposited" : o == 0 ? "rebounded" : "-";
}

struct tally {
    size_t bonded, rebounded, stuck, unsettled, compared, disagree, deposited_not_bonded, rebounded_bonded;
    double d_min, d_max;
};
static struct tally tally(const struct report_data *r, double vrest_threshold)
{
    struct tally t = {.d_min = INFINITY, .d_max = -INFINITY};
    for (size_t i = 0; i < r->row_count; i++) {
        const struct body_row *row = &r->rows[i];
        enum verdict v = verdict(row, vrest_threshold);
        t.bonded += v == BONDED, t.rebounded += v == REBOUNDED, t.stuck += v == STUCK, t.unsettled += v == UNSETTLED;
        t.d_min = fmin(t.d_min, row->d), t.d_max = fmax(t.d_max, row->d);
        int o = row->seed >= 0 ? r->seeds[row->seed].spray_outcome : -1;
        if (o < 0 || v == UNSETTLED)
            continue;
        t.compared++;
        if (o == 1 && v != BONDED)
            t.disagree++, t.deposited_not_bonded++;
        if (o == 0 && v == BONDED)
            t.disagree++, t.rebounded_bonded++;
    }
    return t;
}

/* What the height map's thickness is: the volume over the area at [path] packing = 1 (or in a file without the
 * attribute), 1/packing times that otherwise (dem/deposit.c); "dense-equivalent" was written whatever the packing (a
 * review: 25.9 um at packing 0.5, whose dense-equivalent is 12.9). */
static const char *thickness_kind(const struct report_data *r, char *out, size_t size)
{
    if (!(r->packing > 0.0) || r->packing == 1.0) /* NaN, or 0: a file without /deposit or the attribute */
        snprintf(out, size, "dense-equivalent thickness");
    else
        snprintf(out, size, "thickness at packing %.3g (the dense-equivalent over %.3g)", r->packing, r->packing);
    return out;
}

/* The coating of a moving nozzle: the mean thickness across the passes and, for a line, the track's Gaussian fit. */
static void moving_thickness(FILE *f, const struct report_data *r)
{
    char kind[160];
    if (isfinite(r->mean_thickness))
        fprintf(f,
                "; %s %s µm on average over the middle half of the passes' length and y = %s to %s mm, the band the "
                "nozzle swept (<code>spray.h5 /deposit mean_thickness</code>)",
                thickness_kind(r, kind, sizeof kind), num(r->mean_thickness * 1e6, 3).s, num(r->band_lo * 1e3, 3).s,
                num(r->band_hi * 1e3, 3).s);
    else
        fprintf(f, "; no thickness profile across the path (<code>spray.h5 /deposit</code>)");
    if (isfinite(r->fit_amplitude))
        fprintf(f,
                "; the track's Gaussian fit: amplitude %s &plusmn; %s µm, standard deviation %s mm, centre y = %s "
                "mm (figure deposit_profile)",
                num(r->fit_amplitude * 1e6, 3).s, num(r->fit_amplitude_error * 1e6, 2).s, num(r->fit_width * 1e3, 3).s,
                num(r->fit_centre * 1e3, 3).s);
}

/* vcrit.h5: how many searches bracketed a v_crit, and its range (the table and each search's note below). */
static void vcrit_headline(FILE *f, const struct render_request *req)
{
    hid_t file;
    if (!open_output(req, "vcrit.h5", &file))
        return;
    struct render_array v = {0};
    int searches = 0;
    while (searches < 1000) {
        char name[32];
        snprintf(name, sizeof name, "search/%03d", searches);
        if (!h5_exists(file, name))
            break;
        searches++;
    }
    double lo = INFINITY, hi = -INFINITY;
    if (render_read_array(file, "vcrit.h5", "v_crit", &v) == SC_OK)
        for (size_t i = 0; i < v.count; i++)
            lo = fmin(lo, v.values[i]), hi = fmax(hi, v.values[i]);
    sc_error_clear();
    if (searches > 0)
        fprintf(f, "<li><b>Critical velocity: %zu of %d searches bracketed a v_crit</b>", v.count, searches);
    else /* a vcrit.h5 without its searches (of an older version) */
        fprintf(f, "<li><b>Critical velocity: %zu bracketed</b>", v.count);
    if (v.count > 0)
        fprintf(f, ", from %s to %s m/s", num(lo, 4).s, num(hi, 4).s);
    fprintf(f, " (the table and the searches' notes below).</li>\n");
    render_array_free(&v);
    H5Fclose(file);
}

/* sweep.h5: the range of the DE over the map (the table below, the map in figure sweep_de). */
static void sweep_headline(FILE *f, const struct render_request *req)
{
    hid_t file;
    if (!open_output(req, "sweep.h5", &file))
        return;
    struct render_array de = {0};
    double lo = INFINITY, hi = -INFINITY;
    unsigned char *lower_bound = NULL;
    size_t marked = 0;
    int ok = render_read_array(file, "sweep.h5", "de", &de) == SC_OK &&
             render_sweep_lower_bounds(file, "sweep.h5", de.count, &lower_bound, &marked) == SC_OK;
    for (size_t i = 0; ok && i < de.count; i++)
        lo = fmin(lo, de.values[i]), hi = fmax(hi, de.values[i]);
    sc_error_clear();
    char bounds[160] = "";
    if (marked > 0)
        snprintf(bounds, sizeof bounds, "; %zu of them lower bounds, with particles still in flight at the end",
                 marked);
    if (ok && de.count > 0) /* (a damaged sweep.h5 left the span at +-inf) */
        fprintf(f,
                "<li><b>Sweep: deposition efficiency %s %%</b> over %zu runs%s (the table below, the map in figure "
                "sweep_de).</li>\n",
                span(num(100 * lo, 3), num(100 * hi, 3)).s, de.count, bounds);
    free(lower_bound);
    render_array_free(&de);
    H5Fclose(file);
}

/* The coating: its top, and its thickness as a moving nozzle's mean or a fixed nozzle's radial profile. */
static void coating_headline(FILE *f, const struct report_data *r)
{
    if (!isfinite(r->deposit_top)) {
        fprintf(f, "<li><b>Coating thickness: nothing deposited</b>.</li>\n");
        return;
    }
    fprintf(f,
            "<li><b>Coating thickness: up to %s µm</b> (the top of the highest deposited particle above the "
            "target; their centres span %s µm in height, <code>spray.h5 /metrics/max_thickness</code>)",
            num(r->deposit_top * 1e6, 3).s, num(r->max_thickness * 1e6, 3).s);
    if (r->target_gap_max > TARGET_GAP_SHOWN) /* one held off the target by a particle in the way, or an older file */
        fprintf(f,
                "; the particles stuck on the target rest %s µm above it on average, at most %s µm (where they met "
                "it within their drag skin, docs/physics.md \"Contact detection\")",
                num(r->target_gap_mean * 1e6, 3).s, num(r->target_gap_max * 1e6, 3).s);
    if (r->moves) {
        moving_thickness(f, r);
    } else if (r->profile_bins > 0) {
        double peak = 0;
        for (int b = 0; b < r->profile_bins; b++)
            peak = fmax(peak, r->profile_h[b]);
        fprintf(f,
                "; dense-equivalent thickness %s µm at the axis (r &lt; %s mm), at most %s µm, out to "
                "r = %s mm (profile below)",
                num(r->profile_h[0] * 1e6, 3).s, num(r->profile_width * 1e3, 3).s, num(peak * 1e6, 3).s,
                num(r->profile_width * r->profile_bins * 1e3, 3).s);
    }
    fprintf(f, ".</li>\n");
}

/* The spray's counts and its deposition efficiency. */
static void spray_headline(FILE *f, const struct case_file *c, const struct report_data *r)
{
    if (!r->spray)
        return;
    fprintf(f,
            "<li><b>Spray: deposit fraction %s %%</b>: %lld of %lld injected particles deposited on the "
            "target (rule <code>[deposition] rule = ",
            num(100 * r->deposit_fraction, 3).s, (long long)r->deposited, (long long)r->injected);
    escaped(f, case_text(c, "deposition", "rule"));
    fprintf(f,
            "</code>); at t = %s ms %lld still in flight, %lld resting unbonded on the target, %lld "
            "escaped.</li>\n",
            given(r->t_spray * 1e3).s, (long long)r->in_flight, (long long)r->resting, (long long)r->escaped);
    if (isfinite(r->de))
        fprintf(f,
                "<li><b>Deposition efficiency %s %%</b> by mass: %s µg deposited of %s µg sprayed (by size "
                "class and first-impact angle in figure spray_de).</li>\n",
                num(100 * r->de, 3).s, num(r->de_deposited_mass * 1e9, 3).s, num(r->de_sprayed_mass * 1e9, 3).s);
}

/* The MPM runs' bonded fraction (with its interval where the particles were sampled), the criterion, and how
 * the spray's verdicts on the same particles compare. */
static void impact_headline(FILE *f, const struct case_file *c, const struct report_data *r, const struct tally *t)
{
    if (!r->impact)
        return;
    if (r->row_count == 0) {
        fprintf(f, "<li><b>Impact (MPM): no particle body found in impact.h5</b>.</li>\n");
        return;
    }
    double pbcp_threshold = case_real(c, "impact", "pbcp_threshold");
    double vrest_threshold = case_real(c, "impact", "vrest_threshold");
    fprintf(f, "<li><b>Impact (MPM): bonded fraction %s %%</b>",
            num(100.0 * (double)t->bonded / (double)r->row_count, 3).s);
    if (r->seed_count > 0) { /* sampled from the spray: a handful's sampling error is the first thing to read */
        double lo, hi;       /* the unsettled either way (app/info.c's headline likewise) */
        logistic_wilson_bounds(t->bonded, t->unsettled, r->row_count, 1.959964, &lo, &hi);
        fprintf(f, " (95 %% interval %s-%s %%, Wilson, for %zu particle%s%s)", num(100.0 * lo, 3).s,
                num(100.0 * hi, 3).s, r->row_count, r->row_count == 1 ? "" : "s",
                t->unsettled ? ", the unsettled counted as bonded and as not bonded" : "");
    }
    fprintf(f, ": %zu of %zu %sparticles bonded in %d run%s", t->bonded, r->row_count,
            r->seed_count > 0 ? "sampled " : "", r->runs, r->runs == 1 ? "" : "s");
    const char *sep = " (";
    if (t->rebounded)
        fprintf(f, "%s%zu rebounded", sep, t->rebounded), sep = ", ";
    if (t->stuck)
        fprintf(f, "%s%zu not bonded with v_rest &le; the threshold but PBCP below it", sep, t->stuck), sep = ", ";
    if (t->unsettled)
        fprintf(f, "%s%zu unsettled: the verdict still changing at the end", sep, t->unsettled), sep = ", ";
    fprintf(f,
            "%s. Criterion: bonded when PBCP &ge; %s %% and v_rest &le; %s m/s once the verdict has settled "
            "(<code>[impact] pbcp_threshold, vrest_threshold, settle_*</code>); a run ends when every verdict "
            "in it has settled or at <code>[impact] t_end</code> (the longest lasted %s ns).</li>\n",
            sep[0] == ',' ? ")" : "", given(100 * pbcp_threshold).s, given(vrest_threshold).s,
            given(r->t_impact * 1e9).s);
    if (t->compared > 0)
        fprintf(f,
                "<li><b>Spray vs MPM: %s on %zu of %zu particles</b> (the spray deposited and the MPM run did "
                "not bond: %zu; the spray rebounded and the MPM run bonded: %zu)%s.</li>\n",
                t->disagree ? "disagree" : "agree", t->disagree ? t->disagree : t->compared, t->compared,
                t->deposited_not_bonded, t->rebounded_bonded,
                t->unsettled ? "; unsettled MPM runs are not compared" : "");
}

/* The couple stage's seeds: how the gas at the target changed their speed. */
static void couple_headline(FILE *f, const struct case_file *c, const struct report_data *r)
{
    if (r->seed_count == 0)
        return;
    double change = 0, lo = INFINITY, hi = -INFINITY, v_lo = INFINITY, v_hi = -INFINITY;
    for (size_t i = 0; i < r->seed_count; i++) {
        double dv = r->seeds[i].v_wall - r->seeds[i].v_spray;
        change += dv, lo = fmin(lo, dv), hi = fmax(hi, dv);
        v_lo = fmin(v_lo, r->seeds[i].v_wall), v_hi = fmax(v_hi, r->seeds[i].v_wall);
    }
    fprintf(f, "<li><b>Couple stage: %zu particles</b> sampled from the spray's impacts (<code>[couple] sample = ",
            r->seed_count);
    escaped(f, case_text(c, "couple", "sample"));
    fprintf(f,
            "</code>) and flown from the hand-off plane through the spray's gas at the target (the jet's "
            "wall region) to their first contact, the wall or a deposit: speed there %s m/s, changed by %s m/s on "
            "average (%s m/s) from the spray's impact speed.</li>\n",
            span(num(v_lo, 3), num(v_hi, 3)).s, num(change / (double)r->seed_count, 3).s,
            span(num(lo, 3), num(hi, 3)).s);
}

/* The impact runs' resolution, against the one the bonding parameters were calibrated at. */
static void resolution_headline(FILE *f, const struct case_file *c, const struct report_data *r, const struct tally *t)
{
    if (!r->impact)
        return;
    double spacing = case_real(c, "impact", "spacing");
    double grid = case_real(c, "impact", "grid");
    double reference = case_has(c, "couple", "reference_diameter") ? case_real(c, "couple", "reference_diameter") : 0.0;
    fprintf(f,
            "<li><b>Resolution: grid cells of %s µm, material points %s µm apart</b> "
            "(<code>[impact] grid, spacing</code>)",
            given(grid * 1e6).s, given(spacing * 1e6).s);
    if (reference > 0) /* each run scaled to its particle (impact_stage.c scale_to_particle) */
        fprintf(f,
                " for a particle of %s µm, scaled with each particle's diameter "
                "(<code>[couple] reference_diameter</code>): %s grid cells and %s points across every particle",
                given(reference * 1e6).s, num(reference / grid, 3).s, num(reference / spacing, 3).s);
    else if (r->row_count > 0)
        fprintf(f, ": %s grid cells and %s points across a particle's diameter",
                span(num(t->d_min / grid, 2), num(t->d_max / grid, 2)).s,
                span(num(t->d_min / spacing, 2), num(t->d_max / spacing, 2)).s);
    if (r->points_max >= r->points_min)
        fprintf(f, "; %s material points per run", span(given(r->points_min), given(r->points_max)).s);
    calibration_sentence(f, c);
    if (r->uncalibrated > 0) /* mpm_bonding_calibrated_resolution */
        fprintf(f,
                "; <b>%lld of the %zu particles ran at another resolution: their verdicts below are not "
                "calibrated</b>",
                (long long)r->uncalibrated, r->row_count);
    fprintf(f, ".</li>\n");
}

/* A fixed nozzle's radial thickness profile, under the headline. */
static void profile_under_headline(FILE *f, const struct render_output *out)
{
    const struct render_figure *profile = render_output_find(out, "spray_thickness");
    if (!profile)
        return;
    fprintf(f, "<figure><img src=\"figures/%s.png\" alt=\"", profile->name);
    escaped(f, profile->title);
    fprintf(f,
            "\"><figcaption>Coating thickness vs radius from the spray axis: the volume of the deposited "
            "particles whose centres lie in each annulus, divided by the annulus area, i.e. the thickness "
            "of a fully dense layer (a coating of packing fraction &phi; is 1/&phi; thicker). "
            "(<a href=\"figures/%s.svg\">SVG</a>)</figcaption></figure>\n",
            profile->name);
}

static void headline(FILE *f, const struct render_request *req, const struct report_data *r,
                     const struct render_output *out)
{
    const struct case_file *c = req->c;
    struct tally t = tally(r, case_real(c, "impact", "vrest_threshold"));
    fprintf(f, "<section id=\"headline\">\n<h2>Result</h2>\n<ul>\n");
    spray_headline(f, c, r);
    impact_headline(f, c, r, &t);
    if (r->spray)
        coating_headline(f, r);
    couple_headline(f, c, r);
    resolution_headline(f, c, r, &t);
    vcrit_headline(f, req);
    sweep_headline(f, req);
    fprintf(f, "</ul>\n");
    profile_under_headline(f, out);
    fprintf(f, "</section>\n");
}

static void impact_table(FILE *f, const struct render_request *req, const struct report_data *r)
{
    if (!r->impact)
        return;
    double vrest_threshold = case_real(req->c, "impact", "vrest_threshold");
    double pbcp_threshold = case_real(req->c, "impact", "pbcp_threshold");
    double spacing = case_real(req->c, "impact", "spacing");
    fprintf(f,
            "<h2>Impact results</h2>\n<p>One row per particle body of every run (body: its index in impact.h5, "
            "the substrate being body 0). Verdict: bonded (PBCP &ge; %s %% and v_rest &le; %s m/s), rebounded "
            "(v_rest &gt; %s m/s), not bonded (v_rest &le; %s m/s but PBCP too low), unsettled (the verdict still "
            "changing at the "
            "run's end, or no v_rest: landing with no point slow enough to measure it; a particle leaving with none "
            "is judged on its centre of mass's speed; its row in grey italics: its PBCP, v_rest and CoR are the "
            "last values, not a result). <i>Spray said</i>: the outcome of the "
            "particle's first contact in the spray "
            "stage; highlighted rows: the spray and the MPM run disagree. PBCP (Tang Eq. 5.1) counts the "
            "particle's surface points whose D_bond ever reached 1; <i>bonded interface</i> is the share of the "
            "grid nodes where the particle meets the substrate at the run's end whose pair is bonded there (the "
            "mean of both bodies' D_bond at least 1, Eq. 4.7): a particle that has left keeps its PBCP but bonds "
            "at no node.</p>\n",
            given(100 * pbcp_threshold).s, given(vrest_threshold).s, given(vrest_threshold).s,
            given(vrest_threshold).s);
    fprintf(f, "<table id=\"impact-results\"><tr><th>run</th><th>body</th><th>diameter (µm)</th>"
               "<th>points across d</th><th>impact speed (m/s)</th><th>verdict</th><th>spray said</th>"
               "<th>PBCP (%%)</th><th>bonded interface (%%)</th><th>v_rest (m/s)</th><th>CoR v_rest/v_impact</th>"
               "</tr>\n");
    char low_pbcp[96];
    snprintf(low_pbcp, sizeof low_pbcp, "not bonded: at rest, PBCP < %s %%", given(100 * pbcp_threshold).s);
    const char *const words[] = {"bonded", "rebounded", low_pbcp, "unsettled"};
    for (size_t i = 0; i < r->row_count; i++) {
        const struct body_row *row = &r->rows[i];
        enum verdict v = verdict(row, vrest_threshold);
        const char *said = spray_said(r, row);
        int differs = row->seed >= 0 && v != UNSETTLED && strcmp(said, "-") != 0 &&
                      (strcmp(said, "deposited") == 0) != (v == BONDED);
        fprintf(f, "<tr class=\"body%s%s\">", differs ? " differs" : "", v == UNSETTLED ? " unsettled" : "");
        if (row->run < 0)
            cell(f, "td", "-");
        else
            fprintf(f, "<td>run_%04d</td>", row->run);
        fprintf(f, "<td>%zu</td>", row->body);
        number_cell_digits(f, row->d * 1e6, 3);
        number_cell_digits(f, row->d / (isnan(row->spacing) ? spacing : row->spacing), 2);
        number_cell_digits(f, row->v, 3);
        cell(f, "td", words[v]);
        cell(f, "td", said);
        number_cell_digits(f, 100 * row->pbcp, 3);
        number_cell_digits(f, 100 * row->bonded_interface, 3);
        number_cell_digits(f, row->v_rest, 3);
        number_cell_digits(f, row->cor, 2);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
}

static void couple_table(FILE *f, const struct report_data *r)
{
    if (r->seed_count == 0)
        return;
    fprintf(f, "<h2>Couple stage</h2>\n<p>Each MPM body's particle: its speed at the spray's impact and at the same "
               "contact after the couple stage's flight (the wall, or a deposit above it), and the spray's outcome of "
               "its first contact.</p>\n<table><tr><th>run</th>"
               "<th>body</th><th>spray particle id</th><th>diameter (µm)</th>"
               "<th>spray impact speed (m/s)</th><th>speed at the contact (m/s)</th><th>change (m/s)</th>"
               "<th>spray said</th></tr>\n");
    for (size_t i = 0; i < r->seed_count; i++) {
        const struct seed_row *s = &r->seeds[i];
        long body = -1; /* its index in impact.h5 */
        for (size_t k = 0; k < r->row_count; k++)
            if (r->rows[k].seed == (int)i)
                body = (long)r->rows[k].body;
        fprintf(f, "<tr><td>run_%04ld</td>", s->run);
        if (body >= 0)
            fprintf(f, "<td>%ld</td>", body);
        else
            cell(f, "td", "-");
        fprintf(f, "<td>%ld</td>", s->particle_id);
        number_cell_digits(f, s->d * 1e6, 3);
        number_cell_digits(f, s->v_spray, 3);
        number_cell_digits(f, s->v_wall, 3);
        number_cell_digits(f, s->v_wall - s->v_spray, 3);
        cell(f, "td", s->spray_outcome == 1 ? "deposited" : s->spray_outcome == 0 ? "rebounded" : "-");
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
}

static void spray_table(FILE *f, const struct report_data *r)
{
    if (!r->spray)
        return;
    fprintf(f, "<h2>Spray</h2>\n<table><tr><th>quantity</th><th>value</th><th>unit</th></tr>\n");
    char kind[160], thickness_label[320];
    snprintf(thickness_label, sizeof thickness_label,
             "coating %s, mean over the band the nozzle swept (middle half of the passes)",
             thickness_kind(r, kind, sizeof kind));
    const struct {
        const char *label;
        double value;
        const char *unit;
        int digits;
    } rows[] = {
        {"particles injected", (double)r->injected, "-", 0},
        {"particles deposited", (double)r->deposited, "-", 0},
        {"particles still in flight at the end", (double)r->in_flight, "-", 0},
        {"particles resting unbonded on the target at the end", (double)r->resting, "-", 0},
        {"particles escaped (left the domain)", (double)r->escaped, "-", 0},
        {"deposit fraction (deposited / injected)", 100 * r->deposit_fraction, "%", 3},
        {"deposition efficiency (deposited / sprayed mass)", 100 * r->de, "%", 3},
        {"volume fraction (deposited volume within [target] deposit_radius over a disc D_median thick)",
         100 * r->volume_fraction, "%", 3},
        {"mean distance of the deposited particles from the target centre", r->spread * 1e3, "mm", 3},
        {"scatter of that distance (standard deviation)", r->scatter * 1e3, "mm", 3},
        {"coating: the highest deposited particle's top above the target", r->deposit_top * 1e6, "µm", 3},
        {"coating: height span of the deposited particles' centres", r->max_thickness * 1e6, "µm", 3},
        {r->moves ? thickness_label : NULL, r->mean_thickness * 1e6, "µm", 3},
        {"simulated spray time", r->t_spray * 1e3, "ms", 3},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        if (!rows[i].label)
            continue; /* a row that does not apply to this run */
        fprintf(f, "<tr>");
        cell(f, "td", rows[i].label);
        if (rows[i].digits == 0) /* a count */
            fprintf(f, "<td>%.0f</td>", rows[i].value);
        else
            number_cell_digits(f, rows[i].value, rows[i].digits);
        cell(f, "td", rows[i].unit);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
}

/* The searches of vcrit.h5 (/search/NNN) whose result is not a plain "bracketed": what each says (a pair not
 * bracketed, runs unsettled, a fit set aside), with its diameter and temperature. */
static void vcrit_search_notes(FILE *f, hid_t file)
{
    int listed = 0;
    hid_t group;
    for (int i = 0; i < 1000 && h5_numbered_group(file, "search", (size_t)i, &group); i++) {
        char result[512];
        double d = NAN, T = NAN;
        if (group >= 0 && h5_attr_read_string(group, "result", result, sizeof result) == SC_OK &&
            strcmp(result, "bracketed") != 0 && h5_attr_read_double(group, "diameter", &d) == SC_OK) {
            if (!listed++)
                fprintf(f, "<p>Searches with a note (<code>vcrit.h5 /search/NNN</code> attribute result):</p>\n<ul>\n");
            fprintf(f, "<li>d = %s µm", num(d * 1e6, 3).s);
            if (H5Aexists(group, "temperature") > 0 && h5_attr_read_double(group, "temperature", &T) == SC_OK)
                fprintf(f, ", T = %s K", given(T).s);
            fprintf(f, ": ");
            escaped(f, result);
            fprintf(f, "</li>\n");
        }
        if (group >= 0)
            H5Gclose(group);
    }
    if (listed)
        fprintf(f, "</ul>\n");
    sc_error_clear();
}

/* What a bracketed search of method = logistic (/search/NNN) gives as v_crit: a fit's 50 % point (its standard error
 * finite), the middle of the gap between separable outcomes, or the bisection's (the note says why); -1 when it
 * has no v_crit. */
enum { VCRIT_FITTED, VCRIT_SEPARABLE, VCRIT_BISECTION, VCRIT_KINDS };
static int vcrit_search_kind(hid_t group)
{
    double v = NAN, se = NAN;
    char result[512] = "";
    if (h5_attr_read_double(group, "v_crit", &v) != SC_OK || !isfinite(v))
        return -1;
    if (H5Aexists(group, "v_crit_se") > 0 && h5_attr_read_double(group, "v_crit_se", &se) == SC_OK && isfinite(se))
        return VCRIT_FITTED;
    h5_attr_read_string(group, "result", result, sizeof result);
    return strstr(result, "outcomes separable") ? VCRIT_SEPARABLE : VCRIT_BISECTION;
}

/* The searches of one kind, "d = 8 µm, 10 µm" (with T where the search has one), or "every row" when all are. */
static void vcrit_rows_of_kind(FILE *f, hid_t file, int kind, const int counts[VCRIT_KINDS])
{
    if (counts[kind] == counts[VCRIT_FITTED] + counts[VCRIT_SEPARABLE] + counts[VCRIT_BISECTION]) {
        fprintf(f, "every row");
        return;
    }
    int listed = 0;
    hid_t group;
    for (int i = 0; i < 1000 && h5_numbered_group(file, "search", (size_t)i, &group); i++) {
        double d = NAN, T = NAN;
        if (group >= 0 && vcrit_search_kind(group) == kind && h5_attr_read_double(group, "diameter", &d) == SC_OK) {
            fprintf(f, "%s%s µm", listed++ ? ", " : "d = ", num(d * 1e6, 3).s);
            if (H5Aexists(group, "temperature") > 0 && h5_attr_read_double(group, "temperature", &T) == SC_OK)
                fprintf(f, " at %s K", given(T).s);
        }
        if (group >= 0)
            H5Gclose(group);
    }
}

/* method = logistic: what v_crit is, row by row (the searches of vcrit.h5): a fit's 50 % point, with its standard
 * error in vcrit.csv, or the middle of the gap where the outcomes are separable (no fit, no standard error; it
 * called every row a fit), or the bisection's where the fit was set aside. */
static void vcrit_logistic_resolution(FILE *f, const struct case_file *c, hid_t file)
{
    int counts[VCRIT_KINDS] = {0};
    hid_t group;
    for (int i = 0; i < 1000 && h5_numbered_group(file, "search", (size_t)i, &group); i++) {
        int kind = group >= 0 ? vcrit_search_kind(group) : -1;
        if (kind >= 0)
            counts[kind]++;
        if (group >= 0)
            H5Gclose(group);
    }
    sc_error_clear();
    fprintf(f, "<p>v_crit (<code>[vcrit] method = logistic</code>): ");
    int parts = 0;
    for (int kind = 0; kind < VCRIT_KINDS; kind++) {
        if (!counts[kind])
            continue;
        fprintf(f, "%s", parts++ ? "; " : "");
        if (kind == VCRIT_FITTED)
            fprintf(f, "the speed of a logistic fit's 50 %% bonding probability, its standard error in vcrit.csv "
                       "(v_crit_se)");
        else if (kind == VCRIT_SEPARABLE)
            fprintf(f,
                    "the middle of the gap between the fastest run that failed and the slowest that succeeded, where "
                    "the outcomes are separable (no fit, no standard error: the gap in the notes below)");
        else
            fprintf(f,
                    "the bisection's, the upper end of a bracket at most %s m/s wide (<code>[vcrit] tolerance</code>), "
                    "the fit set aside as the notes below say",
                    given(case_real(c, "vcrit", "tolerance")).s);
        fprintf(f, ", for ");
        vcrit_rows_of_kind(f, file, kind, counts);
    }
    if (!parts)
        fprintf(f, "no row");
    fprintf(f, ".</p>\n");
    sc_error_clear();
}

static void vcrit_results(FILE *f, const struct case_file *c, hid_t file)
{
    static const char *const names[] = {"diameter", "v_crit", "pbcp", "v_rest", "temperature"};
    struct render_array a[5];
    memset(a, 0, sizeof a);
    int ok = 1, hot = h5_exists(file, "temperature"); /* a search over (d, T): a column of its temperatures */
    for (int k = 0; k < 4 + hot; k++)
        ok = render_read_array(file, "vcrit.h5", names[k], &a[k]) == SC_OK && ok && a[k].count == a[0].count;
    sc_error_clear();
    fprintf(f,
            "<h2>Critical velocity</h2>\n<table><tr><th>diameter (µm)</th>%s<th>v_crit (m/s)</th>"
            "<th>PBCP (%%)</th><th>v_rest (m/s)</th></tr>\n",
            hot ? "<th>temperature (K)</th>" : "");
    for (size_t i = 0; ok && i < a[0].count; i++) {
        fprintf(f, "<tr>");
        number_cell_digits(f, a[0].values[i] * 1e6, 3);
        if (hot)
            number_cell_digits(f, a[4].values[i], 4);
        number_cell_digits(f, a[1].values[i], 4);
        number_cell_digits(f, 100 * a[2].values[i], 3);
        number_cell_digits(f, a[3].values[i], 3);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
    /* the digits beyond the search's resolution are not v_crit's (app/vcrit_stage.c) */
    if (case_is(c, "vcrit", "method", "logistic"))
        vcrit_logistic_resolution(f, c, file);
    else
        fprintf(f,
                "<p>v_crit: the upper end of a bracket at most %s m/s wide (<code>[vcrit] tolerance</code>, "
                "bisection): the digits below that are not significant.</p>\n",
                given(case_real(c, "vcrit", "tolerance")).s);
    vcrit_search_notes(f, file);
    for (int k = 0; k < 5; k++)
        render_array_free(&a[k]);
}

/* sweep.h5 (app/sweep_stage.c): the map's cells, DE and mean impact speed of each run, each cell by the values as the
 * case gave them (x_labels, y_labels: a file key's names, a number's text). */
static void sweep_results(FILE *f, hid_t file)
{
    char keys[2][160] = {"", ""}, labels[2][4096] = {"", ""}, label[256];
    h5_attr_read_string(file, "x_key", keys[0], sizeof keys[0]);
    h5_attr_read_string(file, "y_key", keys[1], sizeof keys[1]);
    h5_attr_read_string(file, "x_labels", labels[0], sizeof labels[0]);
    h5_attr_read_string(file, "y_labels", labels[1], sizeof labels[1]);
    size_t nx = 0, ny = 0;
    h5_dataset_size(file, "x_values", &nx);
    if (h5_exists(file, "y_values"))
        h5_dataset_size(file, "y_values", &ny);
    struct render_array de = {0}, speed = {0}, share = {0};
    int ok = render_read_array(file, "sweep.h5", "de", &de) == SC_OK &&
             render_read_array(file, "sweep.h5", "mean_impact_speed", &speed) == SC_OK;
    int two = keys[1][0] != '\0';
    size_t cells = nx * (two && ny ? ny : 1), marked = 0;
    unsigned char *lower_bound = NULL;
    ok = ok && render_sweep_lower_bounds(file, "sweep.h5", de.count, &lower_bound, &marked) == SC_OK;
    int has_share = ok && h5_exists(file, "in_flight_share") &&
                    render_read_array(file, "sweep.h5", "in_flight_share", &share) == SC_OK && share.count == cells;
    sc_error_clear();
    fprintf(f, "<h2>Sweep</h2>\n<table><tr><th>run</th><th>");
    escaped(f, keys[0]);
    fprintf(f, "</th>");
    if (two) {
        fprintf(f, "<th>");
        escaped(f, keys[1]);
        fprintf(f, "</th>");
    }
    fprintf(f, "<th>deposition efficiency (%%)</th><th>mean impact speed (m/s)</th>%s</tr>\n",
            has_share ? "<th>still in flight at the end (% of the sprayed)</th>" : "");
    for (size_t k = 0; ok && nx > 0 && de.count == cells && speed.count == cells && k < cells; k++) {
        fprintf(f, "<tr><td>runs/x%zu_y%zu</td>", k % nx, k / nx);
        render_nth_label(labels[0], k % nx, label, sizeof label);
        cell(f, "td", label);
        if (two) {
            render_nth_label(labels[1], k / nx, label, sizeof label);
            cell(f, "td", label);
        }
        char value[64];
        snprintf(value, sizeof value, "%s%s", lower_bound[k] ? "\u2265 " : "", num(100 * de.values[k], 3).s);
        cell(f, "td", value);
        number_cell_digits(f, speed.values[k], 4);
        if (has_share)
            number_cell_digits(f, 100 * share.values[k], 3);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
    double bound = NAN;
    if (marked > 0 && h5_attr_read_double(file, "de_lower_bound_share", &bound) == SC_OK)
        fprintf(f,
                "<p>&ge;: a lower bound. In %zu of the runs more than %s %% of the particles sprayed were still in "
                "flight at the end; the deposition efficiency counts them as not deposited. A longer [spray] t_end "
                "lets them land.</p>\n",
                marked, num(100 * bound, 2).s);
    sc_error_clear();
    free(lower_bound);
    render_array_free(&de), render_array_free(&speed), render_array_free(&share);
}

static void results(FILE *f, const struct render_request *req, const struct report_data *r)
{
    impact_table(f, req, r);
    couple_table(f, r);
    spray_table(f, r);
    hid_t file;
    if (open_output(req, "vcrit.h5", &file))
        vcrit_results(f, req->c, file), H5Fclose(file);
    if (open_output(req, "sweep.h5", &file))
        sweep_results(f, file), H5Fclose(file);
}

static void figures(FILE *f, const struct render_output *out)
{
    static const char *const groups[] = {"spray", "impact", "vcrit", "calibrate", "sweep"};
    static const char *const headings[] = {"Spray", "Impact", "Critical velocity", "Bonding calibration", "Sweep"};
    fprintf(f, "<h2>Figures</h2>\n");
    for (size_t g = 0; g < sizeof groups / sizeof groups[0]; g++) {
        int shown = 0;
        for (int i = 0; i < out->count; i++) {
            const struct render_figure *fig = &out->figures[i];
            if (strcmp(fig->group, groups[g]) != 0 || strcmp(fig->name, "spray_thickness") == 0)
                continue; /* the thickness profile is in the headline */
            if (!shown++)
                fprintf(f, "<h3>%s</h3>\n", headings[g]);
            fprintf(f, "<figure><img src=\"figures/%s.png\" alt=\"", fig->name);
            escaped(f, fig->title);
            fprintf(f, "\"><figcaption>");
            escaped(f, fig->title);
            if (fig->is_plot)
                fprintf(f, " (<a href=\"figures/%s.svg\">SVG</a>)", fig->name);
            fprintf(f, "</figcaption></figure>\n");
        }
    }
    if (out->frames > 0) /* spraycoat does not call ffmpeg: the frames are the film */
        fprintf(f,
                "<p>%d film frames (every <code>[render] every</code>-th snapshot and the last) are in "
                "<code>figures/film_plume/</code> (the spray) and <code>figures/film_impact*/</code> (each impact "
                "run); <code>ffmpeg -framerate 10 -pattern_type glob -i 'figures/film_plume/*.png' -pix_fmt "
                "yuv420p plume.mp4</code> makes a video of one.</p>\n",
                out->frames);
}

/* What the run's result must be read with, below the headline: the run's state (the caller's notices) and the
 * stages' own warnings that their outputs record (the spray's lower-bound DE and its table's clamped impacts). */
static void warning_item(FILE *f, int *open, const char *text)
{
    if (!*open)
        fprintf(f, "<section id=\"warnings\">\n<h2>Warnings</h2>\n<ul>\n"), *open = 1;
    fprintf(f, "<li>");
    escaped(f, text);
    fprintf(f, "</li>\n");
}

static void warnings(FILE *f, const struct render_request *req, const struct report_data *r)
{
    int open = 0;
    char text[600];
    for (int k = 0; k < req->notice_count; k++)
        warning_item(f, &open, req->notices[k]);
    /* the spray stage's own test (app/spray_stage.c): over 5 % of the sprayed particles in flight at t_end */
    if (r->spray && r->injected > 0 && (double)r->in_flight > 0.05 * (double)r->injected) {
        snprintf(text, sizeof text,
                 "%lld of the %lld particles sprayed (%.1f %%) were still in flight at t_end: the deposition "
                 "efficiency counts them as not deposited, so it is a lower bound; a longer [spray] t_end lets them "
                 "land.",
                 (long long)r->in_flight, (long long)r->injected, 100.0 * (double)r->in_flight / (double)r->injected);
        warning_item(f, &open, text);
    }
    if (r->table_impacts_outside > 0 && r->table_impacts > 0) {
        snprintf(text, sizeof text,
                 "%lld of the %lld impacts judged by the v_crit table (%.1f %%) had a diameter or temperature beyond "
                 "its grid and took the v_crit of its nearest edge: widen the search that made the table ([vcrit] "
                 "diameters, temperatures) to cover the powder.",
                 (long long)r->table_impacts_outside, (long long)r->table_impacts,
                 100.0 * (double)r->table_impacts_outside / (double)r->table_impacts);
        warning_item(f, &open, text);
    }
    if (open)
        fprintf(f, "</ul>\n</section>\n");
}

int render_write_report(const struct render_request *req, const struct render_output *out)
{
    char path[ATOMIC_PATH_MAX];
    snprintf(path, sizeof path, "%s/report.html", req->run_dir);
    struct atomic_file out_file;
    SC_TRY(atomic_open(path, &out_file));
    FILE *f = out_file.stream;
    fprintf(f, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>spraycoat report: ");
    escaped(f, req->run_dir);
    fprintf(f, "</title><style>%s</style></head><body>\n<h1>spraycoat report: ", style);
    escaped(f, req->run_dir);
    fprintf(f, "</h1>\n");
    struct report_data data;
    report_read(req, &data);
    headline(f, req, &data, out);
    warnings(f, req, &data);
    results(f, req, &data);
    report_free(&data);
    figures(f, out);
    fprintf(f, "<details><summary>Provenance and the case</summary>\n");
    provenance(f, req);
    case_summary(f, req);
    fprintf(f, "</details>\n");
    fprintf(f, "</body></html>\n");
    return atomic_publish(&out_file);
}
