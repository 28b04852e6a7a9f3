/* mf_ae: the prior's autoencoder (in place of Stable Diffusion's VAE).
 *
 * Images (B, 3, R, R) in [-1, 1] (each kind already multiplied by its mask) <-> latents
 * (B, zc, R/4, R/4), one autoencoder shared by albedo, ORM and the RGB condition.
 * Encoder: conv3x3(3->c1), res(c1), conv s2(c1->c2), res(c2), conv s2(c2->c2), res(c2), GN+SiLU,
 * conv3x3(c2->zc). Decoder: conv(zc->c2), res(c2), up2, conv(c2->c2), res(c2), up2, conv(c2->c1),
 * res(c1), GN+SiLU, conv(c1->3). Deterministic (no sampling); trained with L1 + MSE
 * reconstruction plus a small latent L2 so latents stay bounded (mf_prior_train). The latents here
 * are UNSCALED; mf_prior multiplies them by the stored latent scale. Tensor names "ae.enc.<i>...",
 * "ae.dec.<i>...". */
#ifndef MF_AE_H
#define MF_AE_H

#include <stddef.h>

#include "nn/mf_nn_kit.h"

typedef struct {
    int res;    /* image size R (multiple of 4) */
    int c1, c2; /* channels at full and reduced resolution */
    int zc;     /* latent channels (4) */
    int groups; /* group-norm groups (divides c1 and c2) */
} MfAeConfig;

typedef struct {
    MfAeConfig cfg;
    MfSpecTab tab; /* all tensors, encoder then decoder */
    MfSeq enc, dec;
    float *params; // (tab.numel) owned
    float *grads;  // (tab.numel) owned, zeroed by the caller per step
} MfAe;

typedef struct {
    MfSeqWork enc, dec;
} MfAeWork;

int mf_ae_new(MfAe **out, const MfAeConfig *cfg);
/* The number of weights (floats) of a configuration, without allocating them; errors as mf_ae_new. */
int mf_ae_numel(const MfAeConfig *cfg, size_t *numel);
void mf_ae_free(MfAe *ae);
void mf_ae_init_weights(MfAe *ae, unsigned long long seed);
/* z (B, zc, R/4, R/4) unscaled, pointer into w (valid until the next encode on w); NULL = OOM. */
float *mf_ae_encode(MfAe *ae, MfAeWork *w, const float *img, int B);
/* Backward of the last encode on w: ae->grads +=, dimg (B, 3, R, R) += (may be NULL). */
void mf_ae_encode_backward(MfAe *ae, MfAeWork *w, const float *dz, float *dimg);
/* The same for a frozen encoder: dimg += only (no weight gradient is computed: about half the work). */
void mf_ae_encode_backward_input(const MfAe *ae, MfAeWork *w, const float *dz, float *dimg);
/* img (B, 3, R, R), pointer into w; NULL = OOM. */
float *mf_ae_decode(MfAe *ae, MfAeWork *w, const float *z, int B);
void mf_ae_decode_backward(MfAe *ae, MfAeWork *w, const float *dimg, float *dz);
void mf_ae_work_free(MfAeWork *w);

#endif
