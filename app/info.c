#include "app/app.h"

#include <dirent.h>
#include <glob.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/logistic.h"
#include "core/version.h"
#include "mpm/mpm.h"

static const char *const root_attributes[] = {"format", "format_version", "program_version", "sources_id",
                                              "stage",  "case_hash",      "created",         NULL};
static const char *const spray_stats[] = {"steps",
                                          "t",
                                          "injected",
                                          "in_flight",
                                          "deposited",
                                          "escaped",
                                          "resting",
                                          "first_impact_deposits",
                                          "contacts_pair",
                                          "contacts_target",
                                          "contacts_deposit",
                                          "contacts_turned_away",
                                          "fixed_point_iterations",
                                          "fixed_point_solves",
                                          "fixed_point_unconverged",
                                          "subcycled_particle_steps",
                                          "particle_steps",
                                          "clamps",
                                          "trapped",
                                          NULL};
static const char *const metric_names[] = {"deposit_fraction", "volume_fraction", "mean_spread", "scatter",
                                           "max_thickness",    "deposition_rate", NULL};

static void print_attribute(hid_t loc, const char *name, FILE *out)
{
    char text[256];
    int64_t whole;
    double real;
    if (h5_attr_read_string(loc, name, text, sizeof text) == SC_OK)
        fprintf(out, "  %-28s %s\n", name, text);
    else if (h5_attr_read_int64(loc, name, &whole) == SC_OK)
        fprintf(out, "  %-28s %lld\n", name, (long long)whole);
    else if (h5_attr_read_double(loc, name, &real) == SC_OK)
        fprintf(out, "  %-28s %.9g\n", name, real);
}

static void print_last_metrics(hid_t file, FILE *out)
{
    size_t n;
    if (h5_dataset_size(file, "metrics/t", &n) != SC_OK || n == 0)
        return;
    double *column = malloc(n * sizeof *column);
    if (!column)
        SC_DIE_OOM(n * sizeof *column, "the metrics of spray.h5");
    fprintf(out, "final metrics:\n");
    for (int k = 0; metric_names[k]; k++) {
        char path[128];
        snprintf(path, sizeof path, "metrics/%s", metric_names[k]);
        if (h5_read_doubles(file, path, column, n) == SC_OK)
            fprintf(out, "  %-28s %.6g\n", metric_names[k], column[n - 1]);
    }
    free(column);
}

static const char *const impact_stats[] = {"steps",
                                           "t_end",
                                           "points",
                                           "mirror_copies",
                                           "point_updates",
                                           "removed_points",
                                           "removed_mass",
                                           "contact_node_steps",
                                           "bonded_node_steps",
                                           "energy_initial",
                                           "grid_nodes",
                                           NULL};
static const char *const impact_checkpoint[] = {"step", "t", "t_end", "snapshots", "active_points", NULL};

/* A double or int64 dataset of n elements as doubles (NULL when absent or of another size). */
static double *read_column(hid_t loc, const char *name, size_t n)
{
    size_t count;
    if (h5_dataset_size(loc, name, &count) != SC_OK || count != n)
        return NULL;
    double *values = malloc((n + 1) * sizeof *values);
    if (!values)
        SC_DIE_OOM((n + 1) * sizeof *values, name);
    if (h5_read_doubles(loc, name, values, n) != SC_OK) {
        /* integer datasets: read as int64 and convert */
        int64_t *integers = malloc((n + 1) * sizeof *integers);
        if (!integers)
            SC_DIE_OOM((n + 1) * sizeof *integers, name);
        int ok = h5_read_int64s(loc, name, integers, n) == SC_OK;
        for (size_t i = 0; ok && i < n; i++)
            values[i] = (double)integers[i];
        free(integers);
        if (!ok) {
            free(values);
            values = NULL;
        }
    }
    return values;
}

/* spray.h5 /deposition_efficiency/GROUP: one line per class, or on one line (`brief`) the DE of each. */
static void print_de_classes(hid_t file, const char *group, const char *bound, double scale, int brief, FILE *out)
{
    char path[128];
    size_t n;
    snprintf(path, sizeof path, "deposition_efficiency/%s/de", group);
    if (h5_dataset_size(file, path, &n) != SC_OK || n == 0)
        return;
    const char *names[] = {"lo", "hi", "sprayed_mass", "deposited_mass", "de", "sprayed_count"};
    double *column[6];
    for (int k = 0; k < 6; k++) {
        snprintf(path, sizeof path, "deposition_efficiency/%s/%s", group, names[k]);
        column[k] = read_column(file, path, n);
    }
    if (column[0] && column[1] && column[2] && column[3] && column[4] && column[5]) {
        fprintf(out, brief ? "        DE by %s:" : "  by %s:\n", bound);
        for (size_t i = 0; i < n; i++) {
            if (brief && column[5][i] > 0)
                fprintf(out, " %.3g-%.3g %.3f;", scale * column[0][i], scale * column[1][i], column[4][i]);
            else if (!brief)
                fprintf(out, "    %9.4g - %-9.4g sprayed %-10.4g kg (%4.0f)  deposited %-10.4g kg  DE %.4f\n",
                        scale * column[0][i], scale * column[1][i], column[2][i], column[5][i], column[3][i],
                        column[4][i]);
        }
        if (brief)
            fputc('\n', out);
    }
    for (int k = 0; k < 6; k++)
        free(column[k]);
}

