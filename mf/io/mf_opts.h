/* mf_opts: declarative option tables — one line per option gives its name, type, place in an
 * options struct, default, allowed range and documentation, and that one line feeds
 *   - the command-line flag  --kebab-case VALUE   (booleans: --kebab-case alone),
 *   - the JSON config key    snake_case           (`--config FILE`: every flag is a key),
 *   - the usage text         (default and range shown),
 *   - the range check        (message names the option, the value and the range),
 *   - run.json               (mf_opts_to_json records every value).
 * Defaults are written once, in the table (mf_opts_defaults fills a struct from it).
 *
 * A module declares its table next to its struct, e.g.
 *   static const MfOpt k_opts[] = {
 *       MF_OPT_INT(MfFooOpts, iters, 400, 0, 1e7, "iterations"),
 *       MF_OPT_FLOAT(MfFooOpts, lr, 0.02, 0, 1, "learning rate"),
 *       MF_OPT_NAMED(MfFooOpts, "spp", spp_sqrt, MF_OPT_INT, 2, 1, 64, "n: n^2 samples", .deprecated = "spp_sqrt"),
 *   };
 *   const MfOptTable mf_foo_opt_table = MF_OPT_TABLE("Foo options", k_opts);
 * Extra designated initialisers after the doc set .alias (another flag spelling, e.g. "-o"),
 * .deprecated (an old snake_case name, accepted with a warning, as --kebab and as a config key),
 * .unset (text shown as the default when the default is outside the range and means "not
 * given", e.g. "the images' size") and .choices ("a|b|c" for MF_OPT_STR).
 *
 * Numbers: MF_OPT_INT (int), MF_OPT_U64 (uint64_t, up to 2^53), MF_OPT_FLOAT (float; finite),
 * MF_OPT_BOOL (int 0/1; a flag without value on the command line, true/false or 0/1 in JSON),
 * MF_OPT_STR (const char *, borrowed from argv or from the parse state's config), MF_OPT_ENUM (an
 * int or C enum field: the index of the value's name in .choices "a|b|c"). Ranges are
 * inclusive; integers must be whole. Library code never prints: warnings go through mf_log. */
#ifndef MF_OPTS_H
#define MF_OPTS_H

#include <cJSON.h>
#include <stddef.h>

#include "core/mf_strbuf.h"

typedef enum { MF_OPT_INT, MF_OPT_U64, MF_OPT_FLOAT, MF_OPT_BOOL, MF_OPT_STR, MF_OPT_ENUM } MfOptType;

typedef struct {
    const char *name;       /* snake_case: JSON key; the flag is --kebab-case */
    MfOptType type;
    size_t off;             /* offset of the field in the options struct */
    double def;             /* default (numbers, BOOL) */
    double min, max;        /* allowed range, inclusive (numbers) */
    const char *doc;        /* one line */
    const char *def_str;    /* default of MF_OPT_STR (NULL: none) */
    const char *alias;      /* another accepted flag, e.g. "-o" (NULL: none) */
    const char *deprecated; /* old snake_case name: accepted with a warning (NULL: none) */
    const char *unset;      /* shown as the default when def lies outside [min, max] (means "not given") */
    const char *choices;    /* MF_OPT_STR: "a|b|c", the accepted values (NULL: any) */
    const char *meta;       /* value placeholder in the usage text (NULL: N, X or S by type) */
} MfOpt;

typedef struct {
    const char *title; /* usage section heading, e.g. "Reconstruction options" (NULL: none) */
    const MfOpt *opts;
    int n;
} MfOptTable;

#define MF_OPT_NAMED(S, name_, field, type_, def_, lo, hi, doc_, ...) \
    {.name = name_, .type = type_, .off = offsetof(S, field), .def = def_, .min = lo, .max = hi, .doc = doc_, __VA_ARGS__}
