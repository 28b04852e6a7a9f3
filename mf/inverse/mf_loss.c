#include "inverse/mf_loss.h"

#include <math.h>
#include <stdlib.h>

#include "core/mf_error.h"

static inline float sgn(float x) { return (float)((x > 0.0f) - (x < 0.0f)); }

void mf_loss_composite(float *out, const float *rgb_premult, const float *alpha, const float *bg, size_t npx) {
    for (size_t i = 0; i < npx; ++i)
        for (int c = 0; c < 3; ++c) out[3 * i + c] = rgb_premult[3 * i + c] + (1.0f - alpha[i]) * bg[3 * i + c];
}

float mf_logsrgb(float x) {
    float f = log1pf(fminf(fmaxf(x, 0.0f), 65535.0f));
    return f > 0.0031308f ? 1.055f * powf(f, 1.0f / 2.4f) - 0.055f : 12.92f * f;
}

float mf_logsrgb_deriv(float x) {
    if (!(x > 0.0f && x < 65535.0f)) return x == 0.0f ? 12.92f : 0.0f; /* one-sided at the clamp */
    float f = log1pf(x);
    float dt = f > 0.0031308f ? (1.055f / 2.4f) * powf(f, 1.0f / 2.4f - 1.0f) : 12.92f;
    return dt / (x + 1.0f);
}

double mf_loss_logl1_fwd(const float *pred, const float *ref, size_t n, float floor) {
    double s = 0.0;
    for (size_t i = 0; i < n; ++i) s += fabsf(mf_logsrgb(pred[i] + floor) - mf_logsrgb(ref[i] + floor));
    return n ? s / (double)n : 0.0;
}

void mf_loss_logl1_bwd(const float *pred, const float *ref, size_t n, float floor, float scale, float *dpred) {
    if (!n) return;
    float k = scale / (float)n;
    for (size_t i = 0; i < n; ++i) {
        float p = pred[i] + floor;
        dpred[i] += k * sgn(mf_logsrgb(p) - mf_logsrgb(ref[i] + floor)) * mf_logsrgb_deriv(p);
    }
}

double mf_loss_mse_fwd(const float *pred, const float *ref, size_t n) {
    double s = 0.0;
    for (size_t i = 0; i < n; ++i) s += (double)(pred[i] - ref[i]) * (pred[i] - ref[i]);
    return n ? s / (double)n : 0.0;
}

void mf_loss_mse_bwd(const float *pred, const float *ref, size_t n, float scale, float *dpred) {
    if (!n) return;
    float k = 2.0f * scale / (float)n;
    for (size_t i = 0; i < n; ++i) dpred[i] += k * (pred[i] - ref[i]);
}

/* Visits every regularised pair (p, q) of texels and channel; returns the pair count. */
#define SMOOTH_PAIRS(BODY)                                                                  \
    for (int y = 0; y < h; ++y)                                                             \
        for (int x = 0; x < w; ++x) {                                                       \
            size_t p = (size_t)y * w + x;                                                   \
            if (mask && !(mask[p] > 0.0f)) continue;                                        \
            for (int d = 0; d < 2; ++d) {                                                   \
                int qx = x + (d == 0), qy = y + (d == 1);                                   \
                if (qx >= w || qy >= h) continue;                                           \
                size_t q = (size_t)qy * w + qx;                                             \
                if (mask && !(mask[q] > 0.0f)) continue;                                    \
                ++pairs;                                                                    \
                for (int c = c0; c < c0 + nc; ++c) {                                        \
                    size_t ip = p * ch + c, iq = q * ch + c;                                \
                    BODY;                                                                   \
                }                                                                           \
            }                                                                               \
        }

double mf_reg_smooth_fwd(const float *tex, int w, int h, int ch, int c0, int nc, const float *mask) {
    double s = 0.0;
    size_t pairs = 0;
    SMOOTH_PAIRS(s += fabsf(tex[ip] - tex[iq]))
    return pairs ? s / ((double)pairs * nc) : 0.0;
}

void mf_reg_smooth_bwd(const float *tex, int w, int h, int ch, int c0, int nc, const float *mask, float scale,
                       float *dtex) {
    size_t pairs = 0;
    SMOOTH_PAIRS((void)ip; (void)iq)
    if (!pairs) return;
    float k = scale / ((float)pairs * nc);
    pairs = 0;
    SMOOTH_PAIRS({
        float g = k * sgn(tex[ip] - tex[iq]);
        dtex[ip] += g;
        dtex[iq] -= g;
    })
}