static double de_value(hid_t file, const char *name)
{
    char path[128];
    double value = NAN;
    snprintf(path, sizeof path, "deposition_efficiency/%s", name);
    h5_read_doubles(file, path, &value, 1);
    return value;
}

/* spray.h5 /deposition_efficiency: the headline DE by mass and its classes. */
static void print_deposition_efficiency(hid_t file, int brief, FILE *out)
{
    if (!h5_exists(file, "deposition_efficiency"))
        return;
    fprintf(out,
            brief ? "        deposition efficiency (mass) %.4f: %.4g of %.4g kg sprayed; first impacts at %.4g m/s "
                    "(normal %.4g m/s) on average\n"
                  : "deposition efficiency (mass): %.6f (%.6g of %.6g kg sprayed); first impacts at %.6g m/s "
                    "(normal %.6g m/s) on average\n",
            de_value(file, "de"), de_value(file, "deposited_mass"), de_value(file, "sprayed_mass"),
            de_value(file, "mean_impact_speed"), de_value(file, "mean_impact_normal_speed"));
    print_de_classes(file, "by_size", "size (um)", 1e6, brief, out);
    print_de_classes(file, "by_angle", "first-impact angle (degree)", 1.0, brief, out);
    if (!brief)
        fprintf(out, "  sprayed without an impact: %.6g kg\n", de_value(file, "unimpacted_mass"));
}

/* The verdict thresholds stored with /summary (mpm/output.c); left as they are where the file has none. */
static void summary_thresholds(hid_t file, double *pbcp_threshold, double *vrest_threshold)
{
    hid_t summary = H5Gopen2(file, "summary", H5P_DEFAULT);
    if (summary < 0)
        return;
    if (h5_attr_read_double(summary, "pbcp_threshold", pbcp_threshold) != SC_OK ||
        h5_attr_read_double(summary, "vrest_threshold", vrest_threshold) != SC_OK)
        *pbcp_threshold = *vrest_threshold = NAN;
    H5Gclose(summary);
}

/* impact.h5: counts, snapshots and the per-body summary. */
static void print_impact_results(hid_t file, FILE *out)
{
    if (h5_exists(file, "stats")) {
        hid_t stats = H5Gopen2(file, "stats", H5P_DEFAULT);
        fprintf(out, "counts:\n");
        for (int k = 0; impact_stats[k]; k++)
            print_attribute(stats, impact_stats[k], out);
        H5Gclose(stats);
    }
    if (h5_exists(file, "snapshots")) {
        hid_t group = H5Gopen2(file, "snapshots", H5P_DEFAULT);
        H5G_info_t group_info;
        if (group >= 0 && H5Gget_info(group, &group_info) >= 0)
            fprintf(out, "snapshots: %llu (/snapshots/000000 ...)\n", (unsigned long long)group_info.nlinks);
        if (group >= 0)
            H5Gclose(group);
    }
    size_t n;
    if (h5_dataset_size(file, "summary/bonded", &n) != SC_OK || n == 0)
        return;
    /* summary/bonded_interface: files of format version 2 on (n/a before) */
    static const char *const names[] = {"summary/diameter",  "summary/v_impact",        "summary/verdict",
                                        "summary/pbcp",      "summary/v_rest",          "summary/cor",
                                        "summary/substrate", "summary/bonded_interface"};
    double *column[8];
    for (int k = 0; k < 8; k++)
        column[k] = read_column(file, names[k], n);
    double pbcp_threshold = NAN, vrest_threshold = NAN; /* absent in files written before they were stored */
    summary_thresholds(file, &pbcp_threshold, &vrest_threshold);
    fprintf(out, "summary (per body):\n  %-5s %-10s %-12s %-12s %-10s %-9s %-18s %-12s %-8s\n", "body", "kind", "d (m)",
            "v_impact", "verdict", "PBCP %", "bonded interface %", "v_rest (m/s)", "CoR");
    int held = 0, unsettled = 0;
    for (size_t b = 0; b < n; b++) {
        double value[8];
        for (int k = 0; k < 8; k++)
            value[k] = column[k] ? column[k][b] : NAN;
        int substrate = value[6] == 1.0;
        const char *verdict = substrate || isnan(value[2]) ? "-" : mpm_verdict_name((int)value[2]);
        if (!substrate && mpm_verdict_held((int)value[2], value[4], vrest_threshold))
            verdict = "held", held = 1;
        unsettled |= !substrate && !isnan(value[2]) && (int)value[2] == MPM_VERDICT_UNSETTLED;
        fprintf(out, "  %-5zu %-10s %-12.4g %-12.4g %-10s %-9.3g %-18.3g %-12.4g %-8.3g\n", b,
                substrate ? "substrate" : "particle", value[0], value[1], verdict, 100.0 * value[3], 100.0 * value[7],
                value[4], value[5]);
    }
    if (held)
        fprintf(out,
                "  held: not bonded, at rest (v_rest <= %g m/s) but PBCP under %g %% (docs/physics.md, \"Held but "
                "not bonded\")\n",
                vrest_threshold, 100.0 * pbcp_threshold);
    if (unsettled)
        fprintf(out, "  unsettled: no verdict by the end of the run; its PBCP, v_rest and CoR are the last values, not "
                     "a result (docs/physics.md, \"Settled verdicts\")\n");
    for (int k = 0; k < 8; k++)
        free(column[k]);
}

