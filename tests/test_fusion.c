/* Tests of MaterialFusion's SDS+ term (mf/fusion/mf_sds): the whole chain from kd/ORM texels
 * through the AOV render, the prior's input preparation and the encoder, checked against central
 * differences with the targets (zhat, D(zhat)) held fixed as the method does; the gamma schedule;
 * and the hook's effect inside a short reconstruction. Uses the tiny prior configuration with
 * random weights (the chain, not the prior's quality, is under test). */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "fusion/mf_sds.h"
#include "mf_test.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"

enum { RES = 16, NV = 4 };

static int make_recon(MfMesh *mesh, MfRecon **out) {
    int rc = mf_shape_uv_sphere(mesh, mf_v3(0, 0, 0), 0.5f, 16, 8);
    if (rc) return rc;
    MfReconView views[NV];
    memset(views, 0, sizeof views);
    MfRtScene *rt = NULL;
    if ((rc = mf_rtscene_new(mesh, &rt))) return rc;
    MfEnvMap env;
    mf_env_init_constant(&env, 8, 4, mf_v3s(1.0f));
    MfTexMaterial mat = {NULL, NULL, mf_v3(0.6f, 0.4f, 0.3f), mf_v3(1, 0.6f, 0.1f), NULL};
    MfRenderInput in = {rt, mesh, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {2, 2, 3, MF_LOBE_ALL};
    for (int v = 0; v < NV && !rc; ++v) {
        float az = 2.0f * MF_PI * v / NV;
        MfMat4 c2w = mf_mat4_look_at(mf_v3(1.8f * cosf(az), 1.8f * sinf(az), 0.4f), mf_v3(0, 0, 0), mf_v3(0, 0, 1));
        double m[16];
        for (int i = 0; i < 16; ++i) m[i] = c2w.m[i];
        if ((rc = mf_camera_init(&views[v].cam, RES, RES, 0.6911, m, "view"))) break;
        MfRenderOut o;
        if ((rc = mf_render(&in, &views[v].cam, &ro, &o, NULL))) break;
        mf_image_alloc(&views[v].ref, RES, RES, 4);
        for (int i = 0; i < RES * RES; ++i) {
            for (int c = 0; c < 3; ++c) views[v].ref.data[4 * i + c] = o.rgb[3 * i + c];
            views[v].ref.data[4 * i + 3] = o.alpha[i];
        }
        mf_render_out_free(&o);
    }
    mf_env_free(&env);
    mf_rtscene_free(rt);
    MfReconOpts o = mf_recon_opts_default();
    o.iters = 6;
    o.tex_res = 8;
    o.env_w = 8;
    o.env_h = 4;
    o.snapshot_every = 0;
    o.checkpoint_every = 0;
    if (!rc) rc = mf_recon_new(mesh, views, NV, &o, out);
    for (int v = 0; v < NV; ++v) mf_image_free(&views[v].ref);
    return rc;
}

static MfSds *tiny_sds_every(int every) {
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    MfPrior *p = NULL;
    if (mf_prior_new(&p, &cfg)) return NULL;
    mf_ae_init_weights(p->ae, 11);
    mf_denoiser_init_weights(p->dn, 12);
    MfSdsOpts o = mf_sds_opts_default();
    o.k_views = 2;
    o.every = every;
    MfSds *s = NULL;
    if (mf_sds_new(p, &o, &s)) {
        mf_prior_free(p);
        return NULL;
    }
    return s;
}

static MfSds *tiny_sds(void) { return tiny_sds_every(1); }

MF_TEST(fusion_sds_chain_gradient) {
    MfMesh mesh;
    MfRecon *r = NULL;
    CHECK_OK(make_recon(&mesh, &r));
    MfSds *s = tiny_sds();
    CHECK(s != NULL);
    if (!r || !s) return;
    /* perturb the textures away from the constant init so every term is active */
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD), *orm = mf_recon_block(r, MF_BLOCK_ORM);
    for (size_t i = 0; i < kd->n; ++i) kd->p[i] = 0.2f + 0.6f * (float)((i * 37) % 11) / 10.0f;
    for (size_t i = 0; i < orm->n; i += 3) orm->p[i + 1] = 0.3f + 0.05f * (float)(i % 7), orm->p[i + 2] = 0.2f + 0.04f * (float)(i % 5);
    MfSdsTargets t;
    int views[2] = {1, 2};
    CHECK_OK(mf_sds_targets(s, r, views, 2, 0, &t));
    mf_param_zero_grad(kd);
    mf_param_zero_grad(orm);
    double l0;
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 1, &l0));
    CHECK(l0 > 0.0);
    double worst = 0.0, gmax = 0.0;
    int checked = 0;
    MfParamBlock *blocks[2] = {kd, orm};
    for (int b = 0; b < 2; ++b)
        for (size_t i = 0; i < blocks[b]->n; ++i) {
            if (b == 1 && i % 3 == 0) continue; /* occlusion is not an input */
            float g = blocks[b]->g[i];
            gmax = fmax(gmax, fabs(g));
            if (fabs(g) < 1e-4) continue; /* texels the view does not see */
            float p0 = blocks[b]->p[i], eps = 2e-3f;
            double lp, lm;
            blocks[b]->p[i] = p0 + eps;
            mf_sds_loss(s, r, &t, 1.0f, 0, &lp);
            blocks[b]->p[i] = p0 - eps;
            mf_sds_loss(s, r, &t, 1.0f, 0, &lm);
            blocks[b]->p[i] = p0;
            double fd = (lp - lm) / (2.0 * eps);
            worst = fmax(worst, fabs(fd - g) / (fabs(fd) + 0.05 * gmax));
            ++checked;
        }
    if (getenv("MF_TEST_VERBOSE")) printf("    SDS chain: %d texel gradients checked, worst relative error %.3g\n", checked, worst);
    CHECK(checked > 20);
    /* float forward through an autoencoder: differences carry ~1e-3 relative noise */
    CHECK_MSG(worst < 3e-2, "SDS chain gradient relative error %.3g", worst);
    mf_sds_targets_free(&t);
    mf_sds_free(s);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* The hook's fused path (one render and encode for targets and loss) equals the public pieces;
 * with every = 3 the term is computed at iterations 0, 3, ... and its gradient held in between. */
