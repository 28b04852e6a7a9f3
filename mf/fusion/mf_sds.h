/* mf_sds: MaterialFusion's SDS+ term (REFERENCE.md "MaterialFusion's SDS+ term"), as a method hook
 * of the shared inverse loop (mf/inverse/mf_recon.h).
 *
 * For each of the first K views of an iteration's batch:
 *   1. render the material AOVs (albedo kd, ORM) at the prior's resolution R from the view's
 *      camera (mf_diff_aov_forward, several primary rays per pixel);
 *   2. prepare them exactly as the prior was trained (DESIGN.md "Contracts"): albedo = sRGB(kd),
 *      ORM linear, each mapped to [-1, 1] and multiplied by the view's mask; condition = the view's
 *      reference image in sRGB, box-filtered to R, (2v - 1) x mask. Note: the official code feeds
 *      sRGB(kd (1 - m)), a quirk (the prior was trained on the undarkened base colour); we feed kd
 *      in both training and SDS;
 *   3. z = Enc(maps); t ~ U{t_min..t_max} (one t per batch: the K views go through the prior as
 *      one batch); zhat = guided DDIM from t over [t, .8t, .6t, .4t, .2t]
 *      (guidance 3.0) — the TARGETS;
 *   4. loss = gamma_i (lambda_latent mean((a (z - zhat))^2) + lambda_rgb mean((a D(zhat) - maps)^2)),
 *      means over elements; a = the mask at the matching resolution; gamma_i = 1 - (i/N)^p (or 1
 *      with gamma_const). With rgb01 (default) the RGB term is taken on maps in [0, 1] as the
 *      official code's textures are, i.e. mean(((a D(zhat) - maps) / 2)^2) of the [-1, 1] prior
 *      maps: lambda_rgb means what it means there (rgb01 = 0 is the first wave's 4x stronger term).
 * Views: when the batch has fewer than k_views views, the remaining ones are drawn from the other
 * training views (seeded by iteration), so K = 4 views get the prior term as in the paper.
 * Trust (weight): the term's texel gradient is applied as is (none), or with its component that
 * opposes the rest of the objective's gradient at that texel removed (conflict: per texel over its
 * channels, h -= min(0, <h, g>) g / |g|^2, g = the image and regulariser gradient of the iteration).
 * The prior can then move a texel only along directions the images do not contradict: where its
 * targets are biased (another renderer, another camera) the data term wins; where the images are
 * ambiguous (albedo vs light, roughness vs metallic) the prior still decides.
 * Or (coverage) the gradient of a texel seen by n training views is scaled by C0 / (C0 + n)
 * (MF_SDS_COVERAGE_C0): 4/5 where one view sees it, 1/2 at four views, 1/17 at 64 — the fewer
 * views constrain a texel, the more the prior decides. (The term renders from training cameras,
 * conditioned on their images, so a texel no training view sees gets no prior gradient at all.) "Seen" = the texel gets weight from a view's primary hits
 * (mf_diff_aov_backward of an all-ones image at the view's resolution, one ray per pixel), counted
 * once when the term is first applied.
 * Or (spread, needs draws >= 2) each element of the loss — latent, albedo map, ORM map — is weighted
 * by how much the prior's targets agree over the noise draws (the same t and views, other noise):
 * w = 1 / (1 + var / var_ref), var = the element's sample variance over the draws, var_ref = the
 * mean variance over the masked elements of its group (latents, albedo maps, ORM maps), then w is
 * scaled to mean 1 over those elements (mf_sds_spread_weights): the term keeps its strength and
 * moves it to the pixels where the prior is sure. With draws > 1 the targets are the draws' mean.
 * Or (views, needs target mean) each texel's gradient is weighted by how much the training views'
 * held targets agree there: every view's target maps (albedo as sRGB, ORM; in [0, 1]) are spread onto
 * the texels its pixel-centre rays at R hit (the AOV adjoint over the object's pixels), normalised
 * to the view's mean value per texel; over the n >= 2 views that see a texel the variance of those
 * means, averaged over the channels (albedo: 3; ORM: roughness and metallic), gives
 * w = 1 / (1 + var / var_ref), var_ref = the mean variance over such texels, then w is scaled to mean
 * 1 over them (mf_sds_agreement_weights); texels fewer than 2 views see keep 1. Computed once,
 * when the term is first applied (all training views' targets are made then); the log states the
 * mean cross-view variances, a measure of how consistent the prior is on this object.
 * Channel trust (trust_rough, trust_metal, in [0, 1], default 1 = the paper): the held ORM gradient's
 * roughness and metallic channels are scaled by these factors before the weighting above — the
 * prior's reliability per channel as measured on a validation split by `mf eval-prior`
 * (ev_prior2d_trust: 1 - its MSE over a constant training-mean predictor's), so a channel the
 * prior predicts no better than a constant gets no pull. Albedo and occlusion are not scaled.
 * Targets (target): ddim (the paper) as in 3. above; or mean: the prior's own prediction for the
 * view from pure noise, the mean over mean_samples samples of mean_steps guided DDIM steps (latents
 * and decoded maps averaged; with spread weighting their variances over the samples replace the
 * draws'), computed the first time a view is picked and then held for the whole run (seeded by the
 * view, so --resume stays exact). It does not depend on the current textures: the loss pulls them
 * toward what the prior predicts from the image alone, the term a 2D evaluation of the prior
 * (`mf eval-prior`) scores, instead of a denoising of the current estimate.
 * Multi-view (mv): the prior's views attend jointly, as StableMaterialMV (`mf eval-prior`'s MV row):
 * with ddim targets the K views of a step are denoised as one object; with mean targets each view's
 * prediction is made jointly with the other views of its group — the training views in order, in
 * groups of MF_SDS_MV_VIEWS (mf_sds_mv_group) — and the whole group is held at once.
 * zhat and D(zhat) are held constant (classic SDS): the latent term back-propagates through the
 * encoder into the maps, the RGB term directly into the maps (as the official code), then through
 * the AOV render into the kd / ORM texels. (The official code also lets zhat depend on z through
 * the noising; we do not — stated choice.) SDS changes materials only, never the light. */
