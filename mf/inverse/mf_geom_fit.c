#include "inverse/mf_geom_fit.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cJSON.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "io/mf_ckpt.h"
#include "io/mf_json.h"
#include "inverse/mf_loss.h"
#include "inverse/mf_optim.h"
#include "render/mf_antialias.h"
#include "render/mf_diffrender.h"
#include "render/mf_rtscene.h"

/* One view: coverage (h, w) from the G-buffer, antialiased; loss sum and dpos (nv, 3) +=
 * scale * d(sum of squared errors)/dpos. */
static int view_grad(const MfRtScene *rt, const MfCamera *cam, const MfImage *mask, int vi, double scale,
                     double *sse, float *dpos) {
    if (mask->w != cam->w || mask->h != cam->h || mask->c < 1)
        return mf_fail(MF_EARG, "geometry fit: view %d: mask is %dx%d, its camera %dx%d", vi, mask->w, mask->h, cam->w,
                       cam->h);
    MfAa *a;
    int rc = mf_aa_new(rt, cam, &a);
    if (rc) return rc;
    size_t np = (size_t)cam->w * cam->h;
    float *cov = malloc(np * sizeof *cov), *out = malloc(np * sizeof *out), *dout = malloc(np * sizeof *dout);
    if (!cov || !out || !dout) {
        rc = mf_fail(MF_ENOMEM, "geometry fit: out of memory for a %dx%d view", cam->w, cam->h);
        goto done;
    }
    const int *tri = mf_aa_tri(a);
    for (size_t i = 0; i < np; ++i) cov[i] = tri[i] >= 0 ? 1.0f : 0.0f;
    mf_aa_forward(a, cov, 1, out);
    double s = 0;
    for (size_t i = 0; i < np; ++i) {
        double d = (double)out[i] - (double)mask->data[i * (size_t)mask->c + (size_t)(mask->c - 1)];
        s += d * d;
        dout[i] = (float)(2.0 * d * scale);
    }
    *sse += s;
    mf_aa_backward(a, cov, 1, dout, NULL, dpos);
done:
    free(cov);
    free(out);
    free(dout);
    mf_aa_free(a);
    return rc;
}

/* One view's loss and vertex gradient: k indexes views[], scale = 1 / (views' pixels). */
typedef int (*ViewGrad)(void *ctx, const MfRtScene *rt, int k, double scale, float *dpos);

/* The skeleton both terms share: extract the mesh from (sdf, deform), build its Embree scene
 * (with vertex normals when normals), run fn on each of views (nviews,), check the vertex
 * gradient, and send it through marching tets into dsdf and ddeform (+=). *rebuild_s (if not
 * NULL) = wall seconds of the extraction and the scene build. */
static int over_views(const MfTetGrid *g, const float *sdf, const float *deform, const MfCamera *cams, const int *views,
                      int nviews, int normals, ViewGrad fn, void *ctx, float *dsdf, float *ddeform, int *nt, double *rebuild_s) {
    MfTetMesh tm;
    double t0 = mf_now();
    int rc = mf_tetgrid_extract(g, sdf, deform, &tm);
    if (rc) return rc;
    MfRtScene *rt = NULL;
    float *dpos = calloc((size_t)tm.mesh.nv * 3, sizeof *dpos);
    if (!dpos) rc = mf_fail(MF_ENOMEM, "geometry fit: out of memory for %d vertices", tm.mesh.nv);
    if (!rc && normals) rc = mf_mesh_compute_normals(&tm.mesh);
    if (!rc) rc = mf_rtscene_new(&tm.mesh, &rt);
    if (rebuild_s) *rebuild_s = mf_now() - t0;
    size_t npix = 0;
    for (int k = 0; k < nviews; ++k) npix += (size_t)cams[views[k]].w * cams[views[k]].h;
    for (int k = 0; k < nviews && !rc; ++k) rc = fn(ctx, rt, k, 1.0 / (double)npix, dpos);
    for (size_t i = 0; !rc && i < (size_t)tm.mesh.nv * 3; ++i)
        if (!isfinite(dpos[i])) rc = mf_fail(MF_ENAN, "geometry fit: non-finite vertex gradient at vertex %zu", i / 3);
    if (!rc) mf_tetgrid_backward(g, sdf, deform, &tm, dpos, dsdf, deform ? ddeform : NULL);
    if (!rc && nt) *nt = tm.mesh.nt;
    mf_rtscene_free(rt);
    free(dpos);
    mf_tetmesh_free(&tm);
    return rc;
}

