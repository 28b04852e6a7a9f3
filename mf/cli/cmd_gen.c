/* mf gen: writes a procedural object and the camera layout of a generated scene (bvault layout) or
 * the object rendered as an instant-ngp capture (--layout ingp), or a whole data set split (layout,
 * optionally rendered in-process; prior-train / test-2d triplets always rendered). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "io/mf_opts.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_capture.h"
#include "datasets/ds_envgen.h"
#include "datasets/ds_gen.h"
#include "datasets/ds_shapes.h"
#include "datasets/ds_cycles.h"
#include "datasets/ds_split.h"

#define K_USAGE \
    "usage: mf gen -o DIR [--family NAME] [--seed N] [--tex-res N] [--train N] [--test N]\n" \
    "  Generates a procedural object and writes, in the bvault layout (README, DESIGN.md):\n" \
    "    DIR/mesh.obj (+ mesh.mtl)    normalised object (largest extent 1, centred, +Z up), UVs, parts\n" \
    "    DIR/gt/kd.png, gt/orm.png    baked base colour (sRGB) and ORM (linear, R = 1)\n" \
    "    DIR/transforms_train.json, transforms_test.json   cameras (camera_angle_x 0.6911,\n" \
    "        azimuth 0-360, elevation -15-90 deg, radius 1.5-2, looking at the origin)\n" \
    "\n" \
    "       mf gen -o DIR --layout ingp [--family NAME] [--seed N] [--tex-res N] [--views 24] [--width 64]\n" \
    "              [--intrinsics FL_X,FL_Y,CX,CY] [--distortion K1,K2,P1,P2] [--spp 4] [--pixel-samples 4]\n" \
    "  Writes the object as an instant-ngp / nerfstudio capture, rendered (datasets/ds_capture.h):\n" \
    "    DIR/transforms.json   every frame (test = frames 0, 8, 16, ...); root: camera_angle_x 0.6911 (NOT the\n" \
    "        lens: what a reader ignoring fl_x would use), fl_x fl_y cx cy w h (the lens; default fl_x 0.9x\n" \
    "        the 0.6911 lens, fl_y = 1.1 fl_x, cx = 0.55 w, cy = 0.45 h), k1 k2 p1 p2, aabb_scale; odd frames\n" \
    "        carry their own fl_x fl_y (x1.25) and cx cy (mirrored about the centre)\n" \
    "    DIR/images/r_NNN.png  RGB (no alpha), sRGB, black background; DIR/masks/r_NNN.png coverage (mask_path)\n" \
    "    DIR/mesh.obj          the mesh with UVs (mf recon's given mesh); no textures, light or relit views\n" \
    "  Images are width x 3/4 width, lit by a procedural indoor light. --distortion writes the coefficients\n" \
    "  only: the images stay undistorted (pinhole), so such a capture is one that readers must refuse.\n" \
    "\n" \
    "       mf gen --split tiny|small|full|test-3d|test-3d-diffuse|test-3d-cyc|test-3d-ambig -o DIR [--no-render] [--seed N] [--env-dir DIR]\n" \
    "  Writes a whole split: DIR/NNN_<family>/ scenes as above plus gt/env.exr (training light),\n" \
    "  relight/<env>.exr and render_{train,test,relight_<env>}.json for `mf render`, DIR/split.json\n" \
    "  and DIR/manifest.json (counts, seeds, FNV-1a 64 of every file), and renders the images\n" \
    "  in-process (--no-render: the layout only): train/ test/ r_NNN.png, gt/albedo/ gt/orm/ r_NNN.png, relight/<env>/r_NNN.exr\n" \
    "  (test-3d-diffuse: diffuse objects, lit views by POV-Ray; test-3d-cyc: test-3d lit by Blender Cycles;\n" \
    "  test-3d-ambig: material ambiguity). Rerunning resumes.\n" \
    "  --asset FILE.glb: one scene, DIR/000_<name>/, whose object is a glTF asset (normalised like ours; its\n" \
    "    base colour and occlusion/roughness/metallic textures become gt/kd.png, gt/orm.png, its normalTexture\n" \
    "    gt/normal.png, used by the renders; emission and other unrendered features are warned about and\n" \
    "    listed in split.json and gt/object.json as not_rendered).\n" \
    "  --layout nerf-synthetic: each scene then cut to NeRF-Synthetic's layout (transforms_{train,test}.json,\n" \
    "    train/, test/: no mesh, no ground truth), for the mesh-less path (mf recon --geometry vhull|dmtet);\n" \
    "    the images are the full split's bytes, so the full split made with the same arguments scores it.\n" \
    "  --compare-povray FILE.md: render the relit test views (first --views N, at --res R) with both\n" \
    "    renderers and append a table row (PSNR, mean relative error) to FILE.md.\n" \
    "  Probes: *.exr of --env-dir (default Blender's studio lights).\n" \
    "\n" \
    "       mf gen --split prior-train|test-2d -o DIR [--count N] [--time-budget SECONDS] [--res 64]\n" \
    "              [--seed N] [--views 12] [--tex-res 128] [--spp 2] [--pixel-samples 4] [--threads N]\n" \
    "  Renders material-prior triplets DIR/{rgb,albedo,orm}/NNNNNN.png (RGBA 8-bit; rgb and albedo\n" \
    "  sRGB, orm linear, alpha = coverage) and DIR/manifest.json; stops after N samples (whole\n" \
    "  objects) or the time budget (prior-train default: 1800 s, as many objects as 30 minutes of\n" \
    "  generation give); rerunning the same command resumes (done/ markers).\n" \
    "  test-2d: 8 held-out objects x 4 views (count 32, spp 4) from another seed stream.\n" \
    "  --train-lights blender|procedural|both: where the env-lit half of the views takes its maps:\n" \
    "    blender (default, the committed prior's recipe): probes of --env-dir (Blender's studio lights);\n" \
    "    procedural: a clear sky with sun or a lit room generated in memory from each view's seed\n" \
    "    (datasets/ds_envgen.h; --env-dir is not read), so test-3d's Blender relighting probes are\n" \
    "    lights the prior never saw; both: half probes, half procedural.\n" \
    "  --diffuse 1: diffuse-dominant objects (metallic 0, roughness >= 0.6); --renderer ours|povray:\n" \
    "    povray renders the lit views with POV-Ray (same objects, cameras, lights; GT albedo/ORM ours).\n" \
    "\n" \
    "       mf gen --envs DIR [--count N] [--seed S] [--kind sky|indoor|both] [--env-width W]\n" \
    "  Writes N procedural HDR env maps per kind (default 8, both kinds), DIR/sky_NNN.exr and\n" \
    "  DIR/indoor_NNN.exr: 32-bit float linear RGB lat-long maps W x W/2 (default 256 x 128) in\n" \
    "  Blender's world mapping, usable by every split's --env-dir. sky: Preetham 1999 clear sky,\n" \
    "  sun elevation 3-80 deg, turbidity 2-6, 0.53 deg sun disc (sub-texel at 256 wide: bilinear\n" \
    "  lookup spreads it, so expect fireflies where it is the main light), ground below the horizon;\n" \
    "  indoor: box room seen from its centre with 1-4 ceiling panels / windows (2700-10000 K).\n" \
    "  Exposure: a white plane facing the main light has radiance 0.7-2.0 (Blender's probes: 0.4-2.6).\n"

#define K_COMPARE_HEAD \
    "# Our renderer vs POV-Ray on the same relit views\n\n" \
    "Written by `mf gen --split NAME -o DIR --scenes N --views V --res R [--pov-radiosity C] --compare-povray FILE`\n" \
    "(one row per command). Scenes: the split's first N objects; views: the first V test cameras of each,\n" \
    "under each of the scene's relighting probes (HDR light probes of Blender's studio lights, unrotated).\n" \
    "Ours: mf_render with all lobes (spp_sqrt 4, 4 pixel samples), and with the diffuse lobe only.\n" \
    "POV-Ray 3.7: Lambert with the same kd texture (finish diffuse 1), the probe reaching the object\n" \
    "through radiosity (recursion_limit 1, count C) from a no_image emissive sphere (ds_povray.h).\n" \
    "Metrics over the pixels covered in either image, pooled over all views: PSNR of sRGB colour clamped\n" \
    "to [0, 1]; mean relative error = sum |ours - pov| / sum |pov| of linear RGB. Seconds per view on the\n" \
    "shared 2-core machine (other jobs running).\n\n" \
    "Why they differ: (1) POV-Ray has no microfacet lobe: its surfaces are Lambertian, while ours adds the\n" \
    "GGX lobe with F0 = 0.04 (dielectrics) and F0 = kd (metals), so glossy and metallic objects differ by\n" \
    "their whole specular part (the diffuse-lobe-only columns remove it; black glass parts are specular only).\n" \
    "(2) POV-Ray gathers the environment through radiosity: irradiance sampled with `count` rays at cached\n" \
    "points and interpolated between them, which blurs contact shadows and, for probes with small very bright\n" \
    "regions (sun, windows), gives splotches where a few gather rays hit the bright texels; ours samples\n" \
    "the probe by importance (MIS with BSDF samples), which handles such sources with little noise.\n" \
    "(3) The probe and kd texture reach POV-Ray as Radiance .hdr files (shared 8-bit exponent: ~1% per pixel).\n" \
    "So POV-Ray ground truth is an independent check for diffuse objects under smooth lighting only.\n\n" \
    "| split | px | radiosity count | views | PSNR all lobes (dB) | rel. error all lobes | PSNR diffuse lobe (dB) | rel. error diffuse lobe | s/view ours | s/view POV-Ray |\n" \
    "|---|---|---|---|---|---|---|---|---|---|\n"

/* mf gen --envs DIR: procedural env maps. */
static int gen_envs(const char *dir, int count, int seed, const char *kind, int width) {
    int sky = 1, indoor = 1;
    if (kind && !strcmp(kind, "sky")) indoor = 0;
    else if (kind && !strcmp(kind, "indoor")) sky = 0;
    else if (kind && strcmp(kind, "both")) { mf_fail(MF_EARG, "--kind: expected sky, indoor or both, not '%s'", kind); return MF_EXIT_USAGE; }
    if (count < 1 || count > 100000) { mf_fail(MF_EARG, "--count %d outside [1, 100000]", count); return MF_EXIT_USAGE; }
    if (width < 8 || width > 16384 || width % 2) { mf_fail(MF_EARG, "--env-width %d: expected an even width in [8, 16384]", width); return MF_EXIT_USAGE; }
    if (mf_mkdirs(dir)) return MF_EXIT_FAIL;
    double t0 = mf_now();
    int written = 0;
    for (int k = 0; k < 2; ++k) {
        if ((k == 0 && !sky) || (k == 1 && !indoor)) continue;
        uint64_t base = mf_hash64((uint64_t)seed, k == 0 ? 0x5C7u : 0x1D0u);
        for (int i = 0; i < count; ++i) {
            char name[64], p[MF_PATH_MAX];
            snprintf(name, sizeof name, "%s_%03d.exr", k == 0 ? "sky" : "indoor", i);
            if (mf_path_join(p, sizeof p, dir, name)) return MF_EXIT_FAIL;
            MfImage img;
            if (ds_env_random(k == 0 ? DS_ENV_SKY : DS_ENV_INDOOR, mf_hash64(base, (uint64_t)i), width, width / 2, &img)) return MF_EXIT_FAIL;
            int rc = mf_image_write(p, &img, MF_ENC_LINEAR, 32); /* temporary name + rename */
            mf_image_free(&img);
            if (rc) return MF_EXIT_FAIL;
            ++written;
        }
    }
    mf_log_info("mf gen: %d procedural env maps (%dx%d, seed %d) -> %s in %.1f s", written, width, width / 2, seed, dir, mf_now() - t0);
    return MF_EXIT_OK;
}

