/* ev_table: aggregation of per-scene metric values into the paper's tables.
 *
 * Records are (method, dataset, scene, metric, value). Aggregation groups by (method, dataset,
 * metric) and reports the mean over scenes with a 95% confidence interval (Student t, GSL;
 * half-width 0 for a single scene). Tables are laid out as the paper's: one row per method, one
 * column group per dataset, one column per metric; in each column the best, second and third
 * methods are marked (Markdown: **bold**, _italic_, <u>underline</u>; LaTeX: \cellcolor{tabfirst},
 * {tabsecond}, {tabthird} as the paper's preamble defines them). Whether higher is better is
 * known per metric name (names containing psnr, ssim or iou: higher; l1, flip, time, mem: lower).
 * Non-finite values are refused at ev_table_add: a NaN never reaches a table. */
#ifndef EV_TABLE_H
#define EV_TABLE_H

#include <stddef.h>

/* Bytes of a method, dataset or scene name with its NUL: 255 characters, a file name's limit
 * (NAME_MAX), so every folder name fits; longer names are refused, never truncated. */
#define EV_NAME_MAX 256
typedef char EvName[EV_NAME_MAX];

typedef struct {
    char method[EV_NAME_MAX], dataset[EV_NAME_MAX], scene[EV_NAME_MAX], metric[32];
    double value;
} EvRecord;

typedef struct {
    EvRecord *rec; /* owned; (n,) */
    size_t n, cap;
} EvTable;

typedef struct {
    double mean, ci95; /* ci95: half-width of the 95% interval of the mean */
    int n;             /* number of scenes */
} EvStat;

void ev_table_init(EvTable *t);
void ev_table_free(EvTable *t);
/* Adds one record; MF_ENAN if value is not finite, MF_EARG if a name is longer than its field
 * (EV_NAME_MAX - 1 characters; metric 31); the message names method/dataset/scene/metric. */
int ev_table_add(EvTable *t, const char *method, const char *dataset, const char *scene, const char *metric,
                 double value);
/* Reads records from a CSV written by ev_table_write_csv (appends). */
int ev_table_read_csv(EvTable *t, const char *path);
/* Mean and 95% CI over the records matching (method, dataset, metric); n = 0 when none. */
EvStat ev_table_stat(const EvTable *t, const char *method, const char *dataset, const char *metric);
/* The value of one record (method, dataset, scene, metric) into *out; 0 when there is none. */
int ev_table_find(const EvTable *t, const char *method, const char *dataset, const char *scene, const char *metric, double *out);
/* 1 when larger values of this metric are better. */
int ev_metric_higher_better(const char *metric);
/* Decimals printed for a metric (psnr 2, time/mem 1, others 4). */
int ev_metric_decimals(const char *metric);
/* Rank (0 = best) of methods[mi] in the column (dataset, metric) among the methods that have a
 * value there; -1 when it has none. Ties share the better rank. */
int ev_table_rank(const EvTable *t, const char *const *methods, int nm, int mi, const char *dataset,
                  const char *metric);

/* Writes every record: method,dataset,scene,metric,value (atomic). */
int ev_table_write_csv(const EvTable *t, const char *path);
/* Paper-layout tables over the given methods (rows), datasets and metrics (columns);
 * `caption` goes above (Markdown) or into \caption (LaTeX). Atomic writes. */
int ev_table_write_markdown(const EvTable *t, const char *path, const char *caption, const char *const *methods,
                            int nm, const char *const *datasets, int nd, const char *const *metrics, int nk);
int ev_table_write_latex(const EvTable *t, const char *path, const char *caption, const char *const *methods, int nm,
                         const char *const *datasets, int nd, const char *const *metrics, int nk);
/* Same as the Markdown writer but into a caller buffer-growing string (for HTML pages);
 * returns a malloc'ed NUL-terminated string or NULL on allocation failure. */
char *ev_table_markdown_string(const EvTable *t, const char *caption, const char *const *methods, int nm,
                               const char *const *datasets, int nd, const char *const *metrics, int nk);

#endif
