/* mf train-prior: trains the StableMaterial-style prior on a prior-train split (mf_prior_train.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "prior/mf_prior_train.h"

#define USAGE_TRAIN_PRIOR \
    "usage: mf train-prior DATA_DIR -o CKPT_DIR [--steps N] [--ae-steps N] [--batch B] [--seed S]\n" \
    "                      [--dn-samples N] [--resume] [--loss-csv PATH] [--ckpt-every K] [--lr-ae X] [--lr X] [--warmup N]\n" \
    "  Trains the autoencoder (--ae-steps, default 1000), freezes it, then the denoiser + image encoder\n" \
    "  (--steps, default 2000) on DATA_DIR (prior-train layout: manifest.json, rgb/ albedo/ orm/ PNGs).\n" \
    "  Writes CKPT_DIR/prior.mfck (weights for `mf prior`), CKPT_DIR/{ae,dn}_state.mfck (resumable state,\n" \
    "  every --ckpt-every steps, default 200) and the loss curve CSV (default reports/prior/loss.csv).\n" \
    "  --resume continues from the state files exactly (same seed -> same result as one run).\n" \
    "  --dn-samples N: the denoiser trains on N samples spread evenly over the split (their latents are\n" \
    "  encoded once; default all); the autoencoder always uses every sample.\n" \
    "  Defaults: batch 16, seed 1, AdamW lr 5e-4 (AE) / 3e-4 (denoiser), wd 1e-2, warm-up 100 steps.\n" \
    "  Model size: --ae-c1/--ae-c2 (AE channels, default 32/64), --unet-c1/--unet-c2 (default 64/128;\n" \
    "  c1 multiple of 8, c2 >= c1 and a multiple of 8). --stop-after N stops (with a checkpoint) after N steps.\n"

static int cmd_train_prior(int argc, char **argv) {
    MfTrainPriorOpts o;
    mf_train_prior_defaults(&o);
    int seed = 1, ae_steps = -1;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "-o", &o.out_dir)) || (r = mf_opt_int(argc, argv, &i, "--steps", &o.steps)) ||
            (r = mf_opt_int(argc, argv, &i, "--ae-steps", &ae_steps)) ||
            (r = mf_opt_int(argc, argv, &i, "--batch", &o.batch)) || (r = mf_opt_int(argc, argv, &i, "--seed", &seed)) ||
            (r = mf_opt_str(argc, argv, &i, "--loss-csv", &o.loss_csv)) ||
            (r = mf_opt_int(argc, argv, &i, "--ckpt-every", &o.ckpt_every)) ||
            (r = mf_opt_float(argc, argv, &i, "--lr-ae", &o.lr_ae)) || (r = mf_opt_float(argc, argv, &i, "--lr", &o.lr_dn)) ||
            (r = mf_opt_int(argc, argv, &i, "--warmup", &o.warmup)) ||
            (r = mf_opt_int(argc, argv, &i, "--dn-samples", &o.dn_samples)) ||
            (r = mf_opt_int(argc, argv, &i, "--stop-after", &o.stop_after)) ||
            (r = mf_opt_int(argc, argv, &i, "--ae-c1", &o.ae_c1)) || (r = mf_opt_int(argc, argv, &i, "--ae-c2", &o.ae_c2)) ||
            (r = mf_opt_int(argc, argv, &i, "--unet-c1", &o.dn_c1)) || (r = mf_opt_int(argc, argv, &i, "--unet-c2", &o.dn_c2))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--resume")) o.resume = 1;
        else if (!strcmp(argv[i], "--tiny")) o.tiny = 1;
        else if (argv[i][0] != '-' && !o.data_dir) o.data_dir = argv[i];
        else {
            mf_fail(MF_EARG, "train-prior: unknown argument '%s'", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (!o.data_dir || !o.out_dir) {
        mf_fail(MF_EARG, "train-prior: need DATA_DIR and -o CKPT_DIR");
        return MF_EXIT_USAGE;
    }
    o.seed = (uint64_t)seed;
    o.ae_steps = ae_steps >= 0 ? ae_steps : 1000;
    MfTrainPriorResult r;
    if (mf_train_prior(&o, &r)) return MF_EXIT_FAIL;
    printf("parameters %zu\n", r.params);
    if (r.ae_step_s > 0)
        printf("autoencoder: %.4f s/step (batch %d), loss %.5f -> %.5f\n", r.ae_step_s, o.batch, r.ae_loss_first,
               r.ae_loss_last);
    if (!r.stopped || r.dn_step_s > 0) {
        printf("autoencoder PSNR (data range 2): albedo %.2f dB, ORM %.2f dB, RGB %.2f dB; latent scale %.5f\n", r.psnr[0],
               r.psnr[1], r.psnr[2], r.latent_scale);
    }
    if (r.dn_step_s > 0)
        printf("denoiser: %.4f s/step (batch %d), loss %.5f -> %.5f\n", r.dn_step_s, o.batch, r.dn_loss_first,
               r.dn_loss_last);
    printf(r.stopped ? "stopped (--stop-after); resume with --resume\n" : "weights: %s/prior.mfck\n", o.out_dir);
    return MF_EXIT_OK;
}

MF_COMMAND(train_prior, "train-prior", "train the material prior (autoencoder, then denoiser)", USAGE_TRAIN_PRIOR,
           cmd_train_prior)
