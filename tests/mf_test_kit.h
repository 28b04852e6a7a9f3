/* Small helpers shared by several test files (header-only): fixture files for the hostile-input
 * tests of issue 15 and a bitwise comparison for the fast-path tests.
 *
 * put:                writes text to path (no folders made).
 * count_files:        number of entries (other than . and ..) in dir, recursively; 0 if it does
 *                     not exist.
 * pj2:                "a/b" in a static rotating buffer (4 slots).
 * write_flat:         a w x h image with c channels, every value v (alpha 1), written to path.
 * k_quad:             OBJ text of a unit quad with UVs, two triangles.
 * k_cams_fmt:         transforms JSON of one camera at z = %s (printf format).
 * k_scene_fmt:        scene JSON naming mesh %s and cameras %s, 16 x 12 px, one sun.
 * write_render_scene: dir/<name>.obj, dir/<name>_cams.json (camera at z = cam_z) and
 *                     dir/<name>.json (the scene); returns the scene path in a static buffer.
 * same3:              bitwise equality of two vectors.
 * (gradient checks: mf_test_grad.h) */
#ifndef MF_TEST_KIT_H
#define MF_TEST_KIT_H

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "core/mf_fs.h"
#include "core/mf_math.h"
#include "io/mf_image.h"

static inline void put(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Number of entries (other than . and ..) in dir, recursively; 0 if it does not exist. Not
 * inline: inlined into a caller, gcc's -Wformat-truncation flags the "%s/%s" below. */
__attribute__((unused)) static int count_files(const char *dir) {
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

static const char *const k_quad =
    "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
static const char *const k_cams_fmt =
    "{\"camera_angle_x\": 0.6911, \"frames\": [{\"file_path\": \"./r_0\", \"transform_matrix\": "
    "[[1,0,0,0],[0,1,0,0],[0,0,1,%s],[0,0,0,1]]}]}";
static const char *const k_scene_fmt =
    "{\"mesh\": \"%s\", \"material\": {\"kd\": [0.5, 0.4, 0.3], \"orm\": [0, 0.6, 0]},\n"
    " \"lights\": [{\"type\": \"sun\", \"dir\": [0, 0.3, 1], \"strength\": 2}],\n"
    " \"env\": null, \"cameras\": \"%s\", \"width\": 16, \"height\": 12,\n"
    " \"render\": {\"spp_sqrt\": 1, \"pixel_samples\": 2}}\n";

/* Writes dir/<name>.obj, dir/<name>_cams.json (camera at z = cam_z) and dir/<name>.json (the
 * scene); returns the scene path in a static buffer. */
static inline const char *write_render_scene(const char *dir, const char *name, const char *obj, const char *cam_z) {
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

/* A w x h image with c channels, every value v (alpha 1), written to path. */
static inline void write_flat(const char *path, int w, int h, int c, float v, MfEncoding enc) {
    MfImage im = {0};
    mf_image_alloc(&im, w, h, c);
    for (size_t i = 0; i < (size_t)w * h; ++i)
        for (int k = 0; k < c; ++k) im.data[i * c + k] = (k == 3) ? 1.0f : v;
    mf_mkdirs_for(path);
    mf_image_write(path, &im, enc, strstr(path, ".exr") ? 32 : 8);
    mf_image_free(&im);
}

static inline const char *pj2(const char *a, const char *b) {
    static char buf[4][MF_PATH_MAX];
    static int k;
    char *o = buf[k++ & 3];
    snprintf(o, MF_PATH_MAX, "%s/%s", a, b);
    return o;
}

static inline int same3(MfVec3 a, MfVec3 b) { return memcmp(&a, &b, sizeof a) == 0; }

#endif
