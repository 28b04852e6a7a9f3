/* mf_estimator: the one Monte Carlo estimator behind the forward renderer (mf_integrator.h,
 * mf_render) and the differentiable renderer (mf_diffrender.h, mf_diff_forward/backward).
 * Internal to render/: callers use those two APIs.
 *
 * Per pixel (x, y): PCG32 stream y*w + x of `seed` (images do not depend on the thread count);
 * `pixel_samples` primary rays through jittered positions (box filter; x and y each stratified
 * into pixel_samples strata, paired by a random permutation, i.e. N-rooks; the permutation is
 * drawn first, then each sample's two jitters just before it is traced). At each hit, direct
 * light only:
 *   - environment map: n^2 light samples (mf_env_sample_dir_n) and n^2 BSDF samples
 *     (mf_brdf_ctx_sample), both stratified on an n x n grid (mf_rng_stratum2), combined with
 *     the balance heuristic (each sample contributes f L V / (n^2 (p_light + p_bsdf))); n = spp_sqrt;
 *   - point and sun lights (delta lights): one shadow ray each, no MIS.
 * Shadow rays start at mf_est_ray_origin (offset along the geometric normal on the side of the
 * ray by p's rounding-error bound: scale-free). No indirect bounces by default. With bounces = B
 * > 0 (forward only; the adjoint stays direct-light, as nvdiffrecmc), each hit of a path also
 * draws one BSDF direction (three more numbers from the pixel's stream, after its direct
 * light's): a ray that hits the mesh there adds f cos / pdf times the radiance leaving that
 * hit toward it (its direct light, and its own bounce while fewer than B were taken); a ray
 * that misses adds nothing, since the env reached along it is counted by the MIS-weighted
 * direct light already (path tracing with next-event estimation). Images with B = 0 are
 * unchanged bit for bit. Misses contribute nothing (transparent film).
 *
 * Sampling and evaluation parameters may differ (the differentiable renderer's gradient checks
 * freeze sampling): directions, pdfs and MIS weights come from mats_s / env_s and the sampling
 * copy's normal map; BRDF values and radiance from mats / env. With the same copies (the forward
 * renderer) both are the same numbers. A sampling copy of the geometry (rt_s, for gradient
 * checks with respect to vertex positions) is traced along the same primary ray; its hit gives
 * the sampling frame (without a normal map), the sampling material's UV and the geometric
 * normal of the below-the-surface tests, so drawn directions, pdfs and MIS weights stay fixed
 * while rt's vertices move (shadow rays and shading use rt's hit).
 *
 * Forward (out != NULL): writes the pixel's AOVs (MfRenderOut: rgb, diffuse, specular averaged
 * over all pixel samples, i.e. premultiplied by alpha; albedo, orm, normal (renormalised shading
 * normal), depth averaged over the hits). Adjoint (adj != NULL): given dLoss/d(rgb, diffuse,
 * specular) of the pixel, accumulates (+=) dLoss/d(material 0's kd, ORM and normal-map texels)
 * and dLoss/d(env texels) into the caller's (per-thread) buffers, and when dpos is given
 * dLoss/d(vertex positions, normals) through the primary hit's UV (texture gradients) and
 * shading normal (mf_hitgrad.h; no normal map), with sampling detached
 * (d/dθ E[f L / p] = E[d(f L)/dθ / p]); pixels with a zero adjoint are skipped (no rays). The
 * adjoint of delta lights reaches the material only. The same seed gives the same samples in
 * both passes. */
#ifndef MF_ESTIMATOR_H
#define MF_ESTIMATOR_H

#include <stdint.h>

#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "render/mf_integrator.h"

#define MF_MAX_PIXEL_SAMPLES 1024
#define MF_MAX_SPP_SQRT 1024

typedef struct {
    const MfRtScene *rt;           /* borrowed */
    const MfRtScene *rt_s;         /* borrowed; sampling copy of the geometry, or NULL = rt (see below) */
    const MfMesh *mesh;            /* borrowed; rt's mesh */
    const MfTexMaterial *mats;     /* borrowed; (nmat,) evaluated; ids outside [0, nmat) use 0 */
    const MfTexMaterial *mats_s;   /* borrowed; (nmat,) sampling copies, or NULL = mats */
    int nmat;
    const MfEnvMap *env;           /* borrowed; evaluated, or NULL (no environment light) */
    const MfEnvMap *env_s;         /* borrowed; sampling copy (NULL = env) */
    const MfLight *lights;         /* borrowed; (nlights,) */
    int nlights;
    const float *tan;              /* borrowed; (nv, 4) tangents when a material has a normal map, else NULL */
    int spp_sqrt, pixel_samples;   /* [1, MF_MAX_SPP_SQRT], [1, MF_MAX_PIXEL_SAMPLES] */
    int lobes;                     /* MfLobes */
    uint64_t seed;
    int centre;                    /* 1: every primary ray through the pixel centre (the random
                                      stream is drawn as without it); for mf_antialias.h */
    int bounces;                   /* forward only: indirect bounces (0: direct light only; below) */
} MfEstimator;

