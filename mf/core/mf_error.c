#include "mf_error.h"

#include <stdio.h>
#include <string.h>

#define MF_ERRBUF 1024
static _Thread_local char g_msg[MF_ERRBUF];

int mf_vfail(int code, const char *fmt, va_list ap) {
    vsnprintf(g_msg, sizeof g_msg, fmt, ap);
    return code;
}

int mf_fail(int code, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    mf_vfail(code, fmt, ap);
    va_end(ap);
    return code;
}

int mf_fail_prefix(int code, const char *fmt, ...) {
    char prefix[MF_ERRBUF], old[MF_ERRBUF];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, g_msg, sizeof old);
    size_t n = strnlen(prefix, sizeof prefix - 1);
    memcpy(g_msg, prefix, n);
    size_t k = n;
    if (k + 2 < sizeof g_msg) { g_msg[k++] = ':'; g_msg[k++] = ' '; }
    size_t m = strnlen(old, sizeof old);
    if (k + m >= sizeof g_msg) m = sizeof g_msg - 1 - k;
    memcpy(g_msg + k, old, m);
    g_msg[k + m] = '\0';
    return code;
}

const char *mf_error(void) { return g_msg; }

void mf_error_clear(void) { g_msg[0] = '\0'; }
