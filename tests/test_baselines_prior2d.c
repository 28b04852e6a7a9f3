/* Tests of baselines/bl_prior2d: the 2D baselines of the prior table (Retinex, training-set mean ORM). */

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

MF_TEST(prior_2d_baselines) {
    MfImage rgb = {0}, a = {0}, r = {0}, o = {0};
    mf_image_alloc(&rgb, 24, 24, 4);
    /* albedo (0.6, 0.4, 0.2) under a smooth left-to-right shading ramp */
    for (int y = 4; y < 20; ++y)
        for (int x = 4; x < 20; ++x) {
            float *px = mf_image_px(&rgb, x, y), s = 0.3f + 0.7f * x / 24.0f;
            px[0] = 0.6f * s, px[1] = 0.4f * s, px[2] = 0.2f * s, px[3] = 1.0f;
        }
    CHECK_OK(bl_albedo_input(&rgb, &a));
    CHECK(a.data[(12 * 24 + 12) * 4 + 1] == rgb.data[(12 * 24 + 12) * 4 + 1]);
    CHECK_OK(bl_albedo_retinex(&rgb, 3.0f, &r));
    /* shading removed: the ratio between the right and left inside columns is far closer to 1 than the input's */
    float in_ratio = mf_image_px(&rgb, 18, 12)[0] / mf_image_px(&rgb, 5, 12)[0];
    float rx_ratio = mf_image_px(&r, 18, 12)[0] / mf_image_px(&r, 5, 12)[0];
    CHECK_MSG(fabsf(rx_ratio - 1) < 0.5f * fabsf(in_ratio - 1), "input %g, retinex %g", in_ratio, rx_ratio);
    CHECK_NEAR(mf_image_px(&r, 12, 12)[1] / mf_image_px(&r, 12, 12)[0], 0.4f / 0.6f, 1e-4); /* chroma kept */
    CHECK(mf_image_px(&r, 0, 0)[0] == 0.0f && mf_image_px(&r, 0, 0)[3] == 0.0f);
    CHECK_OK(bl_orm_constant(&rgb, 0.25f, 0.75f, &o));
    CHECK(mf_image_px(&o, 12, 12)[0] == 1.0f && mf_image_px(&o, 12, 12)[1] == 0.25f && mf_image_px(&o, 12, 12)[2] == 0.75f);
    float rr, mm;
    const MfImage *one = &o;
    CHECK_OK(bl_orm_mean(&one, 1, &rr, &mm));
    CHECK_NEAR(rr, 0.25f, 1e-6);
    CHECK_NEAR(mm, 0.75f, 1e-6);
    MfImage empty = {0};
    mf_image_alloc(&empty, 4, 4, 4);
    one = &empty;
    CHECK_ERR(bl_orm_mean(&one, 1, &rr, &mm), "no pixel inside");
    mf_image_free(&rgb), mf_image_free(&a), mf_image_free(&r), mf_image_free(&o), mf_image_free(&empty);
}
