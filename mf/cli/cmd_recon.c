/* mf recon: recovers albedo/ORM textures and the environment light of a data set's scene on a
 * given mesh or its visual hull (the inverse pipeline of mf/inverse, mesh from mf_recon_geom.h;
 * methods: the nvdiffrecmc-style baseline, MaterialFusion). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli_run_info.h"
#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_load.h"
#include "fusion/mf_sds.h"
#include "fusion/mf_sds_opts.h"
#include "inverse/mf_budget.h"
#include "inverse/mf_recon_opts.h"
#include "io/mf_gltf_read.h"

/* The command's own options (the reconstruction's, the geometry's and the prior term's are in
 * their tables: mf/inverse/mf_recon_opts.c, mf/fusion/mf_sds_opts.c). */
typedef struct {
    const char *out, *method, *mesh, *split, *prior_weights, *mask, *side;
    int res, max_views, resume;
} ReconArgs;

#define A ReconArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "result folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, method, "nvdiffrecmc", "method", .choices = "nvdiffrecmc|materialfusion"),
    MF_OPT_STR(A, mesh, NULL, "mesh with UVs (OBJ, or glTF .glb/.gltf: its mesh, +Z up)", .unset = "DATASET_DIR/mesh.obj", .meta = "OBJ"),
    MF_OPT_STR(A, split, "train", "which views to train on"),
    MF_OPT_STR(A, mask, NULL, "masks for frames without alpha (JPEG, RGB): DIR/<frame name>.png, first channel; a relative DIR is inside DATASET_DIR",
               .unset = "the images' alpha; RGB frames: alpha 1 with a warning", .meta = "DIR"),
    MF_OPT_INT(A, res, 0, 1, MF_OPT_RES_MAX, "train at N pixels wide (box-downsampled; the images' width must be a multiple)",
               .unset = "the images' size"),
    MF_OPT_INT(A, max_views, 0, 0, 1000000, "use at most N views (0: all)"),
    MF_OPT_STR(A, side, "all", "train only on the views whose camera lies on this side of the mesh's bounding-box centre "
               "(+z: above it); --max-views then takes the first N of those (the one-hemisphere few-view split)",
               .choices = "all|+x|-x|+y|-y|+z|-z"),
    MF_OPT_BOOL(A, resume, 0, "continue from RESULT_DIR/checkpoint.mfck"),
    MF_OPT_STR(A, prior_weights, NULL, "materialfusion: prior weights, a .mfck file or its folder",
               .unset = "$MF_PRIOR_WEIGHTS, else " MF_PRIOR_WEIGHTS_DEFAULT, .meta = "F"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Command options", k_args);

static char usage[16384];
static const char k_usage_head[] =
    "usage: mf recon DATASET_DIR -o RESULT_DIR [--method nvdiffrecmc|materialfusion] [--mesh OBJ] [--geometry given|vhull|dmtet]\n"
    "                [--config FILE] [--split train] [--mask DIR] [--res N] [--max-views N] [--side S] [--resume] [option VALUE ...]\n"
    "Recovers albedo (kd), ORM and the HDR environment light of the scene in DATASET_DIR (any format\n"
    "mf can load: bvault, NeRF-Synthetic, NeRFactor, Stanford-ORB capture) on a fixed mesh:\n"
    "--geometry given (the default when there is one): DATASET_DIR/mesh.obj or --mesh; it must have UVs (a mesh\n"
    "without UVs is refused, unwrap it first with mf unwrap); --geometry vhull (the default without a mesh): the visual\n"
    "hull of the training views' masks (as mf hull), unwrapped (as mf unwrap), written to RESULT_DIR/geometry/vhull.obj;\n"
    "--geometry dmtet: DMTet's mask term (silhouettes only, no colour loss) fits an SDF on a --dmtet-res grid, started\n"
    "from that hull, for --geom-iters steps, cleaned and unwrapped like the hull -> RESULT_DIR/geometry/dmtet.obj,\n"
    "per-step loss in RESULT_DIR/geom_log.csv. vhull.obj/dmtet.obj are reused by --resume; a run stopped inside\n"
    "DMTet's steps resumes from RESULT_DIR/geometry/dmtet_state.mfck (written every 25 steps, removed with dmtet.obj\n"
    "written). Another --geometry's files in RESULT_DIR (vhull.obj; dmtet.obj, dmtet_state.mfck, geom_log.csv) are\n"
    "removed, so it holds one run (with --resume: refused).\n"
    "Writes RESULT_DIR/ albedo.png orm.png (normal.png) env.exr mesh.obj scene.glb log.csv run.json snapshots/\n"
    "checkpoint.mfck. --resume continues from RESULT_DIR/checkpoint.mfck and reaches the same result\n"
    "as an uninterrupted run (same build, options and thread count). Options are applied in order:\n"
    "the defaults, --config FILE (a JSON object; its keys are the flags below with underscores,\n"
    "e.g. {\"lambda_rgb\": 0.5, \"tex_res\": 128}), then the flags. A value outside its range is refused\n"
    "before anything is written. run.json records every option's value.\n";

static int cmd_recon_run(int argc, char **argv, const MfOptParse *p, ReconArgs *a, MfReconOpts *po, MfSdsOpts *pso, MfReconGeomOpts *go);

static int cmd_recon(int argc, char **argv) {
    ReconArgs a;
    MfReconOpts o = mf_recon_opts_default();
    MfSdsOpts so = mf_sds_opts_default();
    MfReconGeomOpts go = mf_recon_geom_opts_default();
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind binds[] = {{&k_args_table, &a}, {&mf_recon_geom_opt_table, &go}, {&mf_recon_opt_table, &o}, {&mf_sds_opt_table, &so}};
    MfOptParse p;
    if (mf_opts_parse(binds, 4, argc, argv, 1, &p)) {
        mf_opts_parse_free(&p);
        return MF_EXIT_USAGE;
    }
    int rc = p.print_config ? mf_cli_print_config(binds, 4) : cmd_recon_run(argc, argv, &p, &a, &o, &so, &go);
    mf_opts_parse_free(&p);
    return rc;
}

/* The training views at --res (all of them with --side: its filter needs the mesh), and the mesh
 * path (--mesh, else the data set's, else DATA/mesh.obj) into mesh_path. */
static int load_views(const char *data, const ReconArgs *a, DsViews *dv, char mesh_path[MF_PATH_MAX]) {
    DsLoadOptions lo = {0, strcmp(a->side, "all") ? 0 : a->max_views, 1, 0, a->mask, 0};
    int rc = ds_load_width(data, a->split, &lo, a->res, dv);
    if (rc) return rc;
    if (a->mesh) snprintf(mesh_path, MF_PATH_MAX, "%s", a->mesh);
    else if (dv->mesh_path[0]) snprintf(mesh_path, MF_PATH_MAX, "%s", dv->mesh_path);
    else rc = mf_path_join(mesh_path, MF_PATH_MAX, data, "mesh.obj");
    if (rc) ds_views_free(dv);
    return rc;
}

/* --side S: only the views whose camera lies on that side of the mesh's bounding-box centre, then
 * the first --max-views of them (the one-sided few-view split). */
static int keep_side(DsViews *dv, const MfMesh *mesh, const ReconArgs *a) {
    if (!strcmp(a->side, "all")) return MF_OK;
    MfVec3 lo, hi, dir = {0, 0, 0};
    mf_mesh_bounds(mesh, &lo, &hi);
    float *axis = a->side[1] == 'x' ? &dir.x : a->side[1] == 'y' ? &dir.y : &dir.z;
    *axis = a->side[0] == '-' ? -1.0f : 1.0f;
    int rc = ds_views_keep_side(dv, mf_scale(mf_add(lo, hi), 0.5f), dir, a->max_views);
    if (!rc) mf_log_info("--side %s: training on %d view(s)", a->side, dv->n);
    return rc;
}

/* The views' premultiplied images move into views (n,); dv is freed. */
static int move_views(DsViews *dv, MfReconView **views, int *n) {
    ds_views_premultiply(dv);
    *views = calloc((size_t)dv->n, sizeof **views);
    int rc = *views ? MF_OK : mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; i < dv->n && !rc; ++i) {
        (*views)[i].cam = dv->views[i].cam;
        (*views)[i].ref = dv->views[i].rgba;
        memset(&dv->views[i].rgba, 0, sizeof dv->views[i].rgba);
    }
    *n = rc ? 0 : dv->n;
    ds_views_free(dv);
    return rc;
}

