/* Shared pieces of the differentiable-renderer fixtures (test_render_diffrender.c,
 * test_render_hitgrad.c; header-only).
 *
 * random_materials: the kd (w x h x 3, 0.1 .. 0.9) and ORM (w x h x 3: occlusion 1, roughness
 *                   rough_lo + 0.6 u, metallic 0.1 + 0.8 u) textures drawn texel by texel from r.
 * random_weights:   a random linear loss: weights of rgb (u - 0.3), diffuse and specular
 *                   (0.5 (u - 0.5)), n each, drawn entry by entry from r.
 * weighted_sum:     that loss of a render: sum of wr . rgb + wd . diffuse + ws . specular (n each). */
#ifndef MF_TEST_DIFF_H
#define MF_TEST_DIFF_H

#include "core/mf_rng.h"
#include "io/mf_image.h"
#include "render/mf_integrator.h"

static inline void random_materials(MfRng *r, MfImage *kd, MfImage *orm, float rough_lo) {
    for (int i = 0; i < kd->w * kd->h; ++i) {
        for (int c = 0; c < 3; ++c) kd->data[3 * i + c] = 0.1f + 0.8f * mf_rng_float(r);
        orm->data[3 * i] = 1.0f;
        orm->data[3 * i + 1] = rough_lo + 0.6f * mf_rng_float(r);
        orm->data[3 * i + 2] = 0.1f + 0.8f * mf_rng_float(r);
    }
}

static inline void random_weights(MfRng *r, float *wr, float *wd, float *ws, int n) {
    for (int i = 0; i < n; ++i) {
        wr[i] = mf_rng_float(r) - 0.3f;
        wd[i] = 0.5f * (mf_rng_float(r) - 0.5f);
        ws[i] = 0.5f * (mf_rng_float(r) - 0.5f);
    }
}

static inline double weighted_sum(const MfRenderOut *out, const float *wr, const float *wd, const float *ws, int n) {
    double j = 0;
    for (int i = 0; i < n; ++i) j += (double)wr[i] * out->rgb[i] + (double)wd[i] * out->diffuse[i] + (double)ws[i] * out->specular[i];
    return j;
}

#endif
