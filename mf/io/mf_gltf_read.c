#include "io/mf_gltf_read.h"

#include <cJSON.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "io/mf_obj.h"
#include "scene/mf_tangent.h"

enum {
    GLB_MAGIC = 0x46546C67, /* "glTF" */
    GLB_JSON = 0x4E4F534A,  /* "JSON" */
    GLB_BIN = 0x004E4942,   /* "BIN\0" */
    C_BYTE = 5120, C_UBYTE = 5121, C_SHORT = 5122, C_USHORT = 5123, C_UINT = 5125, C_FLOAT = 5126,
    MAX_DEPTH = 256 /* node nesting */
};

typedef struct {
    const char *path;             /* borrowed; the file, for messages */
    char *file;                   /* owned; the whole file */
    size_t flen;
    cJSON *root;                  /* owned */
    int nbuf;
    unsigned char **buf_owned;    /* owned; (nbuf,) decoded data URIs / external files, or NULL */
    const unsigned char **buf;    /* (nbuf,) the bytes of each buffer */
    size_t *buflen;               /* (nbuf,) byteLength (checked against the bytes that exist) */
} Gltf;

/* A checked accessor: element i, component k lives at base + i * stride + k * csize. */
typedef struct {
    const unsigned char *base;
    size_t count, stride;
    int ncomp, ctype, csize, normalized;
} Acc;

/* The mesh being assembled. */
typedef struct {
    float *pos, *nrm, *uv; /* (cap_v, 3), (cap_v, 3), (cap_v, 2) */
    float *tan;            /* (cap_v, 4) TANGENT in our axes, w = +-1; w = 0: the primitive had none */
    uint32_t *tri;         /* (cap_t, 3) */
    int *mat;              /* (cap_t,) slot into used[] */
    size_t nv, nt, cap_v, cap_t;
    int all_nrm, any_uv, any_tan;
    int *used;             /* (nused,) glTF material index per slot, -1 = the default material */
    int nused;
    char *seen;            /* (nnodes,) nodes visited */
} Build;

static uint32_t rd32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

static const cJSON *item(const cJSON *o, const char *k) { return cJSON_GetObjectItemCaseSensitive(o, k); }

/* Element i of the top-level array `arr`, or an error naming it. */
static int element(const Gltf *g, const char *arr, long i, const char *from, const cJSON **out) {
    const cJSON *a = item(g->root, arr);
    int n = cJSON_IsArray(a) ? cJSON_GetArraySize(a) : 0;
    if (i < 0 || i >= n) return mf_fail(MF_EFORMAT, "%s: %s: %s[%ld] does not exist (%d in the file)", g->path, from, arr, i, n);
    const cJSON *e = cJSON_GetArrayItem(a, (int)i);
    if (!cJSON_IsObject(e)) return mf_fail(MF_EFORMAT, "%s: %s[%ld]: expected an object", g->path, arr, i);
    *out = e;
    return MF_OK;
}

/* An optional integer member in [lo, hi] (absent: dflt). */
static int jint(const Gltf *g, const char *where, const cJSON *o, const char *key, long dflt, long lo, long hi, long *out) {
    const cJSON *it = item(o, key);
    if (!it || cJSON_IsNull(it)) { *out = dflt; return MF_OK; }
    double v = cJSON_IsNumber(it) ? it->valuedouble : NAN;
    if (!(v >= (double)lo && v <= (double)hi) || v != floor(v))
        return mf_fail(MF_EFORMAT, "%s: %s.%s: expected an integer in [%ld, %ld]", g->path, where, key, lo, hi);
    *out = (long)v;
    return MF_OK;
}

/* Optional float array member of exactly n numbers (absent: out untouched). */
static int jfloats(const Gltf *g, const char *where, const cJSON *o, const char *key, int n, double *out) {
    const cJSON *it = item(o, key);
    if (!it || cJSON_IsNull(it)) return MF_OK;
    if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != n)
        return mf_fail(MF_EFORMAT, "%s: %s.%s: expected %d numbers", g->path, where, key, n);
    for (int i = 0; i < n; ++i) {
        const cJSON *e = cJSON_GetArrayItem(it, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
            return mf_fail(MF_EFORMAT, "%s: %s.%s[%d]: expected a finite number", g->path, where, key, i);
        out[i] = e->valuedouble;
    }
    return MF_OK;
}

static double jnum(const cJSON *o, const char *key, double dflt) {
    const cJSON *it = item(o, key);
    return cJSON_IsNumber(it) ? it->valuedouble : dflt;
}

/* ---- buffers ---- */

static int b64(int c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
}

/* Decodes base64 text (padding optional); *out (malloc'ed, at most 3/4 of the text) and *len. */
static int base64_decode(const Gltf *g, const char *where, const char *s, unsigned char **out, size_t *len) {
    size_t n = strlen(s);
    while (n > 0 && s[n - 1] == '=') --n;
    unsigned char *d = malloc(n / 4 * 3 + 3);
    if (!d) return mf_fail(MF_ENOMEM, "%s: %s: out of memory for a data URI of %zu characters", g->path, where, n);
    size_t o = 0;
    uint32_t acc = 0;
    int bits = 0;
    for (size_t i = 0; i < n; ++i) {
        int v = b64((unsigned char)s[i]);
        if (v < 0) { free(d); return mf_fail(MF_EFORMAT, "%s: %s: data URI: character %zu is not base64", g->path, where, i); }
        acc = acc << 6 | (uint32_t)v;
        if ((bits += 6) >= 8) {
            bits -= 8;
            d[o++] = (unsigned char)(acc >> bits);
        }
    }
    *out = d;
    *len = o;
    return MF_OK;
}

/* The bytes a uri names: a base64 data URI or a file relative to the glTF file's folder. *data is
 * malloc'ed. For a data URI, *mime (may be NULL) receives its media type ("" if none). */
static int load_uri(const Gltf *g, const char *where, const char *uri, unsigned char **data, size_t *len, char *mime, size_t mcap) {
    if (mime) mime[0] = 0;
    if (!strncmp(uri, "data:", 5)) {
        const char *comma = strchr(uri, ',');
        const char *semi = strstr(uri, ";base64,");
        if (!comma || !semi || semi + 7 != comma)
            return mf_fail(MF_EFORMAT, "%s: %s.uri: only base64 data URIs are supported", g->path, where);
        if (mime) snprintf(mime, mcap, "%.*s", (int)(semi - uri - 5), uri + 5);
        return base64_decode(g, where, comma + 1, data, len);
    }
    if (strstr(uri, "://") || uri[0] == '/' || !uri[0])
        return mf_fail(MF_EFORMAT, "%s: %s.uri: '%s': only files relative to the glTF file and data URIs are supported", g->path, where, uri);
    if (strchr(uri, '%'))
        return mf_fail(MF_EFORMAT, "%s: %s.uri: '%s': percent-encoded names are not supported", g->path, where, uri);
    char p[MF_PATH_MAX];
    const char *slash = strrchr(g->path, '/');
    int n = slash ? snprintf(p, sizeof p, "%.*s/%s", (int)(slash - g->path), g->path, uri) : snprintf(p, sizeof p, "%s", uri);
    if (n < 0 || (size_t)n >= sizeof p) return mf_fail(MF_EARG, "%s: %s.uri: path too long", g->path, where);
    char *d = NULL;
    int rc = mf_read_file(p, &d, len);
    if (rc) return mf_fail_prefix(rc, "%s: %s.uri", g->path, where);
    *data = (unsigned char *)d;
    return MF_OK;
}

