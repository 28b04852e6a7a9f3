/* The widened prior-train recipe and the content hold-out (datasets/ds_widen.h), and Blender Cycles
 * as a renderer of generated views (datasets/ds_cycles.h): prior-train/test-2d and the test-3d-cyc split. */
#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_cycles.h"
#include "datasets/ds_gen.h"
#include "datasets/ds_povray.h"
#include "datasets/ds_split.h"
#include "io/mf_json.h"
#include "mf_test.h"

MF_TEST(ds_widen_content_partition) {
    /* every object is in exactly one of train / heldout; both occur among the first candidates;
     * the held-out families never pass train */
    int ntrain = 0, nheld = 0;
    for (int j = 0; j < 40; ++j) {
        DsObject o;
        CHECK_OK(ds_object_generate(&o, (DsFamily)(j % DS_FAM_COUNT), ds_object_seed(DS_STREAM_TEST2D, 1, (uint64_t)j), 16));
        int t = ds_content_accepts(DS_CONTENT_TRAIN, &o), h = ds_content_accepts(DS_CONTENT_HELDOUT, &o);
        CHECK_MSG(t != h && ds_content_accepts(DS_CONTENT_ALL, &o), "candidate %d: train %d heldout %d", j, t, h);
        if (ds_family_heldout(o.family)) CHECK(!t);
        ntrain += t, nheld += h;
        ds_object_free(&o);
    }
    CHECK_MSG(ntrain >= 10 && nheld >= 10, "train %d heldout %d of 40", ntrain, nheld);
}

MF_TEST(ds_widen_view_transform) {
    enum { R = 8, N = R * R };
    float rgb[N * 3], ref[N * 3], alpha[N];
    for (int i = 0; i < N; ++i) {
        alpha[i] = i % 7 ? 1.0f : 0.5f;
        for (int c = 0; c < 3; ++c) ref[i * 3 + c] = (0.05f + 0.4f * (float)((i * 3 + c) % 11) / 10.0f) * alpha[i];
    }
    /* identity settings give back the input (premultiplied, below 1) */
    DsWidenView id = {1.0f, 0, 4.0f, 1.0f, 0, 0.0f, 1};
    memcpy(rgb, ref, sizeof rgb);
    CHECK_OK(ds_widen_apply(&id, rgb, 3, alpha, 1, R));
    CHECK_MSG(mf_test_max_abs_diff(rgb, ref, N * 3) < 1e-5f, "identity changed the image by %g", mf_test_max_abs_diff(rgb, ref, N * 3));
    /* exposure x2 doubles values that stay below 1 */
    DsWidenView ex = id;
    ex.exposure = 2.0f;
    memcpy(rgb, ref, sizeof rgb);
    CHECK_OK(ds_widen_apply(&ex, rgb, 3, alpha, 1, R));
    for (int i = 0; i < N * 3; ++i)
        if (ref[i] / alpha[i / 3] < 0.45f) CHECK_MSG(fabsf(rgb[i] - 2.0f * ref[i]) < 1e-5f, "pixel value %d: %g vs %g", i, rgb[i], 2 * ref[i]);
    /* tone curves map any radiance into [0, 1] (times alpha) and keep the order */
    for (int t = 1; t <= 2; ++t) {
        DsWidenView tc = id;
        tc.tone = t;
        float hdr[3] = {0.5f, 10.0f, 1e30f}, al = 1;
        CHECK_OK(ds_widen_apply(&tc, hdr, 3, &al, 1, 1));
        for (int c = 0; c < 3; ++c) CHECK_MSG(hdr[c] >= 0 && hdr[c] <= 1 && isfinite(hdr[c]), "tone %d: %g", t, hdr[c]);
        CHECK_MSG(hdr[0] < hdr[1] && hdr[1] <= hdr[2], "tone %d not monotonic: %g %g %g", t, hdr[0], hdr[1], hdr[2]);
    }
    /* the resolution drop keeps a constant image constant; noise keeps the mean */
    float flat[N * 3], one[N];
    for (int i = 0; i < N; ++i) one[i] = 1.0f, flat[i * 3] = flat[i * 3 + 1] = flat[i * 3 + 2] = 0.2f;
    DsWidenView lo = id;
    lo.lowres = 1;
    CHECK_OK(ds_widen_apply(&lo, flat, 3, one, 1, R));
    for (int i = 0; i < N * 3; ++i) CHECK_MSG(fabsf(flat[i] - 0.2f) < 1e-5f, "low-res changed a flat image: %g", flat[i]);
    DsWidenView nz = id;
    nz.noise = 0.02f;
    CHECK_OK(ds_widen_apply(&nz, flat, 3, one, 1, R));
    double s = 0;
    int changed = 0;
    for (int i = 0; i < N * 3; ++i) s += flat[i], changed += fabsf(flat[i] - 0.2f) > 1e-4f;
    CHECK_MSG(changed > N && fabs(s / (N * 3) - 0.2) < 0.01, "noise: %d values changed, mean %g", changed, s / (N * 3));
}

