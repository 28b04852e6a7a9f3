/* ev_geom (issue 14, T7): nearest neighbours, Chamfer and normal errors against closed forms. */
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
    look_cam(&cam, HW, mf_v3(0, -2.5f, 0.3f), mf_v3s(0));
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
