/* Tests for io/mf_gltf_read: round trip through our own writer (.glb, and the same data as .gltf
 * with a data-URI buffer and with an external buffer and image), node transforms, materials with
 * factors, the scene file and result hooks, and hand-made bad files (each refused by name). */
#include <cJSON.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_eval.h"
#include "io/mf_gltf.h"
#include "io/mf_gltf_read.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"
#include "scene/mf_scene.h"
#include "mf_test.h"
#include "mf_test_kit.h"

static void put32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static char *b64(const unsigned char *d, size_t n) {
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = malloc(4 * (n / 3 + 1) + 1), *p = o;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)d[i] << 16 | (i + 1 < n ? (uint32_t)d[i + 1] << 8 : 0) | (i + 2 < n ? d[i + 2] : 0);
        *p++ = t[v >> 18 & 63], *p++ = t[v >> 12 & 63];
        *p++ = i + 1 < n ? t[v >> 6 & 63] : '=';
        *p++ = i + 2 < n ? t[v & 63] : '=';
    }
    *p = 0;
    return o;
}

/* A .glb from JSON text and BIN bytes (bin may be NULL: no BIN chunk). */
static void write_glb(const char *path, const char *json, const unsigned char *bin, size_t binlen) {
    size_t jl = (strlen(json) + 3) & ~(size_t)3, bl = (binlen + 3) & ~(size_t)3;
    size_t total = 20 + jl + (bin ? 8 + bl : 0);
    unsigned char *g = calloc(total, 1);
    put32(g, 0x46546C67), put32(g + 4, 2), put32(g + 8, (uint32_t)total), put32(g + 12, (uint32_t)jl), put32(g + 16, 0x4E4F534A);
    memset(g + 20, ' ', jl);
    memcpy(g + 20, json, strlen(json));
    if (bin) {
        put32(g + 20 + jl, (uint32_t)bl), put32(g + 24 + jl, 0x004E4942);
        memcpy(g + 28 + jl, bin, binlen);
    }
    CHECK_OK(mf_write_file(path, g, total));
    free(g);
}

/* The source data of the round trip: a UV sphere, an sRGB albedo and a linear ORM PNG. */
static void make_source(MfMesh *m, const char *albedo, const char *orm) {
    CHECK_OK(mf_mesh_uv_sphere(m, 10, 6, mf_v3(0.1f, -0.2f, 0.3f), 0.5f));
    for (int k = 0; k < 2; ++k) {
        MfImage im = {0};
        CHECK_OK(mf_image_alloc(&im, 6 + 2 * k, 4, 3));
        for (int i = 0; i < im.w * im.h * 3; ++i) im.data[i] = (float)((i * 7 + k) % 11) / 10.0f;
        CHECK_OK(mf_image_write(k ? orm : albedo, &im, k ? MF_ENC_LINEAR : MF_ENC_SRGB, 8));
        mf_image_free(&im);
    }
}

/* Mesh b against a: positions exact (the axis change is a permutation and a sign), normals and
 * UVs within tol (UVs go through v -> 1 - v twice in float), triangles identical. */
static void check_same_mesh(const MfMesh *a, const MfMesh *b, float tol, const char *what) {
    CHECK_MSG(a->nv == b->nv && a->nt == b->nt, "%s: %d/%d vertices, %d/%d triangles", what, b->nv, a->nv, b->nt, a->nt);
    if (a->nv != b->nv || a->nt != b->nt || !b->uv || !b->nrm) { CHECK_MSG(b->uv && b->nrm, "%s: no UVs or normals", what); return; }
    int bad_p = 0, bad_n = 0, bad_uv = 0;
    for (int i = 0; i < 3 * a->nv; ++i) bad_p += a->pos[i] != b->pos[i], bad_n += fabsf(a->nrm[i] - b->nrm[i]) > tol;
    for (int i = 0; i < 2 * a->nv; ++i) bad_uv += fabsf(a->uv[i] - b->uv[i]) > tol;
    CHECK_MSG(!bad_p && !bad_n && !bad_uv, "%s: %d positions, %d normals, %d UVs differ", what, bad_p, bad_n, bad_uv);
    CHECK_MSG(!memcmp(a->tri, b->tri, sizeof(uint32_t) * 3 * (size_t)a->nt), "%s: triangles differ", what);
}

/* b against a x scale, channels first..2 (ORM: 1, since a glTF file without occlusionTexture has
 * no occlusion, R = 1, whatever R the metallicRoughness image holds). */
static void check_same_image_from(const MfImage *a, const MfImage *b, float scale, int first, const char *what) {
    CHECK_MSG(a->w == b->w && a->h == b->h && b->c == 3, "%s: %dx%dx%d, expected %dx%dx3", what, b->w, b->h, b->c, a->w, a->h);
    if (a->w != b->w || a->h != b->h || b->c != 3) return;
    double worst = 0;
    for (size_t i = 0; i < (size_t)a->w * a->h; ++i)
        for (int k = first; k < 3; ++k) worst = fmax(worst, fabs(a->data[i * a->c + k] * scale - b->data[3 * i + k]));
    CHECK_MSG(worst <= 1e-6, "%s: texels differ by up to %g", what, worst);
}

static void check_same_image(const MfImage *a, const MfImage *b, float scale, const char *what) { check_same_image_from(a, b, scale, 0, what); }

/* R of an ORM image read without occlusionTexture: 1 everywhere. */
static void check_no_occlusion(const MfImage *orm, const char *what) {
    int bad = 0;
    for (size_t i = 0; i < (size_t)orm->w * orm->h; ++i) bad += orm->data[3 * i] != 1.0f;
    CHECK_MSG(!bad, "%s: %d texels with occlusion R != 1", what, bad);
}

