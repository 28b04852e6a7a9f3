/* mf_ckpt: checkpoint writer and checked reader (format in mf_ckpt.h). */
#include "io/mf_ckpt.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"

size_t mf_tensor_numel(const MfTensorSpec *s) {
    size_t n = 1;
    for (int i = 0; i < s->ndim; ++i) n *= (size_t)s->shape[i];
    return n;
}

size_t mf_specs_numel(const MfTensorSpec *specs, int n) {
    size_t t = 0;
    for (int i = 0; i < n; ++i) t += mf_tensor_numel(&specs[i]);
    return t;
}

void mf_spec_set(MfTensorSpec *spec, const char *prefix, const char *leaf, int ndim, const int *shape) {
    memset(spec, 0, sizeof *spec);
    if (prefix && prefix[0])
        snprintf(spec->name, sizeof spec->name, "%s.%s", prefix, leaf);
    else
        snprintf(spec->name, sizeof spec->name, "%s", leaf);
    spec->ndim = ndim < MF_NN_MAXDIM ? ndim : MF_NN_MAXDIM;
    for (int i = 0; i < spec->ndim; ++i) spec->shape[i] = shape[i];
}

/* A FILE writer that hashes what it writes and remembers the first failure. */
typedef struct {
    FILE *f;
    uint64_t h;
    int bad;
} HashWriter;

static void hw_put(HashWriter *w, const void *p, size_t n) {
    if (w->bad || n == 0) return;
    if (fwrite(p, 1, n, w->f) != n) w->bad = 1;
    w->h = mf_fnv1a64(w->h, p, n);
}

static void hw_u32(HashWriter *w, uint32_t v) { hw_put(w, &v, 4); }

static void shape_str(char *buf, size_t cap, int ndim, const int *shape) {
    size_t k = 0;
    k += (size_t)snprintf(buf + k, cap - k, "(");
    for (int i = 0; i < ndim && k < cap; ++i)
        k += (size_t)snprintf(buf + k, cap - k, i ? ", %d" : "%d", shape[i]);
    if (k < cap) snprintf(buf + k, cap - k, ")");
}

int mf_ckpt_save(const char *path, const MfTensorSpec *specs, int n, const float *data, const char *meta) {
    char tmp[MF_PATH_MAX];
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc) return rc;
    FILE *f = fopen(tmp, "wb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot write: %s", path, strerror(errno));
    HashWriter w = {f, MF_FNV64_INIT, 0};
    size_t mlen = meta ? strlen(meta) : 0;
    hw_put(&w, "MFCK", 4);
    hw_u32(&w, MF_CKPT_VERSION);
    hw_u32(&w, (uint32_t)n);
    hw_u32(&w, (uint32_t)mlen);
    hw_put(&w, meta, mlen);
    for (int i = 0; i < n; ++i) {
        uint32_t nl = (uint32_t)strnlen(specs[i].name, MF_NN_NAME_MAX);
        hw_u32(&w, nl);
        hw_put(&w, specs[i].name, nl);
        hw_u32(&w, (uint32_t)specs[i].ndim);
        for (int k = 0; k < specs[i].ndim; ++k) hw_u32(&w, (uint32_t)specs[i].shape[k]);
    }
    hw_put(&w, data, mf_specs_numel(specs, n) * sizeof(float));
    uint64_t h = w.h;
    if (!w.bad && fwrite(&h, 1, 8, f) != 8) w.bad = 1;
    if (fclose(f) != 0) w.bad = 1;
    if (w.bad) {
        mf_discard_file(tmp);
        return mf_fail(MF_EIO, "%s: write failed", path);
    }
    return mf_commit_file(tmp, path);
}

/* A bounds-checked reader over the file's bytes. */
typedef struct {
    const unsigned char *p;
    size_t len, pos;
} Reader;

static int rd(Reader *r, void *out, size_t n) {
    if (r->len - r->pos < n) return 0;
    memcpy(out, r->p + r->pos, n);
    r->pos += n;
    return 1;
}

#define MF_CKPT_HEADER 16 /* "MFCK", version, tensor count, meta length: 4 bytes each */

