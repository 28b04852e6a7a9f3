/* mf_envmap: equirectangular env light, Blender mapping, importance sampling (see mf_envmap.h).
 *
 * Sampling tables. Texel (x, y) covers u in [x/W, (x+1)/W] and the row band y in
 * [y/H, (y+1)/H] of 1 - v, i.e. z = cos(theta) in [cos(pi (y+1)/H), cos(pi y/H)]. Its weight is
 * (max(R, G, B) + floor) * sin(theta_c) with theta_c = pi (y + 0.5) / H; floor = 1e-4 * mean of
 * max(R, G, B) (or 1 for an all-black map) keeps every direction reachable, so light sampling
 * alone is unbiased even where the bilinear lookup bleeds into a black texel. A texel is chosen
 * from the CDFs, then a point uniform in solid angle inside it (uniform in u and in z), so the
 * density is constant per texel:  pdf = P(texel) / Omega(texel),
 *   Omega(texel) = (2 pi / W) (cos(pi y/H) - cos(pi (y+1)/H))
 * and is finite everywhere, poles included. P(texel) is read back from the same float CDFs the
 * sampler searches, so mf_env_pdf is exactly the density mf_env_sample draws with. */
#include "scene/mf_envmap.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

#define ENV_FLOOR_REL 1e-4

void mf_env_dir_to_uv(MfVec3 d, float *u, float *v) {
    float uu = 0.5f - atan2f(d.y, d.x) * MF_INV_2PI;
    if (uu >= 1.0f) uu -= 1.0f;
    if (uu < 0.0f) uu += 1.0f;
    *u = uu;
    *v = 0.5f + asinf(mf_clampf(d.z, -1.0f, 1.0f)) * MF_INV_PI;
}

MfVec3 mf_env_uv_to_dir(float u, float v) {
    float phi = MF_PI - 2.0f * MF_PI * u;
    float lat = MF_PI * (v - 0.5f);
    float r = cosf(lat);
    return mf_v3(r * cosf(phi), r * sinf(phi), sinf(lat));
}

/* Bilinear footprint of (u, v): 4 texel indices (into h*w) and weights. */
static inline void env_footprint_uv(const MfEnvMap *env, float u, float v, size_t idx[4], float wt[4]) {
    int W = env->img.w, H = env->img.h;
    float x = u * (float)W - 0.5f, y = (1.0f - v) * (float)H - 0.5f;
    if (!isfinite(x)) x = 0.0f;
    if (!isfinite(y)) y = 0.0f;
    float fx = floorf(x), fy = floorf(y);
    float tx = x - fx, ty = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    int x1 = x0 + 1, y1 = y0 + 1;
    x0 %= W;
    if (x0 < 0) x0 += W;
    x1 %= W;
    if (x1 < 0) x1 += W;
    y0 = y0 < 0 ? 0 : (y0 >= H ? H - 1 : y0);
    y1 = y1 < 0 ? 0 : (y1 >= H ? H - 1 : y1);
    idx[0] = (size_t)y0 * W + x0;
    idx[1] = (size_t)y0 * W + x1;
    idx[2] = (size_t)y1 * W + x0;
    idx[3] = (size_t)y1 * W + x1;
    wt[0] = (1.0f - tx) * (1.0f - ty);
    wt[1] = tx * (1.0f - ty);
    wt[2] = (1.0f - tx) * ty;
    wt[3] = tx * ty;
}

/* Bilinear footprint of direction d. */
static inline void env_footprint(const MfEnvMap *env, MfVec3 d, size_t idx[4], float wt[4]) {
    float u, v;
    mf_env_dir_to_uv(d, &u, &v);
    env_footprint_uv(env, u, v, idx, wt);
}

