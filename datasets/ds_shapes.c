#include "datasets/ds_shapes.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "geom/mf_bake.h"
#include "geom/mf_pack.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"

static const char *k_fam_names[DS_FAM_COUNT] = {"cup", "vase", "bottle", "bowl", "box",
                                                "superquadric", "torus", "mug", "clock", "displaced"};

const char *ds_family_name(DsFamily f) { return (f >= 0 && f < DS_FAM_COUNT) ? k_fam_names[f] : "unknown"; }

int ds_family_from_name(const char *name) {
    for (int i = 0; i < DS_FAM_COUNT; ++i)
        if (!strcmp(name, k_fam_names[i])) return i;
    return -1;
}

/* ------------------------------------------------------------------------------------------ */
/* Builder: parts made of parametric grid patches.                                            */

#define MAX_PATCHES 32

typedef struct {
    int nu, nv;  /* quads; vertices (nv + 1) x (nu + 1) */
    MfVec3 *p;   /* owned; (nv + 1, nu + 1) positions in the part's local frame */
    int part;
    int flip;    /* reverse the winding of this patch */
    float lu, lv; /* chart size (mean length along u and v) */
    float x0, y0, w, h; /* chart rectangle in the atlas */
} Patch;

typedef struct {
    int nparts;
    char names[DS_MAX_PARTS][32];
    MfMat4 xf[DS_MAX_PARTS];     /* part local -> object (rigid) */
    DsMaterial mats[DS_MAX_PARTS];
    int npatch;
    Patch patch[MAX_PATCHES];
    int oom;
} Builder;

static int add_part(Builder *b, const char *name, MfMat4 xf, const DsMaterial *m) {
    int k = b->nparts++;
    snprintf(b->names[k], sizeof b->names[k], "%s", name);
    b->xf[k] = xf;
    b->mats[k] = *m;
    return k;
}

static Patch *new_patch(Builder *b, int part, int nu, int nv) {
    if (b->npatch >= MAX_PATCHES) { b->oom = 1; return NULL; }
    Patch *p = &b->patch[b->npatch];
    memset(p, 0, sizeof *p);
    p->p = calloc((size_t)(nu + 1) * (nv + 1), sizeof(MfVec3));
    if (!p->p) { b->oom = 1; return NULL; }
    p->nu = nu;
    p->nv = nv;
    p->part = part;
    b->npatch++;
    return p;
}

static void builder_free(Builder *b) {
    for (int i = 0; i < b->npatch; ++i) free(b->patch[i].p);
}

#define PP(pa, i, j) ((pa)->p[(size_t)(j) * ((pa)->nu + 1) + (i)])

static float urange(MfRng *r, float a, float b) { return a + (b - a) * mf_rng_float(r); }

static MfMat4 mat_translate(MfVec3 t) {
    MfMat4 m = mf_mat4_identity();
    m.m[3] = t.x; m.m[7] = t.y; m.m[11] = t.z;
    return m;
}
/* Rotation about +X by angle. */
static MfMat4 mat_rot_x(float a) {
    float c = cosf(a), s = sinf(a);
    MfMat4 m = {{1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1}};
    return m;
}

/* ---- profiles (r, z) revolved about +Z ---- */

typedef struct { float r, z; } V2;
#define MAX_PROF 512
typedef struct { int n; V2 p[MAX_PROF]; } Profile;

static void prof_add(Profile *pr, float r, float z) {
    if (pr->n >= MAX_PROF) return;
    if (r < 0.0f) r = 0.0f;
    if (pr->n > 0) { /* drop coincident points */
        V2 q = pr->p[pr->n - 1];
        if (fabsf(q.r - r) < 1e-6f && fabsf(q.z - z) < 1e-6f) return;
    }
    pr->p[pr->n].r = r;
    pr->p[pr->n].z = z;
    pr->n++;
}
/* Points from the last point (exclusive) to (r, z) (inclusive) in n steps. */
static void prof_line(Profile *pr, float r, float z, int n) {
    V2 a = pr->p[pr->n - 1];
    for (int k = 1; k <= n; ++k) {
        float t = (float)k / (float)n;
        prof_add(pr, a.r + (r - a.r) * t, a.z + (z - a.z) * t);
    }
    pr->p[pr->n - 1].r = r; /* exact end point */
    pr->p[pr->n - 1].z = z;
}
/* Arc around (cr, cz) of radius rad from angle a0 to a1 (radians, angle 0 = +r), n steps,
 * first point excluded. */
static void prof_arc(Profile *pr, float cr, float cz, float rad, float a0, float a1, int n) {
    for (int k = 1; k <= n; ++k) {
        float a = a0 + (a1 - a0) * (float)k / (float)n;
        prof_add(pr, cr + rad * cosf(a), cz + rad * sinf(a));
    }
}

/* Catmull-Rom radius curve through k control radii at uniform heights over [0, H]. */
typedef struct { int k; float r[8]; float H; } Spline;

static float spline_r(const Spline *s, float z) {
    float t = mf_clampf(z / s->H, 0.0f, 1.0f) * (float)(s->k - 1);
    int i = (int)floorf(t);
    if (i >= s->k - 1) i = s->k - 2;
    float f = t - (float)i;
    float p0 = s->r[i > 0 ? i - 1 : 0], p1 = s->r[i], p2 = s->r[i + 1], p3 = s->r[i + 2 < s->k ? i + 2 : s->k - 1];
    float f2 = f * f, f3 = f2 * f;
    float v = 0.5f * (2.0f * p1 + (-p0 + p2) * f + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * f2 + (-p0 + 3.0f * p1 - 3.0f * p2 + p3) * f3);
    return v;
}

/* A vessel (open top with wall thickness th, floor thickness fl, rounded rim): bottom centre ->
 * outer wall -> rim -> inner wall -> inner floor centre. */
static void vessel_profile(Profile *pr, const Spline *s, float th, float fl, float fillet) {
    float H = s->H, r0 = spline_r(s, 0.0f);
    pr->n = 0;
    prof_add(pr, 0.0f, 0.0f);
    prof_line(pr, r0 - fillet, 0.0f, 8);
    prof_arc(pr, r0 - fillet, fillet, fillet, -0.5f * MF_PI, 0.0f, 5);
    int nw = 40;
    for (int k = 1; k <= nw; ++k) {
        float z = fillet + (H - fillet) * (float)k / (float)nw;
        prof_add(pr, spline_r(s, z), z);
    }
    float rt = spline_r(s, H);
    prof_arc(pr, rt - 0.5f * th, H, 0.5f * th, 0.0f, MF_PI, 8);
    int ni = 34;
    float fi = 0.025f; /* concave fillet where the inner wall meets the floor */
    for (int k = 1; k <= ni; ++k) {
        float z = H - (H - fl - fi) * (float)k / (float)ni;
        prof_add(pr, fmaxf(spline_r(s, z) - th, 0.02f + fi), z);
    }
    float ri = pr->p[pr->n - 1].r;
    prof_arc(pr, ri - fi, fl + fi, fi, 0.0f, -0.5f * MF_PI, 5);
    prof_line(pr, 0.0f, fl, 8);
}

