/* mf render: renders every camera of a scene JSON (mf/scene/mf_scene.h) to multi-layer EXR
 * (channels R G B A, albedo.*, orm.*, normal.*, depth.Z, diffuse.*, specular.*; see
 * mf/io/mf_exr.h) and optionally sRGB RGBA PNG. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_scene.h"

static const char usage[] =
    "usage: mf render SCENE.json -o DIR [--spp N] [--pixel-samples P] [--width W --height H]\n"
    "                 [--seed S] [--lobes all|diffuse|specular] [--png]\n"
    "Renders each camera of SCENE.json to DIR/<name>.exr (multi-layer: R G B A = radiance\n"
    "premultiplied by coverage, albedo, orm, normal, depth, diffuse, specular) and with --png also\n"
    "DIR/<name>.png (sRGB, straight alpha). --spp N: N^2 env-light + N^2 BSDF samples per pixel\n"
    "sample (default from the scene's render.spp_sqrt, else 8); --pixel-samples: primary rays per\n"
    "pixel (default 4). Options override the scene's settings. Exit code 1 on bad input.\n";

static int cmd_render(int argc, char **argv) {
    const char *scene_path = NULL, *outdir = NULL, *lobes_s = NULL;
    int spp = 0, ps = 0, w = 0, h = 0, seed = -1, png = 0;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "-o", &outdir)) || (r = mf_opt_int(argc, argv, &i, "--spp", &spp)) ||
            (r = mf_opt_int(argc, argv, &i, "--pixel-samples", &ps)) || (r = mf_opt_int(argc, argv, &i, "--width", &w)) ||
            (r = mf_opt_int(argc, argv, &i, "--height", &h)) || (r = mf_opt_int(argc, argv, &i, "--seed", &seed)) ||
            (r = mf_opt_str(argc, argv, &i, "--lobes", &lobes_s))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--png")) { png = 1; continue; }
        if (argv[i][0] == '-') { mf_fail(MF_EARG, "unknown option %s", argv[i]); return MF_EXIT_USAGE; }
        if (scene_path) { mf_fail(MF_EARG, "more than one scene file given (%s, %s)", scene_path, argv[i]); return MF_EXIT_USAGE; }
        scene_path = argv[i];
    }
    if (!scene_path || !outdir) { mf_fail(MF_EARG, "need SCENE.json and -o DIR\n%s", usage); return MF_EXIT_USAGE; }
    if (spp < 0 || spp > 1024 || ps < 0 || ps > 1024 || w < 0 || h < 0 || w > 65536 || h > 65536) {
        mf_fail(MF_EARG, "--spp/--pixel-samples must be in [1, 1024] and --width/--height positive");
        return MF_EXIT_USAGE;
    }
    int lobes = -1;
    if (lobes_s && (lobes = mf_lobes_parse(lobes_s)) < 0) {
        mf_fail(MF_EARG, "--lobes: '%s' is not all, diffuse or specular", lobes_s);
        return MF_EXIT_USAGE;
    }

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
    }
    MfRenderInput in = {rt, &sc.mesh, mats, sc.nmat, sc.has_env ? &sc.env : NULL, sc.lights, sc.nlights};
    MfRenderOpts o = {sc.render.spp_sqrt, sc.render.pixel_samples, sc.render.seed, sc.render.lobes};
    if (spp) o.spp_sqrt = spp;
    if (ps) o.pixel_samples = ps;
    if (seed >= 0) o.seed = (uint64_t)seed;
    if (lobes > 0) o.lobes = lobes;
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
