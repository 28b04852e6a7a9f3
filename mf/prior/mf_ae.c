/* mf_ae: see mf_ae.h. */
#include "prior/mf_ae.h"

#include <stdlib.h>
#include <string.h>

#include "core/mf_error.h"

/* Validates the configuration and lays out ae's layers and parameter table (no weights). */
static int ae_build(MfAe *ae, const MfAeConfig *cfg) {
    const MfAeConfig *c = cfg;
    if (c->res < 8 || c->res % 4 || c->c1 < 1 || c->c2 < 1 || c->zc < 1 || c->groups < 1 || c->c1 % c->groups ||
        c->c2 % c->groups)
        return mf_fail(MF_EARG, "autoencoder: bad configuration (res %d, c1 %d, c2 %d, zc %d, groups %d)", c->res,
                       c->c1, c->c2, c->zc, c->groups);
    ae->cfg = *c;
    MfSpecTab *t = &ae->tab;
    int ok = 1;
    MfSeq *e = &ae->enc, *d = &ae->dec;
    mf_seq_begin(e, 3, c->res, c->res, c->groups);
    ok = ok && mf_seq_conv(e, t, "ae.enc", c->c1, 3, 1, 0) && mf_seq_res(e, t, "ae.enc", c->c1);
    ok = ok && mf_seq_conv(e, t, "ae.enc", c->c2, 3, 2, 0) && mf_seq_res(e, t, "ae.enc", c->c2);
    ok = ok && mf_seq_conv(e, t, "ae.enc", c->c2, 3, 2, 0) && mf_seq_res(e, t, "ae.enc", c->c2);
    ok = ok && mf_seq_norm(e, t, "ae.enc") && mf_seq_conv(e, t, "ae.enc", c->zc, 3, 1, 0);
    mf_seq_begin(d, c->zc, c->res / 4, c->res / 4, c->groups);
    ok = ok && mf_seq_conv(d, t, "ae.dec", c->c2, 3, 1, 0) && mf_seq_res(d, t, "ae.dec", c->c2);
    ok = ok && mf_seq_up(d) && mf_seq_conv(d, t, "ae.dec", c->c2, 3, 1, 0) && mf_seq_res(d, t, "ae.dec", c->c2);
    ok = ok && mf_seq_up(d) && mf_seq_conv(d, t, "ae.dec", c->c1, 3, 1, 0) && mf_seq_res(d, t, "ae.dec", c->c1);
    ok = ok && mf_seq_norm(d, t, "ae.dec") && mf_seq_conv(d, t, "ae.dec", 3, 3, 1, 0);
    return ok ? MF_OK : mf_fail(MF_ENOMEM, "autoencoder: out of memory");
}

int mf_ae_new(MfAe **out, const MfAeConfig *cfg) {
    MfAe *ae = calloc(1, sizeof *ae);
    if (!ae) return mf_fail(MF_ENOMEM, "autoencoder: out of memory");
    int rc = ae_build(ae, cfg);
    if (!rc) {
        ae->params = calloc(ae->tab.numel, sizeof(float));
        ae->grads = calloc(ae->tab.numel, sizeof(float));
        if (!ae->params || !ae->grads) rc = mf_fail(MF_ENOMEM, "autoencoder: out of memory");
    }
    if (rc) {
        mf_ae_free(ae);
        return rc;
    }
    *out = ae;
    return MF_OK;
}

int mf_ae_numel(const MfAeConfig *cfg, size_t *numel) {
    MfAe ae = {0};
    int rc = ae_build(&ae, cfg);
    if (!rc) *numel = ae.tab.numel;
    mf_spectab_free(&ae.tab);
    return rc;
}

void mf_ae_free(MfAe *ae) {
    if (!ae) return;
    mf_spectab_free(&ae->tab);
    free(ae->params), free(ae->grads), free(ae);
}

void mf_ae_init_weights(MfAe *ae, unsigned long long seed) {
    mf_seq_init(&ae->enc, ae->params, seed * 2 + 1);
    mf_seq_init(&ae->dec, ae->params, seed * 2 + 2);
}

float *mf_ae_encode(MfAe *ae, MfAeWork *w, const float *img, int B) {
    return mf_seq_forward(&ae->enc, ae->params, &w->enc, img, B);
}

void mf_ae_encode_backward(MfAe *ae, MfAeWork *w, const float *dz, float *dimg) {
    mf_seq_backward(&ae->enc, ae->params, ae->grads, &w->enc, dz, dimg);
}

void mf_ae_encode_backward_input(const MfAe *ae, MfAeWork *w, const float *dz, float *dimg) {
    mf_seq_backward(&ae->enc, ae->params, NULL, &w->enc, dz, dimg);
}

float *mf_ae_decode(MfAe *ae, MfAeWork *w, const float *z, int B) {
    return mf_seq_forward(&ae->dec, ae->params, &w->dec, z, B);
}

void mf_ae_decode_backward(MfAe *ae, MfAeWork *w, const float *dimg, float *dz) {
    mf_seq_backward(&ae->dec, ae->params, ae->grads, &w->dec, dimg, dz);
}

void mf_ae_work_free(MfAeWork *w) {
    mf_seq_work_free(&w->enc);
    mf_seq_work_free(&w->dec);
}