/* A closed disc/cylinder: (0, z0) -> (R, z0) -> (R, z1) -> (0, z1) with rounded edges of radius e. */
static void puck_profile(Profile *pr, float R, float z0, float z1, float e) {
    pr->n = 0;
    prof_add(pr, 0.0f, z0);
    prof_line(pr, R - e, z0, 6);
    prof_arc(pr, R - e, z0 + e, e, -0.5f * MF_PI, 0.0f, 4);
    prof_line(pr, R, z1 - e, 4);
    prof_arc(pr, R - e, z1 - e, e, 0.0f, 0.5f * MF_PI, 4);
    prof_line(pr, 0.0f, z1, 6);
}

/* Rounds every interior corner that turns by more than 20 degrees: the corner point is replaced
 * by a quadratic Bezier tangent to both segments (cut back by at most 40% of the shorter one),
 * sampled so that each new segment turns by at most about 12 degrees. Smooth vertex normals
 * then stay within a few degrees of the faces around them. */
static void prof_round_corners(const Profile *in, Profile *out) {
    out->n = 0;
    for (int i = 0; i < in->n; ++i) {
        if (i == 0 || i == in->n - 1) { prof_add(out, in->p[i].r, in->p[i].z); continue; }
        V2 a = in->p[i - 1], c = in->p[i], e = in->p[i + 1];
        float ar = c.r - a.r, az = c.z - a.z, br = e.r - c.r, bz = e.z - c.z;
        float la = sqrtf(ar * ar + az * az), lb = sqrtf(br * br + bz * bz);
        float cosang = (ar * br + az * bz) / (la * lb);
        float ang = acosf(mf_clampf(cosang, -1.0f, 1.0f));
        if (!(ang > 20.0f * MF_PI / 180.0f) || la <= 0.0f || lb <= 0.0f) { prof_add(out, c.r, c.z); continue; }
        float t = 0.4f * fminf(la, lb);
        V2 s0 = {c.r - ar / la * t, c.z - az / la * t}, s1 = {c.r + br / lb * t, c.z + bz / lb * t};
        int k = (int)ceilf(ang / (12.0f * MF_PI / 180.0f));
        for (int q = 0; q <= k; ++q) {
            float u = (float)q / (float)k, w0 = (1 - u) * (1 - u), w1 = 2 * u * (1 - u), w2 = u * u;
            prof_add(out, w0 * s0.r + w1 * c.r + w2 * s1.r, w0 * s0.z + w1 * c.z + w2 * s1.z);
        }
    }
}

static void revolve(Builder *b, int part, const Profile *pr_in, int nphi) {
    Profile *pr = malloc(sizeof(Profile));
    if (!pr) { b->oom = 1; return; }
    prof_round_corners(pr_in, pr);
    Patch *pa = new_patch(b, part, nphi, pr->n - 1);
    if (!pa) { free(pr); return; }
    if (!pa) return;
    for (int j = 0; j < pr->n; ++j)
        for (int i = 0; i <= nphi; ++i) {
            int ii = i == nphi ? 0 : i;
            float ph = 2.0f * MF_PI * (float)ii / (float)nphi;
            float r = pr->p[j].r;
            PP(pa, i, j) = r == 0.0f ? mf_v3(0.0f, 0.0f, pr->p[j].z) : mf_v3(r * cosf(ph), r * sinf(ph), pr->p[j].z);
        }
    free(pr);
}

/* ---- rounded box: six face patches ---- */

static int box_coords(float h, float rb, int nb, int nm, float *out) {
    int n = 0;
    for (int k = 0; k < nb; ++k) out[n++] = -h + rb * (1.0f - cosf(0.5f * MF_PI * (float)k / (float)nb));
    for (int k = 0; k < nm; ++k) out[n++] = -h + rb + (2.0f * (h - rb)) * (float)k / (float)nm;
    for (int k = 0; k < nb; ++k) out[n++] = h - rb + rb * sinf(0.5f * MF_PI * (float)k / (float)nb);
    out[n++] = h;
    return n; /* 2 nb + nm + 1 values */
}

static MfVec3 rounded(MfVec3 q, MfVec3 h, float rb) {
    MfVec3 in = mf_v3(mf_clampf(q.x, -(h.x - rb), h.x - rb), mf_clampf(q.y, -(h.y - rb), h.y - rb), mf_clampf(q.z, -(h.z - rb), h.z - rb));
    MfVec3 d = mf_sub(q, in);
    float l = mf_len(d);
    return l > 0.0f ? mf_add(in, mf_scale(d, rb / l)) : q;
}

static void rounded_box(Builder *b, int part, MfVec3 h, float rb, int nb, int nm) {
    float cs[3][128];
    int nc[3];
    float hh[3] = {h.x, h.y, h.z};
    for (int a = 0; a < 3; ++a) nc[a] = box_coords(hh[a], rb, nb, nm, cs[a]);
    for (int a = 0; a < 3; ++a)
        for (int sg = -1; sg <= 1; sg += 2) {
            int ba = (a + 1) % 3, ca = (a + 2) % 3; /* e_b x e_c = e_a */
            Patch *pa = new_patch(b, part, nc[ba] - 1, nc[ca] - 1);
            if (!pa) return;
            pa->flip = sg < 0;
            for (int j = 0; j < nc[ca]; ++j)
                for (int i = 0; i < nc[ba]; ++i) {
                    float q[3];
                    q[a] = (float)sg * hh[a];
                    q[ba] = cs[ba][i];
                    q[ca] = cs[ca][j];
                    PP(pa, i, j) = rounded(mf_v3(q[0], q[1], q[2]), h, rb);
                }
        }
}

/* ---- superquadric / ellipsoid (optionally displaced) ---- */

static float spow(float x, float e) { return copysignf(powf(fabsf(x), e), x); }

typedef struct { float amp, freq; uint64_t seed; } Displace;

