#include "datasets/ds_gen.h"

#include <cJSON.h>
#include <dirent.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_cameras.h"
#include "datasets/ds_cycles.h"
#include "datasets/ds_envgen.h"
#include "datasets/ds_povray.h"
#include "datasets/ds_shapes.h"
#include "datasets/ds_split.h"
#include "io/mf_json.h"
#include "render/mf_integrator.h"

uint64_t ds_object_seed(DsSeedStream stream, uint64_t seed, uint64_t k) {
    if (stream == DS_STREAM_TEST) return mf_hash64(seed, k); /* as the test splits always had */
    uint64_t h = mf_hash64(seed ^ ((uint64_t)stream * 0x9E3779B97F4A7C15ull), k);
    return ((uint64_t)stream << 60) | (h >> 4);
}

DsPriorTrainOpts ds_prior_train_defaults(void) {
    DsPriorTrainOpts o = {.count = 0, .res = 64, .seed = 1, .time_budget_s = 0.0, .views_per_object = 12, .tex_res = 128, .spp_sqrt = 2,
                          .pixel_samples = 4, .bounces = 0, .env_dir = NULL, .threads = 0, .stream = DS_STREAM_PRIOR, .split = "prior-train",
                          .train_lights = DS_LIGHTS_BLENDER, .diffuse = 0, .renderer = DS_RENDERER_OURS, .pov_radiosity = 0, .widen = 0,
                          .content = DS_CONTENT_ALL};
    return o;
}

DsPriorTrainOpts ds_test2d_defaults(void) {
    DsPriorTrainOpts o = ds_prior_train_defaults();
    o.count = 32, o.views_per_object = 4, o.spp_sqrt = 4, o.stream = DS_STREAM_TEST2D, o.split = "test-2d";
    return o;
}

int ds_train_lights_from_name(const char *name) {
    if (!name) return -1;
    if (!strcmp(name, "blender")) return DS_LIGHTS_BLENDER;
    if (!strcmp(name, "procedural")) return DS_LIGHTS_PROCEDURAL;
    if (!strcmp(name, "both")) return DS_LIGHTS_BOTH;
    return -1;
}

const char *ds_train_lights_name(DsTrainLights t) {
    return t == DS_LIGHTS_PROCEDURAL ? "procedural" : (t == DS_LIGHTS_BOTH ? "both" : "blender");
}

int ds_renderer_from_name(const char *name) {
    if (!name) return -1;
    if (!strcmp(name, "ours")) return DS_RENDERER_OURS;
    if (!strcmp(name, "povray")) return DS_RENDERER_POVRAY;
    if (!strcmp(name, "cycles")) return DS_RENDERER_CYCLES;
    return -1;
}

const char *ds_renderer_name(DsRenderer r) { return r == DS_RENDERER_POVRAY ? "povray" : r == DS_RENDERER_CYCLES ? "cycles" : "ours"; }

void ds_object_make_diffuse(DsObject *o) {
    for (size_t i = 0; i < (size_t)o->orm.w * (size_t)o->orm.h; ++i) {
        float *t = o->orm.data + i * (size_t)o->orm.c;
        if (t[1] < DS_DIFFUSE_ROUGHNESS_MIN) t[1] = DS_DIFFUSE_ROUGHNESS_MIN;
        t[2] = 0.0f;
    }
}

const char *ds_ambiguity_name(DsAmbiguity a) {
    static const char *const names[DS_AMBIG_COUNT] = {"low-contrast", "mixed-metal", "rough-glossy", "dark"};
    return a >= 0 && a < DS_AMBIG_COUNT ? names[a] : "none";
}

