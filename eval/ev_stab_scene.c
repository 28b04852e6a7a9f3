/* ev_stab_scene: see ev_stab_scene.h. */
#include "eval/ev_stab_scene.h"

#include <cJSON.h>
#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_gen.h"
#include "datasets/ds_split.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "io/mf_json.h"
#include "io/mf_obj.h"

#define SCENE "000_cup"
#define SUN_RADIUS_DEG 2.0
#define SUN_ELEV_DEG 40.0
#define GRAZING_ELEV_DEG 0.5
#define SLIVER_T 1e-4f

static int tiny_spec(DsSplitSpec *s) {
    int rc = ds_split_spec("tiny", s);
    s->n_scenes = 1;
    return rc;
}

int ev_stab_layout(const char *layout_dir) {
    char p[MF_PATH_MAX];
    int rc = mf_path_join(p, sizeof p, layout_dir, "split.json");
    if (rc || mf_file_exists(p)) return rc;
    DsSplitSpec s;
    if ((rc = tiny_spec(&s))) return rc;
    return ds_write_split(&s, layout_dir, NULL, 1);
}

/* ---- copying a folder ---- */

static const char *g_src, *g_dst;
static int g_copy_rc;

static int copy_one(const char *path, const struct stat *sb, int flag, struct FTW *ftw) {
    (void)sb, (void)ftw;
    char dst[MF_PATH_MAX];
    const char *rel = path + strlen(g_src);
    if (snprintf(dst, sizeof dst, "%s%s", g_dst, rel) >= (int)sizeof dst) return g_copy_rc = mf_fail(MF_EARG, "%s: path too long", path);
    if (flag == FTW_D) return (g_copy_rc = mf_mkdirs(dst));
    if (flag != FTW_F) return 0;
    char *data = NULL;
    size_t len = 0;
    if ((g_copy_rc = mf_read_file(path, &data, &len))) return g_copy_rc;
    g_copy_rc = mf_write_file(dst, data, len);
    free(data);
    return g_copy_rc;
}

static int copy_tree(const char *src, const char *dst) {
    g_src = src, g_dst = dst, g_copy_rc = MF_OK;
    if (nftw(src, copy_one, 16, FTW_PHYS) != 0) return g_copy_rc ? g_copy_rc : mf_fail(MF_EIO, "%s: cannot copy to %s", src, dst);
    return MF_OK;
}

/* ---- rewrites before rendering ---- */

static int fill_png(const char *path, MfEncoding enc, float r, float g, float b) {
    MfImage im;
    int rc = mf_image_read(path, enc, &im);
    if (rc) return rc;
    for (int i = 0; i < im.w * im.h; ++i) {
        float v[3] = {r, g, b};
        for (int c = 0; c < 3 && c < im.c; ++c) im.data[(size_t)i * im.c + c] = v[c];
    }
    rc = mf_image_write(path, &im, enc, 8);
    mf_image_free(&im);
    return rc;
}

/* gt/env.exr x gain, plus (sun != 0) the HDR sun disc of ev_stab_scene.h. Blender mapping
 * (DESIGN.md): texel (x, y) looks along u = (x + 0.5) / W, v = 1 - (y + 0.5) / H,
 * phi = 2 pi (0.5 - u), z = sin(pi (v - 0.5)). */
static int rewrite_env(const char *path, double gain, int sun) {
    MfImage im;
    int rc = mf_image_read(path, MF_ENC_LINEAR, &im);
    if (rc) return rc;
    for (size_t i = 0; i < (size_t)im.w * im.h * im.c; ++i) im.data[i] = (float)(im.data[i] * gain);
    if (sun) {
        double e = SUN_ELEV_DEG * M_PI / 180.0, sd[3] = {cos(e), 0.0, sin(e)};
        double cr = cos(SUN_RADIUS_DEG * M_PI / 180.0), radiance = DS_SUN_MAX / (2.0 * M_PI * (1.0 - cr));
        int hits = 0, best = 0;
        double best_dot = -2.0;
        for (int pass = 0; pass < 2 && !hits; ++pass)
            for (int y = 0; y < im.h; ++y)
                for (int x = 0; x < im.w; ++x) {
                    double u = (x + 0.5) / im.w, v = 1.0 - (y + 0.5) / im.h, phi = 2.0 * M_PI * (0.5 - u);
                    double z = sin(M_PI * (v - 0.5)), rxy = sqrt(1.0 - z * z);
                    double d = rxy * cos(phi) * sd[0] + rxy * sin(phi) * sd[1] + z * sd[2];
                    int idx = y * im.w + x;
                    if (d > best_dot) best_dot = d, best = idx;
                    if (pass == 0 ? d < cr : idx != best) continue;
                    for (int c = 0; c < 3 && c < im.c; ++c) im.data[(size_t)idx * im.c + c] += (float)radiance;
                    ++hits;
                }
    }
    rc = mf_image_write(path, &im, MF_ENC_LINEAR, 32);
    mf_image_free(&im);
    return rc;
}

