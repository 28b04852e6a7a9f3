/* mf_geom_fit: the mask term of DMTet geometry optimisation (issue 14, pass 1 core).
 *
 * The unknowns are an SDF (nv,) on an mf_tetgrid grid and optionally its deformation (nv, 3).
 * One evaluation: marching tets (mf_tetgrid_extract) -> Embree scene of the mesh -> per view a
 * pixel-centre coverage pass, antialiased (render/mf_antialias.h, the operation that
 * MfDiffOpts.antialias applies to the renderer's alpha) -> mask loss
 *   L_mask = mean over the views' pixels of (antialiased coverage - target mask)^2
 * -> dL/dalpha -> mf_aa_backward -> dL/dpos of the mesh vertices -> mf_tetgrid_backward ->
 * dL/dsdf, dL/ddeform. Only silhouette edges (outer and inner occlusion edges) receive gradient;
 * shading and materials take no part (coverage needs no normals).
 * Regulariser (nvdiffrec's sdf_reg_loss): over the tet edges (v, v + e), e in {0,1}^3 \ {0},
 * whose ends differ in sign,
 *   L_reg = mean of BCE(sigmoid(s_a), [s_b > 0]) + BCE(sigmoid(s_b), [s_a > 0]),
 * which penalises sign changes (floaters, noise) and keeps the values near the surface small.
 * Colour term (MfGeomFitOpts.color > 0; DMTet's pass 1 with its image loss): the extracted mesh is
 * rendered by the differentiable renderer (render/mf_diffrender.h, antialiased, 1 pixel-centre
 * sample, spp_sqrt 1) with kd and ORM from dense volume textures (scene/mf_voltex.h,
 * MF_GEOM_VOL_RES^3 over the grid's box) under an MF_GEOM_ENV_W x MF_GEOM_ENV_W/2 env map, all
 * three optimised beside the SDF and thrown away after the fit (pass 2 re-estimates materials
 * and light on the unwrapped mesh). Per view
 *   L = color * logl1(rgb, reference rgb premultiplied by its alpha) + (alpha - mask)^2 (means),
 * so silhouettes, inner occlusion edges (antialiasing) and shading (through each hit's position,
 * normal and volume lookup: mf_hitgrad.h) move the surface: concavities the masks cannot see
 * (a cup's inside) get a gradient. Initial state: kd 0.5, roughness 0.5, metallic 0, occlusion
 * 1 (frozen), a constant env of twice the references' mean masked radiance (a diffuse albedo-0.5
 * surface under it matches that mean). Learning rates: SDF lr_sdf, volumes MF_GEOM_LR_MAT per
 * step, env MF_GEOM_LR_ENV x its initial level per step, all with the SDF's decay.
 * Deterministic for a given thread count: the per-view passes are serial, the Embree queries
 * of each pass are parallel but write disjoint pixels (the renderer's gradients are reduced in
 * lane order). */
#ifndef MF_GEOM_FIT_H
#define MF_GEOM_FIT_H

#include <stdint.h>

#include "geom/mf_tetgrid.h"
#include "io/mf_image.h"
#include "scene/mf_camera.h"

/* Mask loss and its gradient for views views[0..nviews) of cams/masks (masks: images whose last
 * channel is the target alpha, of the camera's size). dsdf (nv,) and, when deform and ddeform
 * are non-NULL, ddeform (nv, 3) are ACCUMULATED (+=); *loss = L_mask; *nt (if not NULL) = the
 * extracted mesh's triangles; *rebuild_s (if not NULL) = wall seconds of the extraction and the
 * Embree scene build. Fails with MF_EARG ("... no zero crossing (empty grid)") when the
 * SDF has no surface, MF_ENAN on a non-finite value, MF_EARG on a mask of the wrong size;
 * dsdf/ddeform untouched on failure. */
int mf_geom_mask_grad(const MfTetGrid *g, const float *sdf, const float *deform, const MfCamera *cams,
                      const MfImage *masks, const int *views, int nviews, float *dsdf, float *ddeform, double *loss,
                      int *nt, double *rebuild_s);

/* Sign-change regulariser: returns weight * L_reg and adds weight * dL_reg/dsdf to dsdf (nv,)
 * (if not NULL). 0 when no edge changes sign. */
double mf_geom_sdf_reg(const MfTetGrid *g, const float *sdf, float weight, float *dsdf);

typedef struct {
    int iters;          /* Adam steps (>= 1) */
    float lr_sdf;       /* Adam learning rate of the SDF (world units per step, roughly) */
    float lr_deform;    /* of the deformation (tanh space); 0: the deformation is not optimised */
    float sdf_reg;      /* weight of the sign-change regulariser (0: off) */
    int views_per_step; /* views per step, taken in turn (0: all) */
    float color;        /* weight of the colour term (0: mask term only; > 0 needs RGBA references) */
    uint64_t seed;      /* the colour term's Monte Carlo samples */
    int start;          /* the caller's code for where sdf came from (checked on resume like the options) */
    const char *state;  /* NULL: no checkpoints; else the fit's state file (below) */
    int state_every;    /* steps between state files (the last step always writes one) */
    int resume;         /* 1: continue from the state file when it exists */
    int *resumed;       /* output, may be NULL: the steps a resumed state held (0: started afresh) */
} MfGeomFitOpts;

#define MF_GEOM_VOL_RES 32
#define MF_GEOM_ENV_W 32
#define MF_GEOM_LR_MAT 0.005f
#define MF_GEOM_LR_ENV 0.005f

/* Per-step record. */
typedef struct {
    double rgb;  /* colour term's logl1 (unweighted) of the step's views, before the step; 0 without it */
    double mask; /* L_mask of the step's views, before the step */
    double reg;  /* weighted L_reg, before the step */
    int nt;      /* triangles of the extracted mesh */
    double rebuild_s; /* wall s of the step's extraction and Embree build (a timing: 0 in rows a resumed
                         fit read from its state file, which does not keep it) */
} MfGeomFitStep;

/* The state file (opt->state; an MFCK checkpoint, io/mf_ckpt.h, written atomically): every block's
 * values and Adam moments, Adam's step count, the steps done, the options that shape the steps
 * (learning rates, regulariser, views per step, colour weight, seed, start) and the log rows so far in
 * its meta. Every step depends on the step index, not on opt->iters, so a fit stopped at step k
 * and resumed from its state reaches the bytes of an uninterrupted one (same build and thread
 * count), also when the resumed run asks for more steps. A state whose grid size or options
 * differ, or with more steps done than opt->iters, is refused (MF_EARG naming the file and what
 * differs); one that does not read is an error too, never silently ignored. */

/* Runs opt->iters Adam steps on sdf (nv,) and, when deform is non-NULL and lr_deform > 0, deform
 * (nv, 3), both updated in place; with opt->color > 0 the colour term's unknowns too (above;
 * masks must then be RGBA: linear colour, straight alpha). log: (opt->iters,) or NULL; *done (if not NULL) = steps taken.
 * On failure (an empty extraction, a non-finite gradient) sdf and deform keep the values of the
 * last completed step, *done says how many, and the message names the step. */
int mf_geom_fit(const MfTetGrid *g, float *sdf, float *deform, const MfCamera *cams, const MfImage *masks, int n,
                const MfGeomFitOpts *opt, MfGeomFitStep *log, int *done);

#endif
