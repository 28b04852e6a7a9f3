/* mf_nn_dnnl: oneDNN convolution primitives behind mf_conv2d_* (see mf_nn_dnnl.h). Compiled to
 * nothing without MF_HAVE_DNNL.
 *
 * oneDNN picks the layouts of its arguments (format "any"): on AVX-512 / AVX2 CPUs its direct
 * convolutions work on channel-blocked tensors (nChw16c / nChw8c), and in plain NCHW it falls back
 * to im2col + its own sgemm, no faster than ours. An argument whose chosen layout differs from the
 * caller's plain one is copied (a reorder primitive) into a blocked buffer in the thread's scratch
 * before the call (inputs) or out of it after (outputs). Measured at the prior's shapes, one
 * thread: the blocked convolutions with these copies run 1.7-3x faster than the plain-layout
 * ones (reports/perf/nn-dnnl-*.md against nn-onednn.md). */
#include "nn/mf_nn_dnnl.h"

#ifdef MF_HAVE_DNNL
#include <oneapi/dnnl/dnnl.h>
#include <oneapi/dnnl/dnnl_debug.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "nn/mf_nn.h"

/* One argument of a primitive: user carries the caller's plain array (its handle set per call);
 * when oneDNN wants another layout, inner is that layout (its handle set to the scratch per call),
 * reo copies user -> inner (input) or inner -> user (output), and bytes is inner's size rounded up
 * to 64. */
typedef struct {
    int kind, out; /* DNNL_ARG_*, 1 for the output */
    dnnl_memory_t user, inner;
    dnnl_primitive_t reo;
    size_t bytes;
} DnArg;

typedef struct {
    dnnl_primitive_t prim; /* NULL until first use */
    DnArg arg[4];
    int nargs;
    size_t inner_bytes; /* sum of the args' bytes */
} DnPrim;

/* One conv shape's primitives: 0 forward, 1 backward data, 2 backward weights. */
typedef struct DnnlConv {
    int B, Cin, H, W, Cout, K, stride, bias; /* the key */
    dnnl_primitive_desc_t fwd_pd;            /* also the hint of the backward primitives */
    DnPrim p[3];
    struct DnnlConv *next;
} DnnlConv;

typedef struct {
    dnnl_engine_t eng;
    dnnl_stream_t st;
    DnnlConv *head;
    unsigned char *scratch; // (cap) bytes, 64-aligned: blocked copies, then dw or din before adding
    size_t cap;
} DnnlState;

/* Per thread: memory objects' handles are set per call, so threads must not share them. */
static _Thread_local DnnlState g_dn;
static int g_threads; /* 0: OpenMP's default */

void mf_nn_dnnl_set_threads(int n) { g_threads = n > 0 ? n : 1; }

static int dn_fail(dnnl_status_t s, const char *what) {
    return mf_fail(s == dnnl_out_of_memory ? MF_ENOMEM : MF_EEXT, "oneDNN: %s: %s", what, dnnl_status2str(s));
}

