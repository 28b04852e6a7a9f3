/* mf_vhull: a soft visual hull on an mf_tetgrid grid from posed masks.
 *
 * For each grid vertex p: field(p) = min over views of (bilinear mask at the projection of p) - 0.5,
 * so field > 0 inside the hull (mf_tetgrid's sign) and the zero level set sits where the
 * silhouettes' alpha crosses 0.5. The mask is the view's last channel (alpha, coverage); bilinear
 * with pixel centres at (i + 0.5, j + 0.5), clamped to the edge pixels within the frame.
 * A view for which p is behind the camera or projects outside [0, w] x [0, h] does not carve
 * (a partly cut view says nothing about what it does not see). A vertex no view sees gets +0.5. */
#ifndef MF_VHULL_H
#define MF_VHULL_H

#include "geom/mf_tetgrid.h"
#include "io/mf_image.h"
#include "scene/mf_camera.h"

/* cams: (n,); masks: (n,) images whose last channel is the mask (w, h matching each camera);
 * field: (mf_tetgrid_nverts(g),) output. Fails with MF_EARG naming the first view whose mask
 * size differs from its camera, or when n < 1. Parallel over grid slices; deterministic. */
int mf_vhull(const MfTetGrid *g, const MfCamera *cams, const MfImage *masks, int n, float *field);

#endif
