#include "datasets/ds_materials.h"

#include <math.h>

static const char *k_class_names[DS_MAT_COUNT] = {"metal", "plastic", "rubber", "wood", "ceramic", "glass"};

const char *ds_mat_class_name(DsMatClass c) { return (c >= 0 && c < DS_MAT_COUNT) ? k_class_names[c] : "unknown"; }

/* ---- noise ---- */

static inline uint32_t hash3(int x, int y, int z, uint64_t seed) {
    uint64_t h = seed * 0x9E3779B97F4A7C15ULL;
    h ^= (uint64_t)(uint32_t)x * 0xC2B2AE3D27D4EB4FULL;
    h = (h ^ (h >> 29)) * 0xBF58476D1CE4E5B9ULL;
    h ^= (uint64_t)(uint32_t)y * 0x165667B19E3779F9ULL;
    h = (h ^ (h >> 32)) * 0x94D049BB133111EBULL;
    h ^= (uint64_t)(uint32_t)z * 0x27D4EB2F165667C5ULL;
    h = (h ^ (h >> 31)) * 0xD6E8FEB86659FD93ULL;
    return (uint32_t)(h >> 32);
}

static inline float lattice(int x, int y, int z, uint64_t seed) { return (float)(hash3(x, y, z, seed) >> 8) * (1.0f / 16777216.0f); }

