/* mf_meshproc: clean-up of extracted triangle meshes (marching tets output, visual hulls).
 *
 * All functions work on positions and triangles only. Those that change the vertex set (weld,
 * drop, decimate) free the mesh's normals, UVs and material ids, which no longer apply; call
 * mf_mesh_compute_normals afterwards when normals are needed. Each is deterministic. */
#ifndef MF_MESHPROC_H
#define MF_MESHPROC_H

#include "scene/mf_mesh.h"

/* Merges each vertex into the lowest-index earlier vertex within distance eps (transitively:
 * it takes that vertex's representative, whose position is kept), then drops unused vertices.
 * eps > 0. */
int mf_mesh_weld(MfMesh *m, float eps);
/* Drops triangles with a repeated vertex or area <= area_eps, then unused vertices. */
int mf_mesh_drop_degenerate(MfMesh *m, float area_eps);
/* Drops connected components (triangles sharing vertices) with fewer than min_frac times the
 * triangles of the largest one (floaters); *dropped (optional) gets their count. */
int mf_mesh_drop_small_components(MfMesh *m, float min_frac, int *dropped);
/* Taubin lambda|mu smoothing (umbrella Laplacian, uniform weights): iters pairs of steps
 * p += lambda L(p), p += mu L(p). Typical: lambda 0.5, mu -0.53; shrinks far less than Laplacian. */
int mf_mesh_taubin(MfMesh *m, int iters, float lambda, float mu);

typedef struct {
    int boundary_edges;    /* undirected edges used by one triangle */
    int nonmanifold_edges; /* undirected edges used by more than two triangles */
    int misoriented_edges; /* edges of two triangles that traverse them in the same direction */
    int components;        /* connected components of triangles */
    long euler;            /* V - E + F over referenced vertices */
} MfManifoldInfo;
/* Counts the above; a closed, consistently oriented 2-manifold has the first three 0. */
int mf_mesh_manifold_check(const MfMesh *m, MfManifoldInfo *info);
/* 1 when boundary, non-manifold and misoriented edge counts are all 0. */
int mf_manifold_ok(const MfManifoldInfo *info);

/* Edge-collapse decimation (libmeshoptimizer's meshopt_simplify, topology-preserving) to at most
 * target_tris triangles or until the error exceeds max_error (relative to the mesh extent, e.g.
 * 0.01); unused vertices dropped. A mesh already at or below the target is left alone. */
int mf_mesh_decimate(MfMesh *m, int target_tris, float max_error);

#endif
