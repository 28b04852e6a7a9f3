#include "eval/ev_report.h"

#include <fcntl.h>
#include <gsl/gsl_cdf.h>
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
#include "eval/ev_text.h"


static const char *gnuplot_bin(void) { return "/usr/bin/gnuplot"; }

int ev_gnuplot_available(void) { return access(gnuplot_bin(), X_OK) == 0; }

/* Runs `gnuplot script` (which writes tmp_png) with output to log, removes the data and script
 * files, then renames tmp_png to png_path and removes the log; on failure (MF_EEXT) tmp_png is
 * discarded and the log kept. */
static int run_gnuplot(const char *script, const char *data, const char *log, const char *tmp_png, const char *png_path) {
    char *argv[] = {(char *)gnuplot_bin(), (char *)script, NULL};
    int run = mf_run_logged(argv, log);
    remove(data);
    remove(script);
    if (run) {
        mf_discard_file(tmp_png);
        return run > 0 ? mf_fail(MF_EEXT, "%s: cannot start gnuplot: %s", script, strerror(run))
                       : mf_fail(MF_EEXT, "%s: gnuplot failed (see %s)", script, log);
    }
    remove(log);
    return mf_commit_file(tmp_png, png_path);
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
    return run_gnuplot(script, data, log, tmp_png, png_path);
}

int ev_grid_png(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                int srgb) {
    return ev_grid_png_labelled(png_path, cells, rows, cols, cell_w, cell_h, srgb, NULL);
}

int ev_grid_png_labelled(const char *png_path, const MfImage *const *cells, int rows, int cols, int cell_w, int cell_h,
                         int srgb, const EvGridLabels *lab) {
    /* label bands: a title line and a column-name line on top, row names on the left */
    const int s = cell_w >= 96 ? 2 : 1, pad = 2 * s, line = EV_TEXT_LINE * s + 2 * pad;
    int top = 0, left = 0;
    if (lab && lab->title) top += line;
    if (lab && lab->cols) top += line;
    if (lab && lab->rows) {
        for (int r = 0; r < rows; ++r)
            if (lab->rows[r]) left = left > ev_text_width(lab->rows[r], s) ? left : ev_text_width(lab->rows[r], s);
        left = (left < 2 * cell_w ? left : 2 * cell_w) + 2 * pad;
    }
    MfImage out;
    int rc = mf_image_alloc(&out, left + cols * cell_w, top + rows * cell_h, 3);
    if (rc) return rc;
    if (top || left) {
        const float band = 0.02f; /* linear: dark grey behind the labels */
        for (int y = 0; y < out.h; ++y)
            for (int x = 0; x < out.w; ++x)
                if (y < top || x < left) mf_image_px(&out, x, y)[0] = mf_image_px(&out, x, y)[1] = mf_image_px(&out, x, y)[2] = band;
        int y = pad;
        if (lab->title) ev_text_draw(&out, pad, y, lab->title, s, NULL, out.w - 2 * pad), y += line;
        for (int c = 0; lab->cols && c < cols; ++c)
            if (lab->cols[c]) ev_text_draw(&out, left + c * cell_w + pad, y, lab->cols[c], s, NULL, cell_w - 2 * pad);
        for (int r = 0; lab->rows && r < rows; ++r)
            if (lab->rows[r]) ev_text_draw(&out, pad, top + r * cell_h + pad, lab->rows[r], s, NULL, left - 2 * pad);
    }
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
                    float *o = mf_image_px(&out, left + c * cell_w + x, top + r * cell_h + y);
                    for (int k = 0; k < 3; ++k) {
                        float v = n ? (float)(acc[k] / n) : 0.0f;
                        o[k] = isfinite(v) ? mf_clampf(v, 0.0f, 1.0f) : 0.0f;
                    }
                }
        }
    for (int i = 0; lab && lab->cell_text && i < rows * cols; ++i) {
        const char *txt = lab->cell_text[i];
        if (!txt || !txt[0]) continue;
        /* on a dark box at the bottom-left of the cell */
        int x0 = left + (i % cols) * cell_w, y1 = top + (i / cols + 1) * cell_h;
        int w = ev_text_width(txt, s) + 2 * pad, h = EV_TEXT_LINE * s + pad;
        if (w > cell_w) w = cell_w;
        for (int y = y1 - h; y < y1; ++y)
            for (int x = x0; x < x0 + w; ++x)
                if (y >= 0) mf_image_px(&out, x, y)[0] = mf_image_px(&out, x, y)[1] = mf_image_px(&out, x, y)[2] = 0.0f;
        ev_text_draw(&out, x0 + pad, y1 - h + pad, txt, s, NULL, cell_w - 2 * pad);
    }
    rc = mf_image_write(png_path, &out, srgb ? MF_ENC_SRGB : MF_ENC_LINEAR, 8);
    mf_image_free(&out);
    return rc;
}

