/* ev_stability: see ev_stability.h. */
#include "eval/ev_stability.h"

#include <cJSON.h>
#include <fcntl.h>
#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_strbuf.h"
#include "eval/ev_eval.h"
#include "eval/ev_metrics.h"
#include "eval/ev_paired.h"
#include "eval/ev_table.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "io/mf_ckpt.h"

/* Variants (ev_stab_scene.h). */
static const EvStabVariant k_variants[] = {
    {"reference", EV_VAR_REFERENCE, 0, "000_cup as generated"},
    {"mirror_sun", EV_VAR_MIRROR_SUN, 0, "roughness 0 (floor), metallic 1, HDR sun (2 deg disc, 3 W/m^2) added to the env"},
    {"grazing", EV_VAR_GRAZING, 0, "training cameras at 0.5 deg elevation"},
    {"albedo_0", EV_VAR_ALBEDO, 0, "black albedo (kd = 0; its albedo dB is 100 by construction: scale alignment to a black truth)"},
    {"albedo_1", EV_VAR_ALBEDO, 1, "white albedo (kd = 1)"},
    {"env_-8", EV_VAR_ENV_STOPS, -8, "env strength -8 stops (8-bit training PNGs)"},
    {"env_-4", EV_VAR_ENV_STOPS, -4, "env strength -4 stops (8-bit training PNGs)"},
    {"env_+4", EV_VAR_ENV_STOPS, 4, "env strength +4 stops (8-bit training PNGs, clipped)"},
    {"env_+8", EV_VAR_ENV_STOPS, 8, "env strength +8 stops (8-bit training PNGs, clipped)"},
    {"exr_-8", EV_VAR_EXPOSURE_EXR, -8, "training images as float EXR x 2^-8"},
    {"exr_-4", EV_VAR_EXPOSURE_EXR, -4, "training images as float EXR x 2^-4"},
    {"exr_+4", EV_VAR_EXPOSURE_EXR, 4, "training images as float EXR x 2^4"},
    {"exr_+8", EV_VAR_EXPOSURE_EXR, 8, "training images as float EXR x 2^8"},
    {"png_-1", EV_VAR_EXPOSURE_PNG, -1, "training PNGs darkened 1 stop (8-bit)"},
    {"png_-1_x1", EV_VAR_EXPOSURE_PNG_BACK, -1, "png_-1's 8-bit values brought back 1 stop (16-bit PNG)"},
    {"png_-2", EV_VAR_EXPOSURE_PNG, -2, "training PNGs darkened 2 stops (8-bit)"},
    {"png_-2_x1", EV_VAR_EXPOSURE_PNG_BACK, -2, "png_-2's 8-bit values brought back 2 stops (16-bit PNG)"},
    {"png_-3", EV_VAR_EXPOSURE_PNG, -3, "training PNGs darkened 3 stops (8-bit)"},
    {"png_-3_x1", EV_VAR_EXPOSURE_PNG_BACK, -3, "png_-3's 8-bit values brought back 3 stops (16-bit PNG)"},
    {"png_-4", EV_VAR_EXPOSURE_PNG, -4, "training PNGs darkened 4 stops (8-bit)"},
    {"png_-4_x1", EV_VAR_EXPOSURE_PNG_BACK, -4, "png_-4's 8-bit values brought back 4 stops (16-bit PNG)"},
    {"saturated", EV_VAR_SATURATE, 2, "training PNGs x 4 (2 stops), clipped at 1"},
    {"scale_1e-4", EV_VAR_SCALE, 1e-4, "mesh and cameras x 1e-4"},
    {"scale_1e-2", EV_VAR_SCALE, 1e-2, "mesh and cameras x 1e-2"},
    {"scale_1e2", EV_VAR_SCALE, 1e2, "mesh and cameras x 1e2"},
    {"scale_1e4", EV_VAR_SCALE, 1e4, "mesh and cameras x 1e4"},
    {"sliver", EV_VAR_SLIVER, 0, "every triangle split into a 1e-4 sliver pair, plus a zero-area triangle each"},
    {"one_view", EV_VAR_ONE_VIEW, 0, "one training view"},
    {"mask_2x2", EV_VAR_MASK, 0, "training masks cut to 2 x 2 pixels"},
};

const EvStabVariant *ev_stab_variant(const char *id) {
    for (size_t i = 0; i < sizeof k_variants / sizeof k_variants[0]; ++i)
        if (!strcmp(k_variants[i].id, id)) return &k_variants[i];
    return NULL;
}

/* Expectations: float exposure is divided out exactly by the loop's power-of-two level
 * (README "The methods"), so EXR cells must match the reference within EXP_EXR_DB; 8-bit
 * darkening within the seed-to-seed spread measured there (EXP_PNG_DB); scaled scenes must
 * render within float precision of x1 (EXP_SCALE_RENDER_DB, issue 18) and reconstruct within
 * EXP_SCALE_DB. Cells without a stated expectation must run with finite outputs only. */
#define EXP_EXR_DB 0.3
#define EXP_PNG_DB 1.0
#define EXP_SCALE_DB 0.3
#define EXP_SCALE_RENDER_DB 50.0
#define R(var, q, mindb) {"render", "render", var, "", NULL, 0, 0, mindb, q}
#define B(var, q, maxd) {"recon", "baseline", var, "", NULL, maxd, 0, 0, q}
#define M(var, q, maxd) {"recon", "materialfusion", var, "", NULL, maxd, 0, 0, q}
/* MaterialFusion on a scaled scene: its renders differ from x1's in the last bits only, and the
 * run amplifies those (its seed spread on this scene is dB-sized), so the bound is that spread */
#define MS(var) {"recon", "materialfusion", var, "", NULL, EXP_SCALE_DB, 1, 0, 0}

/* Recon cells: the variant's scene at the test budget of tests/test_cli_pipeline_tiny.c (64 px
 * texels, 32 x 16 env). Refusal cells give an out-of-range value and must name the option. */
