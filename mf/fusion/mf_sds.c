#include "fusion/mf_sds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "inverse/mf_budget.h"
#include "render/mf_diffrender.h"
#include "io/mf_image.h"
#include "nn/mf_nn.h"

struct MfSds {
    MfPrior *prior; /* owned */
    MfSdsOpts o;
    /* the term's texel gradient (without gamma), refreshed every o.every iterations and applied
     * at every iteration in between */
    float *held_kd;  /* (tex kd n,) owned */
    float *held_orm; /* (tex ORM n,) owned */
    size_t held_n;
    float *coverage; /* (texels,) owned; with MF_SDS_WEIGHT_COVERAGE or _VIEWS: the trust weight of each
                        texel (of the kd texture; with _VIEWS that of the ORM texture in cov_orm) */
    float *cov_orm;  /* (texels,) owned; MF_SDS_WEIGHT_VIEWS only */
    size_t coverage_n;
    int held_it;     /* iteration of the last refresh, -1: none */
    double held_loss;
    /* --sds-target mean: the held targets of each training view, filled when a view is first picked */
    int mean_nv;          /* views of the cache */
    unsigned char *have;  /* (mean_nv,) 1: the view's targets are computed */
    float *mz, *md;       /* (mean_nv, 2zc, h, h) latents, (mean_nv, 2, 3, R, R) decoded maps: the means */
    float *mzv, *mdv;     /* the same shapes: variances over the samples (spread weighting only) */
    double seconds;  /* wall time of the refreshes */
    MfSdsTimes times; /* the same and the applies, by stage */
};

int mf_sds_new(MfPrior *prior, const MfSdsOpts *o, MfSds **out) {
    if (o->k_views < 1 || o->k_views > MF_SDS_MAX_VIEWS || o->t_min < 1 || o->t_max > 999 || o->t_min > o->t_max ||
        o->aov_samples < 1 || o->every < 0)
        return mf_fail(MF_EARG, "SDS options: k_views %d (1..%d), t in [%d, %d] (1..999), aov_samples %d, every %d (>= 0) are invalid",
                       o->k_views, MF_SDS_MAX_VIEWS, o->t_min, o->t_max, o->aov_samples, o->every);
    if (o->weight < MF_SDS_WEIGHT_NONE || o->weight > MF_SDS_WEIGHT_VIEWS)
        return mf_fail(MF_EARG, "SDS options: weight %d is not none (0), conflict (1), coverage (2), spread (3) or views (4)",
                       o->weight);
    if (o->weight == MF_SDS_WEIGHT_VIEWS && o->target != MF_SDS_TARGET_MEAN)
        return mf_fail(MF_EARG, "SDS options: --sds-weight views needs --sds-target mean (the views' held targets)");
    if (o->draws < 1 || o->draws > MF_SDS_MAX_DRAWS ||
        (o->weight == MF_SDS_WEIGHT_SPREAD && o->draws < 2 && o->target == MF_SDS_TARGET_DDIM))
        return mf_fail(MF_EARG, "SDS options: --sds-draws %d (1..%d; --sds-weight spread needs >= 2, the spread is over the draws)",
                       o->draws, MF_SDS_MAX_DRAWS);
    if (!(o->trust_rough >= 0.0f && o->trust_rough <= 1.0f && o->trust_metal >= 0.0f && o->trust_metal <= 1.0f))
        return mf_fail(MF_EARG, "SDS options: channel trust roughness %g, metallic %g (each in [0, 1])", o->trust_rough,
                       o->trust_metal);
    if (o->target < MF_SDS_TARGET_DDIM || o->target > MF_SDS_TARGET_MEAN || o->mean_samples < 1 || o->mean_steps < 1 ||
        o->mean_steps > MF_DIFF_T || (o->target == MF_SDS_TARGET_MEAN && o->weight == MF_SDS_WEIGHT_SPREAD && o->mean_samples < 2))
        return mf_fail(MF_EARG, "SDS options: --sds-target %d (ddim 0, mean 1), --sds-mean-samples %d (>= 1; spread weighting "
                       "needs >= 2), --sds-mean-steps %d (1..%d)", o->target, o->mean_samples, o->mean_steps, MF_DIFF_T);
    MfSds *s = calloc(1, sizeof *s);
    if (!s) return mf_fail(MF_ENOMEM, "out of memory");
    s->prior = prior;
    s->o = *o;
    if (o->prior_threads > 0) mf_nn_set_threads(o->prior_threads);
    s->held_it = -1;
    *out = s;
    return MF_OK;
}

int mf_sds_every_auto(int w, int h) {
    double k = ceil(4.0 * 128.0 * 128.0 / ((double)w * h));
    return !(k < 1e6) ? 1000000 : k < 4.0 ? 4 : (int)k; /* also a size of 0 */
}

int mf_sds_every(const MfSds *s) { return s ? s->o.every : 0; }

double mf_sds_seconds(const MfSds *s) { return s ? s->seconds : 0.0; }
void mf_sds_times(const MfSds *s, MfSdsTimes *t) {
    if (s) *t = s->times;
    else memset(t, 0, sizeof *t);
}

void mf_sds_free(MfSds *s) {
    if (!s) return;
    mf_prior_free(s->prior);
    free(s->held_kd), free(s->held_orm), free(s->coverage), free(s->cov_orm);
    free(s->have), free(s->mz), free(s->md), free(s->mzv), free(s->mdv);
    free(s);
}

void mf_sds_targets_free(MfSdsTargets *t) {
    free(t->zhat);
    free(t->dhat);
    free(t->cond);
    free(t->mask);
    free(t->zvar);
    free(t->dvar);
    memset(t, 0, sizeof *t);
}

static int res_of(const MfSds *s) { return s->prior->cfg.ae.res; }
static int lat_of(const MfSds *s) { return s->prior->cfg.ae.res / 4; } /* the autoencoder downsamples by 4 */
static int zc_of(const MfSds *s) { return s->prior->cfg.ae.zc; }

