/* mf_uvatlas: region-growing charts, LSCM by CGLS, splitting, min-area rotation, packing. */
#include "geom/mf_uvatlas.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "geom/mf_chartpack.h"
#include "geom/mf_pack.h"

MfUvAtlasOpts mf_uvatlas_defaults(void) { return (MfUvAtlasOpts){256, 2.0f, 60.0f, 1000, 1}; }

/* ---- mesh analysis ------------------------------------------------------------------------ */

typedef struct {
    int nt, nv;
    const uint32_t *tri;
    int *rep;     /* (nv,) one representative vertex per position */
    int *orep;    /* (nv,) lowest-index vertex at the same position with the same normal */
    int *nb;      /* (nt, 3) triangle across edge (corner e, e+1), or -1 */
    double *fn;   /* (nt, 3) unit face normal (0 for degenerate) */
    double *area; /* (nt,) */
    double *p;    /* (nv, 3) positions */
} Mesh;

static int cmp_vpos(const void *a, const void *b, void *ctx) {
    const MfMesh *m = ctx;
    int i = *(const int *)a, j = *(const int *)b;
    for (int k = 0; k < 3; ++k)
        if (m->pos[3 * i + k] != m->pos[3 * j + k]) return m->pos[3 * i + k] < m->pos[3 * j + k] ? -1 : 1;
    for (int k = 0; m->nrm && k < 3; ++k)
        if (m->nrm[3 * i + k] != m->nrm[3 * j + k]) return m->nrm[3 * i + k] < m->nrm[3 * j + k] ? -1 : 1;
    return (i > j) - (i < j);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void mesh_free(Mesh *m) {
    free(m->rep), free(m->orep), free(m->nb), free(m->fn), free(m->area), free(m->p);
}

static int mesh_build(const MfMesh *in, Mesh *m) {
    memset(m, 0, sizeof *m);
    m->nt = in->nt, m->nv = in->nv, m->tri = in->tri;
    size_t nt = (size_t)in->nt, nv = (size_t)in->nv;
    m->rep = malloc(nv * sizeof *m->rep + 1);
    m->orep = malloc(nv * sizeof *m->orep + 1);
    m->nb = malloc(3 * nt * sizeof *m->nb + 1);
    m->fn = malloc(3 * nt * sizeof *m->fn + 1);
    m->area = malloc(nt * sizeof *m->area + 1);
    m->p = malloc(3 * nv * sizeof *m->p + 1);
    int *idx = malloc(nv * sizeof *idx + 1);
    uint64_t *ek = malloc(3 * nt * sizeof *ek + 1);
    if (!m->rep || !m->orep || !m->nb || !m->fn || !m->area || !m->p || !idx || !ek) {
        free(idx), free(ek), mesh_free(m);
        return mf_fail(MF_ENOMEM, "out of memory for the unwrapper");
    }
    for (size_t v = 0; v < nv; ++v) {
        idx[v] = (int)v;
        for (int k = 0; k < 3; ++k) m->p[3 * v + k] = in->pos[3 * v + k];
    }
    qsort_r(idx, nv, sizeof *idx, cmp_vpos, (void *)in); /* by position, normal, index */
    for (size_t i = 0; i < nv; ++i) {
        int same = i > 0 && !memcmp(in->pos + 3 * idx[i], in->pos + 3 * idx[i - 1], 3 * sizeof(float));
        int same_n = same && (!in->nrm || !memcmp(in->nrm + 3 * idx[i], in->nrm + 3 * idx[i - 1], 3 * sizeof(float)));
        m->rep[idx[i]] = same ? m->rep[idx[i - 1]] : idx[i];
        m->orep[idx[i]] = same_n ? m->orep[idx[i - 1]] : idx[i];
    }
    for (size_t t = 0; t < nt; ++t) {
        const double *a = m->p + 3 * in->tri[3 * t], *b = m->p + 3 * in->tri[3 * t + 1], *c = m->p + 3 * in->tri[3 * t + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        m->area[t] = 0.5 * l;
        for (int k = 0; k < 3; ++k) m->fn[3 * t + k] = l > 0 ? n[k] / l : 0.0;
        for (int e = 0; e < 3; ++e) {
            uint64_t x = (uint64_t)m->rep[in->tri[3 * t + e]], y = (uint64_t)m->rep[in->tri[3 * t + (e + 1) % 3]];
            if (x > y) { uint64_t s = x; x = y; y = s; }
            ek[3 * t + e] = x << 32 | y;
        }
    }
    /* (edge key, corner) pairs sorted by key: an edge with exactly two corners links two triangles */
    size_t ne = 3 * nt;
    uint64_t *pairs = malloc(ne * 2 * sizeof *pairs + 1);
    if (!pairs) { free(idx), free(ek), mesh_free(m); return mf_fail(MF_ENOMEM, "out of memory for the unwrapper"); }
    for (size_t i = 0; i < ne; ++i) pairs[2 * i] = ek[i], pairs[2 * i + 1] = i;
    qsort(pairs, ne, 2 * sizeof *pairs, cmp_u64); /* by key only: the order within a pair does not matter */
    for (size_t i = 0; i < ne; ++i) m->nb[i] = -1;
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        while (j < ne && pairs[2 * j] == pairs[2 * i]) ++j;
        if (j - i == 2) {
            size_t c0 = pairs[2 * i + 1], c1 = pairs[2 * i + 1 + 2];
            if (c0 / 3 != c1 / 3) m->nb[c0] = (int)(c1 / 3), m->nb[c1] = (int)(c0 / 3);
        }
        i = j;
    }
    free(pairs), free(idx), free(ek);
    return MF_OK;
}

/* ---- region growing ----------------------------------------------------------------------- */

typedef struct {
    double key;
    int t;
} HeapItem;

typedef struct {
    HeapItem *a;
    size_t n, cap;
} Heap;

static int heap_less(HeapItem x, HeapItem y) { return x.key < y.key || (x.key == y.key && x.t < y.t); }

static int heap_push(Heap *h, double key, int t) {
    if (h->n == h->cap) {
        size_t cap = h->cap ? 2 * h->cap : 256;
        HeapItem *a = realloc(h->a, cap * sizeof *a);
        if (!a) return MF_ENOMEM;
        h->a = a, h->cap = cap;
    }
    size_t i = h->n++;
    h->a[i] = (HeapItem){key, t};
    while (i > 0 && heap_less(h->a[i], h->a[(i - 1) / 2])) {
        HeapItem s = h->a[i]; h->a[i] = h->a[(i - 1) / 2]; h->a[(i - 1) / 2] = s;
        i = (i - 1) / 2;
    }
    return MF_OK;
}

static HeapItem heap_pop(Heap *h) {
    HeapItem top = h->a[0];
    h->a[0] = h->a[--h->n];
    for (size_t i = 0;;) {
        size_t l = 2 * i + 1, r = l + 1, m = i;
        if (l < h->n && heap_less(h->a[l], h->a[m])) m = l;
        if (r < h->n && heap_less(h->a[r], h->a[m])) m = r;
        if (m == i) break;
        HeapItem s = h->a[i]; h->a[i] = h->a[m]; h->a[m] = s;
        i = m;
    }
    return top;
}

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* 1 when adding triangle t to chart c keeps it a disc: it shares exactly one edge with the chart
 * and its third vertex is not in the chart yet, or it shares two edges. vstamp: chart per rep. */
static int keeps_disc(const Mesh *m, const int *chart, const int *vstamp, int t, int c) {
    int shared = 0, free_corner = -1;
    for (int e = 0; e < 3; ++e)
        if (m->nb[3 * t + e] >= 0 && chart[m->nb[3 * t + e]] == c) ++shared;
        else if (free_corner < 0) free_corner = e;
    if (shared == 2) return 2;
    if (shared != 1) return 0;
    for (int e = 0; e < 3; ++e)
        if (m->nb[3 * t + e] >= 0 && chart[m->nb[3 * t + e]] == c) /* the corner opposite edge (e, e+1) */
            return vstamp[m->rep[m->tri[3 * t + (e + 2) % 3]]] != c;
    return 0;
}

static double centroid_dist(const Mesh *m, int a, int b) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
        double d = 0;
        for (int j = 0; j < 3; ++j) d += m->p[3 * m->tri[3 * a + j] + k] - m->p[3 * m->tri[3 * b + j] + k];
        d2 += d * d / 9.0;
    }
    return sqrt(d2);
}

