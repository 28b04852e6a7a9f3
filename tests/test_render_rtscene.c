/* Tests of mf/render/mf_rtscene (the Embree scene): the batched shadow-ray query
 * (mf_rtscene_occluded_n) against the single-ray one. */
#include <math.h>
#include <stdio.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "render/mf_estimator.h"
#include "render/mf_rtscene.h"
#include "scene/mf_shapes.h"
#include "mf_test.h"

/* mf_rtscene_occluded_n (16-wide packets) gives mf_rtscene_occluded's answer for every ray, for
 * batch sizes around the packet width (a lone ray, partial and full packets), from points on a
 * torus (rays that leave the surface, some blocked by the ring, some not). */
MF_TEST(render_occluded_n_matches_single) {
    MfMesh m;
    MfRtScene *rt = NULL;
    CHECK_OK(mf_shape_torus(&m, 0.35f, 0.15f, 64, 32));
    CHECK_OK(mf_rtscene_new(&m, &rt));
    MfRng rng;
    mf_rng_seed(&rng, 7, 1);
    const int sizes[6] = {1, 2, 15, 16, 17, 64};
    int blocked = 0, free_ = 0, differ = 0;
    for (int k = 0; k < 60; ++k) {
        float a = 6.2831853f * mf_rng_float(&rng);
        MfVec3 org = mf_v3(1.5f * (mf_rng_float(&rng) - 0.5f), 1.5f * (mf_rng_float(&rng) - 0.5f), 1.0f);
        MfVec3 ring = mf_v3(0.35f * cosf(a), 0.35f * sinf(a), 0.0f); /* aim at the ring */
        MfHit h;
        if (!mf_rtscene_intersect(rt, org, mf_norm(mf_sub(ring, org)), 0.0f, INFINITY, &h)) continue;
        int n = sizes[k % 6];
        MfVec3 o[64], d[64];
        unsigned char occ[64];
        for (int i = 0; i < n; ++i) {
            float ct = 2.0f * mf_rng_float(&rng) - 1.0f, st = sqrtf(fmaxf(0.0f, 1.0f - ct * ct)), ph = 6.2831853f * mf_rng_float(&rng);
            d[i] = mf_v3(st * cosf(ph), st * sinf(ph), ct);
            if (mf_dot(d[i], h.ng) < 0.0f) d[i] = mf_neg(d[i]);
            o[i] = mf_est_ray_origin(&h, d[i]);
        }
        float tfar = k % 2 ? INFINITY : 0.2f;
        mf_rtscene_occluded_n(rt, n, o, d, tfar, occ);
        for (int i = 0; i < n; ++i) {
            int single = mf_rtscene_occluded(rt, o[i], d[i], 0.0f, tfar);
            differ += occ[i] != single;
            blocked += single, free_ += !single;
        }
    }
    CHECK(differ == 0);
    if (blocked <= 50 || free_ <= 50) fprintf(stderr, "    blocked %d, free %d\n", blocked, free_);
    CHECK(blocked > 50 && free_ > 50); /* both answers occur */
    mf_rtscene_free(rt);
    mf_mesh_free(&m);
}
