/* mf_prior: see mf_prior.h. */
#include "prior/mf_prior.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "io/mf_ckpt.h"

void mf_prior_config_default(MfPriorConfig *c, int res) {
    MfAeConfig ae = {res, 32, 64, 4, 8};
    MfDenoiserConfig dn = {res / 4, 4, 64, 128, 256, 64, 4, 8, res, 32, 64, 128};
    c->ae = ae, c->dn = dn;
}

void mf_prior_config_tiny(MfPriorConfig *c) {
    MfAeConfig ae = {16, 4, 8, 4, 2};
    MfDenoiserConfig dn = {4, 4, 8, 8, 16, 8, 2, 2, 16, 4, 4, 8};
    c->ae = ae, c->dn = dn;
}

int mf_prior_new(MfPrior **out, const MfPriorConfig *cfg) {
    if (cfg->dn.h * 4 != cfg->ae.res || cfg->dn.img_res != cfg->ae.res || cfg->dn.zc != cfg->ae.zc)
        return mf_fail(MF_EARG, "prior: denoiser (h %d, image %d, zc %d) does not match the autoencoder (res %d, zc %d)",
                       cfg->dn.h, cfg->dn.img_res, cfg->dn.zc, cfg->ae.res, cfg->ae.zc);
    MfPrior *p = calloc(1, sizeof *p);
    if (!p) return mf_fail(MF_ENOMEM, "prior: out of memory");
    p->cfg = *cfg;
    p->latent_scale = 1.0f;
    mf_diffusion_init(&p->diff);
    int rc = mf_ae_new(&p->ae, &cfg->ae);
    if (!rc) rc = mf_denoiser_new(&p->dn, &cfg->dn);
    if (rc) {
        mf_prior_free(p);
        return rc;
    }
    *out = p;
    return MF_OK;
}

void mf_prior_free(MfPrior *p) {
    if (!p) return;
    mf_ae_free(p->ae);
    mf_denoiser_free(p->dn);
    mf_ae_work_free(&p->aew);
    mf_ae_work_free(&p->aes);
    mf_denoiser_work_free(&p->dnw);
    free(p->scratch);
    free(p->mat_in);
    free(p);
}

size_t mf_prior_num_params(const MfPrior *p) { return p->ae->tab.numel + p->dn->tab.numel; }

static float *scratch(MfPrior *p, size_t n) {
    if (n > p->scap) {
        float *m = realloc(p->scratch, n * sizeof(float));
        if (!m) return NULL;
        p->scratch = m, p->scap = n;
    }
    return p->scratch;
}

/* ---- weights file ------------------------------------------------------------------------------ */

static cJSON *config_json(const MfPrior *p) {
    const MfAeConfig *a = &p->cfg.ae;
    const MfDenoiserConfig *d = &p->cfg.dn;
    cJSON *m = cJSON_CreateObject();
    cJSON_AddStringToObject(m, "format", "mf-prior");
    cJSON_AddNumberToObject(m, "version", MF_PRIOR_FORMAT_VERSION);
    cJSON_AddNumberToObject(m, "resolution", a->res);
    cJSON_AddNumberToObject(m, "downsample", 4);
    cJSON_AddNumberToObject(m, "latent_channels", a->zc);
    cJSON_AddNumberToObject(m, "latent_scale", p->latent_scale);
    cJSON *e = cJSON_AddObjectToObject(m, "encodings");
    cJSON_AddStringToObject(e, "albedo", MF_PRIOR_ENC_ALBEDO);
    cJSON_AddStringToObject(e, "orm", MF_PRIOR_ENC_ORM);
    cJSON_AddStringToObject(e, "cond", MF_PRIOR_ENC_COND);
    cJSON_AddNumberToObject(m, "data_seed", (double)p->data_seed);
    cJSON *ae = cJSON_AddObjectToObject(m, "ae");
    cJSON_AddNumberToObject(ae, "c1", a->c1);
    cJSON_AddNumberToObject(ae, "c2", a->c2);
    cJSON_AddNumberToObject(ae, "groups", a->groups);
    cJSON *dn = cJSON_AddObjectToObject(m, "dn");
    int vals[] = {d->c1, d->c2, d->ct, d->tfreq, d->heads, d->groups, d->i1, d->i2, d->i3};
    const char *names[] = {"c1", "c2", "ct", "tfreq", "heads", "groups", "i1", "i2", "i3"};
    for (int i = 0; i < 9; ++i) cJSON_AddNumberToObject(dn, names[i], vals[i]);
    cJSON_AddNumberToObject(m, "params", (double)mf_prior_num_params(p));
    return m;
}

