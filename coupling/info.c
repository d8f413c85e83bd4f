#include "coupling/info.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/h5io.h"

static const char *const root_attributes[] = {
    "format", "format_version", "program_version", "stage", "case_hash", "created", NULL};
static const char *const spray_stats[] = {"steps",
                                          "t",
                                          "injected",
                                          "in_flight",
                                          "deposited",
                                          "escaped",
                                          "contacts_pair",
                                          "contacts_target",
                                          "contacts_deposit",
                                          "fixed_point_iterations",
                                          "fixed_point_solves",
                                          "fixed_point_unconverged",
                                          "subcycled_particle_steps",
                                          "particle_steps",
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
    fprintf(out, "final metrics:\n");
    for (int k = 0; metric_names[k]; k++) {
        char path[128];
        snprintf(path, sizeof path, "metrics/%s", metric_names[k]);
        if (h5_read_doubles(file, path, column, n) == SC_OK)
            fprintf(out, "  %-28s %.6g\n", metric_names[k], column[n - 1]);
    }
    free(column);
}

static int info_file(const char *path, FILE *out)
{
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    fprintf(out, "%s:\n", path);
    for (int k = 0; root_attributes[k]; k++)
        print_attribute(file, root_attributes[k], out);
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
            fprintf(out, "checkpoint: step %lld, injected %lld, escaped %lld, deposited %lld\n", (long long)counters[0],
                    (long long)counters[1], (long long)counters[2], (long long)counters[3]);
    }
    print_last_metrics(file, out);
    H5Fclose(file);
    return SC_OK;
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* The newest checkpoint file name of each stage, from the sorted listing. */
static void info_checkpoints(const char *run_dir, FILE *out)
{
    char dir_path[4096];
    snprintf(dir_path, sizeof dir_path, "%s/checkpoints", run_dir);
    DIR *dir = opendir(dir_path);
    if (!dir) {
        fprintf(out, "checkpoints: none\n");
        return;
    }
    char *names[4096];
    size_t count = 0;
    struct dirent *entry;
    while ((entry = readdir(dir)) && count < 4096) {
        size_t len = strlen(entry->d_name);
        if (len > 3 && strcmp(entry->d_name + len - 3, ".h5") == 0)
            names[count++] = strdup(entry->d_name);
    }
    closedir(dir);
    qsort(names, count, sizeof *names, compare_names);
    fprintf(out, "checkpoints: %zu%s%s\n", count, count ? ", newest " : "", count ? names[count - 1] : "");
    for (size_t i = 0; i < count; i++)
        free(names[i]);
}

int info_print(const char *target, FILE *out)
{
    if (!target)
        SC_FAIL(SC_EINPUT, "info needs a run directory or an .h5 file (see spraycoat --help)");
    struct stat st;
    if (stat(target, &st) != 0)
        SC_FAIL(SC_EIO, "info: cannot read %s", target);
    if (!S_ISDIR(st.st_mode))
        return info_file(target, out);
    char path[4096];
    snprintf(path, sizeof path, "%s/case.ini", target);
    if (access(path, R_OK) != 0)
        SC_FAIL(SC_EIO, "info: %s is not a run directory (no readable case.ini)", target);
    fprintf(out, "run directory %s\n", target);
    fprintf(out, "case: %s\n", path);
    snprintf(path, sizeof path, "%s/spray.h5", target);
    int spray_done = access(path, R_OK) == 0;
    fprintf(out, "stage spray: %s\n", spray_done ? "done" : "not done");
    info_checkpoints(target, out);
    if (spray_done)
        SC_TRY(info_file(path, out));
    return SC_OK;
}
