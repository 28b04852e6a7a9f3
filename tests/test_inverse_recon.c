/* End-to-end tests of the inverse loop (mf/inverse/mf_recon): recovery of a known constant
 * albedo and a known environment map on a sphere, checkpoint/resume equivalence, and the
 * result folder's files. Ground truth is rendered by the forward renderer (mf_render). */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "inverse/mf_recon.h"
#include "mf_test.h"
#include "mf_test_recon.h"
#include "nn/mf_nn.h"
#include "io/mf_ckpt.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"

enum { RES = 32, NV = 8, EW = 16, EH = 8 };
static const float GT_KD[3] = {0.6f, 0.4f, 0.2f};

/* A bright sky above, a dim ground, and a brighter patch; neutral in colour, because colour
 * shared by albedo and light is ambiguous and the shading regulariser (nvdiffrecmc's)
 * resolves it toward white light. */
static void gt_env(MfImage *e) {
    mf_image_alloc(e, EW, EH, 3);
    for (int y = 0; y < EH; ++y)
        for (int x = 0; x < EW; ++x) {
            float *p = mf_image_px(e, x, y);
            int up = y < EH / 2;
            p[0] = p[1] = p[2] = up ? 1.0f : 0.3f;
            if (y == 2 && (x == 3 || x == 4)) p[0] = p[1] = p[2] = 6.0f;
        }
}

/* views (NV,), zeroed first: cameras around mesh and the renders of the GT material under gt_env. */
static int make_views(const MfMesh *mesh, MfReconView *views) {
    memset(views, 0, NV * sizeof *views);
    MfRtScene *rt = NULL;
    int rc = mf_rtscene_new(mesh, &rt);
    if (rc) return rc;
    MfImage e;
    gt_env(&e);
    MfEnvMap env;
    if ((rc = mf_env_init(&env, &e))) return rc;
    MfTexMaterial mat = {.kd = NULL, .orm = NULL, .kd_const = mf_v3(GT_KD[0], GT_KD[1], GT_KD[2]), .orm_const = mf_v3(1.0f, 0.7f, 0.0f), .normal = NULL};
    MfRenderInput in = {rt, mesh, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = 8, .pixel_samples = 4, .seed = 99, .lobes = MF_LOBE_ALL};
    for (int v = 0; v < NV && !rc; ++v) {
        float az = 2.0f * MF_PI * v / NV, el = (v % 2 ? 0.6f : -0.6f); /* both hemispheres observed */
        MfVec3 eye = mf_v3(1.8f * cosf(az) * cosf(el), 1.8f * sinf(az) * cosf(el), 1.8f * sinf(el));
        rc = ref_view(&in, &ro, RES, eye, &views[v]);
    }
    mf_env_free(&env);
    mf_rtscene_free(rt);
    return rc;
}

static MfReconOpts small_opts(void) {
    MfReconOpts o = mf_recon_opts_default();
    o.iters = 160;
    o.batch = 2;
    o.tex_res = 8;
    o.env_w = EW;
    o.env_h = EH;
    o.lr = 0.03f;
    o.snapshot_every = 80;
    o.checkpoint_every = 40;
    return o;
}

/* small_opts for `iters` iterations, without checkpoints or snapshots. */
static MfReconOpts short_opts(int iters) {
    MfReconOpts o = small_opts();
    o.iters = iters;
    o.checkpoint_every = 0;
    o.snapshot_every = 0;
    return o;
}

/* A reconstruction of mesh from fresh make_views views with options o (both checked); NULL on
 * failure. */
static MfRecon *recon_of(const MfMesh *mesh, const MfReconOpts *o) {
    MfReconView v[NV];
    MfRecon *r = NULL;
    CHECK_OK(make_views(mesh, v));
    CHECK_OK(mf_recon_new(mesh, v, NV, o, &r));
    return r;
}

/* Recovery of the albedo (up to scale) and the env map's hemispheres; denoise: with the
 * bilateral denoiser of the demodulated light (mf_denoise.h). */