/* Visits every env pair (p, q) with a texel uncovered by COVER ((h, w), or NULL: every pair). */
#define ENV_PAIRS(COVER, BODY)                                                              \
    for (int y = 0; y < h; ++y)                                                             \
        for (int x = 0; x < w; ++x) {                                                       \
            size_t p = (size_t)y * w + x;                                                   \
            for (int d = 0; d < 2; ++d) {                                                   \
                int qx = d == 0 ? (x + 1) % w : x, qy = y + (d == 1);                       \
                if (qy >= h || ((COVER) && (COVER)[p] && (COVER)[(size_t)qy * w + qx])) continue; \
                size_t q = (size_t)qy * w + qx;                                             \
                ++pairs;                                                                    \
                for (int c = 0; c < 3; ++c) {                                               \
                    size_t ip = p * 3 + c, iq = q * 3 + c;                                  \
                    BODY;                                                                   \
                }                                                                           \
            }                                                                               \
        }

double mf_reg_env_unseen_fwd(const float *env, int w, int h, const unsigned char *cover) {
    double s = 0.0;
    size_t pairs = 0;
    ENV_PAIRS(cover, s += fabsf(env[ip] - env[iq]))
    return pairs ? s / (3.0 * (double)pairs) : 0.0;
}

void mf_reg_env_unseen_bwd(const float *env, int w, int h, const unsigned char *cover, float scale, float *denv) {
    size_t pairs = 0;
    ENV_PAIRS(cover, (void)ip; (void)iq)
    if (!pairs) return;
    float k = scale / (3.0f * (float)pairs);
    pairs = 0;
    ENV_PAIRS(cover, {
        float g = k * sgn(env[ip] - env[iq]);
        denv[ip] += g;
        denv[iq] -= g;
    })
}

double mf_reg_env_logtv_fwd(const float *env, int w, int h) {
    double s = 0.0;
    size_t pairs = 0;
    ENV_PAIRS((const unsigned char *)NULL, s += fabsf(logf(env[ip]) - logf(env[iq])))
    return pairs ? s / (3.0 * (double)pairs) : 0.0;
}

void mf_reg_env_logtv_bwd(const float *env, int w, int h, float scale, float *denv) {
    size_t pairs = (size_t)w * h + (size_t)w * (h - 1); /* every right (wrapping) and lower pair */
    if (!pairs) return;
    float k = scale / (3.0f * (float)pairs);
    ENV_PAIRS((const unsigned char *)NULL, {
        float g = k * sgn(logf(env[ip]) - logf(env[iq]));
        denv[ip] += g / env[ip];
        denv[iq] -= g / env[iq];
    })
}

static const float k_flat[3] = {0.0f, 0.0f, 1.0f};

double mf_reg_nmap_flat_fwd(const float *nmap, int w, int h, const float *mask) {
    double s = 0.0;
    size_t n = 0;
    for (size_t p = 0; p < (size_t)w * h; ++p) {
        if (mask && !(mask[p] > 0.0f)) continue;
        ++n;
        for (int c = 0; c < 3; ++c) s += fabsf(2.0f * nmap[3 * p + c] - 1.0f - k_flat[c]);
    }
    return n ? s / (3.0 * (double)n) : 0.0;
}

void mf_reg_nmap_flat_bwd(const float *nmap, int w, int h, const float *mask, float scale, float *dnmap) {
    size_t n = 0;
    for (size_t p = 0; p < (size_t)w * h; ++p) n += !mask || mask[p] > 0.0f;
    if (!n) return;
    float k = 2.0f * scale / (3.0f * (float)n);
    for (size_t p = 0; p < (size_t)w * h; ++p) {
        if (mask && !(mask[p] > 0.0f)) continue;
        for (int c = 0; c < 3; ++c) dnmap[3 * p + c] += k * sgn(2.0f * nmap[3 * p + c] - 1.0f - k_flat[c]);
    }
}

static inline float luma3(const float *c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }
static const float k_luma[3] = {0.2126f, 0.7152f, 0.0722f};

double mf_reg_shading_fwd(const float *diffuse, const float *spec, const float *cover, size_t npx, float lambda_spec) {
    double white = 0.0, sd = 0.0, ss = 0.0, cov = 0.0;
    for (size_t i = 0; i < npx; ++i) {
        const float *d = diffuse + 3 * i;
        float l = luma3(d);
        for (int c = 0; c < 3; ++c) {
            white += cover[i] * fabsf(d[c] - l);
            sd += cover[i] * d[c];
            ss += cover[i] * spec[3 * i + c];
        }
        cov += cover[i];
    }
    if (cov <= 0.0) return 0.0;
    double r = white / (3.0 * cov);
    if (lambda_spec > 0.0f && sd > 0.0) r += lambda_spec * ss / sd;
    return r;
}

