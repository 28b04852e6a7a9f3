/* mf_image_oiio: the C side of the small C++ shim over OpenImageIO (mf_image_oiio.cpp).
 * Internal to mf/io: use mf_image.h. Raw values: no colour conversion happens here; alpha is
 * read and written unassociated (straight), as PNG stores it. */
#ifndef MF_IMAGE_OIIO_H
#define MF_IMAGE_OIIO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Reads subimage 0 as float. *data is malloc'ed (h, w, c). *is_int is 1 when the file stores
 * integer samples (PNG, JPEG, ...), 0 for float/half. *alpha_channel is -1 when none.
 * Returns 0; -2 (err filled, nothing allocated) when the header's w x h x c floats exceed
 * max_bytes or 2^28 pixels; -1 with err filled on any other failure. */
int mf_oiio_read(const char *path, unsigned long long max_bytes, int *w, int *h, int *c, int *is_int, int *alpha_channel,
                 float **data, char *err, size_t errcap);
/* The same from an encoded file held in memory (bytes, len); ext ("png", "jpg") picks the reader. */
int mf_oiio_read_mem(const void *bytes, size_t len, const char *ext, unsigned long long max_bytes, int *w, int *h, int *c,
                     int *is_int, int *alpha_channel, float **data, char *err, size_t errcap);
/* Writes (h, w, c) floats; bits: 8 or 16 (integer formats), 16 (half) or 32 (float) for EXR/HDR.
 * Returns 0, or -1 with err filled. */
int mf_oiio_write(const char *path, int w, int h, int c, const float *data, int bits, char *err, size_t errcap);

#ifdef __cplusplus
}
#endif

#endif
