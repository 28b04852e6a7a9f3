/* Tests of mf/core/mf_error: messages and prefixes. */
#include <string.h>

#include "core/mf_error.h"
#include "mf_test.h"

MF_TEST(core_error_message) {
    int rc = mf_fail(MF_EIO, "%s: cannot open", "x.png");
    CHECK(rc == MF_EIO);
    CHECK(!strcmp(mf_error(), "x.png: cannot open"));
    mf_fail_prefix(rc, "scene.json");
    CHECK(!strcmp(mf_error(), "scene.json: x.png: cannot open"));
}
