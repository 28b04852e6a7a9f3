/* mf_fs: file-system helpers for safe outputs.
 *
 * Every output file is written to a temporary name beside the target and renamed into place
 * only when complete, so an interrupted or failed run never leaves a half-written file:
 *   char tmp[MF_PATH_MAX]; mf_tmp_path(path, tmp, sizeof tmp);  write tmp ...
 *   mf_commit_file(tmp, path)    (or mf_discard_file(tmp) on failure). */
#ifndef MF_FS_H
#define MF_FS_H

#include <stddef.h>

#define MF_PATH_MAX 4096

/* "dir/.name.tmp.PID.N" beside path, keeping path's extension last so writers that pick a
 * format from the extension still work ("a/b.png" -> "a/.b.tmp123_0.png"). */
int mf_tmp_path(const char *path, char *out, size_t cap);
/* 1 when name (a file name, no folder) has the form mf_tmp_path gives: ".stem.tmpPID_N[.ext]";
 * *pid (may be NULL) receives PID. */
int mf_is_tmp_name(const char *name, long *pid);
/* Removes the temporaries of our own naming (mf_is_tmp_name) that a killed run left in dir and,
 * with depth > 0, its subfolders down to that depth (symbolic links are not followed). A file
 * whose PID is a live process, this one included, is kept: it may be another run's file in
 * progress. *removed (may be NULL) counts the files removed. A missing dir is not an error. */
int mf_remove_stale_tmp(const char *dir, int depth, int *removed);
/* rm -r path: a file, or a folder and everything under it (symbolic links are removed, not
 * followed). A missing path is not an error; MF_EIO names what could not be removed. */
int mf_remove_tree(const char *path);
/* rename(tmp, path); on failure removes tmp and sets the error. */
int mf_commit_file(const char *tmp, const char *path);
void mf_discard_file(const char *tmp);
/* mkdir -p. */
int mf_mkdirs(const char *dir);
/* mkdir -p of the directory part of a file path. */
int mf_mkdirs_for(const char *path);
int mf_file_exists(const char *path);
/* Checks that path names a regular file to read (the one place that refuses a directory where a
 * file is expected: "x: is a directory, expected a file"; "x: no such file"); *size (may be NULL)
 * receives its length in bytes. Every reader calls it before opening. */
int mf_input_file(const char *path, unsigned long long *size);
/* Reads a whole file into a NUL-terminated heap buffer (*len excludes the NUL); refuses what
 * mf_input_file refuses. */
int mf_read_file(const char *path, char **data, size_t *len);
/* Writes a buffer atomically (tmp + rename). */
int mf_write_file(const char *path, const void *data, size_t len);
/* Duplicate output names, found before anything is written: n NUL-terminated names laid out
 * `stride` bytes apart from `first` (an array of structs or of char[N]); returns 1 with the first
 * pair *i < *j of equal names, 0 when all differ. */
int mf_find_duplicate_name(const char *first, size_t stride, int n, int *i, int *j);
/* Joins a and b with '/' into out; returns MF_EARG if it does not fit. */
int mf_path_join(char *out, size_t cap, const char *a, const char *b);
/* Extension of path in lower case without the dot ("" if none), written to ext (cap >= 8). */
void mf_path_ext(const char *path, char *ext, size_t cap);

#endif
