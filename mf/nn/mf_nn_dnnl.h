/* mf_nn_dnnl: conv2d through oneDNN (Debian's libdnnl-dev), the default backend of mf_conv2d_*
 * (mf_nn.h; the default `make` builds it, with -DMF_HAVE_DNNL; `make DNNL=0` does not). Private to
 * mf/nn: the layers call it when mf_nn_backend() is MF_NN_DNNL.
 *
 * Same arrays and semantics as the im2col + sgemm path: activations plain NCHW, weights OIHW,
 * K x K, pad K/2 (right/bottom padding whatever gives Ho = mf_conv2d_out_size), stride 1 or 2.
 * Inside, oneDNN's channel-blocked layouts are used where it picks them (copies in and out, see
 * mf_nn_dnnl.c: they pay). Primitives are created on a shape's first use and cached per thread
 * (creation costs milliseconds, a call microseconds): one entry per (B, Cin, H, W, Cout, K,
 * stride, bias or not; the backward passes use the shape's forward entry), never evicted (a network uses a few dozen shapes); the blocked copies live
 * in one scratch buffer per thread that grows to the largest call. oneDNN's own threads are
 * OpenMP's (see mf_nn_dnnl_set_threads). Results differ from the sgemm path in the last bits
 * (another summation order); for a fixed thread count they are deterministic.
 *
 * Each returns MF_OK, or MF_EEXT / MF_ENOMEM with a message (mf_error) and its output untouched
 * when oneDNN fails (e.g. a shape no implementation takes). */
#ifndef MF_NN_DNNL_H
#define MF_NN_DNNL_H

#ifdef MF_HAVE_DNNL
/* out (B, Cout, Ho, Wo) = conv(in (B, Cin, H, W), w (Cout, Cin, K, K)) + bias (Cout, or NULL). */
int mf_nn_dnnl_conv_forward(float *out, const float *in, const float *w, const float *bias, int B, int Cin, int H,
                            int W, int Cout, int K, int stride);
/* din (B, Cin, H, W) = (acc 0) or += (acc 1) the input gradient from dout (B, Cout, Ho, Wo). */
int mf_nn_dnnl_conv_backward_data(float *din, int acc, const float *dout, const float *w, int B, int Cin, int H,
                                  int W, int Cout, int K, int stride);
/* dw (Cout, Cin, K, K) += the weight gradient from dout (B, Cout, Ho, Wo) and in (B, Cin, H, W). */
int mf_nn_dnnl_conv_backward_weights(float *dw, const float *dout, const float *in, int B, int Cin, int H, int W,
                                     int Cout, int K, int stride);
/* Threads of oneDNN's calls from now on, process-wide (n >= 1; before the first call: OpenMP's
 * default, OMP_NUM_THREADS); mf_nn_set_threads sets it with OpenBLAS's. */
void mf_nn_dnnl_set_threads(int n);
/* Frees the calling thread's primitives, engine and scratch (the next call makes them again). */
void mf_nn_dnnl_release(void);
#endif
/* The calling thread's cached shapes (entries above; 0 in a build without oneDNN). */
int mf_nn_dnnl_entries(void);

#endif
