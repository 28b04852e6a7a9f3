#include "io/mf_opts.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "io/mf_json.h"

/* "--kebab-case" from a snake_case name. */
static void flag_of(const char *name, char *flag, size_t cap) {
    snprintf(flag, cap, "--%s", name);
    for (char *c = flag + 2; *c; ++c)
        if (*c == '_') *c = '-';
}

static int is_int_type(MfOptType t) { return t == MF_OPT_INT || t == MF_OPT_U64 || t == MF_OPT_BOOL; }

/* A limit or value as the usage text and messages write it. */
static void fmt_num(char *s, size_t cap, const MfOpt *o, double v) {
    if (is_int_type(o->type) && fabs(v) < 1e16) snprintf(s, cap, "%.0f", v);
    else snprintf(s, cap, "%g", v);
}

static double get_num(const MfOpt *o, const void *obj) {
    const char *p = (const char *)obj + o->off;
    switch (o->type) {
    case MF_OPT_INT:
    case MF_OPT_ENUM:
    case MF_OPT_BOOL: return *(const int *)p;
    case MF_OPT_U64: return (double)*(const uint64_t *)p;
    case MF_OPT_FLOAT: return *(const float *)p;
    default: return 0.0;
    }
}

static void put_num(const MfOpt *o, void *obj, double v) {
    char *p = (char *)obj + o->off;
    switch (o->type) {
    case MF_OPT_INT:
    case MF_OPT_ENUM:
    case MF_OPT_BOOL: *(int *)p = (int)v; break;
    case MF_OPT_U64: *(uint64_t *)p = (uint64_t)v; break;
    case MF_OPT_FLOAT: *(float *)p = (float)v; break;
    default: break;
    }
}

/* Range of a number, "[a, b]". */
static void fmt_range(char *s, size_t cap, const MfOpt *o) {
    char a[32], b[32];
    fmt_num(a, sizeof a, o, o->min);
    fmt_num(b, sizeof b, o, o->max);
    snprintf(s, cap, "[%s, %s]", a, b);
}

/* Checks and stores a number; who names the option as the user wrote it ("--lr", "cfg.json: lr"). */
static int set_num(const MfOpt *o, void *obj, double v, const char *who) {
    char vs[32], rs[80];
    fmt_num(vs, sizeof vs, o, v);
    fmt_range(rs, sizeof rs, o);
    if (!isfinite(v)) return mf_fail(MF_EARG, "%s: value is not finite (allowed range %s)", who, rs);
    if (is_int_type(o->type) && v != floor(v)) return mf_fail(MF_EARG, "%s %g: expected an integer in %s", who, v, rs);
    if (!(v >= o->min && v <= o->max)) return mf_fail(MF_EARG, "%s %s: outside the allowed range %s", who, vs, rs);
    put_num(o, obj, v);
    return MF_OK;
}

/* Index of s in o->choices ("a|b|c"), -1 when absent. */
static int choice_index(const MfOpt *o, const char *s) {
    size_t n = strlen(s);
    int k = 0;
    for (const char *c = o->choices; *c; ++k) {
        const char *e = strchr(c, '|');
        size_t len = e ? (size_t)(e - c) : strlen(c);
        if (len == n && !strncmp(c, s, n)) return k;
        if (!e) break;
        c = e + 1;
    }
    return -1;
}

static int choice_ok(const MfOpt *o, const char *s) { return !o->choices || !s || choice_index(o, s) >= 0; }

/* Name of choice k into buf ("?" when out of range). */
static const char *choice_name(const MfOpt *o, int k, char *buf, size_t cap) {
    const char *c = o->choices;
    for (int i = 0; i < k && c; ++i) {
        c = strchr(c, '|');
        if (c) ++c;
    }
    if (!c || k < 0) return "?";
    const char *e = strchr(c, '|');
    snprintf(buf, cap, "%.*s", (int)(e ? (size_t)(e - c) : strlen(c)), c);
    return buf;
}

