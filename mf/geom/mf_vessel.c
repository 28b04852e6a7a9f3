#include "geom/mf_vessel.h"

#include <gsl/gsl_eigen.h>
#include <gsl/gsl_matrix.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "core/mf_error.h"

/* Squared 1D distance transform (Felzenszwalb & Huttenlocher 2012) of f (n,) into d (n,): d[q] =
 * min over p of (q - p)^2 + f[p], f[p] = INFINITY where p is no site. Scratch v (n,), z (n + 1,). */
static void edt1(const float *f, float *d, int n, int *v, float *z) {
    int k = -1;
    for (int q = 0; q < n; ++q) {
        if (!isfinite(f[q])) continue;
        float s = -INFINITY;
        while (k >= 0) {
            int p = v[k];
            s = ((f[q] + (float)q * (float)q) - (f[p] + (float)p * (float)p)) / (2.0f * (float)(q - p));
            if (s > z[k]) break;
            --k;
        }
        if (k < 0) s = -INFINITY;
        ++k, v[k] = q, z[k] = s, z[k + 1] = INFINITY;
    }
    for (int q = 0, j = 0; q < n; ++q) {
        if (k < 0) {
            d[q] = INFINITY;
            continue;
        }
        while (z[j + 1] < (float)q) ++j;
        float dq = (float)(q - v[j]);
        d[q] = dq * dq + f[v[j]];
    }
}

/* Squared Euclidean distance in cells, in place: d (N^3,) holds 0 at the sites, INFINITY elsewhere. */
static int edt3(float *d, int N) {
    float *line = malloc((size_t)N * 2 * sizeof *line), *z = malloc((size_t)(N + 1) * sizeof *z);
    int *v = malloc((size_t)N * sizeof *v);
    if (!line || !z || !v) {
        free(line), free(z), free(v);
        return mf_fail(MF_ENOMEM, "vessel: out of memory for the distance transform");
    }
    size_t n = (size_t)N;
    for (int ax = 0; ax < 3; ++ax) {
        size_t st = ax == 0 ? 1 : ax == 1 ? n : n * n;
        for (size_t a = 0; a < n; ++a)
            for (size_t b = 0; b < n; ++b) {
                size_t base = ax == 0 ? n * (a + n * b) : ax == 1 ? a + n * n * b : a + n * b;
                for (size_t q = 0; q < n; ++q) line[q] = d[base + q * st];
                edt1(line, line + N, N, v, z);
                for (size_t q = 0; q < n; ++q) d[base + q * st] = line[n + q];
            }
    }
    free(line), free(z), free(v);
    return MF_OK;
}

/* Largest p . axis over the inside vertices; -INFINITY when there are none. */
static float top_height(const MfTetGrid *g, const float *field, MfVec3 axis) {
    float h = -INFINITY;
    size_t nv = mf_tetgrid_nverts(g);
    for (size_t i = 0; i < nv; ++i)
        if (field[i] > 0) h = fmaxf(h, mf_dot(mf_tetgrid_base(g, i), axis));
    return h;
}

float mf_vessel_wall_cells(const MfTetGrid *g, const float *field, float wall_frac, float min_cells) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t nv = mf_tetgrid_nverts(g);
    for (size_t i = 0; i < nv; ++i) {
        if (!(field[i] > 0)) continue;
        MfVec3 p = mf_tetgrid_base(g, i);
        float c[3] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; ++a) lo[a] = fminf(lo[a], c[a]), hi[a] = fmaxf(hi[a], c[a]);
    }
    float side = fmaxf(hi[0] - lo[0], fmaxf(hi[1] - lo[1], hi[2] - lo[2]));
    return fmaxf(wall_frac * side / g->cell, min_cells); /* empty: -inf, so min_cells */
}