typedef struct {
    const char *out, *family, *split, *env_dir, *compare_povray, *envs, *kind, *train_lights, *renderer, *content, *asset;
    const char *layout, *intrinsics, *distortion;
    int diffuse, widen;
    int seed, tex_res, train, test, width, count, res, views, spp, pixel_samples, bounces, threads, scenes, pov_radiosity, env_width;
    int no_render, render;
    float r_min, r_max, time_budget;
} GenArgs;

#define A GenArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output folder (required except with --envs)", .alias = "-o", .meta = "DIR"),
    MF_OPT_INT(A, seed, 1, 0, 2147483647, "random seed"),
    MF_OPT_STR(A, family, NULL, "object family: cup vase bottle bowl box superquadric torus mug clock displaced",
               .unset = "from the seed", .meta = "NAME"),
    MF_OPT_INT(A, tex_res, 0, 4, 8192, "texture size", .unset = "512; a split's own; prior-train 128"),
    MF_OPT_INT(A, train, 0, 1, 100000, "number of training cameras (one object; a split: overrides its own)",
               .unset = "100 (one object), the split's own"),
    MF_OPT_INT(A, test, 0, 1, 100000, "number of test cameras (one object; a split: overrides its own)",
               .unset = "200 (one object), the split's own"),
    MF_OPT_INT(A, width, 0, 8, 4096, "split: image size, overriding the split's own (e.g. a cheap POV-Ray split: "
               "--split test-3d-diffuse --train 24 --width 64, into its own DIR); --layout ingp: image width (height 3/4 of it)",
               .unset = "the split's own; 64 (ingp)"),
    MF_OPT_STR(A, layout, "bvault", "one object: bvault (mesh, textures and cameras, no images) or ingp (an instant-ngp / "
               "nerfstudio capture: transforms.json with intrinsics, RGB frames, masks, mesh.obj; rendered); a scene split: "
               "bvault (everything) or nerf-synthetic (each scene cut to transforms_{train,test}.json, train/, test/: no mesh, "
               "no ground truth; the images are the bvault split's bytes)", .choices = "bvault|ingp|nerf-synthetic"),
    MF_OPT_STR(A, intrinsics, NULL, "--layout ingp: the global lens in pixels (odd frames: focal lengths x1.25, principal point "
               "mirrored)", .unset = "fl_x 0.9x the 0.6911 lens, fl_y 1.1 fl_x, cx 0.55 w, cy 0.45 h", .meta = "FL_X,FL_Y,CX,CY"),
    MF_OPT_STR(A, distortion, NULL, "--layout ingp: OpenCV lens distortion written into transforms.json (not applied to the "
               "images; readers must refuse it)", .unset = "0,0,0,0", .meta = "K1,K2,P1,P2"),
    MF_OPT_FLOAT(A, r_min, 1.5, 0.1, 100, "camera distance, lower end (2.2 / 2.8 cropped no view of 1500 checked)"),
    MF_OPT_FLOAT(A, r_max, 2.0, 0.1, 100, "camera distance, upper end"),
    MF_OPT_STR(A, split, NULL, "write a whole split: tiny small full test-3d test-3d-diffuse test-3d-cyc test-3d-ambig prior-train test-2d", .meta = "NAME"),
    MF_OPT_STR(A, asset, NULL, "split (tiny small full test-3d ...): one scene from this glTF asset (.glb/.gltf with UVs and one "
               "material; its textures are the ground truth) instead of the procedural objects", .meta = "FILE"),
    MF_OPT_BOOL(A, no_render, 0, "split: write the layout only, render no image"),
    MF_OPT_BOOL(A, render, 0, "split: render the images (the default; kept for scripts)"),
    MF_OPT_STR(A, env_dir, NULL, "folder of *.exr light probes", .unset = "Blender's studio lights", .meta = "DIR"),
    MF_OPT_INT(A, scenes, 0, 0, 100000, "split: only the first N scenes (0: all)"),
    MF_OPT_INT(A, spp, 0, 1, MF_OPT_SPP_MAX, "n: n^2 env-light + n^2 BSDF samples per pixel sample", .unset = "the split's own; 4 (ingp)"),
    MF_OPT_INT(A, bounces, 0, 0, 64, "prior-train/test-2d: indirect bounces of our renderer's lit views (0: direct light only, "
               "as nvdiffrecmc; > 0: interreflection, as path tracers such as Cycles render)"),
    MF_OPT_STR(A, compare_povray, NULL, "split: render the relit test views with both renderers, append a table row to FILE.md",
               .meta = "FILE.md"),
    MF_OPT_INT(A, views, 0, 1, 100000, "--compare-povray: first N test views; prior-train/test-2d: views per object; "
               "--layout ingp: frames (>= 2)", .unset = "all; 12 (prior-train), 4 (test-2d), 24 (ingp)"),
    MF_OPT_INT(A, res, 0, 1, 4096, "--compare-povray: render size; prior-train/test-2d: image size", .unset = "the split's; 64"),
    MF_OPT_INT(A, pov_radiosity, 0, 1, 100000, "--compare-povray, and --renderer povray: POV-Ray radiosity count", .unset = "200"),
    MF_OPT_INT(A, count, 0, 1, 10000000, "prior-train/test-2d: samples; --envs: maps per kind",
               .unset = "time budget (prior-train), 32 (test-2d), 8 (--envs)"),
    MF_OPT_FLOAT(A, time_budget, 0, 0, 1e7, "prior-train/test-2d: stop after this many seconds (0: no limit; prior-train without --count: 1800)",
                 .meta = "SECONDS"),
    MF_OPT_INT(A, pixel_samples, 0, 1, MF_OPT_PIXEL_SAMPLES_MAX, "prior-train/test-2d, --layout ingp: primary rays per pixel", .unset = "4"),
    MF_OPT_INT(A, threads, 0, 0, 4096, "prior-train/test-2d: worker threads (0: OpenMP's default)"),
    MF_OPT_STR(A, train_lights, NULL, "prior-train/test-2d: where the env-lit half of the views takes its maps", .choices = "blender|procedural|both",
               .unset = "blender"),
    MF_OPT_INT(A, diffuse, 0, 0, 1, "prior-train/test-2d: 1 = diffuse-dominant objects (metallic 0, roughness >= 0.6)"),
    MF_OPT_STR(A, renderer, "ours", "prior-train/test-2d: who renders the lit view (GT albedo/ORM are always our AOVs)",
               .choices = "ours|povray|cycles"),
    MF_OPT_INT(A, widen, 0, 0, 1, "prior-train/test-2d: 1 = the widened recipe (datasets/ds_widen.h: POV-Ray for 10% of the objects, "
               "field of view and distance, UV overlays, exposure +-2 stops, tone curves, resolution drop, noise)"),
    MF_OPT_STR(A, content, "all", "prior-train/test-2d: which objects: all, train (none of the held-out families and recipes of "
               "datasets/ds_widen.h), heldout (only objects with one)", .choices = "all|train|heldout"),
    MF_OPT_STR(A, envs, NULL, "write procedural HDR env maps to DIR instead", .meta = "DIR"),
    MF_OPT_STR(A, kind, NULL, "--envs: which kinds", .choices = "sky|indoor|both", .unset = "both"),
    MF_OPT_INT(A, env_width, DS_ENV_W, 8, 16384, "--envs: map width (even; height = width / 2)"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[16384];
__attribute__((constructor)) static void gen_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, K_USAGE, t, 1, NULL);
}