MF_TEST(fusion_sds_hook_every) {
    MfMesh mesh;
    MfRecon *r = NULL;
    CHECK_OK(make_recon(&mesh, &r));
    MfSds *s = tiny_sds_every(3);
    if (!r || !s) return;
    int batch[2] = {0, 1}, N = mf_recon_opts(r)->iters;
    MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    MfSdsTargets t;
    double l = -1.0, h0 = -1.0, h1 = -1.0, h3 = -1.0;
    CHECK_OK(mf_sds_targets(s, r, batch, 2, 3, &t));
    CHECK_OK(mf_sds_loss(s, r, &t, 1.0f, 0, &l));
    mf_sds_targets_free(&t);
    mf_param_zero_grad(kd);
    CHECK_OK(mf_sds_hook(s, r, 0, batch, 2, &h0));
    float *g0 = malloc(kd->n * sizeof(float));
    if (!g0) return;
    memcpy(g0, kd->g, kd->n * sizeof(float));
    mf_param_zero_grad(kd);
    CHECK_OK(mf_sds_hook(s, r, 1, batch, 2, &h1)); /* held: the same gradient and loss, gamma(1) */
    double g1 = 1.0 - 1.0 / (double)N, err = 0.0, mag = 0.0;
    for (size_t i = 0; i < kd->n; ++i) err = fmax(err, fabs(kd->g[i] - g1 * g0[i])), mag = fmax(mag, fabs(g0[i]));
    CHECK(mag > 0.0 && err <= 1e-6 * mag);
    CHECK_NEAR(h1, g1 * h0, 1e-9 * h0);
    CHECK_OK(mf_sds_hook(s, r, 3, batch, 2, &h3)); /* refreshed */
    CHECK(l > 0.0);
    CHECK_NEAR(h3, (1.0 - 3.0 / (double)N) * l, 1e-6 * fabs(h3) + 1e-12);
    free(g0);
    mf_sds_free(s);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

MF_TEST(fusion_sds_hook_schedule) {
    MfMesh mesh;
    MfRecon *r = NULL;
    CHECK_OK(make_recon(&mesh, &r));
    MfSds *s = tiny_sds();
    if (!r || !s) return;
    int batch[2] = {0, 1};
    double l_first, l_last;
    /* gamma = 1 - (i/N)^p: the term vanishes at i = N and is full at i = 0 */
    CHECK_OK(mf_sds_hook(s, r, 0, batch, 2, &l_first));
    CHECK_OK(mf_sds_hook(s, r, 6, batch, 2, &l_last));
    CHECK(l_first > 0.0);
    CHECK(l_last == 0.0);
    /* the hook inside the loop runs and logs a non-zero loss_sds */
    MfReconHook hook = {mf_sds_hook, s};
    CHECK_OK(mf_recon_run(r, &hook, mf_test_path("mf_run")));
    char p[1024], *log = NULL;
    snprintf(p, sizeof p, "%s/log.csv", mf_test_path("mf_run"));
    CHECK_OK(mf_read_file(p, &log, NULL));
    double sds = -1;
    const char *row1 = log ? strchr(log, '\n') : NULL;
    CHECK(row1 && sscanf(row1 + 1, "%*d,%*f,%*f,%*f,%*f,%lf", &sds) == 1 && sds > 0.0);
    free(log);
    mf_sds_free(s);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}