/* calibrate.h5 /size/NNN (method = boundaries): each size's diameter, speed, counts and result ("fitted", "outcomes
 * separable: ..." or why there is no fit), which the calibrated pair alone does not show (a review). */
static void print_calibrate_sizes(hid_t file, FILE *out)
{
    static const char *const names[] = {"diameter", "velocity", "bonded", "rebounded", "unsettled", "failed", "result"};
    hid_t size;
    for (size_t i = 0; h5_numbered_group(file, "size", i, &size); i++) {
        if (size < 0)
            break;
        fprintf(out, "size/%03zu:\n", i);
        for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
            print_attribute(size, names[k], out);
        H5Gclose(size);
    }
    sc_error_clear();
}

/* calibrate.h5: the calibrated pair (NaN where the boundaries do not intersect in the grid) and the grid. */
static void print_calibrate_results(hid_t file, FILE *out)
{
    fprintf(out, "calibration:\n");
    /* the bonding model's two parameters: energy's unless the file names another (files before strain calibrations
     * have no "bonding") */
    static const char *const energy[] = {"Gc", "Gc_rate", "Gc_min", "Gc_max", "Gc_rate_min", "Gc_rate_max"};
    static const char *const strain[] = {"eps_c",     "eps_rate_c",     "eps_c_min",
                                         "eps_c_max", "eps_rate_c_min", "eps_rate_c_max"};
    char model[32] = "energy";
    print_attribute(file, "bonding", out);
    h5_attr_read_string(file, "bonding", model, sizeof model);
    const char *const *names = strcmp(model, "strain") == 0 ? strain : energy;
    for (int k = 0; k < 6; k++)
        print_attribute(file, names[k], out);
    print_attribute(file, "reference_diameter", out);
    print_attribute(file, "outcome", out); /* what the fit counted: bonded, or adhered (bonded or held) */
    print_attribute(file, "method", out);  /* vcrit: the first parameter fitted to measured v_crit */
    print_attribute(file, "fit_tolerance", out);
    print_attribute(file, "rate", out); /* method = vcrit: the second parameter kept or fitted too */
    print_attribute(file, "fit_spread_tolerance", out);
    print_attribute(file, "result", out);
    print_calibrate_sizes(file, out);
}

/* vcrit.h5 of a search over temperature ([vcrit] temperatures): the temperature of each of the n rows above. */
static void print_vcrit_temperatures(hid_t file, size_t n, FILE *out)
{
    if (!h5_exists(file, "temperature"))
        return;
    double *T = read_column(file, "temperature", n);
    fprintf(out, "  temperatures (K) of the rows above:");
    for (size_t i = 0; T && i < n; i++)
        fprintf(out, " %.6g", T[i]);
    fputc('\n', out);
    free(T);
}

/* vcrit.h5: the table and the diameters without a bracket. */
static void print_vcrit_results(hid_t file, FILE *out)
{
    size_t n = 0;
    if (h5_dataset_size(file, "diameter", &n) == SC_OK) {
        static const char *const names[] = {"diameter", "v_crit", "pbcp", "v_rest", "runs"};
        double *column[5];
        for (int k = 0; k < 5; k++)
            column[k] = read_column(file, names[k], n);
        char outcome[16] = "bonded";   /* what v_crit is the threshold of ([vcrit] outcome; older files: bonded) */
        char method[16] = "bisection"; /* how ([vcrit] method; older files: bisection) */
        hid_t first = h5_exists(file, "search/000") ? H5Gopen2(file, "search/000", H5P_DEFAULT) : H5I_INVALID_HID;
        if (first >= 0) {
            h5_attr_read_string(first, "outcome", outcome, sizeof outcome);
            h5_attr_read_string(first, "method", method, sizeof method);
            H5Gclose(first);
        }
        const char *what = strcmp(outcome, "adhered") == 0 ? "adheres (bonded or held)" : "bonds";
        char how[96];
        if (strcmp(method, "logistic") == 0)
            snprintf(how, sizeof how, "speed at which a particle %s with probability 0.5 (logistic fit)", what);
        else
            snprintf(how, sizeof how, "lowest speed at which a particle %s", what);
        fprintf(out, "critical velocity, %s (%zu diameters bracketed):\n  %-12s %-10s %-9s %-12s %-5s\n", how, n,
                "d (m)", "v_crit", "PBCP %", "v_rest (m/s)", "runs");
        for (size_t i = 0; i < n; i++) {
            double value[5];
            for (int k = 0; k < 5; k++)
                value[k] = column[k] ? column[k][i] : NAN;
            fprintf(out, "  %-12.4g %-10.6g %-9.3g %-12.4g %-5.0f\n", value[0], value[1], 100 * value[2], value[3],
                    value[4]);
        }
        for (int k = 0; k < 5; k++)
            free(column[k]);
        print_vcrit_temperatures(file, n, out);
    }
    hid_t group;
    for (size_t i = 0; i < 1000 && h5_numbered_group(file, "search", i, &group); i++) {
        char result[256];
        double d = NAN;
        if (group >= 0 && h5_attr_read_string(group, "result", result, sizeof result) == SC_OK &&
            strcmp(result, "bracketed") != 0 && h5_attr_read_double(group, "diameter", &d) == SC_OK) {
            double T = NAN;
            if (h5_attr_read_double(group, "temperature", &T) == SC_OK)
                fprintf(out, "  d = %.4g m, T = %.4g K: %s\n", d, T, result);
            else
                fprintf(out, "  d = %.4g m: %s\n", d, result);
        }
        if (group >= 0)
            H5Gclose(group);
    }
}

