/* Captures as users have them (issue 15, item 5): instant-ngp / nerfstudio transforms.json with
 * intrinsics (global and per frame, non-square pixels, moved principal point), the hold-out
 * split rule, distortion and camera models refused by name, masks from --mask DIR or mask_path,
 * RGB frames without a mask (alpha 1), duplicate base names refused, NeRF-Synthetic val/test; and a
 * capture written by `mf gen --layout ingp` (ds_capture.h) read back with its own lens. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_capture.h"
#include "datasets/ds_load.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

static void write_text(const char *path, const char *text) {
    mf_mkdirs_for(path);
    FILE *f = fopen(path, "w");
    if (f) { fputs(text, f); fclose(f); }
}

/* A c-channel PNG (c = 3: RGB, no alpha), value v everywhere, or a mask (left half 0). */
static void write_png(const char *path, int w, int h, int c, int mask) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k) mf_image_px(&im, x, y)[k] = mask ? (x >= w / 2 ? 1.0f : 0.0f) : 0.5f;
    mf_mkdirs_for(path);
    CHECK_OK(mf_image_write(path, &im, MF_ENC_LINEAR, 8));
    mf_image_free(&im);
}

#define C2W(z) "[[1,0,0,0],[0,1,0,0],[0,0,1," #z "],[0,0,0,1]]"

/* An instant-ngp style capture in dir: 9 RGB frames images/f<i>.png (8x8), global intrinsics
 * (extra: more root keys), frame 3 with its own fl_x (frame_extra: more keys of frame 3). */
static void make_capture(const char *dir, const char *extra, const char *frame_extra) {
    char json[8192], *p = json;
    p += sprintf(p, "{\"fl_x\": 10, \"fl_y\": 12, \"cx\": 3.5, \"cy\": 4.5, \"w\": 8, \"h\": 8, \"aabb_scale\": 16%s, \"frames\": [",
                 extra);
    for (int i = 0; i < 9; ++i) {
        char img[MF_PATH_MAX];
        snprintf(img, sizeof img, "%s/images/f%d.png", dir, i);
        write_png(img, 8, 8, 3, 0);
        p += sprintf(p, "%s{\"file_path\": \"images/f%d.png\", \"transform_matrix\": " C2W(4) "%s}", i ? "," : "", i,
                     i == 3 ? frame_extra : "");
    }
    sprintf(p, "]}");
    char jp[MF_PATH_MAX];
    snprintf(jp, sizeof jp, "%s/transforms.json", dir);
    write_text(jp, json);
}

MF_TEST(ds_capture_intrinsics_and_split) {
    const char *dir = mf_test_path("cap_ngp");
    make_capture(dir, "", ", \"fl_x\": 20");
    CHECK(ds_detect_format(dir) == DS_FMT_NERF_SYNTHETIC);
    DsViews v;
    CHECK_OK(ds_load(dir, "train", NULL, &v));
    if (mf_test_failed_now()) return;
    CHECK(v.n == 7); /* frames 1..7; 0 and 8 are held out */
    if (v.n != 7) return;
    CHECK(!strcmp(v.views[0].name, "f1") && !strcmp(v.views[6].name, "f7"));
    CHECK_NEAR(v.views[0].cam.fx, 10.0, 1e-6);
    CHECK_NEAR(v.views[0].cam.fy, 12.0, 1e-6); /* non-square pixels */
    CHECK_NEAR(v.views[0].cam.cx, 3.5, 1e-6);
    CHECK_NEAR(v.views[0].cam.cy, 4.5, 1e-6);
    CHECK_NEAR(v.views[2].cam.fx, 20.0, 1e-6); /* frame 3: its own fl_x wins; fl_y stays global */
    CHECK_NEAR(v.views[2].cam.fy, 12.0, 1e-6);
    CHECK(v.views[0].rgba.c == 4 && v.views[0].rgba.data[3] == 1.0f); /* RGB, no mask: alpha 1 */
    ds_views_free(&v);
    CHECK_OK(ds_load(dir, "test", NULL, &v));
    CHECK(v.n == 2 && !strcmp(v.views[0].name, "f0") && !strcmp(v.views[v.n - 1].name, "f8"));
    ds_views_free(&v);
    /* downsampled by 2: intrinsics scale with the image */
    DsLoadOptions o = {0, 0, 2, 0, NULL, 0};
    CHECK_OK(ds_load(dir, "test", &o, &v));
    if (!mf_test_failed_now()) {
        CHECK(v.w == 4);
        CHECK_NEAR(v.views[0].cam.fx, 5.0, 1e-6);
        CHECK_NEAR(v.views[0].cam.fy, 6.0, 1e-6);
        CHECK_NEAR(v.views[0].cam.cx, 1.75, 1e-6);
        ds_views_free(&v);
    }
    CHECK(ds_load(dir, "novel", NULL, &v) != 0 && strstr(mf_error(), "split 'novel' is none of train, test"));
}