static int set_str(const MfOpt *o, void *obj, const char *s, const char *who) {
    if (!choice_ok(o, s)) return mf_fail(MF_EARG, "%s '%s': expected one of %s", who, s, o->choices);
    if (o->type == MF_OPT_ENUM) {
        *(int *)((char *)obj + o->off) = choice_index(o, s);
        return MF_OK;
    }
    *(const char **)((char *)obj + o->off) = s;
    return MF_OK;
}

void mf_opts_defaults(const MfOptTable *t, void *obj) {
    for (int k = 0; k < t->n; ++k) {
        const MfOpt *o = &t->opts[k];
        if (o->type == MF_OPT_STR) *(const char **)((char *)obj + o->off) = o->def_str;
        else put_num(o, obj, o->def);
    }
}

const MfOpt *mf_opts_find(const MfOptTable *t, const char *name) {
    for (int k = 0; k < t->n; ++k)
        if (!strcmp(t->opts[k].name, name)) return &t->opts[k];
    return NULL;
}

/* 1 when arg names o (flag, alias or deprecated flag; the last warns). */
static int flag_matches(const MfOpt *o, const char *arg) {
    char f[96];
    flag_of(o->name, f, sizeof f);
    if (!strcmp(f, arg) || (o->alias && !strcmp(o->alias, arg))) return 1;
    if (o->deprecated) {
        flag_of(o->deprecated, f, sizeof f);
        if (!strcmp(f, arg)) {
            char now[96];
            flag_of(o->name, now, sizeof now);
            mf_log_warn("%s is deprecated: use %s (same meaning)", arg, now);
            return 1;
        }
    }
    return 0;
}

int mf_opts_parse_arg(const MfOptTable *t, void *obj, int argc, char **argv, int *i) {
    const char *a = argv[*i];
    if (a[0] != '-') return 0;
    for (int k = 0; k < t->n; ++k) {
        const MfOpt *o = &t->opts[k];
        if (!flag_matches(o, a)) continue;
        if (o->type == MF_OPT_BOOL) {
            put_num(o, obj, 1.0);
            return 1;
        }
        if (*i + 1 >= argc) return mf_fail(MF_EARG, "option %s needs a value", a), -1;
        const char *s = argv[++*i];
        if (o->type == MF_OPT_STR || o->type == MF_OPT_ENUM) return set_str(o, obj, s, a) ? -1 : 1;
        char *end;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || *end) return mf_fail(MF_EARG, "option %s: '%s' is not a number", a, s), -1;
        return set_num(o, obj, v, a) ? -1 : 1;
    }
    return 0;
}

int mf_opts_apply_json(const MfOptBind *b, int nb, const cJSON *root, const char *file) {
    if (!cJSON_IsObject(root)) return mf_fail(MF_EFORMAT, "%s: a config file is a JSON object", file);
    for (const cJSON *it = root->child; it; it = it->next) {
        if (!strcmp(it->string, "comment") || it->string[0] == '_') continue;
        const MfOpt *o = NULL;
        void *obj = NULL;
        for (int j = 0; j < nb && !o; ++j)
            for (int k = 0; k < b[j].table->n && !o; ++k) {
                const MfOpt *c = &b[j].table->opts[k];
                if (!strcmp(c->name, it->string)) o = c, obj = b[j].obj;
                else if (c->deprecated && !strcmp(c->deprecated, it->string)) {
                    mf_log_warn("%s: key '%s' is deprecated: use '%s' (same meaning)", file, it->string, c->name);
                    o = c, obj = b[j].obj;
                }
            }
        if (!o) return mf_fail(MF_EFORMAT, "%s: unknown option '%s' (keys are the flags' names with underscores)", file, it->string);
        char who[256];
        snprintf(who, sizeof who, "%s: %s", file, it->string);
        if (cJSON_IsNull(it)) { /* null: not given (the default) */
            if (o->type == MF_OPT_STR) *(const char **)((char *)obj + o->off) = o->def_str;
            else put_num(o, obj, o->def);
        } else if (o->type == MF_OPT_STR || o->type == MF_OPT_ENUM) {
            if (!cJSON_IsString(it)) return mf_fail(MF_EFORMAT, "%s: expected a string", who);
            if (set_str(o, obj, it->valuestring, who)) return MF_EARG;
        } else if (o->type == MF_OPT_BOOL && cJSON_IsBool(it)) {
            put_num(o, obj, cJSON_IsTrue(it) ? 1.0 : 0.0);
        } else {
            if (!cJSON_IsNumber(it)) return mf_fail(MF_EFORMAT, "%s: expected a number", who);
            if (set_num(o, obj, it->valuedouble, who)) return MF_EARG;
        }
    }
    return MF_OK;
}