/* Grows charts from seeds in triangle order, nearest first by centroid-path distance from the
 * seed; a triangle with two edges on the chart (a notch) comes before anything else and is
 * taken whatever its normal, which keeps chart boundaries smooth. chart (nt,) gets chart ids
 * 0..; returns the count or a negative status. */
static int grow_charts(const Mesh *m, double cos_max, int max_tris, int *chart) {
    int *vstamp = malloc((size_t)m->nv * sizeof *vstamp + 1);
    Heap h = {0};
    if (!vstamp) return mf_fail(MF_ENOMEM, "out of memory for charts");
    for (int v = 0; v < m->nv; ++v) vstamp[v] = -1;
    for (int t = 0; t < m->nt; ++t) chart[t] = -1;
    int nc = 0, rc = MF_OK;
    for (int seed = 0; seed < m->nt && rc == MF_OK; ++seed) {
        if (chart[seed] >= 0) continue;
        int c = nc++, size = 0;
        double n[3] = {0, 0, 0};
        h.n = 0;
        rc = heap_push(&h, 0.0, seed);
        while (h.n && rc == MF_OK && size < max_tris) {
            HeapItem it = heap_pop(&h);
            int t = it.t;
            if (chart[t] >= 0) continue;
            double l = sqrt(dot3(n, n));
            int k = t == seed ? 2 : keeps_disc(m, chart, vstamp, t, c);
            if (!k || (k == 1 && dot3(m->fn + 3 * t, n) < cos_max * l)) continue;
            chart[t] = c, ++size;
            for (int j = 0; j < 3; ++j) {
                n[j] += m->area[t] * m->fn[3 * t + j];
                vstamp[m->rep[m->tri[3 * t + j]]] = c;
            }
            for (int e = 0; e < 3 && rc == MF_OK; ++e) {
                int u = m->nb[3 * t + e], on = 0;
                if (u < 0 || chart[u] >= 0) continue;
                for (int f = 0; f < 3; ++f) on += m->nb[3 * u + f] >= 0 && chart[m->nb[3 * u + f]] == c;
                rc = heap_push(&h, on >= 2 ? it.key : it.key + centroid_dist(m, t, u), u);
            }
        }
    }
    free(h.a), free(vstamp);
    return rc == MF_OK ? nc : mf_fail(MF_ENOMEM, "out of memory for charts");
}

/* ---- one chart: topology, LSCM, checks, normalisation ------------------------------------- */

enum { CHART_OK = 0, CHART_TOPOLOGY, CHART_FLIP, CHART_OVERLAP, CHART_NOMEM };

/* A UV triangle counts as flipped below this area relative to its chart's squared extent: float
 * UVs in [0,1] (rounding ~6e-8) keep such areas positive for charts wider than a few texels. */
#define MIN_REL_AREA 1e-7

typedef struct {
    int id;
    const int *tris; /* borrowed; (nt,) triangle ids */
    int nt;
    int *verts;      /* owned; (nvl,) sorted rep vertex ids */
    int nvl;
    double *uv;      /* owned; (nvl, 2) final chart-local UVs (3D scale, min corner 0) */
    double w, h;
    int status, iters, split; /* split: made by splitting */
} Chart;

typedef struct {
    int n;
    int *rowptr; /* (n + 1,) */
    int *col;    /* (rowptr[n],) */
    double *val; /* (rowptr[n],) */
} Csr;

static void csr_mul(const Csr *a, const double *x, double *y) { /* y = A x */
    for (int i = 0; i < a->n; ++i) {
        double s = 0.0;
        for (int k = a->rowptr[i]; k < a->rowptr[i + 1]; ++k) s += a->val[k] * x[a->col[k]];
        y[i] = s;
    }
}

static void csr_mul_t(const Csr *a, const double *y, double *x, int nx) { /* x = A^T y */
    memset(x, 0, (size_t)nx * sizeof *x);
    for (int i = 0; i < a->n; ++i)
        for (int k = a->rowptr[i]; k < a->rowptr[i + 1]; ++k) x[a->col[k]] += a->val[k] * y[i];
}

static double dot(const double *a, const double *b, int n) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
}

static int cmp_int(const void *a, const void *b) { int x = *(const int *)a, y = *(const int *)b; return (x > y) - (x < y); }

static int local_of(const Chart *c, int rep) {
    const int *p = bsearch(&rep, c->verts, (size_t)c->nvl, sizeof(int), cmp_int);
    return (int)(p - c->verts);
}

/* Disc check: every boundary vertex has one outgoing boundary half-edge, the half-edges form
 * one loop, and V - E + F = 1. lt (nt, 3) local corners. */
