/* mf_denoiser: see mf_denoiser.h. */
#include "prior/mf_denoiser.h"

#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

static void add_res(MfSpecTab *t, MfDnRes *r, const char *name, int Cin, int Cout, int H, int Ct, int G) {
    MfResBlockDims d = {1, Cin, Cout, H, H, Ct, G, MF_KNORM_EPS};
    r->d = d;
    MfTensorSpec specs[MF_RESBLOCK_NPARAMS];
    int k = mf_resblock_specs(specs, name, &r->d);
    r->off = mf_spectab_add_many(t, specs, k);
}

/* r's dimensions at batch B, with its weights (from p) and, if g is not NULL, gradients bound. */
static MfResBlockDims res_bind(const MfDnRes *r, int B, const float *p, float *g, MfResBlockW *rw, MfResBlockW *rg) {
    MfResBlockDims d = r->d;
    d.B = B;
    mf_resblock_bind(rw, &d, (float *)p + r->off);
    if (g) mf_resblock_bind(rg, &d, g + r->off);
    return d;
}

/* The attention block's dimensions at batch B (V views, joint or not), weights and gradients. */
static MfAttnBlockDims attn_bind(const MfDnAttn *a, int B, int V, int joint, const float *p, float *g, MfAttnBlockW *aw,
                                 MfAttnBlockW *ag) {
    MfAttnBlockDims d = a->d;
    d.BV = B, d.V = V, d.joint = joint;
    mf_attnblock_bind(aw, &d, (float *)p + a->off);
    if (g) mf_attnblock_bind(ag, &d, g + a->off);
    return d;
}

/* Validates the configuration and lays out dn's layers and parameter table (no weights). */
static int dn_build(MfDenoiser *dn, const MfDenoiserConfig *cfg) {
    const MfDenoiserConfig *c = cfg;
    if (c->groups < 1 || c->heads < 1 || c->c1 < 1 || c->c2 < 1 || c->ct < 1 || c->zc < 1) /* before any % */
        return mf_fail(MF_EARG, "denoiser: bad configuration (c1 %d, c2 %d, ct %d, zc %d, groups %d, heads %d: all must be >= 1)",
                       c->c1, c->c2, c->ct, c->zc, c->groups, c->heads);
    if (c->h < 4 || c->h % 2 || c->c1 % c->groups || c->c2 % c->groups || c->c2 % c->heads || c->tfreq % 2 ||
        c->c2 < c->c1 || (c->c1 + c->c2) % c->groups || c->img_res % 8 || c->i1 < 1 || c->i2 < 1 || c->i3 < 1)
        return mf_fail(MF_EARG, "denoiser: bad configuration (h %d, c1 %d, c2 %d, groups %d, heads %d)", c->h, c->c1,
                       c->c2, c->groups, c->heads);
    dn->cfg = *c;
    MfSpecTab *t = &dn->tab;
    int ok = 1, h = c->h, G = c->groups;
    mf_klinear_add(&dn->t1, t, "dn.time.0", c->tfreq, c->ct);
    mf_klinear_add(&dn->t2, t, "dn.time.1", c->ct, c->ct);
    mf_kconv_add(&dn->cin, t, "dn.conv_in", 3 * c->zc, c->c1, 3, 1);
    add_res(t, &dn->res0, "dn.res0", c->c1, c->c1, h, c->ct, G);
    mf_kconv_add(&dn->down, t, "dn.down", c->c1, c->c1, 3, 2);
    add_res(t, &dn->res1, "dn.res1", c->c1, c->c2, h / 2, c->ct, G);
    MfAttnBlockDims ad = {1, c->c2, h / 2, h / 2, G, c->heads, 1, 0, MF_KNORM_EPS};
    dn->attn.d = ad;
    MfTensorSpec as[MF_ATTNBLOCK_NPARAMS];
    int na = mf_attnblock_specs(as, "dn.attn", &dn->attn.d);
    dn->attn.off = mf_spectab_add_many(t, as, na);
    add_res(t, &dn->res2, "dn.res2", c->c2, c->c2, h / 2, c->ct, G);
    add_res(t, &dn->res3, "dn.res3", c->c2 + c->c1, c->c1, h, c->ct, G);
    mf_knorm_add(&dn->nout, t, "dn.norm_out", c->c1, G);
    mf_kconv_add(&dn->cout, t, "dn.conv_out", c->c1, 2 * c->zc, 3, 1);
    /* image encoder */
    MfSeq *s = &dn->img;
    mf_seq_begin(s, 3, c->img_res, c->img_res, 1);
    ok = ok && mf_seq_conv(s, t, "img.enc", c->i1, 3, 2, 0) && mf_seq_silu(s);
    ok = ok && mf_seq_conv(s, t, "img.enc", c->i2, 3, 2, 0) && mf_seq_silu(s);
    ok = ok && mf_seq_conv(s, t, "img.enc", c->i3, 3, 2, 0) && mf_seq_silu(s);
    mf_klinear_add(&dn->iproj, t, "img.proj", c->i3, c->ct);
    return ok && t->v ? MF_OK : mf_fail(MF_ENOMEM, "denoiser: out of memory");
}

