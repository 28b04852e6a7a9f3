/* Shared helpers of the mesh-less `mf recon` tests (test_cli_recon_geom.c, test_cli_recon_geom_ci.c;
 * header-only).
 *
 * geom_result: run.json's options.geometry_result.<key> as a number (NAN when absent), and its
 *              "source" into src (may be NULL).
 * vessel_chosen: run.json's options.geometry_result.vessel.chosen ("closed" | "open" | "open-thick") into out
 *              ("" when the run had no opening to test).
 * gen_nerf:    `mf gen GEN_ARGS --layout nerf-synthetic -o DIR`: the split's scenes as NeRF-Synthetic
 *              has them (transforms and train/, test/ images; no mesh.obj, no ground truth), the
 *              images the bytes of the full split made with GEN_ARGS; 0 when it ran. */
#ifndef MF_TEST_CLI_GEOM_H
#define MF_TEST_CLI_GEOM_H

#include <math.h>
#include <stdio.h>

#include "core/mf_fs.h"
#include "io/mf_json.h"
#include "mf_test.h"

static inline double geom_result(const char *run_dir, const char *key, char *src, size_t cap) {
    char p[MF_PATH_MAX + 16];
    snprintf(p, sizeof p, "%s/run.json", run_dir);
    cJSON *j = NULL;
    if (mf_json_load(p, &j)) return NAN;
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "options"), "geometry_result");
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(g, "source"), *v = cJSON_GetObjectItemCaseSensitive(g, key);
    if (src) snprintf(src, cap, "%s", cJSON_IsString(s) ? s->valuestring : "");
    double r = cJSON_IsNumber(v) ? v->valuedouble : NAN;
    cJSON_Delete(j);
    return r;
}

static inline void vessel_chosen(const char *run_dir, char *out, size_t cap) {
    char p[MF_PATH_MAX + 16];
    snprintf(p, sizeof p, "%s/run.json", run_dir);
    out[0] = '\0';
    cJSON *j = NULL;
    if (mf_json_load(p, &j)) return;
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "options"), "geometry_result");
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(g, "vessel"), "chosen");
    if (cJSON_IsString(c)) snprintf(out, cap, "%s", c->valuestring);
    cJSON_Delete(j);
}

static inline int gen_nerf(const char *mf, const char *gen_args, const char *dir) {
    return mf_test_sh("%s %s --layout nerf-synthetic -o %s 2>/dev/null", mf, gen_args, dir);
}

#endif
