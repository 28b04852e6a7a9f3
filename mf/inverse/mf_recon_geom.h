/* mf_recon_geom: where `mf recon`'s mesh comes from (issue 14 item 10, its hull part).
 *
 *   given  the data set's mesh (or --mesh): read as before; it must have UVs. The default when
 *          such a mesh exists, so runs on a given mesh are unchanged (same bytes).
 *   vhull  the visual hull of the training views' masks, built by mf_vhull_mesh with the same
 *          defaults as `mf hull` (MF_HULL_DEFAULT_*: 128^3 grid, Taubin smoothing, decimation to
 *          40k triangles), unwrapped by mf_uvatlas as `mf unwrap` does (its defaults; the gutter
 *          counted in the run's tex_res), written to <out>/geometry/vhull.obj and read back from
 *          there, so a run and a resumed run optimise the same bytes. The default when the data
 *          set has no mesh (a log line says so). With resume, a readable geometry/vhull.obj with
 *          UVs is reused (the hull and the unwrap are deterministic; an unreadable one is rebuilt
 *          with a warning).
 *   dmtet  DMTet's mask term (mf_geom_fit, issue 14 pass 1 without its colour loss): an SDF on a
 *          dmtet_res^3 tet grid (side hull_extent, enlarged 1.5x once when the hull touches its
 *          border: mf_vhull_grid, as vhull; by default the start's resolution: hull_res, the
 *          hull's own grid, or MF_DMTET_SOFT_RES) initialised (dmtet_init) from the signed
 *          distance to the hull mesh vhull builds (mf_meshsdf; the default) or from the soft
 *          visual hull (mf_vhull, scaled to cell units), geom_iters Adam steps on the training
 *          views' masks (geom_views per step, in turn), then extraction and the hull's clean-up (weld, small
 *          components dropped, Taubin, decimation: the hull_* options), unwrapped as vhull ->
 *          <out>/geometry/dmtet.obj; the per-step loss -> <out>/geom_log.csv. Reused with resume
 *          like vhull.obj. While the fit runs, its state (SDF, Adam moments, step, log) goes to
 *          <out>/geometry/dmtet_state.mfck every 25 steps, so a run stopped inside pass 1 resumes
 *          there (the same bytes as an uninterrupted fit; mf_geom_fit.h); it is removed once
 *          dmtet.obj is written. By default only silhouettes drive it, so concavities the masks do
 *          not see stay as the hull left them; geom_color > 0 adds the colour term
 *          (mf_geom_fit.h), whose shading gradients reach them.
 *   vessel (vhull and dmtet; --vessel auto|open|closed, default auto): silhouettes cannot carve a
 *          cavity, so the field is also tested as an open vessel (mf_vessel.h). When the hull has
 *          a large flat top facing the cameras, auto extracts the closed mesh and the field
 *          carved below that top (walls vessel_wall x the hull's side, at least
 *          MF_VESSEL_MIN_CELLS), and, when those walls are thinner than MF_VESSEL_THICK_CELLS
 *          (e.g. a 64^3 grid), carved again with walls of that many cells (dmtet from the hull:
 *          the opening is the hull's, the hull is carved on its own grid as vhull carves it, and
 *          the fitted SDF, interpolated onto that grid when it is another, is cut by each carved
 *          hull's signed distance; every candidate is extracted there); writes them to
 *          <out>/geometry/<source>-closed.obj, -open.obj and -open-thick.obj, and
 *          mf_recon_geom_vessel_choose fits each (but a carved one whose walls broke through:
 *          its Euler characteristic more than MF_VESSEL_MAX_EULER_DROP below the closed one's)
 *          for a quarter of the run's iterations with every 8th training view held out; the carved mesh with the higher held-out PSNR becomes
 *          geometry/<source>.obj only when it beats the closed one by more than
 *          MF_VESSEL_MARGIN_DB. open carves (the stated wall) without the test, closed never
 *          carves. run.json's geometry_result.vessel records the axis, the walls, the trial PSNRs
 *          and the choice.
 * One folder, one run: once the mesh is read or built, what an earlier run with another source
 * left in out_dir (geometry/vhull*.obj; geometry/dmtet*.obj, dmtet_state.mfck and geom_log.csv) is removed, with a
 * log line each, so the folder never mixes two runs' geometry; the given mesh itself is never
 * removed (--mesh may name an earlier run's hull). The source's own files stay (rewritten, or
 * reused by resume). With resume, another source's files are refused instead (MF_EARG naming
 * the file, before anything is built): a resumed run continues one run.
 * The options are a declarative table (mf_recon_geom_opt_table, mf_recon_opts.c). */
#ifndef MF_RECON_GEOM_H
#define MF_RECON_GEOM_H

