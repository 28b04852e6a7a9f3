/* mf_texture: UV texture lookup (kd albedo, ORM, normal maps) with bilinear filtering,
 * and its adjoint.
 *
 * A texture is an MfImage (h, w, c), linear, row 0 at the top. UV (u right, v up) maps to
 * continuous texel coordinates x = u*W - 0.5, y = (1 - v)*H - 0.5 (texel centres at integers).
 * Addressing: MF_WRAP_REPEAT (tiles) or MF_WRAP_CLAMP (edge texels extend).
 * ORM follows glTF: R occlusion (ignored by the BRDF), G roughness, B metallic. */
#ifndef MF_TEXTURE_H
#define MF_TEXTURE_H

#include "io/mf_image.h"

typedef enum { MF_WRAP_REPEAT = 0, MF_WRAP_CLAMP = 1 } MfWrap;

/* out: (tex->c,) bilinear sample at (u, v). */
void mf_tex_sample(const MfImage *tex, float u, float v, MfWrap wrap, float *out);
/* Adjoint of mf_tex_sample: dtex (h, w, c) += bilinear weights * dout (c,). Not thread-safe on
 * dtex: callers accumulate per thread and reduce. */
void mf_tex_sample_backward(const MfImage *tex, float u, float v, MfWrap wrap, const float *dout, float *dtex);
/* Gradient of <dout, mf_tex_sample(u, v)> with respect to (u, v), += into *du, *dv; dout (nc,),
 * nc <= tex->c channels (the rest count as 0). Piecewise linear lookup: the derivative of the
 * bilinear cell (u, v) lies in (zero where clamping holds the taps equal). */
void mf_tex_sample_grad_uv(const MfImage *tex, float u, float v, MfWrap wrap, const float *dout, int nc, float *du,
                           float *dv);

#endif
