/* mf_tangent: per-vertex tangent frames from UVs, for tangent-space normal maps.
 *
 * Convention (glTF 2.0 / OpenGL "Y+" normal maps): a normal-map texel v in [0,1]^3 encodes the
 * tangent-space normal n_t = 2 v - 1, and the shading normal is normalize(T x + B y + N z) with
 *   T  the tangent, direction of increasing U on the surface,
 *   B  = w cross(N, T), w = +-1 the handedness, pointing in the direction of increasing V in our
 *      UV convention (mf_mesh.h: v up, v = 0 at the texture's bottom row), i.e. toward the TOP
 *      of the texture image (row 0). That is glTF's "+Y is up" in the image: glTF stores
 *      v_gltf = 1 - v (origin at the top-left) and its bitangent points to decreasing v_gltf,
 *      the same surface direction. The flat texel is (0.5, 0.5, 1).
 *   N  the vertex (or interpolated shading) normal.
 * Tangents: per triangle, dP/du and dP/dv from its UV parametrisation (Lengyel), each
 * normalised and weighted by the triangle's area, summed per vertex; then Gram-Schmidt against
 * the vertex normal (area-weighted face normals when the mesh has none), w = sign of
 * dot(cross(N, T), sum dP/dv). Triangles with degenerate UVs (zero UV area) or zero area add
 * nothing; a vertex left without a usable tangent gets an arbitrary orthonormal one (mf_frame)
 * with w = +1, so the result is always finite. This is close to, but not bit-for-bit, MikkTSpace
 * (what glTF viewers derive when a file carries no TANGENT attribute); on smooth, consistently
 * unwrapped meshes the two agree up to interpolation details. */
#ifndef MF_TANGENT_H
#define MF_TANGENT_H

#include "scene/mf_mesh.h"

/* tan: (nv, 4) out, caller-allocated: unit tangent xyz and handedness w = +-1.
 * Fails (MF_EARG) when the mesh has no UVs. */
int mf_mesh_tangents(const MfMesh *m, float *tan);

#endif
