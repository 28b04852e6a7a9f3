#include "datasets/ds_capture.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_envgen.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"

DsCaptureSpec ds_capture_spec_default(int width) {
    DsCaptureSpec s = {0};
    double f0 = width / (2.0 * tan(DS_CAMERA_ANGLE_X / 2.0));
    s.n_frames = 24;
    s.w = width;
    s.h = 3 * width / 4;
    s.fl_x = 0.9 * f0;
    s.fl_y = 1.1 * s.fl_x;
    s.cx = 0.55 * s.w;
    s.cy = 0.45 * s.h;
    s.r_min = 1.5f;
    s.r_max = 2.0f;
    s.spp_sqrt = 4;
    s.pixel_samples = 4;
    return s;
}

int ds_capture_check(const DsCaptureSpec *s) {
    if (s->w < 2 || s->h < 2 || s->w > 16384 || s->h > 16384) return mf_fail(MF_EARG, "capture image size %dx%d outside [2, 16384]", s->w, s->h);
    if (s->n_frames < 2 || s->n_frames > 100000) return mf_fail(MF_EARG, "capture frames %d outside [2, 100000]", s->n_frames);
    if (!(s->fl_x > 0 && s->fl_x < 1e7) || !(s->fl_y > 0 && s->fl_y < 1e7))
        return mf_fail(MF_EARG, "capture focal lengths fl_x %g, fl_y %g: expected finite and positive pixels", s->fl_x, s->fl_y);
    if (!(s->cx > 0 && s->cx < s->w) || !(s->cy > 0 && s->cy < s->h))
        return mf_fail(MF_EARG, "capture principal point (%g, %g) lies outside the %dx%d image", s->cx, s->cy, s->w, s->h);
    for (int k = 0; k < 4; ++k)
        if (!isfinite(s->distortion[k]) || fabs(s->distortion[k]) > 10.0)
            return mf_fail(MF_EARG, "capture distortion %s = %g: expected a number in [-10, 10]", (const char *[]){"k1", "k2", "p1", "p2"}[k],
                           s->distortion[k]);
    if (s->spp_sqrt < 1 || s->pixel_samples < 1) return mf_fail(MF_EARG, "capture spp_sqrt %d, pixel_samples %d: expected >= 1", s->spp_sqrt, s->pixel_samples);
    return MF_OK;
}

/* Frame i's lens: the global one, or on odd frames the second lens. fl = (fl_x, fl_y, cx, cy). */
static void frame_lens(const DsCaptureSpec *s, int i, double fl[4]) {
    int two = i % 2;
    fl[0] = two ? s->fl_x * DS_CAPTURE_LENS2_ZOOM : s->fl_x;
    fl[1] = two ? s->fl_y * DS_CAPTURE_LENS2_ZOOM : s->fl_y;
    fl[2] = two ? s->w - s->cx : s->cx;
    fl[3] = two ? s->h - s->cy : s->cy;
}

static void add_num(cJSON *o, const char *key, double v) {
    char num[32];
    snprintf(num, sizeof num, "%.9g", v);
    cJSON_AddItemToObject(o, key, cJSON_CreateRaw(num));
}

static int write_json(const DsCaptureSpec *s, const MfMat4 *c2w, const char *dir) {
    static const char *const dk[4] = {"k1", "k2", "p1", "p2"};
    static const char *const lk[4] = {"fl_x", "fl_y", "cx", "cy"};
    cJSON *root = cJSON_CreateObject(), *frames = cJSON_CreateArray();
    if (!root || !frames) { cJSON_Delete(root); cJSON_Delete(frames); return mf_fail(MF_ENOMEM, "out of memory"); }
    double fl[4];
    frame_lens(s, 0, fl);
    add_num(root, "camera_angle_x", DS_CAMERA_ANGLE_X);
    for (int k = 0; k < 4; ++k) add_num(root, lk[k], fl[k]);
    add_num(root, "w", s->w);
    add_num(root, "h", s->h);
    for (int k = 0; k < 4; ++k) add_num(root, dk[k], s->distortion[k]);
    add_num(root, "aabb_scale", 1);
    cJSON_AddItemToObject(root, "frames", frames);
    for (int i = 0; i < s->n_frames; ++i) {
        cJSON *fr = cJSON_CreateObject();
        char p[64];
        snprintf(p, sizeof p, "images/r_%03d.png", i);
        cJSON_AddStringToObject(fr, "file_path", p);
        snprintf(p, sizeof p, "masks/r_%03d.png", i);
        cJSON_AddStringToObject(fr, "mask_path", p);
        cJSON_AddItemToObject(fr, "transform_matrix", ds_transform_matrix_json(&c2w[i]));
        if (i % 2) {
            frame_lens(s, i, fl);
            for (int k = 0; k < 4; ++k) add_num(fr, lk[k], fl[k]);
        }
        cJSON_AddItemToArray(frames, fr);
    }
    char path[MF_PATH_MAX];
    int rc = mf_path_join(path, sizeof path, dir, "transforms.json");
    if (!rc) rc = mf_json_save(path, root);
    cJSON_Delete(root);
    return rc;
}

