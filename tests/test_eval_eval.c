/* Tests of eval/ev_eval (per-scene evaluation, ev_eval_scene): hostile input; novel-view scores
 * of a scene without relit or material ground truth (nv_*); the geometry columns against a GT
 * mesh, through ev_eval_scene and `mf eval`. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_load.h"
#include "eval/ev_eval.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "mf_test.h"
#include "mf_test_kit.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

/* put, making path's folders first. */
static void put_mk(const char *path, const char *text) {
    mf_mkdirs_for(path);
    put(path, text);
}

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

/* (c) Per-view GT albedo / ORM / relit images smaller than the views were read past their end
 * by eval (a heap overflow; without ASan a wrong score and exit 0). Now the loader refuses them
 * naming both files, and eval names the relit file and the view image. */
MF_TEST(hostile_eval_gt_size) {
    char scene[512], res[512];
    mf_test_path_to(scene, sizeof scene, "hostile_gt/scene");
    mf_test_path_to(res, sizeof res, "hostile_gt/result");
    CHECK_OK(mf_mkdirs(scene));
    CHECK_OK(mf_mkdirs(res));
    put(pj2(scene, "transforms_test.json"),
        "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./test/r_0\", \"transform_matrix\": "
        "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}");
    put(pj2(scene, "mesh.obj"), k_quad);
    write_flat(pj2(scene, "test/r_0.png"), 16, 16, 4, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(scene, "gt/albedo/r_0.png"), 8, 8, 3, 0.5f, MF_ENC_SRGB);
    put(pj2(res, "mesh.obj"), k_quad);
    write_flat(pj2(res, "albedo.png"), 4, 4, 3, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(res, "orm.png"), 4, 4, 3, 0.5f, MF_ENC_LINEAR);

    DsViews v;
    CHECK_ERR(ds_load(scene, "test", NULL, &v), "gt/albedo/r_0.png: GT albedo is 8x8, the view image");
    CHECK_MSG(strstr(mf_error(), "test/r_0.png is 16x16") != NULL, "message: %s", mf_error());
    EvEvalOpts o = ev_eval_opts_default();
    o.spp_sqrt = 1;
    o.pixel_samples = 1;
    EvTable t;
    ev_table_init(&t);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "gt/albedo/r_0.png: GT albedo is 8x8");
    /* ORM GT too small */
    write_flat(pj2(scene, "gt/albedo/r_0.png"), 16, 16, 3, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(scene, "gt/orm/r_0.png"), 16, 8, 3, 0.5f, MF_ENC_LINEAR);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "gt/orm/r_0.png: GT ORM is 16x8, the view image");
    /* relit GT too small */
    write_flat(pj2(scene, "gt/orm/r_0.png"), 16, 16, 3, 0.5f, MF_ENC_LINEAR);
    write_flat(pj2(scene, "relight/sky.exr"), 8, 4, 3, 1.0f, MF_ENC_LINEAR);
    write_flat(pj2(scene, "relight/sky/r_0.exr"), 8, 8, 4, 0.25f, MF_ENC_LINEAR);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "relight/sky/r_0.exr: relit GT is 8x8, the view image");
    CHECK_MSG(strstr(mf_error(), "test/r_0.png is 16x16") != NULL, "message: %s", mf_error());
    /* all sizes right: scored */
    write_flat(pj2(scene, "relight/sky/r_0.exr"), 16, 16, 4, 0.25f, MF_ENC_LINEAR);
    int ex = 0;
    CHECK_OK(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, &ex));
    CHECK_MSG(ev_table_stat(&t, "m", "d", "relit_psnr").n == 1, "excluded %d, records %zu", ex, t.n);
    CHECK(ev_table_stat(&t, "m", "d", "albedo_psnr").n == 1);
    ev_table_free(&t);
}

/* ---- novel views without relit or material ground truth (issue 15, item 5): the held-out test
 * views are scored under the training light (nv_* metrics), from the result's own env.exr ---- */

