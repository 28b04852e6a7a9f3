#include "eval/ev_orb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "eval/ev_metrics.h"

static double srgb(double x) { return x > 0.0031308 ? 1.055 * pow(x, 1.0 / 2.4) - 0.055 : 12.92 * x; }

static int orb_psnr(const MfImage *pred, const MfImage *gt, const MfImage *mask, double maxv, int gt_median, int tonemap,
                    double *out) {
    int w = gt->w, h = gt->h;
    if (pred->w != w || pred->h != h || mask->w != w || mask->h != h || pred->c < 3 || gt->c < 3)
        return mf_fail(MF_EARG, "ORB PSNR: prediction %dx%dx%d, ground truth %dx%dx%d and mask %dx%d differ", pred->w,
                       pred->h, pred->c, w, h, gt->c, mask->w, mask->h);
    int rc = ev_check_finite(pred, "prediction");
    if (!rc) rc = ev_check_finite(gt, "ground truth");
    if (rc) return rc;
    size_t n = (size_t)w * h;
    unsigned char *m8 = malloc(n), *er = malloc(n);
    double *p = malloc(n * 3 * sizeof(double)), *g = malloc(n * 3 * sizeof(double));
    if (!m8 || !er || !p || !g) {
        free(m8), free(er), free(p), free(g);
        return mf_fail(MF_ENOMEM, "ORB PSNR: out of memory");
    }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double v = ev_mask_coverage(mask, x, y) * 255.0;
            m8[(size_t)y * w + x] = (unsigned char)(v < 0 ? 0 : v > 255 ? 255 : v); /* truncation, as astype(uint8) */
        }
    /* 5x5 erosion; pixels outside the image do not erode */
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            unsigned char lo = 255;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    int yy = y + dy, xx = x + dx;
                    if (yy < 0 || yy >= h || xx < 0 || xx >= w) continue;
                    if (m8[(size_t)yy * w + xx] < lo) lo = m8[(size_t)yy * w + xx];
                }
            er[(size_t)y * w + x] = lo > 127;
        }
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            p[3 * i + c] = er[i] ? pred->data[i * pred->c + c] : 0.0;
            double gv = er[i] ? gt->data[i * gt->c + c] : 0.0;
            g[3 * i + c] = gv < 0.0 ? 0.0 : gv;
        }
    if (gt_median) {
        double sl = 0.0, ss = 0.0;
        for (size_t i = 0; i < 3 * n; ++i) {
            double v = fmin(fmax(g[i], 0.0), 1.0);
            sl += v;
            ss += srgb(v);
        }
        if (sl / (3.0 * n) > 1e-8) {
            double f = ss / sl;
            for (size_t i = 0; i < 3 * n; ++i) p[i] *= f, g[i] *= f;
        }
    }
    for (int c = 0; c < 3; ++c) {
        double pp = 0.0, gp = 0.0, gs = 0.0;
        for (size_t i = 0; i < n; ++i)
            if (er[i]) pp += p[3 * i + c] * p[3 * i + c], gp += g[3 * i + c] * p[3 * i + c], gs += g[3 * i + c];
        double s = 1.0;
        if (pp > 1e-6) {
            s = gp / pp;
        } else { /* fitted as if the prediction were 1 on the mask: sum(gt) / count */
            size_t cnt = 0;
            for (size_t i = 0; i < n; ++i) cnt += er[i];
            if (cnt) s = gs / (double)cnt;
        }
        for (size_t i = 0; i < n; ++i) p[3 * i + c] *= s;
    }
    double mse = 0.0, lb = 0.0;
    for (size_t i = 0; i < 3 * n; ++i) {
        double a = fmin(fmax(p[i], 0.0), maxv), b = fmin(fmax(g[i], 0.0), maxv), half = er[i / 3] ? 0.5 : 0.0;
        if (tonemap) a = srgb(a), b = srgb(b);
        mse += (a - b) * (a - b);
        /* the lower bound uses the clipped (and tone-mapped) GT, as the reference code */
        lb += (half - b) * (half - b);
    }
    mse /= 3.0 * n;
    lb /= 3.0 * n;
    free(m8), free(er), free(p), free(g);
    double v = fmax(-10.0 * log10(mse), -10.0 * log10(lb));
    if (!isfinite(v)) v = EV_PSNR_MAX; /* identical images: capped as ev_psnr */
    *out = fmin(v, EV_PSNR_MAX);
    return MF_OK;
}

int ev_orb_psnr_h(const MfImage *pred, const MfImage *gt, const MfImage *mask, double *out) {
    return orb_psnr(pred, gt, mask, 4.0, 1, 0, out);
}

int ev_orb_psnr_l(const MfImage *pred, const MfImage *gt, const MfImage *mask, double *out) {
    return orb_psnr(pred, gt, mask, 1.0, 0, 1, out);
}
