/* Tests of eval/ev_table: statistics, ranking marks, CSV round trip, NaN refusal. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_table.h"
#include "mf_test.h"

MF_TEST(eval_table_stats_and_ci) {
    EvTable t;
    ev_table_init(&t);
    double v[] = {20.0, 22.0, 24.0};
    for (int i = 0; i < 3; ++i) {
        char s[16];
        snprintf(s, sizeof s, "s%d", i);
        CHECK_OK(ev_table_add(&t, "a", "d", s, "psnr", v[i]));
    }
    EvStat s = ev_table_stat(&t, "a", "d", "psnr");
    CHECK(s.n == 3);
    CHECK_NEAR(s.mean, 22.0, 1e-12);
    /* sd = 2, t(0.975, 2) = 4.302652729911275 -> half-width 4.3027 * 2 / sqrt(3) */
    CHECK_NEAR(s.ci95, 4.302652729911275 * 2.0 / sqrt(3.0), 1e-9);
    CHECK(ev_table_stat(&t, "b", "d", "psnr").n == 0);
    CHECK_ERR(ev_table_add(&t, "a", "d", "s9", "psnr", NAN), "a/d/s9: metric psnr is not finite");
    CHECK(t.n == 3);
    ev_table_free(&t);
}

MF_TEST(eval_table_marks_best) {
    EvTable t;
    ev_table_init(&t);
    const char *methods[] = {"m1", "m2", "m3", "m4"};
    double psnr[] = {25.0, 27.0, 26.0, 24.0}, l1[] = {0.05, 0.03, 0.04, 0.06};
    for (int m = 0; m < 4; ++m) {
        CHECK_OK(ev_table_add(&t, methods[m], "bv", "x", "psnr", psnr[m]));
        CHECK_OK(ev_table_add(&t, methods[m], "bv", "x", "l1", l1[m]));
    }
    const char *ds[] = {"bv"}, *mk[] = {"psnr", "l1"};
    char *md = ev_table_markdown_string(&t, "cap", methods, 4, ds, 1, mk, 2);
    CHECK(md != NULL);
    if (md) {
        CHECK(strstr(md, "| m2 | **27.00** | **0.0300** |") != NULL);
        CHECK(strstr(md, "| m3 | _26.00_ | _0.0400_ |") != NULL);
        CHECK(strstr(md, "| m1 | <u>25.00</u> | <u>0.0500</u> |") != NULL);
        CHECK(strstr(md, "| m4 | 24.00 | 0.0600 |") != NULL);
        CHECK(strstr(md, "LPIPS is not reported") != NULL);
        free(md);
    }
    const char *tex = mf_test_path("t.tex");
    CHECK_OK(ev_table_write_latex(&t, tex, "Relighting", methods, 4, ds, 1, mk, 2));
    char *s = NULL;
    CHECK_OK(mf_read_file(tex, &s, NULL));
    CHECK(s && strstr(s, "m2 & \\cellcolor{tabfirst}27.00 & \\cellcolor{tabfirst}0.0300 \\\\"));
    free(s);
    /* CSV round trip */
    const char *csv = mf_test_path("t.csv");
    CHECK_OK(ev_table_write_csv(&t, csv));
    EvTable u;
    ev_table_init(&u);
    CHECK_OK(ev_table_read_csv(&u, csv));
    CHECK(u.n == t.n);
    CHECK_NEAR(ev_table_stat(&u, "m3", "bv", "l1").mean, 0.04, 1e-12);
    CHECK_OK(mf_write_file(mf_test_path("bad.csv"), "method,dataset,scene,metric,value\na,b,c\n", 40));
    CHECK_ERR(ev_table_read_csv(&u, mf_test_path("bad.csv")), "bad.csv:2: expected 5");
    ev_table_free(&u);
    ev_table_free(&t);
}

/* Scene names are not truncated: a 100-character name survives ev_table_add and the CSV round
 * trip; a name over EV_NAME_MAX - 1 characters is refused by name, never cut. */
MF_TEST(eval_table_long_names) {
    char longn[101], huge[EV_NAME_MAX + 10];
    memset(longn, 'x', 100), longn[100] = 0;
    memset(huge, 'y', sizeof huge - 1), huge[sizeof huge - 1] = 0;
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_add(&t, "m", "d", longn, "psnr", 21.5));
    CHECK_ERR(ev_table_add(&t, "m", "d", huge, "psnr", 1.0), "a name is too long");
    CHECK(t.n == 1);
    const char *p = mf_test_path("eval_table_long/scenes.csv");
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(ev_table_write_csv(&t, p));
    ev_table_free(&t);
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, p));
    double v = 0;
    CHECK_MSG(ev_table_find(&t, "m", "d", longn, "psnr", &v) && v == 21.5, "%s: the 100-character scene name did not round-trip", p);
    ev_table_free(&t);
}
