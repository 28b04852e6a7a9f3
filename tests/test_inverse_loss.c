/* Tests of mf/inverse: losses and regularisers (gradient checks against central differences),
 * and the Adam optimiser (convergence, bounds, frozen channels, NaN refusal). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "inverse/mf_loss.h"
#include "inverse/mf_optim.h"
#include "mf_test.h"
#include "mf_test_grad.h"

/* Central differences of loss around x (n,) (in the ctx), compared with the analytic gradient g (n,):
 * max |g - fd| / max(|fd|, floor). Differences taken in double on float inputs. */
static double worst_rel(MfTestLoss loss, void *ctx, float *x, size_t n, const float *g, float eps, double floor) {
    return mf_test_grad(&(MfGradCheck){.loss = loss, .ctx = ctx, .p = x, .g = g, .n = n, .eps = eps, .atol = floor, .rtol = 1,
                                       .form = MF_ERR_MAX})
        .worst;
}

typedef struct { const float *x, *ref; size_t n; float floor; } PairCtx;
static double f_logl1(void *c) { const PairCtx *p = c; return mf_loss_logl1_fwd(p->x, p->ref, p->n, p->floor); }
static double f_mse(void *c) { const PairCtx *p = c; return mf_loss_mse_fwd(p->x, p->ref, p->n); }

MF_TEST(inverse_loss_logl1_and_mse_gradients) {
    enum { N = 60 };
    float x[N], ref[N], g[N];
    MfRng r;
    mf_rng_seed(&r, 3, 0);
    for (int i = 0; i < N; ++i) {
        /* HDR range incl. very dark and very bright values; keep |x - ref| away from the kink */
        float mag = powf(10.0f, -3.0f + 6.0f * mf_rng_float(&r));
        x[i] = mag;
        ref[i] = mag * (mf_rng_float(&r) < 0.5f ? 0.5f : 1.7f);
    }
    for (int k = 0; k < 2; ++k) { /* without and with a floor */
        PairCtx c = {x, ref, N, k ? 0.1f : 0.0f};
        memset(g, 0, sizeof g);
        mf_loss_logl1_bwd(x, ref, N, c.floor, 1.0f, g);
        /* relative step: values span 1e-3..1e3 */
        double worst = 0;
        for (int i = 0; i < N; ++i) {
            double fd = mf_test_fd(f_logl1, &c, x, i, 1e-3f * x[i]);
            worst = fmax(worst, fabs(fd - g[i]) / fmax(fabs(fd), 1e-4));
        }
        CHECK_MSG(worst < 2e-2, "logl1 gradient relative error %g (floor %g)", worst, c.floor);
    }
    /* the floor caps a near-black pixel's weight: without it 1e-4 weighs > 20x a pixel at 0.5,
     * with 0.1 under 5x */
    float dark = 1e-4f, mid = 0.5f, rd = 2e-4f, rm = 1.0f, gd = 0, gm = 0;
    for (int k = 0; k < 2; ++k) {
        float f = k ? 0.1f : 0.0f;
        gd = gm = 0;
        mf_loss_logl1_bwd(&dark, &rd, 1, f, 1.0f, &gd);
        mf_loss_logl1_bwd(&mid, &rm, 1, f, 1.0f, &gm);
        CHECK_MSG(k ? fabsf(gd) < 5.0f * fabsf(gm) : fabsf(gd) > 20.0f * fabsf(gm), "floor %g: d(dark) %g, d(mid) %g", f, gd, gm);
    }
    /* the tone curve: continuous at the sRGB knee, finite, monotone */
    float prev = -1.0f;
    for (int i = 0; i <= 2000; ++i) {
        float v = powf(10.0f, -6.0f + 10.0f * i / 2000.0f); /* up to 1e4, below the 65535 clamp */
        float t = mf_logsrgb(v);
        CHECK(isfinite(t) && t > prev && isfinite(mf_logsrgb_deriv(v)));
        prev = t;
    }
    CHECK(mf_logsrgb(-5.0f) == 0.0f && mf_logsrgb(1e30f) == mf_logsrgb(65535.0f));
    memset(g, 0, sizeof g);
    mf_loss_mse_bwd(x, ref, N, 2.0f, g);
    for (int i = 0; i < N; ++i) x[i] = fminf(x[i], 10.0f), ref[i] = fminf(ref[i], 12.0f);
    memset(g, 0, sizeof g);
    mf_loss_mse_bwd(x, ref, N, 1.0f, g);
    CHECK_MSG(worst_rel(f_mse, &(PairCtx){x, ref, N, 0.0f}, x, N, g, 1e-2f, 1e-3) < 1e-3, "mse gradient");
}

