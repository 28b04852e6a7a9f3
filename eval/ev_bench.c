/* ev_bench: the benchmark driver behind `mf eval` (ev_bench.h). */
#include "eval/ev_bench.h"

#include <cJSON.h>
#include <dirent.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_strbuf.h"
#include "eval/ev_paired.h"
#include "eval/ev_report.h"
#include "io/mf_json.h"

#define MAX_ITEMS 64

typedef struct {
    const EvBench *b;
    const EvEvalOpts *o;
    EvEvalOpts quiet; /* *o with quiet = 1: a scene's loads after its first (the loader's notes are said once) */
    int loaded[MAX_ITEMS]; /* (nsc,) 1: the scene was loaded once (its notes said) */
    char scene_root[MF_PATH_MAX];
    char scenes[MAX_ITEMS][EV_NAME_MAX], methods[MAX_ITEMS][EV_NAME_MAX]; /* (nsc,), (nm,) */
    const char *mptr[MAX_ITEMS]; /* (nm,) into methods */
    int nsc, nm;
    const char *dataset; /* borrowed: b->dataset or inside scene_root */
    EvTable t;
    MfStrBuf prov; /* runs.md */
    EvSeries series[MAX_ITEMS];
    double cx[MAX_ITEMS][MAX_ITEMS], cy[MAX_ITEMS][MAX_ITEMS]; /* (nm, MAX_ITEMS) snapshot curves */
    int evaluated, excluded;
} Bench;

/* A scene folder: test views in transforms_test.json, or one transforms.json for every frame (an
 * instant-ngp / nerfstudio capture; ds_load's hold-out rule picks its test frames). */
static int is_scene(const char *dir) {
    char p[MF_PATH_MAX];
    return (!mf_path_join(p, sizeof p, dir, "transforms_test.json") && mf_file_exists(p)) ||
           (!mf_path_join(p, sizeof p, dir, "transforms.json") && mf_file_exists(p));
}

/* 1 when name is one of the comma-separated items of list. */
static int in_list(const char *list, const char *name) {
    size_t n = strlen(name);
    for (const char *p = list; *p;) {
        const char *c = strchr(p, ',');
        size_t l = c ? (size_t)(c - p) : strlen(p);
        if (l == n && !strncmp(p, name, n)) return 1;
        p += l + (c != NULL);
    }
    return 0;
}

/* The sub-folders of dir (scene folders when need_scene; only those of the comma-separated list
 * keep when it is not NULL), sorted, into *names (malloc'ed, (*n,)). Every entry is kept: a
 * directory entry's name always fits EvName (NAME_MAX). MF_EIO when dir cannot be read. */
