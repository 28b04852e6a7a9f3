/* mf_antialias: analytic antialiasing of a pixel-centre pass and its adjoint (see mf_antialias.h). */
#include "render/mf_antialias.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

/* One blended pair: pixel p (A or B) moves toward the other by |t - 1/2|. */
typedef struct {
    int a, b;        /* occluder pixel A, other pixel B (indices into h*w) */
    float t;         /* crossing distance from A's centre, [0, 1] */
    int va, vb;      /* the edge's vertices */
    float dta[3], dtb[3]; /* dt / d(position of va, vb) */
} Cross;

struct MfAa {
    const MfMesh *mesh;
    int w, h;
    int *tri;      /* (h, w) */
    float *depth;  /* (h, w) */
    Cross *cr;     /* (ncr,) */
    int ncr, cap;
};

/* ---- screen projection in double, with its Jacobian ---- */

typedef struct {
    double q[2];     /* pixel coordinates */
    double J[2][3];  /* d q / d world position */
} Proj;

static int project(const MfCamera *cam, const float *p, Proj *r) {
    const float *m = cam->c2w.m;
    double d[3] = {(double)p[0] - m[3], (double)p[1] - m[7], (double)p[2] - m[11]};
    double ax[3] = {m[0], m[4], m[8]}, ay[3] = {m[1], m[5], m[9]}, az[3] = {m[2], m[6], m[10]};
    double x = ax[0] * d[0] + ax[1] * d[1] + ax[2] * d[2];
    double y = ay[0] * d[0] + ay[1] * d[1] + ay[2] * d[2];
    double z = az[0] * d[0] + az[1] * d[1] + az[2] * d[2];
    if (!(z < -1e-8)) return 0;
    double iz = 1.0 / -z, u = x * iz, v = y * iz;
    r->q[0] = cam->cx + cam->fx * u;
    r->q[1] = cam->cy - cam->fy * v;
    for (int k = 0; k < 3; ++k) { /* d(x / -z) = (ax + u az) / -z */
        r->J[0][k] = cam->fx * iz * (ax[k] + u * az[k]);
        r->J[1][k] = -cam->fy * iz * (ay[k] + v * az[k]);
    }
    return 1;
}

/* ---- topology: for each triangle edge k (f[k], f[k+1]), the neighbour's opposite vertex ---- */

typedef struct { uint32_t lo, hi; int te; } EdgeRec; /* te = 3 * triangle + k */

static int edge_cmp(const void *x, const void *y) {
    const EdgeRec *a = x, *b = y;
    if (a->lo != b->lo) return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi) return a->hi < b->hi ? -1 : 1;
    return (a->te > b->te) - (a->te < b->te);
}

/* opp (nt, 3): the vertex opposite edge k in the triangle across it; -1 boundary, -2 non-manifold;
 * nbr (nt, 3): that triangle (-1 when there is not exactly one) */
static int topology(const MfMesh *m, int *opp, int *nbr) {
    size_t n = (size_t)m->nt * 3;
    EdgeRec *e = malloc(n * sizeof *e + 1);
    if (!e) return mf_fail(MF_ENOMEM, "antialias: out of memory for %zu edges", n);
    for (size_t i = 0; i < n; ++i) {
        uint32_t a = m->tri[i], b = m->tri[i - i % 3 + (i % 3 + 1) % 3];
        e[i] = (EdgeRec){a < b ? a : b, a < b ? b : a, (int)i};
    }
    qsort(e, n, sizeof *e, edge_cmp);
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && e[j].lo == e[i].lo && e[j].hi == e[i].hi) ++j;
        for (size_t k = i; k < j; ++k) {
            int te = e[k].te;
            nbr[te] = -1;
            if (j - i == 1) {
                opp[te] = -1;
            } else if (j - i > 2) {
                opp[te] = -2;
            } else {
                int o = e[k == i ? i + 1 : i].te; /* the other triangle's edge */
                opp[te] = (int)m->tri[o - o % 3 + (o % 3 + 2) % 3];
                nbr[te] = o / 3;
            }
        }
        i = j;
    }
    free(e);
    return MF_OK;
}

