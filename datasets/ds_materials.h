/* ds_materials: procedural PBR materials for generated objects (the "Datasets" generator).
 *
 * A DsMaterial is plain data drawn from a seed by class (metal, plastic, rubber, painted wood,
 * ceramic, glass). ds_material_eval evaluates it at a 3D point in the part's local frame (the
 * part's axis is +Z, coordinates of the normalised object, roughly in [-0.5, 0.5]) and returns
 * base colour kd (linear RGB), roughness and metallic (glTF meanings, DESIGN.md). Because the
 * functions are defined in 3D, textures baked from them are continuous across UV seams.
 *
 * Value ranges per class (tests check them):
 *   metal         metallic 1 (0 only inside a painted label), roughness 0.08-0.6
 *   plastic       metallic 0 (1 only inside a metallic-foil stripe mask), roughness 0.2-0.7
 *   rubber        metallic 0, roughness 0.75-1
 *   painted wood  metallic 0, roughness 0.35-0.9 (wood grain shows where the paint is worn)
 *   ceramic       metallic 0 (1 inside a gold rim/stripe mask), roughness 0.04-0.35
 *   glass         replaced by black kd, roughness 0.25, metallic 0 (our BRDF has no transmission)
 * Patterns: value noise / fbm, stripes, checker, labels (a band with text-like blocks), clock
 * ticks; roughness variation from scratches and wear. */
#ifndef DS_MATERIALS_H
#define DS_MATERIALS_H

#include <stdint.h>

#include "core/mf_math.h"
#include "core/mf_rng.h"

typedef enum {
    DS_MAT_METAL = 0,
    DS_MAT_PLASTIC,
    DS_MAT_RUBBER,
    DS_MAT_WOOD,    /* painted wood */
    DS_MAT_CERAMIC,
    DS_MAT_GLASS,   /* rendered as black, roughness 0.25, metallic 0 */
    DS_MAT_COUNT
} DsMatClass;

typedef enum {
    DS_PAT_PLAIN = 0,
    DS_PAT_FBM,     /* two-colour fbm mottling */
    DS_PAT_STRIPES, /* bands along a random axis */
    DS_PAT_CHECKER, /* 3D checker */
    DS_PAT_LABEL,   /* cylindrical label band with text-like blocks */
    DS_PAT_TICKS,   /* clock face: hour ticks and a ring, in the local XY plane */
    DS_PAT_COUNT
} DsPattern;

typedef struct {
    DsMatClass cls;
    DsPattern pattern;
    MfVec3 base;        /* linear RGB base colour */
    MfVec3 second;      /* linear RGB pattern colour */
    float rough;        /* base roughness */
    float rough_var;    /* amplitude of fbm roughness variation */
    float metallic;     /* base metallic */
    float freq;         /* pattern frequency (cycles per unit) */
    MfVec3 axis;        /* unit axis for stripes / brushing */
    float scratches;    /* scratch density in [0, 1] */
    float wear;         /* fraction of worn area in [0, 1] */
    int mask_metal;     /* 1: pattern mask flips metallic (foil stripe, gold rim, painted label) */
    float label_z0, label_z1; /* label band in local z (object units) */
    uint64_t seed;      /* noise seed */
} DsMaterial;

/* Short lower-case name of a class ("metal", "plastic", ...). */
const char *ds_mat_class_name(DsMatClass c);

/* Draws a material of class cls; patterns allowed for the class are chosen at random unless
 * force_pattern >= 0. */
void ds_material_random(DsMaterial *m, DsMatClass cls, int force_pattern, MfRng *rng);

/* Evaluates the material at local point p with local unit normal n: kd (linear RGB, [0,1]),
 * roughness and metallic in [0, 1]. Pure function of (m, p, n). */
void ds_material_eval(const DsMaterial *m, MfVec3 p, MfVec3 n, MfVec3 *kd, float *rough, float *metallic);

/* 3D value noise in [0, 1] (smooth, lattice hashed with seed) and fbm (octaves, gain 0.5). */
float ds_value_noise(MfVec3 p, uint64_t seed);
float ds_fbm(MfVec3 p, int octaves, uint64_t seed);

#endif
