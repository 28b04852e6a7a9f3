/* Tests of the budgets from the data (mf/inverse/mf_budget, used by mf_recon): early stopping on
 * held-out views (held out of the loss, stop rule, exact resume), the "no metal" test and its
 * freezing of the metallic channel, and the texture side from the projected texel density.
 * Small sphere scenes rendered by the forward renderer (32 px, 8 views). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "inverse/mf_budget.h"
#include "inverse/mf_loss.h"
#include "inverse/mf_recon.h"
#include "io/mf_obj.h"
#include "mf_test.h"
#include "mf_test_kit.h"
#include "mf_test_recon.h"
#include "render/mf_integrator.h"
#include "scene/mf_shapes.h"

enum { NV = 8 };

/* NV views (zeroed first) of mesh around the origin at distance 1.8, res px, under a sky/ground
 * env; the material: albedo (0.6, 0.4, 0.2), roughness 0.4, the given metallic. */
static int sphere_views(const MfMesh *mesh, int res, float metallic, MfReconView *views) {
    memset(views, 0, NV * sizeof *views);
    MfRtScene *rt = NULL;
    int rc = mf_rtscene_new(mesh, &rt);
    if (rc) return rc;
    MfImage e;
    if ((rc = mf_image_alloc(&e, 16, 8, 3))) return rc;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 16; ++x) {
            float *p = mf_image_px(&e, x, y);
            p[0] = p[1] = p[2] = y < 4 ? 1.0f : 0.3f;
            if (y == 2 && x == 3) p[0] = p[1] = p[2] = 8.0f;
        }
    MfEnvMap env;
    if ((rc = mf_env_init(&env, &e))) return rc;
    MfTexMaterial mat = {.kd = NULL, .orm = NULL, .kd_const = mf_v3(0.6f, 0.4f, 0.2f), .orm_const = mf_v3(1.0f, 0.4f, metallic), .normal = NULL};
    MfRenderInput in = {rt, mesh, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = 4, .pixel_samples = 2, .seed = 99, .lobes = MF_LOBE_ALL};
    for (int v = 0; v < NV && !rc; ++v) {
        float az = 2.0f * MF_PI * v / NV, el = (v % 2 ? 0.6f : -0.6f);
        MfVec3 eye = mf_v3(1.8f * cosf(az) * cosf(el), 1.8f * sinf(az) * cosf(el), 1.8f * sinf(el));
        rc = ref_view(&in, &ro, res, eye, &views[v]);
    }
    mf_env_free(&env);
    mf_rtscene_free(rt);
    return rc;
}

static MfReconOpts tiny_opts(void) {
    MfReconOpts o = mf_recon_opts_default();
    o.tex_res = 8;
    o.env_w = 16;
    o.env_h = 8;
    o.lr = 0.03f;
    o.spp_sqrt = 1;
    o.snapshot_every = 0;
    o.checkpoint_every = 0;
    return o;
}

/* A reconstruction of mesh from fresh sphere_views (24 px, GT metallic) with options o (both
 * checked); NULL on failure. */
static MfRecon *recon_of(const MfMesh *mesh, float metallic, const MfReconOpts *o) {
    MfReconView v[NV];
    MfRecon *r = NULL;
    CHECK_OK(sphere_views(mesh, 24, metallic, v));
    CHECK_OK(mf_recon_new(mesh, v, NV, o, &r));
    return r;
}

/* Every texture and env block of a and b holds the same bytes. */
static void check_same_blocks(MfRecon *a, MfRecon *b) {
    for (int k = 0; k < MF_BLOCK_NORMAL; ++k) {
        const MfParamBlock *x = mf_recon_block(a, k), *y = mf_recon_block(b, k);
        CHECK_MSG(x->n == y->n && !memcmp(x->p, y->p, x->n * sizeof(float)), "block %s differs after resume", x->name);
    }
}

/* ---- early stop ---- */

