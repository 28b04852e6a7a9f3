/* Tests of mf/prior/mf_prior: refusal of bad weights, guidance, per-view mean predictions, the
 * encoder's backward, image preparation and the material latents; hostile weight files (issue
 * 15): configuration numbers in the meta range-checked by name before the model is built. */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "baselines/bl_prior2d.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "io/mf_ckpt.h"
#include "prior/mf_prior.h"
#include "prior/mf_prior_train.h"
#include "tests/mf_test.h"
#include "tests/mf_test_grad.h"
#include "tests/mf_test_prior.h"

MF_TEST(prior_bad_weights_refused) {
    MfPrior *p, *q = NULL;
    tp_tiny_prior(&p);
    const char *good = mf_test_path("prior_good.mfck");
    char path[MF_PATH_MAX];
    CHECK_OK(mf_prior_save(p, good, NULL));
    CHECK_ERR(mf_prior_load(mf_test_path("prior_missing.mfck"), &q), "prior_missing.mfck: cannot open checkpoint");
    CHECK_ERR(mf_prior_load(mf_test_path("prior_missing.mfck"), &q), "MFCK version 1");
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    /* truncated */
    mf_test_path_to(path, sizeof path, "prior_trunc.mfck");
    CHECK_OK(mf_write_file(path, d, len / 2));
    CHECK_ERR(mf_prior_load(path, &q), "truncated");
    CHECK_ERR(mf_prior_load(path, &q), "expected prior weights");
    CHECK_OK(mf_write_file(path, d, 10));
    CHECK_ERR(mf_prior_load(path, &q), "truncated");
    /* wrong container version */
    d[4] = 7;
    CHECK_OK(mf_write_file(path, d, len));
    CHECK_ERR(mf_prior_load(path, &q), "unsupported version 7 of checkpoint");
    d[4] = 1;
    /* corrupt data */
    d[len - 20] ^= 0x55;
    CHECK_OK(mf_write_file(path, d, len));
    CHECK_ERR(mf_prior_load(path, &q), "checksum mismatch");
    free(d);
    /* wrong format version in the meta */
    MfTensorSpec *specs = malloc((size_t)(p->ae->tab.n + p->dn->tab.n) * sizeof *specs);
    memcpy(specs, p->ae->tab.v, (size_t)p->ae->tab.n * sizeof *specs);
    memcpy(specs + p->ae->tab.n, p->dn->tab.v, (size_t)p->dn->tab.n * sizeof *specs);
    int n = p->ae->tab.n + p->dn->tab.n;
    char *meta = NULL;
    CHECK_OK(mf_prior_read_meta(good, &meta));
    char *vpos = meta ? strstr(meta, "\"version\":1") : NULL;
    CHECK(vpos != NULL);
    if (vpos) vpos[10] = '2';
    float *data = calloc(mf_specs_numel(specs, n) + 64, sizeof(float));
    CHECK_OK(mf_ckpt_save(path, specs, n, data, meta));
    CHECK_ERR(mf_prior_load(path, &q), "unsupported mf-prior format version 2");
    if (vpos) vpos[10] = '1';
    /* wrong shape: one tensor's shape changed */
    specs[0].shape[0] += 1;
    CHECK_OK(mf_ckpt_save(path, specs, n, data, meta));
    CHECK_ERR(mf_prior_load(path, &q), "shape mismatch");
    CHECK_ERR(mf_prior_load(path, &q), "expected prior weights");
    CHECK(q == NULL);
    free(meta), free(data), free(specs);
    mf_prior_free(p);
}

