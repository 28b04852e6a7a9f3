/* ev_prior2d: the prior's 2D evaluation table (MaterialFusion's Table 3, `mf eval-prior`) on a
 * test-2d split (read through datasets/ds_prior2d.h: DIR/{rgb,albedo,orm}/NNNNNN.png, RGBA 8-bit,
 * rgb and albedo sRGB, orm linear, alpha = coverage; DIR/manifest.json "count" and
 * "views_per_object", the views of an object consecutive).
 *
 * Methods (fixed order, ev_prior2d_methods): StableMaterial (each view alone), StableMaterialMV
 * (the views of an object jointly), Input image, Retinex (albedo only), Train-mean ORM (ORM
 * only). The predictions are made by the caller (mf/prior, baselines/bl_prior2d.h); this module
 * reads the split, scores and writes. Scores follow the evaluation layer's protocol: albedo
 * aligned per channel in linear space by the ratio of means inside the GT mask
 * (ev_protocol_prepare, EV_ALIGN_MEAN), then sRGB, PSNR / SSIM / L1 inside the mask; ORM on
 * roughness and metallic (ev_protocol_prepare_orm), PSNR / L1 inside the mask, and each channel's
 * mean squared error inside the mask (rough_mse, metal_mse; not in the table, used for the trust
 * below). Records go to an
 * EvTable under data set "test-2d", scene = the sample number "NNNNNN".
 *
 * The same table on the objects of a 3D split (ev_prior2d_load_scenes): each scene folder is one
 * object, its first views of the test split (held-out views under the training light, with their
 * per-view GT albedo and ORM) box-filtered to the prior's resolution; records under the split
 * folder's base name, scene = "<scene>/<view>". This measures the prior's own accuracy on the
 * objects a reconstruction is run on. */
#ifndef EV_PRIOR2D_H
#define EV_PRIOR2D_H

#include "eval/ev_table.h"
#include "io/mf_image.h"

enum { EV_P2_SM, EV_P2_MV, EV_P2_INPUT, EV_P2_RETINEX, EV_P2_MEAN_ORM, EV_PRIOR2D_NM };
extern const char *const ev_prior2d_methods[EV_PRIOR2D_NM];
/* The table's metrics: albedo_psnr, albedo_ssim, albedo_l1, orm_psnr, orm_l1. */
#define EV_PRIOR2D_NK 5
extern const char *const ev_prior2d_metrics[EV_PRIOR2D_NK];

typedef struct {
    int n, V, R;                            /* samples (whole objects), views per object, image size */
    MfImage *rgb_raw, *rgb, *albedo, *orm;  /* owned; (n,) each, RGBA (R, R, 4): raw codes / linear / linear / linear */
    char dataset[EV_NAME_MAX];              /* the records' data set: "test-2d", or a 3D split's folder name */
    EvName *names;                          /* owned; (n,) "<scene>/<view>" (3D split), NULL: "NNNNNN" */
} EvPrior2dSplit;

/* Reads the first max_objects objects (0: all) of a split; every image must be R x R. */
int ev_prior2d_load(const char *dir, int max_objects, EvPrior2dSplit *s);
/* Reads the first max_objects scene folders (0: all) of the 3D split dir (any format ds_load
 * reads), V = views test views each at R x R (the images' width a multiple of R); rgb_raw is
 * the view's straight-alpha colour sRGB-encoded, as SDS gives the prior its views. A scene with
 * fewer than V test views, or a view without GT albedo and ORM, is refused by name. */
int ev_prior2d_load_scenes(const char *dir, int R, int views, int max_objects, EvPrior2dSplit *s);
void ev_prior2d_free(EvPrior2dSplit *s);

/* Predictions per method: albedo[m], orm[m] owned, (n,) each, NULL where method m predicts no
 * such map (or was not run). */
typedef struct {
    int n;
    MfImage *albedo[EV_PRIOR2D_NM], *orm[EV_PRIOR2D_NM];
} EvPrior2dPreds;

/* Allocates empty images for every method's maps (the multi-view method's only when mv). */
int ev_prior2d_preds_alloc(EvPrior2dPreds *p, int n, int mv);
void ev_prior2d_preds_free(EvPrior2dPreds *p);

/* Scores every prediction against the split's ground truth into t (view by view, methods in order). */
int ev_prior2d_score(const EvPrior2dSplit *s, const EvPrior2dPreds *p, EvTable *t);

/* The prior's measured reliability per ORM channel, for SDS's channel trust (--sds-trust-rough,
 * --sds-trust-metal): trust[k] = 1 - MSE(method m) / MSE(Train-mean ORM), the fraction of the
 * constant predictor's squared error that method m removes, over all views (means of the per-view
 * rough_mse / metal_mse records), clamped to [0, 1]; 0 when either method has no record. k: 0
 * roughness, 1 metallic. */
void ev_prior2d_trust(const EvTable *t, const char *dataset, int m, double trust[2]);

/* The settings the table's caption and table2d.json state. */
typedef struct {
    const char *test_dir;
    const char *weights; /* the prior's weights file as resolved */
    int samples, steps, seed;
    float guidance, retinex_sigma, train_roughness, train_metallic;
    double sm_wall_s, mv_wall_s; /* wall seconds of the two prior methods */
    double trust[2];             /* ev_prior2d_trust of StableMaterial: roughness, metallic */
} EvPrior2dInfo;

/* Writes OUT/table2d.md (paper layout), table2d.csv (every record), table2d.json (settings,
 * timings and StableMaterial's channel trust) and examples2d.png (rows: the first views, up to 4; columns: input, GT albedo, SM, MV,
 * Retinex, GT ORM, SM ORM, MV ORM; a failure to write the picture is only logged). A 3D split adds
 * objects.csv (every method's per-object means over its views, scene = the scene folder) and
 * objects.md (the table over objects: the CI is over objects, not views). */
int ev_prior2d_write(const char *out, const EvTable *t, const EvPrior2dSplit *s, const EvPrior2dPreds *p,
                     const EvPrior2dInfo *info);

#endif
