/* Case files: an INI file read with libinih and checked against a registry of keys (see core/config.h).
 *
 * A case holds one slot per registered key: for an ordinary section one slot per key of the registry, for a
 * pattern section ("material.*") one set of slots per [material.NAME] present.  Slots stay sorted in registry
 * order (instances of a pattern by name), so that printing, hashing and writing do not depend on the order,
 * comments or spacing of the file.
 *
 * libinih reads the file through our own line reader, because
 *   - this build of inih does not pass line numbers to the handler, so the reader counts them;
 *   - inih's line buffer is INI_MAX_LINE bytes and a longer line would be split silently: the reader refuses it;
 *   - an indented line would be taken as the continuation of the previous value: the reader drops the indent,
 *     so such a line is either a key of its own or a syntax error;
 *   - inih calls the handler only for keys, so a misspelt section without keys would pass unnoticed: the reader
 *     checks section headers itself. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath(), also when built with _POSIX_C_SOURCE alone */
#endif
#include "core/config.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <ini.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/atomic.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/units.h"

/* A range bound of this magnitude or more means "no bound" (registries write 1e300 or HUGE_VAL). */
#define OPEN_BOUND 1e300
/* Far above any real case file; a bigger file is most likely not a case file at all. */
#define MAX_CASE_BYTES ((size_t)16 << 20)
/* Longest line, without its newline, that inih reads in one piece: its buffer also holds "\n\0". */
#define MAX_LINE_CHARS (INI_MAX_LINE - 2)
/* Same size as the message buffer in core/error.c. */
#define MESSAGE_SIZE 2048
/* Errors listed from one file; beyond, they are counted (a binary file read as a case would list thousands). */
#define MAX_LISTED_ERRORS 100
/* Key and section lists in messages. */
#define LIST_SIZE 1024

enum value_source { SOURCE_UNSET, SOURCE_DEFAULT, SOURCE_FILE, SOURCE_OVERRIDE };

struct parsed_value {
    double real;      /* CFG_REAL, and CFG_INT as a double */
    long integer;     /* CFG_INT */
    bool is_word;     /* CFG_REAL given as one of its words */
    bool has_unit;    /* CFG_REAL written with a unit ("30 mm"): `real` is the value converted to the key's unit */
    bool unit_factor; /* refused: the unit holds a numeric factor ("800 m/s 2"), which UDUNITS-2 multiplies by */
};

struct slot {
    const struct cfg_key *spec;
    int section_rank; /* registry index of the first key of the section: orders the sections */
    int key_rank;     /* registry index of the key */
    char *section;    /* the actual section, e.g. "material.copper" */
    char *text;       /* the value as written; NULL when unset */
    enum value_source source;
    int line;     /* line in the file, for SOURCE_FILE */
    char *origin; /* who set it, for SOURCE_OVERRIDE ("command line") */
    struct parsed_value value;
};

/* The registry as one flat array, with each key's section rank. */
struct registry_view {
    const struct cfg_key **keys;
    int *section_rank;
    int count;
};

struct case_file {
    char *path;
    char *folder; /* folder of path including its trailing '/', "" for the current folder */
    struct registry_view registry;
    struct slot *slots;
    size_t slot_count, slot_capacity;
    /* Slots by (section, key): an open-addressing hash table of slot positions + 1 (0: empty), at most half full,
     * so that a case with many [material.NAME] sections loads in linear time (a linear search per key was
     * quadratic: 1,600 sections took seconds).  Slots appended for a new [material.NAME] are sorted into place
     * once, when the file is read (or the override set), not per section. */
    size_t *index;
    size_t index_size; /* a power of two */
    bool unsorted;
};

/* ---- small utilities ---------------------------------------------------------------------------------- */