MF_TEST(inverse_budget_early_stop_rule) {
    MfEarlyStop es;
    mf_early_stop_init(&es);
    /* improves, then two evaluations within min_delta 0.1 of the best: stops at the second */
    CHECK(!mf_early_stop_observe(&es, 10, 20.0, 2, 0.1));
    CHECK(!mf_early_stop_observe(&es, 20, 21.0, 2, 0.1));
    CHECK(!mf_early_stop_observe(&es, 30, 21.05, 2, 0.1));
    CHECK(es.bad == 1 && es.best_iter == 20);
    CHECK(mf_early_stop_observe(&es, 40, 20.5, 2, 0.1));
    CHECK(es.stop_iter == 40 && es.n == 4 && es.psnr[3] == 20.5);
    /* an improvement resets the count */
    mf_early_stop_init(&es);
    CHECK(!mf_early_stop_observe(&es, 1, 10.0, 2, 0.0));
    CHECK(!mf_early_stop_observe(&es, 2, 9.0, 2, 0.0));
    CHECK(!mf_early_stop_observe(&es, 3, 11.0, 2, 0.0));
    CHECK(!mf_early_stop_observe(&es, 4, 10.0, 2, 0.0));
    CHECK(es.stop_iter == 0 && es.best_iter == 3);
    CHECK(mf_budget_is_holdout(0, 8) && mf_budget_is_holdout(16, 8) && !mf_budget_is_holdout(7, 8));
}

/* A hook recording which views the loss used. */
static int record_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    int *used = ctx;
    (void)r, (void)it;
    for (int k = 0; k < nb; ++k) used[batch[k]]++;
    *loss = 0.0;
    return MF_OK;
}

/* Held-out views never enter the loss; with nothing learning (lr 0) the held-out PSNR never
 * improves, so the run stops after 1 + patience evaluations, and says so in holdout.csv. */
MF_TEST(inverse_budget_holdout_not_in_loss_and_stops) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconView v[NV];
    CHECK_OK(sphere_views(&mesh, 24, 0.0f, v));
    MfReconOpts o = tiny_opts();
    o.iters = 100;
    o.lr = 0.0f;
    o.early_stop = 1;
    o.holdout_every = 4; /* views 0 and 4 */
    o.es_every = 3;
    o.es_patience = 2;
    MfRecon *r = NULL;
    CHECK_OK(mf_recon_new(&mesh, v, NV, &o, &r));
    int used[NV] = {0};
    MfReconHook hook = {record_hook, used};
    char dir[512];
    mf_test_path_to(dir, sizeof dir, "es_stop");
    CHECK_OK(mf_recon_run(r, &hook, dir));
    CHECK(used[0] == 0 && used[4] == 0);
    for (int i = 0; i < NV; ++i) CHECK_MSG(i % 4 == 0 || used[i] > 0, "training view %d never used", i);
    const MfEarlyStop *es = mf_recon_early_stop(r);
    CHECK(es && es->stop_iter == 9 && mf_recon_iteration(r) == 9 && es->n == 3);
    CHECK(es && es->psnr[0] > 5.0 && es->psnr[0] == es->psnr[2]); /* fixed seeds: same state, same PSNR */
    char p[1024], *txt = NULL;
    snprintf(p, sizeof p, "%s/holdout.csv", dir);
    CHECK_OK(mf_read_file(p, &txt, NULL));
    int rows = 0;
    for (char *c = txt; c && *c; ++c) rows += *c == '\n';
    CHECK(rows == 4);
    free(txt);
    mf_recon_free(r);
    /* early_stop needs a view to hold out and one to train on */
    MfReconView one[1];
    memset(one, 0, sizeof one);
    CHECK_OK(mf_image_alloc(&one[0].ref, 4, 4, 4));
    one[0].cam = v[0].cam;
    CHECK_ERR(mf_recon_new(&mesh, one, 1, &o, &r), "early_stop");
    mf_image_free(&one[0].ref);
    for (int i = 0; i < NV; ++i) mf_image_free(&v[i].ref);
    mf_mesh_free(&mesh);
}

