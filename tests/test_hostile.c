/* Regression tests for hostile inputs (issue 15): each case once crashed, overflowed a buffer or
 * reported a misleading error. Every case must now end in an error that names the file and what
 * is wrong, a non-zero exit for the CLI, and no output file. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_load.h"
#include "eval/ev_eval.h"
#include "eval/ev_table.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "io/mf_obj.h"
#include "prior/mf_prior.h"
#include "scene/mf_camera.h"
#include "scene/mf_envmap.h"
#include "scene/mf_scene.h"
#include "mf_test.h"

static void put(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Number of entries (other than . and ..) in dir, recursively; 0 if it does not exist. */
static int count_files(const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char sub[2048];
        snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name);
        struct stat st;
        if (stat(sub, &st) == 0 && S_ISDIR(st.st_mode)) n += count_files(sub);
        else ++n;
    }
    closedir(d);
    return n;
}

static const char *k_quad =
    "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
static const char *k_cams_fmt =
    "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": "
    "[[1,0,0,0],[0,1,0,0],[0,0,1,%s],[0,0,0,1]]}]}";
static const char *k_scene_fmt =
    "{\"mesh\": \"%s\", \"material\": {\"kd\": [0.5, 0.4, 0.3], \"orm\": [0, 0.6, 0]},\n"
    " \"lights\": [{\"type\": \"sun\", \"dir\": [0, 0.3, 1], \"strength\": 2}],\n"
    " \"env\": null, \"cameras\": \"%s\", \"width\": 16, \"height\": 12,\n"
    " \"render\": {\"spp_sqrt\": 1, \"pixel_samples\": 2}}\n";

/* Writes dir/<name>.obj, dir/<name>_cams.json (camera at z = cam_z) and dir/<name>.json (the
 * scene); returns the scene path in a static buffer. */
static const char *write_render_scene(const char *dir, const char *name, const char *obj, const char *cam_z) {
    static char scene[1024];
    char p[1024], buf[4096], objname[256], camname[256];
    snprintf(objname, sizeof objname, "%s.obj", name);
    snprintf(camname, sizeof camname, "%s_cams.json", name);
    snprintf(p, sizeof p, "%s/%s", dir, objname);
    put(p, obj);
    snprintf(buf, sizeof buf, k_cams_fmt, cam_z);
    snprintf(p, sizeof p, "%s/%s", dir, camname);
    put(p, buf);
    snprintf(buf, sizeof buf, k_scene_fmt, objname, camname);
    snprintf(scene, sizeof scene, "%s/%s.json", dir, name);
    put(scene, buf);
    return scene;
}

/* (a) Camera positions and vertices whose squares overflow float (or beyond Embree's ray-origin
 * limit) once aborted inside Embree; now they are refused by name before anything renders. */
MF_TEST(hostile_huge_coordinates) {
    double c2w[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2.5, 0, 0, 0, 1};
    MfCamera cam;
    CHECK_OK(mf_camera_init(&cam, 8, 8, 0.6911, c2w, "cams.json: frames[0]"));
    c2w[11] = 1e18;
    CHECK_OK(mf_camera_init(&cam, 8, 8, 0.6911, c2w, "cams.json: frames[0]"));
    c2w[11] = 1e39;
    CHECK_ERR(mf_camera_init(&cam, 8, 8, 0.6911, c2w, "cams.json: frames[0]"), "cams.json: frames[0]: transform_matrix: camera position z");
    c2w[11] = 2.5;
    c2w[3] = -2e19;
    CHECK_ERR(mf_camera_init(&cam, 8, 8, 0.6911, c2w, "cams.json: frames[0]"), "camera position x = -2e+19 is out of range");

    char dir[512], p[1024];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_coords"));
    CHECK_OK(mf_mkdirs(dir));
    snprintf(p, sizeof p, "%s/big.obj", dir);
    put(p, "v 0 0 0\nv 1 0 0\nv 0 3e38 0\nf 1 2 3\n");
    MfMesh m = {0};
    CHECK_ERR(mf_obj_read(p, &m), "big.obj:3: vertex y = 3e+38 is out of range");
    mf_mesh_free(&m);

    if (!getenv("MF_BIN")) MF_SKIP("MF_BIN not set");
    char err[4096], args[4096], out[1024];
    snprintf(out, sizeof out, "%s/out", dir);
    const char *scene = write_render_scene(dir, "farcam", k_quad, "1e39");
    snprintf(args, sizeof args, "render %s -o %s", scene, out);
    int rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 1, "mf render with a camera at 1e39: exit %d (expected 1): %s", rc, err);
    CHECK_MSG(strstr(err, "farcam_cams.json: frames[0]: transform_matrix: camera position z"), "message: %s", err);
    CHECK(count_files(out) == 0);
    scene = write_render_scene(dir, "farvert", "v 0 0 0\nv 1 0 0\nv 0 1 1e30\nf 1 2 3\n", "2.5");
    snprintf(args, sizeof args, "render %s -o %s", scene, out);
    rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 1, "mf render with a vertex at 1e30: exit %d (expected 1): %s", rc, err);
    CHECK_MSG(strstr(err, "farvert.obj:3: vertex z = 1e+30 is out of range"), "message: %s", err);
    CHECK(count_files(out) == 0);
}