static void check_recovery(int denoise) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 24, 12));
    MfReconView views[NV];
    CHECK_OK(make_views(&mesh, views));
    MfReconOpts o = small_opts();
    o.denoise = denoise;
    MfRecon *r = NULL;
    CHECK_OK(mf_recon_new(&mesh, views, NV, &o, &r));
    if (!r) return;
    const char *dir = mf_test_path(denoise ? "recon_denoise" : "recon");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    /* albedo and light are determined only up to a common scale: fit it on the albedo */
    MfImage kd = mf_recon_kd_image(r);
    double mean[3] = {0, 0, 0};
    for (int i = 0; i < kd.w * kd.h; ++i)
        for (int c = 0; c < 3; ++c) mean[c] += kd.data[3 * i + c] / (kd.w * kd.h);
    double s = (mean[0] * GT_KD[0] + mean[1] * GT_KD[1] + mean[2] * GT_KD[2]) /
               (mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
    double kerr = 0;
    for (int c = 0; c < 3; ++c) kerr = fmax(kerr, fabs(s * mean[c] - GT_KD[c]) / GT_KD[c]);
    MfImage ge;
    gt_env(&ge);
    const MfParamBlock *env = mf_recon_block(r, MF_BLOCK_ENV);
    /* env: compare the upper and lower hemispheres' mean radiance (what a diffuse sphere sees) */
    double up[3] = {0}, lo[3] = {0}, gup[3] = {0}, glo[3] = {0};
    for (int y = 0; y < EH; ++y)
        for (int x = 0; x < EW; ++x)
            for (int c = 0; c < 3; ++c) {
                double v = env->p[(y * EW + x) * 3 + c] * mf_recon_exposure(r) / s, g = mf_image_px(&ge, x, y)[c];
                if (y < EH / 2) up[c] += v, gup[c] += g;
                else lo[c] += v, glo[c] += g;
            }
    double eup = 0, elo = 0;
    for (int c = 0; c < 3; ++c) eup = fmax(eup, fabs(up[c] - gup[c]) / gup[c]), elo = fmax(elo, fabs(lo[c] - glo[c]) / glo[c]);
    if (getenv("MF_TEST_VERBOSE"))
        printf("    albedo scale %.3f, albedo rel err %.4f, env upper %.3f, lower %.3f\n", s, kerr, eup, elo);
    /* Measured (160 iterations): albedo 1%, upper hemisphere 0-5%, lower hemisphere 20-25%;
     * with the denoiser (sigma 2, decorrelated kd adjoint) 0.5%, 3%, 20% (with the primal's
     * light in kd's adjoint, as nvdiffrecmc: 4.5%, 16%, 44%, which fails these bounds).
     * The ground is seen only by the sphere's lower half at grazing angles from the cameras
     * below, so its texels stay partly at their initial value: a limit of these views, not of
     * the optimiser (the upper hemisphere, well observed, converges). */
    CHECK_MSG(kerr < 0.05, "albedo relative error %.3f (scale-aligned)", kerr);
    CHECK_MSG(eup < 0.10, "upper-hemisphere env relative error %.3f", eup);
    CHECK_MSG(elo < 0.40, "lower-hemisphere env relative error %.3f", elo);
    const char *files[] = {"albedo.png", "orm.png", "env.exr", "mesh.obj", "scene.glb", "log.csv", "checkpoint.mfck",
                           "snapshots/iter_00080/albedo.png"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i) {
        char p[1024];
        snprintf(p, sizeof p, "%s/%s", dir, files[i]);
        CHECK_MSG(mf_file_exists(p), "missing %s", files[i]);
    }
    mf_image_free(&ge);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

MF_TEST(inverse_recon_recovers_albedo_and_light) { check_recovery(0); }
MF_TEST(inverse_recon_denoised_recovers_albedo_and_light) { check_recovery(1); }

/* A run resumed from a checkpoint reaches the bytes of an uninterrupted run. */
static void check_resume(int denoise) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(12);
    o.denoise = denoise;
    o.normal_map = 1; /* every block, the normal map's included, must resume exactly */
    MfRecon *full = recon_of(&mesh, &o), *half = NULL;
    const char *full_dir = mf_test_path(denoise ? "full_dn" : "full"), *half_dir = mf_test_path(denoise ? "half_dn" : "half");
    char hd[512], fd[512];
    snprintf(hd, sizeof hd, "%s", half_dir);
    snprintf(fd, sizeof fd, "%s", full_dir);
    CHECK_OK(mf_recon_run(full, NULL, fd));
    MfReconOpts oh = o;
    oh.iters = 5;
    half = recon_of(&mesh, &oh);
    CHECK_OK(mf_recon_run(half, NULL, hd));
    mf_recon_free(half);
    half = NULL;
    /* a new process would start here: fresh state, then the checkpoint */
    half = recon_of(&mesh, &o);
    char ck[1024];
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", hd);
    CHECK_OK(mf_recon_load_checkpoint(half, ck));
    CHECK(mf_recon_iteration(half) == 5);
    CHECK_OK(mf_recon_run(half, NULL, hd));
    for (int b = 0; full && half && b < MF_NBLOCKS; ++b) CHECK(mf_recon_block(full, b)->n > 0);
    const char *d = full && half ? first_diff_block(full, half) : NULL;
    CHECK_MSG(!d, "block %s differs after resume", d);
    if (full) { /* the normal map moved away from flat, and was written with the result */
        const MfParamBlock *nb = mf_recon_block(full, MF_BLOCK_NORMAL);
        double dev = 0;
        for (size_t i = 0; i < nb->n; ++i) dev = fmax(dev, fabs(nb->p[i] - (i % 3 == 2 ? 1.0f : 0.5f)));
        CHECK(dev > 1e-4);
        char np[1024];
        snprintf(np, sizeof np, "%s/normal.png", fd);
        CHECK(mf_file_exists(np));
    }
    /* the resumed log has one row per iteration, 1..12 */
    char lp[1024], *log = NULL;
    snprintf(lp, sizeof lp, "%s/log.csv", hd);
    CHECK_OK(mf_read_file(lp, &log, NULL));
    int rows = 0;
    for (char *c = log; c && *c; ++c) rows += *c == '\n';
    CHECK(rows == 13);
    free(log);
    /* a checkpoint from other sizes is refused */
    MfReconOpts ob = o;
    ob.tex_res = 16;
    MfRecon *bad = recon_of(&mesh, &ob);
    CHECK_ERR(mf_recon_load_checkpoint(bad, ck), "shape mismatch");
    mf_recon_free(bad);
    mf_recon_free(full);
    mf_recon_free(half);
    mf_mesh_free(&mesh);
}

