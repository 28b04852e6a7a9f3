/* Tests of mf/io/mf_obj: exact write->read round trips (with and without UVs/normals, with
 * materials and MTL), all face corner forms, negative indices, polygons, CRLF, comments, and
 * errors naming file:line. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_obj.h"
#include "mf_test.h"

/* An n x n grid of quads (2 triangles each) with awkward float values. */
static void make_grid(MfMesh *m, int n, int with_nrm, int with_uv, int with_mat) {
    int nv = (n + 1) * (n + 1);
    mf_mesh_alloc(m, nv, 2 * n * n, with_nrm, with_uv);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            int v = j * (n + 1) + i;
            m->pos[3 * v] = (float)i / 3.0f - 1e-7f * j;
            m->pos[3 * v + 1] = 1e-30f * i + (float)j * 0.1f;
            m->pos[3 * v + 2] = sinf((float)(i * j)) * 123.456789f;
            if (with_uv) {
                m->uv[2 * v] = (float)i / n;
                m->uv[2 * v + 1] = 1.0f - (float)j / 7.0f;
            }
            if (with_nrm) {
                float x = 0.3f * i - 1.0f, y = 0.2f * j, z = 1.0f, l = sqrtf(x * x + y * y + z * z);
                m->nrm[3 * v] = x / l;
                m->nrm[3 * v + 1] = y / l;
                m->nrm[3 * v + 2] = z / l;
            }
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t a = (uint32_t)(j * (n + 1) + i), b = a + 1, c = a + (uint32_t)n + 1, d = c + 1;
            uint32_t *t = m->tri + 6 * (j * n + i);
            t[0] = a, t[1] = b, t[2] = d, t[3] = a, t[4] = d, t[5] = c;
        }
    if (with_mat) {
        m->nmat = 2;
        m->mat = calloc((size_t)m->nt, sizeof(int));
        m->mat_names = calloc(2, sizeof(char *));
        m->mat_names[0] = strdup("body");
        m->mat_names[1] = strdup("trim");
        for (int t = 0; t < m->nt; ++t) m->mat[t] = (t / 5) % 2;
    }
}

static int same_floats(const float *a, const float *b, size_t n) {
    if (!a || !b) return a == b;
    for (size_t i = 0; i < n; ++i)
        if (memcmp(&a[i], &b[i], sizeof(float)) != 0) return 0;
    return 1;
}

MF_TEST(io_obj_roundtrip_exact) {
    for (int variant = 0; variant < 4; ++variant) {
        int with_nrm = variant & 1, with_uv = (variant >> 1) & 1, with_mat = variant == 3;
        MfMesh a = {0}, b = {0};
        make_grid(&a, 9, with_nrm, with_uv, with_mat);
        const char *p = mf_test_path("grid.obj");
        CHECK_OK(mf_obj_write(p, &a, with_mat ? "albedo.png" : NULL));
        MfObjInfo info;
        MfObjOptions opt = {.read_mtl = 1};
        CHECK_OK(mf_obj_read_ex(p, &opt, &b, &info));
        CHECK(b.nv == a.nv && b.nt == a.nt);
        if (b.nv == a.nv && b.nt == a.nt) {
            CHECK_MSG(same_floats(a.pos, b.pos, 3 * (size_t)a.nv), "variant %d: positions differ", variant);
            CHECK_MSG(same_floats(a.uv, b.uv, 2 * (size_t)a.nv), "variant %d: uvs differ", variant);
            CHECK_MSG(same_floats(a.nrm, b.nrm, 3 * (size_t)a.nv), "variant %d: normals differ", variant);
            CHECK(memcmp(a.tri, b.tri, sizeof(uint32_t) * 3 * (size_t)a.nt) == 0);
        }
        CHECK(info.n_degenerate == 0 && info.n_polygons == 0);
        if (with_mat) {
            CHECK(b.nmat == 2 && b.mat && b.mat_names);
            if (b.mat && b.mat_names && b.nmat == 2) {
                CHECK(strcmp(b.mat_names[0], "body") == 0 && strcmp(b.mat_names[1], "trim") == 0);
                CHECK(memcmp(a.mat, b.mat, sizeof(int) * (size_t)a.nt) == 0);
            }
            CHECK(strstr(info.mtllib, "grid.mtl") != NULL);
            CHECK(info.mtl.n == 2);
            if (info.mtl.n == 2) {
                CHECK(strcmp(info.mtl.names[1], "trim") == 0);
                CHECK(info.mtl.map_kd[0] && strcmp(info.mtl.map_kd[0], "albedo.png") == 0);
            }
        } else {
            CHECK(b.mat == NULL && b.nmat == 0 && info.mtllib[0] == '\0');
        }
        mf_mtl_free(&info.mtl);
        mf_mesh_free(&a);
        mf_mesh_free(&b);
    }
    /* A material-less mesh written with a texture gets one material "material". */
    MfMesh a = {0}, b = {0};
    make_grid(&a, 2, 1, 1, 0);
    CHECK_OK(mf_obj_write(mf_test_path("one.obj"), &a, "albedo.png"));
    MfMtl mtl = {0};
    CHECK_OK(mf_mtl_read(mf_test_path("one.mtl"), &mtl));
    CHECK(mtl.n == 1 && strcmp(mtl.names[0], "material") == 0 && mtl.map_kd[0] && strcmp(mtl.map_kd[0], "albedo.png") == 0);
    mf_mtl_free(&mtl);
    CHECK_OK(mf_obj_read(mf_test_path("one.obj"), &b));
    CHECK(b.nmat == 1 && b.mat_names && strcmp(b.mat_names[0], "material") == 0);
    mf_mesh_free(&a);
    mf_mesh_free(&b);
}

