/* Tests of mf/io/mf_gltf: a small .glb validator (header, chunk alignment and padding, JSON,
 * bufferView/accessor bounds and counts, POSITION min/max, embedded PNG bytes, flipped UVs,
 * positions and normals rotated from our +Z up to glTF's +Y up). */
#include <cJSON.h>
#include <float.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_gltf.h"
#include "io/mf_image.h"
#include "mf_test.h"

static uint32_t rd32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

static int num(const cJSON *o, const char *k, double dflt) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(o, k);
    return cJSON_IsNumber(it) ? (int)it->valuedouble : (int)dflt;
}

/* Validates the file and returns the parsed JSON (NULL on a failed check); *bin points into
 * *file (free *file). */
static cJSON *validate(const char *path, char **file, const unsigned char **bin, size_t *binlen) {
    size_t len = 0;
    *file = NULL;
    CHECK_OK(mf_read_file(path, file, &len));
    if (!*file) return NULL;
    const unsigned char *d = (const unsigned char *)*file;
    CHECK(len >= 28 && len % 4 == 0);
    if (len < 28) return NULL;
    CHECK(rd32(d) == 0x46546C67 && rd32(d + 4) == 2 && rd32(d + 8) == len);
    uint32_t jl = rd32(d + 12);
    CHECK(rd32(d + 16) == 0x4E4F534A && jl % 4 == 0 && 20 + jl + 8 <= len);
    if (20 + (size_t)jl + 8 > len) return NULL;
    /* JSON padded with spaces. */
    size_t jend = jl;
    while (jend > 0 && d[20 + jend - 1] == ' ') --jend;
    CHECK(jl - jend < 4);
    uint32_t bl = rd32(d + 20 + jl);
    CHECK(rd32(d + 24 + jl) == 0x004E4942 && bl % 4 == 0 && 28 + (size_t)jl + bl == len);
    *bin = d + 28 + jl;
    *binlen = bl;
    cJSON *j = cJSON_ParseWithLength((const char *)d + 20, jl);
    CHECK(j != NULL);
    if (!j) return NULL;
    const cJSON *asset = cJSON_GetObjectItem(j, "asset");
    CHECK(asset && cJSON_IsString(cJSON_GetObjectItem(asset, "version")) && strcmp(cJSON_GetObjectItem(asset, "version")->valuestring, "2.0") == 0);
    const cJSON *bufs = cJSON_GetObjectItem(j, "buffers");
    CHECK(cJSON_GetArraySize(bufs) == 1);
    size_t blen = (size_t)num(cJSON_GetArrayItem(bufs, 0), "byteLength", -1);
    CHECK(blen <= bl && bl - blen < 4);
    const cJSON *views = cJSON_GetObjectItem(j, "bufferViews"), *v;
    cJSON_ArrayForEach(v, views) {
        size_t off = (size_t)num(v, "byteOffset", 0), l = (size_t)num(v, "byteLength", -1);
        CHECK(num(v, "buffer", -1) == 0 && off % 4 == 0 && off + l <= blen);
    }
    const cJSON *acc = cJSON_GetObjectItem(j, "accessors"), *a;
    cJSON_ArrayForEach(a, acc) {
        const cJSON *vw = cJSON_GetArrayItem(views, num(a, "bufferView", -1));
        CHECK(vw != NULL);
        if (!vw) continue;
        int ct = num(a, "componentType", 0);
        CHECK(ct == 5126 || ct == 5125);
        const char *type = cJSON_GetObjectItem(a, "type")->valuestring;
        int nc = strcmp(type, "VEC4") == 0 ? 4 : strcmp(type, "VEC3") == 0 ? 3 : strcmp(type, "VEC2") == 0 ? 2 : 1;
        size_t need = (size_t)num(a, "byteOffset", 0) + (size_t)num(a, "count", 0) * nc * 4;
        CHECK_MSG(need <= (size_t)num(vw, "byteLength", 0), "accessor %s needs %zu bytes", type, need);
    }
    return j;
}

