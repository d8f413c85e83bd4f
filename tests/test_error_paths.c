/* The one error path (core/error.h): a write that fails midway leaves no HDF5 object open but the file, every
 * failure carries its traceback frames, and out of memory is one error with status SC_EIO (exit 3); the couple stage
 * refuses a spray.h5 of an older version without /impacts/temperature, saying so; a blow-up names the body as
 * impact.h5 numbers it. */
/* A white-box test: includes the module-private header dem/dem_impl.h (only tests may; tests/test_symbols.sh). */
#include "app/app.h"
#include "core/error.h"
#include "core/h5io.h"
#include "dem/dem.h"
#include "dem/dem_impl.h"
#include "mpm/mpm.h"
#include "tests/case_fixture.h"
#include "tests/check.h"

#include <stdint.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

static hid_t make_file(char path[64])
{
    snprintf(path, 64, "/tmp/spraycoat_errors_XXXXXX");
    int fd = mkstemp(path);
    if (fd < 0) {
        perror("mkstemp");
        exit(2);
    }
    close(fd);
    return H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
}

static void drop_file(hid_t file, const char *path)
{
    H5Fclose(file);
    unlink(path);
}

/* A spray solver with three particles (their states) and no particle ids: the write of /particles/id fails after the
 * group /particles was created (h5io refuses a dataset without data). */
static void broken_solver(struct dem_solver *s)
{
    static uint8_t states[3];
    memset(s, 0, sizeof *s);
    s->p.count = 3;
    s->p.state = states;
}

static void test_spray_output_failure_closes_handles(void)
{
    char path[64];
    hid_t file = make_file(path);
    CHECK(file >= 0, "cannot create %s", path);
    struct dem_solver s;
    broken_solver(&s);
    sc_error_clear();
    int status = dem_write_output(&s, file);
    CHECK(status == SC_EIO, "dem_write_output returned %d, expected SC_EIO", status);
    ssize_t open_objects = H5Fget_obj_count(file, H5F_OBJ_ALL);
    CHECK(open_objects == 1, "after the failed write %zd objects are open in the file, expected 1 (the file)",
          open_objects);
    CHECK(strstr(sc_error_traceback(), "dem/output.c") != NULL, "no dem/output.c frame in the traceback:\n%s",
          sc_error_traceback());
    drop_file(file, path);
}

static void test_spray_checkpoint_failure_closes_handles(void)
{
    char path[64];
    hid_t file = make_file(path);
    struct dem_solver s;
    broken_solver(&s);
    int status = dem_checkpoint_write(&s, file);
    CHECK(status == SC_EIO, "dem_checkpoint_write returned %d, expected SC_EIO", status);
    ssize_t open_objects = H5Fget_obj_count(file, H5F_OBJ_ALL);
    CHECK(open_objects == 1, "after the failed checkpoint %zd objects are open in the file, expected 1", open_objects);
    drop_file(file, path);
}

/* A checkpoint whose /particles group lacks the positions: the read fails inside the group. */
static void test_spray_checkpoint_read_failure_closes_handles(void)
{
    char path[64];
    hid_t file = make_file(path);
    hid_t g;
    CHECK(h5_create_group(file, "particles", &g) == SC_OK, "cannot create /particles");
    int64_t ids[2] = {0, 1}, states[2] = {0, 0};
    hsize_t dims[1] = {2};
    CHECK(h5_write_int64s(g, "id", 1, dims, ids, "", 0) == SC_OK, "cannot write id");
    CHECK(h5_write_int64s(g, "state", 1, dims, states, "", 0) == SC_OK, "cannot write state");
    H5Gclose(g);
    int64_t counters[5] = {0};
    hsize_t cdims[1] = {5};
    CHECK(h5_write_int64s(file, "counters", 1, cdims, counters, "", 0) == SC_OK, "cannot write counters");
    struct dem_solver *s = calloc(1, sizeof *s);
    CHECK(h5_write_bytes(file, "stats", sizeof s->stats, &s->stats, 0) == SC_OK, "cannot write stats");
    int status = dem_checkpoint_read(s, file);
    CHECK(status == SC_EIO, "dem_checkpoint_read returned %d, expected SC_EIO", status);
    ssize_t open_objects = H5Fget_obj_count(file, H5F_OBJ_ALL);
    CHECK(open_objects == 1, "after the failed read %zd objects are open in the file, expected 1", open_objects);
    CHECK(strstr(sc_error_traceback(), "dem/output.c") != NULL, "no dem/output.c frame in the traceback:\n%s",
          sc_error_traceback());
    dem_particles_free(&s->p);
    free(s);
    drop_file(file, path);
}