typedef struct {
    const MfCamera *cams;
    const MfImage *masks;
    const int *views;
    double mse; /* sum of the views' squared errors x scale */
} MaskCtx;

static int mask_view(void *ctx, const MfRtScene *rt, int k, double scale, float *dpos) {
    MaskCtx *c = ctx;
    int v = c->views[k];
    double sse = 0;
    int rc = view_grad(rt, &c->cams[v], &c->masks[v], v, scale, &sse, dpos);
    c->mse += sse * scale;
    return rc;
}

int mf_geom_mask_grad(const MfTetGrid *g, const float *sdf, const float *deform, const MfCamera *cams,
                      const MfImage *masks, const int *views, int nviews, float *dsdf, float *ddeform, double *loss,
                      int *nt, double *rebuild_s) {
    if (nviews < 1) return mf_fail(MF_EARG, "geometry fit: no views");
    MaskCtx c = {cams, masks, views, 0};
    int rc = over_views(g, sdf, deform, cams, views, nviews, 0, mask_view, &c, dsdf, ddeform, nt, rebuild_s);
    if (!rc) *loss = c.mse;
    return rc;
}

/* The colour term's unknowns besides the SDF: volume textures whose grids are Adam blocks' values
 * (borrowed) and the env map (its texels copied from its block after every step). */
typedef struct {
    MfVoltex kd, orm;
    MfEnvMap env;
} ColorState;

/* One view of the colour term: forward (antialiased), loss, adjoints, backward into dpos and the
 * state's gradients (dvkd, dvorm, denv). scale: 1 / (views' pixels). */
static int color_view(const MfRtScene *rt, const ColorState *cs, const MfCamera *cam, const MfImage *ref, int vi, float color,
                      uint64_t seed, double scale, double *lrgb, double *lmask, float *dpos, float *dvkd, float *dvorm, float *denv) {
    if (ref->w != cam->w || ref->h != cam->h || ref->c < 4)
        return mf_fail(MF_EARG, "geometry fit: view %d: the colour term needs an RGBA image of its camera's size (%dx%d, %d channels)",
                       vi, ref->w, ref->h, ref->c);
    size_t np = (size_t)cam->w * cam->h;
    MfRenderOut out = {0};
    float *buf = malloc(np * 8 * sizeof *buf); /* target (np, 3), drgb (np, 3), mask (np), dalpha (np) */
    int rc = buf ? mf_render_out_alloc(&out, cam->w, cam->h) : mf_fail(MF_ENOMEM, "geometry fit: out of memory for a view");
    if (rc) {
        free(buf);
        return rc;
    }
    float *target = buf, *drgb = buf + 3 * np, *mask = buf + 6 * np, *dalpha = buf + 7 * np;
    for (size_t i = 0; i < np; ++i) {
        const float *px = ref->data + i * (size_t)ref->c;
        mask[i] = px[ref->c - 1];
        for (int c = 0; c < 3; ++c) target[3 * i + c] = px[c] * mask[i];
    }
    MfDiffScene s = {.rt = rt, .vkd = &cs->kd, .vorm = &cs->orm, .env = &cs->env};
    MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = 1, .seed = seed, .antialias = 1};
    if (!(rc = mf_diff_forward(&s, cam, &o, &out))) {
        *lrgb += mf_loss_logl1_fwd(out.rgb, target, np * 3, 0.0f) * (double)np * scale;
        *lmask += mf_loss_mse_fwd(out.alpha, mask, np) * (double)np * scale;
        memset(drgb, 0, np * 3 * sizeof *drgb);
        memset(dalpha, 0, np * sizeof *dalpha);
        /* the means' gradients, each view's share of the step's pixels */
        mf_loss_logl1_bwd(out.rgb, target, np * 3, 0.0f, (float)(color * (double)np * scale), drgb);
        mf_loss_mse_bwd(out.alpha, mask, np, (float)((double)np * scale), dalpha);
        MfDiffAdjoint adj = {.drgb = drgb, .dalpha = dalpha};
        MfDiffGrads gr = {.dpos = dpos, .dvkd = dvkd, .dvorm = dvorm, .denv = denv};
        o.seed = mf_hash64(seed, 1); /* decorrelated from the forward pass */
        rc = mf_diff_backward(&s, cam, &o, &adj, &gr);
    }
    mf_render_out_free(&out);
    free(buf);
    return rc;
}