#include <cJSON.h>

#include "core/mf_fs.h"
#include "geom/mf_uvatlas.h"
#include "geom/mf_vessel.h"
#include "geom/mf_vhull.h"
#include "inverse/mf_recon.h"
#include "io/mf_image.h"
#include "scene/mf_camera.h"
#include "scene/mf_mesh.h"

/* DMTet's starting SDF: the soft hull's mask - 0.5 on its grid (in cell units), or the signed
 * distance to the visual hull mesh vhull builds (mf_meshsdf, within MF_DMTET_INIT_BAND cells). */
typedef enum { MF_DMTET_INIT_SOFT, MF_DMTET_INIT_HULL } MfDmtetInit;
#define MF_DMTET_INITS "soft|hull"
#define MF_DMTET_INIT_BAND 4.0f
/* The soft start's grid when dmtet_res is 0 (the hull start's is hull_res). */
#define MF_DMTET_SOFT_RES 64

/* --vessel auto's meshes: closed, open, open-thick */
#define MF_VESSEL_MESHES 3

typedef struct {
    const char *geometry;     /* "given" | "vhull" | "dmtet"; NULL: given when a mesh exists, else vhull */
    int hull_res;             /* MfHullOpts, prefixed (mf recon's --res is the training width) */
    float hull_extent;
    int hull_smooth;
    int hull_target_tris;
    float hull_min_component;
    int dmtet_res;            /* dmtet: grid cubes per axis (0: the start's: hull_res from the hull, MF_DMTET_SOFT_RES from soft) */
    int dmtet_init;           /* dmtet: MfDmtetInit, the SDF's start */
    int dmtet_smooth;         /* dmtet: Taubin iterations of the extracted mesh (-1: 100 (res/hull_res)^2 from
                                 the hull, 100 (res/64)^2 from soft; hull_smooth is the hull's) */
    int geom_iters;           /* dmtet: Adam steps of the mask term */
    int geom_views;           /* dmtet: views per step (0: all) */
    float geom_lr;            /* dmtet: SDF learning rate, in grid cells per step */
    float geom_sdf_reg;       /* dmtet: weight of the sign-change regulariser */
    float geom_color;         /* dmtet: weight of the colour term (mf_geom_fit.h; 0: masks only) */
    int geom_seed;            /* dmtet: the colour term's Monte Carlo seed */
    int vessel;               /* vhull, dmtet: MfVesselMode (mf_vessel.h) */
    float vessel_wall;        /* the carved mesh's wall, x the hull's largest side */
    int vessel_trial_iters;   /* auto: iterations of each trial fit (-1: a quarter of the run's) */
} MfReconGeomOpts;

/* The defaults, from the option table. */
MfReconGeomOpts mf_recon_geom_opts_default(void);

/* What was built (vhull) or read (given). */
typedef struct {
    const char *source;          /* "given" | "vhull" | "dmtet": the resolved choice (static string) */
    char mesh_path[MF_PATH_MAX]; /* the mesh optimised on */
    int reused;                  /* vhull/dmtet with resume: geometry/<source>.obj was reused */
    double hull_s, unwrap_s;     /* wall seconds (0 when reused or given) */
    MfHullInfo hull;             /* vhull, built: the hull's report; dmtet, built: masked_views, extent
                                    (the grid's side after enlarging) and touches_border */
    int hull_tris;               /* vhull: triangles of the unwrapped hull */
    MfUvAtlasInfo atlas;         /* vhull, built: the unwrap's report */
    double geom_s;               /* dmtet, built: wall s of this process's mask-term steps */
    double step_ms;              /* dmtet, built: mean wall ms per step of this process */
    double rebuild_share;        /* dmtet, built: the share of geom_s spent extracting the mesh and building its
                                    Embree scene (issue 14's "rebuild share") */
    int steps;                   /* dmtet, built: steps taken */
    int resumed_at;              /* dmtet, built: steps its state file held (resume; 0: started afresh) */
    double loss_first, loss_last;/* dmtet, built: mask loss of the first and last step */
    double rgb_first, rgb_last;  /* dmtet, built: the colour term's logl1 of the first and last step (0 without it) */
    int dropped_components;      /* dmtet, built: components dropped by the clean-up */
    int dmtet_res;               /* dmtet, built: the grid's resolution (dmtet_res resolved) */
    int smooth_iters;            /* dmtet, built: Taubin iterations used (dmtet_smooth resolved) */
    MfVesselAxis vessel;         /* vhull/dmtet, built, --vessel auto|open: the opening found (candidate 0: none) */
    int vessel_n;                /* meshes made with a candidate: 2 (closed, open) or 3 (and open-thick) */
    size_t vessel_carved[2];     /* grid vertices each carved mesh removed: open, open-thick */
    float vessel_wall_cells[2];  /* their walls, in grid cells (0: not made) */
    long vessel_euler[MF_VESSEL_MESHES]; /* V - E + F of the closed, open and open-thick clean meshes, before
                                            smoothing and decimation (mf_vhull_extract_clean) */
    int vessel_pending;          /* auto with a candidate: the meshes written, mf_recon_geom_vessel_choose to choose */
    double vessel_psnr[MF_VESSEL_MESHES]; /* auto: held-out PSNR of each trial fit (closed, open, open-thick);
                                             NAN: not tried (its walls broke through, MF_VESSEL_MAX_EULER_DROP) */
    int vessel_trial_iters;      /* auto: iterations of each trial fit (resolved) */
    const char *vessel_chosen;   /* "closed" | "open" | "open-thick" once decided; NULL: no candidate, or --vessel closed */
} MfReconGeomInfo;

