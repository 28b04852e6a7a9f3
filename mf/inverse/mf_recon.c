#include "inverse/mf_recon.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "inverse/mf_budget.h"
#include "inverse/mf_denoise.h"
#include "render/mf_diffrender.h"
#include "inverse/mf_loss.h"
#include "inverse/mf_recon_opts.h"
#include "io/mf_exr.h"
#include "io/mf_gltf.h"
#include "io/mf_obj.h"
#include "io/mf_ckpt.h"
#include "render/mf_rtscene.h"
#include "scene/mf_tangent.h"

struct MfRecon {
    const MfMesh *mesh;         /* borrowed */
    MfRtScene *rt;              /* owned */
    MfReconView *views;         /* owned; (nviews,) with owned refs */
    int nviews;
    MfReconOpts o;
    MfParamBlock blocks[MF_NBLOCKS];
    int nblocks;                /* blocks in use: MF_BLOCK_NORMAL + 1 with a normal map, else 3 */
    float *tan;                 /* owned; (nv, 4) mesh tangents (normal map only), else NULL */
    MfAdam adam;
    MfEnvMap env;               /* owned; texels copied from blocks[ENV] before each use */
    float *uv_mask;             /* owned; (tex_res, tex_res) 1 where the mesh's UVs reach */
    int it;                     /* iterations done */
    double wall_offset;         /* wall seconds of earlier (resumed) runs */
    double t_forward, t_adjoint; /* seconds in the primal and adjoint renders (this process) */
    MfReconTimes times;         /* this process's mf_recon_run by stage */
    MfBilateral dn;             /* owned; the denoiser's buffers, reused view after view */
    MfParamSnapshot good;       /* owned; the last good state (lowest loss so far) */
    MfDivGuard guard;           /* the loss watch (running minimum, streak) */
    float lr_scale;             /* learning-rate multiplier, MF_RECON_RECOVERY_LR per recovery */
    float exposure;             /* 2^k: views' radiance / exposure (refs and env are held divided by it) */
    MfReconRecovery rec[64];    /* this process's recoveries (the first 64) */
    int nrec;                   /* recoveries in this process */
    int nrec_total;             /* recoveries including earlier (resumed) runs */
    int *train;                 /* owned; (ntrain,) the views in the loss (all but the held-out ones) */
    int ntrain;
    MfEarlyStop *es;            /* owned with early_stop (held-out curve and patience state), else NULL */
    int metal_state;            /* metal_auto: -1 not tested yet, 0 metallic kept, 1 frozen at 0 */
    double metal_fraction;      /* metal_auto: the fraction measured by the test (-1 before it) */
    double texel_side;          /* tex_auto: median sqrt(screen px / UV area) (0 when off) */
    unsigned char *env_cover;   /* owned with env_auto; (env_h, env_w) 1 where a view sees the texel in a reflection */
    double env_covered;         /* env_auto: fraction of texels covered (-1 when off) */
    int env_res_w;              /* env_res_auto: the width chosen (-1 before the choice) */
    double env_res_rough;       /* env_res_auto: the roughness it was chosen for (-1 before the choice) */
    int spp_now;                /* the training renders' spp_sqrt (spp_grow raises it) */
    double grow_prev, grow_sum; /* spp_grow: mean image loss of the last whole window (-1: none), sum of this one */
    int grow_n;                 /* spp_grow: iterations in this window so far */
    int grew_at[16], ngrew;     /* spp_grow: iterations where spp_now grew */
    /* vertex_lr > 0: the mesh moved by the image loss (verts_init, verts_step); normal_smooth > 0
     * (or vertex_lr > 0): its shading normals recomputed on the welded mesh */
    MfMesh own;                 /* the mutable copy r->mesh points to */
    MfMesh wmesh;               /* welded: (nw) vertices, own's triangles re-indexed; its normals */
    int *wmap;                  /* (nv,) own's vertex -> welded vertex */
    int *adj_off, *adj;         /* welded adjacency (CSR over the triangles' edges) */
    float *dpos, *dnrm;         /* (nv, 3) each: the iteration's dLoss/d own's positions, normals */
    float *wdn;                 /* (nw, 3) dLoss/d the welded normals */
    float *nhist;               /* (normal_smooth, nw, 3) the smoothing's inputs (mf_mesh_smooth_normals) */
    MfParamBlock pos;           /* (nw, 3) welded positions */
    MfAdam adam_pos;
};

long mf_peak_rss_bytes(void) {
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
    return ru.ru_maxrss * 1024L;
}

/* Marks texels whose centres fall inside (or within one texel of) a UV triangle. */
static void uv_mask_build(const MfMesh *m, int res, float *mask) {
    memset(mask, 0, (size_t)res * res * sizeof(float));
    for (int t = 0; t < m->nt; ++t) {
        float x[3], y[3];
        for (int k = 0; k < 3; ++k) {
            uint32_t v = m->tri[3 * t + k];
            x[k] = m->uv[2 * v] * res - 0.5f;
            y[k] = (1.0f - m->uv[2 * v + 1]) * res - 0.5f;
        }
        int x0 = (int)floorf(fminf(x[0], fminf(x[1], x[2]))) - 1, x1 = (int)ceilf(fmaxf(x[0], fmaxf(x[1], x[2]))) + 1;
        int y0 = (int)floorf(fminf(y[0], fminf(y[1], y[2]))) - 1, y1 = (int)ceilf(fmaxf(y[0], fmaxf(y[1], y[2]))) + 1;
        float area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
        for (int py = y0; py <= y1; ++py)
            for (int px = x0; px <= x1; ++px) {
                int inside = 0;
                /* a texel counts when its centre or any neighbour within 1 texel is inside */
                for (int dy = -1; dy <= 1 && !inside; ++dy)
                    for (int dx = -1; dx <= 1 && !inside; ++dx) {
                        float cx = (float)(px + dx), cy = (float)(py + dy);
                        float w0 = (x[1] - cx) * (y[2] - cy) - (x[2] - cx) * (y[1] - cy);
                        float w1 = (x[2] - cx) * (y[0] - cy) - (x[0] - cx) * (y[2] - cy);
                        float w2 = (x[0] - cx) * (y[1] - cy) - (x[1] - cx) * (y[0] - cy);
                        if (area > 0 ? (w0 >= 0 && w1 >= 0 && w2 >= 0) : (w0 <= 0 && w1 <= 0 && w2 <= 0)) inside = 1;
                    }
                if (!inside) continue;
                int wx = ((px % res) + res) % res, wy = ((py % res) + res) % res; /* repeat wrap */
                mask[(size_t)wy * res + wx] = 1.0f;
            }
    }
}

/* Ranges of the options mf_recon_new checks; a message names the option, its value and range. */
float mf_recon_exposure_of(const MfReconView *views, int nviews, double *mean) {
    double sum = 0.0;
    size_t cnt = 0;
    for (int i = 0; i < nviews; ++i) {
        const MfImage *im = &views[i].ref;
        for (size_t p = 0; p < (size_t)im->w * im->h; ++p) {
            const float *px = im->data + 4 * p;
            if (px[3] > 0.5f) sum += ((double)px[0] + px[1] + px[2]) / (3.0 * px[3]), cnt++;
        }
    }
    double m = cnt ? sum / (double)cnt : 0.0;
    if (mean) *mean = m;
    if (!(m > 0.0) || !isfinite(m)) return 1.0f; /* black or empty views: no information */
    long k = lround(log2(m / MF_RECON_EXPOSURE_REF));
    k = k < -100 ? -100 : (k > 100 ? 100 : k);
    return ldexpf(1.0f, (int)k);
}