MF_TEST(inverse_recon_resume_is_exact) { check_resume(0); }
MF_TEST(inverse_recon_denoised_resume_is_exact) { check_resume(1); }

/* A reconstruction (denoiser and normal map on) is the same bits at 1 and 3 OpenMP threads, so
 * results compare across machines with other core counts. */
MF_TEST(inverse_recon_thread_count_independent) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(8);
    o.denoise = 1;
    o.normal_map = 1;
    MfRecon *r[2] = {NULL, NULL};
    int keep = omp_get_max_threads();
    for (int k = 0; k < 2; ++k) {
        char dir[1024];
        mf_test_path_to(dir, sizeof dir, "threads%d", k);
        omp_set_num_threads(k ? 3 : 1);
        r[k] = recon_of(&mesh, &o);
        if (r[k]) CHECK_OK(mf_recon_run(r[k], NULL, dir));
    }
    omp_set_num_threads(keep);
    const char *d = r[0] && r[1] ? first_diff_block(r[0], r[1]) : NULL;
    CHECK_MSG(!d, "block %s differs between 1 and 3 threads", d);
    mf_recon_free(r[0]), mf_recon_free(r[1]);
    mf_mesh_free(&mesh);
}

/* A hook that poisons one gradient at iteration 4. */
static int nan_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    (void)ctx, (void)batch, (void)nb;
    *loss = 0.0;
    if (it == 4) mf_recon_block(r, MF_BLOCK_KD)->g[5] = NAN;
    return MF_OK;
}

