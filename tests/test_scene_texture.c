/* Tests of mf/scene/mf_texture: bilinear exactness on linear ramps, repeat vs clamp at the
 * edges, and the adjoint (exact by linearity). */
#include <stdlib.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "io/mf_image.h"
#include "mf_test.h"
#include "scene/mf_texture.h"

/* texel (x, y) = (a + b x + c y) per channel: bilinear lookup reproduces the ramp exactly
 * wherever the 4 taps are inside the image. */
MF_TEST(texture_bilinear_ramp) {
    enum { W = 7, H = 5, C = 2 };
    MfImage t = {0};
    CHECK_OK(mf_image_alloc(&t, W, H, C));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            mf_image_px(&t, x, y)[0] = 1.0f + 2.0f * x + 3.0f * y;
            mf_image_px(&t, x, y)[1] = -0.5f * x + 0.25f * y;
        }
    MfRng rng;
    mf_rng_seed(&rng, 17, 1);
    for (int i = 0; i < 2000; ++i) {
        /* continuous texel coordinates inside [0, W-1] x [0, H-1] */
        float x = (W - 1) * mf_rng_float(&rng), y = (H - 1) * mf_rng_float(&rng);
        float u = (x + 0.5f) / W, v = 1.0f - (y + 0.5f) / H;
        float out[C];
        for (int w = 0; w < 2; ++w) {
            mf_tex_sample(&t, u, v, (MfWrap)w, out);
            CHECK_NEAR(out[0], 1.0 + 2.0 * x + 3.0 * y, 1e-4);
            CHECK_NEAR(out[1], -0.5 * x + 0.25 * y, 1e-5);
        }
    }
    /* texel centres exactly */
    float out[C];
    mf_tex_sample(&t, 3.5f / W, 1.0f - 2.5f / H, MF_WRAP_REPEAT, out);
    CHECK(out[0] == mf_image_px(&t, 3, 2)[0]);
    mf_image_free(&t);
}

MF_TEST(texture_wrap_clamp_edges) {
    enum { W = 4, H = 3 };
    MfImage t = {0};
    CHECK_OK(mf_image_alloc(&t, W, H, 1));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) mf_image_px(&t, x, y)[0] = (float)(10 * y + x);
    float o;
    /* u = 0 lies halfway between column W-1 (repeat) and column 0; clamp gives column 0 */
    float vrow1 = 1.0f - 1.5f / H;
    mf_tex_sample(&t, 0.0f, vrow1, MF_WRAP_REPEAT, &o);
    CHECK_NEAR(o, 10 + 0.5 * (0 + (W - 1)), 1e-5);
    mf_tex_sample(&t, 0.0f, vrow1, MF_WRAP_CLAMP, &o);
    CHECK_NEAR(o, 10.0, 1e-5);
    mf_tex_sample(&t, 1.0f, vrow1, MF_WRAP_CLAMP, &o);
    CHECK_NEAR(o, 10.0 + W - 1, 1e-5);
    /* v = 1 (top edge): repeat blends rows 0 and H-1, clamp stays on row 0 */
    mf_tex_sample(&t, 1.5f / W, 1.0f, MF_WRAP_REPEAT, &o);
    CHECK_NEAR(o, 1 + 0.5 * (0 + 10 * (H - 1)), 1e-5);
    mf_tex_sample(&t, 1.5f / W, 1.0f, MF_WRAP_CLAMP, &o);
    CHECK_NEAR(o, 1.0, 1e-5);
    /* repeat tiles: u + k, v + k give the same value; far outside clamp gives the corner */
    float a, b;
    mf_tex_sample(&t, 0.37f, 0.61f, MF_WRAP_REPEAT, &a);
    mf_tex_sample(&t, 0.37f + 3.0f, 0.61f - 2.0f, MF_WRAP_REPEAT, &b);
    CHECK_NEAR(a, b, 1e-4);
    mf_tex_sample(&t, -0.63f, 1.61f, MF_WRAP_REPEAT, &b);
    CHECK_NEAR(a, b, 1e-4);
    mf_tex_sample(&t, 7.0f, -5.0f, MF_WRAP_CLAMP, &o);
    CHECK_NEAR(o, 10 * (H - 1) + W - 1, 1e-6);
    mf_tex_sample(&t, -1e30f, NAN, MF_WRAP_REPEAT, &o);
    CHECK(isfinite(o));
    mf_tex_sample(&t, INFINITY, 1e30f, MF_WRAP_CLAMP, &o);
    CHECK(isfinite(o));
    mf_image_free(&t);
}

MF_TEST(texture_adjoint) {
    /* <dout, sample(tex)> summed over lookups = <backward(dout), tex>, both wrap modes,
     * lookups inside and outside [0, 1]^2 */
    enum { W = 9, H = 6, C = 3, N = 500 };
    MfImage t = {0};
    CHECK_OK(mf_image_alloc(&t, W, H, C));
    MfRng rng;
    mf_rng_seed(&rng, 23, 2);
    for (int i = 0; i < W * H * C; ++i) t.data[i] = mf_rng_normal(&rng);
    for (int w = 0; w < 2; ++w) {
        double *g = calloc(W * H * C, sizeof(double));
        float *gf = calloc(W * H * C, sizeof(float));
        double lhs = 0.0;
        for (int n = 0; n < N; ++n) {
            float u = -1.0f + 3.0f * mf_rng_float(&rng), v = -1.0f + 3.0f * mf_rng_float(&rng);
            float dout[C], out[C];
            for (int c = 0; c < C; ++c) dout[c] = mf_rng_normal(&rng);
            mf_tex_sample(&t, u, v, (MfWrap)w, out);
            for (int c = 0; c < C; ++c) lhs += (double)dout[c] * out[c];
            for (int i = 0; i < W * H * C; ++i) gf[i] = 0.0f;
            mf_tex_sample_backward(&t, u, v, (MfWrap)w, dout, gf);
            for (int i = 0; i < W * H * C; ++i) g[i] += gf[i];
        }
        double rhs = 0.0;
        for (int i = 0; i < W * H * C; ++i) rhs += g[i] * t.data[i];
        CHECK_NEAR(lhs, rhs, 1e-5 * (1.0 + fabs(lhs)));
        /* backward accumulates (+=) */
        float acc[W * H * C];
        for (int i = 0; i < W * H * C; ++i) acc[i] = 1.0f;
        float one[C] = {1, 1, 1};
        mf_tex_sample_backward(&t, 0.3f, 0.7f, (MfWrap)w, one, acc);
        double s = 0.0;
        for (int i = 0; i < W * H * C; ++i) s += acc[i];
        CHECK_NEAR(s, W * H * C + 3.0, 1e-4);
        free(g);
        free(gf);
    }
    mf_image_free(&t);
}
