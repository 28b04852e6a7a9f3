/* fuzz_seeds OUT: writes the seed corpora of the fuzz harnesses (mf_fuzz.h) into OUT/<harness>/,
 * one small valid input per layout or feature, made with the project's own writers (images,
 * checkpoints, prior weights) and literal text (OBJ, JSON, argument lists). `make fuzz-seeds`
 * runs it; make test replays its output, make fuzz starts each campaign from it. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "mf_fuzz.h"
#include "io/mf_ckpt.h"
#include "io/mf_gltf.h"
#include "prior/mf_prior.h"
#include "scene/mf_mesh.h"

static const char *g_out;

static int put(const char *harness, const char *name, const void *a, size_t na, const void *b, size_t nb) {
    char p[2048];
    snprintf(p, sizeof p, "%s/%s/%s", g_out, harness, name);
    char *buf = malloc(na + nb + 1);
    if (!buf) return -1;
    memcpy(buf, a, na);
    if (nb) memcpy(buf + na, b, nb);
    int rc = mf_mkdirs_for(p);
    if (!rc) rc = mf_write_file(p, buf, na + nb);
    free(buf);
    if (rc) fprintf(stderr, "fuzz_seeds: %s: %s\n", p, mf_error());
    return rc;
}
static int put_text(const char *harness, const char *name, const char *text) { return put(harness, name, text, strlen(text), NULL, 0); }

/* The bytes of a file, with a one-byte selector in front (sel >= 0) or as they are (sel < 0). */
static int put_file(const char *harness, const char *name, int sel, const char *path) {
    char *d;
    size_t n;
    if (mf_read_file(path, &d, &n)) return fprintf(stderr, "fuzz_seeds: %s\n", mf_error()), -1;
    unsigned char s = (unsigned char)sel;
    int rc = sel >= 0 ? put(harness, name, &s, 1, d, n) : put(harness, name, d, n, NULL, 0);
    free(d);
    return rc;
}

#define C2W "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]"

static int seeds_text(void) {
    int rc = 0;
    rc |= put_text("obj", "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n");
    rc |= put_text("obj", "quad_neg.obj",
                   "# quad, negative indices, normals\nmtllib m.mtl\no q\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                   "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl a\nf -4/-4/-1 -3/-3/-1 -2/-2/-1 -1/-1/-1\n");
    rc |= put_text("obj", "mtl.mtl", "newmtl a\nKd 0.5 0.5 0.5\nmap_Kd kd.png\nnewmtl b\nmap_Kd -s 1 1 1 b.png\n");
    static const char cams[] = "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": " C2W "}]}";
    static const char scene[] =
        "{\"mesh\": \"tri.obj\", \"material\": {\"kd\": \"rgba.png\", \"orm\": [1, 0.5, 0]},"
        " \"env\": {\"file\": \"rgba.exr\", \"rotation_z_deg\": 30, \"strength\": 1},"
        " \"lights\": [{\"type\": \"sun\", \"dir\": [0.3, -0.4, 0.9], \"strength\": 2, \"color\": [1, 0.9, 0.8]},"
        " {\"type\": \"point\", \"pos\": [0, 0, 2], \"power\": 100}],"
        " \"cameras\": \"cams.json\", \"width\": 8, \"height\": 8,"
        " \"render\": {\"spp_sqrt\": 1, \"pixel_samples\": 1, \"seed\": 0, \"lobes\": \"all\"}}";
    rc |= put("scene", "scene_files", scene, sizeof scene, cams, sizeof cams - 1);
    static const char scene_inline[] =
        "{\"mesh\": \"tri.obj\", \"material\": {\"kd\": [0.8, 0.2, 0.2], \"orm\": \"rgba.png\"},"
        " \"cameras\": {\"camera_angle_x\": 0.5, \"frames\": [{\"file_path\": \"a\", \"transform_matrix\": " C2W "}]},"
        " \"width\": 4, \"height\": 2}";
    rc |= put_text("scene", "scene_inline", scene_inline);
    static const char nerf[] = "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": " C2W "}]}";
    rc |= put("transforms", "nerf", "\0", 1, nerf, sizeof nerf - 1);
    rc |= put("transforms", "bvault", "\1", 1, nerf, sizeof nerf - 1);
    static const char orb[] = "{\"camera_angle_x\": 0.5, \"frames\": [{\"file_path\": \"./train/0000\", \"transform_matrix\": " C2W
                              ", \"scene_name\": \"cap\"}]}";
    rc |= put("transforms", "orb", "\2", 1, orb, sizeof orb - 1);
    static const char nfa[] = "{\"cam_transform_mat\": \"1,0,0,0,0,1,0,0,0,0,1,4,0,0,0,1\", \"cam_angle_x\": 0.6911,"
                              " \"imh\": 2, \"imw\": 2, \"envmap\": \"courtyard\"}";
    rc |= put("transforms", "nerfactor", "\3", 1, nfa, sizeof nfa - 1);
    rc |= put_text("opts", "recon", "scene\n--iters\n10\n--lr\n0.01\n--seed\n3\n--res\n64\n");
    rc |= put_text("opts", "config", "scene\n--config\n@cfg\n--seed\n1\n@@\n{\"iters\": 5, \"seed\": null, \"comment\": \"x\"}\n");
    rc |= put_text("opts", "print", "--print-config\n--methods\nnvdiffrecmc\n");
    return rc;
}

