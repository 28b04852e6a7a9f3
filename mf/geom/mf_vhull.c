#include "geom/mf_vhull.h"

#include <math.h>

#include "core/mf_error.h"

/* Bilinear mask (last channel) at continuous pixel position (px, py) inside [0, w] x [0, h]. */
static float mask_at(const MfImage *m, float px, float py) {
    float x = px - 0.5f, y = py - 0.5f;
    int x0 = (int)floorf(x), y0 = (int)floorf(y);
    float fx = x - (float)x0, fy = y - (float)y0;
    int x1 = x0 + 1, y1 = y0 + 1;
    x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0;
    x1 = x1 >= m->w ? m->w - 1 : x1, y1 = y1 >= m->h ? m->h - 1 : y1;
    int c = m->c - 1;
    float a00 = mf_image_px(m, x0, y0)[c], a10 = mf_image_px(m, x1, y0)[c];
    float a01 = mf_image_px(m, x0, y1)[c], a11 = mf_image_px(m, x1, y1)[c];
    return (1 - fy) * ((1 - fx) * a00 + fx * a10) + fy * ((1 - fx) * a01 + fx * a11);
}

int mf_vhull(const MfTetGrid *g, const MfCamera *cams, const MfImage *masks, int n, float *field) {
    if (n < 1) return mf_fail(MF_EARG, "visual hull: no views");
    for (int v = 0; v < n; ++v)
        if (masks[v].w != cams[v].w || masks[v].h != cams[v].h || masks[v].c < 1 || !masks[v].data)
            return mf_fail(MF_EARG, "visual hull: view %d: mask is %dx%d, its camera %dx%d", v, masks[v].w, masks[v].h,
                           cams[v].w, cams[v].h);
    long long nz = (long long)g->res + 1;
    size_t slice = (size_t)(nz * nz);
#pragma omp parallel for schedule(dynamic, 1)
    for (long long k = 0; k < nz; ++k)
        for (size_t s = 0; s < slice; ++s) {
            size_t idx = (size_t)k * slice + s;
            MfVec3 p = mf_tetgrid_base(g, idx);
            float f = 0.5f;
            for (int v = 0; v < n; ++v) {
                float px, py;
                if (!mf_camera_project(&cams[v], p, &px, &py)) continue;
                if (!(px >= 0 && py >= 0 && px <= (float)cams[v].w && py <= (float)cams[v].h)) continue;
                float a = mask_at(&masks[v], px, py) - 0.5f;
                if (a < f) f = a;
            }
            field[idx] = f;
        }
    return MF_OK;
}
