/* Procedural env maps (datasets/ds_envgen.h) and procedural training lights in ds_gen. */
#include <cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "datasets/ds_envgen.h"
#include "datasets/ds_gen.h"
#include "io/mf_json.h"
#include "scene/mf_envmap.h"
#include "mf_test.h"

static int all_finite_nonneg(const MfImage *img) {
    size_t n = (size_t)img->w * img->h * img->c;
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(img->data[i]) || img->data[i] < 0) return 0;
    return 1;
}

static MfVec3 centre_dir(int x, int y, int w, int h) { return mf_env_uv_to_dir((x + 0.5f) / w, 1.0f - (y + 0.5f) / h); }

static void brightest(const MfImage *img, int *bx, int *by) {
    float best = -1;
    for (int y = 0; y < img->h; ++y)
        for (int x = 0; x < img->w; ++x) {
            const float *p = mf_image_px(img, x, y);
            float l = mf_lum(mf_v3(p[0], p[1], p[2]));
            if (l > best) best = l, *bx = x, *by = y;
        }
}

MF_TEST(envgen_deterministic) {
    for (int kind = 0; kind < 2; ++kind) {
        MfImage a, b, c;
        CHECK_OK(ds_env_random((DsEnvKind)kind, 7, DS_ENV_W, DS_ENV_H, &a));
        CHECK_OK(ds_env_random((DsEnvKind)kind, 7, DS_ENV_W, DS_ENV_H, &b));
        CHECK_OK(ds_env_random((DsEnvKind)kind, 8, DS_ENV_W, DS_ENV_H, &c));
        size_t n = sizeof(float) * DS_ENV_W * DS_ENV_H * 3;
        CHECK(a.w == DS_ENV_W && a.h == DS_ENV_H && a.c == 3);
        CHECK(memcmp(a.data, b.data, n) == 0);
        CHECK(memcmp(a.data, c.data, n) != 0);
        CHECK(all_finite_nonneg(&a) && all_finite_nonneg(&c));
        mf_image_free(&a), mf_image_free(&b), mf_image_free(&c);
    }
}

MF_TEST(envgen_sky_finite_and_above_brighter) {
    const float els[3] = {0.0f, 0.5f * MF_PI, 0.3f};
    const float ts[3] = {2.0f, 10.0f, 1.0f}; /* 1.0 is clamped to 2 */
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            DsSkyParams p = {.sun_elevation = els[i], .sun_azimuth = 1.0f, .turbidity = ts[j], .ground_albedo = mf_v3s(0.15f),
                             .sun_scale = 1.0f, .exposure = (j == 1) ? 1.0f : 0.0f};
            MfImage img;
            DsSkyInfo info;
            CHECK_OK(ds_env_sky(&p, 64, 32, &img, &info));
            CHECK(all_finite_nonneg(&img));
            CHECK(isfinite(info.e_sun) && isfinite(info.e_sky) && info.e_sky > 0);
            /* mean luminance of the sky 10 deg or more above the horizon and 5 deg or more from the
             * sun vs the ground */
            double up = 0, nu = 0, dn = 0, nd = 0;
            for (int y = 0; y < img.h; ++y)
                for (int x = 0; x < img.w; ++x) {
                    MfVec3 d = centre_dir(x, y, img.w, img.h);
                    const float *q = mf_image_px(&img, x, y);
                    float l = mf_lum(mf_v3(q[0], q[1], q[2]));
                    if (d.z < 0) dn += l, ++nd;
                    else if (d.z > sinf(0.1745f) && mf_dot(d, info.sun_dir) < cosf(0.0873f)) up += l, ++nu;
                }
            CHECK(nu > 0 && nd > 0);
            CHECK_MSG(up / nu > 1.2 * dn / nd, "el %g T %g: sky %g ground %g", (double)els[i], (double)ts[j], up / nu, dn / nd);
            mf_image_free(&img);
        }
}

