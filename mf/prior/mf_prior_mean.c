/* mf_prior_predict_mean: the prior's material maps for a set of views, mean of S samples
 * (mf_prior.h). */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "prior/mf_prior.h"

int mf_prior_predict_mean(MfPrior *p, const MfImage *rgb_in, int nv, int V, int joint, int S, int steps, float guidance,
                          uint64_t seed, MfImage *alb, MfImage *orm) {
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, B = S * nv, rc = MF_OK;
    if (!joint) V = 1;
    size_t isz = (size_t)3 * R * R, hw = (size_t)R * R, zsz = (size_t)zc * h * h;
    float *rgb = malloc((size_t)B * isz * sizeof(float)), *mask = malloc((size_t)nv * hw * sizeof(float));
    float *zmat = malloc((size_t)B * 2 * zsz * sizeof(float)), *zk = malloc((size_t)B * zsz * sizeof(float));
    float *dec = malloc((size_t)B * isz * sizeof(float)), *mean = malloc((size_t)nv * isz * sizeof(float));
    float *one = malloc(isz * sizeof(float)); /* (3, R, R) one prepared view */
    if (!rgb || !mask || !zmat || !zk || !dec || !mean || !one) rc = mf_fail(MF_ENOMEM, "mf_prior_predict_mean: out of memory");
    /* item b: joint -> (object o, sample k, view v) with b = (o * S + k) * V + v; else b = j * S + k */
    for (int j = 0; j < nv && !rc; ++j) {
        mf_prior_prepare_image(rgb_in[j].data, rgb_in[j].w, rgb_in[j].h, R, one, mask + j * hw);
        for (int k = 0; k < S; ++k) {
            int b = joint ? ((j / V) * S + k) * V + j % V : j * S + k;
            memcpy(rgb + (size_t)b * isz, one, isz * sizeof(float));
        }
    }
    if (!rc) rc = mf_prior_sample(p, rgb, B, V, joint, steps, guidance, seed, zmat);
    for (int kind = 0; kind < 2 && !rc; ++kind) {
        for (int b = 0; b < B; ++b) memcpy(zk + b * zsz, zmat + ((size_t)b * 2 + kind) * zsz, zsz * sizeof(float));
        if ((rc = mf_prior_decode(p, zk, B, dec))) break;
        memset(mean, 0, (size_t)nv * isz * sizeof(float));
        for (int b = 0; b < B; ++b) {
            int j = joint ? (b / (S * V)) * V + b % V : b / S;
            for (size_t q = 0; q < isz; ++q) mean[j * isz + q] += dec[b * isz + q] / (float)S;
        }
        for (int j = 0; j < nv && !rc; ++j) {
            MfImage *out = kind ? &orm[j] : &alb[j];
            if (mf_image_alloc(out, R, R, 4)) {
                rc = mf_fail(MF_ENOMEM, "mf_prior_predict_mean: out of memory");
                break;
            }
            for (size_t q = 0; q < hw; ++q) {
                float a = mask[j * hw + q];
                for (int c = 0; c < 3; ++c) {
                    float v = a > 1e-3f ? 0.5f * (mean[j * isz + c * hw + q] / a + 1.0f) : 0.0f;
                    v = v < 0 ? 0 : v > 1 ? 1 : v;
                    if (kind && c == 0) v = 1.0f;
                    out->data[q * 4 + c] = kind ? v : mf_srgb_to_linear(v);
                }
                out->data[q * 4 + 3] = a;
            }
        }
    }
    free(rgb), free(mask), free(zmat), free(zk), free(dec), free(mean), free(one);
    return rc;
}