/* An interrupted early-stopped run resumes to the same stop iteration and bytes. */
MF_TEST(inverse_budget_early_stop_resume_is_exact) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = tiny_opts();
    o.iters = 100;
    o.early_stop = 1;
    o.holdout_every = 4;
    o.es_every = 2;
    o.es_patience = 2;
    o.es_min_delta = 100.0f; /* nothing counts as an improvement: stops at 2 * (1 + 2) */
    char fd[512], hd[512], ck[1024];
    mf_test_path_to(fd, sizeof fd, "es_full");
    mf_test_path_to(hd, sizeof hd, "es_half");
    MfRecon *full = recon_of(&mesh, 0.0f, &o), *half = NULL;
    CHECK_OK(mf_recon_run(full, NULL, fd));
    CHECK(mf_recon_iteration(full) == 6);
    MfReconOpts oh = o;
    oh.iters = 4; /* interrupted after two evaluations (one without improvement) */
    half = recon_of(&mesh, 0.0f, &oh);
    CHECK_OK(mf_recon_run(half, NULL, hd));
    mf_recon_free(half);
    half = recon_of(&mesh, 0.0f, &o);
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", hd);
    CHECK_OK(mf_recon_load_checkpoint(half, ck));
    CHECK_OK(mf_recon_run(half, NULL, hd));
    const MfEarlyStop *a = mf_recon_early_stop(full), *b = mf_recon_early_stop(half);
    CHECK(a->stop_iter == 6 && b->stop_iter == 6 && b->n == 3 && a->psnr[2] == b->psnr[2]);
    check_same_blocks(full, half);
    /* a stopped run resumed again does no more iterations */
    mf_recon_free(half);
    half = recon_of(&mesh, 0.0f, &o);
    CHECK_OK(mf_recon_load_checkpoint(half, ck));
    CHECK(mf_recon_iteration(half) == 6); /* the checkpoint was written at the stop */
    CHECK_OK(mf_recon_run(half, NULL, hd));
    CHECK(mf_recon_iteration(half) == 6 && mf_recon_early_stop(half)->stop_iter == 6);
    mf_recon_free(half);
    mf_recon_free(full);
    mf_mesh_free(&mesh);
}

/* ---- metallic fixed at 0 when the scene shows no metal ---- */

MF_TEST(inverse_budget_metal_fraction) {
    float orm[4 * 3] = {1, 0.5f, 0.9f, 1, 0.5f, 0.1f, 1, 0.5f, 0.6f, 1, 0.5f, 0.9f};
    unsigned char mask[4] = {1, 1, 1, 0};
    CHECK_NEAR(mf_budget_metal_fraction(orm, mask, 4, 0.5f), 2.0 / 3.0, 1e-12);
    memset(mask, 0, sizeof mask);
    CHECK(mf_budget_metal_fraction(orm, mask, 4, 0.5f) == 0.0);
}

/* After the warm-up, a dielectric sphere gets metallic fixed at 0 (every texel, frozen after);
 * a metallic one keeps its channel. */
static void metal_run(float gt_metal, float init_metal, const char *name, int *state, double *frac, float *max_metal) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = tiny_opts();
    o.iters = 24;
    o.metal_auto = 1;
    o.metal_warmup = 16;
    o.init_metal = init_metal;
    MfRecon *r = recon_of(&mesh, gt_metal, &o);
    char dir[512];
    mf_test_path_to(dir, sizeof dir, "%s", name);
    CHECK_OK(mf_recon_run(r, NULL, dir));
    *state = mf_recon_metal_state(r, frac);
    const MfParamBlock *orm = mf_recon_block(r, MF_BLOCK_ORM);
    *max_metal = 0.0f;
    for (size_t i = 2; i < orm->n; i += 3) *max_metal = fmaxf(*max_metal, orm->p[i]);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

MF_TEST(inverse_budget_metal_auto) {
    int st;
    double frac;
    float mx;
    metal_run(0.0f, 0.25f, "metal_no", &st, &frac, &mx);
    CHECK_MSG(st == 1 && frac < 0.02 && mx == 0.0f, "dielectric: state %d, fraction %g, max metallic %g", st, frac, mx);
    metal_run(1.0f, 0.75f, "metal_yes", &st, &frac, &mx);
    CHECK_MSG(st == 0 && frac > 0.5 && mx > 0.5f, "metallic: state %d, fraction %g, max metallic %g", st, frac, mx);
}

/* A hook whose loss grows every iteration (so the guard's best state stays the starting one, from
 * before the freeze) and that poisons a gradient at iteration 4, the last: the recovery must not bring the
 * pre-freeze metallic back (at the last iteration no Adam step projects it afterwards). */
static int rising_nan_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    (void)ctx, (void)batch, (void)nb;
    *loss = 10.0 * it;
    if (it == 4) mf_recon_block(r, MF_BLOCK_KD)->g[0] = NAN;
    return MF_OK;
}

