/* mf recon's warning for --spp 1 without the denoiser (measured in reports/adaptive/ to lose
 * 3-5 dB relit PSNR): present at --spp 1, absent at --spp 2 and at --spp 1 with --denoise 1. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_fs.h"
#include "datasets/ds_split.h"
#include "mf_test.h"

MF_TEST(recon_warns_spp1) {
    MF_NEED_BIN();
    const char *mf = getenv("MF_BIN");
    if (!mf_file_exists(DS_DEFAULT_ENV_DIR "/studio.exr")) MF_SKIP("blender-data probes not installed (" DS_DEFAULT_ENV_DIR ")");
    char d[1024], err[8192], args[4096];
    mf_test_path_to(d, sizeof d, "recon_warn");
    CHECK(mf_test_sh("%s gen --split tiny --scenes 1 -o %s 2>/dev/null", mf, d) == 0);
    static const struct {
        const char *flags;
        int warns;
    } k_case[] = {{"--spp 1", 1}, {"--spp 2", 0}, {"--spp 1 --denoise 1", 0}};
    for (int i = 0; i < 3; ++i) {
        snprintf(args, sizeof args, "recon %s/000_cup -o %s/out%d --iters 1 --tex-res 16 --env-w 8 --env-h 4 %s", d, d, i,
                 k_case[i].flags);
        int rc = mf_test_run_mf(args, NULL, err, sizeof err);
        CHECK_MSG(rc == 0, "%s: exit %d, '%s'", k_case[i].flags, rc, err);
        CHECK_MSG(!strstr(err, "--spp 1 (one light") == !k_case[i].warns, "%s: warning %s expected: '%s'", k_case[i].flags,
                  k_case[i].warns ? "" : "not", err);
    }
}