/* --geometry against the other options, before anything is loaded: vhull and dmtet take no --mesh; --side needs a given mesh (its filter uses the mesh's box, and the hull would
 * be carved by every loaded view). Called again with the resolved source (src). */
static int geom_args_ok(const ReconArgs *a, const MfReconGeomOpts *go, const char *src) {
    const char *g = src ? src : go->geometry;
    if (!src && mf_recon_geom_resolve(go, 1, &src)) return MF_EARG;
    int built = g && (!strcmp(g, "vhull") || !strcmp(g, "dmtet"));
    if (built && a->mesh) return mf_fail(MF_EARG, "--mesh %s is for --geometry given, not %s", a->mesh, g);
    if (go->dmtet_res > 0 && go->dmtet_res < 4)
        return mf_fail(MF_EARG, "--dmtet-res %d: expected 0 (the start's grid) or 4 to 512", go->dmtet_res);
    if (built && strcmp(a->side, "all"))
        return mf_fail(MF_EARG, "--side %s needs a given mesh (--geometry %s: the hull would be carved by every view)", a->side, g);
    return MF_OK;
}

/* The mesh (mf_recon_geom.h): the given one, or the hull of the loaded views' masks. */
static int load_mesh(const char *out, const ReconArgs *a, const MfReconGeomOpts *go, const MfReconOpts *o, const DsViews *dv,
                     const char *mesh_path, MfMesh *mesh, MfReconGeomInfo *gi) {
    const char *src = NULL;
    int rc = mf_recon_geom_resolve(go, a->mesh || mf_file_exists(mesh_path), &src);
    if (!rc) rc = geom_args_ok(a, go, src);
    MfCamera *cams = rc ? NULL : malloc((size_t)dv->n * sizeof *cams);
    MfImage *masks = rc ? NULL : malloc((size_t)dv->n * sizeof *masks);
    if (!rc && (!cams || !masks)) rc = mf_fail(MF_ENOMEM, "out of memory");
    for (int v = 0; !rc && v < dv->n; ++v) cams[v] = dv->views[v].cam, masks[v] = dv->views[v].rgba;
    if (!rc) rc = mf_recon_geom_mesh(go, src, mesh_path, cams, masks, dv->n, o->tex_res, out, a->resume, mesh, gi);
    free(cams), free(masks);
    return rc;
}

