/* Tests of mf/nn: every backward against central differences, multi-view attention, AdamW,
 * and a tiny network trained and reloaded (the checkpoint format itself: test_io_ckpt.c).
 *
 * Gradient checks: the loss is L = sum(out * r) for a fixed random r, evaluated by the float
 * forward but accumulated in double; the numeric derivative is (L(x+e) - L(x-e)) / (2e) with
 * e = 1e-2 on inputs of magnitude ~1 (the actual float step is used). Bound per element:
 * |numeric - analytic| <= 2e-3 + 1e-2 * max(|numeric|, |analytic|) (float rounding of L is
 * ~1e-5, i.e. ~5e-4 after dividing by 2e; truncation is O(e^2) = 1e-4 for these smooth layers). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "nn/mf_nn.h"
#include "nn/mf_nn_dnnl.h"
#include "io/mf_ckpt.h"
#include "mf_test.h"
#include "mf_test_grad.h"

#define GC_EPS 1e-2f
#define GC_ATOL 2e-3
#define GC_RTOL 1e-2

static void fill(float *x, size_t n, float lo, float hi, uint64_t seed) {
    MfRng r;
    mf_rng_seed(&r, seed, 99);
    for (size_t i = 0; i < n; ++i) x[i] = lo + (hi - lo) * mf_rng_float(&r);
}

static double dotd(const float *a, const float *b, size_t n) {
    double s = 0.0;
    for (size_t i = 0; i < n; ++i) s += (double)a[i] * b[i];
    return s;
}

static float *fal(size_t n) { return calloc(n ? n : 1, sizeof(float)); }

typedef double (*LossFn)(void *ctx);

/* Compares the analytic gradient g of L w.r.t. x (n floats) with central differences on up to
 * `maxs` elements spread over x; reports failures with `what`. */
static void gradcheck(const char *what, LossFn f, void *ctx, float *x, const float *g, size_t n, size_t maxs) {
    MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = f, .ctx = ctx, .p = x, .g = g, .n = n, .stride = n > maxs ? n / maxs : 1,
                                                 .eps = GC_EPS, .step = MF_FD_ROUNDED, .atol = GC_ATOL, .rtol = GC_RTOL,
                                                 .sym = 1, .what = what});
    if (getenv("NN_GC_VERBOSE")) fprintf(stderr, "  %-40s worst err/bound %.3f\n", what, r.worst);
    CHECK_MSG(r.off == 0, "%s: %d elements out of bound (worst err/bound %.3g at [%ld]: numeric %.6g analytic %.6g)", what, r.off,
              r.worst, r.at, r.fd, r.g);
}

/* ---- conv2d ---------------------------------------------------------------------------- */

typedef struct {
    int B, Ci, H, W, Co, K, S, Ho, Wo;
    float *in, *w, *b, *out, *col, *r;
} ConvCtx;

static double conv_loss(void *p) {
    ConvCtx *c = p;
    mf_conv2d_forward(c->out, c->col, c->in, c->w, c->b, c->B, c->Ci, c->H, c->W, c->Co, c->K, c->S);
    return dotd(c->out, c->r, (size_t)c->B * c->Co * c->Ho * c->Wo);
}

static void conv_case(int B, int K, int S, int H, int W) {
    ConvCtx c = {.B = B, .Ci = 3, .H = H, .W = W, .Co = 4, .K = K, .S = S};
    c.Ho = mf_conv2d_out_size(H, K, S);
    c.Wo = mf_conv2d_out_size(W, K, S);
    size_t nin = (size_t)c.B * c.Ci * H * W, nw = (size_t)c.Co * c.Ci * K * K, nout = (size_t)c.B * c.Co * c.Ho * c.Wo;
    c.in = fal(nin), c.w = fal(nw), c.b = fal(c.Co), c.out = fal(nout), c.r = fal(nout);
    c.col = fal(mf_conv2d_col_floats(c.B, c.Ci, H, W, c.Co, K, S));
    fill(c.in, nin, -1, 1, 1);
    fill(c.w, nw, -0.5f, 0.5f, 2);
    fill(c.b, c.Co, -0.5f, 0.5f, 3);
    fill(c.r, nout, -1, 1, 4);
    float *din = fal(nin), *dw = fal(nw), *db = fal(c.Co);
    /* accumulate twice onto a non-zero start to check += semantics */
    for (size_t i = 0; i < nw; ++i) dw[i] = 0.25f;
    conv_loss(&c);
    mf_conv2d_backward(din, dw, db, c.col, c.r, c.in, c.w, c.B, c.Ci, H, W, c.Co, K, S);
    for (size_t i = 0; i < nw; ++i) dw[i] -= 0.25f;
    char what[64];
    snprintf(what, sizeof what, "conv%dx%d/s%d din", K, K, S);
    gradcheck(what, conv_loss, &c, c.in, din, nin, 400);
    snprintf(what, sizeof what, "conv%dx%d/s%d dw", K, K, S);
    gradcheck(what, conv_loss, &c, c.w, dw, nw, 400);
    snprintf(what, sizeof what, "conv%dx%d/s%d db", K, K, S);
    gradcheck(what, conv_loss, &c, c.b, db, c.Co, 400);
    /* a direct (loop) convolution as an independent check of the forward */
    conv_loss(&c);
    int pad = K / 2;
    double maxd = 0.0;
    for (int b = 0; b < c.B; ++b)
        for (int o = 0; o < c.Co; ++o)
            for (int y = 0; y < c.Ho; ++y)
                for (int x = 0; x < c.Wo; ++x) {
                    double s = c.b[o];
                    for (int ci = 0; ci < c.Ci; ++ci)
                        for (int ky = 0; ky < K; ++ky)
                            for (int kx = 0; kx < K; ++kx) {
                                int iy = y * S - pad + ky, ix = x * S - pad + kx;
                                if (iy < 0 || iy >= H || ix < 0 || ix >= W) continue;
                                s += (double)c.w[((o * c.Ci + ci) * K + ky) * K + kx] *
                                     c.in[((size_t)(b * c.Ci + ci) * H + iy) * W + ix];
                            }
                    double d = fabs(s - c.out[((size_t)(b * c.Co + o) * c.Ho + y) * c.Wo + x]);
                    if (d > maxd) maxd = d;
                }
    CHECK_MSG(maxd < 1e-5, "conv%d s%d forward vs direct loop: max diff %g", K, S, maxd);
    free(c.in), free(c.w), free(c.b), free(c.out), free(c.r), free(c.col), free(din), free(dw), free(db);
}

MF_TEST(nn_conv2d_grad) {
    /* small images, B = 2: grouped path (both items in one GEMM) */
    conv_case(2, 3, 1, 5, 6);
    conv_case(2, 3, 2, 6, 6);
    conv_case(2, 3, 2, 5, 7);
    conv_case(2, 1, 1, 4, 5);
    conv_case(2, 1, 2, 6, 4);
    /* B = 1: one item per GEMM (direct path for 1x1 stride 1) */
    conv_case(1, 3, 1, 5, 6);
    conv_case(1, 3, 2, 6, 6);
    conv_case(1, 1, 1, 4, 5);
    /* 16x32 = 512 pixels: groups of 2 items, B = 3 leaves a last group of 1 */
    conv_case(3, 3, 1, 16, 32);
    conv_case(3, 1, 1, 16, 32);
    /* 32x32 = 1024 pixels: one item per GEMM with B = 2 */
    conv_case(2, 3, 1, 32, 32);
    conv_case(2, 1, 1, 32, 32);
    /* images no wider or taller than the 3x3 reach: the stride-1 taps' clipping */
    conv_case(2, 3, 1, 1, 1);
    conv_case(2, 3, 1, 2, 1);
    conv_case(1, 3, 1, 1, 3);
    conv_case(1, 3, 1, 2, 2);
    CHECK(mf_conv2d_out_size(32, 3, 2) == 16);
    CHECK(mf_conv2d_out_size(32, 3, 1) == 32);
    CHECK(mf_conv2d_out_size(32, 1, 2) == 16);
}