/* The header's checks, one place for mf_ckpt_read and mf_ckpt_read_meta: its first n bytes are at h
 * (fewer than MF_CKPT_HEADER: a truncated file); *nt and *mlen receive the tensor count and meta length. */
static int header_check(const char *path, const unsigned char *h, size_t n, uint32_t *nt, uint32_t *mlen) {
    if (n < 4) return mf_fail(MF_EFORMAT, "%s: truncated checkpoint (%zu bytes, no header)", path, n);
    if (memcmp(h, "MFCK", 4) != 0) return mf_fail(MF_EFORMAT, "%s: not an MFCK checkpoint (bad magic)", path);
    if (n < MF_CKPT_HEADER) return mf_fail(MF_EFORMAT, "%s: truncated checkpoint header", path);
    uint32_t version;
    memcpy(&version, h + 4, 4), memcpy(nt, h + 8, 4), memcpy(mlen, h + 12, 4);
    if (version != MF_CKPT_VERSION)
        return mf_fail(MF_EFORMAT, "%s: unsupported version %u of checkpoint (this build reads %u)", path, version,
                       MF_CKPT_VERSION);
    return MF_OK;
}

int mf_ckpt_read(const char *path, MfTensorSpec **specs, int *n, float **data, char **meta) {
    char *buf = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &buf, &len);
    if (rc) return rc;
    Reader r = {(const unsigned char *)buf, len, MF_CKPT_HEADER};
    uint32_t nt, mlen;
    MfTensorSpec *fs = NULL;
    if ((rc = header_check(path, r.p, len < MF_CKPT_HEADER ? len : MF_CKPT_HEADER, &nt, &mlen))) goto done;
    if (r.len - r.pos < mlen) {
        rc = mf_fail(MF_EFORMAT, "%s: truncated checkpoint header (meta text)", path);
        goto done;
    }
    size_t meta_pos = r.pos;
    r.pos += mlen;
    /* read the file's table: names and shapes, and the total number of floats */
    if (nt > (r.len - r.pos) / 12) { /* each entry takes at least 12 bytes */
        rc = mf_fail(MF_EFORMAT, "%s: truncated checkpoint (header lists %u tensors)", path, nt);
        goto done;
    }
    fs = calloc(nt ? nt : 1, sizeof *fs);
    if (!fs) {
        rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        goto done;
    }
    size_t total = 0;
    for (uint32_t i = 0; i < nt; ++i) {
        uint32_t nl, nd;
        if (!rd(&r, &nl, 4) || nl >= MF_NN_NAME_MAX || !rd(&r, fs[i].name, nl) || !rd(&r, &nd, 4) ||
            nd < 1 || nd > MF_NN_MAXDIM) {
            rc = mf_fail(MF_EFORMAT, "%s: truncated or malformed tensor table at entry %u", path, i);
            goto done;
        }
        fs[i].ndim = (int)nd;
        for (uint32_t k = 0; k < nd; ++k) {
            uint32_t s;
            if (!rd(&r, &s, 4)) {
                rc = mf_fail(MF_EFORMAT, "%s: truncated tensor table at entry %u", path, i);
                goto done;
            }
            fs[i].shape[k] = (int)s;
        }
        size_t k = mf_tensor_numel(&fs[i]);
        if (k > len / sizeof(float) || total > len / sizeof(float) - k) {
            rc = mf_fail(MF_EFORMAT, "%s: truncated checkpoint (tensor '%s' needs more data than the file holds)",
                         path, fs[i].name);
            goto done;
        }
        total += k;
    }
    size_t need = r.pos + total * sizeof(float) + 8;
    if (len < need) {
        rc = mf_fail(MF_EFORMAT, "%s: truncated checkpoint (%zu bytes, header says %zu)", path, len, need);
        goto done;
    }
    if (len > need) {
        rc = mf_fail(MF_EFORMAT, "%s: %zu trailing bytes after the checkpoint (expected %zu bytes)", path,
                     len - need, need);
        goto done;
    }
    uint64_t stored, h = mf_fnv1a64(MF_FNV64_INIT, buf, need - 8);
    memcpy(&stored, buf + need - 8, 8);
    if (stored != h) {
        rc = mf_fail(MF_EFORMAT, "%s: checksum mismatch (file corrupt): stored %016llx, computed %016llx",
                     path, (unsigned long long)stored, (unsigned long long)h);
        goto done;
    }
    float *d = malloc(total ? total * sizeof(float) : 1);
    char *m = meta ? malloc((size_t)mlen + 1) : NULL;
    if (!d || (meta && !m)) {
        free(d);
        free(m);
        rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        goto done;
    }
    memcpy(d, buf + r.pos, total * sizeof(float));
    if (m) {
        memcpy(m, buf + meta_pos, mlen);
        m[mlen] = '\0';
        *meta = m;
    }
    *specs = fs, *n = (int)nt, *data = d;
    fs = NULL;
    rc = MF_OK;
