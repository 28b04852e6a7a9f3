/* Tests of mf/prior: diffusion math (closed forms), gradient checks of the autoencoder and the
 * denoiser, training on tiny synthetic data (loss decreases, resume is exact, checkpoints round
 * trip bit-exactly), refusal of bad weights, guidance, and the `mf prior` command. */
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

/* ---- diffusion math ------------------------------------------------------------------------------- */

MF_TEST(prior_schedule_values) {
    MfDiffusion d;
    mf_diffusion_init(&d);
    CHECK_NEAR(d.beta[0], 0.00085, 1e-15);
    CHECK_NEAR(d.beta[999], 0.012, 1e-15);
    double s = sqrt(0.00085) + (sqrt(0.012) - sqrt(0.00085)) * 500.0 / 999.0;
    CHECK_NEAR(d.beta[500], s * s, 1e-15);
    CHECK_NEAR(d.alpha_bar[0], 1.0 - 0.00085, 1e-15);
    long double ab = 1.0L;
    for (int t = 0; t < 1000; ++t) {
        long double q = sqrtl(0.00085L) + (sqrtl(0.012L) - sqrtl(0.00085L)) * t / 999.0L;
        ab *= 1.0L - q * q;
    }
    CHECK_NEAR(d.alpha_bar[999], (double)ab, 1e-12);
    CHECK(d.alpha_bar[999] > 0.004 && d.alpha_bar[999] < 0.006); /* SD's value: 0.00466 */
}

MF_TEST(prior_v_prediction_roundtrip) {
    MfDiffusion d;
    mf_diffusion_init(&d);
    enum { N = 64 };
    float x0[N], eps[N], xt[N], v[N], rx[N], re[N];
    MfRng r;
    mf_rng_seed(&r, 3, 1);
    for (int i = 0; i < N; ++i) x0[i] = mf_rng_normal(&r), eps[i] = mf_rng_normal(&r);
    int ts[4] = {0, 17, 500, 999};
    for (int k = 0; k < 4; ++k) {
        mf_diffusion_q_sample(&d, xt, x0, eps, ts[k], N);
        mf_diffusion_v_target(&d, v, x0, eps, ts[k], N);
        mf_diffusion_from_v(&d, rx, re, xt, v, ts[k], N);
        for (int i = 0; i < N; ++i) {
            CHECK_NEAR(rx[i], x0[i], 2e-6);
            CHECK_NEAR(re[i], eps[i], 2e-6);
        }
    }
}

typedef struct {
    const MfDiffusion *d;
    const float *x0;
    size_t n;
    int calls;
} TrueV;

/* The exact v for a known x0: x0 = sa xt - sb v  =>  v = (sa xt - x0) / sb. */
static int true_v(void *ctx, float *v, const float *xt, int t) {
    TrueV *c = ctx;
    double sa = sqrt(c->d->alpha_bar[t]), sb = sqrt(1.0 - c->d->alpha_bar[t]);
    for (size_t i = 0; i < c->n; ++i) v[i] = (float)((sa * xt[i] - c->x0[i]) / sb);
    c->calls++;
    return MF_OK;
}

/* The exact v of Gaussian data x0 ~ N(mu, sd^2) per element: E[x0 | xt] is linear in xt. */
typedef struct {
    const MfDiffusion *d;
    double mu, sd;
} GaussV;

static int gauss_v(void *ctx, float *v, const float *xt, int t) {
    GaussV *g = ctx;
    double sa = sqrt(g->d->alpha_bar[t]), sb = sqrt(1.0 - g->d->alpha_bar[t]), var = g->sd * g->sd;
    double k = sa * var / (sa * sa * var + sb * sb);
    for (int i = 0; i < 4096; ++i) {
        double x0 = g->mu + k * (xt[i] - sa * g->mu);
        v[i] = (float)((sa * xt[i] - x0) / sb);
    }
    return MF_OK;
}

/* A non-trivial DDIM case: Gaussian data x0 ~ N(mu, sd^2) with the exact posterior-mean v. Every
 * DDIM step is then affine in x, so 50 steps map each noise value x_T to A x_T + B with A, B
 * composed here in double from the step formula (x0^ = sa x - sb v, eps^ = sb x + sa v,
 * x' = sqrt(ab') x0^ + sqrt(1 - ab') eps^); the sampler must agree per element to 1e-4. For this
 * schedule A = 0.4765, B = 0.2891 (the probability-flow limit would be 0.5 and 0.3 - 0.5 * 0.0204:
 * the gap is the 50-step discretisation, reproduced exactly). */
MF_TEST(prior_ddim_samples_gaussian_data) {
    MfDiffusion d;
    mf_diffusion_init(&d);
    enum { N = 4096 };
    static float x[N], x_t[N], v[N];
    MfRng r;
    mf_rng_seed(&r, 9, 1);
    for (int i = 0; i < N; ++i) x_t[i] = x[i] = mf_rng_normal(&r);
    int s50[50];
    mf_diffusion_inference_steps(s50, 50);
    GaussV g = {&d, 0.3, 0.5};
    CHECK_OK(mf_diffusion_ddim(&d, x, v, N, s50, 50, gauss_v, &g));
    double A = 1.0, B = 0.0, var = g.sd * g.sd;
    for (int k = 0; k < 50; ++k) {
        int t = s50[k];
        double sa = sqrt(d.alpha_bar[t]), sb = sqrt(1.0 - d.alpha_bar[t]);
        double ap = k + 1 < 50 ? d.alpha_bar[s50[k + 1]] : 1.0, kk = sa * var / (sa * sa * var + sb * sb);
        double c0 = kk, d0 = g.mu - kk * sa * g.mu;     /* x0^ = c0 x + d0 */
        double ce = (1.0 - sa * c0) / sb, de = -sa * d0 / sb; /* eps^ = ce x + de */
        double cx = sqrt(ap) * c0 + sqrt(1.0 - ap) * ce, dx = sqrt(ap) * d0 + sqrt(1.0 - ap) * de;
        A *= cx, B = cx * B + dx;
    }
    double err = 0.0;
    for (int i = 0; i < N; ++i) err = fmax(err, fabs(x[i] - (A * x_t[i] + B)));
    if (getenv("MF_TEST_VERBOSE")) printf("    DDIM on N(0.3, 0.5^2): A %.4f B %.4f, max error %.2g\n", A, B, err);
    CHECK_NEAR(A, 0.4765, 1e-3);
    CHECK_NEAR(B, 0.2891, 1e-3);
    CHECK_MSG(err < 1e-4, "DDIM differs from the exact affine map by %.3g", err);
}

