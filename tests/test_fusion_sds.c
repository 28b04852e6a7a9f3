/* Tests of MaterialFusion's SDS+ term (mf/fusion/mf_sds): the whole chain from kd/ORM texels
 * through the AOV render, the prior's input preparation and the encoder, checked against central
 * differences with the targets (zhat, D(zhat)) held fixed as the method does; the gamma schedule;
 * and the hook's effect inside a short reconstruction. Uses the tiny prior configuration with
 * random weights, its denoiser's output conv re-drawn so that targets depend on the condition
 * images and the guidance (tiny_sds; the chain, not the prior's quality, is under test). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "fusion/mf_sds.h"
#include "mf_test.h"
#include "mf_test_grad.h"
#include "mf_test_recon.h"
#include "render/mf_diffrender.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"

enum { RES = 16, NV = 4 };

/* iters and ckpt_every override the small defaults (6 and 0) when positive. */
static int g_holdout_every; /* > 0: make_recon_n's runs hold views out (early_stop) */

static int make_recon_n(MfMesh *mesh, MfRecon **out, int iters, int ckpt_every) {
    int rc = mf_shape_uv_sphere(mesh, mf_v3(0, 0, 0), 0.5f, 16, 8);
    if (rc) return rc;
    MfReconView views[NV];
    memset(views, 0, sizeof views);
    MfRtScene *rt = NULL;
    if ((rc = mf_rtscene_new(mesh, &rt))) return rc;
    MfEnvMap env;
    mf_env_init_constant(&env, 8, 4, mf_v3s(1.0f));
    MfTexMaterial mat = {.kd = NULL, .orm = NULL, .kd_const = mf_v3(0.6f, 0.4f, 0.3f), .orm_const = mf_v3(1, 0.6f, 0.1f), .normal = NULL};
    MfRenderInput in = {rt, mesh, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 3, .lobes = MF_LOBE_ALL};
    for (int v = 0; v < NV && !rc; ++v) {
        float az = 2.0f * MF_PI * v / NV;
        rc = ref_view(&in, &ro, RES, mf_v3(1.8f * cosf(az), 1.8f * sinf(az), 0.4f), &views[v]);
    }
    mf_env_free(&env);
    mf_rtscene_free(rt);
    MfReconOpts o = mf_recon_opts_default();
    if (g_holdout_every) o.early_stop = 1, o.holdout_every = g_holdout_every;
    o.iters = iters > 0 ? iters : 6;
    o.tex_res = 8;
    o.env_w = 8;
    o.env_h = 4;
    o.snapshot_every = 0;
    o.checkpoint_every = ckpt_every > 0 ? ckpt_every : 0;
    if (!rc) rc = mf_recon_new(mesh, views, NV, &o, out);
    for (int v = 0; v < NV; ++v) mf_image_free(&views[v].ref);
    return rc;
}

static int make_recon(MfMesh *mesh, MfRecon **out) { return make_recon_n(mesh, out, 0, 0); }

/* A tiny prior with deterministic random weights, as a term with options o. The denoiser's output
 * conv starts at zero (mf_denoiser_init_weights, as training starts), so its v-prediction would be 0
 * and every target a function of the noise alone, blind to the condition images and the guidance;
 * it is re-drawn here (as tests/mf_test_prior.c's tp_tiny_prior does) so that the targets come from
 * a prior that reads its inputs, if an untrained one. */
static MfSds *tiny_sds(const MfSdsOpts *o) {
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    MfPrior *p = NULL;
    if (mf_prior_new(&p, &cfg)) return NULL;
    mf_ae_init_weights(p->ae, 11);
    mf_denoiser_init_weights(p->dn, 12);
    mf_kconv_init(&p->dn->cout, p->dn->params, 13, 0);
    MfSds *s = NULL;
    if (mf_sds_new(p, o, &s)) {
        mf_prior_free(p);
        return NULL;
    }
    return s;
}

/* The SDS options of most tests: the defaults with 2 views a term. */
static MfSdsOpts opts2(void) {
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 2;
    o.every = 4; /* 128 px images' interval: auto (0) would give 256 for these 16 px views */
    return o;
}

/* A test's reconstruction (make_recon) and its SDS terms; sds_done frees them all. */
typedef struct {
    MfMesh mesh;
    MfRecon *r;
    MfSds *s[4];
    int ns;
} SdsFix;

/* View v's reference image darkened 4x (a test-only write through the view's pixels). */
static void darken_view(MfRecon *r, int v) {
    MfImage *ref = (MfImage *)&mf_recon_view(r, v)->ref;
    for (size_t p = 0; p < (size_t)ref->w * ref->h; ++p)
        for (int ch = 0; ch < 3; ++ch) ref->data[4 * p + ch] *= 0.25f;
}

/* f->r from make_recon (checked); returns it, NULL on failure. */
static MfRecon *sds_fix(SdsFix *f) {
    memset(f, 0, sizeof *f);
    CHECK_OK(make_recon(&f->mesh, &f->r));
    return f->r;
}

/* A term with options o (NULL: opts2()), freed by sds_done; NULL on failure. */
static MfSds *sds_term(SdsFix *f, const MfSdsOpts *o) {
    MfSdsOpts d = opts2();
    MfSds *s = tiny_sds(o ? o : &d);
    if (s && f->ns < 4) f->s[f->ns++] = s;
    return s;
}

static void sds_done(SdsFix *f) {
    for (int i = 0; i < f->ns; ++i) mf_sds_free(f->s[i]);
    mf_recon_free(f->r);
    mf_mesh_free(&f->mesh);
}

typedef struct {
    MfSds *s;
    MfRecon *r;
    const MfSdsTargets *t;
} SdsLossCtx;

/* the SDS loss against fixed targets, no gradient */
static double sds_loss_of(void *c) {
    SdsLossCtx *x = c;
    double l = NAN;
    mf_sds_loss(x->s, x->r, x->t, 1.0f, 0, &l);
    return l;
}

