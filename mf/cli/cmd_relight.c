/* mf relight: renders a reconstruction (a result folder) under a novel environment map from the
 * cameras of a transforms.json, with the project's renderer. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "io/mf_opts.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "eval/ev_eval.h"
#include "scene/mf_transforms.h"
#include "render/mf_integrator.h"
#include "render/mf_rtscene.h"

typedef struct {
    const char *env, *cameras, *out;
    int spp, pixel_samples, width, seed, png;
} RelightArgs;

#define A RelightArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, env, NULL, "environment map (linear lat-long, Blender mapping; required)", .meta = "MAP.exr"),
    MF_OPT_STR(A, cameras, NULL, "NeRF-synthetic transforms.json (required)", .meta = "FILE"),
    MF_OPT_STR(A, out, NULL, "output folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_INT(A, spp, 8, 1, MF_OPT_SPP_MAX, "n: n^2 env-light + n^2 BSDF samples per pixel sample"),
    MF_OPT_INT(A, pixel_samples, 4, 1, MF_OPT_PIXEL_SAMPLES_MAX, "primary rays per pixel"),
    MF_OPT_INT(A, width, 512, 1, MF_OPT_RES_MAX, "image width and height"),
    MF_OPT_INT(A, seed, 1, 0, 2147483647, "random seed"),
    MF_OPT_BOOL(A, png, 0, "also write an sRGB PNG per frame"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf relight RESULT_DIR --env MAP.exr --cameras transforms.json -o OUT_DIR\n"
    "                  [--spp N] [--pixel-samples P] [--width W] [--seed S] [--png]\n"
    "Renders RESULT_DIR (mesh.obj, albedo.png, orm.png, and normal.png when present; or a .glb/.gltf\n"
    "file such as RESULT_DIR/scene.glb: its mesh and one PBR material) under MAP\n"
    "(linear lat-long, Blender mapping) for every frame of the NeRF-synthetic transforms.json:\n"
    "OUT_DIR/<frame>.exr (multi-layer, as mf render) and with --png an sRGB PNG.\n";

__attribute__((constructor)) static void relight_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 1, NULL);
}

static int relight_run(const char *result, const RelightArgs *a);

static int cmd_relight(int argc, char **argv) {
    RelightArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_opts_parse(&bind, 1, argc, argv, 1, &p) ? MF_EXIT_USAGE : MF_EXIT_OK;
    if (!rc && p.print_config) rc = mf_cli_print_config(&bind, 1);
    else if (!rc && (!p.npos || !a.env || !a.cameras || !a.out)) {
        mf_fail(MF_EARG, "need RESULT_DIR, --env, --cameras and -o (see mf relight --help)");
        rc = MF_EXIT_USAGE;
    } else if (!rc) rc = relight_run(p.pos[0], &a);
    mf_opts_parse_free(&p);
    return rc;
}

static int relight_run(const char *result, const RelightArgs *a) {
    const char *envp = a->env, *cams = a->cameras, *out = a->out;
    int spp = a->spp, ps = a->pixel_samples, width = a->width, seed = a->seed, png = a->png;
    MfTransforms tf;
    int rc = mf_transforms_load(cams, 0, &tf), nf = tf.n;
    EvResult res;
    int have_res = 0;
    MfEnvMap env;
    int have_env = 0;
    MfRtScene *rt = NULL;
    if (!rc && !(rc = ev_result_load(result, NULL, &res))) have_res = 1;
    if (!rc && !(rc = mf_env_load(&env, envp))) have_env = 1;
    if (!rc) rc = mf_rtscene_new(&res.mesh, &rt);
    MfTexMaterial mat = {.kd = have_res ? &res.kd : NULL, .orm = have_res ? &res.orm : NULL, .kd_const = mf_v3s(0.5f), .orm_const = mf_v3(1, 0.5f, 0), .normal = have_res && res.has_normal ? &res.normal : NULL};
    MfRenderInput in = {rt, have_res ? &res.mesh : NULL, &mat, 1, have_env ? &env : NULL, NULL, 0};
    MfRenderOpts ro = {.spp_sqrt = spp, .pixel_samples = ps, .seed = (uint64_t)seed, .lobes = MF_LOBE_ALL};
    /* every frame's camera and output name first: a bad frame or two frames with the same
     * output name are refused before anything is written */
    typedef struct { char name[256]; MfCamera cam; } Frame;
    Frame *fs = rc ? NULL : calloc(nf > 0 ? (size_t)nf : 1, sizeof *fs);
    if (!rc && !fs) rc = mf_fail(MF_ENOMEM, "%s: out of memory", cams);
    for (int k = 0; k < nf && !rc; ++k) {
        if (tf.frames[k].name[0]) snprintf(fs[k].name, sizeof fs[k].name, "%s", tf.frames[k].name);
        else snprintf(fs[k].name, sizeof fs[k].name, "r_%03d", k);
        char what[MF_PATH_MAX + 64];
        snprintf(what, sizeof what, "%s: frames[%d]", cams, k);
        rc = mf_camera_init(&fs[k].cam, width, width, tf.camera_angle_x, tf.frames[k].c2w, what);
    }
    int di, dj;
    if (!rc && mf_find_duplicate_name(fs[0].name, sizeof fs[0], nf, &di, &dj))
        rc = mf_fail(MF_EFORMAT, "%s: frames[%d] and frames[%d] both name the output '%s' (their files would overwrite each other: give them distinct file_path base names)",
                     cams, di, dj, fs[di].name);
    if (!rc) rc = mf_mkdirs(out);
    if (!rc) rc = mf_remove_stale_tmp(out, 0, NULL); /* left by an interrupted run */
    for (int k = 0; k < nf && !rc; ++k) {
        char what[MF_PATH_MAX + 64], path[MF_PATH_MAX];
        MfRenderOut o;
        if ((rc = mf_render(&in, &fs[k].cam, &ro, &o, NULL))) break;
        snprintf(what, sizeof what, "%s.exr", fs[k].name);
        if (!(rc = mf_path_join(path, sizeof path, out, what))) rc = mf_render_out_write_exr(path, &o);
        if (!rc && png) {
            snprintf(what, sizeof what, "%s.png", fs[k].name);
            if (!(rc = mf_path_join(path, sizeof path, out, what))) rc = mf_render_out_write_png(path, &o);
        }
        mf_render_out_free(&o);
    }
    free(fs);
    if (!rc) mf_log_info("relight: %d views -> %s", nf, out);
    mf_rtscene_free(rt);
    if (have_env) mf_env_free(&env);
    if (have_res) ev_result_free(&res);
    mf_transforms_free(&tf);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(relight, "relight", "render a reconstruction under a novel environment map", usage, cmd_relight)
