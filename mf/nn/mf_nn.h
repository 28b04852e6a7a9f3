/* mf_nn: a small CPU neural-network engine (float32, NCHW), in the style of llm.c.
 *
 * Tensors are plain float pointers plus sizes; every array carries its shape in a comment.
 * Layout is NCHW for images: (B, C, H, W), row-major, W fastest. Token tensors are (B, T, C).
 * Layers come as x_forward / x_backward pairs:
 *   - forward WRITES its output (=) and whatever it caches for backward;
 *   - backward ACCUMULATES (+=) into every gradient it produces (input and weights), so callers
 *     zero gradient buffers once per step. A gradient pointer may be NULL to skip it where noted.
 * Parameters of a model live in ONE allocation: a model lists its tensors (MfTensorSpec, name and
 * shape, in a fixed order) and binds a struct of float pointers into a flat buffer with
 * mf_params_bind (the gradient buffer is bound to a second struct of the same type).
 * Threads: matrix products go through OpenBLAS cblas_sgemm, which brings its own pthreads
 * (OPENBLAS_NUM_THREADS, default all cores); the element-wise loops here are deliberately
 * single-threaded, NOT OpenMP: on 2 cores an OpenMP region right after an sgemm fights
 * OpenBLAS's still-spinning workers (measured: conv2d forward+backward 7 GFLOP/s with OpenMP
 * im2col vs 71 GFLOP/s without). Everything is deterministic for a fixed thread count (no
 * atomics, fixed reduction order; OpenBLAS's sgemm is deterministic for fixed sizes/threads).
 * Convolutions run on oneDNN instead in the default build (`make DNNL=0` builds without it; see
 * "conv backend" below).
 * Scratch buffers are passed in by the caller; sizes come from the *_floats() helpers. */
#ifndef MF_NN_H
#define MF_NN_H

#include <stddef.h>

#include "io/mf_ckpt.h"

/* ---- parameter tables ---------------------------------------------------------------- */

/* MfTensorSpec (one named tensor: name and shape), mf_tensor_numel, mf_specs_numel and
 * mf_spec_set come with the checkpoint format, io/mf_ckpt.h. */

/* Points slots[i] (n pointers, e.g. the fields of a struct of float*) at consecutive tensors of
 * mem in table order; mem holds mf_specs_numel(specs, n) floats (borrowed). */
void mf_params_bind(float **slots, const MfTensorSpec *specs, int n, float *mem);

/* ---- initialisation ------------------------------------------------------------------- */

/* Fills w (n floats) with uniform(-bound, bound), deterministic in seed (PCG32). */
void mf_nn_init_uniform(float *w, size_t n, float bound, unsigned long long seed);

/* ---- conv2d (im2col + sgemm) ---------------------------------------------------------- */

/* K x K convolution, pad = K/2 (so 3x3 pad 1, 1x1 pad 0), stride 1 or 2.
 * Output size Ho = (H + 2*pad - K)/stride + 1 (H/2 for even H with 3x3 stride 2). */
int mf_conv2d_out_size(int H, int K, int stride);
/* Scratch floats for the im2col buffer. Images with Ho*Wo < 1024 are processed nb at a time
 * (nb = min(B, ceil(1024/(Ho*Wo)))) so each GEMM has >= ~1024 columns: scratch is then
 * (Cin*K*K + Cout)*nb*Ho*Wo; otherwise one item at a time, Cin*K*K*Ho*Wo (0 for 1x1 stride 1). */
size_t mf_conv2d_col_floats(int B, int Cin, int H, int W, int Cout, int K, int stride);
/* out (B, Cout, Ho, Wo) = conv(in (B, Cin, H, W), w (Cout, Cin, K, K)) + bias (Cout, may be NULL).
 * col: scratch of mf_conv2d_col_floats floats; for 1x1 stride 1 it may be NULL (then each item
 * is one direct GEMM, no copies). */