static void config_bug(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void config_bug(const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    fputs("spraycoat: internal error (case keys): ", stderr);
    vfprintf(stderr, fmt, args);
    va_end(args);
    fputc('\n', stderr);
    abort();
}

/* Allocation failure cannot be reported through a case-file error; give up loudly. */
static void *must_realloc(void *pointer, size_t size) __attribute__((returns_nonnull));
static void *must_realloc(void *pointer, size_t size)
{
    void *grown = realloc(pointer, size ? size : 1);
    if (!grown)
        SC_DIE_OOM(size ? size : 1, "the case file");
    return grown;
}

static char *must_strndup(const char *text, size_t length)
{
    char *copy = must_realloc(NULL, length + 1);
    memcpy(copy, text, length);
    copy[length] = '\0';
    return copy;
}

static char *must_strdup(const char *text)
{
    return must_strndup(text, strlen(text));
}

static const char *or_empty(const char *text)
{
    return text ? text : "";
}

static bool is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

static char *trimmed_copy(const char *text)
{
    while (is_blank(*text))
        text++;
    size_t length = strlen(text);
    while (length > 0 && is_blank(text[length - 1]))
        length--;
    return must_strndup(text, length);
}

/* Is `word` one of the '|'-separated words of `list`? */
static bool word_in_list(const char *list, const char *word)
{
    size_t length = strlen(word);
    for (const char *start = list; start;) {
        const char *bar = strchr(start, '|');
        size_t word_length = bar ? (size_t)(bar - start) : strlen(start);
        if (word_length == length && strncmp(start, word, length) == 0)
            return true;
        start = bar ? bar + 1 : NULL;
    }
    return false;
}

/* Shortest text of a number that reads back to it (15 digits at most): 1e+13, 2147483647, 0.00016. */
static void format_number(double value, char *out, size_t size)
{
    snprintf(out, size, "%g", value);
    if (strtod(out, NULL) != value)
        snprintf(out, size, "%.15g", value);
}

/* snprintf for messages, where cutting a very long path or value short is fine (and expected by design). */
static void format_message(char *out, size_t size, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void format_message(char *out, size_t size, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    vsnprintf(out, size, fmt, args);
    va_end(args);
}

/* Append to a fixed buffer; text past its end is dropped (messages only). */
static void append_text(char *out, size_t size, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void append_text(char *out, size_t size, const char *fmt, ...)
{
    size_t used = strlen(out);
    if (used + 1 >= size)
        return;
    va_list args;
    va_start(args, fmt);
    vsnprintf(out + used, size - used, fmt, args);
    va_end(args);
}

/* A growing text, for the resolved case. */
struct text_buffer {
    char *data;
    size_t length, capacity;
};

static void buffer_append(struct text_buffer *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void buffer_append(struct text_buffer *b, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    int needed = vsnprintf(NULL, 0, fmt, args);
    va_end(args);
    if (needed < 0)
        config_bug("cannot format text");
    if (b->length + (size_t)needed + 1 > b->capacity) {
        b->capacity = 2 * (b->length + (size_t)needed + 1) + 256;
        b->data = must_realloc(b->data, b->capacity);
    }
    va_start(args, fmt);
    vsnprintf(b->data + b->length, b->capacity - b->length, fmt, args);
    va_end(args);
    b->length += (size_t)needed;
}

/* Levenshtein distance of two short words; long words count as far apart (suggestions only). */
static int edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 63 || lb > 63)
        return INT_MAX;
    int row[64];
    for (size_t j = 0; j <= lb; j++)
        row[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        int diagonal = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int above = row[j];
            int best = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
            if (above + 1 < best)
                best = above + 1;
            if (row[j - 1] + 1 < best)
                best = row[j - 1] + 1;
            row[j] = best;
            diagonal = above;
        }
    }
    return row[lb];
}

/* Close enough to be a typo of `candidate`? */
static bool looks_like_typo(const char *given, const char *candidate)
{
    int distance = edit_distance(given, candidate);
    return distance <= 2 && (size_t)distance < strlen(candidate);
}

/* ---- sections and the registry -------------------------------------------------------------------------- */

/* "material.*" stands for any [material.NAME]. */
static bool is_pattern(const char *section)
{
    size_t length = strlen(section);
    return length >= 2 && strcmp(section + length - 2, ".*") == 0;
}

/* NAME of [material.NAME]: it names HDF5 groups and appears in messages, so keep it plain. */
static bool valid_instance_name(const char *name)
{
    if (!*name)
        return false;
    for (; *name; name++)
        if (!isalnum((unsigned char)*name) && *name != '_' && *name != '-')
            return false;
    return true;
}

int case_valid_name(const char *name)
{
    return name && valid_instance_name(name);
}

static bool section_matches(const char *pattern, const char *name)
{
    if (!is_pattern(pattern))
        return strcmp(pattern, name) == 0;
    size_t prefix = strlen(pattern) - 1; /* "material." */
    return strncmp(pattern, name, prefix) == 0 && valid_instance_name(name + prefix);
}

/* "material.*" is shown to users as "material.NAME". */
static void section_display(const char *pattern, char *out, size_t size)
{
    if (is_pattern(pattern))
        snprintf(out, size, "%.*sNAME", (int)(strlen(pattern) - 1), pattern);
    else
        snprintf(out, size, "%s", pattern);
}

static void check_choices(const struct cfg_key *spec)
{
    if (!spec->choices || !*spec->choices || strstr(spec->choices, "||") || spec->choices[0] == '|' ||
        spec->choices[strlen(spec->choices) - 1] == '|')
        config_bug("[%s] %s: choices \"%s\" must be words separated by '|'", spec->section, spec->key,
                   or_empty(spec->choices));
}

static bool parse_value(const struct cfg_key *spec, const char *text, struct parsed_value *out, char *why, size_t size);

/* Registry mistakes are programming errors: catch them on every load, not when a user hits them. */
static void check_key_spec(const struct cfg_key *spec)
{
    if (!spec->section || !*spec->section)
        config_bug("key \"%s\" has no section", spec->key);
    if (spec->type == CFG_CHOICE || (spec->type == CFG_REAL && spec->choices))
        check_choices(spec);
    if (spec->type == CFG_INT || spec->type == CFG_REAL) {
        if (spec->min == 0 && spec->max == 0)
            config_bug("[%s] %s: range 0 .. 0 (forgotten?); use -HUGE_VAL or HUGE_VAL for an open end", spec->section,
                       spec->key);
        if (!(spec->min <= spec->max))
            config_bug("[%s] %s: min %g > max %g", spec->section, spec->key, spec->min, spec->max);
    }
    if (spec->default_value) {
        struct parsed_value value;
        char why[256];
        if (!parse_value(spec, spec->default_value, &value, why, sizeof why))
            config_bug("[%s] %s: default \"%s\" is invalid: %s", spec->section, spec->key, spec->default_value, why);
    }
}

static void registry_open(struct registry_view *view, const struct cfg_key *const *registry)
{
    int count = 0;
    for (int t = 0; registry && registry[t]; t++)
        for (const struct cfg_key *spec = registry[t]; spec->key; spec++)
            count++;
    view->keys = must_realloc(NULL, (size_t)count * sizeof *view->keys);
    view->section_rank = must_realloc(NULL, (size_t)count * sizeof *view->section_rank);
    view->count = 0;
    for (int t = 0; registry && registry[t]; t++)
        for (const struct cfg_key *spec = registry[t]; spec->key; spec++)
            view->keys[view->count++] = spec;
    for (int i = 0; i < count; i++) {
        check_key_spec(view->keys[i]);
        int first = 0;
        while (strcmp(view->keys[first]->section, view->keys[i]->section) != 0)
            first++;
        view->section_rank[i] = first;
        for (int j = first; j < i; j++)
            if (strcmp(view->keys[j]->section, view->keys[i]->section) == 0 &&
                strcmp(view->keys[j]->key, view->keys[i]->key) == 0)
                config_bug("[%s] %s is registered twice", view->keys[i]->section, view->keys[i]->key);
    }
}

static void registry_close(struct registry_view *view)
{
    free(view->keys);
    free(view->section_rank);
}

/* Rank of the registry section that `name` belongs to, -1 if none. */
static int find_section_rank(const struct registry_view *view, const char *name)
{
    for (int i = 0; i < view->count; i++)
        if (view->section_rank[i] == i && section_matches(view->keys[i]->section, name))
            return i;
    return -1;
}

/* Registry index of `key` in the section of rank `rank`, -1 if none. */
static int find_key_index(const struct registry_view *view, int rank, const char *key)
{
    for (int i = rank; i < view->count; i++)
        if (view->section_rank[i] == rank && strcmp(view->keys[i]->key, key) == 0)
            return i;
    return -1;
}

/* The registered key or NULL. */
static const struct cfg_key *find_spec(const struct registry_view *view, const char *section, const char *key)
{
    int rank = find_section_rank(view, section);
    int index = rank < 0 ? -1 : find_key_index(view, rank, key);
    return index < 0 ? NULL : view->keys[index];
}

static void list_sections(const struct registry_view *view, char *out, size_t size)
{
    out[0] = '\0';
    for (int i = 0; i < view->count; i++) {
        if (view->section_rank[i] != i)
            continue;
        char shown[128];
        section_display(view->keys[i]->section, shown, sizeof shown);
        append_text(out, size, "%s%s", out[0] ? ", " : "", shown);
    }
    if (!out[0])
        snprintf(out, size, "(none)");
}

static void list_keys(const struct registry_view *view, int rank, char *out, size_t size)
{
    out[0] = '\0';
    for (int i = rank; i < view->count; i++)
        if (view->section_rank[i] == rank)
            append_text(out, size, "%s%s", out[0] ? ", " : "", view->keys[i]->key);
}

/* " (did you mean [spray]?)" for a section close to a registered one, else "". */
static void suggest_section(const struct registry_view *view, const char *name, char *out, size_t size)
{
    out[0] = '\0';
    for (int i = 0; i < view->count; i++) {
        const char *section = view->keys[i]->section;
        if (view->section_rank[i] == i && !is_pattern(section) && looks_like_typo(name, section)) {
            snprintf(out, size, " (did you mean [%s]?)", section);
            return;
        }
    }
}

static void suggest_key(const struct registry_view *view, int rank, const char *key, char *out, size_t size)
{
    out[0] = '\0';
    for (int i = rank; i < view->count; i++) {
        if (view->section_rank[i] == rank && looks_like_typo(key, view->keys[i]->key)) {
            snprintf(out, size, " (did you mean \"%s\"?)", view->keys[i]->key);
            return;
        }
    }
}

/* "[material.]": explain what NAME may be rather than calling the section unknown. */
static bool is_bad_instance_name(const struct registry_view *view, const char *name, char *pattern_shown, size_t size)
{
    for (int i = 0; i < view->count; i++) {
        const char *section = view->keys[i]->section;
        if (view->section_rank[i] == i && is_pattern(section) && strncmp(section, name, strlen(section) - 1) == 0) {
            section_display(section, pattern_shown, size);
            return true;
        }
    }
    return false;
}

static void format_unknown_section(const struct registry_view *view, const char *where, const char *name, char *out,
                                   size_t size)
{
    char sections[LIST_SIZE], suggestion[160], pattern[128];
    list_sections(view, sections, sizeof sections);
    if (is_bad_instance_name(view, name, pattern, sizeof pattern)) {
        format_message(out, size, "%s: [%s]: NAME of [%s] must be " CASE_NAME_ALLOWED "; allowed sections: %s", where,
                       name, pattern, sections);
        return;
    }
    suggest_section(view, name, suggestion, sizeof suggestion);
    format_message(out, size, "%s: [%s]: unknown section%s; allowed sections: %s", where, name, suggestion, sections);
}

static void format_unknown_key(const struct registry_view *view, const char *where, const char *section, int rank,
                               const char *key, const char *value, char *out, size_t size)
{
    char keys[LIST_SIZE], suggestion[160];
    list_keys(view, rank, keys, sizeof keys);
    suggest_key(view, rank, key, suggestion, sizeof suggestion);
    format_message(out, size, "%s: [%s] %s = %s: unknown key%s; allowed keys in [%s]: %s", where, section, key, value,
                   suggestion, section, keys);
}

/* ---- values: parsing and describing what is allowed ---------------------------------------------------- */

static bool within_range(const struct cfg_key *spec, double value)
{
    bool low_ok =
        spec->min <= -OPEN_BOUND || ((spec->flags & CFG_MIN_EXCLUSIVE) ? value > spec->min : value >= spec->min);
    bool high_ok = spec->max >= OPEN_BOUND || value <= spec->max;
    return low_ok && high_ok;
}

/* "> 0 m", "0 .. 1 -", ">= 1", "any integer". */
static void describe_range(const struct cfg_key *spec, char *out, size_t size)
{
    char low[64], high[64];
    if (spec->type == CFG_INT) { /* integers in full: 1000000000, not 1e+09 */
        snprintf(low, sizeof low, "%.0f", spec->min);
        snprintf(high, sizeof high, "%.0f", spec->max);
    } else {
        format_number(spec->min, low, sizeof low);
        format_number(spec->max, high, sizeof high);
    }
    bool has_low = spec->min > -OPEN_BOUND, has_high = spec->max < OPEN_BOUND;
    const char *low_op = (spec->flags & CFG_MIN_EXCLUSIVE) ? ">" : ">=";
    if (has_low && has_high && !(spec->flags & CFG_MIN_EXCLUSIVE))
        snprintf(out, size, "%s .. %s", low, high);
    else if (has_low && has_high)
        snprintf(out, size, "> %s and <= %s", low, high);
    else if (has_low)
        snprintf(out, size, "%s %s", low_op, low);
    else if (has_high)
        snprintf(out, size, "<= %s", high);
    else
        snprintf(out, size, "any %s", spec->type == CFG_INT ? "integer" : "finite number");
    if (spec->unit && *spec->unit)
        append_text(out, size, " %s", spec->unit);
}

static void describe_allowed(const struct cfg_key *spec, char *out, size_t size)
{
    out[0] = '\0';
    switch (spec->type) {
    case CFG_REAL:
        if (spec->choices)
            snprintf(out, size, "%s or ", spec->choices);
        /* fall through */
    case CFG_INT: {
        char range[256];
        describe_range(spec, range, sizeof range);
        append_text(out, size, "%s", range);
        return;
    }
    case CFG_CHOICE:
        snprintf(out, size, "%s", spec->choices);
        return;
    case CFG_PATH:
        snprintf(out, size, "a file path (relative to the case file's folder)");
        return;
    case CFG_STRING:
        snprintf(out, size, "any non-empty text");
        return;
    }
}

static const char *type_name(const struct cfg_key *spec)
{
    switch (spec->type) {
    case CFG_INT:
        return "int";
    case CFG_REAL:
        return spec->choices ? "real or word" : "real";
    case CFG_CHOICE:
        return "choice";
    case CFG_PATH:
        return "path";
    case CFG_STRING:
        return "text";
    }
    return "?";
}

/* "1 # note" is a common slip: inih takes only " ;" as the start of an inline comment. */
static const char *comment_hint(const char *text)
{
    return strstr(text, " #") || strstr(text, "\t#") ? " (inline comments start with ';')" : "";
}

/* What follows a number may be a unit ("30 mm", "30mm", "425 degC", "20 µm", "5 %"), not a comment ("1 # note")
 * nor a second number or word list ("1, 2"): a letter, '%', '°' or 'µ' (UTF-8 0xc2 0xb0, 0xc2 0xb5,
 * or the Greek mu 0xce 0xbc), after blanks. */
static bool starts_unit(const char *text)
{
    while (is_blank(*text))
        text++;
    unsigned char c = (unsigned char)*text;
    return isalpha(c) || c == '%' || c == 0xc2 || c == 0xce;
}

static bool parse_int(const struct cfg_key *spec, const char *text, struct parsed_value *out, char *why, size_t size)
{
    char *end;
    errno = 0;
    long value = strtol(text, &end, 10);
    if (end == text || *end != '\0' || is_blank(text[0])) {
        bool unit = end != text && starts_unit(end);
        snprintf(why, size, "not an integer%s%s", unit ? " (a count: write it without a unit)" : "",
                 comment_hint(text));
        return false;
    }
    if (errno == ERANGE || !within_range(spec, (double)value)) {
        snprintf(why, size, "out of range");
        return false;
    }
    out->integer = value;
    out->real = (double)value;
    return true;
}

static bool parse_real(const struct cfg_key *spec, const char *text, struct parsed_value *out, char *why, size_t size)
{
    if (spec->choices && word_in_list(spec->choices, text)) {
        out->is_word = true;
        out->real = NAN;
        return true;
    }
    char *end;
    errno = 0;
    double value = strtod(text, &end);
    if (end == text || is_blank(text[0]) || (*end != '\0' && !starts_unit(end))) {
        snprintf(why, size, "not a number%s%s", spec->choices ? " nor one of the words" : "", comment_hint(text));
        return false;
    }
    /* Overflow gives HUGE_VAL and fails here; underflow to 0 or a subnormal is a rounding and is kept. */
    if (!isfinite(value)) {
        snprintf(why, size, "not a finite number");
        return false;
    }
    if (*end != '\0') {
        const char *unit = end;
        while (is_blank(*unit))
            unit++;
        enum units_status converted = units_to_si(value, unit, spec->unit, &value, why, size);
        if (converted != UNITS_OK) {
            out->unit_factor = converted == UNITS_FACTOR;
            return false;
        }
        out->has_unit = true;
        if (!isfinite(value)) {
            snprintf(why, size, "not a finite number in %s", spec->unit);
            return false;
        }
    }
    if (!within_range(spec, value)) {
        char shown[64];
        format_number(value, shown, sizeof shown);
        if (out->has_unit)
            snprintf(why, size, "out of range (%s %s)", shown, spec->unit);
        else
            snprintf(why, size, "out of range");
        return false;
    }
    out->real = value;
    return true;
}

/* Check `text` against the key's type and range; on failure say what is wrong in `why`. */
static bool parse_value(const struct cfg_key *spec, const char *text, struct parsed_value *out, char *why, size_t size)
{
    *out = (struct parsed_value){0};
    switch (spec->type) {
    case CFG_INT:
        return parse_int(spec, text, out, why, size);
    case CFG_REAL:
        return parse_real(spec, text, out, why, size);
    case CFG_CHOICE:
        if (word_in_list(spec->choices, text))
            return true;
        snprintf(why, size, "not one of the choices%s", comment_hint(text));
        return false;
    case CFG_PATH:
    case CFG_STRING:
        if (*text)
            return true;
        snprintf(why, size, "empty");
        return false;
    }
    snprintf(why, size, "unknown type %d", (int)spec->type);
    return false;
}

/* ---- slots -------------------------------------------------------------------------------------------- */

static int compare_slots(const void *pa, const void *pb)
{
    const struct slot *a = pa, *b = pb;
    if (a->section_rank != b->section_rank)
        return a->section_rank < b->section_rank ? -1 : 1;
    int by_name = strcmp(a->section, b->section);
    if (by_name != 0)
        return by_name;
    return (a->key_rank > b->key_rank) - (a->key_rank < b->key_rank);
}

static size_t slot_hash(const char *section, const char *key)
{
    uint64_t hash = 0xcbf29ce484222325ULL;
    for (const unsigned char *s = (const unsigned char *)section; *s; s++)
        hash = (hash ^ *s) * 0x100000001b3ULL;
    hash = (hash ^ 0xff) * 0x100000001b3ULL; /* separates "ab"+"c" from "a"+"bc" */
    for (const unsigned char *s = (const unsigned char *)key; *s; s++)
        hash = (hash ^ *s) * 0x100000001b3ULL;
    return (size_t)(hash ^ (hash >> 29));
}

static void index_insert(struct case_file *c, size_t position)
{
    const struct slot *slot = &c->slots[position];
    size_t mask = c->index_size - 1;
    size_t at = slot_hash(slot->section, slot->spec->key) & mask;
    while (c->index[at])
        at = (at + 1) & mask;
    c->index[at] = position + 1;
}

/* Rebuild the table for the slots as they are now, growing it to keep it at most half full. */
static void index_rebuild(struct case_file *c)
{
    size_t size = c->index_size ? c->index_size : 256;
    while (size < 2 * c->slot_count + 2)
        size *= 2;
    if (size != c->index_size) {
        free(c->index);
        c->index = must_realloc(NULL, size * sizeof *c->index);
        c->index_size = size;
    }
    memset(c->index, 0, size * sizeof *c->index);
    for (size_t i = 0; i < c->slot_count; i++)
        index_insert(c, i);
}

static void sort_slots(struct case_file *c)
{
    if (c->slot_count > 1)
        qsort(c->slots, c->slot_count, sizeof *c->slots, compare_slots);
    c->unsorted = false;
    index_rebuild(c);
}

static void clear_value(struct slot *slot)
{
    free(slot->text);
    free(slot->origin);
    slot->text = NULL;
    slot->origin = NULL;
    slot->source = SOURCE_UNSET;
    slot->line = 0;
}

/* Store an already checked value. */
static void store_value(struct slot *slot, const char *text, const struct parsed_value *value, enum value_source source,
                        int line, const char *origin)
{
    clear_value(slot);
    slot->text = must_strdup(text);
    slot->origin = origin ? must_strdup(origin) : NULL;
    slot->source = source;
    slot->line = line;
    slot->value = *value;
}

static void apply_default(struct slot *slot)
{
    struct parsed_value value;
    char why[256];
    if (!slot->spec->default_value)
        return;
    if (!parse_value(slot->spec, slot->spec->default_value, &value, why, sizeof why))
        config_bug("[%s] %s: default \"%s\" is invalid: %s", slot->spec->section, slot->spec->key,
                   slot->spec->default_value, why);
    store_value(slot, slot->spec->default_value, &value, SOURCE_DEFAULT, 0, NULL);
}

static void append_slot(struct case_file *c, int key_index, const char *section)
{
    if (c->slot_count == c->slot_capacity) {
        c->slot_capacity = c->slot_capacity ? 2 * c->slot_capacity : 64;
        c->slots = must_realloc(c->slots, c->slot_capacity * sizeof *c->slots);
    }
    struct slot *slot = &c->slots[c->slot_count++];
    *slot = (struct slot){.spec = c->registry.keys[key_index],
                          .section_rank = c->registry.section_rank[key_index],
                          .key_rank = key_index,
                          .section = must_strdup(section)};
    apply_default(slot);
    if (2 * c->slot_count + 2 > c->index_size)
        index_rebuild(c);
    else
        index_insert(c, c->slot_count - 1);
}

static struct slot *find_slot(const struct case_file *c, const char *section, const char *key)
{
    if (!c->index_size)
        return NULL;
    size_t mask = c->index_size - 1;
    for (size_t at = slot_hash(section, key) & mask; c->index[at]; at = (at + 1) & mask) {
        struct slot *slot = &c->slots[c->index[at] - 1];
        if (strcmp(slot->section, section) == 0 && strcmp(slot->spec->key, key) == 0)
            return slot;
    }
    return NULL;
}

/* Every instance of a pattern section has a slot for each key of it, the first one included. */
static bool has_instance(const struct case_file *c, const char *section, int rank)
{
    return find_slot(c, section, c->registry.keys[rank]->key) != NULL;
}

/* Slots for a [material.NAME] seen for the first time, holding the defaults.  Moves the slots; they are sorted
 * into place by finish_slots. */
static void ensure_instance(struct case_file *c, const char *section, int rank)
{
    if (has_instance(c, section, rank))
        return;
    for (int i = rank; i < c->registry.count; i++)
        if (c->registry.section_rank[i] == rank)
            append_slot(c, i, section);
    c->unsorted = true;
}

/* The slots in registry order again after new instances: printing, hashing and writing rely on it. */
static void finish_slots(struct case_file *c)
{
    if (c->unsorted)
        sort_slots(c);
}

/* ---- reading the file ------------------------------------------------------------------------------------ */

struct parse_state {
    struct case_file *c;
    const char *next; /* next unread byte */
    const char *end;
    int line;          /* number of the line inih works on */
    char *section;     /* current section as written; NULL before the first header */
    bool any_section;  /* a [section] header was read */
    bool skip_section; /* the current section is unknown (reported once): its keys are not reported again */
    int error_count;
    struct text_buffer errors; /* every error, one line each, in the order of the file */
};

/* Record an error and go on reading, so that one pass reports every bad line; returns 0, the handler's
 * "failed". */
static int parse_fail(struct parse_state *st, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int parse_fail(struct parse_state *st, const char *fmt, ...)
{
    char message[MESSAGE_SIZE];
    if (++st->error_count > MAX_LISTED_ERRORS)
        return 0;
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof message, fmt, args);
    va_end(args);
    buffer_append(&st->errors, "%s\n", message);
    return 0;
}

/* The end of a section name as inih finds it: ']' or an inline comment (';' after a blank), or the end. */
static const char *section_name_end(const char *s)
{
    bool after_blank = false;
    for (; *s && *s != ']'; s++) {
        if (INI_ALLOW_INLINE_COMMENTS && after_blank && strchr(INI_INLINE_COMMENT_PREFIXES, *s))
            break;
        after_blank = is_blank(*s);
    }
    return s;
}

/* Check a new section against the registry; false (error recorded) when it is unknown. */
static bool enter_section(struct parse_state *st)
{
    char where[PATH_MAX + 32];
    snprintf(where, sizeof where, "%s:%d", st->c->path, st->line);
    int rank = find_section_rank(&st->c->registry, st->section);
    if (rank < 0) {
        char message[MESSAGE_SIZE];
        format_unknown_section(&st->c->registry, where, st->section, message, sizeof message);
        st->skip_section = true;
        return parse_fail(st, "%s", message);
    }
    if (is_pattern(st->c->registry.keys[rank]->section))
        ensure_instance(st->c, st->section, rank);
    return true;
}

/* A "[name]" line (its indent already dropped). */
static bool enter_section_line(struct parse_state *st, const char *line)
{
    const char *close = section_name_end(line + 1);
    if (*close != ']')
        return true; /* inih reports the missing ']' as a syntax error */
    const char *rest = close + 1;
    while (is_blank(*rest))
        rest++;
    /* inih ignores text after ']', so "[spray] dt = 1" would lose dt without a word. */
    if (*rest && *rest != ';' && *rest != '#' && *rest != '\n' && *rest != '\r') {
        int length = (int)strcspn(line, "\r\n");
        st->skip_section = true;
        return parse_fail(st,
                          "%s:%d: syntax error: text after ']' of a section header: got \"%.*s\"; a section "
                          "header stands alone on its line",
                          st->c->path, st->line, length, line);
    }
    free(st->section);
    st->section = must_strndup(line + 1, (size_t)(close - line - 1));
    st->any_section = true;
    st->skip_section = false;
    return enter_section(st);
}

static void format_syntax_error(const char *path, int line, const char *start, const char *end, char *out, size_t size);

/* An empty line in inih's buffer, in place of a line already reported (inih then skips it). */
static char *blank_line(char *buffer)
{
    buffer[0] = '\n';
    buffer[1] = '\0';
    return buffer;
}

/* The first of `chars` in [s, stop) before an inline comment (';' after a blank), as inih finds it; stop if none. */
static const char *find_before_comment(const char *s, const char *stop, const char *chars)
{
    bool after_blank = false;
    for (; s < stop && !strchr(chars, *s); s++) {
        if (INI_ALLOW_INLINE_COMMENTS && after_blank && strchr(INI_INLINE_COMMENT_PREFIXES, *s))
            return stop;
        after_blank = is_blank(*s);
    }
    return s;
}

/* Would inih call the line [start, stop) (blanks trimmed) a syntax error: neither empty, a comment, a
 * "[section]" with its ']' nor "key = value" (or "key: value")? */
static bool is_syntax_error(const char *start, const char *stop)
{
    if (start == stop || strchr(INI_START_COMMENT_PREFIXES, *start))
        return false;
    if (*start == '[')
        return find_before_comment(start + 1, stop, "]") == stop;
    return find_before_comment(start, stop, "=:") == stop;
}

/* inih's reader: hands over one line per call, so that inih's line count is ours. */
static char *next_line(char *buffer, int size, void *stream)
{
    struct parse_state *st = stream;
    if (st->next >= st->end)
        return NULL;
    const char *start = st->next;
    const char *newline = memchr(start, '\n', (size_t)(st->end - start));
    const char *stop = newline ? newline : st->end;
    st->next = newline ? newline + 1 : st->end;
    st->line++;
    while (start < stop && is_blank(*start))
        start++;
    while (stop > start && is_blank(stop[-1]))
        stop--;
    size_t length = (size_t)(stop - start);
    if (size < 3 || length > (size_t)size - 2) {
        parse_fail(st, "%s:%d: syntax error: line too long (%zu characters; at most %d)", st->c->path, st->line, length,
                   size - 2);
        return blank_line(buffer);
    }
    if (is_syntax_error(start, stop)) {
        char message[MESSAGE_SIZE];
        format_syntax_error(st->c->path, st->line, start, stop, message, sizeof message);
        parse_fail(st, "%s", message);
        return blank_line(buffer); /* inih would stop at nothing but report only the first */
    }
    memcpy(buffer, start, length);
    buffer[length] = '\n';
    buffer[length + 1] = '\0';
    if (buffer[0] == '[')
        enter_section_line(st, buffer);
    return buffer;
}

/* Check one value of [section] key; on failure write the standard message (located at `where`) into `message`. */
static bool check_value(const struct cfg_key *spec, const char *section, const char *text, const char *where,
                        struct parsed_value *value, char *message, size_t size)
{
    char why[256], allowed[512];
    if (parse_value(spec, text, value, why, sizeof why))
        return true;
    describe_allowed(spec, allowed, sizeof allowed);
    if (value->unit_factor) /* what the value may be written as, then its range */
        format_message(message, size,
                       "%s: [%s] %s = %s: %s; allowed: a value and a unit without a numeric factor (a power is "
                       "written on its unit: m2, s-1, m^2, 1/s), %s",
                       where, section, spec->key, text, why, allowed);
    else
        format_message(message, size, "%s: [%s] %s = %s: %s; allowed: %s", where, section, spec->key, text, why,
                       allowed);
    return false;
}

/* inih's handler: one "key = value" of the file. */
static int on_key_value(void *user, const char *inih_section, const char *name, const char *value)
{
    (void)inih_section; /* the reader tracks the section: inih truncates long names */
    struct parse_state *st = user;
    struct case_file *c = st->c;
    if (st->skip_section)
        return 1; /* the unknown section was reported; its keys would only repeat it */
    char where[PATH_MAX + 32], sections[LIST_SIZE];
    snprintf(where, sizeof where, "%s:%d", c->path, st->line);
    if (!value)
        return parse_fail(st, "%s: syntax error: \"%s\" has no value", where, name);
    if (!st->section) {
        list_sections(&c->registry, sections, sizeof sections);
        return parse_fail(st, "%s: %s = %s: key before any [section]; allowed sections: %s", where, name, value,
                          sections);
    }
    struct slot *slot = find_slot(c, st->section, name);
    if (!slot) {
        int rank = find_section_rank(&c->registry, st->section);
        char message[MESSAGE_SIZE];
        format_unknown_key(&c->registry, where, st->section, rank, name, value, message, sizeof message);
        return parse_fail(st, "%s", message);
    }
    if (slot->source == SOURCE_FILE)
        return parse_fail(st, "%s: [%s] %s = %s: duplicate key; first given at line %d", where, st->section, name,
                          value, slot->line);
    struct parsed_value parsed;
    char message[MESSAGE_SIZE];
    if (!check_value(slot->spec, st->section, value, where, &parsed, message, sizeof message))
        return parse_fail(st, "%s", message);
    store_value(slot, value, &parsed, SOURCE_FILE, st->line, NULL);
    return 1;
}

static int read_case_text(const char *path, char **text_out, size_t *length_out)
{
    FILE *file;
    char why[PATH_MAX + 128];
    int opened = csv_input_fopen(path, &file, why, sizeof why);
    struct stat info;
    /* a folder stays an I/O error (as a missing file); a FIFO would block and /dev/zero never end: bad input */
    if (opened < 0 && stat(path, &info) == 0 && S_ISDIR(info.st_mode))
        return sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot open case file %s: %s", path, strerror(EISDIR));
    if (opened < 0)
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s (a case file)", why);
    if (opened > 0)
        return sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot open case file %s: %s", path, strerror(opened));
    size_t capacity = 4096, length = 0;
    char *text = must_realloc(NULL, capacity + 1);
    bool too_large = false;
    while (!feof(file) && !ferror(file)) {
        if (length == capacity) {
            too_large = capacity >= MAX_CASE_BYTES;
            if (too_large)
                break;
            capacity *= 2;
            text = must_realloc(text, capacity + 1);
        }
        length += fread(text + length, 1, capacity - length, file);
    }
    int read_errno = ferror(file) ? errno : 0;
    fclose(file);
    text[length] = '\0';
    *text_out = text;
    *length_out = length;
    if (read_errno)
        return sc_error_set(SC_EIO, __FILE__, __LINE__, "cannot read case file %s: %s", path, strerror(read_errno));
    if (too_large)
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: larger than %zu MiB; not a case file", path,
                            MAX_CASE_BYTES >> 20);
    return SC_OK;
}

