/* mf render: renders every camera of a scene JSON (mf/scene/mf_scene.h) to multi-layer EXR
 * (channels R G B A, albedo.*, orm.*, normal.*, depth.Z, diffuse.*, specular.*; see
 * mf/io/mf_exr.h) and optionally sRGB RGBA PNG. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "io/mf_opts.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_scene.h"

typedef struct {
    const char *out, *lobes;
    int spp, pixel_samples, width, height, seed, png, bounces;
} RenderArgs;

static int render_scene(const char *scene_path, const char *outdir, const RenderArgs *a, int lobes);

#define A RenderArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_INT(A, spp, 0, 1, MF_OPT_SPP_MAX, "n: n^2 env-light + n^2 BSDF samples per pixel sample",
               .unset = "the scene's render.spp_sqrt, else 8"),
    MF_OPT_INT(A, pixel_samples, 0, 1, MF_OPT_PIXEL_SAMPLES_MAX, "primary rays per pixel", .unset = "the scene's, else 4"),
    MF_OPT_INT(A, bounces, 0, 0, 64, "indirect bounces after the direct light (0: direct light only, as nvdiffrecmc)"),
    MF_OPT_INT(A, width, 0, 1, MF_OPT_RES_MAX, "image width", .unset = "the scene's"),
    MF_OPT_INT(A, height, 0, 1, MF_OPT_RES_MAX, "image height", .unset = "the scene's"),
    MF_OPT_INT(A, seed, -1, 0, 2147483647, "random seed", .unset = "the scene's render.seed"),
    MF_OPT_STR(A, lobes, NULL, "BSDF lobes rendered", .choices = "all|diffuse|specular", .unset = "the scene's, else all"),
    MF_OPT_BOOL(A, png, 0, "also write DIR/<name>.png (sRGB, straight alpha)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (override the scene's settings; --config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf render SCENE.json -o DIR [--spp N] [--pixel-samples P] [--width W --height H]\n"
    "                 [--seed S] [--lobes all|diffuse|specular] [--png] [--config FILE]\n"
    "Renders each camera of SCENE.json to DIR/<name>.exr (multi-layer: R G B A = radiance\n"
    "premultiplied by coverage, albedo, orm, normal, depth, diffuse, specular) and with --png also\n"
    "DIR/<name>.png (sRGB, straight alpha). Exit code 1 on bad input, 2 on a bad option.\n";

__attribute__((constructor)) static void render_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 1, NULL);
}

static int cmd_render(int argc, char **argv) {
    RenderArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    if (mf_opts_parse(&bind, 1, argc, argv, 1, &p)) {
        mf_opts_parse_free(&p);
        return MF_EXIT_USAGE;
    }
    if (p.print_config) {
        mf_opts_parse_free(&p);
        return mf_cli_print_config(&bind, 1);
    }
    const char *scene_path = p.npos ? p.pos[0] : NULL, *outdir = a.out;
    if (!scene_path || !outdir) {
        mf_opts_parse_free(&p);
        mf_fail(MF_EARG, "need SCENE.json and -o DIR (see mf render --help)");
        return MF_EXIT_USAGE;
    }
    int lobes = a.lobes ? mf_lobes_parse(a.lobes) : -1; /* the table checked the name */
    int rc = render_scene(scene_path, outdir, &a, lobes);
    mf_opts_parse_free(&p);
    return rc;
}

static int render_scene(const char *scene_path, const char *outdir, const RenderArgs *a, int lobes) {
    int spp = a->spp, ps = a->pixel_samples, w = a->width, h = a->height, seed = a->seed, png = a->png;
    MfScene sc;
    if (mf_scene_load(scene_path, &sc)) return MF_EXIT_FAIL;
    MfRtScene *rt = NULL;
    MfTexMaterial *mats = NULL;
    int rc = mf_rtscene_new(&sc.mesh, &rt);
    if (rc) mf_fail_prefix(rc, "%s: mesh", scene_path);
    if (!rc && !(mats = calloc((size_t)sc.nmat, sizeof *mats))) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (!rc) rc = mf_mkdirs(outdir);
    if (!rc) rc = mf_remove_stale_tmp(outdir, 0, NULL); /* left by an interrupted run */
    if (rc) {
        mf_rtscene_free(rt);
        mf_scene_free(&sc);
        return MF_EXIT_FAIL;
    }
    for (int i = 0; i < sc.nmat; ++i) {
        mats[i].kd = sc.mats[i].kd;
        mats[i].orm = sc.mats[i].orm;
        mats[i].kd_const = sc.mats[i].kd_const;
        mats[i].orm_const = sc.mats[i].orm_const;
        mats[i].normal = sc.mats[i].normal;
    }
    MfRenderInput in = {rt, &sc.mesh, mats, sc.nmat, sc.has_env ? &sc.env : NULL, sc.lights, sc.nlights};
    MfRenderOpts o = {.spp_sqrt = sc.render.spp_sqrt, .pixel_samples = sc.render.pixel_samples, .seed = sc.render.seed, .lobes = sc.render.lobes};
    if (spp) o.spp_sqrt = spp;
    if (ps) o.pixel_samples = ps;
    if (seed >= 0) o.seed = (uint64_t)seed;
    if (lobes > 0) o.lobes = lobes;
    o.bounces = a->bounces;
    int W = w ? w : sc.width, H = h ? h : sc.height;
    MfProgress prog;
    mf_progress_begin(&prog, "render", (size_t)H * sc.nviews);
    mf_log_info("render: %s: %d views at %dx%d, %d^2 + %d^2 samples x %d pixel samples, %d triangles", scene_path,
                sc.nviews, W, H, o.spp_sqrt, o.spp_sqrt, o.pixel_samples, sc.mesh.nt);
    double t0 = mf_now();
    for (int k = 0; k < sc.nviews && !rc; ++k) {
        MfCamera cam;
        rc = mf_scene_camera(&sc, k, W, H, &cam);
        if (rc) break;
        MfRenderOpts ok = o;
        ok.seed = mf_hash64(o.seed, (uint64_t)k);
        MfRenderOut out;
        if ((rc = mf_render(&in, &cam, &ok, &out, &prog))) break;
        char path[MF_PATH_MAX], name[160];
        snprintf(name, sizeof name, "%s.exr", sc.views[k].name);
        rc = mf_path_join(path, sizeof path, outdir, name);
        if (!rc) rc = mf_render_out_write_exr(path, &out);
        if (!rc && png) {
            snprintf(name, sizeof name, "%s.png", sc.views[k].name);
            rc = mf_path_join(path, sizeof path, outdir, name);
            if (!rc) rc = mf_render_out_write_png(path, &out);
        }
        mf_render_out_free(&out);
    }
    mf_progress_end(&prog);
    if (!rc) mf_log_info("render: %d views in %.2f s -> %s", sc.nviews, mf_now() - t0, outdir);
    free(mats);
    mf_rtscene_free(rt);
    mf_scene_free(&sc);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(render, "render", "render a scene JSON's cameras to multi-layer EXR (and PNG)", usage, cmd_render)
