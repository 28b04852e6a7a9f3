#include "inverse/mf_geom_fit.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "inverse/mf_optim.h"
#include "render/mf_antialias.h"
#include "render/mf_rtscene.h"

/* One view: coverage (h, w) from the G-buffer, antialiased; loss sum and dpos (nv, 3) +=
 * scale * d(sum of squared errors)/dpos. */
static int view_grad(const MfRtScene *rt, const MfCamera *cam, const MfImage *mask, int vi, double scale,
                     double *sse, float *dpos) {
    if (mask->w != cam->w || mask->h != cam->h || mask->c < 1)
        return mf_fail(MF_EARG, "geometry fit: view %d: mask is %dx%d, its camera %dx%d", vi, mask->w, mask->h, cam->w,
                       cam->h);
    MfAa *a;
    int rc = mf_aa_new(rt, cam, &a);
    if (rc) return rc;
    size_t np = (size_t)cam->w * cam->h;
    float *cov = malloc(np * sizeof *cov), *out = malloc(np * sizeof *out), *dout = malloc(np * sizeof *dout);
    if (!cov || !out || !dout) {
        rc = mf_fail(MF_ENOMEM, "geometry fit: out of memory for a %dx%d view", cam->w, cam->h);
        goto done;
    }
    const int *tri = mf_aa_tri(a);
    for (size_t i = 0; i < np; ++i) cov[i] = tri[i] >= 0 ? 1.0f : 0.0f;
    mf_aa_forward(a, cov, 1, out);
    double s = 0;
    for (size_t i = 0; i < np; ++i) {
        double d = (double)out[i] - (double)mask->data[i * (size_t)mask->c + (size_t)(mask->c - 1)];
        s += d * d;
        dout[i] = (float)(2.0 * d * scale);
    }
    *sse += s;
    mf_aa_backward(a, cov, 1, dout, NULL, dpos);
done:
    free(cov);
    free(out);
    free(dout);
    mf_aa_free(a);
    return rc;
}

int mf_geom_mask_grad(const MfTetGrid *g, const float *sdf, const float *deform, const MfCamera *cams,
                      const MfImage *masks, const int *views, int nviews, float *dsdf, float *ddeform, double *loss,
                      int *nt) {
    if (nviews < 1) return mf_fail(MF_EARG, "geometry fit: no views");
    MfTetMesh tm;
    int rc = mf_tetgrid_extract(g, sdf, deform, &tm);
    if (rc) return rc;
    MfRtScene *rt = NULL;
    float *dpos = calloc((size_t)tm.mesh.nv * 3, sizeof *dpos);
    if (!dpos) {
        rc = mf_fail(MF_ENOMEM, "geometry fit: out of memory for %d vertices", tm.mesh.nv);
        goto done;
    }
    if ((rc = mf_rtscene_new(&tm.mesh, &rt))) goto done;
    size_t npix = 0;
    for (int k = 0; k < nviews; ++k) npix += (size_t)cams[views[k]].w * cams[views[k]].h;
    double sse = 0, scale = 1.0 / (double)npix;
    for (int k = 0; k < nviews && !rc; ++k) rc = view_grad(rt, &cams[views[k]], &masks[views[k]], views[k], scale, &sse, dpos);
    if (rc) goto done;
    for (size_t i = 0; i < (size_t)tm.mesh.nv * 3; ++i)
        if (!isfinite(dpos[i])) {
            rc = mf_fail(MF_ENAN, "geometry fit: non-finite vertex gradient at vertex %zu", i / 3);
            goto done;
        }
    mf_tetgrid_backward(g, sdf, deform, &tm, dpos, dsdf, deform ? ddeform : NULL);
    *loss = sse * scale;
    if (nt) *nt = tm.mesh.nt;
done:
    mf_rtscene_free(rt);
    free(dpos);
    mf_tetmesh_free(&tm);
    return rc;
}

static double sigmoid(double x) { return 1.0 / (1.0 + exp(-x)); }
/* BCE with logits: -(y log s(x) + (1 - y) log(1 - s(x))), stable form */
static double bce_logits(double x, double y) { return fmax(x, 0.0) - x * y + log1p(exp(-fabs(x))); }

