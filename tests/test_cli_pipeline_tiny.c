/* CI regression on the tiny split: generate one scene, render it, reconstruct it with the
 * nvdiffrecmc-style baseline and with MaterialFusion (v1's committed prior weights), relight and
 * evaluate both, all through the `mf` command (MF_BIN); check the baseline's relit PSNR against a
 * threshold set from measured runs and against the trivial guesses, and that MaterialFusion's prior
 * term lifts it above the baseline by a stated margin. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "datasets/ds_split.h"
#include "eval/ev_eval.h"
#include "eval/ev_report.h"
#include "eval/ev_table.h"
#include "io/mf_image.h"
#include "mf_test.h"

MF_TEST(pipeline_tiny_baseline_and_materialfusion) {
    MF_NEED_BIN();
    const char *mf = getenv("MF_BIN");
    if (!mf_file_exists(DS_DEFAULT_ENV_DIR "/studio.exr")) MF_SKIP("blender-data probes not installed (" DS_DEFAULT_ENV_DIR ")");
    const char *d = mf_test_path("pipeline_tiny");
    CHECK(mf_test_sh("%s gen --split tiny -o %s --no-render 2>/dev/null", mf, d) == 0); /* images via the render JSONs below */
    char scene[1024];
    snprintf(scene, sizeof scene, "%s/000_cup", d);
    CHECK_MSG(mf_file_exists(scene), "%s missing", scene);
    /* render train, test and relit views from the scene's render JSONs */
    CHECK(mf_test_sh("cd %s && for j in render_*.json; do n=${j#render_}; n=${n%%.json}; case $n in relight_*) o=relight/${n#relight_};; "
             "*) o=$n;; esac; %s render $j -o $o --png 2>/dev/null || exit 1; done", scene, mf) == 0);
    char res[1024], rep[1024], csv[1100];
    snprintf(res, sizeof res, "%s/results", d);
    snprintf(rep, sizeof rep, "%s/report", d);
    CHECK(mf_test_sh("%s recon %s -o %s/nvdiffrecmc/000_cup --iters 200 --tex-res 64 --env-w 32 --env-h 16 2>/dev/null", mf, scene, res) == 0);
    /* MaterialFusion, same budget, with v1's prior weights (prior.mfck), whose gain on this scene was
     * measured: this checks the SDS mechanism. The default prior (prior-ft.mfck) calls this metal
     * cup (metallic 1) less metallic: measured 17.80 dB relit, ORM 8.63 dB against the baseline's
     * 19.34 / 12.23 and v1's 22.15 / 18.03 (README "Headline results"). --sds-every 4, as measured:
     * the default (0) would refresh these 32 px views' prior term every 64 iterations. */
    CHECK(mf_test_sh("%s recon %s -o %s/materialfusion/000_cup --method materialfusion --prior-weights \"$(dirname %s)/../mf/prior/weights/prior.mfck\" "
                     "--sds-every 4 --iters 200 --tex-res 64 --env-w 32 --env-h 16 2>/dev/null",
             mf, scene, res, mf) == 0);
    CHECK(mf_test_sh("%s eval %s --results %s -o %s --dataset tiny --trivial --no-curves 2>/dev/null", mf, scene, res, rep) == 0);
    /* the report shows no machine path (everything here lies under the absolute test folder), its
     * grid has labels in the image (bands left of and above the 5 x 128 px cells), and the
     * speed-vs-error plot over every scene is there when gnuplot is */
    char p[1200], *html = NULL;
    snprintf(p, sizeof p, "%s/index.html", rep);
    CHECK_OK(mf_read_file(p, &html, NULL));
    CHECK_MSG(html && !strstr(html, mf_test_tmpdir()), "%s shows an absolute path (%s)", p, mf_test_tmpdir());
    CHECK(html && strstr(html, "<code>../000_cup</code>")); /* the data folder, relative to the report */
    free(html);
    MfImage grid = {0};
    snprintf(p, sizeof p, "%s/grid_000_cup.png", rep);
    CHECK_OK(mf_image_read(p, MF_ENC_SRGB, &grid));
    CHECK_MSG(grid.w > 5 * 128 && grid.h > 2 * 128 && grid.h % 128 != 0, "%s: %dx%d, no label bands", p, grid.w, grid.h);
    mf_image_free(&grid);
    snprintf(p, sizeof p, "%s/speed_error_scenes.png", rep);
    CHECK(!ev_gnuplot_available() || mf_file_exists(p));
    /* the result's scene.glb reads back as the result: mesh and textures (io/mf_gltf_read.h) */
    EvResult ra = {0}, rb = {0};
    snprintf(p, sizeof p, "%s/nvdiffrecmc/000_cup", res);
    CHECK_OK(ev_result_load(p, NULL, &ra));
    snprintf(p, sizeof p, "%s/nvdiffrecmc/000_cup/scene.glb", res);
    CHECK_OK(ev_result_load(p, NULL, &rb));
    CHECK(ra.mesh.nv == rb.mesh.nv && ra.mesh.nt == rb.mesh.nt && rb.has_env && rb.kd.w == ra.kd.w && rb.orm.h == ra.orm.h);
    if (ra.mesh.nv == rb.mesh.nv && ra.mesh.nt == rb.mesh.nt && rb.mesh.uv && ra.mesh.uv && rb.kd.w == ra.kd.w && rb.kd.h == ra.kd.h) {
        int bad = 0;
        for (int i = 0; i < 3 * ra.mesh.nv; ++i) bad += ra.mesh.pos[i] != rb.mesh.pos[i];
        for (int i = 0; i < 2 * ra.mesh.nv; ++i) bad += fabsf(ra.mesh.uv[i] - rb.mesh.uv[i]) > 1e-6f;
        for (int i = 0; i < 3 * ra.mesh.nt; ++i) bad += ra.mesh.tri[i] != rb.mesh.tri[i];
        for (int i = 0; i < ra.kd.w * ra.kd.h; ++i)
            for (int k = 0; k < 3; ++k)
                bad += ra.kd.data[i * ra.kd.c + k] != rb.kd.data[3 * i + k] || (k && ra.orm.data[i * ra.orm.c + k] != rb.orm.data[3 * i + k]);
        CHECK_MSG(!bad, "scene.glb differs from the result folder in %d values", bad);
    }
    ev_result_free(&ra), ev_result_free(&rb);
    /* provenance: every scored run with its exact command */
    CHECK(mf_test_sh("grep -q '| materialfusion | 000_cup | .*--method materialfusion' %s/runs.md", rep) == 0);
    /* with the prior weights MaterialFusion loaded, none for the baseline */
    CHECK(mf_test_sh("grep -q '| materialfusion | 000_cup | [^|]* | [^|]*/prior.mfck |' %s/runs.md", rep) == 0);
    CHECK(mf_test_sh("grep -q '| nvdiffrecmc | 000_cup | [^|]* | – |' %s/runs.md", rep) == 0);
    snprintf(csv, sizeof csv, "%s/scenes.csv", rep);
    EvTable t;
    ev_table_init(&t);
    CHECK_OK(ev_table_read_csv(&t, csv));
    EvStat nv = ev_table_stat(&t, "nvdiffrecmc", "tiny", "relit_psnr");
    EvStat grey = ev_table_stat(&t, "trivial-grey", "tiny", "relit_psnr");
    EvStat flat = ev_table_stat(&t, "trivial-flat-light", "tiny", "relit_psnr");
    EvStat mfs = ev_table_stat(&t, "materialfusion", "tiny", "relit_psnr");
    if (getenv("MF_TEST_VERBOSE"))
        printf("    relit PSNR: baseline %.2f, MaterialFusion %.2f, grey %.2f, flat light %.2f\n", nv.mean, mfs.mean, grey.mean, flat.mean);
    CHECK(nv.n == 1 && grey.n == 1 && flat.n == 1 && mfs.n == 1);
    /* The prior must act: measured 22.15 dB (21.43 at an earlier revision) for MaterialFusion (K = 4,
     * L_rgb on [0, 1], prior term every 4th iteration) vs 19.34 for the baseline on this scene.
     * Without the SDS term the run IS the baseline (same seeds: 0 dB difference), so this fails when
     * the prior does nothing; the margin (1 dB) is under half the measured gain. */
    CHECK_MSG(mfs.mean > nv.mean + 1.0, "MaterialFusion relit PSNR %.2f is not 1 dB above the baseline's %.2f: the prior term does not act",
              mfs.mean, nv.mean);
    /* Measured 19.8 dB (baseline), 15.2 (grey), 14.3 (flat light) on this scene. */
    CHECK_MSG(nv.mean > 17.5, "baseline relit PSNR %.2f below the recorded threshold 17.5", nv.mean);
    CHECK_MSG(nv.mean > grey.mean + 2.0 && nv.mean > flat.mean + 2.0, "baseline does not beat the trivial guesses by 2 dB");
    ev_table_free(&t);
    /* --res trains on box-downsampled views (regression: the factor was once lost) */
    CHECK(mf_test_sh("%s recon %s -o %s/res16 --res 16 --iters 1 --tex-res 16 2>&1 | grep -q '8 views 16x16'", mf, scene, res) == 0);
    CHECK(mf_test_sh("%s recon %s -o %s/res5 --res 5 --iters 1 2>/dev/null", mf, scene, res) != 0);
}
