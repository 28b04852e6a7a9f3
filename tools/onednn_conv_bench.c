/* onednn_conv_bench: oneDNN's 3x3 stride-1 convolution (forward, backward data, backward
 * weights) against mf_conv2d_forward + mf_conv2d_backward (im2col + OpenBLAS sgemm) and OpenBLAS
 * sgemm 1024^3, in one process, at the prior's conv shapes (`make bench-nn-onednn`; needs
 * Debian's libdnnl-dev, which the project does not otherwise use).
 *
 * oneDNN works on the project's own layout (plain NCHW activations, OIHW weights), so the
 * comparison is that of a drop-in replacement: no reorders are timed or needed. Each round times
 * sgemm, ours and oneDNN once, in turn; the ratios are medians over rounds of each round's ratio
 * of CPU seconds (run it with one thread: OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1). The outputs
 * are compared (max relative difference) so that both compute the same thing.
 *
 * usage: onednn_conv_bench [rounds]    (markdown on stdout) */
#include <cblas.h>
#include <math.h>
#include <oneapi/dnnl/dnnl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_log.h"
#include "nn/mf_nn.h"

#define CHECK(x)                                                                  \
    do {                                                                          \
        dnnl_status_t s_ = (x);                                                   \
        if (s_ != dnnl_success) {                                                 \
            fprintf(stderr, "onednn_conv_bench: %s failed (%d)\n", #x, (int)s_); \
            exit(1);                                                              \
        }                                                                         \
    } while (0)

static float *fill(size_t n, float s) {
    float *p = malloc(n * sizeof(float));
    if (!p) {
        fprintf(stderr, "onednn_conv_bench: out of memory\n");
        exit(1);
    }
    for (size_t i = 0; i < n; ++i) p[i] = s * ((float)((i * 2654435761u) % 1000) / 1000.0f - 0.5f);
    return p;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *q, int n) {
    qsort(q, (size_t)n, sizeof *q, cmp_double);
    return n % 2 ? q[n / 2] : 0.5 * (q[n / 2 - 1] + q[n / 2]);
}

static double max_rel(const float *a, const float *b, size_t n) {
    double m = 0, s = 0;
    for (size_t i = 0; i < n; ++i) s = fmax(s, fabs((double)b[i]));
    for (size_t i = 0; i < n; ++i) m = fmax(m, fabs((double)a[i] - (double)b[i]));
    return s > 0 ? m / s : m;
}

typedef struct {
    dnnl_primitive_t fwd, bwd_d, bwd_w;
    dnnl_memory_t src, wei, bias, dst, dsrc, dwei, dbias, ddst;
} Dnn;

static dnnl_memory_t mem(dnnl_engine_t eng, int nd, const dnnl_dims_t dims, dnnl_format_tag_t tag, float *data) {
    dnnl_memory_desc_t md;
    CHECK(dnnl_memory_desc_init_by_tag(&md, nd, dims, dnnl_f32, tag));
    dnnl_memory_t m;
    CHECK(dnnl_memory_create(&m, &md, eng, data));
    return m;
}

static dnnl_primitive_t prim(const void *desc, dnnl_engine_t eng, const_dnnl_primitive_desc_t hint, dnnl_primitive_desc_t *pd_out) {
    dnnl_primitive_desc_t pd;
    CHECK(dnnl_primitive_desc_create(&pd, desc, NULL, eng, hint));
    dnnl_primitive_t p;
    CHECK(dnnl_primitive_create(&p, pd));
    if (pd_out) *pd_out = pd;
    else dnnl_primitive_desc_destroy(pd);
    return p;
}

typedef struct {
    int B, C, S;
} Shape;

/* One shape: prints a table row. */
static void bench_shape(dnnl_engine_t eng, dnnl_stream_t st, Shape sh, int rounds, const float *ga, const float *gb, float *gc) {
    int B = sh.B, C = sh.C, S = sh.S, P = S * S, CKK = 9 * C;
    size_t nact = (size_t)B * C * P, nw = (size_t)C * CKK;
    float *in = fill(nact, 1), *w = fill(nw, 0.1f), *bias = fill((size_t)C, 0.1f), *dout = fill(nact, 0.01f);
    float *out_m = fill(nact, 0), *din_m = fill(nact, 0), *dw_m = fill(nw, 0), *db_m = fill((size_t)C, 0);
    float *out_d = fill(nact, 0), *din_d = fill(nact, 0), *dw_d = fill(nw, 0), *db_d = fill((size_t)C, 0);
    float *col = fill(mf_conv2d_col_floats(B, C, S, S, C, 3, 1), 0);
    dnnl_dims_t ad = {B, C, S, S}, wd = {C, C, 3, 3}, bd = {C}, strides = {1, 1}, pad = {1, 1};
    Dnn d;
    d.src = mem(eng, 4, ad, dnnl_nchw, in), d.wei = mem(eng, 4, wd, dnnl_oihw, w), d.bias = mem(eng, 1, bd, dnnl_x, bias);
    d.dst = mem(eng, 4, ad, dnnl_nchw, out_d), d.dsrc = mem(eng, 4, ad, dnnl_nchw, din_d);
    d.dwei = mem(eng, 4, wd, dnnl_oihw, dw_d), d.dbias = mem(eng, 1, bd, dnnl_x, db_d), d.ddst = mem(eng, 4, ad, dnnl_nchw, dout);
    const dnnl_memory_desc_t *md_a, *md_w, *md_b;
    CHECK(dnnl_memory_get_memory_desc(d.src, &md_a));
    CHECK(dnnl_memory_get_memory_desc(d.wei, &md_w));
    CHECK(dnnl_memory_get_memory_desc(d.bias, &md_b));
    dnnl_convolution_desc_t fd, bdd, bwd;
    CHECK(dnnl_convolution_forward_desc_init(&fd, dnnl_forward_training, dnnl_convolution_direct, md_a, md_w, md_b, md_a, strides, pad, pad));
    CHECK(dnnl_convolution_backward_data_desc_init(&bdd, dnnl_convolution_direct, md_a, md_w, md_a, strides, pad, pad));
    CHECK(dnnl_convolution_backward_weights_desc_init(&bwd, dnnl_convolution_direct, md_a, md_w, md_b, md_a, strides, pad, pad));
    dnnl_primitive_desc_t fpd;
    d.fwd = prim(&fd, eng, NULL, &fpd);
    d.bwd_d = prim(&bdd, eng, fpd, NULL);
    d.bwd_w = prim(&bwd, eng, fpd, NULL);
    dnnl_exec_arg_t af[] = {{DNNL_ARG_SRC, d.src}, {DNNL_ARG_WEIGHTS, d.wei}, {DNNL_ARG_BIAS, d.bias}, {DNNL_ARG_DST, d.dst}};
    dnnl_exec_arg_t abd[] = {{DNNL_ARG_DIFF_DST, d.ddst}, {DNNL_ARG_WEIGHTS, d.wei}, {DNNL_ARG_DIFF_SRC, d.dsrc}};
    dnnl_exec_arg_t abw[] = {{DNNL_ARG_SRC, d.src}, {DNNL_ARG_DIFF_DST, d.ddst}, {DNNL_ARG_DIFF_WEIGHTS, d.dwei}, {DNNL_ARG_DIFF_BIAS, d.dbias}};
    double *t = malloc(3 * (size_t)(rounds + 1) * sizeof *t), *q = malloc(2 * (size_t)rounds * sizeof *q);
    if (!t || !q) exit(1);
    for (int r = 0; r <= rounds; ++r) { /* round 0: warm-up */
        double c0 = mf_cpu_now();
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, 1024, 1024, 1024, 1.0f, ga, 1024, gb, 1024, 0.0f, gc, 1024);
        double c1 = mf_cpu_now();
        memset(din_m, 0, nact * sizeof(float)), memset(dw_m, 0, nw * sizeof(float)), memset(db_m, 0, (size_t)C * sizeof(float));
        mf_conv2d_forward(out_m, col, in, w, bias, B, C, S, S, C, 3, 1);
        mf_conv2d_backward(din_m, dw_m, db_m, col, dout, in, w, B, C, S, S, C, 3, 1);
        double c2 = mf_cpu_now();
        CHECK(dnnl_primitive_execute(d.fwd, st, 4, af));
        CHECK(dnnl_primitive_execute(d.bwd_d, st, 3, abd));
        CHECK(dnnl_primitive_execute(d.bwd_w, st, 4, abw));
        CHECK(dnnl_stream_wait(st));
        double c3 = mf_cpu_now();
        t[3 * r] = c1 - c0, t[3 * r + 1] = c2 - c1, t[3 * r + 2] = c3 - c2;
    }
    double fs = 2.0 * 1024 * 1024 * 1024, fc = 3.0 * 2.0 * B * C * (double)P * CKK;
    for (int r = 1; r <= rounds; ++r) {
        q[r - 1] = (fc / t[3 * r + 1]) / (fs / t[3 * r]);
        q[rounds + r - 1] = (fc / t[3 * r + 2]) / (fs / t[3 * r]);
    }
    double best[3] = {1e30, 1e30, 1e30};
    for (int r = 1; r <= rounds; ++r)
        for (int k = 0; k < 3; ++k) best[k] = fmin(best[k], t[3 * r + k]);
    double err = fmax(fmax(max_rel(out_d, out_m, nact), max_rel(din_d, din_m, nact)), max_rel(dw_d, dw_m, nw));
    double m_ours = median(q, rounds), m_dnnl = median(q + rounds, rounds);
    printf("| B=%d C=%d->%d %dx%d | %.1f | %.1f | %.1f | **%.2f** | **%.2f** | %.1e |\n", B, C, C, S, S, fs / best[0] * 1e-9,
           fc / best[1] * 1e-9, fc / best[2] * 1e-9, m_ours, m_dnnl, err);
    dnnl_primitive_desc_destroy(fpd);
    dnnl_primitive_destroy(d.fwd), dnnl_primitive_destroy(d.bwd_d), dnnl_primitive_destroy(d.bwd_w);
    dnnl_memory_t ms[] = {d.src, d.wei, d.bias, d.dst, d.dsrc, d.dwei, d.dbias, d.ddst};
    for (int i = 0; i < 8; ++i) dnnl_memory_destroy(ms[i]);
    free(in), free(w), free(bias), free(dout), free(out_m), free(din_m), free(dw_m), free(db_m);
    free(out_d), free(din_d), free(dw_d), free(db_d), free(col), free(t), free(q);
}

