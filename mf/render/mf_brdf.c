/* mf_brdf: nvdiffrecmc's metallic-workflow BRDF (see mf_brdf.h).
 *
 * Numerically stable forms used throughout (c = cos theta, a2 = alpha^2):
 *   s(c)          = sqrt(c^2 + a2 (1 - c^2))            (so 1 + 2 Lambda(c) = s / c)
 *   G             = 2 co ci / (s(co) ci + s(ci) co)       (height-correlated Smith)
 *   G1(wo)        = 2 co / (co + s(co))
 *   spec * cos_i  = F D G / (4 co) = F D ci / (2 (s(co) ci + s(ci) co))
 *   pdf_spec(wi)  = G1(wo) D(h) / (4 co) = D(h) / (2 (co + s(co)))   (VNDF + reflection Jacobian)
 * None divides by a cosine, so grazing angles stay finite. */
#include "render/mf_brdf.h"

#include <math.h>

static inline float clamp_roughness(float r) { return mf_clampf(fmaxf(r, MF_MIN_ROUGHNESS), MF_MIN_ROUGHNESS, 1.0f); }
static inline float mat_alpha(const MfMaterial *m) {
    float r = clamp_roughness(m->roughness);
    return r * r;
}
static inline float mat_metallic(const MfMaterial *m) { return mf_clampf(fmaxf(m->metallic, 0.0f), 0.0f, 1.0f); }
static inline MfVec3 mat_f0(const MfMaterial *m) {
    float met = mat_metallic(m);
    return mf_add(mf_v3s(0.04f * (1.0f - met)), mf_scale(m->kd, met));
}
/* sqrt(c^2 + a2 (1 - c^2)) for c in [0, 1]. */
static inline float smith_s(float a2, float c) {
    float c2 = c * c;
    return sqrtf(fmaxf(c2 + a2 * (1.0f - c2), 0.0f));
}

/* GGX D from cos^2 and sin^2 of the half vector: d = cos^2 a2 + sin^2 has no cancellation at the
 * peak when sin^2 comes from h.x^2 + h.y^2 (precise for h near the normal, where 1 - cos^2 in
 * float is quantised in steps of 1.2e-7, coarse against a2 = 4e-5 at the roughness floor). */
static inline float ggx_D_cs(float a2, float c2, float s2) {
    float d = fmaf(c2, a2, s2);
    return a2 / (MF_PI * d * d);
}

float mf_ggx_D(float alpha, float cos_h) {
    if (!(cos_h > 0.0f)) return 0.0f;
    float c = fminf(cos_h, 1.0f);
    return ggx_D_cs(alpha * alpha, c * c, fmaf(-c, c, 1.0f));
}

/* D at unit half vector h (zero below the horizon). */
static inline float ggx_D_h(float alpha, MfVec3 h) {
    if (!(h.z > 0.0f)) return 0.0f;
    float s2 = h.x * h.x + h.y * h.y;
    return ggx_D_cs(alpha * alpha, h.z * h.z, s2);
}

float mf_smith_lambda(float alpha, float cos_theta) {
    float c = mf_clampf(cos_theta, 1e-7f, 1.0f);
    return 0.5f * (smith_s(alpha * alpha, c) / c - 1.0f);
}

float mf_smith_G(float alpha, float cos_o, float cos_i) {
    if (!(cos_o > 0.0f) || !(cos_i > 0.0f)) return 0.0f;
    float a2 = alpha * alpha;
    float co = fminf(cos_o, 1.0f), ci = fminf(cos_i, 1.0f);
    return 2.0f * co * ci / (smith_s(a2, co) * ci + smith_s(a2, ci) * co);
}

MfVec3 mf_fresnel_schlick(MfVec3 f0, float cos_d) {
    float c = mf_clampf(cos_d, 0.0f, 1.0f);
    float m = 1.0f - c, m2 = m * m, w = m2 * m2 * m;
    return mf_add(f0, mf_scale(mf_sub(mf_v3s(1.0f), f0), w));
}

MfBrdfValue mf_brdf_eval(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes) {
    MfBrdfValue v = {mf_v3s(0.0f), mf_v3s(0.0f), 0.0f};
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return v;
    float co = fminf(wo.z, 1.0f), ci = fminf(wi.z, 1.0f);
    float met = mat_metallic(mat);
    if (lobes & MF_LOBE_DIFFUSE) {
        v.diffuse_demod = ci * MF_INV_PI;
        v.diffuse = mf_scale(mat->kd, (1.0f - met) * v.diffuse_demod);
    }
    if (lobes & MF_LOBE_SPECULAR) {
        float alpha = mat_alpha(mat), a2 = alpha * alpha;
        MfVec3 h = mf_norm(mf_add(wo, wi));
        float D = ggx_D_h(alpha, h);
        MfVec3 F = mf_fresnel_schlick(mat_f0(mat), mf_dot(wo, h));
        float k = D * ci / (2.0f * (smith_s(a2, co) * ci + smith_s(a2, ci) * co));
        v.specular = mf_scale(F, k);
    }
    return v;
}