static int load_buffers(Gltf *g, const unsigned char *bin, size_t binlen) {
    const cJSON *arr = item(g->root, "buffers");
    if (arr && !cJSON_IsArray(arr)) return mf_fail(MF_EFORMAT, "%s: buffers: expected an array", g->path);
    g->nbuf = arr ? cJSON_GetArraySize(arr) : 0;
    g->buf_owned = calloc((size_t)g->nbuf + 1, sizeof *g->buf_owned);
    g->buf = calloc((size_t)g->nbuf + 1, sizeof *g->buf);
    g->buflen = calloc((size_t)g->nbuf + 1, sizeof *g->buflen);
    if (!g->buf_owned || !g->buf || !g->buflen) return mf_fail(MF_ENOMEM, "%s: out of memory", g->path);
    for (int i = 0; i < g->nbuf; ++i) {
        char w[64];
        snprintf(w, sizeof w, "buffers[%d]", i);
        const cJSON *b = cJSON_GetArrayItem(arr, i);
        long bl;
        int rc = cJSON_IsObject(b) ? MF_OK : mf_fail(MF_EFORMAT, "%s: %s: expected an object", g->path, w);
        if (!rc && !item(b, "byteLength")) rc = mf_fail(MF_EFORMAT, "%s: %s.byteLength: missing", g->path, w);
        if (!rc) rc = jint(g, w, b, "byteLength", 0, 1, 0x7fffffffffffL, &bl);
        if (rc) return rc;
        const char *uri = cJSON_GetStringValue(item(b, "uri"));
        size_t have = 0;
        if (uri) {
            if ((rc = load_uri(g, w, uri, &g->buf_owned[i], &have, NULL, 0))) return rc;
            g->buf[i] = g->buf_owned[i];
        } else if (i == 0 && bin) {
            g->buf[i] = bin;
            have = binlen;
        } else {
            return mf_fail(MF_EFORMAT, "%s: %s: no uri and no BIN chunk to take its bytes from (missing buffer)", g->path, w);
        }
        if ((size_t)bl > have)
            return mf_fail(MF_EFORMAT, "%s: %s.byteLength = %ld but only %zu bytes exist (truncated or missing data)", g->path, w, bl, have);
        g->buflen[i] = (size_t)bl;
    }
    return MF_OK;
}

/* Bytes of bufferViews[v]: *data, *len, *stride (0 when absent). */
static int buffer_view(const Gltf *g, long v, const char *from, const unsigned char **data, size_t *len, size_t *stride) {
    const cJSON *bv;
    char w[64];
    snprintf(w, sizeof w, "bufferViews[%ld]", v);
    long b, off, l, st;
    int rc = element(g, "bufferViews", v, from, &bv);
    if (!rc) rc = jint(g, w, bv, "buffer", -1, 0, 0x7fffffffL, &b);
    if (!rc) rc = jint(g, w, bv, "byteOffset", 0, 0, 0x7fffffffffffL, &off);
    if (!rc) rc = jint(g, w, bv, "byteLength", -1, 1, 0x7fffffffffffL, &l);
    if (!rc) rc = jint(g, w, bv, "byteStride", 0, 4, 252, &st);
    if (rc) return rc;
    if (b < 0 || l < 0) return mf_fail(MF_EFORMAT, "%s: %s: buffer and byteLength are required", g->path, w);
    if (b >= g->nbuf) return mf_fail(MF_EFORMAT, "%s: %s.buffer = %ld does not exist (%d buffers)", g->path, w, b, g->nbuf);
    if ((size_t)off > g->buflen[b] || (size_t)l > g->buflen[b] - (size_t)off)
        return mf_fail(MF_EFORMAT, "%s: %s: bytes %ld..%ld are outside buffers[%ld] (%zu bytes)", g->path, w, off, off + l, b, g->buflen[b]);
    *data = g->buf[b] + off;
    *len = (size_t)l;
    if (stride) *stride = (size_t)st;
    return MF_OK;
}

/* accessors[a], checked: every element lies inside its bufferView. */
static int accessor(const Gltf *g, long a, const char *from, Acc *out) {
    const cJSON *ac;
    char w[64];
    snprintf(w, sizeof w, "accessors[%ld]", a);
    int rc = element(g, "accessors", a, from, &ac);
    if (rc) return rc;
    if (item(ac, "sparse")) return mf_fail(MF_EFORMAT, "%s: %s: sparse accessors are not supported", g->path, w);
    long view, off, ct, count;
    if ((rc = jint(g, w, ac, "bufferView", -1, 0, 0x7fffffffL, &view)) || (rc = jint(g, w, ac, "byteOffset", 0, 0, 0x7fffffffffffL, &off)) ||
        (rc = jint(g, w, ac, "componentType", 0, 0, 0xffff, &ct)) || (rc = jint(g, w, ac, "count", 0, 1, 0x7fffffffL, &count)))
        return rc;
    if (view < 0) return mf_fail(MF_EFORMAT, "%s: %s: no bufferView (all-zero accessors are not supported)", g->path, w);
    const char *type = cJSON_GetStringValue(item(ac, "type"));
    int nc = !type ? 0 : !strcmp(type, "SCALAR") ? 1 : !strcmp(type, "VEC2") ? 2 : !strcmp(type, "VEC3") ? 3 : !strcmp(type, "VEC4") ? 4 : 0;
    if (!nc) return mf_fail(MF_EFORMAT, "%s: %s.type: '%s' is not SCALAR or VEC2..4", g->path, w, type ? type : "(missing)");
    int cs = ct == C_BYTE || ct == C_UBYTE ? 1 : ct == C_SHORT || ct == C_USHORT ? 2 : ct == C_UINT || ct == C_FLOAT ? 4 : 0;
    if (!cs) return mf_fail(MF_EFORMAT, "%s: %s.componentType: %ld is not a glTF component type", g->path, w, ct);
    const unsigned char *vd;
    size_t vl, stride, esize = (size_t)nc * (size_t)cs;
    if ((rc = buffer_view(g, view, w, &vd, &vl, &stride))) return rc;
    if (!stride) stride = esize;
    if (stride < esize) return mf_fail(MF_EFORMAT, "%s: %s: byteStride %zu is smaller than an element (%zu bytes)", g->path, w, stride, esize);
    /* off + (count - 1) * stride + esize <= vl, without overflow */
    if ((size_t)off > vl || esize > vl - (size_t)off || (size_t)(count - 1) > (vl - (size_t)off - esize) / stride)
        return mf_fail(MF_EFORMAT, "%s: %s: %ld elements of %zu bytes (stride %zu) at offset %ld do not fit bufferViews[%ld] (%zu bytes)",
                       g->path, w, count, esize, stride, off, view, vl);
    out->base = vd + off;
    out->count = (size_t)count;
    out->stride = stride;
    out->ncomp = nc;
    out->ctype = (int)ct;
    out->csize = cs;
    out->normalized = cJSON_IsTrue(item(ac, "normalized"));
    return MF_OK;
}

/* Component k of element i as a float (float, or normalised unsigned integers). */
static float acc_f(const Acc *a, size_t i, int k) {
    const unsigned char *p = a->base + i * a->stride + (size_t)k * (size_t)a->csize;
    if (a->ctype == C_FLOAT) { float f; memcpy(&f, p, 4); return f; }
    if (a->ctype == C_UBYTE) return p[0] / 255.0f;
    uint16_t u;
    memcpy(&u, p, 2);
    return u / 65535.0f;
}

static uint32_t acc_u(const Acc *a, size_t i) {
    const unsigned char *p = a->base + i * a->stride;
    if (a->ctype == C_UBYTE) return p[0];
    if (a->ctype == C_USHORT) { uint16_t u; memcpy(&u, p, 2); return u; }
    uint32_t u;
    memcpy(&u, p, 4);
    return u;
}