typedef struct { const float *x; int w, h, ch, c0, nc; const float *mask; } SmoothCtx;
static double f_smooth(void *c) {
    const SmoothCtx *s = c;
    return mf_reg_smooth_fwd(s->x, s->w, s->h, s->ch, s->c0, s->nc, s->mask);
}

MF_TEST(inverse_reg_smooth_gradient) {
    enum { W = 7, H = 5, CH = 3 };
    float tex[W * H * CH], g[W * H * CH], mask[W * H];
    MfRng r;
    mf_rng_seed(&r, 5, 0);
    for (int i = 0; i < W * H * CH; ++i) tex[i] = mf_rng_float(&r);
    for (int i = 0; i < W * H; ++i) mask[i] = (i % 5) ? 1.0f : 0.0f;
    SmoothCtx c = {tex, W, H, CH, 1, 2, mask};
    memset(g, 0, sizeof g);
    mf_reg_smooth_bwd(tex, W, H, CH, 1, 2, mask, 1.0f, g);
    CHECK_MSG(worst_rel(f_smooth, &c, tex, W * H * CH, g, 1e-4f, 1e-2) < 2e-2, "smooth gradient");
    for (int i = 0; i < W * H; ++i) CHECK(g[i * CH] == 0.0f); /* channel 0 not regularised */
    for (int i = 0; i < W * H; i += 5) CHECK(g[i * CH + 1] == 0.0f); /* masked-out texels untouched */
    /* a constant texture has zero smoothness loss */
    for (int i = 0; i < W * H * CH; ++i) tex[i] = 0.3f;
    CHECK(mf_reg_smooth_fwd(tex, W, H, CH, 0, 3, NULL) == 0.0);
}

typedef struct { const float *env; int w, h; const unsigned char *cover; } EnvCtx;
static double f_env_unseen(void *c) {
    const EnvCtx *e = c;
    return mf_reg_env_unseen_fwd(e->env, e->w, e->h, e->cover);
}

MF_TEST(inverse_reg_env_unseen_gradient) {
    enum { W = 8, H = 4 };
    float env[W * H * 3], g[W * H * 3];
    unsigned char cover[W * H];
    MfRng r;
    mf_rng_seed(&r, 6, 0);
    for (int i = 0; i < W * H * 3; ++i) env[i] = 0.1f + 2.0f * mf_rng_float(&r);
    for (int i = 0; i < W * H; ++i) cover[i] = (unsigned char)(i / W < 2); /* the upper two rows seen */
    EnvCtx c = {env, W, H, cover};
    memset(g, 0, sizeof g);
    mf_reg_env_unseen_bwd(env, W, H, cover, 1.0f, g);
    CHECK_MSG(worst_rel(f_env_unseen, &c, env, W * H * 3, g, 1e-4f, 1e-2) < 2e-2, "env unseen gradient");
    for (int i = 0; i < W * 3; ++i) CHECK(g[i] == 0.0f); /* row 0: seen, no unseen neighbour */
    int row1 = 0;
    for (int i = W * 3; i < 2 * W * 3; ++i) row1 += g[i] != 0.0f; /* row 1 borders row 2 */
    CHECK(row1 > 0);
    /* the longitude wraps: a step between the last and first column of an unseen row costs */
    for (int i = 0; i < W * H * 3; ++i) env[i] = 1.0f;
    CHECK(mf_reg_env_unseen_fwd(env, W, H, cover) == 0.0);
    for (int y = 2; y < H; ++y)
        for (int x = W / 2; x < W; ++x)
            for (int k = 0; k < 3; ++k) env[(y * W + x) * 3 + k] = 2.0f;
    /* pairs with an unseen texel: down from rows 1 and 2 (2 x W) + right in rows 2 and 3 (2 x W) =
     * 32; steps of 1: x = 3|4 and x = 7|0 in rows 2 and 3 (4), rows 1|2 at x >= 4 (4) */
    CHECK_MSG(fabs(mf_reg_env_unseen_fwd(env, W, H, cover) - 8.0 / 32.0) < 1e-6, "loss %g",
              mf_reg_env_unseen_fwd(env, W, H, cover));
    /* everything seen: no term */
    memset(cover, 1, sizeof cover);
    memset(g, 0, sizeof g);
    mf_reg_env_unseen_bwd(env, W, H, cover, 1.0f, g);
    CHECK(mf_reg_env_unseen_fwd(env, W, H, cover) == 0.0 && g[0] == 0.0f && g[W * H * 3 - 1] == 0.0f);
}

