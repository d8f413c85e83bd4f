/* Case files (core/config.c): defaults and sources, every kind of error and its message, overrides, the hash,
 * the resolved copy, path resolution, printing and the Markdown registry.  The case files are written into a
 * fresh temporary folder, so the test needs nothing from the tree. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/config.h"
#include "core/error.h"
#include "tests/check.h"

static const struct cfg_key alpha_keys[] = {
    {"alpha", "count", CFG_INT, "-", "3", 1, 100, 0, NULL, "how many things"},
    {"alpha", "length", CFG_REAL, "m", "0.5", 0, 1e300, 1, NULL, "a positive length"},
    {"alpha", "fraction", CFG_REAL, "-", "0.25", 0, 1, 0, NULL, "a fraction"},
    {"alpha", "model", CFG_CHOICE, "", "bickley", 0, 0, 0, "bickley|uniform|none", "the gas model"},
    {"alpha", "restitution", CFG_REAL, "-", "johnson", 0, 1, 0, "johnson", "a word or a number"},
    {"alpha", "data", CFG_PATH, "", NULL, 0, 0, 0, NULL, "a data file"},
    {"alpha", "title", CFG_STRING, "", NULL, 0, 0, 0, NULL, "a title"},
    {"alpha", "workers", CFG_INT, "-", "0", 0, 64, CFG_NOT_HASHED, NULL, "does not change results"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

static const struct cfg_key other_keys[] = {
    {"material.*", "density", CFG_REAL, "kg/m3", NULL, 0, 1e5, 1, NULL, "mass density"},
    {"material.*", "poisson", CFG_REAL, "-", "0.3", 0, 0.5, 0, NULL, "Poisson's ratio"},
    {"beta", "steps", CFG_INT, "steps", NULL, 0, 1e9, 0, NULL, "number of steps"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

static const struct cfg_key *const registry[] = {alpha_keys, other_keys, NULL};

/* Short enough that every path built from it fits in PATH_MAX. */
static char temp_folder[256];

/* Write `text` (length bytes, or strlen if -1) to temp_folder/name; returns the path (static buffer per call site
 * is not enough when two are alive, so the caller passes one). */
static const char *write_file(char *path, size_t size, const char *name, const char *text, long length)
{
    snprintf(path, size, "%s/%s", temp_folder, name);
    FILE *file = fopen(path, "wb");
    if (!file) {
        printf("  cannot write %s: %s\n", path, strerror(errno));
        exit(1);
    }
    fwrite(text, 1, length < 0 ? strlen(text) : (size_t)length, file);
    fclose(file);
    return path;
}

static struct case_file *load_text(const char *name, const char *text, int *status)
{
    char path[PATH_MAX];
    write_file(path, sizeof path, name, text, -1);
    struct case_file *c = NULL;
    sc_error_clear();
    *status = case_load(path, registry, &c);
    return c;
}

/* The error message holds every fragment (NULL-terminated list). */
static int message_has(const char *first, ...)
{
    const char *message = sc_error_message();
    va_list args;
    va_start(args, first);
    int ok = 1;
    for (const char *fragment = first; fragment; fragment = va_arg(args, const char *)) {
        if (!strstr(message, fragment)) {
            printf("  message lacks \"%s\": %s\n", fragment, message);
            ok = 0;
        }
    }
    va_end(args);
    return ok;
}

/* Loading `text` fails with SC_EINPUT and a message holding the fragments. */
static void expect_input_error(const char *text, const char *first, ...)
{
    int status;
    struct case_file *c = load_text("bad.ini", text, &status);
    CHECK(status == SC_EINPUT, "status %d for \"%.40s\"", status, text);
    CHECK(c == NULL, "no case returned on error");
    case_free(c);
    const char *message = sc_error_message();
    va_list args;
    va_start(args, first);
    for (const char *fragment = first; fragment; fragment = va_arg(args, const char *))
        CHECK(strstr(message, fragment), "message lacks \"%s\": %s", fragment, message);
    va_end(args);
}

static void test_defaults_and_sources(void)
{
    int status;
    struct case_file *c = load_text("case.ini", "[alpha]\ncount = 7\n", &status);
    CHECK(status == SC_OK, "load: %s", sc_error_message());
    if (!c)
        return;
    CHECK(case_int(c, "alpha", "count") == 7, "count %ld", case_int(c, "alpha", "count"));
    CHECK(case_is_given(c, "alpha", "count"), "count is given");
    CHECK(case_line(c, "alpha", "count") == 2, "count line %d", case_line(c, "alpha", "count"));
    CHECK_CLOSE(case_real(c, "alpha", "length"), 0.5, 0, 0, "default length");
    CHECK(case_has(c, "alpha", "length") && !case_is_given(c, "alpha", "length"), "length is a default");
    CHECK(case_line(c, "alpha", "length") == 0, "default has no line");
    CHECK(case_is(c, "alpha", "model", "bickley"), "default model");
    CHECK(case_is(c, "alpha", "restitution", "johnson"), "default restitution word");
    CHECK(case_is_word(c, "alpha", "restitution"), "the default restitution is a word");
    CHECK(case_is_word(c, "alpha", "model"), "a choice is a word");
    CHECK(!case_has(c, "alpha", "data"), "data has no default");
    CHECK(!case_has(c, "beta", "steps"), "steps has no default");
    CHECK(!case_has(c, "material.steel", "poisson"), "no [material.steel] in the file");
    CHECK(strstr(case_file_path(c), "case.ini") != NULL, "path %s", case_file_path(c));
    case_free(c);
}

