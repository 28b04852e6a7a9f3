/* T2 of issue 14: the analytic antialiasing of render/mf_antialias (nvdiffrast's operation).
 * (a) the adjoint (image and vertex positions) against central differences of a random linear
 * functional of the antialiased image, the crossings recomputed from the moved mesh; (b) for a
 * straight edge of a large triangle at 0/20/45/70 degrees, d(sum of coverage)/d(normal offset of
 * the edge) equals the edge's length in pixels within 5%. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_antialias.h"
#include "render/mf_diffrender.h"
#include "mf_test.h"
#include "mf_test_grad.h"

static int camera(MfCamera *cam, int w, int h, MfVec3 eye, MfVec3 at, MfVec3 up) {
    MfMat4 c2w = mf_mat4_look_at(eye, at, up);
    double m[16];
    for (int i = 0; i < 16; ++i) m[i] = c2w.m[i];
    return mf_camera_init(cam, w, h, 0.6911, m, "test");
}

static void set_tri(MfMesh *m, int t, uint32_t a, uint32_t b, uint32_t c) {
    m->tri[3 * t] = a;
    m->tri[3 * t + 1] = b;
    m->tri[3 * t + 2] = c;
}

/* sum of w * antialiased(in), the crossings found at m's current positions in the G-buffer of g
 * (the pixel-centre hits stay those of the unmoved mesh: the input image is held fixed too) */
static double aa_loss(const MfMesh *m, const MfCamera *cam, const MfAa *g, const float *in, const float *w, int c,
                      float *tmp) {
    MfAa *a;
    if (mf_aa_new_gbuffer(m, cam, mf_aa_tri(g), mf_aa_depth(g), &a)) return NAN;
    mf_aa_forward(a, in, c, tmp);
    double j = 0;
    for (int i = 0; i < cam->w * cam->h * c; ++i) j += (double)w[i] * tmp[i];
    mf_aa_free(a);
    return j;
}

enum { AW = 32, AH = 32, AC = 4 };

typedef struct { const MfMesh *m; const MfCamera *cam; const MfAa *a; const float *in, *w; float *tmp; } AaCtx;
/* aa_loss at the mesh's current positions */
static double aa_loss_of(void *c) {
    AaCtx *x = c;
    return aa_loss(x->m, x->cam, x->a, x->in, x->w, AC, x->tmp);
}
/* sum of w * antialiased(in) with the crossings of a */
static double img_loss_of(void *c) {
    AaCtx *x = c;
    mf_aa_forward(x->a, x->in, AC, x->tmp);
    double j = 0;
    for (int k = 0; k < x->cam->w * x->cam->h * AC; ++k) j += (double)x->w[k] * x->tmp[k];
    return j;
}

