/* mf_chartpack: skyline packing of conservatively rasterised charts (see the header). */
#include "geom/mf_chartpack.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

enum { PACK_GRID_MAX = 512, PACK_BISECT = 7 };

void mf_chartpack_turn(int rot, double w, double h, double u, double v, double *rx, double *ry) {
    switch (rot & 3) {
    case 0: *rx = u, *ry = v; break;
    case 1: *rx = h - v, *ry = u; break;
    case 2: *rx = w - u, *ry = h - v; break;
    default: *rx = v, *ry = w - u; break;
    }
}

/* One chart in one rotation at the trial scale: per column c in [0, mw) the lowest covered row
 * bot[c] and one past the highest top[c]; botd (mw + 2 d,): the bottom profile of the cells grown
 * by d, for columns -d .. mw + d - 1. */
typedef struct {
    int mw, mtop; /* columns; highest top */
    int *bot, *top, *botd;
} Profile;

typedef struct {
    const MfChartShape *ch;
    int n, P, d;
    int *order;   /* (n,) largest area first */
    int *buf;     /* profile storage: chart c's four rotations from ofs[c] */
    size_t buf_n, *ofs; /* (n,) */
    Profile *prof; /* (n, 4) */
    int *sky;     /* (P,) first free row per column */
} Packer;

/* Rasterises chart ch turned by rot at scale s into pr (storage from mem, which must hold
 * 3 (mw + 2 d) ints for mw = floor(s * extent) + 1). */
static inline double dmin(double a, double b) { return a < b ? a : b; }
static inline double dmax(double a, double b) { return a > b ? a : b; }

static void profile(const MfChartShape *ch, int rot, double s, int d, int *mem, Profile *pr) {
    double W = (rot & 1) ? ch->h : ch->w;
    int mw = (int)floor(s * W) + 1;
    pr->mw = mw, pr->bot = mem, pr->top = mem + mw, pr->botd = mem + 2 * mw;
    for (int c = 0; c < mw; ++c) pr->bot[c] = INT32_MAX, pr->top[c] = 0;
    for (int t = 0; t < ch->nt; ++t) {
        double q[3][2];
        for (int k = 0; k < 3; ++k) {
            const double *uv = ch->uv + 2 * ch->tri[3 * t + k];
            mf_chartpack_turn(rot, ch->w, ch->h, uv[0], uv[1], &q[k][0], &q[k][1]);
            q[k][0] *= s, q[k][1] *= s;
        }
        /* per column i the rows the triangle touches: the y extent of its part inside the slab
         * [i, i + 1] (grown by eps), from the vertices in the slab and the edges' crossings of
         * the slab's sides; conservative, and contiguous because the triangle is convex */
        const double eps = 1e-6;
        int i0 = (int)floor(dmin(q[0][0], dmin(q[1][0], q[2][0])) - eps), i1 = (int)floor(dmax(q[0][0], dmax(q[1][0], q[2][0])) + eps);
        if (i0 < 0) i0 = 0;
        if (i1 > mw - 1) i1 = mw - 1;
        for (int i = i0; i <= i1; ++i) {
            double lo = i - eps, hi = i + 1 + eps, y0 = INFINITY, y1 = -INFINITY;
            for (int e = 0; e < 3; ++e) {
                const double *pa = q[e], *pb = q[(e + 1) % 3];
                if (pa[0] >= lo && pa[0] <= hi) y0 = dmin(y0, pa[1]), y1 = dmax(y1, pa[1]);
                double xa = dmin(pa[0], pb[0]), xb = dmax(pa[0], pb[0]);
                if (!(xb > xa)) continue;
                for (int side = 0; side < 2; ++side) {
                    double X = side ? hi : lo;
                    if (X < xa || X > xb) continue;
                    double y = pa[1] + (X - pa[0]) / (pb[0] - pa[0]) * (pb[1] - pa[1]);
                    y0 = dmin(y0, y), y1 = dmax(y1, y);
                }
            }
            if (!(y1 >= y0)) continue;
            int j0 = (int)floor(y0 - eps), j1 = (int)floor(y1 + eps);
            if (j0 < 0) j0 = 0;
            if (j0 < pr->bot[i]) pr->bot[i] = j0;
            if (j1 + 1 > pr->top[i]) pr->top[i] = j1 + 1;
        }
    }
    pr->mtop = 0;
    for (int c = 0; c < mw; ++c) {
        if (pr->bot[c] == INT32_MAX) pr->bot[c] = pr->top[c] = 0; /* cannot happen for a connected chart */
        if (pr->top[c] > pr->mtop) pr->mtop = pr->top[c];
    }
    for (int j = -d; j < mw + d; ++j) {
        int lo = INT32_MAX;
        for (int c = j - d; c <= j + d; ++c)
            if (c >= 0 && c < mw && pr->top[c] > pr->bot[c] && pr->bot[c] < lo) lo = pr->bot[c];
        pr->botd[j + d] = lo == INT32_MAX ? INT32_MAX : lo - d; /* INT32_MAX: no constraint */
    }
}

