/* ds_gen: rendered data set splits, rendered in-process with mf_render (mf/render/mf_integrator.h).
 *
 * prior-train (layout pinned in notes/contracts.md and the README): training triplets for the
 * material prior. Object k (family k mod DS_FAM_COUNT, seed ds_object_seed(DS_STREAM_PRIOR,
 * seed, k)) is generated with tex_res^2 textures and rendered from views_per_object cameras
 * (ds_sample_cameras, default sampling, stream 0 of the object seed); sample index
 * i = k * views_per_object + v. Each view's light (as the paper's training data, REFERENCE.md):
 * with probability 1/2 an HDR probe of env_dir (uniform choice) rotated about +Z by a uniform
 * angle; otherwise, with equal odds, a point light at the camera (power uniform in
 * [DS_POINT_W_MIN, DS_POINT_W_MAX] W) or a sun shining along the view direction (strength
 * uniform in [DS_SUN_MIN, DS_SUN_MAX] W/m^2). The paper's 150 W point / 10-20 W/m^2 sun were
 * for Objaverse-sized scenes; ours are scaled so a white Lambertian surface facing the light at
 * the mean camera distance has radiance about 0.5-1 (like the probes).
 * train_lights picks where the env-map half of the views gets its maps:
 *   DS_LIGHTS_BLENDER (default, the committed prior's recipe): the probes of env_dir as above;
 *   DS_LIGHTS_PROCEDURAL: a procedural map generated in memory (datasets/ds_envgen.h,
 *     DS_ENV_W x DS_ENV_H) from the view's seed mf_hash64(object seed, 0xE0000 + v): a clear sky
 *     when u_probe < 1/2 (its sun not in the map but a directional MF_LIGHT_SUN of the same
 *     irradiance, rotated with the map: a sub-texel sun in the map gives fireflies), else a lit
 *     room; env_dir is never read, so test-3d's Blender relighting probes stay lights the prior
 *     never saw;
 *   DS_LIGHTS_BOTH: u_probe < 1/2 picks a probe of env_dir (index u_probe * 2 * n), else a
 *     procedural map (sky / room by the second half of u_probe's range).
 * The random draws per view are the same in every mode (so blender mode's bytes are unchanged).
 *   out/rgb/NNNNNN.png     RGBA 8-bit sRGB lit render (straight alpha), alpha = coverage
 *   out/albedo/NNNNNN.png  RGBA 8-bit sRGB kd AOV, alpha = coverage
 *   out/orm/NNNNNN.png     RGBA 8-bit linear ORM AOV (R = 1, G roughness, B metallic)
 *   out/done/OOOOOO.txt    per-object completion marker: one line "<file> <fnv1a64 hex>" per
 *                          file written for that object (written last, atomically)
 *   out/manifest.json      split, resolution, count, seed, objects, views_per_object, lights,
 *                          wall time and views/s of the last run, FNV-1a 64 of every file
 * Renderer axis (issue 12, the generalisation matrix; both off by default, and then the bytes
 * are those of the code before them: no new random draw, no new manifest key):
 *   diffuse = 1: every object made diffuse-dominant by ds_object_make_diffuse (metallic 0,
 *     roughness >= DS_DIFFUSE_ROUGHNESS_MIN), as test-3d-diffuse's objects;
 *   renderer = DS_RENDERER_POVRAY: the lit view out/rgb/ is rendered by POV-Ray (ds_povray.h:
 *     Lambert with kd, the view's env map through radiosity with hide_env = 1, its sun or point
 *     light; every light kind the generator draws is one the export supports), antialiasing
 *     depth 1, radiosity count pov_radiosity (0: DS_SPLIT_POV_RADIOSITY). The same object,
 *     camera and light as our renderer's view; albedo/ and orm/ stay our renderer's AOVs, so a
 *     POV-Ray split and an ours split of the same seed hold the same GT files. POV-Ray has no
 *     GGX lobe: use it with diffuse = 1 (the lit images then differ from ours by the F0 = 0.04
 *     specular lobe and the renderers' own approximations). Scratch files in
 *     out/.povray/OOOOOO/, removed when the object is done; no POV-Ray: MF_EEXT naming the tool
 *     before anything is written.
 * Widened recipe and content filter (ds_widen.h; both off by default, bytes then unchanged):
 *   content != DS_CONTENT_ALL: candidate objects j = 0, 1, ... (family j mod DS_FAM_COUNT, seed
 *     ds_object_seed(stream, seed, j)) are tested by ds_content_accepts and the accepted ones
 *     become objects 0, 1, ... of the split (a count is then required); manifest key "content";
 *   widen = 1: per object and per view as ds_widen.h says; POV-Ray renders the lit views of
 *     DS_WIDEN_POV_FRAC of the objects (made diffuse), so POV-Ray must be installed; manifest
 *     key "widen".
 *   renderer = DS_RENDERER_CYCLES: the lit view is rendered by Blender Cycles (ds_cycles.h: full
 *     path tracing, Principled BSDF with the object's kd/roughness/metallic), the same object,
 *     camera and light; albedo/ and orm/ stay our AOVs; all of an object's views in one Blender
 *     run, scratch in out/.cycles/OOOOOO/; no Blender: MF_EEXT naming it before anything is
 *     written. Blender is optional: nothing in `make test` needs it.
 * Every file is written to a temporary name and renamed. A run resumes: objects with a marker
 * are skipped (their checksums are read from the marker), the others are (re)rendered; the
 * bytes do not depend on interruptions or thread count (deterministic from the seed).
 * Generation stops after `count` samples (rounded up to whole objects) or when time_budget_s
 * of this run is spent (objects already started finish); objects run in parallel (OpenMP),
 * each object's rows serially in its thread.
 *
 * Seeds: prior-train and test-2d object seeds carry their stream index in the top 4 bits
 * (1, 2; hashed seed in the low 60 bits), so those two never meet; the test splits keep their
 * original seeds mf_hash64(seed, k) (the tiny CI scene depends on them), distinct from the
 * others unless a 64-bit hash collides; a test checks the ranges in use. */
