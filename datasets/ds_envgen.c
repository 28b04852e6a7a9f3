#include "datasets/ds_envgen.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "scene/mf_envmap.h"

#define PI_D 3.14159265358979323846

/* ---- shared helpers ---- */

static double texel_omega(int y, int w, int h) {
    return (2.0 * PI_D / w) * (cos(PI_D * y / h) - cos(PI_D * (y + 1) / h));
}

static MfVec3 texel_dir(int x, int y, int w, int h, float su, float sv) {
    /* su, sv in [0, 1): position in the texel, uniform in u and in cos(theta) */
    double c0 = cos(PI_D * y / h), c1 = cos(PI_D * (y + 1) / h);
    double z = c0 + (c1 - c0) * sv;
    float u = (float)((x + su) / w), v = (float)(0.5 + asin(fmax(-1.0, fmin(1.0, z))) / PI_D);
    return mf_env_uv_to_dir(u, v);
}

static int check_size(int w, int h, MfImage *out) {
    if (w < 8 || h < 4 || w > 16384 || h > 8192) return mf_fail(MF_EARG, "envgen: map size %dx%d outside [8, 16384] x [4, 8192]", w, h);
    return mf_image_alloc(out, w, h, 3);
}

static void dir_to_texel(MfVec3 d, int w, int h, int *x, int *y) {
    float u, v;
    mf_env_dir_to_uv(d, &u, &v);
    int xi = (int)floorf(u * (float)w), yi = (int)floorf((1.0f - v) * (float)h);
    xi %= w;
    if (xi < 0) xi += w;
    *x = xi;
    *y = yi < 0 ? 0 : (yi >= h ? h - 1 : yi);
}

double ds_env_irradiance(const MfImage *img, MfVec3 n) {
    double e = 0;
    for (int y = 0; y < img->h; ++y) {
        double om = texel_omega(y, img->w, img->h);
        for (int x = 0; x < img->w; ++x) {
            MfVec3 d = texel_dir(x, y, img->w, img->h, 0.5f, 0.5f);
            float c = mf_dot(d, n);
            if (c <= 0) continue;
            const float *p = mf_image_px(img, x, y);
            e += (double)mf_lum(mf_v3(p[0], p[1], p[2])) * c * om;
        }
    }
    return e;
}

/* Scales img so that the largest irradiance over the candidate normals is pi * exposure. */
static double normalise_exposure(MfImage *img, float exposure, const MfVec3 *extra, int nextra, MfVec3 sun_dir, double sun_lum) {
    if (exposure <= 0) return 1.0;
    int w = img->w, h = img->h, nn = 6 + 64 + nextra;
    MfVec3 nrm[6 + 64 + 8];
    MfVec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int i = 0; i < 6; ++i) nrm[i] = axes[i];
    for (int i = 0; i < 64; ++i) { /* Fibonacci sphere */
        double z = 1.0 - (2.0 * i + 1.0) / 64.0, r = sqrt(fmax(0.0, 1.0 - z * z)), ph = i * 2.399963229728653;
        nrm[6 + i] = mf_v3((float)(r * cos(ph)), (float)(r * sin(ph)), (float)z);
    }
    if (nextra > 8) nextra = 8, nn = 6 + 64 + 8;
    for (int i = 0; i < nextra; ++i) nrm[70 + i] = extra[i];
    double e[6 + 64 + 8] = {0};
    for (int y = 0; y < h; ++y) {
        double om = texel_omega(y, w, h);
        for (int x = 0; x < w; ++x) {
            MfVec3 d = texel_dir(x, y, w, h, 0.5f, 0.5f);
            const float *p = mf_image_px(img, x, y);
            double l = (double)mf_lum(mf_v3(p[0], p[1], p[2])) * om;
            if (l <= 0) continue;
            for (int i = 0; i < nn; ++i) {
                float c = mf_dot(d, nrm[i]);
                if (c > 0) e[i] += l * c;
            }
        }
    }
    double best = 0;
    for (int i = 0; i < nn; ++i) best = fmax(best, e[i] + sun_lum * fmax(0.0, (double)mf_dot(nrm[i], sun_dir)));
    if (!(best > 0) || !isfinite(best)) return 1.0;
    double s = PI_D * exposure / best;
    size_t n = (size_t)w * (size_t)h * 3;
    for (size_t i = 0; i < n; ++i) img->data[i] = (float)(img->data[i] * s);
    return s;
}

