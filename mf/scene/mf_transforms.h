/* mf_transforms: the one reader of NeRF-synthetic style camera files, for the scene loader
 * (mf_scene), `mf relight --cameras`, the split renderer (ds_render_split) and, with MF_TF_CAPTURE,
 * the data set loaders (ds_load: NeRF-Synthetic, bvault, Stanford-ORB, instant-ngp / nerfstudio):
 *   {"camera_angle_x": radians, "frames": [{"file_path": "...", "transform_matrix": 4x4 rows}, ...]}
 * Messages name the file and the JSON path ("frames[3].fl_x = -3: expected a number in (0, 1e+07]").
 * Poses are not checked here: mf_camera_init refuses a bad field of view or a non-rigid matrix. */
#ifndef MF_TRANSFORMS_H
#define MF_TRANSFORMS_H

#include "io/mf_json.h"

/* Flags. 0: camera_angle_x required at the root, file_path optional, nothing else read.
 * MF_TF_CAPTURE: file_path required; camera_angle_x (root or frame) optional where fl_x is given;
 * fl_x fl_y cx cy w h, mask_path, scene_name read; non-zero k1..k4 p1 p2 and non-pinhole
 * camera_model refused by name; aabb_scale ignored with a log line.
 * MF_TF_QUIET: no log lines (for a file loaded again in the same command, whose notes were said). */
enum { MF_TF_CAPTURE = 1, MF_TF_QUIET = 2 };

typedef struct {
    double c2w[16];        /* (4, 4) row-major camera-to-world, OpenGL camera axes */
    double camera_angle_x; /* the frame's own (MF_TF_CAPTURE), else the root's; NAN = not given */
    double intr[6];        /* fl_x, fl_y, cx, cy, w, h in the file's pixels: the frame's own, else
                              the root's (MF_TF_CAPTURE); NAN = not given */
    char name[128]; /* file_path's base name without extension ('\\', ':' and control characters
                       made '_'), "" when the frame has none */
    char *file_path, *mask_path, *scene_name; /* as written (the last two with MF_TF_CAPTURE);
                                                 NULL = not given; owned */
} MfTransformFrame;

typedef struct {
    double camera_angle_x; /* NAN = not given (MF_TF_CAPTURE only) */
    double intr[6];        /* root fl_x, fl_y, cx, cy, w, h; NAN = not given */
    int n;
    MfTransformFrame *frames; /* owned; (n,) */
} MfTransforms;

/* Parses obj. Messages name file and the JSON path: prefix ("" or e.g. "cameras.") + "frames[k]". */
int mf_transforms_parse(const char *file, const char *prefix, const cJSON *obj, int flags, MfTransforms *t);
/* Loads and parses the file at path. */
int mf_transforms_load(const char *path, int flags, MfTransforms *t);
void mf_transforms_free(MfTransforms *t);

#endif
