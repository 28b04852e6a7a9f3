/* mf_gltf: glTF 2.0 binary (.glb) export of a textured mesh with a metallicRoughness material.
 *
 * One mesh, one primitive (triangles), one node, one material; PNG textures are embedded as
 * bufferViews (their file bytes, unchanged). Layout of the BIN chunk (every view 4-byte
 * aligned): POSITION (float VEC3, with accessor min/max), NORMAL (float VEC3, unit), TEXCOORD_0
 * (float VEC2), indices (uint32 SCALAR), then the PNG images. Units: the mesh's world units
 * (glTF says metres). Axes: our world is +Z up (DESIGN.md), glTF's is +Y up (and +Z forward), so
 * positions, normals and tangents are written rotated by -90 degrees about +X:
 * (x, y, z) -> (x, z, -y); a reader going back to our axes applies (x, y, z) -> (x, -z, y), as
 * io/mf_gltf_read.h does. A rotation keeps triangle winding and tangent handedness (w), so both
 * are written unchanged, and the object stands upright in every viewer and in Blender's importer
 * (which turns +Y up back into Blender's +Z up).
 *
 * Conventions: glTF texture coordinates have v down (origin at the top-left of the image), so
 * TEXCOORD_0 = (u, 1 - v) of our OBJ-style UVs. baseColorTexture must be an sRGB PNG (our
 * albedo.png); metallicRoughnessTexture a linear ORM PNG (G roughness, B metallic; R is
 * ignored by glTF, our files hold R = 1). Meshes without normals get area-weighted smooth
 * normals; a mesh without UVs can be exported only without textures. Per-triangle material ids
 * are ignored (one material for the whole mesh). The file is written atomically.
 * Normal maps: normalTexture is a linear tangent-space PNG in glTF's convention, which is ours
 * (scene/mf_tangent.h: +X along increasing u, +Y toward the image's top row). With one, the
 * primitive also carries TANGENT (float VEC4, xyz unit, w = +-1 handedness: bitangent =
 * w cross(NORMAL, tangent)) from mf_mesh_tangents, appended after the images in the BIN chunk,
 * so viewers shade with exactly the frames our renderer uses instead of deriving MikkTSpace
 * ones. Files without a normal map are unchanged. */
#ifndef MF_GLTF_H
#define MF_GLTF_H

#include "scene/mf_mesh.h"

typedef struct {
    const char *name;          /* borrowed; material and node name, NULL = "material" */
    const char *albedo_png;    /* borrowed; path of the baseColorTexture PNG (sRGB), or NULL */
    const char *orm_png;       /* borrowed; path of the metallicRoughnessTexture PNG (linear), or NULL */
    const char *normal_png;    /* borrowed; path of the normalTexture PNG (linear, tangent space), or NULL */
    float base_color[4];       /* baseColorFactor, linear RGBA (multiplies the texture) */
    float metallic, roughness; /* metallicFactor, roughnessFactor (multiply B and G) */
    int double_sided;
} MfGltfMaterial;

/* Factors 1 (so textures are used as they are), single-sided, no textures. */
MfGltfMaterial mf_gltf_material_default(void);

/* Writes m (nv > 0, nt > 0) as a .glb file. mat may be NULL (default material). */
int mf_gltf_write_glb(const char *path, const MfMesh *m, const MfGltfMaterial *mat);

#endif
