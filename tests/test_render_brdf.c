/* Tests of mf/render/mf_brdf: building blocks, reciprocity, energy (white furnace, specular
 * albedo <= 1), pdf normalisation, chi-square of the sampler against the pdf, hard cases, the
 * BRDF context (fast path) bitwise against the plain functions. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_rng.h"
#include "mf_chi2.h"
#include "mf_test.h"
#include "mf_test_kit.h"
#include "mf_test_grad.h"
#include "render/mf_brdf.h"

static MfVec3 dir_from(float cos_t, float phi) {
    float s = sqrtf(fmaxf(0.0f, 1.0f - cos_t * cos_t));
    return mf_v3(s * cosf(phi), s * sinf(phi), cos_t);
}

static MfMaterial mat3(float r, float g, float b, float rough, float metal) {
    MfMaterial m = {mf_v3(r, g, b), rough, metal};
    return m;
}

/* Hemisphere parametrisation for quadrature and binning: cos(theta) = 1 - s^k, s in [0, 1],
 * phi in [0, 2 pi); d(omega) = k s^(k-1) ds dphi. k > 1 resolves lobes peaked at the pole. */
typedef struct {
    const MfMaterial *mat;
    MfVec3 wo;
    int lobes, k;
    int what; /* 0: pdf, 1: specular value (luminance of F == 1 case: .x), 2: diffuse value .x */
    int half; /* 1: (s, phi) parametrise the half vector h, wi = reflect(wo, h), d(wi) = 4 (wo.h) d(h):
                 the specular peak sits at the pole of h whatever wo, so k = 4 resolves it */
} HemiCtx;

static double hemi_integrand(void *vctx, double s, double phi) {
    HemiCtx *c = vctx;
    double sk = pow(s, c->k), cos_t = 1.0 - sk, sin_t = sqrt(sk * (2.0 - sk));
    double jac = c->k * pow(s, c->k - 1);
    MfVec3 wi = mf_v3((float)(sin_t * cos(phi)), (float)(sin_t * sin(phi)), (float)cos_t); /* x, y precise near the pole */
    if (c->half) {
        double hx = sin_t * cos(phi), hy = sin_t * sin(phi);
        double oh = c->wo.x * hx + c->wo.y * hy + c->wo.z * cos_t;
        if (oh <= 0.0) return 0.0;
        wi = mf_v3((float)(2 * oh * hx - c->wo.x), (float)(2 * oh * hy - c->wo.y), (float)(2 * oh * cos_t - c->wo.z));
        if (!(wi.z > 0.0f)) return 0.0;
        jac *= 4.0 * oh;
    }
    double val;
    if (c->what == 0) val = mf_brdf_pdf(c->mat, c->wo, wi, c->lobes);
    else {
        MfBrdfValue v = mf_brdf_eval(c->mat, c->wo, wi, c->lobes);
        val = c->what == 1 ? v.specular.x : v.diffuse.x;
    }
    return val * jac;
}

static double hemi_integral(HemiCtx *c, int ns, int np, int max_depth) {
    double sum = 0.0;
    for (int i = 0; i < ns; ++i)
        for (int j = 0; j < np; ++j)
            sum += mf_quad2d(hemi_integrand, c, (double)i / ns, (double)(i + 1) / ns, 2 * M_PI * j / np, 2 * M_PI * (j + 1) / np,
                             1e-7, 1, max_depth);
    return sum;
}

