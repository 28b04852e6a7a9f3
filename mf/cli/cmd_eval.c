/* mf eval: the evaluation protocol over a data set split for one or more methods' result
 * folders: per-view CSV, per-scene records, paper-layout tables (Markdown, LaTeX, HTML), a
 * speed-vs-error plot from the texture snapshots, image grids and reports/index.html. */
#include <cJSON.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "mf_build_info.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_strbuf.h"
#include "eval/ev_eval.h"
#include "eval/ev_eval_opts.h"
#include "eval/ev_paired.h"
#include "eval/ev_report.h"
#include "io/mf_json.h"

typedef struct {
    const char *out, *results, *methods, *scenes, *dataset;
    int no_curves, trivial;
} EvalArgs;

#define A EvalArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, results, NULL, "folder of <method>/<scene>/ result folders (required)", .meta = "DIR"),
    MF_OPT_STR(A, out, NULL, "report folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, methods, NULL, "comma-separated methods to score", .unset = "every folder in RESULTS_DIR", .meta = "a,b,..."),
    MF_OPT_STR(A, scenes, NULL, "comma-separated scenes to score", .unset = "every scene of DATA_DIR", .meta = "a,b,..."),
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
    "paired.{md,csv} (every method minus the first over the shared scenes: mean, 95% CI, wins, paired\n"
    "t-test and sign-test p; mf compare recomputes it for another reference) and index.html. Methods default to every folder in RESULTS_DIR. --trivial adds two guesses every\n"
    "method must beat: trivial-grey (albedo 0.5 on the GT mesh under the true light) and\n"
    "trivial-flat-light (the true textures under a constant white light).\n";

__attribute__((constructor)) static void eval_usage(void) {
    const MfOptTable *t[] = {&k_args_table, &ev_eval_opt_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 2, NULL);
}

#define MAX_ITEMS 64

static int list_dirs(const char *dir, char names[][64], int max, int need_test_json) {
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < max) {
        if (e->d_name[0] == '.') continue;
        if (strlen(e->d_name) >= 64) continue;
        char p[MF_PATH_MAX];
        if (mf_path_join(p, sizeof p, dir, e->d_name)) continue;
        if (need_test_json) {
            char tj[MF_PATH_MAX];
            if (mf_path_join(tj, sizeof tj, p, "transforms_test.json") || !mf_file_exists(tj)) continue;
        } else {
            DIR *sub = opendir(p);
            if (!sub) continue;
            closedir(sub);
        }
        memcpy(names[n++], e->d_name, strlen(e->d_name) + 1);
    }
    closedir(d);
    qsort(names, (size_t)n, 64, (int (*)(const void *, const void *))strcmp);
    return n;
}

/* Wall seconds, peak RSS and the prior's seconds (MaterialFusion: options.prior_s) of a result
 * folder's run.json (0 when absent; prior may be NULL). With prov, appends the run's provenance as
 * a markdown row: method, scene, revision, seed, threads, time, memory, argv. */
static void run_cost(const char *result_dir, double *wall, double *rss, double *prior, MfStrBuf *prov, const char *method,
                     const char *scene) {
    char p[MF_PATH_MAX];
    cJSON *root = NULL;
    *wall = *rss = 0.0;
    if (prior) *prior = 0.0;
    if (mf_path_join(p, sizeof p, result_dir, "run.json") || !mf_file_exists(p) || mf_json_load(p, &root)) return;
    *wall = cJSON_GetNumberValue(cJSON_GetObjectItem(root, "wall_seconds"));
    *rss = cJSON_GetNumberValue(cJSON_GetObjectItem(root, "peak_rss_bytes"));
    if (*wall != *wall) *wall = 0.0;
    if (*rss != *rss) *rss = 0.0;
    double ps = cJSON_GetNumberValue(cJSON_GetObjectItem(cJSON_GetObjectItem(root, "options"), "prior_s"));
    if (prior && ps == ps) *prior = ps;
    if (prov) {
        const cJSON *rev = cJSON_GetObjectItem(root, "git_revision"), *av = cJSON_GetObjectItem(root, "argv");
        mf_sb_printf(prov, "| %s | %s | %s | %.0f | %.0f | %.1f | %.0f | `", method, scene, cJSON_IsString(rev) ? rev->valuestring : "?",
                     cJSON_GetNumberValue(cJSON_GetObjectItem(root, "seed")), cJSON_GetNumberValue(cJSON_GetObjectItem(root, "threads")),
                     *wall, *rss / 1048576.0);
        const cJSON *a;
        cJSON_ArrayForEach(a, av) if (cJSON_IsString(a)) mf_sb_printf(prov, "%s%s", a == av->child ? "" : " ", a->valuestring);
        mf_sb_printf(prov, "` |\n");
    }
    cJSON_Delete(root);
}