/* impact.h5 of several runs (/run_NNNN): the overall verdicts and one line per run. */
static void print_impact_runs(hid_t file, FILE *out)
{
    hid_t summary = H5Gopen2(file, "summary", H5P_DEFAULT);
    if (summary < 0)
        return;
    static const char *const overall[] = {"runs",
                                          "bodies",
                                          "bonded",
                                          "unsettled",
                                          "bonded_fraction",
                                          "mean_pbcp",
                                          "mean_bonded_interface",
                                          "mean_v_rest",
                                          "mean_cor",
                                          "uncalibrated_bodies",
                                          NULL};
    fprintf(out, "summary (all runs):\n");
    for (int k = 0; overall[k]; k++)
        print_attribute(summary, overall[k], out);
    size_t runs = 0;
    if (h5_dataset_size(summary, "run_bonded_fraction", &runs) == SC_OK && runs > 0) {
        /* run_unsettled: files before it hold none (NaN) */
        static const char *const names[] = {"run_bonded_fraction", "run_pbcp", "run_v_rest", "run_cor",
                                            "run_unsettled"};
        double *column[5];
        for (int k = 0; k < 5; k++)
            column[k] = read_column(summary, names[k], runs);
        sc_error_clear();
        /* v_rest and CoR: means over the run's settled particles (NaN when none settled) */
        fprintf(out, "  %-6s %-16s %-10s %-9s %-12s %-8s\n", "run", "bonded fraction", "unsettled", "PBCP %",
                "v_rest (m/s)", "CoR");
        for (size_t r = 0; r < runs; r++) {
            double value[5];
            for (int k = 0; k < 5; k++)
                value[k] = column[k] ? column[k][r] : NAN;
            fprintf(out, "  %-6zu %-16.3g %-10.3g %-9.3g %-12.4g %-8.3g\n", r, value[0], value[4], 100.0 * value[1],
                    value[2], value[3]);
        }
        for (int k = 0; k < 5; k++)
            free(column[k]);
    }
    H5Gclose(summary);
    fprintf(out, "  per-body results: /run_NNNN/summary in impact.h5\n");
}

/* couple.h5 /flight: how closely the spray's impact velocities agree with the flights' (a file of an older
 * spraycoat has no such attributes: nothing is printed). */
static void print_flight_agreement(hid_t file, FILE *out)
{
    hid_t flight = h5_exists(file, "flight") ? H5Gopen2(file, "flight", H5P_DEFAULT) : H5I_INVALID_HID;
    if (flight < 0)
        return;
    double mean = NAN, median = NAN, max = NAN;
    int64_t outliers = 0;
    if (H5Aexists(flight, "spray_velocity_difference_median") > 0 &&
        h5_attr_read_double(flight, "spray_velocity_difference_mean", &mean) == SC_OK &&
        h5_attr_read_double(flight, "spray_velocity_difference_median", &median) == SC_OK &&
        h5_attr_read_double(flight, "spray_velocity_difference_max", &max) == SC_OK &&
        h5_attr_read_int64(flight, "spray_velocity_outliers", &outliers) == SC_OK)
        fprintf(out,
                "  the spray's impact velocities against the flights': |dv|/|v| %.3g %% on average, %.3g %% at the "
                "median, at most %.3g %% (%lld over 10 %%)\n",
                100.0 * mean, 100.0 * median, 100.0 * max, (long long)outliers);
    H5Gclose(flight);
}

