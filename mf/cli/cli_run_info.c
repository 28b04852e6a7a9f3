#include "cli/cli_run_info.h"

#include <omp.h>
#include <stdio.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "inverse/mf_recon.h"
#include "io/mf_json.h"
#include "mf_build_info.h"

int mf_write_run_json(const char *dir, int argc, char **argv, uint64_t seed, double wall_s, cJSON *extra) {
    cJSON *root = cJSON_CreateObject();
    if (!root) {
        cJSON_Delete(extra);
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    cJSON *av = cJSON_AddArrayToObject(root, "argv");
    cJSON_AddItemToArray(av, cJSON_CreateString("mf"));
    for (int i = 0; i < argc; ++i) cJSON_AddItemToArray(av, cJSON_CreateString(argv[i]));
    cJSON_AddNumberToObject(root, "seed", (double)seed);
    cJSON_AddNumberToObject(root, "threads", omp_get_max_threads());
    cJSON_AddStringToObject(root, "git_revision", MF_GIT_REV);
    cJSON_AddNumberToObject(root, "wall_seconds", wall_s);
    cJSON_AddNumberToObject(root, "peak_rss_bytes", (double)mf_peak_rss_bytes());
    if (extra) cJSON_AddItemToObject(root, "options", extra);
    char p[MF_PATH_MAX];
    int rc = mf_path_join(p, sizeof p, dir, "run.json");
    if (!rc) rc = mf_json_save(p, root);
    cJSON_Delete(root);
    return rc;
}
