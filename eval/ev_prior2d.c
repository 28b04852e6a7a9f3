/* ev_prior2d: the prior's 2D evaluation table (ev_prior2d.h). */
#include "eval/ev_prior2d.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_math.h"
#include "datasets/ds_load.h"
#include "datasets/ds_prior2d.h"
#include "eval/ev_align.h"
#include "eval/ev_bench.h"
#include "eval/ev_metrics.h"
#include "eval/ev_report.h"
#include "io/mf_json.h"

const char *const ev_prior2d_methods[EV_PRIOR2D_NM] = {"StableMaterial", "StableMaterialMV", "Input image", "Retinex",
                                                       "Train-mean ORM"};
const char *const ev_prior2d_metrics[EV_PRIOR2D_NK] = {"albedo_psnr", "albedo_ssim", "albedo_l1", "orm_psnr", "orm_l1"};

static void free_images(MfImage *im, int n) {
    if (!im) return;
    for (int i = 0; i < n; ++i) mf_image_free(&im[i]);
    free(im);
}

void ev_prior2d_free(EvPrior2dSplit *s) {
    free_images(s->rgb_raw, s->n), free_images(s->rgb, s->n), free_images(s->albedo, s->n), free_images(s->orm, s->n);
    free(s->names);
    memset(s, 0, sizeof *s);
}

/* manifest (ds_prior2d.h): count, views_per_object (default 1); n = whole objects only. */
int ev_prior2d_load(const char *dir, int max_objects, EvPrior2dSplit *s) {
    DsPrior2dManifest man;
    int rc = ds_prior2d_manifest(dir, 1, &man);
    if (rc) return rc;
    int count = man.count, V = man.views_per_object == DS_P2_ABSENT ? 1 : man.views_per_object;
    if (count < 1 || V < 1 || count < V) return mf_fail(MF_EFORMAT, "%s: expected \"count\" >= \"views_per_object\" >= 1", man.path);
    int objects = count / V;
    if (max_objects > 0 && objects > max_objects) objects = max_objects;
    s->n = objects * V, s->V = V;
    snprintf(s->dataset, sizeof s->dataset, "test-2d");
    s->rgb_raw = calloc((size_t)s->n, sizeof(MfImage)), s->rgb = calloc((size_t)s->n, sizeof(MfImage));
    s->albedo = calloc((size_t)s->n, sizeof(MfImage)), s->orm = calloc((size_t)s->n, sizeof(MfImage));
    if (!s->rgb_raw || !s->rgb || !s->albedo || !s->orm) return mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    for (int i = 0; i < s->n && !rc; ++i) {
        if (!(rc = ds_prior2d_read(dir, "rgb", i, MF_ENC_LINEAR, &s->rgb_raw[i])) &&
            !(rc = ds_prior2d_read(dir, "rgb", i, MF_ENC_SRGB, &s->rgb[i])) &&
            !(rc = ds_prior2d_read(dir, "albedo", i, MF_ENC_SRGB, &s->albedo[i])))
            rc = ds_prior2d_read(dir, "orm", i, MF_ENC_LINEAR, &s->orm[i]);
        if (!rc && i == 0) s->R = s->albedo[0].w;
        if (!rc && (s->rgb[i].w != s->R || s->rgb[i].h != s->R || s->albedo[i].h != s->R || s->orm[i].w != s->R ||
                    s->orm[i].h != s->R))
            rc = mf_fail(MF_EFORMAT, "%s: sample %d: expected %dx%d images of every kind", dir, i, s->R, s->R);
    }
    return rc;
}

/* (R, R, 4) copy of a (R, R, 3) map with the view's alpha. */
static int with_alpha(const MfImage *map, const MfImage *rgba, MfImage *out) {
    int rc = mf_image_alloc(out, rgba->w, rgba->h, 4);
    for (size_t p = 0; !rc && p < (size_t)rgba->w * rgba->h; ++p) {
        for (int c = 0; c < 3; ++c) out->data[4 * p + c] = map->data[3 * p + c];
        out->data[4 * p + 3] = rgba->data[4 * p + 3];
    }
    return rc;
}

/* Sample i of s from view v of scene `scene`: colour (straight alpha, linear) as rgb and
 * sRGB-encoded as rgb_raw, GT maps with the view's alpha. */