static inline MfVec3 env_lookup(const MfEnvMap *env, const size_t idx[4], const float wt[4]) {
    const float *p = env->img.data;
    MfVec3 r = mf_v3s(0.0f);
    for (int k = 0; k < 4; ++k) r = mf_add(r, mf_scale(mf_v3(p[idx[k] * 3], p[idx[k] * 3 + 1], p[idx[k] * 3 + 2]), wt[k]));
    return r;
}

MfVec3 mf_env_eval(const MfEnvMap *env, MfVec3 d) {
    size_t idx[4];
    float wt[4];
    env_footprint(env, d, idx, wt);
    return env_lookup(env, idx, wt);
}

void mf_env_eval_backward(const MfEnvMap *env, MfVec3 d, MfVec3 dL, float *dimg) {
    size_t idx[4];
    float wt[4];
    env_footprint(env, d, idx, wt);
    for (int k = 0; k < 4; ++k) {
        float *g = dimg + idx[k] * 3;
        g[0] += wt[k] * dL.x;
        g[1] += wt[k] * dL.y;
        g[2] += wt[k] * dL.z;
    }
}

/* Solid angle of one texel of row y divided by (2 pi / W): cos(pi y/H) - cos(pi (y+1)/H). */
static double row_dz(int y, int H) { return 2.0 * sin(M_PI * (2.0 * y + 1.0) / (2.0 * H)) * sin(M_PI / (2.0 * H)); }

/* Smallest power of two >= n / 8 (so a guide interval spans about 8 CDF entries on average). */
static int guide_size(int n) {
    int k = 1;
    while (k < 65536 && k * 8 < n) k *= 2;
    return k;
}

/* guide[k] = cdf_find(cdf, n, k / K) for k < K, guide[K] = n - 1: the entry u = k / K draws.
 * Requires cdf nondecreasing with cdf[0] = 0 and cdf[n] = 1. */
static void build_guide(const float *cdf, int n, int K, uint32_t *guide) {
    int i = 0;
    for (int k = 0; k < K; ++k) {
        float u = (float)k / (float)K;
        while (i < n - 1 && cdf[i + 1] <= u) ++i;
        guide[k] = (uint32_t)i;
    }
    guide[K] = (uint32_t)(n - 1);
}

/* Allocates the acceleration tables if missing and fills the per-row constants. */
static int env_alloc_tables(MfEnvMap *env) {
    int W = env->img.w, H = env->img.h;
    if (!env->row_tab) {
        env->row_tab = malloc(sizeof(double) * 2 * (size_t)H);
        if (!env->row_tab) return mf_fail(MF_ENOMEM, "env map: out of memory for sampling tables");
        for (int y = 0; y < H; ++y) {
            env->row_tab[2 * y] = cos(M_PI * y / H);
            env->row_tab[2 * y + 1] = row_dz(y, H);
        }
    }
    if (!env->marg_guide) {
        env->marg_k = guide_size(H);
        env->marg_guide = malloc(sizeof(uint32_t) * (size_t)(env->marg_k + 1));
        if (!env->marg_guide) return mf_fail(MF_ENOMEM, "env map: out of memory for sampling tables");
    }
    if (!env->cond_guide) {
        env->cond_k = guide_size(W);
        env->cond_guide = malloc(sizeof(uint32_t) * (size_t)H * (size_t)(env->cond_k + 1));
        if (!env->cond_guide) return mf_fail(MF_ENOMEM, "env map: out of memory for sampling tables");
    }
    return MF_OK;
}

