/* mf compare: paired statistics (each method minus a reference method, over the scenes both have)
 * from the per-scene records that `mf eval` wrote (scenes.csv). `mf eval` writes the same tables
 * against its first method; this command recomputes them for any reference without re-scoring. */
#include <stdio.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_paired.h"

typedef struct {
    const char *ref, *out, *dataset;
} CompareArgs;

#define A CompareArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, ref, NULL, "reference method (required)", .meta = "METHOD"),
    MF_OPT_STR(A, out, NULL, "output folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, dataset, NULL, "which dataset's records", .unset = "the first record's", .meta = "NAME"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options", k_args);

static char usage[4096];
__attribute__((constructor)) static void compare_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf compare SCENES_CSV --ref METHOD -o DIR [--dataset NAME]\n"
                       "Reads per-scene records (method,dataset,scene,metric,value; the scenes.csv of mf eval) and writes\n"
                       "DIR/paired.md and DIR/paired.csv: for every other method and metric, the mean paired difference\n"
                       "(method - METHOD) over the shared scenes, its 95% CI (Student t), wins out of n, and two-sided\n"
                       "p-values of the paired t-test and the exact sign test (GSL).\n",
                       t, 1, NULL);
}

#define MAX_METHODS 64

static int cmd_compare(int argc, char **argv) {
    CompareArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int ec = mf_cli_parse(&bind, 1, argc, argv, 1, &p);
    if (ec >= 0) return ec;
    const char *csv = p.npos ? p.pos[0] : NULL, *ref = a.ref, *out = a.out, *dataset = a.dataset;
    if (!csv || !ref || !out) {
        mf_opts_parse_free(&p);
        mf_fail(MF_EARG, "need SCENES_CSV, --ref and -o (see mf compare --help)");
        return MF_EXIT_USAGE;
    }
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
    mf_opts_parse_free(&p);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

MF_COMMAND(compare, "compare", "paired differences between methods over scenes (CI, wins, p) from scenes.csv", usage, cmd_compare)
