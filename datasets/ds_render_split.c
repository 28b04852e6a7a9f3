/* Rendering of a split written by ds_write_split (see ds_split.h): in-process with mf_render or,
 * for specs with povray = 1, with POV-Ray (ds_povray.h), or with cycles = 1, with Blender Cycles
 * (ds_cycles.h); and the per-split manifest. */
#include <cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "datasets/ds_cycles.h"
#include "datasets/ds_povray.h"
#include "datasets/ds_split.h"
#include "io/mf_exr.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"
#include "render/mf_integrator.h"
#include "scene/mf_transforms.h"

typedef struct {
    MfMesh mesh;
    MfImage kd, orm;     /* (res, res, 3) linear */
    MfImage normal;      /* gt/normal.png (linear, tangent space; assets only), or data NULL */
    MfRtScene *rt;
    MfTexMaterial mat;
    double angle_x;
    MfMat4 *train, *test; /* (n_train,), (n_test,) c2w */
    int n_train, n_test;
} Scene;

static void scene_free(Scene *sc) {
    if (sc->rt) mf_rtscene_free(sc->rt);
    mf_mesh_free(&sc->mesh);
    mf_image_free(&sc->kd);
    mf_image_free(&sc->orm);
    mf_image_free(&sc->normal);
    free(sc->train);
    free(sc->test);
    memset(sc, 0, sizeof *sc);
}

static int read_cams(const char *sdir, const char *split, double *angle_x, MfMat4 **c2w, int *n) {
    char p[MF_PATH_MAX], f[64];
    snprintf(f, sizeof f, "transforms_%s.json", split);
    MfTransforms tf;
    int rc = mf_path_join(p, sizeof p, sdir, f);
    if (rc || (rc = mf_transforms_load(p, 0, &tf))) return rc;
    *c2w = malloc(sizeof(MfMat4) * (size_t)(tf.n ? tf.n : 1));
    if (!*c2w) rc = mf_fail(MF_ENOMEM, "out of memory");
    for (int i = 0; i < tf.n && !rc; ++i)
        for (int e = 0; e < 16; ++e) (*c2w)[i].m[e] = (float)tf.frames[i].c2w[e];
    *angle_x = tf.camera_angle_x, *n = tf.n;
    mf_transforms_free(&tf);
    return rc;
}

static int scene_load(Scene *sc, const char *sdir) {
    memset(sc, 0, sizeof *sc);
    char p[MF_PATH_MAX];
    int rc;
    if ((rc = mf_path_join(p, sizeof p, sdir, "mesh.obj")) || (rc = mf_obj_read(p, &sc->mesh))) goto fail;
    if ((rc = mf_path_join(p, sizeof p, sdir, "gt/kd.png")) || (rc = mf_image_read(p, MF_ENC_SRGB, &sc->kd))) goto fail;
    if ((rc = mf_path_join(p, sizeof p, sdir, "gt/orm.png")) || (rc = mf_image_read(p, MF_ENC_LINEAR, &sc->orm))) goto fail;
    /* an asset's normal map: the renderer's normal-map path, as mf relight / mf eval use a result's normal.png */
    if ((rc = mf_path_join(p, sizeof p, sdir, "gt/normal.png"))) goto fail;
    if (mf_file_exists(p)) {
        if ((rc = mf_image_read(p, MF_ENC_LINEAR, &sc->normal))) goto fail;
        if (sc->normal.c < 3) { rc = mf_fail(MF_EFORMAT, "%s: needs 3 channels", p); goto fail; }
        if (!sc->mesh.uv) { rc = mf_fail(MF_EFORMAT, "%s: a normal map needs a mesh with UVs", p); goto fail; }
        sc->mat.normal = &sc->normal;
    }
    if ((rc = mf_rtscene_new(&sc->mesh, &sc->rt))) goto fail;
    if ((rc = read_cams(sdir, "train", &sc->angle_x, &sc->train, &sc->n_train)) || (rc = read_cams(sdir, "test", &sc->angle_x, &sc->test, &sc->n_test)))
        goto fail;
    sc->mat.kd = &sc->kd;
    sc->mat.orm = &sc->orm;
    return MF_OK;
fail:
    scene_free(sc);
    return rc;
}

