#include "geom/mf_tetgrid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

/* The 6 Kuhn tets of a cube as corner codes (bit 0: +x, bit 1: +y, bit 2: +z): the paths
 * 0 -> e_p -> e_p + e_q -> 7 over the 6 axis orders (p, q, r). */
static const int KUHN[6][4] = {
    {0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7},
};

MfTetGrid mf_tetgrid_make(int res, MfVec3 c, float extent) {
    MfTetGrid g = {res, mf_sub(c, mf_v3s(0.5f * extent)), extent / (float)res};
    return g;
}

size_t mf_tetgrid_nverts(const MfTetGrid *g) {
    size_t n = (size_t)g->res + 1;
    return n * n * n;
}

MfVec3 mf_tetgrid_base(const MfTetGrid *g, size_t v) {
    size_t n = (size_t)g->res + 1;
    size_t i = v % n, j = (v / n) % n, k = v / (n * n);
    return mf_add(g->lo, mf_v3(g->cell * (float)i, g->cell * (float)j, g->cell * (float)k));
}

float mf_tetgrid_sample(const MfTetGrid *g, const float *field, MfVec3 p, float outside) {
    float x[3] = {(p.x - g->lo.x) / g->cell, (p.y - g->lo.y) / g->cell, (p.z - g->lo.z) / g->cell}, t[3];
    size_t n = (size_t)g->res + 1, i[3];
    for (int a = 0; a < 3; ++a) {
        if (!(x[a] >= 0 && x[a] <= (float)g->res)) return outside;
        float c = fminf(floorf(x[a]), (float)(g->res - 1));
        i[a] = (size_t)c, t[a] = x[a] - c;
    }
    float v = 0;
    for (int c = 0; c < 8; ++c) {
        float w = 1;
        for (int a = 0; a < 3; ++a) w *= c >> a & 1 ? t[a] : 1 - t[a];
        v += w * field[(i[0] + (c & 1)) + n * ((i[1] + (c >> 1 & 1)) + n * (i[2] + (c >> 2 & 1)))];
    }
    return v;
}

static MfVec3 vert_pos(const MfTetGrid *g, const float *deform, size_t v) {
    MfVec3 p = mf_tetgrid_base(g, v);
    if (!deform) return p;
    float s = 0.5f * g->cell;
    return mf_add(p, mf_v3(s * tanhf(deform[3 * v]), s * tanhf(deform[3 * v + 1]), s * tanhf(deform[3 * v + 2])));
}

void mf_tetmesh_free(MfTetMesh *m) {
    if (!m) return;
    mf_mesh_free(&m->mesh);
    free(m->edge);
    free(m->t);
    memset(m, 0, sizeof *m);
}

/* Grid vertex of cube (i, j, k)'s corner code c. */
static size_t corner_vertex(size_t n, size_t i, size_t j, size_t k, int c) {
    return (i + (c & 1)) + n * ((j + ((c >> 1) & 1)) + n * (k + ((c >> 2) & 1)));
}

/* Global id of the tet edge between corners ca < cb (cb - ca has only bits of cb set: Kuhn
 * edges go from a corner to a componentwise-greater one): lower vertex * 7 + direction - 1. */
static size_t edge_id(size_t n, size_t i, size_t j, size_t k, int ca, int cb) {
    return corner_vertex(n, i, j, k, ca) * 7 + (size_t)((cb ^ ca) - 1);
}

typedef struct {
    size_t cap, n;
    uint32_t *tri; /* (cap, 3) */
} TriBuf;

static int tri_push(TriBuf *b, uint32_t a, uint32_t c, uint32_t d) {
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        uint32_t *t = realloc(b->tri, cap * 3 * sizeof *t);
        if (!t) return MF_ENOMEM;
        b->tri = t;
        b->cap = cap;
    }
    b->tri[3 * b->n] = a, b->tri[3 * b->n + 1] = c, b->tri[3 * b->n + 2] = d;
    ++b->n;
    return MF_OK;
}

