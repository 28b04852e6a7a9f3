#include "inverse/mf_recon_geom.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "geom/mf_meshsdf.h"
#include "inverse/mf_budget.h"
#include "inverse/mf_geom_fit.h"
#include "io/mf_gltf_read.h"
#include "io/mf_obj.h"

int mf_recon_geom_resolve(const MfReconGeomOpts *o, int mesh_exists, const char **source) {
    const char *g = o->geometry;
    if (g && strcmp(g, "given") && strcmp(g, "vhull") && strcmp(g, "dmtet"))
        return mf_fail(MF_EARG, "--geometry '%s': expected given, vhull or dmtet", g);
    if (!g) {
        g = mesh_exists ? "given" : "vhull";
        if (!mesh_exists) mf_log_info("geometry: the data set has no mesh and --geometry is not given: using vhull (the visual hull of the masks)");
    }
    *source = !strcmp(g, "given") ? "given" : !strcmp(g, "vhull") ? "vhull" : "dmtet";
    return MF_OK;
}

float mf_recon_geom_vertex_lr(const char *source, const MfMesh *mesh, int normal_map) {
    if (!strcmp(source, "given") || normal_map) return 0.0f;
    MfVec3 lo, hi;
    mf_mesh_bounds(mesh, &lo, &hi);
    float side = fmaxf(hi.x - lo.x, fmaxf(hi.y - lo.y, hi.z - lo.z));
    return MF_RECON_GEOM_VERTEX_LR * (isfinite(side) && side > 0.0f ? side : 1.0f);
}

int mf_recon_geom_normal_smooth(const char *source) { return strcmp(source, "given") ? MF_RECON_GEOM_NORMAL_SMOOTH : 0; }

/* The given mesh: it must have UVs. */
static int read_given(const char *path, MfMesh *mesh) {
    if (mf_mesh_read(path, mesh)) return mf_fail_prefix(MF_EIO, "mesh (supply one with --mesh, or build one with --geometry vhull)");
    if (mesh->uv) return MF_OK;
    mf_mesh_free(mesh);
    return mf_fail(MF_EARG, "%s: the mesh has no UVs; mf recon refuses it (unwrap it first: mf unwrap %s -o OUT.obj, or e.g. in Blender)", path, path);
}

/* A geometry/vhull.obj from an earlier run of the same folder: usable when it reads, has UVs and
 * triangles and finite positions. 1: *mesh holds it; 0: not usable (a warning says why). */
static int reuse_hull(const char *path, MfMesh *mesh) {
    if (!mf_file_exists(path)) return 0;
    if (mf_mesh_read(path, mesh)) {
        mf_log_warn("%s: cannot be reused (%s); building it again", path, mf_error());
        return 0;
    }
    int ok = mesh->uv && mesh->nt > 0;
    for (int i = 0; ok && i < 3 * mesh->nv; ++i) ok = isfinite(mesh->pos[i]);
    for (int i = 0; ok && i < 2 * mesh->nv; ++i) ok = isfinite(mesh->uv[i]);
    if (!ok) {
        mf_log_warn("%s: cannot be reused (no UVs, no triangles or a non-finite value); building it again", path);
        mf_mesh_free(mesh);
    }
    return ok;
}

/* Smooth normals, unwrap (mf_uvatlas, as mf unwrap), written atomically to path; m is freed;
 * info->unwrap_s += its time. */
static int unwrap_write(MfMesh *m, int tex_res, const char *path, MfReconGeomInfo *info) {
    MfUvAtlasOpts uo = mf_uvatlas_defaults();
    uo.tex_res = tex_res;
    MfMesh out = {0};
    /* smooth vertex normals: the unwrap copies them across its seams, so shading stays continuous */
    int rc = mf_mesh_compute_normals(m);
    double t1 = mf_now();
    if (rc == MF_OK) rc = mf_uvatlas(m, &uo, &out, &info->atlas);
    double dt = mf_now() - t1;
    info->unwrap_s += dt;
    if (rc == MF_OK && info->atlas.forced_single)
        mf_log_warn("geometry: unwrap: %d triangles became charts of their own", info->atlas.forced_single);
    if (rc == MF_OK && (rc = mf_mkdirs_for(path)) == MF_OK) rc = mf_obj_write(path, &out, NULL);
    if (rc == MF_OK) mf_log_info("geometry: %d triangles unwrapped into %d charts in %.2f s -> %s", out.nt, info->atlas.charts, dt, path);
    mf_mesh_free(m);
    mf_mesh_free(&out);
    return rc;
}

/* The hull_* options: the hull's grid and clean-up (the DMTet mesh's too, with dmtet_smooth). */
static MfHullOpts hull_opts(const MfReconGeomOpts *o) {
    /* no vessel_wall: mf recon carves in extract_write, where --vessel auto keeps both meshes */
    return (MfHullOpts){o->hull_res, o->hull_extent, o->hull_smooth, o->hull_target_tris, o->hull_min_component, 0.0f};
}

