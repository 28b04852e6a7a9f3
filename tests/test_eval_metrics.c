/* Tests of eval/ev_metrics and eval/ev_align and the `mf metrics` command.
 *
 * PSNR and SSIM are checked against scikit-image (Debian's python3-skimage, run through
 * /usr/bin/python3) on fixtures the tests write; LDR-FLIP against a NumPy transcription of the
 * published algorithm with full 2-D kernels (scipy.ndimage.correlate, mode 'nearest' = OpenCV's
 * BORDER_REPLICATE used by the reference code), and against closed forms on uniform images. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "eval/ev_align.h"
#include "eval/ev_metrics.h"
#include "io/mf_image.h"
#include "io/mf_image_oiio.h"
#include "mf_test.h"

/* ---------------------------------------------------------------- fixtures */

static MfImage img_new(int w, int h, int c) {
    MfImage im = {0};
    if (mf_image_alloc(&im, w, h, c)) abort();
    return im;
}

static MfImage img_const(int w, int h, int c, float v) {
    MfImage im = img_new(w, h, c);
    for (size_t i = 0; i < (size_t)w * h * c; i++) im.data[i] = v;
    return im;
}

static MfImage img_noise(int w, int h, int c, uint64_t seed) {
    MfImage im = img_new(w, h, c);
    MfRng r;
    mf_rng_seed(&r, seed, 1);
    for (size_t i = 0; i < (size_t)w * h * c; i++) im.data[i] = mf_rng_float(&r);
    return im;
}

/* Smooth gradient plus noise of amplitude amp, clipped to [0, 1]. */
static MfImage img_gradient(int w, int h, int c, float amp, uint64_t seed) {
    MfImage im = img_new(w, h, c);
    MfRng r;
    mf_rng_seed(&r, seed, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++) {
                float v = 0.2f + 0.6f * (float)x / (float)w * (0.5f + 0.5f * (float)y / (float)h) + 0.1f * (float)k +
                          amp * (mf_rng_float(&r) - 0.5f);
                mf_image_px(&im, x, y)[k] = v < 0 ? 0 : (v > 1 ? 1 : v);
            }
    return im;
}

/* b = clip(a + noise of amplitude amp). */
static MfImage img_perturb(const MfImage *a, float amp, uint64_t seed) {
    MfImage b = img_new(a->w, a->h, a->c);
    MfRng r;
    mf_rng_seed(&r, seed, 3);
    for (size_t i = 0; i < (size_t)a->w * a->h * a->c; i++) {
        float v = a->data[i] + amp * (mf_rng_float(&r) - 0.5f);
        b.data[i] = v < 0 ? 0 : (v > 1 ? 1 : v);
    }
    return b;
}

static int write_raw(const char *path, const MfImage *im) {
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    size_t n = (size_t)im->w * im->h * im->c;
    int ok = fwrite(im->data, sizeof(float), n, f) == n;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

/* 1 when /usr/bin/python3 exists and imports every module in mods ("a, b"). */
static int have_python(const char *mods) {
    FILE *f = fopen("/usr/bin/python3", "rb");
    if (!f) return 0;
    fclose(f);
    char cmd[256];
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 -c 'import %s' >/dev/null 2>&1", mods);
    return system(cmd) == 0;
}

static int write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    if (!f) return -1;
    fputs(text, f);
    return fclose(f);
}

/* Writes the reference script py and the fixtures' manifest into the test folder as
 * <name>_ref.py and <name>_manifest.txt and starts /usr/bin/python3 on them; their stdout and
 * stderr come through the pipe returned (NULL when it could not start). */
static FILE *start_ref_script(const char *name, const char *py, const char *manifest) {
    char script[1024], man[1024], cmd[4096];
    mf_test_path_to(script, sizeof script, "%s_ref.py", name);
    mf_test_path_to(man, sizeof man, "%s_manifest.txt", name);
    CHECK(write_text(script, py) == 0 && write_text(man, manifest) == 0);
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 '%s' '%s' 2>&1", script, man);
    return popen(cmd, "r");
}

/* ---------------------------------------------------------------- PSNR / L1 basics */

MF_TEST(eval_psnr_l1_basics) {
    MfImage a = img_const(8, 6, 3, 0.3f), b = img_const(8, 6, 3, 0.4f);
    double v;
    CHECK_OK(ev_psnr(&a, &a, NULL, &v));
    CHECK(v == EV_PSNR_MAX);
    CHECK_OK(ev_psnr(&a, &b, NULL, &v));
    CHECK_NEAR(v, 20.0, 1e-5); /* MSE 0.01 */
    CHECK_OK(ev_l1(&a, &b, NULL, &v));
    CHECK_NEAR(v, 0.1, 1e-6);
    /* masked: only inside pixels count; outside differences are ignored */
    MfImage m = img_const(8, 6, 1, 0.0f);
    for (int x = 0; x < 4; x++) mf_image_px(&m, x, 2)[0] = 1.0f;
    mf_image_px(&b, 0, 2)[0] = 0.3f + 0.2f; /* inside: channel 0 error 0.2 */
    mf_image_px(&b, 7, 5)[1] = 1.0f;        /* outside: large error */
    CHECK_OK(ev_l1(&a, &b, &m, &v));
    CHECK_NEAR(v, (0.2 + 11 * 0.1) / 12.0, 1e-6);
    CHECK_OK(ev_psnr(&a, &b, &m, &v));
    CHECK_NEAR(v, 10.0 * log10(12.0 / (0.04 + 11 * 0.01)), 1e-4);
    /* errors: empty mask, sizes, NaN */
    MfImage e = img_const(8, 6, 1, 0.2f);
    CHECK_ERR(ev_psnr(&a, &b, &e, &v), "mask is empty");
    CHECK_ERR(ev_l1(&a, &b, &e, &v), "mask is empty");
    MfImage c = img_const(8, 5, 3, 0.3f);
    CHECK_ERR(ev_psnr(&a, &c, NULL, &v), "sizes differ");
    b.data[5] = NAN;
    double keep = 42.0;
    CHECK_ERR(ev_psnr(&a, &b, NULL, &keep), "non-finite");
    CHECK(keep == 42.0);
    CHECK_ERR(ev_l1(&b, &a, NULL, &keep), "non-finite");
    CHECK_ERR(ev_ssim(&a, &b, NULL, &keep), "non-finite");
    CHECK_ERR(ev_flip(&a, &b, NULL, 0, &keep), "non-finite");
    CHECK(keep == 42.0);
    mf_image_free(&a), mf_image_free(&b), mf_image_free(&c), mf_image_free(&m), mf_image_free(&e);
}

