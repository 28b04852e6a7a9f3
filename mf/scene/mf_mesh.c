#include "scene/mf_mesh.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

int mf_mesh_alloc(MfMesh *m, int nv, int nt, int with_nrm, int with_uv) {
    if (nv < 0 || nt < 0) return mf_fail(MF_EARG, "mesh size %d vertices, %d triangles is invalid", nv, nt);
    MfMesh r = {0};
    r.nv = nv;
    r.nt = nt;
    r.pos = calloc((size_t)nv * 3 + 1, sizeof(float));
    r.tri = calloc((size_t)nt * 3 + 1, sizeof(uint32_t));
    if (with_nrm) r.nrm = calloc((size_t)nv * 3 + 1, sizeof(float));
    if (with_uv) r.uv = calloc((size_t)nv * 2 + 1, sizeof(float));
    if (!r.pos || !r.tri || (with_nrm && !r.nrm) || (with_uv && !r.uv)) {
        mf_mesh_free(&r);
        return mf_fail(MF_ENOMEM, "out of memory for a mesh of %d vertices", nv);
    }
    *m = r;
    return MF_OK;
}

void mf_mesh_free(MfMesh *m) {
    if (!m) return;
    free(m->pos);
    free(m->nrm);
    free(m->uv);
    free(m->tri);
    free(m->mat);
    if (m->mat_names)
        for (int i = 0; i < m->nmat; ++i) free(m->mat_names[i]);
    free(m->mat_names);
    memset(m, 0, sizeof *m);
}

static MfVec3 vtx(const MfMesh *m, uint32_t i) { return mf_v3(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]); }

int mf_mesh_compute_normals(MfMesh *m) {
    if (!m->nrm) {
        m->nrm = calloc((size_t)m->nv * 3 + 1, sizeof(float));
        if (!m->nrm) return mf_fail(MF_ENOMEM, "out of memory for mesh normals");
    } else {
        memset(m->nrm, 0, (size_t)m->nv * 3 * sizeof(float));
    }
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 n = mf_cross(mf_sub(vtx(m, f[1]), vtx(m, f[0])), mf_sub(vtx(m, f[2]), vtx(m, f[0])));
        for (int k = 0; k < 3; ++k) {
            m->nrm[3 * f[k]] += n.x;
            m->nrm[3 * f[k] + 1] += n.y;
            m->nrm[3 * f[k] + 2] += n.z;
        }
    }
    for (int i = 0; i < m->nv; ++i) {
        MfVec3 n = mf_v3(m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
        float l = mf_len(n);
        n = l > 0.0f ? mf_scale(n, 1.0f / l) : mf_v3(0, 0, 1);
        m->nrm[3 * i] = n.x;
        m->nrm[3 * i + 1] = n.y;
        m->nrm[3 * i + 2] = n.z;
    }
    return MF_OK;
}

/* Adjoint of mf_mesh_compute_normals: n_i = A_i / |A_i|, A_i = sum over the triangles t at i of
 * c_t = (p1 - p0) x (p2 - p0). */