MF_TEST(prior_guidance_one_is_conditional) {
    MfPrior *p;
    tp_tiny_prior(&p);
    int B = 4, R = 16, zc = 4, h = 4;
    size_t ni = (size_t)B * 3 * R * R, nz = (size_t)B * zc * h * h;
    float *rgb = malloc(ni * sizeof(float)), *zimg = malloc(nz * sizeof(float)), *xt = malloc(2 * nz * sizeof(float));
    float *v1 = malloc(2 * nz * sizeof(float)), *v3 = malloc(2 * nz * sizeof(float)), *x = malloc(3 * nz * sizeof(float));
    tp_fill(rgb, ni, 1, 1.0f), tp_fill(zimg, nz, 2, 1.0f), tp_fill(xt, 2 * nz, 3, 1.0f);
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 0, 1.0f, v1));
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 0, 3.0f, v3));
    /* the conditional prediction alone */
    for (int b = 0; b < B; ++b) {
        memcpy(x + (size_t)b * 3 * zc * h * h, zimg + (size_t)b * zc * h * h, (size_t)zc * h * h * sizeof(float));
        memcpy(x + (size_t)b * 3 * zc * h * h + zc * h * h, xt + (size_t)b * 2 * zc * h * h,
               (size_t)2 * zc * h * h * sizeof(float));
    }
    float t[4] = {400, 400, 400, 400}, keep[4] = {1, 1, 1, 1};
    MfDenoiserWork w = {0};
    float *vc = mf_denoiser_forward(p->dn, &w, x, t, rgb, keep, B, 1, 0);
    double diff1 = 0, diff3 = 0;
    for (size_t i = 0; i < 2 * nz; ++i) diff1 = fmax(diff1, fabs(v1[i] - vc[i])), diff3 = fmax(diff3, fabs(v3[i] - vc[i]));
    /* exactly: guidance 1 runs the conditional half only (no u + 1 * (c - u) rounding) */
    CHECK_MSG(diff1 == 0.0, "guidance 1 differs from the conditional prediction by %g", diff1);
    CHECK(diff3 > 1e-3); /* guidance 3 does change it */
    /* multi-view: joint attention over V = 4 views changes the prediction, V = 1 joint does not */
    float *vj = malloc(2 * nz * sizeof(float));
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 4, 1, 3.0f, vj));
    double dj = 0;
    for (size_t i = 0; i < 2 * nz; ++i) dj = fmax(dj, fabs(vj[i] - v3[i]));
    CHECK(dj > 1e-5);
    CHECK_OK(mf_prior_guided_v(p, zimg, rgb, xt, 400, B, 1, 1, 3.0f, vj));
    dj = 0;
    for (size_t i = 0; i < 2 * nz; ++i) dj = fmax(dj, fabs(vj[i] - v3[i]));
    CHECK(dj < 1e-5);
    mf_denoiser_work_free(&w);
    free(rgb), free(zimg), free(xt), free(v1), free(v3), free(x), free(vj);
    mf_prior_free(p);
}

/* mf_prior_predict_mean (eval-prior's predictions): a view's maps depend on its own image only
 * when the views are predicted alone (each one's condition image in its own batch items). */
MF_TEST(prior_predict_mean_views_independent) {
    MfPrior *p;
    tp_tiny_prior(&p);
    int R = 16;
    MfImage in[3] = {{0}}, alb[2][2] = {{{0}}}, orm[2][2] = {{{0}}};
    for (int k = 0; k < 3; ++k) {
        CHECK_OK(mf_image_alloc(&in[k], R, R, 4));
        tp_fill(in[k].data, (size_t)R * R * 4, 20 + k, 0.5f);
        for (size_t q = 0; q < (size_t)R * R * 4; ++q) in[k].data[q] = q % 4 == 3 ? 1.0f : in[k].data[q] + 0.5f;
    }
    /* views (A, B) and (A, C), same seed: view A's maps must not change */
    const MfImage ab[2] = {in[0], in[1]}, ac[2] = {in[0], in[2]};
    CHECK_OK(mf_prior_predict_mean(p, ab, 2, 2, 0, 2, 2, 3.0f, 7, alb[0], orm[0]));
    CHECK_OK(mf_prior_predict_mean(p, ac, 2, 2, 0, 2, 2, 3.0f, 7, alb[1], orm[1]));
    double d0 = 0, d1 = 0;
    for (size_t q = 0; q < (size_t)R * R * 4; ++q) {
        d0 = fmax(d0, fabs(alb[0][0].data[q] - alb[1][0].data[q]) + fabs(orm[0][0].data[q] - orm[1][0].data[q]));
        d1 = fmax(d1, fabs(alb[0][1].data[q] - alb[1][1].data[q]));
    }
    CHECK_MSG(d0 == 0, "view 0's maps changed by %g with view 1's image", d0);
    CHECK(d1 > 1e-4); /* the condition image does matter */
    CHECK(alb[0][0].w == R && alb[0][0].c == 4 && orm[0][0].data[0] == 1.0f); /* ORM R = 1 */
    for (int k = 0; k < 3; ++k) mf_image_free(&in[k]);
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b) mf_image_free(&alb[a][b]), mf_image_free(&orm[a][b]);
    mf_prior_free(p);
}