static int is_disc(const Mesh *m, const int *chart, const Chart *c, const int *lt, int *next) {
    int nb_half = 0;
    for (int v = 0; v < c->nvl; ++v) next[v] = -1;
    for (int i = 0; i < c->nt; ++i)
        for (int e = 0; e < 3; ++e) {
            int u = m->nb[3 * c->tris[i] + e];
            if (u >= 0 && chart[u] == c->id) continue;
            int a = lt[3 * i + e], b = lt[3 * i + (e + 1) % 3];
            if (next[a] >= 0) return 0;
            next[a] = b, ++nb_half;
        }
    if ((3 * c->nt + nb_half) % 2 || c->nvl - (3 * c->nt + nb_half) / 2 + c->nt != 1) return 0;
    int start = -1;
    for (int v = 0; v < c->nvl && start < 0; ++v) if (next[v] >= 0) start = v;
    if (start < 0) return 0;
    int len = 0, v = start;
    do { v = next[v], ++len; } while (v >= 0 && v != start && len <= nb_half);
    return v == start && len == nb_half;
}

static double orient2(const double *a, const double *b, const double *c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

static int on_segment(const double *a, const double *b, const double *p) {
    return fmin(a[0], b[0]) <= p[0] && p[0] <= fmax(a[0], b[0]) && fmin(a[1], b[1]) <= p[1] && p[1] <= fmax(a[1], b[1]);
}

static int segments_meet(const double *a, const double *b, const double *c, const double *d) {
    double d1 = orient2(c, d, a), d2 = orient2(c, d, b), d3 = orient2(a, b, c), d4 = orient2(a, b, d);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return 1;
    return (d1 == 0 && on_segment(c, d, a)) || (d2 == 0 && on_segment(c, d, b)) || (d3 == 0 && on_segment(a, b, c)) ||
           (d4 == 0 && on_segment(a, b, d));
}

typedef struct {
    double lo, hi;
    int a, b;
} Seg;

static int cmp_seg(const void *pa, const void *pb) {
    const Seg *x = pa, *y = pb;
    if (x->lo != y->lo) return x->lo < y->lo ? -1 : 1;
    return (x->a > y->a) - (x->a < y->a);
}

/* 1 when two boundary edges that share no vertex meet (sweep over u). -1: out of memory. */
static int boundary_crosses(const Mesh *m, const int *chart, const Chart *c, const int *lt, const double *uv) {
    Seg *s = malloc(3 * (size_t)c->nt * sizeof *s);
    if (!s) return -1;
    int ns = 0;
    for (int i = 0; i < c->nt; ++i)
        for (int e = 0; e < 3; ++e) {
            int u = m->nb[3 * c->tris[i] + e];
            if (u >= 0 && chart[u] == c->id) continue;
            int a = lt[3 * i + e], b = lt[3 * i + (e + 1) % 3];
            s[ns++] = (Seg){fmin(uv[2 * a], uv[2 * b]), fmax(uv[2 * a], uv[2 * b]), a, b};
        }
    qsort(s, (size_t)ns, sizeof *s, cmp_seg);
    int hit = 0;
    for (int i = 0; i < ns && !hit; ++i)
        for (int j = i + 1; j < ns && s[j].lo <= s[i].hi && !hit; ++j) {
            if (s[i].a == s[j].a || s[i].a == s[j].b || s[i].b == s[j].a || s[i].b == s[j].b) continue;
            hit = segments_meet(uv + 2 * s[i].a, uv + 2 * s[i].b, uv + 2 * s[j].a, uv + 2 * s[j].b);
        }
    free(s);
    return hit;
}

static void cross3(const double *a, const double *b, double *o) {
    o[0] = a[1] * b[2] - a[2] * b[1], o[1] = a[2] * b[0] - a[0] * b[2], o[2] = a[0] * b[1] - a[1] * b[0];
}

static void normalize3(double *a) {
    double l = sqrt(dot3(a, a));
    if (l > 0) a[0] /= l, a[1] /= l, a[2] /= l;
}

/* LSCM rows of each triangle (local frame x along edge 0-1, y = n x x, counter-clockwise):
 * sqrt(A) (u_x - v_y) and sqrt(A) (u_y + v_x), zero for every orientation-preserving similarity.
 * Unknowns: u of local vertex j is column j, v is column nvl + j. */
static int lscm_matrix(const Mesh *m, const Chart *c, const int *lt, Csr *a) {
    a->n = 2 * c->nt;
    a->rowptr = malloc(((size_t)a->n + 1) * sizeof *a->rowptr);
    a->col = malloc((size_t)a->n * 6 * sizeof *a->col);
    a->val = malloc((size_t)a->n * 6 * sizeof *a->val);
    if (!a->rowptr || !a->col || !a->val) return CHART_NOMEM;
    for (int i = 0; i < c->nt; ++i) {
        int t = c->tris[i];
        const double *p0 = m->p + 3 * m->rep[m->tri[3 * t]];
        double ex[3], ey[3], q[3][2];
        for (int k = 0; k < 3; ++k) ex[k] = m->p[3 * m->rep[m->tri[3 * t + 1]] + k] - p0[k];
        normalize3(ex);
        cross3(m->fn + 3 * t, ex, ey);
        for (int j = 0; j < 3; ++j) {
            const double *pj = m->p + 3 * m->rep[m->tri[3 * t + j]];
            double d[3] = {pj[0] - p0[0], pj[1] - p0[1], pj[2] - p0[2]};
            q[j][0] = dot3(d, ex), q[j][1] = dot3(d, ey);
        }
        double A = m->area[t], s = A > 0 ? sqrt(A) / (2.0 * A) : 0.0;
        int r = 2 * i;
        a->rowptr[r] = 6 * r, a->rowptr[r + 1] = 6 * (r + 1);
        for (int j = 0; j < 3; ++j) {
            const double *p1 = q[(j + 1) % 3], *p2 = q[(j + 2) % 3];
            double gx = -(p2[1] - p1[1]) * s, gy = (p2[0] - p1[0]) * s; /* sqrt(A) grad phi_j */
            int cu = lt[3 * i + j], cv = c->nvl + lt[3 * i + j];
            a->col[6 * r + 2 * j] = cu, a->val[6 * r + 2 * j] = gx;
            a->col[6 * r + 2 * j + 1] = cv, a->val[6 * r + 2 * j + 1] = -gy;
            a->col[6 * (r + 1) + 2 * j] = cu, a->val[6 * (r + 1) + 2 * j] = gy;
            a->col[6 * (r + 1) + 2 * j + 1] = cv, a->val[6 * (r + 1) + 2 * j + 1] = gx;
        }
    }
    a->rowptr[a->n] = 6 * a->n;
    return CHART_OK;
}

/* CGLS with a Jacobi preconditioner (conjugate gradients on A_f^T A_f x_f = -A_f^T A_p x_p,
 * never formed): minimises |A x| over the entries with is_free[j], the others fixed; x holds
 * the start. Stops when |A_f^T r| <= tol times its value at the start. Returns the iteration
 * count, or -1 when out of memory. */
static int cgls(const Csr *a, const unsigned char *is_free, double *x, int nx, double tol, int max_iter) {
    double *r = malloc((size_t)a->n * sizeof *r), *q = malloc((size_t)a->n * sizeof *q);
    double *s = malloc((size_t)nx * sizeof *s), *p = malloc((size_t)nx * sizeof *p), *dinv = malloc((size_t)nx * sizeof *dinv);
    int it = -1;
    if (!r || !q || !s || !p || !dinv) goto done;
    memset(dinv, 0, (size_t)nx * sizeof *dinv); /* 1 / diag(A^T A) on the free entries, else 0 */
    for (int k = 0; k < a->rowptr[a->n]; ++k) dinv[a->col[k]] += a->val[k] * a->val[k];
    for (int j = 0; j < nx; ++j) dinv[j] = is_free[j] && dinv[j] > 0 ? 1.0 / dinv[j] : 0.0;
    csr_mul(a, x, r);
    for (int i = 0; i < a->n; ++i) r[i] = -r[i];
    csr_mul_t(a, r, s, nx);
    for (int j = 0; j < nx; ++j) s[j] = is_free[j] ? s[j] : 0.0, p[j] = s[j] * dinv[j];
    double gamma = dot(s, p, nx), ref = sqrt(dot(s, s, nx));
    for (it = 0; it < max_iter && gamma > 0 && sqrt(dot(s, s, nx)) > tol * ref; ++it) {
        csr_mul(a, p, q);
        double qq = dot(q, q, a->n);
        if (!(qq > 0)) break;
        double alpha = gamma / qq;
        for (int j = 0; j < nx; ++j) x[j] += alpha * p[j];
        for (int i = 0; i < a->n; ++i) r[i] -= alpha * q[i];
        csr_mul_t(a, r, s, nx);
        for (int j = 0; j < nx; ++j) s[j] = is_free[j] ? s[j] : 0.0;
        double g2 = 0;
        for (int j = 0; j < nx; ++j) g2 += s[j] * s[j] * dinv[j];
        for (int j = 0; j < nx; ++j) p[j] = s[j] * dinv[j] + g2 / gamma * p[j];
        gamma = g2;
    }
done:
    free(r), free(q), free(s), free(p), free(dinv);
    return it;
}

/* Start and pins: the projection onto the chart's mean plane; pins are a vertex far from local
 * vertex 0 and the vertex farthest from it, placed at their 3D distance along their projected
 * direction. x (2 nvl): u then v. */
static void lscm_start(const Mesh *m, const Chart *c, double *x, unsigned char *is_free) {
    double n[3] = {0, 0, 0}, e1[3], e2[3];
    for (int i = 0; i < c->nt; ++i)
        for (int k = 0; k < 3; ++k) n[k] += m->area[c->tris[i]] * m->fn[3 * c->tris[i] + k];
    normalize3(n);
    if (dot3(n, n) == 0) n[2] = 1;
    int ax = fabs(n[0]) <= fabs(n[1]) && fabs(n[0]) <= fabs(n[2]) ? 0 : (fabs(n[1]) <= fabs(n[2]) ? 1 : 2);
    double axis[3] = {0, 0, 0};
    axis[ax] = 1;
    cross3(axis, n, e1);
    normalize3(e1);
    cross3(n, e1, e2);
    for (int j = 0; j < c->nvl; ++j) {
        x[j] = dot3(m->p + 3 * c->verts[j], e1), x[c->nvl + j] = dot3(m->p + 3 * c->verts[j], e2);
        is_free[j] = is_free[c->nvl + j] = 1;
    }
    int pa = 0, pb = 0;
    double best = -1;
    for (int pass = 0; pass < 2; ++pass) {
        const double *o = m->p + 3 * c->verts[pass ? pa : 0];
        best = -1;
        for (int j = 0; j < c->nvl; ++j) {
            const double *q = m->p + 3 * c->verts[j];
            double d = (q[0] - o[0]) * (q[0] - o[0]) + (q[1] - o[1]) * (q[1] - o[1]) + (q[2] - o[2]) * (q[2] - o[2]);
            if (d > best) best = d, *(pass ? &pb : &pa) = j;
        }
    }
    double du = x[pb] - x[pa], dv = x[c->nvl + pb] - x[c->nvl + pa], dl = sqrt(du * du + dv * dv), L = sqrt(best);
    if (dl > 1e-12 * L) du /= dl, dv /= dl;
    else du = 1, dv = 0;
    x[pb] = x[pa] + L * du, x[c->nvl + pb] = x[c->nvl + pa] + L * dv;
    is_free[pa] = is_free[c->nvl + pa] = is_free[pb] = is_free[c->nvl + pb] = 0;
}

static int cmp_uv(const void *pa, const void *pb, void *ctx) {
    const double *uv = ctx;
    int i = *(const int *)pa, j = *(const int *)pb;
    if (uv[2 * i] != uv[2 * j]) return uv[2 * i] < uv[2 * j] ? -1 : 1;
    if (uv[2 * i + 1] != uv[2 * j + 1]) return uv[2 * i + 1] < uv[2 * j + 1] ? -1 : 1;
    return (i > j) - (i < j);
}

/* Scales uv (nvl, 2) to the chart's 3D area, rotates it to its minimum-area bounding rectangle
 * (hull edge directions; then wider than tall) and moves its lower-left corner to 0. */
static int normalise_chart(const Mesh *m, Chart *c, const int *lt, double *uv) {
    double a3 = 0, a2 = 0;
    for (int i = 0; i < c->nt; ++i) {
        a3 += m->area[c->tris[i]];
        a2 += 0.5 * orient2(uv + 2 * lt[3 * i], uv + 2 * lt[3 * i + 1], uv + 2 * lt[3 * i + 2]);
    }
    double s = a3 > 0 && a2 > 0 ? sqrt(a3 / a2) : 1.0;
    for (int j = 0; j < 2 * c->nvl; ++j) uv[j] *= s;
    int *idx = malloc((size_t)c->nvl * sizeof *idx), *hull = malloc(2 * ((size_t)c->nvl + 1) * sizeof *hull);
    if (!idx || !hull) { free(idx), free(hull); return CHART_NOMEM; }
    for (int j = 0; j < c->nvl; ++j) idx[j] = j;
    qsort_r(idx, (size_t)c->nvl, sizeof *idx, cmp_uv, uv);
    int k = 0; /* Andrew's monotone chain; hull[0..k-1] counter-clockwise */
    for (int i = 0; i < c->nvl; ++i) {
        while (k >= 2 && orient2(uv + 2 * hull[k - 2], uv + 2 * hull[k - 1], uv + 2 * idx[i]) <= 0) --k;
        hull[k++] = idx[i];
    }
    for (int i = c->nvl - 2, lo = k + 1; i >= 0; --i) {
        while (k >= lo && orient2(uv + 2 * hull[k - 2], uv + 2 * hull[k - 1], uv + 2 * idx[i]) <= 0) --k;
        hull[k++] = idx[i];
    }
    if (k > 1) --k;
    double best = INFINITY, bc = 1, bs = 0;
    for (int e = 0; e < k; ++e) {
        const double *p = uv + 2 * hull[e], *q = uv + 2 * hull[(e + 1) % k];
        double dx = q[0] - p[0], dy = q[1] - p[1], l = sqrt(dx * dx + dy * dy);
        if (!(l > 0)) continue;
        double cs = dx / l, sn = dy / l, x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
        for (int h = 0; h < k; ++h) { /* rotate by -angle */
            const double *r = uv + 2 * hull[h];
            double x = cs * r[0] + sn * r[1], y = -sn * r[0] + cs * r[1];
            x0 = fmin(x0, x), x1 = fmax(x1, x), y0 = fmin(y0, y), y1 = fmax(y1, y);
        }
        double area = (x1 - x0) * (y1 - y0);
        if (area < best * (1 - 1e-9)) best = area, bc = cs, bs = sn;
    }
    free(idx), free(hull);
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int j = 0; j < c->nvl; ++j) {
        double x = bc * uv[2 * j] + bs * uv[2 * j + 1], y = -bs * uv[2 * j] + bc * uv[2 * j + 1];
        uv[2 * j] = x, uv[2 * j + 1] = y;
        x0 = fmin(x0, x), x1 = fmax(x1, x), y0 = fmin(y0, y), y1 = fmax(y1, y);
    }
    int turn = y1 - y0 > x1 - x0; /* +90 degrees: (x, y) -> (-y, x) */
    for (int j = 0; j < c->nvl; ++j) {
        double x = uv[2 * j] - x0, y = uv[2 * j + 1] - y0;
        uv[2 * j] = turn ? (y1 - y0) - y : x, uv[2 * j + 1] = turn ? x : y;
    }
    c->w = turn ? y1 - y0 : x1 - x0, c->h = turn ? x1 - x0 : y1 - y0;
    return CHART_OK;
}

