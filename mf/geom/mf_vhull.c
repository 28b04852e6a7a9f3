#include "geom/mf_vhull.h"

#include <math.h>
#include <stdlib.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "geom/mf_meshproc.h"
#include "geom/mf_vessel.h"

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

/* 1 when view c sees p: in front of the camera and projecting inside [0, w] x [0, h] (at *px, *py).
 * Such a view carves p by its mask; one that does not see p carves it only when the object lies
 * wholly inside its frame (mask_touches_border): the one rule of mf_vhull and of the border test. */
static int view_sees(const MfCamera *c, MfVec3 p, float *px, float *py) {
    return mf_camera_project(c, p, px, py) && *px >= 0 && *py >= 0 && *px <= (float)c->w && *py <= (float)c->h;
}

/* 1 when a pixel on the image's border has alpha >= 0.5: the object may extend out of the frame. */
static int mask_touches_border(const MfImage *m) {
    for (int y = 0; y < m->h; ++y)
        for (int x = 0; x < m->w; x += (y == 0 || y == m->h - 1 || m->w == 1) ? 1 : m->w - 1)
            if (mf_image_px(m, x, y)[m->c - 1] >= 0.5f) return 1;
    return 0;
}

int mf_vhull(const MfTetGrid *g, const MfCamera *cams, const MfImage *masks, int n, float *field) {
    if (n < 1) return mf_fail(MF_EARG, "visual hull: no views");
    for (int v = 0; v < n; ++v)
        if (masks[v].w != cams[v].w || masks[v].h != cams[v].h || masks[v].c < 1 || !masks[v].data)
            return mf_fail(MF_EARG, "visual hull: view %d: mask is %dx%d, its camera %dx%d", v, masks[v].w, masks[v].h,
                           cams[v].w, cams[v].h);
    unsigned char *framed = calloc((size_t)n, 1);
    if (!framed) return mf_fail(MF_ENOMEM, "out of memory");
    for (int v = 0; v < n; ++v) framed[v] = !mask_touches_border(&masks[v]);
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
                if (!view_sees(&cams[v], p, &px, &py)) {
                    if (framed[v]) f = -0.5f;
                    continue;
                }
                float a = mask_at(&masks[v], px, py) - 0.5f;
                if (a < f) f = a;
            }
            field[idx] = f;
        }
    free(framed);
    return MF_OK;
}

/* 1 when some grid vertex on the border of g is inside the hull and seen by at least one view.
 * A vertex no view sees (possible only when every view's object touches its frame) keeps +0.5
 * but says nothing about the object: with few such views the grid's corners are often out of
 * every frame, and counting them would report the hull as cut on any scene. */
static int touches_border(const MfTetGrid *g, const float *f, const MfCamera *cams, int nviews) {
    size_t n = (size_t)g->res + 1;
    for (size_t k = 0; k < n; ++k)
        for (size_t j = 0; j < n; ++j)
            for (size_t i = 0; i < n; ++i) {
                size_t idx = i + n * (j + n * k);
                if (!(i == 0 || j == 0 || k == 0 || i == n - 1 || j == n - 1 || k == n - 1) || !(f[idx] > 0)) continue;
                MfVec3 p = mf_tetgrid_base(g, idx);
                float px, py;
                for (int v = 0; v < nviews; ++v)
                    if (view_sees(&cams[v], p, &px, &py)) return 1;
            }
    return 0;
}

int mf_vhull_check_masks(const MfImage *masks, int n, int *masked) {
    int k = 0;
    for (int v = 0; v < n; ++v) {
        const MfImage *m = &masks[v];
        int lo = 0, hi = 0;
        for (size_t p = 0; p < (size_t)m->w * m->h && !(lo && hi); ++p) {
            float a = m->data[p * m->c + m->c - 1];
            lo |= a < 0.5f, hi |= a >= 0.5f;
        }
        k += lo && hi;
    }
    if (masked) *masked = k;
    return k < 3 ? mf_fail(MF_EARG, "%d of %d views have a mask (alpha both below and above 0.5); need at least 3", k, n) : MF_OK;
}