static int list_dirs(const char *dir, int need_scene, const char *keep, EvName **names, int *n) {
    *names = NULL;
    *n = 0;
    DIR *d = opendir(dir);
    if (!d) return mf_fail(MF_EIO, "%s: cannot read the folder", dir);
    EvName *v = NULL;
    int cnt = 0, cap = 0, rc = MF_OK;
    struct dirent *e;
    while (!rc && (e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        size_t len = strlen(e->d_name);
        char p[MF_PATH_MAX];
        if (mf_path_join(p, sizeof p, dir, e->d_name)) continue;
        if (need_scene) {
            if (!is_scene(p)) continue;
        } else {
            DIR *sub = opendir(p);
            if (!sub) continue;
            closedir(sub);
        }
        if (keep && !in_list(keep, e->d_name)) continue;
        if (len >= EV_NAME_MAX) {
            rc = mf_fail(MF_EARG, "%s: folder name longer than %d characters", p, EV_NAME_MAX - 1);
            break;
        }
        if (cnt == cap) {
            cap = cap ? 2 * cap : 16;
            EvName *w = realloc(v, (size_t)cap * sizeof *v);
            if (!w) {
                rc = mf_fail(MF_ENOMEM, "%s: out of memory listing folders", dir);
                break;
            }
            v = w;
        }
        memcpy(v[cnt++], e->d_name, len + 1);
    }
    closedir(d);
    if (rc) {
        free(v);
        return rc;
    }
    if (cnt) qsort(v, (size_t)cnt, sizeof *v, (int (*)(const void *, const void *))strcmp);
    *names = v;
    *n = cnt;
    return MF_OK;
}

int ev_scene_dirs(const char *dir, EvName **names, int *n) { return list_dirs(dir, 1, NULL, names, n); }

/* Wall seconds, peak RSS and the prior's seconds (MaterialFusion: options.prior_s) of a result
 * folder's run.json (0 when absent; prior may be NULL). With prov, appends the run's provenance as
 * a markdown row: method, scene, revision, prior weights, seed, threads, time, memory, argv. */
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
        const cJSON *opts = cJSON_GetObjectItem(root, "options");
        const char *kind = cJSON_GetStringValue(cJSON_GetObjectItem(opts, "method"));
        const char *weights = cJSON_GetStringValue(cJSON_GetObjectItem(opts, "prior_weights"));
        int uses_prior = kind && !strcmp(kind, "materialfusion"); /* the baseline records the default, unused */
        mf_sb_printf(prov, "| %s | %s | %s | %s | %.0f | %.0f | %.1f | %.0f | `", method, scene, cJSON_IsString(rev) ? rev->valuestring : "?",
                     uses_prior && weights ? weights : "–", cJSON_GetNumberValue(cJSON_GetObjectItem(root, "seed")),
                     cJSON_GetNumberValue(cJSON_GetObjectItem(root, "threads")), *wall, *rss / 1048576.0);
        const cJSON *a;
        cJSON_ArrayForEach(a, av) if (cJSON_IsString(a)) mf_sb_printf(prov, "%s%s", a == av->child ? "" : " ", a->valuestring);
        mf_sb_printf(prov, "` |\n");
    }
    cJSON_Delete(root);
}

/* Relit PSNR at each snapshot of one run (first relighting light, up to 4 views), against the
 * wall time logged at that iteration: the speed-vs-error curve. */
static int snapshot_curve(const char *scene_dir, const char *scene, const char *result_dir, const EvEvalOpts *base,
                          double *x, double *y, int max, int *n) {
    char snaps[MF_PATH_MAX], logp[MF_PATH_MAX], mesh[MF_PATH_MAX];
    *n = 0;
    if (mf_path_join(snaps, sizeof snaps, result_dir, "snapshots") || mf_path_join(logp, sizeof logp, result_dir, "log.csv") ||
        mf_path_join(mesh, sizeof mesh, result_dir, "mesh.obj"))
        return MF_EARG;
    EvName *names = NULL;
    int ns = 0;
    char *log = NULL;
    if (!mf_file_exists(snaps) || list_dirs(snaps, 0, NULL, &names, &ns) || ns <= 0 || mf_read_file(logp, &log, NULL)) {
        free(names);
        return MF_OK;
    }
    if (ns > max) mf_log_warn("%s: %d snapshots; the speed-vs-error curve keeps at most %d points", snaps, ns, max);
    EvEvalOpts o = *base;
    o.max_views = 4;
    o.max_lights = 1;
    o.mesh_path = mesh;
    o.no_geom = 1; /* the run's one mesh: scored once, in score_run */
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
        int relit = 1;
        if (ev_eval_scene(scene_dir, sd, "m", "d", scene, &o, &t, NULL, &ex) == MF_OK) {
            EvStat s = ev_table_stat(&t, "m", "d", "relit_psnr");
            if (s.n) x[*n] = wall, y[*n] = s.mean, ++*n;
            relit = s.n > 0;
        }
        ev_table_free(&t);
        if (!relit) break; /* a scene without relit ground truth (a capture) has no relit curve */
    }
    free(log);
    free(names);
    return MF_OK;
}

/* The items of --scenes that name no scene of names (n,), as "'a', 'b'" into out; 0 when none. */
static int unknown_scenes(const char *list, EvName *names, int n, MfStrBuf *out) {
    int bad = 0;
    for (const char *p = list; *p;) {
        const char *c = strchr(p, ',');
        int l = c ? (int)(c - p) : (int)strlen(p);
        int found = 0;
        for (int i = 0; i < n && !found; ++i) found = (int)strlen(names[i]) == l && !strncmp(names[i], p, (size_t)l);
        if (!found && l > 0) mf_sb_printf(out, "%s'%.*s'", bad++ ? ", " : "", l, p);
        p += l + (c != NULL);
    }
    return bad;
}

