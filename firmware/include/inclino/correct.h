/*
 * correct.h - sensor-error correction of one triad: corrected = M * (raw - b),
 * the 12-parameter model fitted by both Ren 2014 (eq. 8-11) and Li 2021
 * (inverse of eq. 3/4).
 *
 * Fixed-point formats (docs/fixed-point.md):
 *   Raw readings are the acquisition's averages with CORR_IN_FRAC_BITS = 6
 *   fraction bits ("Q6 counts", acq_avg_q6): the mean of n samples keeps
 *   what averaging bought (exact for n = 1, 2, 4 ... 64; otherwise rounded
 *   to 1/64 count, an error below 0.008 counts RMS).  Whole counts are the
 *   special case raw_q6 = counts * 64 and give the same bits as before.
 *   accelerometer  raw: int32 Q6 ADIS16210 counts, 1 LSB = 2^-20 g, within
 *                  [-2^21, 2^21 - 64] (int16 counts * 64; survey_compute clamps)
 *                  scaled input  x = corr_in_acc(raw) = raw * 2^9   (Q29 g)
 *                  bias b: int32 Q29 g
 *                  output: int32 Q27 g (1 g = 134217728)
 *   fluxgate       raw: int32 Q6 ADC counts, 1 LSB = 2^-6 nT nominal,
 *                  clamped to [-2^26, (2^20 - 1) * 2^6] (+-2^20 counts, ten
 *                  times the sensor's +-100 000 nT range)
 *                  scaled input  x = corr_in_mag(raw) = raw * 2^4   (Q10 nT)
 *                  bias b: int32 Q10 nT
 *                  output: int32 Q8 nT (1 nT = 256)
 *   M: int32 Q29, row-major, each element in [-4, 4).
 * The input scaling (corr_in_acc, corr_in_mag) is the one place where a raw
 * reading becomes the correction's input: a reading-dependent term (e.g. a
 * temperature correction of the raw reading) belongs there.
 */
#ifndef INCLINO_CORRECT_H
#define INCLINO_CORRECT_H

#include <stdint.h>

#define CORR_IN_FRAC_BITS 6u                           /* raw readings: Q6 counts */
#define CORR_IN_ONE ((int32_t)1L << CORR_IN_FRAC_BITS) /* one count in Q6 */
#define CORR_ACC_IN_SHIFT 9u                           /* Q6 accel counts (2^-20 g) -> Q29 g */
#define CORR_MAG_IN_SHIFT 4u                           /* Q6 fluxgate counts (2^-6 nT) -> Q10 nT */
#define CORR_M_ONE ((int32_t)1L << 29)                 /* 1.0 in Q29 */
#define CORR_ACC_RAW_MAX ((int32_t)0x7FFFL * CORR_IN_ONE)         /* INT16_MAX counts, Q6 */
#define CORR_ACC_RAW_MIN ((int32_t)(-0x7FFFL - 1) * CORR_IN_ONE)  /* INT16_MIN counts, Q6 */
#define CORR_MAG_RAW_MAX ((int32_t)0xFFFFFL * CORR_IN_ONE)        /* (2^20 - 1) counts, Q6 */
#define CORR_MAG_RAW_MIN ((int32_t)(-0xFFFFFL - 1) * CORR_IN_ONE) /* -2^20 counts, Q6 */

/* One triad's coefficients. */
typedef struct {
    int32_t m[9];    /* Q29, row-major */
    int32_t bias[3]; /* Q29 g (accelerometer) or Q10 nT (fluxgate) */
} corr_triad_t;

/* Both triads: what the probe keeps in flash. */
typedef struct {
    corr_triad_t acc;
    corr_triad_t mag;
} corr_cal_t;

/*
 * corr_triad - out = M * (x - b) for one triad.
 *   In: x[3] scaled raw input (see formats above), c coefficients.
 *   Out: out[3] in Q(qx - 2): Q27 g for the accelerometer, Q8 nT for the
 *   fluxgate.
 *   Method: d_j = sat(x_j - b_j); out_i = fx_dot3_q31(row i of M, d) =
 *   sat(sat(p_i0 + p_i1) + p_i2) with p_ij = fx_mul32_q31(m_ij, d_j).
 *   Rounding: truncation inside fx_mul32_q31; error bound per output
 *   -24 < out - exact < 6 LSB (three products, see fx_mul32_q31).
 *   Saturation: each subtraction, product and sum saturates to int32;
 *   returns 1 when any step saturated, else 0.
 */
uint8_t corr_triad(const int32_t x[3], const corr_triad_t *c, int32_t out[3]);

/*
 * corr_in_acc - one accelerometer reading to the correction's input.
 *   In: raw Q6 counts within [CORR_ACC_RAW_MIN, CORR_ACC_RAW_MAX].
 *   Out: raw * 2^CORR_ACC_IN_SHIFT, Q29 g, |x| <= 2^30.  Exact (no rounding,
 *   cannot saturate inside the stated input range).
 */
int32_t corr_in_acc(int32_t raw_q6);

/*
 * corr_in_mag - one fluxgate reading to the correction's input.
 *   In: raw Q6 counts within [CORR_MAG_RAW_MIN, CORR_MAG_RAW_MAX].
 *   Out: raw * 2^CORR_MAG_IN_SHIFT, Q10 nT, |x| <= 2^30.  Exact.
 */
int32_t corr_in_mag(int32_t raw_q6);

/*
 * corr_identity - fill c with M = I, b = 0 (the uncalibrated probe).
 */
void corr_identity(corr_triad_t *c);

#endif /* INCLINO_CORRECT_H */
