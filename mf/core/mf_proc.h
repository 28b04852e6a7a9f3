#pragma once
/* Running an external program (POV-Ray, Blender, gnuplot) with its output in a log file. */

/* Runs argv[0] (a path; argv NULL-terminated) with stdout and stderr to log_path (truncated),
 * stdin from /dev/null, and waits for it. Returns 0 when it exited with status 0, the
 * posix_spawn error number (> 0) when it could not be started, -1 when it failed or was killed.
 * The caller words the error (it knows which input the program was given). */
int mf_run_logged(char *const argv[], const char *log_path);
