/* ds_asset: a glTF asset as a data-set object (mf gen --asset). The asset is written here with
 * our glb writer (datasets/blender_asset.py makes one with Blender's exporter for the bench). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mf_test.h"
#include "core/mf_rng.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_asset.h"
#include "datasets/ds_split.h"
#include "eval/ev_eval.h"
#include "eval/ev_table.h"
#include "io/mf_gltf.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "scene/mf_mesh.h"
#include "scene/mf_transforms.h"

/* A UV sphere of radius 2 off the origin, with a 4x2 albedo (distinct texels) and ORM texture,
 * and when nrm is given a constant 4x2 normal map of that 8-bit texel, written as .glb (our
 * writer: with a normal map it also writes TANGENT); returns its path. */
static const char *write_asset_nrm(const char *name, const unsigned char *nrm);
static const char *write_asset(const char *name) { return write_asset_nrm(name, NULL); }
static const char *write_asset_nrm(const char *name, const unsigned char *nrm) {
    static char glb[MF_PATH_MAX];
    char a[MF_PATH_MAX + 16], o[MF_PATH_MAX + 16];
    mf_test_path_to(glb, sizeof glb, "%s", name);
    snprintf(a, sizeof a, "%s.albedo.png", glb);
    snprintf(o, sizeof o, "%s.orm.png", glb);
    MfMesh m = {0};
    if (mf_mesh_uv_sphere(&m, 16, 8, mf_v3(3.0f, -1.0f, 0.5f), 2.0f)) return NULL;
    MfImage im = {0};
    if (mf_image_alloc(&im, 4, 2, 3)) return NULL;
    for (int i = 0; i < 8; ++i)
        for (int c = 0; c < 3; ++c) im.data[3 * i + c] = (float)((i * 3 + c * 5) % 8) / 7.0f;
    mf_image_write(a, &im, MF_ENC_SRGB, 8);
    for (int i = 0; i < 8; ++i) im.data[3 * i] = 1.0f, im.data[3 * i + 1] = 0.1f * (float)(i + 1), im.data[3 * i + 2] = (float)(i % 2);
    mf_image_write(o, &im, MF_ENC_LINEAR, 8);
    char n[MF_PATH_MAX + 16];
    snprintf(n, sizeof n, "%s.normal.png", glb);
    if (nrm) {
        for (int i = 0; i < 8; ++i)
            for (int c = 0; c < 3; ++c) im.data[3 * i + c] = (float)nrm[c] / 255.0f;
        mf_image_write(n, &im, MF_ENC_LINEAR, 8);
    }
    mf_image_free(&im);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = a, mat.orm_png = o, mat.normal_png = nrm ? n : NULL;
    int rc = mf_gltf_write_glb(glb, &m, &mat);
    mf_mesh_free(&m);
    return rc ? NULL : glb;
}

MF_TEST(ds_asset_object) {
    const char *glb = write_asset("My Asset.glb");
    CHECK(glb != NULL);
    if (!glb) return;
    DsObject o;
    CHECK_OK(ds_object_from_asset(glb, &o));
    CHECK(!strcmp(o.asset, "My_Asset"));
    CHECK(o.mesh.nt > 0 && o.mesh.uv && o.mesh.nrm && !o.mesh.mat);
    /* normalised like the generated objects: centred, largest extent 1 */
    MfVec3 lo, hi;
    mf_mesh_bounds(&o.mesh, &lo, &hi);
    CHECK_NEAR(fmaxf(hi.x - lo.x, fmaxf(hi.y - lo.y, hi.z - lo.z)), 1.0, 1e-5);
    CHECK_NEAR(lo.x + hi.x, 0.0, 1e-5);
    CHECK_NEAR(lo.z + hi.z, 0.0, 1e-5);
    /* the asset's textures are the object's (8-bit round trip) */
    CHECK(o.kd.w == 4 && o.kd.h == 2 && o.orm.w == 4 && o.orm.h == 2);
    if (o.kd.w == 4 && o.kd.h == 2 && o.orm.w == 4 && o.orm.h == 2)
        for (int i = 0; i < 8; ++i) {
            CHECK_NEAR(o.kd.data[3 * i + 1], (float)((i * 3 + 5) % 8) / 7.0f, 0.006);
            CHECK_NEAR(o.orm.data[3 * i + 1], 0.1f * (float)(i + 1), 0.003);
            CHECK_NEAR(o.orm.data[3 * i + 2], (float)(i % 2), 0.003);
        }
    ds_object_free(&o);
    /* one triangle without TEXCOORD_0 (our writer always writes UVs, so this one is by hand) */
    const char *nouv = mf_test_path("nouv.gltf");
    const char *js = "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                     "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
                     "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
                     "\"min\":[0,0,0],\"max\":[1,1,0]}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
                     "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
                     "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}]}";
    CHECK_OK(mf_write_file(nouv, js, strlen(js)));
    CHECK_ERR(ds_object_from_asset(nouv, &o), "no UVs");
    CHECK_ERR(ds_object_from_asset(mf_test_path("missing.glb"), &o), "missing.glb");
    CHECK_ERR(ds_object_from_asset(mf_test_path("mesh.obj"), &o), "glTF");
}

