/* ev_report: the pictures and the page of a report.
 *
 * - ev_plot_png: line/point plots through gnuplot (Debian's gnuplot-nox, pngcairo terminal),
 *   e.g. relit PSNR against wall time per method (speed vs error).
 * - ev_plot_speed_error: wall time against error over all scenes, one point per scene and
 *   method plus each method's mean with 95% CIs on both axes.
 * - ev_grid_png: an image grid (rows x cols cells, each image box-resampled to the cell size,
 *   clipped to [0,1], sRGB-encoded, on black), e.g. ground truth vs each method; with labels
 *   (ev_grid_png_labelled: scene title, column and row names, a line of text in a cell) drawn in
 *   the image with the built-in bitmap font (eval/ev_text.h).
 * - ev_html_*: a single self-contained index.html (tables as HTML with the paper's first /
 *   second / third cell colours, pictures and paths relative to the report folder, never a
 *   machine's absolute path) readable in any browser.
 * All outputs are written atomically. */
#ifndef EV_REPORT_H
#define EV_REPORT_H

#include <stddef.h>

#include "core/mf_strbuf.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"

typedef struct {
    const char *label;   /* legend entry */
    const double *x, *y; /* borrowed; (n,) */
    int n;
} EvSeries;

/* logx: logarithmic x axis. Fails with MF_EEXT when gnuplot is missing or fails. */
int ev_plot_png(const char *png_path, const char *title, const char *xlabel, const char *ylabel, const EvSeries *s,
                int ns, int logx);
/* 1 when gnuplot can be run. */
int ev_gnuplot_available(void);

/* Speed vs error over every scene of dataset: for each method, the scenes where it has both
 * x_metric (e.g. time_s) and y_metric (e.g. relit_psnr) are points, and their mean is drawn with
 * 95% Student-t error bars on both axes (none for a single scene). MF_OK and no file when no method
 * has a point; MF_EEXT when gnuplot is missing or fails. */
/* The points of one method in that plot: (x, y) of every scene of dataset with both metrics, in
 * table order, at most cap; returns how many. */
int ev_speed_error_points(const EvTable *t, const char *method, const char *dataset, const char *x_metric, const char *y_metric,
                          double *x, double *y, int cap);
int ev_plot_speed_error(const char *png_path, const EvTable *t, const char *const *methods, int nm, const char *dataset,
                        const char *x_metric, const char *y_metric, const char *xlabel, const char *ylabel);

/* The report's speed-vs-error plot: out_dir/speed_error_scenes.png from ev_plot_speed_error with
 * time_s against relit_psnr (nv_psnr for data sets scored on novel views only), and its HTML
 * appended to html. MF_OK with nothing written when the table has neither. */
int ev_report_speed_error(const char *out_dir, const EvTable *t, const char *const *methods, int nm, const char *dataset,
                          MfStrBuf *html);

typedef struct {
    const char *title;              /* borrowed; a line above the grid (the scene), or NULL */
    const char *const *cols;        /* borrowed; (cols,) names above the columns, or NULL */
    const char *const *rows;        /* borrowed; (rows,) names left of the rows (methods), or NULL */
    const char *const *cell_text;   /* borrowed; (rows * cols,) a line at the bottom of a cell (a metric), or NULL */
} EvGridLabels;

/* cells: (rows * cols,) row-major, NULL for an empty cell; images linear with >= 3 channels
 * (a 1-channel image is shown grey). Colour images are sRGB-encoded when srgb is set. */
int ev_grid_png(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                int srgb);
/* The same with labels in the image (lab NULL: as ev_grid_png): bands above (title, column names)
 * and to the left (row names, at most 2 cell widths, cut with '~'); text at scale 2 for cells of
 * 96 pixels or more. Any NULL name is left blank. */
int ev_grid_png_labelled(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                         int srgb, const EvGridLabels *lab);

/* Paper-layout HTML table (same content and ranking as the Markdown table). */
char *ev_table_html_string(const EvTable *t, const char *caption, const char *const *methods, int nm,
                           const char *const *datasets, int nd, const char *const *metrics, int nk);

/* path as the report (in report_dir) should show it: relative to report_dir when both exist
 * (resolved with realpath), else path itself when it is relative, else its last component; into
 * out (cap bytes). Never an absolute path. */
void ev_report_relpath(const char *report_dir, const char *path, char *out, size_t cap);

/* A page assembled from blocks of raw HTML, in order. */
int ev_html_write(const char *path, const char *title, const char *const *blocks, int nblocks);

#endif
