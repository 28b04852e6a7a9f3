/* ev_render_bench: renderer throughput against a bare Embree replay (ev_render_bench.h). */
#include "eval/ev_render_bench.h"

#include <embree3/rtcore.h>
#include <stdlib.h>
#include <time.h>

#include "core/mf_error.h"
#include "core/mf_log.h"
#include "render/mf_rtscene.h"

/* Replays recorded rays; returns the number of occluded shadow rays + primary hits (a checksum). */
static long replay(RTCScene scene, const MfRayLog *log) {
    long acc = 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = 0; i < log->n; ++i) {
        const MfRayRec *r = &log->rays[i];
        if (r->kind == 0) {
            struct RTCRayHit rh;
            rh.ray.org_x = r->org[0]; rh.ray.org_y = r->org[1]; rh.ray.org_z = r->org[2];
            rh.ray.dir_x = r->dir[0]; rh.ray.dir_y = r->dir[1]; rh.ray.dir_z = r->dir[2];
            rh.ray.tnear = r->tnear; rh.ray.tfar = r->tfar;
            rh.ray.time = 0; rh.ray.mask = 0xFFFFFFFFu; rh.ray.id = 0; rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            acc += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        } else {
            struct RTCRay ray;
            ray.org_x = r->org[0]; ray.org_y = r->org[1]; ray.org_z = r->org[2];
            ray.dir_x = r->dir[0]; ray.dir_y = r->dir[1]; ray.dir_z = r->dir[2];
            ray.tnear = r->tnear; ray.tfar = r->tfar;
            ray.time = 0; ray.mask = 0xFFFFFFFFu; ray.id = 0; ray.flags = 0;
            rtcOccluded1(scene, &ctx, &ray);
            acc += ray.tfar < 0.0f;
        }
    }
    return acc;
}

/* CPU seconds of all threads of this process (robust to other processes' load). */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

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
    RTCScene scene = (RTCScene)mf_rtscene_handle(in->rt);
    MfProgress prog;
    mf_progress_begin(&prog, "render + bare replay", (size_t)H);
    for (int y0 = 0; y0 < H && !rc; y0 += CHUNK) {
        int y1 = y0 + CHUNK < H ? y0 + CHUNK : H;
        double t0 = mf_now(), c0 = cpu_now();
        rc = mf_render_rows(in, cam, o, y0, y1, out, NULL, NULL);
        r->t_render += mf_now() - t0;
        r->c_render += cpu_now() - c0;
        for (int k = 0; k < CHUNK; ++k) logs[k].n = 0;
        if (!rc) rc = mf_render_rows(in, cam, o, y0, y1, out, logs, NULL);
        if (rc) break;
        for (int k = 0; k < y1 - y0; ++k)
            for (size_t i = 0; i < logs[k].n; ++i) {
                if (logs[k].rays[i].kind == 0) ++r->n_primary;
                else ++r->n_shadow;
            }
        double t1 = mf_now(), c1 = cpu_now();
        long acc = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : acc)
        for (int k = 0; k < y1 - y0; ++k) acc += replay(scene, &logs[k]);
        r->t_bare += mf_now() - t1;
        r->c_bare += cpu_now() - c1;
        r->checksum += acc;
        mf_progress_add(&prog, (size_t)(y1 - y0));
    }
    mf_progress_end(&prog);
    for (int k = 0; k < CHUNK; ++k) mf_raylog_free(&logs[k]);
    free(logs);
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