/* Length of the UTF-8 character at s, 0 if it is not one or is a control character other than tab and CR. */
static size_t text_char_length(const unsigned char *s, size_t left)
{
    unsigned char b = s[0];
    if (b < 0x80)
        return (b >= 0x20 && b != 0x7f) || b == '\t' || b == '\r' || b == '\n' ? 1 : 0;
    size_t n;
    unsigned char low = 0x80, high = 0xbf; /* allowed second byte: excludes overlong forms and surrogates */
    if (b >= 0xc2 && b <= 0xdf) {
        n = 2;
    } else if (b >= 0xe0 && b <= 0xef) {
        n = 3;
        low = b == 0xe0 ? 0xa0 : 0x80;
        high = b == 0xed ? 0x9f : 0xbf;
    } else if (b >= 0xf0 && b <= 0xf4) {
        n = 4;
        low = b == 0xf0 ? 0x90 : 0x80;
        high = b == 0xf4 ? 0x8f : 0xbf;
    } else {
        return 0;
    }
    if (left < n || s[1] < low || s[1] > high)
        return 0;
    for (size_t k = 2; k < n; k++)
        if (s[k] < 0x80 || s[k] > 0xbf)
            return 0;
    return n;
}

static void describe_bad_byte(unsigned char b, char *out, size_t size)
{
    if (b == 0)
        snprintf(out, size, "NUL byte");
    else if (b < 0x20 || b == 0x7f)
        snprintf(out, size, "control character 0x%02x", b);
    else
        snprintf(out, size, "byte 0x%02x that is not UTF-8", b);
}

