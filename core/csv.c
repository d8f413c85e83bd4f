/* Input files: regular files only, and CSV tables (see core/csv.h). */
#include "core/csv.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/config.h"
#include "core/error.h"

/* Value texts in messages are cut to this many characters. */
#define SHOWN 60

static const char *file_kind(mode_t mode)
{
    if (S_ISDIR(mode))
        return "a folder";
    if (S_ISFIFO(mode))
        return "a FIFO (named pipe)";
    if (S_ISCHR(mode))
        return "a character device";
    if (S_ISBLK(mode))
        return "a block device";
    if (S_ISSOCK(mode))
        return "a socket";
    return "not a regular file";
}

int csv_input_fopen(const char *path, FILE **out, char *why, size_t size)
{
    *out = NULL;
    /* O_NONBLOCK: opening a FIFO without a writer would wait for one */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        int saved = errno;
        snprintf(why, size, "cannot open %s: %s", path, strerror(saved));
        return saved ? saved : EIO;
    }
    struct stat info;
    if (fstat(fd, &info) != 0) {
        int saved = errno;
        close(fd);
        snprintf(why, size, "cannot open %s: %s", path, strerror(saved));
        return saved ? saved : EIO;
    }
    if (!S_ISREG(info.st_mode)) {
        close(fd);
        snprintf(why, size, "%s is %s; an input file must be a regular file", path, file_kind(info.st_mode));
        return -1;
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags >= 0)
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    FILE *file = fdopen(fd, "rb");
    if (!file) {
        int saved = errno;
        close(fd);
        snprintf(why, size, "cannot open %s: %s", path, strerror(saved));
        return saved ? saved : EIO;
    }
    *out = file;
    return 0;
}

/* ---- CSV ------------------------------------------------------------------------------------------------ */

struct reader {
    const char *path;
    const struct csv_column *columns;
    int column_count;
    int flags;
    char *message;
    size_t size;
    long line;
    int *field_column; /* header field k holds column field_column[k] (-1: ignored) */
    int header_count;  /* fields of the header */
    int field_count;
    char **fields;
    int fields_capacity;
};

