/* mf_prior_train: see mf_prior_train.h. */
#include "prior/mf_prior_train.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_prior2d.h"
#include "io/mf_image.h"
#include "io/mf_ckpt.h"

/* ---- data ------------------------------------------------------------------------------------ */

typedef struct {
    int n, R;
    uint64_t seed;
    unsigned char *px; // (n, 3 kinds, R, R, 4) raw 8-bit values (kinds: albedo, orm, rgb)
    int m;             /* samples the denoiser trains on (latents cached): sel[0..m-1] */
    int *sel;          // (m,) sample indices, spread evenly over 0..n-1
} Data;

/* Reads manifest.json when present (count, resolution, seed). A folder still being generated
 * (no manifest yet, or fewer files than the manifest's count) is accepted: the samples
 * 0..n-1 whose three files all exist are used, with a warning; the resolution then comes from
 * the first image. */
static int data_load(const char *dir, Data *d) {
    char path[MF_PATH_MAX];
    int rc, want = -1;
    d->R = 0, d->seed = 0;
    DsPrior2dManifest man;
    if ((rc = ds_prior2d_manifest(dir, 0, &man))) return rc;
    if (man.present) {
        if (man.count < 1 || man.resolution < 8)
            return mf_fail(MF_EFORMAT, "%s: expected \"count\" >= 1 and \"resolution\" >= 8", man.path);
        want = man.count, d->R = man.resolution, d->seed = man.seed;
    }
    int n = ds_prior2d_complete(dir, want);
    if (n == 0) return mf_fail(MF_EIO, "%s: no complete sample (rgb/, albedo/, orm/000000.png)", dir);
    if (want < 0) mf_log_warn("%s: no manifest.json; using the %d complete samples present", dir, n);
    else if (n < want) mf_log_warn("%s: manifest says %d samples, using the first %d complete ones", dir, want, n);
    d->n = n;
    for (int i = 0; i < d->n; ++i)
        for (int k = 0; k < 3; ++k) {
            ds_prior2d_path(dir, ds_prior2d_kinds[k], i, path, sizeof path);
            MfImage img = {0};
            if ((rc = mf_image_read(path, MF_ENC_LINEAR, &img))) goto fail;
            if (!d->R && img.w >= 8) d->R = img.w;
            if (!d->px) {
                d->px = malloc((size_t)d->n * 3 * d->R * d->R * 4);
                if (!d->px) {
                    mf_image_free(&img);
                    return mf_fail(MF_ENOMEM, "%s: out of memory for %d samples", dir, d->n);
                }
            }
            if (img.w != d->R || img.h != d->R || img.c != 4) {
                rc = mf_fail(MF_EFORMAT, "%s: expected %dx%d RGBA, got %dx%d with %d channels", path, d->R, d->R, img.w,
                             img.h, img.c);
                mf_image_free(&img);
                goto fail;
            }
            size_t per = (size_t)d->R * d->R * 4;
            unsigned char *dst = d->px + ((size_t)i * 3 + k) * per;
            for (size_t j = 0; j < per; ++j) {
                float v = img.data[j] * 255.0f + 0.5f;
                dst[j] = (unsigned char)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            mf_image_free(&img);
        }
    return MF_OK;
fail:
    free(d->px), d->px = NULL;
    return rc;
}

/* out (3, R, R) = (2 v - 1) * alpha of sample i, kind k. */
static void data_get(const Data *d, int i, int k, float *out) {
    size_t hw = (size_t)d->R * d->R;
    const unsigned char *s = d->px + ((size_t)i * 3 + k) * hw * 4;
    for (size_t p = 0; p < hw; ++p) {
        float a = s[p * 4 + 3] / 255.0f;
        for (int c = 0; c < 3; ++c) out[c * hw + p] = (2.0f * (s[p * 4 + c] / 255.0f) - 1.0f) * a;
    }
}

/* ---- training state files -------------------------------------------------------------------------- */

/* Tensors params, adam.m.*, adam.v.* of tab; meta JSON. */
static int state_tables(const MfSpecTab *tab, MfTensorSpec **out) {
    MfTensorSpec *s = malloc((size_t)tab->n * 3 * sizeof *s);
    if (!s) return mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; i < tab->n; ++i) {
        s[i] = tab->v[i];
        s[tab->n + i] = s[2 * tab->n + i] = tab->v[i];
        snprintf(s[tab->n + i].name, MF_NN_NAME_MAX, "m.%.61s", tab->v[i].name);
        snprintf(s[2 * tab->n + i].name, MF_NN_NAME_MAX, "v.%.61s", tab->v[i].name);
    }
    *out = s;
    return MF_OK;
}