/* Our writer's .glb read back: mesh, textures (exactly the PNGs' decoded values), factors. */
MF_TEST(gltf_read_roundtrip_glb) {
    const char *alb = mf_test_path("rt_albedo.png"), *orm = mf_test_path("rt_orm.png"), *glb = mf_test_path("rt.glb");
    MfMesh m = {0};
    make_source(&m, alb, orm);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = alb, mat.orm_png = orm, mat.name = "rt";
    CHECK_OK(mf_gltf_write_glb(glb, &m, &mat));
    MfGltfAsset a = {0};
    CHECK_OK(mf_gltf_read(glb, &a));
    check_same_mesh(&m, &a.mesh, 1e-6f, glb);
    MfImage ta = {0}, to = {0};
    CHECK_OK(mf_image_read(alb, MF_ENC_SRGB, &ta));
    CHECK_OK(mf_image_read(orm, MF_ENC_LINEAR, &to));
    CHECK(a.nmat == 1 && a.mesh.mat == NULL);
    if (a.nmat == 1) {
        CHECK(!strcmp(a.mats[0].name, "rt") && a.mats[0].albedo_textured && a.mats[0].orm_textured);
        check_same_image(&ta, &a.mats[0].albedo, 1.0f, "albedo");
        check_same_image_from(&to, &a.mats[0].orm, 1.0f, 1, "orm");
        check_no_occlusion(&a.mats[0].orm, "orm");
    }
    mf_gltf_asset_free(&a);
    /* factors multiply the textures (baseColorFactor linear; roughness G, metallic B) */
    mat.base_color[0] = mat.base_color[1] = mat.base_color[2] = 0.5f;
    mat.roughness = 0.25f, mat.metallic = 0.75f;
    CHECK_OK(mf_gltf_write_glb(glb, &m, &mat));
    CHECK_OK(mf_gltf_read(glb, &a));
    if (a.nmat == 1) {
        check_same_image(&ta, &a.mats[0].albedo, 0.5f, "albedo x 0.5");
        const float *o = a.mats[0].orm.data, *t = to.data;
        CHECK_NEAR(o[0], 1.0f, 0);
        CHECK_NEAR(o[1], 0.25f * t[1], 1e-7);
        CHECK_NEAR(o[2], 0.75f * t[2], 1e-7);
    }
    mf_gltf_asset_free(&a);
    /* no textures: 1x1 images of the factors */
    CHECK_OK(mf_gltf_write_glb(glb, &m, NULL));
    CHECK_OK(mf_gltf_read(glb, &a));
    if (a.nmat == 1) {
        CHECK(a.mats[0].albedo.w == 1 && a.mats[0].orm.w == 1 && !a.mats[0].albedo_textured);
        CHECK(a.mats[0].orm.data[0] == 1.0f && a.mats[0].orm.data[1] == 1.0f && a.mats[0].orm.data[2] == 1.0f);
    }
    mf_gltf_asset_free(&a);
    /* mesh only, through the extension dispatch */
    MfMesh r = {0};
    CHECK_OK(mf_mesh_read(glb, &r));
    check_same_mesh(&m, &r, 1e-6f, "mf_mesh_read");
    mf_mesh_free(&r);
    mf_image_free(&ta), mf_image_free(&to);
    mf_mesh_free(&m);
}

/* Reads the .glb made by our writer into its JSON and BIN parts. */
static int split_glb(const char *path, cJSON **json, unsigned char **bin, size_t *binlen) {
    char *d = NULL;
    size_t n = 0;
    if (mf_read_file(path, &d, &n) || n < 28) return 0;
    const unsigned char *u = (const unsigned char *)d;
    uint32_t jl = (uint32_t)u[12] | (uint32_t)u[13] << 8 | (uint32_t)u[14] << 16 | (uint32_t)u[15] << 24;
    const unsigned char *b = u + 28 + jl;
    *binlen = (size_t)b[-8] | (size_t)b[-7] << 8 | (size_t)b[-6] << 16 | (size_t)b[-5] << 24;
    *bin = malloc(*binlen);
    memcpy(*bin, b, *binlen);
    *json = cJSON_ParseWithLength(d + 20, jl);
    free(d);
    return *json != NULL;
}