MF_TEST(brdf_building_blocks) {
    /* D is normalised: int D(h) cos(h) dh = 1, for alphas down to the floor. */
    float alphas[] = {MF_MIN_ROUGHNESS * MF_MIN_ROUGHNESS, 0.04f, 0.25f, 1.0f};
    for (int a = 0; a < 4; ++a) {
        /* int 2 pi D(c) c dc = pi int_0^1 D dx with x = 1 - c^2; trapezoid on a geometric grid
         * in x (the peak has width alpha^2 in x) */
        double sum = 0.0, x0 = 0.0, f0 = MF_PI * mf_ggx_D(alphas[a], 1.0f);
        int n = 20000;
        for (int i = 0; i <= n; ++i) {
            float c = (float)sqrt(1.0 - 1e-9 * pow(0.999e9, (double)i / n));
            double x = 1.0 - (double)c * c; /* the abscissa of the float actually evaluated */
            double f = M_PI * mf_ggx_D(alphas[a], c);
            sum += 0.5 * (f + f0) * (x - x0);
            x0 = x;
            f0 = f;
        }
        CHECK_NEAR(sum, 1.0, 1e-4 + 1e-3 * alphas[a] * alphas[a]); /* + the tail x > 0.999 left out */
    }
    CHECK_NEAR(mf_smith_G(0.3f, 1.0f, 1.0f), 1.0, 1e-6);
    CHECK_NEAR(mf_smith_lambda(0.3f, 1.0f), 0.0, 1e-7);
    /* Lambda(theta) = (-1 + sqrt(1 + a^2 tan^2))/2, G = 1/(1 + Lambda_o + Lambda_i) */
    double t2 = (1.0 - 0.5 * 0.5) / (0.5 * 0.5);
    double lam = 0.5 * (-1.0 + sqrt(1.0 + 0.09 * t2));
    CHECK_NEAR(mf_smith_lambda(0.3f, 0.5f), lam, 1e-6);
    CHECK_NEAR(mf_smith_G(0.3f, 0.5f, 1.0f), 1.0 / (1.0 + lam), 1e-6);
    CHECK(mf_smith_G(0.3f, 0.0f, 0.5f) == 0.0f);
    MfVec3 f = mf_fresnel_schlick(mf_v3(0.04f, 0.5f, 1.0f), 0.5f);
    CHECK_NEAR(f.x, 0.04 + 0.96 * pow(0.5, 5), 1e-7);
    CHECK_NEAR(f.y, 0.5 + 0.5 * pow(0.5, 5), 1e-7);
    CHECK_NEAR(f.z, 1.0, 1e-7);
    /* the value formula against the textbook form F D G / (4 co ci) * ci */
    MfMaterial m = mat3(0.7f, 0.3f, 0.1f, 0.5f, 0.4f);
    MfVec3 wo = dir_from(0.6f, 0.2f), wi = dir_from(0.8f, 2.5f);
    MfBrdfValue v = mf_brdf_eval(&m, wo, wi, MF_LOBE_ALL);
    MfVec3 h = mf_norm(mf_add(wo, wi));
    float alpha = 0.25f;
    MfVec3 f0 = mf_add(mf_v3s(0.04f * 0.6f), mf_scale(m.kd, 0.4f));
    MfVec3 F = mf_fresnel_schlick(f0, mf_dot(wo, h));
    double k = mf_ggx_D(alpha, h.z) * mf_smith_G(alpha, wo.z, wi.z) / (4.0 * wo.z);
    CHECK_NEAR(v.specular.x, F.x * k, 1e-5 * F.x * k);
    CHECK_NEAR(v.specular.z, F.z * k, 1e-5 * F.z * k);
    CHECK_NEAR(v.diffuse.y, 0.3 * 0.6 * wi.z / M_PI, 1e-7);
    CHECK_NEAR(v.diffuse_demod, wi.z / M_PI, 1e-7);
    /* specular pdf = D_v(h) / (4 wo.h), D_v = G1(wo) max(0, wo.h) D(h) / cos_o (Heitz 2018) */
    double G1 = 1.0 / (1.0 + mf_smith_lambda(alpha, wo.z));
    double Dv = G1 * fmax(0.0, mf_dot(wo, h)) * mf_ggx_D(alpha, h.z) / wo.z;
    CHECK_NEAR(mf_brdf_pdf(&m, wo, wi, MF_LOBE_SPECULAR), Dv / (4.0 * mf_dot(wo, h)), 1e-5 * Dv / (4.0 * mf_dot(wo, h)));
    CHECK_NEAR(mf_brdf_pdf(&m, wo, wi, MF_LOBE_DIFFUSE), wi.z / M_PI, 1e-7);
    float pdm = mf_brdf_p_diffuse(&m, wo, MF_LOBE_ALL);
    CHECK_NEAR(mf_brdf_pdf(&m, wo, wi, MF_LOBE_ALL),
               pdm * mf_brdf_pdf(&m, wo, wi, MF_LOBE_DIFFUSE) + (1 - pdm) * mf_brdf_pdf(&m, wo, wi, MF_LOBE_SPECULAR), 1e-6);
    /* lobe masks and the lobe probability */
    MfBrdfValue vd = mf_brdf_eval(&m, wo, wi, MF_LOBE_DIFFUSE);
    CHECK(vd.specular.x == 0.0f && vd.diffuse.x == v.diffuse.x);
    MfBrdfValue vs = mf_brdf_eval(&m, wo, wi, MF_LOBE_SPECULAR);
    CHECK(vs.diffuse.x == 0.0f && vs.diffuse_demod == 0.0f && vs.specular.x == v.specular.x);
    MfVec3 Fo = mf_fresnel_schlick(f0, wo.z);
    double wd = 0.6 * mf_lum(m.kd), ws = mf_lum(Fo);
    CHECK_NEAR(mf_brdf_p_diffuse(&m, wo, MF_LOBE_ALL), wd / (wd + ws), 1e-6);
    CHECK(mf_brdf_p_diffuse(&m, wo, MF_LOBE_DIFFUSE) == 1.0f);
    CHECK(mf_brdf_p_diffuse(&m, wo, MF_LOBE_SPECULAR) == 0.0f);
    /* below the horizon: zero */
    MfVec3 down = mf_v3(0.0f, 0.6f, -0.8f);
    MfBrdfValue z = mf_brdf_eval(&m, wo, down, MF_LOBE_ALL);
    CHECK(z.diffuse.x == 0.0f && z.specular.x == 0.0f && mf_brdf_pdf(&m, wo, down, MF_LOBE_ALL) == 0.0f);
    z = mf_brdf_eval(&m, down, wo, MF_LOBE_ALL);
    CHECK(z.diffuse.x == 0.0f && z.specular.x == 0.0f && mf_brdf_pdf(&m, down, wo, MF_LOBE_ALL) == 0.0f);
}

