/* Tests of eval/ev_eval (per-scene evaluation, ev_eval_scene). Novel-view and geometry scores
 * through ev_eval_scene are tested in test_eval_novelview.c and test_eval_geom.c. */
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_load.h"
#include "eval/ev_eval.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "mf_test.h"
#include "mf_test_kit.h"

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

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
