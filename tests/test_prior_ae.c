/* Tests of mf/prior/mf_ae: the autoencoder's shapes and its gradients against central differences. */

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
    MfAe *ae;
    MfAeWork w;
    const float *x, *wout;
    int B;
} AeGC;

static double ae_loss(void *ctx) {
    AeGC *g = ctx;
    float *z = mf_ae_encode(g->ae, &g->w, g->x, g->B), *y = mf_ae_decode(g->ae, &g->w, z, g->B);
    int R = g->ae->cfg.res;
    return tp_dot(y, g->wout, (size_t)g->B * 3 * R * R);
}

MF_TEST(prior_ae_shapes_and_gradients) {
    MfAeConfig cfg = {8, 2, 4, 4, 2};
    MfAe *ae;
    CHECK_OK(mf_ae_new(&ae, &cfg));
    mf_ae_init_weights(ae, 7);
    int B = 2, R = 8;
    size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * 4 * 2 * 2;
    CHECK(ae->enc.C == 4 && ae->enc.H == 2 && ae->dec.C == 3 && ae->dec.H == 8);
    float *x = malloc(ni * sizeof(float)), *wo = malloc(ni * sizeof(float)), *dx = calloc(ni, sizeof(float));
    float *dz = calloc(nz, sizeof(float));
    tp_fill(x, ni, 1, 1.0f), tp_fill(wo, ni, 2, 1.0f);
    AeGC g = {.ae = ae, .x = x, .wout = wo, .B = B};
    ae_loss(&g);
    memset(ae->grads, 0, ae->tab.numel * sizeof(float));
    mf_ae_decode_backward(ae, &g.w, wo, dz);
    mf_ae_encode_backward(ae, &g.w, dz, dx);
    /* parameters: a spread of indices over every tensor */
    int bad = 0, checked = 0;
    double gmax = 0;
    for (size_t i = 0; i < ae->tab.numel; ++i) gmax = fmax(gmax, fabs(ae->grads[i]));
    CHECK(gmax > 1e-2); /* the check below is not vacuous */
    bad += grad_check(ae_loss, &g, ae->params, ae->grads, ae->tab.numel, 0, 1 + ae->tab.numel / 60, 1e-2, 2e-2, "param", &checked);
    bad += grad_check(ae_loss, &g, x, dx, ni, 0, 13, 1e-2, 2e-2, "input", &checked); /* |x| < 1: step 1e-2 */
    CHECK_MSG(bad == 0, "%d of %d AE gradient entries off", bad, checked);
    mf_ae_work_free(&g.w);
    free(x), free(wo), free(dx), free(dz);
    mf_ae_free(ae);
}

/* The frozen encoder's backward (mf_ae_encode_backward_input, what SDS uses) gives the same input
 * gradient bit for bit as the full backward and leaves the weight gradients alone: at 8 px (the
 * convolutions' batched path) and at 32 px (per-item GEMMs at full resolution, 1x1 skip convs). */
MF_TEST(prior_ae_encode_backward_input_only) {
    MfAeConfig cfgs[2] = {{8, 2, 4, 4, 2}, {32, 4, 8, 4, 2}};
    for (int c = 0; c < 2; ++c) {
        MfAe *ae;
        CHECK_OK(mf_ae_new(&ae, &cfgs[c]));
        mf_ae_init_weights(ae, 11);
        int B = 3, R = cfgs[c].res, h = R / 4;
        size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * 4 * h * h;
        float *x = malloc(ni * sizeof(float)), *dz = malloc(nz * sizeof(float));
        float *da = calloc(ni, sizeof(float)), *db = calloc(ni, sizeof(float));
        tp_fill(x, ni, 3, 1.0f), tp_fill(dz, nz, 4, 1.0f);
        MfAeWork w = {0};
        CHECK(mf_ae_encode(ae, &w, x, B) != NULL);
        memset(ae->grads, 0, ae->tab.numel * sizeof(float));
        mf_ae_encode_backward(ae, &w, dz, da);
        double gsum = 0.0;
        for (size_t i = 0; i < ae->tab.numel; ++i) gsum += fabs(ae->grads[i]);
        CHECK(gsum > 0.0);
        memset(ae->grads, 0, ae->tab.numel * sizeof(float));
        mf_ae_encode_backward_input(ae, &w, dz, db);
        size_t diff = 0, nonzero = 0, gtouched = 0;
        for (size_t i = 0; i < ni; ++i) diff += memcmp(&da[i], &db[i], sizeof(float)) != 0, nonzero += da[i] != 0.0f;
        for (size_t i = 0; i < ae->tab.numel; ++i) gtouched += ae->grads[i] != 0.0f;
        CHECK_MSG(diff == 0 && nonzero > ni / 2, "res %d: %zu of %zu input gradients differ (%zu non-zero)", R, diff, ni, nonzero);
        CHECK_MSG(gtouched == 0, "res %d: the input-only backward wrote %zu weight gradients", R, gtouched);
        mf_ae_work_free(&w);
        free(x), free(dz), free(da), free(db);
        mf_ae_free(ae);
    }
}
