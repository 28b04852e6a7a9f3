/* mf bench-prior: speed of the prior on this machine, measured in one process:
 *   - training samples/s of the denoiser + image encoder step (forward, backward, AdamW) and of the
 *     autoencoder step (encode + decode, both backwards, AdamW), at the training batch;
 *   - the GFLOP/s the network achieves in those steps, counting the FLOPs of its matrix products
 *     (mf_nn_gemm_flops: im2col convolutions, linears, attention; element-wise work is not
 *     counted), as a ratio to OpenBLAS sgemm GFLOP/s (N x N x N) measured in the same run;
 *   - latency of one guided denoising step (classifier-free guidance: conditional and
 *     unconditional passes) at batch 4, single-view and with the 4 views attending jointly;
 *   - peak resident memory (getrusage).
 * Every timing is the best of R rounds after one warm-up (a shared machine slows some rounds).
 * The measurements are mf/prior/mf_prior_bench.h's; this file loads the model and writes the report. */
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_strbuf.h"
#include "nn/mf_nn.h"
#include "prior/mf_prior_bench.h"

typedef struct {
    const char *out, *weights;
    int batch, reps, gemm;
} BenchPriorArgs;

#define A BenchPriorArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "markdown report", .alias = "-o", .meta = "FILE.md", .unset = "none"),
    MF_OPT_STR(A, weights, NULL, "prior weights (.mfck or its folder)", .meta = "CKPT",
               .unset = "the committed weights, else a fresh model"),
    MF_OPT_INT(A, batch, 16, 1, 4096, "training batch B"),
    MF_OPT_INT(A, reps, 5, 1, 1000000, "rounds (best of)"),
    MF_OPT_INT(A, gemm, 1024, 64, 16384, "sgemm size N (N^3)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void bench_prior_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf bench-prior [-o out.md] [--weights CKPT] [--batch B] [--reps R] [--gemm N]\n"
                       "  Training samples/s (denoiser and autoencoder steps at batch B), the network's GEMM GFLOP/s\n"
                       "  against OpenBLAS sgemm (N^3) in the same process, the latency of one guided denoising step\n"
                       "  at batch 4 (single-view and multi-view) and the peak memory; best of R rounds. Uses the\n"
                       "  committed weights when present (else a freshly initialised model of the default\n"
                       "  configuration: speed does not depend on the weights). Markdown to -o.\n",
                       t, 1, NULL);
}


static int bench_prior_run(const BenchPriorArgs *a);

/* Parses the options (string values may live in the --config JSON: p is freed after the run). */
static int cmd_bench_prior(int argc, char **argv) {
    BenchPriorArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 0, &p);
    if (rc >= 0) return rc;
    rc = bench_prior_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

/* --weights, else the committed weights, else (with a warning) a freshly initialised default
 * model: speed does not depend on the weights. *source says which. */
static int load_prior(const char *weights, MfPrior **p, const char **source) {
    *source = "committed weights";
    if (!mf_prior_load_path(weights, p)) return MF_OK;
    if (weights) return MF_EIO;
    mf_log_warn("bench-prior: %s; timing a freshly initialised default model", mf_error());
    MfPriorConfig cfg;
    mf_prior_config_default(&cfg, 64);
    int rc = mf_prior_new(p, &cfg);
    if (rc) return rc;
    mf_ae_init_weights((*p)->ae, 1);
    mf_denoiser_init_weights((*p)->dn, 1);
    (*p)->latent_scale = 1.0f;
    *source = "freshly initialised default model";
    return MF_OK;
}