int mf_vhull_grid(const MfCamera *cams, const MfImage *masks, int n, int res, float extent, MfTetGrid *grid, float **field,
                  int *touches) {
    if (res < 1 || !(extent > 0)) return mf_fail(MF_EARG, "bad grid (res %d, extent %g)", res, extent);
    MfTetGrid g = mf_tetgrid_make(res, mf_v3s(0), extent);
    float *f = malloc(mf_tetgrid_nverts(&g) * sizeof *f);
    if (!f) return mf_fail(MF_ENOMEM, "out of memory for a %d^3 grid", res);
    int rc = mf_vhull(&g, cams, masks, n, f), still = 0;
    if (rc == MF_OK && touches_border(&g, f, cams, n)) {
        g = mf_tetgrid_make(res, mf_v3s(0), 1.5f * extent);
        rc = mf_vhull(&g, cams, masks, n, f);
        still = rc == MF_OK && touches_border(&g, f, cams, n);
        if (still) mf_log_warn("visual hull: the hull touches the border of the grid (side %g): it is cut there", 1.5f * extent);
    }
    if (rc != MF_OK) {
        free(f);
        return rc;
    }
    *grid = g;
    *field = f;
    if (touches) *touches = still;
    return MF_OK;
}

int mf_vhull_mesh(const MfCamera *cams, const MfImage *masks, int n, const MfHullOpts *opt, MfMesh *out, MfHullInfo *info) {
    MfHullInfo r = {0};
    int rc = mf_vhull_check_masks(masks, n, &r.masked_views);
    MfTetGrid g;
    float *f = NULL;
    if (rc == MF_OK) rc = mf_vhull_grid(cams, masks, n, opt->res, opt->extent, &g, &f, &r.touches_border);
    if (rc != MF_OK) return mf_fail_prefix(rc, "visual hull");
    r.extent = g.cell * (float)g.res;
    MfVesselAxis va = {0};
    if (opt->vessel_wall > 0) rc = mf_vessel_open(&g, f, cams, n, opt->vessel_wall, &va, &r.vessel_carved);
    r.vessel_candidate = va.candidate;
    if (opt->vessel_wall > 0 && rc == MF_OK)
        mf_log_info("vessel: top %.3f of the cross-section, tilt %.1f deg, axis (%.3f, %.3f, %.3f): %s", va.cap_frac, va.tilt_deg,
                    va.axis.x, va.axis.y, va.axis.z, va.candidate ? "carved" : "no opening");
    MfMesh m = {0};
    if (rc == MF_OK) rc = mf_vhull_extract_clean(&g, f, opt, &m, &r.extracted_tris, &r.dropped_components, NULL);
    free(f);
    if (rc != MF_OK) return mf_fail_prefix(rc, "visual hull");
    *out = m;
    if (info) *info = r;
    return MF_OK;
}

int mf_vhull_extract_clean(const MfTetGrid *g, const float *field, const MfHullOpts *opt, MfMesh *out, int *extracted_tris,
                           int *dropped, long *euler) {
    MfTetMesh tm = {0};
    int rc = mf_tetgrid_extract(g, field, NULL, &tm);
    if (rc != MF_OK) return rc;
    MfMesh m = tm.mesh;
    tm.mesh = (MfMesh){0};
    mf_tetmesh_free(&tm);
    if (extracted_tris) *extracted_tris = m.nt;
    rc = mf_mesh_weld(&m, 1e-4f * g->cell);
    if (rc == MF_OK) rc = mf_mesh_drop_degenerate(&m, 0);
    if (rc == MF_OK) rc = mf_mesh_drop_small_components(&m, opt->min_component, dropped);
    MfManifoldInfo mi;
    if (rc == MF_OK && euler && (rc = mf_mesh_manifold_check(&m, &mi)) == MF_OK) *euler = mi.euler;
    if (rc == MF_OK && opt->smooth_iters > 0) rc = mf_mesh_taubin(&m, opt->smooth_iters, 0.5f, -0.53f);
    if (rc == MF_OK && opt->target_tris > 0) rc = mf_mesh_decimate(&m, opt->target_tris, 0.01f);
    if (rc == MF_OK && m.nt == 0) rc = mf_fail(MF_EARG, "nothing left after clean-up");
    if (rc != MF_OK) {
        mf_mesh_free(&m);
        return rc;
    }
    *out = m;
    return MF_OK;
}