MF_TEST(brdf_reciprocity) {
    MfRng rng;
    mf_rng_seed(&rng, 1234, 1);
    int bad = 0;
    for (int it = 0; it < 20000; ++it) {
        MfMaterial m = mat3(mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng));
        MfVec3 a = dir_from(0.01f + 0.99f * mf_rng_float(&rng), 2 * MF_PI * mf_rng_float(&rng));
        MfVec3 b = dir_from(0.01f + 0.99f * mf_rng_float(&rng), 2 * MF_PI * mf_rng_float(&rng));
        MfBrdfValue ab = mf_brdf_eval(&m, a, b, MF_LOBE_ALL), ba = mf_brdf_eval(&m, b, a, MF_LOBE_ALL);
        float fab[3] = {(ab.diffuse.x + ab.specular.x) / b.z, (ab.diffuse.y + ab.specular.y) / b.z, (ab.diffuse.z + ab.specular.z) / b.z};
        float fba[3] = {(ba.diffuse.x + ba.specular.x) / a.z, (ba.diffuse.y + ba.specular.y) / a.z, (ba.diffuse.z + ba.specular.z) / a.z};
        for (int c = 0; c < 3; ++c)
            if (!(fabsf(fab[c] - fba[c]) <= 1e-4f * fmaxf(fabsf(fab[c]), 1e-3f))) {
                if (bad++ < 5) CHECK_MSG(0, "f(wo,wi) %g != f(wi,wo) %g (roughness %g)", fab[c], fba[c], m.roughness);
            }
    }
    CHECK(bad == 0);
}