/* One table and one buffer of all tensors: AE then denoiser. */
static int all_tensors(const MfPrior *p, MfTensorSpec **specs, int *n, float **data) {
    int na = p->ae->tab.n, nd = p->dn->tab.n;
    size_t ea = p->ae->tab.numel, ed = p->dn->tab.numel;
    *specs = malloc((size_t)(na + nd) * sizeof **specs);
    *data = malloc((ea + ed) * sizeof(float));
    if (!*specs || !*data) {
        free(*specs), free(*data);
        return mf_fail(MF_ENOMEM, "prior: out of memory");
    }
    memcpy(*specs, p->ae->tab.v, (size_t)na * sizeof **specs);
    memcpy(*specs + na, p->dn->tab.v, (size_t)nd * sizeof **specs);
    *n = na + nd;
    return MF_OK;
}

int mf_prior_save(const MfPrior *p, const char *path, const char *extra_json) {
    MfTensorSpec *specs;
    float *data;
    int n, rc = all_tensors(p, &specs, &n, &data);
    if (rc) return rc;
    memcpy(data, p->ae->params, p->ae->tab.numel * sizeof(float));
    memcpy(data + p->ae->tab.numel, p->dn->params, p->dn->tab.numel * sizeof(float));
    cJSON *m = config_json(p);
    if (extra_json) {
        cJSON *x = cJSON_Parse(extra_json);
        if (x) {
            cJSON *it = x->child;
            while (it) {
                cJSON *next = it->next;
                cJSON_AddItemToObject(m, it->string, cJSON_DetachItemViaPointer(x, it));
                it = next;
            }
            cJSON_Delete(x);
        }
    }
    char *meta = cJSON_PrintUnformatted(m);
    cJSON_Delete(m);
    rc = meta ? mf_ckpt_save(path, specs, n, data, meta) : mf_fail(MF_ENOMEM, "prior: out of memory");
    free(meta), free(specs), free(data);
    return rc;
}

#define EXPECT "expected prior weights: an MFCK version 1 checkpoint with mf-prior format 1, written by `mf train-prior`"

int mf_prior_read_meta(const char *path, char **meta) {
    int rc = mf_ckpt_read_meta(path, MF_PRIOR_META_MAX, meta);
    if (rc && rc != MF_ENOMEM) {
        char why[512];
        snprintf(why, sizeof why, "%s", mf_error());
        rc = mf_fail(rc, "%s (%s)", why, EXPECT);
    }
    return rc;
}

static int jint(const cJSON *o, const char *k, int *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= -1e9 && v->valuedouble <= 1e9)) return 0;
    *out = (int)v->valuedouble;
    return 1;
}

/* One size of the model configuration in the meta, range-checked before anything is built from
 * it (zero groups or heads once divided by zero in the layers; huge channel counts would be
 * allocated before the checksum is looked at). Names the field: "meta: dn.groups = 0 ...". */
static int meta_int(const char *path, const cJSON *o, const char *prefix, const char *k, int lo, int hi, int *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!cJSON_IsNumber(v)) return mf_fail(MF_EFORMAT, "%s: meta lacks the model configuration: %s%s (%s)", path, prefix, k, EXPECT);
    double d = v->valuedouble;
    if (!(d >= lo && d <= hi) || d != floor(d))
        return mf_fail(MF_EFORMAT, "%s: meta: %s%s = %g is out of range (an integer %d..%d) (%s)", path, prefix, k, d, lo, hi, EXPECT);
    *out = (int)d;
    return MF_OK;
}