int mf_opts_parse(const MfOptBind *b, int nb, int argc, char **argv, int max_pos, MfOptParse *p) {
    memset(p, 0, sizeof *p);
    const char *config = NULL;
    for (int i = 1; i < argc; ++i)
        if (!strcmp(argv[i], "--config")) {
            if (i + 1 >= argc) return mf_fail(MF_EARG, "option --config needs a value");
            if (config) return mf_fail(MF_EARG, "--config given twice (%s, %s)", config, argv[i + 1]);
            config = argv[++i];
        }
    if (config) {
        int rc = mf_json_load(config, &p->config);
        if (!rc) rc = mf_opts_apply_json(b, nb, p->config, config);
        if (rc) return rc;
    }
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (!strcmp(a, "--config")) {
            ++i;
            continue;
        }
        if (!strcmp(a, "--print-config")) {
            p->print_config = 1;
            continue;
        }
        int r = 0;
        for (int j = 0; j < nb && !r; ++j) r = mf_opts_parse_arg(b[j].table, b[j].obj, argc, argv, &i);
        if (r < 0) return MF_EARG;
        if (r) continue;
        if (a[0] == '-' && a[1]) return mf_fail(MF_EARG, "unknown option %s (see mf %s --help)", a, argv[0]);
        if (p->npos >= max_pos || p->npos >= MF_OPTS_MAX_POS)
            return max_pos == 0 ? mf_fail(MF_EARG, "unexpected argument '%s' (see mf %s --help)", a, argv[0])
                                : mf_fail(MF_EARG, "too many arguments ('%s'; see mf %s --help)", a, argv[0]);
        p->pos[p->npos++] = a;
    }
    return MF_OK;
}

void mf_opts_parse_free(MfOptParse *p) {
    cJSON_Delete(p->config);
    memset(p, 0, sizeof *p);
}

int mf_opts_check(const MfOptTable *t, const void *obj) {
    for (int k = 0; k < t->n; ++k) {
        const MfOpt *o = &t->opts[k];
        char f[96];
        flag_of(o->name, f, sizeof f);
        if (o->type == MF_OPT_STR) {
            const char *s = *(const char *const *)((const char *)obj + o->off);
            if (!choice_ok(o, s)) return mf_fail(MF_EARG, "%s '%s': expected one of %s", f, s, o->choices);
            continue;
        }
        if (o->type == MF_OPT_ENUM) {
            char nb[64];
            int v = *(const int *)((const char *)obj + o->off);
            if (!strcmp(choice_name(o, v, nb, sizeof nb), "?")) return mf_fail(MF_EARG, "%s: value %d is not one of %s", f, v, o->choices);
            continue;
        }
        double v = get_num(o, obj);
        if (v == o->def) continue; /* the default: in range, or "not given" */
        char vs[32], rs[80];
        fmt_num(vs, sizeof vs, o, v);
        fmt_range(rs, sizeof rs, o);
        /* a float field holds its bounds rounded to float (0.01 is stored as 0.0099999998) */
        double lo = o->type == MF_OPT_FLOAT ? (double)(float)o->min : o->min, hi = o->type == MF_OPT_FLOAT ? (double)(float)o->max : o->max;
        if (!(v >= lo && v <= hi)) return mf_fail(MF_EARG, "%s %s: outside the allowed range %s", f, vs, rs);
    }
    return MF_OK;
}

