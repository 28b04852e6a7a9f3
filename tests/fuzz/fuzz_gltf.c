/* Fuzz harness: glTF 2.0 import (mf_gltf_read: .glb or .gltf, told apart by the bytes). The input
 * lies in the scratch folder, so a .gltf may name the fixtures as external files (fix/rgba.png). */
#include "io/mf_gltf_read.h"
#include "mf_fuzz.h"

MF_FUZZ(gltf) {
    if (!mf_fuzz_dir()[0]) return 0;
    const char *p = mf_fuzz_write("in.glb", data, size);
    MfGltfAsset a = {0};
    if (p && mf_gltf_read(p, &a) == 0) mf_gltf_asset_free(&a);
    return 0;
}
