#include "datasets/ds_load.h"

#include <ctype.h>
#include <dirent.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/mf_error.h"
#include "io/mf_exr.h"
#include "core/mf_log.h"
#include "io/mf_json.h"
#include "scene/mf_transforms.h"

static const char *k_fmt_names[] = {"unknown", "nerf-synthetic", "nerfactor", "stanford-orb", "bvault"};

const char *ds_format_name(DsFormat f) { return (f >= 0 && f <= DS_FMT_BVAULT) ? k_fmt_names[f] : "unknown"; }

static int is_dir(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

static int join(char *out, const char *a, const char *b) { return mf_path_join(out, MF_PATH_MAX, a, b); }

static int joinf(char *out, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int joinf(char *out, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(out, MF_PATH_MAX, fmt, ap);
    va_end(ap);
    if (n < 0 || n >= MF_PATH_MAX) return mf_fail(MF_EARG, "path too long");
    return MF_OK;
}

static void view_images_free(DsView *view) {
    mf_image_free(&view->rgba);
    mf_image_free(&view->albedo);
    mf_image_free(&view->orm);
    mf_image_free(&view->normal);
}

void ds_views_free(DsViews *v) {
    if (!v) return;
    for (int i = 0; i < v->n && v->views; ++i) view_images_free(&v->views[i]);
    free(v->views);
    memset(v, 0, sizeof *v);
}

int ds_views_keep_side(DsViews *v, MfVec3 centre, MfVec3 side, int max_views) {
    int kept = 0;
    for (int i = 0; i < v->n; ++i) {
        DsView *view = &v->views[i];
        int keep = mf_dot(mf_sub(mf_camera_pos(&view->cam), centre), side) > 0.0f && (max_views <= 0 || kept < max_views);
        if (keep) {
            if (kept != i) v->views[kept] = *view;
            ++kept;
            continue;
        }
        view_images_free(view);
    }
    v->n = kept;
    if (kept == 0)
        return mf_fail(MF_EARG, "%s: no %s view lies on the side (%g, %g, %g) of the object", v->dir, v->split, side.x, side.y, side.z);
    return MF_OK;
}

static DsLoadOptions opts_or_default(const DsLoadOptions *opt) {
    DsLoadOptions o = {1, 0, 1, 0, NULL, 0};
    if (opt) o = *opt;
    if (o.downsample < 1) o.downsample = 1;
    return o;
}

/* Box-filters img by k in place (colour weighted by alpha when c == 4). */
static int downsample(MfImage *img, int k, const char *path) {
    if (k <= 1 || !img->data) return MF_OK;
    if (img->w % k || img->h % k) return mf_fail(MF_EARG, "%s: image size %dx%d is not divisible by downsample %d", path, img->w, img->h, k);
    MfImage r = {0};
    int rc = mf_image_alloc(&r, img->w / k, img->h / k, img->c);
    if (rc) return rc;
    int c = img->c;
    for (int y = 0; y < r.h; ++y)
        for (int x = 0; x < r.w; ++x) {
            double acc[64] = {0}, wsum = 0.0;
            for (int dy = 0; dy < k; ++dy)
                for (int dx = 0; dx < k; ++dx) {
                    const float *p = mf_image_px(img, x * k + dx, y * k + dy);
                    double a = c == 4 ? p[3] : 1.0;
                    for (int ch = 0; ch < c; ++ch) acc[ch] += (c == 4 && ch < 3) ? p[ch] * a : p[ch];
                    wsum += a;
                }
            float *q = mf_image_px(&r, x, y);
            double n = (double)k * k;
            for (int ch = 0; ch < c; ++ch) {
                if (c == 4 && ch < 3) {
                    if (wsum > 0.0) q[ch] = (float)(acc[ch] / wsum);
                    else { /* fully transparent: plain mean */
                        double s = 0.0;
                        for (int dy = 0; dy < k; ++dy)
                            for (int dx = 0; dx < k; ++dx) s += mf_image_px(img, x * k + dx, y * k + dy)[ch];
                        q[ch] = (float)(s / n);
                    }
                } else q[ch] = (float)(acc[ch] / n);
            }
        }
    mf_image_free(img);
    *img = r;
    return MF_OK;
}

/* Reads an image with c channels forced to `want` (3 or 4): RGB gets alpha 1; grey is
 * replicated; extra channels are dropped. *stored_c (may be NULL) receives the file's count. */
static int read_image_c(const char *path, MfEncoding enc, int want, MfImage *out, int *stored_c) {
    MfImage im = {0};
    int rc = mf_image_read(path, enc, &im);
    if (rc) return rc;
    if (stored_c) *stored_c = im.c;
    if (im.c == want) { *out = im; return MF_OK; }
    MfImage r = {0};
    if ((rc = mf_image_alloc(&r, im.w, im.h, want))) { mf_image_free(&im); return rc; }
    for (int y = 0; y < im.h; ++y)
        for (int x = 0; x < im.w; ++x) {
            const float *p = mf_image_px(&im, x, y);
            float *q = mf_image_px(&r, x, y);
            float rgb[3], a = 1.0f;
            if (im.c >= 3) { rgb[0] = p[0]; rgb[1] = p[1]; rgb[2] = p[2]; if (im.c >= 4) a = p[3]; }
            else { rgb[0] = rgb[1] = rgb[2] = p[0]; if (im.c == 2) a = p[1]; }
            for (int k = 0; k < 3; ++k) q[k] = rgb[k];
            if (want == 4) q[3] = a;
        }
    mf_image_free(&im);
    *out = r;
    return MF_OK;
}
static int read_image(const char *path, MfEncoding enc, int want, MfImage *out) { return read_image_c(path, enc, want, out, NULL); }

static void free_views(DsView *views, int n) {
    DsViews tmp = {0};
    tmp.views = views;
    tmp.n = n;
    ds_views_free(&tmp);
}

/* ---- NeRF-synthetic and bvault ---- */

/* Reads optional per-view GT of a bvault scene: gt/albedo/<name>.png (sRGB) and gt/orm/<name>.png
 * (linear); when those are absent but the split's image has a multi-layer EXR beside it
 * (<split>/<name>.exr with albedo.* / orm.* layers, as `mf render` writes), the layers are used. */
/* A per-view GT image (read from gt_path) must have the view image's size: eval renders the
 * view's camera and scores the GT pixel by pixel (a smaller GT once overflowed a heap buffer). */
static int check_gt_size(const MfImage *gt, const char *gt_path, const char *what, const DsView *view) {
    if (!gt->data || (gt->w == view->rgba.w && gt->h == view->rgba.h)) return MF_OK;
    return mf_fail(MF_EFORMAT, "%s: %s is %dx%d, the view image %s is %dx%d", gt_path, what, gt->w, gt->h, view->image_path,
                   view->rgba.w, view->rgba.h);
}

static int bvault_view_gt(const char *dir, const char *split, DsView *view) {
    char p[MF_PATH_MAX], exr[MF_PATH_MAX];
    int rc;
    if ((rc = joinf(exr, "%s/%s/%s.exr", dir, split, view->name))) return rc;
    int has_exr = mf_file_exists(exr);
    if ((rc = joinf(p, "%s/gt/albedo/%s.png", dir, view->name))) return rc;
    if (mf_file_exists(p)) {
        if ((rc = read_image(p, MF_ENC_SRGB, 3, &view->albedo)) || (rc = check_gt_size(&view->albedo, p, "GT albedo", view))) return rc;
    } else if (has_exr && mf_exr_read_layer(exr, "albedo", "RGB", &view->albedo)) mf_error_clear();
    else if ((rc = check_gt_size(&view->albedo, exr, "albedo layer", view))) return rc;
    if ((rc = joinf(p, "%s/gt/orm/%s.png", dir, view->name))) return rc;
    if (mf_file_exists(p)) {
        if ((rc = read_image(p, MF_ENC_LINEAR, 3, &view->orm)) || (rc = check_gt_size(&view->orm, p, "GT ORM", view))) return rc;
    } else if (has_exr && mf_exr_read_layer(exr, "orm", "RGB", &view->orm)) mf_error_clear();
    else if ((rc = check_gt_size(&view->orm, exr, "orm layer", view))) return rc;
    return MF_OK;
}

/* Shared reader of transforms_<split>.json (NeRF-synthetic, bvault, ORB). img_dir_override:
 * ORB's per-frame resolution of file_path. */
typedef enum { TF_NERF = 0, TF_BVAULT = 1, TF_ORB = 2 } TfKind;

/* Per-frame work of the parallel image phase; the message of a failure is kept so it can be
 * reported in frame order (the error text is thread-local). */
typedef struct {
    double c2w[16];
    double ax;       /* camera_angle_x, NAN when the frame gives focal lengths instead */
    double fl[6];    /* fl_x, fl_y, cx, cy, w, h in the JSON's pixels; NAN = not given */
    char mask_path[MF_PATH_MAX]; /* mask replacing alpha (mask_path or --mask), or "" */
    int stored_c;    /* channels of the image file (1..4): < 4 = no alpha */
    char what[MF_PATH_MAX + 128];
    char base_dir[MF_PATH_MAX];
    int w0, h0; /* size as stored, before downsampling */
    int rc;
    char msg[MF_PATH_MAX + 256];
} FrameJob;

/* The view's camera at its final size: camera_angle_x (square pixels, centred principal point)
 * or, when the frame gives fl_x, its intrinsics scaled from the JSON's w x h (default: the
 * stored image size) to the final size, so downsampled or resized images keep their camera. */
static int apply_intrinsics(const FrameJob *job, DsView *view) {
    const double *fl = job->fl;
    int W = view->rgba.w, H = view->rgba.h;
    double jw = isnan(fl[4]) ? job->w0 : fl[4], jh = isnan(fl[5]) ? job->h0 : fl[5];
    if (fabs(jw * job->h0 - jh * job->w0) > 0.01 * jw * job->h0)
        return mf_fail(MF_EFORMAT, "%s: w x h = %g x %g, but the image %s is %dx%d (another aspect ratio)", job->what, jw, jh,
                       view->image_path, job->w0, job->h0);
    double ax = isnan(fl[0]) ? job->ax : 2.0 * atan(jw / (2.0 * fl[0]));
    view->camera_angle_x = ax;
    int rc = mf_camera_init(&view->cam, W, H, ax, job->c2w, job->what);
    if (rc || isnan(fl[0])) return rc;
    double sx = W / jw, sy = H / jh;
    view->cam.fx = (float)(fl[0] * sx);
    view->cam.fy = (float)((isnan(fl[1]) ? fl[0] : fl[1]) * sy);
    view->cam.cx = (float)((isnan(fl[2]) ? 0.5 * jw : fl[2]) * sx);
    view->cam.cy = (float)((isnan(fl[3]) ? 0.5 * jh : fl[3]) * sy);
    return MF_OK;
}

/* After the parallel phase, in frame order: the first failure, size agreement with the first
 * frame, and the cameras at the final (possibly downsampled) size. */
static int finish_frames(const FrameJob *jobs, DsView *views, int n) {
    for (int i = 0; i < n; ++i) {
        const FrameJob *job = &jobs[i];
        if (job->rc) return mf_fail(job->rc, "%s", job->msg);
        if (job->w0 != jobs[0].w0 || job->h0 != jobs[0].h0)
            return mf_fail(MF_EFORMAT, "%s: image is %dx%d, the split's first image is %dx%d", views[i].image_path, job->w0,
                           job->h0, jobs[0].w0, jobs[0].h0);
        int rc = apply_intrinsics(job, &views[i]);
        if (rc) return rc;
    }
    return MF_OK;
}

/* The mask file's first channel (linear) replaces the view's alpha; sizes must agree. */
static int apply_mask(const char *mpath, DsView *view) {
    MfImage mask = {0};
    int rc = read_image(mpath, MF_ENC_LINEAR, 3, &mask);
    if (rc) return rc;
    if (mask.w != view->rgba.w || mask.h != view->rgba.h) {
        rc = mf_fail(MF_EFORMAT, "%s: mask is %dx%d, the image %s is %dx%d", mpath, mask.w, mask.h, view->image_path,
                     view->rgba.w, view->rgba.h);
        mf_image_free(&mask);
        return rc;
    }
    for (size_t k = 0; k < (size_t)mask.w * mask.h; ++k) view->rgba.data[4 * k + 3] = mask.data[3 * k];
    mf_image_free(&mask);
    return MF_OK;
}

static int load_frame_images(TfKind kind, const char *dir, const char *split, const char *orb_root, const char *orb_capture,
                             const DsLoadOptions *o, FrameJob *job, DsView *view) {
    int rc;
    int is_exr = !strcmp(strrchr(view->image_path, '.'), ".exr");
    if ((rc = read_image_c(view->image_path, is_exr ? MF_ENC_LINEAR : MF_ENC_SRGB, 4, &view->rgba, &job->stored_c))) return rc;
    if (job->mask_path[0] && (rc = apply_mask(job->mask_path, view))) return rc;
    if (kind == TF_ORB) {
        /* mask from <split>_mask/<name>.png replaces alpha */
        char mpath[MF_PATH_MAX];
        const char *msplit = (!strcmp(split, "novel")) ? "test" : split;
        if ((rc = joinf(mpath, "%s/%s_mask/%s.png", job->base_dir, msplit, view->name))) return rc;
        if ((rc = apply_mask(mpath, view))) return rc;
        if (!strcmp(split, "test")) {
            char ep[MF_PATH_MAX];
            if ((rc = joinf(ep, "%s/ground_truth/%s/env_map/%s.exr", orb_root, orb_capture, view->name))) return rc;
            if (mf_file_exists(ep)) snprintf(view->env_path, sizeof view->env_path, "%s", ep);
        }
    }
    job->w0 = view->rgba.w;
    job->h0 = view->rgba.h;
    if (kind == TF_BVAULT && o->load_gt && (rc = bvault_view_gt(dir, split, view))) return rc;
    if ((rc = downsample(&view->rgba, o->downsample, view->image_path))) return rc;
    if ((rc = downsample(&view->albedo, o->downsample, view->image_path))) return rc;
    if ((rc = downsample(&view->orm, o->downsample, view->image_path))) return rc;
    return MF_OK;
}

/* RGB frames (no alpha in the file) with no mask: the whole frame counts as the object (alpha 1),
 * said once per split with the first such file. */
static void warn_no_alpha(const FrameJob *jobs, const DsView *views, int n, TfKind kind) {
    int first = -1, count = 0;
    for (int i = 0; i < n; ++i)
        if (jobs[i].stored_c < 4 && !jobs[i].mask_path[0] && kind != TF_ORB) {
            if (first < 0) first = i;
            ++count;
        }
    if (count)
        mf_log_warn("%s%s: no alpha channel and no mask (give --mask DIR with <DIR>/<name>.png, or mask_path per frame): "
                    "the whole frame counts as the object (alpha = 1) in %d of %d views", views[first].image_path,
                    count > 1 ? " and others" : "", count, n);
}

/* Three phases: the JSON is parsed and every camera validated first (serial, cheap), images
 * are decoded in parallel (OpenMP over frames), then failures and size mismatches are reported
 * in frame order, so the result and the messages do not depend on the thread count. */
static int load_transforms(const char *dir, const char *split, TfKind kind, const DsLoadOptions *o, const char *orb_root,
                           const char *orb_capture, DsViews *out) {
    char jpath[MF_PATH_MAX], name[64];
    int rc;
    snprintf(name, sizeof name, "transforms_%s.json", split);
    if ((rc = join(jpath, dir, name))) return rc;
    /* instant-ngp / nerfstudio: one transforms.json for every frame; the split is a rule */
    int single = 0;
    char one[MF_PATH_MAX];
    if (kind == TF_NERF && !mf_file_exists(jpath) && !join(one, dir, "transforms.json") && mf_file_exists(one)) {
        if (strcmp(split, "train") && strcmp(split, "test") && strcmp(split, "val"))
            return mf_fail(MF_EARG, "%s holds every frame; split '%s' is none of train, test (and val: every %dth frame "
                           "from the first), train (the others)", one, split, DS_HOLDOUT_EVERY);
        snprintf(jpath, sizeof jpath, "%s", one);
        single = 1;
    }
    MfTransforms tf;
    if ((rc = mf_transforms_load(jpath, MF_TF_CAPTURE | (o->quiet ? MF_TF_QUIET : 0), &tf))) return rc;
    DsViews v = {0};
    DsView *views = NULL;
    FrameJob *jobs = NULL;
    int *sel = NULL;
    int nf = 0, nall = tf.n;
    sel = malloc(((size_t)nall + 1) * sizeof *sel);
    if (!sel) { rc = mf_fail(MF_ENOMEM, "out of memory"); goto fail; }
    for (int i = 0; i < nall; ++i) /* single file: every DS_HOLDOUT_EVERY-th frame is test/val */
        if (!single || ((i % DS_HOLDOUT_EVERY == 0) == (strcmp(split, "train") != 0))) sel[nf++] = i;
    if (nf == 0) {
        rc = single ? mf_fail(MF_EFORMAT, "%s: frames: no frame for split '%s' (%d frames; test and val are every %dth)", jpath,
                              split, nall, DS_HOLDOUT_EVERY)
                    : mf_fail(MF_EFORMAT, "%s: frames: empty", jpath);
        goto fail;
    }
    if (o->max_views > 0 && nf > o->max_views) nf = o->max_views;
    views = calloc((size_t)nf, sizeof(DsView));
    jobs = calloc((size_t)nf, sizeof(FrameJob));
    if (!views || !jobs) { rc = mf_fail(MF_ENOMEM, "out of memory"); goto fail; }
    /* 1. frames and cameras */
    for (int i = 0; i < nf; ++i) {
        const MfTransformFrame *fr = &tf.frames[sel[i]];
        FrameJob *job = &jobs[i];
        DsView *view = &views[i];
        snprintf(job->what, sizeof job->what, "%s: frames[%d]", jpath, sel[i]);
        const char *fp = fr->file_path, *sn = fr->scene_name;
        memcpy(job->c2w, fr->c2w, sizeof job->c2w);
        memcpy(job->fl, fr->intr, sizeof job->fl);
        job->ax = fr->camera_angle_x;
        MfCamera probe;
        if ((rc = mf_camera_init(&probe, 1, 1, isnan(job->ax) ? 1.0 : job->ax, job->c2w, job->what))) goto fail;
        snprintf(view->name, sizeof view->name, "%.*s", DS_NAME_MAX - 1, fr->name); /* "./train/r_0.png" -> "r_0" */
        snprintf(job->base_dir, sizeof job->base_dir, "%s", dir);
        if (kind == TF_ORB && sn) {
            snprintf(view->scene_name, sizeof view->scene_name, "%s", sn);
            /* novel frames: the image lives in the other capture's folder */
            if (strcmp(sn, orb_capture) && (rc = joinf(job->base_dir, "%s/../%s", dir, sn))) goto fail;
        }
        while (fp[0] == '.' && fp[1] == '/') fp += 2; /* "./train/r_0" */
        if ((rc = join(view->image_path, job->base_dir, fp))) goto fail;
        char ext[16];
        mf_path_ext(fp, ext, sizeof ext);
        if (!ext[0]) {
            const char *def = (kind == TF_ORB && !o->ldr) ? ".exr" : ".png";
            if (strlen(view->image_path) + 5 >= MF_PATH_MAX) { rc = mf_fail(MF_EARG, "%s: path too long", job->what); goto fail; }
            strcat(view->image_path, def);
        }
        /* a mask: --mask DIR (<DIR>/<name>.png) wins over the frame's own mask_path */
        if (o->mask_dir && o->mask_dir[0] == '/') rc = joinf(job->mask_path, "%s/%s.png", o->mask_dir, view->name);
        else if (o->mask_dir && o->mask_dir[0]) rc = joinf(job->mask_path, "%s/%s/%s.png", dir, o->mask_dir, view->name);
        else if (fr->mask_path) rc = join(job->mask_path, dir, fr->mask_path);
        if (rc) goto fail;
    }
    /* per-view outputs (renders, scores) are named by the frame's base name */
    int di, dj;
    if (kind != TF_ORB && mf_find_duplicate_name(views[0].name, sizeof views[0], nf, &di, &dj)) {
        rc = mf_fail(MF_EFORMAT, "%s: frames[%d] and frames[%d] both have the base name '%s' (%s, %s): per-view outputs would "
                     "overwrite each other; rename one", jpath, sel[di], sel[dj], views[di].name, views[di].image_path,
                     views[dj].image_path);
        goto fail;
    }
    mf_transforms_free(&tf);
    /* 2. images, in parallel */
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < nf; ++i) {
        FrameJob *job = &jobs[i];
        job->rc = load_frame_images(kind, dir, split, orb_root, orb_capture, o, job, &views[i]);
        if (job->rc) snprintf(job->msg, sizeof job->msg, "%s", mf_error());
    }
    /* 3. failures and sizes in frame order; cameras at the final size */
    if ((rc = finish_frames(jobs, views, nf))) goto fail;
    if (!o->quiet) warn_no_alpha(jobs, views, nf, kind);
    free(jobs);
    free(sel);
    v.format = kind == TF_ORB ? DS_FMT_STANFORD_ORB : (kind == TF_BVAULT ? DS_FMT_BVAULT : DS_FMT_NERF_SYNTHETIC);
    snprintf(v.dir, sizeof v.dir, "%s", dir);
    snprintf(v.split, sizeof v.split, "%s", split);
    v.n = nf;
    v.views = views;
    v.w = views[0].rgba.w;
    v.h = views[0].rgba.h;
    *out = v;
    return MF_OK;
fail:
    mf_transforms_free(&tf);
    free(jobs);
    free(sel);
    free_views(views, nf);
    return rc;
}

int ds_load_nerf_synthetic(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out) {
    DsLoadOptions o = opts_or_default(opt);
    return load_transforms(dir, split, TF_NERF, &o, NULL, NULL, out);
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Sorted names of the entries of dir accepted by keep(name, ctx); *names owned. */
static int list_dir(const char *dir, int (*keep)(const char *, const void *), const void *ctx, char ***names, int *n) {
    DIR *d = opendir(dir);
    if (!d) return mf_fail(MF_EIO, "%s: cannot open folder", dir);
    char **v = NULL;
    int cnt = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.' || !keep(e->d_name, ctx)) continue;
        if (cnt == cap) {
            cap = cap ? 2 * cap : 16;
            char **nv = realloc(v, sizeof(char *) * (size_t)cap);
            if (!nv) break;
            v = nv;
        }
        v[cnt] = strdup(e->d_name);
        if (v[cnt]) ++cnt;
    }
    closedir(d);
    if (cnt) qsort(v, (size_t)cnt, sizeof(char *), cmp_str);
    *names = v;
    *n = cnt;
    return MF_OK;
}

static void free_names(char **names, int n) {
    for (int i = 0; i < n; ++i) free(names[i]);
    free(names);
}

static int keep_exr(const char *name, const void *ctx) {
    (void)ctx;
    size_t n = strlen(name);
    return n > 4 && !strcmp(name + n - 4, ".exr");
}

int ds_load_bvault(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out) {
    DsLoadOptions o = opts_or_default(opt);
    DsViews v;
    int rc = load_transforms(dir, split, TF_BVAULT, &o, NULL, NULL, &v);
    if (rc) return rc;
    char p[MF_PATH_MAX];
    if (!join(p, dir, "mesh.obj") && mf_file_exists(p)) snprintf(v.mesh_path, sizeof v.mesh_path, "%s", p);
    if (!join(p, dir, "gt/env.exr") && mf_file_exists(p)) snprintf(v.env_path, sizeof v.env_path, "%s", p);
    if (!join(p, dir, "gt/kd.png") && mf_file_exists(p)) snprintf(v.kd_path, sizeof v.kd_path, "%s", p);
    if (!join(p, dir, "gt/orm.png") && mf_file_exists(p)) snprintf(v.orm_path, sizeof v.orm_path, "%s", p);
    if (!join(p, dir, "relight") && is_dir(p)) {
        char **names = NULL;
        int n = 0;
        if ((rc = list_dir(p, keep_exr, NULL, &names, &n))) { ds_views_free(&v); return rc; }
        for (int k = 0; k < n && v.n_relight < DS_MAX_RELIGHT; ++k) {
            int r = v.n_relight++;
            snprintf(v.relight_name[r], DS_NAME_MAX, "%s", names[k]);
            v.relight_name[r][strlen(v.relight_name[r]) - 4] = '\0';
            if (joinf(v.relight_env[r], "%s/%s", p, names[k])) v.relight_env[r][0] = '\0';
        }
        free_names(names, n);
    }
    *out = v;
    return MF_OK;
}

/* ---- NeRFactor ---- */

typedef struct { const char *prefix; } SplitCtx;

static int keep_split_dir(const char *name, const void *ctx) {
    const char *pre = ((const SplitCtx *)ctx)->prefix;
    size_t n = strlen(pre);
    if (strncmp(name, pre, n) || name[n] != '_' || !isdigit((unsigned char)name[n + 1])) return 0;
    for (const char *c = name + n + 1; *c; ++c)
        if (!isdigit((unsigned char)*c)) return 0;
    return 1;
}

static int cmp_split_num(const void *a, const void *b) {
    const char *x = strrchr(*(char *const *)a, '_'), *y = strrchr(*(char *const *)b, '_');
    long i = strtol(x + 1, NULL, 10), j = strtol(y + 1, NULL, 10);
    return i < j ? -1 : (i > j);
}

static int keep_relit(const char *name, const void *ctx) {
    (void)ctx;
    size_t n = strlen(name);
    return n > 9 && !strncmp(name, "rgba_", 5) && !strcmp(name + n - 4, ".png");
}

/* "a,b,c,..." with exactly 16 finite numbers. */
static int parse_mat_string(const char *file, const char *s, double *m) {
    const char *c = s;
    for (int k = 0; k < 16; ++k) {
        char *end;
        while (*c == ' ' || *c == '\t' || *c == '[') ++c;
        double x = strtod(c, &end);
        if (end == c || !isfinite(x)) return mf_fail(MF_EFORMAT, "%s: cam_transform_mat: expected 16 comma-separated numbers", file);
        m[k] = x;
        c = end;
        while (*c == ' ' || *c == '\t' || *c == ']') ++c;
        if (k < 15) {
            if (*c != ',') return mf_fail(MF_EFORMAT, "%s: cam_transform_mat: expected 16 comma-separated numbers", file);
            ++c;
        }
    }
    while (*c == ' ' || *c == '\t' || *c == ']' || *c == '\n') ++c;
    if (*c) return mf_fail(MF_EFORMAT, "%s: cam_transform_mat: expected 16 comma-separated numbers", file);
    return MF_OK;
}

int ds_load_nerfactor(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out) {
    DsLoadOptions o = opts_or_default(opt);
    SplitCtx ctx = {split};
    char **names = NULL;
    int n = 0, rc;
    if ((rc = list_dir(dir, keep_split_dir, &ctx, &names, &n))) return rc;
    if (n == 0) { free_names(names, n); return mf_fail(MF_EIO, "%s: no %s_NNN folders", dir, split); }
    qsort(names, (size_t)n, sizeof(char *), cmp_split_num);
    int n_names = n;
    if (o.max_views > 0 && n > o.max_views) n = o.max_views;
    DsViews v = {0};
    DsView *views = calloc((size_t)n, sizeof(DsView));
    FrameJob *jobs = calloc((size_t)n, sizeof(FrameJob));
    int *dims = calloc((size_t)n * 2, sizeof(int)); /* (n, 2) imw, imh from metadata */
    cJSON *meta = NULL;
    if (!views || !jobs || !dims) { rc = mf_fail(MF_ENOMEM, "out of memory"); goto fail; }
    /* 1. metadata and cameras (serial) */
    for (int i = 0; i < n; ++i) {
        DsView *view = &views[i];
        FrameJob *job = &jobs[i];
        char vdir[MF_PATH_MAX], mpath[MF_PATH_MAX];
        snprintf(view->name, sizeof view->name, "%s", names[i]);
        if ((rc = join(vdir, dir, names[i])) || (rc = join(mpath, vdir, "metadata.json"))) goto fail;
        snprintf(job->base_dir, sizeof job->base_dir, "%s", vdir);
        snprintf(job->what, sizeof job->what, "%s", mpath);
        for (int k = 0; k < 6; ++k) job->fl[k] = NAN; /* camera_angle_x only */
        if ((rc = mf_json_load(mpath, &meta))) goto fail;
        const char *ms;
        const cJSON *mt = cJSON_GetObjectItemCaseSensitive(meta, "cam_transform_mat");
        if (cJSON_IsArray(mt)) { /* some NeRFactor-style sets store numbers: 16 flat or 4x4 */
            const cJSON *first = cJSON_GetArrayItem(mt, 0);
            if ((rc = mf_json_numbers(mpath, "", meta, "cam_transform_mat", cJSON_IsArray(first) ? 4 : 0, cJSON_IsArray(first) ? 4 : 16, job->c2w)))
                goto fail;
        } else {
            if ((rc = mf_json_string(mpath, "", meta, "cam_transform_mat", &ms))) goto fail;
            if ((rc = parse_mat_string(mpath, ms, job->c2w))) goto fail;
        }
        if ((rc = mf_json_number(mpath, "", meta, "cam_angle_x", &job->ax))) goto fail;
        if ((rc = mf_json_int(mpath, "", meta, "imh", &dims[2 * i + 1])) || (rc = mf_json_int(mpath, "", meta, "imw", &dims[2 * i]))) goto fail;
        const char *envmap = NULL;
        if ((rc = mf_json_string_opt(mpath, "", meta, "envmap", NULL, &envmap))) goto fail;
        if (envmap && i == 0) snprintf(v.env_path, sizeof v.env_path, "%s", envmap);
        cJSON_Delete(meta);
        meta = NULL;
        MfCamera probe;
        if ((rc = mf_camera_init(&probe, 1, 1, job->ax, job->c2w, job->what))) goto fail;
        if ((rc = join(view->image_path, vdir, "rgba.png"))) goto fail;
    }
    /* 2. images (parallel); failures kept per view */
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < n; ++i) {
        DsView *view = &views[i];
        FrameJob *job = &jobs[i];
        char p[MF_PATH_MAX];
        int r = read_image(view->image_path, MF_ENC_SRGB, 4, &view->rgba);
        if (!r) { job->w0 = view->rgba.w; job->h0 = view->rgba.h; }
        if (!r && (view->rgba.w != dims[2 * i] || view->rgba.h != dims[2 * i + 1]))
            r = mf_fail(MF_EFORMAT, "%s: image is %dx%d, metadata.json says imw %d, imh %d", view->image_path, view->rgba.w,
                        view->rgba.h, dims[2 * i], dims[2 * i + 1]);
        if (!r && o.load_gt) {
            r = join(p, job->base_dir, "albedo.png");
            if (!r && mf_file_exists(p)) r = read_image(p, MF_ENC_LINEAR, 3, &view->albedo);
            if (!r) r = check_gt_size(&view->albedo, p, "GT albedo", view);
            if (!r) r = join(p, job->base_dir, "normal.png");
            if (!r && mf_file_exists(p)) {
                r = read_image(p, MF_ENC_LINEAR, 3, &view->normal);
                if (!r) r = check_gt_size(&view->normal, p, "GT normal map", view);
                for (size_t k = 0; !r && k < (size_t)view->normal.w * view->normal.h * 3; ++k)
                    view->normal.data[k] = 2.0f * view->normal.data[k] - 1.0f;
            }
        }
        if (!r) r = downsample(&view->rgba, o.downsample, view->image_path);
        if (!r) r = downsample(&view->albedo, o.downsample, view->image_path);
        if (!r) r = downsample(&view->normal, o.downsample, view->image_path);
        job->rc = r;
        if (r) snprintf(job->msg, sizeof job->msg, "%s", mf_error());
    }
    /* 3. in view order: failures, sizes, cameras */
    if ((rc = finish_frames(jobs, views, n))) goto fail;
    /* relighting probes: rgba_<probe>.png in the first view's folder */
    {
        char vdir[MF_PATH_MAX];
        char **rl = NULL;
        int nr = 0;
        if (!join(vdir, dir, names[0]) && !list_dir(vdir, keep_relit, NULL, &rl, &nr)) {
            for (int k = 0; k < nr && v.n_relight < DS_MAX_RELIGHT; ++k) {
                int r = v.n_relight++;
                size_t len = strlen(rl[k]);
                snprintf(v.relight_name[r], DS_NAME_MAX, "%.*s", (int)(len - 9), rl[k] + 5);
                v.relight_env[r][0] = '\0';
            }
            free_names(rl, nr);
        }
        mf_error_clear();
    }
    v.format = DS_FMT_NERFACTOR;
    snprintf(v.dir, sizeof v.dir, "%s", dir);
    snprintf(v.split, sizeof v.split, "%s", split);
    v.n = n;
    v.views = views;
    v.w = views[0].rgba.w;
    v.h = views[0].rgba.h;
    free_names(names, n_names);
    free(jobs);
    free(dims);
    *out = v;
    return MF_OK;
fail:
    cJSON_Delete(meta);
    free(jobs);
    free(dims);
    free_views(views, n);
    free_names(names, n_names);
    return rc;
}

