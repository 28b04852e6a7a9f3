/* mf_prior_train: training of the prior on a prior-train split (notes/contracts.md layout:
 * DIR/manifest.json, DIR/{rgb,albedo,orm}/NNNNNN.png, RGBA 8-bit, alpha = mask).
 *
 * Phase 1 trains the autoencoder on all three kinds (albedo, ORM, RGB; one shared AE) with
 * mean |y - x| + mean (y - x)^2 + 1e-3 mean z^2. Then the AE is frozen, every sample's three latents
 * are computed once, the latent scale is set to 1/std of all of them, and phase 2 trains the
 * denoiser and image encoder jointly on v-prediction MSE with t ~ U{0..999} and conditioning
 * dropout (5% embedding only, 5% both, 5% image latent only).
 * Both phases: AdamW (beta 0.9/0.999, wd 1e-2), linear warm-up (then constant, or a cosine to 0 with
 * lr_cosine), global gradient clipping at 1. With init, training goes on from a trained prior: phase 1
 * is skipped and its autoencoder and latent scale are kept, so the denoiser's latents do not move.
 * Randomness is derived from (seed, phase, step) alone, so a run resumed from a checkpoint is
 * bit-identical to an uninterrupted one (same build and thread count).
 * Files in out_dir: ae_state.mfck, dn_state.mfck (weights + AdamW moments, written atomically every
 * ckpt_every steps and at phase ends; with ema, dn_ema.mfck beside it), prior.mfck (the final weights, mf_prior.h format). The loss
 * CSV (phase,step,loss,lr) is rewritten atomically with every checkpoint. A non-finite loss stops
 * training with MF_ENAN and leaves the last good checkpoint in place.
 * Learning rates (defaults) were picked on synthetic 64 px data, same seed (same batches and noise):
 * AE 120 steps: lr 5e-4 -> albedo PSNR 25.3 dB vs 20.4 dB at 2e-3; denoiser 200 steps, mean loss
 * of steps 151-200: 0.483 (1e-4), 0.459 (3e-4), 0.464 (1e-3) -> 3e-4. */
#ifndef MF_PRIOR_TRAIN_H
#define MF_PRIOR_TRAIN_H

#include <stdint.h>

#include "io/mf_opts.h"
#include "prior/mf_prior.h"

typedef struct {
    const char *data_dir, *out_dir; /* borrowed */
    const char *loss_csv;           /* borrowed; NULL = reports/prior/loss.csv */
    int steps;                      /* denoiser steps */
    int ae_steps;                   /* autoencoder steps */
    int dn_samples;                 /* samples the denoiser trains on (their latents are cached), evenly
                                       spread over the split; 0 = all. The autoencoder uses all. */
    int batch;
    int ckpt_every;
    int warmup;
    int resume;
    uint64_t seed;
    float lr_ae, lr_dn, weight_decay;
    int tiny;                       /* the tiny test model (resolution 16) */
    int ae_c1, ae_c2, dn_c1, dn_c2; /* channel overrides of the default model (0 = default 32/64, 64/128) */
    const char *init;               /* borrowed; NULL = random init. A trained prior (.mfck): its model size,
                                       autoencoder and latent scale are kept (the AE is not trained:
                                       ae_steps must be 0) and the denoiser starts from its weights with
                                       fresh AdamW moments (fine-tuning / training on) */
    int fresh_denoiser;             /* with init: keep only its autoencoder and latent scale; the denoiser
                                       starts from random weights (seed), as in a run from scratch, of
                                       the size dn_c1/dn_c2 where given (the data-size and model-size
                                       curves: one autoencoder, denoisers on N samples or of C channels) */
    int lr_cosine;                  /* after the warm-up, both learning rates follow a cosine from their
                                       value to 0 at the phase's last step (else constant) */
    int keep_every;                 /* also keep the weights every K denoiser steps as out_dir/prior-<step>.mfck
                                       (a held-out curve over steps; 0 = off) */
    float ema;                      /* > 0: an exponential moving average of the denoiser's weights, decay
                                       min(ema, (1 + step) / (10 + step)) per step, started from the weights
                                       at the run's first step (from scratch or on resume; kept across
                                       resumes in out_dir/dn_ema.mfck); prior.mfck and prior-<step>.mfck
                                       then hold the average and prior-<step>-raw.mfck the weights
                                       themselves (0 = off) */
    int stop_after;                 /* test hook: checkpoint and stop after this many steps of this run (0 = off) */
    int nan_at;                     /* test hook: pretend the loss is NaN at this global step (0 = off) */
} MfTrainPriorOpts;

typedef struct {
    double ae_step_s, dn_step_s;          /* mean wall seconds per step in this run */
    float ae_loss_first, ae_loss_last;    /* means over the first / last 5 steps of this run */
    float dn_loss_first, dn_loss_last;
    float psnr[3];                        /* AE reconstruction PSNR (data range 2): albedo, ORM, RGB */
    float latent_scale;
    size_t params;
    int stopped;                          /* stop_after reached */
} MfTrainPriorResult;

/* The options as a table (mf_prior_train_opts.c: flags, --config keys, defaults, ranges, docs);
 * mf_train_prior_defaults fills o from it (weight decay 1e-2, not an option). */
extern const MfOptTable mf_train_prior_opt_table;
void mf_train_prior_defaults(MfTrainPriorOpts *o);
int mf_train_prior(const MfTrainPriorOpts *o, MfTrainPriorResult *res);

#endif