/* Rewrites transforms_<split>.json: scale != 1 scales camera positions; grazing moves cameras
 * to GRAZING_ELEV_DEG; keep > 0 keeps the first `keep` frames; exr appends ".exr" to file_path. */
static int rewrite_cams(const char *sdir, const char *split, double scale, int grazing, int keep, int exr) {
    char p[MF_PATH_MAX], f[64];
    snprintf(f, sizeof f, "transforms_%s.json", split);
    cJSON *j = NULL;
    const cJSON *frames;
    int nf = 0, rc = mf_path_join(p, sizeof p, sdir, f);
    if (rc || (rc = mf_json_load(p, &j))) return rc;
    if ((rc = mf_json_array(p, "", j, "frames", &frames, &nf))) goto done;
    while (keep > 0 && cJSON_GetArraySize(frames) > keep) cJSON_DeleteItemFromArray((cJSON *)frames, cJSON_GetArraySize(frames) - 1);
    nf = cJSON_GetArraySize(frames);
    for (int i = 0; i < nf && !rc; ++i) {
        cJSON *fr = cJSON_GetArrayItem(frames, i);
        double m[16];
        char where[32];
        snprintf(where, sizeof where, "frames[%d]", i);
        if ((rc = mf_json_numbers(p, where, fr, "transform_matrix", 4, 4, m))) break;
        double t[3] = {m[3] * scale, m[7] * scale, m[11] * scale};
        if (grazing) {
            double dist = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]), az = atan2(t[1], t[0]), e = GRAZING_ELEV_DEG * M_PI / 180.0;
            double zc[3] = {cos(e) * cos(az), cos(e) * sin(az), sin(e)}; /* camera +z: away from the object */
            double xn = sqrt(zc[0] * zc[0] + zc[1] * zc[1]), xc[3] = {-zc[1] / xn, zc[0] / xn, 0.0}; /* (0,0,1) x z */
            double yc[3] = {zc[1] * xc[2] - zc[2] * xc[1], zc[2] * xc[0] - zc[0] * xc[2], zc[0] * xc[1] - zc[1] * xc[0]};
            for (int r = 0; r < 3; ++r) m[4 * r] = xc[r], m[4 * r + 1] = yc[r], m[4 * r + 2] = zc[r], t[r] = dist * zc[r];
        }
        m[3] = t[0], m[7] = t[1], m[11] = t[2];
        cJSON *rows = cJSON_CreateArray();
        for (int r = 0; r < 4; ++r) cJSON_AddItemToArray(rows, cJSON_CreateDoubleArray(m + 4 * r, 4));
        cJSON_ReplaceItemInObject(fr, "transform_matrix", rows);
        if (exr) {
            const char *fp = NULL;
            char np[MF_PATH_MAX];
            if ((rc = mf_json_string(p, where, fr, "file_path", &fp))) break;
            snprintf(np, sizeof np, "%s.exr", fp);
            cJSON_ReplaceItemInObject(fr, "file_path", cJSON_CreateString(np));
        }
    }
    if (!rc) rc = mf_json_save(p, j);
done:
    cJSON_Delete(j);
    return rc;
}

/* mesh.obj: vertices x scale, or (sliver) each triangle split into a sliver pair plus a
 * zero-area triangle. */