/* ---- Stanford-ORB ---- */

int ds_load_stanford_orb(const char *root, const char *capture, const char *split, const DsLoadOptions *opt, DsViews *out) {
    DsLoadOptions o = opts_or_default(opt);
    char dir[MF_PATH_MAX];
    int rc;
    if ((rc = joinf(dir, "%s/%s/%s", root, o.ldr ? "blender_LDR" : "blender_HDR", capture))) return rc;
    DsViews v;
    if ((rc = load_transforms(dir, split, TF_ORB, &o, root, capture, &v))) return rc;
    char p[MF_PATH_MAX];
    if (!joinf(p, "%s/ground_truth/%s/mesh_blender/mesh.obj", root, capture) && mf_file_exists(p))
        snprintf(v.mesh_path, sizeof v.mesh_path, "%s", p);
    *out = v;
    return MF_OK;
}

/* ---- detection and dispatch ---- */

DsFormat ds_detect_format(const char *dir) {
    char p[MF_PATH_MAX];
    int has_tf = 0;
    const char *splits[] = {"train", "test", "val"};
    for (int k = 0; k < 3; ++k) {
        char name[64];
        snprintf(name, sizeof name, "transforms_%s.json", splits[k]);
        if (!join(p, dir, name) && mf_file_exists(p)) has_tf = 1;
    }
    if (!has_tf && !join(p, dir, "transforms.json") && mf_file_exists(p)) return DS_FMT_NERF_SYNTHETIC;
    if (has_tf) {
        if ((!join(p, dir, "gt") && is_dir(p)) || (!join(p, dir, "relight") && is_dir(p))) return DS_FMT_BVAULT;
        if ((!join(p, dir, "train_mask") && is_dir(p)) || (!join(p, dir, "test_mask") && is_dir(p))) return DS_FMT_STANFORD_ORB;
        return DS_FMT_NERF_SYNTHETIC;
    }
    if (!join(p, dir, "train_000/metadata.json") && mf_file_exists(p)) return DS_FMT_NERFACTOR;
    if (!join(p, dir, "test_000/metadata.json") && mf_file_exists(p)) return DS_FMT_NERFACTOR;
    return DS_FMT_UNKNOWN;
}

