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
 * parameters untouched, so the caller can stop and keep the last good checkpoint. */
#ifndef MF_OPTIM_H
#define MF_OPTIM_H

#include <stddef.h>

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

#endif