/* Parameterises chart c (c->tris set); sets verts, uv, w, h, status, iters. */
static void solve_chart(const Mesh *m, const int *chart, Chart *c) {
    int *lt = malloc(3 * (size_t)c->nt * sizeof *lt), *next = NULL;
    double *x = NULL;
    unsigned char *is_free = NULL;
    Csr a = {0};
    c->status = CHART_NOMEM;
    c->iters = 0;
    if (!lt || !(c->verts = malloc(3 * (size_t)c->nt * sizeof *c->verts))) goto done;
    for (int i = 0; i < 3 * c->nt; ++i) c->verts[i] = m->rep[m->tri[3 * c->tris[i / 3] + i % 3]];
    qsort(c->verts, 3 * (size_t)c->nt, sizeof *c->verts, cmp_int);
    c->nvl = 0;
    for (int i = 0; i < 3 * c->nt; ++i)
        if (!c->nvl || c->verts[c->nvl - 1] != c->verts[i]) c->verts[c->nvl++] = c->verts[i];
    for (int i = 0; i < 3 * c->nt; ++i) lt[i] = local_of(c, m->rep[m->tri[3 * c->tris[i / 3] + i % 3]]);
    int nx = 2 * c->nvl;
    if (!(c->uv = malloc((size_t)nx * sizeof *c->uv)) || !(x = malloc((size_t)nx * sizeof *x)) ||
        !(is_free = malloc((size_t)nx)) || !(next = malloc((size_t)c->nvl * sizeof *next)))
        goto done;
    if (c->nt == 1) { /* the triangle in its own frame (a (nearly) degenerate one: a right triangle) */
        int t = c->tris[0];
        double e = 0;
        for (int j = 0; j < 3; ++j) {
            const double *p = m->p + 3 * m->rep[m->tri[3 * t + j]], *q = m->p + 3 * m->rep[m->tri[3 * t + (j + 1) % 3]];
            e = fmax(e, sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2])));
        }
        if (!(e > 0)) e = 1;
        int thin = !(m->area[t] > MIN_REL_AREA * e * e);
        double ex[3], ey[3];
        const double *p0 = m->p + 3 * m->rep[m->tri[3 * t]];
        for (int k = 0; k < 3; ++k) ex[k] = m->p[3 * m->rep[m->tri[3 * t + 1]] + k] - p0[k];
        normalize3(ex);
        cross3(m->fn + 3 * t, ex, ey);
        for (int j = 0; j < 3; ++j) {
            const double *pj = m->p + 3 * m->rep[m->tri[3 * t + j]];
            double d[3] = {pj[0] - p0[0], pj[1] - p0[1], pj[2] - p0[2]};
            x[2 * lt[j]] = thin ? (j == 1 ? e : 0) : dot3(d, ex);
            x[2 * lt[j] + 1] = thin ? (j == 2 ? e : 0) : dot3(d, ey);
        }
        memcpy(c->uv, x, (size_t)nx * sizeof *x);
        c->status = normalise_chart(m, c, lt, c->uv);
        goto done;
    }
    if (!is_disc(m, chart, c, lt, next)) { c->status = CHART_TOPOLOGY; goto done; }
    if (lscm_matrix(m, c, lt, &a)) goto done;
    lscm_start(m, c, x, is_free);
    if ((c->iters = cgls(&a, is_free, x, nx, 1e-4, 4000)) < 0) goto done;
    for (int j = 0; j < c->nvl; ++j) c->uv[2 * j] = x[j], c->uv[2 * j + 1] = x[c->nvl + j];
    c->status = CHART_OK;
    double umin = INFINITY, umax = -INFINITY;
    for (int j = 0; j < c->nvl; ++j) umin = fmin(umin, c->uv[2 * j]), umax = fmax(umax, c->uv[2 * j]);
    for (int i = 0; i < c->nt && c->status == CHART_OK; ++i) { /* relative to the chart's size, so float UVs keep it positive */
        double ar = 0.5 * orient2(c->uv + 2 * lt[3 * i], c->uv + 2 * lt[3 * i + 1], c->uv + 2 * lt[3 * i + 2]);
        if (!(ar > MIN_REL_AREA * (umax - umin) * (umax - umin))) c->status = CHART_FLIP;
    }
    if (c->status == CHART_OK) {
        int hit = boundary_crosses(m, chart, c, lt, c->uv);
        c->status = hit < 0 ? CHART_NOMEM : hit ? CHART_OVERLAP : CHART_OK;
    }
    if (c->status == CHART_OK) c->status = normalise_chart(m, c, lt, c->uv);
