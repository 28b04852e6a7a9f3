/* Fuzz harness: the command-line option parser (mf_opts_parse, mf_opts_check, mf_opts_to_json)
 * over the reconstruction, SDS and evaluation tables. Input: one argument per line; a line "@@"
 * ends the arguments and the rest is a config file's text; the argument "@cfg" stands for that
 * file's path (so "--config @cfg" reads it). */
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "eval/ev_eval_opts.h"
#include "fusion/mf_sds_opts.h"
#include "inverse/mf_recon_opts.h"
#include "mf_fuzz.h"

#define MAX_ARGS 64

MF_FUZZ(opts) {
    if (!mf_fuzz_dir()[0]) return 0;
    char *text = malloc(size + 1);
    if (!text) return 0;
    memcpy(text, data, size);
    text[size] = 0;
    char *cfg = strstr(text, "\n@@\n");
    const char *cfg_path = mf_fuzz_write("cfg.json", cfg ? cfg + 4 : "", cfg ? strlen(cfg + 4) : 0);
    if (cfg) *cfg = 0;
    char *argv[MAX_ARGS + 1];
    int argc = 0;
    argv[argc++] = "mf";
    for (char *s = text; s && argc < MAX_ARGS;) {
        char *nl = strchr(s, '\n');
        if (nl) *nl = 0;
        argv[argc++] = (!strcmp(s, "@cfg") && cfg_path) ? (char *)cfg_path : s;
        s = nl ? nl + 1 : NULL;
    }
    argv[argc] = NULL;
    MfReconOpts ro;
    MfSdsOpts so;
    EvEvalOpts eo;
    mf_opts_defaults(&mf_recon_opt_table, &ro);
    mf_opts_defaults(&mf_sds_opt_table, &so);
    mf_opts_defaults(&ev_eval_opt_table, &eo);
    MfOptBind b[3] = {{&mf_recon_opt_table, &ro}, {&mf_sds_opt_table, &so}, {&ev_eval_opt_table, &eo}};
    MfOptParse p = {0};
    if (mf_opts_parse(b, 3, argc, argv, MF_OPTS_MAX_POS, &p) == 0) {
        if (mf_opts_check(&mf_recon_opt_table, &ro) == 0 && mf_opts_check(&mf_sds_opt_table, &so) == 0 &&
            mf_opts_check(&ev_eval_opt_table, &eo) == 0) {
            cJSON *j = cJSON_CreateObject();
            mf_opts_to_json(&mf_recon_opt_table, &ro, j);
            mf_opts_to_json(&mf_sds_opt_table, &so, j);
            mf_opts_to_json(&ev_eval_opt_table, &eo, j);
            cJSON_Delete(j);
        }
    }
    mf_opts_parse_free(&p); /* also after a failure (the config may have been read) */
    free(text);
    return 0;
}