/* mf_conv2d_forward_ex / backward_ex: the fused bias_b, add, dbias_b and din_acc = 0 give what the
 * plain layer plus separate element-wise passes give (grouped, per-item and 1x1 direct paths). */
static void conv_ex_case(int B, int K, int H, int W) {
    int Ci = 3, Co = 4;
    size_t nin = (size_t)B * Ci * H * W, nout = (size_t)B * Co * H * W, nw = (size_t)Co * Ci * K * K, P = (size_t)H * W;
    float *in = fal(nin), *w = fal(nw), *b = fal(Co), *bb = fal((size_t)B * Co), *add = fal(nout), *dout = fal(nout);
    float *col = fal(mf_conv2d_col_floats(B, Ci, H, W, Co, K, 1)), *o1 = fal(nout), *o2 = fal(nout);
    float *din1 = fal(nin), *din2 = fal(nin), *dw1 = fal(nw), *dw2 = fal(nw), *db1 = fal(Co), *db2 = fal(Co);
    float *dbb = fal((size_t)B * Co);
    fill(in, nin, -1, 1, 41), fill(w, nw, -0.5f, 0.5f, 42), fill(b, Co, -0.5f, 0.5f, 43);
    fill(bb, (size_t)B * Co, -0.5f, 0.5f, 44), fill(add, nout, -1, 1, 45), fill(dout, nout, -1, 1, 46);
    mf_conv2d_forward(o1, col, in, w, b, B, Ci, H, W, Co, K, 1);
    for (int i = 0; i < B; ++i)
        for (int o = 0; o < Co; ++o)
            for (size_t p = 0; p < P; ++p) {
                size_t k = ((size_t)i * Co + o) * P + p;
                o1[k] = o1[k] + bb[i * Co + o] + add[k];
            }
    mf_conv2d_forward_ex(o2, col, in, w, b, bb, add, B, Ci, H, W, Co, K, 1);
    double md = 0.0;
    for (size_t i = 0; i < nout; ++i) md = fmax(md, fabs((double)o1[i] - o2[i]));
    CHECK_MSG(md <= 1e-6, "conv%d ex forward: max diff %g to conv + bias_b + add", K, md);
    /* backward: din_acc = 0 onto garbage equals += onto zeros; dbias_b sums to dbias */
    fill(din2, nin, 5, 6, 47);
    mf_conv2d_backward(din1, dw1, db1, col, dout, in, w, B, Ci, H, W, Co, K, 1);
    mf_conv2d_backward_ex(din2, 0, dw2, db2, dbb, col, dout, in, w, B, Ci, H, W, Co, K, 1);
    md = 0.0;
    for (size_t i = 0; i < nin; ++i) md = fmax(md, fabs((double)din1[i] - din2[i]));
    for (size_t i = 0; i < nw; ++i) md = fmax(md, fabs((double)dw1[i] - dw2[i]));
    for (int o = 0; o < Co; ++o) {
        double s = 0.0, r = 0.0;
        for (int i = 0; i < B; ++i) s += dbb[i * Co + o];
        for (int i = 0; i < B; ++i)
            for (size_t p = 0; p < P; ++p) r += dout[((size_t)i * Co + o) * P + p];
        md = fmax(md, fmax(fabs(s - r), fabs((double)db2[o] - r)) / fmax(1.0, fabs(r)));
    }
    CHECK_MSG(md <= 1e-5, "conv%d ex backward: max diff %g", K, md);
    free(in), free(w), free(b), free(bb), free(add), free(dout), free(col), free(o1), free(o2);
    free(din1), free(din2), free(dw1), free(dw2), free(db1), free(db2), free(dbb);
}

MF_TEST(nn_conv2d_fused_ex) {
    conv_ex_case(3, 3, 5, 6);   /* grouped */
    conv_ex_case(2, 3, 32, 32); /* one item per GEMM */
    conv_ex_case(2, 1, 32, 32); /* 1x1 direct */
    conv_ex_case(3, 1, 4, 5);   /* 1x1 grouped */
}

/* ---- conv backends: oneDNN against im2col + sgemm ------------------------------------------
 * In a build with oneDNN (the default; not `make DNNL=0`) the same calls through both backends:
 * forward_ex (bias, bias_b, add) and backward_ex (din written and accumulated, dw accumulated onto
 * a non-zero start, dbias, dbias_b) agree within DNNL_RTOL of the largest |value| of each output
 * (measured: at most ~5e-7 on these shapes, float rounding of sums in another order). Skipped in a
 * build without oneDNN. */
#define DNNL_RTOL 1e-5

/* max |a - b| / max |b| over n values */
static double rel_diff(const float *a, const float *b, size_t n) {
    double m = 0.0, s = 0.0;
    for (size_t i = 0; i < n; ++i) m = fmax(m, fabs((double)a[i] - b[i])), s = fmax(s, fabs((double)b[i]));
    return s > 0.0 ? m / s : m;
}

typedef struct {
    float *out, *din, *dw, *db, *dbb;
} ConvRes;

/* One forward_ex + backward_ex under backend be; din_acc 1 starts din from 0.5 (as dw from 0.25). */
static void conv_run_backend(ConvRes *r, MfNnBackend be, int din_acc, const float *in, const float *w, const float *b,
                             const float *bb, const float *add, const float *dout, float *col, int B, int Ci, int H,
                             int W, int Co, int K, int S) {
    size_t nin = (size_t)B * Ci * H * W, nw = (size_t)Co * Ci * K * K;
    CHECK_OK(mf_nn_set_backend(be));
    for (size_t i = 0; i < nin; ++i) r->din[i] = din_acc ? 0.5f : 7.0f; /* din_acc 0 overwrites */
    for (size_t i = 0; i < nw; ++i) r->dw[i] = 0.25f;
    memset(r->db, 0, sizeof(float) * (size_t)Co), memset(r->dbb, 0, sizeof(float) * (size_t)B * Co);
    mf_conv2d_forward_ex(r->out, col, in, w, b, bb, add, B, Ci, H, W, Co, K, S);
    mf_conv2d_backward_ex(r->din, din_acc, r->dw, r->db, r->dbb, col, dout, in, w, B, Ci, H, W, Co, K, S);
    CHECK_MSG(mf_nn_backend() == be, "backend %s fell back to blas: %s", mf_nn_backend_name(be), mf_error());
}

/* Worst relative difference dnnl vs blas over all outputs of one shape; extras: bias_b and add. */
static double conv_backend_case(int B, int Ci, int Co, int H, int W, int K, int S, int extras, int din_acc) {
    int Ho = mf_conv2d_out_size(H, K, S), Wo = mf_conv2d_out_size(W, K, S);
    size_t nin = (size_t)B * Ci * H * W, nw = (size_t)Co * Ci * K * K, nout = (size_t)B * Co * Ho * Wo;
    float *in = fal(nin), *w = fal(nw), *b = fal(Co), *bb = fal((size_t)B * Co), *add = fal(nout), *dout = fal(nout);
    float *col = fal(mf_conv2d_col_floats(B, Ci, H, W, Co, K, S));
    fill(in, nin, -1, 1, 51), fill(w, nw, -0.5f, 0.5f, 52), fill(b, Co, -0.5f, 0.5f, 53);
    fill(bb, (size_t)B * Co, -0.5f, 0.5f, 54), fill(add, nout, -1, 1, 55), fill(dout, nout, -1, 1, 56);
    ConvRes r[2];
    for (int k = 0; k < 2; ++k)
        r[k] = (ConvRes){fal(nout), fal(nin), fal(nw), fal(Co), fal((size_t)B * Co)};
    conv_run_backend(&r[0], MF_NN_BLAS, din_acc, in, w, b, extras ? bb : NULL, extras ? add : NULL, dout, col, B, Ci, H,
                     W, Co, K, S);
    conv_run_backend(&r[1], MF_NN_DNNL, din_acc, in, w, b, extras ? bb : NULL, extras ? add : NULL, dout, col, B, Ci, H,
                     W, Co, K, S);
    double d[5] = {rel_diff(r[1].out, r[0].out, nout), rel_diff(r[1].din, r[0].din, nin), rel_diff(r[1].dw, r[0].dw, nw),
                   rel_diff(r[1].db, r[0].db, Co), rel_diff(r[1].dbb, r[0].dbb, (size_t)B * Co)};
    const char *names[5] = {"out", "din", "dw", "dbias", "dbias_b"};
    double worst = 0.0;
    for (int k = 0; k < 5; ++k) {
        CHECK_MSG(d[k] <= DNNL_RTOL, "conv B=%d %d->%d %dx%d K=%d s%d: dnnl %s differs from blas by %.3g relative", B, Ci,
                  Co, H, W, K, S, names[k], d[k]);
        worst = fmax(worst, d[k]);
    }
    if (getenv("NN_GC_VERBOSE"))
        fprintf(stderr, "  dnnl vs blas B=%d %d->%d %dx%d K=%d s%d: %.2e\n", B, Ci, Co, H, W, K, S, worst);
    for (int k = 0; k < 2; ++k) free(r[k].out), free(r[k].din), free(r[k].dw), free(r[k].db), free(r[k].dbb);
    free(in), free(w), free(b), free(bb), free(add), free(dout), free(col);
    return worst;
}