double mf_geom_sdf_reg(const MfTetGrid *g, const float *sdf, float weight, float *dsdf) {
    const int r1 = g->res + 1;
    size_t count = 0;
    double sum = 0;
    /* two passes: count the sign-change edges, then the mean and its gradient */
    for (int pass = 0; pass < 2; ++pass) {
        double w = pass ? (double)weight / (double)count : 0;
        for (int k = 0; k < r1; ++k)
            for (int j = 0; j < r1; ++j)
                for (int i = 0; i < r1; ++i) {
                    size_t a = (size_t)i + (size_t)r1 * ((size_t)j + (size_t)r1 * (size_t)k);
                    for (int e = 1; e < 8; ++e) {
                        int di = e & 1, dj = (e >> 1) & 1, dk = (e >> 2) & 1;
                        if (i + di >= r1 || j + dj >= r1 || k + dk >= r1) continue;
                        size_t b = a + (size_t)di + (size_t)r1 * ((size_t)dj + (size_t)r1 * (size_t)dk);
                        int pa = sdf[a] > 0, pb = sdf[b] > 0;
                        if (pa == pb) continue;
                        if (!pass) {
                            ++count;
                            continue;
                        }
                        sum += bce_logits(sdf[a], pb) + bce_logits(sdf[b], pa);
                        if (dsdf) {
                            dsdf[a] += (float)(w * (sigmoid(sdf[a]) - pb));
                            dsdf[b] += (float)(w * (sigmoid(sdf[b]) - pa));
                        }
                    }
                }
        if (!count) return 0;
    }
    return (double)weight * sum / (double)count;
}

int mf_geom_fit(const MfTetGrid *g, float *sdf, float *deform, const MfCamera *cams, const MfImage *masks, int n,
                const MfGeomFitOpts *opt, MfGeomFitStep *log, int *done) {
    if (done) *done = 0;
    if (n < 1 || opt->iters < 1 || !(opt->lr_sdf > 0) || !(opt->lr_deform >= 0) || !(opt->sdf_reg >= 0))
        return mf_fail(MF_EARG, "geometry fit: need views (%d), iters >= 1 (%d), lr_sdf > 0 (%g), lr_deform >= 0 (%g), "
                                "sdf_reg >= 0 (%g)", n, opt->iters, (double)opt->lr_sdf, (double)opt->lr_deform,
                       (double)opt->sdf_reg);
    size_t nv = mf_tetgrid_nverts(g);
    int use_def = deform && opt->lr_deform > 0;
    int nb = use_def ? 2 : 1;
    int bsize = opt->views_per_step > 0 && opt->views_per_step < n ? opt->views_per_step : n;
    MfParamBlock b[2];
    memset(b, 0, sizeof b);
    int *views = malloc((size_t)bsize * sizeof *views);
    int rc = views ? mf_param_init(&b[0], "sdf", nv, 1, sdf) : mf_fail(MF_ENOMEM, "geometry fit: out of memory");
    if (!rc && use_def) {
        rc = mf_param_init(&b[1], "deform", nv * 3, 3, deform);
        b[1].lr_scale = opt->lr_deform / opt->lr_sdf;
    }
    MfAdam adam;
    mf_adam_init(&adam, opt->lr_sdf);
    int it = 0;
    for (; !rc && it < opt->iters; ++it) {
        for (int k = 0; k < bsize; ++k) views[k] = (int)(((long)it * bsize + k) % n);
        for (int k = 0; k < nb; ++k) mf_param_zero_grad(&b[k]);
        double lm = 0;
        int nt = 0;
        /* deform is passed even when frozen, so the surface is the deformed grid's */
        rc = mf_geom_mask_grad(g, b[0].p, use_def ? b[1].p : deform, cams, masks, views, bsize, b[0].g,
                               use_def ? b[1].g : NULL, &lm, &nt);
        if (rc) break;
        double lr = opt->sdf_reg > 0 ? mf_geom_sdf_reg(g, b[0].p, opt->sdf_reg, b[0].g) : 0;
        if (log) log[it] = (MfGeomFitStep){.mask = lm, .reg = lr, .nt = nt};
        rc = mf_adam_step(&adam, b, nb, mf_lr_schedule(opt->lr_sdf, it));
    }
    if (rc) rc = mf_fail_prefix(rc, "geometry fit: step %d", it);
    if (b[0].p) memcpy(sdf, b[0].p, nv * sizeof *sdf);
    if (use_def && b[1].p) memcpy(deform, b[1].p, nv * 3 * sizeof *deform);
    if (done) *done = it;
    for (int k = 0; k < 2; ++k) mf_param_free(&b[k]);
    free(views);
    return rc;
}
