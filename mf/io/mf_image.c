#include "io/mf_image.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_math.h"
#include "io/mf_exr.h"
#include "io/mf_image_oiio.h"

int mf_image_alloc(MfImage *img, int w, int h, int c) {
    if (w <= 0 || h <= 0 || c <= 0 || c > 64) return mf_fail(MF_EARG, "image size %dx%dx%d is invalid", w, h, c);
    float *d = calloc((size_t)w * h * c, sizeof(float));
    if (!d) return mf_fail(MF_ENOMEM, "out of memory for a %dx%dx%d image", w, h, c);
    img->w = w;
    img->h = h;
    img->c = c;
    img->data = d;
    return MF_OK;
}

void mf_image_free(MfImage *img) {
    if (!img) return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

float mf_srgb_to_linear(float s) {
    return s <= 0.04045f ? s / 12.92f : powf((s + 0.055f) / 1.055f, 2.4f);
}

float mf_linear_to_srgb(float l) {
    if (!(l > 0.0f)) return 0.0f * l; /* keeps NaN visible, maps negatives and -0 to 0 */
    return l <= 0.0031308f ? l * 12.92f : 1.055f * powf(l, 1.0f / 2.4f) - 0.055f;
}

static int is_alpha(int ch, int c, int alpha_channel) {
    if (alpha_channel >= 0) return ch == alpha_channel;
    return (c == 4 && ch == 3) || (c == 2 && ch == 1);
}

unsigned long long mf_image_decode_limit(unsigned long long file_bytes) {
    unsigned long long lim = file_bytes > (~0ull / MF_IMAGE_DECODE_RATIO) ? ~0ull : file_bytes * MF_IMAGE_DECODE_RATIO;
    return lim < MF_IMAGE_DECODE_FLOOR ? MF_IMAGE_DECODE_FLOOR : lim;
}

int mf_image_check_decode(const char *path, long long w, long long h, long long c, unsigned long long file_bytes) {
    if (w <= 0 || h <= 0 || c <= 0 || w > (1ll << 30) || h > (1ll << 30) || c > 4096)
        return mf_fail(MF_EFORMAT, "%s: bad image size %lldx%lld x %lld channels in the header", path, w, h, c);
    unsigned long long px = (unsigned long long)w * (unsigned long long)h, bytes = px * (unsigned long long)c * 4ull;
    unsigned long long lim = mf_image_decode_limit(file_bytes);
    if (px > MF_IMAGE_MAX_PIXELS || bytes > lim)
        return mf_fail(MF_EFORMAT,
                       "%s: header asks for %lldx%lld x %lld channels (%llu bytes decoded) but the file has %llu bytes "
                       "(limit %llu bytes, %llu pixels): corrupt or hostile header",
                       path, w, h, c, bytes, file_bytes, lim, MF_IMAGE_MAX_PIXELS);
    return MF_OK;
}

/* The checks and conversions after a decode (mf_oiio_read*: rc, err, the pixels). */
static int finish_read(const char *path, int rc, const char *err, unsigned long long fsize, int w, int h, int c, int is_int,
                       int ach, float *data, MfEncoding enc, MfImage *out) {
    if (rc == -2) return mf_fail(MF_EFORMAT, "%s: %s (file of %llu bytes)", path, err, fsize);
    if (rc != 0) return mf_fail(MF_EFORMAT, "%s: cannot read image: %s", path, err);
    size_t npx = (size_t)w * h;
    for (size_t i = 0; i < npx * (size_t)c; ++i)
        if (!isfinite(data[i])) {
            size_t px = i / (size_t)c;
            free(data);
            return mf_fail(MF_ENAN, "%s: pixel (%zu, %zu) channel %zu is NaN or Inf", path, px % (size_t)w,
                           px / (size_t)w, i % (size_t)c);
        }
    if (is_int && enc == MF_ENC_SRGB)
        for (size_t i = 0; i < npx; ++i)
            for (int ch = 0; ch < c; ++ch)
                if (!is_alpha(ch, c, ach)) data[i * c + ch] = mf_srgb_to_linear(data[i * c + ch]);
    out->w = w;
    out->h = h;
    out->c = c;
    out->data = data;
    return MF_OK;
}

/* 1 when the bytes start with the OpenEXR magic number (whatever the file's name says). */
static int is_exr_magic(const unsigned char *b, size_t n) { return n >= 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01; }

/* Bytes [off, off + n) of a file (ctx: FILE *) or of a buffer (ctx: MemSrc *); 0 when they are all there. */
typedef struct {
    const unsigned char *b;
    size_t len;
} MemSrc;
static int read_file_at(void *ctx, unsigned long long off, unsigned char *out, size_t n) {
    FILE *f = ctx;
    return off > (unsigned long long)LONG_MAX || fseek(f, (long)off, SEEK_SET) || fread(out, 1, n, f) != n;
}
static int read_mem_at(void *ctx, unsigned long long off, unsigned char *out, size_t n) {
    const MemSrc *m = ctx;
    if (off > m->len || n > m->len - off) return 1;
    memcpy(out, m->b + off, n);
    return 0;
}

static const unsigned char k_png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

/* A PNG's chunks (length, type, data, CRC) must lie inside its len bytes, from IHDR up to IEND:
 * a truncated PNG is refused here by name, before libpng (through OpenImageIO) reads past the end
 * of it. That path also leaks: OpenImageIO 2.4's read callback longjmps (png_error) over the
 * std::string of its own message. Only the chunk framing is checked; CRCs and contents are
 * libpng's. */
static int png_check_chunks(const char *name, unsigned long long len, int (*rd)(void *, unsigned long long, unsigned char *, size_t),
                            void *ctx) {
    unsigned long long off = 8, idat = 0, raw = 0;
    for (int k = 0;; ++k) {
        unsigned char h[8];
        if (rd(ctx, off, h, 8))
            return mf_fail(MF_EFORMAT, "%s: truncated PNG: the file ends at byte %llu, inside or before chunk %d's header%s", name, len, k,
                           k ? " (no IEND chunk)" : "");
        unsigned long long n = (unsigned long long)h[0] << 24 | (unsigned long long)h[1] << 16 | (unsigned long long)h[2] << 8 | h[3];
        char type[5] = {(char)h[4], (char)h[5], (char)h[6], (char)h[7], 0};
        for (int i = 0; i < 4; ++i)
            if (!((type[i] >= 'A' && type[i] <= 'Z') || (type[i] >= 'a' && type[i] <= 'z')))
                return mf_fail(MF_EFORMAT, "%s: corrupt PNG: chunk %d at byte %llu has no valid type", name, k, off);
        if (k == 0 && strcmp(type, "IHDR")) return mf_fail(MF_EFORMAT, "%s: corrupt PNG: the first chunk is %s, not IHDR", name, type);
        if (n > 0x7fffffffull || off + 12 + n > len)
            return mf_fail(MF_EFORMAT, "%s: truncated PNG: chunk %s at byte %llu declares %llu data bytes, past the end of the file (%llu bytes)",
                           name, type, off, n, len);
        if (k == 0) { /* IHDR: width, height, bit depth, colour type -> the filtered rows' bytes (not interlaced: a lower bound) */
            unsigned char d[13];
            if (n != 13 || rd(ctx, off + 8, d, 13)) return mf_fail(MF_EFORMAT, "%s: corrupt PNG: IHDR is not 13 bytes", name);
            unsigned long long w = (unsigned long long)d[0] << 24 | d[1] << 16 | d[2] << 8 | d[3];
            unsigned long long h = (unsigned long long)d[4] << 24 | d[5] << 16 | d[6] << 8 | d[7];
            static const int chans[7] = {1, 0, 3, 1, 2, 0, 4}; /* by colour type; 0: invalid */
            int ch = d[9] < 7 ? chans[d[9]] : 0;
            if (!w || !h || w > 0x7fffffffull || h > 0x7fffffffull || !ch || !d[8] || d[8] > 16)
                return mf_fail(MF_EFORMAT, "%s: corrupt PNG: IHDR %llux%llu, bit depth %d, colour type %d", name, w, h, d[8], d[9]);
            raw = h * (1 + (w * (unsigned long long)ch * d[8] + 7) / 8);
        }
        if (!strcmp(type, "IDAT")) idat += n;
        off += 12 + n;
        /* deflate expands at most 1032:1, so rows that need more than 1032 bytes per IDAT byte
         * cannot all be there: refused before a decoder allocates them */
        if (!strcmp(type, "IEND") && raw > 1032 * idat + 1032)
            return mf_fail(MF_EFORMAT, "%s: corrupt PNG: its IDAT chunks hold %llu bytes, too few for the %llu bytes of rows its IHDR declares "
                                       "(deflate expands at most 1032:1)",
                           name, idat, raw);
        if (!strcmp(type, "IEND")) return MF_OK;
    }
}

/* 1 when the bytes start with the PNG signature. */
static int is_png_sig(const unsigned char *b, size_t n) { return n >= 8 && !memcmp(b, k_png_sig, 8); }

int mf_image_read(const char *path, MfEncoding enc, MfImage *out) {
    int w = 0, h = 0, c = 0, is_int = 0, ach = -1;
    float *data = NULL;
    char err[512] = "";
    unsigned long long fsize = 0;
    int rc = mf_input_file(path, &fsize);
    if (rc) return rc;
    /* header checks by the file's first bytes, read once: an EXR's sizes, a PNG's chunk framing */
    FILE *f = fopen(path, "rb");
    unsigned char head[8];
    size_t nh = f ? fread(head, 1, sizeof head, f) : 0;
    if (is_exr_magic(head, nh)) rc = mf_exr_check_header(path, fsize);
    else if (is_png_sig(head, nh)) rc = png_check_chunks(path, fsize, read_file_at, f);
    if (f) fclose(f);
    if (rc) return rc;
    rc = mf_oiio_read(path, mf_image_decode_limit(fsize), &w, &h, &c, &is_int, &ach, &data, err, sizeof err);
    return finish_read(path, rc, err, fsize, w, h, c, is_int, ach, data, enc, out);
}

int mf_image_decode(const char *name, const void *bytes, size_t len, const char *ext, MfEncoding enc, MfImage *out) {
    int w = 0, h = 0, c = 0, is_int = 0, ach = -1;
    float *data = NULL;
    char err[512] = "";
    if (!bytes || !len) return mf_fail(MF_EFORMAT, "%s: empty image", name);
    MemSrc m = {bytes, len};
    if (is_png_sig(bytes, len)) {
        int prc = png_check_chunks(name, len, read_mem_at, &m);
        if (prc) return prc;
    }
    int rc = mf_oiio_read_mem(bytes, len, ext, mf_image_decode_limit(len), &w, &h, &c, &is_int, &ach, &data, err, sizeof err);
    return finish_read(name, rc, err, len, w, h, c, is_int, ach, data, enc, out);
}

int mf_image_write(const char *path, const MfImage *img, MfEncoding enc, int bits) {
    char ext[16], tmp[MF_PATH_MAX], err[512];
    if (!img || !img->data) return mf_fail(MF_EARG, "%s: no image to write", path);
    mf_path_ext(path, ext, sizeof ext);
    int is_float = !strcmp(ext, "exr") || !strcmp(ext, "hdr");
    if (!is_float && strcmp(ext, "png") && strcmp(ext, "jpg") && strcmp(ext, "jpeg") && strcmp(ext, "tif") &&
        strcmp(ext, "tiff"))
        return mf_fail(MF_EARG, "%s: unsupported image extension '%s'", path, ext);
    size_t n = (size_t)img->w * img->h * img->c;
    const float *src = img->data;
    float *conv = NULL;
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(src[i])) return mf_fail(MF_ENAN, "%s: refusing to write NaN/Inf pixel values", path);
    if (!is_float) {
        conv = malloc(n * sizeof(float));
        if (!conv) return mf_fail(MF_ENOMEM, "%s: out of memory", path);
        for (size_t i = 0; i < n; ++i) {
            int ch = (int)(i % (size_t)img->c);
            float v = src[i];
            if (enc == MF_ENC_SRGB && !is_alpha(ch, img->c, -1)) v = mf_linear_to_srgb(v);
            conv[i] = mf_clampf(v, 0.0f, 1.0f);
        }
        src = conv;
    }
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc == MF_OK && mf_oiio_write(tmp, img->w, img->h, img->c, src, bits, err, sizeof err) != 0) {
        mf_discard_file(tmp);
        rc = mf_fail(MF_EIO, "%s: cannot write image: %s", path, err);
    }
    free(conv);
    if (rc) return rc;
    return mf_commit_file(tmp, path);
}