MF_TEST(brdf_energy) {
    /* White furnace of the diffuse lobe: kd = 1, m = 0 integrates to exactly 1. */
    MfMaterial white = mat3(1, 1, 1, 0.5f, 0.0f);
    MfRng rng;
    mf_rng_seed(&rng, 77, 2);
    for (int i = 0; i < 10000; ++i) {
        MfVec3 wo = dir_from(0.05f + 0.95f * mf_rng_float(&rng), 0.3f), wi;
        float pdf;
        if (mf_brdf_sample(&white, wo, mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), MF_LOBE_DIFFUSE, &wi, &pdf)) {
            MfBrdfValue v = mf_brdf_eval(&white, wo, wi, MF_LOBE_DIFFUSE);
            if (!(fabsf(v.diffuse.x / pdf - 1.0f) < 1e-5f)) {
                CHECK_NEAR(v.diffuse.x / pdf, 1.0, 1e-5);
                break;
            }
        }
    }
    HemiCtx dc = {&white, dir_from(0.3f, 0.0f), MF_LOBE_DIFFUSE, 1, 2, 0};
    CHECK_NEAR(hemi_integral(&dc, 4, 8, 6), 1.0, 1e-6);

    /* Specular directional albedo with F = 1 (metallic, kd = 1): <= 1 for every roughness and
     * view angle. The VNDF estimator is F G / G1 <= 1 per sample; its mean is cross-checked
     * against adaptive quadrature of mf_brdf_eval (tolerance: 5 sigma of the MC mean + 2e-4). */
    float rough[] = {0.08f, 0.2f, 0.4f, 0.6f, 0.8f, 1.0f};
    float coss[] = {1.0f, 0.7f, 0.3f, 0.1f, 0.01f};
    for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 5; ++b) {
            MfMaterial m = mat3(1, 1, 1, rough[a], 1.0f);
            MfVec3 wo = dir_from(coss[b], 0.7f);
            int n = 20000;
            double s = 0.0, s2 = 0.0, worst = 0.0;
            for (int i = 0; i < n; ++i) {
                MfVec3 wi;
                float pdf;
                double est = 0.0;
                if (mf_brdf_sample(&m, wo, mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), MF_LOBE_SPECULAR, &wi, &pdf))
                    est = mf_brdf_eval(&m, wo, wi, MF_LOBE_SPECULAR).specular.x / pdf;
                s += est;
                s2 += est * est;
                worst = fmax(worst, est);
            }
            double mean = s / n, sigma = sqrt(fmax(s2 / n - mean * mean, 0.0) / n);
            CHECK_MSG(worst <= 1.0 + 1e-4, "r %g cos_o %g: a sample weight %g > 1", rough[a], coss[b], worst);
            CHECK_MSG(mean <= 1.0 + 5 * sigma + 1e-4, "r %g cos_o %g: albedo %g > 1", rough[a], coss[b], mean);
            HemiCtx qc = {&m, wo, MF_LOBE_SPECULAR, 4, 1, 1};
            double quad = hemi_integral(&qc, 8, 16, 7);
            CHECK_MSG(fabs(quad - mean) <= 5 * sigma + 2e-4, "r %g cos_o %g: albedo MC %g vs quadrature %g (sigma %g)", rough[a], coss[b],
                      mean, quad, sigma);
            CHECK(quad <= 1.0 + 1e-4);
            if (a == 0 && b == 0) CHECK_MSG(quad > 0.99, "smooth mirror at normal incidence reflects %g", quad);
        }
}

MF_TEST(brdf_pdf_normalised) {
    /* int pdf over the upper hemisphere = 1 - P(sample rejected: specular reflection below the
     * horizon). P is estimated from 200k samples; tolerance 5 sigma + 5e-4 (quadrature). */
    /* full: no mass can be lost (diffuse, or a smooth lobe well above the horizon): integral = 1 */
    struct { MfMaterial m; float cos_o; int lobes, k, full; } cases[] = {
        {{{0.5f, 0.5f, 0.5f}, 0.5f, 0.0f}, 0.6f, MF_LOBE_DIFFUSE, 1, 1},
        {{{0.9f, 0.8f, 0.7f}, 0.0f, 1.0f}, 1.0f, MF_LOBE_SPECULAR, 4, 1}, /* roughness at the floor */
        {{{0.9f, 0.8f, 0.7f}, 0.08f, 0.0f}, 0.5f, MF_LOBE_ALL, 4, 1},      /* floor, off-normal */
        {{{0.9f, 0.8f, 0.7f}, 0.08f, 1.0f}, 0.02f, MF_LOBE_ALL, 4, 0},     /* floor, grazing */
        {{{0.2f, 0.5f, 0.7f}, 0.3f, 0.5f}, 0.8f, MF_LOBE_ALL, 4, 0},
        {{{0.2f, 0.5f, 0.7f}, 1.0f, 0.0f}, 0.2f, MF_LOBE_SPECULAR, 4, 0}, /* rough and grazing: mass lost */
        {{{0.8f, 0.8f, 0.8f}, 0.6f, 0.2f}, 0.05f, MF_LOBE_ALL, 4, 0},
    };
    MfRng rng;
    mf_rng_seed(&rng, 99, 3);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        MfVec3 wo = dir_from(cases[c].cos_o, 1.1f);
        HemiCtx qc = {&cases[c].m, wo, cases[c].lobes, cases[c].k, 0, cases[c].lobes != MF_LOBE_DIFFUSE};
        double integral = hemi_integral(&qc, 16, 16, 7);
        int n = 200000, fail = 0;
        for (int i = 0; i < n; ++i) {
            MfVec3 wi;
            float pdf;
            fail += !mf_brdf_sample(&cases[c].m, wo, mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), cases[c].lobes, &wi, &pdf);
        }
        double pf = (double)fail / n, sig = sqrt(fmax(pf * (1 - pf), 1.0 / n) / n);
        CHECK_MSG(fabs(integral - (1.0 - pf)) <= 5 * sig + 5e-4, "case %zu: int pdf = %.6f, accepted fraction %.6f", c, integral, 1.0 - pf);
        if (cases[c].full) CHECK_MSG(fabs(integral - 1.0) < 2e-3, "case %zu: int pdf = %.6f", c, integral);
    }
}

