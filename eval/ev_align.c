/* ev_align: scale alignment and the protocol's conversion to display values. See ev_align.h. */
#include "eval/ev_align.h"

#include <math.h>
#include <string.h>

#include "core/mf_error.h"
#include "eval/ev_metrics.h"

int ev_align_parse(const char *s, EvAlign *out) {
    if (s && !strcmp(s, "none")) *out = EV_ALIGN_NONE;
    else if (s && !strcmp(s, "mean")) *out = EV_ALIGN_MEAN;
    else if (s && !strcmp(s, "lsq")) *out = EV_ALIGN_LSQ;
    else return mf_fail(MF_EARG, "--align: '%s' is not one of none, mean, lsq", s ? s : "(null)");
    return MF_OK;
}

const char *ev_align_name(EvAlign mode) {
    switch (mode) {
    case EV_ALIGN_NONE: return "none";
    case EV_ALIGN_MEAN: return "mean";
    case EV_ALIGN_LSQ: return "lsq";
    }
    return "?";
}

int ev_color_channels(int c) { return c == 4 ? 3 : (c == 2 ? 1 : c); }

static int check_inputs(const MfImage *pred, const MfImage *gt, const MfImage *mask) {
    int rc;
    if ((rc = ev_check_finite(pred, "prediction")) || (rc = ev_check_finite(gt, "ground truth"))) return rc;
    if (pred->c < 1 || pred->c > 4 || gt->c < 1 || gt->c > 4)
        return mf_fail(MF_EARG, "prediction has %d and ground truth %d channels; 1 to 4 can be scored (pick one layer)",
                       pred->c, gt->c);
    if (pred->w != gt->w || pred->h != gt->h || pred->c != gt->c)
        return mf_fail(MF_EARG, "prediction is %dx%dx%d but ground truth is %dx%dx%d", pred->w, pred->h, pred->c,
                       gt->w, gt->h, gt->c);
    if (mask) {
        if ((rc = ev_check_finite(mask, "mask"))) return rc;
        if (mask->w != gt->w || mask->h != gt->h)
            return mf_fail(MF_EARG, "mask is %dx%d but ground truth is %dx%d", mask->w, mask->h, gt->w, gt->h);
    }
    return MF_OK;
}

int ev_align_scales(const MfImage *pred, const MfImage *gt, const MfImage *mask, EvAlign mode, float *scale,
                    unsigned *degenerate) {
    int rc = check_inputs(pred, gt, mask);
    if (rc) return rc;
    if (mode != EV_ALIGN_NONE && mode != EV_ALIGN_MEAN && mode != EV_ALIGN_LSQ)
        return mf_fail(MF_EARG, "alignment mode %d unknown", (int)mode);
    int cc = ev_color_channels(pred->c);
    double num[4] = {0}, den[4] = {0};
    size_t inside = 0;
    for (int y = 0; y < gt->h; y++)
        for (int x = 0; x < gt->w; x++) {
            if (mask && !ev_mask_inside(mask, x, y)) continue;
            inside++;
            const float *p = mf_image_px(pred, x, y), *g = mf_image_px(gt, x, y);
            for (int k = 0; k < cc; k++) {
                if (mode == EV_ALIGN_LSQ) {
                    num[k] += (double)g[k] * p[k];
                    den[k] += (double)p[k] * p[k];
                } else {
                    num[k] += g[k];
                    den[k] += p[k];
                }
            }
        }
    if (inside == 0) return mf_fail(MF_EARG, "mask is empty (no pixel with coverage > 0.5)");
    unsigned flags = 0;
    float s[4];
    for (int k = 0; k < cc; k++) {
        s[k] = 1.0f;
        if (mode == EV_ALIGN_NONE) continue;
        double v = den[k] != 0.0 ? num[k] / den[k] : NAN;
        if (isfinite(v) && v >= 0.0 && isfinite((float)v)) s[k] = (float)v;
        else flags |= 1u << k;
    }
    memcpy(scale, s, sizeof(float) * (size_t)cc);
    if (degenerate) *degenerate = flags;
    return MF_OK;
}