/* An empty file, or one of comments only, has no [section]: refused (it is more likely the wrong file than a wish
 * for every default); one empty section takes every default. */
static void test_empty_file(void)
{
    expect_input_error("", "bad.ini", "no [section]", "allowed sections: alpha", NULL);
    expect_input_error("; only a comment\n# and another\n\n", "bad.ini", "no [section]", NULL);
    int status;
    struct case_file *c = load_text("empty.ini", "[alpha]\n", &status);
    CHECK(status == SC_OK && c, "a file with one empty section loads: %s", sc_error_message());
    if (c) {
        CHECK(case_int(c, "alpha", "count") == 3, "default count");
        CHECK(!case_is_given(c, "alpha", "count"), "nothing given");
    }
    case_free(c);
}

/* Old Mac line endings (CR only) are named as such, not as "line too long". */
static void test_cr_line_endings(void)
{
    expect_input_error("[alpha]\rcount = 7\r", "bad.ini:1:", "CR line endings", NULL);
    expect_input_error("[alpha]\ncount = 7\rlength = 1\n", "bad.ini:2:", "CR line endings", NULL);
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\r\ncount = 7\r\n", &status);
    CHECK(status == SC_OK && c && case_int(c, "alpha", "count") == 7, "CRLF is fine: %s", sc_error_message());
    case_free(c);
}

/* Many [material.NAME] sections: each keeps its own values (the slots are found by a hash table and sorted once). */
static void test_many_instances(void)
{
    enum { COUNT = 3000 };
    size_t size = (size_t)COUNT * 64 + 64, used = 0;
    char *text = malloc(size);
    CHECK(text != NULL, "memory");
    if (!text)
        return;
    used += (size_t)snprintf(text + used, size - used, "[alpha]\n");
    for (int i = COUNT - 1; i >= 0; i--) /* in reverse: the slots must end up sorted by name */
        used += (size_t)snprintf(text + used, size - used, "[material.m%05d]\npoisson = 0.%04d\n", i, i + 1);
    int status;
    struct case_file *c = load_text("mat.ini", text, &status);
    free(text);
    CHECK(status == SC_OK && c, "load %d materials: %s", COUNT, sc_error_message());
    if (!c)
        return;
    int wrong = 0;
    for (int i = 0; i < COUNT; i++) {
        char section[32];
        snprintf(section, sizeof section, "material.m%05d", i);
        wrong += !case_has(c, section, "poisson") || fabs(case_real(c, section, "poisson") - (i + 1) * 1e-4) > 1e-12;
    }
    CHECK(wrong == 0, "%d of %d materials have the wrong poisson", wrong, COUNT);
    CHECK(!case_has(c, "material.m99999", "poisson"), "no such material");
    char *resolved = case_resolved_text(c);
    const char *first = resolved ? strstr(resolved, "[material.m00000]") : NULL;
    const char *last = resolved ? strstr(resolved, "[material.m02999]") : NULL;
    CHECK(first && last && first < last, "materials written in name order");
    free(resolved);
    case_free(c);
}

static void test_missing_file(void)
{
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/does-not-exist.ini", temp_folder);
    struct case_file *c = NULL;
    int status = case_load(path, registry, &c);
    CHECK(status == SC_EIO, "status %d", status);
    CHECK(c == NULL, "no case");
    CHECK(message_has("does-not-exist.ini", strerror(ENOENT), NULL), "message names file and cause");
    status = case_load(temp_folder, registry, &c); /* a folder */
    CHECK(status == SC_EIO, "folder: status %d (%s)", status, sc_error_message());
}

static void test_int_errors(void)
{
    expect_input_error("[alpha]\ncount = 3.5\n", "bad.ini:2:", "[alpha] count = 3.5", "not an integer",
                       "allowed: 1 .. 100", NULL);
    expect_input_error("\n[alpha]\ncount = 0\n", "bad.ini:3:", "[alpha] count = 0: out of range", "allowed: 1 .. 100",
                       NULL);
    expect_input_error("[alpha]\ncount = 99999999999999999999999\n", "bad.ini:2:", "out of range", NULL);
    expect_input_error("[alpha]\ncount =\n", "bad.ini:2:", "[alpha] count = : not an integer", NULL);
    expect_input_error("[alpha]\ncount = 5 # five\n", "not an integer", "inline comments start with ';'", NULL);
}

static void test_real_range_and_exclusive_min(void)
{
    expect_input_error("[alpha]\nlength = 0\n", "bad.ini:2:", "[alpha] length = 0: out of range", "allowed: > 0 m",
                       NULL);
    expect_input_error("[alpha]\nlength = -1e-3\n", "allowed: > 0 m", NULL);
    expect_input_error("[alpha]\nfraction = 1.5\n", "[alpha] fraction = 1.5", "allowed: 0 .. 1 -", NULL);
    expect_input_error("[alpha]\nfraction = abc\n", "not a number", "allowed: 0 .. 1 -", NULL);
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\nfraction = 1\nlength = 1e-300\n", &status);
    CHECK(status == SC_OK, "inclusive max: %s", sc_error_message());
    if (c)
        CHECK_CLOSE(case_real(c, "alpha", "fraction"), 1.0, 0, 0, "fraction");
    case_free(c);
}

