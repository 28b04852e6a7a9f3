/* mf_transforms: see mf_transforms.h. */
#include "scene/mf_transforms.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

static void base_name(const char *p, char *out, size_t cap) {
    const char *b = strrchr(p, '/');
    b = b ? b + 1 : p;
    snprintf(out, cap, "%s", b);
    char *dot = strrchr(out, '.');
    if (dot && dot != out) *dot = 0;
    for (char *q = out; *q; ++q)
        if (*q == '\\' || *q == ':' || (unsigned char)*q < 0x20) *q = '_';
}

int mf_transforms_parse(const char *file, const char *prefix, const cJSON *obj, MfTransforms *t) {
    memset(t, 0, sizeof *t);
    const cJSON *frames;
    int n = 0;
    char w[128];
    size_t pl = strlen(prefix);
    snprintf(w, sizeof w, "%.*s", (int)(pl && prefix[pl - 1] == '.' ? pl - 1 : pl), prefix); /* "cameras." -> "cameras" */
    int rc = mf_json_number(file, w, obj, "camera_angle_x", &t->camera_angle_x);
    if (!rc) rc = mf_json_array(file, w, obj, "frames", &frames, &n);
    if (rc) return rc;
    t->frames = calloc(n > 0 ? (size_t)n : 1, sizeof *t->frames);
    if (!t->frames) return mf_fail(MF_ENOMEM, "%s: out of memory", file);
    int k = 0;
    for (const cJSON *f = frames->child; f && !rc; f = f->next, ++k) {
        MfTransformFrame *fr = &t->frames[k];
        snprintf(w, sizeof w, "%sframes[%d]", prefix, k);
        const char *fp;
        if (!cJSON_IsObject(f)) rc = mf_fail(MF_EFORMAT, "%s: %s: expected an object", file, w);
        else if (!(rc = mf_json_numbers(file, w, f, "transform_matrix", 4, 4, fr->c2w)) &&
                 !(rc = mf_json_string_opt(file, w, f, "file_path", NULL, &fp)) && fp && fp[0])
            base_name(fp, fr->name, sizeof fr->name);
    }
    t->n = n;
    if (rc) mf_transforms_free(t);
    return rc;
}

int mf_transforms_load(const char *path, MfTransforms *t) {
    cJSON *j = NULL;
    memset(t, 0, sizeof *t);
    int rc = mf_json_load(path, &j);
    if (!rc) rc = mf_transforms_parse(path, "", j, t);
    cJSON_Delete(j);
    return rc;
}

void mf_transforms_free(MfTransforms *t) {
    free(t->frames);
    memset(t, 0, sizeof *t);
}
