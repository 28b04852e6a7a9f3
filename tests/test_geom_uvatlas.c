/* T6 (issue 14): the UV unwrapper (mf/geom/mf_uvatlas.h) and the shared shelf packer
 * (mf/geom/mf_pack.h). Overlaps are checked by rasterising every UV triangle at the texel
 * centres of a 4096^2 grid of owner triangles (mf_uv_check). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "datasets/ds_shapes.h"
#include "geom/mf_pack.h"
#include "geom/mf_uvatlas.h"
#include "io/mf_obj.h"
#include "mf_test.h"
#include "scene/mf_shapes.h"

/* Every triangle's UV area > 0 (counter-clockwise, like its 3D winding seen from outside). */
static int uv_flips(const MfMesh *m) {
    int n = 0;
    for (int t = 0; t < m->nt; ++t) {
        const float *a = m->uv + 2 * m->tri[3 * t], *b = m->uv + 2 * m->tri[3 * t + 1], *c = m->uv + 2 * m->tri[3 * t + 2];
        double ar = ((double)b[0] - a[0]) * ((double)c[1] - a[1]) - ((double)b[1] - a[1]) * ((double)c[0] - a[0]);
        n += !(ar > 0);
    }
    return n;
}

static int file_equal(const char *p, const char *q) {
    char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    int eq = !mf_read_file(p, &a, &na) && !mf_read_file(q, &b, &nb) && na == nb && !memcmp(a, b, na);
    free(a), free(b);
    return eq;
}

static int uf_root(int *p, int x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
}

/* The gutter: rasterises m's UV triangles at the texel centres of a (4 tex_res)^2 grid, each
 * centre owned by its chart (components of triangles sharing vertices), and counts centres with
 * a centre of another chart within 4 gutter - 3 cells in x and in y: such a pair is closer than
 * sqrt(2) (4 gutter - 3) / (4 tex_res) < gutter / tex_res, so two charts came nearer than the
 * gutter. */
static long gutter_violations(const MfMesh *m, int tex_res, float gutter) {
    int R = (int)(4 * gutter) - 3, G = 4 * tex_res;
    if (R < 1) return 0;
    int *par = malloc((size_t)m->nv * sizeof *par), *own = malloc((size_t)G * G * sizeof *own);
    long bad = 0;
    if (!par || !own) { free(par), free(own); return -1; }
    for (int v = 0; v < m->nv; ++v) par[v] = v;
    for (int t = 0; t < m->nt; ++t)
        for (int k = 1; k < 3; ++k) par[uf_root(par, (int)m->tri[3 * t + k])] = uf_root(par, (int)m->tri[3 * t]);
    for (size_t i = 0; i < (size_t)G * G; ++i) own[i] = -1;
    for (int t = 0; t < m->nt; ++t) {
        const float *p[3] = {m->uv + 2 * m->tri[3 * t], m->uv + 2 * m->tri[3 * t + 1], m->uv + 2 * m->tri[3 * t + 2]};
        double x0 = fmin(p[0][0], fmin(p[1][0], p[2][0])) * G, x1 = fmax(p[0][0], fmax(p[1][0], p[2][0])) * G;
        double y0 = fmin(p[0][1], fmin(p[1][1], p[2][1])) * G, y1 = fmax(p[0][1], fmax(p[1][1], p[2][1])) * G;
        int c = uf_root(par, (int)m->tri[3 * t]);
        for (int j = (int)fmax(0, floor(y0 - 0.5)); j <= (int)fmin(G - 1, ceil(y1)); ++j)
            for (int i = (int)fmax(0, floor(x0 - 0.5)); i <= (int)fmin(G - 1, ceil(x1)); ++i) {
                double x = (i + 0.5) / G, y = (j + 0.5) / G, w[3];
                for (int e = 0; e < 3; ++e) {
                    const float *a = p[e], *b = p[(e + 1) % 3];
                    w[e] = ((double)b[0] - a[0]) * (y - a[1]) - ((double)b[1] - a[1]) * (x - a[0]);
                }
                if (w[0] >= 0 && w[1] >= 0 && w[2] >= 0) own[(size_t)j * G + i] = c;
            }
    }
    for (int j = 0; j < G; ++j)
        for (int i = 0; i < G; ++i) {
            int c = own[(size_t)j * G + i], hit = 0;
            if (c < 0) continue;
            for (int y = j; y <= j + R && y < G && !hit; ++y) /* pairs counted once: the window above and to the right */
                for (int x = i - R; x <= i + R && !hit; ++x)
                    if (x >= 0 && x < G && (y > j || x > i) && own[(size_t)y * G + x] >= 0 && own[(size_t)y * G + x] != c) hit = 1;
            bad += hit;
        }
    free(par), free(own);
    return bad;
}