/* env_auto: which env texels the training views (not the held-out ones) see in a reflection. */
static int env_coverage(MfRecon *r, const MfReconView *views, int nviews) {
    int W = r->o.env_w, H = r->o.env_h;
    unsigned char *skip = calloc((size_t)nviews, 1);
    r->env_cover = malloc((size_t)W * H);
    if (!skip || !r->env_cover) {
        free(skip);
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    for (int i = 0; i < nviews; ++i) skip[i] = (unsigned char)(r->o.early_stop && mf_budget_is_holdout(i, r->o.holdout_every));
    size_t n = mf_budget_env_coverage(r->rt, views, nviews, skip, W, H, r->o.env_auto_dilate, r->env_cover);
    free(skip);
    r->env_covered = (double)n / ((double)W * H);
    mf_log_info("recon: env_auto: the views see %.1f%% of the %dx%d env texels in a reflection (dilated by %d); the "
                "rest are pulled toward their neighbours (weight %g)", 100.0 * r->env_covered, W, H,
                r->o.env_auto_dilate, r->o.w_env_unseen);
    return MF_OK;
}

/* ---- moving vertices (vertex_lr > 0) and smoothed normals (normal_smooth > 0) ---- */

/* qsort_r order of vertex indices by position (pos (nv, 3) the context). */
static int cmp_pos(const void *a, const void *b, void *pos) {
    const float *p = (const float *)pos + 3 * *(const int *)a, *q = (const float *)pos + 3 * *(const int *)b;
    for (int k = 0; k < 3; ++k)
        if (p[k] != q[k]) return p[k] < q[k] ? -1 : 1;
    return 0;
}

/* The welded mesh's area-weighted normals, smoothed normal_smooth times (the inputs kept for the
 * backward), copied to own's seam copies. */
static int normals_apply(MfRecon *r) {
    int rc = mf_mesh_compute_normals(&r->wmesh);
    if (!rc) rc = mf_mesh_smooth_normals(&r->wmesh, r->o.normal_smooth, MF_RECON_NORMAL_SMOOTH_MIN_COS, r->nhist);
    for (int v = 0; !rc && v < r->own.nv; ++v) memcpy(r->own.nrm + 3 * v, r->wmesh.nrm + 3 * r->wmap[v], 3 * sizeof(float));
    return rc;
}

/* own = a copy of m; its vertices welded by exact position (the copies a UV atlas splits at its
 * seams) into wmesh, whose normals (normals_apply) are copied back, so seams do not crease; with
 * vertex_lr > 0 the welded positions are the optimised block, and the welded mesh's edge
 * adjacency serves the Laplacian. */
static int verts_init(MfRecon *r, const MfMesh *m) {
    int nv = m->nv, rc = mf_mesh_alloc(&r->own, nv, m->nt, 1, 1);
    if (rc) return rc;
    memcpy(r->own.pos, m->pos, (size_t)nv * 3 * sizeof(float));
    memcpy(r->own.uv, m->uv, (size_t)nv * 2 * sizeof(float));
    memcpy(r->own.tri, m->tri, (size_t)m->nt * 3 * sizeof(uint32_t));
    if ((rc = mf_mesh_copy_materials(&r->own, m))) return rc;
    int *ord = malloc((size_t)nv * sizeof *ord);
    r->wmap = malloc((size_t)nv * sizeof *r->wmap);
    r->dpos = calloc((size_t)nv * 3, sizeof *r->dpos);
    r->dnrm = calloc((size_t)nv * 3, sizeof *r->dnrm);
    if (!ord || !r->wmap || !r->dpos || !r->dnrm) return free(ord), mf_fail(MF_ENOMEM, "out of memory");
    for (int v = 0; v < nv; ++v) ord[v] = v;
    qsort_r(ord, (size_t)nv, sizeof *ord, cmp_pos, m->pos);
    int nw = 0;
    for (int k = 0; k < nv; ++k) {
        if (k > 0 && cmp_pos(&ord[k - 1], &ord[k], m->pos) != 0) ++nw;
        r->wmap[ord[k]] = nw;
    }
    nw = nv ? nw + 1 : 0;
    free(ord);
    if ((rc = mf_mesh_alloc(&r->wmesh, nw, m->nt, 1, 0))) return rc;
    for (int v = 0; v < nv; ++v) memcpy(r->wmesh.pos + 3 * r->wmap[v], m->pos + 3 * v, 3 * sizeof(float));
    for (int t = 0; t < 3 * m->nt; ++t) r->wmesh.tri[t] = (uint32_t)r->wmap[m->tri[t]];
    r->wdn = malloc((size_t)nw * 3 * sizeof *r->wdn + 1);
    r->nhist = malloc((size_t)r->o.normal_smooth * nw * 3 * sizeof *r->nhist + 1);
    if (!r->wdn || !r->nhist) return mf_fail(MF_ENOMEM, "out of memory");
    if ((rc = normals_apply(r))) return rc;
    if (r->o.vertex_lr > 0) {
        if ((rc = mf_reg_laplacian_adjacency(r->wmesh.tri, m->nt, nw, &r->adj_off, &r->adj))) return rc;
        if ((rc = mf_param_init(&r->pos, "pos", (size_t)nw * 3, 3, r->wmesh.pos))) return rc;
        mf_adam_init(&r->adam_pos, r->o.vertex_lr);
        mf_log_info("recon: vertices move (--vertex-lr %g, --vertex-laplacian %g): %d vertices, %d welded across UV seams",
                    (double)r->o.vertex_lr, (double)r->o.vertex_laplacian, nv, nw);
    }
    if (r->o.normal_smooth > 0) mf_log_info("recon: shading normals smoothed over %d rings (--normal-smooth)", r->o.normal_smooth);
    return MF_OK;
}

/* The welded positions (r->pos) to the welded mesh, its normals, own and the Embree scene (rebuilt). */
static int verts_apply(MfRecon *r) {
    int nw = r->wmesh.nv, nv = r->own.nv;
    memcpy(r->wmesh.pos, r->pos.p, (size_t)nw * 3 * sizeof(float));
    int rc = normals_apply(r);
    if (rc) return rc;
    for (int v = 0; v < nv; ++v) memcpy(r->own.pos + 3 * v, r->wmesh.pos + 3 * r->wmap[v], 3 * sizeof(float));
    mf_rtscene_free(r->rt);
    r->rt = NULL;
    return mf_rtscene_new(&r->own, &r->rt);
}

/* The blocks a checkpoint holds: the textures' and env's (and normal map's), then, with moving
 * vertices, their welded positions (shallow copies into all (MF_NBLOCKS + 1,)); returns the count. */
static int ckpt_blocks(const MfRecon *r, MfParamBlock *all) {
    for (int b = 0; b < r->nblocks; ++b) all[b] = r->blocks[b];
    if (r->o.vertex_lr > 0) all[r->nblocks] = r->pos;
    return r->nblocks + (r->o.vertex_lr > 0);
}

/* One Adam step of the welded positions on the iteration's image gradient (r->dpos and, through
 * the welded mesh's normals and their smoothing, r->dnrm, gathered over the seam copies) plus
 * vertex_laplacian x (1 - it / iters) / nw x the uniform Laplacian (mf_reg_laplacian); own, its
 * normals and the Embree scene (rebuilt) follow. */
static int verts_step(MfRecon *r, int it) {
    int nw = r->wmesh.nv, nv = r->own.nv;
    float *g = r->pos.g, *p = r->pos.p;
    memset(g, 0, (size_t)nw * 3 * sizeof *g);
    memset(r->wdn, 0, (size_t)nw * 3 * sizeof *r->wdn);
    for (int v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) g[3 * r->wmap[v] + k] += r->dpos[3 * v + k], r->wdn[3 * r->wmap[v] + k] += r->dnrm[3 * v + k];
    memset(r->dpos, 0, (size_t)nv * 3 * sizeof *r->dpos);
    memset(r->dnrm, 0, (size_t)nv * 3 * sizeof *r->dnrm);
    int rc = mf_mesh_smooth_normals_backward(&r->wmesh, r->o.normal_smooth, MF_RECON_NORMAL_SMOOTH_MIN_COS, r->nhist, r->wdn);
    if (!rc) rc = mf_mesh_normals_backward(&r->wmesh, r->wdn, g);
    if (rc) return rc;
    double lam = (double)r->o.vertex_laplacian * (1.0 - (double)it / r->o.iters) / nw;
    mf_reg_laplacian_bwd(p, nw, r->adj_off, r->adj, (float)lam, g);
    rc = mf_adam_step(&r->adam_pos, &r->pos, 1, r->o.vertex_lr * mf_lr_schedule(1.0f, it));
    return rc ? rc : verts_apply(r);
}

int mf_recon_new(const MfMesh *mesh, MfReconView *views, int nviews, const MfReconOpts *opts, MfRecon **out) {
    if (!mesh->uv) return mf_fail(MF_EARG, "the mesh has no UVs: reconstruction needs a UV-mapped mesh (unwrap it first: mf unwrap IN.obj -o OUT.obj)");
    if (nviews < 1) return mf_fail(MF_EARG, "no training views");
    int rc = mf_opts_check(&mf_recon_opt_table, opts); /* names the option, its value and its range */
    if (rc) return mf_fail_prefix(rc, "reconstruction options");
    if (opts->tex_auto && opts->tex_auto_min > opts->tex_auto_max)
        return mf_fail(MF_EARG, "reconstruction options: tex_auto_min %d is above tex_auto_max %d", opts->tex_auto_min,
                       opts->tex_auto_max);
    if (opts->vertex_lr > 0 && opts->normal_map)
        return mf_fail(MF_EARG, "reconstruction options: vertex_lr %g with normal_map 1: moving vertices under a normal map is not "
                                "supported (the vertex gradient is refused with a map)", (double)opts->vertex_lr);
    if (opts->early_stop && nviews < 2)
        return mf_fail(MF_EARG, "reconstruction options: early_stop holds out views and needs at least 2 (there is %d)", nviews);
    if (opts->spp_sqrt == 1 && !opts->denoise)
        mf_log_warn("recon: --spp 1 (one light and one BSDF sample per pixel) without the denoiser: measured to lose "
                    "2.9 / 4.7 dB relit PSNR on val-3d / test-3d, the training loss rising instead of falling "
                    "(reports/adaptive/); use --spp 2 or more, or --denoise 1");
    MfRecon *r = calloc(1, sizeof *r);
    if (!r) return mf_fail(MF_ENOMEM, "out of memory");
    r->mesh = mesh;
    r->o = *opts;
    if (r->o.vertex_lr < 0) r->o.vertex_lr = 0;       /* unresolved default: fixed */
    if (r->o.normal_smooth < 0) r->o.normal_smooth = 0; /* unresolved default: the mesh's normals */
    r->lr_scale = 1.0f;
    r->metal_state = -1;
    r->metal_fraction = -1.0;
    r->env_covered = -1.0;
    r->env_res_w = -1;
    r->env_res_rough = -1.0;
    r->spp_now = opts->spp_sqrt;
    r->grow_prev = -1.0;
    mf_divguard_init(&r->guard, opts->div_factor, opts->div_patience);
    rc = MF_OK;
    if ((r->o.vertex_lr > 0 || r->o.normal_smooth > 0) && !(rc = verts_init(r, mesh))) r->mesh = mesh = &r->own;
    if (!rc) rc = mf_rtscene_new(mesh, &r->rt);
    if (!rc && opts->tex_auto && !(rc = mf_budget_texel_side(r->rt, mesh, views, nviews, &r->texel_side, NULL))) {
        r->o.tex_res = mf_budget_pow2_side(r->texel_side, opts->tex_auto_min, opts->tex_auto_max);
        mf_log_info("recon: tex_auto: median %.1f texels per side for 1 pixel per texel over the %d views: tex_res %d",
                    r->texel_side, nviews, r->o.tex_res);
    }
    if (!rc && !(r->train = malloc((size_t)nviews * sizeof(int)))) rc = mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; !rc && i < nviews; ++i)
        if (!opts->early_stop || !mf_budget_is_holdout(i, opts->holdout_every)) r->train[r->ntrain++] = i;
    if (!rc && opts->env_auto) rc = env_coverage(r, views, nviews);
    if (!rc && opts->early_stop) {
        if (!(r->es = malloc(sizeof *r->es))) rc = mf_fail(MF_ENOMEM, "out of memory");
        else mf_early_stop_init(r->es);
    }
    int T = r->o.tex_res;
    size_t ntex = (size_t)T * T * 3, nenv = (size_t)opts->env_w * opts->env_h * 3;
    if (!rc) rc = mf_param_init(&r->blocks[MF_BLOCK_KD], "kd", ntex, 3, NULL);
    if (!rc) rc = mf_param_init(&r->blocks[MF_BLOCK_ORM], "orm", ntex, 3, NULL);
    if (!rc) rc = mf_param_init(&r->blocks[MF_BLOCK_ENV], "env", nenv, 3, NULL);
    r->nblocks = opts->normal_map ? MF_BLOCK_NORMAL + 1 : MF_BLOCK_NORMAL;
    if (!rc && opts->normal_map) {
        rc = mf_param_init(&r->blocks[MF_BLOCK_NORMAL], "normal", ntex, 3, NULL);
        if (!rc && !(r->tan = malloc((size_t)mesh->nv * 4 * sizeof(float) + 1))) rc = mf_fail(MF_ENOMEM, "out of memory");
        if (!rc) rc = mf_mesh_tangents(mesh, r->tan);
    }
    if (!rc) rc = mf_env_init_constant(&r->env, opts->env_w, opts->env_h, mf_v3s(opts->init_light));
    if (!rc && !(r->uv_mask = malloc((size_t)T * T * sizeof(float)))) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (!rc && !(r->views = malloc((size_t)nviews * sizeof *views))) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (rc) {
        mf_recon_free(r);
        return rc;
    }
    MfParamBlock *kd = &r->blocks[MF_BLOCK_KD], *orm = &r->blocks[MF_BLOCK_ORM], *env = &r->blocks[MF_BLOCK_ENV];
    for (size_t i = 0; i < ntex; i += 3) {
        kd->p[i] = kd->p[i + 1] = kd->p[i + 2] = opts->init_kd;
        orm->p[i] = 1.0f;
        orm->p[i + 1] = opts->init_rough;
        orm->p[i + 2] = opts->init_metal;
    }
    for (size_t i = 0; i < nenv; ++i) env->p[i] = opts->init_light;
    for (int c = 0; c < 3; ++c) mf_param_set_bounds(kd, c, 0.0f, 1.0f), mf_param_set_bounds(env, c, 0.01f, INFINITY);
    mf_param_set_bounds(orm, 0, 1.0f, 1.0f);
    mf_param_set_bounds(orm, 1, MF_MIN_ROUGHNESS, 1.0f);
    mf_param_set_bounds(orm, 2, 0.0f, 1.0f);
    env->lr_scale = opts->light_lr_scale;
    if (opts->normal_map) {
        MfParamBlock *nb = &r->blocks[MF_BLOCK_NORMAL];
        for (size_t i = 0; i < ntex; i += 3) nb->p[i] = nb->p[i + 1] = 0.5f, nb->p[i + 2] = 1.0f;
        for (int c = 0; c < 3; ++c) mf_param_set_bounds(nb, c, 0.0f, 1.0f);
    }
    mf_param_project(orm);
    mf_adam_init(&r->adam, opts->lr);
    uv_mask_build(mesh, T, r->uv_mask);
    for (int i = 0; i < nviews; ++i) {
        r->views[i] = views[i];
        memset(&views[i].ref, 0, sizeof views[i].ref);
    }
    r->nviews = nviews;
    /* exposure: the loop works on views divided by a power of two (exact in float) near their
     * mean radiance; the env it learns is multiplied back on output */
    double mean = 0.0;
    r->exposure = mf_recon_exposure_of(r->views, nviews, &mean);
    for (int i = 0; i < nviews && r->exposure != 1.0f; ++i) {
        MfImage *im = &r->views[i].ref;
        for (size_t p = 0; p < (size_t)im->w * im->h; ++p)
            for (int c = 0; c < 3; ++c) im->data[4 * p + c] /= r->exposure;
    }
    mf_log_info("recon: the views' mean radiance inside their masks is %.4g: working in units of 2^%d (env.exr is "
                    "written in the views' units)", mean, (int)lroundf(log2f(r->exposure)));
    *out = r;
    return MF_OK;
}

