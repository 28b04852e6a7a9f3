/* mf: the MaterialFusion command. `mf help` lists the subcommands. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "nn/mf_nn.h"

#define MAX_CMDS 64
static const MfCommand *g_cmds[MAX_CMDS];
static int g_ncmds;

void mf_cli_register(const MfCommand *cmd) {
    if (g_ncmds < MAX_CMDS) g_cmds[g_ncmds++] = cmd;
}

static int cmp_cmd(const void *a, const void *b) {
    return strcmp((*(const MfCommand *const *)a)->name, (*(const MfCommand *const *)b)->name);
}

static void print_help(FILE *f) {
    fprintf(f, "usage: mf <command> [options]   (mf <command> --help for its options)\n\ncommands:\n");
    for (int i = 0; i < g_ncmds; ++i) fprintf(f, "  %-14s %s\n", g_cmds[i]->name, g_cmds[i]->summary);
}

static const MfCommand *find_cmd(const char *name) {
    for (int i = 0; i < g_ncmds; ++i)
        if (!strcmp(g_cmds[i]->name, name)) return g_cmds[i];
    return NULL;
}

/* OpenMP threads that wait for work spin by default (OMP_WAIT_POLICY=active). Beside OpenBLAS's
 * own threads (the prior's matrix products) and any other job on the machine, the spinning takes
 * the cores the work needs: a 24-iteration MaterialFusion run (4 views of test-3d's box) took
 * 90-156 s active and 57-65 s passive on the shared 2-core machine, with identical results.
 * libgomp reads the variable when it is loaded, before main, so it is set here and the program
 * started again, once; a value the user set is kept. */
static void omp_passive_wait(char **argv) {
    if (getenv("OMP_WAIT_POLICY")) return;
    if (setenv("OMP_WAIT_POLICY", "passive", 1)) return;
    execv("/proc/self/exe", argv); /* returns only on failure: go on with the default policy */
}

int main(int argc, char **argv) {
    omp_passive_wait(argv);
    qsort(g_cmds, (size_t)g_ncmds, sizeof g_cmds[0], cmp_cmd);
    if (argc < 2) {
        print_help(stderr);
        return MF_EXIT_USAGE;
    }
    const char *name = argv[1];
    if (!strcmp(name, "help") || !strcmp(name, "--help") || !strcmp(name, "-h")) {
        if (argc >= 3) {
            const MfCommand *c = find_cmd(argv[2]);
            if (!c) { fprintf(stderr, "mf: unknown command '%s'\n", argv[2]); return MF_EXIT_USAGE; }
            printf("%s", c->usage);
            return MF_EXIT_OK;
        }
        print_help(stdout);
        return MF_EXIT_OK;
    }
    const MfCommand *c = find_cmd(name);
    if (!c) {
        fprintf(stderr, "mf: unknown command '%s' (see 'mf help')\n", name);
        return MF_EXIT_USAGE;
    }
    for (int i = 2; i < argc; ++i)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("%s", c->usage);
            return MF_EXIT_OK;
        }
    if (mf_nn_backend_from_env()) { /* MF_NN_BACKEND=blas|dnnl: the network's conv backend (mf_nn.h) */
        fprintf(stderr, "mf %s: error: %s\n", name, mf_error());
        return MF_EXIT_USAGE;
    }
    mf_error_clear();
    int rc = c->fn(argc - 1, argv + 1);
    if (rc != MF_EXIT_OK) {
        const char *msg = mf_error();
        fprintf(stderr, "mf %s: error: %s\n", name, msg[0] ? msg : "failed");
    }
    return rc;
}
