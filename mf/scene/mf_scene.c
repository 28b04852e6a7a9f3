#include "scene/mf_scene.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_json.h"
#include "io/mf_gltf_read.h"
#include "io/mf_obj.h"
#include "io/mf_opts.h"
#include "scene/mf_transforms.h"

int mf_lobes_parse(const char *name) {
    if (!strcmp(name, "all")) return 3;
    if (!strcmp(name, "diffuse")) return 1;
    if (!strcmp(name, "specular")) return 2;
    return -1;
}

/* dir of `file` joined with rel (rel unchanged when absolute). */
static int resolve(const char *file, const char *rel, char *out, size_t cap) {
    if (rel[0] == '/') {
        if (strlen(rel) >= cap) return mf_fail(MF_EARG, "%s: path too long", file);
        strcpy(out, rel);
        return MF_OK;
    }
    const char *slash = strrchr(file, '/');
    if (!slash) {
        if (strlen(rel) >= cap) return mf_fail(MF_EARG, "%s: path too long", file);
        strcpy(out, rel);
        return MF_OK;
    }
    int n = snprintf(out, cap, "%.*s/%s", (int)(slash - file), file, rel);
    if (n < 0 || (size_t)n >= cap) return mf_fail(MF_EARG, "%s: path too long", file);
    return MF_OK;
}

typedef struct {
    MfScene *s;
    const char *file;
    int cap_images;
} Ctx;

static int push_image(Ctx *c, MfImage img, const MfImage **out);

static int add_image(Ctx *c, const char *rel, MfEncoding enc, const char *where, const MfImage **out) {
    char p[MF_PATH_MAX];
    int rc = resolve(c->file, rel, p, sizeof p);
    if (rc) return rc;
    MfImage img;
    rc = mf_image_read(p, enc, &img);
    if (rc) return mf_fail_prefix(rc, "%s: %s", c->file, where);
    if (img.c < 3) {
        /* grey texture: replicate */
        MfImage o;
        rc = mf_image_alloc(&o, img.w, img.h, 3);
        if (rc) { mf_image_free(&img); return rc; }
        for (size_t i = 0; i < (size_t)img.w * img.h; ++i)
            for (int k = 0; k < 3; ++k) o.data[3 * i + k] = img.data[i * img.c];
        mf_image_free(&img);
        img = o;
    }
    return push_image(c, img, out);
}

/* Moves img into the scene's images; *out receives its index + 1 (see add_image). */
static int push_image(Ctx *c, MfImage img, const MfImage **out) {
    MfScene *s = c->s;
    if (s->nimages == c->cap_images) {
        int cap = c->cap_images ? 2 * c->cap_images : 8;
        MfImage *n = realloc(s->images, (size_t)cap * sizeof *n);
        if (!n) { mf_image_free(&img); return mf_fail(MF_ENOMEM, "%s: out of memory", c->file); }
        /* pointers held by materials move with the array: fixed up by the caller (indices) */
        s->images = n;
        c->cap_images = cap;
    }
    s->images[s->nimages] = img;
    *out = (const MfImage *)(intptr_t)(s->nimages + 1); /* index + 1; resolved after loading */
    s->nimages++;
    return MF_OK;
}

/* kd / orm: a file name (string) or 3 numbers. */
static int parse_channel(Ctx *c, const char *where, const cJSON *m, const char *key, MfEncoding enc_png,
                         const MfImage **tex, MfVec3 *val) {
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(m, key);
    if (!it || cJSON_IsNull(it)) return MF_OK;
    char w[256];
    snprintf(w, sizeof w, "%s.%s", where, key);
    if (cJSON_IsString(it)) {
        char ext[16];
        mf_path_ext(it->valuestring, ext, sizeof ext);
        MfEncoding enc = (!strcmp(ext, "exr") || !strcmp(ext, "hdr")) ? MF_ENC_LINEAR : enc_png;
        return add_image(c, it->valuestring, enc, w, tex);
    }
    float v[3];
    int rc = mf_json_floats(c->file, where, m, key, 0, 3, v);
    if (rc) return mf_fail(MF_EFORMAT, "%s: %s: expected a file name or 3 numbers", c->file, w);
    *tex = NULL;
    *val = mf_v3(v[0], v[1], v[2]);
    return MF_OK;
}

