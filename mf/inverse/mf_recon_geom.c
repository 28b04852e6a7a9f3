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

/* Smooth normals, unwrap (mf_uvatlas, as mf unwrap), written atomically to path; m is freed. */
static int unwrap_write(MfMesh *m, int tex_res, const char *path, MfReconGeomInfo *info) {
    MfUvAtlasOpts uo = mf_uvatlas_defaults();
    uo.tex_res = tex_res;
    MfMesh out = {0};
    /* smooth vertex normals: the unwrap copies them across its seams, so shading stays continuous */
    int rc = mf_mesh_compute_normals(m);
    double t1 = mf_now();
    if (rc == MF_OK) rc = mf_uvatlas(m, &uo, &out, &info->atlas);
    info->unwrap_s = mf_now() - t1;
    if (rc == MF_OK && info->atlas.forced_single)
        mf_log_warn("geometry: unwrap: %d triangles became charts of their own", info->atlas.forced_single);
    if (rc == MF_OK && (rc = mf_mkdirs_for(path)) == MF_OK) rc = mf_obj_write(path, &out, NULL);
    if (rc == MF_OK) mf_log_info("geometry: %d triangles unwrapped into %d charts in %.2f s -> %s", out.nt, info->atlas.charts, info->unwrap_s, path);
    mf_mesh_free(m);
    mf_mesh_free(&out);
    return rc;
}

/* The hull_* options: the hull's grid and clean-up (the DMTet mesh's too, with dmtet_smooth). */
static MfHullOpts hull_opts(const MfReconGeomOpts *o) {
    return (MfHullOpts){o->hull_res, o->hull_extent, o->hull_smooth, o->hull_target_tris, o->hull_min_component};
}

