/* Tests of mf/io/mf_gltf: a small .glb validator (header, chunk alignment and padding, JSON,
 * bufferView/accessor bounds and counts, POSITION min/max, embedded PNG bytes, flipped UVs,
 * positions and normals rotated from our +Z up to glTF's +Y up).
 *
 * The .glb we export stands upright (issue 15, "glTF out, right"): glTF is +Y up, our world +Z up.
 * A small reader (below: just enough of glTF 2.0 for our own files: one buffer in the GLB BIN
 * chunk, float/uint accessors) reads scene.glb back and compares it with the OBJ it came from:
 * the up axis, every position, normal, tangent frame (handedness included) and the winding, the
 * UVs, and which PNG each material slot binds. When MF_GLTF_VALIDATOR names the Khronos
 * validator's command (`make test` sets it when node and the npm package gltf-validator are
 * present: tests/gltf_validate.js), the files are checked with it too. */
#include <cJSON.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_gltf.h"
#include "io/mf_image.h"
#include "io/mf_obj.h"
#include "scene/mf_mesh.h"
#include "scene/mf_tangent.h"
#include "mf_test.h"

static uint32_t rd32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

static int jnum(const cJSON *o, const char *k, int dflt) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(o, k);
    return cJSON_IsNumber(it) ? (int)it->valuedouble : dflt;
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
    size_t blen = (size_t)jnum(cJSON_GetArrayItem(bufs, 0), "byteLength", -1);
    CHECK(blen <= bl && bl - blen < 4);
    const cJSON *views = cJSON_GetObjectItem(j, "bufferViews"), *v;
    cJSON_ArrayForEach(v, views) {
        size_t off = (size_t)jnum(v, "byteOffset", 0), l = (size_t)jnum(v, "byteLength", -1);
        CHECK(jnum(v, "buffer", -1) == 0 && off % 4 == 0 && off + l <= blen);
    }
    const cJSON *acc = cJSON_GetObjectItem(j, "accessors"), *a;
    cJSON_ArrayForEach(a, acc) {
        const cJSON *vw = cJSON_GetArrayItem(views, jnum(a, "bufferView", -1));
        CHECK(vw != NULL);
        if (!vw) continue;
        int ct = jnum(a, "componentType", 0);
        CHECK(ct == 5126 || ct == 5125);
        const char *type = cJSON_GetObjectItem(a, "type")->valuestring;
        int nc = strcmp(type, "VEC4") == 0 ? 4 : strcmp(type, "VEC3") == 0 ? 3 : strcmp(type, "VEC2") == 0 ? 2 : 1;
        size_t need = (size_t)jnum(a, "byteOffset", 0) + (size_t)jnum(a, "count", 0) * nc * 4;
        CHECK_MSG(need <= (size_t)jnum(vw, "byteLength", 0), "accessor %s needs %zu bytes", type, need);
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
        const cJSON *ap = cJSON_GetArrayItem(acc, jnum(attr, "POSITION", -1));
        const cJSON *an = cJSON_GetArrayItem(acc, jnum(attr, "NORMAL", -1));
        const cJSON *at = cJSON_GetArrayItem(acc, jnum(attr, "TEXCOORD_0", -1));
        const cJSON *ai = cJSON_GetArrayItem(acc, jnum(prim, "indices", -1));
        CHECK(ap && an && at && ai);
        CHECK(jnum(attr, "TANGENT", -1) == -1); /* only with a normal map */
        if (ap && an && at && ai) {
            CHECK(jnum(ap, "count", 0) == 5 && jnum(an, "count", 0) == 5 && jnum(at, "count", 0) == 5 && jnum(ai, "count", 0) == 18);
            CHECK(jnum(ai, "componentType", 0) == 5125 && jnum(ap, "componentType", 0) == 5126);
            CHECK(jnum(prim, "mode", 4) == 4);
            /* min/max match the data; positions, indices and flipped UVs read back exactly. */
            const float *pos = (const float *)(bin + jnum(cJSON_GetArrayItem(views, jnum(ap, "bufferView", 0)), "byteOffset", 0));
            const float *uv = (const float *)(bin + jnum(cJSON_GetArrayItem(views, jnum(at, "bufferView", 0)), "byteOffset", 0));
            const float *nrm = (const float *)(bin + jnum(cJSON_GetArrayItem(views, jnum(an, "bufferView", 0)), "byteOffset", 0));
            const uint32_t *idx = (const uint32_t *)(bin + jnum(cJSON_GetArrayItem(views, jnum(ai, "bufferView", 0)), "byteOffset", 0));
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
            const cJSON *img = cJSON_GetArrayItem(imgs, jnum(cJSON_GetArrayItem(texs, jnum(ti, "index", -1)), "source", -1));
            CHECK(img && strcmp(cJSON_GetObjectItem(img, "mimeType")->valuestring, "image/png") == 0);
            const cJSON *vw = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "bufferViews"), jnum(img, "bufferView", -1));
            char *png = NULL;
            size_t plen = 0;
            CHECK_OK(mf_read_file(src[k], &png, &plen));
            CHECK(vw && (size_t)jnum(vw, "byteLength", 0) == plen);
            if (vw && png && (size_t)jnum(vw, "byteLength", 0) == plen) CHECK(memcmp(bin + jnum(vw, "byteOffset", 0), png, plen) == 0);
            free(png);
        }
        const cJSON *sc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), jnum(j, "scene", -1));
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
        const cJSON *img = ti ? cJSON_GetArrayItem(imgs, jnum(cJSON_GetArrayItem(texs, jnum(ti, "index", -1)), "source", -1)) : NULL;
        const cJSON *vw = img ? cJSON_GetArrayItem(views, jnum(img, "bufferView", -1)) : NULL;
        char *png = NULL;
        size_t plen = 0;
        CHECK_OK(mf_read_file(np, &png, &plen));
        CHECK(vw && (size_t)jnum(vw, "byteLength", 0) == plen);
        if (vw && png && (size_t)jnum(vw, "byteLength", 0) == plen) CHECK(memcmp(bin + jnum(vw, "byteOffset", 0), png, plen) == 0);
        free(png);
        const cJSON *prim = cJSON_GetArrayItem(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "meshes"), 0), "primitives"), 0);
        const cJSON *attr = cJSON_GetObjectItem(prim, "attributes");
        const cJSON *at = cJSON_GetArrayItem(acc, jnum(attr, "TANGENT", -1)), *an = cJSON_GetArrayItem(acc, jnum(attr, "NORMAL", -1));
        CHECK(at && an && strcmp(cJSON_GetObjectItem(at, "type")->valuestring, "VEC4") == 0 && jnum(at, "count", 0) == 5);
        if (at && an) {
            const float *t = (const float *)(bin + jnum(cJSON_GetArrayItem(views, jnum(at, "bufferView", 0)), "byteOffset", 0));
            const float *n = (const float *)(bin + jnum(cJSON_GetArrayItem(views, jnum(an, "bufferView", 0)), "byteOffset", 0));
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

/* ---- a minimal .glb reader ---- */

typedef struct {
    char *file;                /* owned; the whole .glb */
    size_t len;
    cJSON *json;               /* owned */
    const unsigned char *bin;  /* into file */
    size_t binlen;
} Glb;

static void glb_free(Glb *g) {
    cJSON_Delete(g->json);
    free(g->file);
    memset(g, 0, sizeof *g);
}

static int glb_open(const char *path, Glb *g) {
    memset(g, 0, sizeof *g);
    if (mf_read_file(path, &g->file, &g->len)) return 0;
    const unsigned char *d = (const unsigned char *)g->file;
    if (g->len < 28 || rd32(d) != 0x46546C67 || rd32(d + 4) != 2 || rd32(d + 8) != g->len) return 0;
    uint32_t jl = rd32(d + 12);
    if (rd32(d + 16) != 0x4E4F534A || 20 + (size_t)jl + 8 > g->len) return 0;
    uint32_t bl = rd32(d + 20 + jl);
    if (rd32(d + 24 + jl) != 0x004E4942 || 28 + (size_t)jl + bl > g->len) return 0;
    g->bin = d + 28 + jl;
    g->binlen = bl;
    g->json = cJSON_ParseWithLength(g->file + 20, jl);
    return g->json != NULL;
}

static const cJSON *jat(const cJSON *o, const char *arr, int i) { return cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(o, arr), i); }