static void make_mesh(MfMesh *m) {
    /* A square pyramid with UVs. */
    static const float P[5][3] = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {0, 0, 1.5f}};
    static const uint32_t T[6][3] = {{0, 2, 1}, {0, 3, 2}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    mf_mesh_alloc(m, 5, 6, 0, 1);
    memcpy(m->pos, P, sizeof P);
    memcpy(m->tri, T, sizeof T);
    for (int i = 0; i < 5; ++i) {
        m->uv[2 * i] = 0.5f + 0.5f * P[i][0];
        m->uv[2 * i + 1] = 0.25f + 0.125f * P[i][1];
    }
}

MF_TEST(io_gltf_glb_structure) {
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 8, 4, 3));
    for (int i = 0; i < 8 * 4 * 3; ++i) im.data[i] = (float)(i % 7) / 6.0f;
    const char *alb = mf_test_path("albedo.png"), *orm = mf_test_path("orm.png");
    CHECK_OK(mf_image_write(alb, &im, MF_ENC_SRGB, 8));
    CHECK_OK(mf_image_write(orm, &im, MF_ENC_LINEAR, 8));
    MfMesh m = {0};
    make_mesh(&m);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.name = "pyramid";
    mat.albedo_png = alb;
    mat.orm_png = orm;
    const char *p = mf_test_path("scene.glb");
    CHECK_OK(mf_gltf_write_glb(p, &m, &mat));

    char *file = NULL;
    const unsigned char *bin = NULL;
    size_t binlen = 0;
    cJSON *j = validate(p, &file, &bin, &binlen);
    if (j) {
        const cJSON *prim = cJSON_GetArrayItem(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "meshes"), 0), "primitives"), 0);
        const cJSON *attr = cJSON_GetObjectItem(prim, "attributes");
        const cJSON *acc = cJSON_GetObjectItem(j, "accessors"), *views = cJSON_GetObjectItem(j, "bufferViews");
        const cJSON *ap = cJSON_GetArrayItem(acc, num(attr, "POSITION", -1));
        const cJSON *an = cJSON_GetArrayItem(acc, num(attr, "NORMAL", -1));
        const cJSON *at = cJSON_GetArrayItem(acc, num(attr, "TEXCOORD_0", -1));
        const cJSON *ai = cJSON_GetArrayItem(acc, num(prim, "indices", -1));
        CHECK(ap && an && at && ai);
        CHECK(num(attr, "TANGENT", -1) == -1); /* only with a normal map */
        if (ap && an && at && ai) {
            CHECK(num(ap, "count", 0) == 5 && num(an, "count", 0) == 5 && num(at, "count", 0) == 5 && num(ai, "count", 0) == 18);
            CHECK(num(ai, "componentType", 0) == 5125 && num(ap, "componentType", 0) == 5126);
            CHECK(num(prim, "mode", 4) == 4);
            /* min/max match the data; positions, indices and flipped UVs read back exactly. */
            const float *pos = (const float *)(bin + num(cJSON_GetArrayItem(views, num(ap, "bufferView", 0)), "byteOffset", 0));
            const float *uv = (const float *)(bin + num(cJSON_GetArrayItem(views, num(at, "bufferView", 0)), "byteOffset", 0));
            const float *nrm = (const float *)(bin + num(cJSON_GetArrayItem(views, num(an, "bufferView", 0)), "byteOffset", 0));
            const uint32_t *idx = (const uint32_t *)(bin + num(cJSON_GetArrayItem(views, num(ai, "bufferView", 0)), "byteOffset", 0));
            /* +Z up (ours) written +Y up (glTF's): (x, y, z) -> (x, z, -y), exactly */
            CHECK(memcmp(idx, m.tri, 18 * 4) == 0);
            for (int i = 0; i < 5; ++i)
                CHECK(pos[3 * i] == m.pos[3 * i] && pos[3 * i + 1] == m.pos[3 * i + 2] && pos[3 * i + 2] == -m.pos[3 * i + 1]);
            for (int i = 0; i < 5; ++i) {
                CHECK(uv[2 * i] == m.uv[2 * i] && uv[2 * i + 1] == 1.0f - m.uv[2 * i + 1]);
                CHECK_NEAR(nrm[3 * i] * nrm[3 * i] + nrm[3 * i + 1] * nrm[3 * i + 1] + nrm[3 * i + 2] * nrm[3 * i + 2], 1.0, 1e-5);
            }
            CHECK(nrm[3 * 4 + 1] > 0.99f); /* apex normal points up: +Y in glTF */
            const cJSON *mn = cJSON_GetObjectItem(ap, "min"), *mx = cJSON_GetObjectItem(ap, "max");
            CHECK(cJSON_GetArraySize(mn) == 3 && cJSON_GetArraySize(mx) == 3);
            float emn[3] = {-1, 0, -1}, emx[3] = {1, 1.5f, 1}; /* rotated to +Y up */
            for (int k = 0; k < 3 && cJSON_GetArraySize(mn) == 3; ++k) {
                CHECK((float)cJSON_GetArrayItem(mn, k)->valuedouble == emn[k]);
                CHECK((float)cJSON_GetArrayItem(mx, k)->valuedouble == emx[k]);
            }
        }
        /* Material with both textures; images are the PNG files' bytes. */
        const cJSON *pbr = cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "materials"), 0), "pbrMetallicRoughness");
        const cJSON *texs = cJSON_GetObjectItem(j, "textures"), *imgs = cJSON_GetObjectItem(j, "images");
        const char *slot[2] = {"baseColorTexture", "metallicRoughnessTexture"}, *src[2] = {alb, orm};
        for (int k = 0; k < 2; ++k) {
            const cJSON *ti = cJSON_GetObjectItem(pbr, slot[k]);
            CHECK_MSG(ti != NULL, "%s missing", slot[k]);
            if (!ti) continue;
            const cJSON *img = cJSON_GetArrayItem(imgs, num(cJSON_GetArrayItem(texs, num(ti, "index", -1)), "source", -1));
            CHECK(img && strcmp(cJSON_GetObjectItem(img, "mimeType")->valuestring, "image/png") == 0);
            const cJSON *vw = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "bufferViews"), num(img, "bufferView", -1));
            char *png = NULL;
            size_t plen = 0;
            CHECK_OK(mf_read_file(src[k], &png, &plen));
            CHECK(vw && (size_t)num(vw, "byteLength", 0) == plen);
            if (vw && png && (size_t)num(vw, "byteLength", 0) == plen) CHECK(memcmp(bin + num(vw, "byteOffset", 0), png, plen) == 0);
            free(png);
        }
        const cJSON *sc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), num(j, "scene", -1));
        CHECK(sc && cJSON_GetArraySize(cJSON_GetObjectItem(sc, "nodes")) == 1);
        cJSON_Delete(j);
    }
    free(file);

    /* Without textures and without UVs: still valid, no TEXCOORD_0, no images. */
    free(m.uv);
    m.uv = NULL;
    CHECK_OK(mf_gltf_write_glb(mf_test_path("plain.glb"), &m, NULL));
    j = validate(mf_test_path("plain.glb"), &file, &bin, &binlen);
    if (j) {
        CHECK(cJSON_GetObjectItem(j, "images") == NULL);
        cJSON_Delete(j);
    }
    free(file);
    /* Errors. */
    CHECK_ERR(mf_gltf_write_glb(mf_test_path("bad.glb"), &m, &mat), "textures need a mesh with UVs");
    mf_mesh_free(&m);
    make_mesh(&m);
    mat.albedo_png = mf_test_path("nothere.png");
    CHECK_ERR(mf_gltf_write_glb(mf_test_path("bad.glb"), &m, &mat), "nothere.png");
    CHECK_OK(mf_write_file(mf_test_path("fake.png"), "not a png", 9));
    mat.albedo_png = mf_test_path("fake.png");
    CHECK_ERR(mf_gltf_write_glb(mf_test_path("bad.glb"), &m, &mat), "fake.png: not a PNG");
    CHECK(!mf_file_exists(mf_test_path("bad.glb")));
    mf_mesh_free(&m);
    mf_image_free(&im);
}

