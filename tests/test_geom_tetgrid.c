/* mf_tetgrid (issue 14, T1): marching tets and their adjoint. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "eval/ev_geom.h"
#include "geom/mf_meshproc.h"
#include "geom/mf_tetgrid.h"
#include "geom/mf_vhull.h"
#include "mf_test.h"
#include "mf_test_grad.h"
#include "mf_test_geom.h"

/* ---- T1: marching tets ---------------------------------------------------------------- */

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* 1 when every directed edge occurs once and its reverse once (closed, consistently wound,
 * edge-manifold); *euler = V - E + F. */
static int watertight(const MfMesh *m, long *euler) {
    size_t ne = (size_t)m->nt * 3;
    uint64_t *d = malloc(ne * sizeof *d);
    for (int t = 0; t < m->nt; ++t)
        for (int e = 0; e < 3; ++e) d[3 * t + e] = (uint64_t)m->tri[3 * t + e] << 32 | m->tri[3 * t + (e + 1) % 3];
    qsort(d, ne, sizeof *d, cmp_u64);
    int ok = 1;
    for (size_t i = 0; i < ne && ok; ++i) {
        if (i + 1 < ne && d[i + 1] == d[i]) ok = 0;
        uint64_t r = d[i] << 32 | d[i] >> 32;
        if (!bsearch(&r, d, ne, sizeof *d, cmp_u64)) ok = 0;
    }
    free(d);
    *euler = (long)m->nv - (long)ne / 2 + (long)m->nt;
    return ok;
}


