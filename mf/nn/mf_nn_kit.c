/* mf_nn_kit: see mf_nn_kit.h. */
#include "nn/mf_nn_kit.h"

#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

static int tab_grow(MfSpecTab *t, int extra) {
    if (t->n + extra <= t->cap) return 1;
    int cap = t->cap ? t->cap * 2 : 64;
    while (cap < t->n + extra) cap *= 2;
    MfTensorSpec *v = realloc(t->v, (size_t)cap * sizeof *v);
    if (!v) return 0;
    t->v = v, t->cap = cap;
    return 1;
}

size_t mf_spectab_add(MfSpecTab *t, const char *prefix, const char *leaf, int ndim, const int *shape) {
    if (!tab_grow(t, 1)) return (size_t)-1;
    size_t off = t->numel;
    mf_spec_set(&t->v[t->n], prefix, leaf, ndim, shape);
    t->numel += mf_tensor_numel(&t->v[t->n]);
    t->n++;
    return off;
}

size_t mf_spectab_add_many(MfSpecTab *t, const MfTensorSpec *specs, int n) {
    if (!tab_grow(t, n)) return (size_t)-1;
    size_t off = t->numel;
    for (int i = 0; i < n; ++i) {
        t->v[t->n] = specs[i];
        t->numel += mf_tensor_numel(&specs[i]);
        t->n++;
    }
    return off;
}

void mf_spectab_free(MfSpecTab *t) {
    free(t->v);
    memset(t, 0, sizeof *t);
}

float *mf_arena_take(MfArena *a, size_t n) {
    float *p = a->base ? a->base + a->used : NULL;
    a->used += n;
    return p;
}

/* ---- conv ---------------------------------------------------------------------------------- */

size_t mf_kconv_add(MfKConv *c, MfSpecTab *t, const char *name, int Cin, int Cout, int K, int stride) {
    c->Cin = Cin, c->Cout = Cout, c->K = K, c->stride = stride;
    int sw[4] = {Cout, Cin, K, K}, sb[1] = {Cout};
    c->off = mf_spectab_add(t, name, "w", 4, sw);
    mf_spectab_add(t, name, "b", 1, sb);
    return c->off;
}

void mf_kconv_init(const MfKConv *c, float *params, unsigned long long seed, int zero) {
    size_t nw = (size_t)c->Cout * c->Cin * c->K * c->K;
    float *w = params + c->off, *b = w + nw;
    if (zero) {
        memset(w, 0, (nw + (size_t)c->Cout) * sizeof(float));
        return;
    }
    float bound = 1.0f / sqrtf((float)(c->Cin * c->K * c->K));
    mf_nn_init_uniform(w, nw, bound, seed * 2 + 1);
    mf_nn_init_uniform(b, (size_t)c->Cout, bound, seed * 2 + 2);
}

size_t mf_kconv_col(const MfKConv *c, int B, int H, int W) {
    return mf_conv2d_col_floats(B, c->Cin, H, W, c->Cout, c->K, c->stride);
}

void mf_kconv_forward(const MfKConv *c, const float *params, float *out, float *col, const float *in, int B,
                      int H, int W) {
    const float *w = params + c->off, *b = w + (size_t)c->Cout * c->Cin * c->K * c->K;
    mf_conv2d_forward(out, col, in, w, b, B, c->Cin, H, W, c->Cout, c->K, c->stride);
}

void mf_kconv_backward(const MfKConv *c, const float *params, float *grads, float *din, float *col,
                       const float *dout, const float *in, int B, int H, int W) {
    size_t nw = (size_t)c->Cout * c->Cin * c->K * c->K;
    mf_conv2d_backward(din, grads ? grads + c->off : NULL, grads ? grads + c->off + nw : NULL, col, dout, in, params + c->off, B, c->Cin, H, W,
                       c->Cout, c->K, c->stride);
}

/* ---- group norm + SiLU ---------------------------------------------------------------------- */