MF_TEST(nn_conv2d_dnnl_matches_blas) {
    MfNnBackend was = mf_nn_backend();
    if (mf_nn_set_backend(MF_NN_DNNL) != MF_OK) MF_SKIP("built without oneDNN (make DNNL=0)");
    /* a biased layer's forward and both backward passes share one cached shape (the thread's
     * cache may hold other tests' shapes) */
    int before = mf_nn_dnnl_entries();
    conv_backend_case(2, 3, 4, 5, 7, 3, 1, 0, 1);
    CHECK_MSG(mf_nn_dnnl_entries() == before + 1, "%d cached shapes for one layer", mf_nn_dnnl_entries() - before);
    /* the prior's kinds of conv (3x3 s1, 3x3 s2 down, 1x1 skip) at small sizes, odd sides too */
    conv_backend_case(2, 3, 4, 5, 6, 3, 1, 1, 0);
    conv_backend_case(2, 3, 4, 5, 6, 3, 1, 0, 1);
    conv_backend_case(3, 8, 8, 16, 32, 3, 1, 1, 1);
    conv_backend_case(2, 4, 8, 8, 8, 3, 2, 0, 1);
    conv_backend_case(2, 4, 8, 7, 5, 3, 2, 0, 0);
    conv_backend_case(2, 8, 4, 6, 6, 1, 1, 1, 1);
    conv_backend_case(1, 8, 4, 6, 4, 1, 2, 0, 1);
    conv_backend_case(2, 3, 4, 1, 2, 3, 1, 0, 1); /* smaller than the 3x3 reach */
    /* a denoiser shape (C 64 at 16x16), with the block's fused terms */
    conv_backend_case(4, 64, 64, 16, 16, 3, 1, 1, 0);
    /* the cached primitives serve a repeated shape (same results as a first call) */
    conv_backend_case(2, 3, 4, 5, 6, 3, 1, 1, 0);
    CHECK_OK(mf_nn_set_backend(was));
}

/* MF_NN_BACKEND: blas always works; dnnl only where built; anything else is refused by name. */
MF_TEST(nn_backend_env) {
    MfNnBackend was = mf_nn_backend();
    const char *old = getenv("MF_NN_BACKEND");
    char *saved = old ? strdup(old) : NULL;
    setenv("MF_NN_BACKEND", "blas", 1);
    CHECK_OK(mf_nn_backend_from_env());
    CHECK(mf_nn_backend() == MF_NN_BLAS);
    setenv("MF_NN_BACKEND", "cuda", 1);
    CHECK_ERR(mf_nn_backend_from_env(), "MF_NN_BACKEND=cuda");
    CHECK(mf_nn_backend() == MF_NN_BLAS);
    setenv("MF_NN_BACKEND", "dnnl", 1);
    int rc = mf_nn_backend_from_env();
    if (rc) CHECK(strstr(mf_error(), "MF_NN_BACKEND=dnnl") && strstr(mf_error(), "make DNNL=1") && mf_nn_backend() == MF_NN_BLAS);
    else CHECK(mf_nn_backend() == MF_NN_DNNL);
    setenv("MF_NN_BACKEND", "", 1);
    CHECK_OK(mf_nn_backend_from_env());
    if (saved) setenv("MF_NN_BACKEND", saved, 1);
    else unsetenv("MF_NN_BACKEND");
    free(saved);
    CHECK_OK(mf_nn_set_backend(was));
}

/* ---- upsample, SiLU, tokens, MSE ------------------------------------------------------------- */

typedef struct {
    int B, C, H, W;
    float *in, *out, *r;
} UpCtx;

static double up_loss(void *p) {
    UpCtx *c = p;
    mf_upsample2x_forward(c->out, c->in, c->B, c->C, c->H, c->W);
    return dotd(c->out, c->r, (size_t)c->B * c->C * 4 * c->H * c->W);
}

MF_TEST(nn_upsample_grad) {
    UpCtx c = {.B = 2, .C = 3, .H = 3, .W = 4};
    size_t n = 2 * 3 * 3 * 4;
    c.in = fal(n), c.out = fal(4 * n), c.r = fal(4 * n);
    fill(c.in, n, -1, 1, 5);
    fill(c.r, 4 * n, -1, 1, 6);
    float *din = fal(n);
    up_loss(&c);
    CHECK(c.out[0] == c.in[0] && c.out[1] == c.in[0] && c.out[8] == c.in[0] && c.out[9] == c.in[0]);
    CHECK(c.out[2] == c.in[1] && c.out[16] == c.in[4]);
    mf_upsample2x_backward(din, c.r, c.B, c.C, c.H, c.W);
    gradcheck("upsample din", up_loss, &c, c.in, din, n, 1000);
    free(c.in), free(c.out), free(c.r), free(din);
}

typedef struct {
    size_t n;
    float *in, *out, *r;
} EwCtx;

static double silu_loss(void *p) {
    EwCtx *c = p;
    mf_silu_forward(c->out, c->in, c->n);
    return dotd(c->out, c->r, c->n);
}

static double mse_loss(void *p) {
    EwCtx *c = p; /* out is the target here */
    return mf_mse_forward(c->in, c->out, c->n);
}

MF_TEST(nn_silu_mse_grad) {
    EwCtx c = {.n = 64};
    c.in = fal(64), c.out = fal(64), c.r = fal(64);
    fill(c.in, 64, -4, 4, 7);
    fill(c.r, 64, -1, 1, 8);
    float *din = fal(64);
    silu_loss(&c);
    CHECK_NEAR(c.out[0], c.in[0] / (1 + exp(-c.in[0])), 1e-6);
    mf_silu_backward(din, c.r, c.in, 64);
    gradcheck("silu din", silu_loss, &c, c.in, din, 64, 64);
    fill(c.out, 64, -1, 1, 9);
    memset(din, 0, 64 * sizeof(float));
    mf_mse_backward(din, c.in, c.out, 64, 1.0f);
    gradcheck("mse dpred", mse_loss, &c, c.in, din, 64, 64);
    float a[3] = {1, 2, 3}, b[3] = {1, 0, 0};
    CHECK_NEAR(mf_mse_forward(a, b, 3), (4.0 + 9.0) / 3.0, 1e-6);
    free(c.in), free(c.out), free(c.r), free(din);
}

/* SiLU's own exponential (mf_nn_layers.c nn_expf) against libm in double, over the whole float
 * range it is used on and beyond its clamp; NaN stays NaN. */
