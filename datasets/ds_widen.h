/* ds_widen: the widened prior-train recipe (issue 12, "a prior that generalises") and the content
 * hold-out of the generalisation matrix.
 *
 * Content hold-out: shape families DS_FAM_SUPERQUADRIC and DS_FAM_DISPLACED and the material
 * recipes "rubber" (class DS_MAT_RUBBER) and "checker" (pattern DS_PAT_CHECKER) are never in a
 * widened prior-train split; the test-2d content splits take only objects with (heldout) or
 * without (train) any of them.
 *
 * Widening, all draws from the object seed through streams of their own (ds_widen_* below), so
 * the standard recipe's bytes are unchanged:
 *   per object: camera field of view uniform in [DS_WIDEN_FOV_MIN, DS_WIDEN_FOV_MAX] rad with
 *     the distance scaled to keep the framing (x U(0.85, 1.25)); with probability
 *     DS_WIDEN_POV_FRAC the object is made diffuse and its lit views rendered by POV-Ray (the
 *     second renderer); with probability DS_WIDEN_OVERLAY_FRAC a UV-space pattern is painted over
 *     kd (discs, or "mixed": stripes at a random angle plus discs), some of them also changing
 *     roughness;
 *   per view (the lit image only; GT albedo/ORM untouched): exposure 2^U(-2, 2); a tone curve
 *     (1/2 the plain sRGB clip, 1/4 Reinhard with white point U(2, 8), 1/4 the ACES filmic fit
 *     of Narkowicz 2015) and gamma U(0.9, 1.1) on the display value; with probability 0.3 a
 *     resolution drop (2x2 box down, bilinear up); with probability 0.5 Gaussian noise of sigma
 *     U(0.003, 0.03) on the display value. */
#ifndef DS_WIDEN_H
#define DS_WIDEN_H

#include <stdint.h>

#include "datasets/ds_cameras.h"
#include "datasets/ds_shapes.h"

#define DS_WIDEN_FOV_MIN 0.45f
#define DS_WIDEN_FOV_MAX 1.0f
#define DS_WIDEN_POV_FRAC 0.10f
#define DS_WIDEN_OVERLAY_FRAC 0.30f

typedef enum { DS_CONTENT_ALL = 0, DS_CONTENT_TRAIN = 1, DS_CONTENT_HELDOUT = 2 } DsContent;
/* "all", "train", "heldout" -> content; -1 for another name. */
int ds_content_from_name(const char *name);
const char *ds_content_name(DsContent c);
/* Family held out of widened training. */
int ds_family_heldout(DsFamily f);
/* 1 when the object has a held-out family, or a part of a held-out class or pattern. */
int ds_object_heldout(const DsObject *o);
/* Whether an object passes the content filter. */
int ds_content_accepts(DsContent c, const DsObject *o);

typedef struct {
    int povray;      /* diffuse, lit views by POV-Ray */
    int overlay;     /* 0 none, 1 discs, 2 mixed */
    float fov_scale; /* camera_angle_x = DS_CAMERA_ANGLE_X * fov_scale */
    float dist_scale;
} DsWidenObject;

DsWidenObject ds_widen_object(uint64_t oseed);
/* The widened camera sampling of an object (field of view and distance). */
DsCamSampling ds_widen_cameras(const DsWidenObject *w);
/* Paints the object's UV overlay into kd (and roughness of orm); no-op when overlay is 0. */
void ds_widen_overlay(const DsWidenObject *w, uint64_t oseed, DsObject *o);

typedef struct {
    float exposure;  /* linear factor */
    int tone;        /* 0 sRGB clip, 1 Reinhard, 2 ACES fit */
    float white;     /* Reinhard white point */
    float gamma;     /* applied to the display value */
    int lowres;      /* 2x2 box down, bilinear up */
    float noise;     /* sigma on the display value (0: none) */
    uint64_t seed;   /* noise stream */
} DsWidenView;

DsWidenView ds_widen_view(uint64_t oseed, int v);
/* Applies the view's augmentation in place to rgb (res*res, rs floats per pixel, first 3 used,
 * linear, premultiplied by alpha (as floats, stride as)); the result stays linear premultiplied
 * and is meant for an 8-bit sRGB writer. Returns MF_ENOMEM or MF_OK. */
int ds_widen_apply(const DsWidenView *a, float *rgb, int rs, const float *alpha, int as, int res);

#endif
