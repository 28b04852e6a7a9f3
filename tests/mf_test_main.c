#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "mf_test.h"
#include "nn/mf_nn.h"

#define MAX_TESTS 1024
typedef struct { const char *name; MfTestFn fn; const char *file; } TestEntry;
static TestEntry g_tests[MAX_TESTS];
static int g_ntests;
static int g_cur_failed, g_cur_skipped;
static char g_skip_reason[256];
static char g_tmpdir[256];

void mf_test_register(const char *name, MfTestFn fn, const char *file) {
    if (g_ntests < MAX_TESTS) g_tests[g_ntests++] = (TestEntry){name, fn, file};
}

void mf_test_fail_at(const char *file, int line, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stdout, "    %s:%d: ", file, line);
    vfprintf(stdout, fmt, ap);
    fprintf(stdout, "\n");
    va_end(ap);
    ++g_cur_failed;
}

void mf_test_skip(const char *reason) {
    g_cur_skipped = 1;
    snprintf(g_skip_reason, sizeof g_skip_reason, "%s", reason);
}

int mf_test_failed_now(void) { return g_cur_failed; }

const char *mf_test_tmpdir(void) {
    if (!g_tmpdir[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(g_tmpdir, sizeof g_tmpdir, "%s/mf_tests.%ld", base ? base : "/tmp", (long)getpid());
        mf_mkdirs(g_tmpdir);
    }
    return g_tmpdir;
}

const char *mf_test_path(const char *name) {
    static _Thread_local char bufs[8][1024];
    static _Thread_local int k;
    char *b = bufs[k++ & 7];
    mf_test_path_to(b, sizeof bufs[0], "%s", name);
    return b;
}

void mf_test_path_at(const char *file, int line, char *dst, size_t cap, const char *fmt, ...) {
    int n = snprintf(dst, cap, "%s/", mf_test_tmpdir());
    if (n >= 0 && (size_t)n < cap) {
        va_list ap;
        va_start(ap, fmt);
        n += vsnprintf(dst + n, cap - (size_t)n, fmt, ap);
        va_end(ap);
    }
    if (n < 0 || (size_t)n >= cap) mf_test_fail_at(file, line, "scratch path '%s' (cut short) does not fit in %zu bytes", dst, cap);
}

double mf_test_max_abs_diff(const float *a, const float *b, size_t n) {
    double d = 0.0;
    for (size_t i = 0; i < n; ++i) d = fmax(d, fabs((double)a[i] - b[i]));
    return d;
}

int mf_test_sh(const char *fmt, ...) {
    char cmd[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cmd, sizeof cmd, fmt, ap);
    va_end(ap);
    return system(cmd) == 0 ? 0 : 1;
}

int mf_test_need_bin(const char *file, int line) {
    const char *bin = getenv("MF_BIN");
    if (!bin) mf_test_skip("MF_BIN not set (run through make test)");
    else if (!mf_file_exists(bin)) mf_test_fail_at(file, line, "MF_BIN=%s: no such file", bin);
    return bin && mf_file_exists(bin);
}

int mf_test_run_mf(const char *args, const char *stdout_path, char *err, size_t cap) {
    char cmd[8192], errf[1024];
    mf_test_path_to(errf, sizeof errf, "mf_stderr.txt");
    snprintf(cmd, sizeof cmd, "%s %s >%s 2>%s", getenv("MF_BIN"), args, stdout_path ? stdout_path : "/dev/null", errf);
    int st = system(cmd);
    err[0] = 0;
    FILE *f = fopen(errf, "r");
    if (f) {
        size_t n = fread(err, 1, cap - 1, f);
        err[n] = 0;
        fclose(f);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int cmp_entry(const void *a, const void *b) {
    const TestEntry *x = a, *y = b;
    int c = strcmp(x->file, y->file);
    return c ? c : strcmp(x->name, y->name);
}

static int selected(const char *name, int argc, char **argv) {
    if (argc <= 1) return 1;
    for (int i = 1; i < argc; ++i)
        if (strstr(name, argv[i])) return 1;
    return 0;
}

int main(int argc, char **argv) {
    if (!getenv("MF_LOG")) mf_log_set_level(MF_LOG_WARN);
    if (mf_nn_backend_from_env()) { /* MF_NN_BACKEND=blas|dnnl, as for mf (a DNNL=1 build's default: dnnl) */
        fprintf(stderr, "mf_tests: %s\n", mf_error());
        return 2;
    }
    qsort(g_tests, (size_t)g_ntests, sizeof g_tests[0], cmp_entry);
    int passed = 0, failed = 0, skipped = 0;
    for (int i = 0; i < g_ntests; ++i) {
        if (!selected(g_tests[i].name, argc, argv)) continue;
        g_cur_failed = 0;
        g_cur_skipped = 0;
        double t0 = mf_now();
        g_tests[i].fn();
        double dt = mf_now() - t0;
        if (g_cur_failed) {
            ++failed;
            printf("[FAIL] %s (%s, %.2fs)\n", g_tests[i].name, g_tests[i].file, dt);
        } else if (g_cur_skipped) {
            ++skipped;
            printf("[skip] %s: %s\n", g_tests[i].name, g_skip_reason);
        } else {
            ++passed;
            printf("[ ok ] %s (%.2fs)\n", g_tests[i].name, dt);
        }
        fflush(stdout);
    }
    if (g_tmpdir[0] && failed == 0) {
        char cmd[512];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_tmpdir);
        if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", g_tmpdir);
    }
    printf("%d passed, %d failed, %d skipped\n", passed, failed, skipped);
    return failed ? 1 : 0;
}