#define DN_TRY(call)                                       \
    do {                                                   \
        dnnl_status_t s_ = (call);                         \
        if (s_ != dnnl_success) return dn_fail(s_, #call); \
    } while (0)

static void prim_destroy(DnPrim *p) {
    if (p->prim) dnnl_primitive_destroy(p->prim);
    for (int i = 0; i < p->nargs; ++i) {
        DnArg *a = &p->arg[i];
        if (a->reo) dnnl_primitive_destroy(a->reo);
        if (a->inner) dnnl_memory_destroy(a->inner);
        if (a->user) dnnl_memory_destroy(a->user);
    }
    memset(p, 0, sizeof *p);
}

static void conv_destroy(DnnlConv *c) {
    for (int k = 0; k < 3; ++k) prim_destroy(&c->p[k]);
    if (c->fwd_pd) dnnl_primitive_desc_destroy(c->fwd_pd);
    free(c);
}

void mf_nn_dnnl_release(void) {
    for (DnnlConv *c = g_dn.head, *n; c; c = n) n = c->next, conv_destroy(c);
    if (g_dn.st) dnnl_stream_destroy(g_dn.st);
    if (g_dn.eng) dnnl_engine_destroy(g_dn.eng);
    free(g_dn.scratch);
    memset(&g_dn, 0, sizeof g_dn);
}

static int dn_engine(void) {
    if (g_dn.st) return MF_OK;
    if (!g_dn.eng) DN_TRY(dnnl_engine_create(&g_dn.eng, dnnl_cpu, 0));
    DN_TRY(dnnl_stream_create(&g_dn.st, g_dn.eng, dnnl_stream_default_flags));
    return MF_OK;
}

/* The plain descriptors of c: src (B, Cin, H, W), weights (Cout, Cin, K, K), bias (Cout), dst. */
static int plain_mds(const DnnlConv *c, dnnl_memory_desc_t md[4], dnnl_format_tag_t act, dnnl_format_tag_t wei) {
    int Ho = mf_conv2d_out_size(c->H, c->K, c->stride), Wo = mf_conv2d_out_size(c->W, c->K, c->stride);
    dnnl_dims_t di = {c->B, c->Cin, c->H, c->W}, dw = {c->Cout, c->Cin, c->K, c->K}, db = {c->Cout},
                dout = {c->B, c->Cout, Ho, Wo};
    DN_TRY(dnnl_memory_desc_init_by_tag(&md[0], 4, di, dnnl_f32, act));
    DN_TRY(dnnl_memory_desc_init_by_tag(&md[1], 4, dw, dnnl_f32, wei));
    DN_TRY(dnnl_memory_desc_init_by_tag(&md[2], 1, db, dnnl_f32, dnnl_x));
    DN_TRY(dnnl_memory_desc_init_by_tag(&md[3], 4, dout, dnnl_f32, act));
    return MF_OK;
}

/* The convolution descriptor of c (layouts left to oneDNN); kind: 0 forward, 1 backward data,
 * 2 backward weights. */
static int conv_desc(dnnl_convolution_desc_t *d, const DnnlConv *c, int kind) {
    int Ho = mf_conv2d_out_size(c->H, c->K, c->stride), Wo = mf_conv2d_out_size(c->W, c->K, c->stride), p = c->K / 2;
    /* the right/bottom padding that makes oneDNN's (H + pl + pr - K)/stride + 1 equal Ho */
    dnnl_dims_t strides = {c->stride, c->stride}, pl = {p, p};
    dnnl_dims_t pr = {(Ho - 1) * c->stride + c->K - c->H - p, (Wo - 1) * c->stride + c->K - c->W - p};
    dnnl_memory_desc_t md[4];
    int rc = plain_mds(c, md, dnnl_format_tag_any, dnnl_format_tag_any);
    if (rc) return rc;
    const dnnl_memory_desc_t *bias = c->bias ? &md[2] : NULL;
    if (kind == 0)
        DN_TRY(dnnl_convolution_forward_desc_init(d, dnnl_forward_training, dnnl_convolution_direct, &md[0], &md[1],
                                                  bias, &md[3], strides, pl, pr));
    else if (kind == 1)
        DN_TRY(dnnl_convolution_backward_data_desc_init(d, dnnl_convolution_direct, &md[0], &md[1], &md[3], strides,
                                                        pl, pr));
    else
        DN_TRY(dnnl_convolution_backward_weights_desc_init(d, dnnl_convolution_direct, &md[0], &md[1], NULL, &md[3],
                                                           strides, pl, pr));
    return MF_OK;
}

/* Adds argument kind to p: user in the plain layout `plain`, and inner + reorder when pd wants another. */
static int arg_add(DnPrim *p, const_dnnl_primitive_desc_t pd, int kind, int out, const dnnl_memory_desc_t *plain) {
    DnArg *a = &p->arg[p->nargs++];
    a->kind = kind, a->out = out;
    DN_TRY(dnnl_memory_create(&a->user, plain, g_dn.eng, DNNL_MEMORY_NONE));
    const dnnl_memory_desc_t *want = dnnl_primitive_desc_query_md(pd, dnnl_query_exec_arg_md, kind);
    if (!want) return mf_fail(MF_EEXT, "oneDNN: no descriptor for convolution argument %d", kind);
    if (dnnl_memory_desc_equal(want, plain)) return MF_OK;
    DN_TRY(dnnl_memory_create(&a->inner, want, g_dn.eng, DNNL_MEMORY_NONE));
    a->bytes = (dnnl_memory_desc_get_size(want) + 63) / 64 * 64;
    p->inner_bytes += a->bytes;
    dnnl_primitive_desc_t rpd;
    const dnnl_memory_desc_t *from = out ? want : plain, *to = out ? plain : want;
    DN_TRY(dnnl_reorder_primitive_desc_create(&rpd, from, g_dn.eng, to, g_dn.eng, NULL));
    dnnl_status_t s = dnnl_primitive_create(&a->reo, rpd);
    dnnl_primitive_desc_destroy(rpd);
    if (s != dnnl_success) return dn_fail(s, "reorder primitive");
    return MF_OK;
}

/* Makes c's primitive `kind` (0 forward, 1 backward data, 2 backward weights) and its arguments. */
static int prim_make(DnnlConv *c, int kind) {
    DnPrim *p = &c->p[kind];
    dnnl_primitive_desc_t pd = c->fwd_pd;
    dnnl_memory_desc_t md[4];
    int rc = plain_mds(c, md, dnnl_nchw, dnnl_oihw);
    if (rc) return rc;
    if (kind) {
        dnnl_convolution_desc_t d;
        if ((rc = conv_desc(&d, c, kind))) return rc;
        DN_TRY(dnnl_primitive_desc_create(&pd, &d, NULL, g_dn.eng, c->fwd_pd));
    }
    if (kind == 0) {
        rc = arg_add(p, pd, DNNL_ARG_SRC, 0, &md[0]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_WEIGHTS, 0, &md[1]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_DST, 1, &md[3]);
        if (!rc && c->bias) rc = arg_add(p, pd, DNNL_ARG_BIAS, 0, &md[2]);
    } else if (kind == 1) {
        rc = arg_add(p, pd, DNNL_ARG_DIFF_DST, 0, &md[3]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_WEIGHTS, 0, &md[1]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_DIFF_SRC, 1, &md[0]);
    } else {
        rc = arg_add(p, pd, DNNL_ARG_SRC, 0, &md[0]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_DIFF_DST, 0, &md[3]);
        if (!rc) rc = arg_add(p, pd, DNNL_ARG_DIFF_WEIGHTS, 1, &md[1]);
    }
    dnnl_status_t s = rc ? dnnl_success : dnnl_primitive_create(&p->prim, pd);
    if (kind) dnnl_primitive_desc_destroy(pd);
    if (!rc && s != dnnl_success) rc = dn_fail(s, "convolution primitive");
    if (rc) prim_destroy(p);
    return rc;
}

int mf_nn_dnnl_entries(void) {
    int n = 0;
    for (const DnnlConv *c = g_dn.head; c; c = c->next) ++n;
    return n;
}

/* The entry of a shape (moved to the front of the list), made on first use. bias: 1 or 0 for a
 * forward with or without one; -1 (the backward passes, which take no bias) for an entry with
 * either, so a biased layer's backward shares its forward's entry. */
static int conv_get(DnnlConv **out, int B, int Cin, int H, int W, int Cout, int K, int stride, int bias) {
    int rc = dn_engine();
    if (rc) return rc;
    for (DnnlConv **pp = &g_dn.head; *pp; pp = &(*pp)->next) {
        DnnlConv *c = *pp;
        if (c->B == B && c->Cin == Cin && c->H == H && c->W == W && c->Cout == Cout && c->K == K && c->stride == stride &&
            (bias < 0 || c->bias == bias)) {
            *pp = c->next, c->next = g_dn.head, g_dn.head = c;
            *out = c;
            return MF_OK;
        }
    }
    DnnlConv *c = calloc(1, sizeof *c);
    if (!c) return mf_fail(MF_ENOMEM, "oneDNN conv: out of memory");
    *c = (DnnlConv){.B = B, .Cin = Cin, .H = H, .W = W, .Cout = Cout, .K = K, .stride = stride, .bias = bias > 0};
    dnnl_convolution_desc_t fd;
    dnnl_status_t s = dnnl_success;
    if ((rc = conv_desc(&fd, c, 0)) || (s = dnnl_primitive_desc_create(&c->fwd_pd, &fd, NULL, g_dn.eng, NULL))) {
        conv_destroy(c);
        return rc ? rc : dn_fail(s, "convolution forward primitive descriptor");
    }
    c->next = g_dn.head, g_dn.head = c;
    *out = c;
    return MF_OK;
}

/* 64-aligned scratch of at least n bytes (its contents are not kept). */
static unsigned char *scratch(size_t n) {
    if (n > g_dn.cap) {
        free(g_dn.scratch);
        g_dn.cap = (n + 63) / 64 * 64;
        g_dn.scratch = aligned_alloc(64, g_dn.cap);
        if (!g_dn.scratch) g_dn.cap = 0;
    }
    return g_dn.scratch;
}

/* Runs primitive kind of c on the plain arrays h[i] (args in prim_make's order): inputs copied to
 * their inner layouts first, the output copied back after. extra > 0: the output goes instead to
 * the first `extra` floats of the scratch, returned in *ex, for a caller that adds it to its own. */
static int conv_exec_now(DnnlConv *c, int kind, void *const *h, size_t extra, float **ex) {
    DnPrim *p = &c->p[kind];
    int rc;
    if (!p->prim && (rc = prim_make(c, kind))) return rc;
    size_t off = (extra * sizeof(float) + 63) / 64 * 64;
    unsigned char *s = scratch(off + p->inner_bytes);
    if (!s) return mf_fail(MF_ENOMEM, "oneDNN conv: out of memory (%zu bytes of scratch)", off + p->inner_bytes);
    if (extra) *ex = (float *)s;
    dnnl_exec_arg_t args[4];
    for (int i = 0; i < p->nargs; ++i) {
        DnArg *a = &p->arg[i];
        DN_TRY(dnnl_memory_set_data_handle(a->user, extra && a->out ? (void *)s : h[i]));
        if (a->inner) {
            DN_TRY(dnnl_memory_set_data_handle(a->inner, s + off));
            off += a->bytes;
        }
        args[i] = (dnnl_exec_arg_t){a->kind, a->inner ? a->inner : a->user};
    }
    for (int i = 0; i < p->nargs; ++i) {
        DnArg *a = &p->arg[i];
        dnnl_exec_arg_t r[2] = {{DNNL_ARG_FROM, a->user}, {DNNL_ARG_TO, a->inner}};
        if (a->reo && !a->out) DN_TRY(dnnl_primitive_execute(a->reo, g_dn.st, 2, r));
    }
    DN_TRY(dnnl_primitive_execute(p->prim, g_dn.st, p->nargs, args));
    for (int i = 0; i < p->nargs; ++i) {
        DnArg *a = &p->arg[i];
        dnnl_exec_arg_t r[2] = {{DNNL_ARG_FROM, a->inner}, {DNNL_ARG_TO, a->user}};
        if (a->reo && a->out) DN_TRY(dnnl_primitive_execute(a->reo, g_dn.st, 2, r));
    }
    DN_TRY(dnnl_stream_wait(g_dn.st));
    return MF_OK;
}

/* conv_exec_now with oneDNN's OpenMP threads set to g_threads for the call (the caller's count
 * restored after, so OpenMP regions elsewhere keep theirs). */
static int conv_exec(DnnlConv *c, int kind, void *const *h, size_t extra, float **ex) {
    int was = omp_get_max_threads();
    if (g_threads && g_threads != was) omp_set_num_threads(g_threads);
    int rc = conv_exec_now(c, kind, h, extra, ex);
    if (g_threads && g_threads != was) omp_set_num_threads(was);
    return rc;
}

int mf_nn_dnnl_conv_forward(float *out, const float *in, const float *w, const float *bias, int B, int Cin, int H,
                            int W, int Cout, int K, int stride) {
    DnnlConv *c;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, bias != NULL);
    void *h[4] = {(void *)in, (void *)w, out, (void *)bias};
    return rc ? rc : conv_exec(c, 0, h, 0, NULL);
}