static uint64_t view_seed(const MfSds *s, int it, int view, uint64_t what) {
    return mf_hash64(mf_hash64(mf_hash64(s->o.seed, (uint64_t)it), (uint64_t)view), what);
}

static float srgb_deriv(float l) {
    if (!(l > 0.0031308f)) return l >= 0.0f ? 12.92f : 0.0f;
    if (l >= 1.0f) return 0.0f; /* clipped */
    return (1.055f / 2.4f) * powf(l, 1.0f / 2.4f - 1.0f);
}

/* Material maps of the current textures for the batch: ain, oin (n, 3, R, R) prepared as the
 * prior's inputs; aa, ao (n, R, R, 3) keep the linear AOVs for the backward. */
static int render_maps(MfSds *s, MfRecon *r, const MfSdsTargets *t, float *ain, float *oin, float *aa, float *ao) {
    int R = res_of(s);
    size_t rr = (size_t)R * R;
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r);
    MfDiffScene ds = {.rt = mf_recon_rtscene(r), .kd = &kd, .orm = &orm, .env = mf_recon_env(r)};
    for (int k = 0; k < t->n; ++k) {
        MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = s->o.aov_samples, .seed = t->aov_seed[k]};
        float *a = aa + k * 3 * rr, *m = ao + k * 3 * rr;
        const float *mask = t->mask + k * rr;
        int rc = mf_diff_aov_forward(&ds, &t->cam[k], &o, a, m, NULL);
        if (rc) return rc;
        for (int c = 0; c < 3; ++c)
            for (size_t p = 0; p < rr; ++p) {
                float av = mf_clampf(a[3 * p + c], 0.0f, 1.0f), mv = mf_clampf(m[3 * p + c], 0.0f, 1.0f);
                ain[(k * 3 + c) * rr + p] = (2.0f * mf_linear_to_srgb(av) - 1.0f) * mask[p];
                oin[(k * 3 + c) * rr + p] = (2.0f * mv - 1.0f) * mask[p];
            }
    }
    return MF_OK;
}

/* The current textures' prepared maps and their latents for a batch: ain, oin (n, 3, R, R) prior
 * inputs; aa, ao (n, R, R, 3) linear AOVs; z (n, 2zc, h, h). The prior's encoder cache holds the
 * encode of ain/oin until its next encode (the denoiser and decoder use other work buffers). */
typedef struct {
    float *ain, *oin, *aa, *ao, *z;
} Maps;

static void maps_free(Maps *m) {
    free(m->ain), free(m->oin), free(m->aa), free(m->ao), free(m->z);
    memset(m, 0, sizeof *m);
}

static int maps_compute(MfSds *s, MfRecon *r, const MfSdsTargets *t, Maps *m) {
    size_t rr = (size_t)res_of(s) * res_of(s), nm = (size_t)t->n * 3 * rr;
    size_t nz = (size_t)t->n * 2 * zc_of(s) * lat_of(s) * lat_of(s);
    memset(m, 0, sizeof *m);
    m->ain = malloc(nm * sizeof(float)), m->oin = malloc(nm * sizeof(float));
    m->aa = malloc(nm * sizeof(float)), m->ao = malloc(nm * sizeof(float)), m->z = malloc(nz * sizeof(float));
    int rc = (!m->ain || !m->oin || !m->aa || !m->ao || !m->z) ? mf_fail(MF_ENOMEM, "SDS: out of memory") : MF_OK;
    MfStageClock ts = mf_stage_clock();
    if (!rc) rc = render_maps(s, r, t, m->ain, m->oin, m->aa, m->ao);
    mf_stage_lap(&s->times.aov, &ts);
    if (!rc) rc = mf_prior_encode_materials(s->prior, m->ain, m->oin, t->n, m->z);
    mf_stage_lap(&s->times.encode, &ts);
    if (rc) maps_free(m);
    return rc;
}

/* Welford step: mean and m2 (n,) take draw x (n,) as the k-th (k >= 2). */
static void welford(float *mean, float *m2, const float *x, size_t n, int k) {
    for (size_t i = 0; i < n; ++i) {
        float d = x[i] - mean[i];
        mean[i] += d / (float)k;
        m2[i] += d * (x[i] - mean[i]);
    }
}

/* t->zhat (nz) and t->dhat (nd) for the batch's latents z: the mean over o.draws noise draws at
 * t->t (the first draw's seed is the single-draw one), t->zvar / t->dvar their sample variances. */
static int draws(MfSds *s, MfSdsTargets *t, const float *z, int it, size_t nz, size_t nd) {
    int D = s->o.draws, n = t->n, rc = MF_OK;
    float *zd = NULL, *dd = NULL;
    if (D > 1) {
        t->zvar = calloc(nz, sizeof(float)), t->dvar = calloc(nd, sizeof(float));
        zd = malloc(nz * sizeof(float)), dd = malloc(nd * sizeof(float));
        if (!t->zvar || !t->dvar || !zd || !dd) rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
    }
    for (int d = 0; d < D && !rc; ++d) {
        MfStageClock ts = mf_stage_clock();
        float *zo = d ? zd : t->zhat, *dout = d ? dd : t->dhat;
        uint64_t seed = view_seed(s, it, -1, d ? 0x100u + (uint64_t)d : 3);
        rc = mf_prior_sds_denoise(s->prior, z, t->cond, n, s->o.mv ? n : 1, s->o.mv, t->t, s->o.guidance, seed, zo);
        mf_stage_lap(&s->times.denoise, &ts);
        if (!rc) rc = mf_prior_decode_materials(s->prior, zo, n, dout, dout + nd / 2);
        mf_stage_lap(&s->times.decode, &ts);
        if (!rc && d) welford(t->zhat, t->zvar, zd, nz, d + 1), welford(t->dhat, t->dvar, dd, nd, d + 1);
    }
    for (size_t i = 0; i < nz && D > 1 && !rc; ++i) t->zvar[i] /= (float)(D - 1);
    for (size_t i = 0; i < nd && D > 1 && !rc; ++i) t->dvar[i] /= (float)(D - 1);
    free(zd), free(dd);
    return rc;
}