int ds_load(const char *dir, const char *split, const DsLoadOptions *opt, DsViews *out) {
    DsFormat f = ds_detect_format(dir);
    switch (f) {
    case DS_FMT_NERF_SYNTHETIC: return ds_load_nerf_synthetic(dir, split, opt, out);
    case DS_FMT_BVAULT: return ds_load_bvault(dir, split, opt, out);
    case DS_FMT_NERFACTOR: return ds_load_nerfactor(dir, split, opt, out);
    case DS_FMT_STANFORD_ORB: {
        /* dir = <root>/blender_{HDR,LDR}/<capture> */
        char buf[MF_PATH_MAX], *cap, *kind;
        snprintf(buf, sizeof buf, "%s", dir);
        size_t n = strlen(buf);
        while (n > 1 && buf[n - 1] == '/') buf[--n] = '\0';
        cap = strrchr(buf, '/');
        if (!cap) return mf_fail(MF_EARG, "%s: expected <root>/blender_HDR/<capture>", dir);
        *cap++ = '\0';
        kind = strrchr(buf, '/');
        char *kname = kind ? kind + 1 : buf;
        DsLoadOptions o = opts_or_default(opt);
        o.ldr = !strcmp(kname, "blender_LDR");
        if (strcmp(kname, "blender_LDR") && strcmp(kname, "blender_HDR"))
            return mf_fail(MF_EARG, "%s: Stanford-ORB captures live in <root>/blender_HDR/<capture>", dir);
        if (kind) *kind = '\0';
        else snprintf(buf, sizeof buf, ".");
        return ds_load_stanford_orb(buf, cap, split, &o, out);
    }
    default: return mf_fail(MF_EFORMAT, "%s: unknown data set layout (no transforms_*.json, no train_000/metadata.json)", dir);
    }
}

