/* mf compare: paired statistics (each method minus a reference method, over the scenes both have)
 * from the per-scene records that `mf eval` wrote (scenes.csv). `mf eval` writes the same tables
 * against its first method; this command recomputes them for any reference without re-scoring. */
#include <stdio.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_paired.h"

static const char usage[] =
    "usage: mf compare SCENES_CSV --ref METHOD -o DIR [--dataset NAME]\n"
    "Reads per-scene records (method,dataset,scene,metric,value; the scenes.csv of mf eval) and writes\n"
    "DIR/paired.md and DIR/paired.csv: for every other method and metric, the mean paired difference\n"
    "(method - METHOD) over the shared scenes, its 95% CI (Student t), wins out of n, and two-sided\n"
    "p-values of the paired t-test and the exact sign test (GSL). --dataset: which dataset's records\n"
    "(default: the first record's).\n";

#define MAX_METHODS 64

static int cmd_compare(int argc, char **argv) {
    const char *csv = NULL, *ref = NULL, *out = NULL, *dataset = NULL;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "--ref", &ref)) || (r = mf_opt_str(argc, argv, &i, "-o", &out)) ||
            (r = mf_opt_str(argc, argv, &i, "--dataset", &dataset))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (argv[i][0] == '-') { mf_fail(MF_EARG, "unknown option %s (see mf compare --help)", argv[i]); return MF_EXIT_USAGE; }
        csv = argv[i];
    }
    if (!csv || !ref || !out) { mf_fail(MF_EARG, "need SCENES_CSV, --ref and -o (see mf compare --help)"); return MF_EXIT_USAGE; }
    EvTable t;
    ev_table_init(&t);
    int rc = ev_table_read_csv(&t, csv);
    if (!rc && t.n == 0) rc = mf_fail(MF_EFORMAT, "%s: no records", csv);
    if (!dataset && !rc) dataset = t.rec[0].dataset;
    const char *methods[MAX_METHODS];
    int nm = 0, has_ref = 0;
    for (size_t i = 0; i < t.n && !rc; ++i) {
        if (strcmp(t.rec[i].dataset, dataset)) continue;
        int seen = 0;
        for (int m = 0; m < nm && !seen; ++m) seen = !strcmp(methods[m], t.rec[i].method);
        if (!seen && nm < MAX_METHODS) methods[nm++] = t.rec[i].method;
        has_ref |= !strcmp(t.rec[i].method, ref);
    }
    if (!rc && !has_ref) rc = mf_fail(MF_EARG, "%s: no records of method %s on dataset %s", csv, ref, dataset);
    if (!rc) rc = mf_mkdirs(out);
    if (!rc) rc = ev_paired_write_bench(&t, out, ref, methods, nm, dataset);
    ev_table_free(&t);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(compare, "compare", "paired differences between methods over scenes (CI, wins, p) from scenes.csv", usage, cmd_compare)