/* An attribute accessor of the expected shape: float VECn (uv: also normalised ubyte/ushort). */
static int attribute(const Gltf *g, const cJSON *attrs, const char *name, const char *where, int ncomp, int uv, size_t count, Acc *a, int *present) {
    char w[160];
    snprintf(w, sizeof w, "%s.attributes.%s", where, name);
    long idx;
    int rc = jint(g, w, attrs, name, -1, 0, 0x7fffffffL, &idx);
    *present = 0;
    if (rc || idx < 0) return rc;
    if ((rc = accessor(g, idx, w, a))) return rc;
    int ok_type = a->ctype == C_FLOAT || (uv && a->normalized && (a->ctype == C_UBYTE || a->ctype == C_USHORT));
    if (a->ncomp != ncomp || !ok_type)
        return mf_fail(MF_EFORMAT, "%s: %s: accessors[%ld] must be %s VEC%d", g->path, w, idx, uv ? "float or normalised unsigned" : "float", ncomp);
    if (count && a->count != count)
        return mf_fail(MF_EFORMAT, "%s: %s: %zu elements, but POSITION has %zu", g->path, w, a->count, count);
    *present = 1;
    return MF_OK;
}

/* ---- node transforms (double, column vectors, m[row * 4 + col]) ---- */

static void mat_mul(const double *a, const double *b, double *o) {
    double t[16];
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            double s = 0;
            for (int k = 0; k < 4; ++k) s += a[r * 4 + k] * b[k * 4 + c];
            t[r * 4 + c] = s;
        }
    memcpy(o, t, sizeof t);
}

static int local_matrix(const Gltf *g, const char *w, const cJSON *node, double *m) {
    double cm[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    int rc;
    if (item(node, "matrix")) {
        if ((rc = jfloats(g, w, node, "matrix", 16, cm))) return rc;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m[r * 4 + c] = cm[c * 4 + r]; /* glTF stores column-major */
        return MF_OK;
    }
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    if ((rc = jfloats(g, w, node, "translation", 3, t)) || (rc = jfloats(g, w, node, "rotation", 4, q)) || (rc = jfloats(g, w, node, "scale", 3, s)))
        return rc;
    double ql = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(ql > 1e-12)) return mf_fail(MF_EFORMAT, "%s: %s.rotation: not a unit quaternion", g->path, w);
    double x = q[0] / ql, y = q[1] / ql, z = q[2] / ql, ww = q[3] / ql;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * ww), 2 * (x * z + y * ww),
                   2 * (x * y + z * ww), 1 - 2 * (x * x + z * z), 2 * (y * z - x * ww),
                   2 * (x * z - y * ww), 2 * (y * z + x * ww), 1 - 2 * (x * x + y * y)};
    memset(m, 0, 16 * sizeof *m);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m[i * 4 + j] = r[i * 3 + j] * s[j];
        m[i * 4 + 3] = t[i];
    }
    m[15] = 1;
    return MF_OK;
}

/* ---- assembling the mesh ---- */

static int grow(const Gltf *g, Build *b, size_t nv, size_t nt) {
    if (nv > MF_GLTF_MAX_ELEMENTS - b->nv || nt > MF_GLTF_MAX_ELEMENTS - b->nt)
        return mf_fail(MF_EFORMAT, "%s: the scene has more than %d vertices or triangles (instanced meshes included)", g->path, MF_GLTF_MAX_ELEMENTS);
    if (b->nv + nv > b->cap_v) {
        size_t cap = b->cap_v * 2 > b->nv + nv ? b->cap_v * 2 : b->nv + nv;
        float *p = realloc(b->pos, cap * 3 * sizeof(float) + 1), *n = p ? realloc(b->nrm, cap * 3 * sizeof(float) + 1) : NULL;
        if (p) b->pos = p;
        if (n) b->nrm = n;
        float *u = n ? realloc(b->uv, cap * 2 * sizeof(float) + 1) : NULL;
        if (u) b->uv = u;
        float *tg = u ? realloc(b->tan, cap * 4 * sizeof(float) + 1) : NULL;
        if (tg) b->tan = tg;
        if (!tg) return mf_fail(MF_ENOMEM, "%s: out of memory for %zu vertices", g->path, cap);
        b->cap_v = cap;
    }
    if (b->nt + nt > b->cap_t) {
        size_t cap = b->cap_t * 2 > b->nt + nt ? b->cap_t * 2 : b->nt + nt;
        uint32_t *t = realloc(b->tri, cap * 3 * sizeof(uint32_t) + 1);
        if (t) b->tri = t;
        int *m = t ? realloc(b->mat, cap * sizeof(int) + 1) : NULL;
        if (m) b->mat = m;
        if (!m) return mf_fail(MF_ENOMEM, "%s: out of memory for %zu triangles", g->path, cap);
        b->cap_t = cap;
    }
    return MF_OK;
}

/* glTF +Y up to our +Z up: (x, y, z) -> (x, -z, y), the inverse of mf_gltf_write_glb's. */
static void to_z_up(const double *v, float *o) {
    o[0] = (float)v[0];
    o[1] = (float)-v[2];
    o[2] = (float)v[1];
}

static int material_slot(const Gltf *g, Build *b, long m) {
    for (int i = 0; i < b->nused; ++i)
        if (b->used[i] == m) return i;
    int *u = realloc(b->used, (size_t)(b->nused + 1) * sizeof(int));
    if (!u) return mf_fail(MF_ENOMEM, "%s: out of memory", g->path);
    b->used = u;
    b->used[b->nused] = (int)m;
    return b->nused++;
}

