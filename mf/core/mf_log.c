#define _POSIX_C_SOURCE 200809L
#include "mf_log.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int g_level = -1;

static void log_init(void) {
    if (g_level >= 0) return;
    const char *e = getenv("MF_LOG");
    g_level = MF_LOG_INFO;
    if (!e) return;
    if (!strcmp(e, "error")) g_level = MF_LOG_ERROR;
    else if (!strcmp(e, "warn")) g_level = MF_LOG_WARN;
    else if (!strcmp(e, "debug")) g_level = MF_LOG_DEBUG;
}

void mf_log_set_level(MfLogLevel level) { g_level = (int)level; }

MfLogLevel mf_log_level(void) {
    log_init();
    return (MfLogLevel)g_level;
}

void mf_log(MfLogLevel level, const char *fmt, ...) {
    static const char *names[] = {"error", "warn", "info", "debug"};
    log_init();
    if ((int)level > g_level) return;
    char buf[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    fprintf(stderr, "mf %s: %s\n", names[level], buf);
}

double mf_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double mf_cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

MfStageClock mf_stage_clock(void) {
    MfStageClock c = {mf_now(), mf_cpu_now()};
    return c;
}

void mf_stage_lap(MfStageTime *acc, MfStageClock *c) {
    MfStageClock n = mf_stage_clock();
    if (acc) acc->wall += n.wall - c->wall, acc->cpu += n.cpu - c->cpu;
    *c = n;
}

static void progress_draw(MfProgress *p, int final) {
    double now = mf_now();
    if (!final && now - p->t_last_draw < 0.1) return;
    p->t_last_draw = now;
    double frac = p->total ? (double)p->done / (double)p->total : 1.0;
    if (frac > 1.0) frac = 1.0;
    int width = 30, fill = (int)(frac * width);
    char bar[64];
    for (int i = 0; i < width; ++i) bar[i] = i < fill ? '#' : '.';
    bar[width] = '\0';
    double el = now - p->t_start;
    double eta = frac > 0 ? el * (1.0 - frac) / frac : 0.0;
    fprintf(stderr, "\r%s [%s] %zu/%zu %.0fs eta %.0fs%s", p->label, bar, p->done, p->total, el, eta,
            final ? "\n" : "");
    fflush(stderr);
}

void mf_progress_begin(MfProgress *p, const char *label, size_t total) {
    p->label = label;
    p->total = total;
    p->done = 0;
    p->t_start = mf_now();
    p->t_last_draw = 0.0;
    p->enabled = isatty(STDERR_FILENO) && mf_log_level() >= MF_LOG_INFO;
    if (p->enabled) progress_draw(p, 0);
}

void mf_progress_add(MfProgress *p, size_t n) {
#pragma omp atomic
    p->done += n;
    if (p->enabled) {
#pragma omp critical(mf_progress)
        progress_draw(p, 0);
    }
}

void mf_progress_end(MfProgress *p) {
    if (p->enabled) progress_draw(p, 1);
}