static int write_rgba(const char *path, const float *rgb, int rgb_stride, const float *alpha, int alpha_stride, int n_px, int w, int h,
                      int premult, MfEncoding enc, int bits) {
    (void)n_px;
    MfImage img;
    int rc = mf_mkdirs_for(path);
    if (!rc) rc = mf_image_alloc(&img, w, h, 4);
    if (rc) return rc;
    for (int i = 0; i < w * h; ++i) {
        float a = alpha[(size_t)i * alpha_stride], s = (premult && a > 0) ? 1.0f / a : 1.0f;
        for (int c = 0; c < 3; ++c) img.data[4 * i + c] = a > 0 ? rgb[(size_t)i * rgb_stride + c] * s : 0.0f;
        img.data[4 * i + 3] = a;
    }
    /* EXR through OpenEXRCore (no time stamp in the header: the same pixels give the same bytes) */
    rc = bits == 32 ? mf_exr_write_image(path, &img, "", MF_EXR_FLOAT) : mf_image_write(path, &img, enc, bits);
    mf_image_free(&img);
    return rc;
}

typedef struct {
    const DsSplitSpec *s;
    const char *sdir;
    Scene *sc;
    uint64_t seed;
    MfProgress *prog;
    int rendered;
} Ctx;

/* The file that marks view i of a set done (kind as render_set's): the lit training PNG, the
 * test set's GT ORM (written last of its three), or the relit EXR. */
static void view_file(char *rel, size_t cap, int kind, const char *env_name, int i) {
    if (kind == 0) snprintf(rel, cap, "train/r_%03d.png", i);
    else if (kind == 1) snprintf(rel, cap, "gt/orm/r_%03d.png", i);
    else snprintf(rel, cap, "relight/%s/r_%03d.exr", env_name, i);
}

/* A lit view of kind 0 (training PNG, 8-bit sRGB, straight alpha) or 2 (relit EXR, linear float,
 * premultiplied) from premultiplied rgb and alpha with the given strides. */
static int write_lit(const char *path, int kind, const float *rgb, int rs, const float *alpha, int as, int width) {
    return kind == 2 ? write_rgba(path, rgb, rs, alpha, as, 0, width, width, 0, MF_ENC_LINEAR, 32)
                     : write_rgba(path, rgb, rs, alpha, as, 0, width, width, 1, MF_ENC_SRGB, 8);
}

/* One lighting condition: views of a camera set, outputs per view. kind: 0 train PNG,
 * 1 test PNG + GT albedo/ORM, 2 relit EXR into relight/<env>/. */
