/* Smoothed shading normals (mf_mesh_smooth_normals, scene/mf_mesh.h): the adjoint, through
 * mf_mesh_normals_backward, against central differences of a linear functional of the smoothed
 * normals in the vertex positions; creases beyond the threshold stay sharp; bad thresholds are
 * refused. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "scene/mf_mesh.h"
#include "scene/mf_shapes.h"
#include "mf_test.h"
#include "mf_test_grad.h"

enum { ITERS = 3 };

typedef struct {
    MfMesh m;
    float w[4096]; /* (nv, 3) the functional's weights */
    float min_cos;
} Ctx;

/* sum of w . (the area-weighted normals smoothed ITERS times) at the current positions */
static double loss(void *p) {
    Ctx *c = p;
    if (mf_mesh_compute_normals(&c->m) || mf_mesh_smooth_normals(&c->m, ITERS, c->min_cos, NULL)) return NAN;
    double s = 0;
    for (int i = 0; i < 3 * c->m.nv; ++i) s += (double)c->w[i] * c->m.nrm[i];
    return s;
}

/* a bumpy UV sphere (the bump a function of position, so neighbouring normals differ by a few
 * degrees) with random weights */
static int bumpy(Ctx *c, uint64_t seed) {
    int rc = mf_shape_uv_sphere(&c->m, mf_v3(0, 0, 0), 0.5f, 16, 8);
    if (rc) return rc;
    if (3 * c->m.nv > (int)(sizeof c->w / sizeof c->w[0])) return mf_fail(MF_EARG, "test mesh too large");
    MfRng r;
    mf_rng_seed(&r, seed, 0);
    for (int v = 0; v < c->m.nv; ++v) {
        float *p = c->m.pos + 3 * v, f = 1.0f + 0.05f * sinf(7.0f * p[0]) * cosf(5.0f * p[1] + 0.5f) * sinf(6.0f * p[2] + 1.0f);
        for (int k = 0; k < 3; ++k) p[k] *= f;
        for (int k = 0; k < 3; ++k) c->w[3 * v + k] = 2.0f * mf_rng_float(&r) - 1.0f;
    }
    return MF_OK;
}

MF_TEST(scene_mesh_smooth_normals_adjoint) {
    /* min_cos 0: every neighbour counts, so no choice flips under the steps */
    for (int t = 0; t < 2; ++t) {
        Ctx c = {.min_cos = t ? 0.5f : 0.0f};
        CHECK_OK(bumpy(&c, 11 + t));
        if (!c.m.pos) return;
        CHECK_OK(mf_mesh_compute_normals(&c.m));
        float *hist = malloc(sizeof(float) * ITERS * 3 * (size_t)c.m.nv), *dn = calloc(3 * (size_t)c.m.nv, sizeof(float)),
              *dp = calloc(3 * (size_t)c.m.nv, sizeof(float));
        CHECK_OK(mf_mesh_smooth_normals(&c.m, ITERS, c.min_cos, hist));
        memcpy(dn, c.w, sizeof(float) * 3 * (size_t)c.m.nv);
        CHECK_OK(mf_mesh_smooth_normals_backward(&c.m, ITERS, c.min_cos, hist, dn));
        CHECK_OK(mf_mesh_normals_backward(&c.m, dn, dp));
        MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = loss, .ctx = &c, .p = c.m.pos, .g = dp, .n = 3 * (size_t)c.m.nv,
                                                      .eps = 1e-3, .step = MF_FD_ROUNDED, .atol = 2e-2, .rtol = 2e-3,
                                                      .form = MF_ERR_SUM, .what = "dpos"});
        if (getenv("MF_TEST_VERBOSE"))
            printf("    min_cos %.1f: %d entries, worst error %.3f at %ld (fd %.5g, adjoint %.5g; largest |fd| %.3g)\n",
                   (double)c.min_cos, r.checked, r.worst, r.at, r.fd, r.g, r.fd_max);
        CHECK_MSG(r.checked == 3 * c.m.nv && r.off == 0, "min_cos %g: %d of %d position entries off (worst %.3g)", (double)c.min_cos,
                  r.off, r.checked, r.worst);
        free(hist), free(dn), free(dp);
        mf_mesh_free(&c.m);
    }
}

MF_TEST(scene_mesh_smooth_normals_creases) {
    /* an open box corner: three unit squares at right angles, one vertex per face corner welded
     * along the shared edges; at min_cos cos(15 deg) the faces never mix, at 0 they do */
    static const float P[7][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 1}, {1, 0, 1}};
    static const uint32_t T[6][3] = {{0, 2, 1}, {1, 2, 4}, {0, 1, 3}, {1, 6, 3}, {0, 3, 2}, {2, 3, 5}};
    MfMesh m;
    CHECK_OK(mf_mesh_alloc(&m, 7, 6, 1, 0));
    if (!m.pos) return;
    memcpy(m.pos, P, sizeof P), memcpy(m.tri, T, sizeof T);
    CHECK_OK(mf_mesh_compute_normals(&m));
    float before[21];
    memcpy(before, m.nrm, sizeof before);
    CHECK_OK(mf_mesh_smooth_normals(&m, 5, 0.9659258f, NULL));
    double moved = 0;
    for (int i = 0; i < 21; ++i) moved = fmax(moved, fabs(m.nrm[i] - before[i]));
    CHECK_MSG(moved < 1e-6, "crease at 90 degrees smoothed with a 15-degree threshold: a normal moved by %g", moved);
    CHECK_OK(mf_mesh_smooth_normals(&m, 5, 0.0f, NULL));
    moved = 0;
    for (int i = 0; i < 21; ++i) moved = fmax(moved, fabs(m.nrm[i] - before[i]));
    CHECK_MSG(moved > 0.1, "with every neighbour kept the face normals should mix (largest move %g)", moved);
    CHECK_ERR(mf_mesh_smooth_normals(&m, 1, -0.5f, NULL), "outside [0, 1]");
    CHECK_ERR(mf_mesh_smooth_normals(&m, 1, NAN, NULL), "outside [0, 1]");
    free(m.nrm), m.nrm = NULL;
    CHECK_ERR(mf_mesh_smooth_normals(&m, 1, 0.5f, NULL), "has none");
    mf_mesh_free(&m);
}
