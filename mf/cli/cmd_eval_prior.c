/* mf eval-prior: the prior's 2D evaluation (MaterialFusion's Table 3) on a test-2d split
 * (prior-train layout, notes/contracts.md; manifest "views_per_object" consecutive views per
 * object). Methods: StableMaterial (each view alone), StableMaterialMV (the views of an object
 * denoised jointly), and baselines that need no training (bl_prior2d.h): the input image as
 * albedo, Retinex-style shading removal, the training set's mean roughness/metallic as ORM.
 * Each prediction is the mean of N samples (decoded maps averaged in the prior's [-1, 1] space).
 * Scores follow the evaluation layer's protocol: albedo aligned per channel in linear space by
 * the ratio of means inside the GT mask (ev_protocol_prepare, EV_ALIGN_MEAN), then sRGB, PSNR /
 * SSIM / L1 inside the mask; ORM on roughness and metallic (ev_protocol_prepare_orm), PSNR / L1
 * inside the mask. Writes OUT/table2d.md, OUT/table2d.csv (every record), OUT/table2d.json
 * (settings and timings) and OUT/examples2d.png (a grid of the first views). */
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "eval/ev_align.h"
#include "eval/ev_metrics.h"
#include "eval/ev_report.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "prior/mf_prior.h"

#define USAGE_EVAL_PRIOR \
    "usage: mf eval-prior TEST2D_DIR -o OUT_DIR [--weights CKPT] [--train DIR] [--samples N] [--steps S]\n" \
    "                     [--guidance G] [--seed S] [--max-objects K] [--retinex-sigma PX] [--no-mv]\n" \
    "  2D evaluation of the prior (paper Table 3) on a test-2d split (prior-train layout, views of an\n" \
    "  object consecutive, manifest \"views_per_object\"). StableMaterial = each view alone, mean of N\n" \
    "  samples (default 10) of S DDIM steps (default 50), guidance G (default 3); StableMaterialMV = the\n" \
    "  views of each object jointly. Baselines: input image as albedo, Retinex (rgb / Gaussian-blurred\n" \
    "  luminance, sigma default R/8 px), mean roughness/metallic of the --train split (default\n" \
    "  data/prior-train; its complete samples). Writes OUT_DIR/table2d.{md,csv,json} and examples2d.png.\n"

#define NM 5
static const char *METHODS[NM] = {"StableMaterial", "StableMaterialMV", "Input image", "Retinex", "Train-mean ORM"};
static const char *METRICS[5] = {"albedo_psnr", "albedo_ssim", "albedo_l1", "orm_psnr", "orm_l1"};

typedef struct {
    int n, V, R;
    MfImage *rgb_raw, *rgb, *albedo, *orm; /* (n,) each: raw codes / linear / linear / linear, RGBA */
} Split;

static void split_free(Split *s) {
    for (int i = 0; i < s->n; ++i) {
        if (s->rgb_raw) mf_image_free(&s->rgb_raw[i]);
        if (s->rgb) mf_image_free(&s->rgb[i]);
        if (s->albedo) mf_image_free(&s->albedo[i]);
        if (s->orm) mf_image_free(&s->orm[i]);
    }
    free(s->rgb_raw), free(s->rgb), free(s->albedo), free(s->orm);
    memset(s, 0, sizeof *s);
}

static int read_sample(const char *dir, const char *kind, int i, MfEncoding enc, MfImage *out) {
    char rel[64], path[MF_PATH_MAX];
    snprintf(rel, sizeof rel, "%s/%06d.png", kind, i);
    mf_path_join(path, sizeof path, dir, rel);
    int rc = mf_image_read(path, enc, out);
    if (!rc && out->c != 4) {
        mf_image_free(out);
        rc = mf_fail(MF_EFORMAT, "%s: expected an RGBA image", path);
    }
    return rc;
}

