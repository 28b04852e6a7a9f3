/* mf_recon: the shared inverse-rendering loop (nvdiffrecmc's second pass on a given mesh).
 *
 * Recovers, for a fixed triangle mesh with UVs, an albedo texture kd (th, tw, 3), an ORM
 * texture (th, tw, 3) and an HDR environment map (eh, ew, 3, Blender mapping) from posed RGBA
 * views under one unknown light. Each iteration:
 *   1. lr = lr0 * 10^(-0.0002 it) (light: x light_lr_scale);
 *   2. a batch of views (a per-epoch random permutation, seeded);
 *   3. per view: forward render (mf_diff_forward, seed A) at the view's resolution, composite
 *      render and reference over the same uniform-noise background, image loss = logl1 (+ alpha
 *      MSE, reported: with a fixed mesh it has no material gradient), shading regulariser on the
 *      demodulated light; adjoint render (seed B != A: decorrelated) accumulates the gradients;
 *      with `denoise` the diffuse and specular light are first filtered by nvdiffrecmc's
 *      bilateral denoiser (G-buffer guides of the forward pass) and recombined as
 *      rgb = kd (1 - m) F(diffuse) + F(specular) (mf_denoise.h); the loss and the shading
 *      regulariser see the denoised values, their adjoints pass through F^T into the renderer's
 *      per-pixel diffuse/specular adjoints, and into kd / metallic through the per-pixel
 *      material AOVs (mf_diff_aov_backward, same seed A: same hits with one pixel sample).
 *      In nvdiffrecmc kd's adjoint is drgb F(diffuse) with the PRIMAL's light, correlated with
 *      the image error it multiplies (biased in a non-linear loss); with denoise_decorrelate
 *      (default) that light comes from a third, independent render (seed C) through the same
 *      filter, at the cost of one more forward render (docs/analyses/baseline-denoiser.md);
 *   4. texel smoothness regularisers on kd and ORM (G, B) over the texels the mesh's UVs use
 *      (with a normal map: its smoothness and its perturbation from flat, too);
 *   5. the method hook (MaterialFusion's SDS+ term) may add loss and gradients;
 *   6. Adam step with bounds: kd in [0,1], ORM R = 1 (frozen), G in [0.08,1], B in [0,1],
 *      light >= 0.01 (in the exposure's working units, below), normal-map texels in [0,1] (initialised flat, (0.5, 0.5, 1)). A non-finite gradient is an event of the guard
 *      below (recover, or stop with the last good checkpoint kept and no texture written from
 *      the bad state);
 *   7. with vertex_lr > 0 (issue 14's pass 2 moving the mesh; mf recon's default on a recovered
 *      mesh, mf_recon_geom_vertex_lr; a given mesh stays fixed): the renderer's
 *      vertex gradient (MfDiffGrads.dpos: the hits' positions, UVs and interpolated normals) is
 *      gathered onto the mesh's vertices welded across its UV seams, the uniform Laplacian
 *      (mf_reg_laplacian, weight vertex_laplacian x (1 - it / iters) / welded vertices, as
 *      nvdiffrecmc's 3000 x (1 - t)) is added, and a separate Adam (vertex_lr, the textures'
 *      decay) moves them; normals are recomputed on the welded mesh and the Embree scene rebuilt.
 *      The result's mesh.obj/scene.glb are the moved mesh. Checkpoints hold the welded positions
 *      and their moments (tensor "pos", header "vertex_adam_t"), so a resumed run reaches the
 *      uninterrupted run's bytes; they are not in the guard's last good state (a recovery rolls
 *      back the textures and light only); no normal map (refused).
 * Guard (mf_optim.h): after the loss of an iteration is known and again after the Adam step, the
 * run checks for (a) a non-finite loss, (b) divergence: the loss above div_factor (default 4) x
 * its running minimum for div_patience (default 10) iterations in a row, (c) a non-finite
 * gradient, value or Adam moment (a gradient beyond ~1.8e19 overflows the second moment to +Inf).
 * On any of them it restores the last good state (values, moments and Adam's step count of the
 * iteration with the lowest loss so far, or the starting state), multiplies the learning rate by
 * MF_RECON_RECOVERY_LR (0.1) from then on, logs a warning and records {iter, reason, lr_scale}
 * (mf_recon_recoveries; mf recon writes them into run.json). After max_recoveries (default 4)
 * the next event stops the run with an error naming it; checkpoints already written are kept
 * and the in-memory state returns to the last good one (nothing is written from the bad one).
 * Normal runs stay far from the threshold (tiny scenes: loss at most 4.4x the running minimum,
 * above 4x for 1 iteration in a row). A checkpoint is never written with a non-finite value, and
 * a checkpoint holding one is refused on resume, naming the tensor ("kd.v[12] = inf"). The
 * learning-rate scale and the running minimum are stored in the checkpoint, so a resumed run
 * goes on with them.
 * Parameter blocks are kept in an array (MF_BLOCK_*) so a geometry block can join later
 * without changing the loop. Determinism: every random choice derives from (seed, iteration,
 * view), so a run resumed from a checkpoint reaches the same bytes as an uninterrupted run
 * (same build and thread count).
 *
 * Outputs (mf_recon_run / mf_recon_write_result) follow DESIGN.md's result folder: albedo.png
 * (sRGB), orm.png (linear, R = 1), normal.png (8-bit linear, glTF tangent space; only with
 * normal_map), env.exr, mesh.obj (+ mesh.mtl), scene.glb, log.csv
 * (iter, wall_s, loss_total, loss_image, loss_reg, loss_sds, train_psnr), snapshots/iter_NNNNN/
 * (albedo.png, orm.png, env.exr every snapshot_every iterations) and checkpoint.mfck.
 *
 * Budgets from the data (mf_budget.h; each off by default): early_stop holds views out of step 2's
 * permutation and ends the run on their PSNR (holdout.csv; the checkpoint is written at the stop);
 * metal_auto sets ORM B to 0 and freezes it after metal_warmup iterations when the scene shows no
 * metal (the decision is stored in the checkpoint); tex_auto picks tex_res in mf_recon_new; env_auto
 * finds there the env directions the training views see in a reflection and regularises the others
 * toward their neighbours every iteration; env_res_auto shrinks the env map (box-averaging its values
 * and Adam moments) after env_res_warmup iterations to the width the sharpest visible specular lobe
 * resolves (the size is in the checkpoint, which resumes at it); spp_grow raises the training renders'
 * samples per pixel when the image loss stops falling (the level and its window are in the checkpoint). */
