#include "io/mf_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"

int mf_json_line_of(const char *text, const char *pos) {
    int line = 1;
    for (const char *p = text; p < pos && *p; ++p) line += *p == '\n';
    return line;
}

int mf_json_parse(const char *name, const char *text, size_t len, cJSON **out) {
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (root) {
        /* Only whitespace may follow the value. */
        const char *p = end;
        while (p && p < text + len && (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')) ++p;
        if (p && p < text + len && *p) {
            cJSON_Delete(root);
            return mf_fail(MF_EFORMAT, "%s: invalid JSON near line %d (text after the value)", name, mf_json_line_of(text, p));
        }
        *out = root;
        return MF_OK;
    }
    if (!end || end < text || end > text + len) end = text + len;
    return mf_fail(MF_EFORMAT, "%s: invalid JSON near line %d", name, mf_json_line_of(text, end));
}

int mf_json_load(const char *path, cJSON **out) {
    char *text = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &text, &len);
    if (rc) return rc;
    rc = mf_json_parse(path, text, len, out);
    free(text);
    return rc;
}

/* A growing output buffer for the printer. */
typedef struct {
    char *p;
    size_t n, cap;
    int bad;
} Buf;

static void put(Buf *b, const char *s, size_t n) {
    if (b->bad) return;
    if (b->n + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap * 2 : 4096;
        while (cap < b->n + n + 1) cap *= 2;
        char *q = realloc(b->p, cap);
        if (!q) { b->bad = 1; return; }
        b->p = q;
        b->cap = cap;
    }
    memcpy(b->p + b->n, s, n);
    b->n += n;
    b->p[b->n] = '\0';
}
static void puts_(Buf *b, const char *s) { put(b, s, strlen(s)); }
static void indent(Buf *b, int d) { for (int i = 0; i < d; ++i) put(b, "\t", 1); }

static void put_string(Buf *b, const char *s) {
    put(b, "\"", 1);
    for (const unsigned char *c = (const unsigned char *)(s ? s : ""); *c; ++c) {
        char e[8];
        switch (*c) {
        case '"': puts_(b, "\\\""); break;
        case '\\': puts_(b, "\\\\"); break;
        case '\b': puts_(b, "\\b"); break;
        case '\f': puts_(b, "\\f"); break;
        case '\n': puts_(b, "\\n"); break;
        case '\r': puts_(b, "\\r"); break;
        case '\t': puts_(b, "\\t"); break;
        default:
            if (*c < 0x20) { snprintf(e, sizeof e, "\\u%04x", *c); puts_(b, e); }
            else put(b, (const char *)c, 1);
        }
    }
    put(b, "\"", 1);
}

/* Shortest of %.15g / %.17g that reads back as the same double (cJSON's own printer only
 * round-trips to within DBL_EPSILON); non-finite numbers become null as in cJSON. */
static void put_number(Buf *b, double v) {
    char s[40];
    if (!isfinite(v)) { puts_(b, "null"); return; }
    snprintf(s, sizeof s, "%.15g", v);
    if (strtod(s, NULL) != v) snprintf(s, sizeof s, "%.17g", v);
    puts_(b, s);
}

static void print_item(Buf *b, const cJSON *it, int d) {
    if (cJSON_IsNumber(it)) put_number(b, it->valuedouble);
    else if (cJSON_IsString(it)) put_string(b, it->valuestring);
    else if (cJSON_IsTrue(it)) puts_(b, "true");
    else if (cJSON_IsFalse(it)) puts_(b, "false");
    else if (cJSON_IsRaw(it)) puts_(b, it->valuestring ? it->valuestring : "null");
    else if (cJSON_IsArray(it)) {
        /* Arrays of scalars stay on one line (matrices read row by row). */
        int flat = 1;
        for (const cJSON *e = it->child; e; e = e->next) flat &= !cJSON_IsArray(e) && !cJSON_IsObject(e);
        put(b, "[", 1);
        for (const cJSON *e = it->child; e; e = e->next) {
            if (!flat) { put(b, "\n", 1); indent(b, d + 1); }
            print_item(b, e, d + 1);
            if (e->next) puts_(b, flat ? ", " : ",");
        }
        if (!flat && it->child) { put(b, "\n", 1); indent(b, d); }
        put(b, "]", 1);
    } else if (cJSON_IsObject(it)) {
        put(b, "{", 1);
        for (const cJSON *e = it->child; e; e = e->next) {
            put(b, "\n", 1);
            indent(b, d + 1);
            put_string(b, e->string);
            puts_(b, ": ");
            print_item(b, e, d + 1);
            if (e->next) put(b, ",", 1);
        }
        if (it->child) { put(b, "\n", 1); indent(b, d); }
        put(b, "}", 1);
    } else puts_(b, "null");
}

int mf_json_save(const char *path, const cJSON *root) {
    Buf b = {0};
    print_item(&b, root, 0);
    put(&b, "\n", 1);
    if (b.bad) { free(b.p); return mf_fail(MF_ENOMEM, "%s: out of memory printing JSON", path); }
    int rc = mf_write_file(path, b.p, b.n);
    free(b.p);
    return rc;
}

/* "file: where.key" prefix for messages. */
static void label(char *buf, size_t cap, const char *file, const char *where, const char *key) {
    int has = where && where[0];
    snprintf(buf, cap, "%s: %s%s%s", file, has ? where : "", has ? "." : "", key);
}

static const cJSON *member(const cJSON *obj, const char *key) {
    if (!obj || !cJSON_IsObject(obj)) return NULL;
    return cJSON_GetObjectItemCaseSensitive(obj, key);
}

static int need(const char *file, const char *where, const cJSON *obj, const char *key, const cJSON **it) {
    char lb[1024];
    if (!obj || !cJSON_IsObject(obj)) {
        int has = where && where[0];
        return mf_fail(MF_EFORMAT, "%s: %s: expected an object", file, has ? where : "(top level)");
    }
    *it = member(obj, key);
    if (!*it) {
        label(lb, sizeof lb, file, where, key);
        return mf_fail(MF_EFORMAT, "%s: missing", lb);
    }
    return MF_OK;
}

static int as_number(const char *file, const char *where, const char *key, const cJSON *it, double *out) {
    char lb[1024];
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble)) {
        label(lb, sizeof lb, file, where, key);
        return mf_fail(MF_EFORMAT, "%s: expected a finite number", lb);
    }
    *out = it->valuedouble;
    return MF_OK;
}

