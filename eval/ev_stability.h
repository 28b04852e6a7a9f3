/* ev_stability: the numerical-stability grid (issue 18, item 1), a first, reduced version.
 *
 * Each cell is one `mf` command run as a child process (fork + exec through /bin/sh, so the
 * child IS mf and wait4's ru_maxrss is mf's peak RSS). Per cell: exit code, wall seconds, peak
 * RSS, whether any EXR under the cell's output folder holds a NaN/Inf (mf_exr_read refuses them),
 * and, for cells expected to be refused, whether stderr names the option. */
#ifndef EV_STABILITY_H
#define EV_STABILITY_H

#include <stddef.h>

typedef struct {
    const char *name;   /* cell label, e.g. "baseline lr=1 (max)" */
    const char *kind;   /* "render", "baseline" or "materialfusion" */
    const char *args;   /* extra arguments appended to the cell's command */
    const char *refuse; /* NULL: must succeed; else the option name a refusal must mention */
} EvStabCell;

typedef struct {
    int exit_code;      /* child exit code; -1 on a signal */
    double wall_s;      /* wall seconds */
    long peak_rss_kb;   /* child's peak resident set size, KiB */
    int nonfinite;      /* EXR files under the cell's output with a NaN/Inf */
    int exr_files;      /* EXR files scanned */
    int ok;             /* 1 when the cell behaved as expected (ran, or refused naming the option) */
} EvStabResult;

/* Runs `cmd` (a /bin/sh command line, run with exec so the child is the command itself) with
 * stderr to `stderr_path`; fills exit_code, wall_s and peak_rss_kb. */
int ev_stab_run(const char *cmd, const char *stderr_path, EvStabResult *r);

/* Counts the .exr files under `dir` (recursively) and those that hold a non-finite value. */
int ev_stab_scan_dir(const char *dir, int *exr_files, int *nonfinite);

/* Runs the grid on the tiny split: `mf gen --split tiny` into work/scene, renders its views,
 * then every cell of ev_stab_cells(); recon cells run `iters` iterations (memory row: 50 and
 * `mem_iters`). Writes out_dir/README.md and out_dir/grid.csv atomically. quick != 0 runs the
 * subset used by `make test` (no MaterialFusion cells, no memory row). */
int ev_stab_grid(const char *mf_bin, const char *work, const char *out_dir, int iters, int mem_iters, int quick,
                 EvStabResult *results, int cap, int *n_out);

/* The grid's cells; *n gets their count. */
const EvStabCell *ev_stab_cells(int *n);

#endif