done:
    free(lt), free(next), free(x), free(is_free), free(a.rowptr), free(a.col), free(a.val);
}

/* ---- splitting and the driver -------------------------------------------------------------- */

/* Breadth-first over chart `id` (marked -2 in chart) from `from`; returns the last triangle
 * reached. queue (nt,) scratch; marks are restored to id. */
static int farthest(const Mesh *m, int *chart, const Chart *c, int from, int *queue) {
    for (int i = 0; i < c->nt; ++i) chart[c->tris[i]] = -2;
    int head = 0, tail = 0, last = from;
    chart[from] = c->id, queue[tail++] = from;
    while (head < tail) {
        int t = queue[head++];
        last = t;
        for (int e = 0; e < 3; ++e) {
            int u = m->nb[3 * t + e];
            if (u >= 0 && chart[u] == -2) chart[u] = c->id, queue[tail++] = u;
        }
    }
    for (int i = 0; i < c->nt; ++i) chart[c->tris[i]] = c->id;
    return last;
}

/* Splits chart c (>= 2 triangles) between itself and new_id: two far-apart seeds grow breadth
 * first at once; triangles neither reaches (a disconnected chart) go to new_id. */
static void split_chart(const Mesh *m, int *chart, const Chart *c, int new_id, int *queue) {
    int b = farthest(m, chart, c, c->tris[0], queue);
    int d = farthest(m, chart, c, b, queue);
    if (d == b) d = c->tris[c->tris[0] == b ? 1 : 0];
    for (int i = 0; i < c->nt; ++i) chart[c->tris[i]] = -2;
    int head = 0, tail = 0;
    chart[b] = c->id, queue[tail++] = b;
    chart[d] = new_id, queue[tail++] = d;
    while (head < tail) {
        int t = queue[head++];
        for (int e = 0; e < 3; ++e) {
            int u = m->nb[3 * t + e];
            if (u >= 0 && chart[u] == -2) chart[u] = chart[t], queue[tail++] = u;
        }
    }
    for (int i = 0; i < c->nt; ++i)
        if (chart[c->tris[i]] == -2) chart[c->tris[i]] = new_id;
}

