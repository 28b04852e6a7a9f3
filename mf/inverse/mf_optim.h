/* mf_optim: parameter blocks and the Adam optimiser of the inverse pipeline.
 *
 * Every optimised quantity (kd texture, ORM texture, normal map, env map, and later a geometry
 * block) is an MfParamBlock: a flat float array with its gradient accumulator, Adam moments, a
 * learning-rate multiplier (nvdiffrecmc: light at 3x) and per-channel box constraints applied
 * after each step (kd in [0,1], roughness in [0.08,1], metallic in [0,1], light >= 0.01). A
 * channel whose lower and upper bound are equal is frozen (ORM's occlusion R = 1).
 * Learning-rate schedule as nvdiffrecmc: lr(it) = lr0 * 10^(-0.0002 it).
 * Adam (Kingma & Ba) with bias correction; betas (0.9, 0.999), eps 1e-8 as torch's default.
 * Steps refuse non-finite gradients (MF_ENAN, naming the block and element) and leave the
 * parameters untouched, so the caller can stop and keep the last good checkpoint.
 *
 * Guarding a run (used by mf_recon): mf_params_find_nonfinite scans values and both moments
 * (a gradient beyond ~1.8e19 overflows g^2 in the second moment to +Inf and freezes the
 * element); MfDivGuard watches the loss for divergence (not finite, or above `factor` times its
 * running minimum for `patience` iterations in a row); MfParamSnapshot keeps the last good
 * state (values, moments, Adam's step count) to go back to. */
#ifndef MF_OPTIM_H
#define MF_OPTIM_H

#include <stddef.h>

#include "io/mf_ckpt.h"

#define MF_PARAM_MAX_CH 8

typedef struct {
    char name[32];
    float *p;  /* owned; (n,) values, interleaved channels: element i has channel i % ch */
    float *g;  /* owned; (n,) gradient accumulator (zeroed by mf_param_zero_grad) */
    float *m;  /* owned; (n,) Adam first moment */
    float *v;  /* owned; (n,) Adam second moment */
    size_t n;
    int ch;                      /* channels per element (1..MF_PARAM_MAX_CH) */
    float lr_scale;              /* multiplies the optimiser's learning rate */
    float lo[MF_PARAM_MAX_CH];   /* per-channel lower bound */
    float hi[MF_PARAM_MAX_CH];   /* per-channel upper bound (lo == hi: frozen) */
} MfParamBlock;

/* Allocates a block of n values with ch channels, copying init (n,) when not NULL (else zeros);
 * bounds default to (-inf, inf), lr_scale to 1. */
int mf_param_init(MfParamBlock *b, const char *name, size_t n, int ch, const float *init);
void mf_param_free(MfParamBlock *b);
void mf_param_set_bounds(MfParamBlock *b, int channel, float lo, float hi);
void mf_param_zero_grad(MfParamBlock *b);
/* Clamps every value into its channel's bounds. */
void mf_param_project(MfParamBlock *b);

typedef struct {
    float lr, beta1, beta2, eps;
    long t; /* steps taken */
} MfAdam;

void mf_adam_init(MfAdam *a, float lr);
/* nvdiffrecmc's decay: lr0 * 10^(-0.0002 it). */
float mf_lr_schedule(float lr0, long it);
/* One Adam step on each block with learning rate lr * block->lr_scale, then projection.
 * Checks every gradient first: on a non-finite one nothing changes and MF_ENAN is returned. */
int mf_adam_step(MfAdam *a, MfParamBlock *blocks, int nblocks, float lr);

/* Finds the first non-finite value among the blocks' values (p) and Adam moments (m, v). Returns 1
 * and describes it in msg ("kd.v[1234] = inf", the checkpoint's tensor name), else 0. */
int mf_params_find_nonfinite(const MfParamBlock *blocks, int nblocks, char *msg, size_t cap);

/* A copy of the blocks' values and moments and of Adam's step count. */
typedef struct {
    float *buf; /* owned; for each block in order: p (n), m (n), v (n) */
    size_t len; /* floats in buf */
    long t;     /* Adam steps at the time of the copy */
} MfParamSnapshot;

/* Copies the state into s (allocating on first use; the blocks' sizes must not change). */
int mf_param_snapshot_save(MfParamSnapshot *s, const MfParamBlock *blocks, int nblocks, const MfAdam *a);
/* Copies s back into the blocks and Adam. */
void mf_param_snapshot_restore(const MfParamSnapshot *s, MfParamBlock *blocks, int nblocks, MfAdam *a);
void mf_param_snapshot_free(MfParamSnapshot *s);
/* The checkpoint tensors of that state, in MfParamSnapshot.buf's order: for each block
 * "<name>.p", "<name>.m", "<name>.v", each (n,). specs: (3 * nblocks,); returns 3 * nblocks. */
int mf_param_ckpt_specs(const MfParamBlock *blocks, int nblocks, MfTensorSpec *specs);

/* Divergence watch on a scalar loss. */
typedef struct {
    double factor;   /* diverging: loss > factor * loss_min ... */
    int patience;    /* ... for this many iterations in a row */
    double loss_min; /* running minimum (+inf before the first loss) */
    int streak;      /* iterations in a row above factor * loss_min */
} MfDivGuard;

typedef enum {
    MF_DIV_OK = 0,       /* finite, not a new minimum, not diverging */
    MF_DIV_NEW_MIN = 1,  /* finite and the lowest loss so far (loss_min updated) */
    MF_DIV_NONFINITE = 2,/* NaN or Inf */
    MF_DIV_DIVERGED = 3  /* above factor * loss_min for patience iterations (streak reset) */
} MfDivState;

void mf_divguard_init(MfDivGuard *g, double factor, int patience);
MfDivState mf_divguard_observe(MfDivGuard *g, double loss);

#endif