int ds_load_width(const char *dir, const char *split, const DsLoadOptions *opt, int width, DsViews *out) {
    DsLoadOptions lo = opts_or_default(opt);
    lo.downsample = 1;
    DsViews dv;
    int rc = ds_load(dir, split, &lo, &dv); /* the first image's size gives the factor */
    if (rc || width <= 0 || width == dv.w) {
        if (!rc) *out = dv;
        return rc;
    }
    if (dv.w % width || dv.h % (dv.w / width)) {
        rc = mf_fail(MF_EARG, "--res %d: the images are %dx%d, not a multiple of %d", width, dv.w, dv.h, width);
        ds_views_free(&dv);
        return rc;
    }
    lo.downsample = dv.w / width;
    ds_views_free(&dv);
    return ds_load(dir, split, &lo, out);
}

void ds_views_premultiply(DsViews *v) {
    for (int i = 0; i < v->n; ++i) {
        MfImage *im = &v->views[i].rgba;
        for (size_t p = 0; p < (size_t)im->w * im->h; ++p)
            for (int c = 0; c < 3; ++c) im->data[4 * p + c] *= im->data[4 * p + 3];
    }
}

int ds_relit_path(const DsViews *v, int i, int k, char *out, size_t cap) {
    if (i < 0 || i >= v->n) return mf_fail(MF_EARG, "view %d out of range (%d views)", i, v->n);
    if (k < 0 || k >= v->n_relight) return mf_fail(MF_EARG, "relighting light %d out of range (%d lights)", k, v->n_relight);
    int n;
    if (v->format == DS_FMT_BVAULT) n = snprintf(out, cap, "%s/relight/%s/%s.exr", v->dir, v->relight_name[k], v->views[i].name);
    else if (v->format == DS_FMT_NERFACTOR) n = snprintf(out, cap, "%s/%s/rgba_%s.png", v->dir, v->views[i].name, v->relight_name[k]);
    else return mf_fail(MF_EARG, "%s: format %s has no relit views", v->dir, ds_format_name(v->format));
    if (n < 0 || (size_t)n >= cap) return mf_fail(MF_EARG, "%s: path too long", v->dir);
    return MF_OK;
}