int mf_json_number(const char *file, const char *where, const cJSON *obj, const char *key, double *out) {
    const cJSON *it;
    int rc = need(file, where, obj, key, &it);
    return rc ? rc : as_number(file, where, key, it, out);
}

int mf_json_int(const char *file, const char *where, const cJSON *obj, const char *key, int *out) {
    double v;
    int rc = mf_json_number(file, where, obj, key, &v);
    if (rc) return rc;
    if (v != floor(v) || v < -2147483648.0 || v > 2147483647.0) {
        char lb[1024];
        label(lb, sizeof lb, file, where, key);
        return mf_fail(MF_EFORMAT, "%s: expected an integer, got %g", lb, v);
    }
    *out = (int)v;
    return MF_OK;
}

int mf_json_string(const char *file, const char *where, const cJSON *obj, const char *key, const char **out) {
    const cJSON *it;
    int rc = need(file, where, obj, key, &it);
    if (rc) return rc;
    if (!cJSON_IsString(it) || !it->valuestring) {
        char lb[1024];
        label(lb, sizeof lb, file, where, key);
        return mf_fail(MF_EFORMAT, "%s: expected a string", lb);
    }
    *out = it->valuestring;
    return MF_OK;
}

int mf_json_array(const char *file, const char *where, const cJSON *obj, const char *key, const cJSON **arr, int *n) {
    const cJSON *it;
    int rc = need(file, where, obj, key, &it);
    if (rc) return rc;
    if (!cJSON_IsArray(it)) {
        char lb[1024];
        label(lb, sizeof lb, file, where, key);
        return mf_fail(MF_EFORMAT, "%s: expected an array", lb);
    }
    *arr = it;
    *n = cJSON_GetArraySize(it);
    return MF_OK;
}

/* Fills tmp (rows x cols, or cols when rows == 0) from it; 0 if the shape or a value is wrong. */
static int fill_numbers(const cJSON *it, int rows, int cols, double *tmp) {
    if (!cJSON_IsArray(it)) return 0;
    if (rows == 0) {
        if (cJSON_GetArraySize(it) != cols) return 0;
        int i = 0;
        for (const cJSON *e = it->child; e; e = e->next, ++i) {
            if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble)) return 0;
            tmp[i] = e->valuedouble;
        }
        return 1;
    }
    if (cJSON_GetArraySize(it) != rows) return 0;
    int r = 0;
    for (const cJSON *row = it->child; row; row = row->next, ++r)
        if (!fill_numbers(row, 0, cols, tmp + (size_t)r * cols)) return 0;
    return 1;
}

int mf_json_numbers(const char *file, const char *where, const cJSON *obj, const char *key, int rows, int cols, double *out) {
    if (rows < 0 || cols <= 0 || (size_t)(rows ? rows : 1) * cols > 4096) return mf_fail(MF_EARG, "%s: %s: bad shape %dx%d", file, key, rows, cols);
    const cJSON *it;
    int rc = need(file, where, obj, key, &it);
    if (rc) return rc;
    double tmp[4096];
    if (!fill_numbers(it, rows, cols, tmp)) {
        char lb[1024];
        label(lb, sizeof lb, file, where, key);
        if (rows) return mf_fail(MF_EFORMAT, "%s: expected %dx%d numbers", lb, rows, cols);
        return mf_fail(MF_EFORMAT, "%s: expected %d numbers", lb, cols);
    }
    memcpy(out, tmp, sizeof(double) * (size_t)(rows ? rows : 1) * cols);
    return MF_OK;
}

int mf_json_floats(const char *file, const char *where, const cJSON *obj, const char *key, int rows, int cols, float *out) {
    double tmp[4096];
    if (rows < 0 || cols <= 0 || (size_t)(rows ? rows : 1) * cols > 4096) return mf_fail(MF_EARG, "%s: %s: bad shape %dx%d", file, key, rows, cols);
    int rc = mf_json_numbers(file, where, obj, key, rows, cols, tmp);
    if (rc) return rc;
    for (int i = 0; i < (rows ? rows : 1) * cols; ++i) out[i] = (float)tmp[i];
    return MF_OK;
}

int mf_json_number_opt(const char *file, const char *where, const cJSON *obj, const char *key, double dflt, double *out) {
    const cJSON *it = member(obj, key);
    if (!it || cJSON_IsNull(it)) {
        *out = dflt;
        return MF_OK;
    }
    return as_number(file, where, key, it, out);
}

int mf_json_string_opt(const char *file, const char *where, const cJSON *obj, const char *key, const char *dflt,
                       const char **out) {
    const cJSON *it = member(obj, key);
    if (!it || cJSON_IsNull(it)) {
        *out = dflt;
        return MF_OK;
    }
    return mf_json_string(file, where, obj, key, out);
}
