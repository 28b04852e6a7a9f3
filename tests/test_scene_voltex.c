/* Volume textures (issue 14 item 6): trilinear lookup, its adjoint, the TV regulariser. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "scene/mf_voltex.h"
#include "mf_test.h"
#include "mf_test_grad.h"

static const float LO[3] = {-1.0f, 0.0f, -0.5f}, HI[3] = {2.0f, 1.0f, 0.5f};

static void random_grid(MfVoltex *v, MfRng *rng) {
    for (size_t i = 0; i < mf_voltex_size(v); ++i) v->grid[i] = mf_rng_float(rng);
}

/* Independent double-precision reference of the lookup (clamp, then trilinear over the cell). */
static void ref_lookup(const MfVoltex *v, const double *g, const double p[3], double *out) {
    int r = v->res, idx[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        double u = (p[a] - v->lo[a]) / ((double)v->hi[a] - v->lo[a]) * (r - 1);
        u = u < 0 ? 0 : u > r - 1 ? r - 1 : u;
        idx[a] = (int)floor(u) > r - 2 ? r - 2 : (int)floor(u);
        f[a] = u - idx[a];
    }
    for (int ch = 0; ch < v->c; ++ch) out[ch] = 0;
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
                size_t vi = ((size_t)(idx[2] + dz) * r + idx[1] + dy) * r + idx[0] + dx;
                for (int ch = 0; ch < v->c; ++ch) out[ch] += w * g[vi * v->c + ch];
            }
}

/* sum of dout * the reference lookup (in double) at the n points pp (n x 3) on grid g */
typedef struct {
    const MfVoltex *v;
    const double *g, *pp;
    const float *dout;
    int n;
} RefCtx;

static double ref_loss(void *ctx) {
    const RefCtx *c = ctx;
    double l = 0, o[8];
    for (int i = 0; i < c->n; ++i) {
        double p[3] = {c->pp[3 * i], c->pp[3 * i + 1], c->pp[3 * i + 2]};
        ref_lookup(c->v, c->g, p, o);
        for (int ch = 0; ch < c->v->c; ++ch) l += c->dout[c->v->c * i + ch] * o[ch];
    }
    return l;
}

static void vertex_pos(const MfVoltex *v, int i, int j, int k, float *p) {
    int ijk[3] = {i, j, k};
    for (int a = 0; a < 3; ++a) p[a] = v->lo[a] + (v->hi[a] - v->lo[a]) * (float)ijk[a] / (float)(v->res - 1);
}