int mf_env_update(MfEnvMap *env) {
    int W = env->img.w, H = env->img.h;
    int trc = env_alloc_tables(env);
    if (trc) return trc;
    const float *p = env->img.data;
    size_t n = (size_t)W * H;
    double mean = 0.0;
    for (size_t i = 0; i < n; ++i) {
        float m = fmaxf(p[3 * i], fmaxf(p[3 * i + 1], p[3 * i + 2]));
        if (!isfinite(m)) return mf_fail(MF_ENAN, "env map: texel %zu is not finite", i);
        mean += m > 0.0f ? m : 0.0f;
    }
    mean /= (double)n;
    double floor_w = mean > 0.0 ? ENV_FLOOR_REL * mean : 1.0;
    double *roww = malloc(sizeof(double) * (size_t)(W > H ? W : H));
    if (!roww) return mf_fail(MF_ENOMEM, "env map: out of memory for sampling tables");
    double total = 0.0;
    env->marg_cdf[0] = 0.0f;
    double *rowsum = malloc(sizeof(double) * (size_t)H);
    if (!rowsum) {
        free(roww);
        return mf_fail(MF_ENOMEM, "env map: out of memory for sampling tables");
    }
    for (int y = 0; y < H; ++y) {
        double st = sin(M_PI * (y + 0.5) / H);
        double acc = 0.0;
        float *cdf = env->cond_cdf + (size_t)y * (W + 1);
        for (int x = 0; x < W; ++x) {
            const float *t = p + ((size_t)y * W + x) * 3;
            double m = fmax(fmax(t[0], t[1]), t[2]);
            if (m < 0.0) m = 0.0;
            roww[x] = (m + floor_w) * st;
            acc += roww[x];
        }
        rowsum[y] = acc;
        total += acc;
        double c = 0.0;
        cdf[0] = 0.0f;
        for (int x = 0; x < W; ++x) {
            c += roww[x];
            cdf[x + 1] = (float)(c / acc);
        }
        cdf[W] = 1.0f;
    }
    double c = 0.0;
    for (int y = 0; y < H; ++y) {
        c += rowsum[y];
        env->marg_cdf[y + 1] = (float)(c / total);
    }
    env->marg_cdf[H] = 1.0f;
    env->total = total;
    build_guide(env->marg_cdf, H, env->marg_k, env->marg_guide);
    for (int y = 0; y < H; ++y)
        build_guide(env->cond_cdf + (size_t)y * (W + 1), W, env->cond_k, env->cond_guide + (size_t)y * (env->cond_k + 1));
    free(rowsum);
    free(roww);
    return MF_OK;
}

int mf_env_init(MfEnvMap *env, MfImage *img) {
    MfEnvMap e;
    memset(&e, 0, sizeof e);
    if (!img->data || img->w <= 0 || img->h <= 0 || img->c < 3) {
        int c = img->c;
        mf_image_free(img);
        return mf_fail(MF_EARG, "env map: need an image with at least 3 channels (got %d)", c);
    }
    int W = img->w, H = img->h, C = img->c;
    size_t n = (size_t)W * H;
    for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k)
            if (!isfinite(img->data[i * C + k])) {
                mf_image_free(img);
                return mf_fail(MF_ENAN, "env map: texel (%zu, %zu) is not finite", i % W, i / W);
            }
    if (C != 3) { /* compact to RGB in place */
        for (size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) img->data[i * 3 + k] = img->data[i * C + k];
        float *shrunk = realloc(img->data, sizeof(float) * n * 3);
        if (shrunk) img->data = shrunk;
        img->c = 3;
    }
    e.img = *img;
    memset(img, 0, sizeof *img);
    e.marg_cdf = malloc(sizeof(float) * (size_t)(H + 1));
    e.cond_cdf = malloc(sizeof(float) * (size_t)H * (W + 1));
    if (!e.marg_cdf || !e.cond_cdf) {
        mf_env_free(&e);
        return mf_fail(MF_ENOMEM, "env map: out of memory (%dx%d)", W, H);
    }
    int rc = mf_env_update(&e);
    if (rc) {
        mf_env_free(&e);
        return rc;
    }
    *env = e;
    return MF_OK;
}

