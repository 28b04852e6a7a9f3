/* T3 of issue 14: vertex-position gradients of the differentiable renderer (MfDiffGrads.dpos,
 * render/mf_hitgrad.h) against central differences of the rendered loss with common random
 * numbers. The sampling copy of the geometry (MfDiffScene.rt_s) stays at the unperturbed mesh,
 * so drawn directions, pdfs and MIS weights are constants, as the adjoint assumes. The scene is
 * a bumped quad that covers the whole image (no silhouette: the loss is smooth in the vertices
 * apart from shadow-ray flips, see the bound's comment) with textured kd/ORM and a random env;
 * the loss is a random linear functional of rgb, diffuse and specular. The same with world-space
 * volume textures in place of the UV ones (DMTet's colour pass), where the hit's position, not its
 * UV, carries the material gradient to the vertices, and the volumes' grids get gradients too. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_diffrender.h"
#include "scene/mf_voltex.h"
#include "mf_test.h"
#include "mf_test_diff.h"
#include "mf_test_geom.h"
#include "mf_test_grad.h"

enum { W = 12, H = 12, N = 9, TW = 8, TH = 8, EW = 16, EH = 8 };

typedef struct {
    MfMesh mesh, mesh0; /* evaluated (perturbed) and sampling copies */
    MfRtScene *rt0;
    MfImage kd, orm;
    MfVoltex vkd, vorm;   /* used in place of kd, orm when vol */
    MfVoltex vkd0, vorm0; /* their sampling copies, kept at the initial values */
    int vol;
    MfEnvMap env;
    MfCamera cam;
    float wr[W * H * 3], wd[W * H * 3], ws[W * H * 3];
} Fix;

/* N x N vertex grid over [-1, 1]^2, z = a Gaussian bump; UV = (x, y) mapped to [0, 1]. */
static int bumped_quad(MfMesh *m) {
    int rc = mf_mesh_alloc(m, N * N, 2 * (N - 1) * (N - 1), 0, 1);
    if (rc) return rc;
    for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
            int v = j * N + i;
            float x = -1.0f + 2.0f * (float)i / (N - 1), y = -1.0f + 2.0f * (float)j / (N - 1);
            m->pos[3 * v] = x;
            m->pos[3 * v + 1] = y;
            m->pos[3 * v + 2] = 0.3f - 0.2f * (x * x + y * y) + 0.05f * x * y;
            m->uv[2 * v] = 0.5f * (x + 1.0f);
            m->uv[2 * v + 1] = 0.5f * (y + 1.0f);
        }
    uint32_t *t = m->tri;
    for (int j = 0; j + 1 < N; ++j)
        for (int i = 0; i + 1 < N; ++i) {
            uint32_t a = j * N + i, b = a + 1, c = a + N, d = c + 1;
            uint32_t q[6] = {a, b, d, a, d, c};
            memcpy(t, q, sizeof q);
            t += 6;
        }
    return mf_mesh_compute_normals(m);
}

static int fix_init(Fix *f) {
    memset(f, 0, sizeof *f);
    MfRng r;
    mf_rng_seed(&r, 23, 0);
    int rc = bumped_quad(&f->mesh);
    if (!rc) rc = bumped_quad(&f->mesh0);
    if (!rc) rc = mf_rtscene_new(&f->mesh0, &f->rt0);
    if (!rc) rc = mf_image_alloc(&f->kd, TW, TH, 3);
    if (!rc) rc = mf_image_alloc(&f->orm, TW, TH, 3);
    MfImage env = {0};
    if (!rc) rc = mf_image_alloc(&env, EW, EH, 3);
    if (rc) return rc;
    random_materials(&r, &f->kd, &f->orm, 0.3f);
    /* volumes over the quad's box, 5^3 vertices, drawn like the textures */
    const float lo[3] = {-1.1f, -1.1f, -0.2f}, hi[3] = {1.1f, 1.1f, 0.5f};
    if ((rc = mf_voltex_init(&f->vkd, 5, 3, lo, hi, NULL)) || (rc = mf_voltex_init(&f->vorm, 5, 3, lo, hi, NULL))) return rc;
    for (int i = 0; i < 125; ++i) {
        for (int c = 0; c < 3; ++c) f->vkd.grid[3 * i + c] = 0.1f + 0.8f * mf_rng_float(&r);
        f->vorm.grid[3 * i] = 1.0f;
        f->vorm.grid[3 * i + 1] = 0.3f + 0.6f * mf_rng_float(&r);
        f->vorm.grid[3 * i + 2] = 0.1f + 0.8f * mf_rng_float(&r);
    }
    if ((rc = mf_voltex_init(&f->vkd0, 5, 3, lo, hi, NULL)) || (rc = mf_voltex_init(&f->vorm0, 5, 3, lo, hi, NULL))) return rc;
    memcpy(f->vkd0.grid, f->vkd.grid, sizeof(float) * 375);
    memcpy(f->vorm0.grid, f->vorm.grid, sizeof(float) * 375);
    /* a sky: radiance above 45 degrees of elevation only (rows 0-1; bilinear lookups reach zero
     * at 34 degrees), so shadow rays near a facet's horizon (whose visibility jumps when a
     * primary hit crosses to the next facet) carry no light */
    for (int i = 0; i < EW * EH * 3; ++i) env.data[i] = i < 2 * EW * 3 ? 0.2f + 2.0f * mf_rng_float(&r) : 0.0f;
    if ((rc = mf_env_init(&f->env, &env))) return rc;
    if ((rc = look_cam(&f->cam, W, H, mf_v3(0.25f, -0.5f, 1.5f), mf_v3(0, 0, 0)))) return rc;
    random_weights(&r, f->wr, f->wd, f->ws, W * H * 3);
    return MF_OK;
}