/* Chi-square of mf_brdf_sample against mf_brdf_pdf: ns x np cells in (s, phi) (cos = 1 - s^k)
 * plus one cell for rejected samples (expected N (1 - int pdf)). */
static double brdf_chi2(const MfMaterial *m, MfVec3 wo, int lobes, int k, int n, uint64_t seed, int *dof) {
    enum { NS = 32, NP = 64 };
    double *obs = calloc(NS * NP + 1, sizeof(double)), *expc = calloc(NS * NP + 1, sizeof(double));
    HemiCtx qc = {m, wo, lobes, k, 0, 0};
    double total = 0.0;
    for (int i = 0; i < NS; ++i)
        for (int j = 0; j < NP; ++j) {
            double p = mf_quad2d(hemi_integrand, &qc, (double)i / NS, (double)(i + 1) / NS, 2 * M_PI * j / NP, 2 * M_PI * (j + 1) / NP,
                                 1e-8, 1, 8);
            expc[i * NP + j] = p * n;
            total += p;
        }
    expc[NS * NP] = fmax(0.0, 1.0 - total) * n;
    MfRng rng;
    mf_rng_seed(&rng, seed, 4);
    for (int t = 0; t < n; ++t) {
        MfVec3 wi;
        float pdf;
        if (!mf_brdf_sample(m, wo, mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), lobes, &wi, &pdf)) {
            obs[NS * NP] += 1;
            continue;
        }
        double s = pow(fmax(0.0, 1.0 - wi.z), 1.0 / k);
        double phi = atan2(wi.y, wi.x);
        if (phi < 0) phi += 2 * M_PI;
        int i = (int)(s * NS), j = (int)(phi / (2 * M_PI) * NP);
        i = i < 0 ? 0 : (i >= NS ? NS - 1 : i);
        j = j < 0 ? 0 : (j >= NP ? NP - 1 : j);
        obs[i * NP + j] += 1;
    }
    double chi2;
    double p = mf_chi2_test(obs, expc, NS * NP + 1, &chi2, dof);
    free(obs);
    free(expc);
    return p;
}

MF_TEST(brdf_sample_chi2) {
    struct { MfMaterial m; float cos_o; int lobes, k; } cases[] = {
        {{{0.5f, 0.4f, 0.3f}, 0.5f, 0.0f}, 0.7f, MF_LOBE_DIFFUSE, 1},
        {{{0.9f, 0.9f, 0.9f}, 0.08f, 1.0f}, 1.0f, MF_LOBE_SPECULAR, 4},
        {{{0.9f, 0.9f, 0.9f}, 0.08f, 1.0f}, 0.6f, MF_LOBE_SPECULAR, 1},
        {{{0.9f, 0.6f, 0.3f}, 0.3f, 1.0f}, 0.9f, MF_LOBE_SPECULAR, 2},
        {{{0.9f, 0.6f, 0.3f}, 0.5f, 0.0f}, 0.3f, MF_LOBE_SPECULAR, 1},
        {{{0.9f, 0.6f, 0.3f}, 1.0f, 1.0f}, 0.1f, MF_LOBE_SPECULAR, 1},
        {{{0.6f, 0.4f, 0.2f}, 0.5f, 0.3f}, 0.5f, MF_LOBE_ALL, 1},
        {{{0.8f, 0.8f, 0.8f}, 0.2f, 0.0f}, 0.9f, MF_LOBE_ALL, 1},
        {{{0.3f, 0.7f, 0.5f}, 0.08f, 0.5f}, 0.3f, MF_LOBE_ALL, 1},
        {{{0.0f, 0.0f, 0.0f}, 0.4f, 0.0f}, 0.8f, MF_LOBE_ALL, 1}, /* black dielectric: specular only */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        int dof;
        double p = brdf_chi2(&cases[c].m, dir_from(cases[c].cos_o, 0.4f), cases[c].lobes, cases[c].k, 200000, 1000 + c, &dof);
        CHECK_MSG(p > 0.01, "case %zu (r %g m %g cos_o %g lobes %d): chi-square p = %g (dof %d)", c, cases[c].m.roughness,
                  cases[c].m.metallic, cases[c].cos_o, cases[c].lobes, p, dof);
        CHECK(dof > 3);
    }
}