void mf_recon_free(MfRecon *r) {
    if (!r) return;
    mf_rtscene_free(r->rt);
    mf_mesh_free(&r->own), mf_mesh_free(&r->wmesh), mf_param_free(&r->pos);
    free(r->wmap), free(r->adj_off), free(r->adj), free(r->dpos), free(r->dnrm), free(r->wdn), free(r->nhist);
    for (int b = 0; b < MF_NBLOCKS; ++b) mf_param_free(&r->blocks[b]);
    mf_env_free(&r->env);
    mf_bilateral_free(&r->dn);
    mf_param_snapshot_free(&r->good);
    for (int i = 0; r->views && i < r->nviews; ++i) mf_image_free(&r->views[i].ref);
    free(r->views);
    free(r->uv_mask);
    free(r->tan);
    free(r->train);
    free(r->es);
    free(r->env_cover);
    free(r);
}

int mf_recon_iteration(const MfRecon *r) { return r->it; }
const MfReconRecovery *mf_recon_recoveries(const MfRecon *r, int *n) {
    *n = r->nrec;
    return r->rec;
}
float mf_recon_lr_scale(const MfRecon *r) { return r->lr_scale; }
float mf_recon_exposure(const MfRecon *r) { return r->exposure; }
MfParamBlock *mf_recon_block(MfRecon *r, MfBlockId id) { return &r->blocks[id]; }
const MfReconOpts *mf_recon_opts(const MfRecon *r) { return &r->o; }
const MfReconView *mf_recon_view(const MfRecon *r, int i) { return &r->views[i]; }
int mf_recon_nviews(const MfRecon *r) { return r->nviews; }
const MfMesh *mf_recon_mesh(const MfRecon *r) { return r->mesh; }
const MfRtScene *mf_recon_rtscene(const MfRecon *r) { return r->rt; }
const MfEnvMap *mf_recon_env(const MfRecon *r) { return &r->env; }
void mf_recon_timing(const MfRecon *r, double *forward_s, double *adjoint_s) {
    *forward_s = r->t_forward;
    *adjoint_s = r->t_adjoint;
}
void mf_recon_times(const MfRecon *r, MfReconTimes *t) { *t = r->times; }

static MfImage block_image(const MfParamBlock *b, int w, int h) {
    MfImage im = {w, h, 3, b->p};
    return im;
}
const MfEarlyStop *mf_recon_early_stop(const MfRecon *r) { return r->es; }
int mf_recon_metal_state(const MfRecon *r, double *fraction) {
    *fraction = r->metal_fraction;
    return r->metal_state;
}
double mf_recon_texel_side(const MfRecon *r) { return r->texel_side; }
double mf_recon_env_covered(const MfRecon *r) { return r->env_covered; }
int mf_recon_env_res(const MfRecon *r, double *rough) {
    if (rough) *rough = r->env_res_rough;
    return r->env_res_w;
}
int mf_recon_spp_now(const MfRecon *r, const int **grew_at, int *n) {
    if (grew_at) *grew_at = r->grew_at;
    if (n) *n = r->ngrew;
    return r->spp_now;
}
int mf_recon_is_holdout(const MfRecon *r, int view) { return r->o.early_stop && mf_budget_is_holdout(view, r->o.holdout_every); }