MF_TEST(eval_ssim_basics) {
    MfImage a = img_gradient(20, 17, 3, 0.3f, 1), b = img_perturb(&a, 0.2f, 2);
    double v, v2;
    CHECK_OK(ev_ssim(&a, &a, NULL, &v));
    CHECK_NEAR(v, 1.0, 1e-9);
    CHECK_OK(ev_ssim(&a, &b, NULL, &v));
    CHECK(v < 0.99 && v > 0.0);
    CHECK_OK(ev_ssim(&b, &a, NULL, &v2));
    CHECK_NEAR(v, v2, 1e-12);
    /* the mask inside the 5-pixel crop averages the same map */
    MfImage m = img_const(20, 17, 1, 1.0f);
    CHECK_OK(ev_ssim(&a, &b, &m, &v2));
    CHECK_NEAR(v, v2, 1e-12);
    float *map = malloc(sizeof(float) * 20 * 17);
    CHECK_OK(ev_ssim_map(&a, &b, map));
    double s = 0;
    for (int y = 5; y < 12; y++)
        for (int x = 5; x < 15; x++) s += map[y * 20 + x];
    CHECK_NEAR(s / 70.0, v, 1e-6);
    /* a mask on the border strip only is empty after the crop */
    MfImage e = img_const(20, 17, 1, 0.0f);
    for (int x = 0; x < 20; x++) mf_image_px(&e, x, 1)[0] = 1.0f;
    CHECK_ERR(ev_ssim(&a, &b, &e, &v), "border crop");
    MfImage t = img_const(10, 30, 3, 0.5f);
    CHECK_ERR(ev_ssim(&t, &t, NULL, &v), "smaller than");
    free(map);
    mf_image_free(&a), mf_image_free(&b), mf_image_free(&m), mf_image_free(&e), mf_image_free(&t);
}

/* ---------------------------------------------------------------- against scikit-image */

static const char SKIMAGE_PY[] =
    "import sys\n"
    "import numpy as np\n"
    "try:\n"
    "    from skimage.metrics import structural_similarity as S, peak_signal_noise_ratio as P\n"
    "except Exception as e:\n"
    "    print('NOSKIMAGE', e); sys.exit(0)\n"
    "for line in open(sys.argv[1]):\n"
    "    pa, pb, h, w, c = line.split()\n"
    "    h, w, c = int(h), int(w), int(c)\n"
    "    a = np.fromfile(pa, dtype='<f4').reshape(h, w, c)\n"
    "    b = np.fromfile(pb, dtype='<f4').reshape(h, w, c)\n"
    "    s = S(a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1,\n"
    "          channel_axis=-1)\n"
    "    p = P(a, b, data_range=1)\n"
    "    print('%.12f %.12f' % (s, p))\n";

MF_TEST(eval_psnr_ssim_vs_skimage) {
    if (!have_python("skimage")) MF_SKIP("/usr/bin/python3 with skimage not found (Debian python3-skimage)");
    enum { N = 7 };
    MfImage a[N], b[N];
    a[0] = img_noise(32, 32, 3, 10), b[0] = img_noise(32, 32, 3, 11);         /* random noise */
    a[1] = img_gradient(48, 40, 3, 0.1f, 12), b[1] = img_perturb(&a[1], 0.15f, 13); /* smooth + noise */
    a[2] = img_gradient(16, 16, 3, 0.05f, 14), b[2] = img_perturb(&a[2], 0.3f, 15); /* small 16x16 */
    a[3] = img_gradient(37, 23, 3, 0.2f, 16), b[3] = img_perturb(&a[3], 0.1f, 17);  /* non-square 37x23 */
    a[4] = img_gradient(37, 23, 1, 0.2f, 18), b[4] = img_perturb(&a[4], 0.2f, 19);  /* 1 channel */
    a[5] = img_noise(11, 13, 1, 20), b[5] = img_perturb(&a[5], 0.5f, 21);           /* minimum size */
    a[6] = img_gradient(64, 64, 3, 0.02f, 22), b[6] = img_perturb(&a[6], 0.01f, 23); /* near-identical */
    char manifest[8192] = "";
    for (int i = 0; i < N; i++) {
        char pa[1024], pb[1024];
        mf_test_path_to(pa, sizeof pa, "sk_a%d.f32", i);
        mf_test_path_to(pb, sizeof pb, "sk_b%d.f32", i);
        CHECK(write_raw(pa, &a[i]) == 0 && write_raw(pb, &b[i]) == 0);
        size_t len = strlen(manifest);
        snprintf(manifest + len, sizeof manifest - len, "%s %s %d %d %d\n", pa, pb, a[i].h, a[i].w, a[i].c);
    }
    FILE *p = start_ref_script("skimage", SKIMAGE_PY, manifest);
    CHECK(p != NULL);
    if (!p) return;
    char line[512];
    int got = 0, skipped = 0;
    while (fgets(line, sizeof line, p)) {
        if (!strncmp(line, "NOSKIMAGE", 9)) {
            skipped = 1;
            break;
        }
        double s_ref, p_ref, s, ps;
        if (sscanf(line, "%lf %lf", &s_ref, &p_ref) != 2 || got >= N) {
            CHECK_MSG(0, "unexpected python output: %s", line);
            break;
        }
        CHECK_OK(ev_ssim(&b[got], &a[got], NULL, &s));
        CHECK_OK(ev_psnr(&b[got], &a[got], NULL, &ps));
        CHECK_NEAR(s, s_ref, 1e-4);
        CHECK_NEAR(ps, p_ref, 1e-4);
        /* tighter than the contract: double-precision filtering vs skimage's float32 */
        CHECK_MSG(fabs(s - s_ref) < 2e-5, "fixture %d: ssim %.9f vs skimage %.9f", got, s, s_ref);
        got++;
    }
    int st = pclose(p);
    for (int i = 0; i < N; i++) mf_image_free(&a[i]), mf_image_free(&b[i]);
    if (skipped) MF_SKIP("/usr/bin/python3 lacks scikit-image (install python3-skimage)");
    CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0);
    CHECK_MSG(got == N, "python gave %d of %d results", got, N);
}