int mf_prior_load(const char *path, MfPrior **out) {
    char *meta = NULL;
    int rc = mf_prior_read_meta(path, &meta);
    if (rc) return rc;
    cJSON *m = cJSON_Parse(meta);
    free(meta);
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(m, "format");
    int ver = 0, res = 0, zc = 0, ds = 0;
    if (!m || !cJSON_IsString(fmt) || strcmp(fmt->valuestring, "mf-prior")) {
        cJSON_Delete(m);
        return mf_fail(MF_EFORMAT, "%s: meta is not mf-prior JSON (%s)", path, EXPECT);
    }
    if (!jint(m, "version", &ver) || ver != MF_PRIOR_FORMAT_VERSION) {
        cJSON_Delete(m);
        return mf_fail(MF_EFORMAT, "%s: unsupported mf-prior format version %d (%s)", path, ver, EXPECT);
    }
    MfPriorConfig c;
    mf_prior_config_default(&c, 64);
    const cJSON *ae = cJSON_GetObjectItemCaseSensitive(m, "ae"), *dn = cJSON_GetObjectItemCaseSensitive(m, "dn");
    const int CH = MF_PRIOR_MAX_CHANNELS;
    rc = (!ae || !dn) ? mf_fail(MF_EFORMAT, "%s: meta lacks the model configuration: ae, dn (%s)", path, EXPECT) : MF_OK;
    if (!rc) rc = meta_int(path, m, "", "resolution", 8, 1024, &res);
    if (!rc) rc = meta_int(path, m, "", "latent_channels", 1, 64, &zc);
    if (!rc) rc = meta_int(path, m, "", "downsample", 4, 4, &ds);
    if (!rc) rc = meta_int(path, ae, "ae.", "c1", 1, CH, &c.ae.c1);
    if (!rc) rc = meta_int(path, ae, "ae.", "c2", 1, CH, &c.ae.c2);
    if (!rc) rc = meta_int(path, ae, "ae.", "groups", 1, CH, &c.ae.groups);
    if (!rc) rc = meta_int(path, dn, "dn.", "c1", 1, CH, &c.dn.c1);
    if (!rc) rc = meta_int(path, dn, "dn.", "c2", 1, CH, &c.dn.c2);
    if (!rc) rc = meta_int(path, dn, "dn.", "ct", 1, CH, &c.dn.ct);
    if (!rc) rc = meta_int(path, dn, "dn.", "tfreq", 2, CH, &c.dn.tfreq);
    if (!rc) rc = meta_int(path, dn, "dn.", "heads", 1, CH, &c.dn.heads);
    if (!rc) rc = meta_int(path, dn, "dn.", "groups", 1, CH, &c.dn.groups);
    if (!rc) rc = meta_int(path, dn, "dn.", "i1", 1, CH, &c.dn.i1);
    if (!rc) rc = meta_int(path, dn, "dn.", "i2", 1, CH, &c.dn.i2);
    if (!rc) rc = meta_int(path, dn, "dn.", "i3", 1, CH, &c.dn.i3);
    if (!rc && res % 8) rc = mf_fail(MF_EFORMAT, "%s: meta: resolution %d is not a multiple of 8 (%s)", path, res, EXPECT);
    const cJSON *ls = cJSON_GetObjectItemCaseSensitive(m, "latent_scale"),
                *sd = cJSON_GetObjectItemCaseSensitive(m, "data_seed");
    double lsd = cJSON_IsNumber(ls) ? ls->valuedouble : NAN, sdd = cJSON_IsNumber(sd) ? sd->valuedouble : 0.0;
    if (!rc && !(lsd > 0.0 && lsd < 1e30))
        rc = mf_fail(MF_EFORMAT, "%s: meta: latent_scale is missing or not a positive finite number (%s)", path, EXPECT);
    float lscale = (float)lsd;
    uint64_t dseed = (sdd >= 0.0 && sdd < 18446744073709551616.0) ? (uint64_t)sdd : 0;
    cJSON_Delete(m);
    if (rc) return rc;
    c.ae.res = res, c.ae.zc = zc, c.dn.h = res / 4, c.dn.zc = zc, c.dn.img_res = res;
    /* the configuration's weights must fit in the file before the model (weights and gradients)
     * is allocated: counted from the layer tables alone */
    size_t nae = 0, ndn = 0;
    if ((rc = mf_ae_numel(&c.ae, &nae)) || (rc = mf_denoiser_numel(&c.dn, &ndn))) return mf_fail_prefix(rc, "%s", path);
    struct stat st;
    size_t need = (nae + ndn) * sizeof(float);
    if (stat(path, &st) == 0 && (uint64_t)st.st_size < need)
        return mf_fail(MF_EFORMAT, "%s: truncated: the meta's configuration has %zu weights (%zu bytes), the file has %lld bytes (%s)",
                       path, need / sizeof(float), need, (long long)st.st_size, EXPECT);
    MfPrior *p;
    if ((rc = mf_prior_new(&p, &c))) return mf_fail_prefix(rc, "%s", path);
    MfTensorSpec *specs;
    float *data;
    int n;
    if ((rc = all_tensors(p, &specs, &n, &data))) {
        mf_prior_free(p);
        return rc;
    }
    rc = mf_ckpt_load(path, specs, n, data, NULL);
    if (rc) {
        char msg[1024];
        snprintf(msg, sizeof msg, "%s", mf_error());
        free(specs), free(data), mf_prior_free(p);
        return mf_fail(rc, "%s (%s)", msg, EXPECT);
    }
    memcpy(p->ae->params, data, p->ae->tab.numel * sizeof(float));
    memcpy(p->dn->params, data + p->ae->tab.numel, p->dn->tab.numel * sizeof(float));
    free(specs), free(data);
    p->latent_scale = lscale;
    p->data_seed = dseed;
    *out = p;
    return MF_OK;
}

