#include "inverse/mf_denoise.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

#define W_EPS 1e-4f    /* nvdiffrecmc's FLT_EPS: normal clamp and depth denominator floor */
#define DZ_BIG 1e30f   /* dz of grazing / degenerate planes: depth term ~ 1 */
#define MAX_CH 8
#define CACHE_MAX ((size_t)48 << 20) /* weights cached up to this many floats (192 MB) */

/* Weight of tap t = p + (dx, dy) for output pixel p (both covered): nvdiffrecmc's product of
 * spatial, normal and depth terms. The depth term exp(-|z_t - z_p| / max(dz_p dist, 1e-4)) is
 * computed as exp(-|z_t - z_p| min(1/dz_p * 1/dist, 1e4)); terms below 1e-30 (or past e^-80)
 * are 0. The one function behind the forward, the cache and the adjoint. */
static inline float weight(const MfBilateral *b, size_t p, size_t t, int dx, int dy) {
    if (dx == 0 && dy == 0) return 1.0f; /* centre: normal and depth terms are 1 by definition */
    int r = b->radius;
    size_t k = (size_t)(dy + r) * (size_t)(2 * r + 1) + (size_t)(dx + r);
    const float *np = b->normal + 3 * p, *nt = b->normal + 3 * t;
    float d = np[0] * nt[0] + np[1] * nt[1] + np[2] * nt[2];
    d = d < W_EPS ? W_EPS : d > 1.0f ? 1.0f : d;
    for (int i = 0; i < 7; ++i) d *= d; /* ^128 */
    float sn = b->spatial[k] * d;
    if (!(sn > 1e-30f)) return 0.0f;
    float inv = b->inv_dz[p] * b->inv_dist[k];
    if (!(inv < 1.0f / W_EPS)) inv = 1.0f / W_EPS;
    float a = fabsf(b->depth[t] - b->depth[p]) * inv;
    if (!(a < 80.0f)) return 0.0f;
    return sn * expf(-a);
}

void mf_bilateral_depth_slope(const MfCamera *cam, const float *normal, const float *depth, const float *alpha,
                              float *dz) {
    MfVec3 fwd = mf_v3(-cam->c2w.m[2], -cam->c2w.m[6], -cam->c2w.m[10]);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < cam->h; ++y)
        for (int x = 0; x < cam->w; ++x) {
            size_t i = (size_t)y * cam->w + x;
            dz[i] = DZ_BIG;
            if (!(alpha[i] > 0.0f)) continue;
            MfVec3 n = mf_v3(normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]), o, d0;
            mf_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, &o, &d0);
            float c0 = mf_dot(d0, fwd);
            if (!(c0 > 0.0f)) continue;
            MfVec3 P = mf_madd(o, d0, depth[i] / c0);
            float best = 0.0f;
            for (int k = 0; k < 2; ++k) {
                MfVec3 o1, d1;
                mf_camera_ray(cam, (float)x + 0.5f + (k == 0), (float)y + 0.5f + (k == 1), &o1, &d1);
                float den = mf_dot(n, d1), t1 = mf_dot(n, mf_sub(P, o1)) / den;
                float s = fabsf(t1 * mf_dot(d1, fwd) - depth[i]);
                if (!(fabsf(den) > 1e-6f) || !(t1 > 0.0f) || !(s < DZ_BIG)) s = DZ_BIG;
                if (s > best) best = s;
            }
            dz[i] = best;
        }
}

void mf_bilateral_free(MfBilateral *b) {
    if (!b) return;
    free(b->spatial);
    free(b->inv_dist);
    free(b->normal);
    free(b->inv_dz);
    free(b->inv_norm);
    free(b->wcache);
    memset(b, 0, sizeof *b);
}

