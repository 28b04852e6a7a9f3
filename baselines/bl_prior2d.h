/* bl_prior2d: simple material predictors from one image that need no training, the baselines of
 * the prior's 2D table (paper Table 3, reports/prior/table2d.md).
 *
 * Images are MfImage, linear float RGBA (h, w, 4) as mf_image_read(MF_ENC_SRGB) gives for the
 * sRGB PNGs of the prior-train layout; alpha = coverage. Outputs are allocated here (w, h, 4),
 * alpha copied from the input; free with mf_image_free. The evaluation aligns albedo per channel
 * (ratio of means inside the mask), so a global scale of a baseline's albedo does not matter.
 *   bl_albedo_input    albedo = the lit image itself.
 *   bl_albedo_retinex  Retinex-style shading removal: albedo = rgb / S, S = the luminance
 *                      (Rec. 709 weights) blurred with a Gaussian of std sigma pixels as a
 *                      normalised convolution inside the mask (blur(L m) / blur(m)), floored at
 *                      1e-4; outside the mask the output is 0.
 *   bl_orm_constant    ORM = (1, roughness, metallic) everywhere (e.g. the training-set means of
 *                      bl_orm_mean). */
#ifndef BL_PRIOR2D_H
#define BL_PRIOR2D_H

#include "io/mf_image.h"

int bl_albedo_input(const MfImage *rgb, MfImage *out);
int bl_albedo_retinex(const MfImage *rgb, float sigma, MfImage *out);
int bl_orm_constant(const MfImage *like, float roughness, float metallic, MfImage *out);

/* Mean roughness (G) and metallic (B) over the inside pixels (alpha > 0.5) of linear ORM images
 * (c = 4); MF_EARG when no pixel is inside. */
int bl_orm_mean(const MfImage *const *orm, int n, float *roughness, float *metallic);

#endif