/* Out of memory: one message, status SC_EIO (exit 3), never SC_ESIM (1 is a failed simulation). */
static void test_out_of_memory_is_one_error(void)
{
    sc_error_clear();
    void *huge = (void *)1;
    int status = sc_calloc(&huge, SIZE_MAX / 2, 4, "the test's huge array");
    CHECK(status == SC_EIO, "sc_calloc of an impossible size returned %d, expected SC_EIO (%d)", status, SC_EIO);
    CHECK(huge == NULL, "sc_calloc left a pointer after failing");
    CHECK(strstr(sc_error_message(), "out of memory: cannot allocate") != NULL, "message: %s", sc_error_message());
    CHECK(strstr(sc_error_message(), "the test's huge array") != NULL, "message: %s", sc_error_message());
    CHECK(strstr(sc_error_traceback(), "test_error_paths.c") != NULL, "traceback: %s", sc_error_traceback());
    double *small = NULL;
    CHECK(sc_calloc(&small, 4, sizeof *small, "four doubles") == SC_OK && small && small[3] == 0.0,
          "sc_calloc of four doubles failed");
    free(small);
}

/* SC_DIE_OOM, where no status can be returned: the same message on stderr and exit status 3, not an abort. */
static void test_die_out_of_memory_exits_3(void)
{
    int pipe_ends[2];
    CHECK(pipe(pipe_ends) == 0, "pipe");
    fflush(stdout);
    pid_t child = fork();
    if (child == 0) {
        dup2(pipe_ends[1], 2);
        SC_DIE_OOM(1234, "the child's buffer");
    }
    close(pipe_ends[1]);
    char text[512] = "";
    ssize_t got = read(pipe_ends[0], text, sizeof text - 1);
    text[got > 0 ? got : 0] = '\0';
    close(pipe_ends[0]);
    int wait_status = 0;
    waitpid(child, &wait_status, 0);
    CHECK(WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == SC_EIO,
          "the child ended with wait status %#x, "
          "expected exit status 3",
          wait_status);
    CHECK(strstr(text, "out of memory: cannot allocate 1234 bytes for the child's buffer") != NULL, "stderr: %s", text);
}

/* How often `needle` occurs in `text`. */
static int occurrences(const char *text, const char *needle)
{
    int count = 0;
    for (const char *at = strstr(text, needle); at; at = strstr(at + 1, needle))
        count++;
    return count;
}

/* An empty case ("[run]") written to a fixture folder (its name into dir) and loaded; NULL (checked) on failure. */
static struct case_file *empty_case_in(char dir[64])
{
    CHECK(case_fixture_write(dir, "[run]\n", NULL, NULL, NULL, NULL) == 0, "cannot write the case");
    struct case_file *c = NULL;
    CHECK(case_fixture_load(dir, spraycoat_registry, &c) == SC_OK, "cannot load the case: %s", sc_error_message());
    return c;
}

/* An app-level failure (issue 24): couple.h5 of this case whose /seeds lacks the centres /seeds/x.  The impact
 * stage's read of the seeds fails; afterwards no HDF5 object of any file is open (the file and /seeds closed on
 * the failure path), nothing of the bodies is kept, and the traceback has the frame of couple_stage_read_bodies
 * as well as read_body_columns' (a status chain passed the failure up without its frame). */
