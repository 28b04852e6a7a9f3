/* Tests of eval/ev_paired: paired differences, CI, wins, p-values against closed forms. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_paired.h"
#include "mf_test.h"

MF_TEST(eval_paired_stats) {
    EvTable t;
    ev_table_init(&t);
    /* scenes s0..s3: method "a" beats "ref" by 1, 2, 3, 4 dB; s4 only has ref (not paired) */
    for (int i = 0; i < 5; ++i) {
        char s[16];
        snprintf(s, sizeof s, "s%d", i);
        CHECK_OK(ev_table_add(&t, "ref", "d", s, "relit_psnr", 20.0 + i));
        if (i < 4) CHECK_OK(ev_table_add(&t, "a", "d", s, "relit_psnr", 20.0 + i + (i + 1)));
        if (i < 4) CHECK_OK(ev_table_add(&t, "a", "d", s, "relit_l1", 0.1));
        if (i < 4) CHECK_OK(ev_table_add(&t, "ref", "d", s, "relit_l1", i < 2 ? 0.2 : 0.05));
    }
    EvPaired p;
    ev_paired(&t, "a", "ref", "d", "relit_psnr", &p);
    CHECK(p.n == 4);
    CHECK_NEAR(p.mean, 2.5, 1e-12);
    /* sd 1.2910, se 0.6455, t(0.975, 3) = 3.182446305284263 */
    double se = sqrt(5.0 / 3.0) / 2.0;
    CHECK_NEAR(p.lo, 2.5 - 3.182446305284263 * se, 1e-9);
    CHECK_NEAR(p.hi, 2.5 + 3.182446305284263 * se, 1e-9);
    /* df 3 closed form: two-sided p of t = 3.8730 is 0.0304663 */
    CHECK_NEAR(p.p_t, 0.030466291662170963, 1e-9);
    CHECK(p.wins == 4 && p.ties == 0);
    CHECK_NEAR(p.p_sign, 0.125, 1e-12); /* 4 of 4 positive: 2 * 0.5^4 */
    /* lower-is-better: a's L1 0.1 vs ref 0.2, 0.2, 0.05, 0.05 -> 2 wins; difference sign kept */
    ev_paired(&t, "a", "ref", "d", "relit_l1", &p);
    CHECK(p.n == 4 && p.wins == 2);
    CHECK_NEAR(p.mean, -0.025, 1e-12); /* (-0.1 - 0.1 + 0.05 + 0.05) / 4 */
    CHECK_NEAR(p.p_sign, 1.0, 1e-12);
    ev_paired(&t, "missing", "ref", "d", "relit_psnr", &p);
    CHECK(p.n == 0);
    /* the written table marks the significant PSNR difference and not the L1 one */
    char dir[] = "/tmp/mf_paired_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    const char *methods[] = {"ref", "a"};
    CHECK_OK(ev_paired_write_bench(&t, dir, "ref", methods, 2, "d"));
    char path[256], *md = NULL;
    size_t n = 0;
    snprintf(path, sizeof path, "%s/paired.md", dir);
    CHECK_OK(mf_read_file(path, &md, &n));
    CHECK(md && strstr(md, "| a | relit_psnr | 4 | **+2.50** | [") != NULL);
    CHECK(md && strstr(md, "| 4/4 | 0.030 | 0.125 |") != NULL);
    free(md);
    snprintf(path, sizeof path, "%s/paired.csv", dir);
    CHECK(mf_file_exists(path));
    ev_table_free(&t);
}