void mf_brdf_eval_backward(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes, MfVec3 d_diffuse, MfVec3 d_specular,
                           MfMaterial *dmat) {
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return;
    float co = fminf(wo.z, 1.0f), ci = fminf(wi.z, 1.0f);
    float met = mat_metallic(mat);
    int met_live = mat->metallic >= 0.0f && mat->metallic <= 1.0f;
    if (lobes & MF_LOBE_DIFFUSE) {
        float k = ci * MF_INV_PI;
        dmat->kd = mf_add(dmat->kd, mf_scale(d_diffuse, (1.0f - met) * k));
        if (met_live) dmat->metallic -= mf_dot(d_diffuse, mat->kd) * k;
    }
    if (lobes & MF_LOBE_SPECULAR) {
        float r = clamp_roughness(mat->roughness), alpha = r * r, a2 = alpha * alpha;
        MfVec3 h = mf_norm(mf_add(wo, wi));
        float D = ggx_D_h(alpha, h);
        float so = smith_s(a2, co), si = smith_s(a2, ci);
        float Q = so * ci + si * co;
        float K = D * ci / (2.0f * Q);
        float cd = mf_clampf(mf_dot(wo, h), 0.0f, 1.0f);
        float m1 = 1.0f - cd, m2 = m1 * m1, w = m2 * m2 * m1;
        MfVec3 F = mf_fresnel_schlick(mat_f0(mat), cd);
        /* F = F0 + (1 - F0) w, F0 = 0.04 (1 - m) + kd m */
        float dF0 = (1.0f - w) * K;
        dmat->kd = mf_add(dmat->kd, mf_scale(d_specular, dF0 * met));
        if (met_live) dmat->metallic += dF0 * (mf_dot(d_specular, mat->kd) - 0.04f * (d_specular.x + d_specular.y + d_specular.z));
        if (mat->roughness >= MF_MIN_ROUGHNESS && mat->roughness <= 1.0f && D > 0.0f) {
            /* D = a2 / (pi d^2), d = c2 a2 + s2:  dD/da2 = D (1/a2 - 2 c2 / d) */
            float c2 = h.z * h.z, dd = fmaf(c2, a2, h.x * h.x + h.y * h.y);
            float dD = D * (1.0f / a2 - 2.0f * c2 / dd);
            float dQ = ci * (1.0f - co * co) / (2.0f * so) + co * (1.0f - ci * ci) / (2.0f * si);
            float dK = dD * ci / (2.0f * Q) - K * dQ / Q;
            float da2 = 4.0f * r * r * r; /* a2 = r^4 */
            dmat->roughness += mf_dot(d_specular, F) * dK * da2;
        }
    }
}

float mf_brdf_p_diffuse(const MfMaterial *mat, MfVec3 wo, int lobes) {
    if ((lobes & MF_LOBE_ALL) == MF_LOBE_DIFFUSE) return 1.0f;
    if (!(lobes & MF_LOBE_DIFFUSE)) return 0.0f;
    float met = mat_metallic(mat);
    MfVec3 kd = mf_v3(fmaxf(mat->kd.x, 0.0f), fmaxf(mat->kd.y, 0.0f), fmaxf(mat->kd.z, 0.0f));
    float wd = (1.0f - met) * mf_lum(kd);
    MfVec3 f0 = mf_add(mf_v3s(0.04f * (1.0f - met)), mf_scale(kd, met));
    float ws = mf_lum(mf_fresnel_schlick(f0, wo.z));
    if (!(wd > 0.0f)) return 0.0f; /* no diffuse energy: always specular (covers 0/0) */
    if (!(ws > 0.0f)) return 1.0f;
    float p = wd / (wd + ws);
    return isfinite(p) ? mf_clampf(p, 0.0f, 1.0f) : 0.5f;
}

static float pdf_specular(float alpha, MfVec3 wo, MfVec3 wi) {
    MfVec3 h = mf_norm(mf_add(wo, wi));
    float co = fminf(wo.z, 1.0f);
    return ggx_D_h(alpha, h) / (2.0f * (co + smith_s(alpha * alpha, co)));
}

float mf_brdf_pdf(const MfMaterial *mat, MfVec3 wo, MfVec3 wi, int lobes) {
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f) || !(lobes & MF_LOBE_ALL)) return 0.0f;
    float pd = mf_brdf_p_diffuse(mat, wo, lobes);
    float pdf = 0.0f;
    if (pd > 0.0f) pdf += pd * fminf(wi.z, 1.0f) * MF_INV_PI;
    if (pd < 1.0f) pdf += (1.0f - pd) * pdf_specular(mat_alpha(mat), wo, wi);
    return pdf;
}

/* Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (isotropic alpha). */
static MfVec3 sample_vndf(float alpha, MfVec3 wo, float u1, float u2) {
    MfVec3 vh = mf_norm(mf_v3(alpha * wo.x, alpha * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    MfVec3 t1 = lensq > 0.0f ? mf_scale(mf_v3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq)) : mf_v3(1.0f, 0.0f, 0.0f);
    MfVec3 t2 = mf_cross(vh, t1);
    float r = sqrtf(u1), phi = 2.0f * MF_PI * u2;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    MfVec3 nh = mf_add(mf_add(mf_scale(t1, p1), mf_scale(t2, p2)), mf_scale(vh, sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2))));
    return mf_norm(mf_v3(alpha * nh.x, alpha * nh.y, fmaxf(0.0f, nh.z)));
}

