/* mf_gltf_read: glTF 2.0 import (.glb, and .gltf with external or data-URI buffers and images)
 * of triangle meshes with metallicRoughness materials, into our conventions.
 *
 * Mesh: every mesh primitive reached from the default scene's nodes (or, without scenes, from
 * the nodes that are nobody's child), with the node transforms applied, appended into one MfMesh:
 * POSITION, NORMAL (inverse-transpose of the node matrix, renormalised; when any primitive has
 * none, area-weighted smooth normals are computed for the whole mesh), TEXCOORD_0 (float, or
 * normalised unsigned byte/short; (0, 0) for primitives without it, NULL when no primitive has
 * it) and indices (unsigned byte/short/int; none = consecutive triangles).
 * Axes: glTF is +Y up, ours +Z up (DESIGN.md), so positions and normals go through
 * (x, y, z) -> (x, -z, y), exactly the inverse of what mf_gltf_write_glb writes. UVs: glTF has v
 * down, ours v up: v = 1 - v_gltf (images unchanged). A node matrix with negative determinant
 * (a mirror) has its triangles' winding reversed, as the glTF spec asks.
 *
 * Material: baseColorTexture (sRGB PNG/JPEG, decoded to linear) x baseColorFactor (linear RGB;
 * alpha dropped) -> albedo; metallicRoughnessTexture (G roughness, B metallic) x the factors and
 * occlusionTexture (R, with strength: 1 + strength (R - 1)) -> our ORM (R occlusion, G roughness,
 * B metallic), at the size of the metallicRoughness texture (occlusion sampled bilinearly where
 * the two differ). A channel without a texture is a 1x1 image of its factor. Primitives without
 * a material get glTF's default material (factors 1, no textures).
 * normalTexture (linear, TEXCOORD_0; glTF's convention, which is ours: n_t = 2 v - 1, +X along
 * increasing u, +Y toward the image's top row, bitangent = w cross(N, T), scene/mf_tangent.h)
 * with `scale` applied as the spec says: n_t = normalize((2 v - 1) * (scale, scale, 1)). Every
 * consumer (renderer, relight, eval, the data-set writer) builds tangent frames with
 * mf_mesh_tangents from the mesh, so the map is returned relative to those frames: without a
 * TANGENT attribute glTF asks for generated (MikkTSpace) tangents and ours stand in for them,
 * the map is unchanged; with TANGENT (float VEC4, transformed by the node matrices like
 * positions, w flipped under a mirror) each texel a triangle covers (texel centres inside the
 * triangle in UV space, or up to one texel outside its edges, the nearest triangle winning) is
 * re-expressed from the file's interpolated frame into ours: n_ours = (n.T, n.B, n.N) of
 * n = T_f x + B_f y + N z, normalised. Vertices of primitives without TANGENT use our frame.
 * Emission (emissiveFactor / emissiveTexture), alphaMode other than OPAQUE, material extensions
 * (KHR_materials_*) and texture extensions (KHR_texture_transform) are not rendered: they are
 * listed in MfGltfPbr.unrendered and a warning names the file and the material.
 *
 * Refused with a message naming the file and the JSON path: any extensionsRequired (Draco,
 * meshopt, quantization, texture transforms, KTX2/WebP images, ...), sparse accessors, primitive
 * modes other than triangles, textures on a texCoord set other than 0, images other than PNG/JPEG,
 * URIs that are not relative files or base64 data. Skins and morph targets are ignored (the
 * rest pose). Every size read from the file (chunk lengths, buffer lengths, accessor counts,
 * strides, indices) is checked against the bytes that exist before anything is allocated from it;
 * the assembled mesh is capped at MF_GLTF_MAX_ELEMENTS vertices and triangles (instancing could
 * otherwise multiply a small file into a huge mesh). */
#ifndef MF_GLTF_READ_H
#define MF_GLTF_READ_H

#include "io/mf_image.h"
#include "scene/mf_mesh.h"

#define MF_GLTF_MAX_ELEMENTS (1 << 24)

typedef struct {
    char name[128];  /* the glTF material's name, or "material_<i>" */
    MfImage albedo;  /* owned; (h, w, 3) linear base colour, texture x factor; 1x1 without a texture */
    MfImage orm;     /* owned; (h, w, 3) linear: R occlusion, G roughness, B metallic; 1x1 without textures */
    int albedo_textured, orm_textured; /* 1 when the image came from a texture */
    MfImage normal;  /* owned when has_normal; (h, w, 3) linear tangent-space normal map, scale applied,
                        relative to mf_mesh_tangents of `mesh` (render/mf_normalmap.h convention) */
    int has_normal;
    float normal_scale;     /* normalTexture.scale as the file gives it (already applied to `normal`) */
    char unrendered[256];   /* what of the material changes the look but is not rendered ("" = nothing):
                               emissiveFactor / emissiveTexture, alphaMode, material extensions
                               (KHR_materials_*), texture extensions (KHR_texture_transform) */
} MfGltfPbr;

typedef struct {
    MfMesh mesh;     /* owned; +Z up; mesh.mat (nt,) and mesh.mat_names when nmat > 1 */
    MfGltfPbr *mats; /* owned; (nmat,) the materials the primitives use, in first-use order */
    int nmat;        /* >= 1 */
    int tangents;    /* 1: the file had TANGENT and its normal maps were re-expressed in our frames */
} MfGltfAsset;

/* Reads path (.glb or .gltf, told apart by the first 4 bytes, "glTF" = binary). */
int mf_gltf_read(const char *path, MfGltfAsset *out);
/* Frees everything and zeroes the struct; safe on a zeroed struct. */
void mf_gltf_asset_free(MfGltfAsset *a);
/* 1 when path ends in .glb or .gltf (any case). */
int mf_is_gltf_path(const char *path);
/* A mesh from an OBJ or a glTF file (by extension; glTF: mesh only, materials dropped). */
int mf_mesh_read(const char *path, MfMesh *out);

#endif