/* ---------------------------------------------------------------- FLIP */

static const char FLIP_PY[] =
    "import sys\n"
    "import numpy as np\n"
    "try:\n"
    "    from scipy.ndimage import correlate\n"
    "except Exception as e:\n"
    "    print('NOSCIPY', e); sys.exit(0)\n"
    "M = np.array([[10135552/24577794, 8788810/24577794, 4435075/24577794],\n"
    "              [2613072/12288897, 8788810/12288897, 887015/12288897],\n"
    "              [1425312/73733382, 8788810/73733382, 70074185/73733382]])\n"
    "Mi = np.array([[3.241003275, -1.537398934, -0.498615861], [-0.969224334, 1.875930071, 0.041554224],\n"
    "               [0.055639423, -0.204011202, 1.057148933]])\n"
    "W = np.array([0.950428545, 1.0, 1.088900371])[:, None, None]\n"
    "IW = np.array([1.052156925, 1.0, 0.918357670])[:, None, None]\n"
    "def srgb2lin(v): return np.where(v > 0.04045, ((v + 0.055) / 1.055) ** 2.4, v / 12.92)\n"
    "def lin2xyz(c): return np.einsum('ij,jhw->ihw', M, c)\n"
    "def xyz2ycxcz(x):\n"
    "    x = x * IW\n"
    "    return np.stack([116 * x[1] - 16, 500 * (x[0] - x[1]), 200 * (x[1] - x[2])])\n"
    "def ycxcz2lin(o):\n"
    "    y = (o[0] + 16) / 116\n"
    "    return np.einsum('ij,jhw->ihw', Mi, np.stack([y + o[1] / 500, y, y - o[2] / 200]) * W)\n"
    "def huntlab(rgb):\n"
    "    x = lin2xyz(rgb) * IW\n"
    "    d = 6 / 29\n"
    "    f = np.where(x > d ** 3, np.cbrt(x), x / (3 * d * d) + 4 / 29)\n"
    "    L = 116 * f[1] - 16\n"
    "    return np.stack([L, 0.01 * L * 500 * (f[0] - f[1]), 0.01 * L * 200 * (f[1] - f[2])])\n"
    "def hyab(a, b):\n"
    "    d = a - b\n"
    "    return np.abs(d[0]) + np.sqrt(d[1] ** 2 + d[2] ** 2)\n"
    "def csf(ppd, ch):\n"
    "    a1, b1, a2, b2 = [(1, 0.0047, 0, 1e-5), (1, 0.0053, 0, 1e-5), (34.1, 0.04, 13.5, 0.025)][ch]\n"
    "    r = int(np.ceil(3 * np.sqrt(0.04 / (2 * np.pi ** 2)) * ppd))\n"
    "    x, y = np.meshgrid(range(-r, r + 1), range(-r, r + 1))\n"
    "    z = (x / ppd) ** 2 + (y / ppd) ** 2\n"
    "    s = a1 * np.sqrt(np.pi / b1) * np.exp(-np.pi ** 2 * z / b1) + a2 * np.sqrt(np.pi / b2) * np.exp(-np.pi ** 2 * z / b2)\n"
    "    return s / s.sum()\n"
    "def feat(ppd, point):\n"
    "    sd = 0.5 * 0.082 * ppd\n"
    "    r = int(np.ceil(3 * sd))\n"
    "    x, y = np.meshgrid(range(-r, r + 1), range(-r, r + 1))\n"
    "    g = np.exp(-(x ** 2 + y ** 2) / (2 * sd * sd))\n"
    "    G = (x ** 2 / (sd * sd) - 1) * g if point else -x * g\n"
    "    return np.where(G < 0, G / -G[G < 0].sum(), G / G[G > 0].sum())\n"
    "def flip(ref, test, ppd=67.02):\n"
    "    o = [xyz2ycxcz(lin2xyz(srgb2lin(im))) for im in (ref, test)]\n"
    "    lab = []\n"
    "    for oo in o:\n"
    "        f = np.stack([correlate(oo[c], csf(ppd, c), mode='nearest') for c in range(3)])\n"
    "        lab.append(huntlab(np.clip(ycxcz2lin(f), 0, 1)))\n"
    "    e = hyab(lab[0], lab[1])\n"
    "    g = huntlab(np.array([0., 1, 0]).reshape(3, 1, 1)); b = huntlab(np.array([0., 0, 1]).reshape(3, 1, 1))\n"
    "    cmax = hyab(g, b)[0, 0] ** 0.7\n"
    "    p = e ** 0.7\n"
    "    dc = np.where(p < 0.4 * cmax, 0.95 / (0.4 * cmax) * p, 0.95 + (p - 0.4 * cmax) / (cmax - 0.4 * cmax) * 0.05)\n"
    "    ys = [(oo[0] + 16) / 116 for oo in o]\n"
    "    E, P = feat(ppd, 0), feat(ppd, 1)\n"
    "    def nrm(y, K): return np.hypot(correlate(y, K, mode='nearest'), correlate(y, K.T, mode='nearest'))\n"
    "    df = np.maximum(np.abs(nrm(ys[0], E) - nrm(ys[1], E)), np.abs(nrm(ys[1], P) - nrm(ys[0], P)))\n"
    "    df = (df / np.sqrt(2)) ** 0.5\n"
    "    return dc ** (1 - df)\n"
    "for line in open(sys.argv[1]):\n"
    "    pa, pb, h, w, c, out = line.split()\n"
    "    h, w, c = int(h), int(w), int(c)\n"
    "    a = np.fromfile(pa, dtype='<f4').reshape(h, w, c).astype(np.float64)\n"
    "    b = np.fromfile(pb, dtype='<f4').reshape(h, w, c).astype(np.float64)\n"
    "    if c == 1: a, b = np.repeat(a, 3, 2), np.repeat(b, 3, 2)\n"
    "    m = flip(a.transpose(2, 0, 1), b.transpose(2, 0, 1))\n"
    "    m.astype('<f8').tofile(out)\n"
    "    print('%.12f' % m.mean())\n";

