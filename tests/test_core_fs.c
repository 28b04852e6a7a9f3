/* Tests of mf/core/mf_fs: atomic writes, reads, temporary names, extensions. */
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_fs.h"
#include "mf_test.h"

MF_TEST(core_fs_atomic_write) {
    const char *p = mf_test_path("sub/dir/file.txt");
    CHECK_OK(mf_mkdirs_for(p));
    CHECK_OK(mf_write_file(p, "hello", 5));
    char *d = NULL;
    size_t n = 0;
    CHECK_OK(mf_read_file(p, &d, &n));
    CHECK(n == 5 && d && !strcmp(d, "hello"));
    free(d);
    CHECK_ERR(mf_read_file(mf_test_path("missing.txt"), &d, &n), "missing.txt");
    char tmp[MF_PATH_MAX], ext[8];
    CHECK_OK(mf_tmp_path("a/b.png", tmp, sizeof tmp));
    mf_path_ext(tmp, ext, sizeof ext);
    CHECK(!strcmp(ext, "png"));
    CHECK(!strncmp(tmp, "a/.b.tmp", 8));
}