MF_TEST(prior_ddim_with_true_v_returns_x0) {
    MfDiffusion d;
    mf_diffusion_init(&d);
    enum { N = 32 };
    float x0[N], x[N], v[N], eps[N];
    MfRng r;
    mf_rng_seed(&r, 5, 1);
    for (int i = 0; i < N; ++i) x0[i] = mf_rng_normal(&r), eps[i] = mf_rng_normal(&r);
    /* SDS list [t, .8t, .6t, .4t, .2t] then x0 */
    int t = 700, steps[5] = {700, 560, 420, 280, 140};
    mf_diffusion_q_sample(&d, x, x0, eps, t, N);
    TrueV c = {&d, x0, N, 0};
    CHECK_OK(mf_diffusion_ddim(&d, x, v, N, steps, 5, true_v, &c));
    CHECK(c.calls == 5);
    for (int i = 0; i < N; ++i) CHECK_NEAR(x[i], x0[i], 1e-4);
    /* full 50-step inference list from pure noise */
    int s50[50];
    mf_diffusion_inference_steps(s50, 50);
    CHECK(s50[0] == 981 && s50[49] == 1);
    for (int i = 0; i < N; ++i) x[i] = mf_rng_normal(&r);
    CHECK_OK(mf_diffusion_ddim(&d, x, v, N, s50, 50, true_v, &c));
    for (int i = 0; i < N; ++i) CHECK_NEAR(x[i], x0[i], 1e-4);
    int bad[2] = {100, 200};
    CHECK_ERR(mf_diffusion_ddim(&d, x, v, N, bad, 2, true_v, &c), "descend");
}

MF_TEST(prior_cfg_formula) {
    float u[3] = {1, 2, 3}, c[3] = {2, 0, 3}, o[3];
    mf_diffusion_cfg(o, u, c, 3.0f, 3);
    CHECK_NEAR(o[0], 4.0, 0);
    CHECK_NEAR(o[1], -4.0, 0);
    CHECK_NEAR(o[2], 3.0, 0);
    mf_diffusion_cfg(o, u, c, 1.0f, 3);
    for (int i = 0; i < 3; ++i) CHECK(o[i] == c[i]);
}

/* ---- gradient checks -------------------------------------------------------------------------------- */

static void fill(float *x, size_t n, uint64_t seed, float s) {
    MfRng r;
    mf_rng_seed(&r, seed, 9);
    for (size_t i = 0; i < n; ++i) x[i] = s * (2.0f * mf_rng_float(&r) - 1.0f);
}

static double dot(const float *a, const float *b, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += (double)a[i] * b[i];
    return s;
}

typedef struct {
    MfAe *ae;
    MfAeWork w;
    const float *x, *wout;
    int B;
} AeGC;

static double ae_loss(AeGC *g) {
    float *z = mf_ae_encode(g->ae, &g->w, g->x, g->B), *y = mf_ae_decode(g->ae, &g->w, z, g->B);
    int R = g->ae->cfg.res;
    return dot(y, g->wout, (size_t)g->B * 3 * R * R);
}

/* The frozen encoder's backward (mf_ae_encode_backward_input, what SDS uses) gives the same input
 * gradient bit for bit as the full backward and leaves the weight gradients alone: at 8 px (the
 * convolutions' batched path) and at 32 px (per-item GEMMs at full resolution, 1x1 skip convs). */
MF_TEST(prior_ae_encode_backward_input_only) {
    MfAeConfig cfgs[2] = {{8, 2, 4, 4, 2}, {32, 4, 8, 4, 2}};
    for (int c = 0; c < 2; ++c) {
        MfAe *ae;
        CHECK_OK(mf_ae_new(&ae, &cfgs[c]));
        mf_ae_init_weights(ae, 11);
        int B = 3, R = cfgs[c].res, h = R / 4;
        size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * 4 * h * h;
        float *x = malloc(ni * sizeof(float)), *dz = malloc(nz * sizeof(float));
        float *da = calloc(ni, sizeof(float)), *db = calloc(ni, sizeof(float));
        fill(x, ni, 3, 1.0f), fill(dz, nz, 4, 1.0f);
        MfAeWork w = {0};
        CHECK(mf_ae_encode(ae, &w, x, B) != NULL);
        memset(ae->grads, 0, ae->tab.numel * sizeof(float));
        mf_ae_encode_backward(ae, &w, dz, da);
        double gsum = 0.0;
        for (size_t i = 0; i < ae->tab.numel; ++i) gsum += fabs(ae->grads[i]);
        CHECK(gsum > 0.0);
        memset(ae->grads, 0, ae->tab.numel * sizeof(float));
        mf_ae_encode_backward_input(ae, &w, dz, db);
        size_t diff = 0, nonzero = 0, gtouched = 0;
        for (size_t i = 0; i < ni; ++i) diff += memcmp(&da[i], &db[i], sizeof(float)) != 0, nonzero += da[i] != 0.0f;
        for (size_t i = 0; i < ae->tab.numel; ++i) gtouched += ae->grads[i] != 0.0f;
        CHECK_MSG(diff == 0 && nonzero > ni / 2, "res %d: %zu of %zu input gradients differ (%zu non-zero)", R, diff, ni, nonzero);
        CHECK_MSG(gtouched == 0, "res %d: the input-only backward wrote %zu weight gradients", R, gtouched);
        mf_ae_work_free(&w);
        free(x), free(dz), free(da), free(db);
        mf_ae_free(ae);
    }
}