/* Bytes of bufferView v (bounds-checked), or NULL. */
static const unsigned char *glb_view(const Glb *g, int v, size_t *len) {
    const cJSON *vw = jat(g->json, "bufferViews", v);
    if (!vw) return NULL;
    size_t off = (size_t)jnum(vw, "byteOffset", 0), l = (size_t)jnum(vw, "byteLength", -1);
    if (off > g->binlen || l > g->binlen - off) return NULL;
    if (len) *len = l;
    return g->bin + off;
}

/* Accessor a as a malloc'ed array of count x ncomp values (float, or uint32 indices as float is
 * not wanted: indices go through glb_indices). NULL when absent or malformed. */
static float *glb_floats(const Glb *g, int a, int ncomp, int *count) {
    const cJSON *ac = jat(g->json, "accessors", a);
    if (!ac || jnum(ac, "componentType", 0) != 5126) return NULL;
    const char *type = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(ac, "type"));
    int nc = !type ? 0 : !strcmp(type, "VEC4") ? 4 : !strcmp(type, "VEC3") ? 3 : !strcmp(type, "VEC2") ? 2 : !strcmp(type, "SCALAR") ? 1 : 0;
    if (nc != ncomp) return NULL;
    size_t vl = 0;
    const unsigned char *v = glb_view(g, jnum(ac, "bufferView", -1), &vl);
    size_t n = (size_t)jnum(ac, "count", 0), off = (size_t)jnum(ac, "byteOffset", 0);
    if (!v || off + n * (size_t)nc * 4 > vl) return NULL;
    float *out = malloc(n * (size_t)nc * sizeof(float) + 1);
    if (out) memcpy(out, v + off, n * (size_t)nc * 4);
    *count = (int)n;
    return out;
}

