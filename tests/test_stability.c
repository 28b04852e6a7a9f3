/* The fast subset of the numerical-stability grid (eval/ev_stability.h; issue 18): the tiny
 * scene's render cells and baseline recon cells at 20 iterations through `mf` (MF_BIN). Every
 * cell must behave as expected: no NaN/Inf in any EXR it writes, exit 0 for the cells inside the
 * options' ranges (their bounds included), and a refusal naming the option for the others. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_stability.h"
#include "mf_test.h"

MF_TEST(stability_quick_grid) {
    const char *mf = getenv("MF_BIN");
    if (!mf || !mf_file_exists(mf)) MF_SKIP("MF_BIN not set (run through make test)");
    char work[1024], out[1100];
    snprintf(work, sizeof work, "%s", mf_test_path("stability"));
    snprintf(out, sizeof out, "%s/report", work);
    EvStabResult res[64];
    int n = 0;
    CHECK_OK(ev_stab_grid(mf, work, out, 20, 50, 1, res, 64, &n));
    int nc;
    const EvStabCell *cells = ev_stab_cells(&nc);
    CHECK(n >= 10 && n < nc); /* quick: no MaterialFusion cells */
    for (int i = 0, k = 0; i < nc && k < n; ++i) {
        if (!strcmp(cells[i].kind, "materialfusion")) continue;
        const EvStabResult *r = &res[k++];
        CHECK_MSG(r->nonfinite == 0, "%s / %s: %d EXR files with NaN/Inf", cells[i].kind, cells[i].name, r->nonfinite);
        CHECK_MSG(r->ok, "%s / %s: exit %d, not as expected (refusal must name %s)", cells[i].kind, cells[i].name, r->exit_code,
                  cells[i].refuse ? cells[i].refuse : "nothing");
        if (!cells[i].refuse) CHECK_MSG(r->exr_files > 0, "%s / %s wrote no EXR", cells[i].kind, cells[i].name);
        CHECK(r->peak_rss_kb > 0 && r->wall_s > 0);
    }
    char md[1200];
    snprintf(md, sizeof md, "%s/README.md", out);
    CHECK(mf_file_exists(md));
}
