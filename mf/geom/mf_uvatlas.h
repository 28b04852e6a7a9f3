/* mf_uvatlas: our own UV unwrapper (issue 14 item 8): charts, LSCM, packing.
 *
 * 1. Charts grow by region from seeds in triangle order, nearest first (centroid-path distance):
 *    a neighbour (across an edge used by exactly two triangles; vertices at equal positions are
 *    one vertex) joins when its normal is within max_angle_deg of the chart's area-weighted mean
 *    normal and the chart stays a disc (it shares one edge and its third vertex is new); one
 *    sharing two edges fills a notch and joins whatever its normal. Each chart is then checked:
 *    one boundary loop, Euler characteristic 1.
 * 2. Each chart is parameterised by least-squares conformal maps (Levy et al. 2002) with two
 *    pinned vertices far apart, solved by Jacobi-preconditioned conjugate gradients on the normal
 *    equations (CGLS, a CSR matrix, double precision, relative tolerance 1e-4), started from the
 *    projection onto the chart's mean plane. Growth stops a chart at max_chart_tris, which keeps
 *    CG fast (its iterations grow with the chart's size).
 * 3. A chart that fails the topology check, has a triangle of UV area <= 1e-7 of its squared
 *    extent (so float UVs stay positive), or whose boundary crosses itself in UV (with all
 *    triangles positive this is the only way a disc overlaps itself) is split in two (two
 *    far-apart seed triangles, breadth-first growth from both) and solved again; this ends at
 *    single triangles at worst (MfUvAtlasInfo.forced_single).
 * 4. Each chart is scaled to its 3D area, rotated to its minimum-area bounding rectangle (over
 *    its convex hull's edge directions; wider than tall), stretched across to an aspect of at
 *    least 1:64 when thinner (slivers: so float UVs keep a positive area), and packed by its
 *    rasterised shape (mf_chartpack: skyline, four quarter turns, half-texel grid) into [0,1]^2
 *    with `gutter` texels of a tex_res texture between charts. If that fails (too many charts
 *    for the grid) or a triangle's float UV area comes out <= 0, the charts' bounding rectangles
 *    are shelf-packed instead (mf_pack), as before.
 *
 * The output has one vertex per chart and input vertex (input vertices at the same position with
 * the same normal count as one), so seams split vertices; triangles keep their order, normals and
 * material ids. Deterministic (charts are solved in parallel but independently; splitting is
 * serial). */
#ifndef MF_UVATLAS_H
#define MF_UVATLAS_H

#include "scene/mf_mesh.h"

typedef struct {
    int tex_res;         /* texture side the gutter is counted in (256) */
    float gutter;        /* texels between charts and from the border (2) */
    float max_angle_deg; /* region growing: normal cone half-angle (60) */
    int max_chart_tris;  /* region growing stops a chart at this many triangles (2000) */
    int stretch;         /* 1: stretch the packed layout along u and v separately to fill the square */
} MfUvAtlasOpts;

typedef struct {
    int charts;          /* final charts */
    int grown;           /* charts from region growing, before splits */
    int split_topology;  /* splits because a chart was not a disc */
    int split_flip;      /* splits because of a triangle with UV area <= 0 */
    int split_overlap;   /* splits because a chart's UV boundary crossed itself */
    int forced_single;   /* single-triangle charts made by splitting (last resort) */
    int cg_iters_max;    /* most CG iterations of one chart */
    int packed_shapes;   /* 1: charts packed by their shapes (mf_chartpack); 0: by rectangles on shelves */
} MfUvAtlasInfo;

MfUvAtlasOpts mf_uvatlas_defaults(void);

/* Unwraps in (positions and triangles; normals, material ids copied) into *out (freshly
 * allocated, uv set). info may be NULL. Empty mesh or non-finite positions: MF_EARG / MF_ENAN. */
int mf_uvatlas(const MfMesh *in, const MfUvAtlasOpts *opts, MfMesh *out, MfUvAtlasInfo *info);

typedef struct {
    int res;              /* grid side */
    int charts;           /* connected components of triangles sharing vertices */
    long covered;         /* texel centres inside a triangle */
    long overlap_same;    /* texel centres covered again by a triangle of the same chart */
    long overlap_other;   /* texel centres covered again by a triangle of another chart */
    int flipped;          /* triangles of UV area <= 0 */
    int outside;          /* triangles with a UV outside [0,1]^2 */
    double coverage;      /* covered / res^2 */
} MfUvCheck;

/* Rasterises m's UV triangles at the texel centres of a res x res grid (top-left tie rule, so
 * a centre on a shared edge counts once), recording an owner triangle per texel; charts are the
 * components of triangles sharing vertices (seams split vertices). Flipped triangles are
 * rasterised too (then they show up as overlaps as well). Needs m->uv. */
int mf_uv_check(const MfMesh *m, int res, MfUvCheck *out);

#endif