int ev_speed_error_points(const EvTable *t, const char *method, const char *dataset, const char *x_metric, const char *y_metric,
                          double *x, double *y, int cap) {
    int n = 0;
    for (size_t i = 0; i < t->n && n < cap; ++i) {
        const EvRecord *r = &t->rec[i];
        if (strcmp(r->method, method) || strcmp(r->dataset, dataset) || strcmp(r->metric, y_metric) ||
            !ev_table_find(t, method, dataset, r->scene, x_metric, &x[n]))
            continue;
        y[n++] = r->value;
    }
    return n;
}

int ev_plot_speed_error(const char *png_path, const EvTable *t, const char *const *methods, int nm, const char *dataset,
                        const char *x_metric, const char *y_metric, const char *xlabel, const char *ylabel) {
    /* at most this many points for any one method */
    int npts = 0;
    for (size_t i = 0; i < t->n; ++i) npts += !strcmp(t->rec[i].dataset, dataset) && !strcmp(t->rec[i].metric, y_metric);
    if (!npts) return MF_OK;
    if (!ev_gnuplot_available()) return mf_fail(MF_EEXT, "%s: gnuplot not found (make deps installs gnuplot-nox)", png_path);
    char tmp_png[MF_PATH_MAX], script[MF_PATH_MAX + 8], data[MF_PATH_MAX + 8], log[MF_PATH_MAX + 8];
    int rc = mf_tmp_path(png_path, tmp_png, sizeof tmp_png);
    if (rc) return rc;
    snprintf(script, sizeof script, "%s.gp", tmp_png);
    snprintf(data, sizeof data, "%s.dat", tmp_png);
    snprintf(log, sizeof log, "%s.log", tmp_png);
    FILE *fd = fopen(data, "w");
    if (!fd) return mf_fail(MF_EIO, "%s: cannot write", data);
    int *shown = calloc((size_t)nm + 1, sizeof(int)), nshown = 0;
    if (!shown) {
        fclose(fd);
        remove(data);
        return mf_fail(MF_ENOMEM, "%s: out of memory", png_path);
    }
    double *px = malloc(sizeof(double) * ((size_t)npts + 1)), *py = malloc(sizeof(double) * ((size_t)npts + 1));
    for (int m = 0; m < nm && px && py; ++m) {
        double sx = 0, sy = 0, sxx = 0, syy = 0;
        int n = ev_speed_error_points(t, methods[m], dataset, x_metric, y_metric, px, py, npts);
        for (int i = 0; i < n; ++i) {
            fprintf(fd, "%.9g %.9g\n", px[i], py[i]);
            sx += px[i], sy += py[i], sxx += px[i] * px[i], syy += py[i] * py[i];
        }
        if (!n) continue;
        double mx = sx / n, my = sy / n, cx = 0, cy = 0;
        if (n > 1) {
            double q = gsl_cdf_tdist_Pinv(0.975, n - 1) / sqrt((double)n);
            cx = q * sqrt(fmax(0.0, (sxx - n * mx * mx) / (n - 1)));
            cy = q * sqrt(fmax(0.0, (syy - n * my * my) / (n - 1)));
        }
        fprintf(fd, "\n\n%.9g %.9g %.9g %.9g\n\n\n", mx, my, cx, cy);
        shown[nshown++] = m;
    }
    fclose(fd);
    int nomem = !px || !py;
    free(px), free(py);
    FILE *f = nshown && !nomem ? fopen(script, "w") : NULL;
    if (!f) {
        free(shown);
        remove(data);
        if (nomem) return mf_fail(MF_ENOMEM, "%s: out of memory", png_path);
        return nshown ? mf_fail(MF_EIO, "%s: cannot write", script) : MF_OK;
    }
    fprintf(f, "set terminal pngcairo noenhanced size 720,480 font 'Sans,10'\nset output ");
    gp_quote(f, tmp_png);
    fprintf(f, "\nset title \"%s vs %s: every scene of %.60s (small: one scene; large: mean, bars: 95%% CI)\"\n", y_metric, x_metric, dataset);
    fprintf(f, "set xlabel ");
    gp_quote(f, xlabel);
    fprintf(f, "\nset ylabel ");
    gp_quote(f, ylabel);
    fprintf(f, "\nset grid\nset key outside right top\nset offsets graph 0.05, graph 0.05, graph 0.05, graph 0.05\nplot ");
    for (int k = 0; k < nshown; ++k) {
        fprintf(f, "%s", k ? ", " : "");
        gp_quote(f, data);
        fprintf(f, " index %d with points pt 7 ps 0.8 lc %d notitle, ", 2 * k, k + 1);
        gp_quote(f, data);
        fprintf(f, " index %d with xyerrorbars pt 5 ps 1.6 lw 2 lc %d title ", 2 * k + 1, k + 1);
        gp_quote(f, methods[shown[k]]);
    }
    fprintf(f, "\n");
    fclose(f);
    free(shown);
    return run_gnuplot(script, data, log, tmp_png, png_path);
}