/* The gradient checks' losses: <encoder output, w> for fixed weights w. */
typedef struct {
    MfPrior *p;
    const float *img, *alb, *orm, *w;
    float *z;
    int B;
    size_t nz;
} PriorGC;

static double encode_loss(void *ctx) {
    PriorGC *g = ctx;
    mf_prior_encode(g->p, g->img, g->B, g->z);
    return tp_dot(g->z, g->w, g->nz);
}

static double materials_loss(void *ctx) {
    PriorGC *g = ctx;
    mf_prior_encode_materials(g->p, g->alb, g->orm, g->B, g->z);
    return tp_dot(g->z, g->w, g->nz);
}

MF_TEST(prior_encode_backward_matches_differences) {
    MfPrior *p;
    tp_tiny_prior(&p);
    int B = 1, R = 16;
    size_t ni = (size_t)3 * R * R, nz = 4 * 4 * 4;
    float *img = malloc(ni * sizeof(float)), *z = malloc(nz * sizeof(float)), *wz = malloc(nz * sizeof(float));
    float *dimg = calloc(ni, sizeof(float));
    tp_fill(img, ni, 4, 1.0f), tp_fill(wz, nz, 5, 1.0f);
    CHECK_OK(mf_prior_encode(p, img, B, z));
    mf_prior_encode_backward(p, wz, dimg);
    PriorGC g = {.p = p, .img = img, .w = wz, .z = z, .B = B, .nz = nz};
    int checked = 0, bad = grad_check(encode_loss, &g, img, dimg, ni, 0, 17, 1e-2, 2e-2, "image", &checked);
    CHECK_MSG(bad == 0, "%d of %d encoder input gradients off", bad, checked);
    free(img), free(z), free(wz), free(dimg);
    mf_prior_free(p);
}

MF_TEST(prior_prepare_image_box_filter) {
    /* 4x4 -> 2x2: each output is the mean of a 2x2 block of (2 v - 1) * alpha */
    float rgba[4 * 4 * 4], out[3 * 2 * 2], mask[4];
    for (int i = 0; i < 16; ++i) {
        rgba[i * 4 + 0] = (float)i / 15.0f, rgba[i * 4 + 1] = 1.0f, rgba[i * 4 + 2] = 0.0f;
        rgba[i * 4 + 3] = (i % 2) ? 1.0f : 0.5f;
    }
    mf_prior_prepare_image(rgba, 4, 4, 2, out, mask);
    int blk[4] = {0, 1, 4, 5};
    double e = 0, a = 0;
    for (int k = 0; k < 4; ++k) {
        int i = blk[k];
        e += (2.0 * i / 15.0 - 1.0) * rgba[i * 4 + 3] / 4.0, a += rgba[i * 4 + 3] / 4.0;
    }
    CHECK_NEAR(out[0], e, 1e-6);
    CHECK_NEAR(mask[0], a, 1e-6);
    CHECK_NEAR(out[4 + 0], a, 1e-6);  /* G = 1 -> (2 - 1) * alpha */
    CHECK_NEAR(out[8 + 0], -a, 1e-6); /* B = 0 -> -alpha */
}

