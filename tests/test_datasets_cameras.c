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
