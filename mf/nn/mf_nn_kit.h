/* mf_nn_kit: layer building blocks over mf_nn for whole networks (used by the prior's
 * autoencoder and denoiser).
 *
 * - MfSpecTab: a growing table of named parameter tensors (MfTensorSpec); each layer records the
 *   float offset of its first tensor, so after one flat allocation a layer's weights are
 *   `params + off` and its gradients `grads + off` (llm.c style: one buffer per model).
 * - MfArena: activations taken in a fixed order from one float buffer. A layout function run
 *   with base == NULL only counts floats; run again with a buffer it binds the same pointers.
 * - MfKConv (conv2d with bias) and MfKNorm (group norm followed by SiLU, one fused pass) with forward/backward
 *   pairs; backward accumulates (+=) into every gradient, as everywhere in mf/nn.
 * Layout NCHW float32 throughout. */
#ifndef MF_NN_KIT_H
#define MF_NN_KIT_H

#include <stddef.h>

#include "nn/mf_nn.h"

typedef struct {
    MfTensorSpec *v; // (cap) owned
    int n, cap;
    size_t numel;    /* floats of all tensors so far */
} MfSpecTab;

/* Appends one tensor; returns its float offset, or (size_t)-1 on allocation failure. */
size_t mf_spectab_add(MfSpecTab *t, const char *prefix, const char *leaf, int ndim, const int *shape);
/* Appends n ready specs (e.g. from mf_resblock_specs); returns the offset of the first. */
size_t mf_spectab_add_many(MfSpecTab *t, const MfTensorSpec *specs, int n);
void mf_spectab_free(MfSpecTab *t);

typedef struct {
    float *base; /* borrowed; NULL = count only */
    size_t used;
} MfArena;

/* n floats from the arena (NULL while counting). */
float *mf_arena_take(MfArena *a, size_t n);

/* K x K conv (pad K/2), stride 1 or 2, with bias. */
typedef struct {
    int Cin, Cout, K, stride;
    size_t off; /* w (Cout, Cin, K, K) then b (Cout) */
} MfKConv;

size_t mf_kconv_add(MfKConv *c, MfSpecTab *t, const char *name, int Cin, int Cout, int K, int stride);
/* uniform(+-1/sqrt(fan_in)) (PyTorch default); zero = 1 makes weights and bias 0. */
void mf_kconv_init(const MfKConv *c, float *params, unsigned long long seed, int zero);
size_t mf_kconv_col(const MfKConv *c, int B, int H, int W);
void mf_kconv_forward(const MfKConv *c, const float *params, float *out, float *col, const float *in, int B,
                      int H, int W);
/* din may be NULL (input needs no gradient). */
void mf_kconv_backward(const MfKConv *c, const float *params, float *grads, float *din, float *col,
                       const float *dout, const float *in, int B, int H, int W);

/* Group norm (affine) then SiLU. */
typedef struct {
    int C, G;
    size_t off; /* gamma (C) then beta (C) */
} MfKNorm;

typedef struct {
    float *sig;         // (B, C, HW) sigmoid(GN(in)), mf_gnsilu_forward's cache
    float *mean, *rstd; // (B, G)
    float *a;           // (B, C, HW) SiLU(GN(in)), the layer's output
} MfKNormActs;

size_t mf_knorm_add(MfKNorm *n, MfSpecTab *t, const char *name, int C, int G);
void mf_knorm_init(const MfKNorm *n, float *params);
void mf_knorm_acts(MfKNormActs *a, MfArena *ar, int B, int C, int HW, int G);
void mf_knorm_forward(const MfKNorm *n, const float *params, MfKNormActs *a, const float *in, int B, int HW);
/* din (B, C, HW) += ... from dout (B, C, HW) (gradient of a). */
void mf_knorm_backward(const MfKNorm *n, const float *params, float *grads, MfKNormActs *a, float *din,
                       const float *dout, const float *in, int B, int HW);

/* Linear layer w (OC, IC) then b (OC). */
typedef struct {
    int IC, OC;
    size_t off;
} MfKLinear;

size_t mf_klinear_add(MfKLinear *l, MfSpecTab *t, const char *name, int IC, int OC);
void mf_klinear_init(const MfKLinear *l, float *params, unsigned long long seed);
void mf_klinear_forward(const MfKLinear *l, const float *params, float *out, const float *in, int N);
void mf_klinear_backward(const MfKLinear *l, const float *params, float *grads, float *din, const float *dout,
                         const float *in, int N);

#define MF_KNORM_EPS 1e-5f

/* ---- sequential networks ---------------------------------------------------------------------
 * A chain of layers applied one after another (the autoencoder's encoder and decoder, the image
 * encoder): conv, residual block (no time embedding), nearest upsample x2, GN+SiLU, SiLU. */
typedef enum { MF_SEQ_CONV, MF_SEQ_RES, MF_SEQ_UP, MF_SEQ_NORM, MF_SEQ_SILU } MfSeqKind;

#define MF_SEQ_MAXOPS 24

typedef struct {
    MfSeqKind kind;
    int Ci, Co, Hi, Wi, Ho, Wo; /* input / output channels and sizes */
    MfKConv conv;               /* MF_SEQ_CONV */
    MfKNorm norm;               /* MF_SEQ_NORM */
    MfResBlockDims rd;          /* MF_SEQ_RES (rd.B set per call) */
    size_t roff;                /* MF_SEQ_RES: offset of the block's tensors */
    int zero_init;              /* conv initialised to zero */
} MfSeqOp;

typedef struct {
    int n, G;
    int C, H, W; /* current (after the last op added) */
    int C0, H0, W0;
    MfSeqOp op[MF_SEQ_MAXOPS];
} MfSeq;

typedef struct {
    float *mem; /* owned */
    size_t cap;
    int B;      /* batch of the last forward */
    const float *in;               /* borrowed: input of the last forward (B, C0, H0, W0) */
    float *out[MF_SEQ_MAXOPS];     /* op outputs */
    MfResBlockActs res[MF_SEQ_MAXOPS];
    MfKNormActs norm[MF_SEQ_MAXOPS];
    float *col;                    /* conv scratch */
    float *gA, *gB;                /* backward ping-pong */
} MfSeqWork;

void mf_seq_begin(MfSeq *s, int C, int H, int W, int G);
/* Each adds one op (and its tensors to t, named prefix.<index>...); return 0 on failure. */
int mf_seq_conv(MfSeq *s, MfSpecTab *t, const char *prefix, int Cout, int K, int stride, int zero_init);
int mf_seq_res(MfSeq *s, MfSpecTab *t, const char *prefix, int Cout);
int mf_seq_up(MfSeq *s);
int mf_seq_norm(MfSeq *s, MfSpecTab *t, const char *prefix);
int mf_seq_silu(MfSeq *s);
void mf_seq_init(const MfSeq *s, float *params, unsigned long long seed);
/* Forward for batch B; returns the output (B, s->C, s->H, s->W) inside w (valid until the next
 * forward). in must stay valid until the backward. Returns NULL when out of memory. */
float *mf_seq_forward(const MfSeq *s, const float *params, MfSeqWork *w, const float *in, int B);
/* Backward of the last forward: grads +=, din (B, C0, H0, W0) += (din may be NULL; grads NULL: the
 * input gradient only, for a frozen network; not with time-embedded blocks). */
void mf_seq_backward(const MfSeq *s, const float *params, float *grads, MfSeqWork *w, const float *dout,
                     float *din);
void mf_seq_work_free(MfSeqWork *w);

#endif
