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

static const char usage[] =
    "usage: mf metrics PRED GT [--mask M|alpha] [--align none|mean|lsq] [--linear] [--orm] [--layer NAME]\n"
    "\n"
    "Scores the prediction PRED against the ground truth GT with the evaluation protocol:\n"
    "per-channel scale alignment in linear space inside the mask (default mean: ratio of means;\n"
    "lsq: least squares; none), then linear -> sRGB, clip to [0,1], composite on black with the\n"
    "mask; then PSNR (dB, data range 1, capped at 100), SSIM (scikit-image settings of Wang et al.),\n"
    "L1 and LDR-FLIP (67.02 pixels per degree). Prints one 'name value' line per metric:\n"
    "psnr, ssim, l1, flip, and with a mask also psnr_masked, ssim_masked, l1_masked, flip_masked\n"
    "(averages over mask pixels with coverage > 0.5).\n"
    "\n"
    "  --mask M      mask image (linear; coverage = alpha of a 2/4-channel file, else channel 0);\n"
    "                the word 'alpha' uses GT's alpha channel\n"
    "  --align MODE  none | mean | lsq (default mean)\n"
    "  --linear      PNG/JPEG inputs hold linear values (default: sRGB colour). EXR/HDR are linear.\n"
    "  --orm         ORM images (linear, glTF order): scores roughness G and metallic B only, no\n"
    "                alignment, no sRGB curve (clip, composite); prints psnr, ssim, l1 (no flip)\n"
    "  --layer NAME  EXR layer of PRED and GT to score (default: the R, G, B[, A] layer; e.g. albedo,\n"
    "                orm, diffuse, specular of a file written by mf render). Multi-layer EXR files\n"
    "                are read one layer at a time; other formats have no layers.\n"
    "Alpha channels of PRED and GT are dropped before scoring. Exit code 1 on bad images (sizes\n"
    "differ, NaN pixels, empty mask), 2 on bad usage.\n";

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

static int cmd_metrics(int argc, char **argv) {
    const char *pos[2] = {NULL, NULL}, *mask_path = NULL, *align_s = "mean", *layer = "";
    int npos = 0, linear = 0, orm = 0, align_given = 0;
    for (int i = 1; i < argc; i++) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "--mask", &mask_path)) != 0) {
            if (r < 0) return MF_EXIT_USAGE;
        } else if ((r = mf_opt_str(argc, argv, &i, "--align", &align_s)) != 0) {
            if (r < 0) return MF_EXIT_USAGE;
            align_given = 1;
        } else if ((r = mf_opt_str(argc, argv, &i, "--layer", &layer)) != 0) {
            if (r < 0) return MF_EXIT_USAGE;
        } else if (!strcmp(argv[i], "--orm")) {
            orm = 1;
        } else if (!strcmp(argv[i], "--linear")) {
            linear = 1;
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            mf_fail(MF_EARG, "unknown option '%s' (see mf metrics --help)", argv[i]);
            return MF_EXIT_USAGE;
        } else if (npos < 2) {
            pos[npos++] = argv[i];
        } else {
            mf_fail(MF_EARG, "too many arguments ('%s'); expected PRED GT", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (npos != 2) {
        mf_fail(MF_EARG, "expected PRED GT (see mf metrics --help)");
        return MF_EXIT_USAGE;
    }
    EvAlign mode;
    if (ev_align_parse(align_s, &mode)) return MF_EXIT_USAGE;
    if (orm && align_given) {
        mf_fail(MF_EARG, "--orm scores ORM without alignment; drop --align");
        return MF_EXIT_USAGE;
    }
    const char *pred_path = pos[0], *gt_path = pos[1];
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
