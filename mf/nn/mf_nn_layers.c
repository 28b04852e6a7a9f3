/* mf_nn_layers: the layers of mf_nn.h (conv2d, upsample, group norm, SiLU, linear, token
 * transposes, attention, timestep embedding, MSE), the conv backend switch and the parameter-table
 * helpers. */
#include <cblas.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "nn/mf_nn.h"
#include "nn/mf_nn_dnnl.h"

/* Every matrix product of this module goes through here, so benchmarks can count FLOPs. */
static unsigned long long g_gemm_flops;
unsigned long long mf_nn_gemm_flops(void) { return g_gemm_flops; }
void mf_nn_set_threads(int n) {
    openblas_set_num_threads(n > 0 ? n : 1);
#ifdef MF_HAVE_DNNL
    mf_nn_dnnl_set_threads(n);
#endif
}
void mf_nn_gemm_flops_reset(void) { g_gemm_flops = 0; }
static void nn_sgemm(enum CBLAS_ORDER o, enum CBLAS_TRANSPOSE ta, enum CBLAS_TRANSPOSE tb, int M, int N, int K,
                     float alpha, const float *A, int lda, const float *B, int ldb, float beta, float *C, int ldc) {
    g_gemm_flops += 2ull * (unsigned long long)M * (unsigned long long)N * (unsigned long long)K;
    cblas_sgemm(o, ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
}

/* ---- parameter tables ---------------------------------------------------------------- */

void mf_params_bind(float **slots, const MfTensorSpec *specs, int n, float *mem) {
    for (int i = 0; i < n; ++i) {
        slots[i] = mem;
        mem += mf_tensor_numel(&specs[i]);
    }
}

void mf_nn_init_uniform(float *w, size_t n, float bound, unsigned long long seed) {
    MfRng r;
    mf_rng_seed(&r, seed, 0x6e6eu);
    for (size_t i = 0; i < n; ++i) w[i] = (2.0f * mf_rng_float(&r) - 1.0f) * bound;
}

/* ---- conv2d ------------------------------------------------------------------------------ */

int mf_conv2d_out_size(int H, int K, int stride) { return (H + 2 * (K / 2) - K) / stride + 1; }

/* Batch items per GEMM: small images are grouped so the GEMM has N = nb*Ho*Wo >= ~1024 columns. */
static int conv_chunk(int B, int P) {
    int nb = P >= 1024 ? 1 : (1024 + P - 1) / P;
    return nb < B ? nb : B;
}

size_t mf_conv2d_col_floats(int B, int Cin, int H, int W, int Cout, int K, int stride) {
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride);
    size_t P = (size_t)Ho * Wo, CKK = (size_t)Cin * K * K;
    int nb = conv_chunk(B, (int)P);
    if (nb == 1) return (K == 1 && stride == 1) ? 0 : CKK * P;
    return (CKK + (size_t)Cout) * nb * P;
}

/* Output columns ox whose input column ox*stride - pad + kj lies inside [0, W): [*lo, *hi). */
static void valid_cols(int W, int Wo, int pad, int kj, int stride, int *lo, int *hi) {
    int a = pad - kj, l = a > 0 ? (a + stride - 1) / stride : 0;
    int h = (W + pad - kj + stride - 1) / stride;
    *lo = l < Wo ? l : Wo;
    *hi = h < Wo ? h : Wo;
    if (*hi < *lo) *hi = *lo;
}

/* Stride 1 with odd K (Ho = H, Wo = W): tap (ki, kj) reads the input plane shifted by
 * sh = (ki - pad)*W + (kj - pad), so its col row is ONE contiguous copy of the plane (and col2im
 * one contiguous add) over the output rows [y0, y1) whose input row exists, clipped to
 * q + sh in [0, H*W) as [q0, q1); output columns outside [x0, x1) wrap to the neighbouring row and
 * are fixed up (zeroed) separately. Elements of [y0*W, y1*W) outside [q0, q1) are such columns. */
typedef struct {
    int y0, y1, x0, x1, q0, q1, sh;
} ConvTap;

#define CONV_TAPS_MAX 49 /* the stride-1 paths take K <= 7 */

static void conv_taps_s1(ConvTap *t, int H, int W, int K) {
    int pad = K / 2, HW = H * W;
    for (int ki = 0; ki < K; ++ki)
        for (int kj = 0; kj < K; ++kj, ++t) {
            int dy = ki - pad, dx = kj - pad;
            t->y0 = dy < 0 ? (-dy < H ? -dy : H) : 0;
            t->y1 = dy > 0 ? H - dy : H;
            if (t->y1 < t->y0) t->y1 = t->y0;
            t->x0 = dx < 0 ? (-dx < W ? -dx : W) : 0;
            t->x1 = dx > 0 ? W - dx : W;
            if (t->x1 < t->x0) t->x1 = t->x0;
            t->sh = dy * W + dx;
            t->q0 = t->y0 * W, t->q1 = t->y1 * W;
            if (t->q0 + t->sh < 0) t->q0 = -t->sh;
            if (t->q1 + t->sh > HW) t->q1 = HW - t->sh;
            if (t->q1 < t->q0) t->q1 = t->q0;
        }
}

static int conv_s1_fast(int K, int stride, int H, int W, int Ho, int Wo) {
    return stride == 1 && K <= 7 && Ho == H && Wo == W;
}

/* Zeroes, in rows [y0, y1) of the plane d (H, W), the columns outside [x0, x1) (column by column:
 * a 3x3 tap has at most one, and a loop along a row of one element would become a memset call). */
static inline void zero_edge_cols(float *d, int W, const ConvTap *t) {
    for (int x = 0; x < t->x0; ++x)
        for (int y = t->y0; y < t->y1; ++y) d[(size_t)y * W + x] = 0.0f;
    for (int x = t->x1; x < W; ++x)
        for (int y = t->y0; y < t->y1; ++y) d[(size_t)y * W + x] = 0.0f;
}

