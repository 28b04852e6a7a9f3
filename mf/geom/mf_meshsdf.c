#include "geom/mf_meshsdf.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "core/mf_error.h"

static MfVec3 vat(const float *p, uint32_t i) { return mf_v3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

/* The point of triangle abc nearest p, as barycentric weights (u, v, w) of a, b, c (Ericson,
 * Real-Time Collision Detection, 5.1.5: Voronoi regions of the vertices, edges and face). */
static void closest_bary(MfVec3 p, MfVec3 a, MfVec3 b, MfVec3 c, float *u, float *v, float *w) {
    MfVec3 ab = mf_sub(b, a), ac = mf_sub(c, a), ap = mf_sub(p, a);
    float d1 = mf_dot(ab, ap), d2 = mf_dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) { *u = 1, *v = 0, *w = 0; return; }
    MfVec3 bp = mf_sub(p, b);
    float d3 = mf_dot(ab, bp), d4 = mf_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) { *u = 0, *v = 1, *w = 0; return; }
    float vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) { float t = d1 / (d1 - d3); *u = 1 - t, *v = t, *w = 0; return; }
    MfVec3 cp = mf_sub(p, c);
    float d5 = mf_dot(ab, cp), d6 = mf_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) { *u = 0, *v = 0, *w = 1; return; }
    float vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) { float t = d2 / (d2 - d6); *u = 1 - t, *v = 0, *w = t; return; }
    float va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        float t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        *u = 0, *v = 1 - t, *w = t;
        return;
    }
    float den = va + vb + vc;
    if (!(den > 0)) { *u = 1, *v = 0, *w = 0; return; } /* degenerate triangle: its first corner */
    *v = vb / den, *w = vc / den, *u = 1 - *v - *w;
}

static int clampi(int x, int lo, int hi) { return x < lo ? lo : x > hi ? hi : x; }

/* The vertices farther than the shell from the mesh (best[v] >= shell2) form regions that the
 * shell separates (it is more than a cell thick on each side of the surface, and the regions are
 * joined by grid edges, 6-neighbours); each region takes the sign most of its vertices have (a
 * tie: outside): inside the band (best[v] < band2) the nearest feature's, already in sdf, beyond
 * it far_sign's; with its vertices' own distances (best, at most the band). */
static int far_regions(const MfTetGrid *g, const float *best, float shell2, float band2, const float *far_sign, float *sdf) {
    size_t nv = mf_tetgrid_nverts(g), n1 = (size_t)g->res + 1;
    signed char *label = malloc(nv * sizeof *label); /* -1: in the shell; 0: beyond it, not yet reached; 1: reached */
    size_t *queue = malloc(nv * sizeof *queue);
    if (!label || !queue) {
        free(label), free(queue);
        return mf_fail(MF_ENOMEM, "mesh SDF: out of memory");
    }
    for (size_t v = 0; v < nv; ++v) label[v] = best[v] < shell2 ? -1 : 0;
    for (size_t seed = 0; seed < nv; ++seed) {
        if (label[seed] != 0) continue;
        size_t head = 0, tail = 0;
        long vote = 0;
        queue[tail++] = seed, label[seed] = 1;
        while (head < tail) { /* breadth-first over the region, which queue then lists */
            size_t v = queue[head++], i = v % n1, j = v / n1 % n1, k = v / (n1 * n1);
            vote += (best[v] < band2 ? sdf[v] : far_sign[v]) > 0 ? 1 : -1;
            size_t nb[6] = {i > 0 ? v - 1 : v, i + 1 < n1 ? v + 1 : v, j > 0 ? v - n1 : v,
                            j + 1 < n1 ? v + n1 : v, k > 0 ? v - n1 * n1 : v, k + 1 < n1 ? v + n1 * n1 : v};
            for (int a = 0; a < 6; ++a)
                if (label[nb[a]] == 0) label[nb[a]] = 1, queue[tail++] = nb[a];
        }
        for (size_t q = 0; q < tail; ++q) sdf[queue[q]] = vote > 0 ? sqrtf(best[queue[q]]) : -sqrtf(best[queue[q]]);
    }
    free(label), free(queue);
    return MF_OK;
}

typedef struct { uint32_t a, b; int slot; } EdgeKey; /* slot: 3 t + the opposite corner */

static int cmp_edge(const void *x, const void *y) {
    const EdgeKey *p = x, *q = y;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    if (p->b != q->b) return p->b < q->b ? -1 : 1;
    return (p->slot > q->slot) - (p->slot < q->slot);
}

/* Angle-weighted pseudonormals (Baerentzen and Aanaes 2005), whose sign test is exact on a closed
 * mesh wherever the nearest point lies: fn (nt, 3) face normals; vn (nv, 3) each vertex's face
 * normals weighted by the angle there; en (nt, 3, 3) per triangle and opposite corner, the sum of
 * the normals of the faces sharing that edge. */
