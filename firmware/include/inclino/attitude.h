/*
 * attitude.h - inclination, azimuth, toolfaces, G total, B total and dip from
 * corrected gravity and field vectors, integer only.
 *
 * Frames and formulas: docs/conventions.md.  Body frame: z along the tool
 * axis pointing down-hole; gravity reads +1 g on an axis pointing down.
 *   I   = atan2(sqrt(gx^2 + gy^2), gz)                        [0, 180]
 *   GTF = atan2(gy, -gx)                                      [0, 360)
 *   A   = atan2(|g| (gx by - gy bx),
 *               bz (gx^2 + gy^2) - gz (gx bx + gy by))        [0, 360)
 *   MTF = atan2(-by, bx)                                      [0, 360)
 *   dip = atan2(g.b, |g x b|)  (= asin(g.b / (|g||b|)))       [-90, 90]
 *         with |g x b|^2 = |g|^2 |b|^2 - (g.b)^2
 * Angles are Q16 degrees (degrees * 2^16).
 */
#ifndef INCLINO_ATTITUDE_H
#define INCLINO_ATTITUDE_H

#include <stdint.h>

/* Status flags (att_t.flags, survey output). */
#define ATT_F_NEAR_VERTICAL 0x0001u   /* I < 0.5 deg or I > 179.5 deg: A, GTF undefined */
#define ATT_F_ACC_OVERRANGE 0x0002u   /* an accelerometer raw count beyond +-1.7 g */
#define ATT_F_MAG_OVERRANGE 0x0004u   /* a fluxgate raw count beyond +-100 000 nT */
#define ATT_F_ACC_SATURATED 0x0008u   /* an accelerometer count at the int16 rail */
#define ATT_F_MAG_SATURATED 0x0010u   /* a fluxgate count clamped to +-2^20 (CORR_MAG_RAW_*) */
#define ATT_F_ARITH_SATURATED 0x0020u /* a saturating operation clipped */
#define ATT_F_ZERO_GRAVITY 0x0040u    /* corrected g is the zero vector: nothing is defined */
#define ATT_F_ZERO_FIELD 0x0080u      /* corrected b is the zero vector: A, MTF, dip undefined */

/* Near-vertical threshold: 0.5 degree in Q16 degrees. */
#define ATT_NEAR_VERTICAL_Q16 ((int32_t)32768L)

typedef struct {
    int32_t inc; /* inclination, Q16 degrees, [0, 180] */
    int32_t azi; /* azimuth, Q16 degrees, [0, 360) */
    int32_t gtf; /* gravity toolface, Q16 degrees, [0, 360) */
    int32_t mtf; /* magnetic toolface, Q16 degrees, [0, 360) */
    int32_t gt;  /* G total |g|, Q27 g */
    int32_t bt;  /* B total |b|, Q8 nT */
    int32_t dip; /* dip, Q16 degrees, [-90, 90] */
    uint16_t flags;
} att_t;

/*
 * att_norm3 - block normalisation: out = v * 2^s with the largest |out_i|
 *   in [2^29, 2^30]; returns s in [-2, 29] (0 and out = 0 for v = 0).
 *   Left shifts are exact; right shifts round half up (fx_asr32_rnd).
 */
int8_t att_norm3(const int32_t v[3], int32_t out[3]);

/*
 * att_compute - attitude from corrected vectors.
 *   In: g[3] Q27 g, b[3] Q8 nT (corr_triad outputs); any scale works for the
 *   angles, the formats matter only for gt and bt.
 *   Out: *a (see att_t).  Both vectors are block-normalised (att_norm3), so
 *   all products are fx_mul32_q31 of values below 2^31 and every
 *   intermediate fits 32 bits; magnitudes use fx_sqrt_u32_q8; angles
 *   fx_atan2_q16.
 *   Error bound against float64 on the same inputs (bench accuracy):
 *   angles within 0.001 degree for I >= 1 degree; gt, bt within 2e-6
 *   relative.
 *   Saturation: gt, bt saturate to FX_INT32_MAX (flag ATT_F_ARITH_SATURATED).
 */
void att_compute(const int32_t g[3], const int32_t b[3], att_t *a);

#endif /* INCLINO_ATTITUDE_H */