/* col (Cin*K*K, Ho*Wo; row stride ld) from in (Cin, H, W). */
static void im2col(float *restrict col, size_t ld, const float *restrict in, int Cin, int H, int W, int K,
                   int stride, int Ho, int Wo) {
    int pad = K / 2;
    if (conv_s1_fast(K, stride, H, W, Ho, Wo)) {
        ConvTap taps[CONV_TAPS_MAX];
        conv_taps_s1(taps, H, W, K);
        int HW = H * W, KK = K * K;
        for (int c = 0; c < Cin; ++c) {
            const float *restrict src = in + (size_t)c * HW;
            for (int k = 0; k < KK; ++k) {
                const ConvTap *t = &taps[k];
                float *restrict d = col + ((size_t)c * KK + k) * ld;
                int sh = t->sh;
                for (int q = 0; q < t->y0 * W; ++q) d[q] = 0.0f;
#pragma omp simd
                for (int q = t->q0; q < t->q1; ++q) d[q] = src[q + sh];
                for (int q = t->y1 * W; q < HW; ++q) d[q] = 0.0f;
                zero_edge_cols(d, W, t);
            }
        }
        return;
    }
    for (int r = 0; r < Cin * K * K; ++r) {
        int c = r / (K * K), ki = (r / K) % K, kj = r % K, lo, hi;
        valid_cols(W, Wo, pad, kj, stride, &lo, &hi);
        const float *src = in + (size_t)c * H * W;
        float *dst = col + (size_t)r * ld;
        for (int oy = 0; oy < Ho; ++oy) {
            int iy = oy * stride - pad + ki;
            float *d = dst + (size_t)oy * Wo;
            if (iy < 0 || iy >= H) {
                memset(d, 0, sizeof(float) * (size_t)Wo);
                continue;
            }
            const float *s = src + (size_t)iy * W - pad + kj; /* s[ox*stride] is column ox's input */
            for (int ox = 0; ox < lo; ++ox) d[ox] = 0.0f;
            if (stride == 1)
                memcpy(d + lo, s + lo, sizeof(float) * (size_t)(hi - lo));
            else
                for (int ox = lo; ox < hi; ++ox) d[ox] = s[ox * stride];
            for (int ox = hi; ox < Wo; ++ox) d[ox] = 0.0f;
        }
    }
}

/* din (Cin, H, W) += col2im(col (Cin*K*K, Ho*Wo; row stride ld)), or = when acc is 0. Each input
 * element receives its taps in (ki, kj) order. col is scratch: the stride-1 path zeroes its
 * wrapping edge columns. */
static void col2im(float *restrict din, int acc, float *restrict col, size_t ld, int Cin, int H, int W, int K,
                   int stride, int Ho, int Wo) {
    int pad = K / 2;
    if (!acc) memset(din, 0, sizeof(float) * (size_t)Cin * H * W);
    if (conv_s1_fast(K, stride, H, W, Ho, Wo)) {
        ConvTap taps[CONV_TAPS_MAX];
        conv_taps_s1(taps, H, W, K);
        int HW = H * W, KK = K * K;
        for (int c = 0; c < Cin; ++c) {
            float *restrict dst = din + (size_t)c * HW;
            for (int k = 0; k < KK; ++k) {
                const ConvTap *t = &taps[k];
                float *restrict s = col + ((size_t)c * KK + k) * ld;
                int sh = t->sh;
                zero_edge_cols(s, W, t); /* they add +0 to the wrapped neighbours */
#pragma omp simd
                for (int q = t->q0; q < t->q1; ++q) dst[q + sh] += s[q];
            }
        }
        return;
    }
    for (int c = 0; c < Cin; ++c) {
        float *dst = din + (size_t)c * H * W;
        for (int ki = 0; ki < K; ++ki)
            for (int kj = 0; kj < K; ++kj) {
                int lo, hi;
                valid_cols(W, Wo, pad, kj, stride, &lo, &hi);
                const float *src = col + ((size_t)(c * K + ki) * K + kj) * ld;
                for (int oy = 0; oy < Ho; ++oy) {
                    int iy = oy * stride - pad + ki;
                    if (iy < 0 || iy >= H) continue;
                    float *d = dst + (size_t)iy * W - pad + kj;
                    const float *s = src + (size_t)oy * Wo;
                    if (stride == 1)
                        for (int ox = lo; ox < hi; ++ox) d[ox] += s[ox];
                    else
                        for (int ox = lo; ox < hi; ++ox) d[ox * stride] += s[ox];
                }
            }
    }
}

/* out_b (Cout, P) = g (Cout, P; row stride ldg) + bias[o] + bias_b[o] (+ add_b (Cout, P)), added in
 * that order; NULL terms are skipped (as +0). out_b may be g (ldg = P). */
static void conv_out_rows(float *out_b, const float *g, size_t ldg, const float *bias, const float *bias_b,
                          const float *add_b, int Cout, int P) {
    for (int o = 0; o < Cout; ++o) {
        float bo = bias ? bias[o] : 0.0f, bb = bias_b ? bias_b[o] : 0.0f;
        const float *gr = g + (size_t)o * ldg;
        float *orow = out_b + (size_t)o * P;
        if (add_b) {
            const float *ar = add_b + (size_t)o * P;
#pragma omp simd
            for (int p = 0; p < P; ++p) orow[p] = gr[p] + bo + bb + ar[p];
        } else {
#pragma omp simd
            for (int p = 0; p < P; ++p) orow[p] = gr[p] + bo + bb;
        }
    }
}

/* ---- conv backend (mf_nn.h) ----------------------------------------------------------------- */

#ifdef MF_HAVE_DNNL
static MfNnBackend g_backend = MF_NN_DNNL;
#else
static MfNnBackend g_backend = MF_NN_BLAS;
#endif

MfNnBackend mf_nn_backend(void) { return g_backend; }
const char *mf_nn_backend_name(MfNnBackend b) { return b == MF_NN_DNNL ? "dnnl" : "blas"; }

int mf_nn_set_backend(MfNnBackend b) {
    if (b != MF_NN_BLAS && b != MF_NN_DNNL) return mf_fail(MF_EARG, "nn backend %d: expected blas or dnnl", (int)b);
#ifndef MF_HAVE_DNNL
    if (b == MF_NN_DNNL) return mf_fail(MF_EARG, "nn backend dnnl: this build has no oneDNN (build with make DNNL=1)");
#endif
    g_backend = b;
    return MF_OK;
}