MF_TEST(prior_material_latents_and_backward) {
    MfPrior *p;
    tp_tiny_prior(&p);
    int B = 2, R = 16;
    size_t ni = (size_t)B * 3 * R * R, nm = (size_t)B * 8 * 4 * 4, n1 = (size_t)3 * R * R, z1 = 4 * 4 * 4;
    float *alb = malloc(ni * sizeof(float)), *orm = malloc(ni * sizeof(float)), *zm = malloc(nm * sizeof(float));
    float *wz = malloc(nm * sizeof(float)), *da = calloc(ni, sizeof(float)), *dor = calloc(ni, sizeof(float));
    float *z1buf = malloc(z1 * sizeof(float)), *ra = malloc(ni * sizeof(float)), *ro = malloc(ni * sizeof(float));
    float *d1 = malloc(n1 * sizeof(float));
    tp_fill(alb, ni, 1, 1.0f), tp_fill(orm, ni, 2, 1.0f), tp_fill(wz, nm, 3, 1.0f);
    CHECK_OK(mf_prior_encode_materials(p, alb, orm, B, zm));
    /* packing: item 1's ORM latent equals encoding item 1's ORM map alone */
    CHECK_OK(mf_prior_encode(p, orm + n1, 1, z1buf));
    double e = 0;
    for (size_t i = 0; i < z1; ++i) e = fmax(e, fabs(z1buf[i] - zm[2 * 8 * 16 - z1 + i]));
    CHECK(e < 1e-5);
    CHECK_OK(mf_prior_encode_materials(p, alb, orm, B, zm));
    CHECK_OK(mf_prior_encode_materials_backward(p, wz, da, dor));
    PriorGC g = {.p = p, .alb = alb, .orm = orm, .w = wz, .z = zm, .B = B, .nz = nm};
    int checked = 0, bad = grad_check(materials_loss, &g, alb, da, ni, 5, 97, 1e-2, 2e-2, "albedo", &checked);
    bad += grad_check(materials_loss, &g, orm, dor, ni, 5, 97, 1e-2, 2e-2, "orm", &checked);
    CHECK_MSG(bad == 0, "%d of %d material gradients off", bad, checked);
    /* decode_materials splits like decode */
    CHECK_OK(mf_prior_decode_materials(p, zm, B, ra, ro));
    for (size_t i = 0; i < z1; ++i) z1buf[i] = zm[8 * 16 + i]; /* item 1 albedo latent */
    CHECK_OK(mf_prior_decode(p, z1buf, 1, d1));
    e = 0;
    for (size_t i = 0; i < n1; ++i) e = fmax(e, fabs(d1[i] - ra[n1 + i]));
    CHECK(e < 1e-5);
    free(alb), free(orm), free(zm), free(wz), free(da), free(dor), free(z1buf), free(ra), free(ro), free(d1);
    mf_prior_free(p);
}

/* ---- hostile input (issue 15): each case once crashed, overflowed a buffer or reported a
 * misleading error; it must now end in an error that names the file and what is wrong, a
 * non-zero exit for the CLI, and no output file ---- */

/* Replaces the first occurrence of `from` after `after` in buf (same length) in place. */
static int patch(char *buf, size_t len, const char *after, const char *from, const char *to) {
    char *a = memmem(buf, len, after, strlen(after));
    if (!a) return 0;
    char *f = memmem(a, len - (size_t)(a - buf), from, strlen(from));
    if (!f || strlen(from) != strlen(to)) return 0;
    memcpy(f, to, strlen(to));
    return 1;
}

/* An MFCK file with no tensors and the given meta text (header only). */
static void write_meta_only(const char *path, const char *meta, uint32_t mlen_claimed) {
    FILE *f = fopen(path, "wb");
    if (!f) return;
    uint32_t hdr[3] = {1u, 0u, mlen_claimed};
    fwrite("MFCK", 1, 4, f);
    fwrite(hdr, 4, 3, f);
    fwrite(meta, 1, strlen(meta), f);
    fclose(f);
}

/* (d) Prior weights whose meta says groups or heads = 0 divided by zero while the model was
 * built, before the checksum was checked; a meta length from the header was allocated before it
 * was compared with the file. Now every configuration number is range-checked first, by name. */