MF_TEST(eval_flip_vs_numpy_reference) {
    if (!have_python("numpy, scipy")) MF_SKIP("/usr/bin/python3 with numpy and scipy not found (Debian python3-numpy, python3-scipy)");
    enum { N = 5 };
    MfImage a[N], b[N];
    a[0] = img_noise(24, 20, 3, 30), b[0] = img_noise(24, 20, 3, 31);               /* smaller than the kernels */
    a[1] = img_gradient(45, 38, 3, 0.1f, 32), b[1] = img_perturb(&a[1], 0.2f, 33);
    a[2] = img_gradient(37, 23, 1, 0.05f, 34), b[2] = img_perturb(&a[2], 0.3f, 35);  /* grey */
    a[3] = img_gradient(40, 40, 3, 0.0f, 36), b[3] = img_gradient(40, 40, 3, 0.0f, 36);
    for (size_t i = 0; i < 40 * 40 * 3; i += 3) b[3].data[i] = 1.0f - b[3].data[i]; /* colour shift */
    a[4] = img_const(9, 7, 3, 0.0f), b[4] = img_const(9, 7, 3, 0.0f);
    mf_image_px(&b[4], 4, 3)[0] = 1.0f, mf_image_px(&b[4], 4, 3)[1] = 1.0f, mf_image_px(&b[4], 4, 3)[2] = 1.0f;
    char manifest[8192] = "", outs[N][1024];
    for (int i = 0; i < N; i++) {
        char pa[1024], pb[1024];
        mf_test_path_to(pa, sizeof pa, "fl_a%d.f32", i);
        mf_test_path_to(pb, sizeof pb, "fl_b%d.f32", i);
        mf_test_path_to(outs[i], sizeof outs[i], "fl_map%d.f64", i);
        CHECK(write_raw(pa, &a[i]) == 0 && write_raw(pb, &b[i]) == 0);
        size_t len = strlen(manifest);
        snprintf(manifest + len, sizeof manifest - len, "%s %s %d %d %d %s\n", pa, pb, a[i].h, a[i].w, a[i].c,
                 outs[i]);
    }
    FILE *p = start_ref_script("flip", FLIP_PY, manifest);
    CHECK(p != NULL);
    if (!p) return;
    char line[512];
    int got = 0, skipped = 0;
    while (fgets(line, sizeof line, p)) {
        if (!strncmp(line, "NOSCIPY", 7)) {
            skipped = 1;
            break;
        }
        double ref_mean, mean;
        if (sscanf(line, "%lf", &ref_mean) != 1 || got >= N) {
            CHECK_MSG(0, "unexpected python output: %s", line);
            break;
        }
        CHECK_OK(ev_flip(&a[got], &b[got], NULL, 0.0, &mean));
        CHECK_NEAR(mean, ref_mean, 1e-5);
        size_t n = (size_t)a[got].w * a[got].h;
        float *map = malloc(sizeof(float) * n);
        double *ref = malloc(sizeof(double) * n);
        CHECK_OK(ev_flip_map(&a[got], &b[got], 0.0, map));
        FILE *f = fopen(outs[got], "rb");
        CHECK(f && fread(ref, sizeof(double), n, f) == n);
        if (f) fclose(f);
        double maxd = 0;
        for (size_t i = 0; i < n; i++) maxd = fmax(maxd, fabs(map[i] - ref[i]));
        CHECK_MSG(maxd < 1e-5, "fixture %d: FLIP map differs from the reference by %g", got, maxd);
        free(map), free(ref);
        got++;
    }
    int st = pclose(p);
    for (int i = 0; i < N; i++) mf_image_free(&a[i]), mf_image_free(&b[i]);
    if (skipped) MF_SKIP("/usr/bin/python3 lacks scipy");
    CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0);
    CHECK_MSG(got == N, "python gave %d of %d results", got, N);
}

/* Closed form for uniform grey images: filters keep constants, features vanish, a* = b* = 0
 * for grey (to rounding), so FLIP = map(|L1 − L2|^0.7) with L from the CIE formula on the sRGB
 * luminance; cmax from the CIE Lab of pure green and blue (standard sRGB primaries, D65). */
static double cie_f(double t) { return t > 216.0 / 24389.0 ? cbrt(t) : t * 24389.0 / 27.0 / 116.0 + 16.0 / 116.0; }
static double srgb_lin(double v) { return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }
static void cie_hunt_lab(double X, double Y, double Z, double out[3]) {
    double fx = cie_f(X / 0.95047), fy = cie_f(Y), fz = cie_f(Z / 1.08883);
    double L = 116 * fy - 16;
    out[0] = L, out[1] = 0.01 * L * 500 * (fx - fy), out[2] = 0.01 * L * 200 * (fy - fz);
}
static double grey_flip(double g1, double g2) {
    double gr[3], bl[3];
    cie_hunt_lab(0.3576, 0.7152, 0.1192, gr); /* sRGB green primary */
    cie_hunt_lab(0.1805, 0.0722, 0.9505, bl); /* sRGB blue primary */
    double cmax = pow(fabs(gr[0] - bl[0]) + hypot(gr[1] - bl[1], gr[2] - bl[2]), 0.7);
    double L1 = 116 * cie_f(srgb_lin(g1)) - 16, L2 = 116 * cie_f(srgb_lin(g2)) - 16;
    double p = pow(fabs(L1 - L2), 0.7);
    return p < 0.4 * cmax ? 0.95 / (0.4 * cmax) * p : 0.95 + (p - 0.4 * cmax) / (0.6 * cmax) * 0.05;
}