static void test_nonfinite_rejected(void)
{
    const char *values[] = {"nan", "NaN", "inf", "-inf", "infinity", "1e999", "-1e999"};
    for (size_t i = 0; i < sizeof values / sizeof values[0]; i++) {
        char text[128], expected[64];
        snprintf(text, sizeof text, "[alpha]\nlength = %s\n", values[i]);
        snprintf(expected, sizeof expected, "[alpha] length = %s:", values[i]);
        expect_input_error(text, "bad.ini:2:", expected, "allowed: > 0 m", NULL);
    }
}

static void test_choice(void)
{
    expect_input_error("[alpha]\nmodel = Bickley\n", "bad.ini:2:", "[alpha] model = Bickley: not one of the choices",
                       "allowed: bickley|uniform|none", NULL);
    expect_input_error("[alpha]\nmodel = bickley uniform\n", "allowed: bickley|uniform|none", NULL);
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\nmodel = uniform\n", &status);
    CHECK(status == SC_OK && c, "uniform: %s", sc_error_message());
    if (c) {
        CHECK(case_is(c, "alpha", "model", "uniform"), "is uniform");
        CHECK(!case_is(c, "alpha", "model", "none"), "is not none");
        CHECK(strcmp(case_text(c, "alpha", "model"), "uniform") == 0, "text");
    }
    case_free(c);
}

static void test_real_or_word(void)
{
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\nrestitution = 0.8\n", &status);
    CHECK(status == SC_OK && c, "number: %s", sc_error_message());
    if (c) {
        CHECK(!case_is(c, "alpha", "restitution", "johnson"), "not the word");
        CHECK(!case_is_word(c, "alpha", "restitution"), "a number is no word");
        CHECK_CLOSE(case_real(c, "alpha", "restitution"), 0.8, 0, 0, "restitution");
    }
    case_free(c);
    expect_input_error("[alpha]\nrestitution = jonson\n", "bad.ini:2:", "[alpha] restitution = jonson",
                       "allowed: johnson or 0 .. 1 -", NULL);
    expect_input_error("[alpha]\nrestitution = 1.2\n", "out of range", "allowed: johnson or 0 .. 1 -", NULL);
}

static void test_paths_and_strings(void)
{
    expect_input_error("[alpha]\ndata =\n", "bad.ini:2:", "[alpha] data = : empty", NULL);
    expect_input_error("[alpha]\ntitle =   \n", "[alpha] title = : empty", "allowed: any non-empty text", NULL);
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\ntitle =   a  title  ; with a comment\n", &status);
    CHECK(status == SC_OK && c, "title: %s", sc_error_message());
    if (c)
        CHECK(strcmp(case_text(c, "alpha", "title"), "a  title") == 0, "stripped title \"%s\"",
              case_text(c, "alpha", "title"));
    case_free(c);
}

static void test_unknown_section(void)
{
    /* A misspelt section without keys must be caught too. */
    expect_input_error("[alpha]\ncount = 2\n[alpah]\n", "bad.ini:3:", "[alpah]", "unknown section",
                       "did you mean [alpha]?", "allowed sections: alpha, material.NAME, beta", NULL);
    expect_input_error("[gamma]\nx = 1\n", "bad.ini:1:", "[gamma]: unknown section", NULL);
    expect_input_error("[material.]\ndensity = 1\n", "bad.ini:1:", "NAME of [material.NAME]", NULL);
    expect_input_error("[material.a b]\n", "bad.ini:1:", "NAME of [material.NAME]", NULL);
    expect_input_error("count = 2\n", "bad.ini:1:", "count = 2: key before any [section]", "alpha", NULL);
    expect_input_error("[alpha] count = 2\n", "bad.ini:1:", "syntax error", "text after ']'", NULL);
}

static void test_unknown_key(void)
{
    expect_input_error("[alpha]\n\ncuont = 3\n", "bad.ini:3:", "[alpha] cuont = 3: unknown key",
                       "did you mean \"count\"?", "allowed keys in [alpha]: count, length, fraction, model", NULL);
    expect_input_error("[material.steel]\ndensty = 7800\n", "bad.ini:2:", "[material.steel] densty",
                       "allowed keys in [material.steel]: density, poisson", NULL);
}

static void test_duplicate_key(void)
{
    expect_input_error("[alpha]\ncount = 2\nlength = 1\ncount = 4\n", "bad.ini:4:", "[alpha] count = 4",
                       "duplicate key", "line 2", NULL);
    /* The same section twice is fine as long as no key repeats; a repeated key is not. */
    int status;
    struct case_file *c = load_text("ok.ini", "[alpha]\ncount = 2\n[beta]\nsteps = 1\n[alpha]\nlength = 2\n", &status);
    CHECK(status == SC_OK, "section twice: %s", sc_error_message());
    case_free(c);
    expect_input_error("[alpha]\ncount = 2\n[beta]\n[alpha]\ncount = 2\n", "bad.ini:5:", "duplicate key", NULL);
}