MF_TEST(envgen_sun_is_brightest_texel) {
    const float els_deg[4] = {10, 35, 60, 85}, azs[4] = {0.3f, 2.0f, -2.5f, 4.0f};
    for (int i = 0; i < 4; ++i) {
        DsSkyParams p = {.sun_elevation = els_deg[i] * MF_PI / 180.0f, .sun_azimuth = azs[i], .turbidity = 3.0f, .ground_albedo = mf_v3s(0.2f),
                         .sun_scale = 1.0f, .exposure = 1.0f};
        MfImage img;
        DsSkyInfo info;
        CHECK_OK(ds_env_sky(&p, DS_ENV_W, DS_ENV_H, &img, &info));
        float el = p.sun_elevation;
        MfVec3 s = mf_v3(cosf(azs[i]) * cosf(el), sinf(azs[i]) * cosf(el), sinf(el));
        CHECK_NEAR(mf_dot(s, info.sun_dir), 1.0f, 1e-5f);
        int bx = 0, by = 0;
        brightest(&img, &bx, &by);
        float ang = acosf(mf_clampf(mf_dot(centre_dir(bx, by, img.w, img.h), s), -1, 1));
        float texel = MF_PI / img.h; /* texel height (= width at the horizon) */
        CHECK_MSG(ang <= 1.4143f * texel, "el %g: brightest texel %g deg from the sun (texel %g deg)", (double)els_deg[i], ang * 57.29578, texel * 57.29578);
        /* texel indices: within one of the texel containing the sun centre */
        float u, v;
        mf_env_dir_to_uv(s, &u, &v);
        int sx = (int)floorf(u * img.w) % img.w, sy = (int)floorf((1 - v) * img.h);
        int dx = abs(bx - sx);
        if (dx > img.w / 2) dx = img.w - dx;
        if (els_deg[i] < 80) CHECK(dx <= 1 && abs(by - sy) <= 1);
        mf_image_free(&img);
    }
}

/* Sun share of the irradiance on an upward plane, measured on the map itself: with and without
 * the sun disc. */
static double sun_share(float el_deg, float T, int w, int h, double *e_sun) {
    DsSkyParams p = {.sun_elevation = el_deg * MF_PI / 180.0f, .sun_azimuth = 0.7f, .turbidity = T, .ground_albedo = mf_v3s(0.2f), .sun_scale = 1.0f};
    MfImage a, b;
    if (ds_env_sky(&p, w, h, &a, NULL)) return -1;
    p.sun_scale = 0;
    if (ds_env_sky(&p, w, h, &b, NULL)) return -1;
    double ea = ds_env_irradiance(&a, mf_v3(0, 0, 1)), eb = ds_env_irradiance(&b, mf_v3(0, 0, 1));
    mf_image_free(&a), mf_image_free(&b);
    if (e_sun) *e_sun = ea - eb;
    return (ea - eb) / ea;
}

MF_TEST(envgen_sun_share_of_irradiance) {
    /* header: T = 2: 0.73 at 45 deg, T = 3: 0.67; both within [0.6, 0.9] */
    double s2 = sun_share(45, 2, DS_ENV_W, DS_ENV_H, NULL), s3 = sun_share(45, 3, DS_ENV_W, DS_ENV_H, NULL);
    CHECK_MSG(s2 >= 0.6 && s2 <= 0.9, "T 2, 45 deg: sun share %g", s2);
    CHECK_MSG(s3 >= 0.6 && s3 <= 0.9, "T 3, 45 deg: sun share %g", s3);
    CHECK(s2 > s3); /* clearer air: more direct sun */
    double lo = sun_share(15, 3, DS_ENV_W, DS_ENV_H, NULL), hi = sun_share(70, 3, DS_ENV_W, DS_ENV_H, NULL);
    CHECK_MSG(lo < hi && hi > 0.65, "share 15 deg %g, 70 deg %g", lo, hi);
    /* the sun disc carries the same energy at any resolution (solid angles are right) */
    double ea = 0, eb = 0;
    sun_share(45, 3, DS_ENV_W, DS_ENV_H, &ea);
    sun_share(45, 3, 1024, 512, &eb);
    CHECK_MSG(fabs(ea / eb - 1) < 0.02, "sun irradiance 256x128 %g vs 1024x512 %g klux", ea, eb);
    /* and about what the model says: 128 klux * transmittance * sin(45 deg) is in [40, 90] klux */
    CHECK_MSG(ea > 40 && ea < 90, "sun irradiance %g klux", ea);
}

/* Solid angle of the planar quad c[0..3] seen from the origin (Van Oosterom & Strackee 1983). */
static double tri_omega(MfVec3 a, MfVec3 b, MfVec3 c) {
    double la = mf_len(a), lb = mf_len(b), lc = mf_len(c);
    double num = fabs((double)mf_dot(a, mf_cross(b, c)));
    double den = la * lb * lc + mf_dot(a, b) * lc + mf_dot(a, c) * lb + mf_dot(b, c) * la;
    return 2.0 * atan2(num, den);
}

