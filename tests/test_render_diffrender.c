/* Gradient checks of the differentiable renderer (mf/render/mf_diffrender): central
 * differences in double of the forward estimator, with common random numbers and sampling
 * parameters frozen (see mf_diffrender.h), against the adjoint, for albedo, roughness,
 * metallic and env-map texels. The loss is a random linear functional of rgb, diffuse and
 * specular, so its adjoint is exactly the functional's weights. */
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_diffrender.h"
#include "mf_test.h"
#include "mf_test_diff.h"
#include "mf_test_geom.h"
#include "mf_test_grad.h"
#include "scene/mf_shapes.h"

enum { W = 10, H = 10, TW = 4, TH = 4, EW = 8, EH = 4 };

typedef struct {
    MfMesh mesh;
    MfRtScene *rt;
    MfImage kd, orm, kd_s, orm_s;
    MfImage nm, nm_s; /* normal map and its sampling copy, used when use_nm */
    int use_nm;
    MfEnvMap env, env_s;
    MfCamera cam;
    float wr[W * H * 3], wd[W * H * 3], ws[W * H * 3];
} Fixture;

static int fixture_init(Fixture *f) {
    memset(f, 0, sizeof *f);
    MfRng r;
    mf_rng_seed(&r, 11, 0);
    int rc = mf_shape_uv_sphere(&f->mesh, mf_v3(0, 0, 0), 0.5f, 24, 12);
    if (!rc) rc = mf_rtscene_new(&f->mesh, &f->rt);
    if (!rc) rc = mf_image_alloc(&f->kd, TW, TH, 3);
    if (!rc) rc = mf_image_alloc(&f->orm, TW, TH, 3);
    MfImage env = {0};
    if (!rc) rc = mf_image_alloc(&env, EW, EH, 3);
    if (rc) return rc;
    random_materials(&r, &f->kd, &f->orm, 0.25f);
    for (int i = 0; i < EW * EH * 3; ++i) env.data[i] = 0.2f + 2.0f * mf_rng_float(&r);
    MfImage env2;
    mf_image_alloc(&env2, EW, EH, 3);
    memcpy(env2.data, env.data, sizeof(float) * EW * EH * 3);
    if ((rc = mf_env_init(&f->env, &env)) || (rc = mf_env_init(&f->env_s, &env2))) return rc;
    mf_image_alloc(&f->nm, TW, TH, 3);
    mf_image_alloc(&f->nm_s, TW, TH, 3);
    for (int i = 0; i < TW * TH; ++i) { /* tilted up to ~30 degrees around flat (0.5, 0.5, 1) */
        f->nm.data[3 * i] = 0.5f + 0.3f * (mf_rng_float(&r) - 0.5f);
        f->nm.data[3 * i + 1] = 0.5f + 0.3f * (mf_rng_float(&r) - 0.5f);
        f->nm.data[3 * i + 2] = 0.8f + 0.2f * mf_rng_float(&r);
    }
    memcpy(f->nm_s.data, f->nm.data, sizeof(float) * TW * TH * 3);
    mf_image_alloc(&f->kd_s, TW, TH, 3);
    mf_image_alloc(&f->orm_s, TW, TH, 3);
    memcpy(f->kd_s.data, f->kd.data, sizeof(float) * TW * TH * 3);
    memcpy(f->orm_s.data, f->orm.data, sizeof(float) * TW * TH * 3);
    if ((rc = look_cam(&f->cam, W, H, mf_v3(0.3f, -1.6f, 0.5f), mf_v3(0, 0, 0)))) return rc;
    random_weights(&r, f->wr, f->wd, f->ws, W * H * 3);
    return MF_OK;
}

static void fixture_free(Fixture *f) {
    mf_rtscene_free(f->rt);
    mf_mesh_free(&f->mesh);
    mf_image_free(&f->kd);
    mf_image_free(&f->orm);
    mf_image_free(&f->kd_s);
    mf_image_free(&f->orm_s);
    mf_image_free(&f->nm);
    mf_image_free(&f->nm_s);
    mf_env_free(&f->env);
    mf_env_free(&f->env_s);
}

static MfDiffScene scene_of(Fixture *f) {
    MfDiffScene s = {.rt = f->rt, .kd = &f->kd, .orm = &f->orm, .env = &f->env, .kd_s = &f->kd_s, .orm_s = &f->orm_s,
                     .env_s = &f->env_s, .normal = f->use_nm ? &f->nm : NULL, .normal_s = f->use_nm ? &f->nm_s : NULL};
    return s;
}