static void fix_free(Fix *f) {
    mf_rtscene_free(f->rt0);
    mf_mesh_free(&f->mesh);
    mf_mesh_free(&f->mesh0);
    mf_image_free(&f->kd);
    mf_image_free(&f->orm);
    mf_voltex_free(&f->vkd);
    mf_voltex_free(&f->vorm);
    mf_voltex_free(&f->vkd0);
    mf_voltex_free(&f->vorm0);
    mf_env_free(&f->env);
}

/* The scene over rt: f's UV textures, or its volumes (sampling from the initial copies) when f->vol. */
static MfDiffScene fix_scene(const Fix *f, const MfRtScene *rt) {
    MfDiffScene s = {.rt = rt, .env = &f->env};
    if (f->vol) s.vkd = &f->vkd, s.vorm = &f->vorm, s.vkd_s = &f->vkd0, s.vorm_s = &f->vorm0;
    else s.kd = &f->kd, s.orm = &f->orm;
    return s;
}

/* The loss at f->mesh's current positions (normals recomputed, scene rebuilt); min_alpha gets
 * the smallest coverage. */
static double loss(Fix *f, const MfDiffOpts *o, float *min_alpha) {
    MfRtScene *rt;
    MfRenderOut out;
    if (mf_mesh_compute_normals(&f->mesh) || mf_rtscene_new(&f->mesh, &rt)) return NAN;
    if (mf_render_out_alloc(&out, W, H)) return NAN;
    MfDiffScene s = fix_scene(f, rt);
    s.rt_s = f->rt0;
    double j = NAN;
    if (!mf_diff_forward(&s, &f->cam, o, &out)) {
        j = weighted_sum(&out, f->wr, f->wd, f->ws, W * H * 3);
        if (min_alpha) {
            *min_alpha = 1.0f;
            for (int i = 0; i < W * H; ++i) *min_alpha = fminf(*min_alpha, out.alpha[i]);
        }
    }
    mf_render_out_free(&out);
    mf_rtscene_free(rt);
    return j;
}

typedef struct { Fix *f; const MfDiffOpts *o; } LossCtx;
static double loss_of(void *c) { LossCtx *x = c; return loss(x->f, x->o, NULL); }

