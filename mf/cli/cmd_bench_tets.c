/* mf bench-tets: marching tets forward and adjoint time on a sphere (mf/geom/mf_tetgrid.h). */
#include <stdio.h>
#include <stdlib.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "geom/mf_tetgrid.h"

static const char usage[] =
    "usage: mf bench-tets [--res N] [--reps N]\n"
    "Times mf_tetgrid_extract and mf_tetgrid_backward (with a deformation field) on a sphere of\n"
    "radius 0.4 in a unit grid of N^3 cubes (default 64), the minimum over --reps runs (default 10),\n"
    "and prints one line: res, output vertices, triangles, extract ms, adjoint ms.\n";

static int cmd_bench_tets(int argc, char **argv) {
    int res = 64, reps = 10;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_int(argc, argv, &i, "--res", &res)) != 0 || (r = mf_opt_int(argc, argv, &i, "--reps", &reps)) != 0) {
            if (r < 0) return MF_EXIT_USAGE;
        } else {
            mf_fail(MF_EARG, "unknown argument '%s' (see mf bench-tets --help)", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (res < 2 || res > 512 || reps < 1) {
        mf_fail(MF_EARG, "--res must be in [2, 512] and --reps >= 1");
        return MF_EXIT_USAGE;
    }
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
