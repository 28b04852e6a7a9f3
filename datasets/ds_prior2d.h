/* ds_prior2d: reading the 2D splits (prior-train, test-2d; written by ds_gen.h). Layout:
 *   DIR/{rgb,albedo,orm}/NNNNNN.png   sample i (6 digits), RGBA 8-bit: rgb and albedo sRGB, orm
 *                                     linear, alpha = coverage
 *   DIR/manifest.json                 "count", "resolution", "seed", "views_per_object" (the views
 *                                     of an object consecutive), written last
 * One place for the layout: the prior's training (mf_prior_train), the 2D table (ev_prior2d) and
 * the Train-mean ORM baseline's fit (mf eval-prior) read through it. */
#ifndef DS_PRIOR2D_H
#define DS_PRIOR2D_H

#include <limits.h>
#include <stddef.h>
#include <stdint.h>

#include "core/mf_fs.h"
#include "io/mf_image.h"

/* The three image kinds, in the order the trainer stores them. */
enum { DS_P2_ALBEDO, DS_P2_ORM, DS_P2_RGB, DS_P2_NKIND };
extern const char *const ds_prior2d_kinds[DS_P2_NKIND]; /* "albedo", "orm", "rgb" */

/* DIR/<kind>/NNNNNN.png of sample i into path (cap bytes). */
int ds_prior2d_path(const char *dir, const char *kind, int i, char *path, size_t cap);
/* Reads sample i's image of one kind with the given encoding; refuses a non-RGBA image. */
int ds_prior2d_read(const char *dir, const char *kind, int i, MfEncoding enc, MfImage *out);
/* Samples 0, 1, ... whose three images all exist, counted up to max (max < 0: no limit). */
int ds_prior2d_complete(const char *dir, int max);

#define DS_P2_ABSENT INT_MIN

typedef struct {
    char path[MF_PATH_MAX]; /* DIR/manifest.json */
    int present;            /* the file exists */
    int count, resolution, views_per_object; /* DS_P2_ABSENT where absent or not a number */
    uint64_t seed;                           /* 0 where absent */
} DsPrior2dManifest;

/* Reads DIR/manifest.json's keys into m. A missing file is an error only when required (then the
 * message names it); an unparsable one leaves every key absent. */
int ds_prior2d_manifest(const char *dir, int required, DsPrior2dManifest *m);

#endif
