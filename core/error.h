/* Error status and traceback for spraycoat.
 *
 * Library code returns an int status (0 = success, else one of enum sc_status) and wraps each call in
 * SC_TRY, which records file and line and passes the status up (PETSc's PetscCall pattern).  Only main()
 * prints the message and exits with the status. */
#ifndef SPRAYCOAT_CORE_ERROR_H
#define SPRAYCOAT_CORE_ERROR_H

enum sc_status {
    SC_OK = 0,
    SC_ESIM = 1,      /* the simulation failed: NaN, blow-up */
    SC_EINPUT = 2,    /* bad command line or case file */
    SC_EIO = 3,       /* I/O error */
    SC_EINT = 130,    /* interrupted by SIGINT after a checkpoint */
    SC_ETERM = 143,   /* interrupted by SIGTERM after a checkpoint */
};

/* Record the message of a new error (replacing any earlier one) and return status. */
int sc_error_set(int status, const char *file, int line, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
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

#define SC_FAIL(status, ...) return sc_error_set((status), __FILE__, __LINE__, __VA_ARGS__)

#define SC_TRY(expr)                                                                                  \
    do {                                                                                              \
        int sc_try_status_ = (expr);                                                                  \
        if (sc_try_status_ != SC_OK) {                                                                \
            sc_error_trace(__FILE__, __LINE__);                                                       \
            return sc_try_status_;                                                                    \
        }                                                                                             \
    } while (0)

#endif