/* Relit PSNR at each snapshot of one run (first relighting light, up to 4 views), against the
 * wall time logged at that iteration: the speed-vs-error curve. */
static int snapshot_curve(const char *scene_dir, const char *result_dir, const EvEvalOpts *base, double *x, double *y,
                          int max, int *n) {
    char snaps[MF_PATH_MAX], logp[MF_PATH_MAX], mesh[MF_PATH_MAX];
    *n = 0;
    if (mf_path_join(snaps, sizeof snaps, result_dir, "snapshots") || mf_path_join(logp, sizeof logp, result_dir, "log.csv") ||
        mf_path_join(mesh, sizeof mesh, result_dir, "mesh.obj"))
        return MF_EARG;
    char names[MAX_ITEMS][64];
    int ns = list_dirs(snaps, names, MAX_ITEMS, 0);
    char *log = NULL;
    if (ns <= 0 || mf_read_file(logp, &log, NULL)) return MF_OK;
    EvEvalOpts o = *base;
    o.max_views = 4;
    o.max_lights = 1;
    o.mesh_path = mesh;
    for (int k = 0; k < ns && *n < max; ++k) {
        int it = 0;
        if (sscanf(names[k], "iter_%d", &it) != 1) continue;
        double wall = -1;
        char key[32];
        snprintf(key, sizeof key, "\n%d,", it);
        const char *p = strstr(log, key);
        if (!p || sscanf(p + strlen(key), "%lf", &wall) != 1) continue;
        char sd[MF_PATH_MAX];
        if (mf_path_join(sd, sizeof sd, snaps, names[k])) continue;
        EvTable t;
        ev_table_init(&t);
        int ex = 0;
        if (ev_eval_scene(scene_dir, sd, "m", "d", "s", &o, &t, NULL, &ex) == MF_OK) {
            EvStat s = ev_table_stat(&t, "m", "d", "relit_psnr");
            if (s.n) x[*n] = wall, y[*n] = s.mean, ++*n;
        }
        ev_table_free(&t);
    }
    free(log);
    return MF_OK;
}

static int eval_run(int argc, char **argv, const char *data, const EvalArgs *a, EvEvalOpts o);

static int cmd_eval(int argc, char **argv) {
    EvalArgs a;
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
    if (!rc) rc = eval_run(argc, argv, p.pos[0], &a, o);
    mf_opts_parse_free(&p);
    return rc;
}

