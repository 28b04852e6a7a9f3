/* mf_transforms: see mf_transforms.h. */
#include "scene/mf_transforms.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_log.h"

static const char *const k_intr_keys[6] = {"fl_x", "fl_y", "cx", "cy", "w", "h"};
static const char *const k_dist_keys[] = {"k1", "k2", "k3", "k4", "p1", "p2"};

static void base_name(const char *p, char *out, size_t cap) {
    const char *b = strrchr(p, '/');
    b = b ? b + 1 : p;
    snprintf(out, cap, "%s", b);
    char *dot = strrchr(out, '.');
    if (dot && dot != out) *dot = 0;
    for (char *q = out; *q; ++q)
        if (*q == '\\' || *q == ':' || (unsigned char)*q < 0x20) *q = '_';
}

/* Reads the intrinsics of obj over fl (kept where obj lacks a key) and refuses lens distortion
 * and camera models other than a pinhole, naming the file and the key. */
static int read_intrinsics(const char *file, const char *where, const cJSON *obj, double fl[6]) {
    char w[160];
    snprintf(w, sizeof w, "%s%s", where, where[0] ? "." : "");
    for (int k = 0; k < 6; ++k) {
        int rc = mf_json_number_opt(file, where, obj, k_intr_keys[k], fl[k], &fl[k]);
        if (rc) return rc;
        double lo = k == 2 || k == 3 ? -1e7 : 0.0, hi = k >= 4 ? 65536.0 : 1e7;
        if (!isnan(fl[k]) && !(fl[k] > lo && fl[k] <= hi))
            return mf_fail(MF_EFORMAT, "%s: %s%s = %g: expected a number in (%g, %g]", file, w, k_intr_keys[k], fl[k], lo, hi);
    }
    for (size_t k = 0; k < sizeof k_dist_keys / sizeof k_dist_keys[0]; ++k) {
        double d;
        int rc = mf_json_number_opt(file, where, obj, k_dist_keys[k], 0.0, &d);
        if (rc) return rc;
        if (d != 0.0)
            return mf_fail(MF_EFORMAT, "%s: %s%s = %g: lens distortion is not supported; undistort the images first "
                           "(e.g. COLMAP's image_undistorter) and set k1..k4, p1, p2 to 0", file, w, k_dist_keys[k], d);
    }
    const char *model = NULL;
    int rc = mf_json_string_opt(file, where, obj, "camera_model", NULL, &model);
    if (rc) return rc;
    if (model && strcmp(model, "OPENCV") && strcmp(model, "PINHOLE") && strcmp(model, "SIMPLE_PINHOLE"))
        return mf_fail(MF_EFORMAT, "%s: %scamera_model '%s' is not supported (pinhole cameras only: PINHOLE, OPENCV "
                       "with zero distortion)", file, w, model);
    return MF_OK;
}

/* A copy of s (NULL stays NULL) into *out. */
static int dup_opt(const char *file, const char *s, char **out) {
    if (s && !(*out = strdup(s))) return mf_fail(MF_ENOMEM, "%s: out of memory", file);
    return MF_OK;
}

/* Frame f at JSON path w; fr holds the root's defaults. */
static int parse_frame(const char *file, const char *w, const cJSON *f, int cap, MfTransformFrame *fr) {
    const char *fp = NULL, *mp = NULL, *sn = NULL;
    int rc;
    if (!cJSON_IsObject(f)) return mf_fail(MF_EFORMAT, "%s: %s: expected an object", file, w);
    if ((rc = mf_json_numbers(file, w, f, "transform_matrix", 4, 4, fr->c2w))) return rc;
    if ((rc = cap ? mf_json_string(file, w, f, "file_path", &fp) : mf_json_string_opt(file, w, f, "file_path", NULL, &fp)))
        return rc;
    if (cap && ((rc = mf_json_number_opt(file, w, f, "camera_angle_x", fr->camera_angle_x, &fr->camera_angle_x)) ||
                (rc = read_intrinsics(file, w, f, fr->intr)) || (rc = mf_json_string_opt(file, w, f, "mask_path", NULL, &mp)) ||
                (rc = mf_json_string_opt(file, w, f, "scene_name", NULL, &sn))))
        return rc;
    if (isnan(fr->camera_angle_x) && isnan(fr->intr[0]))
        return mf_fail(MF_EFORMAT, "%s: %s: camera_angle_x: missing (and no fl_x)", file, w);
    if (fp && fp[0]) base_name(fp, fr->name, sizeof fr->name);
    if ((rc = dup_opt(file, fp, &fr->file_path)) || (rc = dup_opt(file, mp, &fr->mask_path))) return rc;
    return dup_opt(file, sn, &fr->scene_name);
}

int mf_transforms_parse(const char *file, const char *prefix, const cJSON *obj, int flags, MfTransforms *t) {
    memset(t, 0, sizeof *t);
    const cJSON *frames;
    int n = 0, cap = flags & MF_TF_CAPTURE;
    char w[128];
    size_t pl = strlen(prefix);
    snprintf(w, sizeof w, "%.*s", (int)(pl && prefix[pl - 1] == '.' ? pl - 1 : pl), prefix); /* "cameras." -> "cameras" */
    t->camera_angle_x = NAN;
    for (int k = 0; k < 6; ++k) t->intr[k] = NAN;
    int rc = cap ? mf_json_number_opt(file, w, obj, "camera_angle_x", NAN, &t->camera_angle_x)
                 : mf_json_number(file, w, obj, "camera_angle_x", &t->camera_angle_x);
    if (!rc && cap) rc = read_intrinsics(file, w, obj, t->intr);
    if (!rc) rc = mf_json_array(file, w, obj, "frames", &frames, &n);
    if (rc) return rc;
    if (cap && !(flags & MF_TF_QUIET) && cJSON_GetObjectItemCaseSensitive(obj, "aabb_scale"))
        mf_log_info("%s: aabb_scale ignored (mf works on a given mesh; no bounding volume is used)", file);
    t->frames = calloc(n > 0 ? (size_t)n : 1, sizeof *t->frames);
    if (!t->frames) return mf_fail(MF_ENOMEM, "%s: out of memory", file);
    t->n = n;
    int k = 0;
    for (const cJSON *f = frames->child; f && !rc; f = f->next, ++k) {
        MfTransformFrame *fr = &t->frames[k];
        fr->camera_angle_x = t->camera_angle_x;
        memcpy(fr->intr, t->intr, sizeof fr->intr);
        snprintf(w, sizeof w, "%sframes[%d]", prefix, k);
        rc = parse_frame(file, w, f, cap, fr);
    }
    if (rc) mf_transforms_free(t);
    return rc;
}

int mf_transforms_load(const char *path, int flags, MfTransforms *t) {
    cJSON *j = NULL;
    memset(t, 0, sizeof *t);
    int rc = mf_json_load(path, &j);
    if (!rc) rc = mf_transforms_parse(path, "", j, flags, t);
    cJSON_Delete(j);
    return rc;
}

void mf_transforms_free(MfTransforms *t) {
    for (int k = 0; k < t->n && t->frames; ++k) {
        free(t->frames[k].file_path);
        free(t->frames[k].mask_path);
        free(t->frames[k].scene_name);
    }
    free(t->frames);
    memset(t, 0, sizeof *t);
}
