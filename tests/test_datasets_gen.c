/* Rendered splits (datasets/ds_gen.h): prior-train layout, determinism, resume, seed streams,
 * bad input. Tiny sizes: 16 px, 2 views per object, 32^2 textures, 1 sample. */
#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_gen.h"
#include "datasets/ds_split.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "mf_test.h"

static const char *gen_probes(void) {
    const char *dir = mf_test_path("gen_probes");
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/b_sky.exr", dir);
    if (mf_file_exists(p)) return dir;
    for (int i = 0; i < 3; ++i) {
        MfImage img;
        if (mf_image_alloc(&img, 32, 16, 3)) return dir;
        for (int y = 0; y < 16; ++y)
            for (int x = 0; x < 32; ++x) {
                float *px = mf_image_px(&img, x, y);
                px[0] = 0.3f + 0.2f * i + (x == 5 * (i + 1) && y == 4 ? 20.0f : 0.0f);
                px[1] = 0.4f + (y < 8 ? 0.3f : 0.0f);
                px[2] = 0.5f;
            }
        snprintf(p, sizeof p, "%s/%c_sky.exr", dir, 'a' + i);
        mf_mkdirs(dir);
        mf_image_write(p, &img, MF_ENC_LINEAR, 32);
        mf_image_free(&img);
    }
    return dir;
}

static DsPriorTrainOpts tiny_opts(int count) {
    DsPriorTrainOpts o = ds_prior_train_defaults();
    o.count = count;
    o.res = 16;
    o.views_per_object = 2;
    o.tex_res = 32;
    o.spp_sqrt = 1;
    o.pixel_samples = 1;
    o.seed = 5;
    o.env_dir = gen_probes();
    return o;
}

/* 1 when every file of a's manifest has the same bytes in b (and both list the same count). */
static int same_files(const char *a, const char *b, int expect_files) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/manifest.json", a);
    cJSON *ma = NULL;
    if (mf_json_load(p, &ma)) return 0;
    const cJSON *files = cJSON_GetObjectItem(ma, "files");
    int n = 0, ok = cJSON_GetArraySize(files) == expect_files;
    for (const cJSON *f = files ? files->child : NULL; f && ok; f = f->next, ++n) {
        char pa[MF_PATH_MAX], pb[MF_PATH_MAX], *da = NULL, *db = NULL;
        size_t la = 0, lb = 0;
        snprintf(pa, sizeof pa, "%s/%s", a, f->string);
        snprintf(pb, sizeof pb, "%s/%s", b, f->string);
        if (mf_read_file(pa, &da, &la) || mf_read_file(pb, &db, &lb)) ok = 0;
        else ok = la == lb && !memcmp(da, db, la);
        free(da);
        free(db);
    }
    cJSON_Delete(ma);
    return ok;
}

