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

/* A residual / attention block of the UNet: its dimensions (.B, .BV, .V, .joint set per call)
 * and the float offset of its tensors in the parameter (and gradient) buffer. */
typedef struct {
    MfResBlockDims d;
    size_t off;
} MfDnRes;

typedef struct {
    MfAttnBlockDims d;
    size_t off;
} MfDnAttn;

typedef struct {
    MfDenoiserConfig cfg;
    MfSpecTab tab;
    MfKLinear t1, t2;   /* time MLP: tfreq -> ct -> ct ("dn.time.0/1") */
    MfKLinear iproj;    /* image embedding: i3 -> ct ("img.proj") */
    MfSeq img;          /* image encoder (3, R, R) -> (i3, R/8, R/8) ("img.enc") */
    MfKConv cin;        /* 3 zc -> c1 @h */
    MfKConv down;       /* c1 -> c1, stride 2: @h -> @h/2 */
    MfDnRes res0;       /* c1 -> c1 @h */
    MfDnRes res1;       /* c1 -> c2 @h/2 */
    MfDnAttn attn;      /* c2 @h/2 */
    MfDnRes res2;       /* c2 -> c2 @h/2 */
    MfDnRes res3;       /* c2 + c1 -> c1 @h */
    MfKNorm nout;       /* GN+SiLU of c1 */
    MfKConv cout;       /* c1 -> 2 zc @h (zero at init) */
    float *params; // (tab.numel) owned
    float *grads;  // (tab.numel) owned
} MfDenoiser;

typedef struct {
    float *mem; /* owned */
    size_t cap;
    int B, V, joint;
    const float *x, *rgb, *keep; /* borrowed inputs of the last forward */
    int ei_ok;                   /* 1: ei holds the image embedding of the last forward's rgb */
    MfSeqWork img;
    float *tf, *t1o, *t1a, *et; // (B, tfreq), (B, Ct) x3
    float *pool, *ei, *emb;     // (B, i3), (B, Ct), (B, Ct)
    float *h0;  // (B, c1, h, h)       conv_in(x)
    float *h1;  // (B, c1, h, h)       res0
    float *h2;  // (B, c1, h/2, h/2)   down
    float *h3;  // (B, c2, h/2, h/2)   res1
    float *h4;  // (B, c2, h/2, h/2)   attn
    float *h5;  // (B, c2, h/2, h/2)   res2
    float *h5u; // (B, c2, h, h)       up2(h5)
    float *h6;  // (B, c2 + c1, h, h)  cat(h5u, h1)
    float *h7;  // (B, c1, h, h)       res3
    float *v;   // (B, 2 zc, h, h)     conv_out(GN+SiLU(h7)), the output
    MfResBlockActs a0, a1, a2, a3; /* res0..res3 caches */
    MfAttnBlockActs aa;
    MfKNormActs an;
    float *col;          // conv scratch: the largest im2col of cin, down, cout
    float *g16a, *g16b;  // (B, c1 + c2, h, h)  backward ping-pong at h
    float *g8a, *g8b;    // (B, c2, h/2, h/2)   backward ping-pong at h/2
    float *gemb, *gtmp;  // (B, Ct)
    float *gpool;        // (B, i3)
    float *gfeat;        // (B, i3, R/8, R/8)   gradient of the image encoder's output
} MfDenoiserWork;

int mf_denoiser_new(MfDenoiser **out, const MfDenoiserConfig *cfg);
/* The number of weights (floats) of a configuration, without allocating them; errors as mf_denoiser_new. */
int mf_denoiser_numel(const MfDenoiserConfig *cfg, size_t *numel);
void mf_denoiser_free(MfDenoiser *dn);
void mf_denoiser_init_weights(MfDenoiser *dn, unsigned long long seed);
/* v (B, 2zc, h, h) inside w; NULL on OOM (error set). t (B) timesteps as floats. */
float *mf_denoiser_forward(MfDenoiser *dn, MfDenoiserWork *w, const float *x, const float *t,
                           const float *rgb, const float *keep, int B, int V, int joint);
/* The same where rgb holds the same images as the previous forward on w (same B, V, joint): with
 * same_rgb the image encoder is not run again and its embedding ei is reused (the same bits; the
 * DDIM steps of one sample). A backward after it is that of the previous image-encoder pass. */
float *mf_denoiser_forward_ex(MfDenoiser *dn, MfDenoiserWork *w, const float *x, const float *t, const float *rgb,
                              const float *keep, int B, int V, int joint, int same_rgb);
/* Backward of the last forward: dn->grads += (UNet and image encoder). */
void mf_denoiser_backward(MfDenoiser *dn, MfDenoiserWork *w, const float *dv);
void mf_denoiser_work_free(MfDenoiserWork *w);

#endif
