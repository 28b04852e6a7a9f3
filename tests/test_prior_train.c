/* Tests of mf/prior/mf_prior_train on tiny synthetic data: the loss decreases, checkpoints round
 * trip bit-exactly, resume is exact, a NaN loss stops with the checkpoint kept, partial folders. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "io/mf_ckpt.h"
#include "prior/mf_prior.h"
#include "prior/mf_prior_train.h"
#include "tests/mf_test.h"
#include "tests/mf_test_prior.h"

static int files_equal(const char *a, const char *b) {
    char *da = NULL, *db = NULL;
    size_t la = 0, lb = 0;
    int eq = !mf_read_file(a, &da, &la) && !mf_read_file(b, &db, &lb) && la == lb && !memcmp(da, db, la);
    free(da), free(db);
    return eq;
}

MF_TEST(prior_train_tiny_reduces_loss_and_roundtrips) {
    char out[MF_PATH_MAX], csv[MF_PATH_MAX], w[MF_PATH_MAX], w2[MF_PATH_MAX];
    mf_test_path_to(out, sizeof out, "prior_run_a");
    mf_test_path_to(csv, sizeof csv, "prior_run_a.csv");
    MfTrainPriorOpts o;
    tp_tiny_opts(&o, out, csv);
    MfTrainPriorResult r;
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK_MSG(r.ae_loss_last < 0.7f * r.ae_loss_first, "AE loss %g -> %g", r.ae_loss_first, r.ae_loss_last);
    CHECK_MSG(r.dn_loss_last < 0.9f * r.dn_loss_first, "denoiser loss %g -> %g", r.dn_loss_first, r.dn_loss_last);
    CHECK(r.latent_scale > 0 && isfinite(r.latent_scale));
    CHECK(r.psnr[0] > 10 && r.psnr[1] > 10 && r.psnr[2] > 10);
    /* the loss CSV has every step of both phases */
    char *txt = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(csv, &txt, &len));
    CHECK(txt && strstr(txt, "phase,step,loss,lr\nae,1,") && strstr(txt, "\ndn,60,"));
    free(txt);
    /* weights: load, save again -> same bytes; outputs bit-exact after a reload */
    mf_path_join(w, sizeof w, out, "prior.mfck");
    mf_test_path_to(w2, sizeof w2, "prior_copy.mfck");
    MfPrior *p, *q;
    CHECK_OK(mf_prior_load(w, &p));
    CHECK(p->latent_scale == r.latent_scale && p->data_seed == 11 && p->cfg.ae.res == 16);
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(w, &meta));
    CHECK(meta && strstr(meta, "\"downsample\":4") && strstr(meta, MF_PRIOR_ENC_ALBEDO) && strstr(meta, MF_PRIOR_ENC_ORM) &&
          strstr(meta, MF_PRIOR_ENC_COND) && strstr(meta, "\"data_seed\":11") && strstr(meta, "\"resolution\":16"));
    free(meta);
    CHECK_OK(mf_prior_save(p, w2, NULL));
    CHECK_OK(mf_prior_load(w2, &q));
    int B = 2, R = 16;
    size_t ni = (size_t)B * 3 * R * R, nm = (size_t)B * 8 * 4 * 4;
    float *rgb = malloc(ni * sizeof(float)), *za = malloc(nm * sizeof(float)), *zb = malloc(nm * sizeof(float));
    tp_fill(rgb, ni, 8, 1.0f);
    CHECK_OK(mf_prior_sample(p, rgb, B, 1, 0, 5, 3.0f, 42, za));
    CHECK_OK(mf_prior_sample(q, rgb, B, 1, 0, 5, 3.0f, 42, zb));
    CHECK(memcmp(za, zb, nm * sizeof(float)) == 0);
    int finite = 1;
    for (size_t i = 0; i < nm; ++i) finite &= isfinite(za[i]) != 0;
    CHECK(finite);
    /* SDS pieces: encode/decode shapes, 5-step denoise runs and is deterministic in its seed */
    float *zimg = malloc((size_t)B * 4 * 16 * sizeof(float)), *img = malloc(ni * sizeof(float));
    CHECK_OK(mf_prior_encode(p, rgb, B, zimg));
    CHECK_OK(mf_prior_decode(p, zimg, B, img));
    CHECK_OK(mf_prior_sds_denoise(p, za, rgb, B, 1, 0, 600, 3.0f, 9, zb));
    float *zc = malloc(nm * sizeof(float));
    CHECK_OK(mf_prior_sds_denoise(q, za, rgb, B, 1, 0, 600, 3.0f, 9, zc));
    CHECK(memcmp(zb, zc, nm * sizeof(float)) == 0);
    free(rgb), free(za), free(zb), free(zc), free(zimg), free(img);
    mf_prior_free(p), mf_prior_free(q);
}

