/* mf bench-prior: speed of the prior on this machine, measured in one process:
 *   - training samples/s of the denoiser + image encoder step (forward, backward, AdamW) and of the
 *     autoencoder step (encode + decode, both backwards, AdamW), at the training batch;
 *   - the GFLOP/s the network achieves in those steps, counting the FLOPs of its matrix products
 *     (mf_nn_gemm_flops: im2col convolutions, linears, attention; element-wise work is not
 *     counted), as a ratio to OpenBLAS sgemm GFLOP/s (N x N x N) measured in the same run;
 *   - latency of one guided denoising step (classifier-free guidance: conditional and
 *     unconditional passes) at batch 4, single-view and with the 4 views attending jointly;
 *   - peak resident memory (getrusage).
 * Every timing is the best of R rounds after one warm-up (a shared machine slows some rounds). */
#include <cblas.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "nn/mf_nn.h"
#include "prior/mf_prior.h"

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

static void fill(float *x, size_t n, uint64_t seed, float s) {
    MfRng r;
    mf_rng_seed(&r, seed, 3);
    for (size_t i = 0; i < n; ++i) x[i] = s * mf_rng_normal(&r);
}

static int bench_prior_run(const BenchPriorArgs *ap);

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

static int bench_prior_run(const BenchPriorArgs *ap) {
    BenchPriorArgs a = *ap;
    const char *out = a.out, *weights = a.weights;
    int B = a.batch, reps = a.reps, N = a.gemm;
    MfPrior *p = NULL;
    const char *source = "committed weights";
    if (mf_prior_load_path(weights, &p)) {
        if (weights) return MF_EXIT_FAIL;
        mf_log_warn("bench-prior: %s; timing a freshly initialised default model", mf_error());
        MfPriorConfig cfg;
        mf_prior_config_default(&cfg, 64);
        if (mf_prior_new(&p, &cfg)) return MF_EXIT_FAIL;
        mf_ae_init_weights(p->ae, 1);
        mf_denoiser_init_weights(p->dn, 1);
        p->latent_scale = 1.0f;
        source = "freshly initialised default model";
    }
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, rc = MF_OK;
    size_t isz = (size_t)3 * R * R, zsz = (size_t)zc * h * h;
    size_t ndn = p->dn->tab.numel, nae = p->ae->tab.numel;
    float *x = malloc((size_t)B * 3 * zsz * sizeof(float)), *rgb = malloc((size_t)B * isz * sizeof(float));
    float *dv = malloc((size_t)B * 2 * zsz * sizeof(float)), *tt = malloc((size_t)B * sizeof(float));
    float *keep = malloc((size_t)B * sizeof(float)), *dy = malloc((size_t)B * isz * sizeof(float));
    float *dz = malloc((size_t)B * zsz * sizeof(float));
    float *ga = malloc((size_t)N * N * sizeof(float)), *gb = malloc((size_t)N * N * sizeof(float));
    float *gc = malloc((size_t)N * N * sizeof(float));
    MfAdamW odn = {0}, oae = {0};
    MfDenoiserWork w = {0};
    MfAeWork aw = {0};
    if (!x || !rgb || !dv || !tt || !keep || !dy || !dz || !ga || !gb || !gc) rc = mf_fail(MF_ENOMEM, "bench-prior: out of memory");
    if (!rc) rc = mf_adamw_init(&odn, ndn, 1e-6f, 0.9f, 0.999f, 1e-8f, 0.0f);
    if (!rc) rc = mf_adamw_init(&oae, nae, 1e-6f, 0.9f, 0.999f, 1e-8f, 0.0f);
    if (rc) goto out;
    fill(x, (size_t)B * 3 * zsz, 1, 1.0f), fill(rgb, (size_t)B * isz, 2, 0.5f), fill(dv, (size_t)B * 2 * zsz, 3, 1e-3f);
    fill(dy, (size_t)B * isz, 4, 1e-4f), fill(ga, (size_t)N * N, 5, 1.0f), fill(gb, (size_t)N * N, 6, 1.0f);
    for (int b = 0; b < B; ++b) tt[b] = (float)(37 * b % 1000), keep[b] = 1.0f;

    /* the timings interleave: each round runs every measurement once */
    double best[5] = {1e30, 1e30, 1e30, 1e30, 1e30};
    unsigned long long fl_dn = 0, fl_ae = 0;
    float *v4 = malloc((size_t)4 * 2 * zsz * sizeof(float)), *z4 = malloc((size_t)4 * zsz * sizeof(float));
    if (!v4 || !z4) {
        free(v4), free(z4);
        rc = mf_fail(MF_ENOMEM, "bench-prior: out of memory");
        goto out;
    }
    if ((rc = mf_prior_encode(p, rgb, 4, z4))) goto out4;
    mf_log_info("bench-prior: %d rounds (batch %d, sgemm %d^3)", reps, B, N);
    for (int r = 0; r <= reps && !rc; ++r) { /* round 0 is the warm-up */
        double t0 = mf_now();
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, N, N, N, 1.0f, ga, N, gb, N, 0.0f, gc, N);
        double dt = mf_now() - t0;
        if (r && dt < best[0]) best[0] = dt;
        /* denoiser training step */
        mf_nn_gemm_flops_reset();
        t0 = mf_now();
        memset(p->dn->grads, 0, ndn * sizeof(float));
        if (!mf_denoiser_forward(p->dn, &w, x, tt, rgb, keep, B, 1, 0)) {
            rc = -1;
            break;
        }
        mf_denoiser_backward(p->dn, &w, dv);
        mf_grad_clip_norm(p->dn->grads, ndn, 1.0f);
        mf_adamw_step(&odn, p->dn->params, p->dn->grads);
        dt = mf_now() - t0;
        fl_dn = mf_nn_gemm_flops();
        if (r && dt < best[1]) best[1] = dt;
        /* autoencoder training step */
        mf_nn_gemm_flops_reset();
        t0 = mf_now();
        memset(p->ae->grads, 0, nae * sizeof(float));
        float *z = mf_ae_encode(p->ae, &aw, rgb, B), *y = z ? mf_ae_decode(p->ae, &aw, z, B) : NULL;
        if (!y) {
            rc = -1;
            break;
        }
        memset(dz, 0, (size_t)B * zsz * sizeof(float));
        mf_ae_decode_backward(p->ae, &aw, dy, dz);
        mf_ae_encode_backward(p->ae, &aw, dz, NULL);
        mf_grad_clip_norm(p->ae->grads, nae, 1.0f);
        mf_adamw_step(&oae, p->ae->params, p->ae->grads);
        dt = mf_now() - t0;
        fl_ae = mf_nn_gemm_flops();
        if (r && dt < best[2]) best[2] = dt;
        /* one guided denoising step at batch 4: single-view, then the 4 views jointly */
        for (int mv = 0; mv < 2 && !rc; ++mv) {
            t0 = mf_now();
            rc = mf_prior_guided_v(p, z4, rgb, x, 500, 4, mv ? 4 : 1, mv, MF_PRIOR_GUIDANCE, v4);
            dt = mf_now() - t0;
            if (r && dt < best[3 + mv]) best[3 + mv] = dt;
        }
    }
