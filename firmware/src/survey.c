/* survey.c - raw readings to attitude; contract in survey.h. */
#include "inclino/survey.h"
#include "inclino/fx_ops.h"

#define ACC_RANGE_Q6 ((int32_t)SURVEY_ACC_RANGE_COUNTS * CORR_IN_ONE)
#define MAG_RANGE_Q6 (SURVEY_MAG_RANGE_COUNTS * CORR_IN_ONE)
#define HALF_COUNT (CORR_IN_ONE / 2)

void survey_compute(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal, survey_t *s)
{
    int32_t x[3];
    uint16_t flags = 0u;
    uint8_t i;

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
    if (corr_triad(x, &cal->acc, s->g) != 0u) {
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
    if (corr_triad(x, &cal->mag, s->b) != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }

    att_compute(s->g, s->b, &s->att);
    s->att.flags = (uint16_t)(s->att.flags | flags);
}
