/* mf_light: analytic lights in Blender's units.
 *
 * MF_LIGHT_SUN: directional; `strength` is irradiance in W/m^2 on a surface facing the sun
 *   (Blender's sun Strength); `dir` is the unit direction from the scene TOWARD the sun.
 * MF_LIGHT_POINT: `power` in W, Blender's convention: radiant intensity I = P / (4 pi) W/sr,
 *   so irradiance at distance r facing the light is I / r^2. `pos` in world space.
 * `color` multiplies either (linear RGB, (1,1,1) = white). */
#ifndef MF_LIGHT_H
#define MF_LIGHT_H

#include "core/mf_math.h"

typedef enum { MF_LIGHT_SUN = 0, MF_LIGHT_POINT = 1 } MfLightKind;

typedef struct {
    MfLightKind kind;
    MfVec3 color;
    float strength; /* sun: W/m^2; point: power in W */
    MfVec3 dir;     /* sun: unit vector toward the light */
    MfVec3 pos;     /* point: position */
} MfLight;

/* For a shading point p: unit direction to the light, distance (INFINITY for the sun), and the
 * irradiance on a surface perpendicular to that direction (RGB, W/m^2). */
void mf_light_incident(const MfLight *l, MfVec3 p, MfVec3 *wi, float *dist, MfVec3 *irradiance);

#endif
