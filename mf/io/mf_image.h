/* mf_image: float images in memory and image files through OpenImageIO.
 *
 * In memory every image is linear float32, interleaved, row 0 at the top:
 *   MfImage.data  (h, w, c)   c = 1..4; for c = 4 the last channel is alpha (coverage, linear).
 * Encoding at file boundaries is explicit (DESIGN.md): 8/16-bit PNG/JPEG hold either sRGB colour
 * (renders, albedo: MF_ENC_SRGB, exact piecewise curve, alpha stays linear) or linear data (ORM,
 * normals, masks: MF_ENC_LINEAR). EXR and Radiance HDR are always linear whatever enc says.
 * Reads reject NaN/Inf pixels with an error naming the file. Writes go to a temporary name and
 * are renamed into place (no half-written file survives a failure). */
#ifndef MF_IMAGE_H
#define MF_IMAGE_H

#include <stddef.h>

typedef enum { MF_ENC_LINEAR = 0, MF_ENC_SRGB = 1 } MfEncoding;

typedef struct {
    int w, h, c;
    float *data; /* owned; (h, w, c) linear */
} MfImage;

/* Zero-filled allocation. */
int mf_image_alloc(MfImage *img, int w, int h, int c);
/* Frees data and zeroes the struct; safe on a zeroed struct. */
void mf_image_free(MfImage *img);
static inline float *mf_image_px(const MfImage *img, int x, int y) { return img->data + ((size_t)y * img->w + x) * img->c; }

/* Exact piecewise sRGB transfer (IEC 61966-2-1). */
float mf_srgb_to_linear(float s);
float mf_linear_to_srgb(float l);

/* Reads any format OpenImageIO knows (PNG 8/16, JPEG, EXR half/float, HDR, ...). A directory
 * is refused by name; so is a header whose size asks for more decoded bytes than the file can
 * hold (mf_image_decode_limit), before anything is allocated. An EXR file's header is first
 * parsed by mf_exr_check_header (OpenEXR's C API, bounded by the file's length), so a corrupt
 * header is refused before OpenImageIO's reader allocates what it declares. */
int mf_image_read(const char *path, MfEncoding enc, MfImage *out);
/* The same for an encoded PNG or JPEG held in memory (an image embedded in a glTF file): ext
 * ("png" or "jpg") picks the decoder, name (the file and the place in it) is used in messages;
 * the decode limit is mf_image_decode_limit(len). */
int mf_image_decode(const char *name, const void *bytes, size_t len, const char *ext, MfEncoding enc, MfImage *out);
/* Most bytes of decoded float32 pixels a reader allocates for an image file of file_bytes bytes:
 * max(64 MiB, 8192 x file_bytes), and never more than MF_IMAGE_MAX_PIXELS pixels. No lossless
 * coding in our formats expands further (deflate, as PNG and EXR ZIP use it, stops near 1032:1,
 * and float32 is at most 4x an 8-bit sample), so a 16 KB file asking for gigabytes is corrupt. */
#define MF_IMAGE_DECODE_RATIO 8192ull
#define MF_IMAGE_DECODE_FLOOR (64ull << 20)
#define MF_IMAGE_MAX_PIXELS (1ull << 28)
unsigned long long mf_image_decode_limit(unsigned long long file_bytes);
/* MF_OK when a w x h x c float32 image fits mf_image_decode_limit(file_bytes), else an error
 * naming path and both sizes. */
int mf_image_check_decode(const char *path, long long w, long long h, long long c, unsigned long long file_bytes);
/* Writes by extension: .png (bits 8 or 16), .jpg (8), .exr (bits 16 = half, 32 = float),
 * .hdr. Values are clamped to [0,1] only for integer formats. The same image gives the same
 * bytes whenever it is written (no date or time in the header). */
int mf_image_write(const char *path, const MfImage *img, MfEncoding enc, int bits);

#endif
