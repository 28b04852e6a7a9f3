/* mf eval-prior: the prior's 2D evaluation (MaterialFusion's Table 3) on a test-2d split: the
 * predictions of StableMaterial (mf/prior, each view alone and multi-view) and of the baselines
 * that need no training (baselines/bl_prior2d.h), scored and written by eval/ev_prior2d.h
 * (OUT/table2d.{md,csv,json}, examples2d.png). Each prior prediction is the mean of N samples. */
#include <stdio.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "datasets/ds_prior2d.h"
#include "eval/ev_prior2d.h"
#include "prior/mf_prior.h"

typedef struct {
    const char *dir, *out, *weights, *train;
    int samples, steps, seed, max_objects, views, no_mv;
    float guidance, retinex_sigma;
} EvalPriorArgs;

#define A EvalPriorArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output folder (required)", .alias = "-o", .meta = "OUT_DIR"),
    MF_OPT_STR(A, weights, NULL, "prior weights, a .mfck file or its folder", .meta = "CKPT",
               .unset = "$MF_PRIOR_WEIGHTS, else " MF_PRIOR_WEIGHTS_DEFAULT),
    MF_OPT_STR(A, train, "data/prior-train", "training split for the mean-ORM baseline (its complete samples)", .meta = "DIR"),
    MF_OPT_INT(A, samples, 10, 1, 10000, "samples averaged per prediction"),
    MF_OPT_INT(A, steps, 50, 1, MF_DIFF_T, "DDIM steps per sample"),
    MF_OPT_FLOAT(A, guidance, MF_PRIOR_GUIDANCE, 0, 100, "classifier-free guidance"),
    MF_OPT_INT(A, seed, 0, 0, 2147483647, "random seed (object o uses seed + o)"),
    MF_OPT_INT(A, max_objects, 0, 0, 1000000, "score only the first K objects (0: all)"),
    MF_OPT_INT(A, views, 4, 1, 1000, "3D split: test views per object (the first N of each scene)"),
    MF_OPT_FLOAT(A, retinex_sigma, 0, 0.01, 10000, "Retinex blur (std, pixels)", .meta = "PX", .unset = "R/8"),
    MF_OPT_BOOL(A, no_mv, 0, "skip StableMaterialMV (the multi-view pass)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[8192];
__attribute__((constructor)) static void eval_prior_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf eval-prior TEST2D_DIR|SPLIT_3D -o OUT_DIR [--weights CKPT] [--train DIR] [--samples N] [--steps S]\n"
                       "                     [--guidance G] [--seed S] [--max-objects K] [--views N] [--retinex-sigma PX] [--no-mv]\n"
                       "  2D evaluation of the prior (paper Table 3) on a test-2d split (prior-train layout, views of an\n"
                       "  object consecutive, manifest \"views_per_object\"), or on the objects of a 3D split (a folder of\n"
                       "  scene folders, no rgb/000000.png: each object's first --views test views with their GT albedo\n"
                       "  and ORM, box-filtered to the prior's resolution; adds objects.{md,csv}, per-object means).\n"
                       "  StableMaterial = each view alone, mean of N\n"
                       "  samples of S DDIM steps with guidance G; StableMaterialMV = the views of each object jointly.\n"
                       "  Baselines: input image as albedo, Retinex (rgb / Gaussian-blurred luminance), mean\n"
                       "  roughness/metallic of the --train split. Writes OUT_DIR/table2d.{md,csv,json} and examples2d.png.\n",
                       t, 1, NULL);
}

/* Mean roughness/metallic over the complete samples of a prior-train folder (the Train-mean ORM
 * baseline's fit). */
static int train_orm_mean(const char *dir, float *rough, float *metal) {
    int n = 0;
    for (;; ++n) {
        char path[MF_PATH_MAX];
        ds_prior2d_path(dir, "orm", n, path, sizeof path);
        if (!mf_file_exists(path)) break;
    }
    if (!n) return mf_fail(MF_EIO, "%s: no orm/000000.png (need the training split for the mean-ORM baseline; --train DIR)", dir);
    double sr = 0, sm = 0, cnt = 0;
    for (int i = 0; i < n; ++i) {
        MfImage im = {0};
        int rc = ds_prior2d_read(dir, "orm", i, MF_ENC_LINEAR, &im);
        if (rc) return rc;
        const MfImage *one = &im;
        float r, m;
        if (!bl_orm_mean(&one, 1, &r, &m)) { /* pixel-weighted: the image's mean times its inside count */
            size_t c = 0;
            for (size_t q = 0; q < (size_t)im.w * im.h; ++q) c += im.data[q * 4 + 3] > 0.5f;
            sr += (double)r * c, sm += (double)m * c, cnt += (double)c;
        }
        mf_image_free(&im);
    }
    if (!(cnt > 0)) return mf_fail(MF_EARG, "%s: no ORM pixel inside a mask", dir);
    *rough = (float)(sr / cnt), *metal = (float)(sm / cnt);
    mf_log_info("eval-prior: training-set mean roughness %.4f, metallic %.4f over %d samples of %s", *rough, *metal, n, dir);
    return MF_OK;
}

/* The prior's predictions for method m (EV_P2_SM or EV_P2_MV), one object per call (same seeds
 * for both); returns the wall seconds in *wall. */
