/* Tests of mf/io/mf_json: round trip through a file, error messages with line numbers and
 * JSON paths for garbage, missing fields and wrong shapes. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_json.h"
#include "mf_test.h"

MF_TEST(io_json_roundtrip) {
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "camera_angle_x", 0.6911112070083618);
    cJSON_AddStringToObject(root, "name", "tiny");
    const char *odd = "q\"b\\n\nt\tc\x01 \xc3\xa9";
    cJSON_AddStringToObject(root, "odd", odd);
    cJSON_AddItemToObject(root, "empty", cJSON_CreateArray());
    cJSON_AddItemToObject(root, "eobj", cJSON_CreateObject());
    cJSON_AddBoolToObject(root, "flag", 1);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (int f = 0; f < 3; ++f) {
        cJSON *fr = cJSON_CreateObject();
        char fp[32];
        snprintf(fp, sizeof fp, "./train/r_%03d", f);
        cJSON_AddStringToObject(fr, "file_path", fp);
        cJSON *m = cJSON_AddArrayToObject(fr, "transform_matrix");
        for (int r = 0; r < 4; ++r) {
            double row[4];
            for (int c = 0; c < 4; ++c) row[c] = (r == c) + 0.1 * f + 1e-7 * (r * 4 + c);
            cJSON_AddItemToArray(m, cJSON_CreateDoubleArray(row, 4));
        }
        cJSON_AddItemToArray(frames, fr);
    }
    const char *p = mf_test_path("rt.json");
    CHECK_OK(mf_json_save(p, root));
    cJSON *back = NULL;
    CHECK_OK(mf_json_load(p, &back));
    double a = 0;
    const char *s = NULL;
    CHECK_OK(mf_json_number(p, "", back, "camera_angle_x", &a));
    CHECK(a == 0.6911112070083618);
    CHECK_OK(mf_json_string(p, NULL, back, "name", &s));
    CHECK(s && strcmp(s, "tiny") == 0);
    CHECK_OK(mf_json_string(p, NULL, back, "odd", &s));
    CHECK(s && strcmp(s, odd) == 0);
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(back, "flag")));
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(back, "empty")) == 0);
    const cJSON *arr = NULL;
    int n = 0;
    CHECK_OK(mf_json_array(p, "", back, "frames", &arr, &n));
    CHECK(n == 3);
    for (int f = 0; f < n; ++f) {
        char where[32];
        snprintf(where, sizeof where, "frames[%d]", f);
        double m[16];
        float mf[16];
        const cJSON *fr = cJSON_GetArrayItem(arr, f);
        CHECK_OK(mf_json_numbers(p, where, fr, "transform_matrix", 4, 4, m));
        CHECK_OK(mf_json_floats(p, where, fr, "transform_matrix", 4, 4, mf));
        for (int i = 0; i < 16; ++i) {
            CHECK(m[i] == (i / 4 == i % 4) + 0.1 * f + 1e-7 * i);
            CHECK(mf[i] == (float)m[i]);
        }
    }
    double d = 0;
    const char *ds = NULL;
    CHECK_OK(mf_json_number_opt(p, "", back, "aabb_scale", 4.0, &d));
    CHECK(d == 4.0);
    CHECK_OK(mf_json_string_opt(p, "", back, "env", "none", &ds));
    CHECK(ds && strcmp(ds, "none") == 0);
    /* The file is pretty-printed (one member per line) and ends with a newline. */
    char *text = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(p, &text, &len));
    CHECK(text && len > 2 && text[len - 1] == '\n' && strstr(text, "\n\t\"name\":"));
    free(text);
    cJSON_Delete(back);
    cJSON_Delete(root);
}

MF_TEST(io_json_errors) {
    const char *p = mf_test_path("bad.json");
    cJSON *j = NULL;
    CHECK_OK(mf_write_file(p, "{\n  \"a\": 1,\n  \"b\": [1, 2,\n  \"c\": }\n", 36));
    CHECK_ERR(mf_json_load(p, &j), "bad.json: invalid JSON near line 4");
    CHECK(j == NULL);
    CHECK_OK(mf_write_file(p, "{\"a\": 1}\n\n}", 11));
    CHECK_ERR(mf_json_load(p, &j), "invalid JSON near line 3");
    CHECK_ERR(mf_json_load(mf_test_path("missing.json"), &j), "missing.json");
    CHECK_ERR(mf_json_parse("empty.json", "", 0, &j), "empty.json: invalid JSON near line 1");

    const char *good = "{\"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},"
                       " {\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}, {\"file_path\": 3}],"
                       " \"n\": 2.5, \"v\": [1, \"x\", 3]}";
    CHECK_OK(mf_json_parse("t.json", good, strlen(good), &j));
    const cJSON *fr = NULL;
    int n = 0;
    CHECK_OK(mf_json_array("t.json", "", j, "frames", &fr, &n));
    CHECK(n == 3);
    double m[16] = {0};
    CHECK_OK(mf_json_numbers("t.json", "frames[0]", cJSON_GetArrayItem(fr, 0), "transform_matrix", 4, 4, m));
    CHECK(m[15] == 1.0);
    m[15] = 7.0;
    CHECK_ERR(mf_json_numbers("t.json", "frames[1]", cJSON_GetArrayItem(fr, 1), "transform_matrix", 4, 4, m),
              "t.json: frames[1].transform_matrix: expected 4x4 numbers");
    CHECK(m[15] == 7.0); /* untouched on failure */
    CHECK_ERR(mf_json_numbers("t.json", "frames[2]", cJSON_GetArrayItem(fr, 2), "transform_matrix", 4, 4, m),
              "t.json: frames[2].transform_matrix: missing");
    const char *s = NULL;
    CHECK_ERR(mf_json_string("t.json", "frames[2]", cJSON_GetArrayItem(fr, 2), "file_path", &s), "frames[2].file_path: expected a string");
    double v = 0;
    int iv = 0;
    CHECK_ERR(mf_json_number("t.json", "", j, "camera_angle_x", &v), "t.json: camera_angle_x: missing");
    CHECK_ERR(mf_json_int("t.json", "", j, "n", &iv), "n: expected an integer");
    CHECK_ERR(mf_json_numbers("t.json", "", j, "v", 0, 3, m), "t.json: v: expected 3 numbers");
    CHECK_ERR(mf_json_number_opt("t.json", "", j, "frames", 1.0, &v), "frames: expected a finite number");
    CHECK_ERR(mf_json_number("t.json", "frames", fr, "x", &v), "frames: expected an object");
    cJSON_Delete(j);
    /* Overflowing numbers are not finite. */
    CHECK_OK(mf_json_parse("inf.json", "{\"x\": 1e999}", 12, &j));
    CHECK_ERR(mf_json_number("inf.json", "", j, "x", &v), "inf.json: x: expected a finite number");
    cJSON_Delete(j);
}
