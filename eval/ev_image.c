/* ev_image: one layer of an image file for scoring. See ev_image.h. */
#include "eval/ev_image.h"

#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "core/mf_error.h"
#include "io/mf_exr.h"

static int has_ext_exr(const char *path) {
    const char *dot = strrchr(path, '.');
    return dot && !strcasecmp(dot, ".exr");
}

/* Channel name of component `comp` in `layer` ("" = default layer), into buf. */
static const char *chan_name(char *buf, size_t cap, const char *layer, const char *comp) {
    if (layer[0]) snprintf(buf, cap, "%s.%s", layer, comp);
    else snprintf(buf, cap, "%s", comp);
    return buf;
}

/* Comma-separated distinct layer names of the file ("" shown as "(default)") into buf. */
static void list_layers(const MfExrImage *im, char *buf, size_t cap) {
    size_t u = 0;
    buf[0] = '\0';
    for (int i = 0; i < im->n; ++i) {
        const char *dot = strrchr(im->names[i], '.');
        int len = dot ? (int)(dot - im->names[i]) : 0;
        int seen = 0;
        for (int j = 0; j < i && !seen; ++j) {
            const char *dj = strrchr(im->names[j], '.');
            int lj = dj ? (int)(dj - im->names[j]) : 0;
            seen = lj == len && !strncmp(im->names[i], im->names[j], (size_t)len);
        }
        if (seen || u + 1 >= cap) continue;
        int m = len ? snprintf(buf + u, cap - u, "%s%.*s", u ? ", " : "", len, im->names[i])
                    : snprintf(buf + u, cap - u, "%s(default)", u ? ", " : "");
        if (m < 0) break;
        u += (size_t)m < cap - u ? (size_t)m : cap - u - 1;
    }
}

static int read_exr_layer(const char *path, const char *layer, MfImage *out) {
    MfExrImage im = {0};
    int rc = mf_exr_read(path, &im);
    if (rc) return rc;
    /* Component sets tried in order; the first whose channels all exist wins. */
    static const char *const sets[][4] = {{"R", "G", "B", "A"}, {"R", "G", "B", NULL}, {"X", "Y", "Z", NULL},
                                          {"Y", "A", NULL, NULL}, {"Y", NULL, NULL, NULL}, {"Z", NULL, NULL, NULL},
                                          {"R", NULL, NULL, NULL}};
    char buf[4][300];
    const char *names[4];
    int nc = 0;
    for (size_t s = 0; s < sizeof sets / sizeof sets[0] && nc == 0; ++s) {
        int k = 0, all = 1;
        for (; k < 4 && sets[s][k]; ++k) {
            names[k] = chan_name(buf[k], sizeof buf[k], layer, sets[s][k]);
            if (!mf_exr_channel(&im, names[k])) all = 0;
        }
        if (all) nc = k;
    }
    if (nc == 0) {
        char have[512];
        list_layers(&im, have, sizeof have);
        mf_exr_free(&im);
        return mf_fail(MF_EARG, "%s: no layer '%s' with R,G,B / X,Y,Z / Y / Z channels (file has layers: %s)", path,
                       layer[0] ? layer : "(default)", have);
    }
    rc = mf_exr_gather(&im, path, names, nc, out);
    mf_exr_free(&im);
    return rc;
}

int ev_image_read(const char *path, const char *layer, MfEncoding enc, MfImage *out) {
    if (!layer) layer = "";
    if (has_ext_exr(path)) return read_exr_layer(path, layer, out);
    if (layer[0]) return mf_fail(MF_EARG, "%s: layer '%s' asked for, but only EXR files have layers", path, layer);
    MfImage img = {0};
    int rc = mf_image_read(path, enc, &img);
    if (rc) return rc;
    if (img.c > 4) {
        int c = img.c;
        mf_image_free(&img);
        return mf_fail(MF_EFORMAT, "%s: %d channels; at most 4 (RGB(A)) can be scored", path, c);
    }
    *out = img;
    return MF_OK;
}