static int pseudonormals(const MfMesh *m, MfVec3 *fn, MfVec3 *vn, MfVec3 *en) {
    EdgeKey *e = malloc((size_t)m->nt * 3 * sizeof *e);
    if (!e) return mf_fail(MF_ENOMEM, "mesh SDF: out of memory");
    for (int v = 0; v < m->nv; ++v) vn[v] = mf_v3s(0);
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 p[3] = {vat(m->pos, f[0]), vat(m->pos, f[1]), vat(m->pos, f[2])};
        MfVec3 n = mf_cross(mf_sub(p[1], p[0]), mf_sub(p[2], p[0]));
        float len = mf_len(n);
        fn[t] = len > 0 ? mf_scale(n, 1.0f / len) : mf_v3s(0);
        for (int c = 0; c < 3; ++c) {
            MfVec3 d1 = mf_sub(p[(c + 1) % 3], p[c]), d2 = mf_sub(p[(c + 2) % 3], p[c]);
            float l = mf_len(d1) * mf_len(d2);
            float ang = l > 0 ? acosf(mf_clampf(mf_dot(d1, d2) / l, -1, 1)) : 0;
            vn[f[c]] = mf_madd(vn[f[c]], fn[t], ang);
            uint32_t a = f[(c + 1) % 3], b = f[(c + 2) % 3];
            e[3 * t + c] = (EdgeKey){a < b ? a : b, a < b ? b : a, 3 * t + c};
        }
    }
    size_t ne = (size_t)m->nt * 3;
    qsort(e, ne, sizeof *e, cmp_edge);
    for (size_t i = 0, j; i < ne; i = j) { /* each run of one edge: the sum of its faces' normals */
        MfVec3 sum = mf_v3s(0);
        for (j = i; j < ne && e[j].a == e[i].a && e[j].b == e[i].b; ++j) sum = mf_add(sum, fn[e[j].slot / 3]);
        for (size_t k = i; k < j; ++k) en[e[k].slot] = sum;
    }
    free(e);
    return MF_OK;
}

int mf_meshsdf_grid(const MfTetGrid *g, const MfMesh *m, const float *far_sign, float band_cells, float *sdf) {
    if (!m || m->nv < 3 || m->nt < 1) return mf_fail(MF_EARG, "mesh SDF: empty mesh");
    if (!(band_cells > 0)) return mf_fail(MF_EARG, "mesh SDF: band %g cells (must be > 0)", (double)band_cells);
    size_t nv = mf_tetgrid_nverts(g);
    float *best = malloc(nv * sizeof *best);
    MfVec3 *fn = malloc((size_t)m->nt * sizeof *fn), *vn = malloc((size_t)m->nv * sizeof *vn), *en = malloc((size_t)m->nt * 3 * sizeof *en);
    int rc = best && fn && vn && en ? pseudonormals(m, fn, vn, en) : mf_fail(MF_ENOMEM, "mesh SDF: out of memory");
    if (rc) {
        free(best), free(fn), free(vn), free(en);
        return rc;
    }
    float band = band_cells * g->cell;
    for (size_t i = 0; i < nv; ++i) best[i] = band * band;
    int n1 = g->res + 1, r = (int)ceilf(band_cells);
    /* one z plane per task, every triangle near it in index order: each vertex sees the triangles
     * in the same order whatever the thread count */
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < n1; ++k)
        for (int t = 0; t < m->nt; ++t) {
            MfVec3 a = vat(m->pos, m->tri[3 * t]), b = vat(m->pos, m->tri[3 * t + 1]), q = vat(m->pos, m->tri[3 * t + 2]);
            float zlo = fminf(a.z, fminf(b.z, q.z)), zhi = fmaxf(a.z, fmaxf(b.z, q.z));
            float z = g->lo.z + g->cell * (float)k;
            if (z < zlo - band || z > zhi + band) continue;
            int i0 = clampi((int)floorf((fminf(a.x, fminf(b.x, q.x)) - g->lo.x) / g->cell) - r, 0, n1 - 1);
            int i1 = clampi((int)ceilf((fmaxf(a.x, fmaxf(b.x, q.x)) - g->lo.x) / g->cell) + r, 0, n1 - 1);
            int j0 = clampi((int)floorf((fminf(a.y, fminf(b.y, q.y)) - g->lo.y) / g->cell) - r, 0, n1 - 1);
            int j1 = clampi((int)ceilf((fmaxf(a.y, fmaxf(b.y, q.y)) - g->lo.y) / g->cell) + r, 0, n1 - 1);
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    size_t idx = (size_t)i + (size_t)n1 * ((size_t)j + (size_t)n1 * (size_t)k);
                    MfVec3 p = mf_tetgrid_base(g, idx);
                    float u, v, w;
                    closest_bary(p, a, b, q, &u, &v, &w);
                    MfVec3 x = mf_add(mf_add(mf_scale(a, u), mf_scale(b, v)), mf_scale(q, w));
                    MfVec3 d = mf_sub(p, x);
                    float d2 = mf_dot(d, d);
                    if (!(d2 < best[idx])) continue;
                    /* the nearest point's feature: a corner (two weights 0), an edge (one), the face */
                    int zeros = (u == 0) + (v == 0) + (w == 0);
                    MfVec3 n = zeros == 0 ? fn[t]
                             : zeros == 2 ? vn[m->tri[3 * t + (u == 1 ? 0 : v == 1 ? 1 : 2)]]
                                          : en[3 * t + (u == 0 ? 0 : v == 0 ? 1 : 2)];
                    best[idx] = d2;
                    sdf[idx] = mf_dot(d, n) > 0 ? -sqrtf(d2) : sqrtf(d2);
                }
        }
    float shell = MF_MESHSDF_SHELL * g->cell;
    rc = far_regions(g, best, shell * shell, band * band, far_sign, sdf);
    free(best), free(fn), free(vn), free(en);
    return rc;
}
