#include "render/mf_integrator.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "io/mf_exr.h"
#include "render/mf_normalmap.h"
#include "scene/mf_tangent.h"
#include "scene/mf_texture.h"

#define MF_SHADOW_EPS 0.001f
#define MF_MAX_PIXEL_SAMPLES 1024

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

static void raylog_push(MfRayLog *log, MfVec3 org, MfVec3 dir, float tnear, float tfar, int kind) {
    if (!log) return;
    if (log->n == log->cap) {
        size_t cap = log->cap ? 2 * log->cap : 4096;
        MfRayRec *r = realloc(log->rays, cap * sizeof *r);
        if (!r) return; /* the benchmark then replays fewer rays; it compares counts */
        log->rays = r;
        log->cap = cap;
    }
    MfRayRec *r = &log->rays[log->n++];
    r->org[0] = org.x; r->org[1] = org.y; r->org[2] = org.z;
    r->dir[0] = dir.x; r->dir[1] = dir.y; r->dir[2] = dir.z;
    r->tnear = tnear;
    r->tfar = tfar;
    r->kind = kind;
}

static MfMaterial lookup_material(const MfRenderInput *in, const MfHit *h, MfVec3 *orm_out) {
    int id = (h->mat >= 0 && h->mat < in->nmat) ? h->mat : 0;
    const MfTexMaterial *tm = &in->mats[id];
    MfMaterial m;
    float buf[4];
    if (tm->kd) {
        mf_tex_sample(tm->kd, h->uv.x, h->uv.y, MF_WRAP_REPEAT, buf);
        m.kd = mf_v3(buf[0], buf[1], buf[2]);
    } else {
        m.kd = tm->kd_const;
    }
    MfVec3 orm;
    if (tm->orm) {
        mf_tex_sample(tm->orm, h->uv.x, h->uv.y, MF_WRAP_REPEAT, buf);
        orm = mf_v3(buf[0], buf[1], buf[2]);
    } else {
        orm = tm->orm_const;
    }
    m.roughness = mf_clampf(orm.y, 0.0f, 1.0f);
    m.metallic = mf_clampf(orm.z, 0.0f, 1.0f);
    *orm_out = orm;
    return m;
}

/* Shadow-ray origin: offset along the geometric normal on the side of wi. */
static inline MfVec3 shadow_origin(const MfHit *h, MfVec3 wi) {
    float s = mf_dot(h->ng, wi) >= 0.0f ? MF_SHADOW_EPS : -MF_SHADOW_EPS;
    return mf_madd(h->p, h->ng, s);
}

static int visible(const MfRenderInput *in, const MfHit *h, MfVec3 wi, float dist, MfRayLog *log) {
    MfVec3 o = shadow_origin(h, wi);
    float tfar = isfinite(dist) ? dist * (1.0f - 1e-4f) : INFINITY;
    raylog_push(log, o, wi, 0.0f, tfar, 1);
    return !mf_rtscene_occluded(in->rt, o, wi, 0.0f, tfar);
}

typedef struct {
    MfVec3 diffuse, specular;
} Shade;

/* Samples are processed in batches: all light-sample directions of a batch first (their CDF
 * searches miss the cache independently, so the CPU overlaps them), then the BRDF and shadow
 * rays, then the radiance lookups of the visible ones. The random numbers, the rays and the
 * order of the sums are those of one-sample-at-a-time, so the result is identical. */
#define SHADE_BATCH 64

typedef struct {
    MfVec3 wi_w, fs; /* world direction, specular BRDF value */
    float fd, p;     /* demodulated diffuse value; MIS weight (light loop) or BSDF pdf (BSDF loop) */
} Accepted;