MF_TEST(eval_flip_properties) {
    double v, v2;
    /* identical images: exactly 0 */
    MfImage a = img_gradient(30, 26, 3, 0.3f, 40), b = img_perturb(&a, 0.2f, 41);
    CHECK_OK(ev_flip(&a, &a, NULL, 0, &v));
    CHECK(v == 0.0);
    /* symmetric */
    CHECK_OK(ev_flip(&a, &b, NULL, 0, &v));
    CHECK_OK(ev_flip(&b, &a, NULL, 0, &v2));
    CHECK(v > 0.0 && v < 1.0);
    CHECK_NEAR(v, v2, 1e-12);
    /* increases with the error magnitude (noise of growing amplitude, same seed) */
    double prev = 0.0;
    for (int i = 1; i <= 5; i++) {
        MfImage c = img_perturb(&a, 0.08f * i, 42);
        CHECK_OK(ev_flip(&a, &c, NULL, 0, &v));
        CHECK_MSG(v > prev, "amplitude %d: flip %g not above %g", i, v, prev);
        prev = v;
        mf_image_free(&c);
    }
    /* uniform grey with a constant offset: the closed form, growing with the offset */
    prev = 0.0;
    const float offs[] = {0.01f, 0.05f, 0.1f, 0.3f, 0.6f};
    for (int i = 0; i < 5; i++) {
        MfImage g1 = img_const(16, 12, 3, 0.2f), g2 = img_const(16, 12, 3, 0.2f + offs[i]);
        CHECK_OK(ev_flip(&g1, &g2, NULL, 0, &v));
        CHECK_NEAR(v, grey_flip(0.2, 0.2 + offs[i]), 1e-4);
        CHECK(v > prev);
        prev = v;
        /* single-channel grey gives the same as replicated RGB */
        MfImage h1 = img_const(16, 12, 1, 0.2f), h2 = img_const(16, 12, 1, 0.2f + offs[i]);
        CHECK_OK(ev_flip(&h1, &h2, NULL, 0, &v2));
        CHECK_NEAR(v, v2, 1e-9);
        mf_image_free(&g1), mf_image_free(&g2), mf_image_free(&h1), mf_image_free(&h2);
    }
    /* hand-checked: black vs white, uniform. L = 0 and 100, ΔE_hyab = 100; 100^0.7 = 25.12 is
     * above pc·cmax, so the value is in (0.95, 1]: 0.95 + (25.119 − 0.4·cmax)/(0.6·cmax)·0.05. */
    MfImage k0 = img_const(12, 12, 3, 0.0f), k1 = img_const(12, 12, 3, 1.0f);
    CHECK_OK(ev_flip(&k0, &k1, NULL, 0, &v));
    CHECK_NEAR(v, grey_flip(0.0, 1.0), 1e-4);
    CHECK(v > 0.95 && v <= 1.0);
    /* masked mean: only inside pixels */
    MfImage m = img_const(30, 26, 1, 0.0f);
    float *map = malloc(sizeof(float) * 30 * 26);
    CHECK_OK(ev_flip_map(&a, &b, 0, map));
    mf_image_px(&m, 3, 4)[0] = 1.0f, mf_image_px(&m, 20, 9)[0] = 0.9f;
    CHECK_OK(ev_flip(&a, &b, &m, 0, &v));
    CHECK_NEAR(v, 0.5 * ((double)map[4 * 30 + 3] + map[9 * 30 + 20]), 1e-7);
    MfImage e = img_const(30, 26, 1, 0.0f);
    CHECK_ERR(ev_flip(&a, &b, &e, 0, &v), "mask is empty");
    MfImage two = img_const(30, 26, 2, 0.5f);
    CHECK_ERR(ev_flip(&two, &two, NULL, 0, &v), "1 or 3 channels");
    free(map);
    mf_image_free(&a), mf_image_free(&b), mf_image_free(&k0), mf_image_free(&k1), mf_image_free(&m);
    mf_image_free(&e), mf_image_free(&two);
}

/* ev_metrics_compute agrees with the single metrics (it shares the SSIM and FLIP maps). */
MF_TEST(eval_metrics_compute_matches_parts) {
    MfImage gt = img_gradient(26, 21, 3, 0.2f, 70), pred = img_perturb(&gt, 0.15f, 71);
    MfImage mask = img_const(26, 21, 1, 0.0f);
    for (int y = 4; y < 18; y++)
        for (int x = 6; x < 22; x++) mf_image_px(&mask, x, y)[0] = 1.0f;
    EvMetrics m;
    double v;
    CHECK_OK(ev_metrics_compute(&pred, &gt, &mask, &m));
    CHECK(m.has_mask == 1);
    CHECK_OK(ev_psnr(&pred, &gt, NULL, &v)); CHECK(v == m.psnr);
    CHECK_OK(ev_ssim(&pred, &gt, NULL, &v)); CHECK(v == m.ssim);
    CHECK_OK(ev_l1(&pred, &gt, NULL, &v)); CHECK(v == m.l1);
    CHECK_OK(ev_flip(&gt, &pred, NULL, 0, &v)); CHECK(v == m.flip);
    CHECK_OK(ev_psnr(&pred, &gt, &mask, &v)); CHECK(v == m.psnr_masked);
    CHECK_OK(ev_ssim(&pred, &gt, &mask, &v)); CHECK(v == m.ssim_masked);
    CHECK_OK(ev_l1(&pred, &gt, &mask, &v)); CHECK(v == m.l1_masked);
    CHECK_OK(ev_flip(&gt, &pred, &mask, 0, &v)); CHECK(v == m.flip_masked);
    CHECK(m.psnr_masked != m.psnr && m.flip_masked != m.flip);
    CHECK_OK(ev_metrics_compute(&pred, &gt, NULL, &m));
    CHECK(m.has_mask == 0 && m.psnr_masked == 0.0);
    MfImage e = img_const(26, 21, 1, 0.0f);
    CHECK_ERR(ev_metrics_compute(&pred, &gt, &e, &m), "mask is empty");
    mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&mask), mf_image_free(&e);
}

/* ---------------------------------------------------------------- alignment */