MF_TEST(ds_widen_object_draws) {
    /* the per-object draws cover their ranges and the POV-Ray share is near DS_WIDEN_POV_FRAC */
    int pov = 0, ov = 0, n = 400;
    for (int j = 0; j < n; ++j) {
        DsWidenObject w = ds_widen_object(ds_object_seed(DS_STREAM_PRIOR, 1, (uint64_t)j));
        pov += w.povray, ov += w.overlay != 0;
        DsCamSampling cs = ds_widen_cameras(&w);
        CHECK(cs.camera_angle_x >= DS_WIDEN_FOV_MIN - 1e-4 && cs.camera_angle_x <= DS_WIDEN_FOV_MAX + 1e-4);
        CHECK(cs.r_min > 0.5f && cs.r_max < 6.0f && cs.r_min < cs.r_max);
    }
    CHECK_MSG(pov > n * DS_WIDEN_POV_FRAC / 2 && pov < n * DS_WIDEN_POV_FRAC * 2, "POV-Ray objects %d of %d", pov, n);
    CHECK_MSG(ov > n * DS_WIDEN_OVERLAY_FRAC / 2 && ov < n * DS_WIDEN_OVERLAY_FRAC * 2, "overlays %d of %d", ov, n);
}

MF_TEST(ds_widen_gen_heldout) {
    if (!ds_povray_available()) MF_SKIP("povray not installed");
    /* a held-out content split with the widened recipe: 3 objects x 1 view at 16 px; the generator
     * re-checks every object's content at full texture size, and the manifest names both */
    DsPriorTrainOpts o = ds_test2d_defaults();
    o.count = 3, o.res = 16, o.views_per_object = 1, o.tex_res = 32, o.spp_sqrt = 1, o.pixel_samples = 1;
    o.train_lights = DS_LIGHTS_PROCEDURAL, o.content = DS_CONTENT_HELDOUT, o.widen = 1;
    const char *out = mf_test_path("widen_heldout");
    CHECK_OK(ds_gen_prior_train(&o, out, NULL));
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/manifest.json", out);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(p, &m));
    const cJSON *c = cJSON_GetObjectItem(m, "content"), *w = cJSON_GetObjectItem(m, "widen"), *n = cJSON_GetObjectItem(m, "count");
    CHECK(cJSON_IsString(c) && !strcmp(c->valuestring, "heldout") && cJSON_IsString(w) && cJSON_IsNumber(n) && n->valueint == 3);
    cJSON_Delete(m);
    /* a content filter without a count is refused */
    o.count = 0, o.time_budget_s = 5;
    CHECK_ERR(ds_gen_prior_train(&o, mf_test_path("widen_nocount"), NULL), "count");
}

