/* mf_prior_bench: the speed of the prior's steps on this machine, measured in one process
 * (`mf bench-prior`): the denoiser + image encoder training step (forward, backward, gradient
 * clipping, AdamW) and the autoencoder training step at batch B, with the FLOPs of their matrix
 * products (mf_nn_gemm_flops: im2col convolutions, linears, attention); OpenBLAS sgemm N x N x N
 * in the same rounds; one guided denoising step (CFG 3, conditional and unconditional passes) at
 * batch 4, single-view and with the 4 views attending jointly. Each timing is the best of reps
 * interleaved rounds (each round runs every measurement once) after one warm-up round, so a shared
 * machine's load affects them alike; with several conv backends (mf_nn.h) each round runs the
 * network measurements under each in turn. Inputs are seeded noise; the weights are updated
 * (learning rate 1e-6). */
#ifndef MF_PRIOR_BENCH_H
#define MF_PRIOR_BENCH_H

#include "nn/mf_nn.h"
#include "prior/mf_prior.h"

typedef struct {
    double sgemm_s;                     /* best wall seconds of one sgemm N^3 */
    double dn_step_s, ae_step_s;        /* best wall seconds of one training step */
    double guided_sv_s, guided_mv_s;    /* best wall seconds of one guided step, batch 4 */
    unsigned long long dn_flops, ae_flops; /* GEMM FLOPs of one training step */
} MfPriorBench;

#define MF_PRIOR_BENCH_MAXBE 2

/* r[k] (nbe <= MF_PRIOR_BENCH_MAXBE) under backend be[k]; sgemm_s is the same in each. The
 * backend in force before the call is restored. */
int mf_prior_bench(MfPrior *p, int B, int reps, int N, int nbe, const MfNnBackend *be, MfPriorBench *r);

#endif
