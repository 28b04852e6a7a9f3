/* mf_diffusion: the prior's diffusion math (Stable Diffusion 2.1's scheduler, v-prediction).
 *
 * Schedule: T = 1000 steps, "scaled linear" betas beta_t = (linspace(sqrt(0.00085), sqrt(0.012),
 * T)_t)^2, alpha_bar_t = prod_{s<=t} (1 - beta_s) (t = 0 .. T-1, computed in double).
 * Forward process: x_t = sqrt(ab_t) x0 + sqrt(1 - ab_t) eps.
 * v-prediction (Salimans & Ho): v = sqrt(ab_t) eps - sqrt(1 - ab_t) x0, hence
 *   x0 = sqrt(ab_t) x_t - sqrt(1 - ab_t) v,   eps = sqrt(1 - ab_t) x_t + sqrt(ab_t) v.
 * DDIM (eta = 0): x_prev = sqrt(ab_prev) x0 + sqrt(1 - ab_prev) eps, over any descending list of
 * timesteps; after the last listed step the sampler jumps to x0 (ab_prev = 1).
 * Classifier-free guidance: v = v_uncond + s (v_cond - v_uncond) (s = 3.0 in StableMaterial). */
#ifndef MF_DIFFUSION_H
#define MF_DIFFUSION_H

#include <stddef.h>

#define MF_DIFF_T 1000
#define MF_DIFF_BETA_START 0.00085
#define MF_DIFF_BETA_END 0.012
#define MF_PRIOR_GUIDANCE 3.0f

typedef struct {
    double beta[MF_DIFF_T];      // (T)
    double alpha_bar[MF_DIFF_T]; // (T)
} MfDiffusion;

void mf_diffusion_init(MfDiffusion *d);

/* xt (n) = sqrt(ab_t) x0 + sqrt(1 - ab_t) eps. */
void mf_diffusion_q_sample(const MfDiffusion *d, float *xt, const float *x0, const float *eps, int t, size_t n);
/* v (n) = sqrt(ab_t) eps - sqrt(1 - ab_t) x0. */
void mf_diffusion_v_target(const MfDiffusion *d, float *v, const float *x0, const float *eps, int t, size_t n);
/* x0 (n) and/or eps (n) (either may be NULL) from x_t and the predicted v. */
void mf_diffusion_from_v(const MfDiffusion *d, float *x0, float *eps, const float *xt, const float *v, int t,
                         size_t n);
/* One DDIM step (eta 0) in place: x (n) holds x_t, becomes x_{t_prev}; t_prev < 0 means x0. */
void mf_diffusion_ddim_step(const MfDiffusion *d, float *x, const float *v, int t, int t_prev, size_t n);
/* out (n) = vu + s (vc - vu). */
void mf_diffusion_cfg(float *out, const float *v_uncond, const float *v_cond, float scale, size_t n);

/* Model callback: v (n) predicted for x_t (n) at timestep t. Returns MF_OK or an error. */
typedef int (*MfVPredFn)(void *ctx, float *v, const float *xt, int t);
/* DDIM over steps[0] > steps[1] > ... > steps[nsteps-1] then x0: x (n) holds x_{steps[0]} on entry
 * and the sample x0 on return. v: scratch (n). */
int mf_diffusion_ddim(const MfDiffusion *d, float *x, float *v, size_t n, const int *steps, int nsteps,
                      MfVPredFn fn, void *ctx);
/* The usual inference list of nsteps (<= T) evenly spaced timesteps ("leading" spacing, as
 * diffusers' DDIMScheduler with steps_offset 1): t_i = i*(T/nsteps) + 1, descending. */
void mf_diffusion_inference_steps(int *steps, int nsteps);

#endif