MF_TEST(ds_cycles_missing_blender) {
    /* no Blender: a clear error naming the tool, before anything is written */
    const char *old = getenv("MF_BLENDER");
    char *saved = old ? strdup(old) : NULL;
    setenv("MF_BLENDER", "/nonexistent/blender", 1);
    DsPriorTrainOpts o = ds_test2d_defaults();
    o.count = 2, o.res = 16, o.views_per_object = 2, o.tex_res = 32, o.spp_sqrt = 1, o.pixel_samples = 1;
    o.renderer = DS_RENDERER_CYCLES;
    const char *out = mf_test_path("cycles_noblender");
    CHECK_ERR(ds_gen_prior_train(&o, out, NULL), "blender");
    CHECK(!mf_file_exists(out));
    if (saved) setenv("MF_BLENDER", saved, 1);
    else unsetenv("MF_BLENDER");
    free(saved);
}

MF_TEST(ds_cycles_renders_views) {
    if (!ds_cycles_available()) MF_SKIP("blender not installed (optional)");
    /* 1 object x 2 views at 16 px: Blender's lit view covers the same pixels as our alpha, the GT
     * AOVs are ours, the scratch folder is gone */
    DsPriorTrainOpts o = ds_test2d_defaults();
    o.count = 2, o.res = 16, o.views_per_object = 2, o.tex_res = 32, o.spp_sqrt = 1, o.pixel_samples = 1;
    o.train_lights = DS_LIGHTS_PROCEDURAL;
    const char *a = mf_test_path("cycles_ours"), *b = mf_test_path("cycles_blender");
    CHECK_OK(ds_gen_prior_train(&o, a, NULL));
    o.renderer = DS_RENDERER_CYCLES;
    CHECK_OK(ds_gen_prior_train(&o, b, NULL));
    for (int i = 0; i < 2; ++i) {
        MfImage img[2][3] = {{{0}}};
        static const char *const kind[3] = {"rgb", "albedo", "orm"};
        for (int s = 0; s < 2; ++s)
            for (int k = 0; k < 3; ++k) {
                char p[MF_PATH_MAX];
                snprintf(p, sizeof p, "%s/%s/%06d.png", s ? b : a, kind[k], i);
                CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &img[s][k]));
            }
        int both = 0, either = 0, same_gt = 1;
        for (int q = 0; img[0][0].data && img[1][0].data && q < 16 * 16; ++q) {
            int ca = img[0][0].data[4 * q + 3] > 0.5f, cb = img[1][0].data[4 * q + 3] > 0.5f;
            both += ca && cb, either += ca || cb;
            for (int k = 1; k < 3 && img[0][k].data && img[1][k].data; ++k)
                for (int c = 0; c < 4; ++c) same_gt &= img[0][k].data[4 * q + c] == img[1][k].data[4 * q + c];
        }
        CHECK_MSG(both > 10 && both >= 0.85 * either, "view %d: coverage %d of %d", i, both, either);
        CHECK_MSG(same_gt, "view %d: GT albedo/ORM must be our AOVs", i);
        for (int s = 0; s < 2; ++s)
            for (int k = 0; k < 3; ++k) mf_image_free(&img[s][k]);
    }
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/.cycles", b);
    CHECK_MSG(!mf_file_exists(p), "%s: scratch folder left behind", p);
}

MF_TEST(ds_split_cycles_missing_blender) {
    /* mf gen --split test-3d-cyc without Blender: exit non-zero naming it, nothing written */
    MF_NEED_BIN();
    const char *out = mf_test_path("split_cyc_noblender");
    char args[MF_PATH_MAX + 128], err[4096];
    snprintf(args, sizeof args, "gen --split test-3d-cyc --scenes 1 --train 2 --test 1 --width 16 -o %s", out);
    const char *old = getenv("MF_BLENDER");
    char *saved = old ? strdup(old) : NULL;
    setenv("MF_BLENDER", "/nonexistent/blender", 1);
    int code = mf_test_run_mf(args, NULL, err, sizeof err);
    if (saved) setenv("MF_BLENDER", saved, 1);
    else unsetenv("MF_BLENDER");
    free(saved);
    CHECK_MSG(code != 0, "exit %d", code);
    CHECK_MSG(strstr(err, "blender") && strstr(err, "--no-render"), "%s", err);
    CHECK(!mf_file_exists(out));
}