static int parse_material(Ctx *c, const char *where, const cJSON *m, MfSceneMaterial *out) {
    if (!cJSON_IsObject(m)) return mf_fail(MF_EFORMAT, "%s: %s: expected an object", c->file, where);
    int rc = parse_channel(c, where, m, "kd", MF_ENC_SRGB, &out->kd, &out->kd_const);
    if (!rc) rc = parse_channel(c, where, m, "orm", MF_ENC_LINEAR, &out->orm, &out->orm_const);
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(m, "normal");
    if (!rc && n && !cJSON_IsNull(n)) {
        char w[256];
        snprintf(w, sizeof w, "%s.normal", where);
        if (!cJSON_IsString(n)) return mf_fail(MF_EFORMAT, "%s: %s: expected a file name (a tangent-space normal map)", c->file, w);
        if (!c->s->mesh.uv) return mf_fail(MF_EFORMAT, "%s: %s: a normal map needs a mesh with UVs", c->file, w);
        rc = add_image(c, n->valuestring, MF_ENC_LINEAR, w, &out->normal);
    }
    return rc;
}

static int parse_env(Ctx *c, const cJSON *e) {
    if (!e || cJSON_IsNull(e)) return MF_OK;
    if (!cJSON_IsObject(e)) return mf_fail(MF_EFORMAT, "%s: env: expected an object or null", c->file);
    const char *rel;
    double rot, strength;
    int rc = mf_json_string(c->file, "env", e, "file", &rel);
    if (!rc) rc = mf_json_number_opt(c->file, "env", e, "rotation_z_deg", 0.0, &rot);
    if (!rc) rc = mf_json_number_opt(c->file, "env", e, "strength", 1.0, &strength);
    if (rc) return rc;
    if (!(strength >= 0.0)) return mf_fail(MF_EFORMAT, "%s: env.strength: must be >= 0", c->file);
    if (!(strength <= MF_STRENGTH_MAX))
        return mf_fail(MF_EFORMAT, "%s: env.strength: %g is out of range (0..%g)", c->file, strength, MF_STRENGTH_MAX);
    if (!isfinite(rot)) return mf_fail(MF_EFORMAT, "%s: env.rotation_z_deg: must be finite", c->file);
    rot = fmod(rot, 360.0); /* exact; 2e40 degrees as a float radian angle was inf */
    char p[MF_PATH_MAX];
    if ((rc = resolve(c->file, rel, p, sizeof p))) return rc;
    MfImage img;
    if ((rc = mf_image_read(p, MF_ENC_LINEAR, &img))) return mf_fail_prefix(rc, "%s: env.file", c->file);
    /* an overflow is the strength's doing: say so, with the largest strength this map allows */
    float peak = 0.0f;
    for (size_t i = 0; i < (size_t)img.w * img.h * img.c; ++i) peak = fmaxf(peak, fabsf(img.data[i]));
    if (!((double)peak * strength <= MF_STRENGTH_MAX)) {
        mf_image_free(&img);
        return mf_fail(MF_EFORMAT, "%s: env.strength: %g times the brightest texel of %s (%g) exceeds %g; at most %.3g for this map",
                       c->file, strength, p, (double)peak, MF_STRENGTH_MAX, MF_STRENGTH_MAX / (double)peak);
    }
    for (size_t i = 0; i < (size_t)img.w * img.h * img.c; ++i) img.data[i] *= (float)strength;
    if ((rc = mf_env_init(&c->s->env, &img))) return mf_fail_prefix(rc, "%s: env.file", c->file);
    c->s->has_env = 1;
    if (rot != 0.0 && (rc = mf_env_rotate_z(&c->s->env, (float)(rot * M_PI / 180.0)))) return mf_fail_prefix(rc, "%s: env", c->file);
    return MF_OK;
}