int mf_mesh_normals_backward(const MfMesh *m, const float *dnrm, float *dpos) {
    float *A = calloc((size_t)m->nv * 3 + 1, sizeof(float)); /* (nv, 3) A_i, then dLoss/dA_i */
    if (!A) return mf_fail(MF_ENOMEM, "out of memory for the mesh normals' adjoint");
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 n = mf_cross(mf_sub(vtx(m, f[1]), vtx(m, f[0])), mf_sub(vtx(m, f[2]), vtx(m, f[0])));
        for (int k = 0; k < 3; ++k) {
            A[3 * f[k]] += n.x;
            A[3 * f[k] + 1] += n.y;
            A[3 * f[k] + 2] += n.z;
        }
    }
    for (int i = 0; i < m->nv; ++i) { /* d(A/|A|) = (g - n (n.g)) / |A|; a zero A gives the constant (0, 0, 1) */
        MfVec3 a = mf_v3(A[3 * i], A[3 * i + 1], A[3 * i + 2]), g = mf_v3(dnrm[3 * i], dnrm[3 * i + 1], dnrm[3 * i + 2]);
        float l = mf_len(a);
        MfVec3 d = mf_v3s(0.0f);
        if (l > 0.0f) {
            MfVec3 n = mf_scale(a, 1.0f / l);
            d = mf_scale(mf_madd(g, n, -mf_dot(n, g)), 1.0f / l);
        }
        A[3 * i] = d.x;
        A[3 * i + 1] = d.y;
        A[3 * i + 2] = d.z;
    }
    for (int t = 0; t < m->nt; ++t) { /* dc_t = sum of dA at its corners; d(e1 x e2) = (e2 x g, g x e1) */
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 g = mf_v3s(0.0f);
        for (int k = 0; k < 3; ++k) g = mf_add(g, mf_v3(A[3 * f[k]], A[3 * f[k] + 1], A[3 * f[k] + 2]));
        MfVec3 e1 = mf_sub(vtx(m, f[1]), vtx(m, f[0])), e2 = mf_sub(vtx(m, f[2]), vtx(m, f[0]));
        MfVec3 g1 = mf_cross(e2, g), g2 = mf_cross(g, e1);
        MfVec3 g0 = mf_neg(mf_add(g1, g2));
        const MfVec3 gk[3] = {g0, g1, g2};
        for (int k = 0; k < 3; ++k) {
            dpos[3 * f[k]] += gk[k].x;
            dpos[3 * f[k] + 1] += gk[k].y;
            dpos[3 * f[k] + 2] += gk[k].z;
        }
    }
    free(A);
    return MF_OK;
}

/* One smoothing step's sums: acc (nv, 3) = n_v + the kept neighbours' n (mf_mesh_smooth_normals);
 * with transpose, the same sums of g (the neighbour relation is symmetric, so the operator is its
 * own transpose; the choice still comes from n). */
static void smooth_sums(const MfMesh *m, const float *n, const float *g, float min_cos, float *acc) {
    memcpy(acc, g, (size_t)m->nv * 3 * sizeof(float));
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const float *a = n + 3 * f[i], *b = n + 3 * f[j];
                if (i == j || a[0] * b[0] + a[1] * b[1] + a[2] * b[2] < min_cos) continue;
                for (int c = 0; c < 3; ++c) acc[3 * f[i] + c] += g[3 * f[j] + c];
            }
    }
}

int mf_mesh_smooth_normals(MfMesh *m, int iters, float min_cos, float *hist) {
    if (iters <= 0) return MF_OK;
    if (!m->nrm) return mf_fail(MF_EARG, "smoothing normals: the mesh has none");
    if (!(min_cos >= 0.0f && min_cos <= 1.0f)) return mf_fail(MF_EARG, "smoothing normals: min_cos %g is outside [0, 1]", (double)min_cos);
    float *acc = malloc((size_t)m->nv * 3 * sizeof(float) + 1), *in = hist;
    if (!acc || (!hist && !(in = malloc((size_t)m->nv * 3 * sizeof(float) + 1)))) {
        free(acc);
        return mf_fail(MF_ENOMEM, "out of memory for smoothing %d vertex normals", m->nv);
    }
    for (int k = 0; k < iters; ++k) {
        float *cur = hist ? hist + (size_t)k * m->nv * 3 : in;
        memcpy(cur, m->nrm, (size_t)m->nv * 3 * sizeof(float));
        smooth_sums(m, cur, cur, min_cos, acc);
        for (int v = 0; v < m->nv; ++v) { /* |sum| >= 1: the unit n_v plus neighbours at a non-negative cosine */
            MfVec3 a = mf_v3(acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]);
            a = mf_scale(a, 1.0f / mf_len(a));
            m->nrm[3 * v] = a.x, m->nrm[3 * v + 1] = a.y, m->nrm[3 * v + 2] = a.z;
        }
    }
    free(acc);
    if (!hist) free(in);
    return MF_OK;
}