static double f_env_logtv(void *c) {
    const EnvCtx *e = c;
    return mf_reg_env_logtv_fwd(e->env, e->w, e->h);
}

MF_TEST(inverse_reg_env_logtv_gradient) {
    enum { W = 8, H = 4 };
    float env[W * H * 3], g[W * H * 3];
    MfRng r;
    mf_rng_seed(&r, 7, 0);
    for (int i = 0; i < W * H * 3; ++i) env[i] = 0.05f + 20.0f * mf_rng_float(&r) * mf_rng_float(&r);
    EnvCtx c = {env, W, H, NULL};
    memset(g, 0, sizeof g);
    mf_reg_env_logtv_bwd(env, W, H, 1.0f, g);
    CHECK_MSG(worst_rel(f_env_logtv, &c, env, W * H * 3, g, 1e-4f, 1e-2) < 2e-2, "env log-TV gradient");
    /* exposure does not change it: the same env x 1000 has the same loss, gradients / 1000 */
    double l1 = mf_reg_env_logtv_fwd(env, W, H);
    for (int i = 0; i < W * H * 3; ++i) env[i] *= 1000.0f;
    CHECK_MSG(fabs(mf_reg_env_logtv_fwd(env, W, H) - l1) < 1e-5 * l1, "%g vs %g", mf_reg_env_logtv_fwd(env, W, H), l1);
    /* a constant env costs nothing; one texel 2x brighter: its 4 pairs (left, right, up, down) of
     * log 2 each, over 3 channels of W x H right pairs (wrapping) + W x (H - 1) lower pairs */
    for (int i = 0; i < W * H * 3; ++i) env[i] = 3.0f;
    CHECK(mf_reg_env_logtv_fwd(env, W, H) == 0.0);
    for (int k = 0; k < 3; ++k) env[(1 * W + 0) * 3 + k] = 6.0f; /* row 1, column 0: its left pair wraps */
    double want = 4.0 * log(2.0) / (double)(W * H + W * (H - 1));
    CHECK_MSG(fabs(mf_reg_env_logtv_fwd(env, W, H) - want) < 1e-6, "loss %g, want %g", mf_reg_env_logtv_fwd(env, W, H), want);
}

typedef struct { const float *diffuse, *spec, *cover; size_t n; float ls; } ShadeCtx;
static double f_shade(void *c) {
    const ShadeCtx *s = c;
    return mf_reg_shading_fwd(s->diffuse, s->spec, s->cover, s->n, s->ls);
}

MF_TEST(inverse_reg_shading_gradient) {
    enum { N = 20 };
    float d[3 * N], s[3 * N], cov[N], gd[3 * N], gs[3 * N];
    MfRng r;
    mf_rng_seed(&r, 9, 0);
    for (int i = 0; i < 3 * N; ++i) d[i] = 0.2f + mf_rng_float(&r), s[i] = 0.1f * mf_rng_float(&r);
    for (int i = 0; i < N; ++i) cov[i] = (i % 4) ? 1.0f : 0.25f;
    ShadeCtx c = {d, s, cov, N, 0.0025f};
    memset(gd, 0, sizeof gd);
    memset(gs, 0, sizeof gs);
    mf_reg_shading_bwd(d, s, cov, N, 0.0025f, 1.0f, gd, gs);
    CHECK_MSG(worst_rel(f_shade, &c, d, 3 * N, gd, 1e-4f, 1e-3) < 2e-2, "shading d/ddiffuse");
    CHECK_MSG(worst_rel(f_shade, &c, s, 3 * N, gs, 1e-4f, 1e-5) < 2e-2, "shading d/dspec");
    /* white light and no specular: zero loss */
    for (int i = 0; i < 3 * N; ++i) d[i] = 0.7f, s[i] = 0.0f;
    CHECK_NEAR(mf_reg_shading_fwd(d, s, cov, N, 0.0025f), 0.0, 1e-7);
}

