/* mf_vessel: the open-vessel hypothesis for a visual hull.
 *
 * Silhouettes cannot carve a cavity: the visual hull of a cup, bowl or mug is closed by a flat cap
 * at its rim. This module states the other hypothesis explicitly: the object is a vessel open on
 * the cap's side, with walls of a given thickness. mf_vessel_axis finds a candidate opening (a
 * large flat top facing the cameras); mf_vessel_carve removes, from a hull field on an mf_tetgrid
 * grid, every inside vertex farther than the wall thickness from the hull's outside below the cap,
 * connected to the cap. Whether the carved hull is the better one is for the images to say
 * (mf recon --vessel auto compares the two fits, mf_recon_geom.h); neither function decides it. */
#ifndef MF_VESSEL_H
#define MF_VESSEL_H

#include <stddef.h>

#include "geom/mf_tetgrid.h"
#include "scene/mf_camera.h"

/* Defaults (written once, here): the wall thickness as a fraction of the hull's largest side (0.03:
 * the generated cups' and mugs' walls, 0.035 of a side about 1.1; a bowl's are thinner), the
 * smallest cap (its area over the hull's cross-section across the axis) and the largest tilt of
 * the fitted cap from the cameras' mean direction. */
#define MF_VESSEL_DEFAULT_WALL 0.03f
#define MF_VESSEL_MIN_CAP 0.25f
#define MF_VESSEL_MAX_TILT_DEG 30.0f
/* mf recon --vessel auto keeps the open mesh only when its trial fit's held-out PSNR beats the
 * closed one's by more than this (dB): without clear evidence, the hull the masks give is kept. */
#define MF_VESSEL_MARGIN_DB 0.1

typedef enum { MF_VESSEL_AUTO, MF_VESSEL_OPEN, MF_VESSEL_CLOSED } MfVesselMode;
#define MF_VESSEL_MODES "auto|open|closed"

typedef struct {
    MfVec3 axis;     /* unit normal of the cap, pointing out of the opening */
    float cap_frac;  /* cap area / the hull's cross-section area across axis */
    float tilt_deg;  /* angle between axis and the cameras' mean direction */
    int candidate;   /* 1: a cap large and flat enough, facing the cameras (axis is set) */
} MfVesselAxis;

/* field: (mf_tetgrid_nverts(g),), > 0 inside (mf_vhull's). cams: (n,). Finds the cameras' mean
 * direction from the hull's centroid (none when the cameras surround the object evenly: no
 * candidate), fits a plane (PCA, GSL) to the hull's boundary vertices near its top along that
 * direction, again along the fitted normal until it moves by less than 0.1 deg (at most 10 fits),
 * and measures the cap. MF_EARG on an empty field. */
int mf_vessel_axis(const MfTetGrid *g, const float *field, const MfCamera *cams, int n, MfVesselAxis *out);

/* Walls, in cells: a wall thinner than MF_VESSEL_MIN_CELLS would carve every inside vertex (each
 * is a cell or more from the outside). mf recon --vessel auto also tries walls of
 * MF_VESSEL_THICK_CELLS when the stated fraction gives fewer, but not more than
 * MF_VESSEL_THICK_MAX_X times as many: at DMTet's former 64^3, after the extracted mesh's smoothing, the
 * stated 1.6-cell walls lost 9 of 13 validation vessels' trials to the closed mesh and all 13 to
 * 3-cell walls, while at 32^3, where the stated wall is 0.8 cells, 3 cells are far thicker than
 * the object's walls (the CI cup's Chamfer 0.26 -> 1.30; docs/analyses/vessel.md). DMTet from the
 * hull (mf recon --dmtet-init hull, the default) carves the hull on its own grid instead. */
#define MF_VESSEL_MIN_CELLS 1.5f
#define MF_VESSEL_THICK_CELLS 3.0f
#define MF_VESSEL_THICK_MAX_X 2.0f

/* A carved mesh whose Euler characteristic (V - E + F) lies more than this below the closed
 * mesh's has walls that broke through (each hole through a wall adds a handle, -2): mf recon
 * --vessel auto does not try it. A carve may open a handle's loop or a small tunnel; walls thinner
 * than the grid resolves lose far more: DMTet's 1.6-cell walls at 64^3 dropped it by 98 to 480 on
 * all 18 validation scenes carved, its 3-cell walls moved it by -2 to +7 (docs/analyses/vessel.md). */
#define MF_VESSEL_MAX_EULER_DROP 4

/* The wall for wall_frac, in cells of g: wall_frac x the largest side of the bounding box of
 * field's inside vertices, at least min_cells (also on an empty field). */
float mf_vessel_wall_cells(const MfTetGrid *g, const float *field, float wall_frac, float min_cells);

/* Carves field in place: inside vertices whose Euclidean distance (exact, separable transform) to
 * the nearest outside vertex lying more than 1.5 cells below the top along axis exceeds wall_cells
 * cells, and which connect (6-neighbours) to the top, are set to the field's smallest value
 * (mf_vhull's -0.5, or a fitted SDF's most outside). *carved (may be NULL): their count. MF_EARG on
 * wall_cells < MF_VESSEL_MIN_CELLS or an empty field; MF_ENOMEM. */
int mf_vessel_carve(const MfTetGrid *g, float *field, MfVec3 axis, float wall_cells, size_t *carved);

/* Both: finds the opening (mf_vessel_axis, into *axis) and, when it is a candidate, carves field
 * (mf_vessel_carve, walls mf_vessel_wall_cells(wall_frac, MF_VESSEL_MIN_CELLS); *carved, may be
 * NULL, is 0 otherwise): mf hull --vessel open (mf_vhull). mf recon --vessel calls the two itself,
 * to carve more than one wall (mf_recon_geom.c). */
int mf_vessel_open(const MfTetGrid *g, float *field, const MfCamera *cams, int n, float wall_frac, MfVesselAxis *axis, size_t *carved);

#endif