/* The trust weights of the spread and views weightings: over the elements with m[i] > thr,
 * w = 1 / (1 + var / var_ref) (var_ref their mean variance), scaled to mean 1 over them; w = 1
 * elsewhere, and everywhere when none of them varies. w may be var (in place). Returns var_ref. */
static double variance_weights(const float *var, const float *m, float thr, size_t n, float *w) {
    double vs = 0.0, cnt = 0.0;
    for (size_t i = 0; i < n; ++i)
        if (m[i] > thr) vs += var[i], cnt += 1.0;
    double vref = cnt > 0.0 ? vs / cnt : 0.0, ws = 0.0;
    for (size_t i = 0; i < n; ++i) {
        w[i] = vref > 0.0 && m[i] > thr ? (float)(1.0 / (1.0 + var[i] / vref)) : 1.0f;
        if (m[i] > thr) ws += w[i];
    }
    float scale = ws > 0.0 ? (float)(cnt / ws) : 1.0f; /* mean 1 over the weighted elements */
    for (size_t i = 0; i < n; ++i)
        if (m[i] > thr) w[i] *= scale;
    return vref;
}

void mf_sds_spread_weights(const float *var, const float *m, size_t n, float *w) { variance_weights(var, m, 0.0f, n, w); }

/* The view's camera at R x R (the same field of view). */
static int prior_camera(const MfCamera *cam, int R, MfCamera *out) {
    double ax = 2.0 * atan((double)cam->w / (2.0 * (double)cam->fx)), m[16];
    for (int i = 0; i < 16; ++i) m[i] = cam->c2w.m[i];
    return mf_camera_init(out, R, R, ax, m, "SDS camera");
}

/* The prior's condition image cond (3, R, R) and mask (R, R) of training view `view`: its reference
 * image as straight-alpha sRGB in [0, 1], box-filtered to R (mf_prior_prepare_image). *rgba: a work
 * buffer, grown here (the caller frees it). */
static int view_cond(MfSds *s, MfRecon *r, int view, float **rgba, float *cond, float *mask) {
    const MfReconView *v = mf_recon_view(r, view);
    int w = v->ref.w, H = v->ref.h;
    if (w != H) return mf_fail(MF_EARG, "SDS: view %d is %dx%d; the prior term needs square views", view, w, H);
    size_t npx = (size_t)w * H;
    float *nr = realloc(*rgba, npx * 4 * sizeof(float));
    if (!nr) return mf_fail(MF_ENOMEM, "SDS: out of memory");
    *rgba = nr;
    for (size_t p = 0; p < npx; ++p) {
        float a = v->ref.data[4 * p + 3];
        for (int c = 0; c < 3; ++c)
            nr[4 * p + c] = a > 0.0f ? mf_clampf(mf_linear_to_srgb(v->ref.data[4 * p + c] / a), 0.0f, 1.0f) : 0.0f;
        nr[4 * p + 3] = a;
    }
    mf_prior_prepare_image(nr, w, H, res_of(s), cond, mask);
    return MF_OK;
}

void mf_sds_mv_group(int ntrain, int p, int *start, int *size, int *own_from) {
    int V = ntrain < MF_SDS_MV_VIEWS ? ntrain : MF_SDS_MV_VIEWS, full = V > 0 ? ntrain / V * V : 0;
    *size = V;
    if (p < full) *start = *own_from = p / V * V;
    else *start = ntrain - V, *own_from = full;
}

/* The held mean targets of the group of training views mem (G,), of which mem[own..] get them:
 * mean_samples samples of mean_steps guided DDIM steps from pure noise, the G views of a sample
 * denoised jointly (joint) or each alone, decoded; the means over the samples of the latents and
 * maps (and with spread their variances) go to the cache. */
static int mean_group(MfSds *s, MfRecon *r, const int *mem, int G, int own, int joint, uint64_t seed, float **rgba) {
    int R = res_of(s), h = lat_of(s), zc = zc_of(s), S = s->o.mean_samples, SG = S * G, var = s->o.weight == MF_SDS_WEIGHT_SPREAD;
    size_t isz = (size_t)3 * R * R, zsz = (size_t)2 * zc * h * h; /* one view's condition image and latents */
    /* work: rgb (S, G, 3, R, R) the condition images, sample-major; zs (S, G, 2zc, h, h) the samples;
     * dec (2, S, G, 3, R, R) their decoded albedo and ORM maps; m2 (zsz + 2 isz) the sums of squared
     * deviations (latents, albedo map, ORM map); mask (R, R) */
    float *work = malloc(((size_t)SG * (3 * isz + zsz) + zsz + 2 * isz + isz / 3) * sizeof(float));
    if (!work) return mf_fail(MF_ENOMEM, "SDS: out of memory");
    float *rgb = work, *zs = rgb + SG * isz, *dec = zs + SG * zsz, *m2 = dec + 2 * SG * isz, *mask = m2 + zsz + 2 * isz;
    int rc = MF_OK;
    MfStageClock ts = mf_stage_clock();
    for (int g = 0; g < G && !rc; ++g) rc = view_cond(s, r, mem[g], rgba, rgb + g * isz, mask);
    for (int j = 1; j < S && !rc; ++j) memcpy(rgb + (size_t)j * G * isz, rgb, G * isz * sizeof(float));
    mf_stage_lap(&s->times.cond, &ts);
    if (!rc) rc = mf_prior_sample(s->prior, rgb, SG, joint ? G : 1, joint, s->o.mean_steps, s->o.guidance, seed, zs);
    mf_stage_lap(&s->times.denoise, &ts);
    if (!rc) rc = mf_prior_decode_materials(s->prior, zs, SG, dec, dec + SG * isz);
    mf_stage_lap(&s->times.decode, &ts);
    for (int g = own; g < G && !rc; ++g) {
        size_t v = (size_t)mem[g];
        float *mz = s->mz + v * zsz, *md = s->md + v * 2 * isz; /* the view's means: latents; albedo, ORM maps */
        for (int j = 0; j < S; ++j)
            for (int part = 0; part < 3; ++part) { /* latents, albedo map, ORM map */
                size_t n = part ? isz : zsz, item = (size_t)j * G + g;
                float *mean = part ? md + (part - 1) * isz : mz, *dev = part ? m2 + zsz + (part - 1) * isz : m2;
                const float *x = part ? dec + ((size_t)(part - 1) * SG + item) * isz : zs + item * zsz;
                if (j == 0) memcpy(mean, x, n * sizeof(float)), memset(dev, 0, n * sizeof(float));
                else welford(mean, dev, x, n, j + 1);
            }
        for (size_t i = 0; i < zsz && var; ++i) s->mzv[v * zsz + i] = m2[i] / (float)(S - 1);
        for (size_t i = 0; i < 2 * isz && var; ++i) s->mdv[v * 2 * isz + i] = m2[zsz + i] / (float)(S - 1);
        s->have[v] = 1;
    }
    free(work);
    return rc;
}