static void test_syntax_errors(void)
{
    expect_input_error("[alpha]\ncount = 2\njust words\n", "bad.ini:3: syntax error", "just words", NULL);
    expect_input_error("[alpha\ncount = 2\n", "bad.ini:1: syntax error", "']'", NULL);
    /* An indented line is not a continuation of the value above: it is a line of its own. */
    expect_input_error("[alpha]\nmodel = bickley\n   uniform\n", "bad.ini:3: syntax error", NULL);
    char line[400];
    memset(line, 'x', sizeof line);
    memcpy(line, "[alpha]\ntitle = ", 16);
    line[sizeof line - 2] = '\n';
    line[sizeof line - 1] = '\0';
    expect_input_error(line, "bad.ini:2: syntax error: line too long", NULL);
}

static void test_binary_garbage(void)
{
    static const char garbage[] = "[alpha]\ncount = 1\n\x7f"
                                  "ELF\x02\x01\x01\x00\x00\xff\xfe\n";
    char path[PATH_MAX];
    write_file(path, sizeof path, "garbage.ini", garbage, (long)sizeof garbage - 1);
    struct case_file *c = NULL;
    int status = case_load(path, registry, &c);
    CHECK(status == SC_EINPUT, "status %d", status);
    CHECK(message_has("garbage.ini:3: syntax error", NULL), "located");
    static const char nul[] = "[alpha]\ncou\0nt = 1\n";
    write_file(path, sizeof path, "nul.ini", nul, (long)sizeof nul - 1);
    status = case_load(path, registry, &c);
    CHECK(status == SC_EINPUT, "NUL: status %d", status);
    CHECK(message_has("nul.ini:2: syntax error: NUL byte at column 4", NULL), "NUL located");
    static const char latin1[] = "[alpha]\ntitle = caf\xe9\n";
    write_file(path, sizeof path, "latin1.ini", latin1, (long)sizeof latin1 - 1);
    status = case_load(path, registry, &c);
    CHECK(status == SC_EINPUT, "latin-1: status %d", status);
    CHECK(message_has("latin1.ini:2: syntax error", "not UTF-8", NULL), "latin-1 located");
    /* A long run of random bytes must fail cleanly, never crash. */
    char noise[4096];
    unsigned state = 12345;
    for (size_t i = 0; i < sizeof noise; i++) {
        state = state * 1103515245u + 12345u;
        noise[i] = (char)(state >> 16);
    }
    write_file(path, sizeof path, "noise.ini", noise, (long)sizeof noise);
    status = case_load(path, registry, &c);
    CHECK(status == SC_EINPUT && c == NULL, "noise: status %d", status);
    CHECK(message_has("noise.ini:", "syntax error", NULL), "noise located");
}

static void test_utf8_bom_and_crlf(void)
{
    int status;
    struct case_file *c =
        load_text("bom.ini", "\xef\xbb\xbf[alpha]\r\ncount = 9\r\ntitle = \xc3\xa9t\xc3\xa9 \r\n", &status);
    CHECK(status == SC_OK && c, "BOM and CRLF: %s", sc_error_message());
    if (c) {
        CHECK(case_int(c, "alpha", "count") == 9, "count");
        CHECK(strcmp(case_text(c, "alpha", "title"), "\xc3\xa9t\xc3\xa9") == 0, "UTF-8 title");
    }
    case_free(c);
}

static void test_material_sections(void)
{
    int status;
    struct case_file *c = load_text("mat.ini",
                                    "[material.steel]\ndensity = 7800\n[material.copper]\ndensity = 8960\n"
                                    "poisson = 0.34\n[material.empty]\n",
                                    &status);
    CHECK(status == SC_OK && c, "materials: %s", sc_error_message());
    if (!c)
        return;
    CHECK_CLOSE(case_real(c, "material.steel", "density"), 7800, 0, 0, "steel density");
    CHECK_CLOSE(case_real(c, "material.steel", "poisson"), 0.3, 0, 0, "steel default poisson");
    CHECK_CLOSE(case_real(c, "material.copper", "poisson"), 0.34, 0, 0, "copper poisson");
    CHECK(case_line(c, "material.copper", "poisson") == 5, "copper poisson line");
    CHECK(case_has(c, "material.empty", "poisson") && !case_has(c, "material.empty", "density"), "empty material");
    CHECK(!case_has(c, "material.gold", "poisson"), "absent material has nothing");
    case_free(c);
    expect_input_error("[material.steel]\ndensity = 0\n", "bad.ini:2:", "[material.steel] density = 0",
                       "allowed: > 0 and <= 100000 kg/m3", NULL);
}

