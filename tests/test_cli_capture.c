/* A capture as users have them, end to end through the `mf` command (MF_BIN; issue 15 item 5):
 * `mf gen --layout ingp` writes an instant-ngp capture whose lens differs from camera_angle_x,
 * `mf recon` reconstructs it on its given mesh, `mf eval` scores its held-out frames as novel views
 * under the training light and says so; with --distortion the capture is refused by key. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "eval/ev_table.h"
#include "mf_test.h"

#pragma GCC diagnostic ignored "-Wformat-truncation"

MF_TEST(cli_capture_ingp_recon_eval) {
    const char *mf = getenv("MF_BIN");
    if (!mf || !mf_file_exists(mf)) MF_SKIP("MF_BIN not set (run through make test)");
    char cap[1024], res[1024], rep[1024], args[4096], err[16384];
    snprintf(cap, sizeof cap, "%s", mf_test_path("cli_cap/cap"));
    snprintf(res, sizeof res, "%s", mf_test_path("cli_cap/results"));
    snprintf(rep, sizeof rep, "%s", mf_test_path("cli_cap/report"));
    snprintf(args, sizeof args, "gen -o %s --layout ingp --views 16 --width 32 --tex-res 64 --spp 2 --seed 3", cap);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    snprintf(args, sizeof args, "recon %s -o %s/nvdiffrecmc/cap --iters 30 --tex-res 32 --env-w 16 --env-h 8", cap, res);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    CHECK_MSG(strstr(err, "14 views 32x24"), "recon did not train on the 14 non-held-out 32x24 frames: %s", err);
    snprintf(args, sizeof args, "eval %s --results %s -o %s --no-curves", cap, res, rep);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    CHECK_MSG(strstr(err, "scored 2 held-out test views under the training light") && strstr(err, "nv_psnr"),
              "mf eval does not say it scored novel views: %s", err);
    char csv[1100];
    snprintf(csv, sizeof csv, "%s/scenes.csv", rep);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, csv));
    EvStat nv = ev_table_stat(&t, "nvdiffrecmc", "cli_cap", "nv_psnr");
    printf("    nv_psnr %.2f dB (n %d)\n", nv.mean, nv.n);
    /* Measured 26.58 dB at this budget; the threshold is well below it but above what a wrong
     * camera gives (the reader forced to camera_angle_x's lens: see notes/ingp.md). */
    CHECK_MSG(nv.n == 1 && nv.mean > 22.0, "nv_psnr %.2f (n %d)", nv.mean, nv.n);
    CHECK(ev_table_stat(&t, "nvdiffrecmc", "cli_cap", "nv_ssim").n == 1 && ev_table_stat(&t, "nvdiffrecmc", "cli_cap", "nv_flip").n == 1);
    CHECK(ev_table_stat(&t, "nvdiffrecmc", "cli_cap", "relit_psnr").n == 0);
    ev_table_free(&t);
    snprintf(csv, sizeof csv, "%s/novelview.md", rep);
    CHECK_MSG(mf_file_exists(csv), "%s missing", csv);
    /* distortion: written by gen, refused by name by recon */
    snprintf(cap, sizeof cap, "%s", mf_test_path("cli_cap/cap_k1"));
    snprintf(args, sizeof args, "gen -o %s --layout ingp --views 2 --width 8 --tex-res 16 --spp 1 --distortion 0.05,0,0,0", cap);
    CHECK_MSG(mf_test_run_mf(args, NULL, err, sizeof err) == 0, "mf %s: %s", args, err);
    snprintf(args, sizeof args, "recon %s -o %s/k1 --iters 1", cap, res);
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) != 0);
    CHECK_MSG(strstr(err, "cap_k1/transforms.json: k1 = 0.05: lens distortion is not supported"), "recon: %s", err);
    CHECK(!mf_file_exists(mf_test_path("cli_cap/results/k1/albedo.png")));
    /* bad options are refused by name */
    snprintf(args, sizeof args, "gen -o %s --layout ingp --distortion 0.05,0", mf_test_path("cli_cap/bad"));
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2 && strstr(err, "--distortion '0.05,0': expected 4 comma-separated"));
    snprintf(args, sizeof args, "gen -o %s --intrinsics 30,33,16,12", mf_test_path("cli_cap/bad"));
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2 && strstr(err, "--intrinsics applies to --layout ingp"));
    snprintf(args, sizeof args, "gen -o %s --layout ingp --width 32 --intrinsics 30,33,40,12", mf_test_path("cli_cap/bad"));
    CHECK(mf_test_run_mf(args, NULL, err, sizeof err) == 2 && strstr(err, "principal point (40, 12) lies outside the 32x24 image"));
    CHECK(!mf_file_exists(mf_test_path("cli_cap/bad")));
}
