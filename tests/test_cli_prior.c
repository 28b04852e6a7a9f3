/* Tests of the `mf prior` and `mf eval-prior` commands. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "io/mf_ckpt.h"
#include "io/mf_json.h"
#include "nn/mf_nn.h"
#include "prior/mf_prior.h"
#include "prior/mf_prior_train.h"
#include "tests/mf_test.h"
#include "tests/mf_test_prior.h"

/* A tiny prior (tp_tiny_prior) saved as the test file `name`, its path into w (MF_PATH_MAX). */
static void save_tiny_prior(char *w, const char *name) {
    MfPrior *p;
    tp_tiny_prior(&p);
    mf_test_path_to(w, MF_PATH_MAX, name);
    CHECK_OK(mf_prior_save(p, w, NULL));
    mf_prior_free(p);
}

MF_TEST(prior_cli_predicts_maps) {
    MF_NEED_BIN();
    char w[MF_PATH_MAX], img[MF_PATH_MAX], out[MF_PATH_MAX], args[8 * MF_PATH_MAX], f[MF_PATH_MAX], err[16384];
    save_tiny_prior(w, "prior_cli.mfck");
    mf_test_path_to(img, sizeof img, "prior_cli_in.png");
    mf_test_path_to(out, sizeof out, "prior_cli_out");
    MfImage im = {0};
    mf_image_alloc(&im, 32, 32, 4);
    for (int y = 8; y < 24; ++y)
        for (int x = 8; x < 24; ++x) {
            float *px = mf_image_px(&im, x, y);
            px[0] = 0.5f, px[1] = 0.3f, px[2] = 0.2f, px[3] = 1.0f;
        }
    CHECK_OK(mf_image_write(img, &im, MF_ENC_SRGB, 8));
    mf_image_free(&im);
    snprintf(args, sizeof args, "prior '%s' -o '%s' --weights '%s' --samples 2 --steps 4 --mv '%s' '%s' '%s'", img, out, w, img, img,
             img);
    char so[MF_PATH_MAX];
    mf_test_path_to(so, sizeof so, "prior_cli_stdout.txt");
    CHECK_MSG(mf_test_run_mf(args, so, err, sizeof err) == 0, "mf %s: %s", args, err);
    /* the printed per-view means are those of the written orm_K.png inside its mask (8-bit: 1/255) */
    char *txt = NULL;
    size_t tn = 0;
    CHECK_OK(mf_read_file(so, &txt, &tn));
    for (int v = 0; v < 4 && txt; ++v) {
        char key[32], f2[MF_PATH_MAX], nm[32];
        snprintf(key, sizeof key, "view %d: mean roughness", v);
        const char *l = strstr(txt, key);
        double pr = -1, pm = -1;
        CHECK_MSG(l && sscanf(l + strlen(key), " %lf, metallic %lf", &pr, &pm) == 2, "no '%s' line in: %s", key, txt);
        if (v) snprintf(nm, sizeof nm, "orm_%d.png", v);
        else snprintf(nm, sizeof nm, "orm.png");
        mf_path_join(f2, sizeof f2, out, nm);
        MfImage o = {0};
        CHECK_OK(mf_image_read(f2, MF_ENC_LINEAR, &o));
        double r = 0, m = 0;
        int n = 0;
        for (int i = 0; o.data && i < o.w * o.h; ++i)
            if (o.data[i * 4 + 3] >= 0.5f) r += o.data[i * 4 + 1], m += o.data[i * 4 + 2], ++n;
        CHECK_MSG(n == 64 && fabs(r / n - pr) < 0.003 && fabs(m / n - pm) < 0.003, "view %d: printed %.4f %.4f, file %.4f %.4f (%d px)", v,
                  pr, pm, n ? r / n : 0, n ? m / n : 0, n);
        mf_image_free(&o);
    }
    free(txt);
    const char *names[4] = {"albedo.png", "orm.png", "albedo_3.png", "orm_3.png"};
    for (int k = 0; k < 4; ++k) {
        mf_path_join(f, sizeof f, out, names[k]);
        MfImage r = {0};
        CHECK_OK(mf_image_read(f, MF_ENC_LINEAR, &r));
        CHECK(r.w == 16 && r.h == 16 && r.c == 4);
        if (r.data) {
            CHECK(mf_image_px(&r, 0, 0)[3] == 0.0f && mf_image_px(&r, 8, 8)[3] == 1.0f);
            if (k % 2) CHECK(mf_image_px(&r, 8, 8)[0] == 1.0f); /* ORM: R = 1 */
        }
        mf_image_free(&r);
    }
    /* mf train-prior end to end on the tiny model */
    char ck[MF_PATH_MAX], lc[MF_PATH_MAX];
    mf_test_path_to(ck, sizeof ck, "prior_cli_ck");
    mf_test_path_to(lc, sizeof lc, "prior_cli_loss.csv");
    snprintf(args, sizeof args, "train-prior '%s' -o '%s' --tiny --ae-steps 3 --steps 3 --batch 4 --loss-csv '%s'", tp_synth_dir(), ck,
             lc);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    mf_path_join(f, sizeof f, ck, "prior.mfck");
    MfPrior *t = NULL;
    CHECK_OK(mf_prior_load(f, &t));
    mf_prior_free(t);
    CHECK(mf_file_exists(lc));
    /* trained on from those weights (--init): a denoiser-only loss curve, still plotted */
    char ck2[MF_PATH_MAX], lc2[MF_PATH_MAX], png[MF_PATH_MAX];
    mf_test_path_to(ck2, sizeof ck2, "prior_cli_ck_init");
    mf_test_path_to(lc2, sizeof lc2, "prior_cli_loss_init.csv");
    mf_test_path_to(png, sizeof png, "prior_cli_loss_init.png");
    snprintf(args, sizeof args, "train-prior '%s' -o '%s' --init '%s' --ae-steps 0 --steps 3 --batch 4 --lr-cosine --loss-csv '%s'",
             tp_synth_dir(), ck2, f, lc2);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    CHECK(mf_file_exists(lc2) && mf_file_exists(png));
    snprintf(args, sizeof args, "train-prior '%s'", tp_synth_dir());
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) != 0); /* no -o */
    /* missing weights: a clear message naming the file and the expected version */
    snprintf(args, sizeof args, "prior '%s' -o '%s' --weights '%s/nope.mfck'", img, out, out);
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) != 0);
    const char *named = strstr(err, "nope.mfck");
    CHECK_MSG(named && strstr(named, "MFCK version 1"), "missing weights: %s", err);
}