MF_TEST(inverse_budget_metal_frozen_through_recovery) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = tiny_opts();
    o.iters = 5;
    o.metal_auto = 1;
    o.metal_warmup = 1; /* every texel starts at 0.25: fixed at 0 after the first iteration */
    o.div_patience = 1000;
    MfRecon *r = recon_of(&mesh, 0.0f, &o);
    MfReconHook hook = {rising_nan_hook, NULL};
    char dir[512];
    mf_test_path_to(dir, sizeof dir, "metal_recover");
    CHECK_OK(mf_recon_run(r, &hook, dir));
    int nrec = 0;
    mf_recon_recoveries(r, &nrec);
    double frac;
    CHECK(nrec == 1 && mf_recon_metal_state(r, &frac) == 1);
    const MfParamBlock *orm = mf_recon_block(r, MF_BLOCK_ORM);
    float mx = 0.0f;
    for (size_t i = 2; i < orm->n; i += 3) mx = fmaxf(mx, orm->p[i]);
    CHECK_MSG(mx == 0.0f, "metallic %g after the recovery", mx);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* ---- texture side from the texel density ---- */

MF_TEST(inverse_budget_texel_side) {
    CHECK(mf_budget_pow2_side(90.0, 16, 1024) == 64);
    CHECK(mf_budget_pow2_side(91.0, 16, 1024) == 128);
    CHECK(mf_budget_pow2_side(3.0, 16, 1024) == 16);
    CHECK(mf_budget_pow2_side(1e6, 16, 1024) == 1024);
    CHECK(mf_budget_pow2_side(0.0, 16, 1024) == 1024);
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&mesh, &rt));
    double side[2];
    for (int k = 0; k < 2; ++k) {
        MfReconView v[NV];
        CHECK_OK(sphere_views(&mesh, 32 << k, 0.0f, v));
        long n = 0;
        CHECK_OK(mf_budget_texel_side(rt, &mesh, v, NV, &side[k], &n));
        CHECK(n > 0);
        if (k == 1) { /* mf_recon_new picks the power of two */
            MfReconOpts o = tiny_opts();
            o.tex_auto = 1;
            MfRecon *r = NULL;
            CHECK_OK(mf_recon_new(&mesh, v, NV, &o, &r));
            CHECK(r && mf_recon_opts(r)->tex_res == mf_budget_pow2_side(side[1], 32, 1024));
            CHECK(r && mf_recon_texel_side(r) == side[1]);
            mf_recon_free(r);
            o.tex_auto_min = 512, o.tex_auto_max = 256;
            CHECK_ERR(mf_recon_new(&mesh, v, NV, &o, &r), "tex_auto_min");
        }
        for (int i = 0; i < NV; ++i) mf_image_free(&v[i].ref);
    }
    /* twice the pixels per side: twice the texels per side */
    CHECK_MSG(fabs(side[1] / side[0] - 2.0) < 0.1, "sides %g at 32 px, %g at 64 px", side[0], side[1]);
    /* at 64 px fx = 64 / (2 tan(0.3456)) = 88.9 px; the sphere's nearest point is 1.3 away, where
     * a world unit spans 68.4 px (4676 px^2 per unit^2); at its equator one unit of UV area is
     * 2 pi^2 r^2 = 4.93 unit^2 of surface: s = sqrt(4676 * 4.93) = 152 facing the camera, less
     * where foreshortened. The median (measured 72) must lie well inside. */
    CHECK_MSG(side[1] > 40.0 && side[1] < 152.0, "side %g at 64 px", side[1]);
    mf_rtscene_free(rt);
    mf_mesh_free(&mesh);
}

/* ---- env coverage (env_auto) ---- */

