#include "datasets/ds_asset.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "io/mf_gltf_read.h"

void ds_asset_stem(const char *path, char *out, size_t cap) {
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    size_t n = strlen(b);
    const char *dot = strrchr(b, '.');
    if (dot && dot != b) n = (size_t)(dot - b);
    if (n >= cap) n = cap - 1;
    for (size_t i = 0; i < n; ++i) out[i] = isalnum((unsigned char)b[i]) || b[i] == '-' || b[i] == '_' ? b[i] : '_';
    out[n] = 0;
}

/* Moves image src into dst (dst takes ownership). */
static void take_image(MfImage *dst, MfImage *src) {
    *dst = *src;
    memset(src, 0, sizeof *src);
}

int ds_object_from_asset(const char *path, DsObject *o) {
    if (!mf_is_gltf_path(path)) return mf_fail(MF_EARG, "%s: an asset must be glTF 2.0 (.glb or .gltf)", path);
    MfGltfAsset a;
    int rc = mf_gltf_read(path, &a);
    if (rc) return rc;
    if (a.mesh.nt < 1) rc = mf_fail(MF_EFORMAT, "%s: the asset has no triangles", path);
    else if (!a.mesh.uv) rc = mf_fail(MF_EFORMAT, "%s: the asset has no UVs (TEXCOORD_0); its textures cannot be ground truth", path);
    else if (a.nmat != 1)
        rc = mf_fail(MF_EFORMAT, "%s: the asset has %d materials; a data-set object has one albedo and one ORM texture "
                     "(bake the materials into one texture set first)", path, a.nmat);
    if (rc) { mf_gltf_asset_free(&a); return rc; }
    memset(o, 0, sizeof *o);
    o->mesh = a.mesh;
    memset(&a.mesh, 0, sizeof a.mesh);
    free(o->mesh.mat); /* one material: no per-triangle ids */
    o->mesh.mat = NULL;
    for (int i = 0; i < o->mesh.nmat && o->mesh.mat_names; ++i) free(o->mesh.mat_names[i]);
    free(o->mesh.mat_names);
    o->mesh.mat_names = NULL;
    o->mesh.nmat = 0;
    mf_mesh_normalize(&o->mesh, 1.0f);
    take_image(&o->kd, &a.mats[0].albedo);
    take_image(&o->orm, &a.mats[0].orm);
    if (a.mats[0].has_normal) take_image(&o->normal, &a.mats[0].normal);
    snprintf(o->unrendered, sizeof o->unrendered, "%s", a.mats[0].unrendered);
    ds_asset_stem(path, o->asset, sizeof o->asset);
    mf_gltf_asset_free(&a);
    return MF_OK;
}
