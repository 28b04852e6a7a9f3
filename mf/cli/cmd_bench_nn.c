/* mf bench-nn: throughput of the nn engine against OpenBLAS sgemm, measured in one process.
 * Reports sgemm GFLOP/s (square N^3, and at the conv layer's own GEMM shape), the GFLOP/s of
 * conv2d forward+backward on a representative layer, and the ratio conv / sgemm. */
#include <cblas.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "nn/mf_nn.h"

typedef struct {
    const char *out;
    int batch, channels, size, gemm, reps;
} BenchNnArgs;

#define A BenchNnArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "markdown table (written atomically)", .alias = "-o", .meta = "FILE.md", .unset = "none"),
    MF_OPT_INT(A, batch, 8, 1, 4096, "conv layer batch B"),
    MF_OPT_INT(A, channels, 64, 1, 4096, "conv layer channels C"),
    MF_OPT_INT(A, size, 32, 2, 4096, "conv layer image side S"),
    MF_OPT_INT(A, gemm, 1024, 16, 16384, "sgemm size N (N x N x N)"),
    MF_OPT_INT(A, reps, 10, 1, 1000000, "interleaved rounds (best of)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_nn_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-nn [-o out.md] [--batch B] [--channels C] [--size S] [--gemm N] [--reps R]\n"
                       "  Measures OpenBLAS sgemm GFLOP/s (N x N x N) and conv2d 3x3 stride 1 forward+backward\n"
                       "  GFLOP/s on a (B, C, S, S) -> (B, C, S, S) layer, best of R interleaved rounds, and writes\n"
                       "  a markdown table to -o.\n",
                       t, 1, NULL);
}

/* Best wall times of reps rounds; each round times every function once, in turn, so the load of a
 * shared machine affects them alike. One warm-up run of each first. */
typedef void (*BenchFn)(void *ctx);
static void best_times(int nfn, BenchFn *fns, void **ctxs, int reps, double *best) {
    for (int f = 0; f < nfn; ++f) fns[f](ctxs[f]), best[f] = 1e30;
    for (int r = 0; r < reps; ++r)
        for (int f = 0; f < nfn; ++f) {
            double t0 = mf_now();
            fns[f](ctxs[f]);
            double dt = mf_now() - t0;
            if (dt < best[f]) best[f] = dt;
        }
}

typedef struct {
    int M, N, K;
    float *a, *b, *c;
} GemmCtx;

static void run_gemm(void *p) {
    GemmCtx *g = p;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, g->M, g->N, g->K, 1.0f, g->a, g->K, g->b, g->N,
                0.0f, g->c, g->N);
}

typedef struct {
    int B, C, S;
    float *in, *w, *bias, *out, *col, *din, *dw, *db, *dout;
} ConvCtx;

static void run_conv(void *p) {
    ConvCtx *c = p;
    mf_conv2d_forward(c->out, c->col, c->in, c->w, c->bias, c->B, c->C, c->S, c->S, c->C, 3, 1);
    mf_conv2d_backward(c->din, c->dw, c->db, c->col, c->dout, c->in, c->w, c->B, c->C, c->S, c->S, c->C, 3, 1);
}

/* A residual block (C -> C, time embedding of 4C channels, 32 groups or fewer), forward+backward. */
typedef struct {
    MfResBlockDims d;
    MfResBlockW w, g;
    MfResBlockActs a;
    float *pm, *gm, *am, *x, *temb, *out, *dx, *dtemb, *dout;
} ResCtx;

static void run_res(void *p) {
    ResCtx *r = p;
    mf_resblock_forward(r->out, &r->a, r->x, r->temb, &r->w, &r->d);
    mf_resblock_backward(r->dx, r->dtemb, &r->g, &r->a, r->dout, r->x, r->temb, &r->w, &r->d);
}

static float *alloc_fill(size_t n, float v) {
    float *p = malloc(n * sizeof(float));
    if (p)
        for (size_t i = 0; i < n; ++i) p[i] = v * (float)((i * 2654435761u) % 1000) / 1000.0f;
    return p;
}

static int gemm_alloc(GemmCtx *g, int M, int N, int K) {
    g->M = M, g->N = N, g->K = K;
    g->a = alloc_fill((size_t)M * K, 1), g->b = alloc_fill((size_t)K * N, 1), g->c = alloc_fill((size_t)M * N, 0);
    return g->a && g->b && g->c;
}

static void gemm_free(GemmCtx *g) { free(g->a), free(g->b), free(g->c); }

static int bench_nn_run(const BenchNnArgs *a);

/* Parses the options (string values may live in the --config JSON: p is freed after the run). */
static int cmd_bench_nn(int argc, char **argv) {
    BenchNnArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 0, &p);
    if (rc >= 0) return rc;
    rc = bench_nn_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

