/* Fuzz harness: scene files (mf_scene_load). The input is the scene JSON, in a folder that also
 * holds a triangle mesh (tri.obj), textures (rgba.png), an env map (rgba.exr) and a cameras file
 * (cams.json, written by the seeds as part of the input after a NUL: "scene\0cameras"). */
#include <string.h>

#include "mf_fuzz.h"
#include "scene/mf_scene.h"

MF_FUZZ(scene) {
    if (!mf_fuzz_dir()[0]) return 0;
    const uint8_t *nul = memchr(data, 0, size);
    size_t n1 = nul ? (size_t)(nul - data) : size;
    const char *p = mf_fuzz_write("fix/scene.json", data, n1);
    if (nul && !mf_fuzz_write("fix/cams.json", nul + 1, size - n1 - 1)) return 0;
    if (!nul) mf_fuzz_write("fix/cams.json", "", 0);
    MfScene s = {0};
    if (p && mf_scene_load(p, &s) == 0) mf_scene_free(&s);
    return 0;
}
