/* mf_rtscene: ray queries against a triangle mesh through Embree 3.
 *
 * One Embree device per scene, with rtcSetDeviceErrorFunction registered: Embree errors become
 * MF_EEXT failures (the message is kept per thread and returned by mf_error()). The mesh's
 * positions and triangles are copied into Embree buffers at creation; the MfMesh is borrowed for
 * normals, UVs and material ids and must outlive the scene.
 *
 * Hits (mf_rtscene_intersect) give the triangle id, barycentrics (b1, b2 of vertices 1 and 2),
 * the distance t along the (unit) ray direction, and the surface attributes at the hit:
 *   p   position (interpolated from the triangle, not org + t dir, for accuracy)
 *   perr  per-component error bound of p: gamma(7) (|b0 p0| + |b1 p1| + |b2 p2| + m), m the
 *       largest |coordinate| of the triangle's vertices (pbrt-v4's interpolation bound, plus a
 *       term for Embree's own plane test); rays leaving the hit start outside it
 *       (render/mf_estimator.h, mf_est_ray_origin). Proportional to the coordinates: scale-free.
 *   ng  geometric (face) normal, flipped to face the ray origin (dot(ng, dir) <= 0)
 *   ns  shading normal: interpolated vertex normals (face normal when the mesh has none),
 *       flipped together with ng so that both lie on the viewer's side; when the interpolated
 *       normal still faces away from the viewer (silhouettes of smooth meshes) it is bent
 *       toward the viewer just enough that dot(ns, -dir) >= 0.01.
 *   uv  interpolated texture coordinates ((0,0) when the mesh has none)
 *   mat material id (0 when the mesh has none)
 * The scene is built with RTC_SCENE_FLAG_ROBUST (watertight: rays do not slip between adjacent
 * triangles). Degenerate (zero-area) triangles are never reported as hits (zero determinant);
 * whenever a normal cannot be normalised the other one (or -dir) is used, so results stay
 * finite. */
#ifndef MF_RTSCENE_H
#define MF_RTSCENE_H

#include "core/mf_math.h"
#include "scene/mf_mesh.h"

typedef struct MfRtScene MfRtScene;

typedef struct {
    float t;      /* distance along dir (unit dir: world units) */
    int tri;      /* triangle index */
    float b1, b2; /* barycentrics of vertices 1 and 2 */
    MfVec3 p;     /* hit position */
    MfVec3 perr;  /* (>= 0) rounding-error bound of p, per component */
    MfVec3 ng;    /* unit geometric normal, facing the ray origin */
    MfVec3 ns;    /* unit shading normal, on the viewer's side */
    MfVec2 uv;
    int mat;
} MfHit;

/* Builds the BVH for `mesh` (borrowed; must outlive the scene). Fails with MF_EEXT on Embree
 * errors and MF_EARG on out-of-range indices. */
int mf_rtscene_new(const MfMesh *mesh, MfRtScene **out);
void mf_rtscene_free(MfRtScene *s);
/* The Embree RTCScene (as void * so callers need not include rtcore.h): for bare benchmarks. */
void *mf_rtscene_handle(const MfRtScene *s);
const MfMesh *mf_rtscene_mesh(const MfRtScene *s);

/* Closest hit along org + t dir, t in (tnear, tfar); dir unit. Returns 1 and fills *hit on a
 * hit, 0 on a miss (hit untouched). Thread-safe. */
int mf_rtscene_intersect(const MfRtScene *s, MfVec3 org, MfVec3 dir, float tnear, float tfar, MfHit *hit);
/* 1 if anything blocks org + t dir for t in (tnear, tfar). Thread-safe. */
int mf_rtscene_occluded(const MfRtScene *s, MfVec3 org, MfVec3 dir, float tnear, float tfar);
/* mf_rtscene_occluded for n rays at once: occ[i] = 1 if org[i] + t dir[i] is blocked for t in
 * (0, tfar). Traced in 16-wide Embree packets (rays from one shading point share an
 * origin, so a packet's rays mostly visit the same nodes: measured 1.8x the rays/s of
 * rtcOccluded1 in `mf bench-render`); the answers are those of mf_rtscene_occluded.
 * org, dir, occ: (n,). Thread-safe. */
void mf_rtscene_occluded_n(const MfRtScene *s, int n, const MfVec3 *org, const MfVec3 *dir, float tfar,
                           unsigned char *occ);

#endif