static int fail(struct reader *r, int status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int fail(struct reader *r, int status, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    vsnprintf(r->message, r->size, fmt, args);
    va_end(args);
    return status;
}

static bool is_blank(char c)
{
    return c == ' ' || c == '\t';
}

/* Split `line` in place at commas; blanks around each field dropped.  Returns SC_OK or SC_EIO (memory). */
static int split(struct reader *r, char *line)
{
    r->field_count = 0;
    for (char *cursor = line;;) {
        if (r->field_count == r->fields_capacity) {
            int grown = r->fields_capacity ? 2 * r->fields_capacity : 16;
            char **more = realloc(r->fields, (size_t)grown * sizeof *more);
            if (!more)
                return fail(r, SC_EIO, "%s:%ld: out of memory", r->path, r->line);
            r->fields = more;
            r->fields_capacity = grown;
        }
        char *comma = strchr(cursor, ',');
        if (comma)
            *comma = '\0';
        while (is_blank(*cursor))
            cursor++;
        char *end = cursor + strlen(cursor);
        while (end > cursor && is_blank(end[-1]))
            *--end = '\0';
        r->fields[r->field_count++] = cursor;
        if (!comma)
            return SC_OK;
        cursor = comma + 1;
    }
}

static void list_columns(const struct reader *r, char *out, size_t size)
{
    out[0] = '\0';
    for (int k = 0; k < r->column_count; k++) {
        size_t used = strlen(out);
        snprintf(out + used, size - used, "%s%s", k ? "," : "", r->columns[k].name);
    }
}

static int read_header(struct reader *r)
{
    char names[512];
    list_columns(r, names, sizeof names);
    r->field_column = malloc((size_t)r->field_count * sizeof *r->field_column);
    if (!r->field_column)
        return fail(r, SC_EIO, "%s:%ld: out of memory", r->path, r->line);
    int seen[64] = {0};
    for (int k = 0; k < r->field_count; k++) {
        int column = -1;
        for (int c = 0; c < r->column_count; c++)
            if (strcmp(r->fields[k], r->columns[c].name) == 0)
                column = c;
        if (column < 0 && (r->flags & CSV_OTHER_COLUMNS)) {
            r->field_column[k] = -1; /* ignored */
            continue;
        }
        if (column < 0)
            return fail(r, SC_EINPUT,
                        "%s:%ld:%d: unknown column '%.*s' in the header; allowed: the columns %s, each "
                        "once",
                        r->path, r->line, k + 1, SHOWN, r->fields[k], names);
        if (seen[column])
            return fail(r, SC_EINPUT,
                        "%s:%ld:%d: duplicate column '%s' in the header (first in column %d); allowed: "
                        "the columns %s, each once",
                        r->path, r->line, k + 1, r->fields[k], seen[column], names);
        seen[column] = k + 1;
        r->field_column[k] = column;
    }
    for (int c = 0; c < r->column_count; c++)
        if (!seen[c])
            return fail(r, SC_EINPUT, "%s:%ld: the header has no column '%s'; required: the columns %s", r->path,
                        r->line, r->columns[c].name, names);
    return SC_OK;
}

static void describe_range(const struct csv_column *column, char *out, size_t size)
{
    snprintf(out, size, "%s %g and <= %g%s%s", column->min_exclusive ? ">" : ">=", column->min, column->max,
             column->unit && *column->unit ? " " : "", column->unit ? column->unit : "");
}

static int parse_number(struct reader *r, int k, const struct csv_column *column, double *value)
{
    const char *text = r->fields[k];
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    char allowed[128];
    describe_range(column, allowed, sizeof allowed);
    if (end == text || *end != '\0')
        return fail(r, SC_EINPUT, "%s:%ld:%d: %s = '%.*s': not a number; allowed: %s", r->path, r->line, k + 1,
                    column->name, SHOWN, text, allowed);
    /* overflow gives HUGE_VAL; an underflow (to 0 or a subnormal) is a rounding and meets the range check */
    if (!isfinite(v) || (errno == ERANGE && fabs(v) > 1.0))
        return fail(r, SC_EINPUT, "%s:%ld:%d: %s = %.*s: not a finite number; allowed: %s", r->path, r->line, k + 1,
                    column->name, SHOWN, text, allowed);
    bool low_ok = column->min_exclusive ? v > column->min : v >= column->min;
    if (!low_ok || !(v <= column->max))
        return fail(r, SC_EINPUT, "%s:%ld:%d: %s = %.*s: out of range; allowed: %s", r->path, r->line, k + 1,
                    column->name, SHOWN, text, allowed);
    *value = v;
    return SC_OK;
}

static int parse_word(struct reader *r, int k, const struct csv_column *column, double *value)
{
    const char *text = r->fields[k];
    size_t length = strlen(text);
    int index = 0;
    for (const char *start = column->words; start; index++) {
        const char *bar = strchr(start, '|');
        size_t word_length = bar ? (size_t)(bar - start) : strlen(start);
        if (word_length == length && strncmp(start, text, length) == 0) {
            *value = index;
            return SC_OK;
        }
        start = bar ? bar + 1 : NULL;
    }
    return fail(r, SC_EINPUT, "%s:%ld:%d: %s = '%.*s': not one of the words; allowed: %s", r->path, r->line, k + 1,
                column->name, SHOWN, text, column->words);
}

static int parse_name(struct reader *r, int k, const struct csv_column *column, char **name)
{
    const char *text = r->fields[k];
    if (!case_valid_name(text))
        return fail(r, SC_EINPUT,
                    "%s:%ld:%d: %s = '%.*s': not a valid name; allowed: " CASE_NAME_ALLOWED
                    " (as in the section [material.NAME])",
                    r->path, r->line, k + 1, column->name, SHOWN, text);
    *name = strdup(text);
    if (!*name)
        return fail(r, SC_EIO, "%s:%ld: out of memory", r->path, r->line);
    return SC_OK;
}

static int grow_table(struct reader *r, struct csv_table *t, size_t *capacity, bool has_names)
{
    if (t->rows < *capacity)
        return SC_OK;
    size_t grown = *capacity ? 2 * *capacity : 256;
    size_t cells = grown * (size_t)t->columns;
    double *numbers = realloc(t->numbers, cells * sizeof *numbers);
    if (numbers)
        t->numbers = numbers;
    long *lines = realloc(t->lines, grown * sizeof *lines);
    if (lines)
        t->lines = lines;
    char **names = NULL;
    if (has_names) {
        names = realloc(t->names, cells * sizeof *names);
        if (names)
            t->names = names;
    }
    if (!numbers || !lines || (has_names && !names))
        return fail(r, SC_EIO, "%s:%ld: out of memory", r->path, r->line);
    *capacity = grown;
    return SC_OK;
}

static int read_row(struct reader *r, struct csv_table *t, size_t *capacity)
{
    if (r->field_count != r->header_count) {
        char names[512];
        list_columns(r, names, sizeof names);
        return fail(r, SC_EINPUT, "%s:%ld: %d fields, the header has %d (%s)", r->path, r->line, r->field_count,
                    r->header_count, r->header_count == r->column_count ? names : "with others");
    }
    bool has_names = false;
    for (int c = 0; c < r->column_count; c++)
        has_names |= r->columns[c].kind == CSV_NAME;
    SC_TRY(grow_table(r, t, capacity, has_names));
    double *numbers = t->numbers + t->rows * (size_t)t->columns;
    char **names = has_names ? t->names + t->rows * (size_t)t->columns : NULL;
    for (int c = 0; names && c < t->columns; c++)
        names[c] = NULL;
    t->lines[t->rows] = r->line;
    t->rows++; /* counted now, so that csv_free frees the names of a row that fails half-way */
    for (int k = 0; k < r->field_count; k++) {
        int c = r->field_column[k];
        if (c < 0)
            continue;
        const struct csv_column *column = &r->columns[c];
        numbers[c] = NAN;
        switch (column->kind) {
        case CSV_NUMBER:
            SC_TRY(parse_number(r, k, column, &numbers[c]));
            break;
        case CSV_WORD:
            SC_TRY(parse_word(r, k, column, &numbers[c]));
            break;
        case CSV_NAME:
            SC_TRY(parse_name(r, k, column, &names[c]));
            break;
        }
    }
    return SC_OK;
}

/* One line of any length without its line end; NULL at the end of the file or on an error (status set). */
static char *next_line(struct reader *r, FILE *file, char **buffer, size_t *capacity, int *status)
{
    errno = 0;
    ssize_t length = getline(buffer, capacity, file);
    if (length < 0) {
        if (ferror(file))
            *status = fail(r, SC_EIO, "cannot read %s: %s", r->path, strerror(errno ? errno : EIO));
        return NULL;
    }
    r->line++;
    char *line = *buffer;
    if ((size_t)length != strlen(line)) {
        *status =
            fail(r, SC_EINPUT, "%s:%ld:%zu: NUL byte; a CSV file must be text", r->path, r->line, strlen(line) + 1);
        return NULL;
    }
    if (r->line == 1 && length >= 3 && memcmp(line, "\xef\xbb\xbf", 3) == 0)
        line += 3; /* a UTF-8 byte order mark */
    size_t end = strcspn(line, "\r\n");
    if (line[end] == '\r' && line[end + 1] != '\n' && line[end + 1] != '\0') {
        /* lines ended by CR alone (classic Mac OS) read as one line: the header, and no data */
        *status = fail(r, SC_EINPUT,
                       "%s:%ld:%zu: a carriage return inside a line (lines ended by CR alone?); allowed: lines ended "
                       "by LF or CRLF",
                       r->path, r->line, end + 1);
        return NULL;
    }
    line[end] = '\0';
    return line;
}

static bool skipped(const char *line)
{
    while (is_blank(*line))
        line++;
    return *line == '\0' || *line == '#';
}

int csv_read(const char *path, const struct csv_column *columns, int column_count, int flags, struct csv_table *out,
             char *message, size_t size)
{
    *out = (struct csv_table){.columns = column_count};
    if (column_count < 1 || column_count > 64)
        return sc_error_set(SC_EIO, __FILE__, __LINE__, "csv_read: %d columns (1 to 64 supported)", column_count);
    FILE *file;
    int opened = csv_input_fopen(path, &file, message, size);
    if (opened != 0)
        return opened < 0 ? SC_EINPUT : SC_EIO;
    struct reader r = {.path = path,
                       .columns = columns,
                       .column_count = column_count,
                       .flags = flags,
                       .message = message,
                       .size = size};
    char *buffer = NULL;
    size_t buffer_size = 0, capacity = 0;
    bool header = false;
    int status = SC_OK;
    for (char *line; status == SC_OK && (line = next_line(&r, file, &buffer, &buffer_size, &status));) {
        if (skipped(line))
            continue;
        status = split(&r, line);
        if (status != SC_OK)
            break;
        if (!header) {
            status = read_header(&r);
            r.header_count = r.field_count;
            header = true;
        } else {
            status = read_row(&r, out, &capacity);
        }
    }
    free(buffer);
    free(r.fields);
    free(r.field_column);
    fclose(file);
    if (status == SC_OK && !header)
        status = fail(&r, SC_EINPUT, "%s: empty file (a header line is required)", path);
    if (status == SC_OK && out->rows == 0)
        status = fail(&r, SC_EINPUT, "%s: no data rows (only a header)", path);
    if (status != SC_OK)
        csv_free(out);
    return status;
}

void csv_free(struct csv_table *t)
{
    if (t->names)
        for (size_t i = 0; i < t->rows * (size_t)t->columns; i++)
            free(t->names[i]);
    free(t->names);
    free(t->numbers);
    free(t->lines);
    int columns = t->columns;
    *t = (struct csv_table){.columns = columns};
}

int csv_header_has(const char *path, const char *name)
{
    char message[512];
    FILE *file;
    if (csv_input_fopen(path, &file, message, sizeof message) != 0)
        return 0;
    struct reader r = {.path = path, .message = message, .size = sizeof message};
    char *buffer = NULL;
    size_t buffer_size = 0;
    int status = SC_OK, found = 0;
    for (char *line; (line = next_line(&r, file, &buffer, &buffer_size, &status));) {
        if (skipped(line))
            continue;
        if (split(&r, line) == SC_OK)
            for (int k = 0; k < r.field_count; k++)
                found |= strcmp(r.fields[k], name) == 0;
        break;
    }
    free(buffer);
    free(r.fields);
    fclose(file);
    return found;
}
