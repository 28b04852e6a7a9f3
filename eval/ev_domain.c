#include "eval/ev_domain.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_strbuf.h"

#define DS_NAME "test-2d" /* the dataset field mf eval-prior writes */

static const char *const kSM = "StableMaterial";
static const char *const kBaselines[2] = {"Input image", "Retinex"};

/* "label|method" into out; non-zero (out cut) when it does not fit in cap */
static int qualified(char *out, size_t cap, const char *label, const char *method) {
    return (size_t)snprintf(out, cap, "%s|%s", label, method) >= cap;
}

int ev_domain_load(EvTable *t, const EvDomainCell *cells, int nc) {
    if (nc < 1 || nc > EV_DOMAIN_MAX_CELLS) return mf_fail(MF_EARG, "generalisation matrix: %d cells (1..%d)", nc, EV_DOMAIN_MAX_CELLS);
    for (int c = 0; c < nc; ++c) {
        const char *l = cells[c].label;
        if (!l || !l[0] || strchr(l, ',') || strchr(l, '|') || strlen(l) > 40)
            return mf_fail(MF_EARG, "generalisation matrix: cell %d: a label of 1..40 characters without ',' or '|'", c);
        for (int d = 0; d < c; ++d)
            if (!strcmp(cells[d].label, l)) return mf_fail(MF_EARG, "generalisation matrix: cell label '%s' given twice", l);
        EvTable one;
        ev_table_init(&one);
        int rc = ev_table_read_csv(&one, cells[c].csv);
        int has_sm = 0;
        for (size_t i = 0; i < one.n && !rc; ++i) {
            const EvRecord *r = &one.rec[i];
            char m[EV_NAME_MAX];
            if (strcmp(r->dataset, DS_NAME)) continue;
            has_sm |= !strcmp(r->method, kSM) && !strcmp(r->metric, "albedo_psnr");
            if (qualified(m, sizeof m, l, r->method))
                rc = mf_fail(MF_EFORMAT, "%s: method name '%s' too long for the cell label '%s' (label|method under %d characters)",
                             cells[c].csv, r->method, l, EV_NAME_MAX);
            else rc = ev_table_add(t, m, r->dataset, r->scene, r->metric, r->value);
        }
        ev_table_free(&one);
        if (rc) return rc;
        if (!has_sm) return mf_fail(MF_EFORMAT, "%s: no StableMaterial albedo_psnr records on %s (expected mf eval-prior's table2d.csv)", cells[c].csv, DS_NAME);
    }
    return MF_OK;
}

/* The baseline with the higher mean albedo PSNR in the cell; "" when none has records. */
static const char *best_baseline(const EvTable *t, const char *label, EvStat *st) {
    const char *best = "";
    EvStat bs = {0, 0, 0};
    for (int b = 0; b < 2; ++b) {
        char m[128];
        qualified(m, sizeof m, label, kBaselines[b]);
        EvStat s = ev_table_stat(t, m, DS_NAME, "albedo_psnr");
        if (s.n && (!bs.n || s.mean > bs.mean)) bs = s, best = kBaselines[b];
    }
    if (st) *st = bs;
    return best;
}

int ev_domain_row(const EvTable *t, const char *label, EvDomainRow *out) {
    memset(out, 0, sizeof *out);
    char m[128];
    qualified(m, sizeof m, label, kSM);
    out->sm_albedo = ev_table_stat(t, m, DS_NAME, "albedo_psnr");
    out->sm_orm = ev_table_stat(t, m, DS_NAME, "orm_psnr");
    snprintf(out->base_method, sizeof out->base_method, "%s", best_baseline(t, label, &out->base_albedo));
    if (out->base_method[0]) {
        char mb[128];
        qualified(mb, sizeof mb, label, out->base_method);
        ev_paired(t, m, mb, DS_NAME, "albedo_psnr", &out->sm_vs_base);
    }
    if (!out->sm_albedo.n) return mf_fail(MF_EARG, "generalisation matrix: no StableMaterial records for cell '%s'", label);
    return MF_OK;
}

int ev_domain_gap(const EvTable *t, const char *a, const char *ref, EvDomainGap *out) {
    memset(out, 0, sizeof *out);
    char ma[128], mr[128];
    qualified(ma, sizeof ma, a, kSM);
    qualified(mr, sizeof mr, ref, kSM);
    ev_paired(t, ma, mr, DS_NAME, "albedo_psnr", &out->sm_albedo);
    ev_paired(t, ma, mr, DS_NAME, "orm_psnr", &out->sm_orm);
    const char *b = best_baseline(t, ref, NULL);
    snprintf(out->base_method, sizeof out->base_method, "%s", b);
    if (b[0]) {
        qualified(ma, sizeof ma, a, b);
        qualified(mr, sizeof mr, ref, b);
        ev_paired(t, ma, mr, DS_NAME, "albedo_psnr", &out->base_albedo);
    }
    if (!out->sm_albedo.n) return mf_fail(MF_EARG, "generalisation matrix: cells '%s' and '%s' share no view", a, ref);
    return MF_OK;
}

static void md_stat(MfStrBuf *b, EvStat s) {
    if (!s.n) mf_sb_printf(b, " – |");
    else mf_sb_printf(b, " %.2f ± %.2f |", s.mean, s.ci95);
}