int mf_vessel_carve(const MfTetGrid *g, float *field, MfVec3 axis, float wall_cells, size_t *carved) {
    if (!(wall_cells >= MF_VESSEL_MIN_CELLS))
        return mf_fail(MF_EARG, "vessel: a wall of %g cells is thinner than %g: it would carve every inside vertex", wall_cells,
                       MF_VESSEL_MIN_CELLS);
    float hmax = top_height(g, field, axis);
    if (!isfinite(hmax)) return mf_fail(MF_EARG, "vessel: the hull is empty");
    int N = g->res + 1;
    size_t nv = mf_tetgrid_nverts(g);
    float *d = malloc(nv * sizeof *d);
    uint8_t *mark = calloc(nv, 1);
    size_t *stack = malloc(nv * sizeof *stack);
    int rc = d && mark && stack ? MF_OK : mf_fail(MF_ENOMEM, "vessel: out of memory for %zu grid vertices", nv);
    float top = hmax - 1.5f * g->cell;
    /* the walls' outside: every outside vertex below the cap's layer */
    for (size_t i = 0; !rc && i < nv; ++i)
        d[i] = field[i] <= 0 && mf_dot(mf_tetgrid_base(g, i), axis) < top ? 0.0f : INFINITY;
    if (!rc) rc = edt3(d, N);
    float w2 = wall_cells * wall_cells;
    size_t ns = 0, nc = 0;
    for (size_t i = 0; !rc && i < nv; ++i) {
        if (!(field[i] > 0 && d[i] > w2)) continue;
        mark[i] = 1;
        if (mf_dot(mf_tetgrid_base(g, i), axis) >= top) mark[i] = 2, stack[ns++] = i;
    }
    size_t n = (size_t)N, step[3] = {1, n, n * n};
    while (ns) {
        size_t i = stack[--ns], c[3] = {i % n, i / n % n, i / (n * n)};
        ++nc;
        for (int a = 0; a < 3; ++a) {
            if (c[a] > 0 && mark[i - step[a]] == 1) mark[i - step[a]] = 2, stack[ns++] = i - step[a];
            if (c[a] + 1 < n && mark[i + step[a]] == 1) mark[i + step[a]] = 2, stack[ns++] = i + step[a];
        }
    }
    /* carved vertices take the field's most outside value: mf_vhull's -0.5, or a fitted SDF's */
    float out = 0.0f;
    for (size_t i = 0; !rc && i < nv; ++i) out = fminf(out, field[i]);
    for (size_t i = 0; !rc && i < nv; ++i)
        if (mark[i] == 2) field[i] = out;
    if (!rc && carved) *carved = nc;
    free(d), free(mark), free(stack);
    return rc;
}

/* 1 when inside vertex i has an outside 6-neighbour (or lies on the grid's border). */
static int on_boundary(const float *field, size_t i, size_t n) {
    size_t c[3] = {i % n, i / n % n, i / (n * n)}, step[3] = {1, n, n * n};
    for (int a = 0; a < 3; ++a) {
        if (c[a] == 0 || c[a] + 1 == n) return 1;
        if (field[i - step[a]] <= 0 || field[i + step[a]] <= 0) return 1;
    }
    return 0;
}

/* Unit normal of the least-squares plane through the boundary vertices within 3 cells of the top
 * along axis (the eigenvector of their covariance with the smallest eigenvalue, GSL), turned to
 * axis's side. */
static int fit_cap(const MfTetGrid *g, const float *field, MfVec3 axis, MfVec3 *normal) {
    size_t nv = mf_tetgrid_nverts(g), n = (size_t)g->res + 1, k = 0;
    float top = top_height(g, field, axis) - 3.0f * g->cell;
    double s[3] = {0}, ss[3][3] = {{0}};
    for (size_t i = 0; i < nv; ++i) {
        if (!(field[i] > 0) || !on_boundary(field, i, n)) continue;
        MfVec3 p = mf_tetgrid_base(g, i);
        if (mf_dot(p, axis) < top) continue;
        double q[3] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; ++a) {
            s[a] += q[a];
            for (int b = 0; b < 3; ++b) ss[a][b] += q[a] * q[b];
        }
        ++k;
    }
    if (k < 3) return mf_fail(MF_EARG, "vessel: fewer than 3 vertices at the hull's top");
    gsl_matrix *cov = gsl_matrix_alloc(3, 3), *vec = gsl_matrix_alloc(3, 3);
    gsl_vector *val = gsl_vector_alloc(3);
    gsl_eigen_symmv_workspace *w = gsl_eigen_symmv_alloc(3);
    if (!cov || !vec || !val || !w) {
        gsl_matrix_free(cov), gsl_matrix_free(vec), gsl_vector_free(val), gsl_eigen_symmv_free(w);
        return mf_fail(MF_ENOMEM, "vessel: out of memory for the plane fit");
    }
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) gsl_matrix_set(cov, a, b, ss[a][b] / (double)k - s[a] * s[b] / ((double)k * (double)k));
    gsl_eigen_symmv(cov, val, vec, w);
    gsl_eigen_symmv_sort(val, vec, GSL_EIGEN_SORT_VAL_ASC);
    MfVec3 nn = mf_v3((float)gsl_matrix_get(vec, 0, 0), (float)gsl_matrix_get(vec, 1, 0), (float)gsl_matrix_get(vec, 2, 0));
    *normal = mf_dot(nn, axis) < 0 ? mf_scale(nn, -1.0f) : nn;
    gsl_matrix_free(cov), gsl_matrix_free(vec), gsl_vector_free(val), gsl_eigen_symmv_free(w);
    return MF_OK;
}

