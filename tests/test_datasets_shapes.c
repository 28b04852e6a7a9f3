/* Tests of datasets/ds_shapes + ds_materials: determinism, mesh validity (closed, oriented,
 * non-degenerate, normalised), UV atlas (in range, no overlaps), material ranges, baking. */
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "datasets/ds_shapes.h"
#include "mf_test.h"

/* Bilinear lookup (u right, v up, texel centres at integers, clamped), kept local so the test
 * does not depend on the texture module. */
static void tex_bilinear(const MfImage *t, float u, float v, float *out) {
    float x = u * t->w - 0.5f, y = (1.0f - v) * t->h - 0.5f;
    int x0 = (int)floorf(x), y0 = (int)floorf(y);
    float fx = x - x0, fy = y - y0;
    for (int c = 0; c < t->c; ++c) out[c] = 0.0f;
    for (int dy = 0; dy <= 1; ++dy)
        for (int dx = 0; dx <= 1; ++dx) {
            int xx = x0 + dx, yy = y0 + dy;
            xx = xx < 0 ? 0 : (xx >= t->w ? t->w - 1 : xx);
            yy = yy < 0 ? 0 : (yy >= t->h ? t->h - 1 : yy);
            float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
            for (int c = 0; c < t->c; ++c) out[c] += w * mf_image_px(t, xx, yy)[c];
        }
}

static MfVec3 vpos(const MfMesh *m, uint32_t i) { return mf_v3(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]); }

MF_TEST(ds_shapes_determinism) {
    DsObject a = {0}, b = {0}, c = {0};
    CHECK_OK(ds_object_generate(&a, DS_FAM_MUG, 7, 64));
    CHECK_OK(ds_object_generate(&b, DS_FAM_MUG, 7, 64));
    CHECK_OK(ds_object_generate(&c, DS_FAM_MUG, 8, 64));
    CHECK(a.mesh.nv == b.mesh.nv && a.mesh.nt == b.mesh.nt);
    if (a.mesh.nv == b.mesh.nv && a.mesh.nt == b.mesh.nt) {
        CHECK(!memcmp(a.mesh.pos, b.mesh.pos, sizeof(float) * 3 * a.mesh.nv));
        CHECK(!memcmp(a.mesh.nrm, b.mesh.nrm, sizeof(float) * 3 * a.mesh.nv));
        CHECK(!memcmp(a.mesh.uv, b.mesh.uv, sizeof(float) * 2 * a.mesh.nv));
        CHECK(!memcmp(a.mesh.tri, b.mesh.tri, sizeof(uint32_t) * 3 * a.mesh.nt));
        CHECK(!memcmp(a.kd.data, b.kd.data, sizeof(float) * 3 * 64 * 64));
        CHECK(!memcmp(a.orm.data, b.orm.data, sizeof(float) * 3 * 64 * 64));
    }
    int differ = a.mesh.nv != c.mesh.nv || memcmp(a.mesh.pos, c.mesh.pos, sizeof(float) * 3 * a.mesh.nv) ||
                 memcmp(a.kd.data, c.kd.data, sizeof(float) * 3 * 64 * 64);
    CHECK(differ);
    CHECK_ERR(ds_object_generate(&c, DS_FAM_COUNT, 1, 64), "family");
    CHECK_ERR(ds_object_generate(&c, DS_FAM_CUP, 1, 4), "texture resolution");
    ds_object_free(&a);
    ds_object_free(&b);
    ds_object_free(&c);
    CHECK(ds_family_from_name("clock") == DS_FAM_CLOCK && ds_family_from_name("nope") == -1);
}

/* Edges with use count != 2 after welding positions (1e-5 grid) within each part. */
typedef struct { int64_t a, b; } Edge;
static int edge_cmp(const void *x, const void *y) {
    const Edge *p = x, *q = y;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    return p->b < q->b ? -1 : (p->b > q->b);
}
typedef struct { int64_t k[4]; int idx; } VKey;
static int vkey_cmp(const void *x, const void *y) {
    const VKey *p = x, *q = y;
    for (int i = 0; i < 4; ++i)
        if (p->k[i] != q->k[i]) return p->k[i] < q->k[i] ? -1 : 1;
    return 0;
}