static double objective(Fixture *f, const MfDiffOpts *o) {
    MfRenderOut out;
    MfDiffScene s = scene_of(f);
    if (mf_render_out_alloc(&out, W, H)) return NAN;
    if (mf_diff_forward(&s, &f->cam, o, &out)) return NAN;
    double j = weighted_sum(&out, f->wr, f->wd, f->ws, W * H * 3);
    mf_render_out_free(&out);
    return j;
}

typedef struct { Fixture *f; const MfDiffOpts *o; } ObjCtx;
static double objective_of(void *c) { ObjCtx *x = c; return objective(x->f, x->o); }

/* max over checked entries (c0, c0 + stride, ... < n) of |adjoint - fd| / (|fd| + floor) */
static double check_block(Fixture *f, const MfDiffOpts *o, float *param, const float *grad, int n, int stride, int c0,
                          float eps, double floor_) {
    ObjCtx c = {f, o};
    return mf_test_grad(&(MfGradCheck){.loss = objective_of, .ctx = &c, .p = param, .g = grad, .n = (size_t)n,
                                       .first = (size_t)c0, .stride = (size_t)stride, .eps = eps, .atol = floor_, .rtol = 1})
        .worst;
}

MF_TEST(render_diffrender_gradients) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 7};
    MfDiffScene s = scene_of(&f);
    float *dkd = calloc(TW * TH * 3, sizeof(float)), *dorm = calloc(TW * TH * 3, sizeof(float));
    float *denv = calloc(EW * EH * 3, sizeof(float));
    MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
    MfDiffGrads g = {.dkd = dkd, .dorm = dorm, .denv = denv};
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g));
    double gsum = 0;
    for (int i = 0; i < TW * TH * 3; ++i) gsum += fabs(dkd[i]) + fabs(dorm[i]);
    CHECK(gsum > 0);
    /* Measured: 1.2e-4 (kd), 1.2e-3 (roughness), 5.6e-4 (metallic), 3.0e-3 (env). The bound 1e-2 leaves
     * room for float rounding of the forward sums (eps 1e-2 on parameters of size ~0.5); a
     * missing term (e.g. Fresnel's dependence on kd) gives errors of 0.1 or more. */
    double e_kd = check_block(&f, &o, f.kd.data, dkd, TW * TH * 3, 1, 0, 1e-2f, 1e-3);
    double e_r = check_block(&f, &o, f.orm.data, dorm, TW * TH * 3, 3, 1, 1e-2f, 1e-3);
    double e_m = check_block(&f, &o, f.orm.data, dorm, TW * TH * 3, 3, 2, 1e-2f, 1e-3);
    double e_env = check_block(&f, &o, f.env.img.data, denv, EW * EH * 3, 1, 0, 1e-2f, 1e-3);
    if (getenv("MF_TEST_VERBOSE")) printf("    rel errors: kd %.3g rough %.3g metal %.3g env %.3g\n", e_kd, e_r, e_m, e_env);
    CHECK_MSG(e_kd < 1e-2, "albedo gradient relative error %.3g", e_kd);
    CHECK_MSG(e_r < 1e-2, "roughness gradient relative error %.3g", e_r);
    CHECK_MSG(e_m < 1e-2, "metallic gradient relative error %.3g", e_m);
    CHECK_MSG(e_env < 1e-2, "env gradient relative error %.3g", e_env);
    for (int i = 0; i < TW * TH; ++i) CHECK(dorm[3 * i] == 0.0f); /* occlusion gets none */
    free(dkd);
    free(dorm);
    free(denv);
    fixture_free(&f);
}

/* The gradients (render and AOV backward) are the same bits at 1, 2 and 3 OpenMP threads: the
 * reduction's order does not follow the thread count (mf_diffrender.c, gradient lanes). */
MF_TEST(render_diffrender_gradients_thread_independent) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 7};
    MfDiffScene s = scene_of(&f);
    enum { NT = TW * TH * 3, NE = EW * EH * 3 };
    float g1[2 * NT + NE + 2 * NT], g[2 * NT + NE + 2 * NT]; /* render: kd, ORM, env; then AOV: kd, ORM */
    int keep = omp_get_max_threads();
    for (int nt = 1; nt <= 3; ++nt) {
        omp_set_num_threads(nt);
        memset(g, 0, sizeof g);
        MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
        MfDiffGrads dg = {.dkd = g, .dorm = g + NT, .denv = g + 2 * NT}, da = {.dkd = g + 2 * NT + NE, .dorm = g + 3 * NT + NE};
        CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &dg));
        CHECK_OK(mf_diff_aov_backward(&s, &f.cam, &o, f.wr, f.wd, &da));
        if (nt == 1) memcpy(g1, g, sizeof g);
        else CHECK_MSG(memcmp(g1, g, sizeof g) == 0, "gradients at %d threads differ from 1 thread's", nt);
    }
    omp_set_num_threads(keep);
    fixture_free(&f);
}

