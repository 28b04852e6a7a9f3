/* mf_cli: the `mf` command's subcommand registry and small option helpers.
 *
 * Each subcommand lives in its own mf/cli/cmd_<name>.c and registers itself:
 *   static int cmd_render(int argc, char **argv);  // argv[0] is the subcommand name
 *   MF_COMMAND(render, "render", "render a scene JSON's cameras to EXR/PNG", usage_text, cmd_render)
 * (the first argument is a C identifier, the second the command's name, e.g. "bench-render")
 * `mf help` lists them; `mf <cmd> --help` (or -h) prints the usage text. A command returns the
 * process exit code (0 ok, 1 runtime failure, 2 usage error); main() prints mf_error() on failure.
 * Options: a command declares them in a table (io/mf_opts.h) and parses with mf_opts_parse, which
 * gives it flags, --config, --print-config, --help lines and range checks in one place; every
 * command does (mf_cli_parse below is the usual call). */
#ifndef MF_CLI_H
#define MF_CLI_H

#include "io/mf_opts.h"

typedef int (*MfCmdFn)(int argc, char **argv);

typedef struct {
    const char *name;
    const char *summary;
    const char *usage;
    MfCmdFn fn;
} MfCommand;

void mf_cli_register(const MfCommand *cmd);

#define MF_COMMAND(id_, name_, summary_, usage_, fn_)                                  \
    __attribute__((constructor)) static void mf_register_cmd_##id_(void) {             \
        static const MfCommand c = {name_, summary_, usage_, fn_};                      \
        mf_cli_register(&c);                                                           \
    }

/* Exit codes. */
#define MF_EXIT_OK 0
#define MF_EXIT_FAIL 1
#define MF_EXIT_USAGE 2

/* Parses a command's options with mf_opts_parse into the bound structs (their defaults already
 * set). Returns -1 when the command goes on (free p with mf_opts_parse_free), else the exit code
 * to return at once (p already freed): MF_EXIT_USAGE on a bad option, MF_EXIT_OK after
 * --print-config printed the options. */
int mf_cli_parse(const MfOptBind *b, int nb, int argc, char **argv, int max_pos, MfOptParse *p);

/* `mf <cmd> --print-config`: prints the options of the bound tables (after --config and flags)
 * as one JSON object on stdout, a valid --config file for the same command; returns MF_EXIT_OK. */
int mf_cli_print_config(const MfOptBind *b, int nb);

#endif