static int open_edges(const MfMesh *m, int *n_edges) {
    size_t nv = (size_t)(m->nv > 0 ? m->nv : 0) + 1;
    VKey *keys = malloc(sizeof(VKey) * nv);
    int *vpart = calloc(nv, sizeof(int)), *rep = malloc(sizeof(int) * nv);
    for (int t = 0; t < m->nt; ++t)
        for (int k = 0; k < 3; ++k) vpart[m->tri[3 * t + k]] = m->mat[t];
    for (int i = 0; i < m->nv; ++i) {
        for (int k = 0; k < 3; ++k) keys[i].k[k] = llrint(m->pos[3 * i + k] * 1e5);
        keys[i].k[3] = vpart[i];
        keys[i].idx = i;
    }
    qsort(keys, m->nv, sizeof(VKey), vkey_cmp);
    int id = -1;
    for (int i = 0; i < m->nv; ++i) {
        if (i == 0 || vkey_cmp(&keys[i], &keys[i - 1])) ++id;
        rep[keys[i].idx] = id;
    }
    Edge *e = malloc(sizeof(Edge) * 3 * m->nt);
    for (int t = 0; t < m->nt; ++t)
        for (int k = 0; k < 3; ++k) {
            int64_t a = rep[m->tri[3 * t + k]], b = rep[m->tri[3 * t + (k + 1) % 3]];
            e[3 * t + k].a = a < b ? a : b;
            e[3 * t + k].b = a < b ? b : a;
        }
    qsort(e, 3 * (size_t)m->nt, sizeof(Edge), edge_cmp);
    int bad = 0, ne = 0;
    for (int i = 0; i < 3 * m->nt;) {
        int j = i;
        while (j < 3 * m->nt && !edge_cmp(&e[i], &e[j])) ++j;
        if (j - i != 2) ++bad;
        ++ne;
        i = j;
    }
    free(keys); free(vpart); free(rep); free(e);
    *n_edges = ne;
    return bad;
}

/* Texels (of a res x res grid) whose centre lies strictly inside more than one UV triangle. */
static long uv_overlaps(const MfMesh *m, int res, long *covered) {
    unsigned char *cnt = calloc((size_t)res * res, 1);
    for (int t = 0; t < m->nt; ++t) {
        float X[3], Y[3];
        for (int k = 0; k < 3; ++k) { X[k] = m->uv[2 * m->tri[3 * t + k]] * res; Y[k] = m->uv[2 * m->tri[3 * t + k] + 1] * res; }
        float den = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
        if (fabsf(den) < 1e-12f) continue;
        int x0 = (int)fmaxf(0, floorf(fminf(X[0], fminf(X[1], X[2])))), x1 = (int)fminf(res - 1, ceilf(fmaxf(X[0], fmaxf(X[1], X[2]))));
        int y0 = (int)fmaxf(0, floorf(fminf(Y[0], fminf(Y[1], Y[2])))), y1 = (int)fminf(res - 1, ceilf(fmaxf(Y[0], fmaxf(Y[1], Y[2]))));
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x) {
                float px = x + 0.5f, py = y + 0.5f;
                float b1 = ((px - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (py - Y[0])) / den;
                float b2 = ((X[1] - X[0]) * (py - Y[0]) - (px - X[0]) * (Y[1] - Y[0])) / den;
                if (b1 > 1e-4f && b2 > 1e-4f && 1.0f - b1 - b2 > 1e-4f && cnt[y * res + x] < 255) cnt[y * res + x]++;
            }
    }
    long over = 0, cov = 0;
    for (long i = 0; i < (long)res * res; ++i) { over += cnt[i] > 1; cov += cnt[i] > 0; }
    free(cnt);
    *covered = cov;
    return over;
}

