/* mf_camera: pinhole cameras in the NeRF-synthetic convention (DESIGN.md).
 *
 * camera_angle_x and a 4x4 camera-to-world matrix with OpenGL camera axes (x right, y up,
 * looking down -z). Pixel (i, j) (column i, row j from the top) has its centre at (i+0.5, j+0.5);
 * fx = fy = W / (2 tan(camera_angle_x / 2)), principal point at (W/2, H/2). */
#ifndef MF_CAMERA_H
#define MF_CAMERA_H

#include "core/mf_math.h"

typedef struct {
    int w, h;
    float fx, fy, cx, cy;
    MfMat4 c2w; /* row-major camera-to-world */
} MfCamera;

/* Builds a camera; fails with MF_EARG ("... is not a rigid transform") when the 3x3 part is not
 * orthonormal within 1e-3 or the last row is not (0,0,0,1). `what` names the source for messages
 * (e.g. "x/transforms_train.json: frames[3]"). Rigid check is done in double. A camera position
 * with a coordinate beyond MF_COORD_MAX (mf_math.h) is refused: "... camera position z = 1e+39 is
 * out of range". */
int mf_camera_init(MfCamera *cam, int w, int h, double camera_angle_x, const double c2w[16], const char *what);
/* Ray through continuous pixel position (px, py) (pixel units, origin top-left): origin and unit dir. */
void mf_camera_ray(const MfCamera *cam, float px, float py, MfVec3 *org, MfVec3 *dir);
/* Projects a world point to continuous pixel coordinates; returns 0 if behind the camera. */
int mf_camera_project(const MfCamera *cam, MfVec3 p, float *px, float *py);
/* Camera position in world space. */
MfVec3 mf_camera_pos(const MfCamera *cam);

#endif
