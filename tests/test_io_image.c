/* Tests of mf/io/mf_image: sRGB curve, PNG/EXR/HDR round trips, bad files. */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_image.h"
#include "io/mf_image_oiio.h"
#include "mf_test.h"

MF_TEST(image_srgb_curve) {
    CHECK_NEAR(mf_srgb_to_linear(0.0f), 0.0f, 0);
    CHECK_NEAR(mf_srgb_to_linear(1.0f), 1.0f, 1e-6);
    CHECK_NEAR(mf_srgb_to_linear(0.04045f), 0.04045f / 12.92f, 1e-7);
    CHECK_NEAR(mf_srgb_to_linear(0.5f), 0.214041140f, 1e-6);
    for (int i = 0; i <= 1000; ++i) {
        float x = i / 1000.0f;
        CHECK_NEAR(mf_srgb_to_linear(mf_linear_to_srgb(x)), x, 2e-6);
    }
    CHECK(mf_linear_to_srgb(-1.0f) == 0.0f);
}

static void fill(MfImage *im) {
    for (int y = 0; y < im->h; ++y)
        for (int x = 0; x < im->w; ++x)
            for (int c = 0; c < im->c; ++c) mf_image_px(im, x, y)[c] = (float)((x * 7 + y * 13 + c * 5) % 17) / 16.0f;
}

MF_TEST(image_roundtrip_formats) {
    MfImage a = {0}, b = {0};
    CHECK_OK(mf_image_alloc(&a, 13, 7, 4));
    fill(&a);
    struct { const char *name; MfEncoding enc; int bits; float tol; } cases[] = {
        {"rt8.png", MF_ENC_SRGB, 8, 0.5f / 255.0f * 13.0f}, /* sRGB quantisation, worst near 0 */
        {"rt16.png", MF_ENC_SRGB, 16, 2e-4f},
        {"rt16lin.png", MF_ENC_LINEAR, 16, 1.0f / 65535.0f},
        {"rth.exr", MF_ENC_LINEAR, 16, 1e-3f},
        {"rtf.exr", MF_ENC_LINEAR, 32, 0.0f},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        const char *p = mf_test_path(cases[k].name);
        CHECK_OK(mf_image_write(p, &a, cases[k].enc, cases[k].bits));
        CHECK_OK(mf_image_read(p, cases[k].enc, &b));
        CHECK(b.w == a.w && b.h == a.h && b.c == a.c);
        if (b.data && b.w == a.w && b.h == a.h && b.c == a.c) {
            float worst = 0.0f;
            for (size_t i = 0; i < (size_t)a.w * a.h * a.c; ++i) worst = fmaxf(worst, fabsf(a.data[i] - b.data[i]));
            CHECK_MSG(worst <= cases[k].tol, "%s: max error %g > %g", cases[k].name, worst, cases[k].tol);
        }
        mf_image_free(&b);
    }
    /* HDR (RGBE) keeps 8 mantissa bits with an exponent shared by the pixel's channels: error
     * below 1% of the pixel's largest channel. */
    MfImage rgb = {0};
    CHECK_OK(mf_image_alloc(&rgb, 5, 4, 3));
    for (int i = 0; i < 60; ++i) rgb.data[i] = 0.01f + 37.0f * (float)i;
    CHECK_OK(mf_image_write(mf_test_path("rt.hdr"), &rgb, MF_ENC_LINEAR, 32));
    CHECK_OK(mf_image_read(mf_test_path("rt.hdr"), MF_ENC_LINEAR, &b));
    for (int i = 0; b.data && i < 60; ++i) CHECK_NEAR(b.data[i], rgb.data[i], 0.01 * rgb.data[i - i % 3 + 2]);
    mf_image_free(&b);
    mf_image_free(&rgb);
    mf_image_free(&a);
}

MF_TEST(image_bad_files) {
    MfImage b = {0};
    CHECK_ERR(mf_image_read(mf_test_path("nope.png"), MF_ENC_SRGB, &b), "nope.png: no such file");
    /* truncated PNG */
    MfImage a = {0};
    CHECK_OK(mf_image_alloc(&a, 64, 64, 3));
    fill(&a);
    const char *p = mf_test_path("trunc.png");
    CHECK_OK(mf_image_write(p, &a, MF_ENC_SRGB, 8));
    FILE *f = fopen(p, "r+b");
    CHECK(f != NULL);
    if (f) {
        fseek(f, 0, SEEK_END);
        long n = ftell(f);
        fclose(f);
        CHECK(truncate(p, n / 2) == 0);
    }
    CHECK_ERR(mf_image_read(p, MF_ENC_SRGB, &b), "trunc.png");
    CHECK(b.data == NULL);
    /* NaN refused on write, and on read of an EXR that holds one */
    a.data[5] = NAN;
    CHECK_ERR(mf_image_write(mf_test_path("image_nan.exr"), &a, MF_ENC_LINEAR, 32), "NaN");
    CHECK(!mf_file_exists(mf_test_path("image_nan.exr")));
    char err[256];
    CHECK(mf_oiio_write(mf_test_path("nan_raw.exr"), a.w, a.h, a.c, a.data, 32, err, sizeof err) == 0);
    CHECK_ERR(mf_image_read(mf_test_path("nan_raw.exr"), MF_ENC_LINEAR, &b), "nan_raw.exr: pixel (1, 0) channel 2 is NaN");
    mf_image_free(&a);
}