static void superquadric(Builder *b, int part, MfVec3 ax, float e1, float e2, int nu, int nv, const Displace *dp) {
    Patch *pa = new_patch(b, part, nu, nv);
    if (!pa) return;
    for (int j = 0; j <= nv; ++j) {
        float th = -0.5f * MF_PI + MF_PI * (float)j / (float)nv;
        float ct = (j == 0 || j == nv) ? 0.0f : cosf(th), st = j == 0 ? -1.0f : (j == nv ? 1.0f : sinf(th));
        for (int i = 0; i <= nu; ++i) {
            int ii = i == nu ? 0 : i;
            float ph = 2.0f * MF_PI * (float)ii / (float)nu;
            float cp = cosf(ph), sp = sinf(ph);
            MfVec3 p = mf_v3(ax.x * spow(ct, e1) * spow(cp, e2), ax.y * spow(ct, e1) * spow(sp, e2), ax.z * spow(st, e1));
            if (ct == 0.0f) p.x = p.y = 0.0f;
            if (dp) {
                MfVec3 n = mf_norm(mf_v3(p.x / (ax.x * ax.x), p.y / (ax.y * ax.y), p.z / (ax.z * ax.z)));
                float d = dp->amp * (2.0f * ds_fbm(mf_scale(p, dp->freq), 5, dp->seed) - 1.0f);
                p = mf_madd(p, n, d);
            }
            PP(pa, i, j) = p;
        }
    }
}

/* ---- torus (full) and torus segment with hemispherical ends (in the local XY plane) ---- */

static void torus(Builder *b, int part, float R, float r, float rz, int nu, int nv) {
    Patch *pa = new_patch(b, part, nu, nv);
    if (!pa) return;
    for (int j = 0; j <= nv; ++j) {
        int jj = j == nv ? 0 : j;
        float be = 2.0f * MF_PI * (float)jj / (float)nv;
        for (int i = 0; i <= nu; ++i) {
            int ii = i == nu ? 0 : i;
            float a = 2.0f * MF_PI * (float)ii / (float)nu;
            float rr = R + r * cosf(be);
            PP(pa, i, j) = mf_v3(rr * cosf(a), rr * sinf(a), rz * sinf(be));
        }
    }
}