#ifndef MF_SDS_H
#define MF_SDS_H

#include <stdint.h>

#include "inverse/mf_recon.h"
#include "prior/mf_prior.h"

/* Defaults, ranges and docs: the option table in mf_sds_opts.c (the only place they are written;
 * a new field is one line there, which also gives it its flag, config key, help and run.json). */
typedef struct {
    int k_views;         /* views per batch that get the prior term */
    float lambda_latent; /* latent term weight */
    float lambda_rgb;    /* RGB term weight */
    float gamma_p;       /* gamma_i = 1 - (i/N)^p */
    int gamma_const;     /* 1: gamma_i = 1 throughout */
    float guidance;      /* classifier-free guidance scale */
    int t_min, t_max;    /* timestep range */
    int aov_samples;     /* primary rays per pixel of the AOV render */
    uint64_t seed;
    int every;           /* the term (prior work: render, encode, guided DDIM, decode, encoder
                            backward) is computed every `every` iterations and at checkpoint
                            multiples; its texel gradient is held and applied (times gamma_i) at
                            every iteration in between (measured default: mf_sds_opts.c); 0: auto,
                            mf_sds_every_auto of the first view's size, fixed at the first hook call. */
    int rgb01;           /* 1: L_rgb on [0, 1] maps (official code); 0: on the prior's [-1, 1] maps (4x) */
    int weight;          /* MF_SDS_WEIGHT_NONE, _CONFLICT, _COVERAGE, _SPREAD or _VIEWS (trust, see above) */
    int draws;           /* noise draws per target at the batch's t: the target is their mean (1: the paper) */
    int prior_threads;   /* OpenBLAS threads set by mf_sds_new (0: left as they are) */
    float trust_rough;   /* channel trust (see above) of the ORM gradient's roughness channel, [0, 1] */
    float trust_metal;   /* ... and of its metallic channel */
    int target;          /* MF_SDS_TARGET_DDIM (the paper) or _MEAN (see "Targets" above) */
    int mean_samples;    /* mean targets: samples averaged per view */
    int mean_steps;      /* mean targets: DDIM steps per sample */
    int mv;              /* 1: the prior's views attend jointly (StableMaterialMV; see "Multi-view" above) */
} MfSdsOpts;

enum { MF_SDS_TARGET_DDIM = 0, MF_SDS_TARGET_MEAN = 1 }; /* "ddim|mean" */

enum {
    MF_SDS_WEIGHT_NONE = 0,
    MF_SDS_WEIGHT_CONFLICT = 1,
    MF_SDS_WEIGHT_COVERAGE = 2,
    MF_SDS_WEIGHT_SPREAD = 3,
    MF_SDS_WEIGHT_VIEWS = 4
}; /* "none|conflict|coverage|spread|views" */
/* coverage: a texel seen by n training views gets the weight C0 / (C0 + n) (1 where no view sees it) */
#define MF_SDS_COVERAGE_C0 4.0f
#define MF_SDS_MAX_DRAWS 8 /* the largest draws */
#define MF_SDS_MV_VIEWS 4  /* views per object of a multi-view group (the prior's StableMaterialMV) */

MfSdsOpts mf_sds_opts_default(void);

typedef struct MfSds MfSds;

/* Takes ownership of prior. */
int mf_sds_new(MfPrior *prior, const MfSdsOpts *o, MfSds **out);
/* --sds-every 0 for w x h training images: the prior's work per refresh does not depend on the
 * images' size, the renderer's per iteration grows with their pixels, so the interval keeps the
 * prior's share of the time it has at 128 x 128 (4): ceil(4 * 128^2 / (w h)), at least 4. */
