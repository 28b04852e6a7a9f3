/* Tests of eval/ev_geom (issue 14, T7): nearest neighbours, Chamfer and normal errors against closed forms. */
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

enum { HW = 96 };

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
    look_cam(&cam, HW, HW, mf_v3(0, -2.5f, 0.3f), mf_v3s(0));
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

/* Squared distance between point i of a (n, 3) and point j of b. */
static double d2_at(const float *a, int i, const float *b, int j) {
    double dx = (double)a[3 * i] - b[3 * j], dy = (double)a[3 * i + 1] - b[3 * j + 1], dz = (double)a[3 * i + 2] - b[3 * j + 2];
    return dx * dx + dy * dy + dz * dz;
}

/* The uniform Chamfer variant: GT area samples against prediction area samples. */
MF_TEST(geom_chamfer_uniform) {
    /* brute force on a small case: two coarse spheres, off-centre, 400 samples each, redrawn
     * here with the streams ev_geom_score uses */
    enum { NS = 400 };
    MfMesh g = {0}, p = {0};
    CHECK_OK(mf_mesh_uv_sphere(&g, 12, 6, mf_v3s(0), 0.4f));
    CHECK_OK(mf_mesh_uv_sphere(&p, 10, 5, mf_v3(0.05f, -0.02f, 0.1f), 0.5f));
    EvGeomScore s, s2;
    CHECK_OK(ev_geom_score(&g, &p, NS, 3, &s));
    CHECK_OK(ev_geom_score(&g, &p, NS, 3, &s2));
    CHECK_MSG(s.chamfer_uniform == s2.chamfer_uniform && s.chamfer == s2.chamfer, "not deterministic: %.17g vs %.17g",
              s.chamfer_uniform, s2.chamfer_uniform);
    float *gp = malloc(NS * 3 * sizeof *gp), *pp = malloc(NS * 3 * sizeof *pp);
    CHECK_OK(ev_geom_sample(&g, NS, 3, EV_GEOM_STREAM_GT, gp, NULL));
    CHECK_OK(ev_geom_sample(&p, NS, 3, EV_GEOM_STREAM_PRED, pp, NULL));
    double sg = 0, sp = 0;
    for (int i = 0; i < NS; ++i) {
        double bg = INFINITY, bp = INFINITY;
        for (int j = 0; j < NS; ++j) bg = fmin(bg, d2_at(gp, i, pp, j)), bp = fmin(bp, d2_at(pp, i, gp, j));
        sg += bg, sp += bp;
    }
    double brute = 1e3 * 0.5 * (sg / NS + sp / NS);
    printf("    small case: uniform Chamfer %.9g, brute force %.9g (vertex Chamfer %.6g)\n", s.chamfer_uniform, brute, s.chamfer);
    CHECK_MSG(fabs(s.chamfer_uniform - brute) <= 1e-12 * brute, "uniform Chamfer %.17g, brute force %.17g", s.chamfer_uniform, brute);
    free(gp), free(pp);
    mf_mesh_free(&g), mf_mesh_free(&p);
    /* concentric spheres r = 0.4, R = 0.45 (30000 samples each). For a point on one sphere the
     * squared distance to a sample on the other at angle t is eps^2 + 2 r R (1 - cos t) ~ eps^2 +
     * r R t^2; the nearest of N samples spread uniformly over the 4 pi sr has E[t^2] = 1 / (pi N /
     * (4 pi)) = 4 / N (2D Poisson nearest neighbour), so each direction has mean eps^2 + 4 r R / N:
     * 2.5 + 0.024 x 1e-3. The statistical error of that mean is ~ 0.024 / sqrt(N) (negligible);
     * the 256 x 128 tessellation moves both spheres inwards by at most r (1 - cos(pi / 256)) ~ 3e-5
     * (proportional to r, so eps shrinks by < 1e-4 relative). Tolerance 0.5%: between the
     * analytic value and eps^2 alone there is 1%. */
    MfMesh a = {0}, b = {0};
    CHECK_OK(mf_mesh_uv_sphere(&a, 256, 128, mf_v3s(0), 0.4f));
    CHECK_OK(mf_mesh_uv_sphere(&b, 256, 128, mf_v3s(0), 0.45f));
    enum { N = 30000 };
    CHECK_OK(ev_geom_score(&a, &b, N, 1, &s));
    double eps2 = 1e3 * 0.05 * 0.05, want = eps2 + 1e3 * 4 * 0.4 * 0.45 / N;
    printf("    spheres 0.4 / 0.45: uniform Chamfer %.5f (analytic %.5f, eps^2 x 1e3 %.5f), vertex Chamfer %.5f\n",
           s.chamfer_uniform, want, eps2, s.chamfer);
    CHECK_MSG(fabs(s.chamfer_uniform / want - 1) < 0.005, "spheres: uniform Chamfer %g, analytic %g", s.chamfer_uniform, want);
    CHECK_MSG(fabs(s.chamfer_uniform / eps2 - 1) < 0.02, "spheres: uniform Chamfer %g, eps^2 x 1e3 %g", s.chamfer_uniform, eps2);
    /* a sphere against itself: only the floor 4 r^2 / N (independent GT and prediction samples) */
    CHECK_OK(ev_geom_score(&a, &a, N, 1, &s));
    want = 1e3 * 4 * 0.4 * 0.4 / N;
    printf("    sphere 0.4 against itself: uniform Chamfer %.5f (floor 4 r^2 / N x 1e3 = %.5f)\n", s.chamfer_uniform, want);
    CHECK_MSG(fabs(s.chamfer_uniform / want - 1) < 0.05, "sphere vs itself: uniform Chamfer %g, floor %g", s.chamfer_uniform, want);
    mf_mesh_free(&a), mf_mesh_free(&b);
}

