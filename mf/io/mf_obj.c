#include "io/mf_obj.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"

/* ---- growable arrays ---------------------------------------------------------------- */

typedef struct {
    void *p;
    size_t n, cap, elem;
} Vec;

static void *vec_push(Vec *v, size_t k) {
    if (v->n + k > v->cap) {
        size_t cap = v->cap ? v->cap : 1024;
        while (cap < v->n + k) cap *= 2;
        void *q = realloc(v->p, cap * v->elem);
        if (!q) return NULL;
        v->p = q;
        v->cap = cap;
    }
    void *r = (char *)v->p + v->n * v->elem;
    v->n += k;
    return r;
}

static void vec_free(Vec *v) {
    free(v->p);
    memset(v, 0, sizeof *v);
}

/* ---- (v, vt, vn) -> vertex hash map --------------------------------------------------- */

typedef struct {
    int32_t v, t, n; /* 0-based indices; -1 = absent */
} Corner;

typedef struct {
    int32_t *slot; /* (cap,) output vertex index or -1 */
    size_t cap;    /* power of two */
} Map;

static uint64_t corner_hash(Corner c) {
    uint64_t h = (uint64_t)(uint32_t)c.v * 0x9E3779B97F4A7C15ull;
    h ^= ((uint64_t)(uint32_t)c.t + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full;
    h ^= ((uint64_t)(uint32_t)c.n + 0x85EBCA77C2B2AE63ull) * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return h;
}

static int map_grow(Map *m, const Corner *verts, size_t nverts) {
    size_t cap = m->cap ? m->cap * 2 : 4096;
    int32_t *s = malloc(cap * sizeof(int32_t));
    if (!s) return -1;
    memset(s, 0xff, cap * sizeof(int32_t));
    for (size_t i = 0; i < nverts; ++i) {
        size_t h = (size_t)corner_hash(verts[i]) & (cap - 1);
        while (s[h] >= 0) h = (h + 1) & (cap - 1);
        s[h] = (int32_t)i;
    }
    free(m->slot);
    m->slot = s;
    m->cap = cap;
    return 0;
}

/* Output vertex index of corner c, adding it to verts when new; -1 on out of memory. */
static int32_t map_get(Map *m, Vec *verts, Corner c) {
    if ((verts->n + 1) * 2 > m->cap && map_grow(m, verts->p, verts->n)) return -1;
    const Corner *vs = verts->p;
    size_t h = (size_t)corner_hash(c) & (m->cap - 1);
    while (m->slot[h] >= 0) {
        const Corner *o = &vs[m->slot[h]];
        if (o->v == c.v && o->t == c.t && o->n == c.n) return m->slot[h];
        h = (h + 1) & (m->cap - 1);
    }
    if (verts->n >= INT32_MAX) return -1;
    Corner *slot = vec_push(verts, 1);
    if (!slot) return -1;
    *slot = c;
    m->slot[h] = (int32_t)(verts->n - 1);
    return m->slot[h];
}

/* ---- parsing helpers ---------------------------------------------------------------- */

static int is_ws(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }
static char *skip_ws(char *s) {
    while (is_ws(*s)) ++s;
    return s;
}

/* Copies the token at s (up to whitespace) for messages. */
static const char *tok_copy(const char *s, char *buf, size_t cap) {
    size_t i = 0;
    while (s[i] && !is_ws(s[i]) && i + 1 < cap) { buf[i] = s[i]; ++i; }
    buf[i] = '\0';
    return buf;
}

typedef struct {
    const char *path;
    long line;
} Ctx;

/* Parses a float at *s. Returns 1 ok, 0 if the line has no more tokens, -1 (error set) if bad. */
static int parse_float(const Ctx *cx, char **s, float *out) {
    char *p = skip_ws(*s);
    if (!*p) return 0;
    char *e;
    errno = 0;
    float v = strtof(p, &e);
    if (e == p || (*e && !is_ws(*e)) || !isfinite(v)) {
        char tb[64];
        mf_fail(MF_EFORMAT, "%s:%ld: bad number '%s'", cx->path, cx->line, tok_copy(p, tb, sizeof tb));
        return -1;
    }
    *out = v;
    *s = e;
    return 1;
}

/* Reads n required floats then ignores the rest of the line. */
static int parse_floats(const Ctx *cx, char *s, float *out, int nreq, int nopt, const char *what) {
    for (int i = 0; i < nreq + nopt; ++i) {
        int r = parse_float(cx, &s, &out[i]);
        if (r < 0) return -1;
        if (r == 0) {
            if (i < nreq) {
                mf_fail(MF_EFORMAT, "%s:%ld: '%s' needs %d numbers, got %d", cx->path, cx->line, what, nreq, i);
                return -1;
            }
            for (int k = i; k < nreq + nopt; ++k) out[k] = 0.0f;
            return 0;
        }
    }
    /* Further numbers (w, vertex colours) are allowed but must still be numbers. */
    float dummy;
    int r;
    while ((r = parse_float(cx, &s, &dummy)) > 0) {}
    return r < 0 ? -1 : 0;
}

/* Parses a signed integer index at *s (stops at '/' or whitespace). */
static int parse_index(const Ctx *cx, char **s, const char *tokstart, long *out) {
    char *e;
    errno = 0;
    long v = strtol(*s, &e, 10);
    if (e == *s || errno || (*e && *e != '/' && !is_ws(*e))) {
        char tb[64];
        mf_fail(MF_EFORMAT, "%s:%ld: bad face corner '%s'", cx->path, cx->line, tok_copy(tokstart, tb, sizeof tb));
        return -1;
    }
    *out = v;
    *s = e;
    return 0;
}

/* Resolves a 1-based or negative OBJ index against count; -1 with error set when invalid. */
static int32_t resolve(const Ctx *cx, long idx, size_t count, const char *what, const char *unit) {
    long r = idx > 0 ? idx - 1 : (long)count + idx;
    if (idx == 0 || r < 0 || (size_t)r >= count) {
        mf_fail(MF_EFORMAT, "%s:%ld: %s index %ld out of range (%zu %s)", cx->path, cx->line, what, idx, count, unit);
        return -1;
    }
    return (int32_t)r;
}

void mf_mtl_free(MfMtl *m) {
    if (!m) return;
    for (int i = 0; i < m->n; ++i) {
        if (m->names) free(m->names[i]);
        if (m->map_kd) free(m->map_kd[i]);
    }
    free(m->names);
    free(m->map_kd);
    memset(m, 0, sizeof *m);
}

/* Removes trailing whitespace in place. */
static void rtrim(char *s) {
    size_t n = strlen(s);
    while (n && (is_ws(s[n - 1]) || s[n - 1] == '\r')) s[--n] = '\0';
}

/* Next line of buf starting at *pos: NUL-terminates it (dropping \r and comments). */
static char *next_line(char *buf, size_t len, size_t *pos) {
    if (*pos >= len) return NULL;
    char *line = buf + *pos;
    char *nl = memchr(line, '\n', len - *pos);
    if (nl) {
        *nl = '\0';
        *pos = (size_t)(nl - buf) + 1;
    } else {
        *pos = len;
    }
    char *hash = strchr(line, '#');
    if (hash) *hash = '\0';
    rtrim(line);
    return line;
}

static int keyword(char **s, const char *kw) {
    size_t n = strlen(kw);
    if (strncmp(*s, kw, n) == 0 && (is_ws((*s)[n]) || (*s)[n] == '\0')) {
        *s += n;
        return 1;
    }
    return 0;
}

int mf_mtl_read(const char *path, MfMtl *out) {
    char *buf = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &buf, &len);
    if (rc) return rc;
    MfMtl r = {0};
    int cap = 0;
    size_t pos = 0;
    char *line;
    long ln = 0;
    while ((line = next_line(buf, len, &pos))) {
        ++ln;
        char *s = skip_ws(line);
        if (keyword(&s, "newmtl")) {
            s = skip_ws(s);
            if (!*s) { rc = mf_fail(MF_EFORMAT, "%s:%ld: newmtl without a name", path, ln); break; }
            if (r.n == cap) {
                int nc = cap ? cap * 2 : 8;
                char **a = realloc(r.names, sizeof(char *) * (size_t)nc), **b = a ? realloc(r.map_kd, sizeof(char *) * (size_t)nc) : NULL;
                if (a) r.names = a;
                if (b) r.map_kd = b;
                if (!a || !b) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); break; }
                cap = nc;
            }
            r.names[r.n] = strdup(s);
            r.map_kd[r.n] = NULL;
            r.n++;
            if (!r.names[r.n - 1]) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); break; }
        } else if (keyword(&s, "map_Kd")) {
            if (r.n == 0) { rc = mf_fail(MF_EFORMAT, "%s:%ld: map_Kd before any newmtl", path, ln); break; }
            /* Options (-s 1 1 1, -bm 1, ...) come first; the file name is the last token. */
            char *name = strrchr(s, ' '), *tab = strrchr(s, '\t');
            if (tab > name) name = tab;
            name = name ? name + 1 : s;
            if (!*name) { rc = mf_fail(MF_EFORMAT, "%s:%ld: map_Kd without a file name", path, ln); break; }
            free(r.map_kd[r.n - 1]);
            r.map_kd[r.n - 1] = strdup(name);
        }
    }
    free(buf);
    if (rc) { mf_mtl_free(&r); return rc; }
    *out = r;
    return MF_OK;
}