#ifndef MF_RECON_H
#define MF_RECON_H

#include <stdint.h>

#include "core/mf_log.h"
#include "inverse/mf_optim.h"
#include "io/mf_image.h"
#include "render/mf_integrator.h"
#include "scene/mf_camera.h"
#include "scene/mf_envmap.h"
#include "scene/mf_mesh.h"

/* MF_BLOCK_NORMAL exists only with opts.normal_map (otherwise its block is empty: n = 0). */
typedef enum { MF_BLOCK_KD = 0, MF_BLOCK_ORM = 1, MF_BLOCK_ENV = 2, MF_BLOCK_NORMAL = 3, MF_NBLOCKS = 4 } MfBlockId;

typedef struct {
    MfCamera cam; /* at the resolution of ref */
    MfImage ref;  /* owned; (h, w, 4) linear: rgb premultiplied by alpha, then alpha */
} MfReconView;

typedef struct {
    int iters;            /* total iterations */
    int batch;            /* views per iteration */
    int spp_sqrt;         /* n: n^2 light + n^2 BSDF samples per pixel sample */
    int pixel_samples;    /* primary rays per pixel */
    int tex_res;          /* kd / ORM texture side */
    int env_w, env_h;     /* env map size */
    float lr;             /* textures' learning rate (nvdiffrecmc pass 2: 0.005; see defaults) */
    float light_lr_scale; /* x lr for the env map (nvdiffrecmc: 3) */
    float w_kd_smooth;    /* albedo smoothness weight */
    float w_orm_smooth;   /* ORM smoothness weight */
    float w_env_tv;       /* env log-radiance total variation weight (mf_reg_env_logtv; 0: off) */
    float w_shading;      /* white-light shading regulariser weight */
    float w_spec_ratio;   /* mean(spec) / mean(diffuse) weight inside the shading term */
    float loss_floor;     /* added to render and image before logl1's curve, in the loop's units (the
                             views / 2^k near their mean): caps the weight of near-black pixels (mf_loss.h) */
    int normal_map;       /* 1: optimise a tangent-space normal map (tex_res^2, MF_BLOCK_NORMAL);
                             default 0 (measured to lower relighting quality on GT meshes) */
    float w_nrm_perturb;  /* normal-map perturbation weight (L1 from flat; nvdiffrecmc 0.25) */
    float w_nrm_smooth;   /* normal-map smoothness weight (nvdiffrecmc 0.025) */
    float vertex_lr;      /* > 0: the mesh's vertices move too (Adam at this rate on the positions welded
                             across UV seams; normals follow; Embree rebuilt every step); 0: fixed.
                             Positions are checkpointed; no normal map. -1 (the default): the caller's
                             to resolve (mf recon: mf_recon_geom_vertex_lr); mf_recon_new takes it as 0 */
    float vertex_laplacian; /* the moving vertices' uniform Laplacian weight, x (1 - it / iters) / vertices */
    int normal_smooth;    /* > 0: the shading normals are the welded mesh's area-weighted normals smoothed
                             over this many 1-rings (mf_mesh_smooth_normals, neighbours within
                             MF_RECON_NORMAL_SMOOTH_MIN_COS), recomputed as the vertices move and
                             differentiated; 0: the mesh's own normals (fixed vertices) or its
                             area-weighted ones (moving). -1 (the default): the caller's to resolve (mf
                             recon: mf_recon_geom_normal_smooth); mf_recon_new takes it as 0 */
    float init_kd, init_rough, init_metal, init_light;
    int denoise;          /* 1: bilateral denoiser of the demodulated light (mf_denoise.h) */
    float denoise_sigma;  /* its spatial sigma in pixels (nvdiffrecmc: 2, 23x23 window) */
    int denoise_decorrelate; /* 1: kd's adjoint uses the denoised light of an independent render */
    float div_factor;     /* divergence: loss above div_factor x its running minimum ... */
    int div_patience;     /* ... for div_patience iterations in a row (see "Guard" above) */
    int max_recoveries;   /* recoveries before the run stops with an error (0: stop at once) */
    int snapshot_every;   /* 0: none */
    int checkpoint_every; /* 0: only at the end */
    uint64_t seed;
    /* budgets from the data (mf_budget.h; each off by default) */
    int early_stop;       /* 1: hold out views (holdout_every) and stop on their PSNR */
    int holdout_every;    /* views 0, N, 2N, ... are held out of the loss with early_stop */
    int es_every;         /* held-out evaluation period (iterations) */
    int es_pixel_samples; /* primary rays per pixel of the held-out renders */
    int es_patience;      /* evaluations without improvement before stopping */
    float es_min_delta;   /* dB an evaluation must beat the best by to count as improvement */
    int metal_auto;       /* 1: after metal_warmup iterations, freeze metallic at 0 when ... */
    int metal_warmup;     /* ... the fraction of visible texels with metallic > 0.5 ... */
    float metal_frac;     /* ... is below this */
    int tex_auto;         /* 1: tex_res from the views' texel density (power of two, clamped) */
    int tex_auto_min, tex_auto_max;
    int env_auto;         /* 1: env texels no view sees in a reflection are regularised toward their neighbours */
    int env_auto_dilate;  /* ... coverage dilated by this many texels ... */
    float w_env_unseen;   /* ... with this weight (mf_reg_env_unseen) */
    int env_res_auto;     /* 1: after env_res_warmup iterations the env map shrinks to what the sharpest
                             visible specular resolves (mf_budget_env_width), not below env_res_min wide */
    int env_res_warmup, env_res_min;
    int spp_grow;         /* 1: spp_sqrt grows by 1 (up to spp_grow_max) whenever the image loss's mean over a
                             window of spp_grow_window iterations fell by less than spp_grow_tol of the previous one */
    int spp_grow_max, spp_grow_window;
    float spp_grow_tol;
} MfReconOpts;

