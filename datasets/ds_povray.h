/* ds_povray: POV-Ray (Debian's povray 3.7) as an independent reference renderer.
 *
 * Exports a scene (triangle mesh with UVs, an albedo texture or constant colour, an HDR
 * environment in Blender's mapping, sun and point lights) to POV-Ray's scene language, runs
 * povray, and reads its linear EXR output, so evaluation can use ground truth that our own
 * renderer did not make (no inverse crime).
 *
 * What POV-Ray can model, and how it is mapped (each mapping was checked by a test):
 * - Coordinates: our world is right-handed, +Z up; POV-Ray's is left-handed, +Y up. A point
 *   (x, y, z) is written as <x, z, y> (swapping two axes flips the handedness); cameras are given
 *   by explicit location/direction/right/up vectors converted the same way.
 * - Surfaces are Lambertian only: finish { diffuse 1 ambient 0 }, pigment = kd. POV-Ray has no
 *   GGX microfacet lobe, so ground truth is valid for diffuse-dominant materials (metallic 0,
 *   high roughness), where our BRDF adds only the F0 = 0.04 specular lobe.
 * - POV-Ray's diffuse term has no 1/pi: radiance = pigment * light colour * cos. A sun of
 *   strength E (W/m^2) becomes a parallel light of colour E/pi. A point light of power P
 *   (irradiance P/(4 pi r^2)) becomes a light with fade_power 2 and fade_distance f, whose
 *   attenuation 2/(1 + (r/f)^2) ~ 2 f^2 / r^2; colour = P / (4 pi^2 * 2 f^2), exact to (f/r)^2.
 * - Environment light: a sky_sphere with the lat-long map (spherical map_type 1, bilinear,
 *   mirrored in x to match Blender's mapping) reaches surfaces through radiosity with
 *   recursion_limit 1, i.e. direct environment light with occlusion and no interreflection
 *   (what our integrator computes). Radiosity interpolates irradiance between cached samples,
 *   which costs accuracy on small features: the radiosity `count` sets the quality.
 * The env map and textures travel as Radiance .hdr files (linear, 8-bit shared-exponent
 * mantissas: about 1% of a pixel's largest channel). */
#ifndef DS_POVRAY_H
#define DS_POVRAY_H

#include "io/mf_image.h"
#include "scene/mf_camera.h"
#include "scene/mf_light.h"
#include "scene/mf_mesh.h"

typedef struct {
    const MfMesh *mesh;    /* borrowed; world space, uv required when kd is given */
    const MfImage *kd;     /* borrowed; (h, w, 3) linear base colour texture, or NULL */
    MfVec3 kd_const;       /* used when kd is NULL */
    const MfImage *env;    /* borrowed; (h, w, 3) linear lat-long radiance, Blender mapping, or NULL */
    const MfLight *lights; /* borrowed; (nlights,) */
    int nlights;
    int radiosity_count;   /* radiosity samples per gather (default 600 when 0) */
    int aa_depth;          /* 0: one ray per pixel centre; d > 0: adaptive-off supersampling, depth d */
    int hide_env;          /* 1: the env lights the object (radiosity) but camera rays do not see it,
                              so alpha = coverage as in our renders: a no_image emissive sphere of
                              radius 1e4 with the sky's mapping instead of a sky_sphere */
} DsPovScene;

/* Writes dir/mesh.inc, dir/kd.hdr and dir/env.hdr (as present): the camera-independent part. */
int ds_povray_export_assets(const DsPovScene *s, const char *dir);
/* Writes dir/<name>.pov for one camera, including the assets of ds_povray_export_assets. */
int ds_povray_write_view(const DsPovScene *s, const MfCamera *cam, const char *dir, const char *name);
/* Runs povray on dir/<name>.pov and reads dir/<name>.exr into out: (h, w, 4) linear RGBA,
 * colour premultiplied by alpha (coverage). povray's log goes to dir/<name>.log. */
int ds_povray_run(const char *dir, const char *name, int w, int h, int aa_depth, MfImage *out);
/* 1 when /usr/bin/povray (or `povray` on PATH) can be run. */
int ds_povray_available(void);

#endif
