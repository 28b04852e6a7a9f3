#include "eval/ev_eval.h"
#include "eval/ev_image.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_load.h"
#include "eval/ev_geom.h"
#include "eval/ev_metrics.h"
#include "eval/ev_orb.h"
#include "io/mf_gltf_read.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"

/* A glTF file as a result: its mesh and its one material's textures, env.exr from its folder. */
static int result_from_gltf(const char *path, EvResult *out) {
    EvResult r;
    memset(&r, 0, sizeof r);
    MfGltfAsset a;
    int rc = mf_gltf_read(path, &a);
    if (rc) return rc;
    if (a.nmat != 1) rc = mf_fail(MF_EFORMAT, "%s: %d materials; a result has one (albedo and ORM textures)", path, a.nmat);
    if (!rc) {
        r.mesh = a.mesh, r.kd = a.mats[0].albedo, r.orm = a.mats[0].orm;
        memset(&a.mesh, 0, sizeof a.mesh), memset(&a.mats[0].albedo, 0, sizeof(MfImage)), memset(&a.mats[0].orm, 0, sizeof(MfImage));
        if (a.mats[0].has_normal) { /* a result's scene.glb carries its normal.png as normalTexture */
            r.normal = a.mats[0].normal, r.has_normal = 1;
            memset(&a.mats[0].normal, 0, sizeof(MfImage));
        }
    }
    mf_gltf_asset_free(&a);
    char p[MF_PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!rc && snprintf(p, sizeof p, "%.*s%senv.exr", slash ? (int)(slash - path) : 0, path, slash ? "/" : "") < (int)sizeof p &&
        mf_file_exists(p)) {
        rc = mf_env_load(&r.env, p);
        r.has_env = !rc;
    }
    if (rc) {
        ev_result_free(&r);
        return rc;
    }
    *out = r;
    return MF_OK;
}

/* r->normal from path when that file exists: a tangent-space normal map (linear, 3 channels) that
 * renders of r use; it needs r->mesh's UVs. */
static int load_normal(const char *path, EvResult *r) {
    if (!mf_file_exists(path)) return MF_OK;
    int rc = mf_image_read(path, MF_ENC_LINEAR, &r->normal);
    r->has_normal = !rc;
    if (!rc && r->normal.c < 3) rc = mf_fail(MF_EFORMAT, "%s: needs 3 channels", path);
    if (!rc && !r->mesh.uv) rc = mf_fail(MF_EFORMAT, "%s: a normal map needs a mesh with UVs", path);
    return rc;
}

int ev_result_load(const char *dir, const char *mesh_path, EvResult *out) {
    if (mf_is_gltf_path(dir)) return result_from_gltf(dir, out);
    EvResult r;
    memset(&r, 0, sizeof r);
    char p[MF_PATH_MAX];
    int rc = mesh_path ? (snprintf(p, sizeof p, "%s", mesh_path), MF_OK) : mf_path_join(p, sizeof p, dir, "mesh.obj");
    if (!rc) rc = mf_mesh_read(p, &r.mesh);
    if (!rc && !(rc = mf_path_join(p, sizeof p, dir, "albedo.png"))) rc = mf_image_read(p, MF_ENC_SRGB, &r.kd);
    if (!rc && !(rc = mf_path_join(p, sizeof p, dir, "orm.png"))) rc = mf_image_read(p, MF_ENC_LINEAR, &r.orm);
    if (!rc && !(rc = mf_path_join(p, sizeof p, dir, "env.exr")) && mf_file_exists(p)) {
        rc = mf_env_load(&r.env, p);
        r.has_env = !rc;
    }
    if (!rc && !(rc = mf_path_join(p, sizeof p, dir, "normal.png"))) rc = load_normal(p, &r);
    if (!rc && (r.kd.c < 3 || r.orm.c < 3)) rc = mf_fail(MF_EFORMAT, "%s: albedo.png and orm.png need 3 channels", dir);
    if (rc) {
        ev_result_free(&r);
        return rc;
    }
    *out = r;
    return MF_OK;
}

void ev_result_free(EvResult *r) {
    if (!r) return;
    mf_mesh_free(&r->mesh);
    mf_image_free(&r->kd);
    mf_image_free(&r->orm);
    if (r->has_normal) mf_image_free(&r->normal);
    if (r->has_env) mf_env_free(&r->env);
    memset(r, 0, sizeof *r);
}

