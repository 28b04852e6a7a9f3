/* ev_align: the evaluation protocol's scale alignment and conversion to display values.
 *
 * Protocol (one fixed order, used for every method):
 *   1. Alignment, in linear space, per colour channel k, over the GT mask's inside pixels
 *      (coverage > 0.5; all pixels when there is no mask):
 *        EV_ALIGN_MEAN (default)  s_k = Σ gt_k / Σ pred_k          (ratio of means)
 *        EV_ALIGN_LSQ             s_k = Σ gt_k·pred_k / Σ pred_k²   (least squares)
 *        EV_ALIGN_NONE            s_k = 1
 *      pred_k ← s_k · pred_k. A channel whose denominator is 0 (all-zero prediction inside the
 *      mask) or whose scale would not be finite or would be negative keeps s_k = 1 and sets bit k
 *      of the `degenerate` flags; an empty mask is an error (MF_EARG). Never a NaN.
 *   2. Linear → sRGB with the exact piecewise curve (IEC 61966-2-1), then clip to [0, 1].
 *   3. Composite on black: value · m, m = mask coverage clamped to [0, 1] (no mask: m = 1).
 * Colour channels are the first 3 of an RGBA image (c = 4), the first of a grey+alpha image
 * (c = 2), all of them otherwise (c = 1 or 3); alpha is dropped from the outputs. Images with more
 * than 4 channels (a whole multi-layer EXR) are refused with MF_EARG: read one layer first
 * (eval/ev_image.h). Scores are then computed
 * by ev_metrics.h on the outputs (values in [0, 1], sRGB).
 *
 * Mask images follow ev_metrics.h: coverage is the alpha channel for c = 2 or 4, else channel 0. */
#ifndef EV_ALIGN_H
#define EV_ALIGN_H

#include "io/mf_image.h"

typedef enum { EV_ALIGN_NONE = 0, EV_ALIGN_MEAN = 1, EV_ALIGN_LSQ = 2 } EvAlign;

/* "none" | "mean" | "lsq" -> mode; MF_EARG naming the word otherwise. */
int ev_align_parse(const char *s, EvAlign *out);
const char *ev_align_name(EvAlign mode);

/* Number of colour channels of an image with c channels (alpha excluded). */
int ev_color_channels(int c);

/* Per-channel scales (scale has ev_color_channels(pred->c) entries) for pred against gt inside
 * mask (NULL: all pixels). pred and gt: same w, h, c; linear; finite. degenerate (may be NULL):
 * bit k set when channel k fell back to scale 1. */
int ev_align_scales(const MfImage *pred, const MfImage *gt, const MfImage *mask, EvAlign mode, float *scale,
                    unsigned *degenerate);

/* The whole protocol: aligns pred_lin to gt_lin, converts both to sRGB, clips, composites on
 * black. pred_out and gt_out are allocated here (w, h, colour channels); free with
 * mf_image_free. scale (may be NULL): at least 3 floats, receives the scales used.
 * Errors name "prediction", "ground truth" or "mask". */
int ev_protocol_prepare(const MfImage *pred_lin, const MfImage *gt_lin, const MfImage *mask, EvAlign mode,
                        MfImage *pred_out, MfImage *gt_out, float *scale, unsigned *degenerate);

/* ORM protocol (DESIGN.md: ORM is linear, metrics use G roughness and B metallic only): takes
 * channels 1 and 2 of linear ORM images (c >= 3), no alignment and no sRGB curve, clips to
 * [0, 1] and composites on black with the mask. Outputs (w, h, 2). */
int ev_protocol_prepare_orm(const MfImage *pred_orm, const MfImage *gt_orm, const MfImage *mask, MfImage *pred_out,
                            MfImage *gt_out);

#endif