static int seeds_binary(void) {
    int rc = 0;
    rc |= put_file("image", "png8", 0, mf_fuzz_path("fix/rgba.png"));
    rc |= put_file("image", "exr", 1, mf_fuzz_path("fix/rgba.exr"));
    static const MfTensorSpec specs[2] = {{"w", 2, {2, 3}}, {"b", 1, {3}}};
    float vals[9] = {1, 2, 3, 4, 5, 6, -1, 0.5f, 0};
    const char *ck = mf_fuzz_path("seed.mfck");
    if (mf_ckpt_save(ck, specs, 2, vals, "{\"iter\": 7}") || put_file("ckpt", "ckpt", -1, ck)) return -1;
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    MfPrior *pr = NULL;
    const char *pp = mf_fuzz_path("seed_prior.mfck");
    if (mf_prior_new(&pr, &cfg) || mf_prior_save(pr, pp, NULL)) {
        mf_prior_free(pr);
        return fprintf(stderr, "fuzz_seeds: prior: %s\n", mf_error()), -1;
    }
    mf_prior_free(pr);
    return rc | put_file("prior", "tiny", -1, pp);
}

/* glTF: our writer's .glb with and without textures (normal map and TANGENT included; a small UV
 * sphere), and .gltf text with a normalTexture, emission and a material extension, and with a
 * base64 buffer, a node hierarchy (TRS, matrix, a mirror), indices and an external image file. */
static int seeds_gltf(void) {
    MfMesh m = {0};
    if (mf_mesh_uv_sphere(&m, 4, 3, mf_v3(0, 0, 0), 0.5f)) return -1;
    MfGltfMaterial mat = mf_gltf_material_default();
    mat.albedo_png = mat.orm_png = mat.normal_png = mf_fuzz_path("fix/rgba.png"); /* normal map: TANGENT too */
    const char *a = mf_fuzz_path("seed_tex.glb"), *b = mf_fuzz_path("seed_plain.glb");
    int rc = mf_gltf_write_glb(a, &m, &mat) || mf_gltf_write_glb(b, &m, NULL);
    mf_mesh_free(&m);
    if (rc) return fprintf(stderr, "fuzz_seeds: glb: %s\n", mf_error()), -1;
    rc = put_file("gltf", "textured.glb", -1, a) | put_file("gltf", "plain.glb", -1, b);
    /* one triangle: positions (0,0,0) (1,0,0) (0,1,0), normals +Z, UVs, uint16 indices 0 1 2 (+ pad) */
    rc |= put_text("gltf", "nodes.gltf",
                   "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,2]}],"
                   "\"nodes\":[{\"translation\":[1,2,3],\"rotation\":[0,0.7071068,0,0.7071068],\"scale\":[2,2,2],\"children\":[1]},"
                   "{\"mesh\":0,\"matrix\":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,5,1]},{\"mesh\":0,\"scale\":[-1,1,1]}],"
                   "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"material\":0}]}],"
                   "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},\"baseColorFactor\":[1,0.5,0.5,1],"
                   "\"metallicRoughnessTexture\":{\"index\":0},\"metallicFactor\":0.5,\"roughnessFactor\":0.5},"
                   "\"occlusionTexture\":{\"index\":0,\"strength\":0.5},\"normalTexture\":{\"index\":0,\"scale\":0.5},"
                   "\"emissiveFactor\":[1,0,0],\"extensions\":{\"KHR_materials_clearcoat\":{}}}],"
                   "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"fix/rgba.png\"}],"
                   "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                   "{\"bufferView\":0,\"byteOffset\":36,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                   "{\"bufferView\":0,\"byteOffset\":72,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"},"
                   "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],"
                   "\"bufferViews\":[{\"buffer\":0,\"byteLength\":96},{\"buffer\":0,\"byteOffset\":96,\"byteLength\":8}],"
                   "\"buffers\":[{\"byteLength\":104,\"uri\":\"data:application/octet-stream;base64,"
                   "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/"
                   "AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAABAAIAAAA=\"}]}");
    return rc;
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: fuzz_seeds OUT\n");
        return 2;
    }
    g_out = argv[1];
    if (!mf_fuzz_dir()[0]) return 1;
    return (seeds_text() || seeds_binary() || seeds_gltf()) ? 1 : 0;
}