void mf_conv2d_forward(float *out, float *col, const float *in, const float *w, const float *bias,
                       int B, int Cin, int H, int W, int Cout, int K, int stride);
/* din (B, Cin, H, W) += ..., dw (Cout, Cin, K, K) += ..., dbias (Cout) += ...; din, dw and dbias
 * may be NULL (dw NULL: the input gradient only, no im2col of the input). dout (B, Cout, Ho, Wo); col: same scratch as forward (im2col is recomputed). */
void mf_conv2d_backward(float *din, float *dw, float *dbias, float *col, const float *dout,
                        const float *in, const float *w, int B, int Cin, int H, int W, int Cout, int K,
                        int stride);
/* The same two with the element-wise steps of a block fused into their copy passes (no extra pass
 * over the activations):
 * forward: out = conv(in) + bias[o] + bias_b[b, o] + add[b, o, y, x], added in that order;
 *   bias_b (B, Cout) a per-image bias (a projected time embedding) or NULL; add (B, Cout, Ho, Wo) a
 *   residual or NULL, not aliasing out.
 * backward: dbias_b (B, Cout) += per-image spatial sums of dout (or NULL); din_acc = 0: din is
 *   written (=) instead of accumulated, so a scratch gradient needs no zeroing. */
void mf_conv2d_forward_ex(float *out, float *col, const float *in, const float *w, const float *bias,
                          const float *bias_b, const float *add, int B, int Cin, int H, int W, int Cout, int K,
                          int stride);
void mf_conv2d_backward_ex(float *din, int din_acc, float *dw, float *dbias, float *dbias_b, float *col,
                           const float *dout, const float *in, const float *w, int B, int Cin, int H, int W,
                           int Cout, int K, int stride);

/* ---- conv backend ---------------------------------------------------------------------------- */

/* The convolutions above run as im2col + OpenBLAS sgemm (MF_NN_BLAS) or through oneDNN's
 * convolution primitives (MF_NN_DNNL, in builds with oneDNN: the default `make`, not `make DNNL=0`;
 * nn/mf_nn_dnnl.h), in the same NCHW / OIHW layout; the fused terms (bias_b, add, dbias, dbias_b)
 * are the same code in both. oneDNN's results differ from the sgemm path's in the last bits
 * (relative 1e-6). Process-wide; the default is MF_NN_DNNL where built, else MF_NN_BLAS. If oneDNN fails on a call (no
 * implementation for a shape, out of memory), that call and every later one run on OpenBLAS and a
 * warning says why (results stay right). mf_nn_gemm_flops counts a oneDNN convolution as the
 * FLOPs of the GEMMs it replaces. */
typedef enum { MF_NN_BLAS, MF_NN_DNNL } MfNnBackend;

/* MF_EARG (backend unchanged) for MF_NN_DNNL in a build without oneDNN. */
int mf_nn_set_backend(MfNnBackend b);
MfNnBackend mf_nn_backend(void);
const char *mf_nn_backend_name(MfNnBackend b); /* "blas" or "dnnl" */
/* From the environment variable MF_NN_BACKEND: blas or dnnl (unset or empty: unchanged); MF_EARG,
 * naming the variable, for another value or for dnnl in a build without oneDNN. */
int mf_nn_backend_from_env(void);

/* ---- nearest upsample x2 ---------------------------------------------------------------- */

/* out (B, C, 2H, 2W) from in (B, C, H, W). */
void mf_upsample2x_forward(float *out, const float *in, int B, int C, int H, int W);
/* din (B, C, H, W) += sum of the 2x2 block of dout (B, C, 2H, 2W). */
void mf_upsample2x_backward(float *din, const float *dout, int B, int C, int H, int W);

/* ---- group norm (affine) ---------------------------------------------------------------- */

/* out (B, C, HW) = (in - mean_g) * rstd_g * gamma[c] + beta[c], statistics over each group of
 * C/G channels x HW pixels (population variance, + eps). Caches mean, rstd (B, G). C % G == 0. */