/* Unwraps `in` with 1 and then 2 threads: the OBJs must be byte-identical; no overlaps at
 * 4096^2, no flips, everything inside [0,1]^2. Returns the atlas use at 256^2. */
static double check_unwrap(const char *name, const MfMesh *in, const MfUvAtlasOpts *opts, MfUvAtlasInfo *info_out) {
    MfUvAtlasOpts o = opts ? *opts : mf_uvatlas_defaults();
    MfUvAtlasInfo info;
    MfMesh out[2] = {{0}, {0}};
    char path[2][MF_PATH_MAX];
    int threads = omp_get_max_threads();
    for (int r = 0; r < 2; ++r) {
        omp_set_num_threads(r + 1);
        double t0 = mf_now();
        CHECK_OK(mf_uvatlas(in, &o, &out[r], &info));
        if (r == 0) fprintf(stderr, "  %s: %d triangles, %d charts (%d grown; splits: topology %d, flips %d, overlaps %d; %d forced single), %.2f s\n",
                            name, in->nt, info.charts, info.grown, info.split_topology, info.split_flip, info.split_overlap,
                            info.forced_single, mf_now() - t0);
        mf_test_path_to(path[r], sizeof path[r], "%s", r ? "uv_b.obj" : "uv_a.obj");
        CHECK_OK(mf_obj_write(path[r], &out[r], NULL));
    }
    omp_set_num_threads(threads);
    CHECK_MSG(file_equal(path[0], path[1]), "%s: two runs (1 and 2 threads) wrote different OBJs", name);
    CHECK(out[0].nt == in->nt && out[0].uv);
    MfUvCheck c, c256;
    CHECK_OK(mf_uv_check(&out[0], 4096, &c));
    CHECK_OK(mf_uv_check(&out[0], 256, &c256));
    CHECK_MSG(c.overlap_same == 0 && c.overlap_other == 0, "%s: %ld texel centres covered twice within a chart, %ld by two charts",
              name, c.overlap_same, c.overlap_other);
    CHECK_MSG(c.flipped == 0 && uv_flips(&out[0]) == 0, "%s: %d flipped UV triangles", name, c.flipped);
    CHECK_MSG(c.outside == 0, "%s: %d triangles outside [0,1]^2", name, c.outside);
    CHECK(c.charts == info.charts);
    long gv = gutter_violations(&out[0], o.tex_res, o.gutter);
    CHECK_MSG(gv == 0, "%s: %ld texel centres (at %d^2) nearer than the %g-texel gutter to another chart", name, gv, 4 * o.tex_res, o.gutter);
    fprintf(stderr, "  %s: atlas use %.1f%% at 256^2 (%.1f%% at 4096^2)\n", name, 100 * c256.coverage, 100 * c.coverage);
    *info_out = info;
    mf_mesh_free(&out[0]);
    mf_mesh_free(&out[1]);
    return c256.coverage;
}

MF_TEST(geom_uvatlas_torus_cup) {
    MfMesh torus = {0};
    MfUvAtlasInfo info;
    /* the generator duplicates its seam vertices; the unwrapper joins equal positions */
    CHECK_OK(mf_shape_torus(&torus, 0.5f, 0.2f, 96, 48));
    double use = check_unwrap("torus", &torus, NULL, &info);
    CHECK(info.charts > 1 && info.charts < torus.nt / 20);
    CHECK_MSG(use > 0.4 && info.packed_shapes, "torus: atlas use %g (shelves gave 0.327), packed by shape %d", use, info.packed_shapes);
    /* whole-torus charts (no normal limit, no size cap): LSCM of the grown disc flips or
     * overlaps, so the split paths run; the result must still be valid */
    MfUvAtlasOpts o = mf_uvatlas_defaults();
    o.max_chart_tris = torus.nt;
    o.max_angle_deg = 180;
    check_unwrap("torus, one grown chart, 180 deg", &torus, &o, &info);
    CHECK(info.grown == 1 && info.split_flip > 0);
    o.max_angle_deg = 120;
    check_unwrap("torus, 120 deg", &torus, &o, &info);
    CHECK(info.split_overlap > 0);
    mf_mesh_free(&torus);
    DsObject cup;
    CHECK_OK(ds_object_generate(&cup, DS_FAM_CUP, 7, 64));
    use = check_unwrap("cup", &cup.mesh, NULL, &info);
    CHECK_MSG(use >= 0.5, "cup: atlas use %g (shelves gave 0.425)", use);
    ds_object_free(&cup);
}