void mf_opts_usage(MfStrBuf *b, const MfOptTable *t) {
    if (t->title) mf_sb_printf(b, "%s:\n", t->title);
    for (int k = 0; k < t->n; ++k) {
        const MfOpt *o = &t->opts[k];
        char f[96], left[160], dv[64], rs[80];
        flag_of(o->name, f, sizeof f);
        const char *meta = o->meta ? o->meta : o->type == MF_OPT_STR || o->type == MF_OPT_ENUM ? "S" : o->type == MF_OPT_FLOAT ? "X" : "N";
        if (o->type == MF_OPT_BOOL) snprintf(left, sizeof left, "%s%s%s", o->alias ? o->alias : "", o->alias ? ", " : "", f);
        else snprintf(left, sizeof left, "%s%s%s %s", o->alias ? o->alias : "", o->alias ? ", " : "", f, meta);
        mf_sb_printf(b, "  %-24s %s", left, o->doc);
        if (o->type == MF_OPT_STR) {
            if (o->choices) mf_sb_printf(b, " (%s; default %s)", o->choices, o->def_str ? o->def_str : o->unset ? o->unset : "none");
            else if (o->def_str || o->unset) mf_sb_printf(b, " (default %s)", o->def_str ? o->def_str : o->unset);
        } else if (o->type == MF_OPT_ENUM) {
            mf_sb_printf(b, " (%s; default %s)", o->choices, choice_name(o, (int)o->def, dv, sizeof dv));
        } else if (o->type == MF_OPT_BOOL) {
            if (o->def != 0) mf_sb_printf(b, " (on by default)");
        } else {
            fmt_num(dv, sizeof dv, o, o->def);
            fmt_range(rs, sizeof rs, o);
            int in = o->def >= o->min && o->def <= o->max;
            mf_sb_printf(b, " (default %s, range %s)", in || !o->unset ? dv : o->unset, rs);
        }
        if (o->deprecated) {
            flag_of(o->deprecated, f, sizeof f);
            mf_sb_printf(b, "; %s: deprecated alias", f);
        }
        mf_sb_printf(b, "\n");
    }
}

void mf_opts_usage_text(char *buf, size_t cap, const char *head, const MfOptTable *const *tables, int nt, const char *tail) {
    MfStrBuf b = {0};
    mf_sb_printf(&b, "%s", head ? head : "");
    for (int i = 0; i < nt; ++i) mf_opts_usage(&b, tables[i]);
    mf_sb_printf(&b, "Config files:\n"
                     "  %-24s apply a JSON object of options first (keys: the flags' names with underscores;\n"
                     "  %-24s null: not given); flags given on the command line override it\n"
                     "  %-24s print the options after --config and flags as JSON (a config file) and stop\n",
                 "--config FILE", "", "--print-config");
    if (tail) mf_sb_printf(&b, "%s", tail);
    char *s = mf_sb_take(&b);
    snprintf(buf, cap, "%s", s ? s : "(usage text: out of memory)\n");
    free(s);
}

/* The shortest decimal that reads back as the same float (0.02, not 0.0199999995529651). */
static double short_float(double v) {
    for (int digits = 6; digits <= 9; ++digits) {
        char b[40];
        snprintf(b, sizeof b, "%.*g", digits, v);
        double d = strtod(b, NULL);
        if ((float)d == (float)v) return d;
    }
    return v;
}

void mf_opts_to_json(const MfOptTable *t, const void *obj, cJSON *out) {
    for (int k = 0; k < t->n; ++k) {
        const MfOpt *o = &t->opts[k];
        if (o->type == MF_OPT_STR) {
            const char *s = *(const char *const *)((const char *)obj + o->off);
            if (s) cJSON_AddStringToObject(out, o->name, s);
            else cJSON_AddNullToObject(out, o->name);
        } else if (o->type == MF_OPT_ENUM) {
            char nb[64];
            cJSON_AddStringToObject(out, o->name, choice_name(o, (int)get_num(o, obj), nb, sizeof nb));
        } else if (o->type == MF_OPT_BOOL) {
            cJSON_AddBoolToObject(out, o->name, get_num(o, obj) != 0);
        } else {
            double v = get_num(o, obj);
            if (v == o->def && !(o->def >= o->min && o->def <= o->max)) cJSON_AddNullToObject(out, o->name); /* not given */
            else if (o->type == MF_OPT_FLOAT) cJSON_AddNumberToObject(out, o->name, short_float(v));
            else cJSON_AddNumberToObject(out, o->name, v);
        }
    }
}
