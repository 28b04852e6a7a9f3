/* mf_diffrender: the differentiable renderer of the inverse pipeline (forward + adjoint).
 *
 * It runs the forward renderer's estimator (render/mf_estimator.h, the one behind mf_render):
 * per pixel, `pixel_samples` stratified primary rays; at each hit n^2 env-map light samples and
 * n^2 BSDF samples combined with the balance heuristic, direct environment light only, all lobes.
 * With the sampling copies absent (or equal), mf_diff_forward gives the bytes of mf_render for
 * the same scene as one textured material, seed and sample counts. What it adds:
 *  - separate parameters for SAMPLING (where directions are drawn, their pdfs and MIS weights)
 *    and for EVALUATION (the BRDF values and the radiance that are differentiated). Gradients are
 *    taken with sampling detached, as nvdiffrecmc does: d/dθ E[f L / p] = E[d(f L)/dθ / p]
 *    for samples drawn from p, so the sampler itself needs no derivative. A gradient check
 *    freezes sampling parameters and varies evaluation parameters, making the estimator a
 *    smooth function of them with common random numbers;
 *  - per-sample accumulation of the adjoint into texels (bilinear lookup of kd/ORM at the hit's
 *    UV, repeat wrap) and env-map texels (bilinear lookup along each sample direction).
 * Optional tangent-space normal map (render/mf_normalmap.h): the shading frame at each primary
 * hit is built from the mapped normal (evaluation) and, for drawing BSDF samples and their
 * pdfs, from the sampling copy's mapped normal; shadow-ray offsets and the below-the-surface
 * test keep the geometric normal. Its adjoint goes through the BRDF's dependence on the normal
 * (cosines and the half vector's cosine; the BRDF is isotropic) into the map's texels. Without
 * a map every output is bit-identical to the renderer without this feature.
 * Vertex positions (MfDiffGrads.dpos): each primary hit moves with its triangle's vertices (the
 * ray-plane intersection, render/mf_hitgrad.h), so its UV, the kd/ORM lookups there (or, with
 * volume textures, the lookups at its position) and the interpolated shading normal change; the normal's adjoint goes through the BRDF's cosines and
 * then through mf_mesh_compute_normals (exact when the mesh's normals are that function of its
 * positions, as for a marching-tets mesh; for a mesh without normals, through the face normal).
 * Not differentiated: the hit's position in shadow-ray origins and point/sun light directions
 * (the env is at infinity: its directions do not depend on the hit), the depth AOV, and the
 * visibility boundary (silhouettes and shadow edges; render/mf_antialias.h covers the primary
 * silhouettes of a pixel-centre pass), as in nvdiffrecmc.
 *
 * Antialiasing (MfDiffOpts.antialias, off by default): every primary ray goes through the pixel
 * centre and the composited outputs (rgb, diffuse, specular, alpha) are blended across screen-
 * space silhouette edges (render/mf_antialias.h), which gives the visibility boundary a gradient
 * (to the edges' vertices) for primary rays; the backward pass renders the pre-antialiasing image
 * once more with its own seed (its colours weight the edge gradient), so it costs one more
 * forward pass.
 * Outputs of the forward pass are MfRenderOut's (rgb, diffuse, specular premultiplied by
 * coverage; albedo, orm, depth averaged over the hits; normal the renormalised average of the
 * hits' shading normals, mapped when a normal map is given). Given dLoss/d(rgb, diffuse,
 * specular) the backward pass accumulates (+=) dLoss/d(kd texels, ORM texels, env texels). Memory
 * does not grow with samples: each thread owns one gradient buffer, reduced in thread order
 * (deterministic for a given seed and thread count). Decorrelation: the caller passes a
 * different seed to the backward pass than to the forward pass whose image produced dLoss/drgb
 * (the primal and adjoint samples are then independent, which removes the bias of
 * correlated estimates in non-linear losses). */
#ifndef MF_DIFFRENDER_H
#define MF_DIFFRENDER_H

#include <stdint.h>

#include "io/mf_image.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_camera.h"
#include "scene/mf_envmap.h"