/* manifest: count, views_per_object (default 1); n = whole objects only. */
static int split_load(const char *dir, int max_objects, Split *s) {
    char path[MF_PATH_MAX], *txt = NULL;
    size_t len;
    mf_path_join(path, sizeof path, dir, "manifest.json");
    int rc = mf_read_file(path, &txt, &len);
    if (rc) return rc;
    cJSON *m = cJSON_Parse(txt);
    free(txt);
    const cJSON *cn = cJSON_GetObjectItemCaseSensitive(m, "count"),
                *cv = cJSON_GetObjectItemCaseSensitive(m, "views_per_object");
    int count = cJSON_IsNumber(cn) ? cn->valueint : 0, V = cJSON_IsNumber(cv) ? cv->valueint : 1;
    cJSON_Delete(m);
    if (count < 1 || V < 1 || count < V) return mf_fail(MF_EFORMAT, "%s: expected \"count\" >= \"views_per_object\" >= 1", path);
    int objects = count / V;
    if (max_objects > 0 && objects > max_objects) objects = max_objects;
    s->n = objects * V, s->V = V;
    s->rgb_raw = calloc((size_t)s->n, sizeof(MfImage)), s->rgb = calloc((size_t)s->n, sizeof(MfImage));
    s->albedo = calloc((size_t)s->n, sizeof(MfImage)), s->orm = calloc((size_t)s->n, sizeof(MfImage));
    if (!s->rgb_raw || !s->rgb || !s->albedo || !s->orm) return mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    for (int i = 0; i < s->n && !rc; ++i) {
        if (!(rc = read_sample(dir, "rgb", i, MF_ENC_LINEAR, &s->rgb_raw[i])) &&
            !(rc = read_sample(dir, "rgb", i, MF_ENC_SRGB, &s->rgb[i])) &&
            !(rc = read_sample(dir, "albedo", i, MF_ENC_SRGB, &s->albedo[i])))
            rc = read_sample(dir, "orm", i, MF_ENC_LINEAR, &s->orm[i]);
        if (!rc && i == 0) s->R = s->albedo[0].w;
        if (!rc && (s->rgb[i].w != s->R || s->rgb[i].h != s->R || s->albedo[i].h != s->R || s->orm[i].w != s->R ||
                    s->orm[i].h != s->R))
            rc = mf_fail(MF_EFORMAT, "%s: sample %d: expected %dx%d images of every kind", dir, i, s->R, s->R);
    }
    return rc;
}

