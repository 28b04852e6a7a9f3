/* mf_loss: image losses and regularisers of the inverse pipeline, as forward/backward pairs.
 *
 * Each *_fwd returns the loss value; each *_bwd accumulates scale * dLoss/dinput into the
 * gradient buffers with += (so terms add up). Means are over the elements named in each
 * comment. All arrays are float32 and interleaved.
 *
 * Image loss as nvdiffrecmc ("logl1"): l(x) = srgb(log(clamp(x, 0, 65535) + 1)) with srgb
 * the exact piecewise curve, loss = mean |l(pred + f) - l(ref + f)| over (N, 3) colour elements,
 * after both are composited over the same random background (mf_loss_composite). The floor f
 * >= 0 is OURS (nvdiffrecmc: 0): the curve's slope near black is up to ~50x its slope at 0.5,
 * so without a floor the darkest pixels, whose 8-bit values carry the least information, weigh
 * most (MfReconOpts.loss_floor).
 * Alpha loss: mean (a_pred - a_ref)^2.
 * Texture smoothness (our texel-space form of nvdiffrecmc's jittered-surface smoothness):
 * mean over texel pairs (right and lower neighbours) of |t(p) - t(q)| for the listed channels,
 * restricted to texels where the weight mask (texels the mesh uses) is > 0.
 * Shading regulariser — OURS, a chroma-only "white light" term, NOT nvdiffrecmc's: over covered
 * pixels, mean |D_c - luma(D)| of the demodulated diffuse light D (pushes the light toward white,
 * so colour goes into albedo), plus lambda_spec * mean(spec) / mean(diffuse). nvdiffrecmc's term
 * (REFERENCE.md) instead compares the log-sRGB luminance of diffuse + specular light with the
 * max-RGB of the reference image, weighted by the diffuse fraction: it also constrains the light's
 * brightness against the image, which ours leaves to the image loss. */
#ifndef MF_LOSS_H
#define MF_LOSS_H

#include <stddef.h>
#include <stdint.h>

/* out (N, 3) = rgb_premult (N, 3) + (1 - alpha (N,)) * bg (N, 3). */
void mf_loss_composite(float *out, const float *rgb_premult, const float *alpha, const float *bg, size_t npx);

/* The logl1 tone curve and its derivative (for tests and callers). */
float mf_logsrgb(float x);
float mf_logsrgb_deriv(float x);

/* pred, ref (n,); floor >= 0 is added to both before the curve. */
double mf_loss_logl1_fwd(const float *pred, const float *ref, size_t n, float floor);
void mf_loss_logl1_bwd(const float *pred, const float *ref, size_t n, float floor, float scale, float *dpred);

double mf_loss_mse_fwd(const float *pred, const float *ref, size_t n);
void mf_loss_mse_bwd(const float *pred, const float *ref, size_t n, float scale, float *dpred);

/* Uniform Laplacian of a mesh's vertices pos (nv, 3), neighbours in CSR (off (nv + 1,), adj): sum over
 * vertices with neighbours of |p_i - mean of its neighbours|^2 (a neighbour listed twice counts twice).
 * bwd: dpos (nv, 3) += scale x its gradient. */
double mf_reg_laplacian_fwd(const float *pos, int nv, const int *off, const int *adj);
/* The neighbour lists they take, for nv vertices and triangles tri (nt, 3): both directions of every
 * triangle's edges (an edge two triangles share counts twice, so a closed mesh's weights stay
 * uniform). *off (nv + 1,) and *adj (6 nt,) are malloc'd; the caller frees both. */
int mf_reg_laplacian_adjacency(const uint32_t *tri, int nt, int nv, int **off, int **adj);
void mf_reg_laplacian_bwd(const float *pos, int nv, const int *off, const int *adj, float scale, float *dpos);

/* tex (h, w, ch); channels [c0, c0 + nc) are regularised; mask (h, w) or NULL (all texels). */
double mf_reg_smooth_fwd(const float *tex, int w, int h, int ch, int c0, int nc, const float *mask);
/* Env-map smoothness of the unseen directions (env_auto): env (h, w, 3) radiance, cover (h, w)
 * (mf_budget_env_coverage); mean over the neighbour pairs (right, with the longitude wrapping, and
 * lower) where at least one texel is uncovered, and the 3 channels, of |e(p) - e(q)|: the uncovered
 * texels are pulled toward their neighbours, the covered ones only where they border them. */
double mf_reg_env_unseen_fwd(const float *env, int w, int h, const unsigned char *cover);
void mf_reg_env_unseen_bwd(const float *env, int w, int h, const unsigned char *cover, float scale, float *denv);
void mf_reg_smooth_bwd(const float *tex, int w, int h, int ch, int c0, int nc, const float *mask, float scale,
                       float *dtex);
/* Env-map log-radiance total variation (w_env_tv): env (h, w, 3) radiance > 0; mean over every
 * neighbour pair (right, the longitude wrapping, and lower) and the 3 channels of
 * |log e(p) - log e(q)|. In log space it does not depend on the images' exposure, and a bright
 * sun's edge costs what any other edge of the same contrast costs. */
double mf_reg_env_logtv_fwd(const float *env, int w, int h);
void mf_reg_env_logtv_bwd(const float *env, int w, int h, float scale, float *denv);

/* Normal-map perturbation (nvdiffrecmc's normal-map regulariser): mean over the masked texels
 * of sum_c |(2 v_c - 1) - flat_c| / 3, flat = (0, 0, 1): the L1 deviation of the tangent-space
 * normal from unperturbed. nmap (h, w, 3) texels in [0, 1]; mask (h, w) or NULL. */
double mf_reg_nmap_flat_fwd(const float *nmap, int w, int h, const float *mask);
void mf_reg_nmap_flat_bwd(const float *nmap, int w, int h, const float *mask, float scale, float *dnmap);

/* diffuse (N, 3), spec (N, 3), cover (N,) in [0, 1]. */
double mf_reg_shading_fwd(const float *diffuse, const float *spec, const float *cover, size_t npx, float lambda_spec);
void mf_reg_shading_bwd(const float *diffuse, const float *spec, const float *cover, size_t npx, float lambda_spec,
                        float scale, float *ddiffuse, float *dspec);

#endif