typedef struct {
    const MfCamera *cams;
    const MfImage *imgs;
    const int *views;
    const ColorState *cs;
    float color;
    uint64_t seed;
    float *dvkd, *dvorm, *denv;
    MfGeomFitStep *st;
} ColorCtx;

static int color_view_k(void *ctx, const MfRtScene *rt, int k, double scale, float *dpos) {
    ColorCtx *c = ctx;
    int v = c->views[k];
    return color_view(rt, c->cs, &c->cams[v], &c->imgs[v], v, c->color, mf_hash64(c->seed, (uint64_t)k), scale, &c->st->rgb,
                      &c->st->mask, dpos, c->dvkd, c->dvorm, c->denv);
}

/* The colour term (with the mask term) over views: dsdf, ddeform and the state's gradients +=. */
static int color_grad(const MfTetGrid *g, const float *sdf, const float *deform, const MfCamera *cams, const MfImage *imgs,
                      const int *views, int nviews, const ColorState *cs, float color, uint64_t seed, float *dsdf,
                      float *ddeform, float *dvkd, float *dvorm, float *denv, MfGeomFitStep *st) {
    ColorCtx c = {cams, imgs, views, cs, color, seed, dvkd, dvorm, denv, st};
    st->rgb = st->mask = 0;
    return over_views(g, sdf, deform, cams, views, nviews, 1, color_view_k, &c, dsdf, ddeform, &st->nt, &st->rebuild_s);
}

static double sigmoid(double x) { return 1.0 / (1.0 + exp(-x)); }
/* BCE with logits: -(y log s(x) + (1 - y) log(1 - s(x))), stable form */
static double bce_logits(double x, double y) { return fmax(x, 0.0) - x * y + log1p(exp(-fabs(x))); }

double mf_geom_sdf_reg(const MfTetGrid *g, const float *sdf, float weight, float *dsdf) {
    const int r1 = g->res + 1;
    size_t count = 0;
    double sum = 0;
    /* two passes: count the sign-change edges, then the mean and its gradient */
    for (int pass = 0; pass < 2; ++pass) {
        double w = pass ? (double)weight / (double)count : 0;
        for (int k = 0; k < r1; ++k)
            for (int j = 0; j < r1; ++j)
                for (int i = 0; i < r1; ++i) {
                    size_t a = (size_t)i + (size_t)r1 * ((size_t)j + (size_t)r1 * (size_t)k);
                    for (int e = 1; e < 8; ++e) {
                        int di = e & 1, dj = (e >> 1) & 1, dk = (e >> 2) & 1;
                        if (i + di >= r1 || j + dj >= r1 || k + dk >= r1) continue;
                        size_t b = a + (size_t)di + (size_t)r1 * ((size_t)dj + (size_t)r1 * (size_t)dk);
                        int pa = sdf[a] > 0, pb = sdf[b] > 0;
                        if (pa == pb) continue;
                        if (!pass) {
                            ++count;
                            continue;
                        }
                        sum += bce_logits(sdf[a], pb) + bce_logits(sdf[b], pa);
                        if (dsdf) {
                            dsdf[a] += (float)(w * (sigmoid(sdf[a]) - pb));
                            dsdf[b] += (float)(w * (sigmoid(sdf[b]) - pa));
                        }
                    }
                }
        if (!count) return 0;
    }
    return (double)weight * sum / (double)count;
}

/* The colour term's state over g's box: volume textures viewing blocks kd, orm (borrowed grids)
 * and an env of constant radiance level. */
static int color_state_init(const MfTetGrid *g, const MfParamBlock *kd, const MfParamBlock *orm, float level, ColorState *cs) {
    memset(cs, 0, sizeof *cs);
    const float lo[3] = {g->lo.x, g->lo.y, g->lo.z}, ext = g->cell * (float)g->res;
    const float hi[3] = {lo[0] + ext, lo[1] + ext, lo[2] + ext};
    for (int a = 0; a < 3; ++a) cs->kd.lo[a] = cs->orm.lo[a] = lo[a], cs->kd.hi[a] = cs->orm.hi[a] = hi[a];
    cs->kd.res = cs->orm.res = MF_GEOM_VOL_RES;
    cs->kd.c = cs->orm.c = 3;
    cs->kd.grid = kd->p, cs->orm.grid = orm->p;
    return mf_env_init_constant(&cs->env, MF_GEOM_ENV_W, MF_GEOM_ENV_W / 2, mf_v3s(level));
}

