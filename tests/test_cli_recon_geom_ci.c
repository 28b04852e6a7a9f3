/* T8 (issue 14): geometry recovery through the `mf` command (MF_BIN) against measured thresholds,
 * on a fixture whose views carve. The tiny split as made (8 views at 32 px, cameras 1.5-2 units
 * away) does not: grid vertices outside every frame are never carved, and at that distance 8 or
 * even 24 frames leave blocks of the grid's corners uncovered (000_cup hull: Chamfer x1e3 115 with
 * 8 views, 85 with 24; 2.25 with 8 views from 2.2-2.8). test_cli_recon_geom.c keeps the tiny split
 * for the CLI behaviour (refusals, defaults, --resume). Here the tiny split is generated with 24
 * training views at 40 px from 2.2-2.8 units, and two of its scenes are reconstructed from the
 * same split in NeRF-Synthetic's layout (mf gen --layout nerf-synthetic: no mesh, no ground
 * truth): 006_torus (convex outside, a hole that only carving opens) and 000_cup (a cavity no
 * silhouette carves). Per scene: the given mesh,
 * --geometry vhull and --geometry dmtet at the same budget, scored by mf eval against the scene's
 * GT mesh and relit views. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_split.h"
#include "eval/ev_table.h"
#include "geom/mf_vessel.h"
#include "io/mf_json.h"
#include "mf_test.h"
#include "mf_test_cli_geom.h"

/* The settings the thresholds were measured with (tests/test_cli_recon_geom_ci.c, README
 * "Geometry"): generation, the recon budget shared by all three runs, and each mode's own. */
#define CI_GEN "gen --split tiny --scenes 7 --train 24 --width 40 --r-min 2.2 --r-max 2.8"
#define CI_RECON "--iters 60 --tex-res 64 --env-w 32 --env-h 16 --hull-target-tris 5000 --hull-res 64"
#define CI_DMTET "--geometry dmtet --dmtet-res 32 --geom-iters 12 --geom-views 0 --geom-lr 0.05"
#define CI_STEPS 12

/* Measured with the settings above (OMP_NUM_THREADS 1 and 2 give the same bytes): Chamfer x1e3,
 * test-view normal error (deg), test-view mask IoU, relit PSNR (dB) of the hull and DMTet runs, and
 * the given-mesh run's relit PSNR. Re-measured 2026-11-28 when the vertices of a recovered mesh
 * began to move by default (--vertex-lr -1); the hull's columns again later that day, when the
 * hull's Taubin default went from 10 to 400 iterations (they were 0.0947 / 7.7 / 0.979 / 28.38 on
 * torus, 1.829 / 12.6 / 0.977 / 19.66 on cup); DMTet's when its extracted mesh's smoothing went
 * from 10 iterations to the resolution's default (25 at 32^3; they were 0.1133 / 14.1 / 0.966 /
 * 27.97 on torus, 1.814 / 14.9 / 0.982 / 19.30 on cup). The cup's columns again on 2026-11-29,
 * when --vessel auto became the default and kept its carved mesh (closed, they were 1.830 / 13.2 /
 * 0.981 / 19.60 for the hull and 1.830 / 14.4 / 0.979 / 19.36 for DMTet); the torus is a candidate
 * too (its flat top), and its trial fits keep the closed mesh. The hull's cup columns again when
 * --vessel auto also tried 3-cell walls where the stated ones are thinner (mf_vessel.h; at the
 * hull's 64^3 here, 1.62 cells): its trial took them (held-out 16.35 closed, 16.69 open, 17.35
 * open-thick dB; with 1.62-cell walls it was 0.2647 / 7.4 / 0.981 / 20.22). DMTet's 32^3 stated wall
 * (0.8 cells) is under half of 3, so it has no thick trial. All columns again when the recovered
 * meshes' shading normals became smoothed (--normal-smooth 5; torus hull 0.0854 / 8.6 / 0.991 /
 * 28.48 and DMTet 0.1100 / 13.2 / 0.969 / 28.36 before) and carved meshes whose walls broke
 * through stopped being tried (MF_VESSEL_MAX_EULER_DROP): the cup's 1.5-1.62-cell walls break
 * through on both grids (Euler characteristic -334 for the hull, -104 for DMTet, against 2 closed),
 * so DMTet keeps its closed cup (it had taken the holed one: 0.2575 / 9.6 / 0.977 / 20.18; the hull's
 * cup was 0.2490 / 6.2 / 0.982 / 20.58). DMTet's columns again when it began to start from the hull
 * mesh's signed distance and to carve what the hull carves (--dmtet-init hull; with the soft hull
 * start they were torus 0.1101 / 12.7 / 0.969 / 28.26, cup, closed, 1.8312 / 12.2 / 0.980 / 19.55):
 * its cup takes the hull's 3-cell walls now, cut into its fitted SDF on the hull's grid. */
typedef struct {
    const char *scene;
    double given_relit;
    double chamfer[2], normal_deg[2], iou[2], relit[2]; /* [0] vhull, [1] dmtet */
    const char *vessel[2];                              /* --vessel auto's choice */
    int thin_broke;                                     /* the stated walls broke through on both grids */
    double loss_ratio;                                  /* DMTet's mask loss, last / first step, at most */
} CiMeasured;

