/* Shared helper of the reconstruction tests (test_inverse_recon.c, test_inverse_budget.c,
 * test_fusion_sds.c; header-only).
 *
 * ref_view: view->cam (res x res px, see look_cam) at eye looking at the origin, and view->ref
 *           (res x res x 4) the forward render of in from it: rgb, then alpha.
 * first_diff_block: the name of the first parameter block whose size or bits differ between two
 *           reconstructions (NULL: all the same; resume and reproducibility checks). */
#ifndef MF_TEST_RECON_H
#define MF_TEST_RECON_H

#include <string.h>

#include "inverse/mf_recon.h"
#include "mf_test_geom.h"
#include "render/mf_integrator.h"

static inline int ref_view(const MfRenderInput *in, const MfRenderOpts *ro, int res, MfVec3 eye, MfReconView *view) {
    int rc = look_cam(&view->cam, res, res, eye, mf_v3(0, 0, 0));
    MfRenderOut out;
    if (rc || (rc = mf_render(in, &view->cam, ro, &out, NULL))) return rc;
    if (!(rc = mf_image_alloc(&view->ref, res, res, 4)))
        for (int i = 0; i < res * res; ++i) {
            for (int c = 0; c < 3; ++c) view->ref.data[4 * i + c] = out.rgb[3 * i + c];
            view->ref.data[4 * i + 3] = out.alpha[i];
        }
    mf_render_out_free(&out);
    return rc;
}

static inline const char *first_diff_block(MfRecon *a, MfRecon *b) {
    for (int k = 0; k < MF_NBLOCKS; ++k) {
        const MfParamBlock *x = mf_recon_block(a, k), *y = mf_recon_block(b, k);
        if (x->n != y->n || (x->n && memcmp(x->p, y->p, x->n * sizeof(float)))) return x->name;
    }
    return NULL;
}

#endif
