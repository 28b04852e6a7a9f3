#include "io/mf_gltf.h"

#include <cJSON.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "scene/mf_tangent.h"
#include "core/mf_fs.h"

enum {
    GLB_MAGIC = 0x46546C67, /* "glTF" */
    GLB_JSON = 0x4E4F534A,  /* "JSON" */
    GLB_BIN = 0x004E4942,   /* "BIN\0" */
    GL_FLOAT = 5126,
    GL_UNSIGNED_INT = 5125,
    GL_ARRAY_BUFFER = 34962,
    GL_ELEMENT_ARRAY_BUFFER = 34963
};

MfGltfMaterial mf_gltf_material_default(void) {
    MfGltfMaterial m = {0};
    m.base_color[0] = m.base_color[1] = m.base_color[2] = m.base_color[3] = 1.0f;
    m.metallic = 1.0f;
    m.roughness = 1.0f;
    return m;
}

static size_t align4(size_t n) { return (n + 3) & ~(size_t)3; }

static void put_u32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

static cJSON *num_array(const float *v, int n) {
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; a && i < n; ++i) cJSON_AddItemToArray(a, cJSON_CreateNumber((double)v[i]));
    return a;
}

static int add_view(cJSON *views, size_t off, size_t len, int target) {
    cJSON *v = cJSON_CreateObject();
    cJSON_AddNumberToObject(v, "buffer", 0);
    cJSON_AddNumberToObject(v, "byteOffset", (double)off);
    cJSON_AddNumberToObject(v, "byteLength", (double)len);
    if (target) cJSON_AddNumberToObject(v, "target", target);
    cJSON_AddItemToArray(views, v);
    return cJSON_GetArraySize(views) - 1;
}

static int add_accessor(cJSON *acc, int view, int ctype, size_t count, const char *type, const float *mn, const float *mx, int nc) {
    cJSON *a = cJSON_CreateObject();
    cJSON_AddNumberToObject(a, "bufferView", view);
    cJSON_AddNumberToObject(a, "byteOffset", 0);
    cJSON_AddNumberToObject(a, "componentType", ctype);
    cJSON_AddNumberToObject(a, "count", (double)count);
    cJSON_AddStringToObject(a, "type", type);
    if (mn) cJSON_AddItemToObject(a, "min", num_array(mn, nc));
    if (mx) cJSON_AddItemToObject(a, "max", num_array(mx, nc));
    cJSON_AddItemToArray(acc, a);
    return cJSON_GetArraySize(acc) - 1;
}

/* Our world is +Z up (DESIGN.md), glTF's is +Y up: (x, y, z) -> (x, z, -y), the rotation by
 * -90 degrees about +X (determinant +1, so winding and tangent handedness are kept). */
static void to_y_up(float *v) {
    float y = v[1], z = v[2];
    v[1] = z;
    v[2] = -y;
}

static int is_png(const char *data, size_t len) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
    return len >= 8 && memcmp(data, sig, 8) == 0;
}

