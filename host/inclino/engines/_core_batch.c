/* _core_batch.c - host-only batched entry points over the firmware core, so
 * that a million vectors cost one call through cffi.  Not part of the probe
 * firmware; each loop body is one call of the firmware function it names. */
#include <stddef.h>
#include <stdint.h>

#include "inclino/attitude.h"
#include "inclino/correct.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"
#include "inclino/qc.h"
#include "inclino/survey.h"
#include "_core_batch.h"

void inc_batch_mul32_q31(const int32_t *a, const int32_t *b, int32_t *out, uint8_t *sat, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        sat[i] = 0u;
        out[i] = fx_mul32_q31(a[i], b[i], &sat[i]);
    }
}

void inc_batch_asr32_rnd(const int32_t *x, const uint8_t *sh, int32_t *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        out[i] = fx_asr32_rnd(x[i], sh[i]);
    }
}

void inc_batch_div_frac_q20(const uint32_t *num, const uint32_t *den, uint32_t *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        out[i] = fx_div_frac_q20(num[i], den[i]);
    }
}

void inc_batch_sqrt_u32_q8(const uint32_t *x, uint32_t *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        out[i] = fx_sqrt_u32_q8(x[i]);
    }
}

void inc_batch_atan2_q16(const int32_t *y, const int32_t *x, int32_t *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) {
        out[i] = fx_atan2_q16(y[i], x[i]);
    }
}

static void att_row(const att_t *a, int32_t *o)
{
    o[0] = a->inc;
    o[1] = a->azi;
    o[2] = a->gtf;
    o[3] = a->mtf;
    o[4] = a->gt;
    o[5] = a->bt;
    o[6] = a->dip;
    o[7] = (int32_t)a->flags;
}

void inc_batch_att(const int32_t *g, const int32_t *b, int32_t *out, size_t n)
{
    size_t i;
    att_t a;
    for (i = 0; i < n; i++) {
        att_compute(&g[3 * i], &b[3 * i], &a);
        att_row(&a, &out[INC_ATT_COLS * i]);
    }
}

void inc_batch_survey(const int32_t *acc, const int32_t *mag, const corr_cal_t *cal, size_t ncal,
                      int32_t *out, size_t n)
{
    size_t i, k;
    survey_t s;
    for (i = 0; i < n; i++) {
        int32_t *o = &out[INC_SURVEY_COLS * i];
        survey_compute(&acc[3 * i], &mag[3 * i], &cal[i % ncal], &s);
        for (k = 0; k < 3; k++) {
            o[k] = s.g[k];
            o[3 + k] = s.b[k];
        }
        att_row(&s.att, &o[6]);
    }
}

void inc_batch_survey_temp(const int32_t *acc, const int32_t *mag, const int32_t *temp_q6,
                           const corr_cal_t *cal, size_t ncal, int32_t *out, size_t n)
{
    size_t i, k;
    survey_t s;
    for (i = 0; i < n; i++) {
        int32_t *o = &out[INC_SURVEY_COLS * i];
        survey_compute_temp(&acc[3 * i], &mag[3 * i], temp_q6[i], &cal[i % ncal], &s);
        for (k = 0; k < 3; k++) {
            o[k] = s.g[k];
            o[3 + k] = s.b[k];
        }
        att_row(&s.att, &o[6]);
    }
}

void inc_batch_qc(const int32_t *att, const qc_ref_t *ref, uint8_t *out, size_t n)
{
    size_t i;
    att_t a;
    for (i = 0; i < n; i++) {
        const int32_t *r = &att[INC_ATT_COLS * i];
        a.inc = r[0];
        a.azi = r[1];
        a.gtf = r[2];
        a.mtf = r[3];
        a.gt = r[4];
        a.bt = r[5];
        a.dip = r[6];
        a.flags = (uint16_t)r[7];
        out[i] = qc_check(&a, ref);
    }
}
