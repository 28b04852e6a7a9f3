/* mf_texture: bilinear UV lookup with repeat/clamp addressing and its adjoint (see mf_texture.h). */
#include "scene/mf_texture.h"

#include <math.h>

static inline int wrap_index(int i, int n, MfWrap wrap) {
    if (wrap == MF_WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
    i %= n;
    return i < 0 ? i + n : i;
}

/* Texel offsets (into h*w) of the 4 bilinear taps and their weights. */
static void tex_footprint(const MfImage *tex, float u, float v, MfWrap wrap, size_t idx[4], float wt[4]) {
    int W = tex->w, H = tex->h;
    float x = u * (float)W - 0.5f, y = (1.0f - v) * (float)H - 0.5f;
    if (!isfinite(x)) x = 0.0f;
    if (!isfinite(y)) y = 0.0f;
    if (wrap == MF_WRAP_REPEAT) { /* keep the integer part small so the cast below cannot overflow */
        x -= floorf(x / (float)W) * (float)W;
        y -= floorf(y / (float)H) * (float)H;
    } else {
        x = fminf(fmaxf(x, -1.0f), (float)W);
        y = fminf(fmaxf(y, -1.0f), (float)H);
    }
    float fx = floorf(x), fy = floorf(y);
    float tx = x - fx, ty = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    int xa = wrap_index(x0, W, wrap), xb = wrap_index(x0 + 1, W, wrap);
    int ya = wrap_index(y0, H, wrap), yb = wrap_index(y0 + 1, H, wrap);
    idx[0] = (size_t)ya * W + xa;
    idx[1] = (size_t)ya * W + xb;
    idx[2] = (size_t)yb * W + xa;
    idx[3] = (size_t)yb * W + xb;
    wt[0] = (1.0f - tx) * (1.0f - ty);
    wt[1] = tx * (1.0f - ty);
    wt[2] = (1.0f - tx) * ty;
    wt[3] = tx * ty;
}

void mf_tex_sample(const MfImage *tex, float u, float v, MfWrap wrap, float *out) {
    size_t idx[4];
    float wt[4];
    int C = tex->c;
    tex_footprint(tex, u, v, wrap, idx, wt);
    for (int c = 0; c < C; ++c) out[c] = 0.0f;
    for (int k = 0; k < 4; ++k) {
        const float *t = tex->data + idx[k] * C;
        for (int c = 0; c < C; ++c) out[c] += wt[k] * t[c];
    }
}

void mf_tex_sample_backward(const MfImage *tex, float u, float v, MfWrap wrap, const float *dout, float *dtex) {
    size_t idx[4];
    float wt[4];
    int C = tex->c;
    tex_footprint(tex, u, v, wrap, idx, wt);
    for (int k = 0; k < 4; ++k) {
        float *g = dtex + idx[k] * C;
        for (int c = 0; c < C; ++c) g[c] += wt[k] * dout[c];
    }
}
