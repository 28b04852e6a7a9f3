/* Tests of the declarative option tables (mf/io/mf_opts.h) and of the commands built on them:
 * defaults in range and unchanged, parsing and range errors naming option, value and range,
 * config files (every flag is a key; null = not given; deprecated keys), and through the binary
 * ($MF_BIN): --print-config lists every flag of --help and round-trips through --config, an
 * out-of-range value is refused naming the option and range with no file written, --help shows
 * defaults and ranges, the deprecated --spp-sqrt warns but works. */
#include <cJSON.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_eval_opts.h"
#include "fusion/mf_sds_opts.h"
#include "inverse/mf_recon_opts.h"
#include "io/mf_json.h"
#include "io/mf_opts.h"
#include "mf_test.h"
#include "scene/mf_shapes.h"

typedef struct {
    int n;
    float x;
    uint64_t seed;
    int flag;
    const char *name;
    int mode;
    int res;
} Toy;

static const MfOpt k_toy[] = {
    MF_OPT_INT(Toy, n, 3, 1, 10, "count"),
    MF_OPT_FLOAT(Toy, x, 0.5, 0, 2, "weight", .deprecated = "old_x"),
    MF_OPT_U64(Toy, seed, 7, 0, 1e9, "seed"),
    MF_OPT_BOOL(Toy, flag, 0, "a switch"),
    MF_OPT_STR(Toy, name, "a", "a name", .choices = "a|b"),
    MF_OPT_ENUM(Toy, mode, 1, "lo|mid|hi", "a mode"),
    MF_OPT_INT(Toy, res, 0, 1, 100, "size", .unset = "native"),
};
static const MfOptTable k_toy_table = MF_OPT_TABLE("Toy", k_toy);

MF_TEST(opts_toy_table_parse_ranges_json) {
    Toy t;
    memset(&t, 0xff, sizeof t);
    mf_opts_defaults(&k_toy_table, &t);
    CHECK(t.n == 3 && t.x == 0.5f && t.seed == 7 && t.flag == 0 && !strcmp(t.name, "a") && t.mode == 1 && t.res == 0);
    CHECK_OK(mf_opts_check(&k_toy_table, &t));
    char *argv[] = {"toy", "--n", "5", "--old-x", "1.5", "--flag", "--name", "b", "--mode", "hi", "pos", "--res", "64", NULL};
    int argc = 13;
    MfOptBind b = {&k_toy_table, &t};
    MfOptParse p;
    CHECK_OK(mf_opts_parse(&b, 1, argc, argv, 1, &p));
    CHECK(t.n == 5 && t.x == 1.5f && t.flag == 1 && !strcmp(t.name, "b") && t.mode == 2 && t.res == 64);
    CHECK(p.npos == 1 && !strcmp(p.pos[0], "pos"));
    mf_opts_parse_free(&p);
    /* range errors name the option, the value and the range */
    char *bad1[] = {"toy", "--n", "11"}, *bad2[] = {"toy", "--x", "-1"}, *bad3[] = {"toy", "--n", "2.5"}, *bad4[] = {"toy", "--name", "c"},
         *bad5[] = {"toy", "--res", "0"}, *bad6[] = {"toy", "--bogus", "1"}, *bad7[] = {"toy", "--x", "nan"}, *bad8[] = {"toy", "--x"};
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad1, 1, &p), "--n 11: outside the allowed range [1, 10]");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad2, 1, &p), "--x -1: outside the allowed range [0, 2]");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad3, 1, &p), "expected an integer in [1, 10]");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad4, 1, &p), "expected one of a|b");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad5, 1, &p), "--res 0: outside the allowed range [1, 100]");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad6, 1, &p), "unknown option --bogus");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 3, bad7, 1, &p), "--x: value is not finite");
    mf_opts_parse_free(&p);
    CHECK_ERR(mf_opts_parse(&b, 1, 2, bad8, 1, &p), "--x needs a value");
    mf_opts_parse_free(&p);
    /* JSON: keys are the names, the deprecated name works, null means "not given" */
    cJSON *j = NULL;
    const char *txt = "{\"n\": 2, \"old_x\": 0.25, \"flag\": true, \"name\": \"b\", \"mode\": \"lo\", \"res\": null, \"comment\": \"x\"}";
    CHECK_OK(mf_json_parse("t.json", txt, strlen(txt), &j));
    t.res = 50;
    CHECK_OK(mf_opts_apply_json(&b, 1, j, "t.json"));
    CHECK(t.n == 2 && t.x == 0.25f && t.flag == 1 && !strcmp(t.name, "b") && t.mode == 0 && t.res == 0);
    /* to_json writes a config that reads back to the same struct */
    cJSON *o = cJSON_CreateObject();
    mf_opts_to_json(&k_toy_table, &t, o);
    Toy u;
    mf_opts_defaults(&k_toy_table, &u);
    MfOptBind bu = {&k_toy_table, &u};
    CHECK_OK(mf_opts_apply_json(&bu, 1, o, "round trip"));
    CHECK(u.n == t.n && u.x == t.x && u.seed == t.seed && u.flag == t.flag && !strcmp(u.name, t.name) && u.mode == t.mode && u.res == t.res);
    cJSON_Delete(o);
    cJSON_Delete(j);
    const char *bad = "{\"n\": 0}", *unk = "{\"zz\": 1}", *typ = "{\"name\": 3}";
    CHECK_OK(mf_json_parse("b.json", bad, strlen(bad), &j));
    CHECK_ERR(mf_opts_apply_json(&b, 1, j, "b.json"), "b.json: n 0: outside the allowed range [1, 10]");
    cJSON_Delete(j);
    CHECK_OK(mf_json_parse("u.json", unk, strlen(unk), &j));
    CHECK_ERR(mf_opts_apply_json(&b, 1, j, "u.json"), "u.json: unknown option 'zz'");
    cJSON_Delete(j);
    CHECK_OK(mf_json_parse("s.json", typ, strlen(typ), &j));
    CHECK_ERR(mf_opts_apply_json(&b, 1, j, "s.json"), "s.json: name: expected a string");
    cJSON_Delete(j);
    /* usage: default and range on each line */
    MfStrBuf sb = {0};
    mf_opts_usage(&sb, &k_toy_table);
    char *s = mf_sb_take(&sb);
    CHECK(s && strstr(s, "--n N") && strstr(s, "(default 3, range [1, 10])") && strstr(s, "(default native, range [1, 100])") &&
          strstr(s, "--old-x: deprecated alias") && strstr(s, "(lo|mid|hi; default mid)"));
    free(s);
}