size_t mf_knorm_add(MfKNorm *n, MfSpecTab *t, const char *name, int C, int G) {
    n->C = C, n->G = G;
    int s[1] = {C};
    n->off = mf_spectab_add(t, name, "w", 1, s);
    mf_spectab_add(t, name, "b", 1, s);
    return n->off;
}

void mf_knorm_init(const MfKNorm *n, float *params) {
    for (int c = 0; c < n->C; ++c) params[n->off + c] = 1.0f, params[n->off + n->C + c] = 0.0f;
}

void mf_knorm_acts(MfKNormActs *a, MfArena *ar, int B, int C, int HW, int G) {
    size_t n = (size_t)B * C * HW;
    a->sig = mf_arena_take(ar, n);
    a->mean = mf_arena_take(ar, (size_t)B * G);
    a->rstd = mf_arena_take(ar, (size_t)B * G);
    a->a = mf_arena_take(ar, n);
}

void mf_knorm_forward(const MfKNorm *n, const float *params, MfKNormActs *a, const float *in, int B, int HW) {
    mf_gnsilu_forward(a->a, a->sig, a->mean, a->rstd, in, params + n->off, params + n->off + n->C, B, n->C, HW, n->G,
                      MF_KNORM_EPS);
}

void mf_knorm_backward(const MfKNorm *n, const float *params, float *grads, MfKNormActs *a, float *din,
                       const float *dout, const float *in, int B, int HW) {
    mf_gnsilu_backward(din, 1, grads ? grads + n->off : NULL, grads ? grads + n->off + n->C : NULL, dout, in, a->sig,
                       a->mean, a->rstd, params + n->off, params + n->off + n->C, B, n->C, HW, n->G);
}

/* ---- linear ---------------------------------------------------------------------------------- */

size_t mf_klinear_add(MfKLinear *l, MfSpecTab *t, const char *name, int IC, int OC) {
    l->IC = IC, l->OC = OC;
    int sw[2] = {OC, IC}, sb[1] = {OC};
    l->off = mf_spectab_add(t, name, "w", 2, sw);
    mf_spectab_add(t, name, "b", 1, sb);
    return l->off;
}

void mf_klinear_init(const MfKLinear *l, float *params, unsigned long long seed) {
    float bound = 1.0f / sqrtf((float)l->IC);
    mf_nn_init_uniform(params + l->off, (size_t)l->OC * l->IC, bound, seed * 2 + 1);
    mf_nn_init_uniform(params + l->off + (size_t)l->OC * l->IC, (size_t)l->OC, bound, seed * 2 + 2);
}

void mf_klinear_forward(const MfKLinear *l, const float *params, float *out, const float *in, int N) {
    mf_linear_forward(out, in, params + l->off, params + l->off + (size_t)l->OC * l->IC, N, l->IC, l->OC);
}

void mf_klinear_backward(const MfKLinear *l, const float *params, float *grads, float *din, const float *dout,
                         const float *in, int N) {
    mf_linear_backward(din, grads + l->off, grads + l->off + (size_t)l->OC * l->IC, dout, in, params + l->off, N,
                       l->IC, l->OC);
}

/* ---- sequential networks ------------------------------------------------------------------------ */

void mf_seq_begin(MfSeq *s, int C, int H, int W, int G) {
    memset(s, 0, sizeof *s);
    s->C = s->C0 = C, s->H = s->H0 = H, s->W = s->W0 = W, s->G = G;
}

static MfSeqOp *seq_push(MfSeq *s, MfSeqKind kind) {
    if (s->n >= MF_SEQ_MAXOPS) return NULL;
    MfSeqOp *o = &s->op[s->n++];
    memset(o, 0, sizeof *o);
    o->kind = kind, o->Ci = o->Co = s->C, o->Hi = o->Ho = s->H, o->Wi = o->Wo = s->W;
    return o;
}