/* The chain's texel gradients against central differences of the loss, for SDS options o. */
static void chain_gradient(const MfSdsOpts *o) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSds *s = sds_term(&f, o);
    CHECK(s != NULL);
    if (!r || !s) return;
    /* perturb the textures away from the constant init so every term is active */
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    for (size_t i = 0; i < kd->n; ++i) kd->p[i] = 0.2f + 0.6f * (float)((i * 37) % 11) / 10.0f;
    for (size_t i = 0; i < orm->n; i += 3) orm->p[i + 1] = 0.3f + 0.05f * (float)(i % 7), orm->p[i + 2] = 0.2f + 0.04f * (float)(i % 5);
    MfSdsTargets t;
    int views[2] = {1, 2};
    CHECK_OK(mf_sds_targets(s, r, views, 2, 0, &t));
    mf_param_zero_grad(kd);
    mf_param_zero_grad(orm);
    double l0;
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 1, &l0));
    CHECK(l0 > 0.0);
    double worst = 0.0, gmax = 0.0;
    int checked = 0;
    MfParamBlock *blocks[2] = {kd, orm};
    SdsLossCtx lc = {s, r, &t};
    for (int b = 0; b < 2; ++b)
        for (size_t i = 0; i < blocks[b]->n; ++i) {
            if (b == 1 && i % 3 == 0) continue; /* occlusion is not an input */
            float g = blocks[b]->g[i];
            gmax = fmax(gmax, fabs(g));
            if (fabs(g) < 1e-4) continue; /* texels the view does not see */
            double fd = mf_test_fd(sds_loss_of, &lc, blocks[b]->p, i, 2e-3f);
            worst = fmax(worst, fabs(fd - g) / (fabs(fd) + 0.05 * gmax));
            ++checked;
        }
    if (getenv("MF_TEST_VERBOSE")) printf("    SDS chain: %d texel gradients checked, worst relative error %.3g\n", checked, worst);
    CHECK(checked > 20);
    /* float forward through an autoencoder: differences carry ~1e-3 relative noise */
    CHECK_MSG(worst < 3e-2, "SDS chain gradient relative error %.3g", worst);
    mf_sds_targets_free(&t);
    sds_done(&f);
}

MF_TEST(fusion_sds_chain_gradient) {
    MfSdsOpts o = opts2();
    chain_gradient(&o);
}

/* The same with the spread weights (fixed with the targets) inside the loss. */
MF_TEST(fusion_sds_chain_gradient_spread) {
    MfSdsOpts o = opts2();
    o.draws = 2, o.weight = MF_SDS_WEIGHT_SPREAD;
    chain_gradient(&o);
}

/* Spread weights: 1 / (1 + var / mean masked var), scaled to mean 1 over the masked elements;
 * unmasked elements and a batch with no spread get 1; spread needs two draws or more. */
MF_TEST(fusion_sds_spread_weights) {
    const float var[5] = {0.0f, 1.0f, 2.0f, 9.0f, 0.0f}, m[5] = {1.0f, 0.5f, 1.0f, 0.0f, 0.0f};
    float w[5];
    mf_sds_spread_weights(var, m, 5, w);
    double raw[3] = {1.0, 1.0 / 2.0, 1.0 / 3.0}, mean = (raw[0] + raw[1] + raw[2]) / 3.0; /* var_ref = 1 */
    for (int i = 0; i < 3; ++i) CHECK_NEAR(w[i], raw[i] / mean, 1e-6);
    CHECK(w[3] == 1.0f && w[4] == 1.0f);
    const float flat[3] = {0.0f, 0.0f, 0.0f}, ones[3] = {1.0f, 1.0f, 1.0f};
    mf_sds_spread_weights(flat, ones, 3, w);
    CHECK(w[0] == 1.0f && w[1] == 1.0f && w[2] == 1.0f);
    MfSdsOpts o = mf_sds_opts_default();
    o.weight = MF_SDS_WEIGHT_SPREAD;
    MfSds *bad = NULL;
    CHECK_ERR(mf_sds_new(NULL, &o, &bad), "--sds-draws 1");
    CHECK(bad == NULL);
}

/* With 2 draws the targets are the mean of the single-draw target and a second draw, and the
 * variance is that of the two: var = 2 (mean - first)^2, element by element. */
MF_TEST(fusion_sds_draws_mean_and_variance) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    MfSds *s1 = sds_term(&f, &o);
    o.draws = 2;
    MfSds *s2 = sds_term(&f, &o);
    o.weight = MF_SDS_WEIGHT_SPREAD;
    MfSds *s3 = sds_term(&f, &o);
    if (!r || !s1 || !s2 || !s3) return;
    MfSdsTargets t1, t2;
    int views[2] = {0, 3};
    CHECK_OK(mf_sds_targets(s1, r, views, 2, 5, &t1));
    CHECK_OK(mf_sds_targets(s2, r, views, 2, 5, &t2));
    if (mf_test_failed_now()) return;
    CHECK(t1.zvar == NULL && t2.zvar != NULL && t2.dvar != NULL && t1.t == t2.t);
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    size_t h = (size_t)cfg.ae.res / 4, nz = 2u * 2 * (size_t)cfg.ae.zc * h * h, nd = 2u * 2 * 3 * (size_t)cfg.ae.res * cfg.ae.res;
    double zerr = 0.0, derr = 0.0, vmax = 0.0;
    for (size_t i = 0; i < nz; ++i) {
        double d = (double)t2.zhat[i] - t1.zhat[i];
        zerr = fmax(zerr, fabs(t2.zvar[i] - 2.0 * d * d));
        vmax = fmax(vmax, t2.zvar[i]);
    }
    for (size_t i = 0; i < nd; ++i) {
        double d = (double)t2.dhat[i] - t1.dhat[i];
        derr = fmax(derr, fabs(t2.dvar[i] - 2.0 * d * d));
    }
    CHECK(vmax > 0.0);
    CHECK_MSG(zerr <= 1e-5 * fmax(vmax, 1.0) && derr <= 1e-5, "draw variance off: latent %.3g, maps %.3g", zerr, derr);
    /* the spread weights enter the loss (same targets, weighted vs unweighted) */
    double ln = 0.0, ls = 0.0;
    CHECK_OK(mf_sds_loss(s2, r, &t2, 1.0f, 0, &ln));
    CHECK_OK(mf_sds_loss(s3, r, &t2, 1.0f, 0, &ls));
    CHECK_MSG(ln > 0.0 && ls > 0.0 && fabs(ls - ln) > 1e-3 * ln, "spread-weighted loss %.6g vs unweighted %.6g", ls, ln);
    mf_sds_targets_free(&t1), mf_sds_targets_free(&t2);
    sds_done(&f);
}