void ev_eval_csv_header(FILE *csv) {
    fprintf(csv, "method,dataset,scene,view,kind,light,psnr,ssim,l1,flip,psnr_masked,ssim_masked,l1_masked\n");
}

/* Un-premultiplies a (h, w, 4) image in place. */
static void unpremultiply(MfImage *im) {
    for (size_t i = 0; i < (size_t)im->w * im->h; ++i) {
        float a = im->data[4 * i + 3];
        for (int c = 0; c < 3; ++c) im->data[4 * i + c] = a > 0.0f ? im->data[4 * i + c] / a : 0.0f;
    }
}

/* (h, w, 4) image from a 3-channel AOV plus alpha. */
static int aov_rgba(const float *rgb, const float *alpha, int w, int h, MfImage *out) {
    int rc = mf_image_alloc(out, w, h, 4);
    if (rc) return rc;
    for (size_t i = 0; i < (size_t)w * h; ++i) {
        for (int c = 0; c < 3; ++c) out->data[4 * i + c] = rgb[3 * i + c];
        out->data[4 * i + 3] = alpha[i];
    }
    return MF_OK;
}

typedef struct { double v[7]; int n; } Acc; /* psnr ssim l1 flip psnr_m ssim_m l1_m */

static void acc_add(Acc *a, const EvMetrics *m) {
    double x[7] = {m->psnr, m->ssim, m->l1, m->flip, m->psnr_masked, m->ssim_masked, m->l1_masked};
    for (int k = 0; k < 7; ++k) a->v[k] += x[k];
    a->n++;
}

static void row(FILE *csv, const char *method, const char *dataset, const char *scene, const char *view, const char *kind,
                const char *light, const EvMetrics *m) {
    if (!csv) return;
    fprintf(csv, "%s,%s,%s,%s,%s,%s,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", method, dataset, scene, view, kind, light, m->psnr,
            m->ssim, m->l1, m->has_flip ? m->flip : 0.0, m->psnr_masked, m->ssim_masked, m->l1_masked);
}

/* Scores one colour prediction (linear, straight alpha) against GT with the protocol. */
static int score_color(const MfImage *pred, const MfImage *gt, EvAlign align, EvMetrics *m) {
    MfImage po = {0}, go = {0};
    int rc = ev_protocol_prepare(pred, gt, gt, align, &po, &go, NULL, NULL);
    if (!rc) rc = ev_metrics_compute(&po, &go, gt, m);
    mf_image_free(&po);
    mf_image_free(&go);
    return rc;
}

/* The GT of a bvault scene as a result (mesh.obj, gt/kd.png, gt/orm.png), or its grey version. */
static int trivial_result(const char *scene_dir, int grey, EvResult *out) {
    EvResult r;
    memset(&r, 0, sizeof r);
    char p[MF_PATH_MAX];
    int rc = mf_path_join(p, sizeof p, scene_dir, "mesh.obj");
    if (!rc) rc = mf_obj_read(p, &r.mesh);
    if (!rc && grey) {
        if (!(rc = mf_image_alloc(&r.kd, 1, 1, 3)) && !(rc = mf_image_alloc(&r.orm, 1, 1, 3))) {
            r.kd.data[0] = r.kd.data[1] = r.kd.data[2] = 0.5f;
            r.orm.data[0] = 1.0f, r.orm.data[1] = 0.5f, r.orm.data[2] = 0.0f;
        }
    } else if (!rc) {
        if (!(rc = mf_path_join(p, sizeof p, scene_dir, "gt/kd.png"))) rc = mf_image_read(p, MF_ENC_SRGB, &r.kd);
        if (!rc && !(rc = mf_path_join(p, sizeof p, scene_dir, "gt/orm.png"))) rc = mf_image_read(p, MF_ENC_LINEAR, &r.orm);
        /* the true material includes the asset's normal map (mf gen --asset writes gt/normal.png) */
        if (!rc && !(rc = mf_path_join(p, sizeof p, scene_dir, "gt/normal.png"))) rc = load_normal(p, &r);
    }
    if (rc) {
        ev_result_free(&r);
        return rc;
    }
    *out = r;
    return MF_OK;
}

/* Novel views under the training light, for scenes with neither relit nor material ground truth
 * (a capture: the held-out test images are all the truth there is): the result rendered with its
 * own env.exr from each test camera against the test image (straight alpha), relit protocol. */