static int state_save(const char *path, const MfSpecTab *tab, const float *params, const MfAdamW *opt,
                      const char *phase, int step, uint64_t seed) {
    MfTensorSpec *s;
    int rc = state_tables(tab, &s);
    if (rc) return rc;
    size_t n = tab->numel;
    float *data = malloc(3 * n * sizeof(float));
    if (!data) {
        free(s);
        return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    }
    memcpy(data, params, n * sizeof(float));
    memcpy(data + n, opt->m, n * sizeof(float));
    memcpy(data + 2 * n, opt->v, n * sizeof(float));
    char meta[256];
    snprintf(meta, sizeof meta, "{\"phase\":\"%s\",\"step\":%d,\"adam_t\":%lld,\"seed\":%llu}", phase, step,
             (long long)opt->t, (unsigned long long)seed);
    rc = mf_ckpt_save(path, s, tab->n * 3, data, meta);
    free(s), free(data);
    return rc;
}

static int state_load(const char *path, const MfSpecTab *tab, float *params, MfAdamW *opt, int *step) {
    MfTensorSpec *s;
    int rc = state_tables(tab, &s);
    if (rc) return rc;
    size_t n = tab->numel;
    float *data = malloc(3 * n * sizeof(float));
    char *meta = NULL;
    if (!data) rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
    if (!rc) rc = mf_ckpt_load(path, s, tab->n * 3, data, &meta);
    cJSON *m = rc ? NULL : cJSON_Parse(meta);
    const cJSON *js = cJSON_GetObjectItemCaseSensitive(m, "step"), *jt = cJSON_GetObjectItemCaseSensitive(m, "adam_t");
    if (!rc && (!cJSON_IsNumber(js) || !cJSON_IsNumber(jt))) rc = mf_fail(MF_EFORMAT, "%s: meta lacks step/adam_t", path);
    if (!rc) {
        memcpy(params, data, n * sizeof(float));
        memcpy(opt->m, data + n, n * sizeof(float));
        memcpy(opt->v, data + 2 * n, n * sizeof(float));
        opt->t = (long long)jt->valuedouble;
        *step = js->valueint;
    }
    cJSON_Delete(m);
    free(meta), free(s), free(data);
    return rc;
}

/* ---- loss history ---------------------------------------------------------------------------------- */

typedef struct {
    char phase[4];
    int step;
    float loss, lr;
} Row;

typedef struct {
    Row *r;
    int n, cap;
} Hist;

static void hist_add(Hist *h, const char *phase, int step, float loss, float lr) {
    if (h->n == h->cap) {
        int cap = h->cap ? 2 * h->cap : 256;
        Row *r = realloc(h->r, (size_t)cap * sizeof *r);
        if (!r) return;
        h->r = r, h->cap = cap;
    }
    Row *x = &h->r[h->n++];
    snprintf(x->phase, sizeof x->phase, "%s", phase);
    x->step = step, x->loss = loss, x->lr = lr;
}

/* Keeps the rows of an existing CSV up to the resumed steps. */
static void hist_read(Hist *h, const char *path, int ae_step, int dn_step) {
    FILE *f = fopen(path, "r");
    if (!f) return;
    char line[256];
    while (fgets(line, sizeof line, f)) {
        char ph[8];
        int st;
        float l, lr;
        if (sscanf(line, "%3[a-z],%d,%g,%g", ph, &st, &l, &lr) != 4) continue;
        if ((!strcmp(ph, "ae") && st <= ae_step) || (!strcmp(ph, "dn") && st <= dn_step)) hist_add(h, ph, st, l, lr);
    }
    fclose(f);
}

static int hist_write(const Hist *h, const char *path) {
    size_t cap = 64 + (size_t)h->n * 64, len = 0;
    char *buf = malloc(cap);
    if (!buf) return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    len += (size_t)snprintf(buf, cap, "phase,step,loss,lr\n");
    for (int i = 0; i < h->n; ++i)
        len += (size_t)snprintf(buf + len, cap - len, "%s,%d,%.9g,%.6g\n", h->r[i].phase, h->r[i].step, h->r[i].loss,
                                h->r[i].lr);
    int rc = mf_mkdirs_for(path);
    if (!rc) rc = mf_write_file(path, buf, len);
    free(buf);
    return rc;
}

/* ---- training --------------------------------------------------------------------------------------- */

/* Learning rate of 0-based step of a phase of total steps: linear warm-up, then constant or a cosine
 * from lr to 0 at the last step. */
