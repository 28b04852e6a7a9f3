/* mf_geom_fit (issue 14, T4): DMTet's mask term moves a marching-tets surface through the
 * antialiased silhouette gradients. A 32^3 grid whose SDF is a sphere of radius R0 fits the
 * masks of a sphere of radius R1 seen from 8 views (64 px); plus the regulariser's gradient and
 * an empty extraction.
 * Measured (MF_TEST_VERBOSE=1): mask loss 0.213 -> 0.004 in 100 steps; mean |r - R1| 0.25 ->
 * 0.036 (cell 0.0625), but only 82% of the vertices lie within a cell of R1: the rest are
 * interior bubbles (21 components) and pits, which silhouettes cannot see. With dL/dsdf negated
 * the loss rises to 0.35 and the checks on the loss and on the near fraction fail (the mean
 * radius error alone, 0.061, would not catch it). */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "geom/mf_meshproc.h"
#include "inverse/mf_geom_fit.h"
#include "inverse/mf_recon_geom.h"
#include "render/mf_antialias.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "mf_test.h"
#include "mf_test_geom.h"
#include "mf_test_grad.h"

enum { NVIEW = 8, IMG = 64, RES = 32, ITERS = 100 };
#define R0 0.45f
#define R1 0.7f
#define EXTENT 2.0f

/* 8 views at distance 3 around the z axis: even ones on the equator, odd ones 45 degrees above
 * and below it in turn */
static int make_cams(MfCamera *cams) {
    for (int v = 0; v < NVIEW; ++v) {
        double az = 2.0 * MF_PI * v / NVIEW, el = (v % 2 ? (v % 4 == 1 ? 1 : -1) * MF_PI / 4 : 0);
        MfVec3 eye = mf_v3((float)(3 * cos(el) * cos(az)), (float)(3 * cos(el) * sin(az)), (float)(3 * sin(el)));
        int rc = look_cam(&cams[v], IMG, IMG, eye, mf_v3(0, 0, 0));
        if (rc) return rc;
    }
    return 0;
}

/* target masks: the antialiased coverage of a fine UV sphere of radius R1 */
static int make_masks(const MfCamera *cams, MfImage *masks) {
    MfMesh s;
    MfRtScene *rt;
    int rc = mf_mesh_uv_sphere(&s, 128, 64, mf_v3(0, 0, 0), R1);
    if (rc) return rc;
    if ((rc = mf_rtscene_new(&s, &rt))) return rc;
    static float cov[IMG * IMG];
    for (int v = 0; v < NVIEW && !rc; ++v) {
        MfAa *a;
        if ((rc = mf_aa_new(rt, &cams[v], &a)) || (rc = mf_image_alloc(&masks[v], IMG, IMG, 1))) break;
        for (int i = 0; i < IMG * IMG; ++i) cov[i] = mf_aa_tri(a)[i] >= 0 ? 1.0f : 0.0f;
        mf_aa_forward(a, cov, 1, masks[v].data);
        mf_aa_free(a);
    }
    mf_rtscene_free(rt);
    mf_mesh_free(&s);
    return rc;
}

static void sphere_sdf(const MfTetGrid *g, float r, float *sdf) {
    for (size_t v = 0; v < mf_tetgrid_nverts(g); ++v) sdf[v] = r - mf_len(mf_tetgrid_base(g, v));
}

typedef struct {
    double mean, max; /* |radius - R1| over the vertices */
    double near;      /* fraction of vertices within a cell of R1 */
    int nv, comps;
} RadiusErr;

static void radius_stats(const MfMesh *m, float cell, RadiusErr *r) {
    double s = 0, mx = 0;
    int near = 0;
    for (int i = 0; i < m->nv; ++i) {
        const float *p = m->pos + 3 * i;
        double e = fabs(sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]) - R1);
        s += e;
        mx = fmax(mx, e);
        near += e <= cell;
    }
    r->mean = s / m->nv;
    r->max = mx;
    r->near = (double)near / m->nv;
    r->nv = m->nv;
}

