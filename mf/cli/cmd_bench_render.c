/* mf bench-render: renderer throughput against a bare Embree loop replaying the renderer's own
 * rays (DESIGN.md, performance method). Writes a markdown report atomically. */
#include <embree3/rtcore.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/utsname.h>
#include <time.h>

#include "cli/mf_cli.h"
#include "io/mf_opts.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "io/mf_image.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"

typedef struct {
    const char *out, *env, *save;
    int width, height, spp, threads, pixel_samples, env_width;
} BenchRenderArgs;

#define A BenchRenderArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, "reports/perf/render.md", "report (markdown, written atomically)", .alias = "-o", .meta = "FILE"),
    MF_OPT_INT(A, width, 512, 1, MF_OPT_RES_MAX, "image width"),
    MF_OPT_INT(A, height, 512, 1, MF_OPT_RES_MAX, "image height"),
    MF_OPT_INT(A, spp, 8, 1, MF_OPT_SPP_MAX, "n: n^2 env-light + n^2 BSDF samples per pixel sample"),
    MF_OPT_INT(A, pixel_samples, 1, 1, MF_OPT_PIXEL_SAMPLES_MAX, "primary rays per pixel"),
    MF_OPT_INT(A, threads, 2, 1, 4096, "OpenMP threads"),
    MF_OPT_STR(A, env, "/usr/share/blender/datafiles/studiolights/world/sunset.exr", "HDR probe (a constant sky when the file is missing)",
               .meta = "FILE.exr"),
    MF_OPT_INT(A, env_width, 0, 2, 65536, "box-filter the probe down to at most EW columns (e.g. 512, the inverse pipeline's)",
               .unset = "full size", .meta = "EW"),
    MF_OPT_STR(A, save, NULL, "write the rendered AOVs (multi-channel EXR) to compare renderer versions", .meta = "IMG.exr"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf bench-render [-o reports/perf/render.md] [--width W] [--height H] [--spp N] [--threads T]\n"
    "                       [--pixel-samples P] [--env FILE.exr] [--env-width EW] [--save IMG.exr]\n"
    "Renders a procedural torus (131072 triangles) under an HDR probe with N^2 light + N^2 BSDF\n"
    "samples per pixel, then replays exactly the renderer's rays (recorded per row) through a bare\n"
    "rtcIntersect1/rtcOccluded1 loop, and reports path samples/s, rays/s and bare time / render time.\n";

__attribute__((constructor)) static void bench_render_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 1, NULL);
}

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

/* CPU seconds of all threads of this process (robust to other processes' load). */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int bench_render_run(const BenchRenderArgs *a);