/* A normal map: material.normalTexture holds the PNG's bytes, and the primitive carries TANGENT
 * (VEC4: unit xyz orthogonal to NORMAL, w = +-1). */
MF_TEST(io_gltf_normal_texture) {
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 4, 4, 3));
    for (int i = 0; i < 16; ++i) im.data[3 * i] = im.data[3 * i + 1] = 0.5f, im.data[3 * i + 2] = 1.0f;
    const char *np = mf_test_path("normal.png");
    CHECK_OK(mf_image_write(np, &im, MF_ENC_LINEAR, 8));
    MfMesh m = {0};
    make_mesh(&m);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.normal_png = np;
    const char *p = mf_test_path("nmap.glb");
    CHECK_OK(mf_gltf_write_glb(p, &m, &mat));
    char *file = NULL;
    const unsigned char *bin = NULL;
    size_t binlen = 0;
    cJSON *j = validate(p, &file, &bin, &binlen);
    if (j) {
        const cJSON *mo = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "materials"), 0);
        const cJSON *ti = cJSON_GetObjectItem(mo, "normalTexture");
        CHECK(ti != NULL);
        const cJSON *texs = cJSON_GetObjectItem(j, "textures"), *imgs = cJSON_GetObjectItem(j, "images");
        const cJSON *views = cJSON_GetObjectItem(j, "bufferViews"), *acc = cJSON_GetObjectItem(j, "accessors");
        const cJSON *img = ti ? cJSON_GetArrayItem(imgs, num(cJSON_GetArrayItem(texs, num(ti, "index", -1)), "source", -1)) : NULL;
        const cJSON *vw = img ? cJSON_GetArrayItem(views, num(img, "bufferView", -1)) : NULL;
        char *png = NULL;
        size_t plen = 0;
        CHECK_OK(mf_read_file(np, &png, &plen));
        CHECK(vw && (size_t)num(vw, "byteLength", 0) == plen);
        if (vw && png && (size_t)num(vw, "byteLength", 0) == plen) CHECK(memcmp(bin + num(vw, "byteOffset", 0), png, plen) == 0);
        free(png);
        const cJSON *prim = cJSON_GetArrayItem(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "meshes"), 0), "primitives"), 0);
        const cJSON *attr = cJSON_GetObjectItem(prim, "attributes");
        const cJSON *at = cJSON_GetArrayItem(acc, num(attr, "TANGENT", -1)), *an = cJSON_GetArrayItem(acc, num(attr, "NORMAL", -1));
        CHECK(at && an && strcmp(cJSON_GetObjectItem(at, "type")->valuestring, "VEC4") == 0 && num(at, "count", 0) == 5);
        if (at && an) {
            const float *t = (const float *)(bin + num(cJSON_GetArrayItem(views, num(at, "bufferView", 0)), "byteOffset", 0));
            const float *n = (const float *)(bin + num(cJSON_GetArrayItem(views, num(an, "bufferView", 0)), "byteOffset", 0));
            for (int i = 0; i < 5; ++i) {
                CHECK_NEAR(t[4 * i] * t[4 * i] + t[4 * i + 1] * t[4 * i + 1] + t[4 * i + 2] * t[4 * i + 2], 1.0, 1e-5);
                CHECK_NEAR(t[4 * i] * n[3 * i] + t[4 * i + 1] * n[3 * i + 1] + t[4 * i + 2] * n[3 * i + 2], 0.0, 1e-5);
                CHECK(t[4 * i + 3] == 1.0f || t[4 * i + 3] == -1.0f);
            }
        }
        cJSON_Delete(j);
    }
    free(file);
    mf_mesh_free(&m);
    mf_image_free(&im);
}