/* Direct light at a hit: demodulated diffuse and specular radiance toward wo_w. */
static Shade shade(const MfRenderInput *in, const MfRenderOpts *opts, const MfHit *h, MfVec3 ns, const MfMaterial *mat,
                   MfVec3 wo_w, MfRng *rng, MfRayLog *log) {
    Shade s = {mf_v3s(0.0f), mf_v3s(0.0f)};
    MfFrame fr = mf_frame(ns);
    MfVec3 wo = mf_to_local(&fr, wo_w);
    if (wo.z <= 0.0f) return s;
    int lobes = opts->lobes;
    if (in->env) {
        MfBrdfCtx bc;
        mf_brdf_prepare(&bc, mat, wo, lobes);
        int n = opts->spp_sqrt, N = n * n;
        float inv_N = 1.0f / (float)(n * n);
        MfVec3 dir[SHADE_BATCH];
        float pdf[SHADE_BATCH], us1[SHADE_BATCH], us2[SHADE_BATCH];
        MfVec3 Ls[SHADE_BATCH];
        Accepted acc[SHADE_BATCH];
        /* Light samples: acc[].p = MIS weight. */
        for (int b0 = 0; b0 < N; b0 += SHADE_BATCH) {
            int nb = N - b0 < SHADE_BATCH ? N - b0 : SHADE_BATCH, na = 0;
            for (int t = 0; t < nb; ++t) mf_rng_stratum2(rng, b0 + t, n, &us1[t], &us2[t]);
            mf_env_sample_dir_n(in->env, nb, us1, us2, dir, pdf);
            for (int t = 0; t < nb; ++t) {
                MfVec3 wi_w = dir[t];
                float pl = pdf[t];
                if (!(pl > 0.0f) || mf_dot(wi_w, h->ng) <= 0.0f) continue;
                MfVec3 wi = mf_to_local(&fr, wi_w);
                if (wi.z <= 0.0f) continue;
                float pb;
                MfBrdfValue f = mf_brdf_ctx_eval_pdf(&bc, wi, &pb);
                if (f.diffuse_demod <= 0.0f && mf_maxc(f.specular) <= 0.0f) continue;
                /* visibility first: occluded samples need no MIS weight */
                if (!visible(in, h, wi_w, INFINITY, log)) continue;
                float w = inv_N / (pl + pb);
                if (!(w > 0.0f) || !isfinite(w)) continue;
                acc[na++] = (Accepted){wi_w, f.specular, f.diffuse_demod, w};
            }
            for (int a = 0; a < na; ++a) dir[a] = acc[a].wi_w;
            mf_env_eval_pdf_n(in->env, na, dir, Ls, NULL);
            for (int a = 0; a < na; ++a) {
                MfVec3 L = Ls[a];
                float w = acc[a].p;
                s.diffuse = mf_madd(s.diffuse, L, acc[a].fd * w);
                s.specular = mf_add(s.specular, mf_scale(mf_mul(L, acc[a].fs), w));
            }
        }
        /* BSDF samples: acc[].p = BSDF pdf. */
        for (int b0 = 0; b0 < N; b0 += SHADE_BATCH) {
            int nb = N - b0 < SHADE_BATCH ? N - b0 : SHADE_BATCH, na = 0;
            for (int t = 0; t < nb; ++t) {
                float u0 = mf_rng_float(rng), u1, u2;
                mf_rng_stratum2(rng, b0 + t, n, &u1, &u2);
                MfVec3 wi;
                float pb;
                MfBrdfValue f;
                if (!mf_brdf_ctx_sample(&bc, u0, u1, u2, &wi, &pb, &f)) continue;
                if (!(pb > 0.0f) || wi.z <= 0.0f) continue;
                MfVec3 wi_w = mf_to_world(&fr, wi);
                if (mf_dot(wi_w, h->ng) <= 0.0f) continue;
                if (f.diffuse_demod <= 0.0f && mf_maxc(f.specular) <= 0.0f) continue;
                if (!visible(in, h, wi_w, INFINITY, log)) continue;
                acc[na++] = (Accepted){wi_w, f.specular, f.diffuse_demod, pb};
            }
            for (int a = 0; a < na; ++a) dir[a] = acc[a].wi_w;
            mf_env_eval_pdf_n(in->env, na, dir, Ls, pdf);
            for (int a = 0; a < na; ++a) {
                MfVec3 L = Ls[a];
                float w = inv_N / (pdf[a] + acc[a].p);
                if (!(w > 0.0f) || !isfinite(w)) continue;
                s.diffuse = mf_madd(s.diffuse, L, acc[a].fd * w);
                s.specular = mf_add(s.specular, mf_scale(mf_mul(L, acc[a].fs), w));
            }
        }
    }
    for (int k = 0; k < in->nlights; ++k) {
        MfVec3 wi_w, E;
        float dist;
        mf_light_incident(&in->lights[k], h->p, &wi_w, &dist, &E);
        if (mf_dot(wi_w, h->ng) <= 0.0f || mf_maxc(E) <= 0.0f) continue;
        MfVec3 wi = mf_to_local(&fr, wi_w);
        if (wi.z <= 0.0f) continue;
        MfBrdfValue f = mf_brdf_eval(mat, wo, wi, lobes);
        if (f.diffuse_demod <= 0.0f && mf_maxc(f.specular) <= 0.0f) continue;
        if (!visible(in, h, wi_w, dist, log)) continue;
        s.diffuse = mf_madd(s.diffuse, E, f.diffuse_demod);
        s.specular = mf_add(s.specular, mf_mul(E, f.specular));
    }
    return s;
}