MF_TEST(ds_gen_prior_train_layout) {
    const char *out = mf_test_path("pt_a");
    DsPriorTrainOpts o = tiny_opts(4);
    DsGenStats st;
    CHECK_OK(ds_gen_prior_train(&o, out, &st));
    CHECK(st.objects == 2 && st.count == 4 && st.rendered_views == 4);
    cJSON *m = NULL;
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/manifest.json", out);
    CHECK_OK(mf_json_load(p, &m));
    if (m) {
        CHECK(!strcmp(cJSON_GetObjectItem(m, "split")->valuestring, "prior-train"));
        CHECK(cJSON_GetObjectItem(m, "resolution")->valueint == 16);
        CHECK(cJSON_GetObjectItem(m, "count")->valueint == 4);
        CHECK(cJSON_GetObjectItem(m, "seed")->valueint == 5);
        CHECK(cJSON_GetObjectItem(m, "objects")->valueint == 2);
        CHECK(cJSON_GetObjectItem(m, "views_per_s")->valuedouble > 0);
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(m, "files")) == 12);
    }
    cJSON_Delete(m);
    int covered = 0;
    for (int i = 0; i < 4; ++i) {
        MfImage rgb = {0}, alb = {0}, orm = {0};
        snprintf(p, sizeof p, "%s/rgb/%06d.png", out, i);
        CHECK_OK(mf_image_read(p, MF_ENC_SRGB, &rgb));
        snprintf(p, sizeof p, "%s/albedo/%06d.png", out, i);
        CHECK_OK(mf_image_read(p, MF_ENC_SRGB, &alb));
        snprintf(p, sizeof p, "%s/orm/%06d.png", out, i);
        CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &orm));
        CHECK(rgb.w == 16 && rgb.h == 16 && rgb.c == 4 && alb.c == 4 && orm.c == 4);
        if (rgb.c == 4 && alb.c == 4 && orm.c == 4) {
            for (int k = 0; k < 16 * 16; ++k) {
                float a = rgb.data[4 * k + 3];
                CHECK(a == alb.data[4 * k + 3] && a == orm.data[4 * k + 3]);
                if (a == 1.0f) {
                    ++covered;
                    CHECK_NEAR(orm.data[4 * k], 1.0, 1e-6); /* occlusion channel */
                }
                if (a == 0.0f) CHECK(alb.data[4 * k] == 0 && orm.data[4 * k + 1] == 0);
            }
        }
        mf_image_free(&rgb);
        mf_image_free(&alb);
        mf_image_free(&orm);
    }
    CHECK(covered > 4 * 16); /* the object is in view */
    /* one thread, another folder: the same bytes */
    const char *out1 = mf_test_path("pt_a1");
    o.threads = 1;
    CHECK_OK(ds_gen_prior_train(&o, out1, NULL));
    CHECK(same_files(out, out1, 12));
    /* another seed: different images */
    o.seed = 6;
    const char *out2 = mf_test_path("pt_a2");
    CHECK_OK(ds_gen_prior_train(&o, out2, NULL));
    CHECK(!same_files(out, out2, 12));
}

MF_TEST(ds_gen_prior_train_resume) {
    const char *full = mf_test_path("pt_full"), *part = mf_test_path("pt_part");
    DsPriorTrainOpts o = tiny_opts(6);
    CHECK_OK(ds_gen_prior_train(&o, full, NULL));
    /* interrupted by a count: 1 object, then continued */
    DsPriorTrainOpts o1 = tiny_opts(2);
    DsGenStats st;
    CHECK_OK(ds_gen_prior_train(&o1, part, &st));
    CHECK(st.objects == 1);
    /* a crash in object 1: half its files written, no marker; a stale temp file around */
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/rgb/000002.png", part);
    CHECK_OK(mf_write_file(p, "garbage", 7));
    CHECK_OK(ds_gen_prior_train(&o, part, &st));
    CHECK(st.objects == 3 && st.count == 6 && st.rendered_views == 4); /* object 0 skipped */
    CHECK(same_files(full, part, 18));
    /* a zero time budget renders nothing new and keeps what is there */
    o.count = 0;
    o.time_budget_s = 1e-9;
    CHECK_OK(ds_gen_prior_train(&o, part, &st));
    CHECK(st.rendered_views == 0 && st.objects == 3);
}

MF_TEST(ds_gen_seed_streams_disjoint) {
    /* prior-train and test-split object seeds never coincide: checked over many seeds/indices */
    enum { N = 4000 };
    static uint64_t a[N];
    for (int i = 0; i < N; ++i) a[i] = ds_object_seed(DS_STREAM_PRIOR, 1 + (uint64_t)(i % 4), (uint64_t)(i / 4));
    for (int s = 0; s < 8; ++s)
        for (int k = 0; k < 200; ++k) {
            uint64_t t = ds_object_seed(DS_STREAM_TEST, (uint64_t)s, (uint64_t)k), t2 = ds_object_seed(DS_STREAM_TEST2D, (uint64_t)s, (uint64_t)k);
            CHECK(t2 >> 60 == DS_STREAM_TEST2D);
            for (int i = 0; i < N; ++i) CHECK(a[i] != t && a[i] != t2);
        }
    for (int i = 0; i < N; ++i) CHECK(a[i] >> 60 == DS_STREAM_PRIOR);
    /* the test splits really use the test stream */
    DsSplitSpec s;
    CHECK_OK(ds_split_spec("tiny", &s));
    s.n_scenes = 1;
    s.tex_res = 16;
    const char *out = mf_test_path("seed_split");
    CHECK_OK(ds_write_split(&s, out, gen_probes(), 11));
    cJSON *list = NULL;
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/split.json", out);
    CHECK_OK(mf_json_load(p, &list));
    const cJSON *sc = list ? cJSON_GetArrayItem(cJSON_GetObjectItem(list, "scenes"), 0) : NULL;
    CHECK(sc != NULL);
    if (sc) {
        unsigned long long v = strtoull(cJSON_GetObjectItem(sc, "object_seed")->valuestring, NULL, 10);
        CHECK(v == ds_object_seed(DS_STREAM_TEST, 11, 0));
    }
    cJSON_Delete(list);
}

