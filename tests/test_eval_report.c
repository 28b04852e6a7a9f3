/* Tests of eval/ev_report: gnuplot plots, image grids, the HTML page. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_report.h"
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