MF_TEST(geom_voltex_lookup) {
    MfVoltex v;
    MfRng rng;
    mf_rng_seed(&rng, 7, 1);
    CHECK_OK(mf_voltex_init(&v, 5, 3, LO, HI, NULL));
    random_grid(&v, &rng);
    /* exact at every grid vertex */
    float worst = 0.0f;
    for (int k = 0; k < 5; ++k)
        for (int j = 0; j < 5; ++j)
            for (int i = 0; i < 5; ++i) {
                float p[3], o[3];
                vertex_pos(&v, i, j, k, p);
                mf_voltex_forward(&v, p, 1, o);
                const float *g = v.grid + (((size_t)k * 5 + j) * 5 + i) * 3;
                for (int ch = 0; ch < 3; ++ch) worst = fmaxf(worst, fabsf(o[ch] - g[ch]));
            }
    CHECK_MSG(worst <= 1e-6f, "vertex lookup off by %g", worst);
    /* linear between two vertices along each axis */
    worst = 0.0f;
    for (int a = 0; a < 3; ++a)
        for (int s = 0; s <= 10; ++s) {
            float t = s / 10.0f, p0[3], p1[3], p[3], o[3];
            vertex_pos(&v, 1, 2, 3, p0);
            int e[3] = {1 + (a == 0), 2 + (a == 1), 3 + (a == 2)};
            vertex_pos(&v, e[0], e[1], e[2], p1);
            for (int q = 0; q < 3; ++q) p[q] = p0[q] + t * (p1[q] - p0[q]);
            mf_voltex_forward(&v, p, 1, o);
            const float *g0 = v.grid + ((3 * 5 + 2) * 5 + 1) * 3, *g1 = v.grid + (((size_t)e[2] * 5 + e[1]) * 5 + e[0]) * 3;
            for (int ch = 0; ch < 3; ++ch) worst = fmaxf(worst, fabsf(o[ch] - ((1 - t) * g0[ch] + t * g1[ch])));
        }
    CHECK_MSG(worst <= 2e-6f, "edge interpolation off by %g", worst);
    /* a linear field at the vertices is reproduced everywhere in the box */
    for (int k = 0; k < 5; ++k)
        for (int j = 0; j < 5; ++j)
            for (int i = 0; i < 5; ++i) {
                float p[3];
                vertex_pos(&v, i, j, k, p);
                float *g = v.grid + (((size_t)k * 5 + j) * 5 + i) * 3;
                g[0] = 0.3f * p[0] - 0.7f * p[1] + 0.2f * p[2] + 0.1f, g[1] = p[2], g[2] = -p[0];
            }
    worst = 0.0f;
    for (int s = 0; s < 200; ++s) {
        float p[3], o[3];
        for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * mf_rng_float(&rng);
        mf_voltex_forward(&v, p, 1, o);
        worst = fmaxf(worst, fabsf(o[0] - (0.3f * p[0] - 0.7f * p[1] + 0.2f * p[2] + 0.1f)));
        worst = fmaxf(worst, fmaxf(fabsf(o[1] - p[2]), fabsf(o[2] + p[0])));
    }
    CHECK_MSG(worst <= 1e-5f, "linear field off by %g", worst);
    /* out of the box: the value at the clamped point, zero derivative along clamped axes */
    float out_p[3] = {3.5f, 0.25f, -2.0f}, in_p[3] = {2.0f, 0.25f, -0.5f}, o1[3], o2[3], dp[3] = {0, 0, 0};
    mf_voltex_forward(&v, out_p, 1, o1);
    mf_voltex_forward(&v, in_p, 1, o2);
    for (int ch = 0; ch < 3; ++ch) CHECK_NEAR(o1[ch], o2[ch], 1e-7);
    float dout[3] = {1, 1, 1}, *dg = calloc(mf_voltex_size(&v), sizeof *dg);
    mf_voltex_backward(&v, out_p, 1, dout, dg, dp);
    CHECK(dp[0] == 0.0f && dp[2] == 0.0f);
    CHECK_NEAR(dp[1], -0.7 + 0 + 0, 1e-4); /* d(o0 + o1 + o2)/dy = -0.7 */
    free(dg);
    /* bad arguments */
    MfVoltex w = {0};
    float flat[3] = {2.0f, 0.0f, 0.5f}; /* y: hi == lo */
    CHECK_ERR(mf_voltex_init(&w, 1, 3, LO, HI, NULL), "resolution");
    CHECK_ERR(mf_voltex_init(&w, 4, 3, LO, flat, NULL), "box");
    CHECK(w.grid == NULL);
    mf_voltex_free(&v);
    mf_voltex_free(&w);
}