static float lr_at(float lr, int step, int warmup, int total, int cosine) {
    if (step < warmup) return lr * (float)(step + 1) / (float)warmup;
    if (!cosine || total - 1 <= warmup) return lr;
    double u = (double)(step - warmup) / (double)(total - 1 - warmup); /* 0 .. 1 */
    return (float)(0.5 * lr * (1.0 + cos(M_PI * u)));
}

typedef struct {
    const MfTrainPriorOpts *o;
    char ae_state[MF_PATH_MAX], dn_state[MF_PATH_MAX], dn_ema[MF_PATH_MAX], final[MF_PATH_MAX];
    const char *csv;
    Hist hist;
    int ran;    /* steps done in this run */
    int saved;  /* denoiser step of the weights last saved by this run (-1: none) */
    float *ema; // (denoiser params,) the moving average of the denoiser's weights (o->ema > 0), else NULL
} Ctx;

/* The average's file: the denoiser's tensors holding the average, meta {"step": dn_step}. */
static int ema_save(const Ctx *c, const MfSpecTab *tab, int step) {
    char meta[64];
    snprintf(meta, sizeof meta, "{\"step\":%d}", step);
    return mf_ckpt_save(c->dn_ema, tab->v, tab->n, c->ema, meta);
}

/* Loads the average of step `step` into c->ema; non-zero when the file is missing, unreadable or of
 * another step (the caller then starts the average afresh from the weights). */
static int ema_load(Ctx *c, const MfSpecTab *tab, int step) {
    char *meta = NULL;
    if (!mf_file_exists(c->dn_ema)) return MF_EIO;
    int rc = mf_ckpt_load(c->dn_ema, tab->v, tab->n, c->ema, &meta);
    cJSON *m = rc ? NULL : cJSON_Parse(meta);
    const cJSON *js = cJSON_GetObjectItemCaseSensitive(m, "step");
    if (!rc && (!cJSON_IsNumber(js) || js->valueint != step)) rc = MF_EFORMAT;
    cJSON_Delete(m);
    free(meta);
    return rc;
}

static int checkpoint(Ctx *c, const char *phase, const MfSpecTab *tab, const float *params, const MfAdamW *opt,
                      int step) {
    int ae = !strcmp(phase, "ae");
    int rc = state_save(ae ? c->ae_state : c->dn_state, tab, params, opt, phase, step, c->o->seed);
    if (!rc && !ae && c->ema) rc = ema_save(c, tab, step);
    if (!rc) rc = hist_write(&c->hist, c->csv);
    return rc;
}

static float mean_of(const Hist *h, const char *phase, int from_end, int k, int since) {
    double s = 0;
    int n = 0;
    if (!from_end) {
        for (int i = since; i < h->n && n < k; ++i)
            if (!strcmp(h->r[i].phase, phase)) s += h->r[i].loss, ++n;
    } else {
        for (int i = h->n - 1; i >= since && n < k; --i)
            if (!strcmp(h->r[i].phase, phase)) s += h->r[i].loss, ++n;
    }
    return n ? (float)(s / n) : NAN;
}