/* The defaults, from the option table (mf_recon_opts.c: defaults, ranges and docs are written there). */
MfReconOpts mf_recon_opts_default(void);

typedef struct MfRecon MfRecon;

/* Method hook (MaterialFusion): called once per iteration after the image terms; adds its
 * gradients into the blocks' g arrays and returns its loss in *loss. */
typedef struct {
    int (*fn)(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss);
    void *ctx;
} MfReconHook;

/* On success takes the views' reference images (views[i].ref is moved: the caller's copy is
 * zeroed; the views array itself stays the caller's); on failure views are untouched. Borrows
 * mesh (must have UVs; must outlive r). */
int mf_recon_new(const MfMesh *mesh, MfReconView *views, int nviews, const MfReconOpts *opts, MfRecon **out);
void mf_recon_free(MfRecon *r);

/* Restores parameters, Adam state and the iteration count from a checkpoint written by a run
 * with the same options (texture/env sizes are checked). */
int mf_recon_load_checkpoint(MfRecon *r, const char *path);
/* Runs iterations from the current one to opts.iters, writing log.csv / snapshots /
 * checkpoints under out_dir (appending to log.csv when resuming). prog may be NULL. */
int mf_recon_run(MfRecon *r, const MfReconHook *hook, const char *out_dir);
/* Writes albedo.png, orm.png (normal.png), env.exr, mesh.obj (+mtl), scene.glb into dir. */
int mf_recon_write_result(const MfRecon *r, const char *dir);

