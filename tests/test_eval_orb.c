/* Tests of eval/ev_orb (Stanford-ORB's PSNR-H / PSNR-L) against an independent NumPy
 * implementation written from the same published definition (run by /usr/bin/python3), and on
 * properties: identity, scale invariance, the 0.5-prediction lower bound. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"
#include "core/mf_rng.h"
#include "eval/ev_orb.h"
#include "mf_test.h"

static const char *k_numpy =
    "import numpy as np,sys\n"
    "w,h=int(sys.argv[4]),int(sys.argv[5])\n"
    "P=np.fromfile(sys.argv[1],np.float32).reshape(h,w,3).astype(np.float64)\n"
    "G=np.fromfile(sys.argv[2],np.float32).reshape(h,w,3).astype(np.float64)\n"
    "M=np.fromfile(sys.argv[3],np.float32).reshape(h,w)\n"
    "def srgb(f): return np.where(f>0.0031308,1.055*np.power(np.maximum(f,0.0031308),1/2.4)-0.055,12.92*f)\n"
    "m8=np.clip(M*255,0,255).astype(np.uint8)\n"
    "pad=np.pad(m8,2,constant_values=255)\n"
    "er=np.min(np.stack([pad[dy:dy+h,dx:dx+w] for dy in range(5) for dx in range(5)]),axis=0)\n"
    "m=(er>127).astype(np.float64)\n"
    "def psnr(p,g,mx,med,tm):\n"
    "  p=p*m[...,None]; g=g*m[...,None]; g[g<0]=0\n"
    "  if med and np.clip(g,0,1).mean()>1e-8:\n"
    "    f=srgb(np.clip(g,0,1)).mean()/np.clip(g,0,1).mean(); p=p*f; g=g*f\n"
    "  pp=p[m>0.5].copy(); gg=g[m>0.5]\n"
    "  for c in range(3):\n"
    "    if (pp[:,c]**2).sum()<=1e-6: pp[:,c]=1\n"
    "  s=(gg*pp).sum(0)/(pp**2).sum(0); p=s*p\n"
    "  p=np.clip(p,0,mx); g=np.clip(g,0,mx)\n"
    "  if tm: p=srgb(p); g=srgb(g)\n"
    "  mse=((p-g)**2).mean(); lb=((0.5*m[...,None]-g)**2).mean()\n"
    "  return max(-10*np.log10(mse),-10*np.log10(lb))\n"
    "print('%.9f %.9f'%(psnr(P,G,4,True,False),psnr(P,G,1,False,True)))\n";

static int have_numpy(void) { return system("/usr/bin/python3 -c 'import numpy' 2>/dev/null") == 0; }

MF_TEST(eval_orb_matches_numpy) {
    if (!have_numpy()) MF_SKIP("/usr/bin/python3 with numpy not available");
    enum { W = 23, H = 19 };
    MfImage p = {0}, g = {0}, m = {0};
    mf_image_alloc(&p, W, H, 3);
    mf_image_alloc(&g, W, H, 3);
    mf_image_alloc(&m, W, H, 1);
    MfRng r;
    mf_rng_seed(&r, 4, 0);
    for (int i = 0; i < W * H; ++i) {
        int x = i % W, y = i / W;
        float in = (x - 11) * (x - 11) + (y - 9) * (y - 9) < 64 ? 1.0f : 0.0f;
        m.data[i] = in * (0.8f + 0.2f * mf_rng_float(&r));
        for (int c = 0; c < 3; ++c) {
            g.data[3 * i + c] = 3.0f * mf_rng_float(&r) * (c + 1) / 3.0f; /* HDR, above 1 in places */
            p.data[3 * i + c] = 0.5f * g.data[3 * i + c] + 0.2f * mf_rng_float(&r);
        }
    }
    double h = 0, l = 0;
    CHECK_OK(ev_orb_psnr_h(&p, &g, &m, &h));
    CHECK_OK(ev_orb_psnr_l(&p, &g, &m, &l));
    const char *files[3] = {mf_test_path("orb_p.f32"), mf_test_path("orb_g.f32"), mf_test_path("orb_m.f32")};
    const MfImage *imgs[3] = {&p, &g, &m};
    for (int k = 0; k < 3; ++k) {
        FILE *f = fopen(files[k], "wb");
        CHECK(f != NULL);
        if (f) fwrite(imgs[k]->data, sizeof(float), (size_t)W * H * imgs[k]->c, f), fclose(f);
    }
    FILE *py = fopen(mf_test_path("orb.py"), "w");
    CHECK(py != NULL);
    if (py) fputs(k_numpy, py), fclose(py);
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "/usr/bin/python3 %s %s %s %s %d %d", mf_test_path("orb.py"), files[0], files[1], files[2], W, H);
    FILE *pp = popen(cmd, "r");
    double nh = -1, nl = -1;
    CHECK(pp && fscanf(pp, "%lf %lf", &nh, &nl) == 2);
    if (pp) pclose(pp);
    if (getenv("MF_TEST_VERBOSE")) printf("    PSNR-H %.6f (numpy %.6f), PSNR-L %.6f (numpy %.6f)\n", h, nh, l, nl);
    CHECK_NEAR(h, nh, 1e-4);
    CHECK_NEAR(l, nl, 1e-4);
    /* scale invariance: a per-channel scaled prediction scores the same */
    for (int i = 0; i < W * H * 3; ++i) p.data[i] *= (i % 3 == 1) ? 7.0f : 0.3f;
    double h2, l2;
    CHECK_OK(ev_orb_psnr_h(&p, &g, &m, &h2));
    CHECK_OK(ev_orb_psnr_l(&p, &g, &m, &l2));
    CHECK_NEAR(h2, h, 1e-6);
    CHECK_NEAR(l2, l, 1e-6);
    /* identity scores the cap; NaN is refused */
    CHECK_OK(ev_orb_psnr_l(&g, &g, &m, &l2));
    CHECK(l2 >= 99.0);
    g.data[7] = NAN;
    CHECK_ERR(ev_orb_psnr_h(&p, &g, &m, &h2), "ground truth");
    mf_image_free(&p), mf_image_free(&g), mf_image_free(&m);
}
