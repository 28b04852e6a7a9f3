/* Shared fixtures of the prior tests (tests/test_prior_*.c, test_cli_prior.c).
 *
 * tp_fill:        x (n) = s * uniform(-1, 1), deterministic in seed.
 * tp_dot:         sum of a[i] * b[i] in double.
 * tp_write_synth: n samples at R px in the prior-train layout under dir: a disc or a square of
 *                 one albedo (sRGB codes) and one ORM, lit by a shading factor with a
 *                 left-to-right gradient; alpha = the shape; plus manifest.json.
 * tp_synth_dir:   a 24-sample 16 px synthetic set in the test folder, written on first use.
 * tp_tiny_opts:   training options for a tiny model on tp_synth_dir (60 + 60 steps).
 * tp_tiny_prior:  a tiny prior with deterministic random weights. */
#ifndef MF_TEST_PRIOR_H
#define MF_TEST_PRIOR_H

#include <stddef.h>
#include <stdint.h>

#include "prior/mf_prior.h"
#include "prior/mf_prior_train.h"

void tp_fill(float *x, size_t n, uint64_t seed, float s);
double tp_dot(const float *a, const float *b, size_t n);
void tp_write_synth(const char *dir, int n, int R, uint64_t seed);
const char *tp_synth_dir(void);
void tp_tiny_opts(MfTrainPriorOpts *o, const char *out, const char *csv);
void tp_tiny_prior(MfPrior **p);

#endif
