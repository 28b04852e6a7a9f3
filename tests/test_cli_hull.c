/* `mf hull`: bad input. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "eval/ev_geom.h"
#include "geom/mf_meshproc.h"
#include "geom/mf_tetgrid.h"
#include "geom/mf_vhull.h"
#include "mf_test.h"
#include "mf_test_geom.h"

MF_TEST(geom_hull_cli_bad_input) {
    char err[4096];
    int rc = mf_test_run_mf("hull /nonexistent/scene -o /dev/null", NULL, err, sizeof err);
    CHECK_MSG(rc == 1 && strstr(err, "/nonexistent/scene"), "missing data: exit %d, '%s'", rc, err);
    rc = mf_test_run_mf("hull /nonexistent/scene", NULL, err, sizeof err);
    CHECK_MSG(rc == 2 && strstr(err, "-o OUT.obj"), "missing -o: exit %d, '%s'", rc, err);
    rc = mf_test_run_mf("hull /nonexistent/scene -o x.obj --res 1", NULL, err, sizeof err);
    CHECK_MSG(rc == 2 && strstr(err, "res"), "--res 1: exit %d, '%s'", rc, err);
}
