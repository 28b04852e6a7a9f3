/* ds_envgen: procedural HDR environment maps (clear sky with sun, lit room), deterministic from
 * a seed, so that the lights the material prior is trained under can be kept apart from the
 * relighting probes of the test splits (Blender's studio lights).
 *
 * Output: MfImage (h, w, 3) linear float RGB (Rec.709 / sRGB primaries) lat-long map in the
 * project's env mapping (mf/scene/mf_envmap.h: +Z up, u = 0.5 - atan2(y, x) / (2 pi),
 * v = 0.5 + asin(z) / pi, row 0 = +Z). Default size DS_ENV_W x DS_ENV_H. Every texel is finite
 * and >= 0. Texel (x, y) covers solid angle (2 pi / w) (cos(pi y / h) - cos(pi (y + 1) / h)).
 *
 * Sky (ds_env_sky): Preetham, Shirley, Smits, "A Practical Analytic Model for Daylight",
 * SIGGRAPH 1999. Sky luminance Y and chromaticity x, y each follow the Perez distribution
 *   F(theta, gamma) = (1 + A exp(B / cos theta)) (1 + C exp(D gamma) + E cos^2 gamma)
 * (theta: zenith angle of the view direction, gamma: angle to the sun), value = zenith value *
 * F(theta, gamma) / F(0, theta_s), with the paper's turbidity-linear coefficients (Appendix A.2):
 *   Y: A = 0.1787T - 1.4630, B = -0.3554T + 0.4275, C = -0.0227T + 5.3251, D = 0.1206T - 2.5771,
 *      E = -0.0670T + 0.3703
 *   x: A = -0.0193T - 0.2592, B = -0.0665T + 0.0008, C = -0.0004T + 0.2125, D = -0.0641T - 0.8989,
 *      E = -0.0033T + 0.0452
 *   y: A = -0.0167T - 0.2608, B = -0.0950T + 0.0092, C = -0.0079T + 0.2102, D = -0.0441T - 1.6537,
 *      E = -0.0109T + 0.0529
 * zenith luminance Y_z = (4.0453T - 4.9710) tan(chi) - 0.2155T + 2.4192 kcd/m^2,
 * chi = (4/9 - T/120)(pi - 2 theta_s), and the paper's cubic zenith chromaticities x_z, y_z in
 * (T^2, T, 1) x (theta_s^3, theta_s^2, theta_s, 1). xyY -> XYZ -> linear Rec.709 (negatives -> 0).
 * The model is valid for T in [2, 10] (fails below 1.3) and sun at or above the horizon: the
 * parameters are clamped to those ranges.
 * Sun: a uniform disc of angular diameter 0.53 deg (DS_SUN_DIAMETER_DEG, solid angle 6.7e-5 sr),
 * direct-normal illuminance 128 klux (extraterrestrial, taken as white) times a per-channel
 * Beer-Lambert transmittance exp(-m (tau_R + tau_a)): Rayleigh tau_R = 0.008735 lambda^-4.08
 * (lambda in um), aerosols tau_a = beta lambda^-1.3 with Preetham's beta = 0.04608T - 0.04586,
 * at lambda = 0.61 / 0.55 / 0.465 um for R / G / B, air mass m = Kasten & Young 1989 (finite at
 * the horizon, 38). The disc is rasterised by 64 x 64 stratified directions (uniform in solid
 * angle over the disc), each adding its share of the illuminance / texel solid angle to the texel
 * it falls in, so the map's sun carries the right energy at any resolution (it is smaller than a
 * 256 x 128 texel); parts below the horizon are hidden by the ground. A sub-texel sun is a poor
 * match for bilinear lookup + per-texel importance sampling (mf_envmap.h): about 40% of its
 * bilinear footprint lies in neighbour texels that env samples rarely reach, so renders get
 * fireflies; renderers should take it as a directional light instead (sun_as_light, as ds_gen
 * does).
 * Ground (below the horizon): constant, Lambertian albedo lit by sun + sky:
 *   L_ground = albedo / pi * E_horizontal (per channel).
 * Units with exposure <= 0: photometric, the luminance Y of a texel in kcd/m^2 (so irradiance in
 * klux). Resulting sun share of the irradiance on an upward plane (measured at 256 x 128, checked
 * by tests/test_datasets_envgen.c): T = 2: 0.64 / 0.73 / 0.78 / 0.81 at 30 / 45 / 60 / 75 deg elevation,
 * T = 3: 0.60 / 0.67 / 0.71 / 0.73; 0.43 / 0.39 at 15 deg. The sun dominates, though a little less
 * than in clear-sky measurements (diffuse fraction about 15-25% for a high sun): Preetham's sky
 * is known to be bright (Zotti, Wilkie, Purgathofer 2007). E.g. T = 3, 45 deg: sun 59 klux, sky
 * 29 klux on the horizontal plane.
 *
 * Room (ds_env_indoor): the observer at the origin inside an axis-aligned box room
 * [-hx, hx] x [-hy, hy] x [floor_z, ceil_z] (metres). 1-4 emitting rectangles lie on its faces:
 * ceiling panels (facing down) and windows (on a wall, facing in), each with a uniform radiance
 * of a colour temperature (Planckian locus, Kim et al. 2002 cubic fit, 1667-25000 K) times an
 * intensity. Walls, floor and ceiling are Lambertian (albedo per face times a smooth value-noise
 * pattern in [0.75, 1.25]), radiance = albedo / pi * (direct irradiance from the lights, 4 x 4
 * points per light, no occlusion needed in a convex room, + indirect irradiance
 * rho / (1 - rho) * Phi / A_room from the integrating-sphere formula). Each texel's value is the
 * average over 4 x 4 directions uniform in solid angle over the texel, so light edges are
 * anti-aliased and a light's share of the map equals its solid angle.
 *
 * Exposure (both kinds): with exposure > 0 the map is scaled so that the brightest irradiance
 * over a fixed set of plane normals (6 axes, 64 Fibonacci directions, the sun / light centres),
 * in luminance, equals pi * exposure: a white Lambertian plane facing the main light then has
 * radiance `exposure` (the scale of Blender's probes as used by ds_gen). */