/* --sds-target mean: computes the held targets of the views (n) not yet in the cache, each alone
 * (seeded by the view) or with --sds-mv in its group of training views (mf_sds_mv_group, seeded by
 * the group's first view: the same bits whichever member is picked first, so --resume stays exact). */
static int mean_fill(MfSds *s, MfRecon *r, const int *views, int n) {
    int R = res_of(s), h = lat_of(s), nviews = mf_recon_nviews(r), var = s->o.weight == MF_SDS_WEIGHT_SPREAD;
    size_t isz = (size_t)3 * R * R, zsz = (size_t)2 * zc_of(s) * h * h;
    if (!s->have) {
        s->mean_nv = nviews;
        s->have = calloc((size_t)nviews, 1);
        s->mz = malloc((size_t)nviews * zsz * sizeof(float)), s->md = malloc((size_t)nviews * 2 * isz * sizeof(float));
        if (var) s->mzv = malloc((size_t)nviews * zsz * sizeof(float)), s->mdv = malloc((size_t)nviews * 2 * isz * sizeof(float));
        if (!s->have || !s->mz || !s->md || (var && (!s->mzv || !s->mdv))) {
            free(s->have), free(s->mz), free(s->md), free(s->mzv), free(s->mdv);
            s->have = NULL, s->mz = s->md = s->mzv = s->mdv = NULL;
            return mf_fail(MF_ENOMEM, "SDS: out of memory");
        }
    }
    int rc = MF_OK, *train = s->o.mv ? malloc((size_t)nviews * sizeof(int)) : NULL, ntrain = 0;
    if (s->o.mv && !train) return mf_fail(MF_ENOMEM, "SDS: out of memory");
    for (int v = 0; v < nviews && train; ++v) /* early stopping's held-out views never enter */
        if (!mf_recon_is_holdout(r, v)) train[ntrain++] = v;
    float *rgba = NULL;
    for (int k = 0; k < n && !rc; ++k) {
        int v = views[k];
        if (v < 0 || v >= s->mean_nv) {
            rc = mf_fail(MF_EARG, "SDS: view %d of %d views", v, s->mean_nv);
            break;
        }
        if (s->have[v]) continue;
        if (!s->o.mv) {
            rc = mean_group(s, r, &v, 1, 0, 0, view_seed(s, -1, v, 5), &rgba);
            continue;
        }
        int p = 0, start, G, own;
        while (p < ntrain && train[p] != v) ++p;
        if (p == ntrain) {
            rc = mf_fail(MF_EARG, "SDS: view %d is held out", v);
            break;
        }
        mf_sds_mv_group(ntrain, p, &start, &G, &own);
        rc = mean_group(s, r, train + start, G, own - start, 1, view_seed(s, -1, train[start], 6), &rgba);
    }
    free(rgba), free(train);
    return rc;
}

/* t->zhat, t->dhat (and with spread t->zvar, t->dvar) of the views (t->n) from the held mean
 * targets, computing those not yet held. t->t = 0: no timestep. */
static int mean_targets(MfSds *s, MfRecon *r, MfSdsTargets *t, const int *views) {
    int rc = mean_fill(s, r, views, t->n), n = t->n, R = res_of(s), h = lat_of(s);
    size_t isz = (size_t)3 * R * R, zsz = (size_t)2 * zc_of(s) * h * h, nm = (size_t)n * isz;
    int var = s->o.weight == MF_SDS_WEIGHT_SPREAD;
    if (!rc && var) {
        t->zvar = malloc((size_t)n * zsz * sizeof(float)), t->dvar = malloc(2 * nm * sizeof(float));
        if (!t->zvar || !t->dvar) rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
    }
    for (int k = 0; k < n && !rc; ++k) { /* cache (v, 2, 3, R, R) -> targets (2, n, 3, R, R) */
        size_t v = (size_t)views[k];
        memcpy(t->zhat + k * zsz, s->mz + v * zsz, zsz * sizeof(float));
        for (int kind = 0; kind < 2; ++kind)
            memcpy(t->dhat + kind * nm + k * isz, s->md + (v * 2 + kind) * isz, isz * sizeof(float));
        if (!var) continue;
        memcpy(t->zvar + k * zsz, s->mzv + v * zsz, zsz * sizeof(float));
        for (int kind = 0; kind < 2; ++kind)
            memcpy(t->dvar + kind * nm + k * isz, s->mdv + (v * 2 + kind) * isz, isz * sizeof(float));
    }
    t->t = 0;
    return rc;
}