int mf_env_init_constant(MfEnvMap *env, int w, int h, MfVec3 radiance) {
    MfImage img = {0};
    if (w <= 0 || h <= 0) return mf_fail(MF_EARG, "env map: size %dx%d is invalid", w, h);
    int rc = mf_image_alloc(&img, w, h, 3);
    if (rc) return rc;
    for (size_t i = 0; i < (size_t)w * h; ++i) {
        img.data[3 * i] = radiance.x;
        img.data[3 * i + 1] = radiance.y;
        img.data[3 * i + 2] = radiance.z;
    }
    return mf_env_init(env, &img);
}

int mf_env_load(MfEnvMap *env, const char *path) {
    MfImage img = {0};
    int rc = mf_image_read(path, MF_ENC_LINEAR, &img);
    if (rc) return rc;
    rc = mf_env_init(env, &img);
    if (rc) return mf_fail_prefix(rc, "%s", path);
    return MF_OK;
}

void mf_env_free(MfEnvMap *env) {
    if (!env) return;
    mf_image_free(&env->img);
    free(env->marg_cdf);
    free(env->cond_cdf);
    free(env->row_tab);
    free(env->marg_guide);
    free(env->cond_guide);
    memset(env, 0, sizeof *env);
}

int mf_env_rotate_z(MfEnvMap *env, float angle) {
    if (!isfinite(angle)) return mf_fail(MF_EARG, "env map: rotation angle %g is not finite", (double)angle);
    int W = env->img.w, H = env->img.h;
    /* new(x) = old(x + angle W / (2 pi)) in texel-centre coordinates, linear in u, wrapped. The
     * angle is reduced to (-2 pi, 2 pi) first (fmod is exact), so a huge angle cannot push the
     * shift beyond int range (it once indexed outside the image). */
    double shift = fmod((double)angle, 2.0 * M_PI) * W / (2.0 * M_PI);
    shift -= floor(shift / W) * W;
    int s0 = (int)floor(shift);
    if (s0 < 0 || s0 >= W) s0 = 0, shift = 0.0; /* rounding of a shift within 1 ulp of 0 or W */
    size_t n = (size_t)W * H * 3;
    float *old = malloc(sizeof(float) * n);
    if (!old) return mf_fail(MF_ENOMEM, "env map: out of memory for rotation");
    memcpy(old, env->img.data, sizeof(float) * n);
    float t = (float)(shift - s0);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            int a = (x + s0) % W, b = (x + s0 + 1) % W;
            const float *pa = old + ((size_t)y * W + a) * 3, *pb = old + ((size_t)y * W + b) * 3;
            float *q = env->img.data + ((size_t)y * W + x) * 3;
            for (int k = 0; k < 3; ++k) q[k] = (1.0f - t) * pa[k] + t * pb[k];
        }
    free(old);
    return mf_env_update(env);
}

/* Index i with cdf[i] <= u < cdf[i+1] (never a zero-width interval), cdf of n+1 entries,
 * searched between the guide entries of u's interval (the same i as a search of all of cdf:
 * cdf is nondecreasing, so that i is unique). */