MF_TEST(brdf_sample_chi2_detects_bugs) {
    /* The test has power: a pdf that is wrong by a few percent (roughness 0.5 sampled, pdf of
     * roughness 0.52) must fail it. Sample with one material, compare with another's pdf. */
    enum { NS = 32, NP = 64, N = 200000 };
    MfMaterial ms = mat3(0.9f, 0.9f, 0.9f, 0.5f, 1.0f), mp = mat3(0.9f, 0.9f, 0.9f, 0.52f, 1.0f);
    MfVec3 wo = dir_from(0.6f, 0.4f);
    double *obs = calloc(NS * NP + 1, sizeof(double)), *expc = calloc(NS * NP + 1, sizeof(double));
    HemiCtx qc = {&mp, wo, MF_LOBE_SPECULAR, 1, 0, 0};
    double total = 0.0;
    for (int i = 0; i < NS; ++i)
        for (int j = 0; j < NP; ++j) {
            double p = mf_quad2d(hemi_integrand, &qc, (double)i / NS, (double)(i + 1) / NS, 2 * M_PI * j / NP, 2 * M_PI * (j + 1) / NP, 1e-9, 1, 8);
            expc[i * NP + j] = p * N;
            total += p;
        }
    expc[NS * NP] = fmax(0.0, 1.0 - total) * N;
    MfRng rng;
    mf_rng_seed(&rng, 5, 5);
    for (int t = 0; t < N; ++t) {
        MfVec3 wi;
        float pdf;
        if (!mf_brdf_sample(&ms, wo, mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), MF_LOBE_SPECULAR, &wi, &pdf)) {
            obs[NS * NP] += 1;
            continue;
        }
        double phi = atan2(wi.y, wi.x);
        if (phi < 0) phi += 2 * M_PI;
        int i = (int)((1.0 - wi.z) * NS), j = (int)(phi / (2 * M_PI) * NP);
        i = i >= NS ? NS - 1 : i;
        j = j >= NP ? NP - 1 : j;
        obs[i * NP + j] += 1;
    }
    double p = mf_chi2_test(obs, expc, NS * NP + 1, NULL, NULL);
    CHECK_MSG(p < 1e-6, "a 4%% roughness error was not detected (p = %g)", p);
    free(obs);
    free(expc);
}

MF_TEST(brdf_hard_cases) {
    float roughs[] = {0.0f, -1.0f, 0.08f, 1.0f, 2.0f};
    float metals[] = {0.0f, 1.0f, 0.5f};
    float kds[] = {0.0f, 1.0f, 0.3f};
    float coss[] = {1e-4f, 1e-3f, 0.5f, 1.0f};
    float us[] = {0.0f, 0x1.fffffep-1f, 0.5f, 1e-7f};
    int bad = 0, nsamp = 0;
    for (int a = 0; a < 5; ++a)
        for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c)
                for (int d = 0; d < 4; ++d) {
                    MfMaterial m = mat3(kds[c], kds[c], kds[c], roughs[a], metals[b]);
                    MfVec3 wo = dir_from(coss[d], 0.3f);
                    float pd = mf_brdf_p_diffuse(&m, wo, MF_LOBE_ALL);
                    bad += !(pd >= 0.0f && pd <= 1.0f);
                    for (int e = 0; e < 4; ++e)
                        for (int f = 0; f < 4; ++f)
                            for (int g = 0; g < 4; ++g)
                                for (int lobes = 1; lobes <= 3; ++lobes) {
                                    MfVec3 wi;
                                    float pdf;
                                    if (mf_brdf_sample(&m, wo, us[e], us[f], us[g], lobes, &wi, &pdf)) {
                                        ++nsamp;
                                        MfBrdfValue v = mf_brdf_eval(&m, wo, wi, lobes);
                                        bad += !(isfinite(pdf) && pdf > 0.0f && mf_isfinite3(wi) && fabsf(mf_len(wi) - 1.0f) < 1e-4f && wi.z > 0.0f);
                                        bad += !(mf_isfinite3(v.diffuse) && mf_isfinite3(v.specular) && isfinite(v.diffuse_demod));
                                        float pp = mf_brdf_pdf(&m, wo, wi, lobes);
                                        bad += !(fabsf(pp - pdf) <= 1e-6f * pdf);
                                    }
                                    MfVec3 wi2 = dir_from(coss[(d + e) % 4], 1.0f + f);
                                    MfBrdfValue v = mf_brdf_eval(&m, wo, wi2, lobes);
                                    float p2 = mf_brdf_pdf(&m, wo, wi2, lobes);
                                    bad += !(mf_isfinite3(v.diffuse) && mf_isfinite3(v.specular) && isfinite(p2) && p2 >= 0.0f);
                                }
                    if (bad) {
                        CHECK_MSG(0, "non-finite output for r %g m %g kd %g cos_o %g", roughs[a], metals[b], kds[c], coss[d]);
                        return;
                    }
                }
    CHECK(nsamp > 1000);
    /* roughness below the floor is the floor */
    MfMaterial r0 = mat3(0.5f, 0.5f, 0.5f, 0.0f, 0.5f), rf = mat3(0.5f, 0.5f, 0.5f, MF_MIN_ROUGHNESS, 0.5f);
    MfVec3 wo = dir_from(0.7f, 0.0f), wi = mf_v3(-wo.x, -wo.y, wo.z);
    CHECK(mf_brdf_eval(&r0, wo, wi, MF_LOBE_ALL).specular.x == mf_brdf_eval(&rf, wo, wi, MF_LOBE_ALL).specular.x);
    CHECK(mf_brdf_eval(&r0, wo, wi, MF_LOBE_ALL).specular.x > 100.0f); /* mirror peak */
    /* black metal: all specular, still samples */
    MfMaterial bm = mat3(0, 0, 0, 0.3f, 1.0f);
    CHECK(mf_brdf_p_diffuse(&bm, mf_v3(0, 0, 1), MF_LOBE_ALL) == 0.0f);
    float pdf;
    CHECK(mf_brdf_sample(&bm, mf_v3(0, 0, 1), 0.5f, 0.3f, 0.3f, MF_LOBE_ALL, &wi, &pdf) == 1);
    /* invalid wo */
    CHECK(mf_brdf_sample(&bm, mf_v3(0, 0.6f, -0.8f), 0.5f, 0.3f, 0.3f, MF_LOBE_ALL, &wi, &pdf) == 0);
}