/* Hull (mf_vhull_mesh, as mf hull), unwrapped and written to path. */
static int build_hull(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, int tex_res,
                      const char *path, MfReconGeomInfo *info) {
    MfHullOpts ho = hull_opts(o);
    MfMesh hull = {0};
    double t0 = mf_now();
    int rc = mf_vhull_mesh(cams, masks, n, &ho, &hull, &info->hull);
    info->hull_s = mf_now() - t0;
    if (rc == MF_OK)
        mf_log_info("geometry: visual hull of %d masked views, %d -> %d triangles in %.2f s", info->hull.masked_views,
                    info->hull.extracted_tris, hull.nt, info->hull_s);
    if (rc == MF_OK) rc = unwrap_write(&hull, tex_res, path, info);
    mf_mesh_free(&hull);
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

/* DMTet's mask term: soft hull (in cell units) -> geom_iters Adam steps -> clean mesh -> unwrap.
 * The fit's state goes to geometry/dmtet_state.mfck every MF_GEOM_STATE_EVERY steps; resume
 * continues from it; it is removed once dmtet.obj is written (which resume then reuses whole). */
#define MF_GEOM_STATE_EVERY 25
static int build_dmtet(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, int tex_res,
                       const char *out_dir, const char *path, int resume, MfReconGeomInfo *info) {
    MfTetGrid g = {0};
    float *sdf = NULL;
    MfGeomFitStep *log = o->geom_iters > 0 ? calloc((size_t)o->geom_iters, sizeof *log) : NULL;
    int rc = log || o->geom_iters == 0 ? MF_OK : mf_fail(MF_ENOMEM, "out of memory for %d steps' log", o->geom_iters);
    double t0 = mf_now();
    if (!rc) rc = mf_vhull_check_masks(masks, n, &info->hull.masked_views);
    /* the hull's grid: enlarged 1.5x once when the hull touches its border, as mf_vhull_mesh does */
    if (!rc) rc = mf_vhull_grid(cams, masks, n, o->dmtet_res, o->hull_extent, &g, &sdf, &info->hull.touches_border);
    info->hull.extent = g.cell * (float)g.res;
    size_t nv = rc ? 0 : mf_tetgrid_nverts(&g);
    /* mask - 0.5 in [-0.5, 0.5]: as a distance, in cells, so geom_lr is in cells per step */
    for (size_t v = 0; v < nv; ++v) sdf[v] *= g.cell;
    info->hull_s = mf_now() - t0;
    char state[MF_PATH_MAX];
    if (!rc && !(rc = mf_path_join(state, sizeof state, out_dir, "geometry/dmtet_state.mfck"))) rc = mf_mkdirs_for(state);
    MfGeomFitOpts fo = {.iters = o->geom_iters, .lr_sdf = o->geom_lr * g.cell, .sdf_reg = o->geom_sdf_reg, .views_per_step = o->geom_views,
                        .color = o->geom_color, .seed = o->geom_seed, .state = state, .state_every = MF_GEOM_STATE_EVERY,
                        .resume = resume, .resumed = &info->resumed_at};
    if (!rc && o->geom_iters > 0) {
        t0 = mf_now();
        rc = mf_geom_fit(&g, sdf, NULL, cams, masks, n, &fo, log, &info->steps);
        info->geom_s = mf_now() - t0;
        info->step_ms = info->steps > info->resumed_at ? 1e3 * info->geom_s / (info->steps - info->resumed_at) : 0;
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
        mf_log_info("geometry: DMTet, %s: %d^3 grid, %d steps of %d views in %.2f s (%.1f ms/step), "
                    "mask loss %.5f -> %.5f", o->geom_color > 0 ? "mask and colour terms" : "mask term only (no colour loss)", o->dmtet_res,
                    info->steps, o->geom_views ? o->geom_views : n, info->geom_s, info->step_ms, info->loss_first, info->loss_last);
    MfMesh m = {0};
    MfHullOpts ho = hull_opts(o);
    ho.smooth_iters = info->smooth_iters = o->dmtet_smooth >= 0 ? o->dmtet_smooth
                                              : (int)lround(100.0 * o->dmtet_res * o->dmtet_res / (64.0 * 64.0));
    if (!rc) rc = mf_vhull_extract_clean(&g, sdf, &ho, &m, NULL, &info->dropped_components);
    free(sdf), free(log);
    if (!rc) rc = unwrap_write(&m, tex_res, path, info);
    if (!rc && o->geom_iters > 0 && remove(state) != 0)
        rc = mf_fail(MF_EIO, "%s: cannot remove the finished fit's state: %s", state, strerror(errno));
    mf_mesh_free(&m);
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
        {"geometry/vhull.obj", "vhull"}, {"geometry/dmtet.obj", "dmtet"}, {"geometry/dmtet_state.mfck", "dmtet"},
        {"geom_log.csv", "dmtet"}};
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
               : build_hull(o, cams, masks, n, tex_res, info->mesh_path, info);
    if (rc) return rc;
    /* read back what was written: a resumed run reuses the file, so both optimise the same bytes */
    if ((rc = mf_mesh_read(info->mesh_path, mesh))) return rc;
    info->hull_tris = mesh->nt;
    if ((rc = remove_other_geometry(out_dir, source, NULL, 0))) mf_mesh_free(mesh);
    return rc;
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
    if (!strcmp(info->source, "dmtet")) {
        cJSON_AddNumberToObject(g, "geom_s", info->geom_s);   /* wall s: the DMTet steps */
        cJSON_AddNumberToObject(g, "step_ms", info->step_ms); /* wall ms per step */
        cJSON_AddNumberToObject(g, "steps", info->steps);
        cJSON_AddNumberToObject(g, "resumed_at", info->resumed_at); /* steps a resumed fit's state held */
        cJSON_AddNumberToObject(g, "mask_loss_first", info->loss_first);
        cJSON_AddNumberToObject(g, "mask_loss_last", info->loss_last);
        cJSON_AddNumberToObject(g, "rgb_loss_first", info->rgb_first); /* the colour term's logl1 (0 without it) */
        cJSON_AddNumberToObject(g, "rgb_loss_last", info->rgb_last);
        cJSON_AddNumberToObject(g, "dropped_components", info->dropped_components);
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
