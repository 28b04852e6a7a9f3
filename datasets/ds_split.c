#include "datasets/ds_split.h"

#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "datasets/ds_asset.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_gen.h"
#include "datasets/ds_shapes.h"
#include "io/mf_json.h"

int ds_split_spec(const char *name, DsSplitSpec *out) {
    DsSplitSpec s;
    memset(&s, 0, sizeof s);
    s.r_min = 1.5f;
    s.r_max = 2.0f;
    s.pixel_samples = 4;
    if (!strcmp(name, "tiny")) { s.n_scenes = 3; s.width = 32; s.n_train = 8; s.n_test = 4; s.tex_res = 64; s.n_relight = 2; s.spp_sqrt = 4; }
    else if (!strcmp(name, "small")) { s.n_scenes = 10; s.width = 128; s.n_train = 50; s.n_test = 20; s.tex_res = 256; s.n_relight = 3; s.spp_sqrt = 8; }
    else if (!strcmp(name, "full")) { s.n_scenes = 30; s.width = 512; s.n_train = 100; s.n_test = 50; s.tex_res = 512; s.n_relight = 4; s.spp_sqrt = 16; }
    else if (!strcmp(name, "test-3d") || !strcmp(name, "test-3d-diffuse") || !strcmp(name, "test-3d-ambig") || !strcmp(name, "test-3d-cyc")) {
        s.n_scenes = 9; s.width = 128; s.n_train = 64; s.n_test = 8; s.tex_res = 256; s.spp_sqrt = 3;
        s.diffuse = s.povray = !strcmp(name, "test-3d-diffuse");
        s.cycles = !strcmp(name, "test-3d-cyc");
        s.ambiguous = !strcmp(name, "test-3d-ambig");
        /* every other probe; the other renderers' variants keep 3 (each POV-Ray view costs ~6 CPU-s) */
        s.n_relight = s.povray || s.cycles ? 3 : DS_RELIGHT_ALL;
    }
    else return mf_fail(MF_EARG, "unknown split '%s' (tiny, small, full, test-3d, test-3d-diffuse, test-3d-cyc, test-3d-ambig, test-2d, prior-train)", name);
    snprintf(s.name, sizeof s.name, "%s", name);
    *out = s;
    return MF_OK;
}

static int copy_file(const char *from, const char *to) {
    size_t l = strlen(from);
    if (l < 4 || strcmp(from + l - 4, ".exr")) { /* .hdr: converted, the layout holds EXR */
        MfImage img = {0};
        int rc = mf_image_read(from, MF_ENC_LINEAR, &img);
        if (!rc) rc = mf_mkdirs_for(to);
        if (!rc) rc = mf_image_write(to, &img, MF_ENC_LINEAR, 32);
        mf_image_free(&img);
        return rc;
    }
    char *data = NULL;
    size_t len = 0;
    int rc = mf_read_file(from, &data, &len);
    if (!rc) rc = mf_mkdirs_for(to);
    if (!rc) rc = mf_write_file(to, data, len);
    free(data);
    return rc;
}

/* A scene JSON for `mf render` (mf_scene.h): paths relative to the scene folder. */
static int write_render_json(const char *path, const char *env, const char *cameras, const DsSplitSpec *s, uint64_t seed, int normal) {
    cJSON *r = cJSON_CreateObject(), *mat = cJSON_CreateObject(), *envo = cJSON_CreateObject(), *ren = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "mesh", "mesh.obj");
    cJSON_AddStringToObject(mat, "kd", "gt/kd.png");
    cJSON_AddStringToObject(mat, "orm", "gt/orm.png");
    if (normal) cJSON_AddStringToObject(mat, "normal", "gt/normal.png"); /* an asset's normalTexture */
    cJSON_AddItemToObject(r, "material", mat);
    cJSON_AddStringToObject(envo, "file", env);
    cJSON_AddNumberToObject(envo, "rotation_z_deg", 0);
    cJSON_AddNumberToObject(envo, "strength", 1);
    cJSON_AddItemToObject(r, "env", envo);
    cJSON_AddStringToObject(r, "cameras", cameras);
    cJSON_AddNumberToObject(r, "width", s->width);
    cJSON_AddNumberToObject(r, "height", s->width);
    cJSON_AddNumberToObject(ren, "spp_sqrt", s->spp_sqrt);
    cJSON_AddNumberToObject(ren, "pixel_samples", s->pixel_samples > 0 ? s->pixel_samples : 4);
    cJSON_AddNumberToObject(ren, "seed", (double)(seed & 0xFFFFFFu));
    cJSON_AddStringToObject(ren, "lobes", "all");
    cJSON_AddItemToObject(r, "render", ren);
    int rc = mf_json_save(path, r);
    cJSON_Delete(r);
    return rc;
}

