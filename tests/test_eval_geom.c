/* mf eval's geometry columns (issue 14 item 11): a result's mesh against the scene's GT mesh
 * (geom_chamfer, geom_chamfer_uniform, geom_normal_deg, geom_normal_1mcos, geom_view_normal_deg,
 * geom_view_normal_1mcos, geom_mask_iou), through ev_eval_scene and
 * through `mf eval` (scenes.csv, geometry.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_eval.h"
#include "io/mf_obj.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

static void put(const char *path, const char *text) {
    mf_mkdirs_for(path);
    FILE *f = fopen(path, "w");
    if (f) { fputs(text, f); fclose(f); }
}

static void write_const(const char *path, int w, int h, int c, float v, MfEncoding enc) {
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, w, h, c));
    for (size_t i = 0; i < (size_t)w * h * c; ++i) im.data[i] = v;
    if (c == 4)
        for (size_t i = 0; i < (size_t)w * h; ++i) im.data[4 * i + 3] = 1.0f;
    mf_mkdirs_for(path);
    CHECK_OK(mf_image_write(path, &im, enc, strstr(path, ".exr") ? 32 : 8));
    mf_image_free(&im);
}

static void write_sphere(const char *path, float r) {
    MfMesh m;
    CHECK_OK(mf_mesh_uv_sphere(&m, 128, 64, mf_v3s(0.0f), r)); /* 8k vertices: a low Chamfer sampling floor */
    mf_mkdirs_for(path);
    CHECK_OK(mf_obj_write(path, &m, NULL));
    mf_mesh_free(&m);
}

/* A result folder: a sphere of radius r, grey textures, a constant env. */
static void write_result(const char *dir, float r) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    write_sphere(p, r);
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    write_const(p, 4, 4, 3, 0.5f, MF_ENC_SRGB);
    snprintf(p, sizeof p, "%s/orm.png", dir);
    write_const(p, 4, 4, 3, 0.5f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/env.exr", dir);
    write_const(p, 8, 4, 3, 0.8f, MF_ENC_LINEAR);
}

/* A bvault scene of two 64 x 64 test views (from +z and from +x, distance 1.5) and a training
 * light, with or without the GT mesh (a sphere of radius 0.4). */
static void write_scene(const char *dir, int with_mesh) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/transforms_test.json", dir);
    put(p, "{\"camera_angle_x\": 0.9, \"frames\": ["
           "{\"file_path\": \"./test/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1.5],[0,0,0,1]]},"
           "{\"file_path\": \"./test/r_1\", \"transform_matrix\": [[0,0,1,1.5],[1,0,0,0],[0,1,0,0],[0,0,0,1]]}]}");
    for (int i = 0; i < 2; ++i) {
        snprintf(p, sizeof p, "%s/test/r_%d.png", dir, i);
        write_const(p, 64, 64, 4, 0.5f, MF_ENC_SRGB);
    }
    snprintf(p, sizeof p, "%s/gt/env.exr", dir); /* gt/: the bvault layout */
    write_const(p, 8, 4, 3, 0.8f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    if (with_mesh) write_sphere(p, 0.4f);
}

MF_TEST(eval_geometry_columns) {
    char scene[MF_PATH_MAX], bare[MF_PATH_MAX], given[MF_PATH_MAX], big[MF_PATH_MAX];
    snprintf(scene, sizeof scene, "%s", mf_test_path("eg/data/scene"));
    snprintf(bare, sizeof bare, "%s", mf_test_path("eg/bare"));
    snprintf(given, sizeof given, "%s", mf_test_path("eg/results/given/scene"));
    snprintf(big, sizeof big, "%s", mf_test_path("eg/results/big/scene"));
    write_scene(scene, 1);
    write_scene(bare, 0);
    write_result(given, 0.4f);  /* the GT mesh itself */
    write_result(big, 0.44f);   /* concentric, eps = 0.04 larger */
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
     * test_eval_geom_chamfer.c), the GT mesh itself 4 r^2 / N; 3% for the 128 x 64 tessellation */
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
    put(p, "v 0 0 0\nv 1 0 0\nf 1 2 2\n");
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