typedef struct {
    int x, y, rot;
} Spot;

static int place_all(Packer *k, int mode, Spot *pos, int *maxx, int *maxy);

/* Packs every chart at scale s; pos (n,) the spots. Returns 1 if all fit in the grid, 0 if not,
 * MF_ENOMEM. The charts' profiles are rasterised first (in parallel, each into its own slice),
 * then placed in order. */
static int try_scale(Packer *k, double s, Spot *pos, int *maxx, int *maxy) {
    int P = k->P, d = k->d;
    size_t need = 0;
    for (int c = 0; c < k->n; ++c) {
        int mwmax = (int)floor(s * fmax(k->ch[c].w, k->ch[c].h)) + 1;
        if (mwmax + 2 * d > P) return 0;
        k->ofs[c] = need;
        need += 4 * 3 * ((size_t)mwmax + 2 * (size_t)d);
    }
    if (need > k->buf_n) {
        int *b = realloc(k->buf, need * sizeof *b);
        if (!b) return MF_ENOMEM;
        k->buf = b, k->buf_n = need;
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int c = 0; c < k->n; ++c) {
        int stride = (int)((c + 1 < k->n ? k->ofs[c + 1] : need) - k->ofs[c]) / 4;
        for (int r = 0; r < 4; ++r) profile(&k->ch[c], r, s, d, k->buf + k->ofs[c] + (size_t)r * stride, &k->prof[4 * c + r]);
    }
    for (int mode = 0; mode < 2; ++mode) {
        int f = place_all(k, mode, pos, maxx, maxy);
        if (f) return f;
    }
    return 0;
}

/* Places the charts (profiles rasterised) on the skyline in order; mode 0 minimises the chart's
 * bottom y, mode 1 its top (y + highest profile row); ties: the least area left under the chart. */
static int place_all(Packer *k, int mode, Spot *pos, int *maxx, int *maxy) {
    int P = k->P, d = k->d;
    for (int x = 0; x < P; ++x) k->sky[x] = d;
    *maxx = *maxy = 0;
    for (int oi = 0; oi < k->n; ++oi) {
        int ci = k->order[oi];
        const Profile *pr = k->prof + 4 * ci;
        long best_y = -1, best_waste = 0;
        Spot best = {0, 0, 0};
        for (int r = 0; r < 4; ++r) {
            const Profile *p = &pr[r];
            for (int x = d; x + p->mw + d <= P; ++x) {
                int y = d, add = mode ? p->mtop : 0; /* the score: y + add */
                for (int j = -d; j < p->mw + d && (best_y < 0 || y + add <= best_y); ++j)
                    if (p->botd[j + d] != INT32_MAX && k->sky[x + j] - p->botd[j + d] > y) y = k->sky[x + j] - p->botd[j + d];
                if ((long)y + p->mtop + d > P || (best_y >= 0 && y + add > best_y)) continue;
                long waste = 0;
                for (int c = 0; c < p->mw; ++c) waste += (long)y + p->bot[c] - k->sky[x + c];
                if (best_y < 0 || y + add < best_y || waste < best_waste) best_y = y + add, best_waste = waste, best = (Spot){x, y, r};
            }
        }
        if (best_y < 0) return 0;
        const Profile *p = &pr[best.rot];
        for (int c = 0; c < p->mw; ++c)
            if (best.y + p->top[c] > k->sky[best.x + c]) k->sky[best.x + c] = best.y + p->top[c];
        if (best.x + p->mw > *maxx) *maxx = best.x + p->mw;
        if (best.y + p->mtop > *maxy) *maxy = best.y + p->mtop;
        pos[ci] = best;
    }
    return 1;
}