MF_TEST(prior_eval_cli_writes_table) {
    MF_NEED_BIN();
    char w[MF_PATH_MAX], dir[MF_PATH_MAX], out[MF_PATH_MAX], f[MF_PATH_MAX], args[6 * MF_PATH_MAX], err[16384];
    save_tiny_prior(w, "prior_eval.mfck");
    /* a test-2d-like split: 2 objects x 2 views */
    mf_test_path_to(dir, sizeof dir, "prior_eval_t2d");
    tp_write_synth(dir, 4, 16, 9);
    const char *man = "{\"split\":\"test-2d\",\"resolution\":16,\"count\":4,\"seed\":9,\"objects\":2,\"views_per_object\":2}";
    mf_path_join(f, sizeof f, dir, "manifest.json");
    CHECK_OK(mf_write_file(f, man, strlen(man)));
    mf_test_path_to(out, sizeof out, "prior_eval_out");
    snprintf(args, sizeof args, "eval-prior '%s' -o '%s' --weights '%s' --train '%s' --samples 2 --steps 3", dir, out, w, tp_synth_dir());
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    mf_path_join(f, sizeof f, out, "table2d.md");
    char *txt = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(f, &txt, &len));
    CHECK(txt && strstr(txt, "StableMaterialMV") && strstr(txt, "Retinex") && strstr(txt, "Train-mean ORM") &&
          strstr(txt, "2 objects x 2 views"));
    free(txt);
    EvTable t;
    ev_table_init(&t);
    mf_path_join(f, sizeof f, out, "table2d.csv");
    CHECK_OK(ev_table_read_csv(&t, f));
    /* 4 views: SM and MV 5 metrics + 2 channel MSEs each, input and Retinex 3 (albedo), mean ORM 2 + 2 */
    CHECK_MSG(t.n == 4 * (7 + 7 + 3 + 3 + 4), "%zu records", t.n);
    CHECK(ev_table_stat(&t, "Train-mean ORM", "test-2d", "metal_mse").n == 4);
    mf_path_join(f, sizeof f, out, "table2d.json");
    cJSON *js = NULL;
    CHECK_OK(mf_json_load(f, &js));
    const char *jw = NULL;
    double tr = -1, tm = -1;
    CHECK_OK(mf_json_string(f, "", js, "weights", &jw));
    CHECK_MSG(jw && !strcmp(jw, w), "table2d.json weights '%s', ran '%s'", jw ? jw : "", w);
    CHECK_OK(mf_json_number(f, "", js, "trust_roughness", &tr));
    CHECK_OK(mf_json_number(f, "", js, "trust_metallic", &tm));
    CHECK(tr >= 0 && tr <= 1 && tm >= 0 && tm <= 1);
    cJSON_Delete(js);
    EvStat a = ev_table_stat(&t, "Input image", "test-2d", "albedo_psnr");
    CHECK(a.n == 4 && a.mean > 5);
    ev_table_free(&t);
    /* a wrong resolution is refused with a message */
    mf_test_path_to(dir, sizeof dir, "prior_eval_t2d_12");
    tp_write_synth(dir, 4, 12, 9);
    mf_path_join(f, sizeof f, dir, "manifest.json");
    CHECK_OK(mf_write_file(f, man, strlen(man)));
    snprintf(args, sizeof args, "eval-prior '%s' -o '%s' --weights '%s' --train '%s'", dir, out, w, tp_synth_dir());
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) != 0);
    CHECK_MSG(strstr(err, "prior works at 16"), "wrong resolution: %s", err);
}