MF_TEST(ds_gen_bad_input) {
    DsPriorTrainOpts o = tiny_opts(2);
    const char *file = mf_test_path("pt_plain_file");
    CHECK_OK(mf_write_file(file, "x", 1));
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/sub", file);
    CHECK_ERR(ds_gen_prior_train(&o, p, NULL), "pt_plain_file");
    o.env_dir = mf_test_path("no_such_probes");
    CHECK_ERR(ds_gen_prior_train(&o, mf_test_path("pt_bad"), NULL), "no_such_probes");
    o = tiny_opts(0);
    CHECK_ERR(ds_gen_prior_train(&o, mf_test_path("pt_bad"), NULL), "count or a time budget");
    MF_NEED_BIN();
    char args[3 * MF_PATH_MAX], err[4096];
    snprintf(args, sizeof args, "gen --split nosuch -o '%s'", mf_test_path("pt_cli"));
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2);
    snprintf(args, sizeof args, "gen --split prior-train -o '%s/sub' --count 2 --res 16 --views 2 --tex-res 32 --env-dir '%s'", file,
             gen_probes());
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 1);
}

/* ---- rendered bvault splits (ds_render_split) ---- */
#include "datasets/ds_load.h"
#include "datasets/ds_povray.h"

static DsSplitSpec mini_spec(void) {
    DsSplitSpec s;
    ds_split_spec("tiny", &s);
    s.n_scenes = 1;
    s.width = 16;
    s.n_train = 3;
    s.n_test = 2;
    s.tex_res = 32;
    s.n_relight = 2;
    s.spp_sqrt = 1;
    s.pixel_samples = 1;
    return s;
}

static cJSON *manifest_files(const char *dir) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/manifest.json", dir);
    cJSON *m = NULL;
    if (mf_json_load(p, &m)) return NULL;
    cJSON *f = cJSON_DetachItemFromObject(m, "files");
    cJSON_Delete(m);
    return f;
}