MfImage mf_recon_kd_image(const MfRecon *r) { return block_image(&r->blocks[MF_BLOCK_KD], r->o.tex_res, r->o.tex_res); }
MfImage mf_recon_orm_image(const MfRecon *r) { return block_image(&r->blocks[MF_BLOCK_ORM], r->o.tex_res, r->o.tex_res); }
MfImage mf_recon_normal_image(const MfRecon *r) { return block_image(&r->blocks[MF_BLOCK_NORMAL], r->o.tex_res, r->o.tex_res); }

/* Copies the env block into the env map and rebuilds its sampling tables. */
static int sync_env(MfRecon *r) {
    memcpy(r->env.img.data, r->blocks[MF_BLOCK_ENV].p, r->blocks[MF_BLOCK_ENV].n * sizeof(float));
    return mf_env_update(&r->env);
}

/* ---- checkpoints: every block's values and Adam moments, plus the iteration ---- */

static int save_checkpoint(const MfRecon *r, const char *path, double wall) {
    char bad[96];
    MfParamBlock all[MF_NBLOCKS + 1];
    int nall = ckpt_blocks(r, all);
    if (mf_params_find_nonfinite(all, nall, bad, sizeof bad))
        return mf_fail(MF_ENAN, "%s: not written at iteration %d: %s is not finite", path, r->it, bad);
    MfTensorSpec specs[(MF_NBLOCKS + 1) * 3];
    int ns = mf_param_ckpt_specs(all, nall, specs);
    MfParamSnapshot snap = {0};
    int rc = mf_param_snapshot_save(&snap, all, nall, &r->adam);
    if (rc) return mf_fail_prefix(rc, "%s", path);
    char meta[1024], grew[16 * 12] = "";
    for (int i = 0, len = 0; i < r->ngrew && i < 16; ++i)
        len += snprintf(grew + len, sizeof grew - (size_t)len, "%s%d", i ? " " : "", r->grew_at[i]);
    snprintf(meta, sizeof meta,
             "{\"kind\":\"mf-recon\",\"iteration\":%d,\"adam_t\":%ld,\"wall_s\":%.17g,\"tex_res\":%d,\"env_w\":%d,\"env_h\":%d,"
             "\"lr_scale\":%.9g,\"loss_min\":%.17g,\"recoveries\":%d,\"exposure\":%.9g,\"metal_state\":%d,\"metal_fraction\":%.17g,"
             "\"spp_now\":%d,\"grow_prev\":%.17g,\"grow_sum\":%.17g,\"grow_n\":%d,\"grew_at\":\"%s\",\"env_res_w\":%d,"
             "\"env_res_rough\":%.17g,\"vertex_adam_t\":%ld}",
             r->it, r->adam.t, wall, r->o.tex_res, r->o.env_w, r->o.env_h, r->lr_scale,
             isfinite(r->guard.loss_min) ? r->guard.loss_min : -1.0, r->nrec_total, r->exposure, r->metal_state,
             r->metal_fraction, r->spp_now, r->grow_prev, r->grow_sum, r->grow_n, grew, r->env_res_w, r->env_res_rough,
             r->o.vertex_lr > 0 ? r->adam_pos.t : -1L);
    rc = mf_ckpt_save(path, specs, ns, snap.buf, meta);
    mf_param_snapshot_free(&snap);
    return rc;
}

/* Shrinks the env map to w x h (an exact fraction 1/f of its size): its values and Adam moments are
 * box-averaged over f x f texels; the env map, env_auto's coverage and the last good state follow. */
static int env_resize(MfRecon *r, int w, int h) {
    int W = r->o.env_w, f = W / w;
    MfParamBlock *old = &r->blocks[MF_BLOCK_ENV], nb;
    int rc = mf_param_init(&nb, old->name, (size_t)w * h * 3, 3, NULL);
    if (rc) return rc;
    nb.lr_scale = old->lr_scale;
    memcpy(nb.lo, old->lo, sizeof nb.lo), memcpy(nb.hi, old->hi, sizeof nb.hi);
    mf_budget_env_shrink(old->p, W, r->o.env_h, f, nb.p);
    mf_budget_env_shrink(old->m, W, r->o.env_h, f, nb.m);
    mf_budget_env_shrink(old->v, W, r->o.env_h, f, nb.v);
    mf_param_free(old);
    *old = nb;
    r->o.env_w = w, r->o.env_h = h;
    mf_env_free(&r->env);
    if ((rc = mf_env_init_constant(&r->env, w, h, mf_v3s(1.0f))) || (rc = sync_env(r))) return rc;
    if (r->env_cover) {
        free(r->env_cover), r->env_cover = NULL;
        if ((rc = env_coverage(r, r->views, r->nviews))) return rc;
    }
    mf_param_snapshot_free(&r->good);
    return mf_param_snapshot_save(&r->good, r->blocks, r->nblocks, &r->adam);
}

/* The env size a checkpoint holds (env_res_auto may have shrunk it): resize to it before loading. */
static int env_size_of_checkpoint(MfRecon *r, const char *path) {
    char *meta = NULL;
    int w = 0, h = 0, rc = mf_ckpt_read_meta(path, (size_t)1 << 24, &meta);
    if (rc) return rc;
    const char *pw = meta ? strstr(meta, "\"env_w\":") : NULL;
    if (pw && sscanf(pw, "\"env_w\":%d,\"env_h\":%d", &w, &h) == 2 && w != r->o.env_w) {
        if (w < 1 || h < 1 || r->o.env_w % w || r->o.env_h % h || r->o.env_w / w != r->o.env_h / h)
            rc = mf_fail(MF_EFORMAT, "%s: its env map is %dx%d, not a fraction of this run's %dx%d", path, w, h, r->o.env_w,
                         r->o.env_h);
        else rc = env_resize(r, w, h);
    }
    free(meta);
    return rc;
}

