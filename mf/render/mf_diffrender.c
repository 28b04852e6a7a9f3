/* mf_diffrender: the differentiable renderer's API over the shared estimator (mf_estimator.h):
 * argument checks, gradient lanes and their reduction in lane order. */
#include "render/mf_diffrender.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "render/mf_antialias.h"
#include "render/mf_estimator.h"
#include "scene/mf_texture.h"

/* The scene as the estimator's one material (evaluated and sampling copies). */
typedef struct {
    MfTexMaterial m, m_s;
    MfEstimator e;
} Est;

static void estimator_of(const MfDiffScene *s, const MfDiffOpts *o, const float *tan, Est *r) {
    r->m = (MfTexMaterial){.kd = s->kd, .orm = s->orm, .normal = s->normal, .vkd = s->vkd, .vorm = s->vorm};
    r->m_s = (MfTexMaterial){.kd = s->kd_s ? s->kd_s : s->kd, .orm = s->orm_s ? s->orm_s : s->orm,
                             .normal = s->normal_s ? s->normal_s : s->normal, .vkd = s->vkd_s ? s->vkd_s : s->vkd,
                             .vorm = s->vorm_s ? s->vorm_s : s->vorm};
    r->e = (MfEstimator){.rt = s->rt, .rt_s = s->rt_s, .mesh = mf_rtscene_mesh(s->rt), .mats = &r->m,
                         .mats_s = &r->m_s, .nmat = 1, .env = s->env, .env_s = s->env_s ? s->env_s : s->env, .tan = tan, .spp_sqrt = o->spp_sqrt,
                         .pixel_samples = o->pixel_samples, .lobes = MF_LOBE_ALL, .seed = o->seed,
                         .centre = o->antialias != 0};
}

/* Gradient lanes: a backward sums image row y into lane y % MF_DIFF_LANES (a lane's rows in
 * order, a lane on one thread), then adds the lanes in order, so the gradients are the same bits
 * at every OpenMP thread count (more threads than lanes idle in the backward). */
#define MF_DIFF_LANES 8

static int check(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o) {
    if (!s || !s->rt || (!s->kd && !s->vkd) || (!s->orm && !s->vorm) || !s->env) return mf_fail(MF_EARG, "diffrender: incomplete scene");
    if ((s->kd && s->kd->c < 3) || (s->orm && s->orm->c < 3)) return mf_fail(MF_EARG, "diffrender: kd and ORM textures need 3 channels");
    const MfVoltex *vol[4] = {s->vkd, s->vorm, s->vkd_s, s->vorm_s};
    for (int k = 0; k < 4; ++k)
        if (vol[k] && vol[k]->c != 3) return mf_fail(MF_EARG, "diffrender: volume textures need 3 channels, not %d", vol[k]->c);
    if (s->normal) {
        if (s->normal->c != 3) return mf_fail(MF_EARG, "diffrender: the normal map needs 3 channels");
        if (s->normal_s && s->normal_s->c != 3) return mf_fail(MF_EARG, "diffrender: the sampling normal map needs 3 channels");
        if (!mf_rtscene_mesh(s->rt)->uv) return mf_fail(MF_EARG, "diffrender: a normal map needs a mesh with UVs");
    }
    Est est;
    estimator_of(s, o, NULL, &est);
    return mf_est_check(&est.e, cam, "diffrender");
}

/* check, then the estimator with its tangents (*owned: computed here, freed by the caller). */
static int setup(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, Est *est, float **owned) {
    *owned = NULL;
    int rc = check(s, cam, o);
    if (rc) return rc;
    const float *tan;
    MfTexMaterial m = {.normal = s->normal};
    if ((rc = mf_est_tangents(mf_rtscene_mesh(s->rt), &m, 1, s->tangent, &tan, owned))) return rc;
    estimator_of(s, o, tan, est);
    return MF_OK;
}

int mf_diff_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, MfRenderOut *out) {
    Est est;
    float *tan_owned;
    int rc = setup(s, cam, o, &est, &tan_owned);
    if (rc) return rc;
    if (out->w != cam->w || out->h != cam->h) {
        free(tan_owned);
        return mf_fail(MF_EARG, "diffrender: output size does not match the camera");
    }
    mf_est_render_rows(&est.e, cam, 0, cam->h, out, NULL, NULL);
    free(tan_owned);
    if (!o->antialias) return MF_OK;
    MfAa *aa;
    if ((rc = mf_aa_new(s->rt, cam, &aa))) return rc;
    size_t n = (size_t)cam->w * cam->h;
    float *tmp = malloc(n * 3 * sizeof(float));
    if (!tmp) {
        mf_aa_free(aa);
        return mf_fail(MF_ENOMEM, "diffrender: out of memory for antialiasing");
    }
    float *img[4] = {out->rgb, out->diffuse, out->specular, out->alpha};
    for (int k = 0; k < 4; ++k) {
        int c = k < 3 ? 3 : 1;
        memcpy(tmp, img[k], n * c * sizeof(float));
        mf_aa_forward(aa, tmp, c, img[k]);
    }
    free(tmp);
    mf_aa_free(aa);
    return MF_OK;
}

