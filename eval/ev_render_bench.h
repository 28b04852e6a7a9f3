/* ev_render_bench: the renderer's throughput against a bare Embree loop replaying the renderer's
 * own rays (DESIGN.md, performance method; `mf bench-render`).
 *
 * ev_render_bench renders the camera's image in chunks of 32 rows, interleaved so that both
 * timings see the same machine load: (1) the renderer renders the chunk (timed); (2) it renders
 * the chunk again recording its rays (untimed; same seeds, so identical rays); (3) a bare loop
 * replays them with rtcIntersect1 / rtcOccluded1 only (timed, rows in parallel). Wall and CPU
 * seconds (all threads of the process) are summed over the chunks. */
#ifndef EV_RENDER_BENCH_H
#define EV_RENDER_BENCH_H

#include "io/mf_image.h"
#include "render/mf_integrator.h"

typedef struct {
    double t_render, t_bare;    /* wall seconds: renderer, bare replay */
    double c_render, c_bare;    /* CPU seconds of the process: renderer, bare replay */
    long n_primary, n_shadow;   /* rays the renderer traced */
    long checksum;              /* bare replay: primary hits + occluded shadow rays */
    double coverage;            /* mean alpha of the image */
} EvRenderBench;

/* out: allocated here (cam->w x cam->h); free with mf_render_out_free. */
int ev_render_bench(const MfRenderInput *in, const MfCamera *cam, const MfRenderOpts *o, MfRenderOut *out, EvRenderBench *r);

/* An env probe as a 3-channel linear image (1 or 2 channels: the first repeated), box-filtered by
 * powers of two until its width is <= max_w (0: full size; keeps 2:1 lat-long); w0, h0: the
 * file's size. */
int ev_env_probe_read(const char *path, int max_w, MfImage *out, int *w0, int *h0);

#endif
