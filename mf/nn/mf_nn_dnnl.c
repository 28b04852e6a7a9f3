/* mf_nn_dnnl: oneDNN convolution primitives behind mf_conv2d_* (see mf_nn_dnnl.h). Compiled to
 * nothing without MF_HAVE_DNNL. */
#include "nn/mf_nn_dnnl.h"

#ifdef MF_HAVE_DNNL
#include <oneapi/dnnl/dnnl.h>
#include <oneapi/dnnl/dnnl_debug.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "nn/mf_nn.h"

/* One conv shape's primitives. The four memory objects carry the descriptors only; each call sets
 * their data handles: act_in is src or diff_src, act_out dst or diff_dst, wei weights or
 * diff_weights. */
typedef struct DnnlConv {
    int B, Cin, H, W, Cout, K, stride, bias; /* the key */
    dnnl_primitive_desc_t fwd_pd;            /* also the hint of the backward primitives */
    dnnl_primitive_t fwd, bwd_d, bwd_w;      /* created on first use */
    dnnl_memory_t act_in, wei, bias_m, act_out;
    struct DnnlConv *next;
} DnnlConv;

typedef struct {
    dnnl_engine_t eng;
    dnnl_stream_t st;
    DnnlConv *head;
    float *scratch; // (cap) dw or din before they are added to the caller's
    size_t cap;
} DnnlState;

/* Per thread: memory objects' handles are set per call, so threads must not share them. */
static _Thread_local DnnlState g_dn;

static int dn_fail(dnnl_status_t s, const char *what) {
    return mf_fail(s == dnnl_out_of_memory ? MF_ENOMEM : MF_EEXT, "oneDNN: %s: %s", what, dnnl_status2str(s));
}

