/* ev_render_bench: the renderer's throughput against a bare Embree loop replaying the renderer's
 * own rays (DESIGN.md, performance method; `mf bench-render`).
 *
 * ev_render_bench renders the camera's image in chunks of 32 rows, interleaved so that both
 * timings see the same machine load: (1) the renderer renders the chunk (timed); (2) it renders
 * the chunk again recording its rays (untimed; same seeds, so identical rays); (3) bare loops
 * replay them with each of Embree's ray APIs in turn (single rays, 16-wide packets, streams;
 * timed, rows in parallel), and the fastest API's total is the bare time. Wall and CPU seconds
 * (all threads of the process) are summed over the chunks. */
#ifndef EV_RENDER_BENCH_H
#define EV_RENDER_BENCH_H

#include "io/mf_image.h"
#include "render/mf_integrator.h"

enum { EV_REPLAY_SINGLE, EV_REPLAY_PACKETS, EV_REPLAY_STREAMS, EV_NREPLAY };
extern const char *const ev_replay_names[EV_NREPLAY];

typedef struct {
    double t_render, t_bare;    /* wall seconds: renderer, bare replay (the fastest API) */
    double c_render, c_bare;    /* CPU seconds of the process: renderer, bare replay */
    double t_api[EV_NREPLAY], c_api[EV_NREPLAY]; /* wall and CPU seconds of each API's replay */
    long sum_api[EV_NREPLAY];   /* each replay's checksum (equal, else ev_render_bench fails) */
    int best;                   /* the fastest replay (EV_REPLAY_*) */
    double load[2];             /* the machine's 1-minute load average at the start and the end */
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
