/* cli_run_info: run.json for result folders (argv, seed, threads, git revision, wall seconds,
 * peak RSS), shared by the commands that write results. */
#ifndef CLI_RUN_INFO_H
#define CLI_RUN_INFO_H

#include <cJSON.h>
#include <stdint.h>

/* Writes dir/run.json atomically. extra (may be NULL) is added under "options" (ownership taken). */
int mf_write_run_json(const char *dir, int argc, char **argv, uint64_t seed, double wall_s, cJSON *extra);

#endif
