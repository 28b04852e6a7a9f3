/* mf train-prior: trains the StableMaterial-style prior on a prior-train split (mf_prior_train.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "eval/ev_report.h"
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

/* Plots the loss CSV (phase,step,loss,lr) next to it as .png: one series per phase, the denoiser's
 * steps after the autoencoder's; a 50-step moving average keeps the curves readable. */
static void plot_loss(const char *csv) {
    FILE *f = fopen(csv, "r");
    if (!f) return;
    int cap = 1024, n[2] = {0, 0};
    double *x[2] = {malloc(cap * sizeof(double)), malloc(cap * sizeof(double))};
    double *y[2] = {malloc(cap * sizeof(double)), malloc(cap * sizeof(double))};
    char line[256];
    int ok = x[0] && x[1] && y[0] && y[1], ae_last = 0;
    while (ok && fgets(line, sizeof line, f)) {
        char ph[8];
        int st;
        float l, lr;
        if (sscanf(line, "%3[a-z],%d,%g,%g", ph, &st, &l, &lr) != 4) continue;
        int k = !strcmp(ph, "dn");
        if (n[k] == cap || n[1 - k] == cap) {
            cap *= 2;
            for (int j = 0; j < 2 && ok; ++j) {
                double *a = realloc(x[j], cap * sizeof(double)), *b = a ? realloc(y[j], cap * sizeof(double)) : NULL;
                if (a) x[j] = a;
                if (b) y[j] = b;
                ok = a && b;
            }
            if (!ok) break;
        }
        if (!k) ae_last = st;
        x[k][n[k]] = k ? ae_last + st : st, y[k][n[k]] = l, ++n[k];
    }
    fclose(f);
    if (ok) {
        for (int k = 0; k < 2; ++k) { /* trailing moving average over 50 steps (in place, from the end) */
            double run = 0;
            double *tmp = malloc((size_t)(n[k] ? n[k] : 1) * sizeof(double));
            if (!tmp) continue;
            for (int i = 0; i < n[k]; ++i) {
                run += y[k][i];
                if (i >= 50) run -= y[k][i - 50];
                tmp[i] = run / (i + 1 < 50 ? i + 1 : 50);
            }
            memcpy(y[k], tmp, (size_t)n[k] * sizeof(double));
            free(tmp);
        }
        EvSeries s[2] = {{"autoencoder (L1 + L2 + latent)", x[0], y[0], n[0]}, {"denoiser (v MSE)", x[1], y[1], n[1]}};
        char png[1024];
        size_t l = strlen(csv);
        snprintf(png, sizeof png, "%.*s.png", (int)(l > 4 && !strcmp(csv + l - 4, ".csv") ? l - 4 : l), csv);
        int ns = n[1] ? 2 : 1;
        if (n[0] && ev_plot_png(png, "prior training loss (50-step moving average)", "step (autoencoder, then denoiser)",
                                "loss", s, ns, 0))
            mf_log_warn("train-prior: no loss plot: %s", mf_error());
    }
    for (int j = 0; j < 2; ++j) free(x[j]), free(y[j]);
}

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
    int rc = mf_train_prior(&o, &r);
    plot_loss(o.loss_csv ? o.loss_csv : "reports/prior/loss.csv");
    if (rc) return MF_EXIT_FAIL;
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