/* Twice the mean radiance of the references' masked pixels (straight colour, alpha > 0.5). */
static float reference_level(const MfImage *imgs, int n) {
    double sum = 0;
    size_t cnt = 0;
    for (int v = 0; v < n; ++v) {
        const MfImage *r = &imgs[v];
        if (r->c < 4) continue;
        for (size_t i = 0; i < (size_t)r->w * r->h; ++i) {
            const float *px = r->data + i * (size_t)r->c;
            if (px[r->c - 1] > 0.5f) sum += (px[0] + px[1] + px[2]) / 3.0, ++cnt;
        }
    }
    double m = cnt ? 2.0 * sum / (double)cnt : 1.0;
    return m > 1e-6 && isfinite(m) ? (float)m : 1.0f;
}

/* ---- the state file: blocks' values and moments (p, m, v each), step, options and log in the meta ---- */

/* The options a state must match, as "key":value pairs of its meta. */
static int state_opts(const MfGeomFitOpts *o, char *buf, size_t cap) {
    return snprintf(buf, cap, "\"lr_sdf\":%.9g,\"lr_deform\":%.9g,\"sdf_reg\":%.9g,\"views_per_step\":%d,\"color\":%.9g,\"seed\":%llu,"
                    "\"start\":%d",
                    (double)o->lr_sdf, (double)o->lr_deform, (double)o->sdf_reg, o->views_per_step, (double)o->color,
                    (unsigned long long)o->seed, o->start);
}

static int state_save(const char *path, const MfParamBlock *b, int nb, const MfAdam *adam, int step, const MfGeomFitOpts *o,
                      const MfGeomFitStep *log) {
    MfTensorSpec specs[15];
    int ns = mf_param_ckpt_specs(b, nb, specs);
    size_t cap = 512 + (size_t)step * 96;
    MfParamSnapshot snap = {0};
    char *meta = malloc(cap);
    int rc = meta ? mf_param_snapshot_save(&snap, b, nb, adam) : mf_fail(MF_ENOMEM, "%s: out of memory", path);
    if (!rc) {
        size_t len = (size_t)snprintf(meta, cap, "{\"kind\":\"mf-geom-fit\",\"step\":%d,\"adam_t\":%ld,", step, adam->t);
        len += (size_t)state_opts(o, meta + len, cap - len);
        len += (size_t)snprintf(meta + len, cap - len, ",\"log\":[");
        for (int i = 0; i < step; ++i) /* mask, weighted regulariser, triangles, colour: exact in %.17g */
            len += (size_t)snprintf(meta + len, cap - len, "%s[%.17g,%.17g,%d,%.17g]", i ? "," : "", log[i].mask, log[i].reg,
                                    log[i].nt, log[i].rgb);
        snprintf(meta + len, cap - len, "]}");
        rc = mf_ckpt_save(path, specs, ns, snap.buf, meta);
    }
    mf_param_snapshot_free(&snap);
    free(meta);
    return rc;
}