static uint32_t *glb_indices(const Glb *g, int a, int *count) {
    const cJSON *ac = jat(g->json, "accessors", a);
    if (!ac || jnum(ac, "componentType", 0) != 5125) return NULL;
    size_t vl = 0;
    const unsigned char *v = glb_view(g, jnum(ac, "bufferView", -1), &vl);
    size_t n = (size_t)jnum(ac, "count", 0), off = (size_t)jnum(ac, "byteOffset", 0);
    if (!v || off + n * 4 > vl) return NULL;
    uint32_t *out = malloc(n * 4 + 1);
    if (out) memcpy(out, v + off, n * 4);
    *count = (int)n;
    return out;
}

/* The image bytes a material slot binds: slot "baseColorTexture" / "metallicRoughnessTexture"
 * (in pbrMetallicRoughness) or "normalTexture" (in the material). */
static const unsigned char *glb_slot_image(const Glb *g, const char *slot, size_t *len) {
    const cJSON *mat = jat(g->json, "materials", 0);
    const cJSON *holder = strcmp(slot, "normalTexture") ? cJSON_GetObjectItemCaseSensitive(mat, "pbrMetallicRoughness") : mat;
    const cJSON *ti = cJSON_GetObjectItemCaseSensitive(holder, slot);
    if (!ti || jnum(ti, "texCoord", 0) != 0) return NULL;
    const cJSON *tex = jat(g->json, "textures", jnum(ti, "index", -1));
    const cJSON *img = jat(g->json, "images", jnum(tex, "source", -1));
    const char *mime = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(img, "mimeType"));
    if (!img || !mime || strcmp(mime, "image/png")) return NULL;
    return glb_view(g, jnum(img, "bufferView", -1), len);
}

/* ---- the upright tests ---- */

static void cross3(const float *a, const float *b, float *c) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Our +Z-up vector as glTF's +Y-up one. */
static void y_up(const float *v, float *o) { o[0] = v[0], o[1] = v[2], o[2] = -v[1]; }

static int same_file_bytes(const unsigned char *b, size_t len, const char *path) {
    char *d = NULL;
    size_t l = 0;
    if (mf_read_file(path, &d, &l)) return 0;
    int same = b && l == len && !memcmp(b, d, l);
    free(d);
    return same;
}