MF_TEST(ds_asset_split) {
    const char *glb = write_asset("cube_asset.glb");
    CHECK(glb != NULL);
    if (!glb) return;
    const char *probes = mf_test_path("asset_probes");
    for (int i = 0; i < 3; ++i) {
        MfImage img = {0};
        char p[MF_PATH_MAX];
        CHECK_OK(mf_image_alloc(&img, 16, 8, 3));
        for (int k = 0; k < 16 * 8 * 3; ++k) img.data[k] = 0.2f + 0.3f * (float)i;
        snprintf(p, sizeof p, "%s/p%d.exr", probes, i);
        mf_mkdirs(probes);
        CHECK_OK(mf_image_write(p, &img, MF_ENC_LINEAR, 32));
        mf_image_free(&img);
    }
    DsSplitSpec s;
    CHECK_OK(ds_split_spec("tiny", &s));
    s.asset = glb;
    const char *out = mf_test_path("asset_split");
    CHECK_OK(ds_write_split(&s, out, probes, 3));
    CHECK(s.n_scenes == 1);
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/000_cube_asset/gt/object.json", out);
    cJSON *j = NULL;
    CHECK_OK(mf_json_load(p, &j));
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(j, "asset");
    CHECK(cJSON_IsString(name) && !strcmp(name->valuestring, "cube_asset"));
    CHECK(!cJSON_GetObjectItemCaseSensitive(j, "family"));
    cJSON_Delete(j);
    snprintf(p, sizeof p, "%s/001_cube_asset", out);
    CHECK(!mf_file_exists(p));
    const char *files[] = {"mesh.obj", "gt/kd.png", "gt/orm.png", "gt/env.exr", "transforms_train.json", "render_train.json"};
    for (int i = 0; i < 6; ++i) {
        snprintf(p, sizeof p, "%s/000_cube_asset/%s", out, files[i]);
        CHECK_MSG(mf_file_exists(p), "%s missing", p);
    }
}

/* Three grey probes of different strength, for the split tests (returns the folder). */
static const char *write_probes(void) {
    const char *probes = mf_test_path("asset_probes_nm");
    mf_mkdirs(probes);
    for (int i = 0; i < 3; ++i) {
        MfImage img = {0};
        char p[MF_PATH_MAX];
        if (mf_image_alloc(&img, 16, 8, 3)) return probes;
        for (int k = 0; k < 16 * 8 * 3; ++k) img.data[k] = 0.2f + 0.3f * (float)i + 0.1f * (float)(k % 5); /* not uniform: shading shows */
        snprintf(p, sizeof p, "%s/p%d.exr", probes, i);
        CHECK_OK(mf_image_write(p, &img, MF_ENC_LINEAR, 32));
        mf_image_free(&img);
    }
    return probes;
}

/* The asset's split rendered (tiny, 16 px, 1 train and 1 test view) into out; the test view's
 * first relit EXR read into *relit (RGBA linear, premultiplied). */
static void render_asset_split(const char *glb, const char *out, const char *probes, MfImage *relit) {
    DsSplitSpec s;
    CHECK_OK(ds_split_spec("tiny", &s));
    s.asset = glb, s.width = 16, s.n_train = 1, s.n_test = 1;
    CHECK_OK(ds_write_split(&s, out, probes, 3));
    int nv = 0;
    CHECK_OK(ds_render_split(&s, out, &nv));
    CHECK(nv == 1 + 1 * (1 + s.n_relight));
    char p[MF_PATH_MAX];
    cJSON *j = NULL;
    snprintf(p, sizeof p, "%s/split.json", out);
    CHECK_OK(mf_json_load(p, &j));
    const cJSON *sc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), 0);
    const char *name = cJSON_GetStringValue(cJSON_GetObjectItem(sc, "name"));
    const char *env = cJSON_GetStringValue(cJSON_GetArrayItem(cJSON_GetObjectItem(sc, "relight"), 0));
    snprintf(p, sizeof p, "%s/%s/relight/%s/r_000.exr", out, name ? name : "?", env ? env : "?");
    cJSON_Delete(j);
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, relit));
}

