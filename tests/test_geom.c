/* Geometry recovery (issue 14): T1 marching tets, T5 visual hull. */
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

static double signed_volume(const MfMesh *m) {
    double v = 0;
    for (int t = 0; t < m->nt; ++t) {
        const float *a = m->pos + 3 * m->tri[3 * t], *b = m->pos + 3 * m->tri[3 * t + 1], *c = m->pos + 3 * m->tri[3 * t + 2];
        v += (a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
              a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0])) / 6.0;
    }
    return v;
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
    double worst = 0;
    for (int which = 0; which < 2; ++which)
        for (size_t i = 0; i < (which ? 3 * nv : nv); ++i) {
            double *x = which ? dd : fd, x0 = x[i], h = 1e-6, l[2];
            for (int sgn = 0; sgn < 2; ++sgn) {
                x[i] = x0 + (sgn ? -h : h);
                l[sgn] = 0;
                for (int o = 0; o < no; ++o) {
                    double p[3];
                    pos_d(&g, fd, dd, m.edge[2 * o], m.edge[2 * o + 1], p);
                    for (int c = 0; c < 3; ++c) l[sgn] += w[3 * o + c] * p[c];
                }
            }
            x[i] = x0;
            double num = (l[0] - l[1]) / (2 * h), ad = which ? gd[i] : gf[i];
            worst = fmax(worst, fabs(num - ad) / fmax(1.0, fabs(num)));
        }
    CHECK_MSG(worst < 1e-4, "adjoint vs central differences: worst %g", worst);
    free(f), free(dfm), free(fd), free(dd), free(w), free(gf), free(gd);
    mf_tetmesh_free(&m);
}

/* ---- T5: visual hull ------------------------------------------------------------------- */

enum { HW = 96 };

/* Signed distance to the test shape (negative inside): 0 sphere r 0.35, 1 box half-size
 * (0.3, 0.2, 0.25). */
static float shape_sd(int shape, MfVec3 p) {
    if (shape == 0) return mf_len(p) - 0.35f;
    MfVec3 q = mf_v3(fabsf(p.x) - 0.3f, fabsf(p.y) - 0.2f, fabsf(p.z) - 0.25f);
    MfVec3 qp = mf_v3(fmaxf(q.x, 0), fmaxf(q.y, 0), fmaxf(q.z, 0));
    return mf_len(qp) + fminf(mf_maxc(q), 0);
}

/* Mask of the shape in cam: 4x4 supersampled coverage by sphere tracing. */
static void render_mask(int shape, const MfCamera *cam, MfImage *m) {
    mf_image_alloc(m, cam->w, cam->h, 1);
    for (int y = 0; y < cam->h; ++y)
        for (int x = 0; x < cam->w; ++x) {
            int hit = 0;
            for (int s = 0; s < 16; ++s) {
                MfVec3 o, d;
                mf_camera_ray(cam, (float)x + ((float)(s & 3) + 0.5f) / 4, (float)y + ((float)(s >> 2) + 0.5f) / 4, &o, &d);
                float t = 0;
                for (int it = 0; it < 200 && t < 10; ++it) {
                    float sd = shape_sd(shape, mf_madd(o, d, t));
                    if (sd < 1e-5f) { ++hit; break; }
                    t += sd;
                }
            }
            m->data[(size_t)y * cam->w + x] = (float)hit / 16;
        }
}

static void look_cam(MfCamera *cam, MfVec3 eye, MfVec3 target) {
    MfMat4 c2w = mf_mat4_look_at(eye, target, mf_v3(0, 0, 1));
    double m[16];
    for (int i = 0; i < 16; ++i) m[i] = c2w.m[i];
    mf_camera_init(cam, HW, HW, 0.6911, m, "test");
}