MF_TEST(geom_uvatlas_50k) {
    MfMesh torus = {0};
    MfUvAtlasInfo info;
    CHECK_OK(mf_shape_torus(&torus, 0.5f, 0.25f, 250, 100)); /* 50,000 triangles */
    for (int v = 0; v < torus.nv; ++v) { /* a bumpy surface, deterministic */
        float *p = torus.pos + 3 * v;
        float s = 1.0f + 0.04f * sinf(23.0f * p[0]) * sinf(19.0f * p[1]) * cosf(17.0f * p[2]);
        for (int k = 0; k < 3; ++k) p[k] *= s;
    }
    double t0 = mf_now();
    double use = check_unwrap("bumpy torus", &torus, NULL, &info);
    /* issue 14: atlas use >= 50% at 256^2 (shelf packing gave 47.7%); <= 5 s for 50k triangles
     * (the check measures two unwraps, 1 and 2 threads, plus rasterising at 4096^2; timing
     * only reported here, the machine may be shared) */
    CHECK_MSG(use >= 0.5, "bumpy torus: atlas use %g, want >= 0.5", use);
    fprintf(stderr, "  bumpy torus: two unwraps and the checks in %.2f s\n", mf_now() - t0);
    mf_mesh_free(&torus);
}

/* The checker itself sees overlaps, flips and points outside the square. */
MF_TEST(geom_uvatlas_check_detects) {
    MfMesh m = {0};
    CHECK_OK(mf_mesh_alloc(&m, 9, 3, 0, 1));
    static const float uv[] = {0.1f, 0.1f, 0.6f, 0.1f, 0.1f, 0.6f,  /* chart A */
                               0.2f, 0.2f, 0.7f, 0.2f, 0.2f, 0.7f,  /* chart B, overlaps A */
                               0.8f, 0.8f, 0.8f, 0.95f, 0.95f, 0.8f}; /* chart C, clockwise */
    memcpy(m.uv, uv, sizeof uv);
    for (int i = 0; i < 27; ++i) m.pos[i] = (float)i;
    for (int i = 0; i < 9; ++i) m.tri[i] = (uint32_t)i;
    MfUvCheck c;
    CHECK_OK(mf_uv_check(&m, 256, &c));
    CHECK(c.charts == 3 && c.overlap_other > 0 && c.overlap_same == 0 && c.flipped == 1 && c.outside == 0);
    m.tri[3] = 0; /* B shares a vertex with A: one chart, overlapping itself */
    CHECK_OK(mf_uv_check(&m, 256, &c));
    CHECK(c.charts == 2 && c.overlap_same > 0 && c.overlap_other == 0);
    m.uv[0] = 1.5f;
    CHECK_OK(mf_uv_check(&m, 256, &c));
    CHECK(c.outside == 2); /* the two triangles using vertex 0 */
    /* two triangles of a square share an edge through texel centres: each centre counted once */
    MfMesh q = {0};
    CHECK_OK(mf_mesh_alloc(&q, 4, 2, 0, 1));
    static const float quv[] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const uint32_t qt[] = {0, 1, 2, 0, 2, 3};
    memcpy(q.uv, quv, sizeof quv);
    memcpy(q.tri, qt, sizeof qt);
    memset(q.pos, 0, 12 * sizeof(float));
    CHECK_OK(mf_uv_check(&q, 64, &c));
    CHECK(c.covered == 64 * 64 && c.overlap_same == 0 && c.coverage == 1.0);
    mf_mesh_free(&m);
    mf_mesh_free(&q);
}