MF_TEST(prior_ae_shapes_and_gradients) {
    MfAeConfig cfg = {8, 2, 4, 4, 2};
    MfAe *ae;
    CHECK_OK(mf_ae_new(&ae, &cfg));
    mf_ae_init_weights(ae, 7);
    int B = 2, R = 8;
    size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * 4 * 2 * 2;
    CHECK(ae->enc.C == 4 && ae->enc.H == 2 && ae->dec.C == 3 && ae->dec.H == 8);
    float *x = malloc(ni * sizeof(float)), *wo = malloc(ni * sizeof(float)), *dx = calloc(ni, sizeof(float));
    float *dz = calloc(nz, sizeof(float));
    fill(x, ni, 1, 1.0f), fill(wo, ni, 2, 1.0f);
    AeGC g = {.ae = ae, .x = x, .wout = wo, .B = B};
    ae_loss(&g);
    memset(ae->grads, 0, ae->tab.numel * sizeof(float));
    mf_ae_decode_backward(ae, &g.w, wo, dz);
    mf_ae_encode_backward(ae, &g.w, dz, dx);
    /* parameters: a spread of indices over every tensor */
    int bad = 0, checked = 0;
    double gmax = 0;
    for (size_t i = 0; i < ae->tab.numel; ++i) gmax = fmax(gmax, fabs(ae->grads[i]));
    CHECK(gmax > 1e-2); /* the check below is not vacuous */
    for (size_t i = 0; i < ae->tab.numel; i += 1 + ae->tab.numel / 60) {
        float keep = ae->params[i];
        double h = 1e-2 * fmax(1.0, fabs(keep));
        ae->params[i] = keep + (float)h;
        double lp = ae_loss(&g);
        ae->params[i] = keep - (float)h;
        double lm = ae_loss(&g);
        ae->params[i] = keep;
        double num = (lp - lm) / (2 * h), an = ae->grads[i];
        if (fabs(num - an) > 2e-2 * fmax(1.0, fabs(num))) ++bad;
        ++checked;
    }
    for (size_t i = 0; i < ni; i += 13) {
        float keep = x[i];
        x[i] = keep + 1e-2f;
        double lp = ae_loss(&g);
        x[i] = keep - 1e-2f;
        double lm = ae_loss(&g);
        x[i] = keep;
        double num = (lp - lm) / 2e-2;
        if (fabs(num - dx[i]) > 2e-2 * fmax(1.0, fabs(num))) ++bad;
        ++checked;
    }
    CHECK_MSG(bad == 0, "%d of %d AE gradient entries off", bad, checked);
    mf_ae_work_free(&g.w);
    free(x), free(wo), free(dx), free(dz);
    mf_ae_free(ae);
}

typedef struct {
    MfDenoiser *dn;
    MfDenoiserWork w;
    const float *x, *t, *rgb, *keep, *wout;
    int B, V, joint;
} DnGC;

static double dn_loss(DnGC *g) {
    float *v = mf_denoiser_forward(g->dn, &g->w, g->x, g->t, g->rgb, g->keep, g->B, g->V, g->joint);
    const MfDenoiserConfig *c = &g->dn->cfg;
    return dot(v, g->wout, (size_t)g->B * 2 * c->zc * c->h * c->h);
}

MF_TEST(prior_denoiser_gradients) {
    MfPriorConfig pc;
    mf_prior_config_tiny(&pc);
    MfDenoiser *dn;
    CHECK_OK(mf_denoiser_new(&dn, &pc.dn));
    mf_denoiser_init_weights(dn, 3);
    mf_kconv_init(&dn->cout, dn->params, 99, 0); /* non-zero output conv so every layer gets gradient */
    const MfDenoiserConfig *c = &dn->cfg;
    int B = 4, V = 2;
    size_t nx = (size_t)B * 3 * c->zc * c->h * c->h, nv = (size_t)B * 2 * c->zc * c->h * c->h,
           ni = (size_t)B * 3 * c->img_res * c->img_res;
    float *x = malloc(nx * sizeof(float)), *rgb = malloc(ni * sizeof(float)), *wo = malloc(nv * sizeof(float));
    float t[4] = {10, 500, 999, 250}, keep[4] = {1, 0, 1, 1};
    fill(x, nx, 4, 1.0f), fill(rgb, ni, 5, 1.0f), fill(wo, nv, 6, 1.0f);
    for (int joint = 0; joint < 2; ++joint) {
        DnGC g = {.dn = dn, .x = x, .t = t, .rgb = rgb, .keep = keep, .wout = wo, .B = B, .V = V, .joint = joint};
        dn_loss(&g);
        memset(dn->grads, 0, dn->tab.numel * sizeof(float));
        mf_denoiser_backward(dn, &g.w, wo);
        int bad = 0, checked = 0;
        for (size_t i = 0; i < dn->tab.numel; i += 1 + dn->tab.numel / 150) {
            float k0 = dn->params[i];
            double h = 1e-2 * fmax(1.0, fabs(k0));
            dn->params[i] = k0 + (float)h;
            double lp = dn_loss(&g);
            dn->params[i] = k0 - (float)h;
            double lm = dn_loss(&g);
            dn->params[i] = k0;
            double num = (lp - lm) / (2 * h), an = dn->grads[i];
            if (fabs(num - an) > 2e-2 * fmax(1.0, fabs(num))) {
                if (bad < 5) fprintf(stderr, "  param %zu: numeric %.6g analytic %.6g\n", i, num, an);
                ++bad;
            }
            ++checked;
        }
        CHECK_MSG(bad == 0, "joint %d: %d of %d denoiser gradient entries off", joint, bad, checked);
        mf_denoiser_work_free(&g.w);
    }
    free(x), free(rgb), free(wo);
    mf_denoiser_free(dn);
}

/* ---- synthetic prior-train data ------------------------------------------------------------------------ */

/* n samples at R px in the prior-train layout: a disc or a square of one albedo (sRGB codes) and
 * one ORM (R = 1), lit by a shading factor with a left-to-right gradient; alpha = the shape. */
