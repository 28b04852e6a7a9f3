/* mf_fuzz: libFuzzer harnesses over the loaders and the option parser (issue 15, item 2).
 *
 * Each fuzz_<name>.c defines one entry point with MF_FUZZ(name). Built with clang and
 * -DMF_LIBFUZZER it is LLVMFuzzerTestOneInput (make fuzz: one binary per harness, ASan + UBSan);
 * built with gcc it is mf_fuzz_<name>, which tests/test_fuzz_replay.c calls on the generated
 * seed corpora and on every past crash kept in tests/fuzz/regress/<name>/ (make test).
 *
 * Loaders take paths, so a harness writes its input to a file in a per-process scratch folder
 * (fixtures it needs beside it are made once, by the harness itself). A harness returns 0 and
 * must neither crash nor leak; a refused input (an error code from the loader) is fine. */
#ifndef MF_FUZZ_H
#define MF_FUZZ_H

#include <stddef.h>
#include <stdint.h>

#ifdef MF_LIBFUZZER
#define MF_FUZZ(name) int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
#else
#define MF_FUZZ(name) int mf_fuzz_##name(const uint8_t *data, size_t size)
#endif

/* The scratch folder of this process (made on first use with the fixtures below, removed at
 * exit); "" if it cannot be made. Also sets the log level to errors only. */
const char *mf_fuzz_dir(void);
/* "<scratch>/rel" in a static rotating buffer. */
const char *mf_fuzz_path(const char *rel);
/* Writes n bytes to <scratch>/rel (parent folders made); returns the path, NULL on failure. */
const char *mf_fuzz_write(const char *rel, const void *data, size_t n);
/* Copies data into a fresh heap buffer with its last 8 bytes replaced by the FNV-1a 64 of the
 * bytes before them (the MFCK checksum), so mutations reach the parser behind the checksum.
 * Inputs shorter than 8 bytes are copied as they are. Caller frees. */
uint8_t *mf_fuzz_fix_checksum(const uint8_t *data, size_t n);

/* Fixtures (made on the first call of mf_fuzz_dir): <scratch>/fix/rgba.png (2x2 RGBA 8-bit),
 * fix/rgba.exr (2x2 RGBA float), fix/tri.obj (one triangle with UVs). */

#endif