/* DDIM targets come from the condition images through the guidance: darkening view 0's image
 * changes its targets at guidance 3 and leaves them the same bits at guidance 0 (the unconditional
 * prediction alone: zero image latent and embedding); guidance 1 and 3 give different targets. */
MF_TEST(fusion_sds_targets_follow_images_and_guidance) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    MfSds *s3 = sds_term(&f, &o); /* guidance 3, the default */
    o.guidance = 1.0f;
    MfSds *s1 = sds_term(&f, &o);
    o.guidance = 0.0f;
    MfSds *s0 = sds_term(&f, &o);
    if (!r || !s3 || !s1 || !s0) return;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    size_t h = (size_t)cfg.ae.res / 4, zsz = 2u * cfg.ae.zc * h * h, isz = 3u * cfg.ae.res * cfg.ae.res;
    int views[2] = {0, 3};
    MfSdsTargets a3, a1, a0, b3, b0;
    CHECK_OK(mf_sds_targets(s3, r, views, 2, 5, &a3));
    CHECK_OK(mf_sds_targets(s1, r, views, 2, 5, &a1));
    CHECK_OK(mf_sds_targets(s0, r, views, 2, 5, &a0));
    darken_view(r, 0);
    CHECK_OK(mf_sds_targets(s3, r, views, 2, 5, &b3));
    CHECK_OK(mf_sds_targets(s0, r, views, 2, 5, &b0));
    if (mf_test_failed_now()) return;
    CHECK(a3.t == a1.t && a3.t == b3.t && a3.t == a0.t);
    double scale = 0.0; /* view 0's latent target */
    for (size_t i = 0; i < zsz; ++i) scale = fmax(scale, fabs(a3.zhat[i]));
    double dimg = mf_test_max_abs_diff(a3.zhat, b3.zhat, zsz), dmap = mf_test_max_abs_diff(a3.dhat, b3.dhat, isz);
    double dgui = mf_test_max_abs_diff(a3.zhat, a1.zhat, zsz);
    if (getenv("MF_TEST_VERBOSE"))
        printf("    view 0's latent target: max |zhat| %.4g; changed by %.4g (image darkened), %.4g (guidance 3 vs 1); albedo map by %.4g\n",
               scale, dimg, dgui, dmap);
    CHECK_MSG(dimg > 5e-2 * scale && dmap > 5e-2, "view 0's targets ignore its image (latent %.3g, map %.3g)", dimg, dmap);
    CHECK_MSG(dgui > 5e-2 * scale, "guidance 3 and 1 give the same targets (%.3g)", dgui);
    CHECK_MSG(memcmp(a0.zhat, b0.zhat, 2 * zsz * sizeof(float)) == 0 && memcmp(a0.dhat, b0.dhat, 4 * isz * sizeof(float)) == 0,
              "unconditional targets (guidance 0) depend on the image");
    mf_sds_targets_free(&a3), mf_sds_targets_free(&a1), mf_sds_targets_free(&a0);
    mf_sds_targets_free(&b3), mf_sds_targets_free(&b0);
    sds_done(&f);
}

/* The hook's fused path (one render and encode for targets and loss) equals the public pieces;
 * with every = 3 the term is computed at iterations 0, 3, ... and its gradient held in between. */
MF_TEST(fusion_sds_hook_every) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    o.every = 3;
    MfSds *s = sds_term(&f, &o);
    if (!r || !s) return;
    int batch[2] = {0, 1}, N = mf_recon_opts(r)->iters;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    MfSdsTargets t;
    double l = -1.0, h0 = -1.0, h1 = -1.0, h3 = -1.0;
    CHECK_OK(mf_sds_targets(s, r, batch, 2, 3, &t));
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 0, &l));
    mf_sds_targets_free(&t);
    mf_param_zero_grad(kd);
    CHECK_OK(mf_sds_hook(s, r, 0, batch, 2, &h0));
    float *g0 = malloc(kd->n * sizeof(float));
    if (!g0) return;
    memcpy(g0, kd->g, kd->n * sizeof(float));
    mf_param_zero_grad(kd);
    CHECK_OK(mf_sds_hook(s, r, 1, batch, 2, &h1)); /* held: the same gradient and loss, gamma(1) */
    double g1 = 1.0 - 1.0 / (double)N, err = 0.0, mag = 0.0;
    for (size_t i = 0; i < kd->n; ++i) err = fmax(err, fabs(kd->g[i] - g1 * g0[i])), mag = fmax(mag, fabs(g0[i]));
    CHECK(mag > 0.0 && err <= 1e-6 * mag);
    CHECK_NEAR(h1, g1 * h0, 1e-9 * h0);
    CHECK_OK(mf_sds_hook(s, r, 3, batch, 2, &h3)); /* refreshed */
    CHECK(l > 0.0);
    CHECK_NEAR(h3, (1.0 - 3.0 / (double)N) * l, 1e-6 * fabs(h3) + 1e-12);
    free(g0);
    sds_done(&f);
}

/* --sds-every 0: the interval follows the training images' pixels (4 at 128^2, at least 4), is
 * fixed at the first hook call and refreshes there as a given interval would. */
MF_TEST(fusion_sds_every_auto) {
    CHECK(mf_sds_every_auto(128, 128) == 4 && mf_sds_every_auto(256, 256) == 4 && mf_sds_every_auto(64, 64) == 16);
    CHECK(mf_sds_every_auto(96, 96) == 8 && mf_sds_every_auto(32, 32) == 64 && mf_sds_every_auto(128, 96) == 6);
    CHECK(mf_sds_every_auto(0, 0) == 1000000 && mf_sds_every_auto(1, 1) == 65536);
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2(), o256 = opts2();
    o.every = 0, o256.every = 256;
    MfSds *s = sds_term(&f, &o), *s256 = sds_term(&f, &o256);
    if (!r || !s || !s256) return;
    CHECK(mf_sds_every(s) == 0);
    int batch[2] = {0, 1};
    double h[2][3];
    for (int it = 0; it < 3; ++it) {
        CHECK_OK(mf_sds_hook(s, r, it, batch, 2, &h[0][it]));
        CHECK_OK(mf_sds_hook(s256, r, it, batch, 2, &h[1][it]));
    }
    CHECK(mf_sds_every(s) == 256); /* 16 x 16 views: ceil(4 * 128^2 / 256) */
    for (int it = 0; it < 3; ++it) CHECK(h[0][it] > 0.0 && h[0][it] == h[1][it]);
    sds_done(&f);
}

