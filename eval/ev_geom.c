#include "eval/ev_geom.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_rtscene.h"

/* A kd-tree stored implicitly: idx (n,) is reordered so the median of each range [lo, hi) sits
 * at mid = (lo + hi) / 2, split on axis depth % 3. */
typedef struct {
    const float *p; /* borrowed; (n, 3) */
    int *idx;       /* owned; (n,) */
} KdTree;

typedef struct { const float *p; int axis; } AxisCtx;
static int cmp_axis(const void *a, const void *b, void *ctx) {
    const AxisCtx *c = ctx;
    float x = c->p[3 * *(const int *)a + c->axis], y = c->p[3 * *(const int *)b + c->axis];
    if (x != y) return x < y ? -1 : 1;
    return *(const int *)a - *(const int *)b;
}

static void kd_build(KdTree *t, int lo, int hi, int depth) {
    if (hi - lo <= 1) return;
    AxisCtx c = {t->p, depth % 3};
    qsort_r(t->idx + lo, (size_t)(hi - lo), sizeof(int), cmp_axis, &c);
    int mid = (lo + hi) / 2;
    kd_build(t, lo, mid, depth + 1);
    kd_build(t, mid + 1, hi, depth + 1);
}

static void kd_query(const KdTree *t, int lo, int hi, int depth, const float q[3], int *best, double *bd) {
    if (hi <= lo) return;
    int mid = (lo + hi) / 2, i = t->idx[mid], ax = depth % 3;
    const float *p = t->p + 3 * i;
    double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
    double d = dx * dx + dy * dy + dz * dz;
    if (d < *bd || (d == *bd && i < *best)) *bd = d, *best = i;
    double diff = (double)q[ax] - p[ax];
    int nlo = diff < 0 ? lo : mid + 1, nhi = diff < 0 ? mid : hi;
    int flo = diff < 0 ? mid + 1 : lo, fhi = diff < 0 ? hi : mid;
    kd_query(t, nlo, nhi, depth + 1, q, best, bd);
    if (diff * diff <= *bd) kd_query(t, flo, fhi, depth + 1, q, best, bd);
}

int ev_nearest(const float *pts, int np, const float *q, int nq, int *nn, double *d2) {
    if (np < 1) return mf_fail(MF_EARG, "nearest points: empty point set");
    KdTree t = {pts, malloc((size_t)np * sizeof(int))};
    if (!t.idx) return mf_fail(MF_ENOMEM, "nearest points: out of memory");
    for (int i = 0; i < np; ++i) t.idx[i] = i;
    kd_build(&t, 0, np, 0);
#pragma omp parallel for schedule(dynamic, 256)
    for (int k = 0; k < nq; ++k) {
        int best = -1;
        double bd = INFINITY;
        kd_query(&t, 0, np, 0, q + 3 * k, &best, &bd);
        nn[k] = best, d2[k] = bd;
    }
    free(t.idx);
    return MF_OK;
}

static MfVec3 vtx(const MfMesh *m, uint32_t v) { return mf_v3(m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2]); }

static int cmp_pos(const void *a, const void *b, void *ctx) {
    const float *p = ctx, *x = p + 3 * *(const int *)a, *y = p + 3 * *(const int *)b;
    for (int c = 0; c < 3; ++c)
        if (x[c] != y[c]) return x[c] < y[c] ? -1 : 1;
    return *(const int *)a - *(const int *)b;
}

/* Area-weighted vertex normals (nv, 3) of m, summed over all vertices at the same position, so
 * a smooth surface split at UV seams gets one normal there. */
static int gt_normals(const MfMesh *m, float *n) {
    int *ord = malloc((size_t)m->nv * sizeof *ord);
    if (!ord) return mf_fail(MF_ENOMEM, "geometry score: out of memory");
    memset(n, 0, (size_t)m->nv * 3 * sizeof *n);
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 c = mf_cross(mf_sub(vtx(m, f[1]), vtx(m, f[0])), mf_sub(vtx(m, f[2]), vtx(m, f[0])));
        for (int k = 0; k < 3; ++k) n[3 * f[k]] += c.x, n[3 * f[k] + 1] += c.y, n[3 * f[k] + 2] += c.z;
    }
    for (int v = 0; v < m->nv; ++v) ord[v] = v;
    qsort_r(ord, (size_t)m->nv, sizeof *ord, cmp_pos, m->pos);
    for (int i = 0; i < m->nv;) {
        int j = i;
        MfVec3 sum = mf_v3s(0);
        while (j < m->nv && !memcmp(m->pos + 3 * ord[j], m->pos + 3 * ord[i], 3 * sizeof(float)))
            sum = mf_add(sum, mf_v3(n[3 * ord[j]], n[3 * ord[j] + 1], n[3 * ord[j] + 2])), ++j;
        float l = mf_len(sum);
        sum = l > 0 ? mf_scale(sum, 1 / l) : mf_v3(0, 0, 1);
        for (; i < j; ++i) memcpy(n + 3 * ord[i], &sum, sizeof sum);
    }
    free(ord);
    return MF_OK;
}