/* The meshes --vessel auto compares, and their files' suffixes: the closed one, the field carved
 * with the stated wall, and carved with walls of MF_VESSEL_THICK_CELLS (only when the stated wall
 * is thinner). */
static const char *const k_vessel_name[MF_VESSEL_MESHES] = {"closed", "open", "open-thick"};

/* <out>/geometry/<source>-<k_vessel_name[k]>.obj */
static int vessel_path(char *path, size_t cap, const char *out_dir, const char *source, int k) {
    char name[64];
    snprintf(name, sizeof name, "geometry/%s-%s.obj", source, k_vessel_name[k]);
    return mf_path_join(path, cap, out_dir, name);
}

/* 1 when vessel mesh k's walls broke through: its Euler characteristic more than
 * MF_VESSEL_MAX_EULER_DROP below the closed mesh's. */
static int vessel_broken(const MfReconGeomInfo *info, int k) {
    return k > 0 && info->vessel_euler[k] < info->vessel_euler[0] - MF_VESSEL_MAX_EULER_DROP;
}

/* The walls --vessel tries on g, into info: the stated fraction of field's side (at least
 * MF_VESSEL_MIN_CELLS) and, under auto where that is thinner than MF_VESSEL_THICK_CELLS but at
 * least half of it, that many cells. */
static void vessel_walls(const MfReconGeomOpts *o, const MfTetGrid *g, const float *field, MfReconGeomInfo *info) {
    float w = mf_vessel_wall_cells(g, field, o->vessel_wall, 0.0f);
    info->vessel_n = 2 + (o->vessel == MF_VESSEL_AUTO && w < MF_VESSEL_THICK_CELLS && MF_VESSEL_THICK_CELLS <= MF_VESSEL_THICK_MAX_X * w);
    info->vessel_wall_cells[0] = fmaxf(w, MF_VESSEL_MIN_CELLS);
    info->vessel_wall_cells[1] = info->vessel_n > 2 ? MF_VESSEL_THICK_CELLS : 0.0f;
}

/* The field's clean mesh (mf_vhull_extract_clean), unwrapped, to path; with --vessel auto|open and
 * a candidate opening, the carved meshes too: open writes the one with the stated wall to path
 * instead of the closed one; auto writes each to <source>-<k_vessel_name>.obj and leaves the
 * choice pending (mf_recon_geom_vessel_choose). cut NULL: the opening is field's (mf_vessel_axis)
 * and each carved mesh is field carved (mf_vessel_carve, walls vessel_walls); else the caller
 * looked for the opening (info->vessel; no candidate: closed) and set the walls, and carved mesh k
 * is field cut by cut[k] (nverts,): their minimum, the intersection of the two solids (DMTet
 * started from the hull: hull_start). */
static int extract_write(const MfReconGeomOpts *o, const MfTetGrid *g, const float *field, float *const *cut, const MfHullOpts *ho,
                         const MfCamera *cams, int n, int tex_res, const char *out_dir, const char *path, int *extracted, int *dropped,
                         MfReconGeomInfo *info) {
    MfMesh m = {0}, open = {0};
    int rc = mf_vhull_extract_clean(g, field, ho, &m, extracted, dropped, &info->vessel_euler[0]), automode = o->vessel == MF_VESSEL_AUTO;
    if (!rc && o->vessel != MF_VESSEL_CLOSED && !cut) rc = mf_vessel_axis(g, field, cams, n, &info->vessel);
    if (rc || o->vessel == MF_VESSEL_CLOSED || !info->vessel.candidate) {
        if (!rc && o->vessel != MF_VESSEL_CLOSED)
            mf_log_info("geometry: vessel: no opening to test (top %.2f of the cross-section, tilt %.1f deg; needs >= %.2f, <= %.0f deg)",
                        info->vessel.cap_frac, info->vessel.tilt_deg, MF_VESSEL_MIN_CAP, MF_VESSEL_MAX_TILT_DEG);
        if (!rc) rc = unwrap_write(&m, tex_res, path, info);
        mf_mesh_free(&m);
        return rc;
    }
    if (!cut) vessel_walls(o, g, field, info);
    size_t nv = mf_tetgrid_nverts(g);
    float *f = malloc(nv * sizeof *f);
    if (!f) rc = mf_fail(MF_ENOMEM, "vessel: out of memory for a copy of the field");
    char p[MF_PATH_MAX];
    if (!rc && automode && !(rc = vessel_path(p, sizeof p, out_dir, info->source, 0))) rc = unwrap_write(&m, tex_res, p, info);
    mf_mesh_free(&m);
    MfVec3 a = info->vessel.axis;
    for (int k = 0; !rc && k + 1 < info->vessel_n; ++k) {
        memcpy(f, field, nv * sizeof *f);
        if (cut)
            for (size_t v = 0; v < nv; ++v) f[v] = fminf(f[v], cut[k][v]);
        else
            rc = mf_vessel_carve(g, f, a, info->vessel_wall_cells[k], &info->vessel_carved[k]);
        if (!rc) rc = mf_vhull_extract_clean(g, f, ho, &open, NULL, NULL, &info->vessel_euler[k + 1]);
        if (!rc)
            mf_log_info("geometry: vessel: a flat top (%.2f of the cross-section) facing the cameras, axis (%.3f, %.3f, %.3f); carved "
                        "%zu %sgrid vertices (walls %.2f cells: %g of the hull's side, at least %g cells); Euler characteristic %ld "
                        "(closed %ld)", info->vessel.cap_frac, a.x, a.y, a.z, info->vessel_carved[k], cut ? "hull " : "",
                        (double)info->vessel_wall_cells[k], (double)o->vessel_wall, (double)(k ? MF_VESSEL_THICK_CELLS : MF_VESSEL_MIN_CELLS),
                        info->vessel_euler[k + 1], info->vessel_euler[0]);
        if (!rc && vessel_broken(info, k + 1))
            mf_log_warn("geometry: vessel: the %.2f-cell walls broke through (Euler characteristic %ld against the closed mesh's %ld)%s",
                        (double)info->vessel_wall_cells[k], info->vessel_euler[k + 1], info->vessel_euler[0],
                        automode ? ": not tried" : "");
        if (!rc && automode) rc = vessel_path(p, sizeof p, out_dir, info->source, k + 1);
        if (!rc) rc = unwrap_write(&open, tex_res, automode ? p : path, info);
        mf_mesh_free(&open);
    }
    free(f);
    if (!rc && automode) info->vessel_pending = 1;
    if (!rc && !automode) info->vessel_chosen = k_vessel_name[1];
    return rc;
}

