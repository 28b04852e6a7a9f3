#include <cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"

int mf_opt_str(int argc, char **argv, int *i, const char *name, const char **out) {
    if (strcmp(argv[*i], name) != 0) return 0;
    if (*i + 1 >= argc) return mf_fail(MF_EARG, "option %s needs a value", name), -1;
    *out = argv[++*i];
    return 1;
}

int mf_opt_int(int argc, char **argv, int *i, const char *name, int *out) {
    const char *s;
    int r = mf_opt_str(argc, argv, i, name, &s);
    if (r != 1) return r;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < -2147483647L || v > 2147483647L)
        return mf_fail(MF_EARG, "option %s: '%s' is not an integer", name, s), -1;
    *out = (int)v;
    return 1;
}

int mf_opt_float(int argc, char **argv, int *i, const char *name, float *out) {
    const char *s;
    int r = mf_opt_str(argc, argv, i, name, &s);
    if (r != 1) return r;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || end == s || !isfinite(v)) return mf_fail(MF_EARG, "option %s: '%s' is not a number", name, s), -1;
    *out = (float)v;
    return 1;
}

int mf_cli_print_config(const MfOptBind *b, int nb) {
    cJSON *o = cJSON_CreateObject();
    for (int i = 0; o && i < nb; ++i) mf_opts_to_json(b[i].table, b[i].obj, o);
    char *s = o ? cJSON_Print(o) : NULL;
    cJSON_Delete(o);
    if (!s) return mf_fail(MF_ENOMEM, "out of memory"), MF_EXIT_FAIL;
    printf("%s\n", s);
    cJSON_free(s);
    return MF_EXIT_OK;
}
