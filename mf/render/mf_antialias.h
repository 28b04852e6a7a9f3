/* mf_antialias: analytic antialiasing of a pixel-centre primary pass, with its adjoint to the
 * image and to the vertex positions (nvdiffrast's antialias operation: Laine et al. 2020,
 * "Modular Primitives for High-Performance Differentiable Rendering", section 3.4; our own code).
 *
 * mf_aa_new traces one ray through each pixel centre (x + 0.5, y + 0.5) and keeps a G-buffer of
 * triangle id (-1: background) and camera depth. For every horizontally or vertically
 * neighbouring pixel pair (A, B) on different triangles (or one on the background), the nearer
 * surface's pixel (A) is the occluder; an edge of A's triangle that is a silhouette in screen
 * space (a boundary edge, a non-manifold edge, or an edge whose neighbour triangle folds to the
 * same side of it as A's triangle) and whose projected segment crosses the line between the two
 * pixel centres, at distance t in [0, 1] from A's centre (when none does, the same is tried on
 * the triangles across A's triangle's edges: the line may leave it through an edge shared with
 * the same surface, near a quad's corner), blends them as a one-dimensional box filter would:
 *   t > 1/2:  B += (t - 1/2) (A - B)        (A's surface reaches into B's footprint)
 *   t < 1/2:  A += (1/2 - t) (B - A)        (A's footprint is partly uncovered)
 * Horizontal pairs take edges at least as steep as 45 degrees (|dy| >= |dx| on screen),
 * vertical pairs the others, so a straight edge is counted once along its length (then
 * d(sum of coverage)/d(normal offset) = its length in pixels). All deltas are taken from the
 * input image (pairs are independent). Inner occlusion edges (a cup's rim) are silhouettes of
 * the nearer triangle and are handled alike; shared edges between front-facing neighbours are
 * not. Adds no shading; deterministic (pairs are scanned in a fixed order, serially).
 *
 * The crossing geometry depends only on the mesh and the camera: mf_aa_new finds it once (the
 * mesh is borrowed and its positions must not change until the last mf_aa_backward);
 * forward/backward then blend any image of c channels (rgb, alpha, AOVs). */
#ifndef MF_ANTIALIAS_H
#define MF_ANTIALIAS_H

#include "render/mf_rtscene.h"
#include "scene/mf_camera.h"

typedef struct MfAa MfAa;

/* G-buffer, topology and the crossings of rt's mesh seen by cam. */
int mf_aa_new(const MfRtScene *rt, const MfCamera *cam, MfAa **out);
/* The same from a given G-buffer (tri (h, w), -1 background; depth (h, w)) of mesh m (borrowed):
 * a pass whose hits are known, or a gradient check that moves the vertices but keeps the
 * pixel-centre hits (they change only when an edge crosses a pixel centre). */
int mf_aa_new_gbuffer(const MfMesh *m, const MfCamera *cam, const int *tri, const float *depth, MfAa **out);
void mf_aa_free(MfAa *a);
/* Number of blended pixel pairs. */
int mf_aa_count(const MfAa *a);
/* The G-buffer: (h, w) triangle ids (-1 background) and camera depths (0 on the background). */
const int *mf_aa_tri(const MfAa *a);
const float *mf_aa_depth(const MfAa *a);
/* out (h, w, c) = the antialiased in (h, w, c); out != in. */
void mf_aa_forward(const MfAa *a, const float *in, int c, float *out);
/* Adjoint: din (h, w, c) += dLoss/d in, dpos (nv, 3) += dLoss/d vertex positions (either may be
 * NULL), given in (h, w, c) and dout (h, w, c). */
void mf_aa_backward(const MfAa *a, const float *in, int c, const float *dout, float *din, float *dpos);

#endif
