/* Tests of mf/core/mf_rng: PCG32, GSL Sobol points, FNV-1a 64. */
#include <gsl/gsl_cdf.h>
#include <stdlib.h>

#include "core/mf_rng.h"
#include "mf_test.h"

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

/* FNV-1a 64 against the published test vectors (the checkpoint checksum and the data set
 * manifests' file digests depend on it). */
MF_TEST(core_fnv1a64_vectors) {
    CHECK(mf_fnv1a64(MF_FNV64_INIT, "", 0) == 0xcbf29ce484222325ull);
    CHECK(mf_fnv1a64(MF_FNV64_INIT, "a", 1) == 0xaf63dc4c8601ec8cull);
    CHECK(mf_fnv1a64(MF_FNV64_INIT, "foobar", 6) == 0x85944171f73967e8ull);
    /* continuing from a partial hash equals hashing the whole */
    CHECK(mf_fnv1a64(mf_fnv1a64(MF_FNV64_INIT, "foo", 3), "bar", 3) == 0x85944171f73967e8ull);
}
