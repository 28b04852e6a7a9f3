#include "inverse/mf_recon_opts.h"

#include <string.h>

#define R MfReconOpts
static const MfOpt k_opts[] = {
    MF_OPT_INT(R, iters, 400, 0, 10000000, "optimisation iterations"),
    MF_OPT_INT(R, batch, 2, 1, 1024, "views per iteration"),
    MF_OPT_NAMED(R, "spp", spp_sqrt, MF_OPT_INT, 2, 1, MF_OPT_SPP_MAX, "n: n^2 env-light + n^2 BSDF samples per pixel sample",
                 .deprecated = "spp_sqrt"),
    MF_OPT_INT(R, pixel_samples, 1, 1, MF_OPT_PIXEL_SAMPLES_MAX, "primary rays per pixel"),
    MF_OPT_INT(R, tex_res, 256, 4, 8192, "albedo/ORM texture side"),
    MF_OPT_INT(R, env_w, 64, 4, 8192, "env map width"),
    MF_OPT_INT(R, env_h, 32, 2, 4096, "env map height"),
    MF_OPT_FLOAT(R, lr, 0.02, 0, 1, "texture learning rate (decays as 10^(-0.0002 it))"),
    MF_OPT_FLOAT(R, light_lr_scale, 3, 0, 100, "env learning rate multiplier"),
    MF_OPT_FLOAT(R, w_kd_smooth, 0.1, 0, 1000, "albedo smoothness weight"),
    MF_OPT_FLOAT(R, w_orm_smooth, 0.05, 0, 1000, "ORM smoothness weight"),
    MF_OPT_FLOAT(R, w_env_tv, 0, 0, 1000, "env smoothness weight: L1 of the log-radiance differences of neighbouring env texels (0: off)"),
    MF_OPT_FLOAT(R, w_shading, 0.15, 0, 1000, "white-light shading regulariser weight"),
    MF_OPT_FLOAT(R, w_spec_ratio, 0.0025, 0, 1000, "mean(spec)/mean(diffuse) weight"),
    /* 0.1 measured (README "The methods"): the baseline on val-3d +0.69 dB relit, +0.79 albedo,
     * +0.58 ORM (8/9 relit wins); 8-bit images darkened 4 stops no longer move the albedo */
    MF_OPT_FLOAT(R, loss_floor, 0.1, 0, 10,
                 "added to render and image before the image loss's log-sRGB curve, in the views' units / 2^k near their mean "
                 "(0: nvdiffrecmc's loss; it caps the weight of near-black pixels)"),
    /* Off by measurement: on test-3d (GT meshes, default budget) the normal map lowered relit
     * PSNR by 3.0 / 0.4 / 4.8 dB (000_cup, 001_vase, 007_mug): on a correct mesh it only adds
     * variance (rarely seen texels random-walk under Adam's per-texel normalisation). */
    MF_OPT_INT(R, normal_map, 0, 0, 1, "1: also optimise a tangent-space normal map (writes normal.png)"),
    MF_OPT_FLOAT(R, w_nrm_perturb, 0.25, 0, 1000, "normal-map perturbation weight (L1 from flat)"),
    MF_OPT_FLOAT(R, w_nrm_smooth, 0.025, 0, 1000, "normal-map smoothness weight"),
    MF_OPT_FLOAT(R, vertex_lr, -1, -1, 1, "> 0: the vertices move too, at this Adam rate (world units per step; welded across UV seams, normals follow, checkpointed; refuses --normal-map 1); 0: the mesh is fixed; -1: 2e-5 x the mesh's largest side on a recovered mesh (--geometry vhull|dmtet, no normal map), else 0"),
    MF_OPT_FLOAT(R, vertex_laplacian, 30000, 0, 1e9, "--vertex-lr: uniform Laplacian weight on the moving vertices, x (1 - it / iters) / vertex count"),
    MF_OPT_INT(R, normal_smooth, -1, -1, 100, "> 0: shading normals smoothed over this many 1-rings of the welded mesh (neighbours within 15 degrees; recomputed and differentiated as vertices move); 0: the mesh's normals; -1: 5 on a recovered mesh (--geometry vhull|dmtet), else 0"),
    MF_OPT_FLOAT(R, init_kd, 0.5, 0, 1, "initial albedo"),
    MF_OPT_FLOAT(R, init_rough, 0.5, 0, 1, "initial roughness"),
    MF_OPT_FLOAT(R, init_metal, 0.25, 0, 1, "initial metallic"),
    MF_OPT_FLOAT(R, init_light, 0.5, 0.01, 1000,
                 "initial env radiance, in the views' units / 2^k near their mean (mf_recon.h; the env is kept >= 0.01 of it)"),
    /* measured (docs/analyses/baseline-denoiser.md): +0.5 dB relit at 3x the CPU; off for cost */
    MF_OPT_INT(R, denoise, 0, 0, 1, "1: bilateral denoiser of the demodulated diffuse/specular light (nvdiffrecmc)"),
    MF_OPT_FLOAT(R, denoise_sigma, 2, 0.1, 8, "denoiser spatial sigma in pixels (window 2*ceil(2.5 sigma)+1 each side)"),
    MF_OPT_INT(R, denoise_decorrelate, 1, 0, 1, "1: kd's adjoint takes the denoised light of an independent render (0: the primal's)"),
    MF_OPT_FLOAT(R, div_factor, 4, 1, 1e30, "divergence: loss above this x its running minimum ..."),
    MF_OPT_INT(R, div_patience, 10, 1, 100000000, "... for this many iterations in a row: restore the best state, lr x0.1"),
    MF_OPT_INT(R, max_recoveries, 4, 0, 64, "recoveries (from divergence or non-finite values) before the run stops"),
    MF_OPT_INT(R, snapshot_every, 50, 0, 10000000, "texture snapshot period (0: none)"),
    MF_OPT_INT(R, checkpoint_every, 50, 0, 10000000, "checkpoint period (0: at the end only)"),
    MF_OPT_U64(R, seed, 1, 0, 9007199254740992.0, "random seed"),
    /* budgets from the data (mf_budget.h): off until measured to pay (reports/frontier) */
    MF_OPT_BOOL(R, early_stop, 0, "1: hold out views 0, N, 2N, ... (N = holdout_every) from the loss and stop when their PSNR stops improving"),
    MF_OPT_INT(R, holdout_every, 8, 2, 1000000, "early_stop: every Nth training view is held out"),
    MF_OPT_INT(R, es_every, 25, 1, 10000000, "early_stop: held-out PSNR evaluated every N iterations"),
    MF_OPT_INT(R, es_pixel_samples, 4, 1, MF_OPT_PIXEL_SAMPLES_MAX, "early_stop: primary rays per pixel of the held-out renders (their noise is not a change of the state)"),
    MF_OPT_INT(R, es_patience, 3, 1, 1000000, "early_stop: stop after N evaluations in a row without improvement"),
    MF_OPT_FLOAT(R, es_min_delta, 0.05, 0, 100, "early_stop: an improvement is a held-out PSNR above the best by more than X dB"),
    MF_OPT_BOOL(R, metal_auto, 0, "1: after metal_warmup iterations, fix metallic at 0 if under metal_frac of the visible texels have metallic > 0.5"),
    MF_OPT_INT(R, metal_warmup, 50, 1, 10000000, "metal_auto: warm-up iterations before the test"),
    MF_OPT_FLOAT(R, metal_frac, 0.02, 0, 1, "metal_auto: largest fraction of metallic texels that counts as no metal"),
    MF_OPT_BOOL(R, tex_auto, 0, "1: tex_res = the power of two nearest 1 pixel per texel over the training views (median over visible triangles)"),
    MF_OPT_INT(R, tex_auto_min, 32, 4, 8192, "tex_auto: smallest texture side"),
    MF_OPT_INT(R, tex_auto_max, 1024, 4, 8192, "tex_auto: largest texture side"),
    MF_OPT_BOOL(R, env_auto, 0, "1: env texels no training view sees in a mirror reflection are pulled toward their neighbours (L1 of neighbour differences)"),
    MF_OPT_INT(R, env_auto_dilate, 1, 0, 64, "env_auto: the reflected directions cover this many texels around them"),
    MF_OPT_FLOAT(R, w_env_unseen, 0.1, 0, 1000, "env_auto: weight of the unseen directions' smoothness"),
    MF_OPT_BOOL(R, env_res_auto, 0, "1: after env_res_warmup iterations, halve the env map while two texels still span the reflected lobe of the visible texels' 10th-percentile roughness"),
    MF_OPT_INT(R, env_res_warmup, 50, 1, 10000000, "env_res_auto: warm-up iterations before the choice"),
    MF_OPT_INT(R, env_res_min, 8, 4, 8192, "env_res_auto: smallest env map width"),
    MF_OPT_BOOL(R, spp_grow, 0, "1: --spp grows by 1 (up to spp_grow_max) each time the image loss's mean over a window fell by less than spp_grow_tol of the previous window's"),
    MF_OPT_INT(R, spp_grow_max, 4, 1, MF_OPT_SPP_MAX, "spp_grow: largest --spp"),
    MF_OPT_INT(R, spp_grow_window, 25, 1, 1000000, "spp_grow: window (iterations; windows end at multiples of it)"),
    MF_OPT_FLOAT(R, spp_grow_tol, 0.02, 0, 1, "spp_grow: relative fall of the windowed loss below which --spp grows"),
};
#undef R
const MfOptTable mf_recon_opt_table = MF_OPT_TABLE("Options of both methods", k_opts);

