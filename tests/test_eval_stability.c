/* The fast subset of the numerical-stability grid (eval/ev_stability.h; issue 18): the cells
 * marked quick, recon at 20 iterations, through `mf` (MF_BIN). Every cell must behave as
 * expected: no NaN/Inf in any EXR it writes, exit 0 inside the options' ranges (bounds
 * included), a refusal naming the option for the others, and the cell's stated bound: float
 * training images x 2^-8 and x 2^8 reconstruct within 0.3 dB of the reference (relit, albedo,
 * ORM), a scene scaled x 1e-4 and x 1e4 renders within 50 dB of x 1; recon cells are scored. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_split.h"
#include "eval/ev_stability.h"
#include "mf_test.h"
#include "io/mf_ckpt.h"

/* The checkpoint scan reads a checkpoint of any table and counts its NaN/Inf values. */
MF_TEST(stability_checkpoint_scan) {
    char dir[1024], path[1100];
    mf_test_path_to(dir, sizeof dir, "stab_ckpt");
    snprintf(path, sizeof path, "%s/checkpoint.mfck", dir);
    CHECK_OK(mf_mkdirs(dir));
    MfTensorSpec specs[2];
    int s0[1] = {3}, s1[2] = {2, 2};
    mf_spec_set(&specs[0], "kd", "value", 1, s0);
    mf_spec_set(&specs[1], "env", "m2", 2, s1);
    float data[7] = {0.5f, 1.0f, 2.0f, 0.0f, 1e-30f, 3.0f, 4.0f};
    long values = 0, bad = 0;
    CHECK_OK(mf_ckpt_save(path, specs, 2, data, NULL));
    ev_stab_scan_ckpt(dir, &values, &bad);
    CHECK(values == 7 && bad == 0);
    data[1] = NAN, data[5] = INFINITY;
    CHECK_OK(mf_ckpt_save(path, specs, 2, data, NULL));
    ev_stab_scan_ckpt(dir, &values, &bad);
    CHECK(values == 7 && bad == 2);
    remove(path);
    ev_stab_scan_ckpt(dir, &values, &bad);
    CHECK(values == -1);
}

MF_TEST(stability_quick_grid) {
    MF_NEED_BIN();
    const char *mf = getenv("MF_BIN");
    if (!mf_file_exists(DS_DEFAULT_ENV_DIR "/studio.exr")) MF_SKIP("blender-data probes not installed (" DS_DEFAULT_ENV_DIR ")");
    char work[1024], out[1100];
    mf_test_path_to(work, sizeof work, "stability");
    snprintf(out, sizeof out, "%s/report", work);
    EvStabResult res[EV_STAB_MAX_CELLS];
    int n = 0, nc, nq = 0, bounded = 0;
    EvStabOpts o = {.iters = 20, .mem_iters = 50, .quick = 1, .jobs = 2, .seeds = 1};
    EvStabSeedRow rows[EV_STAB_MAX_STOPS];
    int nrows = -1;
    CHECK_OK(ev_stab_grid(mf, work, out, &o, res, EV_STAB_MAX_CELLS, &n, rows, &nrows));
    CHECK(nrows == 0);
    const EvStabCell *cells = ev_stab_cells(&nc);
    for (int i = 0; i < nc; ++i) nq += cells[i].quick;
    CHECK(n == nq && n >= 10);
    for (int i = 0, k = 0; i < nc && k < n; ++i) {
        const EvStabCell *c = &cells[i];
        if (!c->quick) continue;
        const EvStabResult *r = &res[k++];
        CHECK_MSG(r->nonfinite == 0, "%s / %s / %s: %d EXR files with NaN/Inf", c->kind, c->variant, c->name, r->nonfinite);
        CHECK_MSG(r->ok, "%s / %s / %s: exit %d, render %.2f dB, delta %.2f / %.2f / %.2f dB: not as expected (refusal must name %s)",
                  c->kind, c->variant, c->name, r->exit_code, r->render_db, r->delta[0], r->delta[1], r->delta[2],
                  c->refuse ? c->refuse : "nothing");
        if (c->refuse) continue;
        CHECK_MSG(r->exr_files > 0, "%s / %s / %s wrote no EXR", c->kind, c->variant, c->name);
        if (strcmp(c->kind, "render")) {
            CHECK_MSG(!isnan(r->db[0]) && !isnan(r->rough[0]), "%s / %s / %s: not scored", c->kind, c->variant, c->name);
            CHECK_MSG(r->ckpt_values > 0 && r->ckpt_nonfinite == 0, "%s / %s / %s: checkpoint %ld floats, %ld non-finite", c->kind,
                      c->variant, c->name, r->ckpt_values, r->ckpt_nonfinite);
            CHECK(r->recoveries >= 0);
        }
        bounded += c->max_delta_db > 0 || c->min_render_db > 0;
        CHECK(r->peak_rss_kb > 0 && r->wall_s > 0);
    }
    CHECK(bounded >= 4); /* exposure x 2^-8, x 2^8 and scale x 1e-4, x 1e4 */
    char md[1200];
    snprintf(md, sizeof md, "%s/README.md", out);
    CHECK(mf_file_exists(md));
}

