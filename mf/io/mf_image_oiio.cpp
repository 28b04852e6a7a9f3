// C++ shim over OpenImageIO for mf_image.c (see mf_image_oiio.h).
#include "mf_image_oiio.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

using namespace OIIO;

static void set_err(char *err, size_t cap, const std::string &msg) {
    std::snprintf(err, cap, "%s", msg.empty() ? "unknown OpenImageIO error" : msg.c_str());
}

/* Converts n values of type t at src to float at dst, where src = (char *)dst + n * (4 - t.size()),
 * in blocks: a block is read before it is written, and writing values [0, i) reaches no source
 * byte of value i or later ((i) * 4 <= n * (4 - size) + i * size). */
static bool widen(TypeDesc t, const unsigned char *src, float *dst, size_t n) {
    size_t ts = t.size();
    float tmp[4096];
    for (size_t i = 0; i < n; i += 4096) {
        size_t k = n - i < 4096 ? n - i : 4096; /* block [i, i + k): read whole, then written */
        if (!convert_pixel_values(t, src + i * ts, TypeDesc::FLOAT, tmp, (int)k)) return false;
        std::memcpy(dst + i, tmp, k * sizeof(float));
    }
    return true;
}

/* Reads subimage 0 of an open input (see mf_oiio_read). */
static int read_open(ImageInput *in, unsigned long long max_bytes, int *w, int *h, int *c, int *is_int, int *alpha_channel,
                     float **data, char *err, size_t errcap) {
    if (!in) {
        set_err(err, errcap, OIIO::geterror());
        return -1;
    }
    const ImageSpec &spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth > 1) {
        set_err(err, errcap, "unsupported image dimensions");
        return -1;
    }
    unsigned long long px = (unsigned long long)spec.width * (unsigned long long)spec.height;
    if (px > (1ull << 28) || px * (unsigned long long)spec.nchannels * 4ull > max_bytes) {
        char msg[256];
        std::snprintf(msg, sizeof msg, "header asks for %dx%d x %d channels (%llu bytes decoded), more than the limit of %llu bytes",
                      spec.width, spec.height, spec.nchannels, px * (unsigned long long)spec.nchannels * 4ull, max_bytes);
        set_err(err, errcap, msg);
        return -2;
    }
    size_t n = (size_t)spec.width * spec.height * spec.nchannels;
    float *buf = (float *)std::malloc(n * sizeof(float));
    if (!buf) {
        set_err(err, errcap, "out of memory");
        return -1;
    }
    /* Asked for float, ImageInput::read_scanlines converts through a scratch buffer of about
     * 64 MiB whatever the image's size (2^26 / scanline bytes rows); reading the file's own type
     * needs none, so a one-format image is read as it is into the tail of buf and widened in
     * place (front to back: the source is never behind the destination). Per-channel formats
     * (EXR mixing half and float) take the converting path. */
    bool ok;
    size_t tsz = spec.format.size();
    if (spec.channelformats.empty() && tsz > 0 && tsz <= sizeof(float)) {
        unsigned char *nat = (unsigned char *)buf + n * (sizeof(float) - tsz);
        /* scanline files straight through read_native_scanlines: read_image/read_scanlines size
         * their buffer from the width alone (256 rows of a 1M-pixel-wide, 2-row EXR: 4 GiB) */
        ok = spec.tile_width > 0 ? in->read_image(0, 0, 0, spec.nchannels, spec.format, nat)
                                 : in->read_native_scanlines(0, 0, spec.y, spec.y + spec.height, spec.z, nat);
        ok = ok && (spec.format == TypeDesc::FLOAT || widen(spec.format, nat, buf, n));
    } else if (spec.tile_width <= 0 && spec.channelformats.size() == (size_t)spec.nchannels) {
        /* per-channel formats (an EXR mixing half and float): the native pixels (each channel
         * in its own type, no larger than a float) into a buffer of their size, then each
         * channel widened with strides, instead of read_image's 64 MiB converting scratch */
        size_t pb = spec.pixel_bytes(true), npx = (size_t)spec.width * spec.height;
        unsigned char *nat = (unsigned char *)std::malloc(npx * pb);
        ok = nat && in->read_native_scanlines(0, 0, spec.y, spec.y + spec.height, spec.z, nat);
        for (int ch = 0, off = 0; ok && ch < spec.nchannels; off += (int)spec.channelformats[ch].size(), ++ch)
            ok = convert_image(1, (int)npx, 1, 1, nat + off, spec.channelformats[ch], (stride_t)pb, AutoStride, AutoStride, buf + ch,
                               TypeDesc::FLOAT, (stride_t)(spec.nchannels * sizeof(float)), AutoStride, AutoStride);
        std::free(nat);
    } else {
        ok = in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, buf);
    }
    if (!ok) {
        std::string e = in->geterror();
        std::free(buf);
        set_err(err, errcap, e.empty() ? std::string("cannot decode pixels (truncated or corrupt file?)") : e);
        return -1;
    }
    std::string e = in->geterror();
    in->close();
    if (!e.empty()) {
        std::free(buf);
        set_err(err, errcap, e);
        return -1;
    }
    *w = spec.width;
    *h = spec.height;
    *c = spec.nchannels;
    TypeDesc::BASETYPE bt = (TypeDesc::BASETYPE)spec.format.basetype;
    *is_int = !(bt == TypeDesc::HALF || bt == TypeDesc::FLOAT || bt == TypeDesc::DOUBLE);
    *alpha_channel = spec.alpha_channel;
    *data = buf;
    return 0;
}

/* The formats a file's first bytes identify: their signature, the reader's key for
 * ImageInput::create and the file name extensions that claim them. */