/* An env map whose texel values are distinct per column (value = 1 + column + 100 row). */
static void column_env(MfImage *img, int w, int h) {
    mf_image_alloc(img, w, h, 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < 3; ++k) mf_image_px(img, x, y)[k] = (float)(1 + x + 100 * y + 1000 * k);
}

/* Loads dir/<name>.json, a scene whose env is env.exr rotated by rot_deg (given as JSON text). */
static int load_rotated_env_scene(const char *dir, const char *name, const char *rot_deg, MfScene *s) {
    char p[1024], buf[2048];
    write_render_scene(dir, name, k_quad, "2.5");
    snprintf(buf, sizeof buf,
             "{\"mesh\": \"%s.obj\", \"env\": {\"file\": \"env.exr\", \"rotation_z_deg\": %s},"
             " \"cameras\": \"%s_cams.json\", \"width\": 8, \"height\": 8}\n", name, rot_deg, name);
    snprintf(p, sizeof p, "%s/%s.json", dir, name);
    put(p, buf);
    return mf_scene_load(p, s);
}

/* (b) An env rotation_z_deg of 2e40 became an infinite float angle and the column shift an
 * out-of-range int: a heap overflow in mf_env_rotate_z. The angle is now reduced modulo 360 in
 * double, so 2e40 degrees rotates exactly as fmod(2e40, 360) does. */
MF_TEST(hostile_env_rotation) {
    enum { W = 16, H = 4 };
    char dir[512], p[1024];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_env"));
    CHECK_OK(mf_mkdirs(dir));
    MfImage img = {0};
    column_env(&img, W, H);
    snprintf(p, sizeof p, "%s/env.exr", dir);
    CHECK_OK(mf_image_write(p, &img, MF_ENC_LINEAR, 32));
    mf_image_free(&img);

    char reduced[64];
    snprintf(reduced, sizeof reduced, "%.17g", fmod(2e40, 360.0));
    MfScene a = {0}, b = {0};
    CHECK_OK(load_rotated_env_scene(dir, "huge", "2e40", &a));
    CHECK_OK(load_rotated_env_scene(dir, "reduced", reduced, &b));
    if (a.has_env && b.has_env) {
        CHECK(a.env.img.w == W && b.env.img.w == W);
        size_t n = (size_t)W * H * 3, same = 0;
        for (size_t i = 0; i < n; ++i) same += a.env.img.data[i] == b.env.img.data[i];
        CHECK_MSG(same == n, "rotation by 2e40 deg differs from rotation by %s deg in %zu of %zu values", reduced, n - same, n);
        /* and the rotation really moved the columns (fmod(2e40, 360) is not a multiple of 360) */
        CHECK(fabs(fmod(2e40, 360.0)) > 1.0);
        CHECK(a.env.img.data[0] != 1.0f);
    }
    mf_scene_free(&a);
    mf_scene_free(&b);
    /* a rotation_z_deg that does not fit a double is refused by name (JSON 1e999 reads as inf) */
    MfScene c = {0};
    CHECK_ERR(load_rotated_env_scene(dir, "inf", "1e999", &c), "inf.json: env");
    mf_scene_free(&c);

    /* the library call itself: a huge finite angle in radians, and a non-finite one */
    MfEnvMap e1, e2;
    column_env(&img, W, H);
    CHECK_OK(mf_env_init(&e1, &img));
    column_env(&img, W, H);
    CHECK_OK(mf_env_init(&e2, &img));
    CHECK_OK(mf_env_rotate_z(&e1, 1e30f));
    CHECK_OK(mf_env_rotate_z(&e2, (float)fmod((double)1e30f, 2.0 * M_PI)));
    double maxd = 0.0;
    for (size_t i = 0; i < (size_t)W * H * 3; ++i) maxd = fmax(maxd, fabs(e1.img.data[i] - e2.img.data[i]));
    CHECK_MSG(maxd < 1e-2, "rotation by 1e30 rad differs from its reduction by %g", maxd);
    CHECK_ERR(mf_env_rotate_z(&e1, INFINITY), "not finite");
    CHECK_ERR(mf_env_rotate_z(&e1, NAN), "not finite");
    mf_env_free(&e1);
    mf_env_free(&e2);
}

/* A w x h image with c channels, every value v (alpha 1), written to path. */
static void write_flat(const char *path, int w, int h, int c, float v, MfEncoding enc) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, c);
    for (size_t i = 0; i < (size_t)w * h; ++i)
        for (int k = 0; k < c; ++k) im.data[i * c + k] = (k == 3) ? 1.0f : v;
    mf_mkdirs_for(path);
    mf_image_write(path, &im, enc, strstr(path, ".exr") ? 32 : 8);
    mf_image_free(&im);
}