#define MF_OPT_INT(S, field, def_, lo, hi, doc_, ...) MF_OPT_NAMED(S, #field, field, MF_OPT_INT, def_, lo, hi, doc_, __VA_ARGS__)
#define MF_OPT_U64(S, field, def_, lo, hi, doc_, ...) MF_OPT_NAMED(S, #field, field, MF_OPT_U64, def_, lo, hi, doc_, __VA_ARGS__)
#define MF_OPT_FLOAT(S, field, def_, lo, hi, doc_, ...) MF_OPT_NAMED(S, #field, field, MF_OPT_FLOAT, def_, lo, hi, doc_, __VA_ARGS__)
#define MF_OPT_BOOL(S, field, def_, doc_, ...) MF_OPT_NAMED(S, #field, field, MF_OPT_BOOL, def_, 0, 1, doc_, __VA_ARGS__)
#define MF_OPT_STR(S, field, defs, doc_, ...) \
    MF_OPT_NAMED(S, #field, field, MF_OPT_STR, 0, 0, 0, doc_, .def_str = defs, __VA_ARGS__)
#define MF_OPT_ENUM(S, field, def_, choices_, doc_, ...) \
    MF_OPT_NAMED(S, #field, field, MF_OPT_ENUM, def_, 0, 0, doc_, .choices = choices_, __VA_ARGS__)
#define MF_OPT_TABLE(title_, arr) {title_, arr, (int)(sizeof arr / sizeof arr[0])}

/* Shared limits, so every command states the same range for the same quantity. */
#define MF_OPT_SPP_MAX 64            /* --spp n: n^2 light + n^2 BSDF samples per pixel sample */
#define MF_OPT_PIXEL_SAMPLES_MAX 256 /* --pixel-samples: primary rays per pixel */
#define MF_OPT_RES_MAX 16384         /* image and texture sides */

/* Sets every field of the table in obj to its default. */
void mf_opts_defaults(const MfOptTable *t, void *obj);

/* One table bound to the struct it fills. */
typedef struct {
    const MfOptTable *table;
    void *obj;
} MfOptBind;

/* A command line parsed against bound tables: positional arguments and the config file's JSON
 * (owned; string options may point into it, so free it only when done with the options). */
#define MF_OPTS_MAX_POS 8
typedef struct {
    const char *pos[MF_OPTS_MAX_POS];
    int npos;
    int print_config; /* --print-config was given: the command prints mf_opts_to_json of its tables and stops */
    cJSON *config;    /* owned */
} MfOptParse;

/* Parses argv[1..argc-1]: first `--config FILE` (a JSON object whose keys are the options'
 * snake_case names; null means "not given"), then every flag in order, so flags override the
 * config; `--print-config` sets p->print_config. Arguments not
 * starting with '-' are positional (at most max_pos). Unknown options, malformed or out-of-range
 * values are errors naming the option (and the file); returns MF_OK or an error code. */
int mf_opts_parse(const MfOptBind *b, int nb, int argc, char **argv, int max_pos, MfOptParse *p);
void mf_opts_parse_free(MfOptParse *p);

/* Applies one JSON object (keys: options' names) to the bound tables; unknown keys are errors
 * (keys "comment" and those starting with '_' are ignored). file names the source in messages. */
int mf_opts_apply_json(const MfOptBind *b, int nb, const cJSON *root, const char *file);

/* If argv[*i] is a flag of t, parses its value into obj, advances *i and returns 1; 0 when not
 * a flag of t; -1 (error set) on a bad value. */
int mf_opts_parse_arg(const MfOptTable *t, void *obj, int argc, char **argv, int *i);

/* Checks every field of obj against the table's ranges (defaults outside the range that mean
 * "not given" pass); MF_OK or an error naming the first bad option, its value and its range. */
int mf_opts_check(const MfOptTable *t, const void *obj);

/* Appends the usage lines of t: "  --flag N   doc (default D, range [a, b])". */
void mf_opts_usage(MfStrBuf *b, const MfOptTable *t);
/* Writes the usage text of a command into buf (cap bytes): head, each table's lines, the
 * --config / --print-config lines, tail. */
void mf_opts_usage_text(char *buf, size_t cap, const char *head, const MfOptTable *const *tables, int nt, const char *tail);

/* Adds every option's value to obj (numbers, booleans, strings; options not given whose default
 * means "not given" as null). The object is a valid config file for the same tables. */
void mf_opts_to_json(const MfOptTable *t, const void *o, cJSON *obj);

/* The option with this snake_case name, or NULL. */
const MfOpt *mf_opts_find(const MfOptTable *t, const char *name);

#endif