/* MaterialFusion's prior term; a missing or mismatched weights file stops before the
 * optimisation starts. Returns an exit code. */
static int load_sds(const char *weights, const MfSdsOpts *so, MfSds **sds) {
    MfPrior *prior = NULL;
    if (mf_prior_load_path(weights, &prior)) {
        mf_fail_prefix(MF_EIO, "materialfusion needs the prior's weights (MFCK version 1, mf-prior format %d; "
                       "make train-prior makes them; the nvdiffrecmc baseline runs without)", MF_PRIOR_FORMAT_VERSION);
        return MF_EXIT_FAIL;
    }
    if (mf_sds_new(prior, so, sds)) {
        mf_prior_free(prior);
        return MF_EXIT_USAGE;
    }
    return MF_EXIT_OK;
}

/* Temporaries a killed run left in the result folder (its snapshots included) are of no use to
 * anyone: resume rewrites every output, so they are removed, not reused. Then --resume. */
static int prepare_out(MfRecon *r, const char *out, int resume) {
    int stale = 0, rc = mf_remove_stale_tmp(out, 3, &stale);
    if (!rc && stale) mf_log_info("%s: removed %d temporary file%s left by an interrupted run", out, stale, stale == 1 ? "" : "s");
    char ck[MF_PATH_MAX];
    if (rc || !resume || (rc = mf_path_join(ck, sizeof ck, out, "checkpoint.mfck"))) return rc;
    if (!mf_file_exists(ck)) {
        mf_log_info("%s: no checkpoint, starting from scratch", ck);
        return MF_OK;
    }
    rc = mf_recon_load_checkpoint(r, ck);
    if (!rc) mf_log_info("resuming %s at iteration %d", ck, mf_recon_iteration(r));
    return rc;
}

