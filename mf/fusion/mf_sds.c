#include "fusion/mf_sds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "inverse/mf_diffrender.h"
#include "io/mf_image.h"

struct MfSds {
    MfPrior *prior; /* owned */
    MfSdsOpts o;
};

MfSdsOpts mf_sds_opts_default(void) {
    MfSdsOpts o = {4, 0.02f, 0.5f, 1.0f, 0, 3.0f, 20, 980, 4, 7};
    return o;
}

int mf_sds_new(MfPrior *prior, const MfSdsOpts *o, MfSds **out) {
    if (o->k_views < 1 || o->t_min < 1 || o->t_max > 999 || o->t_min > o->t_max || o->aov_samples < 1)
        return mf_fail(MF_EARG, "SDS options: k_views %d, t in [%d, %d], aov_samples %d are invalid", o->k_views, o->t_min,
                       o->t_max, o->aov_samples);
    MfSds *s = calloc(1, sizeof *s);
    if (!s) return mf_fail(MF_ENOMEM, "out of memory");
    s->prior = prior;
    s->o = *o;
    *out = s;
    return MF_OK;
}

void mf_sds_free(MfSds *s) {
    if (!s) return;
    mf_prior_free(s->prior);
    free(s);
}

void mf_sds_targets_free(MfSdsTargets *t) {
    free(t->zhat);
    free(t->dhat);
    free(t->cond);
    free(t->mask);
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

/* The current textures' material maps for camera cam: albedo_in, orm_in (3, R, R) prepared as the
 * prior's inputs; aov_alb (R, R, 3) keeps the linear albedo for the backward. */
static int render_maps(MfSds *s, MfRecon *r, const MfCamera *cam, const float *mask, uint64_t seed, float *albedo_in,
                       float *orm_in, float *aov_alb, float *aov_orm) {
    int R = res_of(s);
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r);
    MfDiffScene ds = {mf_recon_rtscene(r), &kd, &orm, mf_recon_env(r), NULL, NULL, NULL};
    MfDiffOpts o = {1, s->o.aov_samples, seed};
    int rc = mf_diff_aov_forward(&ds, cam, &o, aov_alb, aov_orm, NULL);
    if (rc) return rc;
    for (int c = 0; c < 3; ++c)
        for (int p = 0; p < R * R; ++p) {
            float a = mf_clampf(aov_alb[3 * p + c], 0.0f, 1.0f), m = mf_clampf(aov_orm[3 * p + c], 0.0f, 1.0f);
            albedo_in[c * R * R + p] = (2.0f * mf_linear_to_srgb(a) - 1.0f) * mask[p];
            orm_in[c * R * R + p] = (2.0f * m - 1.0f) * mask[p];
        }
    return MF_OK;
}

int mf_sds_targets(MfSds *s, MfRecon *r, int view, int it, MfSdsTargets *t) {
    const MfReconView *v = mf_recon_view(r, view);
    int R = res_of(s), h = lat_of(s), zc = zc_of(s), w = v->ref.w, H = v->ref.h;
    if (w != H) return mf_fail(MF_EARG, "SDS: view %d is %dx%d; the prior term needs square views", view, w, H);
    MfSdsTargets T;
    memset(&T, 0, sizeof T);
    size_t npx = (size_t)w * H;
    float *rgba = malloc(npx * 4 * sizeof(float));
    float *ain = malloc((size_t)3 * R * R * sizeof(float)), *oin = malloc((size_t)3 * R * R * sizeof(float));
    float *aa = malloc((size_t)3 * R * R * sizeof(float)), *ao = malloc((size_t)3 * R * R * sizeof(float));
    float *z = malloc((size_t)2 * zc * h * h * sizeof(float));
    T.zhat = malloc((size_t)2 * zc * h * h * sizeof(float));
    T.dhat = malloc((size_t)6 * R * R * sizeof(float));
    T.cond = malloc((size_t)3 * R * R * sizeof(float));
    T.mask = malloc((size_t)R * R * sizeof(float));
    int rc = MF_OK;
    if (!rgba || !ain || !oin || !aa || !ao || !z || !T.zhat || !T.dhat || !T.cond || !T.mask) {
        rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
        goto done;
    }
    /* condition: the reference view as straight-alpha sRGB in [0, 1] */
    for (size_t p = 0; p < npx; ++p) {
        float a = v->ref.data[4 * p + 3];
        for (int c = 0; c < 3; ++c)
            rgba[4 * p + c] = a > 0.0f ? mf_clampf(mf_linear_to_srgb(v->ref.data[4 * p + c] / a), 0.0f, 1.0f) : 0.0f;
        rgba[4 * p + 3] = a;
    }
    mf_prior_prepare_image(rgba, w, H, R, T.cond, T.mask);
    /* the view's camera at R x R (same field of view) */
    double ax = 2.0 * atan((double)v->cam.w / (2.0 * (double)v->cam.fx)), m[16];
    for (int i = 0; i < 16; ++i) m[i] = v->cam.c2w.m[i];
    if ((rc = mf_camera_init(&T.cam, R, R, ax, m, "SDS camera"))) goto done;
    T.aov_seed = view_seed(s, it, view, 1);
    if ((rc = render_maps(s, r, &T.cam, T.mask, T.aov_seed, ain, oin, aa, ao))) goto done;
    if ((rc = mf_prior_encode_materials(s->prior, ain, oin, 1, z))) goto done;
    MfRng rng;
    mf_rng_seed(&rng, view_seed(s, it, view, 2), 0);
    int tt = s->o.t_min + (int)mf_rng_below(&rng, (uint32_t)(s->o.t_max - s->o.t_min + 1));
    if ((rc = mf_prior_sds_denoise(s->prior, z, T.cond, 1, 1, 0, tt, s->o.guidance, view_seed(s, it, view, 3), T.zhat))) goto done;
    rc = mf_prior_decode_materials(s->prior, T.zhat, 1, T.dhat, T.dhat + (size_t)3 * R * R);
done:
    free(rgba), free(ain), free(oin), free(aa), free(ao), free(z);
    if (rc) mf_sds_targets_free(&T);
    else *t = T;
    return rc;
}