int mf_nn_dnnl_conv_backward_data(float *din, int acc, const float *dout, const float *w, int B, int Cin, int H,
                                  int W, int Cout, int K, int stride) {
    DnnlConv *c;
    size_t n = (size_t)B * Cin * H * W;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, -1);
    if (rc) return rc;
    if (!acc) {
        void *h[3] = {(void *)dout, (void *)w, din};
        return conv_exec(c, 1, h, 0, NULL);
    }
    float *d = NULL;
    void *h[3] = {(void *)dout, (void *)w, NULL};
    if ((rc = conv_exec(c, 1, h, n, &d))) return rc;
#pragma omp simd
    for (size_t i = 0; i < n; ++i) din[i] += d[i];
    return MF_OK;
}

int mf_nn_dnnl_conv_backward_weights(float *dw, const float *dout, const float *in, int B, int Cin, int H, int W,
                                     int Cout, int K, int stride) {
    DnnlConv *c;
    size_t n = (size_t)Cout * Cin * K * K;
    float *d = NULL;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, -1);
    void *h[3] = {(void *)in, (void *)dout, NULL};
    if (rc || (rc = conv_exec(c, 2, h, n, &d))) return rc;
#pragma omp simd
    for (size_t i = 0; i < n; ++i) dw[i] += d[i];
    return MF_OK;
}

#else
int mf_nn_dnnl_entries(void) { return 0; }
#endif