static void chart_clear(Chart *c) {
    free(c->verts), free(c->uv);
    c->verts = NULL, c->uv = NULL;
}

/* Solves every pending chart, splits the failures and repeats. ch grows; returns the count. */
static int solve_all(const Mesh *m, int *chart, int nc, Chart **chp, MfUvAtlasInfo *info) {
    int cap = nc > 16 ? 2 * nc : 32, npend = nc, rc = MF_OK;
    Chart *ch = calloc((size_t)cap, sizeof *ch);
    int *pend = malloc((size_t)cap * sizeof *pend), *ofs = NULL, *list = malloc((size_t)m->nt * sizeof *list);
    int *queue = malloc((size_t)m->nt * sizeof *queue);
    if (!ch || !pend || !list || !queue) rc = MF_ENOMEM;
    for (int i = 0; i < nc && rc == MF_OK; ++i) pend[i] = i, ch[i].id = i;
    while (npend && rc == MF_OK) {
        free(ofs); /* triangles grouped by chart (counting sort, triangle order kept) */
        if (!(ofs = calloc((size_t)nc + 1, sizeof *ofs))) { rc = MF_ENOMEM; break; }
        for (int t = 0; t < m->nt; ++t) ++ofs[chart[t] + 1];
        for (int i = 0; i < nc; ++i) ofs[i + 1] += ofs[i];
        for (int t = 0; t < m->nt; ++t) list[ofs[chart[t]]++] = t;
        for (int i = nc; i > 0; --i) ofs[i] = ofs[i - 1];
        ofs[0] = 0;
        for (int i = 0; i < nc; ++i) ch[i].tris = list + ofs[i], ch[i].nt = ofs[i + 1] - ofs[i];
        #pragma omp parallel for schedule(dynamic, 1)
        for (int k = 0; k < npend; ++k) solve_chart(m, chart, &ch[pend[k]]);
        int np = 0, first_new = nc;
        for (int k = 0; k < npend && rc == MF_OK; ++k) {
            int id = pend[k];
            if (ch[id].iters > info->cg_iters_max) info->cg_iters_max = ch[id].iters;
            if (ch[id].status == CHART_NOMEM) rc = MF_ENOMEM;
            if (ch[id].status == CHART_OK || rc) continue;
            info->split_topology += ch[id].status == CHART_TOPOLOGY;
            info->split_flip += ch[id].status == CHART_FLIP;
            info->split_overlap += ch[id].status == CHART_OVERLAP;
            chart_clear(&ch[id]);
            if (nc == cap) {
                Chart *g = realloc(ch, 2 * (size_t)cap * sizeof *ch);
                int *gp = g ? realloc(pend, 2 * (size_t)cap * sizeof *pend) : NULL;
                if (g) ch = g;
                if (gp) pend = gp;
                if (!g || !gp) { rc = MF_ENOMEM; break; }
                memset(ch + cap, 0, (size_t)cap * sizeof *ch);
                cap *= 2;
            }
            ch[nc] = (Chart){.id = nc, .split = 1};
            ch[id].split = 1;
            split_chart(m, chart, &ch[id], nc++, queue);
            pend[np++] = id; /* np <= k: only handled entries are overwritten */
        }
        for (int id = first_new; id < nc; ++id) pend[np++] = id; /* distinct ids, so np <= nc <= cap */
        npend = np;
    }
    for (int i = 0; ch && i < nc; ++i) {
        ch[i].tris = NULL; /* into list, freed here */
        if (rc) chart_clear(&ch[i]);
    }
    free(pend), free(ofs), free(list), free(queue);
    if (rc) {
        free(ch);
        return mf_fail(rc, "out of memory for the unwrapper");
    }
    *chp = ch;
    return nc;
}

/* Output: one vertex per chart and input vertex (input vertices at the same position with the same
 * normal are one), ordered by (chart, lowest such vertex index); UVs from the packed rectangles. */