/* ---- encode / decode ------------------------------------------------------------------------ */

int mf_prior_encode(MfPrior *p, const float *img, int B, float *z) {
    float *zz = mf_ae_encode(p->ae, &p->aew, img, B);
    if (!zz) return mf_fail(MF_ENOMEM, "prior: out of memory (encoder)");
    size_t n = (size_t)B * p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    for (size_t i = 0; i < n; ++i) z[i] = zz[i] * p->latent_scale;
    return MF_OK;
}

void mf_prior_encode_backward(MfPrior *p, const float *dz, float *dimg) {
    int B = p->aew.enc.B;
    size_t n = (size_t)B * p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    float *g = scratch(p, n);
    if (!g) return;
    for (size_t i = 0; i < n; ++i) g[i] = dz[i] * p->latent_scale;
    mf_ae_encode_backward_input(p->ae, &p->aew, g, dimg);
}

static int decode_with(MfPrior *p, MfAeWork *w, const float *z, int B, float *img) {
    size_t n = (size_t)B * p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    float *zs = malloc(n * sizeof(float));
    if (!zs) return mf_fail(MF_ENOMEM, "prior: out of memory");
    for (size_t i = 0; i < n; ++i) zs[i] = z[i] / p->latent_scale;
    float *o = mf_ae_decode(p->ae, w, zs, B);
    if (o) memcpy(img, o, (size_t)B * 3 * p->cfg.ae.res * p->cfg.ae.res * sizeof(float));
    free(zs);
    return o ? MF_OK : mf_fail(MF_ENOMEM, "prior: out of memory (decoder)");
}

int mf_prior_decode(MfPrior *p, const float *z, int B, float *img) { return decode_with(p, &p->aew, z, B, img); }

