#include "mf_rng.h"

#include <gsl/gsl_qrng.h>
#include <math.h>
#include <stdlib.h>

uint32_t mf_rng_below(MfRng *r, uint32_t n) {
    uint32_t threshold = (-n) % n;
    for (;;) {
        uint32_t x = mf_rng_u32(r);
        if (x >= threshold) return x % n;
    }
}

float mf_rng_normal(MfRng *r) {
    double u1 = mf_rng_double(r), u2 = mf_rng_double(r);
    if (u1 < 1e-300) u1 = 1e-300;
    return (float)(sqrt(-2.0 * log(u1)) * cos(2.0 * 3.14159265358979323846 * u2));
}

uint64_t mf_hash64(uint64_t a, uint64_t b) {
    uint64_t x = a * 0x9E3779B97F4A7C15ULL ^ (b + 0x632BE59BD9B4E019ULL + (a << 6) + (a >> 2));
    x ^= x >> 30;
    x *= 0xBF58476D1CE4E5B9ULL;
    x ^= x >> 27;
    x *= 0x94D049BB133111EBULL;
    x ^= x >> 31;
    return x;
}

uint64_t mf_fnv1a64(uint64_t h, const void *data, size_t n) {
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

struct MfSobol { gsl_qrng *q; };

MfSobol *mf_sobol_new(unsigned dim) {
    MfSobol *s = malloc(sizeof *s);
    if (!s) return NULL;
    s->q = gsl_qrng_alloc(gsl_qrng_sobol, dim);
    if (!s->q) { free(s); return NULL; }
    return s;
}

void mf_sobol_next(MfSobol *s, double *out) { gsl_qrng_get(s->q, out); }

void mf_sobol_free(MfSobol *s) {
    if (!s) return;
    gsl_qrng_free(s->q);
    free(s);
}
