/* Case files: INI parsed with libinih against a registry of keys.
 *
 * Every key a stage accepts is declared once in a table of struct cfg_key (type, unit, default, allowed
 * range or choices, one-line doc).  case_load() refuses unknown sections and keys, duplicate keys, values
 * of the wrong type, non-finite numbers and values out of range, with a message
 *     FILE:LINE: [section] key = value: what is wrong; allowed: what is allowed
 * and status SC_EINPUT.  Cross-key checks are done by the stage that owns the keys, which reports through
 * case_invalid() or case_require() so that its messages have the same form.
 *
 * File format: "key = value" lines under "[section]" headers; ';' or '#' starts a comment line, and " ;" an
 * inline comment.  Indented lines are not continuations.  A line may hold at most INI_MAX_LINE - 2 (198)
 * characters, libinih's buffer.  The file must be UTF-8 text without control characters (tab and CR allowed). */
#ifndef SPRAYCOAT_CORE_CONFIG_H
#define SPRAYCOAT_CORE_CONFIG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

enum cfg_type {
    CFG_INT,    /* integer in [min, max] */
    CFG_REAL,   /* finite real in [min, max]; if choices != NULL, one of those words is accepted as well */
    CFG_CHOICE, /* one of the '|'-separated words in choices */
    CFG_PATH,   /* a file path; relative paths are relative to the case file's folder */
    CFG_STRING, /* any non-empty text */
};

enum cfg_flags { CFG_MIN_EXCLUSIVE = 1, CFG_NOT_HASHED = 2 };

struct cfg_key {
    const char *section; /* "spray"; "material.*" matches any [material.NAME] */
    const char *key;
    enum cfg_type type;
    const char *unit;          /* SI unit ("m", "m/s", "kg/m3", "-" dimensionless, "" none) */
    const char *default_value; /* as text; NULL: no default (the owning stage decides if it is required) */
    double min, max;           /* CFG_INT and CFG_REAL: allowed range; a bound of magnitude >= 1e300 (or HUGE_VAL)
                                  is open; min == max == 0 is refused as a forgotten range */
    int flags;                 /* CFG_MIN_EXCLUSIVE: value must be > min rather than >= min;
                                  CFG_NOT_HASHED: does not change results (threads, checkpoints) */
    const char *choices;       /* CFG_CHOICE (and CFG_REAL alternatives): "a|b|c" */
    const char *doc;           /* one line for `spraycoat check` and docs/keys.md */
};

/* A registry is a NULL-terminated array of tables, each table terminated by an entry with key == NULL.
 * Registry mistakes (invalid default, missing choices, a key registered twice) abort in case_load().
 * Keys of a "material.*" section exist only for the [material.NAME] sections present in the file (or created by
 * case_set), so case_has(c, "material.steel", KEY) is 0 when there is no [material.steel]; defaults apply to each
 * present NAME. */
struct case_file;

/* Parse `path`.  On success *out owns the parsed case.  Errors: SC_EIO when the file cannot be read,
 * SC_EINPUT for anything wrong in it. */
int case_load(const char *path, const struct cfg_key *const *registry, struct case_file **out);
/* The same, and on SC_EINPUT for the lines of the file, *every_error (the caller frees it) lists every error
 * found (bad values, unknown sections and keys, syntax), one a line, in the order of the file; the recorded error
 * is that one error, or "FILE: N errors in the case file:" and the list (which the message buffer may cut
 * short).  *every_error is NULL on success and for the other errors. */
int case_load_reporting(const char *path, const struct cfg_key *const *registry, struct case_file **out,
                        char **every_error);
void case_free(struct case_file *c);
/* A copy of the case as it is now (the file's values, the defaults and every override, each with its source), that
 * the caller frees: a case derived from another one in memory (a sweep's runs, a calibration's searches) rather than
 * from its file read again, which may have changed since or lack the command line's overrides. */
struct case_file *case_clone(const struct case_file *c);