int ev_geom_sample(const MfMesh *m, int n, uint64_t seed, uint64_t stream, float *pts, float *nrm) {
    if (m->nt < 1 || n < 1) return mf_fail(MF_EARG, "area samples: empty mesh");
    double *cdf = malloc((size_t)m->nt * sizeof *cdf), acc = 0; /* (nt,) running area */
    if (!cdf) return mf_fail(MF_ENOMEM, "area samples: out of memory");
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *s = m->tri + 3 * t;
        acc += 0.5 * mf_len(mf_cross(mf_sub(vtx(m, s[1]), vtx(m, s[0])), mf_sub(vtx(m, s[2]), vtx(m, s[0]))));
        cdf[t] = acc;
    }
    if (!(acc > 0)) {
        free(cdf);
        return mf_fail(MF_EARG, "area samples: the mesh has zero area");
    }
    MfRng rng;
    mf_rng_seed(&rng, seed, stream);
    for (int k = 0; k < n; ++k) {
        double u = mf_rng_double(&rng) * acc;
        int lo = 0, hi = m->nt - 1;
        while (lo < hi) {
            int mid = (lo + hi) / 2;
            if (cdf[mid] < u) lo = mid + 1;
            else hi = mid;
        }
        const uint32_t *s = m->tri + 3 * lo;
        float r1 = sqrtf(mf_rng_float(&rng)), r2 = mf_rng_float(&rng);
        MfVec3 a = vtx(m, s[0]), b = vtx(m, s[1]), c = vtx(m, s[2]);
        MfVec3 p = mf_add(mf_add(mf_scale(a, 1 - r1), mf_scale(b, r1 * (1 - r2))), mf_scale(c, r1 * r2));
        memcpy(pts + 3 * k, &p, sizeof p);
        if (nrm) {
            MfVec3 nn = mf_norm(mf_cross(mf_sub(b, a), mf_sub(c, a)));
            memcpy(nrm + 3 * k, &nn, sizeof nn);
        }
    }
    free(cdf);
    return MF_OK;
}

/* The mean squared nearest distance a -> b plus b -> a, over 2 (not yet x 1e3); scratch nn and
 * d2 hold max(na, nb) entries. */
static int chamfer_pts(const float *a, int na, const float *b, int nb, int *nn, double *d2, double *out) {
    double sa = 0, sb = 0;
    int rc = ev_nearest(b, nb, a, na, nn, d2);
    for (int i = 0; rc == MF_OK && i < na; ++i) sa += d2[i];
    if (rc == MF_OK) rc = ev_nearest(a, na, b, nb, nn, d2);
    for (int i = 0; rc == MF_OK && i < nb; ++i) sb += d2[i];
    if (rc == MF_OK) *out = 0.5 * (sa / na + sb / nb);
    return rc;
}