static int train_ae(Ctx *c, MfPrior *p, const Data *d, MfTrainPriorResult *res, int *stop) {
    const MfTrainPriorOpts *o = c->o;
    MfAe *ae = p->ae;
    size_t np = ae->tab.numel;
    MfAdamW opt;
    int rc = mf_adamw_init(&opt, np, o->lr_ae, 0.9f, 0.999f, 1e-8f, o->weight_decay);
    if (rc) return rc;
    int step = 0;
    if (o->resume && mf_file_exists(c->ae_state)) {
        if ((rc = state_load(c->ae_state, &ae->tab, ae->params, &opt, &step))) goto done;
        mf_log_info("train-prior: resuming the autoencoder at step %d", step);
    }
    int B = o->batch, R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = R / 4;
    size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * zc * h * h;
    float *x = malloc(ni * sizeof(float)), *dy = malloc(ni * sizeof(float)), *dz = malloc(nz * sizeof(float));
    MfAeWork w = {0};
    if (!x || !dy || !dz) rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
    int since = c->hist.n;
    MfProgress prog;
    mf_progress_begin(&prog, "autoencoder", (size_t)(o->ae_steps > step ? o->ae_steps - step : 0));
    double t0 = mf_now();
    int done_here = 0;
    for (; !rc && step < o->ae_steps; ++step) {
        MfRng r;
        mf_rng_seed(&r, o->seed, 0x100000000ull + (uint64_t)step);
        for (int b = 0; b < B; ++b) {
            int i = (int)mf_rng_below(&r, (uint32_t)d->n), k = (int)mf_rng_below(&r, 3);
            data_get(d, i, k, x + (size_t)b * 3 * R * R);
        }
        float *z = mf_ae_encode(ae, &w, x, B), *y = z ? mf_ae_decode(ae, &w, z, B) : NULL;
        if (!y) {
            rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
            break;
        }
        double l1 = 0, l2 = 0, lz = 0;
        const float lam = 1e-3f;
        for (size_t i = 0; i < ni; ++i) {
            float e = y[i] - x[i];
            l1 += fabsf(e), l2 += (double)e * e;
            dy[i] = ((e > 0) - (e < 0)) / (float)ni + 2.0f * e / (float)ni;
        }
        for (size_t i = 0; i < nz; ++i) lz += (double)z[i] * z[i];
        float loss = (float)((l1 + l2) / ni + lam * lz / nz);
        if (o->nan_at && o->nan_at == step + 1) loss = NAN;
        if (!isfinite(loss)) {
            rc = mf_fail(MF_ENAN, "train-prior: autoencoder loss is not finite at step %d; stopped, the last good "
                                  "checkpoint is kept (%s)", step + 1, c->ae_state);
            break;
        }
        memset(ae->grads, 0, np * sizeof(float));
        memset(dz, 0, nz * sizeof(float));
        mf_ae_decode_backward(ae, &w, dy, dz);
        for (size_t i = 0; i < nz; ++i) dz[i] += 2.0f * lam * z[i] / (float)nz;
        mf_ae_encode_backward(ae, &w, dz, NULL);
        mf_grad_clip_norm(ae->grads, np, 1.0f);
        opt.lr = lr_at(o->lr_ae, step, o->warmup, o->ae_steps, o->lr_cosine);
        if (mf_adamw_step(&opt, ae->params, ae->grads)) {
            rc = mf_fail_prefix(MF_ENAN, "train-prior: autoencoder step %d (stopped; the last good checkpoint is kept: %s)",
                                step + 1, c->ae_state);
            break;
        }
        hist_add(&c->hist, "ae", step + 1, loss, opt.lr);
        mf_progress_add(&prog, 1);
        ++done_here, ++c->ran;
        int last = step + 1 == o->ae_steps, halt = o->stop_after && c->ran >= o->stop_after;
        if ((o->ckpt_every > 0 && (step + 1) % o->ckpt_every == 0) || last || halt)
            rc = checkpoint(c, "ae", &ae->tab, ae->params, &opt, step + 1);
        if (halt) {
            *stop = 1;
            ++step;
            break;
        }
    }
    mf_progress_end(&prog);
    if (done_here) res->ae_step_s = (mf_now() - t0) / done_here;
    res->ae_loss_first = mean_of(&c->hist, "ae", 0, 5, since);
    res->ae_loss_last = mean_of(&c->hist, "ae", 1, 5, since);
    free(x), free(dy), free(dz);
    mf_ae_work_free(&w);
done:
    mf_adamw_free(&opt);
    return rc;
}

/* Encodes the three kinds of the m selected samples (unscaled) into lat (m, 3, zc, h, h); PSNR of
 * the first 64. */
static int encode_all(MfPrior *p, const Data *d, float *lat, MfTrainPriorResult *res) {
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = R / 4, CH = 16;
    size_t isz = (size_t)3 * R * R, zsz = (size_t)zc * h * h;
    float *x = malloc((size_t)CH * isz * sizeof(float));
    MfAeWork w = {0};
    if (!x) return mf_fail(MF_ENOMEM, "train-prior: out of memory");
    double se[3] = {0, 0, 0};
    size_t cnt[3] = {0, 0, 0};
    int rc = MF_OK;
    for (int k = 0; k < 3 && !rc; ++k)
        for (int i0 = 0; i0 < d->m; i0 += CH) {
            int nb = d->m - i0 < CH ? d->m - i0 : CH;
            for (int b = 0; b < nb; ++b) data_get(d, d->sel[i0 + b], k, x + (size_t)b * isz);
            float *z = mf_ae_encode(p->ae, &w, x, nb);
            if (!z) {
                rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
                break;
            }
            for (int b = 0; b < nb; ++b) memcpy(lat + ((size_t)(i0 + b) * 3 + k) * zsz, z + b * zsz, zsz * sizeof(float));
            if (i0 < 64) {
                float *y = mf_ae_decode(p->ae, &w, z, nb);
                if (!y) {
                    rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
                    break;
                }
                for (size_t j = 0; j < (size_t)nb * isz; ++j) se[k] += (double)(y[j] - x[j]) * (y[j] - x[j]);
                cnt[k] += (size_t)nb * isz;
            }
        }
    for (int k = 0; k < 3; ++k) res->psnr[k] = cnt[k] ? (float)(10.0 * log10(4.0 / fmax(se[k] / cnt[k], 1e-12))) : 0;
    free(x);
    mf_ae_work_free(&w);
    return rc;
}

