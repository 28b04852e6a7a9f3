/* Tests of mf/io/mf_exr: multi-layer round trips (float exact, half within 2^-11), OIIO reads
 * our files, lookups by name, NaN and truncated files refused with the file and channel named. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "mf_test.h"

enum { W = 37, H = 23 }; /* odd sizes: several ZIP chunks of 16 lines, the last one partial */

static const char *NAMES[] = {"R", "G", "B", "A", "albedo.R", "albedo.G", "albedo.B", "depth.Z", "normal.X", "normal.Y", "normal.Z"};
enum { NCH = sizeof NAMES / sizeof NAMES[0] };

static float val(int k, int x, int y) { return (float)(k + 1) * 0.37f + sinf(0.3f * x + 0.7f * y + k) * (k == 7 ? 100.0f : 1.0f); }

static void make_planes(float *planes) {
    for (int k = 0; k < NCH; ++k)
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) planes[((size_t)k * H + y) * W + x] = val(k, x, y);
}

MF_TEST(io_exr_roundtrip_float_half) {
    float *planes = malloc(sizeof(float) * NCH * W * H);
    make_planes(planes);
    /* Write in an order different from EXR's sorted order, plus one interleaved layer. */
    MfExrChannel ch[NCH];
    for (int k = 0; k < NCH; ++k) ch[NCH - 1 - k] = (MfExrChannel){NAMES[k], planes + (size_t)k * W * H, 0};
    for (int half = 0; half <= 1; ++half) {
        const char *p = mf_test_path(half ? "ml_half.exr" : "ml_float.exr");
        CHECK_OK(mf_exr_write(p, W, H, ch, NCH, half ? MF_EXR_HALF : MF_EXR_FLOAT));
        MfExrImage im = {0};
        CHECK_OK(mf_exr_read(p, &im));
        CHECK(im.w == W && im.h == H && im.n == NCH);
        for (int i = 1; i < im.n; ++i) CHECK(strcmp(im.names[i - 1], im.names[i]) < 0); /* sorted */
        for (int k = 0; k < NCH && im.data; ++k) {
            const float *pl = mf_exr_channel(&im, NAMES[k]);
            CHECK_MSG(pl != NULL, "channel %s missing", NAMES[k]);
            if (!pl) continue;
            float worst = 0.0f;
            for (int i = 0; i < W * H; ++i) {
                float a = planes[(size_t)k * W * H + i], b = pl[i];
                float err = fabsf(a - b) / fmaxf(fabsf(a), 6.1e-5f);
                worst = fmaxf(worst, err);
            }
            CHECK_MSG(worst <= (half ? 1.0f / 2048.0f : 0.0f), "%s %s: relative error %g", half ? "half" : "float", NAMES[k], worst);
        }
        CHECK(mf_exr_channel(&im, "specular.R") == NULL);
        mf_exr_free(&im);
        CHECK(im.data == NULL && im.names == NULL);
    }
    free(planes);
}

