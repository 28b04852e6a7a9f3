/* Tests of datasets/ds_capture: a capture written by `mf gen --layout ingp` (issue 15, item 5)
 * read back with its own lens. Reading users' captures (instant-ngp / nerfstudio intrinsics,
 * split rule, masks, refusals) is tested in test_datasets_load.c. */
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

/* Mean |alpha rendered from cam - view's mask| over the image: how well a camera explains the
 * capture's silhouette. */
static double silhouette_error(const MfRenderInput *in, const MfCamera *cam, const DsView *v) {
    MfRenderOpts ro = {.spp_sqrt = 1, .pixel_samples = 16, .seed = 7, .lobes = MF_LOBE_ALL};
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
        MfTexMaterial mat = {.kd = &o.kd, .orm = &o.orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = NULL};
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
