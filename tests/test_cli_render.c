/* Tests of `mf render` through the binary ($MF_BIN): a small scene renders to multi-layer EXR and
 * PNG; bad inputs (missing file, garbage JSON, non-rigid camera, OBJ index out of range) exit
 * non-zero with a message naming the file and leave no output files. Hostile inputs (issue 15):
 * cameras and vertices at huge coordinates (mf_camera_init, mf_obj_read, then `mf render`), frames
 * whose outputs share a name (mf_scene_load, then `mf render` and `mf relight`). */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_exr.h"
#include "io/mf_obj.h"
#include "scene/mf_camera.h"
#include "scene/mf_scene.h"
#include "mf_test.h"
#include "mf_test_kit.h"

/* Number of entries (other than . and ..) in dir, not recursive; 0 if it does not exist. */
static int count_entries(const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) ++n;
    closedir(d);
    return n;
}

static const char *k_cams =
    "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": "
    "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}";
static const char *k_cams_scaled =
    "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": "
    "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}, {\"file_path\": \"./r_1\", \"transform_matrix\": "
    "[[2,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}";

MF_TEST(render_cli_ok) {
    MF_NEED_BIN();
    char dir[512], scene[1024], out[768], buf[4096], args[4096];
    mf_test_path_to(dir, sizeof dir, "cli_ok");
    CHECK_OK(mf_mkdirs(dir));
    write_render_scene(dir, "scene", k_quad, "2.5"); /* scene.obj, scene_cams.json, scene.json */
    snprintf(scene, sizeof scene, "%s/scene.json", dir);
    snprintf(out, sizeof out, "%s/out", dir);
    snprintf(args, sizeof args, "render %s -o %s --png --width 20 --height 10", scene, out);
    int rc = mf_test_run_mf(args, NULL, buf, sizeof buf);
    CHECK_MSG(rc == 0, "mf render failed (%d): %s", rc, buf);
    CHECK(count_entries(out) == 2);
    snprintf(scene, sizeof scene, "%s/r_0.exr", out);
    MfImage img = {0};
    CHECK_OK(mf_exr_read_layer(scene, "", "RGBA", &img));
    CHECK(img.w == 20 && img.h == 10);
    if (img.data) {
        /* The quad fills the view centre: covered and lit there. */
        float *p = mf_image_px(&img, 10, 5);
        CHECK(p[3] == 1.0f);
        CHECK(p[0] > 0.0f && p[1] > 0.0f);
    }
    mf_image_free(&img);
    const char *layers[4] = {"albedo", "orm", "diffuse", "specular"};
    for (int k = 0; k < 4; ++k) {
        CHECK_OK(mf_exr_read_layer(scene, layers[k], "RGB", &img));
        mf_image_free(&img);
    }
    CHECK_OK(mf_exr_read_layer(scene, "normal", "XYZ", &img));
    mf_image_free(&img);
    CHECK_OK(mf_exr_read_layer(scene, "depth", "Z", &img));
    if (img.data) CHECK_NEAR(mf_image_px(&img, 10, 5)[0], 2.5, 1e-3);
    mf_image_free(&img);

    /* mf metrics scores the multi-layer EXR against itself: the RGBA layer by default (the file
     * has 17 channels; indexing them as colour channels once overran 4-entry arrays), another
     * layer by name; an unknown layer is an error naming the layers the file has. */
    char cmd[4096], line[256];
    snprintf(args, sizeof args, "render %s/scene.json -o %s/big --width 24 --height 16", dir, dir); /* SSIM: >= 11x11 */
    rc = mf_test_run_mf(args, NULL, buf, sizeof buf);
    CHECK_MSG(rc == 0, "mf render failed (%d): %s", rc, buf);
    snprintf(scene, sizeof scene, "%s/big/r_0.exr", dir);
    const char *metric_layers[4] = {"", "--layer albedo", "--layer orm", "--layer normal"};
    for (int k = 0; k < 4; ++k) {
        snprintf(cmd, sizeof cmd, "%s metrics %s %s %s 2>&1", getenv("MF_BIN"), scene, scene, metric_layers[k]);
        FILE *p = popen(cmd, "r");
        double psnr = -1.0;
        while (p && fgets(line, sizeof line, p))
            if (!strncmp(line, "psnr ", 5)) psnr = atof(line + 5);
        int st = p ? pclose(p) : -1;
        CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == 0, "mf metrics r_0.exr r_0.exr %s failed", metric_layers[k]);
        CHECK_MSG(psnr == 100.0, "mf metrics %s: psnr %g, want 100", metric_layers[k], psnr);
    }
    snprintf(args, sizeof args, "metrics %s %s --layer nosuch", scene, scene);
    rc = mf_test_run_mf(args, NULL, buf, sizeof buf);
    CHECK_MSG(rc == 1 && strstr(buf, "no layer 'nosuch'") && strstr(buf, "albedo"), "rc %d: %s", rc, buf);
}