/* (w, h, c) image: value a, or (checker) a in the left half and b in the right. */
static void write_img(const char *path, int w, int h, int c, float a, float b, MfEncoding enc) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k) mf_image_px(&im, x, y)[k] = x < w / 2 ? a : b;
    mf_mkdirs_for(path);
    CHECK_OK(mf_image_write(path, &im, enc, strstr(path, ".exr") ? 32 : 8));
    mf_image_free(&im);
}

static void write_quad_result(const char *dir, float kd_a, float kd_b, int env) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    put_mk(p, k_quad);
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    write_img(p, 4, 4, 3, kd_a, kd_b, MF_ENC_SRGB);
    snprintf(p, sizeof p, "%s/orm.png", dir);
    write_img(p, 4, 4, 3, 1.0f, 1.0f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/env.exr", dir);
    if (env) write_img(p, 8, 4, 3, 0.8f, 0.8f, MF_ENC_LINEAR);
}

/* The test views of the scene: the "good" result rendered as eval renders it, straight alpha. */
static void write_nv_views(const char *scene, const char *good, const EvEvalOpts *o) {
    put_mk(mf_test_path("nv/scene/transforms_test.json"),
        "{\"camera_angle_x\": 0.9, \"frames\": ["
        "{\"file_path\": \"./test/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1.5],[0,0,0,1]]},"
        "{\"file_path\": \"./test/r_1\", \"transform_matrix\": [[1,0,0,0.1],[0,1,0,0],[0,0,1,1.4],[0,0,0,1]]}]}");
    EvResult r;
    CHECK_OK(ev_result_load(good, NULL, &r));
    if (mf_test_failed_now()) return;
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&r.mesh, &rt));
    MfTexMaterial mat = {.kd = &r.kd, .orm = &r.orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = NULL};
    MfRenderInput in = {rt, &r.mesh, &mat, 1, &r.env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = o->spp_sqrt, .pixel_samples = o->pixel_samples, .seed = o->seed, .lobes = MF_LOBE_ALL};
    const double c2w[2][16] = {{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1.5, 0, 0, 0, 1}, {1, 0, 0, 0.1, 0, 1, 0, 0, 0, 0, 1, 1.4, 0, 0, 0, 1}};
    for (int i = 0; i < 2; ++i) {
        MfCamera cam;
        MfRenderOut out = {0};
        MfImage im = {0};
        CHECK_OK(mf_camera_init(&cam, 16, 16, 0.9, c2w[i], "test"));
        CHECK_OK(mf_render(&in, &cam, &ro, &out, NULL));
        mf_image_alloc(&im, 16, 16, 4);
        for (int p = 0; p < 256; ++p) {
            float a = out.alpha[p];
            for (int k = 0; k < 3; ++k) im.data[4 * p + k] = a > 0 ? out.rgb[3 * p + k] / a : 0.0f;
            im.data[4 * p + 3] = a;
        }
        char path[MF_PATH_MAX];
        snprintf(path, sizeof path, "%s/test/r_%d.png", scene, i);
        mf_mkdirs_for(path);
        CHECK_OK(mf_image_write(path, &im, MF_ENC_SRGB, 16));
        mf_image_free(&im);
        mf_render_out_free(&out);
    }
    mf_rtscene_free(rt);
    ev_result_free(&r);
}