static int render_set(Ctx *c, const char *env_rel, const char *env_name, int kind) {
    const DsSplitSpec *s = c->s;
    Scene *sc = c->sc;
    int n = kind == 0 ? sc->n_train : sc->n_test;
    const MfMat4 *cams = kind == 0 ? sc->train : sc->test;
    char p[MF_PATH_MAX], rel[512];
    /* which views are missing */
    int missing = 0;
    for (int i = 0; i < n; ++i) {
        view_file(rel, sizeof rel, kind, env_name, i);
        if (mf_path_join(p, sizeof p, c->sdir, rel) || !mf_file_exists(p)) ++missing;
    }
    if (!missing) {
        mf_progress_add(c->prog, (size_t)n);
        return MF_OK;
    }
    MfEnvMap env = {0};
    MfImage env_img = {0};
    int rc, cyc = s->cycles && kind != 1; /* Cycles: every missing view of the set in one Blender run after the loop */
    DsCyclesJob job = {0};
    if ((rc = mf_path_join(p, sizeof p, c->sdir, env_rel))) return rc;
    if (s->povray) {
        if ((rc = mf_image_read(p, MF_ENC_LINEAR, &env_img))) return rc;
    }
    if ((rc = mf_env_load(&env, p))) {
        mf_image_free(&env_img);
        return rc;
    }
    char pdir[MF_PATH_MAX];
    DsPovScene ps = {&sc->mesh, &sc->kd, {0.5f, 0.5f, 0.5f}, &env_img, NULL, 0, s->pov_radiosity > 0 ? s->pov_radiosity : DS_SPLIT_POV_RADIOSITY, 0, 1};
    if ((s->povray || cyc) && sc->normal.data && kind != 1)
        mf_log_warn("%s: %s's lit views ignore gt/normal.png (our AOVs use it)", c->sdir, cyc ? "Cycles" : "POV-Ray");
    if (s->povray) {
        snprintf(rel, sizeof rel, ".povray/%s", env_name);
        if (!(rc = mf_path_join(pdir, sizeof pdir, c->sdir, rel)) && !(rc = mf_mkdirs(pdir))) rc = ds_povray_export_assets(&ps, pdir);
    }
    if (cyc) {
        snprintf(rel, sizeof rel, ".cycles/%s", env_name);
        if (!(rc = mf_path_join(pdir, sizeof pdir, c->sdir, rel))) rc = ds_cycles_begin(&job, pdir, &sc->mesh, &sc->kd, &sc->orm, s->width);
    }
    MfRenderInput in = {sc->rt, &sc->mesh, &sc->mat, 1, &env, NULL, 0};
    MfRenderOut ro = {0};
    for (int i = 0; i < n && !rc; ++i) {
        view_file(rel, sizeof rel, kind, env_name, i);
        if ((rc = mf_path_join(p, sizeof p, c->sdir, rel))) break;
        if (mf_file_exists(p)) { mf_progress_add(c->prog, 1); continue; }
        MfCamera cam;
        double m[16];
        for (int k = 0; k < 16; ++k) m[k] = cams[i].m[k];
        if ((rc = mf_camera_init(&cam, s->width, s->width, sc->angle_x, m, rel))) break;
        if (cyc) { /* the image comes after the Blender run */
            snprintf(rel, sizeof rel, "r_%03d", i);
            rc = ds_cycles_add_view(&job, rel, m, sc->angle_x, &env.img, NULL, 0);
            mf_progress_add(c->prog, 1);
            continue;
        }
        /* our render: the lit image (unless POV-Ray makes it) and the AOVs */
        int need_ours = !s->povray || kind == 1;
        if (need_ours) {
            MfRenderOpts o = {.spp_sqrt = s->spp_sqrt, .pixel_samples = s->pixel_samples > 0 ? s->pixel_samples : 4, .seed = mf_hash64(c->seed, (uint64_t)(kind * 100000 + i)), .lobes = MF_LOBE_ALL};
            if (kind == 2) o.seed = mf_hash64(o.seed, mf_fnv1a64(MF_FNV64_INIT, env_name, strlen(env_name)));
            if ((rc = mf_render(&in, &cam, &o, &ro, NULL))) break;
        }
        MfImage pov = {0};
        if (s->povray && kind != 1) {
            char vname[32];
            snprintf(vname, sizeof vname, "v%03d_%d", i, kind);
            if ((rc = ds_povray_write_view(&ps, &cam, pdir, vname)) || (rc = ds_povray_run(pdir, vname, s->width, s->width, 1, &pov))) break;
            const char *ext[3] = {"pov", "log", "exr"};
            for (int e = 0; e < 3; ++e) {
                char f[64], fp[MF_PATH_MAX];
                snprintf(f, sizeof f, "%s.%s", vname, ext[e]);
                if (!mf_path_join(fp, sizeof fp, pdir, f)) unlink(fp);
            }
        }
        const float *rgb = s->povray && kind != 1 ? pov.data : ro.rgb, *alpha = s->povray && kind != 1 ? pov.data + 3 : ro.alpha;
        int rs = s->povray && kind != 1 ? 4 : 3, as = s->povray && kind != 1 ? 4 : 1;
        if (kind != 1) {
            rc = write_lit(p, kind, rgb, rs, alpha, as, s->width);
        } else {
            char q[MF_PATH_MAX];
            snprintf(rel, sizeof rel, "test/r_%03d.png", i);
            if (!(rc = mf_path_join(q, sizeof q, c->sdir, rel))) rc = write_rgba(q, rgb, rs, alpha, as, 0, s->width, s->width, 1, MF_ENC_SRGB, 8);
            snprintf(rel, sizeof rel, "gt/albedo/r_%03d.png", i);
            if (!rc && !(rc = mf_path_join(q, sizeof q, c->sdir, rel)))
                rc = write_rgba(q, ro.albedo, 3, ro.alpha, 1, 0, s->width, s->width, 0, MF_ENC_SRGB, 8);
            if (!rc) rc = write_rgba(p, ro.orm, 3, ro.alpha, 1, 0, s->width, s->width, 0, MF_ENC_LINEAR, 8);
        }
        mf_image_free(&pov);
        mf_render_out_free(&ro);
        if (!rc) ++c->rendered;
        mf_progress_add(c->prog, 1);
    }
    if (cyc && !rc) rc = ds_cycles_run(&job);
    for (int i = 0; cyc && i < n && !rc; ++i) {
        view_file(rel, sizeof rel, kind, env_name, i);
        if ((rc = mf_path_join(p, sizeof p, c->sdir, rel)) || mf_file_exists(p)) continue;
        char vname[32];
        snprintf(vname, sizeof vname, "r_%03d", i);
        MfImage cimg = {0}; /* (width, width, 4) linear, premultiplied */
        if (!(rc = ds_cycles_read(&job, vname, &cimg))) rc = write_lit(p, kind, cimg.data, 4, cimg.data + 3, 4, s->width);
        mf_image_free(&cimg);
        if (!rc) ++c->rendered;
    }
    if (cyc) ds_cycles_end(&job, rc != 0); /* a failed run keeps blender.log */
    mf_render_out_free(&ro);
    mf_env_free(&env);
    mf_image_free(&env_img);
    return rc;
}