static int parse_lights(Ctx *c, const cJSON *root) {
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!arr || cJSON_IsNull(arr)) return MF_OK;
    if (!cJSON_IsArray(arr)) return mf_fail(MF_EFORMAT, "%s: lights: expected an array", c->file);
    int n = cJSON_GetArraySize(arr);
    if (n == 0) return MF_OK;
    c->s->lights = calloc((size_t)n, sizeof(MfLight));
    if (!c->s->lights) return mf_fail(MF_ENOMEM, "%s: out of memory", c->file);
    int k = 0;
    for (const cJSON *l = arr->child; l; l = l->next, ++k) {
        char w[64];
        snprintf(w, sizeof w, "lights[%d]", k);
        if (!cJSON_IsObject(l)) return mf_fail(MF_EFORMAT, "%s: %s: expected an object", c->file, w);
        const char *type;
        int rc = mf_json_string(c->file, w, l, "type", &type);
        if (rc) return rc;
        MfLight *L = &c->s->lights[k];
        float col[3] = {1, 1, 1};
        if (cJSON_GetObjectItemCaseSensitive(l, "color") && (rc = mf_json_floats(c->file, w, l, "color", 0, 3, col))) return rc;
        for (int q = 0; q < 3; ++q)
            if (!(fabsf(col[q]) <= (float)MF_STRENGTH_MAX))
                return mf_fail(MF_EFORMAT, "%s: %s.color: %g is out of range (|value| <= %g)", c->file, w, (double)col[q], MF_STRENGTH_MAX);
        L->color = mf_v3(col[0], col[1], col[2]);
        double v;
        float d[3];
        if (!strcmp(type, "sun")) {
            L->kind = MF_LIGHT_SUN;
            if ((rc = mf_json_floats(c->file, w, l, "dir", 0, 3, d))) return rc;
            if ((rc = mf_json_number(c->file, w, l, "strength", &v))) return rc;
            MfVec3 dir = mf_v3(d[0], d[1], d[2]);
            if (!(mf_len(dir) > 1e-8f)) return mf_fail(MF_EFORMAT, "%s: %s.dir: zero vector", c->file, w);
            L->dir = mf_norm(dir);
        } else if (!strcmp(type, "point")) {
            L->kind = MF_LIGHT_POINT;
            if ((rc = mf_json_floats(c->file, w, l, "pos", 0, 3, d))) return rc;
            if ((rc = mf_json_number(c->file, w, l, "power", &v))) return rc;
            for (int q = 0; q < 3; ++q)
                if (!(fabsf(d[q]) <= (float)MF_COORD_MAX))
                    return mf_fail(MF_EFORMAT, "%s: %s.pos: %c = %g is out of range (|coordinate| <= %g)", c->file, w, "xyz"[q],
                                   (double)d[q], MF_COORD_MAX);
            L->pos = mf_v3(d[0], d[1], d[2]);
        } else {
            return mf_fail(MF_EFORMAT, "%s: %s.type: unknown light type '%s' (sun, point)", c->file, w, type);
        }
        if (!(v >= 0.0)) return mf_fail(MF_EFORMAT, "%s: %s: strength/power must be >= 0", c->file, w);
        if (!(v <= MF_STRENGTH_MAX))
            return mf_fail(MF_EFORMAT, "%s: %s.%s: %g is out of range (0..%g)", c->file, w, L->kind == MF_LIGHT_SUN ? "strength" : "power", v,
                           MF_STRENGTH_MAX);
        L->strength = (float)v;
        c->s->nlights = k + 1;
    }
    return MF_OK;
}

