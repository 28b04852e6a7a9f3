/* ds_cycles: Blender Cycles (Debian's blender 3.4) as a third renderer of the lit views of
 * generated objects: the renderer that made the public data sets (NeRF-Synthetic, NeRFactor,
 * BlenderVault), used as the held-out renderer of the prior's generalisation matrix.
 *
 * One job per object: ds_cycles_begin writes the object's assets into a scratch folder (mesh.obj
 * with UVs and normals as it is in world space, kd.exr and orm.exr linear float), ds_cycles_add_view
 * adds a view (camera, the view's rotated env map as env_<name>.exr unless it equals the previous
 * view's map, whose file it then names: a split's views under one light share one file, and
 * Blender's world stays loaded; its sun / point lights),
 * ds_cycles_run writes job.json and runs `blender -b --factory-startup -P ds_cycles.py -- job.json`
 * once, and ds_cycles_read returns a view's render. What Blender does with the job is in
 * datasets/ds_cycles.py: Principled BSDF (GGX, F0 = 0.04) with kd, roughness and metallic from
 * the textures, full path tracing with `bounces` bounces (our renderer: direct light only, so
 * Cycles adds interreflection), film transparent.
 * Light units: a sun's irradiance is Blender's sun strength (W/m^2); a point light of our power P
 * (irradiance P / (4 pi r^2)) is given to Blender as P watts (DS_CYCLES_POINT_SCALE 1; not checked
 * against a measurement: the prior's metrics are scale-aligned, so a constant factor is harmless).
 * Measured on 16 diffuse test-2d views (64 px): masked PSNR of Cycles' lit view against ours
 * 15.4-38.0 dB, mean linear ratio 1.05-1.48, the low end and high ratios on concave objects whose
 * insides Cycles lights by interreflection (ours: direct light only).
 * Blender: $MF_BLENDER, else /usr/bin/blender. The script: $MF_CYCLES_SCRIPT, else
 * datasets/ds_cycles.py in the current folder, else beside the running binary's repository. */
#ifndef DS_CYCLES_H
#define DS_CYCLES_H

#include <stdint.h>

#include "io/mf_image.h"
#include "scene/mf_light.h"
#include "scene/mf_mesh.h"

#define DS_CYCLES_SAMPLES 128
#define DS_CYCLES_BOUNCES 4

typedef struct {
    char dir[4096];
    int res, samples, bounces;
    void *views; /* cJSON array, owned */
    uint64_t env_hash; /* FNV-1a 64 of the last env map written (0: none): views that share a map share its file */
    char env_file[300];
} DsCyclesJob;

/* 1 when Blender can be run. */
int ds_cycles_available(void);
/* Writes dir/mesh.obj, dir/kd.exr, dir/orm.exr (dir created). kd, orm: (h, w, 3) linear. */
int ds_cycles_begin(DsCyclesJob *j, const char *dir, const MfMesh *mesh, const MfImage *kd, const MfImage *orm, int res);
/* Adds view `name`: c2w (16, row-major, OpenGL camera axes), horizontal field of view; env
 * (h, w, 3) linear lat-long in Blender's mapping (already rotated) or NULL; lights (n,). */
int ds_cycles_add_view(DsCyclesJob *j, const char *name, const double c2w[16], double angle_x, const MfImage *env,
                       const MfLight *lights, int n);
/* Runs Blender on every view added; its log goes to dir/blender.log. */
int ds_cycles_run(DsCyclesJob *j);
/* out: (res, res, 4) linear RGBA of view `name`, colour premultiplied by alpha. */
int ds_cycles_read(const DsCyclesJob *j, const char *name, MfImage *out);
/* Frees the job and removes its scratch files (keep_log: leave blender.log). */
void ds_cycles_end(DsCyclesJob *j, int keep_log);

#endif