/* The same asset as .gltf: base64 data-URI buffer; external buffer file with an external image. */
MF_TEST(gltf_read_gltf_uris) {
    const char *alb = mf_test_path("u_albedo.png"), *orm = mf_test_path("u_orm.png"), *glb = mf_test_path("u.glb");
    MfMesh m = {0};
    make_source(&m, alb, orm);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = alb, mat.orm_png = orm;
    CHECK_OK(mf_gltf_write_glb(glb, &m, &mat));
    cJSON *j = NULL;
    unsigned char *bin = NULL;
    size_t binlen = 0;
    CHECK(split_glb(glb, &j, &bin, &binlen));
    if (!j) { mf_mesh_free(&m); return; }
    char *enc = b64(bin, binlen), *uri = malloc(strlen(enc) + 64);
    sprintf(uri, "data:application/octet-stream;base64,%s", enc);
    cJSON *buf0 = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "buffers"), 0);
    cJSON_AddStringToObject(buf0, "uri", uri);
    char *txt = cJSON_Print(j);
    const char *g1 = mf_test_path("u_datauri.gltf");
    CHECK_OK(mf_write_file(g1, txt, strlen(txt)));
    free(txt);
    MfGltfAsset a = {0};
    CHECK_OK(mf_gltf_read(g1, &a));
    check_same_mesh(&m, &a.mesh, 1e-6f, g1);
    MfImage ta = {0};
    CHECK_OK(mf_image_read(alb, MF_ENC_SRGB, &ta));
    if (a.nmat == 1) check_same_image(&ta, &a.mats[0].albedo, 1.0f, "data-URI albedo");
    mf_gltf_asset_free(&a);
    /* occlusionTexture: the ORM image's R with strength 0.5 -> 1 + 0.5 (R - 1) */
    cJSON *mat0 = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "materials"), 0);
    cJSON *occ = cJSON_AddObjectToObject(mat0, "occlusionTexture");
    cJSON_AddNumberToObject(occ, "index", 1);
    cJSON_AddNumberToObject(occ, "strength", 0.5);
    txt = cJSON_Print(j);
    CHECK_OK(mf_write_file(g1, txt, strlen(txt)));
    free(txt);
    CHECK_OK(mf_gltf_read(g1, &a));
    MfImage to = {0};
    CHECK_OK(mf_image_read(orm, MF_ENC_LINEAR, &to));
    if (a.nmat == 1 && a.mats[0].orm.w == to.w && a.mats[0].orm.h == to.h) {
        double worst = 0;
        for (size_t i = 0; i < (size_t)to.w * to.h; ++i) worst = fmax(worst, fabs(a.mats[0].orm.data[3 * i] - (1.0 + 0.5 * (to.data[3 * i] - 1.0))));
        CHECK_MSG(worst < 1e-6, "occlusion R differs by %g", worst);
    } else CHECK_MSG(0, "occlusion: ORM image missing or of the wrong size");
    mf_image_free(&to);
    mf_gltf_asset_free(&a);
    cJSON_DeleteItemFromObject(mat0, "occlusionTexture");
    /* external: the buffer in sub/mesh.bin, the albedo image as a file next to it */
    CHECK_OK(mf_mkdirs(mf_test_path("u_ext/sub")));
    CHECK_OK(mf_write_file(mf_test_path("u_ext/sub/mesh.bin"), bin, binlen));
    char *png = NULL;
    size_t pl = 0;
    CHECK_OK(mf_read_file(alb, &png, &pl));
    CHECK_OK(mf_write_file(mf_test_path("u_ext/sub/albedo.png"), png, pl));
    free(png);
    cJSON_ReplaceItemInObject(buf0, "uri", cJSON_CreateString("sub/mesh.bin"));
    cJSON *im0 = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "images"), 0);
    cJSON_DeleteItemFromObject(im0, "bufferView");
    cJSON_DeleteItemFromObject(im0, "mimeType");
    cJSON_AddStringToObject(im0, "uri", "sub/albedo.png");
    txt = cJSON_Print(j);
    const char *g2 = mf_test_path("u_ext/asset.gltf");
    CHECK_OK(mf_write_file(g2, txt, strlen(txt)));
    free(txt);
    CHECK_OK(mf_gltf_read(g2, &a));
    check_same_mesh(&m, &a.mesh, 1e-6f, g2);
    if (a.nmat == 1) check_same_image(&ta, &a.mats[0].albedo, 1.0f, "external albedo");
    mf_gltf_asset_free(&a);
    /* the external buffer missing: named */
    remove(mf_test_path("u_ext/sub/mesh.bin"));
    CHECK_ERR(mf_gltf_read(g2, &a), "buffers[0].uri");
    CHECK_ERR(mf_gltf_read(g2, &a), "mesh.bin");
    mf_image_free(&ta);
    free(enc), free(uri), free(bin);
    cJSON_Delete(j);
    mf_mesh_free(&m);
}

/* One triangle (0,0,0) (1,0,0) (0,1,0) with normal +Z in glTF axes, as a .gltf with a data URI,
 * under the given node list (JSON text) and scene roots. */
static void write_triangle(const char *path, const char *nodes, const char *roots, const char *extra_prim, const char *extra_root) {
    float data[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    char *enc = b64((const unsigned char *)data, sizeof data);
    char *txt = malloc(strlen(enc) + 4096);
    CHECK(txt != NULL);
    if (!txt) {
        free(enc);
        return;
    }
    sprintf(txt,
            "{\"asset\":{\"version\":\"2.0\"}%s,\"scene\":0,\"scenes\":[{\"nodes\":%s}],\"nodes\":%s,"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1}%s}]}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
            "{\"bufferView\":0,\"byteOffset\":36,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteLength\":72}],"
            "\"buffers\":[{\"byteLength\":72,\"uri\":\"data:application/octet-stream;base64,%s\"}]}",
            extra_root, roots, nodes, extra_prim, enc);
    CHECK_OK(mf_write_file(path, txt, strlen(txt)));
    free(txt), free(enc);
}