void mf_groupnorm_forward(float *out, float *mean, float *rstd, const float *in, const float *gamma,
                          const float *beta, int B, int C, int HW, int G, float eps);
/* din (B, C, HW) += ..., dgamma (C) += ..., dbeta (C) += ... (dgamma and dbeta NULL together: not
 * computed) */
void mf_groupnorm_backward(float *din, float *dgamma, float *dbeta, const float *dout,
                           const float *in, const float *mean, const float *rstd,
                           const float *gamma, int B, int C, int HW, int G);

/* ---- SiLU ------------------------------------------------------------------------------- */

/* out (n) = in * sigmoid(in); out may alias in. */
void mf_silu_forward(float *out, const float *in, size_t n);
/* din (n) += dout * silu'(in) (in is the forward INPUT). */
void mf_silu_backward(float *din, const float *dout, const float *in, size_t n);

/* ---- group norm + SiLU in one pass ------------------------------------------------------------ */

/* out (B, C, HW) = SiLU(GN(in)) with GN as mf_groupnorm_forward, computed in the same pass as the
 * statistics' last read; caches mean, rstd (B, G) and sig (B, C, HW) = sigmoid(GN(in)), from which
 * the backward gets SiLU' without another exponential (GN(in) itself is recomputed from in). */
void mf_gnsilu_forward(float *out, float *sig, float *mean, float *rstd, const float *in, const float *gamma,
                       const float *beta, int B, int C, int HW, int G, float eps);
/* din (B, C, HW) += (din_acc = 1) or = (din_acc = 0) the input gradient, dgamma (C) +=, dbeta (C) +=
 * (both NULL: not computed) from da (B, C, HW), the gradient of out; din may be NULL. */
void mf_gnsilu_backward(float *din, int din_acc, float *dgamma, float *dbeta, const float *da, const float *in,
                        const float *sig, const float *mean, const float *rstd, const float *gamma,
                        const float *beta, int B, int C, int HW, int G);

/* ---- GELU (tanh approximation, as GPT-2 / llm.c) ----------------------------------------- */

/* out (n) = 0.5 x (1 + tanh(sqrt(2/pi) (x + 0.044715 x^3))); out may alias in. */
void mf_gelu_forward(float *out, const float *in, size_t n);
/* din (n) += dout * gelu'(in). */
void mf_gelu_backward(float *din, const float *dout, const float *in, size_t n);

/* ---- layer norm over the last dimension ---------------------------------------------------- */

/* out (N, C) = (in - mean) * rstd * w + b per row; caches mean, rstd (N). */
void mf_layernorm_forward(float *out, float *mean, float *rstd, const float *in, const float *w,
                          const float *b, int N, int C, float eps);
/* din (N, C) +=, dw (C) +=, db (C) += */
void mf_layernorm_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                           const float *mean, const float *rstd, const float *w, int N, int C);

/* ---- linear ----------------------------------------------------------------------------- */

/* out (N, OC) = in (N, IC) . w^T + bias; w (OC, IC) (PyTorch layout), bias (OC) or NULL. */
void mf_linear_forward(float *out, const float *in, const float *w, const float *bias, int N, int IC,
                       int OC);
/* din (N, IC) += dout . w, dw (OC, IC) += dout^T . in, dbias (OC) += column sums; din and
 * dbias may be NULL. */
void mf_linear_backward(float *din, float *dw, float *dbias, const float *dout, const float *in,
                        const float *w, int N, int IC, int OC);

/* ---- token layout ----------------------------------------------------------------------- */

/* out (B, HW, C) = transpose of in (B, C, HW), and its backward din (B, C, HW) += dout^T. */
void mf_nchw_to_tokens_forward(float *out, const float *in, int B, int C, int HW);
void mf_nchw_to_tokens_backward(float *din, const float *dout, int B, int C, int HW);
/* out (B, C, HW) = transpose of in (B, HW, C), and its backward. */
void mf_tokens_to_nchw_forward(float *out, const float *in, int B, int C, int HW);
void mf_tokens_to_nchw_backward(float *din, const float *dout, int B, int C, int HW);