/* mf_prior_save of p with root (printed) as its extra meta: to path when step < 0, else to
 * path/prior-<step><suffix>.mfck. */
static int save_json(const MfPrior *p, const char *path, int step, const char *suffix, const cJSON *root) {
    char name[48], kept[MF_PATH_MAX];
    int rc = MF_OK;
    if (step >= 0) {
        snprintf(name, sizeof name, "prior-%d%s.mfck", step, suffix);
        if ((rc = mf_path_join(kept, sizeof kept, path, name))) return rc;
        path = kept;
    }
    char *extra = cJSON_PrintUnformatted(root);
    if (!extra) return mf_fail(MF_ENOMEM, "train-prior: out of memory");
    rc = mf_prior_save(p, path, extra);
    free(extra);
    return rc;
}

/* Writes out_dir/prior.mfck with the current weights (the moving average with c->ema) and
 * out_dir/prior-<dn_step>.mfck at a multiple of keep_every (with c->ema also prior-<dn_step>-raw.mfck,
 * the weights themselves); dn_step = denoiser steps done so far. */
static int save_weights(Ctx *c, const MfPrior *p, const Data *d, const MfTrainPriorResult *res, int dn_step) {
    const MfTrainPriorOpts *o = c->o;
    cJSON *t = cJSON_CreateObject(), *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(t, "ae_steps", o->ae_steps);
    cJSON_AddNumberToObject(t, "dn_steps", dn_step);
    cJSON_AddNumberToObject(t, "dn_steps_planned", o->steps);
    cJSON_AddNumberToObject(t, "batch", o->batch);
    cJSON_AddNumberToObject(t, "seed", (double)o->seed);
    cJSON_AddNumberToObject(t, "samples", d->n);
    cJSON_AddNumberToObject(t, "dn_samples", d->m);
    cJSON_AddNumberToObject(t, "lr", round((double)o->lr_dn * 1e9) / 1e9);
    cJSON_AddBoolToObject(t, "lr_cosine", o->lr_cosine);
    for (int k = 0; k < 3; ++k)
        cJSON_AddNumberToObject(t, (const char *[]){"psnr_albedo", "psnr_orm", "psnr_rgb"}[k], round(res->psnr[k] * 1e3) / 1e3);
    if (o->init) cJSON_AddStringToObject(t, "init", o->init);
    if (o->fresh_denoiser) cJSON_AddBoolToObject(t, "fresh_denoiser", 1);
    if (c->ema) cJSON_AddNumberToObject(t, "ema", round((double)o->ema * 1e6) / 1e6);
    cJSON_AddItemToObject(root, "train", t);
    int keep = o->keep_every > 0 && dn_step > 0 && dn_step % o->keep_every == 0, rc = MF_OK;
    size_t np = p->dn->tab.numel;
    float *raw = c->ema ? malloc(np * sizeof(float)) : NULL;
    if (c->ema && !raw) rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
    if (!rc && raw) { /* the weights themselves first (kept steps only), then the average in their place */
        cJSON_AddStringToObject(t, "weights", "raw");
        if (keep) rc = save_json(p, o->out_dir, dn_step, "-raw", root);
        cJSON_ReplaceItemInObject(t, "weights", cJSON_CreateString("average"));
        memcpy(raw, p->dn->params, np * sizeof(float));
        memcpy(p->dn->params, c->ema, np * sizeof(float));
    }
    if (!rc) rc = save_json(p, c->final, -1, NULL, root);
    if (!rc && keep) rc = save_json(p, o->out_dir, dn_step, "", root);
    if (raw) memcpy(p->dn->params, raw, np * sizeof(float)); /* training goes on from the weights */
    if (!rc) c->saved = dn_step;
    cJSON_Delete(root);
    free(raw);
    return rc;
}