MF_TEST(hostile_prior_meta) {
    MfPriorConfig cfg;
    mf_prior_config_tiny(&cfg);
    MfPrior *p = NULL, *q = NULL;
    CHECK_OK(mf_prior_new(&p, &cfg));
    if (!p) return;
    const char *good = mf_test_path("hostile_prior_good.mfck");
    const char *bad = mf_test_path("hostile_prior_bad.mfck");
    CHECK_OK(mf_prior_save(p, good, NULL));
    mf_prior_free(p);
    CHECK_OK(mf_prior_load(good, &q));
    mf_prior_free(q);
    q = NULL;
    char *d = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(good, &d, &len));
    if (!d) return;
    /* groups = 0 in the denoiser (the checksum no longer matches either: the meta is checked first) */
    CHECK(patch(d, len, "\"dn\":", "\"groups\":2", "\"groups\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: meta: dn.groups = 0 is out of range");
    CHECK(patch(d, len, "\"dn\":", "\"groups\":0", "\"groups\":2"));
    /* heads = 0 */
    CHECK(patch(d, len, "\"dn\":", "\"heads\":2", "\"heads\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: meta: dn.heads = 0 is out of range");
    CHECK(patch(d, len, "\"dn\":", "\"heads\":0", "\"heads\":2"));
    /* autoencoder groups = 0 */
    CHECK(patch(d, len, "\"ae\":", "\"groups\":2", "\"groups\":0"));
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "meta: ae.groups = 0 is out of range");
    CHECK(patch(d, len, "\"ae\":", "\"groups\":0", "\"groups\":2"));
    /* a meta length far beyond the file: refused before allocating */
    uint32_t huge = 0xF0000000u;
    memcpy(d + 12, &huge, 4);
    CHECK_OK(mf_write_file(bad, d, len));
    CHECK_ERR(mf_prior_load(bad, &q), "meta length 4026531840 exceeds the file");
    free(d);
    /* channel counts beyond any model, and a valid meta whose weights are not in the file */
    const char *m1 = "{\"format\":\"mf-prior\",\"version\":1,\"resolution\":16,\"downsample\":4,\"latent_channels\":4,"
                     "\"latent_scale\":1,\"ae\":{\"c1\":4,\"c2\":8,\"groups\":2},\"dn\":{\"c1\":8,\"c2\":1e12,\"ct\":16,"
                     "\"tfreq\":8,\"heads\":2,\"groups\":2,\"i1\":4,\"i2\":4,\"i3\":8}}";
    write_meta_only(bad, m1, (uint32_t)strlen(m1));
    CHECK_ERR(mf_prior_load(bad, &q), "meta: dn.c2 = 1e+12 is out of range");
    const char *m2 = "{\"format\":\"mf-prior\",\"version\":1,\"resolution\":16,\"downsample\":4,\"latent_channels\":4,"
                     "\"latent_scale\":1,\"ae\":{\"c1\":4,\"c2\":8,\"groups\":2},\"dn\":{\"c1\":8,\"c2\":8,\"ct\":16,"
                     "\"tfreq\":8,\"heads\":2,\"groups\":2,\"i1\":4,\"i2\":4,\"i3\":8}}";
    write_meta_only(bad, m2, (uint32_t)strlen(m2));
    CHECK_ERR(mf_prior_load(bad, &q), "hostile_prior_bad.mfck: truncated: the meta's configuration has");
    CHECK(q == NULL);
    /* that check counts the weights from the layer tables before allocating any: the same count
     * as the model's own tables */
    {
        MfPriorConfig tc;
        mf_prior_config_tiny(&tc);
        size_t nae = 0, ndn = 0;
        MfPrior *tp = NULL;
        CHECK_OK(mf_ae_numel(&tc.ae, &nae));
        CHECK_OK(mf_denoiser_numel(&tc.dn, &ndn));
        CHECK_OK(mf_prior_new(&tp, &tc));
        if (tp) CHECK_MSG(nae == tp->ae->tab.numel && ndn == tp->dn->tab.numel, "counted %zu + %zu weights, the model has %zu + %zu", nae,
                          ndn, tp->ae->tab.numel, tp->dn->tab.numel);
        mf_prior_free(tp);
        tc.dn.heads = 0;
        CHECK_ERR(mf_denoiser_numel(&tc.dn, &ndn), "heads 0");
    }
    /* the library's own guard, for configurations built in code */
    cfg.dn.heads = 0;
    CHECK_ERR(mf_prior_new(&p, &cfg), "heads 0");
}