#ifndef DS_GEN_H
#define DS_GEN_H

#include <stdint.h>

#include "datasets/ds_shapes.h"
#include "datasets/ds_widen.h"

#define DS_POINT_W_MIN 30.0f
#define DS_POINT_W_MAX 60.0f
#define DS_SUN_MIN 1.5f
#define DS_SUN_MAX 3.0f

/* Which renderer makes the lit view of prior-train / test-2d (see above). */
typedef enum { DS_RENDERER_OURS = 0, DS_RENDERER_POVRAY = 1, DS_RENDERER_CYCLES = 2 } DsRenderer;
/* "ours", "povray", "cycles" -> renderer; -1 for another name. */
int ds_renderer_from_name(const char *name);
const char *ds_renderer_name(DsRenderer r);

#define DS_DIFFUSE_ROUGHNESS_MIN 0.6f

typedef enum { DS_STREAM_TEST = 0, DS_STREAM_PRIOR = 1, DS_STREAM_TEST2D = 2 } DsSeedStream;

/* Where the env-map lit views of prior-train / test-2d take their maps (see above). */
typedef enum { DS_LIGHTS_BLENDER = 0, DS_LIGHTS_PROCEDURAL = 1, DS_LIGHTS_BOTH = 2 } DsTrainLights;
/* "blender", "procedural", "both" -> mode; -1 for another name. */
int ds_train_lights_from_name(const char *name);
const char *ds_train_lights_name(DsTrainLights t);

/* Object seed k of a stream: DS_STREAM_TEST: mf_hash64(seed, k); others:
 * (stream << 60) | (mf_hash64(seed ^ stream*C, k) >> 4). */
uint64_t ds_object_seed(DsSeedStream stream, uint64_t seed, uint64_t k);