out4:
    free(v4), free(z4);
    if (rc) goto out;
    {
        struct rusage ru;
        getrusage(RUSAGE_SELF, &ru);
        double peak_mib = ru.ru_maxrss / 1024.0;
        double g_sgemm = 2.0 * N * (double)N * N / best[0] / 1e9, g_dn = fl_dn / best[1] / 1e9, g_ae = fl_ae / best[2] / 1e9;
        const char *threads = getenv("OPENBLAS_NUM_THREADS");
        char md[4096];
        int l = snprintf(
            md, sizeof md,
            "# Prior performance (`make bench-prior`)\n\n"
            "Measured by `mf bench-prior` in one process (%s; %zu parameters; %d px images, %dx%dx%d latents); "
            "best of %d interleaved rounds after a warm-up, OPENBLAS_NUM_THREADS=%s. Network GFLOP/s count the "
            "FLOPs of the network's matrix products (im2col convolutions, linears, attention; element-wise "
            "layers and AdamW are in the time but not in the count).\n\n"
            "| measurement | value |\n|---|---|\n"
            "| OpenBLAS sgemm %d^3 | %.1f GFLOP/s |\n"
            "| denoiser + image encoder training step, batch %d | %.3f s (%.1f samples/s) |\n"
            "| denoiser step GEMM FLOPs / GFLOP/s / ratio to sgemm | %.2f GFLOP / %.1f GFLOP/s / %.2f |\n"
            "| autoencoder training step, batch %d | %.3f s (%.1f samples/s) |\n"
            "| autoencoder step GEMM FLOPs / GFLOP/s / ratio to sgemm | %.2f GFLOP / %.1f GFLOP/s / %.2f |\n"
            "| one guided denoising step (CFG 3), batch 4, single-view | %.1f ms |\n"
            "| one guided denoising step (CFG 3), batch 4, 4 views jointly (MV) | %.1f ms |\n"
            "| peak resident memory | %.1f MiB |\n",
            source, mf_prior_num_params(p), R, h, h, zc, reps, threads ? threads : "(unset: all cores)", N, g_sgemm, B,
            best[1], B / best[1], fl_dn / 1e9, g_dn, g_dn / g_sgemm, B, best[2], B / best[2], fl_ae / 1e9, g_ae,
            g_ae / g_sgemm, best[3] * 1e3, best[4] * 1e3, peak_mib);
        fputs(md, stdout);
        if (out) {
            rc = mf_mkdirs_for(out);
            if (!rc) rc = mf_write_file(out, md, (size_t)l);
            if (!rc) printf("wrote %s\n", out);
        }
    }
out:
    free(x), free(rgb), free(dv), free(tt), free(keep), free(dy), free(dz), free(ga), free(gb), free(gc);
    mf_adamw_free(&odn), mf_adamw_free(&oae);
    mf_denoiser_work_free(&w);
    mf_ae_work_free(&aw);
    mf_prior_free(p);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(bench_prior, "bench-prior", "prior speed: training samples/s, GFLOP/s vs sgemm, guided step latency",
           usage, cmd_bench_prior)