/* radius errors of the extracted mesh (raw) and of its largest component (clean) */
static int radius_err(const MfTetGrid *g, const float *sdf, const float *deform, RadiusErr *raw, RadiusErr *clean) {
    MfTetMesh tm;
    int rc = mf_tetgrid_extract(g, sdf, deform, &tm);
    if (rc) return rc;
    radius_stats(&tm.mesh, g->cell, raw);
    MfManifoldInfo mi;
    if (!(rc = mf_mesh_manifold_check(&tm.mesh, &mi))) raw->comps = mi.components;
    if (!rc) rc = mf_mesh_drop_small_components(&tm.mesh, 0.5f, NULL);
    if (!rc) radius_stats(&tm.mesh, g->cell, clean), clean->comps = 1;
    mf_tetmesh_free(&tm);
    return rc;
}

/* 1 when log rows a and b (n,) agree in every field but the timing (rebuild_s), bit for bit */
static int same_rows(const MfGeomFitStep *a, const MfGeomFitStep *b, int n) {
    for (int i = 0; i < n; ++i)
        if (memcmp(&a[i].rgb, &b[i].rgb, sizeof a[i].rgb) || memcmp(&a[i].mask, &b[i].mask, sizeof a[i].mask) ||
            memcmp(&a[i].reg, &b[i].reg, sizeof a[i].reg) || a[i].nt != b[i].nt)
            return 0;
    return 1;
}

static void print_err(const char *what, const RadiusErr *r) {
    printf("    %s: %d vertices, %d components, |r - R1| mean %.4f max %.4f, %.1f%% within a cell\n", what, r->nv,
           r->comps, r->mean, r->max, 100 * r->near);
}

MF_TEST(inverse_geom_fit_sphere) {
    MfCamera cams[NVIEW];
    MfImage masks[NVIEW];
    memset(masks, 0, sizeof masks);
    CHECK_OK(make_cams(cams));
    CHECK_OK(make_masks(cams, masks));
    MfTetGrid g = mf_tetgrid_make(RES, mf_v3(0, 0, 0), EXTENT);
    size_t nv = mf_tetgrid_nverts(&g);
    float *sdf = malloc(nv * sizeof *sdf), *def = calloc(nv * 3, sizeof *def);
    sphere_sdf(&g, R0, sdf);
    RadiusErr e0 = {0}, c0 = {0}, e1 = {0}, c1 = {0};
    CHECK_OK(radius_err(&g, sdf, def, &e0, &c0));
    MfGeomFitOpts o = {.iters = ITERS, .lr_sdf = 0.01f, .lr_deform = 0.03f, .sdf_reg = 0.01f};
    MfGeomFitStep log[ITERS];
    int done = -1;
    CHECK_OK(mf_geom_fit(&g, sdf, def, cams, masks, NVIEW, &o, log, &done));
    CHECK(done == ITERS);
    CHECK_OK(radius_err(&g, sdf, def, &e1, &c1));
    if (getenv("MF_TEST_VERBOSE")) {
        for (int i = 0; i < ITERS; i += 10)
            printf("    step %3d: mask %.5f reg %.5f, %d triangles\n", i, log[i].mask, log[i].reg, log[i].nt);
        printf("    cell %.4f\n", (double)g.cell);
        RadiusErr er, cr;
        float *ref = malloc(nv * sizeof *ref);
        sphere_sdf(&g, R1, ref);
        if (!radius_err(&g, ref, NULL, &er, &cr)) print_err("the R1 sphere's own SDF", &er);
        free(ref);
        print_err("before", &e0);
        print_err("after", &e1);
        print_err("after, largest component", &c1);
    }
    CHECK_MSG(e1.mean < g.cell, "mean |radius - %.2f| after %d steps: %.4f (cell %.4f; before %.4f)", (double)R1, ITERS,
              e1.mean, (double)g.cell, e0.mean);
    CHECK_MSG(c1.near >= 0.75, "largest component: %.1f%% of its vertices within a cell of R1", 100 * c1.near);
    double l0 = log[0].mask, l1 = log[ITERS - 1].mask;
    CHECK_MSG(l1 < 0.2 * l0, "mask loss %.5f -> %.5f (want < 0.2x)", l0, l1);
    /* mostly decreasing: the last ten steps' mean below the mean of steps 10..19 */
    double a = 0, b = 0;
    for (int i = 0; i < 10; ++i) a += log[10 + i].mask, b += log[ITERS - 10 + i].mask;
    CHECK_MSG(b < a, "mask loss of the last 10 steps %.5f not below steps 10..19's %.5f", b / 10, a / 10);
    for (int v = 0; v < NVIEW; ++v) mf_image_free(&masks[v]);
    free(sdf);
    free(def);
}