static int gen_run(const GenArgs *a);

static int cmd_gen(int argc, char **argv) {
    GenArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_opts_parse(&bind, 1, argc, argv, 0, &p) ? MF_EXIT_USAGE : p.print_config ? mf_cli_print_config(&bind, 1) : gen_run(&a);
    mf_opts_parse_free(&p);
    return rc;
}

/* --split prior-train|test-2d: material-prior triplets. */
static int gen_prior_split(const GenArgs *a, int tl) {
    const char *split = a->split, *out = a->out;
    DsPriorTrainOpts po = !strcmp(split, "test-2d") ? ds_test2d_defaults() : ds_prior_train_defaults();
    if (a->count > 0) po.count = a->count;
    po.time_budget_s = a->time_budget;
    if (a->res > 0) po.res = a->res;
    po.seed = (uint64_t)a->seed;
    if (a->views > 0) po.views_per_object = a->views;
    if (a->tex_res > 0) po.tex_res = a->tex_res;
    if (a->spp > 0) po.spp_sqrt = a->spp;
    if (a->pixel_samples > 0) po.pixel_samples = a->pixel_samples;
    po.bounces = a->bounces;
    po.env_dir = a->env_dir;
    po.train_lights = (DsTrainLights)tl;
    po.threads = a->threads;
    po.diffuse = a->diffuse != 0;
    po.pov_radiosity = a->pov_radiosity;
    po.widen = a->widen;
    po.content = (DsContent)ds_content_from_name(a->content); /* valid: the table's choices */
    if ((int)(po.renderer = (DsRenderer)ds_renderer_from_name(a->renderer)) < 0) { mf_fail(MF_EARG, "--renderer: expected ours, povray or cycles, not '%s'", a->renderer); return MF_EXIT_USAGE; }
    if (po.count <= 0 && a->time_budget <= 0) po.time_budget_s = 1800; /* prior-train: as much as 30 minutes give */
    DsGenStats st;
    if (ds_gen_prior_train(&po, out, &st)) return MF_EXIT_FAIL;
    mf_log_info("mf gen: %s %d samples (%d objects) at %d px -> %s; this run %d views in %.1f s (%.2f views/s)", split, st.count,
                st.objects, po.res, out, st.rendered_views, st.wall_s, st.wall_s > 0 ? st.rendered_views / st.wall_s : 0.0);
    return MF_EXIT_OK;
}