/* Scenes (DATA itself, or its sub-folders with transforms_test.json or transforms.json, filtered: every
 * listed name must be a scene there), methods and the data set name. No name is truncated or dropped: a
 * name too long or more than MAX_ITEMS scenes or methods is an error. */
static int find_runs(Bench *B) {
    const EvBench *b = B->b;
    const char *data = b->data;
    EvName *found = NULL;
    int nf = 0, rc = MF_OK;
    if (is_scene(data)) {
        char d[MF_PATH_MAX]; /* data without trailing slashes ("cap/" is the scene cap) */
        size_t n = strlen(data);
        while (n > 1 && data[n - 1] == '/') --n;
        snprintf(d, sizeof d, "%.*s", (int)n, data);
        const char *slash = strrchr(d, '/');
        const char *name = slash && slash[1] ? slash + 1 : d;
        if (strlen(name) >= EV_NAME_MAX) return mf_fail(MF_EARG, "%s: scene name longer than %d characters", data, EV_NAME_MAX - 1);
        if (!(found = malloc(sizeof *found))) return mf_fail(MF_ENOMEM, "out of memory");
        memcpy(found[0], name, strlen(name) + 1); /* fits: checked above */
        snprintf(B->scene_root, sizeof B->scene_root, "%.*s", slash ? (int)(slash - d) : 1, slash ? d : ".");
        nf = 1;
    } else {
        snprintf(B->scene_root, sizeof B->scene_root, "%s", data);
        if ((rc = list_dirs(data, 1, NULL, &found, &nf))) return rc;
    }
    if (b->scenes) { /* every listed name must be a scene of DATA (DATA as one scene: its own name) */
        MfStrBuf bad = {0};
        int nbad = unknown_scenes(b->scenes, found, nf, &bad);
        if (nbad && is_scene(data) && !in_list(b->scenes, found[0]))
            rc = mf_fail(MF_EARG, "--scenes '%s': %s is one scene, '%s', which the list does not name (list it, or drop --scenes)",
                         b->scenes, data, found[0]);
        else if (nbad && is_scene(data))
            rc = mf_fail(MF_EARG, "--scenes '%s': %s is one scene, '%s'; no scene %s there", b->scenes, data, found[0], bad.s);
        else if (nbad)
            rc = mf_fail(MF_EARG, "--scenes '%s': no scene %s in %s (%d scene folder(s) with transforms_test.json or transforms.json there%s%s)",
                         b->scenes, bad.s, data, nf, nf ? ", e.g. " : "", nf ? found[0] : "");
        mf_sb_free(&bad);
        int k = 0;
        for (int i = 0; i < nf && !rc; ++i)
            if (in_list(b->scenes, found[i])) memmove(found[k++], found[i], sizeof found[i]);
        nf = k;
        if (!rc && nf == 0) rc = mf_fail(MF_EARG, "--scenes '%s': names no scene", b->scenes);
    }
    if (!rc && nf <= 0) rc = mf_fail(MF_EIO, "%s: no scene with transforms_test.json or transforms.json", data);
    if (!rc && nf > MAX_ITEMS)
        rc = mf_fail(MF_EARG, "%s: %d scenes, more than mf eval scores in one run (%d); pick some with --scenes", data, nf, MAX_ITEMS);
    for (int i = 0; i < nf && !rc; ++i) memcpy(B->scenes[i], found[i], sizeof found[i]);
    free(found);
    found = NULL;
    if (rc) return rc;
    B->nsc = nf;
    int nm = 0;
    if (b->methods) {
        for (const char *p = b->methods; *p && !rc;) {
            const char *c = strchr(p, ',');
            size_t l = c ? (size_t)(c - p) : strlen(p);
            if (l >= EV_NAME_MAX) rc = mf_fail(MF_EARG, "--methods: '%.*s' is longer than %d characters", (int)l, p, EV_NAME_MAX - 1);
            else if (l > 0 && nm == MAX_ITEMS) rc = mf_fail(MF_EARG, "--methods '%s': more than %d methods", b->methods, MAX_ITEMS);
            else if (l > 0) snprintf(B->methods[nm++], EV_NAME_MAX, "%.*s", (int)l, p);
            p += l + (c != NULL);
        }
    } else if (!(rc = list_dirs(b->results, 0, NULL, &found, &nm))) {
        if (nm > MAX_ITEMS) rc = mf_fail(MF_EARG, "%s: %d method folders, more than mf eval scores in one run (%d); pick some with --methods", b->results, nm, MAX_ITEMS);
        for (int i = 0; i < nm && !rc; ++i) memcpy(B->methods[i], found[i], sizeof found[i]);
        free(found);
    }
    if (rc) return rc;
    if (b->trivial && nm + 2 > MAX_ITEMS) return mf_fail(MF_EARG, "--trivial: %d methods and the 2 trivial guesses are more than %d", nm, MAX_ITEMS);
    if (b->trivial) {
        snprintf(B->methods[nm++], EV_NAME_MAX, "trivial-grey");
        snprintf(B->methods[nm++], EV_NAME_MAX, "trivial-flat-light");
    }
    if (nm <= 0) return mf_fail(MF_EIO, "%s: no method result folders", b->results);
    B->nm = nm;
    for (int m = 0; m < nm; ++m) B->mptr[m] = B->methods[m];
    B->dataset = b->dataset;
    if (!B->dataset) {
        const char *slash = strrchr(B->scene_root, '/');
        B->dataset = slash && slash[1] ? slash + 1 : B->scene_root;
    }
    if (strlen(B->dataset) >= EV_NAME_MAX) return mf_fail(MF_EARG, "data set name '%s' is longer than %d characters", B->dataset, EV_NAME_MAX - 1);
    return MF_OK;
}