static const CiMeasured k_measured[] = {
    {"006_torus", 28.74, {0.0854, 0.0869}, {7.8, 8.4}, {0.991, 0.979}, {28.87, 28.72}, {"closed", "closed"}, 1, 1.05},
    {"000_cup", 20.93, {0.2490, 0.2527}, {5.5, 4.9}, {0.982, 0.979}, {20.68, 20.60}, {"open-thick", "open-thick"}, 1, 0.95},
};
/* The closed hull's cup Chamfer x1e3 (above): issue 14 asks the carved cavity for <= 0.5x of it. */
#define CI_CUP_CLOSED_CHAMFER 1.830
#define CI_SCENES "006_torus,000_cup"

/* Margins: Chamfer <= 1.5x measured (a hull that does not carve is 40x above: 85-115 on cup),
 * normal error <= measured + 4 deg, IoU >= measured - 0.03, relit PSNR >= the given mesh's minus
 * (the measured gap + 1 dB). DMTet's mask loss over all training views, last step over first, must
 * stay under loss_ratio: started from the hull, the torus's masks are fitted already and its 12
 * steps at 0.05 cells move the loss by x1.024; the cup's must fall to <= 0.95 (measured 0.895; a
 * skipped SDF step leaves 1). DMTet's test-view normal error must lie within CI_DMTET_HULL_DEG of
 * the hull's (measured +0.6 torus, -0.6 cup; from the soft hull, the former start, +4.9 and +6.7). */
#define CI_CHAMFER_X 1.5
#define CI_NORMAL_DEG 4.0
#define CI_IOU_DROP 0.03
#define CI_RELIT_DB 1.0
#define CI_DMTET_HULL_DEG 2.0
/* Checked to fail (each broken by hand, then restored): hull carving by every third view only
 * (torus: Chamfer 0.26 and 0.20, normals 14.6 deg), no view carving (both mesh-less runs refuse:
 * the field has no zero crossing), DMTet's Adam step skipped (mask loss x1.000; its geometry then
 * scores better than with the steps: the mask term roughens the surface, README "Geometry"). */

static double metric(const EvTable *t, const char *method, const char *scene, const char *name) {
    double v = NAN;
    return ev_table_find(t, method, "tiny", scene, name, &v) ? v : NAN;
}