/* Antialiasing's adjoint: the pre-antialiasing image (rendered with o's seed), then adj's image
 * adjoints mapped through the blend into aa_adj (buffers in *bufs, free it) and the silhouette
 * edges' vertex gradients into dpos (may be NULL). */
static int antialias_backward(const MfDiffScene *s, const MfEstimator *e, const MfCamera *cam, const MfDiffAdjoint *adj,
                              MfDiffAdjoint *aa_adj, float **bufs, float *dpos) {
    size_t n = (size_t)cam->w * cam->h;
    MfRenderOut pre;
    MfAa *aa;
    *bufs = calloc(n * 9 + 1, sizeof(float));
    if (!*bufs) return mf_fail(MF_ENOMEM, "diffrender: out of memory for antialiasing adjoints");
    int rc = mf_render_out_alloc(&pre, cam->w, cam->h);
    if (rc) return rc;
    mf_est_render_rows(e, cam, 0, cam->h, &pre, NULL, NULL);
    if ((rc = mf_aa_new(s->rt, cam, &aa))) {
        mf_render_out_free(&pre);
        return rc;
    }
    const float *in[3] = {pre.rgb, pre.diffuse, pre.specular}, *d[3] = {adj->drgb, adj->ddiffuse, adj->dspecular};
    const float *o[3] = {NULL, NULL, NULL};
    for (int k = 0; k < 3; ++k)
        if (d[k]) {
            mf_aa_backward(aa, in[k], 3, d[k], *bufs + k * n * 3, dpos);
            o[k] = *bufs + k * n * 3;
        }
    if (adj->dalpha && dpos) mf_aa_backward(aa, pre.alpha, 1, adj->dalpha, NULL, dpos);
    *aa_adj = (MfDiffAdjoint){o[0], o[1], o[2], NULL};
    mf_aa_free(aa);
    mf_render_out_free(&pre);
    return MF_OK;
}

int mf_diff_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const MfDiffAdjoint *adj,
                     MfDiffGrads *g) {
    Est est;
    float *tan_owned;
    int rc = setup(s, cam, o, &est, &tan_owned);
    if (rc) return rc;
    size_t nkd = g->dkd && s->kd && !s->vkd ? (size_t)s->kd->w * s->kd->h * 3 : 0;
    size_t norm = g->dorm && s->orm && !s->vorm ? (size_t)s->orm->w * s->orm->h * 3 : 0;
    size_t nenv = g->denv ? (size_t)s->env->img.w * s->env->img.h * 3 : 0;
    size_t nvkd = g->dvkd && s->vkd ? mf_voltex_size(s->vkd) : 0, nvorm = g->dvorm && s->vorm ? mf_voltex_size(s->vorm) : 0;
    size_t nnm = (g->dnormal && s->normal) ? (size_t)s->normal->w * s->normal->h * 3 : 0;
    const MfMesh *mesh = mf_rtscene_mesh(s->rt);
    size_t npos = g->dpos ? (size_t)mesh->nv * 3 : 0; /* dpos, then the vertex normals' adjoint */
    if (npos && s->normal) {
        free(tan_owned);
        return mf_fail(MF_EARG, "diffrender: vertex-position gradients with a normal map are not supported");
    }
    float *aa_bufs = NULL;
    MfDiffAdjoint aa_adj;
    if (o->antialias) {
        if ((rc = antialias_backward(s, &est.e, cam, adj, &aa_adj, &aa_bufs, g->dpos))) {
            free(aa_bufs);
            free(tan_owned);
            return rc;
        }
        adj = &aa_adj;
    }
    size_t per = nkd + norm + nenv + nnm + nvkd + nvorm + 2 * npos; /* a lane: kd, ORM, env, normal map, volumes, dpos, dnrm */
    float *buf = calloc((size_t)MF_DIFF_LANES * per + 1, sizeof(float)); /* (lanes, per) */
    if (!buf) {
        free(tan_owned);
        free(aa_bufs);
        return mf_fail(MF_ENOMEM, "diffrender: out of memory for %d gradient lanes of %zu floats", MF_DIFF_LANES, per);
    }
#pragma omp parallel for schedule(static, 1)
    for (int l = 0; l < MF_DIFF_LANES; ++l) {
        float *b = buf + (size_t)l * per;
        float *vb = b + nkd + norm + nenv + nnm;
        MfEstAdjoint a = {.drgb = adj->drgb, .ddiffuse = adj->ddiffuse, .dspecular = adj->dspecular, .dkd = nkd ? b : NULL,
                          .dorm = norm ? b + nkd : NULL, .denv = nenv ? b + nkd + norm : NULL,
                          .dnormal = nnm ? b + nkd + norm + nenv : NULL, .dvkd = nvkd ? vb : NULL, .dvorm = nvorm ? vb + nvkd : NULL,
                          .dpos = npos ? b + per - 2 * npos : NULL, .dnrm = npos ? b + per - npos : NULL};
        for (int y = l; y < cam->h; y += MF_DIFF_LANES)
            for (int x = 0; x < cam->w; ++x) mf_est_pixel(&est.e, cam, x, y, NULL, &a, NULL);
    }
    for (int t = 0; t < MF_DIFF_LANES; ++t) {
        const float *b = buf + (size_t)t * per;
        for (size_t i = 0; i < nkd; ++i) g->dkd[i] += b[i];
        for (size_t i = 0; i < norm; ++i) g->dorm[i] += b[nkd + i];
        for (size_t i = 0; i < nenv; ++i) g->denv[i] += b[nkd + norm + i];
        for (size_t i = 0; i < nnm; ++i) g->dnormal[i] += b[nkd + norm + nenv + i];
        for (size_t i = 0; i < nvkd; ++i) g->dvkd[i] += b[nkd + norm + nenv + nnm + i];
        for (size_t i = 0; i < nvorm; ++i) g->dvorm[i] += b[nkd + norm + nenv + nnm + nvkd + i];
        if (t > 0)
            for (size_t i = 0; i < 2 * npos; ++i) buf[per - 2 * npos + i] += b[per - 2 * npos + i];
    }
    if (npos) { /* lane 0's buffer now holds the sums: positions, then normals */
        float *dp = buf + per - 2 * npos;
        if (g->dnrm)
            for (size_t i = 0; i < npos; ++i) g->dnrm[i] += dp[npos + i];
        else if (mesh->nrm && (rc = mf_mesh_normals_backward(mesh, dp + npos, dp))) {
            free(buf);
            free(tan_owned);
            free(aa_bufs);
            return rc;
        }
        for (size_t i = 0; i < npos; ++i) g->dpos[i] += dp[i];
    }
    free(buf);
    free(tan_owned);
    free(aa_bufs);
    return MF_OK;
}