int mf_recon_load_checkpoint(MfRecon *r, const char *path) {
    if (r->o.env_res_auto) {
        int rc = env_size_of_checkpoint(r, path);
        if (rc) return rc;
    }
    MfParamBlock all[MF_NBLOCKS + 1];
    int nall = ckpt_blocks(r, all);
    MfTensorSpec specs[(MF_NBLOCKS + 1) * 3];
    int ns = mf_param_ckpt_specs(all, nall, specs);
    size_t total = mf_specs_numel(specs, ns);
    float *buf = malloc(total * sizeof(float) + 1);
    char *meta = NULL;
    if (!buf) return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    int rc = mf_ckpt_load(path, specs, ns, buf, &meta);
    if (rc) {
        free(buf);
        return mf_fail_prefix(rc, "resume (were texture/env sizes, normal_map or vertex_lr changed?)");
    }
    int it = -1;
    long t = -1;
    double wall = 0.0;
    const char *pi = meta ? strstr(meta, "\"iteration\":") : NULL, *pt = meta ? strstr(meta, "\"adam_t\":") : NULL;
    const char *pw = meta ? strstr(meta, "\"wall_s\":") : NULL;
    if (!pi || !pt || sscanf(pi, "\"iteration\":%d", &it) != 1 || sscanf(pt, "\"adam_t\":%ld", &t) != 1 || it < 0) {
        free(buf);
        free(meta);
        return mf_fail(MF_EFORMAT, "%s: not a reconstruction checkpoint (no iteration in its header)", path);
    }
    if (pw) sscanf(pw, "\"wall_s\":%lf", &wall);
    /* a non-finite value never resumes: name the tensor (block.part) and element */
    for (int b = 0, o = 0; b < nall; ++b)
        for (int k = 0; k < 3; ++k)
            for (size_t i = 0; i < all[b].n; ++i, ++o)
                if (!isfinite(buf[o])) {
                    float v = buf[o];
                    free(buf);
                    free(meta);
                    return mf_fail(MF_ENAN, "%s: tensor %s.%c element %zu is %g; refusing to resume from it", path,
                                   all[b].name, "pmv"[k], i, v);
                }
    long vt = -1;
    const char *pv = meta ? strstr(meta, "\"vertex_adam_t\":") : NULL;
    if (pv) sscanf(pv, "\"vertex_adam_t\":%ld", &vt);
    if (r->o.vertex_lr > 0 && vt < 0) {
        free(buf);
        free(meta);
        return mf_fail(MF_EFORMAT, "%s: holds no vertex positions' optimiser state (written without vertex_lr?)", path);
    }
    /* the guard's state (absent in checkpoints of older builds: defaults) */
    float lr_scale = 1.0f;
    double loss_min = -1.0;
    int nrec = 0;
    const char *pl = meta ? strstr(meta, "\"lr_scale\":") : NULL, *pm = meta ? strstr(meta, "\"loss_min\":") : NULL;
    const char *pr = meta ? strstr(meta, "\"recoveries\":") : NULL;
    if (pl) sscanf(pl, "\"lr_scale\":%f", &lr_scale);
    if (pm) sscanf(pm, "\"loss_min\":%lf", &loss_min);
    if (pr) sscanf(pr, "\"recoveries\":%d", &nrec);
    int metal_state = -1;
    double metal_fraction = -1.0;
    const char *pms = meta ? strstr(meta, "\"metal_state\":") : NULL, *pmf = meta ? strstr(meta, "\"metal_fraction\":") : NULL;
    if (pms) sscanf(pms, "\"metal_state\":%d", &metal_state);
    if (pmf) sscanf(pmf, "\"metal_fraction\":%lf", &metal_fraction);
    float expo = 1.0f;
    const char *pe = meta ? strstr(meta, "\"exposure\":") : NULL;
    if (pe) sscanf(pe, "\"exposure\":%f", &expo);
    if (expo != r->exposure) {
        free(buf);
        free(meta);
        return mf_fail(MF_EARG, "%s: written for views of exposure %g, these views have %g (other images?)", path, expo,
                       r->exposure);
    }
    if (!isfinite(lr_scale) || lr_scale <= 0.0f) {
        free(buf);
        free(meta);
        return mf_fail(MF_EFORMAT, "%s: lr_scale %g in its header is not a positive number", path, lr_scale);
    }
    MfParamSnapshot snap = {.buf = buf, .len = total, .t = t}; /* buf is in a snapshot's order */
    mf_param_snapshot_restore(&snap, all, nall, &r->adam);
    if (r->o.vertex_lr > 0) { /* the positions' values and moments came with it; the mesh follows */
        r->adam_pos.t = vt;
        int arc = verts_apply(r);
        if (arc) {
            free(buf);
            free(meta);
            return arc;
        }
    }
    r->it = it;
    r->wall_offset = wall;
    r->lr_scale = lr_scale;
    r->nrec_total = nrec;
    r->metal_state = metal_state;
    r->metal_fraction = metal_fraction;
    /* spp_grow's state (absent in older checkpoints: the start; without spp_grow, --spp as given) */
    const char *ps = meta && r->o.spp_grow ? strstr(meta, "\"spp_now\":") : NULL;
    if (ps && sscanf(ps, "\"spp_now\":%d,\"grow_prev\":%lf,\"grow_sum\":%lf,\"grow_n\":%d", &r->spp_now, &r->grow_prev,
                     &r->grow_sum, &r->grow_n) == 4) {
        const char *pg = strstr(ps, "\"grew_at\":\"");
        r->ngrew = 0;
        for (const char *q = pg ? pg + 11 : ""; r->ngrew < 16 && *q && *q != '"';) {
            char *end;
            long v = strtol(q, &end, 10);
            if (end == q) break;
            r->grew_at[r->ngrew++] = (int)v, q = end;
        }
    }
    const char *pe2 = meta && r->o.env_res_auto ? strstr(meta, "\"env_res_w\":") : NULL;
    if (pe2) sscanf(pe2, "\"env_res_w\":%d,\"env_res_rough\":%lf", &r->env_res_w, &r->env_res_rough);
    if (metal_state == 1) mf_param_set_bounds(&r->blocks[MF_BLOCK_ORM], 2, 0.0f, 0.0f);
    mf_divguard_init(&r->guard, r->o.div_factor, r->o.div_patience);
    if (isfinite(loss_min) && loss_min >= 0.0) r->guard.loss_min = loss_min;
    free(buf);
    free(meta);
    return MF_OK;
}

/* ---- one iteration ---- */

typedef struct { double image, alpha, reg, sds, psnr; } IterStats;

static int view_step(MfRecon *r, int vi, uint64_t vseed, float scale, IterStats *st) {
    const MfReconView *v = &r->views[vi];
    int w = v->cam.w, h = v->cam.h;
    size_t npx = (size_t)w * h;
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r), nm = mf_recon_normal_image(r);
    MfDiffScene s = {.rt = r->rt, .kd = &kd, .orm = &orm, .env = &r->env, .normal = r->o.normal_map ? &nm : NULL,
                     .tangent = r->tan};
    MfDiffOpts fo = {.spp_sqrt = r->spp_now, .pixel_samples = r->o.pixel_samples, .seed = mf_hash64(vseed, 1)};
    MfRenderOut out;
    float *dz = NULL, *dn = NULL, *gbuf = NULL; /* denoiser: (h, w), (3, h, w, 3), (4, h, w, 3) */
    float *dmod_c = NULL;                       /* (h, w, 3) F(diffuse) of the seed-C render */
    MfRenderOut out_c;
    memset(&out_c, 0, sizeof out_c);
    int rc = mf_render_out_alloc(&out, w, h);
    if (rc) return rc;
    float *bg = malloc(npx * 3 * sizeof(float)), *cp = malloc(npx * 3 * sizeof(float));
    float *cr = malloc(npx * 3 * sizeof(float)), *ra = malloc(npx * sizeof(float));
    float *drgb = calloc(npx * 3, sizeof(float)), *dd = calloc(npx * 3, sizeof(float)), *ds = calloc(npx * 3, sizeof(float));
    float *rrgb = malloc(npx * 3 * sizeof(float));
    if (!bg || !cp || !cr || !ra || !drgb || !dd || !ds || !rrgb) {
        rc = mf_fail(MF_ENOMEM, "out of memory for a %dx%d view", w, h);
        goto done;
    }
    double t0 = mf_now();
    if ((rc = mf_diff_forward(&s, &v->cam, &fo, &out))) goto done;
    r->t_forward += mf_now() - t0;
    /* the light and image the loss sees: the renderer's, or the denoised recombination */
    const float *lrgb = out.rgb, *ldif = out.diffuse, *lspec = out.specular;
    if (r->o.denoise) {
        if (!(dz = malloc(npx * sizeof(float))) || !(dn = malloc(npx * 9 * sizeof(float)))) {
            rc = mf_fail(MF_ENOMEM, "out of memory for the denoiser of a %dx%d view", w, h);
            goto done;
        }
        mf_bilateral_depth_slope(&v->cam, out.normal, out.depth, out.alpha, dz);
        if ((rc = mf_bilateral_init(&r->dn, w, h, r->o.denoise_sigma, out.normal, out.depth, dz, out.alpha)) ||
            (rc = mf_denoise_combine_forward(&r->dn, out.diffuse, out.specular, out.albedo, out.orm, dn, dn + 3 * npx,
                                             dn + 6 * npx)))
            goto done;
        ldif = dn, lspec = dn + 3 * npx, lrgb = dn + 6 * npx;
    }
    MfRng rng;
    mf_rng_seed(&rng, mf_hash64(vseed, 2), 0);
    for (size_t i = 0; i < npx * 3; ++i) bg[i] = mf_rng_float(&rng);
    for (size_t i = 0; i < npx; ++i) {
        ra[i] = v->ref.data[4 * i + 3];
        for (int c = 0; c < 3; ++c) rrgb[3 * i + c] = v->ref.data[4 * i + c];
    }
    mf_loss_composite(cp, lrgb, out.alpha, bg, npx);
    mf_loss_composite(cr, rrgb, ra, bg, npx);
    st->image += mf_loss_logl1_fwd(cp, cr, npx * 3, r->o.loss_floor) * scale;
    st->alpha += mf_loss_mse_fwd(out.alpha, ra, npx) * scale;
    mf_loss_logl1_bwd(cp, cr, npx * 3, r->o.loss_floor, scale, drgb); /* d composite / d rgb_premult = 1 */
    if (r->o.w_shading > 0.0f) {
        st->reg += r->o.w_shading * mf_reg_shading_fwd(ldif, lspec, out.alpha, npx, r->o.w_spec_ratio) * scale;
        mf_reg_shading_bwd(ldif, lspec, out.alpha, npx, r->o.w_spec_ratio, r->o.w_shading * scale, dd, ds);
    }
    double se = 0.0;
    for (size_t i = 0; i < npx * 3; ++i) {
        float a = mf_clampf(mf_linear_to_srgb(cp[i]), 0.0f, 1.0f), b = mf_clampf(mf_linear_to_srgb(cr[i]), 0.0f, 1.0f);
        se += (double)(a - b) * (a - b);
    }
    st->psnr += 10.0 * log10(1.0 / fmax(se / (double)(npx * 3), 1e-10)) * scale;
    MfDiffOpts bo = fo;
    bo.seed = mf_hash64(vseed, 3); /* decorrelated from the primal samples */
    MfDiffAdjoint adj = {.drgb = drgb, .ddiffuse = dd, .dspecular = ds};
    MfDiffGrads g = {.dkd = r->blocks[MF_BLOCK_KD].g, .dorm = r->blocks[MF_BLOCK_ORM].g, .denv = r->blocks[MF_BLOCK_ENV].g,
                     .dnormal = r->o.normal_map ? r->blocks[MF_BLOCK_NORMAL].g : NULL,
                     .dpos = r->o.vertex_lr > 0 ? r->dpos : NULL, .dnrm = r->o.vertex_lr > 0 ? r->dnrm : NULL};
    if (r->o.denoise) {
        /* through the recombination and F^T: per-pixel light adjoints, and the material AOVs'
         * adjoints (kd (1 - m) multiplies the denoised diffuse light per pixel) */
        if (!(gbuf = calloc(npx * 12, sizeof(float)))) {
            rc = mf_fail(MF_ENOMEM, "out of memory for the denoiser of a %dx%d view", w, h);
            goto done;
        }
        float *gd = gbuf, *gs = gbuf + 3 * npx, *galb = gbuf + 6 * npx, *gorm = gbuf + 9 * npx;
        /* the light multiplying kd's adjoint: the primal's (nvdiffrecmc) or, decorrelated, an
         * independent render (seed C) through the same filter */
        const float *dmod = ldif;
        if (r->o.denoise_decorrelate) {
            MfDiffOpts co = fo;
            co.seed = mf_hash64(vseed, 4);
            t0 = mf_now();
            if ((rc = mf_render_out_alloc(&out_c, w, h)) || (rc = mf_diff_forward(&s, &v->cam, &co, &out_c))) goto done;
            r->t_forward += mf_now() - t0;
            if (!(dmod_c = malloc(npx * 3 * sizeof(float)))) {
                rc = mf_fail(MF_ENOMEM, "out of memory for the denoiser of a %dx%d view", w, h);
                goto done;
            }
            if ((rc = mf_bilateral_forward(&r->dn, out_c.diffuse, 3, dmod_c))) goto done;
            dmod = dmod_c;
        }
        rc = mf_denoise_combine_backward(&r->dn, dmod, out.albedo, out.orm, drgb, dd, ds, gd, gs, galb, gorm);
        if (rc)
            goto done;
        adj.drgb = NULL, adj.ddiffuse = gd, adj.dspecular = gs;
        t0 = mf_now();
        rc = mf_diff_aov_backward(&s, &v->cam, &fo, galb, gorm, &g); /* seed A: the forward's hits */
        r->t_adjoint += mf_now() - t0;
        if (rc) goto done;
    }
    t0 = mf_now();
    rc = mf_diff_backward(&s, &v->cam, &bo, &adj, &g);
    r->t_adjoint += mf_now() - t0;