/* couple.h5: the seeds (one line each) and the CVODE work of the flights. */
static void print_couple_results(hid_t file, FILE *out)
{
    size_t n = 0, flights = 0;
    if (h5_dataset_size(file, "seeds/d", &n) != SC_OK)
        return;
    h5_dataset_size(file, "flight/steps", &flights);
    double *d = read_column(file, "seeds/d", n), *t = read_column(file, "seeds/t_wall", n);
    double *v = read_column(file, "seeds/v", 3 * n), *vs = read_column(file, "seeds/v_spray", 3 * n);
    double *x = read_column(file, "seeds/x", 3 * n), *run = read_column(file, "seeds/run", n);
    double *steps = read_column(file, "flight/steps", flights);
    double total_steps = 0.0;
    for (size_t i = 0; steps && i < flights; i++)
        total_steps += steps[i];
    fprintf(out, "seeds: %zu (flights: %zu, %.0f CVODE steps)\n", n, flights, total_steps);
    print_flight_agreement(file, out);
    fprintf(out, "  %-5s %-12s %-12s %-12s %-24s\n", "run", "d (m)", "v spray", "v wall", "centre (m, impact frame)");
    for (size_t i = 0; d && t && v && vs && x && run && i < n && i < 50; i++) {
        double speed = sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
        double spray = sqrt(vs[3 * i] * vs[3 * i] + vs[3 * i + 1] * vs[3 * i + 1] + vs[3 * i + 2] * vs[3 * i + 2]);
        fprintf(out, "  %-5.0f %-12.4g %-12.5g %-12.5g (%.3g, %.3g, %.3g)\n", run[i], d[i], spray, speed, x[3 * i],
                x[3 * i + 1], x[3 * i + 2]);
    }
    if (n > 50)
        fprintf(out, "  ... (%zu more in /seeds)\n", n - 50);
    free(d), free(t), free(v), free(vs), free(x), free(run), free(steps);
}

/* sweep.h5: the map of DE and mean impact speed, one line per run (app/sweep_stage.c). */
static void print_sweep_results(hid_t file, FILE *out)
{
    char keys[2][160] = {"", ""}, labels[2][4096] = {"", ""};
    h5_attr_read_string(file, "x_key", keys[0], sizeof keys[0]);
    h5_attr_read_string(file, "y_key", keys[1], sizeof keys[1]);
    h5_attr_read_string(file, "x_labels", labels[0], sizeof labels[0]);
    h5_attr_read_string(file, "y_labels", labels[1], sizeof labels[1]);
    size_t nx = 0, ny = 0, n = 0;
    h5_dataset_size(file, "x_values", &nx);
    h5_dataset_size(file, "y_values", &ny);
    h5_dataset_size(file, "de", &n);
    double *de = read_column(file, "de", n), *speed = read_column(file, "mean_impact_speed", n);
    fprintf(out, "sweep over %s (%s) and %s (%s):\n", keys[0], labels[0], keys[1][0] ? keys[1] : "-", labels[1]);
    for (size_t k = 0; de && speed && n == nx * ny && k < n; k++)
        fprintf(out, "  runs/x%zu_y%zu  DE %.4f  mean impact speed %.4g m/s\n", k % nx, k / nx, de[k], speed[k]);
    free(de), free(speed);
}

static int info_file(const char *path, FILE *out)
{
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    fprintf(out, "%s:\n", path);
    for (int k = 0; root_attributes[k]; k++)
        print_attribute(file, root_attributes[k], out);
    char stage[64] = "";
    h5_attr_read_string(file, "stage", stage, sizeof stage);
    /* an impact checkpoint holds /series too (mpm/output.c): it is told from impact.h5 by its root attribute step */
    if (strcmp(stage, "impact") == 0 && H5Aexists(file, "step") > 0) {
        fprintf(out, "impact checkpoint:\n");
        for (int k = 0; impact_checkpoint[k]; k++)
            print_attribute(file, impact_checkpoint[k], out);
    } else if (strcmp(stage, "impact") == 0 && h5_exists(file, "series")) {
        print_impact_results(file, out);
    } else if (strcmp(stage, "impact") == 0 && h5_exists(file, "run_0000")) {
        print_impact_runs(file, out);
    } else if (strcmp(stage, "couple") == 0) {
        print_couple_results(file, out);
    } else if (strcmp(stage, "vcrit") == 0) {
        print_vcrit_results(file, out);
    } else if (strcmp(stage, "calibrate") == 0) {
        print_calibrate_results(file, out);
    } else if (strcmp(stage, "sweep") == 0) {
        print_sweep_results(file, out);
    } else {
        if (h5_exists(file, "stats")) {
            hid_t stats = H5Gopen2(file, "stats", H5P_DEFAULT);
            fprintf(out, "counts:\n");
            for (int k = 0; spray_stats[k]; k++)
                print_attribute(stats, spray_stats[k], out);
            H5Gclose(stats);
        }
        if (h5_exists(file, "counters")) {
            int64_t counters[5];
            if (h5_read_int64s(file, "counters", counters, 5) == SC_OK)
                fprintf(out, "checkpoint: step %lld, injected %lld, escaped %lld, deposited %lld\n",
                        (long long)counters[0], (long long)counters[1], (long long)counters[2], (long long)counters[3]);
        }
        print_last_metrics(file, out);
        print_deposition_efficiency(file, 0, out);
    }
    H5Fclose(file);
    sc_error_clear();
    return SC_OK;
}

static int count_lines(const char *path)
{
    FILE *file = fopen(path, "r");
    if (!file)
        return -1;
    int lines = 0, c;
    while ((c = fgetc(file)) != EOF)
        lines += c == '\n';
    fclose(file);
    return lines;
}

