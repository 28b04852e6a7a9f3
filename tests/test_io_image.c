/* Tests of mf/io/mf_image: sRGB curve, PNG/EXR/HDR round trips, bad files. Hostile inputs (issue
 * 15): an EXR or PNG header asking for more pixels than the file can hold is refused before
 * allocating (also by mf_exr_read); the same image written twice gives the same EXR bytes. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_exr.h"
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
    CHECK_ERR(mf_image_read(p, MF_ENC_SRGB, &b), "trunc.png: truncated PNG: chunk IDAT at byte");
    CHECK(b.data == NULL);
    /* the same bytes from memory (an image inside a glTF file), and only the signature */
    char *d = NULL;
    size_t dl = 0;
    CHECK_OK(mf_read_file(p, &d, &dl));
    if (d) CHECK_ERR(mf_image_decode("mem.glb[image 0]", d, dl, "png", MF_ENC_SRGB, &b), "mem.glb[image 0]: truncated PNG");
    if (d) CHECK_ERR(mf_image_decode("sig.png", d, 8, "png", MF_ENC_SRGB, &b), "sig.png: truncated PNG: the file ends at byte 8");
    free(d);
    /* a whole PNG whose IHDR says 64 x 6291506 rows (24 MB of RGB): its few KB of IDAT cannot
     * hold them (deflate expands at most 1032:1), refused before any decoder allocates */
    const char *tall = mf_test_path("tall.png");
    CHECK_OK(mf_image_write(tall, &a, MF_ENC_SRGB, 8));
    CHECK_OK(mf_read_file(tall, &d, &dl));
    if (d && dl > 24) {
        const unsigned char hh[4] = {0x00, 0x60, 0x00, 0x32}; /* 6291506, big-endian, IHDR bytes 20..23 */
        memcpy(d + 20, hh, 4);
        CHECK_OK(mf_write_file(tall, d, dl));
        CHECK_ERR(mf_image_read(tall, MF_ENC_SRGB, &b), "tall.png: corrupt PNG: its IDAT chunks hold");
    }
    free(d);
    CHECK(b.data == NULL);
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

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

/* CRC-32 as PNG chunks use it (ISO 3309, reflected 0xEDB88320). */
static uint32_t crc32_png(const unsigned char *p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
}

/* Reads path, finds the EXR header attribute `name` of type box2i and sets its max corner. */
static int patch_exr_box(char *buf, size_t len, const char *name, int32_t xmax, int32_t ymax) {
    char key[64];
    size_t kl = (size_t)snprintf(key, sizeof key, "%s", name) + 1; /* with the NUL */
    char *a = memmem(buf, len, key, kl);
    if (!a || (size_t)(a - buf) + kl + 6 + 4 + 16 > len || memcmp(a + kl, "box2i", 6)) return 0;
    char *v = a + kl + 6 + 4; /* name\0 type\0 size(4) value: xmin ymin xmax ymax */
    memcpy(v + 8, &xmax, 4);
    memcpy(v + 12, &ymax, 4);
    return 1;
}

/* A zero image w x h x c written to path as a 32-bit float EXR, its bytes into *d (owned), *len. */
static int small_exr_bytes(const char *path, int w, int h, int c, char **d, size_t *len) {
    MfImage im = {0};
    int rc = mf_image_alloc(&im, w, h, c);
    if (!rc) rc = mf_image_write(path, &im, MF_ENC_LINEAR, 32);
    mf_image_free(&im);
    return rc ? rc : mf_read_file(path, d, len);
}

/* Item 2: an EXR of a few KB whose data window asks for gigabytes was allocated before anything
 * was checked; now the header's size is checked against the file's length first. */