done:
    free(dz), free(dn), free(gbuf), free(dmod_c);
    mf_render_out_free(&out_c);
    mf_render_out_free(&out);
    free(bg), free(cp), free(cr), free(ra), free(drgb), free(dd), free(ds), free(rrgb);
    return rc;
}

static int write_textures(const MfRecon *r, const char *dir) {
    char p[MF_PATH_MAX];
    int T = r->o.tex_res, rc = mf_mkdirs(dir);
    if (rc) return rc;
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r);
    MfImage envn = block_image(&r->blocks[MF_BLOCK_ENV], r->o.env_w, r->o.env_h), env = {0};
    (void)T;
    if ((rc = mf_path_join(p, sizeof p, dir, "albedo.png")) || (rc = mf_image_write(p, &kd, MF_ENC_SRGB, 8))) return rc;
    if ((rc = mf_path_join(p, sizeof p, dir, "orm.png")) || (rc = mf_image_write(p, &orm, MF_ENC_LINEAR, 8))) return rc;
    /* the env in the views' units (the loop's are divided by the exposure) */
    if ((rc = mf_image_alloc(&env, envn.w, envn.h, 3))) return rc;
    for (size_t i = 0; i < (size_t)envn.w * envn.h * 3; ++i) env.data[i] = envn.data[i] * r->exposure;
    if (!(rc = mf_path_join(p, sizeof p, dir, "env.exr"))) rc = mf_image_write(p, &env, MF_ENC_LINEAR, 32);
    mf_image_free(&env);
    if (rc) return rc;
    if (r->o.normal_map) {
        MfImage nm = mf_recon_normal_image(r);
        if ((rc = mf_path_join(p, sizeof p, dir, "normal.png")) || (rc = mf_image_write(p, &nm, MF_ENC_LINEAR, 8))) return rc;
    }
    return MF_OK;
}

int mf_recon_write_result(const MfRecon *r, const char *dir) {
    char p[MF_PATH_MAX], a[MF_PATH_MAX], o[MF_PATH_MAX], n[MF_PATH_MAX];
    int rc = write_textures(r, dir);
    if (rc) return rc;
    if ((rc = mf_path_join(p, sizeof p, dir, "mesh.obj")) || (rc = mf_obj_write(p, r->mesh, "albedo.png"))) return rc;
    if ((rc = mf_path_join(p, sizeof p, dir, "scene.glb")) || (rc = mf_path_join(a, sizeof a, dir, "albedo.png")) ||
        (rc = mf_path_join(o, sizeof o, dir, "orm.png")))
        return rc;
    MfGltfMaterial gm = mf_gltf_material_default();
    gm.albedo_png = a;
    gm.orm_png = o;
    if (r->o.normal_map) {
        if ((rc = mf_path_join(n, sizeof n, dir, "normal.png"))) return rc;
        gm.normal_png = n;
    }
    return mf_gltf_write_glb(p, r->mesh, &gm);
}

/* Goes back to the last good state and cuts the learning rate, or stops after max_recoveries. */
static int recover(MfRecon *r, int it, const char *why, const char *ckpt) {
    if (r->nrec_total >= r->o.max_recoveries) {
        /* stopping: the in-memory state goes back to the last good one too (for callers that
         * inspect or write it); no file is written from here */
        mf_param_snapshot_restore(&r->good, r->blocks, r->nblocks, &r->adam);
        if (mf_file_exists(ckpt))
            return mf_fail(MF_ENAN, "iteration %d: %s; stopping after %d recoveries (learning rate x%g); the last good checkpoint is %s",
                           it, why, r->nrec_total, r->lr_scale, ckpt);
        return mf_fail(MF_ENAN, "iteration %d: %s; stopping after %d recoveries (learning rate x%g); no checkpoint was written yet",
                       it, why, r->nrec_total, r->lr_scale);
    }
    mf_param_snapshot_restore(&r->good, r->blocks, r->nblocks, &r->adam);
    mf_param_project(&r->blocks[MF_BLOCK_ORM]); /* a state from before metal_auto froze metallic at 0 */
    r->lr_scale *= MF_RECON_RECOVERY_LR;
    r->guard.streak = 0;
    r->nrec_total++;
    if (r->nrec < (int)(sizeof r->rec / sizeof r->rec[0])) {
        MfReconRecovery *e = &r->rec[r->nrec];
        e->iter = it;
        snprintf(e->reason, sizeof e->reason, "%s", why);
        e->lr_scale = r->lr_scale;
    }
    r->nrec++;
    mf_log_warn("recon: iteration %d: %s; restored the state of the lowest loss (%.4g) and cut the learning rate to x%g "
                "(recovery %d of at most %d)",
                it, why, r->guard.loss_min, r->lr_scale, r->nrec_total, r->o.max_recoveries);
    return MF_OK;
}

/* ---- budgets from the data (mf_budget.h) ---- */

/* Mean over the held-out views of the PSNR (sRGB, inside the union of the rendered and the
 * reference masks, after a per-channel scale) of a forward render of the current state; each
 * view's seed is fixed, so successive evaluations differ by the parameters only. */