/* Hull (the grid of mf_vhull_grid, as mf hull), unwrapped and written to path (extract_write). */
static int build_hull(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, int tex_res,
                      const char *out_dir, const char *path, MfReconGeomInfo *info) {
    MfHullOpts ho = hull_opts(o);
    MfTetGrid g;
    float *f = NULL;
    double t0 = mf_now();
    int rc = mf_vhull_check_masks(masks, n, &info->hull.masked_views);
    if (!rc) rc = mf_vhull_grid(cams, masks, n, ho.res, ho.extent, &g, &f, &info->hull.touches_border);
    if (!rc) info->hull.extent = g.cell * (float)g.res;
    if (!rc) rc = extract_write(o, &g, f, NULL, &ho, cams, n, tex_res, out_dir, path, &info->hull.extracted_tris,
                                &info->hull.dropped_components, info);
    free(f);
    info->hull_s = mf_now() - t0 - info->unwrap_s;
    if (!rc) mf_log_info("geometry: visual hull of %d masked views, %d triangles extracted, in %.2f s", info->hull.masked_views,
                         info->hull.extracted_tris, info->hull_s);
    return rc == MF_OK ? MF_OK : mf_fail_prefix(rc, "--geometry vhull");
}

/* geom_log.csv: one row per step (mask loss and weighted regulariser before the step); steps 0: the header. */
static int write_geom_log(const char *out_dir, const MfGeomFitStep *log, int steps) {
    char path[MF_PATH_MAX];
    int rc = mf_path_join(path, sizeof path, out_dir, "geom_log.csv");
    if (!rc) rc = mf_mkdirs_for(path);
    size_t cap = 64 + (size_t)steps * 80, len = 0;
    char *buf = rc ? NULL : malloc(cap);
    if (!rc && !buf) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (rc) return rc;
    len += (size_t)snprintf(buf, cap, "step,mask_loss,sdf_reg,triangles,rgb_loss\n");
    for (int i = 0; i < steps; ++i)
        len += (size_t)snprintf(buf + len, cap - len, "%d,%.9g,%.9g,%d,%.9g\n", i, log[i].mask, log[i].reg, log[i].nt, log[i].rgb);
    rc = mf_write_file(path, buf, len);
    free(buf);
    return rc;
}

/* DMTet's start from the hull (--dmtet-init hull): the hull mesh vhull builds (its grid *gh, which
 * is g when g has the hull's resolution, and clean-up, the hull_* options), its signed distance on
 * g replacing sdf (the soft hull on g, which gives the sign beyond MF_DMTET_INIT_BAND cells). With
 * --vessel auto|open and an opening in the hull's field (info->vessel), the hull is carved as vhull
 * carves it (its walls, into info, on its grid, where they do not break through), and each carved
 * hull's signed distance on *gh goes to cut[k] (malloc'd, the caller frees them): build_dmtet cuts
 * the fitted SDF with them there. */
