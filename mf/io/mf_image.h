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

/* Reads any format OpenImageIO knows (PNG 8/16, JPEG, EXR half/float, HDR, ...). */
int mf_image_read(const char *path, MfEncoding enc, MfImage *out);
/* Writes by extension: .png (bits 8 or 16), .jpg (8), .exr (bits 16 = half, 32 = float),
 * .hdr. Values are clamped to [0,1] only for integer formats. */
int mf_image_write(const char *path, const MfImage *img, MfEncoding enc, int bits);

#endif