MF_TEST(ds_render_split_layout_and_resume) {
    DsSplitSpec s = mini_spec();
    const char *a = mf_test_path("rs_a"), *b = mf_test_path("rs_b");
    int nv = 0;
    CHECK_OK(ds_write_split(&s, a, gen_probes(), 3));
    CHECK_OK(ds_render_split(&s, a, &nv));
    CHECK(nv == 3 + 2 + 2 * 2);
    CHECK_OK(ds_split_manifest(&s, a, 3, 1, nv, 1.0));
    /* the bvault loader reads it back, with GT and relighting */
    char scene[MF_PATH_MAX];
    snprintf(scene, sizeof scene, "%s/000_cup", a);
    CHECK(ds_detect_format(scene) == DS_FMT_BVAULT);
    DsLoadOptions lo = {1, 0, 1, 0, NULL, 0};
    DsViews v;
    CHECK_OK(ds_load_bvault(scene, "test", &lo, &v));
    if (!mf_test_failed_now()) {
        CHECK(v.n == 2 && v.w == 16 && v.n_relight == 2);
        CHECK(v.views[0].albedo.data != NULL && v.views[0].orm.data != NULL);
        MfImage rl = {0};
        CHECK_OK(ds_load_relit(&v, 1, 1, &rl));
        double cov = 0;
        for (int i = 0; rl.data && i < 16 * 16; ++i) cov += rl.data[4 * i + 3];
        CHECK(rl.w == 16 && cov > 5);
        mf_image_free(&rl);
        ds_views_free(&v);
    }
    /* interrupted run: the layout and one view set only, then a second run finishes it */
    CHECK_OK(ds_write_split(&s, b, gen_probes(), 3));
    CHECK_OK(ds_render_split(&s, b, &nv));
    char p[MF_PATH_MAX];
    /* an interrupted run leaves whole files only (atomic writes): remove some to simulate one */
    const char *del[] = {".rendered", "relight/a_sky/r_001.exr", "relight/b_sky/r_001.exr", "relight/c_sky/r_001.exr",
                         "test/r_000.png", "gt/orm/r_000.png", "train/r_002.png"};
    int deleted = 0;
    for (size_t i = 0; i < sizeof del / sizeof del[0]; ++i) {
        snprintf(p, sizeof p, "%s/000_cup/%s", b, del[i]);
        if (mf_file_exists(p) && !remove(p)) ++deleted;
    }
    CHECK(deleted == 6); /* two of the three probes relight */
    CHECK_OK(ds_render_split(&s, b, &nv));
    CHECK(nv == 4); /* only the missing views again: 2 relit, 1 test, 1 train */
    CHECK_OK(ds_split_manifest(&s, b, 3, 1, nv, 1.0));
    cJSON *fa = manifest_files(a), *fb = manifest_files(b);
    CHECK(fa && fb && cJSON_GetArraySize(fa) > 20);
    CHECK(fa && fb && cJSON_Compare(fa, fb, 1));
    cJSON_Delete(fa);
    cJSON_Delete(fb);
    /* manifest checksums are of the bytes on disk */
    fa = manifest_files(a);
    const cJSON *h = fa ? cJSON_GetObjectItem(fa, "000_cup/train/r_000.png") : NULL;
    CHECK(h && cJSON_IsString(h) && strlen(h->valuestring) == 16);
    cJSON_Delete(fa);
}

MF_TEST(ds_render_split_povray_diffuse) {
    if (!ds_povray_available()) MF_SKIP("povray not installed");
    DsSplitSpec s = mini_spec();
    s.diffuse = s.povray = 1;
    s.n_train = 1;
    s.n_test = 1;
    s.n_relight = 1;
    const char *a = mf_test_path("rs_pov");
    int nv = 0;
    CHECK_OK(ds_write_split(&s, a, gen_probes(), 4));
    CHECK_OK(ds_render_split(&s, a, &nv));
    CHECK(nv == 3);
    char p[MF_PATH_MAX];
    /* diffuse objects: GT ORM has metallic 0 and roughness >= 0.6 where covered */
    MfImage orm = {0}, rl = {0};
    snprintf(p, sizeof p, "%s/000_cup/gt/orm/r_000.png", a);
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &orm));
    int cov = 0;
    for (int i = 0; orm.data && i < orm.w * orm.h; ++i)
        if (orm.data[4 * i + 3] == 1.0f) {
            ++cov;
            CHECK(orm.data[4 * i + 2] < 0.01f && orm.data[4 * i + 1] > 0.59f);
        }
    CHECK(cov > 5);
    /* POV-Ray's relit view exists, is finite and has the object's coverage */
    DsViews v;
    DsLoadOptions lo = {0, 0, 1, 0, NULL, 0};
    snprintf(p, sizeof p, "%s/000_cup", a);
    CHECK_OK(ds_load_bvault(p, "test", &lo, &v));
    if (!mf_test_failed_now()) {
        CHECK_OK(ds_load_relit(&v, 0, 0, &rl));
        double c2 = 0;
        for (int i = 0; rl.data && i < rl.w * rl.h; ++i) c2 += rl.data[4 * i + 3];
        CHECK(c2 > 0.5 * cov);
        ds_views_free(&v);
    }
    mf_image_free(&orm);
    mf_image_free(&rl);
}

