/* mf_bake: UV texture baking (issue 14 item 9).
 *
 * Texel (x, y) of a res x res texture has its centre at UV ((x + 0.5) / res, 1 - (y + 0.5) / res)
 * (row 0 is the top, v = 1: mf_mesh's UV convention). Baking has three steps, each its own call:
 *   1. mf_bake_raster: which triangle covers each texel centre and where (barycentrics), from the
 *      triangles' UV footprints. Serial and deterministic: where footprints share an edge the
 *      later triangle wins. Triangles with a degenerate UV footprint are skipped.
 *   2. the caller evaluates its material at the 3D surface point of every covered texel
 *      (mf_bake_point; mf_bake_volume does this for volume textures);
 *   3. mf_bake_gutter: dilation into the empty texels around the charts, `gutter` rings, each
 *      empty texel with at least one filled 8-neighbour taking the mean of those neighbours
 *      (neighbours filled by the previous rings count, the current ring's do not); texels still
 *      empty afterwards take the mean of the covered texels (or a given default when none is).
 * datasets/ds_shapes.c bakes its procedural materials with steps 1 and 3. */
#ifndef MF_BAKE_H
#define MF_BAKE_H

#include "scene/mf_voltex.h"
#include "io/mf_image.h"
#include "scene/mf_mesh.h"

/* tid (res * res,): covering triangle or -1; bary (res * res, 2): barycentrics (b1, b2) of the
 * texel centre in that triangle (b0 = 1 - b1 - b2). Fails with MF_EARG when m has no UVs. */
int mf_bake_raster(const MfMesh *m, int res, int *tid, float *bary);

/* The surface point p (3,) of texel i of a raster, and the interpolated vertex normal n (3,)
 * (unnormalised; zeros when m has no normals). tid[i] must be >= 0. */
void mf_bake_point(const MfMesh *m, const int *tid, const float *bary, size_t i, float p[3], float n[3]);

/* Gutter dilation of img (res, res, c) in place, coverage from tid (res * res,) of mf_bake_raster;
 * fill (c,) is the value of every texel when nothing is covered. */
int mf_bake_gutter(float *img, int res, int c, const int *tid, int gutter, const float *fill);

/* Bakes the volume texture vol (c channels) onto m's UV layout: a (res, res, vol->c) image
 * (allocated into out) with gutter rings of dilation (zeros everywhere when no texel is covered).
 * Fails (out untouched) when m has no UVs. */
int mf_bake_volume(const MfMesh *m, const MfVoltex *vol, int res, int gutter, MfImage *out);

#endif