MF_TEST(nn_silu_accuracy) {
    enum { N = 4001 };
    float *x = fal(N + 3), *y = fal(N + 3), *dy = fal(N + 3), *one = fal(N + 3);
    for (int i = 0; i < N; ++i) x[i] = -100.0f + 200.0f * (float)i / (N - 1), one[i] = 1.0f;
    x[N] = 1e30f, x[N + 1] = -1e30f, x[N + 2] = NAN;
    one[N] = one[N + 1] = one[N + 2] = 1.0f;
    mf_silu_forward(y, x, N + 3);
    mf_silu_backward(dy, one, x, N + 3);
    double worst = 0.0, worst_g = 0.0;
    for (int i = 0; i < N + 2; ++i) {
        double xd = x[i], s = 1.0 / (1.0 + exp(-xd)), ref = xd * s, g = s * (1.0 + xd * (1.0 - s));
        /* relative to the value, with an absolute floor (1e-26) far below any activation that matters */
        worst = fmax(worst, fabs(y[i] - ref) / fmax(fabs(ref), 1e-20));
        worst_g = fmax(worst_g, fabs(dy[i] - g) / fmax(fabs(g), 1e-3));
    }
    CHECK_MSG(worst < 1e-6, "silu: worst relative error %g", worst);
    CHECK_MSG(worst_g < 2e-6, "silu': worst relative error %g", worst_g);
    CHECK(y[N] == 1e30f && y[N + 1] == 0.0f && dy[N] == 1.0f && dy[N + 1] == 0.0f);
    CHECK(isnan(y[N + 2]) && isnan(dy[N + 2]));
    free(x), free(y), free(dy), free(one);
}

MF_TEST(nn_tokens_transpose_adjoint) {
    int B = 2, C = 3, HW = 5;
    size_t n = (size_t)B * C * HW;
    float *x = fal(n), *y = fal(n), *tx = fal(n), *ty = fal(n), *back = fal(n);
    fill(x, n, -1, 1, 10);
    fill(y, n, -1, 1, 11);
    mf_nchw_to_tokens_forward(tx, x, B, C, HW);
    CHECK(tx[(1 * HW + 2) * C + 1] == x[(1 * C + 1) * HW + 2]); /* token (b=1, p=2), channel 1 */
    mf_nchw_to_tokens_backward(ty, y, B, C, HW);                /* ty = T^T y */
    CHECK_NEAR(dotd(tx, y, n), dotd(x, ty, n), 1e-5);
    mf_tokens_to_nchw_forward(back, tx, B, C, HW);
    CHECK(memcmp(back, x, n * sizeof(float)) == 0);
    memset(ty, 0, n * sizeof(float));
    mf_tokens_to_nchw_backward(ty, y, B, C, HW);
    mf_tokens_to_nchw_forward(back, x, B, C, HW);
    CHECK_NEAR(dotd(back, y, n), dotd(x, ty, n), 1e-5);
    free(x), free(y), free(tx), free(ty), free(back);
}

static double gelu_loss(void *p) {
    EwCtx *c = p;
    mf_gelu_forward(c->out, c->in, c->n);
    return dotd(c->out, c->r, c->n);
}

MF_TEST(nn_gelu_grad) {
    EwCtx c = {.n = 64};
    c.in = fal(64), c.out = fal(64), c.r = fal(64);
    fill(c.in, 64, -4, 4, 70);
    fill(c.r, 64, -1, 1, 71);
    float *din = fal(64);
    gelu_loss(&c);
    double x = c.in[0];
    CHECK_NEAR(c.out[0], 0.5 * x * (1 + tanh(sqrt(2 / M_PI) * (x + 0.044715 * x * x * x))), 1e-6);
    mf_gelu_backward(din, c.r, c.in, 64);
    gradcheck("gelu din", gelu_loss, &c, c.in, din, 64, 64);
    free(c.in), free(c.out), free(c.r), free(din);
}

typedef struct {
    int N, C;
    float *in, *w, *b, *out, *mean, *rstd, *r;
} LnCtx;

static double ln_loss(void *p) {
    LnCtx *c = p;
    mf_layernorm_forward(c->out, c->mean, c->rstd, c->in, c->w, c->b, c->N, c->C, 1e-5f);
    return dotd(c->out, c->r, (size_t)c->N * c->C);
}

MF_TEST(nn_layernorm_grad) {
    LnCtx c = {.N = 3, .C = 6};
    c.in = fal(18), c.w = fal(6), c.b = fal(6), c.out = fal(18), c.mean = fal(3), c.rstd = fal(3), c.r = fal(18);
    fill(c.in, 18, -1, 2, 72);
    fill(c.w, 6, 0.5f, 1.5f, 73);
    fill(c.b, 6, -0.5f, 0.5f, 74);
    fill(c.r, 18, -1, 1, 75);
    float *din = fal(18), *dw = fal(6), *db = fal(6);
    ln_loss(&c);
    mf_layernorm_backward(din, dw, db, c.r, c.in, c.mean, c.rstd, c.w, c.N, c.C);
    gradcheck("layernorm din", ln_loss, &c, c.in, din, 18, 18);
    gradcheck("layernorm dw", ln_loss, &c, c.w, dw, 6, 6);
    gradcheck("layernorm db", ln_loss, &c, c.b, db, 6, 6);
    free(c.in), free(c.w), free(c.b), free(c.out), free(c.mean), free(c.rstd), free(c.r);
    free(din), free(dw), free(db);
}

/* ---- group norm -------------------------------------------------------------------------------- */

typedef struct {
    int B, C, HW, G;
    float *in, *ga, *be, *out, *mean, *rstd, *r;
} GnCtx;

static double gn_loss(void *p) {
    GnCtx *c = p;
    mf_groupnorm_forward(c->out, c->mean, c->rstd, c->in, c->ga, c->be, c->B, c->C, c->HW, c->G, 1e-5f);
    return dotd(c->out, c->r, (size_t)c->B * c->C * c->HW);
}

MF_TEST(nn_groupnorm_grad) {
    GnCtx c = {.B = 2, .C = 4, .HW = 6, .G = 2};
    size_t n = 2 * 4 * 6;
    c.in = fal(n), c.out = fal(n), c.r = fal(n), c.ga = fal(4), c.be = fal(4), c.mean = fal(4), c.rstd = fal(4);
    fill(c.in, n, -1, 2, 12);
    fill(c.r, n, -1, 1, 13);
    fill(c.ga, 4, 0.5f, 1.5f, 14);
    fill(c.be, 4, -0.5f, 0.5f, 15);
    float *din = fal(n), *dg = fal(4), *db = fal(4);
    gn_loss(&c);
    /* normalised groups: mean 0, variance 1 before the affine map (check with gamma 1, beta 0) */
    float one[4] = {1, 1, 1, 1}, zero[4] = {0};
    mf_groupnorm_forward(c.out, c.mean, c.rstd, c.in, one, zero, c.B, c.C, c.HW, c.G, 1e-5f);
    double s = 0, s2 = 0;
    for (int i = 0; i < 12; ++i) s += c.out[i], s2 += (double)c.out[i] * c.out[i];
    CHECK_NEAR(s / 12, 0, 1e-5);
    CHECK_NEAR(s2 / 12, 1, 1e-3);
    gn_loss(&c);
    mf_groupnorm_backward(din, dg, db, c.r, c.in, c.mean, c.rstd, c.ga, c.B, c.C, c.HW, c.G);
    gradcheck("groupnorm din", gn_loss, &c, c.in, din, n, 100);
    gradcheck("groupnorm dgamma", gn_loss, &c, c.ga, dg, 4, 4);
    gradcheck("groupnorm dbeta", gn_loss, &c, c.be, db, 4, 4);
    free(c.in), free(c.out), free(c.r), free(c.ga), free(c.be), free(c.mean), free(c.rstd);
    free(din), free(dg), free(db);
}

typedef struct {
    GnCtx gn;
    float *sig;
} GnsCtx;

static double gns_loss(void *p) {
    GnsCtx *c = p;
    GnCtx *g = &c->gn;
    mf_gnsilu_forward(g->out, c->sig, g->mean, g->rstd, g->in, g->ga, g->be, g->B, g->C, g->HW, g->G, 1e-5f);
    return dotd(g->out, g->r, (size_t)g->B * g->C * g->HW);
}

