/* mf bench-nn: throughput of the nn engine against OpenBLAS sgemm, measured in one process.
 * Reports sgemm GFLOP/s (square N^3, at one image's GEMM shape, and the conv layer's own three
 * GEMMs alone), the GFLOP/s of conv2d forward+backward and of a residual block, and the ratios to
 * sgemm: the median over interleaved rounds of each round's ratio (robust to a shared machine's
 * load) and the ratio of the best times. */
#include <cblas.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_strbuf.h"
#include "nn/mf_nn.h"

typedef struct {
    const char *out;
    int batch, channels, size, gemm, reps, groups;
} BenchNnArgs;

#define A BenchNnArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "markdown table (written atomically)", .alias = "-o", .meta = "FILE.md", .unset = "none"),
    MF_OPT_INT(A, batch, 8, 1, 4096, "conv layer batch B"),
    MF_OPT_INT(A, channels, 64, 1, 4096, "conv layer channels C"),
    MF_OPT_INT(A, size, 32, 2, 4096, "conv layer image side S"),
    MF_OPT_INT(A, gemm, 1024, 16, 16384, "sgemm size N (N x N x N)"),
    MF_OPT_INT(A, reps, 10, 1, 1000000, "interleaved rounds (best of, median of ratios)"),
    MF_OPT_INT(A, groups, 0, 0, 4096, "residual block group-norm groups (0: 32, or 8, or 1, the first dividing C)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_nn_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-nn [-o out.md] [--batch B] [--channels C] [--size S] [--gemm N] [--reps R]\n"
                       "  Measures OpenBLAS sgemm GFLOP/s (N x N x N), conv2d 3x3 stride 1 forward+backward and\n"
                       "  a residual block on a (B, C, S, S) -> (B, C, S, S) layer, and the conv's own GEMMs alone,\n"
                       "  in R interleaved rounds (ratios: medians of the rounds' ratios), and writes a markdown\n"
                       "  table to -o.\n",
                       t, 1, NULL);
}

/* Wall and CPU seconds t[f * reps + r], tc[...] of function f in round r; each round times every
 * function once, in turn, so the load of a shared machine affects them alike. One warm-up run of
 * each first. With one thread, CPU seconds do not count the time other processes hold the core. */
typedef void (*BenchFn)(void *ctx);
static void round_times(int nfn, BenchFn *fns, void **ctxs, int reps, double *t, double *tc) {
    for (int f = 0; f < nfn; ++f) fns[f](ctxs[f]);
    for (int r = 0; r < reps; ++r)
        for (int f = 0; f < nfn; ++f) {
            double t0 = mf_now(), c0 = mf_cpu_now();
            fns[f](ctxs[f]);
            tc[f * reps + r] = mf_cpu_now() - c0;
            t[f * reps + r] = mf_now() - t0;
        }
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median over rounds of (flops_a / t_a) / (flops_b / t_b); best: the ratio of the best times.
 * q: scratch (reps,). */
static double median_ratio(const double *ta, double fa, const double *tb, double fb, int reps, double *q, double *best) {
    double ba = 1e30, bb = 1e30;
    for (int r = 0; r < reps; ++r) {
        q[r] = (fa / ta[r]) / (fb / tb[r]);
        ba = ta[r] < ba ? ta[r] : ba;
        bb = tb[r] < bb ? tb[r] : bb;
    }
    *best = (fa / ba) / (fb / bb);
    qsort(q, (size_t)reps, sizeof *q, cmp_double);
    return reps % 2 ? q[reps / 2] : 0.5 * (q[reps / 2 - 1] + q[reps / 2]);
}

static double min_of(const double *t, int n) {
    double m = 1e30;
    for (int i = 0; i < n; ++i) m = t[i] < m ? t[i] : m;
    return m;
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

/* The three GEMMs of conv2d forward+backward alone, at the shapes mf_conv2d_* give them (images
 * grouped nb at a time, mf_nn_layers.c): out = w col, dw += dout col^T, dcol = w^T dout. */
typedef struct {
    int B, C, P, nb;
    float *w, *col, *out, *dw, *dcol;
} ConvGemmCtx;

static void run_conv_gemms(void *p) {
    ConvGemmCtx *g = p;
    int CKK = 9 * g->C;
    for (int b0 = 0; b0 < g->B; b0 += g->nb) {
        int NP = (g->B - b0 < g->nb ? g->B - b0 : g->nb) * g->P;
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, g->C, NP, CKK, 1.0f, g->w, CKK, g->col, NP, 0.0f, g->out, NP);
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, g->C, CKK, NP, 1.0f, g->out, NP, g->col, NP, 1.0f, g->dw, CKK);
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, CKK, NP, g->C, 1.0f, g->w, CKK, g->out, NP, 0.0f, g->dcol, NP);
    }
}

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