MF_TEST(ds_gen_test2d) {
    DsPriorTrainOpts t = ds_test2d_defaults();
    CHECK(t.count == 32 && t.views_per_object == 4 && t.res == 64 && t.stream == DS_STREAM_TEST2D && !strcmp(t.split, "test-2d"));
    /* miniature: same layout, its own seed stream (other images than prior-train's) */
    DsPriorTrainOpts o = tiny_opts(4);
    o.stream = t.stream;
    o.split = t.split;
    const char *a = mf_test_path("t2d"), *b = mf_test_path("t2d_prior");
    CHECK_OK(ds_gen_prior_train(&o, a, NULL));
    DsPriorTrainOpts p = tiny_opts(4);
    CHECK_OK(ds_gen_prior_train(&p, b, NULL));
    char path[MF_PATH_MAX];
    snprintf(path, sizeof path, "%s/manifest.json", a);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(path, &m));
    CHECK(m && !strcmp(cJSON_GetObjectItem(m, "split")->valuestring, "test-2d"));
    cJSON_Delete(m);
    snprintf(path, sizeof path, "%s/albedo/000000.png", a);
    CHECK(mf_file_exists(path));
    CHECK(!same_files(a, b, 12));
}

/* Reads sub/NNNNNN.png of a generated split (RGBA, linear codes / 255 for orm, sRGB decoded otherwise). */
static int read_view(const char *dir, const char *sub, int i, MfImage *out) {
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/%s/%06d.png", dir, sub, i);
    return mf_image_read(p, strcmp(sub, "orm") ? MF_ENC_SRGB : MF_ENC_LINEAR, out);
}

/* 1 when sub/NNNNNN.png has the same bytes in a and b. */
static int same_view_bytes(const char *a, const char *b, const char *sub, int i) {
    char pa[MF_PATH_MAX], pb[MF_PATH_MAX], *da = NULL, *db = NULL;
    size_t la = 0, lb = 0;
    snprintf(pa, sizeof pa, "%s/%s/%06d.png", a, sub, i);
    snprintf(pb, sizeof pb, "%s/%s/%06d.png", b, sub, i);
    int ok = !mf_read_file(pa, &da, &la) && !mf_read_file(pb, &db, &lb) && la == lb && !memcmp(da, db, la);
    free(da);
    free(db);
    return ok;
}

MF_TEST(ds_gen_renderer_axis_defaults_off) {
    /* the new options default off in both splits, so the default outputs keep their bytes (checked at
     * full size: test-2d regenerated before/after, the 96 manifest checksums equal; reports/generalisation) */
    DsPriorTrainOpts t = ds_test2d_defaults(), p = ds_prior_train_defaults();
    CHECK(t.diffuse == 0 && t.renderer == DS_RENDERER_OURS && t.pov_radiosity == 0);
    CHECK(p.diffuse == 0 && p.renderer == DS_RENDERER_OURS && p.pov_radiosity == 0);
    CHECK(ds_renderer_from_name("ours") == DS_RENDERER_OURS && ds_renderer_from_name("povray") == DS_RENDERER_POVRAY);
    CHECK(ds_renderer_from_name("mitsuba") == -1 && ds_renderer_from_name(NULL) == -1 && ds_renderer_from_name("cycles") == DS_RENDERER_CYCLES);
    CHECK(!strcmp(ds_renderer_name(DS_RENDERER_POVRAY), "povray") && !strcmp(ds_renderer_name(DS_RENDERER_OURS), "ours"));
    /* the default manifest has no new key */
    DsPriorTrainOpts o = tiny_opts(2);
    const char *a = mf_test_path("axis_default");
    CHECK_OK(ds_gen_prior_train(&o, a, NULL));
    char path[MF_PATH_MAX];
    snprintf(path, sizeof path, "%s/manifest.json", a);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(path, &m));
    CHECK(m && !cJSON_GetObjectItem(m, "diffuse") && !cJSON_GetObjectItem(m, "renderer"));
    cJSON_Delete(m);
}

