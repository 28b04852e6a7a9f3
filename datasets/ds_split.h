/* ds_split: writes the layout of a generated data set split (bvault, DESIGN.md "Contracts")
 * without rendering it: per scene the ground-truth object, cameras, training light and
 * relighting lights, plus scene JSONs for `mf render` (mf/scene/mf_scene.h format) that render
 * the images into the same layout.
 *
 * For split spec s, out_dir/<NNN>_<family>/ gets:
 *   mesh.obj (+ mesh.mtl), gt/kd.png, gt/orm.png        ds_object_write
 *   transforms_train.json, transforms_test.json          ds_sample_cameras (streams 0 and 1)
 *   gt/env.exr                                           training light (copied probe)
 *   relight/<env>.exr                                    s.n_relight other probes (never the
 *                                                        training light; .hdr probes converted)
 *   render_train.json, render_test.json,                 `mf render render_train.json -o
 *   render_relight_<env>.json                            <scene>/train --png` etc. (width x width)
 * and out_dir/split.json lists the scenes (name, family, seed, train env, relight envs).
 * Probes come from env_dir (*.exr and *.hdr, sorted by name; Blender's studio lights by default:
 * /usr/share/blender/datafiles/studiolights/world). Scene k uses family k mod DS_FAM_COUNT
 * and object seed ds_object_seed(DS_STREAM_TEST, seed, k) (ds_gen.h); everything is deterministic from (spec, seed). */
#ifndef DS_SPLIT_H
#define DS_SPLIT_H

#include <math.h>
#include <stdint.h>

#define DS_DEFAULT_ENV_DIR "/usr/share/blender/datafiles/studiolights/world"
#define DS_RELIGHT_ALL (-1)

typedef struct {
    char name[32];
    int n_scenes;
    int width;      /* square image size */
    int n_train, n_test;
    int tex_res;
    int n_relight;  /* relighting probes per scene; DS_RELIGHT_ALL: every probe but the training one */
    int spp_sqrt;   /* written into the render JSONs */
    int pixel_samples;  /* primary rays per pixel when rendered (0: 4) */
    int diffuse;    /* 1: objects made diffuse-dominant (metallic 0, roughness >= 0.6) */
    int ambiguous;  /* 1: scene k's object gets material ambiguity k mod DS_AMBIG_COUNT (ds_gen.h) */
    int povray;     /* 1: --render makes the lit views (train, relit) with POV-Ray */
    int cycles;     /* 1: --render makes them with Blender Cycles (ds_cycles.h); the test views
                       under the training light and the GT AOVs stay ours, with either */
    int pov_radiosity; /* POV-Ray radiosity count (0: DS_SPLIT_POV_RADIOSITY) */
    const char *asset; /* NULL: procedural objects; else one scene, 000_<stem>, from this glTF asset (ds_asset.h) */
    int nerf_layout;   /* 1: the rendered split is cut to NeRF-Synthetic's layout (ds_split_nerf_layout);
                          the manifest says so */
    float r_min, r_max; /* camera distance range (default 1.5-2.0 as specified; note: with
                           camera_angle_x 0.6911 and extent-1 objects, 17% of such views crop
                           the object at the frame border, 0% at 2.2-2.8) */
} DsSplitSpec;

/* Named specs: "tiny" (3 scenes, 32x32, 8 train, 4 test views, 64^2 textures, 2 relighting
 * lights), "small" (10 scenes, 128x128, 50 / 20 views, 256^2, 3 lights), "full" (30 scenes,
 * 512x512, 100 / 50 views, 512^2, 4 lights), "test-3d" (9 scenes, 128x128, 64 train / 8 test
 * views, 256^2, every other probe relights (7 with Blender's 8), spp_sqrt 3), "test-3d-diffuse"
 * (test-3d with diffuse objects, lit views by POV-Ray, 3 relighting lights), "test-3d-cyc" (test-3d's
 * objects, cameras and probes, the first 3 relighting lights, lit views by Blender Cycles), "test-3d-ambig"
 * (test-3d whose objects carry material ambiguity: low-contrast albedo, mixed metals, rough beside
 * glossy, dark albedo, in turn; ds_object_make_ambiguous). MF_EARG for an unknown name. */
int ds_split_spec(const char *name, DsSplitSpec *out);

