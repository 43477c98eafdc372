/* survey.c - raw counts to attitude; contract in survey.h. */
#include "inclino/survey.h"
#include "inclino/fx_ops.h"

void survey_compute(const int16_t acc[3], const int32_t mag[3], const corr_cal_t *cal, survey_t *s)
{
    int32_t x[3];
    uint16_t flags = 0u;
    uint8_t i;

    for (i = 0u; i < 3u; i++) {
        int16_t a = acc[i];
        if (a > SURVEY_ACC_RANGE_COUNTS || a < -SURVEY_ACC_RANGE_COUNTS) {
            flags |= ATT_F_ACC_OVERRANGE;
        }
        if (a == INT16_MAX || a == INT16_MIN) {
            flags |= ATT_F_ACC_SATURATED;
        }
        x[i] = (int32_t)a * (int32_t)((uint32_t)1u << CORR_ACC_IN_SHIFT);
    }
    if (corr_triad(x, &cal->acc, s->g) != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }

    for (i = 0u; i < 3u; i++) {
        int32_t m = mag[i];
        if (m > SURVEY_MAG_RANGE_COUNTS || m < -SURVEY_MAG_RANGE_COUNTS) {
            flags |= ATT_F_MAG_OVERRANGE;
        }
        if (m >= CORR_MAG_RAW_MAX) {
            m = CORR_MAG_RAW_MAX;
            flags |= ATT_F_MAG_SATURATED;
        } else if (m <= CORR_MAG_RAW_MIN) {
            m = CORR_MAG_RAW_MIN;
            flags |= ATT_F_MAG_SATURATED;
        }
        x[i] = m * (int32_t)((uint32_t)1u << CORR_MAG_IN_SHIFT);
    }
    if (corr_triad(x, &cal->mag, s->b) != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }

    att_compute(s->g, s->b, &s->att);
    s->att.flags = (uint16_t)(s->att.flags | flags);
}