/* Refuse what cannot be in a text case file before inih sees it: a NUL would cut a line short unnoticed, and
 * control characters or broken UTF-8 would end up in messages and in the copy of the case in every output. */
static int check_text_bytes(const char *path, const char *text, size_t length)
{
    const unsigned char *bytes = (const unsigned char *)text;
    int line = 1;
    size_t line_start = 0;
    for (size_t i = 0; i < length;) {
        size_t n = text_char_length(bytes + i, length - i);
        if (n == 0) {
            char what[64];
            describe_bad_byte(bytes[i], what, sizeof what);
            return sc_error_set(SC_EINPUT, __FILE__, __LINE__,
                                "%s:%d: syntax error: %s at column %zu; a case file must be UTF-8 text", path, line,
                                what, i - line_start + 1);
        }
        if (bytes[i] == '\n') {
            line++;
            line_start = i + 1;
        }
        i += n;
    }
    return SC_OK;
}

/* The message for a line [start, end) that is neither "key = value", "[section]" nor a comment. */
static void format_syntax_error(const char *path, int line, const char *start, const char *end, char *out, size_t size)
{
    while (start < end && is_blank(*start))
        start++;
    size_t shown = 0;
    while (start + shown < end && start[shown] != '\n' && start[shown] != '\r' && shown < 80)
        shown++;
    while (shown > 0 && start + shown < end && ((unsigned char)start[shown] & 0xc0) == 0x80)
        shown--; /* do not cut a UTF-8 character in half */
    const char *what = start < end && *start == '[' ? "section header without ']'"
                                                    : "expected \"key = value\", \"[section]\" or a comment";
    format_message(out, size, "%s:%d: syntax error: %s, got \"%.*s\"", path, line, what, (int)shown, start);
}