/* Runs the Khronos validator (its command in MF_GLTF_VALIDATOR, as the Makefile sets it when node
 * and the npm package are present) on path; checks 0 errors. Through the shell: the variable holds
 * a command line (node, its script and arguments), not one program. */
static void khronos_validate(const char *path) {
    const char *cmd = getenv("MF_GLTF_VALIDATOR");
    if (!cmd || !cmd[0]) return;
    char line[4096], out[1024];
    mf_test_path_to(out, sizeof out, "gltf_validator.txt");
    snprintf(line, sizeof line, "%s '%s' > '%s' 2>&1", cmd, path, out);
    int st = system(line);
    char *txt = NULL;
    size_t n = 0;
    mf_read_file(out, &txt, &n);
    CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == 0, "gltf-validator on %s: exit %d: %s", path, WIFEXITED(st) ? WEXITSTATUS(st) : -1,
              txt ? txt : "");
    free(txt);
}

MF_TEST(gltf_upright_matches_obj) {
    /* a tall object: a UV sphere stretched 3x along +Z, its top at z = 2.5, written as OBJ and read back */
    MfMesh src = {0}, m = {0};
    CHECK_OK(mf_mesh_uv_sphere(&src, 12, 8, mf_v3(0.1f, -0.2f, 1.0f), 0.5f));
    for (int i = 0; i < src.nv; ++i) src.pos[3 * i + 2] = 1.0f + 3.0f * (src.pos[3 * i + 2] - 1.0f);
    free(src.nrm);
    src.nrm = NULL;
    CHECK_OK(mf_mesh_compute_normals(&src));
    const char *objp = mf_test_path("upright.obj");
    CHECK_OK(mf_obj_write(objp, &src, NULL));
    mf_mesh_free(&src);
    CHECK_OK(mf_obj_read(objp, &m));
    if (!m.pos || !m.uv || !m.nrm) { mf_mesh_free(&m); CHECK_MSG(0, "%s: read back without UVs or normals", objp); return; }
    /* three distinct PNGs, so a swapped binding shows */
    const char *pngs[3] = {mf_test_path("up_albedo.png"), mf_test_path("up_orm.png"), mf_test_path("up_normal.png")};
    for (int k = 0; k < 3; ++k) {
        MfImage im = {0};
        CHECK_OK(mf_image_alloc(&im, 4 + 2 * k, 4, 3));
        for (int i = 0; i < im.w * im.h * 3; ++i) im.data[i] = (float)((i + 3 * k) % 5) / 4.0f;
        CHECK_OK(mf_image_write(pngs[k], &im, k == 0 ? MF_ENC_SRGB : MF_ENC_LINEAR, 8));
        mf_image_free(&im);
    }
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = pngs[0], mat.orm_png = pngs[1], mat.normal_png = pngs[2];
    const char *glbp = mf_test_path("upright.glb");
    CHECK_OK(mf_gltf_write_glb(glbp, &m, &mat));
    float *tan = malloc(sizeof(float) * 4 * (size_t)m.nv);
    CHECK_OK(mf_mesh_tangents(&m, tan));

    Glb g;
    CHECK_MSG(glb_open(glbp, &g), "%s: not a readable .glb", glbp);
    const cJSON *prim = jat(jat(g.json, "meshes", 0), "primitives", 0);
    const cJSON *attr = cJSON_GetObjectItemCaseSensitive(prim, "attributes");
    int np = 0, nn = 0, nuv = 0, nt = 0, ni = 0;
    float *P = g.json ? glb_floats(&g, jnum(attr, "POSITION", -1), 3, &np) : NULL;
    float *N = g.json ? glb_floats(&g, jnum(attr, "NORMAL", -1), 3, &nn) : NULL;
    float *UV = g.json ? glb_floats(&g, jnum(attr, "TEXCOORD_0", -1), 2, &nuv) : NULL;
    float *T = g.json ? glb_floats(&g, jnum(attr, "TANGENT", -1), 4, &nt) : NULL;
    uint32_t *I = g.json ? glb_indices(&g, jnum(prim, "indices", -1), &ni) : NULL;
    CHECK(P && N && UV && T && I);
    CHECK(np == m.nv && nn == m.nv && nuv == m.nv && nt == m.nv && ni == 3 * m.nt);
    if (P && N && UV && T && I && np == m.nv && nn == m.nv && nuv == m.nv && nt == m.nv && ni == 3 * m.nt) {
        /* the up axis: the OBJ's tallest extent is along +Z; in the glb it is along +Y, with the
         * top (max OBJ z) at max glb y, not at -y and not along z */
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        int top_obj = 0, top_glb = 0;
        for (int i = 0; i < m.nv; ++i) {
            for (int k = 0; k < 3; ++k) lo[k] = fminf(lo[k], P[3 * i + k]), hi[k] = fmaxf(hi[k], P[3 * i + k]);
            if (m.pos[3 * i + 2] > m.pos[3 * top_obj + 2]) top_obj = i;
            if (P[3 * i + 1] > P[3 * top_glb + 1]) top_glb = i;
        }
        CHECK_MSG(hi[1] - lo[1] > 2.5f * (hi[0] - lo[0]) && hi[1] - lo[1] > 2.5f * (hi[2] - lo[2]),
                  "the glb's tall axis is not Y: extents %g %g %g", hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
        CHECK_NEAR(hi[1], 2.5, 1e-4);
        CHECK_NEAR(P[3 * top_obj + 1], P[3 * top_glb + 1], 0);
        CHECK_MSG(N[3 * top_glb + 1] > 0.8f, "the top vertex's normal is (%g, %g, %g), not +Y", N[3 * top_glb], N[3 * top_glb + 1], N[3 * top_glb + 2]);
        /* accessor min/max (viewers frame the object with them) */
        const cJSON *ap = jat(g.json, "accessors", jnum(attr, "POSITION", -1));
        for (int k = 0; k < 3; ++k) {
            CHECK((float)cJSON_GetArrayItem(cJSON_GetObjectItem(ap, "min"), k)->valuedouble == lo[k]);
            CHECK((float)cJSON_GetArrayItem(cJSON_GetObjectItem(ap, "max"), k)->valuedouble == hi[k]);
        }
        int bad_pos = 0, bad_back = 0, bad_nrm = 0, bad_uv = 0, bad_tan = 0, bad_wind = 0;
        for (int i = 0; i < m.nv; ++i) {
            float e[3], n[3], t[3], b_obj[3], b_glb[3], b_rot[3];
            y_up(m.pos + 3 * i, e);
            bad_pos += memcmp(e, P + 3 * i, 12) != 0;
            /* and back to our axes: (x, y, z) -> (x, -z, y) */
            float back[3] = {P[3 * i], -P[3 * i + 2], P[3 * i + 1]};
            bad_back += memcmp(back, m.pos + 3 * i, 12) != 0;
            y_up(m.nrm + 3 * i, n);
            bad_nrm += fabsf(n[0] - N[3 * i]) + fabsf(n[1] - N[3 * i + 1]) + fabsf(n[2] - N[3 * i + 2]) > 1e-5f;
            bad_uv += UV[2 * i] != m.uv[2 * i] || UV[2 * i + 1] != 1.0f - m.uv[2 * i + 1];
            /* tangent: xyz rotated, w kept; the bitangent w (N x T) of the glb is the rotated one of ours */
            y_up(tan + 4 * i, t);
            bad_tan += fabsf(t[0] - T[4 * i]) + fabsf(t[1] - T[4 * i + 1]) + fabsf(t[2] - T[4 * i + 2]) > 1e-6f || T[4 * i + 3] != tan[4 * i + 3];
            cross3(m.nrm + 3 * i, tan + 4 * i, b_obj);
            cross3(N + 3 * i, T + 4 * i, b_glb);
            y_up(b_obj, b_rot);
            for (int k = 0; k < 3; ++k) b_rot[k] *= tan[4 * i + 3], b_glb[k] *= T[4 * i + 3];
            bad_tan += fabsf(b_rot[0] - b_glb[0]) + fabsf(b_rot[1] - b_glb[1]) + fabsf(b_rot[2] - b_glb[2]) > 1e-4f;
        }
        /* winding: counter-clockwise triangles face their vertex normals (outward) in the glb too */
        for (int f = 0; f < m.nt; ++f) {
            const float *a = P + 3 * I[3 * f], *b = P + 3 * I[3 * f + 1], *c = P + 3 * I[3 * f + 2];
            float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, fn[3];
            cross3(e1, e2, fn);
            float area2 = sqrtf(fn[0] * fn[0] + fn[1] * fn[1] + fn[2] * fn[2]);
            const float *na = N + 3 * I[3 * f];
            if (area2 > 1e-6f) bad_wind += fn[0] * na[0] + fn[1] * na[1] + fn[2] * na[2] <= 0.0f;
        }
        CHECK_MSG(!bad_pos, "%d positions are not (x, z, -y) of the OBJ's", bad_pos);
        CHECK_MSG(!bad_back, "%d positions do not map back to the OBJ's", bad_back);
        CHECK_MSG(!bad_nrm, "%d normals are not the OBJ's rotated", bad_nrm);
        CHECK_MSG(!bad_uv, "%d UVs are not (u, 1 - v)", bad_uv);
        CHECK_MSG(!bad_tan, "%d tangent frames differ from the OBJ's rotated (handedness)", bad_tan);
        CHECK_MSG(!bad_wind, "%d triangles face away from their normals", bad_wind);
        /* texture bindings: each slot holds its own PNG's bytes */
        const char *slots[3] = {"baseColorTexture", "metallicRoughnessTexture", "normalTexture"};
        for (int k = 0; k < 3; ++k) {
            size_t l = 0;
            const unsigned char *b = glb_slot_image(&g, slots[k], &l);
            CHECK_MSG(same_file_bytes(b, l, pngs[k]), "%s does not bind %s", slots[k], pngs[k]);
        }
    }
    free(P), free(N), free(UV), free(T), free(I), free(tan);
    glb_free(&g);
    mf_mesh_free(&m);
}

/* The Khronos validator on a glb with every attribute we write (TANGENT included) and all three
 * textures: 0 errors. Skipped (and said so) without node and the npm package. */
MF_TEST(gltf_khronos_validator) {
    if (!getenv("MF_GLTF_VALIDATOR") || !getenv("MF_GLTF_VALIDATOR")[0])
        MF_SKIP("gltf-validator not found (node + npm package gltf-validator; see the Makefile's test target)");
    MfMesh m = {0};
    CHECK_OK(mf_mesh_uv_sphere(&m, 8, 6, mf_v3(0, 0, 0.5f), 0.5f));
    const char *pngs[3] = {mf_test_path("kv_albedo.png"), mf_test_path("kv_orm.png"), mf_test_path("kv_normal.png")};
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 4, 4, 3));
    for (int i = 0; i < 48; ++i) im.data[i] = (i % 3 == 2) ? 1.0f : 0.5f;
    for (int k = 0; k < 3; ++k) CHECK_OK(mf_image_write(pngs[k], &im, k == 0 ? MF_ENC_SRGB : MF_ENC_LINEAR, 8));
    mf_image_free(&im);
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = pngs[0], mat.orm_png = pngs[1], mat.normal_png = pngs[2];
    const char *glbp = mf_test_path("kv.glb");
    CHECK_OK(mf_gltf_write_glb(glbp, &m, &mat));
    khronos_validate(glbp);
    /* and one without textures or UVs */
    free(m.uv);
    m.uv = NULL;
    CHECK_OK(mf_gltf_write_glb(mf_test_path("kv_plain.glb"), &m, NULL));
    khronos_validate(mf_test_path("kv_plain.glb"));
    mf_mesh_free(&m);
}