/* <gd, diffuse> + <gs, specular> of mf_brdf_eval */
typedef struct {
    const MfMaterial *m;
    MfVec3 wo, wi, gd, gs;
    int lobes;
} EvalCtx;

static double eval_loss(void *ctx) {
    const EvalCtx *c = ctx;
    MfBrdfValue v = mf_brdf_eval(c->m, c->wo, c->wi, c->lobes);
    return mf_dot(c->gd, v.diffuse) + (double)mf_dot(c->gs, v.specular);
}

/* mf_brdf_eval_backward against central differences (double-precision steps on float code:
 * step 1e-3, tolerance 2e-3 relative + absolute floor). */
MF_TEST(brdf_eval_backward) {
    MfRng rng;
    mf_rng_seed(&rng, 2024, 9);
    int bad = 0;
    for (int it = 0; it < 300; ++it) {
        MfMaterial m = mat3(mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng), 0.15f + 0.8f * mf_rng_float(&rng),
                            0.05f + 0.9f * mf_rng_float(&rng));
        MfVec3 wo = dir_from(0.2f + 0.8f * mf_rng_float(&rng), 2 * MF_PI * mf_rng_float(&rng));
        MfVec3 wi = dir_from(0.2f + 0.8f * mf_rng_float(&rng), 2 * MF_PI * mf_rng_float(&rng));
        MfVec3 gd = mf_v3(mf_rng_normal(&rng), mf_rng_normal(&rng), mf_rng_normal(&rng));
        MfVec3 gs = mf_v3(mf_rng_normal(&rng), mf_rng_normal(&rng), mf_rng_normal(&rng));
        int lobes = 1 + it % 3;
        MfMaterial g = {mf_v3s(0), 0, 0};
        mf_brdf_eval_backward(&m, wo, wi, lobes, gd, gs, &g);
        float *params[5] = {&m.kd.x, &m.kd.y, &m.kd.z, &m.roughness, &m.metallic};
        float grads[5] = {g.kd.x, g.kd.y, g.kd.z, g.roughness, g.metallic};
        EvalCtx c = {&m, wo, wi, gd, gs, lobes};
        for (int k = 0; k < 5; ++k) {
            double fd = mf_test_fd(eval_loss, &c, params[k], 0, 1e-3f);
            if (!(fabs(fd - grads[k]) <= 2e-3 * fabs(fd) + 2e-3)) {
                if (bad++ < 5) CHECK_MSG(0, "param %d (lobes %d, r %g): adjoint %g vs finite difference %g", k, lobes, m.roughness, grads[k], fd);
            }
        }
    }
    CHECK(bad == 0);
    /* clamped parameters get no gradient; accumulation is += */
    MfMaterial m = mat3(0.5f, 0.5f, 0.5f, 0.01f, 1.5f), g = {mf_v3s(1.0f), 1.0f, 1.0f};
    mf_brdf_eval_backward(&m, dir_from(0.7f, 0), dir_from(0.6f, 3.0f), MF_LOBE_ALL, mf_v3s(1), mf_v3s(1), &g);
    CHECK(g.roughness == 1.0f && g.metallic == 1.0f);
}