/* Loads path into the blocks, Adam and log[0..step); *step = the steps it holds. */
static int state_load(const char *path, MfParamBlock *b, int nb, MfAdam *adam, const MfGeomFitOpts *o, MfGeomFitStep *log,
                      int *step) {
    MfTensorSpec specs[15];
    int ns = mf_param_ckpt_specs(b, nb, specs);
    size_t total = mf_specs_numel(specs, ns);
    float *buf = malloc(total * sizeof *buf + 1);
    char *meta = NULL, want[512];
    cJSON *root = NULL;
    const cJSON *rows = NULL;
    int rc = buf ? mf_ckpt_load(path, specs, ns, buf, &meta) : mf_fail(MF_ENOMEM, "%s: out of memory", path);
    if (!rc) rc = mf_json_parse(path, meta, strlen(meta), &root);
    double t = 0;
    int k = 0, nrows = 0;
    if (!rc) rc = mf_json_int(path, "state", root, "step", &k);
    if (!rc) rc = mf_json_number(path, "state", root, "adam_t", &t);
    if (!rc) rc = mf_json_array(path, "state", root, "log", &rows, &nrows);
    if (!rc && (k < 0 || k > o->iters || nrows != k))
        rc = mf_fail(MF_EARG, "%s: holds %d steps (log %d rows), this fit asks for %d: run without --resume to start afresh", path, k,
                     nrows, o->iters);
    /* every option that shapes a step must match: compare the meta's pairs as written */
    state_opts(o, want, sizeof want);
    if (!rc && !strstr(meta, want)) {
        const char *its = strstr(meta, "\"lr_sdf\""), *end = its ? strstr(its, ",\"log\"") : NULL;
        rc = mf_fail(MF_EARG, "%s: written with other geometry-fit options ({%.*s}; this run {%s}): run without --resume to start afresh",
                     path, its && end ? (int)(end - its) : 0, its ? its : "", want);
    }
    for (int i = 0; !rc && i < k; ++i) {
        const cJSON *r = cJSON_GetArrayItem(rows, i);
        double v[4];
        for (int j = 0; j < 4 && !rc; ++j) {
            const cJSON *x = cJSON_GetArrayItem(r, j);
            if (cJSON_GetArraySize(r) != 4 || !cJSON_IsNumber(x))
                rc = mf_fail(MF_EFORMAT, "%s: log row %d is not [mask, reg, triangles, rgb]", path, i);
            else
                v[j] = x->valuedouble;
        }
        if (!rc) log[i] = (MfGeomFitStep){.mask = v[0], .reg = v[1], .nt = (int)v[2], .rgb = v[3]};
    }
    if (!rc) { /* buf is in a snapshot's order (mf_param_ckpt_specs) */
        MfParamSnapshot snap = {.buf = buf, .len = total, .t = (long)t};
        mf_param_snapshot_restore(&snap, b, nb, adam);
        *step = k;
    }
    cJSON_Delete(root);
    free(buf), free(meta);
    return rc;
}

