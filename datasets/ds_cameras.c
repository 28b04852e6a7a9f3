#include "datasets/ds_cameras.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "io/mf_json.h"

DsCamSampling ds_cam_sampling_default(void) {
    DsCamSampling s = {DS_CAMERA_ANGLE_X, 0.0f, 360.0f, -15.0f, 90.0f, 1.5f, 2.0f};
    return s;
}

int ds_sample_cameras(const DsCamSampling *s, int n, uint64_t seed, uint64_t stream, MfMat4 *c2w) {
    if (n < 1) return mf_fail(MF_EARG, "camera count %d must be >= 1", n);
    if (!(s->el_min >= -90.0f && s->el_max <= 90.0f && s->el_min <= s->el_max) || !(s->r_min > 0.0f && s->r_min <= s->r_max) ||
        !(s->az_min <= s->az_max))
        return mf_fail(MF_EARG, "camera sampling ranges are invalid (elevation [%g, %g], radius [%g, %g])", s->el_min, s->el_max,
                       s->r_min, s->r_max);
    MfRng rng;
    mf_rng_seed(&rng, seed, 0xCA3E0000u + stream);
    const float deg = MF_PI / 180.0f;
    float z0 = sinf(s->el_min * deg), z1 = sinf(s->el_max * deg);
    for (int i = 0; i < n; ++i) {
        float az = (s->az_min + (s->az_max - s->az_min) * ((float)i + mf_rng_float(&rng)) / (float)n) * deg;
        float sz = z0 + (z1 - z0) * mf_rng_float(&rng);
        float el = asinf(mf_clampf(sz, -1.0f, 1.0f));
        float r = s->r_min + (s->r_max - s->r_min) * mf_rng_float(&rng);
        MfVec3 eye = mf_v3(r * cosf(el) * cosf(az), r * cosf(el) * sinf(az), r * sinf(el));
        c2w[i] = mf_mat4_look_at(eye, mf_v3(0, 0, 0), mf_v3(0, 0, 1));
    }
    return MF_OK;
}

cJSON *ds_transform_matrix_json(const MfMat4 *m) {
    cJSON *rows = cJSON_CreateArray();
    for (int r = 0; rows && r < 4; ++r) {
        cJSON *row = cJSON_CreateArray();
        for (int c = 0; row && c < 4; ++c) {
            char num[32];
            snprintf(num, sizeof num, "%.9g", (double)m->m[r * 4 + c]);
            cJSON_AddItemToArray(row, cJSON_CreateRaw(num));
        }
        cJSON_AddItemToArray(rows, row);
    }
    return rows;
}

int ds_write_transforms(const char *dir, const char *split, double camera_angle_x, const MfMat4 *c2w, int n) {
    char path[MF_PATH_MAX], name[96];
    snprintf(name, sizeof name, "transforms_%s.json", split);
    int rc = mf_path_join(path, sizeof path, dir, name);
    if (rc) return rc;
    if ((rc = mf_mkdirs(dir))) return rc;
    cJSON *root = cJSON_CreateObject(), *frames = cJSON_CreateArray();
    if (!root || !frames) { cJSON_Delete(root); cJSON_Delete(frames); return mf_fail(MF_ENOMEM, "out of memory"); }
    cJSON_AddItemToObject(root, "camera_angle_x", cJSON_CreateNumber(camera_angle_x));
    cJSON_AddItemToObject(root, "frames", frames);
    for (int i = 0; i < n; ++i) {
        cJSON *fr = cJSON_CreateObject();
        char fp[128];
        snprintf(fp, sizeof fp, "./%s/r_%03d", split, i);
        cJSON_AddItemToObject(fr, "file_path", cJSON_CreateString(fp));
        cJSON_AddItemToObject(fr, "transform_matrix", ds_transform_matrix_json(&c2w[i]));
        cJSON_AddItemToArray(frames, fr);
    }
    rc = mf_json_save(path, root);
    cJSON_Delete(root);
    return rc;
}
