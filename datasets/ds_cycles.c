#include "datasets/ds_cycles.h"

#include <cJSON.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_proc.h"
#include "core/mf_rng.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"


/* Blender point-light power per unit of our point power (ds_cycles.h: assumed, not measured). */
#define DS_CYCLES_POINT_SCALE 1.0f

static const char *blender_bin(void) {
    const char *e = getenv("MF_BLENDER");
    return e && *e ? e : "/usr/bin/blender";
}

int ds_cycles_available(void) { return access(blender_bin(), X_OK) == 0; }

/* The script: $MF_CYCLES_SCRIPT, ./datasets/ds_cycles.py, <exe dir>/../datasets/ds_cycles.py. */
static int script_path(char *out, size_t cap) {
    const char *e = getenv("MF_CYCLES_SCRIPT");
    if (e && *e) {
        snprintf(out, cap, "%s", e);
        return mf_file_exists(out) ? MF_OK : mf_fail(MF_EIO, "%s ($MF_CYCLES_SCRIPT): no such file", out);
    }
    snprintf(out, cap, "datasets/ds_cycles.py");
    if (mf_file_exists(out)) return MF_OK;
    char exe[MF_PATH_MAX];
    ssize_t l = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (l > 0) {
        exe[l] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = 0;
            if (snprintf(out, cap, "%s/../datasets/ds_cycles.py", exe) < (int)cap && mf_file_exists(out)) return MF_OK;
        }
    }
    return mf_fail(MF_EIO, "datasets/ds_cycles.py not found (run from the repository root or set $MF_CYCLES_SCRIPT)");
}

static int write_exr(const DsCyclesJob *j, const char *name, const MfImage *img) {
    char p[MF_PATH_MAX];
    int rc = mf_path_join(p, sizeof p, j->dir, name);
    return rc ? rc : mf_image_write(p, img, MF_ENC_LINEAR, 32);
}

int ds_cycles_begin(DsCyclesJob *j, const char *dir, const MfMesh *mesh, const MfImage *kd, const MfImage *orm, int res) {
    memset(j, 0, sizeof *j);
    if (!mesh->uv || !mesh->nrm) return mf_fail(MF_EARG, "%s: the Cycles export needs UVs and normals", dir);
    snprintf(j->dir, sizeof j->dir, "%s", dir);
    j->res = res, j->samples = DS_CYCLES_SAMPLES, j->bounces = DS_CYCLES_BOUNCES;
    if (!(j->views = cJSON_CreateArray())) return mf_fail(MF_ENOMEM, "out of memory");
    char p[MF_PATH_MAX];
    int rc = mf_mkdirs(dir);
    if (!rc && !(rc = mf_path_join(p, sizeof p, dir, "mesh.obj"))) rc = mf_obj_write(p, mesh, NULL);
    if (!rc) rc = write_exr(j, "kd.exr", kd);
    if (!rc) rc = write_exr(j, "orm.exr", orm);
    return rc;
}

static cJSON *vec3(MfVec3 v) {
    float a[3] = {v.x, v.y, v.z};
    return cJSON_CreateFloatArray(a, 3);
}

int ds_cycles_add_view(DsCyclesJob *j, const char *name, const double c2w[16], double angle_x, const MfImage *env,
                       const MfLight *lights, int n) {
    cJSON *v = cJSON_CreateObject(), *ls = cJSON_CreateArray();
    if (!v || !ls) {
        cJSON_Delete(v), cJSON_Delete(ls);
        return mf_fail(MF_ENOMEM, "out of memory");
    }
    cJSON_AddItemToArray((cJSON *)j->views, v);
    cJSON_AddStringToObject(v, "name", name);
    cJSON_AddItemToObject(v, "c2w", cJSON_CreateDoubleArray(c2w, 16));
    cJSON_AddNumberToObject(v, "angle_x", angle_x);
    int rc = MF_OK;
    if (env) {
        char dims[3 * 12];
        int dl = snprintf(dims, sizeof dims, "%d %d %d", env->w, env->h, env->c);
        uint64_t h = mf_fnv1a64(mf_fnv1a64(MF_FNV64_INIT, dims, (size_t)dl), env->data, sizeof(float) * (size_t)env->w * env->h * env->c);
        if (h != j->env_hash || !j->env_hash) {
            snprintf(j->env_file, sizeof j->env_file, "env_%s.exr", name);
            j->env_hash = (rc = write_exr(j, j->env_file, env)) ? 0 : h;
        }
        cJSON_AddStringToObject(v, "env", j->env_file);
    } else
        cJSON_AddNullToObject(v, "env");
    for (int i = 0; i < n; ++i) {
        cJSON *l = cJSON_CreateObject();
        cJSON_AddItemToArray(ls, l);
        int sun = lights[i].kind == MF_LIGHT_SUN;
        float s = lights[i].strength * (sun ? 1.0f : DS_CYCLES_POINT_SCALE);
        cJSON_AddStringToObject(l, "kind", sun ? "sun" : "point");
        cJSON_AddItemToObject(l, sun ? "dir" : "pos", vec3(sun ? lights[i].dir : lights[i].pos));
        cJSON_AddItemToObject(l, "rgb", vec3(mf_scale(lights[i].color, s)));
    }
    cJSON_AddItemToObject(v, "lights", ls);
    return rc;
}

