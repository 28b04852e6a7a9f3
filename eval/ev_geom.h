/* ev_geom: geometry metrics between a predicted and a ground-truth mesh (issue 14).
 *
 * Chamfer as Stanford-ORB defines it: the GT mesh's vertices against n_samples points sampled
 * uniformly by area on the prediction (seeded); for each point of one set the squared distance
 * to the nearest point of the other set, averaged over the set; the two directions averaged,
 * and the result multiplied by 1e3 (units of the data set, object extent 1 for ours).
 * Normal error: for the same nearest pairs, the angle between the GT vertex normal (area-weighted,
 * shared by all vertices at one position, so UV seams do not split it) and the prediction's face normal at the sample, averaged over both
 * directions, in degrees; also Stanford-ORB's 1 - cos.
 * Uniform Chamfer: the same formula with n_samples area samples of the GT mesh in place of its
 * vertices (independent of the prediction's samples: another stream of the same seed), so a GT
 * mesh with uneven vertex density does not weight its dense parts more. Its floor for two copies
 * of one smooth surface of area A is about A / (pi n_samples) x 1e3 (the mean squared distance to
 * the nearest of n points spread uniformly: 1 / (pi density)), e.g. 0.021 for a sphere of radius
 * 0.4 at 30000 samples. Nearest neighbours by a kd-tree (exact). */
#ifndef EV_GEOM_H
#define EV_GEOM_H

#include <stdint.h>

#include "scene/mf_camera.h"
#include "scene/mf_mesh.h"

typedef struct {
    double chamfer;        /* x 1e3: (gt_to_pred + pred_to_gt) / 2 */
    double gt_to_pred;     /* mean squared nearest distance, GT vertices -> samples (x 1e3) */
    double pred_to_gt;     /* samples -> GT vertices (x 1e3) */
    double chamfer_uniform; /* x 1e3: GT area samples <-> prediction area samples, both ways averaged */
    double normal_deg;     /* mean angle, degrees */
    double normal_1mcos;   /* mean 1 - cos */
    int n_gt, n_pred;
} EvGeomScore;

/* Scores pred against gt (n_samples area samples of pred; Stanford-ORB uses 30000; seed picks
 * them). Fails with MF_EARG when either mesh has no triangles of positive area. */
int ev_geom_score(const MfMesh *gt, const MfMesh *pred, int n_samples, uint64_t seed, EvGeomScore *out);

/* n points (n, 3) uniformly by area on m's triangles into pts, and the face normal of each point's
 * triangle into nrm (n, 3; NULL: not wanted); deterministic in (seed, stream). ev_geom_score
 * samples the prediction with stream EV_GEOM_STREAM_PRED and the GT (uniform Chamfer) with
 * EV_GEOM_STREAM_GT. Fails with MF_EARG when m has no area. */
enum { EV_GEOM_STREAM_PRED = 14, EV_GEOM_STREAM_GT = 15 };
int ev_geom_sample(const MfMesh *m, int n, uint64_t seed, uint64_t stream, float *pts, float *nrm);

/* Image-space comparison over views, as Stanford-ORB scores normals (on rendered normal maps):
 * one ray per pixel centre against each mesh; where both are hit, the angle between their
 * shading normals (interpolated vertex normals when the mesh has them, else face normals; both on
 * the viewer's side) averaged over those pixels, in degrees and as 1 - cos; and the mask IoU
 * (pixels hit by both / hit by either). Hidden surfaces (a cup's inner wall seen from outside)
 * do not count, unlike ev_geom_score's point pairs. */
typedef struct {
    double normal_deg, normal_1mcos, mask_iou;
    long pixels; /* pixels hit by both */
} EvGeomViews;
int ev_geom_views(const MfMesh *gt, const MfMesh *pred, const MfCamera *cams, int n, EvGeomViews *out);

/* Exact nearest neighbours: for each of the nq query points (nq, 3) the index of the nearest of
 * the np points (np, 3) into nn (nq,) and its squared distance into d2 (nq,). np >= 1. */
int ev_nearest(const float *pts, int np, const float *q, int nq, int *nn, double *d2);

#endif
