/* Tests of tangent frames (scene/mf_tangent) and tangent-space normal maps in the forward
 * renderer (render/mf_normalmap, mf_integrator): orthonormal frames oriented along dP/du and
 * dP/dv, finite frames for degenerate UVs, the glTF/OpenGL Y+ convention with our UV and image
 * row order, and a flat map leaving renders unchanged. The adjoint is checked in
 * test_inverse_diffrender.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_eval.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "render/mf_normalmap.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"
#include "scene/mf_tangent.h"
#include "mf_test.h"
#include "mf_test_geom.h"

static MfVec3 v3at(const float *a, uint32_t i, int stride) { return mf_v3(a[stride * i], a[stride * i + 1], a[stride * i + 2]); }

MF_TEST(normalmap_tangents_follow_uv) {
    MfMesh m;
    CHECK_OK(mf_shape_uv_sphere(&m, mf_v3(0, 0, 0), 0.5f, 24, 12));
    float *tan = malloc((size_t)m.nv * 4 * sizeof(float));
    CHECK_OK(mf_mesh_tangents(&m, tan));
    int bad = 0, checked = 0;
    for (int t = 0; t < m.nt; ++t) {
        const uint32_t *v = m.tri + 3 * t;
        MfVec3 p0 = v3at(m.pos, v[0], 3), e1 = mf_sub(v3at(m.pos, v[1], 3), p0), e2 = mf_sub(v3at(m.pos, v[2], 3), p0);
        float du1 = m.uv[2 * v[1]] - m.uv[2 * v[0]], dv1 = m.uv[2 * v[1] + 1] - m.uv[2 * v[0] + 1];
        float du2 = m.uv[2 * v[2]] - m.uv[2 * v[0]], dv2 = m.uv[2 * v[2] + 1] - m.uv[2 * v[0] + 1];
        float r = du1 * dv2 - du2 * dv1;
        if (fabsf(r) < 1e-8f) continue;
        MfVec3 dpdu = mf_scale(mf_sub(mf_scale(e1, dv2), mf_scale(e2, dv1)), 1.0f / r);
        MfVec3 dpdv = mf_scale(mf_sub(mf_scale(e2, du1), mf_scale(e1, du2)), 1.0f / r);
        for (int k = 0; k < 3; ++k) {
            MfVec3 T = v3at(tan, v[k], 4), N = v3at(m.nrm, v[k], 3);
            float w = tan[4 * v[k] + 3];
            MfVec3 B = mf_scale(mf_cross(N, T), w);
            ++checked;
            if (fabsf(mf_len(T) - 1.0f) > 1e-4f || fabsf(mf_dot(T, N)) > 1e-4f || fabsf(w) != 1.0f) ++bad;
            /* pole vertices are shared by a fan: only require agreement off the poles */
            if (fabsf(N.z) < 0.9f && (mf_dot(T, mf_norm(dpdu)) < 0.9f || mf_dot(B, mf_norm(dpdv)) < 0.9f)) ++bad;
        }
    }
    CHECK(checked > 100);
    CHECK_MSG(bad == 0, "%d of %d vertex frames disagree with dP/du, dP/dv", bad, checked);
    free(tan);
    mf_mesh_free(&m);
}