/* references for the colour term: the R1 sphere rendered by mf_render (kd KD_REF, roughness 0.6,
 * metallic 0) under a constant env of radiance 2, 4 samples per pixel: RGBA, straight colour */
static const float KD_REF[3] = {0.7f, 0.3f, 0.2f};
static int make_rgba(const MfCamera *cams, MfImage *imgs) {
    MfMesh s;
    MfRtScene *rt = NULL;
    MfEnvMap env = {0};
    MfRenderOut out = {0};
    int rc = mf_mesh_uv_sphere(&s, 128, 64, mf_v3(0, 0, 0), R1);
    if (rc) return rc;
    if (!(rc = mf_rtscene_new(&s, &rt))) rc = mf_env_init_constant(&env, 16, 8, mf_v3s(2.0f));
    MfTexMaterial mat = {.kd_const = mf_v3(KD_REF[0], KD_REF[1], KD_REF[2]), .orm_const = mf_v3(1, 0.6f, 0)};
    MfRenderInput in = {rt, &s, &mat, 1, &env, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = 2, .pixel_samples = 4, .seed = 3, .lobes = MF_LOBE_ALL};
    for (int v = 0; v < NVIEW && !rc; ++v) {
        if ((rc = mf_render(&in, &cams[v], &ro, &out, NULL)) || (rc = mf_image_alloc(&imgs[v], IMG, IMG, 4))) break;
        for (int i = 0; i < IMG * IMG; ++i) {
            float a = out.alpha[i];
            for (int c = 0; c < 3; ++c) imgs[v].data[4 * i + c] = a > 0 ? out.rgb[3 * i + c] / a : 0.0f;
            imgs[v].data[4 * i + 3] = a;
        }
        mf_render_out_free(&out);
    }
    mf_env_free(&env);
    mf_rtscene_free(rt);
    mf_mesh_free(&s);
    return rc;
}

/* the colour tests' views, RGBA references and grid */
static MfTetGrid colour_fixture(MfCamera *cams, MfImage *imgs) {
    memset(imgs, 0, NVIEW * sizeof *imgs);
    CHECK_OK(make_cams(cams));
    CHECK_OK(make_rgba(cams, imgs));
    return mf_tetgrid_make(RES, mf_v3(0, 0, 0), EXTENT);
}

