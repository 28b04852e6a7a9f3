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
#include "inverse/mf_recon_opts.h"
#include "io/mf_obj.h"

static char usage[8192] =
    "usage: mf recon DATASET_DIR -o RESULT_DIR [--method nvdiffrecmc|materialfusion] [--mesh OBJ]\n"
    "                [--config FILE] [--split train] [--res N] [--max-views N] [--resume] [option VALUE ...]\n"
    "Recovers albedo (kd), ORM and the HDR environment light of the scene in DATASET_DIR (any format\n"
    "mf can load: bvault, NeRF-Synthetic, NeRFactor, Stanford-ORB capture) on a fixed mesh\n"
    "(default DATASET_DIR/mesh.obj; it must have UVs: a mesh without UVs is refused, unwrap it first).\n"
    "Writes RESULT_DIR/ albedo.png orm.png (normal.png) env.exr mesh.obj scene.glb log.csv run.json snapshots/\n"
    "checkpoint.mfck. --resume continues from RESULT_DIR/checkpoint.mfck and reaches the same result\n"
    "as an uninterrupted run (same build, options and thread count). --res N trains at N pixels\n"
    "(the images are box-downsampled; their size must be a multiple of N). Options are applied in\n"
    "order: the method's defaults, --config FILE (JSON, keys as below with underscores), flags.\n"
    "MaterialFusion (the baseline plus the SDS+ prior term, mf/fusion/mf_sds.h) adds:\n"
    "  --prior-weights F    prior weights, a .mfck file or its folder (default $MF_PRIOR_WEIGHTS, else the\n"
    "                       committed mf/prior/weights/prior.mfck)\n"
    "  --lambda-latent X    latent term weight (default 0.02)   --lambda-rgb X   RGB term weight (0.5)\n"
    "  --gamma-p P          gamma_i = 1 - (i/N)^P (default 1)    --gamma-const 1  gamma_i = 1 throughout\n"
    "  --k-views K          views per batch with the prior term (default 4)\n"
    "  --sds-every K        recompute the prior term every K iterations, hold its gradient between (default 4)\n"
    "Options of both methods:\n";

static int cmd_recon(int argc, char **argv) {
    const char *data = NULL, *out = NULL, *method = "nvdiffrecmc", *mesh_path = NULL, *config = NULL, *split = "train";
    int res = 0, max_views = 0, resume = 0, gamma_const = 0;
    MfReconOpts o = bl_nvdiffrecmc_opts();
    MfSdsOpts so = mf_sds_opts_default();
    char wdefault[MF_PATH_MAX];
    mf_prior_default_weights(wdefault, sizeof wdefault); /* $MF_PRIOR_WEIGHTS, else the committed weights */
    const char *weights = wdefault;
    /* config first, so flags given anywhere override it */
    for (int i = 1; i + 1 < argc; ++i)
        if (!strcmp(argv[i], "--config")) config = argv[i + 1];
    if (config && mf_recon_opts_load(&o, config)) return MF_EXIT_USAGE;
    for (int i = 1; i < argc; ++i) {
        int r;
        const char *dummy;
        if ((r = mf_opt_str(argc, argv, &i, "-o", &out)) || (r = mf_opt_str(argc, argv, &i, "--method", &method)) ||
            (r = mf_opt_str(argc, argv, &i, "--mesh", &mesh_path)) || (r = mf_opt_str(argc, argv, &i, "--config", &dummy)) ||
            (r = mf_opt_str(argc, argv, &i, "--split", &split)) || (r = mf_opt_int(argc, argv, &i, "--res", &res)) ||
            (r = mf_opt_int(argc, argv, &i, "--max-views", &max_views)) || (r = mf_opt_str(argc, argv, &i, "--prior-weights", &weights)) ||
            (r = mf_opt_float(argc, argv, &i, "--lambda-latent", &so.lambda_latent)) ||
            (r = mf_opt_float(argc, argv, &i, "--lambda-rgb", &so.lambda_rgb)) || (r = mf_opt_float(argc, argv, &i, "--gamma-p", &so.gamma_p)) ||
            (r = mf_opt_int(argc, argv, &i, "--gamma-const", &gamma_const)) || (r = mf_opt_int(argc, argv, &i, "--k-views", &so.k_views)) ||
            (r = mf_opt_int(argc, argv, &i, "--sds-every", &so.every)) ||
            (r = mf_recon_opts_parse_arg(&o, argc, argv, &i))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--resume")) { resume = 1; continue; }
        if (argv[i][0] == '-') { mf_fail(MF_EARG, "unknown option %s (see mf recon --help)", argv[i]); return MF_EXIT_USAGE; }
        if (data) { mf_fail(MF_EARG, "more than one data set given (%s, %s)", data, argv[i]); return MF_EXIT_USAGE; }
        data = argv[i];
    }
    if (!data || !out) { mf_fail(MF_EARG, "need DATASET_DIR and -o RESULT_DIR (see mf recon --help)"); return MF_EXIT_USAGE; }
    int is_mf = !strcmp(method, "materialfusion");
    if (!is_mf && strcmp(method, "nvdiffrecmc")) {
        mf_fail(MF_EARG, "--method %s: unknown method (available: nvdiffrecmc, materialfusion)", method);
        return MF_EXIT_USAGE;
    }
    so.gamma_const = gamma_const != 0;
    so.seed = mf_hash64(o.seed, 0x5d5);
    double t0 = mf_now();
    DsViews dv;
    DsLoadOptions lo = {0, max_views, 1, 0};
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
                         mf_recon_view(r, 0)->cam.w, mf_recon_view(r, 0)->cam.h, o.iters, o.batch, o.tex_res, o.env_w, o.env_h);
    MfReconHook hook = {mf_sds_hook, sds};
    if (!rc) rc = mf_recon_run(r, is_mf ? &hook : NULL, out);
    if (!rc) {
        cJSON *opts = cJSON_CreateObject();
        mf_recon_opts_to_json(&o, opts);
        cJSON_AddStringToObject(opts, "method", method);
        cJSON_AddStringToObject(opts, "mesh", mesh_path);
        double tf, ta;
        mf_recon_timing(r, &tf, &ta);
        cJSON_AddNumberToObject(opts, "forward_render_s", tf);
        cJSON_AddNumberToObject(opts, "adjoint_render_s", ta);
        cJSON_AddNumberToObject(opts, "adjoint_over_forward", tf > 0 ? ta / tf : 0.0);
        if (is_mf) {
            cJSON_AddStringToObject(opts, "prior_weights", weights);
            cJSON_AddNumberToObject(opts, "lambda_latent", so.lambda_latent);
            cJSON_AddNumberToObject(opts, "lambda_rgb", so.lambda_rgb);
            cJSON_AddNumberToObject(opts, "gamma_p", so.gamma_p);
            cJSON_AddNumberToObject(opts, "gamma_const", so.gamma_const);
            cJSON_AddNumberToObject(opts, "k_views", so.k_views);
            cJSON_AddNumberToObject(opts, "sds_every", so.every);
        }
        rc = mf_write_run_json(out, argc, argv, o.seed, mf_now() - t0, opts);
    }
    mf_recon_free(r);
    mf_sds_free(sds);
    mf_mesh_free(&mesh);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

__attribute__((constructor)) static void recon_usage(void) {
    MfReconOpts d = bl_nvdiffrecmc_opts();
    mf_recon_opts_usage(usage, sizeof usage, &d);
}

MF_COMMAND(recon, "recon", "recover materials and light of a scene on a given mesh", usage, cmd_recon)
