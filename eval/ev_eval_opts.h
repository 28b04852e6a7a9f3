/* ev_eval_opts: the evaluation protocol's options (EvEvalOpts, ev_eval.h) as a declarative table
 * (mf/io/mf_opts.h): relighting render quality, scale alignment and view limit, each with its
 * default, range and doc, written once. `mf eval` takes its flags, --config keys and help from it;
 * ev_eval_opts_default() fills a struct from it. */
#ifndef EV_EVAL_OPTS_H
#define EV_EVAL_OPTS_H

#include "eval/ev_eval.h"
#include "io/mf_opts.h"

extern const MfOptTable ev_eval_opt_table;

#endif