static const char *pj2(const char *a, const char *b) {
    static char buf[4][MF_PATH_MAX];
    static int k;
    char *o = buf[k++ & 3];
    snprintf(o, MF_PATH_MAX, "%s/%s", a, b);
    return o;
}

/* (c) Per-view GT albedo / ORM / relit images smaller than the views were read past their end
 * by eval (a heap overflow; without ASan a wrong score and exit 0). Now the loader refuses them
 * naming both files, and eval names the relit file and the view image. */
MF_TEST(hostile_eval_gt_size) {
    char scene[512], res[512];
    snprintf(scene, sizeof scene, "%s", mf_test_path("hostile_gt/scene"));
    snprintf(res, sizeof res, "%s", mf_test_path("hostile_gt/result"));
    CHECK_OK(mf_mkdirs(scene));
    CHECK_OK(mf_mkdirs(res));
    put(pj2(scene, "transforms_test.json"),
        "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./test/r_0\", \"transform_matrix\": "
        "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}");
    put(pj2(scene, "mesh.obj"), k_quad);
    write_flat(pj2(scene, "test/r_0.png"), 16, 16, 4, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(scene, "gt/albedo/r_0.png"), 8, 8, 3, 0.5f, MF_ENC_SRGB);
    put(pj2(res, "mesh.obj"), k_quad);
    write_flat(pj2(res, "albedo.png"), 4, 4, 3, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(res, "orm.png"), 4, 4, 3, 0.5f, MF_ENC_LINEAR);

    DsViews v;
    CHECK_ERR(ds_load(scene, "test", NULL, &v), "gt/albedo/r_0.png: GT albedo is 8x8, the view image");
    CHECK_MSG(strstr(mf_error(), "test/r_0.png is 16x16") != NULL, "message: %s", mf_error());
    EvEvalOpts o = ev_eval_opts_default();
    o.spp_sqrt = 1;
    o.pixel_samples = 1;
    EvTable t;
    ev_table_init(&t);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "gt/albedo/r_0.png: GT albedo is 8x8");
    /* ORM GT too small */
    write_flat(pj2(scene, "gt/albedo/r_0.png"), 16, 16, 3, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(scene, "gt/orm/r_0.png"), 16, 8, 3, 0.5f, MF_ENC_LINEAR);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "gt/orm/r_0.png: GT ORM is 16x8, the view image");
    /* relit GT too small */
    write_flat(pj2(scene, "gt/orm/r_0.png"), 16, 16, 3, 0.5f, MF_ENC_LINEAR);
    write_flat(pj2(scene, "relight/sky.exr"), 8, 4, 3, 1.0f, MF_ENC_LINEAR);
    write_flat(pj2(scene, "relight/sky/r_0.exr"), 8, 8, 4, 0.25f, MF_ENC_LINEAR);
    CHECK_ERR(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, NULL), "relight/sky/r_0.exr: relit GT is 8x8, the view image");
    CHECK_MSG(strstr(mf_error(), "test/r_0.png is 16x16") != NULL, "message: %s", mf_error());
    /* all sizes right: scored */
    write_flat(pj2(scene, "relight/sky/r_0.exr"), 16, 16, 4, 0.25f, MF_ENC_LINEAR);
    int ex = 0;
    CHECK_OK(ev_eval_scene(scene, res, "m", "d", "s", &o, &t, NULL, &ex));
    CHECK_MSG(ev_table_stat(&t, "m", "d", "relit_psnr").n == 1, "excluded %d, records %zu", ex, t.n);
    CHECK(ev_table_stat(&t, "m", "d", "albedo_psnr").n == 1);
    ev_table_free(&t);
}

/* Replaces the first occurrence of `from` after `after` in buf (same length) in place. */
static int patch(char *buf, size_t len, const char *after, const char *from, const char *to) {
    char *a = memmem(buf, len, after, strlen(after));
    if (!a) return 0;
    char *f = memmem(a, len - (size_t)(a - buf), from, strlen(from));
    if (!f || strlen(from) != strlen(to)) return 0;
    memcpy(f, to, strlen(to));
    return 1;
}

/* An MFCK file with no tensors and the given meta text (header only). */
static void write_meta_only(const char *path, const char *meta, uint32_t mlen_claimed) {
    FILE *f = fopen(path, "wb");
    if (!f) return;
    uint32_t hdr[3] = {1u, 0u, mlen_claimed};
    fwrite("MFCK", 1, 4, f);
    fwrite(hdr, 4, 3, f);
    fwrite(meta, 1, strlen(meta), f);
    fclose(f);
}

/* (d) Prior weights whose meta says groups or heads = 0 divided by zero while the model was
 * built, before the checksum was checked; a meta length from the header was allocated before it
 * was compared with the file. Now every configuration number is range-checked first, by name. */