/* inih found a syntax error the reader did not (a safety net: is_syntax_error should find them all first). */
static void append_syntax_error(struct parse_state *st, const char *text, size_t length, int line)
{
    const char *start = text, *end = text + length;
    for (int n = 1; n < line && start < end; n++) {
        const char *newline = memchr(start, '\n', (size_t)(end - start));
        start = newline ? newline + 1 : end;
    }
    const char *stop = memchr(start, '\n', (size_t)(end - start));
    char message[MESSAGE_SIZE];
    format_syntax_error(st->c->path, line, start, stop ? stop : end, message, sizeof message);
    parse_fail(st, "%s", message);
}

/* A CR not followed by LF: the file has old Mac line endings (CR only), which a line reader takes for one long
 * line ("line too long" or a bogus syntax error would name the wrong thing). */
static int check_line_endings(const char *path, const char *text, size_t length)
{
    int line = 1;
    for (size_t i = 0; i < length; i++) {
        if (text[i] == '\n')
            line++;
        else if (text[i] == '\r' && i + 1 < length && text[i + 1] != '\n')
            return sc_error_set(SC_EINPUT, __FILE__, __LINE__,
                                "%s:%d: the file uses CR line endings (a carriage return without a line feed, as "
                                "classic Mac OS wrote); save it with LF (Unix) or CRLF (Windows) line endings",
                                path, line);
    }
    return SC_OK;
}

/* Every error of the file: the one error as it is, or "FILE: N errors in the case file:" and the list (cut
 * short by the message buffer; *every_error has them all). */
static int report_errors(const struct case_file *c, struct parse_state *st, char **every_error)
{
    if (st->error_count > MAX_LISTED_ERRORS)
        buffer_append(&st->errors, "%s: %d more errors not listed\n", c->path, st->error_count - MAX_LISTED_ERRORS);
    while (st->errors.length > 0 && st->errors.data[st->errors.length - 1] == '\n')
        st->errors.data[--st->errors.length] = '\0';
    int status;
    if (st->error_count == 1)
        status = sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s", st->errors.data);
    else
        status = sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: %d errors in the case file:\n%s", c->path,
                              st->error_count, st->errors.data);
    if (every_error) {
        *every_error = st->errors.data;
        st->errors.data = NULL;
    }
    return status;
}

static int parse_case_text(struct case_file *c, const char *text, size_t length, char **every_error)
{
    SC_TRY(check_text_bytes(c->path, text, length));
    SC_TRY(check_line_endings(c->path, text, length));
    /* inih skips a UTF-8 byte order mark too, but the reader must not see it as part of a "[" line. */
    size_t bom = length >= 3 && memcmp(text, "\xef\xbb\xbf", 3) == 0 ? 3 : 0;
    struct parse_state st = {.c = c, .next = text + bom, .end = text + length};
    int result = ini_parse_stream(next_line, &st, on_key_value, &st);
    free(st.section);
    if (result < 0) {
        free(st.errors.data);
        return sc_error_set(SC_EIO, __FILE__, __LINE__, "%s: inih failed (status %d, out of memory?)", c->path, result);
    }
    if (result > 0 && st.error_count == 0)
        append_syntax_error(&st, text + bom, length - bom, result);
    if (st.error_count > 0) {
        int status = report_errors(c, &st, every_error);
        free(st.errors.data);
        return status;
    }
    /* an empty file (or comments only) is more likely the wrong file than a wish for every default */
    if (!st.any_section) {
        char sections[LIST_SIZE];
        list_sections(&c->registry, sections, sizeof sections);
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__,
                            "%s: no [section] in the file (empty, or comments only); a case file has at least one "
                            "section (an empty [run] takes every default); allowed sections: %s",
                            c->path, sections);
    }
    finish_slots(c);
    return SC_OK;
}

