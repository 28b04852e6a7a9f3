/* Tests of datasets/ds_load: fixtures written in each exact layout (NeRF-synthetic, NeRFactor,
 * Stanford-ORB, bvault), loaded back; cameras, sRGB decode, masks, GT, relighting, detection,
 * errors (missing files and keys, wrong counts, truncated PNG, size mismatch, NaN in EXR).
 * Captures as users have them (issue 15, item 5): instant-ngp / nerfstudio transforms.json with
 * intrinsics (global and per frame, non-square pixels, moved principal point), the hold-out
 * split rule, distortion and camera models refused by name, masks from --mask DIR or mask_path,
 * RGB frames without a mask (alpha 1), duplicate base names refused, NeRF-Synthetic val/test. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_load.h"
#include "io/mf_exr.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

#define ANGLE 0.6911

static void write_text(const char *path, const char *text) {
    mf_mkdirs_for(path);
    FILE *f = fopen(path, "w");
    if (f) { fputs(text, f); fclose(f); }
}

static const char *pj(const char *a, const char *b) {
    static char buf[8][MF_PATH_MAX];
    static int k = 0;
    char *o = buf[k++ & 7];
    snprintf(o, MF_PATH_MAX, "%s/%s", a, b);
    return o;
}

/* Camera k of a fixture: on a circle, looking at the origin. */
static MfMat4 fixture_c2w(int k) {
    float a = 0.7f * (float)k + 0.3f;
    return mf_mat4_look_at(mf_v3(1.7f * cosf(a), 1.7f * sinf(a), 0.4f + 0.1f * (float)k), mf_v3(0, 0, 0), mf_v3(0, 0, 1));
}

static void mat_json(char *out, size_t cap, MfMat4 m) {
    snprintf(out, cap, "[[%.9g,%.9g,%.9g,%.9g],[%.9g,%.9g,%.9g,%.9g],[%.9g,%.9g,%.9g,%.9g],[%.9g,%.9g,%.9g,%.9g]]", m.m[0], m.m[1],
             m.m[2], m.m[3], m.m[4], m.m[5], m.m[6], m.m[7], m.m[8], m.m[9], m.m[10], m.m[11], m.m[12], m.m[13], m.m[14], m.m[15]);
}

/* Integer code (0..255) of channel c at pixel (x, y) of fixture image k. */
static int code(int k, int x, int y, int c) { return (x * 29 + y * 13 + c * 71 + k * 5) % 256; }

/* An RGBA image whose stored PNG codes are code(): written as LINEAR so the file holds exactly
 * those codes; bits 8 or 16 (16-bit codes are code * 257). */
static void write_coded_png(const char *path, int k, int w, int h, int c, int bits) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, c);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int ch = 0; ch < c; ++ch) mf_image_px(&im, x, y)[ch] = (float)code(k, x, y, ch) / 255.0f;
    mf_mkdirs_for(path);
    CHECK_OK(mf_image_write(path, &im, MF_ENC_LINEAR, bits));
    mf_image_free(&im);
}

/* Writes transforms_<split>.json with n frames; file_path "./<split>/r_<i>" (no extension) except
 * the last, which carries ".png". skip_tm: frame index without transform_matrix; short_tm:
 * frame index with 15 numbers. */
static void write_transforms(const char *dir, const char *split, int n, int skip_tm, int short_tm) {
    char buf[16384], m[1024];
    int o = snprintf(buf, sizeof buf, "{\"camera_angle_x\": %.9g, \"frames\": [", ANGLE);
    for (int i = 0; i < n; ++i) {
        mat_json(m, sizeof m, fixture_c2w(i));
        if (i == short_tm) snprintf(m, sizeof m, "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0]]");
        o += snprintf(buf + o, sizeof buf - o, "%s{\"file_path\": \"./%s/r_%d%s\"", i ? "," : "", split, i, i == n - 1 ? ".png" : "");
        if (i != skip_tm) o += snprintf(buf + o, sizeof buf - o, ", \"rotation\": 0.1, \"transform_matrix\": %s", m);
        o += snprintf(buf + o, sizeof buf - o, "}");
    }
    snprintf(buf + o, sizeof buf - o, "]}\n");
    char name[64];
    snprintf(name, sizeof name, "transforms_%s.json", split);
    write_text(pj(dir, name), buf);
}

