/* UV baking (issue 14 item 9): a linear volume field baked onto UV-mapped meshes. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "geom/mf_bake.h"
#include "scene/mf_voltex.h"
#include "mf_test.h"

/* field(p) = A p + B, 3 channels */
static void field(const float *p, double *o) {
    o[0] = 0.3 * p[0] - 0.7 * p[1] + 0.2 * p[2] + 0.5;
    o[1] = 0.1 * p[0] + 0.4 * p[2] + 0.2;
    o[2] = -0.5 * p[1] + 0.6;
}

/* A volume texture holding the linear field at its vertices (trilinear reproduces it). */
static void linear_volume(MfVoltex *v) {
    const float lo[3] = {-0.6f, -0.6f, -0.6f}, hi[3] = {0.6f, 0.6f, 0.6f};
    CHECK_OK(mf_voltex_init(v, 9, 3, lo, hi, NULL));
    for (int k = 0; k < 9; ++k)
        for (int j = 0; j < 9; ++j)
            for (int i = 0; i < 9; ++i) {
                int ijk[3] = {i, j, k};
                float p[3];
                double o[3];
                for (int a = 0; a < 3; ++a) p[a] = lo[a] + (hi[a] - lo[a]) * ijk[a] / 8.0f;
                field(p, o);
                for (int c = 0; c < 3; ++c) v->grid[(((size_t)k * 9 + j) * 9 + i) * 3 + c] = (float)o[c];
            }
}

/* A unit cube (side 0.8), each face its own chart: cell (f % 3, f / 3) of a 3 x 2 layout, inset
 * by 0.15 so that gaps of several texels separate the charts. */
static void uv_cube(MfMesh *m) {
    CHECK_OK(mf_mesh_alloc(m, 24, 12, 0, 1));
    for (int f = 0; f < 6; ++f) {
        int ax = f / 2, sgn = f % 2 ? 1 : -1, u = (ax + 1) % 3, w = (ax + 2) % 3;
        for (int c = 0; c < 4; ++c) {
            int cu = c & 1, cw = c >> 1;
            float *p = m->pos + 3 * (4 * f + c);
            p[ax] = 0.4f * sgn, p[u] = cu ? 0.4f : -0.4f, p[w] = cw ? 0.4f : -0.4f;
            m->uv[2 * (4 * f + c)] = ((f % 3) + 0.15f + 0.7f * cu) / 3.0f;
            m->uv[2 * (4 * f + c) + 1] = ((f / 3) + 0.15f + 0.7f * cw) / 2.0f;
        }
        uint32_t b = 4 * f, t[6] = {b, b + 1, b + 3, b, b + 3, b + 2};
        memcpy(m->tri + 6 * f, t, sizeof t);
    }
}

/* Covered texels reproduce the field at their surface point, whose UV is the texel centre. */
static void check_covered(const MfMesh *m, int res, const int *tid, const float *bary, const MfImage *img, double *covered_frac) {
    double wv = 0, wuv = 0;
    size_t nc = 0;
    for (size_t i = 0; i < (size_t)res * res; ++i) {
        if (tid[i] < 0) continue;
        ++nc;
        float p[3], n[3];
        double o[3];
        mf_bake_point(m, tid, bary, i, p, n);
        field(p, o);
        for (int c = 0; c < 3; ++c) wv = fmax(wv, fabs(img->data[3 * i + c] - o[c]));
        const uint32_t *f = m->tri + 3 * tid[i];
        double w[3] = {1.0 - bary[2 * i] - bary[2 * i + 1], bary[2 * i], bary[2 * i + 1]}, uv[2] = {0, 0};
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 2; ++a) uv[a] += w[k] * m->uv[2 * f[k] + a];
        double cu = ((double)(i % res) + 0.5) / res, cv = 1.0 - ((double)(i / res) + 0.5) / res;
        wuv = fmax(wuv, fmax(fabs(uv[0] - cu), fabs(uv[1] - cv)) * res);
    }
    printf("    %.1f%% covered; baked vs field worst %.2g; UV of the surface point vs texel centre worst %.2g texel\n",
           100.0 * nc / ((double)res * res), wv, wuv);
    CHECK_MSG(wv <= 2e-6, "baked value differs from the field by %g", wv);
    CHECK_MSG(wuv <= 1e-3, "surface point's UV is %g texels from the texel centre", wuv);
    *covered_frac = (double)nc / ((double)res * res);
}

