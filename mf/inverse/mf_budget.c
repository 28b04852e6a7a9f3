#include "inverse/mf_budget.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_sort_float.h>
#include <gsl/gsl_statistics_float.h>

#include "core/mf_error.h"
#include "scene/mf_envmap.h"

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Calls fn(ctx, dir, hit) for every primary ray through a pixel centre of the views (those with
 * skip[i] != 0 left out; skip may be NULL) that hits the mesh; dir is the ray's unit direction. */
typedef void (*HitFn)(void *ctx, MfVec3 dir, const MfHit *hit);
static void for_each_centre_hit(const MfRtScene *rt, const MfReconView *views, int nviews, const unsigned char *skip,
                                HitFn fn, void *ctx) {
    for (int v = 0; v < nviews; ++v) {
        if (skip && skip[v]) continue;
        const MfCamera *cam = &views[v].cam;
        for (int py = 0; py < cam->h; ++py)
            for (int px = 0; px < cam->w; ++px) {
                MfVec3 org, dir;
                MfHit hit;
                mf_camera_ray(cam, (float)px + 0.5f, (float)py + 0.5f, &org, &dir);
                if (mf_rtscene_intersect(rt, org, dir, 0.0f, INFINITY, &hit)) fn(ctx, dir, &hit);
            }
    }
}

static void mark_triangle(void *seen, MfVec3 dir, const MfHit *hit) {
    (void)dir;
    ((unsigned char *)seen)[hit->tri] = 1;
}

int mf_budget_texel_side(const MfRtScene *rt, const MfMesh *mesh, const MfReconView *views, int nviews,
                         double *median_side, long *npairs) {
    if (!mesh->uv) return mf_fail(MF_EARG, "texel density: the mesh has no UVs");
    unsigned char *seen = malloc((size_t)mesh->nt + 1);
    double *s = malloc(((size_t)mesh->nt * (size_t)nviews + 1) * sizeof(double)); /* (pairs,) */
    if (!seen || !s) {
        free(seen), free(s);
        return mf_fail(MF_ENOMEM, "texel density: out of memory");
    }
    size_t n = 0;
    for (int v = 0; v < nviews; ++v) {
        memset(seen, 0, (size_t)mesh->nt);
        for_each_centre_hit(rt, &views[v], 1, NULL, mark_triangle, seen); /* triangles view v sees */
        for (int t = 0; t < mesh->nt; ++t) {
            if (!seen[t]) continue;
            float px[3], py[3], u[3], w[3];
            int front = 1;
            for (int k = 0; k < 3; ++k) {
                uint32_t i = mesh->tri[3 * t + k];
                MfVec3 p = mf_v3(mesh->pos[3 * i], mesh->pos[3 * i + 1], mesh->pos[3 * i + 2]);
                front &= mf_camera_project(&views[v].cam, p, &px[k], &py[k]);
                u[k] = mesh->uv[2 * i], w[k] = mesh->uv[2 * i + 1];
            }
            double a_scr = 0.5 * fabs((double)(px[1] - px[0]) * (py[2] - py[0]) - (double)(px[2] - px[0]) * (py[1] - py[0]));
            double a_uv = 0.5 * fabs((double)(u[1] - u[0]) * (w[2] - w[0]) - (double)(u[2] - u[0]) * (w[1] - w[0]));
            if (front && a_uv > 1e-12 && a_scr > 0.0) s[n++] = sqrt(a_scr / a_uv);
        }
    }
    double med = 0.0;
    if (n) {
        qsort(s, n, sizeof *s, cmp_double);
        med = n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
    }
    *median_side = med;
    if (npairs) *npairs = (long)n;
    free(seen), free(s);
    return MF_OK;
}

int mf_budget_pow2_side(double side, int lo, int hi) {
    if (!(side > 0.0)) return hi;
    double e = round(log2(side));
    e = e < 0 ? 0 : (e > 30 ? 30 : e);
    int t = 1 << (int)e;
    return t < lo ? lo : (t > hi ? hi : t);
}

typedef struct {
    int w, h;            /* the grid: a T x T texture, or the env's W x H */
    unsigned char *mask; /* (h, w) */
    size_t marked;
} MarkCtx;

static void mark_cell(MarkCtx *c, int x, int y, unsigned char value) {
    unsigned char *m = &c->mask[(size_t)y * c->w + x];
    c->marked += !*m;
    *m = value;
}

static void mark_texel(void *ctx, MfVec3 dir, const MfHit *hit) {
    MarkCtx *c = ctx;
    int T = c->w, x = (int)floorf(hit->uv.x * T), y = (int)floorf((1.0f - hit->uv.y) * T);
    (void)dir;
    mark_cell(c, ((x % T) + T) % T, ((y % T) + T) % T, 1); /* repeat wrap */
}