MF_TEST(prior_resume_is_exact) {
    char a[MF_PATH_MAX], b[MF_PATH_MAX], ca[MF_PATH_MAX], cb[MF_PATH_MAX], wa[MF_PATH_MAX], wb[MF_PATH_MAX];
    mf_test_path_to(a, sizeof a, "prior_res_a");
    mf_test_path_to(b, sizeof b, "prior_res_b");
    mf_test_path_to(ca, sizeof ca, "prior_res_a.csv");
    mf_test_path_to(cb, sizeof cb, "prior_res_b.csv");
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tp_tiny_opts(&o, a, ca);
    o.ae_steps = 10, o.steps = 10, o.ckpt_every = 3;
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK(!r.stopped);
    /* interrupted twice: once inside the AE phase, once inside the denoiser phase */
    tp_tiny_opts(&o, b, cb);
    o.ae_steps = 10, o.steps = 10, o.ckpt_every = 3, o.stop_after = 5;
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK(r.stopped);
    o.resume = 1, o.stop_after = 9; /* AE steps 6..10, then denoiser steps 1..4 */
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK(r.stopped);
    o.stop_after = 0;
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK(!r.stopped);
    mf_path_join(wa, sizeof wa, a, "prior.mfck");
    mf_path_join(wb, sizeof wb, b, "prior.mfck");
    CHECK(files_equal(wa, wb));
    CHECK(files_equal(ca, cb));
}

MF_TEST(prior_nan_loss_stops_and_keeps_checkpoint) {
    char a[MF_PATH_MAX], ca[MF_PATH_MAX], st[MF_PATH_MAX];
    mf_test_path_to(a, sizeof a, "prior_nan");
    mf_test_path_to(ca, sizeof ca, "prior_nan.csv");
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tp_tiny_opts(&o, a, ca);
    o.ae_steps = 6, o.steps = 6, o.ckpt_every = 4, o.nan_at = 6 + 3;
    CHECK_ERR(mf_train_prior(&o, &r), "not finite at step 3");
    mf_path_join(st, sizeof st, a, "ae_state.mfck");
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(st, &meta));
    CHECK(meta && strstr(meta, "\"step\":6"));
    free(meta);
    mf_path_join(st, sizeof st, a, "prior.mfck");
    CHECK(!mf_file_exists(st));
}

MF_TEST(prior_train_partial_folder_and_default_weights) {
    /* a folder still being generated: no manifest, samples 0..5 and 7 (6 missing) -> 6 samples */
    char dir[MF_PATH_MAX], out[MF_PATH_MAX], path[MF_PATH_MAX], w[MF_PATH_MAX];
    mf_test_path_to(dir, sizeof dir, "prior_partial");
    tp_write_synth(dir, 8, 16, 3);
    mf_path_join(path, sizeof path, dir, "manifest.json");
    remove(path);
    mf_path_join(path, sizeof path, dir, "orm/000006.png");
    remove(path);
    mf_test_path_to(out, sizeof out, "prior_partial_out");
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tp_tiny_opts(&o, out, mf_test_path("prior_partial.csv"));
    o.data_dir = dir, o.ae_steps = 3, o.steps = 3, o.ckpt_every = 2, o.dn_samples = 4;
    CHECK_OK(mf_train_prior(&o, &r));
    mf_path_join(w, sizeof w, out, "prior.mfck");
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(w, &meta));
    CHECK_MSG(meta && strstr(meta, "\"samples\":6") && strstr(meta, "\"dn_samples\":4") && strstr(meta, "\"dn_steps\":3"), "meta %s", meta ? meta : "");
    free(meta);
    /* an empty folder is refused */
    CHECK_ERR((o.data_dir = out, mf_train_prior(&o, &r)), "no complete sample");
    /* the default weights path follows $MF_PRIOR_WEIGHTS (a file or a folder) */
    char got[MF_PATH_MAX];
    setenv(MF_PRIOR_WEIGHTS_ENV, out, 1);
    mf_prior_default_weights(got, sizeof got);
    CHECK(!strcmp(got, w));
    MfPrior *p = NULL;
    CHECK_OK(mf_prior_load_path(NULL, &p));
    CHECK(p && p->cfg.ae.res == 16);
    mf_prior_free(p);
    setenv(MF_PRIOR_WEIGHTS_ENV, w, 1);
    mf_prior_default_weights(got, sizeof got);
    CHECK(!strcmp(got, w));
    unsetenv(MF_PRIOR_WEIGHTS_ENV);
    mf_prior_default_weights(got, sizeof got);
    CHECK(strstr(got, MF_PRIOR_WEIGHTS_DEFAULT) != NULL);
}

