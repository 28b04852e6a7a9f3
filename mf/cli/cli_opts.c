/* cli_opts: option parsing shared by the commands (mf_cli.h). */
#include <cJSON.h>
#include <stdio.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"

int mf_cli_parse(const MfOptBind *b, int nb, int argc, char **argv, int max_pos, MfOptParse *p) {
    if (mf_opts_parse(b, nb, argc, argv, max_pos, p)) {
        mf_opts_parse_free(p);
        return MF_EXIT_USAGE;
    }
    if (!p->print_config) return -1;
    int rc = mf_cli_print_config(b, nb);
    mf_opts_parse_free(p);
    return rc;
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
