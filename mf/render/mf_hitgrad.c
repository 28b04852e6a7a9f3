/* mf_hitgrad: adjoint of a hit's barycentrics, UV and shading normal (see mf_hitgrad.h). */
#include "render/mf_hitgrad.h"

#include <math.h>

static MfVec3 at3(const float *a, uint32_t i) { return mf_v3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }
static void add3(float *a, uint32_t i, MfVec3 v) {
    a[3 * i] += v.x;
    a[3 * i + 1] += v.y;
    a[3 * i + 2] += v.z;
}
/* d(v / |v|) applied to the adjoint g of the unit vector u = v / l */
static MfVec3 unit_backward(MfVec3 u, float l, MfVec3 g) { return mf_scale(mf_madd(g, u, -mf_dot(u, g)), 1.0f / l); }

void mf_hit_backward(const MfMesh *m, const MfHit *h, MfVec3 org, MfVec3 dir, MfVec2 duv, MfVec3 dp, MfVec3 dns,
                     float *dpos, float *dnrm) {
    const uint32_t *f = m->tri + 3 * h->tri;
    MfVec3 p0 = at3(m->pos, f[0]), p1 = at3(m->pos, f[1]), p2 = at3(m->pos, f[2]);
    MfVec3 e1 = mf_sub(p1, p0), e2 = mf_sub(p2, p0), s = mf_sub(org, p0), wo = mf_neg(dir);
    MfVec3 c = mf_cross(e1, e2);
    float lc = mf_len(c), det = mf_dot(e1, mf_cross(dir, e2));
    if (!(lc > 0.0f) || !isfinite(lc) || !(fabsf(det) > 0.0f)) return;
    float b[3] = {1.0f - h->b1 - h->b2, h->b1, h->b2};
    float gb[3] = {0.0f, 0.0f, 0.0f}; /* dLoss/d b_i, the b_i taken as independent */
    MfVec3 de1 = mf_v3s(0.0f), de2 = mf_v3s(0.0f);
    if (m->uv)
        for (int k = 0; k < 3; ++k) gb[k] += duv.x * m->uv[2 * f[k]] + duv.y * m->uv[2 * f[k] + 1];
    const MfVec3 pk[3] = {p0, p1, p2};
    for (int k = 0; k < 3; ++k) { /* p = sum b_k p_k: directly, and through the b_k below */
        gb[k] += mf_dot(dp, pk[k]);
        add3(dpos, f[k], mf_scale(dp, b[k]));
    }
    MfVec3 ngu = mf_scale(c, 1.0f / lc);
    float flip = mf_dot(ngu, wo) < 0.0f ? -1.0f : 1.0f;
    MfVec3 gu = mf_scale(dns, flip); /* adjoint of the unflipped unit normal */
    if (m->nrm) {
        MfVec3 n = mf_v3s(0.0f);
        for (int k = 0; k < 3; ++k) n = mf_madd(n, at3(m->nrm, f[k]), b[k]);
        float ln = mf_len(n);
        if (ln > 1e-12f && isfinite(ln) && mf_dot(n, wo) * flip / ln >= 0.01f) { /* not bent */
            MfVec3 dn = unit_backward(mf_scale(n, 1.0f / ln), ln, gu);
            for (int k = 0; k < 3; ++k) {
                gb[k] += mf_dot(dn, at3(m->nrm, f[k]));
                add3(dnrm, f[k], mf_scale(dn, b[k]));
            }
        }
    } else if (mf_dot(ngu, wo) * flip >= 0.01f) { /* ns = flip * c / |c|, c = e1 x e2 */
        MfVec3 dc = unit_backward(ngu, lc, gu);
        de1 = mf_add(de1, mf_cross(e2, dc));
        de2 = mf_add(de2, mf_cross(dc, e1));
    }
    /* b1 = [s, d, e2] / det, b2 = [d, s, e1] / det, det = [e1, d, e2] */
    float g1 = (gb[1] - gb[0]) / det, g2 = (gb[2] - gb[0]) / det, gdet = -(g1 * b[1] + g2 * b[2]);
    MfVec3 ds = mf_add(mf_scale(mf_cross(dir, e2), g1), mf_scale(mf_cross(e1, dir), g2));
    de2 = mf_add(de2, mf_add(mf_scale(mf_cross(s, dir), g1), mf_scale(mf_cross(e1, dir), gdet)));
    de1 = mf_add(de1, mf_add(mf_scale(mf_cross(dir, s), g2), mf_scale(mf_cross(dir, e2), gdet)));
    add3(dpos, f[0], mf_neg(mf_add(ds, mf_add(de1, de2))));
    add3(dpos, f[1], de1);
    add3(dpos, f[2], de2);
}