int mf_mtl_write(const char *path, const char *const *names, int n, const char *map_kd) {
    char tmp[MF_PATH_MAX];
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc) return rc;
    FILE *f = fopen(tmp, "wb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot write: %s", path, strerror(errno));
    fprintf(f, "# written by mf\n");
    int cnt = names ? n : 1;
    for (int i = 0; i < cnt; ++i) {
        fprintf(f, "newmtl %s\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n", names && names[i] ? names[i] : "material");
        if (map_kd) fprintf(f, "map_Kd %s\n", map_kd);
        fprintf(f, "\n");
    }
    if (fclose(f) != 0) { mf_discard_file(tmp); return mf_fail(MF_EIO, "%s: write failed", path); }
    return mf_commit_file(tmp, path);
}

/* ---- OBJ reading -------------------------------------------------------------------- */

typedef struct {
    Vec v, vt, vn;   /* float (n, 3), (n, 2), (n, 3) */
    Vec verts;       /* Corner: unified output vertices */
    Vec tri;         /* uint32_t (nt, 3) */
    Vec tmat;        /* int (nt,) material id, -1 before the first usemtl */
    Vec poly;        /* int32 output vertex ids of the current face */
    Vec mats;        /* char* material names */
    Map map;
    int any_vt, all_vn, have_default;
} Parse;