MF_TEST(render_hitgrad_dpos) {
    Fix f;
    CHECK_OK(fix_init(&f));
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 5};
    float amin = 0;
    double j0 = loss(&f, &o, &amin);
    CHECK(isfinite(j0));
    CHECK_MSG(amin == 1.0f, "the quad must cover the image (min alpha %g)", amin);
    /* adjoint at the unperturbed mesh */
    float *dpos = calloc((size_t)f.mesh.nv * 3, sizeof(float)), *dkd = calloc(TW * TH * 3, sizeof(float));
    float *dkd2 = calloc(TW * TH * 3, sizeof(float));
    MfDiffScene s = {.rt = f.rt0, .kd = &f.kd, .orm = &f.orm, .env = &f.env};
    MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
    MfDiffGrads g = {.dkd = dkd, .dpos = dpos}, g2 = {.dkd = dkd2};
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g));
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g2));
    CHECK_MSG(!memcmp(dkd, dkd2, sizeof(float) * TW * TH * 3), "dpos changed the texel gradients");
    /* central differences over every coordinate of every vertex */
    LossCtx lc = {&f, &o};
    MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = loss_of, .ctx = &lc, .p = f.mesh.pos, .g = dpos,
                                                 .n = (size_t)f.mesh.nv * 3, .eps = 2e-4f, .atol = 1, .rtol = 0});
    double gmax = r.fd_max, emax = r.worst, rel = emax / gmax;
    if (getenv("MF_TEST_VERBOSE"))
        printf("    dpos: max |fd| %.5g, max |adjoint - fd| %.3g (relative %.3g) at coordinate %ld (fd %.5g, adjoint %.5g)\n",
               gmax, emax, rel, r.at, r.fd, r.g);
    CHECK(gmax > 0);
    CHECK_MSG(rel < 2e-3, "dpos: max |adjoint - fd| / max |fd| = %.3g at coordinate %ld (fd %.6g, adjoint %.6g)", rel, r.at,
              r.fd, r.g);
    /* with dnrm the normals' adjoint stops there: through mf_mesh_normals_backward it gives dpos */
    float *dp2 = calloc((size_t)f.mesh.nv * 3, sizeof(float)), *dn2 = calloc((size_t)f.mesh.nv * 3, sizeof(float));
    MfDiffGrads g3 = {.dpos = dp2, .dnrm = dn2};
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g3));
    double dn_max = 0, dp_err = 0;
    for (int i = 0; i < 3 * f.mesh.nv; ++i) dn_max = fmax(dn_max, fabs(dn2[i]));
    CHECK_OK(mf_mesh_normals_backward(mf_rtscene_mesh(f.rt0), dn2, dp2));
    for (int i = 0; i < 3 * f.mesh.nv; ++i) dp_err = fmax(dp_err, fabs(dp2[i] - dpos[i]));
    CHECK_MSG(dn_max > 0 && dp_err <= 1e-5 * gmax, "dnrm: largest %g; dpos through it differs by %g", dn_max, dp_err);
    free(dp2), free(dn2);
    /* a normal map is refused */
    MfDiffScene sn = s;
    sn.normal = &f.kd;
    CHECK(mf_diff_backward(&sn, &f.cam, &o, &adj, &g) == MF_EARG);
    free(dpos);
    free(dkd);
    free(dkd2);
    fix_free(&f);
}

MF_TEST(render_hitgrad_dpos_volume) {
    /* volume textures: dpos through the hit's position (and normal), and the grids' gradients,
     * against central differences */
    Fix f;
    CHECK_OK(fix_init(&f));
    f.vol = 1;
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 5};
    CHECK(isfinite(loss(&f, &o, NULL)));
    size_t ng = mf_voltex_size(&f.vkd), npos = (size_t)f.mesh.nv * 3;
    float *dpos = calloc(npos, sizeof(float)), *dvkd = calloc(ng, sizeof(float)), *dvorm = calloc(ng, sizeof(float));
    MfDiffScene s = fix_scene(&f, f.rt0);
    MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
    MfDiffGrads g = {.dpos = dpos, .dvkd = dvkd, .dvorm = dvorm};
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g));
    LossCtx lc = {&f, &o};
    struct { const char *name; float *p, *g; size_t n; float eps; double tol; } chk[3] = {
        {"dpos", f.mesh.pos, dpos, npos, 2e-4f, 2e-3}, {"dvkd", f.vkd.grid, dvkd, ng, 1e-3f, 1e-3}, {"dvorm", f.vorm.grid, dvorm, ng, 1e-3f, 2e-3}};
    for (int k = 0; k < 3; ++k) {
        MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = loss_of, .ctx = &lc, .p = chk[k].p, .g = chk[k].g, .n = chk[k].n,
                                                     .eps = chk[k].eps, .atol = 1, .rtol = 0});
        double rel = r.worst / r.fd_max;
        if (getenv("MF_TEST_VERBOSE"))
            printf("    %s: max |fd| %.5g, max |adjoint - fd| %.3g (relative %.3g) at %ld (fd %.5g, adjoint %.5g)\n", chk[k].name,
                   r.fd_max, r.worst, rel, r.at, r.fd, r.g);
        CHECK_MSG(r.fd_max > 0, "%s: no gradient", chk[k].name);
        CHECK_MSG(rel < chk[k].tol, "%s: max |adjoint - fd| / max |fd| = %.3g at %ld (fd %.6g, adjoint %.6g)", chk[k].name, rel, r.at,
                  r.fd, r.g);
    }
    /* the occlusion channel gets none; the AOV path refuses volumes */
    for (size_t i = 0; i < ng; i += 3) CHECK_MSG(dvorm[i] == 0.0f, "occlusion gradient at %zu", i);
    float a[W * H * 3];
    CHECK(mf_diff_aov_forward(&s, &f.cam, &o, a, NULL, NULL) == MF_EARG);
    free(dpos);
    free(dvkd);
    free(dvorm);
    fix_free(&f);
}
