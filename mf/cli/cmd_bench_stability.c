/* mf bench-stability: the numerical-stability grid (eval/ev_stability.h). A thin wrapper. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "eval/ev_stability.h"

#define K_USAGE \
    "usage: mf bench-stability --mf MF_BINARY --work DIR -o OUT_DIR [--iters N] [--mem-iters N] [--quick]\n" \
    "  Runs the stability grid on the tiny split (cells: eval/ev_stability.c) with MF_BINARY as child\n" \
    "  processes in DIR; writes OUT_DIR/README.md and OUT_DIR/grid.csv. Exit 1 when a cell is not as\n" \
    "  expected (non-finite output, a failed run, or a refusal that does not name its option).\n"

static int cmd_bench_stability(int argc, char **argv) {
    const char *mf = NULL, *work = NULL, *out = NULL;
    int iters = 200, mem_iters = 2000, quick = 0;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "--mf", &mf)) || (r = mf_opt_str(argc, argv, &i, "--work", &work)) ||
            (r = mf_opt_str(argc, argv, &i, "-o", &out)) || (r = mf_opt_int(argc, argv, &i, "--iters", &iters)) ||
            (r = mf_opt_int(argc, argv, &i, "--mem-iters", &mem_iters))) {
            if (r < 0) return MF_EXIT_USAGE;
        } else if (!strcmp(argv[i], "--quick")) {
            quick = 1;
        } else {
            mf_fail(MF_EARG, "unknown option '%s'", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (!mf || !work || !out || iters < 1 || mem_iters < 1) {
        mf_fail(MF_EARG, "--mf, --work and -o are required; --iters and --mem-iters must be >= 1");
        return MF_EXIT_USAGE;
    }
    EvStabResult res[EV_STAB_MAX_CELLS];
    int n = 0;
    if (ev_stab_grid(mf, work, out, iters, mem_iters, quick, res, EV_STAB_MAX_CELLS, &n)) return MF_EXIT_FAIL;
    int bad = 0;
    for (int i = 0; i < n; ++i) bad += !res[i].ok;
    printf("stability grid: %d cells, %d not as expected -> %s/README.md\n", n, bad, out);
    if (bad) {
        mf_fail(MF_EFORMAT, "%d stability cells not as expected (see %s/README.md)", bad, out);
        return MF_EXIT_FAIL;
    }
    return MF_EXIT_OK;
}

MF_COMMAND(bench_stability, "bench-stability", "numerical-stability grid on the tiny split (reports/stability)", K_USAGE,
           cmd_bench_stability)