MF_TEST(inverse_budget_env_coverage) {
    /* a flat quad (z = 0, normal +z) seen from straight above reflects the view rays back up:
     * only texels near the zenith are seen; with the sphere's 8 views almost every texel is */
    char path[MF_PATH_MAX];
    mf_test_path_to(path, sizeof path, "envcov_quad.obj");
    put(path, k_quad);
    MfMesh quad, sphere;
    CHECK_OK(mf_obj_read(path, &quad));
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&quad, &rt));
    MfReconView v[NV];
    memset(v, 0, sizeof v);
    CHECK_OK(look_cam(&v[0].cam, 16, 16, mf_v3(0.01f, 0.0f, 2.0f), mf_v3(0, 0, 0)));
    enum { W = 16, H = 8 };
    unsigned char cover[W * H];
    size_t n0 = mf_budget_env_coverage(rt, v, 1, NULL, W, H, 0, cover);
    int top_only = 1;
    for (int i = W; i < W * H; ++i) top_only &= !cover[i];
    CHECK_MSG(n0 > 0 && top_only, "%zu texels marked, all in the top row: %d", n0, top_only);
    size_t n1 = mf_budget_env_coverage(rt, v, 1, NULL, W, H, 1, cover);
    CHECK_MSG(n1 > n0 && n1 <= 2 * W && !cover[2 * W], "dilated: %zu (undilated %zu)", n1, n0);
    unsigned char skip = 1;
    CHECK(mf_budget_env_coverage(rt, v, 1, &skip, W, H, 1, cover) == 0);
    mf_rtscene_free(rt);
    /* the sphere seen from 8 directions: its mirror reflections reach (nearly) every direction */
    CHECK_OK(mf_shape_uv_sphere(&sphere, mf_v3(0, 0, 0), 0.5f, 16, 8));
    CHECK_OK(sphere_views(&sphere, 24, 0.0f, v));
    CHECK_OK(mf_rtscene_new(&sphere, &rt));
    size_t ns = mf_budget_env_coverage(rt, v, NV, NULL, W, H, 0, cover);
    CHECK_MSG(ns > W * H * 9 / 10, "sphere: %zu of %d texels", ns, W * H);
    mf_rtscene_free(rt);
    /* mf_recon_new measures it with env_auto; the flag does not change a run where all is seen */
    MfReconOpts o = tiny_opts();
    o.env_auto = 1, o.env_auto_dilate = 1;
    MfRecon *r = NULL;
    CHECK_OK(mf_recon_new(&sphere, v, NV, &o, &r));
    CHECK(r && mf_recon_env_covered(r) > 0.9 && mf_recon_env_covered(r) <= 1.0);
    mf_recon_free(r);
    for (int i = 0; i < NV; ++i) mf_image_free(&v[i].ref);
    /* the quad from above, 2 views: with env_auto the directions it does not reflect end smoother */
    CHECK_OK(mf_rtscene_new(&quad, &rt));
    MfEnvMap env;
    CHECK_OK(mf_env_init_constant(&env, 16, 8, mf_v3s(0.8f)));
    MfTexMaterial mat = {.kd = NULL, .orm = NULL, .kd_const = mf_v3(0.6f, 0.4f, 0.2f), .orm_const = mf_v3(1.0f, 0.3f, 0.0f), .normal = NULL};
    MfRenderInput in = {rt, &quad, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = 2, .pixel_samples = 1, .seed = 7, .lobes = MF_LOBE_ALL};
    double tv[2];
    for (int k = 0; k < 2; ++k) {
        MfReconView q[2];
        memset(q, 0, sizeof q);
        CHECK_OK(ref_view(&in, &ro, 16, mf_v3(0.01f, 0.0f, 2.0f), &q[0]));
        CHECK_OK(ref_view(&in, &ro, 16, mf_v3(0.3f, 0.2f, 1.9f), &q[1]));
        o = tiny_opts();
        o.spp_sqrt = 2, o.iters = 30, o.env_auto = k;
        char dir[MF_PATH_MAX];
        mf_test_path_to(dir, sizeof dir, k ? "envcov_on" : "envcov_off");
        CHECK(mf_budget_env_coverage(rt, q, 2, NULL, 16, 8, 1, cover) < 16 * 8 / 2);
        CHECK_OK(mf_recon_new(&quad, q, 2, &o, &r));
        CHECK_OK(mf_recon_run(r, NULL, dir));
        /* the spread of the upper hemisphere's unseen texels: the diffuse light's noisy gradients
         * reach them (the lower hemisphere gets none and stays at its start) */
        const float *e = mf_recon_block(r, MF_BLOCK_ENV)->p;
        double s1 = 0, s2 = 0;
        int m = 0;
        for (int i = 0; i < 16 * 4; ++i)
            if (!cover[i]) s1 += e[3 * i], s2 += (double)e[3 * i] * e[3 * i], m++;
        tv[k] = m ? sqrt(fmax(s2 / m - (s1 / m) * (s1 / m), 0.0)) : 0.0;
        mf_recon_free(r);
    }
    CHECK_MSG(tv[1] < 0.5 * tv[0] && tv[0] > 0.0, "spread of the unseen upper texels: %g with env_auto, %g without", tv[1], tv[0]);
    mf_env_free(&env);
    mf_rtscene_free(rt);
    mf_mesh_free(&quad), mf_mesh_free(&sphere);
}