static int hull_start(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, const MfTetGrid *g, float *sdf,
                      MfTetGrid *gh, float *cut[2], MfReconGeomInfo *info) {
    MfHullOpts ho = hull_opts(o);
    float *fh = NULL, *tmp = NULL;
    MfMesh m = {0};
    int rc = MF_OK;
    if (g->res == ho.res) { /* DMTet on the hull's grid (mf_vhull_grid is deterministic): sdf holds its field */
        size_t nv = mf_tetgrid_nverts(g);
        *gh = *g;
        if (!(fh = malloc(nv * sizeof *fh))) rc = mf_fail(MF_ENOMEM, "out of memory for the hull's field");
        else memcpy(fh, sdf, nv * sizeof *fh);
    } else {
        rc = mf_vhull_grid(cams, masks, n, ho.res, ho.extent, gh, &fh, NULL);
    }
    if (!rc) rc = mf_vhull_extract_clean(gh, fh, &ho, &m, NULL, NULL, NULL);
    if (!rc) rc = mf_meshsdf_grid(g, &m, sdf, MF_DMTET_INIT_BAND, sdf);
    if (!rc) mf_log_info("geometry: DMTet starts from the hull mesh's signed distance (%d^3 hull, %d triangles; band %g cells)", ho.res,
                         m.nt, (double)MF_DMTET_INIT_BAND);
    mf_mesh_free(&m);
    if (!rc && o->vessel != MF_VESSEL_CLOSED) rc = mf_vessel_axis(gh, fh, cams, n, &info->vessel);
    if (!rc && o->vessel != MF_VESSEL_CLOSED && info->vessel.candidate) {
        size_t nh = mf_tetgrid_nverts(gh);
        vessel_walls(o, gh, fh, info);
        if (!(tmp = malloc(nh * sizeof *tmp))) rc = mf_fail(MF_ENOMEM, "out of memory for the carved hull");
        for (int k = 0; !rc && k + 1 < info->vessel_n; ++k) {
            memcpy(tmp, fh, nh * sizeof *tmp);
            rc = mf_vessel_carve(gh, tmp, info->vessel.axis, info->vessel_wall_cells[k], &info->vessel_carved[k]);
            if (!rc) rc = mf_vhull_extract_clean(gh, tmp, &ho, &m, NULL, NULL, NULL);
            if (!rc && !(cut[k] = malloc(nh * sizeof *cut[k]))) rc = mf_fail(MF_ENOMEM, "out of memory for the carved hull's SDF");
            if (!rc) rc = mf_meshsdf_grid(gh, &m, tmp, MF_DMTET_INIT_BAND, cut[k]);
            mf_mesh_free(&m);
        }
    }
    free(fh), free(tmp);
    return rc;
}

/* DMTet's mask term: the hull mesh's signed distance (hull_start) or the soft hull (in cell units)
 * -> geom_iters Adam steps -> clean mesh (cut by the carved hulls) -> unwrap.
 * The fit's state goes to geometry/dmtet_state.mfck every MF_GEOM_STATE_EVERY steps; resume
 * continues from it; it is removed once dmtet.obj is written (which resume then reuses whole). */
#define MF_GEOM_STATE_EVERY 25

/* The resolution of DMTet's start: the hull's (hull_res) or the soft hull's (MF_DMTET_SOFT_RES). */
static int dmtet_start_res(const MfReconGeomOpts *o) {
    return o->dmtet_init == MF_DMTET_INIT_HULL ? o->hull_res : MF_DMTET_SOFT_RES;
}

/* Taubin iterations of DMTet's mesh on a res^3 grid: dmtet_smooth, or by default 100 at the start's
 * resolution (the hull's mesh is smoothed already) scaled by (res / that)^2 (mf_recon_opts.c). */
static int dmtet_smooth(const MfReconGeomOpts *o, int res) {
    double base = dmtet_start_res(o);
    return o->dmtet_smooth >= 0 ? o->dmtet_smooth : (int)lround(100.0 * res * res / (base * base));
}