/* Runs a failing render and checks exit code, message and the absence of outputs. */
static void expect_failure(const char *scene, const char *outdir, const char *needle) {
    char args[4096], err[4096];
    snprintf(args, sizeof args, "render %s -o %s", scene, outdir);
    int rc = mf_test_run_mf(args, NULL, err, sizeof err);
    CHECK_MSG(rc == 1, "%s: exit code %d, expected 1", scene, rc);
    CHECK_MSG(strstr(err, needle) != NULL, "message '%s' lacks '%s'", err, needle);
    CHECK_MSG(count_entries(outdir) == 0, "%s: output files left in %s", scene, outdir);
}

MF_TEST(render_cli_bad_inputs) {
    MF_NEED_BIN();
    char dir[512], p[1024], buf[4096], out[1024];
    mf_test_path_to(dir, sizeof dir, "cli_bad");
    CHECK_OK(mf_mkdirs(dir));
    snprintf(out, sizeof out, "%s/out", dir);
    /* missing scene file */
    snprintf(p, sizeof p, "%s/missing_scene.json", dir);
    expect_failure(p, out, "missing_scene.json");
    /* garbage JSON */
    snprintf(p, sizeof p, "%s/garbage.json", dir);
    put(p, "{\"mesh\": \"quad.obj\",\n \"cameras\": [1, 2,,}\n");
    expect_failure(p, out, "garbage.json");
    /* non-rigid camera (second frame scaled) */
    snprintf(p, sizeof p, "%s/quad.obj", dir);
    put(p, k_quad);
    snprintf(p, sizeof p, "%s/scaled.json", dir);
    put(p, k_cams_scaled);
    snprintf(buf, sizeof buf, k_scene_fmt, "quad.obj", "scaled.json");
    snprintf(p, sizeof p, "%s/nonrigid.json", dir);
    put(p, buf);
    expect_failure(p, out, "scaled.json: frames[1]");
    expect_failure(p, out, "rigid");
    /* OBJ with a face index out of range */
    snprintf(p, sizeof p, "%s/transforms.json", dir);
    put(p, k_cams);
    snprintf(p, sizeof p, "%s/badidx.obj", dir);
    put(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    snprintf(buf, sizeof buf, k_scene_fmt, "badidx.obj", "transforms.json");
    snprintf(p, sizeof p, "%s/badobj.json", dir);
    put(p, buf);
    expect_failure(p, out, "badidx.obj");
    /* a bad JSON value names the JSON path */
    snprintf(buf, sizeof buf, k_scene_fmt, "quad.obj", "transforms.json");
    char *m = strstr(buf, "[0, 0.3, 1]");
    if (m) memcpy(m, "[0, 0.3]   ", 11);
    snprintf(p, sizeof p, "%s/badlight.json", dir);
    put(p, buf);
    expect_failure(p, out, "lights[0].dir");
    /* a field of view outside the real limits says them */
    snprintf(p, sizeof p, "%s/widecams.json", dir);
    put(p, "{\"camera_angle_x\": 3.12, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": "
           "[[1,0,0,0],[0,1,0,0],[0,0,1,2.5],[0,0,0,1]]}]}");
    snprintf(buf, sizeof buf, k_scene_fmt, "quad.obj", "widecams.json");
    snprintf(p, sizeof p, "%s/wide.json", dir);
    put(p, buf);
    expect_failure(p, out, "camera_angle_x 3.12 rad is outside (1e-4, 3.1) rad");
    /* an env strength that overflows float is reported as that strength, with the limit */
    MfImage env = {0};
    CHECK_OK(mf_image_alloc(&env, 8, 4, 3));
    for (size_t i = 0; i < 8 * 4 * 3; ++i) env.data[i] = i == 5 ? 100.0f : 1.0f;
    snprintf(p, sizeof p, "%s/env.exr", dir);
    CHECK_OK(mf_image_write(p, &env, MF_ENC_LINEAR, 32));
    mf_image_free(&env);
    snprintf(buf, sizeof buf, k_scene_fmt, "quad.obj", "transforms.json");
    m = strstr(buf, "\"env\": null");
    if (m) {
        char tail[2048];
        snprintf(tail, sizeof tail, "%s", m + strlen("\"env\": null"));
        snprintf(m, sizeof buf - (size_t)(m - buf), "\"env\": {\"file\": \"env.exr\", \"strength\": 9e17}%s", tail);
    }
    snprintf(p, sizeof p, "%s/strong.json", dir);
    put(p, buf);
    expect_failure(p, out, "env.strength: 9e+17 times the brightest texel");
    expect_failure(p, out, "at most 1e+16 for this map");
}

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

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
    mf_test_path_to(dir, sizeof dir, "hostile_coords");
    CHECK_OK(mf_mkdirs(dir));
    snprintf(p, sizeof p, "%s/big.obj", dir);
    put(p, "v 0 0 0\nv 1 0 0\nv 0 3e38 0\nf 1 2 3\n");
    MfMesh m = {0};
    CHECK_ERR(mf_obj_read(p, &m), "big.obj:3: vertex y = 3e+38 is out of range");
    mf_mesh_free(&m);

    MF_NEED_BIN();
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

/* Item 3: two frames whose file_path share a base name wrote the same output file, the second
 * silently replacing the first; now `mf render` and `mf relight` refuse them before writing. */
MF_TEST(hostile_duplicate_output_names) {
    char dir[512], out[1024], args[4096], err[4096];
    mf_test_path_to(dir, sizeof dir, "hostile_dup");
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

    MF_NEED_BIN();
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