MF_TEST(fusion_sds_hook_schedule) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSds *s = sds_term(&f, NULL);
    if (!r || !s) return;
    int batch[2] = {0, 1};
    double l_first, l_last;
    /* gamma = 1 - (i/N)^p: the term vanishes at i = N and is full at i = 0 */
    CHECK_OK(mf_sds_hook(s, r, 0, batch, 2, &l_first));
    CHECK_OK(mf_sds_hook(s, r, 6, batch, 2, &l_last));
    CHECK(l_first > 0.0);
    CHECK(l_last == 0.0);
    /* the hook inside the loop runs and logs a non-zero loss_sds */
    MfReconHook hook = {mf_sds_hook, s};
    CHECK_OK(mf_recon_run(r, &hook, mf_test_path("mf_run")));
    char p[1024], *log = NULL;
    mf_test_path_to(p, sizeof p, "mf_run/log.csv");
    CHECK_OK(mf_read_file(p, &log, NULL));
    double sds = -1;
    const char *row1 = log ? strchr(log, '\n') : NULL;
    CHECK(row1 && sscanf(row1 + 1, "%*d,%*f,%*f,%*f,%*f,%lf", &sds) == 1 && sds > 0.0);
    free(log);
    sds_done(&f);
}

/* The term moves the textures toward the prior's targets: plain gradient steps on kd / ORM texels
 * against fixed targets lower the SDS loss; with both lambdas 0 the hook adds no gradient. */
MF_TEST(fusion_sds_moves_textures_toward_targets) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSds *s = sds_term(&f, NULL);
    if (!r || !s) return;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    MfSdsTargets t;
    int views[2] = {0, 2};
    CHECK_OK(mf_sds_targets(s, r, views, 2, 0, &t));
    double l0 = 0.0, l = 0.0;
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 0, &l0));
    for (int step = 0; step < 30; ++step) {
        mf_param_zero_grad(kd);
        mf_param_zero_grad(orm);
        CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 1, &l));
        MfParamBlock *b[2] = {kd, orm};
        for (int k = 0; k < 2; ++k)
            for (size_t i = 0; i < b[k]->n; ++i) b[k]->p[i] = fminf(1.0f, fmaxf(0.0f, b[k]->p[i] - 20.0f * b[k]->g[i]));
    }
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 0, &l));
    if (getenv("MF_TEST_VERBOSE")) printf("    SDS loss against fixed targets: %.5f -> %.5f after 30 steps\n", l0, l);
    CHECK_MSG(l < 0.7 * l0, "SDS loss %.5f -> %.5f: the textures did not move toward the targets", l0, l);
    mf_sds_targets_free(&t);
    /* lambdas 0: nothing is added */
    MfSdsOpts o = mf_sds_opts_default();
    o.lambda_latent = o.lambda_rgb = 0.0f;
    s = sds_term(&f, &o);
    mf_param_zero_grad(kd);
    double h = -1.0;
    CHECK_OK(mf_sds_hook(s, r, 0, views, 2, &h));
    double gmax = 0.0;
    for (size_t i = 0; i < kd->n; ++i) gmax = fmax(gmax, fabs(kd->g[i]));
    CHECK(h == 0.0 && gmax == 0.0);
    sds_done(&f);
}

/* gamma_i = 1 - (i/N)^p with p = 2, read off the held term's loss between refreshes. */
MF_TEST(fusion_sds_schedule_values) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    o.every = 8, o.gamma_p = 2.0f;
    MfSds *s = sds_term(&f, &o);
    if (!r || !s) return;
    int batch[2] = {0, 1}, N = mf_recon_opts(r)->iters; /* 6 */
    double l0, l;
    CHECK_OK(mf_sds_hook(s, r, 0, batch, 2, &l0));
    CHECK(l0 > 0.0);
    for (int it = 1; it < N; ++it) {
        CHECK_OK(mf_sds_hook(s, r, it, batch, 2, &l));
        double g = 1.0 - ((double)it / N) * ((double)it / N);
        CHECK_NEAR(l, g * l0, 1e-12 + 1e-9 * l0);
    }
    CHECK_OK(mf_sds_hook(s, r, N, batch, 2, &l));
    CHECK(l == 0.0);
    sds_done(&f);
}

/* L_rgb on [0, 1] maps is a quarter of the same term on [-1, 1] maps (targets fixed). */
MF_TEST(fusion_sds_rgb01_scale) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    o.lambda_latent = 0.0f;
    MfSds *s1 = sds_term(&f, &o);
    o.rgb01 = 0;
    MfSds *s0 = sds_term(&f, &o);
    if (!r || !s0 || !s1) return;
    MfSdsTargets t;
    int views[2] = {1, 3};
    CHECK_OK(mf_sds_targets(s1, r, views, 2, 0, &t));
    double l1, l0;
    CHECK_OK(mf_sds_loss(s1, r, &t, 1.0f, 0, &l1));
    CHECK_OK(mf_sds_loss(s0, r, &t, 1.0f, 0, &l0));
    CHECK(l0 > 0.0);
    CHECK_NEAR(l1, 0.25 * l0, 1e-6 * l0);
    mf_sds_targets_free(&t);
    sds_done(&f);
}

/* K views beyond the batch: the batch first, then distinct other views, the same for the same
 * iteration and different across iterations. */