done:
    free(fs);
    free(buf);
    return rc;
}

int mf_ckpt_read_meta(const char *path, size_t max_len, char **meta) {
    int rc = mf_file_exists(path) ? mf_input_file(path, NULL) : MF_OK; /* a directory: refused by name */
    if (rc) return rc;
    FILE *f = fopen(path, "rb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot open checkpoint (%s)", path, strerror(errno));
    unsigned char h[MF_CKPT_HEADER];
    uint32_t nt = 0, mlen = 0;
    rc = header_check(path, h, fread(h, 1, sizeof h, f), &nt, &mlen);
    /* the meta length comes from the file: checked against the file's real length and max_len
     * before allocating */
    if (!rc) {
        long flen = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
        if (flen < 0 || fseek(f, MF_CKPT_HEADER, SEEK_SET) != 0) rc = mf_fail(MF_EIO, "%s: cannot seek", path);
        else if (mlen > max_len || (uint64_t)mlen > (uint64_t)flen - MF_CKPT_HEADER)
            rc = mf_fail(MF_EFORMAT, "%s: meta length %u exceeds the file (%ld bytes) or %zu bytes", path, mlen, flen,
                         max_len);
    }
    char *m = NULL;
    if (!rc) {
        m = malloc((size_t)mlen + 1);
        if (!m) rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        else if (fread(m, 1, mlen, f) != mlen) rc = mf_fail(MF_EFORMAT, "%s: truncated checkpoint (meta text)", path);
        else m[mlen] = 0;
    }
    fclose(f);
    if (rc) {
        free(m);
        return rc;
    }
    *meta = m;
    return MF_OK;
}

int mf_ckpt_load(const char *path, const MfTensorSpec *specs, int n, float *data, char **meta) {
    MfTensorSpec *fs = NULL;
    float *fd = NULL;
    char *fm = NULL;
    int nt = 0, rc = mf_ckpt_read(path, &fs, &nt, &fd, meta ? &fm : NULL);
    if (rc) return rc;
    if (nt != n) rc = mf_fail(MF_EFORMAT, "%s: tensor count %d in the file, the model has %d", path, nt, n);
    for (int i = 0; i < n && !rc; ++i) {
        if (strcmp(fs[i].name, specs[i].name) != 0) {
            rc = mf_fail(MF_EFORMAT, "%s: name mismatch at tensor %d: file has '%s', model expects '%s'",
                         path, i, fs[i].name, specs[i].name);
            break;
        }
        int same = fs[i].ndim == specs[i].ndim;
        for (int k = 0; same && k < fs[i].ndim; ++k) same = fs[i].shape[k] == specs[i].shape[k];
        if (!same) {
            char a[96], b[96];
            shape_str(a, sizeof a, fs[i].ndim, fs[i].shape);
            shape_str(b, sizeof b, specs[i].ndim, specs[i].shape);
            rc = mf_fail(MF_EFORMAT, "%s: shape mismatch for tensor '%s': file has %s, model expects %s",
                         path, specs[i].name, a, b);
        }
    }
    if (!rc) {
        memcpy(data, fd, mf_specs_numel(fs, nt) * sizeof(float));
        if (meta) *meta = fm, fm = NULL;
    }
    free(fm);
    free(fd);
    free(fs);
    return rc;
}
