/* survey.c - raw readings to attitude; contract in survey.h. */
#include "inclino/survey.h"
#include "inclino/fx_ops.h"

#define ACC_RANGE_Q6 ((int32_t)SURVEY_ACC_RANGE_COUNTS * CORR_IN_ONE)
#define MAG_RANGE_Q6 (SURVEY_MAG_RANGE_COUNTS * CORR_IN_ONE)
#define HALF_COUNT (CORR_IN_ONE / 2)

/* tt: the temperature terms of acc and mag at this survey's temperature,
 * or NULL (none applied: survey_compute's bits) */
static void survey_run(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal,
                       const corr_tt_t *tt, uint16_t flags, survey_t *s)
{
    int32_t x[3];
    uint8_t i;
    uint8_t sat;

    for (i = 0u; i < 3u; i++) {
        int32_t a = acc[i];
        if (a > ACC_RANGE_Q6 || a < -ACC_RANGE_Q6) {
            flags |= ATT_F_ACC_OVERRANGE;
        }
        /* the mean rounds to the int16 rail: every sample saturated */
        if (a >= CORR_ACC_RAW_MAX - HALF_COUNT || a < CORR_ACC_RAW_MIN + HALF_COUNT) {
            flags |= ATT_F_ACC_SATURATED;
        }
        if (a > CORR_ACC_RAW_MAX) {
            a = CORR_ACC_RAW_MAX;
        } else if (a < CORR_ACC_RAW_MIN) {
            a = CORR_ACC_RAW_MIN;
        }
        x[i] = corr_in_acc(a);
    }
    sat = (tt != 0) ? corr_triad_temp(x, &cal->acc, &tt[0], s->g) : corr_triad(x, &cal->acc, s->g);
    if (sat != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }

    for (i = 0u; i < 3u; i++) {
        int32_t m = mag[i];
        if (m > MAG_RANGE_Q6 || m < -MAG_RANGE_Q6) {
            flags |= ATT_F_MAG_OVERRANGE;
        }
        if (m >= CORR_MAG_RAW_MAX) {
            m = CORR_MAG_RAW_MAX;
            flags |= ATT_F_MAG_SATURATED;
        } else if (m <= CORR_MAG_RAW_MIN) {
            m = CORR_MAG_RAW_MIN;
            flags |= ATT_F_MAG_SATURATED;
        }
        x[i] = corr_in_mag(m);
    }
    sat = (tt != 0) ? corr_triad_temp(x, &cal->mag, &tt[1], s->b) : corr_triad(x, &cal->mag, s->b);
    if (sat != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }

    att_compute(s->g, s->b, &s->att);
    s->att.flags = (uint16_t)(s->att.flags | flags);
}

void survey_compute(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal, survey_t *s)
{
    survey_run(acc, mag, cal, 0, 0u, s);
}

void survey_compute_temp(const int32_t acc[3], const int32_t mag[3], int32_t temp_q6,
                         const corr_cal_t *cal, survey_t *s)
{
    corr_tt_t tt[2];
    uint8_t sat = 0u;
    int16_t dt;
    if (cal->t_order == 0u) {
        survey_run(acc, mag, cal, 0, 0u, s);
        return;
    }
    /* dT and its terms once per survey, for all six axes */
    dt = corr_temp_dt(temp_q6, cal->t_ref, &sat);
    corr_temp_eval(dt, &cal->acc, &cal->acc_tc, &tt[0], &sat);
    corr_temp_eval(dt, &cal->mag, &cal->mag_tc, &tt[1], &sat);
    survey_run(acc, mag, cal, tt, (sat != 0u) ? ATT_F_ARITH_SATURATED : 0u, s);
}