/* Two triangles: one with all UVs equal (degenerate), one of zero area. */
MF_TEST(normalmap_tangents_degenerate_uvs_are_finite) {
    MfMesh m;
    CHECK_OK(mf_mesh_alloc(&m, 6, 2, 0, 1));
    const float pos[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    memcpy(m.pos, pos, sizeof pos);
    for (int i = 0; i < 12; ++i) m.uv[i] = 0.25f;
    m.uv[8] = 0.5f, m.uv[11] = 0.9f;
    for (int i = 0; i < 6; ++i) m.tri[i] = (uint32_t)i;
    float tan[24];
    CHECK_OK(mf_mesh_tangents(&m, tan));
    for (int i = 0; i < 24; ++i) CHECK(isfinite(tan[i]));
    for (int i = 0; i < 6; ++i) CHECK(fabsf(mf_len(v3at(tan, (uint32_t)i, 4)) - 1.0f) < 1e-5f);
    /* no UVs: a clear error */
    free(m.uv);
    m.uv = NULL;
    CHECK_ERR(mf_mesh_tangents(&m, tan), "no UVs");
    mf_mesh_free(&m);
}

/* A unit quad in z = 0 facing +z, u along +x, v along +y. A texel tilting toward +X tilts the
 * normal toward +x (increasing u); toward +Y, toward +y (increasing v = toward the image's row
 * 0); the map's row 0 is the top (v = 1). */
MF_TEST(normalmap_convention_gltf_y_up) {
    MfMesh m;
    CHECK_OK(mf_mesh_alloc(&m, 4, 2, 1, 1));
    const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m.pos, pos, sizeof pos), memcpy(m.uv, uv, sizeof uv), memcpy(m.tri, tri, sizeof tri);
    for (int i = 0; i < 4; ++i) m.nrm[3 * i] = m.nrm[3 * i + 1] = 0.0f, m.nrm[3 * i + 2] = 1.0f;
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&m, &rt));
    float tan[16];
    CHECK_OK(mf_mesh_tangents(&m, tan));
    MfImage map;
    CHECK_OK(mf_image_alloc(&map, 1, 2, 3));
    float *top = map.data, *bot = map.data + 3; /* row 0: tilt +X; row 1: tilt +Y */
    top[0] = 0.75f, top[1] = 0.5f, top[2] = 1.0f;
    bot[0] = 0.5f, bot[1] = 0.75f, bot[2] = 1.0f;
    MfHit h;
    MfVec3 wo = mf_v3(0, 0, 1);
    CHECK(mf_rtscene_intersect(rt, mf_v3(0.5f, 0.75f, 1.0f), mf_v3(0, 0, -1), 0.0f, INFINITY, &h)); /* v = 0.75: row 0 */
    MfNmapFrame f = mf_nmap_frame(&m, tan, &h);
    MfVec3 n = mf_nmap_normal(&f, &map, h.uv, wo);
    CHECK_NEAR(n.x, 0.5f / sqrtf(1.25f), 1e-4);
    CHECK_NEAR(n.y, 0.0f, 1e-4);
    CHECK(mf_rtscene_intersect(rt, mf_v3(0.5f, 0.25f, 1.0f), mf_v3(0, 0, -1), 0.0f, INFINITY, &h)); /* v = 0.25: row 1 */
    f = mf_nmap_frame(&m, tan, &h);
    n = mf_nmap_normal(&f, &map, h.uv, wo);
    CHECK_NEAR(n.x, 0.0f, 1e-4);
    CHECK_NEAR(n.y, 0.5f / sqrtf(1.25f), 1e-4);
    /* seen from below (normals flipped toward the viewer) the relief is the same surface's:
     * the mapped normal is the negated front one */
    CHECK(mf_rtscene_intersect(rt, mf_v3(0.5f, 0.25f, -1.0f), mf_v3(0, 0, 1), 0.0f, INFINITY, &h));
    f = mf_nmap_frame(&m, tan, &h);
    MfVec3 nb = mf_nmap_normal(&f, &map, h.uv, mf_v3(0, 0, -1));
    CHECK_NEAR(nb.y, -0.5f / sqrtf(1.25f), 1e-4);
    CHECK(nb.z < 0.0f);
    mf_image_free(&map);
    mf_rtscene_free(rt);
    mf_mesh_free(&m);
}

/* Forward renderer: a flat map (0.5, 0.5, 1) renders the same image as no map (up to rounding
 * of the renormalised normal); a tilted map changes it. */
