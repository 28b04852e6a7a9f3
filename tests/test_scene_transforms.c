/* Tests of mf/scene/mf_transforms: the plain mode of the scene loader and `mf relight`
 * (camera_angle_x required, nothing else read) and MF_TF_CAPTURE of the data set loaders
 * (intrinsics inherited from the root, full file_path, mask_path, scene_name), with messages
 * naming the file and the JSON path under a prefix. */
#include <math.h>
#include <string.h>

#include "core/mf_error.h"
#include "scene/mf_transforms.h"
#include "mf_test.h"

#define M "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]"

static int parse(const char *text, const char *prefix, int flags, MfTransforms *t) {
    cJSON *j = NULL;
    int rc = mf_json_parse("t.json", text, strlen(text), &j);
    if (!rc) rc = mf_transforms_parse("t.json", prefix, j, flags, t);
    cJSON_Delete(j);
    return rc;
}

MF_TEST(scene_transforms_capture) {
    MfTransforms t;
    const char *cap = "{\"fl_x\": 10, \"cx\": 3, \"aabb_scale\": 4, \"frames\": ["
                      "{\"file_path\": \"./images/a:b.png\", \"transform_matrix\": " M ", \"fl_y\": 12, \"mask_path\": \"m/a.png\"},"
                      "{\"file_path\": \"x/c\", \"transform_matrix\": " M ", \"camera_angle_x\": 0.5, \"fl_x\": 20, \"scene_name\": \"s2\"}]}";
    int rc = parse(cap, "", MF_TF_CAPTURE, &t);
    CHECK_MSG(rc == 0, "capture parse: %s", mf_error());
    if (rc) return;
    CHECK(t.n == 2 && isnan(t.camera_angle_x) && t.intr[0] == 10 && isnan(t.intr[1]));
    CHECK(!strcmp(t.frames[0].file_path, "./images/a:b.png") && !strcmp(t.frames[0].name, "a_b"));
    CHECK(!strcmp(t.frames[0].mask_path, "m/a.png") && !t.frames[0].scene_name && isnan(t.frames[0].camera_angle_x));
    CHECK(t.frames[0].intr[0] == 10 && t.frames[0].intr[1] == 12 && t.frames[0].intr[2] == 3 && t.frames[0].c2w[11] == 4);
    CHECK(t.frames[1].intr[0] == 20 && isnan(t.frames[1].intr[1]) && t.frames[1].camera_angle_x == 0.5);
    CHECK(!strcmp(t.frames[1].scene_name, "s2") && !t.frames[1].mask_path);
    mf_transforms_free(&t);
    /* the plain mode needs camera_angle_x at the root, even with fl_x, and reads no intrinsics */
    CHECK_ERR(parse(cap, "", 0, &t), "t.json: camera_angle_x: missing");
    rc = parse("{\"camera_angle_x\": 0.7, \"fl_x\": -3, \"frames\": [{\"transform_matrix\": " M "}]}", "", 0, &t);
    CHECK_MSG(rc == 0, "plain parse: %s", mf_error());
    if (rc) return;
    CHECK(t.n == 1 && t.camera_angle_x == 0.7 && t.frames[0].camera_angle_x == 0.7 && isnan(t.frames[0].intr[0]));
    CHECK(!t.frames[0].file_path && !t.frames[0].name[0]);
    mf_transforms_free(&t);
    /* capture errors: file and JSON path under the prefix */
    CHECK_ERR(parse("{\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": " M "}]}", "cameras.", MF_TF_CAPTURE, &t),
              "t.json: cameras.frames[0].file_path: missing");
    CHECK_ERR(parse("{\"frames\": [{\"file_path\": \"a\", \"transform_matrix\": " M "}]}", "", MF_TF_CAPTURE, &t),
              "t.json: frames[0]: camera_angle_x: missing (and no fl_x)");
    CHECK_ERR(parse("{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"a\", \"transform_matrix\": " M "},"
                    "{\"file_path\": \"b\", \"transform_matrix\": " M ", \"fl_x\": -3}]}", "cameras.", MF_TF_CAPTURE, &t),
              "t.json: cameras.frames[1].fl_x = -3: expected a number in (0, 1e+07]");
    CHECK_ERR(parse("{\"camera_angle_x\": 0.7, \"k2\": 0.1, \"frames\": []}", "cameras.", MF_TF_CAPTURE, &t),
              "t.json: cameras.k2 = 0.1: lens distortion is not supported");
    CHECK_ERR(parse("{\"camera_angle_x\": 0.7, \"frames\": [3]}", "", MF_TF_CAPTURE, &t), "t.json: frames[0]: expected an object");
}
