/* ev_orb: Stanford-ORB's own image metrics (Kuang et al. 2023, the benchmark's evaluation code),
 * re-implemented from its published definition:
 *   1. the GT mask (coverage, scaled to 8 bits) is eroded with a 5x5 box (borders do not erode)
 *      and thresholded at 127; both images are multiplied by it; negative GT values become 0;
 *   2. PSNR-H only: both images are multiplied by mean(sRGB(clip(gt,0,1))) / mean(clip(gt,0,1))
 *      (means over all elements), re-normalising dark linear images;
 *   3. per-channel least-squares scale of the prediction over the mask pixels,
 *      s_c = sum(gt_c pred_c) / sum(pred_c^2) (a channel with sum(pred_c^2) <= 1e-6 is fitted as
 *      if the prediction were 1 there);
 *   4. both clipped to [0, max]; PSNR-L also applies the sRGB curve;
 *   5. MSE over all pixels and channels (not divided by the mask area), PSNR = -10 log10(MSE),
 *      bounded below by the PSNR of a constant 0.5 x mask prediction.
 * PSNR-H: max 4, re-normalised, linear. PSNR-L: max 1, sRGB. (Stanford-ORB's SSIM uses a 3x3
 * window through kornia and LPIPS needs learned weights: neither is reproduced here.) */
#ifndef EV_ORB_H
#define EV_ORB_H

#include "io/mf_image.h"

/* pred, gt: linear (h, w, >= 3), colour straight (not premultiplied); mask: coverage image as in
 * ev_metrics.h (alpha for c = 2 or 4, channel 0 otherwise). */
int ev_orb_psnr_h(const MfImage *pred, const MfImage *gt, const MfImage *mask, double *out);
int ev_orb_psnr_l(const MfImage *pred, const MfImage *gt, const MfImage *mask, double *out);

#endif
