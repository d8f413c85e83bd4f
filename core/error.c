#include "core/error.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static _Thread_local char error_message[2048];
static _Thread_local char error_traceback[2048];

int sc_error_set(int status, const char *file, int line, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    vsnprintf(error_message, sizeof error_message, fmt, args);
    va_end(args);
    snprintf(error_traceback, sizeof error_traceback, "  at %s:%d", file, line);
    return status;
}

void sc_error_trace(const char *file, int line)
{
    size_t used = strlen(error_traceback);
    if (used + 1 < sizeof error_traceback)
        snprintf(error_traceback + used, sizeof error_traceback - used, "\n  at %s:%d", file, line);
}

const char *sc_error_message(void)
{
    return error_message;
}
const char *sc_error_traceback(void)
{
    return error_traceback;
}

void sc_error_clear(void)
{
    error_message[0] = '\0';
    error_traceback[0] = '\0';
}

const char *sc_strerror(int errnum)
{
    switch (errnum) {
    case ENOSPC:
        return "no space left on device";
    case EFBIG:
        return "file size limit exceeded (File too large)";
    case EDQUOT:
        return "disk quota exceeded";
    default:
        return strerror(errnum);
    }
}

int sc_out_of_memory(const char *file, int line, size_t bytes, const char *what)
{
    return sc_error_set(SC_EIO, file, line, "out of memory: cannot allocate %zu bytes for %s", bytes, what);
}

_Noreturn void sc_out_of_memory_exit(const char *file, int line, size_t bytes, const char *what)
{
    fprintf(stderr, "spraycoat: out of memory: cannot allocate %zu bytes for %s\n  at %s:%d\n", bytes, what, file,
            line);
    fflush(stderr);
    _Exit(SC_EIO);
}

int sc_calloc_at(const char *file, int line, void *out_pointer, size_t count, size_t size, const char *what)
{
    *(void **)out_pointer = NULL;
    /* a count * size beyond size_t is no allocation at all (and not handed to calloc, which sanitizers abort on) */
    if (size && count > (size_t)-1 / size)
        return sc_out_of_memory(file, line, (size_t)-1, what);
    void *allocated = calloc(count ? count : 1, size ? size : 1);
    *(void **)out_pointer = allocated;
    if (!allocated)
        return sc_out_of_memory(file, line, count * size, what);
    return SC_OK;
}