MF_TEST(hostile_prior_meta) {
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    MfPrior *p = NULL, *q = NULL;
    CHECK_OK(mf_prior_new(&p, &cfg));
    if (!p) return;
    const char *good = mf_test_path("hostile_prior_good.mfck");
    const char *bad = mf_test_path("hostile_prior_bad.mfck");
    CHECK_OK(mf_prior_save(p, good, NULL));
    mf_prior_free(p);
    CHECK_OK(mf_prior_load(good, &q));
    mf_prior_free(q);
    q = NULL;
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    if (!d) return;
    /* groups = 0 in the denoiser (the checksum no longer matches either: the meta is checked first) */
    CHECK(patch(d, len, "\"dn\":", "\"groups\":2", "\"groups\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: meta: dn.groups = 0 is out of range");
    CHECK(patch(d, len, "\"dn\":", "\"groups\":0", "\"groups\":2"));
    /* heads = 0 */
    CHECK(patch(d, len, "\"dn\":", "\"heads\":2", "\"heads\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: meta: dn.heads = 0 is out of range");
    CHECK(patch(d, len, "\"dn\":", "\"heads\":0", "\"heads\":2"));
    /* autoencoder groups = 0 */
    CHECK(patch(d, len, "\"ae\":", "\"groups\":2", "\"groups\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "meta: ae.groups = 0 is out of range");
    CHECK(patch(d, len, "\"ae\":", "\"groups\":0", "\"groups\":2"));
    /* a meta length far beyond the file: refused before allocating */
    uint32_t huge = 0xF0000000u;
    memcpy(d + 12, &huge, 4);
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "meta length 4026531840 exceeds the file");
    free(d);
    /* channel counts beyond any model, and a valid meta whose weights are not in the file */
    const char *m1 = "{\"format\":\"mf-prior\",\"version\":1,\"resolution\":16,\"downsample\":4,\"latent_channels\":4,"
                     "\"latent_scale\":1,\"ae\":{\"c1\":4,\"c2\":8,\"groups\":2},\"dn\":{\"c1\":8,\"c2\":1e12,\"ct\":16,"
                     "\"tfreq\":8,\"heads\":2,\"groups\":2,\"i1\":4,\"i2\":4,\"i3\":8}}";
    write_meta_only(bad, m1, (uint32_t)strlen(m1));
    CHECK_ERR(mf_prior_load(bad, &q), "meta: dn.c2 = 1e+12 is out of range");
    const char *m2 = "{\"format\":\"mf-prior\",\"version\":1,\"resolution\":16,\"downsample\":4,\"latent_channels\":4,"
                     "\"latent_scale\":1,\"ae\":{\"c1\":4,\"c2\":8,\"groups\":2},\"dn\":{\"c1\":8,\"c2\":8,\"ct\":16,"
                     "\"tfreq\":8,\"heads\":2,\"groups\":2,\"i1\":4,\"i2\":4,\"i3\":8}}";
    write_meta_only(bad, m2, (uint32_t)strlen(m2));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: truncated: the meta's configuration has");
    CHECK(q == NULL);
    /* the library's own guard, for configurations built in code */
    cfg.dn.heads = 0;
    CHECK_ERR(mf_prior_new(&p, &cfg), "heads 0");
}

/* Item 2: a path naming a directory where a file is expected was read as a file of LONG_MAX
 * bytes ("out of memory (9223372036854775807 bytes)"); now every reader refuses it by name. */
MF_TEST(hostile_directory_as_file) {
    char dir[512];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_dirs/looks_like.png"));
    CHECK_OK(mf_mkdirs(dir));
    char *d = NULL;
    size_t len = 0;
    CHECK_ERR(mf_read_file(dir, &d, &len), "looks_like.png: is a directory, expected a file");
    MfImage im = {0};
    CHECK_ERR(mf_image_read(dir, MF_ENC_SRGB, &im), "looks_like.png: is a directory, expected a file");
    MfExrImage ex = {0};
    CHECK_ERR(mf_exr_read(dir, &ex), "looks_like.png: is a directory, expected a file");
    MfMesh m = {0};
    CHECK_ERR(mf_obj_read(dir, &m), "looks_like.png: is a directory, expected a file");
    MfScene sc = {0};
    CHECK_ERR(mf_scene_load(dir, &sc), "is a directory, expected a file");
    MfPrior *q = NULL;
    CHECK_ERR(mf_prior_load(dir, &q), "looks_like.png: is a directory, expected a file");
    CHECK_ERR(mf_input_file(mf_test_path("hostile_dirs/none.png"), NULL), "none.png: no such file");
    unsigned long long sz = 1;
    put(mf_test_path("hostile_dirs/empty.txt"), "");
    CHECK_OK(mf_input_file(mf_test_path("hostile_dirs/empty.txt"), &sz));
    CHECK(sz == 0);

    if (!getenv("MF_BIN")) MF_SKIP("MF_BIN not set");
    char args[4096], err[4096], out[1024];
    snprintf(out, sizeof out, "%s", mf_test_path("hostile_dirs/out"));
    const char *cmds[][2] = {
        {"metrics %s %s", "looks_like.png: is a directory, expected a file"},
        {"render %s -o %s", "looks_like.png: is a directory, expected a file"},
        {"prior %s -o %s", "looks_like.png: is a directory, expected a file"},
    };
    for (int k = 0; k < 3; ++k) {
        snprintf(args, sizeof args, cmds[k][0], dir, out);
        int rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 1, "mf %s: exit %d (expected 1): %s", args, rc, err);
        CHECK_MSG(strstr(err, cmds[k][1]) && !strstr(err, "out of memory"), "mf %s: message %s", args, err);
        CHECK(count_files(out) == 0);
    }
}

/* CRC-32 as PNG chunks use it (ISO 3309, reflected 0xEDB88320). */
static uint32_t crc32_png(const unsigned char *p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
}

/* Reads path, finds the EXR header attribute `name` of type box2i and sets its max corner. */
static int patch_exr_box(char *buf, size_t len, const char *name, int32_t xmax, int32_t ymax) {
    char key[64];
    size_t kl = (size_t)snprintf(key, sizeof key, "%s", name) + 1; /* with the NUL */
    char *a = memmem(buf, len, key, kl);
    if (!a || (size_t)(a - buf) + kl + 6 + 4 + 16 > len || memcmp(a + kl, "box2i", 6)) return 0;
    char *v = a + kl + 6 + 4; /* name\0 type\0 size(4) value: xmin ymin xmax ymax */
    memcpy(v + 8, &xmax, 4);
    memcpy(v + 12, &ymax, 4);
    return 1;
}

/* Item 2: an EXR of a few KB whose data window asks for gigabytes was allocated before anything
 * was checked; now the header's size is checked against the file's length first. */
MF_TEST(hostile_exr_header_size) {
    const char *good = mf_test_path("hostile_small.exr"), *bad = mf_test_path("hostile_huge_window.exr");
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 16, 16, 2));
    CHECK_OK(mf_image_write(good, &im, MF_ENC_LINEAR, 32));
    mf_image_free(&im);
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    if (!d) return;
    CHECK(len < 16384);
    /* 30000 x 30000 x 2 channels of float: 7.2 GB */
    CHECK(patch_exr_box(d, len, "dataWindow", 29999, 29999));
    CHECK(patch_exr_box(d, len, "displayWindow", 29999, 29999));
    CHECK_OK(mf_write_file(bad, d, len));
    free(d);
    /* OpenImageIO's EXR reader itself stops at the missing chunk table; ours must not allocate first */
    CHECK_ERR(mf_image_read(bad, MF_ENC_LINEAR, &im), "hostile_huge_window.exr");
    CHECK(im.data == NULL);
    MfExrImage ex = {0};
    CHECK_ERR(mf_exr_read(bad, &ex), "hostile_huge_window.exr: header asks for 30000x30000 x 2 channels (7200000000 bytes");
    CHECK(ex.data == NULL);
    /* a PNG whose IHDR (CRC fixed) says 30000 x 30000 RGBA: the OpenImageIO path allocated 14.4 GB
     * of floats from the header before decoding a row */
    const char *png = mf_test_path("hostile_small.png"), *bpng = mf_test_path("hostile_huge_ihdr.png");
    CHECK_OK(mf_image_alloc(&im, 16, 16, 4));
    CHECK_OK(mf_image_write(png, &im, MF_ENC_SRGB, 8));
    mf_image_free(&im);
    CHECK_OK(mf_read_file(png, &d, &len));
    if (d && len > 33 && !memcmp(d + 12, "IHDR", 4)) {
        unsigned char *u = (unsigned char *)d;
        u[16] = 0, u[17] = 0, u[18] = 0x75, u[19] = 0x30; /* width 30000, big-endian */
        u[20] = 0, u[21] = 0, u[22] = 0x75, u[23] = 0x30;
        uint32_t crc = crc32_png(u + 12, 17);
        u[29] = (unsigned char)(crc >> 24), u[30] = (unsigned char)(crc >> 16), u[31] = (unsigned char)(crc >> 8), u[32] = (unsigned char)crc;
        CHECK_OK(mf_write_file(bpng, d, len));
        CHECK_ERR(mf_image_read(bpng, MF_ENC_SRGB, &im), "hostile_huge_ihdr.png: header asks for 30000x30000 x 4 channels");
        CHECK(im.data == NULL);
    } else {
        CHECK_MSG(0, "%s: not a PNG with IHDR first", png);
    }
    free(d);
    /* the limit itself: floor for small files, proportional above */
    CHECK(mf_image_decode_limit(100) == MF_IMAGE_DECODE_FLOOR);
    CHECK(mf_image_decode_limit(1ull << 20) == (1ull << 20) * MF_IMAGE_DECODE_RATIO);
    CHECK_OK(mf_image_check_decode("x.png", 4096, 4096, 4, 300000)); /* 256 MiB from 300 KB: ratio 895 */
    CHECK_ERR(mf_image_check_decode("x.png", 4096, 4096, 4, 3000), "x.png: header asks for 4096x4096 x 4 channels");
}

