/* mf prior: predicts albedo and ORM for an RGBA image with the trained prior (mf_prior.h):
 * mean of N DDIM samples (default 10 samples, 50 steps, guidance 3.0); --mv adds three more
 * views of the same object, denoised jointly (multi-view attention, StableMaterialMV). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "io/mf_image.h"
#include "prior/mf_prior.h"

#define USAGE_PRIOR \
    "usage: mf prior IMAGE -o DIR [--weights CKPT] [--samples N] [--steps S] [--seed S] [--guidance G]\n" \
    "                [--mv IMG2 IMG3 IMG4]\n" \
    "  IMAGE: RGBA (sRGB colour, alpha = mask), box-filtered to the prior's resolution (64 px).\n" \
    "  Writes DIR/albedo.png (sRGB) and DIR/orm.png (linear, R = 1), alpha = the input mask: the mean of\n" \
    "  N samples (default 10) of S DDIM steps (default 50) with classifier-free guidance G (default 3).\n" \
    "  --weights: a prior.mfck file or the folder holding it (default: $MF_PRIOR_WEIGHTS, else the committed\n" \
    "  mf/prior/weights/prior.mfck of the current directory or of the repository holding this mf binary).\n" \
    "  --mv: three more views of the object, denoised jointly; their maps go to DIR/albedo_K.png, orm_K.png.\n"

static int read_input(const char *path, int R, float *rgb, float *mask) {
    MfImage img = {0};
    int rc = mf_image_read(path, MF_ENC_LINEAR, &img); /* raw codes: the prior works on sRGB values */
    if (rc) return rc;
    if (img.c != 3 && img.c != 4) {
        mf_image_free(&img);
        return mf_fail(MF_EFORMAT, "%s: expected an RGB or RGBA image, got %d channels", path, img.c);
    }
    float *rgba = malloc((size_t)img.w * img.h * 4 * sizeof(float));
    if (!rgba) {
        mf_image_free(&img);
        return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    }
    for (size_t i = 0; i < (size_t)img.w * img.h; ++i)
        for (int c = 0; c < 4; ++c) rgba[i * 4 + c] = c < img.c ? img.data[i * img.c + c] : 1.0f;
    mf_prior_prepare_image(rgba, img.w, img.h, R, rgb, mask);
    free(rgba);
    mf_image_free(&img);
    return MF_OK;
}

/* map (3, R, R) in [-1,1] x mask -> RGBA file; orm = 1 forces R = 1 and writes linear. */
static int write_map(const char *dir, const char *name, int view, const float *map, const float *mask, int R, int orm) {
    char file[64], path[MF_PATH_MAX];
    if (view) snprintf(file, sizeof file, "%s_%d.png", name, view);
    else snprintf(file, sizeof file, "%s.png", name);
    if (mf_path_join(path, sizeof path, dir, file)) return mf_fail(MF_EARG, "%s: path too long", dir);
    MfImage img = {0};
    if (mf_image_alloc(&img, R, R, 4)) return mf_fail(MF_ENOMEM, "out of memory");
    size_t hw = (size_t)R * R;
    for (size_t p = 0; p < hw; ++p) {
        float a = mask[p];
        for (int c = 0; c < 3; ++c) {
            float v = a > 1e-3f ? 0.5f * (map[c * hw + p] / a + 1.0f) : 0.0f;
            v = v < 0 ? 0 : v > 1 ? 1 : v;
            if (orm && c == 0) v = 1.0f;
            img.data[p * 4 + c] = orm ? v : mf_srgb_to_linear(v); /* albedo values are sRGB codes */
        }
        img.data[p * 4 + 3] = a;
    }
    int rc = mf_image_write(path, &img, orm ? MF_ENC_LINEAR : MF_ENC_SRGB, 8);
    mf_image_free(&img);
    return rc;
}