/* Every table's defaults lie in their ranges (or are marked "not given"), and no two options of
 * one command share a name. */
MF_TEST(opts_library_tables_consistent) {
    const MfOptTable *tabs[] = {&mf_recon_opt_table, &mf_sds_opt_table, &ev_eval_opt_table};
    for (int t = 0; t < 3; ++t)
        for (int k = 0; k < tabs[t]->n; ++k) {
            const MfOpt *o = &tabs[t]->opts[k];
            CHECK_MSG(o->doc && o->doc[0], "%s: no doc", o->name);
            if (o->type == MF_OPT_STR || o->type == MF_OPT_ENUM) continue;
            CHECK_MSG((o->def >= o->min && o->def <= o->max) || o->unset, "%s: default %g outside [%g, %g]", o->name, o->def, o->min, o->max);
            CHECK_MSG(o->min <= o->max, "%s: empty range", o->name);
        }
    for (int k = 0; k < mf_recon_opt_table.n; ++k)
        CHECK_MSG(!mf_opts_find(&mf_sds_opt_table, mf_recon_opt_table.opts[k].name), "%s in both recon and SDS tables",
                  mf_recon_opt_table.opts[k].name);
}

/* The defaults, once positional initialisers, are unchanged by the move into tables (byte-identical
 * reconstructions depend on it). */
MF_TEST(opts_defaults_unchanged) {
    MfReconOpts o = mf_recon_opts_default();
    CHECK(o.iters == 400 && o.batch == 2 && o.spp_sqrt == 2 && o.pixel_samples == 1 && o.tex_res == 256 && o.env_w == 64 && o.env_h == 32);
    CHECK(o.lr == 0.02f && o.light_lr_scale == 3.0f && o.w_kd_smooth == 0.1f && o.w_orm_smooth == 0.05f && o.w_shading == 0.15f &&
          o.w_spec_ratio == 0.0025f);
    CHECK(o.normal_map == 0 && o.w_nrm_perturb == 0.25f && o.w_nrm_smooth == 0.025f);
    CHECK(o.init_kd == 0.5f && o.init_rough == 0.5f && o.init_metal == 0.25f && o.init_light == 0.5f);
    CHECK(o.denoise == 0 && o.denoise_sigma == 2.0f && o.denoise_decorrelate == 1 && o.snapshot_every == 50 && o.checkpoint_every == 50 && o.seed == 1);
    MfSdsOpts s = mf_sds_opts_default();
    CHECK(s.k_views == 4 && s.lambda_latent == 0.02f && s.lambda_rgb == 0.5f && s.gamma_p == 1.0f && s.gamma_const == 0 && s.guidance == 3.0f &&
          s.t_min == 20 && s.t_max == 980 && s.aov_samples == 4 && s.seed == 7 && s.every == 0);
    EvEvalOpts e = ev_eval_opts_default();
    CHECK(e.spp_sqrt == 4 && e.pixel_samples == 4 && e.align == EV_ALIGN_MEAN && e.seed == 0x5eedULL && e.max_views == 0 && e.max_lights == 0 &&
          !e.mesh_path);
}

