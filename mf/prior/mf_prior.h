/* mf_prior: StableMaterial in C — the whole prior (autoencoder + conditional v-prediction denoiser +
 * image encoder), its weights file, sampling and the pieces of MaterialFusion's SDS+ term.
 *
 * Inputs (DESIGN.md "Contracts"): images at the prior's resolution R (default 64), NCHW (B, 3, R, R):
 *   albedo = base colour kd in sRGB, ORM linear, condition = the RGB view in sRGB, each mapped to
 *   [-1, 1] and multiplied by the mask (alpha): x = (2 v - 1) * alpha.
 * Latents (B, 4, R/4, R/4) are the autoencoder's latents times the stored latent scale (about unit
 * variance over the training data). A material latent is (B, 8, h, h) = [albedo 4 | ORM 4].
 * Denoising: v-prediction, DDIM (eta 0), classifier-free guidance (3.0; unconditional = zero image
 * embedding and zero image latent). Multi-view (StableMaterialMV, inference only): B = objects * V
 * images with V consecutive views per object; joint = 1 lets the V views attend jointly.
 *
 * Weights file: an MFCK checkpoint (io/mf_ckpt.h, version 1) holding every tensor ("ae.*", "dn.*",
 * "img.*") and JSON meta: {"format": "mf-prior", "version": 1, "resolution", "downsample": 4,
 * "latent_channels", "latent_scale", "encodings": {...}, "data_seed", "ae": {...}, "dn": {...}}.
 * Loading refuses missing, truncated, corrupt, wrong-version and wrong-shape files with a message
 * naming the file and the expected version.
 *
 * SDS+ (MaterialFusion, REFERENCE.md) with this API: zmat = encode_materials(albedo, orm);
 * zhat = sds_denoise(zmat, cond, t ~ U{20..980}); L_latent = MSE(zhat * a, zmat * a) with zhat treated
 * as a constant target (classic SDS; the official code also lets zhat depend on z through the
 * noising, which we do not), gradient dL/dzmat -> encode_materials_backward -> d maps;
 * L_rgb = MSE(decode_materials(zhat) * a, maps) in pixel space (no gradient through the decoder).
 * Not thread-safe: one MfPrior per thread. */
#ifndef MF_PRIOR_H
#define MF_PRIOR_H

#include <stdint.h>

#include "prior/mf_ae.h"
#include "prior/mf_denoiser.h"
#include "prior/mf_diffusion.h"
#include "io/mf_image.h"

#define MF_PRIOR_FORMAT_VERSION 1
/* Loading refuses (by field) meta text longer than this, and configurations with more channels
 * (or groups, heads) than this in any layer: both are checked before anything is allocated. */
#define MF_PRIOR_META_MAX (1u << 20)
#define MF_PRIOR_MAX_CHANNELS 1024
#define MF_PRIOR_ENC_ALBEDO "sRGB kd in [-1,1] x mask"
#define MF_PRIOR_ENC_ORM "linear in [-1,1] x mask"
#define MF_PRIOR_ENC_COND "sRGB RGB in [-1,1] x mask"

typedef struct {
    MfAeConfig ae;
    MfDenoiserConfig dn;
} MfPriorConfig;

/* The default model at resolution res (64): AE 32/64 channels, UNet 64/128, about 1.7 M params. */
void mf_prior_config_default(MfPriorConfig *c, int res);
/* A very small model at resolution 16 for tests. */
void mf_prior_config_tiny(MfPriorConfig *c);

typedef struct {
    MfPriorConfig cfg;
    MfAe *ae;          // owned
    MfDenoiser *dn;    // owned
    float latent_scale;
    uint64_t data_seed;
    MfDiffusion diff;
    MfAeWork aew;      /* work of mf_prior_encode / _backward / _decode (owned) */
    MfAeWork aes;      /* work of the sampler (owned) */
    MfDenoiserWork dnw; /* (owned) */
    float *scratch;    /* (scap) owned */
    size_t scap;
    float *mat_in;     /* (2B, 3, R, R) owned: input of encode_materials, kept for its backward */
    size_t mat_cap;
} MfPrior;

int mf_prior_new(MfPrior **out, const MfPriorConfig *cfg);
void mf_prior_free(MfPrior *p);
/* Total parameter count (AE + denoiser + image encoder). */
size_t mf_prior_num_params(const MfPrior *p);
/* Writes the weights file atomically; extra (may be NULL) is a JSON object whose members are added
 * to the meta (e.g. training facts). */
int mf_prior_save(const MfPrior *p, const char *path, const char *extra_json);
int mf_prior_load(const char *path, MfPrior **out);

/* The default weights: $MF_PRIOR_WEIGHTS when set (a .mfck file or a folder holding prior.mfck);
 * else MF_PRIOR_WEIGHTS_DEFAULT (the committed prior-ft.mfck: `make train-prior-ft`, which continues
 * the first wave's prior.mfck on all of prior-train; chosen on val-3d, docs/analyses/prior.md)
 * relative to the current directory when that file exists; else the same path relative to the
 * repository of the running executable (<exe dir>/../, i.e. build/mf).
 * Writes the chosen path into buf (n bytes); the file need not exist (loading then names it). */