int mf_bilateral_init(MfBilateral *b, int w, int h, float sigma, const float *normal, const float *depth,
                      const float *dz, const float *alpha) {
    if (w <= 0 || h <= 0) return mf_fail(MF_EARG, "bilateral: image size %dx%d", w, h);
    if (!(sigma > 0.0f && sigma <= 8.0f)) return mf_fail(MF_EARG, "bilateral: sigma %g outside (0, 8]", (double)sigma);
    int radius = 2 * (int)ceilf(sigma * 2.5f) + 1, side = 2 * radius + 1;
    size_t np = (size_t)w * h, S = (size_t)side * side;
    /* buffers are kept across calls of the same size and radius (the cache is tens of MB:
     * fresh pages every view would cost more than the filter) */
    if (!(b->spatial && b->w == w && b->h == h && b->radius == radius)) {
        mf_bilateral_free(b);
        b->spatial = malloc(S * sizeof(float));
        b->inv_dist = malloc(S * sizeof(float));
        b->normal = malloc(np * 3 * sizeof(float));
        b->inv_dz = malloc(np * sizeof(float));
        b->inv_norm = malloc(np * sizeof(float));
        if (np * S <= CACHE_MAX) b->wcache = malloc(np * S * sizeof(float)); /* NULL: recomputed */
        if (!b->spatial || !b->inv_dist || !b->normal || !b->inv_dz || !b->inv_norm) {
            mf_bilateral_free(b);
            return mf_fail(MF_ENOMEM, "bilateral: out of memory for a %dx%d guide", w, h);
        }
    }
    MfBilateral t = *b; /* filled here, published at the end */
    t.w = w, t.h = h, t.sigma = sigma, t.radius = radius;
    t.depth = depth, t.dz = dz, t.alpha = alpha;
    for (int dy = -t.radius; dy <= t.radius; ++dy)
        for (int dx = -t.radius; dx <= t.radius; ++dx) {
            size_t k = (size_t)(dy + t.radius) * side + dx + t.radius;
            t.spatial[k] = expf(-(float)(dx * dx + dy * dy) / (2.0f * sigma * sigma));
            t.inv_dist[k] = dx || dy ? 1.0f / sqrtf((float)(dx * dx + dy * dy)) : 0.0f;
        }
    for (size_t i = 0; i < np; ++i) {
        const float *n = normal + 3 * i;
        float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        float s = l > 1e-12f && isfinite(l) ? 1.0f / l : 0.0f;
        for (int c = 0; c < 3; ++c) t.normal[3 * i + c] = n[c] * s;
        t.inv_dz[i] = 1.0f / dz[i]; /* dz = 0: inf, clamped in weight() */
    }
    int r = t.radius;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            size_t p = (size_t)y * w + x;
            float ap = alpha[p];
            if (!(ap > 0.0f)) {
                t.inv_norm[p] = 0.0f;
                continue;
            }
            /* cache entries of taps outside the image or uncovered are never read */
            float sum = 0.0f, *wc = t.wcache ? t.wcache + p * S : NULL;
            for (int dy = -r; dy <= r; ++dy) {
                int ty = y + dy;
                if (ty < 0 || ty >= h) continue;
                for (int dx = -r; dx <= r; ++dx) {
                    int tx = x + dx;
                    if (tx < 0 || tx >= w) continue;
                    size_t q = (size_t)ty * w + tx;
                    if (!(alpha[q] > 0.0f)) continue;
                    float wt = weight(&t, p, q, dx, dy);
                    if (wc) wc[(size_t)(dy + r) * side + dx + r] = wt;
                    sum += wt * alpha[q];
                }
            }
            t.inv_norm[p] = ap / sum; /* sum >= ap (centre tap) > 0 */
        }
    *b = t;
    return MF_OK;
}

int mf_bilateral_forward(const MfBilateral *b, const float *in, int c, float *out) {
    if (c < 1 || c > MAX_CH) return mf_fail(MF_EARG, "bilateral: %d channels outside [1, %d]", c, MAX_CH);
    int w = b->w, h = b->h, r = b->radius, side = 2 * r + 1;
    size_t S = (size_t)side * side;
    const float *alpha = b->alpha;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            size_t p = (size_t)y * w + x;
            float acc[MAX_CH] = {0};
            const float *wc = b->wcache ? b->wcache + p * S : NULL;
            if (b->inv_norm[p] > 0.0f) {
                for (int dy = -r; dy <= r; ++dy) {
                    int ty = y + dy;
                    if (ty < 0 || ty >= h) continue;
                    for (int dx = -r; dx <= r; ++dx) {
                        int tx = x + dx;
                        if (tx < 0 || tx >= w) continue;
                        size_t q = (size_t)ty * w + tx;
                        if (!(alpha[q] > 0.0f)) continue;
                        float wt = wc ? wc[(size_t)(dy + r) * side + dx + r] : weight(b, p, q, dx, dy);
                        if (wt == 0.0f) continue;
                        for (int k = 0; k < c; ++k) acc[k] += wt * in[q * c + k];
                    }
                }
            }
            for (int k = 0; k < c; ++k) out[p * c + k] = acc[k] * b->inv_norm[p];
        }
    return MF_OK;
}