int ds_cycles_run(DsCyclesJob *j) {
    if (!ds_cycles_available())
        return mf_fail(MF_EEXT, "%s: blender cannot be run (install Debian's blender, or set $MF_BLENDER)", blender_bin());
    char script[MF_PATH_MAX], jp[MF_PATH_MAX], logp[MF_PATH_MAX];
    int rc = script_path(script, sizeof script);
    if (rc || (rc = mf_path_join(jp, sizeof jp, j->dir, "job.json")) || (rc = mf_path_join(logp, sizeof logp, j->dir, "blender.log")))
        return rc;
    cJSON *job = cJSON_CreateObject();
    cJSON_AddNumberToObject(job, "res", j->res);
    cJSON_AddNumberToObject(job, "samples", j->samples);
    cJSON_AddNumberToObject(job, "bounces", j->bounces);
    cJSON_AddStringToObject(job, "mesh", "mesh.obj");
    cJSON_AddStringToObject(job, "kd", "kd.exr");
    cJSON_AddStringToObject(job, "orm", "orm.exr");
    cJSON_AddItemReferenceToObject(job, "views", (cJSON *)j->views);
    rc = mf_json_save(jp, job);
    cJSON_Delete(job);
    if (rc) return rc;
    char *argv[] = {(char *)blender_bin(), "-b", "--factory-startup", "-noaudio", "-P", script, "--", jp, NULL};
    int run = mf_run_logged(argv, logp);
    if (run > 0) return mf_fail(MF_EEXT, "%s: cannot start blender: %s", blender_bin(), strerror(run));
    if (run < 0) return mf_fail(MF_EEXT, "%s: blender failed (see %s)", jp, logp);
    return MF_OK;
}

int ds_cycles_read(const DsCyclesJob *j, const char *name, MfImage *out) {
    char f[300], p[MF_PATH_MAX];
    snprintf(f, sizeof f, "%s.exr", name);
    int rc = mf_path_join(p, sizeof p, j->dir, f);
    if (!rc && !mf_file_exists(p)) rc = mf_fail(MF_EEXT, "%s: Blender wrote no image (see %s/blender.log)", p, j->dir);
    MfImage img = {0};
    if (!rc) rc = mf_image_read(p, MF_ENC_LINEAR, &img);
    if (!rc && (img.w != j->res || img.h != j->res || img.c != 4)) {
        rc = mf_fail(MF_EFORMAT, "%s: expected %dx%d RGBA from Blender, got %dx%d with %d channels", p, j->res, j->res, img.w, img.h, img.c);
        mf_image_free(&img);
    }
    if (!rc) *out = img;
    return rc;
}

void ds_cycles_end(DsCyclesJob *j, int keep_log) {
    cJSON_Delete((cJSON *)j->views);
    j->views = NULL;
    DIR *d = opendir(j->dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.' || (keep_log && !strcmp(e->d_name, "blender.log"))) continue;
        char p[MF_PATH_MAX];
        if (!mf_path_join(p, sizeof p, j->dir, e->d_name)) unlink(p);
    }
    closedir(d);
    if (!keep_log) rmdir(j->dir);
}