MF_TEST(fusion_sds_pick_views) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 3;
    MfSds *s = sds_term(&f, &o);
    if (!r || !s) return;
    int batch[1] = {2}, v[MF_SDS_MAX_VIEWS], w[MF_SDS_MAX_VIEWS], differ = 0;
    for (int it = 0; it < 8; ++it) {
        CHECK(mf_sds_pick_views(s, r, it, batch, 1, v) == 3);
        CHECK(mf_sds_pick_views(s, r, it, batch, 1, w) == 3);
        CHECK(v[0] == 2 && !memcmp(v, w, sizeof(int) * 3));
        CHECK(v[1] != v[0] && v[2] != v[0] && v[2] != v[1] && v[1] >= 0 && v[1] < NV && v[2] >= 0 && v[2] < NV);
        int u[MF_SDS_MAX_VIEWS];
        mf_sds_pick_views(s, r, it + 1, batch, 1, u);
        differ |= memcmp(v, u, sizeof(int) * 3) != 0;
    }
    CHECK(differ);
    o.k_views = 8; /* more than the scene's 4 views: all of them, once each */
    s = sds_term(&f, &o);
    int seen = 0;
    CHECK(mf_sds_pick_views(s, r, 0, batch, 1, v) == NV);
    for (int i = 0; i < NV; ++i) seen |= 1 << v[i];
    CHECK(seen == (1 << NV) - 1);
    sds_done(&f);
}

/* With early_stop the held-out views (here 0 and 2 of 4) never get the prior term either. */
MF_TEST(fusion_sds_pick_views_skips_holdout) {
    SdsFix f;
    g_holdout_every = 2;
    MfRecon *r = sds_fix(&f);
    g_holdout_every = 0;
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 8;
    MfSds *s = sds_term(&f, &o);
    if (!r || !s) return;
    int batch[1] = {3}, v[MF_SDS_MAX_VIEWS];
    for (int it = 0; it < 4; ++it) {
        CHECK(mf_sds_pick_views(s, r, it, batch, 1, v) == 2);
        CHECK(v[0] == 3 && v[1] == 1);
    }
    sds_done(&f);
}

/* The iteration's other gradient g (n,) made from the prior's h (n,): for the conflict test. */
typedef void (*DataGradFn)(const float *h, float *g, size_t n);

/* The trust tests' common step: the plain hook s, then its variant sv, each at iteration 0 on
 * views {0, 1} from zeroed kd and ORM gradients; before the variant runs, the kd gradient is set
 * to data(h_kd) when data is given. *h_kd and *h_orm (malloc'ed, each block's n floats; free
 * them) hold the plain hook's gradients; on return the blocks hold the variant's. */
static int hook_then_variant(MfSds *s, MfSds *sv, MfRecon *r, DataGradFn data, float **h_kd, float **h_orm) {
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    int batch[2] = {0, 1};
    double l;
    *h_kd = *h_orm = NULL;
    mf_param_zero_grad(kd), mf_param_zero_grad(orm);
    int rc = mf_sds_hook(s, r, 0, batch, 2, &l);
    if (rc) return rc;
    *h_kd = malloc(kd->n * sizeof(float)), *h_orm = malloc(orm->n * sizeof(float));
    if (!*h_kd || !*h_orm) return mf_fail(MF_ENOMEM, "test: out of memory");
    memcpy(*h_kd, kd->g, kd->n * sizeof(float)), memcpy(*h_orm, orm->g, orm->n * sizeof(float));
    mf_param_zero_grad(kd), mf_param_zero_grad(orm);
    if (data) data(*h_kd, kd->g, kd->n);
    return mf_sds_hook(sv, r, 0, batch, 2, &l);
}

/* Against the prior on even texels, along it on odd ones. */
static float conflict_data_at(const float *h, size_t i) { return ((i / 3) % 2 ? 0.5f : -2.0f) * h[i]; }

static void conflict_data(const float *h, float *g, size_t n) {
    for (size_t i = 0; i < n; ++i) g[i] = conflict_data_at(h, i);
}

/* --sds-weight conflict: where the prior's texel gradient opposes the iteration's other gradient,
 * the opposing part is removed (here: exactly cancelled), elsewhere it is applied in full. */
MF_TEST(fusion_sds_conflict_weight) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    MfSds *s = sds_term(&f, &o);
    o.weight = MF_SDS_WEIGHT_CONFLICT;
    MfSds *sc = sds_term(&f, &o);
    if (!r || !s || !sc) return;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    float *h = NULL, *ho = NULL;
    CHECK_OK(hook_then_variant(s, sc, r, conflict_data, &h, &ho));
    if (mf_test_failed_now()) return;
    double hmax = 0.0, err = 0.0;
    int conflicts = 0;
    for (size_t i = 0; i < kd->n; ++i) {
        hmax = fmax(hmax, fabs(h[i]));
        float g0 = conflict_data_at(h, i);
        double want = (i / 3) % 2 ? g0 + h[i] : g0; /* opposing: the prior's part cancelled */
        err = fmax(err, fabs(kd->g[i] - want));
        conflicts += (i / 3) % 2 == 0 && h[i] != 0.0f;
    }
    CHECK(hmax > 0.0 && conflicts > 0);
    CHECK_MSG(err <= 1e-5 * hmax, "conflict weighting off by %.3g (prior gradient scale %.3g)", err, hmax);
    free(h), free(ho);
    sds_done(&f);
}

/* Coverage trust: a texel's count of views that see it equals, view by view, whether changing
 * that texel changes the view's albedo AOV (forward renders, an independent definition); the
 * hook then applies the prior's gradient times C0 / (C0 + count). */
