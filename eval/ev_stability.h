/* ev_stability: the numerical-stability grid (issue 18, item 1).
 *
 * Each cell is one `mf` command run as a child process (fork + exec through /bin/sh, so the
 * child IS mf and wait4's ru_maxrss is mf's peak RSS) on one scene variant (ev_stab_scene.h:
 * the tiny split's 000_cup, unchanged or rewritten into a hard case). Per cell: exit code, wall
 * seconds, peak RSS, whether any EXR under the cell's output folder holds a NaN/Inf
 * (mf_exr_read refuses them), and, for cells expected to be refused, whether stderr names the
 * option. Render cells: the worst per-view PSNR of their linear RGB against the reference
 * render cell's (same cameras; meaningful where the images should not change, e.g. scale).
 * Recon cells: relit / albedo / ORM PSNR of the result against the variant's own ground truth
 * (ev_eval_scene, scale-aligned as `mf eval`), their difference to the reference recon cell of
 * the same method, and the mean roughness / metallic of the result's orm.png against gt/orm.png
 * (texel means, unseen texels included); checkpoint.mfck read whatever its table
 * (mf_ckpt_read) and every value (parameters and optimiser moments) checked finite; the guard's
 * recoveries counted from run.json. */
#ifndef EV_STABILITY_H
#define EV_STABILITY_H

#include <stddef.h>

#include "eval/ev_stab_scene.h"
#include "eval/ev_table.h"

#define EV_STAB_MAX_CELLS 128
#define EV_STAB_MAX_SEEDS 9
/* The seed row's darkenings of the 8-bit training images: 1..EV_STAB_MAX_STOPS stops. */
#define EV_STAB_MAX_STOPS 4
/* The seed row's runs: per seed and method the reference and, per darkening, png_-K and png_-K_x1. */
#define EV_STAB_MAX_SEED_RUNS (EV_STAB_MAX_SEEDS * 2 * (1 + 2 * EV_STAB_MAX_STOPS))
/* Child runs of one grid: the cells, the memory row's two, the seed row's. */
#define EV_STAB_MAX_RUNS (EV_STAB_MAX_CELLS + 2 + EV_STAB_MAX_SEED_RUNS)

typedef struct {
    const char *name;    /* cell label, e.g. "lr at its maximum (1)" */
    const char *kind;    /* "render", "baseline" or "materialfusion" */
    const char *variant; /* scene variant id (ev_stab_variant) */
    const char *args;    /* extra arguments appended to the cell's command */
    const char *refuse;  /* NULL: must succeed; else the option name a refusal must mention */
    double max_delta_db; /* recon, > 0: |relit|, |albedo| and |ORM| dB difference to the reference cell <= this */
    int spread_bound;    /* recon, 1: the bound of each metric is the larger of max_delta_db and the method's
                            reference spread over the seed row's seeds (max - min): a run that amplifies
                            last-bit input changes moves by as much as a new seed (without a seed row:
                            max_delta_db) */
    double min_render_db; /* render, > 0: PSNR against the reference render >= this */
    int quick;           /* 1: in the subset `make test` runs */
} EvStabCell;

typedef struct {
    int exit_code;      /* child exit code; -1 on a signal */
    double wall_s;      /* wall seconds */
    long peak_rss_kb;   /* child's peak resident set size, KiB */
    int nonfinite;      /* EXR files under the cell's output with a NaN/Inf */
    int exr_files;      /* EXR files scanned */
    double db[3];       /* recon: relit, albedo, ORM PSNR (NaN: not scored / no view scored) */
    double delta[3];    /* recon: db - the reference cell's db (NaN when either is missing) */
    double bound[3];    /* recon: the |delta| bound applied to each metric (0: none; EvStabCell) */
    double rough[2], metal[2]; /* recon: mean roughness / metallic, {result, truth} (NaN: not read) */
    double render_db;   /* render: worst view PSNR against the reference render (NaN: not compared) */
    long ckpt_values;   /* recon: floats in checkpoint.mfck (mf_ckpt_read; -1: missing or unreadable) */
    long ckpt_nonfinite; /* recon: how many of them are NaN/Inf (parameters and Adam moments alike) */
    int recoveries;     /* recon: entries of run.json's options.recoveries (-1: not read) */
    int ok;             /* 1 when the cell behaved as expected (see EvStabCell) */
} EvStabResult;

