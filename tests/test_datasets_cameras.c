/* Tests of datasets/ds_cameras (sampling ranges, determinism, look-at, transforms writer read
 * back by the NeRF-synthetic loader) and ds_object_write (OBJ + textures in the bvault layout). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_load.h"
#include "datasets/ds_shapes.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

MF_TEST(ds_cameras_sampling) {
    DsCamSampling s = ds_cam_sampling_default();
    CHECK_NEAR(s.camera_angle_x, 0.6911, 0);
    enum { N = 400 };
    static MfMat4 a[N], b[N], c[N];
    CHECK_OK(ds_sample_cameras(&s, N, 5, 0, a));
    CHECK_OK(ds_sample_cameras(&s, N, 5, 0, b));
    CHECK_OK(ds_sample_cameras(&s, N, 5, 1, c));
    CHECK(!memcmp(a, b, sizeof a));
    CHECK(memcmp(a, c, sizeof a) != 0);
    int octant[8] = {0}, above = 0;
    for (int i = 0; i < N; ++i) {
        MfVec3 eye = mf_v3(a[i].m[3], a[i].m[7], a[i].m[11]);
        float r = mf_len(eye), el = asinf(eye.z / r) * 180.0f / MF_PI;
        CHECK(r >= 1.5f - 1e-5f && r <= 2.0f + 1e-5f);
        CHECK(el >= -15.0f - 1e-3f && el <= 90.0f + 1e-3f);
        /* looks at the origin: -z axis (third column negated) points from eye to origin */
        MfVec3 fwd = mf_v3(-a[i].m[2], -a[i].m[6], -a[i].m[10]);
        CHECK_NEAR(mf_dot(fwd, mf_scale(eye, -1.0f / r)), 1.0, 1e-5);
        /* rigid, camera x axis horizontal (no roll) */
        double c2w[16];
        for (int k = 0; k < 16; ++k) c2w[k] = a[i].m[k];
        MfCamera cam;
        CHECK_OK(mf_camera_init(&cam, 8, 8, s.camera_angle_x, c2w, "sampled"));
        if (el < 89.0f) CHECK_NEAR(a[i].m[8], 0.0, 1e-5);
        octant[(eye.x > 0) + 2 * (eye.y > 0) + 4 * (eye.z > 0)]++;
        above += eye.z > 0;
    }
    /* azimuth covers all quadrants; elevation uniform in sin(el) over [-15, 90]: P(z > 0) = 1 / (1 + sin 15) */
    for (int k = 4; k < 8; ++k) CHECK_MSG(octant[k] > N / 8, "octant %d: %d", k, octant[k]);
    CHECK_NEAR((double)above / N, 1.0 / (1.0 + sin(15.0 * M_PI / 180.0)), 0.06);
    DsCamSampling bad = s;
    bad.r_min = -1;
    CHECK_ERR(ds_sample_cameras(&bad, 3, 1, 0, a), "ranges are invalid");
}

MF_TEST(ds_cameras_transforms_roundtrip) {
    const char *dir = mf_test_path("gen_scene");
    DsCamSampling s = ds_cam_sampling_default();
    MfMat4 c2w[5];
    CHECK_OK(ds_sample_cameras(&s, 5, 9, 0, c2w));
    CHECK_OK(ds_write_transforms(dir, "train", s.camera_angle_x, c2w, 5));
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 8, 6, 4));
    for (int i = 0; i < 5; ++i) {
        char p[MF_PATH_MAX];
        snprintf(p, sizeof p, "%s/train/r_%03d.png", dir, i);
        mf_mkdirs_for(p);
        CHECK_OK(mf_image_write(p, &im, MF_ENC_SRGB, 8));
    }
    mf_image_free(&im);
    DsViews v = {0};
    CHECK_OK(ds_load(dir, "train", NULL, &v));
    CHECK(v.n == 5 && v.w == 8 && v.h == 6);
    for (int i = 0; i < v.n; ++i) {
        CHECK(!strcmp(v.views[i].name, (const char *[]){"r_000", "r_001", "r_002", "r_003", "r_004"}[i]));
        for (int k = 0; k < 16; ++k) CHECK(v.views[i].cam.c2w.m[k] == c2w[i].m[k]); /* %.9g round-trips floats */
        CHECK_NEAR(v.views[i].camera_angle_x, 0.6911, 1e-12);
    }
    ds_views_free(&v);
}

