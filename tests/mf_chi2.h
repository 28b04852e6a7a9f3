/* mf_chi2: helpers for statistical tests of samplers (header-only, for tests).
 *
 * mf_quad2d: adaptive 2D Gauss-Legendre quadrature (5x5 nodes per rectangle; a rectangle is
 *   split in 4 until the split changes the estimate by less than its share of the error budget
 *   max(tol, 1e-6 |I|) (a quarter per level), at least min_depth and at most max_depth times).
 *   Used to integrate a pdf over chi-square cells.
 * mf_chi2_test: Pearson chi-square of observed against expected counts; cells with expected < 5
 *   are pooled (smallest first) into one cell that is grown until its expected count is >= 5.
 *   Returns the p-value (gsl_cdf_chisq_Q); 0 when a cell with expected 0 was observed. */
#ifndef MF_CHI2_H
#define MF_CHI2_H

#include <gsl/gsl_cdf.h>
#include <math.h>
#include <stdlib.h>

typedef double (*MfQuadFn)(void *ctx, double x, double y);

static const double mf_gl5_x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
static const double mf_gl5_w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665, 0.2369268850561891};

static inline double mf_quad_gl5(MfQuadFn f, void *ctx, double x0, double x1, double y0, double y1) {
    double cx = 0.5 * (x0 + x1), hx = 0.5 * (x1 - x0), cy = 0.5 * (y0 + y1), hy = 0.5 * (y1 - y0), s = 0.0;
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) s += mf_gl5_w[i] * mf_gl5_w[j] * f(ctx, cx + hx * mf_gl5_x[i], cy + hy * mf_gl5_x[j]);
    return s * hx * hy;
}

static inline double mf_quad2d_rec(MfQuadFn f, void *ctx, double x0, double x1, double y0, double y1, double whole, double tol,
                                   int depth, int min_depth, int max_depth) {
    double xm = 0.5 * (x0 + x1), ym = 0.5 * (y0 + y1);
    double q[4] = {mf_quad_gl5(f, ctx, x0, xm, y0, ym), mf_quad_gl5(f, ctx, xm, x1, y0, ym), mf_quad_gl5(f, ctx, x0, xm, ym, y1),
                   mf_quad_gl5(f, ctx, xm, x1, ym, y1)};
    double sum = q[0] + q[1] + q[2] + q[3];
    if (depth + 1 >= max_depth || (depth + 1 >= min_depth && fabs(sum - whole) <= tol)) return sum;
    double t = 0.25 * tol;
    return mf_quad2d_rec(f, ctx, x0, xm, y0, ym, q[0], t, depth + 1, min_depth, max_depth) +
           mf_quad2d_rec(f, ctx, xm, x1, y0, ym, q[1], t, depth + 1, min_depth, max_depth) +
           mf_quad2d_rec(f, ctx, x0, xm, ym, y1, q[2], t, depth + 1, min_depth, max_depth) +
           mf_quad2d_rec(f, ctx, xm, x1, ym, y1, q[3], t, depth + 1, min_depth, max_depth);
}

static inline double mf_quad2d(MfQuadFn f, void *ctx, double x0, double x1, double y0, double y1, double tol, int min_depth,
                               int max_depth) {
    double whole = mf_quad_gl5(f, ctx, x0, x1, y0, y1);
    return mf_quad2d_rec(f, ctx, x0, x1, y0, y1, whole, fmax(tol, 1e-6 * fabs(whole)), 0, min_depth, max_depth);
}

static const double *mf_chi2_sort_key;
static inline int mf_chi2_cmp(const void *a, const void *b) {
    double x = mf_chi2_sort_key[*(const int *)a], y = mf_chi2_sort_key[*(const int *)b];
    return x < y ? -1 : (x > y ? 1 : 0);
}

/* obs, expc: (n,). Writes the statistic and degrees of freedom when non-NULL. */
static inline double mf_chi2_test(const double *obs, const double *expc, int n, double *chi2_out, int *dof_out) {
    int *ord = malloc(sizeof(int) * (size_t)n);
    if (!ord) return 0.0;
    for (int i = 0; i < n; ++i) ord[i] = i;
    mf_chi2_sort_key = expc;
    qsort(ord, (size_t)n, sizeof(int), mf_chi2_cmp);
    double pool_o = 0.0, pool_e = 0.0, chi2 = 0.0;
    int cells = 0, k = 0, bad = 0;
    for (; k < n && (expc[ord[k]] < 5.0 || (pool_e > 0.0 && pool_e < 5.0)); ++k) {
        if (expc[ord[k]] <= 0.0 && obs[ord[k]] > 0.0) bad = 1;
        pool_o += obs[ord[k]];
        pool_e += expc[ord[k]];
    }
    if (pool_e > 0.0) {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++cells;
    } else if (pool_o > 0.0) bad = 1;
    for (; k < n; ++k) {
        double o = obs[ord[k]], e = expc[ord[k]];
        chi2 += (o - e) * (o - e) / e;
        ++cells;
    }
    free(ord);
    if (chi2_out) *chi2_out = chi2;
    if (dof_out) *dof_out = cells - 1;
    if (bad) return 0.0;
    if (cells < 2) return 1.0;
    return gsl_cdf_chisq_Q(chi2, (double)(cells - 1));
}

#endif
