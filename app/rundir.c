/* The run directory, the registry of case keys, and signal handling shared by the stages. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/atomic.h"
#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/run_keys.h"
#include "core/version.h"
#include "app/app.h"
#include "dem/dem.h"
#include "mpm/mpm.h"
#include "render/render.h"

const struct cfg_key *const spraycoat_registry[] = {run_case_keys,    dem_case_keys,   couple_case_keys,
                                                    mpm_case_keys,    vcrit_case_keys, calibrate_case_keys,
                                                    render_case_keys, sweep_case_keys, NULL};

static int make_directories(const char *path)
{
    char partial[4096];
    size_t len = strlen(path);
    if (len == 0 || len >= sizeof partial)
        SC_FAIL(SC_EINPUT, "run directory '%s': empty or too long", path);
    memcpy(partial, path, len + 1);
    for (char *slash = partial + 1; *slash; slash++) {
        if (*slash != '/')
            continue;
        *slash = '\0';
        if (mkdir(partial, 0777) != 0 && errno != EEXIST)
            SC_FAIL(SC_EIO, "cannot create directory %s: %s", partial, strerror(errno));
        *slash = '/';
    }
    if (mkdir(partial, 0777) != 0 && errno != EEXIST)
        SC_FAIL(SC_EIO, "cannot create run directory %s: %s", partial, strerror(errno));
    struct stat info;
    if (stat(partial, &info) != 0 || !S_ISDIR(info.st_mode))
        SC_FAIL(SC_EIO, "run directory %s exists but is not a directory", partial);
    return SC_OK;
}

/* One process per run directory: two runs writing the same checkpoints and outputs would clash.  The
 * lock is an flock on the directory itself (no lock file to leave behind); the kernel drops it when the
 * process ends, however it ends, so a killed run never leaves the directory locked. */
static char locked_dir[4096]; /* the run directory this process holds locked ("" none) */

