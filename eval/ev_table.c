#include "eval/ev_table.h"

#include <gsl/gsl_cdf.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_strbuf.h"

void ev_table_init(EvTable *t) { memset(t, 0, sizeof *t); }

void ev_table_free(EvTable *t) {
    if (!t) return;
    free(t->rec);
    memset(t, 0, sizeof *t);
}

static void copy_field(char *dst, size_t cap, const char *src) { snprintf(dst, cap, "%s", src ? src : ""); }

static int fits(const char *s, size_t cap) { return !s || strlen(s) < cap; }

int ev_table_add(EvTable *t, const char *method, const char *dataset, const char *scene, const char *metric,
                 double value) {
    if (!isfinite(value))
        return mf_fail(MF_ENAN, "%s/%s/%s: metric %s is not finite (%g)", method, dataset, scene, metric, value);
    if (!fits(method, EV_NAME_MAX) || !fits(dataset, EV_NAME_MAX) || !fits(scene, EV_NAME_MAX) || !fits(metric, 32))
        return mf_fail(MF_EARG, "%s/%s/%s: metric %s: a name is too long for the table (method, dataset and scene at most %d characters, metric 31)",
                       method, dataset, scene, metric, EV_NAME_MAX - 1);
    if (t->n == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 64;
        EvRecord *r = realloc(t->rec, cap * sizeof *r);
        if (!r) return mf_fail(MF_ENOMEM, "out of memory for table records");
        t->rec = r;
        t->cap = cap;
    }
    EvRecord *r = &t->rec[t->n++];
    copy_field(r->method, sizeof r->method, method);
    copy_field(r->dataset, sizeof r->dataset, dataset);
    copy_field(r->scene, sizeof r->scene, scene);
    copy_field(r->metric, sizeof r->metric, metric);
    r->value = value;
    return MF_OK;
}

int ev_metric_higher_better(const char *metric) { return strstr(metric, "psnr") || strstr(metric, "ssim") || strstr(metric, "iou"); }

EvStat ev_table_stat(const EvTable *t, const char *method, const char *dataset, const char *metric) {
    EvStat s = {0.0, 0.0, 0};
    double sum = 0.0, sq = 0.0;
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        if (strcmp(r->method, method) || strcmp(r->dataset, dataset) || strcmp(r->metric, metric)) continue;
        sum += r->value;
        s.n++;
    }
    if (s.n == 0) return s;
    s.mean = sum / s.n;
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        if (strcmp(r->method, method) || strcmp(r->dataset, dataset) || strcmp(r->metric, metric)) continue;
        sq += (r->value - s.mean) * (r->value - s.mean);
    }
    if (s.n > 1) {
        double sd = sqrt(sq / (s.n - 1));
        s.ci95 = gsl_cdf_tdist_Pinv(0.975, s.n - 1) * sd / sqrt((double)s.n);
    }
    return s;
}

int ev_table_find(const EvTable *t, const char *method, const char *dataset, const char *scene, const char *metric, double *out) {
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        if (!strcmp(r->method, method) && !strcmp(r->dataset, dataset) && !strcmp(r->scene, scene) && !strcmp(r->metric, metric)) {
            *out = r->value;
            return 1;
        }
    }
    return 0;
}

int ev_table_write_csv(const EvTable *t, const char *path) {
    MfStrBuf b = {0};
    mf_sb_printf(&b, "method,dataset,scene,metric,value\n");
    for (size_t i = 0; i < t->n; ++i) {
        const EvRecord *r = &t->rec[i];
        mf_sb_printf(&b, "%s,%s,%s,%s,%.9g\n", r->method, r->dataset, r->scene, r->metric, r->value);
    }
    return mf_sb_write(&b, path);
}