/* Node transforms: TRS on a parent, a column-major matrix on its child; a mirror flips winding. */
MF_TEST(gltf_read_node_transforms) {
    const char *p = mf_test_path("tri.gltf");
    /* parent: translate (1, 2, 3), rotate 90 degrees about +Y, scale 2; child: matrix translating (0, 0, 5) */
    write_triangle(p,
                   "[{\"translation\":[1,2,3],\"rotation\":[0,0.70710678118654752,0,0.70710678118654752],\"scale\":[2,2,2],\"children\":[1]},"
                   "{\"mesh\":0,\"matrix\":[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,5,1]}]",
                   "[0]", "", "");
    MfGltfAsset a = {0};
    CHECK_OK(mf_gltf_read(p, &a));
    CHECK(a.mesh.nv == 3 && a.mesh.nt == 1 && a.mesh.uv == NULL);
    if (a.mesh.nv == 3) {
        /* glTF world: child moves (0,0,5); Ry(90): (x,y,z) -> (z, y, -x); x2; +(1,2,3).
         * v0 (0,0,0) -> (0,0,5) -> (5,0,0) -> (10,0,0) -> (11,2,3); ours (x, -z, y) = (11,-3,2)
         * v1 (1,0,0) -> (1,0,5) -> (5,0,-1) -> (10,0,-2) -> (11,2,1) -> (11,-1,2)
         * v2 (0,1,0) -> (0,1,5) -> (5,1,0) -> (10,2,0) -> (11,4,3) -> (11,-3,4)
         * normal +Z -> Ry -> +X -> ours +X */
        const float want[9] = {11, -3, 2, 11, -1, 2, 11, -3, 4};
        for (int i = 0; i < 9; ++i) CHECK_NEAR(a.mesh.pos[i], want[i], 1e-5);
        CHECK_NEAR(a.mesh.nrm[0], 1, 1e-6);
        CHECK_NEAR(a.mesh.nrm[1], 0, 1e-6);
        CHECK_NEAR(a.mesh.nrm[2], 0, 1e-6);
        CHECK(a.mesh.tri[0] == 0 && a.mesh.tri[1] == 1 && a.mesh.tri[2] == 2);
    }
    mf_gltf_asset_free(&a);
    /* a mirror (scale -1 on x): winding reversed, so the triangle still faces its normal */
    write_triangle(p, "[{\"mesh\":0,\"scale\":[-1,1,1]}]", "[0]", "", "");
    CHECK_OK(mf_gltf_read(p, &a));
    if (a.mesh.nt == 1) {
        CHECK(a.mesh.tri[0] == 0 && a.mesh.tri[1] == 2 && a.mesh.tri[2] == 1);
        const float *P = a.mesh.pos;
        const uint32_t *t = a.mesh.tri;
        float e1[3], e2[3];
        for (int k = 0; k < 3; ++k) e1[k] = P[3 * t[1] + k] - P[3 * t[0] + k], e2[k] = P[3 * t[2] + k] - P[3 * t[0] + k];
        float fz = e1[0] * e2[1] - e1[1] * e2[0], fy = e1[2] * e2[0] - e1[0] * e2[2];
        /* glTF +Z normal is our -Y: face normal (e1 x e2) must agree with the vertex normal */
        CHECK_MSG(fy * a.mesh.nrm[1] > 0 && fabsf(fz) < 1e-6f, "mirrored triangle faces away (%g vs normal %g)", fy, a.mesh.nrm[1]);
    }
    mf_gltf_asset_free(&a);
}

/* A scene file with a .glb mesh takes its material; a result's scene.glb reads as the result. */
MF_TEST(gltf_read_scene_and_result_hooks) {
    const char *dir = mf_test_path("hook_result");
    CHECK_OK(mf_mkdirs(dir));
    char alb[MF_PATH_MAX], orm[MF_PATH_MAX], obj[MF_PATH_MAX], glb[MF_PATH_MAX], scene[MF_PATH_MAX];
    mf_path_join(alb, sizeof alb, dir, "albedo.png"), mf_path_join(orm, sizeof orm, dir, "orm.png");
    mf_path_join(obj, sizeof obj, dir, "mesh.obj"), mf_path_join(glb, sizeof glb, dir, "scene.glb");
    mf_path_join(scene, sizeof scene, dir, "scene.json");
    MfMesh m = {0};
    make_source(&m, alb, orm);
    CHECK_OK(mf_obj_write(obj, &m, NULL));
    mf_mesh_free(&m);
    /* what mf recon does: scene.glb from the OBJ as read back and the two PNGs */
    CHECK_OK(mf_obj_read(obj, &m));
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = alb, mat.orm_png = orm;
    CHECK_OK(mf_gltf_write_glb(glb, &m, &mat));
    EvResult a = {0}, b = {0};
    CHECK_OK(ev_result_load(dir, NULL, &a));
    CHECK_OK(ev_result_load(glb, NULL, &b));
    check_same_mesh(&a.mesh, &b.mesh, 1e-6f, "scene.glb vs mesh.obj");
    check_same_image(&a.kd, &b.kd, 1.0f, "scene.glb albedo vs albedo.png");
    check_same_image_from(&a.orm, &b.orm, 1.0f, 1, "scene.glb ORM vs orm.png");
    ev_result_free(&a), ev_result_free(&b);
    /* scene file: mesh scene.glb, no material given -> the glb's textures */
    const char *js = "{\"mesh\": \"scene.glb\", \"cameras\": {\"camera_angle_x\": 0.69, \"frames\": [{\"transform_matrix\": "
                     "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}, \"width\": 8, \"height\": 8}";
    CHECK_OK(mf_write_file(scene, js, strlen(js)));
    MfScene s = {0};
    CHECK_OK(mf_scene_load(scene, &s));
    CHECK(s.nmat == 1 && s.mats && s.mats[0].kd && s.mats[0].orm);
    if (s.nmat == 1 && s.mats[0].kd) {
        MfImage ta = {0};
        CHECK_OK(mf_image_read(alb, MF_ENC_SRGB, &ta));
        check_same_image(&ta, s.mats[0].kd, 1.0f, "scene material from the glb");
        mf_image_free(&ta);
        check_same_mesh(&m, &s.mesh, 1e-6f, "scene mesh from the glb");
    }
    mf_scene_free(&s);
    mf_mesh_free(&m);
}

