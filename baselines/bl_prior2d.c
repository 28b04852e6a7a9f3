/* bl_prior2d: see bl_prior2d.h. */
#include "baselines/bl_prior2d.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

static int check_rgba(const MfImage *im, const char *what) {
    if (!im || !im->data || im->c != 4 || im->w < 1 || im->h < 1)
        return mf_fail(MF_EARG, "%s: expected an RGBA image", what);
    return MF_OK;
}

int bl_albedo_input(const MfImage *rgb, MfImage *out) {
    int rc = check_rgba(rgb, "input-albedo baseline");
    if (rc) return rc;
    if (mf_image_alloc(out, rgb->w, rgb->h, 4)) return mf_fail(MF_ENOMEM, "out of memory");
    memcpy(out->data, rgb->data, (size_t)rgb->w * rgb->h * 4 * sizeof(float));
    return MF_OK;
}

/* Separable Gaussian blur of src (h, w) into dst, zero outside the image (normalised later). */
static void blur(const float *src, float *dst, float *tmp, int w, int h, const float *k, int r) {
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0;
            for (int d = -r; d <= r; ++d)
                if (x + d >= 0 && x + d < w) s += k[d + r] * src[y * w + x + d];
            tmp[y * w + x] = (float)s;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0;
            for (int d = -r; d <= r; ++d)
                if (y + d >= 0 && y + d < h) s += k[d + r] * tmp[(y + d) * w + x];
            dst[y * w + x] = (float)s;
        }
}

int bl_albedo_retinex(const MfImage *rgb, float sigma, MfImage *out) {
    int rc = check_rgba(rgb, "Retinex baseline");
    if (rc) return rc;
    if (!(sigma > 0)) return mf_fail(MF_EARG, "Retinex baseline: sigma must be > 0");
    int w = rgb->w, h = rgb->h, r = (int)ceilf(3 * sigma);
    size_t hw = (size_t)w * h;
    float *lm = calloc(hw, sizeof(float)), *m = calloc(hw, sizeof(float)), *tmp = calloc(hw, sizeof(float));
    float *k = malloc((size_t)(2 * r + 1) * sizeof(float));
    if (!lm || !m || !tmp || !k || mf_image_alloc(out, w, h, 4)) {
        free(lm), free(m), free(tmp), free(k);
        return mf_fail(MF_ENOMEM, "Retinex baseline: out of memory");
    }
    for (int d = -r; d <= r; ++d) k[d + r] = expf(-0.5f * d * d / (sigma * sigma));
    for (size_t p = 0; p < hw; ++p) {
        const float *c = rgb->data + p * 4;
        m[p] = c[3] > 0.5f ? 1.0f : 0.0f;
        lm[p] = m[p] * (0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]);
    }
    blur(lm, lm, tmp, w, h, k, r);
    blur(m, m, tmp, w, h, k, r);
    for (size_t p = 0; p < hw; ++p) {
        const float *c = rgb->data + p * 4;
        float *o = out->data + p * 4;
        int in = c[3] > 0.5f;
        float s = m[p] > 1e-6f ? lm[p] / m[p] : 0.0f;
        if (s < 1e-4f) s = 1e-4f;
        for (int j = 0; j < 3; ++j) o[j] = in ? c[j] / s : 0.0f;
        o[3] = c[3];
    }
    free(lm), free(m), free(tmp), free(k);
    return MF_OK;
}

int bl_orm_constant(const MfImage *like, float roughness, float metallic, MfImage *out) {
    int rc = check_rgba(like, "constant-ORM baseline");
    if (rc) return rc;
    if (mf_image_alloc(out, like->w, like->h, 4)) return mf_fail(MF_ENOMEM, "out of memory");
    for (size_t p = 0; p < (size_t)like->w * like->h; ++p) {
        float *o = out->data + p * 4;
        o[0] = 1.0f, o[1] = roughness, o[2] = metallic, o[3] = like->data[p * 4 + 3];
    }
    return MF_OK;
}

int bl_orm_mean(const MfImage *const *orm, int n, float *roughness, float *metallic) {
    double sr = 0, sm = 0;
    size_t cnt = 0;
    for (int i = 0; i < n; ++i) {
        int rc = check_rgba(orm[i], "ORM mean");
        if (rc) return rc;
        for (size_t p = 0; p < (size_t)orm[i]->w * orm[i]->h; ++p) {
            const float *c = orm[i]->data + p * 4;
            if (c[3] > 0.5f) sr += c[1], sm += c[2], ++cnt;
        }
    }
    if (!cnt) return mf_fail(MF_EARG, "ORM mean: no pixel inside the masks of %d image(s)", n);
    *roughness = (float)(sr / cnt), *metallic = (float)(sm / cnt);
    return MF_OK;
}
