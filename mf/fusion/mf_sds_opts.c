#include "fusion/mf_sds_opts.h"

#include <string.h>

#define S MfSdsOpts
static const MfOpt k_opts[] = {
    MF_OPT_FLOAT(S, lambda_latent, 0.02, 0, 1000, "latent term weight"),
    MF_OPT_FLOAT(S, lambda_rgb, 0.5, 0, 1000, "RGB term weight"),
    MF_OPT_FLOAT(S, gamma_p, 1, 0, 100, "gamma_i = 1 - (i/N)^P"),
    MF_OPT_INT(S, gamma_const, 0, 0, 1, "1: gamma_i = 1 throughout"),
    MF_OPT_INT(S, k_views, 4, 1, MF_SDS_MAX_VIEWS,
               "views that get the prior term per step (the batch's, then others drawn at random; paper: 4)"),
    /* Default 0 (auto, mf_sds_every_auto: 4 at 128 px). 4 at 128 px: on the tiny CI scene relit
     * PSNR 23.24 (every 1), 22.86 (2), 22.19 (4) vs 19.34 for the baseline; scaling a gradient
     * applied only every 4th iteration by 4 instead gave 19.75 (Adam's moments do not like
     * spikes). Longer below 128 px, where the prior's fixed cost would dominate: README
     * "MaterialFusion". */
    MF_OPT_NAMED(S, "sds_every", every, MF_OPT_INT, 0, 0, 1000000,
                 "recompute the prior term every K iterations, hold its gradient between (0: 4 at 128x128 training images "
                 "and more below, in proportion to the fewer pixels: 16 at 64x64)"),
    MF_OPT_FLOAT(S, guidance, 3, 0, 100, "classifier-free guidance scale of the DDIM targets"),
    MF_OPT_INT(S, t_min, 20, 1, 999, "smallest diffusion timestep drawn (t_min <= t_max)"),
    MF_OPT_INT(S, t_max, 980, 1, 999, "largest diffusion timestep drawn"),
    MF_OPT_INT(S, aov_samples, 4, 1, MF_OPT_PIXEL_SAMPLES_MAX, "primary rays per pixel of the material AOV render"),
    MF_OPT_NAMED(S, "sds_rgb01", rgb01, MF_OPT_INT, 1, 0, 1,
                 "1: L_rgb on [0,1] maps as the official code; 0: on the prior's [-1,1] maps (4x, the first wave)"),
    /* Default 1: with the renderer's OpenMP threads beside them, OpenBLAS's threads wait for cores
     * (test-3d/000_cup, 40 iterations, OMP_NUM_THREADS=2 on the 2 shared cores: the prior term took
     * 53.6 s with 2 OpenBLAS threads, 31.0 s with 1, the same bits; reports/perf/sds-cost.md). */
    MF_OPT_INT(S, prior_threads, 1, 0, 1024,
               "OpenBLAS threads of the prior's matrix products (0: OpenBLAS's own count; results do not depend on it)"),
    MF_OPT_NAMED(S, "sds_weight", weight, MF_OPT_ENUM, MF_SDS_WEIGHT_NONE, 0, 0,
                 "trust in the prior: none; conflict (per texel, drop the part opposing the images' gradient); "
                 "coverage (per texel, times 4 / (4 + training views that see it)); "
                 "spread (per element, less where the prior's draws disagree; needs --sds-draws >= 2); "
                 "views (per texel, less where the training views' held targets disagree; needs --sds-target mean)",
                 .choices = "none|conflict|coverage|spread|views"),
    MF_OPT_NAMED(S, "sds_draws", draws, MF_OPT_INT, 1, 1, MF_SDS_MAX_DRAWS,
                 "noise draws per prior target (same t): the target is their mean x0 (1: the paper)"),
    MF_OPT_NAMED(S, "sds_trust_rough", trust_rough, MF_OPT_FLOAT, 1, 0, 1,
                 "scale of the prior's roughness gradient (1: the paper; `mf eval-prior` on a validation split prints the measured reliability)"),
    MF_OPT_NAMED(S, "sds_trust_metal", trust_metal, MF_OPT_FLOAT, 1, 0, 1,
                 "scale of the prior's metallic gradient (as --sds-trust-rough)"),
    MF_OPT_NAMED(S, "sds_target", target, MF_OPT_ENUM, MF_SDS_TARGET_DDIM, 0, 0,
                 "the prior's targets: ddim (noise the current maps to t, guided DDIM back; the paper) or mean "
                 "(the prior's mean prediction for each view from pure noise, held for the run)",
                 .choices = "ddim|mean"),
    MF_OPT_NAMED(S, "sds_mean_samples", mean_samples, MF_OPT_INT, 4, 1, 64, "--sds-target mean: samples averaged per view"),
    MF_OPT_NAMED(S, "sds_mean_steps", mean_steps, MF_OPT_INT, 10, 1, MF_DIFF_T, "--sds-target mean: DDIM steps per sample"),
    MF_OPT_NAMED(S, "sds_mv", mv, MF_OPT_INT, 0, 0, 1,
                 "1: the prior's views attend jointly (StableMaterialMV): ddim, the K views of a step; mean, groups of 4 training views"),
};
#undef S
const MfOptTable mf_sds_opt_table = MF_OPT_TABLE("MaterialFusion (SDS+ prior term) options", k_opts);

MfSdsOpts mf_sds_opts_default(void) {
    MfSdsOpts o;
    memset(&o, 0, sizeof o);
    mf_opts_defaults(&mf_sds_opt_table, &o);
    o.seed = 7; /* tests only: mf recon sets it from the reconstruction's seed */
    return o;
}