static void make_nerf_scene(const char *dir, int n) {
    write_transforms(dir, "train", n, -1, -1);
    write_transforms(dir, "test", 2, -1, -1);
    for (int i = 0; i < n; ++i) {
        char p[64];
        snprintf(p, sizeof p, "train/r_%d.png", i);
        write_coded_png(pj(dir, p), i, 8, 8, 4, 8);
    }
    for (int i = 0; i < 2; ++i) {
        char p[64];
        snprintf(p, sizeof p, "test/r_%d.png", i);
        write_coded_png(pj(dir, p), 10 + i, 8, 8, 4, 8);
    }
}

static void check_cam(const MfCamera *cam, int k, int w) {
    MfMat4 m = fixture_c2w(k);
    CHECK_NEAR(cam->fx, w / (2.0 * tan(ANGLE / 2.0)), 1e-4);
    CHECK_NEAR(cam->fy, cam->fx, 0);
    CHECK_NEAR(cam->cx, w / 2.0, 0);
    float worst = 0.0f;
    for (int i = 0; i < 16; ++i) worst = fmaxf(worst, fabsf(cam->c2w.m[i] - m.m[i]));
    CHECK_MSG(worst < 1e-6f, "c2w differs by %g", worst);
}

/* sRGB decode of fixture codes in colour, linear alpha. */
static void check_pixels(const MfImage *im, int k, int bits) {
    double worst = 0.0;
    for (int y = 0; y < im->h; ++y)
        for (int x = 0; x < im->w; ++x)
            for (int c = 0; c < 4; ++c) {
                float s = (float)code(k, x, y, c) / 255.0f;
                float want = c < 3 ? mf_srgb_to_linear(s) : s;
                worst = fmax(worst, fabs(mf_image_px(im, x, y)[c] - want));
            }
    CHECK_MSG(worst < (bits == 8 ? 1e-6 : 2e-5), "pixel decode worst error %g", worst);
}

MF_TEST(ds_load_nerf_synthetic) {
    const char *dir = mf_test_path("nerf_scene");
    make_nerf_scene(dir, 3);
    CHECK(ds_detect_format(dir) == DS_FMT_NERF_SYNTHETIC);
    DsViews v = {0};
    CHECK_OK(ds_load_nerf_synthetic(dir, "train", NULL, &v));
    CHECK(v.n == 3 && v.w == 8 && v.h == 8 && v.format == DS_FMT_NERF_SYNTHETIC);
    for (int i = 0; i < v.n; ++i) {
        CHECK(v.views[i].rgba.c == 4);
        check_cam(&v.views[i].cam, i, 8);
        check_pixels(&v.views[i].rgba, i, 8);
        CHECK(v.views[i].albedo.data == NULL);
    }
    CHECK(!strcmp(v.views[0].name, "r_0") && !strcmp(v.views[2].name, "r_2"));
    CHECK(strstr(v.views[0].image_path, "train/r_0.png") != NULL);
    ds_views_free(&v);
    /* test split via auto-detection; max_views; downsample */
    DsLoadOptions o = {1, 1, 2, 0, NULL, 0};
    CHECK_OK(ds_load(dir, "test", &o, &v));
    CHECK(v.n == 1 && v.w == 4 && v.h == 4 && v.views[0].rgba.w == 4);
    if (v.n == 1) {
        CHECK_NEAR(v.views[0].cam.fx, 4 / (2.0 * tan(ANGLE / 2.0)), 1e-4);
        /* alpha of a 2x2 block is the mean */
        double a = 0;
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 2; ++x) a += code(10, x, y, 3) / 255.0 / 4.0;
        CHECK_NEAR(mf_image_px(&v.views[0].rgba, 0, 0)[3], a, 1e-6);
    }
    ds_views_free(&v);
    /* missing val split: a clear error, output untouched */
    v.n = 12345;
    CHECK_ERR(ds_load_nerf_synthetic(dir, "val", NULL, &v), "transforms_val.json");
    CHECK(v.n == 12345);
}