typedef struct {
    double area;
    int i;
} AreaKey;

static int area_desc(const void *pa, const void *pb) {
    const AreaKey *a = pa, *b = pb;
    if (a->area != b->area) return a->area > b->area ? -1 : 1;
    return (a->i > b->i) - (a->i < b->i);
}

int mf_chartpack(const MfChartShape *ch, int n, int res, float gutter, int stretch, MfChartPlace *place, double *scale_out) {
    if (n < 1 || res < 1) return 1;
    Packer k = {ch, n, 2 * res < PACK_GRID_MAX ? 2 * res : PACK_GRID_MAX, 0, NULL, NULL, 0, NULL, NULL, NULL};
    k.d = (int)ceil((double)gutter * k.P / res - 1e-9);
    if (k.d < 0) k.d = 0;
    AreaKey *key = malloc((size_t)n * sizeof *key);
    k.order = malloc((size_t)n * sizeof *k.order);
    k.sky = malloc((size_t)k.P * sizeof *k.sky);
    k.ofs = malloc((size_t)n * sizeof *k.ofs);
    k.prof = malloc(4 * (size_t)n * sizeof *k.prof);
    Spot *pos = malloc((size_t)n * sizeof *pos), *fit = malloc((size_t)n * sizeof *fit);
    int rc = 1;
    if (!key || !k.order || !k.sky || !k.ofs || !k.prof || !pos || !fit) { rc = mf_fail(MF_ENOMEM, "out of memory for chart packing"); goto done; }
    double area = 0;
    for (int i = 0; i < n; ++i) {
        key[i] = (AreaKey){ch[i].area, i};
        area += ch[i].area > 0 ? ch[i].area : 0;
    }
    qsort(key, (size_t)n, sizeof *key, area_desc);
    for (int i = 0; i < n; ++i) k.order[i] = key[i].i;
    double side = k.P - 2.0 * k.d;
    if (!(area > 0) || side < 1) goto done;
    /* the area bound (every texel used) is an upper bound on the scale; walk down to a fit */
    double hi = side / sqrt(area), lo = 0, s = 0.9 * hi;
    int mx = 0, my = 0, fmx = 0, fmy = 0;
    for (int it = 0; it < 40 && lo == 0; ++it, s *= 0.8) {
        int f = try_scale(&k, s, pos, &mx, &my);
        if (f < 0) { rc = mf_fail(MF_ENOMEM, "out of memory for chart packing"); goto done; }
        if (f) lo = s, memcpy(fit, pos, (size_t)n * sizeof *fit), fmx = mx, fmy = my;
        else hi = s;
    }
    if (lo == 0) goto done;
    for (int it = 0; it < PACK_BISECT; ++it) {
        double mid = 0.5 * (lo + hi);
        int f = try_scale(&k, mid, pos, &mx, &my);
        if (f < 0) { rc = mf_fail(MF_ENOMEM, "out of memory for chart packing"); goto done; }
        if (f) lo = mid, memcpy(fit, pos, (size_t)n * sizeof *fit), fmx = mx, fmy = my;
        else hi = mid;
    }
    /* grid -> [0,1]: the used box [d, fmx] x [d, fmy] stretched to [d, P - d] when asked */
    double P = k.P, fx = 1, fy = 1;
    if (stretch) {
        if (fmx > k.d) fx = fmax(1.0, (P - 2 * k.d) / (fmx - k.d));
        if (fmy > k.d) fy = fmax(1.0, (P - 2 * k.d) / (fmy - k.d));
    }
    for (int i = 0; i < n; ++i)
        place[i] = (MfChartPlace){fit[i].rot, (k.d + (fit[i].x - k.d) * fx) / P, (k.d + (fit[i].y - k.d) * fy) / P, lo * fx / P, lo * fy / P};
    if (scale_out) *scale_out = lo;
    rc = MF_OK;
done:
    free(key), free(k.order), free(k.sky), free(k.buf), free(k.ofs), free(k.prof), free(pos), free(fit);
    return rc;
}
