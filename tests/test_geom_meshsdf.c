/* mf_meshsdf: a closed mesh's signed distance on a tet grid (DMTet's start from the hull mesh). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "geom/mf_meshsdf.h"
#include "geom/mf_tetgrid.h"
#include "mf_test.h"

/* Exact SDFs (> 0 inside): a sphere of radius 0.3, and a torus about z (radii 0.3, 0.12), whose
 * hole tests the sign where the nearest surface faces inwards. */
static float shape_sdf(int torus, MfVec3 p) {
    if (!torus) return 0.3f - mf_len(p);
    float q = sqrtf(p.x * p.x + p.y * p.y) - 0.3f;
    return 0.12f - sqrtf(q * q + p.z * p.z);
}

/* shape's mesh, by marching tets of its exact SDF on a fine grid */
static void shape_mesh(int torus, MfMesh *out) {
    MfTetGrid g = mf_tetgrid_make(48, mf_v3s(0), 1.0f);
    size_t nv = mf_tetgrid_nverts(&g);
    float *f = malloc(nv * sizeof *f);
    for (size_t v = 0; v < nv; ++v) f[v] = shape_sdf(torus, mf_tetgrid_base(&g, v));
    MfTetMesh m = {0};
    CHECK_OK(mf_tetgrid_extract(&g, f, NULL, &m));
    *out = m.mesh;
    m.mesh = (MfMesh){0};
    mf_tetmesh_free(&m);
    free(f);
}

MF_TEST(geom_meshsdf_sphere_torus) {
    const float band = 3.0f;
    for (int torus = 0; torus < 2; ++torus) {
        MfMesh mesh = {0};
        shape_mesh(torus, &mesh);
        MfTetGrid g = mf_tetgrid_make(24, mf_v3s(0), 1.0f);
        size_t nv = mf_tetgrid_nverts(&g);
        float *sign = malloc(nv * sizeof *sign), *sdf = malloc(nv * sizeof *sdf), *sdf1 = malloc(nv * sizeof *sdf1);
        /* the far field's sign is an inflated shape's, so a sign inside the band can only come from the mesh */
        for (size_t v = 0; v < nv; ++v) sign[v] = shape_sdf(torus, mf_tetgrid_base(&g, v)) + g.cell;
        CHECK_OK(mf_meshsdf_grid(&g, &mesh, sign, band, sdf));
        /* within the band the mesh's distance, beyond it the clamp with the far field's sign; the
         * 96^3 mesh lies within ~0.002 of the exact surface (a 32^3 cell is 0.031) */
        double worst = 0;
        int wrong_sign = 0, wrong_far = 0, in_band = 0;
        for (size_t v = 0; v < nv; ++v) {
            float e = shape_sdf(torus, mf_tetgrid_base(&g, v));
            if (fabsf(e) < (band - 0.5f) * g.cell) {
                worst = fmax(worst, fabs(sdf[v] - e)), ++in_band;
                wrong_sign += fabsf(e) > 0.005f && (sdf[v] > 0) != (e > 0);
            } else if (fabsf(e) > (band + 1.5f) * g.cell)
                wrong_far += sdf[v] != (e > 0 ? band * g.cell : -band * g.cell);
        }
        CHECK_MSG(in_band > 1000 && worst < 0.004, "%s: %d vertices in the band, worst |sdf - exact| %g", torus ? "torus" : "sphere",
                  in_band, worst);
        CHECK_MSG(wrong_sign == 0 && wrong_far == 0, "%s: %d wrong signs, %d wrong clamps", torus ? "torus" : "sphere", wrong_sign,
                  wrong_far);
        /* marching tets on it places the surface to a small fraction of a cell */
        MfTetMesh m = {0};
        CHECK_OK(mf_tetgrid_extract(&g, sdf, NULL, &m));
        double far = 0;
        for (int o = 0; o < m.mesh.nv; ++o)
            far = fmax(far, fabs(shape_sdf(torus, mf_v3(m.mesh.pos[3 * o], m.mesh.pos[3 * o + 1], m.mesh.pos[3 * o + 2]))));
        if (getenv("MF_TEST_VERBOSE"))
            printf("    %s: |sdf - exact| <= %.5f in the band, extracted vertices <= %.5f from the surface\n", torus ? "torus" : "sphere",
                   worst, far);
        CHECK_MSG(far < 0.2 * g.cell, "%s: extracted vertex %g from the surface (cell %g)", torus ? "torus" : "sphere", far, g.cell);
        mf_tetmesh_free(&m);
        /* the same bytes on one thread */
        int threads = omp_get_max_threads();
        omp_set_num_threads(1);
        CHECK_OK(mf_meshsdf_grid(&g, &mesh, sign, band, sdf1));
        omp_set_num_threads(threads);
        CHECK(memcmp(sdf, sdf1, nv * sizeof *sdf) == 0);
        free(sign), free(sdf), free(sdf1);
        mf_mesh_free(&mesh);
    }
    /* refusals */
    MfTetGrid g = mf_tetgrid_make(4, mf_v3s(0), 1.0f);
    float f[125] = {0}, out[125];
    MfMesh empty = {0}, sphere = {0};
    CHECK(mf_meshsdf_grid(&g, &empty, f, 3.0f, out) == MF_EARG);
    shape_mesh(0, &sphere);
    CHECK(mf_meshsdf_grid(&g, &sphere, f, 0.0f, out) == MF_EARG);
    mf_mesh_free(&sphere);
}