int mf_prior_encode_materials(MfPrior *p, const float *albedo, const float *orm, int B, float *zmat) {
    size_t ni = (size_t)3 * p->cfg.ae.res * p->cfg.ae.res, nz = (size_t)p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    size_t need = 2 * (size_t)B * (ni + nz);
    if (need > p->mat_cap) {
        float *m = realloc(p->mat_in, need * sizeof(float));
        if (!m) return mf_fail(MF_ENOMEM, "prior: out of memory");
        p->mat_in = m, p->mat_cap = need;
    }
    float *in = p->mat_in, *z = in + 2 * (size_t)B * ni;
    memcpy(in, albedo, (size_t)B * ni * sizeof(float));
    memcpy(in + (size_t)B * ni, orm, (size_t)B * ni * sizeof(float));
    int rc = mf_prior_encode(p, in, 2 * B, z);
    if (!rc)
        for (int b = 0; b < B; ++b) {
            memcpy(zmat + (size_t)b * 2 * nz, z + (size_t)b * nz, nz * sizeof(float));
            memcpy(zmat + (size_t)b * 2 * nz + nz, z + (size_t)(B + b) * nz, nz * sizeof(float));
        }
    return rc;
}

int mf_prior_encode_materials_backward(MfPrior *p, const float *dzmat, float *dalbedo, float *dorm) {
    int B2 = p->aew.enc.B, B = B2 / 2;
    size_t ni = (size_t)3 * p->cfg.ae.res * p->cfg.ae.res, nz = (size_t)p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    float *buf = calloc((size_t)B2 * (nz + ni), sizeof(float));
    if (!buf) return mf_fail(MF_ENOMEM, "prior: out of memory");
    float *dz = buf, *din = buf + (size_t)B2 * nz;
    for (int b = 0; b < B; ++b) {
        memcpy(dz + (size_t)b * nz, dzmat + (size_t)b * 2 * nz, nz * sizeof(float));
        memcpy(dz + (size_t)(B + b) * nz, dzmat + (size_t)b * 2 * nz + nz, nz * sizeof(float));
    }
    mf_prior_encode_backward(p, dz, din);
    for (size_t i = 0; i < (size_t)B * ni; ++i) {
        if (dalbedo) dalbedo[i] += din[i];
        if (dorm) dorm[i] += din[(size_t)B * ni + i];
    }
    free(buf);
    return MF_OK;
}

int mf_prior_decode_materials(MfPrior *p, const float *zmat, int B, float *albedo, float *orm) {
    size_t ni = (size_t)3 * p->cfg.ae.res * p->cfg.ae.res, nz = (size_t)p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    float *buf = malloc(2 * (size_t)B * (nz + ni) * sizeof(float));
    if (!buf) return mf_fail(MF_ENOMEM, "prior: out of memory");
    float *z = buf, *img = buf + 2 * (size_t)B * nz;
    for (int b = 0; b < B; ++b) {
        memcpy(z + (size_t)b * nz, zmat + (size_t)b * 2 * nz, nz * sizeof(float));
        memcpy(z + (size_t)(B + b) * nz, zmat + (size_t)b * 2 * nz + nz, nz * sizeof(float));
    }
    int rc = mf_prior_decode(p, z, 2 * B, img);
    if (!rc) {
        memcpy(albedo, img, (size_t)B * ni * sizeof(float));
        memcpy(orm, img + (size_t)B * ni, (size_t)B * ni * sizeof(float));
    }
    free(buf);
    return rc;
}

/* ---- guided denoising -------------------------------------------------------------------------- */

/* mf_prior_guided_v; same_rgb: rgb (and B, V, joint) are those of the previous call (the denoiser
 * reuses its image embedding). */