static int score_novel_views(const DsViews *dv, const EvResult *res, const MfRtScene *rt, const MfTexMaterial *mat,
                             const MfRenderOpts *ro, EvAlign align, FILE *csv, const char *method, const char *dataset,
                             const char *scene, Acc *acc, int *bad) {
    if (!res->has_env)
        return mf_fail(MF_EARG, "%s: no relit or material ground truth, so the test views are scored under the training "
                       "light, which needs the result's env.exr (missing)", dv->dir);
    MfRenderInput in = {rt, &res->mesh, mat, 1, &res->env, NULL, 0};
    int rc = MF_OK;
    for (int i = 0; i < dv->n && !rc; ++i) {
        const DsView *v = &dv->views[i];
        MfRenderOut out = {0};
        MfImage pred = {0};
        EvMetrics m;
        rc = mf_render(&in, &v->cam, ro, &out, NULL);
        if (!rc) rc = aov_rgba(out.rgb, out.alpha, out.w, out.h, &pred);
        if (!rc) {
            unpremultiply(&pred);
            if (score_color(&pred, &v->rgba, align, &m) == MF_OK) {
                acc_add(acc, &m);
                row(csv, method, dataset, scene, v->name, "novel_view", "training", &m);
            } else {
                mf_log_warn("%s/%s (novel view) excluded: %s", scene, v->name, mf_error());
                ++*bad;
            }
        }
        mf_render_out_free(&out);
        mf_image_free(&pred);
    }
    if (!rc && acc->n)
        mf_log_info("%s: no relit or material ground truth: scored %d held-out test views under the training light "
                    "(the result rendered with its env.exr): nv_psnr %.2f dB, nv_ssim %.4f, nv_flip %.4f", scene, acc->n,
                    acc->v[0] / acc->n, acc->v[1] / acc->n, acc->v[3] / acc->n);
    else if (!rc)
        mf_log_info("%s: no relit or material ground truth: none of %d held-out test views could be scored under the training light",
                    scene, dv->n);
    return rc;
}

/* Geometry against the scene's GT mesh (issue 14 item 11): Stanford-ORB Chamfer, its uniform
 * variant and the point-pair normal error in degrees and as 1 - cos (ev_geom_score,
 * EV_GEOM_SAMPLES area samples), and over the test cameras the image-space normal error (degrees,
 * 1 - cos) and mask IoU (ev_geom_views). Nothing when the scene has no GT mesh;
 * a failure (an unreadable GT mesh, a mesh without area) is logged by the caller, not fatal. */
static int score_geometry(const DsViews *dv, const MfMesh *pred, const EvEvalOpts *o, EvTable *t, const char *method,
                          const char *dataset, const char *scene) {
    if (!dv->mesh_path[0] || dv->n < 1) return MF_OK;
    MfMesh gt;
    int rc = mf_mesh_read(dv->mesh_path, &gt);
    if (rc) return rc;
    MfCamera *cams = malloc(sizeof *cams * (size_t)dv->n);
    EvGeomScore gs;
    EvGeomViews gv;
    if (!cams) rc = mf_fail(MF_ENOMEM, "out of memory for %d cameras", dv->n);
    for (int i = 0; !rc && i < dv->n; ++i) cams[i] = dv->views[i].cam;
    if (!rc) rc = ev_geom_score(&gt, pred, EV_GEOM_SAMPLES, o->seed, &gs);
    if (!rc) rc = ev_geom_views(&gt, pred, cams, dv->n, &gv);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_chamfer", gs.chamfer);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_chamfer_uniform", gs.chamfer_uniform);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_normal_deg", gs.normal_deg);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_normal_1mcos", gs.normal_1mcos);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_view_normal_deg", gv.normal_deg);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_view_normal_1mcos", gv.normal_1mcos);
    if (!rc) rc = ev_table_add(t, method, dataset, scene, "geom_mask_iou", gv.mask_iou);
    free(cams);
    mf_mesh_free(&gt);
    return rc;
}

