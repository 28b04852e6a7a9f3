#include "io/mf_exr.h"

#include <math.h>
#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "io/mf_image.h"

/* OpenEXR reports details through a per-context callback (the default one prints to stderr);
 * we keep the last message of this thread and put it into our own error instead. */
static _Thread_local char g_exr_msg[512];

static void exr_err_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
    (void)ctxt;
    snprintf(g_exr_msg, sizeof g_exr_msg, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

static int exr_fail(int code, const char *path, const char *what, exr_result_t rv) {
    if (g_exr_msg[0]) return mf_fail(code, "%s: %s: %s", path, what, g_exr_msg);
    return mf_fail(code, "%s: %s: %s", path, what, exr_get_default_error_message(rv));
}

static exr_context_initializer_t exr_init(void) {
    exr_context_initializer_t ci = EXR_DEFAULT_CONTEXT_INITIALIZER;
    ci.error_handler_fn = exr_err_cb;
    return ci;
}

static const float HALF_MAX = 65504.0f;

int mf_exr_write(const char *path, int w, int h, const MfExrChannel *ch, int n, int flags) {
    if (w <= 0 || h <= 0 || n <= 0 || !ch) return mf_fail(MF_EARG, "%s: cannot write a %dx%d EXR with %d channels", path, w, h, n);
    int half = (flags & MF_EXR_HALF) != 0;
    for (int i = 0; i < n; ++i) {
        if (!ch[i].name || !ch[i].name[0] || strlen(ch[i].name) > 255 || !ch[i].data)
            return mf_fail(MF_EARG, "%s: channel %d has no name or no data", path, i);
        for (int j = 0; j < i; ++j)
            if (strcmp(ch[i].name, ch[j].name) == 0) return mf_fail(MF_EARG, "%s: channel '%s' given twice", path, ch[i].name);
        if (flags & MF_EXR_ALLOW_NONFINITE) continue;
        size_t st = ch[i].stride > 0 ? (size_t)ch[i].stride : 1;
        for (size_t p = 0; p < (size_t)w * h; ++p) {
            float v = ch[i].data[p * st];
            if (!isfinite(v) || ((half || (i == n - 1 && (flags & MF_EXR_HALF_LAST))) && fabsf(v) > HALF_MAX))
                return mf_fail(MF_ENAN, "%s: channel '%s' pixel (%zu, %zu) = %g is %s", path, ch[i].name, p % (size_t)w,
                               p / (size_t)w, (double)v, isfinite(v) ? "beyond the half range (write float)" : "not finite");
        }
    }
    char tmp[MF_PATH_MAX];
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc) return rc;

    g_exr_msg[0] = '\0';
    exr_context_initializer_t ci = exr_init();
    exr_context_t f = NULL;
    exr_result_t rv = exr_start_write(&f, tmp, EXR_WRITE_FILE_DIRECTLY, &ci);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(MF_EIO, path, "cannot create", rv);
    int part = 0;
    rv = exr_add_part(f, "main", EXR_STORAGE_SCANLINE, &part);
    if (!rv) rv = exr_initialize_required_attr_simple(f, part, w, h, EXR_COMPRESSION_ZIP);
    for (int i = 0; i < n && !rv; ++i)
        rv = exr_add_channel(f, part, ch[i].name, half || (i == n - 1 && (flags & MF_EXR_HALF_LAST)) ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (!rv) rv = exr_write_header(f);
    int32_t spc = 1;
    if (!rv) rv = exr_get_scanlines_per_chunk(f, part, &spc);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int started = 0;
    for (int y = 0; y < h && !rv; y += spc) {
        exr_chunk_info_t ci2;
        rv = exr_write_scanline_chunk_info(f, part, y, &ci2);
        if (rv) break;
        rv = started ? exr_encoding_update(f, part, &ci2, &enc) : exr_encoding_initialize(f, part, &ci2, &enc);
        if (rv) break;
        for (int c = 0; c < enc.channel_count; ++c) {
            exr_coding_channel_info_t *cc = &enc.channels[c];
            int k = 0;
            while (k < n && strcmp(ch[k].name, cc->channel_name) != 0) ++k;
            if (k == n) { rv = EXR_ERR_INVALID_ARGUMENT; break; }
            int st = ch[k].stride > 0 ? ch[k].stride : 1;
            cc->encode_from_ptr = (const uint8_t *)(ch[k].data + (size_t)ci2.start_y * w * st);
            cc->user_pixel_stride = (int32_t)(st * sizeof(float));
            cc->user_line_stride = (int32_t)((size_t)w * st * sizeof(float));
            cc->user_data_type = EXR_PIXEL_FLOAT;
            cc->user_bytes_per_element = 4;
        }
        if (rv) break;
        if (!started) {
            rv = exr_encoding_choose_default_routines(f, part, &enc);
            if (rv) break;
            started = 1;
        }
        rv = exr_encoding_run(f, part, &enc);
    }
    if (started) exr_encoding_destroy(f, &enc);
    if (rv) {
        int r2 = exr_fail(MF_EEXT, path, "OpenEXR write failed", rv);
        exr_finish(&f);
        mf_discard_file(tmp);
        return r2;
    }
    rv = exr_finish(&f);
    if (rv) {
        mf_discard_file(tmp);
        return exr_fail(MF_EIO, path, "cannot finish writing", rv);
    }
    return mf_commit_file(tmp, path);
}

int mf_exr_write_image(const char *path, const MfImage *img, const char *layer, int flags) {
    if (!img || !img->data || img->c < 1 || img->c > 4) return mf_fail(MF_EARG, "%s: image must have 1..4 channels", path);
    static const char *comp1[] = {"Y"}, *comp4[] = {"R", "G", "B", "A"};
    const char **comp = img->c == 1 ? comp1 : comp4;
    char names[4][300];
    MfExrChannel ch[4];
    for (int k = 0; k < img->c; ++k) {
        if (layer && layer[0]) snprintf(names[k], sizeof names[k], "%.250s.%s", layer, comp[k]);
        else snprintf(names[k], sizeof names[k], "%s", comp[k]);
        ch[k] = (MfExrChannel){names[k], img->data + k, img->c};
    }
    return mf_exr_write(path, img->w, img->h, ch, img->c, flags);
}

void mf_exr_free(MfExrImage *im) {
    if (!im) return;
    if (im->names)
        for (int i = 0; i < im->n; ++i) free(im->names[i]);
    free(im->names);
    free(im->data);
    memset(im, 0, sizeof *im);
}

/* Decodes the chunk described by ci into the planes of r (dw: data window origin). */
static exr_result_t decode_chunk(exr_context_t f, exr_decode_pipeline_t *dec, int *started, const exr_chunk_info_t *ci,
                                 MfExrImage *r, int x0, int y0) {
    exr_result_t rv = *started ? exr_decoding_update(f, 0, ci, dec) : exr_decoding_initialize(f, 0, ci, dec);
    if (rv) return rv;
    if (!*started) *started = 1;
    size_t plane = (size_t)r->w * r->h;
    for (int c = 0; c < dec->channel_count; ++c) {
        exr_coding_channel_info_t *cc = &dec->channels[c];
        int k = 0;
        while (k < r->n && strcmp(r->names[k], cc->channel_name) != 0) ++k;
        if (k == r->n) { cc->decode_to_ptr = NULL; continue; }
        float *dst = r->data + plane * k + (size_t)(ci->start_y - y0) * r->w + (ci->start_x - x0);
        cc->decode_to_ptr = (uint8_t *)dst;
        cc->user_pixel_stride = (int32_t)sizeof(float);
        cc->user_line_stride = (int32_t)(sizeof(float) * (size_t)r->w);
        cc->user_data_type = EXR_PIXEL_FLOAT;
        cc->user_bytes_per_element = 4;
    }
    rv = exr_decoding_choose_default_routines(f, 0, dec);
    if (rv) return rv;
    return exr_decoding_run(f, 0, dec);
}

int mf_exr_check_header(const char *path, unsigned long long file_bytes) {
    g_exr_msg[0] = '\0';
    exr_context_initializer_t ci = exr_init();
    /* strict: an attribute that cannot be read (its size runs past the end) fails the parse
     * instead of being skipped */
    ci.flags |= EXR_CONTEXT_FLAG_STRICT_HEADER;
    exr_context_t f = NULL;
    exr_result_t rv = exr_start_read(&f, path, &ci);
    int nparts = 0, code = MF_OK;
    if (rv || (rv = exr_get_count(f, &nparts))) code = exr_fail(MF_EFORMAT, path, "not a readable EXR", rv);
    for (int p = 0; !code && p < nparts; ++p) {
        exr_attr_box2i_t dw;
        const exr_attr_chlist_t *cl = NULL;
        if ((rv = exr_get_data_window(f, p, &dw)) || (rv = exr_get_channels(f, p, &cl)) || !cl) {
            code = exr_fail(MF_EFORMAT, path, "bad header", rv ? rv : EXR_ERR_MISSING_REQ_ATTR);
            break;
        }
        long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
        code = mf_image_check_decode(path, w, h, cl->num_channels, file_bytes);
        /* The pixels must be in the file: for the compressions with a bounded ratio (none 1,
         * RLE 64, zlib-based 1032:1, PXR24 4/3 of that), the part's samples in the file's own
         * types (a lower bound: subsampled channels counted with floor) cannot exceed the file's
         * bytes times that ratio. PIZ, B44 and DWA are left to the decoder (and the decode limit). */
        exr_compression_t comp = EXR_COMPRESSION_LAST_TYPE;
        exr_storage_t st = EXR_STORAGE_LAST_TYPE;
        unsigned long long ratio = 0;
        if (!code && !exr_get_compression(f, p, &comp) && !exr_get_storage(f, p, &st) &&
            (st == EXR_STORAGE_SCANLINE || st == EXR_STORAGE_TILED))
            ratio = comp == EXR_COMPRESSION_NONE ? 1 : comp == EXR_COMPRESSION_RLE ? 64
                  : (comp == EXR_COMPRESSION_ZIPS || comp == EXR_COMPRESSION_ZIP) ? 1032 : comp == EXR_COMPRESSION_PXR24 ? 1376 : 0;
        unsigned long long samples = 0;
        for (int k = 0; ratio && k < cl->num_channels; ++k) {
            const exr_attr_chlist_entry_t *e = &cl->entries[k];
            long long xs = e->x_sampling > 0 ? e->x_sampling : 1, ys = e->y_sampling > 0 ? e->y_sampling : 1;
            samples += (unsigned long long)(w / xs) * (unsigned long long)(h / ys) * (e->pixel_type == EXR_PIXEL_HALF ? 2u : 4u);
        }
        if (ratio && samples > ratio * file_bytes)
            code = mf_fail(MF_EFORMAT, "%s: part %d declares %lldx%lld pixels, %llu bytes of samples, more than its %llu-byte file can hold "
                                       "with its compression (at most %llu:1): corrupt or hostile header",
                           path, p, w, h, samples, file_bytes, ratio);
    }
    exr_finish(&f);
    return code;
}

int mf_exr_read(const char *path, MfExrImage *out) {
    g_exr_msg[0] = '\0';
    unsigned long long fsize = 0;
    int frc = mf_input_file(path, &fsize);
    if (frc) return frc;
    exr_context_initializer_t ci = exr_init();
    exr_context_t f = NULL;
    exr_result_t rv = exr_start_read(&f, path, &ci);
    if (rv) {
        int r = exr_fail(MF_EFORMAT, path, "not a readable EXR", rv);
        exr_finish(&f);
        return r;
    }
    MfExrImage r = {0};
    int code = MF_OK;
    int nparts = 0;
    exr_storage_t st = EXR_STORAGE_SCANLINE;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *cl = NULL;
    if ((rv = exr_get_count(f, &nparts)) || (rv = exr_get_storage(f, 0, &st)) || (rv = exr_get_data_window(f, 0, &dw)) ||
        (rv = exr_get_channels(f, 0, &cl))) {
        code = exr_fail(MF_EFORMAT, path, "bad header", rv);
        goto done;
    }
    if (st != EXR_STORAGE_SCANLINE && st != EXR_STORAGE_TILED) {
        code = mf_fail(MF_EFORMAT, "%s: deep EXR data is not supported", path);
        goto done;
    }
    long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > (1LL << 30) || h > (1LL << 30) || w * h > (1LL << 31) || !cl || cl->num_channels <= 0) {
        code = mf_fail(MF_EFORMAT, "%s: bad data window or no channels", path);
        goto done;
    }
    /* the data window comes from the header: check it against the file's length before allocating */
    if ((code = mf_image_check_decode(path, w, h, cl->num_channels, fsize))) goto done;
    r.w = (int)w;
    r.h = (int)h;
    r.n = cl->num_channels;
    r.names = calloc((size_t)r.n, sizeof(char *));
    r.data = calloc((size_t)r.n * w * h, sizeof(float));
    if (!r.names || !r.data) {
        code = mf_fail(MF_ENOMEM, "%s: out of memory for %dx%d x %d channels", path, r.w, r.h, r.n);
        goto done;
    }
    for (int i = 0; i < r.n; ++i) {
        const exr_attr_chlist_entry_t *e = &cl->entries[i];
        if (e->x_sampling != 1 || e->y_sampling != 1) {
            code = mf_fail(MF_EFORMAT, "%s: channel '%s' is subsampled (not supported)", path, e->name.str);
            goto done;
        }
        r.names[i] = malloc((size_t)e->name.length + 1);
        if (!r.names[i]) { code = mf_fail(MF_ENOMEM, "out of memory"); goto done; }
        memcpy(r.names[i], e->name.str, (size_t)e->name.length);
        r.names[i][e->name.length] = '\0';
    }

    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0;
    if (st == EXR_STORAGE_SCANLINE) {
        int32_t spc = 1;
        rv = exr_get_scanlines_per_chunk(f, 0, &spc);
        for (int y = dw.min.y; !rv && y <= dw.max.y; y += spc) {
            exr_chunk_info_t cinfo;
            rv = exr_read_scanline_chunk_info(f, 0, y, &cinfo);
            if (!rv) rv = decode_chunk(f, &dec, &started, &cinfo, &r, dw.min.x, dw.min.y);
        }
    } else {
        int32_t tw = 0, th = 0;
        rv = exr_get_tile_sizes(f, 0, 0, 0, &tw, &th);
        if (!rv && (tw <= 0 || th <= 0)) rv = EXR_ERR_BAD_CHUNK_LEADER;
        for (int ty = 0; !rv && (long long)ty * th < h; ++ty)
            for (int tx = 0; !rv && (long long)tx * tw < w; ++tx) {
                exr_chunk_info_t cinfo;
                rv = exr_read_tile_chunk_info(f, 0, tx, ty, 0, 0, &cinfo);
                if (rv) break;
                /* Tile chunk origins are relative to the data window. */
                cinfo.start_x = tx * tw + dw.min.x;
                cinfo.start_y = ty * th + dw.min.y;
                rv = decode_chunk(f, &dec, &started, &cinfo, &r, dw.min.x, dw.min.y);
            }
    }
    if (started) exr_decoding_destroy(f, &dec);
    if (rv) {
        exr_compression_t cmp = EXR_COMPRESSION_NONE;
        static const char *cnames[] = {"NONE", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A", "DWAA", "DWAB"};
        if (rv == EXR_ERR_FEATURE_NOT_IMPLEMENTED && !exr_get_compression(f, 0, &cmp) && cmp < EXR_COMPRESSION_LAST_TYPE)
            code = mf_fail(MF_EFORMAT, "%s: %s compression is not supported by the OpenEXR 3.1 C API (read it with mf_image_read)",
                           path, cnames[cmp]);
        else
            code = exr_fail(MF_EFORMAT, path, "cannot decode pixels (truncated or corrupt file?)", rv);
        goto done;
    }
    size_t plane = (size_t)r.w * r.h;
    for (int k = 0; k < r.n; ++k)
        for (size_t p = 0; p < plane; ++p)
            if (!isfinite(r.data[k * plane + p])) {
                code = mf_fail(MF_ENAN, "%s: channel '%s' pixel (%zu, %zu) is not finite (%g)", path, r.names[k],
                               p % (size_t)r.w, p / (size_t)r.w, (double)r.data[k * plane + p]);
                goto done;
            }
done:
    exr_finish(&f);
    if (code) {
        mf_exr_free(&r);
        return code;
    }
    *out = r;
    return MF_OK;
}

const float *mf_exr_channel(const MfExrImage *im, const char *name) {
    for (int i = 0; i < im->n; ++i)
        if (strcmp(im->names[i], name) == 0) return im->data + (size_t)i * im->w * im->h;
    return NULL;
}

int mf_exr_gather(const MfExrImage *im, const char *path, const char *const *names, int nc, MfImage *out) {
    if (nc < 1 || nc > 4) return mf_fail(MF_EARG, "%s: can gather 1..4 channels, not %d", path, nc);
    const float *src[4];
    for (int k = 0; k < nc; ++k) {
        src[k] = mf_exr_channel(im, names[k]);
        if (!src[k]) {
            char have[512];
            size_t u = 0;
            have[0] = '\0';
            for (int i = 0; i < im->n && u + 1 < sizeof have; ++i) {
                int m = snprintf(have + u, sizeof have - u, "%s%s", i ? ", " : "", im->names[i]);
                if (m < 0) break;
                u += (size_t)m;
            }
            return mf_fail(MF_EFORMAT, "%s: no channel '%s' (file has: %s)", path, names[k], have);
        }
    }
    MfImage r;
    int rc = mf_image_alloc(&r, im->w, im->h, nc);
    if (rc) return rc;
    size_t plane = (size_t)im->w * im->h;
    for (size_t p = 0; p < plane; ++p)
        for (int k = 0; k < nc; ++k) r.data[p * nc + k] = src[k][p];
    *out = r;
    return MF_OK;
}

int mf_exr_read_layer(const char *path, const char *layer, const char *comps, MfImage *out) {
    int nc = comps ? (int)strlen(comps) : 0;
    if (nc < 1 || nc > 4) return mf_fail(MF_EARG, "%s: components '%s' must be 1..4 letters", path, comps ? comps : "");
    char buf[4][300];
    const char *names[4];
    for (int k = 0; k < nc; ++k) {
        if (layer && layer[0]) snprintf(buf[k], sizeof buf[k], "%.250s.%c", layer, comps[k]);
        else snprintf(buf[k], sizeof buf[k], "%c", comps[k]);
        names[k] = buf[k];
    }
    MfExrImage im = {0};
    int rc = mf_exr_read(path, &im);
    if (rc) return rc;
    rc = mf_exr_gather(&im, path, names, nc, out);
    mf_exr_free(&im);
    return rc;
}
