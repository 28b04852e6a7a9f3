/* Fuzz harness: prior weight files (mf_prior_load: meta JSON with the model configuration, then
 * the tensors). The checksum is fixed up as in fuzz_ckpt.c, so the configuration in the meta
 * text is what the mutations reach. */
#include <stdlib.h>

#include "mf_fuzz.h"
#include "prior/mf_prior.h"

MF_FUZZ(prior) {
    if (!mf_fuzz_dir()[0]) return 0;
    uint8_t *b = mf_fuzz_fix_checksum(data, size);
    const char *p = b ? mf_fuzz_write("prior.mfck", b, size) : NULL;
    free(b);
    MfPrior *pr = NULL;
    if (p && mf_prior_load(p, &pr) == 0) mf_prior_free(pr);
    return 0;
}