/* The impact runs of an unfinished multi-run stage that are done (RUN_DIR/impact_runs/run_NNNN.h5). */
static void print_runs_done(const char *run_dir, FILE *out)
{
    char path[4200];
    int done = 0;
    for (int r = 0; r < 100000; r++) {
        snprintf(path, sizeof path, "%s/impact_runs/run_%04d.h5", run_dir, r);
        if (access(path, R_OK) != 0)
            break;
        done++;
    }
    if (done)
        fprintf(out, "  runs 0 ... %d done (RUN_DIR/impact_runs/)\n", done - 1);
}

/* An unfinished sweep: its runs done (runs/xI_yJ/spray.h5) and those interrupted (runs/xI_yJ/checkpoints/): the
 * sweep's own folder holds no checkpoint, so "not done" alone hid a sweep stopped half-way. */
static void print_sweep_runs(const char *run_dir, FILE *out)
{
    char pattern[4200], path[4600];
    glob_t runs = {0}, checkpoints = {0};
    size_t done = 0, interrupted = 0;
    snprintf(pattern, sizeof pattern, "%s/runs/x*_y*", run_dir);
    if (glob(pattern, GLOB_ONLYDIR, NULL, &runs) == 0)
        for (size_t k = 0; k < runs.gl_pathc; k++) {
            snprintf(path, sizeof path, "%s/spray.h5", runs.gl_pathv[k]);
            if (access(path, R_OK) == 0) {
                done++;
                continue;
            }
            snprintf(path, sizeof path, "%s/checkpoints/spray_*.h5", runs.gl_pathv[k]);
            if (glob(path, 0, NULL, &checkpoints) == 0)
                interrupted++;
            globfree(&checkpoints);
        }
    globfree(&runs);
    if (done || interrupted)
        fprintf(out, "  %zu runs done, %zu interrupted (RUN_DIR/runs/; `spraycoat resume` finishes the sweep)\n", done,
                interrupted);
}

static void print_render_state(const char *run_dir, const char *stages, FILE *out)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/report.html", run_dir);
    int done = access(path, R_OK) == 0;
    if (done || strstr(stages, "render"))
        fprintf(out, "stage render: %s\n", done ? "done (report.html, figures/)" : "not done");
}

/* " (made by another build ...)" after a stage's `done` when its output is of other sources (docs/architecture.md
 * "Another build"): running the stage computes it again. */
static void print_other_build(const char *path, FILE *out)
{
    hid_t file;
    if (h5_open_read(path, &file) != SC_OK) {
        sc_error_clear();
        return;
    }
    char sources[64];
    if (!h5_same_sources(file, sources, sizeof sources))
        fprintf(out, " (made by another build of spraycoat: sources %s, this build's %s; the stage computes it again)",
                sources, spraycoat_sources_id());
    H5Fclose(file);
}

/* A stage's output made by another case than RUN_DIR/case.ini's (a run of another case into the directory, stopped
 * before it replaced it): "done" alone read as this case's result.  Nothing when case.ini cannot be loaded. */
static void print_other_case(const struct case_file *c, const char *run_dir, const char *stage, const char *path,
                             FILE *out)
{
    if (!c)
        return;
    const struct stage_context ctx = {.c = c, .run_dir = run_dir};
    if (run_dir_made_by_case(&ctx, stage, path) == 0)
        fprintf(out, " (of another case than %s/case.ini: not its result; running the stage computes it again)",
                run_dir);
}

