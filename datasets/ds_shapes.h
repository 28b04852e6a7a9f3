/* ds_shapes: procedural objects for the synthetic data sets (issue "Datasets", part 1).
 *
 * ds_object_generate(fam, seed, tex_res) builds an object that looks artist-made: revolved
 * profiles (cup, vase, bottle with cap, bowl: a random smooth profile curve revolved about +Z,
 * vessels with wall thickness and a rounded rim), bevelled boxes, superquadrics, tori,
 * composites (mug = body + handle tube with rounded ends; clock = case + face + two hands +
 * pin) and displaced surfaces (fbm noise along the normals of an ellipsoid).
 *
 * Geometry: every part is a closed surface made of parametric grid patches; seams duplicate
 * vertices with bit-identical positions; pole rows never produce degenerate triangles.
 * Winding is outward (counter-clockwise seen from outside; each part's signed volume > 0).
 * Normals are smooth per part (area-weighted, welded across seams). The object is centred at
 * the origin with its largest extent 1 (mf_mesh_normalize), +Z up. mesh.mat gives the part
 * index of every triangle and mesh.mat_names the part names ("body", "handle", ...).
 *
 * UVs: one chart per patch, packed without overlap into one [0,1]^2 atlas by shelf packing with
 * a uniform texel density (charts' aspect clamped to 4:1), separated by 2 * gutter texels.
 *
 * Textures: kd (res, res, 3) linear base colour and ORM (res, res, 3) linear (R = 1,
 * G roughness, B metallic), baked in UV space: each texel centre covered by a triangle's UV
 * footprint gets the part's procedural material (ds_materials.h) evaluated at the 3D surface
 * point (so patterns run continuously across chart seams), then `gutter` rings of texels around
 * every chart are dilated (average of covered neighbours) against bilinear bleeding; texels
 * outside every chart and gutter get the mean of covered texels.
 *
 * Determinism: everything is a function of (family, seed, tex_res); same inputs, same bytes. */
#ifndef DS_SHAPES_H
#define DS_SHAPES_H

#include <stdint.h>

#include "datasets/ds_materials.h"
#include "io/mf_image.h"
#include "scene/mf_mesh.h"

typedef enum {
    DS_FAM_CUP = 0,
    DS_FAM_VASE,
    DS_FAM_BOTTLE,
    DS_FAM_BOWL,
    DS_FAM_BOX,
    DS_FAM_SUPERQUADRIC,
    DS_FAM_TORUS,
    DS_FAM_MUG,
    DS_FAM_CLOCK,
    DS_FAM_DISPLACED,
    DS_FAM_COUNT
} DsFamily;

#define DS_MAX_PARTS 8
#define DS_DEFAULT_TEX_RES 512
#define DS_DEFAULT_GUTTER 4

typedef struct {
    char name[32];
    DsMaterial mat;
    MfMat4 obj_to_local; /* normalised object space -> the part's material frame (rigid) */
} DsPart;

typedef struct {
    DsFamily family;
    uint64_t seed;
    MfMesh mesh;  /* owned; normalised; nrm (nv,3) unit, uv (nv,2) in [0,1], mat (nt,) part index */
    int nparts;
    DsPart parts[DS_MAX_PARTS];
    MfImage kd;   /* owned; (res, res, 3) linear base colour */
    MfImage orm;  /* owned; (res, res, 3) linear: R = 1, G roughness, B metallic */
    char asset[64]; /* non-empty: read from this asset (ds_asset.h; its stem), family/seed/parts unused */
    MfImage normal; /* owned; (h, w, 3) linear tangent-space normal map (render/mf_normalmap.h), or
                       data NULL: none (assets only; written as gt/normal.png, used by the GT renders) */
    char unrendered[256]; /* assets: what of the material is not rendered ("" = nothing; ds_asset.h) */
} DsObject;

const char *ds_family_name(DsFamily f);
/* Family by name ("cup", "mug", ...); -1 when unknown. */
int ds_family_from_name(const char *name);

/* Builds the object (geometry, atlas and baked textures of size tex_res x tex_res, gutter
 * DS_DEFAULT_GUTTER). tex_res in [16, 8192]. On failure *o is untouched. */
int ds_object_generate(DsObject *o, DsFamily fam, uint64_t seed, int tex_res);
void ds_object_free(DsObject *o);

/* Writes kd.png (sRGB 8-bit) and orm.png (linear 8-bit) into dir (created), and normal.png
 * (linear 8-bit, like a result's) when the object has a normal map. */
int ds_object_write_textures(const DsObject *o, const char *dir);

/* Writes the object's ground truth in the bvault layout (DESIGN.md "Contracts") under scene_dir:
 * mesh.obj (+ mesh.mtl: one material per part, map_Kd gt/kd.png), gt/kd.png, gt/orm.png, and
 * gt/object.json (family, seed, per part: name, material class, pattern, base colour, roughness,
 * metallic, whether a metallic mask is used). */
int ds_object_write(const DsObject *o, const char *scene_dir);

#endif