MF_TEST(ds_split_cycles_renders_test3d) {
    if (!ds_cycles_available()) MF_SKIP("blender not installed (optional)");
    /* test-3d-cyc is test-3d's objects, cameras and probes lit by Cycles: the same gt/ and
     * transforms bytes as test-3d (so the two pair per scene), Cycles' training and relit views
     * cover the pixels of ours and are not ours, the scratch folder is gone */
    DsSplitSpec c, o;
    CHECK_OK(ds_split_spec("test-3d-cyc", &c));
    CHECK_OK(ds_split_spec("test-3d", &o));
    CHECK(c.cycles && !o.cycles && c.n_relight == 3);
    DsSplitSpec *sp[2] = {&o, &c};
    for (int k = 0; k < 2; ++k) sp[k]->n_scenes = 1, sp[k]->n_train = 2, sp[k]->n_test = 1, sp[k]->width = 16, sp[k]->spp_sqrt = 1;
    const char *a = mf_test_path("split_ours"), *b = mf_test_path("split_cyc");
    CHECK_OK(ds_write_split(&o, a, NULL, 1));
    CHECK_OK(ds_write_split(&c, b, NULL, 1));
    CHECK_OK(ds_render_split(&o, a, NULL));
    int nv = 0;
    CHECK_OK(ds_render_split(&c, b, &nv));
    CHECK_MSG(nv == 2 + 1 + 3, "views rendered %d", nv); /* 2 train, 1 test, 1 per relighting light */
    static const char *const same[] = {"gt/kd.png", "gt/orm.png", "gt/env.exr", "transforms_train.json", "transforms_test.json",
                                       "test/r_000.png", "gt/albedo/r_000.png"};
    for (size_t i = 0; i < sizeof same / sizeof *same; ++i)
        CHECK_MSG(!mf_test_sh("cmp -s %s/000_cup/%s %s/000_cup/%s", a, same[i], b, same[i]), "%s differs", same[i]);
    cJSON *split = NULL;
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/split.json", b);
    CHECK_OK(mf_json_load(p, &split));
    const cJSON *rl = cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(split, "scenes"), 0), "relight");
    CHECK(cJSON_GetArraySize(rl) == 3);
    for (int r = -1; r < cJSON_GetArraySize(rl); ++r) {
        const char *rel = r < 0 ? "train/r_000.png" : NULL;
        char rp[512];
        if (r >= 0) snprintf(rp, sizeof rp, "relight/%s/r_000.exr", cJSON_GetArrayItem(rl, r)->valuestring), rel = rp;
        MfImage img[2] = {{0}};
        for (int s = 0; s < 2; ++s) {
            snprintf(p, sizeof p, "%s/000_cup/%s", s ? b : a, rel);
            CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &img[s]));
        }
        int both = 0, either = 0, differ = 0;
        for (int q = 0; img[0].data && img[1].data && q < 16 * 16; ++q) {
            int ca = img[0].data[4 * q + 3] > 0.5f, cb = img[1].data[4 * q + 3] > 0.5f;
            both += ca && cb, either += ca || cb;
            differ |= img[0].data[4 * q] != img[1].data[4 * q];
        }
        CHECK_MSG(both > 10 && both >= 0.85 * either, "%s: coverage %d of %d", rel, both, either);
        CHECK_MSG(differ, "%s: Cycles' view equals ours", rel);
        mf_image_free(&img[0]), mf_image_free(&img[1]);
    }
    cJSON_Delete(split);
    snprintf(p, sizeof p, "%s/000_cup/.cycles", b);
    CHECK_MSG(!mf_test_sh("[ -z \"$(ls -A %s 2>/dev/null)\" ]", p), "%s: scratch left behind", p);
}