/* out_dir/split.json (its path into p, cap MF_PATH_MAX) loaded into *list (the caller deletes it)
 * and its "scenes" array into *scenes, *ns; on failure nothing is left to free. */
static int split_scenes(const char *out_dir, char *p, cJSON **list, const cJSON **scenes, int *ns) {
    *list = NULL;
    int rc = mf_path_join(p, MF_PATH_MAX, out_dir, "split.json");
    if (rc || (rc = mf_json_load(p, list))) return rc;
    if ((rc = mf_json_array(p, "", *list, "scenes", scenes, ns))) {
        cJSON_Delete(*list);
        *list = NULL;
    }
    return rc;
}

int ds_render_split(const DsSplitSpec *s, const char *out_dir, int *rendered) {
    char p[MF_PATH_MAX];
    cJSON *list;
    const cJSON *scenes;
    int ns = 0, rc = split_scenes(out_dir, p, &list, &scenes, &ns);
    if (rc) return rc;
    MfProgress prog;
    mf_progress_begin(&prog, s->name, (size_t)ns * (size_t)(s->n_train + s->n_test * (1 + s->n_relight)));
    int total = 0;
    for (int k = 0; k < ns && !rc; ++k) {
        const cJSON *jsc = cJSON_GetArrayItem(scenes, k), *rl = cJSON_GetObjectItem(jsc, "relight");
        const cJSON *jn = cJSON_GetObjectItem(jsc, "name"), *js = cJSON_GetObjectItem(jsc, "object_seed");
        if (!cJSON_IsString(jn) || !cJSON_IsString(js) || !cJSON_IsArray(rl)) { rc = mf_fail(MF_EFORMAT, "%s: scenes[%d]: name/object_seed/relight missing", p, k); break; }
        char sdir[MF_PATH_MAX], marker[MF_PATH_MAX];
        if ((rc = mf_path_join(sdir, sizeof sdir, out_dir, jn->valuestring)) || (rc = mf_path_join(marker, sizeof marker, sdir, ".rendered"))) break;
        /* the marker lists the relighting lights it covers: a split regenerated with more lights
         * renders only the views that are missing */
        char done[1024] = "ok", *have = NULL;
        size_t have_len = 0;
        for (int r = 0; r < cJSON_GetArraySize(rl); ++r) {
            const cJSON *e = cJSON_GetArrayItem(rl, r);
            size_t l = strlen(done);
            snprintf(done + l, sizeof done - l, " %s", cJSON_IsString(e) ? e->valuestring : "?");
        }
        strncat(done, "\n", sizeof done - strlen(done) - 1);
        int complete = mf_file_exists(marker) && !mf_read_file(marker, &have, &have_len) && have_len == strlen(done) &&
                       !memcmp(have, done, have_len);
        free(have);
        if (complete) {
            mf_progress_add(&prog, (size_t)(s->n_train + s->n_test * (1 + s->n_relight)));
            continue;
        }
        Scene sc;
        if ((rc = scene_load(&sc, sdir))) break;
        Ctx c = {s, sdir, &sc, strtoull(js->valuestring, NULL, 10), &prog, 0};
        rc = render_set(&c, "gt/env.exr", "train", 0);
        if (!rc) rc = render_set(&c, "gt/env.exr", "test", 1);
        for (int r = 0; r < cJSON_GetArraySize(rl) && !rc; ++r) {
            const char *en = cJSON_GetArrayItem(rl, r)->valuestring;
            char rel[400];
            snprintf(rel, sizeof rel, "relight/%s.exr", en);
            rc = render_set(&c, rel, en, 2);
        }
        total += c.rendered;
        scene_free(&sc);
        if (!rc) rc = mf_write_file(marker, done, strlen(done));
    }
    mf_progress_end(&prog);
    cJSON_Delete(list);
    if (rendered) *rendered = total;
    return rc;
}