int ev_eval_scene(const char *scene_dir, const char *result_dir, const char *method, const char *dataset,
                  const char *scene, const EvEvalOpts *o, EvTable *t, FILE *csv, int *excluded) {
    EvResult res;
    int flat = !strcmp(result_dir, EV_TRIVIAL_FLAT_DIR), grey = !strcmp(result_dir, EV_TRIVIAL_GREY_DIR);
    int rc = (flat || grey) ? trivial_result(scene_dir, grey, &res) : ev_result_load(result_dir, o->mesh_path, &res);
    if (rc) return rc;
    DsViews dv;
    DsLoadOptions lo = {1, o->max_views, 1, 0, o->mask, o->quiet};
    if ((rc = ds_load(scene_dir, "test", &lo, &dv))) {
        ev_result_free(&res);
        return rc;
    }
    MfRtScene *rt = NULL;
    if ((rc = mf_rtscene_new(&res.mesh, &rt))) goto out;
    MfTexMaterial mat = {.kd = &res.kd, .orm = &res.orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = res.has_normal ? &res.normal : NULL};
    MfRenderOpts ro = {.spp_sqrt = o->spp_sqrt, .pixel_samples = o->pixel_samples, .seed = o->seed, .lobes = MF_LOBE_ALL};
    Acc relit = {{0}, 0}, alb = {{0}, 0}, orm = {{0}, 0};
    double orm3 = 0.0, orb_h = 0.0, orb_l = 0.0;
    int orb_n = 0, is_orb = dv.format == DS_FMT_STANFORD_ORB;
    int bad = 0;
    /* relighting */
    int nl = o->max_lights > 0 && o->max_lights < dv.n_relight ? o->max_lights : dv.n_relight;
    for (int k = 0; k < nl && !rc; ++k) {
        if (!dv.relight_env[k][0]) continue;
        MfEnvMap env;
        if ((rc = flat ? mf_env_init_constant(&env, 8, 4, mf_v3s(1.0f)) : mf_env_load(&env, dv.relight_env[k]))) break;
        MfRenderInput in = {rt, &res.mesh, &mat, 1, &env, NULL, 0};
        for (int i = 0; i < dv.n && !rc; ++i) {
            MfImage gt = {0}, pred = {0};
            MfRenderOut out = {0};
            if ((rc = ds_load_relit(&dv, i, k, &gt))) break;
            rc = mf_render(&in, &dv.views[i].cam, &ro, &out, NULL);
            if (!rc) rc = aov_rgba(out.rgb, out.alpha, out.w, out.h, &pred);
            if (!rc && (gt.w != pred.w || gt.h != pred.h)) {
                char rp[MF_PATH_MAX];
                if (ds_relit_path(&dv, i, k, rp, sizeof rp)) snprintf(rp, sizeof rp, "%s", scene_dir);
                rc = mf_fail(MF_EFORMAT, "%s: relit GT is %dx%d, the view image %s is %dx%d", rp, gt.w, gt.h,
                             dv.views[i].image_path, pred.w, pred.h);
            }
            if (!rc) {
                unpremultiply(&gt);
                unpremultiply(&pred);
                EvMetrics m;
                double ph, pl;
                if (is_orb && ev_orb_psnr_h(&pred, &gt, &gt, &ph) == MF_OK && ev_orb_psnr_l(&pred, &gt, &gt, &pl) == MF_OK)
                    orb_h += ph, orb_l += pl, ++orb_n;
                if (score_color(&pred, &gt, o->align, &m) == MF_OK) {
                    acc_add(&relit, &m);
                    row(csv, method, dataset, scene, dv.views[i].name, "relit", dv.relight_name[k], &m);
                } else {
                    mf_log_warn("%s/%s under %s excluded: %s", scene, dv.views[i].name, dv.relight_name[k], mf_error());
                    ++bad;
                }
            }
            mf_render_out_free(&out);
            mf_image_free(&gt);
            mf_image_free(&pred);
        }
        mf_env_free(&env);
    }
    /* albedo and ORM AOVs (light-independent: any light renders them; none is needed) */
    MfRenderOpts ao = ro;
    ao.spp_sqrt = 1;
    MfRenderInput ain = {rt, &res.mesh, &mat, 1, NULL, NULL, 0};
    for (int i = 0; i < dv.n && !rc && !flat && !grey; ++i) { /* trivial guesses: relighting only */
        const DsView *v = &dv.views[i];
        if (!v->albedo.data && !v->orm.data) continue;
        /* the loaders check this (naming the GT file); a GT that does not match would be read
         * past its end below */
        if ((v->albedo.data && (v->albedo.w != v->cam.w || v->albedo.h != v->cam.h)) ||
            (v->orm.data && (v->orm.w != v->cam.w || v->orm.h != v->cam.h))) {
            rc = mf_fail(MF_EFORMAT, "%s: per-view GT albedo/ORM size differs from the view's %dx%d", v->image_path, v->cam.w, v->cam.h);
            break;
        }
        MfRenderOut out;
        if ((rc = mf_render(&ain, &v->cam, &ao, &out, NULL))) break;
        /* GT mask: the view's alpha */
        MfImage mask = {0};
        if (!(rc = mf_image_alloc(&mask, out.w, out.h, 1)))
            for (size_t p = 0; p < (size_t)out.w * out.h; ++p) mask.data[p] = v->rgba.data[4 * p + 3];
        if (!rc && v->albedo.data) {
            MfImage pred = {0}, gt = {0};
            EvMetrics m;
            rc = aov_rgba(out.albedo, out.alpha, out.w, out.h, &pred);
            if (!rc) rc = aov_rgba(v->albedo.data, mask.data, out.w, out.h, &gt); /* GT with its mask as alpha */
            if (!rc) {
                if (score_color(&pred, &gt, o->align, &m) == MF_OK) {
                    acc_add(&alb, &m);
                    row(csv, method, dataset, scene, v->name, "albedo", "-", &m);
                } else {
                    ++bad;
                }
            }
            mf_image_free(&pred);
            mf_image_free(&gt);
        }
        if (!rc && v->orm.data) {
            MfImage pred = {0}, gt = {0}, po = {0}, go = {0};
            EvMetrics m;
            rc = aov_rgba(out.orm, out.alpha, out.w, out.h, &pred);
            if (!rc) rc = aov_rgba(v->orm.data, mask.data, out.w, out.h, &gt);
            if (!rc) {
                if (ev_protocol_prepare_orm(&pred, &gt, &mask, &po, &go) == MF_OK &&
                    ev_metrics_compute(&po, &go, &mask, &m) == MF_OK) {
                    acc_add(&orm, &m);
                    /* constant R = 1 in both: MSE over 3 channels is 2/3 of the (G, B) MSE */
                    orm3 += m.psnr + 10.0 * log10(1.5);
                    row(csv, method, dataset, scene, v->name, "orm", "-", &m);
                } else {
                    ++bad;
                }
            }
            mf_image_free(&pred), mf_image_free(&gt), mf_image_free(&po), mf_image_free(&go);
        }
        mf_image_free(&mask);
        mf_render_out_free(&out);
    }
    Acc nv = {{0}, 0};
    if (!rc && !flat && !grey && dv.n_relight == 0 && !alb.n && !orm.n)
        rc = score_novel_views(&dv, &res, rt, &mat, &ro, o->align, csv, method, dataset, scene, &nv, &bad);
    if (!rc && !flat && !grey && !o->no_geom && score_geometry(&dv, &res.mesh, o, t, method, dataset, scene)) {
        mf_log_warn("%s: geometry not scored: %s", scene, mf_error()); /* the other scores stand */
        mf_error_clear();
    }
    if (!rc) {
        static const char *names[7] = {"psnr", "ssim", "l1", "flip", "psnr_masked", "ssim_masked", "l1_masked"};
        const Acc *accs[4] = {&relit, &alb, &orm, &nv};
        static const char *kinds[4] = {"relit", "albedo", "orm", "nv"};
        for (int a = 0; a < 4 && !rc; ++a) {
            if (!accs[a]->n) continue;
            for (int k = 0; k < 7 && !rc; ++k) {
                if (a == 2 && (k == 1 || k == 3 || k == 5)) continue; /* ORM: PSNR and L1 as the paper */
                char name[32];
                snprintf(name, sizeof name, "%s_%s", kinds[a], names[k]);
                rc = ev_table_add(t, method, dataset, scene, name, accs[a]->v[k] / accs[a]->n);
            }
        }
        if (!rc && orm.n) rc = ev_table_add(t, method, dataset, scene, "orm3_psnr", orm3 / orm.n);
        if (!rc && orb_n) rc = ev_table_add(t, method, dataset, scene, "relit_orb_psnr_h", orb_h / orb_n);
        if (!rc && orb_n) rc = ev_table_add(t, method, dataset, scene, "relit_orb_psnr_l", orb_l / orb_n);
    }
    if (excluded) *excluded += bad;
out:
    mf_rtscene_free(rt);
    ds_views_free(&dv);
    ev_result_free(&res);
    return rc;
}

