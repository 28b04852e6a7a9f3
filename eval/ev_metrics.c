/* ev_metrics: PSNR, SSIM (scikit-image 0.19 settings), L1 and LDR-FLIP. See ev_metrics.h. */
#include "eval/ev_metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

/* ---------------------------------------------------------------- checks and helpers */

int ev_check_finite(const MfImage *img, const char *what) {
    if (!img || !img->data || img->w <= 0 || img->h <= 0 || img->c <= 0)
        return mf_fail(MF_EARG, "%s: empty image", what);
    size_t n = (size_t)img->w * img->h * img->c;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(img->data[i])) {
            size_t p = i / (size_t)img->c;
            return mf_fail(MF_ENAN, "%s: non-finite value %g at pixel (x=%d, y=%d) channel %d", what,
                           (double)img->data[i], (int)(p % (size_t)img->w), (int)(p / (size_t)img->w),
                           (int)(i % (size_t)img->c));
        }
    }
    return MF_OK;
}

float ev_mask_coverage(const MfImage *mask, int x, int y) {
    const float *p = mf_image_px(mask, x, y);
    return (mask->c == 2 || mask->c == 4) ? p[mask->c - 1] : p[0];
}

/* Same size and channels, finite data; mask (optional) of the same w, h and finite. */
static int check_pair(const MfImage *a, const MfImage *b, const MfImage *mask, const char *fn) {
    int rc;
    if ((rc = ev_check_finite(a, "first image")) || (rc = ev_check_finite(b, "second image")))
        return mf_fail_prefix(rc, "%s", fn);
    if (a->w != b->w || a->h != b->h || a->c != b->c)
        return mf_fail(MF_EARG, "%s: image sizes differ (%dx%dx%d vs %dx%dx%d)", fn, a->w, a->h, a->c, b->w,
                       b->h, b->c);
    if (mask) {
        if ((rc = ev_check_finite(mask, "mask"))) return mf_fail_prefix(rc, "%s", fn);
        if (mask->w != a->w || mask->h != a->h)
            return mf_fail(MF_EARG, "%s: mask is %dx%d but the images are %dx%d", fn, mask->w, mask->h, a->w, a->h);
    }
    return MF_OK;
}

static int finite_out(double v, const char *fn, double *out) {
    if (!isfinite(v)) return mf_fail(MF_ENAN, "%s: result is not finite (%g)", fn, v);
    *out = v;
    return MF_OK;
}

/* ---------------------------------------------------------------- PSNR and L1 */

/* Mean over (inside) pixels and all channels of |a-b|^p, p = 1 or 2; with per_ch (a->c,) also
 * each channel's own mean. */
static int mean_err(const MfImage *a, const MfImage *b, const MfImage *mask, int p, const char *fn, double *out,
                    double *per_ch) {
    int rc = check_pair(a, b, mask, fn);
    if (rc) return rc;
    double sum = 0.0;
    size_t n = 0;
    if (per_ch)
        for (int k = 0; k < a->c; k++) per_ch[k] = 0.0;
    for (int y = 0; y < a->h; y++)
        for (int x = 0; x < a->w; x++) {
            if (mask && !ev_mask_inside(mask, x, y)) continue;
            const float *pa = mf_image_px(a, x, y), *pb = mf_image_px(b, x, y);
            for (int k = 0; k < a->c; k++) {
                double d = (double)pa[k] - (double)pb[k], e = p == 1 ? fabs(d) : d * d;
                sum += e;
                if (per_ch) per_ch[k] += e;
            }
            n += (size_t)a->c;
        }
    if (n == 0) return mf_fail(MF_EARG, "%s: the mask is empty (no pixel with coverage > 0.5)", fn);
    *out = sum / (double)n;
    if (per_ch)
        for (int k = 0; k < a->c; k++) per_ch[k] /= (double)(n / (size_t)a->c);
    return MF_OK;
}