MF_TEST(ds_load_errors) {
    DsViews v = {0};
    v.n = 777;
    /* missing transform_matrix */
    const char *d1 = mf_test_path("err_missing_tm");
    make_nerf_scene(d1, 3);
    write_transforms(d1, "train", 3, 2, -1);
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "transforms_train.json: frames[2].transform_matrix: missing");
    /* wrong count */
    write_transforms(d1, "train", 3, -1, 1);
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "frames[1].transform_matrix: expected 4x4 numbers");
    /* missing image, named */
    write_transforms(d1, "train", 3, -1, -1);
    unlink(pj(d1, "train/r_1.png"));
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "train/r_1.png: no such file");
    /* truncated PNG */
    write_coded_png(pj(d1, "train/r_1.png"), 1, 8, 8, 4, 8);
    CHECK_OK(truncate(pj(d1, "train/r_1.png"), 60));
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "train/r_1.png");
    /* mismatched sizes within a split */
    write_coded_png(pj(d1, "train/r_1.png"), 1, 16, 8, 4, 8);
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "train/r_1.png: image is 16x8, the split's first image is 8x8");
    /* several bad frames: the first in frame order is reported, whatever the thread count */
    make_nerf_scene(d1, 6);
    write_coded_png(pj(d1, "train/r_4.png"), 1, 16, 8, 4, 8);
    unlink(pj(d1, "train/r_2.png"));
    int nt = omp_get_max_threads();
    for (int t = 1; t <= 4; t += 3) {
        omp_set_num_threads(t);
        CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "train/r_2.png: no such file");
    }
    omp_set_num_threads(nt);
    write_coded_png(pj(d1, "train/r_2.png"), 2, 8, 8, 4, 8);
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "train/r_4.png: image is 16x8");
    make_nerf_scene(d1, 3);
    /* non-rigid matrix */
    write_coded_png(pj(d1, "train/r_1.png"), 1, 8, 8, 4, 8);
    write_text(pj(d1, "transforms_train.json"),
               "{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": "
               "[[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}");
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "frames[0]: transform_matrix is not a rigid transform");
    /* bad JSON */
    write_text(pj(d1, "transforms_train.json"), "{\"camera_angle_x\": 0.69, \"frames\": [\n{]}");
    CHECK_ERR(ds_load_nerf_synthetic(d1, "train", NULL, &v), "transforms_train.json");
    /* unknown layout */
    CHECK_ERR(ds_load(mf_test_path("nothing_here"), "train", NULL, &v), "unknown data set layout");
    CHECK(v.n == 777);
}

/* ---- NeRFactor ---- */

static void make_nerfactor_view(const char *dir, const char *vname, int k, int w, int h) {
    char vd[MF_PATH_MAX], meta[2048];
    snprintf(vd, sizeof vd, "%s/%s", dir, vname);
    MfMat4 m = fixture_c2w(k);
    int o = snprintf(meta, sizeof meta, "{\"cam_transform_mat\": \"");
    for (int i = 0; i < 16; ++i) o += snprintf(meta + o, sizeof meta - o, "%s%.9g", i ? "," : "", m.m[i]);
    snprintf(meta + o, sizeof meta - o, "\", \"cam_angle_x\": %.9g, \"imh\": %d, \"imw\": %d, \"envmap\": \"city\"}", ANGLE, h, w);
    write_text(pj(vd, "metadata.json"), meta);
    write_coded_png(pj(vd, "rgba.png"), k, w, h, 4, 16);
    write_coded_png(pj(vd, "albedo.png"), k + 1, w, h, 3, 16);
    write_coded_png(pj(vd, "normal.png"), k + 2, w, h, 3, 16);
    write_coded_png(pj(vd, "rgba_sunset.png"), k + 3, w, h, 4, 16);
    write_coded_png(pj(vd, "rgba_courtyard.png"), k + 4, w, h, 4, 16);
}