static void write_synth(const char *dir, int n, int R, uint64_t seed) {
    char path[MF_PATH_MAX], rel[64];
    const char *kinds[3] = {"rgb", "albedo", "orm"};
    for (int k = 0; k < 3; ++k) {
        mf_path_join(path, sizeof path, dir, kinds[k]);
        mf_mkdirs(path);
    }
    MfRng r;
    mf_rng_seed(&r, seed, 77);
    for (int i = 0; i < n; ++i) {
        float alb[3], orm[3] = {1, 0, 0};
        for (int c = 0; c < 3; ++c) alb[c] = 0.1f + 0.85f * mf_rng_float(&r);
        orm[1] = 0.1f + 0.9f * mf_rng_float(&r), orm[2] = mf_rng_float(&r) < 0.5f ? 0.0f : 1.0f;
        int square = mf_rng_float(&r) < 0.5f;
        float cx = R * (0.35f + 0.3f * mf_rng_float(&r)), cy = R * (0.35f + 0.3f * mf_rng_float(&r));
        float rad = R * (0.2f + 0.15f * mf_rng_float(&r)), shade = 0.4f + 0.6f * mf_rng_float(&r);
        MfImage im[3];
        for (int k = 0; k < 3; ++k) mf_image_alloc(&im[k], R, R, 4);
        for (int y = 0; y < R; ++y)
            for (int x = 0; x < R; ++x) {
                float dx = x + 0.5f - cx, dy = y + 0.5f - cy;
                int in = square ? (fabsf(dx) < rad && fabsf(dy) < rad) : (dx * dx + dy * dy < rad * rad);
                if (!in) continue;
                float s = shade * (0.6f + 0.4f * (x + 0.5f) / R);
                for (int c = 0; c < 3; ++c) {
                    mf_image_px(&im[0], x, y)[c] = alb[c] * s;
                    mf_image_px(&im[1], x, y)[c] = alb[c];
                    mf_image_px(&im[2], x, y)[c] = orm[c];
                }
                for (int k = 0; k < 3; ++k) mf_image_px(&im[k], x, y)[3] = 1.0f;
            }
        for (int k = 0; k < 3; ++k) {
            snprintf(rel, sizeof rel, "%s/%06d.png", kinds[k], i);
            mf_path_join(path, sizeof path, dir, rel);
            CHECK_OK(mf_image_write(path, &im[k], MF_ENC_LINEAR, 8)); /* raw codes */
            mf_image_free(&im[k]);
        }
    }
    char man[256];
    snprintf(man, sizeof man, "{\"split\":\"prior-train\",\"resolution\":%d,\"count\":%d,\"seed\":%llu,\"objects\":%d}\n",
             R, n, (unsigned long long)seed, n);
    mf_path_join(path, sizeof path, dir, "manifest.json");
    CHECK_OK(mf_write_file(path, man, strlen(man)));
}

static const char *synth_dir(void) {
    static int made = 0;
    const char *dir = mf_test_path("prior_synth");
    static char keep[MF_PATH_MAX];
    if (!made) {
        snprintf(keep, sizeof keep, "%s", dir);
        write_synth(keep, 24, 16, 11);
        made = 1;
    }
    return keep;
}

static void tiny_opts(MfTrainPriorOpts *o, const char *out, const char *csv) {
    mf_train_prior_defaults(o);
    o->data_dir = synth_dir(), o->out_dir = out, o->loss_csv = csv;
    o->tiny = 1, o->batch = 8, o->ae_steps = 60, o->steps = 60, o->warmup = 5, o->ckpt_every = 7;
    o->lr_ae = 3e-3f, o->lr_dn = 2e-3f, o->seed = 5;
}

static int files_equal(const char *a, const char *b) {
    char *da = NULL, *db = NULL;
    size_t la = 0, lb = 0;
    int eq = !mf_read_file(a, &da, &la) && !mf_read_file(b, &db, &lb) && la == lb && !memcmp(da, db, la);
    free(da), free(db);
    return eq;
}

MF_TEST(prior_train_tiny_reduces_loss_and_roundtrips) {
    char out[MF_PATH_MAX], csv[MF_PATH_MAX], w[MF_PATH_MAX], w2[MF_PATH_MAX];
    snprintf(out, sizeof out, "%s", mf_test_path("prior_run_a"));
    snprintf(csv, sizeof csv, "%s", mf_test_path("prior_run_a.csv"));
    MfTrainPriorOpts o;
    tiny_opts(&o, out, csv);
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
    snprintf(w2, sizeof w2, "%s", mf_test_path("prior_copy.mfck"));
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
    fill(rgb, ni, 8, 1.0f);
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
    snprintf(a, sizeof a, "%s", mf_test_path("prior_res_a"));
    snprintf(b, sizeof b, "%s", mf_test_path("prior_res_b"));
    snprintf(ca, sizeof ca, "%s", mf_test_path("prior_res_a.csv"));
    snprintf(cb, sizeof cb, "%s", mf_test_path("prior_res_b.csv"));
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tiny_opts(&o, a, ca);
    o.ae_steps = 10, o.steps = 10, o.ckpt_every = 3;
    CHECK_OK(mf_train_prior(&o, &r));
    CHECK(!r.stopped);
    /* interrupted twice: once inside the AE phase, once inside the denoiser phase */
    tiny_opts(&o, b, cb);
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
    snprintf(a, sizeof a, "%s", mf_test_path("prior_nan"));
    snprintf(ca, sizeof ca, "%s", mf_test_path("prior_nan.csv"));
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tiny_opts(&o, a, ca);
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

static void tiny_prior(MfPrior **p) {
    MfPriorConfig c;
    mf_prior_config_tiny(&c);
    CHECK_OK(mf_prior_new(p, &c));
    mf_ae_init_weights((*p)->ae, 1);
    mf_denoiser_init_weights((*p)->dn, 2);
    mf_kconv_init(&(*p)->dn->cout, (*p)->dn->params, 3, 0);
    (*p)->latent_scale = 0.7f;
}

MF_TEST(prior_bad_weights_refused) {
    MfPrior *p, *q = NULL;
    tiny_prior(&p);
    const char *good = mf_test_path("prior_good.mfck");
    char path[MF_PATH_MAX];
    CHECK_OK(mf_prior_save(p, good, NULL));
    CHECK_ERR(mf_prior_load(mf_test_path("prior_missing.mfck"), &q), "prior_missing.mfck: cannot open prior weights");
    CHECK_ERR(mf_prior_load(mf_test_path("prior_missing.mfck"), &q), "MFCK version 1");
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    /* truncated */
    snprintf(path, sizeof path, "%s", mf_test_path("prior_trunc.mfck"));
    CHECK_OK(mf_write_file(path, d, len / 2));
    CHECK_ERR(mf_prior_load(path, &q), "truncated");
    CHECK_ERR(mf_prior_load(path, &q), "expected prior weights");
    CHECK_OK(mf_write_file(path, d, 10));
    CHECK_ERR(mf_prior_load(path, &q), "truncated");
    /* wrong container version */
    d[4] = 7;
    CHECK_OK(mf_write_file(path, d, len));
    CHECK_ERR(mf_prior_load(path, &q), "unsupported checkpoint version 7");
    d[4] = 1;
    /* corrupt data */
    d[len - 20] ^= 0x55;
    CHECK_OK(mf_write_file(path, d, len));
    CHECK_ERR(mf_prior_load(path, &q), "checksum mismatch");
    free(d);
    /* wrong format version in the meta */
    MfTensorSpec *specs = malloc((size_t)(p->ae->tab.n + p->dn->tab.n) * sizeof *specs);
    memcpy(specs, p->ae->tab.v, (size_t)p->ae->tab.n * sizeof *specs);
    memcpy(specs + p->ae->tab.n, p->dn->tab.v, (size_t)p->dn->tab.n * sizeof *specs);
    int n = p->ae->tab.n + p->dn->tab.n;
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(good, &meta));
    char *vpos = meta ? strstr(meta, "\"version\":1") : NULL;
    CHECK(vpos != NULL);
    if (vpos) vpos[10] = '2';
    float *data = calloc(mf_specs_numel(specs, n) + 64, sizeof(float));
    CHECK_OK(mf_ckpt_save(path, specs, n, data, meta));
    CHECK_ERR(mf_prior_load(path, &q), "unsupported mf-prior format version 2");
    if (vpos) vpos[10] = '1';
    /* wrong shape: one tensor's shape changed */
    specs[0].shape[0] += 1;
    CHECK_OK(mf_ckpt_save(path, specs, n, data, meta));
    CHECK_ERR(mf_prior_load(path, &q), "shape mismatch");
    CHECK_ERR(mf_prior_load(path, &q), "expected prior weights");
    CHECK(q == NULL);
    free(meta), free(data), free(specs);
    mf_prior_free(p);
}

