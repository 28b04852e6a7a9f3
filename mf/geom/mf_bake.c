#include "geom/mf_bake.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

int mf_bake_raster(const MfMesh *m, int res, int *tid, float *bary) {
    if (!m->uv) return mf_fail(MF_EARG, "baking needs a mesh with UVs");
    size_t npx = (size_t)res * res;
    for (size_t i = 0; i < npx; ++i) tid[i] = -1;
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        float X[3], Y[3];
        for (int k = 0; k < 3; ++k) {
            X[k] = m->uv[2 * f[k]] * (float)res;
            Y[k] = (1.0f - m->uv[2 * f[k] + 1]) * (float)res;
        }
        float den = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
        if (fabsf(den) < 1e-12f) continue;
        int x0 = (int)floorf(fminf(X[0], fminf(X[1], X[2]))), x1 = (int)ceilf(fmaxf(X[0], fmaxf(X[1], X[2])));
        int y0 = (int)floorf(fminf(Y[0], fminf(Y[1], Y[2]))), y1 = (int)ceilf(fmaxf(Y[0], fmaxf(Y[1], Y[2])));
        if (x0 < 0) x0 = 0;
        if (y0 < 0) y0 = 0;
        if (x1 > res - 1) x1 = res - 1;
        if (y1 > res - 1) y1 = res - 1;
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                float px = (float)x + 0.5f, py = (float)y + 0.5f;
                float b1 = ((px - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (py - Y[0])) / den;
                float b2 = ((X[1] - X[0]) * (py - Y[0]) - (px - X[0]) * (Y[1] - Y[0])) / den;
                float b0 = 1.0f - b1 - b2;
                if (b0 < -1e-5f || b1 < -1e-5f || b2 < -1e-5f) continue;
                size_t i = (size_t)y * res + x;
                tid[i] = t;
                bary[2 * i] = b1;
                bary[2 * i + 1] = b2;
            }
    }
    return MF_OK;
}

void mf_bake_point(const MfMesh *m, const int *tid, const float *bary, size_t i, float p[3], float n[3]) {
    const uint32_t *f = m->tri + 3 * tid[i];
    float w[3] = {1.0f - bary[2 * i] - bary[2 * i + 1], bary[2 * i], bary[2 * i + 1]};
    for (int a = 0; a < 3; ++a) p[a] = n[a] = 0.0f;
    for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) {
            p[a] = p[a] + m->pos[3 * f[k] + a] * w[k];
            if (m->nrm) n[a] = n[a] + m->nrm[3 * f[k] + a] * w[k];
        }
}

int mf_bake_gutter(float *img, int res, int c, const int *tid, int gutter, const float *fill) {
    size_t npx = (size_t)res * res;
    unsigned char *cov = malloc(npx), *nxt = malloc(npx);
    double *mean = calloc((size_t)c, sizeof *mean);
    float *acc = malloc((size_t)c * sizeof *acc);
    if (!cov || !nxt || !mean || !acc) {
        free(cov), free(nxt), free(mean), free(acc);
        return mf_fail(MF_ENOMEM, "out of memory for baking");
    }
    for (size_t i = 0; i < npx; ++i) cov[i] = tid[i] >= 0;
    for (int g = 0; g < gutter; ++g) {
        memcpy(nxt, cov, npx);
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x) {
                size_t i = (size_t)y * res + x;
                if (cov[i]) continue;
                int cnt = 0;
                for (int k = 0; k < c; ++k) acc[k] = 0.0f;
                for (int dy = -1; dy <= 1; ++dy) /* neighbours summed in a fixed order */
                    for (int dx = -1; dx <= 1; ++dx) {
                        int xx = x + dx, yy = y + dy;
                        if ((!dx && !dy) || xx < 0 || yy < 0 || xx >= res || yy >= res) continue;
                        size_t jn = (size_t)yy * res + xx;
                        if (!cov[jn]) continue;
                        for (int k = 0; k < c; ++k) acc[k] += img[(size_t)c * jn + k];
                        ++cnt;
                    }
                if (!cnt) continue;
                for (int k = 0; k < c; ++k) img[(size_t)c * i + k] = acc[k] / cnt;
                nxt[i] = 1;
            }
        memcpy(cov, nxt, npx);
    }
    /* the rest: mean of the covered texels */
    size_t nc = 0;
    for (size_t i = 0; i < npx; ++i)
        if (tid[i] >= 0) {
            for (int k = 0; k < c; ++k) mean[k] += img[(size_t)c * i + k];
            ++nc;
        }
    for (size_t i = 0; i < npx; ++i)
        if (!cov[i])
            for (int k = 0; k < c; ++k) img[(size_t)c * i + k] = nc ? (float)(mean[k] / nc) : fill[k];
    free(cov);
    free(nxt);
    free(mean);
    free(acc);
    return MF_OK;
}

int mf_bake_volume(const MfMesh *m, const MfVoltex *vol, int res, int gutter, MfImage *out) {
    if (res < 1 || res > 16384) return mf_fail(MF_EARG, "bake resolution %d is outside [1, 16384]", res);
    size_t npx = (size_t)res * res;
    int *tid = malloc(npx * sizeof *tid);
    float *bary = malloc(npx * 2 * sizeof *bary), *fill = calloc((size_t)vol->c, sizeof *fill);
    MfImage img = {0};
    int rc = tid && bary && fill ? MF_OK : mf_fail(MF_ENOMEM, "out of memory for baking");
    if (!rc) rc = mf_bake_raster(m, res, tid, bary);
    if (!rc) rc = mf_image_alloc(&img, res, res, vol->c);
    size_t ncov = 0;
    for (size_t i = 0; !rc && i < npx; ++i) ncov += tid[i] >= 0;
    float *pts = rc ? NULL : malloc((ncov * 3 + 1) * sizeof *pts), *val = rc ? NULL : malloc((ncov * vol->c + 1) * sizeof *val);
    if (!rc && (!pts || !val)) rc = mf_fail(MF_ENOMEM, "out of memory for baking");
    if (!rc) { /* gather the covered texels' surface points, look them up at once, scatter */
        float n[3];
        for (size_t i = 0, j = 0; i < npx; ++i)
            if (tid[i] >= 0) mf_bake_point(m, tid, bary, i, pts + 3 * j++, n);
        mf_voltex_forward(vol, pts, (int)ncov, val);
        for (size_t i = 0, j = 0; i < npx; ++i)
            if (tid[i] >= 0) memcpy(img.data + i * (size_t)vol->c, val + (j++) * (size_t)vol->c, (size_t)vol->c * sizeof *val);
        rc = mf_bake_gutter(img.data, res, vol->c, tid, gutter, fill);
    }
    free(pts);
    free(val);
    if (!rc) *out = img, img.data = NULL;
    mf_image_free(&img);
    free(tid);
    free(bary);
    free(fill);
    return rc;
}
