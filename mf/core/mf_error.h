/* mf_error: the project's error convention.
 *
 * Library functions that can fail return an int status: MF_OK (0) on success, a negative
 * MfStatus otherwise. On failure they leave a human-readable message, readable with
 * mf_error(), that names the file (or argument) and what was wrong, e.g.
 *   "data/x/transforms_train.json: frames[3].transform_matrix: expected 4x4 numbers".
 * Output parameters are left untouched on failure. The message is thread-local.
 * Library code never prints and never exits; only main() does. */
#ifndef MF_ERROR_H
#define MF_ERROR_H

#include <stdarg.h>

typedef enum {
    MF_OK = 0,
    MF_EIO = -1,      /* file missing, unreadable, unwritable */
    MF_EFORMAT = -2,  /* file content malformed */
    MF_EARG = -3,     /* bad argument or option */
    MF_ENOMEM = -4,   /* allocation failed */
    MF_ENAN = -5,     /* NaN or Inf where finite numbers are required */
    MF_EEXT = -6      /* an external library (Embree, OIIO, ...) reported an error */
} MfStatus;

/* Sets the thread's message (printf format) and returns code, so callers write
 *   return mf_fail(MF_EIO, "%s: cannot open", path); */
int mf_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
int mf_vfail(int code, const char *fmt, va_list ap);

/* Prefixes the current message with "prefix: " (adds context while unwinding); returns code. */
int mf_fail_prefix(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The last message set on this thread ("" if none). */
const char *mf_error(void);

/* Clears the thread's message. */
void mf_error_clear(void);

#endif
