/* ev_render_bench: renderer throughput against a bare Embree replay (ev_render_bench.h). */
#include "eval/ev_render_bench.h"

#include <embree3/rtcore.h>
#include <stdlib.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "render/mf_rtscene.h"

static void ray_of(const MfRayRec *r, struct RTCRay *ray) {
    ray->org_x = r->org[0]; ray->org_y = r->org[1]; ray->org_z = r->org[2];
    ray->dir_x = r->dir[0]; ray->dir_y = r->dir[1]; ray->dir_z = r->dir[2];
    ray->tnear = r->tnear; ray->tfar = r->tfar;
    ray->time = 0; ray->mask = 0xFFFFFFFFu; ray->id = 0; ray->flags = 0;
}

/* Replays recorded rays one at a time (rtcIntersect1 / rtcOccluded1); returns the number of
 * occluded shadow rays + primary hits (a checksum). */
static long replay_single(RTCScene scene, const MfRayLog *log) {
    long acc = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = 0; i < log->n; ++i) {
        const MfRayRec *r = &log->rays[i];
        if (r->kind == 0) {
            struct RTCRayHit rh;
            ray_of(r, &rh.ray);
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            acc += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        } else {
            struct RTCRay ray;
            ray_of(r, &ray);
            rtcOccluded1(scene, &ctx, &ray);
            acc += ray.tfar < 0.0f;
        }
    }
    return acc;
}

/* Lane k of a 16-wide packet from r. */
static void lane_of(const MfRayRec *r, struct RTCRay16 *p, int k) {
    p->org_x[k] = r->org[0]; p->org_y[k] = r->org[1]; p->org_z[k] = r->org[2];
    p->dir_x[k] = r->dir[0]; p->dir_y[k] = r->dir[1]; p->dir_z[k] = r->dir[2];
    p->tnear[k] = r->tnear; p->tfar[k] = r->tfar;
    p->time[k] = 0; p->mask[k] = 0xFFFFFFFFu; p->id[k] = 0; p->flags[k] = 0;
}

/* The same rays in 16-wide packets, in log order: primary rays (a row's consecutive pixels, so
 * coherent) with rtcIntersect16 and a coherent context, shadow rays (consecutive ones share a
 * hit point's origin) with rtcOccluded16. */
static long replay_packets(RTCScene scene, const MfRayLog *log) {
    long acc = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    _Alignas(64) struct RTCRayHit16 ph;
    _Alignas(64) struct RTCRay16 sp;
    _Alignas(64) int pv[16], sv[16];
    int np = 0, ns = 0;
    for (size_t i = 0; i <= log->n; ++i) {
        int end = i == log->n;
        if (np && (np == 16 || end)) {
            for (int k = 0; k < 16; ++k) pv[k] = k < np ? -1 : 0, ph.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            rtcIntersect16(pv, scene, &ctx, &ph);
            for (int k = 0; k < np; ++k) acc += ph.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
            np = 0;
        }
        if (ns && (ns == 16 || end)) {
            for (int k = 0; k < 16; ++k) sv[k] = k < ns ? -1 : 0;
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
            rtcOccluded16(sv, scene, &ctx, &sp);
            for (int k = 0; k < ns; ++k) acc += sp.tfar[k] < 0.0f;
            ns = 0;
        }
        if (end) break;
        const MfRayRec *r = &log->rays[i];
        if (r->kind == 0) {
            lane_of(r, &ph.ray, np);
            ph.hit.instID[0][np++] = RTC_INVALID_GEOMETRY_ID;
        } else {
            lane_of(r, &sp, ns++);
        }
    }
    return acc;
}

/* The same rays as ray streams (rtcIntersect1M coherent, rtcOccluded1M incoherent), in batches
 * of up to STREAM rays of one kind in log order. */
static long replay_streams(RTCScene scene, const MfRayLog *log) {
    enum { STREAM = 256 };
    long acc = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit ph[STREAM];
    struct RTCRay sr[STREAM];
    unsigned np = 0, ns = 0;
    for (size_t i = 0; i <= log->n; ++i) {
        int end = i == log->n;
        if (np && (np == STREAM || end)) {
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            rtcIntersect1M(scene, &ctx, ph, np, sizeof *ph);
            for (unsigned k = 0; k < np; ++k) acc += ph[k].hit.geomID != RTC_INVALID_GEOMETRY_ID;
            np = 0;
        }
        if (ns && (ns == STREAM || end)) {
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
            rtcOccluded1M(scene, &ctx, sr, ns, sizeof *sr);
            for (unsigned k = 0; k < ns; ++k) acc += sr[k].tfar < 0.0f;
            ns = 0;
        }
        if (end) break;
        const MfRayRec *r = &log->rays[i];
        if (r->kind == 0) {
            ray_of(r, &ph[np].ray);
            ph[np].hit.geomID = RTC_INVALID_GEOMETRY_ID;
            ph[np++].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        } else {
            ray_of(r, &sr[ns++]);
        }
    }
    return acc;
}