static int train_dn(Ctx *c, MfPrior *p, const Data *d, const float *lat, MfTrainPriorResult *res, int *stop) {
    const MfTrainPriorOpts *o = c->o;
    MfDenoiser *dn = p->dn;
    size_t np = dn->tab.numel;
    MfAdamW opt;
    int rc = mf_adamw_init(&opt, np, o->lr_dn, 0.9f, 0.999f, 1e-8f, o->weight_decay);
    if (rc) return rc;
    int step = 0;
    if (o->resume && mf_file_exists(c->dn_state)) {
        if ((rc = state_load(c->dn_state, &dn->tab, dn->params, &opt, &step))) goto done;
        mf_log_info("train-prior: resuming the denoiser at step %d", step);
    }
    if (o->ema > 0) {
        c->ema = malloc(np * sizeof(float));
        if (!c->ema) {
            rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
            goto done;
        }
        if (o->resume && !ema_load(c, &dn->tab, step)) mf_log_info("train-prior: resuming the weights' average (decay %g)", o->ema);
        else {
            memcpy(c->ema, dn->params, np * sizeof(float));
            mf_log_info("train-prior: the weights' average (decay %g) starts from the weights at step %d", o->ema, step);
        }
    }
    int B = o->batch, R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = R / 4;
    size_t isz = (size_t)3 * R * R, zsz = (size_t)zc * h * h, nv = (size_t)B * 2 * zsz;
    float *x = malloc((size_t)B * 3 * zsz * sizeof(float)), *rgb = malloc((size_t)B * isz * sizeof(float));
    float *tgt = malloc(nv * sizeof(float)), *dv = malloc(nv * sizeof(float)), *tt = malloc((size_t)B * sizeof(float));
    float *keep = malloc((size_t)B * sizeof(float)), *eps = malloc(2 * zsz * sizeof(float));
    MfDenoiserWork w = {0};
    if (!x || !rgb || !tgt || !dv || !tt || !keep || !eps) rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
    int since = c->hist.n, done_here = 0;
    MfProgress prog;
    mf_progress_begin(&prog, "denoiser", (size_t)(o->steps > step ? o->steps - step : 0));
    double t0 = mf_now();
    for (; !rc && step < o->steps; ++step) {
        MfRng r;
        mf_rng_seed(&r, o->seed, 0x200000000ull + (uint64_t)step);
        for (int b = 0; b < B; ++b) {
            int j = (int)mf_rng_below(&r, (uint32_t)d->m), i = d->sel[j], t = (int)mf_rng_below(&r, MF_DIFF_T);
            float u = mf_rng_float(&r);
            int drop_emb = u < 0.10f, drop_lat = u >= 0.05f && u < 0.15f; /* 5% emb, 5% both, 5% latent */
            for (size_t j = 0; j < 2 * zsz; ++j) eps[j] = mf_rng_normal(&r);
            const float *li = lat + (size_t)j * 3 * zsz; /* albedo, orm, rgb (scaled) */
            float *xb = x + (size_t)b * 3 * zsz;
            for (size_t j = 0; j < zsz; ++j) xb[j] = drop_lat ? 0.0f : li[2 * zsz + j];
            mf_diffusion_q_sample(&p->diff, xb + zsz, li, eps, t, 2 * zsz);
            mf_diffusion_v_target(&p->diff, tgt + (size_t)b * 2 * zsz, li, eps, t, 2 * zsz);
            data_get(d, i, 2, rgb + (size_t)b * isz);
            tt[b] = (float)t, keep[b] = drop_emb ? 0.0f : 1.0f;
        }
        float *v = mf_denoiser_forward(dn, &w, x, tt, rgb, keep, B, 1, 0);
        if (!v) {
            rc = -1;
            break;
        }
        float loss = mf_mse_forward(v, tgt, nv);
        if (o->nan_at && o->nan_at == o->ae_steps + step + 1) loss = NAN;
        if (!isfinite(loss)) {
            rc = mf_fail(MF_ENAN, "train-prior: denoiser loss is not finite at step %d; stopped, the last good "
                                  "checkpoint is kept (%s)", step + 1, c->dn_state);
            break;
        }
        memset(dn->grads, 0, np * sizeof(float));
        memset(dv, 0, nv * sizeof(float));
        mf_mse_backward(dv, v, tgt, nv, 1.0f);
        mf_denoiser_backward(dn, &w, dv);
        mf_grad_clip_norm(dn->grads, np, 1.0f);
        opt.lr = lr_at(o->lr_dn, step, o->warmup, o->steps, o->lr_cosine);
        if (mf_adamw_step(&opt, dn->params, dn->grads)) {
            rc = mf_fail_prefix(MF_ENAN, "train-prior: denoiser step %d (stopped; the last good checkpoint is kept: %s)",
                                step + 1, c->dn_state);
            break;
        }
        if (c->ema) { /* decay warmed up over the first steps, as in latent diffusion's EMA */
            float dk = fminf(o->ema, (float)(step + 2) / (float)(step + 11));
            for (size_t i = 0; i < np; ++i) c->ema[i] = dk * c->ema[i] + (1.0f - dk) * dn->params[i];
        }
        hist_add(&c->hist, "dn", step + 1, loss, opt.lr);
        mf_progress_add(&prog, 1);
        ++done_here, ++c->ran;
        int last = step + 1 == o->steps, halt = o->stop_after && c->ran >= o->stop_after;
        int keep = o->keep_every > 0 && (step + 1) % o->keep_every == 0;
        if ((o->ckpt_every > 0 && (step + 1) % o->ckpt_every == 0) || last || halt || keep) {
            rc = checkpoint(c, "dn", &dn->tab, dn->params, &opt, step + 1);
            if (!rc) rc = save_weights(c, p, d, res, step + 1); /* a partial run is usable */
        }
        if (halt) {
            *stop = 1;
            break;
        }
    }
    mf_progress_end(&prog);
    if (done_here) res->dn_step_s = (mf_now() - t0) / done_here;
    res->dn_loss_first = mean_of(&c->hist, "dn", 0, 5, since);
    res->dn_loss_last = mean_of(&c->hist, "dn", 1, 5, since);
    free(x), free(rgb), free(tgt), free(dv), free(tt), free(keep), free(eps);
    mf_denoiser_work_free(&w);
done:
    mf_adamw_free(&opt);
    return rc;
}