int mf_brdf_sample(const MfMaterial *mat, MfVec3 wo, float u0, float u1, float u2, int lobes, MfVec3 *wi, float *pdf) {
    if (!(wo.z > 0.0f) || !(lobes & MF_LOBE_ALL)) return 0;
    u1 = mf_clampf(u1, 0.0f, 1.0f);
    u2 = mf_clampf(u2, 0.0f, 1.0f);
    float pd = mf_brdf_p_diffuse(mat, wo, lobes);
    MfVec3 d;
    if (u0 < pd) {
        float r = sqrtf(u1), phi = 2.0f * MF_PI * u2;
        d = mf_v3(r * cosf(phi), r * sinf(phi), sqrtf(fmaxf(0.0f, 1.0f - u1)));
    } else {
        MfVec3 h = sample_vndf(mat_alpha(mat), wo, u1, u2);
        d = mf_norm(mf_reflect(wo, h));
    }
    if (!(d.z > 0.0f) || !mf_isfinite3(d)) return 0;
    float p = mf_brdf_pdf(mat, wo, d, lobes);
    if (!(p > 0.0f) || !isfinite(p)) return 0;
    *wi = d;
    *pdf = p;
    return 1;
}

/* ---- per-shading-point context: the same operations as above, constants hoisted ---- */

void mf_brdf_prepare(MfBrdfCtx *c, const MfMaterial *mat, MfVec3 wo, int lobes) {
    c->mat = *mat;
    c->wo = wo;
    c->lobes = lobes;
    c->co = fminf(wo.z, 1.0f);
    c->met = mat_metallic(mat);
    c->alpha = mat_alpha(mat);
    c->a2 = c->alpha * c->alpha;
    c->so = smith_s(c->a2, c->co);
    c->f0 = mat_f0(mat);
    c->pd = (wo.z > 0.0f && (lobes & MF_LOBE_ALL)) ? mf_brdf_p_diffuse(mat, wo, lobes) : 0.0f;
}

MfBrdfValue mf_brdf_ctx_eval_pdf(const MfBrdfCtx *c, MfVec3 wi, float *pdf) {
    MfBrdfValue v = {mf_v3s(0.0f), mf_v3s(0.0f), 0.0f};
    *pdf = 0.0f;
    MfVec3 wo = c->wo;
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return v;
    int lobes = c->lobes;
    float co = c->co, ci = fminf(wi.z, 1.0f);
    if (lobes & MF_LOBE_DIFFUSE) {
        v.diffuse_demod = ci * MF_INV_PI;
        v.diffuse = mf_scale(c->mat.kd, (1.0f - c->met) * v.diffuse_demod);
    }
    float pd = c->pd, p = 0.0f;
    if (!(lobes & MF_LOBE_ALL)) {
        *pdf = 0.0f;
        return v;
    }
    if (pd > 0.0f) p += pd * ci * MF_INV_PI;
    if ((lobes & MF_LOBE_SPECULAR) || pd < 1.0f) {
        MfVec3 h = mf_norm(mf_add(wo, wi));
        float D = ggx_D_h(c->alpha, h);
        if (lobes & MF_LOBE_SPECULAR) {
            MfVec3 F = mf_fresnel_schlick(c->f0, mf_dot(wo, h));
            float k = D * ci / (2.0f * (c->so * ci + smith_s(c->a2, ci) * co));
            v.specular = mf_scale(F, k);
        }
        if (pd < 1.0f) p += (1.0f - pd) * (D / (2.0f * (co + c->so)));
    }
    *pdf = p;
    return v;
}

int mf_brdf_ctx_sample(const MfBrdfCtx *c, float u0, float u1, float u2, MfVec3 *wi, float *pdf, MfBrdfValue *f) {
    MfVec3 wo = c->wo;
    if (!(wo.z > 0.0f) || !(c->lobes & MF_LOBE_ALL)) return 0;
    u1 = mf_clampf(u1, 0.0f, 1.0f);
    u2 = mf_clampf(u2, 0.0f, 1.0f);
    MfVec3 d;
    if (u0 < c->pd) {
        float r = sqrtf(u1), phi = 2.0f * MF_PI * u2;
        d = mf_v3(r * cosf(phi), r * sinf(phi), sqrtf(fmaxf(0.0f, 1.0f - u1)));
    } else {
        MfVec3 h = sample_vndf(c->alpha, wo, u1, u2);
        d = mf_norm(mf_reflect(wo, h));
    }
    if (!(d.z > 0.0f) || !mf_isfinite3(d)) return 0;
    float p;
    MfBrdfValue v = mf_brdf_ctx_eval_pdf(c, d, &p);
    if (!(p > 0.0f) || !isfinite(p)) return 0;
    *wi = d;
    *pdf = p;
    *f = v;
    return 1;
}
