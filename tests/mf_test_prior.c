/* Shared fixtures of the prior tests (tests/mf_test_prior.h). */

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
#include "tests/mf_test_prior.h"

void tp_fill(float *x, size_t n, uint64_t seed, float s) {
    MfRng r;
    mf_rng_seed(&r, seed, 9);
    for (size_t i = 0; i < n; ++i) x[i] = s * (2.0f * mf_rng_float(&r) - 1.0f);
}

double tp_dot(const float *a, const float *b, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += (double)a[i] * b[i];
    return s;
}

void tp_write_synth(const char *dir, int n, int R, uint64_t seed) {
    char path[MF_PATH_MAX], rel[64];
    const char *kinds[3] = {"rgb", "albedo", "orm"};
    for (int k = 0; k < 3; ++k) {
        mf_path_join(path, sizeof path, dir, kinds[k]);
        mf_mkdirs(path);
    }
    MfRng r;
    mf_rng_seed(&r, seed, 77);
    for (int i = 0; i < n; ++i) {
        float alb[3], orm[3] = {1, 0, 0};
        for (int c = 0; c < 3; ++c) alb[c] = 0.1f + 0.85f * mf_rng_float(&r);
        orm[1] = 0.1f + 0.9f * mf_rng_float(&r), orm[2] = mf_rng_float(&r) < 0.5f ? 0.0f : 1.0f;
        int square = mf_rng_float(&r) < 0.5f;
        float cx = R * (0.35f + 0.3f * mf_rng_float(&r)), cy = R * (0.35f + 0.3f * mf_rng_float(&r));
        float rad = R * (0.2f + 0.15f * mf_rng_float(&r)), shade = 0.4f + 0.6f * mf_rng_float(&r);
        MfImage im[3];
        for (int k = 0; k < 3; ++k) mf_image_alloc(&im[k], R, R, 4);
        for (int y = 0; y < R; ++y)
            for (int x = 0; x < R; ++x) {
                float dx = x + 0.5f - cx, dy = y + 0.5f - cy;
                int in = square ? (fabsf(dx) < rad && fabsf(dy) < rad) : (dx * dx + dy * dy < rad * rad);
                if (!in) continue;
                float s = shade * (0.6f + 0.4f * (x + 0.5f) / R);
                for (int c = 0; c < 3; ++c) {
                    mf_image_px(&im[0], x, y)[c] = alb[c] * s;
                    mf_image_px(&im[1], x, y)[c] = alb[c];
                    mf_image_px(&im[2], x, y)[c] = orm[c];
                }
                for (int k = 0; k < 3; ++k) mf_image_px(&im[k], x, y)[3] = 1.0f;
            }
        for (int k = 0; k < 3; ++k) {
            snprintf(rel, sizeof rel, "%s/%06d.png", kinds[k], i);
            mf_path_join(path, sizeof path, dir, rel);
            CHECK_OK(mf_image_write(path, &im[k], MF_ENC_LINEAR, 8)); /* raw codes */
            mf_image_free(&im[k]);
        }
    }
    char man[256];
    snprintf(man, sizeof man, "{\"split\":\"prior-train\",\"resolution\":%d,\"count\":%d,\"seed\":%llu,\"objects\":%d}\n",
             R, n, (unsigned long long)seed, n);
    mf_path_join(path, sizeof path, dir, "manifest.json");
    CHECK_OK(mf_write_file(path, man, strlen(man)));
}

const char *tp_synth_dir(void) {
    static int made = 0;
    const char *dir = mf_test_path("prior_synth");
    static char keep[MF_PATH_MAX];
    if (!made) {
        snprintf(keep, sizeof keep, "%s", dir);
        tp_write_synth(keep, 24, 16, 11);
        made = 1;
    }
    return keep;
}

void tp_tiny_opts(MfTrainPriorOpts *o, const char *out, const char *csv) {
    mf_train_prior_defaults(o);
    o->data_dir = tp_synth_dir(), o->out_dir = out, o->loss_csv = csv;
    o->tiny = 1, o->batch = 8, o->ae_steps = 60, o->steps = 60, o->warmup = 5, o->ckpt_every = 7;
    o->lr_ae = 3e-3f, o->lr_dn = 2e-3f, o->seed = 5;
}

void tp_tiny_prior(MfPrior **p) {
    MfPriorConfig c;
    mf_prior_config_tiny(&c);
    CHECK_OK(mf_prior_new(p, &c));
    mf_ae_init_weights((*p)->ae, 1);
    mf_denoiser_init_weights((*p)->dn, 2);
    mf_kconv_init(&(*p)->dn->cout, (*p)->dn->params, 3, 0);
    (*p)->latent_scale = 0.7f;
}

