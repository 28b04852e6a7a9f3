/* mf_pack: shelf packing (moved from datasets/ds_shapes.c; same arithmetic, so the generated
 * data sets keep their bytes). */
#include "geom/mf_pack.h"

#include <math.h>
#include <stdlib.h>

#include "core/mf_error.h"

typedef struct {
    float h;
    int i;
} HeightKey;

static int height_desc(const void *pa, const void *pb) {
    const HeightKey *a = pa, *b = pb;
    if (a->h != b->h) return a->h > b->h ? -1 : 1;
    return (a->i > b->i) - (a->i < b->i);
}

int mf_pack_order_by_height(const float *size, int n, int *order) {
    HeightKey *k = malloc((size_t)n * sizeof *k + 1);
    if (!k) return mf_fail(MF_ENOMEM, "out of memory for packing");
    for (int i = 0; i < n; ++i) k[i] = (HeightKey){size[2 * i + 1], i};
    qsort(k, (size_t)n, sizeof *k, height_desc);
    for (int i = 0; i < n; ++i) order[i] = k[i].i;
    free(k);
    return MF_OK;
}

/* Shelf packing at scale s with spacing pad; returns 1 if everything fits in [0,1]^2. */
static int shelf_pack(const float *size, const int *order, int n, float s, float pad, float minsz, MfPackRect *out) {
    float x = pad, y = pad, shelf_h = 0.0f;
    for (int k = 0; k < n; ++k) {
        const float *sz = size + 2 * order[k];
        float w = fmaxf(sz[0] * s, minsz), h = fmaxf(sz[1] * s, minsz);
        if (x + w + pad > 1.0f) { /* new shelf */
            x = pad;
            y += shelf_h + pad;
            shelf_h = 0.0f;
        }
        if (x + w + pad > 1.0f || y + h + pad > 1.0f) return 0;
        if (out) out[order[k]] = (MfPackRect){x, y, w, h};
        x += w + pad;
        if (h > shelf_h) shelf_h = h;
    }
    return 1;
}

float mf_pack_shelves(const float *size, const int *order, int n, float pad, float minsz, int stretch, MfPackRect *out) {
    while (!shelf_pack(size, order, n, 0.0f, pad, minsz, NULL) && minsz > 1e-6f) {
        minsz *= 0.5f;
        pad *= 0.5f;
    }
    float lo = 0.0f, hi = 1.0f;
    if (n <= 0) return 0.0f;
    while (hi < 1e30f && shelf_pack(size, order, n, hi, pad, minsz, NULL)) hi *= 2.0f;
    for (int it = 0; it < 40; ++it) {
        float mid = 0.5f * (lo + hi);
        if (shelf_pack(size, order, n, mid, pad, minsz, NULL)) lo = mid; else hi = mid;
    }
    shelf_pack(size, order, n, lo, pad, minsz, out);
    if (!stretch) return lo;
    float mx = 0.0f, my = 0.0f;
    for (int k = 0; k < n; ++k) {
        mx = fmaxf(mx, out[k].x0 + out[k].w);
        my = fmaxf(my, out[k].y0 + out[k].h);
    }
    float sx = mx > pad ? (1.0f - 2.0f * pad) / (mx - pad) : 1.0f, sy = my > pad ? (1.0f - 2.0f * pad) / (my - pad) : 1.0f;
    if (sx < 1.0f) sx = 1.0f;
    if (sy < 1.0f) sy = 1.0f;
    for (int k = 0; k < n; ++k) {
        MfPackRect *r = &out[k];
        r->x0 = pad + (r->x0 - pad) * sx;
        r->w *= sx;
        r->y0 = pad + (r->y0 - pad) * sy;
        r->h *= sy;
    }
    return lo;
}