/* Non-negative, finite RGB from XYZ (Rec.709 primaries, D65). */
static MfVec3 xyz_to_rgb(double X, double Y, double Z) {
    double r = 3.2406 * X - 1.5372 * Y - 0.4986 * Z;
    double g = -0.9689 * X + 1.8758 * Y + 0.0415 * Z;
    double b = 0.0557 * X - 0.2040 * Y + 1.0570 * Z;
    MfVec3 c = mf_v3((float)fmax(r, 0.0), (float)fmax(g, 0.0), (float)fmax(b, 0.0));
    return mf_isfinite3(c) ? c : mf_v3s(0.0f);
}

MfVec3 ds_kelvin_rgb(float kelvin) {
    double T = fmin(25000.0, fmax(1667.0, (double)kelvin)), x, y;
    double t1 = 1e3 / T, t2 = t1 * t1, t3 = t2 * t1; /* Kim et al. 2002, with 10^3/T scaling */
    if (T <= 4000) x = -0.2661239 * t3 - 0.2343589 * t2 + 0.8776956 * t1 + 0.179910;
    else x = -3.0258469 * t3 + 2.1070379 * t2 + 0.2226347 * t1 + 0.240390;
    if (T <= 2222) y = -1.1063814 * x * x * x - 1.34811020 * x * x + 2.18555832 * x - 0.20219683;
    else if (T <= 4000) y = -0.9549476 * x * x * x - 1.37418593 * x * x + 2.09137015 * x - 0.16748867;
    else y = 3.0817580 * x * x * x - 5.87338670 * x * x + 3.75112997 * x - 0.37001483;
    MfVec3 c = xyz_to_rgb(x / y, 1.0, (1.0 - x - y) / y);
    float l = mf_lum(c);
    return l > 0 ? mf_scale(c, 1.0f / l) : mf_v3s(1.0f);
}

/* ---- sky ---- */

typedef struct { double A, B, C, D, E; } Perez;

static Perez perez_coef(const double m[5][2], double T) {
    Perez p = {m[0][0] * T + m[0][1], m[1][0] * T + m[1][1], m[2][0] * T + m[2][1], m[3][0] * T + m[3][1], m[4][0] * T + m[4][1]};
    return p;
}

static double perez_f(const Perez *p, double cos_theta, double gamma, double cos_gamma) {
    cos_theta = fmax(cos_theta, 1e-3);
    return (1.0 + p->A * exp(p->B / cos_theta)) * (1.0 + p->C * exp(p->D * gamma) + p->E * cos_gamma * cos_gamma);
}

static const double K_PEREZ_Y[5][2] = {{0.1787, -1.4630}, {-0.3554, 0.4275}, {-0.0227, 5.3251}, {0.1206, -2.5771}, {-0.0670, 0.3703}};
static const double K_PEREZ_X[5][2] = {{-0.0193, -0.2592}, {-0.0665, 0.0008}, {-0.0004, 0.2125}, {-0.0641, -0.8989}, {-0.0033, 0.0452}};
static const double K_PEREZ_YC[5][2] = {{-0.0167, -0.2608}, {-0.0950, 0.0092}, {-0.0079, 0.2102}, {-0.0441, -1.6537}, {-0.0109, 0.0529}};