MF_TEST(geom_tetgrid_sphere_torus) {
    MfTetGrid g = mf_tetgrid_make(32, mf_v3s(0), 1.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    float *f = malloc(nv * sizeof *f);
    for (int shape = 0; shape < 2; ++shape) {
        for (size_t v = 0; v < nv; ++v) {
            MfVec3 p = mf_tetgrid_base(&g, v);
            if (shape == 0) f[v] = 0.35f - mf_len(p);
            else {
                float q = sqrtf(p.x * p.x + p.y * p.y) - 0.3f;
                f[v] = 0.1f - sqrtf(q * q + p.z * p.z);
            }
        }
        MfTetMesh m = {0};
        CHECK_OK(mf_tetgrid_extract(&g, f, NULL, &m));
        long euler = 99;
        CHECK_MSG(watertight(&m.mesh, &euler), "shape %d: not watertight", shape);
        CHECK_MSG(euler == (shape == 0 ? 2 : 0), "shape %d: Euler characteristic %ld", shape, euler);
        double vol = signed_volume(&m.mesh), ref = shape == 0 ? 4.0 / 3.0 * M_PI * pow(0.35, 3) : 2 * M_PI * M_PI * 0.3 * 0.01;
        CHECK_MSG(fabs(vol / ref - 1) < 0.05, "shape %d: volume %g, analytic %g (outward winding)", shape, vol, ref);
        for (int o = 0; o < m.mesh.nv; ++o) { /* vertices on the surface within a fifth of a cell */
            MfVec3 p = mf_v3(m.mesh.pos[3 * o], m.mesh.pos[3 * o + 1], m.mesh.pos[3 * o + 2]);
            float q = sqrtf(p.x * p.x + p.y * p.y) - 0.3f;
            float d = shape == 0 ? mf_len(p) - 0.35f : sqrtf(q * q + p.z * p.z) - 0.1f;
            if (fabsf(d) > 0.2f * g.cell) { CHECK_MSG(0, "shape %d: vertex %d off the surface by %g", shape, o, d); break; }
        }
        mf_tetmesh_free(&m);
    }
    /* empty and full grids: a status, and out untouched */
    for (size_t v = 0; v < nv; ++v) f[v] = -1;
    MfTetMesh m = {0};
    m.mesh.nv = -7;
    CHECK_ERR(mf_tetgrid_extract(&g, f, NULL, &m), "no zero crossing");
    for (size_t v = 0; v < nv; ++v) f[v] = 1;
    CHECK_ERR(mf_tetgrid_extract(&g, f, NULL, &m), "no zero crossing");
    CHECK(m.mesh.nv == -7 && m.mesh.pos == NULL);
    f[5] = NAN;
    CHECK_ERR(mf_tetgrid_extract(&g, f, NULL, &m), "not finite");
    free(f);
}

/* Output vertex position in double from the grid values (the reference for the adjoint). */
static void pos_d(const MfTetGrid *g, const double *f, const double *d, int a, int b, double p[3]) {
    double t = f[a] / (f[a] - f[b]), s = 0.5 * g->cell;
    MfVec3 ba = mf_tetgrid_base(g, (size_t)a), bb = mf_tetgrid_base(g, (size_t)b);
    double pa[3] = {ba.x, ba.y, ba.z}, pb[3] = {bb.x, bb.y, bb.z};
    for (int c = 0; c < 3; ++c) p[c] = (1 - t) * (pa[c] + s * tanh(d[3 * a + c])) + t * (pb[c] + s * tanh(d[3 * b + c]));
}

/* sum_o w_o . p_o over the output vertices of m, in double from the sdf f and deform d */
typedef struct {
    const MfTetGrid *g;
    const double *f, *d;
    const MfTetMesh *m;
    const float *w;
} PosCtx;

static double pos_loss(void *ctx) {
    const PosCtx *c = ctx;
    double l = 0;
    for (int o = 0; o < c->m->mesh.nv; ++o) {
        double p[3];
        pos_d(c->g, c->f, c->d, c->m->edge[2 * o], c->m->edge[2 * o + 1], p);
        for (int k = 0; k < 3; ++k) l += c->w[3 * o + k] * p[k];
    }
    return l;
}

MF_TEST(geom_tetgrid_adjoint) {
    MfTetGrid g = mf_tetgrid_make(6, mf_v3s(0), 1.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    MfRng rng;
    mf_rng_seed(&rng, 14, 1);
    float *f = malloc(nv * sizeof *f), *dfm = malloc(nv * 3 * sizeof *dfm);
    double *fd = malloc(nv * sizeof *fd), *dd = malloc(nv * 3 * sizeof *dd);
    for (size_t v = 0; v < nv; ++v) {
        f[v] = 0.3f - mf_len(mf_tetgrid_base(&g, v)) + 0.05f * (mf_rng_float(&rng) - 0.5f);
        for (int c = 0; c < 3; ++c) dfm[3 * v + c] = 2 * mf_rng_float(&rng) - 1;
    }
    for (size_t v = 0; v < nv; ++v) fd[v] = f[v];
    for (size_t v = 0; v < 3 * nv; ++v) dd[v] = dfm[v];
    MfTetMesh m = {0};
    CHECK_OK(mf_tetgrid_extract(&g, f, dfm, &m));
    int no = m.mesh.nv;
    float *w = malloc((size_t)no * 3 * sizeof *w), *gf = calloc(nv, sizeof *gf), *gd = calloc(nv * 3, sizeof *gd);
    for (int i = 0; i < 3 * no; ++i) w[i] = 2 * mf_rng_float(&rng) - 1;
    mf_tetgrid_backward(&g, f, dfm, &m, w, gf, gd);
    /* the double reference reproduces the forward */
    double maxd = 0;
    for (int o = 0; o < no; ++o) {
        double p[3];
        pos_d(&g, fd, dd, m.edge[2 * o], m.edge[2 * o + 1], p);
        for (int c = 0; c < 3; ++c) maxd = fmax(maxd, fabs(p[c] - m.mesh.pos[3 * o + c]));
    }
    CHECK_MSG(maxd < 1e-5, "forward vs double reference: %g", maxd);
    /* L = sum_o w_o . p_o; central differences in double of every sdf and deform entry */
    PosCtx c = {&g, fd, dd, &m, w};
    MfGradCheck gc = {.loss = pos_loss, .ctx = &c, .pd = fd, .g = gf, .n = nv, .eps = 1e-6, .atol = 1, .rtol = 1, .form = MF_ERR_MAX};
    double worst = mf_test_grad(&gc).worst;
    gc.pd = dd, gc.g = gd, gc.n = 3 * nv;
    worst = fmax(worst, mf_test_grad(&gc).worst);
    CHECK_MSG(worst < 1e-4, "adjoint vs central differences: worst %g", worst);
    free(f), free(dfm), free(fd), free(dd), free(w), free(gf), free(gd);
    mf_tetmesh_free(&m);
}

/* mf_tetgrid_sample: exact on a field linear in each axis (trilinear reproduces it), the grid
 * vertices' own values at vertices, `outside` beyond the grid (and on NaN coordinates). */
MF_TEST(geom_tetgrid_sample) {
    MfTetGrid g = mf_tetgrid_make(5, mf_v3(0.1f, -0.2f, 0.3f), 2.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    float *f = malloc(nv * sizeof *f);
    for (size_t v = 0; v < nv; ++v) {
        MfVec3 p = mf_tetgrid_base(&g, v);
        f[v] = 1 + 2 * p.x - 3 * p.y + 0.5f * p.z + p.x * p.y * p.z;
    }
    MfRng rng;
    mf_rng_seed(&rng, 7, 0);
    double worst = 0;
    for (int i = 0; i < 200; ++i) {
        MfVec3 p = mf_add(g.lo, mf_scale(mf_v3(mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng)), 2.0f));
        double want = 1 + 2 * p.x - 3 * p.y + 0.5 * p.z + (double)p.x * p.y * p.z;
        worst = fmax(worst, fabs(mf_tetgrid_sample(&g, f, p, -9) - want));
    }
    CHECK_MSG(worst < 1e-5, "trilinear of a trilinear field off by %g", worst);
    CHECK(mf_tetgrid_sample(&g, f, mf_tetgrid_base(&g, nv - 1), -9) == f[nv - 1]);
    CHECK(mf_tetgrid_sample(&g, f, mf_tetgrid_base(&g, 0), -9) == f[0]);
    CHECK(mf_tetgrid_sample(&g, f, mf_v3(g.lo.x - 0.01f, 0, 0.5f), -9) == -9);
    CHECK(mf_tetgrid_sample(&g, f, mf_v3(0.5f, 0, g.lo.z + 2.01f), -9) == -9);
    CHECK(mf_tetgrid_sample(&g, f, mf_v3(NAN, 0, 0.5f), -9) == -9);
    free(f);
}