/* The shading normal at a hit: the material's normal map (tan: the mesh's tangents), or ns. */
static MfVec3 shading_normal(const MfRenderInput *in, const float *tan, const MfHit *h, MfVec3 wo_w) {
    int id = (h->mat >= 0 && h->mat < in->nmat) ? h->mat : 0;
    const MfImage *map = in->mats[id].normal;
    if (!map || !tan) return h->ns;
    MfNmapFrame f = mf_nmap_frame(in->mesh, tan, h);
    return mf_nmap_normal(&f, map, h->uv, wo_w);
}

static void render_pixel(const MfRenderInput *in, const float *tan, const MfCamera *cam, const MfRenderOpts *opts, int x,
                         int y, MfRenderOut *out, MfRayLog *log) {
    MfRng rng;
    mf_rng_seed(&rng, opts->seed, (uint64_t)y * (uint64_t)cam->w + (uint64_t)x);
    int ps = opts->pixel_samples;
    int perm[MF_MAX_PIXEL_SAMPLES];
    for (int k = 0; k < ps; ++k) perm[k] = k;
    for (int k = ps - 1; k > 0; --k) {
        int r = (int)mf_rng_below(&rng, (uint32_t)(k + 1));
        int t = perm[k];
        perm[k] = perm[r];
        perm[r] = t;
    }
    MfVec3 fwd = mf_v3(-cam->c2w.m[2], -cam->c2w.m[6], -cam->c2w.m[10]);
    MfVec3 rgb = mf_v3s(0), dif = mf_v3s(0), spec = mf_v3s(0), alb = mf_v3s(0), orm = mf_v3s(0), nrm = mf_v3s(0);
    float depth = 0.0f;
    int hits = 0;
    float inv_ps = 1.0f / (float)ps;
    for (int k = 0; k < ps; ++k) {
        float px = (float)x + ((float)k + mf_rng_float(&rng)) * inv_ps;
        float py = (float)y + ((float)perm[k] + mf_rng_float(&rng)) * inv_ps;
        if (ps == 1) {
            px = (float)x + mf_rng_float(&rng);
            py = (float)y + mf_rng_float(&rng);
        }
        MfVec3 org, dir;
        mf_camera_ray(cam, px, py, &org, &dir);
        raylog_push(log, org, dir, 0.0f, INFINITY, 0);
        MfHit h;
        if (!mf_rtscene_intersect(in->rt, org, dir, 0.0f, INFINITY, &h)) continue;
        ++hits;
        MfVec3 o;
        MfMaterial mat = lookup_material(in, &h, &o);
        MfVec3 ns = shading_normal(in, tan, &h, mf_neg(dir));
        Shade s = shade(in, opts, &h, ns, &mat, mf_neg(dir), &rng, log);
        MfVec3 kdw = mf_scale(mat.kd, 1.0f - mat.metallic);
        if (!(opts->lobes & MF_LOBE_DIFFUSE)) s.diffuse = mf_v3s(0.0f);
        MfVec3 c = mf_add(mf_mul(kdw, s.diffuse), s.specular);
        rgb = mf_add(rgb, c);
        dif = mf_add(dif, s.diffuse);
        spec = mf_add(spec, s.specular);
        alb = mf_add(alb, mat.kd);
        orm = mf_add(orm, o);
        nrm = mf_add(nrm, ns);
        depth += h.t * mf_dot(dir, fwd);
    }
    size_t i = (size_t)y * cam->w + x;
    out->alpha[i] = (float)hits * inv_ps;
    float inv_h = hits ? 1.0f / (float)hits : 0.0f;
    MfVec3 n = hits ? mf_norm(nrm) : nrm;
    const MfVec3 v3[6] = {mf_scale(rgb, inv_ps), mf_scale(dif, inv_ps), mf_scale(spec, inv_ps),
                          mf_scale(alb, inv_h), mf_scale(orm, inv_h), n};
    float *dst[6] = {out->rgb, out->diffuse, out->specular, out->albedo, out->orm, out->normal};
    for (int a = 0; a < 6; ++a) {
        dst[a][3 * i] = v3[a].x;
        dst[a][3 * i + 1] = v3[a].y;
        dst[a][3 * i + 2] = v3[a].z;
    }
    out->depth[i] = depth * inv_h;
}