DsSkyParams ds_sky_params_random(uint64_t seed) {
    MfRng r;
    mf_rng_seed(&r, seed, 0x5c7u);
    DsSkyParams p;
    p.sun_elevation = (3.0f + 77.0f * mf_rng_float(&r)) * MF_PI / 180.0f;
    p.sun_azimuth = 2.0f * MF_PI * mf_rng_float(&r);
    p.turbidity = 2.0f + 4.0f * mf_rng_float(&r);
    float g = 0.08f + 0.12f * mf_rng_float(&r), tint = 0.15f * (mf_rng_float(&r) - 0.5f);
    p.ground_albedo = mf_v3(g * (1.0f + tint), g, g * (1.0f - tint));
    p.sun_scale = 1.0f;
    p.sun_as_light = 0;
    p.exposure = 0.7f + 1.3f * mf_rng_float(&r);
    return p;
}

int ds_env_sky(const DsSkyParams *p, int w, int h, MfImage *out, DsSkyInfo *info) {
    memset(out, 0, sizeof *out);
    int rc = check_size(w, h, out);
    if (rc) return rc;
    double T = fmin(10.0, fmax(2.0, isfinite(p->turbidity) ? (double)p->turbidity : 3.0));
    double el = fmin(PI_D / 2, fmax(0.0, isfinite(p->sun_elevation) ? (double)p->sun_elevation : 0.0));
    double az = isfinite(p->sun_azimuth) ? (double)p->sun_azimuth : 0.0;
    double ts = PI_D / 2 - el; /* sun zenith angle */
    MfVec3 s = mf_norm(mf_v3((float)(cos(az) * cos(el)), (float)(sin(az) * cos(el)), (float)sin(el)));
    /* zenith values */
    double chi = (4.0 / 9.0 - T / 120.0) * (PI_D - 2.0 * ts);
    double Yz = fmax(0.0, (4.0453 * T - 4.9710) * tan(chi) - 0.2155 * T + 2.4192); /* kcd/m^2 */
    double t3 = ts * ts * ts, t2 = ts * ts, TT = T * T;
    double xz = TT * (0.00166 * t3 - 0.00375 * t2 + 0.00209 * ts) + T * (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * ts + 0.00394) +
                (0.11693 * t3 - 0.21196 * t2 + 0.06052 * ts + 0.25886);
    double yz = TT * (0.00275 * t3 - 0.00610 * t2 + 0.00317 * ts) + T * (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * ts + 0.00516) +
                (0.15346 * t3 - 0.26756 * t2 + 0.06670 * ts + 0.26688);
    Perez pY = perez_coef(K_PEREZ_Y, T), px = perez_coef(K_PEREZ_X, T), py = perez_coef(K_PEREZ_YC, T);
    double cts = cos(ts);
    double nY = perez_f(&pY, 1.0, ts, cts), nx = perez_f(&px, 1.0, ts, cts), ny = perez_f(&py, 1.0, ts, cts);
    /* sky texels (centre direction) above the horizon */
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            MfVec3 d = texel_dir(x, y, w, h, 0.5f, 0.5f);
            float *o = mf_image_px(out, x, y);
            if (d.z <= 0) continue;
            double cg = fmax(-1.0, fmin(1.0, (double)mf_dot(d, s))), g = acos(cg);
            double Y = Yz * perez_f(&pY, d.z, g, cg) / nY;
            double cx = xz * perez_f(&px, d.z, g, cg) / nx, cy = yz * perez_f(&py, d.z, g, cg) / ny;
            MfVec3 c = mf_v3s(0.0f);
            if (Y > 0 && cy > 1e-4 && isfinite(Y)) c = xyz_to_rgb(cx / cy * Y, Y, (1.0 - cx - cy) / cy * Y);
            o[0] = c.x, o[1] = c.y, o[2] = c.z;
        }
    /* sun disc into its own buffer */
    float *sun = calloc((size_t)w * (size_t)h * 3, sizeof(float));
    if (!sun) { mf_image_free(out); return mf_fail(MF_ENOMEM, "out of memory"); }
    double sun_scale = isfinite(p->sun_scale) ? fmax(0.0, (double)p->sun_scale) : 1.0;
    double zdeg = 90.0 - el * 180.0 / PI_D;
    double m = 1.0 / (cos(ts) + 0.50572 * pow(96.07995 - zdeg, -1.6364)); /* Kasten & Young 1989 */
    double beta = 0.04608 * T - 0.04586;
    static const double lam[3] = {0.61, 0.55, 0.465};
    double edn[3];
    for (int c = 0; c < 3; ++c) {
        double tau = 0.008735 * pow(lam[c], -4.08) + beta * pow(lam[c], -1.3);
        edn[c] = sun_scale * 128.0 * exp(-m * tau); /* klux, direct normal */
    }
    const int K = 64;
    int nvis = 0;
    double r = 0.5 * DS_SUN_DIAMETER_DEG * PI_D / 180.0, cr = cos(r);
    MfFrame f = mf_frame(s);
    for (int i = 0; i < K; ++i)
        for (int j = 0; j < K; ++j) {
            double ca = 1.0 - (i + 0.5) / K * (1.0 - cr), sa = sqrt(fmax(0.0, 1.0 - ca * ca)), ph = 2.0 * PI_D * (j + 0.5) / K;
            MfVec3 d = mf_norm(mf_to_world(&f, mf_v3((float)(sa * cos(ph)), (float)(sa * sin(ph)), (float)ca)));
            if (d.z <= 0) continue; /* behind the ground */
            int tx, ty;
            dir_to_texel(d, w, h, &tx, &ty);
            if (texel_dir(tx, ty, w, h, 0.5f, 0.5f).z <= 0) continue; /* lands in a ground texel */
            ++nvis;
            double k = 1.0 / ((double)K * K * texel_omega(ty, w, h));
            float *o = sun + ((size_t)ty * w + tx) * 3;
            for (int c = 0; c < 3; ++c) o[c] += (float)(edn[c] * k);
        }
    /* horizontal irradiance (per channel) from sky and sun */
    double e_sky[3] = {0, 0, 0}, e_sun[3] = {0, 0, 0};
    for (int y = 0; y < h; ++y) {
        double om = texel_omega(y, w, h);
        for (int x = 0; x < w; ++x) {
            MfVec3 d = texel_dir(x, y, w, h, 0.5f, 0.5f);
            if (d.z <= 0) continue;
            const float *o = mf_image_px(out, x, y), *q = sun + ((size_t)y * w + x) * 3;
            for (int c = 0; c < 3; ++c) e_sky[c] += o[c] * d.z * om, e_sun[c] += q[c] * d.z * om;
        }
    }
    float alb[3] = {p->ground_albedo.x, p->ground_albedo.y, p->ground_albedo.z};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float *o = mf_image_px(out, x, y);
            const float *q = sun + ((size_t)y * w + x) * 3;
            if (texel_dir(x, y, w, h, 0.5f, 0.5f).z <= 0) {
                for (int c = 0; c < 3; ++c) {
                    float a = isfinite(alb[c]) ? mf_clampf(alb[c], 0.0f, 1.0f) : 0.0f;
                    o[c] = (float)(a / PI_D * (e_sky[c] + e_sun[c]));
                }
            } else if (!p->sun_as_light)
                for (int c = 0; c < 3; ++c) o[c] += q[c];
        }
    free(sun);
    double vis = (double)nvis / ((double)K * K);
    MfVec3 sun_rgb = mf_v3((float)(edn[0] * vis), (float)(edn[1] * vis), (float)(edn[2] * vis));
    double sc = normalise_exposure(out, p->exposure, &s, 1, s, p->sun_as_light ? (double)mf_lum(sun_rgb) : 0.0);
    if (info) {
        info->sun_dir = s;
        info->e_sun = sc * mf_lum(mf_v3((float)e_sun[0], (float)e_sun[1], (float)e_sun[2]));
        info->e_sky = sc * mf_lum(mf_v3((float)e_sky[0], (float)e_sky[1], (float)e_sky[2]));
        info->scale = sc;
        info->sun_rgb = mf_scale(sun_rgb, (float)sc);
    }
    return MF_OK;
}