MF_TEST(inverse_recon_nan_gradient_stops_cleanly) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(8);
    o.checkpoint_every = 2;
    o.max_recoveries = 0; /* stop at the first event */
    MfRecon *r = recon_of(&mesh, &o);
    if (!r) return;
    const char *dir = mf_test_path("nanrun");
    MfReconHook hook = {nan_hook, NULL};
    CHECK_ERR(mf_recon_run(r, &hook, dir), "stopping after 0 recoveries (learning rate x1); the last good checkpoint is");
    CHECK_MSG(strstr(mf_error(), "iteration 4: parameter block kd: gradient of element 5 is nan"), "%s", mf_error());
    CHECK(mf_recon_iteration(r) == 4);
    /* no texture was written from the bad state, the checkpoint of iteration 4 is there and finite */
    char p[1024];
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    CHECK(!mf_file_exists(p));
    snprintf(p, sizeof p, "%s/checkpoint.mfck", dir);
    CHECK(mf_file_exists(p));
    const MfParamBlock *kd = mf_recon_block(r, MF_BLOCK_KD);
    for (size_t i = 0; i < kd->n; ++i) CHECK(isfinite(kd->p[i]));
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* The guard recovers from a NaN gradient: the state before it comes back, the learning rate is
 * cut, the run finishes, and the recovery is recorded. */
MF_TEST(inverse_recon_guard_recovers_nan_gradient) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(8);
    MfRecon *r = recon_of(&mesh, &o);
    if (!r) return;
    MfReconHook hook = {nan_hook, NULL};
    CHECK_OK(mf_recon_run(r, &hook, mf_test_path("nanrecover")));
    int n = 0;
    const MfReconRecovery *rec = mf_recon_recoveries(r, &n);
    CHECK(n == 1);
    if (n == 1) {
        CHECK(rec[0].iter == 4);
        CHECK_MSG(strstr(rec[0].reason, "kd: gradient of element 5 is nan"), "%s", rec[0].reason);
        CHECK_NEAR(rec[0].lr_scale, MF_RECON_RECOVERY_LR, 1e-9);
    }
    CHECK_NEAR(mf_recon_lr_scale(r), MF_RECON_RECOVERY_LR, 1e-9);
    CHECK(mf_recon_iteration(r) == 8);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* Reads log.csv's loss_total column into loss (at most cap rows); returns the row count. */
static int read_losses(const char *dir, double *loss, int cap) {
    char p[1024], *text = NULL;
    snprintf(p, sizeof p, "%s/log.csv", dir);
    if (mf_read_file(p, &text, NULL)) return 0;
    int n = 0;
    char *save = NULL;
    for (char *ln = strtok_r(text, "\n", &save); ln && n < cap; ln = strtok_r(NULL, "\n", &save)) {
        int it;
        double wall, l;
        if (sscanf(ln, "%d,%lf,%lf", &it, &wall, &l) == 3) loss[n++] = l;
    }
    free(text);
    return n;
}

/* --lr 10 sends the loss up by orders of magnitude (measured: 0.031 -> 12.3 on a tiny scene
 * before the guard). The guard notices it, restores the best state with a lower learning rate
 * and the run ends near its best loss instead of far above it. */
MF_TEST(inverse_recon_guard_recovers_lr_blowup) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(60);
    o.lr = 1.0f; /* the top of lr's range */
    MfRecon *r = recon_of(&mesh, &o);
    if (!r) return;
    const char *dir = mf_test_path("lr10");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    int n = 0;
    const MfReconRecovery *rec = mf_recon_recoveries(r, &n);
    CHECK_MSG(n >= 1 && n <= o.max_recoveries, "%d recoveries", n);
    if (n >= 1) CHECK_MSG(strstr(rec[0].reason, "running minimum"), "%s", rec[0].reason);
    CHECK(mf_recon_lr_scale(r) < 1.0f);
    double loss[128];
    int rows = read_losses(dir, loss, 128);
    CHECK(rows == 60);
    double lo = 1e30;
    for (int i = 0; i < rows; ++i) lo = fmin(lo, loss[i]);
    /* the last 10 iterations stay within the guard's band around the best loss */
    for (int i = rows - 10; i >= 0 && i < rows; ++i) CHECK_MSG(loss[i] <= o.div_factor * lo, "loss[%d] %g, best %g", i, loss[i], lo);
    mf_recon_free(r);
    mf_mesh_free(&mesh);
}

/* A hook that adds a finite but huge gradient (1e30) to a few kd elements from iteration 3 on:
 * g^2 overflows Adam's second moments to +Inf (as --init-light 1e30 did before that option got
 * its range). */
static int huge_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    (void)ctx, (void)batch, (void)nb;
    *loss = 0.0;
    if (it >= 3)
        for (int i = 0; i < 6; ++i) mf_recon_block(r, MF_BLOCK_KD)->g[i] += 1e30f;
    return MF_OK;
}