static int holdout_psnr(MfRecon *r, double *psnr) {
    int rc = sync_env(r), n = 0;
    double sum = 0.0;
    MfImage kd = mf_recon_kd_image(r), orm = mf_recon_orm_image(r), nm = mf_recon_normal_image(r);
    MfDiffScene s = {.rt = r->rt, .kd = &kd, .orm = &orm, .env = &r->env, .normal = r->o.normal_map ? &nm : NULL,
                     .tangent = r->tan};
    for (int vi = 0; vi < r->nviews && !rc; ++vi) {
        if (!mf_budget_is_holdout(vi, r->o.holdout_every)) continue;
        const MfReconView *v = &r->views[vi];
        MfDiffOpts fo = {.spp_sqrt = r->o.spp_sqrt, .pixel_samples = r->o.es_pixel_samples,
                         .seed = mf_hash64(mf_hash64(r->o.seed, 0x686f6c64ULL), (uint64_t)vi)};
        MfRenderOut out;
        if ((rc = mf_render_out_alloc(&out, v->cam.w, v->cam.h))) break;
        double t0 = mf_now();
        rc = mf_diff_forward(&s, &v->cam, &fo, &out);
        r->t_forward += mf_now() - t0;
        /* per-channel scale of the render: ratio of the means inside the reference's mask (as mf
         * eval aligns relit views), so a drift of the albedo/light scale, which relighting
         * scores do not see either, is not taken for a loss of quality */
        size_t npx = (size_t)v->cam.w * v->cam.h;
        double sr[3] = {0, 0, 0}, sf[3] = {0, 0, 0};
        for (size_t p = 0; p < npx; ++p)
            if (v->ref.data[4 * p + 3] > 0.5f)
                for (int c = 0; c < 3; ++c) sr[c] += out.rgb[3 * p + c], sf[c] += v->ref.data[4 * p + c];
        float k[3];
        for (int c = 0; c < 3; ++c) k[c] = sr[c] > 0.0 ? (float)(sf[c] / sr[c]) : 1.0f;
        double se = 0.0;
        size_t cnt = 0;
        for (size_t p = 0; !rc && p < npx; ++p) {
            if (!(out.alpha[p] > 0.0f) && !(v->ref.data[4 * p + 3] > 0.0f)) continue;
            for (int c = 0; c < 3; ++c) {
                float a = mf_clampf(mf_linear_to_srgb(k[c] * out.rgb[3 * p + c]), 0.0f, 1.0f);
                float b = mf_clampf(mf_linear_to_srgb(v->ref.data[4 * p + c]), 0.0f, 1.0f);
                se += (double)(a - b) * (a - b);
            }
            cnt += 3;
        }
        mf_render_out_free(&out);
        if (!rc && cnt) sum += 10.0 * log10(1.0 / fmax(se / (double)cnt, 1e-10)), n++;
    }
    *psnr = n ? sum / n : 0.0;
    return rc;
}

/* spp_grow: adds the image loss of iteration r->it; at the end of a window, raises spp_now when
 * the window's mean fell by less than spp_grow_tol of the previous window's. */
static void spp_grow_observe(MfRecon *r, double loss) {
    r->grow_sum += loss, r->grow_n++;
    if (r->it % r->o.spp_grow_window != 0) return;
    double m = r->grow_sum / (r->grow_n > 0 ? r->grow_n : 1);
    if (r->grow_prev > 0.0 && r->grow_prev - m < r->o.spp_grow_tol * r->grow_prev && r->spp_now < r->o.spp_grow_max) {
        r->spp_now++;
        if (r->ngrew < 16) r->grew_at[r->ngrew++] = r->it;
        mf_log_info("recon: spp_grow at iteration %d: the image loss's mean over the last %d iterations fell %.2f%% "
                    "(< %g%%): --spp %d", r->it, r->grow_n, 100.0 * (r->grow_prev - m) / r->grow_prev,
                    100.0 * r->o.spp_grow_tol, r->spp_now);
    }
    r->grow_prev = m, r->grow_sum = 0.0, r->grow_n = 0;
}