int mf_sds_every_auto(int w, int h);
/* The refresh interval in use (the resolved one once the hook has run; 0 before, when auto). */
int mf_sds_every(const MfSds *s);
void mf_sds_free(MfSds *s);
/* Wall seconds this process spent in the prior's work (the refreshes: AOV render, encode, guided
 * DDIM, decode, encoder backward), for the cost report. */
double mf_sds_seconds(const MfSds *s);
/* The same work by stage, wall and CPU seconds over the run (the cost report's split of the hook). */
typedef struct {
    MfStageTime cond;     /* the views' condition images, masks and cameras at the prior's resolution */
    MfStageTime aov;      /* the material AOV render and the maps prepared from it */
    MfStageTime encode;   /* Enc(maps) */
    MfStageTime denoise;  /* noising and the guided DDIM steps (with the condition image's encode) */
    MfStageTime decode;   /* D(zhat) */
    MfStageTime loss;     /* the loss and its gradient w.r.t. the latents and maps */
    MfStageTime enc_bwd;  /* the gradient back through the encoder */
    MfStageTime aov_bwd;  /* the gradient back through the AOV render into the texels */
    MfStageTime apply;    /* every iteration: the held gradient (weighted) added to the texels' */
} MfSdsTimes;
void mf_sds_times(const MfSds *s, MfSdsTimes *t);
/* Coverage weights (texels,) of r's training views (see "coverage" above): *out owned by the
 * caller, *ntex = texels of the kd texture. */
int mf_sds_coverage(MfRecon *r, float **out, size_t *ntex);
/* The hook for mf_recon_run: ctx is an MfSds. */
int mf_sds_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss);

/* --sds-mv with mean targets: the group of the p-th of ntrain training views (in view order):
 * views [start, start + size) are denoised together (size = min(ntrain, MF_SDS_MV_VIEWS)), and those
 * from own_from on take their targets from it. Groups of size consecutive views; when ntrain is
 * not a multiple of size, the last size views form a group that owns only the remainder. */
void mf_sds_mv_group(int ntrain, int p, int *start, int *size, int *own_from);

/* Pieces, exposed for the chain's gradient check. The K views of an iteration are processed as one
 * batch through the prior (one timestep t per batch, drawn from U{t_min..t_max}). Targets: zhat
 * and D(zhat) held fixed; condition and mask come from the views' reference images. */
#define MF_SDS_MAX_VIEWS 16
typedef struct {
    int n;           /* views */
    int t;           /* timestep of the batch */
    float *zhat;     /* (n, 2zc, h, h) owned */
    float *dhat;     /* (2, n, 3, R, R) owned: decoded albedo maps, then ORM maps */
    float *cond;     /* (n, 3, R, R) owned */
    float *mask;     /* (n, R, R) owned */
    float *zvar;     /* (n, 2zc, h, h) owned: sample variance of zhat over the draws; NULL with 1 draw */
    float *dvar;     /* (2, n, 3, R, R) owned: the same of D(zhat); NULL with 1 draw */
    MfCamera cam[MF_SDS_MAX_VIEWS];     /* the views' cameras at R x R */
    uint64_t aov_seed[MF_SDS_MAX_VIEWS]; /* seeds of the AOV renders (the loss re-renders the same hits) */
} MfSdsTargets;

/* Views weights (see "views" above): w (nt,) from the per-texel sums over the views of the view
 * means, sum and sum2 (nt, 3), the views that see each texel nv (nt,), channels [c0, c1);
 * *mean_var = var_ref. */
void mf_sds_agreement_weights(const double *sum, const double *sum2, const float *nv, size_t nt, int c0, int c1,
                              float *w, double *mean_var);
/* Spread weights (see "spread" above): w (n,) from the variances var (n,) and the elements' masks
 * m (n,) in [0, 1] (weight only where m > 0; w = 1 elsewhere, and everywhere when no masked
 * element varies). */
void mf_sds_spread_weights(const float *var, const float *m, size_t n, float *w);
int mf_sds_targets(MfSds *s, MfRecon *r, const int *views, int n, int it, MfSdsTargets *t);
void mf_sds_targets_free(MfSdsTargets *t);
/* Loss against fixed targets (without gamma; means over all elements of the batch); when grads is
 * non-zero, adds scale * dLoss/d(texels) into the kd and ORM blocks' gradients. */
int mf_sds_loss(MfSds *s, MfRecon *r, const MfSdsTargets *t, float scale, int grads, double *loss);
/* The views of iteration it that get the prior term (the hook's choice): batch's first k_views,
 * then distinct other views drawn at random (seeded by it; never early_stop's held-out views).
 * views (MF_SDS_MAX_VIEWS); returns count. */
int mf_sds_pick_views(const MfSds *s, MfRecon *r, int it, const int *batch, int nb, int *views);

#endif