int mf_denoiser_new(MfDenoiser **out, const MfDenoiserConfig *cfg) {
    MfDenoiser *dn = calloc(1, sizeof *dn);
    if (!dn) return mf_fail(MF_ENOMEM, "denoiser: out of memory");
    int rc = dn_build(dn, cfg);
    if (!rc) {
        dn->params = calloc(dn->tab.numel, sizeof(float));
        dn->grads = calloc(dn->tab.numel, sizeof(float));
        if (!dn->params || !dn->grads) rc = mf_fail(MF_ENOMEM, "denoiser: out of memory");
    }
    if (rc) {
        mf_denoiser_free(dn);
        return rc;
    }
    *out = dn;
    return MF_OK;
}

int mf_denoiser_numel(const MfDenoiserConfig *cfg, size_t *numel) {
    MfDenoiser dn = {0};
    int rc = dn_build(&dn, cfg);
    if (!rc) *numel = dn.tab.numel;
    mf_spectab_free(&dn.tab);
    return rc;
}

void mf_denoiser_free(MfDenoiser *dn) {
    if (!dn) return;
    mf_spectab_free(&dn->tab);
    free(dn->params), free(dn->grads), free(dn);
}

static void init_res(float *p, const MfDnRes *r, unsigned long long seed) {
    MfResBlockW w;
    mf_resblock_bind(&w, &r->d, p + r->off);
    mf_resblock_init(&w, &r->d, seed);
}

void mf_denoiser_init_weights(MfDenoiser *dn, unsigned long long seed) {
    float *p = dn->params;
    unsigned long long s = seed * 1000;
    mf_klinear_init(&dn->t1, p, s + 1);
    mf_klinear_init(&dn->t2, p, s + 2);
    mf_kconv_init(&dn->cin, p, s + 3, 0);
    init_res(p, &dn->res0, s + 4);
    mf_kconv_init(&dn->down, p, s + 5, 0);
    init_res(p, &dn->res1, s + 6);
    MfAttnBlockW aw;
    mf_attnblock_bind(&aw, &dn->attn.d, p + dn->attn.off);
    mf_attnblock_init(&aw, &dn->attn.d, s + 7);
    init_res(p, &dn->res2, s + 8);
    init_res(p, &dn->res3, s + 9);
    mf_knorm_init(&dn->nout, p);
    mf_kconv_init(&dn->cout, p, s + 10, 1);
    mf_seq_init(&dn->img, p, s + 11);
    mf_klinear_init(&dn->iproj, p, s + 12);
}