static int rewrite_mesh(const char *sdir, double scale, int sliver) {
    char p[MF_PATH_MAX];
    MfMesh m, o;
    int rc = mf_path_join(p, sizeof p, sdir, "mesh.obj");
    if (rc || (rc = mf_obj_read(p, &m))) return rc;
    if (!sliver) {
        for (int i = 0; i < 3 * m.nv; ++i) m.pos[i] = (float)(m.pos[i] * scale);
        rc = mf_obj_write(p, &m, NULL);
        mf_mesh_free(&m);
        return rc;
    }
    if ((rc = mf_mesh_alloc(&o, m.nv + m.nt, 3 * m.nt, m.nrm != NULL, m.uv != NULL))) {
        mf_mesh_free(&m);
        return rc;
    }
    memcpy(o.pos, m.pos, sizeof(float) * 3 * (size_t)m.nv);
    if (m.nrm) memcpy(o.nrm, m.nrm, sizeof(float) * 3 * (size_t)m.nv);
    if (m.uv) memcpy(o.uv, m.uv, sizeof(float) * 2 * (size_t)m.nv);
    for (int t = 0; t < m.nt; ++t) {
        uint32_t a = m.tri[3 * t], b = m.tri[3 * t + 1], c = m.tri[3 * t + 2], k = (uint32_t)(m.nv + t);
        for (int d = 0; d < 3; ++d) o.pos[3 * k + d] = m.pos[3 * b + d] + SLIVER_T * (m.pos[3 * c + d] - m.pos[3 * b + d]);
        if (m.nrm) {
            float n[3], len = 0.0f;
            for (int d = 0; d < 3; ++d) n[d] = m.nrm[3 * b + d] + SLIVER_T * (m.nrm[3 * c + d] - m.nrm[3 * b + d]), len += n[d] * n[d];
            for (int d = 0; d < 3; ++d) o.nrm[3 * k + d] = n[d] / sqrtf(len > 0.0f ? len : 1.0f);
        }
        if (m.uv)
            for (int d = 0; d < 2; ++d) o.uv[2 * k + d] = m.uv[2 * b + d] + SLIVER_T * (m.uv[2 * c + d] - m.uv[2 * b + d]);
        uint32_t tris[9] = {a, b, k, a, k, c, a, b, b};
        memcpy(o.tri + 9 * (size_t)t, tris, sizeof tris);
    }
    rc = mf_obj_write(p, &o, NULL);
    mf_mesh_free(&o);
    mf_mesh_free(&m);
    return rc;
}

/* ---- rewrites of the rendered training images ---- */

/* Linear RGB x gain, or the few-pixel mask, written as an sRGB PNG of `bits` 8 or 16 (clipped
 * at 1) or, with bits 32, as a float EXR beside it (the PNG removed). */
static int rewrite_train_view(const char *png, double gain, int bits, int mask) {
    MfImage im;
    int rc = mf_image_read(png, MF_ENC_SRGB, &im);
    if (rc) return rc;
    if (im.c != 4) {
        mf_image_free(&im);
        return mf_fail(MF_EFORMAT, "%s: expected RGBA", png);
    }
    if (mask) { /* 2 x 2 block at the alpha-weighted centroid */
        double sx = 0, sy = 0, sa = 0;
        for (int y = 0; y < im.h; ++y)
            for (int x = 0; x < im.w; ++x) {
                double a = mf_image_px(&im, x, y)[3];
                sx += a * x, sy += a * y, sa += a;
            }
        int cx = sa > 0 ? (int)(sx / sa) : im.w / 2, cy = sa > 0 ? (int)(sy / sa) : im.h / 2;
        for (int y = 0; y < im.h; ++y)
            for (int x = 0; x < im.w; ++x)
                if (x < cx || x > cx + 1 || y < cy || y > cy + 1) memset(mf_image_px(&im, x, y), 0, 4 * sizeof(float));
    }
    for (int i = 0; i < im.w * im.h; ++i)
        for (int c = 0; c < 3; ++c) im.data[4 * i + c] = (float)(im.data[4 * i + c] * gain);
    if (bits == 32) {
        char p[MF_PATH_MAX];
        size_t n = strlen(png);
        snprintf(p, sizeof p, "%.*s.exr", (int)(n - 4), png);
        if (!(rc = mf_image_write(p, &im, MF_ENC_LINEAR, 32))) remove(png);
    } else {
        rc = mf_image_write(png, &im, MF_ENC_SRGB, bits);
    }
    mf_image_free(&im);
    return rc;
}

