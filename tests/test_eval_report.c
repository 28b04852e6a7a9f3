/* Tests of eval/ev_report: gnuplot plots, image grids, the HTML page. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_strbuf.h"
#include "eval/ev_report.h"
#include "eval/ev_text.h"
#include "eval/ev_table.h"
#include "mf_test.h"

MF_TEST(eval_report_plot_png) {
    if (!ev_gnuplot_available()) MF_SKIP("gnuplot not installed");
    double x[] = {1, 2, 4, 8}, y1[] = {20, 23, 25, 26}, y2[] = {21, 24, 27, 28};
    EvSeries s[] = {{"baseline", x, y1, 4}, {"materialfusion", x, y2, 4}};
    const char *p = mf_test_path("plot.png");
    CHECK_OK(ev_plot_png(p, "relit PSNR vs time", "wall time [s]", "PSNR [dB]", s, 2, 1));
    MfImage im = {0};
    CHECK_OK(mf_image_read(p, MF_ENC_SRGB, &im));
    CHECK(im.w == 720 && im.h == 480);
    /* not blank: some dark (axis/text) and some light pixels */
    int dark = 0, light = 0;
    for (int i = 0; im.data && i < im.w * im.h; ++i) {
        float v = im.data[i * im.c + 1];
        dark += v < 0.2f;
        light += v > 0.8f;
    }
    CHECK(dark > 100 && light > 100000);
    mf_image_free(&im);
    double bad[] = {1, NAN, 3, 4};
    EvSeries sb = {"bad", x, bad, 4};
    CHECK_ERR(ev_plot_png(mf_test_path("bad.png"), "t", "x", "y", &sb, 1, 0), "series 'bad' point 1");
    CHECK(!mf_file_exists(mf_test_path("bad.png")));
}

MF_TEST(eval_report_grid_and_html) {
    MfImage a = {0}, b = {0}, g = {0};
    CHECK_OK(mf_image_alloc(&a, 8, 8, 3));
    CHECK_OK(mf_image_alloc(&b, 4, 4, 1));
    for (int i = 0; i < 8 * 8 * 3; ++i) a.data[i] = 0.5f;
    for (int i = 0; i < 16; ++i) b.data[i] = 2.0f; /* clipped to 1 */
    const MfImage *cells[] = {&a, NULL, &b, &a};
    const char *p = mf_test_path("grid.png");
    CHECK_OK(ev_grid_png(p, cells, 2, 2, 4, 4, 0));
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &g));
    CHECK(g.w == 8 && g.h == 8);
    if (g.data) {
        CHECK_NEAR(mf_image_px(&g, 1, 1)[0], 0.5, 1.0 / 255);
        CHECK_NEAR(mf_image_px(&g, 5, 1)[0], 0.0, 0);
        CHECK_NEAR(mf_image_px(&g, 1, 5)[2], 1.0, 0);
    }
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_add(&t, "a<b", "bv", "s", "psnr", 20));
    CHECK_OK(ev_table_add(&t, "c", "bv", "s", "psnr", 30));
    const char *methods[] = {"a<b", "c"}, *ds[] = {"bv"}, *mk[] = {"psnr"};
    char *tab = ev_table_html_string(&t, "cap", methods, 2, ds, 1, mk, 1);
    CHECK(tab && strstr(tab, "<td>a&lt;b</td><td style=\"background:#ffd9b3\">20.00</td>"));
    CHECK(tab && strstr(tab, "<td style=\"background:#ffb3b3\">30.00</td>"));
    const char *blocks[] = {tab ? tab : "", "<img src=\"grid.png\">"};
    CHECK_OK(ev_html_write(mf_test_path("index.html"), "Report", blocks, 2));
    char *html = NULL;
    CHECK_OK(mf_read_file(mf_test_path("index.html"), &html, NULL));
    CHECK(html && strstr(html, "<title>Report</title>") && strstr(html, "<img src=\"grid.png\">"));
    free(html);
    free(tab);
    ev_table_free(&t);
    mf_image_free(&a);
    mf_image_free(&b);
    mf_image_free(&g);
}

