/* mf_normalmap: shading normals from a tangent-space normal map at a ray hit, and the adjoint.
 *
 * Convention: scene/mf_tangent.h (glTF / OpenGL Y+: texel v in [0,1]^3, n_t = 2 v - 1, T along
 * increasing U, B = w cross(N, T) along increasing V = toward the image's top row; the flat
 * texel (0.5, 0.5, 1) leaves the normal unchanged up to rounding).
 * At a hit (render/mf_rtscene.h), the frame is built from the interpolated vertex tangents
 * (tan (nv, 4) from mf_mesh_tangents), Gram-Schmidt against the hit's shading normal N (its
 * side as the mesh defines it: when the hit's normals were flipped toward the viewer, the
 * computed normal is flipped back, so a map describes the same relief seen from either side),
 *   n = side * normalize(T x + B y + N z),  (x, y, z) = 2 bilinear(map, uv) - 1  (repeat wrap),
 * then, like the hit's own shading normal, bent toward the viewer just enough that
 * dot(n, wo) >= 0.01. Shadow-ray offsets keep using the geometric normal (callers' business).
 * The backward pass is the exact derivative of this map from texels to n (bilinear lookup,
 * normalisation, bend), accumulated (+=) into a texel gradient; the degenerate fallbacks (a zero
 * vector, a non-finite bend) pass no gradient. */
#ifndef MF_NORMALMAP_H
#define MF_NORMALMAP_H

#include "io/mf_image.h"
#include "render/mf_rtscene.h"

typedef struct {
    MfVec3 t, b, n; /* world tangent frame (unit, orthonormal); n = side * the hit's ns */
    float side;     /* +1, or -1 where the hit's normals face against the triangle's winding */
    MfVec3 ns;      /* the hit's shading normal (fallback) */
} MfNmapFrame;

/* mesh: the hit's mesh (with UVs); tan (nv, 4) from mf_mesh_tangents. */
MfNmapFrame mf_nmap_frame(const MfMesh *mesh, const float *tan, const MfHit *h);
/* Shading normal from map (h, w, >= 3) at uv, viewed from wo (unit, toward the viewer). */
MfVec3 mf_nmap_normal(const MfNmapFrame *f, const MfImage *map, MfVec2 uv, MfVec3 wo);
/* Adjoint of mf_nmap_normal: dmap (h, w, map->c) += d n / d texels ^T dn. Not thread-safe on dmap. */
void mf_nmap_normal_backward(const MfNmapFrame *f, const MfImage *map, MfVec2 uv, MfVec3 wo, MfVec3 dn, float *dmap);

#endif