static int scene_sample(EvPrior2dSplit *s, int i, const char *scene, const DsViews *dv, const DsView *v) {
    if (!v->albedo.data || !v->orm.data || v->albedo.c != 3 || v->orm.c != 3)
        return mf_fail(MF_EFORMAT, "%s: test view %s has no GT albedo and ORM (gt/albedo, gt/orm)", dv->dir, v->name);
    if (snprintf(s->names[i], EV_NAME_MAX, "%s/%s", scene, v->name) >= EV_NAME_MAX)
        return mf_fail(MF_EARG, "%s: view name %s too long", dv->dir, v->name);
    int rc = mf_image_alloc(&s->rgb[i], v->rgba.w, v->rgba.h, 4);
    if (!rc) rc = mf_image_alloc(&s->rgb_raw[i], v->rgba.w, v->rgba.h, 4);
    for (size_t p = 0; !rc && p < (size_t)v->rgba.w * v->rgba.h; ++p)
        for (int c = 0; c < 4; ++c) {
            float x = v->rgba.data[4 * p + c];
            s->rgb[i].data[4 * p + c] = x;
            s->rgb_raw[i].data[4 * p + c] = c < 3 ? mf_clampf(mf_linear_to_srgb(x), 0.0f, 1.0f) : x;
        }
    if (!rc) rc = with_alpha(&v->albedo, &v->rgba, &s->albedo[i]);
    if (!rc) rc = with_alpha(&v->orm, &v->rgba, &s->orm[i]);
    return rc;
}

int ev_prior2d_load_scenes(const char *dir, int R, int views, int max_objects, EvPrior2dSplit *s) {
    EvName *scenes = NULL;
    int ns = 0, rc = ev_scene_dirs(dir, &scenes, &ns);
    if (!rc && !ns)
        rc = mf_fail(MF_EARG, "%s: neither a 2D split (rgb/000000.png) nor a 3D split (scene folders with "
                     "transforms_test.json or transforms.json)", dir);
    if (rc) return free(scenes), rc;
    if (max_objects > 0 && ns > max_objects) ns = max_objects;
    s->n = ns * views, s->V = views, s->R = R;
    const char *base = strrchr(dir, '/');
    snprintf(s->dataset, sizeof s->dataset, "%s", base && base[1] ? base + 1 : dir);
    s->rgb_raw = calloc((size_t)s->n, sizeof(MfImage)), s->rgb = calloc((size_t)s->n, sizeof(MfImage));
    s->albedo = calloc((size_t)s->n, sizeof(MfImage)), s->orm = calloc((size_t)s->n, sizeof(MfImage));
    s->names = calloc((size_t)s->n, sizeof(EvName));
    if (!s->rgb_raw || !s->rgb || !s->albedo || !s->orm || !s->names) rc = mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    for (int o = 0; o < ns && !rc; ++o) {
        char sd[MF_PATH_MAX];
        DsViews dv = {0};
        DsLoadOptions lo = {.load_gt = 1, .max_views = views, .quiet = 1};
        if (!(rc = mf_path_join(sd, sizeof sd, dir, scenes[o])) &&
            (rc = ds_load_width(sd, "test", &lo, R, &dv)))
            rc = mf_fail_prefix(rc, "%s: test views at the prior's %d px", sd, R);
        else if (!rc && dv.n < views)
            rc = mf_fail(MF_EARG, "%s: %d test views, --views asks for %d", sd, dv.n, views);
        for (int v = 0; v < views && !rc; ++v) rc = scene_sample(s, o * views + v, scenes[o], &dv, &dv.views[v]);
        ds_views_free(&dv);
    }
    free(scenes);
    return rc;
}

int ev_prior2d_preds_alloc(EvPrior2dPreds *p, int n, int mv) {
    memset(p, 0, sizeof *p);
    p->n = n;
    const int alb[] = {EV_P2_SM, EV_P2_MV, EV_P2_INPUT, EV_P2_RETINEX}, orm[] = {EV_P2_SM, EV_P2_MV, EV_P2_MEAN_ORM};
    int bad = 0;
    for (int k = 0; k < 4; ++k)
        if (mv || alb[k] != EV_P2_MV) bad |= !(p->albedo[alb[k]] = calloc((size_t)n, sizeof(MfImage)));
    for (int k = 0; k < 3; ++k)
        if (mv || orm[k] != EV_P2_MV) bad |= !(p->orm[orm[k]] = calloc((size_t)n, sizeof(MfImage)));
    if (bad) {
        ev_prior2d_preds_free(p);
        return mf_fail(MF_ENOMEM, "eval-prior: out of memory");
    }
    return MF_OK;
}

void ev_prior2d_preds_free(EvPrior2dPreds *p) {
    for (int m = 0; m < EV_PRIOR2D_NM; ++m) free_images(p->albedo[m], p->n), free_images(p->orm[m], p->n);
    memset(p, 0, sizeof *p);
}