/* Two runs' folders <tag>_a / <tag>_b (and their loss CSVs): trains a tiny prior into a (weights wa)
 * and leaves o set for a second tiny run into b (weights wb), whose init and options the test sets. */
typedef struct {
    char a[MF_PATH_MAX], b[MF_PATH_MAX], ca[MF_PATH_MAX], cb[MF_PATH_MAX], wa[MF_PATH_MAX], wb[MF_PATH_MAX];
} TwoRuns;

static int tiny_then_second(TwoRuns *t, const char *tag, MfTrainPriorOpts *o, MfTrainPriorResult *ra) {
    char name[64];
    snprintf(name, sizeof name, "%s_a", tag), mf_test_path_to(t->a, sizeof t->a, name);
    snprintf(name, sizeof name, "%s_b", tag), mf_test_path_to(t->b, sizeof t->b, name);
    snprintf(name, sizeof name, "%s_a.csv", tag), mf_test_path_to(t->ca, sizeof t->ca, name);
    snprintf(name, sizeof name, "%s_b.csv", tag), mf_test_path_to(t->cb, sizeof t->cb, name);
    mf_path_join(t->wa, sizeof t->wa, t->a, "prior.mfck");
    mf_path_join(t->wb, sizeof t->wb, t->b, "prior.mfck");
    tp_tiny_opts(o, t->a, t->ca);
    int rc = mf_train_prior(o, ra);
    tp_tiny_opts(o, t->b, t->cb);
    return rc;
}

MF_TEST(prior_train_init_keeps_ae_and_cosine_lr) {
    /* train a tiny prior, then train on from it: the AE and latent scale stay, the denoiser starts
     * where it was (its first losses below a fresh run's), the cosine ends the learning rate at 0 */
    TwoRuns t;
    MfTrainPriorOpts o;
    MfTrainPriorResult ra, rb;
    CHECK_OK(tiny_then_second(&t, "prior_init", &o, &ra));
    const char *b = t.b, *cb = t.cb, *wa = t.wa, *wb = t.wb;
    o.init = wa, o.ae_steps = 0, o.steps = 20, o.lr_cosine = 1, o.seed = 6, o.keep_every = 10;
    o.tiny = 0; /* the model comes from the file */
    CHECK_OK(mf_train_prior(&o, &rb));
    CHECK_MSG(rb.dn_loss_first < 0.8f * ra.dn_loss_first, "init run starts at %g, fresh run at %g", rb.dn_loss_first,
              ra.dn_loss_first);
    CHECK(rb.latent_scale == ra.latent_scale);
    char k10[MF_PATH_MAX], k20[MF_PATH_MAX], k7[MF_PATH_MAX];
    mf_path_join(k10, sizeof k10, b, "prior-10.mfck");
    mf_path_join(k20, sizeof k20, b, "prior-20.mfck");
    mf_path_join(k7, sizeof k7, b, "prior-7.mfck");
    CHECK(mf_file_exists(k10) && files_equal(k20, wb) && !files_equal(k10, wb) && !mf_file_exists(k7));
    MfPrior *pa, *pb;
    CHECK_OK(mf_prior_load(wa, &pa));
    CHECK_OK(mf_prior_load(wb, &pb));
    CHECK(pa->ae->tab.numel == pb->ae->tab.numel &&
          !memcmp(pa->ae->params, pb->ae->params, pa->ae->tab.numel * sizeof(float)));
    CHECK(pb->latent_scale == pa->latent_scale && pb->cfg.ae.res == 16);
    CHECK(memcmp(pa->dn->params, pb->dn->params, pa->dn->tab.numel * sizeof(float)) != 0);
    mf_prior_free(pa), mf_prior_free(pb);
    char *meta = NULL, *txt = NULL;
    size_t len = 0;
    CHECK_OK(mf_prior_read_meta(wb, &meta));
    CHECK_MSG(meta && strstr(meta, "\"init\":") && strstr(meta, "\"lr_cosine\":true") && strstr(meta, "\"ae_steps\":0"),
              "meta %s", meta ? meta : "");
    free(meta);
    /* the CSV: no AE rows; warm-up to 2e-3 at step 5, half of it half-way through the cosine, 0 at the end */
    CHECK_OK(mf_read_file(cb, &txt, &len));
    CHECK(txt && !strstr(txt, "\nae,") && strstr(txt, "\ndn,20,"));
    float lr5 = -1, lr13 = -1, lr20 = -1, l;
    for (char *line = strchr(txt, '\n'); line; line = strchr(line + 1, '\n')) {
        int st;
        float lr;
        if (sscanf(line + 1, "dn,%d,%g,%g", &st, &l, &lr) != 3) continue;
        if (st == 5) lr5 = lr;
        if (st == 13) lr13 = lr; /* step index 12: u = (12 - 5) / (19 - 5) = 0.5 */
        if (st == 20) lr20 = lr;
    }
    free(txt);
    CHECK_MSG(fabsf(lr5 - 2e-3f) < 1e-7f && fabsf(lr13 - 1e-3f) < 1e-7f && lr20 == 0.0f, "lr %g %g %g", lr5, lr13, lr20);
    /* refused: training the AE of an init prior, a model option beside it, a missing file */
    o.ae_steps = 5;
    CHECK_ERR(mf_train_prior(&o, &rb), "--ae-steps 0");
    o.ae_steps = 0, o.tiny = 1;
    CHECK_ERR(mf_train_prior(&o, &rb), "--ae-steps 0");
    o.tiny = 0, o.init = mf_test_path("prior_init_missing.mfck");
    CHECK_ERR(mf_train_prior(&o, &rb), "prior_init_missing.mfck");
}