int info_print(const char *target, FILE *out)
{
    static const char *const stage_names[] = {"spray", "couple", "impact", "vcrit", "calibrate", "sweep"};
    enum { STAGES = 6, VCRIT = 3, IMPACT = 2, CALIBRATE = 4, SWEEP = 5 };
    if (!target)
        SC_FAIL(SC_EINPUT, "info needs a run directory or an .h5 file (see spraycoat --help)");
    struct stat st;
    if (stat(target, &st) != 0)
        SC_FAIL(SC_EIO, "info: cannot read %s", target);
    if (!S_ISDIR(st.st_mode))
        return info_file(target, out);
    char path[4096], newest[4400], stages[256] = "spray";
    snprintf(path, sizeof path, "%s/case.ini", target);
    if (access(path, R_OK) != 0)
        SC_FAIL(SC_EIO, "info: %s is not a run directory (no readable case.ini)", target);
    int running = run_dir_in_use(target);
    fprintf(out, "run directory %s\n", target);
    fprintf(out, "status: %s\n", running ? "running (a spraycoat process holds the run directory now)" : "not running");
    fprintf(out, "case: %s\n", path);
    SC_TRY(run_dir_read_stages(target, stages, sizeof stages));
    fprintf(out, "stages asked for: %s\n", stages);
    struct case_file *c = NULL; /* case.ini, to tell the outputs of another case */
    if (case_load(path, spraycoat_registry, &c) != SC_OK)
        c = NULL, sc_error_clear();
    char *results[STAGES] = {NULL};
    for (int k = 0; k < STAGES; k++) {
        const char *stage = stage_names[k];
        snprintf(path, sizeof path, "%s/%s.h5", target, stage);
        int done = access(path, R_OK) == 0;
        size_t checkpoints = run_dir_stage_checkpoints(target, stage, newest, sizeof newest);
        int asked = strstr(stages, stage) != NULL;
        if (!done && !checkpoints && !asked)
            continue;
        const char *unfinished = running ? "in progress or waiting" : checkpoints ? "interrupted" : "not done";
        fprintf(out, "stage %s: %s", stage, done ? "done" : unfinished);
        if (done) {
            print_other_build(path, out);
            print_other_case(c, target, stage, path, out);
        }
        if (checkpoints)
            fprintf(out, "; %zu checkpoints, newest %s", checkpoints, newest);
        fputc('\n', out);
        if (done && !(results[k] = strdup(path)))
            SC_DIE_OOM(strlen(path) + 1, "a file name");
        else if (!done && checkpoints && !(results[k] = strdup(newest)))
            SC_DIE_OOM(strlen(newest) + 1, "a file name");
        if (k == IMPACT && !done)
            print_runs_done(target, out);
        if (k == SWEEP && !done)
            print_sweep_runs(target, out);
        if ((k == VCRIT || k == CALIBRATE) && !done) {
            snprintf(path, sizeof path, "%s/%s_runs.csv", target, stage);
            int lines = count_lines(path);
            if (lines >= 2)
                fprintf(out, "  %d runs recorded in %s\n", lines - 2, path);
        }
    }
    print_render_state(target, stages, out);
    int status = SC_OK;
    for (int k = 0; k < STAGES; k++)
        if (results[k])
            SC_CHECK(status, info_file(results[k], out), done);
done:
    for (int k = 0; k < STAGES; k++)
        free(results[k]);
    case_free(c);
    return status;
}

/* The last value of a 1-D dataset (NAN when it cannot be read). */
static double last_value(hid_t file, const char *name)
{
    size_t n = 0;
    if (h5_dataset_size(file, name, &n) != SC_OK || n == 0)
        return NAN;
    double *column = read_column(file, name, n);
    double value = column ? column[n - 1] : NAN;
    free(column);
    return value;
}

/* A single run's impact.h5 (no /summary runs attribute): how many particles bonded and each particle's verdict,
 * settled or not by the end (the substrate left out), at most 20 of them. */
static void print_impact_bodies_headline(hid_t file, FILE *out)
{
    size_t n;
    if (h5_dataset_size(file, "summary/verdict", &n) != SC_OK || n == 0)
        return;
    static const char *const names[] = {"summary/diameter",  "summary/v_impact",        "summary/verdict",
                                        "summary/pbcp",      "summary/v_rest",          "summary/substrate",
                                        "summary/t_settled", "summary/bonded_interface"};
    double *column[8];
    for (int k = 0; k < 8; k++)
        column[k] = read_column(file, names[k], n);
    double pbcp_threshold = NAN, vrest_threshold = NAN;
    summary_thresholds(file, &pbcp_threshold, &vrest_threshold);
    size_t particles = 0, bonded = 0, shown = 0;
    for (size_t b = 0; column[2] && b < n; b++)
        if (!(column[5] && column[5][b] == 1.0)) {
            particles++;
            bonded += (int)column[2][b] == MPM_VERDICT_BONDED;
        }
    fprintf(out, "impact: %zu of %zu particles bonded (one MPM run)\n", bonded, particles);
    for (size_t b = 0; column[2] && b < n; b++) {
        double value[8];
        for (int k = 0; k < 8; k++)
            value[k] = column[k] ? column[k][b] : NAN;
        if (value[5] == 1.0)
            continue;
        if (shown++ == 20) {
            fprintf(out, "  ... %zu more particles (`spraycoat info RUN_DIR`)\n", particles - 20);
            break;
        }
        int verdict = (int)value[2];
        const char *name = mpm_verdict_held(verdict, value[4], vrest_threshold) ? "held" : mpm_verdict_name(verdict);
        char settled[64];
        if (isnan(value[6]))
            snprintf(settled, sizeof settled, "not settled by the end of the run");
        else
            snprintf(settled, sizeof settled, "settled at %.3g ns", value[6] * 1e9);
        fprintf(out, "  body %zu (d %.3g um at %.4g m/s): %s (%s); PBCP %.1f %%", b, value[0] * 1e6, value[1], name,
                settled, 100.0 * value[3]);
        if (!isnan(value[7]))
            fprintf(out, ", bonded interface %.1f %%", 100.0 * value[7]);
        fprintf(out, ", v_rest %.3g m/s\n", value[4]);
    }
    for (int k = 0; k < 8; k++)
        free(column[k]);
}

