/* mf_nn_blocks: the residual block and AdamW of mf_nn.h. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "nn/mf_nn.h"

/* ---- residual block ------------------------------------------------------------------------ */

int mf_resblock_specs(MfTensorSpec *specs, const char *prefix, const MfResBlockDims *d) {
    int n = 0;
    int ci[1] = {d->Cin}, co[1] = {d->Cout};
    int k1[4] = {d->Cout, d->Cin, 3, 3}, k2[4] = {d->Cout, d->Cout, 3, 3};
    int kt[2] = {d->Cout, d->Ct}, ks[4] = {d->Cout, d->Cin, 1, 1};
    mf_spec_set(&specs[n++], prefix, "gn1.w", 1, ci);
    mf_spec_set(&specs[n++], prefix, "gn1.b", 1, ci);
    mf_spec_set(&specs[n++], prefix, "conv1.w", 4, k1);
    mf_spec_set(&specs[n++], prefix, "conv1.b", 1, co);
    if (d->Ct > 0) {
        mf_spec_set(&specs[n++], prefix, "temb.w", 2, kt);
        mf_spec_set(&specs[n++], prefix, "temb.b", 1, co);
    }
    mf_spec_set(&specs[n++], prefix, "gn2.w", 1, co);
    mf_spec_set(&specs[n++], prefix, "gn2.b", 1, co);
    mf_spec_set(&specs[n++], prefix, "conv2.w", 4, k2);
    mf_spec_set(&specs[n++], prefix, "conv2.b", 1, co);
    if (d->Cin != d->Cout) {
        mf_spec_set(&specs[n++], prefix, "skip.w", 4, ks);
        mf_spec_set(&specs[n++], prefix, "skip.b", 1, co);
    }
    return n;
}

void mf_resblock_bind(MfResBlockW *w, const MfResBlockDims *d, float *mem) {
    MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
    int n = mf_resblock_specs(specs, "", d);
    float **all[MF_RESBLOCK_NPARAMS] = {&w->gn1_w, &w->gn1_b, &w->conv1_w, &w->conv1_b,
                                        &w->temb_w, &w->temb_b, &w->gn2_w, &w->gn2_b,
                                        &w->conv2_w, &w->conv2_b, &w->skip_w, &w->skip_b};
    float *slots[MF_RESBLOCK_NPARAMS] = {0};
    if (mem) mf_params_bind(slots, specs, n, mem);
    int k = 0;
    for (int i = 0; i < MF_RESBLOCK_NPARAMS; ++i) {
        int present = !((i == 4 || i == 5) && d->Ct <= 0) && !((i == 10 || i == 11) && d->Cin == d->Cout);
        *all[i] = present ? slots[k++] : NULL;
    }
}

static size_t resblock_col_floats(const MfResBlockDims *d) {
    size_t a = mf_conv2d_col_floats(d->B, d->Cin, d->H, d->W, d->Cout, 3, 1);
    size_t b = mf_conv2d_col_floats(d->B, d->Cout, d->H, d->W, d->Cout, 3, 1);
    size_t c = mf_conv2d_col_floats(d->B, d->Cin, d->H, d->W, d->Cout, 1, 1);
    size_t m = a > b ? a : b;
    return m > c ? m : c;
}

size_t mf_resblock_acts_floats(const MfResBlockDims *d) {
    size_t hw = (size_t)d->H * d->W, B = (size_t)d->B;
    size_t cm = (size_t)(d->Cin > d->Cout ? d->Cin : d->Cout);
    return 2 * B * d->Cin * hw + 4 * B * d->G + B * d->Ct + B * d->Cout + 3 * B * d->Cout * hw +
           resblock_col_floats(d) + 2 * B * cm * hw + B * (d->Cout + d->Ct);
}