MF_TEST(prior_train_fresh_denoiser_keeps_only_the_ae) {
    /* --init with --fresh-denoiser (the data-size curve): the AE and latent scale come from the file,
     * the denoiser is exactly a random one of the run's seed, not the file's */
    TwoRuns t;
    MfTrainPriorOpts o;
    MfTrainPriorResult ra, rb;
    CHECK_OK(tiny_then_second(&t, "prior_fresh", &o, &ra));
    const char *wa = t.wa, *wb = t.wb;
    o.fresh_denoiser = 1;
    CHECK_ERR(mf_train_prior(&o, &rb), "--fresh-denoiser needs --init");
    o.init = wa, o.ae_steps = 0, o.steps = 0, o.seed = 9, o.tiny = 0;
    CHECK_OK(mf_train_prior(&o, &rb));
    MfPrior *pa, *pb, *pr;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    CHECK_OK(mf_prior_load(wa, &pa));
    CHECK_OK(mf_prior_load(wb, &pb));
    CHECK_OK(mf_prior_new(&pr, &cfg));
    mf_denoiser_init_weights(pr->dn, 9);
    size_t nd = pb->dn->tab.numel;
    CHECK(!memcmp(pa->ae->params, pb->ae->params, pa->ae->tab.numel * sizeof(float)));
    CHECK(pb->latent_scale == pa->latent_scale);
    CHECK(nd == pr->dn->tab.numel && !memcmp(pb->dn->params, pr->dn->params, nd * sizeof(float)));
    CHECK(memcmp(pb->dn->params, pa->dn->params, nd * sizeof(float)) != 0);
    mf_prior_free(pa), mf_prior_free(pb), mf_prior_free(pr);
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(wb, &meta));
    CHECK_MSG(meta && strstr(meta, "\"fresh_denoiser\":true"), "meta %s", meta ? meta : "");
    free(meta);
    /* a wider denoiser beside the same autoencoder; without --fresh-denoiser the channels are refused */
    o.dn_c1 = 16, o.dn_c2 = 16;
    CHECK_OK(mf_train_prior(&o, &rb));
    CHECK_OK(mf_prior_load(wa, &pa));
    CHECK_OK(mf_prior_load(wb, &pb));
    CHECK(pb->cfg.dn.c1 == 16 && pb->cfg.dn.c2 == 16 && pb->dn->tab.numel > nd);
    CHECK(!memcmp(pa->ae->params, pb->ae->params, pa->ae->tab.numel * sizeof(float)) && pb->latent_scale == pa->latent_scale);
    mf_prior_free(pa), mf_prior_free(pb);
    o.fresh_denoiser = 0;
    CHECK_ERR(mf_train_prior(&o, &rb), "denoiser channels only with --fresh-denoiser");
}