int mf_mesh_smooth_normals_backward(const MfMesh *m, int iters, float min_cos, const float *hist, float *dnrm) {
    if (iters <= 0) return MF_OK;
    float *acc = malloc((size_t)m->nv * 3 * sizeof(float) + 1), *ga = malloc((size_t)m->nv * 3 * sizeof(float) + 1);
    if (!acc || !ga) {
        free(acc), free(ga);
        return mf_fail(MF_ENOMEM, "out of memory for the adjoint of %d smoothed vertex normals", m->nv);
    }
    for (int k = iters - 1; k >= 0; --k) {
        const float *in = hist + (size_t)k * m->nv * 3;
        smooth_sums(m, in, in, min_cos, acc);
        for (int v = 0; v < m->nv; ++v) { /* d(a/|a|) = (g - u (u.g)) / |a| */
            MfVec3 a = mf_v3(acc[3 * v], acc[3 * v + 1], acc[3 * v + 2]), g = mf_v3(dnrm[3 * v], dnrm[3 * v + 1], dnrm[3 * v + 2]);
            float l = mf_len(a);
            MfVec3 u = mf_scale(a, 1.0f / l), d = mf_scale(mf_madd(g, u, -mf_dot(u, g)), 1.0f / l);
            ga[3 * v] = d.x, ga[3 * v + 1] = d.y, ga[3 * v + 2] = d.z;
        }
        smooth_sums(m, in, ga, min_cos, dnrm);
    }
    free(acc), free(ga);
    return MF_OK;
}

void mf_mesh_bounds(const MfMesh *m, MfVec3 *lo, MfVec3 *hi) {
    MfVec3 a = mf_v3s(FLT_MAX), b = mf_v3s(-FLT_MAX);
    for (int i = 0; i < m->nv; ++i) {
        MfVec3 p = vtx(m, (uint32_t)i);
        a = mf_v3(fminf(a.x, p.x), fminf(a.y, p.y), fminf(a.z, p.z));
        b = mf_v3(fmaxf(b.x, p.x), fmaxf(b.y, p.y), fmaxf(b.z, p.z));
    }
    *lo = a;
    *hi = b;
}

int mf_mesh_count_degenerate(const MfMesh *m, float eps) {
    int n = 0;
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 c = mf_cross(mf_sub(vtx(m, f[1]), vtx(m, f[0])), mf_sub(vtx(m, f[2]), vtx(m, f[0])));
        if (!(0.5f * mf_len(c) > eps)) ++n;
    }
    return n;
}

void mf_mesh_normalize(MfMesh *m, float extent) {
    if (m->nv == 0) return;
    MfVec3 lo, hi;
    mf_mesh_bounds(m, &lo, &hi);
    MfVec3 c = mf_scale(mf_add(lo, hi), 0.5f), d = mf_sub(hi, lo);
    float big = mf_maxc(d);
    float s = big > 0.0f ? extent / big : 1.0f;
    for (int i = 0; i < m->nv; ++i)
        for (int k = 0; k < 3; ++k) m->pos[3 * i + k] = (m->pos[3 * i + k] - (&c.x)[k]) * s;
}

