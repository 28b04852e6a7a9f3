/* mf_mesh: indexed triangle meshes with UVs, in world units.
 *
 * Vertices carry position, optional normal and optional UV (OBJ's separate v/vt/vn indices are
 * unified on load). UV convention: OBJ/glTF-style u right, v up (v = 0 is the bottom row of a
 * texture image). Triangles may carry a material id (OBJ usemtl order). */
#ifndef MF_MESH_H
#define MF_MESH_H

#include <stdint.h>
#include <stddef.h>

#include "core/mf_math.h"

typedef struct {
    int nv, nt;
    float *pos;    /* owned; (nv, 3) */
    float *nrm;    /* owned; (nv, 3) unit, or NULL (then face normals are used) */
    float *uv;     /* owned; (nv, 2), or NULL */
    uint32_t *tri; /* owned; (nt, 3) vertex indices */
    int *mat;      /* owned; (nt,) material id, or NULL */
    int nmat;
    char **mat_names; /* owned; (nmat,) strings, or NULL */
} MfMesh;

int mf_mesh_alloc(MfMesh *m, int nv, int nt, int with_nrm, int with_uv);
void mf_mesh_free(MfMesh *m);
/* Area-weighted smooth vertex normals (allocates nrm if NULL). */
int mf_mesh_compute_normals(MfMesh *m);
/* Adjoint of mf_mesh_compute_normals at m's positions: dpos (nv, 3) += from dnrm (nv, 3),
 * dLoss/d(the unit normals). Serial, deterministic. */
int mf_mesh_normals_backward(const MfMesh *m, const float *dnrm, float *dpos);
/* Smooths the unit vertex normals over the 1-rings, iters times: each vertex's normal becomes the
 * normalised sum of itself and, per triangle at it, its two other corners' normals (an edge
 * inside the mesh counts twice), leaving out a neighbour whose normal is more than acos(min_cos)
 * from its own (creases stay sharp). hist (iters, nv, 3), or NULL, keeps each iteration's input
 * for the backward. min_cos must lie in [0, 1] (else MF_EARG), so each sum is at least the unit
 * normal itself and never vanishes. Serial, deterministic. */
int mf_mesh_smooth_normals(MfMesh *m, int iters, float min_cos, float *hist);
/* Adjoint of mf_mesh_smooth_normals (same m, iters, min_cos and its hist): dnrm (nv, 3), dLoss/d
 * the smoothed normals, becomes dLoss/d the normals before smoothing, in place. The neighbour
 * choice is held fixed (exact wherever no normal pair sits on the threshold). */
int mf_mesh_smooth_normals_backward(const MfMesh *m, int iters, float min_cos, const float *hist, float *dnrm);
/* Axis-aligned bounds. */
void mf_mesh_bounds(const MfMesh *m, MfVec3 *lo, MfVec3 *hi);
/* Counts triangles with area below eps (degenerate). */
int mf_mesh_count_degenerate(const MfMesh *m, float eps);
/* Centres at the origin and scales so the largest extent is `extent`. */
void mf_mesh_normalize(MfMesh *m, float extent);
/* A UV sphere (latitude-longitude tessellation) of nu x nv quads, centre c, radius r, with unit
 * normals and UVs (u = longitude / 2pi, v = 1 - colatitude / pi, +Z pole at v = 1). */
int mf_mesh_uv_sphere(MfMesh *m, int nu, int nv, MfVec3 c, float r);
/* Copies src's per-triangle material ids, nmat and material names into dst, whose triangles are
 * src's in the same order (dst's material fields empty before). */
int mf_mesh_copy_materials(MfMesh *dst, const MfMesh *src);
/* Appends b to a (material ids of b offset by a->nmat). */
int mf_mesh_append(MfMesh *a, const MfMesh *b);

#endif
