/* mf hull: the visual hull mesh of a data set's training views (mf/geom/mf_vhull.h), optionally
 * scored against the set's GT mesh (eval/ev_geom.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "datasets/ds_load.h"
#include "eval/ev_geom.h"
#include "geom/mf_vessel.h"
#include "geom/mf_vhull.h"
#include "io/mf_obj.h"
#include "io/mf_opts.h"

typedef struct {
    const char *out, *split;
    int res, smooth, target_tris, max_views, eval, samples, seed, vessel;
    float extent, min_component, vessel_wall;
} HullArgs;

#define A HullArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output mesh (required)", .alias = "-o", .meta = "OUT.obj"),
    MF_OPT_STR(A, split, "train", "views whose masks carve the hull"),
    MF_OPT_INT(A, res, MF_HULL_DEFAULT_RES, 4, 512, "grid cubes per axis"),
    MF_OPT_FLOAT(A, extent, MF_HULL_DEFAULT_EXTENT, 1e-6, 1e6, "side of the grid cube centred at the origin (enlarged 1.5x once when the hull touches it)"),
    MF_OPT_INT(A, smooth, MF_HULL_DEFAULT_SMOOTH, 0, 10000, "Taubin smoothing iterations"),
    MF_OPT_INT(A, target_tris, MF_HULL_DEFAULT_TARGET_TRIS, 0, 100000000, "decimate to at most this many triangles (0: keep all)"),
    MF_OPT_FLOAT(A, min_component, MF_HULL_DEFAULT_MIN_COMPONENT, 0, 1, "drop components with fewer than this fraction of the largest's triangles"),
    MF_OPT_INT(A, max_views, 0, 0, 100000, "use the first N views (0: all)"),
    MF_OPT_ENUM(A, vessel, 0, "closed|open", "closed: the hull as the masks give it; open: carved as an open vessel where the hull has a large flat top "
                "facing the cameras (mf_vessel.h; mf recon --vessel auto lets the images decide)"),
    MF_OPT_FLOAT(A, vessel_wall, MF_VESSEL_DEFAULT_WALL, 1e-4, 0.5, "--vessel open: wall thickness, x the hull's largest side"),
    MF_OPT_BOOL(A, eval, 0, "score against the data set's GT mesh and test views (Chamfer x1e3, normal errors, mask IoU)"),
    MF_OPT_INT(A, samples, 30000, 1, 100000000, "--eval: area samples of the hull"),
    MF_OPT_INT(A, seed, 1, 0, 2147483647, "--eval: sampling seed"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf hull DATA -o OUT.obj [--res N] [--extent S] [--smooth N] [--target-tris N] [--eval]\n"
    "Builds the soft visual hull of DATA's masks (alpha): per grid vertex the minimum over views of\n"
    "the bilinear mask - 0.5 (a view that does not see a vertex carves it only when the view's mask\n"
    "lies wholly inside its frame), extracts it by\n"
    "marching tets, welds, drops degenerate triangles and small components, smooths (Taubin) and\n"
    "decimates (meshoptimizer); writes OUT.obj (no UVs). Prints one CSV line on stdout:\n"
    "  scene,views,res,tris,hull_s[,chamfer,normal_deg,normal_1mcos,view_normal_deg,view_normal_1mcos,mask_iou]\n"
    "(--eval: Chamfer and point-pair normal error against the GT mesh; view_*: normal error and\n"
    "mask IoU over the pixels of the test views, eval/ev_geom.h).\n"
    "hull_s: wall seconds from the loaded masks to the mesh. Refuses data with fewer than 3\n"
    "masked views.\n";

__attribute__((constructor)) static void hull_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 1, NULL);
}

static int hull_run(const char *data, const HullArgs *a) {
    DsLoadOptions lo = {0, a->max_views, 1, 0, NULL, 0};
    DsViews dv;
    if (ds_load(data, a->split, &lo, &dv)) return MF_EXIT_FAIL;
    MfCamera *cams = malloc((size_t)dv.n * sizeof *cams);
    MfImage *masks = malloc((size_t)dv.n * sizeof *masks);
    MfMesh m = {0}, gt = {0};
    int rc = cams && masks ? MF_OK : mf_fail(MF_ENOMEM, "%s: out of memory", data);
    for (int v = 0; v < dv.n && rc == MF_OK; ++v) cams[v] = dv.views[v].cam, masks[v] = dv.views[v].rgba;
    MfHullOpts ho = {a->res, a->extent, a->smooth, a->target_tris, a->min_component, a->vessel ? a->vessel_wall : 0.0f};
    MfHullInfo hi;
    double t0 = mf_now();
    if (rc == MF_OK && (rc = mf_vhull_mesh(cams, masks, dv.n, &ho, &m, &hi)) != MF_OK) mf_fail_prefix(rc, "%s", data);
    double dt = mf_now() - t0;
    if (rc == MF_OK) rc = mf_obj_write(a->out, &m, NULL);
    EvGeomScore s;
    EvGeomViews gv;
    DsViews dt_views = {0};
    if (rc == MF_OK && a->eval) {
        if (!dv.mesh_path[0]) rc = mf_fail(MF_EARG, "%s: --eval: the data set has no GT mesh", data);
        else if ((rc = mf_obj_read(dv.mesh_path, &gt)) == MF_OK) rc = ev_geom_score(&gt, &m, a->samples, (uint64_t)a->seed, &s);
        if (rc == MF_OK) rc = ds_load(data, "test", &lo, &dt_views);
        if (rc == MF_OK) {
            MfCamera *tc = malloc((size_t)dt_views.n * sizeof *tc);
            rc = tc ? mf_mesh_compute_normals(&m) : mf_fail(MF_ENOMEM, "%s: out of memory", data);
            for (int v = 0; v < dt_views.n && rc == MF_OK; ++v) tc[v] = dt_views.views[v].cam;
            if (rc == MF_OK) rc = ev_geom_views(&gt, &m, tc, dt_views.n, &gv);
            free(tc);
        }
    }
    if (rc == MF_OK) {
        char name[MF_PATH_MAX];
        snprintf(name, sizeof name, "%s", dv.dir);
        for (size_t l = strlen(name); l > 1 && name[l - 1] == '/'; --l) name[l - 1] = '\0';
        const char *base = strrchr(name, '/');
        printf("%s,%d,%d,%d,%.3f", base ? base + 1 : name, dv.n, a->res, m.nt, dt);
        if (a->eval)
            printf(",%.4f,%.3f,%.5f,%.3f,%.5f,%.5f", s.chamfer, s.normal_deg, s.normal_1mcos, gv.normal_deg, gv.normal_1mcos, gv.mask_iou);
        printf("\n");
        mf_log_info("hull: %d masked views, grid side %g, %d -> %d triangles (%d floaters dropped) in %.2f s -> %s",
                    hi.masked_views, hi.extent, hi.extracted_tris, m.nt, hi.dropped_components, dt, a->out);
    }
    mf_mesh_free(&m);
    mf_mesh_free(&gt);
    free(cams), free(masks);
    ds_views_free(&dv);
    if (dt_views.views) ds_views_free(&dt_views);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

static int cmd_hull(int argc, char **argv) {
    HullArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_opts_parse(&bind, 1, argc, argv, 1, &p) ? MF_EXIT_USAGE : MF_EXIT_OK;
    if (!rc && p.print_config) rc = mf_cli_print_config(&bind, 1);
    else if (!rc && (!p.npos || !a.out)) {
        mf_fail(MF_EARG, "need DATA and -o OUT.obj (see mf hull --help)");
        rc = MF_EXIT_USAGE;
    } else if (!rc) rc = hull_run(p.pos[0], &a);
    mf_opts_parse_free(&p);
    return rc;
}

MF_COMMAND(hull, "hull", "visual hull mesh of a data set's masks (optionally scored against its GT mesh)", usage, cmd_hull)