/* Hand-made bad files: each refused with a message naming the file and the problem. */
MF_TEST(gltf_read_bad_inputs) {
    const char *glb = mf_test_path("bad_src.glb");
    MfMesh m = {0};
    CHECK_OK(mf_mesh_uv_sphere(&m, 6, 4, mf_v3(0, 0, 0), 0.5f));
    CHECK_OK(mf_gltf_write_glb(glb, &m, NULL));
    mf_mesh_free(&m);
    char *d = NULL;
    size_t n = 0;
    CHECK_OK(mf_read_file(glb, &d, &n));
    MfGltfAsset a = {0};
    const char *p = mf_test_path("bad.glb");
    /* truncated: the header's length disagrees with the file */
    CHECK_OK(mf_write_file(p, d, n / 2));
    CHECK_ERR(mf_gltf_read(p, &a), p);
    CHECK_ERR(mf_gltf_read(p, &a), "truncated");
    CHECK_OK(mf_write_file(p, d, 10));
    CHECK_ERR(mf_gltf_read(p, &a), "truncated .glb");
    /* wrong magic */
    d[0] = 'X';
    CHECK_OK(mf_write_file(p, d, n));
    CHECK_ERR(mf_gltf_read(p, &a), "not a glTF file");
    d[0] = 'g';
    free(d);
    cJSON *j = NULL;
    unsigned char *bin = NULL;
    size_t bl = 0;
    CHECK(split_glb(glb, &j, &bin, &bl));
    if (!j) return;
    struct { const char *edit, *needle; } cases[] = {
        {"accessors.0.count=100000", "do not fit bufferViews"},            /* accessor out of bounds */
        {"accessors.0.count=2147483647", "do not fit bufferViews"},        /* huge count */
        {"accessors.0.byteOffset=1e15", "accessors[0].byteOffset: expected an integer"},
        {"accessors.0.byteOffset=64", "do not fit bufferViews"},
        {"bufferViews.0.byteLength=1e12", "outside buffers[0]"},
        {"buffers.0.byteLength=1e12", "only"},                            /* more bytes than the BIN chunk holds */
        {"accessors.3.componentType=5126", "must be unsigned"},
        {"accessors.0.sparse={}", "sparse accessors are not supported"},
        {"meshes.0.primitives.0.mode=1", "only triangles"},
        {"meshes.0.primitives.0.indices=99", "accessors[99] does not exist"},
        {"nodes.0.mesh=7", "meshes[7] does not exist"},
        {"nodes.0.children=[0]", "reached twice"},
        {"extensionsRequired=[\"KHR_draco_mesh_compression\"]", "KHR_draco_mesh_compression is not supported"},
        {"asset.version=\"1.0\"", "only glTF 2.x"},
        {"buffers.0.uri=\"missing.bin\"", "missing.bin"},                 /* missing buffer */
        {"nodes.0.rotation=[0,0,0,0]", "not a unit quaternion"},
        {"nodes.0.translation=[1e30,0,0]", "out of range"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof *cases; ++c) {
        cJSON *k = cJSON_Duplicate(j, 1);
        char path[256], *eq = strchr(cases[c].edit, '=');
        snprintf(path, sizeof path, "%.*s", (int)(eq - cases[c].edit), cases[c].edit);
        cJSON *val = cJSON_Parse(eq + 1), *o = k;
        char *last = NULL;
        for (char *tok = strtok(path, "."); tok; tok = strtok(NULL, ".")) {
            if (last) o = cJSON_IsArray(o) ? cJSON_GetArrayItem(o, atoi(last)) : cJSON_GetObjectItem(o, last);
            last = tok;
        }
        if (cJSON_IsArray(o)) cJSON_ReplaceItemInArray(o, atoi(last), val);
        else if (cJSON_GetObjectItem(o, last)) cJSON_ReplaceItemInObject(o, last, val);
        else cJSON_AddItemToObject(o, last, val);
        char *txt = cJSON_PrintUnformatted(k);
        write_glb(p, txt, bin, bl);
        mf_error_clear();
        int rc = mf_gltf_read(p, &a);
        CHECK_MSG(rc != 0 && strstr(mf_error(), cases[c].needle) && strstr(mf_error(), p), "%s: rc %d, message '%s' (wanted '%s' and the file name)",
                  cases[c].edit, rc, mf_error(), cases[c].needle);
        if (!rc) mf_gltf_asset_free(&a);
        free(txt);
        cJSON_Delete(k);
    }
    /* an index out of range: the first index set to 100000 in the BIN chunk (indices are uint32 at accessors[3]'s view) */
    const cJSON *iv = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "bufferViews"), 3);
    size_t off = (size_t)cJSON_GetObjectItem(iv, "byteOffset")->valuedouble;
    put32(bin + off, 100000);
    char *txt = cJSON_PrintUnformatted(j);
    write_glb(p, txt, bin, bl);
    CHECK_ERR(mf_gltf_read(p, &a), "= 100000 is out of range");
    /* no BIN chunk at all: the buffer is missing */
    write_glb(p, txt, NULL, 0);
    CHECK_ERR(mf_gltf_read(p, &a), "missing buffer");
    free(txt), free(bin);
    cJSON_Delete(j);
    /* a texture on TEXCOORD_1, and a WebP image */
    const char *tc = mf_test_path("bad_tc.gltf");
    write_triangle(tc, "[{\"mesh\":0}]", "[0]", ",\"material\":0",
                   ",\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"texCoord\":1}}}],"
                   "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"a.webp\"}]");
    CHECK_ERR(mf_gltf_read(tc, &a), "only TEXCOORD_0");
    write_triangle(tc, "[{\"mesh\":0}]", "[0]", ",\"material\":0",
                   ",\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
                   "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"data:image/webp;base64,AAAA\"}]");
    CHECK_ERR(mf_gltf_read(tc, &a), "image type 'image/webp' is not supported");
    /* a directory */
    CHECK_ERR(mf_gltf_read(mf_test_tmpdir(), &a), "directory");
}

/* ---- normalTexture, TANGENT, and what is not rendered ---- */

/* One triangle (0,0,0) (1,0,0) (0,1,0), normal +Z, TEXCOORD_0 (x, 1 - y) (so u runs along +X and
 * our v along +Y), optional TANGENT tan (4 numbers for every vertex), and material JSON mat
 * (an object's text), written as .gltf with a data-URI buffer; the images are files beside it. */