/* ---- samples per pixel that grow as the loss stops falling (spp_grow) ---- */

/* A run of o stopped at `stop` iterations in the test folder `name` (its checkpoint path into ck),
 * then a fresh reconstruction with o resumed from that checkpoint (not yet run). */
static MfRecon *stopped_and_resumed(const MfMesh *mesh, const MfReconOpts *o, int stop, const char *name, char *dir,
                                    size_t dcap, char *ck, size_t ckcap) {
    MfReconOpts oh = *o;
    oh.iters = stop;
    mf_test_path_to(dir, dcap, name);
    MfRecon *h = recon_of(mesh, 0.0f, &oh);
    CHECK_OK(mf_recon_run(h, NULL, dir));
    mf_recon_free(h);
    h = recon_of(mesh, 0.0f, o);
    snprintf(ck, ckcap, "%s/checkpoint.mfck", dir);
    CHECK_OK(mf_recon_load_checkpoint(h, ck));
    return h;
}

MF_TEST(inverse_budget_spp_grow_rule_and_resume) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = tiny_opts();
    o.iters = 24, o.spp_grow = 1, o.spp_grow_window = 4, o.spp_grow_max = 3, o.checkpoint_every = 4;
    o.spp_grow_tol = 1.0f; /* any window whose loss fell by less than 100% grows it */
    MfRecon *r = recon_of(&mesh, 0.0f, &o);
    char dir[512], hd[512], ck[1024];
    mf_test_path_to(dir, sizeof dir, "sppgrow_full");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    const int *at;
    int n, spp = mf_recon_spp_now(r, &at, &n);
    /* the first window sets the reference; windows 2 and 3 grow 1 -> 2 -> 3 (the cap) */
    CHECK_MSG(spp == 3 && n == 2 && at[0] == 8 && at[1] == 12, "spp %d, %d growths (first at %d)", spp, n, n ? at[0] : -1);
    /* stopped at 10 (checkpoints at 8, every 4, and at the end, mid-window) and resumed: the rest is
     * bit-identical */
    MfRecon *h = stopped_and_resumed(&mesh, &o, 10, "sppgrow_half", hd, sizeof hd, ck, sizeof ck);
    CHECK(mf_recon_iteration(h) == 10 && mf_recon_spp_now(h, NULL, NULL) == 2);
    CHECK_OK(mf_recon_run(h, NULL, hd));
    int nh, spph = mf_recon_spp_now(h, &at, &nh);
    CHECK(spph == 3 && nh == 2 && at[0] == 8 && at[1] == 12);
    check_same_blocks(r, h);
    mf_recon_free(h);
    mf_recon_free(r);
    /* off: the level stays at --spp */
    o.spp_grow = 0, o.iters = 12;
    r = recon_of(&mesh, 0.0f, &o);
    mf_test_path_to(dir, sizeof dir, "sppgrow_off");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    int n0, s0 = mf_recon_spp_now(r, NULL, &n0);
    CHECK(s0 == o.spp_sqrt && n0 == 0);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* ---- env_res_auto ---- */

