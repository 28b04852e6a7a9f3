#include "render/mf_rtscene.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

struct MfRtScene {
    RTCDevice dev;
    RTCScene scene;
    const MfMesh *mesh; /* borrowed */
};

static void on_embree_error(void *user, enum RTCError code, const char *str) {
    (void)user;
    mf_fail(MF_EEXT, "embree error %d: %s", (int)code, str ? str : "(no message)");
}

int mf_rtscene_new(const MfMesh *mesh, MfRtScene **out) {
    if (!mesh || mesh->nv < 0 || mesh->nt < 0 || (mesh->nt > 0 && (!mesh->pos || !mesh->tri)))
        return mf_fail(MF_EARG, "rtscene: invalid mesh");
    for (size_t i = 0; i < (size_t)mesh->nt * 3; ++i)
        if (mesh->tri[i] >= (uint32_t)mesh->nv)
            return mf_fail(MF_EARG, "rtscene: triangle %zu uses vertex %u of %d", i / 3, mesh->tri[i], mesh->nv);
    for (size_t i = 0; i < (size_t)mesh->nv * 3; ++i)
        if (!isfinite(mesh->pos[i])) return mf_fail(MF_ENAN, "rtscene: vertex %zu has a non-finite position", i / 3);
        else if (!(fabsf(mesh->pos[i]) <= (float)MF_COORD_MAX))
            return mf_fail(MF_EARG, "rtscene: vertex %zu has a coordinate %g beyond %g", i / 3, (double)mesh->pos[i], MF_COORD_MAX);
    MfRtScene *s = calloc(1, sizeof *s);
    if (!s) return mf_fail(MF_ENOMEM, "rtscene: out of memory");
    s->mesh = mesh;
    mf_error_clear();
    s->dev = rtcNewDevice(NULL);
    if (!s->dev) {
        free(s);
        return mf_fail(MF_EEXT, "embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(s->dev, on_embree_error, NULL);
    s->scene = rtcNewScene(s->dev);
    if (s->scene && mesh->nt > 0) {
        RTCGeometry g = rtcNewGeometry(s->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (g) {
            float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), (size_t)mesh->nv);
            unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), (size_t)mesh->nt);
            if (vb && ib) {
                memcpy(vb, mesh->pos, (size_t)mesh->nv * 3 * sizeof(float));
                memcpy(ib, mesh->tri, (size_t)mesh->nt * 3 * sizeof(unsigned));
                rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
                rtcCommitGeometry(g);
                rtcAttachGeometry(s->scene, g);
            }
            rtcReleaseGeometry(g);
        }
    }
    if (s->scene) {
        rtcSetSceneFlags(s->scene, RTC_SCENE_FLAG_ROBUST); /* watertight, no cracks between triangles */
        rtcSetSceneBuildQuality(s->scene, RTC_BUILD_QUALITY_HIGH);
        rtcCommitScene(s->scene);
    }
    if (!s->scene || rtcGetDeviceError(s->dev) != RTC_ERROR_NONE || mf_error()[0]) {
        if (!mf_error()[0]) mf_fail(MF_EEXT, "embree: scene construction failed");
        char msg[512];
        snprintf(msg, sizeof msg, "%s", mf_error());
        mf_rtscene_free(s);
        return mf_fail(MF_EEXT, "rtscene: %s", msg);
    }
    *out = s;
    return MF_OK;
}

void mf_rtscene_free(MfRtScene *s) {
    if (!s) return;
    if (s->scene) rtcReleaseScene(s->scene);
    if (s->dev) rtcReleaseDevice(s->dev);
    free(s);
}

void *mf_rtscene_handle(const MfRtScene *s) { return (void *)s->scene; }
const MfMesh *mf_rtscene_mesh(const MfRtScene *s) { return s->mesh; }

static MfVec3 v3at(const float *a, uint32_t i) { return mf_v3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }
static MfVec3 abs3(MfVec3 v) { return mf_v3(fabsf(v.x), fabsf(v.y), fabsf(v.z)); }