/* Targets for the batch; keep (may be NULL) receives the current maps that produced them. */
static int targets(MfSds *s, MfRecon *r, const int *views, int n, int it, MfSdsTargets *t, Maps *keep) {
    if (n < 1 || n > MF_SDS_MAX_VIEWS) return mf_fail(MF_EARG, "SDS: %d views in a batch (1..%d)", n, MF_SDS_MAX_VIEWS);
    int R = res_of(s), h = lat_of(s), zc = zc_of(s);
    size_t rr = (size_t)R * R, nm = (size_t)n * 3 * rr, nz = (size_t)n * 2 * zc * h * h;
    MfSdsTargets T;
    memset(&T, 0, sizeof T);
    T.n = n;
    Maps cur = {0};
    float *rgba = NULL;
    MfStageClock ts = mf_stage_clock();
    T.zhat = malloc(nz * sizeof(float));
    T.dhat = malloc(2 * nm * sizeof(float));
    T.cond = malloc(nm * sizeof(float));
    T.mask = malloc((size_t)n * rr * sizeof(float));
    int rc = MF_OK;
    if (!T.zhat || !T.dhat || !T.cond || !T.mask) {
        rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
        goto done;
    }
    for (int k = 0; k < n && !rc; ++k) {
        const MfReconView *v = mf_recon_view(r, views[k]);
        if ((rc = view_cond(s, r, views[k], &rgba, T.cond + k * 3 * rr, T.mask + k * rr))) break;
        rc = prior_camera(&v->cam, R, &T.cam[k]);
        T.aov_seed[k] = view_seed(s, it, views[k], 1);
    }
    mf_stage_lap(&s->times.cond, &ts);
    if (!rc && s->o.target == MF_SDS_TARGET_MEAN) rc = mean_targets(s, r, &T, views);
    if (rc || (rc = maps_compute(s, r, &T, &cur))) goto done;
    if (s->o.target == MF_SDS_TARGET_DDIM) {
        MfRng rng;
        mf_rng_seed(&rng, view_seed(s, it, -1, 2), 0);
        T.t = s->o.t_min + (int)mf_rng_below(&rng, (uint32_t)(s->o.t_max - s->o.t_min + 1));
        rc = draws(s, &T, cur.z, it, nz, 2 * nm);
    }
done:
    free(rgba);
    if (rc || !keep) maps_free(&cur);
    else *keep = cur;
    if (rc) mf_sds_targets_free(&T);
    else *t = T;
    return rc;
}

int mf_sds_targets(MfSds *s, MfRecon *r, const int *views, int n, int it, MfSdsTargets *t) {
    return targets(s, r, views, n, it, t, NULL);
}

/* Loss of maps m (the prior's encoder cache must hold m's encode) against targets t; with g,
 * adds scale * dLoss/d(texels) into g->dkd / g->dorm (m->aa, m->ao are overwritten). */
static int loss_of(MfSds *s, MfRecon *r, const MfSdsTargets *t, Maps *m, float scale, MfDiffGrads *g, double *loss) {
    int R = res_of(s), h = lat_of(s), zc = zc_of(s), f = R / h, n = t->n;
    size_t rr = (size_t)R * R, hh = (size_t)h * h, nm = (size_t)n * 3 * rr, nz = (size_t)n * 2 * zc * hh;
    const float *ain = m->ain, *oin = m->oin, *z = m->z;
    float *aa = m->aa, *ao = m->ao;
    MfStageClock ts = mf_stage_clock();
    float *dz = calloc(nz, sizeof(float)), *al = malloc((size_t)n * hh * sizeof(float));
    float *dain = calloc(nm, sizeof(float)), *doin = calloc(nm, sizeof(float));
    /* with spread weighting: the elements' masks, then their weights, latents (nz) and maps (2 nm) */
    int spread = s->o.weight == MF_SDS_WEIGHT_SPREAD && t->zvar && t->dvar;
    float *em = spread ? malloc((nz + 2 * nm) * sizeof(float)) : NULL, *ew = spread ? malloc((nz + 2 * nm) * sizeof(float)) : NULL;
    int rc = MF_OK;
    if (!dz || !al || !dain || !doin || (spread && (!em || !ew))) {
        rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
        goto done;
    }
    /* masks at latent resolution: box filter by f */
    for (int k = 0; k < n; ++k)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < h; ++x) {
                float acc = 0.0f;
                for (int dy = 0; dy < f; ++dy)
                    for (int dx = 0; dx < f; ++dx) acc += t->mask[k * rr + (size_t)(y * f + dy) * R + x * f + dx];
                al[k * hh + (size_t)y * h + x] = acc / (float)(f * f);
            }
    size_t per_item = (size_t)2 * zc * hh;
#define LAT_MASK(i) al[((i) / per_item) * hh + (i) % hh]
#define MAP_MASK(i) t->mask[(((i) % nm) / (3 * rr)) * rr + (i) % rr]
    if (spread) { /* weights per group: the latents, the albedo maps, the ORM maps */
        for (size_t i = 0; i < nz; ++i) em[i] = LAT_MASK(i);
        for (size_t i = 0; i < 2 * nm; ++i) em[nz + i] = MAP_MASK(i);
        mf_sds_spread_weights(t->zvar, em, nz, ew);
        mf_sds_spread_weights(t->dvar, em + nz, nm, ew + nz);
        mf_sds_spread_weights(t->dvar + nm, em + nz + nm, nm, ew + nz + nm);
    }
    double lat = 0.0, rgb = 0.0;
    for (size_t i = 0; i < nz; ++i) {
        float a = LAT_MASK(i), d = a * (z[i] - t->zhat[i]), w = spread ? ew[i] : 1.0f;
        lat += (double)w * d * d;
        dz[i] = scale * s->o.lambda_latent * 2.0f * w * a * d / (float)nz;
    }
    /* rgb01: the difference of [0, 1] maps is half that of the [-1, 1] prior maps */
    float u = s->o.rgb01 ? 0.5f : 1.0f;
    for (size_t i = 0; i < 2 * nm; ++i) {
        size_t j = i % nm; /* index within the albedo or ORM maps: (k, c, p) */
        float in = i < nm ? ain[j] : oin[j], d = u * (MAP_MASK(i) * t->dhat[i] - in), w = spread ? ew[nz + i] : 1.0f;
        rgb += (double)w * d * d;
        (i < nm ? dain : doin)[j] += -scale * s->o.lambda_rgb * 2.0f * w * u * d / (float)(2 * nm); /* d/d(in) of w d^2 */
    }
