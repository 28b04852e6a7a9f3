#include "inverse/mf_recon_opts.h"

#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <math.h>
#include "core/mf_error.h"
#include "io/mf_json.h"

typedef enum { T_INT, T_FLOAT, T_U64 } OptType;
typedef struct {
    const char *name; /* snake_case */
    OptType type;
    size_t off;
    const char *doc;
} OptField;

#define F(name, type, doc) {#name, type, offsetof(MfReconOpts, name), doc}
static const OptField k_fields[] = {
    F(iters, T_INT, "optimisation iterations"),
    F(batch, T_INT, "views per iteration"),
    F(spp_sqrt, T_INT, "n: n^2 env-light + n^2 BSDF samples per pixel sample"),
    F(pixel_samples, T_INT, "primary rays per pixel"),
    F(tex_res, T_INT, "albedo/ORM texture side"),
    F(env_w, T_INT, "env map width"),
    F(env_h, T_INT, "env map height"),
    F(lr, T_FLOAT, "texture learning rate (decays as 10^(-0.0002 it))"),
    F(light_lr_scale, T_FLOAT, "env learning rate multiplier"),
    F(w_kd_smooth, T_FLOAT, "albedo smoothness weight"),
    F(w_orm_smooth, T_FLOAT, "ORM smoothness weight"),
    F(w_shading, T_FLOAT, "white-light shading regulariser weight"),
    F(w_spec_ratio, T_FLOAT, "mean(spec)/mean(diffuse) weight"),
    F(normal_map, T_INT, "1: also optimise a tangent-space normal map (writes normal.png)"),
    F(w_nrm_perturb, T_FLOAT, "normal-map perturbation weight (L1 from flat)"),
    F(w_nrm_smooth, T_FLOAT, "normal-map smoothness weight"),
    F(init_kd, T_FLOAT, "initial albedo"),
    F(init_rough, T_FLOAT, "initial roughness"),
    F(init_metal, T_FLOAT, "initial metallic"),
    F(init_light, T_FLOAT, "initial env radiance, in the views' units / 2^k near their mean (see mf_recon.h)"),
    F(denoise, T_INT, "1: bilateral denoiser of the demodulated diffuse/specular light (nvdiffrecmc)"),
    F(denoise_sigma, T_FLOAT, "denoiser spatial sigma in pixels (window 2*ceil(2.5 sigma)+1 each side)"),
    F(denoise_decorrelate, T_INT, "1: kd's adjoint takes the denoised light of an independent render (0: the primal's)"),
    F(div_factor, T_FLOAT, "divergence: loss above this x its running minimum ..."),
    F(div_patience, T_INT, "... for this many iterations in a row: restore the best state, lr x0.1"),
    F(max_recoveries, T_INT, "recoveries (from divergence or non-finite values) before the run stops"),
    F(snapshot_every, T_INT, "texture snapshot period (0: none)"),
    F(checkpoint_every, T_INT, "checkpoint period (0: at the end only)"),
    F(seed, T_U64, "random seed"),
};
#undef F
#define NFIELDS ((int)(sizeof k_fields / sizeof k_fields[0]))

static int set_value(MfReconOpts *o, const OptField *f, double v, const char *where) {
    char *p = (char *)o + f->off;
    if (f->type == T_FLOAT) {
        *(float *)p = (float)v;
        return MF_OK;
    }
    if (v != (double)(long long)v || v < 0) return mf_fail(MF_EARG, "%s: %s must be a non-negative integer", where, f->name);
    if (f->type == T_INT) {
        if (v > 2147483647.0) return mf_fail(MF_EARG, "%s: %s is too large", where, f->name);
        *(int *)p = (int)v;
    } else {
        *(uint64_t *)p = (uint64_t)v;
    }
    return MF_OK;
}

int mf_recon_opts_apply_json(MfReconOpts *o, const cJSON *root, const char *file) {
    if (!cJSON_IsObject(root)) return mf_fail(MF_EFORMAT, "%s: a config file is a JSON object", file);
    for (const cJSON *it = root->child; it; it = it->next) {
        if (!strcmp(it->string, "comment") || it->string[0] == '_') continue;
        const OptField *f = NULL;
        for (int k = 0; k < NFIELDS; ++k)
            if (!strcmp(k_fields[k].name, it->string)) f = &k_fields[k];
        if (!f) return mf_fail(MF_EFORMAT, "%s: unknown option '%s'", file, it->string);
        if (!cJSON_IsNumber(it)) return mf_fail(MF_EFORMAT, "%s: %s: expected a number", file, it->string);
        int rc = set_value(o, f, it->valuedouble, file);
        if (rc) return rc;
    }
    return MF_OK;
}

int mf_recon_opts_load(MfReconOpts *o, const char *path) {
    cJSON *root = NULL;
    int rc = mf_json_load(path, &root);
    if (rc) return rc;
    rc = mf_recon_opts_apply_json(o, root, path);
    cJSON_Delete(root);
    return rc;
}

int mf_recon_opts_parse_arg(MfReconOpts *o, int argc, char **argv, int *i) {
    const char *a = argv[*i];
    if (strncmp(a, "--", 2)) return 0;
    for (int k = 0; k < NFIELDS; ++k) {
        char flag[64];
        snprintf(flag, sizeof flag, "--%s", k_fields[k].name);
        for (char *c = flag + 2; *c; ++c)
            if (*c == '_') *c = '-';
        if (strcmp(flag, a)) continue;
        if (*i + 1 >= argc) return mf_fail(MF_EARG, "option %s needs a value", flag), -1;
        const char *s = argv[++*i];
        char *end;
        double v = strtod(s, &end);
        if (end == s || *end || !isfinite(v)) return mf_fail(MF_EARG, "option %s: '%s' is not a number", flag, s), -1;
        return set_value(o, &k_fields[k], v, flag) ? -1 : 1;
    }
    return 0;
}

void mf_recon_opts_usage(char *buf, size_t cap, const MfReconOpts *d) {
    size_t n = strlen(buf);
    for (int k = 0; k < NFIELDS && n < cap; ++k) {
        const OptField *f = &k_fields[k];
        const char *p = (const char *)d + f->off;
        char flag[64], def[32];
        snprintf(flag, sizeof flag, "--%s", f->name);
        for (char *c = flag + 2; *c; ++c)
            if (*c == '_') *c = '-';
        if (f->type == T_FLOAT) snprintf(def, sizeof def, "%g", *(const float *)p);
        else if (f->type == T_INT) snprintf(def, sizeof def, "%d", *(const int *)p);
        else snprintf(def, sizeof def, "%llu", (unsigned long long)*(const uint64_t *)p);
        int w = snprintf(buf + n, cap - n, "  %-20s %s (default %s)\n", flag, f->doc, def);
        if (w < 0) break;
        n += (size_t)w;
    }
}

void mf_recon_opts_to_json(const MfReconOpts *o, cJSON *obj) {
    for (int k = 0; k < NFIELDS; ++k) {
        const OptField *f = &k_fields[k];
        const char *p = (const char *)o + f->off;
        double v = f->type == T_FLOAT ? *(const float *)p : f->type == T_INT ? *(const int *)p : (double)*(const uint64_t *)p;
        cJSON_AddNumberToObject(obj, f->name, v);
    }
}