int ev_psnr(const MfImage *a, const MfImage *b, const MfImage *mask, double *out) {
    double mse;
    int rc = mean_err(a, b, mask, 2, "psnr", &mse, NULL);
    if (rc) return rc;
    double v = mse > 0.0 ? 10.0 * log10(1.0 / mse) : EV_PSNR_MAX;
    if (v > EV_PSNR_MAX) v = EV_PSNR_MAX;
    return finite_out(v, "psnr", out);
}

int ev_mse_channels(const MfImage *a, const MfImage *b, const MfImage *mask, double *mse) {
    double all;
    return mean_err(a, b, mask, 2, "mse", &all, mse);
}

int ev_l1(const MfImage *a, const MfImage *b, const MfImage *mask, double *out) {
    double v;
    int rc = mean_err(a, b, mask, 1, "l1", &v, NULL);
    if (rc) return rc;
    return finite_out(v, "l1", out);
}

/* ---------------------------------------------------------------- separable filtering */

enum { BORDER_REFLECT = 0, BORDER_REPLICATE = 1 };

/* Source index for position i of a line of n samples. REFLECT is scipy.ndimage's 'reflect'
 * (d c b a | a b c d | d c b a); REPLICATE is OpenCV's BORDER_REPLICATE (a a | a b c d | d d). */
static int border_idx(int i, int n, int mode) {
    if (i >= 0 && i < n) return i;
    if (mode == BORDER_REPLICATE) return i < 0 ? 0 : n - 1;
    int period = 2 * n;
    int j = i % period;
    if (j < 0) j += period;
    return j < n ? j : period - 1 - j;
}

/* Correlates plane in (h, w) with kx along x then ky along y (both of 2r+1 taps):
 * out(y, x) = Σ_j Σ_i ky[j] kx[i] in(y + j − r, x + i − r). tmp: (h, w) scratch, line: w + 2r. */
static void sep_filter(const double *in, double *out, int w, int h, const double *kx, const double *ky, int r,
                       int mode, double *tmp, double *line) {
    int taps = 2 * r + 1;
    for (int y = 0; y < h; y++) {
        const double *row = in + (size_t)y * w;
        for (int i = 0; i < w + 2 * r; i++) line[i] = row[border_idx(i - r, w, mode)];
        double *t = tmp + (size_t)y * w;
        for (int x = 0; x < w; x++) {
            double s = 0.0;
            for (int i = 0; i < taps; i++) s += kx[i] * line[x + i];
            t[x] = s;
        }
    }
    for (int y = 0; y < h; y++) {
        double *o = out + (size_t)y * w;
        for (int x = 0; x < w; x++) o[x] = 0.0;
        for (int j = 0; j < taps; j++) {
            const double *t = tmp + (size_t)border_idx(y + j - r, h, mode) * w;
            double kj = ky[j];
            for (int x = 0; x < w; x++) o[x] += kj * t[x];
        }
    }
}

/* ---------------------------------------------------------------- SSIM */

#define SSIM_SIGMA 1.5
#define SSIM_R 5 /* int(3.5 * 1.5 + 0.5) */
#define SSIM_K1 0.01
#define SSIM_K2 0.03

