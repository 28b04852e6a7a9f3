/* Tests of eval/ev_prior2d: the prior's per-channel trust (ev_prior2d_trust). */
#include "core/mf_error.h"
#include "eval/ev_prior2d.h"
#include "mf_test.h"

static void add2(EvTable *t, int m, const char *scene, double rough, double metal) {
    CHECK_OK(ev_table_add(t, ev_prior2d_methods[m], "test-2d", scene, "rough_mse", rough));
    CHECK_OK(ev_table_add(t, ev_prior2d_methods[m], "test-2d", scene, "metal_mse", metal));
}

/* trust = 1 - mean MSE of the method / mean MSE of the training-mean constant, clamped to [0, 1]:
 * a prior that removes 3/4 of the constant's roughness error gets 0.75; one worse than the
 * constant on metallic gets 0; no records give 0. */
MF_TEST(eval_prior2d_trust) {
    EvTable t;
    ev_table_init(&t);
    add2(&t, EV_P2_MEAN_ORM, "000000", 0.04, 0.10);
    add2(&t, EV_P2_MEAN_ORM, "000001", 0.08, 0.30);
    add2(&t, EV_P2_SM, "000000", 0.01, 0.30);
    add2(&t, EV_P2_SM, "000001", 0.02, 0.20);
    double tr[2] = {-1, -1}, none[2] = {-1, -1};
    ev_prior2d_trust(&t, "test-2d", EV_P2_SM, tr);
    CHECK_NEAR(tr[0], 0.75, 1e-12);
    CHECK(tr[1] == 0.0);
    ev_prior2d_trust(&t, "test-2d", EV_P2_MV, none);
    CHECK(none[0] == 0.0 && none[1] == 0.0);
    ev_table_free(&t);
}