/* The built-in font: every printable glyph distinct and inked (space blank), drawn where asked. */
MF_TEST(eval_report_text_font) {
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 95 * EV_TEXT_ADV, EV_TEXT_LINE, 1));
    char all[96];
    for (int i = 0; i < 95; ++i) all[i] = (char)(32 + i);
    all[95] = 0;
    ev_text_draw(&im, 0, 0, all, 1, NULL, 0);
    int dup = 0, blank = 0;
    for (int a = 0; a < 95; ++a) {
        int ink = 0;
        for (int y = 0; y < 7; ++y)
            for (int x = 0; x < 5; ++x) ink += mf_image_px(&im, a * EV_TEXT_ADV + x, y)[0] > 0;
        blank += (a == 0) != (ink == 0);
        for (int b = 0; b < a; ++b) {
            int same = 1;
            for (int y = 0; y < 7 && same; ++y)
                for (int x = 0; x < 5 && same; ++x)
                    same = mf_image_px(&im, a * EV_TEXT_ADV + x, y)[0] == mf_image_px(&im, b * EV_TEXT_ADV + x, y)[0];
            dup += same;
        }
    }
    CHECK_MSG(!dup && !blank, "%d glyph pairs identical, %d glyphs blank (or space inked)", dup, blank);
    /* spacing column and rows stay clear; 'T' top row is solid; scale 2 doubles it */
    int gap = 0;
    for (int a = 0; a < 95; ++a)
        for (int y = 0; y < EV_TEXT_LINE; ++y) gap += mf_image_px(&im, a * EV_TEXT_ADV + 5, y)[0] > 0;
    for (int x = 0; x < im.w; ++x) gap += mf_image_px(&im, x, 7)[0] > 0 || mf_image_px(&im, x, 8)[0] > 0;
    CHECK(gap == 0);
    mf_image_free(&im);
    CHECK_OK(mf_image_alloc(&im, 20, 20, 3));
    ev_text_draw(&im, 3, 2, "T", 2, NULL, 0);
    for (int x = 0; x < 20; ++x) CHECK(mf_image_px(&im, x, 2)[1] == ((x >= 3 && x < 13) ? 1.0f : 0.0f));
    CHECK(ev_text_width("abc", 2) == 3 * EV_TEXT_ADV * 2);
    /* cut to max_w with '~' last; nothing outside the image */
    ev_text_draw(&im, 15, 15, "WWWWWWWW", 1, NULL, 12);
    mf_image_free(&im);
}

/* Fraction of pixels in [x0, x1) x [y0, y1) brighter than 0.9 (white text). */
static double white_share(const MfImage *g, int x0, int y0, int x1, int y1) {
    int n = 0, w = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++n) w += mf_image_px(g, x, y)[0] > 0.9f && mf_image_px(g, x, y)[2] > 0.9f;
    return n ? (double)w / n : 0;
}

/* Labelled grid: bands for the title and column names above, row names on the left, text inside
 * a cell; the cells are where they were, shifted by the bands. */
MF_TEST(eval_report_grid_labels) {
    MfImage a = {0}, g = {0};
    CHECK_OK(mf_image_alloc(&a, 8, 8, 3));
    for (int i = 0; i < 8 * 8 * 3; ++i) a.data[i] = 0.25f;
    const MfImage *cells[] = {&a, &a, &a, &a};
    const char *cols[] = {"relit", "albedo"}, *rows[] = {"ground truth", "materialfusion"}, *txt[] = {NULL, NULL, "21.43 dB", NULL};
    EvGridLabels lab = {"scene 000_cup", cols, rows, txt};
    const char *p = mf_test_path("grid_labels.png");
    CHECK_OK(ev_grid_png_labelled(p, cells, 2, 2, 100, 100, 0, &lab));
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &g));
    /* scale 2: line = 18 + 8 = 26 px; left = 14 chars x 12 + 8 = 176 px */
    const int top = 52, left = 176;
    CHECK_MSG(g.w == left + 200 && g.h == top + 200, "labelled grid is %dx%d, expected %dx%d", g.w, g.h, left + 200, top + 200);
    if (g.w == left + 200 && g.h == top + 200) {
        CHECK(white_share(&g, 0, 0, g.w, 26) > 0.01);                    /* title */
        CHECK(white_share(&g, left, 26, left + 100, top) > 0.01);        /* "relit" */
        CHECK(white_share(&g, left + 100, 26, left + 200, top) > 0.01);  /* "albedo" */
        CHECK(white_share(&g, 0, top, left, top + 26) > 0.01);           /* "ground truth" */
        CHECK(white_share(&g, 0, top + 100, left, top + 126) > 0.01);    /* "materialfusion" */
        CHECK(white_share(&g, left, top + 174, left + 100, top + 200) > 0.01); /* the cell's text, bottom left */
        CHECK(white_share(&g, left + 100, top + 100, left + 200, top + 200) == 0); /* a cell without text */
        CHECK_NEAR(mf_image_px(&g, left + 150, top + 50)[0], 0.25, 1.0 / 255);
        CHECK_NEAR(mf_image_px(&g, left + 50, top + 150)[0], 0.25, 1.0 / 255);
    }
    mf_image_free(&g);
    /* no labels: the plain grid, same size as before */
    CHECK_OK(ev_grid_png_labelled(p, cells, 2, 2, 100, 100, 0, NULL));
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &g));
    CHECK(g.w == 200 && g.h == 200);
    mf_image_free(&g);
    mf_image_free(&a);
}

