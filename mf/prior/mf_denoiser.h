/* mf_denoiser: the prior's conditional v-prediction UNet on latents, plus its image encoder.
 *
 * Input x (B, 3*zc, h, h) = [clean image latent zc | noisy albedo latent zc | noisy ORM latent zc]
 * (scaled latents), timestep t (B), the condition image rgb (B, 3, R, R) in [-1, 1] x mask and a
 * per-item multiplier keep (B) of the image embedding (0 = the zero embedding of classifier-free
 * guidance). Output v (B, 2*zc, h, h) for the material channels [albedo | ORM].
 *   emb  = MLP(sinusoid(t))  +  keep * Linear(meanpool(ImgEnc(rgb)))      (B, Ct)
 *          (ImgEnc: three stride-2 3x3 convs with SiLU, in place of CLIP's image embedding)
 *   h1 = Res(conv_in(x), emb) @h       h3 = Res(conv s2(h1), emb) @h/2 (c1 -> c2)
 *   h4 = Attn(h3) (multi-view: the V views of an object attend jointly when joint = 1)
 *   h5 = Res(h4, emb)    h7 = Res(cat(up2(h5), h1), emb) @h (c2 + c1 -> c1)
 *   v  = conv_out(GN+SiLU(h7))   (conv_out starts at zero)
 * Tensor names "dn.*" (UNet) and "img.*" (image encoder); one parameter buffer for both, trained
 * jointly. The batch holds B = objects * V images, V consecutive views per object. */
#ifndef MF_DENOISER_H
#define MF_DENOISER_H

#include "nn/mf_nn_kit.h"

typedef struct {
    int h;              /* latent size (R / 4) */
    int zc;             /* latent channels per map (4) */
    int c1, c2;         /* UNet channels at h and h/2 */
    int ct, tfreq;      /* embedding width, sinusoid width */
    int heads, groups;
    int img_res;        /* condition image size R */
    int i1, i2, i3;     /* image encoder channels */
} MfDenoiserConfig;

typedef struct {
    MfDenoiserConfig cfg;
    MfSpecTab tab;
    MfKLinear t1, t2, iproj;
    MfSeq img;
    MfKConv cin, down, cout;
    MfResBlockDims r0, r1, r2, r3; /* .B set per call */
    size_t o0, o1, o2, o3;
    MfAttnBlockDims ad;
    size_t oa;
    MfKNorm nout;
    float *params; // (tab.numel) owned
    float *grads;  // (tab.numel) owned
} MfDenoiser;

typedef struct {
    float *mem; /* owned */
    size_t cap;
    int B, V, joint;
    const float *x, *rgb, *keep; /* borrowed inputs of the last forward */
    MfSeqWork img;
    float *tf, *t1o, *t1a, *et; // (B, tfreq), (B, Ct) x3
    float *pool, *ei, *emb;     // (B, i3), (B, Ct), (B, Ct)
    float *h0, *h1, *h2, *h3, *h4, *h5, *h5u, *h6, *h7, *v;
    MfResBlockActs a0, a1, a2, a3;
    MfAttnBlockActs aa;
    MfKNormActs an;
    float *col;
    float *g16a, *g16b, *g8a, *g8b, *gemb, *gtmp, *gpool, *gfeat;
} MfDenoiserWork;

int mf_denoiser_new(MfDenoiser **out, const MfDenoiserConfig *cfg);
void mf_denoiser_free(MfDenoiser *dn);
void mf_denoiser_init_weights(MfDenoiser *dn, unsigned long long seed);
/* v (B, 2zc, h, h) inside w; NULL on OOM (error set). t (B) timesteps as floats. */
float *mf_denoiser_forward(MfDenoiser *dn, MfDenoiserWork *w, const float *x, const float *t,
                           const float *rgb, const float *keep, int B, int V, int joint);
/* Backward of the last forward: dn->grads += (UNet and image encoder). */
void mf_denoiser_backward(MfDenoiser *dn, MfDenoiserWork *w, const float *dv);
void mf_denoiser_work_free(MfDenoiserWork *w);

#endif