/* eval-prior on the objects of a 3D split (mf gen --split tiny, 32 px, at the tiny prior's 16 px):
 * records per view "<scene>/<view>" under the split folder's name, objects.csv holds each object's
 * mean over its views, and asking for more views than a scene has is refused naming the scene. */
MF_TEST(prior_eval_cli_scenes) {
    MF_NEED_BIN();
    char w[MF_PATH_MAX], dir[MF_PATH_MAX], out[MF_PATH_MAX], f[MF_PATH_MAX], args[6 * MF_PATH_MAX], err[16384];
    save_tiny_prior(w, "prior_eval3d.mfck");
    mf_test_path_to(dir, sizeof dir, "prior_eval3d");
    snprintf(args, sizeof args, "gen --split tiny --scenes 2 -o '%s'", dir);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    mf_test_path_to(out, sizeof out, "prior_eval3d_out");
    snprintf(args, sizeof args, "eval-prior '%s' -o '%s' --weights '%s' --train '%s' --views 2 --samples 1 --steps 2 --no-mv",
             dir, out, w, tp_synth_dir());
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    EvTable t, o;
    ev_table_init(&t), ev_table_init(&o);
    mf_path_join(f, sizeof f, out, "table2d.csv");
    CHECK_OK(ev_table_read_csv(&t, f));
    mf_path_join(f, sizeof f, out, "objects.csv");
    CHECK_OK(ev_table_read_csv(&o, f));
    CHECK(ev_table_stat(&t, "Retinex", "prior_eval3d", "albedo_psnr").n == 4);
    CHECK(ev_table_stat(&o, "Retinex", "prior_eval3d", "albedo_psnr").n == 2);
    double v0 = 0, v1 = 0, ob = 0;
    CHECK(ev_table_find(&t, "StableMaterial", "prior_eval3d", "001_vase/r_000", "orm_psnr", &v0));
    CHECK(ev_table_find(&t, "StableMaterial", "prior_eval3d", "001_vase/r_001", "orm_psnr", &v1));
    CHECK(ev_table_find(&o, "StableMaterial", "prior_eval3d", "001_vase", "orm_psnr", &ob));
    CHECK_NEAR(ob, 0.5 * (v0 + v1), 1e-6 * (1 + fabs(ob)));
    CHECK(v0 != v1); /* two different views */
    ev_table_free(&t), ev_table_free(&o);
    snprintf(args, sizeof args, "eval-prior '%s' -o '%s' --weights '%s' --train '%s' --views 50 --samples 1 --steps 2 --no-mv",
             dir, out, w, tp_synth_dir());
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) != 0);
    CHECK_MSG(strstr(err, "000_cup") && strstr(err, "--views asks for 50"), "too many views: %s", err);
}

/* mf bench-prior (tiny model, one round): one column per conv backend of the build, both measured in
 * the same rounds in a DNNL build. No timing asserts. */
MF_TEST(prior_bench_cli_backend_columns) {
    MF_NEED_BIN();
    char w[MF_PATH_MAX], out[MF_PATH_MAX], args[4 * MF_PATH_MAX], err[16384];
    save_tiny_prior(w, "bench_prior.mfck");
    mf_test_path_to(out, sizeof out, "bench_prior.md");
    snprintf(args, sizeof args, "bench-prior --weights '%s' --batch 2 --reps 1 --gemm 64 -o '%s'", w, out);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    char *md = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(out, &md, &len));
    MfNnBackend was = mf_nn_backend();
    int dnnl = mf_nn_set_backend(MF_NN_DNNL) == MF_OK; /* the test binary is built like mf */
    mf_nn_set_backend(was);
    const char *head = dnnl ? "| measurement | blas | dnnl |" : "| measurement | blas |\n";
    CHECK_MSG(md && strstr(md, head), "bench-prior report lacks '%s'", head);
    const char *row = md ? strstr(md, "| denoiser + image encoder training step, batch 2 |") : NULL;
    int cells = 0;
    for (const char *c = row; c && *c && *c != '\n'; ++c) cells += *c == '|';
    CHECK_MSG(cells == (dnnl ? 4 : 3), "denoiser row has %d cell borders", cells);
    free(md);
}
