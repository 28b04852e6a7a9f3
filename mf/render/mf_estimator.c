/* mf_estimator: the Monte Carlo estimator shared by mf_render and the differentiable renderer
 * (see mf_estimator.h). */
#include "render/mf_estimator.h"

#include <math.h>
#include <stdlib.h>

#include "core/mf_error.h"
#include "render/mf_hitgrad.h"
#include "render/mf_normalmap.h"
#include "scene/mf_tangent.h"
#include "scene/mf_texture.h"

void mf_pixel_sampler_init(MfPixelSampler *s, uint64_t seed, int w, int x, int y, int n) {
    mf_rng_seed(&s->rng, seed, (uint64_t)y * (uint64_t)w + (uint64_t)x);
    s->n = n;
    s->x = x;
    s->y = y;
    s->inv_n = 1.0f / (float)n;
    for (int k = 0; k < n; ++k) s->perm[k] = k;
    for (int k = n - 1; k > 0; --k) {
        int r = (int)mf_rng_below(&s->rng, (uint32_t)(k + 1)), t = s->perm[k];
        s->perm[k] = s->perm[r];
        s->perm[r] = t;
    }
}

int mf_est_check(const MfEstimator *e, const MfCamera *cam, const char *who) {
    if (!e->rt || !e->mesh || !e->mats || e->nmat < 1) return mf_fail(MF_EARG, "%s: incomplete input", who);
    if (e->nlights < 0 || (e->nlights > 0 && !e->lights)) return mf_fail(MF_EARG, "%s: invalid light list", who);
    if (e->spp_sqrt < 1 || e->spp_sqrt > MF_MAX_SPP_SQRT)
        return mf_fail(MF_EARG, "%s: spp_sqrt %d outside [1, %d]", who, e->spp_sqrt, MF_MAX_SPP_SQRT);
    if (e->pixel_samples < 1 || e->pixel_samples > MF_MAX_PIXEL_SAMPLES)
        return mf_fail(MF_EARG, "%s: pixel_samples %d outside [1, %d]", who, e->pixel_samples, MF_MAX_PIXEL_SAMPLES);
    if (!(e->lobes & MF_LOBE_ALL) || (e->lobes & ~MF_LOBE_ALL)) return mf_fail(MF_EARG, "%s: invalid lobes %d", who, e->lobes);
    if (cam->w <= 0 || cam->h <= 0) return mf_fail(MF_EARG, "%s: camera size %dx%d is invalid", who, cam->w, cam->h);
    return MF_OK;
}

int mf_est_tangents(const MfMesh *mesh, const MfTexMaterial *mats, int nmat, const float *given, const float **tan,
                    float **owned) {
    *tan = NULL;
    *owned = NULL;
    int need = 0;
    for (int k = 0; k < nmat; ++k) need |= mats[k].normal != NULL;
    if (!need) return MF_OK;
    if (!mesh->uv) return mf_fail(MF_EARG, "render: a normal map needs a mesh with UVs");
    if (given) {
        *tan = given;
        return MF_OK;
    }
    float *t = malloc((size_t)mesh->nv * 4 * sizeof(float) + 1);
    if (!t) return mf_fail(MF_ENOMEM, "render: out of memory for tangents");
    int rc = mf_mesh_tangents(mesh, t);
    if (rc) {
        free(t);
        return rc;
    }
    *tan = *owned = t;
    return MF_OK;
}

/* p + off rounded one ulp further in off's direction (unchanged where off is 0). */
static inline float bump(float p, float off) {
    float o = p + off;
    return off > 0.0f ? nextafterf(o, INFINITY) : off < 0.0f ? nextafterf(o, -INFINITY) : o;
}

/* pbrt-v4's OffsetRayOrigin: move p along ng (to d's side) by the projection of its error
 * bound, MF_RAY_OFFSET_SAFETY times, then round each moved component one ulp further, so the
 * rounding of p + offset cannot bring the origin back. Everything is relative to the
 * coordinates' magnitudes: scaling a scene scales the offsets. (Measured: a quarter of the
 * bound already gives no self-hits in tests/test_render_estimator.c; zero gives about half.) */
