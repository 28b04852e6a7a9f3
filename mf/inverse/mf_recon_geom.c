#include "inverse/mf_recon_geom.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "io/mf_gltf_read.h"
#include "io/mf_obj.h"

int mf_recon_geom_resolve(const MfReconGeomOpts *o, int mesh_exists, const char **source) {
    const char *g = o->geometry;
    if (g && !strcmp(g, "dmtet"))
        return mf_fail(MF_EARG, "--geometry dmtet: DMTet optimisation (issue 14, pass 1) is not implemented; "
                                "use --geometry vhull (the visual hull of the masks) or a given mesh");
    if (g && strcmp(g, "given") && strcmp(g, "vhull"))
        return mf_fail(MF_EARG, "--geometry '%s': expected given, vhull or dmtet", g);
    if (!g) {
        g = mesh_exists ? "given" : "vhull";
        if (!mesh_exists) mf_log_info("geometry: the data set has no mesh and --geometry is not given: using vhull (the visual hull of the masks)");
    }
    *source = !strcmp(g, "given") ? "given" : "vhull";
    return MF_OK;
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
        mf_log_warn("%s: cannot be reused (%s); building the hull again", path, mf_error());
        return 0;
    }
    int ok = mesh->uv && mesh->nt > 0;
    for (int i = 0; ok && i < 3 * mesh->nv; ++i) ok = isfinite(mesh->pos[i]);
    for (int i = 0; ok && i < 2 * mesh->nv; ++i) ok = isfinite(mesh->uv[i]);
    if (!ok) {
        mf_log_warn("%s: cannot be reused (no UVs, no triangles or a non-finite value); building the hull again", path);
        mf_mesh_free(mesh);
    }
    return ok;
}

/* Hull (mf_vhull_mesh, as mf hull), smooth normals, unwrap (mf_uvatlas, as mf unwrap), written
 * atomically to path. */
static int build_hull(const MfReconGeomOpts *o, const MfCamera *cams, const MfImage *masks, int n, int tex_res,
                      const char *path, MfReconGeomInfo *info) {
    MfHullOpts ho = {o->hull_res, o->hull_extent, o->hull_smooth, o->hull_target_tris, o->hull_min_component};
    MfUvAtlasOpts uo = mf_uvatlas_defaults();
    uo.tex_res = tex_res;
    MfMesh hull = {0}, out = {0};
    double t0 = mf_now();
    int rc = mf_vhull_mesh(cams, masks, n, &ho, &hull, &info->hull);
    /* smooth vertex normals: the unwrap copies them across its seams, so shading stays continuous */
    if (rc == MF_OK) rc = mf_mesh_compute_normals(&hull);
    double t1 = mf_now();
    if (rc == MF_OK) rc = mf_uvatlas(&hull, &uo, &out, &info->atlas);
    info->hull_s = t1 - t0, info->unwrap_s = mf_now() - t1;
    if (rc == MF_OK && info->atlas.forced_single)
        mf_log_warn("geometry: unwrap: %d triangles became charts of their own", info->atlas.forced_single);
    if (rc == MF_OK && (rc = mf_mkdirs_for(path)) == MF_OK) rc = mf_obj_write(path, &out, NULL);
    if (rc == MF_OK)
        mf_log_info("geometry: visual hull of %d masked views, %d -> %d triangles in %.2f s; unwrapped into %d charts in %.2f s -> %s",
                    info->hull.masked_views, info->hull.extracted_tris, out.nt, info->hull_s, info->atlas.charts, info->unwrap_s, path);
    mf_mesh_free(&hull);
    mf_mesh_free(&out);
    return rc == MF_OK ? MF_OK : mf_fail_prefix(rc, "--geometry vhull");
}

int mf_recon_geom_mesh(const MfReconGeomOpts *o, const char *source, const char *given_path, const MfCamera *cams,
                       const MfImage *masks, int n, int tex_res, const char *out_dir, int resume, MfMesh *mesh,
                       MfReconGeomInfo *info) {
    memset(info, 0, sizeof *info);
    info->source = source;
    if (!strcmp(source, "given")) {
        snprintf(info->mesh_path, sizeof info->mesh_path, "%s", given_path);
        return read_given(given_path, mesh);
    }
    int rc = mf_path_join(info->mesh_path, sizeof info->mesh_path, out_dir, "geometry/vhull.obj");
    if (rc) return rc;
    if (resume && reuse_hull(info->mesh_path, mesh)) {
        info->reused = 1;
        info->hull_tris = mesh->nt;
        mf_log_info("geometry: reusing %s (%d triangles)", info->mesh_path, mesh->nt);
        return MF_OK;
    }
    if ((rc = build_hull(o, cams, masks, n, tex_res, info->mesh_path, info))) return rc;
    /* read back what was written: a resumed run reuses the file, so both optimise the same bytes */
    if ((rc = mf_mesh_read(info->mesh_path, mesh))) return rc;
    info->hull_tris = mesh->nt;
    return MF_OK;
}

void mf_recon_geom_to_json(const MfReconGeomInfo *info, cJSON *obj) {
    cJSON *g = cJSON_AddObjectToObject(obj, "geometry_result");
    cJSON_AddStringToObject(g, "source", info->source ? info->source : "");
    cJSON_AddStringToObject(g, "mesh", info->mesh_path);
    if (!info->source || strcmp(info->source, "vhull")) return;
    cJSON_AddBoolToObject(g, "reused", info->reused);
    cJSON_AddNumberToObject(g, "hull_s", info->hull_s);     /* wall s: masks -> hull mesh (+ normals) */
    cJSON_AddNumberToObject(g, "unwrap_s", info->unwrap_s); /* wall s: the UV atlas */
    cJSON_AddNumberToObject(g, "triangles", info->hull_tris);
    if (info->reused) return;
    cJSON_AddNumberToObject(g, "masked_views", info->hull.masked_views);
    cJSON_AddNumberToObject(g, "grid_extent", info->hull.extent);
    cJSON_AddNumberToObject(g, "extracted_triangles", info->hull.extracted_tris);
    cJSON_AddNumberToObject(g, "dropped_components", info->hull.dropped_components);
    cJSON_AddBoolToObject(g, "touches_border", info->hull.touches_border);
    cJSON_AddNumberToObject(g, "charts", info->atlas.charts);
    cJSON_AddNumberToObject(g, "forced_single_charts", info->atlas.forced_single);
}
