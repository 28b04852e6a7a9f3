#include "render/mf_normalmap.h"

#include "scene/mf_texture.h"

#define BEND_MIN 0.01f

MfNmapFrame mf_nmap_frame(const MfMesh *m, const float *tan, const MfHit *h) {
    MfNmapFrame f;
    const uint32_t *v = m->tri + 3 * (size_t)h->tri;
    const float *p0 = m->pos + 3 * v[0], *p1 = m->pos + 3 * v[1], *p2 = m->pos + 3 * v[2];
    MfVec3 e1 = mf_v3(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]), e2 = mf_v3(p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
    f.side = mf_dot(mf_cross(e1, e2), h->ng) < 0.0f ? -1.0f : 1.0f;
    f.ns = h->ns;
    f.n = mf_scale(h->ns, f.side);
    float b0 = 1.0f - h->b1 - h->b2, bw[3] = {b0, h->b1, h->b2};
    MfVec3 t = mf_v3s(0.0f);
    float w = 0.0f;
    for (int k = 0; k < 3; ++k) {
        const float *tk = tan + 4 * (size_t)v[k];
        t = mf_madd(t, mf_v3(tk[0], tk[1], tk[2]), bw[k]);
        w += bw[k] * tk[3];
    }
    t = mf_sub(t, mf_scale(f.n, mf_dot(f.n, t)));
    float lt = mf_len(t);
    f.t = (lt > 1e-6f && isfinite(lt)) ? mf_scale(t, 1.0f / lt) : mf_frame(f.n).t;
    f.b = mf_scale(mf_cross(f.n, f.t), w < 0.0f ? -1.0f : 1.0f);
    return f;
}

/* Forward with the intermediates the adjoint needs. */
typedef struct {
    MfVec3 n;       /* side * normalize(m) */
    float lm;       /* |m| (0: fallback) */
    MfVec3 nb;      /* output */
    float lb;       /* |bent vector| (0: not bent) */
    int fallback;   /* 1: output is the hit's ns, no gradient */
} Fwd;

static Fwd forward(const MfNmapFrame *f, const MfImage *map, MfVec2 uv, MfVec3 wo) {
    Fwd r = {mf_v3s(0.0f), 0.0f, f->ns, 0.0f, 1};
    float tx[16];
    if (map->c < 3 || map->c > 16) return r;
    mf_tex_sample(map, uv.x, uv.y, MF_WRAP_REPEAT, tx);
    float x = 2.0f * tx[0] - 1.0f, y = 2.0f * tx[1] - 1.0f, z = 2.0f * tx[2] - 1.0f;
    MfVec3 m = mf_add(mf_add(mf_scale(f->t, x), mf_scale(f->b, y)), mf_scale(f->n, z));
    float lm = mf_len(m);
    if (!(lm > 1e-8f) || !isfinite(lm)) return r;
    r.lm = lm;
    r.n = mf_scale(m, f->side / lm);
    float c = mf_dot(r.n, wo);
    if (c >= BEND_MIN) {
        r.nb = r.n;
        r.fallback = 0;
        return r;
    }
    MfVec3 mb = mf_madd(r.n, wo, BEND_MIN - c);
    float lb = mf_len(mb);
    if (!(lb > 1e-8f) || !isfinite(lb)) return r;
    MfVec3 nb = mf_scale(mb, 1.0f / lb);
    if (!(mf_dot(nb, wo) > 0.0f)) return r;
    r.nb = nb;
    r.lb = lb;
    r.fallback = 0;
    return r;
}

MfVec3 mf_nmap_normal(const MfNmapFrame *f, const MfImage *map, MfVec2 uv, MfVec3 wo) { return forward(f, map, uv, wo).nb; }

void mf_nmap_normal_backward(const MfNmapFrame *f, const MfImage *map, MfVec2 uv, MfVec3 wo, MfVec3 dn, float *dmap) {
    Fwd r = forward(f, map, uv, wo);
    if (r.fallback || map->c > 16) return;
    MfVec3 g = dn;
    if (r.lb > 0.0f) { /* nb = mb / |mb|, mb = (I - wo wo^T) n + BEND_MIN wo */
        MfVec3 gm = mf_scale(mf_sub(g, mf_scale(r.nb, mf_dot(r.nb, g))), 1.0f / r.lb);
        g = mf_sub(gm, mf_scale(wo, mf_dot(wo, gm)));
    }
    /* n = side m / |m| */
    MfVec3 nu = mf_scale(r.n, f->side); /* m / |m| */
    g = mf_scale(g, f->side);
    MfVec3 gm = mf_scale(mf_sub(g, mf_scale(nu, mf_dot(nu, g))), 1.0f / r.lm);
    float gt[4] = {2.0f * mf_dot(f->t, gm), 2.0f * mf_dot(f->b, gm), 2.0f * mf_dot(f->n, gm), 0.0f};
    if (map->c == 3) {
        mf_tex_sample_backward(map, uv.x, uv.y, MF_WRAP_REPEAT, gt, dmap);
    } else {
        float gc[16] = {gt[0], gt[1], gt[2]}; /* extra channels get nothing */
        mf_tex_sample_backward(map, uv.x, uv.y, MF_WRAP_REPEAT, gc, dmap);
    }
}