static int lock_run_dir(const char *run_dir)
{
    if (strcmp(locked_dir, run_dir) == 0)
        return SC_OK;
    int fd = open(run_dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        SC_FAIL(SC_EIO, "cannot open run directory %s: %s", run_dir, strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int saved = errno;
        close(fd);
        if (saved == EWOULDBLOCK)
            SC_FAIL(SC_EIO,
                    "run directory %s is in use by another spraycoat process; wait for it or use another "
                    "directory",
                    run_dir);
        SC_FAIL(SC_EIO, "cannot lock run directory %s: %s", run_dir, strerror(saved));
    }
    snprintf(locked_dir, sizeof locked_dir, "%s", run_dir);
    return SC_OK; /* the descriptor stays open, and the lock held, until the process exits */
}

int run_dir_in_use(const char *run_dir)
{
    int fd = open(run_dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return 0;
    /* a shared lock is refused while another process holds the exclusive one of a running stage */
    int in_use = flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    close(fd); /* drops the shared lock, if taken */
    return in_use;
}

int run_dir_lock_existing(const char *run_dir)
{
    struct stat info;
    if (stat(run_dir, &info) != 0 || !S_ISDIR(info.st_mode))
        return SC_OK; /* made and locked by run_dir_prepare; nothing in it to read before */
    return lock_run_dir(run_dir);
}

int run_dir_prepare(const char *run_dir, const struct case_file *c)
{
    char path[4096];
    SC_TRY(make_directories(run_dir));
    SC_TRY(lock_run_dir(run_dir));
    snprintf(path, sizeof path, "%s/case.ini", run_dir);
    SC_TRY(case_write_resolved(c, path));
    return SC_OK;
}

static char damage_reason[1024]; /* why run_dir_output_state last found an output OUTPUT_DAMAGED */

enum output_state run_dir_output_state(const char *path, uint64_t case_hash)
{
    if (access(path, F_OK) != 0)
        return OUTPUT_NONE;
    hid_t file;
    if (access(path, R_OK) != 0 || h5_open_read(path, &file) != SC_OK) {
        sc_error_clear();
        return OUTPUT_OTHER_CASE;
    }
    char stored[64] = "", wanted[64], sources[64];
    snprintf(wanted, sizeof wanted, "%016llx", (unsigned long long)case_hash);
    int same_case =
        h5_attr_read_string(file, "case_hash", stored, sizeof stored) == SC_OK && strcmp(stored, wanted) == 0;
    int same_sources = h5_same_sources(file, sources, sizeof sources);
    H5Fclose(file);
    sc_error_clear();
    if (!same_case)
        return OUTPUT_OTHER_CASE;
    if (!same_sources)
        return OUTPUT_OTHER_BUILD; /* computed again anyway: not worth reading whole */
    /* results about to be taken as done are read whole first (every dataset and attribute, their checksums
     * verified): a damaged one counted as done, and every later stage (or the gathering of the impact runs) then
     * stopped on it, on every resume */
    if (h5_verify_file(path) != SC_OK) {
        snprintf(damage_reason, sizeof damage_reason, "%s", sc_error_message());
        sc_error_clear();
        return OUTPUT_DAMAGED;
    }
    return OUTPUT_CURRENT;
}

int run_dir_output_current(const char *path, uint64_t case_hash)
{
    return run_dir_output_state(path, case_hash) == OUTPUT_CURRENT;
}

void run_dir_log_rerun(const char *stage, const char *path, enum output_state state)
{
    if (state == OUTPUT_OTHER_CASE)
        log_info("%s: %s was made from another case; running the stage again", stage, path);
    if (state == OUTPUT_OTHER_BUILD)
        log_info("%s: %s was made by another build of spraycoat (other sources, `spraycoat info %s`); running "
                 "the stage again",
                 stage, path, path);
    if (state == OUTPUT_DAMAGED)
        log_warn("%s: %s is damaged (%s); computing it again", stage, path, damage_reason);
}

const char *stage_resume_dir(const struct stage_context *ctx)
{
    return ctx->resume_dir ? ctx->resume_dir : ctx->run_dir;
}

int run_dir_retire_output(const char *path)
{
    if (unlink(path) != 0 && errno != ENOENT)
        SC_FAIL(SC_EIO, "cannot remove %s (the results of another case) before writing the new ones: %s", path,
                strerror(errno));
    return atomic_sync_folder(path);
}

int run_dir_write_stages(const char *run_dir, const char *stages)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/stages", run_dir);
    struct atomic_file out;
    SC_TRY(atomic_open(path, &out));
    fprintf(out.stream, "%s\n", stages);
    return atomic_publish(&out);
}

static int compare_checkpoint_names(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

size_t run_dir_stage_checkpoints(const char *run_dir, const char *stage, char *newest, size_t size)
{
    char dir_path[4096];
    snprintf(dir_path, sizeof dir_path, "%s/checkpoints", run_dir);
    newest[0] = '\0';
    DIR *dir = opendir(dir_path);
    if (!dir)
        return 0;
    char *names[4096];
    size_t count = 0, prefix = strlen(stage);
    struct dirent *entry;
    while ((entry = readdir(dir)) && count < 4096) {
        size_t len = strlen(entry->d_name);
        if (len > prefix + 4 && strncmp(entry->d_name, stage, prefix) == 0 && entry->d_name[prefix] == '_' &&
            strcmp(entry->d_name + len - 3, ".h5") == 0)
            if (!(names[count++] = strdup(entry->d_name)))
                SC_DIE_OOM(len + 1, "a checkpoint's name");
    }
    closedir(dir);
    qsort(names, count, sizeof *names, compare_checkpoint_names);
    if (count)
        snprintf(newest, size, "%s/%s", dir_path, names[count - 1]);
    for (size_t i = 0; i < count; i++)
        free(names[i]);
    return count;
}

int run_dir_read_stages(const char *run_dir, char *out, size_t size)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/stages", run_dir);
    FILE *file = fopen(path, "r");
    if (!file) {
        if (errno != ENOENT)
            SC_FAIL(SC_EIO, "cannot read %s: %s", path, strerror(errno));
        snprintf(out, size, "spray");
        return SC_OK;
    }
    char line[256] = "";
    int ok = fgets(line, sizeof line, file) != NULL;
    fclose(file);
    line[strcspn(line, "\r\n")] = '\0';
    if (!ok || line[0] == '\0')
        SC_FAIL(SC_EIO, "%s is empty: it should name the stages of the run (e.g. impact)", path);
    snprintf(out, size, "%s", line);
    return SC_OK;
}

int app_case_section_given(const struct case_file *c, const char *section)
{
    for (int t = 0; spraycoat_registry[t]; t++)
        for (const struct cfg_key *k = spraycoat_registry[t]; k->key; k++)
            if (strcmp(k->section, section) == 0 && case_is_given(c, section, k->key))
                return 1;
    return 0;
}

int stage_begin(const char *stage, const char *output, uint64_t case_hash, const struct case_file *c,
                struct run_settings *settings)
{
    enum output_state state = run_dir_output_state(output, case_hash);
    if (state == OUTPUT_CURRENT) {
        log_info("%s: %s is up to date with the case; nothing to do", stage, output);
        /* a process killed between writing the output and removing the stage's checkpoints left them behind */
        char run_dir[4096];
        snprintf(run_dir, sizeof run_dir, "%s", output);
        char *slash = strrchr(run_dir, '/');
        if (slash)
            *slash = '\0';
        if (parallel_rank() == 0 && h5_checkpoint_remove_all(slash ? run_dir : ".", stage) != SC_OK)
            log_warn("%s: %s", stage, sc_error_message());
        return 1;
    }
    run_dir_log_rerun(stage, output, state);
    run_settings_load(c, settings);
    if (settings->threads > 0)
        omp_set_num_threads(settings->threads);
    return 0;
}

/* The sections each stage's results depend on: a stage's inputs are its own keys and everything upstream of it.
 * The impact stage of a pipeline case (one with [couple]) takes its bodies from couple.h5. */
static const char *const spray_sections[] = {"run", "spray",      "powder", "target", "contact",
                                             "jet", "deposition", "nozzle", "path",   NULL};
static const char *const couple_sections[] = {"run",        "spray",  "powder", "target", "contact", "jet",
                                              "deposition", "nozzle", "path",   "couple", NULL};
static const char *const pipeline_impact_sections[] = {"run",    "spray",      "powder", "target", "contact",
                                                       "jet",    "deposition", "nozzle", "path",   "couple",
                                                       "impact", "material.*", NULL};
static const char *const impact_sections[] = {"run", "impact", "material.*", NULL};
static const char *const vcrit_sections[] = {"run", "impact", "material.*", "vcrit", NULL};
static const char *const calibrate_sections[] = {"run", "impact", "material.*", "calibrate", NULL};
/* [calibrate] method = vcrit: its searches are of [vcrit] too */
static const char *const calibrate_vcrit_sections[] = {"run", "impact", "material.*", "calibrate", "vcrit", NULL};

int run_dir_has_seeds(const struct case_file *c, const char *run_dir)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/couple.h5", run_dir);
    struct stage_context ctx = {.c = c, .run_dir = run_dir};
    /* the seeds of another build are still this case's: run_dir_check_input warns about them; damaged seeds are
     * this case's too: reading them stops the impact stage, naming the file (not a run on [impact]'s own body) */
    enum output_state state = run_dir_output_state(path, stage_hash(&ctx, "couple"));
    return state == OUTPUT_CURRENT || state == OUTPUT_OTHER_BUILD || state == OUTPUT_DAMAGED;
}