/* ---- loading and freeing --------------------------------------------------------------------------------- */

static struct case_file *case_create(const char *path, const struct cfg_key *const *registry)
{
    struct case_file *c = must_realloc(NULL, sizeof *c);
    *c = (struct case_file){.path = must_strdup(path)};
    const char *slash = strrchr(path, '/');
    c->folder = slash ? must_strndup(path, (size_t)(slash - path) + 1) : must_strdup("");
    registry_open(&c->registry, registry);
    for (int i = 0; i < c->registry.count; i++)
        if (!is_pattern(c->registry.keys[i]->section))
            append_slot(c, i, c->registry.keys[i]->section);
    sort_slots(c);
    return c;
}

int case_load(const char *path, const struct cfg_key *const *registry, struct case_file **out)
{
    return case_load_reporting(path, registry, out, NULL);
}

int case_load_reporting(const char *path, const struct cfg_key *const *registry, struct case_file **out,
                        char **every_error)
{
    *out = NULL;
    if (every_error)
        *every_error = NULL;
    struct case_file *c = case_create(path, registry);
    char *text = NULL;
    size_t length = 0;
    int status;
    SC_CHECK(status, read_case_text(path, &text, &length), done);
    SC_CHECK(status, parse_case_text(c, text, length, every_error), done);
done:
    free(text);
    if (status != SC_OK) {
        case_free(c);
        return status;
    }
    *out = c;
    return SC_OK;
}

void case_free(struct case_file *c)
{
    if (!c)
        return;
    for (size_t i = 0; i < c->slot_count; i++) {
        clear_value(&c->slots[i]);
        free(c->slots[i].section);
    }
    free(c->slots);
    free(c->index);
    registry_close(&c->registry);
    free(c->folder);
    free(c->path);
    free(c);
}

static void *must_copy(const void *data, size_t size)
{
    void *copy = must_realloc(NULL, size ? size : 1);
    if (size)
        memcpy(copy, data, size);
    return copy;
}

struct case_file *case_clone(const struct case_file *c)
{
    struct case_file *copy = must_realloc(NULL, sizeof *copy);
    size_t keys = (size_t)c->registry.count;
    *copy = (struct case_file){
        .path = must_strdup(c->path),
        .folder = must_strdup(c->folder),
        .registry = {.keys = must_copy(c->registry.keys, keys * sizeof *c->registry.keys),
                     .section_rank = must_copy(c->registry.section_rank, keys * sizeof *c->registry.section_rank),
                     .count = c->registry.count},
        .slots = must_copy(c->slots, c->slot_count * sizeof *c->slots),
        .slot_count = c->slot_count,
        .slot_capacity = c->slot_count,
    };
    /* the structs are copied whole; the text they own is copied here */
    for (size_t i = 0; i < copy->slot_count; i++) {
        struct slot *slot = &copy->slots[i];
        slot->section = must_strdup(slot->section);
        slot->text = slot->text ? must_strdup(slot->text) : NULL;
        slot->origin = slot->origin ? must_strdup(slot->origin) : NULL;
    }
    sort_slots(copy);
    return copy;
}

/* ---- overrides ------------------------------------------------------------------------------------------- */

/* A value set from outside must survive case_write_resolved and a new load unchanged. */
static bool fits_in_case_file(const char *key, const char *text, char *why, size_t size)
{
    size_t left = strlen(text);
    for (const char *s = text; *s;) {
        size_t n = text_char_length((const unsigned char *)s, left);
        if (n == 0 || *s == '\n' || *s == '\r') {
            snprintf(why, size, "contains a control character or invalid UTF-8");
            return false;
        }
        if (INI_ALLOW_INLINE_COMMENTS && s > text && is_blank(s[-1]) && strchr(INI_INLINE_COMMENT_PREFIXES, *s)) {
            snprintf(why, size, "contains \"%c\" after a blank, which a case file reads as a comment", *s);
            return false;
        }
        s += n;
        left -= n;
    }
    if (strlen(key) + strlen(text) + 3 > MAX_LINE_CHARS) {
        snprintf(why, size, "longer than a case file line allows (%d characters)", MAX_LINE_CHARS);
        return false;
    }
    return true;
}

static int override_value(struct case_file *c, const char *where, const char *section, const char *key,
                          const char *text, char *message, size_t size)
{
    int rank = find_section_rank(&c->registry, section);
    if (rank < 0) {
        format_unknown_section(&c->registry, where, section, message, size);
        return SC_EINPUT;
    }
    if (find_key_index(&c->registry, rank, key) < 0) {
        format_unknown_key(&c->registry, where, section, rank, key, text, message, size);
        return SC_EINPUT;
    }
    char why[256];
    if (!fits_in_case_file(key, text, why, sizeof why)) {
        format_message(message, size, "%s: [%s] %s = %s: %s", where, section, key, text, why);
        return SC_EINPUT;
    }
    /* Check before creating a new [material.NAME], so that a refused value leaves no empty instance behind. */
    struct parsed_value parsed;
    if (!check_value(find_spec(&c->registry, section, key), section, text, where, &parsed, message, size))
        return SC_EINPUT;
    if (is_pattern(c->registry.keys[rank]->section))
        ensure_instance(c, section, rank);
    store_value(find_slot(c, section, key), text, &parsed, SOURCE_OVERRIDE, 0, where);
    finish_slots(c);
    return SC_OK;
}

int case_set(struct case_file *c, const char *section, const char *key, const char *value, const char *origin)
{
    const char *where = origin && *origin ? origin : "command line";
    char *text = trimmed_copy(value ? value : "");
    char message[MESSAGE_SIZE];
    int status = override_value(c, where, section, key, text, message, sizeof message);
    free(text);
    if (status != SC_OK)
        return sc_error_set(status, __FILE__, __LINE__, "%s", message);
    return SC_OK;
}

/* ---- accessors ---------------------------------------------------------------------------------------------- */

/* The slot of a key; NULL when the key is registered but its [material.NAME] is not present.  An unregistered
 * key is a programming error. */
static const struct slot *lookup(const struct case_file *c, const char *section, const char *key, const char *caller)
{
    const struct slot *slot = find_slot(c, section, key);
    if (!slot && !find_spec(&c->registry, section, key))
        config_bug("%s: [%s] %s is not a registered key", caller, section, key);
    return slot;
}

static const struct slot *lookup_value(const struct case_file *c, const char *section, const char *key,
                                       const char *caller)
{
    const struct slot *slot = lookup(c, section, key, caller);
    if (!slot || !slot->text)
        config_bug("%s: [%s] %s has no value (check case_has first, or give it a default)", caller, section, key);
    return slot;
}

const char *case_file_path(const struct case_file *c)
{
    return c->path;
}

int case_has(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup(c, section, key, "case_has");
    return slot && slot->text;
}

int case_is_given(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup(c, section, key, "case_is_given");
    return slot && (slot->source == SOURCE_FILE || slot->source == SOURCE_OVERRIDE);
}

int case_line(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup(c, section, key, "case_line");
    return slot && slot->source == SOURCE_FILE ? slot->line : 0;
}

double case_real(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup_value(c, section, key, "case_real");
    if (slot->spec->type != CFG_REAL && slot->spec->type != CFG_INT)
        config_bug("case_real: [%s] %s is of type %s", section, key, type_name(slot->spec));
    if (slot->value.is_word)
        config_bug("case_real: [%s] %s is the word \"%s\" (check case_is first)", section, key, slot->text);
    return slot->value.real;
}

long case_int(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup_value(c, section, key, "case_int");
    if (slot->spec->type != CFG_INT)
        config_bug("case_int: [%s] %s is of type %s", section, key, type_name(slot->spec));
    return slot->value.integer;
}

const char *case_text(const struct case_file *c, const char *section, const char *key)
{
    return lookup_value(c, section, key, "case_text")->text;
}

int case_is(const struct case_file *c, const char *section, const char *key, const char *word)
{
    const struct slot *slot = lookup(c, section, key, "case_is");
    const struct cfg_key *spec = find_spec(&c->registry, section, key);
    /* A misspelt word in the code would silently never match. */
    if (!spec->choices || !word_in_list(spec->choices, word))
        config_bug("case_is: \"%s\" is not one of the words of [%s] %s (%s)", word, section, key,
                   spec->choices ? spec->choices : "it has none");
    return slot && slot->text && strcmp(slot->text, word) == 0;
}

