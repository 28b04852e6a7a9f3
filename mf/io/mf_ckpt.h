/* mf_ckpt: checkpoint files of named float32 tensors (model weights, optimiser moments, the
 * reconstruction's textures). MfTensorSpec, the name and shape of one tensor, is declared here
 * (plain data; mf/nn's parameter tables are arrays of it).
 *
 * Format (version 1, all integers little-endian):
 *   "MFCK"  u32 version (1)  u32 ntensors  u32 meta_len  meta (meta_len bytes, free text, e.g.
 *           JSON with the resolution / latent scale / data seed; not NUL-terminated)
 *   per tensor: u32 name_len, name bytes, u32 ndim (1..4), u32 shape[ndim]
 *   data: the tensors' float32 values, in table order, little-endian, no padding
 *   u64 FNV-1a 64 checksum of every byte before it (header and data)
 * Files are written atomically (temporary file + rename). Loading checks, in this order, and
 * refuses with a message naming the file: short/truncated file ("truncated"), magic ("not an
 * MFCK checkpoint"), version ("unsupported version"), checksum ("checksum mismatch"), tensor
 * count, names and shapes against the model's table ("tensor count", "name mismatch",
 * "shape mismatch"). Only little-endian hosts are supported (x86-64, arm64). */
#ifndef MF_CKPT_H
#define MF_CKPT_H

#include <stddef.h>
#include <stdint.h>

#define MF_CKPT_VERSION 1u

#define MF_NN_NAME_MAX 64
#define MF_NN_MAXDIM 4

/* One named tensor: name (e.g. "down.0.res.conv1.w") and shape. */
typedef struct {
    char name[MF_NN_NAME_MAX];
    int ndim;
    int shape[MF_NN_MAXDIM];
} MfTensorSpec;

/* Number of floats of one tensor / of a whole table. */
size_t mf_tensor_numel(const MfTensorSpec *s);
size_t mf_specs_numel(const MfTensorSpec *specs, int n);
/* Fills spec with name (prefix + "." + leaf, or leaf when prefix is "" or NULL) and shape. */
void mf_spec_set(MfTensorSpec *spec, const char *prefix, const char *leaf, int ndim, const int *shape);

/* Writes the n tensors of specs with their values data (mf_specs_numel(specs, n) floats, in
 * table order) and meta (may be NULL) to path, atomically. */
int mf_ckpt_save(const char *path, const MfTensorSpec *specs, int n, const float *data, const char *meta);

/* Reads path into data (mf_specs_numel(specs, n) floats), after checking it matches the
 * table exactly. If meta is not NULL, *meta receives a heap copy of the meta text (NUL-terminated,
 * caller frees). data and *meta are untouched on failure. */
int mf_ckpt_load(const char *path, const MfTensorSpec *specs, int n, float *data, char **meta);

/* Reads any valid checkpoint, whatever its table (every check of mf_ckpt_load but the table
 * match): *specs (*n tensors), *data (their floats in table order) and, if meta is not NULL,
 * *meta (NUL-terminated): heap copies the caller frees. Outputs are untouched on failure. */
int mf_ckpt_read(const char *path, MfTensorSpec **specs, int *n, float **data, char **meta);

/* Reads only the header's meta text of path into *meta (NUL-terminated heap copy the caller frees),
 * without the tensors: the magic, version and a meta length within the file and max_len are checked,
 * not the checksum (mf_ckpt_read / _load check it when the tensors are read). */
int mf_ckpt_read_meta(const char *path, size_t max_len, char **meta);

#endif