/* ---- multi-head self-attention (core; projections are mf_linear layers) --------------- */

/* qkv (B, T, 3C): per token [q (C) | k (C) | v (C)], head h uses channels h*C/NH .. (h+1)*C/NH
 * of each. out (B, T, C) = softmax(q k^T / sqrt(C/NH)) v per head (no mask).
 * att (B, NH, T, T) caches the softmax probabilities. C % NH == 0. */
void mf_attention_forward(float *out, float *att, const float *qkv, int B, int T, int C, int NH);
/* dqkv (B, T, 3C) += ...; scratch holds T*T floats. */
void mf_attention_backward(float *dqkv, float *scratch, const float *dout, const float *att,
                           const float *qkv, int B, int T, int C, int NH);

/* Multi-view attention over spatial tokens (StableMaterialMV). The batch holds BV = B*V images,
 * V consecutive views per object, each with HW tokens: qkv (BV, HW, 3C), out (BV, HW, C).
 * joint = 0: every image attends within itself (T = HW, BV batches).
 * joint = 1: the V views of an object attend jointly: (BV, HW, C) is viewed as (B, V*HW, C),
 * which is the same memory, so tokens of all V views form one sequence. BV % V == 0.
 * att: mf_mv_attention_att_floats floats; scratch: (T*T) with T = joint ? V*HW : HW. */
size_t mf_mv_attention_att_floats(int BV, int V, int HW, int NH, int joint);
void mf_mv_attention_forward(float *out, float *att, const float *qkv, int BV, int V, int HW, int C,
                             int NH, int joint);
void mf_mv_attention_backward(float *dqkv, float *scratch, const float *dout, const float *att,
                              const float *qkv, int BV, int V, int HW, int C, int NH, int joint);

/* ---- timestep embedding (forward only) --------------------------------------------------- */

/* out (B, dim) = [cos(t*f_0..f_{half-1}) | sin(t*f_0..)] with f_i = exp(-ln(max_period)*i/half),
 * half = dim/2 (Stable Diffusion's flip_sin_to_cos=True, shift 0); t (B) in timesteps.
 * dim must be even. max_period is usually 10000. */
void mf_timestep_embedding(float *out, const float *t, int B, int dim, float max_period);

/* ---- MSE ---------------------------------------------------------------------------------- */

/* mean((pred - target)^2) over n elements (accumulated in double). */
float mf_mse_forward(const float *pred, const float *target, size_t n);
/* dpred (n) += dloss * 2 (pred - target) / n. */
void mf_mse_backward(float *dpred, const float *pred, const float *target, size_t n, float dloss);

/* ---- residual block ------------------------------------------------------------------------ */

/* x (B, Cin, H, W), temb (B, Ct):
 *   h  = conv1(SiLU(GN1(x)))  + (temb_w . SiLU(temb) + temb_b)[b, c]   (broadcast over H, W)
 *   out = conv2(SiLU(GN2(h))) + skip(x)        skip = 1x1 conv when Cin != Cout, else identity.
 * conv1, conv2: 3x3 pad 1 stride 1. GN: G groups, eps. Ct = 0 disables the time embedding. */
typedef struct {
    int B, Cin, Cout, H, W, Ct, G;
    float eps;
} MfResBlockDims;

#define MF_RESBLOCK_NPARAMS 12
/* Parameter pointers (into one flat buffer, bound in this field order by mf_params_bind). */
typedef struct {
    float *gn1_w, *gn1_b;     // (Cin), (Cin)
    float *conv1_w, *conv1_b; // (Cout, Cin, 3, 3), (Cout)
    float *temb_w, *temb_b;   // (Cout, Ct), (Cout)      absent (NULL) when Ct == 0
    float *gn2_w, *gn2_b;     // (Cout), (Cout)
    float *conv2_w, *conv2_b; // (Cout, Cout, 3, 3), (Cout)
    float *skip_w, *skip_b;   // (Cout, Cin, 1, 1), (Cout) absent (NULL) when Cin == Cout
} MfResBlockW;