static void write_nm_triangle_uv(const char *path, const float *tan, const char *mat, const float *uv);
static void write_nm_triangle(const char *path, const float *tan, const char *mat) { write_nm_triangle_uv(path, tan, mat, NULL); }
/* uv: 6 numbers replacing TEXCOORD_0, or NULL */
static void write_nm_triangle_uv(const char *path, const float *tan, const char *mat, const float *uv) {
    float data[36] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* POSITION */ 0, 0, 1, 0, 0, 1, 0, 0, 1, /* NORMAL */
                      0, 1, 1, 1, 0, 0 /* TEXCOORD_0 */};
    if (uv) memcpy(data + 18, uv, 6 * sizeof(float));
    for (int i = 0; tan && i < 3; ++i) memcpy(data + 24 + 4 * i, tan, 4 * sizeof(float));
    char *enc = b64((const unsigned char *)data, sizeof data);
    char *txt = malloc(strlen(enc) + strlen(mat) + 4096);
    CHECK(txt != NULL);
    if (!txt) {
        free(enc);
        return;
    }
    sprintf(txt,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2%s},\"material\":0}]}],"
            "\"materials\":[%s],\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"nm.png\"}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
            "{\"bufferView\":0,\"byteOffset\":36,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
            "{\"bufferView\":0,\"byteOffset\":72,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"},"
            "{\"bufferView\":0,\"byteOffset\":96,\"componentType\":5126,\"count\":3,\"type\":\"VEC4\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteLength\":144}],"
            "\"buffers\":[{\"byteLength\":144,\"uri\":\"data:application/octet-stream;base64,%s\"}]}",
            tan ? ",\"TANGENT\":3" : "", mat, enc);
    CHECK_OK(mf_write_file(path, txt, strlen(txt)));
    free(txt), free(enc);
}

/* Texel (x, y) of the material's normal map against the tangent-space vector want (normalised here). */
static void check_texel(const MfGltfAsset *a, int x, int y, double wx, double wy, double wz, const char *what) {
    CHECK_MSG(a->nmat == 1 && a->mats[0].has_normal, "%s: no normal map read", what);
    if (a->nmat != 1 || !a->mats[0].has_normal) return;
    const MfImage *m = &a->mats[0].normal;
    double l = sqrt(wx * wx + wy * wy + wz * wz), w[3] = {wx / l, wy / l, wz / l};
    const float *v = mf_image_px(m, x, y);
    double err = 0;
    for (int k = 0; k < 3; ++k) err = fmax(err, fabs((2.0 * v[k] - 1.0) - w[k]));
    CHECK_MSG(err < 2e-3, "%s: texel (%d, %d) = (%.4f %.4f %.4f) in tangent space, expected (%.4f %.4f %.4f)", what, x, y, 2 * v[0] - 1,
              2 * v[1] - 1, 2 * v[2] - 1, w[0], w[1], w[2]);
}

/* normalTexture: read (linear), scale applied as the spec says, and with TANGENT re-expressed in
 * our tangent frames (mf_mesh_tangents): a file frame equal to ours leaves the map alone, one
 * turned by 90 degrees or mirrored (w = -1) turns or mirrors the texels it covers; texels outside
 * every triangle's footprint (plus one texel) are left alone. Our writer's scene.glb (TANGENT =
 * our frames) reads back as the normal.png it was given. */