MF_TEST(ds_object_write_bvault_layout) {
    DsObject o = {0};
    CHECK_OK(ds_object_generate(&o, DS_FAM_CLOCK, 4, 64));
    const char *dir = mf_test_path("gen_obj");
    CHECK_OK(ds_object_write(&o, dir));
    char p[MF_PATH_MAX];
    MfMesh m = {0};
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    CHECK_OK(mf_obj_read(p, &m));
    CHECK(m.nt == o.mesh.nt && m.nv == o.mesh.nv && m.uv && m.nrm);
    CHECK(m.nmat == o.nparts);
    MfVec3 lo, hi;
    mf_mesh_bounds(&m, &lo, &hi);
    CHECK_NEAR(mf_maxc(mf_sub(hi, lo)), 1.0, 1e-5);
    mf_mesh_free(&m);
    cJSON *oj = NULL;
    snprintf(p, sizeof p, "%s/gt/object.json", dir);
    CHECK_OK(mf_json_load(p, &oj));
    if (oj) {
        CHECK(!strcmp(cJSON_GetObjectItem(oj, "family")->valuestring, "clock"));
        const cJSON *parts = cJSON_GetObjectItem(oj, "parts");
        CHECK(cJSON_GetArraySize(parts) == o.nparts);
        CHECK(!strcmp(cJSON_GetObjectItem(cJSON_GetArrayItem(parts, 1), "name")->valuestring, "face"));
        CHECK(!strcmp(cJSON_GetObjectItem(cJSON_GetArrayItem(parts, 1), "pattern")->valuestring, "ticks"));
    }
    cJSON_Delete(oj);
    MfImage kd = {0}, orm = {0};
    snprintf(p, sizeof p, "%s/gt/kd.png", dir);
    CHECK_OK(mf_image_read(p, MF_ENC_SRGB, &kd));
    snprintf(p, sizeof p, "%s/gt/orm.png", dir);
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &orm));
    CHECK(kd.w == 64 && kd.c == 3 && orm.w == 64 && orm.c == 3);
    double e = 0;
    for (int i = 0; kd.data && orm.data && i < 64 * 64 * 3; ++i) {
        e = fmax(e, fabs(orm.data[i] - o.orm.data[i]));
    }
    CHECK_MSG(e <= 0.5 / 255 + 1e-6, "orm round trip error %g", e);
    mf_image_free(&kd);
    mf_image_free(&orm);
    ds_object_free(&o);
}

static void write_probe(const char *path, float v) {
    MfImage im = {0};
    mf_image_alloc(&im, 8, 4, 3);
    for (int i = 0; i < 8 * 4 * 3; ++i) im.data[i] = v;
    mf_mkdirs_for(path);
    CHECK_OK(mf_image_write(path, &im, MF_ENC_LINEAR, 32));
    mf_image_free(&im);
}

#include "datasets/ds_split.h"
#include "io/mf_json.h"

