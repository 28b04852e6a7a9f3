/* mf recon: recovers albedo/ORM textures and the environment light of a data set's scene on a
 * given mesh (the inverse pipeline of mf/inverse; methods: the nvdiffrecmc-style baseline,
 * MaterialFusion once its prior term exists). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_nvdiffrecmc.h"
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
#include "io/mf_obj.h"

/* The command's own options (the reconstruction's and the prior term's are in their tables:
 * mf/inverse/mf_recon_opts.c, mf/fusion/mf_sds_opts.c). */
typedef struct {
    const char *out, *method, *mesh, *split, *prior_weights, *mask;
    int res, max_views, resume;
} ReconArgs;

#define A ReconArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "result folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, method, "nvdiffrecmc", "method", .choices = "nvdiffrecmc|materialfusion"),
    MF_OPT_STR(A, mesh, NULL, "mesh with UVs", .unset = "DATASET_DIR/mesh.obj", .meta = "OBJ"),
    MF_OPT_STR(A, split, "train", "which views to train on"),
    MF_OPT_STR(A, mask, NULL, "masks for frames without alpha (JPEG, RGB): DIR/<frame name>.png, first channel; a relative DIR is inside DATASET_DIR",
               .unset = "the images' alpha; RGB frames: alpha 1 with a warning", .meta = "DIR"),
    MF_OPT_INT(A, res, 0, 1, MF_OPT_RES_MAX, "train at N pixels wide (box-downsampled; the images' width must be a multiple)",
               .unset = "the images' size"),
    MF_OPT_INT(A, max_views, 0, 0, 1000000, "use at most N views (0: all)"),
    MF_OPT_BOOL(A, resume, 0, "continue from RESULT_DIR/checkpoint.mfck"),
    MF_OPT_STR(A, prior_weights, NULL, "materialfusion: prior weights, a .mfck file or its folder",
               .unset = "$MF_PRIOR_WEIGHTS, else mf/prior/weights/prior.mfck", .meta = "F"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Command options", k_args);

static char usage[16384];
static const char k_usage_head[] =
    "usage: mf recon DATASET_DIR -o RESULT_DIR [--method nvdiffrecmc|materialfusion] [--mesh OBJ]\n"
    "                [--config FILE] [--split train] [--mask DIR] [--res N] [--max-views N] [--resume] [option VALUE ...]\n"
    "Recovers albedo (kd), ORM and the HDR environment light of the scene in DATASET_DIR (any format\n"
    "mf can load: bvault, NeRF-Synthetic, NeRFactor, Stanford-ORB capture) on a fixed mesh\n"
    "(default DATASET_DIR/mesh.obj; it must have UVs: a mesh without UVs is refused, unwrap it first).\n"
    "Writes RESULT_DIR/ albedo.png orm.png (normal.png) env.exr mesh.obj scene.glb log.csv run.json snapshots/\n"
    "checkpoint.mfck. --resume continues from RESULT_DIR/checkpoint.mfck and reaches the same result\n"
    "as an uninterrupted run (same build, options and thread count). Options are applied in order:\n"
    "the defaults, --config FILE (a JSON object; its keys are the flags below with underscores,\n"
    "e.g. {\"lambda_rgb\": 0.5, \"tex_res\": 128}), then the flags. A value outside its range is refused\n"
    "before anything is written. run.json records every option's value.\n";

static int cmd_recon_run(int argc, char **argv, const MfOptParse *p, ReconArgs *a, MfReconOpts *po, MfSdsOpts *pso);

static int cmd_recon(int argc, char **argv) {
    ReconArgs a;
    MfReconOpts o = bl_nvdiffrecmc_opts();
    MfSdsOpts so = mf_sds_opts_default();
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind binds[] = {{&k_args_table, &a}, {&mf_recon_opt_table, &o}, {&mf_sds_opt_table, &so}};
    MfOptParse p;
    if (mf_opts_parse(binds, 3, argc, argv, 1, &p)) {
        mf_opts_parse_free(&p);
        return MF_EXIT_USAGE;
    }
    int rc = p.print_config ? mf_cli_print_config(binds, 3) : cmd_recon_run(argc, argv, &p, &a, &o, &so);
    mf_opts_parse_free(&p);
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
}

static int cmd_recon_run(int argc, char **argv, const MfOptParse *p, ReconArgs *a, MfReconOpts *po, MfSdsOpts *pso) {
    MfReconOpts o = *po;
    MfSdsOpts so = *pso;
    const char *data = p->npos ? p->pos[0] : NULL, *out = a->out, *method = a->method, *mesh_path = a->mesh, *split = a->split;
    int res = a->res, max_views = a->max_views, resume = a->resume;
    char wdefault[MF_PATH_MAX];
    mf_prior_default_weights(wdefault, sizeof wdefault); /* $MF_PRIOR_WEIGHTS, else the committed weights */
    const char *weights = a->prior_weights ? a->prior_weights : wdefault;
    if (!data || !out) { mf_fail(MF_EARG, "need DATASET_DIR and -o RESULT_DIR (see mf recon --help)"); return MF_EXIT_USAGE; }
    int is_mf = !strcmp(method, "materialfusion");
    if (so.t_min > so.t_max) {
        mf_fail(MF_EARG, "--t-min %d is above --t-max %d", so.t_min, so.t_max);
        return MF_EXIT_USAGE;
    }
    so.seed = mf_hash64(o.seed, 0x5d5);
    double t0 = mf_now();
    DsViews dv;
    DsLoadOptions lo = {0, max_views, 1, 0, a->mask};
    /* --res: find the downsample factor from the first image's size */
    if (ds_load(data, split, &lo, &dv)) return MF_EXIT_FAIL;
    if (res > 0 && res != dv.w) {
        if (dv.w % res || dv.h % (dv.w / res)) {
            mf_fail(MF_EARG, "--res %d: the images are %dx%d, not a multiple of %d", res, dv.w, dv.h, res);
            ds_views_free(&dv);
            return MF_EXIT_USAGE;
        }
        lo.downsample = dv.w / res; /* before freeing dv, which zeroes it */
        ds_views_free(&dv);
        if (ds_load(data, split, &lo, &dv)) return MF_EXIT_FAIL;
    }
    char mp[MF_PATH_MAX];
    if (!mesh_path) {
        if (dv.mesh_path[0]) snprintf(mp, sizeof mp, "%s", dv.mesh_path);
        else if (mf_path_join(mp, sizeof mp, data, "mesh.obj")) { ds_views_free(&dv); return MF_EXIT_FAIL; }
        mesh_path = mp;
    }
    MfMesh mesh;
    if (mf_obj_read(mesh_path, &mesh)) {
        ds_views_free(&dv);
        mf_fail_prefix(MF_EIO, "mesh (supply one with --mesh; geometry recovery is not implemented yet)");
        return MF_EXIT_FAIL;
    }
    if (!mesh.uv) {
        mf_fail(MF_EARG, "%s: the mesh has no UVs; mf recon refuses it (unwrap it first, e.g. in Blender)", mesh_path);
        mf_mesh_free(&mesh);
        ds_views_free(&dv);
        return MF_EXIT_FAIL;
    }
    /* a missing or mismatched weights file stops before the optimisation starts */
    MfSds *sds = NULL;
    if (is_mf) {
        MfPrior *prior = NULL;
        if (mf_prior_load_path(weights, &prior)) {
            mf_fail_prefix(MF_EIO, "materialfusion needs the prior's weights (MFCK version 1, mf-prior format %d; "
                           "make train-prior makes them; the nvdiffrecmc baseline runs without)", MF_PRIOR_FORMAT_VERSION);
            mf_mesh_free(&mesh);
            ds_views_free(&dv);
            return MF_EXIT_FAIL;
        }
        if (mf_sds_new(prior, &so, &sds)) {
            mf_prior_free(prior);
            mf_mesh_free(&mesh);
            ds_views_free(&dv);
            return MF_EXIT_USAGE;
        }
    }
    MfReconView *views = calloc((size_t)dv.n, sizeof *views);
    int rc = views ? MF_OK : mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; i < dv.n && !rc; ++i) {
        const MfImage *src = &dv.views[i].rgba;
        views[i].cam = dv.views[i].cam;
        if ((rc = mf_image_alloc(&views[i].ref, src->w, src->h, 4))) break;
        for (size_t p = 0; p < (size_t)src->w * src->h; ++p) {
            float a = src->data[4 * p + 3];
            for (int c = 0; c < 3; ++c) views[i].ref.data[4 * p + c] = src->data[4 * p + c] * a;
            views[i].ref.data[4 * p + 3] = a;
        }
    }
    int nviews = dv.n;
    ds_views_free(&dv);
    MfRecon *r = NULL;
    if (!rc) rc = mf_recon_new(&mesh, views, nviews, &o, &r);
    for (int i = 0; views && i < nviews; ++i) mf_image_free(&views[i].ref); /* moved into r on success */
    free(views);
    /* temporaries a killed run left in the result folder (its snapshots included) are of no
     * use to anyone: resume rewrites every output, so they are removed, not reused */
    int stale = 0;
    if (!rc && !(rc = mf_remove_stale_tmp(out, 3, &stale)) && stale)
        mf_log_info("%s: removed %d temporary file%s left by an interrupted run", out, stale, stale == 1 ? "" : "s");
    if (!rc && resume) {
        char ck[MF_PATH_MAX];
        if (!(rc = mf_path_join(ck, sizeof ck, out, "checkpoint.mfck"))) {
            if (mf_file_exists(ck)) {
                rc = mf_recon_load_checkpoint(r, ck);
                if (!rc) mf_log_info("resuming %s at iteration %d", ck, mf_recon_iteration(r));
            } else {
                mf_log_info("%s: no checkpoint, starting from scratch", ck);
            }
        }
    }
    if (!rc) mf_log_info("recon: %d views %dx%d, %d iterations, batch %d, textures %d^2, env %dx%d", nviews,
                         mf_recon_view(r, 0)->cam.w, mf_recon_view(r, 0)->cam.h, o.iters, o.batch, mf_recon_opts(r)->tex_res, o.env_w, o.env_h);
    MfReconHook hook = {mf_sds_hook, sds};
    int ran = 0;
    if (!rc) rc = mf_recon_run(r, is_mf ? &hook : NULL, out), ran = 1;
    if (ran) { /* run.json also when the guard stopped the run: what happened, and why */
        char stopped[1024];
        snprintf(stopped, sizeof stopped, "%s", rc ? mf_error() : "");
        cJSON *opts = cJSON_CreateObject();
        a->mesh = mesh_path, a->prior_weights = weights; /* as resolved */
        mf_opts_to_json(&k_args_table, a, opts);
        mf_opts_to_json(&mf_recon_opt_table, mf_recon_opts(r), opts); /* as resolved (tex_auto) */
        budgets_to_json(r, opts);
        if (is_mf) mf_opts_to_json(&mf_sds_opt_table, &so, opts);
        double tf, ta;
        mf_recon_timing(r, &tf, &ta);
        cJSON_AddNumberToObject(opts, "forward_render_s", tf);
        cJSON_AddNumberToObject(opts, "adjoint_render_s", ta);
        cJSON_AddNumberToObject(opts, "adjoint_over_forward", tf > 0 ? ta / tf : 0.0);
        if (is_mf) cJSON_AddNumberToObject(opts, "prior_s", mf_sds_seconds(sds)); /* wall s of the prior's work */
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
        int wrc = mf_write_run_json(out, argc, argv, o.seed, mf_now() - t0, opts);
        if (rc) mf_fail(rc, "%s", stopped); /* the run's error, not run.json's */
        else rc = wrc;
    }
    mf_recon_free(r);
    mf_sds_free(sds);
    mf_mesh_free(&mesh);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

__attribute__((constructor)) static void recon_usage(void) {
    const MfOptTable *t[] = {&k_args_table, &mf_sds_opt_table, &mf_recon_opt_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 3, NULL);
}

MF_COMMAND(recon, "recon", "recover materials and light of a scene on a given mesh", usage, cmd_recon)