static const char *write_text(const char *name, const char *text) {
    const char *p = mf_test_path(name);
    mf_write_file(p, text, strlen(text));
    return p;
}

MF_TEST(io_obj_forms) {
    /* A unit cube as 6 quads, positions only, mixed with comments, o/g/s lines, CRLF. */
    const char *cube =
        "# cube\r\no cube\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nv 0 0 1\r\nv 1 0 1\r\nv 1 1 1\r\nv 0 1 1\r\n"
        "g sides\r\ns off\r\nf 1 4 3 2\r\nf 5 6 7 8  # top\r\nf 1 2 6 5\r\nf 2 3 7 6\r\nf 3 4 8 7\r\nf 4 1 5 8\r\n";
    MfMesh m = {0};
    MfObjInfo info;
    CHECK_OK(mf_obj_read_ex(write_text("cube.obj", cube), NULL, &m, &info));
    CHECK(m.nv == 8 && m.nt == 12 && m.uv == NULL && m.nrm == NULL && m.mat == NULL);
    CHECK(info.n_polygons == 6 && info.n_degenerate == 0);
    /* Fan triangulation of face 2 (5 6 7 8): (5 6 7), (5 7 8) as 0-based ids of unified vertices. */
    if (m.nt == 12) CHECK(m.tri[6] == m.tri[9] && m.tri[8] == m.tri[10]);
    mf_mesh_free(&m);

    /* A pentagon with v/vt/vn corners, then a triangle with negative indices and v//vn. */
    const char *poly =
        "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 1.5 0\nv -0.5 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 1\nvt 0 1 0\n"
        "vn 0 0 1\n"
        "usemtl red\nf 1/1/1 2/2/1 3/3/1 4/4/1 5/5/1\n"
        "v 0 0 1\nv 1 0 1\nv 0 1 1\n"
        "usemtl blue\nf -3/1/-1 -2/2/1 -1/3/-1\n"
        "usemtl red\nf 1/1/1 2/2/1 3/3/1\n";
    CHECK_OK(mf_obj_read_ex(write_text("poly.obj", poly), NULL, &m, &info));
    CHECK(m.nt == 3 + 1 + 1);
    CHECK(m.nv == 5 + 3); /* the last face reuses (1,1,1), (2,2,1), (3,3,1) */
    CHECK(m.uv != NULL && m.nrm != NULL);
    CHECK(m.nmat == 2 && m.mat && m.mat_names && strcmp(m.mat_names[0], "red") == 0 && strcmp(m.mat_names[1], "blue") == 0);
    if (m.mat && m.nt == 5) CHECK(m.mat[0] == 0 && m.mat[2] == 0 && m.mat[3] == 1 && m.mat[4] == 0);
    if (m.nt == 5 && m.uv) {
        uint32_t v = m.tri[9]; /* first corner of the negative-index face = vertex 6 (0, 0, 1) */
        CHECK(m.pos[3 * v] == 0.0f && m.pos[3 * v + 2] == 1.0f && m.uv[2 * v] == 0.0f);
        CHECK(memcmp(m.tri + 12, m.tri, 3 * sizeof(uint32_t)) == 0);
    }
    CHECK(info.n_polygons == 1);
    mf_mesh_free(&m);

    /* Faces before the first usemtl get "default"; vt on some corners only -> uv with zeros;
     * vn on some corners only -> no normals. */
    const char *mixed = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvn 0 0 1\nf 1 2 3\nusemtl m\nf 1/1/1 2//1 3/1\n";
    CHECK_OK(mf_obj_read(write_text("mixed.obj", mixed), &m));
    CHECK(m.nt == 2 && m.nv == 6 && m.uv && !m.nrm);
    CHECK(m.nmat == 2 && m.mat_names && strcmp(m.mat_names[0], "default") == 0 && strcmp(m.mat_names[1], "m") == 0);
    if (m.uv && m.nv == 6) CHECK(m.uv[0] == 0.0f && m.uv[2] == 0.25f && m.uv[3] == 0.5f); /* sorted by v: (1), (1/1/1), ... */
    mf_mesh_free(&m);

    /* Extra components (v with w / colours, vt with w) and an empty file. */
    CHECK_OK(mf_obj_read(write_text("extra.obj", "v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nvt 1 2 3\nf 1/1 2/1 3/1\n"), &m));
    CHECK(m.nt == 1 && m.uv && m.uv[0] == 1.0f && m.uv[1] == 2.0f);
    mf_mesh_free(&m);
    CHECK_OK(mf_obj_read(write_text("empty.obj", "# nothing\n"), &m));
    CHECK(m.nv == 0 && m.nt == 0);
    mf_mesh_free(&m);
}