MF_TEST(envgen_indoor_lights_and_solid_angles) {
    for (uint64_t seed = 1; seed <= 6; ++seed) {
        DsIndoorParams p;
        ds_indoor_params_random(seed, &p);
        CHECK(p.nlights >= 1 && p.nlights <= DS_INDOOR_MAX_LIGHTS);
        MfImage img;
        CHECK_OK(ds_env_indoor(&p, DS_ENV_W, DS_ENV_H, &img, NULL));
        CHECK(all_finite_nonneg(&img));
        int bx = 0, by = 0;
        brightest(&img, &bx, &by);
        CHECK_MSG(ds_indoor_hit_light(&p, centre_dir(bx, by, img.w, img.h)) >= 0, "seed %d: brightest texel not on a light", (int)seed);
        /* every light's centre direction hits that light */
        for (int i = 0; i < p.nlights; ++i) {
            MfVec3 c[4];
            ds_indoor_light_corners(&p, i, c);
            MfVec3 m = mf_norm(mf_scale(mf_add(mf_add(c[0], c[1]), mf_add(c[2], c[3])), 0.25f));
            CHECK(ds_indoor_hit_light(&p, m) == i);
        }
        /* each light alone, walls off, raw units: its share of the map is its solid angle */
        for (int i = 0; i < p.nlights; ++i) {
            DsIndoorParams q = p;
            q.lights[0] = p.lights[i];
            q.nlights = 1;
            q.wall_scale = 0;
            q.exposure = 0;
            MfImage li;
            CHECK_OK(ds_env_indoor(&q, DS_ENV_W, DS_ENV_H, &li, NULL));
            double sum = 0;
            for (int y = 0; y < li.h; ++y) {
                double om = (2.0 * M_PI / li.w) * (cos(M_PI * y / li.h) - cos(M_PI * (y + 1) / li.h));
                for (int x = 0; x < li.w; ++x) {
                    const float *t = mf_image_px(&li, x, y);
                    sum += mf_lum(mf_v3(t[0], t[1], t[2])) * om;
                }
            }
            MfVec3 c[4];
            ds_indoor_light_corners(&q, 0, c);
            double om = tri_omega(c[0], c[1], c[2]) + tri_omega(c[0], c[2], c[3]);
            double meas = sum / mf_lum(q.lights[0].radiance);
            CHECK_MSG(fabs(meas / om - 1) < 0.03, "seed %d light %d: map solid angle %g vs %g sr", (int)seed, i, meas, om);
            mf_image_free(&li);
        }
        mf_image_free(&img);
    }
}

MF_TEST(envgen_kelvin_colours) {
    MfVec3 d65 = ds_kelvin_rgb(6504), warm = ds_kelvin_rgb(2700), cold = ds_kelvin_rgb(10000);
    CHECK_NEAR(mf_lum(warm), 1.0f, 1e-4f);
    CHECK(fabsf(d65.x - d65.z) < 0.12f && fabsf(d65.x - 1) < 0.1f); /* near white */
    CHECK(warm.x > warm.y && warm.y > warm.z && cold.z > cold.x);
}

/* Upward irradiance of env by light sampling alone (stratified); counts samples that disagree
 * with mf_env_pdf or are not finite, and samples brighter than bright_lum. */
static double sampled_irradiance(const MfEnvMap *env, int n, int *bad, int *nbright, float bright_lum) {
    double est = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            MfVec3 d;
            float pdf;
            MfVec3 L = mf_env_sample(env, (i + 0.5f) / n, (j + 0.5f) / n, &d, &pdf);
            if (!(pdf > 0) || !isfinite(pdf) || !mf_isfinite3(L)) { ++*bad; continue; }
            if (fabsf(mf_env_pdf(env, d) / pdf - 1) > 1e-3f) ++*bad;
            if (mf_lum(L) > bright_lum) ++*nbright;
            if (d.z > 0) est += mf_lum(L) * d.z / pdf;
        }
    return est / ((double)n * n);
}