/* --ema: after one step the kept average is exactly d w0 + (1 - d) w1 with the warmed-up decay
 * d = min(D, 2 / 11), w0 the fresh denoiser of the seed and w1 the raw weights (prior-1-raw.mfck);
 * prior.mfck is the average; the metas say which is which; a resumed run goes on from the average
 * kept in dn_ema.mfck (bit-identical to an uninterrupted one), and without that file it is not. */
MF_TEST(prior_train_ema_averages_weights) {
    TwoRuns t;
    MfTrainPriorOpts o;
    MfTrainPriorResult ra, rb;
    CHECK_OK(tiny_then_second(&t, "prior_ema", &o, &ra));
    o.init = t.wa, o.ae_steps = 0, o.fresh_denoiser = 1, o.tiny = 0, o.seed = 9, o.ema = 0.9f, o.keep_every = 1;
    o.steps = 1;
    CHECK_OK(mf_train_prior(&o, &rb));
    char raw[MF_PATH_MAX], avg[MF_PATH_MAX];
    mf_path_join(raw, sizeof raw, t.b, "prior-1-raw.mfck");
    mf_path_join(avg, sizeof avg, t.b, "prior-1.mfck");
    MfPrior *pw, *pa, *p0;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    CHECK_OK(mf_prior_load(raw, &pw));
    CHECK_OK(mf_prior_load(avg, &pa));
    CHECK_OK(mf_prior_new(&p0, &cfg));
    mf_denoiser_init_weights(p0->dn, 9);
    size_t nd = p0->dn->tab.numel, far = 0;
    float d = 2.0f / 11.0f;
    CHECK(pw->dn->tab.numel == nd && pa->dn->tab.numel == nd);
    for (size_t i = 0; i < nd; ++i) far += fabsf(pa->dn->params[i] - (d * p0->dn->params[i] + (1.0f - d) * pw->dn->params[i])) > 1e-6f;
    CHECK_MSG(far == 0, "%zu of %zu averaged weights differ from d w0 + (1 - d) w1", far, nd);
    CHECK(memcmp(pa->dn->params, pw->dn->params, nd * sizeof(float)) != 0);
    mf_prior_free(pw), mf_prior_free(pa), mf_prior_free(p0);
    CHECK(files_equal(avg, t.wb));
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(t.wb, &meta));
    CHECK_MSG(meta && strstr(meta, "\"ema\":0.9") && strstr(meta, "\"weights\":\"average\""), "meta %s", meta ? meta : "");
    free(meta), meta = NULL;
    CHECK_OK(mf_prior_read_meta(raw, &meta));
    CHECK_MSG(meta && strstr(meta, "\"weights\":\"raw\""), "meta %s", meta ? meta : "");
    free(meta);
    /* resume: b goes on to 3 steps from its state and average; a fresh folder runs 3 at once */
    char one[MF_PATH_MAX], w3[MF_PATH_MAX], b3[MF_PATH_MAX], ema_file[MF_PATH_MAX];
    mf_test_path_to(one, sizeof one, "prior_ema_one");
    o.steps = 3, o.resume = 1;
    CHECK_OK(mf_train_prior(&o, &rb));
    mf_path_join(b3, sizeof b3, t.b, "prior-3.mfck");
    o.out_dir = one, o.resume = 0;
    CHECK_OK(mf_train_prior(&o, &rb));
    mf_path_join(w3, sizeof w3, one, "prior-3.mfck");
    CHECK(files_equal(b3, w3));
    /* the same resume without dn_ema.mfck restarts the average from the step-1 weights: different */
    o.out_dir = t.b, o.steps = 1;
    CHECK_OK(mf_train_prior(&o, &rb));
    mf_path_join(ema_file, sizeof ema_file, t.b, "dn_ema.mfck");
    CHECK(remove(ema_file) == 0);
    o.steps = 3, o.resume = 1;
    CHECK_OK(mf_train_prior(&o, &rb));
    CHECK(!files_equal(b3, w3));
}
