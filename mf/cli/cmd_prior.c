/* mf prior: predicts albedo and ORM for an RGBA image with the trained prior (mf_prior.h):
 * the mean of N DDIM samples (mf_prior_predict_mean); --mv adds three more views of the same
 * object, denoised jointly (multi-view attention, StableMaterialMV). */
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
               .unset = "$MF_PRIOR_WEIGHTS, else the committed " MF_PRIOR_WEIGHTS_DEFAULT " of the current directory or of "
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
                       "  N samples of S DDIM steps with classifier-free guidance G. Prints each view's mean predicted\n"
                       "  roughness and metallic inside the mask.\n"
                       "  --mv: three more views of the object, denoised jointly; their maps go to DIR/albedo_K.png, orm_K.png.\n",
                       t, 1, NULL);
}

/* IMAGE as RGBA with its raw channel values (the prior works on sRGB codes); alpha 1 when absent. */
static int read_input(const char *path, MfImage *out) {
    MfImage img = {0};
    int rc = mf_image_read(path, MF_ENC_LINEAR, &img);
    if (rc) return rc;
    if (img.c != 3 && img.c != 4) {
        mf_image_free(&img);
        return mf_fail(MF_EFORMAT, "%s: expected an RGB or RGBA image, got %d channels", path, img.c);
    }
    if ((rc = mf_image_alloc(out, img.w, img.h, 4))) {
        mf_image_free(&img);
        return mf_fail(MF_ENOMEM, "%s: out of memory", path);
    }
    for (size_t i = 0; i < (size_t)img.w * img.h; ++i)
        for (int c = 0; c < 4; ++c) out->data[i * 4 + c] = c < img.c ? img.data[i * img.c + c] : 1.0f;
    mf_image_free(&img);
    return MF_OK;
}

/* DIR/<name>.png (view 0) or DIR/<name>_<view>.png: albedo sRGB, ORM linear, 8-bit RGBA. */
static int write_map(const char *dir, const char *name, int view, const MfImage *img, int orm) {
    char file[64], path[MF_PATH_MAX];
    if (view) snprintf(file, sizeof file, "%s_%d.png", name, view);
    else snprintf(file, sizeof file, "%s.png", name);
    if (mf_path_join(path, sizeof path, dir, file)) return mf_fail(MF_EARG, "%s: path too long", dir);
    return mf_image_write(path, img, orm ? MF_ENC_LINEAR : MF_ENC_SRGB, 8);
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

/* One line per view: the predicted roughness and metallic averaged over the mask (alpha >= 0.5), the
 * figures a user checks first on a metal or dielectric object (orm: (h, w, 4) linear, alpha = mask). */
static void print_orm_means(const MfImage *orm, int view) {
    double r = 0, m = 0;
    long n = 0;
    for (long i = 0; i < (long)orm->w * orm->h; ++i) {
        const float *px = orm->data + i * orm->c;
        if (orm->c == 4 && px[3] < 0.5f) continue;
        r += px[1], m += px[2], ++n;
    }
    if (n) printf("view %d: mean roughness %.4f, metallic %.4f inside the mask (%ld px)\n", view, r / n, m / n, n);
    else printf("view %d: empty mask\n", view);
}

static int prior_run(const PriorArgs *a, const char *const *images, int V) {
    MfPrior *p = NULL;
    if (mf_prior_load_path(a->weights, &p)) return MF_EXIT_FAIL;
    MfImage in[4] = {{0}}, alb[4] = {{0}}, orm[4] = {{0}};
    int rc = MF_OK;
    for (int v = 0; v < V && !rc; ++v) rc = read_input(images[v], &in[v]);
    if (!rc) rc = mf_mkdirs(a->out);
    if (!rc) {
        mf_log_info("prior: %d sample(s) x %d view(s), %d DDIM steps, guidance %.2f", a->samples, V, a->steps, a->guidance);
        rc = mf_prior_predict_mean(p, in, V, V, V > 1, a->samples, a->steps, a->guidance, (uint64_t)a->seed, alb, orm);
    }
    for (int kind = 0; kind < 2 && !rc; ++kind)
        for (int v = 0; v < V && !rc; ++v) rc = write_map(a->out, kind ? "orm" : "albedo", v, kind ? &orm[v] : &alb[v], kind);
    for (int v = 0; v < V && !rc; ++v) print_orm_means(&orm[v], v);
    for (int v = 0; v < 4; ++v) mf_image_free(&in[v]), mf_image_free(&alb[v]), mf_image_free(&orm[v]);
    mf_prior_free(p);
    if (rc) return MF_EXIT_FAIL;
    printf("wrote %s/albedo.png and %s/orm.png%s\n", a->out, a->out, V > 1 ? " (+ views 1..3)" : "");
    return MF_EXIT_OK;
}

MF_COMMAND(prior, "prior", "predict albedo and ORM maps of an image with the material prior", usage, cmd_prior)