/* The DDIM steps of one sample reuse the condition images' embedding (mf_denoiser_forward_ex with
 * same_rgb): a step so computed equals, bit for bit, the same step on fresh work buffers; a
 * different rgb without same_rgb gives a different prediction (the embedding is not stale). */
MF_TEST(prior_denoiser_reuses_image_embedding) {
    MfPrior *p;
    tiny_prior(&p);
    int B = 4, R = 16, zc = 4, h = 4;
    size_t ni = (size_t)B * 3 * R * R, nx = (size_t)B * 3 * zc * h * h, nv = (size_t)B * 2 * zc * h * h;
    float *rgb = malloc(ni * sizeof(float)), *rgb2 = malloc(ni * sizeof(float));
    float *x1 = malloc(nx * sizeof(float)), *x2 = malloc(nx * sizeof(float)), *va = malloc(nv * sizeof(float));
    fill(rgb, ni, 1, 1.0f), fill(rgb2, ni, 7, 1.0f), fill(x1, nx, 2, 1.0f), fill(x2, nx, 3, 1.0f);
    float t1[4] = {800, 800, 800, 800}, t2[4] = {640, 640, 640, 640}, keep[4] = {1, 0, 1, 0};
    MfDenoiserWork w = {0}, f = {0};
    CHECK(mf_denoiser_forward(p->dn, &w, x1, t1, rgb, keep, B, 1, 0) != NULL);
    float *v = mf_denoiser_forward_ex(p->dn, &w, x2, t2, rgb, keep, B, 1, 0, 1);
    CHECK(v != NULL);
    if (v) memcpy(va, v, nv * sizeof(float));
    float *vf = mf_denoiser_forward(p->dn, &f, x2, t2, rgb, keep, B, 1, 0);
    CHECK(vf != NULL);
    CHECK_MSG(vf && !memcmp(va, vf, nv * sizeof(float)), "a step with the reused embedding differs from a fresh one");
    v = mf_denoiser_forward_ex(p->dn, &w, x2, t2, rgb2, keep, B, 1, 0, 0);
    double d = 0.0;
    for (size_t i = 0; v && i < nv; ++i) d = fmax(d, fabs(v[i] - va[i]));
    CHECK_MSG(d > 1e-6, "another condition image changes the prediction by %g only", d);
    mf_denoiser_work_free(&w), mf_denoiser_work_free(&f);
    free(rgb), free(rgb2), free(x1), free(x2), free(va);
    mf_prior_free(p);
}

MF_TEST(prior_guidance_one_is_conditional) {
    MfPrior *p;
    tiny_prior(&p);
    int B = 4, R = 16, zc = 4, h = 4;
    size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * zc * h * h;
    float *rgb = malloc(ni * sizeof(float)), *zimg = malloc(nz * sizeof(float)), *xt = malloc(2 * nz * sizeof(float));
    float *v1 = malloc(2 * nz * sizeof(float)), *v3 = malloc(2 * nz * sizeof(float)), *x = malloc(3 * nz * sizeof(float));
    fill(rgb, ni, 1, 1.0f), fill(zimg, nz, 2, 1.0f), fill(xt, 2 * nz, 3, 1.0f);
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 0, 1.0f, v1));
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 0, 3.0f, v3));
    /* the conditional prediction alone */
    for (int b = 0; b < B; ++b) {
        memcpy(x + (size_t)b * 3 * zc * h * h, zimg + (size_t)b * zc * h * h, (size_t)zc * h * h * sizeof(float));
        memcpy(x + (size_t)b * 3 * zc * h * h + zc * h * h, xt + (size_t)b * 2 * zc * h * h,
               (size_t)2 * zc * h * h * sizeof(float));
    }
    float t[4] = {400, 400, 400, 400}, keep[4] = {1, 1, 1, 1};
    MfDenoiserWork w = {0};
    float *vc = mf_denoiser_forward(p->dn, &w, x, t, rgb, keep, B, 1, 0);
    double diff1 = 0, diff3 = 0;
    for (size_t i = 0; i < 2 * nz; ++i) diff1 = fmax(diff1, fabs(v1[i] - vc[i])), diff3 = fmax(diff3, fabs(v3[i] - vc[i]));
    CHECK_MSG(diff1 < 1e-5, "guidance 1 differs from the conditional prediction by %g", diff1);
    CHECK(diff3 > 1e-3); /* guidance 3 does change it */
    /* multi-view: joint attention over V = 4 views changes the prediction, V = 1 joint does not */
    float *vj = malloc(2 * nz * sizeof(float));
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 4, 1, 3.0f, vj));
    double dj = 0;
    for (size_t i = 0; i < 2 * nz; ++i) dj = fmax(dj, fabs(vj[i] - v3[i]));
    CHECK(dj > 1e-5);
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 1, 3.0f, vj));
    dj = 0;
    for (size_t i = 0; i < 2 * nz; ++i) dj = fmax(dj, fabs(vj[i] - v3[i]));
    CHECK(dj < 1e-5);
    mf_denoiser_work_free(&w);
    free(rgb), free(zimg), free(xt), free(v1), free(v3), free(x), free(vj);
    mf_prior_free(p);
}

