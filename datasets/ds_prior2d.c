/* ds_prior2d: see ds_prior2d.h. */
#include "datasets/ds_prior2d.h"

#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

const char *const ds_prior2d_kinds[DS_P2_NKIND] = {"albedo", "orm", "rgb"};

int ds_prior2d_path(const char *dir, const char *kind, int i, char *path, size_t cap) {
    char rel[64];
    snprintf(rel, sizeof rel, "%s/%06d.png", kind, i);
    return mf_path_join(path, cap, dir, rel);
}

int ds_prior2d_read(const char *dir, const char *kind, int i, MfEncoding enc, MfImage *out) {
    char path[MF_PATH_MAX];
    ds_prior2d_path(dir, kind, i, path, sizeof path);
    int rc = mf_image_read(path, enc, out);
    if (!rc && out->c != 4) {
        mf_image_free(out);
        rc = mf_fail(MF_EFORMAT, "%s: expected an RGBA image", path);
    }
    return rc;
}

static int sample_complete(const char *dir, int i) {
    for (int k = 0; k < DS_P2_NKIND; ++k) {
        char path[MF_PATH_MAX];
        ds_prior2d_path(dir, ds_prior2d_kinds[k], i, path, sizeof path);
        if (!mf_file_exists(path)) return 0;
    }
    return 1;
}

int ds_prior2d_complete(const char *dir, int max) {
    int n = 0;
    while ((max < 0 || n < max) && sample_complete(dir, n)) ++n;
    return n;
}

static int number(const cJSON *m, const char *key) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, key);
    return cJSON_IsNumber(v) ? v->valueint : DS_P2_ABSENT;
}

int ds_prior2d_manifest(const char *dir, int required, DsPrior2dManifest *m) {
    memset(m, 0, sizeof *m);
    m->count = m->resolution = m->views_per_object = DS_P2_ABSENT;
    mf_path_join(m->path, sizeof m->path, dir, "manifest.json");
    m->present = mf_file_exists(m->path);
    if (!m->present && !required) return MF_OK;
    char *txt = NULL;
    size_t len;
    int rc = mf_read_file(m->path, &txt, &len);
    if (rc) return rc;
    cJSON *j = cJSON_Parse(txt);
    free(txt);
    m->count = number(j, "count"), m->resolution = number(j, "resolution"), m->views_per_object = number(j, "views_per_object");
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(j, "seed");
    m->seed = cJSON_IsNumber(s) ? (uint64_t)s->valuedouble : 0;
    cJSON_Delete(j);
    return MF_OK;
}
