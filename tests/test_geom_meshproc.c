/* mf_meshproc: welding, clean-up, smoothing and decimation. */
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
#include "mf_test_geom.h"

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
