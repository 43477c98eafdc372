/*
 * acquire.h - acquisition and averaging of both triads and the temperature.
 *
 * One sample = one ADIS16210 burst (adis_read: X, Y, Z acceleration and
 * TEMP_OUT) followed by one settled ADS1256 conversion of each fluxgate
 * channel X, Y, Z (ads_read_channel, about 1.25 ms each).  Consecutive
 * ADIS16210 bursts are at least ACQ_ADIS_GAP_MS apart on the millisecond
 * tick (> 4 ms > one output period at AVG_CNT = 4, 3.765 ms), so each burst
 * reads a new output sample.  A sample takes about 5 ms; n samples about
 * 5 n ms.
 *
 * Averaging: integer sums (an int32 holds 64 x 2^23), then the mean of
 * each triad's axis with ACQ_FRAC_BITS = 6 fraction bits ("Q6 counts",
 * acq_avg_q6: floor(64 sum / n + 1/2)), so the resolution averaging buys
 * (1 count / sqrt(n) once the noise dithers the counts) reaches the
 * correction; for n = 1, 2, 4 ... 64 the Q6 mean is exact.  The
 * temperature's mean is kept the same way (temp_q6, 0.47/64 = 0.0073 degC
 * per LSB: what the temperature terms are evaluated at) and also rounded
 * to whole counts (temp_raw, acq_avg; 0.47 degC per count).
 * Status codes 0x30..0x3F; driver statuses (ADIS_E_*, ADS_E_*) pass through.
 */
#ifndef INCLINO_ACQUIRE_H
#define INCLINO_ACQUIRE_H

#include <stdint.h>

#define ACQ_N_MAX 64u      /* most samples averaged in one acquisition */
#define ACQ_FRAC_BITS 6u   /* fraction bits of the triads' means (= CORR_IN_FRAC_BITS) */
#define ACQ_ADIS_GAP_MS 5u /* tick difference between ADIS16210 bursts */
#define ACQ_GAP_POLL_US 250u
#define ACQ_GAP_POLLS 40u /* bound of the gap wait: 40 x 250 us = 10 ms */

#define ACQ_OK 0x00u
#define ACQ_E_ARG 0x31u /* n outside 1..ACQ_N_MAX */

typedef struct {
    int32_t acc[3];    /* mean ADIS16210 counts, Q6: 1 LSB = 2^-6 count = 2^-20 g */
    int32_t mag[3];    /* mean ADS1256 counts (signed 24-bit), Q6: 1 LSB = 2^-6 nT */
    uint16_t temp_raw; /* averaged TEMP_OUT (12 bit), rounded to whole counts */
    int32_t temp_q6;   /* averaged TEMP_OUT, Q6 counts (acq_avg_q6), 0.0073 degC per LSB */
    int32_t temp_cc;   /* temperature, 0.01 degC (adis_temp_centi_c of temp_raw) */
    uint8_t n;         /* samples averaged */
} acq_result_t;

/*
 * acq_avg - floor(sum / n + 1/2): the mean rounded half up.  In: sum with
 *   |sum| <= 2^30, n 1..255.  Exact (unsigned arithmetic, C99 division is
 *   never applied to a negative number).
 */
int32_t acq_avg(int32_t sum, uint8_t n);

/*
 * acq_avg_q6 - floor(64 sum / n + 1/2): the mean in Q6 counts, rounded half
 *   up.  In: sum with |sum| <= 2^30 and |sum| / n < 2^24 (the result fits
 *   int32: an int16 or 24-bit mean), n 1..255.  Exact: 64 sum / n is split
 *   into 64 (sum div n) + 64 (sum mod n) / n in unsigned arithmetic, so no
 *   intermediate exceeds 2^31 and no division sees a negative number.
 *   Error: |result / 64 - sum / n| <= 1/128 count; 0 when n divides 64 sum.
 */
int32_t acq_avg_q6(int32_t sum, uint8_t n);

/*
 * acq_run - average n samples (1..ACQ_N_MAX) of both triads and the
 *   temperature.  Out: *out, written only on ACQ_OK.  Returns ACQ_OK,
 *   ACQ_E_ARG, or the first driver error (ADIS_E_*, ADS_E_*), which ends
 *   the acquisition at once.
 */
uint8_t acq_run(uint8_t n, acq_result_t *out);

#endif /* INCLINO_ACQUIRE_H */
