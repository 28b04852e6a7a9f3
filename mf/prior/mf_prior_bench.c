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

/* The inputs, optimisers and work buffers of the measured steps. */
typedef struct {
    MfPrior *p;
    int B;
    float *x, *rgb, *dv, *tt, *keep, *dy, *dz; /* training inputs (batch B) */
    float *z4, *v4;                            /* guided step: latents (4) and its output */
    MfAdamW odn, oae;
    MfDenoiserWork w;
    MfAeWork aw;
    unsigned long long fl_dn, fl_ae;           /* GEMM FLOPs of the last steps */
} BenchCtx;

/* One round of the network measurements under the current conv backend: t[1..4] keep the best
 * wall seconds of the denoiser step, the autoencoder step and the two guided steps (r = 0, the
 * warm-up, is not kept). */
static int bench_round(BenchCtx *c, int r, double *t) {
    MfPrior *p = c->p;
    int B = c->B, zsz = p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    size_t ndn = p->dn->tab.numel, nae = p->ae->tab.numel;
    /* denoiser training step */
    mf_nn_gemm_flops_reset();
    double t0 = mf_now();
    memset(p->dn->grads, 0, ndn * sizeof(float));
    if (!mf_denoiser_forward(p->dn, &c->w, c->x, c->tt, c->rgb, c->keep, B, 1, 0))
        return mf_fail(MF_ENOMEM, "mf_prior_bench: denoiser forward failed");
    mf_denoiser_backward(p->dn, &c->w, c->dv);
    mf_grad_clip_norm(p->dn->grads, ndn, 1.0f);
    mf_adamw_step(&c->odn, p->dn->params, p->dn->grads);
    double dt = mf_now() - t0;
    c->fl_dn = mf_nn_gemm_flops();
    if (r && dt < t[1]) t[1] = dt;
    /* autoencoder training step */
    mf_nn_gemm_flops_reset();
    t0 = mf_now();
    memset(p->ae->grads, 0, nae * sizeof(float));
    float *z = mf_ae_encode(p->ae, &c->aw, c->rgb, B), *y = z ? mf_ae_decode(p->ae, &c->aw, z, B) : NULL;
    if (!y) return mf_fail(MF_ENOMEM, "mf_prior_bench: autoencoder forward failed");
    memset(c->dz, 0, (size_t)B * zsz * sizeof(float));
    mf_ae_decode_backward(p->ae, &c->aw, c->dy, c->dz);
    mf_ae_encode_backward(p->ae, &c->aw, c->dz, NULL);
    mf_grad_clip_norm(p->ae->grads, nae, 1.0f);
    mf_adamw_step(&c->oae, p->ae->params, p->ae->grads);
    dt = mf_now() - t0;
    c->fl_ae = mf_nn_gemm_flops();
    if (r && dt < t[2]) t[2] = dt;
    /* one guided denoising step at batch 4: single-view, then the 4 views jointly */
    for (int mv = 0; mv < 2; ++mv) {
        t0 = mf_now();
        int rc = mf_prior_guided_v(p, c->z4, c->rgb, c->x, 500, 4, mv ? 4 : 1, mv, MF_PRIOR_GUIDANCE, c->v4);
        if (rc) return rc;
        dt = mf_now() - t0;
        if (r && dt < t[3 + mv]) t[3 + mv] = dt;
    }
    return MF_OK;
}

