/* mf_pack: shelf packing of rectangles into the unit square (texture atlases).
 *
 * Shared by the procedural objects' atlases (datasets/ds_shapes.c) and the UV unwrapper
 * (mf_uvatlas). Deterministic; single-threaded. */
#ifndef MF_PACK_H
#define MF_PACK_H

typedef struct {
    float x0, y0, w, h; /* placed rectangle in [0,1]^2 (lower-left corner, size) */
} MfPackRect;

/* order (n,): rectangle indices by height descending, ties by index (a stable sort).
 * size (n, 2): width, height. Returns MF_OK or MF_ENOMEM. */
int mf_pack_order_by_height(const float *size, int n, int *order);

/* Packs n rectangles of size (n, 2) (any common unit) into [0,1]^2 on shelves (left to right,
 * shelves bottom to top) in `order` (n,), at the largest uniform scale s found by bisection
 * (40 steps); each side is at least minsz, and pad separates rectangles from each other and
 * from the border. When even scale 0 does not fit (the minimum sizes and spacing), both are
 * halved until it does. stretch 1 then stretches the layout along x and y separately so that it
 * spans [pad, 1 - pad] (gaps only grow; rectangles change aspect). out (n,): the rectangles.
 * Returns the scale s. */
float mf_pack_shelves(const float *size, const int *order, int n, float pad, float minsz, int stretch, MfPackRect *out);

#endif
