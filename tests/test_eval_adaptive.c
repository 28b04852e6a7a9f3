/* eval/adaptive.py (make bench-adaptive's report): wall-time ratios and PSNR differences paired
 * over scenes, and the issue-16 target verdict per flag set. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "mf_test.h"

/* RESULTS/val-3d/<config>/<scene>/{log.csv, run.json} with the loop's final wall time w and the
 * run.json options opts; a scenes.csv row per metric goes to csv. */
static void fake_run(const char *res, const char *config, const char *scene, double w, const char *opts) {
    char d[1024], p[1100], txt[512];
    snprintf(d, sizeof d, "%s/val-3d/%s/%s", res, config, scene);
    CHECK_OK(mf_mkdirs(d));
    snprintf(p, sizeof p, "%s/log.csv", d);
    snprintf(txt, sizeof txt, "iter,wall_s,loss_total\n1,%.3f,1\n400,%.3f,0.1\n", w / 400.0, w);
    CHECK_OK(mf_write_file(p, txt, strlen(txt)));
    snprintf(p, sizeof p, "%s/run.json", d);
    snprintf(txt, sizeof txt, "{\"options\": %s}", opts);
    CHECK_OK(mf_write_file(p, txt, strlen(txt)));
}

static void add_scores(char *csv, size_t cap, const char *config, const char *scene, double relit, double albedo,
                       double orm) {
    size_t n = strlen(csv);
    snprintf(csv + n, cap - n,
             "%s,val-3d,%s,relit_psnr,%.3f\n%s,val-3d,%s,albedo_psnr,%.3f\n%s,val-3d,%s,orm_psnr,%.3f\n", config, scene,
             relit, config, scene, albedo, config, scene, orm);
}

/* fast: 0.4x the time, 0.1 dB lower (met); slow: the same time, relit 0.5 dB lower (not met);
 * better: 0.9x the time, albedo +1 dB with a tight CI (met, better at <= 1x). */
MF_TEST(eval_adaptive_report) {
    if (mf_test_sh("python3 -c 'import csv, json' >/dev/null 2>&1")) {
        mf_test_skip("no python3");
        return;
    }
    char res[1024], out[1024], csv[8192] = "method,dataset,scene,metric,value\n", p[1100];
    mf_test_path_to(res, sizeof res, "adaptive_results");
    mf_test_path_to(out, sizeof out, "adaptive_out");
    static const char *scene[3] = {"a", "b", "c"};
    static const double base[3] = {20.0, 22.0, 25.0}, jitter[3] = {0.0, 0.02, -0.02};
    for (int i = 0; i < 3; ++i) {
        double b = base[i];
        fake_run(res, "default", scene[i], 100.0 + 10 * i, "{}");
        fake_run(res, "fast", scene[i], 0.4 * (100.0 + 10 * i),
                 "{\"early_stop_result\": {\"stop_iter\": 150}, \"tex_auto\": 1, \"tex_res\": 128}");
        fake_run(res, "slow", scene[i], 100.0 + 10 * i, "{}");
        fake_run(res, "better", scene[i], 0.9 * (100.0 + 10 * i), "{}");
        add_scores(csv, sizeof csv, "default", scene[i], b, b + 1, b - 5);
        add_scores(csv, sizeof csv, "fast", scene[i], b - 0.1, b + 0.9, b - 5.1);
        add_scores(csv, sizeof csv, "slow", scene[i], b - 0.5, b + 1, b - 5);
        add_scores(csv, sizeof csv, "better", scene[i], b, b + 2 + jitter[i], b - 5);
    }
    snprintf(p, sizeof p, "%s/val-3d/scenes.csv", out);
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_write_file(p, csv, strlen(csv)));
    CHECK(mf_test_sh("python3 eval/adaptive.py --results '%s' --out '%s' --splits val-3d --config c.json "
                     "--configs 'fast=--early-stop;slow=--x;better=--y'", res, out) == 0);
    char *md = NULL;
    size_t len;
    snprintf(p, sizeof p, "%s/README.md", out);
    CHECK_OK(mf_read_file(p, &md, &len));
    if (!md) return;
    CHECK(strstr(md, "| val-3d | fast (`--early-stop`) | 3 | 0.40 ± 0.00 | -0.10 ± 0.00 | -0.10 ± 0.00 | -0.10 ± 0.00 | "
                     "**met** (within 0.2 dB at <= 0.5x) |"));
    CHECK(strstr(md, "| val-3d | slow (`--x`) | 3 | 1.00 ± 0.00 | -0.50 ± 0.00 | +0.00 ± 0.00 | +0.00 ± 0.00 | not met |"));
    CHECK(strstr(md, "| val-3d | better (`--y`) | 3 | 0.90 ± 0.00 | +0.00 ± 0.00 | +1.00 ± 0.05 | +0.00 ± 0.00 | "
                     "**met** (better at <= 1x) |"));
    CHECK(strstr(md, "| val-3d | fast | a | 100 / 40 | 0.40 | -0.10 | -0.10 | -0.10 | stop 150, tex 128 |"));
    free(md);
    snprintf(p, sizeof p, "%s/adaptive.csv", out);
    CHECK(mf_file_exists(p));
}