/* One seed of the seed row's table: method kind's png_-K_x1 and png_-K values of metric (K = stops),
 * and its reference value unless ref is NaN. */
static void add_seed_stops(EvTable *t, int stops, const char *kind, const char *metric, int seed, double ref, double x1,
                           double var) {
    const double v[3] = {ref, x1, var};
    char sc[24];
    snprintf(sc, sizeof sc, "seed %d", seed);
    for (int i = 0; i < 3; ++i) {
        char m[64];
        if (i) snprintf(m, sizeof m, "%s png_-%d%s", kind, stops, i == 1 ? "_x1" : "");
        else snprintf(m, sizeof m, "%s reference", kind);
        if (!isnan(v[i])) CHECK_OK(ev_table_add(t, m, "seeds", sc, metric, v[i]));
    }
}

static void add_seed(EvTable *t, const char *kind, const char *metric, int seed, double ref, double x1, double var) {
    add_seed_stops(t, 4, kind, metric, seed, ref, x1, var);
}

/* The seed row: per method and metric the paired means over seeds (with CI, ev_paired) of total =
 * png_-4 - reference, exposure = png_-4 - png_-4_x1 and bits = png_-4_x1 - reference, the
 * reference's spread (max - min); ok only when every exposure |mean| <= 0.3 dB (the total is not
 * bounded). */
MF_TEST(stability_seed_row) {
    static const char *kind[2] = {"baseline", "materialfusion"}, *metric[3] = {"relit_psnr", "albedo_psnr", "orm_psnr"};
    static const double ref[3] = {20.0, 20.4, 19.8}, expo[3] = {0.1, 0.2, 0.3}, bits[3] = {0.5, 0.5, 0.8};
    EvTable t;
    ev_table_init(&t);
    for (int m = 0; m < 2; ++m)
        for (int s = 0; s < 3; ++s)
            for (int k = 0; k < 3; ++k) {
                double x1 = ref[s] + k + bits[s], var = x1 + expo[s] * (m ? 3.0 : 1.0);
                add_seed(&t, kind[m], metric[k], s + 1, ref[s] + k, x1, var);
                add_seed_stops(&t, 2, kind[m], metric[k], s + 1, NAN, x1, x1 + (s ? 0.1 : 0.0)); /* exposure mean 0.2 / 3 */
            }
    EvStabSeedRow row;
    ev_stab_seed_row(&t, 4, &row);
    CHECK(row.n == 3 && row.stops == 4);
    CHECK_NEAR(row.mean[EV_SEED_EXPOSURE][0][1], 0.2, 1e-9);
    CHECK_NEAR(row.mean[EV_SEED_BITS][0][1], 0.6, 1e-9);
    CHECK_NEAR(row.mean[EV_SEED_TOTAL][0][1], 0.8, 1e-9);
    CHECK_NEAR(row.spread[0][2], 0.6, 1e-9);
    CHECK(row.lo[EV_SEED_EXPOSURE][0][0] < 0.2 && row.hi[EV_SEED_EXPOSURE][0][0] > 0.2);
    CHECK_NEAR(row.mean[EV_SEED_EXPOSURE][1][0], 0.6, 1e-9);
    CHECK(!row.ok); /* MaterialFusion's exposure mean 0.6 dB > 0.3 */
    ev_stab_seed_row(&t, 2, &row); /* the 2-stop variants of the same table, beside the same references */
    CHECK(row.n == 3 && row.stops == 2 && row.ok);
    CHECK_NEAR(row.mean[EV_SEED_EXPOSURE][1][0], 0.2 / 3, 1e-9);
    CHECK_NEAR(row.mean[EV_SEED_BITS][0][1], 0.6, 1e-9);
    CHECK_NEAR(row.mean[EV_SEED_TOTAL][1][1], 0.6 + 0.2 / 3, 1e-9);
    ev_table_free(&t);
    ev_table_init(&t);
    for (int m = 0; m < 2; ++m)
        for (int s = 0; s < 2; ++s)
            for (int k = 0; k < 3; ++k) add_seed(&t, kind[m], metric[k], s + 1, ref[s], ref[s] + 1.0, ref[s] + 1.0 + (s ? 0.25 : -0.25));
    ev_stab_seed_row(&t, 4, &row);
    CHECK(row.n == 2 && row.ok && fabs(row.mean[EV_SEED_EXPOSURE][1][2]) < 1e-12); /* +-0.25 cancels */
    CHECK_NEAR(row.mean[EV_SEED_TOTAL][1][2], 1.0, 1e-9); /* a 1 dB total from the bits alone is not bounded */
    ev_table_free(&t);
    ev_table_init(&t); /* no png_-4_x1 runs: no exposure comparison, not ok */
    for (int s = 0; s < 2; ++s)
        for (int k = 0; k < 3; ++k) {
            char sc[24];
            snprintf(sc, sizeof sc, "seed %d", s + 1);
            CHECK_OK(ev_table_add(&t, "baseline reference", "seeds", sc, metric[k], ref[s]));
            CHECK_OK(ev_table_add(&t, "baseline png_-4", "seeds", sc, metric[k], ref[s]));
        }
    ev_stab_seed_row(&t, 4, &row);
    CHECK(row.n == 0 && !row.ok);
    ev_table_free(&t);
}