MF_TEST(inverse_adam_converges_with_bounds) {
    /* minimise sum (p - t)^2 with targets partly outside the bounds */
    enum { N = 12 };
    float target[N];
    for (int i = 0; i < N; ++i) target[i] = -0.5f + 0.2f * i;
    MfParamBlock b;
    CHECK_OK(mf_param_init(&b, "orm", N, 3, NULL));
    mf_param_set_bounds(&b, 0, 1.0f, 1.0f); /* frozen occlusion */
    mf_param_set_bounds(&b, 1, 0.08f, 1.0f);
    mf_param_set_bounds(&b, 2, 0.0f, 1.0f);
    for (int i = 0; i < N; i += 3) b.p[i] = 1.0f;
    MfAdam a;
    mf_adam_init(&a, 0.05f);
    for (int it = 0; it < 600; ++it) {
        mf_param_zero_grad(&b);
        for (int i = 0; i < N; ++i) b.g[i] = 2.0f * (b.p[i] - target[i]);
        CHECK_OK(mf_adam_step(&a, &b, 1, mf_lr_schedule(0.05f, it)));
    }
    for (int i = 0; i < N; ++i) {
        int c = i % 3;
        float want = c == 0 ? 1.0f : fminf(fmaxf(target[i], c == 1 ? 0.08f : 0.0f), 1.0f);
        CHECK_NEAR(b.p[i], want, 2e-3);
    }
    /* a NaN gradient is refused and nothing changes */
    float before[N];
    memcpy(before, b.p, sizeof before);
    b.g[4] = NAN;
    CHECK_ERR(mf_adam_step(&a, &b, 1, 0.05f), "orm: gradient of element 4");
    CHECK(!memcmp(before, b.p, sizeof before));
    CHECK_NEAR(mf_lr_schedule(0.03f, 5000), 0.003, 1e-6);
    mf_param_free(&b);
}

typedef struct { const float *pos; int nv; const int *off, *adj; } LapCtx;
static double f_lap(void *c) { const LapCtx *l = c; return mf_reg_laplacian_fwd(l->pos, l->nv, l->off, l->adj); }

/* The moving vertices' Laplacian (mf_recon --vertex-lr): an octahedron's 6 vertices and one vertex
 * without neighbours, the lists from mf_reg_laplacian_adjacency (as mf_recon builds them). The
 * regular octahedron's value is exact; the gradient matches central differences, sums to zero (a
 * translation changes nothing) and leaves the lone vertex alone. */
MF_TEST(inverse_reg_laplacian_gradient) {
    static const uint32_t tri[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    enum { NVX = 7 };
    float pos[NVX * 3] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 3, 3, 3}, g[NVX * 3];
    int *off = NULL, *adj = NULL;
    CHECK_OK(mf_reg_laplacian_adjacency(&tri[0][0], 8, NVX, &off, &adj));
    if (!off) return;
    CHECK(off[NVX] == 48 && off[6] == off[NVX]); /* 8 triangles x 6 entries; the lone vertex has none */
    LapCtx c = {pos, NVX, off, adj};
    /* each vertex's 4 neighbours are the equator around it, centred at the origin: L_i = p_i */
    CHECK_MSG(fabs(f_lap(&c) - 6.0) < 1e-6, "regular octahedron: %g, want 6", f_lap(&c));
    MfRng r;
    mf_rng_seed(&r, 11, 0);
    for (int i = 0; i < 18; ++i) pos[i] += 0.3f * (mf_rng_float(&r) - 0.5f);
    memset(g, 0, sizeof g);
    mf_reg_laplacian_bwd(pos, NVX, off, adj, 1.0f, g);
    CHECK_MSG(worst_rel(f_lap, &c, pos, NVX * 3, g, 1e-3f, 1e-2) < 1e-2, "Laplacian gradient");
    for (int k = 0; k < 3; ++k) {
        double s = 0;
        for (int i = 0; i < NVX; ++i) s += g[3 * i + k];
        CHECK_MSG(fabs(s) < 1e-5, "gradient sums to %g along axis %d", s, k);
        CHECK(g[18 + k] == 0.0f);
    }
    free(off), free(adj);
}