static const EvStabCell k_cells[] = {
    {"reference", "render", "reference", "", NULL, 0, 0, 0, 1},
    {"1 sample per pixel", "render", "reference", "--spp 1", NULL, 0, 0, 0, 0},
    {"4x4 pixels", "render", "reference", "--width 4 --height 4", NULL, 0, 0, 0, 0},
    {"reference", "baseline", "reference", "", NULL, 0, 0, 0, 1},
    {"one iteration", "baseline", "reference", "--iters 1", NULL, 0, 0, 0, 0},
    {"views at 8 px", "baseline", "reference", "--res 8", NULL, 0, 0, 0, 0},
    {"lr at its maximum (1)", "baseline", "reference", "--lr 1", NULL, 0, 0, 0, 1},
    {"init light at its minimum (0.01)", "baseline", "reference", "--init-light 0.01", NULL, 0, 0, 0, 0},
    {"init light at its maximum (1000)", "baseline", "reference", "--init-light 1000", NULL, 0, 0, 0, 1},
    {"lr -1 (refused)", "baseline", "reference", "--lr -1", "--lr", 0, 0, 0, 1},
    {"lr 1e30 (refused)", "baseline", "reference", "--lr 1e30", "--lr", 0, 0, 0, 1},
    {"init light 1e30 (refused)", "baseline", "reference", "--init-light 1e30", "--init-light", 0, 0, 0, 1},
    {"reference", "materialfusion", "reference", "", NULL, 0, 0, 0, 0},
    {"lr at its maximum (1)", "materialfusion", "reference", "--lr 1", NULL, 0, 0, 0, 0},
    {"init light at its maximum (1000)", "materialfusion", "reference", "--init-light 1000", NULL, 0, 0, 0, 0},
    R("mirror_sun", 0, 0), B("mirror_sun", 1, 0), M("mirror_sun", 0, 0),
    R("grazing", 0, 0), B("grazing", 0, 0), M("grazing", 0, 0),
    R("albedo_0", 0, 0), B("albedo_0", 0, 0), M("albedo_0", 0, 0),
    R("albedo_1", 0, 0), B("albedo_1", 0, 0), M("albedo_1", 0, 0),
    R("env_-8", 0, 0), B("env_-8", 0, 0), M("env_-8", 0, 0), B("env_-4", 0, 0), M("env_-4", 0, 0),
    B("env_+4", 0, 0), M("env_+4", 0, 0), R("env_+8", 0, 0), B("env_+8", 0, 0), M("env_+8", 0, 0),
    B("exr_-8", 1, EXP_EXR_DB), M("exr_-8", 0, EXP_EXR_DB), B("exr_-4", 0, EXP_EXR_DB), M("exr_-4", 0, EXP_EXR_DB),
    B("exr_+4", 0, EXP_EXR_DB), M("exr_+4", 0, EXP_EXR_DB), B("exr_+8", 1, EXP_EXR_DB), M("exr_+8", 0, EXP_EXR_DB),
    B("png_-4", 0, EXP_PNG_DB), M("png_-4", 0, EXP_PNG_DB), B("png_-4_x1", 0, 0), M("png_-4_x1", 0, 0),
    B("saturated", 0, 0), M("saturated", 0, 0),
    R("scale_1e-4", 1, EXP_SCALE_RENDER_DB), B("scale_1e-4", 0, EXP_SCALE_DB), MS("scale_1e-4"),
    R("scale_1e-2", 0, EXP_SCALE_RENDER_DB), B("scale_1e-2", 0, EXP_SCALE_DB), MS("scale_1e-2"),
    R("scale_1e2", 0, EXP_SCALE_RENDER_DB), B("scale_1e2", 0, EXP_SCALE_DB), MS("scale_1e2"),
    R("scale_1e4", 1, EXP_SCALE_RENDER_DB), B("scale_1e4", 0, EXP_SCALE_DB), MS("scale_1e4"),
    R("sliver", 0, 0), B("sliver", 0, 0), M("sliver", 0, 0),
    B("one_view", 0, 0), M("one_view", 0, 0),
    B("mask_2x2", 1, 0), M("mask_2x2", 0, 0),
};

const EvStabCell *ev_stab_cells(int *n) {
    *n = (int)(sizeof k_cells / sizeof k_cells[0]);
    return k_cells;
}

/* Starts `cmd` through /bin/sh (exec: the child is the command itself) with stderr to
 * stderr_path and stdout to /dev/null; *t0 gets the start time. */