MF_TEST(ds_gen_test2d_diffuse) {
    /* 3 objects x 2 views: the default objects have glossy or metallic texels, the diffuse ones none */
    DsPriorTrainOpts o = tiny_opts(6);
    o.stream = DS_STREAM_TEST2D;
    o.split = "test-2d";
    const char *a = mf_test_path("t2d_axis_plain"), *b = mf_test_path("t2d_axis_diffuse");
    CHECK_OK(ds_gen_prior_train(&o, a, NULL));
    o.diffuse = 1;
    CHECK_OK(ds_gen_prior_train(&o, b, NULL));
    int cov = 0, glossy_plain = 0, rgb_differs = 0;
    for (int i = 0; i < 6; ++i) {
        MfImage pa = {0}, pb = {0};
        CHECK_OK(read_view(a, "orm", i, &pa));
        CHECK_OK(read_view(b, "orm", i, &pb));
        for (int q = 0; pa.data && pb.data && q < pb.w * pb.h; ++q) {
            if (pb.data[4 * q + 3] <= 0.0f) continue;
            ++cov;
            /* 8-bit linear codes: 0.6 is code 153 = 0.6 exactly; metallic code 0 */
            CHECK_MSG(pb.data[4 * q + 2] == 0.0f && pb.data[4 * q + 1] >= 0.6f - 1e-6f, "view %d px %d: roughness %.4f metallic %.4f", i, q,
                      pb.data[4 * q + 1], pb.data[4 * q + 2]);
            glossy_plain += pa.data[4 * q + 1] < 0.59f || pa.data[4 * q + 2] > 0.01f;
        }
        mf_image_free(&pa);
        mf_image_free(&pb);
        /* same objects, cameras and lights: the albedo AOV keeps its bytes (no new random draw) */
        CHECK_MSG(same_view_bytes(a, b, "albedo", i), "view %d: albedo differs between the default and diffuse objects", i);
        rgb_differs += !same_view_bytes(a, b, "rgb", i);
    }
    CHECK(cov > 50);
    CHECK_MSG(glossy_plain > 0, "the test's default objects must have glossy/metallic texels for the check to mean something");
    CHECK(rgb_differs > 0);
    char path[MF_PATH_MAX];
    snprintf(path, sizeof path, "%s/manifest.json", b);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(path, &m));
    CHECK(m && cJSON_IsTrue(cJSON_GetObjectItem(m, "diffuse")));
    cJSON_Delete(m);
}

MF_TEST(ds_gen_test2d_povray_missing) {
    /* no POV-Ray: a clear error naming the tool, before anything is written */
    const char *old = getenv("MF_POVRAY");
    char *saved = old ? strdup(old) : NULL;
    setenv("MF_POVRAY", "/nonexistent/povray", 1);
    DsPriorTrainOpts o = tiny_opts(2);
    o.renderer = DS_RENDERER_POVRAY;
    o.diffuse = 1;
    const char *a = mf_test_path("t2d_axis_nopov");
    CHECK_ERR(ds_gen_prior_train(&o, a, NULL), "POV-Ray");
    CHECK(!mf_file_exists(a));
    if (saved) setenv("MF_POVRAY", saved, 1);
    else unsetenv("MF_POVRAY");
    free(saved);
}

MF_TEST(ds_gen_test2d_povray) {
    if (!ds_povray_available()) MF_SKIP("povray not installed");
    /* 1 object x 2 views at 32 px: POV-Ray's lit view differs from ours, the GT AOVs are ours */
    DsPriorTrainOpts o = tiny_opts(2);
    o.stream = DS_STREAM_TEST2D;
    o.split = "test-2d";
    o.res = 32;
    o.diffuse = 1;
    o.pov_radiosity = 50;
    const char *a = mf_test_path("t2d_axis_ours"), *b = mf_test_path("t2d_axis_pov");
    CHECK_OK(ds_gen_prior_train(&o, a, NULL));
    o.renderer = DS_RENDERER_POVRAY;
    CHECK_OK(ds_gen_prior_train(&o, b, NULL));
    for (int i = 0; i < 2; ++i) {
        CHECK_MSG(same_view_bytes(a, b, "albedo", i) && same_view_bytes(a, b, "orm", i), "view %d: GT albedo/ORM must be our AOVs", i);
        CHECK_MSG(!same_view_bytes(a, b, "rgb", i), "view %d: the POV-Ray view has our renderer's bytes", i);
        /* the same object seen from the same camera: coverage agrees, shading is the same order */
        MfImage ra = {0}, rb = {0};
        CHECK_OK(read_view(a, "rgb", i, &ra));
        CHECK_OK(read_view(b, "rgb", i, &rb));
        int both = 0, either = 0;
        double sa = 0, sb = 0;
        for (int q = 0; ra.data && rb.data && q < 32 * 32; ++q) {
            int ca = ra.data[4 * q + 3] > 0.5f, cb = rb.data[4 * q + 3] > 0.5f;
            both += ca && cb, either += ca || cb;
            if (ca && cb)
                for (int c = 0; c < 3; ++c) sa += ra.data[4 * q + c], sb += rb.data[4 * q + c];
        }
        CHECK_MSG(both > 30 && both >= 0.9 * either, "view %d: coverage %d of %d", i, both, either);
        CHECK_MSG(sb > 0.3 * sa && sb < 3.0 * sa, "view %d: mean colour ours %.3f vs POV-Ray %.3f", i, sa / (both ? both : 1), sb / (both ? both : 1));
        mf_image_free(&ra);
        mf_image_free(&rb);
    }
    char path[MF_PATH_MAX];
    snprintf(path, sizeof path, "%s/.povray", b);
    CHECK_MSG(!mf_file_exists(path), "%s: scratch folder left behind", path);
    snprintf(path, sizeof path, "%s/manifest.json", b);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(path, &m));
    const cJSON *r = m ? cJSON_GetObjectItem(m, "renderer") : NULL;
    CHECK(cJSON_IsString(r) && strstr(r->valuestring, "povray"));
    cJSON_Delete(m);
}