static inline float smooth5(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

float ds_value_noise(MfVec3 p, uint64_t seed) {
    float fx = floorf(p.x), fy = floorf(p.y), fz = floorf(p.z);
    int ix = (int)fx, iy = (int)fy, iz = (int)fz;
    float tx = smooth5(p.x - fx), ty = smooth5(p.y - fy), tz = smooth5(p.z - fz);
    float c[8];
    for (int k = 0; k < 8; ++k) c[k] = lattice(ix + (k & 1), iy + ((k >> 1) & 1), iz + (k >> 2), seed);
    float x00 = c[0] + (c[1] - c[0]) * tx, x10 = c[2] + (c[3] - c[2]) * tx;
    float x01 = c[4] + (c[5] - c[4]) * tx, x11 = c[6] + (c[7] - c[6]) * tx;
    float y0 = x00 + (x10 - x00) * ty, y1 = x01 + (x11 - x01) * ty;
    return y0 + (y1 - y0) * tz;
}

float ds_fbm(MfVec3 p, int octaves, uint64_t seed) {
    float sum = 0.0f, amp = 0.5f, norm = 0.0f;
    for (int o = 0; o < octaves; ++o) {
        sum += amp * ds_value_noise(p, seed + (uint64_t)o * 1013u);
        norm += amp;
        amp *= 0.5f;
        /* rotate-ish and scale to avoid lattice alignment between octaves */
        p = mf_v3(1.97f * p.x + 0.31f * p.z + 17.1f, 2.03f * p.y - 0.27f * p.x + 3.7f, 1.99f * p.z + 0.23f * p.y - 9.3f);
    }
    return sum / norm;
}

static inline float smoothstepf(float a, float b, float x) {
    float t = mf_clampf((x - a) / (b - a), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

/* ---- palettes (linear RGB) ---- */

static const float k_metal_cols[][3] = {
    {0.56f, 0.57f, 0.58f}, /* iron/steel */
    {0.91f, 0.92f, 0.92f}, /* aluminium */
    {1.00f, 0.78f, 0.34f}, /* gold */
    {0.95f, 0.64f, 0.54f}, /* copper */
    {0.88f, 0.78f, 0.50f}, /* brass */
    {0.55f, 0.56f, 0.55f}, /* chrome */
};
static const float k_plastic_cols[][3] = {
    {0.60f, 0.05f, 0.04f}, {0.04f, 0.20f, 0.60f}, {0.70f, 0.55f, 0.03f}, {0.05f, 0.40f, 0.10f},
    {0.80f, 0.80f, 0.78f}, {0.03f, 0.03f, 0.03f}, {0.80f, 0.25f, 0.02f}, {0.35f, 0.05f, 0.45f},
};
static const float k_rubber_cols[][3] = {
    {0.02f, 0.02f, 0.02f}, {0.05f, 0.05f, 0.06f}, {0.15f, 0.03f, 0.02f}, {0.03f, 0.06f, 0.12f},
};
static const float k_paint_cols[][3] = {
    {0.55f, 0.10f, 0.08f}, {0.10f, 0.25f, 0.35f}, {0.60f, 0.55f, 0.40f}, {0.15f, 0.30f, 0.12f},
    {0.75f, 0.72f, 0.65f}, {0.08f, 0.08f, 0.10f},
};
static const float k_ceramic_cols[][3] = {
    {0.85f, 0.84f, 0.80f}, {0.70f, 0.80f, 0.85f}, {0.85f, 0.70f, 0.60f}, {0.60f, 0.75f, 0.60f},
    {0.10f, 0.15f, 0.40f}, {0.80f, 0.45f, 0.30f},
};

static MfVec3 pick(const float (*pal)[3], int n, MfRng *rng, float jitter) {
    const float *c = pal[mf_rng_below(rng, (uint32_t)n)];
    MfVec3 v;
    float s = 1.0f + jitter * (2.0f * mf_rng_float(rng) - 1.0f);
    v.x = mf_clampf(c[0] * s * (1.0f + 0.5f * jitter * (mf_rng_float(rng) - 0.5f)), 0.0f, 1.0f);
    v.y = mf_clampf(c[1] * s * (1.0f + 0.5f * jitter * (mf_rng_float(rng) - 0.5f)), 0.0f, 1.0f);
    v.z = mf_clampf(c[2] * s * (1.0f + 0.5f * jitter * (mf_rng_float(rng) - 0.5f)), 0.0f, 1.0f);
    return v;
}

static float urange(MfRng *rng, float a, float b) { return a + (b - a) * mf_rng_float(rng); }

static MfVec3 random_axis(MfRng *rng) {
    /* mostly along z (bands around a revolved object), sometimes tilted */
    float t = urange(rng, 0.0f, 0.6f), ph = urange(rng, 0.0f, 2.0f * MF_PI);
    return mf_norm(mf_v3(sinf(t) * cosf(ph), sinf(t) * sinf(ph), cosf(t)));
}

void ds_material_random(DsMaterial *m, DsMatClass cls, int force_pattern, MfRng *rng) {
    DsMaterial r = {0};
    r.cls = cls;
    r.seed = ((uint64_t)mf_rng_u32(rng) << 32) | mf_rng_u32(rng);
    r.axis = random_axis(rng);
    r.freq = urange(rng, 3.0f, 9.0f);
    r.label_z0 = urange(rng, -0.25f, 0.0f);
    r.label_z1 = r.label_z0 + urange(rng, 0.12f, 0.3f);
    DsPattern pats[4];
    int np = 0;
    switch (cls) {
    case DS_MAT_METAL:
        r.base = pick(k_metal_cols, 6, rng, 0.05f);
        r.second = pick(k_paint_cols, 6, rng, 0.1f);
        r.rough = urange(rng, 0.12f, 0.45f);
        r.rough_var = urange(rng, 0.02f, 0.12f);
        r.metallic = 1.0f;
        r.scratches = urange(rng, 0.2f, 1.0f);
        r.wear = 0.0f;
        pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_FBM; pats[np++] = DS_PAT_LABEL;
        r.mask_metal = 1; /* label = paint, not metal */
        break;
    case DS_MAT_PLASTIC:
        r.base = pick(k_plastic_cols, 8, rng, 0.15f);
        r.second = pick(k_plastic_cols, 8, rng, 0.15f);
        r.rough = urange(rng, 0.25f, 0.6f);
        r.rough_var = urange(rng, 0.02f, 0.08f);
        r.metallic = 0.0f;
        r.scratches = urange(rng, 0.0f, 0.5f);
        pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_STRIPES; pats[np++] = DS_PAT_CHECKER; pats[np++] = DS_PAT_LABEL;
        r.mask_metal = mf_rng_float(rng) < 0.25f; /* foil stripes */
        break;
    case DS_MAT_RUBBER:
        r.base = pick(k_rubber_cols, 4, rng, 0.2f);
        r.second = mf_scale(r.base, 1.6f);
        r.rough = urange(rng, 0.82f, 0.95f);
        r.rough_var = urange(rng, 0.01f, 0.04f);
        r.metallic = 0.0f;
        pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_FBM;
        break;
    case DS_MAT_WOOD:
        r.base = pick(k_paint_cols, 6, rng, 0.1f);
        r.second = mf_v3(urange(rng, 0.25f, 0.45f), urange(rng, 0.12f, 0.22f), urange(rng, 0.04f, 0.08f)); /* bare wood */
        r.rough = urange(rng, 0.45f, 0.7f);
        r.rough_var = urange(rng, 0.02f, 0.08f);
        r.metallic = 0.0f;
        r.wear = urange(rng, 0.1f, 0.45f);
        r.freq = urange(rng, 12.0f, 30.0f); /* grain rings */
        pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_STRIPES;
        break;
    case DS_MAT_CERAMIC:
        r.base = pick(k_ceramic_cols, 6, rng, 0.08f);
        r.second = pick(k_ceramic_cols, 6, rng, 0.08f);
        r.rough = urange(rng, 0.06f, 0.25f);
        r.rough_var = urange(rng, 0.01f, 0.05f);
        r.metallic = 0.0f;
        pats[np++] = DS_PAT_PLAIN; pats[np++] = DS_PAT_STRIPES; pats[np++] = DS_PAT_FBM; pats[np++] = DS_PAT_LABEL;
        r.mask_metal = mf_rng_float(rng) < 0.3f; /* gold bands */
        if (r.mask_metal) r.second = mf_v3(1.0f, 0.78f, 0.34f);
        break;
    case DS_MAT_GLASS:
    default:
        r.cls = DS_MAT_GLASS;
        r.base = r.second = mf_v3(0, 0, 0);
        r.rough = 0.25f;
        r.metallic = 0.0f;
        pats[np++] = DS_PAT_PLAIN;
        break;
    }
    r.pattern = force_pattern >= 0 && force_pattern < DS_PAT_COUNT ? (DsPattern)force_pattern : pats[mf_rng_below(rng, (uint32_t)np)];
    /* metallic masks: painted label on metal; foil / gold stripes on plastic and ceramic */
    if (cls == DS_MAT_METAL) r.mask_metal = r.pattern == DS_PAT_LABEL;
    else if (r.pattern != DS_PAT_STRIPES && r.pattern != DS_PAT_LABEL) r.mask_metal = 0;
    if (cls == DS_MAT_METAL && r.pattern != DS_PAT_LABEL) r.second = mf_scale(mf_mul(r.base, mf_v3(0.8f, 0.75f, 0.7f)), 0.8f); /* tarnish */
    *m = r;
}

/* Pattern mask in [0, 1] at local point p (1 = second colour). */
static float pattern_mask(const DsMaterial *m, MfVec3 p) {
    switch (m->pattern) {
    case DS_PAT_FBM: return smoothstepf(0.42f, 0.62f, ds_fbm(mf_scale(p, m->freq), 4, m->seed + 7));
    case DS_PAT_STRIPES: {
        float s = mf_dot(p, m->axis) * m->freq;
        float f = s - floorf(s);
        return smoothstepf(0.0f, 0.04f, f) * (1.0f - smoothstepf(0.3f, 0.34f, f));
    }
    case DS_PAT_CHECKER: {
        float k = m->freq * 0.8f;
        int a = (int)floorf(p.x * k) + (int)floorf(p.y * k) + (int)floorf(p.z * k);
        return (float)(a & 1);
    }
    case DS_PAT_LABEL: {
        if (p.z < m->label_z0 || p.z > m->label_z1) return 0.0f;
        float ang = atan2f(p.y, p.x); /* label covers about 60% of the circumference */
        if (ang < -1.9f || ang > 1.9f) return 0.0f;
        /* text-like blocks: rows of random-width glyph cells, drawn in base colour on the label */
        float h = m->label_z1 - m->label_z0, zr = (p.z - m->label_z0) / h;
        int row = (int)floorf(zr * 4.0f);
        float zin = zr * 4.0f - (float)row;
        float col = (ang + 1.9f) * 9.0f;
        int ci = (int)floorf(col);
        float cin = col - (float)ci;
        uint32_t hsh = (uint32_t)((m->seed >> 7) ^ (uint64_t)(row * 7919 + ci * 104729));
        hsh = hsh * 2654435761u;
        int glyph = row >= 1 && row <= 2 && ((hsh >> 13) & 3) != 0 && zin > 0.2f && zin < 0.8f && cin > 0.15f && cin < 0.85f;
        return glyph ? 0.35f : 1.0f; /* 1 = label paper, 0.35 = ink (mixed below) */
    }
    case DS_PAT_TICKS: {
        float r = sqrtf(p.x * p.x + p.y * p.y);
        float ang = atan2f(p.y, p.x);
        float a12 = ang * (6.0f / MF_PI);
        float d = fabsf(a12 - roundf(a12)) * (MF_PI / 6.0f) * r; /* arc distance to nearest tick line */
        float R = m->label_z1;                                    /* face radius stored here */
        int tick = r > 0.72f * R && r < 0.88f * R && d < 0.018f * R;
        int ring = fabsf(r - 0.92f * R) < 0.01f * R;
        return (tick || ring) ? 1.0f : 0.0f;
    }
    default: return 0.0f;
    }
}

void ds_material_eval(const DsMaterial *m, MfVec3 p, MfVec3 n, MfVec3 *kd, float *rough, float *metallic) {
    (void)n;
    if (m->cls == DS_MAT_GLASS) {
        *kd = mf_v3(0, 0, 0);
        *rough = 0.25f;
        *metallic = 0.0f;
        return;
    }
    float mask = pattern_mask(m, p);
    MfVec3 c = m->base;
    float r = m->rough, mt = m->metallic;
    /* subtle low-frequency colour variation everywhere */
    float tint = 0.92f + 0.16f * ds_fbm(mf_scale(p, 6.0f), 3, m->seed + 11);
    if (m->pattern == DS_PAT_LABEL && mask > 0.0f) {
        /* label paper in second colour, ink in dark base */
        MfVec3 paper = m->second, ink = mf_scale(m->base, 0.15f);
        c = mask >= 1.0f ? paper : ink;
        if (m->mask_metal) mt = 1.0f - m->metallic; /* painted label on metal, foil label on plastic */
        r = m->cls == DS_MAT_METAL ? 0.5f : r;
    } else {
        c = mf_lerp3(c, m->second, mask);
        if (m->mask_metal && mask > 0.5f) mt = 1.0f - m->metallic;
    }
    c = mf_scale(c, tint);
    /* roughness variation */
    r += m->rough_var * (2.0f * ds_fbm(mf_scale(p, 11.0f), 3, m->seed + 23) - 1.0f);
    if (m->cls == DS_MAT_METAL && m->pattern != DS_PAT_LABEL) {
        /* brushing: fine noise stretched along the axis */
        MfVec3 q = p;
        float along = mf_dot(q, m->axis);
        MfVec3 perp = mf_sub(q, mf_scale(m->axis, along));
        float br = ds_value_noise(mf_v3(perp.x * 160.0f, perp.y * 160.0f, along * 6.0f + perp.z * 160.0f), m->seed + 31);
        r += 0.06f * (br - 0.5f);
    }
    if (m->scratches > 0.0f) {
        /* thin ridges of a warped 1D noise: scratches are smoother (metal) or rougher (plastic) */
        float w = ds_fbm(mf_scale(p, 3.0f), 2, m->seed + 41);
        float s = ds_value_noise(mf_v3(mf_dot(p, mf_v3(0.8f, 0.6f, 0.0f)) * 90.0f + w * 8.0f, p.z * 2.0f, 0.5f), m->seed + 43);
        float scr = smoothstepf(0.93f, 0.99f, 1.0f - fabsf(2.0f * s - 1.0f));
        scr *= smoothstepf(0.35f, 0.6f, ds_value_noise(mf_scale(p, 5.0f), m->seed + 47)) * m->scratches;
        r += (m->cls == DS_MAT_METAL ? -0.5f : 0.25f) * scr * r;
        c = mf_lerp3(c, mf_scale(c, 1.2f), 0.3f * scr);
    }
    if (m->cls == DS_MAT_WOOD) {
        /* wood grain rings around the axis, shown where the paint is worn */
        float along = mf_dot(p, m->axis);
        MfVec3 perp = mf_sub(p, mf_scale(m->axis, along));
        float rad = mf_len(perp) + 0.03f * ds_fbm(mf_scale(p, 4.0f), 3, m->seed + 53);
        float ring = 0.5f + 0.5f * sinf(rad * m->freq * 2.0f * MF_PI);
        MfVec3 wood = mf_lerp3(m->second, mf_scale(m->second, 0.6f), ring);
        float wear = smoothstepf(1.0f - m->wear - 0.04f, 1.0f - m->wear + 0.04f, ds_fbm(mf_scale(p, 7.0f), 5, m->seed + 59));
        c = mf_lerp3(c, wood, wear);
        r = r + (0.85f - r) * wear;
    }
    float lo = 0.0f, hi = 1.0f;
    switch (m->cls) {
    case DS_MAT_METAL: lo = 0.08f; hi = 0.6f; break;
    case DS_MAT_PLASTIC: lo = 0.2f; hi = 0.7f; break;
    case DS_MAT_RUBBER: lo = 0.75f; hi = 1.0f; break;
    case DS_MAT_WOOD: lo = 0.35f; hi = 0.9f; break;
    case DS_MAT_CERAMIC: lo = 0.04f; hi = 0.35f; break;
    default: break;
    }
    *kd = mf_v3(mf_clampf(c.x, 0.0f, 1.0f), mf_clampf(c.y, 0.0f, 1.0f), mf_clampf(c.z, 0.0f, 1.0f));
    *rough = mf_clampf(r, lo, hi);
    *metallic = mf_clampf(mt, 0.0f, 1.0f);
}