MF_TEST(ds_shapes_all_families_valid) {
    for (int fam = 0; fam < DS_FAM_COUNT; ++fam)
        for (uint64_t seed = 1; seed <= 2; ++seed) {
            DsObject o = {0};
            int rc = ds_object_generate(&o, (DsFamily)fam, seed, 128);
            CHECK_MSG(rc == 0, "%s seed %d: %s", ds_family_name(fam), (int)seed, mf_error());
            if (rc) continue;
            const MfMesh *m = &o.mesh;
            const char *fn = ds_family_name(fam);
            CHECK_MSG(m->nt > 500 && m->nv > 300 && m->uv && m->nrm && m->mat, "%s: %d tris", fn, m->nt);
            CHECK_MSG(mf_mesh_count_degenerate(m, 1e-10f) == 0, "%s: %d degenerate", fn, mf_mesh_count_degenerate(m, 1e-10f));
            MfVec3 lo, hi;
            mf_mesh_bounds(m, &lo, &hi);
            CHECK_NEAR(mf_maxc(mf_sub(hi, lo)), 1.0, 1e-5);
            CHECK_NEAR(lo.x + hi.x, 0.0, 1e-5);
            CHECK_NEAR(lo.y + hi.y, 0.0, 1e-5);
            CHECK_NEAR(lo.z + hi.z, 0.0, 1e-5);
            int bad_uv = 0, bad_n = 0, bad_f = 0;
            for (int i = 0; i < m->nv; ++i) {
                float u = m->uv[2 * i], v = m->uv[2 * i + 1];
                bad_uv += !(u >= 0.0f && u <= 1.0f && v >= 0.0f && v <= 1.0f);
                MfVec3 n = mf_v3(m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
                bad_n += !(fabsf(mf_len(n) - 1.0f) < 1e-4f);
                bad_f += !mf_isfinite3(vpos(m, i));
            }
            CHECK_MSG(!bad_uv && !bad_n && !bad_f, "%s: %d uv out of range, %d non-unit normals, %d non-finite", fn, bad_uv, bad_n, bad_f);
            int ne = 0, open = open_edges(m, &ne);
            CHECK_MSG(open == 0, "%s seed %d: %d of %d edges not shared by exactly two triangles", fn, (int)seed, open, ne);
            /* outward: per-part signed volume > 0 and vertex normals agree with face normals */
            double vol[DS_MAX_PARTS] = {0};
            int disagree = 0;
            for (int t = 0; t < m->nt; ++t) {
                const uint32_t *f = m->tri + 3 * t;
                MfVec3 p0 = vpos(m, f[0]), p1 = vpos(m, f[1]), p2 = vpos(m, f[2]);
                vol[m->mat[t]] += mf_dot(p0, mf_cross(p1, p2));
                MfVec3 fnrm = mf_cross(mf_sub(p1, p0), mf_sub(p2, p0)), vn = mf_v3s(0);
                for (int k = 0; k < 3; ++k) vn = mf_add(vn, mf_v3(m->nrm[3 * f[k]], m->nrm[3 * f[k] + 1], m->nrm[3 * f[k] + 2]));
                disagree += mf_dot(fnrm, vn) <= 0.0f;
            }
            for (int p = 0; p < o.nparts; ++p) CHECK_MSG(vol[p] > 0.0, "%s: part %s has volume %g", fn, o.parts[p].name, vol[p]);
            CHECK_MSG(disagree <= m->nt / 200, "%s: %d of %d faces disagree with vertex normals", fn, disagree, m->nt);
            /* smooth normals are not averaged across sharp creases: vertex normals stay close to
             * the faces around them */
            int steep = 0;
            for (int t = 0; t < m->nt; ++t) {
                const uint32_t *f = m->tri + 3 * t;
                MfVec3 fnrm = mf_norm(mf_cross(mf_sub(vpos(m, f[1]), vpos(m, f[0])), mf_sub(vpos(m, f[2]), vpos(m, f[0]))));
                for (int k = 0; k < 3; ++k)
                    steep += mf_dot(fnrm, mf_v3(m->nrm[3 * f[k]], m->nrm[3 * f[k] + 1], m->nrm[3 * f[k] + 2])) < 0.7071f;
            }
            CHECK_MSG(steep <= 3 * m->nt / 200, "%s: %d of %d triangle corners deviate > 45 deg from the vertex normal", fn, steep, 3 * m->nt);
            long cov = 0, over = uv_overlaps(m, 512, &cov);
            CHECK_MSG(cov > 512 * 512 * 3 / 10 && over <= cov / 1000, "%s: UV overlap %ld of %ld covered texels", fn, over, cov);
            /* textures: finite, in range, R = 1 */
            int bad_tex = 0;
            for (size_t i = 0; i < (size_t)128 * 128 * 3; ++i) bad_tex += !(o.kd.data[i] >= 0.0f && o.kd.data[i] <= 1.0f);
            for (size_t i = 0; i < (size_t)128 * 128; ++i) {
                float *q = o.orm.data + 3 * i;
                bad_tex += !(q[0] == 1.0f && q[1] >= 0.0f && q[1] <= 1.0f && q[2] >= 0.0f && q[2] <= 1.0f);
            }
            CHECK_MSG(!bad_tex, "%s: %d texel values out of range", fn, bad_tex);
            ds_object_free(&o);
        }
}

/* Baked texels sampled at vertex UVs respect the class ranges of the vertex's part. */
MF_TEST(ds_shapes_material_ranges_in_textures) {
    int seen[DS_MAT_COUNT] = {0};
    for (int fam = 0; fam < DS_FAM_COUNT; ++fam)
        for (uint64_t seed = 10; seed < 16; ++seed) {
            DsObject o = {0};
            CHECK_OK(ds_object_generate(&o, (DsFamily)fam, seed, 128));
            const MfMesh *m = &o.mesh;
            int *vp = calloc(m->nv, sizeof(int));
            for (int t = 0; t < m->nt; ++t)
                for (int k = 0; k < 3; ++k) vp[m->tri[3 * t + k]] = m->mat[t];
            for (int p = 0; p < o.nparts; ++p) {
                const DsMaterial *mt = &o.parts[p].mat;
                int n = 0, metal_hi = 0, bad = 0;
                for (int i = 0; i < m->nv; ++i) {
                    if (vp[i] != p) continue;
                    float kd[3], orm[3];
                    tex_bilinear(&o.kd, m->uv[2 * i], m->uv[2 * i + 1], kd);
                    tex_bilinear(&o.orm, m->uv[2 * i], m->uv[2 * i + 1], orm);
                    ++n;
                    metal_hi += orm[2] > 0.99f;
                    switch (mt->cls) {
                    case DS_MAT_RUBBER: bad += orm[1] < 0.75f - 1e-4f || orm[2] > 1e-4f; break;
                    case DS_MAT_GLASS: bad += kd[0] + kd[1] + kd[2] > 1e-6f || fabsf(orm[1] - 0.25f) > 1e-5f || orm[2] > 1e-6f; break;
                    case DS_MAT_CERAMIC: bad += orm[1] > 0.35f + 1e-4f; break;
                    case DS_MAT_METAL: bad += orm[1] > 0.6f + 1e-4f; break;
                    case DS_MAT_WOOD: bad += orm[1] < 0.35f - 1e-4f || orm[2] > 1e-4f; break;
                    default: break;
                    }
                    if (!mt->mask_metal && mt->cls != DS_MAT_METAL) bad += orm[2] > 1e-4f;
                    if (!mt->mask_metal && mt->cls == DS_MAT_METAL) bad += orm[2] < 1.0f - 1e-4f;
                }
                seen[mt->cls]++;
                CHECK_MSG(bad == 0, "%s seed %d part %s (%s): %d of %d vertices out of class range", ds_family_name(fam), (int)seed,
                          o.parts[p].name, ds_mat_class_name(mt->cls), bad, n);
                if (mt->cls == DS_MAT_METAL && !mt->mask_metal) CHECK_MSG(metal_hi >= n * 6 / 10, "metal part: only %d of %d metallic", metal_hi, n);
            }
            free(vp);
            ds_object_free(&o);
        }
    for (int c = 0; c < DS_MAT_COUNT; ++c) CHECK_MSG(seen[c] > 0, "class %s never drawn", ds_mat_class_name(c));
}

/* Material functions directly: ranges per class over many draws and points. */
MF_TEST(ds_materials_ranges) {
    MfRng rng;
    mf_rng_seed(&rng, 3, 1);
    for (int c = 0; c < DS_MAT_COUNT; ++c)
        for (int k = 0; k < 40; ++k) {
            DsMaterial m;
            ds_material_random(&m, (DsMatClass)c, -1, &rng);
            float rmin = 1, rmax = 0, mmin = 1, mmax = 0;
            for (int s = 0; s < 200; ++s) {
                MfVec3 p = mf_v3(mf_rng_float(&rng) - 0.5f, mf_rng_float(&rng) - 0.5f, mf_rng_float(&rng) - 0.5f), kd;
                float r, mt;
                ds_material_eval(&m, p, mf_v3(0, 0, 1), &kd, &r, &mt);
                CHECK(kd.x >= 0 && kd.x <= 1 && kd.y >= 0 && kd.y <= 1 && kd.z >= 0 && kd.z <= 1);
                rmin = fminf(rmin, r); rmax = fmaxf(rmax, r); mmin = fminf(mmin, mt); mmax = fmaxf(mmax, mt);
            }
            switch (c) {
            case DS_MAT_METAL: CHECK(rmin >= 0.08f && rmax <= 0.6f); if (!m.mask_metal) CHECK(mmin == 1.0f); break;
            case DS_MAT_RUBBER: CHECK(rmin >= 0.75f && mmax == 0.0f); break;
            case DS_MAT_PLASTIC: CHECK(rmin >= 0.2f && rmax <= 0.7f); if (!m.mask_metal) CHECK(mmax == 0.0f); break;
            case DS_MAT_WOOD: CHECK(rmin >= 0.35f && mmax == 0.0f); break;
            case DS_MAT_CERAMIC: CHECK(rmax <= 0.35f); if (!m.mask_metal) CHECK(mmax == 0.0f); break;
            case DS_MAT_GLASS: CHECK(rmin == 0.25f && rmax == 0.25f && mmax == 0.0f); break;
            }
        }
    /* fbm is in [0,1] and varies */
    float lo = 1, hi = 0;
    for (int i = 0; i < 1000; ++i) {
        float v = ds_fbm(mf_v3(i * 0.37f, i * 0.11f, i * 0.05f), 5, 9);
        lo = fminf(lo, v); hi = fmaxf(hi, v);
    }
    CHECK(lo >= 0.0f && hi <= 1.0f && hi - lo > 0.3f);
}

/* Textures are continuous across UV seams: texels on both sides of a seam (same 3D position,
 * different UV) hold similar values. */
MF_TEST(ds_shapes_seam_continuity) {
    DsObject o = {0};
    CHECK_OK(ds_object_generate(&o, DS_FAM_BOX, 3, 256));
    const MfMesh *m = &o.mesh;
    double diff = 0.0;
    int n = 0;
    VKey *keys = malloc(sizeof(VKey) * (size_t)m->nv);
    for (int i = 0; i < m->nv; ++i) {
        for (int k = 0; k < 3; ++k) keys[i].k[k] = llrint(m->pos[3 * i + k] * 1e6);
        keys[i].k[3] = 0;
        keys[i].idx = i;
    }
    qsort(keys, m->nv, sizeof(VKey), vkey_cmp);
    for (int q = 1; q < m->nv; ++q) {
        if (vkey_cmp(&keys[q], &keys[q - 1])) continue;
        int i = keys[q - 1].idx, j = keys[q].idx;
        if (m->uv[2 * i] == m->uv[2 * j] && m->uv[2 * i + 1] == m->uv[2 * j + 1]) continue;
        float a[3], b[3];
        tex_bilinear(&o.kd, m->uv[2 * i], m->uv[2 * i + 1], a);
        tex_bilinear(&o.kd, m->uv[2 * j], m->uv[2 * j + 1], b);
        diff += fabsf(a[0] - b[0]) + fabsf(a[1] - b[1]) + fabsf(a[2] - b[2]);
        ++n;
    }
    free(keys);
    CHECK_MSG(n > 20, "only %d seam pairs found", n);
    CHECK_MSG(n > 0 && diff / (3 * n) < 0.05, "mean seam difference %g over %d pairs", n ? diff / (3 * n) : -1.0, n);
    ds_object_free(&o);
}

/* Same bytes whatever the thread count (the bake evaluates pure functions per texel); tiny
 * resolutions still pack every chart without overlap. */
MF_TEST(ds_shapes_threads_and_tiny_res) {
    DsObject a = {0}, b = {0};
    int nt = omp_get_max_threads();
    omp_set_num_threads(1);
    CHECK_OK(ds_object_generate(&a, DS_FAM_CLOCK, 21, 96));
    omp_set_num_threads(3);
    CHECK_OK(ds_object_generate(&b, DS_FAM_CLOCK, 21, 96));
    omp_set_num_threads(nt);
    CHECK(a.kd.data && b.kd.data && !memcmp(a.kd.data, b.kd.data, sizeof(float) * 3 * 96 * 96));
    CHECK(a.orm.data && b.orm.data && !memcmp(a.orm.data, b.orm.data, sizeof(float) * 3 * 96 * 96));
    ds_object_free(&a);
    ds_object_free(&b);
    CHECK_OK(ds_object_generate(&a, DS_FAM_CLOCK, 2, 16));
    long cov = 0, over = uv_overlaps(&a.mesh, 512, &cov);
    CHECK_MSG(over <= cov / 1000, "UV overlap %ld of %ld at texture size 16", over, cov);
    int bad = 0;
    for (int i = 0; i < 2 * a.mesh.nv; ++i) bad += !(a.mesh.uv[i] >= 0.0f && a.mesh.uv[i] <= 1.0f);
    CHECK(bad == 0);
    ds_object_free(&a);
}
