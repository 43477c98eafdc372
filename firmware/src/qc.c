/* qc.c - survey quality control; contracts in qc.h. */
#include "inclino/qc.h"
#include "inclino/fx_ops.h"

static uint8_t outside(int32_t v, int32_t ref, int32_t tol)
{
    uint8_t sat = 0u;
    int32_t d = fx_sub32_sat(v, ref, &sat);
    if (d < 0) {
        d = (d == FX_INT32_MIN) ? FX_INT32_MAX : -d;
    }
    return (uint8_t)(d > tol);
}

uint8_t qc_check(const att_t *a, const qc_ref_t *r)
{
    uint8_t f = 0u;
    if (outside(a->gt, r->gt_ref, r->gt_tol)) {
        f |= QC_F_GT;
    }
    if (outside(a->bt, r->bt_ref, r->bt_tol)) {
        f |= QC_F_BT;
    }
    if (outside(a->dip, r->dip_ref, r->dip_tol)) {
        f |= QC_F_DIP;
    }
    if ((a->flags & (ATT_F_ZERO_GRAVITY | ATT_F_ZERO_FIELD | ATT_F_ARITH_SATURATED)) != 0u) {
        f |= QC_F_UNDEFINED;
    }
    return f;
}

void qc_default(qc_ref_t *r, int32_t bt_ref, int32_t dip_ref)
{
    r->gt_ref = (int32_t)1L << 27;
    r->gt_tol = QC_GT_TOL_DEFAULT;
    r->bt_ref = bt_ref;
    r->bt_tol = QC_BT_TOL_DEFAULT;
    r->dip_ref = dip_ref;
    r->dip_tol = QC_DIP_TOL_DEFAULT;
}
