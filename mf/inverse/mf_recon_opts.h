/* mf_recon_opts: the reconstruction options by name, for config files and the command line.
 *
 * One table lists every field of MfReconOpts with its name (snake_case in JSON config files,
 * --kebab-case on the command line) and a one-line description, so the config file, the
 * command-line flags and `mf recon --help` cannot drift apart. */
#ifndef MF_RECON_OPTS_H
#define MF_RECON_OPTS_H

#include <cJSON.h>

#include "inverse/mf_recon.h"

/* Applies the keys of a JSON object (a config file's root); unknown keys and wrong types are
 * errors naming the file and the key. */
int mf_recon_opts_apply_json(MfReconOpts *o, const cJSON *root, const char *file);
/* Loads and applies a JSON config file. */
int mf_recon_opts_load(MfReconOpts *o, const char *path);
/* If argv[*i] is --<name> for a field, parses the value, advances *i and returns 1; 0 when not
 * an option of the table; -1 (error set) on a bad value. */
int mf_recon_opts_parse_arg(MfReconOpts *o, int argc, char **argv, int *i);
/* Appends "  --name VALUE   description (default)" lines to buf (for usage text). */
void mf_recon_opts_usage(char *buf, size_t cap, const MfReconOpts *defaults);
/* Writes the options as a JSON object into obj (for run.json). */
void mf_recon_opts_to_json(const MfReconOpts *o, cJSON *obj);

#endif
