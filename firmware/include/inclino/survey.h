/*
 * survey.h - one survey computation: raw sensor counts -> range checks ->
 * correction of both triads -> attitude.  This is the whole per-sample
 * computation of the probe (what `inclino bench mcu` times).
 */
#ifndef INCLINO_SURVEY_H
#define INCLINO_SURVEY_H

#include <stdint.h>

#include "inclino/attitude.h"
#include "inclino/correct.h"

/* ADIS16210: +-1.7 g at 2^-14 g per count -> 27853 counts. */
#define SURVEY_ACC_RANGE_COUNTS 27853
/* Fluxgate: +-100 000 nT at 1 nT per count. */
#define SURVEY_MAG_RANGE_COUNTS 100000L

typedef struct {
    int32_t g[3]; /* corrected gravity, Q27 g */
    int32_t b[3]; /* corrected field, Q8 nT */
    att_t att;    /* attitude; att.flags holds every survey flag */
} survey_t;

/*
 * survey_compute - raw counts to attitude.
 *   In: acc[3] ADIS16210 counts (int16, 2^-14 g); mag[3] fluxgate ADC counts
 *   (int32, signed 24-bit, 1 nT), values outside [-2^20, 2^20 - 1] are
 *   clamped and flagged ATT_F_MAG_SATURATED; cal the coefficients.
 *   Out: *s.  Flags: range (ATT_F_*_OVERRANGE, ATT_F_*_SATURATED),
 *   correction saturation (ATT_F_ARITH_SATURATED) and att_compute's own.
 */
void survey_compute(const int16_t acc[3], const int32_t mag[3], const corr_cal_t *cal,
                    survey_t *s);

#endif /* INCLINO_SURVEY_H */