MF_TEST(eval_novel_view_without_gt) {
    char scene[MF_PATH_MAX], good[MF_PATH_MAX], bad[MF_PATH_MAX], noenv[MF_PATH_MAX];
    mf_test_path_to(scene, sizeof scene, "nv/scene");
    mf_test_path_to(good, sizeof good, "nv/good");
    mf_test_path_to(bad, sizeof bad, "nv/bad");
    mf_test_path_to(noenv, sizeof noenv, "nv/noenv");
    write_quad_result(good, 0.5f, 0.5f, 1);
    write_quad_result(bad, 0.1f, 0.9f, 1); /* albedo that no per-channel scale can align */
    write_quad_result(noenv, 0.5f, 0.5f, 0);
    EvEvalOpts o = ev_eval_opts_default();
    o.spp_sqrt = 2;
    o.pixel_samples = 1;
    write_nv_views(scene, good, &o);
    if (mf_test_failed_now()) return;
    EvTable t;
    ev_table_init(&t);
    int ex = 0;
    CHECK_OK(ev_eval_scene(scene, good, "good", "d", "s", &o, &t, NULL, &ex));
    CHECK_OK(ev_eval_scene(scene, bad, "bad", "d", "s", &o, &t, NULL, &ex));
    EvStat g = ev_table_stat(&t, "good", "d", "nv_psnr"), b = ev_table_stat(&t, "bad", "d", "nv_psnr");
    CHECK(ex == 0);
    printf("    nv_psnr good %.2f bad %.2f\n", g.mean, b.mean);
    CHECK_MSG(g.n == 1 && g.mean > 40.0, "good: n %d, nv_psnr %.2f", g.n, g.mean);
    CHECK_MSG(b.n == 1 && b.mean < g.mean - 10.0, "bad: n %d, nv_psnr %.2f (good %.2f)", b.n, b.mean, g.mean);
    CHECK(ev_table_stat(&t, "good", "d", "nv_ssim").n == 1 && ev_table_stat(&t, "good", "d", "nv_flip").n == 1);
    CHECK(ev_table_stat(&t, "good", "d", "relit_psnr").n == 0); /* nothing claims to be relighting */
    CHECK_ERR(ev_eval_scene(scene, noenv, "noenv", "d", "s", &o, &t, NULL, &ex), "needs the result's env.exr");
    ev_table_free(&t);
}

/* ---- mf eval's geometry columns (issue 14 item 11): a result's mesh against the scene's GT mesh
 * (geom_chamfer, geom_chamfer_uniform, geom_normal_deg, geom_normal_1mcos, geom_view_normal_deg,
 * geom_view_normal_1mcos, geom_mask_iou), through ev_eval_scene and through `mf eval`
 * (scenes.csv, geometry.md) ---- */

static void write_sphere(const char *path, float r) {
    MfMesh m;
    CHECK_OK(mf_mesh_uv_sphere(&m, 128, 64, mf_v3s(0.0f), r)); /* 8k vertices: a low Chamfer sampling floor */
    mf_mkdirs_for(path);
    CHECK_OK(mf_obj_write(path, &m, NULL));
    mf_mesh_free(&m);
}

/* A result folder: a sphere of radius r, grey textures, a constant env. */
static void write_sphere_result(const char *dir, float r) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    write_sphere(p, r);
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    write_flat(p, 4, 4, 3, 0.5f, MF_ENC_SRGB);
    snprintf(p, sizeof p, "%s/orm.png", dir);
    write_flat(p, 4, 4, 3, 0.5f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/env.exr", dir);
    write_flat(p, 8, 4, 3, 0.8f, MF_ENC_LINEAR);
}

/* A bvault scene of two 64 x 64 test views (from +z and from +x, distance 1.5) and a training
 * light, with or without the GT mesh (a sphere of radius 0.4). */
static void write_scene(const char *dir, int with_mesh) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/transforms_test.json", dir);
    put_mk(p, "{\"camera_angle_x\": 0.9, \"frames\": ["
           "{\"file_path\": \"./test/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1.5],[0,0,0,1]]},"
           "{\"file_path\": \"./test/r_1\", \"transform_matrix\": [[0,0,1,1.5],[1,0,0,0],[0,1,0,0],[0,0,0,1]]}]}");
    for (int i = 0; i < 2; ++i) {
        snprintf(p, sizeof p, "%s/test/r_%d.png", dir, i);
        write_flat(p, 64, 64, 4, 0.5f, MF_ENC_SRGB);
    }
    snprintf(p, sizeof p, "%s/gt/env.exr", dir); /* gt/: the bvault layout */
    write_flat(p, 8, 4, 3, 0.8f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    if (with_mesh) write_sphere(p, 0.4f);
}