MF_TEST(ds_capture_refused) {
    DsViews v;
    const char *d1 = mf_test_path("cap_k1");
    make_capture(d1, ", \"k1\": 0.1, \"k2\": 0", "");
    CHECK_ERR(ds_load(d1, "train", NULL, &v), "cap_k1/transforms.json: k1 = 0.1: lens distortion is not supported");
    const char *d2 = mf_test_path("cap_p2");
    make_capture(d2, ", \"k1\": 0, \"p1\": 0", ", \"p2\": -0.01");
    CHECK_ERR(ds_load(d2, "train", NULL, &v), "cap_p2/transforms.json: frames[3].p2 = -0.01: lens distortion");
    const char *d3 = mf_test_path("cap_fisheye");
    make_capture(d3, ", \"camera_model\": \"OPENCV_FISHEYE\"", "");
    CHECK_ERR(ds_load(d3, "train", NULL, &v), "camera_model 'OPENCV_FISHEYE' is not supported");
    const char *d4 = mf_test_path("cap_aspect");
    make_capture(d4, ", \"w\": 16", ""); /* duplicate key: cJSON takes the first (8); make it differ per frame */
    make_capture(d4, "", ", \"h\": 4");
    CHECK_ERR(ds_load(d4, "train", NULL, &v), "w x h = 8 x 4, but the image");
    const char *d5 = mf_test_path("cap_fl");
    make_capture(d5, "", ", \"fl_x\": -3");
    CHECK_ERR(ds_load(d5, "train", NULL, &v), "frames[3].fl_x = -3: expected a number");
}

MF_TEST(ds_capture_masks) {
    const char *dir = mf_test_path("cap_mask");
    make_capture(dir, "", ", \"mask_path\": \"masks/f3.png\"");
    write_png(mf_test_path("cap_mask/masks/f3.png"), 8, 8, 1, 1);
    DsViews v;
    /* mask_path of frame 3 (nerfstudio) replaces its alpha; the others stay 1 */
    CHECK_OK(ds_load(dir, "train", NULL, &v));
    if (!mf_test_failed_now()) {
        const MfImage *a = &v.views[2].rgba, *b = &v.views[0].rgba;
        CHECK(mf_image_px(a, 0, 0)[3] == 0.0f && mf_image_px(a, 7, 0)[3] == 1.0f);
        CHECK(mf_image_px(b, 0, 0)[3] == 1.0f);
        ds_views_free(&v);
    }
    /* --mask DIR: every frame needs DIR/<name>.png */
    const char *md = mf_test_path("cap_masks_dir");
    DsLoadOptions o = {0, 0, 1, 0, md, 0};
    write_png(mf_test_path("cap_masks_dir/f0.png"), 8, 8, 1, 1);
    write_png(mf_test_path("cap_masks_dir/f8.png"), 8, 4, 1, 1);
    CHECK_ERR(ds_load(dir, "test", &o, &v), "cap_masks_dir/f8.png: mask is 8x4, the image");
    write_png(mf_test_path("cap_masks_dir/f8.png"), 8, 8, 1, 1);
    CHECK_OK(ds_load(dir, "test", &o, &v));
    if (!mf_test_failed_now()) {
        CHECK(mf_image_px(&v.views[1].rgba, 0, 0)[3] == 0.0f && mf_image_px(&v.views[1].rgba, 4, 3)[3] == 1.0f);
        ds_views_free(&v);
    }
    CHECK_ERR(ds_load(dir, "train", &o, &v), "cap_masks_dir/f1.png");
    DsLoadOptions rel = {0, 0, 1, 0, "masks", 0}; /* relative: inside the scene folder */
    CHECK_ERR(ds_load(dir, "train", &rel, &v), "cap_mask/masks/f1.png");
}