/* (h, w, 3) copy of channel ch of img (grey: data such as roughness, stored so that the grid's
 * sRGB encoding shows the raw value), or of its first 3 channels (ch < 0), optionally
 * Reinhard-tonemapped, optionally un-premultiplied by the alpha channel 3. */
static int grid_cell(const MfImage *img, int ch, int reinhard, int unpremult, MfImage *out) {
    int rc = mf_image_alloc(out, img->w, img->h, 3);
    if (rc) return rc;
    for (size_t i = 0; i < (size_t)img->w * img->h; ++i) {
        const float *p = img->data + i * img->c;
        float a = (unpremult && img->c == 4) ? p[3] : 1.0f;
        for (int c = 0; c < 3; ++c) {
            float v = ch >= 0 ? p[ch] : p[c];
            if (unpremult) v = a > 0.0f ? v / a : 0.0f;
            if (reinhard) v = v / (1.0f + v);
            if (ch >= 0) v = mf_srgb_to_linear(mf_clampf(v, 0.0f, 1.0f));
            out->data[3 * i + c] = v;
        }
    }
    return MF_OK;
}

const char *const ev_grid_col_names[EV_GRID_COLS] = {"relit", "albedo", "roughness", "metallic", "env map"};

int ev_eval_grid_row(const char *scene_dir, const char *result_dir, const EvEvalOpts *o, MfImage cells[EV_GRID_COLS]) {
    memset(cells, 0, EV_GRID_COLS * sizeof *cells);
    DsViews dv;
    DsLoadOptions lo = {1, 1, 1, 0, o->mask, o->quiet};
    int rc = ds_load(scene_dir, "test", &lo, &dv);
    if (rc) return rc;
    MfImage relit = {0}, env = {0};
    const DsView *v = &dv.views[0];
    if (!result_dir) { /* ground truth */
        if (dv.n_relight > 0 && !(rc = ds_load_relit(&dv, 0, 0, &relit))) rc = grid_cell(&relit, -1, 0, 1, &cells[0]);
        if (!rc && v->albedo.data) rc = grid_cell(&v->albedo, -1, 0, 0, &cells[1]);
        if (!rc && v->orm.data) rc = grid_cell(&v->orm, 1, 0, 0, &cells[2]);
        if (!rc && v->orm.data) rc = grid_cell(&v->orm, 2, 0, 0, &cells[3]);
        if (!rc && dv.env_path[0] && !(rc = ev_image_read(dv.env_path, "", MF_ENC_LINEAR, &env))) rc = grid_cell(&env, -1, 1, 0, &cells[4]);
    } else {
        EvResult res;
        if (!(rc = ev_result_load(result_dir, o->mesh_path, &res))) {
            MfRtScene *rt = NULL;
            MfTexMaterial mat = {.kd = &res.kd, .orm = &res.orm, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = res.has_normal ? &res.normal : NULL};
            MfRenderOpts ro = {.spp_sqrt = o->spp_sqrt, .pixel_samples = o->pixel_samples, .seed = o->seed, .lobes = MF_LOBE_ALL};
            MfRenderOut out = {0};
            MfEnvMap le;
            int have_le = 0;
            rc = mf_rtscene_new(&res.mesh, &rt);
            if (!rc && dv.n_relight > 0 && dv.relight_env[0][0] && !(rc = mf_env_load(&le, dv.relight_env[0]))) have_le = 1;
            MfRenderInput in = {rt, &res.mesh, &mat, 1, have_le ? &le : NULL, NULL, 0};
            if (!rc) rc = mf_render(&in, &v->cam, &ro, &out, NULL);
            if (!rc) {
                MfImage alb = {out.w, out.h, 3, out.albedo}, om = {out.w, out.h, 3, out.orm};
                /* rgb is premultiplied: divide by alpha through a temporary RGBA image */
                MfImage rgba = {0};
                if (!(rc = aov_rgba(out.rgb, out.alpha, out.w, out.h, &rgba))) rc = grid_cell(&rgba, -1, 0, 1, &cells[0]);
                mf_image_free(&rgba);
                if (!rc) rc = grid_cell(&alb, -1, 0, 0, &cells[1]);
                if (!rc) rc = grid_cell(&om, 1, 0, 0, &cells[2]);
                if (!rc) rc = grid_cell(&om, 2, 0, 0, &cells[3]);
            }
            if (!rc && res.has_env) rc = grid_cell(&res.env.img, -1, 1, 0, &cells[4]);
            mf_render_out_free(&out);
            if (have_le) mf_env_free(&le);
            mf_rtscene_free(rt);
            ev_result_free(&res);
        }
    }
    mf_image_free(&relit);
    mf_image_free(&env);
    ds_views_free(&dv);
    if (rc)
        for (int k = 0; k < EV_GRID_COLS; ++k) mf_image_free(&cells[k]);
    return rc;
}