MF_TEST(ds_load_nerfactor) {
    const char *dir = mf_test_path("nerfactor_scene");
    for (int i = 0; i < 3; ++i) {
        char n[32];
        snprintf(n, sizeof n, "train_%03d", i);
        make_nerfactor_view(dir, n, i, 8, 8);
    }
    make_nerfactor_view(dir, "val_000", 9, 8, 8);
    make_nerfactor_view(dir, "test_000", 20, 8, 8);
    CHECK(ds_detect_format(dir) == DS_FMT_NERFACTOR);
    DsViews v = {0};
    CHECK_OK(ds_load(dir, "train", NULL, &v));
    CHECK(v.n == 3 && v.format == DS_FMT_NERFACTOR && !strcmp(v.env_path, "city"));
    for (int i = 0; i < v.n; ++i) {
        CHECK(!strcmp(v.views[i].name, (const char *[]){"train_000", "train_001", "train_002"}[i]));
        check_cam(&v.views[i].cam, i, 8);
        check_pixels(&v.views[i].rgba, i, 16);
        /* albedo linear, normal mapped to [-1, 1] */
        CHECK(v.views[i].albedo.data && v.views[i].normal.data);
        if (v.views[i].albedo.data) CHECK_NEAR(mf_image_px(&v.views[i].albedo, 3, 2)[1], code(i + 1, 3, 2, 1) / 255.0, 2e-5);
        if (v.views[i].normal.data) CHECK_NEAR(mf_image_px(&v.views[i].normal, 1, 5)[2], 2.0 * code(i + 2, 1, 5, 2) / 255.0 - 1.0, 4e-5);
    }
    /* relighting probes found (sorted), relit image read as sRGB */
    CHECK(v.n_relight == 2 && !strcmp(v.relight_name[0], "courtyard") && !strcmp(v.relight_name[1], "sunset"));
    MfImage r = {0};
    CHECK_OK(ds_load_relit(&v, 1, 1, &r));
    if (r.data) {
        CHECK(r.c == 4);
        CHECK_NEAR(mf_image_px(&r, 2, 3)[0], mf_srgb_to_linear(code(1 + 3, 2, 3, 0) / 255.0f), 2e-5);
    }
    mf_image_free(&r);
    ds_views_free(&v);
    /* errors: malformed matrix string, size disagreeing with metadata */
    write_text(pj(dir, "test_000/metadata.json"), "{\"cam_transform_mat\": \"1,0,0,0,0,1,0,0,0,0,1,0,0,0,0\", \"cam_angle_x\": 0.69, \"imh\": 8, \"imw\": 8}");
    CHECK_ERR(ds_load_nerfactor(dir, "test", NULL, &v), "test_000/metadata.json: cam_transform_mat: expected 16 comma-separated numbers");
    write_text(pj(dir, "test_000/metadata.json"), "{\"cam_transform_mat\": \"1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\", \"cam_angle_x\": 0.69, \"imh\": 8, \"imw\": 16}");
    CHECK_ERR(ds_load_nerfactor(dir, "test", NULL, &v), "metadata.json says imw 16");
    write_text(pj(dir, "test_000/metadata.json"), "{\"cam_transform_mat\": \"1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\", \"imh\": 8, \"imw\": 8}");
    CHECK_ERR(ds_load_nerfactor(dir, "test", NULL, &v), "test_000/metadata.json: cam_angle_x: missing");
    CHECK_ERR(ds_load_nerfactor(dir, "nope", NULL, &v), "no nope_NNN folders");
    /* downsampled: normals and albedo follow */
    DsLoadOptions o2 = {1, 2, 2, 0, NULL, 0};
    CHECK_OK(ds_load_nerfactor(dir, "train", &o2, &v));
    CHECK(v.n == 2 && v.w == 4 && v.views[1].normal.w == 4 && v.views[1].albedo.h == 4);
    if (v.n == 2) CHECK_NEAR(v.views[1].cam.fx, 4 / (2.0 * tan(ANGLE / 2.0)), 1e-4);
    ds_views_free(&v);
    /* a view whose size disagrees with the split's first */
    make_nerfactor_view(dir, "train_002", 2, 16, 8);
    CHECK_ERR(ds_load_nerfactor(dir, "train", NULL, &v), "train_002/rgba.png: image is 16x8, the split's first image is 8x8");
    make_nerfactor_view(dir, "train_002", 2, 8, 8);
    /* matrix as a JSON array (flat or nested) */
    write_text(pj(dir, "test_000/metadata.json"), "{\"cam_transform_mat\": [1,0,0,0, 0,1,0,0, 0,0,1,2.5, 0,0,0,1], \"cam_angle_x\": 0.69, \"imh\": 8, \"imw\": 8}");
    CHECK_OK(ds_load_nerfactor(dir, "test", NULL, &v));
    CHECK(v.n == 1 && v.views[0].cam.c2w.m[11] == 2.5f);
    ds_views_free(&v);
    write_text(pj(dir, "test_000/metadata.json"), "{\"cam_transform_mat\": [[1,0,0,0],[0,1,0,0],[0,0,1,2.5]], \"cam_angle_x\": 0.69, \"imh\": 8, \"imw\": 8}");
    CHECK_ERR(ds_load_nerfactor(dir, "test", NULL, &v), "cam_transform_mat: expected 4x4 numbers");
}

