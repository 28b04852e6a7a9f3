/* mf_rng: deterministic random numbers.
 *
 * PCG32 (O'Neill 2014, pcg32_random_r): 64-bit state, 32-bit output, independent streams.
 * Every random choice in the project takes an explicit (seed, stream) pair; per-pixel or
 * per-item streams make results independent of thread scheduling.
 * Quasi-random Sobol points come from GSL (gsl_qrng_sobol), wrapped as MfSobol. */
#ifndef MF_RNG_H
#define MF_RNG_H

#include <stddef.h>
#include <stdint.h>

typedef struct { uint64_t state, inc; } MfRng;

static inline uint32_t mf_rng_u32(MfRng *r) {
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

static inline void mf_rng_seed(MfRng *r, uint64_t seed, uint64_t stream) {
    r->state = 0u;
    r->inc = (stream << 1u) | 1u;
    mf_rng_u32(r);
    r->state += seed;
    mf_rng_u32(r);
}

/* Uniform in [0, 1): 24 random mantissa bits, never returns 1. */
static inline float mf_rng_float(MfRng *r) { return (float)(mf_rng_u32(r) >> 8) * (1.0f / 16777216.0f); }

/* Uniform in [0, 1) with 53 bits. */
static inline double mf_rng_double(MfRng *r) {
    uint64_t hi = mf_rng_u32(r) >> 5, lo = mf_rng_u32(r) >> 6;
    return ((double)hi * 67108864.0 + (double)lo) * (1.0 / 9007199254740992.0);
}

/* A jittered point in stratum k of an n x n grid over [0, 1)^2 (row k / n, column k % n);
 * u1 is drawn before u2. */
static inline void mf_rng_stratum2(MfRng *r, int k, int n, float *u1, float *u2) {
    float inv_n = 1.0f / (float)n;
    *u1 = ((float)(k / n) + mf_rng_float(r)) * inv_n;
    *u2 = ((float)(k % n) + mf_rng_float(r)) * inv_n;
}

/* Uniform integer in [0, n) without modulo bias (n > 0). */
uint32_t mf_rng_below(MfRng *r, uint32_t n);

/* Standard normal (Box-Muller). */
float mf_rng_normal(MfRng *r);

/* Mixes several integers into one well-spread 64-bit value (for deriving per-item seeds). */
uint64_t mf_hash64(uint64_t a, uint64_t b);

/* FNV-1a 64 of n bytes, continuing from h (start with MF_FNV64_INIT): checkpoint checksums,
 * file digests of the data set manifests. */
#define MF_FNV64_INIT 0xcbf29ce484222325ull
uint64_t mf_fnv1a64(uint64_t h, const void *data, size_t n);

/* Sobol low-discrepancy points in [0,1)^dim through GSL (dim <= 40). */
typedef struct MfSobol MfSobol;
MfSobol *mf_sobol_new(unsigned dim);
void mf_sobol_next(MfSobol *s, double *out); /* out: (dim,) */
void mf_sobol_free(MfSobol *s);

#endif
