/* mf_chartpack: packs UV charts by their rasterised shapes, not their bounding rectangles
 * (issue 14 item 8; used by mf_uvatlas).
 *
 * On a grid of P = min(res, 512) texels per side, each chart is rasterised conservatively (every
 * texel its triangles touch) at a common scale s (grid texels per chart unit), in each of the four
 * quarter-turn rotations. Charts are placed one by one, largest area first, on a skyline (the
 * first free row of every grid column): a chart's dilated bottom profile (its cells grown by
 * ceil(gutter P / res) texels in x and y) must stay above the skyline, and the position and
 * rotation chosen are those with the lowest chart bottom (or, in a second pass tried when the
 * first does not fit, the lowest chart top), ties broken by the least area left under the
 * chart, then by x and by rotation. Texels under an overhang are lost (no holes are
 * filled), but ragged charts interlock where rectangles cannot. The scale is the largest that fits
 * in [gutter, 1 - gutter]^2 found by bisection (7 steps after walking down from the area bound
 * to the first scale that fits). stretch 1 then scales the layout along u and v separately to span the square
 * (gaps only grow). Charts never share a texel of the grid and are at least the gutter apart, so
 * their UV triangles cannot overlap. Deterministic (charts are rasterised in parallel, placed one by one). */
#ifndef MF_CHARTPACK_H
#define MF_CHARTPACK_H

typedef struct {
    const double *uv; /* (nv, 2) chart-local UVs in [0, w] x [0, h] */
    const int *tri;   /* (nt, 3) indices into uv */
    int nv, nt;
    double w, h;      /* the chart's extent */
    double area;      /* its UV area (the packing order) */
} MfChartShape;

typedef struct {
    int rot;               /* quarter turns counter-clockwise applied to the chart-local UVs:
                              0: (u, v), 1: (h - v, u), 2: (w - u, h - v), 3: (v, w - u) */
    double x0, y0, sx, sy; /* the turned point r maps to (x0 + sx r.x, y0 + sy r.y) in [0,1]^2 */
} MfChartPlace;

/* The rotated point r of chart-local (u, v) for a chart of extent (w, h) (MfChartPlace.rot). */
void mf_chartpack_turn(int rot, double w, double h, double u, double v, double *rx, double *ry);

/* Packs the n charts into [0,1]^2 for a res x res texture with `gutter` texels between charts and
 * from the border; writes place (n,) and returns MF_OK, or returns 1 (place untouched) when the
 * charts do not fit at any scale tried (too many for the grid: the caller falls back to rectangle
 * packing), or MF_ENOMEM. scale_out (may be NULL): the grid texels per chart unit chosen. */
int mf_chartpack(const MfChartShape *ch, int n, int res, float gutter, int stretch, MfChartPlace *place, double *scale_out);

#endif