static int cmd_prior(int argc, char **argv) {
    const char *image = NULL, *out = NULL, *weights = NULL, *mv[3] = {NULL, NULL, NULL};
    int samples = 10, steps = 50, seed = 0, V = 1;
    float guidance = MF_PRIOR_GUIDANCE;
    for (int i = 1; i < argc; ++i) {
        int r;
        if ((r = mf_opt_str(argc, argv, &i, "-o", &out)) || (r = mf_opt_str(argc, argv, &i, "--weights", &weights)) ||
            (r = mf_opt_int(argc, argv, &i, "--samples", &samples)) || (r = mf_opt_int(argc, argv, &i, "--steps", &steps)) ||
            (r = mf_opt_int(argc, argv, &i, "--seed", &seed)) || (r = mf_opt_float(argc, argv, &i, "--guidance", &guidance))) {
            if (r < 0) return MF_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--mv")) {
            if (i + 3 >= argc) {
                mf_fail(MF_EARG, "prior: --mv needs three more images");
                return MF_EXIT_USAGE;
            }
            for (int k = 0; k < 3; ++k) mv[k] = argv[++i];
            V = 4;
        } else if (argv[i][0] != '-' && !image) image = argv[i];
        else {
            mf_fail(MF_EARG, "prior: unknown argument '%s'", argv[i]);
            return MF_EXIT_USAGE;
        }
    }
    if (!image || !out || samples < 1 || steps < 1 || steps > MF_DIFF_T) {
        mf_fail(MF_EARG, "prior: need IMAGE, -o DIR, --samples >= 1 and --steps in 1..%d", MF_DIFF_T);
        return MF_EXIT_USAGE;
    }
    MfPrior *p = NULL;
    if (mf_prior_load_path(weights, &p)) return MF_EXIT_FAIL;
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, B = samples * V, rc = MF_OK;
    size_t isz = (size_t)3 * R * R, hw = (size_t)R * R, zsz = (size_t)zc * h * h;
    float *rgb = malloc((size_t)B * isz * sizeof(float)), *mask = malloc((size_t)V * hw * sizeof(float));
    float *zmat = malloc((size_t)B * 2 * zsz * sizeof(float)), *zk = malloc((size_t)B * zsz * sizeof(float));
    float *dec = malloc((size_t)B * isz * sizeof(float)), *mean = malloc((size_t)V * isz * sizeof(float));
    if (!rgb || !mask || !zmat || !zk || !dec || !mean) rc = mf_fail(MF_ENOMEM, "prior: out of memory");
    for (int v = 0; v < V && !rc; ++v) rc = read_input(v ? mv[v - 1] : image, R, rgb + v * isz, mask + v * hw);
    for (int s = 1; s < samples && !rc; ++s) memcpy(rgb + (size_t)s * V * isz, rgb, (size_t)V * isz * sizeof(float));
    if (!rc) rc = mf_mkdirs(out);
    if (!rc) {
        mf_log_info("prior: %d sample(s) x %d view(s), %d DDIM steps, guidance %.2f", samples, V, steps, guidance);
        rc = mf_prior_sample(p, rgb, B, V, V > 1, steps, guidance, (uint64_t)seed, zmat);
    }
    for (int kind = 0; kind < 2 && !rc; ++kind) {
        for (int b = 0; b < B; ++b) memcpy(zk + b * zsz, zmat + (b * 2 + kind) * zsz, zsz * sizeof(float));
        if ((rc = mf_prior_decode(p, zk, B, dec))) break;
        memset(mean, 0, (size_t)V * isz * sizeof(float));
        for (int b = 0; b < B; ++b)
            for (size_t i = 0; i < isz; ++i) mean[(b % V) * isz + i] += dec[b * isz + i] / (float)samples;
        for (int v = 0; v < V && !rc; ++v) {
            /* keep the decoded maps inside the mask, as the inputs were */
            for (int c = 0; c < 3; ++c)
                for (size_t q = 0; q < hw; ++q) mean[v * isz + c * hw + q] *= mask[v * hw + q] > 1e-3f ? 1.0f : 0.0f;
            rc = write_map(out, kind ? "orm" : "albedo", v, mean + v * isz, mask + v * hw, R, kind);
        }
    }
    free(rgb), free(mask), free(zmat), free(zk), free(dec), free(mean);
    mf_prior_free(p);
    if (rc) return MF_EXIT_FAIL;
    printf("wrote %s/albedo.png and %s/orm.png%s\n", out, out, V > 1 ? " (+ views 1..3)" : "");
    return MF_EXIT_OK;
}

MF_COMMAND(prior, "prior", "predict albedo and ORM maps of an image with the material prior", USAGE_PRIOR, cmd_prior)