void mf_reg_shading_bwd(const float *diffuse, const float *spec, const float *cover, size_t npx, float lambda_spec,
                        float scale, float *ddiffuse, float *dspec) {
    double sd = 0.0, ss = 0.0, cov = 0.0;
    for (size_t i = 0; i < npx; ++i) {
        cov += cover[i];
        for (int c = 0; c < 3; ++c) sd += cover[i] * diffuse[3 * i + c], ss += cover[i] * spec[3 * i + c];
    }
    if (cov <= 0.0) return;
    float kw = (float)(scale / (3.0 * cov));
    int with_spec = lambda_spec > 0.0f && sd > 0.0;
    float ks = with_spec ? (float)(scale * lambda_spec / sd) : 0.0f;
    float kd = with_spec ? (float)(-scale * lambda_spec * ss / (sd * sd)) : 0.0f;
    for (size_t i = 0; i < npx; ++i) {
        const float *d = diffuse + 3 * i;
        float l = luma3(d), s[3], sum = 0.0f;
        for (int c = 0; c < 3; ++c) s[c] = sgn(d[c] - l), sum += s[c];
        for (int c = 0; c < 3; ++c) {
            /* d|d_c - l|/dd_j = s_c (delta_cj - luma_j) */
            ddiffuse[3 * i + c] += cover[i] * (kw * (s[c] - sum * k_luma[c]) + kd);
            dspec[3 * i + c] += cover[i] * ks;
        }
    }
}

/* L_i = p_i - mean of its neighbours (0 for a vertex without any) into L[3]. */
static void laplacian_at(const float *pos, const int *off, const int *adj, int i, double *L) {
    int d = off[i + 1] - off[i];
    for (int k = 0; k < 3; ++k) {
        double m = 0.0;
        for (int e = off[i]; e < off[i + 1]; ++e) m += pos[3 * adj[e] + k];
        L[k] = d ? pos[3 * i + k] - m / d : 0.0;
    }
}

double mf_reg_laplacian_fwd(const float *pos, int nv, const int *off, const int *adj) {
    double s = 0.0, L[3];
    for (int i = 0; i < nv; ++i) {
        laplacian_at(pos, off, adj, i, L);
        s += L[0] * L[0] + L[1] * L[1] + L[2] * L[2];
    }
    return s;
}

void mf_reg_laplacian_bwd(const float *pos, int nv, const int *off, const int *adj, float scale, float *dpos) {
    /* d/dp_i sum_j |L_j|^2 = 2 L_i - 2 sum over i's neighbour entries j of L_j / deg_j (adjacency is
     * symmetric: j lists i as often as i lists j); L_j recomputed per entry, nothing allocated */
    double Li[3], Lj[3];
    for (int i = 0; i < nv; ++i) {
        if (off[i + 1] == off[i]) continue;
        laplacian_at(pos, off, adj, i, Li);
        double g[3] = {2.0 * Li[0], 2.0 * Li[1], 2.0 * Li[2]};
        for (int e = off[i]; e < off[i + 1]; ++e) {
            int j = adj[e];
            laplacian_at(pos, off, adj, j, Lj);
            for (int k = 0; k < 3; ++k) g[k] -= 2.0 * Lj[k] / (off[j + 1] - off[j]);
        }
        for (int k = 0; k < 3; ++k) dpos[3 * i + k] += (float)(scale * g[k]);
    }
}

int mf_reg_laplacian_adjacency(const uint32_t *tri, int nt, int nv, int **off, int **adj) {
    int *o = calloc((size_t)nv + 1, sizeof *o), *a = malloc((size_t)nt * 6 * sizeof *a + 1), *fill = calloc((size_t)nv + 1, sizeof *fill);
    if (!o || !a || !fill) {
        free(o), free(a), free(fill);
        return mf_fail(MF_ENOMEM, "out of memory for the adjacency of %d vertices", nv);
    }
    for (int t = 0; t < 3 * nt; ++t) o[tri[t] + 1] += 2;
    for (int i = 0; i < nv; ++i) o[i + 1] += o[i];
    for (int t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) {
            uint32_t v = tri[3 * t + k];
            a[o[v] + fill[v]++] = (int)tri[3 * t + (k + 1) % 3];
            a[o[v] + fill[v]++] = (int)tri[3 * t + (k + 2) % 3];
        }
    free(fill);
    *off = o, *adj = a;
    return MF_OK;
}