/* baselines/nvdiffrecmc.json says it holds the compiled-in defaults: check it. */
MF_TEST(opts_baseline_config_matches_defaults) {
    const char *path = "baselines/nvdiffrecmc.json";
    if (!mf_file_exists(path)) MF_SKIP("baselines/nvdiffrecmc.json not found (run from the repository root)");
    MfReconOpts d = mf_recon_opts_default(), o;
    memset(&o, 0, sizeof o);
    mf_opts_defaults(&mf_recon_opt_table, &o);
    o.iters = -1; /* must come from the file */
    cJSON *j = NULL;
    CHECK_OK(mf_json_load(path, &j));
    MfOptBind b = {&mf_recon_opt_table, &o};
    CHECK_OK(mf_opts_apply_json(&b, 1, j, path));
    cJSON_Delete(j);
    CHECK(memcmp(&o, &d, sizeof o) == 0);
}

/* --- through the binary ---------------------------------------------------------------- */

/* Every flag of `mf CMD --help` is a key of --print-config's JSON, and that JSON is accepted by
 * --config and prints back identically. */
MF_TEST(opts_cli_every_flag_is_a_config_key) {
    MF_NEED_BIN();
    const char *cmds[] = {"recon", "render", "eval", "gen", "relight", "bench-render", "metrics", "prior", "train-prior",
                          "eval-prior", "bench-nn", "bench-prior", "bench-tets", "bench-stability", "compare"};
    const int min_flags[] = {8, 8, 8, 8, 8, 8, 5, 6, 18, 10, 6, 5, 2, 6, 3};
    char err[8192];
    for (int c = 0; c < (int)(sizeof cmds / sizeof cmds[0]); ++c) {
        char help[1024], cfg[1024], again[1024], args[4096];
        mf_test_path_to(help, sizeof help, "opts_help.txt");
        mf_test_path_to(cfg, sizeof cfg, "opts_cfg.json");
        mf_test_path_to(again, sizeof again, "opts_cfg2.json");
        snprintf(args, sizeof args, "%s --help", cmds[c]);
        CHECK(mf_test_run_mf(args, help, err, sizeof err) == 0);
        snprintf(args, sizeof args, "%s --print-config", cmds[c]);
        CHECK_MSG(mf_test_run_mf(args, cfg, err, sizeof err) == 0, "mf %s --print-config: %s", cmds[c], err);
        snprintf(args, sizeof args, "%s --config %s --print-config", cmds[c], cfg);
        CHECK_MSG(mf_test_run_mf(args, again, err, sizeof err) == 0, "mf %s --config (its own --print-config): %s", cmds[c], err);
        char *a = NULL, *b = NULL, *h = NULL;
        cJSON *j = NULL;
        CHECK_OK(mf_read_file(cfg, &a, NULL));
        CHECK_OK(mf_read_file(again, &b, NULL));
        CHECK_OK(mf_read_file(help, &h, NULL));
        CHECK_OK(mf_json_load(cfg, &j));
        CHECK_MSG(a && b && !strcmp(a, b), "mf %s: --config of --print-config's output does not print back the same", cmds[c]);
        int nflags = 0, in_table = 0; /* option lines follow a heading such as "Options ...:" */
        for (char *line = h; line && *line;) {
            char *nl = strchr(line, '\n');
            if (nl) *nl = 0;
            size_t len = strlen(line);
            if (len && line[0] != ' ' && line[len - 1] == ':') in_table = 1;
            const char *f = NULL;
            if (!strncmp(line, "  --", 4)) f = line + 4;
            else if (!strncmp(line, "  -o, --", 8)) f = line + 8;
            if (f && in_table && strncmp(f, "config", 6) && strncmp(f, "print-config", 12)) {
                char key[64];
                int k = 0;
                for (; f[k] && f[k] != ' ' && k < 63; ++k) key[k] = f[k] == '-' ? '_' : f[k];
                key[k] = 0;
                CHECK_MSG(cJSON_GetObjectItem(j, key), "mf %s: flag --%s has no config key", cmds[c], f);
                ++nflags;
            }
            line = nl ? nl + 1 : NULL;
        }
        CHECK_MSG(nflags >= min_flags[c] && nflags == cJSON_GetArraySize(j), "mf %s: %d flags in --help, %d config keys", cmds[c], nflags,
                  cJSON_GetArraySize(j));
        cJSON_Delete(j);
        free(a), free(b), free(h);
    }
}