int ev_table_read_csv(EvTable *t, const char *path) {
    char *data = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &data, &len);
    if (rc) return rc;
    char *save = NULL;
    int line = 0;
    for (char *ln = strtok_r(data, "\n", &save); ln; ln = strtok_r(NULL, "\n", &save)) {
        ++line;
        if (line == 1) {
            if (strncmp(ln, "method,dataset,scene,metric,value", 33)) {
                free(data);
                return mf_fail(MF_EFORMAT, "%s:1: expected header 'method,dataset,scene,metric,value'", path);
            }
            continue;
        }
        char *f[5], *end = NULL, *rest = ln;
        int nf = 0;
        for (; nf < 5 && rest; ++nf) { /* fields as they are (a long name meets ev_table_add's check); later columns ignored */
            f[nf] = rest;
            char *c = strchr(rest, ',');
            if (c) *c = 0;
            rest = c ? c + 1 : NULL;
        }
        double v = nf == 5 ? strtod(f[4], &end) : 0.0;
        if (nf != 5 || !f[0][0] || !f[1][0] || !f[2][0] || !f[3][0] || end == f[4]) {
            free(data);
            return mf_fail(MF_EFORMAT, "%s:%d: expected 5 comma-separated fields", path, line);
        }
        rc = ev_table_add(t, f[0], f[1], f[2], f[3], v);
        if (rc) {
            free(data);
            return mf_fail_prefix(rc, "%s:%d", path, line);
        }
    }
    free(data);
    return MF_OK;
}

/* Rank (0 best) of method mi in column (dataset, metric) among the methods with values; -1 when
 * the method has no value. Ties share the better rank. */
int ev_table_rank(const EvTable *t, const char *const *methods, int nm, int mi, const char *dataset,
                   const char *metric) {
    EvStat me = ev_table_stat(t, methods[mi], dataset, metric);
    if (me.n == 0) return -1;
    int hb = ev_metric_higher_better(metric), rank = 0;
    for (int j = 0; j < nm; ++j) {
        if (j == mi) continue;
        EvStat o = ev_table_stat(t, methods[j], dataset, metric);
        if (o.n == 0) continue;
        if (hb ? o.mean > me.mean : o.mean < me.mean) ++rank;
    }
    return rank;
}

int ev_metric_decimals(const char *metric) {
    if (strstr(metric, "psnr")) return 2;
    if (strstr(metric, "time") || strstr(metric, "mem")) return 1;
    return 4;
}

static void markdown(MfStrBuf *b, const EvTable *t, const char *caption, const char *const *methods, int nm,
                     const char *const *datasets, int nd, const char *const *metrics, int nk) {
    if (caption && caption[0]) mf_sb_printf(b, "%s\n\n", caption);
    mf_sb_printf(b, "| method |");
    for (int d = 0; d < nd; ++d)
        for (int k = 0; k < nk; ++k) mf_sb_printf(b, " %s %s %s |", datasets[d], metrics[k], ev_metric_higher_better(metrics[k]) ? "↑" : "↓");
    mf_sb_printf(b, "\n|---|");
    for (int c = 0; c < nd * nk; ++c) mf_sb_printf(b, "---:|");
    mf_sb_printf(b, "\n");
    static const char *open[3] = {"**", "_", "<u>"}, *close[3] = {"**", "_", "</u>"};
    for (int m = 0; m < nm; ++m) {
        mf_sb_printf(b, "| %s |", methods[m]);
        for (int d = 0; d < nd; ++d)
            for (int k = 0; k < nk; ++k) {
                EvStat s = ev_table_stat(t, methods[m], datasets[d], metrics[k]);
                if (s.n == 0) { mf_sb_printf(b, " – |"); continue; }
                int r = nm > 1 ? ev_table_rank(t, methods, nm, m, datasets[d], metrics[k]) : -1;
                int dec = ev_metric_decimals(metrics[k]);
                const char *o = (r >= 0 && r < 3) ? open[r] : "", *c = (r >= 0 && r < 3) ? close[r] : "";
                if (s.n > 1) mf_sb_printf(b, " %s%.*f%s ± %.*f |", o, dec, s.mean, c, dec, s.ci95);
                else mf_sb_printf(b, " %s%.*f%s |", o, dec, s.mean, c);
            }
        mf_sb_printf(b, "\n");
    }
    mf_sb_printf(b, "\nMean over scenes ± 95%% confidence half-width (Student t). Best **bold**, second _italic_, "
               "third <u>underlined</u>. LPIPS is not reported: it needs pretrained network weights that cannot be "
               "obtained here; FLIP is the perceptual metric.\n");
}

