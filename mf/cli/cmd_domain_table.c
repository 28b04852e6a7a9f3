/* mf domain-table: the 2D prior's generalisation matrix (eval/ev_domain.h) from the table2d.csv
 * files of `mf eval-prior`, one per cell. A thin wrapper: the table logic is in eval/. */
#include <stdio.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_domain.h"

typedef struct {
    const char *out, *csv;
} DomainArgs;

static const MfOpt k_args[] = {
    MF_OPT_STR(DomainArgs, out, NULL, "markdown table (required)", .alias = "-o", .meta = "FILE.md"),
    MF_OPT_STR(DomainArgs, csv, NULL, "also the numbers as CSV", .meta = "FILE.csv", .unset = "none"),
};
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--cell, --pair, --caption and --note repeat, so they are flags only; no --config)", k_args);

static char usage[4096];
__attribute__((constructor)) static void domain_table_usage(void) {
    MfStrBuf b = {0};
    mf_opts_usage(&b, &k_args_table);
    snprintf(usage, sizeof usage, "%s%s",
             "usage: mf domain-table --cell LABEL=TABLE2D_CSV ... -o FILE.md [--csv FILE.csv] [--pair A,REF ...]\n"
             "                       [--caption LINE ...] [--note LINE ...]\n"
             "  Per cell (one `mf eval-prior` table2d.csv each): StableMaterial albedo and ORM PSNR and the best\n"
             "  training-free albedo baseline (Input image or Retinex), mean over views with 95% CI; per --pair,\n"
             "  the paired difference A - REF over the views both cells share (same generator seed: view i is\n"
             "  the same object, camera and light). All PSNR are masked (inside the GT mask). --caption lines go\n"
             "  above the tables, --note lines below.\n",
             b.s ? b.s : "");
    mf_sb_free(&b);
}

#define MAX_LINES 32

/* A repeated flag: 1 and its value in *v (advancing *i) when argv[*i] is name; -1 when its value is missing. */
static int repeated(int argc, char **argv, int *i, const char *name, const char **v) {
    if (strcmp(argv[*i], name)) return 0;
    if (*i + 1 >= argc) return mf_fail(MF_EARG, "%s needs a value", name), -1;
    *v = argv[++*i];
    return 1;
}

static int cmd_domain_table(int argc, char **argv) {
    EvDomainCell cells[EV_DOMAIN_MAX_CELLS];
    char labels[EV_DOMAIN_MAX_CELLS][48], pairbuf[MAX_LINES][96];
    const char *pairs[2 * MAX_LINES], *caption[MAX_LINES], *notes[MAX_LINES];
    int nc = 0, np = 0, ncap = 0, nn = 0;
    DomainArgs a;
    mf_opts_defaults(&k_args_table, &a);
    for (int i = 1; i < argc; ++i) {
        const char *v = NULL;
        int r;
        if ((r = mf_opts_parse_arg(&k_args_table, &a, argc, argv, &i))) {
            if (r < 0) return MF_EXIT_USAGE;
        } else if ((r = repeated(argc, argv, &i, "--cell", &v))) {
            const char *eq = r > 0 ? strchr(v, '=') : NULL;
            if (r < 0 || !eq || eq == v || (size_t)(eq - v) >= sizeof labels[0] || nc == EV_DOMAIN_MAX_CELLS) {
                if (r > 0) mf_fail(MF_EARG, "--cell '%s': expected LABEL=PATH (label < 48 characters, at most %d cells)", v, EV_DOMAIN_MAX_CELLS);
                return MF_EXIT_USAGE;
            }
            snprintf(labels[nc], sizeof labels[nc], "%.*s", (int)(eq - v), v);
            cells[nc].label = labels[nc], cells[nc].csv = eq + 1, ++nc;
        } else if ((r = repeated(argc, argv, &i, "--pair", &v))) {
            char *comma = NULL;
            if (r > 0 && np < MAX_LINES && strlen(v) < sizeof pairbuf[0]) {
                snprintf(pairbuf[np], sizeof pairbuf[np], "%s", v);
                comma = strchr(pairbuf[np], ',');
            }
            if (r < 0 || !comma) {
                if (r > 0) mf_fail(MF_EARG, "--pair '%s': expected A,REF (cell labels)", v);
                return MF_EXIT_USAGE;
            }
            *comma = '\0';
            pairs[2 * np] = pairbuf[np], pairs[2 * np + 1] = comma + 1, ++np;
        } else if ((r = repeated(argc, argv, &i, "--caption", &v)) || (r = repeated(argc, argv, &i, "--note", &v))) {
            int is_cap = !strcmp(argv[i - 1], "--caption");
            if (r < 0 || (is_cap ? ncap : nn) == MAX_LINES) {
                if (r > 0) mf_fail(MF_EARG, "at most %d --caption and %d --note lines", MAX_LINES, MAX_LINES);
                return MF_EXIT_USAGE;
            }
            if (is_cap) caption[ncap++] = v;
            else notes[nn++] = v;
        } else {
            mf_fail(MF_EARG, "domain-table: unknown argument '%s'", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    const char *out = a.out, *csv = a.csv;
    if (!nc || !out) {
        mf_fail(MF_EARG, "domain-table: need at least one --cell LABEL=CSV and -o FILE.md");
        return MF_EXIT_USAGE;
    }
    if (mf_mkdirs_for(out) || (csv && mf_mkdirs_for(csv))) return MF_EXIT_FAIL;
    if (ev_domain_write(cells, nc, pairs, np, caption, ncap, notes, nn, out, csv)) return MF_EXIT_FAIL;
    printf("wrote %s%s%s\n", out, csv ? " and " : "", csv ? csv : "");
    return MF_EXIT_OK;
}

MF_COMMAND(domain_table, "domain-table", "the 2D prior's generalisation matrix (renderer x content) from eval-prior records",
           usage, cmd_domain_table)