int case_is_word(const struct case_file *c, const char *section, const char *key)
{
    const struct slot *slot = lookup(c, section, key, "case_is_word");
    if (!slot || !slot->text)
        return 0;
    return slot->spec->type == CFG_CHOICE || (slot->spec->type == CFG_REAL && slot->value.is_word);
}

/* `text` as seen from the current folder: relative paths are relative to the case file's folder. */
static char *resolve_path(const struct case_file *c, const char *text)
{
    if (text[0] == '/' || !c->folder[0])
        return must_strdup(text);
    char *joined = must_realloc(NULL, strlen(c->folder) + strlen(text) + 1);
    strcpy(joined, c->folder);
    strcat(joined, text);
    return joined;
}

int case_path(const struct case_file *c, const char *section, const char *key, char *out, size_t size)
{
    const struct slot *slot = lookup_value(c, section, key, "case_path");
    if (slot->spec->type != CFG_PATH)
        config_bug("case_path: [%s] %s is of type %s", section, key, type_name(slot->spec));
    char *resolved = resolve_path(c, slot->text);
    size_t length = strlen(resolved);
    int status = SC_OK;
    if (length >= size)
        status = case_invalid(c, section, key, "the path %s is longer than %zu bytes", resolved, size - 1);
    else
        memcpy(out, resolved, length + 1);
    free(resolved);
    return status;
}

/* The absolute form of a path value: written to resolved copies (which live in another folder) and hashed, so
 * that a resolved copy names the same files and has the same hash as the case it was made from. */
static char *absolute_path(const struct case_file *c, const char *text)
{
    char *resolved = resolve_path(c, text);
    char *real = realpath(resolved, NULL);
    if (real) {
        free(resolved);
        return real;
    }
    char cwd[PATH_MAX];
    if (resolved[0] == '/' || !getcwd(cwd, sizeof cwd))
        return resolved;
    size_t size = strlen(cwd) + strlen(resolved) + 2;
    char *joined = must_realloc(NULL, size);
    snprintf(joined, size, "%s/%s", cwd, resolved);
    free(resolved);
    return joined;
}

/* ---- errors in the standard form ---------------------------------------------------------------------------- */

int case_require(const struct case_file *c, const char *section, const char *key, const char *why)
{
    const struct cfg_key *spec = find_spec(&c->registry, section, key);
    if (!spec)
        config_bug("case_require: [%s] %s is not a registered key", section, key);
    char allowed[512];
    describe_allowed(spec, allowed, sizeof allowed);
    bool has_why = why && *why;
    return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: [%s] %s is required%s%s%s; %s; allowed: %s", c->path,
                        section, key, has_why ? " (" : "", has_why ? why : "", has_why ? ")" : "", or_empty(spec->doc),
                        allowed);
}

int case_invalid(const struct case_file *c, const char *section, const char *key, const char *fmt, ...)
{
    const struct slot *slot = lookup(c, section, key, "case_invalid");
    char what[MESSAGE_SIZE];
    va_list args;
    va_start(args, fmt);
    vsnprintf(what, sizeof what, fmt, args);
    va_end(args);
    if (!slot || !slot->text)
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: [%s] %s (not set): %s", c->path, section, key, what);
    switch (slot->source) {
    case SOURCE_FILE:
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s:%d: [%s] %s = %s: %s", c->path, slot->line, section, key,
                            slot->text, what);
    case SOURCE_OVERRIDE:
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: [%s] %s = %s: %s", slot->origin, section, key,
                            slot->text, what);
    default:
        return sc_error_set(SC_EINPUT, __FILE__, __LINE__, "%s: [%s] %s = %s (default): %s", c->path, section, key,
                            slot->text, what);
    }
}

/* ---- printing, hashing, writing ------------------------------------------------------------------------------ */

static void describe_source(const struct case_file *c, const struct slot *slot, char *out, size_t size)
{
    switch (slot->source) {
    case SOURCE_FILE:
        snprintf(out, size, "%s:%d", c->path, slot->line);
        return;
    case SOURCE_OVERRIDE:
        snprintf(out, size, "%s", slot->origin);
        return;
    case SOURCE_DEFAULT:
        snprintf(out, size, "default");
        return;
    case SOURCE_UNSET:
        snprintf(out, size, "unset");
        return;
    }
}

/* Widen a column to fit `text`, but not beyond `limit` (a long path must not push every row right). */
static void widen(int *width, const char *text, int limit)
{
    size_t length = strlen(text);
    int wanted = length > (size_t)limit ? limit : (int)length;
    if (wanted > *width)
        *width = wanted;
}

/* The three left columns of a case_print row. */
static void print_row_columns(const struct case_file *c, const struct slot *slot, char *name, char *value, char *source,
                              size_t size)
{
    snprintf(name, size, "[%s] %s", slot->section, slot->spec->key);
    snprintf(value, size, "%s", or_empty(slot->text));
    bool has_unit = slot->spec->unit && *slot->spec->unit;
    if (slot->text && slot->value.has_unit) { /* the value as given and in SI: "30 mm = 0.03 m" */
        char si[64];
        format_number(slot->value.real, si, sizeof si);
        bool dimensionless = !has_unit || strcmp(slot->spec->unit, "-") == 0;
        append_text(value, size, " = %s%s%s", si, dimensionless ? "" : " ", dimensionless ? "" : slot->spec->unit);
    } else if (slot->text && !slot->value.is_word && has_unit) {
        append_text(value, size, " %s", slot->spec->unit);
    }
    char where[PATH_MAX + 32];
    describe_source(c, slot, where, sizeof where);
    snprintf(source, size, "(%s)", where);
}

void case_print(const struct case_file *c, FILE *out)
{
    enum { COLUMN = PATH_MAX + 64 };
    char name[COLUMN], value[COLUMN], source[COLUMN];
    int name_width = 0, value_width = 0, source_width = 0;
    for (size_t i = 0; i < c->slot_count; i++) {
        print_row_columns(c, &c->slots[i], name, value, source, COLUMN);
        widen(&name_width, name, 40);
        widen(&value_width, value, 32);
        widen(&source_width, source, 32);
    }
    for (size_t i = 0; i < c->slot_count; i++) {
        const struct slot *slot = &c->slots[i];
        if (i > 0 && strcmp(slot->section, c->slots[i - 1].section) != 0)
            fputc('\n', out);
        print_row_columns(c, slot, name, value, source, COLUMN);
        fprintf(out, "%-*s = %-*s  %-*s  %s\n", name_width, name, value_width, value, source_width, source,
                or_empty(slot->spec->doc));
    }
}

/* The value as hashed: numbers in one spelling (1e-6 and 0.000001 are the same case), paths absolute. */
static char *canonical_value(const struct case_file *c, const struct slot *slot)
{
    char number[64];
    if (slot->spec->type == CFG_INT) {
        snprintf(number, sizeof number, "%ld", slot->value.integer);
        return must_strdup(number);
    }
    if (slot->spec->type == CFG_REAL && !slot->value.is_word) {
        snprintf(number, sizeof number, "%.17g", slot->value.real);
        return must_strdup(number);
    }
    if (slot->spec->type == CFG_PATH)
        return absolute_path(c, slot->text);
    return must_strdup(slot->text);
}

static uint64_t fnv1a(uint64_t hash, const char *text)
{
    for (const unsigned char *s = (const unsigned char *)text; *s; s++) {
        hash ^= *s;
        hash *= 0x100000001b3ULL;
    }
    return hash;
}

uint64_t case_hash_continue(uint64_t hash, const void *bytes, size_t size)
{
    const unsigned char *b = bytes;
    for (size_t i = 0; i < size; i++)
        hash = (hash ^ b[i]) * 0x100000001b3ULL;
    return hash;
}

/* FNV-1a over the bytes of a file; an unreadable file adds nothing (the stage reports it). */
static uint64_t fnv1a_file(uint64_t hash, const char *path)
{
    FILE *file;
    char why[PATH_MAX + 128];
    if (csv_input_fopen(path, &file, why, sizeof why) != 0) /* no FIFO or device: it would block or never end */
        return hash;
    unsigned char buffer[65536];
    size_t got;
    while ((got = fread(buffer, 1, sizeof buffer, file)) > 0) {
        for (size_t k = 0; k < got; k++) {
            hash ^= buffer[k];
            hash *= 0x100000001b3ULL;
        }
    }
    fclose(file);
    return hash;
}

/* 1 when the slot's section is one of `sections` (NULL: every section). */
static bool slot_in_sections(const struct slot *slot, const char *const *sections)
{
    if (!sections)
        return true;
    for (; *sections; sections++)
        if (section_matches(*sections, slot->section))
            return true;
    return false;
}

