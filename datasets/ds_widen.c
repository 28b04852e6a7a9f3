#include "datasets/ds_widen.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "io/mf_image.h"

/* streams of the object seed, distinct from the generator's own */
#define STREAM_OBJECT 0x5749444eull /* "WIDN" */
#define STREAM_OVERLAY 0x4f564c59ull
#define STREAM_VIEW 0x56494557ull

int ds_content_from_name(const char *name) {
    if (!name) return -1;
    if (!strcmp(name, "all")) return DS_CONTENT_ALL;
    if (!strcmp(name, "train")) return DS_CONTENT_TRAIN;
    if (!strcmp(name, "heldout")) return DS_CONTENT_HELDOUT;
    return -1;
}

const char *ds_content_name(DsContent c) { return c == DS_CONTENT_TRAIN ? "train" : c == DS_CONTENT_HELDOUT ? "heldout" : "all"; }

int ds_family_heldout(DsFamily f) { return f == DS_FAM_SUPERQUADRIC || f == DS_FAM_DISPLACED; }

int ds_object_heldout(const DsObject *o) {
    if (ds_family_heldout(o->family)) return 1;
    for (int i = 0; i < o->nparts; ++i)
        if (o->parts[i].mat.cls == DS_MAT_RUBBER || o->parts[i].mat.pattern == DS_PAT_CHECKER) return 1;
    return 0;
}

int ds_content_accepts(DsContent c, const DsObject *o) {
    if (c == DS_CONTENT_ALL) return 1;
    return ds_object_heldout(o) == (c == DS_CONTENT_HELDOUT);
}

static float urange(MfRng *r, float a, float b) { return a + (b - a) * mf_rng_float(r); }

DsWidenObject ds_widen_object(uint64_t oseed) {
    MfRng r;
    mf_rng_seed(&r, mf_hash64(oseed, STREAM_OBJECT), 0);
    DsWidenObject w;
    float u_pov = mf_rng_float(&r), u_ov = mf_rng_float(&r), u_kind = mf_rng_float(&r);
    float fov = urange(&r, DS_WIDEN_FOV_MIN, DS_WIDEN_FOV_MAX);
    w.povray = u_pov < DS_WIDEN_POV_FRAC;
    w.overlay = u_ov < DS_WIDEN_OVERLAY_FRAC ? (u_kind < 0.5f ? 1 : 2) : 0;
    w.fov_scale = fov / (float)DS_CAMERA_ANGLE_X;
    /* keep the object's size in the frame: distance ~ 1 / tan(fov / 2), then jitter */
    w.dist_scale = (float)(tan(0.5 * DS_CAMERA_ANGLE_X) / tan(0.5 * fov)) * urange(&r, 0.85f, 1.25f);
    return w;
}

DsCamSampling ds_widen_cameras(const DsWidenObject *w) {
    DsCamSampling cs = ds_cam_sampling_default();
    cs.camera_angle_x *= w->fov_scale;
    cs.r_min *= w->dist_scale;
    cs.r_max *= w->dist_scale;
    return cs;
}

static MfVec3 rand_colour(MfRng *r) {
    return mf_v3(mf_srgb_to_linear(mf_rng_float(r)), mf_srgb_to_linear(mf_rng_float(r)), mf_srgb_to_linear(mf_rng_float(r)));
}

void ds_widen_overlay(const DsWidenObject *w, uint64_t oseed, DsObject *o) {
    if (!w->overlay) return;
    MfRng r;
    mf_rng_seed(&r, mf_hash64(oseed, STREAM_OVERLAY), 0);
    enum { MAXD = 32 };
    float cx[MAXD], cy[MAXD], rad[MAXD];
    int nd = 6 + (int)mf_rng_below(&r, MAXD - 6 + 1);
    for (int i = 0; i < nd; ++i) cx[i] = mf_rng_float(&r), cy[i] = mf_rng_float(&r), rad[i] = urange(&r, 0.02f, 0.08f);
    MfVec3 cd = rand_colour(&r), cs = rand_colour(&r);
    float rough_d = mf_rng_float(&r) < 0.5f ? urange(&r, 0.2f, 0.9f) : -1.0f;
    float ang = urange(&r, 0.0f, (float)MF_PI), period = urange(&r, 0.05f, 0.2f);
    float ca = cosf(ang), sa = sinf(ang);
    int W = o->kd.w, H = o->kd.h;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float u = (x + 0.5f) / (float)W, v = (y + 0.5f) / (float)H;
            float *kd = o->kd.data + ((size_t)y * W + x) * 3;
            if (w->overlay == 2) {
                float s = (u * ca + v * sa) / period;
                if (s - floorf(s) < 0.5f) kd[0] = cs.x, kd[1] = cs.y, kd[2] = cs.z;
            }
            for (int i = 0; i < nd; ++i) {
                float dx = u - cx[i], dy = v - cy[i];
                if (dx * dx + dy * dy < rad[i] * rad[i]) {
                    kd[0] = cd.x, kd[1] = cd.y, kd[2] = cd.z;
                    if (rough_d >= 0 && o->orm.w == W && o->orm.h == H) o->orm.data[((size_t)y * W + x) * 3 + 1] = rough_d;
                    break;
                }
            }
        }
}