/* mf_prior_predict_mean (eval-prior's predictions): a view's maps depend on its own image only
 * when the views are predicted alone (each one's condition image in its own batch items). */
MF_TEST(prior_predict_mean_views_independent) {
    MfPrior *p;
    tiny_prior(&p);
    int R = 16;
    MfImage in[3] = {{0}}, alb[2][2] = {{{0}}}, orm[2][2] = {{{0}}};
    for (int k = 0; k < 3; ++k) {
        CHECK_OK(mf_image_alloc(&in[k], R, R, 4));
        fill(in[k].data, (size_t)R * R * 4, 20 + k, 0.5f);
        for (size_t q = 0; q < (size_t)R * R * 4; ++q) in[k].data[q] = q % 4 == 3 ? 1.0f : in[k].data[q] + 0.5f;
    }
    /* views (A, B) and (A, C), same seed: view A's maps must not change */
    const MfImage ab[2] = {in[0], in[1]}, ac[2] = {in[0], in[2]};
    CHECK_OK(mf_prior_predict_mean(p, ab, 2, 2, 0, 2, 2, 3.0f, 7, alb[0], orm[0]));
    CHECK_OK(mf_prior_predict_mean(p, ac, 2, 2, 0, 2, 2, 3.0f, 7, alb[1], orm[1]));
    double d0 = 0, d1 = 0;
    for (size_t q = 0; q < (size_t)R * R * 4; ++q) {
        d0 = fmax(d0, fabs(alb[0][0].data[q] - alb[1][0].data[q]) + fabs(orm[0][0].data[q] - orm[1][0].data[q]));
        d1 = fmax(d1, fabs(alb[0][1].data[q] - alb[1][1].data[q]));
    }
    CHECK_MSG(d0 == 0, "view 0's maps changed by %g with view 1's image", d0);
    CHECK(d1 > 1e-4); /* the condition image does matter */
    CHECK(alb[0][0].w == R && alb[0][0].c == 4 && orm[0][0].data[0] == 1.0f); /* ORM R = 1 */
    for (int k = 0; k < 3; ++k) mf_image_free(&in[k]);
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b) mf_image_free(&alb[a][b]), mf_image_free(&orm[a][b]);
    mf_prior_free(p);
}

MF_TEST(prior_encode_backward_matches_differences) {
    MfPrior *p;
    tiny_prior(&p);
    int B = 1, R = 16;
    size_t ni = (size_t)3 * R * R, nz = 4 * 4 * 4;
    float *img = malloc(ni * sizeof(float)), *z = malloc(nz * sizeof(float)), *wz = malloc(nz * sizeof(float));
    float *dimg = calloc(ni, sizeof(float));
    fill(img, ni, 4, 1.0f), fill(wz, nz, 5, 1.0f);
    CHECK_OK(mf_prior_encode(p, img, B, z));
    mf_prior_encode_backward(p, wz, dimg);
    int bad = 0;
    for (size_t i = 0; i < ni; i += 17) {
        float k = img[i];
        img[i] = k + 1e-2f;
        mf_prior_encode(p, img, B, z);
        double lp = dot(z, wz, nz);
        img[i] = k - 1e-2f;
        mf_prior_encode(p, img, B, z);
        double lm = dot(z, wz, nz);
        img[i] = k;
        double num = (lp - lm) / 2e-2;
        if (fabs(num - dimg[i]) > 2e-2 * fmax(1.0, fabs(num))) ++bad;
    }
    CHECK(bad == 0);
    free(img), free(z), free(wz), free(dimg);
    mf_prior_free(p);
}

MF_TEST(prior_prepare_image_box_filter) {
    /* 4x4 -> 2x2: each output is the mean of a 2x2 block of (2 v - 1) * alpha */
    float rgba[4 * 4 * 4], out[3 * 2 * 2], mask[4];
    for (int i = 0; i < 16; ++i) {
        rgba[i * 4 + 0] = (float)i / 15.0f, rgba[i * 4 + 1] = 1.0f, rgba[i * 4 + 2] = 0.0f;
        rgba[i * 4 + 3] = (i % 2) ? 1.0f : 0.5f;
    }
    mf_prior_prepare_image(rgba, 4, 4, 2, out, mask);
    int blk[4] = {0, 1, 4, 5};
    double e = 0, a = 0;
    for (int k = 0; k < 4; ++k) {
        int i = blk[k];
        e += (2.0 * i / 15.0 - 1.0) * rgba[i * 4 + 3] / 4.0, a += rgba[i * 4 + 3] / 4.0;
    }
    CHECK_NEAR(out[0], e, 1e-6);
    CHECK_NEAR(mask[0], a, 1e-6);
    CHECK_NEAR(out[4 + 0], a, 1e-6);  /* G = 1 -> (2 - 1) * alpha */
    CHECK_NEAR(out[8 + 0], -a, 1e-6); /* B = 0 -> -alpha */
}