/* Before the guard, overflowing Adam moments (+Inf) were written into checkpoint.mfck. Now the run
 * recovers or stops, and every checkpoint written holds finite values only (it loads: loading
 * refuses non-finite ones). */
MF_TEST(inverse_recon_guard_keeps_inf_out_of_checkpoints) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(8);
    o.checkpoint_every = 1;
    MfRecon *r = recon_of(&mesh, &o), *r2 = NULL;
    if (!r) return;
    char dir[512], ck[1024];
    mf_test_path_to(dir, sizeof dir, "init1e30");
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", dir);
    MfReconHook huge = {huge_hook, NULL};
    int rc = mf_recon_run(r, &huge, dir);
    int n = 0;
    mf_recon_recoveries(r, &n);
    CHECK(n >= 1);
    if (rc) CHECK_MSG(strstr(mf_error(), "stopping after"), "%s", mf_error());
    char bad0[96];
    CHECK_MSG(!mf_params_find_nonfinite(mf_recon_block(r, 0), 3, bad0, sizeof bad0), "in memory: %s", bad0);
    CHECK(mf_file_exists(ck)); /* checkpoints were written between the recoveries */
    r2 = recon_of(&mesh, &o);
    if (r2) {
        CHECK_OK(mf_recon_load_checkpoint(r2, ck));
        char bad[96];
        CHECK_MSG(!mf_params_find_nonfinite(mf_recon_block(r2, 0), 3, bad, sizeof bad), "%s", bad);
    }
    mf_recon_free(r);
    mf_recon_free(r2);
    mf_mesh_free(&mesh);
}

/* --resume refuses a checkpoint that holds a NaN or Inf, naming the tensor and element. */
MF_TEST(inverse_recon_resume_refuses_nonfinite_checkpoint) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(2);
    MfRecon *r = recon_of(&mesh, &o), *r2 = NULL;
    if (!r) return;
    char dir[512], ck[1024];
    mf_test_path_to(dir, sizeof dir, "ckbad");
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", dir);
    CHECK_OK(mf_recon_run(r, NULL, dir));
    /* the checkpoint's table, as mf_recon writes it: per block p, m, v */
    MfTensorSpec specs[9];
    static const char *part[3] = {"p", "m", "v"};
    for (int b = 0; b < 3; ++b)
        for (int k = 0; k < 3; ++k) {
            int shape[1] = {(int)mf_recon_block(r, b)->n};
            mf_spec_set(&specs[b * 3 + k], mf_recon_block(r, b)->name, part[k], 1, shape);
        }
    size_t total = mf_specs_numel(specs, 9);
    float *buf = malloc(total * sizeof(float));
    char *meta = NULL;
    CHECK_OK(mf_ckpt_load(ck, specs, 9, buf, &meta));
    size_t nkd = mf_recon_block(r, MF_BLOCK_KD)->n, norm = mf_recon_block(r, MF_BLOCK_ORM)->n;
    buf[3 * nkd + 2 * norm + 7] = NAN; /* orm.v[7] */
    CHECK_OK(mf_ckpt_save(ck, specs, 9, buf, meta));
    r2 = recon_of(&mesh, &o);
    if (r2) {
        CHECK_ERR(mf_recon_load_checkpoint(r2, ck), "tensor orm.v element 7 is nan");
        CHECK(mf_recon_iteration(r2) == 0); /* nothing taken from it */
    }
    free(buf);
    free(meta);
    mf_recon_free(r);
    mf_recon_free(r2);
    mf_mesh_free(&mesh);
}

/* Exposure: views scaled by 16 or 1/16 (a float loader's input at another exposure) give the same
 * optimisation bit for bit (the loop works on views divided by a power of two near their mean
 * radiance), and env.exr comes out scaled by the same factor. */
