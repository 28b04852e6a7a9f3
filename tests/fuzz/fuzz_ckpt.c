/* Fuzz harness: checkpoint files (.mfck, mf_ckpt_load) against a fixed two-tensor table. The
 * last 8 bytes are replaced by the checksum of the rest (mf_fuzz_fix_checksum), so mutations
 * reach the header and table checks behind it. */
#include <stdlib.h>

#include "mf_fuzz.h"
#include "io/mf_ckpt.h"

MF_FUZZ(ckpt) {
    if (!mf_fuzz_dir()[0]) return 0;
    static const MfTensorSpec specs[2] = {{"w", 2, {2, 3}}, {"b", 1, {3}}};
    uint8_t *b = mf_fuzz_fix_checksum(data, size);
    const char *p = b ? mf_fuzz_write("in.mfck", b, size) : NULL;
    free(b);
    float vals[9];
    char *meta = NULL;
    if (p && mf_ckpt_load(p, specs, 2, vals, &meta) == 0) free(meta);
    return 0;
}
