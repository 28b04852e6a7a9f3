/* mf_test: a tiny test framework (after Redis's testhelp.h).
 *
 * Each test_<folder>_<module>.c defines tests with MF_TEST(name) { ... }; they register themselves at
 * start-up, so adding a file to tests/ is all it takes. Checks count failures and print the
 * file, line and values; a test with any failed check fails. MF_SKIP(reason) ends a test as
 * skipped (e.g. ../shared missing). The runner prints one line per test and, last,
 * "N passed, N failed, N skipped"; it exits non-zero if any test failed.
 *
 *   ./mf_tests            run all tests
 *   ./mf_tests brdf env   run the tests whose name contains any of the words */
#ifndef MF_TEST_H
#define MF_TEST_H

#include <math.h>
#include <stdio.h>

typedef void (*MfTestFn)(void);
void mf_test_register(const char *name, MfTestFn fn, const char *file);
void mf_test_fail_at(const char *file, int line, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
void mf_test_skip(const char *reason);
int mf_test_failed_now(void);
/* A scratch directory for this test run (created on first use, removed at exit when all pass). */
const char *mf_test_tmpdir(void);
/* "tmpdir/name" in a static rotating buffer (8 slots: copy it, or use mf_test_path_to, to keep it). */
const char *mf_test_path(const char *name);
/* Writes "tmpdir/" followed by the printf-formatted name into dst (cap bytes); a path that does not
 * fit fails the calling test (at its file and line) and is left cut short. */
#define mf_test_path_to(dst, cap, ...) mf_test_path_at(__FILE__, __LINE__, (dst), (cap), __VA_ARGS__)
void mf_test_path_at(const char *file, int line, char *dst, size_t cap, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
/* 1 when $MF_BIN (the mf binary, set by make test) names a file; else 0, and the test is marked
 * skipped (MF_BIN unset) or failed at file:line (MF_BIN names no file). Use MF_NEED_BIN(). */
int mf_test_need_bin(const char *file, int line);
/* Runs `$MF_BIN args` with stdout to stdout_path (NULL: /dev/null) and stderr captured into err
 * (cap bytes); returns the exit code, -1 when killed by a signal (e.g. an abort in a library). */
int mf_test_run_mf(const char *args, const char *stdout_path, char *err, size_t cap);
/* max |a[i] - b[i]| over n floats (in double). */
double mf_test_max_abs_diff(const float *a, const float *b, size_t n);
/* Runs the printf-formatted shell command; 0 when it exits 0, else 1. */
int mf_test_sh(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

#define MF_TEST(name)                                                                  \
    static void test_##name(void);                                                     \
    __attribute__((constructor)) static void register_##name(void) {                   \
        mf_test_register(#name, test_##name, __FILE__);                                \
    }                                                                                  \
    static void test_##name(void)

#define CHECK(cond)                                                                    \
    do {                                                                               \
        if (!(cond)) mf_test_fail_at(__FILE__, __LINE__, "CHECK(%s)", #cond);          \
    } while (0)

#define CHECK_MSG(cond, ...)                                                           \
    do {                                                                               \
        if (!(cond)) mf_test_fail_at(__FILE__, __LINE__, __VA_ARGS__);                 \
    } while (0)

/* |a - b| <= tol, and both finite. */
#define CHECK_NEAR(a, b, tol)                                                          \
    do {                                                                               \
        double a_ = (double)(a), b_ = (double)(b), t_ = (double)(tol);                 \
        if (!(isfinite(a_) && isfinite(b_) && fabs(a_ - b_) <= t_))                    \
            mf_test_fail_at(__FILE__, __LINE__, "CHECK_NEAR(%s, %s): %.9g vs %.9g, tol %.3g", #a, #b, a_, b_, t_); \
    } while (0)

/* Status code MF_OK expected; prints mf_error() otherwise. */
#define CHECK_OK(expr)                                                                 \
    do {                                                                               \
        int rc_ = (expr);                                                              \
        if (rc_ != 0) mf_test_fail_at(__FILE__, __LINE__, "%s -> %d: %s", #expr, rc_, mf_error()); \
    } while (0)

/* Failure expected, with a message containing `needle`. */
#define CHECK_ERR(expr, needle)                                                        \
    do {                                                                               \
        mf_error_clear();                                                              \
        int rc_ = (expr);                                                              \
        if (rc_ == 0) mf_test_fail_at(__FILE__, __LINE__, "%s: expected failure", #expr); \
        else if (!strstr(mf_error(), (needle)))                                        \
            mf_test_fail_at(__FILE__, __LINE__, "%s: message '%s' lacks '%s'", #expr, mf_error(), (needle)); \
    } while (0)

/* Ends the test unless $MF_BIN names the mf binary (skipped when unset, failed when no file). */
#define MF_NEED_BIN()                                                                  \
    do {                                                                               \
        if (!mf_test_need_bin(__FILE__, __LINE__)) return;                             \
    } while (0)

#define MF_SKIP(reason)                                                                \
    do {                                                                               \
        mf_test_skip(reason);                                                          \
        return;                                                                        \
    } while (0)

#endif
