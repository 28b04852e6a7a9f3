/* mf metrics: the evaluation protocol on one image pair (eval/ev_align.h, eval/ev_metrics.h). */
#include <stdio.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "eval/ev_align.h"
#include "eval/ev_image.h"
#include "eval/ev_metrics.h"
#include "io/mf_image.h"

typedef struct {
    const char *mask, *align, *layer;
    int linear, orm;
} MetricsArgs;

#define A MetricsArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, mask, NULL, "mask image (linear; coverage = alpha of a 2/4-channel file, else channel 0); the word "
               "'alpha' uses GT's alpha channel", .meta = "M|alpha", .unset = "none"),
    MF_OPT_STR(A, align, NULL, "per-channel scale alignment", .choices = "none|mean|lsq", .unset = "mean"),
    MF_OPT_BOOL(A, linear, 0, "PNG/JPEG inputs hold linear values (default: sRGB colour); EXR/HDR are linear"),
    MF_OPT_BOOL(A, orm, 0, "ORM images (linear, glTF order): roughness G and metallic B only, no alignment, no sRGB "
                "curve (clip, composite); prints psnr, ssim, l1 (no flip)"),
    MF_OPT_STR(A, layer, NULL, "EXR layer of PRED and GT to score (e.g. albedo, orm, diffuse, specular of a file written by "
               "mf render; multi-layer EXR files are read one layer at a time)", .meta = "NAME",
               .unset = "the R, G, B[, A] layer"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[8192];
__attribute__((constructor)) static void metrics_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf metrics PRED GT [--mask M|alpha] [--align none|mean|lsq] [--linear] [--orm] [--layer NAME]\n"
                       "\n"
                       "Scores the prediction PRED against the ground truth GT with the evaluation protocol:\n"
                       "per-channel scale alignment in linear space inside the mask (mean: ratio of means;\n"
                       "lsq: least squares; none), then linear -> sRGB, clip to [0,1], composite on black with the\n"
                       "mask; then PSNR (dB, data range 1, capped at 100), SSIM (scikit-image settings of Wang et al.),\n"
                       "L1 and LDR-FLIP (67.02 pixels per degree). Prints one 'name value' line per metric:\n"
                       "psnr, ssim, l1, flip, and with a mask also psnr_masked, ssim_masked, l1_masked, flip_masked\n"
                       "(averages over mask pixels with coverage > 0.5).\n",
                       t, 1,
                       "Alpha channels of PRED and GT are dropped before scoring. Exit code 1 on bad images (sizes\n"
                       "differ, NaN pixels, empty mask), 2 on bad usage.\n");
}

/* Copies the colour channels (alpha dropped) of src into dst. */
static int color_only(const MfImage *src, MfImage *dst) {
    int cc = ev_color_channels(src->c);
    int rc = mf_image_alloc(dst, src->w, src->h, cc);
    if (rc) return rc;
    size_t n = (size_t)src->w * src->h;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < cc; k++) dst->data[i * cc + k] = src->data[i * src->c + k];
    return MF_OK;
}

static int metrics_run(const MetricsArgs *a, const char *pred_path, const char *gt_path, EvAlign mode);

static int cmd_metrics(int argc, char **argv) {
    MetricsArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_cli_parse(&bind, 1, argc, argv, 2, &p);
    if (rc >= 0) return rc;
    EvAlign mode = EV_ALIGN_MEAN;
    if (p.npos != 2) rc = MF_EXIT_USAGE, mf_fail(MF_EARG, "expected PRED GT (see mf metrics --help)");
    else if (a.align && ev_align_parse(a.align, &mode)) rc = MF_EXIT_USAGE;
    else if (a.orm && a.align) rc = MF_EXIT_USAGE, mf_fail(MF_EARG, "--orm scores ORM without alignment; drop --align");
    else rc = metrics_run(&a, p.pos[0], p.pos[1], mode);
    mf_opts_parse_free(&p);
    return rc;
}

