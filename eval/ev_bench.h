/* ev_bench: the benchmark driver behind `mf eval`: scores every method's result folders on a
 * data set split and writes the report.
 *
 * Scenes: DATA itself when it holds transforms_test.json, else its sub-folders that do (sorted,
 * optionally filtered by a comma-separated list, every name of which must be a scene there).
 * Methods: a comma-separated list or every folder of RESULTS (sorted), plus the trivial guesses
 * when asked (EV_TRIVIAL_*_DIR, ev_eval.h). Names up to EV_NAME_MAX - 1 characters and at most 64
 * scenes and 64 methods; anything beyond is refused, never truncated or dropped. Each
 * RESULTS/<method>/<scene>/ is scored by ev_eval_scene (a missing one is skipped with a warning);
 * its run.json adds time_s, mem_mb, prior_share and time_x (wall time over the first method's on
 * the same scene) to the table. Writes OUT/ per_view.csv, scenes.csv, {relight, materials, cost,
 * orb, novelview}.{md,tex} (each only when it has numbers), paired.{md,csv} (every method minus
 * the first), speed_error.png (relit PSNR at each texture snapshot against wall time, first scene;
 * needs gnuplot), grid_<scene>.png (first 6 scenes), index.html and runs.md (provenance of every
 * scored run). All files are written atomically. */
#ifndef EV_BENCH_H
#define EV_BENCH_H

#include "eval/ev_eval.h"

typedef struct {
    const char *data;    /* borrowed; split folder of bvault scenes, or one scene (required) */
    const char *results; /* borrowed; folder of <method>/<scene>/ result folders (required) */
    const char *out;     /* borrowed; report folder, created (required) */
    const char *methods; /* borrowed; comma-separated methods, NULL: every folder in results */
    const char *scenes;  /* borrowed; comma-separated scenes, NULL: every scene of data */
    const char *dataset; /* borrowed; data set name in the tables, NULL: data's folder name */
    int no_curves;       /* skip the speed-vs-error curves */
    int trivial;         /* also score trivial-grey and trivial-flat-light */
    const char *revision;      /* borrowed; the build's revision, for runs.md */
    int argc;                  /* the command line (after `mf`), for runs.md */
    char *const *argv;         /* borrowed; (argc,) */
} EvBench;

/* Scores and writes the report with the protocol options o. Returns MF_OK or an error code
 * (message in mf_error(), naming the folder). */
int ev_bench_run(const EvBench *b, const EvEvalOpts *o);

/* The scene folders of dir (those holding transforms_test.json or transforms.json), sorted, into
 * *names (malloc'ed, (*n,)); MF_EIO naming dir when it cannot be read. */
int ev_scene_dirs(const char *dir, EvName **names, int *n);

#endif
