#include "render/mf_integrator.h"

#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "io/mf_exr.h"
#include "render/mf_estimator.h"

int mf_render_out_alloc(MfRenderOut *o, int w, int h) {
    if (w <= 0 || h <= 0) return mf_fail(MF_EARG, "render: image size %dx%d is invalid", w, h);
    size_t np = (size_t)w * h;
    float *mem = calloc(np * 20, sizeof(float));
    if (!mem) return mf_fail(MF_ENOMEM, "render: out of memory for %dx%d AOVs", w, h);
    MfRenderOut r;
    r.w = w;
    r.h = h;
    r.mem = mem;
    r.rgb = mem;
    r.alpha = r.rgb + 3 * np;
    r.albedo = r.alpha + np;
    r.orm = r.albedo + 3 * np;
    r.normal = r.orm + 3 * np;
    r.depth = r.normal + 3 * np;
    r.diffuse = r.depth + np;
    r.specular = r.diffuse + 3 * np;
    *o = r;
    return MF_OK;
}

void mf_render_out_free(MfRenderOut *o) {
    if (!o) return;
    free(o->mem);
    memset(o, 0, sizeof *o);
}

int mf_render_out_write_exr(const char *path, const MfRenderOut *o) {
    MfExrChannel ch[20] = {
        {"R", o->rgb, 3}, {"G", o->rgb + 1, 3}, {"B", o->rgb + 2, 3}, {"A", o->alpha, 1},
        {"albedo.R", o->albedo, 3}, {"albedo.G", o->albedo + 1, 3}, {"albedo.B", o->albedo + 2, 3},
        {"orm.R", o->orm, 3}, {"orm.G", o->orm + 1, 3}, {"orm.B", o->orm + 2, 3},
        {"normal.X", o->normal, 3}, {"normal.Y", o->normal + 1, 3}, {"normal.Z", o->normal + 2, 3},
        {"depth.Z", o->depth, 1},
        {"diffuse.R", o->diffuse, 3}, {"diffuse.G", o->diffuse + 1, 3}, {"diffuse.B", o->diffuse + 2, 3},
        {"specular.R", o->specular, 3}, {"specular.G", o->specular + 1, 3}, {"specular.B", o->specular + 2, 3},
    };
    return mf_exr_write(path, o->w, o->h, ch, 20, MF_EXR_FLOAT);
}

int mf_render_out_write_png(const char *path, const MfRenderOut *o) {
    MfImage img;
    int rc = mf_image_alloc(&img, o->w, o->h, 4);
    if (rc) return rc;
    for (size_t i = 0; i < (size_t)o->w * o->h; ++i) {
        float a = o->alpha[i], inv = a > 0.0f ? 1.0f / a : 0.0f;
        for (int c = 0; c < 3; ++c) img.data[4 * i + c] = o->rgb[3 * i + c] * inv;
        img.data[4 * i + 3] = a;
    }
    rc = mf_image_write(path, &img, MF_ENC_SRGB, 8);
    mf_image_free(&img);
    return rc;
}

void mf_raylog_free(MfRayLog *log) {
    if (!log) return;
    free(log->rays);
    memset(log, 0, sizeof *log);
}

/* The shared estimator (mf_estimator.h) for this input and options (tan: the tangents). */
static MfEstimator estimator_of(const MfRenderInput *in, const MfRenderOpts *opts, const float *tan) {
    MfEstimator e = {.rt = in->rt, .mesh = in->mesh, .mats = in->mats, .nmat = in->nmat, .env = in->env,
                     .lights = in->lights, .nlights = in->nlights, .tan = tan, .spp_sqrt = opts->spp_sqrt,
                     .pixel_samples = opts->pixel_samples, .lobes = opts->lobes, .seed = opts->seed,
                     .bounces = opts->bounces};
    return e;
}

static int check_args(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts) {
    if (!in || !in->rt || !in->mesh || !in->mats || in->nmat < 1) return mf_fail(MF_EARG, "render: incomplete input");
    MfEstimator e = estimator_of(in, opts, NULL);
    int rc = mf_est_check(&e, cam, "render");
    if (rc) return rc;
    for (int k = 0; k < in->nmat; ++k)
        if (in->mats[k].normal && in->mats[k].normal->c < 3) return mf_fail(MF_EARG, "render: a normal map needs 3 channels");
    return MF_OK;
}

int mf_render_rows(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts, int y0, int y1,
                   MfRenderOut *out, MfRayLog *logs, MfProgress *prog) {
    int rc = check_args(in, cam, opts);
    if (rc) return rc;
    if (out->w != cam->w || out->h != cam->h || y0 < 0 || y1 > cam->h || y0 > y1)
        return mf_fail(MF_EARG, "render: output %dx%d / rows [%d, %d) do not match the camera %dx%d", out->w, out->h, y0, y1,
                       cam->w, cam->h);
    const float *tan;
    float *tan_owned;
    if ((rc = mf_est_tangents(in->mesh, in->mats, in->nmat, NULL, &tan, &tan_owned))) return rc;
    MfEstimator e = estimator_of(in, opts, tan);
    mf_est_render_rows(&e, cam, y0, y1, out, logs, prog);
    free(tan_owned);
    return MF_OK;
}

int mf_render(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts, MfRenderOut *out, MfProgress *prog) {
    int rc = check_args(in, cam, opts);
    if (rc) return rc;
    MfRenderOut o;
    rc = mf_render_out_alloc(&o, cam->w, cam->h);
    if (rc) return rc;
    rc = mf_render_rows(in, cam, opts, 0, cam->h, &o, NULL, prog);
    if (rc) {
        mf_render_out_free(&o);
        return rc;
    }
    *out = o;
    return MF_OK;
}
