/* Tests of mf/core/mf_math: orthonormal frames. */
#include "core/mf_math.h"
#include "core/mf_rng.h"
#include "mf_test.h"

MF_TEST(core_frame_orthonormal) {
    MfRng r;
    mf_rng_seed(&r, 1, 1);
    for (int i = 0; i < 1000; ++i) {
        MfVec3 n = mf_norm(mf_v3(mf_rng_normal(&r), mf_rng_normal(&r), mf_rng_normal(&r)));
        if (i == 0) n = mf_v3(0, 0, -1);
        if (i == 1) n = mf_v3(0, 0, 1);
        MfFrame f = mf_frame(n);
        CHECK_NEAR(mf_dot(f.t, f.b), 0, 1e-5);
        CHECK_NEAR(mf_dot(f.t, f.n), 0, 1e-5);
        CHECK_NEAR(mf_len(f.t), 1, 1e-5);
        CHECK_NEAR(mf_len(f.b), 1, 1e-5);
        MfVec3 v = mf_v3(0.3f, -0.2f, 0.9f);
        MfVec3 w = mf_to_local(&f, mf_to_world(&f, v));
        CHECK_NEAR(w.x, v.x, 1e-5);
        CHECK_NEAR(w.z, v.z, 1e-5);
    }
}