void ds_object_make_ambiguous(DsObject *o, DsAmbiguity a) {
    const size_t n = (size_t)o->kd.w * (size_t)o->kd.h;
    double mean[3] = {0, 0, 0};
    if (a == DS_AMBIG_LOW_CONTRAST) {
        for (size_t i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) mean[c] += o->kd.data[i * (size_t)o->kd.c + (size_t)c] / (double)n;
    }
    for (int y = 0; y < o->kd.h; ++y)
        for (int x = 0; x < o->kd.w; ++x) {
            float *kd = o->kd.data + ((size_t)y * (size_t)o->kd.w + (size_t)x) * (size_t)o->kd.c;
            float *orm = o->orm.data + ((size_t)y * (size_t)o->orm.w + (size_t)x) * (size_t)o->orm.c;
            int band_u = (6 * x / o->kd.w) % 2, band_v = (6 * y / o->kd.h) % 2;
            switch (a) {
            case DS_AMBIG_LOW_CONTRAST:
                for (int c = 0; c < 3; ++c) kd[c] = (float)(mean[c] + 0.2 * (kd[c] - mean[c]));
                break;
            case DS_AMBIG_MIXED_METAL:
                orm[2] = band_u ? 1.0f : 0.0f;
                if (band_u && orm[1] > 0.35f) orm[1] = 0.35f;
                break;
            case DS_AMBIG_ROUGH_GLOSSY: orm[1] = band_v ? 0.08f : 0.9f; break;
            case DS_AMBIG_DARK:
                for (int c = 0; c < 3; ++c) kd[c] *= 0.1f;
                break;
            default: break;
            }
        }
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

int ds_list_probes(const char *dir, char ***names, int *n) {
    DIR *d = opendir(dir);
    if (!d) return mf_fail(MF_EIO, "%s: cannot open the probe folder", dir);
    char **v = NULL;
    int cnt = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t l = strlen(e->d_name);
        if (e->d_name[0] == '.' || l < 5 || (strcmp(e->d_name + l - 4, ".exr") && strcmp(e->d_name + l - 4, ".hdr"))) continue;
        if (cnt == cap) {
            cap = cap ? 2 * cap : 16;
            char **nv = realloc(v, sizeof(char *) * (size_t)cap);
            if (!nv) break;
            v = nv;
        }
        if ((v[cnt] = strdup(e->d_name))) ++cnt;
    }
    closedir(d);
    if (cnt) qsort(v, (size_t)cnt, sizeof(char *), cmp_str);
    *names = v;
    *n = cnt;
    return MF_OK;
}

/* FNV-1a 64 of a file's bytes. */
static int file_fnv(const char *path, uint64_t *h) {
    char *data = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &data, &len);
    if (!rc) *h = mf_fnv1a64(MF_FNV64_INIT, data, len);
    free(data);
    return rc;
}

/* Writes an (res, res, 4) image from colour (rs floats per pixel, first 3 used) and alpha (as
 * floats per pixel): our AOVs (3, 1) or POV-Ray's premultiplied RGBA (4, 4). */
static int write_rgba(const char *path, const float *rgb, int rs, const float *alpha, int as, int w, int h, int premult, MfEncoding enc) {
    MfImage img;
    int rc = mf_image_alloc(&img, w, h, 4);
    if (rc) return rc;
    for (int i = 0; i < w * h; ++i) {
        float a = alpha[(size_t)i * as], s = (premult && a > 0) ? 1.0f / a : 1.0f;
        for (int c = 0; c < 3; ++c) img.data[4 * i + c] = a > 0 ? rgb[(size_t)i * rs + c] * s : 0.0f;
        img.data[4 * i + 3] = a;
    }
    rc = mf_image_write(path, &img, enc, 8);
    mf_image_free(&img);
    return rc;
}

typedef struct {
    MfEnvMap *probes; /* (np,) loaded probes */
    char **names;
    int np;
} ProbeSet;