static int build_output(const MfMesh *in, const Mesh *m, const int *chart, const Chart *ch, const MfPackRect *rect,
                        const MfChartPlace *place, int stretch, MfMesh *out) {
    size_t nc3 = 3 * (size_t)in->nt;
    uint64_t *key = malloc(nc3 * sizeof *key + 1);
    if (!key) return mf_fail(MF_ENOMEM, "out of memory for the unwrapped mesh");
    for (size_t i = 0; i < nc3; ++i) key[i] = (uint64_t)chart[i / 3] << 32 | (uint32_t)m->orep[in->tri[i]];
    qsort(key, nc3, sizeof *key, cmp_u64);
    size_t nk = 0;
    for (size_t i = 0; i < nc3; ++i)
        if (!nk || key[nk - 1] != key[i]) key[nk++] = key[i];
    int rc = mf_mesh_alloc(out, (int)nk, in->nt, in->nrm != NULL, 1);
    if (rc) { free(key); return rc; }
    for (size_t k = 0; k < nk; ++k) {
        int c = (int)(key[k] >> 32), v = (int)(key[k] & 0xffffffffu);
        memcpy(out->pos + 3 * k, in->pos + 3 * (size_t)v, 3 * sizeof(float));
        if (in->nrm) memcpy(out->nrm + 3 * k, in->nrm + 3 * (size_t)v, 3 * sizeof(float));
        const Chart *cc = &ch[c];
        const double *uv = cc->uv + 2 * local_of(cc, m->rep[v]);
        if (place) {
            double rx, ry;
            mf_chartpack_turn(place[c].rot, cc->w, cc->h, uv[0], uv[1], &rx, &ry);
            out->uv[2 * k] = (float)(place[c].x0 + place[c].sx * rx);
            out->uv[2 * k + 1] = (float)(place[c].y0 + place[c].sy * ry);
            continue;
        }
        double sx = cc->w > 0 ? rect[c].w / cc->w : 0, sy = cc->h > 0 ? rect[c].h / cc->h : 0;
        if (!stretch) sx = sy = fmin(cc->w > 0 ? sx : sy, cc->h > 0 ? sy : sx);
        out->uv[2 * k] = (float)(rect[c].x0 + uv[0] * sx);
        out->uv[2 * k + 1] = (float)(rect[c].y0 + uv[1] * sy);
    }
    for (size_t i = 0; i < nc3; ++i) {
        uint64_t q = (uint64_t)chart[i / 3] << 32 | (uint32_t)m->orep[in->tri[i]];
        out->tri[i] = (uint32_t)((const uint64_t *)bsearch(&q, key, nk, sizeof *key, cmp_u64) - key);
    }
    free(key);
    return mf_mesh_copy_materials(out, in);
}

/* A chart thinner than 1/64 of its length (a sliver, most often a single triangle) is stretched
 * across to that aspect, so that at any atlas scale its float UVs keep a positive area; normalised
 * charts are wider than tall, with the lower-left corner at 0. */
static void widen_thin(Chart *c) {
    const double min_aspect = 1.0 / 64;
    if (!(c->w > 0) || !(c->h > 0) || c->h >= min_aspect * c->w) return;
    double f = min_aspect * c->w / c->h;
    for (int j = 0; j < c->nvl; ++j) c->uv[2 * j + 1] *= f;
    c->h *= f;
}

/* Triangles of m whose float UVs have area <= 0. */
static int float_flips(const MfMesh *m) {
    int n = 0;
    for (int t = 0; t < m->nt; ++t) {
        const float *a = m->uv + 2 * m->tri[3 * t], *b = m->uv + 2 * m->tri[3 * t + 1], *c = m->uv + 2 * m->tri[3 * t + 2];
        n += !(((double)b[0] - a[0]) * ((double)c[1] - a[1]) - ((double)b[1] - a[1]) * ((double)c[0] - a[0]) > 0);
    }
    return n;
}

/* Packs the charts by their shapes (mf_chartpack); *place stays NULL when they do not fit that
 * way (then the caller packs rectangles on shelves). */
static int pack_charts(const Mesh *m, const int *chart, const Chart *ch, int nc, const MfUvAtlasOpts *opts, MfChartPlace **place,
                       MfUvAtlasInfo *info) {
    MfChartShape *sh = malloc((size_t)nc * sizeof *sh);
    int *ofs = calloc((size_t)nc + 1, sizeof *ofs), *lt = malloc(3 * (size_t)m->nt * sizeof *lt + 1), rc = MF_OK;
    MfChartPlace *pl = malloc((size_t)nc * sizeof *pl);
    if (!sh || !ofs || !lt || !pl) rc = mf_fail(MF_ENOMEM, "out of memory for packing");
    for (int t = 0; t < m->nt && !rc; ++t) ++ofs[chart[t] + 1];
    for (int c = 0; c < nc && !rc; ++c) ofs[c + 1] += ofs[c];
    for (int t = 0; t < m->nt && !rc; ++t) { /* each chart's local corners, in triangle order */
        const Chart *cc = &ch[chart[t]];
        int o = 3 * ofs[chart[t]]++;
        for (int k = 0; k < 3; ++k) lt[o + k] = local_of(cc, m->rep[m->tri[3 * t + k]]);
    }
    for (int c = 0, o = 0; c < nc && !rc; o += 3 * ch[c].nt, ++c) {
        const Chart *cc = &ch[c];
        double a = 0;
        for (int i = 0; i < cc->nt; ++i) a += 0.5 * orient2(cc->uv + 2 * lt[o + 3 * i], cc->uv + 2 * lt[o + 3 * i + 1], cc->uv + 2 * lt[o + 3 * i + 2]);
        sh[c] = (MfChartShape){cc->uv, lt + o, cc->nvl, cc->nt, cc->w, cc->h, a};
    }
    if (!rc) {
        int f = mf_chartpack(sh, nc, opts->tex_res, opts->gutter, opts->stretch, pl, NULL);
        if (f == MF_OK) *place = pl, pl = NULL, info->packed_shapes = 1;
        else if (f < 0) rc = f;
    }
    free(sh), free(ofs), free(lt), free(pl);
    return rc;
}