typedef struct {
    const MfRtScene *rt;  /* borrowed; the (fixed) geometry, with UVs */
    const MfImage *kd;    /* borrowed; (th, tw, 3) linear base colour, evaluated */
    const MfImage *orm;   /* borrowed; (th, tw, 3) linear (occlusion, roughness, metallic), evaluated */
    const MfEnvMap *env;  /* borrowed; radiance, evaluated */
    const MfImage *kd_s;  /* borrowed; sampling copies, NULL = the evaluated ones */
    const MfImage *orm_s;
    const MfEnvMap *env_s;
    const MfImage *normal;   /* borrowed; (th, tw, 3) tangent-space normal map (mf_normalmap.h), or
                                NULL = none (shading normal = the hit's interpolated normal) */
    const MfImage *normal_s; /* borrowed; its sampling copy, NULL = normal */
    const float *tangent;    /* borrowed; (nv, 4) mf_mesh_tangents of rt's mesh, or NULL =
                                computed per call when a normal map is given */
    const MfRtScene *rt_s;   /* borrowed; sampling copy of the geometry, NULL = rt: gradient checks
                                of dpos keep it at the unperturbed mesh (mf_estimator.h) */
    const MfVoltex *vkd, *vorm;     /* borrowed; world-space volume textures (scene/mf_voltex.h, 3
                                       channels) in place of kd / orm, which may then be NULL (DMTet's
                                       colour pass: the mesh changes every step, so it has no UVs to keep) */
    const MfVoltex *vkd_s, *vorm_s; /* borrowed; their sampling copies, NULL = the evaluated ones */
} MfDiffScene;

typedef struct {
    int spp_sqrt;      /* n: n^2 light + n^2 BSDF samples per pixel sample, [1, 1024] */
    int pixel_samples; /* primary rays per pixel, [1, 1024] */
    uint64_t seed;
    int antialias;     /* 1: primary rays through pixel centres, then render/mf_antialias.h on rgb,
                          diffuse, specular and alpha (the other AOVs are left as traced); the
                          adjoint adds the silhouette edges' vertex gradients to dpos. 0: off */
} MfDiffOpts;

typedef struct {
    const float *drgb;      /* (h, w, 3) dLoss/d rgb, or NULL */
    const float *ddiffuse;  /* (h, w, 3) dLoss/d diffuse light, or NULL */
    const float *dspecular; /* (h, w, 3) dLoss/d specular radiance, or NULL */
    const float *dalpha;    /* (h, w) dLoss/d alpha, or NULL; used with antialias only (coverage
                               depends on nothing else that is differentiated) */
} MfDiffAdjoint;

typedef struct {
    float *dkd;  /* (th, tw, 3) +=, or NULL */
    float *dorm; /* (th, tw, 3) +=, or NULL (channel R never receives gradient) */
    float *denv; /* (eh, ew, 3) +=, or NULL */
    float *dnormal; /* (th, tw, 3) += normal-map texels, or NULL (ignored without a normal map) */
    float *dpos;    /* (nv, 3) += rt's mesh's vertex positions, or NULL; refused with a normal map */
    float *dnrm;    /* with dpos: (nv, 3) += the mesh's unit vertex normals, which then do not go on into
                       dpos (for a caller whose normals are another function of the positions); NULL:
                       they go through mf_mesh_compute_normals into dpos */
    float *dvkd;    /* (res^3 * 3) += the kd volume texture's grid, or NULL (ignored without one) */
    float *dvorm;   /* (res^3 * 3) += the ORM volume texture's grid (channel 0 gets none), or NULL */
} MfDiffGrads;

/* out must be allocated for cam->w x cam->h (mf_render_out_alloc); fills every AOV, as mf_render. */
int mf_diff_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, MfRenderOut *out);
int mf_diff_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const MfDiffAdjoint *adj,
                     MfDiffGrads *g);

/* Material AOVs for the prior term (UV textures only; volume textures are refused): per pixel, the mean over its primary-ray hits of kd (albedo)
 * and ORM at the hit's UV, and the coverage. Samples are stratified like the forward pass
 * (seed o->seed; mf_est_primary_hits: the forward pass's first sample); lighting is not evaluated. albedo, orm (h, w, 3), alpha (h, w). */
int mf_diff_aov_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, float *albedo, float *orm,
                        float *alpha);
/* Adjoint of mf_diff_aov_forward (same seed: same hits): g->dkd += from dalbedo (h, w, 3),
 * g->dorm += from dorm (h, w, 3) (either may be NULL). Deterministic (per-thread buffers). */
int mf_diff_aov_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const float *dalbedo,
                         const float *dorm, MfDiffGrads *g);

#endif
