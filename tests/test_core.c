/* Tests of mf/core: errors, RNG, math frames, Sobol, file helpers. */
#include <gsl/gsl_cdf.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_math.h"
#include "core/mf_rng.h"
#include "mf_test.h"

MF_TEST(core_error_message) {
    int rc = mf_fail(MF_EIO, "%s: cannot open", "x.png");
    CHECK(rc == MF_EIO);
    CHECK(!strcmp(mf_error(), "x.png: cannot open"));
    mf_fail_prefix(rc, "scene.json");
    CHECK(!strcmp(mf_error(), "scene.json: x.png: cannot open"));
}

MF_TEST(core_rng_deterministic_and_uniform) {
    MfRng a, b;
    mf_rng_seed(&a, 42, 7);
    mf_rng_seed(&b, 42, 7);
    for (int i = 0; i < 100; ++i) CHECK(mf_rng_u32(&a) == mf_rng_u32(&b));
    mf_rng_seed(&b, 42, 8);
    int same = 0;
    for (int i = 0; i < 100; ++i) same += mf_rng_u32(&a) == mf_rng_u32(&b);
    CHECK(same < 3);
    /* chi-square of 20 bins */
    enum { BINS = 20, N = 200000 };
    int hist[BINS] = {0};
    for (int i = 0; i < N; ++i) {
        float u = mf_rng_float(&a);
        CHECK(u >= 0.0f && u < 1.0f);
        hist[(int)(u * BINS)]++;
    }
    double chi = 0, e = (double)N / BINS;
    for (int k = 0; k < BINS; ++k) chi += (hist[k] - e) * (hist[k] - e) / e;
    CHECK_MSG(gsl_cdf_chisq_Q(chi, BINS - 1) > 0.01, "chi2 %g", chi);
    for (int i = 0; i < 1000; ++i) CHECK(mf_rng_below(&a, 7) < 7);
}

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

MF_TEST(core_sobol_stratified) {
    MfSobol *s = mf_sobol_new(2);
    CHECK(s != NULL);
    int cells[4][4] = {{0}};
    double p[2];
    /* GSL skips the origin, so 256 points fill each of the 16 cells with 16 +- 1 (random points
     * would deviate by about 4). */
    for (int i = 0; i < 256; ++i) {
        mf_sobol_next(s, p);
        cells[(int)(p[0] * 4)][(int)(p[1] * 4)]++;
    }
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) CHECK_MSG(abs(cells[i][j] - 16) <= 1, "cell %d %d: %d", i, j, cells[i][j]);
    mf_sobol_free(s);
}

MF_TEST(core_fs_atomic_write) {
    const char *p = mf_test_path("sub/dir/file.txt");
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_write_file(p, "hello", 5));
    char *d = NULL;
    size_t n = 0;
    CHECK_OK(mf_read_file(p, &d, &n));
    CHECK(n == 5 && d && !strcmp(d, "hello"));
    free(d);
    CHECK_ERR(mf_read_file(mf_test_path("missing.txt"), &d, &n), "missing.txt");
    char tmp[MF_PATH_MAX], ext[8];
    CHECK_OK(mf_tmp_path("a/b.png", tmp, sizeof tmp));
    mf_path_ext(tmp, ext, sizeof ext);
    CHECK(!strcmp(ext, "png"));
    CHECK(!strncmp(tmp, "a/.b.tmp", 8));
}