int mf_mesh_append(MfMesh *a, const MfMesh *b) {
    int nv = a->nv + b->nv, nt = a->nt + b->nt;
    int want_nrm = a->nrm && b->nrm, want_uv = (a->uv || a->nv == 0) && b->uv;
    MfMesh r;
    int rc = mf_mesh_alloc(&r, nv, nt, want_nrm, want_uv);
    if (rc) return rc;
    memcpy(r.pos, a->pos, (size_t)a->nv * 3 * sizeof(float));
    memcpy(r.pos + (size_t)a->nv * 3, b->pos, (size_t)b->nv * 3 * sizeof(float));
    if (want_nrm) {
        memcpy(r.nrm, a->nrm, (size_t)a->nv * 3 * sizeof(float));
        memcpy(r.nrm + (size_t)a->nv * 3, b->nrm, (size_t)b->nv * 3 * sizeof(float));
    }
    if (want_uv) {
        if (a->nv) memcpy(r.uv, a->uv, (size_t)a->nv * 2 * sizeof(float));
        memcpy(r.uv + (size_t)a->nv * 2, b->uv, (size_t)b->nv * 2 * sizeof(float));
    }
    memcpy(r.tri, a->tri, (size_t)a->nt * 3 * sizeof(uint32_t));
    for (size_t i = 0; i < (size_t)b->nt * 3; ++i) r.tri[(size_t)a->nt * 3 + i] = b->tri[i] + (uint32_t)a->nv;
    r.mat = calloc((size_t)nt + 1, sizeof(int));
    if (!r.mat) { mf_mesh_free(&r); return mf_fail(MF_ENOMEM, "out of memory"); }
    int amat = a->nmat > 0 ? a->nmat : 1, bmat = b->nmat > 0 ? b->nmat : 1;
    for (int t = 0; t < a->nt; ++t) r.mat[t] = a->mat ? a->mat[t] : 0;
    for (int t = 0; t < b->nt; ++t) r.mat[a->nt + t] = amat + (b->mat ? b->mat[t] : 0);
    r.nmat = amat + bmat;
    mf_mesh_free(a);
    *a = r;
    return MF_OK;
}

int mf_mesh_uv_sphere(MfMesh *m, int nu, int nv, MfVec3 c, float r) {
    if (nu < 3 || nv < 2) return mf_fail(MF_EARG, "uv sphere needs nu >= 3 and nv >= 2 (got %d, %d)", nu, nv);
    MfMesh s;
    int rc = mf_mesh_alloc(&s, (nu + 1) * (nv + 1), 2 * nu * (nv - 1), 1, 1);
    if (rc) return rc;
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i <= nu; ++i) {
            int k = j * (nu + 1) + i;
            float th = MF_PI * (float)j / (float)nv, ph = 2.0f * MF_PI * (float)i / (float)nu;
            MfVec3 n = mf_v3(sinf(th) * cosf(ph), sinf(th) * sinf(ph), cosf(th));
            if (j == 0 || j == nv) n = mf_v3(0, 0, j == 0 ? 1.0f : -1.0f);
            s.nrm[3 * k] = n.x, s.nrm[3 * k + 1] = n.y, s.nrm[3 * k + 2] = n.z;
            s.pos[3 * k] = c.x + r * n.x, s.pos[3 * k + 1] = c.y + r * n.y, s.pos[3 * k + 2] = c.z + r * n.z;
            s.uv[2 * k] = (float)i / (float)nu;
            s.uv[2 * k + 1] = 1.0f - (float)j / (float)nv;
        }
    int t = 0;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            uint32_t a = (uint32_t)(j * (nu + 1) + i), b = a + 1, d = a + (uint32_t)(nu + 1), e = d + 1;
            /* counter-clockwise seen from outside; skip the degenerate triangle at each pole */
            if (j != 0) { s.tri[3 * t] = a; s.tri[3 * t + 1] = d; s.tri[3 * t + 2] = b; ++t; }
            if (j != nv - 1) { s.tri[3 * t] = b; s.tri[3 * t + 1] = d; s.tri[3 * t + 2] = e; ++t; }
        }
    s.nt = t;
    *m = s;
    return MF_OK;
}

int mf_mesh_copy_materials(MfMesh *dst, const MfMesh *src) {
    if (src->mat) {
        if (!(dst->mat = malloc((size_t)src->nt * sizeof *dst->mat))) return mf_fail(MF_ENOMEM, "out of memory");
        memcpy(dst->mat, src->mat, (size_t)src->nt * sizeof *dst->mat);
    }
    dst->nmat = src->nmat;
    if (src->mat_names && src->nmat > 0) {
        if (!(dst->mat_names = calloc((size_t)src->nmat, sizeof *dst->mat_names))) return mf_fail(MF_ENOMEM, "out of memory");
        for (int i = 0; i < src->nmat; ++i)
            if (src->mat_names[i] && !(dst->mat_names[i] = strdup(src->mat_names[i]))) return mf_fail(MF_ENOMEM, "out of memory");
    }
    return MF_OK;
}
