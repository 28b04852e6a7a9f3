/* mf bench-stability: the numerical-stability grid (eval/ev_stability.h). A thin wrapper. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "eval/ev_stability.h"

typedef struct {
    const char *mf, *work, *out;
    int iters, mem_iters, quick, jobs;
} StabArgs;

#define A StabArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, mf, NULL, "the mf binary run as child processes (required)", .meta = "MF_BINARY"),
    MF_OPT_STR(A, work, NULL, "work folder (required)", .meta = "DIR"),
    MF_OPT_STR(A, out, NULL, "report folder (required)", .alias = "-o", .meta = "OUT_DIR"),
    MF_OPT_INT(A, iters, 200, 1, 10000000, "iterations of each reconstruction cell"),
    MF_OPT_INT(A, mem_iters, 2000, 1, 10000000, "iterations of the memory row's long run (its short run: 50)"),
    MF_OPT_BOOL(A, quick, 0, "the subset make test runs (no MaterialFusion cells, no memory row)"),
    MF_OPT_INT(A, jobs, 0, 0, 64, "cells run at once, each with OMP_NUM_THREADS = cores / jobs (0: one per core)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_stability_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-stability --mf MF_BINARY --work DIR -o OUT_DIR [--iters N] [--mem-iters N] [--quick] [--jobs N]\n"
                       "  Runs the stability grid on the tiny split (cells: eval/ev_stability.c) with MF_BINARY as child\n"
                       "  processes in DIR; writes OUT_DIR/README.md and OUT_DIR/grid.csv. Exit 1 when a cell is not as\n"
                       "  expected (non-finite output, a failed run, or a refusal that does not name its option).\n",
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
    int iters = a->iters, mem_iters = a->mem_iters, quick = a->quick;
    if (!mf || !work || !out) {
        mf_fail(MF_EARG, "--mf, --work and -o are required");
        return MF_EXIT_USAGE;
    }
    EvStabResult res[EV_STAB_MAX_CELLS];
    int n = 0;
    if (ev_stab_grid(mf, work, out, iters, mem_iters, quick, a->jobs, res, EV_STAB_MAX_CELLS, &n)) return MF_EXIT_FAIL;
    int bad = 0;
    for (int i = 0; i < n; ++i) bad += !res[i].ok;
    printf("stability grid: %d cells, %d not as expected -> %s/README.md\n", n, bad, out);
    if (bad) {
        mf_fail(MF_EFORMAT, "%d stability cells not as expected (see %s/README.md)", bad, out);
        return MF_EXIT_FAIL;
    }
    return MF_EXIT_OK;
}

MF_COMMAND(bench_stability, "bench-stability", "numerical-stability grid on the tiny split (reports/stability)", usage,
           cmd_bench_stability)