struct Sig {
    const char *magic;
    size_t n;
    const char *reader, *name, *exts;
};
static const Sig k_sigs[] = {
    {"\x89PNG\r\n\x1a\n", 8, "png", "PNG", ".png."},
    {"\xff\xd8\xff", 3, "jpg", "JPEG", ".jpg.jpeg.jpe.jfif."},
    {"\x76\x2f\x31\x01", 4, "exr", "OpenEXR", ".exr.sxr.mxr."},
    {"#?", 2, "hdr", "Radiance HDR", ".hdr.rgbe."},
    {"II*\0", 4, "tif", "TIFF", ".tif.tiff.tx.env.sm.vsm."},
    {"MM\0*", 4, "tif", "TIFF", ".tif.tiff.tx.env.sm.vsm."},
    {"II+\0", 4, "tif", "TIFF", ".tif.tiff.tx.env.sm.vsm."},
    {"MM\0+", 4, "tif", "TIFF", ".tif.tiff.tx.env.sm.vsm."},
};

extern "C" int mf_oiio_read(const char *path, unsigned long long max_bytes, int *w, int *h, int *c, int *is_int,
                            int *alpha_channel, float **data, char *err, size_t errcap) {
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    /* The reader is picked by the file's signature when it has one of the formats above (a PNG
     * named .jpg still reads). A file that claims one of them by its extension but starts with
     * no known signature is refused here: OpenImageIO would otherwise try every reader it has
     * (WebP, DICOM, RAW, ...) on it, slowly, and report the last one's complaint. Any other
     * file goes to OpenImageIO as before (extension, then every reader). */
    unsigned char head[8] = {0};
    size_t nh = 0;
    if (FILE *f = std::fopen(path, "rb")) {
        nh = std::fread(head, 1, sizeof head, f);
        std::fclose(f);
    }
    const Sig *sig = nullptr;
    for (const Sig &k : k_sigs)
        if (!sig && nh >= k.n && !std::memcmp(head, k.magic, k.n)) sig = &k;
    std::string ext = Strutil::lower(Filesystem::extension(path));
    if (!sig && !ext.empty()) {
        for (const Sig &k : k_sigs)
            if (std::strstr(k.exts, (ext + ".").c_str())) {
                char msg[256];
                std::snprintf(msg, sizeof msg, "not a %s file: its first bytes are no %s signature (nor PNG, JPEG, OpenEXR, HDR or TIFF)",
                              k.name, k.name);
                set_err(err, errcap, msg);
                return -1;
            }
    }
    std::unique_ptr<ImageInput> in;
    if (sig) {
        in = ImageInput::create(sig->reader);
        ImageSpec spec;
        if (in && !in->open(path, spec, config)) {
            std::string e = in->geterror();
            set_err(err, errcap, e.empty() ? std::string("cannot open as ") + sig->name : e);
            return -1;
        }
    } else {
        in = ImageInput::open(path, &config);
    }
    int rc = read_open(in.get(), max_bytes, w, h, c, is_int, alpha_channel, data, err, errcap);
    OIIO::geterror(); /* OpenImageIO keeps a global (per-thread) error until it is read: drained, so failed reads do not pile up messages */
    return rc;
}

extern "C" int mf_oiio_read_mem(const void *bytes, size_t len, const char *ext, unsigned long long max_bytes, int *w, int *h,
                                int *c, int *is_int, int *alpha_channel, float **data, char *err, size_t errcap) {
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    Filesystem::IOMemReader mem(bytes, len);
    /* a reader for the format (by extension), opened on the bytes in mem */
    auto in = ImageInput::create(ext);
    ImageSpec spec;
    if (!in || !in->supports("ioproxy") || !in->set_ioproxy(&mem) || !in->open(std::string("memory.") + ext, spec, config)) {
        std::string e = in ? in->geterror() : OIIO::geterror();
        set_err(err, errcap, e.empty() ? std::string("cannot decode the image bytes") : e);
        return -1;
    }
    return read_open(in.get(), max_bytes, w, h, c, is_int, alpha_channel, data, err, errcap);
}

extern "C" int mf_oiio_write(const char *path, int w, int h, int c, const float *data, int bits, char *err,
                             size_t errcap) {
    auto out = ImageOutput::create(path);
    if (!out) {
        set_err(err, errcap, OIIO::geterror());
        return -1;
    }
    std::string fmt = out->format_name();
    TypeDesc td = TypeDesc::FLOAT;
    if (fmt == "openexr") td = bits == 32 ? TypeDesc::FLOAT : TypeDesc::HALF;
    else if (fmt == "hdr") td = TypeDesc::FLOAT;
    else td = bits == 16 ? TypeDesc::UINT16 : TypeDesc::UINT8;
    ImageSpec spec(w, h, c, td);
    if (c == 4) spec.alpha_channel = 3;
    if (c == 2) spec.alpha_channel = 1;
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (fmt == "openexr") {
        spec.attribute("compression", "zip");
        /* OpenImageIO stamps the time of writing into the EXR header (capDate) unless DateTime is
         * given: an empty one keeps identical runs byte-identical (env.exr of mf recon) */
        spec.attribute("DateTime", "");
    }
    if (!out->open(path, spec)) {
        set_err(err, errcap, out->geterror());
        return -1;
    }
    bool ok = out->write_image(TypeDesc::FLOAT, data);
    std::string e = out->geterror();
    ok = out->close() && ok;
    if (!ok) {
        set_err(err, errcap, e.empty() ? std::string("write failed") : e);
        return -1;
    }
    return 0;
}
