/* mf_light: sun and point lights in Blender's units (see mf_light.h). */
#include "scene/mf_light.h"

#include <math.h>

void mf_light_incident(const MfLight *l, MfVec3 p, MfVec3 *wi, float *dist, MfVec3 *irradiance) {
    if (l->kind == MF_LIGHT_SUN) {
        *wi = mf_norm(l->dir);
        *dist = INFINITY;
        *irradiance = mf_scale(l->color, l->strength);
        return;
    }
    MfVec3 d = mf_sub(l->pos, p);
    float r2 = mf_dot(d, d);
    if (!(r2 > 0.0f) || !isfinite(r2)) { /* at the light itself: no defined direction */
        *wi = mf_v3(0.0f, 0.0f, 1.0f);
        *dist = 0.0f;
        *irradiance = mf_v3s(0.0f);
        return;
    }
    float r = sqrtf(r2);
    *wi = mf_scale(d, 1.0f / r);
    *dist = r;
    *irradiance = mf_scale(l->color, l->strength * MF_INV_4PI / r2);
}