int ds_load_relit(const DsViews *v, int i, int k, MfImage *out) {
    char p[MF_PATH_MAX];
    int rc;
    if ((rc = ds_relit_path(v, i, k, p, sizeof p))) return rc;
    if (v->format == DS_FMT_BVAULT) {
        if (!mf_file_exists(p)) return mf_fail(MF_EIO, "%s: no such file", p);
        MfExrImage ex = {0};
        if ((rc = mf_exr_read(p, &ex))) return rc;
        static const char *const rgba[4] = {"R", "G", "B", "A"};
        int has_a = mf_exr_channel(&ex, "A") != NULL;
        MfImage im = {0};
        rc = mf_exr_gather(&ex, p, rgba, has_a ? 4 : 3, &im);
        mf_exr_free(&ex);
        if (rc) return rc;
        if (!has_a) { /* RGB only: opaque */
            MfImage r4 = {0};
            if ((rc = mf_image_alloc(&r4, im.w, im.h, 4))) { mf_image_free(&im); return rc; }
            for (size_t q = 0; q < (size_t)im.w * im.h; ++q) {
                for (int c = 0; c < 3; ++c) r4.data[4 * q + c] = im.data[3 * q + c];
                r4.data[4 * q + 3] = 1.0f;
            }
            mf_image_free(&im);
            im = r4;
        }
        *out = im;
        return MF_OK;
    }
    return read_image(p, MF_ENC_SRGB, 4, out); /* NeRFactor */
}

