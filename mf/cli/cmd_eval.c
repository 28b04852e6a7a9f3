/* mf eval: the evaluation protocol over a data set split for one or more methods' result
 * folders: per-view CSV, per-scene records, paper-layout tables (Markdown, LaTeX, HTML), a
 * speed-vs-error plot from the texture snapshots, image grids and reports/index.html. The work
 * is eval/ev_bench.h's; this file parses the options. */
#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "eval/ev_bench.h"
#include "eval/ev_eval_opts.h"
#include "mf_build_info.h"

#define A EvBench
static const MfOpt k_args[] = {
    MF_OPT_STR(A, results, NULL, "folder of <method>/<scene>/ result folders (required)", .meta = "DIR"),
    MF_OPT_STR(A, out, NULL, "report folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, methods, NULL, "comma-separated methods to score", .unset = "every folder in RESULTS_DIR", .meta = "a,b,..."),
    MF_OPT_STR(A, scenes, NULL, "comma-separated scenes to score (every name must be a scene of DATA_DIR, else refused naming the unknown ones; DATA_DIR as one scene must be listed)", .unset = "every scene of DATA_DIR", .meta = "a,b,..."),
    MF_OPT_STR(A, dataset, NULL, "data set name in the tables", .unset = "DATA_DIR's folder name", .meta = "NAME"),
    MF_OPT_BOOL(A, no_curves, 0, "skip the speed-vs-error curves from the texture snapshots"),
    MF_OPT_BOOL(A, trivial, 0, "also score the trivial guesses trivial-grey and trivial-flat-light"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf eval DATA_DIR --results RESULTS_DIR -o REPORT_DIR [--methods a,b,...] [--dataset NAME]\n"
    "               [--align mean|lsq|none] [--spp N] [--pixel-samples P] [--max-views N] [--no-curves]\n"
    "               [--trivial] [--scenes a,b,...] [--config FILE]\n"
    "Scores RESULTS_DIR/<method>/<scene>/ against DATA_DIR (a split folder of bvault scenes, or one\n"
    "scene) with the protocol stated in the README: relit views (every relighting light, test\n"
    "cameras; per-channel scale inside the GT mask (mean: ratio of means, default; lsq: least\n"
    "squares), sRGB, clip, composite on black), albedo (same protocol) and ORM (roughness and\n"
    "metallic, no scaling; orm3 adds a constant R channel). Metrics: PSNR, SSIM, L1, FLIP (LPIPS is\n"
    "not computed: it needs pretrained weights that cannot be obtained here). Writes REPORT_DIR/\n"
    "per_view.csv, scenes.csv, relight.{md,tex}, materials.{md,tex}, cost.md, runs.md (provenance), speed_error.png,\n"
    "geometry.{md,tex} (scenes with a GT mesh: Chamfer x1e3 as Stanford-ORB, normal error, test-view mask IoU; --no-geom skips),\n"
    "paired.{md,csv} (every method minus the first over the shared scenes: mean, 95% CI, wins, paired\n"
    "t-test and sign-test p; mf compare recomputes it for another reference) and index.html. Methods default to every folder in RESULTS_DIR. --trivial adds two guesses every\n"
    "method must beat: trivial-grey (albedo 0.5 on the GT mesh under the true light) and\n"
    "trivial-flat-light (the true textures under a constant white light).\n";

__attribute__((constructor)) static void eval_usage(void) {
    const MfOptTable *t[] = {&k_args_table, &ev_eval_opt_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 2, NULL);
}

static int cmd_eval(int argc, char **argv) {
    EvBench a = {0};
    EvEvalOpts o = ev_eval_opts_default();
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind binds[] = {{&k_args_table, &a}, {&ev_eval_opt_table, &o}};
    MfOptParse p;
    int rc = mf_opts_parse(binds, 2, argc, argv, 1, &p) ? MF_EXIT_USAGE : MF_EXIT_OK;
    if (!rc && p.print_config) {
        mf_opts_parse_free(&p);
        return mf_cli_print_config(binds, 2);
    }
    if (!rc && (!p.npos || !a.results || !a.out)) {
        mf_fail(MF_EARG, "need DATA_DIR, --results and -o (see mf eval --help)");
        rc = MF_EXIT_USAGE;
    }
    if (!rc) {
        a.data = p.pos[0], a.revision = MF_GIT_REV, a.argc = argc, a.argv = argv;
        rc = ev_bench_run(&a, &o) ? MF_EXIT_FAIL : MF_EXIT_OK;
    }
    mf_opts_parse_free(&p);
    return rc;
}

MF_COMMAND(eval, "eval", "score method result folders on a data set split (tables, plots, index.html)", usage, cmd_eval)