MF_TEST(fusion_sds_coverage_weight) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    MfSds *s = sds_term(&f, &o);
    o.weight = MF_SDS_WEIGHT_COVERAGE;
    MfSds *sc = sds_term(&f, &o);
    if (!r || !s || !sc) return;
    float *w = NULL;
    size_t nt = 0;
    CHECK_OK(mf_sds_coverage(r, &w, &nt));
    MfImage kd0 = mf_recon_kd_image(r), orm = mf_recon_orm_image(r), kd;
    CHECK(nt == (size_t)kd0.w * (size_t)kd0.h && w != NULL);
    CHECK_OK(mf_image_alloc(&kd, kd0.w, kd0.h, 3));
    if (!w || !kd.data) return;
    MfDiffScene ds = {.rt = mf_recon_rtscene(r), .kd = &kd, .orm = &orm, .env = mf_recon_env(r)};
    int seen_some = 0, unseen_some = 0;
    float *a0 = malloc(RES * RES * 3 * sizeof(float)), *a1 = malloc(RES * RES * 3 * sizeof(float));
    float *m = malloc(RES * RES * 3 * sizeof(float));
    if (!a0 || !a1 || !m) return;
    for (size_t t = 0; t < nt; ++t) {
        int count = 0;
        for (int v = 0; v < NV; ++v) {
            MfDiffOpts dopt = {.spp_sqrt = 1, .pixel_samples = 1, .seed = 0x5eedu + (uint64_t)v};
            for (size_t i = 0; i < nt * 3; ++i) kd.data[i] = 0.5f;
            CHECK_OK(mf_diff_aov_forward(&ds, &mf_recon_view(r, v)->cam, &dopt, a0, m, NULL));
            kd.data[3 * t] = 0.9f;
            CHECK_OK(mf_diff_aov_forward(&ds, &mf_recon_view(r, v)->cam, &dopt, a1, m, NULL));
            int changed = 0;
            for (int i = 0; i < RES * RES * 3 && !changed; ++i) changed = a0[i] != a1[i];
            count += changed;
        }
        float want = MF_SDS_COVERAGE_C0 / (MF_SDS_COVERAGE_C0 + (float)count);
        CHECK_MSG(w[t] == want, "texel %zu: coverage weight %g, views that see it %d (weight %g)", t, w[t], count, want);
        seen_some |= count > 0, unseen_some |= count < NV;
    }
    CHECK(seen_some && unseen_some);
    /* the hook: prior gradient h scaled by the weight, texel by texel */
    MfParamBlock *kdb = mf_recon_block(r, MF_BLOCK_KD);
    float *h = NULL, *ho = NULL;
    CHECK_OK(hook_then_variant(s, sc, r, NULL, &h, &ho));
    if (mf_test_failed_now()) return;
    double err = 0.0, hmax = 0.0;
    for (size_t i = 0; i < kdb->n; ++i) {
        err = fmax(err, fabs(kdb->g[i] - h[i] * w[i / 3]));
        hmax = fmax(hmax, fabs(h[i]));
    }
    CHECK(hmax > 0.0);
    CHECK_MSG(err <= 1e-6 * hmax, "coverage weighting off by %.3g (prior gradient scale %.3g)", err, hmax);
    free(h), free(ho), free(w), free(a0), free(a1), free(m);
    mf_image_free(&kd);
    sds_done(&f);
}

/* Channel trust: the hook's ORM gradient has its roughness and metallic channels scaled by
 * trust_rough / trust_metal (occlusion and albedo untouched); trust 0 on both leaves only the
 * occlusion channel's pull; out-of-range trust is refused. */
MF_TEST(fusion_sds_channel_trust) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    MfSds *s = sds_term(&f, &o);
    o.trust_rough = 0.25f, o.trust_metal = 0.0f;
    MfSds *st = sds_term(&f, &o);
    if (!r || !s || !st) return;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    float *h = NULL, *hk = NULL;
    CHECK_OK(hook_then_variant(s, st, r, NULL, &hk, &h));
    if (mf_test_failed_now()) return;
    const float scale[3] = {1.0f, 0.25f, 0.0f};
    double err = 0.0, mag[3] = {0, 0, 0}, kerr = 0.0;
    for (size_t i = 0; i < orm->n; ++i) {
        err = fmax(err, fabs(orm->g[i] - scale[i % 3] * h[i]));
        mag[i % 3] = fmax(mag[i % 3], fabs(h[i]));
    }
    for (size_t i = 0; i < kd->n; ++i) kerr = fmax(kerr, fabs(kd->g[i] - hk[i]));
    CHECK(mag[1] > 0.0 && mag[2] > 0.0);
    CHECK_MSG(err <= 1e-6 * fmax(mag[1], mag[2]), "channel trust off by %.3g", err);
    CHECK(kerr == 0.0);
    free(h), free(hk);
    o.trust_metal = 1.5f;
    MfSds *bad = NULL;
    CHECK(mf_sds_new(NULL, &o, &bad) == MF_EARG && bad == NULL);
    sds_done(&f);
}

/* The SDS hook, killed (an error) when iteration `kill_at` begins: the checkpoint of the
 * iterations before it is on disk, as after a real interruption. */
typedef struct {
    MfSds *s;
    int kill_at;
} Killed;

static int killed_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    Killed *k = ctx;
    if (it == k->kill_at) return mf_fail(MF_EIO, "killed at iteration %d", it);
    return mf_sds_hook(k->s, r, it, batch, nb, loss);
}

/* A MaterialFusion run killed after a checkpoint and resumed in a fresh process state reaches the
 * bytes of the uninterrupted run (the held prior gradient is refreshed where it was; gamma_i
 * depends on the run's total iterations, which the resumed run keeps). */
MF_TEST(fusion_resume_is_exact) {
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 3, o.every = 3;
    MfMesh mf, mh, mr;
    MfRecon *full = NULL, *half = NULL, *res = NULL;
    MfSds *s1 = tiny_sds(&o), *s2 = tiny_sds(&o), *s3 = tiny_sds(&o);
    CHECK_OK(make_recon_n(&mf, &full, 8, 4));
    CHECK_OK(make_recon_n(&mh, &half, 8, 4));
    if (!full || !half || !s1 || !s2 || !s3) return;
    char fd[512], hd[512], ck[600];
    mf_test_path_to(fd, sizeof fd, "mf_full");
    mf_test_path_to(hd, sizeof hd, "mf_half");
    Killed k = {s2, 6};
    MfReconHook h1 = {mf_sds_hook, s1}, h2 = {killed_hook, &k}, h3 = {mf_sds_hook, s3};
    CHECK_OK(mf_recon_run(full, &h1, fd));
    CHECK_ERR(mf_recon_run(half, &h2, hd), "killed at iteration 6");
    /* a new process: fresh reconstruction and prior term, then the checkpoint */
    CHECK_OK(make_recon_n(&mr, &res, 8, 4));
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", hd);
    CHECK_OK(mf_recon_load_checkpoint(res, ck));
    CHECK(mf_recon_iteration(res) == 4);
    CHECK_OK(mf_recon_run(res, &h3, hd));
    const char *d = res ? first_diff_block(full, res) : NULL;
    CHECK_MSG(!d, "block %s differs after resume", d);
    mf_sds_free(s1), mf_sds_free(s2), mf_sds_free(s3);
    mf_recon_free(full), mf_recon_free(half), mf_recon_free(res);
    mf_mesh_free(&mf), mf_mesh_free(&mh), mf_mesh_free(&mr);
}


