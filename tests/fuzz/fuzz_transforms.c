/* Fuzz harness: the data set loaders' JSON (ds_load.h), every layout. The first byte picks the
 * layout, the rest is the file: 0 NeRF-Synthetic transforms_train.json, 1 bvault (with gt/),
 * 2 Stanford-ORB blender_HDR/<capture>/transforms_train.json (train_mask/ beside it),
 * 3 NeRFactor train_000/metadata.json. Every layout's folder holds 2x2 images under the names
 * the seeds use (train/r_0.png, train/0000.exr, train_mask/0000.png, train_000/rgba.png), so
 * inputs that parse reach the image phase. */
#include <stdio.h>
#include <stdlib.h>

#include "datasets/ds_load.h"
#include "core/mf_fs.h"
#include "mf_fuzz.h"

static int copy_fix(const char *fix, const char *rel) {
    char *d;
    size_t n;
    char src[1024];
    snprintf(src, sizeof src, "%s", mf_fuzz_path(fix));
    if (mf_read_file(src, &d, &n)) return -1;
    const char *p = mf_fuzz_write(rel, d, n);
    free(d);
    return p ? 0 : -1;
}

static int layouts(void) {
    static int state; /* 0 not made, 1 ready, -1 failed */
    if (state) return state;
    state = -1;
    if (copy_fix("fix/rgba.png", "nerf/train/r_0.png") || copy_fix("fix/rgba.png", "bvault/train/r_0.png") ||
        copy_fix("fix/rgba.png", "bvault/gt/albedo/r_0.png") || copy_fix("fix/rgba.png", "bvault/gt/orm/r_0.png") ||
        copy_fix("fix/rgba.exr", "orb/blender_HDR/cap/train/0000.exr") ||
        copy_fix("fix/rgba.png", "orb/blender_HDR/cap/train_mask/0000.png") ||
        copy_fix("fix/rgba.png", "nerfactor/train_000/rgba.png"))
        return state;
    state = 1;
    return state;
}

MF_FUZZ(transforms) {
    if (!mf_fuzz_dir()[0] || layouts() != 1 || size < 1) return 0;
    DsLoadOptions o = {.load_gt = 1};
    DsViews v = {0};
    int rc = -1;
    switch (data[0] % 4) {
    case 0:
        if (mf_fuzz_write("nerf/transforms_train.json", data + 1, size - 1))
            rc = ds_load_nerf_synthetic(mf_fuzz_path("nerf"), "train", &o, &v);
        break;
    case 1:
        if (mf_fuzz_write("bvault/transforms_train.json", data + 1, size - 1))
            rc = ds_load_bvault(mf_fuzz_path("bvault"), "train", &o, &v);
        break;
    case 2:
        if (mf_fuzz_write("orb/blender_HDR/cap/transforms_train.json", data + 1, size - 1))
            rc = ds_load_stanford_orb(mf_fuzz_path("orb"), "cap", "train", &o, &v);
        break;
    default:
        if (mf_fuzz_write("nerfactor/train_000/metadata.json", data + 1, size - 1))
            rc = ds_load_nerfactor(mf_fuzz_path("nerfactor"), "train", &o, &v);
        break;
    }
    if (rc == 0) ds_views_free(&v);
    return 0;
}