/* An out-of-range value, on the command line or in a config file, is refused with the option,
 * the value and the range, exit 2, and nothing written. */
MF_TEST(opts_cli_out_of_range_refused_no_file) {
    MF_NEED_BIN();
    char err[8192], args[4096], out[1024], cfg[1024];
    mf_test_path_to(out, sizeof out, "opts_out");
    mf_test_path_to(cfg, sizeof cfg, "opts_bad.json");
    FILE *f = fopen(cfg, "w");
    if (f) fputs("{\"denoise_sigma\": 100}\n", f), fclose(f);
    struct {
        const char *args, *needle;
    } cases[] = {
        {"recon %s/nodata -o %s --lr -1", "--lr -1: outside the allowed range [0, 1]"},
        {"recon %s/nodata -o %s --res 0", "--res 0: outside the allowed range [1, 16384]"},
        {"recon %s/nodata -o %s --max-views -1", "--max-views -1: outside the allowed range [0, 1000000]"},
        {"recon %s/nodata -o %s --spp 65", "--spp 65: outside the allowed range [1, 64]"},
        {"recon %s/nodata -o %s --lambda-rgb -0.5", "--lambda-rgb -0.5: outside the allowed range [0, 1000]"},
        {"recon %s/nodata -o %s --init-light 1e30", "--init-light 1e+30: outside the allowed range [0.01, 1000]"},
        {"recon %s/nodata -o %s --t-min 500 --t-max 100", "--t-min 500 is above --t-max 100"},
        {"recon %s/nodata -o %s --method magic", "--method 'magic': expected one of nvdiffrecmc|materialfusion"},
        {"recon %s/nodata -o %s --config " /* cfg */, "denoise_sigma 100: outside the allowed range [0.1, 8]"},
        {"render %s/scene.json -o %s --spp 65", "--spp 65: outside the allowed range [1, 64]"},
        {"render %s/scene.json -o %s --width 0", "--width 0: outside the allowed range [1, 16384]"},
        {"eval %s --results x -o %s --pixel-samples 0", "--pixel-samples 0: outside the allowed range [1, 256]"},
        {"eval %s --results x -o %s --align median", "--align 'median': expected one of none|mean|lsq"},
        {"gen -o %.0s%s --spp 0", "--spp 0: outside the allowed range [1, 64]"},
        {"gen -o %.0s%s --train 0", "--train 0: outside the allowed range [1, 100000]"},
        {"relight %s --env e.exr --cameras c.json -o %s --spp 100", "--spp 100: outside the allowed range [1, 64]"},
        {"metrics %s/a.png %s/b.png --align median", "--align 'median': expected one of none|mean|lsq"},
        {"prior %s/a.png -o %s --samples 0", "--samples 0: outside the allowed range [1, 10000]"},
        {"eval-prior %s -o %s --steps 1001", "--steps 1001: outside the allowed range [1, 1000]"},
        {"train-prior %s -o %s --batch 0", "--batch 0: outside the allowed range [1, 4096]"},
        {"bench-nn -o %.0s%s --gemm 8", "--gemm 8: outside the allowed range [16, 16384]"},
        {"bench-tets --res 1 %.0s%.0s", "--res 1: outside the allowed range [2, 512]"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        char a[2048];
        snprintf(a, sizeof a, cases[k].args, mf_test_tmpdir(), out);
        if (strstr(cases[k].needle, "denoise_sigma")) snprintf(args, sizeof args, "%s%s", a, cfg);
        else snprintf(args, sizeof args, "%s", a);
        int rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 2, "mf %s: exit %d, expected 2", args, rc);
        CHECK_MSG(strstr(err, cases[k].needle), "mf %s: message '%s' lacks '%s'", args, err, cases[k].needle);
        CHECK_MSG(!mf_file_exists(out), "mf %s: left %s behind", args, out);
    }
}