MF_TEST(recon_geometry_carve_ci) {
    MF_NEED_BIN();
    const char *mf = getenv("MF_BIN");
    if (!mf_file_exists(DS_DEFAULT_ENV_DIR "/studio.exr")) MF_SKIP("blender-data probes not installed (" DS_DEFAULT_ENV_DIR ")");
    char d[1024], data[1100], res[1100], rep[1100], bare[1200], run[1300], p[1400], err[8192], args[4096];
    mf_test_path_to(d, sizeof d, "recon_geom_ci");
    snprintf(data, sizeof data, "%s/data", d);
    snprintf(res, sizeof res, "%s/results", d);
    snprintf(rep, sizeof rep, "%s/report", d);
    CHECK(mf_test_sh("%s " CI_GEN " -o %s 2>/dev/null", mf, data) == 0);
    snprintf(p, sizeof p, "%s/nerf", d); /* the same split in NeRF-Synthetic's layout: no mesh, no ground truth */
    CHECK(gen_nerf(mf, CI_GEN, p) == 0);

    const int ns = (int)(sizeof k_measured / sizeof k_measured[0]);
    for (int s = 0; s < ns; ++s) {
        const char *sc = k_measured[s].scene;
        snprintf(bare, sizeof bare, "%s/nerf/%s", d, sc);
        snprintf(args, sizeof args, "recon %s/%s -o %s/given/%s " CI_RECON, data, sc, res, sc);
        int rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 0, "%s given: exit %d, '%s'", sc, rc, err);
        snprintf(args, sizeof args, "recon %s -o %s/vhull/%s --geometry vhull " CI_RECON, bare, res, sc);
        rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 0, "%s vhull: exit %d, '%s'", sc, rc, err);
        snprintf(run, sizeof run, "%s/dmtet/%s", res, sc);
        snprintf(args, sizeof args, "recon %s -o %s " CI_DMTET " " CI_RECON, bare, run);
        rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 0, "%s dmtet: exit %d, '%s'", sc, rc, err);
        /* the SDF step did its job on the training masks (same views first and last: --geom-views 0) */
        double first = geom_result(run, "mask_loss_first", NULL, 0), last = geom_result(run, "mask_loss_last", NULL, 0);
        if (getenv("MF_TEST_VERBOSE")) printf("    %s dmtet: mask loss %.5f -> %.5f (x%.3f)\n", sc, first, last, last / first);
        CHECK_MSG(geom_result(run, "steps", NULL, 0) == CI_STEPS && first > 0 && last <= k_measured[s].loss_ratio * first,
                  "%s dmtet: %g steps, mask loss %g -> %g (must be <= %.2fx)", sc, geom_result(run, "steps", NULL, 0), first, last,
                  k_measured[s].loss_ratio);
    }

    snprintf(args, sizeof args, "eval %s --results %s -o %s --dataset tiny --scenes " CI_SCENES " --no-curves", data, res, rep);
    int rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 0, "mf eval: exit %d, '%s'", rc, err);
    snprintf(p, sizeof p, "%s/scenes.csv", rep);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, p));
    const char *mode[2] = {"vhull", "dmtet"};
    for (int s = 0; s < ns; ++s) {
        const CiMeasured *m = &k_measured[s];
        double nd_hull = metric(&t, "vhull", m->scene, "geom_view_normal_deg"), nd_dmtet = metric(&t, "dmtet", m->scene, "geom_view_normal_deg");
        CHECK_MSG(fabs(nd_dmtet - nd_hull) <= CI_DMTET_HULL_DEG, "%s: DMTet's normal error %g deg, the hull's %g: more than %g apart", m->scene,
                  nd_dmtet, nd_hull, CI_DMTET_HULL_DEG);
        double given = metric(&t, "given", m->scene, "relit_psnr"), given_ch = metric(&t, "given", m->scene, "geom_chamfer");
        if (getenv("MF_TEST_VERBOSE")) printf("    %s given: Chamfer x1e3 %.4f, relit PSNR %.2f\n", m->scene, given_ch, given);
        CHECK_MSG(isfinite(given) && given >= m->given_relit - CI_RELIT_DB, "%s given: relit PSNR %g < measured %g - %g dB", m->scene, given,
                  m->given_relit, CI_RELIT_DB);
        for (int k = 0; k < 2; ++k) {
            double ch = metric(&t, mode[k], m->scene, "geom_chamfer"), nd = metric(&t, mode[k], m->scene, "geom_view_normal_deg");
            double iou = metric(&t, mode[k], m->scene, "geom_mask_iou"), rl = metric(&t, mode[k], m->scene, "relit_psnr");
            if (getenv("MF_TEST_VERBOSE"))
                printf("    %s %s: Chamfer x1e3 %.4f, view normal %.2f deg, mask IoU %.4f, relit PSNR %.2f (given - %.2f dB)\n", m->scene,
                       mode[k], ch, nd, iou, rl, given - rl);
            CHECK_MSG(isfinite(ch) && ch <= CI_CHAMFER_X * m->chamfer[k], "%s %s: Chamfer x1e3 %g > %.1f x measured %g", m->scene, mode[k], ch,
                      CI_CHAMFER_X, m->chamfer[k]);
            CHECK_MSG(isfinite(nd) && nd <= m->normal_deg[k] + CI_NORMAL_DEG, "%s %s: view normal error %g deg > measured %g + %g", m->scene,
                      mode[k], nd, m->normal_deg[k], CI_NORMAL_DEG);
            CHECK_MSG(isfinite(iou) && iou >= m->iou[k] - CI_IOU_DROP, "%s %s: mask IoU %g < measured %g - %g", m->scene, mode[k], iou,
                      m->iou[k], CI_IOU_DROP);
            char chosen[16];
            snprintf(p, sizeof p, "%s/%s/%s", res, mode[k], m->scene);
            vessel_chosen(p, chosen, sizeof chosen);
            CHECK_MSG(!strcmp(chosen, m->vessel[k]), "%s %s: --vessel auto chose '%s', measured '%s'", m->scene, mode[k], chosen,
                      m->vessel[k]);
            /* a thick trial ran: its mesh is kept beside the others, its fit's folder is gone */
            for (int f = 0; !strcmp(m->vessel[k], "open-thick") && f < 2; ++f) {
                char q[1500];
                snprintf(q, sizeof q, f ? "%s/geometry/trial-open-thick" : "%s/geometry/%s-open-thick.obj", p, mode[k]);
                CHECK_MSG(mf_file_exists(q) == !f, "%s: %s", q, f ? "left behind" : "missing");
            }
            /* walls that broke through were not tried: their trial's PSNR is null */
            double e0 = vessel_number(p, "euler_closed"), e1 = vessel_number(p, "euler_open"), t1 = vessel_number(p, "holdout_psnr_open");
            CHECK_MSG(!m->thin_broke || (e1 < e0 - MF_VESSEL_MAX_EULER_DROP && isnan(t1)),
                      "%s %s: the stated walls' Euler characteristic %g (closed %g), their trial's PSNR %g: expected broken, not tried", m->scene,
                      mode[k], e1, e0, t1);
            CHECK_MSG(strncmp(m->vessel[k], "open", 4) || ch <= 0.5 * CI_CUP_CLOSED_CHAMFER, "%s %s: carved, Chamfer x1e3 %g > 0.5 x the closed hull's %g",
                      m->scene, mode[k], ch, CI_CUP_CLOSED_CHAMFER);
            double gap = m->given_relit - m->relit[k];
            CHECK_MSG(isfinite(rl) && rl >= given - (gap + CI_RELIT_DB), "%s %s: relit PSNR %g < given %g - (measured gap %.2f + %g) dB",
                      m->scene, mode[k], rl, given, gap, CI_RELIT_DB);
        }
    }
    ev_table_free(&t);
}
