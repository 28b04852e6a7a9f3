/* mf_meshsdf: a closed mesh's signed distance on an mf_tetgrid grid.
 *
 * DMTet's SDF can start from the visual hull mesh (mf recon --dmtet-init hull) instead of the soft
 * hull's mask - 0.5, whose values saturate within a pixel of the silhouette: marching tets on a
 * field that is a distance places the surface to a fraction of a cell, so a 64^3 grid keeps what
 * the 128^3 hull resolved. */
#ifndef MF_MESHSDF_H
#define MF_MESHSDF_H

#include "geom/mf_tetgrid.h"
#include "scene/mf_mesh.h"

/* sdf: (mf_tetgrid_nverts(g),) output, > 0 inside (mf_tetgrid's sign), in world units. Within
 * band_cells cells of m (closed, outward-wound, as mf_vhull_extract_clean gives it): the distance
 * to the nearest point of m; farther, +-band_cells cells. The sign: within MF_MESHSDF_SHELL cells
 * of m, the nearest feature's angle-weighted pseudonormal (face, edge or corner; exact on a closed
 * mesh that does not cross itself); beyond, one per connected region of such vertices (the shell
 * separates inside from outside), the sign most of the region's vertices have: the nearest
 * feature's within the band, far_sign's (nverts,) (> 0 inside; e.g. the soft hull on g) beyond
 * it. A decimated hull need not be free of self-crossings (on a 24^3 test grid a band vertex 3
 * cells out came out inside, an island), and a coarse field keeps stray inside vertices (a floater
 * the mesh dropped); the regions overrule both. Ties between triangles go to the lower index, so
 * the result is deterministic (and the same for any thread count). far_sign may be sdf itself
 * (only vertices beyond the band read it). MF_EARG on an empty mesh or band_cells <= 0; MF_ENOMEM. */
#define MF_MESHSDF_SHELL 1.5f
int mf_meshsdf_grid(const MfTetGrid *g, const MfMesh *m, const float *far_sign, float band_cells, float *sdf);

#endif