uint64_t stage_hash(const struct stage_context *ctx, const char *stage)
{
    const struct case_file *c = ctx->c;
    if (strcmp(stage, "spray") == 0)
        return case_hash_sections(c, spray_sections);
    if (strcmp(stage, "couple") == 0)
        return case_hash_sections(c, couple_sections);
    if (strcmp(stage, "impact") == 0)
        return case_hash_sections(c, ctx->impact_from_seeds ? pipeline_impact_sections : impact_sections);
    if (strcmp(stage, "vcrit") == 0)
        return case_hash_sections(c, vcrit_sections);
    if (strcmp(stage, "calibrate") == 0)
        return case_hash_sections(c, case_is(c, "calibrate", "method", "vcrit") ? calibrate_vcrit_sections
                                                                                : calibrate_sections);
    if (strcmp(stage, "sweep") == 0) { /* the spray's keys and [sweep]: follows spray_sections as it grows */
        static const char *const sweep_only[] = {"sweep", NULL};
        /* with a file key swept, also the contents of the files its values name (sweep_stage.c) */
        return sweep_stage_hash(c, case_hash_sections(c, spray_sections) * 1099511628211ULL ^
                                       case_hash_sections(c, sweep_only));
    }
    return case_hash(c);
}

int stage_has_section(const char *stage, const char *section)
{
    if (strcmp(stage, "spray") != 0)
        return 0;
    for (int k = 0; spray_sections[k]; k++)
        if (strcmp(spray_sections[k], section) == 0)
            return 1;
    return 0;
}

