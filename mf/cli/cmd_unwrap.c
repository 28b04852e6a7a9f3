/* mf unwrap: a UV atlas for a mesh (mf/geom/mf_uvatlas.h). */
#include <stdio.h>

#include "cli/mf_cli.h"
#include "core/mf_error.h"
#include "core/mf_log.h"
#include "geom/mf_uvatlas.h"
#include "io/mf_gltf_read.h"
#include "io/mf_obj.h"
#include "io/mf_opts.h"

typedef struct {
    const char *out;
    int tex_res, stretch, max_chart_tris, check_res;
    float gutter, max_angle;
} UnwrapArgs;

#define A UnwrapArgs
static const MfOpt k_args[] = {
    MF_OPT_STR(A, out, NULL, "output mesh (required)", .alias = "-o", .meta = "OUT.obj"),
    MF_OPT_INT(A, tex_res, 256, 1, 65536, "texture side the gutter is counted in"),
    MF_OPT_FLOAT(A, gutter, 2, 0, 1000, "texels between charts and from the border"),
    MF_OPT_FLOAT(A, max_angle, 60, 1, 180, "chart growth: a triangle joins when its normal is within this many degrees of the chart's mean normal"),
    MF_OPT_INT(A, max_chart_tris, 1000, 1, 2000000000, "chart growth stops at this many triangles"),
    MF_OPT_INT(A, check_res, 0, 0, 16384, "also rasterise the atlas at this resolution and report double-covered texel centres, flips and UVs outside [0,1] (0: off)"),
    MF_OPT_INT(A, stretch, 1, 0, 1, "1: stretch the packed layout along u and v separately to fill the square"),
};
#undef A
static const MfOptTable k_args_table = MF_OPT_TABLE("Options (--config FILE: a JSON object with these keys)", k_args);

static char usage[8192];
static const char k_usage_head[] =
    "usage: mf unwrap IN.obj -o OUT.obj [--tex-res 256] [--gutter 2] [--max-angle 60] [--max-chart-tris 1000]\n"
    "Cuts IN (OBJ or glTF; its UVs, if any, are ignored) into disc charts grown by face normals,\n"
    "flattens each by least-squares conformal maps (charts with flipped or overlapping triangles\n"
    "are split), and packs them by their shapes into [0,1]^2 with a gutter; writes OUT.obj with UVs (seams split\n"
    "vertices; triangle order, normals and materials kept). Prints one CSV line on stdout:\n"
    "  mesh,tris,charts,unwrap_s,atlas_use\n"
    "atlas_use: the fraction of a tex_res^2 texture's texel centres inside a UV triangle.\n";

__attribute__((constructor)) static void unwrap_usage(void) {
    const MfOptTable *t[] = {&k_args_table};
    mf_opts_usage_text(usage, sizeof usage, k_usage_head, t, 1, NULL);
}

static int unwrap_run(const char *in_path, const UnwrapArgs *a) {
    MfMesh in = {0}, out = {0};
    MfUvAtlasOpts o = {a->tex_res, a->gutter, a->max_angle, a->max_chart_tris, a->stretch};
    MfUvAtlasInfo info;
    MfUvCheck chk;
    int rc = mf_mesh_read(in_path, &in);
    double t0 = mf_now();
    if (rc == MF_OK && (rc = mf_uvatlas(&in, &o, &out, &info)) != MF_OK) mf_fail_prefix(rc, "%s", in_path);
    double dt = mf_now() - t0;
    if (rc == MF_OK && (rc = mf_uv_check(&out, a->tex_res, &chk)) != MF_OK) mf_fail_prefix(rc, "%s", in_path);
    MfUvCheck hi = {0};
    if (rc == MF_OK && a->check_res && (rc = mf_uv_check(&out, a->check_res, &hi)) != MF_OK) mf_fail_prefix(rc, "%s", in_path);
    if (rc == MF_OK) rc = mf_obj_write(a->out, &out, NULL);
    if (rc == MF_OK) {
        if (info.forced_single)
            mf_log_warn("unwrap: %s: %d triangles became charts of their own (splitting failed to give valid larger charts)",
                        in_path, info.forced_single);
        printf("%s,%d,%d,%.3f,%.4f\n", in_path, out.nt, info.charts, dt, chk.coverage);
        mf_log_info("unwrap: %d triangles, %d charts grown, %d after splits (topology %d, flips %d, overlaps %d), "
                    "most CG iterations %d, packed by %s, atlas use %.1f%% at %d^2 in %.2f s -> %s",
                    out.nt, info.grown, info.charts, info.split_topology, info.split_flip, info.split_overlap,
                    info.cg_iters_max, info.packed_shapes ? "shape" : "rectangle", 100.0 * chk.coverage, a->tex_res, dt, a->out);
        if (a->check_res)
            mf_log_info("unwrap: check at %d^2: %ld texel centres covered twice within a chart, %ld by two charts, "
                        "%d flipped triangles, %d outside [0,1]^2", a->check_res, hi.overlap_same, hi.overlap_other, hi.flipped, hi.outside);
    }
    mf_mesh_free(&in);
    mf_mesh_free(&out);
    return rc ? MF_EXIT_FAIL : MF_EXIT_OK;
}

static int cmd_unwrap(int argc, char **argv) {
    UnwrapArgs a;
    mf_opts_defaults(&k_args_table, &a);
    MfOptBind bind = {&k_args_table, &a};
    MfOptParse p;
    int rc = mf_opts_parse(&bind, 1, argc, argv, 1, &p) ? MF_EXIT_USAGE : MF_EXIT_OK;
    if (!rc && p.print_config) rc = mf_cli_print_config(&bind, 1);
    else if (!rc && (p.npos != 1 || !a.out)) {
        mf_fail(MF_EARG, "need one IN.obj and -o OUT.obj (see mf unwrap --help)");
        rc = MF_EXIT_USAGE;
    } else if (!rc) rc = unwrap_run(p.pos[0], &a);
    mf_opts_parse_free(&p);
    return rc;
}

MF_COMMAND(unwrap, "unwrap", "UV atlas for a mesh: disc charts, LSCM, packing (writes an OBJ with UVs)", usage, cmd_unwrap)
