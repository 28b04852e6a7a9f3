/* Shared helpers of the mesh-less `mf recon` tests (test_cli_recon_geom.c, test_cli_recon_geom_ci.c;
 * header-only).
 *
 * geom_result: run.json's options.geometry_result.<key> as a number (NAN when absent), and its
 *              "source" into src (may be NULL).
 * vessel_chosen: run.json's options.geometry_result.vessel.chosen ("closed" | "open" | "open-thick") into out
 *              ("" when the run had no opening to test).
 * vessel_number: run.json's options.geometry_result.vessel.<key> as a number (NAN when absent or
 *              null: a trial not run).
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

/* run.json's options.geometry_result.vessel (NULL when absent); *root to be deleted by the caller */
static inline const cJSON *run_vessel(const char *run_dir, cJSON **root) {
    char p[MF_PATH_MAX + 16];
    snprintf(p, sizeof p, "%s/run.json", run_dir);
    *root = NULL;
    if (mf_json_load(p, root)) return NULL;
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(*root, "options"), "geometry_result");
    return cJSON_GetObjectItemCaseSensitive(g, "vessel");
}

static inline void vessel_chosen(const char *run_dir, char *out, size_t cap) {
    cJSON *j;
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(run_vessel(run_dir, &j), "chosen");
    snprintf(out, cap, "%s", cJSON_IsString(c) ? c->valuestring : "");
    cJSON_Delete(j);
}

static inline double vessel_number(const char *run_dir, const char *key) {
    cJSON *j;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(run_vessel(run_dir, &j), key);
    double r = cJSON_IsNumber(v) ? v->valuedouble : NAN;
    cJSON_Delete(j);
    return r;
}

static inline int gen_nerf(const char *mf, const char *gen_args, const char *dir) {
    return mf_test_sh("%s %s --layout nerf-synthetic -o %s 2>/dev/null", mf, gen_args, dir);
}

#endif