/* Exposure (mf_recon_new): the views' mean linear radiance over pixels with alpha > 0.5, m, sets
 * the working scale E = 2^round(log2(m / MF_RECON_EXPOSURE_REF)); the loop works on the views
 * divided by E, so init_light, the env's 0.01 floor and Adam's absolute steps are relative to
 * the images' level (within half a stop of MF_RECON_EXPOSURE_REF) instead of absolute. env.exr
 * (and snapshots) are written multiplied by E, in the views' units; the env block, the env map
 * of mf_recon_env and the checkpoint hold the working units. A power of two divides exactly, so
 * float views scaled by 2^k give the same optimisation bit for bit, and views already near the
 * reference level (E = 1) are not changed at all. Black views: E = 1. The reference 0.25 is the
 * level the default start renders at (albedo 0.5 under light 0.5 gives a diffuse surface about
 * 0.25); measured means: tiny/000_cup 0.20 (E = 1), tiny/001_vase 0.68 (E = 2), tiny/002_bottle
 * 0.050 (E = 1/4), the sphere of tests/test_inverse_recon.c 0.33 (E = 1). */
#define MF_RECON_EXPOSURE_REF 0.25f
/* normal_smooth keeps a neighbour's normal only within 15 degrees of the vertex's own, so creases
 * (a box's edges, a clock's rim) stay sharp (docs/analyses/normal-smoothing.md) */
#define MF_RECON_NORMAL_SMOOTH_MIN_COS 0.9659258f
/* E for views (their ref images); mean (may be NULL) receives m. */
float mf_recon_exposure_of(const MfReconView *views, int nviews, double *mean);
/* E of this run. */
float mf_recon_exposure(const MfRecon *r);

/* Learning-rate multiplier after each recovery (see "Guard"). */
#define MF_RECON_RECOVERY_LR 0.1f

/* One recovery of the guard. */
typedef struct {
    int iter;         /* the iteration whose check failed (0-based, as the hook's it) */
    char reason[192]; /* e.g. "loss 12.3 above 4 x its running minimum 0.031 for 10 iterations" */
    float lr_scale;   /* learning-rate multiplier from then on */
} MfReconRecovery;

/* The recoveries of this process's run (borrowed; n receives their count; at most 64 kept). */
const MfReconRecovery *mf_recon_recoveries(const MfRecon *r, int *n);
/* The current learning-rate multiplier (1 until a recovery; restored from a checkpoint). */
float mf_recon_lr_scale(const MfRecon *r);

/* Accessors for hooks and tests (those of the budgets are in mf_budget.h). */

int mf_recon_iteration(const MfRecon *r);
MfParamBlock *mf_recon_block(MfRecon *r, MfBlockId id);
const MfReconOpts *mf_recon_opts(const MfRecon *r);
const MfReconView *mf_recon_view(const MfRecon *r, int i);
int mf_recon_nviews(const MfRecon *r);
const MfMesh *mf_recon_mesh(const MfRecon *r);
const MfRtScene *mf_recon_rtscene(const MfRecon *r);
/* Texture images viewing the current parameters (borrowed; valid until the next step). */
MfImage mf_recon_kd_image(const MfRecon *r);
MfImage mf_recon_orm_image(const MfRecon *r);
MfImage mf_recon_normal_image(const MfRecon *r); /* data NULL without normal_map */
const MfEnvMap *mf_recon_env(const MfRecon *r);
/* Seconds spent in the primal (forward) and adjoint renders by this process. */
void mf_recon_timing(const MfRecon *r, double *forward_s, double *adjoint_s);
/* Wall and CPU seconds of this process's mf_recon_run, by stage (disjoint; the cost report's split). */
typedef struct {
    MfStageTime views;  /* the image term of the batch's views: env sync, render, loss, adjoint */
    MfStageTime reg;    /* the texture regularisers */
    MfStageTime hook;   /* the method hook (MaterialFusion: the prior term, mf_sds_times splits it) */
    MfStageTime step;   /* the divergence guard, the last-good snapshot, Adam */
    MfStageTime io;     /* log rows, snapshots, checkpoints */
    MfStageTime checks; /* metal_auto's test, early_stop's held-out renders */
    MfStageTime output; /* the result files at the end */
} MfReconTimes;
void mf_recon_times(const MfRecon *r, MfReconTimes *t);
/* Peak resident set size of this process in bytes (from getrusage). */
long mf_peak_rss_bytes(void);

#endif
