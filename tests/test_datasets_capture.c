/* Captures as users have them (issue 15, item 5): instant-ngp / nerfstudio transforms.json with
 * intrinsics (global and per frame, non-square pixels, moved principal point), the hold-out
 * split rule, distortion and camera models refused by name, masks from --mask DIR or mask_path,
 * RGB frames without a mask (alpha 1), duplicate base names refused, NeRF-Synthetic val/test. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_load.h"
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
    DsLoadOptions o = {0, 0, 2, 0, NULL};
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
    DsLoadOptions o = {0, 0, 1, 0, md};
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
    DsLoadOptions rel = {0, 0, 1, 0, "masks"}; /* relative: inside the scene folder */
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