/* Group norm + SiLU in one pass: equal to the two layers within float rounding, exact gradients
 * (central differences), din written (din_acc = 0) or accumulated; HW above the chunk of the
 * backward's dh buffer (512) so the chunked loop runs more than once. */
MF_TEST(nn_gnsilu_fused) {
    int B = 2, C = 4, HW = 700, G = 2;
    size_t n = (size_t)B * C * HW;
    GnsCtx c = {.gn = {.B = B, .C = C, .HW = HW, .G = G}};
    GnCtx *g = &c.gn;
    g->in = fal(n), g->out = fal(n), g->r = fal(n), g->ga = fal(C), g->be = fal(C), g->mean = fal(4), g->rstd = fal(4);
    c.sig = fal(n);
    fill(g->in, n, -1, 2, 22), fill(g->r, n, -1, 1, 23), fill(g->ga, C, 0.5f, 1.5f, 24), fill(g->be, C, -0.5f, 0.5f, 25);
    float *h = fal(n), *a = fal(n), *m2 = fal(4), *r2 = fal(4);
    mf_groupnorm_forward(h, m2, r2, g->in, g->ga, g->be, B, C, HW, G, 1e-5f);
    mf_silu_forward(a, h, n);
    gns_loss(&c);
    double md = 0.0, ms = 0.0;
    for (size_t i = 0; i < n; ++i) {
        md = fmax(md, fabs((double)a[i] - g->out[i]));
        ms = fmax(ms, fabs(1.0 / (1.0 + exp(-(double)h[i])) - c.sig[i]));
    }
    CHECK_MSG(md < 2e-6 && ms < 1e-6, "gnsilu vs groupnorm + silu: max diff %g (sigmoid cache %g)", md, ms);
    CHECK(g->mean[0] == m2[0] && g->rstd[3] == r2[3]);
    /* reference gradients: silu backward then groupnorm backward */
    float *dh = fal(n), *dref = fal(n), *dgr = fal(C), *dbr = fal(C), *din = fal(n), *dg = fal(C), *db = fal(C);
    mf_silu_backward(dh, g->r, h, n);
    mf_groupnorm_backward(dref, dgr, dbr, dh, g->in, m2, r2, g->ga, B, C, HW, G);
    fill(din, n, 7, 8, 26); /* written over */
    mf_gnsilu_backward(din, 0, dg, db, g->r, g->in, c.sig, g->mean, g->rstd, g->ga, g->be, B, C, HW, G);
    md = 0.0;
    for (size_t i = 0; i < n; ++i) md = fmax(md, fabs((double)din[i] - dref[i]));
    for (int i = 0; i < C; ++i) md = fmax(md, fmax(fabs((double)dg[i] - dgr[i]), fabs((double)db[i] - dbr[i])) / 100.0);
    CHECK_MSG(md < 1e-5, "gnsilu backward vs silu + groupnorm backward: max diff %g", md);
    gradcheck("gnsilu din", gns_loss, &c, g->in, din, n, 100);
    gradcheck("gnsilu dgamma", gns_loss, &c, g->ga, dg, C, C);
    gradcheck("gnsilu dbeta", gns_loss, &c, g->be, db, C, C);
    /* din_acc = 1 adds onto what is there (the forward's cache again at the unperturbed input) */
    gns_loss(&c);
    float *din2 = fal(n);
    for (size_t i = 0; i < n; ++i) din2[i] = 0.5f;
    mf_gnsilu_backward(din2, 1, NULL, NULL, g->r, g->in, c.sig, g->mean, g->rstd, g->ga, g->be, B, C, HW, G);
    md = 0.0;
    for (size_t i = 0; i < n; ++i) md = fmax(md, fabs((double)din2[i] - 0.5 - din[i]));
    CHECK_MSG(md < 1e-6, "gnsilu backward din_acc = 1: max diff %g", md);
    free(g->in), free(g->out), free(g->r), free(g->ga), free(g->be), free(g->mean), free(g->rstd), free(c.sig);
    free(h), free(a), free(m2), free(r2), free(dh), free(dref), free(dgr), free(dbr), free(din), free(dg), free(db), free(din2);
}

/* ---- linear -------------------------------------------------------------------------------------- */

typedef struct {
    int N, IC, OC;
    float *in, *w, *b, *out, *r;
} LinCtx;

static double lin_loss(void *p) {
    LinCtx *c = p;
    mf_linear_forward(c->out, c->in, c->w, c->b, c->N, c->IC, c->OC);
    return dotd(c->out, c->r, (size_t)c->N * c->OC);
}

MF_TEST(nn_linear_grad) {
    LinCtx c = {.N = 3, .IC = 5, .OC = 4};
    c.in = fal(15), c.w = fal(20), c.b = fal(4), c.out = fal(12), c.r = fal(12);
    fill(c.in, 15, -1, 1, 16);
    fill(c.w, 20, -1, 1, 17);
    fill(c.b, 4, -1, 1, 18);
    fill(c.r, 12, -1, 1, 19);
    float *din = fal(15), *dw = fal(20), *db = fal(4);
    lin_loss(&c);
    CHECK_NEAR(c.out[1 * 4 + 2], c.b[2] + dotd(c.in + 5, c.w + 2 * 5, 5), 1e-5);
    mf_linear_backward(din, dw, db, c.r, c.in, c.w, c.N, c.IC, c.OC);
    gradcheck("linear din", lin_loss, &c, c.in, din, 15, 15);
    gradcheck("linear dw", lin_loss, &c, c.w, dw, 20, 20);
    gradcheck("linear db", lin_loss, &c, c.b, db, 4, 4);
    free(c.in), free(c.w), free(c.b), free(c.out), free(c.r), free(din), free(dw), free(db);
}

/* ---- attention ------------------------------------------------------------------------------------ */

typedef struct {
    int BV, V, HW, C, NH, joint;
    float *qkv, *out, *att, *r;
} AttCtx;

static double att_loss(void *p) {
    AttCtx *c = p;
    mf_mv_attention_forward(c->out, c->att, c->qkv, c->BV, c->V, c->HW, c->C, c->NH, c->joint);
    return dotd(c->out, c->r, (size_t)c->BV * c->HW * c->C);
}

static void att_grad_case(int joint) {
    AttCtx c = {.BV = 4, .V = 2, .HW = 3, .C = 4, .NH = 2, .joint = joint};
    size_t nq = (size_t)c.BV * c.HW * 3 * c.C, no = (size_t)c.BV * c.HW * c.C;
    int T = joint ? c.V * c.HW : c.HW;
    c.qkv = fal(nq), c.out = fal(no), c.r = fal(no);
    c.att = fal(mf_mv_attention_att_floats(c.BV, c.V, c.HW, c.NH, joint));
    float *dq = fal(nq), *scr = fal((size_t)T * T);
    fill(c.qkv, nq, -1.5f, 1.5f, 20);
    fill(c.r, no, -1, 1, 21);
    att_loss(&c);
    mf_mv_attention_backward(dq, scr, c.r, c.att, c.qkv, c.BV, c.V, c.HW, c.C, c.NH, joint);
    gradcheck(joint ? "mv-attention(joint) dqkv" : "attention dqkv", att_loss, &c, c.qkv, dq, nq, 300);
    free(c.qkv), free(c.out), free(c.r), free(c.att), free(dq), free(scr);
}

