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

typedef struct {
    const char *out, *weights;
    int samples, steps, seed;
    float guidance;
} PriorArgs;

#define A PriorArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output folder (required)", .alias = "-o", .meta = "DIR"),
    MF_OPT_STR(A, weights, NULL, "a prior.mfck file or the folder holding it", .meta = "CKPT",
               .unset = "$MF_PRIOR_WEIGHTS, else the committed mf/prior/weights/prior.mfck of the current directory or of "
                        "the repository holding this mf binary"),
    MF_OPT_INT(A, samples, 10, 1, 10000, "samples averaged"),
    MF_OPT_INT(A, steps, 50, 1, MF_DIFF_T, "DDIM steps per sample"),
    MF_OPT_INT(A, seed, 0, 0, 2147483647, "random seed"),
    MF_OPT_FLOAT(A, guidance, MF_PRIOR_GUIDANCE, 0, 100, "classifier-free guidance"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--mv IMG2 IMG3 IMG4 is a flag only, not a config key)", k_args);

static char usage[8192];
__attribute__((constructor)) static void prior_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage,
                       "usage: mf prior IMAGE -o DIR [--weights CKPT] [--samples N] [--steps S] [--seed S] [--guidance G]\n"
                       "                [--mv IMG2 IMG3 IMG4]\n"
                       "  IMAGE: RGBA (sRGB colour, alpha = mask), box-filtered to the prior's resolution (64 px).\n"
                       "  Writes DIR/albedo.png (sRGB) and DIR/orm.png (linear, R = 1), alpha = the input mask: the mean of\n"
                       "  N samples of S DDIM steps with classifier-free guidance G.\n"
                       "  --mv: three more views of the object, denoised jointly; their maps go to DIR/albedo_K.png, orm_K.png.\n",
                       t, 1, NULL);
}

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

static int prior_run(const PriorArgs *a, const char *const *images, int V);

/* --mv takes three values, so it is taken out of argv before the table parses the rest. */
static int cmd_prior(int argc, char **argv) {
    PriorArgs a;
    mf_opts_defaults(&k_args_table, &a);
    char **rest = malloc((size_t)(argc + 1) * sizeof *rest);
    const char *images[4] = {NULL, NULL, NULL, NULL};
    int n = 0, V = 1;
    if (!rest) return mf_fail(MF_ENOMEM, "prior: out of memory"), MF_EXIT_FAIL;
    for (int i = 0; i < argc; ++i) {
        if (strcmp(argv[i], "--mv")) rest[n++] = argv[i];
        else if (i + 3 >= argc) V = 0;
        else images[1] = argv[i + 1], images[2] = argv[i + 2], images[3] = argv[i + 3], i += 3, V = 4;
    }
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = V ? mf_cli_parse(&bind, 1, n, rest, 1, &p) : (mf_fail(MF_EARG, "prior: --mv needs three more images"), MF_EXIT_USAGE);
    if (rc < 0) {
        images[0] = p.npos ? p.pos[0] : NULL;
        if (!images[0] || !a.out) rc = MF_EXIT_USAGE, mf_fail(MF_EARG, "prior: need IMAGE and -o DIR");
        else rc = prior_run(&a, images, V);
        mf_opts_parse_free(&p);
    }
    free(rest);
    return rc;
}

static int prior_run(const PriorArgs *a, const char *const *images, int V) {
    const char *out = a->out;
    int samples = a->samples, steps = a->steps, seed = a->seed;
    float guidance = a->guidance;
    MfPrior *p = NULL;
    if (mf_prior_load_path(a->weights, &p)) return MF_EXIT_FAIL;
    int R = p->cfg.ae.res, zc = p->cfg.ae.zc, h = p->cfg.dn.h, B = samples * V, rc = MF_OK;
    size_t isz = (size_t)3 * R * R, hw = (size_t)R * R, zsz = (size_t)zc * h * h;
    float *rgb = malloc((size_t)B * isz * sizeof(float)), *mask = malloc((size_t)V * hw * sizeof(float));
    float *zmat = malloc((size_t)B * 2 * zsz * sizeof(float)), *zk = malloc((size_t)B * zsz * sizeof(float));
    float *dec = malloc((size_t)B * isz * sizeof(float)), *mean = malloc((size_t)V * isz * sizeof(float));
    if (!rgb || !mask || !zmat || !zk || !dec || !mean) rc = mf_fail(MF_ENOMEM, "prior: out of memory");
    for (int v = 0; v < V && !rc; ++v) rc = read_input(images[v], R, rgb + v * isz, mask + v * hw);
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

MF_COMMAND(prior, "prior", "predict albedo and ORM maps of an image with the material prior", usage, cmd_prior)