MF_TEST(inverse_geom_fit_colour_sphere) {
    /* the colour term (volume-texture materials and an env, optimised with the SDF); every step
     * sees all 8 views, so the log compares like with like.
     * (a) at the right surface with the SDF held (lr_sdf 1e-6), materials and light fit the
     *     references: the colour loss falls, the same bytes twice;
     * (b) with the colour weight ~0 the same path (the renderer's antialiased alpha) fits the
     *     silhouettes from R0, as the mask term does.
     * Measured (MF_TEST_VERBOSE=1): (a) 0.0555 -> 0.0457 in 20 steps; (b) mask 0.207 -> 0.168.
     * With the colour adjoint negated (a) fails (0.0555 -> 0.072).
     * Not asserted, because it does not hold: with weight 1 and lr_sdf 0.01 from R1 the surface
     * drifts (mask 0.0024 -> 0.013, colour 0.055 -> 0.086 in 40 steps): the shading gradients move
     * the surface to make up for materials not yet fitted. */
    enum { CI = 20, CI2 = 4 };
    MfCamera cams[NVIEW];
    MfImage imgs[NVIEW];
    MfTetGrid g = colour_fixture(cams, imgs);
    size_t nv = mf_tetgrid_nverts(&g);
    float *sdf = malloc(nv * sizeof(float));
    MfGeomFitStep log[2][CI];
    MfGeomFitOpts o = {.iters = CI, .lr_sdf = 1e-6f, .color = 1.0f, .seed = 7};
    for (int run = 0; run < 2; ++run) { /* the second run: its first CI2 steps */
        sphere_sdf(&g, R1, sdf);
        int done = -1;
        o.iters = run ? CI2 : CI;
        CHECK_OK(mf_geom_fit(&g, sdf, NULL, cams, imgs, NVIEW, &o, log[run], &done));
        CHECK(done == o.iters);
    }
    CHECK_MSG(same_rows(log[0], log[1], CI2), "two runs with the same seed differ");
    o.iters = CI;
    double r0 = log[0][0].rgb, r1 = 0;
    for (int i = CI - 5; i < CI; ++i) r1 += log[0][i].rgb / 5;
    if (getenv("MF_TEST_VERBOSE")) printf("    (a) colour loss %.5f -> %.5f (last 5 steps' mean)\n", r0, r1);
    CHECK_MSG(r0 > 0 && r1 < 0.9 * r0, "(a) colour loss %.5f -> %.5f (want < 0.9x)", r0, r1);
    o.lr_sdf = 0.01f, o.color = 1e-6f;
    sphere_sdf(&g, R0, sdf);
    CHECK_OK(mf_geom_fit(&g, sdf, NULL, cams, imgs, NVIEW, &o, log[0], NULL));
    double m0 = log[0][0].mask, m1 = 0;
    for (int i = CI - 5; i < CI; ++i) m1 += log[0][i].mask / 5;
    if (getenv("MF_TEST_VERBOSE")) printf("    (b) mask loss %.5f -> %.5f\n", m0, m1);
    CHECK_MSG(m1 < 0.85 * m0, "(b) mask loss %.5f -> %.5f (want < 0.85x)", m0, m1);
    /* masks without colour are refused by name */
    MfImage one = {0}, ones[NVIEW];
    CHECK_OK(mf_image_alloc(&one, IMG, IMG, 1));
    for (int v = 0; v < NVIEW; ++v) ones[v] = one;
    CHECK_ERR(mf_geom_fit(&g, sdf, NULL, cams, ones, NVIEW, &o, NULL, NULL), "RGBA");
    mf_image_free(&one);
    for (int v = 0; v < NVIEW; ++v) mf_image_free(&imgs[v]);
    free(sdf);
}

/* A fit stopped at step 5 and resumed from its state file reaches the bytes of an uninterrupted
 * 8-step fit (SDF, deformation, log), with every block kind (SDF, deformation, the colour term's
 * volumes and env) and 4 of the 8 views a step; a state written with other options (or another start), or holding
 * more steps than asked for, is refused. Checked to fail: without the Adam moments' load the SDF
 * differs; without the env's refresh after the load the SDF and the log differ. */
MF_TEST(inverse_geom_fit_resume) {
    enum { FULL = 8, HALF = 5 };
    MfCamera cams[NVIEW];
    MfImage imgs[NVIEW];
    MfTetGrid g = colour_fixture(cams, imgs);
    size_t nv = mf_tetgrid_nverts(&g);
    float *sdf[2] = {malloc(nv * sizeof(float)), malloc(nv * sizeof(float))};
    float *def[2] = {calloc(nv * 3, sizeof(float)), calloc(nv * 3, sizeof(float))};
    MfGeomFitStep log[2][FULL];
    memset(log, 0, sizeof log);
    char st[2][512];
    snprintf(st[0], sizeof st[0], "%s", mf_test_path("geomfit_full.mfck"));
    snprintf(st[1], sizeof st[1], "%s", mf_test_path("geomfit_half.mfck"));
    MfGeomFitOpts o = {.iters = FULL, .lr_sdf = 0.01f, .lr_deform = 0.03f, .sdf_reg = 0.01f, .views_per_step = 4,
                       .color = 0.1f, .seed = 3, .state = st[0], .state_every = 3};
    for (int r = 0; r < 2; ++r) sphere_sdf(&g, R0, sdf[r]);
    int done = -1;
    CHECK_OK(mf_geom_fit(&g, sdf[0], def[0], cams, imgs, NVIEW, &o, log[0], &done));
    CHECK(done == FULL);
    /* the interrupted run: 5 steps, then a new call from the same start that resumes */
    MfGeomFitOpts h = o;
    h.iters = HALF, h.state = st[1];
    CHECK_OK(mf_geom_fit(&g, sdf[1], def[1], cams, imgs, NVIEW, &h, log[1], NULL));
    sphere_sdf(&g, R0, sdf[1]);
    memset(def[1], 0, nv * 3 * sizeof(float));
    memset(log[1], 0, sizeof log[1]);
    h.iters = FULL, h.resume = 1;
    CHECK_OK(mf_geom_fit(&g, sdf[1], def[1], cams, imgs, NVIEW, &h, log[1], &done));
    CHECK(done == FULL);
    CHECK_MSG(!memcmp(sdf[0], sdf[1], nv * sizeof(float)), "the resumed SDF differs from the uninterrupted one");
    CHECK_MSG(!memcmp(def[0], def[1], nv * 3 * sizeof(float)), "the resumed deformation differs");
    CHECK_MSG(same_rows(log[0], log[1], FULL), "the resumed log differs");
    CHECK(log[0][FULL - 1].rgb > 0);
    /* refusals: other options; more steps held than asked for */
    h.seed = 4;
    CHECK_ERR(mf_geom_fit(&g, sdf[1], def[1], cams, imgs, NVIEW, &h, log[1], NULL), "other geometry-fit options");
    h.seed = 3, h.start = 1; /* another start of the SDF (mf recon --dmtet-init) */
    CHECK_ERR(mf_geom_fit(&g, sdf[1], def[1], cams, imgs, NVIEW, &h, log[1], NULL), "other geometry-fit options");
    h.start = 0, h.iters = HALF;
    CHECK_ERR(mf_geom_fit(&g, sdf[1], def[1], cams, imgs, NVIEW, &h, log[1], NULL), "holds 8 steps");
    for (int v = 0; v < NVIEW; ++v) mf_image_free(&imgs[v]);
    for (int r = 0; r < 2; ++r) free(sdf[r]), free(def[r]);
}

