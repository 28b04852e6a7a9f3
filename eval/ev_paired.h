/* ev_paired: paired comparison of two methods over the scenes they share — the statistic every
 * "method A beats method B" claim in reports/ rests on.
 *
 * For one (dataset, metric), the per-scene differences d_s = value(method, s) - value(ref, s) over
 * the scenes where both have a value give: the mean difference with its 95% confidence interval
 * (Student t, n - 1 degrees of freedom), the wins (scenes where `method` is better in the metric's
 * own direction, ev_metric_higher_better), ties, and two two-sided p-values: the paired t-test and
 * the exact sign test (ties dropped; binomial, GSL). A difference is "significant" when the 95% CI
 * excludes 0 (equivalently p_t < 0.05). With n < 2 the CI and p_t are undefined (NaN, printed "–").
 * Differences keep the metric's units and sign (method - ref), also for lower-is-better metrics. */
#ifndef EV_PAIRED_H
#define EV_PAIRED_H

#include "eval/ev_table.h"

typedef struct {
    int n;              /* scenes with a value for both methods */
    double mean;        /* mean of (method - ref) */
    double lo, hi;      /* 95% CI of the mean difference (NaN when n < 2) */
    int wins, ties;     /* scenes where method is better / equal (to 1e-9) */
    double p_t;         /* two-sided paired t-test (NaN when n < 2 or all differences equal) */
    double p_sign;      /* two-sided exact sign test over the non-tied scenes (1 when none) */
} EvPaired;

/* Paired statistics of method against ref on (dataset, metric); out->n = 0 when no scene is shared. */
void ev_paired(const EvTable *t, const char *method, const char *ref, const char *dataset, const char *metric,
               EvPaired *out);

/* Markdown (and the same rows as CSV: method,ref,dataset,metric,n,mean,lo,hi,wins,ties,p_t,p_sign)
 * of every method except ref against ref, one row per (method, metric); atomic writes. csv_path may
 * be NULL. */
int ev_paired_write(const EvTable *t, const char *md_path, const char *csv_path, const char *caption,
                    const char *ref, const char *const *methods, int nm, const char *dataset,
                    const char *const *metrics, int nk);

/* The benchmark's paired tables: every method in methods except ref against ref on relit, albedo and
 * ORM PSNR / SSIM / L1 / FLIP and wall time, into DIR/paired.md and DIR/paired.csv (metrics absent
 * from t are skipped). */
int ev_paired_write_bench(const EvTable *t, const char *dir, const char *ref, const char *const *methods, int nm,
                          const char *dataset);

#endif