static size_t layout(const MfDenoiser *dn, MfDenoiserWork *w, float *base, int B, int V, int joint) {
    const MfDenoiserConfig *c = &dn->cfg;
    MfArena ar = {base, 0};
    size_t n16 = (size_t)c->h * c->h, n8 = n16 / 4, Bz = (size_t)B;
    w->tf = mf_arena_take(&ar, Bz * c->tfreq);
    w->t1o = mf_arena_take(&ar, Bz * c->ct);
    w->t1a = mf_arena_take(&ar, Bz * c->ct);
    w->et = mf_arena_take(&ar, Bz * c->ct);
    w->pool = mf_arena_take(&ar, Bz * c->i3);
    w->ei = mf_arena_take(&ar, Bz * c->ct);
    w->emb = mf_arena_take(&ar, Bz * c->ct);
    w->h0 = mf_arena_take(&ar, Bz * c->c1 * n16);
    w->h1 = mf_arena_take(&ar, Bz * c->c1 * n16);
    w->h2 = mf_arena_take(&ar, Bz * c->c1 * n8);
    w->h3 = mf_arena_take(&ar, Bz * c->c2 * n8);
    w->h4 = mf_arena_take(&ar, Bz * c->c2 * n8);
    w->h5 = mf_arena_take(&ar, Bz * c->c2 * n8);
    w->h5u = mf_arena_take(&ar, Bz * c->c2 * n16);
    w->h6 = mf_arena_take(&ar, Bz * (c->c1 + c->c2) * n16);
    w->h7 = mf_arena_take(&ar, Bz * c->c1 * n16);
    w->v = mf_arena_take(&ar, Bz * 2 * c->zc * n16);
    const MfDnRes *rs[4] = {&dn->res0, &dn->res1, &dn->res2, &dn->res3};
    MfResBlockActs *as[4] = {&w->a0, &w->a1, &w->a2, &w->a3};
    for (int i = 0; i < 4; ++i) {
        MfResBlockDims d = rs[i]->d;
        d.B = B;
        float *m = mf_arena_take(&ar, mf_resblock_acts_floats(&d));
        if (m) mf_resblock_acts_bind(as[i], &d, m);
    }
    MfAttnBlockDims ad = dn->attn.d;
    ad.BV = B, ad.V = V, ad.joint = joint;
    float *m = mf_arena_take(&ar, mf_attnblock_acts_floats(&ad));
    if (m) mf_attnblock_acts_bind(&w->aa, &ad, m);
    mf_knorm_acts(&w->an, &ar, B, c->c1, (int)n16, c->groups);
    size_t col = mf_kconv_col(&dn->cin, B, c->h, c->h), k;
    if ((k = mf_kconv_col(&dn->down, B, c->h, c->h)) > col) col = k;
    if ((k = mf_kconv_col(&dn->cout, B, c->h, c->h)) > col) col = k;
    w->col = mf_arena_take(&ar, col);
    size_t g16 = Bz * (c->c1 + c->c2) * n16, g8 = Bz * c->c2 * n8;
    w->g16a = mf_arena_take(&ar, g16);
    w->g16b = mf_arena_take(&ar, g16);
    w->g8a = mf_arena_take(&ar, g8);
    w->g8b = mf_arena_take(&ar, g8);
    w->gemb = mf_arena_take(&ar, Bz * c->ct);
    w->gtmp = mf_arena_take(&ar, Bz * c->ct);
    w->gpool = mf_arena_take(&ar, Bz * c->i3);
    const MfSeq *s = &dn->img;
    w->gfeat = mf_arena_take(&ar, Bz * s->C * s->H * s->W);
    return ar.used;
}

float *mf_denoiser_forward(MfDenoiser *dn, MfDenoiserWork *w, const float *x, const float *t,
                           const float *rgb, const float *keep, int B, int V, int joint) {
    return mf_denoiser_forward_ex(dn, w, x, t, rgb, keep, B, V, joint, 0);
}

