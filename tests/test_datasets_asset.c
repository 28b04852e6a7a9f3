/* ds_asset: a glTF asset as a data-set object (mf gen --asset). The asset is written here with
 * our glb writer (datasets/blender_asset.py makes one with Blender's exporter for the bench). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mf_test.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_asset.h"
#include "datasets/ds_split.h"
#include "io/mf_gltf.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "scene/mf_mesh.h"

/* A UV sphere of radius 2 off the origin, with a 4x2 albedo (distinct texels) and ORM texture,
 * written as .glb; returns its path. */
static const char *write_asset(const char *name) {
    static char glb[MF_PATH_MAX];
    char a[MF_PATH_MAX + 16], o[MF_PATH_MAX + 16];
    snprintf(glb, sizeof glb, "%s", mf_test_path(name));
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
    mf_image_free(&im);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = a, mat.orm_png = o;
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