static double aov_objective(void *c) {
    Fixture *f = ((ObjCtx *)c)->f;
    const MfDiffOpts *o = ((ObjCtx *)c)->o;
    MfDiffScene s = scene_of(f);
    float alb[W * H * 3], orm[W * H * 3], a[W * H];
    if (mf_diff_aov_forward(&s, &f->cam, o, alb, orm, a)) return NAN;
    double j = 0;
    for (int i = 0; i < W * H * 3; ++i) j += (double)f->wr[i] * alb[i] + (double)f->wd[i] * orm[i];
    return j;
}

MF_TEST(render_diffrender_aov_gradients) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    MfDiffOpts o = {.spp_sqrt = 1, .pixel_samples = 3, .seed = 5};
    MfDiffScene s = scene_of(&f);
    float dkd[TW * TH * 3] = {0}, dorm[TW * TH * 3] = {0};
    MfDiffGrads g = {.dkd = dkd, .dorm = dorm};
    CHECK_OK(mf_diff_aov_backward(&s, &f.cam, &o, f.wr, f.wd, &g));
    /* the AOVs are linear in the texels (hits fixed): differences are exact up to rounding */
    double worst = 0;
    float *blocks[2] = {f.kd.data, f.orm.data};
    const float *grads[2] = {dkd, dorm};
    ObjCtx c = {&f, &o};
    for (int b = 0; b < 2; ++b)
        worst = fmax(worst, mf_test_grad(&(MfGradCheck){.loss = aov_objective, .ctx = &c, .p = blocks[b], .g = grads[b],
                                                        .n = TW * TH * 3, .eps = 0.05, .atol = 1e-3, .rtol = 1})
                                .worst);
    CHECK_MSG(worst < 1e-3, "AOV gradient relative error %.3g", worst);
    fixture_free(&f);
}

/* Normal-map texels (mf_normalmap.h): the adjoint through the bilinear lookup, the frame, the
 * normalisation and the BRDF's dependence on the shading normal, against central differences
 * with the sampling copy frozen. The other blocks keep their checks with the map on. */
MF_TEST(render_diffrender_normal_map_gradients) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    f.use_nm = 1;
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 7};
    MfDiffScene s = scene_of(&f);
    float *dnm = calloc(TW * TH * 3, sizeof(float)), *dkd = calloc(TW * TH * 3, sizeof(float));
    float *denv = calloc(EW * EH * 3, sizeof(float));
    MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
    MfDiffGrads g = {.dkd = dkd, .denv = denv, .dnormal = dnm};
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g));
    double gsum = 0;
    for (int i = 0; i < TW * TH * 3; ++i) gsum += fabs(dnm[i]);
    CHECK(gsum > 0);
    /* Normal-map gradients span 1e-4 .. 4 here and the specular lobe is sharp in the normal:
     * eps 1e-2 leaves a truncation error of ~5% on the largest entries, eps 1e-3 is dominated by
     * float rounding of the forward sums; eps 3e-3 with an absolute floor of 2e-2 (0.5% of the
     * largest gradient) measures about 3e-3. A wrong bitangent sign, a missing half-vector
     * term or a missing projection of the normalisation gives errors of 0.1 or more. */
    double e_n = check_block(&f, &o, f.nm.data, dnm, TW * TH * 3, 1, 0, 3e-3f, 2e-2);
    double e_kd = check_block(&f, &o, f.kd.data, dkd, TW * TH * 3, 1, 0, 1e-2f, 1e-3);
    double e_env = check_block(&f, &o, f.env.img.data, denv, EW * EH * 3, 1, 0, 1e-2f, 1e-3);
    if (getenv("MF_TEST_VERBOSE")) printf("    rel errors: normal %.3g kd %.3g env %.3g\n", e_n, e_kd, e_env);
    CHECK_MSG(e_n < 1.5e-2, "normal-map gradient relative error %.3g", e_n);
    CHECK_MSG(e_kd < 1e-2, "albedo gradient relative error (normal map on) %.3g", e_kd);
    CHECK_MSG(e_env < 1e-2, "env gradient relative error (normal map on) %.3g", e_env);
    free(dnm);
    free(dkd);
    free(denv);
    fixture_free(&f);
}

/* No map and a flat map (0.5, 0.5, 1) give the same image (the flat map up to rounding of the
 * renormalised normal); a flat map receives gradient but the absent one leaves dnormal alone. */
