/* mf_obj: Wavefront OBJ (+ MTL) read into MfMesh and written from it.
 *
 * Reading understands v (extra components such as w or vertex colours are ignored), vt (u, v),
 * vn, f with v | v/vt | v//vn | v/vt/vn corners, 1-based or negative (relative) indices,
 * polygons (fan-triangulated: (0, i, i+1)), usemtl (per-triangle material id in order of first
 * use; faces before the first usemtl get a material named "default"), mtllib, comments, CRLF
 * line ends. o, g, s, l, p and unknown statements are ignored. Distinct (v, vt, vn) triplets
 * become single MfMesh vertices (hash map; a 1M-triangle file loads in about a second).
 * Attributes: uv is allocated when any corner has a vt (corners without one get (0, 0));
 * nrm only when every corner has a vn (else NULL: the renderer uses face normals). Normals are
 * stored as read (the writer's unit normals round-trip bit-exactly).
 * Errors name the file and line: "mesh.obj:12: face index 9 out of range (3 vertices)",
 * "mesh.obj:4: bad number 'abc'", "mesh.obj:7: face with 2 vertices (need at least 3)".
 * Zero-area triangles are allowed by default and counted (MfObjInfo.n_degenerate); the
 * renderer must tolerate them. MfObjOptions.reject_degenerate makes them an error.
 *
 * Writing is atomic (temporary file + rename) and prints floats with %.9g, so a written mesh
 * reads back bit-exactly (same vertices, same order). Output vertices are ordered by their
 * position index (then first use); vertices no face uses are dropped. */
#ifndef MF_OBJ_H
#define MF_OBJ_H

#include "core/mf_fs.h"
#include "scene/mf_mesh.h"

/* Materials of an .mtl file. */
typedef struct {
    int n;
    char **names;  /* owned; (n,) newmtl names in file order */
    char **map_kd; /* owned; (n,) map_Kd file name as written (relative to the .mtl), NULL if none */
} MfMtl;

typedef struct {
    int reject_degenerate;  /* 1: a triangle of area <= degenerate_area is an error */
    float degenerate_area;  /* area threshold in world units^2 (0 = only exactly flat ones) */
    int read_mtl;           /* 1: parse the first mtllib into MfObjInfo.mtl (a missing file is an error) */
} MfObjOptions;

typedef struct {
    int n_degenerate;          /* triangles with area <= degenerate_area */
    int n_polygons;            /* faces with more than 3 corners (triangulated) */
    char mtllib[MF_PATH_MAX];  /* first mtllib resolved against the OBJ's folder, or "" */
    MfMtl mtl;                 /* owned; filled when options.read_mtl and an mtllib exists */
} MfObjInfo;

/* Reads with default options (degenerate triangles allowed, no MTL). */
int mf_obj_read(const char *path, MfMesh *out);
/* opt and info may be NULL. Free info->mtl with mf_mtl_free. */
int mf_obj_read_ex(const char *path, const MfObjOptions *opt, MfMesh *out, MfObjInfo *info);

/* Writes m. With mtl_texture (e.g. "albedo.png") also writes "<stem>.mtl" beside the OBJ (one
 * newmtl per material of m, or one named "material", each with Kd 1 1 1 and map_Kd
 * mtl_texture) and references it with mtllib/usemtl. NULL writes geometry only (usemtl lines
 * still separate m's materials when m->mat is set). */
int mf_obj_write(const char *path, const MfMesh *m, const char *mtl_texture);

int mf_mtl_read(const char *path, MfMtl *out);
/* n materials named names[i] (NULL names: one named "material"), all with map_Kd map_kd. */
int mf_mtl_write(const char *path, const char *const *names, int n, const char *map_kd);
void mf_mtl_free(MfMtl *m);

#endif