MF_TEST(ds_capture_duplicate_names) {
    const char *dir = mf_test_path("cap_dup");
    write_png(mf_test_path("cap_dup/a/r_0.png"), 4, 4, 4, 0);
    write_png(mf_test_path("cap_dup/b/r_0.jpg"), 4, 4, 3, 0);
    write_text(mf_test_path("cap_dup/transforms_train.json"),
               "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"a/r_0\", \"transform_matrix\": " C2W(4) "},"
               "{\"file_path\": \"b/r_0.jpg\", \"transform_matrix\": " C2W(5) "}]}");
    DsViews v;
    CHECK_ERR(ds_load(dir, "train", NULL, &v), "frames[0] and frames[1] both have the base name 'r_0'");
}

/* NeRF-Synthetic ships transforms_{train,val,test}.json; each split loads its own frames. */
MF_TEST(ds_capture_nerf_synthetic_splits) {
    const char *dir = mf_test_path("cap_nerfsyn");
    const char *splits[3] = {"train", "val", "test"};
    for (int s = 0; s < 3; ++s) {
        char p[MF_PATH_MAX], json[1024];
        snprintf(p, sizeof p, "%s/%s/r_%d.png", dir, splits[s], s);
        write_png(p, 4, 4, 4, 0);
        snprintf(json, sizeof json, "{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./%s/r_%d\", \"transform_matrix\": " C2W(4) "}]}",
                 splits[s], s);
        snprintf(p, sizeof p, "%s/transforms_%s.json", dir, splits[s]);
        write_text(p, json);
    }
    for (int s = 0; s < 3; ++s) {
        DsViews v;
        CHECK_OK(ds_load(dir, splits[s], NULL, &v));
        if (mf_test_failed_now()) return;
        char want[8];
        snprintf(want, sizeof want, "r_%d", s);
        CHECK(v.n == 1 && !strcmp(v.views[0].name, want));
        ds_views_free(&v);
    }
}

/* Mean |alpha rendered from cam - view's mask| over the image: how well a camera explains the
 * capture's silhouette. */
static double silhouette_error(const MfRenderInput *in, const MfCamera *cam, const DsView *v) {
    MfRenderOpts ro = {1, 16, 7, MF_LOBE_ALL};
    MfRenderOut out = {0};
    double e = 0.0;
    if (mf_render(in, cam, &ro, &out, NULL)) return 1e9;
    int n = out.w * out.h;
    for (int p = 0; p < n; ++p) e += fabs((double)out.alpha[p] - v->rgba.data[4 * p + 3]);
    mf_render_out_free(&out);
    return e / n;
}

/* mf gen --layout ingp (ds_write_capture): the capture loads with the lens it was rendered with
 * (global on even frames, the frame's own on odd ones), which is not what camera_angle_x says,
 * and the images were rendered with it: the loaded cameras explain the masks, camera_angle_x's do
 * not. */