MF_TEST(ds_split_tiny_layout) {
    const char *probes = mf_test_path("probes");
    const char *names[] = {"alpha", "beta", "gamma", "delta"};
    for (int i = 0; i < 4; ++i) {
        char p[MF_PATH_MAX];
        snprintf(p, sizeof p, "%s/%s.exr", probes, names[i]);
        write_probe(p, 0.5f + i);
    }
    DsSplitSpec s;
    CHECK_OK(ds_split_spec("tiny", &s));
    CHECK(s.n_scenes == 3 && s.width == 32 && s.n_relight == 2);
    CHECK_ERR(ds_split_spec("huge", &s), "unknown split");
    CHECK_OK(ds_split_spec("tiny", &s));
    const char *out = mf_test_path("tiny");
    CHECK_OK(ds_write_split(&s, out, probes, 11));
    char p[MF_PATH_MAX];
    cJSON *list = NULL;
    snprintf(p, sizeof p, "%s/split.json", out);
    CHECK_OK(mf_json_load(p, &list));
    const cJSON *scenes = list ? cJSON_GetObjectItem(list, "scenes") : NULL;
    CHECK(cJSON_GetArraySize(scenes) == 3);
    for (int k = 0; k < cJSON_GetArraySize(scenes); ++k) {
        const cJSON *sc = cJSON_GetArrayItem(scenes, k);
        const char *name = cJSON_GetObjectItem(sc, "name")->valuestring, *tenv = cJSON_GetObjectItem(sc, "train_env")->valuestring;
        const cJSON *rl = cJSON_GetObjectItem(sc, "relight");
        CHECK(cJSON_GetArraySize(rl) == 2);
        for (int r = 0; r < cJSON_GetArraySize(rl); ++r) {
            const char *en = cJSON_GetArrayItem(rl, r)->valuestring;
            CHECK_MSG(strcmp(en, tenv) != 0, "scene %s: training light %s is also a relighting light", name, tenv);
            snprintf(p, sizeof p, "%s/%s/relight/%s.exr", out, name, en);
            CHECK(mf_file_exists(p));
            snprintf(p, sizeof p, "%s/%s/render_relight_%s.json", out, name, en);
            CHECK(mf_file_exists(p));
        }
        const char *files[] = {"mesh.obj", "mesh.mtl", "gt/kd.png", "gt/orm.png", "gt/env.exr", "transforms_train.json",
                               "transforms_test.json", "render_train.json", "render_test.json"};
        for (size_t f = 0; f < sizeof files / sizeof files[0]; ++f) {
            snprintf(p, sizeof p, "%s/%s/%s", out, name, files[f]);
            CHECK_MSG(mf_file_exists(p), "missing %s", p);
        }
        /* cameras: counts as the spec */
        cJSON *tf = NULL;
        snprintf(p, sizeof p, "%s/%s/transforms_train.json", out, name);
        CHECK_OK(mf_json_load(p, &tf));
        if (tf) CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(tf, "frames")) == 8);
        cJSON_Delete(tf);
        /* render JSON points at the scene's own files */
        cJSON *rj = NULL;
        snprintf(p, sizeof p, "%s/%s/render_test.json", out, name);
        CHECK_OK(mf_json_load(p, &rj));
        if (rj) {
            CHECK(!strcmp(cJSON_GetObjectItem(rj, "cameras")->valuestring, "transforms_test.json"));
            CHECK(cJSON_GetObjectItem(rj, "width")->valueint == 32);
            CHECK(!strcmp(cJSON_GetObjectItem(cJSON_GetObjectItem(rj, "env"), "file")->valuestring, "gt/env.exr"));
        }
        cJSON_Delete(rj);
    }
    cJSON_Delete(list);
    CHECK_ERR(ds_write_split(&s, mf_test_path("tiny2"), mf_test_path("no_probes_here"), 1), "no_probes_here");
}

/* test-3d relights under every probe but the training one; a .hdr probe is converted to EXR */
MF_TEST(ds_split_relights_every_other_probe) {
    const char *probes = mf_test_path("probes_all");
    const char *names[] = {"a.exr", "b.hdr", "c.exr"};
    for (int i = 0; i < 3; ++i) {
        char p[MF_PATH_MAX];
        snprintf(p, sizeof p, "%s/%s", probes, names[i]);
        write_probe(p, 1.0f + i);
    }
    DsSplitSpec s;
    CHECK_OK(ds_split_spec("test-3d", &s));
    CHECK(s.n_relight == DS_RELIGHT_ALL);
    s.n_scenes = 2, s.width = 16, s.n_train = 2, s.n_test = 1, s.tex_res = 32;
    const char *out = mf_test_path("allprobes");
    CHECK_OK(ds_write_split(&s, out, probes, 5));
    CHECK(s.n_relight == 2);
    cJSON *list = NULL;
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/split.json", out);
    CHECK_OK(mf_json_load(p, &list));
    const cJSON *scenes = list ? cJSON_GetObjectItem(list, "scenes") : NULL;
    for (int k = 0; k < cJSON_GetArraySize(scenes); ++k) {
        const cJSON *sc = cJSON_GetArrayItem(scenes, k), *rl = cJSON_GetObjectItem(sc, "relight");
        const char *name = cJSON_GetObjectItem(sc, "name")->valuestring;
        CHECK(cJSON_GetArraySize(rl) == 2);
        for (int r = 0; r < cJSON_GetArraySize(rl); ++r) {
            const char *en = cJSON_GetArrayItem(rl, r)->valuestring;
            MfImage im = {0};
            snprintf(p, sizeof p, "%s/%s/relight/%s.exr", out, name, en);
            CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &im)); /* b.hdr arrives as b.exr, values kept */
            if (!strcmp(en, "b")) CHECK_NEAR(im.data[0], 2.0f, 1e-2f);
            mf_image_free(&im);
        }
    }
    cJSON_Delete(list);
    CHECK_OK(ds_split_spec("test-3d-diffuse", &s));
    CHECK(s.n_relight == 3 && s.povray);
}

