/* Tests of the renderer's fast paths: they must return exactly (bitwise) what the plain
 * functions return. mf_env_sample_dir / _n (guide tables, per-row tables, staged prefetches)
 * against a copy of the original one-sample code (full binary searches, trig per call);
 * mf_env_eval_pdf / _n against mf_env_eval + mf_env_pdf; the BRDF context (mf_brdf_prepare,
 * mf_brdf_ctx_eval_pdf, mf_brdf_ctx_sample) against mf_brdf_eval / _pdf / _sample. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "mf_test.h"
#include "render/mf_brdf.h"
#include "scene/mf_envmap.h"

/* ---- reference: the original mf_env_sample (before the fast paths) ---- */

static int ref_cdf_find(const float *cdf, int n, float u) {
    int lo = 0, hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) >> 1;
        if (cdf[mid] <= u) lo = mid;
        else hi = mid;
    }
    return lo;
}

static double ref_row_dz(int y, int H) { return 2.0 * sin(M_PI * (2.0 * y + 1.0) / (2.0 * H)) * sin(M_PI / (2.0 * H)); }

static float ref_texel_pdf(const MfEnvMap *env, int x, int y) {
    int W = env->img.w, H = env->img.h;
    const float *cc = env->cond_cdf + (size_t)y * (W + 1);
    double p = ((double)env->marg_cdf[y + 1] - env->marg_cdf[y]) * ((double)cc[x + 1] - cc[x]);
    return (float)(p * W / (2.0 * M_PI * ref_row_dz(y, H)));
}

static void ref_sample(const MfEnvMap *env, float u1, float u2, MfVec3 *dir, float *pdf) {
    int W = env->img.w, H = env->img.h;
    u1 = mf_clampf(u1, 0.0f, 0x1.fffffep-1f);
    u2 = mf_clampf(u2, 0.0f, 0x1.fffffep-1f);
    int y = ref_cdf_find(env->marg_cdf, H, u1);
    const float *cc = env->cond_cdf + (size_t)y * (W + 1);
    int x = ref_cdf_find(cc, W, u2);
    double ty = ((double)u1 - env->marg_cdf[y]) / ((double)env->marg_cdf[y + 1] - env->marg_cdf[y]);
    double tx = ((double)u2 - cc[x]) / ((double)cc[x + 1] - cc[x]);
    ty = ty < 0.0 ? 0.0 : (ty > 1.0 ? 1.0 : ty);
    tx = tx < 0.0 ? 0.0 : (tx > 1.0 ? 1.0 : tx);
    double ztop = cos(M_PI * y / H);
    double z = ztop - ty * ref_row_dz(y, H);
    if (z > 1.0) z = 1.0;
    if (z < -1.0) z = -1.0;
    double u = (x + tx) / W;
    double phi = M_PI - 2.0 * M_PI * u;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    *dir = mf_v3((float)(r * cos(phi)), (float)(r * sin(phi)), (float)z);
    *pdf = ref_texel_pdf(env, x, y);
}

static int same3(MfVec3 a, MfVec3 b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Extreme dynamic range (a 1e9 sun over black and 1e-3 texels) so that many float CDF entries
 * repeat (zero-width intervals) and the guide intervals are degenerate. */
static void harsh_env(MfEnvMap *env, int w, int h, uint64_t seed) {
    MfImage img = {0};
    CHECK_OK(mf_image_alloc(&img, w, h, 3));
    MfRng rng;
    mf_rng_seed(&rng, seed, 5);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float *p = mf_image_px(&img, x, y);
            float v = mf_rng_float(&rng) < 0.3f ? 0.0f : powf(10.0f, -3.0f + 5.0f * mf_rng_float(&rng));
            p[0] = v;
            p[1] = 0.5f * v;
            p[2] = 0.25f * v;
        }
    float *sun = mf_image_px(&img, w / 5, h / 3);
    sun[0] = sun[1] = sun[2] = 1e9f;
    CHECK_OK(mf_env_init(env, &img));
}

/* u values that hit table boundaries exactly: 0, 1 - ulp, k / 2^m, and the CDF entries. */
static float probe_u(const MfEnvMap *env, MfRng *rng, int i, int row) {
    int W = env->img.w;
    switch (i % 5) {
    case 0: return mf_rng_float(rng);
    case 1: return (float)(i % 97) / 96.0f * 0x1.fffffep-1f;
    case 2: return ldexpf((float)(i % 64), -6);
    case 3: return env->marg_cdf[i % (env->img.h + 1)];
    default: return env->cond_cdf[(size_t)row * (W + 1) + (size_t)(i % (W + 1))];
    }
}