int mf_tetgrid_extract(const MfTetGrid *g, const float *sdf, const float *deform, MfTetMesh *out) {
    if (g->res < 1 || !(g->cell > 0)) return mf_fail(MF_EARG, "marching tets: bad grid (res %d, cell %g)", g->res, g->cell);
    size_t nv = mf_tetgrid_nverts(g), n = (size_t)g->res + 1;
    for (size_t v = 0; v < nv; ++v) {
        if (!isfinite(sdf[v])) return mf_fail(MF_ENAN, "marching tets: sdf[%zu] is not finite", v);
        if (deform && !(isfinite(deform[3 * v]) && isfinite(deform[3 * v + 1]) && isfinite(deform[3 * v + 2])))
            return mf_fail(MF_ENAN, "marching tets: deform[%zu] is not finite", v);
    }
    int32_t *emap = malloc(nv * 7 * sizeof *emap); /* (nv * 7,) edge id -> output vertex or -1 */
    if (!emap) return mf_fail(MF_ENOMEM, "marching tets: out of memory");
    memset(emap, 0xff, nv * 7 * sizeof *emap);
    size_t nout = 0, ecap = 0;
    int32_t *edge = NULL;
    float *tw = NULL;
    TriBuf tb = {0};
    int rc = MF_OK;
    for (size_t k = 0; k < n - 1 && rc == MF_OK; ++k)
        for (size_t j = 0; j < n - 1 && rc == MF_OK; ++j)
            for (size_t i = 0; i < n - 1 && rc == MF_OK; ++i) {
                int in8 = 0;
                for (int c = 0; c < 8; ++c) in8 |= (sdf[corner_vertex(n, i, j, k, c)] > 0) << c;
                if (in8 == 0 || in8 == 255) continue;
                for (int q = 0; q < 6 && rc == MF_OK; ++q) {
                    const int *tc = KUHN[q];
                    int ins[4], outs[4], ni = 0, no = 0;
                    for (int a = 0; a < 4; ++a) {
                        if (in8 >> tc[a] & 1) ins[ni++] = tc[a];
                        else outs[no++] = tc[a];
                    }
                    if (ni == 0 || no == 0) continue;
                    /* output vertices on the crossing edges, in a cycle for ni == 2:
                     * (i0 o0), (i0 o1), (i1 o1), (i1 o0) */
                    int pairs[4][2], np = 0;
                    if (ni == 1) for (int b = 0; b < 3; ++b) pairs[np][0] = ins[0], pairs[np++][1] = outs[b];
                    else if (no == 1) for (int b = 0; b < 3; ++b) pairs[np][0] = ins[b], pairs[np++][1] = outs[0];
                    else {
                        int cyc[4][2] = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
                        for (int b = 0; b < 4; ++b) pairs[np][0] = ins[cyc[b][0]], pairs[np++][1] = outs[cyc[b][1]];
                    }
                    uint32_t vid[4];
                    MfVec3 bp[4]; /* undeformed edge midpoints: the winding never degenerates */
                    for (int b = 0; b < np; ++b) {
                        int ca = pairs[b][0], cb = pairs[b][1];
                        if ((ca & cb) != ca) { int x = ca; ca = cb; cb = x; } /* lower corner first */
                        size_t va = corner_vertex(n, i, j, k, ca), vb = corner_vertex(n, i, j, k, cb);
                        size_t e = edge_id(n, i, j, k, ca, cb);
                        if (emap[e] < 0) {
                            if (nout == ecap) {
                                size_t cap = ecap ? 2 * ecap : 4096;
                                int32_t *ne = realloc(edge, cap * 2 * sizeof *ne);
                                if (ne) edge = ne;
                                float *nt = realloc(tw, cap * sizeof *nt);
                                if (nt) tw = nt;
                                if (!ne || !nt) { rc = MF_ENOMEM; break; }
                                ecap = cap;
                            }
                            edge[2 * nout] = (int32_t)va, edge[2 * nout + 1] = (int32_t)vb;
                            tw[nout] = sdf[va] / (sdf[va] - sdf[vb]);
                            emap[e] = (int32_t)nout++;
                        }
                        vid[b] = (uint32_t)emap[e];
                        bp[b] = mf_lerp3(mf_tetgrid_base(g, va), mf_tetgrid_base(g, vb), 0.5f);
                    }
                    if (rc != MF_OK) break;
                    /* Wind so the normal points from the inside corners to the outside ones. */
                    MfVec3 cin = mf_v3s(0), cout = mf_v3s(0);
                    for (int a = 0; a < ni; ++a) cin = mf_add(cin, mf_tetgrid_base(g, corner_vertex(n, i, j, k, ins[a])));
                    for (int a = 0; a < no; ++a) cout = mf_add(cout, mf_tetgrid_base(g, corner_vertex(n, i, j, k, outs[a])));
                    MfVec3 dir = mf_sub(mf_scale(cout, 1.0f / (float)no), mf_scale(cin, 1.0f / (float)ni));
                    MfVec3 nrm = mf_v3s(0); /* Newell's normal of the polygon */
                    for (int b = 0; b < np; ++b) nrm = mf_add(nrm, mf_cross(bp[b], bp[(b + 1) % np]));
                    if (mf_dot(nrm, dir) < 0) {
                        uint32_t x = vid[1]; vid[1] = vid[np - 1]; vid[np - 1] = x;
                    }
                    rc = tri_push(&tb, vid[0], vid[1], vid[2]);
                    if (rc == MF_OK && np == 4) rc = tri_push(&tb, vid[0], vid[2], vid[3]);
                }
            }
    free(emap);
    if (rc == MF_OK && nout == 0) rc = mf_fail(MF_EARG, "marching tets: the field has no zero crossing (empty grid)");
    else if (rc == MF_ENOMEM) mf_fail(rc, "marching tets: out of memory");
    MfTetMesh m = {0};
    if (rc == MF_OK && mf_mesh_alloc(&m.mesh, (int)nout, (int)tb.n, 0, 0) != MF_OK) rc = mf_fail(MF_ENOMEM, "marching tets: out of memory");
    if (rc != MF_OK) {
        free(edge), free(tw), free(tb.tri);
        mf_mesh_free(&m.mesh);
        return rc;
    }
    memcpy(m.mesh.tri, tb.tri, tb.n * 3 * sizeof *tb.tri);
    free(tb.tri);
    for (size_t o = 0; o < nout; ++o) {
        MfVec3 p = mf_lerp3(vert_pos(g, deform, (size_t)edge[2 * o]), vert_pos(g, deform, (size_t)edge[2 * o + 1]), tw[o]);
        m.mesh.pos[3 * o] = p.x, m.mesh.pos[3 * o + 1] = p.y, m.mesh.pos[3 * o + 2] = p.z;
    }
    m.edge = edge;
    m.t = tw;
    *out = m;
    return MF_OK;
}