static int score(EvTable *t, const char *method, const char *ds, const char *scene, const MfImage *alb, const MfImage *orm,
                 const MfImage *gt_alb, const MfImage *gt_orm) {
    int rc = MF_OK;
    if (alb) {
        MfImage po = {0}, go = {0};
        double ps, ss, l1;
        rc = ev_protocol_prepare(alb, gt_alb, gt_alb, EV_ALIGN_MEAN, &po, &go, NULL, NULL);
        if (!rc) rc = ev_psnr(&po, &go, gt_alb, &ps);
        if (!rc) rc = ev_ssim(&po, &go, gt_alb, &ss);
        if (!rc) rc = ev_l1(&po, &go, gt_alb, &l1);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "albedo_psnr", ps);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "albedo_ssim", ss);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "albedo_l1", l1);
        mf_image_free(&po), mf_image_free(&go);
        if (rc) return mf_fail_prefix(rc, "eval-prior: %s, sample %s", method, scene);
    }
    if (orm) {
        MfImage po = {0}, go = {0};
        double ps, l1, mse[2];
        rc = ev_protocol_prepare_orm(orm, gt_orm, gt_alb, &po, &go);
        if (!rc) rc = ev_psnr(&po, &go, gt_alb, &ps);
        if (!rc) rc = ev_l1(&po, &go, gt_alb, &l1);
        if (!rc) rc = ev_mse_channels(&po, &go, gt_alb, mse); /* po, go: (h, w, 2) roughness, metallic */
        if (!rc) rc = ev_table_add(t, method, ds, scene, "orm_psnr", ps);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "orm_l1", l1);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "rough_mse", mse[0]);
        if (!rc) rc = ev_table_add(t, method, ds, scene, "metal_mse", mse[1]);
        mf_image_free(&po), mf_image_free(&go);
        if (rc) return mf_fail_prefix(rc, "eval-prior: %s, sample %s", method, scene);
    }
    return rc;
}

int ev_prior2d_score(const EvPrior2dSplit *s, const EvPrior2dPreds *p, EvTable *t) {
    int rc = MF_OK;
    for (int i = 0; i < s->n && !rc; ++i) {
        char num[16];
        snprintf(num, sizeof num, "%06d", i);
        const char *scene = s->names ? s->names[i] : num;
        for (int m = 0; m < EV_PRIOR2D_NM && !rc; ++m)
            if (p->albedo[m] || p->orm[m])
                rc = score(t, ev_prior2d_methods[m], s->dataset, scene, p->albedo[m] ? &p->albedo[m][i] : NULL,
                           p->orm[m] ? &p->orm[m][i] : NULL, &s->albedo[i], &s->orm[i]);
    }
    return rc;
}

void ev_prior2d_trust(const EvTable *t, const char *dataset, int m, double trust[2]) {
    static const char *metric[2] = {"rough_mse", "metal_mse"};
    for (int k = 0; k < 2; ++k) {
        EvStat p = ev_table_stat(t, ev_prior2d_methods[m], dataset, metric[k]);
        EvStat c = ev_table_stat(t, ev_prior2d_methods[EV_P2_MEAN_ORM], dataset, metric[k]);
        double r = (p.n && c.n && c.mean > 0.0) ? 1.0 - p.mean / c.mean : 0.0;
        trust[k] = r < 0.0 ? 0.0 : (r > 1.0 ? 1.0 : r);
    }
}

/* rows = the first views (up to 4), columns = input, GT albedo, SM, MV, Retinex, GT ORM, SM ORM, MV ORM */
static void write_examples(const char *path, const EvPrior2dSplit *s, const EvPrior2dPreds *p) {
    int n = s->n, rows = n < 4 ? n : 4, cols = 8;
    const MfImage **cells = calloc((size_t)rows * cols, sizeof *cells);
    if (!cells) return;
    for (int r = 0; r < rows; ++r) {
        int i = r * (n / rows);
        const MfImage *mv_a = p->albedo[EV_P2_MV] ? &p->albedo[EV_P2_MV][i] : NULL, *mv_o = p->orm[EV_P2_MV] ? &p->orm[EV_P2_MV][i] : NULL;
        const MfImage *row[8] = {&s->rgb[i], &s->albedo[i], &p->albedo[EV_P2_SM][i], mv_a, &p->albedo[EV_P2_RETINEX][i],
                                 &s->orm[i], &p->orm[EV_P2_SM][i], mv_o};
        memcpy(cells + r * cols, row, sizeof row);
    }
    if (ev_grid_png(path, cells, rows, cols, 96, 96, 1)) mf_log_warn("eval-prior: %s", mf_error());
    free(cells);
}

/* Per-object means over the views of every method's records in t into o (scene = the object's
 * scene folder), for a split of a 3D split's objects. */
