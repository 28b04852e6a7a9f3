/* ds_load: loaders for the four on-disk data set formats into one in-memory structure
 * (issue "Datasets", part 4).
 *
 * Every loader returns DsViews: posed RGBA views (linear colour, alpha = mask/coverage) with
 * NeRF-synthetic cameras (DESIGN.md: camera_angle_x + camera-to-world, OpenGL axes), plus
 * optional ground truth (per-view albedo / ORM / normals, GT mesh, training light, relighting
 * lights). Formats and what is read:
 *
 *  NeRF-Synthetic  <dir>/transforms_<split>.json: camera_angle_x, frames[].file_path (relative
 *                  to dir; ".png" is added when it has no extension), frames[].transform_matrix
 *                  (4x4 c2w). Images: 8/16-bit RGBA PNG, sRGB colour, alpha = mask. A split
 *                  whose json is missing (often "val") fails with MF_EIO ("...: no such file").
 *                  instant-ngp / nerfstudio captures use the same reader: one <dir>/transforms.json
 *                  (used when transforms_<split>.json is absent; split rule at DS_HOLDOUT_EVERY),
 *                  intrinsics fl_x, fl_y, cx, cy, w, h at the root or per frame (per frame wins;
 *                  fl_y defaults to fl_x, cx/cy to the centre, w/h to the image's size; they are
 *                  scaled to the loaded image size, so non-square pixels and moved principal
 *                  points are kept), camera_angle_x optional when fl_x is given. Lens distortion
 *                  (any non-zero k1..k4, p1, p2) and camera models other than a pinhole are
 *                  refused, naming the file and the key; aabb_scale is ignored with a note.
 *                  Frames without alpha (JPEG, RGB PNG) take their mask from --mask DIR
 *                  (DsLoadOptions.mask_dir) or the frame's mask_path; with neither, alpha = 1
 *                  and a warning names the first such file. Two frames with the same base name
 *                  are refused (their per-view outputs would overwrite each other).
 *  NeRFactor       <dir>/<split>_NNN/ folders (sorted by NNN), each with metadata.json
 *                  (cam_transform_mat: "a,b,..." 16 comma-separated numbers, row-major c2w,
 *                  as NeRFactor writes it; a JSON array of 16 or 4x4 numbers is accepted too;
 *                  cam_angle_x; imh; imw; envmap), rgba.png (16-bit, sRGB colour, alpha = mask),
 *                  and when present albedo.png (linear, as NeRFactor writes it), normal.png
 *                  (linear, n = 2 x - 1) and relit rgba_<probe>.png (sRGB).
 *  Stanford-ORB    <root>/blender_HDR/<capture>/ (or blender_LDR): transforms_{train,test,novel}.json,
 *                  <split>/NNNN.exr (linear HDR; .png in LDR, sRGB), <split>_mask/NNNN.png (alpha),
 *                  novel frames carry "scene_name" (the capture whose test folder holds the image)
 *                  and their own "camera_angle_x". Ground truth in <root>/ground_truth/<capture>/:
 *                  env_map/NNNN.exr per test view (a lat-long map in the CAMERA's frame: to
 *                  get the world light, rotate directions by the view's c2w rotation; see
 *                  ds_orb_env_to_world for the layout), mesh_blender/mesh.obj.
 *  bvault          NeRF-synthetic files plus gt/albedo/r_NNN.png (sRGB), gt/orm/r_NNN.png
 *                  (linear), gt/kd.png, gt/orm.png, gt/env.exr, mesh.obj, relight/<env>.exr and
 *                  relight/<env>/r_NNN.exr (DESIGN.md "Contracts"). Per-view GT falls back to the
 *                  albedo.* / orm.* layers of <split>/r_NNN.exr when the PNGs are absent (the
 *                  multi-layer EXR `mf render --png` writes beside each PNG).
 *
 * Errors name the file and the JSON path: "x/transforms_train.json: frames[2].transform_matrix:
 * missing", "...: expected 4x4 numbers", "x/train/r_3.png: no such file", a truncated PNG
 * ("cannot read image"), "x/train/r_2.png: image is 16x8, the split's first image is 8x8",
 * "x/gt/albedo/r_1.png: GT albedo is 8x8, the view image x/test/r_1.png is 16x16",
 * NaN in an EXR (named by the image reader). On failure *out is untouched.
 *
 * Loading: the JSON (parsed by scene/mf_transforms.h with MF_TF_CAPTURE, every frame of the
 * file, those of other splits too) or the metadata are read and every camera checked first
 * (serial), then images are decoded in parallel (OpenMP over views); failures and size
 * mismatches are reported for the first offending view in file order, so results and messages
 * do not depend on the thread count. DsLoadOptions.downsample box-filters by an integer factor (colour weighted by alpha)
 * and scales the cameras with the image (same camera_angle_x). */
#ifndef DS_LOAD_H
#define DS_LOAD_H

#include "core/mf_fs.h"
#include "io/mf_image.h"
#include "scene/mf_camera.h"

typedef enum {
    DS_FMT_UNKNOWN = 0,
    DS_FMT_NERF_SYNTHETIC,
    DS_FMT_NERFACTOR,
    DS_FMT_STANFORD_ORB,
    DS_FMT_BVAULT
} DsFormat;

#define DS_MAX_RELIGHT 16
#define DS_NAME_MAX 64