/* Speed vs error: every scene's point, not the first scene's only; the plot is written. */
MF_TEST(eval_report_speed_error_all_scenes) {
    EvTable t;
    ev_table_init(&t);
    const char *sc[] = {"s1", "s2", "s3"};
    for (int i = 0; i < 3; ++i) {
        CHECK_OK(ev_table_add(&t, "base", "ds", sc[i], "time_s", 10 + i));
        CHECK_OK(ev_table_add(&t, "base", "ds", sc[i], "relit_psnr", 20 + i));
        CHECK_OK(ev_table_add(&t, "mf", "ds", sc[i], "relit_psnr", 22 + i));
        if (i) CHECK_OK(ev_table_add(&t, "mf", "ds", sc[i], "time_s", 30 + i)); /* s1: no time -> no point */
    }
    double x[8], y[8];
    CHECK(ev_speed_error_points(&t, "base", "ds", "time_s", "relit_psnr", x, y, 8) == 3);
    int n = ev_speed_error_points(&t, "mf", "ds", "time_s", "relit_psnr", x, y, 8);
    CHECK(n == 2 && x[0] == 31 && y[0] == 23 && x[1] == 32 && y[1] == 24);
    if (ev_gnuplot_available()) {
        const char *methods[] = {"base", "mf", "none"};
        MfStrBuf html = {0};
        CHECK_OK(ev_report_speed_error(mf_test_tmpdir(), &t, methods, 3, "ds", &html));
        CHECK(html.s && strstr(html.s, "speed_error_scenes.png"));
        MfImage im = {0};
        CHECK_OK(mf_image_read(mf_test_path("speed_error_scenes.png"), MF_ENC_SRGB, &im));
        CHECK(im.w == 720 && im.h == 480);
        mf_image_free(&im);
        mf_sb_free(&html);
    }
    ev_table_free(&t);
}

/* Paths in the report: relative to the report folder, never absolute. */
MF_TEST(eval_report_relpath) {
    char rep[1024], data[1024], out[1024];
    mf_test_path_to(rep, sizeof rep, "rp/reports/run1");
    mf_test_path_to(data, sizeof data, "rp/data/tiny");
    CHECK_OK(mf_mkdirs(rep));
    CHECK_OK(mf_mkdirs(data));
    ev_report_relpath(rep, data, out, sizeof out);
    CHECK_MSG(!strcmp(out, "../../data/tiny"), "got '%s'", out);
    ev_report_relpath(rep, rep, out, sizeof out);
    CHECK_MSG(!strcmp(out, "."), "got '%s'", out);
    ev_report_relpath(data, mf_test_path("rp/data"), out, sizeof out);
    CHECK_MSG(!strcmp(out, ".."), "got '%s'", out);
    CHECK_OK(mf_mkdirs(mf_test_path("rp/reports/run1/sub")));
    ev_report_relpath(rep, mf_test_path("rp/reports/run1/sub"), out, sizeof out);
    CHECK_MSG(!strcmp(out, "sub"), "got '%s'", out);
    CHECK_OK(mf_mkdirs(mf_test_path("rp/reports/run")));
    ev_report_relpath(rep, mf_test_path("rp/reports/run"), out, sizeof out); /* a prefix of the name, not a parent */
    CHECK_MSG(!strcmp(out, "../run"), "got '%s'", out);
    ev_report_relpath(rep, "/no/such/place/scene", out, sizeof out);
    CHECK_MSG(!strcmp(out, "scene"), "got '%s'", out);
    ev_report_relpath(rep, "rel/x", out, sizeof out);
    CHECK_MSG(!strcmp(out, "rel/x"), "got '%s'", out);
}
