/* ds_asset: a data-set object from a user's asset (glTF 2.0, .glb or .gltf) instead of a
 * procedural one, so a real PBR asset (a Khronos sample, a Blender export) goes through the same
 * split writer, renderer, reconstruction and evaluation as the generated objects (issue 15).
 *
 * The asset must have UVs and one material (its textures become the ground truth gt/kd.png and
 * gt/orm.png, ORM = glTF occlusion R, roughness G, metallic B, as mf_gltf_read reads them; its
 * normalTexture becomes o->normal, written as gt/normal.png and used by the GT renders); the
 * mesh is normalised like the generated objects (centred, largest extent 1, +Z up). What the
 * material has that is not rendered (emission, ...; MfGltfPbr.unrendered) is copied into
 * o->unrendered, recorded as not_rendered in gt/object.json and split.json. */
#ifndef DS_ASSET_H
#define DS_ASSET_H

#include "datasets/ds_shapes.h"

/* Fills *o (family unused, nparts 0, o->asset = the file's base name without extension).
 * MF_EFORMAT naming the file when it has no UVs, more than one material or no triangles. */
int ds_object_from_asset(const char *path, DsObject *o);

/* The scene name for an asset: its base name without extension, characters other than
 * [A-Za-z0-9_-] replaced by '_' (cap bytes including the NUL). */
void ds_asset_stem(const char *path, char *out, size_t cap);

#endif