static void md_paired(MfStrBuf *b, const EvPaired *p) {
    if (!p->n) { mf_sb_printf(b, " – |"); return; }
    mf_sb_printf(b, " %+.2f", p->mean);
    if (isfinite(p->lo)) mf_sb_printf(b, " [%+.2f, %+.2f]", p->lo, p->hi);
    mf_sb_printf(b, ", wins %d/%d", p->wins, p->n);
    if (isfinite(p->p_t)) mf_sb_printf(b, ", p %.2g", p->p_t);
    mf_sb_printf(b, " |");
}

static void csv_stat(MfStrBuf *b, const char *cell, const char *metric, const char *method, EvStat s) {
    mf_sb_printf(b, "cell,%s,,%s,%s,%d,%.6g,%.6g,,,\n", cell, metric, method, s.n, s.mean, s.ci95);
}

static void csv_paired(MfStrBuf *b, const char *a, const char *ref, const char *metric, const char *method, const EvPaired *p) {
    mf_sb_printf(b, "gap,%s,%s,%s,%s,%d,%.6g,%.6g,%.6g,%d,%.6g\n", a, ref, metric, method, p->n, p->mean, p->lo, p->hi, p->wins, p->p_t);
}

int ev_domain_write(const EvDomainCell *cells, int nc, const char *const *pairs, int npairs, const char *const *caption,
                    int ncaption, const char *const *notes, int nnotes, const char *md_path, const char *csv_path) {
    EvTable t;
    ev_table_init(&t);
    int rc = ev_domain_load(&t, cells, nc);
    MfStrBuf md = {0}, csv = {0};
    for (int i = 0; i < ncaption; ++i) mf_sb_printf(&md, "%s\n", caption[i]);
    if (ncaption) mf_sb_printf(&md, "\n");
    mf_sb_printf(&md, "| cell (renderer / content) | views | StableMaterial albedo PSNR (dB, masked) | StableMaterial ORM PSNR (dB, masked) "
                      "| best training-free albedo PSNR (dB, masked) | that baseline | StableMaterial − that baseline, albedo (dB, paired) |\n"
                      "|---|---|---|---|---|---|---|\n");
    mf_sb_printf(&csv, "kind,cell,ref,metric,method,n,mean,ci95_or_lo,hi,wins,p_t\n");
    for (int c = 0; c < nc && !rc; ++c) {
        EvDomainRow r;
        if ((rc = ev_domain_row(&t, cells[c].label, &r))) break;
        mf_sb_printf(&md, "| %s | %d |", cells[c].label, r.sm_albedo.n);
        md_stat(&md, r.sm_albedo);
        md_stat(&md, r.sm_orm);
        md_stat(&md, r.base_albedo);
        mf_sb_printf(&md, " %s |", r.base_method[0] ? r.base_method : "–");
        md_paired(&md, &r.sm_vs_base);
        mf_sb_printf(&md, "\n");
        csv_stat(&csv, cells[c].label, "albedo_psnr", kSM, r.sm_albedo);
        csv_stat(&csv, cells[c].label, "orm_psnr", kSM, r.sm_orm);
        csv_stat(&csv, cells[c].label, "albedo_psnr", r.base_method, r.base_albedo);
        if (r.base_method[0]) csv_paired(&csv, cells[c].label, r.base_method, "albedo_psnr", kSM, &r.sm_vs_base);
    }
    if (!rc && npairs > 0) {
        mf_sb_printf(&md, "\nPaired differences over the views the two cells share (the same objects, cameras and lights: view i of one "
                          "cell is view i of the other); mean [95%% CI], wins = views where the first cell scores higher, p = paired "
                          "t-test (two-sided). Masked PSNR.\n\n");
        mf_sb_printf(&md, "| difference | StableMaterial albedo PSNR (dB) | StableMaterial ORM PSNR (dB) | training-free albedo PSNR (dB) "
                          "| that baseline |\n|---|---|---|---|---|\n");
    }
    for (int k = 0; k < npairs && !rc; ++k) {
        const char *a = pairs[2 * k], *ref = pairs[2 * k + 1];
        EvDomainGap g;
        if ((rc = ev_domain_gap(&t, a, ref, &g))) break;
        mf_sb_printf(&md, "| %s − %s |", a, ref);
        md_paired(&md, &g.sm_albedo);
        md_paired(&md, &g.sm_orm);
        md_paired(&md, &g.base_albedo);
        mf_sb_printf(&md, " %s |\n", g.base_method[0] ? g.base_method : "–");
        csv_paired(&csv, a, ref, "albedo_psnr", kSM, &g.sm_albedo);
        csv_paired(&csv, a, ref, "orm_psnr", kSM, &g.sm_orm);
        if (g.base_method[0]) csv_paired(&csv, a, ref, "albedo_psnr", g.base_method, &g.base_albedo);
    }
    if (!rc) {
        if (nnotes) mf_sb_printf(&md, "\n");
        for (int i = 0; i < nnotes; ++i) mf_sb_printf(&md, "%s\n", notes[i]);
        rc = mf_sb_write(&md, md_path);
        if (!rc && csv_path) rc = mf_sb_write(&csv, csv_path);
    }
    mf_sb_free(&md);
    mf_sb_free(&csv);
    ev_table_free(&t);
    return rc;
}