int mf_geom_fit(const MfTetGrid *g, float *sdf, float *deform, const MfCamera *cams, const MfImage *masks, int n,
                const MfGeomFitOpts *opt, MfGeomFitStep *log, int *done) {
    if (done) *done = 0;
    if (opt->resumed) *opt->resumed = 0;
    if (n < 1 || opt->iters < 1 || !(opt->lr_sdf > 0) || !(opt->lr_deform >= 0) || !(opt->sdf_reg >= 0) || !(opt->color >= 0))
        return mf_fail(MF_EARG, "geometry fit: need views (%d), iters >= 1 (%d), lr_sdf > 0 (%g), lr_deform >= 0 (%g), "
                                "sdf_reg >= 0 (%g), color >= 0 (%g)", n, opt->iters, (double)opt->lr_sdf, (double)opt->lr_deform,
                       (double)opt->sdf_reg, (double)opt->color);
    size_t nv = mf_tetgrid_nverts(g), nvol = (size_t)MF_GEOM_VOL_RES * MF_GEOM_VOL_RES * MF_GEOM_VOL_RES * 3;
    int use_def = deform && opt->lr_deform > 0, use_col = opt->color > 0;
    /* blocks: sdf, [deform], [kd, orm, env] */
    int idef = use_def ? 1 : -1, ikd = use_col ? 1 + use_def : -1, iorm = ikd + 1, ienv = ikd + 2;
    int nb = 1 + use_def + 3 * use_col;
    int bsize = opt->views_per_step > 0 && opt->views_per_step < n ? opt->views_per_step : n;
    MfParamBlock b[5];
    memset(b, 0, sizeof b);
    ColorState cs;
    memset(&cs, 0, sizeof cs);
    float level = use_col ? reference_level(masks, n) : 1.0f;
    int *views = malloc((size_t)bsize * sizeof *views);
    int rc = views ? mf_param_init(&b[0], "sdf", nv, 1, sdf) : mf_fail(MF_ENOMEM, "geometry fit: out of memory");
    if (!rc && use_def) {
        rc = mf_param_init(&b[idef], "deform", nv * 3, 3, deform);
        b[idef].lr_scale = opt->lr_deform / opt->lr_sdf;
    }
    if (!rc && use_col && !(rc = mf_param_init(&b[ikd], "vol_kd", nvol, 3, NULL)) && !(rc = mf_param_init(&b[iorm], "vol_orm", nvol, 3, NULL))) {
        for (size_t i = 0; i < nvol; i += 3) {
            b[ikd].p[i] = b[ikd].p[i + 1] = b[ikd].p[i + 2] = 0.5f;
            b[iorm].p[i] = 1.0f, b[iorm].p[i + 1] = 0.5f, b[iorm].p[i + 2] = 0.0f;
        }
        for (int c = 0; c < 3; ++c) mf_param_set_bounds(&b[ikd], c, 0.0f, 1.0f);
        mf_param_set_bounds(&b[iorm], 0, 1.0f, 1.0f);
        mf_param_set_bounds(&b[iorm], 1, 0.08f, 1.0f);
        mf_param_set_bounds(&b[iorm], 2, 0.0f, 1.0f);
        b[ikd].lr_scale = b[iorm].lr_scale = MF_GEOM_LR_MAT / opt->lr_sdf;
        if (!(rc = color_state_init(g, &b[ikd], &b[iorm], level, &cs)) &&
            !(rc = mf_param_init(&b[ienv], "env", (size_t)cs.env.img.w * cs.env.img.h * 3, 3, cs.env.img.data))) {
            for (int c = 0; c < 3; ++c) mf_param_set_bounds(&b[ienv], c, 1e-3f * level, INFINITY);
            b[ienv].lr_scale = MF_GEOM_LR_ENV * level / opt->lr_sdf;
        }
    }
    MfAdam adam;
    mf_adam_init(&adam, opt->lr_sdf);
    int it = 0;
    /* a state file carries the log, so a fit that keeps one keeps a log (its own when log is NULL) */
    MfGeomFitStep *own = !rc && opt->state && !log ? calloc((size_t)opt->iters, sizeof *own) : NULL;
    if (own) log = own;
    else if (!rc && opt->state && !log) rc = mf_fail(MF_ENOMEM, "geometry fit: out of memory");
    if (!rc && opt->state && opt->resume && mf_file_exists(opt->state)) {
        rc = state_load(opt->state, b, nb, &adam, opt, log, &it);
        if (!rc && use_col) { /* the env's texels and sampling tables follow its block */
            memcpy(cs.env.img.data, b[ienv].p, b[ienv].n * sizeof(float));
            rc = mf_env_update(&cs.env);
        }
        if (!rc) mf_log_info("geometry fit: resuming from %s at step %d of %d", opt->state, it, opt->iters);
        if (!rc && opt->resumed) *opt->resumed = it;
    }
    for (; !rc && it < opt->iters; ++it) {
        for (int k = 0; k < bsize; ++k) views[k] = (int)(((long)it * bsize + k) % n);
        for (int k = 0; k < nb; ++k) mf_param_zero_grad(&b[k]);
        MfGeomFitStep st = {0};
        /* deform is passed even when frozen, so the surface is the deformed grid's */
        const float *def = use_def ? b[idef].p : deform;
        float *ddef = use_def ? b[idef].g : NULL;
        if (use_col)
            rc = color_grad(g, b[0].p, def, cams, masks, views, bsize, &cs, opt->color, mf_hash64(opt->seed, (uint64_t)it), b[0].g, ddef,
                            b[ikd].g, b[iorm].g, b[ienv].g, &st);
        else
            rc = mf_geom_mask_grad(g, b[0].p, def, cams, masks, views, bsize, b[0].g, ddef, &st.mask, &st.nt, &st.rebuild_s);
        if (rc) break;
        st.reg = opt->sdf_reg > 0 ? mf_geom_sdf_reg(g, b[0].p, opt->sdf_reg, b[0].g) : 0;
        if (log) log[it] = st;
        rc = mf_adam_step(&adam, b, nb, mf_lr_schedule(opt->lr_sdf, it));
        if (!rc && use_col) { /* the env's texels and sampling tables follow its block */
            memcpy(cs.env.img.data, b[ienv].p, b[ienv].n * sizeof(float));
            rc = mf_env_update(&cs.env);
        }
        if (!rc && opt->state && ((opt->state_every > 0 && (it + 1) % opt->state_every == 0) || it + 1 == opt->iters))
            rc = state_save(opt->state, b, nb, &adam, it + 1, opt, log);
    }
    if (rc) rc = mf_fail_prefix(rc, "geometry fit: step %d", it);
    if (b[0].p) memcpy(sdf, b[0].p, nv * sizeof *sdf);
    if (use_def && b[idef].p) memcpy(deform, b[idef].p, nv * 3 * sizeof *deform);
    if (done) *done = it;
    mf_env_free(&cs.env);
    for (int k = 0; k < 5; ++k) mf_param_free(&b[k]);
    free(views), free(own);
    return rc;
}