/* ---- room ---- */

static const MfVec3 K_FACE_N[6] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}; /* inward normals */

/* Face hit by the ray from the origin along d; hit point in *hp. */
static int room_hit(const DsIndoorParams *p, MfVec3 d, MfVec3 *hp) {
    double tbest = INFINITY;
    int face = 5;
    double t;
    if (d.x > 0 && (t = p->hx / d.x) < tbest) tbest = t, face = 0;
    if (d.x < 0 && (t = -p->hx / d.x) < tbest) tbest = t, face = 1;
    if (d.y > 0 && (t = p->hy / d.y) < tbest) tbest = t, face = 2;
    if (d.y < 0 && (t = -p->hy / d.y) < tbest) tbest = t, face = 3;
    if (d.z > 0 && (t = p->ceil_z / d.z) < tbest) tbest = t, face = 4;
    if (d.z < 0 && (t = p->floor_z / d.z) < tbest) tbest = t, face = 5;
    if (!isfinite(tbest)) tbest = 0;
    *hp = mf_scale(d, (float)tbest);
    return face;
}

static void face_ab(int face, MfVec3 q, float *a, float *b) {
    if (face <= 1) *a = q.y, *b = q.z;
    else if (face <= 3) *a = q.x, *b = q.z;
    else *a = q.x, *b = q.y;
}