MF_TEST(envgen_importance_sampling) {
    const int n = 128;
    /* room, and sky with the sun as a directional light: light sampling alone integrates them */
    for (int kind = 0; kind < 2; ++kind) {
        MfImage img;
        DsSkyInfo info = {0};
        if (kind == 0) {
            DsSkyParams p = ds_sky_params_random(11);
            p.sun_as_light = 1;
            CHECK_OK(ds_env_sky(&p, DS_ENV_W, DS_ENV_H, &img, &info));
        } else
            CHECK_OK(ds_env_random(DS_ENV_INDOOR, 11, DS_ENV_W, DS_ENV_H, &img));
        double ref = ds_env_irradiance(&img, mf_v3(0, 0, 1));
        MfEnvMap env;
        CHECK_OK(mf_env_init(&env, &img));
        int bad = 0, nb = 0;
        double est = sampled_irradiance(&env, n, &bad, &nb, INFINITY);
        CHECK(bad == 0);
        CHECK_MSG(fabs(est / ref - 1) < 0.03, "kind %d: sampled irradiance %g vs texel sum %g", kind, est, ref);
        mf_env_free(&env);
    }
    /* sun disc in the map: same total as sun-as-light + the directional term, and env samples
     * concentrate on it */
    DsSkyParams p = ds_sky_params_random(12);
    MfImage a, b;
    DsSkyInfo ia, ib;
    CHECK_OK(ds_env_sky(&p, DS_ENV_W, DS_ENV_H, &a, &ia));
    p.sun_as_light = 1;
    CHECK_OK(ds_env_sky(&p, DS_ENV_W, DS_ENV_H, &b, &ib));
    CHECK_NEAR(ia.scale / ib.scale, 1.0, 1e-3);
    double ea = ds_env_irradiance(&a, mf_v3(0, 0, 1)), eb = ds_env_irradiance(&b, mf_v3(0, 0, 1)) + mf_lum(ib.sun_rgb) * ib.sun_dir.z;
    CHECK_MSG(fabs(ea / eb - 1) < 0.01, "disc in the map %g vs directional sun %g", ea, eb);
    mf_image_free(&b);
    MfEnvMap env;
    CHECK_OK(mf_env_init(&env, &a));
    int bad = 0, nb = 0;
    sampled_irradiance(&env, n, &bad, &nb, 100.0f);
    CHECK(bad == 0);
    CHECK_MSG(nb > 0.3 * n * n, "only %d of %d env samples at the sun", nb, n * n);
    mf_env_free(&env);
}

MF_TEST(envgen_bad_input) {
    DsSkyParams p = ds_sky_params_random(1);
    MfImage img;
    CHECK_ERR(ds_env_sky(&p, 4, 2, &img, NULL), "map size");
    DsIndoorParams q;
    ds_indoor_params_random(1, &q);
    q.nlights = 0;
    CHECK_ERR(ds_env_indoor(&q, 64, 32, &img, NULL), "room lights");
    ds_indoor_params_random(1, &q);
    q.floor_z = 0.5f;
    CHECK_ERR(ds_env_indoor(&q, 64, 32, &img, NULL), "observer");
}

