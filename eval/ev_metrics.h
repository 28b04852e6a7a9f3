/* ev_metrics: full-reference image metrics on float images in memory.
 *
 * Images are MfImage (io/mf_image.h): float32, interleaved (h, w, c), row 0 at the top. The
 * metrics compare two images of the same size and channel count and treat every channel alike
 * (callers drop alpha first; ev_align.h's protocol does). Values are expected in [0, 1] (the
 * protocol gives sRGB values clipped to [0, 1]); data range is 1 everywhere.
 *
 *   PSNR  10·log10(1 / MSE), MSE over all pixels and channels. Identical images (MSE = 0) and
 *         anything above EV_PSNR_MAX report EV_PSNR_MAX (100 dB), so a PSNR is always finite.
 *   SSIM  exactly scikit-image 0.19's structural_similarity(gaussian_weights=True, sigma=1.5,
 *         use_sample_covariance=False, data_range=1, channel_axis=-1): per channel, local
 *         means/variances/covariance by scipy.ndimage.gaussian_filter (σ = 1.5, truncate 3.5 →
 *         11 taps, mode 'reflect' = half-sample symmetric), K1 = 0.01, K2 = 0.03, the SSIM map
 *         cropped by 5 pixels on every side and averaged; channels averaged. Needs h, w >= 11.
 *   L1    mean |a − b| over all pixels and channels.
 *   FLIP  LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating
 *         Images"), mean of the per-pixel error map in [0, 1]. Inputs are sRGB-encoded values in
 *         [0, 1]; c = 3, or c = 1 (grey, replicated to RGB). No learned weights. Pipeline: sRGB →
 *         linear → XYZ (D65) → YCxCz; CSF filters (achromatic/red-green single Gaussians,
 *         blue-yellow two Gaussians; radius ceil(3·sqrt(0.04/(2π²))·ppd), border replicate) →
 *         linear RGB clipped to [0, 1] → CIELAB → Hunt adjustment (a, b scaled by 0.01·L) →
 *         HyAB distance ^0.7, mapped with pc = 0.4, pt = 0.95 against cmax = HyAB(green, blue)^0.7;
 *         features on the achromatic Y (= (Y* + 16)/116): first (edge) and second (point)
 *         derivative-of-Gaussian filters, σ = 0.5·0.082·ppd, positive/negative weights normalised
 *         to ±1, ΔEf = (max(|‖e_ref‖ − ‖e_test‖|, |‖p_ref‖ − ‖p_test‖|)/√2)^0.5; final
 *         ΔE = ΔEc^(1 − ΔEf). Filters are applied separably (mathematically identical to the 2-D
 *         kernels of the reference code) in double precision. Both terms are symmetric, so
 *         FLIP(a, b) = FLIP(b, a); by convention the first argument is the reference.
 *
 * Masked variants (mask != NULL): the mask is an MfImage of the same w, h; its coverage is the
 * last channel when c is 2 or 4 (alpha), channel 0 otherwise; a pixel is inside when coverage
 * > 0.5. PSNR/L1/FLIP average over inside pixels; SSIM averages the SSIM map over inside pixels
 * within the 5-pixel crop. An empty mask is an error (MF_EARG), never a NaN.
 *
 * Every function checks that its inputs and its result are finite: a NaN/Inf pixel gives
 * MF_ENAN with the pixel's position; outputs are untouched on failure. */
#ifndef EV_METRICS_H
#define EV_METRICS_H

#include "io/mf_image.h"

#define EV_PSNR_MAX 100.0
#define EV_FLIP_PPD 67.02 /* pixels per degree: 0.7 m wide 4K screen seen from 0.7 m */
#define EV_SSIM_WIN 11    /* Gaussian window side (σ = 1.5, truncate 3.5) */

/* mask may be NULL (all pixels). */
int ev_psnr(const MfImage *a, const MfImage *b, const MfImage *mask, double *out);
int ev_l1(const MfImage *a, const MfImage *b, const MfImage *mask, double *out);
/* Mean squared error of each channel, mse (a->c,), over the same pixels as ev_psnr. */
int ev_mse_channels(const MfImage *a, const MfImage *b, const MfImage *mask, double *mse);
int ev_ssim(const MfImage *a, const MfImage *b, const MfImage *mask, double *out);
/* Per-pixel SSIM map averaged over channels, (h, w), uncropped (the border strip is valid data
 * but excluded from ev_ssim's mean). */
int ev_ssim_map(const MfImage *a, const MfImage *b, float *map);

/* ppd <= 0 means EV_FLIP_PPD. ref is the reference, test the image under test. */
int ev_flip(const MfImage *ref, const MfImage *test, const MfImage *mask, double ppd, double *out);
/* Per-pixel LDR-FLIP error, map (h, w), values in [0, 1]. */
int ev_flip_map(const MfImage *ref, const MfImage *test, double ppd, float *map);

/* All metrics at once; the *_masked fields are computed only when mask != NULL (else 0); FLIP
 * only for 1 or 3 channels (has_flip; e.g. not for ORM's G, B pair). */
typedef struct {
    double psnr, ssim, l1, flip;
    double psnr_masked, ssim_masked, l1_masked, flip_masked;
    int has_mask;
    int has_flip;
} EvMetrics;

/* pred is the image under test, gt the reference (FLIP's reference). */
int ev_metrics_compute(const MfImage *pred, const MfImage *gt, const MfImage *mask, EvMetrics *out);

/* Coverage of a mask pixel (see above) and the inside test. */
float ev_mask_coverage(const MfImage *mask, int x, int y);
static inline int ev_mask_inside(const MfImage *mask, int x, int y) { return ev_mask_coverage(mask, x, y) > 0.5f; }

/* MF_OK when all values of img are finite, else MF_ENAN naming `what` and the pixel. */
int ev_check_finite(const MfImage *img, const char *what);

#endif
