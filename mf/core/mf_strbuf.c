#include "core/mf_strbuf.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"

void mf_sb_printf(MfStrBuf *b, const char *fmt, ...) {
    if (b->oom) return;
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (w < 0) { b->oom = 1; return; }
    if (b->n + (size_t)w + 1 > b->cap) {
        size_t cap = (b->cap ? 2 * b->cap : 1024) + (size_t)w + 1;
        char *s = realloc(b->s, cap);
        if (!s) { b->oom = 1; return; }
        b->s = s;
        b->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(b->s + b->n, b->cap - b->n, fmt, ap);
    va_end(ap);
    b->n += (size_t)w;
}

void mf_sb_html(MfStrBuf *b, const char *s) {
    for (; *s; ++s) {
        if (*s == '<') mf_sb_printf(b, "&lt;");
        else if (*s == '>') mf_sb_printf(b, "&gt;");
        else if (*s == '&') mf_sb_printf(b, "&amp;");
        else if (*s == '"') mf_sb_printf(b, "&quot;");
        else mf_sb_printf(b, "%c", *s);
    }
}

void mf_sb_free(MfStrBuf *b) {
    free(b->s);
    memset(b, 0, sizeof *b);
}

char *mf_sb_take(MfStrBuf *b) {
    char *s = b->oom ? NULL : b->s;
    if (b->oom) free(b->s);
    if (s == NULL && !b->oom) s = calloc(1, 1);
    memset(b, 0, sizeof *b);
    return s;
}

int mf_sb_write(MfStrBuf *b, const char *path) {
    if (b->oom) {
        mf_sb_free(b);
        return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    }
    int rc = mf_write_file(path, b->s ? b->s : "", b->n);
    mf_sb_free(b);
    return rc;
}