/* The results table of a vcrit, calibrate or sweep run directory (`spraycoat info`'s), when its file is there. */
static void print_search_headline(const char *run_dir, FILE *out)
{
    static const char *const stages[] = {"vcrit", "calibrate", "sweep"};
    static void (*const print[])(hid_t, FILE *) = {print_vcrit_results, print_calibrate_results, print_sweep_results};
    for (int k = 0; k < 3; k++) {
        char path[4200];
        hid_t file;
        snprintf(path, sizeof path, "%s/%s.h5", run_dir, stages[k]);
        if (access(path, R_OK) == 0 && h5_open_read(path, &file) == SC_OK) {
            print[k](file, out);
            H5Fclose(file);
        }
    }
}

void info_headline(const char *run_dir, FILE *out)
{
    char path[4200];
    hid_t file;
    snprintf(path, sizeof path, "%s/spray.h5", run_dir);
    if (access(path, R_OK) == 0 && h5_open_read(path, &file) == SC_OK) {
        fprintf(out,
                "spray:  deposit fraction %.3f (%.0f of %.0f particles deposited), deposited centres span %.3g m in "
                "height\n",
                last_value(file, "metrics/deposit_fraction"), last_value(file, "metrics/deposited"),
                last_value(file, "metrics/injected"), last_value(file, "metrics/max_thickness"));
        print_deposition_efficiency(file, 1, out);
        H5Fclose(file);
    }
    snprintf(path, sizeof path, "%s/impact.h5", run_dir);
    hid_t summary;
    if (access(path, R_OK) == 0 && h5_open_read(path, &file) == SC_OK) {
        double fraction = NAN, pbcp = NAN, v_rest = NAN, interface = NAN;
        int64_t bodies = 0, bonded = -1, runs = 0, unsettled = -1, uncalibrated = -1;
        if (h5_exists(file, "summary") && (summary = H5Gopen2(file, "summary", H5P_DEFAULT)) >= 0) {
            h5_attr_read_double(summary, "bonded_fraction", &fraction);
            h5_attr_read_double(summary, "mean_pbcp", &pbcp);
            h5_attr_read_double(summary, "mean_v_rest", &v_rest);
            h5_attr_read_double(summary, "mean_bonded_interface", &interface); /* format version 2 on */
            h5_attr_read_int64(summary, "bodies", &bodies);
            h5_attr_read_int64(summary, "bonded", &bonded);
            h5_attr_read_int64(summary, "runs", &runs);
            h5_attr_read_int64(summary, "unsettled", &unsettled);
            if (H5Aexists(summary, "uncalibrated_bodies") > 0)
                h5_attr_read_int64(summary, "uncalibrated_bodies", &uncalibrated);
            H5Gclose(summary);
        }
        if (runs > 0) {
            /* counts, not a rounded share alone (1 of 200 is not "0 %"); an unsettled body, whose verdict still
             * changed at the end, is neither bonded nor rebounded: the share is of all bodies, a lower bound, and
             * the interval takes the unsettled either way (it counted them as not bonded: 0 of 4 with all 4
             * unsettled read 0-49 %, a review) */
            fprintf(out, "impact: %lld of %lld bodies bonded (%.1f %%", (long long)bonded, (long long)bodies,
                    100.0 * fraction);
            snprintf(path, sizeof path, "%s/couple.h5", run_dir);
            if (bonded >= 0 && bodies > 0 && access(path, R_OK) == 0) { /* sampled from the spray: its error */
                double lo, hi;
                size_t unknown = unsettled > 0 ? (size_t)unsettled : 0;
                logistic_wilson_bounds((size_t)bonded, unknown, (size_t)bodies, 1.959964, &lo, &hi);
                fprintf(out, "; %s95 %% interval %.3g-%.3g %%", unknown ? "the unsettled counted either way, " : "",
                        100.0 * lo, 100.0 * hi);
            }
            fprintf(out, ") over %lld MPM runs", (long long)runs);
            if (unsettled >= 0)
                fprintf(out, ", %lld unsettled (neither bonded nor rebounded)", (long long)unsettled);
            fprintf(out, "; mean PBCP %.1f %%", 100.0 * pbcp);
            if (!isnan(interface)) /* PBCP counts points that ever bonded; this, nodes bonded at the end */
                fprintf(out, ", mean bonded interface %.1f %%", 100.0 * interface);
            if (unsettled > 0) /* impact_stage.c: v_rest's mean is over the settled bodies */
                fprintf(out, ", mean v_rest %.3g m/s of the %lld settled\n", v_rest, (long long)(bodies - unsettled));
            else
                fprintf(out, ", mean v_rest %.3g m/s\n", v_rest);
            if (uncalibrated > 0) /* mpm_bonding_calibrated_resolution: the verdict means nothing there */
                fprintf(out,
                        "        %lld of the %lld bodies ran at a resolution their bonding parameters were not "
                        "calibrated at: their verdicts are not calibrated (docs/physics.md \"Bonding calibration\")\n",
                        (long long)uncalibrated, (long long)bodies);
        } else {
            print_impact_bodies_headline(file, out);
        }
        H5Fclose(file);
    }
    print_search_headline(run_dir, out);
    snprintf(path, sizeof path, "%s/report.html", run_dir);
    if (access(path, R_OK) == 0)
        fprintf(out, "report: %s (figures in %s/figures)\n", path, run_dir);
    sc_error_clear();
}