/* --compare-povray FILE.md: our renderer against POV-Ray on the split's relit test views, one
 * table row appended. */
static int gen_compare_povray(const GenArgs *a, const DsSplitSpec *spec) {
    const char *compare = a->compare_povray;
    DsRenderCompare c;
    int cres = a->res > 0 ? a->res : spec->width;
    if (ds_compare_renderers(spec, a->out, a->scenes, a->views > 0 ? a->views : 0, cres, &c)) return MF_EXIT_FAIL;
    int fresh = !mf_file_exists(compare);
    FILE *f = fopen(compare, "a");
    if (!f) { mf_fail(MF_EIO, "%s: cannot open for appending", compare); return MF_EXIT_FAIL; }
    if (fresh) fputs(K_COMPARE_HEAD, f);
    fprintf(f, "| %s%s | %d | %d | %d | %.2f | %.4f | %.2f | %.4f | %.2f | %.2f |\n", a->split, spec->diffuse ? " (diffuse objects)" : "", cres, spec->pov_radiosity > 0 ? spec->pov_radiosity : DS_SPLIT_POV_RADIOSITY,
            c.all.n_views, ds_compare_psnr(&c.all), c.all.rel_den > 0 ? c.all.rel_num / c.all.rel_den : 0.0,
            ds_compare_psnr(&c.diffuse_lobe),
            c.diffuse_lobe.rel_den > 0 ? c.diffuse_lobe.rel_num / c.diffuse_lobe.rel_den : 0.0, c.all.n_views ? c.sec_ours / c.all.n_views : 0.0,
            c.all.n_views ? c.sec_povray / c.all.n_views : 0.0);
    fclose(f);
    mf_log_info("mf gen: ours vs POV-Ray on %d relit views: PSNR %.2f dB, mean relative error %.4f -> %s", c.all.n_views,
                ds_compare_psnr(&c.all), c.all.rel_den > 0 ? c.all.rel_num / c.all.rel_den : 0.0, compare);
    return MF_EXIT_OK;
}