/* Fast path: the BRDF context (mf_brdf_prepare, mf_brdf_ctx_eval_pdf, mf_brdf_ctx_sample) must
 * return exactly (bitwise) what mf_brdf_eval / _pdf / _sample return. */

static int same_value(MfBrdfValue a, MfBrdfValue b) {
    return same3(a.diffuse, b.diffuse) && same3(a.specular, b.specular) && memcmp(&a.diffuse_demod, &b.diffuse_demod, sizeof(float)) == 0;
}

static MfVec3 random_dir(MfRng *rng, int upper) {
    float z = upper ? mf_rng_float(rng) : 2.0f * mf_rng_float(rng) - 1.0f, phi = 2.0f * MF_PI * mf_rng_float(rng);
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return mf_v3(r * cosf(phi), r * sinf(phi), z);
}

MF_TEST(fastpath_brdf_ctx_matches_plain) {
    MfRng rng;
    mf_rng_seed(&rng, 17, 3);
    int bad_eval = 0, bad_pdf = 0, bad_sample = 0, n_ok = 0;
    for (int m = 0; m < 400; ++m) {
        MfMaterial mat = {mf_v3(mf_rng_float(&rng), mf_rng_float(&rng), mf_rng_float(&rng)), mf_rng_float(&rng),
                          mf_rng_float(&rng)};
        if (m % 7 == 0) mat.roughness = 0.0f;               /* roughness floor */
        if (m % 11 == 0) mat.kd = mf_v3s(0.0f);             /* black: always specular */
        if (m % 13 == 0) mat.metallic = m % 2 ? 1.0f : 1.3f; /* out of range is clamped */
        if (m % 17 == 0) mat.roughness = -0.5f;
        int lobes = 1 + m % 3;
        MfVec3 wo = random_dir(&rng, m % 9 != 0); /* some below the horizon */
        if (m % 23 == 0) wo = mf_norm(mf_v3(1.0f, 0.0f, 1e-4f)); /* grazing */
        MfBrdfCtx c;
        mf_brdf_prepare(&c, &mat, wo, lobes);
        for (int k = 0; k < 50; ++k) {
            MfVec3 wi = random_dir(&rng, k % 5 != 0);
            if (k == 0) wi = mf_v3(-wo.x, -wo.y, wo.z); /* mirror direction: h = n */
            float p;
            MfBrdfValue v = mf_brdf_ctx_eval_pdf(&c, wi, &p);
            if (!same_value(v, mf_brdf_eval(&mat, wo, wi, lobes))) ++bad_eval;
            float pp = mf_brdf_pdf(&mat, wo, wi, lobes);
            if (memcmp(&p, &pp, sizeof p) != 0) ++bad_pdf;
            float u0 = mf_rng_float(&rng), u1 = mf_rng_float(&rng), u2 = mf_rng_float(&rng);
            MfVec3 w1, w2;
            float p1, p2;
            MfBrdfValue f;
            int r1 = mf_brdf_sample(&mat, wo, u0, u1, u2, lobes, &w1, &p1);
            int r2 = mf_brdf_ctx_sample(&c, u0, u1, u2, &w2, &p2, &f);
            if (r1 != r2) ++bad_sample;
            else if (r1) {
                ++n_ok;
                if (!same3(w1, w2) || p1 != p2 || !same_value(f, mf_brdf_eval(&mat, wo, w2, lobes))) ++bad_sample;
            }
        }
    }
    CHECK_MSG(bad_eval == 0, "%d BRDF values differ", bad_eval);
    CHECK_MSG(bad_pdf == 0, "%d BRDF pdfs differ", bad_pdf);
    CHECK_MSG(bad_sample == 0, "%d BRDF samples differ", bad_sample);
    CHECK(n_ok > 5000);
}