static int parse_cameras(Ctx *c, const cJSON *root) {
    const cJSON *cams = cJSON_GetObjectItemCaseSensitive(root, "cameras");
    if (!cams) return mf_fail(MF_EFORMAT, "%s: cameras: missing", c->file);
    cJSON *own = NULL;
    const cJSON *obj = cams;
    char cfile[MF_PATH_MAX];
    const char *file = c->file;
    char prefix[64] = "cameras.";
    int rc;
    if (cJSON_IsString(cams)) {
        if ((rc = resolve(c->file, cams->valuestring, cfile, sizeof cfile))) return rc;
        if ((rc = mf_json_load(cfile, &own))) return mf_fail_prefix(rc, "%s: cameras", c->file);
        obj = own;
        file = cfile;
        prefix[0] = 0;
    } else if (!cJSON_IsObject(cams)) {
        return mf_fail(MF_EFORMAT, "%s: cameras: expected a file name or an object", c->file);
    }
    MfTransforms tf;
    char w[128];
    rc = mf_transforms_parse(file, prefix, obj, 0, &tf);
    if (!rc && tf.n == 0) rc = mf_fail(MF_EFORMAT, "%s: %sframes: empty", file, prefix);
    if (!rc) {
        c->s->views = calloc((size_t)tf.n, sizeof(MfSceneView));
        if (!c->s->views) rc = mf_fail(MF_ENOMEM, "%s: out of memory", file);
    }
    for (int k = 0; k < tf.n && !rc; ++k) {
        snprintf(w, sizeof w, "%sframes[%d]", prefix, k);
        MfSceneView *v = &c->s->views[k];
        v->camera_angle_x = tf.camera_angle_x;
        memcpy(v->c2w, tf.frames[k].c2w, sizeof v->c2w);
        if (tf.frames[k].name[0]) snprintf(v->name, sizeof v->name, "%s", tf.frames[k].name);
        else snprintf(v->name, sizeof v->name, "view_%03d", k);
        MfCamera cam;
        if ((rc = mf_camera_init(&cam, c->s->width, c->s->height, v->camera_angle_x, v->c2w, w))) {
            rc = mf_fail_prefix(rc, "%s", file);
            break;
        }
        c->s->nviews = k + 1;
    }
    int di, dj;
    if (!rc && mf_find_duplicate_name(c->s->views[0].name, sizeof c->s->views[0], c->s->nviews, &di, &dj))
        rc = mf_fail(MF_EFORMAT, "%s: %sframes[%d] and %sframes[%d] both name the output '%s' (their files would overwrite each other: give them distinct file_path base names)",
                     file, prefix, di, prefix, dj, c->s->views[di].name);
    mf_transforms_free(&tf);
    if (own) cJSON_Delete(own);
    return rc;
}

static int parse_render(Ctx *c, const cJSON *root) {
    MfSceneRender *r = &c->s->render;
    r->spp_sqrt = 8;
    r->pixel_samples = 4;
    r->seed = 0;
    r->lobes = 3;
    const cJSON *o = cJSON_GetObjectItemCaseSensitive(root, "render");
    if (!o || cJSON_IsNull(o)) return MF_OK;
    if (!cJSON_IsObject(o)) return mf_fail(MF_EFORMAT, "%s: render: expected an object", c->file);
    double a, b, s;
    const char *lobes;
    int rc = mf_json_number_opt(c->file, "render", o, "spp_sqrt", 8, &a);
    if (!rc) rc = mf_json_number_opt(c->file, "render", o, "pixel_samples", 4, &b);
    if (!rc) rc = mf_json_number_opt(c->file, "render", o, "seed", 0, &s);
    if (!rc) rc = mf_json_string_opt(c->file, "render", o, "lobes", "all", &lobes);
    if (rc) return rc;
    /* the same limits as every command's --spp and --pixel-samples (mf_opts.h) */
    if (a < 1 || a > MF_OPT_SPP_MAX || a != floor(a))
        return mf_fail(MF_EFORMAT, "%s: render.spp_sqrt: expected an integer in [1, %d]", c->file, MF_OPT_SPP_MAX);
    if (b < 1 || b > MF_OPT_PIXEL_SAMPLES_MAX || b != floor(b))
        return mf_fail(MF_EFORMAT, "%s: render.pixel_samples: expected an integer in [1, %d]", c->file, MF_OPT_PIXEL_SAMPLES_MAX);
    /* 2^64 and above do not convert to the unsigned 64-bit seed (undefined behaviour, found by fuzz_scene) */
    if (s < 0 || s != floor(s) || s >= 18446744073709551616.0)
        return mf_fail(MF_EFORMAT, "%s: render.seed: expected a non-negative integer below 2^64", c->file);
    int l = mf_lobes_parse(lobes);
    if (l < 0) return mf_fail(MF_EFORMAT, "%s: render.lobes: '%s' is not all, diffuse or specular", c->file, lobes);
    r->spp_sqrt = (int)a;
    r->pixel_samples = (int)b;
    r->seed = (unsigned long long)s;
    r->lobes = l;
    return MF_OK;
}