/* ---- crossings ---- */

#define T_SLACK 0.05 /* pixels */

static double side(const double *a, const double *b, const double *c) {
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* The crossing of pair (A = occluder pixel (xa, ya), B) along axis ax (0: horizontal, 1: vertical)
 * with a silhouette edge of triangle t; 1 and *c filled when found. */
static int cross_tri(const MfMesh *m, const MfCamera *cam, const int *opp, int t, int xa, int ya, int xb, int yb,
                     int ax, Cross *c) {
    const uint32_t *f = m->tri + 3 * t;
    Proj pr[3];
    for (int k = 0; k < 3; ++k)
        if (!project(cam, m->pos + 3 * f[k], &pr[k])) return 0;
    int oa = ax, ob = 1 - ax; /* along the pair, across it */
    double ca[2] = {xa + 0.5, ya + 0.5}, cb[2] = {xb + 0.5, yb + 0.5};
    for (int k = 0; k < 3; ++k) {
        const Proj *P = &pr[k], *Q = &pr[(k + 1) % 3];
        const double *p = P->q, *q = Q->q;
        double e[2] = {q[0] - p[0], q[1] - p[1]};
        /* horizontal pairs take edges with |dy| >= |dx|, vertical pairs the others */
        if (ax == 0 ? !(fabs(e[1]) >= fabs(e[0])) : !(fabs(e[0]) > fabs(e[1]))) continue;
        int o = opp[3 * t + k];
        if (o >= 0) { /* silhouette when the neighbour's far vertex lies on our triangle's side */
            Proj po;
            if (!project(cam, m->pos + 3 * o, &po)) continue;
            if (side(p, q, pr[(k + 2) % 3].q) * side(p, q, po.q) <= 0.0) continue;
        }
        /* crossing with the line through both centres (coordinate ob = ca[ob]) */
        double s = (ca[ob] - p[ob]) / e[ob];
        if (!(s >= 0.0 && s <= 1.0)) continue;
        double xc = p[oa] + s * e[oa];
        double dir = cb[oa] > ca[oa] ? 1.0 : -1.0; /* from A toward B */
        /* t lies in [0, 1] when the G-buffer and the mesh agree; a small slack (then clamped, with
         * no gradient) keeps rounding between Embree's hits and this projection, or a vertex
         * moved under a fixed G-buffer, from dropping the pair */
        double tt = (xc - ca[oa]) * dir;
        if (!(tt >= -T_SLACK && tt <= 1.0 + T_SLACK)) continue;
        int clamped = tt < 0.0 || tt > 1.0;
        tt = fmin(fmax(tt, 0.0), 1.0);
        /* dxc/dp[oa] = 1 - s, dxc/dq[oa] = s, dxc/dp[ob] = e[oa] (s - 1) / e[ob], dxc/dq[ob] = -e[oa] s / e[ob] */
        double gp[2], gq[2];
        gp[oa] = 1.0 - s;
        gq[oa] = s;
        gp[ob] = e[oa] * (s - 1.0) / e[ob];
        gq[ob] = -e[oa] * s / e[ob];
        if (clamped) gp[0] = gp[1] = gq[0] = gq[1] = 0.0;
        c->t = (float)tt;
        c->va = (int)f[k];
        c->vb = (int)f[(k + 1) % 3];
        for (int j = 0; j < 3; ++j) {
            c->dta[j] = (float)(dir * (gp[0] * P->J[0][j] + gp[1] * P->J[1][j]));
            c->dtb[j] = (float)(dir * (gq[0] * Q->J[0][j] + gq[1] * Q->J[1][j]));
        }
        return 1;
    }
    return 0;
}

/* cross_tri on A's triangle t, then (when the line between the centres leaves t through an edge
 * it shares with the same surface, e.g. near a corner of a quad) on t's neighbours */
static int find_cross(const MfMesh *m, const MfCamera *cam, const int *opp, const int *nbr, int t, int xa, int ya,
                      int xb, int yb, int ax, Cross *c) {
    if (cross_tri(m, cam, opp, t, xa, ya, xb, yb, ax, c)) return 1;
    for (int k = 0; k < 3; ++k)
        if (nbr[3 * t + k] >= 0 && cross_tri(m, cam, opp, nbr[3 * t + k], xa, ya, xb, yb, ax, c)) return 1;
    return 0;
}

static int push(MfAa *a, const Cross *c) {
    if (a->ncr == a->cap) {
        int cap = a->cap ? 2 * a->cap : 256;
        Cross *n = realloc(a->cr, (size_t)cap * sizeof *n);
        if (!n) return mf_fail(MF_ENOMEM, "antialias: out of memory for %d crossings", cap);
        a->cr = n;
        a->cap = cap;
    }
    a->cr[a->ncr++] = *c;
    return MF_OK;
}

static MfAa *aa_alloc(const MfMesh *m, const MfCamera *cam) {
    MfAa *a = calloc(1, sizeof *a);
    size_t np = (size_t)cam->w * cam->h;
    if (a) {
        a->tri = malloc(np * sizeof(int));
        a->depth = malloc(np * sizeof(float));
    }
    if (!a || !a->tri || !a->depth) {
        mf_aa_free(a);
        mf_fail(MF_ENOMEM, "antialias: out of memory for a %dx%d G-buffer", cam->w, cam->h);
        return NULL;
    }
    a->mesh = m;
    a->w = cam->w;
    a->h = cam->h;
    return a;
}

/* the crossings of a's G-buffer (serial scan: fixed order) */
static int crossings(MfAa *a, const MfCamera *cam) {
    const MfMesh *m = a->mesh;
    int *opp = malloc((size_t)m->nt * 6 * sizeof(int) + 1), *nbr = opp + (size_t)m->nt * 3;
    if (!opp) return mf_fail(MF_ENOMEM, "antialias: out of memory for the edge table");
    int rc = topology(m, opp, nbr);
    for (int y = 0; y < cam->h && !rc; ++y)
        for (int x = 0; x < cam->w && !rc; ++x)
            for (int ax = 0; ax < 2 && !rc; ++ax) {
                int x2 = x + (ax == 0), y2 = y + (ax == 1);
                if (x2 >= cam->w || y2 >= cam->h) continue;
                int i = y * cam->w + x, j = y2 * cam->w + x2, ti = a->tri[i], tj = a->tri[j];
                if (ti == tj) continue;
                int first = tj < 0 || (ti >= 0 && a->depth[i] <= a->depth[j]); /* (x, y) is the occluder */
                Cross c;
                int found = first ? find_cross(m, cam, opp, nbr, ti, x, y, x2, y2, ax, &c)
                                  : find_cross(m, cam, opp, nbr, tj, x2, y2, x, y, ax, &c);
                if (!found) continue;
                c.a = first ? i : j;
                c.b = first ? j : i;
                rc = push(a, &c);
            }
    free(opp);
    return rc;
}

int mf_aa_new(const MfRtScene *rt, const MfCamera *cam, MfAa **out) {
    if (cam->w <= 0 || cam->h <= 0) return mf_fail(MF_EARG, "antialias: camera size %dx%d is invalid", cam->w, cam->h);
    MfAa *a = aa_alloc(mf_rtscene_mesh(rt), cam);
    if (!a) return MF_ENOMEM;
    MfVec3 fwd = mf_v3(-cam->c2w.m[2], -cam->c2w.m[6], -cam->c2w.m[10]);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < cam->h; ++y)
        for (int x = 0; x < cam->w; ++x) {
            MfVec3 org, dir;
            MfHit hit;
            size_t i = (size_t)y * cam->w + x;
            mf_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, &org, &dir);
            int got = mf_rtscene_intersect(rt, org, dir, 0.0f, INFINITY, &hit);
            a->tri[i] = got ? hit.tri : -1;
            a->depth[i] = got ? hit.t * mf_dot(dir, fwd) : 0.0f;
        }
    int rc = crossings(a, cam);
    if (rc) {
        mf_aa_free(a);
        return rc;
    }
    *out = a;
    return MF_OK;
}

