#include "eval/ev_eval_opts.h"

#include <string.h>

_Static_assert(sizeof(EvAlign) == sizeof(int), "MF_OPT_ENUM stores an int");

#define E EvEvalOpts
static const MfOpt k_opts[] = {
    MF_OPT_NAMED(E, "spp", spp_sqrt, MF_OPT_INT, 4, 1, MF_OPT_SPP_MAX, "relighting renders: n^2 env-light + n^2 BSDF samples per pixel sample"),
    MF_OPT_INT(E, pixel_samples, 4, 1, MF_OPT_PIXEL_SAMPLES_MAX, "relighting renders: primary rays per pixel"),
    MF_OPT_ENUM(E, align, EV_ALIGN_MEAN, "none|mean|lsq", "per-channel scale inside the GT mask (mean: ratio of means; lsq: least squares)"),
    MF_OPT_INT(E, max_views, 0, 0, 1000000, "score at most N test views per scene (0: all)"),
    MF_OPT_STR(E, mask, NULL, "masks for test frames without alpha: DIR/<frame name>.png; a relative DIR is inside each scene",
               .unset = "the images' alpha; RGB frames: alpha 1 with a warning", .meta = "DIR"),
    MF_OPT_BOOL(E, no_geom, 0, "skip the geometry columns (Chamfer, normal error, mask IoU against the scene's GT mesh)"),
};
#undef E
const MfOptTable ev_eval_opt_table = MF_OPT_TABLE("Protocol options", k_opts);

EvEvalOpts ev_eval_opts_default(void) {
    EvEvalOpts o;
    memset(&o, 0, sizeof o);
    mf_opts_defaults(&ev_eval_opt_table, &o);
    o.seed = 0x5eedULL; /* relighting renders' base seed (not an option: scores stay comparable) */
    return o;
}
