/* mf_texture: bilinear UV lookup with repeat/clamp addressing and its adjoint (see mf_texture.h). */
#include "scene/mf_texture.h"

#include <math.h>

static inline int wrap_index(int i, int n, MfWrap wrap) {
    if (wrap == MF_WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
    i %= n;
    return i < 0 ? i + n : i;
}

/* Texel offsets (into h*w) of the 4 bilinear taps, their weights and the fractions (tx, ty). */
static void tex_taps(const MfImage *tex, float u, float v, MfWrap wrap, size_t idx[4], float wt[4], float *ftx,
                     float *fty) {
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
    *ftx = tx;
    *fty = ty;
}

static void tex_footprint(const MfImage *tex, float u, float v, MfWrap wrap, size_t idx[4], float wt[4]) {
    float tx, ty;
    tex_taps(tex, u, v, wrap, idx, wt, &tx, &ty);
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

void mf_tex_sample_grad_uv(const MfImage *tex, float u, float v, MfWrap wrap, const float *dout, int nc, float *du,
                           float *dv) {
    size_t idx[4];
    float wt[4], tx, ty;
    int C = tex->c;
    tex_taps(tex, u, v, wrap, idx, wt, &tx, &ty);
    float gx = 0.0f, gy = 0.0f; /* d<dout, sample> / d(x, y) in texel units */
    for (int c = 0; c < nc && c < C; ++c) {
        float t00 = tex->data[idx[0] * C + c], t01 = tex->data[idx[1] * C + c];
        float t10 = tex->data[idx[2] * C + c], t11 = tex->data[idx[3] * C + c];
        gx += dout[c] * ((1.0f - ty) * (t01 - t00) + ty * (t11 - t10));
        gy += dout[c] * ((1.0f - tx) * (t10 - t00) + tx * (t11 - t01));
    }
    *du += gx * (float)tex->w;  /* x = u W - 0.5 */
    *dv -= gy * (float)tex->h;  /* y = (1 - v) H - 0.5 */
}
