/* mf_math: small vector/matrix math for the renderer and the scene model.
 *
 * MfVec3 is three floats; MfMat4 is a row-major 4x4 float matrix acting on column vectors
 * (p' = M p), the layout of NeRF-synthetic's transform_matrix. Frames: an orthonormal basis
 * (t, b, n) built from a unit normal without branches that break at the poles (Duff et al. 2017).
 * Everything is inline and side-effect free. */
#ifndef MF_MATH_H
#define MF_MATH_H

#include <math.h>

#define MF_PI 3.14159265358979323846f
#define MF_INV_PI 0.31830988618379067154f
#define MF_INV_2PI 0.15915494309189533577f
#define MF_INV_4PI 0.07957747154594766788f
/* Largest world coordinate (camera position, mesh vertex) the renderer accepts, in absolute value.
 * Squares and squared distances of such coordinates stay finite in float (3 * (2e18)^2 < FLT_MAX),
 * and it is below Embree's own limit on ray origins (FLT_LARGE = 1.844e18: a ray from farther
 * aborts inside Embree with "Assertion ray.valid() failed"). Loaders refuse larger values by name. */
#define MF_COORD_MAX 1e18
/* Largest light strength, power, colour factor or scaled env radiance a scene file may give (the
 * same reasoning: its square stays finite in float); larger ones are refused by name instead of
 * ending in "texel not finite" or an all-NaN render. */
#define MF_STRENGTH_MAX 1e18

typedef struct { float x, y, z; } MfVec3;
typedef struct { float x, y; } MfVec2;
typedef struct { float m[16]; } MfMat4; /* row-major: m[r*4 + c] */
typedef struct { MfVec3 t, b, n; } MfFrame;

static inline MfVec3 mf_v3(float x, float y, float z) { MfVec3 v = {x, y, z}; return v; }
static inline MfVec3 mf_v3s(float s) { return mf_v3(s, s, s); }
static inline MfVec3 mf_add(MfVec3 a, MfVec3 b) { return mf_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline MfVec3 mf_sub(MfVec3 a, MfVec3 b) { return mf_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline MfVec3 mf_mul(MfVec3 a, MfVec3 b) { return mf_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline MfVec3 mf_scale(MfVec3 a, float s) { return mf_v3(a.x * s, a.y * s, a.z * s); }
static inline MfVec3 mf_madd(MfVec3 a, MfVec3 b, float s) { return mf_v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline float mf_dot(MfVec3 a, MfVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline MfVec3 mf_cross(MfVec3 a, MfVec3 b) {
    return mf_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float mf_len(MfVec3 a) { return sqrtf(mf_dot(a, a)); }
static inline MfVec3 mf_norm(MfVec3 a) {
    float l = mf_len(a);
    return l > 0.0f ? mf_scale(a, 1.0f / l) : a;
}
static inline MfVec3 mf_neg(MfVec3 a) { return mf_v3(-a.x, -a.y, -a.z); }
static inline MfVec3 mf_lerp3(MfVec3 a, MfVec3 b, float t) { return mf_add(mf_scale(a, 1.0f - t), mf_scale(b, t)); }
static inline float mf_maxc(MfVec3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }
static inline float mf_clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }
static inline float mf_lum(MfVec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
static inline MfVec3 mf_reflect(MfVec3 v, MfVec3 n) { return mf_sub(mf_scale(n, 2.0f * mf_dot(v, n)), v); }
static inline int mf_isfinite3(MfVec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Orthonormal basis around unit n (Duff et al., "Building an Orthonormal Basis, Revisited"). */
static inline MfFrame mf_frame(MfVec3 n) {
    float s = copysignf(1.0f, n.z);
    float a = -1.0f / (s + n.z), b = n.x * n.y * a;
    MfFrame f;
    f.t = mf_v3(1.0f + s * n.x * n.x * a, s * b, -s * n.x);
    f.b = mf_v3(b, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
static inline MfVec3 mf_to_local(const MfFrame *f, MfVec3 v) { return mf_v3(mf_dot(v, f->t), mf_dot(v, f->b), mf_dot(v, f->n)); }
static inline MfVec3 mf_to_world(const MfFrame *f, MfVec3 v) {
    return mf_add(mf_add(mf_scale(f->t, v.x), mf_scale(f->b, v.y)), mf_scale(f->n, v.z));
}

static inline MfMat4 mf_mat4_identity(void) {
    MfMat4 m = {{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}};
    return m;
}
static inline MfMat4 mf_mat4_mul(MfMat4 a, MfMat4 b) {
    MfMat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            float s = 0.0f;
            for (int k = 0; k < 4; ++k) s += a.m[i * 4 + k] * b.m[k * 4 + j];
            r.m[i * 4 + j] = s;
        }
    return r;
}
static inline MfVec3 mf_mat4_point(const MfMat4 *m, MfVec3 p) {
    const float *a = m->m;
    return mf_v3(a[0] * p.x + a[1] * p.y + a[2] * p.z + a[3], a[4] * p.x + a[5] * p.y + a[6] * p.z + a[7],
                 a[8] * p.x + a[9] * p.y + a[10] * p.z + a[11]);
}
static inline MfVec3 mf_mat4_dir(const MfMat4 *m, MfVec3 d) {
    const float *a = m->m;
    return mf_v3(a[0] * d.x + a[1] * d.y + a[2] * d.z, a[4] * d.x + a[5] * d.y + a[6] * d.z,
                 a[8] * d.x + a[9] * d.y + a[10] * d.z);
}
/* Rotation about +Z by angle (radians). */
static inline MfMat4 mf_mat4_rot_z(float a) {
    float c = cosf(a), s = sinf(a);
    MfMat4 m = {{c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}};
    return m;
}
/* Camera-to-world matrix (OpenGL camera axes: looks down -z, y up) for a camera at eye looking at
 * target with world up vector up. */
static inline MfMat4 mf_mat4_look_at(MfVec3 eye, MfVec3 target, MfVec3 up) {
    MfVec3 z = mf_norm(mf_sub(eye, target));
    MfVec3 x = mf_cross(up, z);
    if (mf_len(x) < 1e-6f) x = mf_cross(mf_v3(0, 1, 0), z);
    x = mf_norm(x);
    MfVec3 y = mf_cross(z, x);
    MfMat4 m = {{x.x, y.x, z.x, eye.x, x.y, y.y, z.y, eye.y, x.z, y.z, z.z, eye.z, 0, 0, 0, 1}};
    return m;
}

#endif
