#include "baselines/bl_nvdiffrecmc.h"

MfReconOpts bl_nvdiffrecmc_opts(void) { return mf_recon_opts_default(); }