/* Activations and backward scratch (one flat buffer, bound by mf_resblock_acts_bind). */
typedef struct {
    float *s1;           // (B, Cin, H, W)  sigmoid(GN1(x)) (mf_gnsilu_forward's cache)
    float *mean1, *rstd1; // (B, G)
    float *a1;           // (B, Cin, H, W)  SiLU(GN1(x))
    float *tsilu;        // (B, Ct)         SiLU(temb)
    float *tproj;        // (B, Cout)       projection of SiLU(temb)
    float *c1;           // (B, Cout, H, W) conv1(a1) + tproj
    float *s2;           // (B, Cout, H, W) sigmoid(GN2(c1))
    float *mean2, *rstd2; // (B, G)
    float *a2;           // (B, Cout, H, W) SiLU(GN2(c1))
    float *col;          // conv scratch, max of mf_conv2d_col_floats of conv1, conv2, skip
    float *gA, *gB;      // (B, max(Cin, Cout), H, W) backward scratch
    float *gt;           // (B, Cout + Ct) backward scratch
} MfResBlockActs;

/* Writes the block's tensor specs (names prefix.gn1.w, ...) in MfResBlockW field order, absent
 * tensors skipped; returns how many (<= MF_RESBLOCK_NPARAMS). */
int mf_resblock_specs(MfTensorSpec *specs, const char *prefix, const MfResBlockDims *d);
/* Binds w's present fields to consecutive tensors of mem (mf_specs_numel of the specs); absent
 * fields are set to NULL. Call once for the parameters and once for the gradients (mem NULL: every
 * field NULL, for a backward that computes no parameter gradient). */
void mf_resblock_bind(MfResBlockW *w, const MfResBlockDims *d, float *mem);
size_t mf_resblock_acts_floats(const MfResBlockDims *d);
void mf_resblock_acts_bind(MfResBlockActs *a, const MfResBlockDims *d, float *mem);
/* Default initialisation (PyTorch-like uniform(+-1/sqrt(fan_in)) weights, GN gamma 1, beta 0). */
void mf_resblock_init(MfResBlockW *w, const MfResBlockDims *d, unsigned long long seed);
/* out (B, Cout, H, W); temb (B, Ct) or NULL when Ct == 0. */
void mf_resblock_forward(float *out, MfResBlockActs *a, const float *x, const float *temb,
                         const MfResBlockW *w, const MfResBlockDims *d);
/* dx (B, Cin, H, W) +=, dtemb (B, Ct) += (may be NULL), g (gradients) +=; g's fields may be NULL
 * (bound to NULL: the input gradient only) where the block has no time embedding. */
void mf_resblock_backward(float *dx, float *dtemb, MfResBlockW *g, MfResBlockActs *a,
                          const float *dout, const float *x, const float *temb, const MfResBlockW *w,
                          const MfResBlockDims *d);

/* ---- spatial self-attention block -------------------------------------------------------- */

/* x (BV, C, H, W), BV = B*V images (V consecutive views per object):
 *   h = GN(x); tokens (BV, HW, C); qkv = h . Wqkv^T + bqkv; y = MV-attention(qkv) (joint across
 *   the V views when joint = 1, see mf_mv_attention_forward); out = x + NCHW(y . Wproj^T + bproj). */
typedef struct {
    int BV, C, H, W, G, NH, V, joint;
    float eps;
} MfAttnBlockDims;

#define MF_ATTNBLOCK_NPARAMS 6
typedef struct {
    float *gn_w, *gn_b;     // (C), (C)
    float *qkv_w, *qkv_b;   // (3C, C), (3C)
    float *proj_w, *proj_b; // (C, C), (C)
} MfAttnBlockW;