static void parse_free(Parse *p) {
    vec_free(&p->v);
    vec_free(&p->vt);
    vec_free(&p->vn);
    vec_free(&p->verts);
    vec_free(&p->tri);
    vec_free(&p->tmat);
    vec_free(&p->poly);
    for (size_t i = 0; i < p->mats.n; ++i) free(((char **)p->mats.p)[i]);
    vec_free(&p->mats);
    free(p->map.slot);
}

static int parse_face(const Ctx *cx, Parse *P, char *s, int cur_mat, int *n_poly) {
    P->poly.n = 0;
    for (;;) {
        s = skip_ws(s);
        if (!*s) break;
        char *tok = s;
        long iv, it = 0, in = 0;
        int has_t = 0, has_n = 0;
        if (parse_index(cx, &s, tok, &iv)) return -1;
        if (*s == '/') {
            ++s;
            if (*s != '/') {
                if (parse_index(cx, &s, tok, &it)) return -1;
                has_t = 1;
            }
            if (*s == '/') {
                ++s;
                if (parse_index(cx, &s, tok, &in)) return -1;
                has_n = 1;
            }
        }
        if (*s && !is_ws(*s)) {
            char tb[64];
            return mf_fail(MF_EFORMAT, "%s:%ld: bad face corner '%s'", cx->path, cx->line, tok_copy(tok, tb, sizeof tb));
        }
        Corner c = {resolve(cx, iv, P->v.n, "face", "vertices"), -1, -1};
        if (c.v < 0) return -1;
        if (has_t && (c.t = resolve(cx, it, P->vt.n, "texture coordinate", "texture coordinates")) < 0) return -1;
        if (has_n && (c.n = resolve(cx, in, P->vn.n, "normal", "normals")) < 0) return -1;
        P->any_vt |= has_t;
        P->all_vn &= has_n;
        int32_t id = map_get(&P->map, &P->verts, c);
        int32_t *slot = id >= 0 ? vec_push(&P->poly, 1) : NULL;
        if (!slot) return mf_fail(MF_ENOMEM, "%s:%ld: out of memory", cx->path, cx->line);
        *slot = id;
    }
    size_t k = P->poly.n;
    if (k < 3) return mf_fail(MF_EFORMAT, "%s:%ld: face with %zu vertices (need at least 3)", cx->path, cx->line, k);
    if (k > 3) ++*n_poly;
    const int32_t *pv = P->poly.p;
    uint32_t *t = vec_push(&P->tri, 3 * (k - 2));
    int *tm = t ? vec_push(&P->tmat, k - 2) : NULL;
    if (!t || !tm) return mf_fail(MF_ENOMEM, "%s:%ld: out of memory", cx->path, cx->line);
    for (size_t i = 1; i + 1 < k; ++i) {
        t[3 * (i - 1)] = (uint32_t)pv[0];
        t[3 * (i - 1) + 1] = (uint32_t)pv[i];
        t[3 * (i - 1) + 2] = (uint32_t)pv[i + 1];
        tm[i - 1] = cur_mat;
    }
    if (P->tri.n / 3 > (size_t)INT32_MAX) return mf_fail(MF_EFORMAT, "%s:%ld: too many triangles", cx->path, cx->line);
    return 0;
}