/* An EXR header attribute of unknown type whose size field says 1.5 GB, in a file of a few hundred
 * bytes: OpenImageIO's reader (OpenEXR's C++ library) allocated the declared size before it found
 * the end of the file (seconds per file under ASan: the fuzz harness's slowest inputs). mf_image_read
 * now parses the header with the C API first, which reads no further than the file goes. */
MF_TEST(hostile_exr_attribute_size) {
    const char *good = mf_test_path("hostile_attr_ok.exr"), *bad = mf_test_path("hostile_attr_big.exr");
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 4, 4, 3));
    CHECK_OK(mf_image_write(good, &im, MF_ENC_LINEAR, 32));
    mf_image_free(&im);
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    if (!d) return;
    /* walk the attributes (name\0 type\0 size value) to the NUL that ends the header */
    size_t at = 8;
    while (at < len && d[at]) {
        size_t nl = strnlen(d + at, len - at) + 1, tl = nl < len - at ? strnlen(d + at + nl, len - at - nl) + 1 : 0;
        int32_t sz = 0;
        if (!tl || at + nl + tl + 4 > len) break;
        memcpy(&sz, d + at + nl + tl, 4);
        at += nl + tl + 4 + (size_t)sz;
    }
    CHECK(at < len && d[at] == 0);
    static const char attr[] = "junk\0mystery\0\0\0\0\0abcd"; /* size patched below */
    size_t alen = sizeof attr - 1;
    char *b = malloc(len + alen);
    if (b && at < len) {
        memcpy(b, d, at);
        memcpy(b + at, attr, alen);
        int32_t big = 1500000000;
        memcpy(b + at + 13, &big, 4);
        memcpy(b + at + alen, d + at, len - at);
        CHECK_OK(mf_write_file(bad, b, len + alen));
        CHECK_ERR(mf_image_read(bad, MF_ENC_LINEAR, &im), "hostile_attr_big.exr: not a readable EXR");
        CHECK(im.data == NULL);
        CHECK_OK(mf_image_read(good, MF_ENC_LINEAR, &im)); /* the pre-check passes a sound file */
        mf_image_free(&im);
    }
    free(b);
    free(d);
}