/* The grid's settings (mf bench-stability's options). */
typedef struct {
    int iters;     /* iterations of each recon cell */
    int mem_iters; /* the memory row's long run (its short run: 50) */
    int quick;     /* 1: only the cells marked quick; no memory or seed row */
    int jobs;      /* cells run at once (< 1: one per core) */
    int seeds;     /* 1..EV_STAB_MAX_SEEDS: the seed row runs the 8-bit darkened cells (png_-K,
                      png_-K_x1) and their references at recon seeds 1..seeds, seed 1 of those the
                      grid has (reference, png_-4, png_-4_x1) taken from the grid (1: no seed row) */
    const char *seed_stops; /* the seed row's darkenings K, a comma list in 1..EV_STAB_MAX_STOPS
                               (NULL or "": "4", the grid's own png_-4 cells) */
    int seed_row_only; /* 1: no cells and no memory row, only the seed row (every seed run here) */
} EvStabOpts;

/* The seed row of one darkening: the effect of darkening the 8-bit training images K = `stops`
 * stops on each method ([0] baseline, [1] MaterialFusion) and metric (relit, albedo, ORM PSNR),
 * paired over recon seeds 1..n (ev_paired: mean difference and its 95% CI), split in three
 * comparisons (a - b):
 *   EV_SEED_TOTAL     png_-K - reference      what darkening an 8-bit capture costs in all;
 *   EV_SEED_EXPOSURE  png_-K - png_-K_x1      the same bits at two exposures: the method's part;
 *   EV_SEED_BITS      png_-K_x1 - reference   the same exposure, fewer bits: the images' part;
 * beside the reference's own seed-to-seed spread (max - min over the seeds). ok: every exposure
 * |mean| <= EV_STAB_SEED_DB, issue 18's exposure target for the method (the total is reported,
 * not bounded: the bits part is information the darkened images no longer hold). */
#define EV_STAB_SEED_DB 0.3
enum { EV_SEED_TOTAL, EV_SEED_EXPOSURE, EV_SEED_BITS, EV_SEED_NCMP };
typedef struct {
    int stops, n;
    double mean[EV_SEED_NCMP][2][3], lo[EV_SEED_NCMP][2][3], hi[EV_SEED_NCMP][2][3], spread[2][3];
    int ok;
} EvStabSeedRow;

/* For the cells with spread_bound: each metric's bound becomes the larger of the cell's
 * max_delta_db and the method's reference spread in row (a NaN spread leaves max_delta_db), and
 * the cell's ok is judged again. cells (n,) and res (n,) in the same order; other cells untouched. */
void ev_stab_spread_bounds(const EvStabCell *const *cells, EvStabResult *res, int n, const EvStabSeedRow *row);

/* Counts the .exr files under `dir` (recursively) and those that hold a non-finite value. */
int ev_stab_scan_dir(const char *dir, int *exr_files, int *nonfinite);

/* dir/checkpoint.mfck: *values = its float count (-1 when missing or unreadable), *nonfinite =
 * how many are NaN/Inf. */
void ev_stab_scan_ckpt(const char *dir, long *values, long *nonfinite);

/* Runs the grid: builds the variants the cells use under work/scenes/, then every cell of
 * ev_stab_cells() (o->quick: only those marked quick, and no memory or seed row); recon cells run
 * o->iters iterations (memory row: 50 and o->mem_iters). o->jobs: cells run at once (< 1: one per
 * core); with jobs > 1 each gets OMP_NUM_THREADS = cores / jobs (at least 1). Results are not bit-identical across
 * thread counts (the renderer's OpenMP sums run in another order), so every cell of a run gets
 * the same count and is compared with its reference cell from the same run; wall times are
 * measured under the load of the cells beside it. results[i] belongs to the i-th
 * cell run (ev_stab_cells order, skipping the others); seed_rows[0..*n_rows) (room for
 * EV_STAB_MAX_STOPS) get the seed row of each darkening of o->seed_stops (*n_rows = 0 without a
 * seed row). Writes out_dir/README.md, out_dir/grid.csv (not with o->seed_row_only) and
 * out_dir/seeds.csv (with a seed row) atomically. */
int ev_stab_grid(const char *mf_bin, const char *work, const char *out_dir, const EvStabOpts *o, EvStabResult *results,
                 int cap, int *n_out, EvStabSeedRow *seed_rows, int *n_rows);
/* The seed row of darkening `stops` from t's records (method "<kind> <variant>" for kind baseline
 * and materialfusion and variant reference, png_-K and png_-K_x1 with K = stops; dataset "seeds",
 * scene = the seed, metrics relit_psnr, albedo_psnr, orm_psnr). */
void ev_stab_seed_row(const EvTable *t, int stops, EvStabSeedRow *row);

/* The grid's cells; *n gets their count. */
const EvStabCell *ev_stab_cells(int *n);
/* The variant of that id, or NULL. */
const EvStabVariant *ev_stab_variant(const char *id);

#endif