MF_TEST(geom_voltex_adjoint) {
    enum { N = 40, C = 3 };
    MfVoltex v;
    MfRng rng;
    mf_rng_seed(&rng, 11, 2);
    CHECK_OK(mf_voltex_init(&v, 4, C, LO, HI, NULL));
    random_grid(&v, &rng);
    size_t ng = mf_voltex_size(&v);
    float pts[N * 3], dout[N * C], out[N * C], dpts[N * 3] = {0};
    double *g = malloc(ng * sizeof *g);
    float *dgrid = calloc(ng, sizeof *dgrid);
    for (size_t i = 0; i < ng; ++i) g[i] = v.grid[i];
    for (int i = 0; i < N; ++i) {
        for (int a = 0; a < 3; ++a) { /* inside cells, away from cell faces (the lookup is C0 there) */
            float cellw = (HI[a] - LO[a]) / 3.0f;
            pts[3 * i + a] = LO[a] + cellw * ((float)(int)(3 * mf_rng_float(&rng)) + 0.05f + 0.9f * mf_rng_float(&rng));
        }
        for (int ch = 0; ch < C; ++ch) dout[C * i + ch] = 2.0f * mf_rng_float(&rng) - 1.0f;
    }
    mf_voltex_forward(&v, pts, N, out);
    mf_voltex_backward(&v, pts, N, dout, dgrid, dpts);
    /* the reference reproduces the float forward */
    double worst = 0;
    for (int i = 0; i < N; ++i) {
        double p[3] = {pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]}, o[C];
        ref_lookup(&v, g, p, o);
        for (int ch = 0; ch < C; ++ch) worst = fmax(worst, fabs(o[ch] - out[C * i + ch]));
    }
    CHECK_MSG(worst <= 1e-5, "reference differs from the forward by %g", worst);
    /* L = sum dout * out; central differences in double */
    double pp[N * 3];
    for (int i = 0; i < N * 3; ++i) pp[i] = pts[i];
    RefCtx c = {&v, g, pp, dout, N};
    MfGradCheck gc = {.loss = ref_loss, .ctx = &c, .pd = g, .g = dgrid, .n = ng, .eps = 1e-4, .atol = 1, .rtol = 0};
    double wg = mf_test_grad(&gc).worst;
    gc.pd = pp, gc.g = dpts, gc.n = N * 3;
    double wp = mf_test_grad(&gc).worst;
    printf("    adjoint vs central differences: dgrid worst %.2g, dpts worst %.2g\n", wg, wp);
    CHECK_MSG(wg <= 1e-3, "dgrid vs central differences: worst %g", wg);
    CHECK_MSG(wp <= 1e-3, "dpts vs central differences: worst %g", wp);
    /* += semantics: a second backward doubles the gradients */
    float d0 = dgrid[5], p0 = dpts[4];
    mf_voltex_backward(&v, pts, N, dout, dgrid, dpts);
    CHECK_NEAR(dgrid[5], 2 * d0, 1e-5);
    CHECK_NEAR(dpts[4], 2 * p0, 1e-5);
    free(g);
    free(dgrid);
    mf_voltex_free(&v);
}

typedef struct {
    MfVoltex *v;
    float eps, wt;
} TvCtx;

static double tv_loss(void *ctx) {
    const TvCtx *c = ctx;
    return mf_voltex_tv(c->v, c->eps, c->wt, NULL);
}

MF_TEST(geom_voltex_tv) {
    MfVoltex v;
    MfRng rng;
    mf_rng_seed(&rng, 13, 3);
    CHECK_OK(mf_voltex_init(&v, 5, 2, LO, HI, (const float[2]){0.25f, 0.75f}));
    /* a constant grid has zero TV and zero gradient */
    size_t ng = mf_voltex_size(&v);
    float *dg = calloc(ng, sizeof *dg);
    CHECK_NEAR(mf_voltex_tv(&v, 0.01f, 1.0f, dg), 0.0, 1e-12);
    float amax = 0;
    for (size_t i = 0; i < ng; ++i) amax = fmaxf(amax, fabsf(dg[i]));
    CHECK(amax == 0.0f);
    /* a step of height 1 along x between i = 1 and 2: (res^2 C edges) of sqrt(1 + eps^2) - eps over N terms */
    for (size_t vi = 0; vi < ng / 2; ++vi) v.grid[2 * vi] = v.grid[2 * vi + 1] = (vi % 5) >= 2 ? 1.0f : 0.0f;
    double want = 25.0 * 2 * (sqrt(1 + 1e-4) - 0.01) / (3.0 * 4 * 25 * 2);
    CHECK_NEAR(mf_voltex_tv(&v, 0.01f, 1.0f, NULL), want, 1e-9);
    /* gradient vs central differences (random grid with some equal neighbours: the eps region) */
    random_grid(&v, &rng);
    for (size_t i = 0; i < ng; i += 7) v.grid[i] = v.grid[(i + 2) % ng];
    memset(dg, 0, ng * sizeof *dg);
    const float eps = 0.05f, wt = 3.0f;
    mf_voltex_tv(&v, eps, wt, dg);
    TvCtx c = {&v, eps, wt};
    MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = tv_loss, .ctx = &c, .p = v.grid, .g = dg, .n = ng, .eps = 1e-3f,
                                                 .step = MF_FD_ROUNDED, .atol = 1, .rtol = 0});
    double worst = r.worst, gmax = r.fd_max;
    printf("    TV gradient vs central differences: worst %.2g (largest gradient %.2g)\n", worst, gmax);
    CHECK_MSG(worst <= 1e-3 * gmax, "TV gradient vs central differences: worst %g (largest %g)", worst, gmax);
    free(dg);
    mf_voltex_free(&v);
}