static int object_table(const EvTable *t, const EvPrior2dSplit *s, EvTable *o) {
    int rc = MF_OK;
    for (int ob = 0; ob < s->n / s->V && !rc; ++ob) {
        EvName obj;
        snprintf(obj, sizeof obj, "%s", s->names[ob * s->V]);
        char *slash = strrchr(obj, '/');
        if (slash) *slash = '\0';
        for (int m = 0; m < EV_PRIOR2D_NM && !rc; ++m)
            for (int k = 0; k < EV_PRIOR2D_NK && !rc; ++k) {
                double sum = 0.0, v;
                int cnt = 0;
                for (int i = ob * s->V; i < (ob + 1) * s->V; ++i)
                    if (ev_table_find(t, ev_prior2d_methods[m], s->dataset, s->names[i], ev_prior2d_metrics[k], &v))
                        sum += v, ++cnt;
                if (cnt) rc = ev_table_add(o, ev_prior2d_methods[m], s->dataset, obj, ev_prior2d_metrics[k], sum / cnt);
            }
    }
    return rc;
}

int ev_prior2d_write(const char *out, const EvTable *t, const EvPrior2dSplit *s, const EvPrior2dPreds *p,
                     const EvPrior2dInfo *in) {
    char path[MF_PATH_MAX], caption[768 + MF_PATH_MAX];
    const char *ds[1] = {s->dataset};
    int rc = mf_mkdirs(out);
    if (!rc) {
        snprintf(caption, sizeof caption,
                 "Prior 2D evaluation (paper Table 3) on %s, prior %s: %d objects x %d views at %d px; mean of %d samples "
                 "(%d DDIM steps, guidance %.1f) per view; albedo aligned per channel (ratio of means, linear) "
                 "inside the mask, then sRGB; ORM = roughness and metallic; metrics inside the mask; mean over "
                 "views with 95%% CI. Baselines need no training (Retinex sigma %.1f px; training-set mean "
                 "roughness %.3f, metallic %.3f).",
                 in->test_dir, in->weights ? in->weights : "?", s->n / s->V, s->V, s->R, in->samples, in->steps, in->guidance, in->retinex_sigma,
                 in->train_roughness, in->train_metallic);
        mf_path_join(path, sizeof path, out, "table2d.md");
        rc = ev_table_write_markdown(t, path, caption, ev_prior2d_methods, EV_PRIOR2D_NM, ds, 1, ev_prior2d_metrics, EV_PRIOR2D_NK);
    }
    if (!rc) {
        mf_path_join(path, sizeof path, out, "table2d.csv");
        rc = ev_table_write_csv(t, path);
    }
    if (!rc) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "test_dir", in->test_dir);
        cJSON_AddStringToObject(j, "weights", in->weights ? in->weights : "");
        cJSON_AddNumberToObject(j, "objects", s->n / s->V);
        cJSON_AddNumberToObject(j, "views", s->V);
        cJSON_AddNumberToObject(j, "resolution", s->R);
        cJSON_AddNumberToObject(j, "samples", in->samples);
        cJSON_AddNumberToObject(j, "ddim_steps", in->steps);
        cJSON_AddNumberToObject(j, "guidance", in->guidance);
        cJSON_AddNumberToObject(j, "seed", in->seed);
        cJSON_AddNumberToObject(j, "retinex_sigma", in->retinex_sigma);
        cJSON_AddNumberToObject(j, "train_mean_roughness", in->train_roughness);
        cJSON_AddNumberToObject(j, "train_mean_metallic", in->train_metallic);
        cJSON_AddNumberToObject(j, "stablematerial_wall_s", in->sm_wall_s);
        cJSON_AddNumberToObject(j, "stablematerialmv_wall_s", in->mv_wall_s);
        cJSON_AddNumberToObject(j, "trust_roughness", in->trust[0]);
        cJSON_AddNumberToObject(j, "trust_metallic", in->trust[1]);
        mf_path_join(path, sizeof path, out, "table2d.json");
        rc = j ? mf_json_save(path, j) : mf_fail(MF_ENOMEM, "out of memory");
        cJSON_Delete(j);
    }
    if (!rc && s->names) {
        EvTable o;
        ev_table_init(&o);
        rc = object_table(t, s, &o);
        if (!rc) {
            mf_path_join(path, sizeof path, out, "objects.csv");
            rc = ev_table_write_csv(&o, path);
        }
        if (!rc) {
            char cap2[1024 + MF_PATH_MAX];
            snprintf(cap2, sizeof cap2, "%s\n\nPer object: each object's mean over its %d views, then the mean over the %d "
                     "objects with its 95%% CI over objects (objects.csv: the per-object values).", caption, s->V, s->n / s->V);
            mf_path_join(path, sizeof path, out, "objects.md");
            rc = ev_table_write_markdown(&o, path, cap2, ev_prior2d_methods, EV_PRIOR2D_NM, ds, 1, ev_prior2d_metrics,
                                         EV_PRIOR2D_NK);
        }
        ev_table_free(&o);
    }
    if (!rc) {
        mf_path_join(path, sizeof path, out, "examples2d.png");
        write_examples(path, s, p);
    }
    return rc;
}