MF_TEST(eval_align_recovers_scaled_gt) {
    MfImage gt = img_gradient(24, 18, 3, 0.2f, 50), pred = img_new(24, 18, 3), mask = img_const(24, 18, 1, 0.0f);
    const float k[3] = {2.0f, 0.5f, 3.0f};
    for (int y = 0; y < 18; y++)
        for (int x = 0; x < 24; x++) {
            int in = x > 3 && x < 20 && y > 2 && y < 15;
            mf_image_px(&mask, x, y)[0] = in ? 1.0f : 0.0f;
            for (int c = 0; c < 3; c++)
                mf_image_px(&pred, x, y)[c] = in ? k[c] * mf_image_px(&gt, x, y)[c] : 7.0f; /* junk outside */
        }
    for (EvAlign mode = EV_ALIGN_MEAN; mode <= EV_ALIGN_LSQ; mode++) {
        float s[3];
        unsigned deg = 99;
        CHECK_OK(ev_align_scales(&pred, &gt, &mask, mode, s, &deg));
        CHECK(deg == 0);
        for (int c = 0; c < 3; c++) CHECK_NEAR(s[c], 1.0 / k[c], 1e-6);
        MfImage po = {0}, go = {0};
        CHECK_OK(ev_protocol_prepare(&pred, &gt, &mask, mode, &po, &go, s, &deg));
        double maxd = 0;
        for (size_t i = 0; i < (size_t)24 * 18 * 3; i++) maxd = fmax(maxd, fabs(po.data[i] - go.data[i]));
        CHECK_MSG(maxd < 1e-5, "aligned prediction differs from GT by %g", maxd);
        double v;
        CHECK_OK(ev_psnr(&po, &go, &mask, &v));
        CHECK(v > 90.0);
        /* outside the mask both are composited to black */
        CHECK(mf_image_px(&po, 0, 0)[0] == 0.0f && mf_image_px(&go, 0, 0)[1] == 0.0f);
        mf_image_free(&po), mf_image_free(&go);
    }
    /* none leaves the prediction as it is */
    float s[3];
    CHECK_OK(ev_align_scales(&pred, &gt, &mask, EV_ALIGN_NONE, s, NULL));
    CHECK(s[0] == 1.0f && s[1] == 1.0f && s[2] == 1.0f);
    mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&mask);
}

MF_TEST(eval_align_lsq_vs_mean) {
    /* two pixels, one channel: pred (1, 2), gt (2, 2): mean 4/3, lsq (2 + 4)/(1 + 4) = 6/5 */
    MfImage pred = img_new(2, 1, 1), gt = img_const(2, 1, 1, 2.0f);
    pred.data[0] = 1.0f, pred.data[1] = 2.0f;
    float s;
    CHECK_OK(ev_align_scales(&pred, &gt, NULL, EV_ALIGN_MEAN, &s, NULL));
    CHECK_NEAR(s, 4.0 / 3.0, 1e-7);
    CHECK_OK(ev_align_scales(&pred, &gt, NULL, EV_ALIGN_LSQ, &s, NULL));
    CHECK_NEAR(s, 6.0 / 5.0, 1e-7);
    EvAlign m;
    CHECK_OK(ev_align_parse("lsq", &m));
    CHECK(m == EV_ALIGN_LSQ);
    CHECK_ERR(ev_align_parse("median", &m), "median");
    mf_image_free(&pred), mf_image_free(&gt);
}

MF_TEST(eval_align_degenerate) {
    MfImage gt = img_const(6, 5, 4, 0.5f), pred = img_const(6, 5, 4, 0.25f), mask = img_const(6, 5, 1, 0.0f);
    float s[3] = {-1, -1, -1};
    unsigned deg = 0;
    /* empty mask: error, outputs untouched */
    CHECK_ERR(ev_align_scales(&pred, &gt, &mask, EV_ALIGN_MEAN, s, &deg), "mask is empty");
    CHECK(s[0] == -1.0f);
    MfImage po = {0}, go = {0};
    CHECK_ERR(ev_protocol_prepare(&pred, &gt, &mask, EV_ALIGN_LSQ, &po, &go, s, &deg), "mask is empty");
    CHECK(po.data == NULL && go.data == NULL);
    /* all-zero prediction in channel 1: scale 1 with a flag, never NaN */
    for (int i = 0; i < 30; i++) pred.data[i * 4 + 1] = 0.0f;
    CHECK_OK(ev_align_scales(&pred, &gt, NULL, EV_ALIGN_MEAN, s, &deg));
    CHECK(deg == 2u);
    CHECK_NEAR(s[0], 2.0, 1e-7);
    CHECK(s[1] == 1.0f);
    CHECK_OK(ev_align_scales(&pred, &gt, NULL, EV_ALIGN_LSQ, s, &deg));
    CHECK(deg == 2u && s[1] == 1.0f);
    /* RGBA: alpha is dropped, 3 colour channels out */
    CHECK_OK(ev_protocol_prepare(&pred, &gt, NULL, EV_ALIGN_MEAN, &po, &go, s, &deg));
    CHECK(po.c == 3 && go.c == 3);
    for (size_t i = 0; i < (size_t)po.w * po.h * 3; i++) CHECK(isfinite(po.data[i]) && po.data[i] >= 0 && po.data[i] <= 1);
    mf_image_free(&po), mf_image_free(&go);
    /* NaN in either image or the mask: error naming it */
    pred.data[7] = NAN;
    CHECK_ERR(ev_align_scales(&pred, &gt, NULL, EV_ALIGN_MEAN, s, &deg), "prediction");
    pred.data[7] = 0.1f;
    gt.data[3] = INFINITY;
    CHECK_ERR(ev_protocol_prepare(&pred, &gt, NULL, EV_ALIGN_MEAN, &po, &go, s, &deg), "ground truth");
    gt.data[3] = 0.5f;
    mask.data[2] = NAN;
    CHECK_ERR(ev_align_scales(&pred, &gt, &mask, EV_ALIGN_MEAN, s, &deg), "mask");
    MfImage small = img_const(5, 5, 4, 0.5f);
    CHECK_ERR(ev_align_scales(&small, &gt, NULL, EV_ALIGN_MEAN, s, &deg), "ground truth is");
    mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&mask), mf_image_free(&small);
}