/* bvault per-view GT read from the albedo/orm layers of the multi-layer EXR beside each PNG */
#include "io/mf_exr.h"
MF_TEST(ds_load_bvault_gt_from_exr_layers) {
    const char *dir = mf_test_path("bvault_exr");
    MfMat4 c2w[2];
    DsCamSampling s = ds_cam_sampling_default();
    CHECK_OK(ds_sample_cameras(&s, 2, 3, 1, c2w));
    CHECK_OK(ds_write_transforms(dir, "test", s.camera_angle_x, c2w, 2));
    float plane[3][16];
    for (int i = 0; i < 2; ++i) {
        char p[MF_PATH_MAX];
        MfImage im = {0};
        mf_image_alloc(&im, 4, 4, 4);
        snprintf(p, sizeof p, "%s/test/r_%03d.png", dir, i);
        mf_mkdirs_for(p);
        CHECK_OK(mf_image_write(p, &im, MF_ENC_SRGB, 8));
        mf_image_free(&im);
        for (int c = 0; c < 3; ++c)
            for (int q = 0; q < 16; ++q) plane[c][q] = 0.1f * c + 0.01f * q + 0.3f * i;
        MfExrChannel ch[6] = {{"albedo.R", plane[0], 1}, {"albedo.G", plane[1], 1}, {"albedo.B", plane[2], 1},
                              {"orm.R", plane[2], 1},    {"orm.G", plane[1], 1},    {"orm.B", plane[0], 1}};
        snprintf(p, sizeof p, "%s/test/r_%03d.exr", dir, i);
        CHECK_OK(mf_exr_write(p, 4, 4, ch, 6, MF_EXR_FLOAT));
    }
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/gt", dir);
    mf_mkdirs(p);
    DsViews v = {0};
    CHECK_OK(ds_load(dir, "test", NULL, &v));
    CHECK(v.format == DS_FMT_BVAULT && v.n == 2);
    for (int i = 0; i < v.n; ++i) {
        CHECK(v.views[i].albedo.data && v.views[i].orm.data);
        if (v.views[i].albedo.data) CHECK_NEAR(mf_image_px(&v.views[i].albedo, 3, 2)[1], 0.1f + 0.01f * 11 + 0.3f * i, 1e-6);
        if (v.views[i].orm.data) CHECK_NEAR(mf_image_px(&v.views[i].orm, 3, 2)[2], 0.01f * 11 + 0.3f * i, 1e-6);
    }
    ds_views_free(&v);
}

/* The `mf gen` command: writes the layout, exit code 2 on usage errors. */
MF_TEST(ds_cli_gen) {
    MF_NEED_BIN();
    const char *out = mf_test_path("cli_gen");
    char args[2 * MF_PATH_MAX], err[4096];
    snprintf(args, sizeof args, "gen -o '%s' --family torus --seed 3 --tex-res 32 --train 3 --test 2", out);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    const char *files[] = {"mesh.obj", "gt/kd.png", "gt/orm.png", "transforms_train.json", "transforms_test.json"};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; ++f) {
        char p[MF_PATH_MAX];
        snprintf(p, sizeof p, "%s/%s", out, files[f]);
        CHECK_MSG(mf_file_exists(p), "missing %s", p);
    }
    snprintf(args, sizeof args, "gen -o '%s' --family teapot", out);
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2);
}