MF_TEST(nn_attention_grad) {
    att_grad_case(0);
    att_grad_case(1);
    /* forward against a direct double-precision softmax attention (one batch, T=3, 1 head) */
    int T = 3, C = 2;
    float qkv[3 * 3 * 2], out[3 * 2], att[9];
    fill(qkv, sizeof qkv / sizeof qkv[0], -1, 1, 22);
    mf_attention_forward(out, att, qkv, 1, T, C, 1);
    for (int i = 0; i < T; ++i) {
        double s[3], m = -1e30, z = 0;
        for (int j = 0; j < T; ++j) {
            s[j] = (qkv[i * 6 + 0] * qkv[j * 6 + 2] + qkv[i * 6 + 1] * qkv[j * 6 + 3]) / sqrt(2.0);
            m = fmax(m, s[j]);
        }
        for (int j = 0; j < T; ++j) z += (s[j] = exp(s[j] - m));
        for (int c = 0; c < C; ++c) {
            double o = 0;
            for (int j = 0; j < T; ++j) o += s[j] / z * qkv[j * 6 + 4 + c];
            CHECK_NEAR(out[i * 2 + c], o, 1e-6);
        }
    }
}

MF_TEST(nn_mv_attention_modes) {
    int HW = 4, C = 4, NH = 2;
    /* V = 1: joint and per-view attention are the same computation */
    {
        int BV = 3, V = 1;
        size_t nq = (size_t)BV * HW * 3 * C, no = (size_t)BV * HW * C;
        float *qkv = fal(nq), *o1 = fal(no), *o2 = fal(no);
        float *a1 = fal(mf_mv_attention_att_floats(BV, V, HW, NH, 0));
        float *a2 = fal(mf_mv_attention_att_floats(BV, V, HW, NH, 1));
        fill(qkv, nq, -1, 1, 23);
        mf_mv_attention_forward(o1, a1, qkv, BV, V, HW, C, NH, 0);
        mf_mv_attention_forward(o2, a2, qkv, BV, V, HW, C, NH, 1);
        CHECK(memcmp(o1, o2, no * sizeof(float)) == 0);
        free(qkv), free(o1), free(o2), free(a1), free(a2);
    }
    /* V = 2: joint attention mixes the views, so it differs; and it equals attention over the
     * concatenated token sequence of each object (B = BV/V, T = V*HW) */
    {
        int BV = 4, V = 2;
        size_t nq = (size_t)BV * HW * 3 * C, no = (size_t)BV * HW * C;
        float *qkv = fal(nq), *o1 = fal(no), *o2 = fal(no), *o3 = fal(no);
        float *a1 = fal(mf_mv_attention_att_floats(BV, V, HW, NH, 0));
        float *a2 = fal(mf_mv_attention_att_floats(BV, V, HW, NH, 1));
        CHECK(mf_mv_attention_att_floats(BV, V, HW, NH, 1) == (size_t)V * mf_mv_attention_att_floats(BV, V, HW, NH, 0));
        fill(qkv, nq, -1, 1, 24);
        mf_mv_attention_forward(o1, a1, qkv, BV, V, HW, C, NH, 0);
        mf_mv_attention_forward(o2, a2, qkv, BV, V, HW, C, NH, 1);
        double maxd = 0;
        for (size_t i = 0; i < no; ++i) maxd = fmax(maxd, fabs(o1[i] - o2[i]));
        CHECK_MSG(maxd > 1e-3, "joint and per-view attention agree (max diff %g) with V=2", maxd);
        mf_attention_forward(o3, a2, qkv, BV / V, V * HW, C, NH);
        CHECK(memcmp(o2, o3, no * sizeof(float)) == 0);
        /* every joint attention row spreads weight over both views */
        for (int i = 0; i < V * HW; ++i) {
            double w_other = 0;
            for (int j = HW; j < 2 * HW; ++j) w_other += a2[(size_t)i * V * HW + j];
            CHECK(w_other > 1e-3 && w_other < 1 - 1e-3);
        }
        free(qkv), free(o1), free(o2), free(o3), free(a1), free(a2);
    }
}

/* ---- timestep embedding ---------------------------------------------------------------------- */

MF_TEST(nn_timestep_embedding) {
    float t[2] = {0.0f, 500.0f}, e[2 * 8];
    mf_timestep_embedding(e, t, 2, 8, 10000.0f);
    for (int i = 0; i < 4; ++i) {
        CHECK_NEAR(e[i], 1.0, 1e-7);     /* cos(0) */
        CHECK_NEAR(e[4 + i], 0.0, 1e-7); /* sin(0) */
        double f = exp(-log(10000.0) * i / 4);
        CHECK_NEAR(e[8 + i], cos(500.0 * f), 1e-6);
        CHECK_NEAR(e[12 + i], sin(500.0 * f), 1e-6);
    }
}

/* ---- residual block -------------------------------------------------------------------------- */

typedef struct {
    MfResBlockDims d;
    MfResBlockW w;
    MfResBlockActs a;
    float *x, *temb, *out, *r;
} RbCtx;

static double rb_loss(void *p) {
    RbCtx *c = p;
    mf_resblock_forward(c->out, &c->a, c->x, c->temb, &c->w, &c->d);
    return dotd(c->out, c->r, (size_t)c->d.B * c->d.Cout * c->d.H * c->d.W);
}

static void rb_case(int Cin, int Cout, int Ct) {
    RbCtx c = {.d = {2, Cin, Cout, 4, 3, Ct, 2, 1e-5f}};
    MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
    int ns = mf_resblock_specs(specs, "blk", &c.d);
    CHECK(ns == 8 + (Ct > 0 ? 2 : 0) + (Cin != Cout ? 2 : 0));
    CHECK(!strcmp(specs[2].name, "blk.conv1.w") && specs[2].shape[1] == Cin);
    size_t np = mf_specs_numel(specs, ns);
    float *pm = fal(np), *gm = fal(np), *am = fal(mf_resblock_acts_floats(&c.d));
    MfResBlockW g;
    mf_resblock_bind(&c.w, &c.d, pm);
    mf_resblock_bind(&g, &c.d, gm);
    mf_resblock_acts_bind(&c.a, &c.d, am);
    CHECK((c.w.skip_w != NULL) == (Cin != Cout));
    CHECK((c.w.temb_w != NULL) == (Ct > 0));
    mf_resblock_init(&c.w, &c.d, 7);
    /* perturb GN affine away from (1, 0) so their gradients are exercised generically */
    fill(c.w.gn1_w, Cin, 0.7f, 1.3f, 30);
    fill(c.w.gn2_b, Cout, -0.3f, 0.3f, 31);
    size_t HW = 12, nx = (size_t)2 * Cin * HW, no = (size_t)2 * Cout * HW;
    c.x = fal(nx), c.out = fal(no), c.r = fal(no), c.temb = Ct ? fal((size_t)2 * Ct) : NULL;
    fill(c.x, nx, -1, 1, 32);
    fill(c.r, no, -1, 1, 33);
    if (Ct) fill(c.temb, (size_t)2 * Ct, -1, 1, 34);
    float *dx = fal(nx), *dt = fal((size_t)2 * (Ct ? Ct : 1));
    rb_loss(&c);
    mf_resblock_backward(dx, Ct ? dt : NULL, &g, &c.a, c.r, c.x, c.temb, &c.w, &c.d);
    char what[160];
    snprintf(what, sizeof what, "resblock %d->%d dx", Cin, Cout);
    gradcheck(what, rb_loss, &c, c.x, dx, nx, 60);
    if (Ct) {
        snprintf(what, sizeof what, "resblock %d->%d dtemb", Cin, Cout);
        gradcheck(what, rb_loss, &c, c.temb, dt, (size_t)2 * Ct, 20);
    }
    /* every parameter tensor: the flat buffers line up tensor by tensor */
    size_t off = 0;
    for (int i = 0; i < ns; ++i) {
        size_t n = mf_tensor_numel(&specs[i]);
        snprintf(what, sizeof what, "resblock %d->%d d%.63s", Cin, Cout, specs[i].name);
        gradcheck(what, rb_loss, &c, pm + off, gm + off, n, 25);
        off += n;
    }
    free(pm), free(gm), free(am), free(c.x), free(c.out), free(c.r), free(c.temb), free(dx), free(dt);
}

MF_TEST(nn_resblock_grad) {
    rb_case(2, 4, 3); /* channels change: 1x1 skip */
    rb_case(4, 4, 3); /* identity skip */
    rb_case(4, 2, 0); /* no time embedding */
}