MfReconOpts mf_recon_opts_default(void) {
    MfReconOpts o;
    memset(&o, 0, sizeof o);
    mf_opts_defaults(&mf_recon_opt_table, &o);
    return o;
}

#define G MfReconGeomOpts
static const MfOpt k_geom_opts[] = {
    MF_OPT_STR(G, geometry, NULL, "where the mesh comes from: the data set's (or --mesh), the visual hull of the training views' masks "
               "unwrapped (written to RESULT_DIR/geometry/vhull.obj), or DMTet's mask term from that hull (RESULT_DIR/geometry/dmtet.obj, per-step loss in RESULT_DIR/geom_log.csv)",
               .choices = "given|vhull|dmtet", .unset = "given when DATASET_DIR has a mesh (or --mesh), else vhull"),
    MF_OPT_INT(G, hull_res, MF_HULL_DEFAULT_RES, 4, 512, "vhull: grid cubes per axis (mf hull --res)"),
    MF_OPT_FLOAT(G, hull_extent, MF_HULL_DEFAULT_EXTENT, 1e-6, 1e6, "vhull, dmtet: side of the grid cube centred at the origin (enlarged 1.5x once when the hull touches it)"),
    MF_OPT_INT(G, hull_smooth, MF_HULL_DEFAULT_SMOOTH, 0, 10000, "vhull: Taubin smoothing iterations"),
    MF_OPT_INT(G, hull_target_tris, MF_HULL_DEFAULT_TARGET_TRIS, 0, 100000000, "vhull, dmtet: decimate to at most this many triangles (0: keep all)"),
    MF_OPT_FLOAT(G, hull_min_component, MF_HULL_DEFAULT_MIN_COMPONENT, 0, 1, "vhull, dmtet: drop components with fewer than this fraction of the largest's triangles"),
    /* the hull_* decimation and component options also clean the DMTet mesh; hull_extent is its grid's side */
    /* 0 from the hull: its own grid (--hull-res), where the 64^3 grid lost what the hull resolved
     * (docs/analyses/dmtet-grid.md) */
    MF_OPT_INT(G, dmtet_res, 0, 0, 512, "dmtet: tet grid cubes per axis, 4-512 (side --hull-extent; 0: the start's, --hull-res from "
               "--dmtet-init hull, 64 from soft)"),
    /* hull: relit +0.23 dB [+0.06, +0.40], 15/18 validation scenes, against soft (docs/analyses/dmtet-init.md) */
    MF_OPT_ENUM(G, dmtet_init, MF_DMTET_INIT_HULL, MF_DMTET_INITS,
                "dmtet: the SDF's start: hull (the signed distance to --geometry vhull's hull mesh, built with the hull_* options; "
                "a vessel is then carved as the hull is) or soft (the soft visual hull's mask - 0.5 on the tet grid, the former start)"),
    /* -1 from the soft hull: 100 at 64^3, chosen on val-3d (relit +0.14 dB [+0.09, +0.20] against
     * 10, the former value; docs/analyses/hull-smoothing.md); from the hull, whose mesh is smoothed
     * already, 100 on the hull's grid (validated at the default 128^3, docs/analyses/dmtet-grid.md).
     * Scaled by the resolution squared on other grids: an iteration acts per mesh edge, and the
     * length it smooths grows as the edge x sqrt(iterations). Only those two points were validated. */
    MF_OPT_INT(G, dmtet_smooth, -1, -1, 10000, "dmtet: Taubin smoothing iterations of the extracted mesh (-1: 100 x (res / --hull-res)^2 "
               "from --dmtet-init hull, 100 x (res / 64)^2 from soft, rounded)"),
    MF_OPT_INT(G, geom_iters, 200, 0, 1000000, "dmtet: Adam steps of the mask term (and the colour term with --geom-color; 0: the hull's SDF extracted as is)"),
    MF_OPT_INT(G, geom_views, 4, 0, 100000, "dmtet: training views per step, taken in turn (0: all)"),
    /* 0.01: on val-3d's box, superquadric and torus (hull start, 64^3, 200 mask-term steps) 0.05
     * doubled the test views' normal error (4.7-7.1 deg at 0.01, 10.1-11.7 at 0.05) and lost 1.7 dB
     * relit against 0.01; README "Geometry". */
    MF_OPT_FLOAT(G, geom_lr, 0.01, 1e-6, 100, "dmtet: SDF learning rate, in grid cells per step"),
    MF_OPT_FLOAT(G, geom_sdf_reg, 0, 0, 1000, "dmtet: weight of the sign-change regulariser (nvdiffrec's sdf_reg_loss)"),
    MF_OPT_FLOAT(G, geom_color, 0, 0, 1000, "dmtet: weight of the colour term (logl1 of an antialiased render with volume-texture materials and "
                 "an env, optimised with the SDF: shading moves the surface where masks cannot, e.g. a cup's inside; 0: the mask term only)"),
    MF_OPT_INT(G, geom_seed, 1, 0, 2147483647, "dmtet: the colour term's Monte Carlo seed"),
    MF_OPT_ENUM(G, vessel, MF_VESSEL_AUTO, MF_VESSEL_MODES,
                "vhull, dmtet: an open vessel (a cup's inside, which silhouettes cannot carve; mf_vessel.h): auto (when the hull has a large "
                "flat top facing the cameras, fit the closed and the carved mesh, and one with 3-cell walls where --vessel-wall gives 1.5 to 3 cells, "
                "for --vessel-trial-iters iterations with every 8th view held out, and keep the best carved one only when its held-out PSNR is "
                "higher by more than 0.1 dB), open (carve whenever there is such a top), closed (never carve)"),
    MF_OPT_FLOAT(G, vessel_wall, MF_VESSEL_DEFAULT_WALL, 1e-4, 0.5,
                 "vhull, dmtet: the carved vessel's wall thickness, x the hull's largest side (at least 1.5 grid cells)"),
    MF_OPT_INT(G, vessel_trial_iters, -1, -1, 1000000, "--vessel auto: iterations of each trial fit (-1: a quarter of --iters, at least 1)"),
};
#undef G
const MfOptTable mf_recon_geom_opt_table = MF_OPT_TABLE("Geometry options", k_geom_opts);

MfReconGeomOpts mf_recon_geom_opts_default(void) {
    MfReconGeomOpts o;
    memset(&o, 0, sizeof o);
    mf_opts_defaults(&mf_recon_geom_opt_table, &o);
    return o;
}