MF_TEST(gltf_read_normal_texture) {
    const char *dir = mf_test_path("nmtex");
    CHECK_OK(mf_mkdirs(dir));
    char png[MF_PATH_MAX], gl[MF_PATH_MAX];
    mf_path_join(png, sizeof png, dir, "nm.png"), mf_path_join(gl, sizeof gl, dir, "tri.gltf");
    const unsigned char tex[3] = {204, 128, 230};
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 8, 8, 3));
    for (int i = 0; i < 64; ++i)
        for (int c = 0; c < 3; ++c) im.data[3 * i + c] = tex[c] / 255.0f;
    CHECK_OK(mf_image_write(png, &im, MF_ENC_LINEAR, 8));
    mf_image_free(&im);
    CHECK_OK(mf_image_read(png, MF_ENC_LINEAR, &im)); /* the decoded texels */
    const double tx = 2 * tex[0] / 255.0 - 1, ty = 2 * tex[1] / 255.0 - 1, tz = 2 * tex[2] / 255.0 - 1;
    MfGltfAsset a = {0};
    /* no TANGENT: the map as stored; with scale 0.5: x and y halved, renormalised */
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":0}}");
    CHECK_OK(mf_gltf_read(gl, &a));
    CHECK(!a.tangents && a.nmat == 1 && a.mats[0].has_normal && a.mats[0].normal.w == 8 && im.c == 3);
    if (a.nmat == 1 && a.mats[0].has_normal && a.mats[0].normal.w == 8 && im.c == 3)
        CHECK(!memcmp(a.mats[0].normal.data, im.data, sizeof(float) * 192)); /* unchanged, bit for bit */
    mf_gltf_asset_free(&a);
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":0,\"scale\":0.5}}");
    CHECK_OK(mf_gltf_read(gl, &a));
    check_texel(&a, 2, 3, 0.5 * tx, 0.5 * ty, tz, "scale 0.5");
    CHECK_NEAR(a.nmat == 1 ? a.mats[0].normal_scale : 0, 0.5, 0);
    mf_gltf_asset_free(&a);
    /* TANGENT along +X (u), w = +1: our frame (T = +X, B = N x T = +Y in glTF axes) */
    const float t_same[4] = {1, 0, 0, 1}, t_turn[4] = {0, 1, 0, 1}, t_mirror[4] = {1, 0, 0, -1};
    write_nm_triangle(gl, t_same, "{\"normalTexture\":{\"index\":0}}");
    CHECK_OK(mf_gltf_read(gl, &a));
    CHECK(a.tangents == 1);
    check_texel(&a, 1, 6, tx, ty, tz, "TANGENT = our frame");
    mf_gltf_asset_free(&a);
    /* TANGENT along +Y (our bitangent): file B = N x T = -X, so (x, y) -> ours (-y, x) */
    write_nm_triangle(gl, t_turn, "{\"normalTexture\":{\"index\":0}}");
    CHECK_OK(mf_gltf_read(gl, &a));
    /* the triangle covers the image's lower-left half (row 0 is v = 1, the vertex (0, 1, 0)) */
    check_texel(&a, 0, 7, -ty, tx, tz, "TANGENT turned 90 degrees, inside");
    check_texel(&a, 1, 6, -ty, tx, tz, "TANGENT turned 90 degrees, inside");
    /* (the footprint wraps like the sampler: texels within one texel across the map's border count) */
    if (a.nmat == 1 && a.mats[0].has_normal && a.mats[0].normal.w == 8)
        CHECK_MSG(!memcmp(mf_image_px(&a.mats[0].normal, 6, 1), mf_image_px(&im, 6, 1), 3 * sizeof(float)),
                  "TANGENT turned 90 degrees: texel (6, 1), outside the triangle, changed");
    mf_gltf_asset_free(&a);
    /* UVs far out (1e12) or tiling 100 times: the re-expression skips those triangles (with a
     * warning) instead of visiting billions of texels */
    const float far[6] = {1e12f, 1e12f, 1e12f + 1e6f, 1e12f, 1e12f, 1e12f + 1e6f}, tiled[6] = {0, 0, 100, 0, 0, 100};
    write_nm_triangle_uv(gl, t_turn, "{\"normalTexture\":{\"index\":0}}", far);
    CHECK_OK(mf_gltf_read(gl, &a));
    mf_gltf_asset_free(&a);
    write_nm_triangle_uv(gl, t_turn, "{\"normalTexture\":{\"index\":0}}", tiled);
    CHECK_OK(mf_gltf_read(gl, &a));
    if (a.nmat == 1 && a.mats[0].has_normal) CHECK(!memcmp(a.mats[0].normal.data, im.data, sizeof(float) * 192));
    mf_gltf_asset_free(&a);
    /* w = -1: the file's bitangent is -ours, so y flips */
    write_nm_triangle(gl, t_mirror, "{\"normalTexture\":{\"index\":0}}");
    CHECK_OK(mf_gltf_read(gl, &a));
    check_texel(&a, 1, 6, tx, -ty, tz, "TANGENT w = -1");
    mf_gltf_asset_free(&a);
    mf_image_free(&im);
    /* our writer's glb (normalTexture + TANGENT from mf_mesh_tangents) reads back as its normal.png */
    MfMesh m = {0};
    char nrm[MF_PATH_MAX], glb[MF_PATH_MAX];
    mf_path_join(nrm, sizeof nrm, dir, "normal.png"), mf_path_join(glb, sizeof glb, dir, "scene.glb");
    CHECK_OK(mf_mesh_uv_sphere(&m, 12, 8, mf_v3(0, 0, 0), 0.5f));
    CHECK_OK(mf_image_alloc(&im, 8, 8, 3));
    for (int i = 0; i < 64; ++i) { /* unit tangent-space vectors varying over the map */
        double ang = 0.7 * i, sx = 0.5 * cos(ang), sy = 0.5 * sin(ang), sz = sqrt(1 - sx * sx - sy * sy);
        im.data[3 * i] = (float)(0.5 * (sx + 1)), im.data[3 * i + 1] = (float)(0.5 * (sy + 1)), im.data[3 * i + 2] = (float)(0.5 * (sz + 1));
    }
    CHECK_OK(mf_image_write(nrm, &im, MF_ENC_LINEAR, 8));
    mf_image_free(&im);
    CHECK_OK(mf_image_read(nrm, MF_ENC_LINEAR, &im));
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.normal_png = nrm;
    CHECK_OK(mf_gltf_write_glb(glb, &m, &mat));
    CHECK_OK(mf_gltf_read(glb, &a));
    CHECK(a.tangents == 1 && a.nmat == 1 && a.mats[0].has_normal);
    if (a.nmat == 1 && a.mats[0].has_normal && a.mats[0].normal.w == 8) {
        double worst = 0;
        for (int i = 0; i < 64 * 3; ++i) worst = fmax(worst, fabs(a.mats[0].normal.data[i] - im.data[i]));
        CHECK_MSG(worst < 2.0 / 255, "our glb's normal map reads back off by %g", worst);
    }
    mf_gltf_asset_free(&a);
    /* mf relight / mf eval on that glb: the result carries the normal map */
    EvResult r = {0};
    CHECK_OK(ev_result_load(glb, NULL, &r));
    CHECK(r.has_normal && r.normal.w == 8);
    ev_result_free(&r);
    /* mf render: a scene file on the glb takes its normal map; one on an OBJ names it with "normal" */
    char scene[MF_PATH_MAX], obj[MF_PATH_MAX];
    mf_path_join(scene, sizeof scene, dir, "scene.json"), mf_path_join(obj, sizeof obj, dir, "mesh.obj");
    CHECK_OK(mf_obj_write(obj, &m, NULL));
    const char *cams = "\"cameras\": {\"camera_angle_x\": 0.69, \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}";
    const char *meshes[2] = {"\"mesh\": \"scene.glb\"", "\"mesh\": \"mesh.obj\", \"material\": {\"normal\": \"normal.png\"}"};
    for (int k = 0; k < 2; ++k) {
        char js[1024];
        snprintf(js, sizeof js, "{%s, %s}", meshes[k], cams);
        CHECK_OK(mf_write_file(scene, js, strlen(js)));
        MfScene sc = {0};
        CHECK_OK(mf_scene_load(scene, &sc));
        CHECK_MSG(sc.nmat == 1 && sc.mats && sc.mats[0].normal && sc.mats[0].normal->w == 8, "scene %d: no normal map", k);
        mf_scene_free(&sc);
    }
    mf_image_free(&im);
    mf_mesh_free(&m);
}

