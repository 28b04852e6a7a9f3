/* ds_cameras: camera sampling for the generated splits and the transforms_<split>.json writer
 * (issue "Datasets", part 3; the images themselves are rendered elsewhere).
 *
 * Cameras follow DESIGN.md: NeRF-synthetic convention, camera_angle_x 0.6911 rad (Blender's
 * default lens), looking at the origin with +Z up (mf_mat4_look_at). Positions: azimuth
 * stratified over [az_min, az_max) degrees (view i in stratum i, jittered), elevation drawn so
 * directions are uniform in area over the band [el_min, el_max] degrees (uniform in sin(el)),
 * radius uniform in [r_min, r_max] world units. Deterministic from (seed, split stream).
 *
 * The writer produces {"camera_angle_x": a, "frames": [{"file_path": "./<split>/r_NNN",
 * "transform_matrix": [[...4x4 c2w...]]}, ...]} (file_path without extension, as NeRF-synthetic),
 * written atomically, numbers with 9 significant digits (float round trip). */
#ifndef DS_CAMERAS_H
#define DS_CAMERAS_H

#include <stdint.h>

#include "core/mf_math.h"

#define DS_CAMERA_ANGLE_X 0.6911

typedef struct {
    double camera_angle_x; /* radians */
    float az_min, az_max;  /* degrees */
    float el_min, el_max;  /* degrees, within [-90, 90] */
    float r_min, r_max;    /* world units */
} DsCamSampling;

/* camera_angle_x 0.6911, azimuth 0-360, elevation -15-90, radius 1.5-2.0. */
DsCamSampling ds_cam_sampling_default(void);

/* n camera-to-world matrices (n >= 1) into c2w (n,); stream separates splits (e.g. 0 train,
 * 1 test) so that they never share cameras. */
int ds_sample_cameras(const DsCamSampling *s, int n, uint64_t seed, uint64_t stream, MfMat4 *c2w);

/* Writes dir/transforms_<split>.json for n frames named "./<split>/r_NNN" (NNN = 3+ digits). */
int ds_write_transforms(const char *dir, const char *split, double camera_angle_x, const MfMat4 *c2w, int n);
/* m as a transforms file's "transform_matrix": 4 rows of 4 numbers printed %.9g; NULL when out of memory. */
struct cJSON *ds_transform_matrix_json(const MfMat4 *m);

#endif