/* run.json: what the budgets from the data decided (mf_budget.h). */
static void budgets_to_json(const MfRecon *r, cJSON *opts) {
    const MfEarlyStop *es = mf_recon_early_stop(r);
    if (es) {
        cJSON *e = cJSON_AddObjectToObject(opts, "early_stop_result");
        cJSON_AddNumberToObject(e, "stop_iter", es->stop_iter);
        cJSON_AddNumberToObject(e, "best_iter", es->best_iter);
        cJSON_AddNumberToObject(e, "best_holdout_psnr", es->best);
        cJSON *hv = cJSON_AddArrayToObject(e, "holdout_views");
        for (int i = 0; i < mf_recon_nviews(r); ++i)
            if (mf_recon_is_holdout(r, i)) cJSON_AddItemToArray(hv, cJSON_CreateNumber(i));
        cJSON *c = cJSON_AddArrayToObject(e, "curve"); /* [iteration, held-out PSNR dB] */
        for (int k = 0; k < es->n; ++k) {
            double row[2] = {es->iter[k], es->psnr[k]};
            cJSON_AddItemToArray(c, cJSON_CreateDoubleArray(row, 2));
        }
    }
    double frac;
    int ms = mf_recon_metal_state(r, &frac);
    if (mf_recon_opts(r)->metal_auto) {
        cJSON *m = cJSON_AddObjectToObject(opts, "metal_auto_result");
        cJSON_AddNumberToObject(m, "metal_fraction", frac);
        cJSON_AddStringToObject(m, "decision", ms < 0 ? "not tested" : (ms ? "metallic fixed at 0" : "metallic kept"));
    }
    if (mf_recon_opts(r)->tex_auto) cJSON_AddNumberToObject(opts, "tex_auto_median_side", mf_recon_texel_side(r));
    if (mf_recon_opts(r)->env_auto) cJSON_AddNumberToObject(opts, "env_auto_covered_fraction", mf_recon_env_covered(r));
    if (mf_recon_opts(r)->env_res_auto) {
        double rough;
        int w = mf_recon_env_res(r, &rough);
        cJSON *e = cJSON_AddObjectToObject(opts, "env_res_result");
        cJSON_AddNumberToObject(e, "roughness_p10", rough);
        cJSON_AddNumberToObject(e, "env_w", mf_recon_opts(r)->env_w); /* the chosen size once chosen */
        cJSON_AddNumberToObject(e, "env_h", mf_recon_opts(r)->env_h);
        cJSON_AddStringToObject(e, "decision", w < 0 ? "not tested (the run ended before the warm-up)" : "chosen");
    }
    if (mf_recon_opts(r)->spp_grow) {
        const int *at;
        int n, spp = mf_recon_spp_now(r, &at, &n);
        cJSON *g = cJSON_AddObjectToObject(opts, "spp_grow_result");
        cJSON_AddNumberToObject(g, "spp_final", spp);
        cJSON_AddItemToObject(g, "grew_at", cJSON_CreateIntArray(at, n));
    }
}

/* run.json's time_split (wall seconds) and cpu_split (CPU seconds of the process, all threads: the
 * cost without the time other processes held the cores) by disjoint stage (setup: from the start
 * to the loop; the loop's stages, mf_recon_times; the prior term's, mf_sds_times, in place of the
 * hook's total; output: the result files). Their sums are at most wall_seconds and cpu_seconds
 * (the rest: run.json itself, the progress bar, the loop's bookkeeping). One info line in the log
 * gives the wall split. */
static void split_to_json(const MfRecon *r, const MfSds *sds, MfStageTime setup, MfStageTime total, int cpu, cJSON *opts) {
    MfReconTimes rt;
    mf_recon_times(r, &rt);
    MfSdsTimes st;
    mf_sds_times(sds, &st);
#define PICK(x) (cpu ? (x).cpu : (x).wall)
    double sds_sum = PICK(st.cond) + PICK(st.aov) + PICK(st.encode) + PICK(st.denoise) + PICK(st.decode) + PICK(st.loss) +
                     PICK(st.enc_bwd) + PICK(st.aov_bwd) + PICK(st.apply);
    double hook_rest = PICK(rt.hook) - sds_sum; /* view picking, buffers: the hook outside the named stages */
    struct { const char *name; double v; } k[] = {
        {"setup_s", PICK(setup)}, {"image_s", PICK(rt.views)}, {"reg_s", PICK(rt.reg)}, {"step_s", PICK(rt.step)},
        {"io_s", PICK(rt.io)}, {"checks_s", PICK(rt.checks)}, {"output_s", PICK(rt.output)},
        {"prior_cond_s", PICK(st.cond)}, {"prior_aov_s", PICK(st.aov)}, {"prior_encode_s", PICK(st.encode)},
        {"prior_denoise_s", PICK(st.denoise)}, {"prior_decode_s", PICK(st.decode)}, {"prior_loss_s", PICK(st.loss)},
        {"prior_encoder_backward_s", PICK(st.enc_bwd)}, {"prior_aov_backward_s", PICK(st.aov_bwd)},
        {"prior_apply_s", PICK(st.apply)}, {"prior_rest_s", hook_rest > 0.0 ? hook_rest : 0.0},
    };
    double all = PICK(total), hook = PICK(rt.hook);
#undef PICK
    cJSON *o = cJSON_AddObjectToObject(opts, cpu ? "cpu_split" : "time_split");
    if (cpu) cJSON_AddNumberToObject(opts, "cpu_seconds", all);
    char line[1024];
    int len = snprintf(line, sizeof line, "recon: time split of %.1f s wall:", all);
    double sum = 0.0;
    for (size_t i = 0; i < sizeof k / sizeof k[0]; ++i) {
        if (!sds && !strncmp(k[i].name, "prior_", 6)) continue;
        cJSON_AddNumberToObject(o, k[i].name, k[i].v);
        sum += k[i].v;
        if (len < (int)sizeof line)
            len += snprintf(line + len, sizeof line - (size_t)len, " %.*s %.1f", (int)strlen(k[i].name) - 2, k[i].name, k[i].v);
    }
    if (len < (int)sizeof line)
        snprintf(line + len, sizeof line - (size_t)len, " (rest %.1f; prior term %.1f s = %.0f%%)", all - sum,
                 sds ? hook : 0.0, all > 0.0 && sds ? 100.0 * hook / all : 0.0);
    if (!cpu) mf_log_info("%s", line);
}