MF_TEST(render_antialias_adjoint) {
    /* a quad in front of a quad (inner occlusion edges) and the background (outer silhouettes) */
    MfMesh m;
    CHECK_OK(mf_mesh_alloc(&m, 8, 4, 0, 0));
    const float P[8][3] = {{-0.8f, -0.7f, 0}, {0.7f, -0.8f, 0}, {0.75f, 0.7f, 0}, {-0.7f, 0.8f, 0},
                           {-0.35f, -0.2f, 0.3f}, {0.3f, -0.35f, 0.35f}, {0.4f, 0.25f, 0.3f}, {-0.25f, 0.3f, 0.25f}};
    memcpy(m.pos, P, sizeof P);
    set_tri(&m, 0, 0, 1, 2);
    set_tri(&m, 1, 0, 2, 3);
    set_tri(&m, 2, 4, 5, 6);
    set_tri(&m, 3, 4, 6, 7);
    MfCamera cam;
    CHECK_OK(camera(&cam, AW, AH, mf_v3(0.3f, -0.4f, 2.6f), mf_v3(0, 0, 0), mf_v3(0, 1, 0)));
    MfRng r;
    mf_rng_seed(&r, 5, 0);
    static float in[AW * AH * AC], w[AW * AH * AC], tmp[AW * AH * AC], din[AW * AH * AC];
    for (int i = 0; i < AW * AH * AC; ++i) {
        in[i] = mf_rng_float(&r);
        w[i] = mf_rng_float(&r) - 0.5f;
    }
    MfRtScene *rt;
    MfAa *a;
    CHECK_OK(mf_rtscene_new(&m, &rt));
    CHECK_OK(mf_aa_new(rt, &cam, &a));
    int n = mf_aa_count(a), nbg = 0, nin = 0;
    for (int i = 0; i < AW * AH; ++i) nbg += mf_aa_tri(a)[i] < 0, nin += mf_aa_tri(a)[i] >= 2;
    CHECK_MSG(n > 40 && nbg > 0 && nin > 0, "%d crossings, %d background and %d front-quad pixels", n, nbg, nin);
    float dpos[8 * 3] = {0};
    memset(din, 0, sizeof din);
    mf_aa_backward(a, in, AC, w, din, dpos);
    /* determinism: a second G-buffer gives the same image */
    MfAa *a2;
    static float o1[AW * AH * AC], o2[AW * AH * AC];
    CHECK_OK(mf_aa_new(rt, &cam, &a2));
    mf_aa_forward(a, in, AC, o1);
    mf_aa_forward(a2, in, AC, o2);
    CHECK(!memcmp(o1, o2, sizeof o1));
    mf_aa_free(a2);
    /* a quad's shared diagonal is no silhouette: pixels whose 4-neighbours all lie on their own
     * quad keep their colour (some of them do touch the other triangle); the front quad's
     * outline over the back quad (an inner occlusion edge) is blended */
    const int *tri = mf_aa_tri(a);
    int diag = 0, kept = 1, inner = 0;
    for (int y = 0; y < AH; ++y)
        for (int x = 0; x < AW; ++x) {
            int i = y * AW + x, t = tri[i], same = t >= 0, other_tri = 0, back = 0;
            const int nb[4][2] = {{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}};
            for (int k = 0; k < 4; ++k) {
                if (nb[k][0] < 0 || nb[k][0] >= AW || nb[k][1] < 0 || nb[k][1] >= AH) continue;
                int u = tri[nb[k][1] * AW + nb[k][0]];
                same &= u >= 0 && u / 2 == t / 2;
                other_tri |= u >= 0 && u != t && u / 2 == t / 2;
                back |= t >= 2 && u >= 0 && u < 2;
            }
            int changed = memcmp(o1 + (size_t)i * AC, in + (size_t)i * AC, AC * sizeof(float)) != 0;
            if (same) kept &= !changed, diag += other_tri;
            inner += back && changed;
        }
    CHECK_MSG(kept && diag > 0, "pixels along a quad's diagonal changed (%d pixels there)", diag);
    CHECK_MSG(inner > 0, "the front quad's outline over the back quad was not blended");
    AaCtx c = {&m, &cam, a, in, w, tmp};
    MfGradResult rp = mf_test_grad(&(MfGradCheck){.loss = aa_loss_of, .ctx = &c, .p = m.pos, .g = dpos, .n = 8 * 3,
                                                  .eps = 1e-4f /* world units; about 2e-3 pixels */, .atol = 1, .rtol = 0});
    double gmax = rp.fd_max, emax = rp.worst;
    if (getenv("MF_TEST_VERBOSE")) printf("    worst v%ld.%ld fd %.6g adjoint %.6g\n", rp.at / 3, rp.at % 3, rp.fd, rp.g);
    CHECK(gmax > 0);
    CHECK_MSG(emax <= 1e-3 * gmax, "dpos: max |adjoint - fd| %.3g, max |fd| %.3g", emax, gmax);
    /* the image adjoint is exact (the image enters linearly): a few pixels by differences */
    double eimg = mf_test_grad(&(MfGradCheck){.loss = img_loss_of, .ctx = &c, .p = in, .g = din, .n = AW * AH * AC,
                                              .stride = 37, .eps = 0.25, .atol = 1, .rtol = 0})
                      .worst;
    CHECK_MSG(eimg < 1e-5, "image adjoint error %.3g", eimg);
    if (getenv("MF_TEST_VERBOSE")) printf("    %d crossings; dpos max err %.3g of %.3g; image %.3g\n", n, emax, gmax, eimg);
    mf_aa_free(a);
    mf_rtscene_free(rt);
    mf_mesh_free(&m);
}