typedef long (*ReplayFn)(RTCScene scene, const MfRayLog *log);
static const ReplayFn k_replay[EV_NREPLAY] = {replay_single, replay_packets, replay_streams};
const char *const ev_replay_names[EV_NREPLAY] = {"rtcIntersect1 / rtcOccluded1", "rtcIntersect16 / rtcOccluded16 packets",
                                                 "rtcIntersect1M / rtcOccluded1M streams"};

int ev_render_bench(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *o, MfRenderOut *out, EvRenderBench *r) {
    int W = cam->w, H = cam->h, rc = mf_render_out_alloc(out, W, H);
    if (rc) return rc;
    enum { CHUNK = 32 };
    MfRayLog *logs = calloc(CHUNK, sizeof *logs);
    if (!logs) {
        mf_render_out_free(out);
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    *r = (EvRenderBench){0};
    getloadavg(&r->load[0], 1);
    RTCScene scene = (RTCScene)mf_rtscene_handle(in->rt);
    MfProgress prog;
    mf_progress_begin(&prog, "render + bare replay", (size_t)H);
    for (int y0 = 0; y0 < H && !rc; y0 += CHUNK) {
        int y1 = y0 + CHUNK < H ? y0 + CHUNK : H;
        double t0 = mf_now(), c0 = mf_cpu_now();
        rc = mf_render_rows(in, cam, o, y0, y1, out, NULL, NULL);
        r->t_render += mf_now() - t0;
        r->c_render += mf_cpu_now() - c0;
        for (int k = 0; k < CHUNK; ++k) logs[k].n = 0;
        if (!rc) rc = mf_render_rows(in, cam, o, y0, y1, out, logs, NULL);
        if (rc) break;
        for (int k = 0; k < y1 - y0; ++k)
            for (size_t i = 0; i < logs[k].n; ++i) {
                if (logs[k].rays[i].kind == 0) ++r->n_primary;
                else ++r->n_shadow;
            }
        for (int v = 0; v < EV_NREPLAY; ++v) {
            ReplayFn fn = k_replay[v];
            double t1 = mf_now(), c1 = mf_cpu_now();
            long acc = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : acc)
            for (int k = 0; k < y1 - y0; ++k) acc += fn(scene, &logs[k]);
            r->t_api[v] += mf_now() - t1;
            r->c_api[v] += mf_cpu_now() - c1;
            r->sum_api[v] += acc;
        }
        mf_progress_add(&prog, (size_t)(y1 - y0));
    }
    mf_progress_end(&prog);
    for (int k = 0; k < CHUNK; ++k) mf_raylog_free(&logs[k]);
    free(logs);
    r->best = 0;
    for (int v = 1; v < EV_NREPLAY; ++v)
        if (r->t_api[v] < r->t_api[r->best]) r->best = v;
    r->t_bare = r->t_api[r->best], r->c_bare = r->c_api[r->best], r->checksum = r->sum_api[0];
    getloadavg(&r->load[1], 1);
    for (int v = 1; v < EV_NREPLAY && !rc; ++v)
        if (r->sum_api[v] != r->sum_api[0])
            rc = mf_fail(MF_EEXT, "bench-render: the %s replay's checksum %ld differs from %s's %ld", ev_replay_names[v],
                         r->sum_api[v], ev_replay_names[0], r->sum_api[0]);
    for (size_t i = 0; i < (size_t)W * H; ++i) r->coverage += out->alpha[i];
    r->coverage /= (double)W * H;
    if (rc) mf_render_out_free(out);
    return rc;
}

/* Box-filters img down by integer factors until its width is <= max_w (keeps 2:1 lat-long). */
static int downsample_env(MfImage *img, int max_w) {
    int f = 1;
    while (img->w / f > max_w && img->w % (2 * f) == 0 && img->h % (2 * f) == 0) f *= 2;
    if (f == 1) return MF_OK;
    MfImage o;
    int rc = mf_image_alloc(&o, img->w / f, img->h / f, 3);
    if (rc) return rc;
    for (int y = 0; y < o.h; ++y)
        for (int x = 0; x < o.w; ++x)
            for (int c = 0; c < 3; ++c) {
                double acc = 0;
                for (int dy = 0; dy < f; ++dy)
                    for (int dx = 0; dx < f; ++dx) acc += mf_image_px(img, x * f + dx, y * f + dy)[c];
                mf_image_px(&o, x, y)[c] = (float)(acc / (f * f));
            }
    mf_image_free(img);
    *img = o;
    return MF_OK;
}

int ev_env_probe_read(const char *path, int max_w, MfImage *out, int *w0, int *h0) {
    MfImage img;
    int rc = mf_image_read(path, MF_ENC_LINEAR, &img);
    if (rc) return rc;
    *w0 = img.w, *h0 = img.h;
    if (img.c != 3) {
        MfImage o;
        if ((rc = mf_image_alloc(&o, img.w, img.h, 3))) {
            mf_image_free(&img);
            return rc;
        }
        for (size_t i = 0; i < (size_t)img.w * img.h; ++i)
            for (int c = 0; c < 3; ++c) o.data[3 * i + c] = img.data[i * img.c + (c < img.c ? c : 0)];
        mf_image_free(&img);
        img = o;
    }
    if (max_w > 0 && (rc = downsample_env(&img, max_w))) {
        mf_image_free(&img);
        return rc;
    }
    *out = img;
    return MF_OK;
}
