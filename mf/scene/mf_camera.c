#include "scene/mf_camera.h"

#include <math.h>

#include "core/mf_error.h"

int mf_camera_init(MfCamera *cam, int w, int h, double camera_angle_x, const double c2w[16], const char *what) {
    if (w <= 0 || h <= 0) return mf_fail(MF_EARG, "%s: image size %dx%d is invalid", what, w, h);
    if (!(camera_angle_x > 1e-4 && camera_angle_x < 3.1)) return mf_fail(MF_EARG, "%s: camera_angle_x %g rad is outside (1e-4, 3.1) rad", what, camera_angle_x);
    for (int i = 0; i < 16; ++i)
        if (!isfinite(c2w[i])) return mf_fail(MF_EARG, "%s: transform_matrix has a non-finite entry", what);
    /* Rigid: columns of the 3x3 part orthonormal, last row (0,0,0,1). */
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            double d = 0.0;
            for (int r = 0; r < 3; ++r) d += c2w[r * 4 + a] * c2w[r * 4 + b];
            if (fabs(d - (a == b ? 1.0 : 0.0)) > 1e-3)
                return mf_fail(MF_EARG, "%s: transform_matrix is not a rigid transform (rotation columns %d,%d dot = %.4g)", what, a, b, d);
        }
    if (fabs(c2w[12]) > 1e-6 || fabs(c2w[13]) > 1e-6 || fabs(c2w[14]) > 1e-6 || fabs(c2w[15] - 1.0) > 1e-6)
        return mf_fail(MF_EARG, "%s: transform_matrix is not a rigid transform (last row is not 0 0 0 1)", what);
    for (int r = 0; r < 3; ++r)
        if (!(fabs(c2w[r * 4 + 3]) <= MF_COORD_MAX))
            return mf_fail(MF_EARG, "%s: transform_matrix: camera position %c = %g is out of range (|coordinate| <= %g)",
                           what, "xyz"[r], c2w[r * 4 + 3], MF_COORD_MAX);
    double f = (double)w / (2.0 * tan(camera_angle_x / 2.0));
    cam->w = w;
    cam->h = h;
    cam->fx = cam->fy = (float)f;
    cam->cx = 0.5f * (float)w;
    cam->cy = 0.5f * (float)h;
    for (int i = 0; i < 16; ++i) cam->c2w.m[i] = (float)c2w[i];
    return MF_OK;
}

void mf_camera_ray(const MfCamera *cam, float px, float py, MfVec3 *org, MfVec3 *dir) {
    MfVec3 d = mf_v3((px - cam->cx) / cam->fx, -(py - cam->cy) / cam->fy, -1.0f);
    *dir = mf_norm(mf_mat4_dir(&cam->c2w, d));
    *org = mf_camera_pos(cam);
}

MfVec3 mf_camera_pos(const MfCamera *cam) { return mf_v3(cam->c2w.m[3], cam->c2w.m[7], cam->c2w.m[11]); }

int mf_camera_project(const MfCamera *cam, MfVec3 p, float *px, float *py) {
    const float *m = cam->c2w.m;
    MfVec3 q = mf_sub(p, mf_camera_pos(cam));
    /* camera coordinates = R^T q */
    float x = m[0] * q.x + m[4] * q.y + m[8] * q.z;
    float y = m[1] * q.x + m[5] * q.y + m[9] * q.z;
    float z = m[2] * q.x + m[6] * q.y + m[10] * q.z;
    if (z >= -1e-8f) return 0;
    *px = cam->cx + cam->fx * (x / -z);
    *py = cam->cy - cam->fy * (y / -z);
    return 1;
}