static int spawn_cell(const char *cmd, const char *stderr_path, pid_t *pid, struct timespec *t0) {
    clock_gettime(CLOCK_MONOTONIC, t0);
    *pid = fork();
    if (*pid < 0) return mf_fail(MF_EIO, "fork failed for: %s", cmd);
    if (*pid == 0) {
        int fd = open(stderr_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) dup2(fd, 2), close(fd);
        int nul = open("/dev/null", O_WRONLY);
        if (nul >= 0) dup2(nul, 1), close(nul);
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    return MF_OK;
}

/* The child's exit status st and usage ru, started at t0, into r. */
static void finish_cell(int st, const struct rusage *ru, const struct timespec *t0, EvStabResult *r) {
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    r->exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    r->wall_s = (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
    r->peak_rss_kb = ru->ru_maxrss;
}

/* Runs the n commands cmds[i] (stderr to errs[i]) at most `jobs` at a time, each result into
 * res[i] (exit code, wall seconds, peak RSS); returns when all have ended. */
static int run_pool(char (*cmds)[4096], char (*errs)[1100], EvStabResult *const *res, int n, int jobs) {
    pid_t pid[EV_STAB_MAX_RUNS];
    struct timespec t0[EV_STAB_MAX_RUNS];
    int next = 0, running = 0, rc = MF_OK;
    while (next < n || running > 0) {
        while (!rc && running < jobs && next < n) {
            if ((rc = spawn_cell(cmds[next], errs[next], &pid[next], &t0[next]))) break;
            ++next, ++running;
        }
        if (running == 0) break;
        int st = 0;
        struct rusage ru;
        memset(&ru, 0, sizeof ru);
        pid_t done = wait4(-1, &st, 0, &ru);
        if (done < 0) return mf_fail(MF_EIO, "wait4 failed in the stability grid");
        for (int i = 0; i < next; ++i)
            if (pid[i] == done) finish_cell(st, &ru, &t0[i], res[i]), --running;
    }
    return rc;
}

static int g_exr, g_bad;

static int scan_one(const char *path, const struct stat *sb, int flag, struct FTW *ftw) {
    (void)sb, (void)ftw;
    size_t n = strlen(path);
    if (flag != FTW_F || n < 4 || strcmp(path + n - 4, ".exr")) return 0;
    MfExrImage im;
    memset(&im, 0, sizeof im);
    ++g_exr;
    if (mf_exr_read(path, &im) == MF_ENAN) ++g_bad;
    mf_exr_free(&im);
    return 0;
}

int ev_stab_scan_dir(const char *dir, int *exr_files, int *nonfinite) {
    g_exr = g_bad = 0;
    if (mf_file_exists(dir) && nftw(dir, scan_one, 16, FTW_PHYS) != 0) return mf_fail(MF_EIO, "%s: cannot walk", dir);
    *exr_files = g_exr, *nonfinite = g_bad;
    return MF_OK;
}

void ev_stab_scan_ckpt(const char *dir, long *values, long *nonfinite) {
    char p[MF_PATH_MAX];
    MfTensorSpec *specs = NULL;
    float *data = NULL;
    int n = 0;
    *values = -1, *nonfinite = 0;
    if (mf_path_join(p, sizeof p, dir, "checkpoint.mfck") || !mf_file_exists(p) || mf_ckpt_read(p, &specs, &n, &data, NULL)) {
        mf_error_clear();
        return;
    }
    size_t k = mf_specs_numel(specs, n);
    for (size_t i = 0; i < k; ++i) *nonfinite += !isfinite(data[i]);
    *values = (long)k;
    free(specs);
    free(data);
}

/* Entries of dir/run.json's options.recoveries; -1 when it cannot be read. */
static int count_recoveries(const char *dir) {
    char p[MF_PATH_MAX];
    cJSON *j = NULL;
    if (mf_path_join(p, sizeof p, dir, "run.json") || mf_json_load(p, &j)) return mf_error_clear(), -1;
    const cJSON *rec = cJSON_GetObjectItem(cJSON_GetObjectItem(j, "options"), "recoveries");
    int n = cJSON_IsArray(rec) ? cJSON_GetArraySize(rec) : -1;
    cJSON_Delete(j);
    return n;
}

/* 1 when the file at `path` contains `needle`. */
static int file_mentions(const char *path, const char *needle) {
    char *data = NULL;
    size_t len = 0;
    if (mf_read_file(path, &data, &len)) return 0;
    int hit = strstr(data, needle) != NULL;
    free(data);
    return hit;
}

/* One cell's command line into cmd. */
static void cell_cmd(char *cmd, size_t cap, const char *mf, const char *scene, const char *out, const EvStabCell *c, int iters) {
    if (!strcmp(c->kind, "render"))
        snprintf(cmd, cap, "exec %s render %s/render_train.json -o %s %s", mf, scene, out, c->args);
    else
        snprintf(cmd, cap, "exec %s recon %s -o %s --method %s --iters %d --tex-res 64 --env-w 32 --env-h 16 %s", mf, scene, out,
                 strcmp(c->kind, "baseline") ? "materialfusion" : "nvdiffrecmc", iters, c->args);
}

/* Mean of channels 1 and 2 (roughness, metallic) of an ORM image file. */
static int orm_means(const char *path, double *rough, double *metal) {
    MfImage im;
    if (mf_image_read(path, MF_ENC_LINEAR, &im)) return mf_error_clear(), MF_EIO;
    double s1 = 0, s2 = 0;
    size_t n = (size_t)im.w * im.h;
    for (size_t i = 0; i < n && im.c >= 3; ++i) s1 += im.data[i * im.c + 1], s2 += im.data[i * im.c + 2];
    *rough = im.c >= 3 ? s1 / (double)n : NAN;
    *metal = im.c >= 3 ? s2 / (double)n : NAN;
    mf_image_free(&im);
    return MF_OK;
}

/* Recon cell quality: ev_eval_scene of the result against its scene, and the ORM texel means. */
static void score_recon(const char *scene, const char *out, EvStabResult *r) {
    EvTable t;
    ev_table_init(&t);
    EvEvalOpts o = ev_eval_opts_default();
    o.no_geom = 1; /* only the material scores are read */
    int excluded = 0;
    static const char *metric[3] = {"relit_psnr", "albedo_psnr", "orm_psnr"};
    if (ev_eval_scene(scene, out, "m", "stability", "000_cup", &o, &t, NULL, &excluded) == MF_OK)
        for (int k = 0; k < 3; ++k) {
            EvStat st = ev_table_stat(&t, "m", "stability", metric[k]);
            if (st.n) r->db[k] = st.mean;
        }
    else
        mf_error_clear();
    ev_table_free(&t);
    char p[MF_PATH_MAX];
    if (!mf_path_join(p, sizeof p, out, "orm.png")) orm_means(p, &r->rough[0], &r->metal[0]);
    if (!mf_path_join(p, sizeof p, scene, "gt/orm.png")) orm_means(p, &r->rough[1], &r->metal[1]);
}

/* Render cell: the worst per-view PSNR of its RGB against the reference render's (NaN when a
 * view is missing in either). */
static double render_psnr(const char *out, const char *ref_out) {
    double worst = NAN;
    for (int i = 0;; ++i) {
        char rel[32], a[MF_PATH_MAX], b[MF_PATH_MAX];
        snprintf(rel, sizeof rel, "r_%03d.exr", i);
        if (mf_path_join(a, sizeof a, out, rel) || mf_path_join(b, sizeof b, ref_out, rel) || !mf_file_exists(a) || !mf_file_exists(b))
            break;
        MfImage x = {0}, y = {0};
        double db = NAN;
        if (mf_exr_read_layer(a, "", "RGB", &x) || mf_exr_read_layer(b, "", "RGB", &y) || ev_psnr(&x, &y, NULL, &db)) mf_error_clear(), db = NAN;
        mf_image_free(&x);
        mf_image_free(&y);
        if (isnan(db)) return NAN;
        if (isnan(worst) || db < worst) worst = db;
    }
    return worst;
}

static void fmt_db(char *buf, size_t cap, double v, int sign) {
    if (isnan(v)) snprintf(buf, cap, "-");
    else snprintf(buf, cap, sign ? "%+.2f" : "%.2f", v);
}

static const char *const k_seed_kind[2] = {"baseline", "materialfusion"};
static const char *const k_seed_metric[3] = {"relit_psnr", "albedo_psnr", "orm_psnr"};

/* The seed row's comparisons (EV_SEED_*): variant a - variant b, "%s" standing for png_-K. */
static const struct {
    const char *a, *b, *name;
} k_seed_cmp[EV_SEED_NCMP] = {{"%s", "reference", "total"}, {"%s", "%s_x1", "exposure"}, {"%s_x1", "reference", "bits"}};

void ev_stab_seed_row(const EvTable *t, int stops, EvStabSeedRow *row) {
    memset(row, 0, sizeof *row);
    row->stops = stops, row->ok = 1;
    row->n = -1;
    char png[16];
    snprintf(png, sizeof png, "png_-%d", stops);
    for (int m = 0; m < 2; ++m)
        for (int k = 0; k < 3; ++k) {
            for (int c = 0; c < EV_SEED_NCMP; ++c) {
                char a[64], b[64], va[32], vb[32];
                snprintf(va, sizeof va, k_seed_cmp[c].a, png);
                snprintf(vb, sizeof vb, k_seed_cmp[c].b, png);
                snprintf(a, sizeof a, "%s %s", k_seed_kind[m], va);
                snprintf(b, sizeof b, "%s %s", k_seed_kind[m], vb);
                EvPaired p;
                ev_paired(t, a, b, "seeds", k_seed_metric[k], &p);
                if (row->n < 0 || p.n < row->n) row->n = p.n;
                row->mean[c][m][k] = p.n ? p.mean : NAN, row->lo[c][m][k] = p.lo, row->hi[c][m][k] = p.hi;
                if (c == EV_SEED_EXPOSURE && (!p.n || !(fabs(p.mean) <= EV_STAB_SEED_DB))) row->ok = 0;
            }
            char ref[64];
            snprintf(ref, sizeof ref, "%s reference", k_seed_kind[m]);
            double lo = INFINITY, hi = -INFINITY;
            for (size_t i = 0; i < t->n; ++i) {
                const EvRecord *r = &t->rec[i];
                if (strcmp(r->method, ref) || strcmp(r->dataset, "seeds") || strcmp(r->metric, k_seed_metric[k])) continue;
                lo = fmin(lo, r->value), hi = fmax(hi, r->value);
            }
            row->spread[m][k] = hi >= lo ? hi - lo : NAN;
        }
}

/* The seed rows' section of the report (Markdown into m) and their CSV (c: seeds.csv). */
static void write_seed_rows(MfStrBuf *m, MfStrBuf *c, const EvStabSeedRow *rows, int nrows) {
    int ok = 1;
    for (int i = 0; i < nrows; ++i) ok &= rows[i].ok;
    mf_sb_printf(m, "\nSeed row: the 8-bit training images darkened K stops (png_-K), the same 8-bit values brought "
                    "back K stops into 16-bit PNGs (png_-K_x1: the darkened images' information at the reference's "
                    "exposure) and the reference, each reconstructed at recon seeds 1..%d. Paired over seeds: mean "
                    "difference with its 95%% CI (Student t) for total = png_-K - reference, exposure = png_-K - "
                    "png_-K_x1 (the method's part: the same bits at two exposures) and bits = png_-K_x1 - reference "
                    "(the images' part: the information the darkened 8-bit images no longer hold); beside them the "
                    "reference's own spread over the seeds (max - min). Expected: every exposure |mean| <= %.1f dB "
                    "(issue 18's exposure target for the method): %s. The total is reported, not bounded.\n\n| stops "
                    "| method | metric | seeds | total dB [95%% CI] | exposure dB [95%% CI] | bits dB [95%% CI] | "
                    "reference spread dB |\n|---|---|---|---|---|---|---|---|\n",
                 nrows ? rows[0].n : 0, EV_STAB_SEED_DB, ok ? "yes" : "**NO**");
    mf_sb_printf(c, "stops,method,metric,comparison,seeds,mean_diff,ci_lo,ci_hi,reference_spread,bounded,within_bound\n");
    for (int i = 0; i < nrows; ++i) {
        const EvStabSeedRow *s = &rows[i];
        for (int mi = 0; mi < 2; ++mi)
            for (int k = 0; k < 3; ++k) {
                mf_sb_printf(m, "| -%d | %s | %s | %d ", s->stops, k_seed_kind[mi], k_seed_metric[k], s->n);
                for (int j = 0; j < EV_SEED_NCMP; ++j) {
                    mf_sb_printf(m, "| %+.2f [%+.2f, %+.2f] ", s->mean[j][mi][k], s->lo[j][mi][k], s->hi[j][mi][k]);
                    mf_sb_printf(c, "-%d,%s,%s,%s,%d,%.4f,%.4f,%.4f,%.4f,%d,%d\n", s->stops, k_seed_kind[mi], k_seed_metric[k],
                                 k_seed_cmp[j].name, s->n, s->mean[j][mi][k], s->lo[j][mi][k], s->hi[j][mi][k],
                                 s->spread[mi][k], j == EV_SEED_EXPOSURE, fabs(s->mean[j][mi][k]) <= EV_STAB_SEED_DB);
                }
                mf_sb_printf(m, "| %.2f |\n", s->spread[mi][k]);
            }
    }
}

/* Whether variant is one of the seed row's: the reference, png_-K or png_-K_x1 for K in stops. */
static int seed_variant(const char *variant, const int *stops, int nstops) {
    if (!strcmp(variant, "reference")) return 1;
    for (int i = 0; i < nstops; ++i) {
        char png[16];
        snprintf(png, sizeof png, "png_-%d", stops[i]);
        size_t l = strlen(png);
        if (!strncmp(variant, png, l) && (!variant[l] || !strcmp(variant + l, "_x1"))) return 1;
    }
    return 0;
}

/* Whether variant id is used by one of the n cells or the seed rows (the report lists only those). */
static int variant_used(const char *id, const EvStabCell *const *cells, int n, const EvStabSeedRow *rows, int nrows) {
    for (int i = 0; i < n; ++i)
        if (!strcmp(cells[i]->variant, id)) return 1;
    for (int i = 0; i < nrows; ++i)
        if (seed_variant(id, &rows[i].stops, 1)) return 1;
    return 0;
}

static int write_report(const char *out_dir, const EvStabCell *const *cells, const EvStabResult *res, int n, int iters,
                        const EvStabResult *mem, const int *mem_iters, int nmem, const EvStabSeedRow *rows, int nrows,
                        double total_s, int jobs, int threads) {
    char md[1024], csv[1024];
    snprintf(md, sizeof md, "%s/README.md", out_dir);
    snprintf(csv, sizeof csv, "%s/grid.csv", out_dir);
    MfStrBuf m = {0}, c = {0};
    int grid = n || nmem;
    if (grid)
        mf_sb_printf(&m, "# Numerical-stability grid\n\nGenerated by `make bench-stability` (`mf bench-stability`); do not edit. "
                         "Scenes: `mf gen --split tiny`'s 000_cup (8 train views, 32 px) and the hard-case variants below, each "
                         "rendered with its own ground truth (eval/ev_stab_scene.h). Recon cells: %d iterations, "
                         "--tex-res 64 --env-w 32 --env-h 16. Non-finite: EXR files under the cell's output holding a NaN/Inf "
                         "(the recon guard refuses to write them). Render dB: worst view PSNR (linear RGB) against the reference "
                         "render, for the scenes whose images should not change (reference, scale, sliver). Recon dB: relit / albedo / ORM PSNR against the scene's own ground truth (`mf eval`'s "
                         "scale-aligned protocol), then the difference to the same method's reference cell. Rough / metal: texel "
                         "means of the result's orm.png, truth in brackets. Expected: exit 0 (or, for a refusal cell, non-zero "
                         "with a message naming its option), no non-finite value, and the cell's stated bound when it has one "
                         "(|delta| <= bound dB on relit, albedo and ORM; render dB >= bound). MaterialFusion's scale cells are bounded per metric "
                         "by the larger of 0.3 dB and its reference's spread over the seed row's seeds (max - min): their renders "
                         "differ from x1's in the last bits only, and the run amplifies such a change as much as a new seed. "
                         "Whole grid: %.0f s wall, %d cell%s at a "
                         "time (%s); a cell's wall s is its own, under that load.\n\n",
                     iters, total_s, jobs, jobs > 1 ? "s" : "", threads > 0 ? "every cell with OMP_NUM_THREADS = cores / cells" : "OpenMP threads as inherited");
    else
        mf_sb_printf(&m, "# Numerical-stability grid: the seed row alone\n\nGenerated by `mf bench-stability --seed-row-only`; do "
                         "not edit. Scene: `mf gen --split tiny`'s 000_cup (8 train views, 32 px) and its darkened variants below "
                         "(eval/ev_stab_scene.h). Recon runs: %d iterations, --tex-res 64 --env-w 32 --env-h 16, relit / albedo / "
                         "ORM PSNR against the scene's ground truth (`mf eval`'s scale-aligned protocol). %.0f s wall, %d run%s at "
                         "a time (%s).\n\n",
                     iters, total_s, jobs, jobs > 1 ? "s" : "", threads > 0 ? "every run with OMP_NUM_THREADS = cores / runs" : "OpenMP threads as inherited");
    mf_sb_printf(&m, "Scene variants:\n\n| scene | what |\n|---|---|\n");
    for (size_t i = 0; i < sizeof k_variants / sizeof k_variants[0]; ++i)
        if (variant_used(k_variants[i].id, cells, n, rows, nrows)) mf_sb_printf(&m, "| %s | %s |\n", k_variants[i].id, k_variants[i].what);
    if (grid) mf_sb_printf(&m, "\n| kind | scene | case | exit | bound | expected | EXR / non-finite | ckpt floats / non-finite | recoveries | render dB | relit dB | albedo dB | "
                     "ORM dB | rough | metal | wall s | peak RSS MB |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    mf_sb_printf(&c, "kind,scene,case,exit,expected,exr_files,nonfinite,ckpt_values,ckpt_nonfinite,recoveries,render_db,relit_db,albedo_db,orm_db,relit_delta,albedo_delta,"
                     "orm_delta,rough,rough_true,metal,metal_true,wall_s,peak_rss_mb\n");
    for (int i = 0; i < n; ++i) {
        const EvStabResult *r = &res[i];
        const EvStabCell *e = cells[i];
        char bound[48] = "-", rd[16], q[3][48], rough[32] = "-", metal[32] = "-", ck[48] = "-", rec[16] = "-";
        if (r->ckpt_values >= 0) snprintf(ck, sizeof ck, "%ld / %ld", r->ckpt_values, r->ckpt_nonfinite);
        if (r->recoveries >= 0) snprintf(rec, sizeof rec, "%d", r->recoveries);
        if (r->bound[0] > 0 && (r->bound[0] != r->bound[1] || r->bound[0] != r->bound[2]))
            snprintf(bound, sizeof bound, "±%.2f / %.2f / %.2f dB", r->bound[0], r->bound[1], r->bound[2]);
        else if (r->bound[0] > 0) snprintf(bound, sizeof bound, "±%.1f dB", r->bound[0]);
        if (e->min_render_db > 0) snprintf(bound, sizeof bound, ">= %.0f dB", e->min_render_db);
        fmt_db(rd, sizeof rd, r->render_db, 0);
        for (int k = 0; k < 3; ++k) {
            char a[16], d[16];
            fmt_db(a, sizeof a, r->db[k], 0);
            fmt_db(d, sizeof d, r->delta[k], 1);
            if (isnan(r->delta[k])) snprintf(q[k], sizeof q[k], "%s", a);
            else snprintf(q[k], sizeof q[k], "%s (%s)", a, d);
        }
        if (!isnan(r->rough[0])) snprintf(rough, sizeof rough, "%.2f (%.2f)", r->rough[0], r->rough[1]);
        if (!isnan(r->metal[0])) snprintf(metal, sizeof metal, "%.2f (%.2f)", r->metal[0], r->metal[1]);
        mf_sb_printf(&m, "| %s | %s | %s | %d | %s | %s | %d / %d | %s | %s | %s | %s | %s | %s | %s | %s | %.1f | %.0f |\n", e->kind,
                     e->variant, e->name, r->exit_code, bound, r->ok ? "yes" : "**NO**", r->exr_files, r->nonfinite, ck, rec, rd, q[0], q[1], q[2], rough, metal,
                     r->wall_s, r->peak_rss_kb / 1024.0);
        mf_sb_printf(&c, "%s,%s,\"%s\",%d,%d,%d,%d,%ld,%ld,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%.2f,%.1f\n", e->kind,
                     e->variant, e->name, r->exit_code, r->ok, r->exr_files, r->nonfinite, r->ckpt_values, r->ckpt_nonfinite, r->recoveries,
                     r->render_db, r->db[0], r->db[1], r->db[2],
                     r->delta[0], r->delta[1], r->delta[2], r->rough[0], r->rough[1], r->metal[0], r->metal[1], r->wall_s,
                     r->peak_rss_kb / 1024.0);
    }
    if (nmem) {
        mf_sb_printf(&m, "\nMemory row (baseline, reference scene, same settings):\n\n| iterations | exit | peak RSS MB | wall s |\n|---|---|---|---|\n");
        for (int i = 0; i < nmem; ++i) {
            mf_sb_printf(&m, "| %d | %d | %.0f | %.1f |\n", mem_iters[i], mem[i].exit_code, mem[i].peak_rss_kb / 1024.0, mem[i].wall_s);
            mf_sb_printf(&c, "memory,reference,\"baseline %d iterations\",%d,%d,0,0,-1,0,-1,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,%.2f,%.1f\n",
                         mem_iters[i], mem[i].exit_code, mem[i].exit_code == 0, mem[i].wall_s, mem[i].peak_rss_kb / 1024.0);
        }
    }
    int rc3 = MF_OK;
    if (nrows) {
        MfStrBuf sc = {0};
        char scsv[1024];
        snprintf(scsv, sizeof scsv, "%s/seeds.csv", out_dir);
        write_seed_rows(&m, &sc, rows, nrows);
        rc3 = mf_sb_write(&sc, scsv);
    }
    int rc = mf_sb_write(&m, md);
    int rc2 = grid ? mf_sb_write(&c, csv) : (mf_sb_free(&c), MF_OK);
    return rc ? rc : rc2 ? rc2 : rc3;
}

/* Variants whose renders should equal the reference's (to float precision): render dB is
 * reported only for them. */
static int same_images(const EvStabVariant *v) {
    return v->kind == EV_VAR_REFERENCE || v->kind == EV_VAR_SCALE || v->kind == EV_VAR_SLIVER;
}

static int is_reference(const EvStabCell *c, const char *kind) {
    return !strcmp(c->kind, kind) && !strcmp(c->variant, "reference") && !c->args[0];
}

/* Whether a finished cell is as expected (see EvStabCell). */
static int cell_ok(const EvStabCell *c, const EvStabResult *r, const char *err_path) {
    if (r->nonfinite) return 0;
    if (c->refuse) return r->exit_code != 0 && file_mentions(err_path, c->refuse);
    if (r->exit_code != 0) return 0;
    if (strcmp(c->kind, "render") && (r->ckpt_values <= 0 || r->ckpt_nonfinite)) return 0;
    for (int k = 0; k < 3; ++k)
        if (r->bound[k] > 0 && (isnan(r->delta[k]) || fabs(r->delta[k]) > r->bound[k])) return 0;
    return !(c->min_render_db > 0) || (!isnan(r->render_db) && r->render_db >= c->min_render_db);
}

void ev_stab_spread_bounds(const EvStabCell *const *cells, EvStabResult *res, int n, const EvStabSeedRow *row) {
    for (int j = 0; j < n; ++j) {
        if (!cells[j]->spread_bound || cells[j]->refuse) continue;
        int m = !strcmp(cells[j]->kind, "materialfusion");
        for (int k = 0; k < 3; ++k) res[j].bound[k] = fmax(cells[j]->max_delta_db, row->spread[m][k]);
        res[j].ok = cell_ok(cells[j], &res[j], NULL);
    }
}

/* One run of the seed row: its seed, kind, variant, scene folder and output folder. */
typedef struct {
    int seed;
    const char *kind;
    char variant[16], scene[1200], out[1090];
} SeedRun;

/* Whether the grid itself has a cell of kind and variant at the default settings (its seed 1). */
static int grid_has(const char *kind, const char *variant) {
    for (size_t i = 0; i < sizeof k_cells / sizeof k_cells[0]; ++i)
        if (!strcmp(k_cells[i].kind, kind) && !strcmp(k_cells[i].variant, variant) && !k_cells[i].args[0]) return 1;
    return 0;
}

/* The seed row's runs into r (room for EV_STAB_MAX_SEED_RUNS): seeds 1..o->seeds, each method, the
 * reference and png_-K / png_-K_x1 for each K in stops; seed 1 of what the grid has is left to the
 * grid's cells unless o->seed_row_only. Returns their count. */
static int seed_runs(const char *work, const EvStabOpts *o, const int *stops, int nstops, SeedRun *r) {
    int n = 0;
    for (int s = 1; s <= o->seeds; ++s)
        for (int m = 0; m < 2; ++m)
            for (int v = 0; v < 1 + 2 * nstops; ++v) {
                SeedRun *x = &r[n];
                if (!v) snprintf(x->variant, sizeof x->variant, "reference");
                else snprintf(x->variant, sizeof x->variant, "png_-%d%s", stops[(v - 1) / 2], (v - 1) % 2 ? "_x1" : "");
                if (s == 1 && !o->seed_row_only && grid_has(k_seed_kind[m], x->variant)) continue;
                x->seed = s, x->kind = k_seed_kind[m];
                snprintf(x->out, sizeof x->out, "%s/seed%d-%s-%s", work, s, x->kind, x->variant);
                ++n;
            }
    return n;
}

/* Builds variant v under work/scenes/<id>/ (ev_stab_variant_build: once, then kept) and writes its
 * scene folder to scene. */
static int variant_scene(const char *layout, const char *work, const EvStabVariant *v, char *scene, size_t cap) {
    char vdir[1100];
    snprintf(vdir, sizeof vdir, "%s/scenes/%s", work, v->id);
    int rc = ev_stab_variant_build(layout, v, vdir);
    if (rc) return mf_fail_prefix(rc, "stability scene variant %s", v->id);
    snprintf(scene, cap, "%s/000_cup", vdir);
    return MF_OK;
}

/* Recon commands of the seed runs r[0..nr) (their scene variants built first, r[j].scene set),
 * appended to cmd/err/slot from index n; their results go to sres. */
static int seed_cmds(const char *mf, const char *layout, const char *work, const char *env, int iters, SeedRun *r,
                     int nr, int n, char (*cmd)[4096], char (*err)[1100], EvStabResult **slot, EvStabResult *sres) {
    for (int j = 0; j < nr; ++j) {
        char args[32];
        int rc = variant_scene(layout, work, ev_stab_variant(r[j].variant), r[j].scene, sizeof r[j].scene);
        if (rc) return rc;
        snprintf(args, sizeof args, "--seed %d", r[j].seed);
        EvStabCell c = {"seed", r[j].kind, r[j].variant, args, NULL, 0, 0, 0, 0};
        snprintf(err[n + j], sizeof err[n + j], "%s.err", r[j].out);
        size_t e = (size_t)snprintf(cmd[n + j], sizeof cmd[n + j], "%s", env);
        cell_cmd(cmd[n + j] + e, sizeof cmd[n + j] - e, mf, r[j].scene, r[j].out, &c, iters);
        memset(&sres[j], 0, sizeof sres[j]);
        for (int k = 0; k < 3; ++k) sres[j].db[k] = NAN;
        slot[n + j] = &sres[j];
    }
    return MF_OK;
}

/* o->seed_stops ("1,2,3"; NULL or "": "4") into stops[0..*n), ascending, each in 1..EV_STAB_MAX_STOPS,
 * no repeats. */
static int parse_stops(const char *text, int *stops, int *n) {
    const char *p = text && text[0] ? text : "4";
    *n = 0;
    while (*p) {
        char *end;
        long k = strtol(p, &end, 10);
        int dup = 0;
        for (int i = 0; i < *n; ++i) dup |= stops[i] == k;
        if (end == p || (*end && (*end != ',' || !end[1])) || k < 1 || k > EV_STAB_MAX_STOPS || dup || *n >= EV_STAB_MAX_STOPS)
            return mf_fail(MF_EARG, "--seed-stops '%s': expected distinct stops in 1..%d separated by commas, e.g. 1,2,3",
                           text, EV_STAB_MAX_STOPS);
        int i = (*n)++;
        for (; i > 0 && stops[i - 1] > k; --i) stops[i] = stops[i - 1]; /* kept in ascending order */
        stops[i] = (int)k;
        p = *end ? end + 1 : end;
    }
    return MF_OK;
}

/* Adds a recon result's three PSNRs to the seed table t (method "<kind> <variant>"). */
static int seed_record(EvTable *t, const char *kind, const char *variant, int seed, const EvStabResult *r) {
    char method[64], scene[16];
    snprintf(method, sizeof method, "%s %s", kind, variant);
    snprintf(scene, sizeof scene, "seed %d", seed);
    int rc = MF_OK;
    for (int k = 0; k < 3 && !rc; ++k)
        if (r->exit_code == 0 && !isnan(r->db[k])) rc = ev_table_add(t, method, "seeds", scene, k_seed_metric[k], r->db[k]);
    return rc;
}

int ev_stab_grid(const char *mf, const char *work, const char *out_dir, const EvStabOpts *o, EvStabResult *results,
                 int cap, int *n_out, EvStabSeedRow *seed_rows, int *n_rows) {
    int iters = o->iters, quick = o->quick, jobs = o->jobs, stops[EV_STAB_MAX_STOPS], nstops = 0;
    char layout[1024], scene[1200], ref_render[1100] = "";
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    *n_out = *n_rows = 0;
    if (o->seeds < 1 || o->seeds > EV_STAB_MAX_SEEDS)
        return mf_fail(MF_EARG, "stability grid: --seeds %d outside [1, %d]", o->seeds, EV_STAB_MAX_SEEDS);
    int rc;
    if ((rc = parse_stops(o->seed_stops, stops, &nstops))) return rc;
    if (o->seed_row_only && (quick || o->seeds < 2))
        return mf_fail(MF_EARG, "stability grid: --seed-row-only needs --seeds 2 or more and no --quick");
    snprintf(layout, sizeof layout, "%s/layout", work);
    rc = mf_mkdirs(work);
    if (rc || (rc = mf_mkdirs(out_dir)) || (rc = ev_stab_layout(layout))) return rc;
    int nc, n = 0;
    const EvStabCell *cells = ev_stab_cells(&nc);
    const EvStabCell *ran[EV_STAB_MAX_CELLS];
    int idx[EV_STAB_MAX_CELLS];
    /* one pool of commands: the cells, the memory row's two runs, the seed row's */
    char(*cmd)[4096] = malloc(EV_STAB_MAX_RUNS * sizeof *cmd), (*err)[1100] = malloc(EV_STAB_MAX_RUNS * sizeof *err);
    EvStabResult mem[2], *slot[EV_STAB_MAX_RUNS], *sres = malloc(EV_STAB_MAX_SEED_RUNS * sizeof *sres);
    SeedRun *sr = malloc(EV_STAB_MAX_SEED_RUNS * sizeof *sr);
    if (!cmd || !err || !sres || !sr) {
        free(cmd), free(err), free(sres), free(sr);
        return mf_fail(MF_ENOMEM, "stability grid: out of memory");
    }
    /* threads per cell: the cores shared by the cells that run at once (set in the child's env) */
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (cores < 1) cores = 1;
    if (jobs < 1) jobs = (int)cores;
    int threads = jobs > 1 ? (int)(cores > jobs ? cores / jobs : 1) : 0;
    char env[64] = "";
    if (threads > 0) snprintf(env, sizeof env, "OMP_NUM_THREADS=%d ", threads);
    for (int i = 0; i < nc && n < cap && n < EV_STAB_MAX_CELLS && !rc; ++i) {
        const EvStabCell *c = &cells[i];
        const EvStabVariant *v = ev_stab_variant(c->variant);
        if ((quick && !c->quick) || o->seed_row_only) continue;
        if (!v) {
            rc = mf_fail(MF_EARG, "stability cell %d: unknown scene variant '%s'", i, c->variant);
            break;
        }
        if ((rc = variant_scene(layout, work, v, scene, sizeof scene))) break;
        char out[1100];
        snprintf(out, sizeof out, "%s/cell%02d", work, i);
        snprintf(err[n], sizeof err[n], "%s/cell%02d.err", work, i);
        size_t e = (size_t)snprintf(cmd[n], sizeof cmd[n], "%s", env);
        cell_cmd(cmd[n] + e, sizeof cmd[n] - e, mf, scene, out, c, iters);
        EvStabResult *r = &results[n];
        memset(r, 0, sizeof *r);
        r->render_db = NAN;
        r->ckpt_values = r->recoveries = -1;
        for (int k = 0; k < 3; ++k) r->db[k] = r->delta[k] = NAN;
        r->rough[0] = r->rough[1] = r->metal[0] = r->metal[1] = NAN;
        slot[n] = r, ran[n] = c, idx[n] = i, ++n;
    }
    int mem_n[2] = {50, o->mem_iters}, nmem = quick || o->seed_row_only ? 0 : 2;
    for (int i = 0; i < nmem && !rc; ++i) {
        static const EvStabCell base = {"memory", "baseline", "reference", "", NULL, 0, 0, 0, 0};
        char out[1100];
        snprintf(scene, sizeof scene, "%s/scenes/reference/000_cup", work);
        snprintf(out, sizeof out, "%s/mem%d", work, i);
        snprintf(err[n + i], sizeof err[n + i], "%s/mem%d.err", work, i);
        size_t e = (size_t)snprintf(cmd[n + i], sizeof cmd[n + i], "%s", env);
        cell_cmd(cmd[n + i] + e, sizeof cmd[n + i] - e, mf, scene, out, &base, mem_n[i]);
        memset(&mem[i], 0, sizeof mem[i]);
        slot[n + i] = &mem[i];
    }
    int nseed = quick || rc || o->seeds < 2 ? 0 : seed_runs(work, o, stops, nstops, sr);
    if (!rc && nseed) rc = seed_cmds(mf, layout, work, env, iters, sr, nseed, n + nmem, cmd, err, slot, sres);
    if (!rc) rc = run_pool(cmd, err, slot, n + nmem + nseed, jobs);
    /* scoring, in the cells' order: each reference cell comes before the cells compared with it */
    const EvStabResult *ref[2] = {NULL, NULL}; /* baseline, materialfusion reference cells */
    for (int j = 0; j < n && !rc; ++j) {
        const EvStabCell *c = ran[j];
        EvStabResult *r = &results[j];
        char out[1100];
        snprintf(out, sizeof out, "%s/cell%02d", work, idx[j]);
        snprintf(scene, sizeof scene, "%s/scenes/%s/000_cup", work, c->variant);
        if (ev_stab_scan_dir(out, &r->exr_files, &r->nonfinite)) {
            rc = MF_EIO;
            break;
        }
        int render = !strcmp(c->kind, "render"), m = !strcmp(c->kind, "materialfusion");
        if (render && is_reference(c, "render")) snprintf(ref_render, sizeof ref_render, "%s", out);
        else if (render && ref_render[0] && r->exit_code == 0 && same_images(ev_stab_variant(c->variant)))
            r->render_db = render_psnr(out, ref_render);
        if (!render && r->exit_code == 0) {
            ev_stab_scan_ckpt(out, &r->ckpt_values, &r->ckpt_nonfinite);
            r->recoveries = count_recoveries(out);
            score_recon(scene, out, r);
            if (is_reference(c, c->kind)) ref[m] = r;
            for (int k = 0; k < 3 && ref[m]; ++k) r->delta[k] = r->db[k] - ref[m]->db[k];
        }
        for (int k = 0; k < 3; ++k) r->bound[k] = render ? 0 : c->max_delta_db;
        r->ok = cell_ok(c, r, err[j]);
    }
    /* the seed rows: seed 1 from the grid's own cells (unless seed_row_only), then the seed runs */
    if (nseed && !rc) {
        EvTable st;
        ev_table_init(&st);
        for (int j = 0; j < n && !rc; ++j) {
            const EvStabCell *c = ran[j];
            if (strcmp(c->kind, "render") && !c->args[0] && seed_variant(c->variant, stops, nstops))
                rc = seed_record(&st, c->kind, c->variant, 1, &results[j]);
        }
        for (int j = 0; j < nseed && !rc; ++j) {
            if (sres[j].exit_code == 0) score_recon(sr[j].scene, sr[j].out, &sres[j]);
            rc = seed_record(&st, sr[j].kind, sr[j].variant, sr[j].seed, &sres[j]);
        }
        for (int i = 0; i < nstops && !rc; ++i) ev_stab_seed_row(&st, stops[i], &seed_rows[i]);
        if (!rc) *n_rows = nstops;
        ev_table_free(&st);
    }
    if (!rc && *n_rows) ev_stab_spread_bounds(ran, results, n, &seed_rows[0]);
    free(cmd), free(err), free(sres), free(sr);
    if (rc) return rc;
    *n_out = n;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double total = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    return write_report(out_dir, ran, results, n, iters, mem, mem_n, nmem, seed_rows, *n_rows, total, jobs, threads);
}