typedef struct {
    float *h;           // (BV, C, HW) GN(x)
    float *mean, *rstd; // (BV, G)
    float *tok;         // (BV, HW, C)
    float *qkv;         // (BV, HW, 3C)
    float *att;         // mf_mv_attention_att_floats(BV, V, HW, NH, joint)
    float *y;           // (BV, HW, C) attention output
    float *z;           // (BV, HW, C) projection output
    float *scratch;     // (T, T), T = joint ? V*HW : HW
    float *g1, *g2;     // (BV, HW, C) backward scratch
    float *gqkv;        // (BV, HW, 3C) backward scratch
} MfAttnBlockActs;

int mf_attnblock_specs(MfTensorSpec *specs, const char *prefix, const MfAttnBlockDims *d);
void mf_attnblock_bind(MfAttnBlockW *w, const MfAttnBlockDims *d, float *mem);
size_t mf_attnblock_acts_floats(const MfAttnBlockDims *d);
void mf_attnblock_acts_bind(MfAttnBlockActs *a, const MfAttnBlockDims *d, float *mem);
/* GN gamma 1, beta 0; linear weights uniform(+-1/sqrt(C)); proj initialised like the others
 * (zero it for an identity block at the start of training if wanted). */
void mf_attnblock_init(MfAttnBlockW *w, const MfAttnBlockDims *d, unsigned long long seed);
/* out (BV, C, H, W) */
void mf_attnblock_forward(float *out, MfAttnBlockActs *a, const float *x, const MfAttnBlockW *w,
                          const MfAttnBlockDims *d);
/* dx (BV, C, H, W) +=, g +=. */
void mf_attnblock_backward(float *dx, MfAttnBlockW *g, MfAttnBlockActs *a, const float *dout,
                           const float *x, const MfAttnBlockW *w, const MfAttnBlockDims *d);

/* ---- AdamW ---------------------------------------------------------------------------------- */

/* AdamW (Loshchilov & Hutter) over a flat parameter buffer: with bias-corrected moments
 *   p -= lr * (m_hat / (sqrt(v_hat) + eps) + weight_decay * p)      (decoupled decay).
 * Decay applies to every element; run two optimisers over ranges to exempt some. */
typedef struct {
    float lr, beta1, beta2, eps, weight_decay;
    long long t;  /* steps taken */
    size_t n;
    float *m;     // (n) owned, first moment
    float *v;     // (n) owned, second moment
} MfAdamW;

int mf_adamw_init(MfAdamW *opt, size_t n, float lr, float beta1, float beta2, float eps,
                  float weight_decay);
/* One step: params (n) updated from grads (n). lr may be changed between steps (schedules).
 * Refuses non-finite gradients (MF_ENAN, naming the first bad element) and then leaves params,
 * moments and the step count untouched, so the caller can stop at the last good state. */
int mf_adamw_step(MfAdamW *opt, float *params, const float *grads);
void mf_adamw_free(MfAdamW *opt);

/* MF_OK if all n values are finite, else MF_ENAN with "what[i] is nan|inf". */
int mf_nn_check_finite(const float *x, size_t n, const char *what);

/* Global L2 norm of grads (n), accumulated in double; if it exceeds max_norm > 0 the gradients
 * are scaled by max_norm / norm. Returns the norm before clipping. */
float mf_grad_clip_norm(float *grads, size_t n, float max_norm);

/* FLOPs (2*M*N*K per product) of the sgemm calls made by the layers since the last reset: a
 * process-wide counter for benchmarks (not thread-safe; the layers are called from one thread). */
unsigned long long mf_nn_gemm_flops(void);
void mf_nn_gemm_flops_reset(void);

/* Threads of OpenBLAS's matrix products from now on, process-wide (n >= 1; the start value is
 * OPENBLAS_NUM_THREADS, else OMP_NUM_THREADS, else all cores). OpenBLAS splits a product's rows
 * and columns among its threads, not the sums: the results do not depend on it. With the dnnl
 * backend it also sets oneDNN's threads (else OMP_NUM_THREADS), whose results may depend on them. */
void mf_nn_set_threads(int n);

#endif