MF_TEST(fastpath_env_sampling_matches_reference) {
    const int sizes[][2] = {{1, 1}, {7, 3}, {64, 32}, {333, 129}, {1024, 512}};
    for (int s = 0; s < 5; ++s) {
        MfEnvMap env;
        harsh_env(&env, sizes[s][0], sizes[s][1], 40 + s);
        MfRng rng;
        mf_rng_seed(&rng, 9, (uint64_t)s);
        enum { N = 3000 };
        static float u1[N], u2[N], pdf[N];
        static MfVec3 dir[N];
        int bad = 0, bad_n = 0;
        for (int i = 0; i < N; ++i) {
            int row = (int)mf_rng_below(&rng, (uint32_t)env.img.h);
            u1[i] = probe_u(&env, &rng, i, row);
            u2[i] = probe_u(&env, &rng, i / 5 + 3 * i, row);
            MfVec3 dr, d1;
            float pr, p1;
            ref_sample(&env, u1[i], u2[i], &dr, &pr);
            mf_env_sample_dir(&env, u1[i], u2[i], &d1, &p1);
            if (!same3(dr, d1) || pr != p1) ++bad;
            MfVec3 L = mf_env_sample(&env, u1[i], u2[i], &d1, &p1), Lr = mf_env_eval(&env, dr);
            if (!same3(dr, d1) || pr != p1 || !same3(L, Lr)) ++bad;
        }
        mf_env_sample_dir_n(&env, N, u1, u2, dir, pdf);
        for (int i = 0; i < N; ++i) {
            MfVec3 dr;
            float pr;
            ref_sample(&env, u1[i], u2[i], &dr, &pr);
            if (!same3(dr, dir[i]) || pr != pdf[i]) ++bad_n;
        }
        CHECK_MSG(bad == 0, "%dx%d: %d single samples differ from the reference", sizes[s][0], sizes[s][1], bad);
        CHECK_MSG(bad_n == 0, "%dx%d: %d batched samples differ from the reference", sizes[s][0], sizes[s][1], bad_n);
        /* the tables follow mf_env_update after the texels change */
        mf_image_px(&env.img, 0, env.img.h - 1)[0] = 5e9f;
        CHECK_OK(mf_env_update(&env));
        bad = 0;
        for (int i = 0; i < N; ++i) {
            MfVec3 dr, d1;
            float pr, p1;
            ref_sample(&env, u1[i], u2[i], &dr, &pr);
            mf_env_sample_dir(&env, u1[i], u2[i], &d1, &p1);
            if (!same3(dr, d1) || pr != p1) ++bad;
        }
        CHECK_MSG(bad == 0, "%dx%d after update: %d samples differ", sizes[s][0], sizes[s][1], bad);
        mf_env_free(&env);
    }
}

MF_TEST(fastpath_env_eval_pdf_matches_plain) {
    MfEnvMap env;
    harsh_env(&env, 96, 48, 7);
    MfRng rng;
    mf_rng_seed(&rng, 2, 2);
    enum { N = 5000 };
    static MfVec3 d[N], L[N], L2[N];
    static float pdf[N];
    for (int i = 0; i < N; ++i) {
        float z = 2.0f * mf_rng_float(&rng) - 1.0f, phi = 2.0f * MF_PI * mf_rng_float(&rng);
        if (i % 50 == 0) z = (i % 100 == 0) ? 1.0f : -1.0f; /* poles */
        float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        d[i] = mf_v3(r * cosf(phi), r * sinf(phi), z);
    }
    mf_env_eval_pdf_n(&env, N, d, L, pdf);
    mf_env_eval_pdf_n(&env, N, d, L2, NULL);
    int bad = 0;
    for (int i = 0; i < N; ++i) {
        float p1;
        MfVec3 l1 = mf_env_eval_pdf(&env, d[i], &p1), le = mf_env_eval(&env, d[i]);
        float pe = mf_env_pdf(&env, d[i]);
        if (!same3(le, l1) || !same3(le, L[i]) || !same3(le, L2[i]) || pe != p1 || pe != pdf[i]) ++bad;
    }
    CHECK_MSG(bad == 0, "%d of %d lookups differ", bad, N);
    mf_env_eval_pdf_n(&env, 0, d, L, pdf); /* empty batch is fine */
    mf_env_free(&env);
}

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