static int guided_v(MfPrior *p, const float *zimg, const float *rgb, const float *xt, int t, int B, int V, int joint,
                    float guidance, int same_rgb, float *v) {
    int zc = p->cfg.ae.zc, h = p->cfg.dn.h, R = p->cfg.ae.res;
    size_t hw = (size_t)h * h, nz = zc * hw, nx = 3 * nz, nv = 2 * nz, ni = (size_t)3 * R * R;
    int B2 = guidance == 1.0f ? B : 2 * B; /* guidance 1 is the conditional prediction alone: no unconditional half */
    float *x = malloc(((size_t)B2 * nx + (size_t)B2 * ni + 2 * (size_t)B2) * sizeof(float));
    if (!x) return mf_fail(MF_ENOMEM, "prior: out of memory");
    float *rgb2 = x + (size_t)B2 * nx, *tt = rgb2 + (size_t)B2 * ni, *keep = tt + B2;
    for (int b = 0; b < B2; ++b) {
        int src = b % B, cond = b < B;
        float *xb = x + (size_t)b * nx;
        if (cond) memcpy(xb, zimg + (size_t)src * nz, nz * sizeof(float));
        else memset(xb, 0, nz * sizeof(float));
        memcpy(xb + nz, xt + (size_t)src * nv, nv * sizeof(float));
        memcpy(rgb2 + (size_t)b * ni, rgb + (size_t)src * ni, ni * sizeof(float));
        tt[b] = (float)t, keep[b] = cond ? 1.0f : 0.0f;
    }
    float *out = mf_denoiser_forward_ex(p->dn, &p->dnw, x, tt, rgb2, keep, B2, V, joint, same_rgb);
    if (out && B2 == B) memcpy(v, out, (size_t)B * nv * sizeof(float));
    else if (out) mf_diffusion_cfg(v, out + (size_t)B * nv, out, guidance, (size_t)B * nv);
    free(x);
    return out ? MF_OK : -1;
}

int mf_prior_guided_v(MfPrior *p, const float *zimg, const float *rgb, const float *xt, int t, int B, int V,
                      int joint, float guidance, float *v) {
    return guided_v(p, zimg, rgb, xt, t, B, V, joint, guidance, 0, v);
}

typedef struct {
    MfPrior *p;
    const float *zimg, *rgb;
    int B, V, joint;
    float guidance;
    int calls; /* steps so far: after the first, the condition images' embedding is reused */
} GuideCtx;

static int guide_fn(void *ctx, float *v, const float *xt, int t) {
    GuideCtx *g = ctx;
    return guided_v(g->p, g->zimg, g->rgb, xt, t, g->B, g->V, g->joint, g->guidance, g->calls++ > 0, v);
}

static int run_ddim(MfPrior *p, const float *rgb, int B, int V, int joint, float guidance, const int *steps,
                    int nsteps, float *x) {
    int zc = p->cfg.ae.zc, h = p->cfg.dn.h;
    size_t nz = (size_t)zc * h * h;
    float *zimg = malloc((size_t)B * nz * sizeof(float)), *v = malloc((size_t)B * 2 * nz * sizeof(float));
    int rc = (!zimg || !v) ? mf_fail(MF_ENOMEM, "prior: out of memory") : MF_OK;
    if (!rc) {
        float *zz = mf_ae_encode(p->ae, &p->aes, rgb, B);
        if (!zz) rc = mf_fail(MF_ENOMEM, "prior: out of memory (encoder)");
        else
            for (size_t i = 0; i < (size_t)B * nz; ++i) zimg[i] = zz[i] * p->latent_scale;
    }
    if (!rc) {
        GuideCtx g = {p, zimg, rgb, B, V, joint, guidance, 0};
        rc = mf_diffusion_ddim(&p->diff, x, v, (size_t)B * 2 * nz, steps, nsteps, guide_fn, &g);
    }
    free(zimg), free(v);
    return rc;
}

int mf_prior_sample(MfPrior *p, const float *rgb, int B, int V, int joint, int nsteps, float guidance,
                    uint64_t seed, float *zmat) {
    if (nsteps < 1 || nsteps > MF_DIFF_T) return mf_fail(MF_EARG, "prior: --steps must be 1..%d", MF_DIFF_T);
    size_t n = (size_t)B * 2 * p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    int *steps = malloc((size_t)nsteps * sizeof(int));
    if (!steps) return mf_fail(MF_ENOMEM, "prior: out of memory");
    mf_diffusion_inference_steps(steps, nsteps);
    MfRng r;
    mf_rng_seed(&r, seed, 0x5a3b1e);
    for (size_t i = 0; i < n; ++i) zmat[i] = mf_rng_normal(&r);
    int rc = run_ddim(p, rgb, B, V, joint, guidance, steps, nsteps, zmat);
    free(steps);
    return rc;
}

