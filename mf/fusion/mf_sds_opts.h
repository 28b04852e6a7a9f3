/* mf_sds_opts: MaterialFusion's SDS+ options (MfSdsOpts, mf_sds.h) as a declarative table
 * (mf/io/mf_opts.h): name, default, range and doc of each field, written once. `mf recon
 * --method materialfusion` takes its flags, --config keys, help text and run.json entries from
 * it; mf_sds_opts_default() fills a struct from it. The seed is not an option: `mf recon` derives
 * it from the reconstruction's seed. */
#ifndef MF_SDS_OPTS_H
#define MF_SDS_OPTS_H

#include "fusion/mf_sds.h"
#include "io/mf_opts.h"

extern const MfOptTable mf_sds_opt_table;

#endif