float *mf_denoiser_forward_ex(MfDenoiser *dn, MfDenoiserWork *w, const float *x, const float *t, const float *rgb,
                              const float *keep, int B, int V, int joint, int same_rgb) {
    const MfDenoiserConfig *c = &dn->cfg;
    /* the image embedding can be reused only from a forward with the same layout */
    int reuse = same_rgb && w->ei_ok && w->mem && w->B == B && w->V == V && w->joint == joint;
    if (V < 1 || B % V) {
        mf_fail(MF_EARG, "denoiser: batch %d is not a multiple of the view count %d", B, V);
        return NULL;
    }
    size_t need = layout(dn, w, NULL, B, V, joint);
    if (need > w->cap) {
        float *m = realloc(w->mem, need * sizeof(float));
        if (!m) {
            mf_fail(MF_ENOMEM, "denoiser: out of memory (%zu floats of activations)", need);
            return NULL;
        }
        w->mem = m, w->cap = need;
    }
    layout(dn, w, w->mem, B, V, joint); /* the same layout as the previous forward's when reuse */
    w->ei_ok = 0;
    w->B = B, w->V = V, w->joint = joint, w->x = x, w->rgb = rgb, w->keep = keep;
    const float *p = dn->params;
    int h = c->h, n16 = h * h, n8 = n16 / 4, Ct = c->ct;
    /* embeddings */
    mf_timestep_embedding(w->tf, t, B, c->tfreq, 10000.0f);
    mf_klinear_forward(&dn->t1, p, w->t1o, w->tf, B);
    mf_silu_forward(w->t1a, w->t1o, (size_t)B * Ct);
    mf_klinear_forward(&dn->t2, p, w->et, w->t1a, B);
    if (!reuse) {
        const float *feat = mf_seq_forward(&dn->img, p, &w->img, rgb, B);
        if (!feat) {
            mf_fail(MF_ENOMEM, "denoiser: out of memory (image encoder)");
            return NULL;
        }
        const MfSeq *s = &dn->img;
        int fhw = s->H * s->W;
        for (int b = 0; b < B; ++b)
            for (int k = 0; k < s->C; ++k) {
                const float *row = feat + ((size_t)b * s->C + k) * fhw;
                double acc = 0.0;
                for (int i = 0; i < fhw; ++i) acc += row[i];
                w->pool[(size_t)b * s->C + k] = (float)(acc / fhw);
            }
        mf_klinear_forward(&dn->iproj, p, w->ei, w->pool, B);
    }
    w->ei_ok = 1;
    for (int b = 0; b < B; ++b)
        for (int k = 0; k < Ct; ++k) {
            size_t i = (size_t)b * Ct + k;
            w->emb[i] = w->et[i] + keep[b] * w->ei[i];
        }
    /* UNet */
    MfResBlockW rw;
    MfResBlockDims d;
    mf_kconv_forward(&dn->cin, p, w->h0, w->col, x, B, h, h);
    d = res_bind(&dn->res0, B, p, NULL, &rw, NULL);
    mf_resblock_forward(w->h1, &w->a0, w->h0, w->emb, &rw, &d);
    mf_kconv_forward(&dn->down, p, w->h2, w->col, w->h1, B, h, h);
    d = res_bind(&dn->res1, B, p, NULL, &rw, NULL);
    mf_resblock_forward(w->h3, &w->a1, w->h2, w->emb, &rw, &d);
    MfAttnBlockW aw;
    MfAttnBlockDims ad = attn_bind(&dn->attn, B, V, joint, p, NULL, &aw, NULL);
    mf_attnblock_forward(w->h4, &w->aa, w->h3, &aw, &ad);
    d = res_bind(&dn->res2, B, p, NULL, &rw, NULL);
    mf_resblock_forward(w->h5, &w->a2, w->h4, w->emb, &rw, &d);
    mf_upsample2x_forward(w->h5u, w->h5, B, c->c2, h / 2, h / 2);
    size_t sA = (size_t)c->c2 * n16, sB = (size_t)c->c1 * n16;
    for (int b = 0; b < B; ++b) {
        memcpy(w->h6 + b * (sA + sB), w->h5u + b * sA, sA * sizeof(float));
        memcpy(w->h6 + b * (sA + sB) + sA, w->h1 + b * sB, sB * sizeof(float));
    }
    d = res_bind(&dn->res3, B, p, NULL, &rw, NULL);
    mf_resblock_forward(w->h7, &w->a3, w->h6, w->emb, &rw, &d);
    mf_knorm_forward(&dn->nout, p, &w->an, w->h7, B, n16);
    mf_kconv_forward(&dn->cout, p, w->v, w->col, w->an.a, B, h, h);
    (void)n8;
    return w->v;
}

