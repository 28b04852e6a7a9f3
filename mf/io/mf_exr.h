/* mf_exr: multi-layer OpenEXR files through the OpenEXR 3.1 C API (libOpenEXRCore).
 *
 * One file holds any number of named float planes of the same size (one scanline part, ZIP
 * compression, data window = display window = [0, w) x [0, h), row 0 at the top). Values are
 * linear float32 in memory; in the file each channel is half (MF_EXR_HALF) or float32.
 *
 * Channel naming convention for render outputs (the renderer writes these, eval reads them):
 *   "R", "G", "B", "A"              beauty pass, linear radiance, A = coverage
 *   "albedo.R", "albedo.G", "albedo.B"      base colour kd (linear)
 *   "orm.R", "orm.G", "orm.B"       occlusion, roughness, metallic (glTF ORM)
 *   "normal.X", "normal.Y", "normal.Z"      world-space shading normal (unit; 0 off the object)
 *   "depth.Z"                       distance along the camera's -z axis, world units (0 = miss)
 *   "diffuse.R/G/B"                 demodulated diffuse light (radiance / albedo)
 *   "specular.R/G/B"                specular radiance
 * Layer "x" channel "c" is named "x.c" (OpenEXR's layer convention, which OpenImageIO, Blender
 * and Nuke understand; the unprefixed R, G, B, A are the default layer, so any viewer shows
 * the beauty pass). EXR stores channels sorted by name: readers must look channels up by name,
 * never by position.
 *
 * Writes go to a temporary name beside the target and are renamed into place. Writers refuse
 * NaN/Inf (and, for half, magnitudes beyond 65504) unless MF_EXR_ALLOW_NONFINITE is given;
 * readers always refuse NaN/Inf, naming the file, channel and pixel. Reading supports scanline
 * and tiled (level 0) single-part files with half, float or uint channels; subsampled channels
 * and deep data are refused. */
#ifndef MF_EXR_H
#define MF_EXR_H

#include <stddef.h>

#include "io/mf_image.h"

/* Flags for mf_exr_write. */
enum {
    MF_EXR_FLOAT = 0,            /* float32 channels (exact) */
    MF_EXR_HALF = 1,             /* float16 channels (relative error <= 2^-11) */
    MF_EXR_ALLOW_NONFINITE = 2,  /* write NaN/Inf as they are (tests of readers only) */
    MF_EXR_HALF_LAST = 4         /* the last channel float16, the others as the flags say (a file of mixed types) */
};

/* One channel to write. Pixel (x, y) is data[(y * w + x) * stride]; stride 0 means 1, so a
 * plane is (h, w) and channel k of an interleaved (h, w, c) image is {name, img + k, c}. */
typedef struct {
    const char *name;  /* borrowed; e.g. "R", "albedo.G", "depth.Z" */
    const float *data; /* borrowed; (h, w) with pixel stride `stride` floats */
    int stride;        /* floats between neighbouring pixels; 0 = 1 */
} MfExrChannel;

/* Writes n channels (names must be distinct, 1..255 chars) of a w x h image. flags: MF_EXR_HALF,
 * MF_EXR_HALF_LAST and/or MF_EXR_ALLOW_NONFINITE. */
int mf_exr_write(const char *path, int w, int h, const MfExrChannel *ch, int n, int flags);

/* Writes an MfImage (c = 1..4) under a layer name: layer "" gives R, G, B, A (c = 1: "Y"),
 * layer "albedo" gives albedo.R, albedo.G, ... Convenience for single-layer files. */
int mf_exr_write_image(const char *path, const MfImage *img, const char *layer, int flags);

/* All channels of a file, as float planes. */
typedef struct {
    int w, h, n;
    char **names; /* owned; (n,) channel names as stored in the file (sorted by name) */
    float *data;  /* owned; (n, h, w) planes in names' order, linear */
} MfExrImage;

/* Reads every channel of a single-part file. NaN/Inf gives MF_ENAN with
 * "path: channel 'depth.Z' pixel (x, y) is not finite". */
int mf_exr_read(const char *path, MfExrImage *out);
/* Frees and zeroes; safe on a zeroed struct. */
void mf_exr_free(MfExrImage *im);
/* Parses only the header of an EXR file of file_bytes bytes (every part) with the C API, which
 * reads attributes no further than the file goes, and checks each part's data window and channel
 * count with mf_image_check_decode. MF_OK or MF_EFORMAT naming path. mf_image_read calls it on
 * EXR files before OpenImageIO, whose OpenEXR C++ reader allocates an attribute's declared size
 * (up to 2 GB, from a 60-byte file) before it finds that the file ends. */
int mf_exr_check_header(const char *path, unsigned long long file_bytes);
/* The (h, w) plane of a channel, or NULL when the file has no such channel. */
const float *mf_exr_channel(const MfExrImage *im, const char *name);

/* Interleaves named channels into a new (h, w, nc) MfImage (nc = 1..4), e.g.
 * {"albedo.R", "albedo.G", "albedo.B"}. A missing channel fails with
 * "path: no channel 'albedo.G' (file has: A, B, G, R)"; path is only used in messages. */
int mf_exr_gather(const MfExrImage *im, const char *path, const char *const *names, int nc, MfImage *out);

/* Reads layer `layer` (e.g. "albedo"; "" = the default R, G, B[, A] layer) with components
 * `comps` (e.g. "RGB", "XYZ", "Z", "RGBA") into an interleaved MfImage. */
int mf_exr_read_layer(const char *path, const char *layer, const char *comps, MfImage *out);

#endif