/* --split tiny|small|full|test-3d|test-3d-*: the layout, rendered unless --no-render. */
static int gen_split(const GenArgs *a) {
    const char *split = a->split, *out = a->out;
    int render = !a->no_render;
    DsSplitSpec spec;
    if (ds_split_spec(split, &spec)) return MF_EXIT_USAGE;
    if (render && spec.cycles && !ds_cycles_available()) {
        mf_fail(MF_EEXT, "--split %s renders with Blender Cycles: no blender here (install Debian's blender, or set $MF_BLENDER; "
                "--no-render writes the layout only)", split);
        return MF_EXIT_FAIL;
    }
    spec.r_min = a->r_min;
    spec.r_max = a->r_max;
    if (a->spp > 0) spec.spp_sqrt = a->spp;
    if (a->scenes > 0) spec.n_scenes = a->scenes;
    if (a->train > 0) spec.n_train = a->train; /* ranges: the option table */
    if (a->test > 0) spec.n_test = a->test;
    if (a->width > 0) spec.width = a->width;
    spec.pov_radiosity = a->pov_radiosity;
    spec.asset = a->asset;
    spec.nerf_layout = !strcmp(a->layout, "nerf-synthetic");
    if (spec.nerf_layout) spec.n_relight = 0; /* cut anyway; the probes' draw does not depend on it */
    double t0 = mf_now();
    int nv = 0;
    if (ds_write_split(&spec, out, a->env_dir, (uint64_t)a->seed)) return MF_EXIT_FAIL;
    if (render && ds_render_split(&spec, out, &nv)) return MF_EXIT_FAIL;
    if (spec.nerf_layout && ds_split_nerf_layout(out)) return MF_EXIT_FAIL;
    double wall = mf_now() - t0;
    if (ds_split_manifest(&spec, out, (uint64_t)a->seed, render, nv, wall)) return MF_EXIT_FAIL;
    if (a->compare_povray && gen_compare_povray(a, &spec)) return MF_EXIT_FAIL;
    mf_log_info("mf gen: split %s (%d scenes) -> %s%s; %d views rendered in %.1f s", split, spec.n_scenes, out,
                render ? "" : " (layout only, --no-render)", nv, wall);
    return MF_EXIT_OK;
}