MF_TEST(io_exr_layers_and_oiio) {
    MfImage rgba = {0}, alb = {0}, got = {0};
    CHECK_OK(mf_image_alloc(&rgba, W, H, 4));
    CHECK_OK(mf_image_alloc(&alb, W, H, 3));
    for (size_t i = 0; i < (size_t)W * H * 4; ++i) rgba.data[i] = (float)(i % 97) / 31.0f;
    for (size_t i = 0; i < (size_t)W * H * 3; ++i) alb.data[i] = (float)(i % 89) / 88.0f;
    MfExrChannel ch[7];
    const char *n[7] = {"R", "G", "B", "A", "albedo.R", "albedo.G", "albedo.B"};
    for (int k = 0; k < 4; ++k) ch[k] = (MfExrChannel){n[k], rgba.data + k, 4};
    for (int k = 0; k < 3; ++k) ch[4 + k] = (MfExrChannel){n[4 + k], alb.data + k, 3};
    const char *p = mf_test_path("layers.exr");
    CHECK_OK(mf_exr_write(p, W, H, ch, 7, MF_EXR_FLOAT));
    /* Our layer reader. */
    CHECK_OK(mf_exr_read_layer(p, "albedo", "RGB", &got));
    CHECK(got.c == 3 && got.w == W && got.h == H);
    for (size_t i = 0; got.data && i < (size_t)W * H * 3; ++i) CHECK(got.data[i] == alb.data[i]);
    mf_image_free(&got);
    CHECK_OK(mf_exr_read_layer(p, "", "RGBA", &got));
    for (size_t i = 0; got.data && i < (size_t)W * H * 4; ++i) CHECK(got.data[i] == rgba.data[i]);
    mf_image_free(&got);
    CHECK_ERR(mf_exr_read_layer(p, "orm", "RGB", &got), "no channel 'orm.R'");
    /* OpenImageIO reads the default layer as R, G, B, A. */
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &got));
    CHECK(got.w == W && got.h == H && got.c >= 4);
    if (got.data && got.c >= 4)
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                for (int k = 0; k < 4; ++k) CHECK(mf_image_px(&got, x, y)[k] == mf_image_px(&rgba, x, y)[k]);
    mf_image_free(&got);
    /* mf_exr_write_image + OIIO, half. */
    CHECK_OK(mf_exr_write_image(mf_test_path("img.exr"), &rgba, "", MF_EXR_HALF));
    CHECK_OK(mf_image_read(mf_test_path("img.exr"), MF_ENC_LINEAR, &got));
    CHECK(got.c == 4);
    for (size_t i = 0; got.data && got.c == 4 && i < (size_t)W * H * 4; ++i) CHECK_NEAR(got.data[i], rgba.data[i], 4.0f / 2048.0f);
    mf_image_free(&got);
    /* And we read what OpenImageIO writes. */
    CHECK_OK(mf_image_write(mf_test_path("oiio.exr"), &rgba, MF_ENC_LINEAR, 32));
    CHECK_OK(mf_exr_read_layer(mf_test_path("oiio.exr"), "", "RGBA", &got));
    for (size_t i = 0; got.data && i < (size_t)W * H * 4; ++i) CHECK(got.data[i] == rgba.data[i]);
    mf_image_free(&got);
    mf_image_free(&rgba);
    mf_image_free(&alb);
}

MF_TEST(io_exr_bad_input) {
    float plane[W * H];
    for (int i = 0; i < W * H; ++i) plane[i] = 0.5f;
    MfExrChannel ch[2] = {{"R", plane, 0}, {"depth.Z", plane, 0}};
    MfExrImage im = {0};
    /* Writers refuse non-finite values and half overflow unless asked. */
    plane[5 * W + 3] = NAN;
    CHECK_ERR(mf_exr_write(mf_test_path("nan.exr"), W, H, ch, 2, MF_EXR_FLOAT), "pixel (3, 5)");
    CHECK(!mf_file_exists(mf_test_path("nan.exr")));
    CHECK_OK(mf_exr_write(mf_test_path("nan.exr"), W, H, ch, 2, MF_EXR_FLOAT | MF_EXR_ALLOW_NONFINITE));
    CHECK_ERR(mf_exr_read(mf_test_path("nan.exr"), &im), "nan.exr: channel 'R' pixel (3, 5) is not finite");
    CHECK(im.data == NULL);
    plane[5 * W + 3] = 1e6f;
    CHECK_ERR(mf_exr_write(mf_test_path("big.exr"), W, H, ch, 2, MF_EXR_HALF), "half range");
    CHECK_OK(mf_exr_write(mf_test_path("big.exr"), W, H, ch, 2, MF_EXR_FLOAT));
    plane[5 * W + 3] = 0.5f;
    MfExrChannel dup[2] = {{"R", plane, 0}, {"R", plane, 0}};
    CHECK_ERR(mf_exr_write(mf_test_path("dup.exr"), W, H, dup, 2, 0), "given twice");
    /* Missing, garbage and truncated files. */
    CHECK_ERR(mf_exr_read(mf_test_path("none.exr"), &im), "none.exr");
    CHECK_OK(mf_write_file(mf_test_path("garbage.exr"), "hello, this is not an EXR file at all", 37));
    CHECK_ERR(mf_exr_read(mf_test_path("garbage.exr"), &im), "garbage.exr");
    /* Noise so the compressed pixels are large, then cut the file in the pixel data. */
    for (int i = 0; i < W * H; ++i) plane[i] = (float)((i * 2654435761u) % 1000003u) / 1000.0f;
    const char *full = mf_test_path("full.exr");
    CHECK_OK(mf_exr_write(full, W, H, ch, 2, MF_EXR_FLOAT));
    char *buf = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(full, &buf, &len));
    CHECK(len > 2000);
    if (buf && len > 2000) {
        CHECK_OK(mf_write_file(mf_test_path("trunc.exr"), buf, len - 1500));
        CHECK_ERR(mf_exr_read(mf_test_path("trunc.exr"), &im), "trunc.exr");
        CHECK(im.data == NULL);
    }
    free(buf);
}

