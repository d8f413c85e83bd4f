/* Logging with levels and an elapsed-time prefix, and a progress reporter.
 *
 * Messages go to stderr as "[  12.3 s] info: ...".  The progress reporter draws a bar with rate and ETA
 * when stderr is a terminal and writes a plain log line every `interval` seconds otherwise. */
#ifndef SPRAYCOAT_CORE_LOG_H
#define SPRAYCOAT_CORE_LOG_H

#include <stdint.h>

enum log_level { LOG_QUIET = 0, LOG_ERROR = 1, LOG_WARN = 2, LOG_INFO = 3, LOG_DEBUG = 4 };

void log_set_level(enum log_level level);
enum log_level log_get_level(void);
/* Seconds since the program started (monotonic clock). */
double log_elapsed(void);
/* Who writes (e.g. "[rank 3]" under MPI), shown after the time of every line; NULL or "" for none. */
void log_set_origin(const char *origin);
void log_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_info(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void log_debug(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

struct progress {
    const char *label;   /* e.g. "spray" */
    const char *unit;    /* what is counted, e.g. "steps" */
    int64_t total;       /* 0 if unknown */
    int64_t start_count; /* count at begin (a resumed run starts part way) */
    double start_time;   /* log_elapsed() at begin */
    double last_report;  /* log_elapsed() of the last output */
    double interval;     /* seconds between plain log lines when not on a terminal */
    int on_terminal;
};

void log_progress_begin(struct progress *p, const char *label, const char *unit, int64_t start_count, int64_t total);
/* Report that `count` units are done; cheap when nothing needs printing.  `extra` is appended
 * (e.g. "in flight 1234, deposited 56") and may be NULL. */
void log_progress_update(struct progress *p, int64_t count, const char *extra);
void log_progress_end(struct progress *p, int64_t count);
/* The closing line of work cut short (an interruption or a failure): "stopped", never "done". */
void log_progress_stop(struct progress *p, int64_t count);

#endif