int ev_geom_score(const MfMesh *gt, const MfMesh *pred, int n_samples, uint64_t seed, EvGeomScore *out) {
    if (gt->nv < 1 || gt->nt < 1) return mf_fail(MF_EARG, "geometry score: the GT mesh is empty");
    if (pred->nt < 1 || n_samples < 1) return mf_fail(MF_EARG, "geometry score: the predicted mesh is empty");
    int nmax = gt->nv > n_samples ? gt->nv : n_samples;
    float *gn = malloc((size_t)gt->nv * 3 * sizeof *gn), *sp = malloc((size_t)n_samples * 3 * sizeof *sp);
    float *sn = malloc((size_t)n_samples * 3 * sizeof *sn), *gp = malloc((size_t)n_samples * 3 * sizeof *gp);
    int *nn_g = malloc((size_t)gt->nv * sizeof *nn_g), *nn_s = malloc((size_t)nmax * sizeof *nn_s);
    double *d_g = malloc((size_t)gt->nv * sizeof *d_g), *d_s = malloc((size_t)nmax * sizeof *d_s), uni = 0;
    int rc = MF_OK;
    if (!gn || !sp || !sn || !gp || !nn_g || !nn_s || !d_g || !d_s) { rc = mf_fail(MF_ENOMEM, "geometry score: out of memory"); goto done; }
    if (ev_geom_sample(pred, n_samples, seed, EV_GEOM_STREAM_PRED, sp, sn) != MF_OK) {
        rc = mf_fail(MF_EARG, "geometry score: the predicted mesh has zero area");
        goto done;
    }
    if (ev_geom_sample(gt, n_samples, seed, EV_GEOM_STREAM_GT, gp, NULL) != MF_OK) {
        rc = mf_fail(MF_EARG, "geometry score: the GT mesh has zero area");
        goto done;
    }
    if ((rc = chamfer_pts(gp, n_samples, sp, n_samples, nn_s, d_s, &uni)) != MF_OK) goto done;
    if ((rc = gt_normals(gt, gn)) != MF_OK) goto done;
    if ((rc = ev_nearest(sp, n_samples, gt->pos, gt->nv, nn_g, d_g)) != MF_OK) goto done;
    if ((rc = ev_nearest(gt->pos, gt->nv, sp, n_samples, nn_s, d_s)) != MF_OK) goto done;
    double sg = 0, ss = 0, ag = 0, as = 0, cg = 0, cs = 0;
    for (int v = 0; v < gt->nv; ++v) {
        double c = fmax(-1, fmin(1, (double)gn[3 * v] * sn[3 * nn_g[v]] + (double)gn[3 * v + 1] * sn[3 * nn_g[v] + 1] +
                                        (double)gn[3 * v + 2] * sn[3 * nn_g[v] + 2]));
        sg += d_g[v], ag += acos(c) * 180 / M_PI, cg += 1 - c;
    }
    for (int k = 0; k < n_samples; ++k) {
        double c = fmax(-1, fmin(1, (double)sn[3 * k] * gn[3 * nn_s[k]] + (double)sn[3 * k + 1] * gn[3 * nn_s[k] + 1] +
                                        (double)sn[3 * k + 2] * gn[3 * nn_s[k] + 2]));
        ss += d_s[k], as += acos(c) * 180 / M_PI, cs += 1 - c;
    }
    EvGeomScore r = {0};
    r.gt_to_pred = 1e3 * sg / gt->nv;
    r.pred_to_gt = 1e3 * ss / n_samples;
    r.chamfer = 0.5 * (r.gt_to_pred + r.pred_to_gt);
    r.chamfer_uniform = 1e3 * uni;
    r.normal_deg = 0.5 * (ag / gt->nv + as / n_samples);
    r.normal_1mcos = 0.5 * (cg / gt->nv + cs / n_samples);
    r.n_gt = gt->nv, r.n_pred = n_samples;
    *out = r;
done:
    free(gn), free(sp), free(sn), free(gp), free(nn_g), free(nn_s), free(d_g), free(d_s);
    return rc;
}

int ev_geom_views(const MfMesh *gt, const MfMesh *pred, const MfCamera *cams, int n, EvGeomViews *out) {
    MfRtScene *sg = NULL, *sp = NULL;
    int rc = mf_rtscene_new(gt, &sg);
    if (rc == MF_OK) rc = mf_rtscene_new(pred, &sp);
    double sdeg = 0, scos = 0;
    long both = 0, either = 0;
    for (int v = 0; v < n && rc == MF_OK; ++v) {
        const MfCamera *c = &cams[v];
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : sdeg, scos, both, either)
        for (int y = 0; y < c->h; ++y)
            for (int x = 0; x < c->w; ++x) {
                MfVec3 o, d;
                MfHit hg, hp;
                mf_camera_ray(c, (float)x + 0.5f, (float)y + 0.5f, &o, &d);
                int ig = mf_rtscene_intersect(sg, o, d, 0, INFINITY, &hg), ip = mf_rtscene_intersect(sp, o, d, 0, INFINITY, &hp);
                either += ig || ip;
                if (!(ig && ip)) continue;
                double cs = fmax(-1, fmin(1, mf_dot(hg.ns, hp.ns)));
                ++both, sdeg += acos(cs) * 180 / M_PI, scos += 1 - cs;
            }
    }
    mf_rtscene_free(sg);
    mf_rtscene_free(sp);
    if (rc != MF_OK) return rc;
    if (both == 0) return mf_fail(MF_EARG, "geometry views: no pixel shows both meshes");
    EvGeomViews r = {sdeg / both, scos / both, (double)both / either, both};
    *out = r;
    return MF_OK;
}