/* One run: scores, cost records (time_s, mem_mb, prior_share, time_x) and, on the first scene,
 * the snapshot curve. */
static int score_run(Bench *B, int m, int s, FILE *csv) {
    const EvBench *b = B->b;
    const char *method = B->methods[m], *scene = B->scenes[s], *ds = B->dataset;
    char sd[MF_PATH_MAX], md[MF_PATH_MAX], rd[MF_PATH_MAX];
    int rc;
    if ((rc = mf_path_join(sd, sizeof sd, B->scene_root, scene)) || (rc = mf_path_join(md, sizeof md, b->results, method)) ||
        (rc = mf_path_join(rd, sizeof rd, md, scene)))
        return rc;
    if (!strcmp(method, "trivial-grey")) snprintf(rd, sizeof rd, "%s", EV_TRIVIAL_GREY_DIR);
    else if (!strcmp(method, "trivial-flat-light")) snprintf(rd, sizeof rd, "%s", EV_TRIVIAL_FLAT_DIR);
    else if (!mf_file_exists(rd)) {
        mf_log_warn("%s: missing; %s is not scored on %s", rd, method, scene);
        return MF_OK;
    }
    mf_log_info("eval: %s on %s", method, scene);
    rc = ev_eval_scene(sd, rd, method, ds, scene, B->loaded[s] ? &B->quiet : B->o, &B->t, csv, &B->excluded);
    B->loaded[s] = 1;
    if (rc) return mf_fail_prefix(rc, "%s", rd);
    ++B->evaluated;
    double wall, rss, prior;
    run_cost(rd, &wall, &rss, &prior, &B->prov, method, scene);
    if (wall > 0 && !(rc = ev_table_add(&B->t, method, ds, scene, "time_s", wall)))
        rc = ev_table_add(&B->t, method, ds, scene, "mem_mb", rss / 1048576.0);
    if (!rc && wall > 0 && prior > 0) rc = ev_table_add(&B->t, method, ds, scene, "prior_share", prior / wall);
    /* wall time as a multiple of the first method's on the same scene (the baseline in bench) */
    char bd[MF_PATH_MAX];
    double bwall = 0.0, brss;
    if (!rc && wall > 0 && !mf_path_join(md, sizeof md, b->results, B->methods[0]) && !mf_path_join(bd, sizeof bd, md, scene))
        run_cost(bd, &bwall, &brss, NULL, NULL, NULL, NULL);
    if (!rc && wall > 0 && bwall > 0) rc = ev_table_add(&B->t, method, ds, scene, "time_x", wall / bwall);
    if (!rc && !b->no_curves && s == 0) rc = snapshot_curve(sd, scene, rd, &B->quiet, B->cx[m], B->cy[m], MAX_ITEMS, &B->series[m].n);
    return rc;
}