/* Renders object k completely and writes its marker. Runs in one thread. */
/* Object k of the split is candidate j (k itself unless a content filter is on). */
static int render_object(const DsPriorTrainOpts *o, const char *out, const ProbeSet *ps, int k, int j, int *nviews, int *nenv) {
    DsFamily fam = (DsFamily)(j % DS_FAM_COUNT);
    uint64_t oseed = ds_object_seed(o->stream, o->seed, (uint64_t)j);
    DsObject obj;
    int rc = ds_object_generate(&obj, fam, oseed, o->tex_res);
    if (rc) return rc;
    if (!ds_content_accepts(o->content, &obj)) { /* the filter ran on a small-texture copy: must agree */
        ds_object_free(&obj);
        return mf_fail(MF_EARG, "%s: object %d (candidate %d) fails the content filter at texture size %d", o->split, k, j, o->tex_res);
    }
    DsWidenObject wo = {0};
    if (o->widen) {
        wo = ds_widen_object(oseed);
        ds_widen_overlay(&wo, oseed, &obj);
    }
    if (o->diffuse || wo.povray) ds_object_make_diffuse(&obj);
    MfRtScene *rt = NULL;
    MfMat4 *c2w = malloc(sizeof(MfMat4) * (size_t)o->views_per_object);
    char *marker = NULL;
    size_t mcap = (size_t)o->views_per_object * 3 * 64 + 64, mlen = 0;
    marker = malloc(mcap);
    if (!c2w || !marker) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (!rc) rc = mf_rtscene_new(&obj.mesh, &rt);
    DsCamSampling cs = o->widen ? ds_widen_cameras(&wo) : ds_cam_sampling_default();
    if (!rc) rc = ds_sample_cameras(&cs, o->views_per_object, oseed, 0, c2w);
    MfTexMaterial mat = {.kd = &obj.kd, .orm = &obj.orm, .kd_const = {0.5f, 0.5f, 0.5f}, .orm_const = {1, 0.5f, 0}};
    MfRng rng;
    mf_rng_seed(&rng, oseed, 0x119447u);
    MfRenderOut ro = {0};
    /* POV-Ray: the camera-independent assets once per object, in a scratch folder of its own */
    int pov = o->renderer == DS_RENDERER_POVRAY || wo.povray, cyc = o->renderer == DS_RENDERER_CYCLES && !wo.povray;
    char pdir[MF_PATH_MAX] = "";
    DsCyclesJob job = {0}; /* Cycles: every view of the object in one Blender run after the loop */
    if (!rc && cyc) {
        char rel[64], cdir[MF_PATH_MAX];
        snprintf(rel, sizeof rel, ".cycles/%06d", k);
        if (!(rc = mf_path_join(cdir, sizeof cdir, out, rel))) rc = ds_cycles_begin(&job, cdir, &obj.mesh, &obj.kd, &obj.orm, o->res);
    }
    DsPovScene pscene = {&obj.mesh, &obj.kd, {0.5f, 0.5f, 0.5f}, NULL, NULL, 0, o->pov_radiosity > 0 ? o->pov_radiosity : DS_SPLIT_POV_RADIOSITY, 1, 1};
    if (!rc && pov) {
        char rel[64];
        snprintf(rel, sizeof rel, ".povray/%06d", k);
        if (!(rc = mf_path_join(pdir, sizeof pdir, out, rel)) && !(rc = mf_mkdirs(pdir))) rc = ds_povray_export_assets(&pscene, pdir);
    }
    for (int v = 0; v < o->views_per_object && !rc; ++v) {
        MfCamera cam;
        double m[16];
        for (int i = 0; i < 16; ++i) m[i] = c2w[v].m[i];
        if ((rc = mf_camera_init(&cam, o->res, o->res, cs.camera_angle_x, m, "prior-train camera"))) break;
        /* the light: all draws happen for every view, so the stream does not depend on choices */
        float u_kind = mf_rng_float(&rng), u_kind2 = mf_rng_float(&rng), u_probe = mf_rng_float(&rng), u_rot = mf_rng_float(&rng),
              u_pow = mf_rng_float(&rng);
        MfEnvMap env = {0};
        MfLight light;
        MfRenderInput in = {rt, &obj.mesh, &mat, 1, NULL, NULL, 0};
        MfVec3 cpos = mf_camera_pos(&cam);
        if (u_kind < 0.5f) {
            MfImage copy;
            int procedural = o->train_lights == DS_LIGHTS_PROCEDURAL || (o->train_lights == DS_LIGHTS_BOTH && u_probe >= 0.5f);
            if (procedural) {
                float u_sel = o->train_lights == DS_LIGHTS_BOTH ? 2.0f * (u_probe - 0.5f) : u_probe;
                uint64_t eseed = mf_hash64(oseed, 0xE0000u + (uint64_t)v);
                if (u_sel < 0.5f) { /* sky map + the sun as a directional light (ds_envgen.h) */
                    DsSkyParams sp = ds_sky_params_random(eseed);
                    sp.sun_as_light = 1;
                    DsSkyInfo si;
                    if ((rc = ds_env_sky(&sp, DS_ENV_W, DS_ENV_H, &copy, &si))) break;
                    float a = u_rot * 2.0f * MF_PI, ca = cosf(a), sa = sinf(a); /* rotated with the map */
                    memset(&light, 0, sizeof light);
                    light.kind = MF_LIGHT_SUN;
                    light.dir = mf_norm(mf_v3(ca * si.sun_dir.x - sa * si.sun_dir.y, sa * si.sun_dir.x + ca * si.sun_dir.y, si.sun_dir.z));
                    light.color = si.sun_rgb;
                    light.strength = 1.0f;
                    if (mf_maxc(si.sun_rgb) > 0) in.lights = &light, in.nlights = 1;
                } else if ((rc = ds_env_random(DS_ENV_INDOOR, eseed, DS_ENV_W, DS_ENV_H, &copy)))
                    break;
            } else {
                float u_sel = o->train_lights == DS_LIGHTS_BOTH ? 2.0f * u_probe : u_probe;
                int pi = (int)(u_sel * (float)ps->np);
                if (pi >= ps->np) pi = ps->np - 1;
                if (pi < 0) pi = 0;
                const MfImage *src = &ps->probes[pi].img;
                if ((rc = mf_image_alloc(&copy, src->w, src->h, 3))) break;
                memcpy(copy.data, src->data, sizeof(float) * (size_t)src->w * (size_t)src->h * 3);
            }
            if ((rc = mf_env_init(&env, &copy))) break;
            ++*nenv;
            if ((rc = mf_env_rotate_z(&env, u_rot * 2.0f * MF_PI))) { mf_env_free(&env); break; }
            in.env = &env;
        } else {
            memset(&light, 0, sizeof light);
            light.color = mf_v3s(1.0f);
            if (u_kind2 < 0.5f) {
                light.kind = MF_LIGHT_POINT;
                light.pos = cpos;
                light.strength = DS_POINT_W_MIN + u_pow * (DS_POINT_W_MAX - DS_POINT_W_MIN);
            } else {
                light.kind = MF_LIGHT_SUN;
                light.dir = mf_norm(cpos);
                light.strength = DS_SUN_MIN + u_pow * (DS_SUN_MAX - DS_SUN_MIN);
            }
            in.lights = &light;
            in.nlights = 1;
        }
        MfRenderOpts ropt = {.spp_sqrt = o->spp_sqrt, .pixel_samples = o->pixel_samples, .seed = mf_hash64(oseed, (uint64_t)v + 1000),
                             .lobes = MF_LOBE_ALL, .bounces = o->bounces};
        rc = mf_render(&in, &cam, &ropt, &ro, NULL);
        MfImage pimg = {0}; /* POV-Ray's lit view: (res, res, 4) linear, premultiplied */
        char vname[32];
        snprintf(vname, sizeof vname, "v%03d", v);
        if (!rc && cyc) rc = ds_cycles_add_view(&job, vname, m, cs.camera_angle_x, in.env ? &env.img : NULL, in.lights, in.nlights);
        if (!rc && pov) {
            /* the same light: the view's (rotated) env map and its sun or point light */
            DsPovScene envonly = {NULL, NULL, {0, 0, 0}, in.env ? &env.img : NULL, NULL, 0, 0, 0, 1};
            pscene.env = in.env ? &env.img : NULL;
            pscene.lights = in.lights;
            pscene.nlights = in.nlights;
            if (!(rc = ds_povray_export_assets(&envonly, pdir)) && !(rc = ds_povray_write_view(&pscene, &cam, pdir, vname)))
                rc = ds_povray_run(pdir, vname, o->res, o->res, pscene.aa_depth, &pimg);
            static const char *const ext[3] = {"pov", "log", "exr"};
            for (int e = 0; e < 3 && !rc; ++e) {
                char f[64], fp[MF_PATH_MAX];
                snprintf(f, sizeof f, "%s.%s", vname, ext[e]);
                if (!mf_path_join(fp, sizeof fp, pdir, f)) unlink(fp);
            }
        }
        if (in.env) mf_env_free(&env);
        if (!rc && o->widen && !cyc) { /* Cycles: after its run */
            DsWidenView wv = ds_widen_view(oseed, v);
            rc = pov ? ds_widen_apply(&wv, pimg.data, 4, pimg.data + 3, 4, o->res) : ds_widen_apply(&wv, ro.rgb, 3, ro.alpha, 1, o->res);
        }
        if (rc) {
            mf_image_free(&pimg);
            break;
        }
        int idx = k * o->views_per_object + v;
        static const char *const sub[3] = {"rgb", "albedo", "orm"};
        for (int j = 0; j < 3 && !rc; ++j) {
            char rel[64], p[MF_PATH_MAX];
            snprintf(rel, sizeof rel, "%s/%06d.png", sub[j], idx);
            if (j == 0 && cyc) continue; /* after the Blender run */
            if ((rc = mf_path_join(p, sizeof p, out, rel))) break;
            if (j == 0 && pov) rc = write_rgba(p, pimg.data, 4, pimg.data + 3, 4, o->res, o->res, 1, MF_ENC_SRGB);
            else if (j == 0) rc = write_rgba(p, ro.rgb, 3, ro.alpha, 1, o->res, o->res, 1, MF_ENC_SRGB);
            else if (j == 1) rc = write_rgba(p, ro.albedo, 3, ro.alpha, 1, o->res, o->res, 0, MF_ENC_SRGB);
            else rc = write_rgba(p, ro.orm, 3, ro.alpha, 1, o->res, o->res, 0, MF_ENC_LINEAR);
            uint64_t h = 0;
            if (!rc) rc = file_fnv(p, &h);
            if (!rc) mlen += (size_t)snprintf(marker + mlen, mcap - mlen, "%s %016llx\n", rel, (unsigned long long)h);
        }
        mf_render_out_free(&ro);
        mf_image_free(&pimg);
        if (!rc) ++*nviews;
    }
    if (cyc && !rc) rc = ds_cycles_run(&job);
    for (int v = 0; cyc && v < o->views_per_object && !rc; ++v) {
        char vname[32], rel[64], p[MF_PATH_MAX];
        snprintf(vname, sizeof vname, "v%03d", v);
        snprintf(rel, sizeof rel, "rgb/%06d.png", k * o->views_per_object + v);
        MfImage cimg = {0}; /* (res, res, 4) linear, premultiplied */
        uint64_t h = 0;
        DsWidenView wv = ds_widen_view(oseed, v);
        if (!(rc = ds_cycles_read(&job, vname, &cimg)) && !(rc = o->widen ? ds_widen_apply(&wv, cimg.data, 4, cimg.data + 3, 4, o->res) : MF_OK) &&
            !(rc = mf_path_join(p, sizeof p, out, rel)) && !(rc = write_rgba(p, cimg.data, 4, cimg.data + 3, 4, o->res, o->res, 1, MF_ENC_SRGB)) &&
            !(rc = file_fnv(p, &h)))
            mlen += (size_t)snprintf(marker + mlen, mcap - mlen, "%s %016llx\n", rel, (unsigned long long)h);
        mf_image_free(&cimg);
    }
    if (cyc) ds_cycles_end(&job, rc != 0); /* a failed run keeps blender.log */
    if (pov && pdir[0]) { /* scratch: the assets and the folder (a failed view's files stay for its log) */
        static const char *const assets[3] = {"mesh.inc", "kd.hdr", "env.hdr"};
        for (int e = 0; e < 3 && !rc; ++e) {
            char fp[MF_PATH_MAX];
            if (!mf_path_join(fp, sizeof fp, pdir, assets[e])) unlink(fp);
        }
        if (!rc) rmdir(pdir);
    }
    if (!rc) {
        char rel[64], p[MF_PATH_MAX];
        snprintf(rel, sizeof rel, "done/%06d.txt", k);
        if (!(rc = mf_path_join(p, sizeof p, out, rel))) rc = mf_write_file(p, marker, mlen);
    }
    mf_render_out_free(&ro);
    free(marker);
    free(c2w);
    if (rt) mf_rtscene_free(rt);
    ds_object_free(&obj);
    return rc;
}

