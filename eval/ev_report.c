#include "eval/ev_report.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_proc.h"
#include "core/mf_fs.h"
#include "core/mf_math.h"
#include "core/mf_strbuf.h"


static const char *gnuplot_bin(void) { return "/usr/bin/gnuplot"; }

int ev_gnuplot_available(void) { return access(gnuplot_bin(), X_OK) == 0; }

/* Runs `gnuplot script` with output to log; MF_EEXT on failure. */
static int run_gnuplot(const char *script, const char *log) {
    char *argv[] = {(char *)gnuplot_bin(), (char *)script, NULL};
    int run = mf_run_logged(argv, log);
    if (run > 0) return mf_fail(MF_EEXT, "%s: cannot start gnuplot: %s", script, strerror(run));
    if (run < 0) return mf_fail(MF_EEXT, "%s: gnuplot failed (see %s)", script, log);
    return MF_OK;
}

static void gp_quote(FILE *f, const char *s) {
    fputc('"', f);
    for (; *s; ++s) {
        if (*s == '"' || *s == '\\') fputc('\\', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

int ev_plot_png(const char *png_path, const char *title, const char *xlabel, const char *ylabel, const EvSeries *s,
                int ns, int logx) {
    if (!ev_gnuplot_available()) return mf_fail(MF_EEXT, "%s: gnuplot not found (make deps installs gnuplot-nox)", png_path);
    for (int k = 0; k < ns; ++k)
        for (int i = 0; i < s[k].n; ++i)
            if (!isfinite(s[k].x[i]) || !isfinite(s[k].y[i]))
                return mf_fail(MF_ENAN, "%s: series '%s' point %d is not finite", png_path, s[k].label, i);
    char tmp_png[MF_PATH_MAX], script[MF_PATH_MAX + 8], data[MF_PATH_MAX + 8], log[MF_PATH_MAX + 8];
    int rc = mf_tmp_path(png_path, tmp_png, sizeof tmp_png);
    if (rc) return rc;
    snprintf(script, sizeof script, "%s.gp", tmp_png);
    snprintf(data, sizeof data, "%s.dat", tmp_png);
    snprintf(log, sizeof log, "%s.log", tmp_png);
    FILE *fd = fopen(data, "w");
    if (!fd) return mf_fail(MF_EIO, "%s: cannot write", data);
    for (int k = 0; k < ns; ++k) {
        for (int i = 0; i < s[k].n; ++i) fprintf(fd, "%.9g %.9g\n", s[k].x[i], s[k].y[i]);
        fprintf(fd, "\n\n");
    }
    fclose(fd);
    FILE *f = fopen(script, "w");
    if (!f) {
        remove(data);
        return mf_fail(MF_EIO, "%s: cannot write", script);
    }
    fprintf(f, "set terminal pngcairo size 720,480 font 'Sans,10'\nset output ");
    gp_quote(f, tmp_png);
    fprintf(f, "\nset title ");
    gp_quote(f, title);
    fprintf(f, "\nset xlabel ");
    gp_quote(f, xlabel);
    fprintf(f, "\nset ylabel ");
    gp_quote(f, ylabel);
    fprintf(f, "\nset grid\nset key bottom right\n%s", logx ? "set logscale x\n" : "");
    fprintf(f, "plot ");
    for (int k = 0; k < ns; ++k) {
        fprintf(f, "%s", k ? ", " : "");
        gp_quote(f, data);
        fprintf(f, " index %d with linespoints lw 2 title ", k);
        gp_quote(f, s[k].label);
    }
    fprintf(f, "\n");
    fclose(f);
    rc = run_gnuplot(script, log);
    remove(data);
    remove(script);
    if (rc) {
        mf_discard_file(tmp_png);
        return rc;
    }
    remove(log);
    return mf_commit_file(tmp_png, png_path);
}

int ev_grid_png(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                int srgb) {
    MfImage out;
    int rc = mf_image_alloc(&out, cols * cell_w, rows * cell_h, 3);
    if (rc) return rc;
    for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) {
            const MfImage *im = cells[r * cols + c];
            if (!im || !im->data) continue;
            for (int y = 0; y < cell_h; ++y)
                for (int x = 0; x < cell_w; ++x) {
                    /* box filter over the source footprint of this cell pixel */
                    int x0 = x * im->w / cell_w, x1 = (x + 1) * im->w / cell_w;
                    int y0 = y * im->h / cell_h, y1 = (y + 1) * im->h / cell_h;
                    if (x1 <= x0) x1 = x0 + 1;
                    if (y1 <= y0) y1 = y0 + 1;
                    double acc[3] = {0, 0, 0};
                    int n = 0;
                    for (int sy = y0; sy < y1 && sy < im->h; ++sy)
                        for (int sx = x0; sx < x1 && sx < im->w; ++sx, ++n) {
                            const float *p = mf_image_px(im, sx, sy);
                            for (int k = 0; k < 3; ++k) acc[k] += p[im->c >= 3 ? k : 0];
                        }
                    float *o = mf_image_px(&out, c * cell_w + x, r * cell_h + y);
                    for (int k = 0; k < 3; ++k) {
                        float v = n ? (float)(acc[k] / n) : 0.0f;
                        o[k] = isfinite(v) ? mf_clampf(v, 0.0f, 1.0f) : 0.0f;
                    }
                }
        }
    rc = mf_image_write(png_path, &out, srgb ? MF_ENC_SRGB : MF_ENC_LINEAR, 8);
    mf_image_free(&out);
    return rc;
}

char *ev_table_html_string(const EvTable *t, const char *caption, const char *const *methods, int nm,
                           const char *const *datasets, int nd, const char *const *metrics, int nk) {
    static const char *colour[3] = {"#ffb3b3", "#ffd9b3", "#ffffb3"}; /* the paper's tabfirst/second/third */
    MfStrBuf b = {0};
    mf_sb_printf(&b, "<table>\n<caption>");
    mf_sb_html(&b, caption ? caption : "");
    mf_sb_printf(&b, "</caption>\n<tr><th rowspan=2>method</th>");
    for (int d = 0; d < nd; ++d) {
        mf_sb_printf(&b, "<th colspan=%d>", nk);
        mf_sb_html(&b, datasets[d]);
        mf_sb_printf(&b, "</th>");
    }
    mf_sb_printf(&b, "</tr>\n<tr>");
    for (int d = 0; d < nd; ++d)
        for (int k = 0; k < nk; ++k) {
            mf_sb_printf(&b, "<th>");
            mf_sb_html(&b, metrics[k]);
            mf_sb_printf(&b, " %s</th>", ev_metric_higher_better(metrics[k]) ? "&uarr;" : "&darr;");
        }
    mf_sb_printf(&b, "</tr>\n");
    for (int m = 0; m < nm; ++m) {
        mf_sb_printf(&b, "<tr><td>");
        mf_sb_html(&b, methods[m]);
        mf_sb_printf(&b, "</td>");
        for (int d = 0; d < nd; ++d)
            for (int k = 0; k < nk; ++k) {
                EvStat s = ev_table_stat(t, methods[m], datasets[d], metrics[k]);
                if (s.n == 0) { mf_sb_printf(&b, "<td>&ndash;</td>"); continue; }
                int better = ev_table_rank(t, methods, nm, m, datasets[d], metrics[k]);
                int dec = ev_metric_decimals(metrics[k]);
                if (nm > 1 && better < 3) mf_sb_printf(&b, "<td style=\"background:%s\">", colour[better]);
                else mf_sb_printf(&b, "<td>");
                mf_sb_printf(&b, "%.*f", dec, s.mean);
                if (s.n > 1) mf_sb_printf(&b, " <small>&plusmn; %.*f</small>", dec, s.ci95);
                mf_sb_printf(&b, "</td>");
            }
        mf_sb_printf(&b, "</tr>\n");
    }
    mf_sb_printf(&b, "</table>\n");
    return mf_sb_take(&b);
}

int ev_html_write(const char *path, const char *title, const char *const *blocks, int nblocks) {
    MfStrBuf b = {0};
    mf_sb_printf(&b, "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>");
    mf_sb_html(&b, title);
    mf_sb_printf(&b, "</title>\n<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto}"
                    "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #999;padding:3px 8px;"
                    "text-align:right}caption{font-weight:bold;text-align:left}img{max-width:100%%}</style>\n"
                    "</head><body>\n<h1>");
    mf_sb_html(&b, title);
    mf_sb_printf(&b, "</h1>\n");
    for (int i = 0; i < nblocks; ++i) mf_sb_printf(&b, "%s\n", blocks[i]);
    mf_sb_printf(&b, "</body></html>\n");
    return mf_sb_write(&b, path);
}