/* --sds-target mean: a view's targets are the prior's prediction from its image alone, held for the
 * run: the same bits at another iteration, in another batch and after the textures changed; with 2
 * samples the mean of the 1-sample target and a second sample, the variance that of the two; a
 * darker image gives another target. */
MF_TEST(fusion_sds_mean_targets_held) {
    MfMesh mesh;
    MfRecon *r = NULL;
    CHECK_OK(make_recon(&mesh, &r));
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 2;
    o.target = MF_SDS_TARGET_MEAN;
    o.mean_samples = 1;
    o.mean_steps = 3;
    MfSds *s1 = tiny_sds(&o);
    o.mean_samples = 2;
    o.weight = MF_SDS_WEIGHT_SPREAD;
    MfSds *s2 = tiny_sds(&o);
    o.mean_samples = 1;
    MfSds *bad = NULL;
    CHECK_ERR(mf_sds_new(NULL, &o, &bad), "--sds-mean-samples 1");
    o.weight = MF_SDS_WEIGHT_NONE;
    MfSds *s3 = tiny_sds(&o); /* as s1, for view 3 once its image is darkened */
    if (!r || !s1 || !s2 || !s3) return;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    size_t h = (size_t)cfg.ae.res / 4, zsz = 2u * cfg.ae.zc * h * h, isz = 3u * cfg.ae.res * cfg.ae.res;
    MfSdsTargets a, b, c;
    int va[2] = {0, 3}, vb[2] = {3, 1};
    CHECK_OK(mf_sds_targets(s1, r, va, 2, 5, &a));
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    for (size_t i = 0; i < kd->n; ++i) kd->p[i] = 0.5f * kd->p[i] + 0.3f; /* other textures */
    CHECK_OK(mf_sds_targets(s1, r, vb, 2, 9, &b));
    CHECK_OK(mf_sds_targets(s2, r, vb, 2, 9, &c));
    if (mf_test_failed_now()) return;
    CHECK(a.t == 0 && b.t == 0 && a.zvar == NULL && c.zvar != NULL && c.dvar != NULL);
    if (mf_test_failed_now()) return;
    /* view 3: item 1 of a, item 0 of b and c; maps (2, n, 3, R, R) */
    CHECK(memcmp(a.zhat + zsz, b.zhat, zsz * sizeof(float)) == 0);
    for (int kind = 0; kind < 2; ++kind)
        CHECK(memcmp(a.dhat + (2 * kind + 1) * isz, b.dhat + 2 * kind * isz, isz * sizeof(float)) == 0);
    double zerr = 0.0, derr = 0.0, vmax = 0.0;
    for (size_t i = 0; i < zsz; ++i) {
        double d = (double)c.zhat[i] - b.zhat[i];
        zerr = fmax(zerr, fabs(c.zvar[i] - 2.0 * d * d));
        vmax = fmax(vmax, c.zvar[i]);
    }
    for (int kind = 0; kind < 2; ++kind) {
        double kmax = 0.0; /* the samples differ in both maps */
        for (size_t i = 0; i < isz; ++i) {
            size_t j = 2 * kind * isz + i;
            double d = (double)c.dhat[j] - b.dhat[j];
            derr = fmax(derr, fabs(c.dvar[j] - 2.0 * d * d));
            kmax = fmax(kmax, c.dvar[j]);
        }
        CHECK_MSG(kmax > 0.0, "maps %d: no variance over the samples", kind);
    }
    CHECK(vmax > 0.0);
    CHECK_MSG(zerr <= 1e-5 * fmax(vmax, 1.0) && derr <= 1e-5, "sample variance off: latent %.3g, maps %.3g", zerr, derr);
    /* from the view's image: view 3 darkened, a fresh term's target for it moves */
    darken_view(r, 3);
    MfSdsTargets e;
    CHECK_OK(mf_sds_targets(s3, r, vb, 2, 9, &e));
    if (mf_test_failed_now()) return;
    double scale = 0.0, dz = 0.0, dm = 0.0;
    for (size_t i = 0; i < zsz; ++i) scale = fmax(scale, fabs(b.zhat[i])), dz = fmax(dz, fabs(e.zhat[i] - b.zhat[i]));
    for (size_t i = 0; i < isz; ++i) dm = fmax(dm, fabs(e.dhat[i] - b.dhat[i]));
    if (getenv("MF_TEST_VERBOSE")) printf("    view 3's mean target: max |zhat| %.4g; image darkened: latent moves %.4g, albedo map %.4g\n", scale, dz, dm);
    CHECK_MSG(dz > 5e-2 * scale && dm > 5e-2, "view 3's mean target ignores its image (latent %.3g, map %.3g)", dz, dm);
    mf_sds_targets_free(&a), mf_sds_targets_free(&b), mf_sds_targets_free(&c), mf_sds_targets_free(&e);
    mf_sds_free(s1), mf_sds_free(s2), mf_sds_free(s3);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* --sds-mv groups: consecutive training views in fours; the last four own only the remainder. */
MF_TEST(fusion_sds_mv_groups) {
    int start, size, own;
    mf_sds_mv_group(8, 5, &start, &size, &own);
    CHECK(start == 4 && size == 4 && own == 4);
    mf_sds_mv_group(6, 3, &start, &size, &own);
    CHECK(start == 0 && size == 4 && own == 0);
    mf_sds_mv_group(6, 5, &start, &size, &own); /* views 2..5 denoised together, 4 and 5 keep theirs */
    CHECK(start == 2 && size == 4 && own == 4);
    mf_sds_mv_group(3, 2, &start, &size, &own);
    CHECK(start == 0 && size == 3 && own == 0);
}

/* --sds-mv with mean targets: a view's target comes from its group's joint prediction, so it is the
 * same bits whichever member is picked first (--resume stays exact), and it depends on the other
 * members' images (the views attend to each other), while a single-view target does not. */
MF_TEST(fusion_sds_mv_mean_targets) {
    MfMesh mesh;
    MfRecon *r = NULL;
    CHECK_OK(make_recon(&mesh, &r));
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 1;
    o.target = MF_SDS_TARGET_MEAN;
    o.mean_samples = 2;
    o.mean_steps = 3;
    MfSds *alone = tiny_sds(&o);
    o.mv = 1;
    MfSds *s1 = tiny_sds(&o), *s2 = tiny_sds(&o), *s3 = tiny_sds(&o);
    o.mv = 0;
    MfSds *alone2 = tiny_sds(&o);
    if (!r || !alone || !alone2 || !s1 || !s2 || !s3) return;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    size_t h = (size_t)cfg.ae.res / 4, zsz = 2u * cfg.ae.zc * h * h, isz = 3u * cfg.ae.res * cfg.ae.res;
    MfSdsTargets a, b, c, d, e, f;
    int v0 = 0, v3 = 3;
    CHECK_OK(mf_sds_targets(s1, r, &v0, 1, 1, &a)); /* group {0..3} made for view 0 */
    CHECK_OK(mf_sds_targets(s1, r, &v3, 1, 2, &b)); /* view 3 from the held group */
    CHECK_OK(mf_sds_targets(s2, r, &v3, 1, 1, &c)); /* view 3 first in a fresh term */
    CHECK_OK(mf_sds_targets(alone, r, &v3, 1, 1, &d));
    darken_view(r, 0);
    CHECK_OK(mf_sds_targets(s3, r, &v3, 1, 1, &e));
    CHECK_OK(mf_sds_targets(alone2, r, &v3, 1, 1, &f));
    if (mf_test_failed_now()) return;
    CHECK(memcmp(b.zhat, c.zhat, zsz * sizeof(float)) == 0 && memcmp(b.dhat, c.dhat, 2 * isz * sizeof(float)) == 0);
    CHECK_MSG(memcmp(a.zhat, b.zhat, zsz * sizeof(float)) != 0, "views 0 and 3 got the same target");
    CHECK_MSG(memcmp(c.zhat, e.zhat, zsz * sizeof(float)) != 0, "view 3's joint target ignores view 0's image");
    CHECK(memcmp(d.zhat, f.zhat, zsz * sizeof(float)) == 0); /* alone: view 0 does not matter */
    mf_sds_targets_free(&a), mf_sds_targets_free(&b), mf_sds_targets_free(&c), mf_sds_targets_free(&d);
    mf_sds_targets_free(&e), mf_sds_targets_free(&f);
    mf_sds_free(alone), mf_sds_free(alone2), mf_sds_free(s1), mf_sds_free(s2), mf_sds_free(s3);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}


/* Views weights: a texel's variance over the views' means, 1 / (1 + var / mean var), scaled to mean 1
 * over the texels two or more views see; a texel one view sees keeps 1; channels outside [c0, c1)
 * are ignored. Texel 1: views 0.2 and 0.4 (var 0.01); texel 2: 0.3 twice (var 0); channel 0 of both
 * disagrees wildly but is outside [1, 3). */
MF_TEST(fusion_sds_agreement_weights) {
    double sum[9] = {0.5, 0.5, 0.5, 9.0, 0.6, 0.6, -9.0, 0.6, 0.6};
    double sum2[9] = {0.25, 0.25, 0.25, 90.0, 0.2, 0.2, 90.0, 0.18, 0.18};
    float nv[3] = {1, 2, 2}, w[3];
    double mv = 0.0;
    mf_sds_agreement_weights(sum, sum2, nv, 3, 1, 3, w, &mv);
    CHECK_NEAR(mv, 0.005, 1e-9);
    CHECK_NEAR(w[0], 1.0, 1e-6);
    CHECK_NEAR(w[1], 0.5, 1e-6); /* (1/3) * 1.5 */
    CHECK_NEAR(w[2], 1.5, 1e-6); /* 1 * 1.5 */
    MfSdsOpts o = mf_sds_opts_default();
    o.weight = MF_SDS_WEIGHT_VIEWS;
    MfSds *bad = NULL;
    CHECK_ERR(mf_sds_new(NULL, &o, &bad), "--sds-weight views needs --sds-target mean");
}

/* --sds-weight views in the hook: the prior's kd and ORM gradients are scaled texel by texel (one
 * factor per texel over its channels, >= 0), by factors that differ between texels (the 4 views'
 * held targets disagree more at some texels than at others). */
MF_TEST(fusion_sds_views_weight) {
    SdsFix f;
    MfRecon *r = sds_fix(&f);
    MfSdsOpts o = opts2();
    o.target = MF_SDS_TARGET_MEAN;
    o.mean_samples = 2;
    o.mean_steps = 3;
    MfSds *s = sds_term(&f, &o);
    o.weight = MF_SDS_WEIGHT_VIEWS;
    MfSds *sv = sds_term(&f, &o);
    if (!r || !s || !sv) return;
    MfParamBlock *blocks[2] = {mf_recon_block(r, MF_BLOCK_KD), mf_recon_block(r, MF_BLOCK_ORM)};
    float *h[2] = {NULL, NULL};
    CHECK_OK(hook_then_variant(s, sv, r, NULL, &h[0], &h[1]));
    if (mf_test_failed_now()) return;
    for (int b = 0; b < 2; ++b) {
        const float *g = blocks[b]->g;
        double wmin = INFINITY, wmax = 0.0;
        int bad = 0, used = 0;
        for (size_t t = 0; t + 2 < blocks[b]->n; t += 3) {
            int c0 = b ? 1 : 0, c = c0; /* ORM: roughness and metallic (occlusion's pull may be 0) */
            while (c < 3 && fabs(h[b][t + c]) < 1e-12) ++c;
            if (c == 3) continue;
            double w = g[t + c] / h[b][t + c];
            for (int k = c0; k < 3; ++k) bad += !(fabs(g[t + k] - w * h[b][t + k]) <= 1e-5 * fabs(h[b][t + k]) + 1e-12);
            bad += !(w >= 0.0) || !isfinite(w);
            wmin = fmin(wmin, w), wmax = fmax(wmax, w), ++used;
        }
        CHECK_MSG(bad == 0, "block %d: %d texel channels not scaled by one non-negative factor", b, bad);
        CHECK_MSG(used > 0 && wmax > 1.5 * wmin, "block %d: weights %g..%g over %d texels", b, wmin, wmax, used);
    }
    free(h[0]), free(h[1]);
    sds_done(&f);
}
