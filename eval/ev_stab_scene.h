/* ev_stab_scene: the hard-case scene variants of the stability grid (issue 18; ev_stability.h).
 *
 * A variant is the tiny split's 000_cup rewritten before and/or after it is rendered:
 *   reference        unchanged
 *   mirror_sun       gt/orm.png = (1, 0, 1) (roughness 0, below its 0.283 floor; metallic 1) and
 *                    an HDR sun added to gt/env.exr: a 2-degree disc at 40 degrees elevation whose
 *                    radiance gives 3 W/m^2 (DS_SUN_MAX) at normal incidence (the nearest texel
 *                    when no texel centre falls inside the disc)
 *   grazing          training cameras moved to 0.5 degrees elevation at their own azimuth and
 *                    distance, looking at the origin (top and bottom seen edge-on)
 *   albedo           gt/kd.png = p (0: black, 1: white)
 *   env_stops        gt/env.exr x 2^p before rendering (8-bit training images: clipped or quantised)
 *   exposure_exr     training images as float EXR (straight alpha): the PNGs' linear values x 2^p
 *   exposure_png     training PNGs' linear values x 2^p, written back as 8-bit sRGB
 *   exposure_png_back  exposure_png's 8-bit values brought back x 2^-p into 16-bit sRGB PNGs:
 *                    the darkened images' information at the reference's exposure (it separates
 *                    what the exposure changes from what the lost bits change)
 *   saturate         as exposure_png with p > 0: clipped highlights
 *   scale            mesh.obj vertices and camera positions (train and test) x p
 *   sliver           every triangle (a, b, c) replaced by a sliver (a, b, m) and (a, m, c),
 *                    m = b + 1e-4 (c - b), plus a zero-area (a, b, b); the surface is unchanged
 *   one_view         only the first training view
 *   mask             each training view's alpha cut to a 2 x 2 pixel block at its mask's
 *                    centroid (colour 0 elsewhere)
 * Relighting lights, test views and GT per-view albedo/ORM are rendered from the rewritten
 * scene (ds_render_split), so a variant's recon is scored against its own ground truth. */
#ifndef EV_STAB_SCENE_H
#define EV_STAB_SCENE_H

typedef enum {
    EV_VAR_REFERENCE,
    EV_VAR_MIRROR_SUN,
    EV_VAR_GRAZING,
    EV_VAR_ALBEDO,
    EV_VAR_ENV_STOPS,
    EV_VAR_EXPOSURE_EXR,
    EV_VAR_EXPOSURE_PNG,
    EV_VAR_EXPOSURE_PNG_BACK,
    EV_VAR_SATURATE,
    EV_VAR_SCALE,
    EV_VAR_SLIVER,
    EV_VAR_ONE_VIEW,
    EV_VAR_MASK
} EvStabVarKind;

typedef struct {
    const char *id;     /* folder name, e.g. "scale_1e-4" */
    EvStabVarKind kind;
    double p;           /* the kind's parameter (see above) */
    const char *what;   /* one line for the report */
} EvStabVariant;

/* Writes the unrendered layout of the tiny split's first scene (000_cup) into layout_dir
 * (ds_write_split with one scene) unless layout_dir/split.json exists. */
int ev_stab_layout(const char *layout_dir);

/* Copies layout_dir to out_dir, applies v and renders it (ds_render_split, resumable: a variant
 * whose out_dir/.done exists is reused). The scene folder is out_dir/000_cup. */
int ev_stab_variant_build(const char *layout_dir, const EvStabVariant *v, const char *out_dir);

#endif