int main(int argc, char **argv) {
    int rounds = argc > 1 ? atoi(argv[1]) : 9;
    if (rounds < 1 || rounds > 10000) {
        fprintf(stderr, "usage: onednn_conv_bench [rounds in 1..10000]\n");
        return 2;
    }
    dnnl_engine_t eng;
    dnnl_stream_t st;
    CHECK(dnnl_engine_create(&eng, dnnl_cpu, 0));
    CHECK(dnnl_stream_create(&st, eng, dnnl_stream_default_flags));
    float *ga = fill(1024 * 1024, 1), *gb = fill(1024 * 1024, 1), *gc = fill(1024 * 1024, 0);
    const dnnl_version_t *v = dnnl_version();
    double load = 0.0;
    getloadavg(&load, 1);
    printf("# oneDNN conv2d vs ours (im2col + OpenBLAS sgemm)\n\n"
           "Generated by `make bench-nn-onednn` (tools/onednn_conv_bench.c); do not edit by hand.\n"
           "oneDNN %d.%d.%d (%s), plain NCHW / OIHW (the project's layout, no reorders; the default backend\n"
           "lets oneDNN pick blocked layouts instead: make bench-nn); 1-minute load average %.2f\n"
           "at the start. OpenMP threads and\n"
           "OpenBLAS threads as set by the caller (the make target: 1). 3x3 stride 1 forward + backward data +\n"
           "backward weights; GFLOP/s of the best of %d rounds (CPU seconds); ratios to sgemm 1024^3: median over\n"
           "rounds of each round's ratio. max rel. diff: largest |oneDNN - ours| / max |ours| over out, din, dw.\n\n"
           "| shape | sgemm 1024^3 | ours | oneDNN | ours / sgemm | oneDNN / sgemm | max rel. diff |\n"
           "|---|---|---|---|---|---|---|\n",
           v->major, v->minor, v->patch, v->cpu_runtime == DNNL_RUNTIME_OMP ? "OpenMP" : "other runtime", load, rounds);
    /* the prior's convolutions at training batch 16 (mf/prior/weights/prior.mfck: denoiser c1 64
     * at 16x16, c2 128 at 8x8; autoencoder c1 32 at 64x64, c2 64 at 32x32) */
    const Shape shapes[] = {{16, 64, 16}, {16, 128, 8}, {16, 32, 64}, {16, 64, 32}};
    for (size_t i = 0; i < sizeof shapes / sizeof *shapes; ++i) bench_shape(eng, st, shapes[i], rounds, ga, gb, gc);
    free(ga), free(gb), free(gc);
    dnnl_stream_destroy(st);
    dnnl_engine_destroy(eng);
    return 0;
}