int mf_obj_read(const char *path, MfMesh *out) { return mf_obj_read_ex(path, NULL, out, NULL); }

int mf_obj_read_ex(const char *path, const MfObjOptions *opt, MfMesh *out, MfObjInfo *info) {
    MfObjOptions o = opt ? *opt : (MfObjOptions){0};
    char *buf = NULL;
    size_t len = 0;
    int rc = mf_read_file(path, &buf, &len);
    if (rc) return rc;
    Parse P = {0};
    P.v.elem = P.vn.elem = 3 * sizeof(float);
    P.vt.elem = 2 * sizeof(float);
    P.verts.elem = sizeof(Corner);
    P.tri.elem = sizeof(uint32_t);
    P.tmat.elem = P.poly.elem = sizeof(int32_t);
    P.mats.elem = sizeof(char *);
    P.all_vn = 1;
    char mtllib[MF_PATH_MAX] = "";
    int cur_mat = -1, n_poly = 0;
    Ctx cx = {path, 0};
    size_t pos = 0;
    char *line;
    MfMesh m = {0};
    MfMtl mtl = {0};
    while (!rc && (line = next_line(buf, len, &pos))) {
        ++cx.line;
        char *s = skip_ws(line);
        if (!*s) continue;
        if (s[0] == 'v' && is_ws(s[1])) {
            float *d = vec_push(&P.v, 1);
            if (!d) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); break; }
            if (parse_floats(&cx, s + 1, d, 3, 0, "v")) rc = MF_EFORMAT;
            for (int k = 0; !rc && k < 3; ++k)
                if (!(fabsf(d[k]) <= (float)MF_COORD_MAX))
                    rc = mf_fail(MF_EFORMAT, "%s:%ld: vertex %c = %g is out of range (|coordinate| <= %g)", path,
                                 cx.line, "xyz"[k], (double)d[k], MF_COORD_MAX);
        } else if (s[0] == 'v' && s[1] == 't' && is_ws(s[2])) {
            float *d = vec_push(&P.vt, 1), w[3];
            if (!d) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); break; }
            if (parse_floats(&cx, s + 2, w, 1, 2, "vt")) rc = MF_EFORMAT;
            d[0] = w[0];
            d[1] = w[1];
        } else if (s[0] == 'v' && s[1] == 'n' && is_ws(s[2])) {
            float *d = vec_push(&P.vn, 1);
            if (!d) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); break; }
            if (parse_floats(&cx, s + 2, d, 3, 0, "vn")) rc = MF_EFORMAT;
        } else if (s[0] == 'f' && is_ws(s[1])) {
            if (parse_face(&cx, &P, s + 1, cur_mat, &n_poly)) rc = MF_EFORMAT;
        } else if (keyword(&s, "usemtl")) {
            s = skip_ws(s);
            if (!*s) { rc = mf_fail(MF_EFORMAT, "%s:%ld: usemtl without a name", path, cx.line); break; }
            char **names = P.mats.p;
            int k = 0;
            while ((size_t)k < P.mats.n && strcmp(names[k], s) != 0) ++k;
            if ((size_t)k == P.mats.n) {
                char **slot = vec_push(&P.mats, 1);
                if (!slot || !(*slot = strdup(s))) {
                    if (slot) P.mats.n--;
                    rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
                    break;
                }
            }
            cur_mat = k;
        } else if (keyword(&s, "mtllib")) {
            s = skip_ws(s);
            if (*s && !mtllib[0]) {
                const char *slash = strrchr(path, '/');
                char name[MF_PATH_MAX];
                snprintf(name, sizeof name, "%s", s);
                char *sp = name; /* first file name only */
                while (*sp && !is_ws(*sp)) ++sp;
                *sp = '\0';
                if (slash) {
                    char dir[MF_PATH_MAX];
                    snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
                    if (mf_path_join(mtllib, sizeof mtllib, dir, name)) mtllib[0] = '\0';
                } else {
                    snprintf(mtllib, sizeof mtllib, "%s", name);
                }
            }
        }
        /* o, g, s, l, p, vp and anything else: ignored. */
    }
    free(buf);
    buf = NULL;
    if (rc) goto fail;

    size_t nv = P.verts.n, nt = P.tri.n / 3;
    int with_nrm = nv > 0 && P.all_vn, with_uv = P.any_vt;
    if ((rc = mf_mesh_alloc(&m, (int)nv, (int)nt, with_nrm, with_uv))) goto fail;
    /* Order output vertices by position index (counting sort, stable: ties keep first-use
     * order), so a file whose faces use v/v/v triplets keeps the file's vertex order. */
    const Corner *cs0 = P.verts.p;
    Corner *cs = malloc(sizeof(Corner) * (nv + 1));
    uint32_t *remap = malloc(sizeof(uint32_t) * (nv + 1));
    size_t *start = calloc(P.v.n + 1, sizeof(size_t));
    if (!cs || !remap || !start) {
        free(cs); free(remap); free(start);
        rc = mf_fail(MF_ENOMEM, "%s: out of memory", path);
        goto fail;
    }
    for (size_t i = 0; i < nv; ++i) start[cs0[i].v + 1]++;
    for (size_t k = 0; k < P.v.n; ++k) start[k + 1] += start[k];
    for (size_t i = 0; i < nv; ++i) {
        size_t d = start[cs0[i].v]++;
        cs[d] = cs0[i];
        remap[i] = (uint32_t)d;
    }
    free(start);
    uint32_t *tp = P.tri.p;
    for (size_t i = 0; i < nt * 3; ++i) tp[i] = remap[tp[i]];
    free(remap);
    const float *vp = P.v.p, *vtp = P.vt.p, *vnp = P.vn.p;
    for (size_t i = 0; i < nv; ++i) {
        memcpy(m.pos + 3 * i, vp + 3 * (size_t)cs[i].v, 3 * sizeof(float));
        if (with_uv) {
            m.uv[2 * i] = cs[i].t >= 0 ? vtp[2 * (size_t)cs[i].t] : 0.0f;
            m.uv[2 * i + 1] = cs[i].t >= 0 ? vtp[2 * (size_t)cs[i].t + 1] : 0.0f;
        }
        if (with_nrm) memcpy(m.nrm + 3 * i, vnp + 3 * (size_t)cs[i].n, 3 * sizeof(float));
    }
    free(cs);
    if (nt) memcpy(m.tri, P.tri.p, nt * 3 * sizeof(uint32_t));
    if (P.mats.n > 0) {
        const int *tm = P.tmat.p;
        int shift = 0;
        for (size_t t = 0; t < nt; ++t) shift |= tm[t] < 0;
        m.nmat = (int)P.mats.n + shift;
        m.mat = malloc(sizeof(int) * (nt + 1));
        m.mat_names = calloc((size_t)m.nmat, sizeof(char *));
        if (!m.mat || !m.mat_names) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto fail; }
        for (size_t t = 0; t < nt; ++t) m.mat[t] = tm[t] + shift; /* -1 -> 0 = "default" */
        if (shift && !(m.mat_names[0] = strdup("default"))) { rc = mf_fail(MF_ENOMEM, "%s: out of memory", path); goto fail; }
        for (size_t k = 0; k < P.mats.n; ++k) {
            m.mat_names[k + shift] = ((char **)P.mats.p)[k];
            ((char **)P.mats.p)[k] = NULL;
        }
    }
    int n_degen = mf_mesh_count_degenerate(&m, o.degenerate_area);
    if (o.reject_degenerate && n_degen > 0) {
        rc = mf_fail(MF_EFORMAT, "%s: %d degenerate (area <= %g) triangles of %zu", path, n_degen, (double)o.degenerate_area, nt);
        goto fail;
    }
    if (o.read_mtl && mtllib[0] && (rc = mf_mtl_read(mtllib, &mtl))) {
        mf_fail_prefix(rc, "%s: mtllib", path);
        goto fail;
    }
    parse_free(&P);
    if (info) {
        info->n_degenerate = n_degen;
        info->n_polygons = n_poly;
        snprintf(info->mtllib, sizeof info->mtllib, "%s", mtllib);
        info->mtl = mtl;
    } else {
        mf_mtl_free(&mtl);
    }
    *out = m;
    return MF_OK;