static int build_dmtet(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, int tex_res,
                       const char *out_dir, const char *path, int resume, MfReconGeomInfo *info) {
    MfTetGrid g = {0};
    float *sdf = NULL;
    MfGeomFitStep *log = o->geom_iters > 0 ? calloc((size_t)o->geom_iters, sizeof *log) : NULL;
    int rc = log || o->geom_iters == 0 ? MF_OK : mf_fail(MF_ENOMEM, "out of memory for %d steps' log", o->geom_iters);
    double t0 = mf_now();
    if (!rc) rc = mf_vhull_check_masks(masks, n, &info->hull.masked_views);
    /* the hull's grid: enlarged 1.5x once when the hull touches its border, as mf_vhull_mesh does */
    info->dmtet_res = o->dmtet_res ? o->dmtet_res : dmtet_start_res(o);
    if (!rc) rc = mf_vhull_grid(cams, masks, n, info->dmtet_res, o->hull_extent, &g, &sdf, &info->hull.touches_border);
    info->hull.extent = g.cell * (float)g.res;
    size_t nv = rc ? 0 : mf_tetgrid_nverts(&g);
    float *cut[2] = {NULL, NULL};
    MfTetGrid gh = {0};
    if (!rc && o->dmtet_init == MF_DMTET_INIT_HULL) {
        rc = hull_start(o, cams, masks, n, &g, sdf, &gh, cut, info);
    } else {
        /* mask - 0.5 in [-0.5, 0.5]: as a distance, in cells, so geom_lr is in cells per step */
        for (size_t v = 0; v < nv; ++v) sdf[v] *= g.cell;
    }
    info->hull_s = mf_now() - t0;
    char state[MF_PATH_MAX];
    if (!rc && !(rc = mf_path_join(state, sizeof state, out_dir, "geometry/dmtet_state.mfck"))) rc = mf_mkdirs_for(state);
    MfGeomFitOpts fo = {.iters = o->geom_iters, .lr_sdf = o->geom_lr * g.cell, .sdf_reg = o->geom_sdf_reg, .views_per_step = o->geom_views,
                        .color = o->geom_color, .seed = o->geom_seed, .start = o->dmtet_init, .state = state, .state_every = MF_GEOM_STATE_EVERY,
                        .resume = resume, .resumed = &info->resumed_at};
    if (!rc && o->geom_iters > 0) {
        t0 = mf_now();
        rc = mf_geom_fit(&g, sdf, NULL, cams, masks, n, &fo, log, &info->steps);
        info->geom_s = mf_now() - t0;
        info->step_ms = info->steps > info->resumed_at ? 1e3 * info->geom_s / (info->steps - info->resumed_at) : 0;
        double rebuild = 0;
        for (int i = info->resumed_at; i < info->steps; ++i) rebuild += log[i].rebuild_s;
        info->rebuild_share = info->geom_s > 0 ? rebuild / info->geom_s : 0;
        if (info->steps) info->loss_first = log[0].mask, info->loss_last = log[info->steps - 1].mask;
        if (info->steps) info->rgb_first = log[0].rgb, info->rgb_last = log[info->steps - 1].rgb;
    }
    /* header only at 0 steps, so the folder never keeps an earlier run's log; nothing when the hull
     * failed (a refused run leaves no folder behind) */
    if (!rc || info->steps) {
        int wrc = write_geom_log(out_dir, log, info->steps);
        if (!rc) rc = wrc;
    }
    if (!rc)
        mf_log_info("geometry: DMTet, %s: %d^3 grid, %d steps of %d views in %.2f s (%.1f ms/step, %.0f%% extraction and Embree "
                    "build), mask loss %.5f -> %.5f", o->geom_color > 0 ? "mask and colour terms" : "mask term only (no colour loss)",
                    info->dmtet_res, info->steps, o->geom_views ? o->geom_views : n, info->geom_s, info->step_ms,
                    100 * info->rebuild_share, info->loss_first, info->loss_last);
    /* a vessel found in the hull: every mesh is extracted on the hull's grid, the fitted SDF
     * interpolated onto it (when it is another grid), so the carved hull's walls keep the cells they
     * were carved with */
    float *up = NULL;
    const MfTetGrid *ge = cut[0] ? &gh : &g;
    if (!rc && cut[0] && gh.res != g.res) {
        size_t nh = mf_tetgrid_nverts(&gh);
        if (!(up = malloc(nh * sizeof *up))) rc = mf_fail(MF_ENOMEM, "out of memory for the fitted SDF on the hull's grid");
        for (size_t v = 0; !rc && v < nh; ++v) up[v] = mf_tetgrid_sample(&g, sdf, mf_tetgrid_base(&gh, v), -MF_DMTET_INIT_BAND * g.cell);
    }
    MfHullOpts ho = hull_opts(o);
    ho.smooth_iters = info->smooth_iters = dmtet_smooth(o, info->dmtet_res);
    if (!rc)
        rc = extract_write(o, ge, up ? up : sdf, o->dmtet_init == MF_DMTET_INIT_HULL ? cut : NULL, &ho, cams, n, tex_res, out_dir, path,
                           NULL, &info->dropped_components, info);
    free(sdf), free(up), free(log), free(cut[0]), free(cut[1]);
    if (!rc && o->geom_iters > 0 && remove(state) != 0)
        rc = mf_fail(MF_EIO, "%s: cannot remove the finished fit's state: %s", state, strerror(errno));
    return rc == MF_OK ? MF_OK : mf_fail_prefix(rc, "--geometry dmtet");
}

/* 1 when a and b name the same existing file (same device and inode). */
static int same_file(const char *a, const char *b) {
    struct stat x, y;
    return !stat(a, &x) && !stat(b, &y) && x.st_dev == y.st_dev && x.st_ino == y.st_ino;
}

/* Removes from out_dir what an earlier run with another --geometry left (its mesh, dmtet's log),
 * so the folder holds one run; keep (the mesh this run uses, may be NULL) is never removed. The
 * outputs of this run's own source stay: they are rewritten, or reused by --resume. check_only:
 * removes nothing; MF_EARG naming the first such file (a --resume must continue the same run). */