#undef LAT_MASK
#undef MAP_MASK
    *loss = s->o.lambda_latent * lat / (double)nz + s->o.lambda_rgb * rgb / (double)(2 * nm);
    if (!isfinite(*loss)) {
        rc = mf_fail(MF_ENAN, "SDS: non-finite prior loss");
        goto done;
    }
    mf_stage_lap(&s->times.loss, &ts);
    if (!g) goto done;
    rc = mf_prior_encode_materials_backward(s->prior, dz, dain, doin);
    mf_stage_lap(&s->times.enc_bwd, &ts);
    if (rc) goto done;
    /* maps -> AOVs: albedo_in = (2 sRGB(kd) - 1) mask, orm_in = (2 orm - 1) mask; AOVs (R, R, 3) */
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r);
    MfDiffScene ds = {.rt = mf_recon_rtscene(r), .kd = &kd, .orm = &orm, .env = mf_recon_env(r)};
    for (int k = 0; k < n && !rc; ++k) {
        float *a = aa + k * 3 * rr, *m = ao + k * 3 * rr;
        for (int c = 0; c < 3; ++c)
            for (size_t p = 0; p < rr; ++p) {
                float mk = t->mask[k * rr + p], mv = m[3 * p + c];
                a[3 * p + c] = dain[(k * 3 + c) * rr + p] * 2.0f * mk * srgb_deriv(a[3 * p + c]);
                m[3 * p + c] = doin[(k * 3 + c) * rr + p] * 2.0f * mk * (mv >= 0.0f && mv <= 1.0f);
            }
        MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = s->o.aov_samples, .seed = t->aov_seed[k]};
        rc = mf_diff_aov_backward(&ds, &t->cam[k], &o, a, m, g);
    }
    mf_stage_lap(&s->times.aov_bwd, &ts);
done:
    free(dz), free(al), free(dain), free(doin), free(em), free(ew);
    return rc;
}

int mf_sds_loss(MfSds *s, MfRecon *r, const MfSdsTargets *t, float scale, int grads, double *loss) {
    Maps m; /* the current textures' maps (same primary hits as the targets' render) */
    int rc = maps_compute(s, r, t, &m);
    MfDiffGrads g = {.dkd = mf_recon_block(r, MF_BLOCK_KD)->g, .dorm = mf_recon_block(r, MF_BLOCK_ORM)->g};
    if (!rc) rc = loss_of(s, r, t, &m, scale, grads ? &g : NULL, loss);
    maps_free(&m);
    return rc;
}

int mf_sds_pick_views(const MfSds *s, MfRecon *r, int it, const int *batch, int nb, int *views) {
    int nv = mf_recon_nviews(r), ntrain = 0, k = 0;
    for (int v = 0; v < nv; ++v) ntrain += !mf_recon_is_holdout(r, v); /* early_stop's held-out views never enter */
    int want = s->o.k_views < ntrain ? s->o.k_views : ntrain;
    for (int i = 0; i < nb && k < want; ++i) views[k++] = batch[i];
    if (k == want) return k;
    MfRng rng;
    mf_rng_seed(&rng, view_seed(s, it, -1, 4), 0);
    for (int tries = 0; k < want; ++tries) { /* random distinct views; a sequential fill after many draws */
        int v = tries < 64 * MF_SDS_MAX_VIEWS ? (int)mf_rng_below(&rng, (uint32_t)nv) : tries % nv, used = mf_recon_is_holdout(r, v);
        for (int j = 0; j < k && !used; ++j) used = views[j] == v;
        if (!used) views[k++] = v;
    }
    return k;
}

int mf_sds_coverage(MfRecon *r, float **out, size_t *ntex) {
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    size_t nt = kd->n / 3;
    size_t npx = 0; /* the largest view's pixels */
    for (int v = 0; v < mf_recon_nviews(r); ++v) {
        const MfCamera *c = &mf_recon_view(r, v)->cam;
        if ((size_t)c->w * (size_t)c->h > npx) npx = (size_t)c->w * (size_t)c->h;
    }
    float *w = calloc(nt, sizeof(float)), *g = malloc(kd->n * sizeof(float)), *ones = malloc(npx * 3 * sizeof(float));
    if (!w || !g || !ones) {
        free(w), free(g), free(ones);
        return mf_fail(MF_ENOMEM, "SDS coverage: out of memory");
    }
    for (size_t i = 0; i < npx * 3; ++i) ones[i] = 1.0f;
    MfImage kdi = mf_recon_kd_image(r), ormi = mf_recon_orm_image(r);
    MfDiffScene ds = {.rt = mf_recon_rtscene(r), .kd = &kdi, .orm = &ormi, .env = mf_recon_env(r)};
    int rc = MF_OK;
    for (int v = 0; v < mf_recon_nviews(r) && !rc; ++v) {
        if (mf_recon_is_holdout(r, v)) continue; /* early_stop's held-out views are not training data */
        const MfReconView *view = mf_recon_view(r, v);
        memset(g, 0, kd->n * sizeof(float));
        MfDiffGrads dg = {.dkd = g};
        MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = 1, .seed = 0x5eedu + (uint64_t)v};
        rc = mf_diff_aov_backward(&ds, &view->cam, &o, ones, NULL, &dg);
        for (size_t t = 0; t < nt && !rc; ++t) w[t] += (g[3 * t] > 0.0f);
    }
    free(g), free(ones);
    if (rc) {
        free(w);
        return rc;
    }
    for (size_t t = 0; t < nt; ++t) w[t] = MF_SDS_COVERAGE_C0 / (MF_SDS_COVERAGE_C0 + w[t]);
    *out = w;
    *ntex = nt;
    return MF_OK;
}