static int check_args(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts) {
    if (!in || !in->rt || !in->mesh || !in->mats || in->nmat < 1) return mf_fail(MF_EARG, "render: incomplete input");
    if (in->nlights < 0 || (in->nlights > 0 && !in->lights)) return mf_fail(MF_EARG, "render: invalid light list");
    if (opts->spp_sqrt < 1 || opts->spp_sqrt > 1024) return mf_fail(MF_EARG, "render: spp_sqrt %d outside [1, 1024]", opts->spp_sqrt);
    if (opts->pixel_samples < 1 || opts->pixel_samples > MF_MAX_PIXEL_SAMPLES)
        return mf_fail(MF_EARG, "render: pixel_samples %d outside [1, %d]", opts->pixel_samples, MF_MAX_PIXEL_SAMPLES);
    if (!(opts->lobes & MF_LOBE_ALL) || (opts->lobes & ~MF_LOBE_ALL)) return mf_fail(MF_EARG, "render: invalid lobes %d", opts->lobes);
    if (cam->w <= 0 || cam->h <= 0) return mf_fail(MF_EARG, "render: camera size %dx%d is invalid", cam->w, cam->h);
    return MF_OK;
}

int mf_render_rows(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *opts, int y0, int y1,
                   MfRenderOut *out, MfRayLog *logs, MfProgress *prog) {
    int rc = check_args(in, cam, opts);
    if (rc) return rc;
    if (out->w != cam->w || out->h != cam->h || y0 < 0 || y1 > cam->h || y0 > y1)
        return mf_fail(MF_EARG, "render: output %dx%d / rows [%d, %d) do not match the camera %dx%d", out->w, out->h, y0, y1,
                       cam->w, cam->h);
    float *tan = NULL; /* (nv, 4) tangents, only when a material has a normal map */
    for (int k = 0; k < in->nmat && !tan; ++k) {
        if (!in->mats[k].normal) continue;
        if (!in->mesh->uv) return mf_fail(MF_EARG, "render: a normal map needs a mesh with UVs");
        if (in->mats[k].normal->c < 3) return mf_fail(MF_EARG, "render: a normal map needs 3 channels");
        if (!(tan = malloc((size_t)in->mesh->nv * 4 * sizeof(float) + 1))) return mf_fail(MF_ENOMEM, "render: out of memory for tangents");
        if ((rc = mf_mesh_tangents(in->mesh, tan))) {
            free(tan);
            return rc;
        }
    }
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = y0; y < y1; ++y) {
        MfRayLog *log = logs ? &logs[y - y0] : NULL;
        for (int x = 0; x < cam->w; ++x) render_pixel(in, tan, cam, opts, x, y, out, log);
        if (prog) mf_progress_add(prog, 1);
    }
    free(tan);
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