char *ev_table_markdown_string(const EvTable *t, const char *caption, const char *const *methods, int nm,
                               const char *const *datasets, int nd, const char *const *metrics, int nk) {
    MfStrBuf b = {0};
    markdown(&b, t, caption, methods, nm, datasets, nd, metrics, nk);
    return mf_sb_take(&b);
}

int ev_table_write_markdown(const EvTable *t, const char *path, const char *caption, const char *const *methods,
                            int nm, const char *const *datasets, int nd, const char *const *metrics, int nk) {
    MfStrBuf b = {0};
    markdown(&b, t, caption, methods, nm, datasets, nd, metrics, nk);
    return mf_sb_write(&b, path);
}

static void latex_escape(MfStrBuf *b, const char *s) {
    for (; *s; ++s) {
        if (*s == '_' || *s == '%' || *s == '&' || *s == '#') mf_sb_printf(b, "\\%c", *s);
        else mf_sb_printf(b, "%c", *s);
    }
}

int ev_table_write_latex(const EvTable *t, const char *path, const char *caption, const char *const *methods, int nm,
                         const char *const *datasets, int nd, const char *const *metrics, int nk) {
    MfStrBuf b = {0};
    static const char *cell[3] = {"\\cellcolor{tabfirst}", "\\cellcolor{tabsecond}", "\\cellcolor{tabthird}"};
    mf_sb_printf(&b, "%% generated by mf (eval/ev_table.c); needs \\usepackage[table]{xcolor} and the paper's\n"
                "%% \\definecolor{tabfirst}{rgb}{1,0.7,0.7} {tabsecond}{rgb}{1,0.85,0.7} {tabthird}{rgb}{1,1,0.7}\n");
    mf_sb_printf(&b, "\\begin{table}[t]\n\\centering\n\\begin{tabular}{l");
    for (int c = 0; c < nd * nk; ++c) mf_sb_printf(&b, "c");
    mf_sb_printf(&b, "}\n\\toprule\n");
    for (int d = 0; d < nd; ++d) {
        mf_sb_printf(&b, " & \\multicolumn{%d}{c}{", nk);
        latex_escape(&b, datasets[d]);
        mf_sb_printf(&b, "}");
    }
    mf_sb_printf(&b, " \\\\\nMethod");
    for (int d = 0; d < nd; ++d)
        for (int k = 0; k < nk; ++k) {
            mf_sb_printf(&b, " & ");
            latex_escape(&b, metrics[k]);
            mf_sb_printf(&b, ev_metric_higher_better(metrics[k]) ? " $\\uparrow$" : " $\\downarrow$");
        }
    mf_sb_printf(&b, " \\\\\n\\midrule\n");
    for (int m = 0; m < nm; ++m) {
        latex_escape(&b, methods[m]);
        for (int d = 0; d < nd; ++d)
            for (int k = 0; k < nk; ++k) {
                EvStat s = ev_table_stat(t, methods[m], datasets[d], metrics[k]);
                if (s.n == 0) { mf_sb_printf(&b, " & --"); continue; }
                int r = nm > 1 ? ev_table_rank(t, methods, nm, m, datasets[d], metrics[k]) : -1;
                mf_sb_printf(&b, " & %s%.*f", (r >= 0 && r < 3) ? cell[r] : "", ev_metric_decimals(metrics[k]), s.mean);
            }
        mf_sb_printf(&b, " \\\\\n");
    }
    mf_sb_printf(&b, "\\bottomrule\n\\end{tabular}\n\\caption{");
    latex_escape(&b, caption ? caption : "");
    mf_sb_printf(&b, " Mean over scenes. LPIPS not reported (needs pretrained weights unavailable here).}\n\\end{table}\n");
    return mf_sb_write(&b, path);
}