int mf_nn_backend_from_env(void) {
    const char *v = getenv("MF_NN_BACKEND");
    if (!v || !v[0]) return MF_OK;
    int b = !strcmp(v, "blas") ? MF_NN_BLAS : !strcmp(v, "dnnl") ? MF_NN_DNNL : -1;
    if (b < 0) return mf_fail(MF_EARG, "MF_NN_BACKEND=%s: expected blas or dnnl", v);
    int rc = mf_nn_set_backend((MfNnBackend)b);
    return rc ? mf_fail_prefix(rc, "MF_NN_BACKEND=%s", v) : MF_OK;
}

#ifdef MF_HAVE_DNNL
/* oneDNN failed (mf_error says how): this call's remaining work and every later conv run on OpenBLAS. */
static void dnnl_off(void) {
    mf_log_warn("conv2d: oneDNN failed (%s); the convolutions use OpenBLAS from now on", mf_error());
    g_backend = MF_NN_BLAS;
}

/* The GEMM FLOPs one pass (forward, backward data or weights) of the im2col path would count. */
static void dnnl_count(int B, int Cin, int Cout, int K, int P) {
    g_gemm_flops += 2ull * (unsigned long long)B * (unsigned long long)Cout * (unsigned long long)P *
                    (unsigned long long)Cin * (unsigned long long)(K * K);
}

/* mf_conv2d_forward_ex through oneDNN (bias fused there when there is no other term); MF_OK or
 * the error (out then holds no result). */
static int conv_forward_dnnl(float *out, const float *in, const float *w, const float *bias, const float *bias_b,
                             const float *add, int B, int Cin, int H, int W, int Cout, int K, int stride) {
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride), P = Ho * Wo;
    int extra = bias_b || add;
    int rc = mf_nn_dnnl_conv_forward(out, in, w, extra ? NULL : bias, B, Cin, H, W, Cout, K, stride);
    if (rc) return rc;
    dnnl_count(B, Cin, Cout, K, P);
    size_t out_sz = (size_t)Cout * P;
    if (extra)
        for (int b = 0; b < B; ++b)
            conv_out_rows(out + b * out_sz, out + b * out_sz, (size_t)P, bias, bias_b ? bias_b + (size_t)b * Cout : NULL,
                          add ? add + b * out_sz : NULL, Cout, P);
    return MF_OK;
}
#endif

void mf_conv2d_forward(float *out, float *col, const float *in, const float *w, const float *bias,
                       int B, int Cin, int H, int W, int Cout, int K, int stride) {
    mf_conv2d_forward_ex(out, col, in, w, bias, NULL, NULL, B, Cin, H, W, Cout, K, stride);
}

void mf_conv2d_forward_ex(float *out, float *col, const float *in, const float *w, const float *bias,
                          const float *bias_b, const float *add, int B, int Cin, int H, int W, int Cout, int K,
                          int stride) {
#ifdef MF_HAVE_DNNL
    if (g_backend == MF_NN_DNNL) {
        if (conv_forward_dnnl(out, in, w, bias, bias_b, add, B, Cin, H, W, Cout, K, stride) == MF_OK) return;
        dnnl_off();
    }
#endif
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride);
    int P = Ho * Wo, CKK = Cin * K * K, nb = conv_chunk(B, P);
    size_t in_sz = (size_t)Cin * H * W, out_sz = (size_t)Cout * P;
    if (!col && K == 1 && stride == 1) nb = 1; /* no scratch given: per-item direct GEMMs */
    if (nb == 1) {
        int direct = (K == 1 && stride == 1);
        for (int b = 0; b < B; ++b) {
            const float *in_b = in + b * in_sz, *colp = in_b;
            float *out_b = out + b * out_sz;
            if (!direct) {
                im2col(col, (size_t)P, in_b, Cin, H, W, K, stride, Ho, Wo);
                colp = col;
            }
            /* out_b (Cout, P) = w (Cout, CKK) . col (CKK, P), then the bias terms in place */
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, Cout, P, CKK, 1.0f, w, CKK, colp, P,
                        0.0f, out_b, P);
            if (bias || bias_b || add)
                conv_out_rows(out_b, out_b, (size_t)P, bias, bias_b ? bias_b + (size_t)b * Cout : NULL,
                              add ? add + b * out_sz : NULL, Cout, P);
        }
        return;
    }
    /* grouped: col (CKK, n*P) holds n items side by side; tmp (Cout, n*P) is the GEMM result, copied
     * to out with the bias terms in the same pass */
    float *tmp = col + (size_t)CKK * nb * P;
    for (int b0 = 0; b0 < B; b0 += nb) {
        int n = B - b0 < nb ? B - b0 : nb, NP = n * P;
        for (int i = 0; i < n; ++i)
            im2col(col + (size_t)i * P, (size_t)NP, in + (b0 + i) * in_sz, Cin, H, W, K, stride, Ho, Wo);
        nn_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, Cout, NP, CKK, 1.0f, w, CKK, col, NP, 0.0f,
                    tmp, NP);
        for (int i = 0; i < n; ++i) {
            int b = b0 + i;
            conv_out_rows(out + b * out_sz, tmp + (size_t)i * P, (size_t)NP, bias,
                          bias_b ? bias_b + (size_t)b * Cout : NULL, add ? add + b * out_sz : NULL, Cout, P);
        }
    }
}

/* Row sums of g (Cout, P) (four interleaved partial sums): dbias[o] += and dbias_b[o] += (either
 * NULL); when t is given, also copies g into t (Cout, P; row stride ldt). */
static void conv_dout_rows(float *t, size_t ldt, float *dbias, float *dbias_b, const float *g, int Cout, int P) {
    for (int o = 0; o < Cout; ++o) {
        const float *row = g + (size_t)o * P;
        if (t) memcpy(t + (size_t)o * ldt, row, sizeof(float) * (size_t)P);
        if (!dbias && !dbias_b) continue;
        float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
        int p = 0;
        for (; p + 4 <= P; p += 4) s0 += row[p], s1 += row[p + 1], s2 += row[p + 2], s3 += row[p + 3];
        for (; p < P; ++p) s0 += row[p];
        float s = (s0 + s1) + (s2 + s3);
        if (dbias) dbias[o] += s;
        if (dbias_b) dbias_b[o] += s;
    }
}

