#include "geom/mf_meshproc.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <meshoptimizer.h>

#include "core/mf_error.h"

static int oom(const char *what) { return mf_fail(MF_ENOMEM, "%s: out of memory", what); }

/* Replaces m by the triangles tri (nt, 3) (indices into m's vertices), keeping only the vertices
 * they use (in first-use order); normals, UVs and materials are dropped. */
static int compact(MfMesh *m, const uint32_t *tri, int nt, const char *what) {
    int32_t *map = malloc((size_t)(m->nv > 0 ? m->nv : 1) * sizeof *map);
    if (!map) return oom(what);
    memset(map, 0xff, (size_t)m->nv * sizeof *map);
    int nv = 0;
    for (size_t i = 0; i < (size_t)nt * 3; ++i)
        if (map[tri[i]] < 0) map[tri[i]] = nv++;
    MfMesh out = {0};
    if (mf_mesh_alloc(&out, nv, nt, 0, 0) != MF_OK) { free(map); return oom(what); }
    for (int v = 0; v < m->nv; ++v)
        if (map[v] >= 0) memcpy(out.pos + 3 * map[v], m->pos + 3 * v, 3 * sizeof(float));
    for (size_t i = 0; i < (size_t)nt * 3; ++i) out.tri[i] = (uint32_t)map[tri[i]];
    free(map);
    mf_mesh_free(m);
    *m = out;
    return MF_OK;
}

typedef struct { int64_t x, y, z; int v; } WeldKey;

static int cmp_weld(const void *a, const void *b) {
    const WeldKey *p = a, *q = b;
    if (p->x != q->x) return p->x < q->x ? -1 : 1;
    if (p->y != q->y) return p->y < q->y ? -1 : 1;
    if (p->z != q->z) return p->z < q->z ? -1 : 1;
    return (p->v > q->v) - (p->v < q->v);
}

int mf_mesh_weld(MfMesh *m, float eps) {
    if (!(eps > 0)) return mf_fail(MF_EARG, "mesh weld: eps must be > 0 (got %g)", eps);
    size_t nv = (size_t)(m->nv > 0 ? m->nv : 1);
    WeldKey *k = malloc(nv * sizeof *k);
    uint32_t *rep = malloc(nv * sizeof *rep), *tri = malloc((size_t)m->nt * 3 * sizeof *tri + 1);
    if (!k || !rep || !tri) { free(k), free(rep), free(tri); return oom("mesh weld"); }
    for (int v = 0; v < m->nv; ++v)
        k[v] = (WeldKey){(int64_t)floor(m->pos[3 * v] / eps), (int64_t)floor(m->pos[3 * v + 1] / eps),
                         (int64_t)floor(m->pos[3 * v + 2] / eps), v};
    qsort(k, (size_t)m->nv, sizeof *k, cmp_weld);
    /* in index order, v joins the representative of the lowest-index earlier vertex within eps
     * (searched in the 27 cells around v's) */
    for (int v = 0; v < m->nv; ++v) rep[v] = (uint32_t)v;
    WeldKey *byv = malloc(nv * sizeof *byv);
    if (!byv) { free(k), free(rep), free(tri); return oom("mesh weld"); }
    for (int i = 0; i < m->nv; ++i) byv[k[i].v] = k[i];
    for (int v = 0; v < m->nv; ++v) {
        const float *p = m->pos + 3 * v;
        int best = v;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    WeldKey q = {byv[v].x + dx, byv[v].y + dy, byv[v].z + dz, -1};
                    size_t lo = 0, hi = (size_t)m->nv; /* first key >= q */
                    while (lo < hi) {
                        size_t mid = (lo + hi) / 2;
                        if (cmp_weld(&k[mid], &q) < 0) lo = mid + 1;
                        else hi = mid;
                    }
                    for (size_t i = lo; i < (size_t)m->nv && k[i].x == q.x && k[i].y == q.y && k[i].z == q.z && k[i].v < best; ++i) {
                        const float *r = m->pos + 3 * k[i].v;
                        float ex = r[0] - p[0], ey = r[1] - p[1], ez = r[2] - p[2];
                        if (ex * ex + ey * ey + ez * ez <= eps * eps) best = k[i].v;
                    }
                }
        rep[v] = rep[best];
    }
    for (size_t i = 0; i < (size_t)m->nt * 3; ++i) tri[i] = rep[m->tri[i]];
    int rc = compact(m, tri, m->nt, "mesh weld");
    free(k), free(byv), free(rep), free(tri);
    return rc;
}

