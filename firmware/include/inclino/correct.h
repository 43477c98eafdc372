/*
 * correct.h - sensor-error correction of one triad: corrected = M * (raw - b),
 * the 12-parameter model fitted by both Ren 2014 (eq. 8-11) and Li 2021
 * (inverse of eq. 3/4).
 *
 * Fixed-point formats (docs/fixed-point.md):
 *   accelerometer  raw: int16 ADIS16210 counts, 1 LSB = 2^-14 g
 *                  scaled input  x = raw * 2^15          (Q29 g)
 *                  bias b: int32 Q29 g
 *                  output: int32 Q27 g (1 g = 134217728)
 *   fluxgate       raw: signed 24-bit ADC counts, 1 LSB = 1 nT nominal,
 *                  clamped to [-2^20, 2^20 - 1] (ten times the sensor's
 *                  +-100 000 nT range)
 *                  scaled input  x = raw * 2^10          (Q10 nT)
 *                  bias b: int32 Q10 nT
 *                  output: int32 Q8 nT (1 nT = 256)
 *   M: int32 Q29, row-major, each element in [-4, 4).
 */
#ifndef INCLINO_CORRECT_H
#define INCLINO_CORRECT_H

#include <stdint.h>

#define CORR_ACC_IN_SHIFT 15u                       /* raw accel counts -> Q29 g */
#define CORR_MAG_IN_SHIFT 10u                       /* raw fluxgate counts -> Q10 nT */
#define CORR_M_ONE ((int32_t)1L << 29)              /* 1.0 in Q29 */
#define CORR_MAG_RAW_MAX ((int32_t)0xFFFFFL)        /* 2^20 - 1 */
#define CORR_MAG_RAW_MIN ((int32_t)(-0xFFFFFL - 1)) /* -2^20 */

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
 * corr_identity - fill c with M = I, b = 0 (the uncalibrated probe).
 */
void corr_identity(corr_triad_t *c);

#endif /* INCLINO_CORRECT_H */