#define MF_PRIOR_WEIGHTS_ENV "MF_PRIOR_WEIGHTS"
#define MF_PRIOR_WEIGHTS_DEFAULT "mf/prior/weights/prior-ft.mfck"
void mf_prior_default_weights(char *buf, size_t n);
/* path: a .mfck file, a folder holding prior.mfck, or NULL for mf_prior_default_weights. */
int mf_prior_load_path(const char *path, MfPrior **out);
/* Reads only the JSON meta of an MFCK file (heap string, caller frees); checks magic and version. */
int mf_prior_read_meta(const char *path, char **meta);

/* z (B, zc, h, h) = latent_scale * Enc(img (B, 3, R, R)). Keeps what the backward needs; img must
 * stay valid until mf_prior_encode_backward. */
int mf_prior_encode(MfPrior *p, const float *img, int B, float *z);
/* dimg (B, 3, R, R) += d/dimg of <dz, z> for the last mf_prior_encode (the encoder is frozen: its
 * weight gradients are not computed). */
void mf_prior_encode_backward(MfPrior *p, const float *dz, float *dimg);
/* img (B, 3, R, R) = Dec(z / latent_scale), z (B, zc, h, h) scaled. */
int mf_prior_decode(MfPrior *p, const float *z, int B, float *img);

/* Material maps <-> material latents, for the SDS+ term. albedo, orm (B, 3, R, R) in [-1, 1] x mask;
 * zmat (B, 2zc, h, h) = [albedo latent | ORM latent] per item (scaled). Both maps are encoded as one
 * batch of 2B images, so mf_prior_encode_materials_backward can follow (it adds to dalbedo and dorm,
 * (B, 3, R, R) each, the gradient of <dzmat, zmat>; either may be NULL to skip it). These share the
 * work buffers of mf_prior_encode / _decode: a backward refers to the latest encode call. */
int mf_prior_encode_materials(MfPrior *p, const float *albedo, const float *orm, int B, float *zmat);
int mf_prior_encode_materials_backward(MfPrior *p, const float *dzmat, float *dalbedo, float *dorm);
int mf_prior_decode_materials(MfPrior *p, const float *zmat, int B, float *albedo, float *orm);

/* Guided v (B, 2zc, h, h) for noisy material latents xt (B, 2zc, h, h) at timestep t, given the
 * scaled image latent zimg (B, zc, h, h) and the condition image rgb (B, 3, R, R). Guidance 1 is
 * the conditional prediction itself: the unconditional half of the batch is not run (half the cost). */
int mf_prior_guided_v(MfPrior *p, const float *zimg, const float *rgb, const float *xt, int t, int B, int V,
                      int joint, float guidance, float *v);
/* One sample per item: DDIM from pure noise (seeded) over nsteps with guidance; zmat (B, 2zc, h, h). */
int mf_prior_sample(MfPrior *p, const float *rgb, int B, int V, int joint, int nsteps, float guidance,
                    uint64_t seed, float *zmat);
/* SDS+ denoise (MaterialFusion): noise zmat (B, 2zc, h, h) to timestep t with seeded noise, run the
 * guided DDIM steps [t, .8t, .6t, .4t, .2t] and then x0; zhat (B, 2zc, h, h). */
int mf_prior_sds_denoise(MfPrior *p, const float *zmat, const float *rgb, int B, int V, int joint, int t,
                         float guidance, uint64_t seed, float *zhat);

/* Material maps predicted for nv views (mf_prior_mean.c): each the mean of S samples of `steps`
 * DDIM steps (decoded maps averaged in [-1, 1]), the sample seeds drawn from seed. rgb: (nv,) RGBA
 * images with raw channel values (the file's own encoding, as mf_prior_prepare_image takes them).
 * joint: the nv views are whole objects of V consecutive views, denoised jointly (multi-view);
 * else each view alone (V ignored). Outputs (nv,) each, allocated here at the prior's resolution
 * (R, R, 4): albedo linear (decoded as sRGB), ORM linear with R = 1, alpha = the input's
 * box-filtered coverage; colour 0 where that is below 1e-3. */
int mf_prior_predict_mean(MfPrior *p, const MfImage *rgb, int nv, int V, int joint, int S, int steps, float guidance,
                          uint64_t seed, MfImage *albedo, MfImage *orm);

/* Maps an RGBA image (h, w, 4) with raw channel values in [0, 1] (the file's own encoding) to
 * out (3, R, R) = (2 v - 1) * alpha after box-filtering (area averaging of v*alpha and alpha) to
 * R x R; mask (R, R) receives the filtered alpha (may be NULL). */
void mf_prior_prepare_image(const float *rgba, int w, int h, int R, float *out, float *mask);

#endif
