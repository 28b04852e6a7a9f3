/* mf eval on a scene without relit or material ground truth (issue 15, item 5): the held-out test
 * views are scored under the training light (nv_* metrics), from the result's own env.exr. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_eval.h"
#include "io/mf_exr.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

static const char *k_quad =
    "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";

static void put(const char *path, const char *text) {
    mf_mkdirs_for(path);
    FILE *f = fopen(path, "w");
    if (f) { fputs(text, f); fclose(f); }
}

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

static void write_result(const char *dir, float kd_a, float kd_b, int env) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    put(p, k_quad);
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    write_img(p, 4, 4, 3, kd_a, kd_b, MF_ENC_SRGB);
    snprintf(p, sizeof p, "%s/orm.png", dir);
    write_img(p, 4, 4, 3, 1.0f, 1.0f, MF_ENC_LINEAR);
    snprintf(p, sizeof p, "%s/env.exr", dir);
    if (env) write_img(p, 8, 4, 3, 0.8f, 0.8f, MF_ENC_LINEAR);
}

/* The test views of the scene: the "good" result rendered as eval renders it, straight alpha. */
static void write_views(const char *scene, const char *good, const EvEvalOpts *o) {
    put(mf_test_path("nv/scene/transforms_test.json"),
        "{\"camera_angle_x\": 0.9, \"frames\": ["
        "{\"file_path\": \"./test/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,1.5],[0,0,0,1]]},"
        "{\"file_path\": \"./test/r_1\", \"transform_matrix\": [[1,0,0,0.1],[0,1,0,0],[0,0,1,1.4],[0,0,0,1]]}]}");
    EvResult r;
    CHECK_OK(ev_result_load(good, NULL, &r));
    if (mf_test_failed_now()) return;
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&r.mesh, &rt));
    MfTexMaterial mat = {&r.kd, &r.orm, mf_v3s(0.5f), mf_v3(1, 0.5f, 0), NULL};
    MfRenderInput in = {rt, &r.mesh, &mat, 1, &r.env, NULL, 0};
    MfRenderOpts ro = {o->spp_sqrt, o->pixel_samples, o->seed, MF_LOBE_ALL};
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
    snprintf(scene, sizeof scene, "%s", mf_test_path("nv/scene"));
    snprintf(good, sizeof good, "%s", mf_test_path("nv/good"));
    snprintf(bad, sizeof bad, "%s", mf_test_path("nv/bad"));
    snprintf(noenv, sizeof noenv, "%s", mf_test_path("nv/noenv"));
    write_result(good, 0.5f, 0.5f, 1);
    write_result(bad, 0.1f, 0.9f, 1); /* albedo that no per-channel scale can align */
    write_result(noenv, 0.5f, 0.5f, 0);
    EvEvalOpts o = ev_eval_opts_default();
    o.spp_sqrt = 2;
    o.pixel_samples = 1;
    write_views(scene, good, &o);
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