static void test_failed_seed_read_closes_couple_h5(void)
{
    char dir[64];
    struct case_file *c = empty_case_in(dir);
    if (!c)
        return;
    struct stage_context ctx = {.c = c, .run_dir = dir, .impact_from_seeds = 1};
    char path[128];
    snprintf(path, sizeof path, "%s/couple.h5", dir);
    hid_t file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    CHECK(file >= 0, "cannot create %s", path);
    CHECK(h5_write_root_attributes(file, "spraycoat-couple", 1, "couple", stage_hash(&ctx, "couple")) == SC_OK,
          "cannot write the root attributes");
    hid_t g;
    CHECK(h5_create_group(file, "seeds", &g) == SC_OK, "cannot create /seeds");
    int64_t run[2] = {0, 0};
    double d[2] = {1e-5, 2e-5};
    hsize_t dims[1] = {2};
    CHECK(h5_write_int64s(g, "run", 1, dims, run, "", 0) == SC_OK, "cannot write /seeds/run");
    CHECK(h5_write_doubles(g, "d", 1, dims, d, "m", 0) == SC_OK, "cannot write /seeds/d");
    H5Gclose(g);
    H5Fclose(file);
    CHECK(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0, "objects open before the read");

    sc_error_clear();
    struct couple_bodies bodies;
    int status = couple_stage_read_bodies(&ctx, &bodies);
    CHECK(status == SC_EIO, "couple_stage_read_bodies returned %d, expected SC_EIO: %s", status, sc_error_message());
    ssize_t open_objects = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL);
    CHECK(open_objects == 0, "after the failed read %zd HDF5 objects are open, expected none", open_objects);
    CHECK(bodies.d == NULL && bodies.center == NULL && bodies.first == NULL && bodies.count == 0,
          "the failed read kept bodies");
    CHECK(strstr(sc_error_message(), "x") != NULL, "message: %s", sc_error_message());
    CHECK(occurrences(sc_error_traceback(), "app/couple_stage.c") >= 2,
          "expected the frames of read_body_columns and couple_stage_read_bodies in the traceback:\n%s",
          sc_error_traceback());
    case_free(c);
    unlink(path);
    case_fixture_remove(dir);
}

/* spray.h5 of this case with one row of /impacts, its temperature column only when `temperature`, and no /handoff. */
static int write_spray_impacts(const char *path, const struct stage_context *ctx, int temperature)
{
    hid_t file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (file < 0)
        SC_FAIL(SC_EIO, "cannot create %s", path);
    hid_t g = H5I_INVALID_HID;
    int status;
    SC_CHECK(status, h5_write_root_attributes(file, DEM_FORMAT, 3, "spray", stage_hash(ctx, "spray")), done);
    SC_CHECK(status, h5_create_group(file, "impacts", &g), done);
    int64_t id[1] = {0};
    double t[1] = {1e-4}, x[3] = {0, 0, 0.03}, v[3] = {0, 0, 700}, d[1] = {1e-5}, m[1] = {1.4e-12}, T[1] = {300};
    hsize_t n[1] = {1}, n3[2] = {1, 3};
    SC_CHECK(status, h5_write_doubles(g, "t", 1, n, t, "s", 0), done);
    SC_CHECK(status, h5_write_int64s(g, "particle_id", 1, n, id, "", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "x", 2, n3, x, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "v_in", 2, n3, v, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "d", 1, n, d, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "m", 1, n, m, "kg", 0), done);
    SC_CHECK(status, h5_write_int64s(g, "partner", 1, n, id, "", 0), done);
    if (temperature)
        SC_CHECK(status, h5_write_doubles(g, "temperature", 1, n, T, "K", 0), done);
done:
    if (g >= 0)
        H5Gclose(g);
    H5Fclose(file);
    return status;
}

/* The couple stage on a spray.h5 of an older spraycoat (spray format 3: no /impacts/temperature, which the seeds'
 * temperature is taken from, with no fallback): exit status 3 (SC_EIO) with a message that says so and that the
 * spray stage must run again, not HDF5's "cannot open dataset"; with the column, the stage reads /impacts and stops
 * at the next thing this file lacks, /handoff. */
static void test_couple_refuses_spray_without_temperature(void)
{
    char dir[64];
    struct case_file *c = empty_case_in(dir);
    if (!c)
        return;
    const struct stage_context ctx = {.c = c, .run_dir = dir};
    char path[128];
    snprintf(path, sizeof path, "%s/spray.h5", dir);
    CHECK(write_spray_impacts(path, &ctx, 0) == SC_OK, "cannot write %s: %s", path, sc_error_message());
    sc_error_clear();
    int status = couple_stage_run(&ctx);
    const char *message = sc_error_message();
    CHECK(status == SC_EIO, "couple_stage_run returned %d, expected SC_EIO: %s", status, message);
    CHECK(strstr(message, "spray.h5 has no /impacts/temperature") && strstr(message, "older version of spraycoat") &&
              strstr(message, "run the spray stage again"),
          "message: %s", message);
    CHECK(write_spray_impacts(path, &ctx, 1) == SC_OK, "cannot write %s: %s", path, sc_error_message());
    sc_error_clear();
    status = couple_stage_run(&ctx);
    CHECK(status == SC_EIO && strstr(sc_error_message(), "no /handoff group"),
          "with /impacts/temperature: status %d, %s", status, sc_error_message());
    CHECK(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0, "HDF5 objects left open");
    case_free(c);
    case_fixture_remove(dir);
}

