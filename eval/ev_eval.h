/* ev_eval: scores a method's result folder against a generated (bvault) or loaded scene.
 *
 * A result folder (DESIGN.md "Contracts": results/<method>/<scene>/) holds mesh.obj, albedo.png
 * (sRGB), orm.png (linear) and env.exr. Scoring, for every test view of the scene:
 *   relit   the result rendered under each relighting light of the scene (relight/<env>.exr)
 *           with the project's renderer, against the data set's relit view; both are linear and
 *           premultiplied by coverage: they are un-premultiplied, then the protocol of
 *           ev_align.h (per-channel scale inside the GT mask, default ratio of means; sRGB; clip;
 *           composite on black) and the metrics of ev_metrics.h, full-frame and masked;
 *   albedo  the result's albedo AOV (kd at the primary hits) against the view's GT albedo, with
 *           the same protocol;
 *   orm     the ORM AOV against GT ORM on roughness and metallic (G, B), no alignment; orm3
 *           repeats PSNR over all three channels with a constant R (as the paper's numbers
 *           behave: +1.76 dB);
 *   nv      only for a scene with neither relighting lights nor per-view albedo/ORM (a capture,
 *           e.g. instant-ngp / nerfstudio): novel-view synthesis under the TRAINING light, the
 *           result rendered with its own env.exr from each held-out test camera against the test
 *           image, with the relit protocol (metrics nv_psnr, nv_ssim, nv_l1, nv_flip, nv_*_masked;
 *           CSV kind "novel_view", light "training"; a log line says so). A result without
 *           env.exr is refused there.
 * Per-view rows go to a CSV; per-scene means become EvTable records (metric names:
 * relit_psnr, relit_ssim, relit_l1, relit_flip, relit_psnr_masked, albedo_psnr, albedo_ssim,
 * albedo_l1, orm_psnr, orm_l1, orm3_psnr). A view whose score cannot be computed (e.g. an
 * empty mask) is excluded and counted, never turned into a NaN.
 * Geometry (issue 14), when the scene has a GT mesh (DsViews.mesh_path) and unless no_geom: the
 * result's mesh against it, per scene only: geom_chamfer (Stanford-ORB Chamfer x 1e3, GT vertices
 * vs EV_GEOM_SAMPLES area samples of the result), geom_chamfer_uniform (EV_GEOM_SAMPLES area
 * samples of each mesh), geom_normal_deg and geom_normal_1mcos (the point pairs of geom_chamfer),
 * geom_view_normal_deg, geom_view_normal_1mcos and geom_mask_iou (normal maps and masks ray-cast
 * from the scored test cameras; eval/ev_geom.h). A method that keeps the given mesh scores about
 * 0 (the sampling floors) on all but the IoU, which is 1. */
#ifndef EV_EVAL_H
#define EV_EVAL_H

#include <stdio.h>

#include "eval/ev_align.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "scene/mf_envmap.h"
#include "scene/mf_mesh.h"

typedef struct {
    MfMesh mesh; /* owned */
    MfImage kd;  /* owned; (h, w, 3) linear */
    MfImage orm; /* owned; (h, w, 3) linear */
    int has_env;
    MfEnvMap env; /* owned when has_env */
    int has_normal;
    MfImage normal; /* owned when has_normal; (h, w, 3) tangent-space normal map (normal.png, linear) */
} EvResult;

/* mesh_path NULL: dir/mesh.obj (a snapshot folder passes its run's mesh; an OBJ or a glTF file).
 * Loads normal.png too when the folder has one (renders then use it as the material's normal map).
 * dir may also name a .glb/.gltf file (a result's scene.glb, or any asset with one material): mesh,
 * albedo, ORM and normalTexture come from it (io/mf_gltf_read.h), env.exr from the
 * file's folder when present. */
int ev_result_load(const char *dir, const char *mesh_path, EvResult *out);
void ev_result_free(EvResult *r);

/* Area samples of the result mesh for geom_chamfer, and of each mesh for geom_chamfer_uniform
 * (Stanford-ORB uses 30000). */
#define EV_GEOM_SAMPLES 30000

typedef struct {
    int spp_sqrt, pixel_samples; /* relighting render quality */
    EvAlign align;
    unsigned long long seed;
    int max_views; /* 0: all test views */
    int max_lights; /* 0: all relighting lights */
    const char *mesh_path; /* NULL: the result folder's mesh.obj */
    const char *mask;      /* NULL: the images' alpha; else DsLoadOptions.mask_dir (e.g. "masks": <scene>/masks/) */
    int no_geom;           /* 1: skip the geometry records (geom_*) */
    int quiet;             /* 1: the scene loader's notes are not said again (DsLoadOptions.quiet): a
                              scene already loaded by this command */
} EvEvalOpts;

/* Trivial guesses that every method must beat (pass as result_dir, with the scene's GT):
 *   EV_TRIVIAL_GREY_DIR   mid-grey albedo 0.5, roughness 0.5, metallic 0 on the GT mesh, relit
 *                         under the true relighting light;
 *   EV_TRIVIAL_FLAT_DIR   the true albedo and ORM on the GT mesh, but rendered under a constant
 *                         white light instead of the relighting light (lighting ignored).
 * Both go through the same protocol (so their scale is aligned like every method's) and are
 * scored on relighting only (their materials are not estimates). */
#define EV_TRIVIAL_GREY_DIR ":trivial-grey"
#define EV_TRIVIAL_FLAT_DIR ":trivial-flat-light"

/* The defaults: the option table of ev_eval_opts.c (render quality, alignment, view limit). */
EvEvalOpts ev_eval_opts_default(void);

/* Scores result_dir against scene_dir's test split; adds per-scene records to t and per-view rows
 * to csv (may be NULL; header written by the caller: ev_eval_csv_header). Returns MF_OK even when
 * some views are excluded (*excluded counts them). */
int ev_eval_scene(const char *scene_dir, const char *result_dir, const char *method, const char *dataset,
                  const char *scene, const EvEvalOpts *o, EvTable *t, FILE *csv, int *excluded);
void ev_eval_csv_header(FILE *csv);

/* The cells of one row of a scene's image grid, for test view 0 under relighting light 0:
 * relit view, albedo, roughness, metallic (grey) and the env map (Reinhard-tonemapped), all
 * linear (h, w, 3) ready for ev_grid_png. result_dir NULL gives the ground-truth row. */
#define EV_GRID_COLS 5
/* The columns' names, for the grid's labels. */
extern const char *const ev_grid_col_names[EV_GRID_COLS];
int ev_eval_grid_row(const char *scene_dir, const char *result_dir, const EvEvalOpts *o, MfImage cells[EV_GRID_COLS]);

#endif