MF_TEST(hostile_exr_header_size) {
    const char *good = mf_test_path("hostile_small.exr"), *bad = mf_test_path("hostile_huge_window.exr");
    MfImage im = {0};
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(small_exr_bytes(good, 16, 16, 2, &d, &len));
    if (!d) return;
    CHECK(len < 16384);
    /* 30000 x 30000 x 2 channels of float: 7.2 GB */
    CHECK(patch_exr_box(d, len, "dataWindow", 29999, 29999));
    CHECK(patch_exr_box(d, len, "displayWindow", 29999, 29999));
    CHECK_OK(mf_write_file(bad, d, len));
    free(d);
    /* OpenImageIO's EXR reader itself stops at the missing chunk table; ours must not allocate first */
    CHECK_ERR(mf_image_read(bad, MF_ENC_LINEAR, &im), "hostile_huge_window.exr");
    CHECK(im.data == NULL);
    MfExrImage ex = {0};
    CHECK_ERR(mf_exr_read(bad, &ex), "hostile_huge_window.exr: header asks for 30000x30000 x 2 channels (7200000000 bytes");
    CHECK(ex.data == NULL);
    /* within the decode limit (2000 x 2000 x 2 floats: 32 MB) but not within what a ZIP file of a
     * few hundred bytes can hold (deflate: at most 1032:1): refused from the header */
    const char *mid = mf_test_path("hostile_mid_window.exr");
    CHECK_OK(small_exr_bytes(good, 16, 16, 2, &d, &len));
    if (d) {
        CHECK(patch_exr_box(d, len, "dataWindow", 1999, 1999));
        CHECK(patch_exr_box(d, len, "displayWindow", 1999, 1999));
        CHECK_OK(mf_write_file(mid, d, len));
        free(d);
        CHECK_ERR(mf_image_read(mid, MF_ENC_LINEAR, &im), "hostile_mid_window.exr: part 0 declares 2000x2000 pixels, 32000000 bytes of samples");
        CHECK(im.data == NULL);
    }
    /* a PNG whose IHDR (CRC fixed) says 30000 x 30000 RGBA: the OpenImageIO path allocated 14.4 GB
     * of floats from the header before decoding a row */
    const char *png = mf_test_path("hostile_small.png"), *bpng = mf_test_path("hostile_huge_ihdr.png");
    CHECK_OK(mf_image_alloc(&im, 16, 16, 4));
    CHECK_OK(mf_image_write(png, &im, MF_ENC_SRGB, 8));
    mf_image_free(&im);
    CHECK_OK(mf_read_file(png, &d, &len));
    if (d && len > 33 && !memcmp(d + 12, "IHDR", 4)) {
        unsigned char *u = (unsigned char *)d;
        u[16] = 0, u[17] = 0, u[18] = 0x75, u[19] = 0x30; /* width 30000, big-endian */
        u[20] = 0, u[21] = 0, u[22] = 0x75, u[23] = 0x30;
        uint32_t crc = crc32_png(u + 12, 17);
        u[29] = (unsigned char)(crc >> 24), u[30] = (unsigned char)(crc >> 16), u[31] = (unsigned char)(crc >> 8), u[32] = (unsigned char)crc;
        CHECK_OK(mf_write_file(bpng, d, len));
        /* refused by the IDAT bound (deflate's 1032:1) before the decode limit is reached */
        CHECK_ERR(mf_image_read(bpng, MF_ENC_SRGB, &im), "hostile_huge_ihdr.png: corrupt PNG: its IDAT chunks hold");
        CHECK(im.data == NULL);
    } else {
        CHECK_MSG(0, "%s: not a PNG with IHDR first", png);
    }
    free(d);
    /* the limit itself: floor for small files, proportional above */
    CHECK(mf_image_decode_limit(100) == MF_IMAGE_DECODE_FLOOR);
    CHECK(mf_image_decode_limit(1ull << 20) == (1ull << 20) * MF_IMAGE_DECODE_RATIO);
    CHECK_OK(mf_image_check_decode("x.png", 4096, 4096, 4, 300000)); /* 256 MiB from 300 KB: ratio 895 */
    CHECK_ERR(mf_image_check_decode("x.png", 4096, 4096, 4, 3000), "x.png: header asks for 4096x4096 x 4 channels");
}

/* Item 3: env.exr (and every EXR written through mf_image_write) carried the time of writing in
 * its header (OpenImageIO's capDate), so identical runs differed byte-wise. */
MF_TEST(hostile_exr_bytes_reproducible) {
    const char *a = mf_test_path("hostile_repro_a.exr"), *b = mf_test_path("hostile_repro_b.exr");
    MfImage im = {0};
    CHECK_OK(mf_image_alloc(&im, 8, 4, 3));
    for (int i = 0; i < 8 * 4 * 3; ++i) im.data[i] = 0.25f * (float)i;
    CHECK_OK(mf_image_write(a, &im, MF_ENC_LINEAR, 32));
    /* a second later: a time stamp would differ */
    struct timespec ts = {1, 100000000};
    nanosleep(&ts, NULL);
    CHECK_OK(mf_image_write(b, &im, MF_ENC_LINEAR, 32));
    mf_image_free(&im);
    char *da = NULL, *db = NULL;
    size_t la = 0, lb = 0;
    CHECK_OK(mf_read_file(a, &da, &la));
    CHECK_OK(mf_read_file(b, &db, &lb));
    if (da && db) {
        CHECK_MSG(la == lb && !memcmp(da, db, la), "the same image written twice gave different bytes (%zu vs %zu)", la, lb);
        char today[32];
        time_t now = time(NULL);
        strftime(today, sizeof today, "%Y:%m:%d", gmtime(&now));
        CHECK_MSG(!memmem(da, la, today, strlen(today)), "the EXR header holds today's date %s", today);
        strftime(today, sizeof today, "%Y:%m:%d", localtime(&now));
        CHECK_MSG(!memmem(da, la, today, strlen(today)), "the EXR header holds today's date %s", today);
    }
    free(da), free(db);
}

