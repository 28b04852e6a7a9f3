/* mf_envmap: HDR equirectangular environment light in Blender's world mapping, with
 * importance sampling.
 *
 * Mapping (DESIGN.md): unit world direction d = (x, y, z), +Z up:
 *   u = 0.5 - atan2(y, x) / (2 pi),   v = 0.5 + asin(z) / pi,
 * image row 0 at v = 1 (+Z), texel centres at u*W - 0.5 (bilinear, wrap in u, clamp in v).
 * Radiance is linear (W / (m^2 sr)), RGB.
 * Sampling (as nvdiffrecmc): piecewise-constant over texels with probability proportional to
 * max(R, G, B) * sin(theta) (theta = polar angle of the texel centre row); pdf returned in solid
 * angle. Rebuild the tables (mf_env_update) whenever texels change.
 * Details: texel (x, y) is the cell u in [x, x+1]/W, row band theta in [y, y+1] pi/H. Its weight
 * gets a floor of 1e-4 * mean(max(R, G, B)) (all-black map: uniform), so every direction has
 * pdf > 0 and light sampling alone is unbiased even where bilinear filtering bleeds light into
 * black texels. Inside the texel the point is uniform in solid angle (uniform in u and in
 * cos(theta)), so pdf = P(texel) / Omega(texel) is constant per texel and finite at the poles.
 * P(texel) comes from the same float CDFs the sampler searches: mf_env_pdf(d) is exactly the
 * density of mf_env_sample (up to rounding on texel borders). */
#ifndef MF_ENVMAP_H
#define MF_ENVMAP_H

#include <stdint.h>

#include "core/mf_math.h"
#include "io/mf_image.h"

typedef struct {
    MfImage img;     /* owned; (h, w, 3) linear radiance */
    float *marg_cdf; /* owned; (h + 1,) cumulative over rows */
    float *cond_cdf; /* owned; (h, w + 1) cumulative within each row */
    double total;    /* sum of texel weights (for pdf) */
    /* Acceleration tables (rebuilt by mf_env_update; results are identical without them). */
    double *row_tab;      /* owned; (h, 2): cos(pi y / h), cos(pi y / h) - cos(pi (y + 1) / h) */
    uint32_t *marg_guide; /* owned; (marg_k + 1,) marg_guide[k] = row drawn by u = k / marg_k */
    uint32_t *cond_guide; /* owned; (h, cond_k + 1) same per row for the column CDFs */
    int marg_k, cond_k;   /* guide table sizes (powers of two) */
} MfEnvMap;

/* Takes ownership of img (must have c >= 3; extra channels dropped; NaN/Inf refused) and builds
 * the sampling tables. On failure img is freed. */
int mf_env_init(MfEnvMap *env, MfImage *img);
/* Constant radiance env map of size w x h. */
int mf_env_init_constant(MfEnvMap *env, int w, int h, MfVec3 radiance);
/* Loads an EXR/HDR file. */
int mf_env_load(MfEnvMap *env, const char *path);
void mf_env_free(MfEnvMap *env);
/* Rebuilds the sampling tables after the texels changed. */
int mf_env_update(MfEnvMap *env);
/* Rotates the map about +Z by angle (radians, right-handed: a feature at azimuth phi moves to
 * phi + angle), resampling columns with linear interpolation in u. The angle is taken modulo
 * 2 pi; a non-finite angle fails with MF_EARG. */
int mf_env_rotate_z(MfEnvMap *env, float angle);

void mf_env_dir_to_uv(MfVec3 d, float *u, float *v);
MfVec3 mf_env_uv_to_dir(float u, float v);
/* Bilinear radiance along world direction d (unit). */
MfVec3 mf_env_eval(const MfEnvMap *env, MfVec3 d);
/* Adjoint of mf_env_eval: dimg (h, w, 3) += weights * dL. */
void mf_env_eval_backward(const MfEnvMap *env, MfVec3 d, MfVec3 dL, float *dimg);
/* Draws a direction from (u1, u2) in [0,1)^2; returns its radiance (mf_env_eval), writes the
 * direction and its solid-angle pdf. */
MfVec3 mf_env_sample(const MfEnvMap *env, float u1, float u2, MfVec3 *dir, float *pdf);
/* Solid-angle pdf of mf_env_sample for direction d. */
float mf_env_pdf(const MfEnvMap *env, MfVec3 d);
/* mf_env_sample without the radiance lookup (same direction and pdf): for callers that reject
 * many samples before they need the radiance (then call mf_env_eval). */
void mf_env_sample_dir(const MfEnvMap *env, float u1, float u2, MfVec3 *dir, float *pdf);
/* mf_env_eval and mf_env_pdf of the same direction from one direction -> (u, v) conversion
 * (identical values). */
MfVec3 mf_env_eval_pdf(const MfEnvMap *env, MfVec3 d, float *pdf);
/* Batched forms (n >= 0 items, same values as the single calls): memory loads of all items are
 * issued (prefetched) before any is used, so their cache misses overlap. pdf may be NULL in
 * mf_env_eval_pdf_n (then only radiance). */
void mf_env_sample_dir_n(const MfEnvMap *env, int n, const float *u1, const float *u2, MfVec3 *dir, float *pdf);
void mf_env_eval_pdf_n(const MfEnvMap *env, int n, const MfVec3 *d, MfVec3 *L, float *pdf);

#endif