MfVec3 mf_est_ray_origin(const MfHit *h, MfVec3 d) {
    MfVec3 n = h->ng;
    float dist = (fabsf(n.x) * h->perr.x + fabsf(n.y) * h->perr.y + fabsf(n.z) * h->perr.z) * MF_RAY_OFFSET_SAFETY;
    if (mf_dot(n, d) < 0.0f) dist = -dist;
    MfVec3 off = mf_scale(n, dist);
    return mf_v3(bump(h->p.x, off.x), bump(h->p.y, off.y), bump(h->p.z, off.z));
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

/* 1 if nothing blocks the hit from direction wi up to dist (INFINITY: env light). */
static int visible(const MfEstimator *e, const MfHit *h, MfVec3 wi, float dist, MfRayLog *log) {
    MfVec3 o = mf_est_ray_origin(h, wi);
    float tfar = isfinite(dist) ? dist * (1.0f - 1e-4f) : INFINITY;
    raylog_push(log, o, wi, 0.0f, tfar, 1);
    return !mf_rtscene_occluded(e->rt, o, wi, 0.0f, tfar);
}

/* Samples are processed in batches of at most SHADE_BATCH (see shade). */
#define SHADE_BATCH 64

/* visible() for n <= SHADE_BATCH env-light directions wi (n,) at once (traced together, the
 * answers those of visible()): vis (n,). */
static void visible_n(const MfEstimator *e, const MfHit *h, int n, const MfVec3 *wi, unsigned char *vis, MfRayLog *log) {
    MfVec3 org[SHADE_BATCH];
    if (n <= 0) return;
    int i = 0;
    do { /* (not a for loop: gcc 12 then warns that org may be uninitialised) */
        org[i] = mf_est_ray_origin(h, wi[i]);
        raylog_push(log, org[i], wi[i], 0.0f, INFINITY, 1);
    } while (++i < n);
    mf_rtscene_occluded_n(e->rt, n, org, wi, INFINITY, vis);
    for (i = 0; i < n; ++i) vis[i] = !vis[i];
}

typedef struct {
    MfMaterial m;
    MfVec3 orm; /* as stored (occlusion, roughness, metallic), before clamping */
} Mat;

static Mat material_at(const MfTexMaterial *tm, const MfHit *h) {
    Mat r;
    float b[4];
    const float p[3] = {h->p.x, h->p.y, h->p.z};
    MfVec2 uv = h->uv;
    if (tm->vkd) {
        mf_voltex_forward(tm->vkd, p, 1, b);
        r.m.kd = mf_v3(b[0], b[1], b[2]);
    } else if (tm->kd) {
        mf_tex_sample(tm->kd, uv.x, uv.y, MF_WRAP_REPEAT, b);
        r.m.kd = mf_v3(b[0], b[1], b[2]);
    } else {
        r.m.kd = tm->kd_const;
    }
    if (tm->vorm) {
        mf_voltex_forward(tm->vorm, p, 1, b);
        r.orm = mf_v3(b[0], b[1], b[2]);
    } else if (tm->orm) {
        mf_tex_sample(tm->orm, uv.x, uv.y, MF_WRAP_REPEAT, b);
        r.orm = mf_v3(b[0], b[1], b[2]);
    } else {
        r.orm = tm->orm_const;
    }
    r.m.roughness = mf_clampf(r.orm.y, 0.0f, 1.0f);
    r.m.metallic = mf_clampf(r.orm.z, 0.0f, 1.0f);
    return r;
}

static inline int brdf_zero(const MfBrdfValue *f) { return f->diffuse_demod <= 0.0f && mf_maxc(f->specular) <= 0.0f; }
static inline int is_zero3(MfVec3 v) { return v.x == 0.0f && v.y == 0.0f && v.z == 0.0f; }

/* Adjoint weights of one pixel sample: dLoss/d(rgb, diffuse, specular) of this sample. */
typedef struct { MfVec3 g, gd, gs; } Adj;

/* One hit being shaded: its material, frames and (adjoint) accumulators. */
typedef struct {
    const MfEstimator *e;
    const MfHit *h;
    const MfHit *hs;      /* the sampling geometry's hit (rt_s), or h */
    int id;               /* material id */
    Mat mat;              /* evaluated material */
    MfBrdfCtx bc;         /* evaluated BRDF at wo */
    MfVec3 wo, wo_w;      /* local (shading frame) and world direction to the viewer */
    const Adj *a;         /* NULL: forward */
    MfEstAdjoint *adj;    /* this thread's gradient buffers (adjoint only) */
    MfVec3 dif, spec;     /* forward sums */
    MfVec3 dkd, dn;       /* adjoint sums over the hit's samples (kd, world shading normal) */
    float dr, dm;         /* roughness, metallic */
    int want_dn;          /* 1: accumulate dn */
} Shading;

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

/* One light-transport sample: direction wi (local, world), BRDF value f at it, weight w,
 * radiance L, visible. Forward: adds f L w to the hit's sums. Adjoint: accumulates dLoss/d(L)
 * into the env texels (env_grad) and dLoss/d(material, normal) into the hit's sums. */
static void contribute(Shading *sh, MfVec3 wi, MfVec3 wi_w, const MfBrdfValue *f, float w, MfVec3 L, int env_grad) {
    if (!sh->a) {
        sh->dif = mf_madd(sh->dif, L, f->diffuse_demod * w);
        sh->spec = mf_add(sh->spec, mf_scale(mf_mul(L, f->specular), w));
        return;
    }
    const Adj *a = sh->a;
    float m = sh->mat.m.metallic;
    MfVec3 kd = sh->mat.m.kd;
    /* radiance adjoint: rgb = kd (1-m) D + S, D = sum L cos/pi w, S = sum L f_s w */
    if (env_grad && sh->adj->denv) {
        MfVec3 f_rgb = mf_add(mf_scale(kd, (1.0f - m) * f->diffuse_demod), f->specular);
        MfVec3 gL = mf_add(mf_mul(a->g, f_rgb), mf_add(mf_scale(a->gd, f->diffuse_demod), mf_mul(a->gs, f->specular)));
        mf_env_eval_backward(sh->e->env, wi_w, mf_scale(gL, w), sh->adj->denv);
    }
    /* material adjoint: rgb gets L f_d w + L f_s w, the specular AOV L f_s w */
    MfVec3 Lw = mf_scale(L, w);
    MfMaterial dmat = {mf_v3s(0.0f), 0.0f, 0.0f};
    mf_brdf_eval_backward(&sh->mat.m, sh->wo, wi, sh->bc.lobes, mf_mul(a->g, Lw), mf_mul(mf_add(a->g, a->gs), Lw), &dmat);
    sh->dkd = mf_add(sh->dkd, dmat.kd);
    sh->dr += dmat.roughness;
    sh->dm += dmat.metallic;
    if (sh->want_dn) { /* normal adjoint: rgb gets kd (1-m) L demod w + L F k w, diffuse L demod w, specular L F k w */
        float mc = mf_clampf(fmaxf(m, 0.0f), 0.0f, 1.0f);
        float gdem = mf_dot(a->g, mf_mul(mf_scale(kd, 1.0f - mc), Lw)) + mf_dot(a->gd, Lw);
        MfVec3 h = mf_norm(mf_add(sh->wo, wi));
        MfVec3 F = mf_fresnel_schlick(sh->bc.f0, mf_dot(sh->wo, h));
        float gk = mf_dot(mf_mul(mf_add(a->g, a->gs), Lw), F);
        sh->dn = mf_add(sh->dn, brdf_normal_grad(&sh->bc, sh->wo, wi, sh->wo_w, wi_w, gdem, gk));
    }
}

/* Samples are processed in batches: all light-sample directions of a batch first (their CDF
 * searches miss the cache independently, so the CPU overlaps them), then the BRDF values, then
 * the batch's shadow rays together (16-wide packets, mf_rtscene_occluded_n), then the radiance
 * lookups of the visible ones. The random numbers, the rays and the order of the sums are those
 * of one-sample-at-a-time, so the result is identical. */

typedef struct {
    MfVec3 wi, wi_w; /* shading-frame and world direction */
    MfBrdfValue f;   /* evaluated BRDF */
    float p;         /* MIS weight (light loop) or BSDF pdf (BSDF loop) */
} Accepted;

/* Direct light at a hit (shading normal ns; sampling copy's ns_s) toward wo_w; returns 0 (and
 * adds nothing) when the viewer is below the shading horizon. */
static int shade(Shading *sh, MfVec3 ns, MfVec3 ns_s, int sep, MfRng *rng, MfRayLog *log) {
    const MfEstimator *e = sh->e;
    const MfHit *h = sh->h;
    MfFrame fr = mf_frame(ns), fr_s = sep ? mf_frame(ns_s) : fr;
    sh->wo = mf_to_local(&fr, sh->wo_w);
    MfVec3 wo_s = sep ? mf_to_local(&fr_s, sh->wo_w) : sh->wo;
    if (sh->wo.z <= 0.0f) return 0;
    int lobes = e->lobes;
    mf_brdf_prepare(&sh->bc, &sh->mat.m, sh->wo, lobes);
    /* the sampling BRDF: another material (sampling copies) or another frame (normal map copy) */
    const MfTexMaterial *tms = e->mats_s ? &e->mats_s[sh->id] : NULL;
    const MfTexMaterial *tm = &e->mats[sh->id];
    int sepm = (tms && (tms->kd != tm->kd || tms->orm != tm->orm || tms->vkd != tm->vkd || tms->vorm != tm->vorm)) || sh->hs != h;
    MfBrdfCtx bc_s;
    const MfBrdfCtx *bs = &sh->bc;
    if (sepm || sep) {
        Mat ms = sepm ? material_at(tms ? tms : tm, sh->hs) : sh->mat;
        mf_brdf_prepare(&bc_s, &ms.m, wo_s, lobes);
        bs = &bc_s;
    }
    int other = bs != &sh->bc;
    if (e->env) {
        const MfEnvMap *env = e->env, *env_s = e->env_s ? e->env_s : e->env;
        int n = e->spp_sqrt, N = n * n;
        float inv_N = 1.0f / (float)(n * n);
        MfVec3 dir[SHADE_BATCH], Ls[SHADE_BATCH];
        float pdf[SHADE_BATCH], us1[SHADE_BATCH], us2[SHADE_BATCH];
        unsigned char vis[SHADE_BATCH];
        int sel[SHADE_BATCH];
        Accepted acc[SHADE_BATCH];
        /* light samples: acc[].p = MIS weight */
        for (int b0 = 0; b0 < N; b0 += SHADE_BATCH) {
            int nb = N - b0 < SHADE_BATCH ? N - b0 : SHADE_BATCH, na = 0;
            for (int t = 0; t < nb; ++t) mf_rng_stratum2(rng, b0 + t, n, &us1[t], &us2[t]);
            mf_env_sample_dir_n(env_s, nb, us1, us2, dir, pdf);
            for (int t = 0; t < nb; ++t) {
                MfVec3 wi_w = dir[t];
                float pl = pdf[t];
                if (!(pl > 0.0f) || mf_dot(wi_w, sh->hs->ng) <= 0.0f) continue;
                MfVec3 wi = mf_to_local(&fr, wi_w);
                if (wi.z <= 0.0f) continue;
                float pb;
                MfBrdfValue f = mf_brdf_ctx_eval_pdf(&sh->bc, wi, &pb);
                if (other) mf_brdf_ctx_eval_pdf(bs, sep ? mf_to_local(&fr_s, wi_w) : wi, &pb);
                if (brdf_zero(&f)) continue;
                float w = inv_N / (pl + pb);
                if (!(w > 0.0f) || !isfinite(w)) continue;
                acc[na++] = (Accepted){wi, wi_w, f, w};
            }
            /* shadow rays of the batch together; keep the visible ones in order */
            for (int a = 0; a < na; ++a) dir[a] = acc[a].wi_w;
            visible_n(e, h, na, dir, vis, log);
            int nv = 0;
            for (int a = 0; a < na; ++a)
                if (vis[a]) acc[nv] = acc[a], dir[nv++] = dir[a];
            na = nv;
            mf_env_eval_pdf_n(env, na, dir, Ls, NULL);
            for (int a = 0; a < na; ++a) contribute(sh, acc[a].wi, acc[a].wi_w, &acc[a].f, acc[a].p, Ls[a], 1);
        }
        /* BSDF samples: acc[].p = BSDF pdf */
        for (int b0 = 0; b0 < N; b0 += SHADE_BATCH) {
            int nb = N - b0 < SHADE_BATCH ? N - b0 : SHADE_BATCH, na = 0;
            for (int t = 0; t < nb; ++t) {
                float u0 = mf_rng_float(rng), u1, u2;
                mf_rng_stratum2(rng, b0 + t, n, &u1, &u2);
                MfVec3 wi;
                float pb;
                MfBrdfValue f;
                if (!mf_brdf_ctx_sample(bs, u0, u1, u2, &wi, &pb, &f)) continue;
                if (!(pb > 0.0f) || wi.z <= 0.0f) continue;
                MfVec3 wi_w = mf_to_world(&fr_s, wi);
                if (mf_dot(wi_w, sh->hs->ng) <= 0.0f) continue;
                if (sep && (wi = mf_to_local(&fr, wi_w)).z <= 0.0f) continue; /* below the shading horizon: f = 0 */
                if (other) {
                    float p_unused;
                    f = mf_brdf_ctx_eval_pdf(&sh->bc, wi, &p_unused);
                }
                if (brdf_zero(&f)) continue;
                acc[na++] = (Accepted){wi, wi_w, f, pb};
            }
            for (int a = 0; a < na; ++a) dir[a] = acc[a].wi_w;
            /* the env pdf is that of the sampling map; the radiance that of the evaluated map */
            if (env_s == env) {
                mf_env_eval_pdf_n(env, na, dir, Ls, pdf);
            } else {
                for (int a = 0; a < na; ++a) pdf[a] = mf_env_pdf(env_s, dir[a]);
                mf_env_eval_pdf_n(env, na, dir, Ls, NULL);
            }
            /* MIS weights, then the shadow rays of those with a usable weight together */
            int nt = 0;
            for (int a = 0; a < na; ++a) {
                float w = inv_N / (pdf[a] + acc[a].p);
                if (!(w > 0.0f) || !isfinite(w)) continue;
                pdf[a] = w;
                sel[nt] = a;
                dir[nt++] = acc[a].wi_w;
            }
            visible_n(e, h, nt, dir, vis, log);
            for (int t = 0; t < nt; ++t)
                if (vis[t]) contribute(sh, acc[sel[t]].wi, acc[sel[t]].wi_w, &acc[sel[t]].f, pdf[sel[t]], Ls[sel[t]], 1);
        }
    }
    for (int k = 0; k < e->nlights; ++k) {
        MfVec3 wi_w, E;
        float dist;
        mf_light_incident(&e->lights[k], h->p, &wi_w, &dist, &E);
        if (mf_dot(wi_w, h->ng) <= 0.0f || mf_maxc(E) <= 0.0f) continue;
        MfVec3 wi = mf_to_local(&fr, wi_w);
        if (wi.z <= 0.0f) continue;
        MfBrdfValue f = mf_brdf_eval(&sh->mat.m, sh->wo, wi, lobes);
        if (brdf_zero(&f) || !visible(e, h, wi_w, dist, log)) continue;
        contribute(sh, wi, wi_w, &f, 1.0f, E, 0);
    }
    return 1;
}

/* The radiance a shaded hit sends toward its viewer, kd (1 - m) D + S; a diffuse lobe the
 * estimator leaves out is zeroed in the sums first (its AOV too). */
static MfVec3 radiance_out(const MfEstimator *e, Shading *sh) {
    if (!(e->lobes & MF_LOBE_DIFFUSE)) sh->dif = mf_v3s(0.0f);
    return mf_add(mf_mul(mf_scale(sh->mat.m.kd, 1.0f - sh->mat.m.metallic), sh->dif), sh->spec);
}

/* The shading normal at hit h toward wo_w: the material's normal map, else the hit's (forward). */
static MfVec3 shading_normal(const MfEstimator *e, const MfHit *h, int id, MfVec3 wo_w) {
    const MfImage *map = e->tan ? e->mats[id].normal : NULL;
    if (!map) return h->ns;
    MfNmapFrame nf = mf_nmap_frame(e->mesh, e->tan, h);
    return mf_nmap_normal(&nf, map, h->uv, wo_w);
}

/* Forward only: `left` more indirect bounces from a shaded hit (shading normal ns, sh->bc
 * prepared by shade): one BSDF direction; a mesh hit along it adds f cos / pdf times the
 * radiance leaving that hit toward sh (its direct light and, recursively, its bounces) to sh's
 * sums; a miss adds nothing (the env along it is in sh's MIS-weighted direct light). */
static void bounce(Shading *sh, MfVec3 ns, int left, MfRng *rng, MfRayLog *log) {
    const MfEstimator *e = sh->e;
    float u0 = mf_rng_float(rng), u1 = mf_rng_float(rng), u2 = mf_rng_float(rng);
    MfVec3 wi;
    float pb;
    MfBrdfValue f;
    if (!mf_brdf_ctx_sample(&sh->bc, u0, u1, u2, &wi, &pb, &f) || !(pb > 0.0f) || wi.z <= 0.0f || brdf_zero(&f)) return;
    MfFrame fr = mf_frame(ns);
    MfVec3 wi_w = mf_to_world(&fr, wi);
    if (mf_dot(wi_w, sh->h->ng) <= 0.0f) return;
    MfVec3 org = mf_est_ray_origin(sh->h, wi_w);
    raylog_push(log, org, wi_w, 0.0f, INFINITY, 0); /* closest hit, as a primary ray */
    MfHit h2;
    if (!mf_rtscene_intersect(e->rt, org, wi_w, 0.0f, INFINITY, &h2)) return;
    int id = (h2.mat >= 0 && h2.mat < e->nmat) ? h2.mat : 0;
    Shading s2 = {.e = e, .h = &h2, .hs = &h2, .id = id, .mat = material_at(&e->mats[id], &h2), .wo_w = mf_neg(wi_w)};
    MfVec3 n2 = shading_normal(e, &h2, id, s2.wo_w);
    if (!shade(&s2, n2, n2, 0, rng, log)) return;
    if (left > 1) bounce(&s2, n2, left - 1, rng, log);
    MfVec3 L = radiance_out(e, &s2);
    if (mf_isfinite3(L)) contribute(sh, wi, wi_w, &f, 1.0f / pb, L, 0);
}

void mf_est_pixel(const MfEstimator *e, const MfCamera *cam, int x, int y, MfRenderOut *out, MfEstAdjoint *adj,
                  MfRayLog *log) {
    size_t i = (size_t)y * cam->w + x;
    int ps = e->pixel_samples;
    float inv_ps = 1.0f / (float)ps;
    Adj a;
    if (adj) {
        const float *g = adj->drgb, *gd = adj->ddiffuse, *gs = adj->dspecular;
        a.g = g ? mf_v3(g[3 * i] * inv_ps, g[3 * i + 1] * inv_ps, g[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        a.gd = gd ? mf_v3(gd[3 * i] * inv_ps, gd[3 * i + 1] * inv_ps, gd[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        a.gs = gs ? mf_v3(gs[3 * i] * inv_ps, gs[3 * i + 1] * inv_ps, gs[3 * i + 2] * inv_ps) : mf_v3s(0.0f);
        if (is_zero3(a.g) && is_zero3(a.gd) && is_zero3(a.gs)) return; /* no adjoint here: nothing to trace */
    }
    MfPixelSampler smp;
    mf_pixel_sampler_init(&smp, e->seed, cam->w, x, y, ps);
    MfVec3 fwd = mf_v3(-cam->c2w.m[2], -cam->c2w.m[6], -cam->c2w.m[10]); /* camera -z */
    MfVec3 rgb = mf_v3s(0), dif = mf_v3s(0), spec = mf_v3s(0), alb = mf_v3s(0), orm = mf_v3s(0), nrm = mf_v3s(0);
    float depth = 0.0f;
    int hits = 0;
    for (int k = 0; k < ps; ++k) {
        float px, py;
        mf_pixel_sampler_pos(&smp, k, &px, &py);
        if (e->centre) px = (float)x + 0.5f, py = (float)y + 0.5f;
        MfVec3 org, dir;
        mf_camera_ray(cam, px, py, &org, &dir);
        raylog_push(log, org, dir, 0.0f, INFINITY, 0);
        MfHit h;
        if (!mf_rtscene_intersect(e->rt, org, dir, 0.0f, INFINITY, &h)) continue;
        ++hits;
        MfHit hs;
        int geo_s = e->rt_s && e->rt_s != e->rt && mf_rtscene_intersect(e->rt_s, org, dir, 0.0f, INFINITY, &hs);
        int id = (h.mat >= 0 && h.mat < e->nmat) ? h.mat : 0;
        Shading sh = {.e = e, .h = &h, .hs = geo_s ? &hs : &h, .id = id, .mat = material_at(&e->mats[id], &h),
                      .wo_w = mf_neg(dir), .a = adj ? &a : NULL, .adj = adj};
        /* shading normal: the material's normal map, or the hit's; and the sampling copy's */
        const MfImage *map = e->tan ? e->mats[id].normal : NULL;
        const MfImage *map_s = map && e->mats_s ? e->mats_s[id].normal : map;
        MfVec3 ns = h.ns, ns_s = sh.hs->ns;
        MfNmapFrame nf;
        int sep = geo_s;
        if (map) {
            nf = mf_nmap_frame(e->mesh, e->tan, &h);
            ns = ns_s = mf_nmap_normal(&nf, map, h.uv, sh.wo_w);
            sep = geo_s || (map_s && map_s != map);
            if (sep) ns_s = mf_nmap_normal(&nf, map_s ? map_s : map, h.uv, sh.wo_w);
        }
        sh.want_dn = adj && ((adj->dnormal && map) || (adj->dpos && !map)) && id == 0;
        int lit = shade(&sh, ns, ns_s, sep, &smp.rng, log);
        if (lit && e->bounces > 0 && !adj) bounce(&sh, ns, e->bounces, &smp.rng, log);
        if (adj) {
            if (!lit || id != 0) continue; /* nothing to add; gradient buffers are material 0's */
            float gkd[3] = {sh.dkd.x, sh.dkd.y, sh.dkd.z};
            float gorm[3] = {0.0f, sh.mat.orm.y >= 0.0f && sh.mat.orm.y <= 1.0f ? sh.dr : 0.0f,
                             sh.mat.orm.z >= 0.0f && sh.mat.orm.z <= 1.0f ? sh.dm : 0.0f};
            const MfTexMaterial *tm = &e->mats[0];
            const int uvkd = tm->kd && !tm->vkd, uvorm = tm->orm && !tm->vorm; /* looked up by UV */
            if (adj->dkd && uvkd) mf_tex_sample_backward(tm->kd, h.uv.x, h.uv.y, MF_WRAP_REPEAT, gkd, adj->dkd);
            if (adj->dorm && uvorm) mf_tex_sample_backward(tm->orm, h.uv.x, h.uv.y, MF_WRAP_REPEAT, gorm, adj->dorm);
            /* volume textures: their grids, and the hit position (for dpos) */
            const float p[3] = {h.p.x, h.p.y, h.p.z};
            float dp[3] = {0.0f, 0.0f, 0.0f}, *dpp = adj->dpos && !map ? dp : NULL;
            if (tm->vkd && (adj->dvkd || dpp)) mf_voltex_backward(tm->vkd, p, 1, gkd, adj->dvkd, dpp);
            if (tm->vorm && (adj->dvorm || dpp)) mf_voltex_backward(tm->vorm, p, 1, gorm, adj->dvorm, dpp);
            if (sh.want_dn && map) mf_nmap_normal_backward(&nf, map, h.uv, sh.wo_w, sh.dn, adj->dnormal);
            if (adj->dpos && !map) { /* the hit moves with the vertices: its UV, position and shading normal */
                MfVec2 duv = {0.0f, 0.0f};
                if (uvkd) mf_tex_sample_grad_uv(tm->kd, h.uv.x, h.uv.y, MF_WRAP_REPEAT, gkd, 3, &duv.x, &duv.y);
                if (uvorm) mf_tex_sample_grad_uv(tm->orm, h.uv.x, h.uv.y, MF_WRAP_REPEAT, gorm, 3, &duv.x, &duv.y);
                mf_hit_backward(e->mesh, &h, org, dir, duv, mf_v3(dp[0], dp[1], dp[2]), sh.dn, adj->dpos, adj->dnrm);
            }
            continue;
        }
        rgb = mf_add(rgb, radiance_out(e, &sh));
        dif = mf_add(dif, sh.dif);
        spec = mf_add(spec, sh.spec);
        alb = mf_add(alb, sh.mat.m.kd);
        orm = mf_add(orm, sh.mat.orm);
        nrm = mf_add(nrm, ns);
        depth += h.t * mf_dot(dir, fwd);
    }
    if (!out) return;
    out->alpha[i] = (float)hits * inv_ps;
    float inv_h = hits ? 1.0f / (float)hits : 0.0f;
    MfVec3 n = hits ? mf_norm(nrm) : nrm;
    const MfVec3 v3[6] = {mf_scale(rgb, inv_ps), mf_scale(dif, inv_ps), mf_scale(spec, inv_ps),
                          mf_scale(alb, inv_h), mf_scale(orm, inv_h), n};
    float *dst[6] = {out->rgb, out->diffuse, out->specular, out->albedo, out->orm, out->normal};
    for (int c = 0; c < 6; ++c) {
        dst[c][3 * i] = v3[c].x;
        dst[c][3 * i + 1] = v3[c].y;
        dst[c][3 * i + 2] = v3[c].z;
    }
    out->depth[i] = depth * inv_h;
}

void mf_est_render_rows(const MfEstimator *e, const MfCamera *cam, int y0, int y1, MfRenderOut *out, MfRayLog *logs,
                        MfProgress *prog) {
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = y0; y < y1; ++y) {
        MfRayLog *log = logs ? &logs[y - y0] : NULL;
        for (int x = 0; x < cam->w; ++x) mf_est_pixel(e, cam, x, y, out, NULL, log);
        if (prog) mf_progress_add(prog, 1);
    }
}

int mf_est_primary_hits(const MfEstimator *e, const MfCamera *cam, int x, int y, MfHit *hits) {
    MfPixelSampler smp;
    mf_pixel_sampler_init(&smp, e->seed, cam->w, x, y, e->pixel_samples);
    int n = 0;
    for (int k = 0; k < e->pixel_samples; ++k) {
        float px, py;
        mf_pixel_sampler_pos(&smp, k, &px, &py);
        if (e->centre) px = (float)x + 0.5f, py = (float)y + 0.5f;
        MfVec3 org, dir;
        mf_camera_ray(cam, px, py, &org, &dir);
        if (mf_rtscene_intersect(e->rt, org, dir, 0.0f, INFINITY, &hits[n])) ++n;
    }
    return n;
}
