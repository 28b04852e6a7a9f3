#include "inverse/mf_diffrender.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_brdf.h"
#include "render/mf_normalmap.h"
#include "scene/mf_tangent.h"
#include "scene/mf_texture.h"

#define SHADOW_EPS 0.001f
#define MAX_PIXEL_SAMPLES 256

typedef struct {
    const MfDiffScene *s;
    const MfCamera *cam;
    const MfDiffOpts *o;
    const MfDiffAdjoint *adj; /* NULL in the forward pass */
    float *dkd, *dorm, *denv; /* this thread's accumulators (adjoint only) */
    const float *tan;         /* (nv, 4) tangents when s->normal, else NULL */
    float *dnormal;           /* this thread's normal-map accumulator (adjoint only), or NULL */
} Ctx;

typedef struct {
    MfMaterial m;
    MfVec3 orm;
} Mat;

static Mat lookup(const MfImage *kd, const MfImage *orm, MfVec2 uv) {
    Mat r;
    float b[4];
    mf_tex_sample(kd, uv.x, uv.y, MF_WRAP_REPEAT, b);
    r.m.kd = mf_v3(b[0], b[1], b[2]);
    mf_tex_sample(orm, uv.x, uv.y, MF_WRAP_REPEAT, b);
    r.orm = mf_v3(b[0], b[1], b[2]);
    r.m.roughness = mf_clampf(r.orm.y, 0.0f, 1.0f);
    r.m.metallic = mf_clampf(r.orm.z, 0.0f, 1.0f);
    return r;
}

/* Adjoint weights of one pixel sample: dLoss/d(rgb, diffuse, specular) of this sample. */
typedef struct { MfVec3 g, gd, gs; } Adj;

/* One light-transport sample: direction wi (local and world), MIS weight w, visible. Adds its
 * contribution to the sample's diffuse/specular (forward) or its adjoint to the gradients. */
/* Gradient of <gd, demod> + <gk, k> with respect to the (world) shading normal, where
 * demod = cos_i / pi and k = D ci / (2 (s(co) ci + s(ci) co)) (the BRDF's specular factor
 * without Fresnel, which depends on dot(wo, h) only). The BRDF is isotropic: it depends on the
 * normal only through co = n.wo, ci = n.wi and hz = n.h. */
static MfVec3 brdf_normal_grad(const MfBrdfCtx *bc, MfVec3 wo, MfVec3 wi, MfVec3 wo_w, MfVec3 wi_w, float gd, float gk) {
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return mf_v3s(0.0f);
    MfVec3 gn = mf_scale(wi_w, gd * MF_INV_PI);
    if (!(bc->lobes & MF_LOBE_SPECULAR) || gk == 0.0f) return gn;
    float co = bc->co, ci = fminf(wi.z, 1.0f), a2 = bc->a2;
    MfVec3 h = mf_norm(mf_add(wo, wi)), h_w = mf_norm(mf_add(wo_w, wi_w));
    if (!(h.z > 0.0f)) return gn;
    float c2 = h.z * h.z, d = fmaf(c2, a2, h.x * h.x + h.y * h.y);
    float D = a2 / (MF_PI * d * d);
    float so = bc->so, si = sqrtf(fmaxf(ci * ci + a2 * (1.0f - ci * ci), 0.0f));
    float Q = so * ci + si * co, k = D * ci / (2.0f * Q);
    float dso = co * (1.0f - a2) / so, dsi = ci * (1.0f - a2) / si;
    float dk_dci = D / (2.0f * Q) - k / Q * (so + dsi * co);
    float dk_dco = -k / Q * (dso * ci + si);
    float dk_dhz = -4.0f * D * h.z * (a2 - 1.0f) / d * ci / (2.0f * Q);
    gn = mf_madd(gn, wi_w, gk * dk_dci);
    gn = mf_madd(gn, wo_w, gk * dk_dco);
    return mf_madd(gn, h_w, gk * dk_dhz);
}