MF_TEST(geom_bake_linear_field) {
    enum { RES = 64, GUTTER = 3 };
    MfVoltex vol;
    linear_volume(&vol);
    MfMesh cube;
    uv_cube(&cube);
    MfImage img = {0};
    int tid[RES * RES];
    float *bary = malloc(sizeof(float) * 2 * RES * RES);
    CHECK_OK(mf_bake_volume(&cube, &vol, RES, GUTTER, &img));
    CHECK(img.w == RES && img.h == RES && img.c == 3);
    CHECK_OK(mf_bake_raster(&cube, RES, tid, bary));
    double frac;
    check_covered(&cube, RES, tid, bary, &img, &frac);
    /* six charts of (0.7/3 x 0.7/2) of the square: 49% of the texels, up to the border texels */
    CHECK_MSG(fabs(frac - 0.7 * 0.7) < 0.03, "covered fraction %g", frac);
    /* gutter: texel at Chebyshev distance d from the charts; d <= GUTTER: inside the range of the
     * covered values (a mean of means), d = 1: exactly the mean of its covered neighbours; the rest:
     * the mean of all covered texels. No NaN anywhere. */
    double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9}, mean[3] = {0, 0, 0};
    size_t nc = 0;
    for (int i = 0; i < RES * RES; ++i)
        if (tid[i] >= 0) {
            for (int c = 0; c < 3; ++c)
                lo[c] = fmin(lo[c], img.data[3 * i + c]), hi[c] = fmax(hi[c], img.data[3 * i + c]), mean[c] += img.data[3 * i + c];
            ++nc;
        }
    int nan = 0, ring1 = 0, ring_bad = 0, far = 0, far_bad = 0, gutter_px = 0;
    for (int y = 0; y < RES; ++y)
        for (int x = 0; x < RES; ++x) {
            int i = y * RES + x, d = 1000;
            for (int c = 0; c < 3; ++c) nan += !isfinite(img.data[3 * i + c]);
            if (tid[i] >= 0) continue;
            double s[3] = {0, 0, 0};
            int cnt = 0;
            for (int yy = 0; yy < RES; ++yy)
                for (int xx = 0; xx < RES; ++xx)
                    if (tid[yy * RES + xx] >= 0) {
                        int dd = abs(xx - x) > abs(yy - y) ? abs(xx - x) : abs(yy - y);
                        if (dd < d) d = dd;
                        if (dd == 1)
                            for (int c = 0; c < 3; ++c) s[c] += img.data[3 * (yy * RES + xx) + c];
                        cnt += dd == 1;
                    }
            for (int c = 0; c < 3; ++c) {
                float v = img.data[3 * i + c];
                if (d == 1 && fabs(v - s[c] / cnt) > 1e-6) ++ring_bad;
                if (d <= GUTTER && (v < lo[c] - 1e-6 || v > hi[c] + 1e-6)) ++ring_bad;
                if (d > GUTTER && fabs(v - mean[c] / nc) > 1e-5) ++far_bad;
            }
            ring1 += d == 1;
            gutter_px += d <= GUTTER;
            far += d > GUTTER;
        }
    CHECK(nan == 0);
    CHECK_MSG(ring1 > 100 && gutter_px > ring1 && far > 0, "ring 1: %d texels, gutter %d, beyond %d", ring1, gutter_px, far);
    CHECK_MSG(ring_bad == 0, "%d gutter values are wrong", ring_bad);
    CHECK_MSG(far_bad == 0, "%d texels beyond the gutter differ from the covered mean", far_bad);
    mf_image_free(&img);
    /* a UV sphere (poles and a seam) */
    MfMesh sph;
    CHECK_OK(mf_mesh_uv_sphere(&sph, 48, 24, mf_v3s(0.0f), 0.45f));
    CHECK_OK(mf_bake_volume(&sph, &vol, RES, GUTTER, &img));
    CHECK_OK(mf_bake_raster(&sph, RES, tid, bary));
    check_covered(&sph, RES, tid, bary, &img, &frac);
    CHECK_MSG(frac > 0.95, "a UV sphere covers %g of its texture", frac);
    nan = 0;
    for (int i = 0; i < 3 * RES * RES; ++i) nan += !isfinite(img.data[i]);
    CHECK(nan == 0);
    mf_image_free(&img);
    /* no UVs: refused, output untouched */
    free(cube.uv);
    cube.uv = NULL;
    CHECK_ERR(mf_bake_volume(&cube, &vol, RES, GUTTER, &img), "UVs");
    CHECK(img.data == NULL);
    mf_mesh_free(&cube);
    mf_mesh_free(&sph);
    mf_voltex_free(&vol);
    free(bary);
}