int mf_bilateral_backward(const MfBilateral *b, const float *dout, int c, float *din) {
    if (c < 1 || c > MAX_CH) return mf_fail(MF_EARG, "bilateral: %d channels outside [1, %d]", c, MAX_CH);
    int w = b->w, h = b->h, r = b->radius, side = 2 * r + 1;
    size_t S = (size_t)side * side;
    const float *alpha = b->alpha;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            size_t t = (size_t)y * w + x;
            if (!(alpha[t] > 0.0f)) continue; /* background taps have weight 0 */
            float acc[MAX_CH] = {0};
            /* gather over the output pixels p = t + (ex, ey) whose window holds t */
            for (int ey = -r; ey <= r; ++ey) {
                int py = y + ey;
                if (py < 0 || py >= h) continue;
                for (int ex = -r; ex <= r; ++ex) {
                    int px = x + ex;
                    if (px < 0 || px >= w) continue;
                    size_t p = (size_t)py * w + px;
                    float s = b->inv_norm[p];
                    if (!(s > 0.0f)) continue;
                    float wt = (b->wcache ? b->wcache[p * S + (size_t)(r - ey) * side + (r - ex)] : weight(b, p, t, -ex, -ey)) * s;
                    if (wt == 0.0f) continue;
                    for (int k = 0; k < c; ++k) acc[k] += wt * dout[p * c + k];
                }
            }
            for (int k = 0; k < c; ++k) din[t * c + k] += acc[k];
        }
    return MF_OK;
}

static inline float clamp01(float v) { return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; }

int mf_denoise_combine_forward(const MfBilateral *b, const float *diffuse, const float *specular, const float *albedo,
                               const float *orm, float *dn_diffuse, float *dn_specular, float *rgb) {
    size_t np = (size_t)b->w * b->h;
    float *buf = calloc(np * 12, sizeof(float)); /* zeroed: no uninitialised read even with np = 0 */
    if (!buf) return mf_fail(MF_ENOMEM, "denoise: out of memory");
    float *in = buf, *out = buf + np * 6;
    for (size_t i = 0; i < np; ++i)
        for (int k = 0; k < 3; ++k) in[6 * i + k] = diffuse[3 * i + k], in[6 * i + 3 + k] = specular[3 * i + k];
    int rc = mf_bilateral_forward(b, in, 6, out);
    if (!rc)
        for (size_t i = 0; i < np; ++i) {
            float m = clamp01(orm[3 * i + 2]);
            for (int k = 0; k < 3; ++k) {
                float d = out[6 * i + k], s = out[6 * i + 3 + k];
                dn_diffuse[3 * i + k] = d;
                dn_specular[3 * i + k] = s;
                rgb[3 * i + k] = albedo[3 * i + k] * (1.0f - m) * d + s;
            }
        }
    free(buf);
    return rc;
}

int mf_denoise_combine_backward(const MfBilateral *b, const float *dn_diffuse, const float *albedo, const float *orm,
                                const float *drgb, const float *d_dn_diffuse, const float *d_dn_specular,
                                float *ddiffuse, float *dspecular, float *dalbedo, float *dorm) {
    size_t np = (size_t)b->w * b->h;
    float *buf = malloc(np * 12 * sizeof(float));
    if (!buf) return mf_fail(MF_ENOMEM, "denoise: out of memory");
    float *g = buf, *gin = buf + np * 6;
    for (size_t i = 0; i < np; ++i) {
        float mo = orm[3 * i + 2], m = clamp01(mo), gm = 0.0f;
        for (int k = 0; k < 3; ++k) {
            size_t j = 3 * i + k;
            float a = albedo[j] * (1.0f - m);
            g[6 * i + k] = drgb[j] * a + (d_dn_diffuse ? d_dn_diffuse[j] : 0.0f);
            g[6 * i + 3 + k] = drgb[j] + (d_dn_specular ? d_dn_specular[j] : 0.0f);
            float ga = drgb[j] * dn_diffuse[j]; /* dLoss / d(albedo (1 - m)) */
            if (dalbedo) dalbedo[j] += ga * (1.0f - m);
            gm -= ga * albedo[j];
        }
        if (dorm && mo >= 0.0f && mo <= 1.0f) dorm[3 * i + 2] += gm;
    }
    memset(gin, 0, np * 6 * sizeof(float));
    int rc = mf_bilateral_backward(b, g, 6, gin);
    if (!rc)
        for (size_t i = 0; i < np; ++i)
            for (int k = 0; k < 3; ++k) ddiffuse[3 * i + k] += gin[6 * i + k], dspecular[3 * i + k] += gin[6 * i + 3 + k];
    free(buf);
    return rc;
}