/* Channel-averaged SSIM map (h, w) in double. Inputs already checked. */
static int ssim_map_d(const MfImage *a, const MfImage *b, double *map) {
    int w = a->w, h = a->h;
    if (w < EV_SSIM_WIN || h < EV_SSIM_WIN)
        return mf_fail(MF_EARG, "ssim: image %dx%d is smaller than the %dx%d window", w, h, EV_SSIM_WIN, EV_SSIM_WIN);
    size_t n = (size_t)w * h;
    double k[2 * SSIM_R + 1], ksum = 0.0;
    for (int i = -SSIM_R; i <= SSIM_R; i++) ksum += (k[i + SSIM_R] = exp(-0.5 / (SSIM_SIGMA * SSIM_SIGMA) * i * i));
    for (int i = 0; i < 2 * SSIM_R + 1; i++) k[i] /= ksum;

    double *buf = malloc(sizeof(double) * (n * 12 + (size_t)w + 2 * SSIM_R));
    if (!buf) return mf_fail(MF_ENOMEM, "ssim: out of memory for %dx%d", w, h);
    double *x = buf, *yv = x + n, *prod = yv + n, *ux = prod + n, *uy = ux + n, *uxx = uy + n, *uyy = uxx + n,
           *uxy = uyy + n, *tmp = uxy + n, *line = tmp + n;
    const double C1 = (SSIM_K1 * 1.0) * (SSIM_K1 * 1.0), C2 = (SSIM_K2 * 1.0) * (SSIM_K2 * 1.0);
    for (size_t i = 0; i < n; i++) map[i] = 0.0;
    for (int c = 0; c < a->c; c++) {
        for (size_t i = 0; i < n; i++) {
            x[i] = a->data[i * a->c + c];
            yv[i] = b->data[i * b->c + c];
        }
        sep_filter(x, ux, w, h, k, k, SSIM_R, BORDER_REFLECT, tmp, line);
        sep_filter(yv, uy, w, h, k, k, SSIM_R, BORDER_REFLECT, tmp, line);
        for (size_t i = 0; i < n; i++) prod[i] = x[i] * x[i];
        sep_filter(prod, uxx, w, h, k, k, SSIM_R, BORDER_REFLECT, tmp, line);
        for (size_t i = 0; i < n; i++) prod[i] = yv[i] * yv[i];
        sep_filter(prod, uyy, w, h, k, k, SSIM_R, BORDER_REFLECT, tmp, line);
        for (size_t i = 0; i < n; i++) prod[i] = x[i] * yv[i];
        sep_filter(prod, uxy, w, h, k, k, SSIM_R, BORDER_REFLECT, tmp, line);
        for (size_t i = 0; i < n; i++) {
            double vx = uxx[i] - ux[i] * ux[i], vy = uyy[i] - uy[i] * uy[i], vxy = uxy[i] - ux[i] * uy[i];
            double A1 = 2.0 * ux[i] * uy[i] + C1, A2 = 2.0 * vxy + C2;
            double B1 = ux[i] * ux[i] + uy[i] * uy[i] + C1, B2 = vx + vy + C2;
            map[i] += (A1 * A2) / (B1 * B2);
        }
    }
    for (size_t i = 0; i < n; i++) map[i] /= a->c;
    free(buf);
    return MF_OK;
}

int ev_ssim_map(const MfImage *a, const MfImage *b, float *map) {
    int rc = check_pair(a, b, NULL, "ssim");
    if (rc) return rc;
    size_t n = (size_t)a->w * a->h;
    double *m = malloc(sizeof(double) * n);
    if (!m) return mf_fail(MF_ENOMEM, "ssim: out of memory");
    if ((rc = ssim_map_d(a, b, m))) {
        free(m);
        return rc;
    }
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(m[i])) {
            free(m);
            return mf_fail(MF_ENAN, "ssim: map is not finite at pixel %zu", i);
        }
    }
    for (size_t i = 0; i < n; i++) map[i] = (float)m[i];
    free(m);
    return MF_OK;
}

/* Mean of the SSIM map over the cropped interior (inside the mask when given). */
static int ssim_mean(const double *m, int w, int h, const MfImage *mask, double *out) {
    int pad = (EV_SSIM_WIN - 1) / 2;
    double sum = 0.0;
    size_t cnt = 0;
    for (int y = pad; y < h - pad; y++)
        for (int x = pad; x < w - pad; x++) {
            if (mask && !ev_mask_inside(mask, x, y)) continue;
            sum += m[(size_t)y * w + x];
            cnt++;
        }
    if (cnt == 0)
        return mf_fail(MF_EARG, "ssim: the mask has no pixel with coverage > 0.5 inside the %d-pixel border crop", pad);
    return finite_out(sum / (double)cnt, "ssim", out);
}