/* prior-train with procedural lights never reads env_dir (here a folder that does not exist). */
MF_TEST(envgen_prior_train_procedural_lights) {
    DsPriorTrainOpts o = ds_prior_train_defaults();
    o.count = 6;
    o.res = 16;
    o.views_per_object = 6;
    o.tex_res = 32;
    o.spp_sqrt = 1;
    o.pixel_samples = 1;
    o.seed = 3;
    o.threads = 1;
    o.env_dir = "/nonexistent/no_such_probes";
    o.train_lights = DS_LIGHTS_BLENDER;
    CHECK_ERR(ds_gen_prior_train(&o, mf_test_path("envgen_pt_blender"), NULL), "no_such_probes");
    o.train_lights = DS_LIGHTS_PROCEDURAL;
    DsGenStats st;
    const char *out = mf_test_path("envgen_pt_proc");
    CHECK_OK(ds_gen_prior_train(&o, out, &st));
    CHECK(st.objects == 1 && st.count == 6 && st.rendered_views == 6);
    CHECK(st.env_views > 0); /* the procedural maps were used */
    char p[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/manifest.json", out);
    cJSON *m = NULL;
    CHECK_OK(mf_json_load(p, &m));
    const cJSON *tl = cJSON_GetObjectItem(m, "train_lights"), *pr = cJSON_GetObjectItem(m, "probes");
    CHECK(cJSON_IsString(tl) && !strcmp(tl->valuestring, "procedural"));
    CHECK(pr && cJSON_GetArraySize(pr) == 0);
    cJSON_Delete(m);
    snprintf(p, sizeof p, "%s/rgb/000005.png", out);
    CHECK(mf_file_exists(p));
    /* both: a probe folder is needed again (here two procedural maps written as files) */
    const char *pdir = mf_test_path("envgen_pt_probes");
    CHECK_OK(mf_mkdirs(pdir));
    for (int i = 0; i < 2; ++i) {
        MfImage img;
        CHECK_OK(ds_env_random((DsEnvKind)i, 40 + i, 32, 16, &img));
        snprintf(p, sizeof p, "%s/p%d.exr", pdir, i);
        CHECK_OK(mf_image_write(p, &img, MF_ENC_LINEAR, 32));
        mf_image_free(&img);
    }
    o.train_lights = DS_LIGHTS_BOTH;
    o.env_dir = pdir;
    CHECK_OK(ds_gen_prior_train(&o, mf_test_path("envgen_pt_both"), &st));
    CHECK(st.objects == 1 && st.env_views > 0);
    CHECK(ds_train_lights_from_name("both") == DS_LIGHTS_BOTH && ds_train_lights_from_name("x") == -1);
}

/* ds_gen rotates a procedural sky map and its directional sun together: the sun direction rotated
 * by angle a about +Z is where mf_env_rotate_z moves the disc. */
MF_TEST(envgen_rotation_matches_sun) {
    DsSkyParams p = ds_sky_params_random(21);
    p.sun_elevation = 0.5f;
    MfImage img;
    DsSkyInfo info;
    CHECK_OK(ds_env_sky(&p, DS_ENV_W, DS_ENV_H, &img, &info));
    MfEnvMap env;
    CHECK_OK(mf_env_init(&env, &img));
    float a = 1.3f, ca = cosf(a), sa = sinf(a);
    CHECK_OK(mf_env_rotate_z(&env, a));
    MfVec3 s = info.sun_dir, r = mf_v3(ca * s.x - sa * s.y, sa * s.x + ca * s.y, s.z);
    int bx = 0, by = 0;
    brightest(&env.img, &bx, &by);
    float ang = acosf(mf_clampf(mf_dot(centre_dir(bx, by, env.img.w, env.img.h), r), -1, 1));
    CHECK_MSG(ang <= 1.4143f * MF_PI / env.img.h, "rotated sun %g deg from the brightest texel", ang * 57.29578);
    mf_env_free(&env);
}

/* mf gen --envs writes loadable maps that ds_list_probes (every split's --env-dir) finds. */
MF_TEST(envgen_cli_envs) {
    MF_NEED_BIN();
    const char *dir = mf_test_path("envgen_cli");
    char args[2 * MF_PATH_MAX], err[4096];
    snprintf(args, sizeof args, "gen --envs '%s' --count 2 --seed 3 --env-width 64", dir);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    char **names = NULL;
    int n = 0;
    CHECK_OK(ds_list_probes(dir, &names, &n));
    CHECK(n == 4);
    static const char *const want[4] = {"indoor_000.exr", "indoor_001.exr", "sky_000.exr", "sky_001.exr"};
    for (int i = 0; i < n; ++i) {
        CHECK(i < 4 && !strcmp(names[i], want[i]));
        char p[MF_PATH_MAX];
        snprintf(p, sizeof p, "%s/%s", dir, names[i]);
        MfEnvMap env;
        CHECK_OK(mf_env_load(&env, p));
        CHECK(env.img.w == 64 && env.img.h == 32);
        /* the bytes are ds_env_random's (seed per kind and index as cmd_gen.c derives them) */
        MfImage ref;
        uint64_t base = mf_hash64(3, i < 2 ? 0x1D0u : 0x5C7u);
        CHECK_OK(ds_env_random(i < 2 ? DS_ENV_INDOOR : DS_ENV_SKY, mf_hash64(base, (uint64_t)(i % 2)), 64, 32, &ref));
        CHECK(memcmp(ref.data, env.img.data, sizeof(float) * 64 * 32 * 3) == 0);
        mf_image_free(&ref);
        mf_env_free(&env);
        free(names[i]);
    }
    free(names);
    snprintf(args, sizeof args, "gen --envs '%s' --kind lamp", dir);
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2);
}
