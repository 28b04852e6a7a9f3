/* ds_capture: a generated object written and rendered as an instant-ngp / nerfstudio capture
 * (`mf gen --layout ingp`; issue 15 item 5), the layout users' captures have, so that the capture
 * reader of ds_load.h can be checked against known cameras. dir gets:
 *   transforms.json   one file for every frame (ds_load's split rule: test = frames 0, 8, 16, ...):
 *                     root: camera_angle_x (the sampling's nominal 0.6911: what a reader that
 *                     ignored fl_x would use), fl_x, fl_y, cx, cy, w, h (the global lens),
 *                     k1, k2, p1, p2 (s->distortion), aabb_scale; per frame: file_path
 *                     "images/r_NNN.png", mask_path "masks/r_NNN.png", transform_matrix (c2w,
 *                     OpenGL axes) and, on odd frames, their own fl_x, fl_y, cx, cy (a second
 *                     lens: focal lengths x DS_CAPTURE_LENS2_ZOOM, principal point mirrored
 *                     about the centre), which win over the root's
 *   images/r_NNN.png  RGB 8-bit sRGB, no alpha: the straight (un-premultiplied) colour over a
 *                     black background
 *   masks/r_NNN.png   1 channel 8-bit linear coverage
 *   mesh.obj          the object's mesh with UVs (world space, no material: mf recon's given mesh)
 * No ground truth (textures, light, relit views): it is a capture. Every frame is rendered with
 * mf_render at its own intrinsics (non-square pixels, moved principal point) under one procedural
 * indoor light (ds_envgen.h, DS_ENV_INDOOR, from the seed), cameras from ds_sample_cameras (stream
 * 0). The images are always rendered with a pinhole: non-zero distortion coefficients are written
 * as given but NOT applied to the images, so such a capture only checks that a reader refuses
 * (or would apply) them. Files are written to temporary names and renamed; the bytes follow from
 * (spec, object, seed). */
#ifndef DS_CAPTURE_H
#define DS_CAPTURE_H

#include <stdint.h>

#include "datasets/ds_shapes.h"

/* Odd frames' lens: focal lengths times this. */
#define DS_CAPTURE_LENS2_ZOOM 1.25

typedef struct {
    int n_frames;         /* frames in transforms.json (>= 2: one test, one train) */
    int w, h;             /* image size in pixels */
    double fl_x, fl_y, cx, cy; /* global lens in pixels (cy from the top row) */
    double distortion[4]; /* k1, k2, p1, p2 (OpenCV), written only */
    float r_min, r_max;   /* camera distance range */
    int spp_sqrt, pixel_samples;
} DsCaptureSpec;

/* n_frames 24, w x h = width x (3 width / 4), fl_x = 0.9 f0 with f0 = width / (2 tan(0.6911 / 2))
 * (a wider lens than camera_angle_x says), fl_y = 1.1 fl_x (non-square pixels), cx = 0.55 w,
 * cy = 0.45 h, no distortion, radius 1.5-2.0, spp_sqrt 4, 4 pixel samples. */
DsCaptureSpec ds_capture_spec_default(int width);

/* MF_EARG naming the bad field: sizes, frame count, a focal length that is not finite and positive,
 * a principal point outside the image, distortion outside [-10, 10], no samples. */
int ds_capture_check(const DsCaptureSpec *s);

/* Writes and renders the capture of o into dir (see above); checks s first (ds_capture_check). */
int ds_write_capture(const DsCaptureSpec *s, const DsObject *o, uint64_t seed, const char *dir);

#endif