static int metrics_run(const MetricsArgs *a, const char *pred_path, const char *gt_path, EvAlign mode) {
    const char *mask_path = a->mask, *layer = a->layer ? a->layer : "";
    int linear = a->linear, orm = a->orm;
    MfEncoding enc = (linear || orm) ? MF_ENC_LINEAR : MF_ENC_SRGB;

    MfImage pred = {0}, gt = {0}, mask = {0}, pc = {0}, gc = {0}, po = {0}, go = {0};
    const MfImage *maskp = NULL;
    int ret = MF_EXIT_FAIL, rc;
    if (ev_image_read(pred_path, layer, enc, &pred) || ev_image_read(gt_path, layer, enc, &gt)) goto done;
    if (pred.w != gt.w || pred.h != gt.h) {
        mf_fail(MF_EARG, "%s is %dx%d but %s is %dx%d: sizes differ", pred_path, pred.w, pred.h, gt_path, gt.w,
                gt.h);
        goto done;
    }
    if (ev_color_channels(pred.c) != ev_color_channels(gt.c)) {
        mf_fail(MF_EARG, "%s has %d colour channels but %s has %d", pred_path, ev_color_channels(pred.c), gt_path,
                ev_color_channels(gt.c));
        goto done;
    }
    if (mask_path && !strcmp(mask_path, "alpha")) {
        if (gt.c != 2 && gt.c != 4) {
            mf_fail(MF_EARG, "%s: --mask alpha but the image has no alpha channel (%d channels)", gt_path, gt.c);
            goto done;
        }
        maskp = &gt; /* coverage = GT's alpha */
        mask_path = gt_path;
    } else if (mask_path) {
        if (ev_image_read(mask_path, "", MF_ENC_LINEAR, &mask)) goto done;
        if (mask.w != gt.w || mask.h != gt.h) {
            mf_fail(MF_EARG, "mask %s is %dx%d but %s is %dx%d: sizes differ", mask_path, mask.w, mask.h, gt_path,
                    gt.w, gt.h);
            goto done;
        }
        maskp = &mask;
    }
    float scale[4] = {1, 1, 1, 1};
    unsigned degenerate = 0;
    if (orm) {
        if ((rc = ev_protocol_prepare_orm(&pred, &gt, maskp, &po, &go))) {
            mf_fail_prefix(rc, "%s vs %s%s%s", pred_path, gt_path, maskp ? " with mask " : "", maskp ? mask_path : "");
            goto done;
        }
    } else if (color_only(&pred, &pc) || color_only(&gt, &gc)) {
        goto done;
    } else if ((rc = ev_protocol_prepare(&pc, &gc, maskp, mode, &po, &go, scale, &degenerate))) {
        mf_fail_prefix(rc, "%s vs %s%s%s", pred_path, gt_path, maskp ? " with mask " : "", maskp ? mask_path : "");
        goto done;
    }
    if (degenerate)
        mf_log_warn("mf metrics: %s: channel(s) with zero prediction inside the mask kept scale 1 (flags 0x%x)",
                    pred_path, degenerate);
    mf_log_debug("mf metrics: align %s scales %g %g %g", ev_align_name(mode), scale[0], scale[1], scale[2]);
    EvMetrics m;
    /* FLIP needs 1 or 3 channels: ev_color_channels gives that for colour files; ORM (2) has none. */
    if ((rc = ev_metrics_compute(&po, &go, maskp, &m))) {
        mf_fail_prefix(rc, "%s vs %s", pred_path, gt_path);
        goto done;
    }
    printf("psnr %.6f\nssim %.6f\nl1 %.6f\n", m.psnr, m.ssim, m.l1);
    if (m.has_flip) printf("flip %.6f\n", m.flip);
    if (m.has_mask) {
        printf("psnr_masked %.6f\nssim_masked %.6f\nl1_masked %.6f\n", m.psnr_masked, m.ssim_masked, m.l1_masked);
        if (m.has_flip) printf("flip_masked %.6f\n", m.flip_masked);
    }
    ret = MF_EXIT_OK;
done:
    mf_image_free(&pred);
    mf_image_free(&gt);
    mf_image_free(&mask);
    mf_image_free(&pc);
    mf_image_free(&gc);
    mf_image_free(&po);
    mf_image_free(&go);
    return ret;
}

MF_COMMAND(metrics, "metrics", "scale-aligned PSNR/SSIM/L1/FLIP of a prediction against ground truth", usage,
           cmd_metrics)