static int parse_size(Ctx *c, const cJSON *root) {
    double w, h;
    int rc = mf_json_number_opt(c->file, "", root, "width", 256, &w);
    if (!rc) rc = mf_json_number_opt(c->file, "", root, "height", 256, &h);
    if (rc) return rc;
    if (w < 1 || h < 1 || w > 65536 || h > 65536 || w != floor(w) || h != floor(h))
        return mf_fail(MF_EFORMAT, "%s: width/height: expected integers in [1, 65536]", c->file);
    c->s->width = (int)w;
    c->s->height = (int)h;
    return MF_OK;
}

/* The materials of a glTF mesh (gltf: its asset, images moved into the scene), used when the scene
 * file names none. */
static int gltf_materials(Ctx *c, MfGltfAsset *gltf) {
    MfScene *s = c->s;
    for (int i = 0; i < s->nmat && i < gltf->nmat; ++i) {
        int rc = push_image(c, gltf->mats[i].albedo, &s->mats[i].kd);
        memset(&gltf->mats[i].albedo, 0, sizeof(MfImage));
        if (!rc) rc = push_image(c, gltf->mats[i].orm, &s->mats[i].orm);
        memset(&gltf->mats[i].orm, 0, sizeof(MfImage));
        if (!rc && gltf->mats[i].has_normal) rc = push_image(c, gltf->mats[i].normal, &s->mats[i].normal);
        memset(&gltf->mats[i].normal, 0, sizeof(MfImage)), gltf->mats[i].has_normal = 0;
        if (rc) return rc;
    }
    return MF_OK;
}

static int parse_materials(Ctx *c, const cJSON *root, MfGltfAsset *gltf) {
    MfScene *s = c->s;
    s->nmat = s->mesh.nmat > 0 ? s->mesh.nmat : 1;
    s->mats = calloc((size_t)s->nmat, sizeof *s->mats);
    if (!s->mats) return mf_fail(MF_ENOMEM, "%s: out of memory", c->file);
    MfSceneMaterial dflt = {NULL, NULL, mf_v3s(0.8f), mf_v3(0.0f, 0.5f, 0.0f), NULL};
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(root, "material");
    int rc;
    if (gltf && (!m || cJSON_IsNull(m)) && !cJSON_GetObjectItemCaseSensitive(root, "materials")) return gltf_materials(c, gltf);
    if (m && !cJSON_IsNull(m) && (rc = parse_material(c, "material", m, &dflt))) return rc;
    for (int i = 0; i < s->nmat; ++i) s->mats[i] = dflt;
    const cJSON *mm = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (!mm || cJSON_IsNull(mm)) return MF_OK;
    if (!cJSON_IsObject(mm)) return mf_fail(MF_EFORMAT, "%s: materials: expected an object keyed by OBJ material name", c->file);
    for (const cJSON *e = mm->child; e; e = e->next) {
        char w[256];
        snprintf(w, sizeof w, "materials.%s", e->string);
        int id = -1;
        for (int i = 0; i < s->mesh.nmat && s->mesh.mat_names; ++i)
            if (s->mesh.mat_names[i] && !strcmp(s->mesh.mat_names[i], e->string)) id = i;
        if (id < 0) return mf_fail(MF_EFORMAT, "%s: %s: the mesh has no material of that name", c->file, w);
        if ((rc = parse_material(c, w, e, &s->mats[id]))) return rc;
    }
    return MF_OK;
}

