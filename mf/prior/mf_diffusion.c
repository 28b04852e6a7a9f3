/* mf_diffusion: see mf_diffusion.h. */
#include "prior/mf_diffusion.h"

#include <math.h>

#include "core/mf_error.h"

void mf_diffusion_init(MfDiffusion *d) {
    double a = sqrt(MF_DIFF_BETA_START), b = sqrt(MF_DIFF_BETA_END), ab = 1.0;
    for (int t = 0; t < MF_DIFF_T; ++t) {
        double s = a + (b - a) * (double)t / (double)(MF_DIFF_T - 1);
        d->beta[t] = s * s;
        ab *= 1.0 - d->beta[t];
        d->alpha_bar[t] = ab;
    }
}

void mf_diffusion_q_sample(const MfDiffusion *d, float *xt, const float *x0, const float *eps, int t, size_t n) {
    double sa = sqrt(d->alpha_bar[t]), sb = sqrt(1.0 - d->alpha_bar[t]);
    for (size_t i = 0; i < n; ++i) xt[i] = (float)(sa * x0[i] + sb * eps[i]);
}

void mf_diffusion_v_target(const MfDiffusion *d, float *v, const float *x0, const float *eps, int t, size_t n) {
    double sa = sqrt(d->alpha_bar[t]), sb = sqrt(1.0 - d->alpha_bar[t]);
    for (size_t i = 0; i < n; ++i) v[i] = (float)(sa * eps[i] - sb * x0[i]);
}

void mf_diffusion_from_v(const MfDiffusion *d, float *x0, float *eps, const float *xt, const float *v, int t,
                         size_t n) {
    double sa = sqrt(d->alpha_bar[t]), sb = sqrt(1.0 - d->alpha_bar[t]);
    for (size_t i = 0; i < n; ++i) {
        double x = xt[i], vv = v[i];
        if (x0) x0[i] = (float)(sa * x - sb * vv);
        if (eps) eps[i] = (float)(sb * x + sa * vv);
    }
}

void mf_diffusion_ddim_step(const MfDiffusion *d, float *x, const float *v, int t, int t_prev, size_t n) {
    double sa = sqrt(d->alpha_bar[t]), sb = sqrt(1.0 - d->alpha_bar[t]);
    double ap = t_prev >= 0 ? d->alpha_bar[t_prev] : 1.0, pa = sqrt(ap), pb = sqrt(1.0 - ap);
    for (size_t i = 0; i < n; ++i) {
        double xx = x[i], vv = v[i];
        double x0 = sa * xx - sb * vv, eps = sb * xx + sa * vv;
        x[i] = (float)(pa * x0 + pb * eps);
    }
}

void mf_diffusion_cfg(float *out, const float *v_uncond, const float *v_cond, float scale, size_t n) {
    for (size_t i = 0; i < n; ++i) out[i] = v_uncond[i] + scale * (v_cond[i] - v_uncond[i]);
}

int mf_diffusion_ddim(const MfDiffusion *d, float *x, float *v, size_t n, const int *steps, int nsteps,
                      MfVPredFn fn, void *ctx) {
    for (int k = 0; k < nsteps; ++k) {
        int t = steps[k];
        if (t < 0 || t >= MF_DIFF_T || (k > 0 && t >= steps[k - 1]))
            return mf_fail(MF_EARG, "DDIM: step list must descend within 0..%d (step %d is %d)", MF_DIFF_T - 1, k, t);
        int rc = fn(ctx, v, x, t);
        if (rc) return rc;
        mf_diffusion_ddim_step(d, x, v, t, k + 1 < nsteps ? steps[k + 1] : -1, n);
    }
    return MF_OK;
}

void mf_diffusion_inference_steps(int *steps, int nsteps) {
    int stride = MF_DIFF_T / nsteps;
    for (int i = 0; i < nsteps; ++i) {
        int t = (nsteps - 1 - i) * stride + 1;
        steps[i] = t < MF_DIFF_T ? t : MF_DIFF_T - 1;
    }
}