/* run.json, also when the guard stopped the run (rc != 0): what happened, and why. Every option
 * as resolved, render timings, the prior's seconds, recoveries. Returns rc or run.json's error. */
static int write_run(int rc, int argc, char **argv, const char *out, const ReconArgs *a, const MfReconOpts *o,
                     const MfSdsOpts *so, MfRecon *r, MfSds *sds, const MfReconGeomOpts *go, const MfReconGeomInfo *gi,
                     MfStageTime setup, MfStageClock start) {
    MfStageTime total = {0};
    mf_stage_lap(&total, &start);
    double wall = total.wall;
    char stopped[1024];
    snprintf(stopped, sizeof stopped, "%s", rc ? mf_error() : "");
    cJSON *opts = cJSON_CreateObject();
    mf_opts_to_json(&k_args_table, a, opts);
    MfReconGeomOpts g = *go;
    g.geometry = gi->source; /* as resolved */
    mf_opts_to_json(&mf_recon_geom_opt_table, &g, opts);
    mf_recon_geom_to_json(gi, opts);
    mf_opts_to_json(&mf_recon_opt_table, mf_recon_opts(r), opts); /* as resolved (tex_auto) */
    budgets_to_json(r, opts);
    if (sds) mf_opts_to_json(&mf_sds_opt_table, so, opts);
    double tf, ta;
    mf_recon_timing(r, &tf, &ta);
    cJSON_AddNumberToObject(opts, "forward_render_s", tf);
    cJSON_AddNumberToObject(opts, "adjoint_render_s", ta);
    cJSON_AddNumberToObject(opts, "adjoint_over_forward", tf > 0 ? ta / tf : 0.0);
    if (sds) cJSON_AddNumberToObject(opts, "prior_s", mf_sds_seconds(sds)); /* wall s of the prior's work */
    split_to_json(r, sds, setup, total, 0, opts);
    split_to_json(r, sds, setup, total, 1, opts);
    int nrec;
    const MfReconRecovery *rec = mf_recon_recoveries(r, &nrec);
    cJSON *ra = cJSON_AddArrayToObject(opts, "recoveries");
    for (int k = 0; k < nrec && k < 64; ++k) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "iter", rec[k].iter);
        cJSON_AddStringToObject(e, "reason", rec[k].reason);
        cJSON_AddNumberToObject(e, "lr_scale", rec[k].lr_scale);
        cJSON_AddItemToArray(ra, e);
    }
    cJSON_AddNumberToObject(opts, "lr_scale", mf_recon_lr_scale(r));
    if (rc) cJSON_AddStringToObject(opts, "stopped", stopped);
    int wrc = mf_write_run_json(out, argc, argv, o->seed, wall, opts);
    if (rc) return mf_fail(rc, "%s", stopped); /* the run's error, not run.json's */
    return wrc;
}