/* sRGB conversion and clipping in the protocol: values above 1 clip, the curve is exact. */
MF_TEST(eval_protocol_srgb_clip) {
    MfImage gt = img_new(3, 1, 1), pred = img_new(3, 1, 1);
    gt.data[0] = 0.0f, gt.data[1] = 0.214041144f, gt.data[2] = 4.0f;
    for (int i = 0; i < 3; i++) pred.data[i] = gt.data[i];
    MfImage po = {0}, go = {0};
    CHECK_OK(ev_protocol_prepare(&pred, &gt, NULL, EV_ALIGN_NONE, &po, &go, NULL, NULL));
    CHECK(go.data[0] == 0.0f);
    CHECK_NEAR(go.data[1], 0.5, 1e-6);
    CHECK(go.data[2] == 1.0f);
    /* a fractional mask composites on black */
    MfImage m = img_const(3, 1, 1, 0.6f);
    mf_image_free(&po), mf_image_free(&go);
    CHECK_OK(ev_protocol_prepare(&pred, &gt, &m, EV_ALIGN_MEAN, &po, &go, NULL, NULL));
    CHECK_NEAR(go.data[1], 0.3, 1e-6);
    CHECK_NEAR(po.data[1], 0.3, 1e-6);
    mf_image_free(&po), mf_image_free(&go), mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&m);
}

/* ORM protocol: G and B only, linear, no alignment; R is ignored. */
MF_TEST(eval_protocol_orm) {
    MfImage gt = img_gradient(16, 14, 4, 0.1f, 80), pred = img_perturb(&gt, 0.2f, 81), m = img_const(16, 14, 1, 1.0f);
    for (size_t i = 0; i < (size_t)16 * 14; i++) pred.data[i * 4] = 0.0f, gt.data[i * 4] = 1.0f; /* R differs */
    MfImage po = {0}, go = {0};
    CHECK_OK(ev_protocol_prepare_orm(&pred, &gt, &m, &po, &go));
    CHECK(po.c == 2 && go.c == 2);
    double maxd = 0;
    for (size_t i = 0; i < (size_t)16 * 14; i++)
        for (int k = 0; k < 2; k++) maxd = fmax(maxd, fabs(go.data[i * 2 + k] - gt.data[i * 4 + k + 1]));
    CHECK(maxd == 0.0);
    EvMetrics r;
    CHECK_OK(ev_metrics_compute(&po, &go, &m, &r));
    CHECK(r.has_flip == 0 && r.has_mask == 1);
    double v;
    CHECK_OK(ev_l1(&po, &go, NULL, &v));
    CHECK(v == r.l1 && v > 0.0);
    mf_image_free(&po), mf_image_free(&go);
    MfImage e = img_const(16, 14, 1, 0.0f), two = img_const(16, 14, 2, 0.5f);
    CHECK_ERR(ev_protocol_prepare_orm(&pred, &gt, &e, &po, &go), "mask is empty");
    CHECK_ERR(ev_protocol_prepare_orm(&two, &two, NULL, &po, &go), "3 or 4 channels");
    mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&m), mf_image_free(&e), mf_image_free(&two);
}

/* ---------------------------------------------------------------- the mf metrics command */

/* Runs `$MF_BIN metrics args`, captures stdout+stderr into out; returns the exit code or -1. */
static int run_mf(const char *args, char *out, size_t cap) {
    const char *bin = getenv("MF_BIN");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "'%s' metrics %s 2>&1", bin ? bin : "build/mf", args);
    FILE *p = popen(cmd, "r");
    if (!p) return -1;
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = '\0';
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static double find_value(const char *out, const char *name) {
    char key[64];
    snprintf(key, sizeof key, "%s ", name);
    for (const char *s = out; (s = strstr(s, key)); s++)
        if (s == out || s[-1] == '\n') return atof(s + strlen(key));
    return NAN;
}