static int add_primitive(const Gltf *g, Build *b, const cJSON *prim, const char *w, const double *M) {
    if (!cJSON_IsObject(prim)) return mf_fail(MF_EFORMAT, "%s: %s: expected an object", g->path, w);
    long mode, mat, ind;
    int rc;
    if ((rc = jint(g, w, prim, "mode", 4, 0, 6, &mode)) || (rc = jint(g, w, prim, "material", -1, 0, 0x7fffffffL, &mat)) ||
        (rc = jint(g, w, prim, "indices", -1, 0, 0x7fffffffL, &ind)))
        return rc;
    if (mode != 4) return mf_fail(MF_EFORMAT, "%s: %s.mode = %ld: only triangles (4) are supported", g->path, w, mode);
    const cJSON *attrs = item(prim, "attributes");
    if (!cJSON_IsObject(attrs)) return mf_fail(MF_EFORMAT, "%s: %s.attributes: expected an object", g->path, w);
    Acc P, N, T, I, TG;
    int hp, hn, ht, htg;
    if ((rc = attribute(g, attrs, "POSITION", w, 3, 0, 0, &P, &hp))) return rc;
    if (!hp) return mf_fail(MF_EFORMAT, "%s: %s.attributes.POSITION: missing", g->path, w);
    if ((rc = attribute(g, attrs, "NORMAL", w, 3, 0, P.count, &N, &hn)) || (rc = attribute(g, attrs, "TEXCOORD_0", w, 2, 1, P.count, &T, &ht)) ||
        (rc = attribute(g, attrs, "TANGENT", w, 4, 0, P.count, &TG, &htg)))
        return rc;
    size_t nidx = P.count;
    if (ind >= 0) {
        char wi[160];
        snprintf(wi, sizeof wi, "%s.indices", w);
        if ((rc = accessor(g, ind, wi, &I))) return rc;
        if (I.ncomp != 1 || !(I.ctype == C_UBYTE || I.ctype == C_USHORT || I.ctype == C_UINT))
            return mf_fail(MF_EFORMAT, "%s: %s: accessors[%ld] must be unsigned byte/short/int SCALAR", g->path, wi, ind);
        nidx = I.count;
    }
    if (nidx % 3) return mf_fail(MF_EFORMAT, "%s: %s: %zu indices is not a multiple of 3", g->path, w, nidx);
    if ((rc = grow(g, b, P.count, nidx / 3))) return rc;
    int slot = material_slot(g, b, mat);
    if (slot < 0) return slot;

    /* normals: the inverse transpose of the upper 3x3 (its cofactor matrix; the scale drops out) */
    const double a = M[0], bb = M[1], c = M[2], d = M[4], e = M[5], f = M[6], gg = M[8], h = M[9], k = M[10];
    const double C[9] = {e * k - f * h, f * gg - d * k, d * h - e * gg, c * h - bb * k, a * k - c * gg, bb * gg - a * h,
                         bb * f - c * e, c * d - a * f, a * e - bb * d};
    double det = a * C[0] + bb * C[1] + c * C[2];
    size_t v0 = b->nv;
    for (size_t i = 0; i < P.count; ++i) {
        double p[3], q[3];
        for (int j = 0; j < 3; ++j) p[j] = acc_f(&P, i, j);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return mf_fail(MF_ENAN, "%s: %s.attributes.POSITION: vertex %zu is not finite", g->path, w, i);
        for (int j = 0; j < 3; ++j) q[j] = M[j * 4] * p[0] + M[j * 4 + 1] * p[1] + M[j * 4 + 2] * p[2] + M[j * 4 + 3];
        if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]) || fabs(q[0]) > 1e18 || fabs(q[1]) > 1e18 || fabs(q[2]) > 1e18)
            return mf_fail(MF_ENAN, "%s: %s: vertex %zu is out of range (|x| > 1e18) after its node transforms", g->path, w, i);
        to_z_up(q, b->pos + 3 * (v0 + i));
        float *no = b->nrm + 3 * (v0 + i);
        if (hn) {
            double n[3], m[3];
            for (int j = 0; j < 3; ++j) n[j] = acc_f(&N, i, j);
            for (int j = 0; j < 3; ++j) m[j] = C[j * 3] * n[0] + C[j * 3 + 1] * n[1] + C[j * 3 + 2] * n[2];
            if (det < 0) m[0] = -m[0], m[1] = -m[1], m[2] = -m[2]; /* the cofactor matrix is det x inverse transpose */
            double l = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
            if (!isfinite(l)) return mf_fail(MF_ENAN, "%s: %s.attributes.NORMAL: normal %zu is not finite", g->path, w, i);
            if (l > 0) m[0] /= l, m[1] /= l, m[2] /= l;
            else m[0] = 0, m[1] = 1, m[2] = 0;
            to_z_up(m, no);
        } else {
            no[0] = no[1] = no[2] = 0.0f;
        }
        float *tg = b->tan + 4 * (v0 + i);
        tg[0] = tg[1] = tg[2] = tg[3] = 0.0f;
        if (htg) { /* a surface direction: the node matrix itself; a mirror flips the handedness */
            double t[4], m[3];
            for (int j = 0; j < 4; ++j) t[j] = acc_f(&TG, i, j);
            for (int j = 0; j < 3; ++j) m[j] = M[j * 4] * t[0] + M[j * 4 + 1] * t[1] + M[j * 4 + 2] * t[2];
            double l = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
            if (!isfinite(l) || !isfinite(t[3])) return mf_fail(MF_ENAN, "%s: %s.attributes.TANGENT: tangent %zu is not finite", g->path, w, i);
            if (l > 0) {
                m[0] /= l, m[1] /= l, m[2] /= l;
                to_z_up(m, tg);
                tg[3] = (t[3] < 0) != (det < 0) ? -1.0f : 1.0f;
            }
        }
        float *uv = b->uv + 2 * (v0 + i);
        uv[0] = ht ? acc_f(&T, i, 0) : 0.0f;
        uv[1] = ht ? 1.0f - acc_f(&T, i, 1) : 0.0f;
        if (!isfinite(uv[0]) || !isfinite(uv[1])) return mf_fail(MF_ENAN, "%s: %s.attributes.TEXCOORD_0: %zu is not finite", g->path, w, i);
    }
    for (size_t t = 0; t < nidx / 3; ++t) {
        uint32_t f3[3];
        for (int j = 0; j < 3; ++j) {
            size_t n = 3 * t + (size_t)j;
            f3[j] = ind >= 0 ? acc_u(&I, n) : (uint32_t)n;
            if (f3[j] >= P.count)
                return mf_fail(MF_EFORMAT, "%s: %s.indices: index %zu = %u is out of range (POSITION has %zu vertices)", g->path, w, n, f3[j], P.count);
        }
        uint32_t *o = b->tri + 3 * (b->nt + t);
        o[0] = (uint32_t)v0 + f3[0];
        o[1] = (uint32_t)v0 + (det < 0 ? f3[2] : f3[1]);
        o[2] = (uint32_t)v0 + (det < 0 ? f3[1] : f3[2]);
        b->mat[b->nt + t] = slot;
    }
    b->nv += P.count;
    b->nt += nidx / 3;
    b->all_nrm &= hn;
    b->any_uv |= ht;
    b->any_tan |= htg;
    return MF_OK;
}

static int visit(const Gltf *g, Build *b, long n, const double *parent, int depth, const char *from) {
    const cJSON *node;
    char w[64];
    snprintf(w, sizeof w, "nodes[%ld]", n);
    int rc = element(g, "nodes", n, from, &node);
    if (rc) return rc;
    if (b->seen[n]) return mf_fail(MF_EFORMAT, "%s: %s is reached twice (a cycle, or a node with two parents)", g->path, w);
    if (depth > MAX_DEPTH) return mf_fail(MF_EFORMAT, "%s: %s: nodes nested deeper than %d", g->path, w, MAX_DEPTH);
    b->seen[n] = 1;
    double local[16], M[16];
    if ((rc = local_matrix(g, w, node, local))) return rc;
    mat_mul(parent, local, M);
    long mesh;
    if ((rc = jint(g, w, node, "mesh", -1, 0, 0x7fffffffL, &mesh))) return rc;
    if (mesh >= 0) {
        const cJSON *me;
        char wm[64];
        snprintf(wm, sizeof wm, "meshes[%ld]", mesh);
        if ((rc = element(g, "meshes", mesh, w, &me))) return rc;
        const cJSON *prims = item(me, "primitives");
        if (!cJSON_IsArray(prims)) return mf_fail(MF_EFORMAT, "%s: %s.primitives: expected an array", g->path, wm);
        int np = cJSON_GetArraySize(prims);
        for (int i = 0; i < np && !rc; ++i) {
            char wp[96];
            snprintf(wp, sizeof wp, "%s.primitives[%d]", wm, i);
            rc = add_primitive(g, b, cJSON_GetArrayItem(prims, i), wp, M);
        }
        if (rc) return rc;
    }
    const cJSON *kids = item(node, "children");
    if (kids && !cJSON_IsArray(kids)) return mf_fail(MF_EFORMAT, "%s: %s.children: expected an array", g->path, w);
    for (int i = 0; kids && i < cJSON_GetArraySize(kids) && !rc; ++i) {
        const cJSON *k = cJSON_GetArrayItem(kids, i);
        if (!cJSON_IsNumber(k) || !(k->valuedouble >= -1 && k->valuedouble <= 0x7fffffff)) /* (visit names one out of range) */
            return mf_fail(MF_EFORMAT, "%s: %s.children[%d]: expected a node index", g->path, w, i);
        rc = visit(g, b, (long)k->valuedouble, M, depth + 1, w);
    }
    return rc;
}