static MfVec3 face_point(const DsIndoorParams *p, int face, float a, float b) {
    switch (face) {
    case 0: return mf_v3(p->hx, a, b);
    case 1: return mf_v3(-p->hx, a, b);
    case 2: return mf_v3(a, p->hy, b);
    case 3: return mf_v3(a, -p->hy, b);
    case 4: return mf_v3(a, b, p->ceil_z);
    default: return mf_v3(a, b, p->floor_z);
    }
}

static int light_at(const DsIndoorParams *p, int face, MfVec3 q) {
    float a, b;
    face_ab(face, q, &a, &b);
    for (int i = 0; i < p->nlights && i < DS_INDOOR_MAX_LIGHTS; ++i) {
        const DsRectLight *l = &p->lights[i];
        if (l->face == face && a >= l->a0 && a <= l->a1 && b >= l->b0 && b <= l->b1) return i;
    }
    return -1;
}

int ds_indoor_hit_light(const DsIndoorParams *p, MfVec3 d) {
    MfVec3 q;
    int f = room_hit(p, d, &q);
    return light_at(p, f, q);
}

void ds_indoor_light_corners(const DsIndoorParams *p, int i, MfVec3 c[4]) {
    const DsRectLight *l = &p->lights[i];
    c[0] = face_point(p, l->face, l->a0, l->b0);
    c[1] = face_point(p, l->face, l->a1, l->b0);
    c[2] = face_point(p, l->face, l->a1, l->b1);
    c[3] = face_point(p, l->face, l->a0, l->b1);
}

static float hash01(uint64_t seed, int64_t a, int64_t b) {
    return (float)(mf_hash64(seed, ((uint64_t)(uint32_t)a << 32) | (uint32_t)b) >> 40) * (1.0f / 16777216.0f);
}