/* Override a value as if it were given in the file (e.g. --threads); `origin` is shown as its source
 * ("command line"; NULL means that) and replaces FILE:LINE in messages.  Validated exactly like a file value,
 * and refused if it could not be written back to a case file (line break, " ;", too long). */
int case_set(struct case_file *c, const char *section, const char *key, const char *value, const char *origin);

const char *case_file_path(const struct case_file *c);
/* 1 if the key has a value (from the file, the command line or a default), else 0. */
int case_has(const struct case_file *c, const char *section, const char *key);
/* 1 if the value came from the file or the command line, 0 if it is the default or unset. */
int case_is_given(const struct case_file *c, const char *section, const char *key);
/* Typed accessors: the key must be registered and have a value (programming error otherwise: abort). */
double case_real(const struct case_file *c, const char *section, const char *key);
long case_int(const struct case_file *c, const char *section, const char *key);
const char *case_text(const struct case_file *c, const char *section, const char *key);
/* 1 if the value is the word `word` (for CFG_CHOICE and CFG_REAL with word alternatives). */
int case_is(const struct case_file *c, const char *section, const char *key, const char *word);
/* 1 if the key has a value that is one of its words rather than a number (a CFG_REAL with word alternatives
 * given as a word, or any CFG_CHOICE value), else 0: lets a caller that handles any key (a sweep's axis) tell
 * before case_real, without naming the words. */
int case_is_word(const struct case_file *c, const char *section, const char *key);
/* The path of a CFG_PATH key, resolved relative to the case file's folder, into out[size]. */
int case_path(const struct case_file *c, const char *section, const char *key, char *out, size_t size);
/* Line of the key in the file, 0 if not from the file. */
int case_line(const struct case_file *c, const char *section, const char *key);

/* The NAME of a [material.NAME] section (and so a material name anywhere): 1 if it is made of the characters
 * CASE_NAME_ALLOWED says, else 0. */
#define CASE_NAME_ALLOWED "letters, digits, '_' or '-'"
int case_valid_name(const char *name);
/* The NAMEs of the [PREFIX.NAME] sections present (prefix "material"), at most `max` of them, in the case's order;
 * their number (which may exceed max).  The names belong to the case. */
size_t case_section_names(const struct case_file *c, const char *prefix, const char **names, size_t max);

/* Errors in the standard form.  Both return SC_EINPUT. */
int case_require(const struct case_file *c, const char *section, const char *key, const char *why);
int case_invalid(const struct case_file *c, const char *section, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Print every registered key: [section] key = value unit (source: FILE:LINE | default | unset), and doc. */
void case_print(const struct case_file *c, FILE *out);
/* 64-bit hash (FNV-1a) of the resolved values, independent of comments, order and formatting: lines
 * "section.key=value\n" in registry order, numbers in one spelling (%.17g, %ld), CFG_PATH values absolute. */
uint64_t case_hash(const struct case_file *c);
/* The same over the keys of the listed sections only (NULL-terminated; "material.*" matches every
 * [material.NAME]; NULL means every section): what one stage's results depend on, so that changing a later
 * stage's key does not rerun an earlier stage. */
uint64_t case_hash_sections(const struct case_file *c, const char *const *sections);
/* A hash continued (FNV-1a) over `size` raw bytes: a stage's own values (doubles) added to a case hash. */
uint64_t case_hash_continue(uint64_t hash, const void *bytes, size_t size);
/* Write the resolved case (every key with a value) as INI to `path` (atomically: tmp, fsync, rename).
 * CFG_PATH values are written as absolute paths, so that the copy (in a run folder) names the same files;
 * loading the copy gives the same case_hash().  Errors: SC_EIO with strerror. */
int case_write_resolved(const struct case_file *c, const char *path);
/* The resolved case as INI text without provenance comments or CFG_NOT_HASHED keys (caller frees): what
 * determines the results, stored in output files so that a resumed run writes the same text. */
char *case_resolved_text(const struct case_file *c);

/* Emit the registry as a Markdown table per section (`spraycoat keys`: docs/keys.md and its check). */
void case_registry_markdown(const struct cfg_key *const *registry, FILE *out);

#endif
