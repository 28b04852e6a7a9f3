/* mf_transforms: NeRF-synthetic camera files (a split's transforms_<split>.json, the "cameras"
 * of a scene JSON, `mf relight --cameras`):
 *   {"camera_angle_x": radians, "frames": [{"file_path": "...", "transform_matrix": 4x4 rows}, ...]}
 * One reader for the scene loader (mf_scene), `mf relight` and the split renderer
 * (ds_render_split). The capture loader (datasets/ds_load) reads the richer files of real
 * captures (fl_x/fl_y, cx/cy, per-frame intrinsics, image and mask paths) itself. The values are
 * not checked here: mf_camera_init refuses a bad field of view or a non-rigid matrix. */
#ifndef MF_TRANSFORMS_H
#define MF_TRANSFORMS_H

#include "io/mf_json.h"

typedef struct {
    double c2w[16]; /* (4, 4) row-major camera-to-world, OpenGL camera axes */
    char name[128]; /* file_path's base name without extension ('\\', ':' and control characters
                       made '_'), "" when the frame has none */
} MfTransformFrame;

typedef struct {
    double camera_angle_x;
    int n;
    MfTransformFrame *frames; /* owned; (n,) */
} MfTransforms;

/* Parses obj. Messages name file and the JSON path: prefix ("" or e.g. "cameras.") + "frames[k]". */
int mf_transforms_parse(const char *file, const char *prefix, const cJSON *obj, MfTransforms *t);
/* Loads and parses the file at path. */
int mf_transforms_load(const char *path, MfTransforms *t);
void mf_transforms_free(MfTransforms *t);

#endif