#ifndef DS_ENVGEN_H
#define DS_ENVGEN_H

#include <stdint.h>

#include "core/mf_math.h"
#include "io/mf_image.h"

#define DS_ENV_W 256
#define DS_ENV_H 128
#define DS_SUN_DIAMETER_DEG 0.53f
#define DS_INDOOR_MAX_LIGHTS 4

typedef enum { DS_ENV_SKY = 0, DS_ENV_INDOOR = 1 } DsEnvKind;

typedef struct {
    float sun_elevation;  /* radians above the horizon, clamped to [0, pi/2] */
    float sun_azimuth;    /* radians; sun direction (cos az cos el, sin az cos el, sin el) */
    float turbidity;      /* clamped to [2, 10] (2: very clear, 10: hazy) */
    MfVec3 ground_albedo; /* in [0, 1] */
    float sun_scale;      /* multiplies the sun's illuminance (1: physical; 0: sky only) */
    int sun_as_light;     /* 0: the disc is rasterised into the map; 1: left out of the texels
                             (ground lighting and exposure still count it): the caller adds a
                             directional light of irradiance DsSkyInfo.sun_rgb along sun_dir */
    float exposure;       /* > 0: normalise (header); <= 0: photometric units (kcd/m^2) */
} DsSkyParams;

typedef struct {
    MfVec3 sun_dir;  /* unit */
    double e_sun;    /* irradiance of the sun disc on an upward plane, luminance, map units */
    double e_sky;    /* same for the sky above the horizon (ground does not reach it) */
    double scale;    /* factor applied by the exposure normalisation (1 without) */
    MfVec3 sun_rgb;  /* the sun's irradiance on a plane facing it (RGB, map units after the
                        exposure scale; the part above the horizon) */
} DsSkyInfo;

/* One emitting rectangle on face `face` of the room: 0 +x wall, 1 -x wall, 2 +y wall, 3 -y wall,
 * 4 ceiling, 5 floor (unused). In-face coordinates (a, b): x walls (y, z), y walls (x, z),
 * ceiling (x, y); the rectangle is [a0, a1] x [b0, b1]. */
typedef struct {
    int face;
    float a0, a1, b0, b1;
    float kelvin;     /* colour temperature */
    MfVec3 radiance;  /* emitted radiance, RGB (before exposure) */
} DsRectLight;

typedef struct {
    float hx, hy;          /* room half extents in x, y (m), observer at the origin */
    float floor_z, ceil_z; /* floor_z < 0 < ceil_z */
    MfVec3 albedo[6];      /* per face (same order as DsRectLight.face) */
    uint64_t pattern_seed; /* value-noise pattern of the surfaces */
    int nlights;           /* 1..DS_INDOOR_MAX_LIGHTS */
    DsRectLight lights[DS_INDOOR_MAX_LIGHTS];
    float wall_scale;      /* multiplies wall/floor/ceiling radiance (1; 0: lights only) */
    float exposure;        /* as DsSkyParams.exposure (<= 0: raw units of the light radiances) */
} DsIndoorParams;

/* Random parameters (deterministic from seed): sky elevation 3-80 deg, azimuth 0-360 deg,
 * turbidity 2-6, grey-ish ground albedo 0.08-0.2 (forest, grass, asphalt; brighter ground
 * would outshine the sky under a high sun); room 3-8 m wide, 2.2-3.6 m high, eye 0.8-1.4 m
 * above the floor, 1-4 non-overlapping lights (45% windows 0.6-2 x 0.8-1.6 m, 5000-10000 K;
 * ceiling panels 0.3-1.2 m square-ish, 2700-6500 K; intensity x1-4). Exposure 0.7-2.0 for both:
 * Blender's 8 probes give 0.42 (night) to 2.6 (city), median about 1.5, by the same measure. */
DsSkyParams ds_sky_params_random(uint64_t seed);
void ds_indoor_params_random(uint64_t seed, DsIndoorParams *p);

/* Writes a (h, w, 3) map into out (allocated here). w >= 8, h >= 4. info may be NULL. */
int ds_env_sky(const DsSkyParams *p, int w, int h, MfImage *out, DsSkyInfo *info);
/* scale (may be NULL): the exposure factor applied (1 without). */
int ds_env_indoor(const DsIndoorParams *p, int w, int h, MfImage *out, double *scale);
/* Random map of a kind: ds_*_params_random(seed) then the generator. */
int ds_env_random(DsEnvKind kind, uint64_t seed, int w, int h, MfImage *out);

/* Index of the light the ray from the origin along d (unit) hits, or -1 (wall, floor, ceiling). */
int ds_indoor_hit_light(const DsIndoorParams *p, MfVec3 d);
/* The 4 corners of light i in world space (metres), in order around the rectangle. */
void ds_indoor_light_corners(const DsIndoorParams *p, int i, MfVec3 corners[4]);
/* Planckian-locus colour of a temperature (1667-25000 K, clamped) as linear Rec.709 RGB with
 * luminance 1. */
MfVec3 ds_kelvin_rgb(float kelvin);
/* Irradiance (luminance) on a plane with unit normal n from a (h, w, c >= 3) lat-long map:
 * sum over texels of lum(L) max(0, n . d) Omega (texel centre directions). */
double ds_env_irradiance(const MfImage *img, MfVec3 n);

#endif