MF_TEST(render_diffrender_flat_normal_map_is_identity) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    MfDiffOpts o = {.spp_sqrt = 2, .pixel_samples = 2, .seed = 9};
    MfRenderOut a, b;
    CHECK_OK(mf_render_out_alloc(&a, W, H));
    CHECK_OK(mf_render_out_alloc(&b, W, H));
    MfDiffScene s = scene_of(&f);
    CHECK_OK(mf_diff_forward(&s, &f.cam, &o, &a));
    for (int i = 0; i < TW * TH; ++i) f.nm.data[3 * i] = f.nm.data[3 * i + 1] = 0.5f, f.nm.data[3 * i + 2] = 1.0f;
    f.use_nm = 1;
    s = scene_of(&f);
    s.normal_s = NULL;
    CHECK_OK(mf_diff_forward(&s, &f.cam, &o, &b));
    double worst = 0, mx = 0;
    for (int i = 0; i < W * H * 3; ++i) {
        worst = fmax(worst, fabs(a.rgb[i] - b.rgb[i]));
        mx = fmax(mx, fabs(a.rgb[i]));
    }
    CHECK(mx > 0.05);
    CHECK_MSG(worst < 1e-4 * mx, "flat normal map changes the image by %.3g (max %.3g)", worst, mx);
    float dn[TW * TH * 3] = {0};
    MfDiffAdjoint adj = {.drgb = f.wr, .ddiffuse = f.wd, .dspecular = f.ws};
    MfDiffGrads g = {.dnormal = dn};
    s.normal = NULL; /* absent map: nothing accumulated */
    CHECK_OK(mf_diff_backward(&s, &f.cam, &o, &adj, &g));
    for (int i = 0; i < TW * TH * 3; ++i) CHECK(dn[i] == 0.0f);
    mf_render_out_free(&a);
    mf_render_out_free(&b);
    fixture_free(&f);
}

/* One estimator (render/mf_estimator.h): mf_diff_forward is mf_render for the same scene as one
 * textured material, seed and sample counts, on every AOV, with and without a normal map and
 * with one and several pixel samples. Measured: bit-identical (difference 0). */
static double max_rel_diff(const float *a, const float *b, size_t n) {
    double d = 0, m = 0;
    for (size_t i = 0; i < n; ++i) {
        d = fmax(d, fabs((double)a[i] - b[i]));
        m = fmax(m, fabs((double)b[i]));
    }
    return isfinite(d) ? d / fmax(m, 1e-30) : INFINITY;
}

MF_TEST(render_diffrender_forward_equals_render) {
    Fixture f;
    CHECK_OK(fixture_init(&f));
    const int cases[4][3] = {{2, 1, 0}, {2, 3, 0}, {3, 2, 1}, {1, 1, 1}}; /* spp_sqrt, pixel samples, normal map */
    for (int c = 0; c < 4; ++c) {
        f.use_nm = cases[c][2];
        MfDiffOpts o = {.spp_sqrt = cases[c][0], .pixel_samples = cases[c][1], .seed = 31 + (uint64_t)c};
        MfDiffScene s = {.rt = f.rt, .kd = &f.kd, .orm = &f.orm, .env = &f.env, .normal = f.use_nm ? &f.nm : NULL};
        MfTexMaterial mat = {.kd = &f.kd, .orm = &f.orm, .normal = s.normal};
        MfRenderInput in = {.rt = f.rt, .mesh = &f.mesh, .mats = &mat, .nmat = 1, .env = &f.env};
        MfRenderOpts ro = {.spp_sqrt = o.spp_sqrt, .pixel_samples = o.pixel_samples, .seed = o.seed, .lobes = MF_LOBE_ALL};
        MfRenderOut a, b;
        CHECK_OK(mf_render_out_alloc(&a, W, H));
        CHECK_OK(mf_diff_forward(&s, &f.cam, &o, &a));
        CHECK_OK(mf_render(&in, &f.cam, &ro, &b, NULL));
        const float *pa[8] = {a.rgb, a.alpha, a.albedo, a.orm, a.normal, a.depth, a.diffuse, a.specular};
        const float *pb[8] = {b.rgb, b.alpha, b.albedo, b.orm, b.normal, b.depth, b.diffuse, b.specular};
        const int nc[8] = {3, 1, 3, 3, 3, 1, 3, 3};
        const char *name[8] = {"rgb", "alpha", "albedo", "orm", "normal", "depth", "diffuse", "specular"};
        double mx = 0;
        for (int i = 0; i < W * H * 3; ++i) mx = fmax(mx, b.rgb[i]);
        CHECK(mx > 0.05); /* something was lit */
        for (int k = 0; k < 8; ++k) {
            double e = max_rel_diff(pa[k], pb[k], (size_t)W * H * nc[k]);
            CHECK_MSG(e <= 1e-6, "case %d: mf_diff_forward and mf_render differ in %s by %.3g (relative to its max)", c,
                      name[k], e);
        }
        mf_render_out_free(&a);
        mf_render_out_free(&b);
    }
    fixture_free(&f);
}