/* an SDF without a zero crossing: a status naming the step, the field untouched */
MF_TEST(inverse_geom_fit_empty) {
    MfCamera cams[NVIEW];
    MfImage masks[NVIEW];
    memset(masks, 0, sizeof masks);
    CHECK_OK(make_cams(cams));
    for (int v = 0; v < NVIEW; ++v) CHECK_OK(mf_image_alloc(&masks[v], IMG, IMG, 1));
    MfTetGrid g = mf_tetgrid_make(8, mf_v3(0, 0, 0), EXTENT);
    size_t nv = mf_tetgrid_nverts(&g);
    float *sdf = malloc(nv * sizeof *sdf);
    for (size_t v = 0; v < nv; ++v) sdf[v] = -0.1f;
    MfGeomFitOpts o = {.iters = 5, .lr_sdf = 0.01f};
    int done = -1;
    int rc = mf_geom_fit(&g, sdf, NULL, cams, masks, NVIEW, &o, NULL, &done);
    CHECK(rc == MF_EARG);
    CHECK(done == 0);
    CHECK_MSG(strstr(mf_error(), "step 0") && strstr(mf_error(), "empty"), "message: %s", mf_error());
    int same = 1;
    for (size_t v = 0; v < nv; ++v) same &= sdf[v] == -0.1f;
    CHECK(same);
    /* a mask of the wrong size is refused */
    sphere_sdf(&g, R0, sdf);
    mf_image_free(&masks[3]);
    CHECK_OK(mf_image_alloc(&masks[3], IMG / 2, IMG, 1));
    rc = mf_geom_fit(&g, sdf, NULL, cams, masks, NVIEW, &o, NULL, &done);
    CHECK_MSG(rc == MF_EARG && strstr(mf_error(), "view 3"), "rc %d: %s", rc, mf_error());
    for (int v = 0; v < NVIEW; ++v) mf_image_free(&masks[v]);
    free(sdf);
}

typedef struct { const MfTetGrid *g; const float *sdf; } RegCtx;
static double reg_loss(void *c) { RegCtx *r = c; return mf_geom_sdf_reg(r->g, r->sdf, 0.5f, NULL); }
/* a sign flip changes the edge set */
static int near_sign_flip(const MfGradCheck *c, size_t v) { return fabsf(c->p[v]) < 2 * (float)c->eps; }