/* ---- attention block -------------------------------------------------------------------------- */

typedef struct {
    MfAttnBlockDims d;
    MfAttnBlockW w;
    MfAttnBlockActs a;
    float *x, *out, *r;
} AbCtx;

static double ab_loss(void *p) {
    AbCtx *c = p;
    mf_attnblock_forward(c->out, &c->a, c->x, &c->w, &c->d);
    return dotd(c->out, c->r, (size_t)c->d.BV * c->d.C * c->d.H * c->d.W);
}

static void ab_setup(AbCtx *c, float **pm, float **gm, float **am, MfAttnBlockW *g) {
    MfTensorSpec specs[MF_ATTNBLOCK_NPARAMS];
    mf_attnblock_specs(specs, "attn", &c->d);
    size_t np = mf_specs_numel(specs, MF_ATTNBLOCK_NPARAMS);
    *pm = fal(np), *gm = fal(np), *am = fal(mf_attnblock_acts_floats(&c->d));
    mf_attnblock_bind(&c->w, &c->d, *pm);
    mf_attnblock_bind(g, &c->d, *gm);
    mf_attnblock_acts_bind(&c->a, &c->d, *am);
    mf_attnblock_init(&c->w, &c->d, 3);
    fill(c->w.gn_w, (size_t)c->d.C, 0.7f, 1.3f, 60);
    fill(c->w.gn_b, (size_t)c->d.C, -0.3f, 0.3f, 61);
    size_t n = (size_t)c->d.BV * c->d.C * c->d.H * c->d.W;
    c->x = fal(n), c->out = fal(n), c->r = fal(n);
    fill(c->x, n, -1, 1, 62);
    fill(c->r, n, -1, 1, 63);
}

MF_TEST(nn_attnblock_grad) {
    for (int joint = 0; joint <= 1; ++joint) {
        AbCtx c = {.d = {.BV = 4, .C = 4, .H = 2, .W = 3, .G = 2, .NH = 2, .V = 2, .joint = joint, .eps = 1e-5f}};
        float *pm, *gm, *am;
        MfAttnBlockW g;
        ab_setup(&c, &pm, &gm, &am, &g);
        size_t n = (size_t)4 * 4 * 6;
        float *dx = fal(n);
        ab_loss(&c);
        mf_attnblock_backward(dx, &g, &c.a, c.r, c.x, &c.w, &c.d);
        char what[160];
        snprintf(what, sizeof what, "attnblock(joint=%d) dx", joint);
        gradcheck(what, ab_loss, &c, c.x, dx, n, 60);
        MfTensorSpec specs[MF_ATTNBLOCK_NPARAMS];
        mf_attnblock_specs(specs, "attn", &c.d);
        size_t off = 0;
        for (int i = 0; i < MF_ATTNBLOCK_NPARAMS; ++i) {
            size_t k = mf_tensor_numel(&specs[i]);
            snprintf(what, sizeof what, "attnblock(joint=%d) d%.63s", joint, specs[i].name);
            gradcheck(what, ab_loss, &c, pm + off, gm + off, k, 25);
            off += k;
        }
        free(pm), free(gm), free(am), free(c.x), free(c.out), free(c.r), free(dx);
    }
}

MF_TEST(nn_attnblock_views_interact_only_when_joint) {
    for (int joint = 0; joint <= 1; ++joint) {
        AbCtx c = {.d = {.BV = 2, .C = 4, .H = 2, .W = 2, .G = 2, .NH = 2, .V = 2, .joint = joint, .eps = 1e-5f}};
        float *pm, *gm, *am;
        MfAttnBlockW g;
        ab_setup(&c, &pm, &gm, &am, &g);
        size_t per = (size_t)4 * 4; /* one view: C * HW */
        float *o0 = fal(2 * per);
        ab_loss(&c);
        memcpy(o0, c.out, 2 * per * sizeof(float));
        c.x[per + 3] += 0.5f; /* change view 1 only */
        ab_loss(&c);
        double d0 = 0, d1 = 0;
        for (size_t i = 0; i < per; ++i) d0 = fmax(d0, fabs(c.out[i] - o0[i]));
        for (size_t i = per; i < 2 * per; ++i) d1 = fmax(d1, fabs(c.out[i] - o0[i]));
        CHECK(d1 > 1e-3);
        if (joint)
            CHECK_MSG(d0 > 1e-4, "joint: view 0 does not see view 1 (%g)", d0);
        else
            CHECK_MSG(d0 == 0.0, "per-view: view 0 changed with view 1 (%g)", d0);
        free(pm), free(gm), free(am), free(c.x), free(c.out), free(c.r), free(o0);
    }
}

/* ---- AdamW ------------------------------------------------------------------------------------ */

MF_TEST(nn_adamw_fits_regression) {
    /* y = A x_true + b_true, fit a linear layer by MSE with AdamW (tiny decay) */
    enum { N = 64, IC = 3, OC = 2 };
    float X[N * IC], Y[N * OC], wt[OC * IC] = {0.5f, -1.0f, 2.0f, 1.5f, 0.25f, -0.75f}, bt[OC] = {0.3f, -0.2f};
    fill(X, N * IC, -1, 1, 40);
    mf_linear_forward(Y, X, wt, bt, N, IC, OC);
    float params[OC * IC + OC] = {0}, grads[OC * IC + OC], pred[N * OC], dpred[N * OC];
    MfAdamW opt;
    CHECK_OK(mf_adamw_init(&opt, OC * IC + OC, 0.05f, 0.9f, 0.999f, 1e-8f, 1e-4f));
    float first = 0, loss = 0;
    for (int it = 0; it < 600; ++it) {
        mf_linear_forward(pred, X, params, params + OC * IC, N, IC, OC);
        loss = mf_mse_forward(pred, Y, N * OC);
        if (it == 0) first = loss;
        memset(grads, 0, sizeof grads);
        memset(dpred, 0, sizeof dpred);
        mf_mse_backward(dpred, pred, Y, N * OC, 1.0f);
        mf_linear_backward(NULL, grads, grads + OC * IC, dpred, X, params, N, IC, OC);
        if (it > 400) opt.lr = 0.005f;
        CHECK_OK(mf_adamw_step(&opt, params, grads));
    }
    CHECK_MSG(loss < 1e-4f * first, "loss %g from %g", loss, first);
    for (int i = 0; i < OC * IC; ++i) CHECK_NEAR(params[i], wt[i], 1e-2);
    for (int i = 0; i < OC; ++i) CHECK_NEAR(params[OC * IC + i], bt[i], 1e-2);
    CHECK(opt.t == 600);
    mf_adamw_free(&opt);
}