/* Whether the root attribute case_hash of the open file is one this case's `stage` writes (the impact stage's of
 * either kind: from [impact] or from couple.h5's seeds, since `spraycoat render` reads both). */
static int made_by_stage(const struct stage_context *ctx, const char *stage, const char *stored)
{
    char wanted[32];
    snprintf(wanted, sizeof wanted, "%016llx", (unsigned long long)stage_hash(ctx, stage));
    if (strcmp(stored, wanted) == 0)
        return 1;
    if (strcmp(stage, "impact") != 0)
        return 0;
    const char *const *other = ctx->impact_from_seeds ? impact_sections : pipeline_impact_sections;
    snprintf(wanted, sizeof wanted, "%016llx", (unsigned long long)case_hash_sections(ctx->c, other));
    return strcmp(stored, wanted) == 0;
}

/* 1 the first time `path` is asked about in this process (of the few inputs a command reads), then 0. */
static int first_warning_of(const char *path)
{
    static char warned[8][4096];
    static int count;
    for (int k = 0; k < count; k++)
        if (strcmp(warned[k], path) == 0)
            return 0;
    if (count < 8)
        snprintf(warned[count++], sizeof warned[0], "%s", path);
    return 1;
}

int run_dir_made_by_case(const struct stage_context *ctx, const char *stage, const char *path)
{
    hid_t file;
    if (h5_open_read(path, &file) != SC_OK) {
        sc_error_clear();
        return -1;
    }
    char stored[64] = "";
    int status = h5_attr_read_string(file, "case_hash", stored, sizeof stored);
    H5Fclose(file);
    sc_error_clear();
    return status != SC_OK ? -1 : made_by_stage(ctx, stage, stored);
}

int run_dir_check_input(const struct stage_context *ctx, const char *stage, const char *reader, int required)
{
    const char *run_dir = ctx->run_dir;
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.h5", run_dir, stage);
    if (access(path, F_OK) != 0) {
        if (!required)
            return SC_OK;
        SC_FAIL(SC_EIO,
                "%s: the stage's input %s is missing; run the %s stage first (`spraycoat %s` or `spraycoat "
                "run`)",
                reader, path, stage, stage);
    }
    hid_t file;
    SC_TRY(h5_open_read(path, &file));
    char stored[64] = "", sources[64];
    int status = h5_attr_read_string(file, "case_hash", stored, sizeof stored);
    int same_sources = h5_same_sources(file, sources, sizeof sources);
    H5Fclose(file);
    if (status != SC_OK) {
        char reason[1024];
        snprintf(reason, sizeof reason, "%s", sc_error_message());
        SC_FAIL(SC_EIO, "%s: %s is not an output of spraycoat (%s); rerun the %s stage", reader, path, reason, stage);
    }
    if (!made_by_stage(ctx, stage, stored)) {
        char wanted[32];
        snprintf(wanted, sizeof wanted, "%016llx", (unsigned long long)stage_hash(ctx, stage));
        SC_FAIL(SC_EIO,
                "%s: %s was made by another case (case hash %s, this case's %s stage writes %s): rerun the "
                "%s stage (`spraycoat %s` or `spraycoat run`)",
                reader, path, stored, stage, wanted, stage, stage);
    }
    /* this case's results all the same, and a long stage's: warned, not refused (`spraycoat run` computes them
     * again first); once per file, though the command checks its inputs before it starts and each stage again */
    if (!same_sources && first_warning_of(path))
        log_warn("%s: %s was made by another build of spraycoat (sources %s, this build's %s): what follows from it "
                 "mixes two programs' results; run the %s stage again to have this build's",
                 reader, path, sources, spraycoat_sources_id(), stage);
    return SC_OK;
}
