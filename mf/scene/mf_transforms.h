/* mf_transforms: the one reader of NeRF-synthetic style camera files: a split's
 * transforms_<split>.json, the "cameras" of a scene JSON, `mf relight --cameras`, and the richer
 * files of data sets and real captures (bvault, Stanford-ORB, instant-ngp / nerfstudio
 * transforms.json):
 *   {"camera_angle_x": radians, "frames": [{"file_path": "...", "transform_matrix": 4x4 rows}, ...]}
 * Used by the scene loader (mf_scene), `mf relight`, the split renderer (ds_render_split) and, with
 * MF_TF_CAPTURE, the data set loaders (datasets/ds_load), which add only the data-set logic
 * (split selection, image and mask paths, images). Messages name the file and the JSON path
 * ("frames[3].fl_x = -3: expected a number in (0, 1e+07]"). Poses and fields of view are not
 * checked here: mf_camera_init refuses a bad field of view or a non-rigid matrix. */
#ifndef MF_TRANSFORMS_H
#define MF_TRANSFORMS_H

#include "io/mf_json.h"

/* Intrinsics keys of instant-ngp / nerfstudio files, the order of intr[] below. */
enum { MF_TF_FL_X, MF_TF_FL_Y, MF_TF_CX, MF_TF_CY, MF_TF_W, MF_TF_H, MF_TF_NINTR };

/* Flags of mf_transforms_parse. Without flags: camera_angle_x is required at the root, file_path
 * is optional and nothing else is read. MF_TF_CAPTURE: file_path is required; camera_angle_x
 * (root or per frame) may be left out where fl_x gives the focal length; fl_x, fl_y, cx, cy, w, h
 * are read at the root and per frame, lens distortion (k1..k4, p1, p2 non-zero) and camera models
 * other than a pinhole are refused by name; mask_path and scene_name are read; aabb_scale is
 * ignored with a log line. */
enum { MF_TF_CAPTURE = 1 };

typedef struct {
    double c2w[16];        /* (4, 4) row-major camera-to-world, OpenGL camera axes */
    double camera_angle_x; /* the frame's own (MF_TF_CAPTURE), else the root's; NAN = not given */
    double intr[MF_TF_NINTR]; /* the frame's own, else the root's, in the file's pixels; NAN = not given */
    char name[128]; /* file_path's base name without extension ('\\', ':' and control characters
                       made '_'), "" when the frame has none */
    char *file_path;  /* as written; NULL = not given; owned */
    char *mask_path;  /* MF_TF_CAPTURE; NULL = not given; owned */
    char *scene_name; /* MF_TF_CAPTURE (Stanford-ORB novel frames); NULL = not given; owned */
} MfTransformFrame;

typedef struct {
    double camera_angle_x;    /* NAN = not given (MF_TF_CAPTURE only) */
    double intr[MF_TF_NINTR]; /* root intrinsics; NAN = not given */
    int n;
    MfTransformFrame *frames; /* owned; (n,) */
} MfTransforms;

/* Parses obj. Messages name file and the JSON path: prefix ("" or e.g. "cameras.") + "frames[k]". */
int mf_transforms_parse(const char *file, const char *prefix, const cJSON *obj, int flags, MfTransforms *t);
/* Loads and parses the file at path. */
int mf_transforms_load(const char *path, int flags, MfTransforms *t);
void mf_transforms_free(MfTransforms *t);

#endif
