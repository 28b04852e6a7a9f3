/* Tests of mf/scene/mf_scene (scene JSON): a full scene with textures, materials by OBJ name,
 * env, lights and inline cameras loads with the documented meaning; errors name file and path;
 * light and env strengths and light positions that overflow float are refused by field (issue 15). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_image.h"
#include "scene/mf_scene.h"
#include "mf_test.h"
#include "mf_test_kit.h"

static void put_in(const char *dir, const char *name, const char *text) {
    char p[1200];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static const char *k_obj =
    "mtllib none.mtl\nv -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "usemtl red\nf 1/1 2/2 3/3\nusemtl blue\nf 1/1 3/3 4/4\n";

MF_TEST(render_scene_load) {
    char dir[1024], p[1200];
    mf_test_path_to(dir, sizeof dir, "scene_load");
    CHECK_OK(mf_mkdirs(dir));
    put_in(dir, "quad.obj", k_obj);
    /* 2x2 sRGB kd texture: 0.5 sRGB -> 0.214 linear; a 1x1 linear ORM PNG */
    MfImage kd, orm, env;
    CHECK_OK(mf_image_alloc(&kd, 2, 2, 3));
    for (int i = 0; i < 12; ++i) kd.data[i] = mf_srgb_to_linear(0.5f);
    snprintf(p, sizeof p, "%s/kd.png", dir);
    CHECK_OK(mf_image_write(p, &kd, MF_ENC_SRGB, 8));
    CHECK_OK(mf_image_alloc(&orm, 1, 1, 3));
    orm.data[0] = 1.0f; orm.data[1] = 0.6f; orm.data[2] = 0.2f;
    snprintf(p, sizeof p, "%s/orm.png", dir);
    CHECK_OK(mf_image_write(p, &orm, MF_ENC_LINEAR, 16));
    CHECK_OK(mf_image_alloc(&env, 8, 4, 3));
    for (int i = 0; i < 8 * 4 * 3; ++i) env.data[i] = 0.5f;
    snprintf(p, sizeof p, "%s/env.exr", dir);
    CHECK_OK(mf_image_write(p, &env, MF_ENC_LINEAR, 32));
    put_in(dir, "scene.json",
        "{\"mesh\": \"quad.obj\",\n"
        " \"material\": {\"kd\": \"kd.png\", \"orm\": \"orm.png\"},\n"
        " \"materials\": {\"blue\": {\"kd\": [0.1, 0.2, 0.9], \"orm\": [0, 0.3, 1]}},\n"
        " \"env\": {\"file\": \"env.exr\", \"strength\": 2},\n"
        " \"lights\": [{\"type\": \"sun\", \"dir\": [0, 0, 2], \"strength\": 3},\n"
        "            {\"type\": \"point\", \"pos\": [1, 2, 3], \"power\": 50, \"color\": [1, 0.5, 0.25]}],\n"
        " \"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [\n"
        "   {\"file_path\": \"./train/r_007\", \"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]},\n"
        "   {\"transform_matrix\": [[0,-1,0,0],[1,0,0,0],[0,0,1,3],[0,0,0,1]]}]},\n"
        " \"width\": 40, \"height\": 30,\n"
        " \"render\": {\"spp_sqrt\": 3, \"pixel_samples\": 2, \"seed\": 17, \"lobes\": \"diffuse\"}}\n");
    snprintf(p, sizeof p, "%s/scene.json", dir);
    MfScene s;
    CHECK_OK(mf_scene_load(p, &s));
    if (mf_error()[0] && s.path == NULL) return;
    CHECK(s.mesh.nt == 2);
    CHECK(s.nmat == 2);
    CHECK(s.nviews == 2 && s.width == 40 && s.height == 30);
    CHECK(!strcmp(s.views[0].name, "r_007"));
    CHECK(!strcmp(s.views[1].name, "view_001"));
    CHECK(s.render.spp_sqrt == 3 && s.render.pixel_samples == 2 && s.render.seed == 17 && s.render.lobes == 1);
    /* material ids follow usemtl order: red = 0 (default material, textures), blue = 1 */
    int red = -1, blue = -1;
    for (int i = 0; i < s.mesh.nmat; ++i) {
        if (!strcmp(s.mesh.mat_names[i], "red")) red = i;
        if (!strcmp(s.mesh.mat_names[i], "blue")) blue = i;
    }
    CHECK(red >= 0 && blue >= 0);
    if (red >= 0 && blue >= 0) {
        CHECK(s.mats[red].kd != NULL && s.mats[red].orm != NULL);
        if (s.mats[red].kd) CHECK_NEAR(s.mats[red].kd->data[0], mf_srgb_to_linear(0.5f), 2e-3);
        if (s.mats[red].orm) CHECK_NEAR(s.mats[red].orm->data[1], 0.6, 2e-4);
        CHECK(s.mats[blue].kd == NULL && s.mats[blue].orm == NULL);
        CHECK_NEAR(s.mats[blue].kd_const.z, 0.9, 1e-6);
        CHECK_NEAR(s.mats[blue].orm_const.z, 1.0, 1e-6);
    }
    CHECK(s.has_env);
    if (s.has_env) CHECK_NEAR(mf_env_eval(&s.env, mf_v3(0, 0, 1)).x, 1.0, 1e-5);
    CHECK(s.nlights == 2);
    if (s.nlights == 2) {
        CHECK(s.lights[0].kind == MF_LIGHT_SUN && fabsf(s.lights[0].dir.z - 1.0f) < 1e-6f && s.lights[0].strength == 3.0f);
        CHECK(s.lights[1].kind == MF_LIGHT_POINT && s.lights[1].pos.y == 2.0f && s.lights[1].color.z == 0.25f);
    }
    MfCamera cam;
    CHECK_OK(mf_scene_camera(&s, 1, 0, 0, &cam));
    CHECK(cam.w == 40 && cam.h == 30);
    CHECK_NEAR(cam.fx, 40.0 / (2.0 * tan(0.35)), 1e-3);
    mf_scene_free(&s);

    /* Errors name the file and the JSON path. */
    put_in(dir, "bad1.json", "{\"mesh\": \"quad.obj\", \"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": [[1,0,0]]}]}}");
    snprintf(p, sizeof p, "%s/bad1.json", dir);
    CHECK_ERR(mf_scene_load(p, &s), "bad1.json: cameras.frames[0].transform_matrix");
    put_in(dir, "bad2.json", "{\"mesh\": \"quad.obj\", \"materials\": {\"green\": {\"kd\": [1,1,1]}}, "
                          "\"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}}");
    snprintf(p, sizeof p, "%s/bad2.json", dir);
    CHECK_ERR(mf_scene_load(p, &s), "bad2.json: materials.green");
    put_in(dir, "bad3.json", "{\"mesh\": \"quad.obj\", \"material\": {\"kd\": \"nope.png\"}, "
                          "\"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}}");
    snprintf(p, sizeof p, "%s/bad3.json", dir);
    CHECK_ERR(mf_scene_load(p, &s), "nope.png");
    put_in(dir, "bad4.json", "{\"mesh\": \"quad.obj\", \"lights\": [{\"type\": \"area\"}], "
                          "\"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}}");
    snprintf(p, sizeof p, "%s/bad4.json", dir);
    CHECK_ERR(mf_scene_load(p, &s), "bad4.json: lights[0].type");
    /* a seed of 2^64 or more was converted to unsigned long long (undefined behaviour, fuzz_scene) */
    put_in(dir, "bad5.json", "{\"mesh\": \"quad.obj\", \"render\": {\"seed\": 1e45}, "
                          "\"cameras\": {\"camera_angle_x\": 0.7, \"frames\": [{\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}}");
    snprintf(p, sizeof p, "%s/bad5.json", dir);
    CHECK_ERR(mf_scene_load(p, &s), "bad5.json: render.seed: expected a non-negative integer below 2^64");
    mf_image_free(&kd);
    mf_image_free(&orm);
    mf_image_free(&env);
}

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

/* Strengths whose squares overflow float (env strength 1e31 ended in "texel not finite", a sun of
 * 1e30 in NaN pixels) and far-away point lights are refused by the field that gives them. */
MF_TEST(hostile_huge_strengths) {
    char dir[512], buf[2048];
    mf_test_path_to(dir, sizeof dir, "hostile_strength");
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