int ev_ssim(const MfImage *a, const MfImage *b, const MfImage *mask, double *out) {
    int rc = check_pair(a, b, mask, "ssim");
    if (rc) return rc;
    double *m = malloc(sizeof(double) * (size_t)a->w * a->h);
    if (!m) return mf_fail(MF_ENOMEM, "ssim: out of memory");
    if (!(rc = ssim_map_d(a, b, m))) rc = ssim_mean(m, a->w, a->h, mask, out);
    free(m);
    return rc;
}

/* ---------------------------------------------------------------- LDR-FLIP */

/* D65 reference white and its inverse, as in the FLIP reference code. */
static const double FLIP_WHITE[3] = {0.950428545, 1.000000000, 1.088900371};
static const double FLIP_INV_WHITE[3] = {1.052156925, 1.000000000, 0.918357670};
/* linear sRGB -> XYZ (D65) and back. */
static const double FLIP_RGB2XYZ[3][3] = {{10135552.0 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0},
                                          {2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0},
                                          {1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0}};
static const double FLIP_XYZ2RGB[3][3] = {{3.241003275, -1.537398934, -0.498615861},
                                          {-0.969224334, 1.875930071, 0.041554224},
                                          {0.055639423, -0.204011202, 1.057148933}};

static double flip_srgb2lin(double v) { return v > 0.04045 ? pow((v + 0.055) / 1.055, 2.4) : v / 12.92; }

static void mat3(const double M[3][3], const double in[3], double out[3]) {
    for (int i = 0; i < 3; i++) out[i] = M[i][0] * in[0] + M[i][1] * in[1] + M[i][2] * in[2];
}

/* Linear RGB -> Hunt-adjusted CIELAB (L, 0.01·L·a, 0.01·L·b). */
static void flip_lin2hunt_lab(const double rgb[3], double out[3]) {
    double xyz[3], f[3];
    mat3(FLIP_RGB2XYZ, rgb, xyz);
    const double d = 6.0 / 29.0, d3 = d * d * d, fac = 1.0 / (3.0 * d * d);
    for (int i = 0; i < 3; i++) {
        double t = xyz[i] * FLIP_INV_WHITE[i];
        f[i] = t > d3 ? cbrt(t) : fac * t + 4.0 / 29.0;
    }
    double L = 116.0 * f[1] - 16.0, A = 500.0 * (f[0] - f[1]), B = 200.0 * (f[1] - f[2]);
    out[0] = L;
    out[1] = 0.01 * L * A;
    out[2] = 0.01 * L * B;
}

static double flip_hyab(const double p[3], const double q[3]) {
    double dl = p[0] - q[0], da = p[1] - q[1], db = p[2] - q[2];
    return fabs(dl) + sqrt(da * da + db * db);
}

/* CSF of one opponent channel: Σ_k c_k·exp(−π²·|x|²·Δ²/b_k), a1, b1, a2, b2 per channel. */
static const double FLIP_CSF[3][4] = {
    {1.0, 0.0047, 0.0, 1e-5},  /* achromatic */
    {1.0, 0.0053, 0.0, 1e-5},  /* red-green */
    {34.1, 0.04, 13.5, 0.025}, /* blue-yellow */
};

typedef struct {
    int r;
    int nterms;
    double weight[2];  /* c_k / Σ(2-D kernel) */
    double *g[2];      /* (2r+1) 1-D factors */
} FlipCsf;

static int flip_csf_radius(double ppd) {
    return (int)ceil(3.0 * sqrt(0.04 / (2.0 * M_PI * M_PI)) * ppd);
}

/* g must hold 2·(2r+1) doubles. */
static void flip_csf_init(FlipCsf *f, int ch, double ppd, int r, double *g) {
    double dx = 1.0 / ppd;
    f->r = r;
    f->nterms = 0;
    double c[2], total = 0.0;
    for (int k = 0; k < 2; k++) {
        double a = FLIP_CSF[ch][2 * k], b = FLIP_CSF[ch][2 * k + 1];
        if (a == 0.0) continue;
        double *gk = g + (size_t)f->nterms * (2 * r + 1), s = 0.0;
        for (int i = -r; i <= r; i++) s += (gk[i + r] = exp(-M_PI * M_PI * (i * dx) * (i * dx) / b));
        c[f->nterms] = a * sqrt(M_PI / b);
        f->g[f->nterms] = gk;
        total += c[f->nterms] * s * s;
        f->nterms++;
    }
    for (int k = 0; k < f->nterms; k++) f->weight[k] = c[k] / total;
}