void mf_resblock_acts_bind(MfResBlockActs *a, const MfResBlockDims *d, float *mem) {
    size_t hw = (size_t)d->H * d->W, B = (size_t)d->B;
    size_t cm = (size_t)(d->Cin > d->Cout ? d->Cin : d->Cout);
    float *p = mem;
#define TAKE(field, count) (a->field = p, p += (count))
    TAKE(s1, B * d->Cin * hw);
    TAKE(mean1, B * d->G);
    TAKE(rstd1, B * d->G);
    TAKE(a1, B * d->Cin * hw);
    TAKE(tsilu, B * d->Ct);
    TAKE(tproj, B * d->Cout);
    TAKE(c1, B * d->Cout * hw);
    TAKE(s2, B * d->Cout * hw);
    TAKE(mean2, B * d->G);
    TAKE(rstd2, B * d->G);
    TAKE(a2, B * d->Cout * hw);
    TAKE(col, resblock_col_floats(d));
    TAKE(gA, B * cm * hw);
    TAKE(gB, B * cm * hw);
    TAKE(gt, B * (d->Cout + d->Ct));
#undef TAKE
}

void mf_resblock_init(MfResBlockW *w, const MfResBlockDims *d, unsigned long long seed) {
    for (int c = 0; c < d->Cin; ++c) w->gn1_w[c] = 1.0f, w->gn1_b[c] = 0.0f;
    for (int c = 0; c < d->Cout; ++c) w->gn2_w[c] = 1.0f, w->gn2_b[c] = 0.0f;
    float b1 = 1.0f / sqrtf((float)(d->Cin * 9)), b2 = 1.0f / sqrtf((float)(d->Cout * 9));
    mf_nn_init_uniform(w->conv1_w, (size_t)d->Cout * d->Cin * 9, b1, seed * 16 + 1);
    mf_nn_init_uniform(w->conv1_b, (size_t)d->Cout, b1, seed * 16 + 2);
    mf_nn_init_uniform(w->conv2_w, (size_t)d->Cout * d->Cout * 9, b2, seed * 16 + 3);
    mf_nn_init_uniform(w->conv2_b, (size_t)d->Cout, b2, seed * 16 + 4);
    if (w->temb_w) {
        float bt = 1.0f / sqrtf((float)d->Ct);
        mf_nn_init_uniform(w->temb_w, (size_t)d->Cout * d->Ct, bt, seed * 16 + 5);
        mf_nn_init_uniform(w->temb_b, (size_t)d->Cout, bt, seed * 16 + 6);
    }
    if (w->skip_w) {
        float bs = 1.0f / sqrtf((float)d->Cin);
        mf_nn_init_uniform(w->skip_w, (size_t)d->Cout * d->Cin, bs, seed * 16 + 7);
        mf_nn_init_uniform(w->skip_b, (size_t)d->Cout, bs, seed * 16 + 8);
    }
}

void mf_resblock_forward(float *out, MfResBlockActs *a, const float *x, const float *temb,
                         const MfResBlockW *w, const MfResBlockDims *d) {
    int B = d->B, Ci = d->Cin, Co = d->Cout, H = d->H, W = d->W, HW = d->H * d->W;
    const float *tproj = NULL;
    mf_gnsilu_forward(a->a1, a->s1, a->mean1, a->rstd1, x, w->gn1_w, w->gn1_b, B, Ci, HW, d->G, d->eps);
    if (d->Ct > 0 && temb) {
        mf_silu_forward(a->tsilu, temb, (size_t)B * d->Ct);
        mf_linear_forward(a->tproj, a->tsilu, w->temb_w, w->temb_b, B, d->Ct, Co);
        tproj = a->tproj;
    }
    /* c1 = conv1(a1) + conv1_b + tproj[b] (broadcast over H, W), in the conv's copy pass */
    mf_conv2d_forward_ex(a->c1, a->col, a->a1, w->conv1_w, w->conv1_b, tproj, NULL, B, Ci, H, W, Co, 3, 1);
    mf_gnsilu_forward(a->a2, a->s2, a->mean2, a->rstd2, a->c1, w->gn2_w, w->gn2_b, B, Co, HW, d->G, d->eps);
    /* out = conv2(a2) + conv2_b + skip(x), the skip added in the conv's copy pass (a 1x1 skip conv is
     * computed into gA first, which is backward scratch) */
    const float *skip = x;
    if (w->skip_w) {
        mf_conv2d_forward(a->gA, a->col, x, w->skip_w, w->skip_b, B, Ci, H, W, Co, 1, 1);
        skip = a->gA;
    }
    mf_conv2d_forward_ex(out, a->col, a->a2, w->conv2_w, w->conv2_b, NULL, skip, B, Co, H, W, Co, 3, 1);
}