static int remove_other_geometry(const char *out_dir, const char *source, const char *keep, int check_only) {
    static const struct { const char *file, *owner; } outs[] = {
        {"geometry/vhull.obj", "vhull"}, {"geometry/vhull-closed.obj", "vhull"}, {"geometry/vhull-open.obj", "vhull"},
        {"geometry/vhull-open-thick.obj", "vhull"}, {"geometry/dmtet.obj", "dmtet"}, {"geometry/dmtet-closed.obj", "dmtet"},
        {"geometry/dmtet-open.obj", "dmtet"}, {"geometry/dmtet-open-thick.obj", "dmtet"},
        {"geometry/dmtet_state.mfck", "dmtet"}, {"geom_log.csv", "dmtet"}};
    char path[MF_PATH_MAX];
    for (size_t i = 0; i < sizeof outs / sizeof outs[0]; ++i) {
        if (!strcmp(outs[i].owner, source)) continue;
        int rc = mf_path_join(path, sizeof path, out_dir, outs[i].file);
        if (rc) return rc;
        if (!mf_file_exists(path) || (keep && same_file(path, keep))) continue;
        if (check_only)
            return mf_fail(MF_EARG, "--resume --geometry %s: %s is an earlier --geometry %s run's; resume with --geometry %s, or "
                           "run without --resume to start afresh (which removes it)", source, path, outs[i].owner, outs[i].owner);
        if (remove(path) != 0)
            return mf_fail(MF_EIO, "%s: cannot remove an earlier --geometry %s run's output: %s", path, outs[i].owner, strerror(errno));
        mf_log_info("%s: removed (an earlier --geometry %s run's output; this run uses --geometry %s)", path, outs[i].owner, source);
    }
    int rc = check_only ? MF_OK : mf_path_join(path, sizeof path, out_dir, "geometry");
    if (!rc && !check_only) rmdir(path); /* only when that left it empty */
    return rc;
}

int mf_recon_geom_mesh(const MfReconGeomOpts *o, const char *source, const char *given_path, const MfCamera *cams,
                       const MfImage *masks, int n, int tex_res, const char *out_dir, int resume, MfMesh *mesh,
                       MfReconGeomInfo *info) {
    memset(info, 0, sizeof *info);
    info->source = source;
    /* a resumed run continues one run: another source's outputs mean the folder holds another run */
    if (resume) {
        int rc = remove_other_geometry(out_dir, source, !strcmp(source, "given") ? given_path : NULL, 1);
        if (rc) return rc;
    }
    if (!strcmp(source, "given")) {
        snprintf(info->mesh_path, sizeof info->mesh_path, "%s", given_path);
        int rc = read_given(given_path, mesh);
        if (!rc && (rc = remove_other_geometry(out_dir, source, given_path, 0))) mf_mesh_free(mesh);
        return rc;
    }
    int dmtet = !strcmp(source, "dmtet");
    int rc = mf_path_join(info->mesh_path, sizeof info->mesh_path, out_dir, dmtet ? "geometry/dmtet.obj" : "geometry/vhull.obj");
    if (rc) return rc;
    if (resume && reuse_hull(info->mesh_path, mesh)) {
        info->reused = 1;
        info->hull_tris = mesh->nt;
        mf_log_info("geometry: reusing %s (%d triangles)", info->mesh_path, mesh->nt);
        if ((rc = remove_other_geometry(out_dir, source, NULL, 0))) mf_mesh_free(mesh);
        return rc;
    }
    rc = dmtet ? build_dmtet(o, cams, masks, n, tex_res, out_dir, info->mesh_path, resume, info)
               : build_hull(o, cams, masks, n, tex_res, out_dir, info->mesh_path, info);
    if (rc) return rc;
    /* an earlier auto run's meshes in this folder that this run did not write are not this run's */
    char vp[MF_VESSEL_MESHES][MF_PATH_MAX];
    for (int k = 0; k < MF_VESSEL_MESHES; ++k) {
        if ((rc = vessel_path(vp[k], sizeof vp[k], out_dir, source, k))) return rc;
        if ((!info->vessel_pending || k >= info->vessel_n) && mf_file_exists(vp[k]) && remove(vp[k]) != 0)
            return mf_fail(MF_EIO, "%s: cannot remove an earlier run's vessel mesh: %s", vp[k], strerror(errno));
    }
    /* read back what was written: a resumed run reuses the file, so both optimise the same bytes
     * (a pending vessel choice: the closed mesh, until mf_recon_geom_vessel_choose) */
    if ((rc = mf_mesh_read(info->vessel_pending ? vp[0] : info->mesh_path, mesh))) return rc;
    info->hull_tris = mesh->nt;
    if ((rc = remove_other_geometry(out_dir, source, NULL, 0))) mf_mesh_free(mesh);
    return rc;
}

/* A trial fit of mesh: iters iterations of ro with views 0, 8, 16, ... held out, in dir (removed
 * after); *psnr: their PSNR at the end (mf_recon's hold-out score: per-channel scale, sRGB). */
