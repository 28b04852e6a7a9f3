/* ev_domain: the generalisation matrix of the 2D prior (issue 12, Deliver item 1), renderer axis.
 *
 * Input: one `mf eval-prior` record file (OUT/table2d.csv: method,dataset,scene,metric,value, one
 * record per view) per cell of the matrix, e.g. ours-standard (test-2d), ours-diffuse (test-2d
 * --diffuse 1) and POV-Ray-diffuse (test-2d --diffuse 1 --renderer povray). Every metric there is
 * MASKED: computed inside the GT mask only (cmd_eval_prior.c: albedo aligned per channel by the
 * ratio of means inside the mask, then sRGB; ORM = roughness and metallic).
 *
 * Per cell: StableMaterial's albedo PSNR and ORM PSNR, and the best training-free albedo baseline
 * (of "Input image" and "Retinex", the one with the higher mean albedo PSNR in that cell), each as
 * the mean over views with its 95% CI (Student t, ev_table_stat), and StableMaterial - that
 * baseline paired over the cell's views (ev_paired). Per pair of cells (a, ref) whose
 * views correspond one to one (same generator seed: same objects, cameras and lights, view index
 * = scene name): the paired difference a - ref of each of those metrics over the shared views
 * (ev_paired: mean, 95% CI, wins, paired t-test p); the baseline column compares the baseline that
 * is best in ref. */
#ifndef EV_DOMAIN_H
#define EV_DOMAIN_H

#include "eval/ev_paired.h"
#include "eval/ev_table.h"

#define EV_DOMAIN_MAX_CELLS 32

typedef struct {
    const char *label; /* borrowed; row name, e.g. "POV-Ray-diffuse" (no ',' or '|') */
    const char *csv;   /* borrowed; that cell's table2d.csv */
} EvDomainCell;

typedef struct {
    EvStat sm_albedo, sm_orm, base_albedo; /* masked PSNR, mean over views and 95% CI half-width */
    char base_method[64];                  /* the best training-free albedo baseline of the cell */
    EvPaired sm_vs_base;                   /* StableMaterial - that baseline, albedo PSNR, paired over views */
} EvDomainRow;

typedef struct {
    EvPaired sm_albedo, sm_orm, base_albedo; /* a - ref over the shared views */
    char base_method[64];                    /* the baseline compared: the best in ref */
} EvDomainGap;

/* Loads every cell's records into t, method names prefixed "label|" (dataset "test-2d" kept).
 * Errors name the file; a cell without StableMaterial albedo_psnr records is refused. */
int ev_domain_load(EvTable *t, const EvDomainCell *cells, int nc);
/* The row of one cell (t as ev_domain_load fills it). MF_EARG when the cell has no records. */
int ev_domain_row(const EvTable *t, const char *label, EvDomainRow *out);
/* Paired differences a - ref. MF_EARG when no view is shared. */
int ev_domain_gap(const EvTable *t, const char *a, const char *ref, EvDomainGap *out);

/* Writes md_path (Markdown: the caption lines, the matrix table, the paired-gap table of each
 * (pairs[2k], pairs[2k+1]) = (a, ref) label pair, then the note lines) and csv_path (may be NULL:
 * kind,cell,ref,metric,method,n,mean,ci95_or_lo,hi,wins,p_t: kind "cell" = a mean with its CI
 * half-width; kind "gap" = paired method(cell) - method(ref) with ref a cell label, or, within a
 * cell, StableMaterial - the baseline named in ref), atomically. */
int ev_domain_write(const EvDomainCell *cells, int nc, const char *const *pairs, int npairs, const char *const *caption,
                    int ncaption, const char *const *notes, int nnotes, const char *md_path, const char *csv_path);

#endif
