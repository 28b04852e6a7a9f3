/* Tests of mf/prior/mf_diffusion: the schedule, v-prediction, DDIM sampling and classifier-free
 * guidance against closed forms. */

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
