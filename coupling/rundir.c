/* The run directory, the registry of case keys, and signal handling shared by the stages. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/run_keys.h"
#include "coupling/stages.h"
#include "dem/dem.h"

const struct cfg_key *const spraycoat_registry[] = {run_case_keys, dem_case_keys, NULL};

static volatile sig_atomic_t received_signal;

static void on_signal(int number) { received_signal = number; }

void stages_install_signal_handlers(void)
{
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, NULL);
    sigaction(SIGTERM, &action, NULL);
}

int stages_interrupt_status(void)
{
    if (received_signal == SIGINT)
        return SC_EINT;
    if (received_signal == SIGTERM)
        return SC_ETERM;
    return SC_OK;
}

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
static int lock_run_dir(const char *run_dir)
{
    int fd = open(run_dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        SC_FAIL(SC_EIO, "cannot open run directory %s: %s", run_dir, strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int saved = errno;
        close(fd);
        if (saved == EWOULDBLOCK)
            SC_FAIL(SC_EIO, "run directory %s is in use by another spraycoat process; wait for it or use another "
                    "directory", run_dir);
        SC_FAIL(SC_EIO, "cannot lock run directory %s: %s", run_dir, strerror(saved));
    }
    return SC_OK; /* the descriptor stays open, and the lock held, until the process exits */
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