static int cmd_bench_render(int argc, char **argv) {
    BenchRenderArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_opts_parse(&bind, 1, argc, argv, 0, &p) ? MF_EXIT_USAGE : p.print_config ? mf_cli_print_config(&bind, 1)
                                                                                          : bench_render_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

static int bench_render_run(const BenchRenderArgs *a) {
    const char *outp = a->out, *savep = a->save, *envp = a->env;
    int W = a->width, H = a->height, spp = a->spp, threads = a->threads, ps = a->pixel_samples, env_w = a->env_width;
    omp_set_num_threads(threads);
    MfMesh mesh;
    if (mf_shape_torus(&mesh, 0.35f, 0.15f, 512, 128)) return MF_EXIT_FAIL;
    MfRtScene *rt = NULL;
    MfEnvMap env;
    int has_env = 0, rc;
    char env_desc[1200];
    snprintf(env_desc, sizeof env_desc, "%s", envp);
    if ((rc = mf_rtscene_new(&mesh, &rt))) goto done;
    if (mf_file_exists(envp)) {
        MfImage img;
        if ((rc = mf_image_read(envp, MF_ENC_LINEAR, &img))) goto done;
        int w0 = img.w, h0 = img.h;
        if (img.c != 3) {
            MfImage o;
            if ((rc = mf_image_alloc(&o, img.w, img.h, 3))) { mf_image_free(&img); goto done; }
            for (size_t i = 0; i < (size_t)img.w * img.h; ++i)
                for (int c = 0; c < 3; ++c) o.data[3 * i + c] = img.data[i * img.c + (c < img.c ? c : 0)];
            mf_image_free(&img);
            img = o;
        }
        if (env_w > 0 && (rc = downsample_env(&img, env_w))) { mf_image_free(&img); goto done; }
        snprintf(env_desc, sizeof env_desc, "%s (%dx%d, used at %dx%d)", envp, w0, h0, img.w, img.h);
        if ((rc = mf_env_init(&env, &img))) goto done;
    } else {
        snprintf(env_desc, sizeof env_desc, "constant radiance 1 (probe not found)");
        if ((rc = mf_env_init_constant(&env, 64, 32, mf_v3s(1.0f)))) goto done;
    }
    has_env = 1;
    MfTexMaterial mat = {NULL, NULL, {0.6f, 0.5f, 0.4f}, {0.0f, 0.4f, 0.3f}, NULL};
    MfRenderInput in = {rt, &mesh, &mat, 1, &env, NULL, 0};
    MfRenderOpts o = {spp, ps, 1, MF_LOBE_ALL};
    MfMat4 m = mf_mat4_look_at(mf_v3(0.0f, -1.15f, 0.75f), mf_v3(0, 0, 0), mf_v3(0, 0, 1));
    double c2w[16];
    for (int i = 0; i < 16; ++i) c2w[i] = m.m[i];
    MfCamera cam;
    if ((rc = mf_camera_init(&cam, W, H, 0.6911, c2w, "bench camera"))) goto done;

    /* Interleaved by chunks of rows, so that both timings see the same machine load (this
     * machine is shared): (1) the renderer renders the chunk (timed); (2) it renders the chunk
     * again recording its rays (untimed; same seeds, so identical rays); (3) a bare loop replays
     * them with rtcIntersect1 / rtcOccluded1 only (timed). */
    MfRenderOut out;
    if ((rc = mf_render_out_alloc(&out, W, H))) goto done;
    const int chunk = 32;
    MfRayLog *logs = calloc((size_t)chunk, sizeof *logs);
    if (!logs) { rc = mf_fail(MF_ENOMEM, "out of memory"); mf_render_out_free(&out); goto done; }
    double t_render = 0, t_bare = 0, c_render = 0, c_bare = 0;
    long n_primary = 0, n_shadow = 0, checksum = 0;
    RTCScene scene = (RTCScene)mf_rtscene_handle(rt);
    MfProgress prog;
    mf_progress_begin(&prog, "render + bare replay", (size_t)H);
    for (int y0 = 0; y0 < H && !rc; y0 += chunk) {
        int y1 = y0 + chunk < H ? y0 + chunk : H;
        double t0 = mf_now(), c0 = cpu_now();
        rc = mf_render_rows(&in, &cam, &o, y0, y1, &out, NULL, NULL);
        t_render += mf_now() - t0;
        c_render += cpu_now() - c0;
        for (int k = 0; k < chunk; ++k) logs[k].n = 0;
        if (!rc) rc = mf_render_rows(&in, &cam, &o, y0, y1, &out, logs, NULL);
        if (rc) break;
        for (int k = 0; k < y1 - y0; ++k)
            for (size_t i = 0; i < logs[k].n; ++i) {
                if (logs[k].rays[i].kind == 0) ++n_primary;
                else ++n_shadow;
            }
        double t1 = mf_now(), c1 = cpu_now();
        long acc = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : acc)
        for (int k = 0; k < y1 - y0; ++k) acc += replay(scene, &logs[k]);
        t_bare += mf_now() - t1;
        c_bare += cpu_now() - c1;
        checksum += acc;
        mf_progress_add(&prog, (size_t)(y1 - y0));
    }
    mf_progress_end(&prog);
    for (int k = 0; k < chunk; ++k) mf_raylog_free(&logs[k]);
    free(logs);
    double cover = 0;
    for (size_t i = 0; i < (size_t)W * H; ++i) cover += out.alpha[i];
    cover /= (double)W * H;
    if (!rc && savep) rc = mf_render_out_write_exr(savep, &out);
    mf_render_out_free(&out);
    if (rc) goto done;

    double path_samples = (double)W * H * ps * 2.0 * spp * spp;
    double rays = (double)(n_primary + n_shadow);
    struct utsname un;
    uname(&un);
    char md[4096];
    int len = snprintf(md, sizeof md,
        "# Renderer throughput vs a bare Embree loop\n\n"
        "Generated by `mf bench-render` (`make bench-render`); do not edit by hand.\n\n"
        "| setting | value |\n|---|---|\n"
        "| mesh | procedural torus, %d triangles |\n"
        "| image | %d x %d, %d primary ray(s) per pixel, coverage %.3f |\n"
        "| samples | %d x %d env-light + %d x %d BSDF per pixel sample (MIS, balance heuristic) |\n"
        "| environment | %s |\n"
        "| material | constant kd (0.6, 0.5, 0.4), roughness 0.4, metallic 0.3 |\n"
        "| threads | %d (OpenMP, rows) |\n"
        "| machine | %s %s |\n\n"
        "| measure | value |\n|---|---|\n"
        "| renderer wall time (sum over row chunks) | %.3f s |\n"
        "| path samples (pixels x pixel samples x 2 n^2) | %.0f |\n"
        "| **path samples / s** | **%.3g** |\n"
        "| rays traced (primary + shadow) | %ld + %ld |\n"
        "| renderer rays / s | %.3g |\n"
        "| bare Embree replay of the same rays (rtcIntersect1 / rtcOccluded1 only) | %.3f s (%.3g rays/s) |\n"
        "| **bare time / renderer time** (wall) | **%.3f** (target >= 0.4) |\n"
        "| CPU seconds: renderer / bare replay / ratio | %.3f / %.3f / %.3f |\n\n"
        "Both timings are taken interleaved per chunk of 32 rows (render chunk, record its rays untimed,\n"
        "replay them bare), so a shared machine's load affects both alike.\n"
        "Shadow rays are traced only for samples with a non-zero BRDF value and a direction above the\n"
        "geometric surface, so rays < path samples + primary rays. Replay checksum (hits + occluded): %ld.\n",
        mesh.nt, W, H, ps, cover, spp, spp, spp, spp, env_desc, threads, un.sysname, un.machine, t_render, path_samples,
        path_samples / t_render, n_primary, n_shadow, rays / t_render, t_bare, rays / t_bare, t_bare / t_render, c_render, c_bare, c_bare / c_render, checksum);
    if (len < 0 || (size_t)len >= sizeof md) { rc = mf_fail(MF_EARG, "report too long"); goto done; }
    if ((rc = mf_mkdirs_for(outp)) || (rc = mf_write_file(outp, md, (size_t)len))) goto done;
    fputs(md, stdout);
done:
    if (has_env) mf_env_free(&env);
    mf_rtscene_free(rt);
    mf_mesh_free(&mesh);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(bench_render, "bench-render", "renderer throughput vs a bare Embree loop -> markdown", usage, cmd_bench_render)