/* A tiled file with an offset data window, written directly through the OpenEXR C API (our
 * writer only makes scanline files): the reader's tile path must put every pixel in place. */
#include <openexr.h>

static int write_tiled(const char *path, const float *plane, int w, int h, int ox, int oy, int tw, int th) {
    exr_context_initializer_t ci = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t f = NULL;
    int part = 0;
    exr_result_t rv = exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &ci);
    if (rv) return rv;
    exr_attr_box2i_t dw;
    exr_attr_v2f_t swc;
    memset(&swc, 0, sizeof swc);
    dw.min.x = ox;
    dw.min.y = oy;
    dw.max.x = ox + w - 1;
    dw.max.y = oy + h - 1;
    rv = exr_add_part(f, "tiled", EXR_STORAGE_TILED, &part);
    if (!rv) rv = exr_initialize_required_attr(f, part, &dw, &dw, 1.0f, &swc, 1.0f, EXR_LINEORDER_INCREASING_Y, EXR_COMPRESSION_ZIP);
    if (!rv) rv = exr_set_tile_descriptor(f, part, (uint32_t)tw, (uint32_t)th, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN);
    if (!rv) rv = exr_add_channel(f, part, "Y", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    if (!rv) rv = exr_write_header(f);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int started = 0;
    for (int ty = 0; !rv && ty * th < h; ++ty)
        for (int tx = 0; !rv && tx * tw < w; ++tx) {
            exr_chunk_info_t c;
            rv = exr_write_tile_chunk_info(f, part, tx, ty, 0, 0, &c);
            if (!rv) rv = started ? exr_encoding_update(f, part, &c, &enc) : exr_encoding_initialize(f, part, &c, &enc);
            if (rv) break;
            enc.channels[0].encode_from_ptr = (const uint8_t *)(plane + (size_t)ty * th * w + (size_t)tx * tw);
            enc.channels[0].user_pixel_stride = 4;
            enc.channels[0].user_line_stride = 4 * w;
            enc.channels[0].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[0].user_bytes_per_element = 4;
            if (!started) rv = exr_encoding_choose_default_routines(f, part, &enc);
            started = 1;
            if (!rv) rv = exr_encoding_run(f, part, &enc);
        }
    if (started) exr_encoding_destroy(f, &enc);
    exr_result_t r2 = exr_finish(&f);
    return rv ? rv : r2;
}

MF_TEST(io_exr_read_tiled) {
    float plane[W * H];
    for (int i = 0; i < W * H; ++i) plane[i] = (float)i * 0.25f;
    const char *p = mf_test_path("tiled.exr");
    CHECK(write_tiled(p, plane, W, H, 5, -3, 16, 8) == 0);
    MfExrImage im = {0};
    CHECK_OK(mf_exr_read(p, &im));
    CHECK(im.w == W && im.h == H && im.n == 1);
    const float *y = im.data ? mf_exr_channel(&im, "Y") : NULL;
    CHECK(y != NULL);
    int bad = 0;
    for (int i = 0; y && i < W * H; ++i) bad += y[i] != plane[i];
    CHECK_MSG(bad == 0, "%d of %d tiled pixels misplaced", bad, W * H);
    mf_exr_free(&im);
}
