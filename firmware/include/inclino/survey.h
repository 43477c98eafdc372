/*
 * survey.h - one survey computation: averaged raw readings -> range checks ->
 * correction of both triads -> attitude.  This is the whole per-sample
 * computation of the probe (what `inclino bench mcu` times).
 */
#ifndef INCLINO_SURVEY_H
#define INCLINO_SURVEY_H

#include <stdint.h>

#include "inclino/attitude.h"
#include "inclino/correct.h"

/* ADIS16210: +-1.7 g at 2^-14 g per count -> 27853 counts (x 64 in Q6). */
#define SURVEY_ACC_RANGE_COUNTS 27853
/* Fluxgate: +-100 000 nT at 1 nT per count. */
#define SURVEY_MAG_RANGE_COUNTS 100000L

typedef struct {
    int32_t g[3]; /* corrected gravity, Q27 g */
    int32_t b[3]; /* corrected field, Q8 nT */
    att_t att;    /* attitude; att.flags holds every survey flag */
} survey_t;

/*
 * survey_compute - averaged raw readings to attitude.
 *   In: acc[3] ADIS16210 readings in Q6 counts (int32, 2^-20 g: the
 *   acquisition's mean with 6 fraction bits, acq_avg_q6), clamped to the
 *   int16 range [-32768, 32767] counts; mag[3] fluxgate ADC readings in Q6
 *   counts (int32, 2^-6 nT), clamped to [-2^20, 2^20 - 1] counts; cal the
 *   coefficients.  Whole counts c are passed as c * 64 (CORR_IN_ONE) and
 *   give exactly the results of the former whole-count interface.
 *   Out: *s.  Flags: ATT_F_ACC_OVERRANGE when |acc| > 27853 counts,
 *   ATT_F_MAG_OVERRANGE when |mag| > 100 000 counts; ATT_F_ACC_SATURATED
 *   when an accelerometer mean is within half a count of the int16 rail
 *   (it rounds to the rail: every sample saturated); ATT_F_MAG_SATURATED
 *   when a fluxgate reading was clamped; correction saturation
 *   (ATT_F_ARITH_SATURATED) and att_compute's own.
 */
void survey_compute(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal,
                    survey_t *s);

#endif /* INCLINO_SURVEY_H */