int mf_seq_conv(MfSeq *s, MfSpecTab *t, const char *prefix, int Cout, int K, int stride, int zero_init) {
    MfSeqOp *o = seq_push(s, MF_SEQ_CONV);
    if (!o) return 0;
    char name[MF_NN_NAME_MAX];
    snprintf(name, sizeof name, "%s.%d", prefix, s->n - 1);
    if (mf_kconv_add(&o->conv, t, name, s->C, Cout, K, stride) == (size_t)-1) return 0;
    o->zero_init = zero_init;
    o->Co = s->C = Cout;
    o->Ho = s->H = mf_conv2d_out_size(s->H, K, stride);
    o->Wo = s->W = mf_conv2d_out_size(s->W, K, stride);
    return 1;
}

int mf_seq_res(MfSeq *s, MfSpecTab *t, const char *prefix, int Cout) {
    MfSeqOp *o = seq_push(s, MF_SEQ_RES);
    if (!o) return 0;
    char name[MF_NN_NAME_MAX];
    snprintf(name, sizeof name, "%s.%d", prefix, s->n - 1);
    MfResBlockDims d = {1, s->C, Cout, s->H, s->W, 0, s->G, MF_KNORM_EPS};
    MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
    int k = mf_resblock_specs(specs, name, &d);
    o->rd = d;
    o->roff = mf_spectab_add_many(t, specs, k);
    if (o->roff == (size_t)-1) return 0;
    o->Co = s->C = Cout;
    return 1;
}

int mf_seq_up(MfSeq *s) {
    MfSeqOp *o = seq_push(s, MF_SEQ_UP);
    if (!o) return 0;
    o->Ho = s->H = 2 * s->H, o->Wo = s->W = 2 * s->W;
    return 1;
}

int mf_seq_norm(MfSeq *s, MfSpecTab *t, const char *prefix) {
    MfSeqOp *o = seq_push(s, MF_SEQ_NORM);
    if (!o) return 0;
    char name[MF_NN_NAME_MAX];
    snprintf(name, sizeof name, "%s.%d", prefix, s->n - 1);
    return mf_knorm_add(&o->norm, t, name, s->C, s->G) != (size_t)-1;
}

int mf_seq_silu(MfSeq *s) { return seq_push(s, MF_SEQ_SILU) != NULL; }

void mf_seq_init(const MfSeq *s, float *params, unsigned long long seed) {
    for (int i = 0; i < s->n; ++i) {
        const MfSeqOp *o = &s->op[i];
        unsigned long long sd = seed * 131 + (unsigned long long)i;
        if (o->kind == MF_SEQ_CONV) mf_kconv_init(&o->conv, params, sd, o->zero_init);
        if (o->kind == MF_SEQ_NORM) mf_knorm_init(&o->norm, params);
        if (o->kind == MF_SEQ_RES) {
            MfResBlockW rw;
            mf_resblock_bind(&rw, &o->rd, params + o->roff);
            mf_resblock_init(&rw, &o->rd, sd);
        }
    }
}

/* Binds (or, with base NULL, counts) the work buffers for batch B; returns the floats needed. */
static size_t seq_layout(const MfSeq *s, MfSeqWork *w, float *base, int B) {
    MfArena ar = {base, 0};
    size_t col = 0, gmax = (size_t)B * s->C0 * s->H0 * s->W0;
    for (int i = 0; i < s->n; ++i) {
        const MfSeqOp *o = &s->op[i];
        size_t on = (size_t)B * o->Co * o->Ho * o->Wo;
        if (on > gmax) gmax = on;
        w->out[i] = NULL;
        if (o->kind == MF_SEQ_RES) {
            MfResBlockDims d = o->rd;
            d.B = B;
            float *m = mf_arena_take(&ar, mf_resblock_acts_floats(&d));
            if (m) mf_resblock_acts_bind(&w->res[i], &d, m);
            w->out[i] = mf_arena_take(&ar, on);
        } else if (o->kind == MF_SEQ_NORM) {
            mf_knorm_acts(&w->norm[i], &ar, B, o->Ci, o->Hi * o->Wi, s->G);
            w->out[i] = w->norm[i].a;
        } else {
            if (o->kind == MF_SEQ_CONV) {
                size_t c = mf_kconv_col(&o->conv, B, o->Hi, o->Wi);
                if (c > col) col = c;
            }
            w->out[i] = mf_arena_take(&ar, on);
        }
    }
    w->col = mf_arena_take(&ar, col);
    w->gA = mf_arena_take(&ar, gmax);
    w->gB = mf_arena_take(&ar, gmax);
    return ar.used;
}