static void test_case_set(void)
{
    int status;
    struct case_file *c = load_text("set.ini", "[alpha]\ncount = 2\n", &status);
    if (!c)
        return;
    CHECK(case_set(c, "alpha", "count", " 42 ", NULL) == SC_OK, "override: %s", sc_error_message());
    CHECK(case_int(c, "alpha", "count") == 42, "overridden count");
    CHECK(case_is_given(c, "alpha", "count") && case_line(c, "alpha", "count") == 0, "override is given, no line");
    CHECK(case_set(c, "beta", "steps", "10", "--steps") == SC_OK, "set unset key");
    CHECK(case_int(c, "beta", "steps") == 10, "steps");
    CHECK(case_set(c, "material.gold", "density", "19300", NULL) == SC_OK, "new material");
    CHECK(case_has(c, "material.gold", "poisson"), "new material gets defaults");

    sc_error_clear();
    CHECK(case_set(c, "alpha", "count", "-1", NULL) == SC_EINPUT, "invalid override");
    CHECK(message_has("command line: [alpha] count = -1: out of range; allowed: 1 .. 100", NULL), "override form");
    CHECK(case_int(c, "alpha", "count") == 42, "failed override keeps the value");
    CHECK(case_set(c, "alpha", "length", "inf", "--length") == SC_EINPUT, "inf override");
    CHECK(message_has("--length: [alpha] length = inf", "allowed: > 0 m", NULL), "origin shown");
    CHECK(case_set(c, "alpha", "lenght", "1", NULL) == SC_EINPUT, "unknown key");
    CHECK(message_has("command line: [alpha] lenght = 1: unknown key", "did you mean \"length\"?", NULL), "unknown");
    CHECK(case_set(c, "gamma", "x", "1", NULL) == SC_EINPUT, "unknown section");
    CHECK(message_has("[gamma]: unknown section", NULL), "unknown section message");
    CHECK(case_set(c, "alpha", "title", "a ; b", NULL) == SC_EINPUT, "value that would read back as a comment");
    CHECK(case_set(c, "alpha", "title", "a\nb", NULL) == SC_EINPUT, "value with a line break");
    CHECK(case_set(c, "alpha", "title", "caf\xe9", NULL) == SC_EINPUT, "value that is not UTF-8");
    CHECK(case_set(c, "alpha", "title", "\xc3\xa9t\xc3\xa9;x", NULL) == SC_OK, "UTF-8 value: %s", sc_error_message());
    CHECK(case_set(c, "material.lead", "density", "-1", NULL) == SC_EINPUT, "invalid value for a new material");
    CHECK(!case_has(c, "material.lead", "poisson"), "a refused value creates no material");

    CHECK(case_invalid(c, "alpha", "count", "more than %d", 10) == SC_EINPUT, "case_invalid status");
    CHECK(message_has("command line: [alpha] count = 42: more than 10", NULL), "case_invalid on an override");
    case_free(c);
}

/* A clone is the case as it is in memory, overrides and all, and lives on its own: the file edited after the load
 * and changes to the clone reach neither (a sweep's runs and a calibration's searches are clones). */
static void test_clone(void)
{
    int status;
    char path[PATH_MAX];
    struct case_file *c = load_text("clone.ini", "[alpha]\ncount = 2\n[material.steel]\ndensity = 7800\n", &status);
    if (!c)
        return;
    CHECK(case_set(c, "alpha", "workers", "3", "--workers") == SC_OK, "override: %s", sc_error_message());
    CHECK(case_set(c, "material.gold", "density", "19300", NULL) == SC_OK, "new material: %s", sc_error_message());
    write_file(path, sizeof path, "clone.ini", "[alpha]\ncount = 5\n", -1); /* edited after the load */
    struct case_file *copy = case_clone(c);
    CHECK(case_hash(copy) == case_hash(c), "the clone's hash differs");
    CHECK(case_int(copy, "alpha", "count") == 2, "the clone read the edited file: count %ld",
          case_int(copy, "alpha", "count"));
    CHECK(case_int(copy, "alpha", "workers") == 3 && case_is_given(copy, "alpha", "workers"), "override lost");
    CHECK(case_line(copy, "alpha", "count") == 2, "the file's line lost");
    CHECK_CLOSE(case_real(copy, "material.gold", "density"), 19300, 0, 0, "the new material lost");
    CHECK_CLOSE(case_real(copy, "material.steel", "density"), 7800, 0, 0, "the file's material lost");
    CHECK(strcmp(case_file_path(copy), case_file_path(c)) == 0, "path %s", case_file_path(copy));
    CHECK(case_set(copy, "alpha", "count", "9", NULL) == SC_OK &&
              case_set(copy, "material.lead", "density", "11340", NULL) == SC_OK,
          "set on the clone: %s", sc_error_message());
    CHECK(case_int(c, "alpha", "count") == 2 && !case_has(c, "material.lead", "density"), "the clone shares values");
    case_free(copy);
    CHECK(case_int(c, "alpha", "count") == 2 && case_int(c, "alpha", "workers") == 3, "freeing the clone");
    case_free(c);
}

static void test_require_and_invalid(void)
{
    int status;
    struct case_file *c = load_text("req.ini", "[alpha]\n\ncount = 5\n", &status);
    if (!c)
        return;
    CHECK(case_require(c, "beta", "steps", "with model = uniform") == SC_EINPUT, "require status");
    CHECK(message_has("req.ini: [beta] steps is required (with model = uniform); number of steps; allowed: 0 .. "
                      "1000000000 steps",
                      NULL),
          "require form");
    CHECK(case_invalid(c, "alpha", "count", "larger than %s", "fraction") == SC_EINPUT, "invalid status");
    CHECK(message_has("req.ini:3: [alpha] count = 5: larger than fraction", NULL), "invalid from the file");
    case_invalid(c, "alpha", "length", "too long");
    CHECK(message_has("req.ini: [alpha] length = 0.5 (default): too long", NULL), "invalid on a default");
    case_invalid(c, "alpha", "data", "missing");
    CHECK(message_has("req.ini: [alpha] data (not set): missing", NULL), "invalid on an unset key");
    case_free(c);
}