int mf_aa_new_gbuffer(const MfMesh *m, const MfCamera *cam, const int *tri, const float *depth, MfAa **out) {
    if (cam->w <= 0 || cam->h <= 0) return mf_fail(MF_EARG, "antialias: camera size %dx%d is invalid", cam->w, cam->h);
    for (int i = 0; i < cam->w * cam->h; ++i)
        if (tri[i] < -1 || tri[i] >= m->nt)
            return mf_fail(MF_EARG, "antialias: G-buffer triangle %d at pixel %d is not in the mesh", tri[i], i);
    MfAa *a = aa_alloc(m, cam);
    if (!a) return MF_ENOMEM;
    memcpy(a->tri, tri, (size_t)cam->w * cam->h * sizeof(int));
    memcpy(a->depth, depth, (size_t)cam->w * cam->h * sizeof(float));
    int rc = crossings(a, cam);
    if (rc) {
        mf_aa_free(a);
        return rc;
    }
    *out = a;
    return MF_OK;
}

void mf_aa_free(MfAa *a) {
    if (!a) return;
    free(a->tri);
    free(a->depth);
    free(a->cr);
    free(a);
}

int mf_aa_count(const MfAa *a) { return a->ncr; }
const int *mf_aa_tri(const MfAa *a) { return a->tri; }
const float *mf_aa_depth(const MfAa *a) { return a->depth; }