MF_TEST(eval_geometry_columns) {
    char scene[MF_PATH_MAX], bare[MF_PATH_MAX], given[MF_PATH_MAX], big[MF_PATH_MAX];
    mf_test_path_to(scene, sizeof scene, "eg/data/scene");
    mf_test_path_to(bare, sizeof bare, "eg/bare");
    mf_test_path_to(given, sizeof given, "eg/results/given/scene");
    mf_test_path_to(big, sizeof big, "eg/results/big/scene");
    write_scene(scene, 1);
    write_scene(bare, 0);
    write_sphere_result(given, 0.4f);  /* the GT mesh itself */
    write_sphere_result(big, 0.44f);   /* concentric, eps = 0.04 larger */
    if (mf_test_failed_now()) return;
    EvEvalOpts o = ev_eval_opts_default();
    o.spp_sqrt = 1;
    o.pixel_samples = 1;
    EvTable t;
    ev_table_init(&t);
    int ex = 0;
    CHECK_OK(ev_eval_scene(scene, given, "given", "d", "s", &o, &t, NULL, &ex));
    CHECK_OK(ev_eval_scene(scene, big, "big", "d", "s", &o, &t, NULL, &ex));
    const char *names[7] = {"geom_chamfer", "geom_normal_deg", "geom_view_normal_deg", "geom_mask_iou",
                            "geom_chamfer_uniform", "geom_normal_1mcos", "geom_view_normal_1mcos"};
    double g[7] = {0}, b[7] = {0};
    for (int k = 0; k < 7; ++k) {
        CHECK_MSG(ev_table_find(&t, "given", "d", "s", names[k], &g[k]) && ev_table_find(&t, "big", "d", "s", names[k], &b[k]),
                  "%s missing", names[k]);
    }
    printf("    given mesh: Chamfer %.4f, normals %.2f deg (views %.3f), IoU %.4f; sphere 1.1x: Chamfer %.3f (eps^2 x 1e3 = 1.6), "
           "normals %.2f deg (views %.2f), IoU %.4f\n", g[0], g[1], g[2], g[3], b[0], b[1], b[2], b[3]);
    /* Chamfer of concentric spheres: eps^2 x 1e3 each way (+ the floor of sampling against the GT
     * vertices); the GT mesh itself: that floor only */
    CHECK_MSG(fabs(b[0] - 1.6) < 0.1 * 1.6, "Chamfer r 0.4 vs 0.44: %g (want 1.6)", b[0]);
    CHECK_MSG(g[0] < 0.05, "Chamfer of the GT mesh itself: %g", g[0]);
    /* the uniform variant: eps^2 + 4 r R / N each way (the nearest of N = 30000 samples; see
     * test_eval_geom.c), the GT mesh itself 4 r^2 / N; 3% for the 128 x 64 tessellation */
    double uni_big = 1e3 * (0.04 * 0.04 + 4 * 0.4 * 0.44 / EV_GEOM_SAMPLES), uni_given = 1e3 * 4 * 0.4 * 0.4 / EV_GEOM_SAMPLES;
    printf("    uniform Chamfer: given %.4f (floor %.4f), sphere 1.1x %.4f (analytic %.4f)\n", g[4], uni_given, b[4], uni_big);
    CHECK_MSG(fabs(b[4] / uni_big - 1) < 0.03 && fabs(g[4] / uni_given - 1) < 0.1, "uniform Chamfer: big %g (want %g), given %g (want %g)",
              b[4], uni_big, g[4], uni_given);
    /* 1 - cos beside the mean angle: 1 - cos is convex below 90 degrees, so its mean is at least
     * 1 - cos(mean angle) (Jensen); small for the GT mesh itself */
    for (int k = 5; k <= 6; ++k) {
        double lo = 1 - cos((k == 5 ? b[1] : b[2]) * M_PI / 180);
        CHECK_MSG(b[k] >= lo && b[k] < 0.02 && g[k] < 1e-3, "%s: big %g (>= %g), given %g", names[k], b[k], lo, g[k]);
    }
    CHECK_MSG(g[2] < 0.05 && g[3] == 1.0, "GT mesh itself: view normals %g deg, IoU %g", g[2], g[3]);
    /* silhouettes from distance 1.5: IoU = (tan asin(0.4/1.5) / tan asin(0.44/1.5))^2 = 0.813 */
    double want = pow(tan(asin(0.4 / 1.5)) / tan(asin(0.44 / 1.5)), 2.0);
    CHECK_MSG(fabs(b[3] - want) < 0.04, "IoU r 0.4 vs 0.44: %g (want %.3f)", b[3], want);
    /* point pairs: the sample's face normal against the nearest GT vertex's normal */
    CHECK_MSG(g[1] < 2.5 && b[1] < 2.5, "point-pair normal error: given %g, big %g deg", g[1], b[1]);
    /* no GT mesh, or no_geom (--no-geom): no geometry records */
    EvTable t2;
    ev_table_init(&t2);
    CHECK_OK(ev_eval_scene(bare, big, "bare", "d", "s", &o, &t2, NULL, &ex));
    o.no_geom = 1;
    CHECK_OK(ev_eval_scene(scene, big, "nogeom", "d", "s", &o, &t2, NULL, &ex));
    CHECK(ev_table_stat(&t2, "bare", "d", "geom_chamfer").n == 0 && ev_table_stat(&t2, "nogeom", "d", "geom_mask_iou").n == 0);
    CHECK(ev_table_stat(&t2, "bare", "d", "nv_psnr").n == 1); /* the rest still scored */
    /* a GT mesh without area: a warning, no geometry records, the rest scored */
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/mesh.obj", bare);
    put_mk(p, "v 0 0 0\nv 1 0 0\nf 1 2 2\n");
    o.no_geom = 0;
    CHECK_OK(ev_eval_scene(bare, big, "broken", "d", "s", &o, &t2, NULL, &ex));
    CHECK(ev_table_stat(&t2, "broken", "d", "geom_chamfer").n == 0 && ev_table_stat(&t2, "broken", "d", "nv_psnr").n == 1);
    ev_table_free(&t);
    ev_table_free(&t2);
    /* mf eval: the columns in scenes.csv and geometry.md (IoU marked higher-is-better, best marked) */
    char args[4 * MF_PATH_MAX], err[4096], *csv = NULL, *md = NULL;
    snprintf(args, sizeof args, "eval %s --results %s -o %s --no-curves --spp 1 --pixel-samples 1", scene,
             mf_test_path("eg/results"), mf_test_path("eg/report"));
    int code = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(code == 0, "mf eval exited %d: %s", code, err);
    CHECK_OK(mf_read_file(mf_test_path("eg/report/scenes.csv"), &csv, NULL));
    CHECK_OK(mf_read_file(mf_test_path("eg/report/geometry.md"), &md, NULL));
    if (csv && md) {
        CHECK(strstr(csv, "geom_chamfer") && strstr(csv, "geom_mask_iou") && strstr(csv, "geom_view_normal_deg"));
        CHECK_MSG(strstr(md, "geom_chamfer_uniform ↓") && strstr(md, "geom_normal_1mcos ↓") && strstr(md, "geom_view_normal_1mcos ↓"),
                  "geometry.md lacks the uniform Chamfer or 1 - cos columns:\n%s", md);
        CHECK_MSG(strstr(md, "geom_mask_iou ↑") && strstr(md, "geom_chamfer ↓") && strstr(md, "given") && strstr(md, "big"),
                  "geometry.md:\n%s", md);
    }
    free(csv);
    free(md);
}
