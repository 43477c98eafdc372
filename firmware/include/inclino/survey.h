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

/*
 * survey_compute_temp - survey_compute with the calibration's temperature
 *   terms applied at the probe's temperature (what the probe runs).
 *   In: as survey_compute, and temp_q6 the TEMP_OUT mean in Q6 counts
 *   (acq_result_t.temp_q6, 0.47/64 degC per LSB).
 *   Method: when cal->t_order is 0 (an image without terms), exactly
 *   survey_compute.  Otherwise dT = corr_temp_dt(temp_q6, cal->t_ref) and
 *   the terms of both triads at dT (corr_temp_eval) once, then
 *   survey_compute's steps with corr_triad_temp in place of corr_triad.
 *   Error: corr_temp_dt's, corr_temp_eval's and corr_triad_temp's bounds
 *   (correct.h); the truncation of 1/(1 + s(T)) to second order is the
 *   host's, stated in CAL.json (docs/calibration.md).
 *   Flags: survey_compute's; ATT_F_ARITH_SATURATED also when dT or a term
 *   saturated.
 */
void survey_compute_temp(const int32_t acc[3], const int32_t mag[3], int32_t temp_q6,
                         const corr_cal_t *cal, survey_t *s);

#endif /* INCLINO_SURVEY_H */