/* Blender lat-long mapping (DESIGN.md). */
static MfVec3 uv_to_dir(float u, float v) {
    float phi = (0.5f - u) * 2.0f * MF_PI, th = (v - 0.5f) * MF_PI;
    return mf_v3(cosf(th) * cosf(phi), cosf(th) * sinf(phi), sinf(th));
}

int ds_orb_env_to_world(const MfImage *cam_env, const MfMat4 *c2w, MfImage *world_env) {
    if (!cam_env || !cam_env->data) return mf_fail(MF_EARG, "no env map to convert");
    MfImage r = {0};
    int rc = mf_image_alloc(&r, cam_env->w, cam_env->h, cam_env->c);
    if (rc) return rc;
    const float *m = c2w->m;
    int W = cam_env->w, H = cam_env->h, C = cam_env->c;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            /* world direction of this output texel (Blender mapping, texel centres) */
            MfVec3 d = uv_to_dir(((float)x + 0.5f) / (float)W, 1.0f - ((float)y + 0.5f) / (float)H);
            /* camera-frame direction R^T d */
            MfVec3 dc = mf_v3(m[0] * d.x + m[4] * d.y + m[8] * d.z, m[1] * d.x + m[5] * d.y + m[9] * d.z, m[2] * d.x + m[6] * d.y + m[10] * d.z);
            /* Stanford-ORB camera-frame layout (orb/utils/env_map.py), pixel centres at integers */
            float fy = acosf(mf_clampf(dc.y, -1.0f, 1.0f)) * MF_INV_PI * (float)(H - 1);
            float fx = (atan2f(dc.x, -dc.z) + MF_PI) * MF_INV_2PI * (float)(W - 1);
            int x0 = (int)floorf(fx), y0 = (int)floorf(fy);
            float tx = fx - (float)x0, ty = fy - (float)y0;
            float *q = mf_image_px(&r, x, y);
            for (int dy = 0; dy <= 1; ++dy)
                for (int dx = 0; dx <= 1; ++dx) {
                    int xx = ((x0 + dx) % W + W) % W, yy = y0 + dy;
                    yy = yy < 0 ? 0 : (yy >= H ? H - 1 : yy);
                    float w = (dx ? tx : 1.0f - tx) * (dy ? ty : 1.0f - ty);
                    const float *p = mf_image_px(cam_env, xx, yy);
                    for (int c = 0; c < C; ++c) q[c] += w * p[c];
                }
        }
    *world_env = r;
    return MF_OK;
}