/* ---- material AOVs ---- */

/* check, and the AOVs' UV textures */
static int check_aov(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o) {
    int rc = check(s, cam, o);
    if (!rc && (!s->kd || !s->orm || s->vkd || s->vorm)) rc = mf_fail(MF_EARG, "diffrender: material AOVs need UV textures, not volume textures");
    return rc;
}

int mf_diff_aov_forward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, float *albedo, float *orm,
                        float *alpha) {
    int rc = check_aov(s, cam, o);
    if (rc) return rc;
    Est est;
    estimator_of(s, o, NULL, &est);
    MfHit *hits_all = malloc((size_t)omp_get_max_threads() * o->pixel_samples * sizeof(MfHit));
    if (!hits_all) return mf_fail(MF_ENOMEM, "diffrender: out of memory for primary hits");
#pragma omp parallel for schedule(dynamic, 1)
    for (int y = 0; y < cam->h; ++y) {
        MfHit *hits = hits_all + (size_t)omp_get_thread_num() * o->pixel_samples;
        for (int x = 0; x < cam->w; ++x) {
            size_t i = (size_t)y * cam->w + x;
            int n = mf_est_primary_hits(&est.e, cam, x, y, hits);
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
    free(hits_all);
    return MF_OK;
}

int mf_diff_aov_backward(const MfDiffScene *s, const MfCamera *cam, const MfDiffOpts *o, const float *dalbedo,
                         const float *dorm, MfDiffGrads *g) {
    int rc = check_aov(s, cam, o);
    if (rc) return rc;
    Est est;
    estimator_of(s, o, NULL, &est);
    size_t nkd = (g->dkd && dalbedo) ? (size_t)s->kd->w * s->kd->h * 3 : 0;
    size_t norm = (g->dorm && dorm) ? (size_t)s->orm->w * s->orm->h * 3 : 0;
    size_t per = nkd + norm;
    float *buf = calloc((size_t)MF_DIFF_LANES * per + 1, sizeof(float)); /* (lanes, per) */
    MfHit *hits_all = malloc((size_t)MF_DIFF_LANES * o->pixel_samples * sizeof(MfHit));
    if (!buf || !hits_all) {
        free(buf);
        free(hits_all);
        return mf_fail(MF_ENOMEM, "diffrender: out of memory for AOV gradient lanes");
    }
#pragma omp parallel for schedule(static, 1)
    for (int l = 0; l < MF_DIFF_LANES; ++l) {
        float *b = buf + (size_t)l * per;
        MfHit *hits = hits_all + (size_t)l * o->pixel_samples;
        for (int y = l; y < cam->h; y += MF_DIFF_LANES)
            for (int x = 0; x < cam->w; ++x) {
                size_t i = (size_t)y * cam->w + x;
                int n = mf_est_primary_hits(&est.e, cam, x, y, hits);
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
    for (int t = 0; t < MF_DIFF_LANES; ++t) {
        const float *b = buf + (size_t)t * per;
        for (size_t i = 0; i < nkd; ++i) g->dkd[i] += b[i];
        for (size_t i = 0; i < norm; ++i) g->dorm[i] += b[nkd + i];
    }
    free(buf);
    free(hits_all);
    return MF_OK;
}