int mf_sds_view_loss(MfSds *s, MfRecon *r, const MfSdsTargets *t, float scale, int grads, double *loss) {
    int R = res_of(s), h = lat_of(s), zc = zc_of(s), f = R / h;
    size_t nm = (size_t)3 * R * R, nz = (size_t)2 * zc * h * h;
    float *ain = malloc(nm * sizeof(float)), *oin = malloc(nm * sizeof(float));
    float *aa = malloc(nm * sizeof(float)), *ao = malloc(nm * sizeof(float));
    float *z = malloc(nz * sizeof(float)), *dz = calloc(nz, sizeof(float)), *al = malloc((size_t)h * h * sizeof(float));
    float *dain = calloc(nm, sizeof(float)), *doin = calloc(nm, sizeof(float));
    int rc = MF_OK;
    if (!ain || !oin || !aa || !ao || !z || !dz || !al || !dain || !doin) {
        rc = mf_fail(MF_ENOMEM, "SDS: out of memory");
        goto done;
    }
    /* the maps of the current textures (same primary hits as the targets' render) and their latents;
     * encoding again here keeps the encoder's cache for the backward below */
    if ((rc = render_maps(s, r, &t->cam, t->mask, t->aov_seed, ain, oin, aa, ao))) goto done;
    if ((rc = mf_prior_encode_materials(s->prior, ain, oin, 1, z))) goto done;
    /* mask at latent resolution: box filter by f */
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < h; ++x) {
            float acc = 0.0f;
            for (int dy = 0; dy < f; ++dy)
                for (int dx = 0; dx < f; ++dx) acc += t->mask[(y * f + dy) * R + x * f + dx];
            al[y * h + x] = acc / (float)(f * f);
        }
    double lat = 0.0, rgb = 0.0;
    for (size_t i = 0; i < nz; ++i) {
        float a = al[i % ((size_t)h * h)], d = a * (z[i] - t->zhat[i]);
        lat += (double)d * d;
        dz[i] = scale * s->o.lambda_latent * 2.0f * a * d / (float)nz;
    }
    for (size_t i = 0; i < 2 * nm; ++i) {
        float in = i < nm ? ain[i] : oin[i - nm], d = t->mask[i % ((size_t)R * R)] * t->dhat[i] - in;
        rgb += (double)d * d;
        /* d/d(in) of d^2 = -2 d */
        (i < nm ? dain : doin)[i % nm] += -scale * s->o.lambda_rgb * 2.0f * d / (float)(2 * nm);
    }
    *loss = s->o.lambda_latent * lat / (double)nz + s->o.lambda_rgb * rgb / (double)(2 * nm);
    if (!isfinite(*loss)) {
        rc = mf_fail(MF_ENAN, "SDS: non-finite prior loss");
        goto done;
    }
    if (!grads) goto done;
    if ((rc = mf_prior_encode_materials_backward(s->prior, dz, dain, doin))) goto done;
    /* maps -> AOVs: albedo_in = (2 sRGB(kd) - 1) mask, orm_in = (2 orm - 1) mask; AOVs (R, R, 3) */
    for (int c = 0; c < 3; ++c)
        for (int p = 0; p < R * R; ++p) {
            float m = t->mask[p];
            aa[3 * p + c] = dain[c * R * R + p] * 2.0f * m * srgb_deriv(aa[3 * p + c]);
            ao[3 * p + c] = doin[c * R * R + p] * 2.0f * m * (ao[3 * p + c] >= 0.0f && ao[3 * p + c] <= 1.0f);
        }
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r);
    MfDiffScene ds = {mf_recon_rtscene(r), &kd, &orm, mf_recon_env(r), NULL, NULL, NULL};
    MfDiffOpts o = {1, s->o.aov_samples, t->aov_seed};
    MfDiffGrads g = {mf_recon_block(r, MF_BLOCK_KD)->g, mf_recon_block(r, MF_BLOCK_ORM)->g, NULL};
    rc = mf_diff_aov_backward(&ds, &t->cam, &o, aa, ao, &g);
done:
    free(ain), free(oin), free(aa), free(ao), free(z), free(dz), free(al), free(dain), free(doin);
    return rc;
}

int mf_sds_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    MfSds *s = ctx;
    const MfReconOpts *ro = mf_recon_opts(r);
    double gamma = s->o.gamma_const ? 1.0 : 1.0 - pow((double)it / (double)(ro->iters > 0 ? ro->iters : 1), s->o.gamma_p);
    int k = nb < s->o.k_views ? nb : s->o.k_views;
    *loss = 0.0;
    if (gamma <= 0.0 || (s->o.lambda_latent == 0.0f && s->o.lambda_rgb == 0.0f)) return MF_OK;
    for (int i = 0; i < k; ++i) {
        MfSdsTargets t;
        double l = 0.0;
        int rc = mf_sds_targets(s, r, batch[i], it, &t);
        if (!rc) rc = mf_sds_view_loss(s, r, &t, (float)(gamma / k), 1, &l);
        mf_sds_targets_free(&t);
        if (rc) return mf_fail_prefix(rc, "iteration %d, view %d", it, batch[i]);
        *loss += gamma * l / k;
    }
    return MF_OK;
}