int mf_gltf_write_glb(const char *path, const MfMesh *m, const MfGltfMaterial *matp) {
    MfGltfMaterial mat = matp ? *matp : mf_gltf_material_default();
    if (!m || m->nv <= 0 || m->nt <= 0 || !m->pos || !m->tri) return mf_fail(MF_EARG, "%s: cannot export an empty mesh", path);
    if ((mat.albedo_png || mat.orm_png || mat.normal_png) && !m->uv) return mf_fail(MF_EARG, "%s: textures need a mesh with UVs", path);
    for (size_t i = 0; i < (size_t)m->nt * 3; ++i)
        if (m->tri[i] >= (uint32_t)m->nv) return mf_fail(MF_EARG, "%s: triangle %zu uses vertex %u of %d", path, i / 3, m->tri[i], m->nv);
    for (size_t i = 0; i < (size_t)m->nv * 3; ++i)
        if (!isfinite(m->pos[i])) return mf_fail(MF_ENAN, "%s: vertex %zu position is not finite", path, i / 3);

    size_t nv = (size_t)m->nv, nt = (size_t)m->nt;
    int rc = MF_OK;
    char *png[3] = {NULL, NULL, NULL};
    size_t pnglen[3] = {0, 0, 0};
    const char *pngpath[3] = {mat.albedo_png, mat.orm_png, mat.normal_png};
    float *tan = NULL; /* (nv, 4) TANGENT, with a normal map */
    for (int k = 0; k < 3; ++k) {
        if (!pngpath[k]) continue;
        if ((rc = mf_read_file(pngpath[k], &png[k], &pnglen[k]))) goto out_png;
        if (!is_png(png[k], pnglen[k])) { rc = mf_fail(MF_EFORMAT, "%s: not a PNG file (glTF export of %s)", pngpath[k], path); goto out_png; }
    }

    if (png[2]) {
        if (!(tan = malloc(sizeof(float) * 4 * nv))) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto out_png; }
        if ((rc = mf_mesh_tangents(m, tan))) goto out_png;
        for (size_t i = 0; i < nv; ++i) to_y_up(tan + 4 * i); /* w (handedness) unchanged: a rotation */
    }

    /* Normals: the mesh's (normalised) or smooth ones computed on a copy. */
    float *nrm = malloc(sizeof(float) * 3 * nv);
    if (!nrm) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto out_png; }
    if (m->nrm) {
        memcpy(nrm, m->nrm, sizeof(float) * 3 * nv);
    } else {
        MfMesh tmp = *m;
        tmp.nrm = nrm;
        if ((rc = mf_mesh_compute_normals(&tmp))) { free(nrm); goto out_png; }
    }
    for (size_t i = 0; i < nv; ++i) {
        float *n = nrm + 3 * i;
        float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(l > 0.0f) || !isfinite(l)) { n[0] = 0.0f; n[1] = 0.0f; n[2] = 1.0f; }
        else if (fabsf(l - 1.0f) > 1e-6f) { n[0] /= l; n[1] /= l; n[2] /= l; }
        to_y_up(n);
    }

    /* BIN chunk layout. */
    size_t o_pos = 0, l_pos = 12 * nv;
    size_t o_nrm = align4(o_pos + l_pos), l_nrm = 12 * nv;
    size_t o_uv = align4(o_nrm + l_nrm), l_uv = m->uv ? 8 * nv : 0;
    size_t o_idx = align4(o_uv + l_uv), l_idx = 12 * nt;
    size_t o_img[3], end = align4(o_idx + l_idx);
    for (int k = 0; k < 3; ++k) {
        o_img[k] = end;
        end = align4(end + pnglen[k]);
    }
    size_t o_tan = end, l_tan = tan ? 16 * nv : 0;
    end = align4(end + l_tan);
    size_t binlen = end;
    if (binlen > 0xFFFFFFF0u) { free(nrm); rc = mf_fail(MF_EARG, "%s: mesh too large for a .glb (%zu bytes)", path, binlen); goto out_png; }
    unsigned char *bin = calloc(binlen + 4, 1);
    if (!bin) { free(nrm); rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto out_png; }
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (size_t i = 0; i < nv; ++i) {
        float p[3] = {m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]};
        to_y_up(p);
        memcpy(bin + o_pos + 12 * i, p, 12);
        for (int k = 0; k < 3; ++k) {
            mn[k] = fminf(mn[k], p[k]);
            mx[k] = fmaxf(mx[k], p[k]);
        }
    }
    memcpy(bin + o_nrm, nrm, l_nrm);
    free(nrm);
    for (size_t i = 0; m->uv && i < nv; ++i) {
        float uv[2] = {m->uv[2 * i], 1.0f - m->uv[2 * i + 1]};
        memcpy(bin + o_uv + 8 * i, uv, 8);
    }
    memcpy(bin + o_idx, m->tri, l_idx);
    for (int k = 0; k < 3; ++k)
        if (png[k]) memcpy(bin + o_img[k], png[k], pnglen[k]);
    if (tan) memcpy(bin + o_tan, tan, l_tan);


    /* JSON. */
    const char *name = mat.name ? mat.name : "material";
    cJSON *root = cJSON_CreateObject();
    cJSON *asset = cJSON_AddObjectToObject(root, "asset");
    cJSON_AddStringToObject(asset, "version", "2.0");
    cJSON_AddStringToObject(asset, "generator", "mf (MaterialFusion in C)");
    cJSON_AddNumberToObject(root, "scene", 0);
    cJSON *scenes = cJSON_AddArrayToObject(root, "scenes");
    cJSON *sc = cJSON_CreateObject();
    int zero = 0;
    cJSON_AddItemToObject(sc, "nodes", cJSON_CreateIntArray(&zero, 1));
    cJSON_AddItemToArray(scenes, sc);
    cJSON *nodes = cJSON_AddArrayToObject(root, "nodes");
    cJSON *node = cJSON_CreateObject();
    cJSON_AddNumberToObject(node, "mesh", 0);
    cJSON_AddStringToObject(node, "name", name);
    cJSON_AddItemToArray(nodes, node);

    cJSON *views = cJSON_AddArrayToObject(root, "bufferViews");
    cJSON *acc = cJSON_AddArrayToObject(root, "accessors");
    int a_pos = add_accessor(acc, add_view(views, o_pos, l_pos, GL_ARRAY_BUFFER), GL_FLOAT, nv, "VEC3", mn, mx, 3);
    int a_nrm = add_accessor(acc, add_view(views, o_nrm, l_nrm, GL_ARRAY_BUFFER), GL_FLOAT, nv, "VEC3", NULL, NULL, 3);
    int a_uv = m->uv ? add_accessor(acc, add_view(views, o_uv, l_uv, GL_ARRAY_BUFFER), GL_FLOAT, nv, "VEC2", NULL, NULL, 2) : -1;
    int a_idx = add_accessor(acc, add_view(views, o_idx, l_idx, GL_ELEMENT_ARRAY_BUFFER), GL_UNSIGNED_INT, 3 * nt, "SCALAR", NULL, NULL, 1);
    int a_tan = tan ? add_accessor(acc, add_view(views, o_tan, l_tan, GL_ARRAY_BUFFER), GL_FLOAT, nv, "VEC4", NULL, NULL, 4) : -1;

    cJSON *meshes = cJSON_AddArrayToObject(root, "meshes");
    cJSON *mesh = cJSON_CreateObject();
    cJSON_AddStringToObject(mesh, "name", name);
    cJSON *prims = cJSON_AddArrayToObject(mesh, "primitives");
    cJSON *prim = cJSON_CreateObject();
    cJSON *attr = cJSON_AddObjectToObject(prim, "attributes");
    cJSON_AddNumberToObject(attr, "POSITION", a_pos);
    cJSON_AddNumberToObject(attr, "NORMAL", a_nrm);
    if (a_uv >= 0) cJSON_AddNumberToObject(attr, "TEXCOORD_0", a_uv);
    if (a_tan >= 0) cJSON_AddNumberToObject(attr, "TANGENT", a_tan);
    cJSON_AddNumberToObject(prim, "indices", a_idx);
    cJSON_AddNumberToObject(prim, "material", 0);
    cJSON_AddNumberToObject(prim, "mode", 4);
    cJSON_AddItemToArray(prims, prim);
    cJSON_AddItemToArray(meshes, mesh);

    cJSON *mats = cJSON_AddArrayToObject(root, "materials");
    cJSON *mo = cJSON_CreateObject();
    cJSON_AddStringToObject(mo, "name", name);
    cJSON *pbr = cJSON_AddObjectToObject(mo, "pbrMetallicRoughness");
    cJSON_AddItemToObject(pbr, "baseColorFactor", num_array(mat.base_color, 4));
    cJSON_AddNumberToObject(pbr, "metallicFactor", mat.metallic);
    cJSON_AddNumberToObject(pbr, "roughnessFactor", mat.roughness);
    if (mat.double_sided) cJSON_AddTrueToObject(mo, "doubleSided");
    cJSON_AddItemToArray(mats, mo);

    if (png[0] || png[1] || png[2]) {
        cJSON *images = cJSON_AddArrayToObject(root, "images");
        cJSON *textures = cJSON_AddArrayToObject(root, "textures");
        cJSON *samplers = cJSON_AddArrayToObject(root, "samplers");
        cJSON *smp = cJSON_CreateObject();
        cJSON_AddNumberToObject(smp, "magFilter", 9729);  /* LINEAR */
        cJSON_AddNumberToObject(smp, "minFilter", 9987);  /* LINEAR_MIPMAP_LINEAR */
        cJSON_AddNumberToObject(smp, "wrapS", 10497);     /* REPEAT */
        cJSON_AddNumberToObject(smp, "wrapT", 10497);
        cJSON_AddItemToArray(samplers, smp);
        const char *slot[3] = {"baseColorTexture", "metallicRoughnessTexture", "normalTexture"};
        const char *iname[3] = {"albedo", "orm", "normal"};
        for (int k = 0; k < 3; ++k) {
            if (!png[k]) continue;
            cJSON *im = cJSON_CreateObject();
            cJSON_AddStringToObject(im, "name", iname[k]);
            cJSON_AddNumberToObject(im, "bufferView", add_view(views, o_img[k], pnglen[k], 0));
            cJSON_AddStringToObject(im, "mimeType", "image/png");
            cJSON_AddItemToArray(images, im);
            cJSON *tx = cJSON_CreateObject();
            cJSON_AddNumberToObject(tx, "sampler", 0);
            cJSON_AddNumberToObject(tx, "source", cJSON_GetArraySize(images) - 1);
            cJSON_AddItemToArray(textures, tx);
            cJSON *ti = cJSON_AddObjectToObject(k == 2 ? mo : pbr, slot[k]); /* normalTexture: in the material */
            cJSON_AddNumberToObject(ti, "index", cJSON_GetArraySize(textures) - 1);
        }
    }
    cJSON *buffers = cJSON_AddArrayToObject(root, "buffers");
    cJSON *buf = cJSON_CreateObject();
    cJSON_AddNumberToObject(buf, "byteLength", (double)binlen);
    cJSON_AddItemToArray(buffers, buf);

    char *json = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    if (!json) { free(bin); rc = mf_fail(MF_ENOMEM, "%s: out of memory printing glTF JSON", path); goto out_png; }
    size_t jlen = strlen(json), jpad = align4(jlen);
    size_t total = 12 + 8 + jpad + 8 + binlen;
    unsigned char *glb = malloc(total);
    if (!glb) { cJSON_free(json); free(bin); rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto out_png; }
    put_u32(glb, GLB_MAGIC);
    put_u32(glb + 4, 2);
    put_u32(glb + 8, (uint32_t)total);
    put_u32(glb + 12, (uint32_t)jpad);
    put_u32(glb + 16, GLB_JSON);
    memcpy(glb + 20, json, jlen);
    memset(glb + 20 + jlen, ' ', jpad - jlen);
    put_u32(glb + 20 + jpad, (uint32_t)binlen);
    put_u32(glb + 24 + jpad, GLB_BIN);
    memcpy(glb + 28 + jpad, bin, binlen);
    cJSON_free(json);
    free(bin);
    rc = mf_write_file(path, glb, total);
    free(glb);
out_png:
    free(png[0]);
    free(png[1]);
    free(png[2]);
    free(tan);
    return rc;
}