/* Resolves s->n_relight == DS_RELIGHT_ALL to the probe count - 1 (in place). With s->asset, writes
 * one scene (s->n_scenes set to 1) whose object is the asset; split.json names it ("asset"). */
int ds_write_split(DsSplitSpec *s, const char *out_dir, const char *env_dir, uint64_t seed);

/* Renders a split written by ds_write_split (reads out_dir/split.json and the scene files) into
 *   <scene>/train/r_NNN.png           training views under gt/env.exr (RGBA 8-bit sRGB, straight
 *                                     alpha = coverage)
 *   <scene>/test/r_NNN.png            test views under gt/env.exr
 *   <scene>/gt/albedo/r_NNN.png, gt/orm/r_NNN.png   GT AOVs of the test views (sRGB / linear)
 *   <scene>/relight/<env>/r_NNN.exr   test views under each relighting light (linear RGBA float,
 *                                     colour premultiplied by alpha)
 * with mf_render (s->spp_sqrt, s->pixel_samples; per-view seeds from the object seed) or, when
 * s->povray, POV-Ray for the lit views (ds_povray.h; scratch in <scene>/.povray/), or when
 * s->cycles, Blender Cycles (ds_cycles.h; one Blender run per light, scratch in <scene>/.cycles/;
 * its blender.log stays there when a run fails). Resumable:
 * views whose file exists are skipped (all writes are atomic), a scene is marked complete by
 * <scene>/.rendered. *rendered (may be NULL) = views rendered by this call. */
int ds_render_split(const DsSplitSpec *s, const char *out_dir, int *rendered);

/* Cuts a rendered split to NeRF-Synthetic's layout: each scene folder of out_dir/split.json keeps
 * transforms_train.json, transforms_test.json, train/ and test/ (RGBA PNGs) and loses the rest
 * (mesh, textures, gt/, relight/, render JSONs, the .rendered marker): a mesh-less scene with no
 * ground truth, as a user of such a set has it. Its images are the full split's bytes, so a
 * full split made with the same arguments scores results on it. A rerun of mf gen rewrites and
 * re-renders what was removed, then cuts again. */
int ds_split_nerf_layout(const char *out_dir);

/* Writes out_dir/manifest.json: split, seed, counts, render settings, wall time and views/s of
 * this run, and "files": {"<relative path>": "<FNV-1a 64 hex>"} for every file under out_dir
 * (sorted; names starting with '.' and manifest.json itself excluded). */
int ds_split_manifest(const DsSplitSpec *s, const char *out_dir, uint64_t seed, int rendered, int views_rendered, double wall_s);

/* POV-Ray radiosity samples per gather for generated splits (600 costs 3x the time at 128 px
 * for about the same error against our renderer; reports/datasets/renderers.md). */
#define DS_SPLIT_POV_RADIOSITY 200

/* Our renderer against POV-Ray on the relit test views of a written split (scenes [0,
 * max_scenes), views [0, max_views), res x res; 0 = all): ours with all lobes (spp_sqrt 4,
 * 4 pixel samples) and with the diffuse lobe only, POV-Ray with the scene's kd (Lambert,
 * radiosity s->pov_radiosity, scratch in <scene>/.compare/). Over the pixels covered in either
 * image of every view (pooled): PSNR of the sRGB-encoded premultiplied colour clamped to [0, 1]
 * (10 log10(1 / MSE)), and the mean relative error sum |ours - pov| / sum |pov| of linear colour. */
typedef struct {
    double se, n_px, rel_num, rel_den; /* sums over pixels of all views */
    int n_views;
} DsRenderCompareStat;
static inline double ds_compare_psnr(const DsRenderCompareStat *c) {
    double mse = c->n_px > 0 ? c->se / (3.0 * c->n_px) : 0.0;
    return 10.0 * log10(1.0 / (mse > 1e-12 ? mse : 1e-12));
}
typedef struct {
    DsRenderCompareStat all;           /* ours (diffuse + specular) vs POV-Ray */
    DsRenderCompareStat diffuse_lobe;  /* ours, diffuse lobe only, vs POV-Ray */
    double sec_ours, sec_povray;       /* wall time of the renders */
} DsRenderCompare;
int ds_compare_renderers(const DsSplitSpec *s, const char *out_dir, int max_scenes, int max_views, int res, DsRenderCompare *out);

#endif