MF_TEST(inverse_recon_exposure_invariant) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    static const float scales[3] = {1.0f, 16.0f, 1.0f / 16.0f};
    MfRecon *r[3] = {NULL, NULL, NULL};
    MfReconOpts o = short_opts(6);
    for (int k = 0; k < 3; ++k) {
        MfReconView v[NV];
        CHECK_OK(make_views(&mesh, v));
        for (int i = 0; i < NV; ++i)
            for (size_t p = 0; p < (size_t)RES * RES; ++p)
                for (int c = 0; c < 3; ++c) v[i].ref.data[4 * p + c] *= scales[k];
        double mean = 0.0;
        float e = mf_recon_exposure_of(v, NV, &mean);
        CHECK(mean > 0.0 && e > 0.0f && frexpf(e, &(int){0}) == 0.5f); /* a power of two */
        CHECK(e <= 2.0f * (float)mean / MF_RECON_EXPOSURE_REF && e >= 0.5f * (float)mean / MF_RECON_EXPOSURE_REF);
        CHECK_OK(mf_recon_new(&mesh, v, NV, &o, &r[k]));
        char dir[64];
        snprintf(dir, sizeof dir, "expo%d", k);
        if (r[k]) CHECK_OK(mf_recon_run(r[k], NULL, mf_test_path(dir)));
    }
    if (r[0] && r[1] && r[2]) {
        CHECK(mf_recon_exposure(r[1]) == 16.0f * mf_recon_exposure(r[0]));
        CHECK(mf_recon_exposure(r[2]) * 16.0f == mf_recon_exposure(r[0]));
        for (int k = 1; k < 3; ++k)
            for (int b = 0; b < 3; ++b) {
                const MfParamBlock *x = mf_recon_block(r[0], b), *y = mf_recon_block(r[k], b);
                CHECK_MSG(!memcmp(x->p, y->p, x->n * sizeof(float)), "block %s differs at scale %g", x->name, scales[k]);
            }
        /* env.exr in the views' units */
        for (int k = 0; k < 3; ++k) {
            char p[1024];
            mf_test_path_to(p, sizeof p, "%s/env.exr", k == 0 ? "expo0" : k == 1 ? "expo1" : "expo2");
            MfImage e = {0};
            CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &e));
            const MfParamBlock *eb = mf_recon_block(r[k], MF_BLOCK_ENV);
            if (e.data)
                for (size_t i = 0; i < eb->n; ++i)
                    if (e.data[i] != eb->p[i] * mf_recon_exposure(r[k])) {
                        CHECK_MSG(0, "env.exr[%zu] = %g, block %g x exposure %g", i, e.data[i], eb->p[i], mf_recon_exposure(r[k]));
                        break;
                    }
            mf_image_free(&e);
        }
    }
    for (int k = 0; k < 3; ++k) mf_recon_free(r[k]);
    mf_mesh_free(&mesh);
}

/* Invalid options are refused by name, value and range (mf_recon_new). */
MF_TEST(inverse_recon_options_named_in_errors) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconView v[NV];
    CHECK_OK(make_views(&mesh, v));
    MfRecon *r = NULL;
    MfReconOpts o = small_opts();
    o.lr = -1.0f;
    CHECK_ERR(mf_recon_new(&mesh, v, NV, &o, &r), "--lr -1: outside the allowed range [0, 1]");
    o = small_opts();
    o.env_h = 1;
    CHECK_ERR(mf_recon_new(&mesh, v, NV, &o, &r), "--env-h 1: outside the allowed range [2, 4096]");
    o = small_opts();
    o.init_light = NAN;
    CHECK_ERR(mf_recon_new(&mesh, v, NV, &o, &r), "--init-light nan: outside the allowed range [0.01, 1000]");
    CHECK(r == NULL && v[0].ref.data != NULL); /* views untouched on failure */
    for (int i = 0; i < NV; ++i) mf_image_free(&v[i].ref);
    mf_mesh_free(&mesh);
}

/* Mean 1 - cos of the angle between m's vertex normals and the sphere's (radial) normals: 0 for a
 * sphere, whatever its radius (silhouettes carry no gradient here) and however its vertices slide
 * along it (the texture lookups' gradient moves them tangentially too). */
static double normal_error(const MfMesh *m) {
    double s = 0;
    for (int v = 0; v < m->nv; ++v) {
        const float *p = m->pos + 3 * v, *n = m->nrm + 3 * v;
        double lp = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
        s += 1.0 - ((double)p[0] * n[0] + (double)p[1] * n[1] + (double)p[2] * n[2]) / lp;
    }
    return s / m->nv;
}