/* ---- NeRF-Synthetic layout ---- */

int ds_split_nerf_layout(const char *out_dir) {
    static const char *const keep[] = {"transforms_train.json", "transforms_test.json", "train", "test"};
    char p[MF_PATH_MAX];
    cJSON *list;
    const cJSON *scenes;
    int ns = 0, rc = split_scenes(out_dir, p, &list, &scenes, &ns);
    if (rc) return rc;
    for (int k = 0; k < ns && !rc; ++k) {
        const cJSON *jn = cJSON_GetObjectItem(cJSON_GetArrayItem(scenes, k), "name");
        char sdir[MF_PATH_MAX];
        if (!cJSON_IsString(jn)) { rc = mf_fail(MF_EFORMAT, "%s: scenes[%d]: name missing", p, k); break; }
        if ((rc = mf_path_join(sdir, sizeof sdir, out_dir, jn->valuestring))) break;
        DIR *d = opendir(sdir);
        if (!d) { rc = mf_fail(MF_EIO, "%s: cannot open the scene folder", sdir); break; }
        struct dirent *e;
        while (!rc && (e = readdir(d))) {
            int kept = !strcmp(e->d_name, ".") || !strcmp(e->d_name, "..");
            for (size_t i = 0; i < sizeof keep / sizeof keep[0] && !kept; ++i) kept = !strcmp(e->d_name, keep[i]);
            char f[MF_PATH_MAX];
            if (!kept && !(rc = mf_path_join(f, sizeof f, sdir, e->d_name))) rc = mf_remove_tree(f);
        }
        closedir(d);
    }
    cJSON_Delete(list);
    return rc;
}

/* ---- manifest ---- */

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Adds "rel": "fnv hex" for every regular file under dir/rel (names starting with '.' and the
 * top-level manifest.json skipped), in sorted order. */
static int hash_tree(const char *root, const char *rel, cJSON *files, int *nfiles) {
    char dir[MF_PATH_MAX];
    int rc = rel[0] ? mf_path_join(dir, sizeof dir, root, rel) : (snprintf(dir, sizeof dir, "%s", root), 0);
    if (rc) return rc;
    DIR *d = opendir(dir);
    if (!d) return mf_fail(MF_EIO, "%s: cannot open the folder", dir);
    char **names = NULL;
    int n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        if (!rel[0] && !strcmp(e->d_name, "manifest.json")) continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 32;
            char **nn = realloc(names, sizeof(char *) * (size_t)cap);
            if (!nn) { rc = mf_fail(MF_ENOMEM, "out of memory"); break; }
            names = nn;
        }
        if (!(names[n] = strdup(e->d_name))) { rc = mf_fail(MF_ENOMEM, "out of memory"); break; }
        ++n;
    }
    closedir(d);
    if (n) qsort(names, (size_t)n, sizeof(char *), cmp_str);
    for (int i = 0; i < n && !rc; ++i) {
        char r2[MF_PATH_MAX], full[MF_PATH_MAX];
        if (rel[0]) snprintf(r2, sizeof r2, "%s/%s", rel, names[i]);
        else snprintf(r2, sizeof r2, "%s", names[i]);
        if ((rc = mf_path_join(full, sizeof full, root, r2))) break;
        struct stat st;
        if (stat(full, &st)) { rc = mf_fail(MF_EIO, "%s: cannot stat", full); break; }
        if (S_ISDIR(st.st_mode)) rc = hash_tree(root, r2, files, nfiles);
        else if (S_ISREG(st.st_mode)) {
            char *data = NULL;
            size_t len = 0;
            if ((rc = mf_read_file(full, &data, &len))) break;
            char hx[24];
            snprintf(hx, sizeof hx, "%016llx", (unsigned long long)mf_fnv1a64(MF_FNV64_INIT, data, len));
            free(data);
            cJSON_AddStringToObject(files, r2, hx);
            ++*nfiles;
        }
    }
    for (int i = 0; i < n; ++i) free(names[i]);
    free(names);
    return rc;
}

