/* mf_shapes: procedural meshes for tests, benchmarks and examples.
 *
 * UV sphere: `seg` segments around +Z and `rings` rings from the north pole (+Z) to the south
 * pole, exact unit normals, UVs u = azimuth / 2pi (seam duplicated), v = 1 - polar / pi;
 * 2 seg (rings - 1) triangles (pole rows are single triangles), like Blender's UV sphere.
 * Torus: around +Z, major radius R, minor radius r, `nu` x `nv` quads split into triangles,
 * exact normals, UVs over [0,1]^2. Both are wound counter-clockwise seen from outside. */
#ifndef MF_SHAPES_H
#define MF_SHAPES_H

#include "core/mf_math.h"
#include "scene/mf_mesh.h"

int mf_shape_uv_sphere(MfMesh *out, MfVec3 center, float radius, int seg, int rings);
int mf_shape_torus(MfMesh *out, float R, float r, int nu, int nv);

#endif
