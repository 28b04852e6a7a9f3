/* mf_brdf: the nvdiffrecmc BRDF (REFERENCE.md), its sampling and pdf.
 *
 * All directions are unit vectors in the local shading frame (z = shading normal); wo points
 * toward the viewer, wi toward the light. Material (metallic workflow):
 *   diffuse  = kd (1 - m) / pi                         (Lambert)
 *   specular = F D G / (4 cos_o cos_i), GGX D with alpha = r^2, r = max(roughness, 0.08),
 *              G = height-correlated Smith 1 / (1 + Lambda(wi) + Lambda(wo)),
 *              F = Schlick(F0, dot(wo, h)), F0 = 0.04 (1 - m) + kd m, f90 = 1.
 * mf_brdf_eval returns both lobes multiplied by cos_i (the integrand's BRDF factor); the
 * diffuse part is also returned demodulated (without kd (1 - m)) for the renderer's AOVs.
 * Sampling: lobe chosen with p_diffuse = (1-m) lum(kd) / ((1-m) lum(kd) + lum(F(F0, cos_o)));
 * diffuse by cosine-weighted hemisphere, specular by GGX visible normals (Heitz 2018).
 * Hard cases (roughness at its floor, grazing angles, black or white albedo) stay finite. */
#ifndef MF_BRDF_H
#define MF_BRDF_H

#include "core/mf_math.h"

#define MF_MIN_ROUGHNESS 0.08f

typedef enum { MF_LOBE_DIFFUSE = 1, MF_LOBE_SPECULAR = 2, MF_LOBE_ALL = 3 } MfLobes;

typedef struct {
    MfVec3 kd;       /* base colour, linear */
    float roughness; /* [0, 1], clamped to >= MF_MIN_ROUGHNESS inside */
    float metallic;  /* [0, 1] */
} MfMaterial;

typedef struct {
    MfVec3 diffuse;       /* kd (1-m) / pi * cos_i */
    MfVec3 specular;      /* F D G / (4 cos_o cos_i) * cos_i */
    float diffuse_demod;  /* cos_i / pi (white-Lambert factor) */
} MfBrdfValue;

/* Zero when wo.z <= 0 or wi.z <= 0. Lobes not in `lobes` are zero. */
MfBrdfValue mf_brdf_eval(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes);
/* Probability of choosing the diffuse lobe (1 or 0 when only one lobe is enabled). */
float mf_brdf_p_diffuse(const MfMaterial *mat, MfVec3 wo, int lobes);
/* Solid-angle pdf of mf_brdf_sample: p_d cos_i / pi + (1 - p_d) D_v(h) / (4 dot(wo, h)), zero
 * when wo.z <= 0 or wi.z <= 0. Specular samples reflected below the horizon are rejected by
 * mf_brdf_sample, so at rough/grazing settings this integrates to (1 - P(rejection)) < 1 over
 * the hemisphere; it is still exactly the density of the accepted samples (use it for MIS). */
float mf_brdf_pdf(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes);
/* Samples wi from (u0 chooses the lobe, u1, u2 the direction); returns 0 if no valid direction
 * (then *wi and *pdf are unspecified). */
int mf_brdf_sample(const MfMaterial *mat, MfVec3 wo, float u0, float u1, float u2, int lobes, MfVec3 *wi, float *pdf);

/* Per-shading-point constants for one material and wo (lobe probability, alpha, F0, Smith term
 * of wo): mf_brdf_prepare once, then mf_brdf_ctx_eval_pdf / mf_brdf_ctx_sample return exactly
 * the values of mf_brdf_eval + mf_brdf_pdf / mf_brdf_sample + mf_brdf_eval (same operations),
 * without recomputing them per direction. */
typedef struct {
    MfMaterial mat;
    MfVec3 wo, f0;
    int lobes;
    float co, met, alpha, a2, so; /* min(wo.z, 1), clamped metallic, r^2, alpha^2, s(co) */
    float pd;                     /* mf_brdf_p_diffuse */
} MfBrdfCtx;
void mf_brdf_prepare(MfBrdfCtx *c, const MfMaterial *mat, MfVec3 wo, int lobes);
/* mf_brdf_eval(wi) and, in *pdf, mf_brdf_pdf(wi). */
MfBrdfValue mf_brdf_ctx_eval_pdf(const MfBrdfCtx *c, MfVec3 wi, float *pdf);
/* mf_brdf_sample; on success also *f = mf_brdf_eval(*wi). */
int mf_brdf_ctx_sample(const MfBrdfCtx *c, float u0, float u1, float u2, MfVec3 *wi, float *pdf, MfBrdfValue *f);

/* Adjoint of mf_brdf_eval with respect to the material (wo, wi and the sampling are constants):
 * dmat->kd, ->roughness, ->metallic += gradient of <d_diffuse, diffuse> + <d_specular, specular>.
 * Roughness outside [MF_MIN_ROUGHNESS, 1] and metallic outside [0, 1] are clamped in mf_brdf_eval
 * and get no gradient (at the bounds themselves the inner derivative is passed). */
void mf_brdf_eval_backward(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes, MfVec3 d_diffuse, MfVec3 d_specular,
                           MfMaterial *dmat);

/* Building blocks, exposed for tests and the adjoint. alpha = roughness^2 (already clamped). */
float mf_ggx_D(float alpha, float cos_h);
float mf_smith_lambda(float alpha, float cos_theta);
float mf_smith_G(float alpha, float cos_o, float cos_i);
MfVec3 mf_fresnel_schlick(MfVec3 f0, float cos_d);

#endif