void mf_tetgrid_backward(const MfTetGrid *g, const float *sdf, const float *deform, const MfTetMesh *m,
                         const float *dpos, float *dsdf, float *ddeform) {
    float s = 0.5f * g->cell;
    for (int o = 0; o < m->mesh.nv; ++o) {
        size_t va = (size_t)m->edge[2 * o], vb = (size_t)m->edge[2 * o + 1];
        float t = m->t[o];
        MfVec3 gp = mf_v3(dpos[3 * o], dpos[3 * o + 1], dpos[3 * o + 2]);
        MfVec3 pa = vert_pos(g, deform, va), pb = vert_pos(g, deform, vb);
        /* p = (1 - t) pa + t pb, t = fa / (fa - fb): dt/dfa = -fb / (fa - fb)^2, dt/dfb = fa / (fa - fb)^2 */
        float fa = sdf[va], fb = sdf[vb], den = (fa - fb) * (fa - fb);
        float gt = mf_dot(gp, mf_sub(pb, pa));
        dsdf[va] += gt * (-fb / den);
        dsdf[vb] += gt * (fa / den);
        if (deform && ddeform) {
            for (int c = 0; c < 3; ++c) {
                float ta = tanhf(deform[3 * va + c]), tb = tanhf(deform[3 * vb + c]);
                float gc = c == 0 ? gp.x : (c == 1 ? gp.y : gp.z);
                ddeform[3 * va + c] += gc * (1.0f - t) * s * (1.0f - ta * ta);
                ddeform[3 * vb + c] += gc * t * s * (1.0f - tb * tb);
            }
        }
    }
}
