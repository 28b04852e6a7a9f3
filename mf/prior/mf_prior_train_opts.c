/* mf_train_prior_opt_table: the prior training options (MfTrainPriorOpts, mf_prior_train.h) as a
 * declarative table (io/mf_opts.h): `mf train-prior` takes its flags, --config keys, help and
 * range checks from it and mf_train_prior_defaults its defaults. */
#include "prior/mf_prior_train.h"

#include <string.h>

#define S MfTrainPriorOpts
static const MfOpt k_opts[] = {
    MF_OPT_NAMED(S, "out", out_dir, MF_OPT_STR, 0, 0, 0, "checkpoint folder (required): prior.mfck and the resumable state",
                 .alias = "-o", .meta = "CKPT_DIR"),
    MF_OPT_INT(S, steps, 2000, 0, 10000000, "denoiser + image encoder steps"),
    MF_OPT_INT(S, ae_steps, 1000, 0, 10000000, "autoencoder steps (first; then it is frozen)"),
    MF_OPT_INT(S, batch, 16, 1, 4096, "batch size"),
    MF_OPT_U64(S, seed, 1, 0, 9007199254740992.0, "random seed"),
    MF_OPT_INT(S, dn_samples, 0, 0, 1000000000, "the denoiser trains on N samples spread evenly over the split (their "
               "latents are encoded once; 0: all); the autoencoder always uses every sample"),
    MF_OPT_BOOL(S, resume, 0, "continue from the state files exactly (same seed -> same result as one run)"),
    MF_OPT_STR(S, loss_csv, NULL, "loss curve CSV (phase,step,loss,lr; plotted next to it as .png)", .meta = "PATH",
               .unset = "reports/prior/loss.csv"),
    MF_OPT_INT(S, ckpt_every, 200, 1, 10000000, "resumable state every K steps"),
    MF_OPT_FLOAT(S, lr_ae, 5e-4, 0, 1, "AdamW learning rate of the autoencoder"),
    MF_OPT_NAMED(S, "lr", lr_dn, MF_OPT_FLOAT, 3e-4, 0, 1, "AdamW learning rate of the denoiser"),
    MF_OPT_INT(S, warmup, 100, 0, 10000000, "learning-rate warm-up steps"),
    MF_OPT_BOOL(S, lr_cosine, 0, "after the warm-up, each phase's learning rate falls along a cosine to 0 at its last step "
                "(default: constant)"),
    MF_OPT_STR(S, init, NULL, "train on from these prior weights (.mfck): the model size, autoencoder and latent scale "
               "are kept (needs --ae-steps 0), the denoiser starts from its weights with fresh AdamW moments",
               .meta = "WEIGHTS"),
    MF_OPT_BOOL(S, fresh_denoiser, 0, "with --init: keep only its autoencoder and latent scale; the denoiser starts "
                "from random weights (--seed), at --unet-c1/--unet-c2 where given"),
    MF_OPT_INT(S, ae_c1, 0, 0, 4096, "AE channels, first level (0: default 32)"),
    MF_OPT_INT(S, ae_c2, 0, 0, 4096, "AE channels, second level (0: default 64)"),
    MF_OPT_NAMED(S, "unet_c1", dn_c1, MF_OPT_INT, 0, 0, 4096, "denoiser channels, first level (0: default 64; a multiple of 8)"),
    MF_OPT_NAMED(S, "unet_c2", dn_c2, MF_OPT_INT, 0, 0, 4096, "denoiser channels, second level (0: default 128; >= c1, a multiple of 8)"),
    MF_OPT_INT(S, keep_every, 0, 0, 10000000, "also keep the weights every N denoiser steps as CKPT_DIR/prior-<step>.mfck (0: off)"),
    MF_OPT_FLOAT(S, ema, 0, 0, 0.99999, "keep an exponential moving average of the denoiser's weights with this decay "
                 "(warmed up as min(D, (1 + step) / (10 + step)); started from the weights at this run's first step unless "
                 "CKPT_DIR/dn_ema.mfck holds it): prior.mfck and prior-<step>.mfck then hold the average, "
                 "prior-<step>-raw.mfck the weights (0: off)", .meta = "D"),
    MF_OPT_INT(S, stop_after, 0, 0, 1000000000, "stop (with a checkpoint) after N steps of this run (0: off)"),
    MF_OPT_BOOL(S, tiny, 0, "the tiny test model (resolution 16)"),
};
#undef S
const MfOptTable mf_train_prior_opt_table = MF_OPT_TABLE("Training options", k_opts);

void mf_train_prior_defaults(MfTrainPriorOpts *o) {
    memset(o, 0, sizeof *o);
    mf_opts_defaults(&mf_train_prior_opt_table, o);
    o->weight_decay = 1e-2f;
}