static uint64_t hash_of(const char *name, const char *text)
{
    int status;
    struct case_file *c = load_text(name, text, &status);
    CHECK(status == SC_OK && c, "%s: %s", name, sc_error_message());
    uint64_t hash = c ? case_hash(c) : 0;
    case_free(c);
    return hash;
}

static void test_hash(void)
{
    uint64_t a =
        hash_of("h1.ini", "[alpha]\ncount = 5\nlength = 2\n[material.b]\ndensity=1\n[material.a]\ndensity=2\n");
    uint64_t b = hash_of("h2.ini", "; a comment\n[material.a]\n  density = 2.0 ; two\n[alpha]\nlength=2e0\n\n"
                                   "[material.b]\ndensity = 1\n[alpha]\ncount=+5\nmodel = bickley\n");
    uint64_t changed = hash_of("h3.ini", "[alpha]\ncount = 6\nlength = 2\n[material.b]\ndensity=1\n"
                                         "[material.a]\ndensity=2\n");
    uint64_t fewer = hash_of("h4.ini", "[alpha]\ncount = 5\nlength = 2\n[material.b]\ndensity=1\n");
    CHECK(a == b, "comments, order, spelling and explicit defaults do not matter: %016llx %016llx",
          (unsigned long long)a, (unsigned long long)b);
    CHECK(a != changed, "a changed value changes the hash");
    CHECK(a != fewer, "a removed material changes the hash");
    int status;
    struct case_file *c = load_text("h5.ini",
                                    "[alpha]\ncount = 5\nlength = 2\n[material.b]\ndensity=1\n"
                                    "[material.a]\ndensity=2\n",
                                    &status);
    if (c) {
        CHECK(case_hash(c) == a, "same text, same hash");
        case_set(c, "alpha", "fraction", "0.5", NULL);
        CHECK(case_hash(c) != a, "an override changes the hash");
    }
    case_free(c);
}

static void test_write_resolved_round_trip(void)
{
    char data[PATH_MAX];
    write_file(data, sizeof data, "particles.csv", "x\n1\n", -1);
    int status;
    struct case_file *c = load_text("round.ini",
                                    "[alpha]\ncount = 5 ; five\ndata = particles.csv\ntitle = A run\n"
                                    "[material.steel]\ndensity = 7.8e3\n[material.none]\n",
                                    &status);
    CHECK(status == SC_OK && c, "load: %s", sc_error_message());
    if (!c)
        return;
    case_set(c, "beta", "steps", "100", NULL);
    mkdir(temp_folder, 0700);
    char out[PATH_MAX], tmp[PATH_MAX + 8];
    snprintf(out, sizeof out, "%s/run", temp_folder);
    mkdir(out, 0700);
    snprintf(out, sizeof out, "%s/run/case.ini", temp_folder);
    CHECK(case_write_resolved(c, out) == SC_OK, "write: %s", sc_error_message());
    snprintf(tmp, sizeof tmp, "%s.tmp", out);
    CHECK(access(tmp, F_OK) != 0, "no temporary file left");
    struct case_file *again = NULL;
    CHECK(case_load(out, registry, &again) == SC_OK, "reload: %s", sc_error_message());
    if (again) {
        CHECK(case_hash(again) == case_hash(c), "same hash after the round trip");
        CHECK(case_int(again, "beta", "steps") == 100, "override written");
        /* a default stays a default read back (it became a given key: `resume` then ran another case) */
        CHECK(!case_is_given(again, "alpha", "length") && case_has(again, "alpha", "length"), "a default stays one");
        CHECK(case_is_given(again, "alpha", "count"), "a given key stays given");
        CHECK(case_has(again, "material.none", "poisson"), "empty material kept");
        char resolved[PATH_MAX];
        CHECK(case_path(again, "alpha", "data", resolved, sizeof resolved) == SC_OK, "path");
        CHECK(strcmp(resolved, data) == 0 || strstr(resolved, "/particles.csv"), "copy names the same file: %s",
              resolved);
        CHECK(access(resolved, R_OK) == 0, "the resolved copy's path exists from its new folder: %s", resolved);
    }
    case_free(again);
    char *text = case_resolved_text(c);
    /* the text stored in output files is canonical: values only, no provenance marks */
    CHECK(text && strstr(text, "[alpha]\n") && strstr(text, "count = 5\n") && !strstr(text, "; default") &&
              !strstr(text, "read from"),
          "resolved text:\n%s", text ? text : "(null)");
    CHECK(text && strstr(text, "title = A run\n") && strstr(text, "[material.none]\n"), "resolved text contents");
    free(text);
    snprintf(out, sizeof out, "%s/no-such-folder/case.ini", temp_folder);
    CHECK(case_write_resolved(c, out) == SC_EIO, "unwritable: SC_EIO");
    CHECK(message_has("no-such-folder", strerror(ENOENT), NULL), "I/O message");
    case_free(c);
    snprintf(out, sizeof out, "%s/run/case.ini", temp_folder);
    unlink(out);
    snprintf(out, sizeof out, "%s/run", temp_folder);
    rmdir(out);
}