float *mf_seq_forward(const MfSeq *s, const float *params, MfSeqWork *w, const float *in, int B) {
    size_t need = seq_layout(s, w, NULL, B);
    if (need > w->cap) {
        float *m = realloc(w->mem, need * sizeof(float));
        if (!m) return NULL;
        w->mem = m, w->cap = need;
    }
    seq_layout(s, w, w->mem, B);
    w->B = B, w->in = in;
    const float *x = in;
    for (int i = 0; i < s->n; ++i) {
        const MfSeqOp *o = &s->op[i];
        size_t nin = (size_t)B * o->Ci * o->Hi * o->Wi;
        switch (o->kind) {
        case MF_SEQ_CONV: mf_kconv_forward(&o->conv, params, w->out[i], w->col, x, B, o->Hi, o->Wi); break;
        case MF_SEQ_RES: {
            MfResBlockDims d = o->rd;
            d.B = B;
            MfResBlockW rw;
            mf_resblock_bind(&rw, &d, (float *)params + o->roff);
            mf_resblock_forward(w->out[i], &w->res[i], x, NULL, &rw, &d);
            break;
        }
        case MF_SEQ_UP: mf_upsample2x_forward(w->out[i], x, B, o->Ci, o->Hi, o->Wi); break;
        case MF_SEQ_NORM: mf_knorm_forward(&o->norm, params, &w->norm[i], x, B, o->Hi * o->Wi); break;
        case MF_SEQ_SILU: mf_silu_forward(w->out[i], x, nin); break;
        }
        x = w->out[i];
    }
    return (float *)x;
}

void mf_seq_backward(const MfSeq *s, const float *params, float *grads, MfSeqWork *w, const float *dout,
                     float *din) {
    int B = w->B;
    const float *g = dout;
    for (int i = s->n - 1; i >= 0; --i) {
        const MfSeqOp *o = &s->op[i];
        const float *x = i > 0 ? w->out[i - 1] : w->in;
        size_t nin = (size_t)B * o->Ci * o->Hi * o->Wi;
        float *dst = (g == w->gA) ? w->gB : w->gA; /* scratch for the input gradient */
        if (i == 0 && din) dst = din;
        else if (i == 0 && o->kind == MF_SEQ_CONV) dst = NULL;
        else memset(dst, 0, nin * sizeof(float));
        switch (o->kind) {
        case MF_SEQ_CONV:
            mf_kconv_backward(&o->conv, params, grads, dst, w->col, g, x, B, o->Hi, o->Wi);
            break;
        case MF_SEQ_RES: {
            MfResBlockDims d = o->rd;
            d.B = B;
            MfResBlockW rw, rg;
            mf_resblock_bind(&rw, &d, (float *)params + o->roff);
            mf_resblock_bind(&rg, &d, grads ? grads + o->roff : NULL);
            mf_resblock_backward(dst, NULL, &rg, &w->res[i], g, x, NULL, &rw, &d);
            break;
        }
        case MF_SEQ_UP: mf_upsample2x_backward(dst, g, B, o->Ci, o->Hi, o->Wi); break;
        case MF_SEQ_NORM: mf_knorm_backward(&o->norm, params, grads, &w->norm[i], dst, g, x, B, o->Hi * o->Wi); break;
        case MF_SEQ_SILU: mf_silu_backward(dst, g, x, nin); break;
        }
        g = dst;
    }
}

void mf_seq_work_free(MfSeqWork *w) {
    free(w->mem);
    memset(w, 0, sizeof *w);
}