void mf_sds_agreement_weights(const double *sum, const double *sum2, const float *nv, size_t nt, int c0, int c1,
                              float *w, double *mean_var) {
    for (size_t t = 0; t < nt; ++t) {
        w[t] = 0.0f;
        if (nv[t] < 2.0f) continue;
        double var = 0.0;
        for (int c = c0; c < c1; ++c) {
            double m = sum[3 * t + c] / nv[t];
            var += fmax(0.0, sum2[3 * t + c] / nv[t] - m * m);
        }
        w[t] = (float)(var / (c1 - c0)); /* the variance, turned into the weight in place below */
    }
    *mean_var = variance_weights(w, nv, 1.5f, nt, w); /* the texels at least two views see (nv counts views) */
}

/* --sds-weight views: the kd and ORM texel weights from the training views' held mean targets (see
 * MF_SDS_WEIGHT_VIEWS); logs the mean cross-view variances. */
static int views_weights(MfSds *s, MfRecon *r) {
    int R = res_of(s), nviews = mf_recon_nviews(r), rc = MF_OK;
    size_t rr = (size_t)R * R, isz = 3 * rr, nkd = mf_recon_block(r, MF_BLOCK_KD)->n, nt = nkd / 3;
    if (mf_recon_block(r, MF_BLOCK_ORM)->n != nkd) return mf_fail(MF_EARG, "SDS views: the kd and ORM textures differ in size");
    int *train = malloc((size_t)nviews * sizeof(int)), ntrain = 0;
    /* per texel over the views: sum and sum of squares of the view's mean target there (albedo 3,
     * ORM 3), views that see it; per view: the splat of the targets (g1) and of ones (g0) */
    double *sum = calloc(2 * nkd, sizeof(double)), *sum2 = calloc(2 * nkd, sizeof(double));
    float *nv = calloc(nt, sizeof(float)), *g0 = malloc(nkd * sizeof(float)), *g1 = malloc(2 * nkd * sizeof(float));
    float *img = malloc(3 * isz * sizeof(float)); /* (3, R, R, 3): ones, albedo target, ORM target */
    float *wkd = malloc(nt * sizeof(float)), *worm = malloc(nt * sizeof(float));
    if (!train || !sum || !sum2 || !nv || !g0 || !g1 || !img || !wkd || !worm) rc = mf_fail(MF_ENOMEM, "SDS views: out of memory");
    for (int v = 0; v < nviews && !rc; ++v)
        if (!mf_recon_is_holdout(r, v)) train[ntrain++] = v;
    if (!rc) rc = mean_fill(s, r, train, ntrain);
    MfImage kdi = mf_recon_kd_image(r), ormi = mf_recon_orm_image(r);
    MfDiffScene ds = {.rt = mf_recon_rtscene(r), .kd = &kdi, .orm = &ormi, .env = mf_recon_env(r)};
    float *mask = NULL, *cond = malloc(isz * sizeof(float)), *rgba = NULL;
    if (!rc && (!cond || !(mask = malloc(rr * sizeof(float))))) rc = mf_fail(MF_ENOMEM, "SDS views: out of memory");
    for (int k = 0; k < ntrain && !rc; ++k) {
        int v = train[k];
        MfCamera cam;
        if ((rc = view_cond(s, r, v, &rgba, cond, mask)) || (rc = prior_camera(&mf_recon_view(r, v)->cam, R, &cam))) break;
        const float *md = s->md + (size_t)v * 2 * isz; /* (2, 3, R, R) in [-1, 1] */
        for (size_t p = 0; p < rr; ++p)
            for (int c = 0; c < 3; ++c) {
                float m = mask[p] > 0.5f ? 1.0f : 0.0f; /* the object's pixels */
                img[3 * p + c] = m;
                img[isz + 3 * p + c] = m * 0.5f * (md[c * rr + p] + 1.0f);
                img[2 * isz + 3 * p + c] = m * 0.5f * (md[isz + c * rr + p] + 1.0f);
            }
        MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = 1, .seed = 0x5eedu + (uint64_t)v};
        memset(g0, 0, nkd * sizeof(float)), memset(g1, 0, 2 * nkd * sizeof(float));
        MfDiffGrads d0 = {.dkd = g0}, d1 = {.dkd = g1, .dorm = g1 + nkd};
        if ((rc = mf_diff_aov_backward(&ds, &cam, &o, img, NULL, &d0)) ||
            (rc = mf_diff_aov_backward(&ds, &cam, &o, img + isz, img + 2 * isz, &d1)))
            break;
        for (size_t t = 0; t < nt; ++t) {
            float wt = g0[3 * t];
            if (!(wt > 1e-3f)) continue; /* the view hardly sees the texel */
            nv[t] += 1.0f;
            for (int part = 0; part < 2; ++part)
                for (int c = 0; c < 3; ++c) {
                    double m = g1[part * nkd + 3 * t + c] / wt;
                    sum[part * nkd + 3 * t + c] += m, sum2[part * nkd + 3 * t + c] += m * m;
                }
        }
    }
    double var[2] = {0.0, 0.0};
    size_t seen2 = 0;
    if (!rc) {
        mf_sds_agreement_weights(sum, sum2, nv, nt, 0, 3, wkd, &var[0]);             /* albedo: 3 channels */
        mf_sds_agreement_weights(sum + nkd, sum2 + nkd, nv, nt, 1, 3, worm, &var[1]); /* roughness, metallic */
        for (size_t t = 0; t < nt; ++t) seen2 += nv[t] >= 2.0f;
        mf_log(MF_LOG_INFO, "SDS views: %zu texels seen by >= 2 of %d views; mean cross-view variance of the targets: "
               "albedo (sRGB) %.4g, roughness/metallic %.4g", seen2, ntrain, var[0], var[1]);
        free(s->coverage), free(s->cov_orm);
        s->coverage = wkd, s->cov_orm = worm, s->coverage_n = nt;
        wkd = worm = NULL;
    }
    free(train), free(sum), free(sum2), free(nv), free(g0), free(g1), free(img), free(wkd), free(worm), free(mask),
        free(cond), free(rgba);
    return rc;
}

