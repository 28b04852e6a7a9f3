/* Shared helpers of the geometry tests (header-only). */
#ifndef MF_TEST_GEOM_H
#define MF_TEST_GEOM_H

#include "scene/mf_camera.h"
#include "scene/mf_mesh.h"

/* The signed volume of a closed mesh (positive for outward-facing triangles). */
static inline double signed_volume(const MfMesh *m) {
    double v = 0;
    for (int t = 0; t < m->nt; ++t) {
        const float *a = m->pos + 3 * m->tri[3 * t], *b = m->pos + 3 * m->tri[3 * t + 1], *c = m->pos + 3 * m->tri[3 * t + 2];
        v += (a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
              a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0])) / 6.0;
    }
    return v;
}

/* cam (w x h px, camera_angle_x 0.6911 rad) at eye looking at target, z up; mf_camera_init's
 * status. */
static inline int look_cam(MfCamera *cam, int w, int h, MfVec3 eye, MfVec3 target) {
    MfMat4 c2w = mf_mat4_look_at(eye, target, mf_v3(0, 0, 1));
    double m[16];
    for (int i = 0; i < 16; ++i) m[i] = c2w.m[i];
    return mf_camera_init(cam, w, h, 0.6911, m, "test");
}

#endif