static int rewrite_train(const char *sdir, int n, double gain, int bits, int mask) {
    int rc = MF_OK;
    for (int i = 0; i < n && !rc; ++i) {
        char rel[32], p[MF_PATH_MAX];
        snprintf(rel, sizeof rel, "train/r_%03d.png", i);
        if (!(rc = mf_path_join(p, sizeof p, sdir, rel))) rc = rewrite_train_view(p, gain, bits, mask);
    }
    if (!rc && bits == 32) rc = rewrite_cams(sdir, "train", 1.0, 0, 0, 1);
    return rc;
}

int ev_stab_variant_build(const char *layout_dir, const EvStabVariant *v, const char *out_dir) {
    char done[MF_PATH_MAX], sdir[MF_PATH_MAX], p[MF_PATH_MAX];
    int rc;
    if ((rc = mf_path_join(done, sizeof done, out_dir, ".done")) || (rc = mf_path_join(sdir, sizeof sdir, out_dir, SCENE))) return rc;
    if (mf_file_exists(done)) return MF_OK;
    DsSplitSpec s;
    if ((rc = tiny_spec(&s)) || (rc = mf_mkdirs(out_dir)) || (rc = copy_tree(layout_dir, out_dir))) return rc;
    switch (v->kind) { /* before rendering */
    case EV_VAR_MIRROR_SUN:
        if (!(rc = mf_path_join(p, sizeof p, sdir, "gt/orm.png")) && !(rc = fill_png(p, MF_ENC_LINEAR, 1.0f, 0.0f, 1.0f)) &&
            !(rc = mf_path_join(p, sizeof p, sdir, "gt/env.exr")))
            rc = rewrite_env(p, 1.0, 1);
        break;
    case EV_VAR_GRAZING: rc = rewrite_cams(sdir, "train", 1.0, 1, 0, 0); break;
    case EV_VAR_ALBEDO:
        if (!(rc = mf_path_join(p, sizeof p, sdir, "gt/kd.png"))) rc = fill_png(p, MF_ENC_SRGB, (float)v->p, (float)v->p, (float)v->p);
        break;
    case EV_VAR_ENV_STOPS:
        if (!(rc = mf_path_join(p, sizeof p, sdir, "gt/env.exr"))) rc = rewrite_env(p, pow(2.0, v->p), 0);
        break;
    case EV_VAR_SCALE:
        if (!(rc = rewrite_mesh(sdir, v->p, 0)) && !(rc = rewrite_cams(sdir, "train", v->p, 0, 0, 0)))
            rc = rewrite_cams(sdir, "test", v->p, 0, 0, 0);
        break;
    case EV_VAR_SLIVER: rc = rewrite_mesh(sdir, 1.0, 1); break;
    case EV_VAR_ONE_VIEW: rc = rewrite_cams(sdir, "train", 1.0, 0, 1, 0); break;
    default: break;
    }
    if (v->kind == EV_VAR_ONE_VIEW) s.n_train = 1;
    if (!rc) rc = ds_render_split(&s, out_dir, NULL);
    switch (v->kind) { /* after rendering */
    case EV_VAR_EXPOSURE_EXR: if (!rc) rc = rewrite_train(sdir, s.n_train, pow(2.0, v->p), 32, 0); break;
    case EV_VAR_EXPOSURE_PNG:
    case EV_VAR_SATURATE: if (!rc) rc = rewrite_train(sdir, s.n_train, pow(2.0, v->p), 8, 0); break;
    case EV_VAR_EXPOSURE_PNG_BACK: /* the 8-bit darkened values, brightened back in 16 bits */
        if (!rc && !(rc = rewrite_train(sdir, s.n_train, pow(2.0, v->p), 8, 0)))
            rc = rewrite_train(sdir, s.n_train, pow(2.0, -v->p), 16, 0);
        break;
    case EV_VAR_MASK: if (!rc) rc = rewrite_train(sdir, s.n_train, 1.0, 8, 1); break;
    default: break;
    }
    if (!rc) rc = mf_write_file(done, v->id, strlen(v->id));
    return rc;
}