static int cmd_recon_run(int argc, char **argv, const MfOptParse *p, ReconArgs *a, MfReconOpts *po, MfSdsOpts *pso, MfReconGeomOpts *go) {
    MfReconOpts o = *po;
    MfSdsOpts so = *pso;
    const char *data = p->npos ? p->pos[0] : NULL, *out = a->out;
    char wdefault[MF_PATH_MAX], mesh_path[MF_PATH_MAX];
    mf_prior_default_weights(wdefault, sizeof wdefault); /* $MF_PRIOR_WEIGHTS, else the committed weights */
    const char *weights = a->prior_weights ? a->prior_weights : wdefault;
    if (!data || !out) { mf_fail(MF_EARG, "need DATASET_DIR and -o RESULT_DIR (see mf recon --help)"); return MF_EXIT_USAGE; }
    int is_mf = !strcmp(a->method, "materialfusion");
    if (so.t_min > so.t_max) {
        mf_fail(MF_EARG, "--t-min %d is above --t-max %d", so.t_min, so.t_max);
        return MF_EXIT_USAGE;
    }
    so.seed = mf_hash64(o.seed, 0x5d5);
    if (geom_args_ok(a, go, NULL)) return MF_EXIT_USAGE; /* before loading anything */
    MfStageClock start = mf_stage_clock();
    DsViews dv;
    MfReconView *views = NULL;
    MfMesh mesh = {0};
    MfReconGeomInfo gi;
    int nviews = 0, rc = load_views(data, a, &dv, mesh_path);
    if (rc) return rc == MF_EARG ? MF_EXIT_USAGE : MF_EXIT_FAIL; /* MF_EARG: --res does not divide the images */
    if ((rc = load_mesh(out, a, go, &o, &dv, mesh_path, &mesh, &gi)) || (rc = keep_side(&dv, &mesh, a)) ||
        (rc = move_views(&dv, &views, &nviews))) {
        ds_views_free(&dv);
        mf_mesh_free(&mesh);
        return MF_EXIT_FAIL;
    }
    if (o.vertex_lr < 0) {
        o.vertex_lr = mf_recon_geom_vertex_lr(gi.source, &mesh, o.normal_map);
        if (o.vertex_lr > 0) mf_log_info("recon: --geometry %s: the vertices move (--vertex-lr %g, the default on a recovered mesh; 0 fixes them)", gi.source, (double)o.vertex_lr);
    }
    if (o.normal_smooth < 0) o.normal_smooth = mf_recon_geom_normal_smooth(gi.source);
    if (mf_recon_geom_vessel_choose(go, &gi, views, nviews, &o, out, &mesh)) {
        for (int i = 0; i < nviews; ++i) mf_image_free(&views[i].ref);
        free(views);
        mf_mesh_free(&mesh);
        return MF_EXIT_FAIL;
    }
    MfSds *sds = NULL;
    MfRecon *r = NULL;
    int exit_code = is_mf ? load_sds(weights, &so, &sds) : MF_EXIT_OK;
    if (!exit_code) rc = mf_recon_new(&mesh, views, nviews, &o, &r);
    for (int i = 0; i < nviews; ++i) mf_image_free(&views[i].ref); /* moved into r on success */
    free(views);
    if (!exit_code && !rc) rc = prepare_out(r, out, a->resume);
    if (!exit_code && !rc)
        mf_log_info("recon: %d views %dx%d, %d iterations, batch %d, textures %d^2, env %dx%d", nviews, mf_recon_view(r, 0)->cam.w,
                    mf_recon_view(r, 0)->cam.h, o.iters, o.batch, mf_recon_opts(r)->tex_res, o.env_w, o.env_h);
    if (!exit_code && !rc) {
        MfReconHook hook = {mf_sds_hook, sds};
        MfStageTime setup = {0};
        MfStageClock sc = start;
        mf_stage_lap(&setup, &sc);
        rc = mf_recon_run(r, is_mf ? &hook : NULL, out);
        a->mesh = gi.mesh_path, a->prior_weights = weights; /* as resolved */
        if (sds) so.every = mf_sds_every(sds);
        rc = write_run(rc, argc, argv, out, a, &o, &so, r, sds, go, &gi, setup, start);
    }
    mf_recon_free(r);
    mf_sds_free(sds);
    mf_mesh_free(&mesh);
    return exit_code ? exit_code : rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

__attribute__((constructor)) static void recon_usage(void) {
    const MfOptTable *t[] = {&k_args_table, &mf_recon_geom_opt_table, &mf_sds_opt_table, &mf_recon_opt_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 4, NULL);
}

MF_COMMAND(recon, "recon", "recover materials and light of a scene on a given mesh or its visual hull", usage, cmd_recon)