/* Feature kernels: 1-D factor f (derivative direction) and g (smoothing), both (2r+1). */
static int flip_feature_radius(double ppd) { return (int)ceil(3.0 * 0.5 * 0.082 * ppd); }

static void flip_feature_init(double ppd, int r, int point, double *fd, double *gs) {
    double sd = 0.5 * 0.082 * ppd, pos = 0.0, neg = 0.0, gsum = 0.0;
    for (int i = -r; i <= r; i++) {
        double g = exp(-(double)(i * i) / (2.0 * sd * sd));
        double v = point ? ((double)(i * i) / (sd * sd) - 1.0) * g : -(double)i * g;
        fd[i + r] = v;
        gs[i + r] = g;
        gsum += g;
        if (v > 0) pos += v;
        if (v < 0) neg -= v;
    }
    /* The 2-D kernel is fd(x)·gs(y); its positive part sums to pos·gsum, its negative part to
     * −neg·gsum. Normalising those to ±1 is the same as fd/pos (or fd/neg) times gs/gsum. */
    for (int i = 0; i < 2 * r + 1; i++) {
        fd[i] = fd[i] > 0 ? fd[i] / pos : (fd[i] < 0 ? fd[i] / neg : 0.0);
        gs[i] /= gsum;
    }
}

int ev_flip_map(const MfImage *ref, const MfImage *test, double ppd, float *map) {
    int rc = check_pair(ref, test, NULL, "flip");
    if (rc) return rc;
    if (ref->c != 1 && ref->c != 3)
        return mf_fail(MF_EARG, "flip: needs 1 or 3 channels (sRGB), got %d", ref->c);
    if (!(ppd > 0.0)) ppd = EV_FLIP_PPD;
    int w = ref->w, h = ref->h;
    size_t n = (size_t)w * h;
    int rc_csf = flip_csf_radius(ppd), rf = flip_feature_radius(ppd);
    int rmax = rc_csf > rf ? rc_csf : rf;

    /* planes: opponent (3), filtered (3), hunt lab ref (3), Y ref/test (2), 4 feature
     * responses, scratch (2), line. */
    size_t nplanes = 18;
    double *buf = malloc(sizeof(double) * (n * nplanes + (size_t)w + 2 * rmax + 4 * (2 * rmax + 1) + 4 * (2 * rmax + 1)));
    if (!buf) return mf_fail(MF_ENOMEM, "flip: out of memory for %dx%d", w, h);
    double *opp = buf;                /* (3, h, w) YCxCz of the current image */
    double *flt = opp + 3 * n;        /* (3, h, w) CSF-filtered */
    double *lab_ref = flt + 3 * n;    /* (3, h, w) Hunt-adjusted Lab of the reference */
    double *yimg[2] = {lab_ref + 3 * n, lab_ref + 4 * n}; /* (h, w) normalised Y, ref/test */
    double *edge[2] = {lab_ref + 5 * n, lab_ref + 6 * n}; /* (h, w) |edge gradient| */
    double *pnt[2] = {lab_ref + 7 * n, lab_ref + 8 * n};  /* (h, w) |point response| */
    double *t1 = lab_ref + 9 * n, *t2 = t1 + n, *tmp = t2 + n; /* scratch (h, w) each */
    double *line = tmp + n;                                  /* w + 2 rmax */
    double *kbuf = line + w + 2 * rmax;                      /* kernels */
    double *csf_g = kbuf;                                    /* 2 (2r+1) */
    double *fe = csf_g + 2 * (2 * rmax + 1), *ge = fe + (2 * rmax + 1);
    double *fp = ge + (2 * rmax + 1), *gp = fp + (2 * rmax + 1);

    flip_feature_init(ppd, rf, 0, fe, ge);
    flip_feature_init(ppd, rf, 1, fp, gp);

    for (int img = 0; img < 2; img++) {
        const MfImage *im = img == 0 ? ref : test;
        /* sRGB -> linear -> XYZ -> YCxCz */
        for (size_t i = 0; i < n; i++) {
            double rgb[3], xyz[3];
            for (int k = 0; k < 3; k++) rgb[k] = flip_srgb2lin(im->data[i * im->c + (im->c == 1 ? 0 : k)]);
            mat3(FLIP_RGB2XYZ, rgb, xyz);
            for (int k = 0; k < 3; k++) xyz[k] *= FLIP_INV_WHITE[k];
            opp[i] = 116.0 * xyz[1] - 16.0;
            opp[n + i] = 500.0 * (xyz[0] - xyz[1]);
            opp[2 * n + i] = 200.0 * (xyz[1] - xyz[2]);
            yimg[img][i] = (opp[i] + 16.0) / 116.0;
        }
        /* colour pipeline: CSF filter each opponent channel */
        for (int ch = 0; ch < 3; ch++) {
            FlipCsf f;
            flip_csf_init(&f, ch, ppd, rc_csf, csf_g);
            double *o = flt + (size_t)ch * n;
            for (size_t i = 0; i < n; i++) o[i] = 0.0;
            for (int k = 0; k < f.nterms; k++) {
                sep_filter(opp + (size_t)ch * n, t1, w, h, f.g[k], f.g[k], f.r, BORDER_REPLICATE, tmp, line);
                for (size_t i = 0; i < n; i++) o[i] += f.weight[k] * t1[i];
            }
        }
        /* YCxCz -> XYZ -> linear RGB, clip, -> Hunt-adjusted Lab; HyAB against the reference */
        for (size_t i = 0; i < n; i++) {
            double xyz[3], rgb[3], lab[3];
            double yy = (flt[i] + 16.0) / 116.0;
            xyz[0] = (yy + flt[n + i] / 500.0) * FLIP_WHITE[0];
            xyz[1] = yy * FLIP_WHITE[1];
            xyz[2] = (yy - flt[2 * n + i] / 200.0) * FLIP_WHITE[2];
            mat3(FLIP_XYZ2RGB, xyz, rgb);
            for (int k = 0; k < 3; k++) rgb[k] = rgb[k] < 0.0 ? 0.0 : (rgb[k] > 1.0 ? 1.0 : rgb[k]);
            flip_lin2hunt_lab(rgb, lab);
            if (img == 0) {
                for (int k = 0; k < 3; k++) lab_ref[(size_t)k * n + i] = lab[k];
            } else {
                double lr[3] = {lab_ref[i], lab_ref[n + i], lab_ref[2 * n + i]};
                lab_ref[i] = flip_hyab(lr, lab); /* reuse plane 0 for ΔE_hyab */
            }
        }
        /* feature pipeline on normalised Y */
        sep_filter(yimg[img], t1, w, h, fe, ge, rf, BORDER_REPLICATE, tmp, line); /* d/dx */
        sep_filter(yimg[img], t2, w, h, ge, fe, rf, BORDER_REPLICATE, tmp, line); /* d/dy */
        for (size_t i = 0; i < n; i++) edge[img][i] = sqrt(t1[i] * t1[i] + t2[i] * t2[i]);
        sep_filter(yimg[img], t1, w, h, fp, gp, rf, BORDER_REPLICATE, tmp, line);
        sep_filter(yimg[img], t2, w, h, gp, fp, rf, BORDER_REPLICATE, tmp, line);
        for (size_t i = 0; i < n; i++) pnt[img][i] = sqrt(t1[i] * t1[i] + t2[i] * t2[i]);
    }

    /* cmax: HyAB between Hunt-adjusted green and blue, ^qc */
    const double qc = 0.7, qf = 0.5, pc = 0.4, pt = 0.95;
    double green[3] = {0, 1, 0}, blue[3] = {0, 0, 1}, lg[3], lb[3];
    flip_lin2hunt_lab(green, lg);
    flip_lin2hunt_lab(blue, lb);
    double cmax = pow(flip_hyab(lg, lb), qc), pccmax = pc * cmax;

    for (size_t i = 0; i < n; i++) {
        double p = pow(lab_ref[i], qc);
        double dec = p < pccmax ? (pt / pccmax) * p : pt + ((p - pccmax) / (cmax - pccmax)) * (1.0 - pt);
        double df = fmax(fabs(edge[0][i] - edge[1][i]), fabs(pnt[1][i] - pnt[0][i]));
        df = pow(df / sqrt(2.0), qf);
        double v = pow(dec, 1.0 - df);
        if (!isfinite(v)) {
            free(buf);
            return mf_fail(MF_ENAN, "flip: error map is not finite at pixel (x=%d, y=%d)", (int)(i % (size_t)w),
                           (int)(i / (size_t)w));
        }
        map[i] = (float)v;
    }
    free(buf);
    return MF_OK;
}