int ev_report_speed_error(const char *out_dir, const EvTable *t, const char *const *methods, int nm, const char *dataset,
                          MfStrBuf *html) {
    const char *ym = "relit_psnr";
    int any = 0;
    for (int m = 0; m < nm && !any; ++m) any = ev_table_stat(t, methods[m], dataset, ym).n > 0;
    if (!any) ym = "nv_psnr";
    char p[MF_PATH_MAX];
    int rc = mf_path_join(p, sizeof p, out_dir, "speed_error_scenes.png");
    if (!rc) remove(p); /* a stale plot of an earlier run is not this run's */
    if (!rc) rc = ev_plot_speed_error(p, t, methods, nm, dataset, "time_s", ym, "wall time [s]", strcmp(ym, "relit_psnr") ? "novel-view PSNR [dB]" : "relit PSNR [dB]");
    if (!rc && mf_file_exists(p))
        mf_sb_printf(html, "<h2>Speed vs error, every scene</h2><p>One small point per scene and method (wall time of the "
                           "run, %s of the scene); large points: the method's mean over the scenes, bars: 95%% CI.</p>"
                           "<img src=\"speed_error_scenes.png\">\n", ym);
    return rc;
}

void ev_report_relpath(const char *report_dir, const char *path, char *out, size_t cap) {
    char *a = realpath(report_dir, NULL), *b = realpath(path, NULL);
    if (a && b) {
        /* the common folder prefix, then one ".." per folder of a below it */
        size_t i = 0, cut = 0;
        while (a[i] && a[i] == b[i]) {
            if (a[i] == '/') cut = i;
            ++i;
        }
        if (!a[i] && (!b[i] || b[i] == '/')) cut = i; /* b is a or inside it */
        else if (!b[i] && a[i] == '/') cut = i;       /* a is inside b */
        MfStrBuf r = {0};
        for (const char *p = a + cut; *p; ++p)
            if (*p == '/') mf_sb_printf(&r, "%s..", r.s ? "/" : "");
        const char *rest = b + cut + (b[cut] == '/');
        if (*rest) mf_sb_printf(&r, "%s%s", r.s ? "/" : "", rest);
        snprintf(out, cap, "%s", r.s ? r.s : ".");
        mf_sb_free(&r);
    } else if (path[0] != '/') {
        snprintf(out, cap, "%s", path);
    } else {
        const char *slash = strrchr(path, '/');
        snprintf(out, cap, "%s", slash[1] ? slash + 1 : path);
    }
    free(a);
    free(b);
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