#ifdef MF_HAVE_DNNL
/* mf_conv2d_backward_ex through oneDNN; a part oneDNN fails runs on the im2col path instead (each
 * part writes only its own gradient, so none is counted twice). The bias sums are the same code. */
static void conv_backward_dnnl(float *din, int din_acc, float *dw, float *dbias, float *dbias_b, float *col,
                               const float *dout, const float *in, const float *w, int B, int Cin, int H, int W,
                               int Cout, int K, int stride) {
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride), P = Ho * Wo;
    if (dw) {
        if (mf_nn_dnnl_conv_backward_weights(dw, dout, in, B, Cin, H, W, Cout, K, stride) == MF_OK)
            dnnl_count(B, Cin, Cout, K, P);
        else {
            dnnl_off();
            mf_conv2d_backward_ex(NULL, 1, dw, NULL, NULL, col, dout, in, w, B, Cin, H, W, Cout, K, stride);
        }
    }
    if (din) {
        if (g_backend == MF_NN_DNNL &&
            mf_nn_dnnl_conv_backward_data(din, din_acc, dout, w, B, Cin, H, W, Cout, K, stride) == MF_OK)
            dnnl_count(B, Cin, Cout, K, P);
        else {
            if (g_backend == MF_NN_DNNL) dnnl_off();
            mf_conv2d_backward_ex(din, din_acc, NULL, NULL, NULL, col, dout, in, w, B, Cin, H, W, Cout, K, stride);
        }
    }
    size_t out_sz = (size_t)Cout * P;
    if (dbias || dbias_b)
        for (int b = 0; b < B; ++b)
            conv_dout_rows(NULL, 0, dbias, dbias_b ? dbias_b + (size_t)b * Cout : NULL, dout + b * out_sz, Cout, P);
}
#endif

void mf_conv2d_backward(float *din, float *dw, float *dbias, float *col, const float *dout,
                        const float *in, const float *w, int B, int Cin, int H, int W, int Cout, int K,
                        int stride) {
    mf_conv2d_backward_ex(din, 1, dw, dbias, NULL, col, dout, in, w, B, Cin, H, W, Cout, K, stride);
}

void mf_conv2d_backward_ex(float *din, int din_acc, float *dw, float *dbias, float *dbias_b, float *col,
                           const float *dout, const float *in, const float *w, int B, int Cin, int H, int W,
                           int Cout, int K, int stride) {
#ifdef MF_HAVE_DNNL
    if (g_backend == MF_NN_DNNL) {
        conv_backward_dnnl(din, din_acc, dw, dbias, dbias_b, col, dout, in, w, B, Cin, H, W, Cout, K, stride);
        return;
    }
#endif
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride);
    int P = Ho * Wo, CKK = Cin * K * K, nb = conv_chunk(B, P);
    size_t in_sz = (size_t)Cin * H * W, out_sz = (size_t)Cout * P;
    if (!col && K == 1 && stride == 1) nb = 1; /* no scratch given: per-item direct GEMMs */
    if (nb == 1) {
        int direct = (K == 1 && stride == 1);
        for (int b = 0; b < B; ++b) {
            const float *in_b = in + b * in_sz, *dout_b = dout + b * out_sz, *colp = in_b;
            if (dw && !direct) {
                im2col(col, (size_t)P, in_b, Cin, H, W, K, stride, Ho, Wo);
                colp = col;
            }
            /* dw (Cout, CKK) += dout_b (Cout, P) . col^T (P, CKK) */
            if (dw)
                nn_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, Cout, CKK, P, 1.0f, dout_b, P, colp, P,
                         1.0f, dw, CKK);
            conv_dout_rows(NULL, 0, dbias, dbias_b ? dbias_b + (size_t)b * Cout : NULL, dout_b, Cout, P);
            if (!din) continue;
            float *din_b = din + b * in_sz;
            if (direct) {
                /* din_b (Cin, P) (+)= w^T (Cin, Cout) . dout_b (Cout, P) */
                nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, Cin, P, Cout, 1.0f, w, Cin, dout_b, P,
                            din_acc ? 1.0f : 0.0f, din_b, P);
            } else {
                /* dcol (CKK, P) = w^T (CKK, Cout) . dout_b (Cout, P), then scatter-add */
                nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, CKK, P, Cout, 1.0f, w, CKK, dout_b, P,
                            0.0f, col, P);
                col2im(din_b, din_acc, col, (size_t)P, Cin, H, W, K, stride, Ho, Wo);
            }
        }
        return;
    }
    float *tmp = col + (size_t)CKK * nb * P; /* dout of the group as (Cout, n*P) */
    for (int b0 = 0; b0 < B; b0 += nb) {
        int n = B - b0 < nb ? B - b0 : nb, NP = n * P;
        for (int i = 0; i < n; ++i) {
            int b = b0 + i;
            if (dw) im2col(col + (size_t)i * P, (size_t)NP, in + b * in_sz, Cin, H, W, K, stride, Ho, Wo);
            conv_dout_rows(tmp + (size_t)i * P, (size_t)NP, dbias, dbias_b ? dbias_b + (size_t)b * Cout : NULL,
                           dout + b * out_sz, Cout, P);
        }
        if (dw)
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, Cout, CKK, NP, 1.0f, tmp, NP, col, NP, 1.0f, dw,
                     CKK);
        if (!din) continue;
        nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, CKK, NP, Cout, 1.0f, w, CKK, tmp, NP, 0.0f, col,
                    NP);
        for (int i = 0; i < n; ++i)
            col2im(din + (b0 + i) * in_sz, din_acc, col + (size_t)i * P, (size_t)NP, Cin, H, W, K, stride, Ho, Wo);
    }
}

/* ---- upsample ------------------------------------------------------------------------------ */