MF_TEST(geom_vhull_sphere_box_cut) {
    enum { NV = 64 };
    MfCamera cams[NV + 1];
    MfImage masks[NV + 1];
    for (int shape = 0; shape < 2; ++shape) {
        for (int v = 0; v < NV; ++v) { /* Fibonacci sphere of directions at distance 2.5 */
            float z = 1 - (2 * (float)v + 1) / NV, r = sqrtf(1 - z * z), phi = (float)v * 2.39996323f;
            look_cam(&cams[v], mf_scale(mf_v3(r * cosf(phi), r * sinf(phi), z), 2.5f), mf_v3s(0));
            render_mask(shape, &cams[v], &masks[v]);
        }
        /* a cut view: close up, seeing only the shape's +x part */
        look_cam(&cams[NV], mf_v3(0.35f, -1.2f, 0.1f), mf_v3(0.35f, 0, 0));
        render_mask(shape, &cams[NV], &masks[NV]);
        MfTetGrid g = mf_tetgrid_make(48, mf_v3s(0), 1.0f);
        size_t nv = mf_tetgrid_nverts(&g);
        float *f = malloc(nv * sizeof *f), *fc = malloc(nv * sizeof *fc);
        CHECK_OK(mf_vhull(&g, cams, masks, NV, f));
        MfTetMesh m = {0};
        CHECK_OK(mf_tetgrid_extract(&g, f, NULL, &m));
        double worst = 0;
        for (int o = 0; o < m.mesh.nv; ++o)
            worst = fmax(worst, fabs(shape_sd(shape, mf_v3(m.mesh.pos[3 * o], m.mesh.pos[3 * o + 1], m.mesh.pos[3 * o + 2]))));
        CHECK_MSG(worst <= g.cell, "shape %d: hull vertex %g from the surface, a voxel is %g", shape, worst, g.cell);
        int missed = 0; /* nothing inside the shape carved */
        for (size_t v = 0; v < nv; ++v) missed += shape_sd(shape, mf_tetgrid_base(&g, v)) < -g.cell && !(f[v] > 0);
        CHECK_MSG(missed == 0, "shape %d: %d inner vertices carved", shape, missed);
        /* the cut view alone carves nothing inside the shape */
        CHECK_OK(mf_vhull(&g, &cams[NV], &masks[NV], 1, fc));
        int carved = 0, seen_out = 0;
        for (size_t v = 0; v < nv; ++v) {
            MfVec3 p = mf_tetgrid_base(&g, v);
            float px, py;
            int in_frame = mf_camera_project(&cams[NV], p, &px, &py) && px >= 0 && py >= 0 && px <= HW && py <= HW;
            carved += shape_sd(shape, p) < -g.cell && !(fc[v] > 0);
            seen_out += !in_frame && shape_sd(shape, p) < 0;
        }
        CHECK_MSG(seen_out > 1000, "shape %d: the cut view sees the whole shape (%d inner vertices out of frame)", shape, seen_out);
        CHECK_MSG(carved == 0, "shape %d: the cut view carves %d inner vertices", shape, carved);
        if (shape == 0) { /* the whole pipeline: a closed, smoothed, decimated hull */
            MfHullOpts ho = {48, 1.0f, 10, 2000, 0.01f};
            MfMesh hm = {0};
            MfHullInfo hi;
            MfManifoldInfo mi;
            CHECK_OK(mf_vhull_mesh(cams, masks, NV, &ho, &hm, &hi));
            CHECK_OK(mf_mesh_manifold_check(&hm, &mi));
            CHECK_MSG(hm.nt <= 2000 && mf_manifold_ok(&mi) && mi.euler == 2 && hi.masked_views == NV && !hi.touches_border,
                      "hull mesh: %d triangles, manifold %d, euler %ld", hm.nt, mf_manifold_ok(&mi), mi.euler);
            mf_mesh_free(&hm);
            /* views without masks (alpha all 1) are refused */
            for (int v = 0; v < NV; ++v)
                for (int p = 0; p < HW * HW; ++p) masks[v].data[p] = 1;
            CHECK_ERR(mf_vhull_mesh(cams, masks, NV, &ho, &hm, &hi), "need at least 3");
        }
        mf_tetmesh_free(&m);
        free(f), free(fc);
        for (int v = 0; v <= NV; ++v) mf_image_free(&masks[v]);
    }
    /* a mask of the wrong size is refused, naming the view */
    MfImage bad = {0};
    mf_image_alloc(&bad, 8, 8, 1);
    MfTetGrid g = mf_tetgrid_make(4, mf_v3s(0), 1.0f);
    float f[125];
    CHECK_ERR(mf_vhull(&g, cams, &bad, 1, f), "view 0");
    mf_image_free(&bad);
}