DsWidenView ds_widen_view(uint64_t oseed, int v) {
    MfRng r;
    mf_rng_seed(&r, mf_hash64(mf_hash64(oseed, STREAM_VIEW), (uint64_t)v), 0);
    DsWidenView a;
    a.exposure = exp2f(urange(&r, -2.0f, 2.0f));
    float ut = mf_rng_float(&r);
    a.tone = ut < 0.5f ? 0 : ut < 0.75f ? 1 : 2;
    a.white = urange(&r, 2.0f, 8.0f);
    a.gamma = urange(&r, 0.9f, 1.1f);
    a.lowres = mf_rng_float(&r) < 0.3f;
    float un = mf_rng_float(&r), sig = urange(&r, 0.003f, 0.03f);
    a.noise = un < 0.5f ? sig : 0.0f;
    a.seed = ((uint64_t)mf_rng_u32(&r) << 32) | mf_rng_u32(&r);
    return a;
}

/* scene-linear -> display-linear in [0, 1] */
static float tone(const DsWidenView *a, float x) {
    if (x <= 0) return 0;
    if (x >= 1e4f) return 1.0f; /* every curve is at 1 (within 8 bits) there; avoids x^2 overflow */
    float d;
    if (a->tone == 1) d = x * (1.0f + x / (a->white * a->white)) / (1.0f + x);
    else if (a->tone == 2) d = (x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f);
    else d = x;
    return d < 1.0f ? d : 1.0f;
}

int ds_widen_apply(const DsWidenView *a, float *rgb, int rs, const float *alpha, int as, int res) {
    size_t n = (size_t)res * res;
    float *d = malloc(n * 3 * sizeof(float)); // (res, res, 3) display values in [0, 1]
    if (!d) return mf_fail(MF_ENOMEM, "out of memory");
    for (size_t i = 0; i < n; ++i) {
        float al = alpha[i * as], s = al > 0 ? a->exposure / al : 0.0f;
        for (int c = 0; c < 3; ++c) d[i * 3 + c] = powf(mf_linear_to_srgb(tone(a, rgb[i * rs + c] * s)), a->gamma);
    }
    if (a->lowres && res >= 4) { /* 2x2 box down, bilinear (half-pixel centred) up */
        int h = res / 2;
        float *lo = malloc((size_t)h * h * 3 * sizeof(float)); // (h, h, 3)
        if (!lo) {
            free(d);
            return mf_fail(MF_ENOMEM, "out of memory");
        }
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < h; ++x)
                for (int c = 0; c < 3; ++c) {
                    const float *p = d + ((size_t)(2 * y) * res + 2 * x) * 3 + c;
                    lo[((size_t)y * h + x) * 3 + c] = 0.25f * (p[0] + p[3] + p[(size_t)res * 3] + p[(size_t)res * 3 + 3]);
                }
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x) {
                float fy = (y + 0.5f) * 0.5f - 0.5f, fx = (x + 0.5f) * 0.5f - 0.5f;
                fy = fy < 0 ? 0 : fy > h - 1 ? (float)(h - 1) : fy;
                fx = fx < 0 ? 0 : fx > h - 1 ? (float)(h - 1) : fx;
                int y0 = (int)fy, x0 = (int)fx, y1 = y0 + 1 < h ? y0 + 1 : y0, x1 = x0 + 1 < h ? x0 + 1 : x0;
                float ty = fy - y0, tx = fx - x0;
                for (int c = 0; c < 3; ++c) {
                    float v00 = lo[((size_t)y0 * h + x0) * 3 + c], v01 = lo[((size_t)y0 * h + x1) * 3 + c];
                    float v10 = lo[((size_t)y1 * h + x0) * 3 + c], v11 = lo[((size_t)y1 * h + x1) * 3 + c];
                    d[((size_t)y * res + x) * 3 + c] = (1 - ty) * ((1 - tx) * v00 + tx * v01) + ty * ((1 - tx) * v10 + tx * v11);
                }
            }
        free(lo);
    }
    MfRng r;
    mf_rng_seed(&r, a->seed, 0);
    for (size_t i = 0; i < n; ++i) {
        float al = alpha[i * as];
        for (int c = 0; c < 3; ++c) {
            float v = d[i * 3 + c];
            if (a->noise > 0) v += a->noise * mf_rng_normal(&r); /* drawn for every pixel: the stream does not depend on the mask */
            v = v < 0 ? 0 : v > 1 ? 1 : v;
            rgb[i * rs + c] = mf_srgb_to_linear(v) * al;
        }
    }
    free(d);
    return MF_OK;
}