/* Bad normalTexture references are refused naming the file: a texture index out of range, a
 * missing image file, a second UV set. */
MF_TEST(gltf_read_normal_texture_bad) {
    const char *dir = mf_test_path("nmbad");
    CHECK_OK(mf_mkdirs(dir));
    char gl[MF_PATH_MAX];
    mf_path_join(gl, sizeof gl, dir, "tri.gltf");
    MfGltfAsset a = {0};
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":3}}");
    CHECK_ERR(mf_gltf_read(gl, &a), gl);
    CHECK_ERR(mf_gltf_read(gl, &a), "normalTexture: textures[3] does not exist");
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":0}}"); /* nm.png is not there */
    CHECK_ERR(mf_gltf_read(gl, &a), gl);
    CHECK_ERR(mf_gltf_read(gl, &a), "nm.png");
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":0,\"texCoord\":1}}");
    CHECK_ERR(mf_gltf_read(gl, &a), "normalTexture.texCoord = 1: only TEXCOORD_0");
    write_nm_triangle(gl, NULL, "{\"normalTexture\":{\"index\":0,\"scale\":\"big\"}}");
    CHECK_ERR(mf_gltf_read(gl, &a), "normalTexture.scale");
}

/* Emission and other features that change the look are listed (and warned about) by material;
 * mf gen --asset says so on stderr and records them in split.json and gt/object.json. */
MF_TEST(gltf_read_unrendered_warned) {
    const char *dir = mf_test_path("emis");
    CHECK_OK(mf_mkdirs(dir));
    char gl[MF_PATH_MAX], png[MF_PATH_MAX];
    mf_path_join(gl, sizeof gl, dir, "glow.gltf"), mf_path_join(png, sizeof png, dir, "nm.png");
    write_flat(png, 2, 2, 3, 0.5f, MF_ENC_LINEAR);
    write_nm_triangle(gl, NULL,
                      "{\"name\":\"Lamp\",\"emissiveFactor\":[1,0.5,0],\"alphaMode\":\"BLEND\","
                      "\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1}},"
                      "\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":{}}}}}");
    MfGltfAsset a = {0};
    CHECK_OK(mf_gltf_read(gl, &a));
    const char *u = a.nmat == 1 ? a.mats[0].unrendered : "";
    CHECK_MSG(strstr(u, "emissiveFactor") && strstr(u, "alphaMode BLEND") && strstr(u, "KHR_materials_clearcoat") &&
                  strstr(u, "KHR_texture_transform"), "unrendered: '%s'", u);
    mf_gltf_asset_free(&a);
    /* nothing to say about a plain material */
    write_nm_triangle(gl, NULL, "{\"emissiveFactor\":[0,0,0]}");
    CHECK_OK(mf_gltf_read(gl, &a));
    CHECK_MSG(a.nmat == 1 && !a.mats[0].unrendered[0], "unrendered: '%s'", a.nmat == 1 ? a.mats[0].unrendered : "?");
    mf_gltf_asset_free(&a);
    /* an emissive texture alone, through mf gen --asset (layout only) */
    write_nm_triangle(gl, NULL, "{\"name\":\"Lamp\",\"emissiveTexture\":{\"index\":0},\"emissiveFactor\":[1,1,1]}");
    char probes[MF_PATH_MAX], out[MF_PATH_MAX], args[3 * MF_PATH_MAX + 128], err[4096];
    mf_path_join(probes, sizeof probes, dir, "probes"), mf_path_join(out, sizeof out, dir, "split");
    CHECK_OK(mf_mkdirs(probes));
    for (int i = 0; i < 3; ++i) {
        char p[MF_PATH_MAX + 32];
        snprintf(p, sizeof p, "%s/p%d.exr", probes, i);
        write_flat(p, 8, 4, 3, 0.5f, MF_ENC_LINEAR);
    }
    snprintf(args, sizeof args, "gen --split tiny --asset %s --env-dir %s --no-render -o %s", gl, probes, out);
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 0);
    CHECK_MSG(strstr(err, gl) && strstr(err, "'Lamp'") && strstr(err, "emissiveFactor, emissiveTexture") && strstr(err, "not rendered"),
              "stderr: %s", err);
    char p[MF_PATH_MAX + 32];
    cJSON *j = NULL;
    snprintf(p, sizeof p, "%s/split.json", out);
    CHECK_OK(mf_json_load(p, &j));
    const cJSON *sc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), 0);
    const char *nr = cJSON_GetStringValue(cJSON_GetObjectItem(sc, "not_rendered"));
    CHECK_MSG(nr && strstr(nr, "emissiveTexture"), "split.json not_rendered: %s", nr ? nr : "(none)");
    CHECK(cJSON_IsFalse(cJSON_GetObjectItem(sc, "normal_map")));
    cJSON_Delete(j);
    snprintf(p, sizeof p, "%s/000_glow/gt/object.json", out);
    CHECK_OK(mf_json_load(p, &j));
    nr = cJSON_GetStringValue(cJSON_GetObjectItem(j, "not_rendered"));
    CHECK_MSG(nr && strstr(nr, "emissiveFactor"), "object.json not_rendered: %s", nr ? nr : "(none)");
    cJSON_Delete(j);
}