/* Resolves o->geometry into *source ("given", "vhull" or "dmtet"): NULL means given when
 * mesh_exists, else vhull (logged). */
int mf_recon_geom_resolve(const MfReconGeomOpts *o, int mesh_exists, const char **source);

/* --vertex-lr's default (-1) resolved for a mesh from *source: 0 (fixed) for a given mesh or with a
 * normal map; on a recovered one (vhull, dmtet) MF_RECON_GEOM_VERTEX_LR x the mesh's largest
 * bounding-box side. The rate was chosen on val-3d's hulls (extent 1) and measured on test-3d
 * (reports/bench/geometry-vertices: relit +0.27 dB, 9/9 scenes, p 0.011). */
#define MF_RECON_GEOM_VERTEX_LR 2e-5f
float mf_recon_geom_vertex_lr(const char *source, const MfMesh *mesh, int normal_map);

/* --normal-smooth's default (-1) resolved for a mesh from source: 0 for a given mesh (its normals
 * are the asset's), MF_RECON_GEOM_NORMAL_SMOOTH on a recovered one, whose marching-tets facets
 * leave high-frequency noise in the area-weighted normals (docs/analyses/normal-smoothing.md). */
#define MF_RECON_GEOM_NORMAL_SMOOTH 5
int mf_recon_geom_normal_smooth(const char *source);

/* The mesh to optimise on, into *mesh (with UVs), per *source (mf_recon_geom_resolve):
 * given reads given_path; vhull builds from cams (n,) and masks (n,) (last channel = mask, sizes
 * matching the cameras) and writes out_dir/geometry/vhull.obj (reused with resume). tex_res: the
 * run's texture side (the unwrap's gutter is counted in its texels). On success, the other
 * sources' outputs in out_dir are removed (above; with resume, refused); MF_EIO when one
 * cannot be removed. */
int mf_recon_geom_mesh(const MfReconGeomOpts *o, const char *source, const char *given_path, const MfCamera *cams,
                       const MfImage *masks, int n, int tex_res, const char *out_dir, int resume, MfMesh *mesh,
                       MfReconGeomInfo *info);

/* --vessel auto with a candidate opening (info->vessel_pending): mf_recon_geom_mesh wrote the
 * closed mesh to geometry/<source>-closed.obj (it is in *mesh), the carved ones to
 * geometry/<source>-open.obj (and -open-thick.obj: info->vessel_n 3), and left
 * geometry/<source>.obj unwritten. This fits each (not a carved one with broken walls,
 * MF_VESSEL_MAX_EULER_DROP) for o->vessel_trial_iters iterations (-1:
 * ro->iters / 4, at least 1) with the run's options ro (no prior term) and views 0, 8, 16, ...
 * held out (ro's early_stop hold-out; the fits' files, under geometry/trial-*, are removed), keeps
 * the carved mesh with the higher held-out PSNR only when it beats the closed one's by more than
 * MF_VESSEL_MARGIN_DB, writes the chosen mesh to geometry/<source>.obj and puts it in *mesh, so
 * a resumed run reuses it. Nothing to do (MF_OK) when no choice is pending. views: (nviews,), as
 * mf_recon_new takes them (they are copied, not moved). */
int mf_recon_geom_vessel_choose(const MfReconGeomOpts *o, MfReconGeomInfo *info, const MfReconView *views, int nviews,
                                const MfReconOpts *ro, const char *out_dir, MfMesh *mesh);

/* run.json: geometry source, mesh path, hull_s, unwrap_s, reuse, the hull/unwrap reports and
 * (dmtet) geom_s, step_ms, steps, first/last mask loss. */
void mf_recon_geom_to_json(const MfReconGeomInfo *info, cJSON *obj);

#endif