/* SC_CHECK: records a frame and jumps to the cleanup label; SC_OK falls through. */
static int failing(void)
{
    SC_FAIL(SC_EINPUT, "bad input");
}

static int with_cleanup(int fail, int *cleaned)
{
    int status;
    SC_CHECK(status, SC_OK, done);
    if (fail)
        SC_CHECK(status, failing(), done);
    status = 42;
done:
    *cleaned = 1;
    return status;
}

static void test_check_records_frame_and_cleans_up(void)
{
    int cleaned = 0;
    sc_error_clear();
    CHECK(with_cleanup(0, &cleaned) == 42 && cleaned, "the success path did not run to its end");
    cleaned = 0;
    CHECK(with_cleanup(1, &cleaned) == SC_EINPUT && cleaned, "the failure did not reach the cleanup label");
    const char *trace = sc_error_traceback();
    const char *first = strstr(trace, "test_error_paths.c");
    CHECK(first && strstr(first + 1, "test_error_paths.c"), "expected two frames (SC_FAIL, SC_CHECK):\n%s", trace);
}

/* A blow-up names the material point's body as impact.h5 and the log number them, from 0 with the substrate body 0
 * (README): the demo's particle (body 1) at 30 km/s with cfl = 1 fails its stress update within 40 steps, and the
 * message said "body 2" (the body index plus one). */
static void test_blow_up_names_the_body_from_0(void)
{
    char dir[64];
    CHECK(case_fixture_write(dir,
                             "[run]\nthreads = 1\n[impact]\ndiameter = 10e-6\nvelocity = 30000\ngrid = 2e-6\n"
                             "spacing = 1e-6\nsubstrate = cylinder\nsubstrate_diameter = 24e-6\n"
                             "substrate_height = 8e-6\nt_end = 5e-9\ncfl = 1\n[material.aluminium]\n",
                             NULL, NULL, NULL, NULL) == 0,
          "cannot write the case");
    struct case_file *c = NULL;
    CHECK(case_fixture_load(dir, spraycoat_registry, &c) == SC_OK, "cannot load the case: %s", sc_error_message());
    struct mpm_config cfg;
    CHECK(c && mpm_config_load(c, &cfg) == SC_OK, "cannot read [impact]: %s", sc_error_message());
    struct mpm_solver *s = NULL;
    CHECK(mpm_create(&cfg, &s) == SC_OK, "cannot set up the impact: %s", sc_error_message());
    CHECK(mpm_body_count(s) == 2, "%d bodies, expected the substrate and the particle", mpm_body_count(s));
    sc_error_clear();
    int status = SC_OK;
    for (int step = 0; step < 1000 && status == SC_OK && !mpm_finished(s); step++)
        status = mpm_step(s);
    const char *message = sc_error_message();
    CHECK(status == SC_ESIM, "the impact at 30 km/s with cfl = 1 returned %d, expected SC_ESIM: %s", status, message);
    CHECK(strstr(message, "of body 1:") != NULL, "expected the particle, body 1, in: %s", message);
    mpm_destroy(s);
    mpm_config_free(&cfg);
    case_free(c);
    case_fixture_remove(dir);
}

int main(void)
{
    H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
    RUN(test_spray_output_failure_closes_handles);
    RUN(test_spray_checkpoint_failure_closes_handles);
    RUN(test_spray_checkpoint_read_failure_closes_handles);
    RUN(test_out_of_memory_is_one_error);
    RUN(test_die_out_of_memory_exits_3);
    RUN(test_check_records_frame_and_cleans_up);
    RUN(test_failed_seed_read_closes_couple_h5);
    RUN(test_couple_refuses_spray_without_temperature);
    RUN(test_blow_up_names_the_body_from_0);
    return check_finish();
}
