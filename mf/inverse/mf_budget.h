/* mf_budget: budgets of the inverse loop chosen from the data (issue 16), each behind a flag of
 * the reconstruction options (mf_recon_opts.c) and used by mf_recon:
 *   - texture side from the projected texel density of the training views (tex_auto);
 *   - visible texels (hit by a primary ray through a training pixel's centre), on which the
 *     "no metal" test (metal_auto) counts metallic texels;
 *   - env directions seen in a reflection by some training view (env_auto: the others are
 *     regularised toward their neighbours);
 *   - the env map's size from the sharpest specular lobe on the visible texels (env_res_auto);
 *   - early stopping on held-out training views (early_stop): which views are held out, and
 *     the patience rule on their PSNR.
 * Units: pixels of the training views at their training resolution; UV area in the unit square
 * (a texture of side T has T^2 texels over it). Pure functions, no logging. */
#ifndef MF_BUDGET_H
#define MF_BUDGET_H

#include "inverse/mf_recon.h"
#include "render/mf_rtscene.h"

/* Texel density: for each (triangle, view) pair where the triangle is hit by at least one
 * primary ray through a pixel centre (visible), s = sqrt(screen area in pixels / UV area); the
 * side T = s gives one pixel per texel on that triangle. Returns the median s over the pairs in
 * *median_side (0 when nothing is visible or every visible triangle has zero UV area) and the
 * number of pairs in *npairs (may be NULL). */
int mf_budget_texel_side(const MfRtScene *rt, const MfMesh *mesh, const MfReconView *views, int nviews,
                         double *median_side, long *npairs);
/* The power of two nearest to side (in log2), clamped to [lo, hi] (lo, hi powers of two or
 * not: the result is clamped after rounding). side <= 0 gives hi (no information: the cap). */
int mf_budget_pow2_side(double side, int lo, int hi);

/* mask (T, T): 1 where a texel is hit (nearest texel of the hit's UV, repeat wrap) by a primary
 * ray through a pixel centre of one of the views, else 0. skip (may be NULL): views i with
 * skip[i] != 0 are not used. Returns the number of texels marked. */
size_t mf_budget_visible_texels(const MfRtScene *rt, const MfReconView *views, int nviews, const unsigned char *skip,
                                int T, unsigned char *mask);
/* cover (H, W), the env map's texels (row 0 = +z, mf_envmap.h): 1 where a texel lies within
 * `dilate` texels (the longitude wraps) of the mirror reflection, about the shading normal, of a
 * primary ray through a pixel centre of one of the views (skip as above), else 0: the directions
 * some view sees in a reflection. Returns the number of texels marked. */
size_t mf_budget_env_coverage(const MfRtScene *rt, const MfReconView *views, int nviews, const unsigned char *skip,
                              int W, int H, int dilate, unsigned char *cover);
/* Fraction of the texels with mask != 0 whose metallic (channel 2 of orm, (T*T, 3)) is above
 * thresh; 0 when the mask is empty. */
double mf_budget_metal_fraction(const float *orm, const unsigned char *mask, size_t ntex, float thresh);

/* env_res_auto. The full width at half maximum, in radians, of the reflected GGX lobe of a
 * roughness (alpha = rough^2): the half-vector distribution falls to half at tan(theta_h) =
 * alpha sqrt(sqrt(2) - 1), and a reflection doubles the angle: 4 atan(0.6436 alpha). */
double mf_budget_lobe_fwhm(float rough);
/* The env width the sharpest visible specular can use: *rough = the pct quantile (e.g. 0.1) of the
 * roughness (orm (T*T, 3) channel 1) over the texels with mask != 0 (-1 when none: then w_max);
 * a texel of 2 pi / W radians puts two texels across that lobe at W >= 4 pi / fwhm. Returns the
 * smallest w_max / 2^k (k >= 0) at or above that and at or above w_min, halving only while both
 * w_max / 2^k and h_max / 2^k stay even and the height at least 2 (so the height is
 * h_max * W / w_max, exact); -1 when out of memory. */
int mf_budget_env_width(const float *orm, const unsigned char *mask, size_t ntex, double pct, int w_max, int h_max,
                        int w_min, double *rough);

/* src (H, W, 3) -> dst (H / f, W / f, 3): each texel the mean of its f x f block (W, H multiples of f). */
void mf_budget_env_shrink(const float *src, int W, int H, int f, float *dst);

/* Early stopping: views with index % every == 0 are held out (0, every, 2*every, ...). */
static inline int mf_budget_is_holdout(int view, int every) { return every > 0 && view % every == 0; }

#define MF_BUDGET_CURVE_MAX 4096
typedef struct {
    double best;      /* best held-out PSNR so far (dB; -1 before the first evaluation) */
    int best_iter;    /* iteration of the best */
    int bad;          /* evaluations in a row without an improvement of more than min_delta */
    int stop_iter;    /* iteration the run stopped at (0: not stopped) */
    int n;            /* evaluations recorded */
    int iter[MF_BUDGET_CURVE_MAX];    /* (n,) iteration of each evaluation */
    double psnr[MF_BUDGET_CURVE_MAX]; /* (n,) its held-out PSNR */
} MfEarlyStop;

void mf_early_stop_init(MfEarlyStop *es);
/* Records the evaluation (iter, psnr); returns 1 when the run must stop: psnr has not exceeded
 * the best by more than min_delta for `patience` evaluations in a row (sets stop_iter). */
int mf_early_stop_observe(MfEarlyStop *es, int iter, double psnr, int patience, double min_delta);

/* What a run's budgets decided (mf_recon.c). The early-stop state and held-out curve
 * (borrowed; NULL without early_stop); the curve is also logged to RESULT/holdout.csv (iter,
 * wall_s, holdout_psnr); once stop_iter != 0 the run is over (a resumed stopped run does no
 * more iterations). */
const MfEarlyStop *mf_recon_early_stop(const MfRecon *r);
/* 1 when view i is held out of the loss (early_stop), else 0. */
int mf_recon_is_holdout(const MfRecon *r, int view);
/* metal_auto: -1 not tested (yet), 0 metallic kept, 1 fixed at 0; *fraction the measured
 * fraction of visible metallic texels (-1 before the test). */
int mf_recon_metal_state(const MfRecon *r, double *fraction);
/* tex_auto: the measured median side for 1 pixel per texel (0 when tex_auto is off). */
double mf_recon_texel_side(const MfRecon *r);
/* spp_grow: the training renders' spp_sqrt now, and the iterations it grew at (up to 16; *n their count). */
int mf_recon_spp_now(const MfRecon *r, const int **grew_at, int *n);
/* env_auto: the fraction of env texels some view sees in a reflection (-1 when env_auto is off). */
double mf_recon_env_covered(const MfRecon *r);
/* env_res_auto: the env width chosen (-1 before the choice); *rough (may be NULL) the roughness it
 * was chosen for. */
int mf_recon_env_res(const MfRecon *r, double *rough);

#endif