static int trial_fit(const MfMesh *mesh, const MfReconView *views, int n, const MfReconOpts *ro, int iters, const char *dir,
                     double *psnr) {
    MfReconOpts t = *ro;
    t.iters = iters, t.early_stop = 1, t.holdout_every = 8, t.es_every = iters, t.es_patience = 1000000;
    t.snapshot_every = 0, t.checkpoint_every = 0;
    MfReconView *cp = calloc((size_t)n, sizeof *cp);
    int rc = cp ? MF_OK : mf_fail(MF_ENOMEM, "out of memory for the trial's views");
    for (int i = 0; !rc && i < n; ++i) {
        const MfImage *v = &views[i].ref;
        cp[i].cam = views[i].cam;
        if (!(rc = mf_image_alloc(&cp[i].ref, v->w, v->h, v->c)))
            memcpy(cp[i].ref.data, v->data, (size_t)v->w * v->h * v->c * sizeof *v->data);
    }
    MfRecon *r = NULL;
    if (!rc) rc = mf_recon_new(mesh, cp, n, &t, &r);
    for (int i = 0; cp && i < n; ++i) mf_image_free(&cp[i].ref); /* moved into r on success */
    free(cp);
    if (!rc) rc = mf_recon_run(r, NULL, dir);
    const MfEarlyStop *es = r ? mf_recon_early_stop(r) : NULL;
    if (!rc) rc = es && es->n > 0 ? MF_OK : mf_fail(MF_EARG, "the trial fit held no view out (%d views)", n);
    if (!rc) *psnr = es->psnr[es->n - 1];
    mf_recon_free(r);
    int rrc = mf_remove_tree(dir);
    return rc ? rc : rrc;
}

int mf_recon_geom_vessel_choose(const MfReconGeomOpts *o, MfReconGeomInfo *info, const MfReconView *views, int nviews,
                                const MfReconOpts *ro, const char *out_dir, MfMesh *mesh) {
    if (!info->vessel_pending) return MF_OK;
    char p[MF_PATH_MAX];
    MfMesh open[MF_VESSEL_MESHES - 1] = {{0}};
    const MfMesh *m[MF_VESSEL_MESHES] = {mesh, &open[0], &open[1]};
    int iters = o->vessel_trial_iters >= 0 ? o->vessel_trial_iters : ro->iters / 4, rc = MF_OK, pick = 0;
    iters = iters > 0 ? iters : 1;
    double t0 = mf_now();
    for (int k = 0; k < info->vessel_n && !rc; ++k) {
        char name[64];
        info->vessel_psnr[k] = NAN;
        if (vessel_broken(info, k)) continue; /* not tried: its mesh is not read either */
        if (k && !(rc = vessel_path(p, sizeof p, out_dir, info->source, k))) rc = mf_mesh_read(p, &open[k - 1]);
        snprintf(name, sizeof name, "geometry/trial-%s", k_vessel_name[k]);
        if (!rc && !(rc = mf_path_join(p, sizeof p, out_dir, name))) rc = trial_fit(m[k], views, nviews, ro, iters, p, &info->vessel_psnr[k]);
        /* an open mesh is kept only when it beats the closed one by the margin, and the other open one */
        if (!rc && k && info->vessel_psnr[k] > info->vessel_psnr[0] + MF_VESSEL_MARGIN_DB && info->vessel_psnr[k] > info->vessel_psnr[pick])
            pick = k;
    }
    info->vessel_trial_iters = iters;
    if (!rc) {
        info->vessel_chosen = k_vessel_name[pick];
        char held[MF_VESSEL_MESHES][32] = {"", "", ""};
        for (int k = 0; k < info->vessel_n; ++k)
            if (isfinite(info->vessel_psnr[k])) snprintf(held[k], sizeof held[k], "%s %.3f dB", k_vessel_name[k], info->vessel_psnr[k]);
            else snprintf(held[k], sizeof held[k], "%s not tried", k_vessel_name[k]);
        mf_log_info("geometry: vessel: trial fits of %d iterations in %.1f s, held-out PSNR %s, %s%s%s: keeping the %s mesh", iters,
                    mf_now() - t0, held[0], held[1], info->vessel_n > 2 ? ", " : "", held[2], k_vessel_name[pick]);
        rc = mf_obj_write(info->mesh_path, m[pick], NULL);
    }
    if (!rc && pick) {
        mf_mesh_free(mesh);
        *mesh = open[pick - 1];
        open[pick - 1] = (MfMesh){0};
    }
    for (int k = 0; k < MF_VESSEL_MESHES - 1; ++k) mf_mesh_free(&open[k]);
    info->vessel_pending = 0;
    return rc ? mf_fail_prefix(rc, "--vessel auto") : MF_OK;
}

