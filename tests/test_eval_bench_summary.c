/* eval/bench_summary.py (make bench-summary, reports/bench/README.md): each method minus the
 * baseline per split, copied from the reports' paired.csv, with the prior weights from runs.md. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "mf_test.h"

static void write_in(const char *dir, const char *name, const char *text) {
    char p[1100];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_write_file(p, text, strlen(text)));
}

static const char *k_paired =
    "method,ref,dataset,metric,n,mean,lo,hi,wins,ties,p_t,p_sign\n"
    "materialfusion,nvdiffrecmc,s,relit_psnr,9,0.5,-0.25,1.25,6,0,0.17,0.5\n"
    "materialfusion,nvdiffrecmc,s,albedo_psnr,9,1.0,0.2,1.8,8,0,0.02,0.04\n"
    "materialfusion,nvdiffrecmc,s,orm_psnr,9,-2.0,-3.0,-1.0,1,0,0.001,0.04\n"
    "materialfusion,nvdiffrecmc,s,time_x,9,0.7,0.5,0.9,0,0,0.001,0.004\n"
    "trivial-grey,nvdiffrecmc,s,relit_psnr,9,-5,-8,-2,1,0,0.002,0.04\n"
    "materialfusion,trivial-grey,s,relit_psnr,9,9,9,9,9,0,0,0\n";

/* new: runs.md with the prior column; old: without it, the prior from --prior-weights; the
 * revision unknown to git and no --prior-weights: said so, not guessed. */
MF_TEST(eval_bench_summary_table) {
    if (mf_test_sh("python3 -c 'import csv, argparse' >/dev/null 2>&1")) {
        mf_test_skip("no python3");
        return;
    }
    char a[1024], b[1024], c[1024], out[1100];
    mf_test_path_to(a, sizeof a, "summary_new");
    mf_test_path_to(b, sizeof b, "summary_old");
    mf_test_path_to(c, sizeof c, "summary_unknown");
    snprintf(out, sizeof out, "%s/README.md", a);
    write_in(a, "paired.csv", k_paired);
    write_in(b, "paired.csv", k_paired);
    write_in(c, "paired.csv", k_paired);
    write_in(a, "runs.md",
             "# Provenance\n\n| method | scene | revision | prior | seed | threads | wall s | peak MB | command |\n"
             "|---|---|---|---|---:|---:|---:|---:|---|\n"
             "| nvdiffrecmc | x | r2 | – | 1 | 1 | 10.0 | 1 | `mf recon d -o o --method nvdiffrecmc` |\n"
             "| materialfusion | x | r1 | mf/prior/weights/prior-ft.mfck | 1 | 1 | 17.0 | 1 | `mf recon d -o o --method "
             "materialfusion` |\n");
    write_in(b, "runs.md",
             "| method | scene | revision | seed | threads | wall s | peak MB | command |\n|---|---|---|---:|---:|---:|---:|---|\n"
             "| materialfusion | x | r3 | 1 | 1 | 17.0 | 1 | `mf recon d -o o --method materialfusion --prior-weights "
             "mf/prior/weights/prior-bounce.mfck --resume` |\n");
    write_in(c, "runs.md",
             "| method | scene | revision | seed | threads | wall s | peak MB | command |\n|---|---|---|---:|---:|---:|---:|---|\n"
             "| materialfusion | x | 0000000 | 1 | 1 | 17.0 | 1 | `mf recon d -o o --method materialfusion` |\n");
    CHECK(mf_test_sh("python3 eval/bench_summary.py -o '%s' --split new '%s' --split old '%s' --split unk '%s' "
                     "--split gone '%s/none'", out, a, b, c, a) == 0);
    char *md = NULL;
    size_t len;
    CHECK_OK(mf_read_file(out, &md, &len));
    if (!md) return;
    const char *cells = "| +0.50 [-0.25, +1.25] 6/9, p 0.170 | **+1.00** [+0.20, +1.80] 8/9, p 0.020 | "
                        "**-2.00** [-3.00, -1.00] 1/9, p 0.001 | 1.70× |";
    char want[1400];
    snprintf(want, sizeof want, "| new | `%s` | materialfusion | prior-ft.mfck %s r1 |", a, cells);
    CHECK_MSG(strstr(md, want), "missing row %s in\n%s", want, md);
    snprintf(want, sizeof want, "| old | `%s` | materialfusion | prior-bounce.mfck %s r3 |", b, cells);
    CHECK_MSG(strstr(md, want), "missing row %s", want);
    snprintf(want, sizeof want, "| unk | `%s` | materialfusion | default (unknown) %s 0000000 |", c, cells);
    CHECK_MSG(strstr(md, want), "missing row %s", want);
    CHECK(!strstr(md, "trivial-grey")); /* the trivial guesses and other references are left out */
    CHECK(strstr(md, "Not in this table: gone (") != NULL);
    free(md);
}