/* Mean of the FLIP map (inside the mask when given). */
static int flip_mean(const float *map, int w, int h, const MfImage *mask, double *out) {
    double sum = 0.0;
    size_t cnt = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (mask && !ev_mask_inside(mask, x, y)) continue;
            sum += map[(size_t)y * w + x];
            cnt++;
        }
    if (cnt == 0) return mf_fail(MF_EARG, "flip: the mask is empty (no pixel with coverage > 0.5)");
    return finite_out(sum / (double)cnt, "flip", out);
}

int ev_flip(const MfImage *ref, const MfImage *test, const MfImage *mask, double ppd, double *out) {
    int rc = check_pair(ref, test, mask, "flip");
    if (rc) return rc;
    float *map = malloc(sizeof(float) * (size_t)ref->w * ref->h);
    if (!map) return mf_fail(MF_ENOMEM, "flip: out of memory");
    if (!(rc = ev_flip_map(ref, test, ppd, map))) rc = flip_mean(map, ref->w, ref->h, mask, out);
    free(map);
    return rc;
}

/* ---------------------------------------------------------------- all at once */

int ev_metrics_compute(const MfImage *pred, const MfImage *gt, const MfImage *mask, EvMetrics *out) {
    EvMetrics m;
    memset(&m, 0, sizeof m);
    int rc = check_pair(pred, gt, mask, "metrics");
    if (rc) return rc;
    if ((rc = ev_psnr(pred, gt, NULL, &m.psnr)) || (rc = ev_l1(pred, gt, NULL, &m.l1))) return rc;
    if (mask && ((rc = ev_psnr(pred, gt, mask, &m.psnr_masked)) || (rc = ev_l1(pred, gt, mask, &m.l1_masked))))
        return rc;
    /* SSIM and FLIP maps once each, averaged with and without the mask */
    size_t n = (size_t)gt->w * gt->h;
    double *smap = malloc(sizeof(double) * n);
    float *fmap = malloc(sizeof(float) * n);
    if (!smap || !fmap) {
        free(smap), free(fmap);
        return mf_fail(MF_ENOMEM, "metrics: out of memory");
    }
    m.has_flip = gt->c == 1 || gt->c == 3;
    if (!(rc = ssim_map_d(pred, gt, smap)) && !(rc = ssim_mean(smap, gt->w, gt->h, NULL, &m.ssim)) && mask)
        rc = ssim_mean(smap, gt->w, gt->h, mask, &m.ssim_masked);
    if (!rc && m.has_flip && !(rc = ev_flip_map(gt, pred, 0.0, fmap)) &&
        !(rc = flip_mean(fmap, gt->w, gt->h, NULL, &m.flip)) && mask)
        rc = flip_mean(fmap, gt->w, gt->h, mask, &m.flip_masked);
    free(smap), free(fmap);
    if (rc) return rc;
    m.has_mask = mask != NULL;
    *out = m;
    return MF_OK;
}