uint64_t case_hash_sections(const struct case_file *c, const char *const *sections)
{
    uint64_t hash = 0xcbf29ce484222325ULL;
    for (size_t i = 0; i < c->slot_count; i++) {
        const struct slot *slot = &c->slots[i];
        if (!slot->text || (slot->spec->flags & CFG_NOT_HASHED) || !slot_in_sections(slot, sections))
            continue;
        char *value = canonical_value(c, slot);
        hash = fnv1a(hash, slot->section);
        hash = fnv1a(hash, ".");
        hash = fnv1a(hash, slot->spec->key);
        hash = fnv1a(hash, "=");
        hash = fnv1a(hash, value);
        hash = fnv1a(hash, "\n");
        /* a data file that changes changes the results: its contents are part of the case */
        if (slot->spec->type == CFG_PATH)
            hash = fnv1a_file(hash, value);
        free(value);
    }
    return hash;
}

uint64_t case_hash(const struct case_file *c)
{
    return case_hash_sections(c, NULL);
}

/* Slots [first, end) share one section; returns end. */
static size_t section_group_end(const struct case_file *c, size_t first)
{
    size_t end = first + 1;
    while (end < c->slot_count && strcmp(c->slots[end].section, c->slots[first].section) == 0)
        end++;
    return end;
}

size_t case_section_names(const struct case_file *c, const char *prefix, const char **names, size_t max)
{
    size_t count = 0, length = strlen(prefix);
    for (size_t first = 0; first < c->slot_count; first = section_group_end(c, first)) {
        const char *section = c->slots[first].section;
        if (strncmp(section, prefix, length) != 0 || section[length] != '.')
            continue;
        if (count < max)
            names[count] = section + length + 1;
        count++;
    }
    return count;
}

static bool group_has_values(const struct case_file *c, size_t first, size_t end)
{
    for (size_t i = first; i < end; i++)
        if (c->slots[i].text)
            return true;
    return false;
}

static void append_resolved_section(const struct case_file *c, size_t first, size_t end, bool canonical,
                                    struct text_buffer *b)
{
    buffer_append(b, "\n[%s]\n", c->slots[first].section);
    for (size_t i = first; i < end; i++) {
        const struct slot *slot = &c->slots[i];
        if (!slot->text || (canonical && (slot->spec->flags & CFG_NOT_HASHED)))
            continue;
        char *value = slot->spec->type == CFG_PATH ? absolute_path(c, slot->text) : must_strdup(slot->text);
        size_t line_length = strlen(slot->spec->key) + 3 + strlen(value);
        /* a default is shown as a comment: read back (`resume` reads RUN_DIR/case.ini) it must stay a default, not
         * become a given key (a given [jet] C1 overrode what [nozzle] derives; a given flip clashed with apic) */
        if (!canonical && slot->source == SOURCE_DEFAULT) {
            if (line_length + 12 <= MAX_LINE_CHARS)
                buffer_append(b, "; %s = %s  (default)\n", slot->spec->key, value);
        } else {
            buffer_append(b, "%s = %s\n", slot->spec->key, value);
        }
        free(value);
    }
}

/* The case file's name in a comment line: no line breaks or other control characters. */
static void append_comment_path(struct text_buffer *b, const char *path)
{
    buffer_append(b, "; read from: ");
    for (const char *s = path; *s; s++)
        buffer_append(b, "%c", (unsigned char)*s < 0x20 || *s == 0x7f ? '?' : *s);
    buffer_append(b, "\n");
}

static char *resolved_text(const struct case_file *c, bool canonical)
{
    struct text_buffer b = {0};
    if (canonical) {
        buffer_append(&b, "; spraycoat case, resolved\n");
    } else {
        buffer_append(&b, "; spraycoat case, resolved: every key that has a value, the defaults as comments.\n");
        append_comment_path(&b, c->path);
    }
    buffer_append(&b, "; case hash: %016llx\n", (unsigned long long)case_hash(c));
    for (size_t first = 0; first < c->slot_count;) {
        size_t end = section_group_end(c, first);
        /* A [material.NAME] is written even without values: its presence is part of the case. */
        if (group_has_values(c, first, end) || is_pattern(c->slots[first].spec->section))
            append_resolved_section(c, first, end, canonical, &b);
        first = end;
    }
    return b.data;
}

char *case_resolved_text(const struct case_file *c)
{
    return resolved_text(c, true);
}

/* inih splits longer lines: refuse to write a file that would not read back the same. */
static int check_line_lengths(const char *path, const char *text)
{
    for (const char *line = text; *line;) {
        const char *newline = strchr(line, '\n');
        size_t length = newline ? (size_t)(newline - line) : strlen(line);
        if (length > MAX_LINE_CHARS)
            return sc_error_set(SC_EINPUT, __FILE__, __LINE__,
                                "cannot write %s: the line \"%.40s...\" is longer than a case file allows (%d "
                                "characters)",
                                path, line, MAX_LINE_CHARS);
        line = newline ? newline + 1 : line + length;
    }
    return SC_OK;
}

int case_write_resolved(const struct case_file *c, const char *path)
{
    char *text = resolved_text(c, false);
    int status;
    SC_CHECK(status, check_line_lengths(path, text), done);
    SC_CHECK(status, atomic_write(path, text, strlen(text)), done);
done:
    free(text);
    return status;
}

/* ---- documentation -------------------------------------------------------------------------------------------- */

/* A Markdown table cell: '|' would end the cell. */
static void print_cell(FILE *out, const char *text)
{
    fputs(" ", out);
    for (const char *s = text; *s; s++) {
        if (*s == '|')
            fputc('\\', out);
        fputc(*s, out);
    }
    fputs(" |", out);
}

static void print_markdown_table(const struct registry_view *view, int rank, FILE *out)
{
    char shown[128], allowed[512];
    section_display(view->keys[rank]->section, shown, sizeof shown);
    fprintf(out, "### [%s]\n\n| key | type | unit | default | allowed | meaning |\n", shown);
    fprintf(out, "| --- | --- | --- | --- | --- | --- |\n");
    for (int i = rank; i < view->count; i++) {
        if (view->section_rank[i] != rank)
            continue;
        const struct cfg_key *spec = view->keys[i];
        describe_allowed(spec, allowed, sizeof allowed);
        fprintf(out, "| `%s` |", spec->key);
        print_cell(out, type_name(spec));
        print_cell(out, or_empty(spec->unit));
        print_cell(out, spec->default_value ? spec->default_value : "(none)");
        print_cell(out, allowed);
        print_cell(out, or_empty(spec->doc));
        fputc('\n', out);
    }
    fputc('\n', out);
}

/* What every table below assumes: how values and their units are written. */
static const char markdown_header[] =
    "# Case-file keys\n\n"
    "Generated by `spraycoat keys` (`make docs`); tests/test_keys_doc.sh checks that this page is current.\n\n"
    "A case file is INI: `key = value` lines under `[section]` headers, comments start with `;` or `#`.  A bare\n"
    "number is in the SI unit of the key's *unit* column (`-`: dimensionless).  A real value may carry a unit of\n"
    "its own, which [UDUNITS-2](https://docs.unidata.ucar.edu/udunits/current/) converts to that unit:\n"
    "`standoff = 30 mm`, `median_diameter = 20 um` (or `20 µm`), `T_initial = 25 degC`, `yield_stress = 250 MPa`,\n"
    "`dt = 50 ns`, `release_speed_max = 60 m/s`, fractions in `%`: SI prefixes, products, quotients and integer\n"
    "powers (`g/cm3`, `J/(kg K)`, `mm/s`; a power is written on its unit: `m2`, `s-1`, `m^2`).  A number in the\n"
    "unit is an error, not a factor (`800 m/s 2`, `30 mm (2)`).  A unit of another dimension (`standoff = 30 s`) or\n"
    "one UDUNITS-2 does not know is an error that names the unit given and the unit expected; the range is checked\n"
    "after the conversion.  An angle counts as a dimension (UDUNITS-2 calls it dimensionless): a key in `degree` "
    "takes\n"
    "`rad`, `degree`, `arc_minute` or `arc_second`, not `%` or `sr`, and a dimensionless key (`-`) no angle.\n"
    "Integer keys (counts) and the keys whose unit has a fractional power (`m^(4/3)/s`) take bare numbers.\n"
    "`spraycoat check CASE` shows a value given with a unit next to its SI value (`30 mm = 0.03 m`).\n\n";

void case_registry_markdown(const struct cfg_key *const *registry, FILE *out)
{
    struct registry_view view;
    registry_open(&view, registry);
    fputs(markdown_header, out);
    for (int i = 0; i < view.count; i++)
        if (view.section_rank[i] == i)
            print_markdown_table(&view, i, out);
    registry_close(&view);
}
