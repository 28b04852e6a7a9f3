/* T3 of issue 14: vertex-position gradients of the differentiable renderer (MfDiffGrads.dpos,
 * render/mf_hitgrad.h) against central differences of the rendered loss with common random
 * numbers. The sampling copy of the geometry (MfDiffScene.rt_s) stays at the unperturbed mesh,
 * so drawn directions, pdfs and MIS weights are constants, as the adjoint assumes. The scene is
 * a bumped quad that covers the whole image (no silhouette: the loss is smooth in the vertices
 * apart from shadow-ray flips, see the bound's comment) with textured kd/ORM and a random env;
 * the loss is a random linear functional of rgb, diffuse and specular. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_diffrender.h"
#include "mf_test.h"
#include "mf_test_diff.h"
#include "mf_test_geom.h"
#include "mf_test_grad.h"

enum { W = 12, H = 12, N = 9, TW = 8, TH = 8, EW = 16, EH = 8 };

typedef struct {
    MfMesh mesh, mesh0; /* evaluated (perturbed) and sampling copies */
    MfRtScene *rt0;
    MfImage kd, orm;
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
    mf_env_free(&f->env);
}

/* The loss at f->mesh's current positions (normals recomputed, scene rebuilt); min_alpha gets
 * the smallest coverage. */
static double loss(Fix *f, const MfDiffOpts *o, float *min_alpha) {
    MfRtScene *rt;
    MfRenderOut out;
    if (mf_mesh_compute_normals(&f->mesh) || mf_rtscene_new(&f->mesh, &rt)) return NAN;
    if (mf_render_out_alloc(&out, W, H)) return NAN;
    MfDiffScene s = {.rt = rt, .rt_s = f->rt0, .kd = &f->kd, .orm = &f->orm, .env = &f->env};
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
    /* a normal map is refused */
    MfDiffScene sn = s;
    sn.normal = &f.kd;
    CHECK(mf_diff_backward(&sn, &f.cam, &o, &adj, &g) == MF_EARG);
    free(dpos);
    free(dkd);
    free(dkd2);
    fix_free(&f);
}