/* ---- Stanford-ORB ---- */

static void write_exr_rgb(const char *path, int k, int w, int h, float nan_at) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, 3);
    for (int i = 0; i < w * h * 3; ++i) im.data[i] = 0.01f * (float)((i * 7 + k * 3) % 50) + (i % 3 == 0 ? 2.5f : 0.0f);
    if (nan_at >= 0) im.data[(int)nan_at] = NAN;
    mf_mkdirs_for(path);
    CHECK_OK(mf_exr_write_image(path, &im, "", MF_EXR_FLOAT | (nan_at >= 0 ? MF_EXR_ALLOW_NONFINITE : 0)));
    mf_image_free(&im);
}

static void make_orb_capture(const char *root, const char *cap, const char *other) {
    char cd[MF_PATH_MAX], buf[8192], m[1024];
    snprintf(cd, sizeof cd, "%s/blender_HDR/%s", root, cap);
    const char *splits[] = {"train", "test"};
    for (int s = 0; s < 2; ++s) {
        int o = snprintf(buf, sizeof buf, "{\"camera_angle_x\": %.9g, \"frames\": [", ANGLE);
        for (int i = 0; i < 2; ++i) {
            mat_json(m, sizeof m, fixture_c2w(i + 3 * s));
            o += snprintf(buf + o, sizeof buf - o, "%s{\"file_path\": \"./%s/%04d\", \"transform_matrix\": %s}", i ? "," : "", splits[s], i, m);
            char p[MF_PATH_MAX];
            snprintf(p, sizeof p, "%s/%s/%04d.exr", cd, splits[s], i);
            write_exr_rgb(p, i + 3 * s, 8, 8, -1);
            snprintf(p, sizeof p, "%s/%s_mask/%04d.png", cd, splits[s], i);
            write_coded_png(p, i + 3 * s, 8, 8, 1, 8);
            if (s == 1) {
                snprintf(p, sizeof p, "%s/ground_truth/%s/env_map/%04d.exr", root, cap, i);
                write_exr_rgb(p, 40 + i, 16, 8, -1);
            }
        }
        snprintf(buf + o, sizeof buf - o, "]}");
        char name[64];
        snprintf(name, sizeof name, "transforms_%s.json", splits[s]);
        write_text(pj(cd, name), buf);
    }
    /* novel: frames of the other capture with their own camera_angle_x */
    mat_json(m, sizeof m, fixture_c2w(7));
    snprintf(buf, sizeof buf, "{\"frames\": [{\"file_path\": \"./test/0001\", \"scene_name\": \"%s\", \"camera_angle_x\": 0.5, \"transform_matrix\": %s}]}", other, m);
    write_text(pj(cd, "transforms_novel.json"), buf);
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/ground_truth/%s/mesh_blender/mesh.obj", root, cap);
    write_text(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
}

MF_TEST(ds_load_stanford_orb) {
    const char *root = mf_test_path("orb");
    make_orb_capture(root, "cactus_scene001", "cactus_scene002");
    make_orb_capture(root, "cactus_scene002", "cactus_scene001");
    DsViews v = {0};
    CHECK_OK(ds_load_stanford_orb(root, "cactus_scene001", "test", NULL, &v));
    CHECK(v.n == 2 && v.format == DS_FMT_STANFORD_ORB && strstr(v.mesh_path, "mesh_blender/mesh.obj"));
    for (int i = 0; i < v.n; ++i) {
        check_cam(&v.views[i].cam, i + 3, 8);
        /* HDR colour kept linear (> 1 survives), alpha from the mask PNG (linear) */
        CHECK_NEAR(mf_image_px(&v.views[i].rgba, 0, 0)[0], 0.01f * (float)((0 + (i + 3) * 3) % 50) + 2.5f, 1e-6);
        CHECK_NEAR(mf_image_px(&v.views[i].rgba, 5, 6)[3], code(i + 3, 5, 6, 0) / 255.0, 1e-6);
        CHECK(strstr(v.views[i].env_path, "ground_truth/cactus_scene001/env_map/") != NULL);
    }
    ds_views_free(&v);
    /* novel: image from the other capture's test folder, own camera_angle_x */
    CHECK_OK(ds_load_stanford_orb(root, "cactus_scene001", "novel", NULL, &v));
    CHECK(v.n == 1);
    if (v.n == 1) {
        CHECK(strstr(v.views[0].image_path, "cactus_scene002/test/0001.exr") != NULL);
        CHECK(!strcmp(v.views[0].scene_name, "cactus_scene002"));
        CHECK_NEAR(v.views[0].camera_angle_x, 0.5, 0);
        CHECK_NEAR(v.views[0].cam.fx, 8 / (2.0 * tan(0.25)), 1e-4);
        CHECK_NEAR(mf_image_px(&v.views[0].rgba, 1, 1)[3], code(4, 1, 1, 0) / 255.0, 1e-6);
    }
    ds_views_free(&v);
    /* auto-detection from the capture folder */
    char cd[MF_PATH_MAX];
    snprintf(cd, sizeof cd, "%s/blender_HDR/cactus_scene001", root);
    CHECK(ds_detect_format(cd) == DS_FMT_STANFORD_ORB);
    CHECK_OK(ds_load(cd, "train", NULL, &v));
    CHECK(v.n == 2 && v.format == DS_FMT_STANFORD_ORB);
    ds_views_free(&v);
    /* NaN in an EXR: named */
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/train/0001.exr", cd);
    write_exr_rgb(p, 1, 8, 8, 17);
    v.n = 55;
    CHECK_ERR(ds_load_stanford_orb(root, "cactus_scene001", "train", NULL, &v), "train/0001.exr");
    CHECK(v.n == 55);
    /* missing mask */
    write_exr_rgb(p, 1, 8, 8, -1);
    snprintf(p, sizeof p, "%s/train_mask/0000.png", cd);
    unlink(p);
    CHECK_ERR(ds_load_stanford_orb(root, "cactus_scene001", "train", NULL, &v), "train_mask/0000.png: no such file");
}

/* blender_LDR: PNG images (sRGB) with the same masks and transforms */
MF_TEST(ds_load_stanford_orb_ldr) {
    const char *root = mf_test_path("orb_ldr");
    char cd[MF_PATH_MAX], buf[4096], m[1024], p[MF_PATH_MAX];
    snprintf(cd, sizeof cd, "%s/blender_LDR/teapot_scene001", root);
    mat_json(m, sizeof m, fixture_c2w(1));
    snprintf(buf, sizeof buf, "{\"camera_angle_x\": %.9g, \"frames\": [{\"file_path\": \"./train/0000\", \"transform_matrix\": %s}]}", ANGLE, m);
    write_text(pj(cd, "transforms_train.json"), buf);
    snprintf(p, sizeof p, "%s/train/0000.png", cd);
    write_coded_png(p, 5, 8, 8, 3, 8);
    snprintf(p, sizeof p, "%s/train_mask/0000.png", cd);
    write_coded_png(p, 6, 8, 8, 1, 8);
    DsLoadOptions o = {1, 0, 1, 1, NULL, 0};
    DsViews v = {0};
    CHECK_OK(ds_load_stanford_orb(root, "teapot_scene001", "train", &o, &v));
    CHECK(v.n == 1 && v.format == DS_FMT_STANFORD_ORB);
    if (v.n == 1) {
        check_cam(&v.views[0].cam, 1, 8);
        CHECK(strstr(v.views[0].image_path, "blender_LDR/teapot_scene001/train/0000.png") != NULL);
        CHECK_NEAR(mf_image_px(&v.views[0].rgba, 3, 4)[1], mf_srgb_to_linear(code(5, 3, 4, 1) / 255.0f), 1e-6);
        CHECK_NEAR(mf_image_px(&v.views[0].rgba, 3, 4)[3], code(6, 3, 4, 0) / 255.0, 1e-6);
    }
    ds_views_free(&v);
    /* auto-detection picks LDR from the folder name */
    CHECK_OK(ds_load(cd, "train", NULL, &v));
    CHECK(v.n == 1);
    ds_views_free(&v);
}

MF_TEST(ds_load_orb_env_to_world) {
    /* camera-frame map in ORB's layout holding f(d_cam) = d_cam + 1; the world map (Blender
     * mapping) at world direction d must hold R^T d + 1 */
    int W = 128, H = 64;
    MfImage cam = {0}, world = {0};
    CHECK_OK(mf_image_alloc(&cam, W, H, 3));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float phi = (float)y / (H - 1) * MF_PI, a = (float)x / (W - 1) * 2.0f * MF_PI - MF_PI;
            MfVec3 dc = mf_v3(sinf(phi) * sinf(a), cosf(phi), -sinf(phi) * cosf(a));
            float *q = mf_image_px(&cam, x, y);
            q[0] = dc.x + 1; q[1] = dc.y + 1; q[2] = dc.z + 1;
        }
    MfMat4 c2w = fixture_c2w(2);
    CHECK_OK(ds_orb_env_to_world(&cam, &c2w, &world));
    double err = 0, worst = 0;
    int n = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float u = (x + 0.5f) / W, v = 1.0f - (y + 0.5f) / H;
            float phi = (0.5f - u) * 2.0f * MF_PI, th = (v - 0.5f) * MF_PI;
            MfVec3 d = mf_v3(cosf(th) * cosf(phi), cosf(th) * sinf(phi), sinf(th));
            const float *m = c2w.m;
            MfVec3 dc = mf_v3(m[0] * d.x + m[4] * d.y + m[8] * d.z, m[1] * d.x + m[5] * d.y + m[9] * d.z, m[2] * d.x + m[6] * d.y + m[10] * d.z);
            const float *q = mf_image_px(&world, x, y);
            double e = (fabs(q[0] - dc.x - 1) + fabs(q[1] - dc.y - 1) + fabs(q[2] - dc.z - 1)) / 3;
            err += e;
            worst = fmax(worst, e);
            ++n;
        }
    CHECK_MSG(err / n < 3e-3, "mean error %g", err / n);
    /* where the camera looks (-z) the world map shows the camera map's centre column */
    MfVec3 fwd = mf_v3(-c2w.m[2], -c2w.m[6], -c2w.m[10]);
    float u = 0.5f - atan2f(fwd.y, fwd.x) / (2 * MF_PI), v = 0.5f + asinf(fwd.z) / MF_PI;
    int x = (int)(u * W), y = (int)((1 - v) * H);
    CHECK_NEAR(mf_image_px(&world, x % W, y)[2], 0.0, 0.1); /* d_cam.z = -1 there */
    mf_image_free(&cam);
    mf_image_free(&world);
}