#define DN_TRY(call)                                     \
    do {                                                 \
        dnnl_status_t s_ = (call);                       \
        if (s_ != dnnl_success) return dn_fail(s_, #call); \
    } while (0)

static void conv_destroy(DnnlConv *c) {
    if (c->fwd) dnnl_primitive_destroy(c->fwd);
    if (c->bwd_d) dnnl_primitive_destroy(c->bwd_d);
    if (c->bwd_w) dnnl_primitive_destroy(c->bwd_w);
    if (c->fwd_pd) dnnl_primitive_desc_destroy(c->fwd_pd);
    dnnl_memory_t m[4] = {c->act_in, c->wei, c->bias_m, c->act_out};
    for (int i = 0; i < 4; ++i)
        if (m[i]) dnnl_memory_destroy(m[i]);
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

static int mem_new(dnnl_memory_t *m, int nd, const dnnl_dims_t dims, dnnl_format_tag_t tag) {
    dnnl_memory_desc_t md;
    DN_TRY(dnnl_memory_desc_init_by_tag(&md, nd, dims, dnnl_f32, tag));
    DN_TRY(dnnl_memory_create(m, &md, g_dn.eng, DNNL_MEMORY_NONE));
    return MF_OK;
}

static const dnnl_memory_desc_t *mem_md(dnnl_memory_t m) {
    const dnnl_memory_desc_t *md = NULL;
    dnnl_memory_get_memory_desc(m, &md);
    return md;
}

/* The convolution descriptor of c; kind: 0 forward, 1 backward data, 2 backward weights. */
static int conv_desc(dnnl_convolution_desc_t *d, const DnnlConv *c, int kind) {
    int Ho = mf_conv2d_out_size(c->H, c->K, c->stride), Wo = mf_conv2d_out_size(c->W, c->K, c->stride), p = c->K / 2;
    /* the right/bottom padding that makes oneDNN's (H + pl + pr - K)/stride + 1 equal Ho */
    dnnl_dims_t strides = {c->stride, c->stride}, pl = {p, p};
    dnnl_dims_t pr = {(Ho - 1) * c->stride + c->K - c->H - p, (Wo - 1) * c->stride + c->K - c->W - p};
    const dnnl_memory_desc_t *src = mem_md(c->act_in), *wei = mem_md(c->wei), *dst = mem_md(c->act_out);
    const dnnl_memory_desc_t *bias = c->bias ? mem_md(c->bias_m) : NULL;
    if (kind == 0)
        DN_TRY(dnnl_convolution_forward_desc_init(d, dnnl_forward_training, dnnl_convolution_direct, src, wei, bias, dst,
                                                  strides, pl, pr));
    else if (kind == 1)
        DN_TRY(dnnl_convolution_backward_data_desc_init(d, dnnl_convolution_direct, src, wei, dst, strides, pl, pr));
    else
        DN_TRY(dnnl_convolution_backward_weights_desc_init(d, dnnl_convolution_direct, src, wei, NULL, dst, strides, pl,
                                                           pr));
    return MF_OK;
}

/* The entry of a shape (moved to the front of the list), made on first use. */
static int conv_get(DnnlConv **out, int B, int Cin, int H, int W, int Cout, int K, int stride, int bias) {
    int rc = dn_engine();
    if (rc) return rc;
    for (DnnlConv **pp = &g_dn.head; *pp; pp = &(*pp)->next) {
        DnnlConv *c = *pp;
        if (c->B == B && c->Cin == Cin && c->H == H && c->W == W && c->Cout == Cout && c->K == K && c->stride == stride &&
            c->bias == bias) {
            *pp = c->next, c->next = g_dn.head, g_dn.head = c;
            *out = c;
            return MF_OK;
        }
    }
    DnnlConv *c = calloc(1, sizeof *c);
    if (!c) return mf_fail(MF_ENOMEM, "oneDNN conv: out of memory");
    *c = (DnnlConv){.B = B, .Cin = Cin, .H = H, .W = W, .Cout = Cout, .K = K, .stride = stride, .bias = bias};
    int Ho = mf_conv2d_out_size(H, K, stride), Wo = mf_conv2d_out_size(W, K, stride);
    dnnl_dims_t di = {B, Cin, H, W}, dwt = {Cout, Cin, K, K}, db = {Cout}, dout = {B, Cout, Ho, Wo};
    dnnl_convolution_desc_t fd;
    if ((rc = mem_new(&c->act_in, 4, di, dnnl_nchw)) || (rc = mem_new(&c->wei, 4, dwt, dnnl_oihw)) ||
        (rc = mem_new(&c->bias_m, 1, db, dnnl_x)) || (rc = mem_new(&c->act_out, 4, dout, dnnl_nchw)) ||
        (rc = conv_desc(&fd, c, 0))) {
        conv_destroy(c);
        return rc;
    }
    dnnl_status_t s = dnnl_primitive_desc_create(&c->fwd_pd, &fd, NULL, g_dn.eng, NULL);
    if (s != dnnl_success) {
        conv_destroy(c);
        return dn_fail(s, "convolution forward primitive descriptor");
    }
    c->next = g_dn.head, g_dn.head = c;
    *out = c;
    return MF_OK;
}

/* c's primitive of kind (0 forward, 1 backward data, 2 backward weights), made on first use. */
static int conv_prim(dnnl_primitive_t *out, DnnlConv *c, int kind) {
    dnnl_primitive_t *p = kind == 0 ? &c->fwd : kind == 1 ? &c->bwd_d : &c->bwd_w;
    if (!*p) {
        dnnl_primitive_desc_t pd = c->fwd_pd;
        if (kind) {
            dnnl_convolution_desc_t d;
            int rc = conv_desc(&d, c, kind);
            if (rc) return rc;
            DN_TRY(dnnl_primitive_desc_create(&pd, &d, NULL, g_dn.eng, c->fwd_pd));
        }
        dnnl_status_t s = dnnl_primitive_create(p, pd);
        if (kind) dnnl_primitive_desc_destroy(pd);
        if (s != dnnl_success) return dn_fail(s, "convolution primitive");
    }
    *out = *p;
    return MF_OK;
}

/* Binds the handles (NULL: left as is) and runs prim on the thread's stream. */
static int conv_run(DnnlConv *c, dnnl_primitive_t prim, int nargs, const dnnl_exec_arg_t *args, const void *act_in,
                    const void *wei, const void *bias, const void *act_out) {
    const void *h[4] = {act_in, wei, bias, act_out};
    dnnl_memory_t m[4] = {c->act_in, c->wei, c->bias_m, c->act_out};
    for (int i = 0; i < 4; ++i)
        if (h[i]) DN_TRY(dnnl_memory_set_data_handle(m[i], (void *)h[i]));
    DN_TRY(dnnl_primitive_execute(prim, g_dn.st, nargs, args));
    DN_TRY(dnnl_stream_wait(g_dn.st));
    return MF_OK;
}

static float *scratch(size_t n) {
    if (n > g_dn.cap) {
        float *p = realloc(g_dn.scratch, n * sizeof(float));
        if (!p) return NULL;
        g_dn.scratch = p, g_dn.cap = n;
    }
    return g_dn.scratch;
}

int mf_nn_dnnl_conv_forward(float *out, const float *in, const float *w, const float *bias, int B, int Cin, int H,
                            int W, int Cout, int K, int stride) {
    DnnlConv *c;
    dnnl_primitive_t p;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, bias != NULL);
    if (rc || (rc = conv_prim(&p, c, 0))) return rc;
    dnnl_exec_arg_t a[] = {{DNNL_ARG_SRC, c->act_in}, {DNNL_ARG_WEIGHTS, c->wei}, {DNNL_ARG_DST, c->act_out},
                           {DNNL_ARG_BIAS, c->bias_m}};
    return conv_run(c, p, bias ? 4 : 3, a, in, w, bias, out);
}

int mf_nn_dnnl_conv_backward_data(float *din, int acc, const float *dout, const float *w, int B, int Cin, int H,
                                  int W, int Cout, int K, int stride) {
    DnnlConv *c;
    dnnl_primitive_t p;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, 0);
    if (rc || (rc = conv_prim(&p, c, 1))) return rc;
    size_t n = (size_t)B * Cin * H * W;
    float *d = acc ? scratch(n) : din;
    if (!d) return mf_fail(MF_ENOMEM, "oneDNN conv backward data: out of memory (%zu floats)", n);
    dnnl_exec_arg_t a[] = {{DNNL_ARG_DIFF_DST, c->act_out}, {DNNL_ARG_WEIGHTS, c->wei}, {DNNL_ARG_DIFF_SRC, c->act_in}};
    if ((rc = conv_run(c, p, 3, a, d, w, NULL, dout))) return rc;
    if (acc)
#pragma omp simd
        for (size_t i = 0; i < n; ++i) din[i] += d[i];
    return MF_OK;
}

int mf_nn_dnnl_conv_backward_weights(float *dw, const float *dout, const float *in, int B, int Cin, int H, int W,
                                     int Cout, int K, int stride) {
    DnnlConv *c;
    dnnl_primitive_t p;
    int rc = conv_get(&c, B, Cin, H, W, Cout, K, stride, 0);
    if (rc || (rc = conv_prim(&p, c, 2))) return rc;
    size_t n = (size_t)Cout * Cin * K * K;
    float *d = scratch(n);
    if (!d) return mf_fail(MF_ENOMEM, "oneDNN conv backward weights: out of memory (%zu floats)", n);
    dnnl_exec_arg_t a[] = {{DNNL_ARG_SRC, c->act_in}, {DNNL_ARG_DIFF_DST, c->act_out}, {DNNL_ARG_DIFF_WEIGHTS, c->wei}};
    if ((rc = conv_run(c, p, 3, a, in, d, NULL, dout))) return rc;
#pragma omp simd
    for (size_t i = 0; i < n; ++i) dw[i] += d[i];
    return MF_OK;
}

#else
typedef int mf_nn_dnnl_unused; /* ISO C wants a translation unit to declare something */
#endif