typedef struct {
    int count;            /* samples wanted (<= 0: unlimited, the time budget decides) */
    int res;              /* square image size (64) */
    uint64_t seed;
    double time_budget_s; /* <= 0: none */
    int views_per_object; /* 12 */
    int tex_res;          /* 128 */
    int spp_sqrt;         /* 2 */
    int pixel_samples;    /* 4 */
    int bounces;          /* 0: direct light only (as every committed split); > 0: indirect bounces of
                             our renderer's lit views (MfRenderOpts.bounces: interreflection) */
    const char *env_dir;  /* NULL: DS_DEFAULT_ENV_DIR */
    int threads;          /* objects in parallel (<= 0: OpenMP default) */
    DsSeedStream stream;  /* DS_STREAM_PRIOR (test-2d: DS_STREAM_TEST2D) */
    const char *split;    /* name written into the manifest ("prior-train", "test-2d") */
    DsTrainLights train_lights; /* DS_LIGHTS_BLENDER (default) */
    int diffuse;          /* 0 (default); 1: diffuse-dominant objects (ds_object_make_diffuse) */
    DsRenderer renderer;  /* DS_RENDERER_OURS (default) or DS_RENDERER_POVRAY for the lit view */
    int pov_radiosity;    /* POV-Ray radiosity count (0: DS_SPLIT_POV_RADIOSITY) */
    int widen;            /* 0 (default); 1: the widened recipe of ds_widen.h */
    DsContent content;    /* DS_CONTENT_ALL (default); TRAIN / HELDOUT: the content filter of ds_widen.h */
} DsPriorTrainOpts;

DsPriorTrainOpts ds_prior_train_defaults(void);
/* test-2d (the paper's 2D table): 8 held-out objects x 4 views, the prior-train layout and
 * lights, object seeds from DS_STREAM_TEST2D. */
DsPriorTrainOpts ds_test2d_defaults(void);

typedef struct {
    int objects;          /* complete objects on disk (prefix 0..objects-1) */
    int count;            /* samples = objects * views_per_object */
    int rendered_views;   /* views rendered in this run */
    int env_views;        /* of those, views lit by an env map (probe or procedural) */
    double wall_s;        /* this run */
} DsGenStats;

/* Writes or resumes the prior-train split in out_dir. stats may be NULL. */
int ds_gen_prior_train(const DsPriorTrainOpts *o, const char *out_dir, DsGenStats *stats);

/* Makes an object diffuse-dominant in place: metallic 0 and roughness >= DS_DIFFUSE_ROUGHNESS_MIN
 * in every texel of its ORM texture (test-3d-diffuse, test-2d --diffuse 1). */
void ds_object_make_diffuse(DsObject *o);

/* Material ambiguity (test-3d-ambig, issue 12 item 4): cases where the images alone leave albedo,
 * material and light hard to separate, made from a generated object's textures in place.
 *   LOW_CONTRAST  kd pulled to its per-channel mean: kd = m + 0.2 (kd - m)
 *   MIXED_METAL   metallic 1 in every other of 6 bands along u (roughness there at most 0.35),
 *                 0 between them: metal and dielectric of the same base colour side by side
 *   ROUGH_GLOSSY  roughness 0.08 in every other of 6 bands along v, 0.9 between them
 *   DARK          kd x 0.1 (albedo 0-0.1; the optimiser works at the images' exposure, so this is
 *                 the same as dark albedo under a 10x brighter light, up to the scale alignment)
 * Texel columns map to u, rows to v. */
typedef enum { DS_AMBIG_LOW_CONTRAST = 0, DS_AMBIG_MIXED_METAL, DS_AMBIG_ROUGH_GLOSSY, DS_AMBIG_DARK, DS_AMBIG_COUNT } DsAmbiguity;
const char *ds_ambiguity_name(DsAmbiguity a);
void ds_object_make_ambiguous(DsObject *o, DsAmbiguity a);

/* Sorted *.exr and *.hdr names of a folder (caller frees each and the array). */
int ds_list_probes(const char *dir, char ***names, int *n);

#endif