MF_TEST(inverse_budget_env_width) {
    enum { N = 10 };
    float orm[N * 3];
    unsigned char vis[N];
    double rough;
    for (int i = 0; i < N; ++i) orm[3 * i] = 1.0f, orm[3 * i + 1] = 0.7f, orm[3 * i + 2] = 0.0f, vis[i] = 1;
    /* 0.7: alpha 0.49, lobe 4 atan(0.315) = 1.22 rad, 2 texels across it at W >= 10.3: 64 -> 16 */
    CHECK(fabs(mf_budget_lobe_fwhm(0.7f) - 4.0 * atan(0.6436 * 0.49)) < 1e-6);
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 16 && fabs(rough - 0.7) < 1e-6);
    /* 0.3: alpha 0.09, lobe 0.231 rad, W >= 54.3: 64 kept */
    for (int i = 0; i < N; ++i) orm[3 * i + 1] = 0.3f;
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 64);
    /* the texels no view sees do not count: a mirror texel out of sight leaves 16 */
    for (int i = 0; i < N; ++i) orm[3 * i + 1] = i ? 0.7f : 0.08f, vis[i] = i != 0;
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 16);
    /* ... but seen, it counts: one in ten moves the 10th percentile (GSL's, interpolated) to
     * 0.1 x 0.08 + 0.9 x 0.7 = 0.638 (still 16); two set it at 0.08 and keep all 64 */
    vis[0] = 1;
    CHECK_MSG(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 16 && fabs(rough - 0.638) < 1e-5, "rough %g", rough);
    orm[3 * 1 + 1] = 0.08f;
    CHECK_MSG(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 64 && fabs(rough - 0.08) < 1e-6, "rough %g", rough);
    /* roughness 1 (lobe 2.29 rad, W >= 5.5): the floor w_min, and an odd height stops the halving */
    for (int i = 0; i < N; ++i) orm[3 * i + 1] = 1.0f;
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 16, &rough) == 16);
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 8);
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 6, 4, &rough) == 32);
    /* nothing visible: the cap, rough -1 */
    memset(vis, 0, sizeof vis);
    CHECK(mf_budget_env_width(orm, vis, N, 0.1, 64, 32, 4, &rough) == 64 && rough == -1.0);
    /* the shrink: 4x2 texels of value x + 10 y + 100 c, by 2: the means of 2x2 blocks */
    float src[2 * 4 * 3], dst[1 * 2 * 3];
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x)
            for (int c = 0; c < 3; ++c) src[(y * 4 + x) * 3 + c] = (float)(x + 10 * y + 100 * c);
    mf_budget_env_shrink(src, 4, 2, 2, dst);
    for (int x = 0; x < 2; ++x)
        for (int c = 0; c < 3; ++c) CHECK(dst[x * 3 + c] == (float)(2 * x + 0.5 + 5 + 100 * c));
}

MF_TEST(inverse_budget_env_res_auto_and_resume) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = tiny_opts();
    /* rough start (0.9: lobe 1.94 rad, W >= 6.5) tested after 2 iterations: 64x32 -> 8x4 */
    o.env_w = 64, o.env_h = 32, o.init_rough = 0.9f, o.iters = 10, o.checkpoint_every = 4;
    o.env_res_auto = 1, o.env_res_warmup = 2, o.env_res_min = 8;
    MfRecon *r = recon_of(&mesh, 0.0f, &o);
    char dir[512], hd[512], ck[1024];
    mf_test_path_to(dir, sizeof dir, "envres_full");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    double rough;
    int w = mf_recon_env_res(r, &rough);
    const MfParamBlock *env = mf_recon_block(r, MF_BLOCK_ENV);
    CHECK_MSG(w == 8 && mf_recon_opts(r)->env_w == 8 && mf_recon_opts(r)->env_h == 4 && env->n == 8 * 4 * 3 &&
                  mf_recon_env(r)->img.w == 8 && rough > 0.8 && rough < 1.0,
              "width %d (rough %g), env block of %zu", w, rough, env->n);
    /* stopped at 6 (after the choice) and resumed: the checkpoint holds the 8x4 env; bit-identical */
    MfRecon *h = stopped_and_resumed(&mesh, &o, 6, "envres_half", hd, sizeof hd, ck, sizeof ck);
    CHECK(mf_recon_iteration(h) == 6 && mf_recon_env_res(h, NULL) == 8 && mf_recon_opts(h)->env_w == 8);
    CHECK_OK(mf_recon_run(h, NULL, hd));
    check_same_blocks(r, h);
    mf_recon_free(h);
    /* a checkpoint whose env is not a fraction of the run's is refused by name */
    MfReconOpts ob = o;
    ob.env_w = 60, ob.env_h = 30;
    h = recon_of(&mesh, 0.0f, &ob);
    CHECK(mf_recon_load_checkpoint(h, ck) == MF_EFORMAT && strstr(mf_error(), "not a fraction"));
    mf_recon_free(h);
    mf_recon_free(r);
    /* glossy (0.3: W >= 54): the env keeps its 64x32 */
    o.init_rough = 0.3f, o.iters = 4;
    r = recon_of(&mesh, 0.0f, &o);
    mf_test_path_to(dir, sizeof dir, "envres_keep");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    CHECK(mf_recon_env_res(r, NULL) == 64 && mf_recon_block(r, MF_BLOCK_ENV)->n == 64 * 32 * 3);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}