static void contribute(Ctx *c, const Mat *mat, const MfBrdfCtx *bc, MfVec3 wo, MfVec3 wi, MfVec3 wi_w, float w,
                       MfVec3 L, MfVec3 *dif, MfVec3 *spec, const Adj *a, MfVec3 *dkd, float *dr, float *dm,
                       MfVec3 wo_w, MfVec3 *dn) {
    float pdf_unused;
    MfBrdfValue f = mf_brdf_ctx_eval_pdf(bc, wi, &pdf_unused); /* = mf_brdf_eval(&mat->m, wo, wi) */
    if (!c->adj) {
        *dif = mf_madd(*dif, L, f.diffuse_demod * w);
        *spec = mf_add(*spec, mf_scale(mf_mul(L, f.specular), w));
        return;
    }
    float m = mat->m.metallic;
    MfVec3 kd = mat->m.kd;
    /* radiance adjoint: rgb = kd (1-m) D + S, D = sum L cos/pi w, S = sum L f_s w */
    MfVec3 f_rgb = mf_add(mf_scale(kd, (1.0f - m) * f.diffuse_demod), f.specular);
    MfVec3 gL = mf_add(mf_mul(a->g, f_rgb), mf_add(mf_scale(a->gd, f.diffuse_demod), mf_mul(a->gs, f.specular)));
    gL = mf_scale(gL, w);
    if (c->denv) mf_env_eval_backward(c->s->env, wi_w, gL, c->denv);
    /* material adjoint: rgb gets L f_d w + L f_s w, the specular AOV L f_s w */
    MfVec3 Lw = mf_scale(L, w);
    MfMaterial dmat = {mf_v3s(0.0f), 0.0f, 0.0f};
    mf_brdf_eval_backward(&mat->m, wo, wi, MF_LOBE_ALL, mf_mul(a->g, Lw), mf_mul(mf_add(a->g, a->gs), Lw), &dmat);
    *dkd = mf_add(*dkd, dmat.kd);
    *dr += dmat.roughness;
    *dm += dmat.metallic;
    if (dn) { /* normal adjoint: rgb gets kd (1-m) L demod w + L F k w, diffuse L demod w, specular L F k w */
        float mc = mf_clampf(fmaxf(m, 0.0f), 0.0f, 1.0f);
        float gdem = mf_dot(a->g, mf_mul(mf_scale(kd, 1.0f - mc), Lw)) + mf_dot(a->gd, Lw);
        MfVec3 h = mf_norm(mf_add(wo, wi));
        MfVec3 F = mf_fresnel_schlick(bc->f0, mf_dot(wo, h));
        float gk = mf_dot(mf_mul(mf_add(a->g, a->gs), Lw), F);
        *dn = mf_add(*dn, brdf_normal_grad(bc, wo, wi, wo_w, wi_w, gdem, gk));
    }
}

static inline int visible(const MfDiffScene *s, const MfHit *h, MfVec3 wi) {
    MfVec3 o = mf_madd(h->p, h->ng, mf_dot(h->ng, wi) >= 0.0f ? SHADOW_EPS : -SHADOW_EPS);
    return !mf_rtscene_occluded(s->rt, o, wi, 0.0f, INFINITY);
}

