/* mf_vhull: a soft visual hull on an mf_tetgrid grid from posed masks.
 *
 * For each grid vertex p: field(p) = min over views of (bilinear mask at the projection of p) - 0.5,
 * so field > 0 inside the hull (mf_tetgrid's sign) and the zero level set sits where the
 * silhouettes' alpha crosses 0.5. The mask is the view's last channel (alpha, coverage); bilinear
 * with pixel centres at (i + 0.5, j + 0.5), clamped to the edge pixels within the frame.
 * A view for which p is behind the camera or projects outside [0, w] x [0, h] carves it (-0.5)
 * when its mask lies wholly inside the frame (no border pixel with alpha >= 0.5: the object is
 * in view, so what the frame misses is not the object), and does not carve it when the mask
 * touches the border (a cut view says nothing about what it does not see). A vertex that no view
 * carves gets +0.5. Measured (`mf hull --eval`, Chamfer x1e3; `mf gen --split tiny --train 24
 * --width 40`, cameras 1.5-2 units away): with the framed views carving, cup 84.9 -> 2.3 and box
 * 102 -> 0.20 at 24 views, every object better at 8 views (vase 199 -> 1.4, torus 161 -> 0.71,
 * cup 108 -> 57); the same split at 2.2-2.8 units and test-3d unchanged but one (superquadric at
 * 8 views 75 -> 2.0). */
#ifndef MF_VHULL_H
#define MF_VHULL_H

#include "geom/mf_tetgrid.h"
#include "io/mf_image.h"
#include "scene/mf_camera.h"

/* cams: (n,); masks: (n,) images whose last channel is the mask (w, h matching each camera);
 * field: (mf_tetgrid_nverts(g),) output. Fails with MF_EARG naming the first view whose mask
 * size differs from its camera, or when n < 1. Parallel over grid slices; deterministic. */
int mf_vhull(const MfTetGrid *g, const MfCamera *cams, const MfImage *masks, int n, float *field);
/* Counts the views whose mask has alpha both below and above 0.5 into *masked (may be NULL);
 * MF_EARG naming the count when fewer than 3: too few to carve a hull or fit silhouettes. */
int mf_vhull_check_masks(const MfImage *masks, int n, int *masked);

/* The defaults of `mf hull` and of `mf recon --geometry vhull` (written once, here). */
#define MF_HULL_DEFAULT_RES 128
#define MF_HULL_DEFAULT_EXTENT 1.2
/* 400 Taubin iterations, not 10: relit +0.09 dB [+0.03, +0.15] over 18 validation scenes (val-3d,
 * val-3d-s3), from better silhouettes (mask IoU); docs/analyses/hull-smoothing.md. */
#define MF_HULL_DEFAULT_SMOOTH 400
#define MF_HULL_DEFAULT_TARGET_TRIS 40000
#define MF_HULL_DEFAULT_MIN_COMPONENT 0.01

typedef struct {
    int res;            /* grid cubes per axis (128: the setting for 128 px views) */
    float extent;       /* side of the grid cube centred at the origin, world units */
    int smooth_iters;   /* Taubin lambda 0.5 / mu -0.53 iterations (0: none) */
    int target_tris;    /* decimate to at most this many triangles (0: no decimation) */
    float min_component;/* drop components with fewer than this fraction of the largest's triangles */
    float vessel_wall;  /* > 0: carve an open vessel where the hull has an opening (mf_vessel), walls
                           this fraction of the hull's largest side thick; 0: the hull as the masks give it */
} MfHullOpts;

typedef struct {
    int masked_views;   /* views with both alpha < 0.5 and alpha >= 0.5 pixels */
    float extent;       /* grid side used (after enlarging once when the hull touched the border) */
    int touches_border; /* 1: the hull still touches the (enlarged) grid border: a warning was logged */
    int dropped_components;
    int extracted_tris; /* triangles before clean-up and decimation */
    int vessel_candidate; /* vessel_wall > 0: 1 when an opening was found and carved */
    size_t vessel_carved; /* its carved grid vertices */
} MfHullInfo;

/* The soft hull's field (mf_vhull) on a res^3 grid of side extent centred at the origin, into *grid
 * and *field (malloc'd, (mf_tetgrid_nverts(grid),), the caller frees it). When the hull touches the
 * grid's border (a border vertex inside and seen by at least one view: a vertex no view sees is
 * +0.5 but does not count, or a few one-sided views would always "touch"), the grid is enlarged
 * 1.5x once; when it still touches, *touches = 1 (may be NULL) and a warning says the hull is
 * cut there. MF_EARG on res < 1 or extent <= 0. The grid of mf_vhull_mesh and of mf recon --geometry dmtet. */
int mf_vhull_grid(const MfCamera *cams, const MfImage *masks, int n, int res, float extent, MfTetGrid *grid, float **field,
                  int *touches);
/* The hull as a clean mesh: refuses (MF_EARG, saying why) fewer than 3 masked views; builds the
 * field on the grid (mf_vhull_grid: enlarged 1.5x once when the hull touches its border),
 * extracts by marching tets (an empty hull is an error, never an empty mesh), welds, drops
 * degenerate triangles and small components, smooths, decimates (mf_meshproc); with
 * opt->vessel_wall > 0 the field is carved first where mf_vessel_axis finds an opening. */
int mf_vhull_mesh(const MfCamera *cams, const MfImage *masks, int n, const MfHullOpts *opt, MfMesh *out, MfHullInfo *info);
/* The clean-up half of mf_vhull_mesh, for any field on g (the hull's, or a fitted SDF): extracts
 * by marching tets (no deformation), welds, drops degenerate triangles and components under
 * opt->min_component, smooths and decimates as opt says; nothing left is an error. The triangle
 * count before clean-up and the dropped components go to *extracted_tris / *dropped, and the
 * Euler characteristic (V - E + F) after the clean-up, before smoothing and decimation, to *euler
 * (each may be NULL). */
int mf_vhull_extract_clean(const MfTetGrid *g, const float *field, const MfHullOpts *opt, MfMesh *out, int *extracted_tris,
                           int *dropped, long *euler);

#endif
