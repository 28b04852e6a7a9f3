/* ev_image: reading the images that the evaluation scores, one layer at a time.
 *
 * A multi-layer EXR (what `mf render` writes: R, G, B, A plus albedo.*, orm.*, normal.*, depth.Z,
 * ...; io/mf_exr.h) holds more than the 1..4 channels the protocol scores (eval/ev_align.h). The
 * reader here picks one layer by name and returns at most 4 channels:
 *   layer "" (or NULL)  the default layer: R, G, B and A when present (else Y)
 *   layer "albedo"      albedo.R, albedo.G, albedo.B (and albedo.A when present); a layer with
 *                       X, Y, Z components (normal) gives those; a one-channel layer (depth.Z,
 *                       or any single component) gives that channel.
 * Other formats (PNG, JPEG, HDR, single-layer EXR through OpenImageIO) are read whole with
 * mf_image_read; they have no layers, so only layer "" is accepted, and a file with more than 4
 * channels is refused (never truncated silently). Values are linear (PNG/JPEG decoded with enc). */
#ifndef EV_IMAGE_H
#define EV_IMAGE_H

#include "io/mf_image.h"

/* Reads layer `layer` of path into out (c = 1..4). Errors name the file and, for a missing layer,
 * the layers the file has. out is untouched on failure. */
int ev_image_read(const char *path, const char *layer, MfEncoding enc, MfImage *out);

#endif