/* One thread's adjoint: the pixel adjoints (read) and its gradient buffers (+=). */
typedef struct {
    const float *drgb, *ddiffuse, *dspecular; /* borrowed; (h, w, 3) dLoss/d AOV, or NULL */
    float *dkd;     /* borrowed; (th, tw, 3) material 0's kd texels, or NULL */
    float *dorm;    /* borrowed; (th, tw, 3) material 0's ORM texels (R gets none), or NULL */
    float *dnormal; /* borrowed; (th, tw, 3) material 0's normal-map texels, or NULL */
    float *denv;    /* borrowed; (eh, ew, 3) env texels, or NULL */
    float *dvkd;    /* borrowed; (res^3 * 3) material 0's kd volume texture (MfTexMaterial.vkd), or NULL */
    float *dvorm;   /* borrowed; (res^3 * 3) its ORM volume texture (channel 0 gets none), or NULL */
    float *dpos;    /* borrowed; (nv, 3) vertex positions through the hit point (mf_hitgrad.h), or NULL */
    float *dnrm;    /* borrowed; (nv, 3) vertex normals through the shading normal; with dpos */
} MfEstAdjoint;

/* The film positions of one pixel's samples and the pixel's random stream. */
typedef struct {
    MfRng rng;                       /* the pixel's stream; shading draws from it too */
    int n, x, y;                     /* pixel samples; pixel */
    float inv_n;
    int perm[MF_MAX_PIXEL_SAMPLES];  /* (n,) y stratum of sample k */
} MfPixelSampler;

/* Seeds the pixel's stream (seed, stream y*w + x) and draws the strata permutation. */
void mf_pixel_sampler_init(MfPixelSampler *s, uint64_t seed, int w, int x, int y, int n);
/* Film position of sample k (draws two numbers). */
static inline void mf_pixel_sampler_pos(MfPixelSampler *s, int k, float *px, float *py) {
    *px = (float)s->x + ((float)k + mf_rng_float(&s->rng)) * s->inv_n;
    *py = (float)s->y + ((float)s->perm[k] + mf_rng_float(&s->rng)) * s->inv_n;
}

/* Checks an estimator's options (who: the caller's name for messages). */
int mf_est_check(const MfEstimator *e, const MfCamera *cam, const char *who);

/* The tangents the materials' normal maps need: `given` if non-NULL, else computed into *owned
 * (free it); *tan = NULL when no material has a map. */
int mf_est_tangents(const MfMesh *mesh, const MfTexMaterial *mats, int nmat, const float *given, const float **tan,
                    float **owned);

/* One pixel: forward into out (adj NULL) or adjoint into adj (out NULL); log (may be NULL)
 * records the rays traced. */
void mf_est_pixel(const MfEstimator *e, const MfCamera *cam, int x, int y, MfRenderOut *out, MfEstAdjoint *adj,
                  MfRayLog *log);
/* Rows [y0, y1) forward into out (rows in parallel); logs[y - y0] (if logs) gets row y's rays;
 * prog (may be NULL) advances by one per row. */
void mf_est_render_rows(const MfEstimator *e, const MfCamera *cam, int y0, int y1, MfRenderOut *out, MfRayLog *logs,
                        MfProgress *prog);
/* The primary hits of pixel (x, y), sampled like the forward pass (same stream, strata and
 * permutation; no shading): sample 0 is the forward pass's sample 0, later samples differ since
 * the forward pass draws its shading numbers in between. hits (pixel_samples,); returns their count. */
int mf_est_primary_hits(const MfEstimator *e, const MfCamera *cam, int x, int y, MfHit *hits);

/* Origin of a ray leaving hit h in direction d: h->p offset along the geometric normal, on d's
 * side, by MF_RAY_OFFSET_SAFETY times the projection of h->perr (p's error bound) onto it, then
 * rounded one ulp away from p (pbrt-v4's OffsetRayOrigin; "A Fast and Robust Method for Avoiding
 * Self-Intersection", Ray Tracing Gems ch. 6, for the motivation). Proportional to the
 * magnitudes of the triangle's coordinates, so a scene and its cameras scaled by any factor
 * render the same (mf_render of a scene x 1e-4 .. x 1e4 is within float precision of x 1). */
#define MF_RAY_OFFSET_SAFETY 4.0f
MfVec3 mf_est_ray_origin(const MfHit *h, MfVec3 d);

#endif
