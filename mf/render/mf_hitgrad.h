/* mf_hitgrad: adjoint of a ray hit's surface attributes with respect to the mesh's vertices.
 *
 * A hit (mf_rtscene_intersect) of the ray org + t dir on triangle (p0, p1, p2) has barycentrics
 * (b1, b2) = ([s, d, e2], [d, s, e1]) / [e1, d, e2] (Moller-Trumbore: s = org - p0, e1 = p1 - p0,
 * e2 = p2 - p0, [a, b, c] = a.(b x c)), i.e. the ray-plane intersection expressed in the
 * triangle; moving the vertices moves the hit across the surface, so the interpolated UV (and
 * the textures looked up there) and the interpolated shading normal change. mf_hit_backward
 * maps dLoss/d(uv), dLoss/d(hit position p, world: p = sum b_i p_i is the point on the ray, so
 * it moves along the ray; volume textures are looked up there) and dLoss/d(unit shading normal
 * ns, world) of one hit to the vertices:
 *   dpos (nv, 3) += through the barycentrics, and for meshes without normals through the face
 *                   normal (ns = the flipped unit face normal);
 *   dnrm (nv, 3) += dLoss/d(vertex normals), through ns = flip * normalize(sum b_i n_i); chain it
 *                   with mf_mesh_normals_backward when the normals are mf_mesh_compute_normals'.
 * The normal's side flip is a constant; a shading normal that mf_rtscene bent toward the viewer
 * (silhouettes of smooth meshes) passes no normal gradient. Degenerate triangles pass nothing.
 * Not thread-safe on dpos / dnrm: callers accumulate per thread and reduce. */
#ifndef MF_HITGRAD_H
#define MF_HITGRAD_H

#include "render/mf_rtscene.h"

void mf_hit_backward(const MfMesh *m, const MfHit *h, MfVec3 org, MfVec3 dir, MfVec2 duv, MfVec3 dp, MfVec3 dns,
                     float *dpos, float *dnrm);

#endif