/* Material ambiguity transforms (test-3d-ambig): each does what ds_gen.h states, on a real object. */
static void kd_orm_stats(const DsObject *o, double kd_sd[3], float kd_max[1], float rough_mm[2], float metal_mm[2]) {
    size_t n = (size_t)o->kd.w * (size_t)o->kd.h;
    double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
    kd_max[0] = 0.0f;
    rough_mm[0] = metal_mm[0] = 1e9f;
    rough_mm[1] = metal_mm[1] = -1e9f;
    for (size_t i = 0; i < n; ++i) {
        const float *kd = o->kd.data + i * (size_t)o->kd.c, *orm = o->orm.data + i * (size_t)o->orm.c;
        for (int c = 0; c < 3; ++c) { s[c] += kd[c]; s2[c] += (double)kd[c] * kd[c]; if (kd[c] > kd_max[0]) kd_max[0] = kd[c]; }
        if (orm[1] < rough_mm[0]) rough_mm[0] = orm[1];
        if (orm[1] > rough_mm[1]) rough_mm[1] = orm[1];
        if (orm[2] < metal_mm[0]) metal_mm[0] = orm[2];
        if (orm[2] > metal_mm[1]) metal_mm[1] = orm[2];
    }
    for (int c = 0; c < 3; ++c) kd_sd[c] = sqrt(fmax(0.0, s2[c] / (double)n - (s[c] / (double)n) * (s[c] / (double)n)));
}

MF_TEST(ds_object_make_ambiguous) {
    double sd0[3], sd[3];
    float kmax0, kmax, r0[2], r[2], m0[2], m[2];
    for (int a = 0; a < DS_AMBIG_COUNT; ++a) {
        DsObject o;
        CHECK_OK(ds_object_generate(&o, DS_FAM_VASE, 11, 64));
        kd_orm_stats(&o, sd0, &kmax0, r0, m0);
        ds_object_make_ambiguous(&o, (DsAmbiguity)a);
        kd_orm_stats(&o, sd, &kmax, r, m);
        switch (a) {
        case DS_AMBIG_LOW_CONTRAST:
            for (int c = 0; c < 3; ++c) CHECK_MSG(fabs(sd[c] - 0.2 * sd0[c]) < 1e-4, "channel %d sd %.4f, expected %.4f", c, sd[c], 0.2 * sd0[c]);
            break;
        case DS_AMBIG_MIXED_METAL: CHECK(m[0] == 0.0f && m[1] == 1.0f); break;
        case DS_AMBIG_ROUGH_GLOSSY: CHECK(r[0] == 0.08f && r[1] == 0.9f); break;
        case DS_AMBIG_DARK: CHECK(kmax > 0.0f && fabsf(kmax - 0.1f * kmax0) < 1e-6f); break;
        default: break;
        }
        ds_object_free(&o);
    }
    CHECK(!strcmp(ds_ambiguity_name(DS_AMBIG_DARK), "dark"));
}
