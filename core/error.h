/* Error status and traceback for spraycoat.
 *
 * Library code returns an int status (0 = success, else one of enum sc_status) and wraps each call in
 * SC_TRY, which records file and line and passes the status up (PETSc's PetscCall pattern).  Only main()
 * prints the message and exits with the status.
 *
 * One error path.  A function that owns nothing to release wraps each call in SC_TRY and fails with SC_FAIL.  A
 * function that holds memory or HDF5 handles keeps one `int status` and one cleanup label at its end, which
 * releases everything on every path: SC_CHECK(status, call, label) records the traceback frame and jumps there on
 * failure, SC_FAIL_AT(status, label, code, ...) sets a new error and jumps there.  No `if (status == SC_OK)`
 * chains: a failure jumps at once, and every failure carries its file and line.
 *
 * Out of memory, one way: SC_FAIL_OOM(bytes, what) (or sc_calloc, which allocates and reports) records
 * "out of memory: cannot allocate N bytes for WHAT" with status SC_EIO.  Exit status 3, not 1: like a full disk,
 * running out of memory is the machine's resources failing, and 1 is kept for a simulation that failed (NaN,
 * blow-up), which rerunning on a bigger machine would not fix.  Code that cannot return a status (a void
 * function inside a parallel loop) calls SC_DIE_OOM(bytes, what), which prints the same message and traceback
 * frame the way main() would and ends the process with the same exit status 3. */
#ifndef SPRAYCOAT_CORE_ERROR_H
#define SPRAYCOAT_CORE_ERROR_H

#include <stddef.h>

enum sc_status {
    SC_OK = 0,
    SC_ESIM = 1,    /* the simulation failed: NaN, blow-up */
    SC_EINPUT = 2,  /* bad command line or case file */
    SC_EIO = 3,     /* I/O error */
    SC_EINT = 130,  /* interrupted by SIGINT after a checkpoint */
    SC_ETERM = 143, /* interrupted by SIGTERM after a checkpoint */
};

/* Record the message of a new error (replacing any earlier one) and return status. */
int sc_error_set(int status, const char *file, int line, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
/* Append one traceback frame to the current error; returns nothing. */
void sc_error_trace(const char *file, int line);
/* The message of the last error ("" if none). */
const char *sc_error_message(void);
/* The traceback of the last error, frames separated by newlines ("" if none). */
const char *sc_error_traceback(void);
void sc_error_clear(void);
/* strerror(errnum), but in words a user can act on where the system's are terse: ENOSPC "no space left on
 * device", EFBIG "file size limit exceeded (File too large)", EDQUOT "disk quota exceeded". */
const char *sc_strerror(int errnum);

/* Record "out of memory: cannot allocate BYTES bytes for WHAT" at file:line; returns SC_EIO (see above). */
int sc_out_of_memory(const char *file, int line, size_t bytes, const char *what);
/* The same message, printed to stderr with its frame as main() prints an error; ends the process with SC_EIO. For
 * code that cannot return a status. */
_Noreturn void sc_out_of_memory_exit(const char *file, int line, size_t bytes, const char *what);
/* *(void **)out_pointer = calloc(count, size) (at least one byte); SC_OK, or SC_EIO recorded by sc_out_of_memory
 * with *out_pointer NULL.  Call it as sc_calloc(&pointer, count, size, what), which passes the caller's file and
 * line. */
int sc_calloc_at(const char *file, int line, void *out_pointer, size_t count, size_t size, const char *what);
#define sc_calloc(out_pointer, count, size, what)                                                                      \
    sc_calloc_at(__FILE__, __LINE__, (out_pointer), (count), (size), (what))

#define SC_FAIL(status, ...) return sc_error_set((status), __FILE__, __LINE__, __VA_ARGS__)

#define SC_TRY(expr)                                                                                                   \
    do {                                                                                                               \
        int sc_try_status_ = (expr);                                                                                   \
        if (sc_try_status_ != SC_OK) {                                                                                 \
            sc_error_trace(__FILE__, __LINE__);                                                                        \
            return sc_try_status_;                                                                                     \
        }                                                                                                              \
    } while (0)

/* return the out-of-memory error for `bytes` bytes of `what` (a string) */
#define SC_FAIL_OOM(bytes, what) return sc_out_of_memory(__FILE__, __LINE__, (bytes), (what))
/* print the out-of-memory error and exit with SC_EIO, where no status can be returned */
#define SC_DIE_OOM(bytes, what) sc_out_of_memory_exit(__FILE__, __LINE__, (bytes), (what))

/* status_var = expr; on failure record a traceback frame and goto label (the function's one cleanup path). */
#define SC_CHECK(status_var, expr, label)                                                                              \
    do {                                                                                                               \
        (status_var) = (expr);                                                                                         \
        if ((status_var) != SC_OK) {                                                                                   \
            sc_error_trace(__FILE__, __LINE__);                                                                        \
            goto label;                                                                                                \
        }                                                                                                              \
    } while (0)

/* status_var = a new error (sc_error_set with the arguments) and goto label. */
#define SC_FAIL_AT(status_var, label, code, ...)                                                                       \
    do {                                                                                                               \
        (status_var) = sc_error_set((code), __FILE__, __LINE__, __VA_ARGS__);                                          \
        goto label;                                                                                                    \
    } while (0)

/* status_var = the out-of-memory error for `bytes` bytes of `what`, and goto label. */
#define SC_FAIL_OOM_AT(status_var, label, bytes, what)                                                                 \
    do {                                                                                                               \
        (status_var) = sc_out_of_memory(__FILE__, __LINE__, (bytes), (what));                                          \
        goto label;                                                                                                    \
    } while (0)

#endif