size_t mf_budget_visible_texels(const MfRtScene *rt, const MfReconView *views, int nviews, const unsigned char *skip,
                                int T, unsigned char *mask) {
    memset(mask, 0, (size_t)T * T);
    MarkCtx c = {T, T, mask, 0};
    for_each_centre_hit(rt, views, nviews, skip, mark_texel, &c);
    return c.marked;
}

static void mark_reflection(void *ctx, MfVec3 dir, const MfHit *hit) {
    MarkCtx *c = ctx;
    float u, w;
    mf_env_dir_to_uv(mf_reflect(mf_neg(dir), hit->ns), &u, &w);
    int x = (int)floorf(u * (float)c->w), y = (int)floorf((1.0f - w) * (float)c->h);
    mark_cell(c, x < 0 ? 0 : (x >= c->w ? c->w - 1 : x), y < 0 ? 0 : (y >= c->h ? c->h - 1 : y), 2);
}

size_t mf_budget_env_coverage(const MfRtScene *rt, const MfReconView *views, int nviews, const unsigned char *skip,
                              int W, int H, int dilate, unsigned char *cover) {
    memset(cover, 0, (size_t)W * H);
    MarkCtx c = {W, H, cover, 0};
    for_each_centre_hit(rt, views, nviews, skip, mark_reflection, &c); /* 2: reached; 1: by the dilation */
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (cover[(size_t)y * W + x] != 2) continue;
            for (int dy = -dilate; dy <= dilate; ++dy)
                for (int dx = -dilate; dx <= dilate; ++dx) {
                    int yy = y + dy, xx = ((x + dx) % W + W) % W;
                    if (yy >= 0 && yy < H && !cover[(size_t)yy * W + xx]) cover[(size_t)yy * W + xx] = 1;
                }
        }
    size_t marked = 0;
    for (size_t i = 0; i < (size_t)W * H; ++i) marked += cover[i] != 0, cover[i] = cover[i] != 0;
    return marked;
}

double mf_budget_metal_fraction(const float *orm, const unsigned char *mask, size_t ntex, float thresh) {
    size_t vis = 0, metal = 0;
    for (size_t i = 0; i < ntex; ++i)
        if (mask[i]) vis++, metal += orm[3 * i + 2] > thresh;
    return vis ? (double)metal / (double)vis : 0.0;
}

double mf_budget_lobe_fwhm(float rough) {
    double alpha = (double)rough * rough;
    return 4.0 * atan(0.6436 * alpha); /* tan at half maximum = alpha sqrt(sqrt(2) - 1) */
}

int mf_budget_env_width(const float *orm, const unsigned char *mask, size_t ntex, double pct, int w_max, int h_max,
                        int w_min, double *rough) {
    *rough = -1.0;
    float *r = malloc(ntex * sizeof(float) + 1);
    if (!r) return -1;
    size_t n = 0;
    for (size_t i = 0; i < ntex; ++i)
        if (mask[i]) r[n++] = orm[3 * i + 1];
    if (n) {
        gsl_sort_float(r, 1, n);
        *rough = gsl_stats_float_quantile_from_sorted_data(r, 1, n, pct);
    }
    free(r);
    if (!n) return w_max; /* nothing visible: no information, the cap */
    double need = 4.0 * M_PI / mf_budget_lobe_fwhm((float)*rough); /* two texels across the lobe */
    int w = w_max, h = h_max;
    while (w % 2 == 0 && h % 2 == 0 && h / 2 >= 2 && w / 2 >= w_min && w / 2 >= need) w /= 2, h /= 2;
    return w;
}

void mf_budget_env_shrink(const float *src, int W, int H, int f, float *dst) {
    int w = W / f, h = H / f;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                double sum = 0.0;
                for (int dy = 0; dy < f; ++dy)
                    for (int dx = 0; dx < f; ++dx) sum += src[((size_t)(y * f + dy) * W + x * f + dx) * 3 + c];
                dst[((size_t)y * w + x) * 3 + c] = (float)(sum / ((double)f * f));
            }
}

void mf_early_stop_init(MfEarlyStop *es) {
    memset(es, 0, sizeof *es);
    es->best = -1.0;
}

int mf_early_stop_observe(MfEarlyStop *es, int iter, double psnr, int patience, double min_delta) {
    if (es->n < MF_BUDGET_CURVE_MAX) es->iter[es->n] = iter, es->psnr[es->n] = psnr, es->n++;
    if (es->best < 0.0 || psnr > es->best + min_delta) {
        es->best = psnr, es->best_iter = iter, es->bad = 0;
        return 0;
    }
    if (++es->bad < patience) return 0;
    es->stop_iter = iter;
    return 1;
}
