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
#include "mf_test.h"

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
    double gmax = 0, emax = 0;
    const float h = 1e-4f; /* world units; about 2e-3 pixels */
    for (int i = 0; i < 8 * 3; ++i) {
        float p0 = m.pos[i];
        m.pos[i] = p0 + h;
        double jp = aa_loss(&m, &cam, a, in, w, AC, tmp);
        m.pos[i] = p0 - h;
        double jm = aa_loss(&m, &cam, a, in, w, AC, tmp);
        m.pos[i] = p0;
        double fd = (jp - jm) / (2.0 * (double)h);
        gmax = fmax(gmax, fabs(fd));
        emax = fmax(emax, fabs(fd - dpos[i]));
        if (getenv("MF_TEST_VERBOSE")) printf("    v%d.%d fd %.6g adjoint %.6g\n", i / 3, i % 3, fd, dpos[i]);
    }
    CHECK(gmax > 0);
    CHECK_MSG(emax <= 1e-3 * gmax, "dpos: max |adjoint - fd| %.3g, max |fd| %.3g", emax, gmax);
    /* the image adjoint is exact (the image enters linearly): a few pixels by differences */
    double eimg = 0;
    for (int i = 0; i < AW * AH * AC; i += 37) {
        float v0 = in[i];
        in[i] = v0 + 0.25f;
        mf_aa_forward(a, in, AC, tmp);
        double jp = 0;
        for (int k = 0; k < AW * AH * AC; ++k) jp += (double)w[k] * tmp[k];
        in[i] = v0 - 0.25f;
        mf_aa_forward(a, in, AC, tmp);
        double jm = 0;
        for (int k = 0; k < AW * AH * AC; ++k) jm += (double)w[k] * tmp[k];
        in[i] = v0;
        eimg = fmax(eimg, fabs((jp - jm) / 0.5 - din[i]));
    }
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
        if (getenv("MF_TEST_VERBOSE")) printf("    %2.0f deg: d(sum alpha)/d delta %.3f, edge length %.3f px (%d crossings)\n", angles[k], g, L, mf_aa_count(a));
        CHECK_MSG(fabs(g - L) <= 0.05 * L, "%.0f degrees: d(sum alpha)/d delta = %.3f, edge length %.3f px", angles[k], g, L);
        mf_aa_free(a);
        mf_rtscene_free(rt);
        mf_mesh_free(&m);
    }
}