int mf_rtscene_intersect(const MfRtScene *s, MfVec3 org, MfVec3 dir, float tnear, float tfar, MfHit *hit) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = org.x; rh.ray.org_y = org.y; rh.ray.org_z = org.z;
    rh.ray.dir_x = dir.x; rh.ray.dir_y = dir.y; rh.ray.dir_z = dir.z;
    rh.ray.tnear = tnear; rh.ray.tfar = tfar;
    rh.ray.time = 0.0f; rh.ray.mask = 0xFFFFFFFFu; rh.ray.id = 0; rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;

    const MfMesh *m = s->mesh;
    uint32_t t = rh.hit.primID;
    uint32_t i0 = m->tri[3 * t], i1 = m->tri[3 * t + 1], i2 = m->tri[3 * t + 2];
    float b1 = rh.hit.u, b2 = rh.hit.v, b0 = 1.0f - b1 - b2;
    MfVec3 p0 = v3at(m->pos, i0), p1 = v3at(m->pos, i1), p2 = v3at(m->pos, i2);
    MfHit h;
    h.t = rh.ray.tfar;
    h.tri = (int)t;
    h.b1 = b1;
    h.b2 = b2;
    h.p = mf_add(mf_add(mf_scale(p0, b0), mf_scale(p1, b1)), mf_scale(p2, b2));
    /* Error bound of p: the interpolation's, gamma(7) sum |b_i p_i| (pbrt-v4,
     * Triangle::InteractionFromIntersection), plus gamma(7) max |vertex coordinate| on every axis
     * for Embree's plane test from an origin that close (it subtracts the origin from the
     * vertices; exact zeros, e.g. a plane z = 0, otherwise give a zero bound). */
    const float g7 = 7.0f * 0x1p-24f / (1.0f - 7.0f * 0x1p-24f);
    MfVec3 a0 = abs3(p0), a1 = abs3(p1), a2 = abs3(p2);
    float vmax = fmaxf(fmaxf(mf_maxc(a0), mf_maxc(a1)), mf_maxc(a2));
    h.perr = mf_scale(mf_add(mf_add(mf_add(abs3(mf_scale(p0, b0)), abs3(mf_scale(p1, b1))), abs3(mf_scale(p2, b2))), mf_v3s(vmax)), g7);
    MfVec3 wo = mf_neg(dir);
    MfVec3 ng = mf_cross(mf_sub(p1, p0), mf_sub(p2, p0));
    float lg = mf_len(ng);
    int have_ng = lg > 0.0f && isfinite(lg);
    ng = have_ng ? mf_scale(ng, 1.0f / lg) : wo;
    float flip = mf_dot(ng, wo) < 0.0f ? -1.0f : 1.0f;
    ng = mf_scale(ng, flip);
    MfVec3 ns = ng;
    if (m->nrm) {
        MfVec3 n = mf_add(mf_add(mf_scale(v3at(m->nrm, i0), b0), mf_scale(v3at(m->nrm, i1), b1)), mf_scale(v3at(m->nrm, i2), b2));
        float ln = mf_len(n);
        if (ln > 1e-12f && isfinite(ln)) {
            ns = mf_scale(n, flip / ln);
            if (!have_ng && mf_dot(ns, wo) < 0.0f) ns = mf_neg(ns);
        }
    }
    /* Bend a back-facing shading normal toward the viewer (silhouettes of smooth meshes). */
    float c = mf_dot(ns, wo);
    if (c < 0.01f) {
        ns = mf_norm(mf_madd(ns, wo, 0.01f - c));
        if (!(mf_dot(ns, wo) > 0.0f) || !mf_isfinite3(ns)) ns = ng;
    }
    h.ng = ng;
    h.ns = ns;
    if (m->uv) {
        h.uv.x = b0 * m->uv[2 * i0] + b1 * m->uv[2 * i1] + b2 * m->uv[2 * i2];
        h.uv.y = b0 * m->uv[2 * i0 + 1] + b1 * m->uv[2 * i1 + 1] + b2 * m->uv[2 * i2 + 1];
    } else {
        h.uv.x = h.uv.y = 0.0f;
    }
    h.mat = m->mat ? m->mat[t] : 0;
    *hit = h;
    return 1;
}

int mf_rtscene_occluded(const MfRtScene *s, MfVec3 org, MfVec3 dir, float tnear, float tfar) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    r.org_x = org.x; r.org_y = org.y; r.org_z = org.z;
    r.dir_x = dir.x; r.dir_y = dir.y; r.dir_z = dir.z;
    r.tnear = tnear; r.tfar = tfar;
    r.time = 0.0f; r.mask = 0xFFFFFFFFu; r.id = 0; r.flags = 0;
    rtcOccluded1(s->scene, &ctx, &r);
    return r.tfar < 0.0f;
}

void mf_rtscene_occluded_n(const MfRtScene *s, int n, const MfVec3 *org, const MfVec3 *dir, float tfar,
                           unsigned char *occ) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    _Alignas(64) struct RTCRay16 r;
    _Alignas(64) int valid[16];
    for (int b = 0; b < n; b += 16) {
        int m = n - b < 16 ? n - b : 16;
        if (m == 1) { /* a lone ray: the single-ray kernel */
            occ[b] = (unsigned char)mf_rtscene_occluded(s, org[b], dir[b], 0.0f, tfar);
            break;
        }
        for (int k = 0; k < 16; ++k) {
            valid[k] = k < m ? -1 : 0;
            int i = b + (k < m ? k : 0);
            r.org_x[k] = org[i].x; r.org_y[k] = org[i].y; r.org_z[k] = org[i].z;
            r.dir_x[k] = dir[i].x; r.dir_y[k] = dir[i].y; r.dir_z[k] = dir[i].z;
            r.tnear[k] = 0.0f; r.tfar[k] = tfar;
            r.time[k] = 0.0f; r.mask[k] = 0xFFFFFFFFu; r.id[k] = 0; r.flags[k] = 0;
        }
        rtcOccluded16(valid, s->scene, &ctx, &r);
        for (int k = 0; k < m; ++k) occ[b + k] = r.tfar[k] < 0.0f;
    }
}