void mf_resblock_backward(float *dx, float *dtemb, MfResBlockW *g, MfResBlockActs *a,
                          const float *dout, const float *x, const float *temb, const MfResBlockW *w,
                          const MfResBlockDims *d) {
    int B = d->B, Ci = d->Cin, Co = d->Cout, H = d->H, W = d->W, HW = d->H * d->W;
    size_t nin = (size_t)B * Ci * HW;
    int has_t = d->Ct > 0 && temb;
    float *dtp = a->gt, *dts = a->gt + (size_t)B * Co; /* (B, Co) gradient of tproj, (B, Ct) of tsilu */
    /* skip path */
    if (w->skip_w)
        mf_conv2d_backward(dx, g->skip_w, g->skip_b, a->col, dout, x, w->skip_w, B, Ci, H, W, Co, 1, 1);
    else
        for (size_t i = 0; i < nin; ++i) dx[i] += dout[i];
    /* conv2: dA2 -> gA (written) */
    mf_conv2d_backward_ex(a->gA, 0, g->conv2_w, g->conv2_b, NULL, a->col, dout, a->a2, w->conv2_w, B, Co, H, W,
                          Co, 3, 1);
    /* GN2 + SiLU: dC1 -> gB (written) */
    mf_gnsilu_backward(a->gB, 0, g->gn2_w, g->gn2_b, a->gA, a->c1, a->s2, a->mean2, a->rstd2, w->gn2_w, w->gn2_b,
                       B, Co, HW, d->G);
    /* conv1: dA1 -> gA (written); dtproj (B, Co) = spatial sums of dC1, in the conv's bias pass */
    if (has_t) memset(dtp, 0, (size_t)B * Co * sizeof(float));
    mf_conv2d_backward_ex(a->gA, 0, g->conv1_w, g->conv1_b, has_t ? dtp : NULL, a->col, a->gB, a->a1, w->conv1_w,
                          B, Ci, H, W, Co, 3, 1);
    if (has_t) {
        memset(dts, 0, (size_t)B * d->Ct * sizeof(float));
        mf_linear_backward(dts, g->temb_w, g->temb_b, dtp, a->tsilu, w->temb_w, B, d->Ct, Co);
        if (dtemb) mf_silu_backward(dtemb, dts, temb, (size_t)B * d->Ct);
    }
    /* GN1 + SiLU -> dx (accumulated) */
    mf_gnsilu_backward(dx, 1, g->gn1_w, g->gn1_b, a->gA, x, a->s1, a->mean1, a->rstd1, w->gn1_w, w->gn1_b, B, Ci,
                       HW, d->G);
}

/* ---- spatial self-attention block ---------------------------------------------------------- */

int mf_attnblock_specs(MfTensorSpec *specs, const char *prefix, const MfAttnBlockDims *d) {
    int c[1] = {d->C}, c3[1] = {3 * d->C}, wq[2] = {3 * d->C, d->C}, wp[2] = {d->C, d->C};
    mf_spec_set(&specs[0], prefix, "gn.w", 1, c);
    mf_spec_set(&specs[1], prefix, "gn.b", 1, c);
    mf_spec_set(&specs[2], prefix, "qkv.w", 2, wq);
    mf_spec_set(&specs[3], prefix, "qkv.b", 1, c3);
    mf_spec_set(&specs[4], prefix, "proj.w", 2, wp);
    mf_spec_set(&specs[5], prefix, "proj.b", 1, c);
    return MF_ATTNBLOCK_NPARAMS;
}