/* Item 3: two frames whose file_path share a base name wrote the same output file, the second
 * silently replacing the first; now `mf render` and `mf relight` refuse them before writing. */
MF_TEST(hostile_duplicate_output_names) {
    char dir[512], out[1024], args[4096], err[4096];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_dup"));
    CHECK_OK(mf_mkdirs(dir));
    const char *cams =
        "{\"camera_angle_x\": 0.6911, \"frames\": ["
        "{\"file_path\": \"./a/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]},"
        "{\"file_path\": \"./b/r_1\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]},"
        "{\"file_path\": \"./b/r_0.png\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3.5],[0,0,0,1]]}]}";
    put(pj2(dir, "dup_cams.json"), cams);
    put(pj2(dir, "quad.obj"), k_quad);
    char buf[2048];
    snprintf(buf, sizeof buf, k_scene_fmt, "quad.obj", "dup_cams.json");
    put(pj2(dir, "dup.json"), buf);
    MfScene sc = {0};
    CHECK_ERR(mf_scene_load(pj2(dir, "dup.json"), &sc), "dup_cams.json: frames[0] and frames[2] both name the output 'r_0'");
    mf_scene_free(&sc);
    const char *names[3] = {"x", "y", "z"};
    char nm[3][8] = {"x", "y", "x"};
    int i = -1, j = -1;
    CHECK(!mf_find_duplicate_name(names[0], 0, 1, &i, &j));
    CHECK(mf_find_duplicate_name(nm[0], sizeof nm[0], 3, &i, &j) && i == 0 && j == 2);
    CHECK(!mf_find_duplicate_name(nm[0], sizeof nm[0], 2, &i, &j));

    if (!getenv("MF_BIN")) MF_SKIP("MF_BIN not set");
    snprintf(out, sizeof out, "%s/out", dir);
    snprintf(args, sizeof args, "render %s -o %s --png", pj2(dir, "dup.json"), out);
    int rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 1, "mf render with duplicate names: exit %d: %s", rc, err);
    CHECK_MSG(strstr(err, "frames[0] and frames[2] both name the output 'r_0'"), "message: %s", err);
    CHECK(count_files(out) == 0);
    /* mf relight: a result folder and an env map */
    char res[1024];
    snprintf(res, sizeof res, "%s/result", dir);
    CHECK_OK(mf_mkdirs(res));
    put(pj2(res, "mesh.obj"), k_quad);
    write_flat(pj2(res, "albedo.png"), 4, 4, 3, 0.5f, MF_ENC_SRGB);
    write_flat(pj2(res, "orm.png"), 4, 4, 3, 0.5f, MF_ENC_LINEAR);
    write_flat(pj2(dir, "sky.exr"), 8, 4, 3, 1.0f, MF_ENC_LINEAR);
    snprintf(args, sizeof args, "relight %s --env %s --cameras %s -o %s --width 8 --spp 1 --pixel-samples 1", res,
             pj2(dir, "sky.exr"), pj2(dir, "dup_cams.json"), out);
    rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 1, "mf relight with duplicate names: exit %d: %s", rc, err);
    CHECK_MSG(strstr(err, "dup_cams.json: frames[0] and frames[2] both name the output 'r_0'"), "message: %s", err);
    CHECK(count_files(out) == 0);
    /* distinct names: both commands write every view */
    put(pj2(dir, "dup_cams.json"), "{\"camera_angle_x\": 0.6911, \"frames\": ["
        "{\"file_path\": \"./a/r_0\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]},"
        "{\"file_path\": \"./b/r_1\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}");
    rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 0, "mf relight: exit %d: %s", rc, err);
    CHECK(count_files(out) == 2);
}

