/* Fuzz harness: the image layer (mf_image_read through OpenImageIO, mf_exr_read through the
 * OpenEXR C API). The first byte picks the file name's extension (0 .png, 1 .exr, 2 .hdr), so
 * the reader that name selects gets the rest; EXR bytes also go through mf_exr_read. */
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "mf_fuzz.h"

MF_FUZZ(image) {
    if (!mf_fuzz_dir()[0] || size < 1) return 0;
    static const char *const names[] = {"in.png", "in.exr", "in.hdr"};
    int k = data[0] % 3;
    const char *p = mf_fuzz_write(names[k], data + 1, size - 1);
    if (!p) return 0;
    MfImage img = {0};
    if (mf_image_read(p, k == 1 ? MF_ENC_LINEAR : MF_ENC_SRGB, &img) == 0) mf_image_free(&img);
    if (k == 1) {
        MfExrImage ex = {0};
        if (mf_exr_read(p, &ex) == 0) mf_exr_free(&ex);
    }
    return 0;
}
