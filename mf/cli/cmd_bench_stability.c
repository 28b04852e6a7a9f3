/* mf bench-stability: the numerical-stability grid (eval/ev_stability.h). A thin wrapper. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "eval/ev_stability.h"

typedef struct {
    const char *mf, *work, *out;
    EvStabOpts o;
} StabArgs;

#define A StabArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, mf, NULL, "the mf binary run as child processes (required)", .meta = "MF_BINARY"),
    MF_OPT_STR(A, work, NULL, "work folder (required)", .meta = "DIR"),
    MF_OPT_STR(A, out, NULL, "report folder (required)", .alias = "-o", .meta = "OUT_DIR"),
    MF_OPT_NAMED(A, "iters", o.iters, MF_OPT_INT, 200, 1, 10000000, "iterations of each reconstruction cell"),
    MF_OPT_NAMED(A, "mem_iters", o.mem_iters, MF_OPT_INT, 2000, 1, 10000000, "iterations of the memory row's long run (its short run: 50)"),
    MF_OPT_NAMED(A, "quick", o.quick, MF_OPT_BOOL, 0, 0, 1, "the subset make test runs (no MaterialFusion cells, no memory or seed row)"),
    MF_OPT_NAMED(A, "jobs", o.jobs, MF_OPT_INT, 0, 0, 64, "cells run at once, each with OMP_NUM_THREADS = cores / jobs (0: one per core)"),
    MF_OPT_NAMED(A, "seeds", o.seeds, MF_OPT_INT, 1, 1, EV_STAB_MAX_SEEDS,
               "recon seeds of the seed row: the 8-bit darkened cells (png_-K, png_-K_x1) and their references at seeds 1..N "
               "(seed 1 of the grid's own png_-4 cells from the grid); the paired exposure difference png_-K - png_-K_x1 "
               "must be within 0.3 dB (1: no seed row)"),
    MF_OPT_NAMED(A, "seed_stops", o.seed_stops, MF_OPT_STR, 0, 0, 0,
               "the seed row's darkenings K, distinct stops in 1..4 separated by commas (default 4)", .meta = "K[,K...]"),
    MF_OPT_NAMED(A, "seed_row_only", o.seed_row_only, MF_OPT_BOOL, 0, 0, 1,
               "run the seed row alone (no cells, no memory row; README.md and seeds.csv only)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_stability_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-stability --mf MF_BINARY --work DIR -o OUT_DIR [--iters N] [--mem-iters N] [--quick] [--jobs N]\n"
                       "                          [--seeds N] [--seed-stops K[,K...]] [--seed-row-only]\n"
                       "  Runs the stability grid on the tiny split (cells: eval/ev_stability.c) with MF_BINARY as child\n"
                       "  processes in DIR; writes OUT_DIR/README.md, OUT_DIR/grid.csv (and seeds.csv). Exit 1 when a cell is not\n"
                       "  as expected (non-finite output, a failed run, a refusal that does not name its option, a bound\n"
                       "  not met) or a seed row's mean exposure difference exceeds 0.3 dB.\n",
                       t, 1, NULL);
}

static int bench_stability_run(const StabArgs *a);

/* Parses the options (string values may live in the --config JSON: p is freed after the run). */
static int cmd_bench_stability(int argc, char **argv) {
    StabArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 0, &p);
    if (rc >= 0) return rc;
    rc = bench_stability_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

static int bench_stability_run(const StabArgs *a) {
    const char *mf = a->mf, *work = a->work, *out = a->out;
    if (!mf || !work || !out) {
        mf_fail(MF_EARG, "--mf, --work and -o are required");
        return MF_EXIT_USAGE;
    }
    EvStabResult res[EV_STAB_MAX_CELLS];
    EvStabSeedRow rows[EV_STAB_MAX_STOPS];
    int n = 0, nrows = 0, bad = 0;
    if (ev_stab_grid(mf, work, out, &a->o, res, EV_STAB_MAX_CELLS, &n, rows, &nrows)) return MF_EXIT_FAIL;
    for (int i = 0; i < nrows; ++i) bad += !rows[i].ok;
    for (int i = 0; i < n; ++i) bad += !res[i].ok;
    printf("stability grid: %d cells%s, %d not as expected -> %s/README.md\n", n, nrows ? " and the seed row" : "", bad, out);
    if (bad) {
        mf_fail(MF_EFORMAT, "%d stability cells (or the seed row) not as expected (see %s/README.md)", bad, out);
        return MF_EXIT_FAIL;
    }
    return MF_EXIT_OK;
}

MF_COMMAND(bench_stability, "bench-stability", "numerical-stability grid on the tiny split (reports/stability)", usage,
           cmd_bench_stability)