/* An EXR header attribute of unknown type whose size field says 1.5 GB, in a file of a few hundred
 * bytes: OpenImageIO's reader (OpenEXR's C++ library) allocated the declared size before it found
 * the end of the file (seconds per file under ASan: the fuzz harness's slowest inputs). mf_image_read
 * now parses the header with the C API first, which reads no further than the file goes. */
MF_TEST(hostile_exr_attribute_size) {
    const char *good = mf_test_path("hostile_attr_ok.exr"), *bad = mf_test_path("hostile_attr_big.exr");
    MfImage im = {0};
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(small_exr_bytes(good, 4, 4, 3, &d, &len));
    if (!d) return;
    /* walk the attributes (name\0 type\0 size value) to the NUL that ends the header */
    size_t at = 8;
    while (at < len && d[at]) {
        size_t nl = strnlen(d + at, len - at) + 1, tl = nl < len - at ? strnlen(d + at + nl, len - at - nl) + 1 : 0;
        int32_t sz = 0;
        if (!tl || at + nl + tl + 4 > len) break;
        memcpy(&sz, d + at + nl + tl, 4);
        at += nl + tl + 4 + (size_t)sz;
    }
    CHECK(at < len && d[at] == 0);
    static const char attr[] = "junk\0mystery\0\0\0\0\0abcd"; /* size patched below */
    size_t alen = sizeof attr - 1;
    char *b = malloc(len + alen);
    if (b && at < len) {
        memcpy(b, d, at);
        memcpy(b + at, attr, alen);
        int32_t big = 1500000000;
        memcpy(b + at + 13, &big, 4);
        memcpy(b + at + alen, d + at, len - at);
        CHECK_OK(mf_write_file(bad, b, len + alen));
        CHECK_ERR(mf_image_read(bad, MF_ENC_LINEAR, &im), "hostile_attr_big.exr: not a readable EXR");
        CHECK(im.data == NULL);
        CHECK_OK(mf_image_read(good, MF_ENC_LINEAR, &im)); /* the pre-check passes a sound file */
        mf_image_free(&im);
    }
    free(b);
    free(d);
}

/* An EXR whose channels mix float and half (RGB float, A half) reads with the same values through
 * mf_image_read (the per-channel native path of mf_image_oiio.cpp; k/16 values are exact in half). */
MF_TEST(image_exr_mixed_channel_types) {
    MfImage a = {0}, b = {0};
    CHECK_OK(mf_image_alloc(&a, 13, 7, 4));
    fill(&a);
    const char *n[4] = {"R", "G", "B", "A"};
    MfExrChannel ch[4];
    for (int k = 0; k < 4; ++k) ch[k] = (MfExrChannel){n[k], a.data + k, 4};
    const char *p = mf_test_path("mixed_types.exr");
    CHECK_OK(mf_exr_write(p, a.w, a.h, ch, 4, MF_EXR_HALF_LAST));
    CHECK_OK(mf_image_read(p, MF_ENC_LINEAR, &b));
    CHECK(b.w == a.w && b.h == a.h && b.c == 4);
    if (b.data && b.w == a.w && b.h == a.h && b.c == 4)
        for (size_t i = 0; i < (size_t)a.w * a.h * 4; ++i)
            if (a.data[i] != b.data[i]) {
                CHECK_MSG(0, "%s: value %zu (channel %zu) is %g, wrote %g", p, i, i % 4, b.data[i], a.data[i]);
                break;
            }
    mf_image_free(&a);
    mf_image_free(&b);
}

/* The reader follows the file's signature: PNG bytes named .jpg read as PNG; bytes with no known
 * signature named .png are refused as "not a PNG file" at once (OpenImageIO is not asked to try
 * every reader it has). */
MF_TEST(image_signature_picks_reader) {
    MfImage a = {0}, b = {0};
    CHECK_OK(mf_image_alloc(&a, 5, 3, 4));
    fill(&a);
    const char *png = mf_test_path("sig/a.png"), *jpg = mf_test_path("sig/a_really_png.jpg"), *junk = mf_test_path("sig/junk.png");
    CHECK_OK(mf_mkdirs_for(png));
    CHECK_OK(mf_image_write(png, &a, MF_ENC_LINEAR, 16));
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(png, &d, &len));
    CHECK_OK(mf_write_file(jpg, d, len));
    free(d);
    CHECK_OK(mf_image_read(jpg, MF_ENC_LINEAR, &b));
    CHECK(b.w == 5 && b.h == 3 && b.c == 4);
    mf_image_free(&b);
    CHECK_OK(mf_write_file(junk, "GIF89a but not really an image at all", 38));
    CHECK_ERR(mf_image_read(junk, MF_ENC_LINEAR, &b), "not a PNG file");
    CHECK(b.data == NULL);
    mf_image_free(&a);
}