/* A pid that is not running: a child that has exited and been reaped. */
static long dead_pid(void) {
    pid_t c = fork();
    if (c == 0) _exit(0);
    int st;
    waitpid(c, &st, 0);
    return (long)c;
}

/* Item 3: a killed run left hidden temporaries (".albedo.tmp1234_0.png") that neither a fresh run
 * nor --resume reused or removed; now runs remove those of dead processes on start. */
MF_TEST(hostile_stale_temporaries) {
    char tmp[MF_PATH_MAX];
    CHECK_OK(mf_tmp_path("res/snapshots/albedo.png", tmp, sizeof tmp));
    long pid = 0;
    CHECK(mf_is_tmp_name(strrchr(tmp, '/') + 1, &pid) && pid == (long)getpid());
    CHECK_OK(mf_tmp_path("res/log", tmp, sizeof tmp));
    CHECK(mf_is_tmp_name(strrchr(tmp, '/') + 1, NULL));
    CHECK(mf_is_tmp_name(".a.tmp.b.tmp12_3.exr", &pid) && pid == 12);
    CHECK(!mf_is_tmp_name("albedo.tmp12_3.png", NULL));   /* not hidden */
    CHECK(!mf_is_tmp_name(".albedo.tmp12.png", NULL));    /* no counter */
    CHECK(!mf_is_tmp_name(".albedo.tmpx_3.png", NULL));
    CHECK(!mf_is_tmp_name(".albedo.tmp12_3.png.bak", NULL));
    CHECK(!mf_is_tmp_name(".notes.txt", NULL));

    char dir[512], p[2048];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_stale"));
    CHECK_OK(mf_mkdirs(pj2(dir, "snapshots/iter_00010")));
    long dead = dead_pid();
    char stale1[2048], stale2[2048], live[1024], own[1024];
    snprintf(stale1, sizeof stale1, "%s/.albedo.tmp%ld_0.png", dir, dead);
    snprintf(stale2, sizeof stale2, "%s/snapshots/iter_00010/.env.tmp%ld_7.exr", dir, dead);
    snprintf(live, sizeof live, "%s/.orm.tmp%ld_1.png", dir, (long)getppid());
    snprintf(own, sizeof own, "%s/.kd.tmp%ld_1.png", dir, (long)getpid());
    put(stale1, "x"), put(stale2, "x"), put(live, "x"), put(own, "x");
    put(pj2(dir, ".user_notes.txt"), "keep");
    int removed = 0;
    CHECK_OK(mf_remove_stale_tmp(dir, 0, &removed));
    CHECK(removed == 1 && !mf_file_exists(stale1) && mf_file_exists(stale2));
    CHECK_OK(mf_remove_stale_tmp(dir, 3, &removed));
    CHECK(removed == 2 && !mf_file_exists(stale2));
    CHECK(mf_file_exists(live) && mf_file_exists(own) && mf_file_exists(pj2(dir, ".user_notes.txt")));
    CHECK_OK(mf_remove_stale_tmp(pj2(dir, "missing"), 3, NULL));
    remove(live), remove(own);

    if (!getenv("MF_BIN")) MF_SKIP("MF_BIN not set");
    /* mf recon --resume on a result folder holding a killed run's temporaries */
    char data[1024], out[1024], args[4096], err[4096];
    snprintf(data, sizeof data, "%s/data", dir);
    snprintf(out, sizeof out, "%s/out", dir);
    CHECK_OK(mf_mkdirs(pj2(out, "snapshots/iter_00000")));
    CHECK_OK(mf_mkdirs(data));
    put(pj2(data, "mesh.obj"), k_quad);
    put(pj2(data, "transforms_train.json"),
        "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": "
        "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}");
    write_flat(pj2(data, "train/r_0.png"), 16, 16, 4, 0.5f, MF_ENC_SRGB);
    snprintf(stale1, sizeof stale1, "%s/.albedo.tmp%ld_0.png", out, dead);
    snprintf(stale2, sizeof stale2, "%s/snapshots/iter_00000/.env.tmp%ld_3.exr", out, dead);
    put(stale1, "partial"), put(stale2, "partial");
    snprintf(p, sizeof p, "%s/.keep.txt", out);
    put(p, "user file");
    snprintf(args, sizeof args, "recon %s -o %s --iters 2 --tex-res 16 --env-w 8 --env-h 4 --resume", data, out);
    int rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 0, "mf recon --resume: exit %d: %s", rc, err);
    CHECK_MSG(!mf_file_exists(stale1) && !mf_file_exists(stale2), "stale temporaries survived mf recon --resume");
    CHECK(mf_file_exists(p));
    CHECK(mf_file_exists(pj2(out, "albedo.png")) && mf_file_exists(pj2(out, "env.exr")));
}

