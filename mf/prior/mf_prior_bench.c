/* mf_prior_bench: the speed of the prior's steps (mf_prior_bench.h). */
#include "prior/mf_prior_bench.h"

#include <cblas.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "nn/mf_nn.h"

static void fill(float *x, size_t n, uint64_t seed, float s) {
    MfRng r;
    mf_rng_seed(&r, seed, 3);
    for (size_t i = 0; i < n; ++i) x[i] = s * mf_rng_normal(&r);
}

int mf_prior_bench(MfPrior *p, int B, int reps, int N, MfPriorBench *res) {
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
    if (!x || !rgb || !dv || !tt || !keep || !dy || !dz || !ga || !gb || !gc) rc = mf_fail(MF_ENOMEM, "mf_prior_bench: out of memory");
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
        rc = mf_fail(MF_ENOMEM, "mf_prior_bench: out of memory");
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
            rc = mf_fail(MF_ENOMEM, "mf_prior_bench: denoiser forward failed");
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
            rc = mf_fail(MF_ENOMEM, "mf_prior_bench: autoencoder forward failed");
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
    if (!rc) *res = (MfPriorBench){best[0], best[1], best[2], best[3], best[4], fl_dn, fl_ae};
out:
    free(x), free(rgb), free(dv), free(tt), free(keep), free(dy), free(dz), free(ga), free(gb), free(gc);
    mf_adamw_free(&odn), mf_adamw_free(&oae);
    mf_denoiser_work_free(&w);
    mf_ae_work_free(&aw);
    return rc;
}
