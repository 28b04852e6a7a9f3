/* mf_log: logging to stderr (never stdout), with levels, and a progress bar for long work.
 *
 * The level comes from the environment variable MF_LOG (error|warn|info|debug; default info)
 * or mf_log_set_level(). The progress bar draws only when stderr is a terminal; otherwise it
 * is silent, so logs of CI and scripts stay clean. */
#ifndef MF_LOG_H
#define MF_LOG_H

#include <stddef.h>

typedef enum { MF_LOG_ERROR = 0, MF_LOG_WARN = 1, MF_LOG_INFO = 2, MF_LOG_DEBUG = 3 } MfLogLevel;

void mf_log_set_level(MfLogLevel level);
MfLogLevel mf_log_level(void);
void mf_log(MfLogLevel level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#define mf_log_error(...) mf_log(MF_LOG_ERROR, __VA_ARGS__)
#define mf_log_warn(...) mf_log(MF_LOG_WARN, __VA_ARGS__)
#define mf_log_info(...) mf_log(MF_LOG_INFO, __VA_ARGS__)
#define mf_log_debug(...) mf_log(MF_LOG_DEBUG, __VA_ARGS__)

/* A progress bar over `total` units of work. Thread-safe mf_progress_add. */
typedef struct {
    const char *label; /* borrowed */
    size_t total;
    size_t done;
    double t_start;
    double t_last_draw;
    int enabled; /* stderr is a tty and level >= info */
} MfProgress;

void mf_progress_begin(MfProgress *p, const char *label, size_t total);
void mf_progress_add(MfProgress *p, size_t n);
void mf_progress_end(MfProgress *p);

/* Monotonic wall clock in seconds. */
double mf_now(void);
/* CPU seconds of all threads of this process (benchmarks: not counting the time other processes
 * hold the cores). */
double mf_cpu_now(void);
/* A stage's accumulated cost: wall seconds and CPU seconds of the process (all its threads). */
typedef struct {
    double wall, cpu;
} MfStageTime;
/* A running stage clock: the stamps of the last lap. */
typedef struct {
    double wall, cpu;
} MfStageClock;
MfStageClock mf_stage_clock(void);
/* Adds the time since *c's last lap to *acc (may be NULL: the time is dropped) and restarts *c. */
void mf_stage_lap(MfStageTime *acc, MfStageClock *c);

#endif