MF_TEST(prior_cli_predicts_maps) {
    const char *bin = getenv("MF_BIN");
    if (!bin) MF_SKIP("MF_BIN not set (run through make test)");
    MfPrior *p;
    tiny_prior(&p);
    char w[MF_PATH_MAX], img[MF_PATH_MAX], out[MF_PATH_MAX], cmd[8 * MF_PATH_MAX], f[MF_PATH_MAX];
    snprintf(w, sizeof w, "%s", mf_test_path("prior_cli.mfck"));
    snprintf(img, sizeof img, "%s", mf_test_path("prior_cli_in.png"));
    snprintf(out, sizeof out, "%s", mf_test_path("prior_cli_out"));
    CHECK_OK(mf_prior_save(p, w, NULL));
    mf_prior_free(p);
    MfImage im = {0};
    mf_image_alloc(&im, 32, 32, 4);
    for (int y = 8; y < 24; ++y)
        for (int x = 8; x < 24; ++x) {
            float *px = mf_image_px(&im, x, y);
            px[0] = 0.5f, px[1] = 0.3f, px[2] = 0.2f, px[3] = 1.0f;
        }
    CHECK_OK(mf_image_write(img, &im, MF_ENC_SRGB, 8));
    mf_image_free(&im);
    snprintf(cmd, sizeof cmd, "'%s' prior '%s' -o '%s' --weights '%s' --samples 2 --steps 4 --mv '%s' '%s' '%s' > /dev/null",
             bin, img, out, w, img, img, img);
    CHECK(system(cmd) == 0);
    const char *names[4] = {"albedo.png", "orm.png", "albedo_3.png", "orm_3.png"};
    for (int k = 0; k < 4; ++k) {
        mf_path_join(f, sizeof f, out, names[k]);
        MfImage r = {0};
        CHECK_OK(mf_image_read(f, MF_ENC_LINEAR, &r));
        CHECK(r.w == 16 && r.h == 16 && r.c == 4);
        if (r.data) {
            CHECK(mf_image_px(&r, 0, 0)[3] == 0.0f && mf_image_px(&r, 8, 8)[3] == 1.0f);
            if (k % 2) CHECK(mf_image_px(&r, 8, 8)[0] == 1.0f); /* ORM: R = 1 */
        }
        mf_image_free(&r);
    }
    /* mf train-prior end to end on the tiny model */
    char ck[MF_PATH_MAX], lc[MF_PATH_MAX];
    snprintf(ck, sizeof ck, "%s", mf_test_path("prior_cli_ck"));
    snprintf(lc, sizeof lc, "%s", mf_test_path("prior_cli_loss.csv"));
    snprintf(cmd, sizeof cmd, "'%s' train-prior '%s' -o '%s' --tiny --ae-steps 3 --steps 3 --batch 4 --loss-csv '%s' > /dev/null 2>&1",
             bin, synth_dir(), ck, lc);
    CHECK(system(cmd) == 0);
    mf_path_join(f, sizeof f, ck, "prior.mfck");
    MfPrior *t = NULL;
    CHECK_OK(mf_prior_load(f, &t));
    mf_prior_free(t);
    CHECK(mf_file_exists(lc));
    snprintf(cmd, sizeof cmd, "'%s' train-prior '%s' > /dev/null 2>&1", bin, synth_dir());
    CHECK(system(cmd) != 0); /* no -o */
    /* missing weights: a clear message naming the file and the expected version */
    snprintf(cmd, sizeof cmd, "'%s' prior '%s' -o '%s' --weights '%s/nope.mfck' 2>&1 | grep -q 'nope.mfck.*MFCK version 1'",
             bin, img, out, out);
    CHECK(system(cmd) == 0);
}

MF_TEST(prior_material_latents_and_backward) {
    MfPrior *p;
    tiny_prior(&p);
    int B = 2, R = 16;
    size_t ni = (size_t)B * 3 * R * R, nm = (size_t)B * 8 * 4 * 4, n1 = (size_t)3 * R * R, z1 = 4 * 4 * 4;
    float *alb = malloc(ni * sizeof(float)), *orm = malloc(ni * sizeof(float)), *zm = malloc(nm * sizeof(float));
    float *wz = malloc(nm * sizeof(float)), *da = calloc(ni, sizeof(float)), *dor = calloc(ni, sizeof(float));
    float *z1buf = malloc(z1 * sizeof(float)), *ra = malloc(ni * sizeof(float)), *ro = malloc(ni * sizeof(float));
    float *d1 = malloc(n1 * sizeof(float));
    fill(alb, ni, 1, 1.0f), fill(orm, ni, 2, 1.0f), fill(wz, nm, 3, 1.0f);
    CHECK_OK(mf_prior_encode_materials(p, alb, orm, B, zm));
    /* packing: item 1's ORM latent equals encoding item 1's ORM map alone */
    CHECK_OK(mf_prior_encode(p, orm + n1, 1, z1buf));
    double e = 0;
    for (size_t i = 0; i < z1; ++i) e = fmax(e, fabs(z1buf[i] - zm[2 * 8 * 16 - z1 + i]));
    CHECK(e < 1e-5);
    CHECK_OK(mf_prior_encode_materials(p, alb, orm, B, zm));
    CHECK_OK(mf_prior_encode_materials_backward(p, wz, da, dor));
    int bad = 0;
    for (int k = 0; k < 2; ++k)
        for (size_t i = 5; i < ni; i += 97) {
            float *m = k ? orm : alb, keep = m[i];
            m[i] = keep + 1e-2f;
            mf_prior_encode_materials(p, alb, orm, B, zm);
            double lp = dot(zm, wz, nm);
            m[i] = keep - 1e-2f;
            mf_prior_encode_materials(p, alb, orm, B, zm);
            double lm = dot(zm, wz, nm);
            m[i] = keep;
            double num = (lp - lm) / 2e-2, an = k ? dor[i] : da[i];
            if (fabs(num - an) > 2e-2 * fmax(1.0, fabs(num))) ++bad;
        }
    CHECK(bad == 0);
    /* decode_materials splits like decode */
    CHECK_OK(mf_prior_decode_materials(p, zm, B, ra, ro));
    for (size_t i = 0; i < z1; ++i) z1buf[i] = zm[8 * 16 + i]; /* item 1 albedo latent */
    CHECK_OK(mf_prior_decode(p, z1buf, 1, d1));
    e = 0;
    for (size_t i = 0; i < n1; ++i) e = fmax(e, fabs(d1[i] - ra[n1 + i]));
    CHECK(e < 1e-5);
    free(alb), free(orm), free(zm), free(wz), free(da), free(dor), free(z1buf), free(ra), free(ro), free(d1);
    mf_prior_free(p);
}

