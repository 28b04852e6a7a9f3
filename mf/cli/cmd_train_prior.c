/* mf train-prior: trains the StableMaterial-style prior on a prior-train split (mf_prior_train.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "eval/ev_report.h"
#include "prior/mf_prior_train.h"

static char usage[8192];
__attribute__((constructor)) static void train_prior_usage(void) {
    const MfOptTable *t[] = {&mf_train_prior_opt_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf train-prior DATA_DIR -o CKPT_DIR [--steps N] [--ae-steps N] [--batch B] [--seed S]\n"
                       "                      [--dn-samples N] [--resume] [--loss-csv PATH] [--ckpt-every K] [--lr-ae X] [--lr X] [--warmup N]\n"
                       "  Trains the autoencoder (--ae-steps), freezes it, then the denoiser + image encoder (--steps) on\n"
                       "  DATA_DIR (prior-train layout: manifest.json, rgb/ albedo/ orm/ PNGs). Writes CKPT_DIR/prior.mfck\n"
                       "  (weights for `mf prior`), CKPT_DIR/{ae,dn}_state.mfck (resumable state) and the loss curve CSV.\n"
                       "  AdamW weight decay 1e-2.\n",
                       t, 1, NULL);
}

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
        /* the phases with rows: both, the autoencoder alone (stopped in it), or the denoiser alone (--init) */
        int first = n[0] ? 0 : 1, ns = n[0] && n[1] ? 2 : 1;
        if (n[first] && ev_plot_png(png, "prior training loss (50-step moving average)", "step (autoencoder, then denoiser)",
                                    "loss", s + first, ns, 0))
            mf_log_warn("train-prior: no loss plot: %s", mf_error());
    }
    for (int j = 0; j < 2; ++j) free(x[j]), free(y[j]);
}

static int train_prior_run(const MfTrainPriorOpts *po);

static int cmd_train_prior(int argc, char **argv) {
    MfTrainPriorOpts o;
    mf_train_prior_defaults(&o);
    MfOptBind bind = {&mf_train_prior_opt_table, &o};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 1, &p);
    if (rc >= 0) return rc;
    o.data_dir = p.npos ? p.pos[0] : NULL;
    if (!o.data_dir || !o.out_dir) rc = MF_EXIT_USAGE, mf_fail(MF_EARG, "train-prior: need DATA_DIR and -o CKPT_DIR");
    else rc = train_prior_run(&o);
    mf_opts_parse_free(&p);
    return rc;
}

static int train_prior_run(const MfTrainPriorOpts *po) {
    MfTrainPriorOpts o = *po;
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

MF_COMMAND(train_prior, "train-prior", "train the material prior (autoencoder, then denoiser)", usage,
           cmd_train_prior)