static double tri_area(const MfMesh *m, const uint32_t *t) {
    const float *a = m->pos + 3 * t[0], *b = m->pos + 3 * t[1], *c = m->pos + 3 * t[2];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

int mf_mesh_drop_degenerate(MfMesh *m, float area_eps) {
    uint32_t *tri = malloc((size_t)m->nt * 3 * sizeof *tri + 1);
    if (!tri) return oom("mesh degenerate clean-up");
    int nt = 0;
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *s = m->tri + 3 * t;
        if (s[0] == s[1] || s[1] == s[2] || s[0] == s[2] || !(tri_area(m, s) > area_eps)) continue;
        memcpy(tri + 3 * nt++, s, 3 * sizeof *s);
    }
    int rc = compact(m, tri, nt, "mesh degenerate clean-up");
    free(tri);
    return rc;
}

static uint32_t uf_find(uint32_t *p, uint32_t x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
}

/* Union-find parent array (nv,) joining the vertices of each triangle (uf_find gives a root). */
static uint32_t *components(const MfMesh *m) {
    uint32_t *p = malloc((size_t)(m->nv > 0 ? m->nv : 1) * sizeof *p);
    if (!p) return NULL;
    for (int v = 0; v < m->nv; ++v) p[v] = (uint32_t)v;
    for (int t = 0; t < m->nt; ++t)
        for (int e = 1; e < 3; ++e) {
            uint32_t a = uf_find(p, m->tri[3 * t]), b = uf_find(p, m->tri[3 * t + e]);
            if (a != b) p[a > b ? a : b] = a < b ? a : b;
        }
    return p;
}

int mf_mesh_drop_small_components(MfMesh *m, float min_frac, int *dropped) {
    uint32_t *p = components(m);
    int *count = calloc((size_t)(m->nv > 0 ? m->nv : 1), sizeof *count);
    uint32_t *tri = malloc((size_t)m->nt * 3 * sizeof *tri + 1);
    if (!p || !count || !tri) { free(p), free(count), free(tri); return oom("mesh component clean-up"); }
    int big = 0, ndrop = 0, nt = 0;
    for (int t = 0; t < m->nt; ++t) {
        int c = ++count[uf_find(p, m->tri[3 * t])];
        if (c > big) big = c;
    }
    for (int v = 0; v < m->nv; ++v)
        if (p[v] == (uint32_t)v && count[v] > 0 && (float)count[v] < min_frac * (float)big) ++ndrop;
    for (int t = 0; t < m->nt; ++t)
        if (!((float)count[uf_find(p, m->tri[3 * t])] < min_frac * (float)big)) memcpy(tri + 3 * nt++, m->tri + 3 * t, 3 * sizeof *tri);
    int rc = compact(m, tri, nt, "mesh component clean-up");
    free(p), free(count), free(tri);
    if (rc == MF_OK && dropped) *dropped = ndrop;
    return rc;
}

typedef struct { uint64_t key; int dir; } EdgeRec;

static int cmp_edge(const void *a, const void *b) {
    const EdgeRec *p = a, *q = b;
    if (p->key != q->key) return p->key < q->key ? -1 : 1;
    return p->dir - q->dir;
}

/* Sorted undirected edges of all triangles, each with its direction (0: low -> high). */
static EdgeRec *edges(const MfMesh *m) {
    EdgeRec *e = malloc((size_t)m->nt * 3 * sizeof *e + 1);
    if (!e) return NULL;
    for (int t = 0; t < m->nt; ++t)
        for (int k = 0; k < 3; ++k) {
            uint64_t a = m->tri[3 * t + k], b = m->tri[3 * t + (k + 1) % 3];
            e[3 * t + k] = (EdgeRec){a < b ? a << 32 | b : b << 32 | a, a > b};
        }
    qsort(e, (size_t)m->nt * 3, sizeof *e, cmp_edge);
    return e;
}

