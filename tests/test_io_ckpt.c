/* Tests of mf/io/mf_ckpt (checkpoint files of named float32 tensors): round trip, tensor-name
 * helpers, and refusal of a mismatched table or a corrupt file with a message naming the file. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "core/mf_rng.h"
#include "io/mf_ckpt.h"
#include "mf_test.h"

static float *fal(size_t n) { return calloc(n ? n : 1, sizeof(float)); }

static void fill(float *x, size_t n, float lo, float hi, uint64_t seed) {
    MfRng r;
    mf_rng_seed(&r, seed, 99);
    for (size_t i = 0; i < n; ++i) x[i] = lo + (hi - lo) * mf_rng_float(&r);
}

static int write_bytes(const char *path, const char *data, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    size_t w = fwrite(data, 1, n, f);
    fclose(f);
    return w == n ? 0 : -1;
}

MF_TEST(io_ckpt_roundtrip_and_refusals) {
    MfTensorSpec s[3];
    int s0[2] = {3, 4}, s1[1] = {5}, s2[4] = {2, 1, 3, 3};
    mf_spec_set(&s[0], "enc", "w", 2, s0);
    mf_spec_set(&s[1], "enc", "b", 1, s1);
    mf_spec_set(&s[2], NULL, "conv.w", 4, s2);
    CHECK(!strcmp(s[0].name, "enc.w") && !strcmp(s[2].name, "conv.w"));
    size_t n = mf_specs_numel(s, 3);
    CHECK(n == 12 + 5 + 18);
    float *data = fal(n), *back = fal(n);
    fill(data, n, -10, 10, 50);
    const char *path = mf_test_path("model.mfck");
    CHECK_OK(mf_ckpt_save(path, s, 3, data, "{\"res\": 64}"));
    char *meta = NULL;
    CHECK_OK(mf_ckpt_load(path, s, 3, back, &meta));
    CHECK(memcmp(data, back, n * sizeof(float)) == 0);
    CHECK(meta && !strcmp(meta, "{\"res\": 64}"));
    free(meta);
    CHECK_OK(mf_ckpt_load(path, s, 3, back, NULL));

    /* model table mismatches */
    MfTensorSpec bad[3];
    memcpy(bad, s, sizeof bad);
    snprintf(bad[1].name, sizeof bad[1].name, "enc.bias");
    CHECK_ERR(mf_ckpt_load(path, bad, 3, back, NULL), "name mismatch");
    CHECK_ERR(mf_ckpt_load(path, bad, 3, back, NULL), "enc.bias");
    memcpy(bad, s, sizeof bad);
    bad[2].shape[1] = 2;
    CHECK_ERR(mf_ckpt_load(path, bad, 3, back, NULL), "shape mismatch");
    CHECK_ERR(mf_ckpt_load(path, bad, 3, back, NULL), "(2, 1, 3, 3)");
    CHECK_ERR(mf_ckpt_load(path, s, 2, back, NULL), "tensor count");

    /* corrupt files, each refused with the file named */
    char *raw = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(path, &raw, &len));
    const char *p2 = mf_test_path("corrupt.mfck");
    char *cp = malloc(len);
    CHECK(write_bytes(p2, raw, len / 2) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "truncated");
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "corrupt.mfck");
    CHECK(write_bytes(p2, raw, len - 1) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "truncated");
    CHECK(write_bytes(p2, raw, 2) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "truncated");
    memcpy(cp, raw, len);
    cp[8] = (char)0xff, cp[9] = (char)0xff, cp[10] = (char)0xff, cp[11] = (char)0x7f; /* absurd tensor count */
    CHECK(write_bytes(p2, cp, len) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "truncated");
    memcpy(cp, raw, len);
    /* absurd first dimension of tensor 0: header is at 16 + meta (11 bytes); entry: len 5, "enc.w", ndim */
    {
        size_t off = 16 + 11 + 4 + 5 + 4;
        uint32_t big = 0x7fffffffu;
        memcpy(cp + off, &big, 4);
        CHECK(write_bytes(p2, cp, len) == 0);
        CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "truncated");
        CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "enc.w");
    }
    memcpy(cp, raw, len);
    cp[0] = 'X';
    CHECK(write_bytes(p2, cp, len) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "not an MFCK checkpoint");
    memcpy(cp, raw, len);
    cp[4] = 2; /* version 2 */
    CHECK(write_bytes(p2, cp, len) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "unsupported version 2");
    memcpy(cp, raw, len);
    cp[len - 20] ^= 0x01; /* flip one bit of the data */
    CHECK(write_bytes(p2, cp, len) == 0);
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "checksum mismatch");
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "corrupt.mfck");
    CHECK_ERR(mf_ckpt_load(mf_test_path("missing.mfck"), s, 3, back, NULL), "missing.mfck");
    /* failed loads leave the output untouched */
    memset(back, 0, n * sizeof(float));
    CHECK_ERR(mf_ckpt_load(p2, s, 3, back, NULL), "checksum");
    for (size_t i = 0; i < n; ++i) CHECK(back[i] == 0.0f);
    free(raw), free(cp), free(data), free(back);
}

MF_TEST(io_ckpt_read_meta_header_only) {
    /* the meta text alone, without the tensors; a length beyond the file or the caller's bound,
     * a bad magic and a missing file are refused by name */
    MfTensorSpec s[1];
    int sh[1] = {1000};
    mf_spec_set(&s[0], NULL, "w", 1, sh);
    float *data = fal(1000);
    fill(data, 1000, -1, 1, 7);
    char path[MF_PATH_MAX], bad[MF_PATH_MAX];
    mf_test_path_to(path, sizeof path, "meta_only.mfck");
    mf_test_path_to(bad, sizeof bad, "meta_bad.mfck");
    const char *meta = "{\"env_w\":32,\"env_h\":16}";
    CHECK_OK(mf_ckpt_save(path, s, 1, data, meta));
    char *got = NULL;
    CHECK_OK(mf_ckpt_read_meta(path, 1024, &got));
    CHECK(got && !strcmp(got, meta));
    free(got), got = NULL;
    CHECK_ERR(mf_ckpt_read_meta(path, 8, &got), "meta length 23 exceeds");
    char *buf = NULL;
    size_t len = 0;
    CHECK_OK(mf_read_file(path, &buf, &len));
    uint32_t huge = 0xF0000000u;
    memcpy(buf + 12, &huge, 4);
    CHECK(!write_bytes(bad, buf, len));
    CHECK_ERR(mf_ckpt_read_meta(bad, (size_t)1 << 31, &got), "meta_bad.mfck: meta length 4026531840 exceeds the file");
    buf[0] = 'X';
    CHECK(!write_bytes(bad, buf, len));
    CHECK_ERR(mf_ckpt_read_meta(bad, 1024, &got), "meta_bad.mfck: not an MFCK checkpoint");
    CHECK_ERR(mf_ckpt_read_meta(mf_test_path("meta_missing.mfck"), 1024, &got), "meta_missing.mfck: cannot open");
    CHECK(got == NULL);
    free(buf), free(data);
}