void mf_attnblock_bind(MfAttnBlockW *w, const MfAttnBlockDims *d, float *mem) {
    MfTensorSpec specs[MF_ATTNBLOCK_NPARAMS];
    mf_attnblock_specs(specs, "", d);
    float *slots[MF_ATTNBLOCK_NPARAMS];
    mf_params_bind(slots, specs, MF_ATTNBLOCK_NPARAMS, mem);
    w->gn_w = slots[0], w->gn_b = slots[1], w->qkv_w = slots[2], w->qkv_b = slots[3];
    w->proj_w = slots[4], w->proj_b = slots[5];
}

static size_t attn_T(const MfAttnBlockDims *d) {
    return d->joint ? (size_t)d->V * d->H * d->W : (size_t)d->H * d->W;
}

size_t mf_attnblock_acts_floats(const MfAttnBlockDims *d) {
    size_t n = (size_t)d->BV * d->C * d->H * d->W, T = attn_T(d);
    return n + 2 * (size_t)d->BV * d->G + n + 3 * n +
           mf_mv_attention_att_floats(d->BV, d->V, d->H * d->W, d->NH, d->joint) + 2 * n + T * T + 2 * n + 3 * n;
}

void mf_attnblock_acts_bind(MfAttnBlockActs *a, const MfAttnBlockDims *d, float *mem) {
    size_t n = (size_t)d->BV * d->C * d->H * d->W, T = attn_T(d);
    float *p = mem;
#define TAKE(field, count) (a->field = p, p += (count))
    TAKE(h, n);
    TAKE(mean, (size_t)d->BV * d->G);
    TAKE(rstd, (size_t)d->BV * d->G);
    TAKE(tok, n);
    TAKE(qkv, 3 * n);
    TAKE(att, mf_mv_attention_att_floats(d->BV, d->V, d->H * d->W, d->NH, d->joint));
    TAKE(y, n);
    TAKE(z, n);
    TAKE(scratch, T * T);
    TAKE(g1, n);
    TAKE(g2, n);
    TAKE(gqkv, 3 * n);
#undef TAKE
}

void mf_attnblock_init(MfAttnBlockW *w, const MfAttnBlockDims *d, unsigned long long seed) {
    int C = d->C;
    float bd = 1.0f / sqrtf((float)C);
    for (int c = 0; c < C; ++c) w->gn_w[c] = 1.0f, w->gn_b[c] = 0.0f;
    mf_nn_init_uniform(w->qkv_w, (size_t)3 * C * C, bd, seed * 16 + 1);
    mf_nn_init_uniform(w->qkv_b, (size_t)3 * C, bd, seed * 16 + 2);
    mf_nn_init_uniform(w->proj_w, (size_t)C * C, bd, seed * 16 + 3);
    mf_nn_init_uniform(w->proj_b, (size_t)C, bd, seed * 16 + 4);
}

void mf_attnblock_forward(float *out, MfAttnBlockActs *a, const float *x, const MfAttnBlockW *w,
                          const MfAttnBlockDims *d) {
    int BV = d->BV, C = d->C, HW = d->H * d->W, N = BV * HW;
    size_t n = (size_t)BV * C * HW;
    mf_groupnorm_forward(a->h, a->mean, a->rstd, x, w->gn_w, w->gn_b, BV, C, HW, d->G, d->eps);
    mf_nchw_to_tokens_forward(a->tok, a->h, BV, C, HW);
    mf_linear_forward(a->qkv, a->tok, w->qkv_w, w->qkv_b, N, C, 3 * C);
    mf_mv_attention_forward(a->y, a->att, a->qkv, BV, d->V, HW, C, d->NH, d->joint);
    mf_linear_forward(a->z, a->y, w->proj_w, w->proj_b, N, C, C);
    mf_tokens_to_nchw_forward(out, a->z, BV, C, HW);
    for (size_t i = 0; i < n; ++i) out[i] += x[i];
}