int mf_mesh_taubin(MfMesh *m, int iters, float lambda, float mu) {
    EdgeRec *e = edges(m);
    size_t ne = (size_t)m->nt * 3;
    float *acc = malloc((size_t)(m->nv > 0 ? m->nv : 1) * 3 * sizeof *acc);
    int *deg = malloc((size_t)(m->nv > 0 ? m->nv : 1) * sizeof *deg);
    if (!e || !acc || !deg) { free(e), free(acc), free(deg); return oom("Taubin smoothing"); }
    for (int it = 0; it < 2 * iters; ++it) {
        float step = it & 1 ? mu : lambda;
        memset(acc, 0, (size_t)m->nv * 3 * sizeof *acc);
        memset(deg, 0, (size_t)m->nv * sizeof *deg);
        for (size_t i = 0; i < ne; ++i) {
            if (i > 0 && e[i].key == e[i - 1].key) continue; /* each undirected edge once */
            uint32_t a = (uint32_t)(e[i].key >> 32), b = (uint32_t)e[i].key;
            for (int c = 0; c < 3; ++c) {
                acc[3 * a + c] += m->pos[3 * b + c] - m->pos[3 * a + c];
                acc[3 * b + c] += m->pos[3 * a + c] - m->pos[3 * b + c];
            }
            ++deg[a], ++deg[b];
        }
        for (int v = 0; v < m->nv; ++v)
            if (deg[v])
                for (int c = 0; c < 3; ++c) m->pos[3 * v + c] += step * acc[3 * v + c] / (float)deg[v];
    }
    free(e), free(acc), free(deg);
    return MF_OK;
}

int mf_mesh_manifold_check(const MfMesh *m, MfManifoldInfo *info) {
    EdgeRec *e = edges(m);
    uint32_t *p = components(m);
    char *used = calloc((size_t)(m->nv > 0 ? m->nv : 1), 1);
    if (!e || !p || !used) { free(e), free(p), free(used); return oom("manifold check"); }
    MfManifoldInfo r = {0};
    size_t ne = (size_t)m->nt * 3;
    long nedges = 0;
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        while (j < ne && e[j].key == e[i].key) ++j;
        ++nedges;
        if (j - i == 1) ++r.boundary_edges;
        else if (j - i > 2) ++r.nonmanifold_edges;
        else if (e[i].dir == e[i + 1].dir) ++r.misoriented_edges;
        i = j;
    }
    long nv = 0;
    for (size_t i = 0; i < ne; ++i) used[m->tri[i]] = 1;
    for (int v = 0; v < m->nv; ++v) {
        nv += used[v];
        r.components += used[v] && uf_find(p, (uint32_t)v) == (uint32_t)v;
    }
    r.euler = nv - nedges + m->nt;
    free(e), free(p), free(used);
    *info = r;
    return MF_OK;
}

int mf_manifold_ok(const MfManifoldInfo *info) {
    return info->boundary_edges == 0 && info->nonmanifold_edges == 0 && info->misoriented_edges == 0;
}

int mf_mesh_decimate(MfMesh *m, int target_tris, float max_error) {
    if (target_tris < 1) return mf_fail(MF_EARG, "mesh decimation: target %d triangles", target_tris);
    if (m->nt <= target_tris) return MF_OK;
    unsigned int *dst = malloc((size_t)m->nt * 3 * sizeof *dst);
    if (!dst) return oom("mesh decimation");
    size_t n = meshopt_simplify(dst, m->tri, (size_t)m->nt * 3, m->pos, (size_t)m->nv, 3 * sizeof(float),
                                (size_t)target_tris * 3, max_error, 0, NULL);
    int rc = compact(m, dst, (int)(n / 3), "mesh decimation");
    free(dst);
    return rc;
}
