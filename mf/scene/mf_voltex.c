#include "scene/mf_voltex.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

int mf_voltex_init(MfVoltex *v, int res, int c, const float lo[3], const float hi[3], const float *fill) {
    if (res < 2 || res > 1024) return mf_fail(MF_EARG, "volume texture resolution %d is outside [2, 1024]", res);
    if (c < 1) return mf_fail(MF_EARG, "volume texture needs at least 1 channel (got %d)", c);
    for (int a = 0; a < 3; ++a)
        if (!(hi[a] > lo[a]) || !isfinite(lo[a]) || !isfinite(hi[a]))
            return mf_fail(MF_EARG, "volume texture box is empty or not finite on axis %d: [%g, %g]", a, lo[a], hi[a]);
    size_t nvert = (size_t)res * res * res;
    float *g = fill ? malloc(nvert * (size_t)c * sizeof *g) : calloc(nvert * (size_t)c, sizeof *g);
    if (!g) return mf_fail(MF_ENOMEM, "out of memory for a %d^3 x %d volume texture", res, c);
    if (fill)
        for (size_t i = 0; i < nvert; ++i) memcpy(g + i * (size_t)c, fill, (size_t)c * sizeof *g);
    v->res = res;
    v->c = c;
    memcpy(v->lo, lo, sizeof v->lo);
    memcpy(v->hi, hi, sizeof v->hi);
    v->grid = g;
    return MF_OK;
}

void mf_voltex_free(MfVoltex *v) {
    if (!v) return;
    free(v->grid);
    memset(v, 0, sizeof *v);
}

size_t mf_voltex_size(const MfVoltex *v) { return (size_t)v->res * v->res * v->res * (size_t)v->c; }

/* The cell of one point: base vertex index (into res^3), fractions f (3,), per-axis derivative
 * of the grid coordinate with respect to the world coordinate (0 when clamped). */
typedef struct { size_t base; float f[3], du[3]; } Cell;

static Cell cell_of(const MfVoltex *v, const float *p) {
    Cell cl;
    int idx[3];
    float r1 = (float)(v->res - 1);
    for (int a = 0; a < 3; ++a) {
        float scale = r1 / (v->hi[a] - v->lo[a]);
        float u = (p[a] - v->lo[a]) * scale;
        cl.du[a] = scale;
        if (!(u >= 0.0f)) u = 0.0f, cl.du[a] = 0.0f; /* also NaN */
        else if (u > r1) u = r1, cl.du[a] = 0.0f;
        int i = (int)floorf(u);
        if (i > v->res - 2) i = v->res - 2;
        idx[a] = i;
        cl.f[a] = u - (float)i;
    }
    cl.base = ((size_t)idx[2] * v->res + idx[1]) * v->res + idx[0];
    return cl;
}

/* Offset (in vertices) of corner k (bit 0: +x, bit 1: +y, bit 2: +z) and its weight and the
 * weight's partial derivatives with respect to the fractions. */
static void corner(const MfVoltex *v, const Cell *cl, int k, size_t *off, float *w, float dw[3]) {
    int b[3] = {k & 1, (k >> 1) & 1, (k >> 2) & 1};
    float t[3], s[3];
    for (int a = 0; a < 3; ++a) {
        t[a] = b[a] ? cl->f[a] : 1.0f - cl->f[a];
        s[a] = b[a] ? 1.0f : -1.0f;
    }
    *off = ((size_t)b[2] * v->res + b[1]) * v->res + b[0];
    *w = t[0] * t[1] * t[2];
    dw[0] = s[0] * t[1] * t[2];
    dw[1] = t[0] * s[1] * t[2];
    dw[2] = t[0] * t[1] * s[2];
}

void mf_voltex_forward(const MfVoltex *v, const float *pts, int n, float *out) {
    int c = v->c;
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
        Cell cl = cell_of(v, pts + 3 * (size_t)i);
        float *o = out + (size_t)i * c;
        for (int ch = 0; ch < c; ++ch) o[ch] = 0.0f;
        for (int k = 0; k < 8; ++k) {
            size_t off;
            float w, dw[3];
            corner(v, &cl, k, &off, &w, dw);
            const float *g = v->grid + (cl.base + off) * (size_t)c;
            for (int ch = 0; ch < c; ++ch) o[ch] += w * g[ch];
        }
    }
}

void mf_voltex_backward(const MfVoltex *v, const float *pts, int n, const float *dout, float *dgrid, float *dpts) {
    int c = v->c;
    for (int i = 0; i < n; ++i) {
        Cell cl = cell_of(v, pts + 3 * (size_t)i);
        const float *d = dout + (size_t)i * c;
        float dp[3] = {0, 0, 0};
        for (int k = 0; k < 8; ++k) {
            size_t off;
            float w, dw[3];
            corner(v, &cl, k, &off, &w, dw);
            size_t gi = (cl.base + off) * (size_t)c;
            float dot = 0.0f;
            for (int ch = 0; ch < c; ++ch) {
                if (dgrid) dgrid[gi + ch] += w * d[ch];
                dot += d[ch] * v->grid[gi + ch];
            }
            for (int a = 0; a < 3; ++a) dp[a] += dot * dw[a];
        }
        if (dpts)
            for (int a = 0; a < 3; ++a) dpts[3 * (size_t)i + a] += dp[a] * cl.du[a];
    }
}

double mf_voltex_tv(const MfVoltex *v, float eps, float weight, float *dgrid) {
    int r = v->res, c = v->c;
    double nterms = 3.0 * (r - 1) * (double)r * r * c, scale = weight / nterms, e = eps, sum = 0.0;
    size_t stride[3] = {(size_t)c, (size_t)r * c, (size_t)r * r * c};
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < r; ++k)
            for (int j = 0; j < r; ++j)
                for (int i = 0; i < r; ++i) {
                    int coord[3] = {i, j, k};
                    if (coord[a] == r - 1) continue;
                    size_t ia = (((size_t)k * r + j) * r + i) * c, ib = ia + stride[a];
                    for (int ch = 0; ch < c; ++ch) {
                        double d = (double)v->grid[ib + ch] - v->grid[ia + ch], s = sqrt(d * d + e * e);
                        sum += s - e;
                        if (dgrid) {
                            float gr = (float)(scale * d / s);
                            dgrid[ib + ch] += gr;
                            dgrid[ia + ch] -= gr;
                        }
                    }
                }
    return scale * sum;
}