static inline int cdf_find_guided(const float *cdf, const uint32_t *guide, int K, float u) {
    if (!(u >= 0.0f)) return 0; /* NaN: as the plain binary search */
    int k = (int)(u * (float)K); /* exact: K is a power of two; u in [0, 1) */
    int lo = (int)guide[k], hi = (int)guide[k + 1] + 1; /* cdf[lo] <= k/K <= u < (k+1)/K < cdf[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) >> 1;
        if (cdf[mid] <= u) lo = mid;
        else hi = mid;
    }
    return lo;
}

/* Texel probability from the CDFs, divided by the texel's solid angle. */
static inline float texel_pdf(const MfEnvMap *env, int x, int y) {
    int W = env->img.w;
    const float *cc = env->cond_cdf + (size_t)y * (W + 1);
    double p = ((double)env->marg_cdf[y + 1] - env->marg_cdf[y]) * ((double)cc[x + 1] - cc[x]);
    return (float)(p * W / (2.0 * M_PI * env->row_tab[2 * y + 1]));
}

/* Direction and pdf of texel (x, y) with cdf row cc at (u1, u2) (the tail of mf_env_sample). */
static inline void sample_finish(const MfEnvMap *env, const float *cc, int x, int y, float u1, float u2, MfVec3 *dir,
                                 float *pdf) {
    int W = env->img.w;
    double ty = ((double)u1 - env->marg_cdf[y]) / ((double)env->marg_cdf[y + 1] - env->marg_cdf[y]);
    double tx = ((double)u2 - cc[x]) / ((double)cc[x + 1] - cc[x]);
    ty = ty < 0.0 ? 0.0 : (ty > 1.0 ? 1.0 : ty);
    tx = tx < 0.0 ? 0.0 : (tx > 1.0 ? 1.0 : tx);
    /* uniform in z = cos(theta) within the row band, uniform in u within the column */
    double ztop = env->row_tab[2 * y], dz = env->row_tab[2 * y + 1];
    double z = ztop - ty * dz;
    if (z > 1.0) z = 1.0;
    if (z < -1.0) z = -1.0;
    double u = (x + tx) / W;
    double phi = M_PI - 2.0 * M_PI * u;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double sp, cp;
    sincos(phi, &sp, &cp);
    *dir = mf_v3((float)(r * cp), (float)(r * sp), (float)z);
    *pdf = texel_pdf(env, x, y);
}

void mf_env_sample_dir(const MfEnvMap *env, float u1, float u2, MfVec3 *dir, float *pdf) {
    int W = env->img.w;
    u1 = mf_clampf(u1, 0.0f, 0x1.fffffep-1f);
    u2 = mf_clampf(u2, 0.0f, 0x1.fffffep-1f);
    int y = cdf_find_guided(env->marg_cdf, env->marg_guide, env->marg_k, u1);
    const float *cc = env->cond_cdf + (size_t)y * (W + 1);
    int x = cdf_find_guided(cc, env->cond_guide + (size_t)y * (env->cond_k + 1), env->cond_k, u2);
    sample_finish(env, cc, x, y, u1, u2, dir, pdf);
}

#define ENV_BATCH 64

void mf_env_sample_dir_n(const MfEnvMap *env, int n, const float *u1, const float *u2, MfVec3 *dir, float *pdf) {
    int W = env->img.w, K = env->cond_k;
    for (int b0 = 0; b0 < n; b0 += ENV_BATCH) {
        int nb = n - b0 < ENV_BATCH ? n - b0 : ENV_BATCH;
        int ys[ENV_BATCH], lo[ENV_BATCH], hi[ENV_BATCH];
        float a[ENV_BATCH], b[ENV_BATCH];
        const uint32_t *g[ENV_BATCH];
        /* 1: rows (marginal tables are small and hot), prefetch the guide entries */
        for (int t = 0; t < nb; ++t) {
            a[t] = mf_clampf(u1[b0 + t], 0.0f, 0x1.fffffep-1f);
            b[t] = mf_clampf(u2[b0 + t], 0.0f, 0x1.fffffep-1f);
            ys[t] = cdf_find_guided(env->marg_cdf, env->marg_guide, env->marg_k, a[t]);
            int k = b[t] >= 0.0f ? (int)(b[t] * (float)K) : 0;
            g[t] = env->cond_guide + (size_t)ys[t] * (K + 1) + k;
            __builtin_prefetch(g[t]);
        }
        /* 2: search ranges, prefetch the CDF entries they span */
        for (int t = 0; t < nb; ++t) {
            lo[t] = (int)g[t][0];
            hi[t] = (int)g[t][1] + 1;
            const float *cc = env->cond_cdf + (size_t)ys[t] * (W + 1);
            __builtin_prefetch(cc + lo[t]);
            __builtin_prefetch(cc + hi[t]);
        }
        /* 3: finish (the same search as cdf_find_guided, from the same range) */
        for (int t = 0; t < nb; ++t) {
            const float *cc = env->cond_cdf + (size_t)ys[t] * (W + 1);
            int x;
            if (!(b[t] >= 0.0f)) {
                x = 0;
            } else {
                int l = lo[t], h = hi[t];
                while (h - l > 1) {
                    int mid = (l + h) >> 1;
                    if (cc[mid] <= b[t]) l = mid;
                    else h = mid;
                }
                x = l;
            }
            sample_finish(env, cc, x, ys[t], a[t], b[t], &dir[b0 + t], &pdf[b0 + t]);
            /* the radiance lookup of this sample (if it is kept) reads rows y and y +- 1 */
            const float *px = env->img.data + ((size_t)ys[t] * W + x) * 3;
            __builtin_prefetch(px);
            if (ys[t] > 0) __builtin_prefetch(px - (size_t)W * 3);
            if (ys[t] + 1 < env->img.h) __builtin_prefetch(px + (size_t)W * 3);
        }
    }
}

MfVec3 mf_env_sample(const MfEnvMap *env, float u1, float u2, MfVec3 *dir, float *pdf) {
    mf_env_sample_dir(env, u1, u2, dir, pdf);
    return mf_env_eval(env, *dir);
}

/* Texel of (u, v) for the pdf. */
static inline float pdf_uv(const MfEnvMap *env, float u, float v) {
    int W = env->img.w, H = env->img.h;
    int x = (int)floorf(u * (float)W), y = (int)floorf((1.0f - v) * (float)H);
    x = x < 0 ? 0 : (x >= W ? W - 1 : x);
    y = y < 0 ? 0 : (y >= H ? H - 1 : y);
    return texel_pdf(env, x, y);
}

float mf_env_pdf(const MfEnvMap *env, MfVec3 d) {
    float u, v;
    mf_env_dir_to_uv(d, &u, &v);
    return pdf_uv(env, u, v);
}

MfVec3 mf_env_eval_pdf(const MfEnvMap *env, MfVec3 d, float *pdf) {
    float u, v;
    mf_env_dir_to_uv(d, &u, &v);
    size_t idx[4];
    float wt[4];
    env_footprint_uv(env, u, v, idx, wt);
    *pdf = pdf_uv(env, u, v);
    return env_lookup(env, idx, wt);
}

void mf_env_eval_pdf_n(const MfEnvMap *env, int n, const MfVec3 *d, MfVec3 *L, float *pdf) {
    int W = env->img.w, H = env->img.h;
    for (int b0 = 0; b0 < n; b0 += ENV_BATCH) {
        int nb = n - b0 < ENV_BATCH ? n - b0 : ENV_BATCH;
        size_t idx[ENV_BATCH][4];
        float wt[ENV_BATCH][4];
        int px[ENV_BATCH], py[ENV_BATCH];
        for (int t = 0; t < nb; ++t) {
            float u, v;
            mf_env_dir_to_uv(d[b0 + t], &u, &v);
            env_footprint_uv(env, u, v, idx[t], wt[t]);
            for (int k = 0; k < 4; ++k) __builtin_prefetch(env->img.data + idx[t][k] * 3);
            if (pdf) { /* the texel of pdf_uv */
                int x = (int)floorf(u * (float)W), y = (int)floorf((1.0f - v) * (float)H);
                px[t] = x < 0 ? 0 : (x >= W ? W - 1 : x);
                py[t] = y < 0 ? 0 : (y >= H ? H - 1 : y);
                __builtin_prefetch(env->cond_cdf + (size_t)py[t] * (W + 1) + px[t]);
            }
        }
        for (int t = 0; t < nb; ++t) {
            L[b0 + t] = env_lookup(env, idx[t], wt[t]);
            if (pdf) pdf[b0 + t] = texel_pdf(env, px[t], py[t]);
        }
    }
}