int ds_split_manifest(const DsSplitSpec *s, const char *out_dir, uint64_t seed, int rendered, int views_rendered, double wall_s) {
    cJSON *r = cJSON_CreateObject(), *files = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "split", s->name);
    cJSON_AddNumberToObject(r, "seed", (double)seed);
    cJSON_AddStringToObject(r, "object_seeds", "ds_object_seed(DS_STREAM_TEST, seed, k) (datasets/ds_gen.h); listed in split.json");
    cJSON_AddNumberToObject(r, "scenes", s->n_scenes);
    cJSON_AddNumberToObject(r, "resolution", s->width);
    cJSON_AddNumberToObject(r, "train_views", s->n_train);
    cJSON_AddNumberToObject(r, "test_views", s->n_test);
    cJSON_AddNumberToObject(r, "relight_lights", s->n_relight);
    cJSON_AddNumberToObject(r, "tex_res", s->tex_res);
    cJSON_AddNumberToObject(r, "spp_sqrt", s->spp_sqrt);
    cJSON_AddNumberToObject(r, "pixel_samples", s->pixel_samples > 0 ? s->pixel_samples : 4);
    cJSON_AddBoolToObject(r, "diffuse", s->diffuse);
    if (s->nerf_layout) cJSON_AddStringToObject(r, "layout", "nerf-synthetic (transforms_{train,test}.json, train/, test/; no mesh, no ground truth)");
    cJSON_AddStringToObject(r, "renderer", !rendered ? "none (layout only; render with mf render or --render)" : s->povray ? "povray (lit views), mf (GT albedo/ORM AOVs)" : s->cycles ? "blender cycles (train and relit views), mf (test views under the training light, GT albedo/ORM AOVs)" : "mf");
    cJSON_AddNumberToObject(r, "views_rendered_this_run", views_rendered);
    cJSON_AddNumberToObject(r, "wall_time_s", wall_s);
    cJSON_AddNumberToObject(r, "views_per_s", wall_s > 0 ? views_rendered / wall_s : 0.0);
    cJSON_AddStringToObject(r, "checksum", "fnv1a64");
    int nf = 0;
    int rc = hash_tree(out_dir, "", files, &nf);
    cJSON_AddNumberToObject(r, "file_count", nf);
    cJSON_AddItemToObject(r, "files", files);
    char p[MF_PATH_MAX];
    if (!rc && !(rc = mf_path_join(p, sizeof p, out_dir, "manifest.json"))) rc = mf_json_save(p, r);
    cJSON_Delete(r);
    return rc;
}

/* ---- our renderer vs POV-Ray ---- */

static void accumulate(const float *a, int as, const float *aa, int aas, const float *b, int bs, const float *ba, int bas, int npx, DsRenderCompareStat *c) {
    double se = 0, num = 0, den = 0;
    int n = 0;
    for (int i = 0; i < npx; ++i) {
        float wa = aa[(size_t)i * aas], wb = ba[(size_t)i * bas];
        if (wa < 0.5f && wb < 0.5f) continue; /* background in both */
        for (int k = 0; k < 3; ++k) {
            float x = a[(size_t)i * as + k], y = b[(size_t)i * bs + k]; /* premultiplied linear */
            float xs = mf_linear_to_srgb(x < 0 ? 0 : x > 1 ? 1 : x), ys = mf_linear_to_srgb(y < 0 ? 0 : y > 1 ? 1 : y);
            se += (double)(xs - ys) * (xs - ys);
            num += fabs((double)x - y);
            den += fabs((double)y);
        }
        ++n;
    }
    if (!n) return;
    double mse = se / (3.0 * n);
    mf_log_debug("compare: %d px, PSNR %.2f dB, rel %.4f (sum|pov| %.4g)", n, 10.0 * log10(1.0 / (mse > 1e-12 ? mse : 1e-12)), den > 0 ? num / den : 0.0, den);
    c->se += se;
    c->n_px += n;
    c->rel_num += num;
    c->rel_den += den;
    c->n_views += 1;
}