/* The scene.glb of an `mf recon` result against its mesh.obj: same bounds, rotated to +Y up. */
MF_TEST(gltf_upright_recon_result) {
    MF_NEED_BIN();
    char dir[512], args[4096], err[4096];
    mf_test_path_to(dir, sizeof dir, "gltf_recon");
    CHECK_OK(mf_mkdirs(dir));
    /* a tall box (0.4 x 0.4 x 1.6) with UVs, seen from the side */
    char p[1024];
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    FILE *f = fopen(p, "w");
    if (f) {
        fputs("v -0.2 -0.2 -0.8\nv 0.2 -0.2 -0.8\nv 0.2 0.2 -0.8\nv -0.2 0.2 -0.8\n"
              "v -0.2 -0.2 0.8\nv 0.2 -0.2 0.8\nv 0.2 0.2 0.8\nv -0.2 0.2 0.8\n"
              "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
              "f 1/1 3/3 2/2\nf 1/1 4/4 3/3\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\nf 1/1 2/2 6/3\nf 1/1 6/3 5/4\n"
              "f 2/1 3/2 7/3\nf 2/1 7/3 6/4\nf 3/1 4/2 8/3\nf 3/1 8/3 7/4\nf 4/1 1/2 5/3\nf 4/1 5/3 8/4\n", f);
        fclose(f);
    }
    snprintf(p, sizeof p, "%s/transforms_train.json", dir);
    f = fopen(p, "w");
    if (f) {
        fputs("{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": "
              "[[1,0,0,0],[0,0,-1,-4],[0,1,0,0],[0,0,0,1]]}]}", f);
        fclose(f);
    }
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 16, 16, 4));
    for (int i = 0; i < 16 * 16; ++i) im.data[4 * i] = im.data[4 * i + 1] = im.data[4 * i + 2] = 0.5f, im.data[4 * i + 3] = 1.0f;
    snprintf(p, sizeof p, "%s/train/r_0.png", dir);
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_image_write(p, &im, MF_ENC_SRGB, 8));
    mf_image_free(&im);
    snprintf(args, sizeof args, "recon %s -o %s/out --iters 1 --tex-res 16 --env-w 8 --env-h 4", dir, dir);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    MfMesh m = {0};
    snprintf(p, sizeof p, "%s/out/mesh.obj", dir);
    CHECK_OK(mf_obj_read(p, &m));
    snprintf(p, sizeof p, "%s/out/scene.glb", dir);
    Glb g;
    CHECK_MSG(glb_open(p, &g), "%s: not a readable .glb", p);
    if (g.json && m.pos) {
        MfVec3 lo, hi;
        mf_mesh_bounds(&m, &lo, &hi);
        const cJSON *prim = jat(jat(g.json, "meshes", 0), "primitives", 0);
        const cJSON *ap = jat(g.json, "accessors", jnum(cJSON_GetObjectItem(prim, "attributes"), "POSITION", -1));
        const cJSON *mn = cJSON_GetObjectItem(ap, "min"), *mx = cJSON_GetObjectItem(ap, "max");
        float elo[3] = {lo.x, lo.z, -hi.y}, ehi[3] = {hi.x, hi.z, -lo.y};
        for (int k = 0; k < 3 && cJSON_GetArraySize(mn) == 3 && cJSON_GetArraySize(mx) == 3; ++k) {
            CHECK_NEAR(cJSON_GetArrayItem(mn, k)->valuedouble, elo[k], 1e-6);
            CHECK_NEAR(cJSON_GetArrayItem(mx, k)->valuedouble, ehi[k], 1e-6);
        }
        CHECK_NEAR(cJSON_GetArrayItem(mx, 1)->valuedouble, 0.8, 1e-6); /* the box's top, +Y */
        size_t l = 0;
        const unsigned char *b = glb_slot_image(&g, "baseColorTexture", &l);
        snprintf(p, sizeof p, "%s/out/albedo.png", dir);
        CHECK_MSG(same_file_bytes(b, l, p), "scene.glb's baseColorTexture is not albedo.png");
        b = glb_slot_image(&g, "metallicRoughnessTexture", &l);
        snprintf(p, sizeof p, "%s/out/orm.png", dir);
        CHECK_MSG(same_file_bytes(b, l, p), "scene.glb's metallicRoughnessTexture is not orm.png");
    }
    glb_free(&g);
    mf_mesh_free(&m);
    snprintf(p, sizeof p, "%s/out/scene.glb", dir);
    khronos_validate(p);
}