void mf_attnblock_backward(float *dx, MfAttnBlockW *g, MfAttnBlockActs *a, const float *dout,
                           const float *x, const MfAttnBlockW *w, const MfAttnBlockDims *d) {
    int BV = d->BV, C = d->C, HW = d->H * d->W, N = BV * HW;
    size_t n = (size_t)BV * C * HW;
    for (size_t i = 0; i < n; ++i) dx[i] += dout[i];
    memset(a->g1, 0, n * sizeof(float)); /* dz (BV, HW, C) */
    mf_tokens_to_nchw_backward(a->g1, dout, BV, C, HW);
    memset(a->g2, 0, n * sizeof(float)); /* dy */
    mf_linear_backward(a->g2, g->proj_w, g->proj_b, a->g1, a->y, w->proj_w, N, C, C);
    memset(a->gqkv, 0, 3 * n * sizeof(float));
    mf_mv_attention_backward(a->gqkv, a->scratch, a->g2, a->att, a->qkv, BV, d->V, HW, C, d->NH, d->joint);
    memset(a->g1, 0, n * sizeof(float)); /* dtok */
    mf_linear_backward(a->g1, g->qkv_w, g->qkv_b, a->gqkv, a->tok, w->qkv_w, N, C, 3 * C);
    memset(a->g2, 0, n * sizeof(float)); /* dh (BV, C, HW) */
    mf_nchw_to_tokens_backward(a->g2, a->g1, BV, C, HW);
    mf_groupnorm_backward(dx, g->gn_w, g->gn_b, a->g2, x, a->mean, a->rstd, w->gn_w, BV, C, HW, d->G);
}

/* ---- AdamW ---------------------------------------------------------------------------------- */

int mf_adamw_init(MfAdamW *opt, size_t n, float lr, float beta1, float beta2, float eps,
                  float weight_decay) {
    float *m = calloc(n ? n : 1, sizeof(float)), *v = calloc(n ? n : 1, sizeof(float));
    if (!m || !v) {
        free(m);
        free(v);
        return mf_fail(MF_ENOMEM, "adamw: cannot allocate moments for %zu parameters", n);
    }
    opt->lr = lr;
    opt->beta1 = beta1;
    opt->beta2 = beta2;
    opt->eps = eps;
    opt->weight_decay = weight_decay;
    opt->t = 0;
    opt->n = n;
    opt->m = m;
    opt->v = v;
    return MF_OK;
}

int mf_nn_check_finite(const float *x, size_t n, const char *what) {
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(x[i])) return mf_fail(MF_ENAN, "%s[%zu] is %s", what, i, isnan(x[i]) ? "nan" : "inf");
    return MF_OK;
}

int mf_adamw_step(MfAdamW *opt, float *params, const float *grads) {
    int rc = mf_nn_check_finite(grads, opt->n, "adamw: gradient");
    if (rc) return rc;
    opt->t++;
    float b1 = opt->beta1, b2 = opt->beta2, lr = opt->lr, eps = opt->eps, wd = opt->weight_decay;
    float c1 = 1.0f - (float)pow(b1, (double)opt->t), c2 = 1.0f - (float)pow(b2, (double)opt->t);
    float *m = opt->m, *v = opt->v;
    size_t n = opt->n;
    for (size_t i = 0; i < n; ++i) {
        float gi = grads[i];
        float mi = b1 * m[i] + (1.0f - b1) * gi;
        float vi = b2 * v[i] + (1.0f - b2) * gi * gi;
        m[i] = mi;
        v[i] = vi;
        float mh = mi / c1, vh = vi / c2;
        params[i] -= lr * (mh / (sqrtf(vh) + eps) + wd * params[i]);
    }
    return MF_OK;
}

void mf_adamw_free(MfAdamW *opt) {
    if (!opt) return;
    free(opt->m);
    free(opt->v);
    opt->m = opt->v = NULL;
    opt->n = 0;
}

float mf_grad_clip_norm(float *grads, size_t n, float max_norm) {
    double s = 0.0;
    for (size_t i = 0; i < n; ++i) s += (double)grads[i] * grads[i];
    float norm = (float)sqrt(s);
    if (max_norm > 0.0f && norm > max_norm) {
        float k = max_norm / norm;
        for (size_t i = 0; i < n; ++i) grads[i] *= k;
    }
    return norm;
}