/* ---- bvault ---- */

MF_TEST(ds_load_bvault) {
    const char *dir = mf_test_path("bvault_scene");
    make_nerf_scene(dir, 2);
    for (int i = 0; i < 2; ++i) {
        char p[64];
        snprintf(p, sizeof p, "gt/albedo/r_%d.png", i);
        write_coded_png(pj(dir, p), 30 + i, 8, 8, 4, 8);
        snprintf(p, sizeof p, "gt/orm/r_%d.png", i);
        write_coded_png(pj(dir, p), 40 + i, 8, 8, 4, 8);
        snprintf(p, sizeof p, "relight/sky/r_%d.exr", i);
        write_exr_rgb(pj(dir, p), 50 + i, 8, 8, -1);
    }
    write_coded_png(pj(dir, "gt/kd.png"), 1, 16, 16, 3, 8);
    write_coded_png(pj(dir, "gt/orm.png"), 2, 16, 16, 3, 8);
    write_exr_rgb(pj(dir, "gt/env.exr"), 3, 16, 8, -1);
    write_exr_rgb(pj(dir, "relight/sky.exr"), 4, 16, 8, -1);
    write_exr_rgb(pj(dir, "relight/attic.exr"), 5, 16, 8, -1);
    write_text(pj(dir, "mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK(ds_detect_format(dir) == DS_FMT_BVAULT);
    DsViews v = {0};
    CHECK_OK(ds_load(dir, "test", NULL, &v));
    CHECK(v.n == 2 && v.format == DS_FMT_BVAULT);
    CHECK(strstr(v.mesh_path, "mesh.obj") && strstr(v.env_path, "gt/env.exr") && strstr(v.kd_path, "gt/kd.png") &&
          strstr(v.orm_path, "gt/orm.png"));
    CHECK(v.n_relight == 2 && !strcmp(v.relight_name[0], "attic") && !strcmp(v.relight_name[1], "sky"));
    CHECK(strstr(v.relight_env[1], "relight/sky.exr") != NULL);
    for (int i = 0; i < v.n; ++i) {
        check_cam(&v.views[i].cam, i, 8);
        check_pixels(&v.views[i].rgba, 10 + i, 8);
        CHECK(v.views[i].albedo.data && v.views[i].albedo.c == 3 && v.views[i].orm.data);
        if (v.views[i].albedo.data) CHECK_NEAR(mf_image_px(&v.views[i].albedo, 4, 1)[2], mf_srgb_to_linear(code(30 + i, 4, 1, 2) / 255.0f), 1e-6);
        if (v.views[i].orm.data) CHECK_NEAR(mf_image_px(&v.views[i].orm, 4, 1)[1], code(40 + i, 4, 1, 1) / 255.0, 1e-6);
    }
    MfImage r = {0};
    CHECK_OK(ds_load_relit(&v, 1, 1, &r));
    if (r.data) {
        CHECK(r.c == 4 && r.w == 8);
        CHECK_NEAR(mf_image_px(&r, 0, 0)[0], 0.01f * (float)((51 * 3) % 50) + 2.5f, 1e-6);
        CHECK_NEAR(mf_image_px(&r, 0, 0)[3], 1.0, 0);
    }
    mf_image_free(&r);
    CHECK_ERR(ds_load_relit(&v, 0, 0, &r), "relight/attic/r_0.exr: no such file");
    ds_views_free(&v);
    /* GT skipped on request */
    DsLoadOptions o = {0, 0, 1, 0, NULL, 0};
    CHECK_OK(ds_load_bvault(dir, "test", &o, &v));
    CHECK(v.n == 2 && v.views[0].albedo.data == NULL);
    ds_views_free(&v);
}

/* ds_views_keep_side: the views whose camera is on the +x side of the centre, in order, at most N;
 * the others' images freed; none kept is an error naming the folder. */
MF_TEST(ds_views_keep_side) {
    const float xs[6] = {1.0f, -1.0f, 2.0f, -0.5f, 0.5f, 3.0f};
    DsViews v;
    memset(&v, 0, sizeof v);
    snprintf(v.dir, sizeof v.dir, "scene_dir");
    snprintf(v.split, sizeof v.split, "train");
    v.n = 6;
    v.views = calloc(6, sizeof *v.views);
    CHECK(v.views != NULL);
    for (int i = 0; i < 6; ++i) {
        double c2w[16] = {1, 0, 0, xs[i], 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1};
        CHECK_OK(mf_camera_init(&v.views[i].cam, 4, 4, ANGLE, c2w, "test"));
        CHECK_OK(mf_image_alloc(&v.views[i].rgba, 4, 4, 4));
        snprintf(v.views[i].name, DS_NAME_MAX, "r_%d", i);
    }
    /* centre x = 0.75: kept are x = 1, 2, 3 (names r_0, r_2, r_5); max 2 keeps r_0, r_2 */
    CHECK_OK(ds_views_keep_side(&v, mf_v3(0.75f, 0, 0), mf_v3(1, 0, 0), 2));
    CHECK(v.n == 2);
    CHECK(!strcmp(v.views[0].name, "r_0") && !strcmp(v.views[1].name, "r_2"));
    CHECK(v.views[1].rgba.data != NULL);
    /* nothing above z = 5: an error naming the folder */
    CHECK_ERR(ds_views_keep_side(&v, mf_v3(0, 0, 5), mf_v3(0, 0, 1), 0), "scene_dir");
    CHECK(v.n == 0);
    ds_views_free(&v);
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