void mf_upsample2x_forward(float *out, const float *in, int B, int C, int H, int W) {
    int W2 = 2 * W;
    for (int bc = 0; bc < B * C; ++bc) {
        const float *s = in + (size_t)bc * H * W;
        float *d = out + (size_t)bc * 4 * H * W;
        for (int y = 0; y < H; ++y) {
            float *r0 = d + (size_t)(2 * y) * W2, *r1 = r0 + W2;
            for (int x = 0; x < W; ++x) {
                float v = s[(size_t)y * W + x];
                r0[2 * x] = r0[2 * x + 1] = r1[2 * x] = r1[2 * x + 1] = v;
            }
        }
    }
}

void mf_upsample2x_backward(float *din, const float *dout, int B, int C, int H, int W) {
    int W2 = 2 * W;
    for (int bc = 0; bc < B * C; ++bc) {
        float *d = din + (size_t)bc * H * W;
        const float *s = dout + (size_t)bc * 4 * H * W;
        for (int y = 0; y < H; ++y) {
            const float *r0 = s + (size_t)(2 * y) * W2, *r1 = r0 + W2;
            for (int x = 0; x < W; ++x)
                d[(size_t)y * W + x] += (r0[2 * x] + r0[2 * x + 1]) + (r1[2 * x] + r1[2 * x + 1]);
        }
    }
}

/* ---- group norm ------------------------------------------------------------------------------ */

/* Sum of x (n floats) in double, four interleaved partial sums (a latency chain a quarter as long). */
static double sum_d(const float *x, size_t n) {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    size_t i = 0;
    for (; i + 4 <= n; i += 4) s0 += x[i], s1 += x[i + 1], s2 += x[i + 2], s3 += x[i + 3];
    for (; i < n; ++i) s0 += x[i];
    return (s0 + s1) + (s2 + s3);
}

/* Mean and 1/sqrt(var + eps) (population variance) of a group x (n floats), two passes in double. */
static void gn_stats(const float *x, size_t n, float eps, float *mean, float *rstd) {
    double mu = sum_d(x, n) / (double)n, v0 = 0.0, v1 = 0.0, v2 = 0.0, v3 = 0.0;
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
        double d0 = x[i] - mu, d1 = x[i + 1] - mu, d2 = x[i + 2] - mu, d3 = x[i + 3] - mu;
        v0 += d0 * d0, v1 += d1 * d1, v2 += d2 * d2, v3 += d3 * d3;
    }
    for (; i < n; ++i) v0 += (x[i] - mu) * (x[i] - mu);
    double v = (v0 + v1) + (v2 + v3);
    *mean = (float)mu;
    *rstd = (float)(1.0 / sqrt(v / (double)n + eps));
}

void mf_groupnorm_forward(float *out, float *mean, float *rstd, const float *in, const float *gamma,
                          const float *beta, int B, int C, int HW, int G, float eps) {
    int cpg = C / G;
    size_t n = (size_t)cpg * HW;
    for (int bg = 0; bg < B * G; ++bg) {
        int b = bg / G, g = bg % G;
        size_t off = ((size_t)b * C + (size_t)g * cpg) * HW;
        const float *x = in + off;
        float m, rs;
        gn_stats(x, n, eps, &m, &rs);
        mean[bg] = m;
        rstd[bg] = rs;
        for (int cc = 0; cc < cpg; ++cc) {
            int c = g * cpg + cc;
            float ga = gamma[c] * rs, be = beta[c];
            const float *xc = x + (size_t)cc * HW;
            float *o = out + off + (size_t)cc * HW;
#pragma omp simd
            for (int p = 0; p < HW; ++p) o[p] = (xc[p] - m) * ga + be;
        }
    }
}

/* The double sums of the group norm backward over one channel row: *dgs += sum dy*xh, *dbs += sum dy,
 * with xh = (x - m)*rs (four interleaved partial sums each). */
static void gn_row_sums(const float *x, const float *dy, int HW, float m, float rs, double *dgs, double *dbs) {
    double g0 = 0.0, g1 = 0.0, g2 = 0.0, g3 = 0.0, b0 = 0.0, b1 = 0.0, b2 = 0.0, b3 = 0.0;
    int p = 0;
    for (; p + 4 <= HW; p += 4) {
        float h0 = (x[p] - m) * rs, h1 = (x[p + 1] - m) * rs, h2 = (x[p + 2] - m) * rs, h3 = (x[p + 3] - m) * rs;
        g0 += (double)dy[p] * h0, g1 += (double)dy[p + 1] * h1, g2 += (double)dy[p + 2] * h2, g3 += (double)dy[p + 3] * h3;
        b0 += dy[p], b1 += dy[p + 1], b2 += dy[p + 2], b3 += dy[p + 3];
    }
    for (; p < HW; ++p) g0 += (double)dy[p] * ((x[p] - m) * rs), b0 += dy[p];
    *dgs += (g0 + g1) + (g2 + g3);
    *dbs += (b0 + b1) + (b2 + b3);
}

/* One group of the group norm backward: dgamma/dbeta of its channels and the two means m1, m2 of
 * the input gradient dx = rs * (dy*gamma - m1 - xh*m2). */
static void gn_group_sums(const float *x, const float *dy, int cpg, int HW, int c0, float m, float rs,
                          const float *gamma, float *dgamma, float *dbeta, float *m1, float *m2) {
    double s1 = 0.0, s2 = 0.0;
    for (int cc = 0; cc < cpg; ++cc) {
        int c = c0 + cc;
        double dgs = 0.0, dbs = 0.0;
        gn_row_sums(x + (size_t)cc * HW, dy + (size_t)cc * HW, HW, m, rs, &dgs, &dbs);
        if (dgamma) dgamma[c] += (float)dgs, dbeta[c] += (float)dbs;
        s1 += dbs * gamma[c];
        s2 += dgs * gamma[c];
    }
    double n = (double)cpg * HW;
    *m1 = (float)(s1 / n), *m2 = (float)(s2 / n);
}