/* Shades one hit: forward fills dif/spec; adjoint accumulates into the thread's gradients. */
static void shade(Ctx *c, const MfHit *h, MfVec3 wo_w, MfRng *rng, MfVec3 *dif, MfVec3 *spec, const Adj *a) {
    const MfDiffScene *s = c->s;
    Mat mat = lookup(s->kd, s->orm, h->uv);
    Mat mat_s = (s->kd_s || s->orm_s) ? lookup(s->kd_s ? s->kd_s : s->kd, s->orm_s ? s->orm_s : s->orm, h->uv) : mat;
    const MfEnvMap *env_s = s->env_s ? s->env_s : s->env;
    /* shading frame (evaluation) and sampling frame: the hit's normal, or the mapped normals */
    MfFrame fr, fr_s;
    MfNmapFrame nf;
    int sep = 0; /* 1: the sampling frame differs from the shading frame */
    if (s->normal) {
        nf = mf_nmap_frame(mf_rtscene_mesh(s->rt), c->tan, h);
        fr = mf_frame(mf_nmap_normal(&nf, s->normal, h->uv, wo_w));
        sep = s->normal_s && s->normal_s != s->normal;
        fr_s = sep ? mf_frame(mf_nmap_normal(&nf, s->normal_s, h->uv, wo_w)) : fr;
    } else {
        fr = fr_s = mf_frame(h->ns);
    }
    MfVec3 wo = mf_to_local(&fr, wo_w), wo_s = sep ? mf_to_local(&fr_s, wo_w) : wo;
    *dif = *spec = mf_v3s(0.0f);
    if (wo.z <= 0.0f) return;
    MfVec3 dkd = mf_v3s(0.0f), dnv = mf_v3s(0.0f);
    MfVec3 *dn = (c->adj && c->dnormal && s->normal) ? &dnv : NULL;
    float dr = 0.0f, dm = 0.0f;
    /* Batched as in the forward renderer (mf_integrator.c): same random numbers, same shadow
     * rays, same order of the sums, so the same values as one sample at a time. */
    MfBrdfCtx bc, bc_s; /* shading and sampling material */
    mf_brdf_prepare(&bc, &mat.m, wo, MF_LOBE_ALL);
    mf_brdf_prepare(&bc_s, &mat_s.m, wo_s, MF_LOBE_ALL);
    int n = c->o->spp_sqrt, N = n * n;
    float inv_N = 1.0f / (float)(n * n);
    enum { B = 64 };
    float us1[B], us2[B], pdf[B], ws[B];
    MfVec3 dir[B], wis[B], Ls[B];
    for (int b0 = 0; b0 < N; b0 += B) {
        int nb = N - b0 < B ? N - b0 : B, na = 0;
        for (int t = 0; t < nb; ++t) mf_rng_stratum2(rng, b0 + t, n, &us1[t], &us2[t]);
        mf_env_sample_dir_n(env_s, nb, us1, us2, dir, pdf);
        for (int t = 0; t < nb; ++t) {
            MfVec3 wi_w = dir[t];
            float pl = pdf[t];
            if (!(pl > 0.0f) || mf_dot(wi_w, h->ng) <= 0.0f) continue;
            MfVec3 wi = mf_to_local(&fr, wi_w);
            if (wi.z <= 0.0f) continue;
            float pb;
            mf_brdf_ctx_eval_pdf(&bc_s, sep ? mf_to_local(&fr_s, wi_w) : wi, &pb);
            float w = inv_N / (pl + pb);
            if (!(w > 0.0f) || !isfinite(w) || !visible(s, h, wi_w)) continue;
            dir[na] = wi_w;
            wis[na] = wi;
            ws[na++] = w;
        }
        mf_env_eval_pdf_n(s->env, na, dir, Ls, NULL);
        for (int t = 0; t < na; ++t) contribute(c, &mat, &bc, wo, wis[t], dir[t], ws[t], Ls[t], dif, spec, a, &dkd, &dr, &dm, wo_w, dn);
    }
    for (int b0 = 0; b0 < N; b0 += B) {
        int nb = N - b0 < B ? N - b0 : B, na = 0;
        for (int t = 0; t < nb; ++t) {
            float u0 = mf_rng_float(rng), u1, u2;
            mf_rng_stratum2(rng, b0 + t, n, &u1, &u2);
            MfVec3 wi;
            float pb;
            MfBrdfValue f_unused;
            if (!mf_brdf_ctx_sample(&bc_s, u0, u1, u2, &wi, &pb, &f_unused)) continue;
            if (!(pb > 0.0f) || wi.z <= 0.0f) continue;
            MfVec3 wi_w = mf_to_world(&fr_s, wi);
            if (mf_dot(wi_w, h->ng) <= 0.0f) continue;
            if (sep && (wi = mf_to_local(&fr, wi_w)).z <= 0.0f) continue; /* below the shading horizon: f = 0 */
            dir[na] = wi_w;
            wis[na] = wi;
            ws[na++] = pb;
        }
        /* the env pdf is that of the sampling map; the radiance that of the shading map */
        if (env_s == s->env) {
            mf_env_eval_pdf_n(s->env, na, dir, Ls, pdf);
        } else {
            for (int t = 0; t < na; ++t) pdf[t] = mf_env_pdf(env_s, dir[t]);
            mf_env_eval_pdf_n(s->env, na, dir, Ls, NULL);
        }
        for (int t = 0; t < na; ++t) {
            float w = inv_N / (pdf[t] + ws[t]);
            if (!(w > 0.0f) || !isfinite(w) || !visible(s, h, dir[t])) continue;
            contribute(c, &mat, &bc, wo, wis[t], dir[t], w, Ls[t], dif, spec, a, &dkd, &dr, &dm, wo_w, dn);
        }
    }
    if (c->adj) {
        float gkd[3] = {dkd.x, dkd.y, dkd.z};
        float gorm[3] = {0.0f, mat.orm.y >= 0.0f && mat.orm.y <= 1.0f ? dr : 0.0f,
                         mat.orm.z >= 0.0f && mat.orm.z <= 1.0f ? dm : 0.0f};
        if (c->dkd) mf_tex_sample_backward(s->kd, h->uv.x, h->uv.y, MF_WRAP_REPEAT, gkd, c->dkd);
        if (c->dorm) mf_tex_sample_backward(s->orm, h->uv.x, h->uv.y, MF_WRAP_REPEAT, gorm, c->dorm);
        if (dn) mf_nmap_normal_backward(&nf, s->normal, h->uv, wo_w, dnv, c->dnormal);
    }
}