/* length in pixels of the line through c with direction d inside [0, W] x [0, H] */
static double chord(double cx, double cy, double dx, double dy, double W, double H) {
    double t0 = -1e30, t1 = 1e30;
    const double o[2] = {cx, cy}, d[2] = {dx, dy}, hi[2] = {W, H};
    for (int k = 0; k < 2; ++k) {
        if (fabs(d[k]) < 1e-12) continue;
        double a = (0 - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
        t0 = fmax(t0, fmin(a, b));
        t1 = fmin(t1, fmax(a, b));
    }
    return (t1 - t0) * sqrt(dx * dx + dy * dy);
}

enum { EW = 64, EH = 64 };

MF_TEST(render_antialias_edge_length) {
    /* camera 2 units above the plane z = 0, looking straight down: the plane maps to pixels by
     * a similarity of scale fx / 2 */
    MfCamera cam;
    CHECK_OK(camera(&cam, EW, EH, mf_v3(0, 0, 2), mf_v3(0, 0, 0), mf_v3(0, 1, 0)));
    double s = cam.fx / 2.0;
    const double angles[4] = {0, 20, 45, 70};
    static float in[EW * EH], ones[EW * EH];
    for (int i = 0; i < EW * EH; ++i) ones[i] = 1.0f;
    for (int k = 0; k < 4; ++k) {
        double th = angles[k] * MF_PI / 180.0;
        double dx = cos(th), dy = sin(th), nx = -dy, ny = dx; /* edge direction, outward normal (world) */
        double c0x = 0.013, c0y = -0.021;                      /* off the pixel centres */
        MfMesh m;
        CHECK_OK(mf_mesh_alloc(&m, 3, 1, 0, 0));
        const float P[3][3] = {{(float)(c0x - 10 * dx), (float)(c0y - 10 * dy), 0},
                               {(float)(c0x + 10 * dx), (float)(c0y + 10 * dy), 0},
                               {(float)(c0x - 10 * nx), (float)(c0y - 10 * ny), 0}};
        memcpy(m.pos, P, sizeof P);
        set_tri(&m, 0, 0, 1, 2);
        MfRtScene *rt;
        MfAa *a;
        CHECK_OK(mf_rtscene_new(&m, &rt));
        CHECK_OK(mf_aa_new(rt, &cam, &a));
        for (int i = 0; i < EW * EH; ++i) in[i] = mf_aa_tri(a)[i] >= 0 ? 1.0f : 0.0f; /* coverage */
        float dpos[9] = {0};
        mf_aa_backward(a, in, 1, ones, NULL, dpos);
        /* moving both edge vertices by delta (pixels) along the outward normal */
        double g = ((dpos[0] + dpos[3]) * nx + (dpos[1] + dpos[4]) * ny) / s;
        /* the edge on screen: world x right = pixel x, world y = -pixel y (camera up = +y) */
        double px = cam.cx + s * c0x, py = cam.cy - s * c0y;
        double L = chord(px, py, dx, -dy, EW, EH);
        if (getenv("MF_TEST_VERBOSE"))
            printf("    %2.0f deg: d(sum alpha)/d delta %.3f, edge length %.3f px (%d crossings)\n", angles[k], g, L,
                   mf_aa_count(a));
        CHECK_MSG(fabs(g - L) <= 0.05 * L, "%.0f degrees: d(sum alpha)/d delta = %.3f, edge length %.3f px", angles[k], g, L);
        mf_aa_free(a);
        mf_rtscene_free(rt);
        mf_mesh_free(&m);
    }
}

/* T2, last part: through the differentiable renderer (MfDiffOpts.antialias), d(loss)/d(shift of
 * a quad) against central differences of 256-spp renders (box-filtered pixels, common random
 * numbers), for the outer silhouette (the back quad on the background) and for a quad in front
 * of a quad (inner occlusion edges). Flat quads with one texel each under a constant sky: the
 * only gradient is the visibility boundary's. */
enum { RW = 24, RH = 24 };

static void quad(MfMesh *m, int v0, int t0, float cx, float cy, float z, float half, float deg, float u) {
    float c = cosf(deg * (float)MF_PI / 180.0f), s = sinf(deg * (float)MF_PI / 180.0f);
    const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; ++k) {
        float x = half * corner[k][0], y = half * corner[k][1];
        float *p = m->pos + 3 * (v0 + k);
        p[0] = cx + c * x - s * y;
        p[1] = cy + s * x + c * y;
        p[2] = z;
        m->uv[2 * (v0 + k)] = u;
        m->uv[2 * (v0 + k) + 1] = 0.5f;
    }
    set_tri(m, t0, v0, v0 + 1, v0 + 2);
    set_tri(m, t0 + 1, v0, v0 + 2, v0 + 3);
}

typedef struct {
    MfMesh m;
    MfImage kd, orm;
    MfEnvMap env;
    MfCamera cam;
    float w[RW * RH * 3];
} QuadScene;

static double quad_loss(QuadScene *q, const MfDiffOpts *o) {
    MfRtScene *rt;
    MfRenderOut out;
    if (mf_mesh_compute_normals(&q->m) || mf_rtscene_new(&q->m, &rt)) return NAN;
    if (mf_render_out_alloc(&out, RW, RH)) return NAN;
    MfDiffScene s = {.rt = rt, .kd = &q->kd, .orm = &q->orm, .env = &q->env};
    double j = NAN;
    if (!mf_diff_forward(&s, &q->cam, o, &out)) {
        j = 0;
        for (int i = 0; i < RW * RH * 3; ++i) j += (double)q->w[i] * out.rgb[i];
    }
    mf_render_out_free(&out);
    mf_rtscene_free(rt);
    return j;
}

