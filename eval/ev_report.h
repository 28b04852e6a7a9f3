/* ev_report: the pictures and the page of a report.
 *
 * - ev_plot_png: line/point plots through gnuplot (Debian's gnuplot-nox, pngcairo terminal),
 *   e.g. relit PSNR against wall time per method (speed vs error).
 * - ev_grid_png: an image grid (rows x cols cells, each image box-resampled to the cell size,
 *   clipped to [0,1], sRGB-encoded, on black), e.g. ground truth vs each method.
 * - ev_html_*: a single self-contained index.html (tables as HTML with the paper's first /
 *   second / third cell colours, pictures by relative path) readable in any browser.
 * All outputs are written atomically. */
#ifndef EV_REPORT_H
#define EV_REPORT_H

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

/* cells: (rows * cols,) row-major, NULL for an empty cell; images linear with >= 3 channels
 * (a 1-channel image is shown grey). Colour images are sRGB-encoded when srgb is set. */
int ev_grid_png(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                int srgb);

/* Paper-layout HTML table (same content and ranking as the Markdown table). */
char *ev_table_html_string(const EvTable *t, const char *caption, const char *const *methods, int nm,
                           const char *const *datasets, int nd, const char *const *metrics, int nk);

/* A page assembled from blocks of raw HTML, in order. */
int ev_html_write(const char *path, const char *title, const char *const *blocks, int nblocks);

#endif
