/*
 * qc.h - survey quality control: G total, B total and dip of a survey against
 * a stored reference with tolerances, as MWD surveys are checked (ISCWSA's
 * accepted window: B total within 300 nT, dip within 0.25 degree).
 */
#ifndef INCLINO_QC_H
#define INCLINO_QC_H

#include <stdint.h>

#include "inclino/attitude.h"

/* qc_check result bits; 0 means the survey passes. */
#define QC_F_GT 0x01u        /* |G total - reference| > tolerance */
#define QC_F_BT 0x02u        /* |B total - reference| > tolerance */
#define QC_F_DIP 0x04u       /* |dip - reference| > tolerance */
#define QC_F_UNDEFINED 0x08u /* zero gravity/field or saturation: not checkable */

/* Default tolerances. */
#define QC_GT_TOL_DEFAULT ((int32_t)335544L) /* 2.5 mg in Q27 g (0.0025 * 2^27) */
#define QC_BT_TOL_DEFAULT ((int32_t)76800L)  /* 300 nT in Q8 nT */
#define QC_DIP_TOL_DEFAULT ((int32_t)16384L) /* 0.25 degree in Q16 degrees */

typedef struct {
    int32_t gt_ref;  /* Q27 g */
    int32_t gt_tol;  /* Q27 g, >= 0 */
    int32_t bt_ref;  /* Q8 nT */
    int32_t bt_tol;  /* Q8 nT, >= 0 */
    int32_t dip_ref; /* Q16 degrees */
    int32_t dip_tol; /* Q16 degrees, >= 0 */
} qc_ref_t;

/*
 * qc_check - compare one survey with the reference.
 *   In: a attitude (att_compute output), r reference and tolerances.
 *   Out: QC_F_* bits, 0 = pass.  A difference exactly equal to the
 *   tolerance passes.  Differences saturate (fx_sub32_sat), so extreme
 *   values fail rather than wrap.  A survey flagged zero gravity, zero field
 *   or arithmetic saturation gets QC_F_UNDEFINED in addition to the checks.
 *   Exact integer comparisons: no rounding.
 */
uint8_t qc_check(const att_t *a, const qc_ref_t *r);

/*
 * qc_default - reference for field total bt_ref (Q8 nT) and dip dip_ref
 *   (Q16 degrees), G total 1 g, default tolerances.
 */
void qc_default(qc_ref_t *r, int32_t bt_ref, int32_t dip_ref);

#endif /* INCLINO_QC_H */