/* --vertex-lr: a bumpy sphere's vertices move toward the sphere its views show (the normals turn
 * toward the sphere's: with the default Laplacian 0.0132 -> 0.0037 in 80 steps, with the image
 * term alone 0.0090), stay finite, and the copies split at UV seams move together; the result's
 * mesh.obj is the moved mesh; a normal map is refused. With the Laplacian's gradient negated the
 * error rises to 0.044. */
MF_TEST(inverse_recon_vertices_move) {
    MfMesh gt, bumpy;
    CHECK_OK(mf_shape_uv_sphere(&gt, mf_v3(0, 0, 0), 0.5f, 24, 12));
    CHECK_OK(mf_shape_uv_sphere(&bumpy, mf_v3(0, 0, 0), 0.5f, 24, 12));
    for (int v = 0; v < bumpy.nv; ++v) { /* a function of the position, so seam copies stay together */
        float *p = bumpy.pos + 3 * v, f = 1.0f + 0.06f * sinf(9.0f * p[0]) * sinf(7.0f * p[1] + 1.0f) * cosf(8.0f * p[2]);
        for (int k = 0; k < 3; ++k) p[k] *= f;
    }
    CHECK_OK(mf_mesh_compute_normals(&bumpy));
    MfReconView views[NV];
    CHECK_OK(make_views(&gt, views));
    MfReconOpts o = short_opts(80);
    o.vertex_lr = 5e-4f;
    MfRecon *r = NULL;
    double before = normal_error(&bumpy);
    CHECK_OK(mf_recon_new(&bumpy, views, NV, &o, &r));
    if (!r) return;
    const char *dir = mf_test_path("recon_vertices");
    CHECK_OK(mf_recon_run(r, NULL, dir));
    const MfMesh *m = mf_rtscene_mesh(mf_recon_rtscene(r));
    double after = normal_error(m), moved = 0;
    int finite = 1, apart = 0;
    for (int i = 0; i < 3 * m->nv; ++i) finite &= isfinite(m->pos[i]) != 0, moved = fmax(moved, fabs(m->pos[i] - bumpy.pos[i]));
    for (int a = 0; a < bumpy.nv; ++a)
        for (int b = a + 1; b < bumpy.nv; ++b)
            if (!memcmp(bumpy.pos + 3 * a, bumpy.pos + 3 * b, 3 * sizeof(float)))
                apart += memcmp(m->pos + 3 * a, m->pos + 3 * b, 3 * sizeof(float)) != 0;
    if (getenv("MF_TEST_VERBOSE")) printf("    normal error (1 - cos) %.5f -> %.5f, largest move %.4f\n", before, after, moved);
    CHECK_MSG(finite && apart == 0 && moved > 1e-3, "positions finite %d, %d seam copies apart, largest move %g", finite, apart, moved);
    CHECK_MSG(after < 0.5 * before, "normal error (1 - cos) %.5f -> %.5f: the bumps stayed", before, after);
    /* mesh.obj's first vertex is the moved one */
    char p[1024], line[256];
    float v0[3] = {NAN, NAN, NAN};
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    FILE *f = fopen(p, "r");
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "v %f %f %f", &v0[0], &v0[1], &v0[2]) == 3) break;
    if (f) fclose(f);
    CHECK_MSG(fabsf(v0[0] - m->pos[0]) < 1e-6f && fabsf(v0[1] - m->pos[1]) < 1e-6f && fabsf(v0[2] - m->pos[2]) < 1e-6f,
              "mesh.obj's first vertex (%g %g %g) is not the moved mesh's (%g %g %g)", v0[0], v0[1], v0[2], m->pos[0], m->pos[1], m->pos[2]);
    mf_recon_free(r);
    /* the image term alone (no Laplacian) turns the normals toward the views' sphere too: 0.0132 ->
     * 0.0090 when measured; with the vertex gradient's sign flipped it would not */
    MfReconView v2[NV];
    CHECK_OK(make_views(&gt, v2));
    o.vertex_laplacian = 0.0f;
    r = NULL;
    CHECK_OK(mf_recon_new(&bumpy, v2, NV, &o, &r));
    if (r) CHECK_OK(mf_recon_run(r, NULL, mf_test_path("recon_vertices_image")));
    double image_only = r ? normal_error(mf_rtscene_mesh(mf_recon_rtscene(r))) : NAN;
    if (getenv("MF_TEST_VERBOSE")) printf("    image term alone: normal error %.5f -> %.5f\n", before, image_only);
    CHECK_MSG(image_only < 0.85 * before, "image term alone: normal error %.5f -> %.5f", before, image_only);
    mf_recon_free(r);
    o.normal_map = 1;
    CHECK_ERR(mf_recon_new(&bumpy, v2, NV, &o, &r), "normal_map 1");
    for (int i = 0; i < NV; ++i) mf_image_free(&views[i].ref), mf_image_free(&v2[i].ref);
    mf_mesh_free(&gt), mf_mesh_free(&bumpy);
}

