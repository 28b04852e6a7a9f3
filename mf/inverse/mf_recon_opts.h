/* mf_recon_opts: the reconstruction options (MfReconOpts, mf_recon.h) as a declarative table
 * (mf/io/mf_opts.h): each field's name (snake_case in JSON config files, --kebab-case on the
 * command line), default, allowed range and a one-line description. The table is the only place
 * the defaults are written: mf_recon_opts_default() fills a struct from it, and `mf recon`'s
 * flags, --config keys, --help text, range checks and run.json all come from it.
 *
 * The defaults are the nvdiffrecmc-style baseline's (`--method nvdiffrecmc`: this loop with no
 * prior term; MaterialFusion adds its SDS options, mf/fusion/mf_sds_opts.h, to the same ones):
 * nvdiffrecmc's second pass (REFERENCE.md) scaled for a 2-core machine, each deliberate
 * difference stated:
 *   textures 256^2 (nvdiffrecmc 1024^2), env 64x32 (256x128): the test images are 128 px;
 *   iterations 400 (5000), batch 2 (8): the published budget takes hours per scene here;
 *   samples: 2^2 light + 2^2 BSDF per pixel (8^2 + 8^2), 1 primary ray per pixel;
 *   learning rate 0.02 (0.005) to reach a comparable point in fewer iterations; light 3x;
 *   the bilateral denoiser of the demodulated light is nvdiffrecmc's (sigma 2, 23x23 window,
 *   mf_denoise.h) but OFF by default (--denoise 1 turns it on): measured in
 *   docs/analyses/baseline-denoiser.md, on 3 test-3d scenes it raises mean relit / albedo / ORM PSNR by
 *   about 0.5 / 0.9 / 1.3 dB at about 3x the CPU time, while --spp 3 without it gains
 *   0.5 / 1.2 / 0.9 dB at 1.5x; the benchmarks of reports/bench were run without it, so the
 *   default stays the configuration they measured. Off, the image is the raw 2^2+2^2-sample
 *   estimate with a decorrelated adjoint; on, kd's adjoint multiplies the denoised light of an
 *   independent render, not the primal's (denoise_decorrelate 1; 0 is nvdiffrecmc's way);
 *   smoothness regularisers act on texel neighbours rather than jittered surface points;
 *   logl1 with a floor of 0.1 (0: nvdiffrecmc's loss) added to render and image in the loop's
 *   exposure units, so near-black pixels stop outweighing the rest (mf_loss.h; README "The methods").
 * baselines/nvdiffrecmc.json holds the same values as a config file (a test checks they agree);
 * BENCH_FULL runs use baselines/nvdiffrecmc_full.json (the published budget). */
#ifndef MF_RECON_OPTS_H
#define MF_RECON_OPTS_H

#include "inverse/mf_recon.h"
#include "inverse/mf_recon_geom.h"
#include "io/mf_opts.h"

extern const MfOptTable mf_recon_opt_table;

/* Where the mesh comes from (mf_recon_geom.h): --geometry given|vhull|dmtet and the hull's
 * settings, whose defaults are `mf hull`'s (MF_HULL_DEFAULT_*). A table of its own: the
 * geometry is made before the loop, and MfReconOpts stays the loop's (its checkpoint and
 * baselines/nvdiffrecmc.json hold the loop's options). */
extern const MfOptTable mf_recon_geom_opt_table;

#endif