/* Cross-section of the inside vertices across axis, in cells: the distinct cells of their
 * projection onto the plane through the origin perpendicular to axis. */
static size_t cross_section(const MfTetGrid *g, const float *field, MfVec3 axis) {
    MfVec3 u = fabsf(axis.x) < 0.9f ? mf_v3(1, 0, 0) : mf_v3(0, 1, 0);
    u = mf_norm(mf_cross(axis, u));
    MfVec3 v = mf_cross(axis, u);
    size_t m = 4 * ((size_t)g->res + 1), nv = mf_tetgrid_nverts(g), area = 0;
    uint8_t *seen = calloc(m * m, 1);
    if (!seen) return 0;
    float half = 0.5f * g->cell * (float)m;
    MfVec3 centre = mf_add(g->lo, mf_v3s(0.5f * g->cell * (float)g->res));
    for (size_t i = 0; i < nv; ++i) {
        if (!(field[i] > 0)) continue;
        MfVec3 p = mf_sub(mf_tetgrid_base(g, i), centre);
        long a = lroundf((mf_dot(p, u) + half) / g->cell), b = lroundf((mf_dot(p, v) + half) / g->cell);
        if (a < 0 || b < 0 || (size_t)a >= m || (size_t)b >= m) continue;
        if (!seen[a * m + b]) seen[a * m + b] = 1, ++area;
    }
    free(seen);
    return area;
}

int mf_vessel_axis(const MfTetGrid *g, const float *field, const MfCamera *cams, int n, MfVesselAxis *out) {
    *out = (MfVesselAxis){0};
    size_t nv = mf_tetgrid_nverts(g), k = 0;
    MfVec3 c = mf_v3(0, 0, 0);
    for (size_t i = 0; i < nv; ++i)
        if (field[i] > 0) c = mf_add(c, mf_tetgrid_base(g, i)), ++k;
    if (!k) return mf_fail(MF_EARG, "vessel: the hull is empty");
    c = mf_scale(c, 1.0f / (float)k);
    MfVec3 m = mf_v3(0, 0, 0);
    for (int i = 0; i < n; ++i) m = mf_add(m, mf_norm(mf_sub(mf_camera_pos(&cams[i]), c)));
    /* cameras all round (a sphere of views): no side to look into */
    if (n < 1 || mf_len(m) < 0.2f * (float)n) return MF_OK;
    MfVec3 d0 = mf_norm(m), axis = d0;
    /* refit until the axis settles: a tilted cap's top layer along d0 holds a part of its rim */
    for (int it = 0; it < 10; ++it) {
        MfVec3 prev = axis;
        int rc = fit_cap(g, field, prev, &axis);
        if (rc) return rc;
        if (mf_dot(axis, prev) > cosf(0.1f * MF_PI / 180.0f)) break;
    }
    out->axis = axis;
    out->tilt_deg = acosf(fminf(1.0f, mf_dot(axis, d0))) * 180.0f / MF_PI;
    /* the cap's area: its top layer's boundary vertices, against the hull's cross-section */
    float top = top_height(g, field, axis) - 1.5f * g->cell;
    size_t layer = 0, nn = (size_t)g->res + 1;
    for (size_t i = 0; i < nv; ++i)
        if (field[i] > 0 && mf_dot(mf_tetgrid_base(g, i), axis) >= top && on_boundary(field, i, nn)) ++layer;
    size_t xs = cross_section(g, field, axis);
    out->cap_frac = xs ? (float)layer / (float)xs : 0.0f;
    out->candidate = out->cap_frac >= MF_VESSEL_MIN_CAP && out->tilt_deg <= MF_VESSEL_MAX_TILT_DEG;
    return MF_OK;
}

int mf_vessel_open(const MfTetGrid *g, float *field, const MfCamera *cams, int n, float wall_frac, MfVesselAxis *axis, size_t *carved) {
    if (carved) *carved = 0;
    int rc = mf_vessel_axis(g, field, cams, n, axis);
    if (rc || !axis->candidate) return rc;
    if (!(wall_frac > 0)) return mf_fail(MF_EARG, "vessel: wall thickness %g must be > 0", wall_frac);
    return mf_vessel_carve(g, field, axis->axis, mf_vessel_wall_cells(g, field, wall_frac, MF_VESSEL_MIN_CELLS), carved);
}