static int stop_hook(void *ctx, MfRecon *r, int it, const int *batch, int nb, double *loss) {
    (void)ctx, (void)r, (void)batch, (void)nb;
    *loss = 0.0;
    return it == 5 ? mf_fail(MF_EARG, "stopped by the test at iteration %d", it) : MF_OK;
}

/* --vertex-lr resumes exactly: a 12-iteration run stopped after its checkpoint at 5, a new recon
 * loading it, and the 7 more equal 12 in one run (every block and every vertex position, bit for bit); a checkpoint without positions is
 * refused by a run that moves vertices. With smoothed normals (--normal-smooth), which the resumed
 * run recomputes from the positions. */
MF_TEST(inverse_recon_vertices_resume_is_exact) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 16, 8));
    MfReconOpts o = short_opts(12);
    o.vertex_lr = 5e-4f;
    o.normal_smooth = 3;
    char hd[512], fd[512], ck[1024];
    snprintf(fd, sizeof fd, "%s", mf_test_path("vfull"));
    snprintf(hd, sizeof hd, "%s", mf_test_path("vhalf"));
    MfRecon *full = recon_of(&mesh, &o), *half = NULL;
    if (full) CHECK_OK(mf_recon_run(full, NULL, fd));
    /* the same 12-iteration run, stopped by its hook in iteration 6 after the checkpoint of 5 (the
     * Laplacian's weight follows it / iters, so a 5-iteration run would be another run) */
    MfReconOpts oh = o;
    oh.checkpoint_every = 5;
    half = recon_of(&mesh, &oh);
    MfReconHook stop = {.fn = stop_hook, .ctx = NULL};
    if (half) CHECK_ERR(mf_recon_run(half, &stop, hd), "stopped by the test");
    mf_recon_free(half);
    half = recon_of(&mesh, &o); /* a new process would start here */
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", hd);
    if (half) CHECK_OK(mf_recon_load_checkpoint(half, ck));
    if (half) CHECK_OK(mf_recon_run(half, NULL, hd));
    const char *d = full && half ? first_diff_block(full, half) : NULL;
    CHECK_MSG(!d, "block %s differs after resume", d);
    if (full && half) {
        const MfMesh *a = mf_rtscene_mesh(mf_recon_rtscene(full)), *b = mf_rtscene_mesh(mf_recon_rtscene(half));
        double moved = 0;
        for (int i = 0; i < 3 * mesh.nv; ++i) moved = fmax(moved, fabs(a->pos[i] - mesh.pos[i]));
        CHECK_MSG(a->nv == b->nv && !memcmp(a->pos, b->pos, (size_t)a->nv * 3 * sizeof(float)) &&
                      !memcmp(a->nrm, b->nrm, (size_t)a->nv * 3 * sizeof(float)) && moved > 1e-4,
                  "vertex positions or normals differ after resume (largest move %g)", moved);
    }
    /* a checkpoint written without moving vertices holds no positions */
    MfReconOpts of = short_opts(3);
    MfRecon *fixed = recon_of(&mesh, &of);
    if (fixed) CHECK_OK(mf_recon_run(fixed, NULL, mf_test_path("vfixed")));
    mf_recon_free(fixed);
    snprintf(ck, sizeof ck, "%s/checkpoint.mfck", mf_test_path("vfixed"));
    MfRecon *moving = recon_of(&mesh, &o);
    if (moving) CHECK_ERR(mf_recon_load_checkpoint(moving, ck), "vertex_lr");
    mf_recon_free(moving);
    mf_recon_free(full);
    mf_recon_free(half);
    mf_mesh_free(&mesh);
}