/* The report: one column per conv backend measured (b[k] under be[k]). */
static int write_report(const BenchPriorArgs *a, MfPrior *p, const char *source, int nbe, const MfNnBackend *be,
                        const MfPriorBench *b, const double load[2]) {
    int B = a->batch, N = a->gemm, R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h;
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    double g_sgemm = 2.0 * N * (double)N * N / b[0].sgemm_s / 1e9;
    const char *threads = getenv("OPENBLAS_NUM_THREADS"), *omp_threads = getenv("OMP_NUM_THREADS");
    MfStrBuf sb = {0};
    mf_sb_printf(&sb,
                 "# Prior performance (`make bench-prior`)\n\n"
                 "Measured by `mf bench-prior` in one process (%s; %zu parameters; %d px images, %dx%dx%d latents); "
                 "best of %d interleaved rounds after a warm-up (each round runs the network's measurements under "
                 "each conv backend in turn: blas = im2col + OpenBLAS sgemm, dnnl = oneDNN, in builds with oneDNN: the default; "
                 "make DNNL=0 builds without), OPENBLAS_NUM_THREADS=%s, OMP_NUM_THREADS=%s; 1-minute load average %.2f at the "
                 "start, %.2f at the end. Network GFLOP/s count the FLOPs of the network's matrix products "
                 "(convolutions as their im2col GEMMs, linears, attention; element-wise layers and AdamW are in "
                 "the time but not in the count).\n\n| measurement |",
                 source, mf_prior_num_params(p), R, h, h, zc, a->reps, threads ? threads : "(unset: all cores)",
                 omp_threads ? omp_threads : "(unset: all cores)", load[0], load[1]);
    for (int k = 0; k < nbe; ++k) mf_sb_printf(&sb, " %s |", mf_nn_backend_name(be[k]));
    mf_sb_printf(&sb, "\n|---|%s\n| OpenBLAS sgemm %d^3 | %.1f GFLOP/s |", nbe > 1 ? "---|---|" : "---|", N, g_sgemm);
    for (int k = 1; k < nbe; ++k) mf_sb_printf(&sb, " (the same) |");
    const char *rows[6] = {"denoiser + image encoder training step, batch %d", "denoiser step GEMM FLOPs / GFLOP/s / ratio to sgemm",
                           "autoencoder training step, batch %d", "autoencoder step GEMM FLOPs / GFLOP/s / ratio to sgemm",
                           "one guided denoising step (CFG 3), batch 4, single-view",
                           "one guided denoising step (CFG 3), batch 4, 4 views jointly (MV)"};
    for (int r = 0; r < 6; ++r) {
        mf_sb_printf(&sb, "\n| ");
        mf_sb_printf(&sb, rows[r], B);
        mf_sb_printf(&sb, " |");
        for (int k = 0; k < nbe; ++k) {
            const MfPriorBench *q = &b[k];
            double s = r < 2 ? q->dn_step_s : q->ae_step_s, fl = (double)(r < 2 ? q->dn_flops : q->ae_flops);
            if (r == 0 || r == 2) mf_sb_printf(&sb, " %.3f s (%.1f samples/s) |", s, B / s);
            else if (r == 1 || r == 3) mf_sb_printf(&sb, " %.2f GFLOP / %.1f GFLOP/s / %.2f |", fl / 1e9, fl / s / 1e9, fl / s / 1e9 / g_sgemm);
            else mf_sb_printf(&sb, " %.1f ms |", (r == 4 ? q->guided_sv_s : q->guided_mv_s) * 1e3);
        }
    }
    mf_sb_printf(&sb, "\n| peak resident memory (the process) | %.1f MiB |\n", ru.ru_maxrss / 1024.0);
    if (sb.s && !sb.oom) fputs(sb.s, stdout);
    if (!a->out) {
        mf_sb_free(&sb);
        return MF_OK;
    }
    int rc = mf_mkdirs_for(a->out);
    if (rc) mf_sb_free(&sb);
    else if (!(rc = mf_sb_write(&sb, a->out))) printf("wrote %s\n", a->out);
    return rc;
}

static int bench_prior_run(const BenchPriorArgs *a) {
    MfPrior *p = NULL;
    const char *source;
    if (load_prior(a->weights, &p, &source)) return MF_EXIT_FAIL;
    /* the conv backends of this build: blas, and dnnl where built */
    MfNnBackend was = mf_nn_backend(), be[MF_PRIOR_BENCH_MAXBE] = {MF_NN_BLAS, MF_NN_DNNL};
    int nbe = mf_nn_set_backend(MF_NN_DNNL) == MF_OK ? 2 : 1;
    mf_nn_set_backend(was);
    MfPriorBench b[MF_PRIOR_BENCH_MAXBE];
    double load[2] = {0.0, 0.0};
    getloadavg(&load[0], 1);
    int rc = mf_prior_bench(p, a->batch, a->reps, a->gemm, nbe, be, b);
    getloadavg(&load[1], 1);
    if (!rc) rc = write_report(a, p, source, nbe, be, b, load);
    mf_prior_free(p);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(bench_prior, "bench-prior", "prior speed: training samples/s, GFLOP/s vs sgemm, guided step latency",
           usage, cmd_bench_prior)
