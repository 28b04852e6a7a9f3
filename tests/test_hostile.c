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

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_obj.h"
#include "scene/mf_camera.h"
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

/* Runs `$MF_BIN args` with stderr captured into err; returns the exit code (-1 when killed by a
 * signal, e.g. an abort inside a library). */
static int run_mf(const char *args, char *err, size_t cap) {
    const char *bin = getenv("MF_BIN");
    char cmd[8192], errf[1024];
    snprintf(errf, sizeof errf, "%s", mf_test_path("hostile_stderr.txt"));
    snprintf(cmd, sizeof cmd, "%s %s >/dev/null 2>%s", bin, args, errf);
    int st = system(cmd);
    err[0] = 0;
    FILE *f = fopen(errf, "r");
    if (f) {
        size_t n = fread(err, 1, cap - 1, f);
        err[n] = 0;
        fclose(f);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
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
    int rc = run_mf(args, err, sizeof err);
    CHECK_MSG(rc == 1, "mf render with a camera at 1e39: exit %d (expected 1): %s", rc, err);
    CHECK_MSG(strstr(err, "farcam_cams.json: frames[0]: transform_matrix: camera position z"), "message: %s", err);
    CHECK(count_files(out) == 0);
    scene = write_render_scene(dir, "farvert", "v 0 0 0\nv 1 0 0\nv 0 1 1e30\nf 1 2 3\n", "2.5");
    snprintf(args, sizeof args, "render %s -o %s", scene, out);
    rc = run_mf(args, err, sizeof err);
    CHECK_MSG(rc == 1, "mf render with a vertex at 1e30: exit %d (expected 1): %s", rc, err);
    CHECK_MSG(strstr(err, "farvert.obj:3: vertex z = 1e+30 is out of range"), "message: %s", err);
    CHECK(count_files(out) == 0);
}