/* "a,b,c,d": exactly n finite numbers into out, else MF_EARG naming the option. */
static int parse_numbers(const char *opt, const char *text, double *out, int n) {
    const char *p = text;
    for (int k = 0; k < n; ++k) {
        char *end;
        double v = strtod(p, &end);
        if (end == p || !isfinite(v) || (*end != (k + 1 < n ? ',' : '\0')))
            return mf_fail(MF_EARG, "%s '%s': expected %d comma-separated finite numbers", opt, text, n);
        out[k] = v;
        p = end + 1;
    }
    return MF_OK;
}

/* One object: its training and test cameras (bvault), or a rendered capture (--layout ingp). */
static int gen_object(const GenArgs *a) {
    const char *out = a->out, *fam_name = a->family;
    int seed = a->seed, res = a->tex_res > 0 ? a->tex_res : DS_DEFAULT_TEX_RES;
    int ntrain = a->train > 0 ? a->train : 100, ntest = a->test > 0 ? a->test : 200;
    int fam = fam_name ? ds_family_from_name(fam_name) : (int)((unsigned)seed % DS_FAM_COUNT);
    if (fam < 0) { mf_fail(MF_EARG, "--family: unknown family '%s'", fam_name); return MF_EXIT_USAGE; }
    int ingp = !strcmp(a->layout, "ingp");
    DsCaptureSpec cap = ds_capture_spec_default(a->width > 0 ? a->width : 64);
    if (ingp && a->views > 0) cap.n_frames = a->views;
    if (ingp && (a->train > 0 || a->test > 0)) { mf_fail(MF_EARG, "--train/--test: --layout ingp writes --views N frames (test: 0, 8, 16, ...)"); return MF_EXIT_USAGE; }
    if (ingp && a->views == 1) { mf_fail(MF_EARG, "--views 1: a capture needs >= 2 frames (frame 0 is held out for test)"); return MF_EXIT_USAGE; }
    double lens[4];
    if (ingp && a->intrinsics) {
        if (parse_numbers("--intrinsics", a->intrinsics, lens, 4)) return MF_EXIT_USAGE;
        cap.fl_x = lens[0], cap.fl_y = lens[1], cap.cx = lens[2], cap.cy = lens[3];
    }
    if (ingp && a->distortion && parse_numbers("--distortion", a->distortion, cap.distortion, 4)) return MF_EXIT_USAGE;
    cap.r_min = a->r_min, cap.r_max = a->r_max;
    if (a->spp > 0) cap.spp_sqrt = a->spp;
    if (a->pixel_samples > 0) cap.pixel_samples = a->pixel_samples;
    if (ingp && ds_capture_check(&cap)) return MF_EXIT_USAGE; /* before the object is made */
    DsObject o;
    if (ds_object_generate(&o, (DsFamily)fam, (uint64_t)seed, res)) return MF_EXIT_FAIL;
    int rc = ingp ? ds_write_capture(&cap, &o, (uint64_t)seed, out) : ds_object_write(&o, out);
    if (!rc && !ingp) {
        DsCamSampling s = ds_cam_sampling_default();
        s.r_min = a->r_min;
        s.r_max = a->r_max;
        MfMat4 *c2w = malloc(sizeof(MfMat4) * (size_t)(ntrain > ntest ? ntrain : ntest));
        if (!c2w) rc = mf_fail(MF_ENOMEM, "out of memory");
        if (!rc) rc = ds_sample_cameras(&s, ntrain, (uint64_t)seed, 0, c2w);
        if (!rc) rc = ds_write_transforms(out, "train", s.camera_angle_x, c2w, ntrain);
        if (!rc) rc = ds_sample_cameras(&s, ntest, (uint64_t)seed, 1, c2w);
        if (!rc) rc = ds_write_transforms(out, "test", s.camera_angle_x, c2w, ntest);
        free(c2w);
    }
    if (!rc) mf_log_info("mf gen: %s seed %d (%d parts, %d triangles) -> %s", ds_family_name(o.family), seed, o.nparts, o.mesh.nt, out);
    ds_object_free(&o);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

static int gen_run(const GenArgs *a) {
    const char *split = a->split, *train_lights = a->train_lights;
    if (a->envs) return gen_envs(a->envs, a->count > 0 ? a->count : 8, a->seed, a->kind, a->env_width);
    if (!a->out) { mf_fail(MF_EARG, "missing -o DIR"); return MF_EXIT_USAGE; }
    int tl = train_lights ? ds_train_lights_from_name(train_lights) : DS_LIGHTS_BLENDER;
    if (tl < 0) { mf_fail(MF_EARG, "--train-lights: expected blender, procedural or both, not '%s'", train_lights); return MF_EXIT_USAGE; }
    int prior_split = split && (!strcmp(split, "prior-train") || !strcmp(split, "test-2d"));
    if (train_lights && !prior_split) {
        mf_fail(MF_EARG, "--train-lights applies to --split prior-train or test-2d");
        return MF_EXIT_USAGE;
    }
    int ingp = !strcmp(a->layout, "ingp"), nerf = !strcmp(a->layout, "nerf-synthetic");
    if (ingp && split) { mf_fail(MF_EARG, "--layout ingp writes one object's capture; it does not apply to --split"); return MF_EXIT_USAGE; }
    if (nerf && (!split || prior_split || a->no_render)) {
        mf_fail(MF_EARG, "--layout nerf-synthetic applies to a rendered scene split (--split tiny|small|full|test-3d|...; not with --no-render)");
        return MF_EXIT_USAGE;
    }
    if (!ingp && (a->intrinsics || a->distortion)) {
        mf_fail(MF_EARG, "--%s applies to --layout ingp", a->intrinsics ? "intrinsics" : "distortion");
        return MF_EXIT_USAGE;
    }
    if (a->asset && (!split || prior_split)) {
        mf_fail(MF_EARG, "--asset applies to a scene split (--split tiny|small|full|test-3d|test-3d-diffuse|test-3d-ambig)");
        return MF_EXIT_USAGE;
    }
    return prior_split ? gen_prior_split(a, tl) : split ? gen_split(a) : gen_object(a);
}

MF_COMMAND(gen, "gen", "generate a procedural object, or a data set split (layout, rendered views, prior-train triplets)", usage, cmd_gen)
