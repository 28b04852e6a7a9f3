#include "eval/ev_paired.h"

#include <gsl/gsl_cdf.h>
#include <gsl/gsl_statistics_double.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_strbuf.h"

/* Value of (method, dataset, scene, metric); 0 when absent. */
static int lookup(const EvTable *t, const char *method, const char *dataset, const char *scene, const char *metric,
                  double *v) {
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        if (!strcmp(r->method, method) && !strcmp(r->dataset, dataset) && !strcmp(r->scene, scene) &&
            !strcmp(r->metric, metric)) {
            *v = r->value;
            return 1;
        }
    }
    return 0;
}

void ev_paired(const EvTable *t, const char *method, const char *ref, const char *dataset, const char *metric,
               EvPaired *out) {
    memset(out, 0, sizeof *out);
    out->lo = out->hi = out->p_t = NAN;
    out->p_sign = 1.0;
    double *d = malloc((t->n + 1) * sizeof(double));
    if (!d) return;
    int n = 0, hb = ev_metric_higher_better(metric);
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        double b;
        if (strcmp(r->method, method) || strcmp(r->dataset, dataset) || strcmp(r->metric, metric)) continue;
        if (!lookup(t, ref, dataset, r->scene, metric, &b)) continue;
        d[n++] = r->value - b;
    }
    out->n = n;
    if (n == 0) {
        free(d);
        return;
    }
    int pos = 0, neg = 0;
    for (int i = 0; i < n; ++i) {
        if (fabs(d[i]) <= 1e-9) out->ties++;
        else if ((d[i] > 0) == (hb != 0)) out->wins++;
        if (d[i] > 1e-9) pos++;
        if (d[i] < -1e-9) neg++;
    }
    out->mean = gsl_stats_mean(d, 1, (size_t)n);
    if (n >= 2) {
        double se = gsl_stats_sd_m(d, 1, (size_t)n, out->mean) / sqrt((double)n);
        double q = gsl_cdf_tdist_Pinv(0.975, n - 1);
        out->lo = out->mean - q * se, out->hi = out->mean + q * se;
        if (se > 0.0) out->p_t = 2.0 * gsl_cdf_tdist_Q(fabs(out->mean) / se, n - 1);
    }
    int m = pos + neg, k = pos < neg ? pos : neg;
    if (m > 0) {
        double p = 2.0 * gsl_cdf_binomial_P((unsigned)k, 0.5, (unsigned)m);
        out->p_sign = p < 1.0 ? p : 1.0;
    }
    free(d);
}

static void fmt_num(MfStrBuf *b, double v, int dec) {
    if (isfinite(v)) mf_sb_printf(b, "%+.*f", dec, v);
    else mf_sb_printf(b, "–");
}

static void fmt_p(MfStrBuf *b, double p) {
    if (!isfinite(p)) mf_sb_printf(b, "–");
    else if (p < 0.001) mf_sb_printf(b, "<0.001");
    else mf_sb_printf(b, "%.3f", p);
}

int ev_paired_write(const EvTable *t, const char *md_path, const char *csv_path, const char *caption,
                    const char *ref, const char *const *methods, int nm, const char *dataset,
                    const char *const *metrics, int nk) {
    MfStrBuf md = {0}, csv = {0};
    if (caption && *caption) mf_sb_printf(&md, "%s\n\n", caption);
    mf_sb_printf(&md,
                 "Paired over scenes, each method minus `%s` (dataset %s). CI: 95%% of the mean difference "
                 "(Student t); wins: scenes where the method is better in the metric's own direction; p: "
                 "two-sided paired t-test and exact sign test. **Bold**: the CI excludes 0.\n\n",
                 ref, dataset);
    mf_sb_printf(&md, "| method | metric | n | mean diff | 95%% CI | wins | p (t) | p (sign) |\n");
    mf_sb_printf(&md, "|---|---|---:|---:|---|---:|---:|---:|\n");
    mf_sb_printf(&csv, "method,ref,dataset,metric,n,mean,lo,hi,wins,ties,p_t,p_sign\n");
    for (int i = 0; i < nm; ++i) {
        if (!strcmp(methods[i], ref)) continue;
        for (int k = 0; k < nk; ++k) {
            EvPaired p;
            ev_paired(t, methods[i], ref, dataset, metrics[k], &p);
            if (p.n == 0) continue;
            int dec = ev_metric_decimals(metrics[k]), sig = isfinite(p.lo) && (p.lo > 0.0 || p.hi < 0.0);
            mf_sb_printf(&md, "| %s | %s | %d | %s", methods[i], metrics[k], p.n, sig ? "**" : "");
            fmt_num(&md, p.mean, dec);
            mf_sb_printf(&md, "%s | [", sig ? "**" : "");
            fmt_num(&md, p.lo, dec);
            mf_sb_printf(&md, ", ");
            fmt_num(&md, p.hi, dec);
            mf_sb_printf(&md, "] | %d/%d | ", p.wins, p.n);
            fmt_p(&md, p.p_t);
            mf_sb_printf(&md, " | ");
            fmt_p(&md, p.p_sign);
            mf_sb_printf(&md, " |\n");
            mf_sb_printf(&csv, "%s,%s,%s,%s,%d,%.9g,%.9g,%.9g,%d,%d,%.9g,%.9g\n", methods[i], ref, dataset, metrics[k],
                         p.n, p.mean, p.lo, p.hi, p.wins, p.ties, p.p_t, p.p_sign);
        }
    }
    int rc = mf_sb_write(&md, md_path);
    if (!rc && csv_path) rc = mf_sb_write(&csv, csv_path);
    else mf_sb_free(&csv);
    return rc;
}

int ev_paired_write_bench(const EvTable *t, const char *dir, const char *ref, const char *const *methods, int nm,
                          const char *dataset) {
    static const char *const metrics[] = {"relit_psnr", "relit_psnr_masked", "relit_ssim", "relit_flip",
                                          "albedo_psnr", "albedo_psnr_masked", "albedo_ssim", "orm_psnr",
                                          "orm_psnr_masked", "time_x"};
    char md[1024], csv[1024];
    snprintf(md, sizeof md, "%s/paired.md", dir);
    snprintf(csv, sizeof csv, "%s/paired.csv", dir);
    return ev_paired_write(t, md, csv,
                           "# Paired differences against the baseline\n\n`*_psnr`: full frame (prediction and ground truth "
                           "composited on black, so the background counts as exact); `*_psnr_masked`: inside the "
                           "ground-truth mask only (the basis of the 2D prior table). Relit and albedo are "
                           "scale-aligned first; ORM (roughness, metallic) is not. time_x: wall time over the "
                           "baseline's on the same scene.",
                           ref, methods, (int)nm, dataset, metrics, (int)(sizeof metrics / sizeof metrics[0]));
}
