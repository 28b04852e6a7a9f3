#include "inverse/mf_optim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

int mf_param_init(MfParamBlock *b, const char *name, size_t n, int ch, const float *init) {
    if (ch < 1 || ch > MF_PARAM_MAX_CH || n % (size_t)ch)
        return mf_fail(MF_EARG, "parameter block %s: %zu values do not split into %d channels", name, n, ch);
    MfParamBlock r;
    memset(&r, 0, sizeof r);
    snprintf(r.name, sizeof r.name, "%s", name);
    r.n = n;
    r.ch = ch;
    r.lr_scale = 1.0f;
    for (int c = 0; c < MF_PARAM_MAX_CH; ++c) r.lo[c] = -INFINITY, r.hi[c] = INFINITY;
    r.p = malloc((n + 1) * sizeof(float));
    r.g = calloc(n + 1, sizeof(float));
    r.m = calloc(n + 1, sizeof(float));
    r.v = calloc(n + 1, sizeof(float));
    if (!r.p || !r.g || !r.m || !r.v) {
        mf_param_free(&r);
        return mf_fail(MF_ENOMEM, "parameter block %s: out of memory (%zu values)", name, n);
    }
    if (init) memcpy(r.p, init, n * sizeof(float));
    else memset(r.p, 0, n * sizeof(float));
    *b = r;
    return MF_OK;
}

void mf_param_free(MfParamBlock *b) {
    if (!b) return;
    free(b->p);
    free(b->g);
    free(b->m);
    free(b->v);
    memset(b, 0, sizeof *b);
}

void mf_param_set_bounds(MfParamBlock *b, int channel, float lo, float hi) {
    b->lo[channel] = lo;
    b->hi[channel] = hi;
}

void mf_param_zero_grad(MfParamBlock *b) { memset(b->g, 0, b->n * sizeof(float)); }

void mf_param_project(MfParamBlock *b) {
    for (size_t i = 0; i < b->n; ++i) {
        int c = (int)(i % (size_t)b->ch);
        b->p[i] = fminf(fmaxf(b->p[i], b->lo[c]), b->hi[c]);
    }
}

void mf_adam_init(MfAdam *a, float lr) {
    a->lr = lr;
    a->beta1 = 0.9f;
    a->beta2 = 0.999f;
    a->eps = 1e-8f;
    a->t = 0;
}

float mf_lr_schedule(float lr0, long it) { return lr0 * powf(10.0f, -0.0002f * (float)it); }

int mf_adam_step(MfAdam *a, MfParamBlock *blocks, int nblocks, float lr) {
    for (int k = 0; k < nblocks; ++k)
        for (size_t i = 0; i < blocks[k].n; ++i)
            if (!isfinite(blocks[k].g[i]))
                return mf_fail(MF_ENAN, "parameter block %s: gradient of element %zu is %g", blocks[k].name, i,
                               blocks[k].g[i]);
    a->t++;
    double bc1 = 1.0 - pow(a->beta1, (double)a->t), bc2 = 1.0 - pow(a->beta2, (double)a->t);
    for (int k = 0; k < nblocks; ++k) {
        MfParamBlock *b = &blocks[k];
        float step = (float)(lr * b->lr_scale / bc1);
        float inv_sqrt_bc2 = (float)(1.0 / sqrt(bc2));
        for (size_t i = 0; i < b->n; ++i) {
            int c = (int)(i % (size_t)b->ch);
            if (b->lo[c] == b->hi[c]) continue; /* frozen channel */
            b->m[i] = a->beta1 * b->m[i] + (1.0f - a->beta1) * b->g[i];
            b->v[i] = a->beta2 * b->v[i] + (1.0f - a->beta2) * b->g[i] * b->g[i];
            b->p[i] -= step * b->m[i] / (sqrtf(b->v[i]) * inv_sqrt_bc2 + a->eps);
        }
        mf_param_project(b);
    }
    return MF_OK;
}

int mf_params_find_nonfinite(const MfParamBlock *blocks, int nblocks, char *msg, size_t cap) {
    for (int k = 0; k < nblocks; ++k) {
        const MfParamBlock *b = &blocks[k];
        const float *arr[3] = {b->p, b->m, b->v};
        static const char part[3] = {'p', 'm', 'v'};
        for (int a = 0; a < 3; ++a)
            for (size_t i = 0; i < b->n; ++i)
                if (!isfinite(arr[a][i])) {
                    snprintf(msg, cap, "%s.%c[%zu] = %g", b->name, part[a], i, arr[a][i]);
                    return 1;
                }
    }
    return 0;
}

int mf_param_snapshot_save(MfParamSnapshot *s, const MfParamBlock *blocks, int nblocks, const MfAdam *a) {
    size_t len = 0;
    for (int k = 0; k < nblocks; ++k) len += 3 * blocks[k].n;
    if (!s->buf) {
        if (!(s->buf = malloc(len * sizeof(float) + 1))) return mf_fail(MF_ENOMEM, "out of memory for a %zu-value snapshot", len);
        s->len = len;
    }
    if (s->len != len) return mf_fail(MF_EARG, "snapshot of %zu values, blocks now hold %zu", s->len, len);
    size_t off = 0;
    for (int k = 0; k < nblocks; ++k) {
        const MfParamBlock *b = &blocks[k];
        memcpy(s->buf + off, b->p, b->n * sizeof(float)), off += b->n;
        memcpy(s->buf + off, b->m, b->n * sizeof(float)), off += b->n;
        memcpy(s->buf + off, b->v, b->n * sizeof(float)), off += b->n;
    }
    s->t = a->t;
    return MF_OK;
}

void mf_param_snapshot_restore(const MfParamSnapshot *s, MfParamBlock *blocks, int nblocks, MfAdam *a) {
    size_t off = 0;
    for (int k = 0; k < nblocks; ++k) {
        MfParamBlock *b = &blocks[k];
        memcpy(b->p, s->buf + off, b->n * sizeof(float)), off += b->n;
        memcpy(b->m, s->buf + off, b->n * sizeof(float)), off += b->n;
        memcpy(b->v, s->buf + off, b->n * sizeof(float)), off += b->n;
    }
    a->t = s->t;
}

int mf_param_ckpt_specs(const MfParamBlock *blocks, int nblocks, MfTensorSpec *specs) {
    static const char *part[3] = {"p", "m", "v"};
    for (int k = 0; k < nblocks; ++k)
        for (int j = 0; j < 3; ++j) {
            int shape[1] = {(int)blocks[k].n};
            mf_spec_set(&specs[3 * k + j], blocks[k].name, part[j], 1, shape);
        }
    return 3 * nblocks;
}

void mf_param_snapshot_free(MfParamSnapshot *s) {
    if (!s) return;
    free(s->buf);
    memset(s, 0, sizeof *s);
}

void mf_divguard_init(MfDivGuard *g, double factor, int patience) {
    g->factor = factor;
    g->patience = patience;
    g->loss_min = INFINITY;
    g->streak = 0;
}

MfDivState mf_divguard_observe(MfDivGuard *g, double loss) {
    if (!isfinite(loss)) return MF_DIV_NONFINITE;
    if (loss < g->loss_min) {
        g->loss_min = loss;
        g->streak = 0;
        return MF_DIV_NEW_MIN;
    }
    if (loss > g->factor * g->loss_min) {
        if (++g->streak >= g->patience) {
            g->streak = 0;
            return MF_DIV_DIVERGED;
        }
    } else {
        g->streak = 0;
    }
    return MF_DIV_OK;
}