static void test_relative_paths(void)
{
    char folder[PATH_MAX], path[PATH_MAX], resolved[PATH_MAX], expected[PATH_MAX + 32];
    snprintf(folder, sizeof folder, "%s/sub", temp_folder);
    mkdir(folder, 0700);
    write_file(path, sizeof path, "sub/case.ini", "[alpha]\ndata = in/data.csv\n", -1);
    struct case_file *c = NULL;
    CHECK(case_load(path, registry, &c) == SC_OK, "load: %s", sc_error_message());
    if (c) {
        CHECK(case_path(c, "alpha", "data", resolved, sizeof resolved) == SC_OK, "case_path");
        snprintf(expected, sizeof expected, "%s/sub/in/data.csv", temp_folder);
        CHECK(strcmp(resolved, expected) == 0, "relative: %s, expected %s", resolved, expected);
        CHECK(strcmp(case_text(c, "alpha", "data"), "in/data.csv") == 0, "text unchanged");
        char small[8];
        CHECK(case_path(c, "alpha", "data", small, sizeof small) == SC_EINPUT, "too small a buffer");
        case_set(c, "alpha", "data", "/abs/data.csv", NULL);
        CHECK(case_path(c, "alpha", "data", resolved, sizeof resolved) == SC_OK, "absolute");
        CHECK(strcmp(resolved, "/abs/data.csv") == 0, "absolute unchanged: %s", resolved);
    }
    case_free(c);
    unlink(path);
    rmdir(folder);
}

static char *capture(void (*write)(const void *, FILE *), const void *what)
{
    char *text = NULL;
    size_t size = 0;
    FILE *out = open_memstream(&text, &size);
    write(what, out);
    fclose(out);
    return text;
}

static void print_case(const void *c, FILE *out)
{
    case_print(c, out);
}
static void print_markdown(const void *r, FILE *out)
{
    case_registry_markdown(r, out);
}

static void test_print(void)
{
    int status;
    struct case_file *c = load_text("print.ini", "[alpha]\ncount = 4\n[material.steel]\ndensity = 7800\n", &status);
    if (!c)
        return;
    case_set(c, "alpha", "fraction", "0.5", NULL);
    char *text = capture(print_case, c);
    CHECK(strstr(text, "[alpha] count") && strstr(text, "print.ini:2)"), "file source:\n%s", text);
    CHECK(strstr(text, "(default)") && strstr(text, "(command line)") && strstr(text, "(unset)"), "sources");
    CHECK(strstr(text, "0.5 m ") && strstr(text, "a positive length"), "unit and doc");
    CHECK(strstr(text, "[material.steel] density") && strstr(text, "7800 kg/m3"), "material rows");
    CHECK(!strstr(text, "material.*"), "no pattern rows");
    free(text);
    case_free(c);
}

static void test_markdown(void)
{
    char *text = capture(print_markdown, registry);
    CHECK(strstr(text, "### [alpha]") && strstr(text, "### [material.NAME]"), "section titles:\n%s", text);
    CHECK(strstr(text, "| key | type | unit | default | allowed | meaning |"), "header");
    CHECK(strstr(text, "| `count` | int | - | 3 | 1 .. 100 - | how many things |"), "count row");
    CHECK(strstr(text, "| `model` | choice |  | bickley | bickley\\|uniform\\|none |"), "escaped choices");
    CHECK(strstr(text, "| `density` | real | kg/m3 | (none) |"), "no default");
    free(text);
}

static void remove_temp_folder(void)
{
    static const char *const names[] = {
        "case.ini",  "empty.ini", "comments.ini",  "bad.ini",   "ok.ini",    "garbage.ini", "nul.ini", "latin1.ini",
        "noise.ini", "bom.ini",   "mat.ini",       "set.ini",   "req.ini",   "h1.ini",      "h2.ini",  "h3.ini",
        "h4.ini",    "h5.ini",    "particles.csv", "round.ini", "print.ini", "clone.ini"};
    char path[PATH_MAX + 32];
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", temp_folder, names[i]);
        unlink(path);
    }
    if (rmdir(temp_folder) != 0)
        printf("  note: could not remove %s: %s\n", temp_folder, strerror(errno));
}

/* Keys flagged CFG_NOT_HASHED (threads, checkpoint policy) change neither the hash nor the canonical text. */
static void test_not_hashed_keys(void)
{
    struct case_file *c = NULL;
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/unhashed.ini", temp_folder);
    mkdir(temp_folder, 0700);
    FILE *file = fopen(path, "w");
    fputs("[alpha]\ncount = 4\n", file);
    fclose(file);
    CHECK(case_load(path, registry, &c) == SC_OK, "load: %s", sc_error_message());
    if (!c)
        return;
    uint64_t before = case_hash(c);
    CHECK(case_set(c, "alpha", "workers", "8", "command line") == SC_OK, "set");
    CHECK(case_hash(c) == before, "hash unchanged by a CFG_NOT_HASHED key");
    char *text = case_resolved_text(c);
    CHECK(text && !strstr(text, "workers"), "canonical text leaves it out");
    free(text);
    CHECK(case_set(c, "alpha", "count", "5", "command line") == SC_OK, "set");
    CHECK(case_hash(c) != before, "a hashed key changes the hash");
    case_free(c);
    unlink(path);
}