MF_TEST(normalmap_flat_map_renders_unchanged) {
    MfMesh m;
    CHECK_OK(mf_shape_uv_sphere(&m, mf_v3(0, 0, 0), 0.5f, 24, 12));
    MfRtScene *rt = NULL;
    CHECK_OK(mf_rtscene_new(&m, &rt));
    MfEnvMap env;
    MfImage envi;
    CHECK_OK(mf_image_alloc(&envi, 16, 8, 3));
    for (int i = 0; i < 16 * 8 * 3; ++i) envi.data[i] = 0.2f + (float)((i * 7) % 11) / 5.0f;
    CHECK_OK(mf_env_init(&env, &envi));
    MfImage flat;
    CHECK_OK(mf_image_alloc(&flat, 8, 8, 3));
    for (int i = 0; i < 64; ++i) flat.data[3 * i] = flat.data[3 * i + 1] = 0.5f, flat.data[3 * i + 2] = 1.0f;
    MfTexMaterial mat = {.kd = NULL, .orm = NULL, .kd_const = mf_v3(0.6f, 0.5f, 0.4f), .orm_const = mf_v3(1, 0.3f, 0.2f), .normal = NULL};
    MfRenderInput in = {rt, &m, &mat, 1, &env, NULL, 0};
    MfCamera cam;
    CHECK_OK(look_cam(&cam, 16, 16, mf_v3(0.3f, -1.6f, 0.5f), mf_v3(0, 0, 0)));
    MfRenderOpts o = {.spp_sqrt = 2, .pixel_samples = 1, .seed = 3, .lobes = MF_LOBE_ALL};
    MfRenderOut a, b, c;
    CHECK_OK(mf_render(&in, &cam, &o, &a, NULL));
    mat.normal = &flat;
    CHECK_OK(mf_render(&in, &cam, &o, &b, NULL));
    double worst = 0, mx = 0, dn = 0;
    for (int i = 0; i < 16 * 16 * 3; ++i) {
        worst = fmax(worst, fabs(a.rgb[i] - b.rgb[i]));
        mx = fmax(mx, fabs(a.rgb[i]));
        dn = fmax(dn, fabs(a.normal[i] - b.normal[i]));
    }
    CHECK(mx > 0.05);
    CHECK_MSG(worst < 1e-4 * mx, "flat map changes the render by %.3g", worst);
    CHECK(dn < 1e-5);
    for (int i = 0; i < 64; ++i) flat.data[3 * i] = 0.8f; /* tilted */
    CHECK_OK(mf_render(&in, &cam, &o, &c, NULL));
    double diff = 0;
    for (int i = 0; i < 16 * 16 * 3; ++i) diff = fmax(diff, fabs(a.rgb[i] - c.rgb[i]));
    CHECK(diff > 1e-2 * mx);
    mf_render_out_free(&a), mf_render_out_free(&b), mf_render_out_free(&c);
    mf_image_free(&flat);
    mf_env_free(&env);
    mf_rtscene_free(rt);
    mf_mesh_free(&m);
}

/* A result folder's normal.png is loaded (and used by relighting) when present, not otherwise. */
MF_TEST(normalmap_result_folder_loads_normal_png) {
    const char *dir = mf_test_path("nmres");
    char p[1024];
    CHECK_OK(mf_mkdirs(dir));
    MfMesh m;
    CHECK_OK(mf_shape_uv_sphere(&m, mf_v3(0, 0, 0), 0.5f, 8, 4));
    snprintf(p, sizeof p, "%s/mesh.obj", dir);
    CHECK_OK(mf_obj_write(p, &m, "albedo.png"));
    MfImage im;
    CHECK_OK(mf_image_alloc(&im, 4, 4, 3));
    for (int i = 0; i < 48; ++i) im.data[i] = 0.5f;
    snprintf(p, sizeof p, "%s/albedo.png", dir);
    CHECK_OK(mf_image_write(p, &im, MF_ENC_SRGB, 8));
    snprintf(p, sizeof p, "%s/orm.png", dir);
    CHECK_OK(mf_image_write(p, &im, MF_ENC_LINEAR, 8));
    EvResult r;
    CHECK_OK(ev_result_load(dir, NULL, &r));
    CHECK(!r.has_normal);
    ev_result_free(&r);
    for (int i = 0; i < 16; ++i) im.data[3 * i] = 0.75f, im.data[3 * i + 2] = 1.0f;
    snprintf(p, sizeof p, "%s/normal.png", dir);
    CHECK_OK(mf_image_write(p, &im, MF_ENC_LINEAR, 8));
    CHECK_OK(ev_result_load(dir, NULL, &r));
    CHECK(r.has_normal && r.normal.w == 4 && r.normal.c == 3);
    if (r.has_normal) CHECK_NEAR(r.normal.data[0], 191.0f / 255.0f, 1e-6); /* linear 8-bit, not sRGB-decoded */
    ev_result_free(&r);
    mf_image_free(&im);
    mf_mesh_free(&m);
}