static int run_prior(MfPrior *p, const EvPrior2dSplit *s, EvPrior2dPreds *pr, int m, int samples, int steps, float guidance,
                     int seed, double *wall) {
    MfProgress prog;
    double t0 = mf_now();
    int rc = MF_OK, objects = s->n / s->V;
    mf_progress_begin(&prog, ev_prior2d_methods[m], (size_t)objects);
    for (int o = 0; o < objects && !rc; ++o) {
        int i0 = o * s->V;
        rc = mf_prior_predict_mean(p, &s->rgb_raw[i0], s->V, s->V, m == EV_P2_MV, samples, steps, guidance,
                                   (uint64_t)seed + (uint64_t)o, &pr->albedo[m][i0], &pr->orm[m][i0]);
        mf_progress_add(&prog, 1);
    }
    mf_progress_end(&prog);
    *wall = mf_now() - t0;
    return rc;
}

static int eval_prior_run(EvalPriorArgs *a) {
    EvPrior2dSplit s = {0};
    EvPrior2dPreds pr = {0};
    EvPrior2dInfo info = {.test_dir = a->dir, .samples = a->samples, .steps = a->steps, .seed = a->seed,
                          .guidance = a->guidance, .retinex_sigma = a->retinex_sigma};
    MfPrior *p = NULL;
    EvTable t;
    ev_table_init(&t);
    char first[MF_PATH_MAX], wdefault[MF_PATH_MAX]; /* a 2D split's first input image; the default weights */
    mf_prior_default_weights(wdefault, sizeof wdefault);
    info.weights = a->weights ? a->weights : wdefault;
    int rc = ds_prior2d_path(a->dir, "rgb", 0, first, sizeof first);
    if (!rc) rc = mf_prior_load_path(info.weights, &p);
    if (!rc) rc = mf_file_exists(first) ? ev_prior2d_load(a->dir, a->max_objects, &s)
                                      : ev_prior2d_load_scenes(a->dir, p->cfg.ae.res, a->views, a->max_objects, &s);
    if (!rc) rc = train_orm_mean(a->train, &info.train_roughness, &info.train_metallic);
    if (!rc && p->cfg.ae.res != s.R)
        rc = mf_fail(MF_EARG, "%s: images are %d px, the prior works at %d px (generate test-2d at --res %d)", a->dir, s.R,
                     p->cfg.ae.res, p->cfg.ae.res);
    if (!rc) rc = ev_prior2d_preds_alloc(&pr, s.n, !a->no_mv);
    if (!rc) {
        mf_log_info("eval-prior: %d objects x %d views, %d samples of %d DDIM steps, guidance %.2f", s.n / s.V, s.V,
                    a->samples, a->steps, a->guidance);
        rc = run_prior(p, &s, &pr, EV_P2_SM, a->samples, a->steps, a->guidance, a->seed, &info.sm_wall_s);
        if (!rc && !a->no_mv) rc = run_prior(p, &s, &pr, EV_P2_MV, a->samples, a->steps, a->guidance, a->seed, &info.mv_wall_s);
    }
    if (!info.retinex_sigma) info.retinex_sigma = s.R / 8.0f;
    for (int i = 0; i < s.n && !rc; ++i)
        if (!(rc = bl_albedo_input(&s.rgb[i], &pr.albedo[EV_P2_INPUT][i])) &&
            !(rc = bl_albedo_retinex(&s.rgb[i], info.retinex_sigma, &pr.albedo[EV_P2_RETINEX][i])))
            rc = bl_orm_constant(&s.rgb[i], info.train_roughness, info.train_metallic, &pr.orm[EV_P2_MEAN_ORM][i]);
    if (!rc) rc = ev_prior2d_score(&s, &pr, &t);
    if (!rc) ev_prior2d_trust(&t, s.dataset, EV_P2_SM, info.trust);
    if (!rc) rc = ev_prior2d_write(a->out, &t, &s, &pr, &info);
    for (int m = 0; m < EV_PRIOR2D_NM && !rc; ++m) {
        printf("%-18s", ev_prior2d_methods[m]);
        for (int k = 0; k < EV_PRIOR2D_NK; ++k) {
            EvStat st = ev_table_stat(&t, ev_prior2d_methods[m], s.dataset, ev_prior2d_metrics[k]);
            if (st.n) printf("  %s %.4f", ev_prior2d_metrics[k], st.mean);
        }
        printf("\n");
    }
    if (!rc)
        printf("channel trust of StableMaterial (1 - MSE / Train-mean ORM's MSE): roughness %.4f metallic %.4f\n"
               "  (mf recon --method materialfusion --sds-trust-rough %.2f --sds-trust-metal %.2f)\n"
               "wrote %s/table2d.md (SM %.1f s, MV %.1f s)\n",
               info.trust[0], info.trust[1], info.trust[0], info.trust[1], a->out, info.sm_wall_s, info.mv_wall_s);
    ev_prior2d_preds_free(&pr);
    ev_table_free(&t);
    mf_prior_free(p);
    ev_prior2d_free(&s);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

static int cmd_eval_prior(int argc, char **argv) {
    EvalPriorArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 1, &p);
    if (rc >= 0) return rc;
    a.dir = p.npos ? p.pos[0] : NULL;
    if (!a.dir || !a.out) rc = MF_EXIT_USAGE, mf_fail(MF_EARG, "eval-prior: need TEST2D_DIR and -o OUT_DIR");
    else rc = eval_prior_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

MF_COMMAND(eval_prior, "eval-prior", "2D evaluation of the material prior against simple baselines (Table 3)",
           usage, cmd_eval_prior)