MF_TEST(opts_cli_help_shows_defaults_and_ranges) {
    MF_NEED_BIN();
    struct {
        const char *cmd, *needle;
    } cases[] = {
        {"recon", "--lr X                   texture learning rate (decays as 10^(-0.0002 it)) (default 0.02, range [0, 1])"},
        {"recon", "--lambda-rgb X           RGB term weight (default 0.5, range [0, 1000])"},
        {"recon", "--spp N                  n: n^2 env-light + n^2 BSDF samples per pixel sample (default 2, range [1, 64]); --spp-sqrt: deprecated alias"},
        {"recon", "--init-light X"},
        {"render", "(default the scene's render.spp_sqrt, else 8, range [1, 64])"},
        {"eval", "--spp N"},
        {"eval", "(none|mean|lsq; default mean)"},
        {"gen", "--r-min X                camera distance, lower end (2.2 / 2.8 cropped no view of 1500 checked) (default 1.5, range [0.1, 100])"},
    };
    char err[256], outf[1024], args[256];
    mf_test_path_to(outf, sizeof outf, "opts_help2.txt");
    char *h = NULL;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        if (k == 0 || strcmp(cases[k].cmd, cases[k - 1].cmd)) { /* one --help per command */
            free(h);
            h = NULL;
            snprintf(args, sizeof args, "%s --help", cases[k].cmd);
            CHECK(mf_test_run_mf(args, outf, err, sizeof err) == 0);
            CHECK_OK(mf_read_file(outf, &h, NULL));
        }
        CHECK_MSG(h && strstr(h, cases[k].needle), "mf %s --help lacks '%s'", cases[k].cmd, cases[k].needle);
    }
    free(h);
}

/* --spp-sqrt and the spp_sqrt config key still work, with a warning naming the new flag. */
MF_TEST(opts_cli_deprecated_alias_warns_but_works) {
    MF_NEED_BIN();
    char err[4096], outf[1024], cfg[1024], args[2048];
    mf_test_path_to(outf, sizeof outf, "opts_dep.json");
    mf_test_path_to(cfg, sizeof cfg, "opts_dep_in.json");
    CHECK(mf_test_run_mf("recon --spp-sqrt 3 --print-config", outf, err, sizeof err) == 0);
    CHECK_MSG(strstr(err, "--spp-sqrt is deprecated: use --spp"), "no deprecation warning: '%s'", err);
    cJSON *j = NULL;
    CHECK_OK(mf_json_load(outf, &j));
    CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(j, "spp")) == 3.0 && !cJSON_GetObjectItem(j, "spp_sqrt"));
    cJSON_Delete(j);
    FILE *f = fopen(cfg, "w");
    if (f) fputs("{\"spp_sqrt\": 4}\n", f), fclose(f);
    snprintf(args, sizeof args, "recon --config %s --print-config", cfg);
    CHECK(mf_test_run_mf(args, outf, err, sizeof err) == 0);
    CHECK_MSG(strstr(err, "key 'spp_sqrt' is deprecated: use 'spp'"), "no deprecation warning: '%s'", err);
    CHECK_OK(mf_json_load(outf, &j));
    CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(j, "spp")) == 4.0);
    cJSON_Delete(j);
}

/* The library checks options against the same table: a program calling mf_recon_new with a
 * bad value gets the option, the value and the range. */
MF_TEST(opts_recon_new_checks_the_table) {
    MfMesh mesh;
    CHECK_OK(mf_shape_uv_sphere(&mesh, mf_v3(0, 0, 0), 0.5f, 8, 4));
    MfReconView v;
    memset(&v, 0, sizeof v);
    MfReconOpts o = mf_recon_opts_default();
    o.tex_res = 2;
    MfRecon *r = NULL;
    CHECK_ERR(mf_recon_new(&mesh, &v, 1, &o, &r), "--tex-res 2: outside the allowed range [4, 8192]");
    o = mf_recon_opts_default();
    o.lr = -1.0f;
    CHECK_ERR(mf_recon_new(&mesh, &v, 1, &o, &r), "--lr -1: outside the allowed range [0, 1]");
    CHECK(r == NULL);
    mf_mesh_free(&mesh);
}
