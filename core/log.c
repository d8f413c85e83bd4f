/* Logging with an elapsed-time prefix, and the progress reporter (see core/log.h).
 *
 * Each message is formatted into one buffer and written with one call under the stderr lock, so that lines from
 * several threads do not interleave.  While a progress bar is drawn on the terminal its line has no newline:
 * the next log message erases it first, and the bar comes back at the next update. */
#include "core/log.h"

#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

/* Redraws of the terminal bar per second, at most. */
#define BAR_PERIOD 0.2
/* Seconds between plain progress lines when progress.interval is 0. */
#define DEFAULT_INTERVAL 10.0
#define BAR_CELLS        24
#define LINE_SIZE        4096

static enum log_level current_level = LOG_INFO;
static double clock_origin = -1.0;
static int bar_on_screen;

static double monotonic_seconds(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

/* Start the clock when the program starts, not at the first message. */
__attribute__((constructor)) static void start_clock(void)
{
    if (clock_origin < 0)
        clock_origin = monotonic_seconds();
}

double log_elapsed(void)
{
    start_clock();
    return monotonic_seconds() - clock_origin;
}

void log_set_level(enum log_level level)
{
    current_level = level < LOG_QUIET ? LOG_QUIET : level > LOG_DEBUG ? LOG_DEBUG : level;
}

enum log_level log_get_level(void)
{
    return current_level;
}

static const char *level_name(enum log_level level)
{
    switch (level) {
    case LOG_ERROR:
        return "error";
    case LOG_WARN:
        return "warning";
    case LOG_INFO:
        return "info";
    case LOG_DEBUG:
        return "debug";
    default:
        return "log";
    }
}

/* " [rank N]" on the lines of MPI ranks other than 0; empty otherwise. */
static char log_origin[32] = "";

void log_set_origin(const char *origin)
{
    snprintf(log_origin, sizeof log_origin, "%s%s", origin && *origin ? " " : "", origin ? origin : "");
}

/* Write finished text to stderr, erasing a bar drawn there first. */
static void write_stderr(const char *text, int leaves_bar)
{
    flockfile(stderr);
    if (bar_on_screen)
        fputs("\r\033[K", stderr);
    fputs(text, stderr);
    fflush(stderr);
    bar_on_screen = leaves_bar;
    funlockfile(stderr);
}

static void log_message(enum log_level level, const char *fmt, va_list args)
{
    if (level > current_level || level == LOG_QUIET)
        return;
    char line[LINE_SIZE];
    int prefix = snprintf(line, sizeof line, "[%8.1f s]%s %s: ", log_elapsed(), log_origin, level_name(level));
    vsnprintf(line + prefix, sizeof line - (size_t)prefix, fmt, args);
    size_t length = strlen(line);
    if (length + 1 >= sizeof line)
        length = sizeof line - 2; /* truncated: keep room for the newline */
    if (line[length - 1] != '\n')
        line[length++] = '\n';
    line[length] = '\0';
    write_stderr(line, 0);
}

#define DEFINE_LOG_FUNCTION(name, level)                                                                               \
    void name(const char *fmt, ...)                                                                                    \
    {                                                                                                                  \
        va_list args;                                                                                                  \
        va_start(args, fmt);                                                                                           \
        log_message(level, fmt, args);                                                                                 \
        va_end(args);                                                                                                  \
    }

DEFINE_LOG_FUNCTION(log_error, LOG_ERROR)
DEFINE_LOG_FUNCTION(log_warn, LOG_WARN)
DEFINE_LOG_FUNCTION(log_info, LOG_INFO)
DEFINE_LOG_FUNCTION(log_debug, LOG_DEBUG)

/* ---- progress ---------------------------------------------------------------------------------------------- */

/* "950", "12.3k", "4.56M": rates span many decades. */
static void format_rate(double rate, char *out, size_t size)
{
    static const char *const suffix[] = {"", "k", "M", "G", "T"};
    int power = 0;
    while (rate >= 999.5 && power < 4) {
        rate /= 1000.0;
        power++;
    }
    int decimals = rate >= 99.95 ? 0 : rate >= 9.995 ? 1 : 2;
    snprintf(out, size, "%.*f%s", decimals, rate, suffix[power]);
}

/* "4.2s", "37s", "12m05s", "3h07m"; "?" when unknown. */
static void format_duration(double seconds, char *out, size_t size)
{
    if (!isfinite(seconds) || seconds < 0 || seconds > 1e9)
        snprintf(out, size, "?");
    else if (seconds < 10)
        snprintf(out, size, "%.1fs", seconds);
    else if (seconds < 60)
        snprintf(out, size, "%.0fs", seconds);
    else if (seconds < 3600)
        snprintf(out, size, "%dm%02ds", (int)(seconds / 60), (int)fmod(seconds, 60));
    else
        snprintf(out, size, "%dh%02dm", (int)(seconds / 3600), (int)fmod(seconds / 60, 60));
}

/* Rate since begin, in units per second (0 before any time has passed). */
static double progress_rate(const struct progress *p, int64_t count, double now)
{
    double elapsed = now - p->start_time;
    return elapsed > 0 ? (double)(count - p->start_count) / elapsed : 0.0;
}

/* "45.2% 1234/5000 steps, 123 steps/s, ETA 1m23s, extra"; without a total "1234 steps, 123 steps/s, extra". */
static void describe_progress(const struct progress *p, int64_t count, double now, const char *extra, char *out,
                              size_t size)
{
    double rate = progress_rate(p, count, now);
    char rate_text[32], eta_text[32];
    format_rate(rate, rate_text, sizeof rate_text);
    if (p->total > 0) {
        double eta = rate > 0 ? (double)(p->total - count) / rate : NAN;
        format_duration(eta, eta_text, sizeof eta_text);
        double percent = 100.0 * (double)count / (double)p->total;
        snprintf(out, size, "%.1f%% %" PRId64 "/%" PRId64 " %s, %s %s/s, ETA %s", percent, count, p->total, p->unit,
                 rate_text, p->unit, eta_text);
    } else {
        snprintf(out, size, "%" PRId64 " %s, %s %s/s", count, p->unit, rate_text, p->unit);
    }
    if (extra && *extra) {
        size_t used = strlen(out);
        snprintf(out + used, size - used, ", %s", extra);
    }
}

static int terminal_columns(void)
{
    struct winsize size;
    if (ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 20)
        return size.ws_col;
    return 80;
}

static void draw_bar(const struct progress *p, int64_t count, const char *facts)
{
    char bar[BAR_CELLS + 4] = ""; /* "[###...] " */
    if (p->total > 0) {
        double fraction = (double)count / (double)p->total;
        int filled = fraction <= 0 ? 0 : fraction >= 1 ? BAR_CELLS : (int)(fraction * BAR_CELLS);
        bar[0] = '[';
        memset(bar + 1, '#', (size_t)filled);
        memset(bar + 1 + filled, '.', (size_t)(BAR_CELLS - filled));
        memcpy(bar + 1 + BAR_CELLS, "] ", 3);
    }
    char line[LINE_SIZE];
    int length = snprintf(line, sizeof line, "%s %s%s", p->label, bar, facts);
    /* A line wider than the terminal wraps, and '\r' would then redraw only its last row. */
    int columns = terminal_columns() - 1;
    if (length > columns)
        line[columns] = '\0';
    write_stderr(line, 1);
}

void log_progress_begin(struct progress *p, const char *label, const char *unit, int64_t start_count, int64_t total)
{
    double now = log_elapsed();
    *p = (struct progress){
        .label = label ? label : "",
        .unit = unit ? unit : "",
        .total = total > 0 ? total : 0,
        .start_count = start_count,
        .start_time = now,
        .last_report = now,
        .interval = 0.0,
        .on_terminal = isatty(STDERR_FILENO),
    };
}

void log_progress_update(struct progress *p, int64_t count, const char *extra)
{
    if (current_level < LOG_INFO)
        return;
    double now = log_elapsed();
    double period = p->on_terminal ? BAR_PERIOD : p->interval > 0 ? p->interval : DEFAULT_INTERVAL;
    if (now - p->last_report < period)
        return;
    p->last_report = now;
    char facts[LINE_SIZE / 2];
    describe_progress(p, count, now, extra, facts, sizeof facts);
    if (p->on_terminal)
        draw_bar(p, count, facts);
    else
        log_info("%s: %s", p->label, facts);
}

/* The closing line: "done" when the work is complete, "stopped" when it was cut short. */
static void progress_close(struct progress *p, int64_t count, const char *how)
{
    double now = log_elapsed();
    char total_text[32], rate_text[32];
    format_duration(now - p->start_time, total_text, sizeof total_text);
    format_rate(progress_rate(p, count, now), rate_text, sizeof rate_text);
    p->last_report = now;
    log_info("%s: %s, %" PRId64 " %s in %s (%s %s/s)", p->label, how, count - p->start_count, p->unit, total_text,
             rate_text, p->unit);
}

void log_progress_end(struct progress *p, int64_t count)
{
    progress_close(p, count, "done");
}

void log_progress_stop(struct progress *p, int64_t count)
{
    progress_close(p, count, "stopped");
}
