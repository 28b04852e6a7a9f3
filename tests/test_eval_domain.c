/* Tests of eval/ev_domain: the 2D prior's generalisation matrix from eval-prior record files. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_domain.h"
#include "mf_test.h"

/* A table2d.csv of 4 views: StableMaterial albedo = base + i, ORM = 10 + i; Input image = inp + i,
 * Retinex = ret + i (per view i). */
static const char *write_cell(const char *name, double base, double inp, double ret) {
    const char *p = mf_test_path(name);
    FILE *f = fopen(p, "w");
    if (!f) return p;
    fprintf(f, "method,dataset,scene,metric,value\n");
    for (int i = 0; i < 4; ++i) {
        fprintf(f, "StableMaterial,test-2d,%06d,albedo_psnr,%g\n", i, base + i);
        fprintf(f, "StableMaterial,test-2d,%06d,orm_psnr,%g\n", i, 10.0 + i);
        fprintf(f, "Input image,test-2d,%06d,albedo_psnr,%g\n", i, inp + i);
        fprintf(f, "Retinex,test-2d,%06d,albedo_psnr,%g\n", i, ret + i);
        fprintf(f, "Train-mean ORM,test-2d,%06d,orm_psnr,%g\n", i, 99.0);
    }
    fclose(f);
    return p;
}

MF_TEST(ev_domain_rows_and_gaps) {
    EvDomainCell cells[2] = {{"ours", write_cell("dom_ours.csv", 20, 15, 17)}, {"pov", write_cell("dom_pov.csv", 18, 16, 14)}};
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_domain_load(&t, cells, 2));
    EvDomainRow r;
    CHECK_OK(ev_domain_row(&t, "ours", &r));
    CHECK(r.sm_albedo.n == 4);
    CHECK_NEAR(r.sm_albedo.mean, 21.5, 1e-9);
    CHECK_NEAR(r.sm_orm.mean, 11.5, 1e-9);
    /* sd of 0..3 = 1.29099; t(0.975, 3) = 3.18245; half-width = 3.18245 * 1.29099 / 2 */
    CHECK_NEAR(r.sm_albedo.ci95, 3.18245 * 1.290994 / 2.0, 1e-4);
    CHECK(!strcmp(r.base_method, "Retinex"));
    CHECK_NEAR(r.base_albedo.mean, 18.5, 1e-9);
    CHECK(r.sm_vs_base.n == 4 && r.sm_vs_base.wins == 4); /* StableMaterial - Retinex = +3 on every view */
    CHECK_NEAR(r.sm_vs_base.mean, 3.0, 1e-9);
    CHECK_OK(ev_domain_row(&t, "pov", &r));
    CHECK(!strcmp(r.base_method, "Input image"));
    /* pov - ours: -2 dB on every view (CI degenerate: all differences equal), 0 wins */
    EvDomainGap g;
    CHECK_OK(ev_domain_gap(&t, "pov", "ours", &g));
    CHECK(g.sm_albedo.n == 4 && g.sm_albedo.wins == 0);
    CHECK_NEAR(g.sm_albedo.mean, -2.0, 1e-9);
    CHECK_NEAR(g.sm_orm.mean, 0.0, 1e-9);
    CHECK(!strcmp(g.base_method, "Retinex")); /* the baseline best in the reference cell */
    CHECK_NEAR(g.base_albedo.mean, -3.0, 1e-9);
    CHECK_ERR(ev_domain_row(&t, "cycles", &r), "cycles");
    ev_table_free(&t);
    /* the written table states masked PSNR and holds both rows and the gap */
    const char *md = mf_test_path("dom.md"), *csv = mf_test_path("dom.csv");
    const char *pairs[2] = {"pov", "ours"}, *cap[1] = {"# matrix"}, *notes[1] = {"Cycles: skipped"};
    CHECK_OK(ev_domain_write(cells, 2, pairs, 1, cap, 1, notes, 1, md, csv));
    char *txt = NULL;
    CHECK_OK(mf_read_file(md, &txt, NULL));
    CHECK(txt && strstr(txt, "masked") && strstr(txt, "| ours | 4 | 21.50 ±") && strstr(txt, "| pov − ours | -2.00") &&
          strstr(txt, "Cycles: skipped"));
    free(txt);
    CHECK_OK(mf_read_file(csv, &txt, NULL));
    CHECK(txt && strstr(txt, "gap,pov,ours,albedo_psnr,StableMaterial,4,-2,") && strstr(txt, "gap,ours,Retinex,albedo_psnr,StableMaterial,4,3,"));
    free(txt);
}

MF_TEST(ev_domain_bad_input) {
    EvTable t;
    ev_table_init(&t);
    EvDomainCell none[1] = {{"x", mf_test_path("dom_missing.csv")}};
    CHECK_ERR(ev_domain_load(&t, none, 1), "dom_missing.csv");
    const char *p = mf_test_path("dom_nosm.csv");
    FILE *f = fopen(p, "w");
    if (f) {
        fprintf(f, "method,dataset,scene,metric,value\nRetinex,test-2d,000000,albedo_psnr,12\n");
        fclose(f);
    }
    EvDomainCell nosm[1] = {{"x", p}};
    CHECK_ERR(ev_domain_load(&t, nosm, 1), "StableMaterial");
    EvDomainCell bad[1] = {{"a|b", p}};
    CHECK_ERR(ev_domain_load(&t, bad, 1), "label");
    ev_table_free(&t);
}

/* make bench-matrix's compare table: 3 priors x 8 cells load; one cell over the limit is refused */
MF_TEST(ev_domain_cell_limit) {
    enum { N = EV_DOMAIN_MAX_CELLS + 1 };
    static char labels[N][16];
    EvDomainCell cells[N];
    const char *csv = write_cell("dom_many.csv", 20, 15, 17);
    for (int c = 0; c < N; ++c) {
        snprintf(labels[c], sizeof labels[c], "p%d:c%d", c / 8, c % 8);
        cells[c] = (EvDomainCell){labels[c], csv};
    }
    CHECK(EV_DOMAIN_MAX_CELLS >= 24);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_domain_load(&t, cells, 24));
    ev_table_free(&t);
    ev_table_init(&t);
    CHECK_ERR(ev_domain_load(&t, cells, N), "cells");
    ev_table_free(&t);
}