/* images/<name>.png (RGB, straight colour, sRGB) and masks/<name>.png (coverage) of one render. */
static int write_frame(const char *dir, int i, const MfRenderOut *ro) {
    MfImage rgb = {0}, mask = {0};
    int rc = mf_image_alloc(&rgb, ro->w, ro->h, 3);
    if (!rc) rc = mf_image_alloc(&mask, ro->w, ro->h, 1);
    for (size_t p = 0; !rc && p < (size_t)ro->w * ro->h; ++p) {
        float a = ro->alpha[p];
        for (int c = 0; c < 3; ++c) rgb.data[3 * p + c] = a > 0.0f ? ro->rgb[3 * p + c] / a : 0.0f;
        mask.data[p] = a;
    }
    char rel[64], path[MF_PATH_MAX];
    snprintf(rel, sizeof rel, "images/r_%03d.png", i);
    if (!rc && !(rc = mf_path_join(path, sizeof path, dir, rel)) && !(rc = mf_mkdirs_for(path))) rc = mf_image_write(path, &rgb, MF_ENC_SRGB, 8);
    snprintf(rel, sizeof rel, "masks/r_%03d.png", i);
    if (!rc && !(rc = mf_path_join(path, sizeof path, dir, rel)) && !(rc = mf_mkdirs_for(path))) rc = mf_image_write(path, &mask, MF_ENC_LINEAR, 8);
    mf_image_free(&rgb);
    mf_image_free(&mask);
    return rc;
}

int ds_write_capture(const DsCaptureSpec *s, const DsObject *o, uint64_t seed, const char *dir) {
    int rc = ds_capture_check(s);
    if (rc) return rc;
    DsCamSampling cs = ds_cam_sampling_default();
    cs.r_min = s->r_min;
    cs.r_max = s->r_max;
    MfMat4 *c2w = malloc(sizeof(MfMat4) * (size_t)s->n_frames);
    if (!c2w) return mf_fail(MF_ENOMEM, "out of memory for %d cameras", s->n_frames);
    MfEnvMap env = {0};
    MfImage env_img = {0};
    MfRtScene *rt = NULL;
    char path[MF_PATH_MAX];
    if ((rc = ds_sample_cameras(&cs, s->n_frames, seed, 0, c2w)) || (rc = mf_mkdirs(dir))) goto out;
    if ((rc = ds_env_random(DS_ENV_INDOOR, mf_hash64(seed, 0xCA97u), 128, 64, &env_img)) || (rc = mf_env_init(&env, &env_img))) goto out;
    if ((rc = mf_path_join(path, sizeof path, dir, "mesh.obj")) || (rc = mf_obj_write(path, &o->mesh, NULL))) goto out;
    if ((rc = mf_rtscene_new(&o->mesh, &rt))) goto out;
    MfTexMaterial mat = {.kd = &o->kd, .orm = &o->orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = NULL};
    MfRenderInput in = {rt, &o->mesh, &mat, 1, &env, NULL, 0};
    for (int i = 0; i < s->n_frames && !rc; ++i) {
        MfCamera cam;
        double m[16], fl[4];
        char what[48];
        snprintf(what, sizeof what, "capture frame %d", i);
        for (int k = 0; k < 16; ++k) m[k] = c2w[i].m[k];
        if ((rc = mf_camera_init(&cam, s->w, s->h, DS_CAMERA_ANGLE_X, m, what))) break;
        frame_lens(s, i, fl);
        cam.fx = (float)fl[0], cam.fy = (float)fl[1], cam.cx = (float)fl[2], cam.cy = (float)fl[3];
        MfRenderOpts ro = {.spp_sqrt = s->spp_sqrt, .pixel_samples = s->pixel_samples, .seed = mf_hash64(seed, 0xCA9000u + (uint64_t)i), .lobes = MF_LOBE_ALL};
        MfRenderOut out = {0};
        if (!(rc = mf_render(&in, &cam, &ro, &out, NULL))) rc = write_frame(dir, i, &out);
        mf_render_out_free(&out);
    }
    if (!rc) rc = write_json(s, c2w, dir); /* last: a capture whose transforms.json exists is complete */
    if (!rc)
        mf_log_info("capture: %d frames %dx%d (fl_x %.2f fl_y %.2f cx %.2f cy %.2f; odd frames x%.2f)%s -> %s", s->n_frames, s->w, s->h,
                    s->fl_x, s->fl_y, s->cx, s->cy, DS_CAPTURE_LENS2_ZOOM,
                    (s->distortion[0] || s->distortion[1] || s->distortion[2] || s->distortion[3]) ? "; distortion written, not applied" : "",
                    dir);
out:
    if (rt) mf_rtscene_free(rt);
    mf_env_free(&env);
    free(c2w);
    return rc;
}