void mf_recon_geom_to_json(const MfReconGeomInfo *info, cJSON *obj) {
    cJSON *g = cJSON_AddObjectToObject(obj, "geometry_result");
    cJSON_AddStringToObject(g, "source", info->source ? info->source : "");
    cJSON_AddStringToObject(g, "mesh", info->mesh_path);
    if (!info->source || !strcmp(info->source, "given")) return;
    cJSON_AddBoolToObject(g, "reused", info->reused);
    cJSON_AddNumberToObject(g, "hull_s", info->hull_s);     /* wall s: masks -> hull mesh (+ normals) */
    cJSON_AddNumberToObject(g, "unwrap_s", info->unwrap_s); /* wall s: the UV atlas */
    cJSON_AddNumberToObject(g, "triangles", info->hull_tris);
    if (info->reused) return;
    if (info->vessel.candidate) {
        cJSON *v = cJSON_AddObjectToObject(g, "vessel");
        cJSON *ax = cJSON_AddArrayToObject(v, "axis");
        float a[3] = {info->vessel.axis.x, info->vessel.axis.y, info->vessel.axis.z};
        for (int k = 0; k < 3; ++k) cJSON_AddItemToArray(ax, cJSON_CreateNumber(a[k]));
        cJSON_AddNumberToObject(v, "cap_fraction", info->vessel.cap_frac);
        cJSON_AddNumberToObject(v, "tilt_deg", info->vessel.tilt_deg);
        cJSON_AddNumberToObject(v, "carved_vertices", (double)info->vessel_carved[0]);
        cJSON_AddNumberToObject(v, "wall_cells", info->vessel_wall_cells[0]);
        cJSON_AddNumberToObject(v, "euler_closed", (double)info->vessel_euler[0]);
        cJSON_AddNumberToObject(v, "euler_open", (double)info->vessel_euler[1]);
        if (info->vessel_n > 2) { /* auto, a stated wall under MF_VESSEL_THICK_CELLS: the thick one too */
            cJSON_AddNumberToObject(v, "carved_vertices_thick", (double)info->vessel_carved[1]);
            cJSON_AddNumberToObject(v, "wall_cells_thick", info->vessel_wall_cells[1]);
            cJSON_AddNumberToObject(v, "euler_open_thick", (double)info->vessel_euler[2]);
        }
        if (info->vessel_trial_iters) { /* auto: the trials ran */
            static const char *const key[MF_VESSEL_MESHES] = {"holdout_psnr_closed", "holdout_psnr_open", "holdout_psnr_open_thick"};
            for (int k = 0; k < info->vessel_n; ++k) /* null: not tried */
                if (isfinite(info->vessel_psnr[k])) cJSON_AddNumberToObject(v, key[k], info->vessel_psnr[k]);
                else cJSON_AddNullToObject(v, key[k]);
            cJSON_AddNumberToObject(v, "trial_iters", info->vessel_trial_iters);
        }
        cJSON_AddStringToObject(v, "chosen", info->vessel_chosen ? info->vessel_chosen : "");
    }
    if (!strcmp(info->source, "dmtet")) {
        cJSON_AddNumberToObject(g, "geom_s", info->geom_s);   /* wall s: the DMTet steps */
        cJSON_AddNumberToObject(g, "step_ms", info->step_ms); /* wall ms per step */
        cJSON_AddNumberToObject(g, "rebuild_share", info->rebuild_share); /* of geom_s: extraction and Embree build */
        cJSON_AddNumberToObject(g, "steps", info->steps);
        cJSON_AddNumberToObject(g, "resumed_at", info->resumed_at); /* steps a resumed fit's state held */
        cJSON_AddNumberToObject(g, "mask_loss_first", info->loss_first);
        cJSON_AddNumberToObject(g, "mask_loss_last", info->loss_last);
        cJSON_AddNumberToObject(g, "rgb_loss_first", info->rgb_first); /* the colour term's logl1 (0 without it) */
        cJSON_AddNumberToObject(g, "rgb_loss_last", info->rgb_last);
        cJSON_AddNumberToObject(g, "dropped_components", info->dropped_components);
        cJSON_AddNumberToObject(g, "dmtet_res", info->dmtet_res);       /* the grid's resolution (--dmtet-res resolved) */
        cJSON_AddNumberToObject(g, "smooth_iters", info->smooth_iters); /* Taubin iterations of the extracted mesh */
        cJSON_AddNumberToObject(g, "grid_extent", info->hull.extent);
        cJSON_AddBoolToObject(g, "touches_border", info->hull.touches_border);
        cJSON_AddNumberToObject(g, "charts", info->atlas.charts);
        return;
    }
    cJSON_AddNumberToObject(g, "masked_views", info->hull.masked_views);
    cJSON_AddNumberToObject(g, "grid_extent", info->hull.extent);
    cJSON_AddNumberToObject(g, "extracted_triangles", info->hull.extracted_tris);
    cJSON_AddNumberToObject(g, "dropped_components", info->hull.dropped_components);
    cJSON_AddBoolToObject(g, "touches_border", info->hull.touches_border);
    cJSON_AddNumberToObject(g, "charts", info->atlas.charts);
    cJSON_AddNumberToObject(g, "forced_single_charts", info->atlas.forced_single);
}