int ds_compare_renderers(const DsSplitSpec *spec, const char *out_dir, int max_scenes, int max_views, int res, DsRenderCompare *out) {
    memset(out, 0, sizeof *out);
    char p[MF_PATH_MAX];
    cJSON *list;
    const cJSON *scenes;
    int ns = 0, rc = split_scenes(out_dir, p, &list, &scenes, &ns);
    if (rc) return rc;
    if (max_scenes > 0 && ns > max_scenes) ns = max_scenes;
    double t_ours = 0, t_pov = 0;
    for (int k = 0; k < ns && !rc; ++k) {
        const cJSON *jsc = cJSON_GetArrayItem(scenes, k), *rl = cJSON_GetObjectItem(jsc, "relight");
        const cJSON *jn = cJSON_GetObjectItem(jsc, "name");
        if (!cJSON_IsString(jn) || !cJSON_IsArray(rl)) { rc = mf_fail(MF_EFORMAT, "%s: scenes[%d]: name/relight missing", p, k); break; }
        char sdir[MF_PATH_MAX], pdir[MF_PATH_MAX];
        Scene sc;
        if ((rc = mf_path_join(sdir, sizeof sdir, out_dir, jn->valuestring)) || (rc = scene_load(&sc, sdir))) break;
        /* the scene's metallic / roughness: diffuse-dominant when metallic 0 and roughness >= 0.6 everywhere */
        for (int r = 0; r < cJSON_GetArraySize(rl) && !rc; ++r) {
            const char *en = cJSON_GetArrayItem(rl, r)->valuestring;
            char rel[400];
            snprintf(rel, sizeof rel, "relight/%s.exr", en);
            MfEnvMap env = {0};
            MfImage env_img = {0};
            if ((rc = mf_path_join(p, sizeof p, sdir, rel)) || (rc = mf_image_read(p, MF_ENC_LINEAR, &env_img)) || (rc = mf_env_load(&env, p))) {
                mf_image_free(&env_img);
                break;
            }
            DsPovScene ps = {&sc.mesh, &sc.kd, {0.5f, 0.5f, 0.5f}, &env_img, NULL, 0, spec->pov_radiosity > 0 ? spec->pov_radiosity : DS_SPLIT_POV_RADIOSITY, 0, 1};
            snprintf(rel, sizeof rel, ".compare/%s", en);
            if (!(rc = mf_path_join(pdir, sizeof pdir, sdir, rel)) && !(rc = mf_mkdirs(pdir))) rc = ds_povray_export_assets(&ps, pdir);
            MfRenderInput in = {sc.rt, &sc.mesh, &sc.mat, 1, &env, NULL, 0};
            int nv = sc.n_test < max_views || max_views <= 0 ? sc.n_test : max_views;
            for (int i = 0; i < nv && !rc; ++i) {
                MfCamera cam;
                double m[16];
                for (int q = 0; q < 16; ++q) m[q] = sc.test[i].m[q];
                if ((rc = mf_camera_init(&cam, res, res, sc.angle_x, m, "compare camera"))) break;
                MfRenderOut ro = {0}, rd = {0};
                MfRenderOpts o = {.spp_sqrt = 4, .pixel_samples = 4, .seed = mf_hash64(77, (uint64_t)i), .lobes = MF_LOBE_ALL};
                double t0 = mf_now();
                rc = mf_render(&in, &cam, &o, &ro, NULL);
                t_ours += mf_now() - t0;
                o.lobes = MF_LOBE_DIFFUSE;
                if (!rc) rc = mf_render(&in, &cam, &o, &rd, NULL);
                MfImage pov = {0};
                char vname[32];
                snprintf(vname, sizeof vname, "v%03d", i);
                t0 = mf_now();
                if (!rc && !(rc = ds_povray_write_view(&ps, &cam, pdir, vname))) rc = ds_povray_run(pdir, vname, res, res, 1, &pov);
                t_pov += mf_now() - t0;
                if (!rc) {
                    accumulate(ro.rgb, 3, ro.alpha, 1, pov.data, 4, pov.data + 3, 4, res * res, &out->all);
                    accumulate(rd.rgb, 3, rd.alpha, 1, pov.data, 4, pov.data + 3, 4, res * res, &out->diffuse_lobe);
                }
                mf_image_free(&pov);
                mf_render_out_free(&ro);
                mf_render_out_free(&rd);
            }
            mf_env_free(&env);
            mf_image_free(&env_img);
        }
        scene_free(&sc);
    }
    cJSON_Delete(list);
    out->sec_ours = t_ours;
    out->sec_povray = t_pov;
    return rc;
}