/* Smooth value noise in [0, 1] on a 0.6 m lattice. */
static float value_noise(uint64_t seed, float a, float b) {
    float fa = a / 0.6f, fb = b / 0.6f;
    float ia = floorf(fa), ib = floorf(fb), ta = fa - ia, tb = fb - ib;
    ta = ta * ta * (3 - 2 * ta), tb = tb * tb * (3 - 2 * tb);
    int64_t xa = (int64_t)ia, xb = (int64_t)ib;
    float v00 = hash01(seed, xa, xb), v10 = hash01(seed, xa + 1, xb), v01 = hash01(seed, xa, xb + 1), v11 = hash01(seed, xa + 1, xb + 1);
    return (v00 * (1 - ta) + v10 * ta) * (1 - tb) + (v01 * (1 - ta) + v11 * ta) * tb;
}

void ds_indoor_params_random(uint64_t seed, DsIndoorParams *p) {
    MfRng r;
    mf_rng_seed(&r, seed, 0x1d00u);
    memset(p, 0, sizeof *p);
    p->hx = 1.5f + 2.5f * mf_rng_float(&r);
    p->hy = 1.5f + 2.5f * mf_rng_float(&r);
    float height = 2.2f + 1.4f * mf_rng_float(&r), eye = 0.8f + 0.6f * mf_rng_float(&r);
    p->floor_z = -eye;
    p->ceil_z = height - eye;
    float wall = 0.45f + 0.35f * mf_rng_float(&r);
    MfVec3 wall_c = mf_v3(wall * (1.0f + 0.2f * (mf_rng_float(&r) - 0.5f)), wall, wall * (1.0f + 0.2f * (mf_rng_float(&r) - 0.5f)));
    for (int f = 0; f < 4; ++f) p->albedo[f] = wall_c;
    float cl = 0.65f + 0.2f * mf_rng_float(&r);
    p->albedo[4] = mf_v3s(cl);
    float fl = 0.1f + 0.3f * mf_rng_float(&r);
    p->albedo[5] = mf_v3(fl * 1.2f, fl, fl * 0.75f);
    p->pattern_seed = mf_hash64(seed, 0x9a77e2u);
    p->nlights = 1 + (int)mf_rng_below(&r, DS_INDOOR_MAX_LIGHTS);
    p->wall_scale = 1.0f;
    p->exposure = 0.7f + 1.3f * mf_rng_float(&r);
    int n = 0;
    for (int tries = 0; tries < 64 && n < p->nlights; ++tries) {
        DsRectLight l;
        int window = mf_rng_float(&r) < 0.45f;
        if (window) {
            l.face = (int)mf_rng_below(&r, 4);
            float len = l.face <= 1 ? p->hy : p->hx; /* half length of that wall */
            float wdt = fminf(0.6f + 1.4f * mf_rng_float(&r), 2.0f * len - 0.4f), hgt = 0.8f + 0.8f * mf_rng_float(&r);
            float c = (2.0f * mf_rng_float(&r) - 1.0f) * (len - 0.2f - 0.5f * wdt);
            float b0 = p->floor_z + 0.7f + 0.3f * mf_rng_float(&r);
            if (b0 + hgt > p->ceil_z - 0.1f) hgt = p->ceil_z - 0.1f - b0;
            l.a0 = c - 0.5f * wdt, l.a1 = c + 0.5f * wdt, l.b0 = b0, l.b1 = b0 + hgt;
            l.kelvin = 5000.0f + 5000.0f * mf_rng_float(&r);
        } else {
            l.face = 4;
            float sa = 0.3f + 0.9f * mf_rng_float(&r), sb = 0.3f + 0.9f * mf_rng_float(&r);
            sa = fminf(sa, 2.0f * p->hx - 0.4f), sb = fminf(sb, 2.0f * p->hy - 0.4f);
            float ca = (2.0f * mf_rng_float(&r) - 1.0f) * (p->hx - 0.2f - 0.5f * sa), cb = (2.0f * mf_rng_float(&r) - 1.0f) * (p->hy - 0.2f - 0.5f * sb);
            l.a0 = ca - 0.5f * sa, l.a1 = ca + 0.5f * sa, l.b0 = cb - 0.5f * sb, l.b1 = cb + 0.5f * sb;
            l.kelvin = 2700.0f + 3800.0f * mf_rng_float(&r);
        }
        float inten = 1.0f + 3.0f * mf_rng_float(&r);
        l.radiance = mf_scale(ds_kelvin_rgb(l.kelvin), (window ? 3.0f : 2.0f) * inten);
        int overlap = 0; /* keep 0.1 m apart from the others on the same face */
        for (int j = 0; j < n; ++j) {
            const DsRectLight *o = &p->lights[j];
            if (o->face == l.face && l.a0 < o->a1 + 0.1f && o->a0 < l.a1 + 0.1f && l.b0 < o->b1 + 0.1f && o->b0 < l.b1 + 0.1f) overlap = 1;
        }
        if (!overlap && l.a1 > l.a0 && l.b1 > l.b0) p->lights[n++] = l;
    }
    p->nlights = n > 0 ? n : 1;
    if (n == 0) { /* unreachable in practice: one central ceiling panel */
        DsRectLight l = {4, -0.3f, 0.3f, -0.3f, 0.3f, 4000.0f, mf_scale(ds_kelvin_rgb(4000.0f), 4.0f)};
        p->lights[0] = l;
    }
}