static int marker_path(const char *out, int k, char *p, size_t cap) {
    char rel[64];
    snprintf(rel, sizeof rel, "done/%06d.txt", k);
    return mf_path_join(p, cap, out, rel);
}

static int write_manifest(const DsPriorTrainOpts *o, const char *out, const ProbeSet *ps, const DsGenStats *st) {
    cJSON *r = cJSON_CreateObject(), *files = cJSON_CreateObject(), *pr = cJSON_CreateArray();
    char buf[64];
    cJSON_AddStringToObject(r, "split", o->split ? o->split : "prior-train");
    cJSON_AddNumberToObject(r, "seed_stream", o->stream);
    cJSON_AddNumberToObject(r, "resolution", o->res);
    cJSON_AddNumberToObject(r, "count", st->count);
    cJSON_AddNumberToObject(r, "seed", (double)o->seed);
    cJSON_AddNumberToObject(r, "objects", st->objects);
    cJSON_AddNumberToObject(r, "views_per_object", o->views_per_object);
    cJSON_AddNumberToObject(r, "tex_res", o->tex_res);
    cJSON_AddNumberToObject(r, "spp_sqrt", o->spp_sqrt);
    cJSON_AddNumberToObject(r, "pixel_samples", o->pixel_samples);
    if (o->bounces) cJSON_AddNumberToObject(r, "bounces", o->bounces);
    static const char *const kLights[3] = {
        "50% HDR probe rotated about +Z, 25% point light at the camera, 25% sun along the view",
        "50% procedural env map (25% clear sky with sun, 25% lit room; datasets/ds_envgen.h) rotated about +Z, 25% point light at the camera, 25% sun along the view",
        "25% HDR probe rotated about +Z, 25% procedural env map (12.5% sky, 12.5% room) rotated about +Z, 25% point light at the camera, 25% sun along the view"};
    cJSON_AddStringToObject(r, "lights", kLights[o->train_lights == DS_LIGHTS_PROCEDURAL ? 1 : (o->train_lights == DS_LIGHTS_BOTH ? 2 : 0)]);
    cJSON_AddStringToObject(r, "train_lights", ds_train_lights_name(o->train_lights));
    if (o->diffuse || o->renderer != DS_RENDERER_OURS) { /* only then: the default manifest keeps its keys */
        cJSON_AddBoolToObject(r, "diffuse", o->diffuse != 0);
        cJSON_AddStringToObject(r, "renderer", o->renderer == DS_RENDERER_POVRAY   ? "povray (lit views), mf (GT albedo/ORM AOVs)"
                                               : o->renderer == DS_RENDERER_CYCLES ? "blender cycles (lit views: datasets/ds_cycles.py), mf (GT albedo/ORM AOVs)"
                                                                                   : "mf");
        if (o->renderer == DS_RENDERER_POVRAY)
            cJSON_AddNumberToObject(r, "pov_radiosity", o->pov_radiosity > 0 ? o->pov_radiosity : DS_SPLIT_POV_RADIOSITY);
    }
    if (o->content != DS_CONTENT_ALL) cJSON_AddStringToObject(r, "content", ds_content_name(o->content));
    if (o->widen)
        cJSON_AddStringToObject(r, "widen", "datasets/ds_widen.h: POV-Ray lit views for 10% of the objects (made diffuse), field of view "
                                            "0.45-1.0 rad, UV overlays on 30%, exposure +-2 stops, tone curves, resolution drop, noise");
    snprintf(buf, sizeof buf, "[%g, %g]", (double)DS_POINT_W_MIN, (double)DS_POINT_W_MAX);
    cJSON_AddStringToObject(r, "point_power_w", buf);
    snprintf(buf, sizeof buf, "[%g, %g]", (double)DS_SUN_MIN, (double)DS_SUN_MAX);
    cJSON_AddStringToObject(r, "sun_strength_w_m2", buf);
    for (int i = 0; i < ps->np; ++i) cJSON_AddItemToArray(pr, cJSON_CreateString(ps->names[i]));
    cJSON_AddItemToObject(r, "probes", pr);
    cJSON_AddNumberToObject(r, "wall_time_s", st->wall_s);
    cJSON_AddNumberToObject(r, "views_rendered_this_run", st->rendered_views);
    cJSON_AddNumberToObject(r, "views_per_s", st->wall_s > 0 ? st->rendered_views / st->wall_s : 0.0);
    cJSON_AddNumberToObject(r, "threads", omp_get_max_threads());
    cJSON_AddStringToObject(r, "checksum", "fnv1a64");
    int rc = MF_OK;
    for (int k = 0; k < st->objects && !rc; ++k) {
        char p[MF_PATH_MAX], *data = NULL;
        size_t len = 0;
        if ((rc = marker_path(out, k, p, sizeof p)) || (rc = mf_read_file(p, &data, &len))) break;
        char *save = NULL;
        for (char *line = strtok_r(data, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
            char *sp = strchr(line, ' ');
            if (!sp) { rc = mf_fail(MF_EFORMAT, "%s: malformed marker line", p); break; }
            *sp = '\0';
            cJSON_AddStringToObject(files, line, sp + 1);
        }
        free(data);
    }
    cJSON_AddItemToObject(r, "files", files);
    char p[MF_PATH_MAX];
    if (!rc && !(rc = mf_path_join(p, sizeof p, out, "manifest.json"))) rc = mf_json_save(p, r);
    cJSON_Delete(r);
    return rc;
}

/* cand (n,) = the first n candidate indices the content filter accepts. Objects are generated
 * with small textures for the test (materials do not depend on the texture size; render_object
 * checks the full-size object again); held-out families decide without generating. */
static int content_candidates(const DsPriorTrainOpts *o, int n, int **cand) {
    int *c = malloc(sizeof(int) * (size_t)n);
    if (!c) return mf_fail(MF_ENOMEM, "out of memory");
    int got = 0, rc = MF_OK;
    for (int j = 0; got < n && !rc; ++j) {
        if (j >= (1 << 24)) {
            rc = mf_fail(MF_EARG, "%s: only %d of %d objects pass content %s", o->split, got, n, ds_content_name(o->content));
            break;
        }
        DsFamily fam = (DsFamily)(j % DS_FAM_COUNT);
        int ok;
        if (ds_family_heldout(fam)) ok = o->content == DS_CONTENT_HELDOUT;
        else {
            DsObject obj;
            if ((rc = ds_object_generate(&obj, fam, ds_object_seed(o->stream, o->seed, (uint64_t)j), 16))) break;
            ok = ds_content_accepts(o->content, &obj);
            ds_object_free(&obj);
        }
        if (ok) c[got++] = j;
    }
    if (rc) free(c), c = NULL;
    *cand = c;
    return rc;
}

int ds_gen_prior_train(const DsPriorTrainOpts *o, const char *out_dir, DsGenStats *stats) {
    if (o->res < 8 || o->res > 4096) return mf_fail(MF_EARG, "prior-train: resolution %d outside [8, 4096]", o->res);
    if (o->views_per_object < 1 || o->spp_sqrt < 1 || o->pixel_samples < 1) return mf_fail(MF_EARG, "prior-train: views, spp and pixel samples must be >= 1");
    if (o->bounces < 0) return mf_fail(MF_EARG, "prior-train: bounces must be >= 0");
    if (o->count <= 0 && o->time_budget_s <= 0) return mf_fail(MF_EARG, "prior-train: give a count or a time budget");
    if (o->renderer != DS_RENDERER_OURS && o->renderer != DS_RENDERER_POVRAY && o->renderer != DS_RENDERER_CYCLES)
        return mf_fail(MF_EARG, "prior-train: unknown renderer %d", (int)o->renderer);
    if (o->content != DS_CONTENT_ALL && o->count <= 0)
        return mf_fail(MF_EARG, "%s: content %s needs a sample count", o->split ? o->split : "prior-train", ds_content_name(o->content));
    if (o->renderer == DS_RENDERER_CYCLES && !ds_cycles_available())
        return mf_fail(MF_EEXT, "%s: renderer cycles needs Blender: blender (/usr/bin/blender or $MF_BLENDER) cannot be run (install Debian's blender; it is optional)",
                       o->split ? o->split : "prior-train");
    if ((o->renderer == DS_RENDERER_POVRAY || o->widen) && !ds_povray_available())
        return mf_fail(MF_EEXT, "%s: renderer povray needs POV-Ray: povray (/usr/bin/povray or $MF_POVRAY) cannot be run (install Debian's povray: make deps)",
                       o->split ? o->split : "prior-train");
    double t0 = mf_now();
    const char *env_dir = o->env_dir ? o->env_dir : DS_DEFAULT_ENV_DIR;
    static const char *const subs[4] = {"rgb", "albedo", "orm", "done"};
    for (int j = 0; j < 4; ++j) {
        char p[MF_PATH_MAX];
        int r = mf_path_join(p, sizeof p, out_dir, subs[j]);
        if (r || (r = mf_mkdirs(p))) return r;
    }
    if (o->train_lights != DS_LIGHTS_BLENDER && o->train_lights != DS_LIGHTS_PROCEDURAL && o->train_lights != DS_LIGHTS_BOTH)
        return mf_fail(MF_EARG, "prior-train: unknown train_lights %d", (int)o->train_lights);
    ProbeSet ps = {0};
    int rc = MF_OK;
    if (o->train_lights != DS_LIGHTS_PROCEDURAL) { /* procedural: env_dir is never read */
        if ((rc = ds_list_probes(env_dir, &ps.names, &ps.np))) return rc;
        if (!ps.np) rc = mf_fail(MF_EARG, "%s: no .exr/.hdr probes", env_dir);
    }
    if (!rc && ps.np > 0 && !(ps.probes = calloc((size_t)ps.np, sizeof(MfEnvMap)))) rc = mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; i < ps.np && !rc; ++i) {
        char p[MF_PATH_MAX];
        if (!(rc = mf_path_join(p, sizeof p, env_dir, ps.names[i]))) rc = mf_env_load(&ps.probes[i], p);
    }
    int max_obj = o->count > 0 ? (o->count + o->views_per_object - 1) / o->views_per_object : 1 << 20;
    int *cand = NULL; /* (max_obj,) candidate index of each object; NULL: the identity */
    if (!rc && o->content != DS_CONTENT_ALL) rc = content_candidates(o, max_obj, &cand);
    int first_err = 0, views_total = 0, env_total = 0, stop = 0;
    char errmsg[1024] = "";
    MfProgress prog;
    mf_progress_begin(&prog, o->split ? o->split : "prior-train", o->count > 0 ? (size_t)max_obj : 0);
    int nthreads = o->threads > 0 ? o->threads : omp_get_max_threads();
    if (!rc) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads) reduction(+ : views_total, env_total)
        for (int k = 0; k < max_obj; ++k) {
            int skip;
#pragma omp atomic read
            skip = stop;
            if (skip) continue;
            if (o->time_budget_s > 0 && mf_now() - t0 > o->time_budget_s) {
#pragma omp atomic write
                stop = 1;
                continue;
            }
            char mp[MF_PATH_MAX];
            if (marker_path(out_dir, k, mp, sizeof mp) == MF_OK && mf_file_exists(mp)) { mf_progress_add(&prog, 1); continue; }
            int nv = 0, ne = 0;
            int r = render_object(o, out_dir, &ps, k, cand ? cand[k] : k, &nv, &ne);
            views_total += nv;
            env_total += ne;
            if (r) {
#pragma omp critical(ds_gen_err)
                {
                    if (!first_err) { first_err = r; snprintf(errmsg, sizeof errmsg, "%s", mf_error()); }
                }
#pragma omp atomic write
                stop = 1;
            }
            mf_progress_add(&prog, 1);
        }
    }
    mf_progress_end(&prog);
    for (int s = 0; s < 2; ++s) { /* the scratch roots, empty when every object finished */
        char p[MF_PATH_MAX];
        if (!mf_path_join(p, sizeof p, out_dir, s ? ".cycles" : ".povray")) rmdir(p);
    }
    if (!rc && first_err) rc = mf_fail(first_err, "%s", errmsg);
    DsGenStats st = {0};
    st.rendered_views = views_total;
    st.env_views = env_total;
    st.wall_s = mf_now() - t0;
    /* complete objects: the prefix with markers */
    if (!rc) {
        char mp[MF_PATH_MAX];
        while (st.objects < max_obj && marker_path(out_dir, st.objects, mp, sizeof mp) == MF_OK && mf_file_exists(mp)) ++st.objects;
        st.count = st.objects * o->views_per_object;
        rc = write_manifest(o, out_dir, &ps, &st);
    }
    if (stats) *stats = st;
    free(cand);
    for (int i = 0; i < ps.np; ++i) {
        if (ps.probes) mf_env_free(&ps.probes[i]);
        free(ps.names[i]);
    }
    free(ps.probes);
    free(ps.names);
    return rc;
}
