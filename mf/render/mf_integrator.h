/* mf_integrator: the forward Monte Carlo renderer (nvdiffrecmc's direct-lighting estimator).
 *
 * The estimator itself is render/mf_estimator.h, shared with the differentiable renderer
 * (mf_diffrender.h): per pixel, `pixel_samples` primary rays through jittered positions inside
 * the pixel (box filter; N-rooks stratified). At each hit, direct light only:
 *   - environment map: n^2 light samples (mf_env_sample) and n^2 BSDF samples (mf_brdf_sample),
 *     both stratified on an n x n grid, combined with the balance heuristic (multi-sample MIS:
 *     each sample contributes f L V / (n^2 (p_light + p_bsdf))); n = spp_sqrt;
 *   - point and sun lights (delta lights): one shadow ray each, no MIS.
 * Shadow rays start at p offset along the geometric normal ng on the side of the sampled
 * direction (mf_est_ray_origin). No indirect bounces unless MfRenderOpts.bounces > 0 (then a path
 * continues from each hit by one BSDF sample per bounce, mf_estimator.h). Misses contribute
 * nothing (transparent film).
 *
 * Outputs (MfRenderOut, per pixel, all (h, w, c) row 0 at the top):
 *   alpha             fraction of pixel samples that hit the mesh (coverage)
 *   rgb, diffuse, specular  averaged over ALL pixel samples with misses counted as 0, i.e.
 *                     premultiplied by alpha (background = 0). rgb is linear HDR radiance;
 *                     diffuse is the demodulated diffuse light  sum L cos / pi  (what a white
 *                     Lambertian would reflect), specular the specular radiance. For every
 *                     pixel sample rgb = kd (1 - m) diffuse + specular exactly; for the pixel
 *                     averages this holds exactly when kd, m are constant over the covered
 *                     samples (always with pixel_samples = 1).
 *   albedo (kd), orm, normal (world shading normal, renormalised average), depth (distance
 *                     along the camera's -z axis)  averaged over the samples that HIT only
 *                     (not premultiplied); 0 where alpha = 0.
 * Materials: per material id (mesh->mat, 0 without), kd from a linear RGB texture (sRGB-decoded
 * on load by the scene loader) or a constant; ORM (occlusion, roughness, metallic; linear) from a
 * texture or a constant; textures sampled bilinearly with repeat wrap at the hit's UV. A
 * material may carry a tangent-space normal map (mf_normalmap.h; tangents from the mesh's UVs,
 * scene/mf_tangent.h): it sets the shading normal at the primary hit (and the normal AOV);
 * shadow-ray offsets keep the geometric normal. Without one, images are unchanged bit for bit.
 * Determinism: pixel (x, y) draws from PCG32 stream y*w + x of `seed`, so images do not depend
 * on the thread count. Rows are distributed over OpenMP threads. */
#ifndef MF_INTEGRATOR_H
#define MF_INTEGRATOR_H

#include <stddef.h>
#include <stdint.h>

#include "core/mf_log.h"
#include "io/mf_image.h"
#include "render/mf_brdf.h"
#include "render/mf_rtscene.h"
#include "scene/mf_camera.h"
#include "scene/mf_envmap.h"
#include "scene/mf_light.h"
#include "scene/mf_voltex.h"

typedef struct {
    const MfImage *kd;  /* borrowed; (h, w, >=3) linear base colour, or NULL: kd_const */
    const MfImage *orm; /* borrowed; (h, w, >=3) linear ORM, or NULL: orm_const */
    MfVec3 kd_const;    /* linear base colour */
    MfVec3 orm_const;   /* (occlusion, roughness, metallic) */
    const MfImage *normal; /* borrowed; (h, w, 3) tangent-space normal map (render/mf_normalmap.h,
                              glTF convention), or NULL: the hit's interpolated normal */
    const MfVoltex *vkd;   /* borrowed; (res^3, 3) world-space volume texture (scene/mf_voltex.h)
                              looked up at the hit's position, in place of kd / kd_const; or NULL */
    const MfVoltex *vorm;  /* borrowed; the same for ORM, in place of orm / orm_const; or NULL */
} MfTexMaterial;

typedef struct {
    const MfRtScene *rt;        /* borrowed; built from the mesh below */
    const MfMesh *mesh;         /* borrowed */
    const MfTexMaterial *mats;  /* borrowed; (nmat,), nmat >= 1; ids outside [0, nmat) use 0 */
    int nmat;
    const MfEnvMap *env;        /* borrowed, or NULL (no environment light) */
    const MfLight *lights;      /* borrowed; (nlights,) */
    int nlights;
} MfRenderInput;

typedef struct {
    int spp_sqrt;      /* n: n^2 env-light samples + n^2 BSDF samples per pixel sample (>= 1) */
    int pixel_samples; /* primary rays per pixel (>= 1) */
    uint64_t seed;
    int lobes;         /* MfLobes */
    int bounces;       /* indirect bounces after the direct light (0: nvdiffrecmc's direct light only);
                          forward renders only, e.g. data sets with interreflection (mf_estimator.h) */
} MfRenderOpts;

static inline MfRenderOpts mf_render_opts_default(void) {
    MfRenderOpts o = {.spp_sqrt = 8, .pixel_samples = 4, .seed = 0, .lobes = MF_LOBE_ALL};
    return o;
}

/* One allocation, AOV pointers into it (llm.c style). */
typedef struct {
    int w, h;
    float *rgb;      /* (h, w, 3) linear radiance, premultiplied by alpha */
    float *alpha;    /* (h, w) coverage */
    float *albedo;   /* (h, w, 3) kd, linear */
    float *orm;      /* (h, w, 3) */
    float *normal;   /* (h, w, 3) world shading normal */
    float *depth;    /* (h, w) camera -z distance */
    float *diffuse;  /* (h, w, 3) demodulated diffuse light, premultiplied */
    float *specular; /* (h, w, 3) specular radiance, premultiplied */
    float *mem;      /* owned; backing store of all of the above */
} MfRenderOut;

int mf_render_out_alloc(MfRenderOut *o, int w, int h);
void mf_render_out_free(MfRenderOut *o);

/* Writes all AOVs to one multi-layer EXR (float32; channels R G B A, albedo.R/G/B, orm.R/G/B,
 * normal.X/Y/Z, depth.Z, diffuse.R/G/B, specular.R/G/B; R G B premultiplied by A), atomically. */
int mf_render_out_write_exr(const char *path, const MfRenderOut *o);
/* Writes rgb and alpha as an 8-bit sRGB PNG with straight (un-premultiplied) alpha, atomically. */
int mf_render_out_write_png(const char *path, const MfRenderOut *o);

/* One recorded ray (for the bare-Embree benchmark). kind 0 = primary (closest hit),
 * 1 = shadow (occlusion). */
typedef struct {
    float org[3], dir[3];
    float tnear, tfar;
    int kind;
} MfRayRec;

typedef struct {
    MfRayRec *rays; /* owned; (n,) */
    size_t n, cap;
} MfRayLog;

void mf_raylog_free(MfRayLog *log);

/* Renders the camera's full image into out (allocated here; out->w, h = cam->w, h).
 * prog may be NULL; it advances by one per row. */
int mf_render(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts, MfRenderOut *out, MfProgress *prog);

/* Renders rows [y0, y1) into an already allocated out (cam->w x cam->h); if logs is non-NULL,
 * logs[y - y0] receives the rays traced for row y (rows are rendered in parallel). */
int mf_render_rows(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts, int y0, int y1,
                   MfRenderOut *out, MfRayLog *logs, MfProgress *prog);

#endif