/* "dir/rel" in one of 4 rotating buffers. */
static const char *in_dir(const char *dir, const char *rel) {
    static char buf[4][MF_PATH_MAX + 64];
    static int k;
    char *o = buf[k++ % 4];
    if (mf_path_join(o, sizeof buf[0], dir, rel)) o[0] = 0;
    return o;
}

static double mean_abs_diff(const MfImage *a, const MfImage *b) {
    if (a->w != b->w || a->h != b->h || a->c != b->c || !a->data || !b->data) return -1;
    double d = 0;
    for (size_t i = 0; i < (size_t)a->w * a->h * a->c; ++i) d += fabs(a->data[i] - b->data[i]);
    return d / ((double)a->w * a->h * a->c);
}

/* An asset's normalTexture reaches the GT renders of mf gen --asset: gt/normal.png is written
 * (the asset's map, 8-bit), a tilted map changes the renders, a flat (128, 128, 255) map leaves
 * them nearly unchanged, and the GT render is exactly the renderer's normal-map path (mf_render
 * with MfTexMaterial.normal = gt/normal.png, as mf relight / mf eval use a result's normal.png). */
MF_TEST(ds_asset_normal_map_gt_renders) {
    const unsigned char tilt[3] = {204, 128, 230}, flat[3] = {128, 128, 255};
    const char *probes = write_probes();
    MfImage none = {0}, tilted = {0}, flatr = {0};
    render_asset_split(write_asset("plain_nm.glb"), mf_test_path("nm_none"), probes, &none);
    render_asset_split(write_asset_nrm("tilt_nm.glb", tilt), mf_test_path("nm_tilt"), probes, &tilted);
    render_asset_split(write_asset_nrm("flat_nm.glb", flat), mf_test_path("nm_flat"), probes, &flatr);
    char p[MF_PATH_MAX];
    mf_test_path_to(p, sizeof p, "nm_none/000_plain_nm/gt/normal.png");
    CHECK_MSG(!mf_file_exists(p), "%s written for an asset without normalTexture", p);
    /* the map as written: the asset's texel (our writer's TANGENT are our frames: unchanged) */
    MfImage nm = {0};
    mf_test_path_to(p, sizeof p, "nm_tilt/000_tilt_nm/gt/normal.png");
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &nm));
    CHECK(nm.w == 4 && nm.h == 2 && nm.c >= 3);
    for (int i = 0; nm.data && i < nm.w * nm.h; ++i)
        for (int c = 0; c < 3; ++c) CHECK_NEAR(nm.data[i * nm.c + c] * 255.0f, (float)tilt[c], 1.01f);
    double d_tilt = mean_abs_diff(&none, &tilted), d_flat = mean_abs_diff(&none, &flatr), mean = 0;
    for (size_t i = 0; none.data && i < (size_t)none.w * none.h * 4; ++i) mean += none.data[i] / (double)(none.w * none.h * 4);
    CHECK_MSG(mean > 0.02, "render too dark to compare (mean %g)", mean);
    CHECK_MSG(d_tilt > 0.03 * mean, "a tilted normal map hardly changes the GT render: mean |diff| %g (mean %g)", d_tilt, mean);
    mf_log_info("GT relit view: mean %.4f, mean |diff| to no normal map: tilted %.5f, flat %.6f", mean, d_tilt, d_flat);
    CHECK_MSG(d_flat >= 0 && d_flat < 0.01 * mean, "a flat normal map changes the GT render: mean |diff| %g (mean %g)", d_flat, mean);
    /* the renderer's own normal-map path on the scene's files gives the same bytes */
    cJSON *j = NULL;
    mf_test_path_to(p, sizeof p, "nm_tilt/split.json");
    CHECK_OK(mf_json_load(p, &j));
    const cJSON *sc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), 0);
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(sc, "normal_map")));
    cJSON *rj = NULL; /* the scene file for `mf render` names the map too */
    mf_test_path_to(p, sizeof p, "nm_tilt/000_tilt_nm/render_test.json");
    CHECK_OK(mf_json_load(p, &rj));
    const char *rn = cJSON_GetStringValue(cJSON_GetObjectItem(cJSON_GetObjectItem(rj, "material"), "normal"));
    CHECK_MSG(rn && !strcmp(rn, "gt/normal.png"), "render_test.json material.normal: %s", rn ? rn : "(none)");
    cJSON_Delete(rj);
    const char *env = cJSON_GetStringValue(cJSON_GetArrayItem(cJSON_GetObjectItem(sc, "relight"), 0));
    const char *seeds = cJSON_GetStringValue(cJSON_GetObjectItem(sc, "object_seed"));
    char dir[MF_PATH_MAX];
    mf_test_path_to(dir, sizeof dir, "nm_tilt/000_tilt_nm");
    MfMesh m = {0};
    MfImage kd = {0}, orm = {0};
    MfEnvMap e = {0};
    MfTransforms tf = {0};
    char q[MF_PATH_MAX];
    CHECK_OK(mf_obj_read(in_dir(dir, "mesh.obj"), &m));
    CHECK_OK(mf_image_read(in_dir(dir, "gt/kd.png"), MF_ENC_SRGB, &kd));
    CHECK_OK(mf_image_read(in_dir(dir, "gt/orm.png"), MF_ENC_LINEAR, &orm));
    snprintf(q, sizeof q, "relight/%s.exr", env ? env : "?");
    CHECK_OK(mf_env_load(&e, in_dir(dir, q)));
    CHECK_OK(mf_transforms_load(in_dir(dir, "transforms_test.json"), 0, &tf));
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&m, &rt));
    if (rt && tf.n == 1 && env && seeds) {
        MfTexMaterial mat = {.kd = &kd, .orm = &orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = &nm};
        MfRenderInput in = {rt, &m, &mat, 1, &e, NULL, 0};
        MfCamera cam;
        CHECK_OK(mf_camera_init(&cam, 16, 16, tf.camera_angle_x, tf.frames[0].c2w, "test"));
        MfRenderOpts o = {.spp_sqrt = 4, .pixel_samples = 4, .seed = mf_hash64(strtoull(seeds, NULL, 10), 2 * 100000), .lobes = MF_LOBE_ALL};
        o.seed = mf_hash64(o.seed, mf_fnv1a64(MF_FNV64_INIT, env, strlen(env)));
        MfRenderOut ro = {0};
        CHECK_OK(mf_render(&in, &cam, &o, &ro, NULL));
        int bad = 0;
        for (int i = 0; ro.rgb && i < 16 * 16; ++i)
            for (int c = 0; c < 3; ++c) bad += (ro.alpha[i] > 0 ? ro.rgb[3 * i + c] : 0.0f) != tilted.data[4 * i + c];
        CHECK_MSG(!bad, "%d values of the GT relit view differ from mf_render with the normal map", bad);
        mat.normal = NULL;
        mf_render_out_free(&ro);
        CHECK_OK(mf_render(&in, &cam, &o, &ro, NULL));
        bad = 0;
        for (int i = 0; ro.rgb && i < 16 * 16; ++i)
            for (int c = 0; c < 3; ++c) bad += (ro.alpha[i] > 0 ? ro.rgb[3 * i + c] : 0.0f) != tilted.data[4 * i + c];
        CHECK_MSG(bad > 0, "the GT relit view is also what mf_render gives without the normal map");
        mf_render_out_free(&ro);
    }
    /* eval's trivial-flat-light row (the true material under a white light) renders the true
     * material, the GT's normal map included: it scores differently without gt/normal.png */
    double with_nm = -1, without_nm = -1;
    for (int pass = 0; pass < 2; ++pass) {
        EvEvalOpts eo = ev_eval_opts_default();
        eo.no_geom = 1;
        EvTable t;
        ev_table_init(&t);
        int ex = 0;
        CHECK_OK(ev_eval_scene(dir, EV_TRIVIAL_FLAT_DIR, "flat", "d", "s", &eo, &t, NULL, &ex));
        CHECK(ev_table_find(&t, "flat", "d", "s", "relit_psnr", pass ? &without_nm : &with_nm));
        ev_table_free(&t);
        if (!pass) CHECK(mf_test_sh("mv '%s' '%s.off'", in_dir(dir, "gt/normal.png"), in_dir(dir, "gt/normal.png")) == 0);
    }
    CHECK(mf_test_sh("mv '%s.off' '%s'", in_dir(dir, "gt/normal.png"), in_dir(dir, "gt/normal.png")) == 0);
    CHECK_MSG(with_nm > 0 && without_nm > 0 && with_nm != without_nm,
              "trivial-flat-light scores %g dB with the GT normal map and %g without", with_nm, without_nm);
    if (rt) mf_rtscene_free(rt);
    mf_transforms_free(&tf);
    mf_env_free(&e);
    mf_mesh_free(&m);
    mf_image_free(&kd), mf_image_free(&orm), mf_image_free(&nm);
    mf_image_free(&none), mf_image_free(&tilted), mf_image_free(&flatr);
    cJSON_Delete(j);
}