/* g (n,) += gamma * h, texel by texel over its 3 channels, channel c of h scaled by ch[c] first;
 * with MF_SDS_WEIGHT_CONFLICT the part of h that opposes g (the iteration's image and regulariser
 * gradient) is removed; with a texel weight cov (n / 3,; coverage or views, else NULL) h is scaled by it. */
static void apply_held(float *g, const float *h, size_t n, float gamma, const float ch[3], int weight, const float *cov) {
    for (size_t i = 0; i + 2 < n; i += 3) {
        float hv[3] = {h[i] * ch[0], h[i + 1] * ch[1], h[i + 2] * ch[2]};
        if (cov)
            for (int c = 0; c < 3; ++c) hv[c] *= cov[i / 3];
        if (weight == MF_SDS_WEIGHT_CONFLICT) {
            double dot = 0.0, gg = 0.0;
            for (int c = 0; c < 3; ++c) dot += (double)hv[c] * g[i + c], gg += (double)g[i + c] * g[i + c];
            if (dot < 0.0 && gg > 0.0)
                for (int c = 0; c < 3; ++c) hv[c] -= (float)(dot / gg) * g[i + c];
        }
        for (int c = 0; c < 3; ++c) g[i + c] += gamma * hv[c];
    }
}

int mf_sds_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    MfSds *s = ctx;
    const MfReconOpts *ro = mf_recon_opts(r);
    double gamma = s->o.gamma_const ? 1.0 : 1.0 - pow((double)it / (double)(ro->iters > 0 ? ro->iters : 1), s->o.gamma_p);
    int views[MF_SDS_MAX_VIEWS], k = mf_sds_pick_views(s, r, it, batch, nb, views);
    *loss = 0.0;
    if (gamma <= 0.0 || (s->o.lambda_latent == 0.0f && s->o.lambda_rgb == 0.0f)) return MF_OK;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    if (s->o.every == 0) {
        const MfCamera *c = &mf_recon_view(r, 0)->cam;
        s->o.every = mf_sds_every_auto(c->w, c->h);
        mf_log_info("prior term: every %d iterations (--sds-every 0: %dx%d training images)", s->o.every, c->w, c->h);
    }
    /* refresh at multiples of `every` and of the checkpoint period (a resumed run starts at one:
     * it refreshes where the uninterrupted run did, so --resume stays exact) */
    int ce = ro->checkpoint_every;
    if (s->held_it < 0 || it % s->o.every == 0 || (ce > 0 && it % ce == 0)) {
        if (s->held_n != kd->n || !s->held_kd || !s->held_orm) {
            free(s->held_kd), free(s->held_orm);
            s->held_kd = malloc(kd->n * sizeof(float)), s->held_orm = malloc(orm->n * sizeof(float));
            s->held_n = kd->n;
            if (!s->held_kd || !s->held_orm) return mf_fail(MF_ENOMEM, "SDS: out of memory");
        }
        memset(s->held_kd, 0, kd->n * sizeof(float));
        memset(s->held_orm, 0, orm->n * sizeof(float));
        double t0 = mf_now();
        MfSdsTargets t;
        Maps m = {0}; /* the textures do not change between the targets and the loss: one render and encode */
        MfDiffGrads g = {.dkd = s->held_kd, .dorm = s->held_orm};
        int rc = targets(s, r, views, k, it, &t, &m);
        if (!rc) rc = loss_of(s, r, &t, &m, 1.0f, &g, &s->held_loss);
        maps_free(&m);
        mf_sds_targets_free(&t);
        s->seconds += mf_now() - t0;
        if (rc) {
            s->held_it = -1;
            return mf_fail_prefix(rc, "iteration %d: prior term", it);
        }
        s->held_it = it;
    }
    if (s->o.weight == MF_SDS_WEIGHT_VIEWS && (!s->coverage || s->coverage_n * 3 != kd->n)) {
        int rc = views_weights(s, r);
        if (rc) return mf_fail_prefix(rc, "iteration %d: prior term", it);
    }
    if (s->o.weight == MF_SDS_WEIGHT_COVERAGE && (!s->coverage || s->coverage_n * 3 != kd->n)) {
        free(s->coverage);
        s->coverage = NULL;
        int rc = mf_sds_coverage(r, &s->coverage, &s->coverage_n);
        if (rc) return mf_fail_prefix(rc, "iteration %d: prior term", it);
        if (s->coverage_n * 3 != orm->n) return mf_fail(MF_EARG, "SDS coverage: the kd and ORM textures differ in size");
    }
    MfStageClock ts = mf_stage_clock();
    const float ch_kd[3] = {1.0f, 1.0f, 1.0f}, ch_orm[3] = {1.0f, s->o.trust_rough, s->o.trust_metal};
    int by_views = s->o.weight == MF_SDS_WEIGHT_VIEWS;
    apply_held(kd->g, s->held_kd, kd->n, (float)gamma, ch_kd, s->o.weight, s->coverage);
    apply_held(orm->g, s->held_orm, orm->n, (float)gamma, ch_orm, s->o.weight, by_views ? s->cov_orm : s->coverage);
    mf_stage_lap(&s->times.apply, &ts);
    *loss = gamma * s->held_loss;
    return MF_OK;
}