int mf_scene_load(const char *path, MfScene *out) {
    MfScene s;
    memset(&s, 0, sizeof s);
    Ctx c = {&s, path, 0};
    cJSON *root = NULL;
    int rc = mf_json_load(path, &root);
    if (rc) return rc;
    s.path = strdup(path);
    if (!s.path) rc = mf_fail(MF_ENOMEM, "out of memory");
    if (!rc && !cJSON_IsObject(root)) rc = mf_fail(MF_EFORMAT, "%s: expected a JSON object at the top level", path);
    const char *mesh_rel = NULL;
    MfGltfAsset gltf = {0};
    int is_gltf = 0;
    if (!rc) rc = mf_json_string(path, "", root, "mesh", &mesh_rel);
    if (!rc) rc = parse_size(&c, root);
    if (!rc) rc = parse_render(&c, root);
    if (!rc) rc = parse_cameras(&c, root);
    if (!rc) rc = parse_lights(&c, root);
    if (!rc) {
        char p[MF_PATH_MAX];
        rc = resolve(path, mesh_rel, p, sizeof p);
        if (!rc && mf_is_gltf_path(p)) {
            if ((rc = mf_gltf_read(p, &gltf))) rc = mf_fail_prefix(rc, "%s: mesh", path);
            else s.mesh = gltf.mesh, memset(&gltf.mesh, 0, sizeof gltf.mesh), is_gltf = 1;
        } else if (!rc && (rc = mf_obj_read(p, &s.mesh))) {
            rc = mf_fail_prefix(rc, "%s: mesh", path);
        }
        if (!rc && s.mesh.nt == 0) rc = mf_fail(MF_EFORMAT, "%s: mesh: %s has no triangles", path, p);
    }
    if (!rc) rc = parse_materials(&c, root, is_gltf ? &gltf : NULL);
    mf_gltf_asset_free(&gltf);
    if (!rc) rc = parse_env(&c, cJSON_GetObjectItemCaseSensitive(root, "env"));
    cJSON_Delete(root);
    if (rc) {
        mf_scene_free(&s);
        return rc;
    }
    /* Resolve texture indices (stored as index + 1) into pointers now that images stopped moving. */
    for (int i = 0; i < s.nmat; ++i) {
        if (s.mats[i].kd) s.mats[i].kd = &s.images[(intptr_t)s.mats[i].kd - 1];
        if (s.mats[i].orm) s.mats[i].orm = &s.images[(intptr_t)s.mats[i].orm - 1];
        if (s.mats[i].normal) s.mats[i].normal = &s.images[(intptr_t)s.mats[i].normal - 1];
    }
    *out = s;
    return MF_OK;
}

void mf_scene_free(MfScene *s) {
    if (!s) return;
    free(s->path);
    mf_mesh_free(&s->mesh);
    for (int i = 0; i < s->nimages; ++i) mf_image_free(&s->images[i]);
    free(s->images);
    free(s->mats);
    if (s->has_env) mf_env_free(&s->env);
    free(s->lights);
    free(s->views);
    memset(s, 0, sizeof *s);
}

int mf_scene_camera(const MfScene *s, int k, int w, int h, MfCamera *cam) {
    if (k < 0 || k >= s->nviews) return mf_fail(MF_EARG, "%s: no view %d", s->path, k);
    char what[256];
    snprintf(what, sizeof what, "%s: view %s", s->path, s->views[k].name);
    return mf_camera_init(cam, w > 0 ? w : s->width, h > 0 ? h : s->height, s->views[k].camera_angle_x, s->views[k].c2w, what);
}