int mf_uvatlas(const MfMesh *in, const MfUvAtlasOpts *opts, MfMesh *out, MfUvAtlasInfo *info_out) {
    MfUvAtlasInfo info = {0};
    if (!in->nt || !in->nv) return mf_fail(MF_EARG, "empty mesh: nothing to unwrap");
    if (opts->tex_res < 1 || opts->max_chart_tris < 1 || !(opts->gutter >= 0) || !(opts->max_angle_deg > 0 && opts->max_angle_deg <= 180))
        return mf_fail(MF_EARG, "unwrap options: tex_res %d (>= 1), gutter %g (>= 0), max angle %g (0, 180]", opts->tex_res,
                       opts->gutter, opts->max_angle_deg);
    for (size_t i = 0; i < 3 * (size_t)in->nv; ++i)
        if (!isfinite(in->pos[i])) return mf_fail(MF_ENAN, "vertex %zu has a non-finite coordinate", i / 3);
    for (size_t i = 0; i < 3 * (size_t)in->nt; ++i)
        if (in->tri[i] >= (uint32_t)in->nv) return mf_fail(MF_EARG, "triangle %zu: vertex index out of range", i / 3);
    Mesh m;
    int rc = mesh_build(in, &m), nc = 0;
    if (rc) return rc;
    int *chart = malloc((size_t)in->nt * sizeof *chart);
    Chart *ch = NULL;
    float *size = NULL;
    int *order = NULL;
    MfPackRect *rect = NULL;
    if (!chart) rc = mf_fail(MF_ENOMEM, "out of memory for charts");
    if (!rc && (nc = grow_charts(&m, cos(opts->max_angle_deg * M_PI / 180.0), opts->max_chart_tris, chart)) < 0) rc = nc;
    info.grown = nc;
    if (!rc && (nc = solve_all(&m, chart, nc, &ch, &info)) < 0) rc = nc;
    if (!rc && (!(size = malloc(2 * (size_t)nc * sizeof *size)) || !(order = malloc((size_t)nc * sizeof *order)) ||
                !(rect = malloc((size_t)nc * sizeof *rect))))
        rc = mf_fail(MF_ENOMEM, "out of memory for packing");
    for (int c = 0; c < nc && !rc; ++c) {
        widen_thin(&ch[c]);
        size[2 * c] = (float)ch[c].w, size[2 * c + 1] = (float)ch[c].h;
        info.forced_single += ch[c].split && ch[c].nt == 1;
    }
    MfChartPlace *place = NULL;
    if (!rc) rc = pack_charts(&m, chart, ch, nc, opts, &place, &info);
    if (!rc && place) {
        rc = build_output(in, &m, chart, ch, rect, place, opts->stretch, out);
        if (!rc && float_flips(out) > 0) { /* a sliver rounded flat in float: pack rectangles instead */
            mf_mesh_free(out);
            free(place), place = NULL;
            info.packed_shapes = 0;
        } else if (rc) mf_mesh_free(out);
    }
    if (!rc && !place) {
        rc = mf_pack_order_by_height(size, nc, order);
        if (!rc) {
            mf_pack_shelves(size, order, nc, opts->gutter / (float)opts->tex_res, 1.0f / (float)opts->tex_res, opts->stretch, rect);
            rc = build_output(in, &m, chart, ch, rect, NULL, opts->stretch, out);
            if (rc) mf_mesh_free(out);
        }
    }
    free(place);
    info.charts = nc;
    for (int c = 0; ch && c < nc; ++c) chart_clear(&ch[c]);
    free(ch), free(chart), free(size), free(order), free(rect);
    mesh_free(&m);
    if (info_out) *info_out = info;
    return rc;
}

/* ---- checking ----------------------------------------------------------------------------- */

static int uf_find(int *p, int x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
}

/* Counts a centre on edge a->b of a counter-clockwise triangle when the edge points down, or
 * left when horizontal: exactly one of two triangles sharing the edge counts it. */
static int edge_in(double w, double dx, double dy) { return w > 0 || (w == 0 && (dy < 0 || (dy == 0 && dx > 0))); }

int mf_uv_check(const MfMesh *m, int res, MfUvCheck *out) {
    memset(out, 0, sizeof *out);
    out->res = res;
    if (!m->uv) return mf_fail(MF_EARG, "the mesh has no UVs");
    if (res < 1 || res > 16384) return mf_fail(MF_EARG, "check grid %d out of range [1, 16384]", res);
    int *par = malloc((size_t)m->nv * sizeof *par + 1), *owner = malloc((size_t)res * res * sizeof *owner);
    int *tchart = malloc((size_t)m->nt * sizeof *tchart + 1);
    if (!par || !owner || !tchart) { free(par), free(owner), free(tchart); return mf_fail(MF_ENOMEM, "out of memory for the UV check"); }
    for (int v = 0; v < m->nv; ++v) par[v] = v;
    for (int t = 0; t < m->nt; ++t)
        for (int k = 1; k < 3; ++k) {
            int a = uf_find(par, (int)m->tri[3 * t]), b = uf_find(par, (int)m->tri[3 * t + k]);
            if (a != b) par[a > b ? a : b] = a < b ? a : b;
        }
    for (int t = 0; t < m->nt; ++t) tchart[t] = uf_find(par, (int)m->tri[3 * t]);
    for (int t = 0; t < m->nt; ++t) /* roots of used vertices, counted once */
        if (par[tchart[t]] >= 0) ++out->charts, par[tchart[t]] = -1 - tchart[t];
    for (size_t i = 0; i < (size_t)res * res; ++i) owner[i] = -1;
    for (int t = 0; t < m->nt; ++t) {
        double p[3][2];
        int bad = 0;
        for (int j = 0; j < 3; ++j) {
            p[j][0] = m->uv[2 * m->tri[3 * t + j]] * (double)res, p[j][1] = m->uv[2 * m->tri[3 * t + j] + 1] * (double)res;
            bad |= !(p[j][0] >= 0 && p[j][0] <= res && p[j][1] >= 0 && p[j][1] <= res);
        }
        out->outside += bad;
        double ar = orient2(p[0], p[1], p[2]);
        if (!(ar > 0)) {
            ++out->flipped;
            double s[2] = {p[1][0], p[1][1]};
            p[1][0] = p[2][0], p[1][1] = p[2][1], p[2][0] = s[0], p[2][1] = s[1];
        }
        double x0 = fmin(p[0][0], fmin(p[1][0], p[2][0])), x1 = fmax(p[0][0], fmax(p[1][0], p[2][0]));
        double y0 = fmin(p[0][1], fmin(p[1][1], p[2][1])), y1 = fmax(p[0][1], fmax(p[1][1], p[2][1]));
        int i0 = (int)fmax(0, ceil(x0 - 0.5)), i1 = (int)fmin(res - 1, floor(x1 - 0.5));
        int j0 = (int)fmax(0, ceil(y0 - 0.5)), j1 = (int)fmin(res - 1, floor(y1 - 0.5));
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) {
                double c[2] = {i + 0.5, j + 0.5};
                int in = 1;
                for (int e = 0; e < 3 && in; ++e) {
                    const double *a = p[e], *b = p[(e + 1) % 3];
                    in = edge_in(orient2(a, b, c), b[0] - a[0], b[1] - a[1]);
                }
                if (!in) continue;
                int *o = &owner[(size_t)j * res + i];
                if (*o < 0) ++out->covered, *o = t;
                else if (tchart[*o] == tchart[t]) ++out->overlap_same;
                else ++out->overlap_other;
            }
    }
    out->coverage = (double)out->covered / ((double)res * res);
    free(par), free(owner), free(tchart);
    return MF_OK;
}
