/* mf_tetgrid: a cube grid split into tetrahedra, and marching tets (forward and adjoint).
 *
 * The grid has res cubes per axis, (res+1)^3 vertices at lo + cell * (i, j, k), vertex index
 * i + (res+1) * (j + (res+1) * k). Each cube is cut into 6 tets (Kuhn / Freudenthal split along
 * the cube's diagonal from corner (0,0,0) to (1,1,1)), so neighbouring cubes share faces
 * exactly and every tet edge runs from a grid vertex v to v + e with e in {0,1}^3 \ {0}.
 *
 * Field convention: sdf > 0 is INSIDE the object, sdf <= 0 outside (DMTet's occupancy sign).
 * Optional deformation (DMTet): vertex v sits at base(v) + (cell / 2) * tanh(deform[v]), i.e.
 * at most half a cell away (2 / (2 res) * tanh(d) for a grid spanning [-1, 1]).
 *
 * Marching tets puts one output vertex on each tet edge whose ends differ in sign, at
 * p = (1 - t) p_a + t p_b with t = f_a / (f_a - f_b); edges are shared between tets, so the mesh
 * is watertight. Triangles are wound counter-clockwise seen from outside (normals point out).
 * Each output vertex keeps its edge (a, b) and t, which is all the adjoint needs. */
#ifndef MF_TETGRID_H
#define MF_TETGRID_H

#include <stdint.h>

#include "core/mf_math.h"
#include "scene/mf_mesh.h"

typedef struct {
    int res;     /* cubes per axis (>= 1) */
    MfVec3 lo;   /* position of vertex (0, 0, 0) */
    float cell;  /* cube edge length */
} MfTetGrid;

typedef struct {
    MfMesh mesh;     /* owned; pos (nv, 3) and tri (nt, 3); no normals or UVs */
    int32_t *edge;   /* owned; (nv, 2) grid vertex indices a, b of the tet edge */
    float *t;        /* owned; (nv,) weight: p = (1 - t) p_a + t p_b */
} MfTetMesh;

/* A grid of res cubes per axis whose cube [lo, lo + extent]^3 is centred at c. */
MfTetGrid mf_tetgrid_make(int res, MfVec3 c, float extent);
/* Number of grid vertices, (res + 1)^3. */
size_t mf_tetgrid_nverts(const MfTetGrid *g);
/* Undeformed position of grid vertex v. */
MfVec3 mf_tetgrid_base(const MfTetGrid *g, size_t v);

/* The trilinear interpolation of field (nv,) at p; outside (a value) beyond the grid. */
float mf_tetgrid_sample(const MfTetGrid *g, const float *field, MfVec3 p, float outside);

/* Marching tets. sdf: (nv,) grid values; deform: (nv, 3) or NULL. Fails with MF_EARG
 * ("marching tets: the field has no zero crossing (empty grid)") when no edge changes sign,
 * and MF_ENAN on a non-finite value; out is untouched on failure. */
int mf_tetgrid_extract(const MfTetGrid *g, const float *sdf, const float *deform, MfTetMesh *out);
/* Adjoint of mf_tetgrid_extract for the mesh it returned: given dpos (nv_out, 3) = dL/dp,
 * ACCUMULATES (+=) dL/dsdf into dsdf (nv,) and, when deform and ddeform are non-NULL,
 * dL/ddeform into ddeform (nv, 3). Serial, so deterministic. */
void mf_tetgrid_backward(const MfTetGrid *g, const float *sdf, const float *deform, const MfTetMesh *m,
                         const float *dpos, float *dsdf, float *ddeform);
void mf_tetmesh_free(MfTetMesh *m);

#endif