int ev_protocol_prepare(const MfImage *pred_lin, const MfImage *gt_lin, const MfImage *mask, EvAlign mode,
                        MfImage *pred_out, MfImage *gt_out, float *scale, unsigned *degenerate) {
    float s[4];
    unsigned flags = 0;
    int rc = ev_align_scales(pred_lin, gt_lin, mask, mode, s, &flags);
    if (rc) return rc;
    int c = pred_lin->c, cc = ev_color_channels(c), w = gt_lin->w, h = gt_lin->h;
    MfImage po = {0}, go = {0};
    if ((rc = mf_image_alloc(&po, w, h, cc)) || (rc = mf_image_alloc(&go, w, h, cc))) {
        mf_image_free(&po);
        return rc;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float m = 1.0f;
            if (mask) {
                m = ev_mask_coverage(mask, x, y);
                m = m < 0.0f ? 0.0f : (m > 1.0f ? 1.0f : m);
            }
            const float *p = mf_image_px(pred_lin, x, y), *g = mf_image_px(gt_lin, x, y);
            float *pd = mf_image_px(&po, x, y), *gd = mf_image_px(&go, x, y);
            for (int k = 0; k < cc; k++) {
                float pv = mf_linear_to_srgb(s[k] * p[k]), gv = mf_linear_to_srgb(g[k]);
                pv = pv < 0.0f ? 0.0f : (pv > 1.0f ? 1.0f : pv);
                gv = gv < 0.0f ? 0.0f : (gv > 1.0f ? 1.0f : gv);
                pd[k] = pv * m;
                gd[k] = gv * m;
            }
        }
    if ((rc = ev_check_finite(&po, "aligned prediction")) || (rc = ev_check_finite(&go, "converted ground truth"))) {
        mf_image_free(&po);
        mf_image_free(&go);
        return rc;
    }
    *pred_out = po;
    *gt_out = go;
    if (scale) memcpy(scale, s, sizeof(float) * (size_t)cc);
    if (degenerate) *degenerate = flags;
    return MF_OK;
}

int ev_protocol_prepare_orm(const MfImage *pred_orm, const MfImage *gt_orm, const MfImage *mask, MfImage *pred_out,
                            MfImage *gt_out) {
    int rc = check_inputs(pred_orm, gt_orm, mask);
    if (rc) return rc;
    if (gt_orm->c < 3) return mf_fail(MF_EARG, "ORM images need 3 or 4 channels, got %d", gt_orm->c);
    int w = gt_orm->w, h = gt_orm->h;
    if (mask) {
        size_t inside = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) inside += ev_mask_inside(mask, x, y);
        if (inside == 0) return mf_fail(MF_EARG, "mask is empty (no pixel with coverage > 0.5)");
    }
    MfImage po = {0}, go = {0};
    if ((rc = mf_image_alloc(&po, w, h, 2)) || (rc = mf_image_alloc(&go, w, h, 2))) {
        mf_image_free(&po);
        return rc;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float m = 1.0f;
            if (mask) {
                m = ev_mask_coverage(mask, x, y);
                m = m < 0.0f ? 0.0f : (m > 1.0f ? 1.0f : m);
            }
            const float *p = mf_image_px(pred_orm, x, y), *g = mf_image_px(gt_orm, x, y);
            float *pd = mf_image_px(&po, x, y), *gd = mf_image_px(&go, x, y);
            for (int k = 0; k < 2; k++) {
                float pv = p[k + 1], gv = g[k + 1];
                pd[k] = (pv < 0.0f ? 0.0f : (pv > 1.0f ? 1.0f : pv)) * m;
                gd[k] = (gv < 0.0f ? 0.0f : (gv > 1.0f ? 1.0f : gv)) * m;
            }
        }
    *pred_out = po;
    *gt_out = go;
    return MF_OK;
}