MF_TEST(eval_cli_metrics) {
    MF_NEED_BIN();
    MfImage gt = img_gradient(32, 28, 4, 0.1f, 60), pred = img_new(32, 28, 4), mask = img_const(32, 28, 1, 0.0f);
    for (int y = 0; y < 28; y++)
        for (int x = 0; x < 32; x++) {
            float *g = mf_image_px(&gt, x, y), *p = mf_image_px(&pred, x, y);
            int in = (x - 16) * (x - 16) + (y - 14) * (y - 14) < 100;
            g[3] = in ? 1.0f : 0.0f;
            mf_image_px(&mask, x, y)[0] = g[3];
            for (int c = 0; c < 3; c++) p[c] = 1.7f * g[c] * (1.0f + 0.1f * (float)((x * 7 + y * 3 + c) % 5 - 2) / 2.0f);
            p[3] = 1.0f;
        }
    char pg[1024], pp[1024], pm[1024], ps[1024], pe[1024], args[4096], out[8192];
    mf_test_path_to(pg, sizeof pg, "cli_gt.exr");
    mf_test_path_to(pp, sizeof pp, "cli_pred.exr");
    mf_test_path_to(pm, sizeof pm, "cli_mask.png");
    mf_test_path_to(ps, sizeof ps, "cli_small.exr");
    mf_test_path_to(pe, sizeof pe, "cli_empty.png");
    CHECK_OK(mf_image_write(pg, &gt, MF_ENC_LINEAR, 32));
    CHECK_OK(mf_image_write(pp, &pred, MF_ENC_LINEAR, 32));
    CHECK_OK(mf_image_write(pm, &mask, MF_ENC_LINEAR, 8));
    MfImage small = img_const(16, 16, 4, 0.5f), empty = img_const(32, 28, 1, 0.0f);
    CHECK_OK(mf_image_write(ps, &small, MF_ENC_LINEAR, 32));
    CHECK_OK(mf_image_write(pe, &empty, MF_ENC_LINEAR, 8));

    /* the command reproduces the library's protocol */
    snprintf(args, sizeof args, "'%s' '%s' --mask '%s' --align lsq", pp, pg, pm);
    CHECK(run_mf(args, out, sizeof out) == 0);
    MfImage pc = img_new(32, 28, 3), gc = img_new(32, 28, 3), po = {0}, go = {0};
    for (size_t i = 0; i < (size_t)32 * 28; i++)
        for (int c = 0; c < 3; c++) pc.data[i * 3 + c] = pred.data[i * 4 + c], gc.data[i * 3 + c] = gt.data[i * 4 + c];
    CHECK_OK(ev_protocol_prepare(&pc, &gc, &mask, EV_ALIGN_LSQ, &po, &go, NULL, NULL));
    EvMetrics m;
    CHECK_OK(ev_metrics_compute(&po, &go, &mask, &m));
    CHECK_NEAR(find_value(out, "psnr"), m.psnr, 1e-5);
    CHECK_NEAR(find_value(out, "ssim"), m.ssim, 1e-5);
    CHECK_NEAR(find_value(out, "l1"), m.l1, 1e-5);
    CHECK_NEAR(find_value(out, "flip"), m.flip, 1e-5);
    CHECK_NEAR(find_value(out, "psnr_masked"), m.psnr_masked, 1e-5);
    CHECK_NEAR(find_value(out, "ssim_masked"), m.ssim_masked, 1e-5);
    CHECK_NEAR(find_value(out, "l1_masked"), m.l1_masked, 1e-5);
    CHECK_NEAR(find_value(out, "flip_masked"), m.flip_masked, 1e-5);
    /* --mask alpha is the same mask */
    char out2[8192];
    snprintf(args, sizeof args, "'%s' '%s' --mask alpha --align lsq", pp, pg);
    CHECK(run_mf(args, out2, sizeof out2) == 0);
    CHECK_NEAR(find_value(out2, "psnr_masked"), m.psnr_masked, 1e-5);
    /* alignment makes a difference; without a mask there are no masked lines */
    snprintf(args, sizeof args, "'%s' '%s' --align none", pp, pg);
    CHECK(run_mf(args, out, sizeof out) == 0);
    CHECK(isnan(find_value(out, "psnr_masked")));
    CHECK(find_value(out, "psnr") < m.psnr);
    /* --orm: G, B only, no flip line */
    snprintf(args, sizeof args, "'%s' '%s' --orm --mask '%s'", pp, pg, pm);
    CHECK(run_mf(args, out, sizeof out) == 0);
    MfImage oo = {0}, og = {0};
    CHECK_OK(ev_protocol_prepare_orm(&pred, &gt, &mask, &oo, &og));
    CHECK_OK(ev_metrics_compute(&oo, &og, &mask, &m));
    CHECK_NEAR(find_value(out, "psnr"), m.psnr, 1e-5);
    CHECK_NEAR(find_value(out, "l1_masked"), m.l1_masked, 1e-5);
    CHECK(isnan(find_value(out, "flip")) && isnan(find_value(out, "flip_masked")));
    mf_image_free(&oo), mf_image_free(&og);
    snprintf(args, sizeof args, "'%s' '%s' --orm --align mean", pp, pg);
    CHECK(run_mf(args, out, sizeof out) == 2);
    /* errors: sizes (naming both files), empty mask, usage */
    snprintf(args, sizeof args, "'%s' '%s'", pp, ps);
    CHECK(run_mf(args, out, sizeof out) == 1);
    CHECK_MSG(strstr(out, "cli_pred.exr") && strstr(out, "cli_small.exr") && strstr(out, "sizes differ"), "%s", out);
    snprintf(args, sizeof args, "'%s' '%s' --mask '%s'", pp, pg, pe);
    CHECK(run_mf(args, out, sizeof out) == 1);
    CHECK_MSG(strstr(out, "mask is empty") && strstr(out, "cli_empty.png"), "%s", out);
    snprintf(args, sizeof args, "'%s' '%s' --align median", pp, pg);
    CHECK(run_mf(args, out, sizeof out) == 2);
    snprintf(args, sizeof args, "'%s'", pp);
    CHECK(run_mf(args, out, sizeof out) == 2);
    /* a NaN pixel in a file (written through the OIIO shim, since mf_image_write refuses NaN) */
    char pn[1024], err[256];
    mf_test_path_to(pn, sizeof pn, "cli_nan.exr");
    MfImage nanimg = img_const(32, 28, 4, 0.5f);
    nanimg.data[4 * (3 * 32 + 5) + 1] = NAN;
    CHECK(mf_oiio_write(pn, 32, 28, 4, nanimg.data, 32, err, sizeof err) == 0);
    snprintf(args, sizeof args, "'%s' '%s'", pn, pg);
    CHECK(run_mf(args, out, sizeof out) == 1);
    CHECK_MSG(strstr(out, "cli_nan.exr") && (strstr(out, "NaN") || strstr(out, "not finite")), "%s", out);
    mf_image_free(&nanimg);
    snprintf(args, sizeof args, "'%s' '%s'", pp, mf_test_path("missing.exr"));
    CHECK(run_mf(args, out, sizeof out) == 1);
    CHECK_MSG(strstr(out, "missing.exr"), "%s", out);
    mf_image_free(&gt), mf_image_free(&pred), mf_image_free(&mask), mf_image_free(&small), mf_image_free(&empty);
    mf_image_free(&pc), mf_image_free(&gc), mf_image_free(&po), mf_image_free(&go);
}

/* Per-channel MSE over the pixels ev_psnr uses: channel 0 off by 0.1 everywhere, channel 1 by 0.3
 * on the masked-in half only; their mean is ev_psnr's MSE. */
MF_TEST(eval_mse_channels) {
    MfImage a = {0}, b = {0}, m = {0};
    CHECK_OK(mf_image_alloc(&a, 4, 2, 2));
    CHECK_OK(mf_image_alloc(&b, 4, 2, 2));
    CHECK_OK(mf_image_alloc(&m, 4, 2, 1));
    if (!a.data || !b.data || !m.data) return;
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x) {
            mf_image_px(&b, x, y)[0] = 0.1f;
            mf_image_px(&b, x, y)[1] = x < 2 ? 0.3f : 0.9f;
            mf_image_px(&m, x, y)[0] = x < 2 ? 1.0f : 0.0f;
        }
    double mse[2] = {-1, -1}, ps = 0;
    CHECK_OK(ev_mse_channels(&a, &b, &m, mse));
    CHECK_NEAR(mse[0], 0.01, 1e-7);
    CHECK_NEAR(mse[1], 0.09, 1e-7);
    CHECK_OK(ev_psnr(&a, &b, &m, &ps));
    CHECK_NEAR(ps, 10.0 * log10(1.0 / 0.05), 1e-5);
    mf_image_free(&a), mf_image_free(&b), mf_image_free(&m);
}
