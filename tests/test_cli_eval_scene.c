/* `mf eval` with DATA a single scene (an instant-ngp capture from `mf gen --layout ingp`, through
 * the `mf` command, MF_BIN): the loader's note "aabb_scale ignored" is said once per eval although
 * the scene is loaded for every method's scores and every grid row; --scenes is honoured (the
 * scene must be listed, else a clear error naming the option and the scene); "cap/" is the scene
 * cap. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_table.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

/* A small capture and two methods' results on it (1 iteration each), made once per test run. */
static int fixture(char cap[1024], char res[1024]) {
    char args[4096], err[16384];
    mf_test_path_to(cap, 1024, "cli_eval_scene/cap");
    mf_test_path_to(res, 1024, "cli_eval_scene/results");
    char done[1100];
    snprintf(done, sizeof done, "%s/m2/cap/mesh.obj", res);
    if (mf_file_exists(done)) return 1;
    snprintf(args, sizeof args, "gen -o %s --layout ingp --views 16 --width 32 --tex-res 32 --spp 1 --seed 3", cap);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    snprintf(args, sizeof args, "recon %s -o %s/m1/cap --iters 1 --tex-res 16 --env-w 16 --env-h 8", cap, res);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    CHECK(mf_test_sh("cp -r '%s/m1' '%s/m2'", res, res) == 0);
    return mf_file_exists(done);
}

static int count(const char *s, const char *needle) {
    int n = 0;
    for (const char *p = strstr(s, needle); p; p = strstr(p + 1, needle)) ++n;
    return n;
}

MF_TEST(cli_eval_scene_note_once) {
    MF_NEED_BIN();
    char cap[1024], res[1024], args[4096], err[16384];
    if (!fixture(cap, res)) return;
    snprintf(args, sizeof args, "eval %s --results %s -o %s", cap, res, mf_test_path("cli_eval_scene/rep_note"));
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    CHECK_MSG(strstr(err, "eval: 2 runs scored"), "mf %s: %s", args, err);
    /* loaded 5 times (2 methods' scores, the ground-truth grid row and 2 method rows): said once */
    int n = count(err, "transforms.json: aabb_scale ignored");
    CHECK_MSG(n == 1, "the aabb_scale note appears %d times: %s", n, err);
}

MF_TEST(cli_eval_scene_scenes_option) {
    MF_NEED_BIN();
    char cap[1024], res[1024], args[4096], err[16384], p[1100];
    if (!fixture(cap, res)) return;
    /* the single scene is not listed: refused by name, nothing written */
    const char *rep = mf_test_path("cli_eval_scene/rep_a");
    snprintf(args, sizeof args, "eval %s --results %s -o %s --methods m1 --no-curves --scenes a,b", cap, res, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 1, "mf %s should fail: %s", args, err);
    CHECK_MSG(strstr(err, "--scenes 'a,b':") && strstr(err, "is one scene, 'cap', which the list does not name"), "mf %s: %s", args,
              err);
    snprintf(p, sizeof p, "%s/per_view.csv", rep);
    CHECK(!mf_file_exists(p));
    /* listed beside a name that is no scene: refused, naming it */
    rep = mf_test_path("cli_eval_scene/rep_x");
    snprintf(args, sizeof args, "eval %s --results %s -o %s --methods m1 --no-curves --scenes x,cap", cap, res, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 1, "mf %s should fail: %s", args, err);
    CHECK_MSG(strstr(err, "is one scene, 'cap'; no scene 'x' there"), "mf %s: %s", args, err);
    CHECK(!mf_file_exists(rep));
    /* listed (and DATA given with a trailing slash): scored as the scene cap */
    rep = mf_test_path("cli_eval_scene/rep_b");
    snprintf(args, sizeof args, "eval %s/ --results %s -o %s --methods m1 --no-curves --scenes cap --dataset d", cap, res, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    snprintf(p, sizeof p, "%s/scenes.csv", rep);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, p));
    double v;
    CHECK_MSG(ev_table_find(&t, "m1", "d", "cap", "nv_psnr", &v), "%s: no nv_psnr row for m1 on cap", p);
    ev_table_free(&t);
}

/* A split whose --scenes list names a scene that does not exist: refused, naming the unknown
 * scenes and the split folder; nothing written. Scene folders need only exist for this check. */
MF_TEST(cli_eval_scene_unknown_in_split) {
    MF_NEED_BIN();
    char split[1024], res[1024], args[4096], err[16384];
    mf_test_path_to(split, sizeof split, "cli_eval_scene/unknown/split");
    mf_test_path_to(res, sizeof res, "cli_eval_scene/unknown/results");
    CHECK(mf_test_sh("mkdir -p '%s/a' '%s/b' '%s/m1/a' && touch '%s/a/transforms_test.json' '%s/b/transforms_test.json'", split, split,
                     res, split, split) == 0);
    const char *rep = mf_test_path("cli_eval_scene/unknown/rep");
    snprintf(args, sizeof args, "eval %s --results %s -o %s --no-curves --scenes a,typo,b,typo2", split, res, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 1, "mf %s should fail: %s", args, err);
    CHECK_MSG(strstr(err, "no scene 'typo', 'typo2' in ") && strstr(err, split), "mf %s: %s", args, err);
    CHECK_MSG(!mf_file_exists(rep), "%s: written although eval failed", rep);
}

/* A 100-character scene name (a split of the capture and a folder of that name) is scored under
 * its full name: scenes.csv, per_view.csv and the image grid's file name, nothing truncated. */
MF_TEST(cli_eval_scene_long_name) {
    MF_NEED_BIN();
    char cap[1024], res[1024], args[4096], err[16384], name[101], p[1400];
    if (!fixture(cap, res)) return;
    memset(name, 'n', 100), name[100] = 0;
    memcpy(name, "long_", 5);
    char split[1024], lres[1024];
    mf_test_path_to(split, sizeof split, "cli_eval_scene/long/split");
    mf_test_path_to(lres, sizeof lres, "cli_eval_scene/long/results");
    CHECK(mf_test_sh("rm -rf '%s' '%s' && mkdir -p '%s' '%s/m1' && cp -r '%s' '%s/%s' && cp -r '%s' '%s/short' && cp -r '%s/m1/cap' '%s/m1/%s'",
                     split, lres, split, lres, cap, split, name, cap, split, res, lres, name) == 0);
    const char *rep = mf_test_path("cli_eval_scene/long/rep");
    snprintf(args, sizeof args, "eval %s --results %s -o %s --no-curves --dataset d", split, lres, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    snprintf(p, sizeof p, "%s/scenes.csv", rep);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, p));
    double v;
    CHECK_MSG(ev_table_find(&t, "m1", "d", name, "nv_psnr", &v), "%s: no nv_psnr row for m1 on the 100-character scene", p);
    ev_table_free(&t);
    char *csv = NULL;
    snprintf(p, sizeof p, "%s/per_view.csv", rep);
    CHECK_OK(mf_read_file(p, &csv, NULL));
    CHECK_MSG(csv && strstr(csv, name), "%s: the full scene name is missing", p);
    free(csv);
    snprintf(p, sizeof p, "%s/grid_%s.png", rep, name);
    CHECK_MSG(mf_file_exists(p), "%s: no grid under the full scene name", p);
}
