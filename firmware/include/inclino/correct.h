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
 * reading becomes the correction's input.  The temperature terms (below)
 * act on d = x - b, right after that scaling and the bias subtraction:
 * the model brings the raw reading to the reference temperature about the
 * bias, raw_ref = b + (raw - b - bias(T)) / (1 + s(T)), and corr_triad then
 * subtracts b again, so raw_ref - b = (d - bias(T)) r(T) is applied to d
 * directly (no add and subtract of b, no extra saturation).
 *
 * Temperature terms (calibration image version 2, docs/calibration.md), per
 * axis i of each triad, in dT = T - t_ref:
 *   bias(T) = dT (c1_i + c2_i dT)         added to b (b_eff = b + bias(T))
 *   r(T)    = 1 + dT (r1_i + r2_i dT)     multiplies x - b_eff: the host's
 *             expansion of 1 / (1 + s(T)) to second order in dT (no
 *             division here)
 *   formats  dT      int16 Q7 degC (|dT| <= 255.99 degC), from the averaged
 *                    TEMP_OUT reading (corr_temp_dt)
 *            c1      int32, |c1| <= 2^30: Q38 g/degC (acc, +-3.9 mg/degC,
 *                    LSB 3.6e-12), Q19 nT/degC (mag, +-2048 nT/degC, LSB
 *                    1.9e-6)
 *            c2      int16: Q31 g/degC^2 (acc, +-15 ug/degC^2, LSB 4.7e-10),
 *                    Q12 nT/degC^2 (mag, +-8 nT/degC^2, LSB 2.4e-4)
 *            r1      int32, |r1| <= 2^30: Q38 /degC (+-3906 ppm/degC, LSB
 *                    3.6e-6 ppm/degC)
 *            r2      int16 Q31 /degC^2 (+-15 ppm/degC^2, LSB 4.7e-4 ppm/degC^2)
 *   Inner sums (Horner): c1 + c2 dT, the 16 x 16 product c2 dT already in
 *   c1's format (Q31 + Q7 = Q38, Q12 + Q7 = Q19); then one product by dT
 *   (fx_mul32_q31 with dT 2^15, Q22): Q38 x Q22 / 2^31 = Q29 g, Q19 x Q22
 *   / 2^31 = Q10 nT, and e = r(T) - 1 in Q29, |e| < 1.
 *   The second-order coefficients' LSB times dT^2 bounds their quantisation
 *   (half an LSB): at |dT| = 30 degC 0.2 ug, 0.11 nT, 0.2 ppm; at 100 degC
 *   2.3 ug, 1.2 nT, 2.3 ppm.
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

/* One triad's temperature terms (formats above; all 0 without terms). */
typedef struct {
    int32_t c1[3]; /* bias, 1st order: Q38 g/degC (acc), Q19 nT/degC (mag); |c1| <= 2^30 */
    int16_t c2[3]; /* bias, 2nd order: Q31 g/degC^2 (acc), Q12 nT/degC^2 (mag) */
    int32_t r1[3]; /* 1/(1 + s(T)) - 1, 1st order: Q38 /degC; |r1| <= 2^30 */
    int16_t r2[3]; /* 1/(1 + s(T)) - 1, 2nd order: Q31 /degC^2 */
} corr_tc_t;

/* Both triads: what the probe keeps in flash. */
typedef struct {
    corr_triad_t acc;
    corr_triad_t mag;
    corr_tc_t acc_tc;
    corr_tc_t mag_tc;
    int16_t t_ref;   /* reference temperature, Q7 degC */
    uint8_t t_order; /* 0: no temperature terms (image version 1), else 1 or 2 */
} corr_cal_t;

/* One triad's temperature terms evaluated at one temperature (per survey). */
typedef struct {
    int32_t beff[3]; /* b + bias(T), the triad's input format (Q29 g / Q10 nT) */
    int32_t e[3];    /* r(T) - 1, Q29 */
} corr_tt_t;

#define CORR_TEMP_RAW_ZERO 1331L /* TEMP_OUT count at 0 degC (adis16210.h) */
#define CORR_TEMP_K 30802        /* 0.47 degC/count, Q6 counts -> Q7 degC: 0.94 in Q15 */
#define CORR_TC_LIMIT ((int32_t)0x40000000L) /* |c1|, |r1| <= 2^30 (calimg_parse) */
#define CORR_E_MAX ((int32_t)0x1FFFFF00L)    /* |r(T) - 1| <= 1 - 2^-21 in Q29: |4 p| < 2^31 */

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