MF_TEST(nn_adamw_step_formula) {
    /* first step: m_hat = g, v_hat = g^2, so p -= lr * (sign(g) * |g|/(|g|+eps) + wd p) */
    float p[2] = {1.0f, -2.0f}, g[2] = {0.5f, -3.0f};
    MfAdamW opt;
    CHECK_OK(mf_adamw_init(&opt, 2, 0.1f, 0.9f, 0.999f, 1e-8f, 0.01f));
    CHECK_OK(mf_adamw_step(&opt, p, g));
    CHECK_NEAR(p[0], 1.0 - 0.1 * (1.0 + 0.01 * 1.0), 1e-6);
    CHECK_NEAR(p[1], -2.0 - 0.1 * (-1.0 + 0.01 * -2.0), 1e-6);
    /* decoupled decay with zero gradient: p shrinks by lr*wd*p exactly, no moment scaling */
    float q[1] = {3.0f}, z[1] = {0.0f};
    MfAdamW o2;
    CHECK_OK(mf_adamw_init(&o2, 1, 0.1f, 0.9f, 0.999f, 1e-8f, 0.5f));
    CHECK_OK(mf_adamw_step(&o2, q, z));
    CHECK_NEAR(q[0], 3.0 - 0.1 * 0.5 * 3.0, 1e-6);
    /* minimises a quadratic sum_i c_i (p_i - t_i)^2 */
    float x[4] = {0}, t[4] = {1, -2, 3, 0.5f}, cc[4] = {1, 10, 0.1f, 100}, gx[4];
    MfAdamW o3;
    CHECK_OK(mf_adamw_init(&o3, 4, 0.05f, 0.9f, 0.999f, 1e-8f, 0.0f));
    for (int it = 0; it < 2000; ++it) {
        for (int i = 0; i < 4; ++i) gx[i] = 2 * cc[i] * (x[i] - t[i]);
        if (it == 1500) o3.lr = 0.002f;
        CHECK_OK(mf_adamw_step(&o3, x, gx));
    }
    for (int i = 0; i < 4; ++i) CHECK_NEAR(x[i], t[i], 5e-3);
    /* non-finite gradients are refused and change nothing */
    float xs[4], ms[4];
    memcpy(xs, x, sizeof xs);
    memcpy(ms, o3.m, sizeof ms);
    gx[2] = NAN;
    CHECK_ERR(mf_adamw_step(&o3, x, gx), "gradient[2] is nan");
    gx[2] = INFINITY;
    CHECK_ERR(mf_adamw_step(&o3, x, gx), "gradient[2] is inf");
    CHECK(memcmp(xs, x, sizeof xs) == 0 && memcmp(ms, o3.m, sizeof ms) == 0 && o3.t == 2000);
    mf_adamw_free(&opt);
    mf_adamw_free(&o2);
    mf_adamw_free(&o3);
    mf_adamw_free(NULL);
}

MF_TEST(nn_grad_clip_norm) {
    float g[2] = {3.0f, 4.0f};
    CHECK_NEAR(mf_grad_clip_norm(g, 2, 10.0f), 5.0, 1e-6);
    CHECK(g[0] == 3.0f && g[1] == 4.0f);
    CHECK_NEAR(mf_grad_clip_norm(g, 2, 1.0f), 5.0, 1e-6);
    CHECK_NEAR(g[0], 0.6, 1e-6);
    CHECK_NEAR(g[1], 0.8, 1e-6);
}

/* ---- mf bench-nn (CLI smoke test: tiny sizes, checks the report is written; no timing asserts) */

MF_TEST(nn_bench_cli_writes_report) {
    MF_NEED_BIN();
    const char *out = mf_test_path("bench_nn.md");
    char args[4096], err[4096];
    snprintf(args, sizeof args, "bench-nn --batch 1 --channels 4 --size 8 --gemm 32 --reps 1 -o '%s'", out);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    char *md = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(out, &md, &len));
    CHECK(md && strstr(md, "**conv2d / sgemm**") && strstr(md, "B=1 C=4->4 8x8") && strstr(md, "the conv's GEMMs alone"));
    free(md);
    CHECK(mf_test_run_mf("bench-nn --size 0", NULL, err, sizeof err) == 2);
    CHECK_MSG(strstr(err, "--size 0: outside the allowed range"), "bench-nn --size 0: %s", err);
    CHECK(mf_test_run_mf("bench-nn --batch 1 --channels 4 --size 8 --gemm 32 --reps 1 --groups 3", NULL, err, sizeof err) == 2);
    CHECK_MSG(strstr(err, "--groups 3 does not divide --channels 4"), "bench-nn --groups 3: %s", err);
}

/* ---- integration: a tiny network trained with AdamW, saved and reloaded ---------------------- */

MF_TEST(nn_tiny_net_trains_and_reloads) {
    /* net: resblock (2 -> 8 channels) -> 1x1 conv (8 -> 1); target: a fixed 3x3 filter of x */
    enum { B = 4, CI = 2, CH = 8, H = 8, W = 8, HW = H * W };
    MfResBlockDims d = {B, CI, CH, H, W, 0, 2, 1e-5f};
    MfTensorSpec specs[MF_RESBLOCK_NPARAMS + 2];
    int ns = mf_resblock_specs(specs, "res", &d);
    int ow[4] = {1, CH, 1, 1}, ob[1] = {1};
    mf_spec_set(&specs[ns++], "out", "w", 4, ow);
    mf_spec_set(&specs[ns++], "out", "b", 1, ob);
    size_t np = mf_specs_numel(specs, ns), nres = np - CH - 1;
    float *params = fal(np), *grads = fal(np), *acts = fal(mf_resblock_acts_floats(&d));
    MfResBlockW w, g;
    MfResBlockActs a;
    mf_resblock_bind(&w, &d, params);
    mf_resblock_bind(&g, &d, grads);
    mf_resblock_acts_bind(&a, &d, acts);
    mf_resblock_init(&w, &d, 11);
    float *out_w = params + nres, *out_b = out_w + CH, *gout_w = grads + nres, *gout_b = gout_w + CH;
    mf_nn_init_uniform(out_w, CH, 1.0f / sqrtf(CH), 12);
    float *x = fal(B * CI * HW), *y = fal(B * HW), *k = fal(CI * 9), *h = fal(B * CH * HW), *pred = fal(B * HW);
    float *dpred = fal(B * HW), *dh = fal(B * CH * HW), *dx = fal(B * CI * HW);
    float *col = fal(mf_conv2d_col_floats(B, CI, H, W, 1, 3, 1));
    fill(x, B * CI * HW, -1, 1, 80);
    fill(k, CI * 9, -0.5f, 0.5f, 81);
    mf_conv2d_forward(y, col, x, k, NULL, B, CI, H, W, 1, 3, 1);
    MfAdamW opt;
    CHECK_OK(mf_adamw_init(&opt, np, 3e-3f, 0.9f, 0.999f, 1e-8f, 1e-4f));
    float first = 0, loss = 0;
    for (int it = 0; it < 300; ++it) {
        mf_resblock_forward(h, &a, x, NULL, &w, &d);
        mf_conv2d_forward(pred, NULL, h, out_w, out_b, B, CH, H, W, 1, 1, 1);
        loss = mf_mse_forward(pred, y, B * HW);
        if (it == 0) first = loss;
        memset(grads, 0, np * sizeof(float));
        memset(dpred, 0, B * HW * sizeof(float));
        memset(dh, 0, B * CH * HW * sizeof(float));
        memset(dx, 0, B * CI * HW * sizeof(float));
        mf_mse_backward(dpred, pred, y, B * HW, 1.0f);
        mf_conv2d_backward(dh, gout_w, gout_b, NULL, dpred, h, out_w, B, CH, H, W, 1, 1, 1);
        mf_resblock_backward(dx, NULL, &g, &a, dh, x, NULL, &w, &d);
        CHECK_OK(mf_adamw_step(&opt, params, grads));
    }
    if (getenv("NN_GC_VERBOSE")) fprintf(stderr, "  tiny net loss %g -> %g\n", first, loss);
    CHECK_MSG(loss < 0.05f * first, "tiny net: loss %g from %g after 300 AdamW steps", loss, first);
    /* save, reload into a fresh buffer, and get the same predictions bit for bit */
    const char *path = mf_test_path("tiny_net.mfck");
    CHECK_OK(mf_ckpt_save(path, specs, ns, params, "tiny"));
    float *params2 = fal(np), *pred2 = fal(B * HW);
    CHECK_OK(mf_ckpt_load(path, specs, ns, params2, NULL));
    MfResBlockW w2;
    mf_resblock_bind(&w2, &d, params2);
    mf_resblock_forward(h, &a, x, NULL, &w, &d);
    mf_conv2d_forward(pred, NULL, h, out_w, out_b, B, CH, H, W, 1, 1, 1);
    mf_resblock_forward(h, &a, x, NULL, &w2, &d);
    mf_conv2d_forward(pred2, NULL, h, params2 + nres, params2 + nres + CH, B, CH, H, W, 1, 1, 1);
    CHECK(memcmp(pred, pred2, B * HW * sizeof(float)) == 0);
    mf_adamw_free(&opt);
    free(params), free(grads), free(acts), free(x), free(y), free(k), free(h), free(pred), free(dpred);
    free(dh), free(dx), free(col), free(params2), free(pred2);
}