static void strip_ext(char *s) {
    size_t l = strlen(s);
    if (l > 4 && (!strcmp(s + l - 4, ".exr") || !strcmp(s + l - 4, ".hdr"))) s[l - 4] = '\0';
}

int ds_write_split(DsSplitSpec *s, const char *out_dir, const char *env_dir, uint64_t seed) {
    if (!env_dir) env_dir = DS_DEFAULT_ENV_DIR;
    char **probes = NULL;
    int np = 0, rc;
    if ((rc = ds_list_probes(env_dir, &probes, &np))) return rc;
    if (s->n_relight == DS_RELIGHT_ALL) s->n_relight = np - 1;
    if (np < 2 || np < s->n_relight + 1) {
        for (int i = 0; i < np; ++i) free(probes[i]);
        free(probes);
        return mf_fail(MF_EARG, "%s: %d probes, the split needs %d (1 training + %d relighting)", env_dir, np, s->n_relight + 1, s->n_relight);
    }
    cJSON *list = cJSON_CreateObject(), *scenes = cJSON_CreateArray();
    cJSON_AddStringToObject(list, "split", s->name);
    cJSON_AddNumberToObject(list, "seed", (double)seed);
    cJSON_AddNumberToObject(list, "width", s->width);
    cJSON_AddItemToObject(list, "scenes", scenes);
    MfMat4 *c2w = malloc(sizeof(MfMat4) * (size_t)(s->n_train > s->n_test ? s->n_train : s->n_test));
    int *perm = malloc(sizeof(int) * (size_t)np);
    if (!c2w || !perm) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (s->asset) s->n_scenes = 1;
    if (!rc) rc = mf_mkdirs(out_dir);
    for (int k = 0; k < s->n_scenes && !rc; ++k) {
        DsFamily fam = (DsFamily)(k % DS_FAM_COUNT);
        uint64_t oseed = ds_object_seed(DS_STREAM_TEST, seed, (uint64_t)k);
        char sdir[MF_PATH_MAX], p[MF_PATH_MAX], name[80];
        DsObject o;
        if ((rc = s->asset ? ds_object_from_asset(s->asset, &o) : ds_object_generate(&o, fam, oseed, s->tex_res))) break;
        snprintf(name, sizeof name, "%03d_%s", k, s->asset ? o.asset : ds_family_name(fam));
        if ((rc = mf_path_join(sdir, sizeof sdir, out_dir, name))) { ds_object_free(&o); break; }
        if (s->diffuse) ds_object_make_diffuse(&o); /* metallic 0, roughness >= 0.6 */
        if (s->ambiguous) ds_object_make_ambiguous(&o, (DsAmbiguity)(k % DS_AMBIG_COUNT));
        int has_normal = o.normal.data != NULL;
        char unrendered[sizeof o.unrendered];
        snprintf(unrendered, sizeof unrendered, "%s", o.unrendered);
        rc = ds_object_write(&o, sdir);
        ds_object_free(&o);
        if (rc) break;
        DsCamSampling cs = ds_cam_sampling_default();
        cs.r_min = s->r_min;
        cs.r_max = s->r_max;
        if ((rc = ds_sample_cameras(&cs, s->n_train, oseed, 0, c2w)) || (rc = ds_write_transforms(sdir, "train", cs.camera_angle_x, c2w, s->n_train)))
            break;
        if ((rc = ds_sample_cameras(&cs, s->n_test, oseed, 1, c2w)) || (rc = ds_write_transforms(sdir, "test", cs.camera_angle_x, c2w, s->n_test)))
            break;
        /* probes: a seeded permutation; the first trains, the next n_relight relight */
        MfRng rng;
        mf_rng_seed(&rng, oseed, 0xE4F0u);
        for (int i = 0; i < np; ++i) perm[i] = i;
        for (int i = np - 1; i > 0; --i) {
            int j = (int)mf_rng_below(&rng, (uint32_t)(i + 1)), t = perm[i];
            perm[i] = perm[j];
            perm[j] = t;
        }
        char src[MF_PATH_MAX];
        if ((rc = mf_path_join(src, sizeof src, env_dir, probes[perm[0]])) || (rc = mf_path_join(p, sizeof p, sdir, "gt/env.exr")) ||
            (rc = copy_file(src, p)))
            break;
        if ((rc = mf_path_join(p, sizeof p, sdir, "render_train.json")) || (rc = write_render_json(p, "gt/env.exr", "transforms_train.json", s, oseed, has_normal)))
            break;
        if ((rc = mf_path_join(p, sizeof p, sdir, "render_test.json")) || (rc = write_render_json(p, "gt/env.exr", "transforms_test.json", s, oseed + 1, has_normal)))
            break;
        cJSON *sc = cJSON_CreateObject(), *rl = cJSON_CreateArray();
        char envname[256];
        snprintf(envname, sizeof envname, "%s", probes[perm[0]]);
        strip_ext(envname);
        cJSON_AddStringToObject(sc, "name", name);
        if (s->asset) {
            cJSON_AddStringToObject(sc, "asset", s->asset);
            cJSON_AddBoolToObject(sc, "normal_map", has_normal);
            if (unrendered[0]) cJSON_AddStringToObject(sc, "not_rendered", unrendered);
        } else cJSON_AddStringToObject(sc, "family", ds_family_name(fam));
        if (s->ambiguous) cJSON_AddStringToObject(sc, "ambiguity", ds_ambiguity_name((DsAmbiguity)(k % DS_AMBIG_COUNT)));
        char seedstr[32];
        snprintf(seedstr, sizeof seedstr, "%llu", (unsigned long long)oseed);
        cJSON_AddStringToObject(sc, "object_seed", seedstr);
        cJSON_AddStringToObject(sc, "train_env", envname);
        cJSON_AddItemToObject(sc, "relight", rl);
        cJSON_AddItemToArray(scenes, sc);
        for (int r = 0; r < s->n_relight && !rc; ++r) {
            char en[256], rel[MF_PATH_MAX + 300], jn[400];
            snprintf(en, sizeof en, "%s", probes[perm[1 + r]]);
            strip_ext(en);
            cJSON_AddItemToArray(rl, cJSON_CreateString(en));
            snprintf(rel, sizeof rel, "relight/%s.exr", en);
            if ((rc = mf_path_join(src, sizeof src, env_dir, probes[perm[1 + r]])) || (rc = mf_path_join(p, sizeof p, sdir, rel)) ||
                (rc = copy_file(src, p)))
                break;
            snprintf(jn, sizeof jn, "render_relight_%s.json", en);
            if ((rc = mf_path_join(p, sizeof p, sdir, jn)) || (rc = write_render_json(p, rel, "transforms_test.json", s, oseed + 2 + (uint64_t)r, has_normal)))
                break;
        }
    }
    if (!rc) {
        char p[MF_PATH_MAX];
        if (!(rc = mf_path_join(p, sizeof p, out_dir, "split.json"))) rc = mf_json_save(p, list);
    }
    cJSON_Delete(list);
    free(c2w);
    free(perm);
    for (int i = 0; i < np; ++i) free(probes[i]);
    free(probes);
    return rc;
}