/* An n x n quad grid (2 triangles per quad) on [-0.5, 0.5]^2 in the z = 0 plane, rotated by a
 * radians about the x axis: normal (0, -sin a, cos a). */
static void tilted_grid(MfMesh *m, int n, double a) {
    CHECK_OK(mf_mesh_alloc(m, (n + 1) * (n + 1), 2 * n * n, 0, 0));
    if (mf_test_failed_now()) return;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = (double)i / n - 0.5, y = (double)j / n - 0.5;
            float *v = m->pos + 3 * (j * (n + 1) + i);
            v[0] = (float)x, v[1] = (float)(y * cos(a)), v[2] = (float)(y * sin(a));
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t v0 = (uint32_t)(j * (n + 1) + i), v1 = v0 + 1, v2 = v0 + (uint32_t)n + 1, v3 = v2 + 1, *t = m->tri + 6 * (j * n + i);
            t[0] = v0, t[1] = v1, t[2] = v3, t[3] = v0, t[4] = v3, t[5] = v2;
        }
}

/* Stanford-ORB's 1 - cos beside the angle: a flat grid against the same grid tilted by 30 degrees
 * about a line through it; every point pair and every pixel sees the same 30 degrees. */
MF_TEST(geom_normal_1mcos) {
    const double a = 30 * M_PI / 180, want = 1 - cos(a);
    MfMesh g = {0}, p = {0};
    tilted_grid(&g, 16, 0);
    tilted_grid(&p, 16, a);
    if (mf_test_failed_now()) return;
    EvGeomScore s;
    CHECK_OK(ev_geom_score(&g, &p, 5000, 1, &s));
    printf("    point pairs: %.6f deg, 1 - cos %.8f (1 - cos 30 deg = %.8f)\n", s.normal_deg, s.normal_1mcos, want);
    CHECK_MSG(fabs(s.normal_deg - 30) < 1e-3, "point pairs: %g deg (want 30)", s.normal_deg);
    CHECK_MSG(fabs(s.normal_1mcos - want) < 1e-6 && fabs(s.normal_1mcos - (1 - cos(s.normal_deg * M_PI / 180))) < 1e-6,
              "point pairs: 1 - cos %.9g, want %.9g (1 - cos of the mean angle %.9g)", s.normal_1mcos, want,
              1 - cos(s.normal_deg * M_PI / 180));
    MfCamera cam;
    look_cam(&cam, 48, 48, mf_v3(0.1f, -1.5f, 1.5f), mf_v3s(0));
    EvGeomViews gv;
    CHECK_OK(ev_geom_views(&g, &p, &cam, 1, &gv));
    printf("    view: %.6f deg, 1 - cos %.8f over %ld px\n", gv.normal_deg, gv.normal_1mcos, gv.pixels);
    CHECK_MSG(gv.pixels > 200 && fabs(gv.normal_deg - 30) < 1e-3 && fabs(gv.normal_1mcos - want) < 1e-6,
              "view: %g deg, 1 - cos %.9g (want %.9g) over %ld px", gv.normal_deg, gv.normal_1mcos, want, gv.pixels);
    /* the same grid: both 0 */
    CHECK_OK(ev_geom_score(&g, &g, 5000, 1, &s));
    CHECK_MSG(s.normal_deg < 1e-3 && s.normal_1mcos < 1e-9, "grid vs itself: %g deg, 1 - cos %g", s.normal_deg, s.normal_1mcos);
    mf_mesh_free(&g), mf_mesh_free(&p);
}