/* A random permutation pairing the x and y strata of the pixel samples (N-rooks). */
static void stratified_perm(MfRng *rng, int ps, int *perm) {
    for (int k = 0; k < ps; ++k) perm[k] = k;
    for (int k = ps - 1; k > 0; --k) {
        int r = (int)mf_rng_below(rng, (uint32_t)(k + 1)), t = perm[k];
        perm[k] = perm[r];
        perm[r] = t;
    }
}

static inline int is_zero3(MfVec3 v) { return v.x == 0.0f && v.y == 0.0f && v.z == 0.0f; }

static void pixel(Ctx *c, int x, int y, MfRenderOut *out) {
    const MfCamera *cam = c->cam;
    MfRng rng;
    mf_rng_seed(&rng, c->o->seed, (uint64_t)y * (uint64_t)cam->w + (uint64_t)x);
    int ps = c->o->pixel_samples;
    int perm[MAX_PIXEL_SAMPLES];
    stratified_perm(&rng, ps, perm);
    size_t i = (size_t)y * cam->w + x;
    float inv_ps = 1.0f / (float)ps;
    Adj a;
    if (c->adj) {
        const float *g = c->adj->drgb, *gd = c->adj->ddiffuse, *gs = c->adj->dspecular;
        a.g = g ? mf_v3(g[3 * i] * inv_ps, g[3 * i + 1] * inv_ps, g[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        a.gd = gd ? mf_v3(gd[3 * i] * inv_ps, gd[3 * i + 1] * inv_ps, gd[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        a.gs = gs ? mf_v3(gs[3 * i] * inv_ps, gs[3 * i + 1] * inv_ps, gs[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        if (is_zero3(a.g) && is_zero3(a.gd) && is_zero3(a.gs)) return; /* no adjoint here: nothing to trace */
    }
    MfVec3 rgb = mf_v3s(0), dif = mf_v3s(0), spec = mf_v3s(0), alb = mf_v3s(0), orm = mf_v3s(0), nrm = mf_v3s(0);
    MfVec3 fwd = mf_v3(-cam->c2w.m[2], -cam->c2w.m[6], -cam->c2w.m[10]); /* camera -z */
    float depth = 0.0f;
    int hits = 0;
    for (int k = 0; k < ps; ++k) {
        float px = (float)x + ((float)k + mf_rng_float(&rng)) * inv_ps;
        float py = (float)y + ((float)perm[k] + mf_rng_float(&rng)) * inv_ps;
        MfVec3 org, dir;
        mf_camera_ray(cam, px, py, &org, &dir);
        MfHit h;
        if (!mf_rtscene_intersect(c->s->rt, org, dir, 0.0f, INFINITY, &h)) continue;
        ++hits;
        MfVec3 d, sp;
        shade(c, &h, mf_neg(dir), &rng, &d, &sp, c->adj ? &a : NULL);
        if (c->adj) continue;
        Mat m = lookup(c->s->kd, c->s->orm, h.uv);
        rgb = mf_add(rgb, mf_add(mf_mul(mf_scale(m.m.kd, 1.0f - m.m.metallic), d), sp));
        dif = mf_add(dif, d);
        spec = mf_add(spec, sp);
        alb = mf_add(alb, m.m.kd);
        orm = mf_add(orm, m.orm);
        nrm = mf_add(nrm, h.ns); /* G-buffer guides (the denoiser's), as mf_integrator's */
        depth += h.t * mf_dot(dir, fwd);
    }
    if (c->adj) return;
    out->alpha[i] = (float)hits * inv_ps;
    float inv_h = hits ? 1.0f / (float)hits : 0.0f;
    const MfVec3 v[5] = {mf_scale(rgb, inv_ps), mf_scale(dif, inv_ps), mf_scale(spec, inv_ps), mf_scale(alb, inv_h),
                         mf_scale(orm, inv_h)};
    float *dst[5] = {out->rgb, out->diffuse, out->specular, out->albedo, out->orm};
    for (int k = 0; k < 5; ++k) {
        dst[k][3 * i] = v[k].x;
        dst[k][3 * i + 1] = v[k].y;
        dst[k][3 * i + 2] = v[k].z;
    }
    MfVec3 n = hits ? mf_norm(nrm) : nrm;
    out->normal[3 * i] = n.x, out->normal[3 * i + 1] = n.y, out->normal[3 * i + 2] = n.z;
    out->depth[i] = depth * inv_h;
}

static int check(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o) {
    if (!s || !s->rt || !s->kd || !s->orm || !s->env) return mf_fail(MF_EARG, "diffrender: incomplete scene");
    if (s->kd->c < 3 || s->orm->c < 3) return mf_fail(MF_EARG, "diffrender: kd and ORM textures need 3 channels");
    if (o->spp_sqrt < 1 || o->spp_sqrt > 64) return mf_fail(MF_EARG, "diffrender: spp_sqrt %d outside [1, 64]", o->spp_sqrt);
    if (o->pixel_samples < 1 || o->pixel_samples > MAX_PIXEL_SAMPLES)
        return mf_fail(MF_EARG, "diffrender: pixel_samples %d outside [1, %d]", o->pixel_samples, MAX_PIXEL_SAMPLES);
    if (cam->w <= 0 || cam->h <= 0) return mf_fail(MF_EARG, "diffrender: camera size %dx%d", cam->w, cam->h);
    if (s->normal) {
        if (s->normal->c != 3) return mf_fail(MF_EARG, "diffrender: the normal map needs 3 channels");
        if (s->normal_s && s->normal_s->c != 3) return mf_fail(MF_EARG, "diffrender: the sampling normal map needs 3 channels");
        if (!mf_rtscene_mesh(s->rt)->uv) return mf_fail(MF_EARG, "diffrender: a normal map needs a mesh with UVs");
    }
    return MF_OK;
}

/* The tangents a normal map needs: the scene's, or computed into *owned (freed by the caller). */
static int tangents(const MfDiffScene *s, const float **tan, float **owned) {
    *tan = NULL;
    *owned = NULL;
    if (!s->normal) return MF_OK;
    if (s->tangent) {
        *tan = s->tangent;
        return MF_OK;
    }
    const MfMesh *m = mf_rtscene_mesh(s->rt);
    float *t = malloc((size_t)m->nv * 4 * sizeof(float) + 1);
    if (!t) return mf_fail(MF_ENOMEM, "diffrender: out of memory for tangents");
    int rc = mf_mesh_tangents(m, t);
    if (rc) {
        free(t);
        return rc;
    }
    *tan = *owned = t;
    return MF_OK;
}

int mf_diff_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, MfRenderOut *out) {
    int rc = check(s, cam, o);
    if (rc) return rc;
    if (out->w != cam->w || out->h != cam->h) return mf_fail(MF_EARG, "diffrender: output size does not match the camera");
    const float *tan;
    float *tan_owned;
    if ((rc = tangents(s, &tan, &tan_owned))) return rc;
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = 0; y < cam->h; ++y) {
        Ctx c = {s, cam, o, NULL, NULL, NULL, NULL, tan, NULL};
        for (int x = 0; x < cam->w; ++x) pixel(&c, x, y, out);
    }
    free(tan_owned);
    return MF_OK;
}

int mf_diff_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const MfDiffAdjoint *adj,
                     MfDiffGrads *g) {
    int rc = check(s, cam, o);
    if (rc) return rc;
    size_t nkd = g->dkd ? (size_t)s->kd->w * s->kd->h * 3 : 0;
    size_t norm = g->dorm ? (size_t)s->orm->w * s->orm->h * 3 : 0;
    size_t nenv = g->denv ? (size_t)s->env->img.w * s->env->img.h * 3 : 0;
    size_t nnm = (g->dnormal && s->normal) ? (size_t)s->normal->w * s->normal->h * 3 : 0;
    size_t per = nkd + norm + nenv + nnm;
    const float *tan;
    float *tan_owned;
    if ((rc = tangents(s, &tan, &tan_owned))) return rc;
    int nt = omp_get_max_threads();
    float *buf = calloc((size_t)nt * per + 1, sizeof(float));
    if (!buf) {
        free(tan_owned);
        return mf_fail(MF_ENOMEM, "diffrender: out of memory for %d gradient buffers of %zu floats", nt, per);
    }
#pragma omp parallel num_threads(nt)
    {
        int t = omp_get_thread_num();
        float *b = buf + (size_t)t * per;
        Ctx c = {s, cam, o, adj, nkd ? b : NULL, norm ? b + nkd : NULL, nenv ? b + nkd + norm : NULL, tan,
                 nnm ? b + nkd + norm + nenv : NULL};
        /* static schedule: the rows a thread handles, and so the summation order, are fixed */
#pragma omp for schedule(static, 1)
        for (int y = 0; y < cam->h; ++y)
            for (int x = 0; x < cam->w; ++x) pixel(&c, x, y, NULL);
    }
    for (int t = 0; t < nt; ++t) {
        const float *b = buf + (size_t)t * per;
        for (size_t i = 0; i < nkd; ++i) g->dkd[i] += b[i];
        for (size_t i = 0; i < norm; ++i) g->dorm[i] += b[nkd + i];
        for (size_t i = 0; i < nenv; ++i) g->denv[i] += b[nkd + norm + i];
        for (size_t i = 0; i < nnm; ++i) g->dnormal[i] += b[nkd + norm + nenv + i];
    }
    free(buf);
    free(tan_owned);
    return MF_OK;
}

/* ---- material AOVs ---- */

/* Primary hits of pixel (x, y) with the forward pass's pixel sampling; returns their count. */
static int pixel_hits(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, int x, int y, MfHit *hits) {
    MfRng rng;
    mf_rng_seed(&rng, o->seed, (uint64_t)y * (uint64_t)cam->w + (uint64_t)x);
    int ps = o->pixel_samples, perm[MAX_PIXEL_SAMPLES], n = 0;
    stratified_perm(&rng, ps, perm);
    float inv_ps = 1.0f / (float)ps;
    for (int k = 0; k < ps; ++k) {
        float px = (float)x + ((float)k + mf_rng_float(&rng)) * inv_ps;
        float py = (float)y + ((float)perm[k] + mf_rng_float(&rng)) * inv_ps;
        MfVec3 org, dir;
        mf_camera_ray(cam, px, py, &org, &dir);
        if (mf_rtscene_intersect(s->rt, org, dir, 0.0f, INFINITY, &hits[n])) ++n;
    }
    return n;
}

int mf_diff_aov_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, float *albedo, float *orm,
                        float *alpha) {
    int rc = check(s, cam, o);
    if (rc) return rc;
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = 0; y < cam->h; ++y) {
        MfHit hits[MAX_PIXEL_SAMPLES];
        for (int x = 0; x < cam->w; ++x) {
            size_t i = (size_t)y * cam->w + x;
            int n = pixel_hits(s, cam, o, x, y, hits);
            float a[3] = {0, 0, 0}, m[3] = {0, 0, 0}, b[4];
            for (int k = 0; k < n; ++k) {
                mf_tex_sample(s->kd, hits[k].uv.x, hits[k].uv.y, MF_WRAP_REPEAT, b);
                for (int c = 0; c < 3; ++c) a[c] += b[c] / (float)n;
                mf_tex_sample(s->orm, hits[k].uv.x, hits[k].uv.y, MF_WRAP_REPEAT, b);
                for (int c = 0; c < 3; ++c) m[c] += b[c] / (float)n;
            }
            for (int c = 0; c < 3; ++c) {
                if (albedo) albedo[3 * i + c] = a[c];
                if (orm) orm[3 * i + c] = m[c];
            }
            if (alpha) alpha[i] = (float)n / (float)o->pixel_samples;
        }
    }
    return MF_OK;
}

int mf_diff_aov_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const float *dalbedo,
                         const float *dorm, MfDiffGrads *g) {
    int rc = check(s, cam, o);
    if (rc) return rc;
    size_t nkd = (g->dkd && dalbedo) ? (size_t)s->kd->w * s->kd->h * 3 : 0;
    size_t norm = (g->dorm && dorm) ? (size_t)s->orm->w * s->orm->h * 3 : 0;
    size_t per = nkd + norm;
    int nt = omp_get_max_threads();
    float *buf = calloc((size_t)nt * per + 1, sizeof(float));
    if (!buf) return mf_fail(MF_ENOMEM, "diffrender: out of memory for AOV gradient buffers");
#pragma omp parallel num_threads(nt)
    {
        float *b = buf + (size_t)omp_get_thread_num() * per;
        MfHit hits[MAX_PIXEL_SAMPLES];
#pragma omp for schedule(static, 1)
        for (int y = 0; y < cam->h; ++y)
            for (int x = 0; x < cam->w; ++x) {
                size_t i = (size_t)y * cam->w + x;
                int n = pixel_hits(s, cam, o, x, y, hits);
                for (int k = 0; k < n; ++k) {
                    float ga[3], gm[3];
                    for (int c = 0; c < 3; ++c) {
                        ga[c] = nkd ? dalbedo[3 * i + c] / (float)n : 0.0f;
                        gm[c] = norm ? dorm[3 * i + c] / (float)n : 0.0f;
                    }
                    if (nkd) mf_tex_sample_backward(s->kd, hits[k].uv.x, hits[k].uv.y, MF_WRAP_REPEAT, ga, b);
                    if (norm) mf_tex_sample_backward(s->orm, hits[k].uv.x, hits[k].uv.y, MF_WRAP_REPEAT, gm, b + nkd);
                }
            }
    }
    for (int t = 0; t < nt; ++t) {
        const float *b = buf + (size_t)t * per;
        for (size_t i = 0; i < nkd; ++i) g->dkd[i] += b[i];
        for (size_t i = 0; i < norm; ++i) g->dorm[i] += b[nkd + i];
    }
    free(buf);
    return MF_OK;
}