MF_TEST(prior_train_partial_folder_and_default_weights) {
    /* a folder still being generated: no manifest, samples 0..5 and 7 (6 missing) -> 6 samples */
    char dir[MF_PATH_MAX], out[MF_PATH_MAX], path[MF_PATH_MAX], w[MF_PATH_MAX];
    snprintf(dir, sizeof dir, "%s", mf_test_path("prior_partial"));
    write_synth(dir, 8, 16, 3);
    mf_path_join(path, sizeof path, dir, "manifest.json");
    remove(path);
    mf_path_join(path, sizeof path, dir, "orm/000006.png");
    remove(path);
    snprintf(out, sizeof out, "%s", mf_test_path("prior_partial_out"));
    MfTrainPriorOpts o;
    MfTrainPriorResult r;
    tiny_opts(&o, out, mf_test_path("prior_partial.csv"));
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

MF_TEST(prior_eval_cli_writes_table) {
    const char *bin = getenv("MF_BIN");
    if (!bin) MF_SKIP("MF_BIN not set (run through make test)");
    MfPrior *p;
    tiny_prior(&p);
    char w[MF_PATH_MAX], dir[MF_PATH_MAX], out[MF_PATH_MAX], f[MF_PATH_MAX], cmd[6 * MF_PATH_MAX];
    snprintf(w, sizeof w, "%s", mf_test_path("prior_eval.mfck"));
    CHECK_OK(mf_prior_save(p, w, NULL));
    mf_prior_free(p);
    /* a test-2d-like split: 2 objects x 2 views */
    snprintf(dir, sizeof dir, "%s", mf_test_path("prior_eval_t2d"));
    write_synth(dir, 4, 16, 9);
    const char *man = "{\"split\":\"test-2d\",\"resolution\":16,\"count\":4,\"seed\":9,\"objects\":2,\"views_per_object\":2}";
    mf_path_join(f, sizeof f, dir, "manifest.json");
    CHECK_OK(mf_write_file(f, man, strlen(man)));
    snprintf(out, sizeof out, "%s", mf_test_path("prior_eval_out"));
    snprintf(cmd, sizeof cmd, "'%s' eval-prior '%s' -o '%s' --weights '%s' --train '%s' --samples 2 --steps 3 > /dev/null 2>&1",
             bin, dir, out, w, synth_dir());
    CHECK(system(cmd) == 0);
    mf_path_join(f, sizeof f, out, "table2d.md");
    char *txt = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(f, &txt, &len));
    CHECK(txt && strstr(txt, "StableMaterialMV") && strstr(txt, "Retinex") && strstr(txt, "Train-mean ORM") &&
          strstr(txt, "2 objects x 2 views"));
    free(txt);
    EvTable t;
    ev_table_init(&t);
    mf_path_join(f, sizeof f, out, "table2d.csv");
    CHECK_OK(ev_table_read_csv(&t, f));
    /* 4 views: SM and MV 5 metrics each, input and Retinex 3 (albedo), mean ORM 2 */
    CHECK_MSG(t.n == 4 * (5 + 5 + 3 + 3 + 2), "%zu records", t.n);
    EvStat a = ev_table_stat(&t, "Input image", "test-2d", "albedo_psnr");
    CHECK(a.n == 4 && a.mean > 5);
    ev_table_free(&t);
    /* a wrong resolution is refused with a message */
    snprintf(dir, sizeof dir, "%s", mf_test_path("prior_eval_t2d_12"));
    write_synth(dir, 4, 12, 9);
    mf_path_join(f, sizeof f, dir, "manifest.json");
    CHECK_OK(mf_write_file(f, man, strlen(man)));
    snprintf(cmd, sizeof cmd, "'%s' eval-prior '%s' -o '%s' --weights '%s' --train '%s' 2>&1 | grep -q 'prior works at 16'",
             bin, dir, out, w, synth_dir());
    CHECK(system(cmd) == 0);
}

MF_TEST(prior_2d_baselines) {
    MfImage rgb = {0}, a = {0}, r = {0}, o = {0};
    mf_image_alloc(&rgb, 24, 24, 4);
    /* albedo (0.6, 0.4, 0.2) under a smooth left-to-right shading ramp */
    for (int y = 4; y < 20; ++y)
        for (int x = 4; x < 20; ++x) {
            float *px = mf_image_px(&rgb, x, y), s = 0.3f + 0.7f * x / 24.0f;
            px[0] = 0.6f * s, px[1] = 0.4f * s, px[2] = 0.2f * s, px[3] = 1.0f;
        }
    CHECK_OK(bl_albedo_input(&rgb, &a));
    CHECK(a.data[(12 * 24 + 12) * 4 + 1] == rgb.data[(12 * 24 + 12) * 4 + 1]);
    CHECK_OK(bl_albedo_retinex(&rgb, 3.0f, &r));
    /* shading removed: the ratio between the right and left inside columns is far closer to 1 than the input's */
    float in_ratio = mf_image_px(&rgb, 18, 12)[0] / mf_image_px(&rgb, 5, 12)[0];
    float rx_ratio = mf_image_px(&r, 18, 12)[0] / mf_image_px(&r, 5, 12)[0];
    CHECK_MSG(fabsf(rx_ratio - 1) < 0.5f * fabsf(in_ratio - 1), "input %g, retinex %g", in_ratio, rx_ratio);
    CHECK_NEAR(mf_image_px(&r, 12, 12)[1] / mf_image_px(&r, 12, 12)[0], 0.4f / 0.6f, 1e-4); /* chroma kept */
    CHECK(mf_image_px(&r, 0, 0)[0] == 0.0f && mf_image_px(&r, 0, 0)[3] == 0.0f);
    CHECK_OK(bl_orm_constant(&rgb, 0.25f, 0.75f, &o));
    CHECK(mf_image_px(&o, 12, 12)[0] == 1.0f && mf_image_px(&o, 12, 12)[1] == 0.25f && mf_image_px(&o, 12, 12)[2] == 0.75f);
    float rr, mm;
    const MfImage *one = &o;
    CHECK_OK(bl_orm_mean(&one, 1, &rr, &mm));
    CHECK_NEAR(rr, 0.25f, 1e-6);
    CHECK_NEAR(mm, 0.75f, 1e-6);
    MfImage empty = {0};
    mf_image_alloc(&empty, 4, 4, 4);
    one = &empty;
    CHECK_ERR(bl_orm_mean(&one, 1, &rr, &mm), "no pixel inside");
    mf_image_free(&rgb), mf_image_free(&a), mf_image_free(&r), mf_image_free(&o), mf_image_free(&empty);
}