void mf_groupnorm_backward(float *din, float *dgamma, float *dbeta, const float *dout,
                           const float *in, const float *mean, const float *rstd,
                           const float *gamma, int B, int C, int HW, int G) {
    int cpg = C / G;
    /* each group owns its channels of dgamma/dbeta; batch items in order */
    for (int b = 0; b < B; ++b)
        for (int g = 0; g < G; ++g) {
            int bg = b * G + g;
            size_t off = ((size_t)b * C + (size_t)g * cpg) * HW;
            const float *x = in + off, *dy = dout + off;
            float m = mean[bg], rs = rstd[bg], m1, m2;
            gn_group_sums(x, dy, cpg, HW, g * cpg, m, rs, gamma, dgamma, dbeta, &m1, &m2);
            if (!din) continue;
            float *dx = din + off;
            for (int cc = 0; cc < cpg; ++cc) {
                float ga = gamma[g * cpg + cc];
                const float *xc = x + (size_t)cc * HW, *dyc = dy + (size_t)cc * HW;
                float *dxc = dx + (size_t)cc * HW;
#pragma omp simd
                for (int p = 0; p < HW; ++p) {
                    float xh = (xc[p] - m) * rs;
                    dxc[p] += rs * (dyc[p] * ga - m1 - xh * m2);
                }
            }
        }
}

/* ---- SiLU ------------------------------------------------------------------------------------ */

/* e^x for the SiLU family, within about 2 ulp of expf for |x| <= 80: Cody-Waite reduction to r in
 * [-ln2/2, ln2/2], a degree-7 Taylor polynomial (truncation below 1e-8 relative), 2^n set through
 * the exponent bits. |x| > 80 (and NaN) gives +inf for positive x and 0 for negative x (expf gives
 * inf above 88.7 and subnormals below -87: sigmoid and SiLU differ by < 1e-34 there; a NaN input
 * still makes SiLU and its gradient NaN through their other factor x). Integer selects only, no
 * float compare and no libm call, so the loops that use it vectorise (gcc -O2 leaves a loop with a
 * float select scalar: the compare may trap). */
static inline float nn_expf(float x) {
    int32_t b, sign, big;
    memcpy(&b, &x, sizeof b);
    sign = b & (int32_t)0x80000000u;
    b &= 0x7fffffff;
    big = -(b > 0x42A00000); /* all ones where |x| > 80.0f, or NaN */
    b = (b & ~big) | (0x42A00000 & big);
    b |= sign;
    memcpy(&x, &b, sizeof x);
    float t = x * 1.44269504088896341f + 12582912.0f; /* 1.5*2^23: t's low bits hold round(x/ln2) */
    float n = t - 12582912.0f;
    float r = (x - n * 0.693359375f) - n * -2.12194440e-4f; /* ln2 split in two: n*hi is exact */
    float p = 1.0f / 5040.0f;
    p = p * r + 1.0f / 720.0f;
    p = p * r + 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r + 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r + 1.0f;
    p = p * r + 1.0f;
    int32_t ti, e;
    memcpy(&ti, &t, sizeof ti);
    e = (ti - 0x4B400000 + 127) * (1 << 23); /* n + 127 in the exponent field */
    float sc, y;
    memcpy(&sc, &e, sizeof sc);
    y = p * sc;
    memcpy(&e, &y, sizeof e);
    e = (e & ~big) | (~-(sign != 0) & 0x7F800000 & big); /* 0 (x < 0) or +inf */
    memcpy(&y, &e, sizeof y);
    return y;
}

void mf_silu_forward(float *out, const float *in, size_t n) {
#pragma omp simd
    for (size_t i = 0; i < n; ++i) {
        float x = in[i];
        out[i] = x / (1.0f + nn_expf(-x));
    }
}

void mf_silu_backward(float *din, const float *dout, const float *in, size_t n) {
#pragma omp simd
    for (size_t i = 0; i < n; ++i) {
        float x = in[i], s = 1.0f / (1.0f + nn_expf(-x));
        din[i] += dout[i] * s * (1.0f + x * (1.0f - s));
    }
}

/* ---- group norm + SiLU ------------------------------------------------------------------------- */

void mf_gnsilu_forward(float *out, float *sig, float *mean, float *rstd, const float *in, const float *gamma,
                       const float *beta, int B, int C, int HW, int G, float eps) {
    int cpg = C / G;
    size_t n = (size_t)cpg * HW;
    for (int bg = 0; bg < B * G; ++bg) {
        int b = bg / G, g = bg % G;
        size_t off = ((size_t)b * C + (size_t)g * cpg) * HW;
        const float *x = in + off;
        float m, rs;
        gn_stats(x, n, eps, &m, &rs);
        mean[bg] = m;
        rstd[bg] = rs;
        for (int cc = 0; cc < cpg; ++cc) {
            int c = g * cpg + cc;
            float ga = gamma[c] * rs, be = beta[c];
            const float *xc = x + (size_t)cc * HW;
            float *o = out + off + (size_t)cc * HW, *sg = sig + off + (size_t)cc * HW;
#pragma omp simd
            for (int p = 0; p < HW; ++p) {
                float h = (xc[p] - m) * ga + be, d = 1.0f + nn_expf(-h);
                o[p] = h / d;
                sg[p] = 1.0f / d;
            }
        }
    }
}

/* dh (n) = da * silu'(h) for one channel row, h = (x - m)*ga + be recomputed as the forward did and
 * s = sigmoid(h) as the forward stored it. */
static void gnsilu_dh(float *restrict dh, const float *restrict da, const float *restrict x,
                      const float *restrict s, int n, float m, float ga, float be) {
#pragma omp simd
    for (int p = 0; p < n; ++p) {
        float h = (x[p] - m) * ga + be, sv = s[p];
        dh[p] = da[p] * sv * (1.0f + h * (1.0f - sv));
    }
}

#define GNSILU_CHUNK 512 /* floats of dh held on the stack at a time */