MF_TEST(render_antialias_vs_supersampling) {
    QuadScene q;
    memset(&q, 0, sizeof q);
    CHECK_OK(mf_mesh_alloc(&q.m, 8, 4, 0, 1));
    quad(&q.m, 0, 0, 0.0f, 0.0f, 0.0f, 0.5f, 12.0f, 0.25f);     /* back: texel 0 */
    /* front: texel 1, near the camera so that its shadow on the back quad is negligible (the
     * reference sees shadows move; antialiasing does not) */
    quad(&q.m, 4, 2, 0.01f, 0.004f, 1.8f, 0.04f, -20.0f, 0.75f);
    CHECK_OK(mf_image_alloc(&q.kd, 2, 1, 3));
    CHECK_OK(mf_image_alloc(&q.orm, 2, 1, 3));
    const float kd[6] = {0.9f, 0.8f, 0.7f, 0.1f, 0.2f, 0.3f}, orm[6] = {1, 1, 0, 1, 1, 0};
    memcpy(q.kd.data, kd, sizeof kd);
    memcpy(q.orm.data, orm, sizeof orm);
    CHECK_OK(mf_env_init_constant(&q.env, 8, 4, mf_v3(1, 1, 1)));
    CHECK_OK(camera(&q.cam, RW, RH, mf_v3(0, 0, 2.2f), mf_v3(0, 0, 0), mf_v3(0, 1, 0)));
    MfDiffOpts oa = {.spp_sqrt = 2, .pixel_samples = 4, .seed = 3, .antialias = 1};
    MfDiffOpts ref = {.spp_sqrt = 1, .pixel_samples = 256, .seed = 11};
    const float hs[2] = {0.03f, 0.0055f}; /* world units: about 0.45 pixels at either quad's depth */
    const char *name[2] = {"outer silhouette (back quad)", "quad in front of a quad"};
    for (int axis = 0; axis < 2; ++axis) {
        /* the loss weighs the right (x shifts) or lower (y shifts) half of the image, so the two
         * opposite edges of a quad do not cancel */
        for (int y = 0; y < RH; ++y)
            for (int x = 0; x < RW; ++x)
                for (int c = 0; c < 3; ++c)
                    q.w[3 * (y * RW + x) + c] = ((axis ? y >= RH / 2 : x >= RW / 2) ? 1.0f : 0.0f) * (1.0f + 0.2f * (float)c);
        MfRtScene *rt;
        CHECK_OK(mf_mesh_compute_normals(&q.m));
        CHECK_OK(mf_rtscene_new(&q.m, &rt));
        MfDiffScene s = {.rt = rt, .kd = &q.kd, .orm = &q.orm, .env = &q.env};
        float dpos[8 * 3] = {0};
        MfDiffAdjoint adj = {.drgb = q.w};
        MfDiffGrads g = {.dpos = dpos};
        CHECK_OK(mf_diff_backward(&s, &q.cam, &oa, &adj, &g));
        mf_rtscene_free(rt);
        for (int which = 0; which < 2; ++which) {
            double ga = 0, j[2], h = hs[which];
            for (int v = 4 * which; v < 4 * which + 4; ++v) ga += dpos[3 * v + axis];
            for (int sgn = 0; sgn < 2; ++sgn) {
                for (int v = 4 * which; v < 4 * which + 4; ++v) q.m.pos[3 * v + axis] += (float)(sgn ? -h : h);
                j[sgn] = quad_loss(&q, &ref);
                for (int v = 4 * which; v < 4 * which + 4; ++v) q.m.pos[3 * v + axis] -= (float)(sgn ? -h : h);
            }
            double fd = (j[0] - j[1]) / (2.0 * h);
            if (getenv("MF_TEST_VERBOSE")) printf("    %s, shift %c: antialiased %.4f, 256 spp %.4f\n", name[which], "xy"[axis], ga, fd);
            CHECK_MSG(fabs(ga - fd) <= 0.1 * fabs(fd), "%s, shift along %c: antialiased gradient %.4f, 256-spp differences %.4f",
                      name[which], "xy"[axis], ga, fd);
        }
    }
    mf_mesh_free(&q.m);
    mf_image_free(&q.kd);
    mf_image_free(&q.orm);
    mf_env_free(&q.env);
}