/* The root nodes: scenes[scene] (default 0), or without scenes every node nobody lists as a child. */
static int build_mesh(const Gltf *g, Build *b) {
    const cJSON *nodes = item(g->root, "nodes");
    int nn = cJSON_IsArray(nodes) ? cJSON_GetArraySize(nodes) : 0;
    if (!(b->seen = calloc((size_t)nn + 1, 1))) return mf_fail(MF_ENOMEM, "%s: out of memory", g->path);
    const double I4[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    b->all_nrm = 1;
    int rc = MF_OK;
    const cJSON *scenes = item(g->root, "scenes");
    if (cJSON_IsArray(scenes) && cJSON_GetArraySize(scenes) > 0) {
        long s;
        const cJSON *sc;
        if ((rc = jint(g, "", g->root, "scene", 0, 0, 0x7fffffffL, &s)) || (rc = element(g, "scenes", s, "scene", &sc))) return rc;
        const cJSON *roots = item(sc, "nodes");
        for (int i = 0; cJSON_IsArray(roots) && i < cJSON_GetArraySize(roots) && !rc; ++i) {
            const cJSON *r = cJSON_GetArrayItem(roots, i);
            if (!cJSON_IsNumber(r) || !(r->valuedouble >= -1 && r->valuedouble <= 0x7fffffff))
                return mf_fail(MF_EFORMAT, "%s: scenes[%ld].nodes[%d]: expected a node index", g->path, s, i);
            rc = visit(g, b, (long)r->valuedouble, I4, 0, "scenes");
        }
    } else {
        char *child = calloc((size_t)nn + 1, 1);
        if (!child) return mf_fail(MF_ENOMEM, "%s: out of memory", g->path);
        for (int i = 0; i < nn; ++i) {
            const cJSON *kids = item(cJSON_GetArrayItem(nodes, i), "children");
            for (int j = 0; cJSON_IsArray(kids) && j < cJSON_GetArraySize(kids); ++j) {
                const cJSON *k = cJSON_GetArrayItem(kids, j);
                if (cJSON_IsNumber(k) && k->valuedouble >= 0 && k->valuedouble < nn) child[(int)k->valuedouble] = 1;
            }
        }
        for (int i = 0; i < nn && !rc; ++i)
            if (!child[i]) rc = visit(g, b, i, I4, 0, "nodes");
        free(child);
    }
    if (!rc && b->nt == 0) rc = mf_fail(MF_EFORMAT, "%s: the scene has no triangles (no node refers to a mesh)", g->path);
    return rc;
}

/* ---- materials ---- */

/* images[i] decoded (3 channels: grey replicated, alpha dropped). */
static int image(const Gltf *g, long i, const char *from, MfEncoding enc, MfImage *out) {
    const cJSON *im;
    char w[64], name[MF_PATH_MAX + 64], mime[64] = "";
    snprintf(w, sizeof w, "images[%ld]", i);
    int rc = element(g, "images", i, from, &im);
    if (rc) return rc;
    const char *uri = cJSON_GetStringValue(item(im, "uri"));
    const char *mt = cJSON_GetStringValue(item(im, "mimeType"));
    unsigned char *owned = NULL;
    const unsigned char *bytes = NULL;
    size_t len = 0;
    long view;
    if ((rc = jint(g, w, im, "bufferView", -1, 0, 0x7fffffffL, &view))) return rc;
    if (view >= 0) {
        if ((rc = buffer_view(g, view, w, &bytes, &len, NULL))) return rc;
    } else if (uri) {
        if ((rc = load_uri(g, w, uri, &owned, &len, mime, sizeof mime))) return rc;
        bytes = owned;
        if (!mime[0]) { /* a file: its extension */
            char ext[16];
            mf_path_ext(uri, ext, sizeof ext);
            snprintf(mime, sizeof mime, "%s", !strcmp(ext, "png") ? "image/png" : !strcmp(ext, "jpg") || !strcmp(ext, "jpeg") ? "image/jpeg" : ext);
        }
    } else {
        return mf_fail(MF_EFORMAT, "%s: %s: neither bufferView nor uri", g->path, w);
    }
    if (mt && !mime[0]) snprintf(mime, sizeof mime, "%s", mt);
    const char *ext = !strcmp(mime, "image/png") ? "png" : !strcmp(mime, "image/jpeg") ? "jpg" : NULL;
    if (!ext) {
        free(owned);
        return mf_fail(MF_EFORMAT, "%s: %s: image type '%s' is not supported (PNG or JPEG)", g->path, w, mime[0] ? mime : "(no mimeType)");
    }
    snprintf(name, sizeof name, "%s: %s", g->path, w);
    MfImage raw;
    rc = mf_image_decode(name, bytes, len, ext, enc, &raw);
    free(owned);
    if (rc) return rc;
    if ((rc = mf_image_alloc(out, raw.w, raw.h, 3))) { mf_image_free(&raw); return rc; }
    for (size_t p = 0; p < (size_t)raw.w * raw.h; ++p)
        for (int k = 0; k < 3; ++k) out->data[3 * p + k] = raw.data[p * raw.c + (raw.c >= 3 ? k : 0)];
    mf_image_free(&raw);
    return MF_OK;
}

/* The image a textureInfo binds (present: *has = 1), refusing texCoord sets other than 0. */
static int texture(const Gltf *g, const cJSON *holder, const char *key, const char *where, MfEncoding enc, MfImage *out, int *has) {
    const cJSON *ti = item(holder, key);
    *has = 0;
    if (!ti || cJSON_IsNull(ti)) return MF_OK;
    char w[160];
    snprintf(w, sizeof w, "%s.%s", where, key);
    if (!cJSON_IsObject(ti)) return mf_fail(MF_EFORMAT, "%s: %s: expected an object", g->path, w);
    long idx, set, src;
    const cJSON *tex;
    int rc;
    if ((rc = jint(g, w, ti, "index", -1, 0, 0x7fffffffL, &idx)) || (rc = jint(g, w, ti, "texCoord", 0, 0, 0x7fffffffL, &set))) return rc;
    if (set != 0) return mf_fail(MF_EFORMAT, "%s: %s.texCoord = %ld: only TEXCOORD_0 is supported", g->path, w, set);
    if ((rc = element(g, "textures", idx, w, &tex))) return rc;
    char wt[64];
    snprintf(wt, sizeof wt, "textures[%ld]", idx);
    if ((rc = jint(g, wt, tex, "source", -1, 0, 0x7fffffffL, &src))) return rc;
    if (src < 0) return mf_fail(MF_EFORMAT, "%s: %s: no source image (images from extensions are not supported)", g->path, wt);
    if ((rc = image(g, src, wt, enc, out))) return rc;
    *has = 1;
    return MF_OK;
}

/* Bilinear sample of channel ch of img at continuous texel coordinates (x, y), clamped. */
static float sample(const MfImage *img, float x, float y, int ch) {
    x = fminf(fmaxf(x, 0.0f), (float)(img->w - 1));
    y = fminf(fmaxf(y, 0.0f), (float)(img->h - 1));
    int x0 = (int)x, y0 = (int)y, x1 = x0 + 1 < img->w ? x0 + 1 : x0, y1 = y0 + 1 < img->h ? y0 + 1 : y0;
    float fx = x - (float)x0, fy = y - (float)y0;
    float a = mf_image_px(img, x0, y0)[ch], b = mf_image_px(img, x1, y0)[ch];
    float c = mf_image_px(img, x0, y1)[ch], d = mf_image_px(img, x1, y1)[ch];
    return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy;
}

/* Appends ", what" (or "what" first) to the list in buf (cap bytes), truncating with "...". */
static void add_item(char *buf, size_t cap, const char *what) {
    size_t l = strlen(buf);
    if (l + 8 >= cap) return;
    int n = snprintf(buf + l, cap - l, "%s%s", l ? ", " : "", what);
    if (n < 0 || (size_t)n >= cap - l) snprintf(buf + cap - 4, 4, "...");
}

/* What of material mo changes the look but is not rendered: emission, transparency, texture
 * transforms, KHR_materials_* and other material extensions; listed in out (cap bytes, "" = none). */
static void unrendered(const cJSON *mo, char *out, size_t cap) {
    out[0] = 0;
    double e[3] = {0, 0, 0};
    const cJSON *ef = item(mo, "emissiveFactor");
    for (int k = 0; k < 3 && cJSON_IsArray(ef); ++k) {
        const cJSON *x = cJSON_GetArrayItem(ef, k);
        e[k] = cJSON_IsNumber(x) ? x->valuedouble : 0;
    }
    int emissive = e[0] != 0 || e[1] != 0 || e[2] != 0;
    if (emissive) add_item(out, cap, "emissiveFactor");
    if (item(mo, "emissiveTexture")) add_item(out, cap, emissive ? "emissiveTexture" : "emissiveTexture (emissiveFactor 0: dark)");
    const char *am = cJSON_GetStringValue(item(mo, "alphaMode"));
    if (am && strcmp(am, "OPAQUE")) {
        char t[64];
        snprintf(t, sizeof t, "alphaMode %.16s", am);
        add_item(out, cap, t);
    }
    const cJSON *ex = item(mo, "extensions");
    for (const cJSON *x = cJSON_IsObject(ex) ? ex->child : NULL; x; x = x->next) add_item(out, cap, x->string);
    const cJSON *pbr = item(mo, "pbrMetallicRoughness");
    const cJSON *tis[5] = {item(pbr, "baseColorTexture"), item(pbr, "metallicRoughnessTexture"), item(mo, "occlusionTexture"),
                           item(mo, "normalTexture"), item(mo, "emissiveTexture")};
    for (int i = 0; i < 5; ++i) {
        const cJSON *tx = item(tis[i], "extensions");
        for (const cJSON *x = cJSON_IsObject(tx) ? tx->child : NULL; x; x = x->next) {
            char t[96];
            snprintf(t, sizeof t, "%.64s on a texture", x->string ? x->string : "?");
            if (!strstr(out, t)) add_item(out, cap, t);
        }
    }
}

static int material(const Gltf *g, long m, int slot, MfGltfPbr *out) {
    const cJSON *mo = NULL;
    char w[64];
    snprintf(w, sizeof w, "materials[%ld]", m);
    int rc = m >= 0 ? element(g, "materials", m, "a primitive", &mo) : MF_OK;
    if (rc) return rc;
    const char *nm = cJSON_GetStringValue(item(mo, "name"));
    if (nm && nm[0]) snprintf(out->name, sizeof out->name, "%s", nm);
    else snprintf(out->name, sizeof out->name, "material_%d", slot);
    const cJSON *pbr = item(mo, "pbrMetallicRoughness");
    char wp[96];
    snprintf(wp, sizeof wp, "%s.pbrMetallicRoughness", w);
    double bc[4] = {1, 1, 1, 1}, metal = jnum(pbr, "metallicFactor", 1.0), rough = jnum(pbr, "roughnessFactor", 1.0);
    double occ_strength = jnum(item(mo, "occlusionTexture"), "strength", 1.0);
    if ((rc = jfloats(g, wp, pbr, "baseColorFactor", 4, bc))) return rc;
    if (!isfinite(metal) || !isfinite(rough) || !isfinite(occ_strength))
        return mf_fail(MF_EFORMAT, "%s: %s: metallicFactor, roughnessFactor and occlusion strength must be finite", g->path, w);
    MfImage mr = {0}, occ = {0};
    int has_bc, has_mr, has_occ;
    if ((rc = texture(g, pbr, "baseColorTexture", wp, MF_ENC_SRGB, &out->albedo, &has_bc))) return rc;
    if (!has_bc && (rc = mf_image_alloc(&out->albedo, 1, 1, 3))) return rc;
    for (size_t p = 0; p < (size_t)out->albedo.w * out->albedo.h; ++p)
        for (int k = 0; k < 3; ++k) out->albedo.data[3 * p + k] = (has_bc ? out->albedo.data[3 * p + k] : 1.0f) * (float)bc[k];
    out->albedo_textured = has_bc;
    if ((rc = texture(g, pbr, "metallicRoughnessTexture", wp, MF_ENC_LINEAR, &mr, &has_mr)) ||
        (rc = texture(g, mo, "occlusionTexture", w, MF_ENC_LINEAR, &occ, &has_occ))) {
        mf_image_free(&mr);
        return rc;
    }
    const MfImage *size = has_mr ? &mr : has_occ ? &occ : NULL;
    if ((rc = mf_image_alloc(&out->orm, size ? size->w : 1, size ? size->h : 1, 3))) goto done;
    for (int y = 0; y < out->orm.h; ++y)
        for (int x = 0; x < out->orm.w; ++x) {
            float *o = mf_image_px(&out->orm, x, y);
            float r = 1.0f;
            if (has_occ) {
                float ox = (x + 0.5f) * (float)occ.w / (float)out->orm.w - 0.5f, oy = (y + 0.5f) * (float)occ.h / (float)out->orm.h - 0.5f;
                float t = occ.w == out->orm.w && occ.h == out->orm.h ? mf_image_px(&occ, x, y)[0] : sample(&occ, ox, oy, 0);
                r = 1.0f + (float)occ_strength * (t - 1.0f);
            }
            o[0] = r;
            o[1] = (has_mr ? mf_image_px(&mr, x, y)[1] : 1.0f) * (float)rough;
            o[2] = (has_mr ? mf_image_px(&mr, x, y)[2] : 1.0f) * (float)metal;
        }
    out->orm_textured = has_mr || has_occ;
    /* normalTexture: linear, texCoord 0; scale s: n = normalize((2 v - 1) * (s, s, 1)) */
    const cJSON *nt = item(mo, "normalTexture");
    const cJSON *ns = item(nt, "scale");
    double nscale = ns ? (cJSON_IsNumber(ns) ? ns->valuedouble : NAN) : 1.0;
    if (!isfinite(nscale)) { rc = mf_fail(MF_EFORMAT, "%s: %s.normalTexture.scale: expected a finite number", g->path, w); goto done; }
    if ((rc = texture(g, mo, "normalTexture", w, MF_ENC_LINEAR, &out->normal, &out->has_normal))) goto done;
    out->normal_scale = (float)nscale;
    if (out->has_normal && nscale != 1.0)
        for (size_t p = 0; p < (size_t)out->normal.w * out->normal.h; ++p) {
            float *v = out->normal.data + 3 * p;
            double t[3] = {(2.0 * v[0] - 1.0) * nscale, (2.0 * v[1] - 1.0) * nscale, 2.0 * v[2] - 1.0};
            double l = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
            if (l > 0)
                for (int k = 0; k < 3; ++k) v[k] = (float)(0.5 * (t[k] / l + 1.0));
        }
    unrendered(mo, out->unrendered, sizeof out->unrendered);
    if (out->unrendered[0])
        mf_log_warn("%s: material '%s': not rendered: %s (renders of this asset, ground truth included, lack it)", g->path, out->name,
                    out->unrendered);
done:
    mf_image_free(&mr);
    mf_image_free(&occ);
    return rc;
}

/* ---- the file ---- */

static int parse_container(Gltf *g, const unsigned char **bin, size_t *binlen) {
    const unsigned char *d = (const unsigned char *)g->file;
    *bin = NULL;
    *binlen = 0;
    const char *json = g->file;
    size_t jlen = g->flen;
    if (g->flen >= 4 && rd32(d) == GLB_MAGIC) {
        if (g->flen < 20) return mf_fail(MF_EFORMAT, "%s: truncated .glb (%zu bytes, the header alone needs 20)", g->path, g->flen);
        if (rd32(d + 4) != 2) return mf_fail(MF_EFORMAT, "%s: glTF binary version %u (only 2 is supported)", g->path, rd32(d + 4));
        if (rd32(d + 8) != g->flen)
            return mf_fail(MF_EFORMAT, "%s: the header says %u bytes but the file has %zu (truncated or padded)", g->path, rd32(d + 8), g->flen);
        size_t jl = rd32(d + 12);
        if (rd32(d + 16) != GLB_JSON) return mf_fail(MF_EFORMAT, "%s: the first chunk is not JSON", g->path);
        if (jl > g->flen - 20) return mf_fail(MF_EFORMAT, "%s: the JSON chunk (%zu bytes) runs past the end of the file", g->path, jl);
        json = g->file + 20;
        jlen = jl;
        size_t at = 20 + jl;
        if (g->flen - at >= 8) {
            size_t bl = rd32(d + at);
            if (rd32(d + at + 4) != GLB_BIN) return mf_fail(MF_EFORMAT, "%s: the second chunk is not BIN", g->path);
            if (bl > g->flen - at - 8) return mf_fail(MF_EFORMAT, "%s: the BIN chunk (%zu bytes) runs past the end of the file", g->path, bl);
            *bin = d + at + 8;
            *binlen = bl;
        } else if (g->flen != at) {
            return mf_fail(MF_EFORMAT, "%s: %zu stray bytes after the JSON chunk", g->path, g->flen - at);
        }
    } else if (g->flen >= 4 && !memcmp(g->file, "glTF", 4)) {
        return mf_fail(MF_EFORMAT, "%s: bad .glb header", g->path);
    } else {
        size_t i = 0;
        while (i < g->flen && (g->file[i] == ' ' || g->file[i] == '\t' || g->file[i] == '\n' || g->file[i] == '\r')) ++i;
        if (i == g->flen || g->file[i] != '{')
            return mf_fail(MF_EFORMAT, "%s: not a glTF file (neither the .glb magic \"glTF\" nor a JSON object)", g->path);
    }
    g->root = cJSON_ParseWithLength(json, jlen);
    if (!g->root || !cJSON_IsObject(g->root)) return mf_fail(MF_EFORMAT, "%s: invalid glTF JSON", g->path);
    const cJSON *asset = item(g->root, "asset");
    const char *ver = cJSON_GetStringValue(item(asset, "version"));
    if (!ver || strncmp(ver, "2.", 2)) return mf_fail(MF_EFORMAT, "%s: asset.version: '%s' (only glTF 2.x is supported)", g->path, ver ? ver : "(missing)");
    const cJSON *req = item(g->root, "extensionsRequired");
    if (cJSON_IsArray(req) && cJSON_GetArraySize(req) > 0) {
        const char *e = cJSON_GetStringValue(cJSON_GetArrayItem(req, 0));
        return mf_fail(MF_EFORMAT, "%s: extensionsRequired: %s is not supported (no glTF extension is)", g->path, e ? e : "(not a string)");
    }
    return MF_OK;
}

static void gltf_free(Gltf *g) {
    for (int i = 0; g->buf_owned && i < g->nbuf; ++i) free(g->buf_owned[i]);
    free(g->buf_owned);
    free(g->buf);
    free(g->buflen);
    cJSON_Delete(g->root);
    free(g->file);
}

void mf_gltf_asset_free(MfGltfAsset *a) {
    if (!a) return;
    mf_mesh_free(&a->mesh);
    for (int i = 0; a->mats && i < a->nmat; ++i) {
        mf_image_free(&a->mats[i].albedo);
        mf_image_free(&a->mats[i].orm);
        mf_image_free(&a->mats[i].normal);
    }
    free(a->mats);
    memset(a, 0, sizeof *a);
}

/* Frame at a point of triangle t with barycentrics bw: unit N, T (Gram-Schmidt), B = w N x T.
 * tan (nv, 4); rows with w = 0 are replaced by alt (may be NULL: none). 0 when degenerate. */
static int frame_at(const MfMesh *m, const float *tan, const float *alt, int t, const float *bw, MfVec3 *T, MfVec3 *B, MfVec3 *N) {
    const uint32_t *v = m->tri + 3 * (size_t)t;
    MfVec3 n = mf_v3s(0.0f), tt = mf_v3s(0.0f);
    float w = 0.0f;
    for (int k = 0; k < 3; ++k) {
        const float *nk = m->nrm + 3 * (size_t)v[k], *tk = tan + 4 * (size_t)v[k];
        if (tk[3] == 0.0f && alt) tk = alt + 4 * (size_t)v[k];
        n = mf_madd(n, mf_v3(nk[0], nk[1], nk[2]), bw[k]);
        tt = mf_madd(tt, mf_v3(tk[0], tk[1], tk[2]), bw[k]);
        w += bw[k] * tk[3];
    }
    float ln = mf_len(n);
    if (!(ln > 1e-12f)) return 0;
    n = mf_scale(n, 1.0f / ln);
    tt = mf_sub(tt, mf_scale(n, mf_dot(n, tt)));
    float lt = mf_len(tt);
    if (!(lt > 1e-6f)) return 0;
    *N = n;
    *T = mf_scale(tt, 1.0f / lt);
    *B = mf_scale(mf_cross(n, *T), w < 0.0f ? -1.0f : 1.0f);
    return 1;
}

/* Re-expresses map (material slot `slot`; tri_slot (nt,)) from the file's tangent frames ftan
 * (nv, 4) into ours (mf_mesh_tangents), texel by texel over the triangles' UV footprints. */
static int normal_to_our_frames(const char *path, const MfMesh *m, const float *ftan, const int *tri_slot, int slot, MfImage *map) {
    size_t nv = (size_t)m->nv, npx = (size_t)map->w * (size_t)map->h;
    float *ours = malloc(nv * 4 * sizeof(float) + 1), *best = malloc(npx * sizeof(float) + 1), *src = malloc(npx * 3 * sizeof(float) + 1);
    int rc = ours && best && src ? mf_mesh_tangents(m, ours) : mf_fail(MF_ENOMEM, "%s: out of memory for the normal map's tangent frames", path);
    if (!rc) {
        memcpy(src, map->data, npx * 3 * sizeof(float));
        for (size_t i = 0; i < npx; ++i) best[i] = INFINITY;
    }
    const int W = map->w, H = map->h;
    int skipped = 0;
    /* the work: texels visited over all footprints; overlapping or tiling UVs (or a hostile file)
     * could multiply it, so past a budget generous for an unwrapped mesh the map is kept as stored */
    double visits = 0, budget = 16.0 * (double)npx + 64.0 * (double)m->nt;
    for (int t = 0; !rc && t < m->nt && visits <= budget; ++t) {
        if (tri_slot && tri_slot[t] != slot) continue;
        const uint32_t *v = m->tri + 3 * (size_t)t;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 2; ++d) {
                double c = d ? (1.0 - m->uv[2 * v[k] + 1]) * H : m->uv[2 * v[k]] * W;
                lo[d] = fmin(lo[d], c), hi[d] = fmax(hi[d], c);
            }
        double area = (hi[0] - lo[0] + 4) * (hi[1] - lo[1] + 4);
        visits += area <= 4.0 * (double)npx + 64 ? area : 0; /* tiling triangles are skipped below */
    }
    if (!rc && visits > budget) {
        mf_log_warn("%s: the normal map's UV footprint is too large to re-express from TANGENT (%.3g texel visits, budget %.3g): "
                    "used as stored, in our tangent frames", path, visits, budget);
        free(ours), free(best), free(src);
        return MF_OK;
    }
    for (int t = 0; !rc && t < m->nt; ++t) {
        if (tri_slot && tri_slot[t] != slot) continue;
        const uint32_t *v = m->tri + 3 * (size_t)t;
        double px[3], py[3]; /* continuous texel coordinates (mf_texture.h) */
        for (int k = 0; k < 3; ++k) px[k] = m->uv[2 * v[k]] * W - 0.5, py[k] = (1.0 - m->uv[2 * v[k] + 1]) * H - 0.5;
        double x0 = floor(fmin(px[0], fmin(px[1], px[2]))) - 1, x1 = ceil(fmax(px[0], fmax(px[1], px[2]))) + 1;
        double y0 = floor(fmin(py[0], fmin(py[1], py[2]))) - 1, y1 = ceil(fmax(py[0], fmax(py[1], py[2]))) + 1;
        double area = (px[1] - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (py[1] - py[0]);
        if (!(fabs(area) > 1e-12)) continue;
        /* a tiling triangle, or one so far out in UV that texel steps would lose precision */
        if ((x1 - x0 + 1) * (y1 - y0 + 1) > 4.0 * (double)npx + 64 || fmax(fabs(x0), fabs(x1)) > 1e9 || fmax(fabs(y0), fabs(y1)) > 1e9) {
            ++skipped;
            continue;
        }
        double elen[3];
        for (int e = 0; e < 3; ++e) elen[e] = hypot(px[(e + 2) % 3] - px[(e + 1) % 3], py[(e + 2) % 3] - py[(e + 1) % 3]);
        for (double y = y0; y <= y1; ++y)
            for (double x = x0; x <= x1; ++x) {
                /* barycentric k: the edge opposite vertex k; outside distance in texels */
                double b[3], out = -INFINITY;
                for (int k = 0; k < 3; ++k) {
                    int i1 = (k + 1) % 3, i2 = (k + 2) % 3;
                    b[k] = ((px[i1] - x) * (py[i2] - y) - (px[i2] - x) * (py[i1] - y)) / area;
                    out = fmax(out, -b[k] * fabs(area) / (elen[k] > 0 ? elen[k] : 1));
                }
                if (out > 1.0) continue;
                int ix = (int)(((long)x % W + W) % W), iy = (int)(((long)y % H + H) % H);
                size_t pi = (size_t)iy * W + ix;
                if (!((float)out < best[pi])) continue;
                float bw[3], s = 0;
                for (int k = 0; k < 3; ++k) bw[k] = (float)fmax(b[k], 0.0), s += bw[k];
                for (int k = 0; k < 3; ++k) bw[k] /= s;
                MfVec3 Tf, Bf, Nf, To, Bo, No;
                if (!frame_at(m, ftan, ours, t, bw, &Tf, &Bf, &Nf) || !frame_at(m, ours, NULL, t, bw, &To, &Bo, &No)) continue;
                const float *sv = src + 3 * pi;
                MfVec3 n = mf_add(mf_add(mf_scale(Tf, 2 * sv[0] - 1), mf_scale(Bf, 2 * sv[1] - 1)), mf_scale(Nf, 2 * sv[2] - 1));
                MfVec3 o = mf_v3(mf_dot(n, To), mf_dot(n, Bo), mf_dot(n, No));
                float lo = mf_len(o);
                if (!(lo > 1e-12f) || !isfinite(lo)) continue;
                float *dv = map->data + 3 * pi;
                dv[0] = 0.5f * (o.x / lo + 1.0f), dv[1] = 0.5f * (o.y / lo + 1.0f), dv[2] = 0.5f * (o.z / lo + 1.0f);
                best[pi] = (float)out;
            }
    }
    if (!rc && skipped)
        mf_log_warn("%s: %d triangles span more than 4 copies of the normal map in UV (tiling) or lie beyond 1e9 texels: their texels were "
                    "not re-expressed from TANGENT", path, skipped);
    free(ours), free(best), free(src);
    return rc;
}

static int read_gltf(const char *path, int with_materials, MfGltfAsset *out) {
    Gltf g = {0};
    g.path = path;
    Build b = {0};
    MfGltfAsset a = {0};
    const unsigned char *bin;
    size_t binlen;
    int rc = mf_read_file(path, &g.file, &g.flen);
    if (!rc) rc = parse_container(&g, &bin, &binlen);
    if (!rc) rc = load_buffers(&g, bin, binlen);
    if (!rc) rc = build_mesh(&g, &b);
    if (!rc) {
        MfMesh *m = &a.mesh;
        m->nv = (int)b.nv, m->nt = (int)b.nt;
        m->pos = b.pos, m->nrm = b.nrm, m->uv = b.uv, m->tri = b.tri;
        b.pos = b.nrm = b.uv = NULL, b.tri = NULL;
        if (!b.any_uv) { free(m->uv); m->uv = NULL; }
        if (!b.all_nrm) rc = mf_mesh_compute_normals(m);
    }
    if (!rc && with_materials) {
        a.nmat = b.nused;
        if (!(a.mats = calloc((size_t)b.nused, sizeof *a.mats))) rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        for (int i = 0; !rc && i < b.nused; ++i) rc = material(&g, b.used[i], i, &a.mats[i]);
        for (int i = 0; !rc && i < b.nused; ++i) {
            MfGltfPbr *p = &a.mats[i];
            if (p->has_normal && !a.mesh.uv) {
                mf_log_warn("%s: material '%s': normalTexture ignored (the mesh has no TEXCOORD_0)", path, p->name);
                mf_image_free(&p->normal);
                p->has_normal = 0;
            }
            if (p->has_normal && b.any_tan) {
                rc = normal_to_our_frames(path, &a.mesh, b.tan, b.mat, i, &p->normal);
                a.tangents = 1;
            }
        }
        if (!rc && b.nused > 1) {
            a.mesh.mat = b.mat;
            b.mat = NULL;
            a.mesh.nmat = b.nused;
            if (!(a.mesh.mat_names = calloc((size_t)b.nused, sizeof(char *)))) rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
            for (int i = 0; !rc && i < b.nused; ++i)
                if (!(a.mesh.mat_names[i] = strdup(a.mats[i].name))) rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        }
    }
    free(b.pos), free(b.nrm), free(b.uv), free(b.tan), free(b.tri), free(b.mat), free(b.used), free(b.seen);
    gltf_free(&g);
    if (rc) {
        mf_gltf_asset_free(&a);
        return rc;
    }
    *out = a;
    return MF_OK;
}

int mf_gltf_read(const char *path, MfGltfAsset *out) { return read_gltf(path, 1, out); }

int mf_is_gltf_path(const char *path) {
    char ext[16];
    mf_path_ext(path, ext, sizeof ext);
    return !strcmp(ext, "glb") || !strcmp(ext, "gltf");
}

int mf_mesh_read(const char *path, MfMesh *out) {
    if (!mf_is_gltf_path(path)) return mf_obj_read(path, out);
    MfGltfAsset a;
    int rc = read_gltf(path, 0, &a);
    if (rc) return rc;
    *out = a.mesh;
    return MF_OK;
}