int mf_train_prior(const MfTrainPriorOpts *o, MfTrainPriorResult *res) {
    memset(res, 0, sizeof *res);
    if (o->batch < 1 || o->steps < 0 || o->ae_steps < !o->init)
        return mf_fail(MF_EARG, "train-prior: need --batch >= 1, --steps >= 0, --ae-steps >= 1");
    if (o->init && (o->ae_steps || o->tiny || o->ae_c1 || o->ae_c2 || (!o->fresh_denoiser && (o->dn_c1 || o->dn_c2))))
        return mf_fail(MF_EARG, "train-prior: --init %s keeps that prior's model and autoencoder: give --ae-steps 0 and "
                                "no --tiny or channel options (denoiser channels only with --fresh-denoiser)", o->init);
    if (o->fresh_denoiser && !o->init) return mf_fail(MF_EARG, "train-prior: --fresh-denoiser needs --init WEIGHTS");
    Data d = {0};
    int rc = data_load(o->data_dir, &d);
    if (rc) return rc;
    MfPriorConfig cfg;
    if (o->tiny) mf_prior_config_tiny(&cfg);
    else mf_prior_config_default(&cfg, d.R);
    if (!o->tiny) {
        if (o->ae_c1 > 0) cfg.ae.c1 = o->ae_c1;
        if (o->ae_c2 > 0) cfg.ae.c2 = o->ae_c2;
        if (o->dn_c1 > 0) cfg.dn.c1 = o->dn_c1;
        if (o->dn_c2 > 0) cfg.dn.c2 = o->dn_c2;
    }
    if (cfg.ae.res != d.R) {
        free(d.px);
        return mf_fail(MF_EARG, "%s: resolution %d, the model expects %d", o->data_dir, d.R, cfg.ae.res);
    }
    MfPrior *p = NULL;
    float *lat = NULL;
    Ctx c = {0};
    int stop = 0;
    c.o = o;
    c.saved = -1;
    c.csv = o->loss_csv ? o->loss_csv : "reports/prior/loss.csv";
    if (o->init) {
        if ((rc = mf_prior_load(o->init, &p))) goto out;
        if (p->cfg.ae.res != d.R) {
            rc = mf_fail(MF_EARG, "train-prior: --init %s is a %d px prior, %s holds %d px samples", o->init, p->cfg.ae.res,
                         o->data_dir, d.R);
            goto out;
        }
        if (o->fresh_denoiser && (o->dn_c1 > 0 || o->dn_c2 > 0)) { /* a denoiser of another size */
            MfPriorConfig fc = p->cfg;
            if (o->dn_c1 > 0) fc.dn.c1 = o->dn_c1;
            if (o->dn_c2 > 0) fc.dn.c2 = o->dn_c2;
            MfPrior *q = NULL;
            if ((rc = mf_prior_new(&q, &fc))) goto out;
            memcpy(q->ae->params, p->ae->params, p->ae->tab.numel * sizeof(float));
            q->latent_scale = p->latent_scale;
            mf_prior_free(p);
            p = q;
        }
        if (o->fresh_denoiser) mf_denoiser_init_weights(p->dn, o->seed);
    } else {
        if ((rc = mf_prior_new(&p, &cfg))) goto out;
        mf_ae_init_weights(p->ae, o->seed);
        mf_denoiser_init_weights(p->dn, o->seed);
    }
    p->data_seed = d.seed;
    res->params = mf_prior_num_params(p);
    if ((rc = mf_mkdirs(o->out_dir))) goto out;
    mf_path_join(c.ae_state, sizeof c.ae_state, o->out_dir, "ae_state.mfck");
    mf_path_join(c.dn_state, sizeof c.dn_state, o->out_dir, "dn_state.mfck");
    mf_path_join(c.dn_ema, sizeof c.dn_ema, o->out_dir, "dn_ema.mfck");
    mf_path_join(c.final, sizeof c.final, o->out_dir, "prior.mfck");
    if (o->resume) {
        int sa = 0, sd = 0;
        char *meta = NULL;
        if (mf_file_exists(c.ae_state) && !mf_prior_read_meta(c.ae_state, &meta)) {
            cJSON *m = cJSON_Parse(meta);
            const cJSON *s = cJSON_GetObjectItemCaseSensitive(m, "step");
            if (cJSON_IsNumber(s)) sa = s->valueint;
            cJSON_Delete(m), free(meta), meta = NULL;
        }
        if (mf_file_exists(c.dn_state) && !mf_prior_read_meta(c.dn_state, &meta)) {
            cJSON *m = cJSON_Parse(meta);
            const cJSON *s = cJSON_GetObjectItemCaseSensitive(m, "step");
            if (cJSON_IsNumber(s)) sd = s->valueint;
            cJSON_Delete(m), free(meta);
        }
        hist_read(&c.hist, c.csv, sa, sd);
    } else {
        remove(c.ae_state), remove(c.dn_state), remove(c.dn_ema);
    }
    mf_log_info("train-prior: %d samples at %d px, %zu parameters, batch %d, %d AE + %d denoiser steps", d.n, d.R,
                res->params, o->batch, o->ae_steps, o->steps);
    if (o->init)
        mf_log_info("train-prior: starting from %s (autoencoder and latent scale %.4f kept%s)", o->init, p->latent_scale,
                    o->fresh_denoiser ? "; the denoiser from random weights" : "");
    else if ((rc = train_ae(&c, p, &d, res, &stop)) || stop) goto out;
    d.m = o->dn_samples > 0 && o->dn_samples < d.n ? o->dn_samples : d.n;
    d.sel = malloc((size_t)d.m * sizeof(int));
    if (!d.sel) {
        rc = mf_fail(MF_ENOMEM, "train-prior: out of memory");
        goto out;
    }
    for (int j = 0; j < d.m; ++j) d.sel[j] = (int)((long long)j * d.n / d.m);
    if (d.m < d.n) mf_log_info("train-prior: the denoiser trains on %d of the %d samples (evenly spread)", d.m, d.n);
    size_t zsz = (size_t)p->cfg.ae.zc * (d.R / 4) * (d.R / 4), nl = (size_t)d.m * 3 * zsz;
    lat = malloc(nl * sizeof(float));
    if (!lat) {
        rc = mf_fail(MF_ENOMEM, "train-prior: out of memory for latents");
        goto out;
    }
    if ((rc = encode_all(p, &d, lat, res))) goto out;
    if (!o->init) { /* a trained denoiser keeps the scale it was trained at */
        double s = 0, s2 = 0;
        for (size_t i = 0; i < nl; ++i) s += lat[i], s2 += (double)lat[i] * lat[i];
        double mean = s / nl, sd = sqrt(fmax(s2 / nl - mean * mean, 1e-12));
        p->latent_scale = (float)(1.0 / sd);
    }
    res->latent_scale = p->latent_scale;
    for (size_t i = 0; i < nl; ++i) lat[i] *= p->latent_scale;
    mf_log_info("train-prior: autoencoder PSNR albedo %.2f dB, ORM %.2f dB, RGB %.2f dB; latent scale %.4f",
                res->psnr[0], res->psnr[1], res->psnr[2], p->latent_scale);
    if ((rc = train_dn(&c, p, &d, lat, res, &stop)) || stop) goto out;
    if (c.saved != o->steps) rc = save_weights(&c, p, &d, res, o->steps); /* e.g. resumed with no step left */
    if (!rc) rc = hist_write(&c.hist, c.csv);
out:
    res->stopped = stop;
    free(lat), free(d.px), free(d.sel), free(c.hist.r), free(c.ema);
    mf_prior_free(p);
    return rc;
}
