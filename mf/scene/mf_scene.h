/* mf_scene: scene description files (JSON) for `mf render`, and the objects they describe.
 *
 * Format (all paths relative to the JSON file's folder unless absolute; units as DESIGN.md):
 * {
 *   "mesh": "mesh.obj",                        required; OBJ (v/vt/vn, usemtl), world space, or
 *                                              glTF 2.0 (.glb/.gltf, io/mf_gltf_read.h: turned to
 *                                              +Z up; its PBR materials are used when the file
 *                                              gives neither "material" nor "materials")
 *   "material": {                              optional default material for every triangle
 *     "kd":  "kd.png" | [r, g, b],             base colour: PNG/JPEG read as sRGB and decoded to
 *                                              linear (EXR/HDR taken as linear), or linear
 *                                              numbers; default [0.8, 0.8, 0.8]
 *     "orm": "orm.png" | [o, r, m],            glTF ORM: read as linear data; G roughness,
 *                                              B metallic (R unused); default [0, 0.5, 0]
 *     "normal": "normal.png"                   optional tangent-space normal map (linear, glTF
 *   },                                         convention, render/mf_normalmap.h; needs UVs).
 *                                              A glTF mesh's own materials bring their normalTexture
 *   "materials": {"<usemtl name>": {...}},     optional per-OBJ-material overrides, same fields
 *   "env": {"file": "probe.exr",               optional (absent or null: no environment light);
 *           "rotation_z_deg": 0,               lat-long HDR, Blender mapping; rotation about +Z
 *           "strength": 1},                    (right-handed) and a radiance multiplier
 *   "lights": [                                optional
 *     {"type": "sun", "dir": [x, y, z],        dir points FROM the scene TOWARD the sun
 *      "strength": 3, "color": [1, 1, 1]},     strength = irradiance, W/m^2 (Blender's Strength)
 *     {"type": "point", "pos": [x, y, z],
 *      "power": 100, "color": [1, 1, 1]}       power in W, intensity P / (4 pi) W/sr (Blender)
 *   ],
 *   "cameras": "transforms.json" | {...},      required; NeRF-synthetic: camera_angle_x and
 *                                              frames[].transform_matrix (4x4 camera-to-world,
 *                                              OpenGL axes), optional frames[].file_path whose
 *                                              base name names the output ("view_000" otherwise;
 *                                              two frames naming the same output are refused)
 *   "width": 256, "height": 256,               output size (defaults 256 x 256)
 *   "render": {"spp_sqrt": 8,                  optional renderer settings (MfRenderOpts):
 *              "pixel_samples": 4,             n^2 env + n^2 BSDF samples, primary rays per
 *              "seed": 0,                      pixel, base seed (view k uses hash(seed, k)),
 *              "lobes": "all"}                 "all" | "diffuse" | "specular"
 * }
 * Errors name the file and the JSON path, e.g. "s/scene.json: lights[1].dir: expected 3 numbers"
 * or "s/transforms.json: frames[2]: transform_matrix is not a rigid transform (...)". Loading
 * builds everything (mesh, textures, env tables); nothing is rendered here. Scene data only:
 * the renderer's inputs (MfRenderInput) are assembled from it by the caller (mf/cli/cmd_render.c),
 * keeping the dependency direction scene <- render. */
#ifndef MF_SCENE_H
#define MF_SCENE_H

#include "io/mf_image.h"
#include "scene/mf_camera.h"
#include "scene/mf_envmap.h"
#include "scene/mf_light.h"
#include "scene/mf_mesh.h"

typedef struct {
    char name[128];        /* output base name (no folder, no extension) */
    double camera_angle_x; /* radians */
    double c2w[16];        /* row-major camera-to-world, checked rigid */
} MfSceneView;

typedef struct {
    const MfImage *kd;  /* borrowed (from MfScene.images) or NULL: kd_const */
    const MfImage *orm; /* borrowed or NULL: orm_const */
    MfVec3 kd_const;    /* linear base colour */
    MfVec3 orm_const;   /* (occlusion, roughness, metallic) */
    const MfImage *normal; /* borrowed; tangent-space normal map (render/mf_normalmap.h), or NULL */
} MfSceneMaterial;

/* Renderer settings stored in the scene (mirrors MfRenderOpts). */
typedef struct {
    int spp_sqrt, pixel_samples;
    unsigned long long seed;
    int lobes; /* 1 diffuse, 2 specular, 3 all (MfLobes) */
} MfSceneRender;

typedef struct {
    char *path;            /* owned; the JSON file as given */
    MfMesh mesh;           /* owned */
    MfImage *images;       /* owned; (nimages,) textures, linear */
    int nimages;
    MfSceneMaterial *mats;   /* owned; (nmat,) indexed by mesh.mat; texture pointers into images */
    int nmat;
    MfEnvMap env;          /* owned when has_env */
    int has_env;
    MfLight *lights;       /* owned; (nlights,) */
    int nlights;
    MfSceneView *views;    /* owned; (nviews,) */
    int nviews;
    int width, height;
    MfSceneRender render;
} MfScene;

/* Loads and validates a scene file; on failure *out is untouched and the message names the
 * offending file and JSON path. */
int mf_scene_load(const char *path, MfScene *out);
void mf_scene_free(MfScene *s);
/* Camera of view k at w x h (0 = the scene's width/height). */
int mf_scene_camera(const MfScene *s, int k, int w, int h, MfCamera *cam);
/* Parses "all" | "diffuse" | "specular" into MfLobes values (1, 2, 3); -1 when unknown. */
int mf_lobes_parse(const char *name);

#endif