/* The texels a training view (not a held-out one) sees: *vis (T, T) malloc'd, *nvis their count. */
static int visible_texels(const MfRecon *r, unsigned char **vis, size_t *nvis) {
    int T = r->o.tex_res;
    unsigned char *skip = calloc((size_t)r->nviews, 1);
    *vis = malloc((size_t)T * T);
    if (!*vis || !skip) {
        free(*vis), free(skip), *vis = NULL;
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    for (int i = 0; i < r->nviews; ++i) skip[i] = (unsigned char)mf_recon_is_holdout(r, i);
    *nvis = mf_budget_visible_texels(r->rt, r->views, r->nviews, skip, T, *vis);
    free(skip);
    return MF_OK;
}

/* env_res_auto: the env width for the visible texels' 10th-percentile roughness (mf_budget_env_width). */
static int env_res_test(MfRecon *r) {
    unsigned char *vis;
    size_t nvis;
    int rc = visible_texels(r, &vis, &nvis), W = r->o.env_w, H = r->o.env_h;
    if (rc) return rc;
    int w = mf_budget_env_width(r->blocks[MF_BLOCK_ORM].p, vis, (size_t)r->o.tex_res * r->o.tex_res, 0.1, W, H,
                                r->o.env_res_min, &r->env_res_rough);
    free(vis);
    if (w < 0) return mf_fail(MF_ENOMEM, "out of memory");
    int h = H / (W / w);
    r->env_res_w = w;
    mf_log_info("recon: env_res_auto at iteration %d: roughness %.3f (10th percentile of %zu visible texels), lobe %.1f deg: "
                "env %dx%d%s", r->it, r->env_res_rough, nvis, mf_budget_lobe_fwhm((float)r->env_res_rough) * 180.0 / M_PI,
                w, h, w == W ? " (kept)" : "");
    return w == W ? MF_OK : env_resize(r, w, h);
}

/* metal_auto: the fraction of the training views' visible texels with metallic > 0.5; below
 * metal_frac the channel is set to 0 and frozen (its Adam moments zeroed). */
static int metal_test(MfRecon *r) {
    unsigned char *vis;
    size_t nvis;
    int rc = visible_texels(r, &vis, &nvis);
    if (rc) return rc;
    MfParamBlock *orm = &r->blocks[MF_BLOCK_ORM];
    r->metal_fraction = mf_budget_metal_fraction(orm->p, vis, (size_t)r->o.tex_res * r->o.tex_res, 0.5f);
    r->metal_state = r->metal_fraction < r->o.metal_frac;
    if (r->metal_state) {
        for (size_t i = 2; i < orm->n; i += 3) orm->p[i] = orm->m[i] = orm->v[i] = 0.0f;
        mf_param_set_bounds(orm, 2, 0.0f, 0.0f);
    }
    mf_log_info("recon: metal_auto at iteration %d: %.4f of %zu visible texels have metallic > 0.5 (threshold %g): %s",
                r->it, r->metal_fraction, nvis, r->o.metal_frac, r->metal_state ? "metallic fixed at 0" : "metallic kept");
    free(vis);
    return MF_OK;
}

/* Opens a per-iteration CSV log for writing: fresh (header) when the run starts at iteration 0,
 * else keeps the rows up to the resumed iteration; each kept row is passed to keep (may be NULL). */
static FILE *open_iter_log(const char *path, const char *header, int it0, void (*keep)(void *, const char *), void *ctx) {
    if (it0 == 0) {
        FILE *f = fopen(path, "w");
        if (f) fprintf(f, "%s\n", header);
        if (!f) mf_fail(MF_EIO, "%s: cannot write", path);
        return f;
    }
    char *old = NULL;
    size_t len = 0;
    if (mf_read_file(path, &old, &len) != MF_OK) {
        mf_fail(MF_EIO, "%s: resume needs the run's %s", path, strrchr(path, '/') ? strrchr(path, '/') + 1 : path);
        return NULL;
    }
    FILE *f = fopen(path, "w");
    if (f) {
        char *save = NULL;
        for (char *ln = strtok_r(old, "\n", &save); ln; ln = strtok_r(NULL, "\n", &save)) {
            int it;
            if (sscanf(ln, "%d,", &it) == 1) {
                if (it > it0) break;
                if (keep) keep(ctx, ln);
            }
            fprintf(f, "%s\n", ln);
        }
    } else {
        mf_fail(MF_EIO, "%s: cannot write", path);
    }
    free(old);
    return f;
}

/* Replays a kept holdout.csv row through the patience rule: the resumed state is the one the
 * uninterrupted run had. */
static void replay_holdout(void *ctx, const char *ln) {
    MfRecon *r = ctx;
    int it;
    double psnr;
    if (sscanf(ln, "%d,%lf", &it, &psnr) == 2) mf_early_stop_observe(r->es, it, psnr, r->o.es_patience, r->o.es_min_delta);
}

int mf_recon_run(MfRecon *r, const MfReconHook *hook, const char *out_dir) {
    char logp[MF_PATH_MAX], ckpt[MF_PATH_MAX], holdp[MF_PATH_MAX];
    int rc = mf_mkdirs(out_dir);
    if (rc || (rc = mf_path_join(logp, sizeof logp, out_dir, "log.csv")) ||
        (rc = mf_path_join(ckpt, sizeof ckpt, out_dir, "checkpoint.mfck")) ||
        (rc = mf_path_join(holdp, sizeof holdp, out_dir, "holdout.csv")))
        return rc;
    /* log.csv (and holdout.csv with early_stop): rewritten from scratch on a fresh run; on
     * resume, rows past the checkpoint's iteration are dropped so the logs match an
     * uninterrupted run, and the held-out rows kept rebuild the patience state. */
    FILE *log = open_iter_log(logp, "iter,wall_s,loss_total,loss_image,loss_reg,loss_sds,train_psnr", r->it, NULL, NULL);
    if (!log) return MF_EIO;
    FILE *hlog = NULL;
    if (r->es) {
        mf_early_stop_init(r->es);
        if (!(hlog = open_iter_log(holdp, "iter,wall_s,holdout_psnr", r->it, replay_holdout, r))) {
            fclose(log);
            return MF_EIO;
        }
    }
    /* the first good state is the starting one (fresh or resumed) */
    if ((rc = mf_param_snapshot_save(&r->good, r->blocks, r->nblocks, &r->adam))) {
        fclose(log);
        if (hlog) fclose(hlog);
        return rc;
    }
    MfProgress prog;
    mf_progress_begin(&prog, "recon", (size_t)(r->o.iters - r->it));
    double t0 = mf_now();
    int nt = r->ntrain, nb = r->o.batch < nt ? r->o.batch : nt;
    int *perm = malloc((size_t)nt * sizeof(int));
    if (!perm) {
        fclose(log);
        if (hlog) fclose(hlog);
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    while (r->it < r->o.iters && !(r->es && r->es->stop_iter) && rc == MF_OK) {
        int it = r->it;
        /* views of this iteration: epoch-wise permutation of the training views (all views
         * unless early_stop holds some out) derived from (seed, epoch) */
        int per_epoch = (nt + nb - 1) / nb, epoch = it / per_epoch, slot = it % per_epoch;
        MfRng prng;
        mf_rng_seed(&prng, mf_hash64(r->o.seed, 0x7065726dULL), (uint64_t)epoch);
        for (int i = 0; i < nt; ++i) perm[i] = r->train[i];
        for (int i = nt - 1; i > 0; --i) {
            int j = (int)mf_rng_below(&prng, (uint32_t)(i + 1)), t = perm[i];
            perm[i] = perm[j], perm[j] = t;
        }
        int batch[64], n = 0;
        for (int k = 0; k < nb && n < 64; ++k) batch[n++] = perm[(slot * nb + k) % nt];
        MfStageClock ck = mf_stage_clock(); /* each stage adds its wall and CPU seconds to r->times */
        for (int b = 0; b < r->nblocks; ++b) mf_param_zero_grad(&r->blocks[b]);
        if ((rc = sync_env(r))) break;
        IterStats st = {0};
        for (int k = 0; k < n && !rc; ++k)
            rc = view_step(r, batch[k], mf_hash64(mf_hash64(r->o.seed, (uint64_t)it), (uint64_t)batch[k]), 1.0f / n, &st);
        mf_stage_lap(&r->times.views, &ck);
        if (rc) break;
        MfParamBlock *kd = &r->blocks[MF_BLOCK_KD], *orm = &r->blocks[MF_BLOCK_ORM];
        int T = r->o.tex_res;
        if (r->o.w_kd_smooth > 0.0f) {
            st.reg += r->o.w_kd_smooth * mf_reg_smooth_fwd(kd->p, T, T, 3, 0, 3, r->uv_mask);
            mf_reg_smooth_bwd(kd->p, T, T, 3, 0, 3, r->uv_mask, r->o.w_kd_smooth, kd->g);
        }
        if (r->o.w_orm_smooth > 0.0f) {
            st.reg += r->o.w_orm_smooth * mf_reg_smooth_fwd(orm->p, T, T, 3, 1, 2, r->uv_mask);
            mf_reg_smooth_bwd(orm->p, T, T, 3, 1, 2, r->uv_mask, r->o.w_orm_smooth, orm->g);
        }
        if (r->o.w_env_tv > 0.0f) {
            MfParamBlock *env = &r->blocks[MF_BLOCK_ENV];
            st.reg += r->o.w_env_tv * mf_reg_env_logtv_fwd(env->p, r->o.env_w, r->o.env_h);
            mf_reg_env_logtv_bwd(env->p, r->o.env_w, r->o.env_h, r->o.w_env_tv, env->g);
        }
        if (r->env_cover && r->o.w_env_unseen > 0.0f) {
            MfParamBlock *env = &r->blocks[MF_BLOCK_ENV];
            st.reg += r->o.w_env_unseen * mf_reg_env_unseen_fwd(env->p, r->o.env_w, r->o.env_h, r->env_cover);
            mf_reg_env_unseen_bwd(env->p, r->o.env_w, r->o.env_h, r->env_cover, r->o.w_env_unseen, env->g);
        }
        if (r->o.normal_map) {
            MfParamBlock *nb = &r->blocks[MF_BLOCK_NORMAL];
            if (r->o.w_nrm_smooth > 0.0f) {
                st.reg += r->o.w_nrm_smooth * mf_reg_smooth_fwd(nb->p, T, T, 3, 0, 3, r->uv_mask);
                mf_reg_smooth_bwd(nb->p, T, T, 3, 0, 3, r->uv_mask, r->o.w_nrm_smooth, nb->g);
            }
            if (r->o.w_nrm_perturb > 0.0f) {
                st.reg += r->o.w_nrm_perturb * mf_reg_nmap_flat_fwd(nb->p, T, T, r->uv_mask);
                mf_reg_nmap_flat_bwd(nb->p, T, T, r->uv_mask, r->o.w_nrm_perturb, nb->g);
            }
        }
        mf_stage_lap(&r->times.reg, &ck);
        if (hook && hook->fn) {
            rc = hook->fn(hook->ctx, r, it, batch, n, &st.sds);
            mf_stage_lap(&r->times.hook, &ck);
            if (rc) break;
        }
        /* the guard: the loss of the current state, then the step's gradients, values, moments */
        double loss = st.image + st.reg + st.sds;
        char why[192] = "", bad[96];
        MfDivState dst = mf_divguard_observe(&r->guard, loss);
        if (dst == MF_DIV_NEW_MIN && (rc = mf_param_snapshot_save(&r->good, r->blocks, r->nblocks, &r->adam))) break;
        if (dst == MF_DIV_NONFINITE) {
            snprintf(why, sizeof why, "the loss is %g", loss);
        } else if (dst == MF_DIV_DIVERGED) {
            snprintf(why, sizeof why, "loss %.4g above %g x its running minimum %.4g for %d iterations", loss,
                     r->guard.factor, r->guard.loss_min, r->guard.patience);
        } else {
            int arc = mf_adam_step(&r->adam, r->blocks, r->nblocks, r->lr_scale * mf_lr_schedule(r->o.lr, it));
            if (arc == MF_ENAN) snprintf(why, sizeof why, "%s", mf_error());
            else if (arc) rc = arc;
            else if (mf_params_find_nonfinite(r->blocks, r->nblocks, bad, sizeof bad))
                snprintf(why, sizeof why, "after the Adam step %s (a gradient beyond ~1.8e19 overflows g^2)", bad);
        }
        if (!rc && !why[0] && r->o.vertex_lr > 0) rc = verts_step(r, it);
        if (rc || (why[0] && (rc = recover(r, it, why, ckpt)))) break;
        r->it = it + 1;
        mf_stage_lap(&r->times.step, &ck);
        double wall = r->wall_offset + ck.wall - t0;
        fprintf(log, "%d,%.3f,%.6g,%.6g,%.6g,%.6g,%.4f\n", r->it, wall, st.image + st.reg + st.sds, st.image, st.reg,
                st.sds, st.psnr);
        fflush(log);
        mf_stage_lap(&r->times.io, &ck);
        if (r->o.metal_auto && r->metal_state < 0 && r->it >= r->o.metal_warmup && (rc = metal_test(r))) break;
        if (r->o.env_res_auto && r->env_res_w < 0 && r->it >= r->o.env_res_warmup && (rc = env_res_test(r))) break;
        if (r->o.spp_grow) spp_grow_observe(r, st.image);
        if (r->es && r->it % r->o.es_every == 0) {
            double hp;
            if ((rc = holdout_psnr(r, &hp))) break;
            fprintf(hlog, "%d,%.3f,%.17g\n", r->it, r->wall_offset + mf_now() - t0, hp);
            fflush(hlog);
            if (mf_early_stop_observe(r->es, r->it, hp, r->o.es_patience, r->o.es_min_delta))
                mf_log_info("recon: early stop at iteration %d: held-out PSNR %.3f dB, best %.3f dB at iteration %d "
                            "(%d evaluations without an improvement above %g dB)", r->it, hp, r->es->best,
                            r->es->best_iter, r->o.es_patience, r->o.es_min_delta);
        }
        mf_stage_lap(&r->times.checks, &ck);
        if (r->o.snapshot_every > 0 && r->it % r->o.snapshot_every == 0) {
            char d[MF_PATH_MAX], name[32];
            snprintf(name, sizeof name, "snapshots/iter_%05d", r->it);
            if ((rc = mf_path_join(d, sizeof d, out_dir, name)) || (rc = write_textures(r, d))) break;
        }
        if ((r->o.checkpoint_every > 0 && r->it % r->o.checkpoint_every == 0) || r->it == r->o.iters ||
            (r->es && r->es->stop_iter))
            if ((rc = save_checkpoint(r, ckpt, wall))) break;
        mf_stage_lap(&r->times.io, &ck);
        mf_progress_add(&prog, 1);
    }
    mf_progress_end(&prog);
    free(perm);
    fclose(log);
    if (hlog) fclose(hlog);
    if (rc) return rc;
    MfStageClock ck = mf_stage_clock();
    rc = mf_recon_write_result(r, out_dir);
    mf_stage_lap(&r->times.output, &ck);
    return rc;
}
