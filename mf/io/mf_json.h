/* mf_json: thin helpers over cJSON that make precise error messages easy.
 *
 * Every getter takes the file name and a "where" string (the JSON path of obj inside the file,
 * e.g. "frames[3]", or "" / NULL at the top level) and produces messages such as
 *   "data/x/transforms_train.json: frames[3].transform_matrix: expected 4x4 numbers"
 *   "data/x/transforms_train.json: camera_angle_x: missing"
 *   "data/x/transforms_train.json: invalid JSON near line 7"
 * Numbers must be finite. Outputs are untouched on failure. Saving pretty-prints and writes
 * atomically (temporary file + rename). */
#ifndef MF_JSON_H
#define MF_JSON_H

#include <cJSON.h>
#include <stddef.h>

/* Parses a whole file; *out is a new tree (free with cJSON_Delete). */
int mf_json_load(const char *path, cJSON **out);
/* Parses a string; `name` is used in messages in place of a file name. */
int mf_json_parse(const char *name, const char *text, size_t len, cJSON **out);
/* Writes the tree pretty-printed (plus a final newline), atomically. */
int mf_json_save(const char *path, const cJSON *root);

/* Required members of object obj. */
int mf_json_number(const char *file, const char *where, const cJSON *obj, const char *key, double *out);
int mf_json_int(const char *file, const char *where, const cJSON *obj, const char *key, int *out);
/* *out borrows the string inside the tree. */
int mf_json_string(const char *file, const char *where, const cJSON *obj, const char *key, const char **out);
/* Exactly rows x cols numbers: rows = 0 expects a flat array of cols numbers ("expected 3
 * numbers"); rows > 0 an array of rows arrays of cols numbers ("expected 4x4 numbers"). out is
 * row-major, (rows, cols). */
int mf_json_numbers(const char *file, const char *where, const cJSON *obj, const char *key, int rows, int cols, double *out);
/* Same as mf_json_numbers into float. */
int mf_json_floats(const char *file, const char *where, const cJSON *obj, const char *key, int rows, int cols, float *out);
/* A required array member; *arr borrows it, *n is its length. */
int mf_json_array(const char *file, const char *where, const cJSON *obj, const char *key, const cJSON **arr, int *n);

/* Optional members: absent (or null) gives the default and MF_OK; present but of the wrong type
 * is an error. */
int mf_json_number_opt(const char *file, const char *where, const cJSON *obj, const char *key, double dflt, double *out);
int mf_json_string_opt(const char *file, const char *where, const cJSON *obj, const char *key, const char *dflt,
                       const char **out);

/* 1-based line of position pos in text (counts '\n' before it). */
int mf_json_line_of(const char *text, const char *pos);

#endif
