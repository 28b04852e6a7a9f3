/* mf_recon_opts: the reconstruction options (MfReconOpts, mf_recon.h) as a declarative table
 * (mf/io/mf_opts.h): each field's name (snake_case in JSON config files, --kebab-case on the
 * command line), default, allowed range and a one-line description. The table is the only place
 * the defaults are written: mf_recon_opts_default() fills a struct from it, and `mf recon`'s
 * flags, --config keys, --help text, range checks and run.json all come from it. */
#ifndef MF_RECON_OPTS_H
#define MF_RECON_OPTS_H

#include "inverse/mf_recon.h"
#include "io/mf_opts.h"

extern const MfOptTable mf_recon_opt_table;

#endif