MF_TEST(geom_uvatlas_bad_input) {
    MfMesh m = {0}, out = {0};
    MfUvAtlasOpts o = mf_uvatlas_defaults();
    CHECK_ERR(mf_uvatlas(&m, &o, &out, NULL), "empty mesh");
    CHECK_OK(mf_shape_torus(&m, 0.5f, 0.2f, 8, 4));
    m.pos[4] = NAN;
    CHECK_ERR(mf_uvatlas(&m, &o, &out, NULL), "non-finite");
    m.pos[4] = 0;
    o.tex_res = 0;
    CHECK_ERR(mf_uvatlas(&m, &o, &out, NULL), "tex_res");
    mf_mesh_free(&m);
    char err[4096];
    int rc = mf_test_run_mf("unwrap /nonexistent/in.obj -o /dev/null", NULL, err, sizeof err);
    CHECK_MSG(rc == 1 && strstr(err, "/nonexistent/in.obj"), "mf unwrap on a missing file: rc %d, '%s'", rc, err);
    rc = mf_test_run_mf("unwrap /nonexistent/in.obj", NULL, err, sizeof err);
    CHECK_MSG(rc == 2 && strstr(err, "-o OUT.obj"), "mf unwrap without -o: rc %d, '%s'", rc, err);
}

MF_TEST(geom_uvatlas_cli) {
    MfMesh m = {0}, back = {0};
    CHECK_OK(mf_shape_torus(&m, 0.5f, 0.2f, 32, 16));
    free(m.uv), m.uv = NULL;
    const char *in = mf_test_path("unwrap_in.obj");
    CHECK_OK(mf_obj_write(in, &m, NULL));
    char args[3 * MF_PATH_MAX], err[4096];
    const char *outp = mf_test_path("unwrap_out.obj");
    snprintf(args, sizeof args, "unwrap %s -o %s --tex-res 128 --gutter 1", in, outp);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf unwrap: %s", err);
    CHECK_OK(mf_obj_read(outp, &back));
    CHECK(back.uv && back.nt == m.nt);
    MfUvCheck c;
    CHECK_OK(mf_uv_check(&back, 1024, &c));
    CHECK(c.overlap_same == 0 && c.overlap_other == 0 && c.flipped == 0 && c.outside == 0);
    mf_mesh_free(&m);
    mf_mesh_free(&back);
}

/* mf_pack: rectangles inside the square, apart by at least pad, in height order on shelves. */
MF_TEST(geom_pack_shelves) {
    enum { N = 40 };
    float size[2 * N];
    int order[N];
    MfPackRect r[N];
    for (int i = 0; i < N; ++i) size[2 * i] = 1.0f + (float)(i * 7 % 5), size[2 * i + 1] = 1.0f + (float)(i * 3 % 4);
    CHECK_OK(mf_pack_order_by_height(size, N, order));
    for (int i = 1; i < N; ++i)
        CHECK(size[2 * order[i - 1] + 1] > size[2 * order[i] + 1] ||
              (size[2 * order[i - 1] + 1] == size[2 * order[i] + 1] && order[i - 1] < order[i]));
    for (int stretch = 0; stretch < 2; ++stretch) {
        float pad = 0.01f, s = mf_pack_shelves(size, order, N, pad, 0.0f, stretch, r);
        CHECK(s > 0);
        double used = 0;
        for (int i = 0; i < N; ++i) {
            CHECK(r[i].x0 >= pad * 0.999f && r[i].y0 >= pad * 0.999f && r[i].x0 + r[i].w <= 1 - pad * 0.999f &&
                  r[i].y0 + r[i].h <= 1 - pad * 0.999f);
            if (!stretch) CHECK_NEAR(r[i].w, size[2 * i] * s, 1e-5);
            used += (double)r[i].w * r[i].h;
            for (int j = 0; j < i; ++j) {
                int apart = r[i].x0 >= r[j].x0 + r[j].w + pad * 0.999f || r[j].x0 >= r[i].x0 + r[i].w + pad * 0.999f ||
                            r[i].y0 >= r[j].y0 + r[j].h + pad * 0.999f || r[j].y0 >= r[i].y0 + r[i].h + pad * 0.999f;
                CHECK_MSG(apart, "rectangles %d and %d closer than pad", i, j);
            }
        }
        CHECK(used > 0.4);
    }
}
