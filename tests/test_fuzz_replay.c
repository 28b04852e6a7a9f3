/* Replays the fuzz harnesses (tests/fuzz/, compiled here with gcc, no libFuzzer) on the seed
 * corpora that build/fuzz_seeds writes ($MF_FUZZ_SEEDS, set by make test) and on every crash a
 * campaign found, kept in tests/fuzz/regress/<harness>/. A crash or sanitizer report ends the
 * test run; each harness must also have replayed at least one seed, so a missing corpus fails. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_fs.h"
#include "mf_test.h"

typedef int (*FuzzFn)(const unsigned char *, size_t);
int mf_fuzz_obj(const unsigned char *, size_t);
int mf_fuzz_scene(const unsigned char *, size_t);
int mf_fuzz_transforms(const unsigned char *, size_t);
int mf_fuzz_image(const unsigned char *, size_t);
int mf_fuzz_ckpt(const unsigned char *, size_t);
int mf_fuzz_prior(const unsigned char *, size_t);
int mf_fuzz_opts(const unsigned char *, size_t);
int mf_fuzz_gltf(const unsigned char *, size_t);

static const struct { const char *name; FuzzFn fn; } k_harness[] = {
    {"obj", mf_fuzz_obj},     {"scene", mf_fuzz_scene}, {"transforms", mf_fuzz_transforms}, {"image", mf_fuzz_image},
    {"ckpt", mf_fuzz_ckpt},   {"prior", mf_fuzz_prior}, {"opts", mf_fuzz_opts},
    {"gltf", mf_fuzz_gltf},
};

/* Runs fn on every file of dir; returns the number replayed (0 when dir does not exist). */
static int replay_dir(FuzzFn fn, const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char p[2048], *buf;
        size_t len;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        if (mf_read_file(p, &buf, &len)) continue;
        CHECK_MSG(fn((const unsigned char *)buf, len) == 0, "%s: harness returned non-zero", p);
        free(buf);
        ++n;
    }
    closedir(d);
    return n;
}

MF_TEST(fuzz_replay_seeds_and_regressions) {
    const char *seeds = getenv("MF_FUZZ_SEEDS");
    if (!seeds || !seeds[0]) {
        MF_SKIP("MF_FUZZ_SEEDS not set (make test sets it)");
        return;
    }
    int total_regress = 0;
    for (size_t k = 0; k < sizeof k_harness / sizeof k_harness[0]; ++k) {
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/%s", seeds, k_harness[k].name);
        int ns = replay_dir(k_harness[k].fn, dir);
        CHECK_MSG(ns > 0, "%s: no seeds replayed", dir);
        snprintf(dir, sizeof dir, "tests/fuzz/regress/%s", k_harness[k].name);
        total_regress += replay_dir(k_harness[k].fn, dir);
    }
    printf("    replayed the seeds of %d harnesses and %d regression inputs\n", (int)(sizeof k_harness / sizeof k_harness[0]),
           total_regress);
}