/* Item 3: env.exr (and every EXR written through mf_image_write) carried the time of writing in
 * its header (OpenImageIO's capDate), so identical runs differed byte-wise. */
MF_TEST(hostile_exr_bytes_reproducible) {
    const char *a = mf_test_path("hostile_repro_a.exr"), *b = mf_test_path("hostile_repro_b.exr");
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 8, 4, 3));
    for (int i = 0; i < 8 * 4 * 3; ++i) im.data[i] = 0.25f * (float)i;
    CHECK_OK(mf_image_write(a, &im, MF_ENC_LINEAR, 32));
    /* a second later: a time stamp would differ */
    struct timespec ts = {1, 100000000};
    nanosleep(&ts, NULL);
    CHECK_OK(mf_image_write(b, &im, MF_ENC_LINEAR, 32));
    mf_image_free(&im);
    char *da = NULL, *db = NULL;
    size_t la = 0, lb = 0;
    CHECK_OK(mf_read_file(a, &da, &la));
    CHECK_OK(mf_read_file(b, &db, &lb));
    if (da && db) {
        CHECK_MSG(la == lb && !memcmp(da, db, la), "the same image written twice gave different bytes (%zu vs %zu)", la, lb);
        char today[32];
        time_t now = time(NULL);
        strftime(today, sizeof today, "%Y:%m:%d", gmtime(&now));
        CHECK_MSG(!memmem(da, la, today, strlen(today)), "the EXR header holds today's date %s", today);
        strftime(today, sizeof today, "%Y:%m:%d", localtime(&now));
        CHECK_MSG(!memmem(da, la, today, strlen(today)), "the EXR header holds today's date %s", today);
    }
    free(da), free(db);
}

/* Strengths whose squares overflow float (env strength 1e31 ended in "texel not finite", a sun of
 * 1e30 in NaN pixels) and far-away point lights are refused by the field that gives them. */
MF_TEST(hostile_huge_strengths) {
    char dir[512], buf[2048];
    snprintf(dir, sizeof dir, "%s", mf_test_path("hostile_strength"));
    CHECK_OK(mf_mkdirs(dir));
    write_render_scene(dir, "s", k_quad, "2.5");
    write_flat(pj2(dir, "env.exr"), 8, 4, 3, 2.0f, MF_ENC_LINEAR);
    const char *cases[][2] = {
        {"\"env\": {\"file\": \"env.exr\", \"strength\": 1e31}", "env.strength: 1e+31 is out of range"},
        {"\"env\": {\"file\": \"env.exr\", \"strength\": 9e17}", "env.strength: 9e+17 times the brightest texel"},
        {"\"lights\": [{\"type\": \"sun\", \"dir\": [0, 0, 1], \"strength\": 1e30}]", "lights[0].strength: 1e+30 is out of range"},
        {"\"lights\": [{\"type\": \"point\", \"pos\": [0, 0, 1], \"power\": 1e25}]", "lights[0].power: 1e+25 is out of range"},
        {"\"lights\": [{\"type\": \"point\", \"pos\": [0, 3e38, 1], \"power\": 1}]", "lights[0].pos: y = 3e+38 is out of range"},
        {"\"lights\": [{\"type\": \"sun\", \"dir\": [0, 0, 1], \"strength\": 1, \"color\": [1, 1e20, 1]}]", "lights[0].color: 1e+20 is out of range"},
    };
    for (int k = 0; k < 6; ++k) {
        snprintf(buf, sizeof buf, "{\"mesh\": \"s.obj\", %s, \"cameras\": \"s_cams.json\", \"width\": 8, \"height\": 8}\n", cases[k][0]);
        put(pj2(dir, "strength.json"), buf);
        MfScene sc = {0};
        CHECK_ERR(mf_scene_load(pj2(dir, "strength.json"), &sc), cases[k][1]);
        mf_scene_free(&sc);
    }
    /* in range: loads */
    snprintf(buf, sizeof buf, "{\"mesh\": \"s.obj\", \"env\": {\"file\": \"env.exr\", \"strength\": 1e3}, \"lights\": [{\"type\": \"sun\", "
             "\"dir\": [0, 0, 1], \"strength\": 1e6}], \"cameras\": \"s_cams.json\", \"width\": 8, \"height\": 8}\n");
    put(pj2(dir, "strength.json"), buf);
    MfScene sc = {0};
    CHECK_OK(mf_scene_load(pj2(dir, "strength.json"), &sc));
    mf_scene_free(&sc);
}