int mf_prior_sds_denoise(MfPrior *p, const float *zmat, const float *rgb, int B, int V, int joint, int t,
                         float guidance, uint64_t seed, float *zhat) {
    if (t < 5 || t >= MF_DIFF_T) return mf_fail(MF_EARG, "prior: SDS timestep %d outside 5..%d", t, MF_DIFF_T - 1);
    size_t n = (size_t)B * 2 * p->cfg.ae.zc * p->cfg.dn.h * p->cfg.dn.h;
    float *eps = malloc(n * sizeof(float));
    if (!eps) return mf_fail(MF_ENOMEM, "prior: out of memory");
    MfRng r;
    mf_rng_seed(&r, seed, 0x5d5);
    for (size_t i = 0; i < n; ++i) eps[i] = mf_rng_normal(&r);
    mf_diffusion_q_sample(&p->diff, zhat, zmat, eps, t, n);
    free(eps);
    int steps[5] = {t, (int)(0.8 * t), (int)(0.6 * t), (int)(0.4 * t), (int)(0.2 * t)};
    return run_ddim(p, rgb, B, V, joint, guidance, steps, 5, zhat);
}

/* ---- input images ------------------------------------------------------------------------------- */

/* Area-weighted box filter of one axis: weights of source pixels for destination pixel i. */
void mf_prior_prepare_image(const float *rgba, int w, int h, int R, float *out, float *mask) {
    double sx = (double)w / R, sy = (double)h / R;
    for (int y = 0; y < R; ++y)
        for (int x = 0; x < R; ++x) {
            double y0 = y * sy, y1 = (y + 1) * sy, x0 = x * sx, x1 = (x + 1) * sx;
            double acc[4] = {0, 0, 0, 0}, wsum = 0.0;
            for (int j = (int)floor(y0); j < (int)ceil(y1) && j < h; ++j) {
                double wy = fmin(y1, j + 1.0) - fmax(y0, (double)j);
                if (wy <= 0) continue;
                for (int i = (int)floor(x0); i < (int)ceil(x1) && i < w; ++i) {
                    double wx = fmin(x1, i + 1.0) - fmax(x0, (double)i);
                    if (wx <= 0) continue;
                    const float *px = rgba + ((size_t)j * w + i) * 4;
                    double ww = wx * wy, a = px[3];
                    for (int c = 0; c < 3; ++c) acc[c] += ww * px[c] * a;
                    acc[3] += ww * a, wsum += ww;
                }
            }
            double a = acc[3] / wsum;
            for (int c = 0; c < 3; ++c) out[((size_t)c * R + y) * R + x] = (float)(2.0 * acc[c] / wsum - a);
            if (mask) mask[(size_t)y * R + x] = (float)a;
        }
}

/* "x.mfck" stays; anything else is taken as a folder holding prior.mfck. */
static void weights_file(char *buf, size_t n, const char *path) {
    size_t l = strlen(path);
    if (l >= 5 && !strcmp(path + l - 5, ".mfck")) snprintf(buf, n, "%s", path);
    else mf_path_join(buf, n, path, "prior.mfck");
}

void mf_prior_default_weights(char *buf, size_t n) {
    const char *env = getenv(MF_PRIOR_WEIGHTS_ENV);
    if (env && *env) {
        weights_file(buf, n, env);
        return;
    }
    snprintf(buf, n, "%s", MF_PRIOR_WEIGHTS_DEFAULT);
    if (mf_file_exists(buf)) return;
    char exe[MF_PATH_MAX];
    ssize_t l = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (l <= 0) return;
    exe[l] = 0;
    char *slash = strrchr(exe, '/');
    if (!slash) return;
    *slash = 0; /* exe dir, e.g. <repo>/build */
    char cand[MF_PATH_MAX];
    if (snprintf(cand, sizeof cand, "%s/../%s", exe, MF_PRIOR_WEIGHTS_DEFAULT) < (int)sizeof cand && mf_file_exists(cand))
        snprintf(buf, n, "%s", cand);
}

int mf_prior_load_path(const char *path, MfPrior **out) {
    char file[MF_PATH_MAX];
    if (path) weights_file(file, sizeof file, path);
    else mf_prior_default_weights(file, sizeof file);
    return mf_prior_load(file, out);
}