/* the sign-change regulariser's gradient against central differences */
MF_TEST(inverse_geom_fit_sdf_reg_grad) {
    MfTetGrid g = mf_tetgrid_make(4, mf_v3(0, 0, 0), EXTENT);
    size_t nv = mf_tetgrid_nverts(&g);
    float *sdf = malloc(nv * sizeof *sdf), *d = calloc(nv, sizeof *d);
    for (size_t v = 0; v < nv; ++v) sdf[v] = 0.8f - mf_len(mf_tetgrid_base(&g, v)) + 0.05f * (float)((v * 7) % 5);
    double r = mf_geom_sdf_reg(&g, sdf, 0.5f, d);
    CHECK(r > 0);
    RegCtx c = {&g, sdf};
    MfGradResult res = mf_test_grad(&(MfGradCheck){.loss = reg_loss, .ctx = &c, .p = sdf, .g = d, .n = nv,
                                                   .skip = near_sign_flip, .eps = 1e-3f, .atol = 1, .rtol = 0});
    double emax = res.worst, gmax = res.fd_max;
    CHECK(gmax > 0);
    CHECK_MSG(emax <= 1e-3 * gmax + 1e-7, "max |adjoint - fd| %.3g of %.3g", emax, gmax);
    free(sdf);
    free(d);
}

/* mf recon --geometry dmtet's grid (mf_recon_geom_mesh): on a grid of side 1.4 the hull of the
 * R1 = 0.7 sphere's masks touches the border, so the grid is enlarged 1.5x once, as the vhull path
 * does (mf_vhull_grid), and the extracted mesh is closed and reaches beyond the first grid, from
 * either start (--dmtet-init). Without the enlargement the mesh is cut open at |x| = 0.7 (boundary
 * edges, side 1.4). From the hull mesh, whose 128^3 grid enlarges itself, it reaches 0.709; a
 * decimated hull's fold-over once left an island 3 cells out (2 components) before the far
 * vertices' signs went by region (mf_meshsdf.h). */
MF_TEST(inverse_recon_geom_dmtet_enlarges_grid) {
    MfCamera cams[NVIEW];
    MfImage masks[NVIEW];
    memset(masks, 0, sizeof masks);
    CHECK_OK(make_cams(cams));
    CHECK_OK(make_masks(cams, masks));
    for (int init = 0; init < 2; ++init) {
        MfReconGeomOpts o = mf_recon_geom_opts_default();
        o.geometry = "dmtet", o.dmtet_init = init ? MF_DMTET_INIT_HULL : MF_DMTET_INIT_SOFT;
        o.dmtet_res = 24, o.geom_iters = 0, o.hull_extent = 1.4f, o.hull_target_tris = 3000;
        MfMesh m = {0};
        MfReconGeomInfo info;
        CHECK_OK(mf_recon_geom_mesh(&o, "dmtet", NULL, cams, masks, NVIEW, 64, mf_test_path("recon_geom_dmtet_border"), 0, &m, &info));
        CHECK_MSG(fabs(info.hull.extent - 2.1) < 1e-4 && !info.hull.touches_border, "grid side %g (want 2.1), still touching %d",
                  (double)info.hull.extent, info.hull.touches_border);
        float mx = 0;
        for (int i = 0; i < 3 * m.nv; ++i) mx = fmaxf(mx, fabsf(m.pos[i]));
        MfManifoldInfo mi = {0};
        if (m.nv) {
            CHECK_OK(mf_mesh_weld(&m, 1e-5f)); /* the unwrap's seams split vertices */
            CHECK_OK(mf_mesh_manifold_check(&m, &mi));
        }
        /* closed (no boundary edge) and one piece: the 4 islands near (+-0.8, +-0.8, 0) that no view
         * sees are carved by the views whose masks lie inside their frames (mf_vhull.h; before that
         * rule they stayed, 5 components) */
        CHECK_MSG(m.nt > 100 && mf_manifold_ok(&mi) && mi.components == 1,
                  "dmtet mesh (start %d): %d triangles, %d boundary edges, %d components, euler %ld", init, m.nt, mi.boundary_edges,
                  mi.components, mi.euler);
        float reach = init ? 0.705f : 0.72f;
        CHECK_MSG(mx > reach && mx < 1.05f, "dmtet mesh (start %d) reaches |coordinate| %g: the first grid's border is 0.7", init,
                  (double)mx);
        mf_mesh_free(&m);
    }
    for (int v = 0; v < NVIEW; ++v) mf_image_free(&masks[v]);
}
