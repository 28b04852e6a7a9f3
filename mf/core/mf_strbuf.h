/* mf_strbuf: a growing text buffer for writers of text files (tables, reports, scripts).
 * Allocation failures are remembered and reported once, at mf_sb_write / mf_sb_take. */
#ifndef MF_STRBUF_H
#define MF_STRBUF_H

#include <stddef.h>

typedef struct {
    char *s; /* owned; NUL-terminated text, or NULL while empty */
    size_t n, cap;
    int oom;
} MfStrBuf;

void mf_sb_printf(MfStrBuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Appends s with HTML's special characters escaped. */
void mf_sb_html(MfStrBuf *b, const char *s);
/* Writes the text atomically to path and frees the buffer. */
int mf_sb_write(MfStrBuf *b, const char *path);
/* Returns the text (caller frees) or NULL after an allocation failure; the buffer is emptied. */
char *mf_sb_take(MfStrBuf *b);
void mf_sb_free(MfStrBuf *b);

#endif