/* Mean roughness/metallic over the complete samples of a prior-train folder. */
static int train_orm_mean(const char *dir, float *rough, float *metal) {
    int n = 0;
    for (;; ++n) {
        char rel[64], path[MF_PATH_MAX];
        snprintf(rel, sizeof rel, "orm/%06d.png", n);
        mf_path_join(path, sizeof path, dir, rel);
        if (!mf_file_exists(path)) break;
    }
    if (!n) return mf_fail(MF_EIO, "%s: no orm/000000.png (need the training split for the mean-ORM baseline; --train DIR)", dir);
    double sr = 0, sm = 0, cnt = 0;
    for (int i = 0; i < n; ++i) {
        MfImage im = {0};
        int rc = read_sample(dir, "orm", i, MF_ENC_LINEAR, &im);
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

/* Prior predictions for items [i0, i0 + nv) of the split: mean of S samples per item, as linear
 * RGBA images (albedo, ORM). joint: the nv items are whole objects of V views, denoised jointly. */
static int predict(MfPrior *p, const Split *s, int i0, int nv, int joint, int S, int steps, float guidance,
                   uint64_t seed, MfImage *alb, MfImage *orm) {
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, V = joint ? s->V : 1, B = S * nv, rc = MF_OK;
    size_t isz = (size_t)3 * R * R, hw = (size_t)R * R, zsz = (size_t)zc * h * h;
    float *rgb = malloc((size_t)B * isz * sizeof(float)), *mask = malloc((size_t)nv * hw * sizeof(float));
    float *zmat = malloc((size_t)B * 2 * zsz * sizeof(float)), *zk = malloc((size_t)B * zsz * sizeof(float));
    float *dec = malloc((size_t)B * isz * sizeof(float)), *mean = malloc((size_t)nv * isz * sizeof(float));
    if (!rgb || !mask || !zmat || !zk || !dec || !mean) rc = mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    /* item b: joint -> (object o, sample k, view v) with b = (o * S + k) * V + v; else b = j * S + k */
    for (int j = 0; j < nv && !rc; ++j) {
        const MfImage *im = &s->rgb_raw[i0 + j];
        float *one = rgb; /* prepare once into the first slot, then copy */
        mf_prior_prepare_image(im->data, im->w, im->h, R, one, mask + j * hw);
        float *tmp = malloc(isz * sizeof(float));
        if (!tmp) {
            rc = mf_fail(MF_ENOMEM, "eval-prior: out of memory");
            break;
        }
        memcpy(tmp, one, isz * sizeof(float));
        for (int k = 0; k < S; ++k) {
            int b = joint ? ((j / V) * S + k) * V + j % V : j * S + k;
            memcpy(rgb + (size_t)b * isz, tmp, isz * sizeof(float));
        }
        free(tmp);
    }
    if (!rc) rc = mf_prior_sample(p, rgb, B, V, joint, steps, guidance, seed, zmat);
    for (int kind = 0; kind < 2 && !rc; ++kind) {
        for (int b = 0; b < B; ++b) memcpy(zk + b * zsz, zmat + ((size_t)b * 2 + kind) * zsz, zsz * sizeof(float));
        if ((rc = mf_prior_decode(p, zk, B, dec))) break;
        memset(mean, 0, (size_t)nv * isz * sizeof(float));
        for (int b = 0; b < B; ++b) {
            int j = joint ? (b / (S * V)) * V + b % V : b / S;
            for (size_t q = 0; q < isz; ++q) mean[j * isz + q] += dec[b * isz + q] / (float)S;
        }
        for (int j = 0; j < nv && !rc; ++j) {
            MfImage *out = kind ? &orm[i0 + j] : &alb[i0 + j];
            if (mf_image_alloc(out, R, R, 4)) {
                rc = mf_fail(MF_ENOMEM, "eval-prior: out of memory");
                break;
            }
            for (size_t q = 0; q < hw; ++q) {
                float a = mask[j * hw + q];
                for (int c = 0; c < 3; ++c) {
                    float v = a > 1e-3f ? 0.5f * (mean[j * isz + c * hw + q] / a + 1.0f) : 0.0f;
                    v = v < 0 ? 0 : v > 1 ? 1 : v;
                    if (kind && c == 0) v = 1.0f;
                    out->data[q * 4 + c] = kind ? v : mf_srgb_to_linear(v);
                }
                out->data[q * 4 + 3] = a;
            }
        }
    }
    free(rgb), free(mask), free(zmat), free(zk), free(dec), free(mean);
    return rc;
}

static int score(EvTable *t, const char *method, const char *scene, const MfImage *alb, const MfImage *orm,
                 const MfImage *gt_alb, const MfImage *gt_orm) {
    int rc = MF_OK;
    if (alb) {
        MfImage po = {0}, go = {0};
        double ps, ss, l1;
        rc = ev_protocol_prepare(alb, gt_alb, gt_alb, EV_ALIGN_MEAN, &po, &go, NULL, NULL);
        if (!rc) rc = ev_psnr(&po, &go, gt_alb, &ps);
        if (!rc) rc = ev_ssim(&po, &go, gt_alb, &ss);
        if (!rc) rc = ev_l1(&po, &go, gt_alb, &l1);
        if (!rc) rc = ev_table_add(t, method, "test-2d", scene, "albedo_psnr", ps);
        if (!rc) rc = ev_table_add(t, method, "test-2d", scene, "albedo_ssim", ss);
        if (!rc) rc = ev_table_add(t, method, "test-2d", scene, "albedo_l1", l1);
        mf_image_free(&po), mf_image_free(&go);
        if (rc) return mf_fail_prefix(rc, "eval-prior: %s, sample %s", method, scene);
    }
    if (orm) {
        MfImage po = {0}, go = {0};
        double ps, l1;
        rc = ev_protocol_prepare_orm(orm, gt_orm, gt_alb, &po, &go);
        if (!rc) rc = ev_psnr(&po, &go, gt_alb, &ps);
        if (!rc) rc = ev_l1(&po, &go, gt_alb, &l1);
        if (!rc) rc = ev_table_add(t, method, "test-2d", scene, "orm_psnr", ps);
        if (!rc) rc = ev_table_add(t, method, "test-2d", scene, "orm_l1", l1);
        mf_image_free(&po), mf_image_free(&go);
        if (rc) return mf_fail_prefix(rc, "eval-prior: %s, sample %s", method, scene);
    }
    return rc;
}

static void free_images(MfImage *im, int n) {
    if (!im) return;
    for (int i = 0; i < n; ++i) mf_image_free(&im[i]);
    free(im);
}

static int cmd_eval_prior(int argc, char **argv) {
    const char *dir = NULL, *out = NULL, *weights = NULL, *train = "data/prior-train";
    int samples = 10, steps = 50, seed = 0, max_objects = 0, no_mv = 0;
    float guidance = MF_PRIOR_GUIDANCE, sigma = 0;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "-o", &out)) || (r = mf_opt_str(argc, argv, &i, "--weights", &weights)) ||
            (r = mf_opt_str(argc, argv, &i, "--train", &train)) || (r = mf_opt_int(argc, argv, &i, "--samples", &samples)) ||
            (r = mf_opt_int(argc, argv, &i, "--steps", &steps)) || (r = mf_opt_int(argc, argv, &i, "--seed", &seed)) ||
            (r = mf_opt_int(argc, argv, &i, "--max-objects", &max_objects)) ||
            (r = mf_opt_float(argc, argv, &i, "--guidance", &guidance)) ||
            (r = mf_opt_float(argc, argv, &i, "--retinex-sigma", &sigma))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--no-mv")) no_mv = 1;
        else if (argv[i][0] != '-' && !dir) dir = argv[i];
        else {
            mf_fail(MF_EARG, "eval-prior: unknown argument '%s'", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (!dir || !out || samples < 1 || steps < 1 || steps > MF_DIFF_T) {
        mf_fail(MF_EARG, "eval-prior: need TEST2D_DIR, -o OUT_DIR, --samples >= 1 and --steps in 1..%d", MF_DIFF_T);
        return MF_EXIT_USAGE;
    }
    Split s = {0};
    MfPrior *p = NULL;
    EvTable t;
    ev_table_init(&t);
    MfImage *sa = NULL, *so = NULL, *ma = NULL, *mo = NULL, *ia = NULL, *ra = NULL, *co = NULL;
    float rough = 0, metal = 0;
    double t_sv = 0, t_mv = 0;
    int rc = split_load(dir, max_objects, &s);
    if (!rc) rc = train_orm_mean(train, &rough, &metal);
    if (!rc) rc = mf_prior_load_path(weights, &p);
    if (!rc && p->cfg.ae.res != s.R)
        rc = mf_fail(MF_EARG, "%s: images are %d px, the prior works at %d px (generate test-2d at --res %d)", dir, s.R,
                     p->cfg.ae.res, p->cfg.ae.res);
    int n = s.n;
    if (!rc) {
        sa = calloc((size_t)n, sizeof(MfImage)), so = calloc((size_t)n, sizeof(MfImage));
        ma = calloc((size_t)n, sizeof(MfImage)), mo = calloc((size_t)n, sizeof(MfImage));
        ia = calloc((size_t)n, sizeof(MfImage)), ra = calloc((size_t)n, sizeof(MfImage));
        co = calloc((size_t)n, sizeof(MfImage));
        if (!sa || !so || !ma || !mo || !ia || !ra || !co) rc = mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    }
    if (!rc) {
        mf_log_info("eval-prior: %d objects x %d views, %d samples of %d DDIM steps, guidance %.2f", n / s.V, s.V, samples,
                    steps, guidance);
        MfProgress prog;
        double t0 = mf_now();
        /* StableMaterial: one object's views per call (independent items), same seeds as MV */
        mf_progress_begin(&prog, "StableMaterial", (size_t)(n / s.V));
        for (int o = 0; o < n / s.V && !rc; ++o) {
            rc = predict(p, &s, o * s.V, s.V, 0, samples, steps, guidance, (uint64_t)seed + (uint64_t)o, sa, so);
            mf_progress_add(&prog, 1);
        }
        mf_progress_end(&prog);
        t_sv = mf_now() - t0;
        if (!no_mv) {
            t0 = mf_now();
            mf_progress_begin(&prog, "StableMaterialMV", (size_t)(n / s.V));
            for (int o = 0; o < n / s.V && !rc; ++o) {
                rc = predict(p, &s, o * s.V, s.V, 1, samples, steps, guidance, (uint64_t)seed + (uint64_t)o, ma, mo);
                mf_progress_add(&prog, 1);
            }
            mf_progress_end(&prog);
            t_mv = mf_now() - t0;
        }
    }
    if (!sigma) sigma = s.R / 8.0f;
    for (int i = 0; i < n && !rc; ++i) {
        char scene[16];
        snprintf(scene, sizeof scene, "%06d", i);
        if ((rc = bl_albedo_input(&s.rgb[i], &ia[i])) || (rc = bl_albedo_retinex(&s.rgb[i], sigma, &ra[i])) ||
            (rc = bl_orm_constant(&s.rgb[i], rough, metal, &co[i])))
            break;
        if ((rc = score(&t, METHODS[0], scene, &sa[i], &so[i], &s.albedo[i], &s.orm[i]))) break;
        if (!no_mv && (rc = score(&t, METHODS[1], scene, &ma[i], &mo[i], &s.albedo[i], &s.orm[i]))) break;
        if ((rc = score(&t, METHODS[2], scene, &ia[i], NULL, &s.albedo[i], &s.orm[i]))) break;
        if ((rc = score(&t, METHODS[3], scene, &ra[i], NULL, &s.albedo[i], &s.orm[i]))) break;
        if ((rc = score(&t, METHODS[4], scene, NULL, &co[i], &s.albedo[i], &s.orm[i]))) break;
    }
    char path[MF_PATH_MAX], caption[768];
    const char *ds[1] = {"test-2d"};
    if (!rc) rc = mf_mkdirs(out);
    if (!rc) {
        snprintf(caption, sizeof caption,
                 "Prior 2D evaluation (paper Table 3) on %s: %d objects x %d views at %d px; mean of %d samples "
                 "(%d DDIM steps, guidance %.1f) per view; albedo aligned per channel (ratio of means, linear) "
                 "inside the mask, then sRGB; ORM = roughness and metallic; metrics inside the mask; mean over "
                 "views with 95%% CI. Baselines need no training (Retinex sigma %.1f px; training-set mean "
                 "roughness %.3f, metallic %.3f).",
                 dir, n / s.V, s.V, s.R, samples, steps, guidance, sigma, rough, metal);
        mf_path_join(path, sizeof path, out, "table2d.md");
        rc = ev_table_write_markdown(&t, path, caption, METHODS, NM, ds, 1, METRICS, 5);
    }
    if (!rc) {
        mf_path_join(path, sizeof path, out, "table2d.csv");
        rc = ev_table_write_csv(&t, path);
    }
    if (!rc) {
        char js[1024];
        int l = snprintf(js, sizeof js,
                         "{\"test_dir\":\"%s\",\"objects\":%d,\"views\":%d,\"resolution\":%d,\"samples\":%d,"
                         "\"ddim_steps\":%d,\"guidance\":%.3f,\"seed\":%d,\"retinex_sigma\":%.3f,"
                         "\"train_mean_roughness\":%.5f,\"train_mean_metallic\":%.5f,"
                         "\"stablematerial_wall_s\":%.1f,\"stablematerialmv_wall_s\":%.1f}\n",
                         dir, n / s.V, s.V, s.R, samples, steps, guidance, seed, sigma, rough, metal, t_sv, t_mv);
        mf_path_join(path, sizeof path, out, "table2d.json");
        rc = mf_write_file(path, js, (size_t)l);
    }
    if (!rc) {
        /* grid: rows = the first views (up to 4), columns = input, GT albedo, SM, MV, Retinex, GT ORM, SM ORM, MV ORM */
        int rows = n < 4 ? n : 4, cols = 8;
        const MfImage **cells = calloc((size_t)rows * cols, sizeof *cells);
        if (cells) {
            for (int r = 0; r < rows; ++r) {
                int i = r * (n / rows);
                const MfImage *row[8] = {&s.rgb[i], &s.albedo[i], &sa[i], no_mv ? NULL : &ma[i], &ra[i], &s.orm[i], &so[i],
                                         no_mv ? NULL : &mo[i]};
                memcpy(cells + r * cols, row, sizeof row);
            }
            mf_path_join(path, sizeof path, out, "examples2d.png");
            if (ev_grid_png(path, cells, rows, cols, 96, 96, 1)) mf_log_warn("eval-prior: %s", mf_error());
            free(cells);
        }
    }
    if (!rc) {
        for (int mi = 0; mi < NM; ++mi) {
            printf("%-18s", METHODS[mi]);
            for (int k = 0; k < 5; ++k) {
                EvStat st = ev_table_stat(&t, METHODS[mi], "test-2d", METRICS[k]);
                if (st.n) printf("  %s %.4f", METRICS[k], st.mean);
            }
            printf("\n");
        }
        printf("wrote %s/table2d.md (SM %.1f s, MV %.1f s)\n", out, t_sv, t_mv);
    }
    free_images(sa, n), free_images(so, n), free_images(ma, n), free_images(mo, n), free_images(ia, n);
    free_images(ra, n), free_images(co, n);
    ev_table_free(&t);
    mf_prior_free(p);
    split_free(&s);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(eval_prior, "eval-prior", "2D evaluation of the material prior against simple baselines (Table 3)",
           USAGE_EVAL_PRIOR, cmd_eval_prior)
