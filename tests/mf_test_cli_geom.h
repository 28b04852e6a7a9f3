/* Shared helpers of the mesh-less `mf recon` tests (test_cli_recon_geom.c, test_cli_recon_geom_ci.c;
 * header-only).
 *
 * geom_result: run.json's options.geometry_result.<key> as a number (NAN when absent), and its
 *              "source" into src (may be NULL).
 * bare_copy:   the NeRF-Synthetic layout of a generated scene's views (transforms and train/,
 *              test/ images) in bare, without mesh.obj or any ground truth; 0 on success. */
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

static inline int bare_copy(const char *scene, const char *bare) {
    return mf_test_sh("mkdir -p %s && cp -r %s/transforms_train.json %s/transforms_test.json %s/train %s/test %s/", bare, scene,
                      scene, scene, scene, bare);
}

#endif