MF_TEST(io_obj_errors) {
    MfMesh m = {0};
    const char *tri3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    char buf[256];
    snprintf(buf, sizeof buf, "%sf 1 2 12\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("range.obj", buf), &m), "range.obj:4: face index 12 out of range (3 vertices)");
    CHECK(m.pos == NULL);
    snprintf(buf, sizeof buf, "%sf 1 2 -4\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("neg.obj", buf), &m), "neg.obj:4: face index -4 out of range (3 vertices)");
    snprintf(buf, sizeof buf, "%sf 0 1 2\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("zero.obj", buf), &m), "zero.obj:4: face index 0 out of range");
    snprintf(buf, sizeof buf, "%svt 0 0\nf 1/1 2/2 3/1\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("vt.obj", buf), &m), "vt.obj:5: texture coordinate index 2 out of range (1 texture coordinates)");
    snprintf(buf, sizeof buf, "%sf 1//1 2//1 3//1\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("vn.obj", buf), &m), "vn.obj:4: normal index 1 out of range (0 normals)");
    CHECK_ERR(mf_obj_read(write_text("nan.obj", "v 0 0 0\nv 1 abc 0\n"), &m), "nan.obj:2: bad number 'abc'");
    CHECK_ERR(mf_obj_read(write_text("nan2.obj", "v 0 0 nan\n"), &m), "nan2.obj:1: bad number 'nan'");
    CHECK_ERR(mf_obj_read(write_text("num.obj", "v 0 0 1.5x\n"), &m), "num.obj:1: bad number '1.5x'");
    CHECK_ERR(mf_obj_read(write_text("short.obj", "v 0 0\n"), &m), "short.obj:1: 'v' needs 3 numbers, got 2");
    snprintf(buf, sizeof buf, "%sf 1 2\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("two.obj", buf), &m), "two.obj:4: face with 2 vertices (need at least 3)");
    snprintf(buf, sizeof buf, "%sf 1 2/x 3\n", tri3);
    CHECK_ERR(mf_obj_read(write_text("corner.obj", buf), &m), "corner.obj:4: bad face corner '2/x'");
    CHECK_ERR(mf_obj_read(mf_test_path("absent.obj"), &m), "absent.obj");
    MfObjOptions opt = {.read_mtl = 1};
    MfObjInfo info;
    snprintf(buf, sizeof buf, "mtllib nothere.mtl\n%sf 1 2 3\n", tri3);
    CHECK_ERR(mf_obj_read_ex(write_text("mtl.obj", buf), &opt, &m, &info), "nothere.mtl");
    CHECK(m.pos == NULL);
}

MF_TEST(io_obj_degenerate) {
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 2\nf 1 2 4\n";
    const char *p = write_text("degen.obj", text);
    MfMesh m = {0};
    MfObjInfo info;
    CHECK_OK(mf_obj_read_ex(p, NULL, &m, &info));
    CHECK(m.nt == 3 && info.n_degenerate == 2); /* repeated vertex and collinear */
    mf_mesh_free(&m);
    MfObjOptions opt = {.reject_degenerate = 1};
    CHECK_ERR(mf_obj_read_ex(p, &opt, &m, &info), "degen.obj: 2 degenerate");
    CHECK(m.pos == NULL);
}

MF_TEST(io_obj_large) {
    /* 2 * 160^2 = 51200 triangles, 25921 vertices: exercises hash map growth; the written file
     * reads back with the same vertex count (unification does not merge distinct indices). */
    MfMesh a = {0}, b = {0};
    make_grid(&a, 160, 1, 1, 0);
    const char *p = mf_test_path("large.obj");
    CHECK_OK(mf_obj_write(p, &a, NULL));
    CHECK_OK(mf_obj_read(p, &b));
    CHECK(b.nv == a.nv && b.nt == a.nt);
    if (b.nv == a.nv && b.nt == a.nt) {
        CHECK(same_floats(a.pos, b.pos, 3 * (size_t)a.nv) && same_floats(a.uv, b.uv, 2 * (size_t)a.nv));
        CHECK(memcmp(a.tri, b.tri, sizeof(uint32_t) * 3 * (size_t)a.nt) == 0);
    }
    mf_mesh_free(&a);
    mf_mesh_free(&b);
}
