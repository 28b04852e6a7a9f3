/* mf bench-tets: marching tets forward and adjoint time on a sphere (mf/geom/mf_tetgrid.h). */
#include <stdio.h>
#include <stdlib.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "geom/mf_tetgrid.h"

typedef struct {
    int res, reps;
} TetsArgs;

static const MfOpt k_args[] = {
    MF_OPT_INT(TetsArgs, res, 64, 2, 512, "grid of N^3 cubes"),
    MF_OPT_INT(TetsArgs, reps, 10, 1, 1000000, "runs; the minimum time is reported"),
};
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_tets_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-tets [--res N] [--reps N]\n"
                       "Times mf_tetgrid_extract and mf_tetgrid_backward (with a deformation field) on a sphere of\n"
                       "radius 0.4 in a unit grid of N^3 cubes, the minimum over --reps runs, and prints one line:\n"
                       "res, output vertices, triangles, extract ms, adjoint ms.\n",
                       t, 1, NULL);
}

static int cmd_bench_tets(int argc, char **argv) {
    TetsArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int ec = mf_cli_parse(&bind, 1, argc, argv, 0, &p);
    if (ec >= 0) return ec;
    mf_opts_parse_free(&p);
    int res = a.res, reps = a.reps;
    MfTetGrid g = mf_tetgrid_make(res, mf_v3s(0), 1.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    float *f = malloc(nv * sizeof *f), *d = calloc(nv * 3, sizeof *d), *gf = calloc(nv, sizeof *gf), *gd = calloc(nv * 3, sizeof *gd);
    int rc = f && d && gf && gd ? MF_OK : mf_fail(MF_ENOMEM, "bench-tets: out of memory");
    for (size_t v = 0; v < nv && rc == MF_OK; ++v) f[v] = 0.4f - mf_len(mf_tetgrid_base(&g, v));
    double best_f = 1e30, best_b = 1e30;
    MfTetMesh m = {0};
    for (int r = 0; r < reps && rc == MF_OK; ++r) {
        mf_tetmesh_free(&m);
        double t0 = mf_now();
        if ((rc = mf_tetgrid_extract(&g, f, d, &m)) != MF_OK) break;
        double t1 = mf_now();
        float *dp = calloc((size_t)m.mesh.nv * 3, sizeof *dp);
        if (!dp) { rc = mf_fail(MF_ENOMEM, "bench-tets: out of memory"); break; }
        double t2 = mf_now();
        mf_tetgrid_backward(&g, f, d, &m, dp, gf, gd);
        double t3 = mf_now();
        free(dp);
        best_f = t1 - t0 < best_f ? t1 - t0 : best_f;
        best_b = t3 - t2 < best_b ? t3 - t2 : best_b;
    }
    if (rc == MF_OK)
        printf("res %d: %d vertices, %d triangles, extract %.1f ms, adjoint %.1f ms (min of %d)\n", res, m.mesh.nv, m.mesh.nt,
               1e3 * best_f, 1e3 * best_b, reps);
    mf_tetmesh_free(&m);
    free(f), free(d), free(gf), free(gd);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(bench_tets, "bench-tets", "marching tets forward/adjoint timing", usage, cmd_bench_tets)