void mf_gnsilu_backward(float *din, int din_acc, float *dgamma, float *dbeta, const float *da, const float *in,
                        const float *sig, const float *mean, const float *rstd, const float *gamma,
                        const float *beta, int B, int C, int HW, int G) {
    int cpg = C / G;
    float dh[GNSILU_CHUNK];
    for (int b = 0; b < B; ++b)
        for (int g = 0; g < G; ++g) {
            int bg = b * G + g;
            size_t off = ((size_t)b * C + (size_t)g * cpg) * HW;
            float m = mean[bg], rs = rstd[bg];
            double s1 = 0.0, s2 = 0.0;
            for (int cc = 0; cc < cpg; ++cc) {
                int c = g * cpg + cc;
                size_t o = off + (size_t)cc * HW;
                double dgs = 0.0, dbs = 0.0;
                for (int p0 = 0; p0 < HW; p0 += GNSILU_CHUNK) {
                    int k = HW - p0 < GNSILU_CHUNK ? HW - p0 : GNSILU_CHUNK;
                    gnsilu_dh(dh, da + o + p0, in + o + p0, sig + o + p0, k, m, gamma[c] * rs, beta[c]);
                    gn_row_sums(in + o + p0, dh, k, m, rs, &dgs, &dbs);
                }
                if (dgamma) dgamma[c] += (float)dgs, dbeta[c] += (float)dbs;
                s1 += dbs * gamma[c];
                s2 += dgs * gamma[c];
            }
            if (!din) continue;
            float m1 = (float)(s1 / ((double)cpg * HW)), m2 = (float)(s2 / ((double)cpg * HW));
            for (int cc = 0; cc < cpg; ++cc) {
                int c = g * cpg + cc;
                size_t o = off + (size_t)cc * HW;
                float ga = gamma[c];
                for (int p0 = 0; p0 < HW; p0 += GNSILU_CHUNK) {
                    int k = HW - p0 < GNSILU_CHUNK ? HW - p0 : GNSILU_CHUNK;
                    const float *xc = in + o + p0;
                    float *dxc = din + o + p0;
                    gnsilu_dh(dh, da + o + p0, xc, sig + o + p0, k, m, gamma[c] * rs, beta[c]);
                    if (din_acc) {
#pragma omp simd
                        for (int p = 0; p < k; ++p) dxc[p] += rs * (dh[p] * ga - m1 - (xc[p] - m) * rs * m2);
                    } else {
#pragma omp simd
                        for (int p = 0; p < k; ++p) dxc[p] = rs * (dh[p] * ga - m1 - (xc[p] - m) * rs * m2);
                    }
                }
            }
        }
}

/* ---- GELU ------------------------------------------------------------------------------------ */

#define GELU_K 0.7978845608028654f /* sqrt(2/pi) */

void mf_gelu_forward(float *out, const float *in, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        float x = in[i];
        out[i] = 0.5f * x * (1.0f + tanhf(GELU_K * (x + 0.044715f * x * x * x)));
    }
}

void mf_gelu_backward(float *din, const float *dout, const float *in, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        float x = in[i], u = GELU_K * (x + 0.044715f * x * x * x), t = tanhf(u);
        float sech2 = 1.0f - t * t;
        float g = 0.5f * (1.0f + t) + 0.5f * x * sech2 * GELU_K * (1.0f + 3.0f * 0.044715f * x * x);
        din[i] += dout[i] * g;
    }
}

/* ---- layer norm ------------------------------------------------------------------------------- */

void mf_layernorm_forward(float *out, float *mean, float *rstd, const float *in, const float *w,
                          const float *b, int N, int C, float eps) {
    for (int i = 0; i < N; ++i) {
        const float *x = in + (size_t)i * C;
        double s = 0.0, v = 0.0;
        for (int c = 0; c < C; ++c) s += x[c];
        double mu = s / C;
        for (int c = 0; c < C; ++c) v += (x[c] - mu) * (x[c] - mu);
        float m = (float)mu, rs = (float)(1.0 / sqrt(v / C + eps));
        float *o = out + (size_t)i * C;
        for (int c = 0; c < C; ++c) o[c] = (x[c] - m) * rs * w[c] + b[c];
        mean[i] = m;
        rstd[i] = rs;
    }
}

void mf_layernorm_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                           const float *mean, const float *rstd, const float *w, int N, int C) {
    for (int i = 0; i < N; ++i) {
        const float *x = in + (size_t)i * C, *dy = dout + (size_t)i * C;
        float m = mean[i], rs = rstd[i];
        double s1 = 0.0, s2 = 0.0;
        for (int c = 0; c < C; ++c) {
            float xh = (x[c] - m) * rs, dxh = dy[c] * w[c];
            s1 += dxh;
            s2 += (double)dxh * xh;
            dw[c] += dy[c] * xh;
            db[c] += dy[c];
        }
        float m1 = (float)(s1 / C), m2 = (float)(s2 / C);
        if (!din) continue;
        float *dx = din + (size_t)i * C;
        for (int c = 0; c < C; ++c) {
            float xh = (x[c] - m) * rs;
            dx[c] += rs * (dy[c] * w[c] - m1 - xh * m2);
        }
    }
}

/* ---- linear ---------------------------------------------------------------------------------- */

void mf_linear_forward(float *out, const float *in, const float *w, const float *bias, int N, int IC,
                       int OC) {
    nn_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, N, OC, IC, 1.0f, in, IC, w, IC, 0.0f, out, OC);
    if (bias)
        for (int i = 0; i < N; ++i)
            for (int o = 0; o < OC; ++o) out[(size_t)i * OC + o] += bias[o];
}

void mf_linear_backward(float *din, float *dw, float *dbias, const float *dout, const float *in,
                        const float *w, int N, int IC, int OC) {
    if (din)
        nn_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, N, IC, OC, 1.0f, dout, OC, w, IC, 1.0f,
                    din, IC);
    nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, OC, IC, N, 1.0f, dout, OC, in, IC, 1.0f, dw, IC);
    if (dbias)
        for (int o = 0; o < OC; ++o) {
            float s = 0.0f;
            for (int i = 0; i < N; ++i) s += dout[(size_t)i * OC + o];
            dbias[o] += s;
        }
}

/* ---- token layout -------------------------------------------------------------------------- */

/* dst (B, R, S) (op)= transpose of src (B, S, R) */
static void transpose_batched(float *dst, const float *src, int B, int S, int R, int accumulate) {
    for (int b = 0; b < B; ++b) {
        const float *s = src + (size_t)b * S * R;
        float *d = dst + (size_t)b * S * R;
        for (int i = 0; i < S; ++i)
            for (int j = 0; j < R; ++j) {
                if (accumulate)
                    d[(size_t)j * S + i] += s[(size_t)i * R + j];
                else
                    d[(size_t)j * S + i] = s[(size_t)i * R + j];
            }
    }
}