void mf_aa_forward(const MfAa *a, const float *in, int c, float *out) {
    memcpy(out, in, (size_t)a->w * a->h * c * sizeof(float));
    for (int k = 0; k < a->ncr; ++k) {
        const Cross *x = &a->cr[k];
        const float *A = in + (size_t)x->a * c, *B = in + (size_t)x->b * c;
        if (x->t > 0.5f) {
            float *o = out + (size_t)x->b * c, w = x->t - 0.5f;
            for (int ch = 0; ch < c; ++ch) o[ch] += w * (A[ch] - B[ch]);
        } else {
            float *o = out + (size_t)x->a * c, w = 0.5f - x->t;
            for (int ch = 0; ch < c; ++ch) o[ch] += w * (B[ch] - A[ch]);
        }
    }
}

void mf_aa_backward(const MfAa *a, const float *in, int c, const float *dout, float *din, float *dpos) {
    if (din)
        for (size_t i = 0; i < (size_t)a->w * a->h * c; ++i) din[i] += dout[i];
    for (int k = 0; k < a->ncr; ++k) {
        const Cross *x = &a->cr[k];
        const float *A = in + (size_t)x->a * c, *B = in + (size_t)x->b * c;
        int far = x->t > 0.5f;
        const float *g = dout + (size_t)(far ? x->b : x->a) * c; /* the blended pixel's adjoint */
        float w = far ? x->t - 0.5f : 0.5f - x->t, gt = 0.0f;
        for (int ch = 0; ch < c; ++ch) gt += g[ch] * (A[ch] - B[ch]); /* d out / dt = A - B either way */
        if (din) { /* far: B += w (A - B); near: A += w (B - A) */
            float *dA = din + (size_t)x->a * c, *dB = din + (size_t)x->b * c;
            for (int ch = 0; ch < c; ++ch) {
                dA[ch] += (far ? w : -w) * g[ch];
                dB[ch] += (far ? -w : w) * g[ch];
            }
        }
        if (dpos)
            for (int j = 0; j < 3; ++j) {
                dpos[3 * x->va + j] += gt * x->dta[j];
                dpos[3 * x->vb + j] += gt * x->dtb[j];
            }
    }
}
