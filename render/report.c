/* RUN_DIR/report.html: one page with provenance, the case summary, the main results and every figure (images
 * beside it in figures/, so the page is small and the PNGs stay usable on their own). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/version.h"
#include "render/render_impl.h"

static void escaped(FILE *f, const char *text)
{
    for (const char *p = text ? text : ""; *p; p++) {
        switch (*p) {
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '&': fputs("&amp;", f); break;
        case '"': fputs("&quot;", f); break;
        default: fputc(*p, f);
        }
    }
}

static void cell(FILE *f, const char *tag, const char *text)
{
    fprintf(f, "<%s>", tag);
    escaped(f, text);
    fprintf(f, "</%s>", tag);
}

static void number_cell(FILE *f, double value)
{
    char text[48];
    snprintf(text, sizeof text, "%.6g", value);
    cell(f, "td", text);
}

static const char style[] =
    "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left}"
    "th{background:#f2f2f2}figure{display:inline-block;width:47%;margin:0.5em;vertical-align:top}"
    "figure img{width:100%;border:1px solid #ddd}figcaption{font-size:90%}";

/* One row per output file: its root attributes. */
static void provenance(FILE *f, const struct render_request *req)
{
    static const char *const files[] = {"spray.h5", "impact.h5", "vcrit.h5"};
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
    for (int i = 0; i < 3; i++) {
        char path[4200], value[256];
        snprintf(path, sizeof path, "%s/%s", req->run_dir, files[i]);
        hid_t file;
        if (access(path, R_OK) != 0 || h5_open_read(path, &file) != SC_OK) {
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

/* Spray: the counts of /stats and the last row of /metrics. */
static void spray_results(FILE *f, hid_t file)
{
    static const char *const counts[] = {"injected", "deposited", "escaped", "in_flight"};
    static const char *const metrics[] = {"deposit_fraction", "volume_fraction", "mean_spread", "scatter",
                                          "max_thickness"};
    static const char *const units[] = {"-", "-", "m", "m", "m"};
    fprintf(f, "<h3>Spray</h3>\n<table><tr><th>quantity</th><th>value</th><th>unit</th></tr>\n");
    hid_t stats = h5_exists(file, "stats") ? H5Gopen2(file, "stats", H5P_DEFAULT) : H5I_INVALID_HID;
    for (int i = 0; stats >= 0 && i < 4; i++) {
        int64_t value;
        if (h5_attr_read_int64(stats, counts[i], &value) == SC_OK)
            fprintf(f, "<tr><td>particles %s</td><td>%lld</td><td>-</td></tr>\n", counts[i], (long long)value);
    }
    if (stats >= 0)
        H5Gclose(stats);
    for (int i = 0; i < 5; i++) {
        char name[64];
        snprintf(name, sizeof name, "metrics/%s", metrics[i]);
        struct render_array a;
        if (render_read_array(file, "spray.h5", name, &a) != SC_OK || a.count == 0) {
            render_array_free(&a);
            continue;
        }
        fprintf(f, "<tr><td>%s (at the end)</td>", metrics[i]);
        number_cell(f, a.values[a.count - 1]);
        cell(f, "td", units[i]);
        fprintf(f, "</tr>\n");
        render_array_free(&a);
    }
    sc_error_clear();
    fprintf(f, "</table>\n");
}

/* Impact: /summary per body of one run group. */
static void impact_summary(FILE *f, hid_t group, const char *title)
{
    static const char *const names[] = {"diameter", "v_impact", "bonded", "pbcp", "v_rest", "cor"};
    struct render_array a[6];
    int ok = 1;
    for (int k = 0; k < 6; k++) {
        char name[48];
        snprintf(name, sizeof name, "summary/%s", names[k]);
        ok = render_read_array(group, "impact.h5", name, &a[k]) == SC_OK && ok && a[k].count == a[0].count;
    }
    sc_error_clear();
    fprintf(f, "<h3>Impact%s</h3>\n<table><tr><th>body</th><th>diameter (µm)</th><th>impact speed (m/s)</th>"
               "<th>verdict</th><th>PBCP (%%)</th><th>v_rest (m/s)</th><th>restitution ratio</th></tr>\n", title);
    for (size_t b = 0; ok && b < a[0].count; b++) {
        if (a[2].values[b] < 0)
            continue; /* the substrate */
        fprintf(f, "<tr><td>%zu</td>", b);
        number_cell(f, a[0].values[b] * 1e6);
        number_cell(f, a[1].values[b]);
        cell(f, "td", a[2].values[b] == 1 ? "bonded" : "rebounded");
        number_cell(f, 100 * a[3].values[b]);
        number_cell(f, a[4].values[b]);
        number_cell(f, a[5].values[b]);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
    for (int k = 0; k < 6; k++)
        render_array_free(&a[k]);
}

static herr_t impact_run_group(hid_t parent, const char *name, const H5L_info_t *info, void *data)
{
    (void)info;
    if (strncmp(name, "run_", 4) != 0)
        return 0;
    hid_t g = H5Gopen2(parent, name, H5P_DEFAULT);
    if (g < 0)
        return 0;
    char title[48];
    snprintf(title, sizeof title, " (%s)", name);
    impact_summary(data, g, title);
    H5Gclose(g);
    return 0;
}

static void vcrit_results(FILE *f, hid_t file)
{
    static const char *const names[] = {"diameter", "v_crit", "pbcp", "v_rest"};
    struct render_array a[4];
    int ok = 1;
    for (int k = 0; k < 4; k++)
        ok = render_read_array(file, "vcrit.h5", names[k], &a[k]) == SC_OK && ok && a[k].count == a[0].count;
    sc_error_clear();
    fprintf(f, "<h3>Critical velocity</h3>\n<table><tr><th>diameter (µm)</th><th>v_crit (m/s)</th>"
               "<th>PBCP (%%)</th><th>v_rest (m/s)</th></tr>\n");
    for (size_t i = 0; ok && i < a[0].count; i++) {
        fprintf(f, "<tr>");
        number_cell(f, a[0].values[i] * 1e6);
        number_cell(f, a[1].values[i]);
        number_cell(f, 100 * a[2].values[i]);
        number_cell(f, a[3].values[i]);
        fprintf(f, "</tr>\n");
    }
    fprintf(f, "</table>\n");
    for (int k = 0; k < 4; k++)
        render_array_free(&a[k]);
}

static void results(FILE *f, const struct render_request *req)
{
    fprintf(f, "<h2>Results</h2>\n");
    static const char *const files[] = {"spray.h5", "impact.h5", "vcrit.h5"};
    for (int i = 0; i < 3; i++) {
        char path[4200];
        snprintf(path, sizeof path, "%s/%s", req->run_dir, files[i]);
        hid_t file;
        if (access(path, R_OK) != 0 || h5_open_read(path, &file) != SC_OK) {
            sc_error_clear();
            continue;
        }
        if (i == 0)
            spray_results(f, file);
        else if (i == 1 && h5_exists(file, "summary"))
            impact_summary(f, file, "");
        else if (i == 1)
            H5Literate(file, H5_INDEX_NAME, H5_ITER_INC, NULL, impact_run_group, f);
        else
            vcrit_results(f, file);
        H5Fclose(file);
    }
}

static void figures(FILE *f, const struct render_output *out)
{
    static const char *const groups[] = {"spray", "impact", "vcrit"};
    static const char *const headings[] = {"Spray", "Impact", "Critical velocity"};
    fprintf(f, "<h2>Figures</h2>\n");
    for (int g = 0; g < 3; g++) {
        int shown = 0;
        for (int i = 0; i < out->count; i++) {
            const struct render_figure *fig = &out->figures[i];
            if (strcmp(fig->group, groups[g]) != 0)
                continue;
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
    if (out->frames > 0)
        fprintf(f, "<p>%d frames of the impact snapshots are in <code>figures/frames/</code>; "
                   "<code>ffmpeg -framerate 10 -pattern_type glob -i 'figures/frames/*.png' -pix_fmt yuv420p "
                   "impact.mp4</code> makes a film of them.</p>\n", out->frames);
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
    fprintf(f, "</h1>\n<p>All quantities SI unless the unit says otherwise.</p>\n");
    provenance(f, req);
    case_summary(f, req);
    results(f, req);
    figures(f, out);
    fprintf(f, "</body></html>\n");
    return atomic_publish(&out_file);
}
