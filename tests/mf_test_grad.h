/* Gradient checks against central differences, shared by the tests (header-only).
 *
 * mf_test_fd:   one central difference (L(p_i + h) - L(p_i - h)) / 2h of a loss in the float
 *               entry p[i]; p[i] is restored.
 * grad_check:   mf_test_grad as the prior tests use it (scaled steps, tol * max(1, |fd|)).
 * mf_test_grad: the analytic gradient g (n,) of loss(ctx) against central differences at the
 *               entries first, first + stride, ... < n of p (float) or pd (double), each given a
 *               relative error err_i (the form below); returns the worst entry, how many were
 *               checked and how many were off (err_i > 1, or a difference that is not finite).
 *
 * The step h: eps (MF_FD_NOMINAL: p[i] +- (float)eps, divided by 2 eps), the same with the
 * divisor the float step actually taken (MF_FD_ROUNDED), or eps * max(1, |p[i]|) (MF_FD_SCALED).
 * A double pd takes pd[i] +- eps (MF_FD_NOMINAL only).
 * The error: err_i = |fd - g_i| / (atol + rtol * s) (MF_ERR_SUM), or / max(atol, rtol * s)
 * (MF_ERR_MAX), where s = |fd|, or max(|fd|, |g_i|) when sym. atol = 1, rtol = 0 gives the
 * absolute error |fd - g_i|; fd_max (the largest |fd|) then serves checks relative to the
 * largest gradient. */
#ifndef MF_TEST_GRAD_H
#define MF_TEST_GRAD_H

#include <math.h>
#include <stdio.h>

typedef double (*MfTestLoss)(void *ctx);

/* (loss(p_i + h) - loss(p_i - h)) / 2h with p[i] +- (float)h; p[i] restored. */
static inline double mf_test_fd(MfTestLoss loss, void *ctx, float *p, size_t i, double h) {
    float keep = p[i];
    p[i] = keep + (float)h;
    double lp = loss(ctx);
    p[i] = keep - (float)h;
    double lm = loss(ctx);
    p[i] = keep;
    return (lp - lm) / (2.0 * h);
}

enum { MF_FD_NOMINAL, MF_FD_ROUNDED, MF_FD_SCALED };
enum { MF_ERR_SUM, MF_ERR_MAX };

typedef struct MfGradCheck MfGradCheck;
struct MfGradCheck {
    MfTestLoss loss;
    void *ctx;
    float *p;                 /* (n,) the parameters, or */
    double *pd;               /* (n,) double ones */
    const float *g;           /* (n,) the analytic gradient */
    size_t n, first, stride;  /* entries first, first + stride, ... < n (stride 0: 1) */
    int (*skip)(const MfGradCheck *c, size_t i); /* non-NULL: entries it returns 1 for are passed over */
    double eps;               /* the step (see step) */
    int step;                 /* MF_FD_NOMINAL, MF_FD_ROUNDED or MF_FD_SCALED */
    double atol, rtol;        /* the error's denominator (see form) */
    int form;                 /* MF_ERR_SUM or MF_ERR_MAX */
    int sym;                  /* scale by max(|fd|, |g_i|) instead of |fd| */
    const char *what;         /* non-NULL: the first 5 entries off go to stderr, labelled what */
};

typedef struct {
    double worst;  /* the largest err_i; INFINITY when one is not finite */
    long at;       /* its entry; -1 when none was checked */
    double fd, g;  /* the difference and the gradient there */
    double fd_max; /* the largest |fd| */
    int checked;   /* entries checked */
    int off;       /* entries with err_i > 1 or not finite */
} MfGradResult;

static inline MfGradResult mf_test_grad(const MfGradCheck *c) {
    MfGradResult r = {.at = -1};
    for (size_t i = c->first; i < c->n; i += c->stride ? c->stride : 1) {
        if (c->skip && c->skip(c, i)) continue;
        double fd;
        if (c->pd) {
            double keep = c->pd[i];
            c->pd[i] = keep + c->eps;
            double lp = c->loss(c->ctx);
            c->pd[i] = keep - c->eps;
            double lm = c->loss(c->ctx);
            c->pd[i] = keep;
            fd = (lp - lm) / (2 * c->eps);
        } else if (c->step == MF_FD_ROUNDED) {
            float keep = c->p[i], xp = keep + (float)c->eps, xm = keep - (float)c->eps;
            c->p[i] = xp;
            double lp = c->loss(c->ctx);
            c->p[i] = xm;
            double lm = c->loss(c->ctx);
            c->p[i] = keep;
            fd = (lp - lm) / ((double)xp - (double)xm);
        } else {
            double h = c->step == MF_FD_SCALED ? c->eps * fmax(1.0, fabs(c->p[i])) : c->eps;
            fd = mf_test_fd(c->loss, c->ctx, c->p, i, h);
        }
        double g = c->g[i], s = c->sym ? fmax(fabs(fd), fabs(g)) : fabs(fd);
        double den = c->form == MF_ERR_MAX ? fmax(c->atol, c->rtol * s) : c->atol + c->rtol * s;
        double err = fabs(fd - g) / den;
        if (!isfinite(err)) err = INFINITY;
        if (err > 1.0) {
            if (c->what && r.off < 5) fprintf(stderr, "  %s %zu: numeric %.6g analytic %.6g\n", c->what, i, fd, g);
            ++r.off;
        }
        if (r.at < 0 || err > r.worst) r.worst = err, r.at = (long)i, r.fd = fd, r.g = g;
        r.fd_max = fmax(r.fd_max, fabs(fd));
        ++r.checked;
    }
    return r;
}

/* mf_test_grad with h = eps * max(1, |p_i|): entry i is off when |fd - grad_i| > tol * max(1, |fd|).
 * The first 5 entries off go to stderr, labelled what. Adds the entries checked to *checked;
 * returns how many were off. */
static inline int grad_check(MfTestLoss loss, void *ctx, float *p, const float *grad, size_t n, size_t first, size_t stride,
                             double eps, double tol, const char *what, int *checked) {
    MfGradResult r = mf_test_grad(&(MfGradCheck){.loss = loss, .ctx = ctx, .p = p, .g = grad, .n = n, .first = first,
                                                 .stride = stride, .eps = eps, .step = MF_FD_SCALED, .atol = tol,
                                                 .rtol = tol, .form = MF_ERR_MAX, .what = what});
    *checked += r.checked;
    return r.off;
}

#endif