/* The seed row's options are checked before any work: darkenings outside 1..4, repeated or not a
 * number, and --seed-row-only without seeds to pair, each refused naming the option. */
MF_TEST(stability_seed_options_refused) {
    static const char *bad[] = {"5", "0", "1,1", "2,x", "3,", "1,2,3,4,1"};
    char work[1024];
    mf_test_path_to(work, sizeof work, "stability-refused");
    EvStabResult res[1];
    EvStabSeedRow rows[EV_STAB_MAX_STOPS];
    int n, nrows;
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        EvStabOpts o = {.iters = 1, .mem_iters = 1, .seeds = 2, .seed_stops = bad[i]};
        CHECK_ERR(ev_stab_grid("mf", work, work, &o, res, 1, &n, rows, &nrows), "--seed-stops");
    }
    EvStabOpts o = {.iters = 1, .mem_iters = 1, .seeds = 1, .seed_stops = "1,2", .seed_row_only = 1};
    CHECK_ERR(ev_stab_grid("mf", work, work, &o, res, 1, &n, rows, &nrows), "--seed-row-only");
    CHECK(!mf_file_exists(work)); /* refused before anything was written */
}

/* MaterialFusion's scale cells: bounded by the larger of 0.3 dB and its reference's seed spread
 * per metric once the seed row has measured it; the baseline's keep 0.3 dB; a NaN spread keeps it. */
MF_TEST(stability_scale_cells_spread_bound) {
    int nc;
    const EvStabCell *cells = ev_stab_cells(&nc), *pick[3] = {NULL, NULL, NULL};
    for (int i = 0; i < nc; ++i) {
        if (strcmp(cells[i].variant, "scale_1e2")) continue;
        if (!strcmp(cells[i].kind, "materialfusion")) pick[0] = pick[2] = &cells[i];
        if (!strcmp(cells[i].kind, "baseline")) pick[1] = &cells[i];
    }
    CHECK(pick[0] && pick[1] && pick[0]->spread_bound && !pick[1]->spread_bound);
    if (!pick[0] || !pick[1]) return;
    EvStabResult res[3];
    memset(res, 0, sizeof res);
    for (int j = 0; j < 3; ++j) {
        res[j].ckpt_values = 10;
        for (int k = 0; k < 3; ++k) res[j].bound[k] = pick[j]->max_delta_db, res[j].delta[k] = -0.31;
    }
    res[2].delta[2] = 2.5; /* beyond MaterialFusion's ORM spread */
    EvStabSeedRow row;
    memset(&row, 0, sizeof row);
    const double spread[2][3] = {{0.2, 0.4, 0.1}, {1.8, 2.3, 2.0}};
    memcpy(row.spread, spread, sizeof spread);
    ev_stab_spread_bounds(pick, res, 3, &row);
    CHECK(res[0].ok && res[0].bound[0] == 1.8 && res[0].bound[1] == 2.3 && res[0].bound[2] == 2.0);
    CHECK(!res[1].ok && res[1].bound[1] == pick[1]->max_delta_db); /* the baseline: -0.31 against 0.3 */
    CHECK(!res[2].ok);
    row.spread[1][0] = row.spread[1][1] = row.spread[1][2] = NAN;
    ev_stab_spread_bounds(pick, res, 1, &row);
    CHECK(!res[0].ok && res[0].bound[0] == pick[0]->max_delta_db);
}