int mf_prior_bench(MfPrior *p, int B, int reps, int N, int nbe, const MfNnBackend *be, MfPriorBench *res) {
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, rc = MF_OK;
    if (nbe < 1 || nbe > MF_PRIOR_BENCH_MAXBE) return mf_fail(MF_EARG, "mf_prior_bench: %d backends (1..%d)", nbe, MF_PRIOR_BENCH_MAXBE);
    size_t isz = (size_t)3 * R * R, zsz = (size_t)zc * h * h;
    int nb = B > 4 ? B : 4; /* x and rgb serve the training batch and the guided step's 4 views */
    BenchCtx c = {.p = p, .B = B};
    c.x = malloc((size_t)nb * 3 * zsz * sizeof(float)), c.rgb = malloc((size_t)nb * isz * sizeof(float));
    c.dv = malloc((size_t)B * 2 * zsz * sizeof(float)), c.tt = malloc((size_t)B * sizeof(float));
    c.keep = malloc((size_t)B * sizeof(float)), c.dy = malloc((size_t)B * isz * sizeof(float));
    c.dz = malloc((size_t)B * zsz * sizeof(float));
    c.v4 = malloc((size_t)4 * 2 * zsz * sizeof(float)), c.z4 = malloc((size_t)4 * zsz * sizeof(float));
    float *ga = malloc((size_t)N * N * sizeof(float)), *gb = malloc((size_t)N * N * sizeof(float));
    float *gc = malloc((size_t)N * N * sizeof(float));
    if (!c.x || !c.rgb || !c.dv || !c.tt || !c.keep || !c.dy || !c.dz || !c.v4 || !c.z4 || !ga || !gb || !gc)
        rc = mf_fail(MF_ENOMEM, "mf_prior_bench: out of memory");
    if (!rc) rc = mf_adamw_init(&c.odn, p->dn->tab.numel, 1e-6f, 0.9f, 0.999f, 1e-8f, 0.0f);
    if (!rc) rc = mf_adamw_init(&c.oae, p->ae->tab.numel, 1e-6f, 0.9f, 0.999f, 1e-8f, 0.0f);
    if (!rc) {
        fill(c.x, (size_t)nb * 3 * zsz, 1, 1.0f), fill(c.rgb, (size_t)nb * isz, 2, 0.5f);
        fill(c.dv, (size_t)B * 2 * zsz, 3, 1e-3f), fill(c.dy, (size_t)B * isz, 4, 1e-4f);
        fill(ga, (size_t)N * N, 5, 1.0f), fill(gb, (size_t)N * N, 6, 1.0f);
        for (int b = 0; b < B; ++b) c.tt[b] = (float)(37 * b % 1000), c.keep[b] = 1.0f;
        rc = mf_prior_encode(p, c.rgb, 4, c.z4);
    }
    /* the timings interleave: each round runs every measurement once, under each backend in turn */
    MfNnBackend was = mf_nn_backend();
    double t[MF_PRIOR_BENCH_MAXBE][5];
    for (int k = 0; k < MF_PRIOR_BENCH_MAXBE * 5; ++k) t[k / 5][k % 5] = 1e30;
    if (!rc) mf_log_info("bench-prior: %d rounds (batch %d, sgemm %d^3, %d backend(s))", reps, B, N, nbe);
    for (int r = 0; r <= reps && !rc; ++r) { /* round 0 is the warm-up */
        double t0 = mf_now();
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, N, N, N, 1.0f, ga, N, gb, N, 0.0f, gc, N);
        double dt = mf_now() - t0;
        if (r && dt < t[0][0]) t[0][0] = dt;
        for (int k = 0; k < nbe && !rc; ++k)
            if (!(rc = mf_nn_set_backend(be[k]))) rc = bench_round(&c, r, t[k]);
    }
    mf_nn_set_backend(was);
    for (int k = 0; k < nbe && !rc; ++k)
        res[k] = (MfPriorBench){t[0][0], t[k][1], t[k][2], t[k][3], t[k][4], c.fl_dn, c.fl_ae};
    free(c.x), free(c.rgb), free(c.dv), free(c.tt), free(c.keep), free(c.dy), free(c.dz), free(c.v4), free(c.z4);
    free(ga), free(gb), free(gc);
    mf_adamw_free(&c.odn), mf_adamw_free(&c.oae);
    mf_denoiser_work_free(&c.w);
    mf_ae_work_free(&c.aw);
    return rc;
}