static int bench_nn_run(const BenchNnArgs *a) {
    const char *out = a->out;
    int B = a->batch, C = a->channels, S = a->size, NG = a->gemm, reps = a->reps;
    int blas_threads = openblas_get_num_threads(), omp_threads = omp_get_max_threads();
    int P = S * S, CKK = C * 9;
    GemmCtx gsq = {0}, gsh = {0};
    ConvCtx c = {.B = B, .C = C, .S = S};
    size_t nact = (size_t)B * C * P, nw = (size_t)C * CKK;
    c.in = alloc_fill(nact, 1), c.out = alloc_fill(nact, 0), c.din = alloc_fill(nact, 0), c.dout = alloc_fill(nact, 0.01f);
    c.w = alloc_fill(nw, 0.05f), c.dw = alloc_fill(nw, 0), c.bias = alloc_fill((size_t)C, 0.1f), c.db = alloc_fill((size_t)C, 0);
    c.col = alloc_fill(mf_conv2d_col_floats(B, C, S, S, C, 3, 1), 0);
    int rc = MF_EXIT_OK;
    int ok_g = gemm_alloc(&gsq, NG, NG, NG) & gemm_alloc(&gsh, C, P, CKK);
    if (!ok_g || !c.in || !c.out || !c.din || !c.dout || !c.w || !c.dw || !c.bias || !c.db || !c.col) {
        mf_fail(MF_ENOMEM, "bench-nn: out of memory");
        rc = MF_EXIT_FAIL;
    } else {
        ResCtx rs = {.d = {B, C, C, S, S, 4 * C, C % 32 == 0 ? 32 : (C % 8 == 0 ? 8 : 1), 1e-5f}};
        MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
        size_t np = mf_specs_numel(specs, mf_resblock_specs(specs, "", &rs.d));
        rs.pm = alloc_fill(np, 0), rs.gm = alloc_fill(np, 0), rs.am = alloc_fill(mf_resblock_acts_floats(&rs.d), 0);
        rs.x = alloc_fill(nact, 1), rs.out = alloc_fill(nact, 0), rs.dx = alloc_fill(nact, 0), rs.dout = alloc_fill(nact, 0.01f);
        rs.temb = alloc_fill((size_t)B * 4 * C, 1), rs.dtemb = alloc_fill((size_t)B * 4 * C, 0);
        if (!rs.pm || !rs.gm || !rs.am || !rs.x || !rs.out || !rs.dx || !rs.dout || !rs.temb || !rs.dtemb) {
            mf_fail(MF_ENOMEM, "bench-nn: out of memory");
            rc = MF_EXIT_FAIL;
            goto res_done;
        }
        mf_resblock_bind(&rs.w, &rs.d, rs.pm);
        mf_resblock_bind(&rs.g, &rs.d, rs.gm);
        mf_resblock_acts_bind(&rs.a, &rs.d, rs.am);
        mf_resblock_init(&rs.w, &rs.d, 1);
        BenchFn fns[4] = {run_gemm, run_gemm, run_conv, run_res};
        void *ctxs[4] = {&gsq, &gsh, &c, &rs};
        double best[4];
        best_times(4, fns, ctxs, reps, best);
        /* resblock FLOPs: its two 3x3 convs and the time projection, forward + both backward GEMMs */
        double res_flops = 3.0 * (2.0 * 2.0 * B * C * (double)P * CKK + 2.0 * B * C * 4.0 * C);
        double g_res = res_flops / best[3] * 1e-9;
        double g_sq = 2.0 * NG * NG * (double)NG / best[0] * 1e-9;
        double g_shape = 2.0 * C * (double)P * CKK / best[1] * 1e-9;
        double t = best[2];
        double flops = 3.0 * 2.0 * B * C * (double)P * CKK; /* forward, dW, dX */
        double g_conv = flops / t * 1e-9;
        double ratio = g_conv / g_sq;
        char md[4096];
        snprintf(md, sizeof md,
                 "# mf bench-nn\n\n"
                 "OpenBLAS threads %d, OpenMP threads %d; best of %d interleaved rounds after one warm-up.\n\n"
                 "| measurement | shape | GFLOP/s |\n|---|---|---|\n"
                 "| sgemm (reference) | %d x %d x %d | %.1f |\n"
                 "| sgemm at one image's GEMM shape | M=%d N=%d K=%d | %.1f |\n"
                 "| conv2d 3x3 s1 forward+backward | B=%d C=%d->%d %dx%d (%.4f s) | %.1f |\n"
                 "| residual block forward+backward (GEMM FLOPs only) | B=%d C=%d->%d %dx%d Ct=%d G=%d (%.4f s) | %.1f |\n\n"
                 "conv2d / sgemm ratio: **%.2f** (target >= 0.4); conv2d / sgemm at one image's GEMM shape: %.2f\n\n"
                 "residual block / sgemm ratio: **%.2f** (includes group norm, SiLU, bias and copies)\n",
                 blas_threads, omp_threads, reps, NG, NG, NG, g_sq, C, P, CKK, g_shape, B, C, C, S, S, t,
                 g_conv, B, C, C, S, S, 4 * C, rs.d.G, best[3], g_res, ratio, g_conv / g_shape, g_res / g_sq);
        printf("%s", md);
        if (out && (mf_mkdirs_for(out) || mf_write_file(out, md, strlen(md)))) rc = MF_EXIT_FAIL;
    res_done:
        free(rs.pm), free(rs.gm), free(rs.am), free(rs.x), free(rs.out), free(rs.dx), free(rs.dout);
        free(rs.temb), free(rs.dtemb);
    }
    gemm_free(&gsq), gemm_free(&gsh);
    free(c.in), free(c.out), free(c.din), free(c.dout), free(c.w), free(c.dw), free(c.bias), free(c.db), free(c.col);
    return rc;
}

MF_COMMAND(bench_nn, "bench-nn", "conv2d forward+backward GFLOP/s vs OpenBLAS sgemm", usage, cmd_bench_nn)