/*
 * corr_tc_clear - all temperature terms of one triad to 0.
 */
void corr_tc_clear(corr_tc_t *tc);

/*
 * corr_temp_dt - the averaged temperature reading to dT = T - t_ref.
 *   In: temp_q6 the TEMP_OUT mean in Q6 counts (acq_avg_q6 of the 12-bit
 *   readings, 0.47/64 = 0.0073 degC per LSB), t_ref Q7 degC.
 *   Out: dT int16 Q7 degC (1/128 degC per LSB).
 *   Method: u = clamp(1331 * 64 - temp_q6, +-32767) (Q6 counts below the
 *   0 degC count; |u| <= 32767 is -240..+240 degC, beyond the part's
 *   -40..125 degC), T = fx_asr32_rnd(fx_mul16(u, 30802), 15) (Q7 degC: x
 *   0.94 = 0.47 x 128 / 64; a 16 x 16 product), dT = clamp(T - t_ref,
 *   +-32767).
 *   Rounding: round half up; |T - exact| <= 1/2 LSB + |T| x 2.6e-6 (30802 /
 *   2^15 = 0.9400024 for 0.94): <= 0.0043 degC below 125 degC.
 *   Saturation: either clamp sets *sat to 1 (never within -40..125 degC
 *   and |t_ref| <= 125 degC).
 */
int16_t corr_temp_dt(int32_t temp_q6, int16_t t_ref, uint8_t *sat);

/*
 * corr_temp_eval - one triad's terms at dT, once per survey.
 *   In: dT Q7 degC, c the triad's M and b, tc its terms (formats above,
 *   |c1|, |r1| <= 2^30 as calimg_parse checks).
 *   Out: tt->beff[i] = sat(b_i + dT (c1 + c2 dT)) in the triad's input
 *   format (Q29 g or Q10 nT); tt->e[i] = dT (r1 + r2 dT) in Q29 (r(T) - 1),
 *   clamped to |e| <= CORR_E_MAX (1 - 2^-21).
 *   Method (Horner, per value): inner = c1 + fx_mul16(c2, dT) (|c2 dT| <
 *   2^30 and |c1| <= 2^30: a plain sum), value = fx_mul32_q31(inner,
 *   dT 2^15) (inner x dT / 2^16; |dT 2^15| < 2^30: no saturation,
 *   |value| < 2^30).
 *   Rounding: fx_mul32_q31's truncation only: -8 < value - exact < 2 LSB
 *   of the output (2^-29 g, 2^-10 nT, 2^-29) for the terms as stored.
 *   Saturation: b + bias(T) (|b| < 2^30, |bias| <= 2^30) and the clamp of
 *   e (|e| >= 1: a scale change of 100 %); each sets *sat to 1.
 */
void corr_temp_eval(int16_t dt, const corr_triad_t *c, const corr_tc_t *tc, corr_tt_t *tt,
                    uint8_t *sat);

/*
 * corr_triad_temp - out = M * (r(T) (x - b - bias(T))) for one triad: the
 *   reading brought to t_ref (raw_ref - b) and corrected.
 *   In: x[3] scaled raw input, c coefficients (M), tt the terms at this
 *   survey's temperature (corr_temp_eval: b_eff and e, |e| <= CORR_E_MAX).
 *   Out: out[3] as corr_triad.
 *   Method: v_j = sat(x_j - beff_j); p_j = fx_mul32_q31(v_j, e_j) (Q(v) - 2;
 *   |p_j| <= 2^29 - 256 + 8 < 2^29, its error being below 8 LSB); d_j =
 *   sat(v_j + 4 p_j) = v_j (1 + e_j); then out as corr_triad.
 *   Rounding: the scale product truncates: -32 < d - v (1 + e) < 8 LSB of
 *   d (Q29 g / Q10 nT) before M; then corr_triad's bound.
 *   Saturation: each step saturates to int32; returns 1 when any did.
 */
uint8_t corr_triad_temp(const int32_t x[3], const corr_triad_t *c, const corr_tt_t *tt,
                        int32_t out[3]);

#endif /* INCLINO_CORRECT_H */