int ds_env_indoor(const DsIndoorParams *p, int w, int h, MfImage *out, double *scale) {
    memset(out, 0, sizeof *out);
    if (p->nlights < 1 || p->nlights > DS_INDOOR_MAX_LIGHTS) return mf_fail(MF_EARG, "envgen: %d room lights outside [1, %d]", p->nlights, DS_INDOOR_MAX_LIGHTS);
    if (!(p->hx > 0 && p->hy > 0 && p->floor_z < 0 && p->ceil_z > 0 && isfinite(p->hx) && isfinite(p->hy) && isfinite(p->floor_z) && isfinite(p->ceil_z)))
        return mf_fail(MF_EARG, "envgen: the room must contain the observer (hx, hy > 0, floor_z < 0 < ceil_z)");
    for (int i = 0; i < p->nlights; ++i)
        if (p->lights[i].face < 0 || p->lights[i].face > 4 || !mf_isfinite3(p->lights[i].radiance))
            return mf_fail(MF_EARG, "envgen: room light %d: bad face or radiance", i);
    int rc = check_size(w, h, out);
    if (rc) return rc;
    /* emitted power and the indirect (integrating-sphere) irradiance, per channel */
    double area[6] = {2.0 * p->hy * (p->ceil_z - p->floor_z), 0, 2.0 * p->hx * (p->ceil_z - p->floor_z), 0, 4.0 * p->hx * p->hy, 0};
    area[1] = area[0], area[3] = area[2], area[5] = area[4];
    double atot = 0, rho[3] = {0, 0, 0}, phi[3] = {0, 0, 0};
    for (int f = 0; f < 6; ++f) {
        atot += area[f];
        rho[0] += area[f] * p->albedo[f].x, rho[1] += area[f] * p->albedo[f].y, rho[2] += area[f] * p->albedo[f].z;
    }
    for (int i = 0; i < p->nlights; ++i) {
        const DsRectLight *l = &p->lights[i];
        double a = (double)(l->a1 - l->a0) * (l->b1 - l->b0) * PI_D;
        phi[0] += l->radiance.x * a, phi[1] += l->radiance.y * a, phi[2] += l->radiance.z * a;
    }
    double e_ind[3];
    for (int c = 0; c < 3; ++c) {
        double rh = fmin(0.95, fmax(0.0, rho[c] / atot));
        e_ind[c] = rh / (1.0 - rh) * phi[c] / atot;
    }
    float wall_scale = isfinite(p->wall_scale) ? fmaxf(0.0f, p->wall_scale) : 1.0f;
    const int S = 4;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            /* wall radiance at the texel centre's hit point */
            MfVec3 q, dc = texel_dir(x, y, w, h, 0.5f, 0.5f);
            int fc = room_hit(p, dc, &q);
            MfVec3 wallL = mf_v3s(0.0f);
            if (wall_scale > 0) {
                MfVec3 n = K_FACE_N[fc];
                double e[3] = {e_ind[0], e_ind[1], e_ind[2]};
                for (int i = 0; i < p->nlights; ++i) {
                    const DsRectLight *l = &p->lights[i];
                    if (l->face == fc) continue; /* coplanar: no direct light */
                    MfVec3 ln = K_FACE_N[l->face];
                    double dA = (double)(l->a1 - l->a0) * (l->b1 - l->b0) / 16.0;
                    for (int si = 0; si < 4; ++si)
                        for (int sj = 0; sj < 4; ++sj) {
                            MfVec3 lp = face_point(p, l->face, l->a0 + (l->a1 - l->a0) * (si + 0.5f) / 4, l->b0 + (l->b1 - l->b0) * (sj + 0.5f) / 4);
                            MfVec3 v = mf_sub(lp, q);
                            double r2 = fmax((double)mf_dot(v, v), 1e-2), rl = sqrt(r2);
                            double c1 = mf_dot(n, v) / rl, c2 = -mf_dot(ln, v) / rl;
                            if (c1 <= 0 || c2 <= 0) continue;
                            double k = c1 * c2 / r2 * dA;
                            e[0] += l->radiance.x * k, e[1] += l->radiance.y * k, e[2] += l->radiance.z * k;
                        }
                }
                float a, b;
                face_ab(fc, q, &a, &b);
                float pat = 0.75f + 0.5f * value_noise(p->pattern_seed ^ ((uint64_t)fc * 0x9E3779B97F4A7C15ull), a, b);
                MfVec3 al = p->albedo[fc];
                wallL = mf_scale(mf_v3((float)(al.x * e[0]), (float)(al.y * e[1]), (float)(al.z * e[2])), (float)(pat * wall_scale / PI_D));
            }
            MfVec3 acc = mf_v3s(0.0f);
            for (int si = 0; si < S; ++si)
                for (int sj = 0; sj < S; ++sj) {
                    MfVec3 d = texel_dir(x, y, w, h, (si + 0.5f) / S, (sj + 0.5f) / S);
                    int f = room_hit(p, d, &q);
                    int li = light_at(p, f, q);
                    acc = mf_add(acc, li >= 0 ? p->lights[li].radiance : wallL);
                }
            acc = mf_scale(acc, 1.0f / (S * S));
            float *o = mf_image_px(out, x, y);
            o[0] = fmaxf(0.0f, acc.x), o[1] = fmaxf(0.0f, acc.y), o[2] = fmaxf(0.0f, acc.z);
            if (!mf_isfinite3(acc)) o[0] = o[1] = o[2] = 0.0f;
        }
    MfVec3 centres[DS_INDOOR_MAX_LIGHTS];
    for (int i = 0; i < p->nlights; ++i) {
        MfVec3 c[4];
        ds_indoor_light_corners(p, i, c);
        centres[i] = mf_norm(mf_scale(mf_add(mf_add(c[0], c[1]), mf_add(c[2], c[3])), 0.25f));
    }
    double sc = normalise_exposure(out, p->exposure, centres, p->nlights, mf_v3(0, 0, 1), 0.0);
    if (scale) *scale = sc;
    return MF_OK;
}

int ds_env_random(DsEnvKind kind, uint64_t seed, int w, int h, MfImage *out) {
    if (kind == DS_ENV_SKY) {
        DsSkyParams sp = ds_sky_params_random(seed);
        return ds_env_sky(&sp, w, h, out, NULL);
    }
    DsIndoorParams ip;
    ds_indoor_params_random(seed, &ip);
    return ds_env_indoor(&ip, w, h, out, NULL);
}