MF_TEST(ds_capture_gen_intrinsics) {
    const char *dir = mf_test_path("cap_gen");
    DsObject o;
    CHECK_OK(ds_object_generate(&o, DS_FAM_BOX, 5, 16));
    if (mf_test_failed_now()) return;
    DsCaptureSpec s = ds_capture_spec_default(32);
    s.n_frames = 9, s.spp_sqrt = 1, s.pixel_samples = 4;
    CHECK_OK(ds_write_capture(&s, &o, 5, dir));
    DsViews v = {0};
    CHECK_OK(ds_load(dir, "train", NULL, &v));
    if (mf_test_failed_now()) { ds_object_free(&o); return; }
    CHECK(v.n == 7 && v.w == 32 && v.h == 24 && !strcmp(v.views[0].name, "r_001")); /* frames 0 and 8 are held out */
    double f_ax = 32.0 / (2.0 * tan(DS_CAMERA_ANGLE_X / 2.0));
    for (int i = 0; i < v.n && i < 2; ++i) {
        const MfCamera *c = &v.views[i].cam;
        int odd = i == 0; /* views[0] is frame 1 */
        double z = odd ? DS_CAPTURE_LENS2_ZOOM : 1.0;
        CHECK_NEAR(c->fx, s.fl_x * z, 1e-3);
        CHECK_NEAR(c->fy, s.fl_y * z, 1e-3);
        CHECK_NEAR(c->cx, odd ? 32 - s.cx : s.cx, 1e-3);
        CHECK_NEAR(c->cy, odd ? 24 - s.cy : s.cy, 1e-3);
        CHECK_MSG(fabs(c->fx - f_ax) > 0.05 * f_ax && fabs(c->fy - c->fx) > 0.05 * c->fx && fabs(c->cx - 16) > 1 && fabs(c->cy - 12) > 1,
                  "view %d: fx %g fy %g cx %g cy %g are (close to) camera_angle_x's %g, square, centred", i, c->fx, c->fy, c->cx, c->cy, f_ax);
    }
    /* the renders used those cameras: silhouettes match the loaded ones, not camera_angle_x's */
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&o.mesh, &rt));
    if (rt) {
        MfTexMaterial mat = {&o.kd, &o.orm, mf_v3s(0.5f), mf_v3(1, 0.5f, 0), NULL};
        MfRenderInput in = {rt, &o.mesh, &mat, 1, NULL, NULL, 0};
        double e_loaded = 0, e_ax = 0;
        for (int i = 0; i < v.n; ++i) {
            MfCamera ax;
            double m[16];
            for (int k = 0; k < 16; ++k) m[k] = v.views[i].cam.c2w.m[k];
            CHECK_OK(mf_camera_init(&ax, v.w, v.h, DS_CAMERA_ANGLE_X, m, "ax"));
            e_loaded += silhouette_error(&in, &v.views[i].cam, &v.views[i]) / v.n;
            e_ax += silhouette_error(&in, &ax, &v.views[i]) / v.n;
        }
        printf("    silhouette error: loaded cameras %.4f, camera_angle_x cameras %.4f\n", e_loaded, e_ax);
        CHECK_MSG(e_loaded < 0.01 && e_ax > 5 * e_loaded, "silhouette error %.4f (loaded) vs %.4f (camera_angle_x)", e_loaded, e_ax);
        mf_rtscene_free(rt);
    }
    /* RGB frames with their masks (mask_path): alpha is the coverage, not 1 */
    int bg = 0;
    for (int p = 0; p < v.w * v.h; ++p) bg += v.views[1].rgba.data[4 * p + 3] == 0.0f;
    CHECK_MSG(bg > 0, "no background pixel in the masked view");
    ds_views_free(&v);
    /* distortion is written, so the capture is refused with the file and the key */
    const char *d2 = mf_test_path("cap_gen_k1"), *d3 = mf_test_path("cap_gen_p2");
    s.n_frames = 2, s.w = 8, s.h = 6, s.cx = 4.4, s.cy = 2.7;
    s.fl_x = 9, s.fl_y = 10;
    s.distortion[0] = 0.05;
    CHECK_OK(ds_write_capture(&s, &o, 5, d2));
    CHECK_ERR(ds_load(d2, "test", NULL, &v), "cap_gen_k1/transforms.json: k1 = 0.05: lens distortion is not supported");
    s.distortion[0] = 0.0, s.distortion[3] = -0.001;
    CHECK_OK(ds_write_capture(&s, &o, 5, d3));
    CHECK_ERR(ds_load(d3, "train", NULL, &v), "cap_gen_p2/transforms.json: p2 = -0.001: lens distortion is not supported");
    /* a principal point outside the image is refused before anything is written */
    s.distortion[3] = 0.0, s.cx = 9;
    CHECK_ERR(ds_write_capture(&s, &o, 5, mf_test_path("cap_gen_bad")), "principal point (9, 2.7) lies outside the 8x6 image");
    CHECK(!mf_file_exists(mf_test_path("cap_gen_bad")));
    ds_object_free(&o);
}
