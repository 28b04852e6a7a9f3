#include "scene/mf_tangent.h"

#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

static MfVec3 vget(const float *a, uint32_t i) { return mf_v3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }

int mf_mesh_tangents(const MfMesh *m, float *tan) {
    if (!m->uv) return mf_fail(MF_EARG, "tangents: the mesh has no UVs");
    size_t nv = (size_t)m->nv;
    float *acc = calloc(nv * 9 + 1, sizeof(float)); /* (nv, 3) T, (nv, 3) B, (nv, 3) face normals */
    if (!acc) return mf_fail(MF_ENOMEM, "tangents: out of memory for %d vertices", m->nv);
    float *at = acc, *ab = acc + 3 * nv, *an = acc + 6 * nv;
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *v = m->tri + 3 * (size_t)t;
        if (v[0] >= nv || v[1] >= nv || v[2] >= nv) continue;
        MfVec3 p0 = vget(m->pos, v[0]), e1 = mf_sub(vget(m->pos, v[1]), p0), e2 = mf_sub(vget(m->pos, v[2]), p0);
        MfVec3 fn = mf_cross(e1, e2); /* |fn| = 2 area */
        float area = 0.5f * mf_len(fn);
        if (!(area > 0.0f) || !isfinite(area)) continue;
        float du1 = m->uv[2 * v[1]] - m->uv[2 * v[0]], dv1 = m->uv[2 * v[1] + 1] - m->uv[2 * v[0] + 1];
        float du2 = m->uv[2 * v[2]] - m->uv[2 * v[0]], dv2 = m->uv[2 * v[2] + 1] - m->uv[2 * v[0] + 1];
        float r = du1 * dv2 - du2 * dv1;
        MfVec3 T = mf_sub(mf_scale(e1, dv2), mf_scale(e2, dv1)), B = mf_sub(mf_scale(e2, du1), mf_scale(e1, du2));
        int uv_ok = r != 0.0f && isfinite(r);
        if (uv_ok) {
            /* sign(r) orients both; their lengths (1/|r| scaled) are dropped */
            float lt = mf_len(T), lb = mf_len(B), sr = r > 0.0f ? 1.0f : -1.0f;
            uv_ok = lt > 0.0f && lb > 0.0f && isfinite(lt) && isfinite(lb);
            if (uv_ok) {
                T = mf_scale(T, sr * area / lt);
                B = mf_scale(B, sr * area / lb);
            }
        }
        for (int k = 0; k < 3; ++k) {
            float *pt = at + 3 * v[k], *pb = ab + 3 * v[k], *pn = an + 3 * v[k];
            pn[0] += 0.5f * fn.x, pn[1] += 0.5f * fn.y, pn[2] += 0.5f * fn.z;
            if (!uv_ok) continue;
            pt[0] += T.x, pt[1] += T.y, pt[2] += T.z;
            pb[0] += B.x, pb[1] += B.y, pb[2] += B.z;
        }
    }
    for (size_t i = 0; i < nv; ++i) {
        MfVec3 n = m->nrm ? vget(m->nrm, (uint32_t)i) : vget(an, (uint32_t)i);
        float ln = mf_len(n);
        if (!(ln > 0.0f) || !isfinite(ln)) {
            n = vget(an, (uint32_t)i);
            ln = mf_len(n);
        }
        n = (ln > 0.0f && isfinite(ln)) ? mf_scale(n, 1.0f / ln) : mf_v3(0.0f, 0.0f, 1.0f);
        MfVec3 t = vget(at, (uint32_t)i), b = vget(ab, (uint32_t)i);
        t = mf_sub(t, mf_scale(n, mf_dot(n, t)));
        float lt = mf_len(t), w = 1.0f;
        if (lt > 1e-6f * (mf_len(vget(at, (uint32_t)i)) + 1e-30f) && lt > 0.0f && isfinite(lt)) {
            t = mf_scale(t, 1.0f / lt);
            if (mf_dot(mf_cross(n, t), b) < 0.0f) w = -1.0f;
        } else {
            t = mf_frame(n).t;
        }
        tan[4 * i] = t.x, tan[4 * i + 1] = t.y, tan[4 * i + 2] = t.z, tan[4 * i + 3] = w;
    }
    free(acc);
    return MF_OK;
}