static int eval_run(int argc, char **argv, const char *data, const EvalArgs *a, EvEvalOpts o) {
    const char *results = a->results, *out = a->out, *methods_s = a->methods, *dataset = a->dataset, *scenes_s = a->scenes;
    int curves = !a->no_curves, trivial = a->trivial;
    /* scenes: DATA_DIR itself, or its sub-folders with transforms_test.json */
    static char scenes[MAX_ITEMS][64], methods[MAX_ITEMS][64];
    char scene_root[MF_PATH_MAX];
    int nsc;
    char tj[MF_PATH_MAX];
    snprintf(tj, sizeof tj, "%s/transforms_test.json", data);
    if (mf_file_exists(tj)) {
        const char *slash = strrchr(data, '/');
        snprintf(scenes[0], 64, "%s", slash && slash[1] ? slash + 1 : data);
        snprintf(scene_root, sizeof scene_root, "%.*s", slash ? (int)(slash - data) : 1, slash ? data : ".");
        nsc = 1;
    } else {
        snprintf(scene_root, sizeof scene_root, "%s", data);
        nsc = list_dirs(data, scenes, MAX_ITEMS, 1);
    }
    if (scenes_s && nsc > 1) { /* keep only the listed scenes */
        int k = 0;
        for (int i = 0; i < nsc; ++i) {
            char list[4096];
            snprintf(list, sizeof list, ",%s,", scenes_s);
            char key[70];
            snprintf(key, sizeof key, ",%.63s,", scenes[i]);
            if (strstr(list, key)) memmove(scenes[k++], scenes[i], 64);
        }
        nsc = k;
    }
    if (nsc <= 0) { mf_fail(MF_EIO, "%s: no scene with transforms_test.json", data); return MF_EXIT_FAIL; }
    int nm = 0;
    if (methods_s) {
        char buf[1024];
        snprintf(buf, sizeof buf, "%s", methods_s);
        for (char *save = NULL, *t = strtok_r(buf, ",", &save); t && nm < MAX_ITEMS; t = strtok_r(NULL, ",", &save))
            snprintf(methods[nm++], 64, "%s", t);
    } else {
        nm = list_dirs(results, methods, MAX_ITEMS, 0);
    }
    if (trivial && nm + 2 <= MAX_ITEMS) {
        snprintf(methods[nm++], 64, "trivial-grey");
        snprintf(methods[nm++], 64, "trivial-flat-light");
    }
    if (nm <= 0) { mf_fail(MF_EIO, "%s: no method result folders", results); return MF_EXIT_FAIL; }
    if (!dataset) {
        const char *slash = strrchr(scene_root, '/');
        dataset = slash && slash[1] ? slash + 1 : scene_root;
    }
    if (mf_mkdirs(out)) return MF_EXIT_FAIL;
    char p[MF_PATH_MAX], tmp[MF_PATH_MAX];
    snprintf(p, sizeof p, "%s/per_view.csv", out);
    if (mf_tmp_path(p, tmp, sizeof tmp)) return MF_EXIT_FAIL;
    FILE *csv = fopen(tmp, "w");
    if (!csv) { mf_fail(MF_EIO, "%s: cannot write", p); return MF_EXIT_FAIL; }
    ev_eval_csv_header(csv);
    EvTable t;
    ev_table_init(&t);
    int rc = MF_OK, excluded = 0, evaluated = 0;
    const char *mptr[MAX_ITEMS];
    for (int m = 0; m < nm; ++m) mptr[m] = methods[m];
    MfStrBuf curves_html = {0}, prov = {0};
    mf_sb_printf(&prov, "# Provenance\n\nWritten by `mf eval` (revision %s):\n\n    mf", MF_GIT_REV);
    for (int i = 0; i < argc; ++i) mf_sb_printf(&prov, " %s", argv[i]);
    mf_sb_printf(&prov, "\n\nEach scored run (from its run.json): the revision that produced it, seed, OpenMP threads, wall "
                        "time, peak memory and the exact command.\n\n| method | scene | revision | seed | threads | wall s | "
                        "peak MB | command |\n|---|---|---|---:|---:|---:|---:|---|\n");
    EvSeries series[MAX_ITEMS];
    static double cx[MAX_ITEMS][MAX_ITEMS], cy[MAX_ITEMS][MAX_ITEMS];
    for (int m = 0; m < nm && !rc; ++m) {
        series[m] = (EvSeries){methods[m], cx[m], cy[m], 0};
        for (int s = 0; s < nsc && !rc; ++s) {
            char sd[MF_PATH_MAX], md[MF_PATH_MAX], rd[MF_PATH_MAX];
            if ((rc = mf_path_join(sd, sizeof sd, scene_root, scenes[s])) || (rc = mf_path_join(md, sizeof md, results, methods[m])) ||
                (rc = mf_path_join(rd, sizeof rd, md, scenes[s])))
                break;
            if (!strcmp(methods[m], "trivial-grey")) snprintf(rd, sizeof rd, "%s", EV_TRIVIAL_GREY_DIR);
            else if (!strcmp(methods[m], "trivial-flat-light")) snprintf(rd, sizeof rd, "%s", EV_TRIVIAL_FLAT_DIR);
            else if (!mf_file_exists(rd)) {
                mf_log_warn("%s: missing; %s is not scored on %s", rd, methods[m], scenes[s]);
                continue;
            }
            mf_log_info("eval: %s on %s", methods[m], scenes[s]);
            rc = ev_eval_scene(sd, rd, methods[m], dataset, scenes[s], &o, &t, csv, &excluded);
            if (rc) {
                mf_fail_prefix(rc, "%s", rd);
                break;
            }
            ++evaluated;
            double wall, rss, prior;
            run_cost(rd, &wall, &rss, &prior, &prov, methods[m], scenes[s]);
            if (wall > 0 && !(rc = ev_table_add(&t, methods[m], dataset, scenes[s], "time_s", wall)))
                rc = ev_table_add(&t, methods[m], dataset, scenes[s], "mem_mb", rss / 1048576.0);
            if (!rc && wall > 0 && prior > 0) rc = ev_table_add(&t, methods[m], dataset, scenes[s], "prior_share", prior / wall);
            /* wall time as a multiple of the first method's on the same scene (the baseline in bench) */
            char bd[MF_PATH_MAX];
            double bwall = 0.0, brss;
            if (!rc && wall > 0 && !mf_path_join(md, sizeof md, results, methods[0]) && !mf_path_join(bd, sizeof bd, md, scenes[s]))
                run_cost(bd, &bwall, &brss, NULL, NULL, NULL, NULL);
            if (!rc && wall > 0 && bwall > 0) rc = ev_table_add(&t, methods[m], dataset, scenes[s], "time_x", wall / bwall);
            if (!rc && curves && s == 0) rc = snapshot_curve(sd, rd, &o, cx[m], cy[m], MAX_ITEMS, &series[m].n);
        }
    }
    int bad = fclose(csv) != 0;
    if (rc || bad) {
        mf_discard_file(tmp);
        ev_table_free(&t);
        mf_sb_free(&prov);
        if (!rc) mf_fail(MF_EIO, "%s: write failed", p);
        return MF_EXIT_FAIL;
    }
    if ((rc = mf_commit_file(tmp, p))) return MF_EXIT_FAIL;
    const char *ds[1] = {dataset};
    const char *relit_m[] = {"relit_psnr", "relit_ssim", "relit_l1", "relit_flip"};
    const char *mat_m[] = {"albedo_psnr", "albedo_ssim", "albedo_l1", "orm_psnr", "orm_l1", "orm3_psnr"};
    const char *cost_m[] = {"time_s", "time_x", "prior_share", "mem_mb"};
    const char *orb_m[] = {"relit_orb_psnr_h", "relit_orb_psnr_l"};
    const char *nv_m[] = {"nv_psnr", "nv_ssim", "nv_l1", "nv_flip"};
    struct { const char *file, *caption; const char *const *metrics; int nk; } tabs[] = {
        {"relight", "Relighting (test views under novel lights)", relit_m, 4},
        {"materials", "Albedo and ORM (per test view)", mat_m, 6},
        {"cost", "Wall time (s), wall time as a multiple of the first method's on the same scene (time_x), the prior's share of the wall time (MaterialFusion), and peak memory (MB) per scene", cost_m, 4},
        {"orb", "Stanford-ORB's own relighting metrics (PSNR-H, PSNR-L)", orb_m, 2},
        {"novelview", "Novel views under the TRAINING light (held-out test views; the scene has no relit or material ground truth)", nv_m, 4},
    };
    MfStrBuf page = {0};
    mf_sb_printf(&page, "<p>Data: <code>");
    { char rel[MF_PATH_MAX]; ev_report_relpath(out, data, rel, sizeof rel); mf_sb_html(&page, rel); } /* no machine paths */
    mf_sb_printf(&page, "</code>; %d scene(s), %d method(s), %d evaluated runs, %d excluded view scores.</p>\n", nsc, nm,
                 evaluated, excluded);
    mf_sb_printf(&page, "<p>Protocol: relit RGB and albedo aligned per channel inside the GT mask (%s), then sRGB, "
                        "clip to [0,1], composite on black; ORM not rescaled, scored on roughness and metallic "
                        "(orm3: constant R added). Relit images rendered with %d&sup2;+%d&sup2; samples, %d per pixel. "
                        "LPIPS is not reported (needs pretrained weights that cannot be obtained here); FLIP is the "
                        "perceptual metric.</p>\n",
                 ev_align_name(o.align), o.spp_sqrt, o.spp_sqrt, o.pixel_samples);
    for (size_t k = 0; k < sizeof tabs / sizeof tabs[0] && !rc; ++k) {
        int any = 0;
        for (int m = 0; m < nm && !any; ++m) any = ev_table_stat(&t, mptr[m], dataset, tabs[k].metrics[0]).n > 0;
        if (!any) continue; /* e.g. the ORB table outside Stanford-ORB */
        char md[MF_PATH_MAX], tex[MF_PATH_MAX];
        snprintf(md, sizeof md, "%s/%s.md", out, tabs[k].file);
        snprintf(tex, sizeof tex, "%s/%s.tex", out, tabs[k].file);
        rc = ev_table_write_markdown(&t, md, tabs[k].caption, mptr, nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        if (!rc) rc = ev_table_write_latex(&t, tex, tabs[k].caption, mptr, nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        char *h = ev_table_html_string(&t, tabs[k].caption, mptr, nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        if (h) mf_sb_printf(&page, "%s", h);
        free(h);
    }
    if (!rc) {
        snprintf(p, sizeof p, "%s/scenes.csv", out);
        rc = ev_table_write_csv(&t, p);
    }
    if (!rc && nm > 1) rc = ev_paired_write_bench(&t, out, mptr[0], mptr, nm, dataset); /* against the first method */
    int have_curve = 0;
    for (int m = 0; m < nm; ++m) have_curve |= series[m].n > 0;
    if (!rc && curves && have_curve && ev_gnuplot_available()) {
        snprintf(p, sizeof p, "%s/speed_error.png", out);
        if ((rc = ev_plot_png(p, "Relit PSNR vs wall time (first scene)", "wall time [s]", "relit PSNR [dB]", series, nm, 0)) == MF_OK)
            mf_sb_printf(&curves_html, "<h2>Speed vs error</h2><img src=\"speed_error.png\">\n");
    }
    if (!rc && ev_gnuplot_available()) rc = ev_report_speed_error(out, &t, mptr, nm, dataset, &curves_html);
    /* image grids: ground truth and each method, first test view, first novel light */
    MfStrBuf grids = {0};
    for (int sc = 0; sc < nsc && sc < 6 && !rc; ++sc) {
        enum { MAXR = 9 };
        MfImage cells[MAXR][EV_GRID_COLS];
        const MfImage *ptr[MAXR * EV_GRID_COLS];
        char labels[1024] = "ground truth", psnr[MAXR][32];
        const char *rlab[MAXR], *ctext[MAXR * EV_GRID_COLS] = {0};
        int rows = 0;
        char sd[MF_PATH_MAX];
        if (mf_path_join(sd, sizeof sd, scene_root, scenes[sc])) break;
        if (ev_eval_grid_row(sd, NULL, &o, cells[rows]) == MF_OK) rlab[rows++] = "ground truth";
        for (int m = 0; m < nm && rows < MAXR; ++m) {
            char md[MF_PATH_MAX], rd[MF_PATH_MAX];
            if (mf_path_join(md, sizeof md, results, methods[m]) || mf_path_join(rd, sizeof rd, md, scenes[sc]) || !mf_file_exists(rd)) continue;
            if (ev_eval_grid_row(sd, rd, &o, cells[rows]) != MF_OK) continue;
            size_t l = strlen(labels);
            snprintf(labels + l, sizeof labels - l, ", %.63s", methods[m]);
            double v;
            if (ev_table_find(&t, mptr[m], dataset, scenes[sc], "relit_psnr", &v))
                snprintf(psnr[rows], sizeof psnr[rows], "%.2f dB", v), ctext[rows * EV_GRID_COLS] = psnr[rows];
            rlab[rows++] = methods[m];
        }
        if (rows < 2) {
            for (int r = 0; r < rows; ++r)
                for (int k = 0; k < EV_GRID_COLS; ++k) mf_image_free(&cells[r][k]);
            continue;
        }
        for (int r = 0; r < rows; ++r)
            for (int k = 0; k < EV_GRID_COLS; ++k) ptr[r * EV_GRID_COLS + k] = cells[r][k].data ? &cells[r][k] : NULL;
        char name[128];
        snprintf(name, sizeof name, "grid_%.60s.png", scenes[sc]);
        snprintf(p, sizeof p, "%s/%s", out, name);
        rc = ev_grid_png_labelled(p, ptr, rows, EV_GRID_COLS, 128, 128, 1, &(EvGridLabels){scenes[sc], ev_grid_col_names, rlab, ctext});
        for (int r = 0; r < rows; ++r)
            for (int k = 0; k < EV_GRID_COLS; ++k) mf_image_free(&cells[r][k]);
        if (!rc) {
            mf_sb_printf(&grids, "<h3>%s</h3><p>Rows: ", scenes[sc]);
            mf_sb_html(&grids, labels);
            mf_sb_printf(&grids, ". Columns: relit view (first test view, first novel light), albedo, roughness, "
                                 "metallic, env map (tonemapped x/(1+x)); in a method's relit cell, its relit PSNR on this scene.</p><img src=\"%s\">\n", name);
        }
    }
    if (!rc) {
        if (grids.s) mf_sb_printf(&curves_html, "<h2>Images</h2>\n%s", grids.s);
        const char *blocks[2] = {page.s ? page.s : "", curves_html.s ? curves_html.s : ""};
        snprintf(p, sizeof p, "%s/index.html", out);
        rc = ev_html_write(p, "MaterialFusion evaluation", blocks, 2);
    }
    if (!rc) {
        snprintf(p, sizeof p, "%s/runs.md", out);
        rc = mf_sb_write(&prov, p);
    }
    mf_sb_free(&page);
    mf_sb_free(&curves_html);
    mf_sb_free(&prov);
    mf_sb_free(&grids);
    ev_table_free(&t);
    if (rc) return MF_EXIT_FAIL;
    mf_log_info("eval: %d runs scored, %d view scores excluded -> %s", evaluated, excluded, out);
    return MF_EXIT_OK;
}

MF_COMMAND(eval, "eval", "score method result folders on a data set split (tables, plots, index.html)", usage, cmd_eval)
