/* Tests of mf/core/mf_fs: atomic writes, reads, temporary names, extensions. Hostile inputs
 * (issue 15): a directory given where a file is expected, refused by mf_read_file and
 * mf_input_file and so by every reader (image, EXR, OBJ, scene, prior) and command that uses
 * them; temporaries of killed runs found (mf_is_tmp_name) and removed (mf_remove_stale_tmp, also
 * by `mf recon --resume`). */
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "io/mf_obj.h"
#include "prior/mf_prior.h"
#include "scene/mf_scene.h"
#include "mf_test.h"
#include "mf_test_kit.h"

MF_TEST(core_fs_atomic_write) {
    const char *p = mf_test_path("sub/dir/file.txt");
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_write_file(p, "hello", 5));
    char *d = NULL;
    size_t n = 0;
    CHECK_OK(mf_read_file(p, &d, &n));
    CHECK(n == 5 && d && !strcmp(d, "hello"));
    free(d);
    CHECK_ERR(mf_read_file(mf_test_path("missing.txt"), &d, &n), "missing.txt");
    char tmp[MF_PATH_MAX], ext[8];
    CHECK_OK(mf_tmp_path("a/b.png", tmp, sizeof tmp));
    mf_path_ext(tmp, ext, sizeof ext);
    CHECK(!strcmp(ext, "png"));
    CHECK(!strncmp(tmp, "a/.b.tmp", 8));
}

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

/* Item 2: a path naming a directory where a file is expected was read as a file of LONG_MAX
 * bytes ("out of memory (9223372036854775807 bytes)"); now every reader refuses it by name. */
MF_TEST(hostile_directory_as_file) {
    char dir[512];
    mf_test_path_to(dir, sizeof dir, "hostile_dirs/looks_like.png");
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

    MF_NEED_BIN();
    char args[4096], err[4096], out[1024];
    mf_test_path_to(out, sizeof out, "hostile_dirs/out");
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
    mf_test_path_to(dir, sizeof dir, "hostile_stale");
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

    MF_NEED_BIN();
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

/* mf_remove_tree (mf gen --layout nerf-synthetic cuts scenes with it): a nested folder goes, a
 * symbolic link inside it is removed without following it (its target stays), a missing path is
 * no error, and a single file is removed too. */
MF_TEST(core_fs_remove_tree) {
    char root[1024], p[1200], keep[1200];
    mf_test_path_to(root, sizeof root, "remove_tree");
    snprintf(p, sizeof p, "%s/a/b/c", root);
    CHECK_OK(mf_mkdirs(p));
    snprintf(p, sizeof p, "%s/a/b/c/f.txt", root);
    CHECK_OK(mf_write_file(p, "x", 1));
    snprintf(p, sizeof p, "%s/a/g.txt", root);
    CHECK_OK(mf_write_file(p, "y", 1));
    snprintf(keep, sizeof keep, "%s/outside.txt", root);
    CHECK_OK(mf_write_file(keep, "z", 1));
    snprintf(p, sizeof p, "%s/a/b/link", root);
    CHECK(symlink(keep, p) == 0);
    snprintf(p, sizeof p, "%s/a", root);
    CHECK_OK(mf_remove_tree(p));
    CHECK(!mf_file_exists(p) && mf_file_exists(keep));
    CHECK_OK(mf_remove_tree(p)); /* already gone */
    CHECK_OK(mf_remove_tree(keep));
    CHECK(!mf_file_exists(keep));
}