void mf_nchw_to_tokens_forward(float *out, const float *in, int B, int C, int HW) {
    transpose_batched(out, in, B, C, HW, 0);
}
void mf_nchw_to_tokens_backward(float *din, const float *dout, int B, int C, int HW) {
    transpose_batched(din, dout, B, HW, C, 1);
}
void mf_tokens_to_nchw_forward(float *out, const float *in, int B, int C, int HW) {
    transpose_batched(out, in, B, HW, C, 0);
}
void mf_tokens_to_nchw_backward(float *din, const float *dout, int B, int C, int HW) {
    transpose_batched(din, dout, B, C, HW, 1);
}

/* ---- attention ------------------------------------------------------------------------------- */

void mf_attention_forward(float *out, float *att, const float *qkv, int B, int T, int C, int NH) {
    int hs = C / NH, C3 = 3 * C;
    float scale = 1.0f / sqrtf((float)hs);
    for (int b = 0; b < B; ++b)
        for (int h = 0; h < NH; ++h) {
            const float *q = qkv + (size_t)b * T * C3 + (size_t)h * hs;
            const float *k = q + C, *v = q + 2 * C;
            float *P = att + ((size_t)b * NH + h) * T * T;
            /* P (T, T) = scale * q (T, hs) . k^T (hs, T) */
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, T, T, hs, scale, q, C3, k, C3, 0.0f, P,
                        T);
            for (int i = 0; i < T; ++i) {
                float *row = P + (size_t)i * T, mx = row[0];
                for (int j = 1; j < T; ++j) mx = row[j] > mx ? row[j] : mx;
                double s = 0.0;
                for (int j = 0; j < T; ++j) {
                    row[j] = expf(row[j] - mx);
                    s += row[j];
                }
                float inv = (float)(1.0 / s);
                for (int j = 0; j < T; ++j) row[j] *= inv;
            }
            /* out (T, hs; ld C) = P (T, T) . v (T, hs; ld 3C) */
            float *o = out + (size_t)b * T * C + (size_t)h * hs;
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, T, hs, T, 1.0f, P, T, v, C3, 0.0f, o, C);
        }
}

void mf_attention_backward(float *dqkv, float *scratch, const float *dout, const float *att,
                           const float *qkv, int B, int T, int C, int NH) {
    int hs = C / NH, C3 = 3 * C;
    float scale = 1.0f / sqrtf((float)hs);
    for (int b = 0; b < B; ++b)
        for (int h = 0; h < NH; ++h) {
            size_t qoff = (size_t)b * T * C3 + (size_t)h * hs;
            const float *q = qkv + qoff, *k = q + C, *v = q + 2 * C;
            float *dq = dqkv + qoff, *dk = dq + C, *dv = dq + 2 * C;
            const float *P = att + ((size_t)b * NH + h) * T * T;
            const float *dO = dout + (size_t)b * T * C + (size_t)h * hs;
            float *dP = scratch;
            /* dv (T, hs) += P^T (T, T) . dO (T, hs) */
            nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, T, hs, T, 1.0f, P, T, dO, C, 1.0f, dv, C3);
            /* dP (T, T) = dO (T, hs) . v^T (hs, T) */
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, T, T, hs, 1.0f, dO, C, v, C3, 0.0f, dP, T);
            /* softmax backward: dS = P * (dP - sum_j P dP), times the scale */
            for (int i = 0; i < T; ++i) {
                const float *pr = P + (size_t)i * T;
                float *dr = dP + (size_t)i * T;
                double s = 0.0;
                for (int j = 0; j < T; ++j) s += (double)pr[j] * dr[j];
                float sf = (float)s;
                for (int j = 0; j < T; ++j) dr[j] = scale * pr[j] * (dr[j] - sf);
            }
            /* dq (T, hs) += dS (T, T) . k (T, hs);  dk (T, hs) += dS^T . q */
            nn_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, T, hs, T, 1.0f, dP, T, k, C3, 1.0f, dq, C3);
            nn_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, T, hs, T, 1.0f, dP, T, q, C3, 1.0f, dk, C3);
        }
}

size_t mf_mv_attention_att_floats(int BV, int V, int HW, int NH, int joint) {
    if (joint) return (size_t)(BV / V) * NH * (size_t)(V * HW) * (size_t)(V * HW);
    return (size_t)BV * NH * (size_t)HW * HW;
}

void mf_mv_attention_forward(float *out, float *att, const float *qkv, int BV, int V, int HW, int C,
                             int NH, int joint) {
    if (joint)
        mf_attention_forward(out, att, qkv, BV / V, V * HW, C, NH);
    else
        mf_attention_forward(out, att, qkv, BV, HW, C, NH);
}

void mf_mv_attention_backward(float *dqkv, float *scratch, const float *dout, const float *att,
                              const float *qkv, int BV, int V, int HW, int C, int NH, int joint) {
    if (joint)
        mf_attention_backward(dqkv, scratch, dout, att, qkv, BV / V, V * HW, C, NH);
    else
        mf_attention_backward(dqkv, scratch, dout, att, qkv, BV, HW, C, NH);
}

/* ---- timestep embedding ---------------------------------------------------------------------- */

void mf_timestep_embedding(float *out, const float *t, int B, int dim, float max_period) {
    int half = dim / 2;
    for (int b = 0; b < B; ++b)
        for (int i = 0; i < half; ++i) {
            double f = exp(-log((double)max_period) * i / half);
            double a = (double)t[b] * f;
            out[(size_t)b * dim + i] = (float)cos(a);
            out[(size_t)b * dim + half + i] = (float)sin(a);
        }
}

/* ---- MSE ------------------------------------------------------------------------------------- */

float mf_mse_forward(const float *pred, const float *target, size_t n) {
    double s = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double d = (double)pred[i] - target[i];
        s += d * d;
    }
    return n ? (float)(s / (double)n) : 0.0f;
}

void mf_mse_backward(float *dpred, const float *pred, const float *target, size_t n, float dloss) {
    float k = n ? 2.0f * dloss / (float)n : 0.0f;
    for (size_t i = 0; i < n; ++i) dpred[i] += k * (pred[i] - target[i]);
}
