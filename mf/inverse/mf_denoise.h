/* mf_denoise: nvdiffrecmc's differentiable bilateral denoiser of the demodulated light, and the
 * recombination rgb = kd (1 - m) F(diffuse) + F(specular) of the denoised light.
 *
 * Source (NVlabs/nvdiffrecmc, read for this port): denoiser/denoiser.py (BilateralDenoiser:
 * sigma = max(2 * influence, 1e-4)), render/optixutils/c_src/denoising.cu (the CUDA kernels),
 * render/optixutils/ops.py (output = sum w col / max(sum w, 1e-4); the gradient goes to the
 * colour only) and render/render.py (the diffuse and specular light are filtered separately,
 * guided by the shading normal and (depth, depth gradient), then rgb = F(diffuse) kd (1 - m)
 * + F(specular)). The weights there, for output pixel p and tap t = p + (dx, dy):
 *   window       |dx|, |dy| <= r, r = 2 ceil(2.5 sigma) + 1   (r = 11: 23x23 at sigma = 2)
 *   spatial      exp(-(dx^2 + dy^2) / (2 sigma^2))
 *   normal       clamp(n_p . n_t, 1e-4, 1)^128                (unit shading normals)
 *   depth        exp(-|z_t - z_p| / max(dz_p * |(dx, dy)|, 1e-4))
 * They depend on the G-buffer only, so for fixed geometry the filter is LINEAR in the light and
 * its adjoint is the transposed filter (the CUDA backward kernel gathers the same weights with
 * p and t swapped, the depth term keeping the OUTPUT pixel's dz). nvdiffrecmc's second pass
 * (geometry/dlmesh.py) runs at full strength; its first pass ramps sigma in over 1750
 * iterations, which this fixed-mesh loop has no use for.
 *
 * Differences, deliberate: depth z is the camera -z distance (not NDC z/w; the term is a ratio,
 * so the scale cancels) and dz is its change per pixel step on the pixel's tangent plane (the
 * larger of the x and y steps; nvdiffrecmc uses the rasteriser's derivative);
 * coverage: rasterised background has zero normals (weight 0) there; here a tap weighs by its
 * coverage alpha_t and the result is re-premultiplied by the output pixel's alpha_p, so that
 * partially covered edge pixels (pixel_samples > 1) stay premultiplied:
 *   F(x)_p = alpha_p sum_t w_pt x_t / W_p,   W_p = sum_t w_pt alpha_t,
 * for x premultiplied by alpha (x_t = alpha_t c gives alpha_p c: constants are preserved);
 * weights below 1e-30 (or with a depth term below e^-80) are dropped as 0, in the forward and
 * the adjoint alike (one weight function, cached per view when it fits in 192 MB);
 * the centre tap's normal and depth terms are 1 by definition, so W_p >= alpha_p > 0 wherever
 * a pixel is covered (no clamp needed), and F(x)_p = 0 where alpha_p = 0.
 * Images are (h, w, c) row-major, c channels per pixel (c = 3 for light). Rows are distributed
 * over OpenMP threads; every output value is a gather in a fixed order, so results do not
 * depend on the thread count. */
#ifndef MF_DENOISE_H
#define MF_DENOISE_H

#include <stddef.h>

#include "scene/mf_camera.h"

typedef struct {
    int w, h;
    float sigma;
    int radius;       /* 2 ceil(2.5 sigma) + 1 */
    float *spatial;   /* owned; (2r+1, 2r+1) spatial weights */
    float *inv_dist;  /* owned; (2r+1, 2r+1) 1 / |(dx, dy)| (0 at the centre) */
    float *normal;    /* owned; (h, w, 3) unit shading normal (0 where degenerate) */
    float *inv_dz;    /* owned; (h, w) 1 / dz */
    const float *depth; /* borrowed; (h, w) camera -z distance */
    const float *dz;    /* borrowed; (h, w) depth change per pixel step */
    const float *alpha; /* borrowed; (h, w) coverage in [0, 1] */
    float *inv_norm;  /* owned; (h, w) alpha_p / W_p (0 where alpha_p = 0) */
    float *wcache;    /* owned or NULL; (h, w, 2r+1, 2r+1) w_pt, when it fits in 192 MB
                       * (otherwise recomputed: the same function, the same values) */
} MfBilateral;

/* dz for the depth term: per covered pixel, the plane through the pixel centre's hit point
 * (depth along the centre ray) with the given normal, intersected with the rays through the
 * next pixel centres in x and y; dz = max |z_next - z|. Grazing or degenerate planes give a
 * large finite value (the depth term then tends to 1), never NaN. normal (h, w, 3), depth,
 * alpha, dz (h, w). */
void mf_bilateral_depth_slope(const MfCamera *cam, const float *normal, const float *depth, const float *alpha,
                              float *dz);

/* Prepares the filter for one G-buffer (w x h): copies and normalises the normals, keeps
 * pointers to depth, dz and alpha (which must outlive b's use) and computes the weights and
 * normalisation. sigma in (0, 8]. b must be zeroed before its first init; a later init of the
 * same b reuses its buffers when size and radius are unchanged. mf_bilateral_free releases. */
int mf_bilateral_init(MfBilateral *b, int w, int h, float sigma, const float *normal, const float *depth,
                      const float *dz, const float *alpha);
void mf_bilateral_free(MfBilateral *b);

/* out = F(in): in, out (h, w, c), distinct. */
int mf_bilateral_forward(const MfBilateral *b, const float *in, int c, float *out);
/* din += F^T(dout): dout, din (h, w, c), distinct. */
int mf_bilateral_backward(const MfBilateral *b, const float *dout, int c, float *din);

/* The demodulated recombination of the renderer (mf_diffrender: per sample rgb = kd (1 - m)
 * diffuse + specular), applied to the denoised light: per pixel
 *   dn_diffuse = F(diffuse), dn_specular = F(specular),
 *   rgb = albedo (1 - clamp(orm.B, 0, 1)) dn_diffuse + dn_specular,
 * with albedo, orm the per-pixel means over the pixel's hits (MfRenderOut's albedo/orm, not
 * premultiplied) and diffuse, specular premultiplied. With F = identity and one pixel sample
 * this is the renderer's rgb exactly. All arrays (h, w, 3). */
int mf_denoise_combine_forward(const MfBilateral *b, const float *diffuse, const float *specular, const float *albedo,
                               const float *orm, float *dn_diffuse, float *dn_specular, float *rgb);
/* Adjoint, given dLoss/d(rgb, dn_diffuse, dn_specular) (the latter two may be NULL, e.g. the
 * shading regulariser's terms): ddiffuse, dspecular, dalbedo, dorm += (dorm gets channel B
 * only, none where orm.B is outside [0, 1]). dn_diffuse is the forward's output. */
int mf_denoise_combine_backward(const MfBilateral *b, const float *dn_diffuse, const float *albedo, const float *orm,
                                const float *drgb, const float *d_dn_diffuse, const float *d_dn_specular,
                                float *ddiffuse, float *dspecular, float *dalbedo, float *dorm);

#endif