/* The contents of a file a case names are part of the case: editing the file changes the hash. */
static void test_hash_follows_file_contents(void)
{
    char path[PATH_MAX], data[PATH_MAX];
    mkdir(temp_folder, 0700);
    snprintf(data, sizeof data, "%s/table.csv", temp_folder);
    snprintf(path, sizeof path, "%s/with_file.ini", temp_folder);
    FILE *file = fopen(data, "w");
    fputs("a,b\n1,2\n", file);
    fclose(file);
    file = fopen(path, "w");
    fputs("[alpha]\ndata = table.csv\n", file);
    fclose(file);
    struct case_file *c = NULL;
    CHECK(case_load(path, registry, &c) == SC_OK, "load: %s", sc_error_message());
    uint64_t before = c ? case_hash(c) : 0;
    case_free(c);
    file = fopen(data, "w");
    fputs("a,b\n1,3\n", file);
    fclose(file);
    c = NULL;
    CHECK(case_load(path, registry, &c) == SC_OK, "reload: %s", sc_error_message());
    CHECK(c && case_hash(c) != before, "the hash changes with the file's contents");
    case_free(c);
    unlink(path);
    unlink(data);
}

/* One pass reports every bad line, in the order of the file: a bad value, an unknown key, a syntax error and an
 * unknown section (whose keys are not reported again); a single error keeps its message as it is. */
static void test_every_error(void)
{
    char path[PATH_MAX];
    write_file(path, sizeof path, "bad.ini",
               "[alpha]\ncount = 0\ncuont = 3\njust words\n[gamma]\nx = 1\n[alpha]\nlength = 2\nfraction = 7\n", -1);
    struct case_file *c = NULL;
    char *every = NULL;
    sc_error_clear();
    int status = case_load_reporting(path, registry, &c, &every);
    CHECK(status == SC_EINPUT && !c, "status %d", status);
    case_free(c);
    static const char *const expected[] = {"bad.ini:2: [alpha] count = 0: out of range", "bad.ini:3: [alpha] cuont",
                                           "bad.ini:4: syntax error", "bad.ini:5: [gamma]: unknown section",
                                           "bad.ini:9: [alpha] fraction = 7: out of range"};
    int lines = 0;
    const char *line = every ? every : "";
    for (; *line; lines++) {
        size_t length = strcspn(line, "\n");
        if (lines < 5)
            CHECK(strstr(line, expected[lines]) && (size_t)(strstr(line, expected[lines]) - line) < length,
                  "error %d is \"%.*s\", expected \"%s\"", lines + 1, (int)length, line, expected[lines]);
        line += length + (line[length] == '\n');
    }
    CHECK(lines == 5, "%d errors listed, expected 5:\n%s", lines, every ? every : "(none)");
    CHECK(strstr(sc_error_message(), "bad.ini: 5 errors in the case file:"), "message: %s", sc_error_message());
    free(every);
    /* one error: the message of that error alone, and the list holds just it */
    write_file(path, sizeof path, "bad.ini", "[alpha]\ncount = 0\n", -1);
    status = case_load_reporting(path, registry, &c, &every);
    CHECK(status == SC_EINPUT && every && !strchr(every, '\n'), "one error, one line: %s", every ? every : "(none)");
    CHECK(strstr(sc_error_message(), "bad.ini:2: [alpha] count = 0") == sc_error_message() + strlen(path) - 7,
          "message: %s", sc_error_message());
    free(every);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(temp_folder, sizeof temp_folder, "%s/test_config.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(temp_folder)) {
        printf("FAIL test_config: mkdtemp: %s\n", strerror(errno));
        return 1;
    }
    RUN(test_defaults_and_sources);
    RUN(test_empty_file);
    RUN(test_cr_line_endings);
    RUN(test_many_instances);
    RUN(test_missing_file);
    RUN(test_int_errors);
    RUN(test_real_range_and_exclusive_min);
    RUN(test_nonfinite_rejected);
    RUN(test_choice);
    RUN(test_real_or_word);
    RUN(test_paths_and_strings);
    RUN(test_unknown_section);
    RUN(test_unknown_key);
    RUN(test_duplicate_key);
    RUN(test_syntax_errors);
    RUN(test_every_error);
    RUN(test_binary_garbage);
    RUN(test_utf8_bom_and_crlf);
    RUN(test_material_sections);
    RUN(test_case_set);
    RUN(test_clone);
    RUN(test_require_and_invalid);
    RUN(test_hash);
    RUN(test_write_resolved_round_trip);
    RUN(test_not_hashed_keys);
    RUN(test_hash_follows_file_contents);
    RUN(test_relative_paths);
    RUN(test_print);
    RUN(test_markdown);
    remove_temp_folder();
    return check_finish();
}
