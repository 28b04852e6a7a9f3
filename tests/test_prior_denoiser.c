/* Tests of mf/prior/mf_denoiser: its gradients against central differences. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "io/mf_ckpt.h"
#include "prior/mf_prior.h"
#include "prior/mf_prior_train.h"
#include "tests/mf_test.h"
#include "tests/mf_test_grad.h"
#include "tests/mf_test_prior.h"

/* ---- gradient checks -------------------------------------------------------------------------------- */
typedef struct {
    MfDenoiser *dn;
    MfDenoiserWork w;
    const float *x, *t, *rgb, *keep, *wout;
    int B, V, joint;
} DnGC;

static double dn_loss(void *ctx) {
    DnGC *g = ctx;
    float *v = mf_denoiser_forward(g->dn, &g->w, g->x, g->t, g->rgb, g->keep, g->B, g->V, g->joint);
    const MfDenoiserConfig *c = &g->dn->cfg;
    return tp_dot(v, g->wout, (size_t)g->B * 2 * c->zc * c->h * c->h);
}

MF_TEST(prior_denoiser_gradients) {
    MfPriorConfig pc;
    mf_prior_config_tiny(&pc);
    MfDenoiser *dn;
    CHECK_OK(mf_denoiser_new(&dn, &pc.dn));
    mf_denoiser_init_weights(dn, 3);
    mf_kconv_init(&dn->cout, dn->params, 99, 0); /* non-zero output conv so every layer gets gradient */
    const MfDenoiserConfig *c = &dn->cfg;
    int B = 4, V = 2;
    size_t nx = (size_t)B * 3 * c->zc * c->h * c->h, nv = (size_t)B * 2 * c->zc * c->h * c->h,
           ni = (size_t)B * 3 * c->img_res * c->img_res;
    float *x = malloc(nx * sizeof(float)), *rgb = malloc(ni * sizeof(float)), *wo = malloc(nv * sizeof(float));
    float t[4] = {10, 500, 999, 250}, keep[4] = {1, 0, 1, 1};
    tp_fill(x, nx, 4, 1.0f), tp_fill(rgb, ni, 5, 1.0f), tp_fill(wo, nv, 6, 1.0f);
    for (int joint = 0; joint < 2; ++joint) {
        DnGC g = {.dn = dn, .x = x, .t = t, .rgb = rgb, .keep = keep, .wout = wo, .B = B, .V = V, .joint = joint};
        dn_loss(&g);
        memset(dn->grads, 0, dn->tab.numel * sizeof(float));
        mf_denoiser_backward(dn, &g.w, wo);
        int checked = 0;
        int bad = grad_check(dn_loss, &g, dn->params, dn->grads, dn->tab.numel, 0, 1 + dn->tab.numel / 150, 1e-2, 2e-2,
                             "param", &checked);
        CHECK_MSG(bad == 0, "joint %d: %d of %d denoiser gradient entries off", joint, bad, checked);
        mf_denoiser_work_free(&g.w);
    }
    free(x), free(rgb), free(wo);
    mf_denoiser_free(dn);
}

/* The DDIM steps of one sample reuse the condition images' embedding (mf_denoiser_forward_ex with
 * same_rgb): a step so computed equals, bit for bit, the same step on fresh work buffers; a
 * different rgb without same_rgb gives a different prediction (the embedding is not stale). */
MF_TEST(prior_denoiser_reuses_image_embedding) {
    MfPrior *p;
    tp_tiny_prior(&p);
    int B = 4, R = 16, zc = 4, h = 4;
    size_t ni = (size_t)B * 3 * R * R, nx = (size_t)B * 3 * zc * h * h, nv = (size_t)B * 2 * zc * h * h;
    float *rgb = malloc(ni * sizeof(float)), *rgb2 = malloc(ni * sizeof(float));
    float *x1 = malloc(nx * sizeof(float)), *x2 = malloc(nx * sizeof(float)), *va = malloc(nv * sizeof(float));
    tp_fill(rgb, ni, 1, 1.0f), tp_fill(rgb2, ni, 7, 1.0f), tp_fill(x1, nx, 2, 1.0f), tp_fill(x2, nx, 3, 1.0f);
    float t1[4] = {800, 800, 800, 800}, t2[4] = {640, 640, 640, 640}, keep[4] = {1, 0, 1, 0};
    MfDenoiserWork w = {0}, f = {0};
    CHECK(mf_denoiser_forward(p->dn, &w, x1, t1, rgb, keep, B, 1, 0) != NULL);
    float *v = mf_denoiser_forward_ex(p->dn, &w, x2, t2, rgb, keep, B, 1, 0, 1);
    CHECK(v != NULL);
    if (v) memcpy(va, v, nv * sizeof(float));
    float *vf = mf_denoiser_forward(p->dn, &f, x2, t2, rgb, keep, B, 1, 0);
    CHECK(vf != NULL);
    CHECK_MSG(vf && !memcmp(va, vf, nv * sizeof(float)), "a step with the reused embedding differs from a fresh one");
    v = mf_denoiser_forward_ex(p->dn, &w, x2, t2, rgb2, keep, B, 1, 0, 0);
    double d = 0.0;
    for (size_t i = 0; v && i < nv; ++i) d = fmax(d, fabs(v[i] - va[i]));
    CHECK_MSG(d > 1e-6, "another condition image changes the prediction by %g only", d);
    mf_denoiser_work_free(&w), mf_denoiser_work_free(&f);
    free(rgb), free(rgb2), free(x1), free(x2), free(va);
    mf_prior_free(p);
}