/* ---- mesh clean-up ----------------------------------------------------------------------- */

/* The sphere of radius r extracted at res cubes (a closed mesh for the clean-up tests). */
static void sphere_mesh(int res, float r, MfMesh *out) {
    MfTetGrid g = mf_tetgrid_make(res, mf_v3s(0), 1.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    float *f = malloc(nv * sizeof *f);
    for (size_t v = 0; v < nv; ++v) f[v] = r - mf_len(mf_tetgrid_base(&g, v));
    MfTetMesh m = {0};
    CHECK_OK(mf_tetgrid_extract(&g, f, NULL, &m));
    *out = m.mesh;
    m.mesh = (MfMesh){0};
    mf_tetmesh_free(&m);
    free(f);
}

static void radius_stats(const MfMesh *m, double *mean, double *sd) {
    double s = 0, s2 = 0;
    for (int v = 0; v < m->nv; ++v) {
        double r = mf_len(mf_v3(m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2]));
        s += r, s2 += r * r;
    }
    *mean = s / m->nv;
    *sd = sqrt(fmax(0, s2 / m->nv - *mean * *mean));
}

MF_TEST(geom_meshproc) {
    /* weld: a cube of 6 separate quads (24 vertices) becomes one closed mesh of 8 */
    MfMesh c = {0};
    mf_mesh_alloc(&c, 24, 12, 0, 0);
    static const int F[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (int f = 0; f < 6; ++f) {
        for (int k = 0; k < 4; ++k)
            for (int a = 0; a < 3; ++a) c.pos[3 * (4 * f + k) + a] = (float)(F[f][k] >> a & 1) + 1e-5f * (float)f;
        uint32_t b = (uint32_t)(4 * f);
        uint32_t t[6] = {b, b + 1, b + 2, b, b + 2, b + 3};
        memcpy(c.tri + 6 * f, t, sizeof t);
    }
    MfManifoldInfo mi;
    CHECK_OK(mf_mesh_manifold_check(&c, &mi));
    CHECK(mi.boundary_edges == 24 && mi.components == 6);
    CHECK_OK(mf_mesh_weld(&c, 1e-3f));
    CHECK_OK(mf_mesh_manifold_check(&c, &mi));
    CHECK_MSG(c.nv == 8 && mf_manifold_ok(&mi) && mi.euler == 2 && mi.components == 1,
              "welded cube: nv %d, boundary %d, non-manifold %d, misoriented %d, euler %ld", c.nv, mi.boundary_edges,
              mi.nonmanifold_edges, mi.misoriented_edges, mi.euler);
    CHECK_MSG(signed_volume(&c) > 0.99, "welded cube volume %g", signed_volume(&c));
    /* a flipped triangle and a repeated one are found */
    uint32_t x = c.tri[1]; c.tri[1] = c.tri[2]; c.tri[2] = x;
    CHECK_OK(mf_mesh_manifold_check(&c, &mi));
    CHECK(mi.misoriented_edges >= 1);
    c.tri[2] = c.tri[1], c.tri[1] = x;
    /* degenerate triangles (repeated vertex, zero area) are dropped */
    MfMesh d = {0};
    mf_mesh_alloc(&d, 9, 14, 0, 0);
    memcpy(d.pos, c.pos, 24 * sizeof(float));
    for (int a = 0; a < 3; ++a) d.pos[24 + a] = 0.5f * (c.pos[a] + c.pos[3 + a]); /* vertex 8 halfway from 0 to 1 */
    memcpy(d.tri, c.tri, 36 * sizeof(uint32_t));
    uint32_t extra[6] = {0, 0, 3, 0, 8, 1};
    memcpy(d.tri + 36, extra, sizeof extra);
    CHECK_OK(mf_mesh_drop_degenerate(&d, 1e-9f));
    CHECK_MSG(d.nt == 12 && d.nv == 8, "after degenerate clean-up: %d triangles, %d vertices", d.nt, d.nv);
    mf_mesh_free(&d);
    /* a floater far smaller than the main body goes */
    MfMesh s = {0};
    sphere_mesh(24, 0.3f, &s);
    int nt0 = s.nt, ndrop = -1;
    CHECK_OK(mf_mesh_append(&s, &c));
    CHECK_OK(mf_mesh_drop_small_components(&s, 0.05f, &ndrop));
    CHECK_MSG(s.nt == nt0 && ndrop == 1, "component clean-up: %d of %d triangles kept, %d dropped", s.nt, nt0, ndrop);
    mf_mesh_free(&c);
    /* Taubin smoothing: a noisy sphere gets smoother without shrinking */
    MfRng rng;
    mf_rng_seed(&rng, 3, 1);
    for (int v = 0; v < s.nv; ++v)
        for (int a = 0; a < 3; ++a) s.pos[3 * v + a] += 0.01f * (mf_rng_float(&rng) - 0.5f);
    double m0, sd0, m1, sd1;
    radius_stats(&s, &m0, &sd0);
    CHECK_OK(mf_mesh_taubin(&s, 10, 0.5f, -0.53f));
    radius_stats(&s, &m1, &sd1);
    CHECK_MSG(sd1 < 0.5 * sd0 && fabs(m1 / m0 - 1) < 0.01, "Taubin: radius %g +- %g -> %g +- %g", m0, sd0, m1, sd1);
    /* decimation: fewer triangles, still closed, still on the sphere */
    mf_mesh_free(&s);
    sphere_mesh(48, 0.3f, &s);
    CHECK_OK(mf_mesh_weld(&s, 1e-6f));
    CHECK_OK(mf_mesh_drop_degenerate(&s, 0));
    CHECK_OK(mf_mesh_decimate(&s, 2000, 0.01f));
    CHECK_OK(mf_mesh_manifold_check(&s, &mi));
    radius_stats(&s, &m1, &sd1);
    CHECK_MSG(s.nt <= 2000 && s.nt > 1000 && mf_manifold_ok(&mi) && mi.euler == 2 && fabs(m1 - 0.3) < 0.005,
              "decimated: %d triangles, manifold %d, euler %ld, radius %g +- %g", s.nt, mf_manifold_ok(&mi), mi.euler, m1, sd1);
    mf_mesh_free(&s);
}

/* ---- T7: Chamfer ----------------------------------------------------------------------- */

MF_TEST(geom_chamfer) {
    /* nearest neighbours match brute force */
    enum { NP = 700, NQ = 500 };
    float *p = malloc(NP * 3 * sizeof *p), *q = malloc(NQ * 3 * sizeof *q);
    MfRng rng;
    mf_rng_seed(&rng, 7, 1);
    for (int i = 0; i < NP * 3; ++i) p[i] = mf_rng_float(&rng) * (i % 3 == 2 ? 0.1f : 1.0f);
    for (int i = 0; i < NQ * 3; ++i) q[i] = 1.2f * mf_rng_float(&rng) - 0.1f;
    int nn[NQ];
    double d2[NQ];
    CHECK_OK(ev_nearest(p, NP, q, NQ, nn, d2));
    int bad = 0;
    for (int k = 0; k < NQ; ++k) {
        double best = INFINITY;
        for (int i = 0; i < NP; ++i) {
            double dx = (double)p[3 * i] - q[3 * k], dy = (double)p[3 * i + 1] - q[3 * k + 1], dz = (double)p[3 * i + 2] - q[3 * k + 2];
            best = fmin(best, dx * dx + dy * dy + dz * dz);
        }
        bad += d2[k] != best;
    }
    CHECK_MSG(bad == 0, "kd-tree: %d of %d nearest distances differ from brute force", bad, NQ);
    free(p), free(q);
    /* concentric spheres of radius r and r + eps: Chamfer = eps^2 x 1e3, normals agree */
    MfMesh a = {0}, b = {0};
    CHECK_OK(mf_mesh_uv_sphere(&a, 256, 128, mf_v3s(0), 0.4f));
    CHECK_OK(mf_mesh_uv_sphere(&b, 256, 128, mf_v3s(0), 0.45f));
    EvGeomScore s;
    CHECK_OK(ev_geom_score(&a, &b, 30000, 1, &s));
    double ref = 1e3 * 0.05 * 0.05;
    CHECK_MSG(fabs(s.chamfer / ref - 1) < 0.05 && fabs(s.gt_to_pred / ref - 1) < 0.05 && fabs(s.pred_to_gt / ref - 1) < 0.05,
              "spheres: Chamfer %g (%g, %g), analytic %g", s.chamfer, s.gt_to_pred, s.pred_to_gt, ref);
    CHECK_MSG(s.normal_deg < 3 && s.normal_1mcos < 2e-3, "spheres: normal error %g deg, 1-cos %g", s.normal_deg, s.normal_1mcos);
    CHECK_OK(ev_geom_score(&a, &a, 30000, 1, &s));
    CHECK_MSG(s.chamfer < 0.1 * ref, "a sphere against itself: Chamfer %g", s.chamfer);
    /* image-space normals and mask IoU: a sphere against itself and a larger one */
    MfCamera cam;
    look_cam(&cam, mf_v3(0, -2.5f, 0.3f), mf_v3s(0));
    EvGeomViews gv;
    CHECK_OK(ev_geom_views(&a, &a, &cam, 1, &gv));
    CHECK_MSG(gv.normal_deg < 0.05 && gv.mask_iou == 1, "sphere vs itself: %g deg, IoU %g", gv.normal_deg, gv.mask_iou);
    CHECK_OK(ev_geom_views(&a, &b, &cam, 1, &gv));
    double iou = 0.4 * 0.4 / (0.45 * 0.45); /* silhouette areas, to first order in the view angle */
    CHECK_MSG(fabs(gv.mask_iou - iou) < 0.03 && gv.normal_deg > 0.5 && gv.normal_deg < 10,
              "spheres 0.4 vs 0.45: IoU %g (about %g), normals %g deg", gv.mask_iou, iou, gv.normal_deg);
    MfMesh e = {0};
    CHECK_ERR(ev_geom_score(&a, &e, 30000, 1, &s), "empty");
    mf_mesh_free(&a), mf_mesh_free(&b);
}

/* ---- mf hull: bad input ------------------------------------------------------------------ */

MF_TEST(geom_hull_cli_bad_input) {
    char err[4096];
    int rc = mf_test_run_mf("hull /nonexistent/scene -o /dev/null", NULL, err, sizeof err);
    CHECK_MSG(rc == 1 && strstr(err, "/nonexistent/scene"), "missing data: exit %d, '%s'", rc, err);
    rc = mf_test_run_mf("hull /nonexistent/scene", NULL, err, sizeof err);
    CHECK_MSG(rc == 2 && strstr(err, "-o OUT.obj"), "missing -o: exit %d, '%s'", rc, err);
    rc = mf_test_run_mf("hull /nonexistent/scene -o x.obj --res 1", NULL, err, sizeof err);
    CHECK_MSG(rc == 2 && strstr(err, "res"), "--res 1: exit %d, '%s'", rc, err);
}