/* Every method on every scene, per-view rows to OUT/per_view.csv. */
static int score_all(Bench *B) {
    char p[MF_PATH_MAX], tmp[MF_PATH_MAX];
    int rc;
    if ((rc = mf_path_join(p, sizeof p, B->b->out, "per_view.csv")) || (rc = mf_tmp_path(p, tmp, sizeof tmp))) return rc;
    FILE *csv = fopen(tmp, "w");
    if (!csv) return mf_fail(MF_EIO, "%s: cannot write", p);
    ev_eval_csv_header(csv);
    for (int m = 0; m < B->nm && !rc; ++m) {
        B->series[m] = (EvSeries){B->methods[m], B->cx[m], B->cy[m], 0};
        for (int s = 0; s < B->nsc && !rc; ++s) rc = score_run(B, m, s, csv);
    }
    int bad = fclose(csv) != 0;
    if (!rc && bad) rc = mf_fail(MF_EIO, "%s: write failed", p);
    if (rc) {
        mf_discard_file(tmp);
        return rc;
    }
    return mf_commit_file(tmp, p);
}

/* The paper-layout tables (md, tex, and HTML into page), scenes.csv, paired.{md,csv} and the
 * speed-vs-error plot (its HTML into extra). */
static int write_tables(Bench *B, MfStrBuf *page, MfStrBuf *extra) {
    const EvBench *b = B->b;
    const EvEvalOpts *o = B->o;
    const char *ds[1] = {B->dataset};
    const char *relit_m[] = {"relit_psnr", "relit_ssim", "relit_l1", "relit_flip"};
    const char *mat_m[] = {"albedo_psnr", "albedo_ssim", "albedo_l1", "orm_psnr", "orm_l1", "orm3_psnr"};
    const char *cost_m[] = {"time_s", "time_x", "prior_share", "mem_mb"};
    const char *orb_m[] = {"relit_orb_psnr_h", "relit_orb_psnr_l"};
    const char *nv_m[] = {"nv_psnr", "nv_ssim", "nv_l1", "nv_flip"};
    const char *geom_m[] = {"geom_chamfer", "geom_chamfer_uniform", "geom_normal_deg", "geom_normal_1mcos",
                            "geom_view_normal_deg", "geom_view_normal_1mcos", "geom_mask_iou"};
    struct { const char *file, *caption; const char *const *metrics; int nk; } tabs[] = {
        {"relight", "Relighting (test views under novel lights)", relit_m, 4},
        {"materials", "Albedo and ORM (per test view)", mat_m, 6},
        {"cost", "Wall time (s), wall time as a multiple of the first method's on the same scene (time_x), the prior's share of the wall time (MaterialFusion), and peak memory (MB) per scene", cost_m, 4},
        {"orb", "Stanford-ORB's own relighting metrics (PSNR-H, PSNR-L)", orb_m, 2},
        {"novelview", "Novel views under the TRAINING light (held-out test views; the scene has no relit or material ground truth)", nv_m, 4},
        {"geometry", "Geometry against the GT mesh: Chamfer x1e3 (Stanford-ORB: GT vertices vs 30k area samples; uniform: 30k area samples of each mesh), normal error in degrees and as 1 - cos (those point pairs; and the test views' normal maps), test-view mask IoU", geom_m, 7},
    };
    mf_sb_printf(page, "<p>Data: <code>");
    char rel[MF_PATH_MAX];
    ev_report_relpath(b->out, b->data, rel, sizeof rel); /* no machine paths in the page */
    mf_sb_html(page, rel);
    mf_sb_printf(page, "</code>; %d scene(s), %d method(s), %d evaluated runs, %d excluded view scores.</p>\n", B->nsc, B->nm,
                 B->evaluated, B->excluded);
    mf_sb_printf(page, "<p>Protocol: relit RGB and albedo aligned per channel inside the GT mask (%s), then sRGB, "
                       "clip to [0,1], composite on black; ORM not rescaled, scored on roughness and metallic "
                       "(orm3: constant R added). Relit images rendered with %d&sup2;+%d&sup2; samples, %d per pixel. "
                       "LPIPS is not reported (needs pretrained weights that cannot be obtained here); FLIP is the "
                       "perceptual metric.</p>\n",
                 ev_align_name(o->align), o->spp_sqrt, o->spp_sqrt, o->pixel_samples);
    int rc = MF_OK;
    for (size_t k = 0; k < sizeof tabs / sizeof tabs[0] && !rc; ++k) {
        int any = 0;
        for (int m = 0; m < B->nm && !any; ++m) any = ev_table_stat(&B->t, B->mptr[m], B->dataset, tabs[k].metrics[0]).n > 0;
        if (!any) continue; /* e.g. the ORB table outside Stanford-ORB */
        char md[MF_PATH_MAX], tex[MF_PATH_MAX];
        snprintf(md, sizeof md, "%s/%s.md", b->out, tabs[k].file);
        snprintf(tex, sizeof tex, "%s/%s.tex", b->out, tabs[k].file);
        rc = ev_table_write_markdown(&B->t, md, tabs[k].caption, B->mptr, B->nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        if (!rc) rc = ev_table_write_latex(&B->t, tex, tabs[k].caption, B->mptr, B->nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        char *h = ev_table_html_string(&B->t, tabs[k].caption, B->mptr, B->nm, ds, 1, tabs[k].metrics, tabs[k].nk);
        if (h) mf_sb_printf(page, "%s", h);
        free(h);
    }
    char p[MF_PATH_MAX];
    if (!rc) {
        snprintf(p, sizeof p, "%s/scenes.csv", b->out);
        rc = ev_table_write_csv(&B->t, p);
    }
    if (!rc && B->nm > 1) rc = ev_paired_write_bench(&B->t, b->out, B->mptr[0], B->mptr, B->nm, B->dataset); /* against the first method */
    int have_curve = 0;
    for (int m = 0; m < B->nm; ++m) have_curve |= B->series[m].n > 0;
    if (!rc && !b->no_curves && have_curve && ev_gnuplot_available()) {
        snprintf(p, sizeof p, "%s/speed_error.png", b->out);
        if ((rc = ev_plot_png(p, "Relit PSNR vs wall time (first scene)", "wall time [s]", "relit PSNR [dB]", B->series, B->nm, 0)) == MF_OK)
            mf_sb_printf(extra, "<h2>Speed vs error</h2><img src=\"speed_error.png\">\n");
    }
    if (!rc && ev_gnuplot_available()) rc = ev_report_speed_error(b->out, &B->t, B->mptr, B->nm, B->dataset, extra);
    return rc;
}

/* Image grid of one scene: ground truth and each method with a result, first test view, first
 * novel light; nothing when fewer than two rows. Its HTML goes to grids. */
static int write_grid(Bench *B, int sc, MfStrBuf *grids) {
    enum { MAXR = 9 };
    MfImage cells[MAXR][EV_GRID_COLS];
    const MfImage *ptr[MAXR * EV_GRID_COLS];
    char labels[MAXR * (EV_NAME_MAX + 2)] = "ground truth", psnr[MAXR][32];
    const char *rlab[MAXR], *ctext[MAXR * EV_GRID_COLS] = {0};
    int rows = 0, rc;
    char sd[MF_PATH_MAX];
    if ((rc = mf_path_join(sd, sizeof sd, B->scene_root, B->scenes[sc]))) return rc;
    const EvEvalOpts *o = B->loaded[sc] ? &B->quiet : B->o;
    if (ev_eval_grid_row(sd, NULL, o, cells[rows]) == MF_OK) rlab[rows++] = "ground truth";
    B->loaded[sc] = 1;
    for (int m = 0; m < B->nm && rows < MAXR; ++m) {
        char md[MF_PATH_MAX], rd[MF_PATH_MAX];
        if (mf_path_join(md, sizeof md, B->b->results, B->methods[m]) || mf_path_join(rd, sizeof rd, md, B->scenes[sc]) ||
            !mf_file_exists(rd))
            continue;
        if (ev_eval_grid_row(sd, rd, &B->quiet, cells[rows]) != MF_OK) continue;
        size_t l = strlen(labels);
        snprintf(labels + l, sizeof labels - l, ", %s", B->methods[m]);
        double v;
        if (ev_table_find(&B->t, B->mptr[m], B->dataset, B->scenes[sc], "relit_psnr", &v))
            snprintf(psnr[rows], sizeof psnr[rows], "%.2f dB", v), ctext[rows * EV_GRID_COLS] = psnr[rows];
        rlab[rows++] = B->methods[m];
    }
    if (rows >= 2) {
        for (int r = 0; r < rows; ++r)
            for (int k = 0; k < EV_GRID_COLS; ++k) ptr[r * EV_GRID_COLS + k] = cells[r][k].data ? &cells[r][k] : NULL;
        char name[EV_NAME_MAX + 16], p[MF_PATH_MAX];
        snprintf(name, sizeof name, "grid_%s.png", B->scenes[sc]);
        snprintf(p, sizeof p, "%s/%s", B->b->out, name);
        rc = ev_grid_png_labelled(p, ptr, rows, EV_GRID_COLS, 128, 128, 1, &(EvGridLabels){B->scenes[sc], ev_grid_col_names, rlab, ctext});
        if (!rc) {
            mf_sb_printf(grids, "<h3>%s</h3><p>Rows: ", B->scenes[sc]);
            mf_sb_html(grids, labels);
            mf_sb_printf(grids, ". Columns: relit view (first test view, first novel light), albedo, roughness, "
                                "metallic, env map (tonemapped x/(1+x)); in a method's relit cell, its relit PSNR on this scene.</p><img src=\"%s\">\n", name);
        }
    }
    for (int r = 0; r < rows; ++r)
        for (int k = 0; k < EV_GRID_COLS; ++k) mf_image_free(&cells[r][k]);
    return rc;
}

/* Tables, plot, grids of the first 6 scenes, index.html and runs.md. */
static int write_report(Bench *B) {
    MfStrBuf page = {0}, extra = {0}, grids = {0};
    char p[MF_PATH_MAX];
    int rc = write_tables(B, &page, &extra);
    for (int sc = 0; sc < B->nsc && sc < 6 && !rc; ++sc) rc = write_grid(B, sc, &grids);
    if (!rc) {
        if (grids.s) mf_sb_printf(&extra, "<h2>Images</h2>\n%s", grids.s);
        const char *blocks[2] = {page.s ? page.s : "", extra.s ? extra.s : ""};
        snprintf(p, sizeof p, "%s/index.html", B->b->out);
        rc = ev_html_write(p, "MaterialFusion evaluation", blocks, 2);
    }
    if (!rc) {
        snprintf(p, sizeof p, "%s/runs.md", B->b->out);
        rc = mf_sb_write(&B->prov, p);
    }
    mf_sb_free(&page);
    mf_sb_free(&extra);
    mf_sb_free(&grids);
    return rc;
}

int ev_bench_run(const EvBench *b, const EvEvalOpts *o) {
    Bench *B = calloc(1, sizeof *B);
    if (!B) return mf_fail(MF_ENOMEM, "ev_bench_run: out of memory");
    B->b = b;
    B->o = o;
    B->quiet = *o;
    B->quiet.quiet = 1;
    ev_table_init(&B->t);
    int rc = find_runs(B);
    if (!rc) rc = mf_mkdirs(b->out);
    if (!rc) {
        mf_sb_printf(&B->prov, "# Provenance\n\nWritten by `mf eval` (revision %s):\n\n    mf", b->revision);
        for (int i = 0; i < b->argc; ++i) mf_sb_printf(&B->prov, " %s", b->argv[i]);
        mf_sb_printf(&B->prov, "\n\nEach scored run (from its run.json): the revision that produced it, the prior weights it "
                               "loaded (MaterialFusion), seed, OpenMP threads, wall time, peak memory and the exact command.\n\n"
                               "| method | scene | revision | prior | seed | threads | wall s | peak MB | command |\n"
                               "|---|---|---|---|---:|---:|---:|---:|---|\n");
        rc = score_all(B);
    }
    if (!rc) rc = write_report(B);
    if (!rc) mf_log_info("eval: %d runs scored, %d view scores excluded -> %s", B->evaluated, B->excluded, b->out);
    ev_table_free(&B->t);
    mf_sb_free(&B->prov);
    free(B);
    return rc;
}
