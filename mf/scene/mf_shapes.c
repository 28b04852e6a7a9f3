#include "scene/mf_shapes.h"

#include "core/mf_error.h"

int mf_shape_uv_sphere(MfMesh *out, MfVec3 c, float radius, int seg, int rings) {
    if (seg < 3 || rings < 2 || !(radius > 0.0f)) return mf_fail(MF_EARG, "uv sphere: invalid size %d x %d, radius %g", seg, rings, radius);
    int nv = (seg + 1) * (rings + 1), nt = 2 * seg * (rings - 1);
    MfMesh m;
    int rc = mf_mesh_alloc(&m, nv, nt, 1, 1);
    if (rc) return rc;
    for (int r = 0; r <= rings; ++r)
        for (int s = 0; s <= seg; ++s) {
            int i = r * (seg + 1) + s;
            double th = M_PI * r / rings, ph = 2.0 * M_PI * s / seg;
            double n[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
            if (r == 0 || r == rings) n[0] = n[1] = 0.0;
            for (int k = 0; k < 3; ++k) m.nrm[3 * i + k] = (float)n[k];
            m.pos[3 * i] = c.x + radius * (float)n[0];
            m.pos[3 * i + 1] = c.y + radius * (float)n[1];
            m.pos[3 * i + 2] = c.z + radius * (float)n[2];
            m.uv[2 * i] = (float)s / seg;
            m.uv[2 * i + 1] = 1.0f - (float)r / rings;
        }
    int t = 0;
    for (int r = 0; r < rings; ++r)
        for (int s = 0; s < seg; ++s) {
            uint32_t a = r * (seg + 1) + s, b = a + 1, d = a + (seg + 1), e = d + 1;
            /* a (north) - d (south), counter-clockwise seen from outside */
            if (r != 0) {
                m.tri[3 * t] = a; m.tri[3 * t + 1] = d; m.tri[3 * t + 2] = b; ++t;
            }
            if (r != rings - 1) {
                m.tri[3 * t] = b; m.tri[3 * t + 1] = d; m.tri[3 * t + 2] = e; ++t;
            }
        }
    *out = m;
    return MF_OK;
}

int mf_shape_torus(MfMesh *out, float R, float r, int nu, int nv) {
    if (nu < 3 || nv < 3 || !(r > 0.0f) || !(R > r)) return mf_fail(MF_EARG, "torus: invalid parameters");
    int nvert = (nu + 1) * (nv + 1), nt = 2 * nu * nv;
    MfMesh m;
    int rc = mf_mesh_alloc(&m, nvert, nt, 1, 1);
    if (rc) return rc;
    for (int i = 0; i <= nu; ++i)
        for (int j = 0; j <= nv; ++j) {
            int k = i * (nv + 1) + j;
            double u = 2.0 * M_PI * i / nu, v = 2.0 * M_PI * j / nv;
            double n[3] = {cos(v) * cos(u), cos(v) * sin(u), sin(v)};
            m.pos[3 * k] = (float)((R + r * cos(v)) * cos(u));
            m.pos[3 * k + 1] = (float)((R + r * cos(v)) * sin(u));
            m.pos[3 * k + 2] = (float)(r * sin(v));
            for (int q = 0; q < 3; ++q) m.nrm[3 * k + q] = (float)n[q];
            m.uv[2 * k] = (float)i / nu;
            m.uv[2 * k + 1] = (float)j / nv;
        }
    int t = 0;
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            uint32_t a = i * (nv + 1) + j, b = a + (nv + 1), c = b + 1, d = a + 1;
            m.tri[3 * t] = a; m.tri[3 * t + 1] = b; m.tri[3 * t + 2] = c; ++t;
            m.tri[3 * t] = a; m.tri[3 * t + 1] = c; m.tri[3 * t + 2] = d; ++t;
        }
    *out = m;
    return MF_OK;
}
