/* Fuzz harness: Wavefront OBJ (mf_obj_read) and MTL (mf_mtl_read) on the same bytes. */
#include "io/mf_obj.h"
#include "mf_fuzz.h"

MF_FUZZ(obj) {
    if (!mf_fuzz_dir()[0]) return 0;
    const char *p = mf_fuzz_write("in.obj", data, size);
    MfMesh m = {0};
    if (p && mf_obj_read(p, &m) == 0) mf_mesh_free(&m);
    MfMtl mtl = {0};
    if (p && mf_mtl_read(p, &mtl) == 0) mf_mtl_free(&mtl);
    return 0;
}