void mf_denoiser_backward(MfDenoiser *dn, MfDenoiserWork *w, const float *dv) {
    const MfDenoiserConfig *c = &dn->cfg;
    const float *p = dn->params;
    float *g = dn->grads;
    int B = w->B, h = c->h, n16 = h * h, n8 = n16 / 4, Ct = c->ct;
    size_t s16 = (size_t)B * c->c1 * n16, s8 = (size_t)B * c->c2 * n8;
    MfResBlockW rw, rg;
    MfResBlockDims d;
    memset(w->gemb, 0, (size_t)B * Ct * sizeof(float));
    /* conv_out, norm_out: dh7 -> g16b */
    memset(w->g16a, 0, s16 * sizeof(float));
    mf_kconv_backward(&dn->cout, p, g, w->g16a, w->col, dv, w->an.a, B, h, h);
    memset(w->g16b, 0, s16 * sizeof(float));
    mf_knorm_backward(&dn->nout, p, g, &w->an, w->g16b, w->g16a, w->h7, B, n16);
    /* res3: dh6 -> g16a */
    size_t s6 = (size_t)B * (c->c1 + c->c2) * n16;
    memset(w->g16a, 0, s6 * sizeof(float));
    d = res_bind(&dn->res3, B, p, g, &rw, &rg);
    mf_resblock_backward(w->g16a, w->gemb, &rg, &w->a3, w->g16b, w->h6, w->emb, &rw, &d);
    /* split: dh5u (first c2 channels), dh1 (last c1 channels) -> g16b holds dh1 */
    size_t sA = (size_t)c->c2 * n16, sB = (size_t)c->c1 * n16;
    float *dh1 = w->g16b;
    for (int b = 0; b < B; ++b) memcpy(dh1 + b * sB, w->g16a + b * (sA + sB) + sA, sB * sizeof(float));
    /* up: dh5 -> g8a (reads the dh5u parts from g16a in place, item by item) */
    memset(w->g8a, 0, s8 * sizeof(float));
    for (int b = 0; b < B; ++b)
        mf_upsample2x_backward(w->g8a + (size_t)b * c->c2 * n8, w->g16a + b * (sA + sB), 1, c->c2, h / 2, h / 2);
    /* res2: dh4 -> g8b */
    memset(w->g8b, 0, s8 * sizeof(float));
    d = res_bind(&dn->res2, B, p, g, &rw, &rg);
    mf_resblock_backward(w->g8b, w->gemb, &rg, &w->a2, w->g8a, w->h4, w->emb, &rw, &d);
    /* attention: dh3 -> g8a */
    memset(w->g8a, 0, s8 * sizeof(float));
    MfAttnBlockW aw, ag;
    MfAttnBlockDims ad = attn_bind(&dn->attn, B, w->V, w->joint, p, g, &aw, &ag);
    mf_attnblock_backward(w->g8a, &ag, &w->aa, w->g8b, w->h3, &aw, &ad);
    /* res1: dh2 -> g8b (c1 channels) */
    memset(w->g8b, 0, (size_t)B * c->c1 * n8 * sizeof(float));
    d = res_bind(&dn->res1, B, p, g, &rw, &rg);
    mf_resblock_backward(w->g8b, w->gemb, &rg, &w->a1, w->g8a, w->h2, w->emb, &rw, &d);
    /* down: dh1 += */
    mf_kconv_backward(&dn->down, p, g, dh1, w->col, w->g8b, w->h1, B, h, h);
    /* res0: dh0 -> g16a */
    memset(w->g16a, 0, s16 * sizeof(float));
    d = res_bind(&dn->res0, B, p, g, &rw, &rg);
    mf_resblock_backward(w->g16a, w->gemb, &rg, &w->a0, dh1, w->h0, w->emb, &rw, &d);
    /* conv_in (no input gradient) */
    mf_kconv_backward(&dn->cin, p, g, NULL, w->col, w->g16a, w->x, B, h, h);
    /* embeddings: det = gemb; dei = keep * gemb */
    memset(w->gtmp, 0, (size_t)B * Ct * sizeof(float));
    mf_klinear_backward(&dn->t2, p, g, w->gtmp, w->gemb, w->t1a, B);
    float *dt1o = w->gemb; /* reuse after the image branch below has read gemb: do image branch first */
    (void)dt1o;
    /* image branch */
    float *dei = w->ei; /* ei is no longer needed: overwrite with keep * gemb */
    for (int b = 0; b < B; ++b)
        for (int k = 0; k < Ct; ++k) dei[(size_t)b * Ct + k] = w->keep[b] * w->gemb[(size_t)b * Ct + k];
    const MfSeq *s = &dn->img;
    memset(w->gpool, 0, (size_t)B * s->C * sizeof(float));
    mf_klinear_backward(&dn->iproj, p, g, w->gpool, dei, w->pool, B);
    int fhw = s->H * s->W;
    for (int b = 0; b < B; ++b)
        for (int k = 0; k < s->C; ++k) {
            float gv = w->gpool[(size_t)b * s->C + k] / (float)fhw, *row = w->gfeat + ((size_t)b * s->C + k) * fhw;
            for (int i = 0; i < fhw; ++i) row[i] = gv;
        }
    mf_seq_backward(s, p, g, &w->img, w->gfeat, NULL);
    /* time MLP: dt1o from gtmp via SiLU */
    memset(w->gemb, 0, (size_t)B * Ct * sizeof(float));
    mf_silu_backward(w->gemb, w->gtmp, w->t1o, (size_t)B * Ct);
    mf_klinear_backward(&dn->t1, p, g, NULL, w->gemb, w->tf, B);
}

void mf_denoiser_work_free(MfDenoiserWork *w) {
    mf_seq_work_free(&w->img);
    free(w->mem);
    memset(w, 0, sizeof *w);
}
