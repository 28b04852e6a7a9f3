/* Scratch folder, files and checksum fix-up shared by the fuzz harnesses (mf_fuzz.h). */
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_log.h"
#include "core/mf_rng.h"
#include "io/mf_ckpt.h"
#include "io/mf_exr.h"
#include "io/mf_image.h"
#include "mf_fuzz.h"


static char g_dir[256];
static int g_state; /* 0 not made, 1 ready, -1 failed */

static int rm_entry(const char *p, const struct stat *sb, int flag, struct FTW *ftw) { return remove(p); }
static void rm_scratch(void) {
    if (g_dir[0]) nftw(g_dir, rm_entry, 16, FTW_DEPTH | FTW_PHYS);
}

static int make_fixtures(void) {
    MfImage img = {0};
    if (mf_image_alloc(&img, 2, 2, 4)) return -1;
    for (int i = 0; i < 16; ++i) img.data[i] = (float)(i % 5) / 4.0f;
    char p[1024];
    int rc = mf_mkdirs(mf_fuzz_path("fix"));
    snprintf(p, sizeof p, "%s", mf_fuzz_path("fix/rgba.png"));
    if (!rc) rc = mf_image_write(p, &img, MF_ENC_SRGB, 8);
    snprintf(p, sizeof p, "%s", mf_fuzz_path("fix/rgba.exr"));
    if (!rc) rc = mf_exr_write_image(p, &img, "", 0);
    mf_image_free(&img);
    static const char tri[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    if (!rc && !mf_fuzz_write("fix/tri.obj", tri, sizeof tri - 1)) rc = -1;
    return rc;
}

const char *mf_fuzz_dir(void) {
    if (g_state == 0) {
        g_state = -1;
        mf_log_set_level(MF_LOG_ERROR);
        const char *base = getenv("TMPDIR");
        snprintf(g_dir, sizeof g_dir, "%s/mf_fuzz.XXXXXX", base && base[0] ? base : "/tmp");
        if (!mkdtemp(g_dir)) {
            g_dir[0] = 0;
            return "";
        }
        atexit(rm_scratch);
        g_state = 1;
        if (make_fixtures()) {
            fprintf(stderr, "mf_fuzz: cannot make fixtures in %s: %s\n", g_dir, mf_error());
            g_state = -1;
        }
    }
    return g_state == 1 ? g_dir : "";
}

const char *mf_fuzz_path(const char *rel) {
    static char bufs[8][1024];
    static int k;
    char *b = bufs[k++ & 7];
    snprintf(b, 1024, "%s/%s", g_dir, rel);
    return b;
}

const char *mf_fuzz_write(const char *rel, const void *data, size_t n) {
    const char *p = mf_fuzz_path(rel);
    FILE *f = fopen(p, "wb"); /* the folders exist after the first write: made only when missing (a mkdir per level per input cost 18% of fuzz_scene) */
    if (!f && (mf_mkdirs_for(p) || !(f = fopen(p, "wb")))) return NULL;
    size_t w = n ? fwrite(data, 1, n, f) : 0;
    if (fclose(f) || w != n) return NULL;
    return p;
}

uint8_t *mf_fuzz_fix_checksum(const uint8_t *data, size_t n) {
    uint8_t *b = malloc(n ? n : 1);
    if (!b) return NULL;
    if (n) memcpy(b, data, n);
    if (n >= 8) {
        uint64_t h = mf_fnv1a64(MF_FNV64_INIT, b, n - 8);
        memcpy(b + n - 8, &h, 8);
    }
    return b;
}