fail:
    free(buf);
    parse_free(&P);
    mf_mesh_free(&m);
    mf_mtl_free(&mtl);
    return rc;
}

/* ---- OBJ writing -------------------------------------------------------------------- */

int mf_obj_write(const char *path, const MfMesh *m, const char *mtl_texture) {
    if (!m || (m->nv > 0 && !m->pos) || (m->nt > 0 && !m->tri)) return mf_fail(MF_EARG, "%s: empty mesh", path);
    for (size_t i = 0; i < (size_t)m->nt * 3; ++i)
        if (m->tri[i] >= (uint32_t)m->nv) return mf_fail(MF_EARG, "%s: triangle %zu uses vertex %u of %d", path, i / 3, m->tri[i], m->nv);
    char mtlpath[MF_PATH_MAX], mtlname[MF_PATH_MAX];
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    int stem = dot ? (int)(dot - base) : (int)strlen(base);
    if (stem > 1000 || strlen(path) > MF_PATH_MAX - 16) return mf_fail(MF_EARG, "%s: path too long", path);
    snprintf(mtlname, sizeof mtlname, "%.*s.mtl", stem, base);
    snprintf(mtlpath, sizeof mtlpath, "%.*s%.1010s", (int)(base - path), path, mtlname);
    int use_mat = m->mat && m->nmat > 0;

    char tmp[MF_PATH_MAX];
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc) return rc;
    FILE *f = fopen(tmp, "wb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot write: %s", path, strerror(errno));
    char *vb = malloc(1 << 20);
    if (vb) setvbuf(f, vb, _IOFBF, 1 << 20);
    fprintf(f, "# written by mf: %d vertices, %d triangles\n", m->nv, m->nt);
    if (mtl_texture) fprintf(f, "mtllib %s\n", mtlname);
    for (int i = 0; i < m->nv; ++i) fprintf(f, "v %.9g %.9g %.9g\n", m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]);
    if (m->uv)
        for (int i = 0; i < m->nv; ++i) fprintf(f, "vt %.9g %.9g\n", m->uv[2 * i], m->uv[2 * i + 1]);
    if (m->nrm)
        for (int i = 0; i < m->nv; ++i) fprintf(f, "vn %.9g %.9g %.9g\n", m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
    int cur = -2;
    for (int t = 0; t < m->nt; ++t) {
        int id = use_mat ? m->mat[t] : 0;
        if (id != cur && (use_mat || mtl_texture)) {
            if (use_mat && m->mat_names && id >= 0 && id < m->nmat && m->mat_names[id]) fprintf(f, "usemtl %s\n", m->mat_names[id]);
            else if (use_mat) fprintf(f, "usemtl mat%d\n", id);
            else fprintf(f, "usemtl material\n");
            cur = id;
        }
        fputc('f', f);
        for (int k = 0; k < 3; ++k) {
            unsigned v = m->tri[3 * t + k] + 1;
            if (m->uv && m->nrm) fprintf(f, " %u/%u/%u", v, v, v);
            else if (m->uv) fprintf(f, " %u/%u", v, v);
            else if (m->nrm) fprintf(f, " %u//%u", v, v);
            else fprintf(f, " %u", v);
        }
        fputc('\n', f);
    }
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    free(vb);
    if (bad) { mf_discard_file(tmp); return mf_fail(MF_EIO, "%s: write failed", path); }
    if (mtl_texture) {
        /* Material names as the OBJ references them. */
        int n = use_mat ? m->nmat : 1;
        char **names = calloc((size_t)n, sizeof(char *));
        char (*gen)[32] = calloc((size_t)n, 32);
        if (!names || !gen) { free(names); free(gen); mf_discard_file(tmp); return mf_fail(MF_ENOMEM, "out of memory"); }
        for (int i = 0; i < n; ++i) {
            if (use_mat && m->mat_names && m->mat_names[i]) names[i] = m->mat_names[i];
            else {
                if (use_mat) snprintf(gen[i], 32, "mat%d", i);
                else snprintf(gen[i], 32, "material");
                names[i] = gen[i];
            }
        }
        rc = mf_mtl_write(mtlpath, (const char *const *)names, n, mtl_texture);
        free(names);
        free(gen);
        if (rc) { mf_discard_file(tmp); return rc; }
    }
    return mf_commit_file(tmp, path);
}