static void tube_segment(Builder *b, int part, float R, float r, float a0, float a1, int ns, int nc, int nv) {
    int nu = ns + 2 * nc;
    Patch *pa = new_patch(b, part, nu, nv);
    if (!pa) return;
    for (int i = 0; i <= nu; ++i) {
        float a, g; /* sweep angle; cap angle gamma (pi/2 at the tip) */
        float tsign = 0.0f;
        if (i < nc) { a = a0; g = 0.5f * MF_PI * (float)(nc - i) / (float)nc; tsign = -1.0f; }
        else if (i > nc + ns) { a = a1; g = 0.5f * MF_PI * (float)(i - nc - ns) / (float)nc; tsign = 1.0f; }
        else { a = a0 + (a1 - a0) * (float)(i - nc) / (float)ns; g = 0.0f; }
        MfVec3 c = mf_v3(R * cosf(a), R * sinf(a), 0.0f), er = mf_v3(cosf(a), sinf(a), 0.0f), et = mf_v3(-sinf(a), cosf(a), 0.0f);
        int tip = (i == 0 || i == nu);
        float cg = tip ? 0.0f : cosf(g), sg = tip ? 1.0f : sinf(g);
        for (int j = 0; j <= nv; ++j) {
            int jj = j == nv ? 0 : j;
            float be = 2.0f * MF_PI * (float)jj / (float)nv;
            MfVec3 ring = mf_add(mf_scale(er, cosf(be)), mf_v3(0, 0, sinf(be)));
            MfVec3 p = mf_add(c, mf_scale(et, tsign * r * sg));
            if (!tip) p = mf_add(p, mf_scale(ring, r * cg));
            PP(pa, i, j) = p;
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Families                                                                                   */

static DsMatClass pick_class(MfRng *rng, const DsMatClass *cls, const float *w, int n) {
    float tot = 0.0f;
    for (int i = 0; i < n; ++i) tot += w[i];
    float u = mf_rng_float(rng) * tot;
    for (int i = 0; i < n; ++i) {
        if (u < w[i]) return cls[i];
        u -= w[i];
    }
    return cls[n - 1];
}

static DsMaterial rand_mat(MfRng *rng, const DsMatClass *cls, const float *w, int n) {
    DsMaterial m;
    DsMatClass c = pick_class(rng, cls, w, n);
    ds_material_random(&m, c, -1, rng);
    return m;
}

static void build_cup_like(Builder *b, MfRng *rng, DsFamily fam) {
    Spline s = {0};
    float th, fl;
    switch (fam) {
    case DS_FAM_VASE: {
        s.H = urange(rng, 1.2f, 2.2f);
        s.k = 6;
        float rb = urange(rng, 0.25f, 0.4f), bulge = urange(rng, 0.4f, 0.7f), neck = urange(rng, 0.12f, 0.25f);
        s.r[0] = rb; s.r[1] = bulge * urange(rng, 0.8f, 1.0f); s.r[2] = bulge; s.r[3] = neck * urange(rng, 1.2f, 1.8f);
        s.r[4] = neck; s.r[5] = neck * urange(rng, 1.1f, 1.6f);
        th = 0.03f; fl = 0.08f;
        break;
    }
    case DS_FAM_BOWL: {
        s.H = urange(rng, 0.35f, 0.6f);
        s.k = 4;
        float rt = urange(rng, 0.9f, 1.2f);
        s.r[0] = rt * urange(rng, 0.35f, 0.5f); s.r[1] = rt * 0.8f; s.r[2] = rt * 0.95f; s.r[3] = rt;
        th = 0.04f; fl = 0.05f;
        break;
    }
    default: { /* cup / mug body */
        s.H = urange(rng, 0.8f, 1.2f);
        s.k = 4;
        float r0 = urange(rng, 0.3f, 0.45f), flare = urange(rng, 1.0f, 1.35f);
        s.r[0] = r0; s.r[1] = r0 * (1.0f + (flare - 1.0f) * 0.4f) * urange(rng, 0.97f, 1.05f);
        s.r[2] = r0 * (1.0f + (flare - 1.0f) * 0.75f); s.r[3] = r0 * flare;
        th = 0.035f; fl = 0.06f;
        break;
    }
    }
    static const DsMatClass cls[] = {DS_MAT_CERAMIC, DS_MAT_PLASTIC, DS_MAT_METAL, DS_MAT_GLASS, DS_MAT_WOOD};
    static const float w_cup[] = {5, 2, 2, 0.5f, 0.5f}, w_vase[] = {5, 0.5f, 2, 1.5f, 0.5f}, w_bowl[] = {4, 2, 1.5f, 0.5f, 2};
    DsMaterial m = rand_mat(rng, cls, fam == DS_FAM_VASE ? w_vase : fam == DS_FAM_BOWL ? w_bowl : w_cup, 5);
    Profile pr;
    vessel_profile(&pr, &s, th, fl, 0.03f);
    int body = add_part(b, "body", mf_mat4_identity(), &m);
    revolve(b, body, &pr, 64);
    if (fam == DS_FAM_MUG) {
        /* handle: a tube segment in the XZ plane sticking out in +X */
        float zc = s.H * urange(rng, 0.45f, 0.55f);
        float Rh = s.H * urange(rng, 0.25f, 0.33f), rh = s.H * urange(rng, 0.035f, 0.055f);
        float rmin = fminf(spline_r(&s, zc - Rh), spline_r(&s, zc + Rh));
        float am = urange(rng, 1.5f, 1.75f);
        float cx = rmin - 0.5f * th - Rh * cosf(am);
        MfMat4 xf = mf_mat4_mul(mat_translate(mf_v3(cx, 0.0f, zc)), mat_rot_x(0.5f * MF_PI));
        DsMaterial hm = m;
        if (mf_rng_float(rng) < 0.3f) hm = rand_mat(rng, cls, w_cup, 3);
        int handle = add_part(b, "handle", xf, &hm);
        tube_segment(b, handle, Rh, rh, -am, am, 40, 6, 20);
    }
}

static void build_bottle(Builder *b, MfRng *rng) {
    float H = urange(rng, 1.4f, 2.4f), rb = urange(rng, 0.28f, 0.45f), rn = urange(rng, 0.08f, 0.13f);
    float zs = H * urange(rng, 0.5f, 0.65f), zn = H * urange(rng, 0.75f, 0.82f);
    Profile pr = {0};
    float f = 0.04f;
    prof_add(&pr, 0.0f, 0.0f);
    prof_line(&pr, rb - f, 0.0f, 8);
    prof_arc(&pr, rb - f, f, f, -0.5f * MF_PI, 0.0f, 5);
    int nw = 60;
    for (int k = 1; k <= nw; ++k) {
        float z = f + (H - 0.02f - f) * (float)k / (float)nw;
        float t = mf_clampf((z - zs) / (zn - zs), 0.0f, 1.0f);
        t = t * t * (3.0f - 2.0f * t);
        prof_add(&pr, rb + (rn - rb) * t, z);
    }
    prof_arc(&pr, rn - 0.02f, H - 0.02f, 0.02f, 0.0f, 0.5f * MF_PI, 4);
    prof_line(&pr, 0.0f, H, 6);
    static const DsMatClass cls[] = {DS_MAT_GLASS, DS_MAT_PLASTIC, DS_MAT_METAL, DS_MAT_CERAMIC};
    static const float w[] = {3, 3, 1.5f, 1};
    DsMaterial m = rand_mat(rng, cls, w, 4);
    if (m.cls != DS_MAT_GLASS && mf_rng_float(rng) < 0.6f) ds_material_random(&m, m.cls, DS_PAT_LABEL, rng);
    int body = add_part(b, "body", mf_mat4_identity(), &m);
    revolve(b, body, &pr, 64);
    static const DsMatClass ccls[] = {DS_MAT_METAL, DS_MAT_PLASTIC, DS_MAT_RUBBER};
    static const float cw[] = {2, 2, 1};
    DsMaterial cm = rand_mat(rng, ccls, cw, 3);
    float capH = urange(rng, 0.12f, 0.25f);
    Profile cp;
    puck_profile(&cp, rn * 1.18f, H - capH, H + 0.015f, 0.012f);
    int cap = add_part(b, "cap", mf_mat4_identity(), &cm);
    revolve(b, cap, &cp, 48);
}

static void build_box(Builder *b, MfRng *rng) {
    MfVec3 h = mf_v3(urange(rng, 0.3f, 0.5f), urange(rng, 0.2f, 0.5f), urange(rng, 0.15f, 0.5f));
    float rb = fminf(fminf(h.x, h.y), h.z) * urange(rng, 0.08f, 0.4f);
    static const DsMatClass cls[] = {DS_MAT_WOOD, DS_MAT_PLASTIC, DS_MAT_METAL, DS_MAT_RUBBER};
    static const float w[] = {3, 3, 2, 0.5f};
    DsMaterial m = rand_mat(rng, cls, w, 4);
    int p = add_part(b, "box", mf_mat4_identity(), &m);
    rounded_box(b, p, h, rb, 6, 16);
}

static void build_superquadric(Builder *b, MfRng *rng) {
    MfVec3 ax = mf_v3(urange(rng, 0.3f, 0.5f), urange(rng, 0.3f, 0.5f), urange(rng, 0.25f, 0.6f));
    float e1 = urange(rng, 0.35f, 1.6f), e2 = urange(rng, 0.35f, 1.6f);
    static const DsMatClass cls[] = {DS_MAT_PLASTIC, DS_MAT_METAL, DS_MAT_RUBBER, DS_MAT_CERAMIC};
    static const float w[] = {3, 2, 1, 2};
    DsMaterial m = rand_mat(rng, cls, w, 4);
    int p = add_part(b, "body", mf_mat4_identity(), &m);
    superquadric(b, p, ax, e1, e2, 96, 64, NULL);
}

static void build_torus(Builder *b, MfRng *rng) {
    float R = 0.5f, r = R * urange(rng, 0.18f, 0.45f), rz = r * urange(rng, 0.7f, 1.3f);
    static const DsMatClass cls[] = {DS_MAT_RUBBER, DS_MAT_PLASTIC, DS_MAT_METAL, DS_MAT_CERAMIC};
    static const float w[] = {2, 2, 2, 1};
    DsMaterial m = rand_mat(rng, cls, w, 4);
    int p = add_part(b, "ring", mf_mat4_identity(), &m);
    torus(b, p, R, r, rz, 96, 32);
}

static void build_clock(Builder *b, MfRng *rng) {
    float Rc = 1.0f, h = urange(rng, 0.18f, 0.35f), w = urange(rng, 0.06f, 0.14f), d = urange(rng, 0.04f, 0.08f);
    MfMat4 stand = mf_mat4_mul(mat_translate(mf_v3(0, 0, Rc)), mat_rot_x(0.5f * MF_PI)); /* face toward -Y */
    static const DsMatClass ccls[] = {DS_MAT_WOOD, DS_MAT_METAL, DS_MAT_PLASTIC};
    static const float cw[] = {2, 2, 2};
    DsMaterial cm = rand_mat(rng, ccls, cw, 3);
    Profile pr = {0};
    float f = 0.04f, e = 0.03f;
    prof_add(&pr, 0.0f, 0.0f);
    prof_line(&pr, Rc - f, 0.0f, 10);
    prof_arc(&pr, Rc - f, f, f, -0.5f * MF_PI, 0.0f, 5);
    prof_line(&pr, Rc, h - e, 6);
    prof_arc(&pr, Rc - e, h - e, e, 0.0f, 0.5f * MF_PI, 5);
    float f2 = fminf(0.012f, d / 3.0f); /* fillets at the recess edge (convex) and floor (concave) */
    prof_line(&pr, Rc - w + f2, h, 4);
    prof_arc(&pr, Rc - w + f2, h - f2, f2, 0.5f * MF_PI, MF_PI, 4);
    prof_line(&pr, Rc - w, h - d + f2, 4);
    prof_arc(&pr, Rc - w - f2, h - d + f2, f2, 0.0f, -0.5f * MF_PI, 4);
    prof_line(&pr, 0.0f, h - d, 10);
    int casep = add_part(b, "case", stand, &cm);
    revolve(b, casep, &pr, 96);
    /* face */
    static const DsMatClass fcls[] = {DS_MAT_CERAMIC, DS_MAT_PLASTIC};
    static const float fw[] = {1, 1};
    DsMaterial fm;
    ds_material_random(&fm, pick_class(rng, fcls, fw, 2), DS_PAT_TICKS, rng);
    float Rf = Rc - w - 0.004f, z0 = h - d + 0.002f, z1 = z0 + 0.008f;
    fm.mask_metal = 0;
    fm.base = mf_v3(urange(rng, 0.7f, 0.9f), urange(rng, 0.7f, 0.9f), urange(rng, 0.65f, 0.85f));
    fm.second = mf_v3(0.02f, 0.02f, 0.02f);
    fm.label_z1 = Rf; /* face radius, read by the tick pattern (local units before normalisation are fixed up below) */
    Profile fp;
    puck_profile(&fp, Rf, z0, z1, 0.003f);
    int face = add_part(b, "face", stand, &fm);
    revolve(b, face, &fp, 96);
    /* hands */
    static const DsMatClass hcls[] = {DS_MAT_METAL, DS_MAT_PLASTIC};
    static const float hw[] = {1, 1};
    DsMaterial hm;
    ds_material_random(&hm, pick_class(rng, hcls, hw, 2), DS_PAT_PLAIN, rng);
    if (hm.cls == DS_MAT_PLASTIC) hm.base = hm.second = mf_v3(0.02f, 0.02f, 0.02f);
    float lens[2] = {0.5f * Rf, 0.8f * Rf}, wids[2] = {0.035f, 0.022f};
    for (int k = 0; k < 2; ++k) {
        float ang = urange(rng, 0.0f, 2.0f * MF_PI), tk = 0.006f;
        float zc = z1 + 0.004f + tk + (float)k * (2.0f * tk + 0.004f);
        MfMat4 xf = mf_mat4_mul(stand, mf_mat4_mul(mat_translate(mf_v3(0, 0, zc)), mf_mat4_rot_z(ang)));
        xf = mf_mat4_mul(xf, mat_translate(mf_v3(0.4f * lens[k], 0, 0)));
        int hp = add_part(b, k == 0 ? "hour_hand" : "minute_hand", xf, &hm);
        rounded_box(b, hp, mf_v3(0.5f * lens[k] + 0.05f, wids[k], tk), 0.004f, 2, 8);
    }
    Profile pin;
    puck_profile(&pin, 0.04f, z1 - 0.002f, z1 + 0.05f, 0.01f);
    int pp = add_part(b, "pin", stand, &hm);
    revolve(b, pp, &pin, 32);
}

static void build_displaced(Builder *b, MfRng *rng) {
    MfVec3 ax = mf_v3(urange(rng, 0.35f, 0.5f), urange(rng, 0.35f, 0.5f), urange(rng, 0.3f, 0.55f));
    Displace dp = {urange(rng, 0.03f, 0.08f), urange(rng, 2.0f, 5.0f), ((uint64_t)mf_rng_u32(rng) << 32) | mf_rng_u32(rng)};
    float e = urange(rng, 0.8f, 1.2f);
    static const DsMatClass cls[] = {DS_MAT_CERAMIC, DS_MAT_RUBBER, DS_MAT_PLASTIC, DS_MAT_WOOD, DS_MAT_METAL};
    static const float w[] = {2, 1, 2, 1, 1};
    DsMaterial m = rand_mat(rng, cls, w, 5);
    int p = add_part(b, "body", mf_mat4_identity(), &m);
    superquadric(b, p, ax, e, e, 128, 80, &dp);
}

/* ------------------------------------------------------------------------------------------ */
/* Atlas packing                                                                              */

static void patch_lengths(Patch *pa) {
    double su = 0.0, sv = 0.0;
    for (int j = 0; j <= pa->nv; ++j)
        for (int i = 0; i < pa->nu; ++i) su += mf_len(mf_sub(PP(pa, i + 1, j), PP(pa, i, j)));
    for (int i = 0; i <= pa->nu; ++i)
        for (int j = 0; j < pa->nv; ++j) sv += mf_len(mf_sub(PP(pa, i, j + 1), PP(pa, i, j)));
    float lu = (float)(su / (pa->nv + 1)), lv = (float)(sv / (pa->nu + 1));
    lu = fmaxf(lu, 1e-4f);
    lv = fmaxf(lv, 1e-4f);
    if (lu > 4.0f * lv) lu = 4.0f * lv;
    if (lv > 4.0f * lu) lv = 4.0f * lu;
    pa->lu = lu;
    pa->lv = lv;
}

/* Charts get a uniform texel density, but at least minsz on a side (small parts such as clock
 * hands stay a few texels wide); shelf-packed (mf_pack), then stretched to span the atlas (single
 * long charts such as a torus would otherwise leave most of it empty). */
static int pack_atlas(Builder *b, float pad, float minsz) {
    int order[MAX_PATCHES];
    float size[2 * MAX_PATCHES];
    MfPackRect r[MAX_PATCHES];
    for (int k = 0; k < b->npatch; ++k) {
        patch_lengths(&b->patch[k]);
        size[2 * k] = b->patch[k].lu, size[2 * k + 1] = b->patch[k].lv;
    }
    int rc = mf_pack_order_by_height(size, b->npatch, order);
    if (rc) return rc;
    mf_pack_shelves(size, order, b->npatch, pad, minsz, 1, r);
    for (int k = 0; k < b->npatch; ++k) {
        Patch *pa = &b->patch[k];
        pa->x0 = r[k].x0, pa->y0 = r[k].y0, pa->w = r[k].w, pa->h = r[k].h;
    }
    return MF_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Mesh assembly, normals                                                                     */

static float tri_area(MfVec3 a, MfVec3 bb, MfVec3 c) { return 0.5f * mf_len(mf_cross(mf_sub(bb, a), mf_sub(c, a))); }

typedef struct { int64_t k[3]; int part; int idx; } WeldKey;

static int weld_cmp(const void *pa, const void *pb) {
    const WeldKey *a = pa, *b = pb;
    if (a->part != b->part) return a->part < b->part ? -1 : 1;
    for (int i = 0; i < 3; ++i)
        if (a->k[i] != b->k[i]) return a->k[i] < b->k[i] ? -1 : 1;
    return a->idx < b->idx ? -1 : (a->idx > b->idx);
}

/* Smooth normals welded across seams within each part (vertices equal to 1e-6). */
static int welded_normals(MfMesh *m, const int *vpart) {
    WeldKey *keys = malloc(sizeof(WeldKey) * (size_t)m->nv + 1);
    int *rep = malloc(sizeof(int) * (size_t)m->nv + 1);
    double *acc = calloc((size_t)m->nv * 3 + 1, sizeof(double));
    if (!keys || !rep || !acc) { free(keys); free(rep); free(acc); return mf_fail(MF_ENOMEM, "out of memory for normals"); }
    for (int i = 0; i < m->nv; ++i) {
        for (int k = 0; k < 3; ++k) keys[i].k[k] = llrint((double)m->pos[3 * i + k] * 1e6);
        keys[i].part = vpart[i];
        keys[i].idx = i;
    }
    qsort(keys, (size_t)m->nv, sizeof(WeldKey), weld_cmp);
    for (int i = 0; i < m->nv; ++i) {
        int same = i > 0 && keys[i].part == keys[i - 1].part && keys[i].k[0] == keys[i - 1].k[0] &&
                   keys[i].k[1] == keys[i - 1].k[1] && keys[i].k[2] == keys[i - 1].k[2];
        rep[keys[i].idx] = same ? rep[keys[i - 1].idx] : keys[i].idx;
    }
    for (int t = 0; t < m->nt; ++t) {
        const uint32_t *f = m->tri + 3 * t;
        MfVec3 a = mf_v3(m->pos[3 * f[0]], m->pos[3 * f[0] + 1], m->pos[3 * f[0] + 2]);
        MfVec3 bb = mf_v3(m->pos[3 * f[1]], m->pos[3 * f[1] + 1], m->pos[3 * f[1] + 2]);
        MfVec3 c = mf_v3(m->pos[3 * f[2]], m->pos[3 * f[2] + 1], m->pos[3 * f[2] + 2]);
        MfVec3 n = mf_cross(mf_sub(bb, a), mf_sub(c, a));
        for (int k = 0; k < 3; ++k) {
            int r = rep[f[k]];
            acc[3 * r] += n.x;
            acc[3 * r + 1] += n.y;
            acc[3 * r + 2] += n.z;
        }
    }
    for (int i = 0; i < m->nv; ++i) {
        int r = rep[i];
        double x = acc[3 * r], y = acc[3 * r + 1], z = acc[3 * r + 2], l = sqrt(x * x + y * y + z * z);
        if (l > 0.0) { x /= l; y /= l; z /= l; } else { x = 0; y = 0; z = 1; }
        m->nrm[3 * i] = (float)x;
        m->nrm[3 * i + 1] = (float)y;
        m->nrm[3 * i + 2] = (float)z;
    }
    free(keys);
    free(rep);
    free(acc);
    return MF_OK;
}

static int assemble(Builder *b, MfMesh *out, int *vpart_out[]) {
    int nv = 0, nt = 0;
    for (int k = 0; k < b->npatch; ++k) {
        Patch *pa = &b->patch[k];
        nv += (pa->nu + 1) * (pa->nv + 1);
        nt += 2 * pa->nu * pa->nv;
    }
    MfMesh m;
    int rc = mf_mesh_alloc(&m, nv, nt, 1, 1);
    if (rc) return rc;
    m.mat = calloc((size_t)nt + 1, sizeof(int));
    m.mat_names = calloc((size_t)b->nparts + 1, sizeof(char *));
    int *vpart = calloc((size_t)nv + 1, sizeof(int));
    if (!m.mat || !m.mat_names || !vpart) { free(vpart); mf_mesh_free(&m); return mf_fail(MF_ENOMEM, "out of memory for a mesh"); }
    m.nmat = b->nparts;
    for (int p = 0; p < b->nparts; ++p) m.mat_names[p] = strdup(b->names[p]);
    int v = 0, t = 0;
    for (int k = 0; k < b->npatch; ++k) {
        Patch *pa = &b->patch[k];
        const MfMat4 *xf = &b->xf[pa->part];
        int base = v;
        for (int j = 0; j <= pa->nv; ++j)
            for (int i = 0; i <= pa->nu; ++i) {
                MfVec3 q = mf_mat4_point(xf, PP(pa, i, j));
                m.pos[3 * v] = q.x; m.pos[3 * v + 1] = q.y; m.pos[3 * v + 2] = q.z;
                m.uv[2 * v] = pa->x0 + pa->w * (float)i / (float)pa->nu;
                m.uv[2 * v + 1] = pa->y0 + pa->h * (float)j / (float)pa->nv;
                vpart[v] = pa->part;
                ++v;
            }
        for (int j = 0; j < pa->nv; ++j)
            for (int i = 0; i < pa->nu; ++i) {
                uint32_t a = (uint32_t)(base + j * (pa->nu + 1) + i), bq = a + 1, c = a + (uint32_t)(pa->nu + 1), d = c + 1;
                uint32_t tris[2][3] = {{a, bq, d}, {a, d, c}};
                for (int q = 0; q < 2; ++q) {
                    uint32_t *f = tris[q];
                    MfVec3 p0 = mf_v3(m.pos[3 * f[0]], m.pos[3 * f[0] + 1], m.pos[3 * f[0] + 2]);
                    MfVec3 p1 = mf_v3(m.pos[3 * f[1]], m.pos[3 * f[1] + 1], m.pos[3 * f[1] + 2]);
                    MfVec3 p2 = mf_v3(m.pos[3 * f[2]], m.pos[3 * f[2] + 1], m.pos[3 * f[2] + 2]);
                    if (!(tri_area(p0, p1, p2) > 1e-9f)) continue; /* pole triangles */
                    m.tri[3 * t] = f[0];
                    m.tri[3 * t + 1] = pa->flip ? f[2] : f[1];
                    m.tri[3 * t + 2] = pa->flip ? f[1] : f[2];
                    m.mat[t] = pa->part;
                    ++t;
                }
            }
    }
    m.nt = t;
    /* drop vertices no triangle uses (pole columns whose triangles were degenerate) */
    {
        int *remap = malloc(sizeof(int) * (size_t)nv + 1);
        if (!remap) { free(vpart); mf_mesh_free(&m); return mf_fail(MF_ENOMEM, "out of memory for a mesh"); }
        for (int i = 0; i < nv; ++i) remap[i] = -1;
        for (int i = 0; i < 3 * m.nt; ++i) remap[m.tri[i]] = 0;
        int nn = 0;
        for (int i = 0; i < nv; ++i) {
            if (remap[i] < 0) continue;
            remap[i] = nn;
            memmove(m.pos + 3 * nn, m.pos + 3 * i, 3 * sizeof(float));
            memmove(m.uv + 2 * nn, m.uv + 2 * i, 2 * sizeof(float));
            vpart[nn] = vpart[i];
            ++nn;
        }
        for (int i = 0; i < 3 * m.nt; ++i) m.tri[i] = (uint32_t)remap[m.tri[i]];
        m.nv = nn;
        free(remap);
    }
    /* outward winding: each part is closed, so its signed volume must be positive */
    for (int p = 0; p < b->nparts; ++p) {
        double vol = 0.0;
        for (int i = 0; i < m.nt; ++i) {
            if (m.mat[i] != p) continue;
            const uint32_t *f = m.tri + 3 * i;
            MfVec3 p0 = mf_v3(m.pos[3 * f[0]], m.pos[3 * f[0] + 1], m.pos[3 * f[0] + 2]);
            MfVec3 p1 = mf_v3(m.pos[3 * f[1]], m.pos[3 * f[1] + 1], m.pos[3 * f[1] + 2]);
            MfVec3 p2 = mf_v3(m.pos[3 * f[2]], m.pos[3 * f[2] + 1], m.pos[3 * f[2] + 2]);
            vol += (double)mf_dot(p0, mf_cross(p1, p2));
        }
        if (vol < 0.0)
            for (int i = 0; i < m.nt; ++i)
                if (m.mat[i] == p) { uint32_t s = m.tri[3 * i + 1]; m.tri[3 * i + 1] = m.tri[3 * i + 2]; m.tri[3 * i + 2] = s; }
    }
    *out = m;
    *vpart_out = vpart;
    return MF_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Texture baking                                                                             */

static int bake(DsObject *o, int res, int gutter) {
    const MfMesh *m = &o->mesh;
    size_t npx = (size_t)res * res;
    int *tid = malloc(npx * sizeof(int));
    float *bary = malloc(npx * 2 * sizeof(float));
    MfImage kd = {0}, orm = {0};
    int rc = MF_OK;
    if (!tid || !bary) { rc = mf_fail(MF_ENOMEM, "out of memory for baking"); goto done; }
    if ((rc = mf_image_alloc(&kd, res, res, 3)) || (rc = mf_image_alloc(&orm, res, res, 3))) goto done;
    /* 1. rasterise UV footprints (mf_bake_raster: serial, the later triangle wins on shared edges) */
    if ((rc = mf_bake_raster(m, res, tid, bary))) goto done;
    /* 2. evaluate materials at the 3D surface points (parallel over texels, pure functions) */
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
            size_t i = (size_t)y * res + x;
            float *ok = kd.data + 3 * i, *oo = orm.data + 3 * i;
            oo[0] = 1.0f;
            if (tid[i] < 0) continue;
            float pp[3], nn[3];
            mf_bake_point(m, tid, bary, i, pp, nn);
            MfVec3 p = mf_v3(pp[0], pp[1], pp[2]), n = mf_v3(nn[0], nn[1], nn[2]);
            const DsPart *part = &o->parts[m->mat[tid[i]]];
            MfVec3 lp = mf_mat4_point(&part->obj_to_local, p), ln = mf_norm(mf_mat4_dir(&part->obj_to_local, n));
            MfVec3 c;
            float r, mt;
            ds_material_eval(&part->mat, lp, ln, &c, &r, &mt);
            ok[0] = c.x; ok[1] = c.y; ok[2] = c.z;
            oo[1] = r; oo[2] = mt;
        }
    /* 3. gutter: `gutter` rings of dilation, then the mean of the covered texels */
    static const float kd_fill[3] = {0.5f, 0.5f, 0.5f}, orm_fill[3] = {1.0f, 0.5f, 0.5f};
    if ((rc = mf_bake_gutter(kd.data, res, 3, tid, gutter, kd_fill)) || (rc = mf_bake_gutter(orm.data, res, 3, tid, gutter, orm_fill)))
        goto done;
    o->kd = kd;
    o->orm = orm;
    kd.data = orm.data = NULL;
done:
    mf_image_free(&kd);
    mf_image_free(&orm);
    free(tid);
    free(bary);
    return rc;
}

/* ------------------------------------------------------------------------------------------ */

int ds_object_generate(DsObject *out, DsFamily fam, uint64_t seed, int tex_res) {
    if (fam < 0 || fam >= DS_FAM_COUNT) return mf_fail(MF_EARG, "object family %d is unknown", (int)fam);
    if (tex_res < 16 || tex_res > 8192) return mf_fail(MF_EARG, "texture resolution %d is outside [16, 8192]", tex_res);
    MfRng rng;
    mf_rng_seed(&rng, seed, 0x5EED0000u + (uint64_t)fam);
    Builder *b = calloc(1, sizeof(Builder));
    if (!b) return mf_fail(MF_ENOMEM, "out of memory");
    switch (fam) {
    case DS_FAM_CUP: case DS_FAM_VASE: case DS_FAM_BOWL: case DS_FAM_MUG: build_cup_like(b, &rng, fam); break;
    case DS_FAM_BOTTLE: build_bottle(b, &rng); break;
    case DS_FAM_BOX: build_box(b, &rng); break;
    case DS_FAM_SUPERQUADRIC: build_superquadric(b, &rng); break;
    case DS_FAM_TORUS: build_torus(b, &rng); break;
    case DS_FAM_CLOCK: build_clock(b, &rng); break;
    case DS_FAM_DISPLACED: build_displaced(b, &rng); break;
    default: break;
    }
    int rc = MF_OK;
    DsObject o = {0};
    int *vpart = NULL;
    if (b->oom) { rc = mf_fail(MF_ENOMEM, "out of memory building a %s", ds_family_name(fam)); goto fail; }
    /* local material frames centred on each part's local bounds */
    MfVec3 lc[DS_MAX_PARTS];
    for (int p = 0; p < b->nparts; ++p) {
        MfVec3 lo = mf_v3s(FLT_MAX), hi = mf_v3s(-FLT_MAX);
        for (int k = 0; k < b->npatch; ++k) {
            Patch *pa = &b->patch[k];
            if (pa->part != p) continue;
            for (int i = 0; i < (pa->nu + 1) * (pa->nv + 1); ++i) {
                MfVec3 q = pa->p[i];
                lo = mf_v3(fminf(lo.x, q.x), fminf(lo.y, q.y), fminf(lo.z, q.z));
                hi = mf_v3(fmaxf(hi.x, q.x), fmaxf(hi.y, q.y), fmaxf(hi.z, q.z));
            }
        }
        lc[p] = mf_scale(mf_add(lo, hi), 0.5f);
    }
    if ((rc = pack_atlas(b, 2.0f * (float)DS_DEFAULT_GUTTER / (float)tex_res, 8.0f / (float)tex_res))) goto fail;
    if ((rc = assemble(b, &o.mesh, &vpart))) goto fail;
    if ((rc = welded_normals(&o.mesh, vpart))) goto fail;
    /* normalise as mf_mesh_normalize does, remembering centre c and scale s */
    MfVec3 lo, hi;
    mf_mesh_bounds(&o.mesh, &lo, &hi);
    MfVec3 c = mf_scale(mf_add(lo, hi), 0.5f);
    float big = mf_maxc(mf_sub(hi, lo)), s = big > 0.0f ? 1.0f / big : 1.0f;
    mf_mesh_normalize(&o.mesh, 1.0f);
    o.family = fam;
    o.seed = seed;
    o.nparts = b->nparts;
    for (int p = 0; p < b->nparts; ++p) {
        DsPart *dp = &o.parts[p];
        snprintf(dp->name, sizeof dp->name, "%s", b->names[p]);
        dp->mat = b->mats[p];
        /* local' = R^T (p_norm / s + c - t) * s - lc * s  =  R^T p_norm + R^T s (c - t) - s lc */
        const float *x = b->xf[p].m;
        MfVec3 t = mf_v3(x[3], x[7], x[11]);
        MfVec3 ct = mf_scale(mf_sub(c, t), s);
        MfMat4 L = mf_mat4_identity();
        for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) L.m[r * 4 + k] = x[k * 4 + r];
            L.m[r * 4 + 3] = x[0 * 4 + r] * ct.x + x[1 * 4 + r] * ct.y + x[2 * 4 + r] * ct.z - s * (&lc[p].x)[r];
        }
        dp->obj_to_local = L;
        if (dp->mat.pattern == DS_PAT_TICKS) dp->mat.label_z1 *= s; /* face radius in normalised units */
        else {
            dp->mat.label_z0 *= 1.0f; /* label band is already in normalised part-centred units */
        }
    }
    if ((rc = bake(&o, tex_res, DS_DEFAULT_GUTTER))) goto fail;
    free(vpart);
    builder_free(b);
    free(b);
    *out = o;
    return MF_OK;
fail:
    free(vpart);
    ds_object_free(&o);
    builder_free(b);
    free(b);
    return rc;
}

void ds_object_free(DsObject *o) {
    if (!o) return;
    mf_mesh_free(&o->mesh);
    mf_image_free(&o->kd);
    mf_image_free(&o->orm);
    mf_image_free(&o->normal);
    memset(o, 0, sizeof *o);
}

int ds_object_write_textures(const DsObject *o, const char *dir) {
    char p[MF_PATH_MAX];
    int rc = mf_mkdirs(dir);
    if (rc) return rc;
    if ((rc = mf_path_join(p, sizeof p, dir, "kd.png"))) return rc;
    if ((rc = mf_image_write(p, &o->kd, MF_ENC_SRGB, 8))) return rc;
    if ((rc = mf_path_join(p, sizeof p, dir, "orm.png"))) return rc;
    if ((rc = mf_image_write(p, &o->orm, MF_ENC_LINEAR, 8))) return rc;
    if (!o->normal.data) return MF_OK;
    if ((rc = mf_path_join(p, sizeof p, dir, "normal.png"))) return rc;
    return mf_image_write(p, &o->normal, MF_ENC_LINEAR, 8); /* as a result's normal.png */
}

int ds_object_write(const DsObject *o, const char *scene_dir) {
    char p[MF_PATH_MAX];
    int rc;
    if ((rc = mf_mkdirs(scene_dir))) return rc;
    if ((rc = mf_path_join(p, sizeof p, scene_dir, "gt"))) return rc;
    if ((rc = ds_object_write_textures(o, p))) return rc;
    if ((rc = mf_path_join(p, sizeof p, scene_dir, "mesh.obj"))) return rc;
    if ((rc = mf_obj_write(p, &o->mesh, "gt/kd.png"))) return rc;
    /* gt/object.json: what was generated (family, seed, per-part material class and parameters) */
    static const char *pat_names[DS_PAT_COUNT] = {"plain", "fbm", "stripes", "checker", "label", "ticks"};
    cJSON *root = cJSON_CreateObject(), *parts = cJSON_CreateArray();
    char seedstr[32];
    snprintf(seedstr, sizeof seedstr, "%llu", (unsigned long long)o->seed);
    if (o->asset[0]) {
        cJSON_AddStringToObject(root, "asset", o->asset);
        cJSON_AddBoolToObject(root, "normal_map", o->normal.data != NULL);
        if (o->unrendered[0]) cJSON_AddStringToObject(root, "not_rendered", o->unrendered);
    } else {
        cJSON_AddStringToObject(root, "family", ds_family_name(o->family));
    }
    cJSON_AddStringToObject(root, "seed", seedstr);
    cJSON_AddNumberToObject(root, "triangles", o->mesh.nt);
    cJSON_AddNumberToObject(root, "texture_size", o->kd.w);
    cJSON_AddItemToObject(root, "parts", parts);
    for (int k = 0; k < o->nparts; ++k) {
        const DsMaterial *m = &o->parts[k].mat;
        cJSON *pj = cJSON_CreateObject();
        const float base[3] = {m->base.x, m->base.y, m->base.z};
        cJSON_AddStringToObject(pj, "name", o->parts[k].name);
        cJSON_AddStringToObject(pj, "class", ds_mat_class_name(m->cls));
        cJSON_AddStringToObject(pj, "pattern", pat_names[m->pattern]);
        cJSON_AddItemToObject(pj, "base_color_linear", cJSON_CreateFloatArray(base, 3));
        cJSON_AddNumberToObject(pj, "roughness", m->rough);
        cJSON_AddNumberToObject(pj, "metallic", m->metallic);
        cJSON_AddBoolToObject(pj, "metallic_mask", m->mask_metal);
        cJSON_AddItemToArray(parts, pj);
    }
    if (!(rc = mf_path_join(p, sizeof p, scene_dir, "gt/object.json"))) rc = mf_json_save(p, root);
    cJSON_Delete(root);
    return rc;
}
