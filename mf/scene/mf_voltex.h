/* mf_voltex: dense trilinear volume textures (issue 14 item 6).
 *
 * A volume texture stores C channels (kd: 3, ORM: 3) at the vertices of a res x res x res grid
 * spanning an axis-aligned box [lo, hi] (the object's box; default res 64). Vertex (i, j, k) sits
 * at lo + (hi - lo) * (i, j, k) / (res - 1). A world point p is looked up trilinearly from the 8
 * vertices of its cell.
 *
 * Stated difference from the paper: MaterialFusion (after nvdiffrec) stores materials in a
 * multi-resolution hash grid followed by a small MLP; we use this dense grid instead (64^3 x 3
 * floats = 3 MB per texture), which has an exact, cheap adjoint and no network.
 *
 * Out-of-box rule: each coordinate of a point is clamped to the box before the lookup, so a
 * point outside takes the value at the nearest point of the box; the derivative with respect to
 * a clamped coordinate is 0 (and a point on the box face gets the one-sided derivative of the
 * boundary cell).
 *
 * Regulariser: anisotropic total variation, Charbonnier-smoothed L1:
 *   TV = weight / N * sum over grid edges (a, b) along x, y, z and channels c of
 *        sqrt((g[a,c] - g[b,c])^2 + eps^2) - eps,
 * N = 3 (res - 1) res^2 C the number of terms, so TV is a mean per edge and channel and does not
 * grow with res. eps > 0 keeps the gradient finite at 0 differences (it is ~L1 for |d| >> eps and
 * ~d^2 / (2 eps) below). */
#ifndef MF_VOLTEX_H
#define MF_VOLTEX_H

#include <stddef.h>

#define MF_VOLTEX_DEFAULT_RES 64

typedef struct {
    int res;       /* vertices per axis, >= 2 */
    int c;         /* channels, >= 1 */
    float lo[3], hi[3]; /* the box, hi > lo on every axis */
    float *grid;   /* owned; (res, res, res, c), z slowest: ((k * res + j) * res + i) * c + ch */
} MfVoltex;

/* Allocates a grid of res^3 vertices with c channels over [lo, hi], every vertex set to fill
 * (c values; NULL: zeros). Fails with MF_EARG (res < 2, c < 1, an empty box axis) or MF_ENOMEM;
 * v is untouched on failure. */
int mf_voltex_init(MfVoltex *v, int res, int c, const float lo[3], const float hi[3], const float *fill);
void mf_voltex_free(MfVoltex *v);
/* Number of floats in the grid: res^3 * c. */
size_t mf_voltex_size(const MfVoltex *v);

/* out (n, c) = trilinear lookup at pts (n, 3) world points (clamped to the box). */
void mf_voltex_forward(const MfVoltex *v, const float *pts, int n, float *out);

/* Adjoint of mf_voltex_forward: given dout (n, c) = dL/dout, accumulates, when not NULL, dgrid
 * (res^3 * c) += dL/dgrid and dpts (n, 3) += dL/dpts (0 along clamped axes). Serial (a
 * scatter): deterministic. */
void mf_voltex_backward(const MfVoltex *v, const float *pts, int n, const float *dout, float *dgrid, float *dpts);

/* The TV regulariser above (eps > 0); when dgrid is not NULL, accumulates its gradient
 * dgrid (res^3 * c) +=. Returns the loss. */
double mf_voltex_tv(const MfVoltex *v, float eps, float weight, float *dgrid);

#endif