typedef struct {
    char name[DS_NAME_MAX];        /* frame id: "r_000", "train_003", "0007" */
    char image_path[MF_PATH_MAX];  /* the file the colour came from */
    MfCamera cam;
    double camera_angle_x;
    MfImage rgba;    /* owned; (h, w, 4) linear colour, alpha = mask */
    MfImage albedo;  /* owned; (h, w, 3) linear GT base colour, or empty (data NULL) */
    MfImage orm;     /* owned; (h, w, 3) linear GT ORM, or empty */
    MfImage normal;  /* owned; (h, w, 3) GT normals in [-1, 1] (NeRFactor), or empty */
    char env_path[MF_PATH_MAX];    /* per-view GT light (ORB camera-frame env map), or "" */
    char scene_name[DS_NAME_MAX];  /* ORB novel frames: capture holding the image, else "" */
} DsView;

typedef struct {
    DsFormat format;
    char dir[MF_PATH_MAX];    /* the scene folder */
    char split[16];
    int n;
    DsView *views;            /* owned; (n,) */
    int w, h;                 /* common image size */
    char mesh_path[MF_PATH_MAX]; /* GT mesh (world space) or "" */
    char env_path[MF_PATH_MAX];  /* training light (bvault gt/env.exr) or "" */
    char kd_path[MF_PATH_MAX];   /* GT UV textures (bvault) or "" */
    char orm_path[MF_PATH_MAX];
    int n_relight;                                   /* relighting lights found */
    char relight_name[DS_MAX_RELIGHT][DS_NAME_MAX];  /* env names (bvault) / probe names (NeRFactor) */
    char relight_env[DS_MAX_RELIGHT][MF_PATH_MAX];   /* env map file, or "" when not in the scene */
} DsViews;

typedef struct {
    int load_gt;     /* 1: read per-view GT (albedo, ORM, normals) when present */
    int max_views;   /* 0: all; else the first max_views frames */
    int downsample;  /* 1 (or 0): full size; k: box-filter by k (w, h divisible by k), fx scales */
    int ldr;         /* Stanford-ORB: 1 = blender_LDR (PNG), 0 = blender_HDR (EXR) */
    const char *mask_dir; /* borrowed; NULL or "": none. Else <mask_dir>/<frame name>.png (first channel,
                             linear; a relative mask_dir is inside the scene folder) replaces each
                             view's alpha (NeRF-Synthetic / bvault / instant-ngp layouts) */
    int quiet;       /* 1: no notes or warnings about the files (aabb_scale ignored, no alpha channel):
                        a command loading a scene again after a first load that said them */
} DsLoadOptions;

/* One transforms.json for all frames (instant-ngp / nerfstudio): test and val are the frames
 * 0, 8, 16, ... and train the others. */
#define DS_HOLDOUT_EVERY 8

const char *ds_format_name(DsFormat f);

/* Guesses the format of a scene folder: bvault (transforms_*.json and gt/ or relight/),
 * Stanford-ORB (transforms_*.json and a <split>_mask/ folder), NeRF-synthetic
 * (transforms_*.json), NeRFactor (train_000/metadata.json). */
DsFormat ds_detect_format(const char *dir);

/* Loads split of the scene in dir with the detected format (ORB: dir is the capture folder
 * blender_HDR/<capture>; ground truth is looked up in ../../ground_truth/<capture>). */
int ds_load(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out);

int ds_load_nerf_synthetic(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out);
int ds_load_nerfactor(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out);
/* root holds blender_HDR/, blender_LDR/ and ground_truth/; split: train, test or novel. */
int ds_load_stanford_orb(const char *root, const char *capture, const char *split, const DsLoadOptions *opt, DsViews *out);
int ds_load_bvault(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out);

void ds_views_free(DsViews *v);

/* Keeps only the views whose camera lies on one side of the object: dot(camera position - centre,
 * side) > 0 (side need not be unit), then at most max_views of them (0: all) in their order; the
 * others are freed. The few-view "one hemisphere" split: the far side of the object is seen by no
 * kept view. Fails (MF_EARG, naming the scene folder and the side) when no view is kept. */
int ds_views_keep_side(DsViews *v, MfVec3 centre, MfVec3 side, int max_views);
/* ds_load at a given image width: width 0 or the images' own width loads at full size; else the
 * images' width must be a multiple of width and their height of the factor, and they are
 * box-filtered by it (DsLoadOptions.downsample; opt's own downsample is ignored). A size that
 * does not divide gives MF_EARG naming both. */
int ds_load_width(const char *dir, const char *split, const DsLoadOptions *opt, int width, DsViews *out);
/* Multiplies every view's colour by its alpha (the premultiplied convention of the renderer's
 * output and of mf_recon's reference views). */
void ds_views_premultiply(DsViews *v);

/* Ground-truth relit image of view i under relighting light k into out (h, w, 4), linear:
 * bvault: relight/<env>/<name>.exr channels R, G, B, A looked up by name (colour as stored:
 * premultiplied by A, the EXR convention `mf render` follows); NeRFactor:
 * <view folder>/rgba_<probe>.png, sRGB decoded, straight alpha. */
int ds_load_relit(const DsViews *v, int i, int k, MfImage *out);
/* The file ds_load_relit reads for view i under light k, for messages. */
int ds_relit_path(const DsViews *v, int i, int k, char *out, size_t cap);

/* Stanford-ORB's ground-truth env maps are lat-long maps in each test view's CAMERA frame,
 * laid out as ORB's own orb/utils/env_map.py reads them: for a camera-frame direction
 * (x right, y up, z backwards) the row is acos(y) / pi * (H - 1) (camera up at the top) and the
 * column (atan2(x, -z) + pi) / (2 pi) * (W - 1) (the viewing direction -z in the centre column),
 * integer coordinates at pixel centres, wrapping in x. To get the world light, rotate
 * directions by the view's c2w rotation R: this writes world_env (same size) in DESIGN.md's
 * Blender mapping of the transforms' world frame, each texel of world direction d taking the
 * camera-map value at R^T d (bilinear). */
int ds_orb_env_to_world(const MfImage *cam_env, const MfMat4 *c2w, MfImage *world_env);

#endif