/* Runs fn under one conv backend (mf_nn_set_backend), so the rounds interleave both backends. */
typedef struct {
    MfNnBackend be;
    BenchFn fn;
    void *ctx;
} BackendCtx;

static void run_backend(void *p) {
    BackendCtx *b = p;
    mf_nn_set_backend(b->be);
    b->fn(b->ctx);
}

/* Round times of the report: t (wall), tc (CPU), (nfn, reps) each, of sgemm, sgemm at one image's
 * shape, the conv's GEMMs, then conv and residual block for each of the nbe backends be. */
typedef struct {
    int G, nb, nbe;
    const MfNnBackend *be;
    const double *t, *tc;
    double load0; /* 1-minute load average at the start */
} BenchNnTimes;

/* rat = {CPU median, wall median, wall best} of (flops fi / time i) / (flops fj / time j). */
static void ratios(const BenchNnTimes *m, int reps, int i, double fi, int j, double fj, double *q, double rat[3]) {
    double unused;
    rat[0] = median_ratio(m->tc + i * reps, fi, m->tc + j * reps, fj, reps, q, &unused);
    rat[1] = median_ratio(m->t + i * reps, fi, m->t + j * reps, fj, reps, q, &rat[2]);
}

/* The report (printed, and written to a->out when set); q: scratch (reps,). */
static int write_report(const BenchNnArgs *a, const BenchNnTimes *m, double *q) {
    int B = a->batch, C = a->channels, S = a->size, NG = a->gemm, reps = a->reps, P = S * S, CKK = C * 9;
    double load1 = 0.0, r[3];
    getloadavg(&load1, 1);
    const double *tc = m->tc;
    double f_sq = 2.0 * NG * NG * (double)NG, f_sh = 2.0 * C * (double)P * CKK;
    double f_conv = 3.0 * 2.0 * B * C * (double)P * CKK; /* forward, dW, dX */
    /* resblock FLOPs: its two 3x3 convs and the time projection, forward + both backward GEMMs */
    double f_res = 3.0 * (2.0 * 2.0 * B * C * (double)P * CKK + 2.0 * B * C * 4.0 * C);
    MfStrBuf sb = {0};
    mf_sb_printf(&sb,
                 "# mf bench-nn\n\n"
                 "OpenBLAS threads %d, OpenMP threads %d; %d interleaved rounds after one warm-up; 1-minute load\n"
                 "average %.2f at the start, %.2f at the end. Backend: the conv layers' (mf_nn.h: blas = im2col +\n"
                 "OpenBLAS sgemm, dnnl = oneDNN, in builds with it: make DNNL=0 builds without). GFLOP/s and seconds: the best\n"
                 "round's CPU seconds; ratios: the median over rounds of each round's ratio of CPU seconds (with\n"
                 "one thread, not counting the time other processes hold the core; their cache traffic still\n"
                 "counts), of wall seconds, and the ratio of the best rounds' wall seconds.\n\n"
                 "| measurement | backend | shape | GFLOP/s |\n|---|---|---|---|\n"
                 "| sgemm (reference) | - | %d x %d x %d | %.1f |\n"
                 "| sgemm at one image's GEMM shape | - | M=%d N=%d K=%d | %.1f |\n"
                 "| the conv's three GEMMs alone (%d images per GEMM) | blas | M=%d N=%d K=%d, then NT and TN | %.1f |\n",
                 openblas_get_num_threads(), omp_get_max_threads(), reps, m->load0, load1, NG, NG, NG,
                 f_sq / min_of(tc, reps) * 1e-9, C, P, CKK, f_sh / min_of(tc + reps, reps) * 1e-9, m->nb, C, m->nb * P,
                 CKK, f_conv / min_of(tc + 2 * reps, reps) * 1e-9);
    for (int k = 0; k < m->nbe; ++k) {
        const char *be = mf_nn_backend_name(m->be[k]);
        double tcv = min_of(tc + (3 + 2 * k) * reps, reps), trs = min_of(tc + (4 + 2 * k) * reps, reps);
        mf_sb_printf(&sb,
                     "| conv2d 3x3 s1 forward+backward | %s | B=%d C=%d->%d %dx%d (%.4f s) | %.1f |\n"
                     "| residual block forward+backward (GEMM FLOPs only) | %s | B=%d C=%d->%d %dx%d Ct=%d G=%d (%.4f s) | %.1f |\n",
                     be, B, C, C, S, S, tcv, f_conv / tcv * 1e-9, be, B, C, C, S, S, 4 * C, m->G, trs, f_res / trs * 1e-9);
    }
    mf_sb_printf(&sb, "\n| ratio | backend | median, CPU s | median, wall s | best rounds, wall s |\n|---|---|---|---|---|\n");
    for (int k = 0; k < m->nbe; ++k) {
        ratios(m, reps, 3 + 2 * k, f_conv, 0, f_sq, q, r);
        mf_sb_printf(&sb, "| **conv2d / sgemm** | %s | **%.2f** | %.2f | %.2f |\n", mf_nn_backend_name(m->be[k]), r[0], r[1], r[2]);
    }
    for (int k = 0; k < m->nbe; ++k) {
        ratios(m, reps, 4 + 2 * k, f_res, 0, f_sq, q, r);
        mf_sb_printf(&sb, "| **residual block / sgemm** (includes group norm, SiLU, bias and copies) | %s | **%.2f** | %.2f | %.2f |\n",
                     mf_nn_backend_name(m->be[k]), r[0], r[1], r[2]);
    }
    ratios(m, reps, 2, f_conv, 0, f_sq, q, r);
    mf_sb_printf(&sb, "| the conv's GEMMs alone / sgemm (the bound for conv2d with these GEMMs) | blas | %.2f | %.2f | %.2f |\n",
                 r[0], r[1], r[2]);
    ratios(m, reps, 3, f_conv, 2, f_conv, q, r);
    mf_sb_printf(&sb, "| conv2d / its GEMMs alone (im2col, col2im, copies) | blas | %.2f | %.2f | %.2f |\n", r[0], r[1], r[2]);
    if (sb.s && !sb.oom) printf("%s", sb.s);
    int rc = sb.oom ? mf_fail(MF_ENOMEM, "bench-nn: out of memory") : MF_OK;
    if (!rc && a->out && !(rc = mf_mkdirs_for(a->out))) return mf_sb_write(&sb, a->out) ? MF_EXIT_FAIL : MF_EXIT_OK;
    mf_sb_free(&sb);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

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
    int B = a->batch, C = a->channels, S = a->size, NG = a->gemm, reps = a->reps;
    int G = a->groups ? a->groups : C % 32 == 0 ? 32 : (C % 8 == 0 ? 8 : 1);
    if (C % G) {
        mf_fail(MF_EARG, "bench-nn: --groups %d does not divide --channels %d", G, C);
        return MF_EXIT_USAGE;
    }
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
        ResCtx rs = {.d = {B, C, C, S, S, 4 * C, G, 1e-5f}};
        MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
        size_t np = mf_specs_numel(specs, mf_resblock_specs(specs, "", &rs.d));
        /* the grouping of mf_conv2d_* (mf_nn.h): nb = min(B, ceil(1024 / P)) images per GEMM */
        int nb = P >= 1024 ? 1 : (1024 + P - 1) / P;
        nb = nb < B ? nb : B;
        ConvGemmCtx cg = {B, C, P, nb, c.w, alloc_fill((size_t)CKK * nb * P, 1), alloc_fill((size_t)C * nb * P, 0.01f), c.dw,
                          alloc_fill((size_t)CKK * nb * P, 0)};
        rs.pm = alloc_fill(np, 0), rs.gm = alloc_fill(np, 0), rs.am = alloc_fill(mf_resblock_acts_floats(&rs.d), 0);
        rs.x = alloc_fill(nact, 1), rs.out = alloc_fill(nact, 0), rs.dx = alloc_fill(nact, 0), rs.dout = alloc_fill(nact, 0.01f);
        rs.temb = alloc_fill((size_t)B * 4 * C, 1), rs.dtemb = alloc_fill((size_t)B * 4 * C, 0);
        /* the conv backends of this build: blas, and dnnl where built */
        MfNnBackend was = mf_nn_backend(), bes[2] = {MF_NN_BLAS, MF_NN_DNNL};
        int nbe = mf_nn_set_backend(MF_NN_DNNL) == MF_OK ? 2 : 1, nfn = 3 + 2 * nbe;
        mf_nn_set_backend(was);
        double *t = malloc((2 * (size_t)nfn + 1) * (size_t)reps * sizeof *t); /* wall, CPU (nfn x reps), scratch */
        if (!rs.pm || !rs.gm || !rs.am || !rs.x || !rs.out || !rs.dx || !rs.dout || !rs.temb || !rs.dtemb || !cg.col ||
            !cg.out || !cg.dcol || !t) {
            mf_fail(MF_ENOMEM, "bench-nn: out of memory");
            rc = MF_EXIT_FAIL;
            goto res_done;
        }
        mf_resblock_bind(&rs.w, &rs.d, rs.pm);
        mf_resblock_bind(&rs.g, &rs.d, rs.gm);
        mf_resblock_acts_bind(&rs.a, &rs.d, rs.am);
        mf_resblock_init(&rs.w, &rs.d, 1);
        BackendCtx bc[4];
        BenchFn fns[7] = {run_gemm, run_gemm, run_conv_gemms};
        void *ctxs[7] = {&gsq, &gsh, &cg};
        for (int k = 0; k < nbe; ++k) {
            bc[2 * k] = (BackendCtx){bes[k], run_conv, &c}, bc[2 * k + 1] = (BackendCtx){bes[k], run_res, &rs};
            fns[3 + 2 * k] = fns[4 + 2 * k] = run_backend;
            ctxs[3 + 2 * k] = &bc[2 * k], ctxs[4 + 2 * k] = &bc[2 * k + 1];
        }
        BenchNnTimes m = {G, nb, nbe, bes, t, t + nfn * reps, 0.0};
        getloadavg(&m.load0, 1);
        round_times(nfn, fns, ctxs, reps, t, t + nfn * reps);
        mf_nn_set_backend(was);
        rc = write_report(a, &m, t + 2 * nfn * reps);
    res_done:
        free(rs.pm), free(rs.gm), free(rs.am), free(rs.x), free(rs.out), free(rs.dx), free(rs.dout);
        free(rs.temb), free(rs.dtemb), free(cg.col), free(cg.out), free(cg.dcol), free(t);
    }
    gemm_free(&gsq), gemm_free(&gsh);
    free(c.in), free(c.out), free(c.din), free(c.dout), free(c.w), free(c.dw), free(c.bias), free(c.db), free(c.col);
    return rc;
}

MF_COMMAND(bench_nn, "bench-nn", "conv2d forward+backward GFLOP/s vs OpenBLAS sgemm", usage, cmd_bench_nn)
